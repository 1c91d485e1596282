"""The front of a crack cut by gmsh's ``Crack`` plugin: the vertices shared by its two
faces (:func:`bonecontact.fracture.body3d.front_vertices`, used by
:func:`bonecontact.runners.cracks3d.front_nodes` and
:func:`bonecontact.fracture.surface3d.front_nodes`).

The plugin gives every face vertex but the front's a copy on each face at the same point,
so the faces' common points are all their nodes: the front is told by the vertex.  The
references are independent of that: every returned node lies on the crack's front curve
(distance ≤ 1e-9·a), and their number is that of the edges bounding one face (counted
from the face's triangles alone: the edges used by one of its triangles), which for a
closed front is the number of its nodes.
"""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import mesh

from bonecontact.fracture.body3d import body_surface, mesh_body_with_planar_crack
from bonecontact.fracture.crack3d import PlanarCrack
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.surface3d import front_nodes as block_front_nodes
from bonecontact.runners.cracks3d import front_nodes

A = 0.3  # crack radius (m) in the box [-1, 1]^3


def _box_body(comm: MPI.Comm):
    msh = mesh.create_box(comm, [[-1.0] * 3, [1.0] * 3], [3, 3, 3], mesh.CellType.tetrahedron)
    n = msh.topology.index_map(3).size_local
    cells = mesh.meshtags(msh, 3, np.arange(n, dtype=np.int32), np.ones(n, dtype=np.int32))
    msh.topology.create_connectivity(2, 3)
    ext = mesh.exterior_facet_indices(msh.topology).astype(np.int32)
    facets = mesh.meshtags(msh, 2, ext, np.full(len(ext), 2, dtype=np.int32))
    return body_surface(msh, cells, facets, {"bone": (3, 1), "outer": (2, 2)}, "bone")


def _face_boundary_edges(cb, tag: int) -> int:
    """Edges used by exactly one triangle of facet group ``tag`` (collective)."""
    msh = cb.mesh
    msh.topology.create_connectivity(2, 0)
    f2v = msh.topology.connectivity(2, 0)
    facets = cb.facet_tags.find(tag)
    facets = facets[facets < msh.topology.index_map(2).size_local]
    tri = [msh.geometry.x[mesh.entities_to_geometry(msh, 0, f2v.links(f)).ravel()] for f in facets]
    tri = np.concatenate(msh.comm.allgather(np.array(tri).reshape(-1, 3, 3)))
    key = np.round(tri / (1e-9 * A)).astype(np.int64)
    count: dict[tuple, int] = {}
    for t in key:
        for i, j in ((0, 1), (1, 2), (2, 0)):
            e = tuple(sorted((tuple(t[i]), tuple(t[j]))))
            count[e] = count.get(e, 0) + 1
    return sum(1 for c in count.values() if c == 1)


#: (centre, normal, front size a/n)
CRACKS = [
    ((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 6),
    ((0.1, -0.05, 0.0), (1.0, 0.0, 1.0), 6),
    ((0.0, 0.0, 0.05), (0.0, 0.0, 1.0), 10),
]


@pytest.mark.parametrize("centre, normal, per_a", CRACKS)
def test_front_nodes_lie_on_the_front(centre, normal, per_a) -> None:
    comm = MPI.COMM_WORLD
    n = np.asarray(normal) / np.linalg.norm(normal)
    axis = np.cross(n, [0.0, 1.0, 0.0])
    crack = PlanarCrack(centre, tuple(n), A, A, tuple(axis / np.linalg.norm(axis)))
    cb, _ = mesh_body_with_planar_crack(_box_body(comm), crack, TipMesh(A / per_a, 0.3), comm)
    x = front_nodes(cb)
    d = x - np.asarray(centre)
    off = d @ n
    radial = np.linalg.norm(d - np.outer(off, n), axis=1)
    assert np.max(np.abs(off)) <= 1e-9 * A
    assert np.max(np.abs(radial - A)) <= 1e-9 * A
    edges = _face_boundary_edges(cb, cb.face_tags[0])
    assert edges == _face_boundary_edges(cb, cb.face_tags[1])
    assert len(x) == edges
    assert abs(len(x) - 2 * math.pi * per_a) <= 0.25 * 2 * math.pi * per_a  # h = a/per_a
    # the same on every rank, and the block's front_nodes is the same function
    assert np.array_equal(np.concatenate(comm.allgather(x[:1])), np.repeat(x[:1], comm.size, 0))
    np.testing.assert_array_equal(block_front_nodes(cb.block()), x)
