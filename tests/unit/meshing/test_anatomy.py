"""Bone-section builders (bonecontact.meshing.anatomy): measures of every named group
against the exact geometry.

Runs serially and under ``mpiexec -n 2/3`` (all measures are assembled and summed over
the ranks).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx.io.gmsh import read_from_msh
from mesh_measures import group_vertices, measure

from bonecontact.meshing import anatomy

COMM = MPI.COMM_WORLD
REPO = Path(__file__).resolve().parents[3]


def check_long_bone(md, length=0.2, width=0.03, t=5e-3, flare=4e-3, flare_length=0.03):
    assert set(md.physical_groups) == {"cortical", "cancellous", "distal", "proximal", "periosteum"}
    total = width * length + 2 * flare * flare_length
    assert measure(md, "cortical") == pytest.approx(2 * t * length, rel=1e-12)
    assert measure(md, "cancellous") == pytest.approx(total - 2 * t * length, rel=1e-12)
    for end in ("distal", "proximal"):
        assert measure(md, end) == pytest.approx(width + 2 * flare, rel=1e-12)
    side = length - 2 * flare_length + 2 * math.hypot(flare, flare_length)
    assert measure(md, "periosteum") == pytest.approx(2 * side, rel=1e-12)
    # Conforming cortex/core interface: it is interior, so the whole exterior boundary
    # is exactly the three named facet groups.
    assert measure(md) == pytest.approx(2 * side + 2 * (width + 2 * flare), rel=1e-12)
    _, x = group_vertices(md, "distal")
    assert np.allclose(x[:, 1], 0.0)


def test_long_bone_2d():
    check_long_bone(anatomy.long_bone_2d(h=3e-3, comm=COMM))


def test_long_bone_2d_without_flare():
    check_long_bone(anatomy.long_bone_2d(h=3e-3, flare=0.0, comm=COMM), flare=0.0)


def test_shipped_long_bone_mesh():
    path = REPO / "data" / "scenes" / "long_bone.msh"
    assert path.stat().st_size < 300_000
    md = read_from_msh(path, COMM, 0, gdim=2)
    check_long_bone(md)
    n_nodes = md.mesh.topology.index_map(0).size_global
    assert 2500 < n_nodes < 4500  # element size about 1.5 mm


def test_invalid_long_bone_is_rejected():
    with pytest.raises(ValueError):
        anatomy.long_bone_2d(cortical_thickness=0.02, comm=COMM)
