"""A penny crack grows under mode I: planar and circular
(docs/theory/fracture.md#front-advance-of-a-planar-crack).

The penny is the regular octagon of circumradius a = 1 in z = 0, in the block [−4, 4]³
under tension σ = 1 normal to it (E = 1, ν = 0.3); every increment re-meshes the block
with the crack (two faces), solves, takes K_I at the mid-edges and advances the vertices
by Δa_max (K_i/K_max)² (smoothed over three vertices), Δa_max = 0.1a.  Under mode I the
front stays in its plane (the advance is in-plane by construction) and, K being the same
at every mid-edge up to the mesh's scatter, it stays circular: every vertex at the same
distance from the centroid.  The unit tests of the advance rule are in
tests/unit/fracture/test_advance3d.py.

* Default: 2 increments, front a/8 (12k dofs): vertex radii within 1 % of each other
  (measured 0.074 %), the mean radius grown by 2Δa within 2 % (measured 0.198a), the
  front in its plane, the centroid kept (measured 3·10⁻⁴a), K_I up with the crack.
* Slow: 5 increments, front a/10: radius spread ≤ 2 % (the issue's criterion; measured
  0.078 %, the mean radius grown by 0.495a); the increment halved: the grown front moves
  by less than a front element (measured 0.0024a against 0.125a).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import numpy as np
import pytest

from bonecontact.verification.front_advance import grow_polygon_penny


def _check(rec, increments: int, spread: float):
    r0 = rec.radii(0).mean()
    r = rec.radii(increments)
    assert (r.max() - r.min()) / r.mean() < spread
    # every vertex advanced by about Δa_max: the K of the mid-edges differ by a few per cent
    assert r.mean() - r0 == pytest.approx(increments * 0.1, rel=0.02)
    np.testing.assert_allclose(np.asarray(rec.vertices[-1])[:, 2], 0.0, atol=1e-12)  # planar
    np.testing.assert_allclose(np.asarray(rec.vertices[-1]).mean(axis=0), 0.0, atol=0.01)
    means = [float(np.mean(k)) for k in rec.k_edges]
    assert all(b > a for a, b in zip(means, means[1:], strict=False))  # K grows with a


def test_penny_grows_planar_and_circular():
    rec = grow_polygon_penny(n_sides=8, increments=2, h_front=0.125)
    _check(rec, 2, 0.01)


@pytest.mark.slow
def test_penny_grows_circular_five_advances():
    """5 advances at front a/10 (16.7k–20.5k dofs): vertex radii within 2 % of each other
    (measured 0.078 %)."""
    rec = grow_polygon_penny(n_sides=8, increments=5, h_front=0.1)
    _check(rec, 5, 0.02)


@pytest.mark.slow
def test_grown_front_does_not_depend_on_the_increment():
    """Two advances of 0.1a against four of 0.05a (front a/8): the grown fronts differ by
    less than the front element size (measured 0.0024a against 0.125a)."""
    h = 0.125
    a = grow_polygon_penny(n_sides=8, increments=2, da=0.1, h_front=h)
    b = grow_polygon_penny(n_sides=8, increments=4, da=0.05, h_front=h)
    d = np.linalg.norm(np.asarray(a.vertices[-1]) - np.asarray(b.vertices[-1]), axis=1)
    assert d.max() < h
