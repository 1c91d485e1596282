"""The table of run kinds (``bonecontact.runners.kinds``): one place chooses the kind, and
``run``, ``check`` and the ``bonecontact`` command all go through it.

Every shipped scene of ``data/scenes`` and a family of test scenes (a plate with or without
a ``[[crack]]``, ``[fracture] initiate``, ``[neoplasm]``, ``[analysis]``) is given the kind
its tables call for (written out here, not computed); the test replaces every row's
``check`` and ``run`` by recorders and asserts that ``dispatch.run_scene``,
``dispatch.check``, ``bonecontact check`` and ``bonecontact run`` reach that row and no
other, and that every row of the table is reached by some scene.  Nothing is solved: the
recorders return at once (collective only through the CLI's summary, which counts no
cells without a model).
"""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

from mpi4py import MPI

import pytest

from bonecontact.runners import cli, dispatch, kinds
from bonecontact.runners.results import RunResult
from bonecontact.scene import load_scene

ROOT = Path(__file__).resolve().parents[3]
SCENES = ROOT / "data" / "scenes"

#: the kind each shipped scene runs as (by its tables: [neoplasm] alone, with [analysis], ...)
SHIPPED = {
    "cyst_radicular": "growth",
    "jaw_cyst3d": "coupled",
    "knee2d": "mechanics",
    "knee2d_gait": "mechanics",
    "knee2d_tumour": "coupled",
    "knee3d_gait": "mechanics",
    "long_bone": "mechanics",
    "tumour_growth_2d": "growth",
}

PLATE = """format = 1
[scene]
name = "{name}"
mesh = "plate.msh"
dimension = 2
{analysis}
{mechanics}
{tables}
"""

MECHANICS = """[[material]]
name = "cortical"
regions = ["plate", "lesion"]
model = "isotropic"
E = 17e9
nu = 0.3
rho = 1900.0
sigma_t = 133e6
K_Ic = 2e6
[[dirichlet]]
boundary = "bottom"
value = [0.0, 0.0]
[[traction]]
boundary = "top"
value = [0.0, 1e6]"""

STATIC = '[analysis]\nkind = "static"\nload_steps = 2'
DYNAMIC = '[analysis]\nkind = "dynamic"\nt_end = 1e-3\ndt = 5e-4'
CRACK = '[[crack]]\nname = "c"\npoints = [[-0.001, 0.0], [0.001, 0.0]]\nregion = "plate"'
INITIATE = "[fracture]\ninitiate = true"
RISK = '[fracture]\ncriterion = "tension"'
CYST = """[neoplasm]
kind = "cyst"
region = "lesion"
host = ["plate"]
t_end = 8.64e4
dt = 4.32e4
mechanics_every = 0
[neoplasm.cyst]
model = "sphere"
beta = 3.2e-11
C_minus = 1.0
temperature = 310.0
E = 1.0e6
viscosity = 1.0e9
"""

#: (name, [analysis] table, other tables, the kind they call for)
FAMILY = [
    ("static", STATIC, "", "mechanics"),
    ("dynamic", DYNAMIC, "", "mechanics"),
    ("risk_only", STATIC, RISK, "mechanics"),
    ("crack_static", STATIC, CRACK, "crack"),
    ("crack_dynamic", DYNAMIC, CRACK, "crack"),
    ("initiate", STATIC, INITIATE, "crack"),
    ("cyst_coupled", STATIC, CYST, "coupled"),
    ("cyst_alone", "", CYST, "growth"),
]


def _family_scene(folder: Path, name: str, analysis: str, tables: str) -> Path:
    path = folder / f"{name}.toml"
    mechanics = MECHANICS if analysis else ""  # a growth-only scene has no mechanics tables
    if MPI.COMM_WORLD.rank == 0:  # one writer: the other ranks read it after the barrier
        path.write_text(
            PLATE.format(name=name, analysis=analysis, mechanics=mechanics, tables=tables)
        )
    return path


def _scenes(folder: Path) -> list[tuple[Path, str]]:
    """Every scene of the test with the kind it calls for (the family's mesh file is only
    named, never read: an empty file, written by rank 0)."""
    if MPI.COMM_WORLD.rank == 0:
        (folder / "plate.msh").touch()
    shipped = [(SCENES / f"{name}.toml", kind) for name, kind in SHIPPED.items()]
    made = [(_family_scene(folder, n, a, t), kind) for n, a, t, kind in FAMILY]
    MPI.COMM_WORLD.barrier()
    return shipped + made


@pytest.fixture
def recorded(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, str]]:
    """Every row's check and run replaced by a recorder of (kind, what was asked)."""
    calls: list[tuple[str, str]] = []
    for name, row in list(kinds.KINDS.items()):

        def check(scene, comm, name=name):
            calls.append((name, "check"))
            return None

        def run(scene, comm, output, progress, restart, name=name):
            calls.append((name, "run"))
            return RunResult("converged", {"steps": 0}, None, Path(output or "."))

        monkeypatch.setitem(kinds.KINDS, name, kinds.RunKind(name, row.what, check, run))
    return calls


def _cli(args: list[str]) -> int:
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        return cli.main(args)


def test_the_shipped_scenes_are_all_listed():
    assert {p.stem for p in SCENES.glob("*.toml")} == set(SHIPPED)


def test_run_check_and_the_command_choose_the_same_kind(tmp_shared_path, recorded):
    """Four routes into the table, each reaching the one row the scene's tables call for."""
    for path, kind in _scenes(tmp_shared_path):
        scene = load_scene(path)
        assert dispatch.run_kind(scene) == kind, path.name
        recorded.clear()
        dispatch.run_scene(scene, output=tmp_shared_path / "out", progress=False)
        dispatch.check(scene)
        assert _cli(["check", str(path)]) == 0, path.name
        assert _cli(["run", str(path), "-q", "-o", str(tmp_shared_path / "out")]) == 0
        assert recorded == [(kind, "run"), (kind, "check"), (kind, "check"), (kind, "run")], (
            path.name
        )


def test_every_kind_of_the_table_is_reached_by_a_scene(tmp_shared_path):
    reached = {dispatch.run_kind(load_scene(p)) for p, _ in _scenes(tmp_shared_path)}
    assert reached == set(kinds.KINDS)
    assert {k for _, _, _, k in FAMILY} | set(SHIPPED.values()) == set(kinds.KINDS)
