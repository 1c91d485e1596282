"""Tests of bonecontact.common.geometry and bonecontact.common.constants."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bonecontact.common.constants import R_GAS, SECONDS_PER_DAY, SECONDS_PER_YEAR
from bonecontact.common.geometry import (
    cross2,
    first_ray_hits,
    line_triangle_hits,
    nearest_triangle,
    nearest_triangle_distance,
    point_triangle_distance,
    polygon_area,
    signed_polygon_area,
)

SQUARE = [[0.0, 0.0], [2.0, 0.0], [2.0, 3.0], [0.0, 3.0]]  # counter-clockwise, area 6


def test_cross2():
    assert cross2([1.0, 0.0], [0.0, 1.0]) == 1.0
    assert cross2([0.0, 1.0], [1.0, 0.0]) == -1.0
    a = np.array([[1.0, 2.0], [3.0, 4.0], [2.0, 4.0]])
    b = np.array([[5.0, 6.0], [7.0, 8.0], [1.0, 2.0]])
    np.testing.assert_array_equal(cross2(a, b), [1 * 6 - 2 * 5, 3 * 8 - 4 * 7, 0.0])
    np.testing.assert_array_equal(cross2(a, [0.0, 1.0]), [1.0, 3.0, 2.0])  # broadcasting


def test_polygon_areas():
    assert signed_polygon_area(SQUARE) == 6.0
    assert signed_polygon_area(SQUARE[::-1]) == -6.0
    assert polygon_area(SQUARE) == polygon_area(SQUARE[::-1]) == 6.0
    th = 2 * np.pi * np.arange(400) / 400
    circle = np.column_stack([np.cos(th), np.sin(th)])
    assert abs(signed_polygon_area(circle) - 0.5 * 400 * np.sin(2 * np.pi / 400)) < 1e-13


def test_constants():
    assert R_GAS == 8.314462618
    assert SECONDS_PER_DAY == 86400.0
    assert SECONDS_PER_YEAR == 365.25 * 86400.0 == 31557600.0


@pytest.mark.parametrize(
    "x, d",
    [
        ((0.2, 0.2, 0.5), 0.5),  # above the inside: the plane
        ((2.0, 0.0, 0.0), 1.0),  # beyond a corner
        ((-1.0, -1.0, 0.0), math.sqrt(2.0)),  # beyond the right-angle corner
        ((1.0, 1.0, 0.0), math.sqrt(0.5)),  # beyond the hypotenuse
        ((0.5, -1.0, 2.0), math.sqrt(5.0)),  # off an edge and the plane
    ],
)
def test_point_triangle_distance_closed_form(x, d: float) -> None:
    tri = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]])
    assert point_triangle_distance(np.array(x), tri)[0] == pytest.approx(d, rel=1e-14)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_point_triangle_distance_against_sampling(seed: int) -> None:
    """Never above the distance of the nearest of 20k sampled points of the triangle,
    below it by less than the sampling's spacing."""
    rng = np.random.default_rng(seed)
    tri = rng.normal(size=(6, 3, 3))
    x = rng.normal(size=3) * 2.0
    w = rng.dirichlet(np.ones(3), size=20000)
    for t, d in zip(tri, point_triangle_distance(x, tri), strict=True):
        sampled = np.linalg.norm(w @ t - x, axis=1).min()
        h = np.linalg.norm(t - np.roll(t, 1, axis=0), axis=1).max()
        assert d <= sampled + 1e-12 and sampled - d < 0.05 * h


def test_point_triangle_distance_pairwise():
    """Point i against triangle i: the same as measuring each pair alone."""
    rng = np.random.default_rng(7)
    tri, p = rng.normal(size=(5, 3, 3)), rng.normal(size=(5, 3))
    one = [point_triangle_distance(p[k], tri[k : k + 1])[0] for k in range(5)]
    np.testing.assert_allclose(point_triangle_distance(p, tri), one, rtol=1e-15)


def _icosphere(levels: int) -> np.ndarray:
    """The triangles (k, 3, 3) of a unit sphere: an octahedron split ``levels`` times,
    the new corners pushed onto the sphere."""
    V = [
        np.array(v, float)
        for v in ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1))
    ]
    tris = [
        np.array([V[a], V[b], V[c]])
        for a, b, c in (
            (0, 2, 4),
            (2, 1, 4),
            (1, 3, 4),
            (3, 0, 4),
            (2, 0, 5),
            (1, 2, 5),
            (3, 1, 5),
            (0, 3, 5),
        )
    ]
    for _ in range(levels):
        out = []
        for a, b, c in tris:
            ab, bc, ca = ((x + y) / np.linalg.norm(x + y) for x, y in ((a, b), (b, c), (c, a)))
            out += [np.array(t) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))]
        tris = out
    return np.array(tris)


@pytest.mark.parametrize("direction", [(1, 0, 0), (0.3, -0.5, 0.8), (-0.2, 0.1, -1.0)])
def test_line_triangle_hits_sphere(direction) -> None:
    """A line from the centre of a closed triangulated sphere leaves it once each way:
    two hits (three or more only where it passes an edge: counted once after merging),
    each on its triangle's plane, the points on the line, at a radius between the facets'
    inradius and 1."""
    T = _icosphere(3)
    d = np.asarray(direction, float)
    s = line_triangle_hits(np.zeros(3), d, T)
    hit = np.flatnonzero(np.isfinite(s))
    x = s[hit, None] * d
    n = np.cross(T[hit, 1] - T[hit, 0], T[hit, 2] - T[hit, 0])
    off = np.einsum("ij,ij->i", x - T[hit, 0], n) / np.linalg.norm(n, axis=1)
    assert np.max(np.abs(off)) < 1e-14
    r = np.linalg.norm(x, axis=1)
    assert np.all((r > 0.98) & (r <= 1 + 1e-14))
    ends = np.unique(np.round(s[hit] * 1e9))
    assert len(ends) == 2 and ends[0] < 0 < ends[1]


