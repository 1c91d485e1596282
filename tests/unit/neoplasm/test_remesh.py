"""Remeshing and field transfer for moving boundaries (bonecontact.neoplasm.remesh, curvature)."""

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from dolfinx import fem

from bonecontact.common.geometry import signed_polygon_area
from bonecontact.neoplasm import curvature, remesh


def _ellipse(n, a=1.0, b=0.6):
    th = 2 * np.pi * np.arange(n) / n
    return np.column_stack([a * np.cos(th), b * np.sin(th)])


def _area(msh):
    return msh.comm.allreduce(
        fem.assemble_scalar(fem.form(fem.Constant(msh, 1.0) * ufl.dx)), op=MPI.SUM
    )


def test_fixed_boundary_remesh_keeps_area_and_l2_norm():
    comm = MPI.COMM_WORLD
    h = 0.08
    m0 = remesh.polygon_mesh(_ellipse(60), h, comm)
    A0 = _area(m0)
    b = remesh.gather_boundary(m0)
    assert signed_polygon_area(b.points) > 0 and len(b.points) == 60
    m1 = remesh.polygon_mesh(remesh.resample_closed_curve(b.points, h), h, comm)
    assert abs(_area(m1) / A0 - 1) < 1e-3
    # smooth field: L2 norm kept within 0.5% (P1 and DG0)
    for family, deg in (("Lagrange", 1), ("DG", 0)):
        V0 = fem.functionspace(m0, (family, deg))
        u0 = fem.Function(V0)
        u0.interpolate(lambda x: np.exp(x[0]) * np.cos(2 * x[1]))
        u1 = remesh.transfer(u0, fem.functionspace(m1, (family, deg)), extrapolate=h)
        n0 = comm.allreduce(fem.assemble_scalar(fem.form(u0 * u0 * ufl.dx)), op=MPI.SUM)
        n1 = comm.allreduce(fem.assemble_scalar(fem.form(u1 * u1 * ufl.dx)), op=MPI.SUM)
        assert abs(np.sqrt(n1 / n0) - 1) < 5e-3, (family, n0, n1)


def test_point_outside_is_reported_not_zeroed():
    comm = MPI.COMM_WORLD
    m0 = remesh.polygon_mesh(_ellipse(40), 0.15, comm)
    m1 = remesh.polygon_mesh(1.2 * _ellipse(40), 0.15, comm)  # sticks out by up to 0.2
    u0 = fem.Function(fem.functionspace(m0, ("Lagrange", 1)), name="u")
    u0.x.array[:] = 1.0
    V1 = fem.functionspace(m1, ("Lagrange", 1))
    with pytest.raises(remesh.CoverageError, match="outside the source mesh"):
        remesh.transfer(u0, V1, extrapolate=0.0)
    # within an explicit extrapolation band the constant is reproduced everywhere (never 0)
    u1 = remesh.transfer(u0, V1, extrapolate=0.25)
    assert np.allclose(u1.x.array, 1.0)


def test_curvature_circle_ellipse_sphere():
    th = 2 * np.pi * np.arange(80) / 80
    pts = 2.0 * np.column_stack([np.cos(th), np.sin(th)])
    assert np.allclose(curvature.polygon_curvature(pts), 0.5, rtol=1e-12)
    a, b = 1.0, 0.6
    e = _ellipse(400, a, b)
    exact = (
        a
        * b
        / (a**2 * np.sin(th := 2 * np.pi * np.arange(400) / 400) ** 2 + b**2 * np.cos(th) ** 2)
        ** 1.5
    )
    assert np.max(np.abs(curvature.polygon_curvature(e) / exact - 1)) < 1e-3
    # clockwise polygon: negative (convention: counter-clockwise boundary, convex > 0)
    assert np.all(curvature.polygon_curvature(pts[::-1]) < 0)


def test_mesh_motion_moves_boundary_exactly():
    comm = MPI.COMM_WORLD
    msh = remesh.polygon_mesh(_ellipse(40), 0.15, comm)
    A0 = _area(msh)
    mm = remesh.MeshMotion(msh)
    d = fem.Function(mm.V)
    d.interpolate(lambda x: 0.1 * x[:2])  # uniform dilation by 1.1
    mm.move(d)
    assert abs(_area(msh) / A0 - 1.21) < 1e-10


def test_release_destroys_the_replaced_solvers():
    """What a remesh replaces is destroyed explicitly (in parallel a garbage-collected PETSc
    object is only parked, keeping the old mesh's communicators: a growth run ran out of
    MPI communicators after ~200 remeshes on 2 ranks); a Laplacian shared with a motion
    belongs to its owner and survives the motion's release."""
    msh = remesh.polygon_mesh(_ellipse(40), 0.15, MPI.COMM_WORLD)
    own = remesh.MeshMotion(msh)
    lap = own.laplacian
    assert lap.ksp.handle and lap.A.handle
    remesh.release_replaced_meshes(own, None)
    assert not any(o.handle for o in (lap.ksp, lap.A, lap.b, lap.x))
    shared = remesh.DirichletLaplacian(lap.V, lap.boundary_dofs)
    motion = remesh.MeshMotion(msh, shared)
    remesh.release_replaced_meshes(motion)
    assert shared.ksp.handle and shared.A.handle  # still usable by its owner
    d = fem.Function(motion.V)
    d.interpolate(lambda x: 0.1 * x[:2])
    A0 = _area(msh)
    motion.move(d)  # the shared Laplacian still solves: uniform dilation by 1.1
    assert abs(_area(msh) / A0 - 1.21) < 1e-10
    remesh.release_replaced_meshes(shared)
    assert not shared.ksp.handle
