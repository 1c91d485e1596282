"""The first active set of a 3D cold start from the compliance of the support patch.

References, independent of the code: Hertz's solution (the contact radius of a
paraboloid under a load, Johnson 1985 §4.2), the displacement of the surface around a
flat punch (Johnson §3.8), and the series law of two springs.
"""

from __future__ import annotations

import numpy as np
import pytest

from bonecontact.contact.cold_start import (
    edge_gap,
    first_set,
    punch_approach,
    structure_stiffness,
)

R, E_STAR, P = 0.01, 2.2e9, 300.0


def _grid(h: float, half: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nodes of a square grid on the plane y = 0 (spacing h), their areas h² and the
    gaps r²/(2R) of a sphere of radius R touching at the origin."""
    s = np.arange(-half, half + h / 2, h)
    x, z = np.meshgrid(s, s, indexing="ij")
    X = np.c_[x.ravel(), np.zeros(x.size), z.ravel()]
    r2 = X[:, 0] ** 2 + X[:, 2] ** 2
    return X, np.full(x.size, h * h), r2 / (2 * R)


def test_edge_gap_of_a_load_driven_paraboloid_is_hertz():
    """Held only by the contact (K_b = 0), a patch of radius ρ with the punch approach
    δ₁ = P/(2E*ρ): the predicted zone ends at Hertz's edge gap a²/(2R),
    a = (3PR/(4E*))^(1/3), whatever ρ."""
    a = (3 * P * R / (4 * E_STAR)) ** (1 / 3)
    _, area, gap = _grid(a / 40, 2 * a)
    for rho in (a / 10, a / 4):
        t = edge_gap(gap, area, P, P / (2 * E_STAR * rho), rho, 0.0)
        assert t == pytest.approx(a**2 / (2 * R), rel=0.03)


def test_edge_gap_of_a_rigidly_driven_body_is_half_the_approach():
    """A body driven by a prescribed approach δ (K_b = ∞): a paraboloid's zone ends where
    the gap is δ/2 (Hertz: δ = a²/R); a stiff finite structure comes close to it."""
    _, area, gap = _grid(1e-5, 2e-3)
    delta = 1e-4
    assert edge_gap(gap, area, P, delta, 1e-4, np.inf) == 0.5 * delta
    t = edge_gap(gap, area, P, delta, 1e-4, 1e6 * P / delta)
    assert t == pytest.approx(0.5 * delta, rel=0.02)


def test_structure_stiffness_is_the_series_law():
    """1/K = 1/K_b + δ₁/P₁; no stiffness left: 0; all of it the contact's: ∞."""
    P1, d1 = 2.0, 1e-4
    Kb = 3e4
    K = 1.0 / (1.0 / Kb + d1 / P1)
    assert structure_stiffness(P1, d1, K) == pytest.approx(Kb, rel=1e-12)
    assert structure_stiffness(P1, d1, 0.0) == 0.0
    assert structure_stiffness(P1, d1, -1.0) == 0.0
    assert structure_stiffness(P1, d1, 2 * P1 / d1) == np.inf


def test_punch_approach_recovers_the_punch_displacement():
    """The surface around a flat punch pressed in by δ moves by δ(1 − (2/π)arcsin(ρ/r));
    a far-field bending added beyond 4ρ does not change the estimate."""
    X, _, _ = _grid(1e-5, 4e-4)
    r = np.hypot(X[:, 0], X[:, 2])
    rho, delta = 3.3e-5, 2e-4
    patch = r <= rho
    un = np.where(patch, 0.0, delta * (1 - 2 / np.pi * np.arcsin(np.minimum(rho / r, 1.0))))
    un = un + np.where(r > 4 * rho, 1e3 * (r - 4 * rho) ** 2, 0.0)  # bending far away
    force = np.where(patch, 1.0, 0.0)
    assert punch_approach(X, un, force, patch, rho) == pytest.approx(delta, rel=1e-12)


def test_first_set_keeps_the_patch_and_takes_the_predicted_zone():
    """A synthetic first solve of a load-driven paraboloid (punch displacement, force P on
    the patch, no structure stiffness): the first set is the patch plus the nodes
    within Hertz's radius (to the grid), and only the patch without a measurement."""
    a = (3 * P * R / (4 * E_STAR)) ** (1 / 3)
    X, area, gap = _grid(a / 20, 2 * a)
    r = np.hypot(X[:, 0], X[:, 2])
    patch = r <= 1.6 * a / 20
    rho = np.sqrt(area[patch].sum() / np.pi)
    delta = P / (2 * E_STAR * rho)
    un = np.where(patch, gap, delta * (1 - 2 / np.pi * np.arcsin(np.minimum(rho / r, 1.0))))
    force = np.where(patch, P / patch.sum(), 0.0)
    got = first_set(X, gap, area, un, force, patch, np.zeros_like(gap), delta)
    assert got[patch].all()
    assert np.sqrt(area[got].sum() / np.pi) == pytest.approx(a, rel=0.05)
    none = first_set(X, gap, area, un, np.zeros_like(force), patch, None, delta)
    assert np.array_equal(none, patch)
