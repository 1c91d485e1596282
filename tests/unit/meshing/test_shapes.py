"""Parametric geometry builders (bonecontact.meshing.shapes): measures of every named group against
the exact geometry.

Runs serially and under ``mpiexec -n 2/3`` (all measures are assembled and summed over
the ranks).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

from mpi4py import MPI

import gmsh
import numpy as np
import pytest
from dolfinx.io.gmsh import read_from_msh
from mesh_measures import count_owned, group_vertices, measure

from bonecontact.meshing import shapes as meshing

COMM = MPI.COMM_WORLD


def test_quarter_tube():
    r_in, r_out, h = 0.01, 0.02, 1.0e-3
    md = meshing.quarter_tube(r_in, r_out, h, COMM)
    assert set(md.physical_groups) == {"tube", "inner", "outer", "x0", "y0"}
    # Chords of length <= ~h on an arc of radius r: each arc is off by about pi h^2 / 24 in
    # area (outer arc loses area, inner arc adds) and pi h^2 / (48 r) in length.
    area = math.pi * (r_out**2 - r_in**2) / 4
    assert abs(measure(md, "tube") - area) < 2 * math.pi * h**2 / 24
    for name, r in (("inner", r_in), ("outer", r_out)):
        arc = math.pi * r / 2
        length = measure(md, name)
        assert length < arc  # a polygon inscribed in the arc
        assert arc - length < 2 * math.pi * h**2 / (48 * r)
    for name in ("x0", "y0"):
        assert measure(md, name) == pytest.approx(r_out - r_in, rel=1e-12)


@pytest.mark.parametrize("structured", [False, True])
def test_rectangle(structured):
    lx, ly, nx, ny = 0.02, 0.01, 8, 5
    md = meshing.rectangle(lx, ly, nx, ny, COMM, structured=structured)
    assert set(md.physical_groups) == {"body", "left", "right", "bottom", "top"}
    assert measure(md, "body") == pytest.approx(lx * ly, rel=1e-12)
    for name, length, n in (
        ("left", ly, ny),
        ("right", ly, ny),
        ("bottom", lx, nx),
        ("top", lx, nx),
    ):
        assert measure(md, name) == pytest.approx(length, rel=1e-12)
        assert count_owned(md, name) == n
    if structured:
        assert count_owned(md, "body") == 2 * nx * ny


def test_box():
    lx, ly, lz, h = 0.02, 0.01, 0.015, 2.5e-3
    md = meshing.box(lx, ly, lz, h, COMM)
    assert measure(md, "body") == pytest.approx(lx * ly * lz, rel=1e-12)
    faces = {
        "left": ly * lz,
        "right": ly * lz,
        "bottom": lx * lz,
        "top": lx * lz,
        "front": lx * ly,
        "back": lx * ly,
    }
    assert set(md.physical_groups) == {"body", *faces}
    for name, area in faces.items():
        assert measure(md, name) == pytest.approx(area, rel=1e-12)
    # the front face is z = 0, the top face y = ly
    _, x = group_vertices(md, "front")
    assert np.allclose(x[:, 2], 0.0)
    _, x = group_vertices(md, "top")
    assert np.allclose(x[:, 1], ly)


def test_cantilever():
    L, H, W, h = 0.1, 0.01, 0.008, 2.5e-3
    md = meshing.cantilever(L, H, W, h, COMM)
    assert set(md.physical_groups) == {"beam", "clamped", "tip", "top", "bottom", "sides"}
    assert measure(md, "beam") == pytest.approx(L * H * W, rel=1e-12)
    for name, area in (
        ("clamped", H * W),
        ("tip", H * W),
        ("top", L * W),
        ("bottom", L * W),
        ("sides", 2 * L * H),
    ):
        assert measure(md, name) == pytest.approx(area, rel=1e-12)
    _, x = group_vertices(md, "tip")
    assert np.allclose(x[:, 0], L)


def _check_non_matching(md, dim):
    """The two bodies share no vertex, and their interface facets are exterior facets."""
    lower, _ = group_vertices(md, "lower")
    upper, _ = group_vertices(md, "upper")
    assert lower.size > 0 and upper.size > 0
    assert np.intersect1d(lower, upper).size == 0
    _, xl = group_vertices(md, "lower_contact")
    _, xu = group_vertices(md, "upper_contact")
    assert len(xl) != len(xu)  # different mesh sizes
    # Equal footprints: only the corners of the interface coincide geometrically.
    dist = np.linalg.norm(xl[:, None, :] - xu[None, :, :], axis=2)
    assert np.count_nonzero(dist < 1e-12) == 2 ** (dim - 1)


def test_two_blocks_2d():
    w, h0, h1 = 0.02, 0.01, 0.012
    md = meshing.two_blocks_2d(COMM, upper_height=h1)
    names = {
        "lower",
        "upper",
        "bottom",
        "top",
        "lower_contact",
        "upper_contact",
        "lower_left",
        "lower_right",
        "upper_left",
        "upper_right",
    }
    assert set(md.physical_groups) == names
    assert measure(md, "lower") == pytest.approx(w * h0, rel=1e-12)
    assert measure(md, "upper") == pytest.approx(w * h1, rel=1e-12)
    for name in ("bottom", "top", "lower_contact", "upper_contact"):
        assert measure(md, name) == pytest.approx(w, rel=1e-12)
    for name, length in (
        ("lower_left", h0),
        ("lower_right", h0),
        ("upper_left", h1),
        ("upper_right", h1),
    ):
        assert measure(md, name) == pytest.approx(length, rel=1e-12)
    _check_non_matching(md, 2)


def test_two_blocks_2d_narrow_upper():
    md = meshing.two_blocks_2d(COMM, upper_width=0.01, upper_offset=0.004)
    assert measure(md, "upper_contact") == pytest.approx(0.01, rel=1e-12)
    assert measure(md, "lower_contact") == pytest.approx(0.02, rel=1e-12)
    _, x = group_vertices(md, "upper_left")
    assert np.allclose(x[:, 0], 0.004)


def test_two_boxes_3d():
    w, d, h0, h1 = 0.02, 0.02, 0.01, 0.01
    md = meshing.two_boxes_3d(COMM)
    # a list, not a set: every rank must run the collective measures in the same order
    sides = [f"{b}_{s}" for b in ("lower", "upper") for s in ("left", "right", "front", "back")]
    assert set(md.physical_groups) == {
        "lower",
        "upper",
        "bottom",
        "top",
        "lower_contact",
        "upper_contact",
        *sides,
    }
    assert measure(md, "lower") == pytest.approx(w * d * h0, rel=1e-12)
    assert measure(md, "upper") == pytest.approx(w * d * h1, rel=1e-12)
    for name in ("bottom", "top", "lower_contact", "upper_contact"):
        assert measure(md, name) == pytest.approx(w * d, rel=1e-12)
    for name in sides:
        assert measure(md, name) == pytest.approx(w * h0, rel=1e-12)
    _check_non_matching(md, 3)


def test_write_msh_and_read_back(tmp_shared_path):
    path = meshing.quarter_tube(0.01, 0.02, 2e-3, COMM, path=tmp_shared_path / "sub" / "tube.msh")
    assert path == tmp_shared_path / "sub" / "tube.msh" and path.is_file()
    md = read_from_msh(path, COMM, 0, gdim=2)
    direct = meshing.quarter_tube(0.01, 0.02, 2e-3, COMM)
    assert md.physical_groups == direct.physical_groups
    assert measure(md, "tube") == pytest.approx(measure(direct, "tube"), rel=1e-12)


def test_keeps_an_existing_gmsh_session():
    if COMM.rank == 0:
        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("mine")
    try:
        md = meshing.rectangle(1.0, 1.0, 2, 2, COMM)
        assert measure(md, "body") == pytest.approx(1.0)
        if COMM.rank == 0:
            assert gmsh.isInitialized()
            assert "mine" in gmsh.model.list()
    finally:
        if COMM.rank == 0:
            gmsh.finalize()


@pytest.mark.parametrize(
    "call",
    [
        lambda: meshing.quarter_tube(0.02, 0.01, 1e-3, COMM),
        lambda: meshing.rectangle(1.0, 1.0, 0, 2, COMM),
        lambda: meshing.box(1.0, -1.0, 1.0, 0.1, COMM),
        lambda: meshing.two_blocks_2d(COMM, h_upper=0.0),
    ],
)
def test_invalid_geometry_is_rejected(call):
    with pytest.raises(ValueError):
        call()


def test_hertz_3d_volume_meshers_fill_the_same_surface():
    """gmsh's Delaunay and HXT volume meshers fill the same surface mesh: every group's
    measure agrees to round-off between them, and the hemisphere's volume and curved
    area lie within the chordal error of the exact (2/3)πR³ and 2πR²."""
    R, w, hb, h = 0.01, 0.02, 0.02, 2.5e-3
    kw = dict(radius=R, block_half_width=w, block_height=hb, h_contact=h, h_far=4e-3)
    md = {m: meshing.hertz_3d(COMM, algorithm_3d=m, **kw) for m in ("delaunay", "hxt")}
    for name in ("sphere", "block", "sphere_contact", "block_contact", "sphere_top"):
        assert measure(md["hxt"], name) == pytest.approx(measure(md["delaunay"], name), rel=1e-10)
    assert measure(md["hxt"], "block") == pytest.approx(4 * w * w * hb, rel=1e-12)
    # inscribed: the chordal defect of a facet of size h on a sphere is ~ h²/(8R) in depth
    vol, area = 2 * math.pi * R**3 / 3, 2 * math.pi * R**2
    assert 0 < vol - measure(md["hxt"], "sphere") < area * h**2 / (4 * R)
    assert 0 < area - measure(md["hxt"], "sphere_contact") < area * h**2 / (2 * R**2)


def test_hertz_3d_unknown_volume_mesher_is_rejected():
    with pytest.raises(ValueError, match="algorithm_3d must be one of"):
        meshing.hertz_3d(COMM, algorithm_3d="frontal")
