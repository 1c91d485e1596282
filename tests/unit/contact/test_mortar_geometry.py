"""Tests of the pure-NumPy mortar geometry (SPEC §4.1, §4.2, §8 "dual basis, D, M").

Pure NumPy: safe to run redundantly on every rank under
``mpiexec -n 2 python -m mpi4py -m pytest``.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from bonecontact.contact import mortar_geometry as mg

# ----------------------------------------------------------------------------------
# helpers: meshes
# ----------------------------------------------------------------------------------


def square_grid(
    n: int, lo: float, hi: float, rng: np.random.Generator, perturb: float = 0.25, flip: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Triangulated square [lo, hi]^2 with randomly perturbed interior nodes."""
    t = np.linspace(lo, hi, n + 1)
    X, Y = np.meshgrid(t, t, indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel()], axis=1)
    h = (hi - lo) / n
    inner = np.all((pts > lo + 1e-12) & (pts < hi - 1e-12), axis=1)
    pts[inner] += rng.uniform(-perturb * h, perturb * h, (int(inner.sum()), 2))
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    if flip:
        tris = np.concatenate([np.stack([a, b, d], 1), np.stack([b, c, d], 1)])
    else:
        tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return pts, tris


def flat_surface(n, lo, hi, z, rng, **kw):
    pts, tris = square_grid(n, lo, hi, rng, **kw)
    return np.column_stack([pts, np.full(len(pts), z)]), tris


def sphere_cap(n, half_width, radius, rng, **kw):
    """Cap of the sphere |x| = radius over the square [-hw, hw]^2 (central projection)."""
    pts, tris = square_grid(n, -half_width, half_width, rng, **kw)
    p = np.column_stack([pts, np.ones(len(pts))])
    return radius * p / np.linalg.norm(p, axis=1, keepdims=True), tris


def arc(n_seg, radius, theta0, theta1):
    th = np.linspace(theta0, theta1, n_seg + 1)
    pts = radius * np.stack([np.cos(th), np.sin(th)], axis=1)
    segs = np.stack([np.arange(n_seg), np.arange(1, n_seg + 1)], axis=1)
    return pts, segs


def line(n_seg, x0, x1, y, rng=None, perturb=0.0):
    x = np.linspace(x0, x1, n_seg + 1)
    if rng is not None:
        h = (x1 - x0) / n_seg
        x[1:-1] += rng.uniform(-perturb * h, perturb * h, n_seg - 1)
    pts = np.stack([x, np.full_like(x, y)], axis=1)
    segs = np.stack([np.arange(n_seg), np.arange(1, n_seg + 1)], axis=1)
    return pts, segs


def row_sums(res: mg.MortarContributions, n: int) -> np.ndarray:
    return np.bincount(res.m_rows, weights=res.m_vals, minlength=n)


def lumped(coords: np.ndarray, facets: np.ndarray) -> np.ndarray:
    """int phi_p over the slave surface (independent of the mortar code)."""
    x = coords[facets]
    if facets.shape[1] == 2:
        meas = np.linalg.norm(x[:, 1] - x[:, 0], axis=1)
    else:
        meas = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
    nv = facets.shape[1]
    return np.bincount(facets.ravel(), weights=np.repeat(meas / nv, nv), minlength=len(coords))


# ----------------------------------------------------------------------------------
# dual basis
# ----------------------------------------------------------------------------------


def test_quadrature_rules_exact():
    t, w = mg.GAUSS_SEGMENT
    for k in range(6):
        assert np.isclose(np.sum(w * t**k), 1.0 / (k + 1), rtol=0, atol=1e-15)
    bary, w = mg.TRIANGLE_RULE
    # int over the reference triangle of xi^a eta^b = a! b! / (a+b+2)!, area 1/2
    from math import factorial

    for a, b in itertools.product(range(6), repeat=2):
        if a + b <= 5:
            exact = factorial(a) * factorial(b) / factorial(a + b + 2)
            num = 0.5 * np.sum(w * bary[:, 1] ** a * bary[:, 2] ** b)
            assert abs(num - exact) < 1e-15


def test_biorthogonality_segment():
    t, w = mg.GAUSS_SEGMENT
    phi, psi = mg.shape_segment(t), mg.dual_segment(t)
    gram = np.einsum("q,qj,qk->jk", w, psi, phi)
    np.testing.assert_allclose(gram, 0.5 * np.eye(2), atol=1e-15)
    np.testing.assert_allclose(mg.dual_segment([0.0, 1.0]), [[2.0, -1.0], [-1.0, 2.0]])


