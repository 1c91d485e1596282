"""Tests of the surface normals and tangent frames of the mortar geometry.

Pure NumPy: safe to run redundantly on every rank under
``mpiexec -n 2 python -m mpi4py -m pytest``.
"""

from __future__ import annotations

import numpy as np
from mortar_meshes import sphere_cap

from bonecontact.common.geometry import cross2
from bonecontact.contact.geometry import facet_normals, nodal_normals, nodal_tangents


def test_nodal_normals_circle_outward_any_ordering():
    rng = np.random.default_rng(5)
    n = 17
    th = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    pts = 2.0 * np.stack([np.cos(th), np.sin(th)], axis=1) + [1.0, -3.0]
    segs = np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)
    flip = rng.random(n) < 0.5
    segs[flip] = segs[flip, ::-1]
    interior = np.tile([1.0, -3.0], (n, 1))
    nrm = nodal_normals(pts, segs, interior)
    radial = (pts - [1.0, -3.0]) / 2.0
    np.testing.assert_allclose(nrm, radial, atol=1e-14)
    fn, length = facet_normals(pts, segs, interior)
    assert np.all(np.einsum("fg,fg->f", fn, pts[segs].mean(1) - [1.0, -3.0]) > 0)
    np.testing.assert_allclose(length, 2 * 2.0 * np.sin(np.pi / n), rtol=1e-14)
    t = nodal_tangents(nrm)
    assert t.shape == (n, 1, 2)
    np.testing.assert_allclose(np.einsum("ng,ng->n", t[:, 0], nrm), 0.0, atol=1e-15)
    np.testing.assert_allclose(cross2(nrm, t[:, 0]), 1.0, atol=1e-14)


def test_nodal_normals_area_weighted_3d():
    # two triangles sharing an edge (the y axis), unequal areas, "valley" shape
    pts = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 1.0], [3.0, 0.0, 3.0]])
    tris = np.array([[0, 1, 2], [0, 3, 1]])
    interior = np.array([[0.0, 0.5, -5.0], [0.0, 0.5, -5.0]])
    fn, area = facet_normals(pts, tris, interior)
    np.testing.assert_allclose(fn[0], [1, 0, 1] / np.sqrt(2), atol=1e-15)
    np.testing.assert_allclose(fn[1], [-1, 0, 1] / np.sqrt(2), atol=1e-15)
    np.testing.assert_allclose(area, [np.sqrt(2) / 2, 3 * np.sqrt(2) / 2], rtol=1e-14)
    nrm = nodal_normals(pts, tris, interior)
    expected = (area[0] * fn[0] + area[1] * fn[1]) / np.linalg.norm(
        area[0] * fn[0] + area[1] * fn[1]
    )
    np.testing.assert_allclose(nrm[0], expected, atol=1e-15)
    np.testing.assert_allclose(nrm[2], fn[0], atol=1e-15)
    np.testing.assert_allclose(nrm[3], fn[1], atol=1e-15)


def test_nodal_normals_sphere_and_tangent_frames():
    rng = np.random.default_rng(6)
    pts, tris = sphere_cap(12, 0.6, 2.0, rng)
    tris[::3] = tris[::3, ::-1]  # inconsistent vertex ordering
    nrm = nodal_normals(pts, tris, np.zeros((len(tris), 3)))
    radial = pts / 2.0
    # averaged normals of a perturbed faceted sphere: within a few degrees of radial
    assert np.all(np.einsum("ng,ng->n", nrm, radial) > 0.995)
    frame = nodal_tangents(nrm)
    assert frame.shape == (len(pts), 2, 3)
    full = np.concatenate([nrm[:, None, :], frame], axis=1)
    np.testing.assert_allclose(
        np.einsum("nig,njg->nij", full, full),
        np.broadcast_to(np.eye(3), (len(pts), 3, 3)),
        atol=1e-14,
    )
    np.testing.assert_allclose(np.cross(frame[:, 0], frame[:, 1]), nrm, atol=1e-14)
