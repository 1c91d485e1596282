"""``[fracture] max_kink_deg`` and ``stop_out_of_plane`` (the validity of a crack grown in
its plane, issue #26) as the reader takes them.

* left out: 15.0 and false (the declared defaults);
* ``max_kink_deg`` is an angle in degrees, 0 < value ≤ 90: 0, a negative value, 90.5,
  a string or a boolean is refused naming the file, ``[fracture]``, the key and the range;
  90 and 0.5 are read as given;
* they apply where a crack grows in its plane — a growing semi-elliptical surface crack
  of a 3D scene, or the surface phase of ``breakthrough = "surface_crack"`` — and are
  refused (naming the key) in a 2D scene, in a 3D scene whose interior crack grows (it
  turns by its kink) and for a surface crack that does not grow.

Pure Python (no mesh is read): also runs under mpiexec (each rank its own tmp_path).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from bonecontact.scene import SceneError, load_scene

HEAD = """format = 1
[scene]
name = "plate"
mesh = "plate.msh"
dimension = {dim}
[analysis]
kind = "static"
[[material]]
name = "bone"
regions = ["plate"]
model = "isotropic"
E = 17e9
nu = 0.3
sigma_t = 133e6
K_Ic = 2e6
"""
SURFACE = """[[crack]]
name = "mouth"
shape = "semi_elliptical"
centre = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
depth = 2e-4
half_length = 2e-4
region = "plate"
"""
DISC = """[[crack]]
name = "penny"
centre = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
radius = 1e-3
region = "plate"
"""
LINE = """[[crack]]
name = "edge"
points = [[0.0, 0.0], [1e-3, 0.0]]
region = "plate"
"""
GROWS = "propagate = true\nincrement = 1e-5\n"


def _load(tmp_path: Path, fracture: str, crack: str = SURFACE, dim: int = 3):
    (tmp_path / "plate.msh").write_text("")
    path = tmp_path / "scene.toml"
    path.write_text(HEAD.format(dim=dim) + "[fracture]\n" + fracture + crack)
    return path, load_scene(path)


def test_defaults(tmp_path: Path) -> None:
    _, scene = _load(tmp_path, GROWS)
    assert scene.fracture.max_kink_deg == 15.0 and type(scene.fracture.max_kink_deg) is float
    assert scene.fracture.stop_out_of_plane is False


@pytest.mark.parametrize("value", [90, 0.5, 45.0])
def test_angles_in_range_are_read(tmp_path: Path, value: float) -> None:
    _, scene = _load(tmp_path, GROWS + f"max_kink_deg = {value}\nstop_out_of_plane = true\n")
    assert scene.fracture.max_kink_deg == float(value)
    assert scene.fracture.stop_out_of_plane is True


@pytest.mark.parametrize("value", ["0", "-5.0", "90.5", "1e3", '"15"', "true"])
def test_bad_angle_is_refused(tmp_path: Path, value: str) -> None:
    with pytest.raises(SceneError) as info:
        _load(tmp_path, GROWS + f"max_kink_deg = {value}\n")
    exc = info.value
    where = (str(tmp_path / "scene.toml"), "[fracture]", "max_kink_deg")
    assert (exc.file, exc.table, exc.key) == where
    if value not in ('"15"', "true"):  # not a number: the type's message
        assert "0 < max_kink_deg <= 90 (degrees)" in exc.message, str(exc)
    assert str(tmp_path / "scene.toml") in str(exc)


def test_bad_stop_value_is_refused(tmp_path: Path) -> None:
    with pytest.raises(SceneError) as info:
        _load(tmp_path, GROWS + 'stop_out_of_plane = "yes"\n')
    assert (info.value.table, info.value.key) == ("[fracture]", "stop_out_of_plane")


@pytest.mark.parametrize("key", ["max_kink_deg = 20.0", "stop_out_of_plane = true"])
@pytest.mark.parametrize(
    "fracture, crack, dim",
    [
        (GROWS, LINE, 2),  # a 2D crack turns by its direction
        (GROWS, DISC, 3),  # an interior 3D crack turns by its kink
        ("", SURFACE, 3),  # a surface crack that does not grow
    ],
    ids=["2d", "interior", "stationary"],
)
def test_refused_where_no_crack_grows_in_its_plane(
    tmp_path: Path, key: str, fracture: str, crack: str, dim: int
) -> None:
    with pytest.raises(SceneError) as info:
        _load(tmp_path, fracture + key + "\n", crack, dim)
    exc = info.value
    assert (exc.table, exc.key) == ("[fracture]", key.split(" ")[0]), str(exc)
    assert "applies to a crack grown in its plane" in exc.message


def test_read_with_a_breakthrough_to_a_surface_crack(tmp_path: Path) -> None:
    fracture = GROWS + 'breakthrough = "surface_crack"\nstop_out_of_plane = true\n'
    _, scene = _load(tmp_path, fracture, DISC)
    assert scene.fracture.stop_out_of_plane is True
