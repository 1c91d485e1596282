"""The ``bonecontact`` command: input validation and failure handling (docs/scene_format.md).

Every validation rule of the scene format is exercised through the command's entry
point (``bonecontact.runners.cli.main``, in this process), and a representative subset
through the real command (``bonecontact run`` in a new process, serially and under
``mpiexec -n 2``).  Each must give exit status 2, one message that names the file and
the key (and the allowed values where there is a set), no traceback, and no results.

Most of these tests spawn their own processes, so the module runs only in the serial
session.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from cli_support import ENV as BASE_ENV
from cli_support import check_reaction_balance, run_cli

from bonecontact.runners.cli import main

pytestmark = pytest.mark.serial

ENV = {**BASE_ENV, "PYTHONWARNINGS": "ignore"}


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    """Two tiny meshes: a 2D rectangle and a 3D box (groups body/left/right/bottom/top...)."""
    from bonecontact.meshing import shapes as meshing

    d = tmp_path_factory.mktemp("cli-meshes")
    meshing.rectangle(0.02, 0.01, 8, 4, None, path=d / "rect.msh")
    meshing.box(0.02, 0.01, 0.01, 0.005, None, path=d / "box.msh")
    return d


BASE = """format = 1

[scene]
name = "cli"
mesh = "{mesh}"
dimension = {dim}

[analysis]
kind = "dynamic"
t_end = 0.002
dt = 0.001

[[material]]
name = "bone"
regions = ["body"]
model = "isotropic"
E = 17.0e9
nu = 0.3
rho = 1900.0

[[dirichlet]]
boundary = "left"
value = [0.0, 0.0]

[[traction]]
boundary = "right"
value = [0.0, -1.0e6]
ramp = 0.001

