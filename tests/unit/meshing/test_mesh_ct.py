"""``bonecontact mesh-ct`` and the bodies/ends options of ct_slice_mesh, on the synthetic
DICOM phantom of test_ct.py (two discs of known radius and HU in water).

References: the exact disc areas (the kept body's area within half a pixel times its
perimeter, plus the 0.5 % of the resampling at two pixels); the arc length of a circle
of radius r within a band of depth f·2r from its lowest or highest point, 2 r acos(1 - 2f)
(boundary segments are classified by their midpoints: within two element sizes).
Runs serially and under ``mpiexec -n 2``.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

from mpi4py import MPI

import pytest
from test_ct import DISCS, PIXEL, phantom, write_dicom

from bonecontact.meshing.ct import ct_slice_mesh, main, mesh_ct, read_ct_slice

COMM = MPI.COMM_WORLD
H = 2 * PIXEL


def phantom_file(tmp_path):
    path = COMM.bcast(str(tmp_path / "phantom.dcm"), root=0)
    if COMM.rank == 0:
        write_dicom(path, phantom())
    COMM.barrier()
    return path


def disc(k):
    """Radius (m) and area (m²) of disc k of the phantom."""
    r = DISCS[k][1] * PIXEL
    return r, math.pi * r * r


@pytest.mark.parametrize("fraction", [0.1, 0.25])
@pytest.mark.parametrize("axis", [0, 1])
def test_largest_body_and_end_groups(tmp_path, axis, fraction):
    src = phantom_file(tmp_path)
    out = COMM.bcast(str(tmp_path / "ct.msh"), root=0)
    r = mesh_ct(src, out, 200.0, H, name="b", ends=(axis, fraction), comm=COMM)
    if COMM.rank != 0:
        assert r is None
        return
    radius, area = disc(1)  # the larger disc (400 HU, above 200 HU); the other dropped
    cells = [g for g in r.groups if g.dim == 2]
    assert [g.name for g in cells] == ["b"]
    perimeter = 2 * math.pi * radius
    assert abs(cells[0].measure - area) <= 0.5 * PIXEL * perimeter + 5e-3 * area
    assert "2 connected bodies" in r.notes[0] and "dropped 1" in r.notes[0]
    low, high = ("left", "right") if axis == 0 else ("bottom", "top")
    arc = 2 * radius * math.acos(1 - 2 * fraction)
    for end in (low, high):
        assert abs(r.group(f"b_{end}").measure - arc) < 2 * H
    total = sum(r.group(f"b_{g}").measure for g in (low, high, "outer"))
    assert total == pytest.approx(perimeter, rel=0.02)
    # the extent of the kept body alone: the disc's diameter
    assert r.upper[axis] - r.lower[axis] == pytest.approx(2 * radius, abs=PIXEL)


@pytest.mark.parametrize("threshold, n", [(600.0, 1), (200.0, 2)])
def test_each_body_its_own_cell_group(tmp_path, threshold, n):
    src = phantom_file(tmp_path)
    md = ct_slice_mesh(src, threshold, H, name="b", bodies="each", comm=COMM)
    cells = sorted(k for k, g in md.physical_groups.items() if g.dim == 2)
    assert cells == [f"b_{k}" for k in range(1, n + 1)]
    assert {"b_outer"} == {k for k, g in md.physical_groups.items() if g.dim == 1}


def test_command_exit_codes_and_report(tmp_path, capsys):
    src = phantom_file(tmp_path)
    out = COMM.bcast(str(tmp_path / "cmd.msh"), root=0)
    assert main([src, out, "--threshold", "200", "--size", str(H), "--all-bodies"]) == 0
    text = capsys.readouterr().out
    if COMM.rank == 0:
        assert "cmd.msh: written" in text and "'bone_1' (cells" in text
        assert "'bone_2' (cells" in text and "'bone_bottom' (facets" in text
        assert "'bone_top' (facets" in text and "area: input" in text
    missing = str(tmp_path / "no_such.dcm")
    assert main([missing, out]) == 2
    if COMM.rank == 0:
        assert "no_such.dcm: no such file" in capsys.readouterr().err


def test_bad_options_are_refused(tmp_path, capsys):
    src = phantom_file(tmp_path)
    out = COMM.bcast(str(tmp_path / "bad.msh"), root=0)
    assert main([src, out, "--end-fraction", "0.7"]) == 2
    if COMM.rank == 0:
        assert "fraction in (0, 0.5)" in capsys.readouterr().err
    with pytest.raises(ValueError, match="bodies must be one of all, largest, each"):
        ct_slice_mesh(read_ct_slice(src), 200.0, bodies="biggest", comm=COMM)


@pytest.mark.parametrize("command", ["mesh-ct", "mesh-surface"])
def test_package_command_dispatches(tmp_path, capsys, command):
    from bonecontact.runners.cli import main as bonecontact

    missing = COMM.bcast(str(tmp_path / "missing.file"), root=0)
    out = COMM.bcast(str(tmp_path / "x.msh"), root=0)
    extra = ["--size", "0.01"] if command == "mesh-surface" else []
    assert bonecontact([command, missing, out, *extra]) == 2
    if COMM.rank == 0:
        assert "missing.file: no such file" in capsys.readouterr().err
