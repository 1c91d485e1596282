"""Tests of the mortar integrals and the assembled D, M and weighted gap
(docs/theory/mortar.md#mortar-matrices, docs/theory/verification.md#verification-references "D, M").

Pure NumPy: safe to run redundantly on every rank under
``mpiexec -n 2 python -m mpi4py -m pytest``.
"""

from __future__ import annotations

import numpy as np
from mortar_meshes import (
    arc,
    flat_surface,
    line,
    lumped,
    quadrature_triangle_pair_integrals,
    reference_intersection_area,
    row_sums,
    sphere_cap,
)

from bonecontact.contact.geometry import nodal_normals, normalise
from bonecontact.contact.mortar_assembly import (
    assemble_mortar,
    coincident_pairs,
    integrate_segment_pairs,
    integrate_triangle_pairs,
)


def test_segment_pair_partial_overlap_exact():
    g = 0.1
    xs = np.array([[[0.0, 0.0], [2.0, 0.0]]])
    ns = np.array([[[0.0, 1.0], [0.0, 1.0]]])
    xm = np.array([[[1.5, g], [0.5, g]]])  # reversed orientation
    res = integrate_segment_pairs(xs, ns, xm)
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
        axis = normalise(rng.normal(size=3))
        ang = 0.3
        K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        R = np.eye(3) + np.sin(ang) * K + (1 - np.cos(ang)) * K @ K
        xm = (3.0 * (xs - c)) @ R.T + c + 0.05 * n_s
        # project slave vertices along n_s onto the master plane, barycentrics there
        n_m = np.cross(xm[1] - xm[0], xm[2] - xm[0])
        t = ((xm[0] - xs) @ n_m) / (n_s @ n_m)
        proj = xs + t[:, None] * n_s
        B = np.linalg.lstsq(
            np.column_stack([xm[1] - xm[0], xm[2] - xm[0]]), (proj - xm[0]).T, rcond=None
        )[0].T
        lam = np.column_stack([1 - B.sum(axis=1), B])
        if np.any(lam < 0):  # projected master must contain the slave for the identity
            continue
        ns = np.tile(n_s, (3, 1))
        res = integrate_triangle_pairs(xs[None], ns[None], xm[None])
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
    ns = np.repeat(
        normalise(np.cross(xs[:, 1] - xs[:, 0], xs[:, 2] - xs[:, 0]))[:, None], 3, axis=1
    )
    res = integrate_triangle_pairs(xs, ns, xm)
    ref = np.empty(n)
    for i in range(n):
        e1 = normalise(xs[i, 1] - xs[i, 0])
        e2 = np.cross(ns[i, 0], e1)
        frame = np.stack([e1, e2], axis=1)
        ref[i] = reference_intersection_area((xs[i] - xs[i, 0]) @ frame, (xm[i] - xs[i, 0]) @ frame)
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
    ns = nodal_normals(xs, fs, np.zeros((len(fs), 2)))
    res = assemble_mortar(xs, fs, ns, xm, fm, search_radius=0.05)
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
    # partially covered slave (master shorter): the dual basis of the partly covered
    # segments is biorthogonal on their covered part, so sum_q M_pq = D_pp on every row
    xm2, fm2 = arc(23, R + g, 0.5, 1.0)
    part = assemble_mortar(xs, fs, ns, xm2, fm2, search_radius=0.05)
    full = part.fully_covered_nodes(fs, rtol=1e-12)
    assert 0 < full.sum() < len(xs)
    np.testing.assert_allclose(row_sums(part, len(xs)), part.d, atol=1e-12)
    assert len(part.d_off_vals) == 0


def test_weighted_gap_and_linear_reproduction_2d_flat():
    rng = np.random.default_rng(14)
    g = 0.037
    xs, fs = line(9, 0.0, 1.0, 0.0, rng, perturb=0.3)
    xm, fm = line(31, -0.1, 1.1, g, rng, perturb=0.3)
    ns = nodal_normals(xs, fs, xs[fs].mean(axis=1) - [0.0, 1.0])
    np.testing.assert_allclose(ns, np.tile([0.0, 1.0], (len(xs), 1)), atol=1e-15)
    res = assemble_mortar(xs, fs, ns, xm, fm, search_radius=0.1)
    np.testing.assert_allclose(res.gap, g * res.d, atol=1e-12)
    np.testing.assert_allclose(row_sums(res, len(xs)), res.d, atol=1e-12)
    # flat, parallel: M reproduces linear functions, M x_m = D x_s
    mx = np.bincount(res.m_rows, weights=res.m_vals * xm[res.m_cols, 0], minlength=len(xs))
    np.testing.assert_allclose(mx, res.d * xs[:, 0], atol=1e-12)


