"""The Paris law and its block integration against closed forms, with no finite elements
(docs/theory/fracture.md#fatigue).

* A rate that varies exponentially with the growth (K = K0 exp(λs)): the block rule is
  exact, N = (1 − exp(−mλS)) / (C ΔK0^m mλ), asserted to 1e-9 for any block size.
* Griffith's crack in an infinite plate (K = σ√(πa)): N = (a0^(1−m/2) − a1^(1−m/2)) /
  (C (Δσ√π)^m (m/2 − 1)); the rule converges (order ≥ 2.5 from 32 to 64 blocks) and is
  within 1e-6 at Δa = (a1 − a0)/64.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

import numpy as np
import pytest

from bonecontact.fracture.crack import FractureError
from bonecontact.fracture.fatigue import ParisLaw, block_cycles, grow_by_fatigue

C = 1.0e-30  # (m/cycle)/(Pa√m)^m: any positive value scales N only
SIGMA = 1.0e6


class AnalyticBody:
    """Tips whose K depends on their own growth only: K_i = k_of(a0_i + s_i)."""

    def __init__(self, a0, k_of):
        self.a = np.asarray(a0, dtype=float)
        self.k_of = k_of

    def k_max(self):
        return self.k_of(self.a)

    def grow(self, advances):
        self.a = self.a + advances


@pytest.mark.parametrize("m", [2.5, 3.0, 4.0])
@pytest.mark.parametrize("R", [0.0, 0.1, -0.5])
@pytest.mark.parametrize("da", [0.05, 0.13, 0.5])
def test_exponential_rate_is_integrated_exactly(m, R, da):
    lam, k0, total = 2.0, 1.0e6, 0.5
    law = ParisLaw(C, m, R=R)
    res = grow_by_fatigue(AnalyticBody([0.0], lambda a: k0 * np.exp(lam * a)), law, da, total)
    dk0 = (1 - R) * k0 if R >= 0 else k0
    ref = (1 - math.exp(-m * lam * total)) / (C * dk0**m * m * lam)
    assert res.status == "grown"
    assert res.growth[-1] == pytest.approx(total, rel=1e-12)
    assert res.cycles[-1] == pytest.approx(ref, rel=1e-9)


def griffith_cycles(a0, a1, law):
    dsig = float(law.delta_k(SIGMA))
    p = 1 - law.m / 2
    if abs(p) < 1e-12:
        return math.log(a1 / a0) / (law.C * (dsig * math.sqrt(math.pi)) ** law.m)
    return (a1**p - a0**p) / (p * law.C * (dsig * math.sqrt(math.pi)) ** law.m)


@pytest.mark.parametrize("m", [2.0, 3.0, 4.0])
@pytest.mark.parametrize("R", [0.0, 0.1])
def test_griffith_crack_converges_to_the_closed_form(m, R):
    a0, a1 = 0.01, 0.03
    law = ParisLaw(C, m, R=R)
    ref = griffith_cycles(a0, a1, law)

    def k_of(a):
        return SIGMA * np.sqrt(np.pi * a)

    errs = []
    for n in (8, 32, 64):
        res = grow_by_fatigue(AnalyticBody([a0, a0], k_of), law, (a1 - a0) / n, a1 - a0)
        assert len(res.growth) == n + 1
        errs.append(abs(res.cycles[-1] / ref - 1))
    assert errs[0] < 1e-3
    assert errs[2] < 1e-6
    assert math.log2(errs[1] / errs[2]) > 2.5


def test_unequal_tips_count_the_cycles_of_the_leading_tip():
    """Tip 1 sees twice the K of tip 0: it leads, grows da_max per block, tip 0 grows
    2^-m as much; the cycles are those of the leading tip's own K(a)."""
    m, a0, a1 = 3.0, 0.01, 0.02
    law = ParisLaw(C, m)
    factor = np.array([1.0, 2.0])

    def k_of(a):
        return factor * SIGMA * np.sqrt(np.pi * a)

    body = AnalyticBody([a0, a0], k_of)
    res = grow_by_fatigue(body, law, (a1 - a0) / 64, a1 - a0)
    ref = griffith_cycles(a0, a1, law) / 2**m
    assert res.cycles[-1] == pytest.approx(ref, rel=1e-6)
    assert body.a[1] == pytest.approx(a1, rel=1e-12)
    assert body.a[0] < a0 + (a1 - a0) / 2**m * 1.01


def test_threshold_arrests_and_load_ratio_conventions():
    law = ParisLaw(1e-20, 3.0, delta_K_th=1.0e6, R=0.2)
    assert law.delta_k(2.0e6) == pytest.approx(1.6e6)
    assert law.rate(1.2e6) == 0.0  # ΔK = 0.96 MPa√m below the threshold
    assert law.rate(2.0e6) == pytest.approx(1e-20 * 1.6e6**3)
    assert ParisLaw(1e-20, 3.0, R=-1.0).delta_k(2.0e6) == pytest.approx(2.0e6)
    assert ParisLaw(1e-20, 3.0).rate(-1.0e6) == 0.0
    res = grow_by_fatigue(AnalyticBody([0.01], lambda a: 0 * a + 1.2e6), law, 1e-3, 1e-2)
    assert res.status == "arrested"
    assert res.cycles[-1] == 0.0


def test_max_blocks_stops_the_run():
    law = ParisLaw(C, 3.0)
    res = grow_by_fatigue(
        AnalyticBody([0.01], lambda a: SIGMA * np.sqrt(np.pi * a)), law, 1e-3, 1e-2, max_blocks=3
    )
    assert res.status == "max_blocks"
    assert len(res.growth) == 4


@pytest.mark.parametrize(
    "kwargs, key",
    [
        ({"C": 0.0, "m": 3.0}, "C"),
        ({"C": 1e-30, "m": -1.0}, "m"),
        ({"C": 1e-30, "m": 3.0, "delta_K_th": -1.0}, "delta_K_th"),
        ({"C": 1e-30, "m": 3.0, "R": 1.0}, "R"),
        ({"C": 1e-30, "m": float("nan")}, "m"),
    ],
)
def test_bad_paris_constants_name_their_key(kwargs, key):
    with pytest.raises(FractureError, match=key):
        ParisLaw(**kwargs)


def test_bad_growth_arguments_name_their_key():
    body = AnalyticBody([0.01], lambda a: SIGMA * np.sqrt(np.pi * a))
    with pytest.raises(FractureError, match="da_max"):
        grow_by_fatigue(body, ParisLaw(C, 3.0), 0.0, 1e-2)
    with pytest.raises(FractureError, match="max_blocks"):
        grow_by_fatigue(body, ParisLaw(C, 3.0), 1e-3, 1e-2, max_blocks=0)
    with pytest.raises(FractureError, match="rate"):
        block_cycles([0.0, 1.0], [1.0, 0.0])
