"""The first-order K_I of a nearly circular planar crack (bonecontact.verification.
planar_crack), the reference of the polygonal crack scenes, against closed forms:

* a front mode a(θ) = a₀(1 + ε cos nθ): the formula's functional is exact for it,
  K(θ₀)/K₀(a(θ₀)) = 1 − nε cos nθ₀ / (2(1 + ε cos nθ₀)) (n = 0 … 5, to 1e-7);
* Irwin's ellipse of semi-axes a > b, near a circle: the first order's error is of the
  second order in 1 − b/a (b/a = 0.98, 0.95, 0.9: within 0.005, 0.03, 0.12 %; the error
  grows about fourfold when 1 − b/a doubles);
* a regular n-gon: the same K at the middle of every side, between the inscribed penny
  and (square) the tunnel crack of the same width (the comparison principle); the excess
  over the inscribed penny → ln 2/n (the sides' sum in closed form, module docstring).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bonecontact.fracture.front3d import irwin_k
from bonecontact.verification.planar_crack import (
    first_order_k_ratio,
    polygon_mid_side_k,
    polygon_radius,
)


@pytest.mark.parametrize("n", [0, 1, 2, 3, 5])
@pytest.mark.parametrize("theta0", [0.0, 0.4, 2.0])
def test_a_front_mode(n: int, theta0: float) -> None:
    eps = 0.01
    ratio = first_order_k_ratio(lambda t: 1.0 + eps * math.cos(n * t), theta0)
    c = math.cos(n * theta0)
    assert ratio == pytest.approx(1 - n * eps * c / (2 * (1 + eps * c)), abs=1e-7)


def _ellipse_error(b: float, theta0: float) -> float:
    """The first order's relative error against Irwin for the ellipse a = 1, b at the
    front point of polar angle θ₀."""

    def r(t: float) -> float:
        return b / math.hypot(b * math.cos(t), math.sin(t))

    phi = math.atan2(math.sin(theta0), b * math.cos(theta0))  # parametric angle
    exact = float(irwin_k(1.0, 1.0, b, phi)) / (2 * math.sqrt(r(theta0) / math.pi))
    return first_order_k_ratio(r, theta0) / exact - 1


@pytest.mark.parametrize("theta0", [0.0, math.pi / 4, math.pi / 2])
def test_near_circular_ellipse_against_irwin(theta0: float) -> None:
    errors = [abs(_ellipse_error(b, theta0)) for b in (0.98, 0.95, 0.9)]
    assert errors[0] < 5e-5 and errors[1] < 3e-4 and errors[2] < 1.2e-3, errors
    assert 2.5 < errors[2] / errors[1] < 6.0  # second order: ×4 when 1 − b/a doubles


@pytest.mark.parametrize("n", [4, 8, 12, 24])
def test_regular_polygon_mid_side(n: int) -> None:
    r = polygon_radius(n, 1.0)
    mids = [(2 * k + 1) * math.pi / n for k in range(n)]
    np.testing.assert_allclose([r(t) for t in mids], math.cos(math.pi / n), rtol=1e-14)
    assert r(0.0) == pytest.approx(1.0, rel=1e-14)  # a vertex
    ratios = [first_order_k_ratio(r, t) for t in mids[: min(n, 4)]]
    np.testing.assert_allclose(ratios, ratios[0], rtol=1e-9)
    k = polygon_mid_side_k(1.0, 1.0, n)
    inscribed = 2 * math.sqrt(math.cos(math.pi / n) / math.pi)
    assert k == pytest.approx(inscribed * ratios[0], rel=1e-12)
    assert k > inscribed
    # the straight sides' excess over the inscribed penny: ln 2 / n + O(1/n²)
    assert abs(n * (ratios[0] - 1) - math.log(2)) < 2.0 / n**2
    if n == 4:  # the tunnel crack of the square's width: σ√(π inradius)
        assert k < math.sqrt(math.pi * math.cos(math.pi / 4))


def test_polygon_needs_three_sides() -> None:
    with pytest.raises(ValueError, match="n >= 3"):
        polygon_mid_side_k(1.0, 1.0, 2)