def test_biorthogonality_reference_triangle():
    bary, w = mg.TRIANGLE_RULE
    xi = bary[:, 1:]
    phi, psi = mg.shape_triangle(xi), mg.dual_triangle(xi)
    gram = 0.5 * np.einsum("q,qj,qk->jk", w, psi, phi)
    np.testing.assert_allclose(gram, np.eye(3) / 6.0, atol=1e-15)
    np.testing.assert_allclose(mg.dual_triangle([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), 4 * np.eye(3) - 1)


def test_biorthogonality_random_affine_triangle():
    rng = np.random.default_rng(1)
    for _ in range(10):
        v = rng.normal(size=(3, 3))
        area = 0.5 * np.linalg.norm(np.cross(v[1] - v[0], v[2] - v[0]))
        bary, w = mg.TRIANGLE_RULE
        # physical quadrature: psi / phi are the same functions of barycentrics
        phi = bary
        psi = mg.evaluate_dual(mg.DUAL_COEFFS_TRIANGLE, phi)
        gram = area * np.einsum("q,qj,qk->jk", w, psi, phi)
        np.testing.assert_allclose(gram, area / 3.0 * np.eye(3), atol=1e-14 * area)
        np.testing.assert_allclose(psi, mg.dual_triangle(bary[:, 1:]), atol=1e-15)


def test_general_constructor_matches_closed_form():
    rng = np.random.default_rng(2)
    for gdim in (2, 3):
        segs = rng.normal(size=(20, 2, gdim))
        np.testing.assert_allclose(
            mg.dual_coefficients(segs), np.broadcast_to(mg.DUAL_COEFFS_SEGMENT, (20, 2, 2)), atol=1e-12
        )
    tris = rng.normal(size=(20, 3, 3))
    np.testing.assert_allclose(
        mg.dual_coefficients(tris), np.broadcast_to(mg.DUAL_COEFFS_TRIANGLE, (20, 3, 3)), atol=1e-12
    )
    # element mass matrix against the closed form |T|/12 (1 + delta)
    area = 0.5 * np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    np.testing.assert_allclose(
        mg.element_mass_matrices(tris), area[:, None, None] / 12.0 * (np.ones((3, 3)) + np.eye(3)), rtol=1e-13
    )


def test_general_constructor_nonaffine_weight():
    """A_e = D_e M_e^-1 with a non-constant weight (e.g. a non-affine Jacobian)."""
    # 5-point rule to integrate weight * phi * phi exactly (weight quadratic)
    x, wx = np.polynomial.legendre.leggauss(5)
    x, wx = 0.5 * (x + 1.0), 0.5 * wx
    weight = 1.0 + x + 2.0 * x**2
    phi = mg.shape_segment(x)
    mass = np.einsum("q,q,qj,qk->jk", wx, weight, phi, phi)
    A = mg.dual_coefficients_from_mass(mass)
    psi = mg.evaluate_dual(A, phi)
    gram = np.einsum("q,q,qj,qk->jk", wx, weight, psi, phi)
    np.testing.assert_allclose(gram, np.diag(mass.sum(axis=1)), atol=1e-14)
    np.testing.assert_allclose(psi.sum(axis=1), 1.0, atol=1e-14)


def test_partition_of_unity():
    rng = np.random.default_rng(3)
    xi = rng.uniform(-0.5, 1.5, 50)
    np.testing.assert_allclose(mg.dual_segment(xi).sum(axis=1), 1.0, atol=1e-14)
    pts = rng.uniform(-0.5, 1.5, (50, 2))
    np.testing.assert_allclose(mg.dual_triangle(pts).sum(axis=1), 1.0, atol=1e-14)
    np.testing.assert_allclose(mg.shape_triangle(pts).sum(axis=1), 1.0, atol=1e-14)


def test_boundary_modification_segment():
    A = mg.modify_dual_coefficients(mg.DUAL_COEFFS_SEGMENT, [[True, False], [False, False]])
    xi = np.linspace(0.0, 1.0, 7)
    psi0 = mg.evaluate_dual(A[0], mg.shape_segment(xi))
    np.testing.assert_allclose(psi0[:, 0], 0.0, atol=0)  # masked node: multiplier vanishes
    np.testing.assert_allclose(psi0[:, 1], 1.0, atol=1e-15)  # interior node: psi = 1 on end segment
    np.testing.assert_allclose(A[1], mg.DUAL_COEFFS_SEGMENT)  # untouched element
    none = mg.modify_dual_coefficients(mg.DUAL_COEFFS_SEGMENT, [[True, True]])
    np.testing.assert_array_equal(none, 0.0)


@pytest.mark.parametrize("mask", [(True, False, False), (False, True, True), (False, False, False)])
def test_boundary_modification_triangle(mask):
    rng = np.random.default_rng(4)
    A = mg.modify_dual_coefficients(mg.DUAL_COEFFS_TRIANGLE, [mask])[0]
    pts = rng.uniform(0.0, 1.0, (40, 2))
    psi = mg.evaluate_dual(A, mg.shape_triangle(pts))
    np.testing.assert_allclose(psi.sum(axis=1), 1.0, atol=1e-14)  # constants reproduced
    m = np.array(mask)
    np.testing.assert_array_equal(psi[:, m], 0.0)
    # biorthogonality kept between free nodes; int psi~_j phi_b = int phi_b / n_free
    bary, w = mg.TRIANGLE_RULE
    gram = np.einsum("q,qj,qk->jk", w, mg.evaluate_dual(A, bary), bary)  # area 1
    free = ~m
    expected = np.diag(np.where(free, 1.0 / 3.0, 0.0))
    expected[np.ix_(free, m)] = (1.0 / 3.0) / free.sum()
    np.testing.assert_allclose(gram, expected, atol=1e-15)


# ----------------------------------------------------------------------------------
# normals
# ----------------------------------------------------------------------------------


def test_nodal_normals_circle_outward_any_ordering():
    rng = np.random.default_rng(5)
    n = 17
    th = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    pts = 2.0 * np.stack([np.cos(th), np.sin(th)], axis=1) + [1.0, -3.0]
    segs = np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)
    flip = rng.random(n) < 0.5
    segs[flip] = segs[flip, ::-1]
    interior = np.tile([1.0, -3.0], (n, 1))
    nrm = mg.nodal_normals(pts, segs, interior)
    radial = (pts - [1.0, -3.0]) / 2.0
    np.testing.assert_allclose(nrm, radial, atol=1e-14)
    fn, length = mg.facet_normals(pts, segs, interior)
    assert np.all(np.einsum("fg,fg->f", fn, pts[segs].mean(1) - [1.0, -3.0]) > 0)
    np.testing.assert_allclose(length, 2 * 2.0 * np.sin(np.pi / n), rtol=1e-14)
    t = mg.nodal_tangents(nrm)
    assert t.shape == (n, 1, 2)
    np.testing.assert_allclose(np.einsum("ng,ng->n", t[:, 0], nrm), 0.0, atol=1e-15)
    np.testing.assert_allclose(mg._cross2(nrm, t[:, 0]), 1.0, atol=1e-14)


