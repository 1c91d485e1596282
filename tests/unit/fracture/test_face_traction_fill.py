"""The face tractions of :func:`bonecontact.fracture.faces.face_traction` are placed on the
pair's nodes alone (the slave nodes by global index, the master nodes of the pair's
``M̂`` columns matched to the slave points by a k-d tree) — the same fields as the
direct method it replaced, kept here as the reference: every local dof visited in
Python, its coordinates rounded to a key looked up among the slave points, and every
dof's distance to every tip (both from the same gathered and recovered slave tractions,
:func:`~bonecontact.fracture.faces.face_data`).

Cases: a 2D centre crack at 30° closed by compression, frictionless and with Coulomb
faces (μ = 0.3), with and without the recovery near the tips; a 3D semi-elliptical
surface crack closed by compression (bonecontact.verification.surface_crack at its
reduced size, its front nodes as the tips, the recovery of the scenes: reach 6).  Both
fields equal the reference's to 1e-14 of the largest traction on every rank (1, 2 and
3 ranks).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

from mpi4py import MPI

import numpy as np
import pytest

import bonecontact.verification.surface_crack as surface_crack
from bonecontact.fracture.faces import face_data, face_traction
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.plates import centre_crack, mesh_plate, solve_plate
from bonecontact.fracture.surface3d import SurfaceCrack
from bonecontact.materials.laws import Isotropic

COMM = MPI.COMM_WORLD
A, H_TIP = 0.1, 0.01


def reference_face_traction(V, itf, result, k=0, tips=(), radius=None, reach=2.0):
    """The fields by the direct method: ``(plus, minus)`` arrays (local dofs)."""
    bs = V.dofmap.index_map_bs
    im = V.dofmap.index_map
    vp = np.zeros((im.size_local + im.num_ghosts, bs))
    vm = vp.copy()
    face = face_data(V, itf, result, k, tips, radius, reach)
    xs, ts = face.x, face.t
    if xs.size == 0:
        return vp.ravel(), vm.ravel()
    gblocks = im.local_to_global(np.arange(vp.shape[0], dtype=np.int32))
    is_slave = np.isin(gblocks, face.slave_g)
    pos = {g: i for i, g in enumerate(face.slave_g)}
    for b in np.flatnonzero(is_slave):
        vp[b] = ts[pos[int(gblocks[b])]]
    x = V.tabulate_dof_coordinates()[:, :bs]
    scale = float(np.ptp(xs, axis=0).max()) or 1.0
    key = lambda p: tuple(np.round(p / (1e-9 * scale)).astype(np.int64))  # noqa: E731
    at = {key(p): tr for p, tr in zip(xs, ts, strict=True)}
    for b in np.flatnonzero(~is_slave):
        tr = at.get(key(x[b]))
        if tr is not None:
            vm[b] = -tr
    for tip, tr in zip(face.tips, face.tip_t, strict=True):
        for b in np.flatnonzero(np.linalg.norm(x - tip, axis=1) <= 1e-9 * scale):
            vp[b], vm[b] = tr, -tr
    return vp.ravel(), vm.ravel()


def _same(args: tuple, kwargs: dict) -> None:
    """face_traction(*args, **kwargs) against the reference on every rank: the same
    nonzero pattern and values to 1e-14 of the largest traction."""
    got = face_traction(*args, **kwargs)
    ref_p, ref_m = reference_face_traction(*args, **kwargs)
    scale = COMM.allreduce(float(np.max(np.abs(ref_p), initial=0.0)), op=MPI.MAX)
    assert scale > 0
    filled = COMM.allreduce(int(np.count_nonzero(ref_m)), op=MPI.SUM)
    assert filled > 0  # the master face carries the traction
    for a, b in ((got.plus.x.array, ref_p), (got.minus.x.array, ref_m)):
        np.testing.assert_array_equal(a != 0, b != 0)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-14 * scale)


@pytest.fixture(scope="module", params=[0.0, 0.3], ids=["frictionless", "coulomb"])
def closed_2d(request):
    cm = mesh_plate(1.0, 1.0, centre_crack(A, 30.0), TipMesh(H_TIP, 0.3, 0.2), COMM)
    mat = Isotropic(E=10.0e9, nu=0.3)
    loads = {"edge2": (0.0, -1e6), "edge0": (0.0, 1e6)}  # compression
    friction = request.param or None
    return cm, solve_plate(cm, mat, loads, face_contact=True, friction=friction)


@pytest.mark.parametrize("radius", [None, 2 * H_TIP], ids=["raw", "recovered"])
def test_2d_closed_crack(closed_2d, radius) -> None:
    cm, sol = closed_2d
    tips = [cm.crack.tip(e) for e in cm.crack.tip_ends]
    assert int(np.count_nonzero(sol.contact.active[0])) == sol.contact_interface.num_owned
    args = (sol.model.V, sol.contact_interface, sol.contact, 0, tips)
    _same(args, {"radius": radius})


@pytest.fixture(scope="module")
def surface_call(monkeypatch_module) -> tuple:
    """The arguments of the face_traction call of a closed surface crack (semi-elliptical,
    a/c = 1, a/t = 0.2, front a/8) under compression."""
    calls = []

    def spy(*args, **kwargs):
        calls.append((args, kwargs))
        return face_traction(*args, **kwargs)

    monkeypatch_module.setattr(surface_crack, "face_traction", spy)
    p = surface_crack.PlateProblem(
        SurfaceCrack("semi_elliptical", 0.2, 0.2),
        b=2.0,
        h=2.0,
        t=1.0,
        h_front=0.2 / 8,
        grading=0.15,
        h_max=0.5,
        r_out=0.3 * 0.2,
        S=-1.0,
        contact=True,
    )
    sol = surface_crack.solve_plate(p)
    assert len(calls) == 1 and sol.face_traction is not None
    return calls[0]


@pytest.fixture(scope="module")
def monkeypatch_module():
    mp = pytest.MonkeyPatch()
    yield mp
    mp.undo()


def test_3d_closed_surface_crack(surface_call) -> None:
    args, kwargs = surface_call
    assert len(args[4]) > 10  # the front nodes
    _same(args, kwargs)
    _same(args[:5], {})  # without the recovery
