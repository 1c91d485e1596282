"""Tests of the ``[fracture]`` and ``[[crack]]`` tables of bonecontact.scene.reader: the
parsed values (FractureSpec / CrackSpec of bonecontact.fracture.scene_tables, the material
strengths) and every bad value reported as a SceneError naming file, table and key (the
CLI's exit status 2).  Pure Python: also runs under mpiexec (each rank its own tmp_path).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bonecontact.fracture import CrackSpec, FractureSpec
from bonecontact.scene import SceneError, load_scene

HEAD = """format = 1
[scene]
name = "plate"
mesh = "plate.msh"
dimension = {dim}

[analysis]
kind = "static"
load_steps = 1

[[material]]
name = "cortical"
regions = ["plate"]
model = "isotropic"
E = 17.0e9
nu = 0.3
{strengths}

[[dirichlet]]
boundary = "bottom"
value = [0.0, 0.0]
"""

STRENGTHS = "sigma_t = 133.0e6\nsigma_c = 193.0e6\nK_Ic = 4.0e6"

FRACTURE = """
[fracture]
criterion = "tension_compression"
direction = "principal"
propagate = true
increment = 2.0e-4
max_increments = 7
tip_size = 2.5e-5
tip_grading = 0.3

[[crack]]
name = "c1"
points = [[0.0, 0.0], [1.0e-3, 5.0e-4]]
tips = "end"
region = "plate"
friction = 0.4
"""


def _write(tmp_path: Path, text: str) -> Path:
    (tmp_path / "plate.msh").write_text("")  # the reader only checks that the mesh exists
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def _scene(dim: int = 2, strengths: str = STRENGTHS, tail: str = FRACTURE) -> str:
    return HEAD.format(dim=dim, strengths=strengths) + tail


def _error(tmp_path: Path, text: str) -> SceneError:
    path = _write(tmp_path, text)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.file == str(path)
    return info.value


def test_valid_tables_are_read(tmp_path: Path) -> None:
    scene = load_scene(_write(tmp_path, _scene()))
    assert scene.fracture == FractureSpec(
        "tension_compression", "principal", True, 2.0e-4, 7, 2.5e-5, 0.3
    )
    (crack,) = scene.cracks
    assert isinstance(crack, CrackSpec)
    assert (crack.name, crack.region, crack.friction) == ("c1", "plate", 0.4)
    np.testing.assert_array_equal(crack.crack.points, [[0.0, 0.0], [1.0e-3, 5.0e-4]])
    assert crack.crack.length == pytest.approx(np.hypot(1.0e-3, 5.0e-4), rel=1e-14)
    assert scene.materials[0].strengths == {"sigma_t": 133.0e6, "sigma_c": 193.0e6, "K_Ic": 4.0e6}


def test_defaults_and_no_fracture(tmp_path: Path) -> None:
    scene = load_scene(_write(tmp_path, _scene(strengths="sigma_t = 1.0e8", tail="\n[fracture]\n")))
    assert scene.fracture == FractureSpec()  # tension, mts, no propagation
    assert scene.cracks == ()
    plain = load_scene(_write(tmp_path, _scene(strengths="", tail="")))
    assert plain.fracture is None and plain.cracks == ()


BAD = [
    # (fracture tail, table, key, message part)
    ('\n[fracture]\ncriterion = "brittle"\n', "[fracture]", "criterion", "must be one of"),
    ('\n[fracture]\ndirection = "north"\n', "[fracture]", "direction", "'mts' or 'principal'"),
    ("\n[fracture]\npropagate = 1\n", "[fracture]", "propagate", "true or false"),
    ("\n[fracture]\npropagate = true\n", "[fracture]", "increment", "is required"),
    ("\n[fracture]\nincrement = -1.0\n", "[fracture]", "increment", "positive number"),
    ("\n[fracture]\nmax_increments = 0\n", "[fracture]", "max_increments", "positive integer"),
    ("\n[fracture]\ntip_size = 0.0\n", "[fracture]", "tip_size", "positive number"),
    ("\n[fracture]\nlength = 1.0\n", "[fracture]", "length", "unknown key"),
    ('\n[[crack]]\nregion = "plate"\n', "[[crack]] #1", "points", "is required"),
    ("\n[[crack]]\npoints = [[0.0, 0.0], [1.0, 0.0]]\n", "[[crack]] #1", "region", "is required"),
    (
        '\n[[crack]]\npoints = [[0.0, 0.0], [1.0, 0.0]]\nregion = "plate"\nfriction = -0.1\n',
        "[[crack]] #1",
        "friction",
        ">= 0",
    ),
    (
        '\n[[crack]]\npoints = [[0.0, 0.0], [1.0, 0.0]]\nregion = "plate"\ndepth = 1\n',
        "[[crack]] #1",
        "depth",
        "unknown key",
    ),
    (
        '\n[[crack]]\nname = "a"\npoints = [[0.0, 0.0], [1.0, 0.0]]\nregion = "plate"\n'
        '\n[[crack]]\nname = "a"\npoints = [[0.0, 1.0], [1.0, 1.0]]\nregion = "plate"\n',
        '[[crack]] #2 "a"',
        "name",
        "not unique",
    ),
]


@pytest.mark.parametrize(
    "tail, table, key, part", BAD, ids=[f"{b[2]}-{i}" for i, b in enumerate(BAD)]
)
def test_bad_value_names_table_and_key(
    tmp_path: Path, tail: str, table: str, key: str, part: str
) -> None:
    exc = _error(tmp_path, _scene(tail=tail))
    assert exc.table is not None and exc.table.startswith(table), str(exc)
    assert exc.key == key, str(exc)
    assert part in exc.message, str(exc)
    assert f'key "{key}"' in str(exc)


@pytest.mark.parametrize(
    "strengths, tail, key",
    [
        ("", "\n[fracture]\n", "sigma_t"),
        ("sigma_t = 1.0e8", '\n[fracture]\ncriterion = "tension_compression"\n', "sigma_c"),
        ("sigma_t = 1.0e8", "\n[fracture]\npropagate = true\nincrement = 1e-4\n", "K_Ic"),
    ],
)
def test_missing_strength_names_material_and_key(
    tmp_path: Path, strengths: str, tail: str, key: str
) -> None:
    exc = _error(tmp_path, _scene(strengths=strengths, tail=tail))
    assert exc.table == '[[material]] #1 "cortical"' and exc.key == key, str(exc)
    assert "[fracture]" in exc.message


def test_bad_strength_and_what_3d_refuses(tmp_path: Path) -> None:
    exc = _error(tmp_path, _scene(strengths="sigma_t = -5.0", tail="\n[fracture]\n"))
    assert (exc.table, exc.key) == ('[[material]] #1 "cortical"', "sigma_t")
    assert "> 0" in exc.message
    text3d = _scene(dim=3, tail="\n[fracture]\n").replace("[0.0, 0.0]", "[0.0, 0.0, 0.0]")
    assert load_scene(_write(tmp_path, text3d)).fracture == FractureSpec()  # the risk check
    exc = _error(tmp_path, text3d + "propagate = true\nincrement = 1e-3\n")
    assert (exc.table, exc.key) == ("[fracture]", "propagate") and "2D" in exc.message
    crack2d = FRACTURE[FRACTURE.index("[[crack]]") :]
    exc = _error(tmp_path, text3d.replace("[fracture]", crack2d + "\n[fracture]"))  # a polyline
    assert exc.table.startswith("[[crack]]") and exc.key == "points", str(exc)
    assert "planar disc or ellipse" in exc.message