def test_nodal_normals_area_weighted_3d():
    # two triangles sharing an edge (the y axis), unequal areas, "valley" shape
    pts = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 1.0], [3.0, 0.0, 3.0]])
    tris = np.array([[0, 1, 2], [0, 3, 1]])
    interior = np.array([[0.0, 0.5, -5.0], [0.0, 0.5, -5.0]])
    fn, area = mg.facet_normals(pts, tris, interior)
    np.testing.assert_allclose(fn[0], [1, 0, 1] / np.sqrt(2), atol=1e-15)
    np.testing.assert_allclose(fn[1], [-1, 0, 1] / np.sqrt(2), atol=1e-15)
    np.testing.assert_allclose(area, [np.sqrt(2) / 2, 3 * np.sqrt(2) / 2], rtol=1e-14)
    nrm = mg.nodal_normals(pts, tris, interior)
    expected = (area[0] * fn[0] + area[1] * fn[1]) / np.linalg.norm(area[0] * fn[0] + area[1] * fn[1])
    np.testing.assert_allclose(nrm[0], expected, atol=1e-15)
    np.testing.assert_allclose(nrm[2], fn[0], atol=1e-15)
    np.testing.assert_allclose(nrm[3], fn[1], atol=1e-15)


def test_nodal_normals_sphere_and_tangent_frames():
    rng = np.random.default_rng(6)
    pts, tris = sphere_cap(12, 0.6, 2.0, rng)
    tris[::3] = tris[::3, ::-1]  # inconsistent vertex ordering
    nrm = mg.nodal_normals(pts, tris, np.zeros((len(tris), 3)))
    radial = pts / 2.0
    # averaged normals of a perturbed faceted sphere: within a few degrees of radial
    assert np.all(np.einsum("ng,ng->n", nrm, radial) > 0.995)
    frame = mg.nodal_tangents(nrm)
    assert frame.shape == (len(pts), 2, 3)
    full = np.concatenate([nrm[:, None, :], frame], axis=1)
    np.testing.assert_allclose(
        np.einsum("nig,njg->nij", full, full), np.broadcast_to(np.eye(3), (len(pts), 3, 3)), atol=1e-14
    )
    np.testing.assert_allclose(np.cross(frame[:, 0], frame[:, 1]), nrm, atol=1e-14)


# ----------------------------------------------------------------------------------
# candidate search and clipping
# ----------------------------------------------------------------------------------


