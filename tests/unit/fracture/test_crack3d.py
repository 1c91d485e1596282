"""The 3D ``[[crack]]`` geometry (bonecontact.fracture.crack3d): parsing, its frame and
front against closed forms, and every bad value refused naming its key."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bonecontact.fracture.crack import FractureError
from bonecontact.fracture.crack3d import PlanarCrack, planar_crack_from_table
from bonecontact.fracture.scene_tables import crack_from_table

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
        ({"shape": "square"}, "shape", "disc, ellipse"),
        ({"semi_axes": [1.0, 0.5]}, "semi_axes", "ellipse"),
        ({"points": [[0, 0], [1, 0]]}, "points", "planar disc"),
        ({"front_points": 0}, "front_points", "positive integer"),
        ({"friction": -0.1}, "friction", ">= 0"),
        ({"colour": "red"}, "colour", "unknown key"),
    ],
)
def test_bad_disc_names_the_key(change: dict, key: str, text: str) -> None:
    table = {**DISC, **change}
    table = {k: v for k, v in table.items() if v is not None}
    with pytest.raises(FractureError) as err:
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
    with pytest.raises(FractureError) as err:
        crack_from_table(table, 1, dim=3)
    assert err.value.key == key and text in str(err.value), str(err.value)
