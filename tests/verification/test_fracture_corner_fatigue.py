"""Newman and Raju's corner crack grown by fatigue: the reference of the corner-crack
scenes (bonecontact.verification.corner_fatigue; docs/theory/fracture.md#corner-cracks-in-
a-scenes-body).  No finite elements: Newman and Raju's K throughout.

The plate of tests/unit/runners/test_corner_crack_scene3d.py (t = 1 mm, width 5 mm,
S = 1 MPa), a corner crack a = 0.2, c = 0.4 mm, da/dN = C ΔK^m (R = 0), the K points of
the runner's growth for a front of 0.02 mm (a₀/10).

* The K points: a quarter circle of radius r has its points 2.5 h/r from the faces
  (exactly: the arc length is r ψ), else 10°; for a/c = 0.5 the margin comes from the
  end of the face of c, where the front is tighter (√(c² sin²ψ + a² cos²ψ) → a).
* RK4 in a (:func:`newman_raju_corner_growth`) converges: 400 and 800 steps agree to
  1e-9 (cycles and c).
* The runner's block rule with Newman and Raju's K (:func:`corner_block_growth`) against
  that integration, a from 0.2 to 0.36 mm (the scene test's four blocks): at
  Δa_max = 0.04 mm the cycles within 0.9 % (measured m = 3: +0.49 … +0.76 %, m = 2:
  +0.27 … +0.39 %), c within 1.2 % (m = 3: down to −0.99 %, m = 2: −0.72 %); halving
  Δa_max halves the errors (first order: each block grows at its starting rates).  The
  scene test takes 0.8 % as the blocks' share of its cycle error.
* Bad input: a/c > 1 (outside the implemented equation) and a non-positive Δa_max are
  refused naming the key.
"""

import math

import numpy as np
import pytest

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.fatigue import ParisLaw
from bonecontact.verification.corner_fatigue import (
    CornerPlate,
    corner_block_growth,
    corner_growth_angles,
    corner_rates,
    newman_raju_corner_growth,
)
from bonecontact.verification.surface_crack import corner_crack_k

L = 1e-3
PLATE = CornerPlate(1.0e6, 1.0 * L, 5.0 * L)
A0, C0, H = 0.2 * L, 0.4 * L, 0.02 * L


def _angles(a: float, c: float) -> tuple[float, float]:
    return corner_growth_angles(a, c, H)


def test_k_points_of_the_runner() -> None:
    # a quarter circle: arc length r ψ, so the margin is 2.5 h / r
    psi_c, psi_a = corner_growth_angles(A0, A0, H)
    assert psi_c == pytest.approx(2.5 * H / A0, rel=1e-6)
    assert psi_a == pytest.approx(0.5 * math.pi - 2.5 * H / A0, rel=1e-6)
    # a large crack: the least angle, 10°
    assert corner_growth_angles(0.5 * L, 0.6 * L, H) == pytest.approx(
        (math.radians(10.0), math.radians(80.0)), rel=1e-12
    )
    # a/c = 0.5: the tighter end (ψ = 0, speed a) sets the margin, a little below 2.5h/a
    psi_c, _ = corner_growth_angles(A0, C0, H)
    assert math.radians(10.0) < psi_c < 2.5 * H / A0
    assert math.degrees(psi_c) == pytest.approx(13.93, abs=0.01)  # the scene's 13.927°


def test_rates_are_the_paris_rates_of_newman_raju() -> None:
    law = ParisLaw(C=1e-20, m=3.0)
    r = corner_rates(law, PLATE, A0, C0, (0.2, 1.3))
    k = corner_crack_k(1.0e6, A0, C0, L, 5 * L, np.array([0.2, 1.3]))
    np.testing.assert_allclose(r, 1e-20 * k**3, rtol=1e-14)


def test_rk4_converges() -> None:
    law = ParisLaw(C=1e-20, m=3.0)
    a1, c1, n1 = newman_raju_corner_growth(law, PLATE, A0, C0, 0.36 * L, _angles, 400)
    a2, c2, n2 = newman_raju_corner_growth(law, PLATE, A0, C0, 0.36 * L, _angles, 800)
    assert a1[-1] == a2[-1] == pytest.approx(0.36 * L)
    assert n2[-1] == pytest.approx(n1[-1], rel=1e-7)
    assert c2[-1] == pytest.approx(c1[-1], rel=1e-7)
    assert c2[-1] > C0 and np.all(np.diff(n2) > 0)


@pytest.mark.parametrize(("m", "n_tol"), [(2.0, 0.005), (3.0, 0.009)])
def test_block_rule_against_rk4(m: float, n_tol: float) -> None:
    law = ParisLaw(C=1e-20, m=m)
    errors = []
    for da, blocks in ((0.04 * L, 4), (0.02 * L, 8)):
        b = corner_block_growth(law, PLATE, A0, C0, da, blocks, _angles)
        a = np.asarray(b.a)
        assert a[-1] == pytest.approx(0.36 * L, rel=1e-5)  # the face of a leads throughout
        ag, cg, ng = newman_raju_corner_growth(law, PLATE, A0, C0, a[-1], _angles, 800)
        err_n = np.asarray(b.cycles[1:]) / np.interp(a[1:], ag, ng) - 1
        err_c = np.asarray(b.c) / np.interp(a, ag, cg) - 1
        print(f"m {m} da {da / L:g} mm: N {np.round(100 * err_n, 3)}, c {np.round(100 * err_c, 3)}")
        errors.append(max(np.abs(err_n).max(), np.abs(err_c).max()))
        if da == 0.04 * L:
            assert np.abs(err_n).max() < n_tol
            assert np.abs(err_c).max() < 0.012
    assert errors[1] < 0.6 * errors[0]  # first order in the block size


def test_bad_input_is_refused() -> None:
    law = ParisLaw(C=1e-20, m=3.0)
    with pytest.raises(ParameterError, match="a/c"):
        corner_rates(law, PLATE, 0.3 * L, 0.2 * L, (0.2, 1.3))
    with pytest.raises(ParameterError, match="da_max"):
        corner_block_growth(law, PLATE, A0, C0, 0.0, 2, _angles)
    with pytest.raises(ParameterError, match="width"):
        CornerPlate(1.0e6, L, -1.0)