@pytest.mark.parametrize("gdim", [2, 3])
def test_candidate_pairs_match_brute_force(gdim):
    rng = np.random.default_rng(7 + gdim)
    ca, cb = rng.uniform(0, 1, (300, gdim)), rng.uniform(0, 1, (500, gdim))
    ha, hb = rng.uniform(0, 0.08, (300, gdim)), rng.uniform(0, 0.03, (500, gdim))
    ha[:5] *= 6.0  # a few large boxes
    amin, amax, bmin, bmax = ca - ha, ca + ha, cb - hb, cb + hb
    ia, ib = mg.find_candidate_pairs(amin, amax, bmin, bmax)
    brute = np.all((amin[:, None] <= bmax[None]) & (bmin[None] <= amax[:, None]), axis=2)
    bi, bj = np.nonzero(brute)
    np.testing.assert_array_equal(ia, bi)
    np.testing.assert_array_equal(ib, bj)
    for h in (0.005, 0.3):  # result independent of the grid spacing
        ja, jb = mg.find_candidate_pairs(amin, amax, bmin, bmax, cell_size=h)
        np.testing.assert_array_equal(ja, bi)
        np.testing.assert_array_equal(jb, bj)


def _inside(tri, p, eps=1e-13):
    s = [mg._cross2(tri[(i + 1) % 3] - tri[i], p - tri[i]) for i in range(3)]
    return all(v >= -eps for v in s) or all(v <= eps for v in s)


def _reference_intersection_area(a: np.ndarray, b: np.ndarray) -> float:
    """Area of triangle ∩ triangle by an independent method: vertices of each inside
    the other plus edge/edge intersections, sorted by angle, shoelace."""
    pts = [p for p in a if _inside(b, p)] + [p for p in b if _inside(a, p)]
    for i, j in itertools.product(range(3), range(3)):
        p, r = a[i], a[(i + 1) % 3] - a[i]
        q, s = b[j], b[(j + 1) % 3] - b[j]
        den = mg._cross2(r, s)
        if abs(den) < 1e-300:
            continue
        t = mg._cross2(q - p, s) / den
        u = mg._cross2(q - p, r) / den
        if 0.0 <= t <= 1.0 and 0.0 <= u <= 1.0:
            pts.append(p + t * r)
    if len(pts) < 3:
        return 0.0
    pts = np.array(pts)
    c = pts.mean(axis=0)
    pts = pts[np.argsort(np.arctan2(pts[:, 1] - c[1], pts[:, 0] - c[0]))]
    return 0.5 * abs(np.sum(mg._cross2(pts, np.roll(pts, -1, axis=0))))


def test_clipped_areas_random_triangle_pairs():
    rng = np.random.default_rng(8)
    n = 400
    a = rng.uniform(0, 1, (n, 3, 2))
    b = rng.uniform(0, 1, (n, 3, 2)) * rng.uniform(0.2, 1.0, (n, 1, 1)) + rng.uniform(0, 0.5, (n, 1, 2))
    b[:20] = a[:20] * 0.3 + 0.7 * a[:20].mean(axis=1, keepdims=True)  # b inside a
    b[20:40] = 3.0 * (a[20:40] - a[20:40].mean(axis=1, keepdims=True)) + a[20:40].mean(axis=1, keepdims=True)
    b[40:60] = a[40:60] + [5.0, 0.0]  # disjoint
    poly, count = mg.clip_polygons_by_triangles(b, np.full(n, 3), a)
    area = mg.polygon_areas(poly, count)
    ref = np.array([_reference_intersection_area(a[i], b[i]) for i in range(n)])
    np.testing.assert_allclose(area, ref, atol=1e-13)
    area_a = mg.polygon_areas(a, np.full(n, 3))
    area_b = mg.polygon_areas(b, np.full(n, 3))
    np.testing.assert_allclose(area[:20], area_b[:20], rtol=1e-12)
    np.testing.assert_allclose(area[20:40], area_a[20:40], rtol=1e-12)
    np.testing.assert_array_equal(area[40:60], 0.0)
    assert np.count_nonzero(area[60:] > 0) > 100
    # symmetric in the roles of subject and clip triangle
    poly2, count2 = mg.clip_polygons_by_triangles(a, np.full(n, 3), b)
    np.testing.assert_allclose(mg.polygon_areas(poly2, count2), area, atol=1e-13)
    # fan-quadrature weights of the clipped polygons integrate 1 to the same area
    _, wq = mg._fan_quadrature(poly, count)
    np.testing.assert_allclose(wq.sum(axis=1), area, atol=1e-13)


def test_clipped_areas_monte_carlo():
    rng = np.random.default_rng(9)
    a = rng.uniform(0, 1, (8, 3, 2))
    b = rng.uniform(0, 1, (8, 3, 2))
    poly, count = mg.clip_polygons_by_triangles(b, np.full(8, 3), a)
    area = mg.polygon_areas(poly, count)
    pts = rng.uniform(0, 1, (200_000, 2))

    def inside(tri):
        s = np.stack([mg._cross2(tri[(i + 1) % 3] - tri[i], pts - tri[i]) for i in range(3)], axis=1)
        return np.all(s >= 0, axis=1) | np.all(s <= 0, axis=1)

    for i in range(8):
        mc = np.mean(inside(a[i]) & inside(b[i]))
        assert abs(mc - area[i]) < 5e-3


