"""The body count of a mesh (``count_bodies`` / ``find_bodies``) on meshes built by hand.

A family of meshes made of unit boxes (2D: squares of 2 × 3 × 3 triangles; 3D: cubes of
6 × 3³ tetrahedra, Kuhn's subdivision) placed apart, touching at one corner vertex (one
body: cells sharing a vertex are connected) or nearly touching (a gap of 10⁻³: two
bodies).  The count is checked against the construction and the volume of each body
(summed over the owned cells of every rank) against the number of boxes it is made of.
The meshes are distributed by DOLFINx's partitioner, so under ``mpiexec -n 2`` and
``-n 3`` the pieces of one body lie on several ranks and must be joined through the
vertices of the partition boundary: the same answer on any number of ranks.
"""

from __future__ import annotations

import itertools

from mpi4py import MPI

import basix.ufl
import numpy as np
import pytest
import ufl
from dolfinx import mesh as dmesh

from bonecontact.scene.mesh_checks import count_bodies
from bonecontact.scene.rigid_motions import find_bodies

COMM = MPI.COMM_WORLD
N = 3  # boxes of N^d squares / cubes

#: layout name -> (box origins in units of the box side, volumes of the bodies)
LAYOUTS: dict[str, tuple[list[tuple[float, ...]], list[float]]] = {
    "one": ([(0, 0, 0)], [1.0]),
    "two_apart": ([(0, 0, 0), (2, 0, 0)], [1.0, 1.0]),
    "three_apart": ([(0, 0, 0), (2, 0, 0), (0, 2, 0)], [1.0, 1.0, 1.0]),
    "corner": ([(0, 0, 0), (1, 1, 1)], [2.0]),
    "corner_chain": ([(0, 0, 0), (1, 1, 1), (2, 2, 2)], [3.0]),
    "corner_and_apart": ([(0, 0, 0), (1, 1, 1), (3, 0, 0)], [1.0, 2.0]),
    "gap": ([(0, 0, 0), (1.001, 1.001, 1.001)], [1.0, 1.0]),
}


def _box(dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Points and simplices of the unit box split into N^dim squares / cubes."""
    g = np.arange(N + 1)
    pts = np.array(list(itertools.product(g, repeat=dim)), dtype=float) / N

    def index(c: np.ndarray) -> int:
        return int(np.ravel_multi_index(tuple(c), (N + 1,) * dim))

    cells = []
    for corner in itertools.product(range(N), repeat=dim):
        c0 = np.array(corner)
        for perm in itertools.permutations(range(dim)):  # Kuhn: one simplex per path
            path, c = [index(c0)], c0.copy()
            for axis in perm:
                c[axis] += 1
                path.append(index(c))
            cells.append(path)
    return pts, np.array(cells, dtype=np.int64)


def _boxes_mesh(dim: int, origins: list[tuple[float, ...]]) -> dmesh.Mesh:
    """One mesh of unit boxes at ``origins``; coinciding points become one vertex."""
    pts, cells = _box(dim)
    x = np.concatenate([pts + np.asarray(o[:dim], dtype=float) for o in origins])
    c = np.concatenate([cells + k * len(pts) for k in range(len(origins))])
    x, inverse = np.unique(np.round(x, 9), axis=0, return_inverse=True)
    c = inverse.ravel()[c]
    cell = "triangle" if dim == 2 else "tetrahedron"
    el = ufl.Mesh(basix.ufl.element("Lagrange", cell, 1, shape=(dim,)))
    root = COMM.rank == 0
    return dmesh.create_mesh(
        COMM,
        c if root else np.zeros((0, dim + 1), np.int64),
        el,
        x if root else np.zeros((0, dim)),
    )


def _body_volumes(msh: dmesh.Mesh, cell_body: np.ndarray, count: int) -> np.ndarray:
    """Volume (area in 2D) of each body from the owned cells of all ranks."""
    tdim = msh.topology.dim
    n = msh.topology.index_map(tdim).size_local
    dofs = np.asarray(msh.geometry.dofmaps[0])[:n]
    x = msh.geometry.x[dofs][:, :, :tdim]
    e = x[:, 1:, :] - x[:, :1, :]
    vol = np.abs(np.linalg.det(e)) / (2.0 if tdim == 2 else 6.0)
    local = np.bincount(cell_body[:n], weights=vol, minlength=count)
    return COMM.allreduce(local, op=MPI.SUM)


@pytest.mark.parametrize("layout", list(LAYOUTS))
@pytest.mark.parametrize("dim", [2, 3])
def test_body_count(dim, layout):
    origins, volumes = LAYOUTS[layout]
    msh = _boxes_mesh(dim, origins)
    assert count_bodies(msh, COMM) == len(volumes)
    bodies = find_bodies(msh, None, {}, COMM)
    assert bodies.count == len(volumes)
    got = np.sort(_body_volumes(msh, bodies.cell_body, bodies.count))
    assert np.allclose(got, sorted(volumes), rtol=1e-12, atol=0)
