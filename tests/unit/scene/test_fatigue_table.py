"""``[fracture.fatigue]`` (docs/scene_format.md, *[fracture.fatigue]*): the values read into
FatigueSpec and its Paris law (bonecontact.runners.crack_fatigue.paris_law), and every bad
value a SceneError naming the file, ``[fracture.fatigue]`` (or ``[fracture]``) and the
key, with the allowed values; the CLI's exit status 2.  Also runs under mpiexec (each
rank its own tmp_path).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from bonecontact.runners.crack_fatigue import paris_law
from bonecontact.scene import SceneError, load_scene
from bonecontact.scene.spec import FatigueSpec

HEAD = """format = 1
[scene]
name = "plate"
mesh = "plate.msh"
dimension = {dim}

[analysis]
kind = "static"

[[material]]
name = "cortical"
regions = ["plate"]
model = "isotropic"
E = 17.0e9
nu = 0.3
sigma_t = 133.0e6

[[dirichlet]]
boundary = "bottom"
value = {zero}
"""

CRACK = """
[[crack]]
points = [[0.0, 0.0], [1.0e-3, 0.0]]
tips = "end"
region = "plate"
"""

DISC3D = """
[[crack]]
shape = "disc"
centre = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
radius = 1.0e-3
region = "plate"
"""

FATIGUE = {"C": "1.0e-30", "m": "4.0", "da_max": "2.0e-4"}


def _scene(
    tmp_path: Path,
    fatigue: dict[str, str] | None = None,
    fracture: str = "",
    crack: str = CRACK,
    dim: int = 2,
) -> Path:
    zero = "[0.0, 0.0]" if dim == 2 else "[0.0, 0.0, 0.0]"
    text = HEAD.format(dim=dim, zero=zero) + crack + "\n[fracture]\n" + fracture + "\n"
    entries = dict(FATIGUE) if fatigue is None else fatigue
    text += "[fracture.fatigue]\n" + "".join(f"{k} = {v}\n" for k, v in entries.items())
    (tmp_path / "plate.msh").write_text("")
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def _error(path: Path) -> SceneError:
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.file == str(path)
    return info.value


@pytest.mark.parametrize(
    "given",
    [
        {},
        {"delta_K_th": "2.0e5", "R": "0.1", "max_blocks": "7"},
        {"R": "-0.5"},
        {"m": "9.5", "C": "3"},  # an integer C is a number
    ],
)
def test_values_are_read_with_their_defaults(tmp_path: Path, given: dict[str, str]) -> None:
    spec = load_scene(_scene(tmp_path, FATIGUE | given)).fracture
    f = spec.fatigue
    expected = {"delta_K_th": 0.0, "R": 0.0, "max_blocks": 100} | FATIGUE | given
    assert f == FatigueSpec(
        float(expected["C"]),
        float(expected["m"]),
        float(expected["da_max"]),
        float(expected["delta_K_th"]),
        float(expected["R"]),
        int(expected["max_blocks"]),
    )
    assert spec.grows and not spec.propagate and spec.growth_step == float(expected["da_max"])
    law = paris_law(f)
    assert (law.C, law.m, law.delta_K_th, law.R) == (f.C, f.m, f.delta_K_th, f.R)
    # the law of the table: da/dN = C ((1 - R) K)^m for R >= 0, C K^m for R < 0
    k = 1.0e6
    dk = (1.0 - f.R) * k if f.R >= 0 else k
    assert float(law.rate(k)) == pytest.approx(f.C * dk**f.m if dk > f.delta_K_th else 0.0)


BAD = [
    ({"m": "4.0", "da_max": "1e-4"}, "C", "missing required key"),
    ({"C": "1e-30", "da_max": "1e-4"}, "m", "missing required key"),
    ({"C": "1e-30", "m": "4.0"}, "da_max", "missing required key"),
    (FATIGUE | {"C": "0.0"}, "C", "must be a positive number (> 0)"),
    (FATIGUE | {"C": '"small"'}, "C", "must be a number"),
    (FATIGUE | {"m": "-1.0"}, "m", "must be a positive number (> 0)"),
    (FATIGUE | {"delta_K_th": "-1.0"}, "delta_K_th", "must be >= 0"),
    (FATIGUE | {"R": "1.0"}, "R", "must be < 1"),
    (FATIGUE | {"R": "2.5"}, "R", "must be < 1"),
    (FATIGUE | {"da_max": "0.0"}, "da_max", "must be a positive number (> 0)"),
    (FATIGUE | {"max_blocks": "0"}, "max_blocks", "must be a positive integer (>= 1)"),
    (FATIGUE | {"max_blocks": "2.5"}, "max_blocks", "must be an integer"),
    (FATIGUE | {"colour": '"red"'}, "colour", "allowed: C, m, delta_K_th, R, da_max, max_blocks"),
]


@pytest.mark.parametrize("entries, key, text", BAD, ids=[f"{b[1]}-{i}" for i, b in enumerate(BAD)])
def test_bad_value_names_table_and_key(tmp_path: Path, entries, key: str, text: str) -> None:
    exc = _error(_scene(tmp_path, entries))
    assert (exc.table, exc.key) == ("[fracture.fatigue]", key), str(exc)
    assert text in exc.message, str(exc)


@pytest.mark.parametrize(
    "fracture, crack, dim, key, text",
    [
        ("propagate = true\nincrement = 1e-4\n", CRACK, 2, "propagate", "give one of them"),
        ("", "", 2, "fatigue", "add a [[crack]] or set initiate = true"),
        ("", "", 3, "fatigue", "add a [[crack]] or set initiate = true"),
        ('fatigue = "paris"\n', CRACK, 2, "fatigue", "must be a table [fracture.fatigue]"),
    ],
)
def test_fatigue_in_a_wrong_scene_names_fracture(
    tmp_path: Path, fracture: str, crack: str, dim: int, key: str, text: str
) -> None:
    path = _scene(tmp_path, fracture=fracture, crack=crack, dim=dim)
    if "fatigue =" in fracture:  # the key given as a value, not as the sub-table
        path.write_text(path.read_text().split("[fracture.fatigue]")[0])
    exc = _error(path)
    assert (exc.table, exc.key) == ("[fracture]", key), str(exc)
    assert text in exc.message, str(exc)


def test_fatigue_of_an_interior_3d_crack_is_read(tmp_path: Path) -> None:
    """A 3D disc with ``[fracture.fatigue]`` reads (it grows by blocks of cycles:
    runners.front_growth3d); without a crack fatigue stays refused (above)."""
    scene = load_scene(_scene(tmp_path, crack=DISC3D, dim=3))
    assert scene.fracture.fatigue == FatigueSpec(1.0e-30, 4.0, 2.0e-4)
    assert len(scene.cracks) == 1 and not scene.fracture.propagate


@pytest.mark.serial  # spawns its own process: not under mpiexec
def test_cli_exit_status_is_2(tmp_path: Path) -> None:
    path = _scene(tmp_path, FATIGUE | {"R": "1.5"})
    cmd = [sys.executable, "-m", "bonecontact.runners.cli", "check", str(path)]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert out.returncode == 2, out.stderr
    assert "[fracture.fatigue]" in out.stderr and '"R"' in out.stderr + out.stdout, out.stderr
