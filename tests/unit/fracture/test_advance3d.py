"""The planar front advance rule (bonecontact.fracture.advance3d)."""

import math

import numpy as np
import pytest

from bonecontact.fracture.advance3d import advance_polygon_front, vertex_directions
from bonecontact.fracture.crack import FractureError

N = np.array([0.0, 0.0, 1.0])


def square(a: float = 1.0) -> np.ndarray:
    return np.array([[a, -a, 0], [a, a, 0], [-a, a, 0], [-a, -a, 0]], dtype=float)


@pytest.mark.parametrize("n", [4, 8, 13])
def test_uniform_k_scales_a_regular_polygon(n):
    """Equal K everywhere: a regular polygon grows into the regular polygon of circumradius
    a + Δa (the vertices move radially by Δa)."""
    t = 2 * math.pi * np.arange(n) / n
    V = np.column_stack([np.cos(t), np.sin(t), 0 * t])
    new, da = advance_polygon_front(V, N, np.full(n, 2.0), 0.1)
    np.testing.assert_allclose(da, 0.1, rtol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(new, axis=1), 1.1, rtol=1e-12)
    np.testing.assert_allclose(vertex_directions(V, N), V, atol=1e-12)


def test_advance_scales_with_k_power_and_holds_below_toughness():
    """Δa_i = Δa_max (K_i/K_max)^n with K_i the mean of the two edges at vertex i; vertices
    below K_Ic hold."""
    V = square()
    k = np.array([1.0, 2.0, 2.0, 1.0])  # edges 0..3 (vertex k → k + 1)
    _, da = advance_polygon_front(V, N, k, 0.2, exponent=2.0, smooth=False)
    kv = np.array([1.0, 1.5, 2.0, 1.5])  # vertex k between edges k − 1 and k
    np.testing.assert_allclose(da, 0.2 * (kv / 2.0) ** 2, rtol=1e-14)
    _, da = advance_polygon_front(V, N, k, 0.2, exponent=1.0, k_ic=1.6, smooth=False)
    np.testing.assert_allclose(da, [0.0, 0.0, 0.2, 0.0], atol=1e-15)
    _, ds = advance_polygon_front(V, N, k, 0.2, exponent=1.0, smooth=True)
    np.testing.assert_allclose(ds.sum(), (0.2 * kv / 2.0).sum(), rtol=1e-14)  # mean kept


def test_bad_input_refused():
    with pytest.raises(FractureError, match="k_edges"):
        advance_polygon_front(square(), N, [1.0, 1.0, 1.0], 0.1)
    with pytest.raises(FractureError, match="k_edges"):
        advance_polygon_front(square(), N, [1.0, -1.0, 1.0, 1.0], 0.1)
    t = 2 * math.pi * (np.arange(8) + 0.5) / 8
    octagon = np.column_stack([np.cos(t), np.sin(t), 0 * t])
    k = np.ones(8)
    k[1] = 100.0  # one edge far ahead of the others: a reflex angle at its neighbours
    with pytest.raises(FractureError, match="convex"):
        advance_polygon_front(octagon, N, k, 5.0, smooth=False)
