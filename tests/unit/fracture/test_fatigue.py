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


def test_block_cycles_do_not_overshoot_a_sharp_minimum_of_the_rate():
    """The lead K_V of the scanned-L4 run to the break around its minimum (kPa√m: the front
    enters the compressed half, then the faces close in shear), rates K^4.4, blocks of
    4 mm.  The cubic through the four ends around the minimum dips below it (that block's
    cycles 1.7 times the line's, as counted while the run goes, with the ends known so
    far).  Every block, counted with all ends or with the ends known so far, stays between
    its length over its larger and over its smaller end rate; the block after the minimum
    is the line's Δs (1/r₀ − 1/r₁)/ln(r₁/r₀) (exact for an exponential rate)."""
    k = np.array([102.0, 85.1, 53.8, 80.9, 112.1, 130.2]) * 1e3
    r = C * k**4.4
    h = 4e-3
    s = h * np.arange(len(k))
    lo, hi = h / np.maximum(r[:-1], r[1:]), h / np.minimum(r[:-1], r[1:])
    every = block_cycles(s, r)
    so_far = np.array([block_cycles(s[: j + 2], r[: j + 2])[-1] for j in range(len(k) - 1)])
    for n in (every, so_far):
        assert np.all(n >= lo) and np.all(n <= hi)
    line = h * (1 / r[2] - 1 / r[3]) / math.log(r[3] / r[2])
    assert so_far[2] == pytest.approx(line, rel=1e-12)
    log_r = np.log(r[:4])  # what the unguarded cubic through those four ends gives
    cubic = np.polyfit(s[:4] - s[2], log_r, 3)
    x = 0.5 * h * (1.0 + np.polynomial.legendre.leggauss(8)[0])
    w = np.polynomial.legendre.leggauss(8)[1]
    unguarded = 0.5 * h * np.sum(w * np.exp(-np.polyval(cubic, x)))
    assert unguarded > 1.5 * line and unguarded <= hi[2]


def test_block_cycles_are_exact_for_an_exponential_rate():
    """ln r linear in s through every end (r = r₀ 4^(s/Δs)): every block is exact."""
    h = 4e-3
    s = h * np.arange(5)
    r = 1e-8 * 4.0 ** np.arange(5)
    exact = h * (1 / r[:-1] - 1 / r[1:]) / np.log(4.0)
    np.testing.assert_allclose(block_cycles(s, r), exact, rtol=1e-12)


def test_block_cycles_keep_the_cubic_on_smooth_rates():
    """A smooth monotone rate r = C (σ√(πa))^m with a from 10 to 20 mm in 5 blocks: the
    cubic rule stays in place (no block falls back to the line) and gives the closed form
    of Paris' law, N = ∫ da / (C (σ√(πa))^m), within 1e-4."""
    m, sig = 4.0, 1.0e6
    a = np.linspace(0.01, 0.02, 6)
    r = C * (sig * np.sqrt(np.pi * a)) ** m
    exact = (1 / a[0] - 1 / a[-1]) / (C * sig**m * np.pi**2)  # m = 4: ∫ a⁻² da / (C σ⁴ π²)
    assert block_cycles(a, r).sum() == pytest.approx(exact, rel=1e-4)
