"""The report of ``bonecontact mesh-surface`` (bonecontact.meshing.report, stl.mesh_surface).

References: a box's exact volume and face areas (its triangles are kept: exact to
rounding); a sphere of radius R against 4/3 π R³ and 4 π R²: an inscribed convex
polyhedron whose triangles have circumradius at most ρ contains the ball of radius
R - δ, δ = R - sqrt(R² - ρ²), so its volume lies in [4/3 π (R-δ)³, 4/3 π R³] and its
area in [4 π (R-δ)², 4 π R²] (monotonicity of volume and area of convex bodies under
inclusion); the error falls by about 4 from one icosphere subdivision to the next.
Runs serially and under ``mpiexec -n 2`` (the report is made on rank 0).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

from mpi4py import MPI

import meshio
import numpy as np
import pytest
import pyvista as pv

from bonecontact.meshing import Surface, SurfaceRegion
from bonecontact.meshing.report import format_report
from bonecontact.meshing.stl import main, mesh_surface, select_triangles

COMM = MPI.COMM_WORLD
R = 0.02


def icosphere(nsub):
    s = pv.Icosphere(radius=R, nsub=nsub)
    return Surface(np.asarray(s.points, float), s.faces.reshape(-1, 4)[:, 1:].astype(np.int64))


def box_surface(lx, ly, lz, n):
    b = pv.Box(bounds=(0, lx, 0, ly, 0, lz), level=n, quads=False).triangulate().clean()
    return Surface(np.asarray(b.points, float), b.faces.reshape(-1, 4)[:, 1:].astype(np.int64))


def circumradius_max(s):
    a, b, c = (s.points[s.triangles[:, i]] for i in range(3))
    la, lb, lc = (np.linalg.norm(u, axis=1) for u in (b - c, c - a, a - b))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    return float((la * lb * lc / (4 * area)).max())


def shared_path(tmp_path, name):
    return COMM.bcast(str(tmp_path / name), root=0)


@pytest.mark.parametrize("nsub", [2, 3])
def test_sphere_report_within_the_inscribed_bounds(tmp_path, nsub):
    s = icosphere(nsub)
    path = shared_path(tmp_path, f"ball{nsub}.msh")
    top = SurfaceRegion("top", cone=((0, 1, 0), 30))
    r = mesh_surface(s, path, 8e-3, name="ball", regions=[top], remesh=False, comm=COMM)
    if COMM.rank != 0:
        assert r is None
        return
    delta = R - math.sqrt(R**2 - circumradius_max(s) ** 2)
    volume = r.group("ball").measure
    area = r.group("top").measure + r.group("ball_surface").measure
    assert 4 / 3 * math.pi * (R - delta) ** 3 <= volume <= 4 / 3 * math.pi * R**3
    assert 4 * math.pi * (R - delta) ** 2 <= area <= 4 * math.pi * R**2
    assert volume == pytest.approx(s.volume, rel=1e-10)  # the boundary is the input's
    assert r.volume_change == pytest.approx(0.0, abs=1e-10)
    assert r.cells == r.group("ball").count and r.vertices >= len(s.points)
    assert r.lower == pytest.approx(s.points.min(axis=0)) and r.long_axis in "xyz"
    assert "merged" not in " ".join(r.repairs)
    text = format_report(r)
    assert f"{r.cells} tetrahedra" in text and "'top' (facets" in text and "change +0.000 %" in text


def test_sphere_error_falls_with_refinement(tmp_path):
    errors = []
    for nsub in (2, 3):
        path = shared_path(tmp_path, f"b{nsub}.msh")
        r = mesh_surface(icosphere(nsub), path, 8e-3, remesh=False, comm=COMM)
        if COMM.rank == 0:
            errors.append(1 - r.cell_measure / (4 / 3 * math.pi * R**3))
    if COMM.rank == 0:
        assert 3.0 < errors[0] / errors[1] < 5.0  # second order in the edge length


@pytest.mark.parametrize("n", [1, 3])
def test_box_volume_and_face_area_exact(tmp_path, n):
    """Exact up to pyvista's float32 coordinates (relative 1e-7)."""
    lx, ly, lz = 0.03, 0.05, 0.02
    s = box_surface(lx, ly, lz, n)
    path = shared_path(tmp_path, f"box{n}.msh")
    regions = [
        SurfaceRegion("up", cone=((0, 1, 0), 10)),
        SurfaceRegion("down", cone=((0, -1, 0), 10)),
    ]
    r = mesh_surface(s, path, 0.01, regions=regions, remesh=False, comm=COMM)
    if COMM.rank == 0:
        assert r.group("bone").measure == pytest.approx(lx * ly * lz, rel=1e-6)
        assert r.group("up").measure == pytest.approx(lx * lz, rel=1e-6)
        assert r.group("down").measure == pytest.approx(lx * lz, rel=1e-6)
        side = 2 * (lx * ly + ly * lz)
        assert r.group("bone_surface").measure == pytest.approx(side, rel=1e-6)
        assert r.upper == pytest.approx((lx, ly, lz), rel=1e-6) and r.long_axis == "y"


