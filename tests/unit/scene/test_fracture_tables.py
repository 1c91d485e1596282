"""Tests of the ``[fracture]`` and ``[[crack]]`` tables of bonecontact.scene.reader: the
parsed values (FractureSpec / CrackSpec of bonecontact.scene.spec, the material
strengths) and every bad value reported as a SceneError naming file, table and key (the
CLI's exit status 2).  Pure Python: also runs under mpiexec (each rank its own tmp_path).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from bonecontact.scene import SceneError, load_scene
from bonecontact.scene.spec import CrackSpec, FractureSpec

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
coefficient = 0.4
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
    assert (crack.name, crack.region, crack.coefficient) == ("c1", "plate", 0.4)
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
    ('\n[fracture]\ndirection = "north"\n', "[fracture]", "direction", '"mts", "principal"'),
    ("\n[fracture]\npropagate = 1\n", "[fracture]", "propagate", "true or false"),
    ("\n[fracture]\npropagate = true\n", "[fracture]", "increment", "is required"),
    ("\n[fracture]\nincrement = -1.0\n", "[fracture]", "increment", "positive number"),
    (
        "\n[fracture]\nmax_increments = 0\n",
        "[fracture]",
        "max_increments",
        "a positive integer (>= 1)",
    ),
    ("\n[fracture]\ntip_size = 0.0\n", "[fracture]", "tip_size", "positive number"),
    ("\n[fracture]\nlength = 1.0\n", "[fracture]", "length", "unknown key"),
    ('\n[[crack]]\nregion = "plate"\n', "[[crack]] #1", "points", "missing required key"),
    (
        "\n[[crack]]\npoints = [[0.0, 0.0], [1.0, 0.0]]\n",
        "[[crack]] #1",
        "region",
        "missing required key",
    ),
    (
        '\n[[crack]]\npoints = [[0.0, 0.0], [1.0, 0.0]]\nregion = "plate"\nfriction = -0.1\n',
        "[[crack]] #1",
        "friction",
        '>= 0, got -0.1 ("friction" is the old name of "coefficient")',
    ),
    (
        '\n[[crack]]\npoints = [[0.0, 0.0], [1.0, 0.0]]\nregion = "plate"\ncoefficient = -0.1\n',
        "[[crack]] #1",
        "coefficient",
        "must be >= 0, got -0.1",
    ),
    (
        '\n[[crack]]\npoints = [[0.0, 0.0], [1.0, 0.0]]\nregion = "plate"\n'
        "friction = 0.1\ncoefficient = 0.2\n",
        "[[crack]] #1",
        "friction",
        'is the old name of "coefficient"; give coefficient only',
    ),
    (
        "\n[fracture]\ninitiate = true\nfriction = 0.1\ncoefficient = 0.2\n",
        "[fracture]",
        "friction",
        'is the old name of "coefficient"; give coefficient only',
    ),
    ("\n[fracture]\ncoefficient = 0.2\n", "[fracture]", "coefficient", "set initiate = true"),
    ("\n[fracture]\nfriction = 0.2\n", "[fracture]", "friction", "set initiate = true"),
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


# --------------------------------------------------------------------------------------
# the old spelling of the Coulomb coefficient: friction = <number> (one name per meaning)
# --------------------------------------------------------------------------------------
CRACK3D = """
[[crack]]
name = "disc"
shape = "disc"
centre = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
radius = 1.0e-3
region = "plate"
{mu}
"""


@pytest.mark.parametrize("mu", [0.0, 0.25, 1])
@pytest.mark.parametrize(
    "dim, tail, table",
    [
        (2, FRACTURE.replace("coefficient = 0.4", "{mu}"), '[[crack]] #1 "c1"'),
        (3, CRACK3D, '[[crack]] #1 "disc"'),
        (2, "\n[fracture]\ninitiate = true\n{mu}\n", "[fracture]"),
    ],
    ids=["crack2d", "crack3d", "fracture"],
)
def test_old_friction_key_reads_as_coefficient(
    tmp_path: Path, dim: int, tail: str, table: str, mu: float
) -> None:
    """``friction = mu`` (old) gives the same scene as ``coefficient = mu`` (new), with one
    SceneDeprecationWarning naming the file, the table, the old and the new key; the new
    spelling warns of nothing."""
    from bonecontact.scene.keys import SceneDeprecationWarning

    def text(line: str) -> str:
        body = _scene(dim=dim, tail=tail.replace("{mu}", line))
        return body.replace("[0.0, 0.0]", "[0.0, 0.0, 0.0]") if dim == 3 else body

    new_dir, old_dir = tmp_path / "new", tmp_path / "old"
    new_dir.mkdir(), old_dir.mkdir()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        new = load_scene(_write(new_dir, text(f"coefficient = {mu}")))
    path = _write(old_dir, text(f"friction = {mu}"))
    with pytest.warns(SceneDeprecationWarning) as record:
        old = load_scene(path)
    messages = [str(w.message) for w in record]
    assert len(messages) == 1, messages
    assert messages[0].startswith(f'{path}: {table}, key "friction": ')
    assert 'is the old name of "coefficient"' in messages[0]
    assert f"write coefficient = {mu!r}" in messages[0]
    assert old.fracture == new.fracture and repr(old.cracks) == repr(new.cracks)
    got = [c.coefficient for c in new.cracks] or [new.fracture.coefficient]
    assert got == [float(mu)]
    assert all(isinstance(c.coefficient, float) for c in new.cracks)