def test_clipped_areas_tile_square():
    rng = np.random.default_rng(10)
    ps, ts = square_grid(7, 0.0, 1.0, rng, perturb=0.3)
    pm, tm = square_grid(19, 0.0, 1.0, rng, perturb=0.3, flip=True)
    ia, ib = mg.find_candidate_pairs(*mg.facet_bounding_boxes(ps, ts), *mg.facet_bounding_boxes(pm, tm))
    poly, count = mg.clip_polygons_by_triangles(pm[tm[ib]], np.full(len(ia), 3), ps[ts[ia]])
    area = mg.polygon_areas(poly, count)
    assert abs(area.sum() - 1.0) < 1e-12
    per_slave = np.bincount(ia, weights=area, minlength=len(ts))
    np.testing.assert_allclose(per_slave, mg.polygon_areas(ps[ts], np.full(len(ts), 3)), atol=1e-14)
    # the same through the 3D pipeline (master lifted off the plane by a gap)
    xs = np.column_stack([ps, np.zeros(len(ps))])
    xm = np.column_stack([pm, np.full(len(pm), 0.05)])
    ns = mg.nodal_normals(xs, ts, xs[ts].mean(axis=1) - [0, 0, 1])
    res = mg.assemble_mortar(xs, ts, ns, xm, tm, search_radius=0.1)
    assert abs(res.covered_area.sum() - 1.0) < 1e-12
    np.testing.assert_allclose(res.covered_area, res.facet_area, atol=1e-14)


def test_projection_onto_segment_interpolated_normal():
    rng = np.random.default_rng(11)
    n = 200
    x1, x2 = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
    t = x2 - x1
    nf = np.stack([t[:, 1], -t[:, 0]], 1) / np.linalg.norm(t, axis=1, keepdims=True)
    n1 = mg._normalise(nf + 0.3 * rng.normal(size=(n, 2)))
    n2 = mg._normalise(nf + 0.3 * rng.normal(size=(n, 2)))
    xi_true = rng.uniform(-0.2, 1.2, n)
    dist = rng.uniform(-0.3, 0.3, n)
    nx = (1 - xi_true)[:, None] * n1 + xi_true[:, None] * n2
    p = (1 - xi_true)[:, None] * x1 + xi_true[:, None] * x2 + dist[:, None] * nx
    xi = mg.project_points_to_segments_interpolated_normal(p, x1, x2, n1, n2)
    np.testing.assert_allclose(xi, xi_true, atol=1e-9)
    eta = mg.project_points_to_lines_along_directions(p - 0.5 * nx, nx, x1, x2)
    np.testing.assert_allclose(eta, xi_true, atol=1e-9)


# ----------------------------------------------------------------------------------
# pair integrals
# ----------------------------------------------------------------------------------


def test_segment_pair_partial_overlap_exact():
    g = 0.1
    xs = np.array([[[0.0, 0.0], [2.0, 0.0]]])
    ns = np.array([[[0.0, 1.0], [0.0, 1.0]]])
    xm = np.array([[[1.5, g], [0.5, g]]])  # reversed orientation
    res = mg.integrate_segment_pairs(xs, ns, xm)
    # independent: exact polynomial integrals over xi in [0.25, 0.75], ds = 2 dxi
    P = np.polynomial.Polynomial
    phi = [P([1, -1]), P([0, 1])]
    psi = [P([2, -3]), P([-1, 3])]
    # master: y(eta) = 1.5 - eta, hit at x = 2 xi  =>  eta = 1.5 - 2 xi
    eta = [P([-0.5, 2.0]), P([1.5, -2.0])]

    def integ(p):
        q = p.integ()
        return 2.0 * (q(0.75) - q(0.25))

    D = np.array([[integ(psi[j] * phi[k]) for k in range(2)] for j in range(2)])
    M = np.array([[integ(psi[j] * eta[k]) for k in range(2)] for j in range(2)])
    np.testing.assert_allclose(res.area, [1.0], rtol=1e-15)
    np.testing.assert_allclose(res.d[0], D, atol=1e-15)
    np.testing.assert_allclose(res.m[0], M, atol=1e-15)
    np.testing.assert_allclose(res.gap[0], g * np.array([integ(psi[0]), integ(psi[1])]), atol=1e-15)