[output]
directory = "{out}"
fields_every = 0
probes = [[0.01, 0.005]]
"""


def _scene(
    tmp_path: Path, meshes: Path, edit=None, text: str | None = None, dim: int = 2
) -> tuple[Path, Path]:
    out = tmp_path / "results"
    mesh = meshes / ("rect.msh" if dim == 2 else "box.msh")
    src = BASE.format(mesh=mesh, dim=dim, out=out) if text is None else text
    if edit is not None:
        src = edit(src)
    path = tmp_path / "scene.toml"
    path.write_text(src)
    return path, out


def _run(args: list[str], nproc: int = 1, timeout: float = 180) -> subprocess.CompletedProcess:
    return run_cli(args, nproc, timeout, env=ENV)


def _sub(old: str, new: str):
    def edit(src: str) -> str:
        assert old in src, f"test set-up: {old!r} not in the base scene"
        return src.replace(old, new, 1)

    return edit


# (case id, edit of the base scene, words that must appear in the message)
CASES = [
    ("malformed_toml", _sub('name = "cli"', 'name = "cli'), ["scene.toml"]),
    ("unknown_top_key", _sub("format = 1", "format = 1\ncolour = 3"), ["colour"]),
    ("unknown_table_key", _sub("dt = 0.001", "dt = 0.001\ndtt = 0.1"), ["dtt", "analysis"]),
    ("wrong_type", _sub("E = 17.0e9", 'E = "stiff"'), ["E"]),
    ("missing_required_key", _sub('model = "isotropic"\n', ""), ["model"]),
    ("unknown_cell_group", _sub('regions = ["body"]', 'regions = ["marrow"]'), ["marrow"]),
    ("unknown_facet_group", _sub('boundary = "left"', 'boundary = "distal"'), ["distal"]),
    ("cell_group_as_boundary", _sub('boundary = "right"', 'boundary = "body"'), ["body"]),
    ("dimension_mismatch", _sub("dimension = 2", "dimension = 3"), ["dimension"]),
    ("missing_mesh_file", _sub('rect.msh"', 'nothere.msh"'), ["mesh", "nothere.msh"]),
    ("E_not_positive", _sub("E = 17.0e9", "E = -1.0"), ["E"]),
    ("nu_too_large", _sub("nu = 0.3", "nu = 0.5"), ["nu"]),
    ("nu_too_small", _sub("nu = 0.3", "nu = -1.0"), ["nu"]),
    (
        "not_positive_definite",
        _sub(
            'model = "isotropic"\nE = 17.0e9\nnu = 0.3',
            'model = "orthotropic"\nE1 = 1e9\nE2 = 1e9\nE3 = 1e9\n'
            "nu12 = 0.9\nnu13 = 0.9\nnu23 = 0.9\n"
            "G12 = 1e8\nG13 = 1e8\nG23 = 1e8\naxes = [[1.0, 0.0], [0.0, 1.0]]",
        ),
        ["positive"],
    ),
    ("missing_rho_dynamic", _sub("rho = 1900.0\n", ""), ["rho"]),
    ("dt_not_positive", _sub("dt = 0.001", "dt = 0.0"), ["dt"]),
    ("t_end_not_positive", _sub("t_end = 0.002", "t_end = -1.0"), ["t_end"]),
    (
        "load_steps_below_one",
        _sub('kind = "dynamic"\nt_end = 0.002\ndt = 0.001', 'kind = "static"\nload_steps = 0'),
        ["load_steps"],
    ),
    (
        "unknown_analysis_kind",
        _sub('kind = "dynamic"', 'kind = "explicit"'),
        ["kind", "static", "quasistatic", "dynamic"],
    ),
    (
        "unknown_linear_solver",
        _sub("[[material]]", '[solver]\nlinear = "cholesky"\n\n[[material]]'),
        ["linear", "direct", "iterative"],
    ),
    (
        "unknown_material_model",
        _sub('model = "isotropic"', 'model = "hyperelastic"'),
        ["model", "isotropic", "orthotropic"],
    ),
    (
        "wrong_component_count",
        _sub("value = [0.0, -1.0e6]", "value = [0.0, -1.0e6, 0.0]"),
        ["value"],
    ),
    (
        "ramp_and_schedule",
        _sub("ramp = 0.001", "ramp = 0.001\nschedule = [[0.0, 0.0], [1.0, 1.0]]"),
        ["ramp", "schedule"],
    ),
    ("probe_outside_mesh", _sub("probes = [[0.01, 0.005]]", "probes = [[0.5, 0.5]]"), ["probes"]),
    ("format_not_1", _sub("format = 1", "format = 2"), ["format"]),
]

# A friction key of another law (a Coulomb coefficient on a Tresca pair) is an input error.
CONTACT_NOT_YET = (
    "friction_key_of_another_law",
    _sub(
        "[[dirichlet]]",
        '[[contact]]\nname = "joint"\nslave = "top"\nmaster = "bottom"\nfriction = "tresca"\n'
        "coefficient = 0.3\n\n[[dirichlet]]",
    ),
    ["coefficient", "coulomb", "tresca"],
)


def _check_input_error(
    res: subprocess.CompletedProcess, words: list[str], out: Path, nproc: int
) -> None:
    text = res.stdout + res.stderr
    assert res.returncode == 2, f"exit {res.returncode}, expected 2:\n{text}"
    assert "Traceback" not in text, text
    assert "scene.toml" in res.stderr, f"the message must name the file:\n{res.stderr}"
    low = res.stderr.lower()
    for w in words:
        assert w.lower() in low, f"the message must name {w!r}:\n{res.stderr}"
    # printed once (rank 0 only), and nothing written
    assert res.stderr.count("error:") == 1, res.stderr
    assert not out.exists(), f"{out} was created by a run with invalid input"


@pytest.mark.parametrize("case", CASES + [CONTACT_NOT_YET], ids=lambda c: c[0])
def test_invalid_input_exit_2(case, tmp_path, meshes, capsys):
    """The entry point in this process: its return value is the exit status."""
    _, edit, words = case
    scene, out = _scene(tmp_path, meshes, edit)
    code = main(["run", str(scene), "-q"])
    captured = capsys.readouterr()
    res = subprocess.CompletedProcess(["main"], code, captured.out, captured.err)
    _check_input_error(res, words, out, 1)


COMMAND_SUBSET = {"malformed_toml", "missing_mesh_file", "unknown_analysis_kind"}


@pytest.mark.parametrize("case", [c for c in CASES if c[0] in COMMAND_SUBSET], ids=lambda c: c[0])
def test_invalid_input_exit_2_command(case, tmp_path, meshes):
    """The real command in a new process: exit status 2 from the interpreter."""
    _, edit, words = case
    scene, out = _scene(tmp_path, meshes, edit)
    _check_input_error(_run(["run", str(scene), "-q"]), words, out, 1)


MPI_SUBSET = {
    "malformed_toml",
    "unknown_cell_group",
    "nu_too_large",
    "probe_outside_mesh",
    "missing_rho_dynamic",
    "dimension_mismatch",
}


@pytest.mark.parametrize("case", [c for c in CASES if c[0] in MPI_SUBSET], ids=lambda c: c[0])
def test_invalid_input_exit_2_mpi(case, tmp_path, meshes):
    """Under ``mpiexec -n 2`` the same error stops both ranks (no hang), printed once."""
    _, edit, words = case
    scene, out = _scene(tmp_path, meshes, edit)
    _check_input_error(_run(["run", str(scene), "-q"], nproc=2, timeout=120), words, out, 2)


def test_valid_scene_runs_and_energy_is_plausible(tmp_path, meshes):
    """The base scene itself is valid: exit 0 and the results docs/scene_format.md lists."""
    scene, out = _scene(tmp_path, meshes)
    res = _run(["run", str(scene), "-q"])
    assert res.returncode == 0, res.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "converged"
    assert summary["steps"] == 2
    header = (out / "history.csv").read_text().splitlines()[0]
    assert header == (
        "step,time,pair,normal_force,tangential_force,n_active,n_stick,n_slip,"
        "pdas_iterations,kinetic_energy,strain_energy,external_work,dirichlet_work,"
        "contact_work,viscous_dissipation,numerical_dissipation,"
        "reaction_left_x,reaction_left_y,reaction_left_mz,load_x,load_y,load_mz,"
        "inertia_x,inertia_y,inertia_mz"
    )
    check_reaction_balance(out)  # the support's reaction, the loads and the inertia balance
    # dynamic run: the energy balance closes (E = W_ext + W_dir + W_c - D_visc - D_num from rest)
    last = [float(x) for x in (out / "history.csv").read_text().splitlines()[-1].split(",")[3:]]
    e, works = last[6] + last[7], last[8] + last[9] + last[10] - last[11] - last[12]
    assert e > 0.0 and works == pytest.approx(e, rel=1e-9)
    assert summary["energy"]["final"] == pytest.approx(e, rel=1e-12)
    assert (
        (out / "probes.csv").read_text().splitlines()[0].startswith("step,time,probe,x,y,u_x,u_y")
    )


def test_solver_failure_exit_1_last_state_written(tmp_path, meshes):
    """A linear solver that cannot converge: exit 1, status "failed" with a message, and
    the last good state (step 0) written."""
    scene, out = _scene(
        tmp_path,
        meshes,
        _sub(
            "[[material]]",
            '[solver]\nlinear = "iterative"\nmax_iterations = 1\ntolerance = 1e-14\n\n[[material]]',
        ),
    )
    env_opts = {**ENV, "PETSC_OPTIONS": "-bc_ksp_max_it 1 -bc_ksp_error_if_not_converged 1"}
    res = run_cli(["run", str(scene), "-q"], timeout=180, env=env_opts)
    assert res.returncode == 1, res.stdout + res.stderr
    assert "Traceback" not in res.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed"
    assert "step 1" in summary["message"]
    rows = (out / "history.csv").read_text().splitlines()
    assert rows[1].startswith("0,0.0,"), rows  # the initial (last good) state is there


def test_help():
    res = _run(["--help"])
    assert res.returncode == 0 and "run" in res.stdout and "SI" in res.stdout
    res = _run(["run", "--help"])
    assert res.returncode == 0 and "scene" in res.stdout.lower() and "--output" in res.stdout