def test_boundary_mask_2d():
    rng = np.random.default_rng(15)
    xs, fs = line(8, 0.0, 1.0, 0.0, rng, perturb=0.3)
    xm, fm = line(20, -0.1, 1.1, 0.02, rng, perturb=0.3)
    ns = nodal_normals(xs, fs, xs[fs].mean(axis=1) - [0.0, 1.0])
    mask = np.zeros(len(xs), dtype=bool)
    mask[[0, -1]] = True
    res = assemble_mortar(xs, fs, ns, xm, fm, slave_node_mask=mask, search_radius=0.1)
    np.testing.assert_array_equal(res.d[mask], 0.0)
    np.testing.assert_array_equal(res.gap[mask], 0.0)
    assert not np.any(np.isin(res.m_rows[np.abs(res.m_vals) > 0], np.flatnonzero(mask)))
    # interior node of each end segment: psi~ = 1, so D = int phi_p, extra coupling to the end node
    np.testing.assert_allclose(res.d[~mask], lumped(xs, fs)[~mask], rtol=1e-13)
    L0 = np.linalg.norm(xs[1] - xs[0])
    assert set(zip(res.d_off_rows.tolist(), res.d_off_cols.tolist())) == {
        (1, 0),
        (len(xs) - 2, len(xs) - 1),
    }
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
    ns = nodal_normals(xs, fs, xs[fs].mean(axis=1) - [0.0, 0.0, 1.0])
    np.testing.assert_allclose(ns, np.tile([0.0, 0.0, 1.0], (len(xs), 1)), atol=1e-15)
    res = assemble_mortar(xs, fs, ns, xm, fm, search_radius=0.05)
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
    ns = nodal_normals(xs, fs, xs[fs].mean(axis=1) - [0.0, 0.0, 1.0])
    res = assemble_mortar(xs, fs, ns, xm, fm, search_radius=0.05)
    assert abs(res.covered_area.sum() - 1.0) < 1e-12
    np.testing.assert_allclose(res.d, lumped(xs, fs), atol=1e-12)
    np.testing.assert_allclose(row_sums(res, len(xs)), res.d, atol=1e-12)
    np.testing.assert_allclose(res.gap, 0.02 * res.d, atol=1e-12)


def test_row_sums_3d_curved():
    rng = np.random.default_rng(18)
    R, g = 2.0, 0.01
    xs, fs = sphere_cap(6, 0.4, R, rng, perturb=0.25)
    xm, fm = sphere_cap(19, 0.5, R + g, rng, perturb=0.25, flip=True)
    ns = nodal_normals(xs, fs, np.zeros((len(fs), 3)))
    res = assemble_mortar(xs, fs, ns, xm, fm, search_radius=0.1)
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
    ns = nodal_normals(xs, fs, xs[fs].mean(axis=1) - [0.0, 0.0, 1.0])
    mask = np.isclose(xs[:, 0], 1.0)  # multiplier vanishes on the right edge
    res = assemble_mortar(xs, fs, ns, xm, fm, slave_node_mask=mask, search_radius=0.05)
    np.testing.assert_array_equal(res.d[mask], 0.0)
    full = res.fully_covered_nodes(fs, rtol=1e-12) & ~mask
    partial_facets = ~res.fully_covered_facets(rtol=1e-12)
    assert full.sum() > 0 and partial_facets.sum() > 0
    off = np.bincount(res.d_off_rows, weights=res.d_off_vals, minlength=len(xs))
    rs = row_sums(res, len(xs))
    np.testing.assert_allclose(rs, res.d + off, atol=1e-12)  # every row, covered or not
    np.testing.assert_allclose(res.gap, 0.01 * (res.d + off), atol=1e-12)
    untouched = full & (
        np.bincount(fs[np.isin(fs, np.flatnonzero(mask)).any(axis=1)].ravel(), minlength=len(xs))
        == 0
    )
    assert untouched.sum() > 0
    np.testing.assert_allclose(rs[untouched], res.d[untouched], atol=1e-12)
    np.testing.assert_allclose(res.d[untouched], lumped(xs, fs)[untouched], rtol=1e-12)


