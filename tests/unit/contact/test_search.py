"""Tests of the candidate search between slave and master facets
(docs/theory/mortar.md#candidate-search).

Every search result is compared with a brute-force reference over all pairs.

Pure NumPy: safe to run redundantly on every rank under
``mpiexec -n 2 python -m mpi4py -m pytest``.
"""

from __future__ import annotations

import numpy as np
import pytest
from mortar_meshes import sphere_cap, square_grid

from bonecontact.contact.geometry import facet_normals, nodal_normals
from bonecontact.contact.mortar_assembly import compute_mortar_pairs, integrate_triangle_pairs
from bonecontact.contact.search import (
    facet_bounding_boxes,
    find_candidate_pairs,
    swept_facet_boxes,
)


def _brute_force_boxes(amin, amax, bmin, bmax):
    """All intersecting box pairs by testing every pair."""
    hit = np.all((amin[:, None] <= bmax[None]) & (bmin[None] <= amax[:, None]), axis=2)
    return np.nonzero(hit)


@pytest.mark.parametrize("gdim", [2, 3])
def test_candidate_pairs_match_brute_force(gdim):
    rng = np.random.default_rng(7 + gdim)
    ca, cb = rng.uniform(0, 1, (300, gdim)), rng.uniform(0, 1, (500, gdim))
    ha, hb = rng.uniform(0, 0.08, (300, gdim)), rng.uniform(0, 0.03, (500, gdim))
    ha[:5] *= 6.0  # a few large boxes
    hb[:20, 0] *= 10.0  # long thin boxes
    hb[20:40, 1] = 0.0  # flat boxes
    amin, amax, bmin, bmax = ca - ha, ca + ha, cb - hb, cb + hb
    amax[7] = bmin[3]  # a pair of touching boxes counts
    ia, ib = find_candidate_pairs(amin, amax, bmin, bmax)
    bi, bj = _brute_force_boxes(amin, amax, bmin, bmax)
    assert len(bi) > 300
    np.testing.assert_array_equal(ia, bi)
    np.testing.assert_array_equal(ib, bj)
    # a single box on either side, and no box at all
    for sel_a, sel_b in ((slice(3, 4), slice(None)), (slice(None), slice(9, 10))):
        ja, jb = find_candidate_pairs(amin[sel_a], amax[sel_a], bmin[sel_b], bmax[sel_b])
        ri, rj = _brute_force_boxes(amin[sel_a], amax[sel_a], bmin[sel_b], bmax[sel_b])
        np.testing.assert_array_equal(ja, ri)
        np.testing.assert_array_equal(jb, rj)
    ja, jb = find_candidate_pairs(amin[:0], amax[:0], bmin, bmax)
    assert ja.size == 0 and jb.size == 0


def _wavy_sheet(n, rng, z0, amplitude):
    """A random-ish curved 3D surface: perturbed grid on [-1, 1]^2 lifted by waves."""
    pts, tris = square_grid(n, -1.0, 1.0, rng, perturb=0.3)
    z = z0 + amplitude * np.sin(2.3 * pts[:, 0] + 0.7) * np.cos(1.7 * pts[:, 1] - 0.4)
    return np.column_stack([pts, z]), tris


def test_swept_boxes_hold_the_swept_points_and_no_more():
    """Each swept box is the box of the facet's vertices moved by ±r along the unit
    facet normal (and, if given, along every nodal normal)."""
    rng = np.random.default_rng(3)
    x, tris = _wavy_sheet(6, rng, 0.0, 0.3)
    r = rng.uniform(0.01, 0.2, len(tris))
    n_f, _ = facet_normals(x, tris)
    lo, hi = swept_facet_boxes(x, tris, r)
    for f in range(len(tris)):
        v = x[tris[f]]
        pts = np.concatenate([v, v + r[f] * n_f[f], v - r[f] * n_f[f]])
        np.testing.assert_allclose(lo[f], pts.min(axis=0), atol=1e-15)
        np.testing.assert_allclose(hi[f], pts.max(axis=0), atol=1e-15)
        # random points x + s n with x on the facet and |s| <= r lie inside the box
        w = rng.dirichlet(np.ones(3), 20)
        s = rng.uniform(-r[f], r[f], (20, 1))
        p = w @ v + s * n_f[f]
        assert np.all(p >= lo[f] - 1e-15) and np.all(p <= hi[f] + 1e-15)
    nn = nodal_normals(x, tris)
    lo2, hi2 = swept_facet_boxes(x, tris, r, nn)
    v = x[tris]
    for k in range(3):
        for sign in (1.0, -1.0):
            moved = v + sign * r[:, None, None] * nn[tris][:, k : k + 1, :]
            assert np.all(moved.min(axis=1) >= lo2 - 1e-15)
            assert np.all(moved.max(axis=1) <= hi2 + 1e-15)


def test_search_on_curved_surface_matches_brute_force():
    """Wavy slave sheet over a wavy master sheet (both random-ish, non-matching): the
    search returns exactly the box pairs that a test of every pair returns, and the
    integrated pairs are exactly those of all pairs whose projections overlap."""
    rng = np.random.default_rng(11)
    xs, fs = _wavy_sheet(9, rng, 0.05, 0.08)
    xm, fm = _wavy_sheet(13, rng, 0.0, 0.08)
    xm[:, :2] = 1.1 * xm[:, :2] + 0.03  # master a bit larger, shifted
    ns = nodal_normals(xs, fs, xs[fs].mean(axis=1) + [0.0, 0.0, 1.0])
    _, meas = facet_normals(xs, fs)
    r = 3.0 * np.sqrt(2.0 * meas)
    boxes = (*swept_facet_boxes(xs, fs, r), *facet_bounding_boxes(xm, fm))
    ia, ib = find_candidate_pairs(*boxes)
    bi, bj = _brute_force_boxes(*boxes)
    np.testing.assert_array_equal(ia, bi)
    np.testing.assert_array_equal(ib, bj)
    # the largest gap (≈ 0.21) is below the search distance, so the swept search keeps
    # every pair whose projection overlaps: compare with all pairs integrated
    assert r.min() > 0.25
    pairs = compute_mortar_pairs(xs, fs, ns, xm, fm, search_radius=r)
    every_s, every_m = np.meshgrid(np.arange(len(fs)), np.arange(len(fm)), indexing="ij")
    every_s, every_m = every_s.ravel(), every_m.ravel()
    ref = integrate_triangle_pairs(xs[fs[every_s]], ns[fs[every_s]], xm[fm[every_m]])
    overlap = ref.area > 0.0
    np.testing.assert_array_equal(pairs.slave_facet, every_s[overlap])
    np.testing.assert_array_equal(pairs.master_facet, every_m[overlap])
    np.testing.assert_allclose(pairs.integrals.area, ref.area[overlap], rtol=1e-14)
    assert pairs.candidates < 0.2 * len(every_s)  # the search prunes most pairs


def test_search_distance():
    """A master sheet beyond the search distance along the slave normal is not paired
    (even though it is much wider than the slave); within it, it is."""
    rng = np.random.default_rng(2)
    xs, fs = sphere_cap(4, 0.2, 1.0, rng)
    flat = np.column_stack([xs[:, :2] * 3.0, np.full(len(xs), 1.3)])
    ns = nodal_normals(xs, fs, np.zeros((len(fs), 3)))
    far = compute_mortar_pairs(xs, fs, ns, flat, fs, search_radius=0.2)
    near = compute_mortar_pairs(xs, fs, ns, flat, fs, search_radius=0.4)
    assert far.slave_facet.size == 0 and far.candidates == 0
    assert near.slave_facet.size > 0
