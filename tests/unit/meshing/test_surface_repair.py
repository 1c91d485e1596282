"""Reading, checking, repairing and remeshing closed surfaces
(bonecontact.meshing.surface_repair), on icospheres written as STL files with known defects.

References: the volume and area of the unbroken icosphere (divergence theorem on its
triangles), and the exact counts of the defects made here.
"""

import meshio
import numpy as np
import pytest
import pyvista as pv

from bonecontact.meshing.surface_repair import (
    MeshInputError,
    Surface,
    merge_vertices,
    orient_surface,
    prepare_surface,
    read_surface,
    remesh_surface,
    surface_defects,
)

R = 0.02


def icosphere(nsub=3, radius=R):
    s = pv.Icosphere(radius=radius, nsub=nsub)
    return Surface(np.asarray(s.points, float), s.faces.reshape(-1, 4)[:, 1:].astype(np.int64))


def write_stl(path, points, triangles):
    meshio.write(path, meshio.Mesh(points, [("triangle", triangles)]), binary=True)
    return path


def soup(surface):
    """Every triangle with its own three vertices (as in an STL file)."""
    pts = surface.points[surface.triangles].reshape(-1, 3)
    return Surface(pts, np.arange(len(pts)).reshape(-1, 3))


def test_divergence_theorem_measures_of_a_box():
    b = pv.Box(bounds=(0, 1, 0, 1, 0, 1)).triangulate().clean()
    corners = np.round(np.asarray(b.points, float))  # exactly 0 or 1 (pyvista: float32)
    s = Surface(corners * [0.01, 0.02, 0.03], b.faces.reshape(-1, 4)[:, 1:])
    assert s.volume == pytest.approx(0.01 * 0.02 * 0.03, rel=1e-12)
    assert s.area == pytest.approx(2 * (0.01 * 0.02 + 0.02 * 0.03 + 0.01 * 0.03), rel=1e-12)


def test_duplicates_and_orientation_are_repaired_silently():
    ref = icosphere()
    broken = soup(ref)
    flip = np.arange(0, len(ref.triangles), 7)  # 1 in 7 triangles turned over
    broken.triangles[flip] = broken.triangles[flip][:, ::-1]
    fixed = orient_surface(merge_vertices(broken))
    assert len(fixed.points) == len(ref.points)
    assert len(fixed.triangles) == len(ref.triangles)
    assert fixed.volume == pytest.approx(ref.volume, rel=1e-12)
    assert surface_defects(fixed) == []
    assert any(f"{len(flip)} triangles reoriented" in r for r in fixed.repairs)


def test_closed_file_passes(tmp_path):
    ref = icosphere()
    path = write_stl(tmp_path / "ball.stl", ref.points * 1e3, ref.triangles)  # millimetres
    s = prepare_surface(path, scale=1e-3)
    assert s.volume == pytest.approx(ref.volume, rel=1e-6)  # binary STL: float32
    assert s.area == pytest.approx(ref.area, rel=1e-6)


def test_open_surface_is_refused_with_count_and_location(tmp_path):
    ref = icosphere()
    top = np.argmax(ref.centroids()[:, 1])  # the triangle at the top (y = R)
    path = write_stl(tmp_path / "open.stl", ref.points, np.delete(ref.triangles, top, axis=0))
    with pytest.raises(MeshInputError) as err:
        prepare_surface(path)
    msg = str(err.value)
    assert str(path) in msg and "open surface: 3 boundary edges in 1 hole(s)" in msg
    where = np.array([float(v) for v in msg.split("around (")[1].split(")")[0].split(",")])
    assert np.linalg.norm(where - ref.centroids()[top]) < 1e-5  # printed to 4 digits


def test_non_manifold_edge_is_refused_with_location(tmp_path):
    ref = icosphere()
    a, b = ref.triangles[0, :2]
    fin_tip = 2.0 * ref.points[[a, b]].mean(axis=0)  # a fin sticking out of the edge (a, b)
    pts = np.vstack([ref.points, fin_tip])
    tri = np.vstack([ref.triangles, [a, b, len(ref.points)]])
    path = write_stl(tmp_path / "fin.stl", pts, tri)
    with pytest.raises(MeshInputError) as err:
        prepare_surface(path)
    msg = str(err.value)
    assert str(path) in msg and "non-manifold edge: 1 edge(s)" in msg
    where = np.array([float(v) for v in msg.split("first at (")[1].split(")")[0].split(",")])
    assert np.linalg.norm(where - ref.points[[a, b]].mean(axis=0)) < 1e-5


def test_inverted_shell_is_refused_then_flipped(tmp_path):
    ref = icosphere()
    path = write_stl(tmp_path / "inverted.stl", ref.points, ref.triangles[:, ::-1])
    with pytest.raises(MeshInputError, match=r"inverted\.stl: inverted shell: signed volume -"):
        prepare_surface(path)
    s = prepare_surface(path, repair=True)
    assert s.volume == pytest.approx(ref.volume, rel=1e-6)
    assert "inverted shell flipped" in s.repairs


def test_small_hole_is_filled_on_request(tmp_path):
    ref = icosphere(nsub=4)
    near_top = np.argsort(-ref.centroids()[:, 1])[:6]  # a hole of six triangles
    path = write_stl(tmp_path / "hole.stl", ref.points, np.delete(ref.triangles, near_top, axis=0))
    assert "open surface" in surface_defects(merge_vertices(read_surface(path)))[0]
    s = prepare_surface(path, repair=True)
    assert surface_defects(s) == []
    assert s.volume == pytest.approx(ref.volume, rel=1e-3)
    assert any("pymeshfix" in r for r in s.repairs)


def test_unreadable_file_is_refused(tmp_path):
    path = tmp_path / "bad.stl"
    path.write_text("solid nothing\nthis is not an stl\n")
    with pytest.raises(MeshInputError, match=r"bad\.stl"):
        prepare_surface(path)


def test_remesh_to_requested_size():
    ref = icosphere(nsub=4)  # 1.5 mm triangles, remeshed to 3 mm
    s = remesh_surface(ref, 3e-3)
    assert surface_defects(s) == []
    assert s.mean_edge() == pytest.approx(3e-3, rel=0.25)
    assert s.volume == pytest.approx(ref.volume, rel=0.01)
    assert s.area == pytest.approx(ref.area, rel=0.01)
    # a coarse input (8 mm triangles) is refined to the requested size
    coarse = icosphere(nsub=2)
    fine = remesh_surface(coarse, 2e-3)
    assert fine.mean_edge() == pytest.approx(2e-3, rel=0.25)
    assert fine.volume == pytest.approx(coarse.volume, rel=0.01)


def test_remeshing_that_loses_volume_is_refused():
    # a thin plate (1 mm) remeshed to 6 mm triangles: clusters span both faces
    b = pv.Box(bounds=(0, 0.03, 0, 0.001, 0, 0.03), level=8).triangulate().clean()
    s = Surface(np.asarray(b.points, float), b.faces.reshape(-1, 4)[:, 1:].astype(np.int64))
    s = orient_surface(merge_vertices(s))
    with pytest.raises(MeshInputError, match="changes the enclosed volume by"):
        remesh_surface(s, 6e-3)
