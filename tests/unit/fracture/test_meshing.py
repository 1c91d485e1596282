"""Cracked-body meshing (bonecontact.fracture.meshing): group measures against the exact
geometry, duplicated face nodes with shared tips, face sides, and the tip grading.

Runs serially and under ``mpiexec -n 2/3`` (measures and counts are summed over ranks).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh

from bonecontact.fracture.crack import Crack2D, FractureError
from bonecontact.fracture.meshing import Hole, TipMesh, mesh_cracked_body

COMM = MPI.COMM_WORLD
OUTLINE = [(-1.0, -2.0), (1.0, -2.0), (1.0, 2.0), (-1.0, 2.0)]


def total(form) -> float:
    return COMM.allreduce(fem.assemble_scalar(fem.form(form)), op=MPI.SUM)


def group_length(cm, name) -> float:
    ds = ufl.Measure("ds", domain=cm.mesh, subdomain_data=cm.facet_tags)
    return total(1.0 * ds(cm.groups[name]))


def nodes_at(cm, p) -> int:
    """Number of mesh nodes (owned, summed over ranks) at the point p."""
    n = cm.mesh.geometry.index_map().size_local
    x = cm.mesh.geometry.x[:n, :2]
    return COMM.allreduce(int(np.sum(np.hypot(*(x - p).T) < 1e-10)), op=MPI.SUM)


@pytest.fixture(scope="module")
def kinked():
    crack = Crack2D(np.array([(-0.3, 0.0), (0.0, 0.1), (0.3, 0.0)]))
    return mesh_cracked_body(OUTLINE, crack, TipMesh(0.006, 0.25, 0.2), COMM)


def test_interior_kinked_crack(kinked):
    cm = kinked
    length = 2 * math.hypot(0.3, 0.1)
    for face in ("crack_plus", "crack_minus"):
        assert group_length(cm, face) == pytest.approx(length, rel=1e-12)
    for i, side in enumerate((2.0, 4.0, 2.0, 4.0)):
        assert group_length(cm, f"edge{i}") == pytest.approx(side, rel=1e-12)
    assert total(1.0 * ufl.dx(domain=cm.mesh)) == pytest.approx(8.0, rel=1e-12)
    # the faces are separate (duplicated nodes) except at the two shared tips
    assert nodes_at(cm, (-0.3, 0.0)) == 1 and nodes_at(cm, (0.3, 0.0)) == 1
    assert nodes_at(cm, (0.0, 0.1)) == 2
    # the whole boundary: outline + both faces
    tdim = cm.mesh.topology.dim
    cm.mesh.topology.create_connectivity(tdim - 1, tdim)
    ext = mesh.exterior_facet_indices(cm.mesh.topology)
    tags = mesh.meshtags(cm.mesh, 1, ext, np.ones(ext.size, np.int32))
    ds = ufl.Measure("ds", domain=cm.mesh, subdomain_data=tags)
    assert total(1.0 * ds(1)) == pytest.approx(12.0 + 2 * length, rel=1e-12)


def test_plus_face_is_left_of_the_polyline(kinked):
    """Cells behind crack_plus lie above the (left-to-right) crack, crack_minus below."""
    cm = kinked
    msh = cm.mesh
    msh.topology.create_connectivity(1, 2)
    f2c = msh.topology.connectivity(1, 2)
    for name, sign in (("crack_plus", 1), ("crack_minus", -1)):
        facets = cm.facet_tags.find(cm.groups[name])
        cells = np.array([f2c.links(f)[0] for f in facets], dtype=np.int32)
        fm = mesh.compute_midpoints(msh, 1, facets)
        cc = mesh.compute_midpoints(msh, 2, cells)
        # both segments run left to right, so "left" is +y at every facet
        assert np.all(sign * (cc[:, 1] - fm[:, 1]) > 0)


def test_tip_grading(kinked):
    """Every cell near a tip is no larger than h_tip + grading * distance (+ gmsh slack)."""
    cm, h_tip, g = kinked, 0.006, 0.25
    msh = cm.mesh
    n = msh.topology.index_map(2).size_local
    cells = np.arange(n, dtype=np.int32)
    h = msh.h(2, cells)
    mid = mesh.compute_midpoints(msh, 2, cells)[:, :2]
    d = np.minimum(np.hypot(*(mid - (-0.3, 0)).T), np.hypot(*(mid - (0.3, 0)).T))
    near = d < 0.05
    assert COMM.allreduce(int(near.sum()), op=MPI.SUM) > 20
    worst = COMM.allreduce(float(np.max(h[near] / (h_tip + g * d[near]), initial=0)), op=MPI.MAX)
    assert worst < 1.6
    finest = COMM.allreduce(float(np.min(h, initial=1.0)), op=MPI.MIN)
    assert 0.5 * h_tip < finest < 1.5 * h_tip


def test_edge_crack_opens_at_the_mouth():
    crack = Crack2D(np.array([(-1.0, 0.0), (-0.6, 0.0)]), "end")
    cm = mesh_cracked_body(OUTLINE, crack, TipMesh(0.01, 0.3, 0.25), COMM)
    assert nodes_at(cm, (-1.0, 0.0)) == 2 and nodes_at(cm, (-0.6, 0.0)) == 1
    assert group_length(cm, "edge3") == pytest.approx(4.0, rel=1e-12)
    assert group_length(cm, "crack_plus") == pytest.approx(0.4, rel=1e-12)


def test_hole_without_crack():
    """Area = plate - inscribed polygon of the hole; the hole edge is graded to its size."""
    r, h = 0.05, 0.002
    cm = mesh_cracked_body(OUTLINE, None, TipMesh(0.01), COMM, holes=(Hole((0.0, 0.0), r, h),))
    perimeter = group_length(cm, "hole0")
    n_seg = 2 * math.pi * r / perimeter  # about the number of segments
    assert (
        perimeter < 2 * math.pi * r
        and 2 * math.pi * r - perimeter < 2 * (2 * math.pi * r) / n_seg**2
    )
    assert 0.7 * h < perimeter / round(2 * math.pi * r / h) < 1.3 * h


def test_bad_input():
    with pytest.raises(FractureError, match="not inside"):
        mesh_cracked_body(OUTLINE, Crack2D(np.array([(0.5, 0), (1.5, 0)])), TipMesh(0.01), COMM)
    with pytest.raises(FractureError, match="h_tip"):
        TipMesh(0.0)
