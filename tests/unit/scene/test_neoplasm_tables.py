"""Tests of the ``[neoplasm]`` tables of bonecontact.scene.reader: the parsed values
(the physics dataclasses TumourParameters / CystParameters, built by the reader) and
the range errors of those dataclasses reported as SceneError with file, table and key.
Pure Python: also runs under mpiexec (each rank writes under its own tmp_path).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from bonecontact.common.constants import R_GAS
from bonecontact.neoplasm.cyst import CystParameterError, CystParameters
from bonecontact.neoplasm.tumour import TumourParameterError, TumourParameters
from bonecontact.scene import CystSpec, NeoplasmSpec, RateExpression, SceneError, load_scene

TUMOUR = """format = 1
[scene]
name = "tumour"
dimension = 2

[neoplasm]
kind = "tumour"
radius = 1.5
h = 0.25
t_end = 3.0
dt = 0.2
remesh_every = 2

[neoplasm.tumour]
D_c = 2.0
lambda = 3
eps0 = 0.5
u_c1 = 0.8
K_B = "1.0*(u_c - 0.5)"
K_Q = 0.25
K_R = -0.125
gamma = 0.01
u_p0 = 0.75
u_q0 = 0.25
"""

CYST = """format = 1
[scene]
name = "cyst"
dimension = 3

[neoplasm]
kind = "cyst"
radius = 2.0e-3
t_end = 3.15576e7
dt = 2.6298e6

