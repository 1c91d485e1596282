"""Tests of the 3D polygon clipping and the 2D segment projections of the mortar.

Pure NumPy: safe to run redundantly on every rank under
``mpiexec -n 2 python -m mpi4py -m pytest``.
"""

from __future__ import annotations

import numpy as np
from mortar_meshes import reference_intersection_area, square_grid

from bonecontact.common.geometry import cross2
from bonecontact.contact.clipping import (
    clip_polygons_by_triangles,
    fan_quadrature,
    fan_triangle_quadrature,
    polygon_areas,
    polygon_moments,
    project_points_to_lines_along_directions,
    project_points_to_segments_interpolated_normal,
)
from bonecontact.contact.geometry import nodal_normals, normalise
from bonecontact.contact.mortar_assembly import assemble_mortar
from bonecontact.contact.search import facet_bounding_boxes, find_candidate_pairs


def test_clipped_areas_random_triangle_pairs():
    rng = np.random.default_rng(8)
    n = 400
    a = rng.uniform(0, 1, (n, 3, 2))
    b = rng.uniform(0, 1, (n, 3, 2)) * rng.uniform(0.2, 1.0, (n, 1, 1)) + rng.uniform(
        0, 0.5, (n, 1, 2)
    )
    b[:20] = a[:20] * 0.3 + 0.7 * a[:20].mean(axis=1, keepdims=True)  # b inside a
    b[20:40] = 3.0 * (a[20:40] - a[20:40].mean(axis=1, keepdims=True)) + a[20:40].mean(
        axis=1, keepdims=True
    )
    b[40:60] = a[40:60] + [5.0, 0.0]  # disjoint
    poly, count = clip_polygons_by_triangles(b, np.full(n, 3), a)
    area = polygon_areas(poly, count)
    ref = np.array([reference_intersection_area(a[i], b[i]) for i in range(n)])
    np.testing.assert_allclose(area, ref, atol=1e-13)
    area_a = polygon_areas(a, np.full(n, 3))
    area_b = polygon_areas(b, np.full(n, 3))
    np.testing.assert_allclose(area[:20], area_b[:20], rtol=1e-12)
    np.testing.assert_allclose(area[20:40], area_a[20:40], rtol=1e-12)
    np.testing.assert_array_equal(area[40:60], 0.0)
    assert np.count_nonzero(area[60:] > 0) > 100
    # symmetric in the roles of subject and clip triangle
    poly2, count2 = clip_polygons_by_triangles(a, np.full(n, 3), b)
    np.testing.assert_allclose(polygon_areas(poly2, count2), area, atol=1e-13)
    # fan-quadrature weights of the clipped polygons integrate 1 to the same area
    _, wq = fan_quadrature(poly, count)
    np.testing.assert_allclose(wq.sum(axis=1), area, atol=1e-13)


def test_polygon_moments_against_fan_quadrature():
    """Moments of order <= 2 of clipped polygons (3 to 6 vertices, either orientation)
    by Green's theorem equal the degree-5 fan rule (exact for quadratics); the unpadded
    fan rule equals the padded one."""
    rng = np.random.default_rng(10)
    n = 300
    a = rng.uniform(0, 1, (n, 3, 2))
    b = rng.uniform(0, 1, (n, 3, 2)) + rng.uniform(-0.3, 0.3, (n, 1, 2))
    poly, count = clip_polygons_by_triangles(b, np.full(n, 3), a)
    idx = np.arange(poly.shape[1])
    rev = np.where(idx < count[:, None], count[:, None] - 1 - idx, idx)
    poly[::2] = np.take_along_axis(poly, rev[:, :, None], axis=1)[::2]  # clockwise
    keep = count >= 3
    poly, count = poly[keep], count[keep]
    assert set(np.unique(count)) >= {3, 4, 5, 6}
    mom = polygon_moments(poly, count)
    qp, w = fan_quadrature(poly, count)
    b_q = np.stack([np.ones(qp.shape[:2]), qp[..., 0], qp[..., 1]], axis=-1)
    ref = np.einsum("pq,pqi,pqj->pij", w, b_q, b_q)
    np.testing.assert_allclose(mom, ref, rtol=0, atol=1e-14)
    np.testing.assert_allclose(mom[:, 0, 0], polygon_areas(poly, count), atol=1e-15)
    owner, qp_flat, w_flat = fan_triangle_quadrature(poly, count)
    assert np.all(np.diff(owner) >= 0) and len(owner) == count.sum()
    np.testing.assert_allclose(np.bincount(owner, w_flat.sum(axis=1)), w.sum(axis=1), atol=1e-15)
    f = lambda p: np.sin(3 * p[..., 0]) * np.exp(p[..., 1])  # noqa: E731
    np.testing.assert_allclose(
        np.bincount(owner, (w_flat * f(qp_flat)).sum(axis=1)), (w * f(qp)).sum(axis=1), atol=1e-14
    )


