"""Tests of bonecontact.neoplasm.host3d's gmsh reading and writing of a host geometry."""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import numpy as np

from bonecontact.neoplasm.host3d import read_host_geometry3d, write_host_geometry3d

SEGMENT = Path(__file__).resolve().parents[3] / "data" / "scenes" / "spine_segment.msh"


def test_written_host_geometry_reads_back_the_same(tmp_path: Path) -> None:
    """The shipped lumbar segment (six cell groups, its facet groups) written and read
    again: the same nodes, and every group with its tag and cells, exactly; the volume
    of each cell group unchanged."""
    if MPI.COMM_WORLD.rank != 0:
        return
    g = read_host_geometry3d(SEGMENT)
    write_host_geometry3d(g, tmp_path / "again.msh")
    h = read_host_geometry3d(tmp_path / "again.msh")
    np.testing.assert_array_equal(g.x, h.x)
    for a, b in ((g.cells, h.cells), (g.facets, h.facets)):
        assert a.keys() == b.keys() and len(a) > 0
        for name in a:
            assert a[name][0] == b[name][0]
            np.testing.assert_array_equal(a[name][1], b[name][1])
    for name in g.cells:
        assert h.volume(name) == g.volume(name) > 0.0