def test_triangle_pair_tilted_master_affine_exactness():
    """Contained, tilted master: phi^m o Pi is affine on the slave, so
    M[j, k] = D[j, j] phi^m_k(Pi x_j) exactly (Pi: projection along n_s)."""
    rng = np.random.default_rng(12)
    for _ in range(10):
        xs = rng.normal(size=(3, 3))
        n_s = np.cross(xs[1] - xs[0], xs[2] - xs[0])
        n_s /= np.linalg.norm(n_s)
        c = xs.mean(axis=0)
        # master: enlarged copy of the slave, rotated slightly out of plane and shifted along n_s
        axis = mg._normalise(rng.normal(size=3))
        ang = 0.3
        K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        R = np.eye(3) + np.sin(ang) * K + (1 - np.cos(ang)) * K @ K
        xm = (3.0 * (xs - c)) @ R.T + c + 0.05 * n_s
        # project slave vertices along n_s onto the master plane, barycentrics there
        n_m = np.cross(xm[1] - xm[0], xm[2] - xm[0])
        t = ((xm[0] - xs) @ n_m) / (n_s @ n_m)
        proj = xs + t[:, None] * n_s
        B = np.linalg.lstsq(np.column_stack([xm[1] - xm[0], xm[2] - xm[0]]), (proj - xm[0]).T, rcond=None)[
            0
        ].T
        lam = np.column_stack([1 - B.sum(axis=1), B])
        if np.any(lam < 0):  # projected master must contain the slave for the identity
            continue
        ns = np.tile(n_s, (3, 1))
        res = mg.integrate_triangle_pairs(xs[None], ns[None], xm[None])
        area = 0.5 * np.linalg.norm(np.cross(xs[1] - xs[0], xs[2] - xs[0]))
        np.testing.assert_allclose(res.area[0], area, rtol=1e-13)
        np.testing.assert_allclose(res.d[0], area / 3 * np.eye(3), atol=1e-14 * area)
        np.testing.assert_allclose(res.m[0], area / 3 * lam, atol=1e-13 * area)
        # gap is affine too: int psi_j g = D_jj g(x_j), g along n_s = t
        np.testing.assert_allclose(res.gap[0], area / 3 * t, atol=1e-13 * area)


def test_triangle_pair_clipped_area_in_slave_plane():
    """Overlap area of random non-coplanar 3D pairs against the independent 2D
    intersection in an orthonormal frame of the slave plane."""
    rng = np.random.default_rng(13)
    n = 300
    xs = rng.normal(size=(n, 3, 3))
    xm = xs + 0.5 * rng.normal(size=(n, 3, 3))
    ns = np.repeat(mg._normalise(np.cross(xs[:, 1] - xs[:, 0], xs[:, 2] - xs[:, 0]))[:, None], 3, axis=1)
    res = mg.integrate_triangle_pairs(xs, ns, xm)
    ref = np.empty(n)
    for i in range(n):
        e1 = mg._normalise(xs[i, 1] - xs[i, 0])
        e2 = np.cross(ns[i, 0], e1)
        frame = np.stack([e1, e2], axis=1)
        ref[i] = _reference_intersection_area((xs[i] - xs[i, 0]) @ frame, (xm[i] - xs[i, 0]) @ frame)
    np.testing.assert_allclose(res.area, ref, atol=1e-12)
    assert np.count_nonzero(ref > 0) > 150
    # sum_k M[j, k] = int_overlap psi_j = sum_k D[j, k]
    np.testing.assert_allclose(res.m.sum(axis=2), res.d.sum(axis=2), atol=1e-12)


# ----------------------------------------------------------------------------------
# assembled D, M, gap
# ----------------------------------------------------------------------------------


def test_row_sums_2d_nonmatching_arc():
    R, g = 1.0, 0.01
    xs, fs = arc(7, R, 0.2, 1.3)
    xm, fm = arc(23, R + g, 0.15, 1.35)
    fm = fm[:, ::-1]  # master facing the other way
    ns = mg.nodal_normals(xs, fs, np.zeros((len(fs), 2)))
    res = mg.assemble_mortar(xs, fs, ns, xm, fm, search_radius=0.05)
    covered = res.fully_covered_nodes(fs, rtol=1e-12)
    assert covered.all()
    np.testing.assert_allclose(res.covered_area, res.facet_area, rtol=1e-13)
    np.testing.assert_allclose(res.d, lumped(xs, fs), rtol=1e-13)
    np.testing.assert_allclose(row_sums(res, len(xs)), res.d, atol=1e-12)
    assert len(res.d_off_vals) == 0
    assert res.m_cols.max() < len(xm) and res.m_rows.max() < len(xs)
    # the nodal gap is g up to the chord sagittas of the polygonal arcs
    sag_s = R * (1 - np.cos(1.1 / 7 / 2))
    sag_m = (R + g) * (1 - np.cos(1.2 / 23 / 2))
    assert np.all(res.gap / res.d >= g - sag_m) and np.all(res.gap / res.d <= g + sag_s)
    # partially covered slave (master shorter): the overlap identity still holds row-wise
    xm2, fm2 = arc(23, R + g, 0.5, 1.0)
    part = mg.assemble_mortar(xs, fs, ns, xm2, fm2, search_radius=0.05)
    full = part.fully_covered_nodes(fs, rtol=1e-12)
    assert 0 < full.sum() < len(xs)
    rs = row_sums(part, len(xs))
    np.testing.assert_allclose(rs[full], part.d[full], atol=1e-12)
    off = np.bincount(part.d_off_rows, weights=part.d_off_vals, minlength=len(xs))
    np.testing.assert_allclose(rs, part.d + off, atol=1e-12)
    assert len(part.d_off_vals) > 0


