"""A grown 3D front that is no longer a convex polygon is named (issue 26;
fracture.advance3d.front_defects; the runner stops ``not_convex``:
tests/unit/runners/test_crack_polygon3d.py).

Constructed fronts, seen along the crack's normal: the regular octagon (convex: nothing
named), in z = 0 and tilted by 1 rad about x, and out of its plane by a zigzag of ±0.2
of its radius (the projection is still the octagon); one vertex pulled in to half the
radius (the chord of its neighbours lies at cos 45° = 0.71 of it: it turns right there, and
only there); pulled in just short of that chord (0.72: convex) and just past it (0.70);
two vertices swapped (the boundary crosses itself: the two edges pairs that cross and the
vertices where it turns right); a vertex moved onto the edge before its neighbour (a turn
of 180°) or back past it along their edge (the front folds back); the octagon clockwise
about the normal (every vertex turns right).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bonecontact.fracture.advance3d import front_defects

N = 8
Z = np.array([0.0, 0.0, 1.0])


def octagon(radius: float = 1.0) -> np.ndarray:
    t = 2 * math.pi * np.arange(N) / N
    return np.column_stack([radius * np.cos(t), radius * np.sin(t), 0 * t])


def tilt() -> np.ndarray:
    c, s = math.cos(1.0), math.sin(1.0)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def test_convex_fronts_have_no_defect() -> None:
    V = octagon()
    assert front_defects(V, Z) is None
    R = tilt()
    assert front_defects(V @ R.T + 0.3, R @ Z) is None
    zigzag = V + np.outer(0.2 * (-1.0) ** np.arange(N), Z)  # out of the plane
    assert front_defects(zigzag, Z) is None


@pytest.mark.parametrize("pull", [0.5, 0.70])
def test_a_vertex_pulled_in_turns_right(pull: float) -> None:
    V = octagon()
    V[3] *= pull
    assert front_defects(V, Z) == "turns right at vertices 3"
    R = tilt()
    assert front_defects(V @ R.T, R @ Z) == "turns right at vertices 3"


def test_a_vertex_pulled_in_short_of_the_chord_is_convex() -> None:
    V = octagon()
    V[3] *= 0.72  # the neighbours' chord at 0.7071
    assert front_defects(V, Z) is None


def test_swapped_vertices_cross() -> None:
    V = octagon()
    V[[2, 5]] = V[[5, 2]]
    assert front_defects(V, Z) == (
        "turns right at vertices 2, 5; edges 1 and 5 cross; edges 2 and 4 cross"
    )


@pytest.mark.parametrize("back", [0.5, -0.5])
def test_a_front_folding_back(back: float) -> None:
    """Vertex 3 moved onto edge 1 (the front turns 180° at vertex 2) or back past vertex 2
    along edge 2's line."""
    V = octagon()
    V[3] = V[2] + back * (V[1] - V[2]) if back > 0 else V[2] + back * (V[3] - V[2])
    assert front_defects(V, Z) == "turns right at vertices 2, 3; edges 1 and 3 cross"


def test_a_clockwise_front_turns_right_everywhere() -> None:
    assert front_defects(octagon()[::-1], Z) == "turns right at vertices " + ", ".join(
        map(str, range(N))
    )