def test_empty_inputs():
    xs, fs = flat_surface(2, 0.0, 1.0, 0.0, np.random.default_rng(0))
    ns = nodal_normals(xs, fs)
    far, ffar = flat_surface(2, 10.0, 11.0, 0.0, np.random.default_rng(0))
    res = assemble_mortar(xs, fs, ns, far, ffar, search_radius=0.1)
    assert len(res.m_vals) == 0 and np.all(res.d == 0) and np.all(res.covered_area == 0)
    res = assemble_mortar(xs, fs[:0], ns, far, ffar)
    assert len(res.covered_area) == 0 and len(res.m_vals) == 0


def test_fast_path_equals_all_pairs_quadrature_3d():
    """Curved slave over a wavy, non-matching master: D, M and the weighted gap of
    assemble_mortar (swept-box search, exact polygon moments for D and M, gap by
    quadratic forms on the fan rule) equal, to 1e-12, an assembly over ALL facet pairs
    with quadrature at every point (the previous implementation)."""
    rng = np.random.default_rng(21)
    xs, fs = sphere_cap(7, 0.2, 2.0, rng, perturb=0.25)
    xs[:, 2] -= 2.0  # apex at the origin, normals up
    xm, fm = flat_surface(15, -0.45, 0.45, 0.0, rng, perturb=0.3, flip=True)
    xm[:, 2] = 0.02 + 0.01 * np.sin(7.0 * xm[:, 0]) * np.cos(5.0 * xm[:, 1])
    ns = nodal_normals(xs, fs, xs[fs].mean(axis=1) - [0.0, 0.0, 1.0])
    res = assemble_mortar(xs, fs, ns, xm, fm, search_radius=0.2)  # > the largest gap

    every_s, every_m = (a.ravel() for a in np.meshgrid(np.arange(len(fs)), np.arange(len(fm))))
    with np.errstate(divide="ignore", invalid="ignore"):
        area, d, m, gap = quadrature_triangle_pair_integrals(
            xs[fs[every_s]], ns[fs[every_s]], xm[fm[every_m]]
        )
    live = area > 0.0
    sf, mf = every_s[live], every_m[live]
    assert np.array_equal(np.unique(sf), np.arange(len(fs)))  # every slave facet covered
    d_ref = np.bincount(fs[sf].ravel(), np.einsum("pjj->pj", d[live]).ravel(), len(xs))
    gap_ref = np.bincount(fs[sf].ravel(), gap[live].ravel(), len(xs))
    m_ref = np.zeros((len(xs), len(xm)))
    np.add.at(m_ref, (fs[sf][:, :, None], fm[mf][:, None, :]), m[live])
    m_fast = np.zeros_like(m_ref)
    np.add.at(m_fast, (res.m_rows, res.m_cols), res.m_vals)
    scale = d_ref.max()
    np.testing.assert_allclose(res.d, d_ref, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(m_fast, m_ref, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(res.gap, gap_ref, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(res.covered_area, res.facet_area, rtol=1e-12)
    np.testing.assert_allclose(row_sums(res, len(xs)), res.d, atol=1e-12 * scale)
    assert np.ptp(res.gap / res.d) > 0.005  # the gap really varies over the interface


def test_coincident_pairs_are_the_facets_on_each_other():
    """``coincident_pairs``: segments and triangles whose vertices are the slave's (in any
    order) are kept; one moved by 10 tolerances, or sharing only a vertex (the adjacent
    facet at a kink), is not."""
    tol = 1e-10
    s2 = np.array([[[0.0, 0.0], [1.0, 0.0]]] * 4)
    m2 = np.array(
        [
            [[1.0, 0.0], [0.0, 0.0]],  # the same, reversed
            [[0.0, 0.5 * tol], [1.0, 0.0]],  # within the tolerance
            [[0.0, 10 * tol], [1.0, 0.0]],  # moved
            [[1.0, 0.0], [1.3, 0.9]],  # shares a vertex only
        ]
    )
    assert coincident_pairs(s2, m2, tol).tolist() == [True, True, False, False]
    tri = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    s3 = np.array([tri] * 3)
    m3 = np.array([tri[[2, 0, 1]], tri + [0.0, 0.0, 10 * tol], tri[[0, 1]].tolist() + [[1, 1, 0]]])
    assert coincident_pairs(s3, m3, tol).tolist() == [True, False, False]
