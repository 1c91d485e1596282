"""Tetrahedral bones from closed surfaces (bonecontact.meshing.stl).

References: the volume and area of the input surface (divergence theorem on its
triangles), the exact sphere for the cortical shell (inner radius R - t), the areas of the
triangles each region selects.  Runs serially and under ``mpiexec -n 2`` (the mesh is
built on rank 0 and distributed; every measure is summed over the ranks).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

from mpi4py import MPI

import meshio
import numpy as np
import pytest
import pyvista as pv
from mesh_measures import group_vertices, measure

from bonecontact.meshing import (
    MeshInputError,
    Surface,
    SurfaceRegion,
    anatomy_surface,
    bone_from_surface,
    read_gmsh_mesh,
)
from bonecontact.meshing.stl import select_triangles

COMM = MPI.COMM_WORLD
R = 0.02


def icosphere(nsub=3, radius=R):
    s = pv.Icosphere(radius=radius, nsub=nsub)
    return Surface(np.asarray(s.points, float), s.faces.reshape(-1, 4)[:, 1:].astype(np.int64))


TOP = SurfaceRegion("top", cone=((0, 1, 0), 30))
BASE = SurfaceRegion("base", plane=((0, -0.015, 0), (0, -1, 0)))
SIDE = SurfaceRegion("side", box=((0.01, -1, -1), (1, 1, 1)))


def test_region_selection():
    c = np.array([[0.0, 0.02, 0.0], [0.0, -0.019, 0.0], [0.015, 0.0, 0.0], [-0.015, 0.0, 0.0]])
    n = np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    assert TOP.select(c, n).tolist() == [True, False, False, False]
    assert BASE.select(c, n).tolist() == [False, True, False, False]
    assert SIDE.select(c, n).tolist() == [False, False, True, False]
    both = SurfaceRegion("x", cone=((1, 0, 0), 10), plane=((0, 0, 0), (-1, 0, 0)))
    assert not both.select(c, n).any()  # criteria combine with "and"
    with pytest.raises(ValueError, match="at least one"):
        SurfaceRegion("nothing")


def test_first_region_wins_and_rest_is_named():
    s = icosphere()
    groups = select_triangles(s, [TOP, SurfaceRegion("upper", plane=((0, 0, 0), (0, 1, 0)))], "r")
    assert not set(groups["top"]) & set(groups["upper"])
    assert sum(len(v) for v in groups.values()) == len(s.triangles)
    with pytest.raises(MeshInputError, match="'far' selects no triangle"):
        select_triangles(s, [SurfaceRegion("far", box=((1, 1, 1), (2, 2, 2)))], "r")


def test_sphere_with_cortical_shell():
    s = icosphere()  # 3 mm triangles, kept as they are
    h, t = 5e-3, 4e-3
    md = bone_from_surface(s, h, t, name="ball", regions=[TOP, BASE, SIDE], remesh=False, comm=COMM)
    assert set(md.physical_groups) == {
        "ball_cortical",
        "ball_cancellous",
        "top",
        "base",
        "side",
        "ball_surface",
    }
    cortical, cancellous = measure(md, "ball_cortical"), measure(md, "ball_cancellous")
    # the boundary is the input's triangles: volume and area exact
    assert cortical + cancellous == pytest.approx(s.volume, rel=1e-10)
    assert measure(md) == pytest.approx(s.area, rel=1e-10)
    groups = select_triangles(s, [TOP, BASE, SIDE], "ball_surface")
    areas = s.triangle_areas()
    for name, tri in groups.items():
        assert measure(md, name) == pytest.approx(areas[tri].sum(), rel=1e-10)
    # the cortex/core interface lies at depth t within one element size
    g_cort, x_cort = group_vertices(md, "ball_cortical")
    g_core, x_core = group_vertices(md, "ball_cancellous")
    interface = x_core[np.isin(g_core, g_cort)]
    r = np.linalg.norm(interface, axis=1)
    assert len(r) > 50
    assert np.all(np.abs(r - (R - t)) < h)
    assert abs(r.mean() - (R - t)) < 0.1 * h
    shell = 4 / 3 * np.pi * (R**3 - (R - t) ** 3)
    assert cortical == pytest.approx(shell, rel=0.1)


def test_remeshed_sphere_keeps_volume_and_area():
    s = icosphere(nsub=4)  # 1.5 mm triangles, remeshed to 3 mm
    md = bone_from_surface(s, 3e-3, name="ball", comm=COMM)
    assert set(md.physical_groups) == {"ball", "ball_surface"}
    assert measure(md, "ball") == pytest.approx(s.volume, rel=0.01)
    assert measure(md) == pytest.approx(s.area, rel=0.01)


def test_broken_file_is_refused_on_every_rank(tmp_path):
    s = icosphere(nsub=2)
    path = tmp_path / f"open{COMM.rank}.stl"
    meshio.write(path, meshio.Mesh(s.points, [("triangle", s.triangles[1:])]), binary=True)
    with pytest.raises(MeshInputError, match=r"open surface: 3 boundary edges"):
        bone_from_surface(path, 5e-3, 2e-3, comm=COMM)


def test_written_file_loads_with_its_groups(tmp_path):
    path = COMM.bcast(str(tmp_path / "ball.msh"), root=0)
    s = icosphere(nsub=2)
    bone_from_surface(s, 6e-3, 3e-3, name="ball", regions=[TOP], remesh=False, path=path, comm=COMM)
    dim, md = read_gmsh_mesh(path, COMM, 3)
    assert dim == 3
    assert {"ball_cortical", "ball_cancellous", "top", "ball_surface"} <= set(md.physical_groups)
    assert measure(md, "ball_cortical") + measure(md, "ball_cancellous") == pytest.approx(
        s.volume, rel=1e-10
    )


def test_shipped_vertebra_meshes():
    l4 = anatomy_surface("L4")
    endplate = SurfaceRegion(
        "L4_endplate", cone=((0, 1, 0), 35), box=((-0.02, 0.02, -0.03), (0.02, 0.04, 0.03))
    )
    md = bone_from_surface(l4, 5e-3, 2e-3, name="L4", regions=[endplate], remesh=False, comm=COMM)
    assert set(md.physical_groups) == {"L4_cortical", "L4_cancellous", "L4_endplate", "L4_surface"}
    total = measure(md, "L4_cortical") + measure(md, "L4_cancellous")
    assert total == pytest.approx(l4.volume, rel=1e-10)
    assert measure(md) == pytest.approx(l4.area, rel=1e-10)
    # a vertebral body is mostly cancellous; the thin processes are all cortex
    assert 0.2 < measure(md, "L4_cancellous") / total < 0.8
    assert 1e-4 < measure(md, "L4_endplate") < 2e-3  # the upper endplate: a few cm²


def test_command_line_exit_status(tmp_path, capsys):
    from bonecontact.meshing.stl import main

    s = icosphere(nsub=2)
    tmp = COMM.bcast(tmp_path, root=0)  # one set of files for all ranks
    broken = tmp / "inverted.stl"
    good = tmp / "ball_mm.stl"
    if COMM.rank == 0:
        inverted = meshio.Mesh(s.points, [("triangle", s.triangles[:, ::-1])])
        meshio.write(broken, inverted, binary=True)
        meshio.write(good, meshio.Mesh(s.points * 1e3, [("triangle", s.triangles)]), binary=True)
    COMM.barrier()
    out = tmp / "out.msh"
    assert main([str(broken), str(out), "--size", "0.005"]) == 2
    err = capsys.readouterr().err
    assert ("inverted.stl: inverted shell" in err) == (COMM.rank == 0)  # printed once
    assert not out.exists()
    args = [str(good), str(out), "--size", "0.006", "--scale", "1e-3", "--keep-triangles"]
    assert main([*args, "--cone", "top", "0", "1", "0", "30", "--cortical", "0.003"]) == 0
    m = meshio.read(out)
    assert {"bone_cortical", "bone_cancellous", "top", "bone_surface"} == set(m.field_data)
