"""The geometry of a quarter-elliptical corner crack in a 3D body
(bonecontact.fracture.surface_body3d: faces_at, onto_edge, corner_frame, corner_point,
corner_parameter; cut_mouth with ``shape = "quarter_elliptical"``).

The body is the box [0, 2] × [0, 2] × [0, 1] triangulated by hand (a 0.25 grid on every
face, outward), the crack plane y = 1 across the edge x = 0, z = 1 where the side face
x = 0 meets the top face z = 1:

* the faces near a point: one on a face, two on an edge, three at a vertex; a point near
  the edge moved onto it;
* the frame: the centre moved onto the edge, an axis 10° off the top face's line moved
  onto it, c along it and a down the side face, right-handed (c ≥ a and c < a);
* the cut mouth (centre 0.03 off a grid line): its ends at c along the top face and a
  down the side face (within 5 % of the smaller: an end snaps to a vertex), the front the
  quarter arc between them (a/c = 0.5 and 2), ψ = 45° where Newman and Raju put it; the
  cut boundary closed;
* bad input naming the key: a centre on a face or at a vertex, a re-entrant edge (the box
  turned inside out), a plane containing the edge (``normal``), an axis along no face or
  out of the body (``axis``); a semi-elliptical crack centred on the edge (``centre``);
  and the scene table: ``length`` and ``axis`` required,
  ``half_length`` refused.

Pure NumPy, no mesh: the same on every rank.
"""

from __future__ import annotations

import math

import _box_surface
import numpy as np
import pytest

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.body3d import BodySurface
from bonecontact.fracture.crack3d import SurfaceBreakingCrack, planar_crack_from_table
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.surface_body3d import (
    corner_frame,
    corner_parameter,
    corner_point,
    crack_frame,
    cut_mouth,
    faces_at,
    onto_edge,
)

SIZE = (2.0, 2.0, 1.0)
EDGE_POINT = np.array([0.0, 1.0, 1.0])  # on the edge x = 0, z = 1


def box_triangles(h: float = 0.25, inside_out: bool = False) -> np.ndarray:
    """The box's boundary: a grid of spacing ``h`` on each face, two triangles a square,
    outward (inward when ``inside_out``); shape (n, 3, 3)."""
    return _box_surface.box_triangles(SIZE, h, inside_out)


