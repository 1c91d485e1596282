"""Several ``[[crack]]`` tables (bonecontact.scene.fracture_tables.read_fracture): cracks
that cross or touch are refused naming both tables and the key, in 2D (polylines) and
3D (planar discs, ellipses, polygons); cracks apart are read; a 2D scene's cracks lie in
one region.  The 3D test of meeting surfaces is checked against configurations whose
answer is known by construction (parallel, coplanar, crossing, tilted).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

import pytest

from bonecontact.scene.errors import SceneError
from bonecontact.scene.fracture_tables import planar_cracks_meet, read_fracture
from bonecontact.scene.spec import MaterialSpec  # noqa: F401  (the materials are not read)


def _doc(cracks: list[dict]) -> dict:
    return {"crack": [{"region": "plate", **c} for c in cracks]}


def _read(cracks: list[dict], dim: int = 2):
    return read_fracture(_doc(cracks), dim, [], False)


def test_cracks_apart_are_read_in_order() -> None:
    _, cracks = _read(
        [
            {"name": "a", "points": [[0.0, 0.0], [1.0, 0.0]]},
            {"name": "b", "points": [[0.0, 0.5], [1.0, 0.6], [2.0, 0.4]]},
            {"name": "c", "points": [[1.2, 0.0], [2.0, 0.0]], "tips": "both"},
        ]
    )
    assert [c.name for c in cracks] == ["a", "b", "c"]


@pytest.mark.parametrize(
    "second, what",
    [
        ([[0.5, -0.5], [0.5, 0.5]], "crossing"),
        ([[1.0, 0.0], [2.0, 0.0]], "touching at a tip"),
        ([[0.5, 0.0], [1.5, 0.0]], "overlapping"),
        ([[1.5, 0.3], [0.5, 0.0]], "a tip on the other's segment"),
    ],
)
def test_cracks_that_meet_are_refused_naming_both(second: list, what: str) -> None:
    cracks = [{"name": "a", "points": [[0.0, 0.0], [1.0, 0.0]]}, {"name": "b", "points": second}]
    with pytest.raises(SceneError) as err:
        _read(cracks)
    text = str(err.value)
    assert '[[crack]] #2 "b"' in text and "points" in text, what
    assert '[[crack]] #1 "a"' in text and "not supported" in text, what


def test_2d_cracks_lie_in_one_region() -> None:
    cracks = [
        {"name": "a", "points": [[0.0, 0.0], [1.0, 0.0]]},
        {"name": "b", "points": [[0.0, 1.0], [1.0, 1.0]], "region": "other"},
    ]
    with pytest.raises(SceneError, match=r'#2 "b".*region.*one body.*#1 "a"'):
        _read(cracks)


def _disc(centre, normal, radius=1.0, name="d") -> dict:
    return {"name": name, "shape": "disc", "centre": centre, "normal": normal, "radius": radius}


@pytest.mark.parametrize(
    "second, meet",
    [
        (_disc([3.0, 0.0, 0.0], [0.0, 0.0, 1.0]), False),  # coplanar, apart
        (_disc([1.9, 0.0, 0.0], [0.0, 0.0, 1.0]), True),  # coplanar, overlapping
        (_disc([0.0, 0.0, 0.5], [0.0, 0.0, 1.0]), False),  # parallel, stacked
        (_disc([0.5, 0.0, 0.0], [1.0, 0.0, 0.0]), True),  # crossing at right angles
        (_disc([0.0, 0.0, 1.2], [1.0, 0.0, 0.0]), False),  # normal plane, above the first
        (_disc([0.0, 0.0, 0.9], [1.0, 0.0, 0.0]), True),  # the same, reaching through it
        (_disc([2.5, 0.0, 0.0], [math.sqrt(0.5), 0.0, math.sqrt(0.5)]), False),  # tilted, beside it
        (
            {
                "name": "d",
                "shape": "polygon",
                "vertices": [[0.5, -0.2, -1.0], [0.5, 0.2, -1.0], [0.5, 0.0, 1.0]],
            },
            True,  # a triangle through the disc
        ),
    ],
)
def test_planar_cracks_that_meet(second: dict, meet: bool) -> None:
    first = _disc([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], name="c")
    if meet:
        with pytest.raises(SceneError, match=r'#2 "d".*crosses or touches \[\[crack\]\] #1 "c"'):
            _read([first, second], dim=3)
    else:
        _, cracks = _read([first, second], dim=3)
        assert len(cracks) == 2
        # the geometric test itself, either way round
        a, b = (c.crack for c in cracks)
        assert not planar_cracks_meet(a, b) and not planar_cracks_meet(b, a)


def test_points_in_polygon_is_the_one_point_rule() -> None:
    """The vectorised even–odd rule (used by the 3D check) against the one-point rule."""
    import numpy as np

    from bonecontact.fracture.crack import point_in_polygon, points_in_polygon

    rng = np.random.default_rng(0)
    poly = np.array([[0.0, 0.0], [1.0, 0.0], [1.2, 0.8], [0.3, 1.1], [-0.2, 0.5], [0.4, 0.4]])
    p = rng.uniform(-0.5, 1.5, (3000, 2))
    many = points_in_polygon(p, poly)
    assert many.tolist() == [point_in_polygon(q, poly) for q in p]
    assert 0 < many.sum() < len(p)


def test_fatigue_waiting_keys_name_the_crack() -> None:
    """A checkpoint's waiting growth is keyed by (crack, tip) and reads back the same;
    an older key (the tip alone) reads as an unnamed crack's tip."""
    from bonecontact.runners.crack_fatigue import FatigueProgress

    prog = FatigueProgress(waiting={("left", -1): 1e-4, ("b@x", 0): 2e-4})
    back = FatigueProgress.from_state(prog.state())
    assert back.waiting == prog.waiting
    old = prog.state() | {"waiting": {"-1": 3e-4}}
    assert FatigueProgress.from_state(old).waiting == {("", -1): 3e-4}