def test_weighted_gap_and_linear_reproduction_2d_flat():
    rng = np.random.default_rng(14)
    g = 0.037
    xs, fs = line(9, 0.0, 1.0, 0.0, rng, perturb=0.3)
    xm, fm = line(31, -0.1, 1.1, g, rng, perturb=0.3)
    ns = mg.nodal_normals(xs, fs, xs[fs].mean(axis=1) - [0.0, 1.0])
    np.testing.assert_allclose(ns, np.tile([0.0, 1.0], (len(xs), 1)), atol=1e-15)
    res = mg.assemble_mortar(xs, fs, ns, xm, fm, search_radius=0.1)
    np.testing.assert_allclose(res.gap, g * res.d, atol=1e-12)
    np.testing.assert_allclose(row_sums(res, len(xs)), res.d, atol=1e-12)
    # flat, parallel: M reproduces linear functions, M x_m = D x_s
    mx = np.bincount(res.m_rows, weights=res.m_vals * xm[res.m_cols, 0], minlength=len(xs))
    np.testing.assert_allclose(mx, res.d * xs[:, 0], atol=1e-12)


def test_boundary_mask_2d():
    rng = np.random.default_rng(15)
    xs, fs = line(8, 0.0, 1.0, 0.0, rng, perturb=0.3)
    xm, fm = line(20, -0.1, 1.1, 0.02, rng, perturb=0.3)
    ns = mg.nodal_normals(xs, fs, xs[fs].mean(axis=1) - [0.0, 1.0])
    mask = np.zeros(len(xs), dtype=bool)
    mask[[0, -1]] = True
    res = mg.assemble_mortar(xs, fs, ns, xm, fm, slave_node_mask=mask, search_radius=0.1)
    np.testing.assert_array_equal(res.d[mask], 0.0)
    np.testing.assert_array_equal(res.gap[mask], 0.0)
    assert not np.any(np.isin(res.m_rows[np.abs(res.m_vals) > 0], np.flatnonzero(mask)))
    # interior node of each end segment: psi~ = 1, so D = int phi_p, extra coupling to the end node
    np.testing.assert_allclose(res.d[~mask], lumped(xs, fs)[~mask], rtol=1e-13)
    L0 = np.linalg.norm(xs[1] - xs[0])
    assert set(zip(res.d_off_rows.tolist(), res.d_off_cols.tolist())) == {(1, 0), (len(xs) - 2, len(xs) - 1)}
    np.testing.assert_allclose(res.d_off_vals[res.d_off_rows == 1], L0 / 2, rtol=1e-13)
    off = np.bincount(res.d_off_rows, weights=res.d_off_vals, minlength=len(xs))
    np.testing.assert_allclose(row_sums(res, len(xs)), res.d + off, atol=1e-12)
    np.testing.assert_allclose(res.gap, 0.02 * (res.d + off), atol=1e-12)


def test_row_sums_3d_flat_nonmatching():
    rng = np.random.default_rng(16)
    g = 0.013
    xs, fs = flat_surface(6, 0.0, 1.0, 0.0, rng, perturb=0.3)
    xm, fm = flat_surface(17, -0.05, 1.05, g, rng, perturb=0.3, flip=True)
    fm[::2] = fm[::2, ::-1]
    ns = mg.nodal_normals(xs, fs, xs[fs].mean(axis=1) - [0.0, 0.0, 1.0])
    np.testing.assert_allclose(ns, np.tile([0.0, 0.0, 1.0], (len(xs), 1)), atol=1e-15)
    res = mg.assemble_mortar(xs, fs, ns, xm, fm, search_radius=0.05)
    assert res.fully_covered_nodes(fs, rtol=1e-12).all()
    assert abs(res.covered_area.sum() - 1.0) < 1e-12
    np.testing.assert_allclose(res.d, lumped(xs, fs), rtol=1e-12)
    np.testing.assert_allclose(row_sums(res, len(xs)), res.d, atol=1e-12)
    np.testing.assert_allclose(res.gap, g * res.d, atol=1e-12)
    for c in range(2):  # linear reproduction (flat, parallel)
        mx = np.bincount(res.m_rows, weights=res.m_vals * xm[res.m_cols, c], minlength=len(xs))
        np.testing.assert_allclose(mx, res.d * xs[:, c], atol=1e-12)
    assert len(res.d_off_vals) == 0


