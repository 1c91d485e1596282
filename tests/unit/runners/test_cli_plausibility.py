"""``bonecontact check`` / ``run`` as processes: unit slips refused (exit 2), plausibility
warnings, ``--strict``, the check summary, ``--version`` and the small-strain verdict
(exit 3, ``"status": "invalid"``).

References: a bar under uniaxial traction with ν = 0 (plane strain) has the uniform strain
σ/E, which P1 elements reproduce exactly; the dofs of a P1 vector field are 2 × the mesh
nodes; the version is the installed package's metadata.

These tests spawn their own processes, so they run only in the serial session.
"""

from __future__ import annotations

import json
from importlib.metadata import version
from pathlib import Path

from mpi4py import MPI

import pytest
from cli_support import run_cli, write_bar_meshes, write_bar_scene

pytestmark = pytest.mark.serial

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    """The bars of :data:`cli_support.BAR_WIDTHS` (20 mm across in metres; the same numbers
    taken as metres: a mesh written in millimetres; ...)."""
    return write_bar_meshes(tmp_path_factory.mktemp("plausibility-meshes"), MPI.COMM_SELF)


def _scene(tmp_path, meshes, E=17.0e9, t=1.0e6, mesh="rect_m", name="cortical"):
    return write_bar_scene(tmp_path, meshes, E, t, mesh, name, comm=MPI.COMM_SELF)


def _run(args, nproc=1):
    return run_cli(args, nproc, timeout=300)


def test_version():
    r = _run(["--version"])
    assert r.returncode == 0
    assert r.stdout.strip() == f"bonecontact {version('bonecontact')}"


def test_check_summary_of_the_knee():
    import meshio

    r = _run(["check", str(ROOT / "data" / "scenes" / "knee2d.toml")])
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""  # a correct scene: no warning
    out = r.stdout
    m = meshio.read(ROOT / "data" / "scenes" / "knee2d.msh")
    nodes = {int(i) for c in m.cells if c.type == "triangle" for i in c.data.ravel()}
    assert f"dofs        {2 * len(nodes)} (P1 displacement)" in out
    assert "2 bodies" in out  # femur and tibia, apart
    assert "tibiofemoral: femur_contact (slave) on tibia_contact (master), frictionless" in out
    assert "static, 4 load steps" in out
    assert "cortical (Isotropic, E = 17 GPa) on femur_cortical, tibia_cortical" in out
    assert "warnings    none" in out


@pytest.mark.parametrize("nproc", [1, pytest.param(2, marks=pytest.mark.slow)])
def test_gpa_slip_is_refused(tmp_path, meshes, nproc):
    """``E = 17`` (GPa meant): a unit slip beyond doubt, exit 2 with the reason on every
    command, nothing written; --allow-implausible runs it, and the strain (1e6 Pa / 17 Pa)
    makes the result invalid (exit 3)."""
    path, out = _scene(tmp_path, meshes, E=17.0)
    r = _run(["run", "-q", str(path)], nproc)
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("E = 17 Pa: did you mean 17 GPa?") == 1  # rank 0 only
    assert "a unit slip beyond doubt; --allow-implausible runs it anyway" in r.stderr
    assert not out.exists()  # nothing solved, nothing written
    r = _run(["run", "-q", "--allow-implausible", str(path)], nproc)
    assert r.returncode == 3, r.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "invalid"
    assert summary["strain_measure"] == pytest.approx(1.0e6 / 17.0, rel=1e-8)


def test_doubtful_value_with_strict_exits_2(tmp_path, meshes):
    """17 MPa for cortical bone: outside its range but not beyond doubt — a warning
    (test_validity_cli.py); with --strict an error."""
    path, out = _scene(tmp_path, meshes, E=17.0e6)
    strict = _run(["run", "-q", "--strict", str(path)])
    assert strict.returncode == 2
    assert "error (--strict)" in strict.stderr and "E = 1.7e+07 Pa" in strict.stderr
    assert not out.exists()


def test_mesh_in_millimetres_is_refused(tmp_path, meshes):
    path, out = _scene(tmp_path, meshes, mesh="rect_mm")
    r = _run(["run", "-q", str(path)])
    assert r.returncode == 2
    assert "is the mesh in millimetres?" in r.stderr
    assert "20 m across" in r.stderr
    assert not out.exists()


def test_correct_bar_gives_no_warning(tmp_path, meshes):
    path, _ = _scene(tmp_path, meshes)
    r = _run(["check", "--strict", str(path)])
    assert r.returncode == 0, r.stderr
    assert "warning" not in r.stderr


@pytest.mark.parametrize("strain", [0.05, 0.2])
def test_computed_strain_flag(tmp_path, meshes, strain):
    """σ = strain × E on a ν = 0 bar: the computed strain is σ/E exactly; above 10 % the
    run ends "invalid" with exit status 3 (results written) and the console says why."""
    E = 1.0e9
    path, out = _scene(tmp_path, meshes, E=E, t=strain * E, name="cancellous")
    r = _run(["run", "-q", str(path)])
    assert r.returncode == (3 if strain > 0.1 else 0), r.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["max_strain"] == pytest.approx(strain, rel=1e-8)
    assert summary["strain_measure"] == pytest.approx(strain, rel=1e-8)
    assert summary["small_strain_valid"] is (strain <= 0.1)
    assert summary["status"] == ("invalid" if strain > 0.1 else "converged")
    assert len(summary["warnings"]) == (strain > 0.1)  # the estimate before the run
    assert ("invalid result: the strain measure reaches 0.2" in r.stderr) is (strain > 0.1)
