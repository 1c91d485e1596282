"""Tests of bonecontact.common.geometry and bonecontact.common.constants."""

from __future__ import annotations

import numpy as np

from bonecontact.common.constants import R_GAS, SECONDS_PER_DAY, SECONDS_PER_YEAR
from bonecontact.common.geometry import cross2, polygon_area, signed_polygon_area

SQUARE = [[0.0, 0.0], [2.0, 0.0], [2.0, 3.0], [0.0, 3.0]]  # counter-clockwise, area 6


def test_cross2():
    assert cross2([1.0, 0.0], [0.0, 1.0]) == 1.0
    assert cross2([0.0, 1.0], [1.0, 0.0]) == -1.0
    a = np.array([[1.0, 2.0], [3.0, 4.0], [2.0, 4.0]])
    b = np.array([[5.0, 6.0], [7.0, 8.0], [1.0, 2.0]])
    np.testing.assert_array_equal(cross2(a, b), [1 * 6 - 2 * 5, 3 * 8 - 4 * 7, 0.0])
    np.testing.assert_array_equal(cross2(a, [0.0, 1.0]), [1.0, 3.0, 2.0])  # broadcasting


def test_polygon_areas():
    assert signed_polygon_area(SQUARE) == 6.0
    assert signed_polygon_area(SQUARE[::-1]) == -6.0
    assert polygon_area(SQUARE) == polygon_area(SQUARE[::-1]) == 6.0
    th = 2 * np.pi * np.arange(400) / 400
    circle = np.column_stack([np.cos(th), np.sin(th)])
    assert abs(signed_polygon_area(circle) - 0.5 * 400 * np.sin(2 * np.pi / 400)) < 1e-13


def test_constants():
    assert R_GAS == 8.314462618
    assert SECONDS_PER_DAY == 86400.0
    assert SECONDS_PER_YEAR == 365.25 * 86400.0 == 31557600.0