[neoplasm.cyst]
model = "shape"
strain = "engineering"
beta = 3.2e-11
C_minus = 1.5
temperature = 300.0
E = 2.0e6
viscosity = 5.0e8
f0 = 100.0
"""


def _load(tmp_path: Path, text: str) -> tuple[Path, object]:
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path, load_scene(path)


def _error(tmp_path: Path, text: str) -> SceneError:
    path = tmp_path / "scene.toml"
    path.write_text(text)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.file == str(path)
    return info.value


def test_tumour_values(tmp_path):
    _, scene = _load(tmp_path, TUMOUR)
    neo = scene.neoplasm
    assert isinstance(neo, NeoplasmSpec) and scene.growth_only
    assert (neo.kind, neo.region, neo.host, neo.radius, neo.h) == ("tumour", None, (), 1.5, 0.25)
    assert (neo.t_end, neo.dt, neo.remesh_every, neo.mechanics_every) == (3.0, 0.2, 2, 0)
    assert neo.n_steps == 15 and neo.cyst is None
    p = neo.tumour
    assert isinstance(p, TumourParameters)
    assert (p.D_c, p.lambda_, p.eps0, p.u_c1) == (2.0, 3.0, 0.5, 0.8)
    assert isinstance(p.lambda_, float)  # integers are read as floats
    assert p.K_B == RateExpression("1.0*(u_c - 0.5)") and p.K_B(0.8) == pytest.approx(
        0.3, rel=1e-15
    )
    assert (p.K_Q, p.K_A, p.K_P, p.K_D, p.K_R) == (0.25, 0.0, 0.0, 0.0, -0.125)
    assert (p.gamma, p.u_p0, p.u_q0) == (0.01, 0.75, 0.25)


def test_tumour_defaults(tmp_path):
    text = TUMOUR.split("[neoplasm.tumour]")[0]
    _, scene = _load(tmp_path, text)
    assert scene.neoplasm.tumour == TumourParameters()
    assert scene.neoplasm.tumour.K_B == 1.0


def test_cyst_values(tmp_path):
    _, scene = _load(tmp_path, CYST)
    neo = scene.neoplasm
    assert (neo.kind, neo.radius, neo.t_end, neo.dt, neo.tumour) == (
        "cyst",
        2.0e-3,
        3.15576e7,
        2.6298e6,
        None,
    )
    assert neo.cyst == CystSpec(
        model="shape",
        parameters=CystParameters(
            beta=3.2e-11,
            C_minus=1.5,
            temperature=300.0,
            E=2.0e6,
            viscosity=5.0e8,
            f0=100.0,
            strain="engineering",
        ),
    )
    assert neo.cyst.parameters.alpha == R_GAS * 300.0


def test_cyst_defaults(tmp_path):
    text = CYST.split("model =")[0] + "beta = 1e-11\nC_minus = 1.0\n"
    _, scene = _load(tmp_path, text)
    assert scene.neoplasm.cyst == CystSpec("sphere", CystParameters(beta=1e-11, C_minus=1.0))
    p = scene.neoplasm.cyst.parameters
    assert (p.temperature, p.E, p.viscosity, p.f0, p.strain) == (310.0, 1.0e6, 1.0e9, 0.0, "log")


@pytest.mark.parametrize(
    "old, new, key, message",
    [
        ("D_c = 2.0", "D_c = 0.0", "D_c", "must be > 0, got 0.0"),
        ("lambda = 3", "lambda = -1.0", "lambda", "must be > 0, got -1.0"),
        ("eps0 = 0.5", "eps0 = -0.5", "eps0", "must be >= 0, got -0.5"),
        ("u_c1 = 0.8", "u_c1 = -0.8", "u_c1", "must be >= 0, got -0.8"),
        ("gamma = 0.01", "gamma = -0.1", "gamma", "must be >= 0, got -0.1"),
        ("u_p0 = 0.75", "u_p0 = 1.5", "u_p0", "must satisfy 0 <= u_p0 <= 1, got 1.5"),
        (
            "u_q0 = 0.25",
            "u_q0 = 0.5",
            "u_q0",
            "must satisfy u_p0 + u_q0 <= 1 (volume fractions), got u_p0 = 0.75, u_q0 = 0.5",
        ),
    ],
)
def test_tumour_range_errors(tmp_path, old, new, key, message):
    exc = _error(tmp_path, TUMOUR.replace(old, new))
    assert (exc.table, exc.key, exc.message) == ("[neoplasm.tumour]", key, message)


@pytest.mark.parametrize(
    "old, new, key, message",
    [
        ("beta = 3.2e-11", "beta = -1e-11", "beta", "must be >= 0, got -1e-11"),
        ("C_minus = 1.5", "C_minus = 0.0", "C_minus", "must be > 0, got 0.0"),
        ("temperature = 300.0", "temperature = -1.0", "temperature", "must be > 0, got -1.0"),
        ("E = 2.0e6", "E = 0.0", "E", "must be > 0, got 0.0"),
        ("viscosity = 5.0e8", "viscosity = -5.0", "viscosity", "must be > 0, got -5.0"),
        (
            "f0 = 100.0",
            "f0 = -1.0e4",
            "f0",
            f"must be > -R_g T C_minus = {-R_GAS * 300.0 * 1.5:.6g} Pa (the osmolarity "
            "inside the cyst must stay positive), got -10000.0",
        ),
        (
            'strain = "engineering"',
            'strain = "green"',
            "strain",
            'must be one of "log", "engineering", got "green"',
        ),
    ],
)
def test_cyst_range_errors(tmp_path, old, new, key, message):
    exc = _error(tmp_path, CYST.replace(old, new))
    assert (exc.table, exc.key, exc.message) == ("[neoplasm.cyst]", key, message)


def test_parameter_errors_of_the_physics_dataclasses():
    """The same rules, raised by the dataclasses themselves (key and message)."""
    with pytest.raises(TumourParameterError) as info:
        TumourParameters(D_c=0.0).validate()
    assert (info.value.key, info.value.message) == ("D_c", "must be > 0, got 0.0")
    assert str(info.value) == "[neoplasm.tumour]: 'D_c' must be > 0, got 0.0"
    assert isinstance(info.value, ValueError)
    with pytest.raises(TumourParameterError, match="'K_B' must be a number or a callable of u_c"):
        TumourParameters(K_B="2*u_c").validate()  # type: ignore[arg-type]
    with pytest.raises(CystParameterError) as cinfo:
        CystParameters(beta=1e-11, C_minus=1.0, f0=-1.0e4)
    assert cinfo.value.key == "f0" and "osmolarity" in cinfo.value.message
    assert isinstance(cinfo.value, ValueError)
    assert CystParameters(beta=0.0, C_minus=1.0, E=float("inf")).tau == 0.0  # viscous limit allowed