@pytest.mark.parametrize("nsub, h", [(3, 6e-3), (4, 4e-3), (4, 6e-3)])
def test_remeshing_volume_change_sign_and_size(tmp_path, nsub, h):
    s = icosphere(nsub)
    path = shared_path(tmp_path, f"re{nsub}_{h}.msh")
    r = mesh_surface(s, path, h, comm=COMM)
    if COMM.rank == 0:
        # the remeshed vertices lie on the input surface: a convex polyhedron inscribed in
        # it, with triangles of circumradius below h (edges about h): volume lost, at most
        # 3 δ / R with δ = h² / (2 R)
        bound = 3 * (h**2 / (2 * R)) / R
        assert -bound < r.volume_change < 0
        assert r.input_measure == pytest.approx(s.volume, rel=1e-12)
        assert any("pyacvd" in x for x in r.repairs)
        assert "change -" in format_report(r)


@pytest.mark.parametrize(
    "options, named",
    [
        (
            ["--box", "top", "-1", "-1", "-1", "1", "1", "1", "--cone", "top", "0", "1", "0", "30"],
            "--cone top",
        ),
        (
            [
                "--side",
                "a",
                "0",
                "0",
                "0",
                "0",
                "1",
                "0",
                "--side",
                "a",
                "0",
                "0",
                "0",
                "1",
                "0",
                "0",
            ],
            "--side a",
        ),
        (["--cone", "bone_surface", "0", "1", "0", "30"], "--name"),
    ],
)
def test_repeated_region_option_is_an_error(tmp_path, capsys, options, named):
    s = icosphere(2)
    stl = shared_path(tmp_path, "ball.stl")
    if COMM.rank == 0:
        meshio.write(stl, meshio.Mesh(s.points, [("triangle", s.triangles)]), binary=True)
    COMM.barrier()
    out = shared_path(tmp_path, "never.msh")
    assert main([stl, out, "--size", "0.006", *options]) == 2
    if COMM.rank == 0:
        err = capsys.readouterr().err
        assert named in err and "already named" in err
    assert not tmp_path.joinpath("never.msh").exists()


def test_repeated_region_name_in_the_api():
    s = icosphere(2)
    twice = [
        SurfaceRegion("a", cone=((0, 1, 0), 30)),
        SurfaceRegion("a", box=((0, 0, 0), (1, 1, 1))),
    ]
    with pytest.raises(ValueError, match="'a' is given twice"):
        select_triangles(s, twice, "rest")


def test_command_prints_the_report(tmp_path, capsys):
    s = icosphere(2)
    stl = shared_path(tmp_path, "ball_mm.stl")
    if COMM.rank == 0:
        meshio.write(stl, meshio.Mesh(s.points * 1e3, [("triangle", s.triangles)]), binary=True)
    COMM.barrier()
    out = shared_path(tmp_path, "ball.msh")
    args = [stl, out, "--size", "0.008", "--scale", "1e-3", "--keep-triangles"]
    assert main([*args, "--cone", "top", "0", "1", "0", "30"]) == 0
    text = capsys.readouterr().out
    if COMM.rank == 0:
        assert "ball.msh: written" in text and "group 'top' (facets" in text
        assert "change +0.000 %" in text and "multiplied by 0.001" in text
        assert "longest along" in text and "bounding box" in text
    else:
        assert text == ""


@pytest.mark.parametrize(
    "defect, note",
    [("hole", "pymeshfix: holes filled"), ("inverted", "inverted shell flipped")],
)
def test_every_repair_is_listed(tmp_path, defect, note):
    s = icosphere(2)
    tri = s.triangles[1:] if defect == "hole" else s.triangles[:, ::-1]
    broken = Surface(s.points, tri, "broken.stl")
    path = shared_path(tmp_path, f"{defect}.msh")
    r = mesh_surface(broken, path, 8e-3, repair=True, remesh=False, comm=COMM)
    if COMM.rank == 0:
        assert any(note in x for x in r.repairs)
        assert note in format_report(r)
        # the repaired surface bounds the mesh: its volume is the input's, within the
        # one filled triangle (a hole) of the sphere's
        assert r.volume_change == pytest.approx(0.0, abs=1e-10)
        assert r.cell_measure == pytest.approx(s.volume, rel=0.02)
