"""The 3D ``[[crack]]`` geometry (bonecontact.fracture.crack3d): parsing, its frame and
front against closed forms, and every bad value refused naming its key."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bonecontact.fracture.crack3d import PlanarCrack, planar_crack_from_table
from bonecontact.scene.errors import SceneError
from bonecontact.scene.fracture_tables import crack_from_table

S = math.sqrt(0.5)
DISC = {"centre": [1.0, 2.0, 3.0], "normal": [0.0, S, S], "radius": 0.5, "region": "bone"}
ELLIPSE = {
    "shape": "ellipse",
    "centre": [0.0, 0.0, 0.0],
    "normal": [0.0, 0.0, 1.0],
    "semi_axes": [2.0, 1.0],
    "axis": [S, S, 0.0],
    "region": "bone",
}


def test_disc_frame_and_front() -> None:
    spec = crack_from_table(DISC, 1, dim=3)
    c = spec.crack
    assert isinstance(c, PlanarCrack) and spec.name == "crack1" and spec.front_points == 8
    R = c.axes
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-14)  # orthonormal
    assert np.linalg.det(R) == pytest.approx(1.0)  # right-handed
    np.testing.assert_allclose(R[2], [0.0, S, S], atol=1e-15)
    front = c.front()
    phi = c.front_parameters(6)
    pts = front.point(phi)
    np.testing.assert_allclose(np.linalg.norm(pts - c.centre, axis=1), 0.5, rtol=1e-12)
    np.testing.assert_allclose((pts - c.centre) @ R[2], 0.0, atol=1e-15)  # in the plane
    np.testing.assert_allclose(np.diff(phi), 2 * math.pi / 6, rtol=1e-6)  # a circle: even φ
    for p, f in zip(pts, phi, strict=True):
        e1, e2, e3 = front.frame(f)
        np.testing.assert_allclose(e1, (p - c.centre) / 0.5, atol=1e-12)  # radial, outward
        np.testing.assert_allclose(e2, R[2], atol=1e-15)
        np.testing.assert_allclose(e3, np.cross(e1, e2), atol=1e-15)
    # the nearest front point of points off the front
    probe = pts + 0.1 * np.array([front.frame(f)[0] for f in phi])
    np.testing.assert_allclose(np.cos(front.nearest(probe)), np.cos(phi), atol=1e-12)


def test_ellipse_points_are_equally_spaced_in_arc_length() -> None:
    c = planar_crack_from_table(ELLIPSE)
    front = c.front()
    phi = c.front_parameters(8)
    s = front.arc_length(phi)
    np.testing.assert_allclose(np.diff(s), front.perimeter / 8, rtol=1e-4)
    p0 = front.point(0.0)[0]
    np.testing.assert_allclose(p0, [2 * S, 2 * S, 0.0], atol=1e-14)  # a along `axis`
    # Ramanujan's perimeter of the 2 × 1 ellipse
    h = (2 - 1) ** 2 / (2 + 1) ** 2
    ram = math.pi * 3 * (1 + 3 * h / (10 + math.sqrt(4 - 3 * h)))
    assert front.perimeter == pytest.approx(ram, rel=1e-6)
    pts = c.sample_points()
    loc = front.local(pts)
    assert np.all((loc[:, 0] / 2) ** 2 + loc[:, 1] ** 2 <= 1 + 1e-12)  # on the crack
    assert np.max(np.abs(loc[:, 2])) < 1e-14


@pytest.mark.parametrize(
    ("change", "key", "text"),
    [
        ({"normal": [0.0, 0.0, 0.0]}, "normal", "unit vector"),
        ({"normal": [0.0, 0.0, 2.0]}, "normal", "unit vector"),
        ({"normal": [0.0, 1.0]}, "normal", "three numbers"),
        ({"radius": 0.0}, "radius", "positive"),
        ({"radius": -1.0}, "radius", "positive"),
        ({"radius": None}, "radius", "required"),
        ({"centre": None}, "centre", "required"),
        ({"shape": "square"}, "shape", '"disc", "ellipse", "polygon"'),
        ({"semi_axes": [1.0, 0.5]}, "semi_axes", "ellipse"),
        ({"points": [[0, 0], [1, 0]]}, "points", "planar disc"),
        ({"front_points": 0}, "front_points", "positive integer"),
        ({"coefficient": -0.1}, "coefficient", ">= 0"),
        ({"colour": "red"}, "colour", "unknown key"),
    ],
)
def test_bad_disc_names_the_key(change: dict, key: str, text: str) -> None:
    table = {**DISC, **change}
    table = {k: v for k, v in table.items() if v is not None}
    with pytest.raises(SceneError) as err:
        crack_from_table(table, 1, dim=3)
    assert err.value.key == key and text in str(err.value), str(err.value)


@pytest.mark.parametrize(
    ("change", "key", "text"),
    [
        ({"semi_axes": [1.0, 2.0]}, "semi_axes", "a >= b"),
        ({"semi_axes": [1.0]}, "semi_axes", "[a, b]"),
        ({"axis": [0.0, S, S]}, "axis", "in the crack plane"),
        ({"axis": None}, "axis", "required"),
        ({"radius": 1.0}, "radius", "disc"),
    ],
)
def test_bad_ellipse_names_the_key(change: dict, key: str, text: str) -> None:
    table = {k: v for k, v in {**ELLIPSE, **change}.items() if v is not None}
    with pytest.raises(SceneError) as err:
        crack_from_table(table, 1, dim=3)
    assert err.value.key == key and text in str(err.value), str(err.value)


# --------------------------------------------------------------------------- polygon
SQUARE = {
    "shape": "polygon",
    "vertices": [[1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0], [-1.0, -1.0, 0.0]],
    "region": "bone",
}


def _tilted(points: list[list[float]]) -> list[list[float]]:
    """``points`` rotated by 30° about x and shifted by (1, 2, 3)."""
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    R = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    return (np.asarray(points) @ R.T + [1.0, 2.0, 3.0]).tolist()


def test_polygon_frame_front_and_points() -> None:
    """A tilted square of side 2: centroid, normal from the vertex order, circum- and
    inradius, K points at the mid-sides with the straight-edge frame (e₁ the outward
    normal of the side, e₂ the plane normal, e₃ along the side), nearest points."""
    table = {**SQUARE, "vertices": _tilted(SQUARE["vertices"])}
    spec = crack_from_table(table, 1, dim=3)
    c = spec.crack
    assert c.shape == "polygon" and c.size_key == "vertices" and spec.front_points == 1
    n = np.array([0.0, -0.5, math.sqrt(0.75)])  # z turned by 30° about x
    np.testing.assert_allclose(c.normal, n, atol=1e-14)
    np.testing.assert_allclose(c.centre, [1.0, 2.0, 3.0], atol=1e-14)
    assert c.a == pytest.approx(math.sqrt(2.0)) and c.b == pytest.approx(1.0)
    front = c.front()
    assert front.perimeter == pytest.approx(8.0)
    assert front.radius_of_curvature(0.3) == math.inf
    phi = c.front_parameters(1)
    pts = front.point(phi)
    corners = np.asarray(c.vertices)
    mids = 0.5 * (corners + np.roll(corners, -1, axis=0))
    np.testing.assert_allclose(pts, mids, atol=1e-14)
    for p, f in zip(pts, phi, strict=True):
        e1, e2, e3 = front.frame(f)
        np.testing.assert_allclose(e1, p - c.centre, atol=1e-14)  # |p − c| = 1: the side normal
        np.testing.assert_allclose(e2, n, atol=1e-14)
        np.testing.assert_allclose(e3, np.cross(e1, e2), atol=1e-15)
        assert front.corner_distance(f) == pytest.approx(1.0)
    probe = pts + 0.2 * np.array([front.frame(f)[0] for f in phi]) + 0.1 * n
    np.testing.assert_allclose(front.nearest(probe), phi, atol=1e-12)
    np.testing.assert_allclose(front.arc_length(phi), [1.0, 3.0, 5.0, 7.0], atol=1e-12)
    samples = c.sample_points()
    assert np.max(np.abs(front.local(samples)[:, 2])) < 1e-14  # in the plane
    outward = np.array([front.frame(f)[0] for f in phi])
    assert np.max((samples - c.centre) @ outward.T) <= 1 + 1e-12  # on the square


def test_polygon_points_keep_away_from_the_corners() -> None:
    """Three points per side of length 2: from c = max(0.15 L, margin) to L − c."""
    c = crack_from_table({**SQUARE, "front_points": 3}, 1, dim=3).crack
    s = c.front().arc_length(c.front_parameters(3))
    np.testing.assert_allclose(s[:3], [0.3, 1.0, 1.7], atol=1e-12)
    s = c.front().arc_length(c.front_parameters(3, margin=0.5))
    np.testing.assert_allclose(s[3:6], [2.5, 3.0, 3.5], atol=1e-12)


def test_regular_polygon_normal_given() -> None:
    """A regular 24-gon: area, inradius and circumradius; the given normal accepted."""
    t = 2 * math.pi * np.arange(24) / 24
    v = np.column_stack([np.cos(t), np.sin(t), 0 * t]).tolist()
    c = planar_crack_from_table({"shape": "polygon", "vertices": v, "normal": [0.0, 0.0, 1.0]})
    assert c.a == pytest.approx(1.0) and c.b == pytest.approx(math.cos(math.pi / 24))
    assert c.front().perimeter == pytest.approx(48 * math.sin(math.pi / 24))


@pytest.mark.parametrize(
    ("change", "key", "text"),
    [
        ({"vertices": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]}, "vertices", "at least 3"),
        ({"vertices": [[0.0, 0.0, 0.0], [1.0, 0.0], [0.0, 1.0, 0.0]]}, "vertices", "three"),
        ({"vertices": None}, "vertices", "required"),
        ({"vertices": [[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]]}, "vertices", "zero area"),
        (  # one corner 2e-5 up: 5e-6 from the best-fit plane (tolerance 2.8e-6)
            {"vertices": [[1.0, -1, 0], [1.0, 1, 0], [-1.0, 1, 2e-5], [-1.0, -1, 0]]},
            "vertices",
            "one plane",
        ),
        (  # an arrow head: concave at (0, 0)
            {"vertices": [[0.0, 0, 0], [1.0, -1, 0], [0.0, 2, 0], [-1.0, -1, 0]]},
            "vertices",
            "convex",
        ),
        (  # a pentagram: every turn to the left, but it winds twice
            {
                "vertices": [
                    [math.cos(4 * math.pi * k / 5), math.sin(4 * math.pi * k / 5), 0.0]
                    for k in range(5)
                ]
            },
            "vertices",
            "intersects itself",
        ),
        (
            {"vertices": [[1.0, -1, 0], [1.0, 1, 0], [1.0, 1, 0], [-1.0, -1, 0]]},
            "vertices",
            "coincide",
        ),
        ({"normal": [0.0, 0.0, -1.0]}, "vertices", "counter-clockwise"),
        ({"normal": [0.0, 1.0, 0.0]}, "normal", "plane of the vertices"),
        ({"centre": [0.0, 0.0, 0.0]}, "centre", "polygon"),
        ({"radius": 1.0}, "radius", "polygon"),
        ({"front_points": 0}, "front_points", "positive integer"),
    ],
)
def test_bad_polygon_names_the_key(change: dict, key: str, text: str) -> None:
    table = {k: v for k, v in {**SQUARE, **change}.items() if v is not None}
    with pytest.raises(SceneError) as err:
        crack_from_table(table, 1, dim=3)
    assert err.value.key == key and text in str(err.value), str(err.value)


def test_vertices_of_a_disc_are_refused() -> None:
    with pytest.raises(SceneError) as err:
        crack_from_table({**DISC, "vertices": SQUARE["vertices"]}, 1, dim=3)
    assert err.value.key == "vertices" and "polygon" in str(err.value)
