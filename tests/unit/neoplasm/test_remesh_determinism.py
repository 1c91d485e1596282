"""The input of a remesh does not depend on the partition or on round-off
(bonecontact.neoplasm.remesh: snap_to_grid, gather_boundary, polygon_mesh, surface_mesh).

A growing neoplasm is remeshed from its moved boundary.  On another number of ranks the
boundary differs by round-off (the solves sum in another order); gmsh would turn that into
another mesh, and the runs would drift apart by the discretisation error.  So gmsh sees
the boundary in a canonical order and snapped to a grid.
"""

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import numpy as np
import pytest

from bonecontact.neoplasm import remesh


def _ellipse(n, a=1.0, b=0.6):
    th = 2 * np.pi * np.arange(n) / n
    return np.column_stack([a * np.cos(th), b * np.sin(th)])


def _nodes(msh):
    """All geometry nodes of a mesh, in input (gmsh) order, on every rank."""
    gdim = msh.geometry.dim
    nloc = msh.geometry.index_map().size_local
    keys = np.asarray(msh.geometry.input_global_indices, dtype=np.int64)[:nloc]
    x = msh.geometry.x[:nloc, :gdim]
    keys = np.concatenate(msh.comm.allgather(keys))
    x = np.concatenate(msh.comm.allgather(x)).reshape(-1, gdim)
    return x[np.argsort(keys)]


def test_snap_to_grid_power_of_two_spacing():
    rng = np.random.default_rng(1)
    p = rng.uniform(-3.0, 5.0, size=(200, 3))  # extent < 8 = 2^3: spacing 2^(2 - 32)
    q = 2.0 ** (2 - remesh.SNAP_BITS)
    s = remesh.snap_to_grid(p)
    assert np.all(np.abs(s - p) <= 0.5 * q)
    np.testing.assert_array_equal(s / q, np.round(s / q))  # on the grid, exactly
    np.testing.assert_array_equal(remesh.snap_to_grid(s), s)  # idempotent
    # a round-off perturbation (1e-15 relative) lands on the same grid points
    t = remesh.snap_to_grid(p * (1.0 + 1e-15 * rng.standard_normal(p.shape)))
    assert np.count_nonzero(t != s) <= 1  # a straddled half-grid point: probability ~1e-5


@pytest.mark.parametrize("dim", [2, 3])
def test_gathered_boundary_independent_of_partition(dim):
    """The boundary gathered from a distributed mesh equals, bit for bit and in the same
    order, the one gathered from the same gmsh mesh on one rank."""
    meshes = {}
    for name, comm in (("world", MPI.COMM_WORLD), ("self", MPI.COMM_SELF)):
        if dim == 2:
            meshes[name] = remesh.polygon_mesh(_ellipse(48), 0.1, comm)
        else:
            meshes[name] = remesh.sphere_mesh(1.0, 0.3, comm)
    bw, bs = (remesh.gather_boundary(meshes[k]) for k in ("world", "self"))
    np.testing.assert_array_equal(bw.keys, bs.keys)
    np.testing.assert_array_equal(bw.facets, bs.facets)
    np.testing.assert_array_equal(bw.points, bs.points)
    if dim == 3:  # canonical: each triangle starts at its smallest index, rows sorted
        assert np.all(bw.facets[:, 0] == bw.facets.min(axis=1))
        order = np.lexsort(bw.facets.T[::-1])
        np.testing.assert_array_equal(order, np.arange(len(order)))


def test_round_off_does_not_change_the_mesh_2d():
    """A polygon 1e-15 (relative) away gives the same mesh, node for node."""
    rng = np.random.default_rng(2)
    p = remesh.resample_closed_curve(_ellipse(40) * 1.3, 0.1)
    p2 = p * (1.0 + 1e-15 * rng.standard_normal(p.shape))
    assert np.any(p2 != p)
    comm = MPI.COMM_SELF
    m1 = remesh.polygon_mesh(remesh.resample_closed_curve(p, 0.1), 0.1, comm)
    m2 = remesh.polygon_mesh(remesh.resample_closed_curve(p2, 0.1), 0.1, comm)
    np.testing.assert_array_equal(_nodes(m1), _nodes(m2))


def test_round_off_does_not_change_the_mesh_3d():
    """A closed surface 1e-15 (relative) away gives the same tetrahedral mesh."""
    ball = remesh.sphere_mesh(1.0, 0.4, MPI.COMM_SELF)
    b = remesh.gather_boundary(ball)
    rng = np.random.default_rng(3)
    pts2 = b.points * (1.0 + 1e-15 * rng.standard_normal(b.points.shape))
    assert np.any(pts2 != b.points)
    m1 = remesh.surface_mesh(b.points, b.facets, 0.4, MPI.COMM_SELF)
    m2 = remesh.surface_mesh(pts2, b.facets, 0.4, MPI.COMM_SELF)
    np.testing.assert_array_equal(_nodes(m1), _nodes(m2))