def test_clipped_areas_monte_carlo():
    rng = np.random.default_rng(9)
    a = rng.uniform(0, 1, (8, 3, 2))
    b = rng.uniform(0, 1, (8, 3, 2))
    poly, count = clip_polygons_by_triangles(b, np.full(8, 3), a)
    area = polygon_areas(poly, count)
    pts = rng.uniform(0, 1, (200_000, 2))

    def inside(tri):
        s = np.stack([cross2(tri[(i + 1) % 3] - tri[i], pts - tri[i]) for i in range(3)], axis=1)
        return np.all(s >= 0, axis=1) | np.all(s <= 0, axis=1)

    for i in range(8):
        mc = np.mean(inside(a[i]) & inside(b[i]))
        assert abs(mc - area[i]) < 5e-3


def test_clipped_areas_tile_square():
    rng = np.random.default_rng(10)
    ps, ts = square_grid(7, 0.0, 1.0, rng, perturb=0.3)
    pm, tm = square_grid(19, 0.0, 1.0, rng, perturb=0.3, flip=True)
    ia, ib = find_candidate_pairs(*facet_bounding_boxes(ps, ts), *facet_bounding_boxes(pm, tm))
    poly, count = clip_polygons_by_triangles(pm[tm[ib]], np.full(len(ia), 3), ps[ts[ia]])
    area = polygon_areas(poly, count)
    assert abs(area.sum() - 1.0) < 1e-12
    per_slave = np.bincount(ia, weights=area, minlength=len(ts))
    np.testing.assert_allclose(per_slave, polygon_areas(ps[ts], np.full(len(ts), 3)), atol=1e-14)
    # the same through the 3D pipeline (master lifted off the plane by a gap)
    xs = np.column_stack([ps, np.zeros(len(ps))])
    xm = np.column_stack([pm, np.full(len(pm), 0.05)])
    ns = nodal_normals(xs, ts, xs[ts].mean(axis=1) - [0, 0, 1])
    res = assemble_mortar(xs, ts, ns, xm, tm, search_radius=0.1)
    assert abs(res.covered_area.sum() - 1.0) < 1e-12
    np.testing.assert_allclose(res.covered_area, res.facet_area, atol=1e-14)


def test_projection_onto_segment_interpolated_normal():
    rng = np.random.default_rng(11)
    n = 200
    x1, x2 = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
    t = x2 - x1
    nf = np.stack([t[:, 1], -t[:, 0]], 1) / np.linalg.norm(t, axis=1, keepdims=True)
    n1 = normalise(nf + 0.3 * rng.normal(size=(n, 2)))
    n2 = normalise(nf + 0.3 * rng.normal(size=(n, 2)))
    xi_true = rng.uniform(-0.2, 1.2, n)
    dist = rng.uniform(-0.3, 0.3, n)
    nx = (1 - xi_true)[:, None] * n1 + xi_true[:, None] * n2
    p = (1 - xi_true)[:, None] * x1 + xi_true[:, None] * x2 + dist[:, None] * nx
    xi = project_points_to_segments_interpolated_normal(p, x1, x2, n1, n2)
    np.testing.assert_allclose(xi, xi_true, atol=1e-9)
    eta = project_points_to_lines_along_directions(p - 0.5 * nx, nx, x1, x2)
    np.testing.assert_allclose(eta, xi_true, atol=1e-9)
