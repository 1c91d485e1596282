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


# ----------------------------------------------------------------- retries after gmsh fails
def _failing(monkeypatch, name: str, failures: int) -> list:
    """Replace ``remesh.<name>`` by a wrapper that raises RemeshError on its first
    ``failures`` calls (on every rank, like a gmsh error broadcast from rank 0) and records
    every call's boundary (rank 0) and size."""
    real = getattr(remesh, name)
    calls = []

    def wrapper(points, *args):
        h = args[-2]
        calls.append((None if points is None else np.array(points), h))
        if len(calls) <= failures:
            raise remesh.RemeshError(f"{name}: injected failure {len(calls)}")
        return real(points, *args)

    monkeypatch.setattr(remesh, name, wrapper)
    return calls


def _noisy_circle(n: int = 80, r: float = 1.0, noise: float = 0.02) -> np.ndarray:
    th = 2 * np.pi * np.arange(n) / n
    rr = r * (1 + noise * (-1.0) ** np.arange(n))  # zigzag at the scale of the edges
    return np.column_stack([rr * np.cos(th), rr * np.sin(th)])


@pytest.mark.parametrize("failures", [1, 2])
def test_curve_remesh_retries_smoothed_then_smaller(monkeypatch, failures):
    """2D: a gmsh failure on the moved curve is retried with the Taubin-smoothed curve
    (the zigzag's amplitude drops by more than half, the enclosed area stays within 1 %),
    then also with half the size; the mesh of the successful attempt covers the
    smoothed curve's area (to the resampling error, 1 %)."""
    comm = MPI.COMM_WORLD
    h = 0.1
    pts = _noisy_circle()
    calls = _failing(monkeypatch, "polygon_mesh", failures)
    msh, smoothed = remesh.moved_curve_mesh(pts, h, comm)
    assert smoothed
    assert [c[1] for c in calls] == [h, h, 0.5 * h][: failures + 1]
    smooth = remesh.smooth_curve(pts)
    zig = lambda p: np.ptp(np.linalg.norm(p, axis=1))  # noqa: E731
    assert zig(smooth) < 0.5 * zig(pts)
    assert abs(signed_polygon_area(smooth)) == pytest.approx(
        abs(signed_polygon_area(pts)), rel=0.01
    )
    if comm.rank == 0:  # the successful attempt meshed the resampled smoothed curve
        last = calls[-1][0]
        r = np.linalg.norm(last, axis=1)
        assert r.min() > 1 - 0.5 * 0.02 and r.max() < 1 + 0.5 * 0.02
    assert _area(msh) == pytest.approx(abs(signed_polygon_area(smooth)), rel=0.01)


def test_curve_remesh_fails_after_the_retries(monkeypatch):
    """Every attempt fails: one RemeshError naming the three attempts (on every rank)."""
    calls = _failing(monkeypatch, "polygon_mesh", 10)
    with pytest.raises(remesh.RemeshError) as info:
        remesh.moved_curve_mesh(_noisy_circle(), 0.1, MPI.COMM_WORLD)
    assert len(calls) == 3
    msg = str(info.value)
    assert "gmsh failed 3 times" in msg
    assert "boundary as moved, size × 1" in msg and "smoothed boundary, size × 0.5" in msg


def test_surface_remesh_retries_with_half_the_size(monkeypatch):
    """3D: after two failures the smoothed surface is tetrahedralised with half the size;
    the result encloses the smoothed surface's volume (to 2 %)."""
    comm = MPI.COMM_WORLD
    ball = remesh.sphere_mesh(1.0, 0.4, comm)
    b = remesh.gather_boundary(ball)
    calls = _failing(monkeypatch, "surface_mesh", 2)
    msh, smoothed = remesh.moved_surface_mesh(b.points, b.facets, 0.4, comm)
    assert smoothed and [c[1] for c in calls] == [0.4, 0.4, 0.2]
    sm = remesh.smooth_surface(b.points, b.facets)
    a, bb, c = (sm[b.facets[:, k]] for k in range(3))
    volume = abs(np.einsum("ij,ij->i", a, np.cross(bb, c)).sum()) / 6.0
    assert _area(msh) == pytest.approx(volume, rel=0.02)
    n_cells = msh.topology.index_map(3).size_global
    assert n_cells > ball.topology.index_map(3).size_global  # the smaller size was used
