"""Crack polylines (bonecontact.fracture.crack): tips, directions, growth and validation
against hand-computed geometry."""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

import numpy as np
import pytest

from bonecontact.fracture.crack import (
    Crack2D,
    FractureError,
    point_in_polygon,
    point_segment_distance,
    segments_intersect,
)

SQUARE = [(0, 0), (1, 0), (1, 1), (0, 1)]


def test_tips_direction_and_length():
    c = Crack2D(np.array([(0.2, 0.5), (0.5, 0.5), (0.8, 0.8)]))
    assert c.tip_ends == (0, -1) and c.mouth_ends == ()
    assert c.length == pytest.approx(0.3 + 0.3 * math.sqrt(2), rel=1e-14)
    np.testing.assert_allclose(c.direction(0), (-1, 0), atol=1e-15)
    np.testing.assert_allclose(c.direction(-1), (1 / math.sqrt(2),) * 2, rtol=1e-14)
    assert c.tip_segment_length(-1) == pytest.approx(0.3 * math.sqrt(2), rel=1e-14)


def test_extended_kinks_by_the_given_angle():
    c = Crack2D(np.array([(0.0, 0.5), (0.4, 0.5)]), "end")
    g = c.extended(-1, 0.1, math.radians(30))
    np.testing.assert_allclose(g.tip(-1), (0.4 + 0.1 * math.cos(math.pi / 6), 0.55), rtol=1e-14)
    assert g.length == pytest.approx(0.5, rel=1e-14)
    h = Crack2D(np.array([(0.3, 0.5), (0.6, 0.5)])).extended(0, 0.1, math.pi / 2)
    # at tip 0 the direction is -x; +90 degrees counter-clockwise turns it to -y
    np.testing.assert_allclose(h.tip(0), (0.3, 0.4), atol=1e-15)
    with pytest.raises(FractureError, match="not a tip"):
        c.extended(0, 0.1, 0.0)
    with pytest.raises(FractureError, match="increment"):
        c.extended(-1, -0.1, 0.0)


@pytest.mark.parametrize(
    "points, tips, match",
    [
        (np.zeros((1, 2)), "both", "n >= 2"),
        (np.array([(0, 0), (0, 0)]), "both", "distinct"),
        (np.array([(0, 0), (1, 0), (1, 1), (0.5, -1)]), "both", "intersect"),
        (np.array([(0, 0), (1, 0)]), "middle", "tips"),
        (np.array([(0, np.nan), (1, 0)]), "both", "finite"),
    ],
)
def test_invalid_polylines_are_refused(points, tips, match):
    with pytest.raises(FractureError, match=match):
        Crack2D(points, tips)


def test_check_inside():
    Crack2D(np.array([(0.2, 0.5), (0.8, 0.5)])).check_inside(SQUARE)
    Crack2D(np.array([(0.0, 0.5), (0.4, 0.5)]), "end").check_inside(SQUARE)
    with pytest.raises(FractureError, match="not on the outline"):
        Crack2D(np.array([(0.1, 0.5), (0.4, 0.5)]), "end").check_inside(SQUARE)
    with pytest.raises(FractureError, match="not inside"):
        Crack2D(np.array([(0.5, 0.5), (1.5, 0.5)])).check_inside(SQUARE)
    u_shape = [(0, 0), (3, 0), (3, 2), (2, 2), (2, 1), (1, 1), (1, 2), (0, 2)]
    with pytest.raises(FractureError, match="crosses"):  # both ends inside, spans the notch
        Crack2D(np.array([(0.5, 1.5), (2.5, 1.5)])).check_inside(u_shape)
    with pytest.raises(FractureError, match="hole"):
        Crack2D(np.array([(0.2, 0.5), (0.8, 0.5)])).check_inside(SQUARE, [(0.5, 0.52, 0.05)])


def test_planar_helpers():
    assert point_segment_distance((0.5, 1.0), (0, 0), (1, 0)) == 1.0
    assert point_segment_distance((2.0, 0.0), (0, 0), (1, 0)) == 1.0
    assert segments_intersect((0, 0), (1, 1), (0, 1), (1, 0))
    assert not segments_intersect((0, 0), (1, 0), (0, 1), (1, 1))
    assert point_in_polygon((0.5, 0.5), SQUARE) and not point_in_polygon((1.5, 0.5), SQUARE)