def box_mesh(inside_out: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(nodes, triangles as node indices) of :func:`box_triangles`."""
    X = box_triangles(inside_out=inside_out).reshape(-1, 3)
    nodes, inv = np.unique(np.round(X, 9), axis=0, return_inverse=True)
    return nodes, inv.reshape(-1, 3)


def corner(a: float = 0.2, c: float = 0.2, **kw) -> SurfaceBreakingCrack:
    v = {"centre": tuple(EDGE_POINT), "normal": (0.0, 1.0, 0.0), "axis": (1.0, 0.0, 0.0)} | kw
    return SurfaceBreakingCrack(v["centre"], v["normal"], a, c, v["axis"], "quarter_elliptical")


def test_faces_near_a_face_an_edge_and_a_vertex() -> None:
    nodes, conn = box_mesh()
    assert len(faces_at(nodes, conn, np.array([1.0, 1.0, 1.0]), 0.05)) == 1
    faces = faces_at(nodes, conn, EDGE_POINT, 0.05)
    normals = sorted(tuple(np.round(f.normal, 12)) for f in faces)
    assert normals == [(-1.0, 0.0, 0.0), (0.0, 0.0, 1.0)]
    assert len(faces_at(nodes, conn, np.array([0.0, 0.0, 1.0]), 0.05)) == 3
    off = EDGE_POINT + np.array([0.01, 0.0, -0.02])
    np.testing.assert_allclose(onto_edge(off, faces_at(nodes, conn, off, 0.05)), EDGE_POINT)


@pytest.mark.parametrize(("a", "c"), [(0.2, 0.4), (0.4, 0.2)])
def test_frame_moves_centre_and_axis_onto_the_edge_and_face(a: float, c: float) -> None:
    nodes, conn = box_mesh()
    tilt = math.radians(10.0)
    crack = corner(a, c, centre=(0.01, 1.0, 0.99), axis=(math.cos(tilt), 0.0, math.sin(tilt)))
    ell, framed = corner_frame(crack, nodes, conn)
    np.testing.assert_allclose(framed.centre, EDGE_POINT, atol=1e-12)
    np.testing.assert_allclose(framed.axis, (1.0, 0.0, 0.0), atol=1e-12)
    R = ell.rotation
    assert np.linalg.det(R) == pytest.approx(1.0)
    np.testing.assert_allclose(R[2], (0.0, 1.0, 0.0))
    assert (ell.a, ell.b) == (max(a, c), min(a, c))
    np.testing.assert_allclose(corner_point(framed, ell, 0.0), EDGE_POINT + (c, 0, 0), atol=1e-12)
    deep = corner_point(framed, ell, 0.5 * math.pi)
    np.testing.assert_allclose(deep, EDGE_POINT + (0, 0, -a), atol=1e-12)


@pytest.mark.parametrize(("a", "c"), [(0.2, 0.4), (0.4, 0.2)])
def test_cut_mouth_of_a_corner_crack(a: float, c: float) -> None:
    tris = box_triangles()
    body = BodySurface(tris, np.ones(len(tris), dtype=np.int32), {1: "wall"}, ("box", 1), 0.25)
    cut = cut_mouth(body, corner(a, c, centre=(0.0, 1.03, 1.0)), TipMesh(0.02, 0.12))
    X = cut.nodes[list(cut.mouth)]
    ends = sorted([X[0], X[-1]], key=lambda p: p[0])
    tol = 0.05 * min(a, c)  # the front's end snaps to a vertex within a tenth of an edge
    np.testing.assert_allclose(ends[0], EDGE_POINT + (0, 0.03, -a), atol=tol)
    np.testing.assert_allclose(ends[1], EDGE_POINT + (c, 0.03, 0), atol=tol)
    assert np.allclose(X[:, 1], 1.03, atol=1e-12)
    p0, p1 = cut.arc.phi_range
    assert p1 - p0 == pytest.approx(0.5 * math.pi, abs=0.02)
    mid = cut.arc.point(corner_parameter(cut, 0.25 * math.pi))[0]
    np.testing.assert_allclose(mid, (c / math.sqrt(2), 1.03, 1.0 - a / math.sqrt(2)), atol=1e-9)
    edges: dict[tuple[int, int], int] = {}
    for t in cut.triangles:
        for k in range(3):
            e = tuple(sorted((int(t[k]), int(t[(k + 1) % 3]))))
            edges[e] = edges.get(e, 0) + 1
    assert set(edges.values()) == {2}  # closed


@pytest.mark.parametrize(
    ("kw", "key", "text"),
    [
        ({"centre": (1.0, 1.0, 1.0)}, "centre", "1 face"),
        ({"centre": (0.0, 0.0, 1.0)}, "centre", "3 face"),
        ({"normal": (1.0, 0.0, 0.0), "axis": (0.0, 0.0, -1.0)}, "normal", "cross the edge"),
        ({"axis": (math.sqrt(0.5), 0.0, -math.sqrt(0.5))}, "axis", "along one of the faces"),
        ({"axis": (-1.0, 0.0, 0.0)}, "axis", "out of the body"),
    ],
)
def test_bad_corner_cracks_name_the_key(kw: dict, key: str, text: str) -> None:
    nodes, conn = box_mesh()
    with pytest.raises(ParameterError, match=text) as info:
        corner_frame(corner(**kw), nodes, conn)
    assert info.value.key == key


def test_semi_elliptical_crack_on_an_edge_is_refused() -> None:
    nodes, conn = box_mesh()
    semi = SurfaceBreakingCrack(tuple(EDGE_POINT), (0.0, 1.0, 0.0), 0.2, 0.4)
    with pytest.raises(ParameterError, match="quarter_elliptical") as info:
        crack_frame(semi, nodes, conn)
    assert info.value.key == "centre"
    mid_face = SurfaceBreakingCrack((1.0, 1.0, 1.0), (0.0, 1.0, 0.0), 0.2, 0.4)
    ell, _ = crack_frame(mid_face, nodes, conn)  # away from the edge: as before
    np.testing.assert_allclose(ell.rotation[1], (0.0, 0.0, -1.0), atol=1e-12)


def test_re_entrant_edge_is_refused() -> None:
    nodes, conn = box_mesh(inside_out=True)
    with pytest.raises(ParameterError, match="re-entrant") as info:
        corner_frame(corner(), nodes, conn)
    assert info.value.key == "centre"


def test_table_keys() -> None:
    table = {
        "shape": "quarter_elliptical",
        "centre": [0.0, 1.0, 1.0],
        "normal": [0.0, 1.0, 0.0],
        "depth": 0.2,
        "length": 0.4,
        "axis": [1.0, 0.0, 0.0],
    }
    crack = planar_crack_from_table(table)
    assert (crack.shape, crack.depth, crack.half_length) == ("quarter_elliptical", 0.2, 0.4)
    for missing in ("length", "axis", "depth"):
        with pytest.raises(ParameterError, match="is required") as info:
            planar_crack_from_table({k: v for k, v in table.items() if k != missing})
        assert info.value.key == missing
    with pytest.raises(ParameterError) as info:
        planar_crack_from_table(table | {"half_length": 0.4})
    assert info.value.key == "half_length"
    with pytest.raises(ParameterError) as info:
        planar_crack_from_table(table | {"shape": "semi_elliptical", "half_length": 0.4})
    assert info.value.key == "length"
    with pytest.raises(ParameterError) as info:
        planar_crack_from_table(table | {"axis": [0.0, 1.0, 0.0]})
    assert info.value.key == "axis"
