"""The re-characterisation of an interior flaw at an edge as a corner crack
(runners.breakthrough3d.surface_flaw, corner_flaw; docs/theory/fracture.md#corner-cracks-
in-a-scenes-body) on a box, against the rule done by hand.

The box [0, 2] × [0, 2] × [0, 1] mm (a 0.25 mm grid of triangles on every face, outward);
its edge x = 0, z = 1 where the face x = 0 (outward −x) meets the face z = 1 (outward +z).
A rectangular flaw in the plane y = 1 (normal y), x from x₀ to 0.5 mm and z from 0.6 to
0.95 mm: its ligament to z = 1 is 0.05 mm (the nearest face), to x = 0 x₀.

* x₀ = 0.1 mm, within twice 0.05 mm of the second face: a corner crack centred on the edge
  at (0, 1, 1), ``axis`` +x (along the face z = 1, from the edge), c = 0.5 (the flaw's
  farthest from x = 0), a = 0.4 (its farthest from z = 1: ligament 0.05 + height 0.35),
  ligament₂ 0.1, length 0.4; cut into the box its front is the quarter arc between the
  faces;
* the plane turned 20° about z (normal (sin 20°, cos 20°, 0), still crossing the edge):
  the distances in the plane to x = 0 are the normal ones over cos 20°: the flaw's
  vertices placed at in-plane distances 0.1 … 0.5 from it give c = 0.5, ligament₂ 0.1,
  the axis (cos 20°, −sin 20°, 0);
* x₀ = 0.3 mm (0.3 > 2 × 0.05): the semi-elliptical rule as before (centre (0.4, 1, 1),
  depth 0.4, half-length 0.1).

Pure numpy: runs under mpiexec too (the same on every rank).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from bonecontact.fracture.body3d import BodySurface
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.surface_body3d import cut_mouth
from bonecontact.runners.breakthrough3d import EDGE_LIGAMENT_RATIO, surface_flaw

sys.path.insert(0, str(Path(__file__).parents[1] / "fracture"))
from _box_surface import box_triangles

MM = 1e-3
SIZE = (2.0 * MM, 2.0 * MM, 1.0 * MM)


def _box(h: float = 0.25 * MM) -> BodySurface:
    """The box's boundary: a grid of spacing ``h`` on each face, outward."""
    T = box_triangles(SIZE, h)
    return BodySurface(T, np.ones(len(T), dtype=np.int32), {1: "wall"}, ("box", 1), h)


def _flaw(x0: float, turn_deg: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The rectangle's vertices (in-plane distance x0 … 0.5 mm from the face x = 0, z from
    0.6 to 0.95 mm) in the plane through (0, 1, 0) mm turned ``turn_deg`` about z, and
    its normal."""
    th = math.radians(turn_deg)
    n = np.array([math.sin(th), math.cos(th), 0.0])
    w = np.array([math.cos(th), -math.sin(th), 0.0])  # in the plane, off the face x = 0
    origin = np.array([0.0, 1.0, 0.0]) * MM
    corners = [(x0, 0.6), (0.5, 0.6), (0.5, 0.95), (x0, 0.95)]
    up = np.array([0.0, 0.0, 1.0])
    V = np.array([origin + MM * (s * w + z * up) for s, z in corners])
    return V, n


def test_flaw_at_the_edge_becomes_a_corner_crack() -> None:
    body = _box()
    V, n = _flaw(0.1)
    flaw = surface_flaw(body, V, n)
    c = flaw.crack
    assert c.shape == "quarter_elliptical"
    np.testing.assert_allclose(c.centre, np.array([0.0, 1.0, 1.0]) * MM, atol=1e-12 * MM)
    np.testing.assert_allclose(c.axis, (1.0, 0.0, 0.0), atol=1e-12)
    assert c.half_length == pytest.approx(0.5 * MM, rel=1e-9)
    assert c.depth == pytest.approx(0.4 * MM, rel=1e-9)
    assert flaw.ligament == pytest.approx(0.05 * MM, rel=1e-9)
    assert flaw.height == pytest.approx(0.35 * MM, rel=1e-9)
    assert flaw.length == pytest.approx(0.4 * MM, rel=1e-9)
    assert flaw.ligament2 == pytest.approx(0.1 * MM, rel=1e-9)
    assert flaw.summary()["shape"] == "quarter_elliptical"
    cut = cut_mouth(body, c, TipMesh(0.04 * MM, 0.12))
    p0, p1 = cut.arc.phi_range
    assert p1 - p0 == pytest.approx(0.5 * math.pi, abs=0.05)


def test_turned_plane_measures_in_the_plane() -> None:
    V, n = _flaw(0.1, turn_deg=20.0)
    flaw = surface_flaw(_box(), V, n)
    c = flaw.crack
    th = math.radians(20.0)
    assert c.shape == "quarter_elliptical"
    np.testing.assert_allclose(c.centre, np.array([0.0, 1.0, 1.0]) * MM, atol=1e-12 * MM)
    np.testing.assert_allclose(c.axis, (math.cos(th), -math.sin(th), 0.0), atol=1e-12)
    assert c.half_length == pytest.approx(0.5 * MM, rel=1e-9)
    assert c.depth == pytest.approx(0.4 * MM, rel=1e-9)
    assert flaw.ligament2 == pytest.approx(0.1 * MM, rel=1e-9)


def test_flaw_away_from_the_edge_stays_semi_elliptical() -> None:
    assert 0.3 > EDGE_LIGAMENT_RATIO * 0.05
    V, n = _flaw(0.3)
    flaw = surface_flaw(_box(), V, n)
    c = flaw.crack
    assert c.shape == "semi_elliptical" and flaw.ligament2 is None
    assert "shape" not in flaw.summary()  # the semi-elliptical entry as before
    np.testing.assert_allclose(c.centre, np.array([0.4, 1.0, 1.0]) * MM, atol=1e-12 * MM)
    assert c.depth == pytest.approx(0.4 * MM, rel=1e-9)
    assert c.half_length == pytest.approx(0.1 * MM, rel=1e-9)
