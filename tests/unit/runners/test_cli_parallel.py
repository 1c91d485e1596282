"""Same results on 1, 2 and 3 ranks: ``history.csv`` and ``probes.csv`` agree to rtol 1e-8.

Runs ``bonecontact run`` serially and under ``mpiexec -n 2`` / ``-n 3`` on a 2D dynamic
scene (two materials with a 30x stiffness contrast, transversely isotropic cortex,
Kelvin–Voigt damping, traction ramp, initial velocity, probes in both materials) and a
3D quasi-static scene (prescribed displacement schedule plus a body force), and compares
the files number by number.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from cli_support import run_scene

pytestmark = pytest.mark.serial

ROOT = Path(__file__).resolve().parents[3]

SCENE_2D = """format = 1
[scene]
name = "bone2d"
mesh = "{mesh}"
dimension = 2

[analysis]
kind = "dynamic"
t_end = 0.0012
dt = 0.0001

[[material]]
name = "cortical"
regions = ["cortical"]
model = "transversely_isotropic"
E_p = 11.5e9
E_a = 17.0e9
nu_p = 0.51
nu_pa = 0.31
G_pa = 3.3e9
axis = [0.0, 1.0]
rho = 1900.0
tau_v = 2.0e-5

[[material]]
name = "cancellous"
regions = ["cancellous"]
model = "isotropic"
E = 0.5e9
nu = 0.3
rho = 1000.0
tau_v = 2.0e-5

[[dirichlet]]
boundary = "distal"
value = [0.0, 0.0]

[[traction]]
boundary = "proximal"
value = [2.0e5, -2.0e6]
ramp = 0.0006

[[initial_velocity]]
regions = ["cancellous"]
value = [0.01, 0.0]

[output]
directory = "{out}"
fields_every = 0
probes = [[0.0, 0.1], [0.011, 0.15], [0.0, 0.19]]
"""

SCENE_3D = """format = 1
[scene]
name = "box3d"
mesh = "{mesh}"
dimension = 3

[analysis]
kind = "quasistatic"
t_end = 1.0
dt = 0.25

[solver]
linear = "{linear}"

[[material]]
name = "bone"
regions = ["body"]
model = "orthotropic"
E1 = 12.0e9
E2 = 13.4e9
E3 = 20.0e9
nu12 = 0.38
nu13 = 0.22
nu23 = 0.24
G12 = 4.5e9
G13 = 5.6e9
G23 = 6.2e9
axes = [[0.8, 0.6, 0.0], [-0.6, 0.8, 0.0], [0.0, 0.0, 1.0]]
tau_v = 0.01

[[dirichlet]]
boundary = "left"
value = [0.0, 0.0, 0.0]

[[dirichlet]]
boundary = "right"
value = [1.0e-5, "free", "free"]
schedule = [[0.0, 0.0], [0.5, 1.0], [1.0, 0.5]]

[[body_force]]
regions = ["body"]
value = [0.0, -1.0e5, 2.0e4]

[output]
directory = "{out}"
fields_every = 2
probes = [[0.01, 0.005, 0.005], [0.02, 0.01, 0.01]]
"""


def _read(path: Path) -> tuple[list[str], np.ndarray]:
    with open(path) as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    num = np.array([[float(v) if v not in ("",) else np.nan for v in r] for r in body])
    return header, num


def _run_all(scene: Path, tmp: Path) -> dict[int, Path]:
    outs = {}
    for n in (1, 2, 3):
        out = tmp / f"out{n}"
        res = run_scene(scene, out, n, timeout=300)
        assert res.returncode == 0, f"{n} ranks: exit {res.returncode}\n{res.stderr}"
        outs[n] = out
    return outs


def _resultant(column: str) -> bool:
    return column.startswith(("reaction_", "load_", "inertia_"))


def _is_moment(column: str) -> bool:
    return column.rsplit("_", 1)[-1] in ("mx", "my", "mz")


def _compare(outs: dict[int, Path]) -> None:
    for name in ("history.csv", "probes.csv"):
        h1, a1 = _read(outs[1] / name)
        assert len(a1) > 1
        scale = np.abs(np.nan_to_num(a1)).max(axis=0)  # per column
        # reaction/load/inertia columns on the scale of the run's largest force (moment)
        for moment in (False, True):
            force = [j for j, c in enumerate(h1) if _resultant(c) and _is_moment(c) == moment]
            if force:
                scale[force] = scale[force].max()
        for n in (2, 3):
            hn, an = _read(outs[n] / name)
            assert hn == h1 and an.shape == a1.shape, f"{name}: {n} ranks differ in shape/header"
            # rtol 1e-8 with an absolute floor 1e-8 x the column's magnitude (values ~ 0)
            tol = 1e-8 * np.abs(a1) + 1e-8 * scale
            bad = ~(np.abs(an - a1) <= tol) & ~(np.isnan(a1) & np.isnan(an))
            assert not bad.any(), (
                f"{name}: {n} ranks differ from serial at rows/cols "
                f"{np.argwhere(bad)[:5].tolist()}: {an[bad][:5]} vs {a1[bad][:5]}"
            )
    s = [json.loads((outs[n] / "summary.json").read_text()) for n in (1, 2, 3)]
    assert [x["ranks"] for x in s] == [1, 2, 3]
    for key in ("status", "steps", "dofs"):
        assert s[0][key] == s[1][key] == s[2][key], key


def test_history_probes_identical_2d_dynamic(tmp_path):
    scene = tmp_path / "bone2d.toml"
    scene.write_text(
        SCENE_2D.format(mesh=ROOT / "data" / "scenes" / "long_bone.msh", out=tmp_path / "x")
    )
    outs = _run_all(scene, tmp_path)
    _compare(outs)
    # the run is not trivial: the bone moves and stores energy
    _, h = _read(outs[1] / "history.csv")
    assert h[-1, 10] > 0.0 and h[-1, 9] > 0.0
    _, p = _read(outs[1] / "probes.csv")
    assert np.abs(p[:, 6]).max() > 1e-7  # u_y at the probes


@pytest.mark.parametrize("linear", ["direct", pytest.param("iterative", marks=pytest.mark.slow)])
def test_history_probes_identical_3d_quasistatic(tmp_path, linear):
    from bonecontact.meshing import shapes as meshing

    mesh = meshing.box(0.02, 0.01, 0.01, 0.0025, None, path=tmp_path / "box.msh")
    scene = tmp_path / "box3d.toml"
    scene.write_text(SCENE_3D.format(mesh=mesh, out=tmp_path / "x", linear=linear))
    outs = _run_all(scene, tmp_path)
    _compare(outs)
    # the prescribed end displacement follows its schedule at the probe on the right face
    _, p = _read(outs[1] / "probes.csv")
    right = p[p[:, 2] == 2]
    expected = 1.0e-5 * np.interp(right[:, 1], [0.0, 0.5, 1.0], [0.0, 1.0, 0.5])
    np.testing.assert_allclose(right[:, 6], expected, rtol=1e-10, atol=1e-15)