def test_row_sums_3d_flat_same_extent():
    """Master with exactly the slave's extent: boundary edges coincide."""
    rng = np.random.default_rng(17)
    xs, fs = flat_surface(5, 0.0, 1.0, 0.0, rng, perturb=0.3)
    xm, fm = flat_surface(11, 0.0, 1.0, 0.02, rng, perturb=0.3, flip=True)
    ns = mg.nodal_normals(xs, fs, xs[fs].mean(axis=1) - [0.0, 0.0, 1.0])
    res = mg.assemble_mortar(xs, fs, ns, xm, fm, search_radius=0.05)
    assert abs(res.covered_area.sum() - 1.0) < 1e-12
    np.testing.assert_allclose(res.d, lumped(xs, fs), atol=1e-12)
    np.testing.assert_allclose(row_sums(res, len(xs)), res.d, atol=1e-12)
    np.testing.assert_allclose(res.gap, 0.02 * res.d, atol=1e-12)


def test_row_sums_3d_curved():
    rng = np.random.default_rng(18)
    R, g = 2.0, 0.01
    xs, fs = sphere_cap(6, 0.4, R, rng, perturb=0.25)
    xm, fm = sphere_cap(19, 0.5, R + g, rng, perturb=0.25, flip=True)
    ns = mg.nodal_normals(xs, fs, np.zeros((len(fs), 3)))
    res = mg.assemble_mortar(xs, fs, ns, xm, fm, search_radius=0.1)
    covered = res.fully_covered_nodes(fs, rtol=1e-12)
    assert covered.all()
    np.testing.assert_allclose(res.covered_area, res.facet_area, rtol=1e-12)
    np.testing.assert_allclose(res.d, lumped(xs, fs), rtol=1e-12)
    np.testing.assert_allclose(row_sums(res, len(xs)), res.d, atol=1e-12)

    # curved: the nodal gap is g up to the (O(h^2)) sagittas of the faceted spheres
    def sagitta(x, f, r):
        e = np.linalg.norm(x[f] - x[np.roll(f, 1, axis=1)], axis=2).max()
        return e**2 / (8 * r)

    tol = 2 * (sagitta(xs, fs, R) + sagitta(xm, fm, R + g))
    np.testing.assert_allclose(res.gap / res.d, g, atol=tol)


def test_boundary_mask_and_partial_cover_3d():
    rng = np.random.default_rng(19)
    xs, fs = flat_surface(5, 0.0, 1.0, 0.0, rng, perturb=0.3)
    xm, fm = flat_surface(13, 0.2, 1.05, 0.01, rng, perturb=0.3, flip=True)
    ns = mg.nodal_normals(xs, fs, xs[fs].mean(axis=1) - [0.0, 0.0, 1.0])
    mask = np.isclose(xs[:, 0], 1.0)  # multiplier vanishes on the right edge
    res = mg.assemble_mortar(xs, fs, ns, xm, fm, slave_node_mask=mask, search_radius=0.05)
    np.testing.assert_array_equal(res.d[mask], 0.0)
    full = res.fully_covered_nodes(fs, rtol=1e-12) & ~mask
    partial_facets = ~res.fully_covered_facets(rtol=1e-12)
    assert full.sum() > 0 and partial_facets.sum() > 0
    off = np.bincount(res.d_off_rows, weights=res.d_off_vals, minlength=len(xs))
    rs = row_sums(res, len(xs))
    np.testing.assert_allclose(rs, res.d + off, atol=1e-12)  # every row, covered or not
    np.testing.assert_allclose(res.gap, 0.01 * (res.d + off), atol=1e-12)
    untouched = full & (
        np.bincount(fs[np.isin(fs, np.flatnonzero(mask)).any(axis=1)].ravel(), minlength=len(xs)) == 0
    )
    assert untouched.sum() > 0
    np.testing.assert_allclose(rs[untouched], res.d[untouched], atol=1e-12)
    np.testing.assert_allclose(res.d[untouched], lumped(xs, fs)[untouched], rtol=1e-12)


def test_empty_inputs():
    xs, fs = flat_surface(2, 0.0, 1.0, 0.0, np.random.default_rng(0))
    ns = mg.nodal_normals(xs, fs)
    far, ffar = flat_surface(2, 10.0, 11.0, 0.0, np.random.default_rng(0))
    res = mg.assemble_mortar(xs, fs, ns, far, ffar, search_radius=0.1)
    assert len(res.m_vals) == 0 and np.all(res.d == 0) and np.all(res.covered_area == 0)
    res = mg.assemble_mortar(xs, fs[:0], ns, far, ffar)
    assert len(res.covered_area) == 0 and len(res.m_vals) == 0