def test_line_triangle_hits_plane_closed_form() -> None:
    """Two triangles tiling the unit square in z = 0.5: s = (0.5 − p_z)/d_z inside, nan
    outside, parallel lines nan."""
    T = np.array([[[0, 0, 0.5], [1, 0, 0.5], [1, 1, 0.5]], [[0, 0, 0.5], [1, 1, 0.5], [0, 1, 0.5]]])
    s = line_triangle_hits([0.25, 0.6, 2.0], [0.1, -0.2, -3.0], T)
    assert np.isnan(s[0]) and s[1] == pytest.approx(0.5, rel=1e-14)
    assert np.all(np.isnan(line_triangle_hits([2.0, 2.0, 0.0], [0, 0, 1.0], T)))
    assert np.all(np.isnan(line_triangle_hits([0.5, 0.5, 0.0], [1.0, 0, 0], T)))
    # through the shared diagonal: both triangles
    np.testing.assert_allclose(line_triangle_hits([0.5, 0.5, 0.0], [0, 0, 1.0], T), [0.5, 0.5])


@pytest.mark.parametrize("chunk", [1, 7, 256])
def test_first_ray_hits_sphere_from_outside(chunk) -> None:
    """Rays aimed at the centre of a triangulated unit sphere from distance 3 enter it
    first at 3 − r, r between the facets' inradius and 1 (the line's own hits, least
    positive one); rays pointing away hit nothing (inf, -1); the answer does not depend
    on the chunk size."""
    T = _icosphere(3)
    rng = np.random.default_rng(5)
    u = rng.normal(size=(40, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    origins = 3.0 * u
    dirs = np.vstack([-u[:30], u[30:]])
    s, which = first_ray_hits(origins, dirs, T, chunk=chunk)
    assert np.all((s[:30] >= 2.0 - 1e-14) & (s[:30] < 2.02))
    assert np.all(np.isinf(s[30:])) and np.all(which[30:] == -1)
    for i in range(30):
        line = line_triangle_hits(origins[i], dirs[i], T)
        assert s[i] == np.nanmin(np.where(line > 0, line, np.nan))
        assert line[which[i]] == s[i]
    assert np.all(np.isinf(first_ray_hits(origins, dirs, T[:0])[0]))


def test_first_ray_hits_edge_slack() -> None:
    """A ray through the shared diagonal of two triangles hits with the default slack;
    with tol = 0 it may miss both or hit one, never at another distance."""
    T = np.array([[[0, 0, 0.5], [1, 0, 0.5], [1, 1, 0.5]], [[0, 0, 0.5], [1, 1, 0.5], [0, 1, 0.5]]])
    s, which = first_ray_hits([[0.5, 0.5, 0.0], [0.25, 0.6, 0.0]], [[0, 0, 1.0], [0, 0, 2.0]], T)
    np.testing.assert_allclose(s, [0.5, 0.25], rtol=1e-14)
    assert which[1] == 1
    s0, _ = first_ray_hits([[0.5, 0.5, 0.0]], [[0, 0, 1.0]], T, tol=0.0)
    assert np.isinf(s0[0]) or s0[0] == pytest.approx(0.5, rel=1e-14)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_nearest_triangle_distance_equals_brute_force(seed: int) -> None:
    """Against every triangle (to the last bit): random and sliver triangles, points near,
    on and far from them."""
    rng = np.random.default_rng(seed)
    t = rng.normal(size=(300, 3, 3)) * rng.uniform(0.01, 1.0, size=(300, 1, 1))
    t[:50, 2] = t[:50, 0] + 1e-6 * rng.normal(size=(50, 3))  # slivers
    t += rng.uniform(-5, 5, size=(300, 1, 3))
    pts = np.concatenate(
        [rng.uniform(-8, 8, size=(200, 3)), t[:20].mean(axis=1), rng.normal(size=(5, 3)) * 50]
    )
    want = np.array([point_triangle_distance(p, t).min() for p in pts])
    got = nearest_triangle_distance(pts, t)
    assert np.array_equal(got, want)
    # the nearest triangle: the brute force's first argmin, also where copies tie
    t2 = np.concatenate([t, t[::-1]])
    d, k = nearest_triangle(pts, t2)
    assert np.array_equal(d, want)
    assert np.array_equal(k, [int(np.argmin(point_triangle_distance(p, t2))) for p in pts])
    assert nearest_triangle_distance(pts[0], t).shape == (1,)


def test_nearest_triangle_distance_plane_closed_form() -> None:
    """Points above a triangulated square [0, 1]² (z = 0): the height where they lie over
    it, else the distance to the square."""
    g = np.linspace(0.0, 1.0, 9)
    X, Y = np.meshgrid(g, g)
    v = np.stack([X.ravel(), Y.ravel(), 0 * X.ravel()], axis=1)
    i = np.arange(8)
    c = (i[:, None] * 9 + i[None, :]).ravel()
    tri = np.concatenate([np.stack([c, c + 1, c + 10], 1), np.stack([c, c + 10, c + 9], 1)])
    pts = np.array([[0.3, 0.7, 0.25], [0.5, 0.5, -2.0], [1.5, 0.5, 0.0], [2.0, 2.0, 1.0]])
    want = [0.25, 2.0, 0.5, math.sqrt(3.0)]
    np.testing.assert_allclose(nearest_triangle_distance(pts, v[tri]), want, rtol=1e-14)
