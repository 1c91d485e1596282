"""``bonecontact run``: unit slips beyond doubt refused, results beyond the small-strain limit
``"invalid"`` (exit status 3), through the command's entry point (collective: serial and
under ``mpiexec``).

References: a bar under uniaxial traction σ with ν = 0 (plane strain, free sides) has the
uniform strain σ/E, which P1 elements reproduce exactly, so the strain measure is σ/E in
every cell; the limit is 10 %.  The slips are the ones of the issue: a modulus written in GPa
numbers as Pa (``E = 17``), a mesh written in millimetres (20 m across); each family has
plausible controls next to the implausible values.
"""

from __future__ import annotations

import json
from pathlib import Path

from mpi4py import MPI

import pytest
from cli_support import BAR_WIDTHS, run_in_process, write_bar_meshes, write_bar_scene

from bonecontact.scene.checks import SMALL_STRAIN_LIMIT

COMM = MPI.COMM_WORLD


class ExitCode:
    """The exit statuses of the command that these tests need (docs: the exit-code table)."""

    CONVERGED = 0
    BAD_INPUT = 2
    INVALID = 3


@pytest.fixture(scope="module")
def meshes(tmp_path_factory) -> Path:
    """The bars of :data:`cli_support.BAR_WIDTHS`, on a path every rank sees."""
    d = COMM.bcast(str(tmp_path_factory.mktemp("validity")) if COMM.rank == 0 else None)
    return write_bar_meshes(Path(d), COMM)


def _scene(d: Path, meshes: Path, **kw) -> tuple[Path, Path]:
    return write_bar_scene(d, meshes, comm=COMM, **kw)


def _summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


def _said(r, text: str) -> bool:
    """``text`` is in the command's stderr (printed on rank 0 only)."""
    return text in r.stderr if COMM.rank == 0 else True


def _not_said(r, text: str) -> bool:
    return text not in r.stderr


@pytest.mark.parametrize(
    "E, refused",
    [
        (17.0, True),  # GPa meant
        (500.0, True),  # below 1 kPa
        (0.017, True),  # far below
        (17.0e9, False),  # the control: bone
        (2.0e6, False),  # below the range of bone but above the floor: only a warning
    ],
)
def test_a_modulus_below_1_kpa_is_refused(tmp_shared_path, meshes, E, refused):
    """Through the command: exit 2 with the reason, nothing written; --allow-implausible runs
    it (a warning) and then the strain decides."""
    t = 1.0e-4 * E  # strain 1e-4 whatever E (a plausible traction would not matter)
    path, out = _scene(tmp_shared_path, meshes, E=E, t=t, name="bone")
    r = run_in_process(["run", "-q", str(path)])
    if refused:
        assert r.returncode == ExitCode.BAD_INPUT
        assert _said(r, '[[material]] #1 "bone", key "E": E = ')
        assert _said(r, "a unit slip beyond doubt; --allow-implausible runs it anyway")
        assert _said(r, "did you mean 17 MPa or 17 GPa?") if E == 17.0 else True
        assert not (out / "summary.json").exists()
        r = run_in_process(["run", "-q", "--allow-implausible", str(path)])
    assert r.returncode == ExitCode.CONVERGED, r.stderr
    assert _summary(out)["strain_measure"] == pytest.approx(1.0e-4, rel=1e-8)
    if E < 5.0e6:  # below the range of bone (data/plausibility.toml): a warning
        assert _said(r, "warning: implausible value")
    else:
        assert _not_said(r, "implausible")


@pytest.mark.parametrize(
    "mesh, refused", [("rect_mm", True), ("rect_um", True), ("rect_m", False), ("rect_1m", False)]
)
def test_a_mesh_larger_than_2_m_or_smaller_than_01_mm_is_refused(
    tmp_shared_path, meshes, mesh, refused
):
    path, out = _scene(tmp_shared_path, meshes, mesh=mesh)
    r = run_in_process(["run", "-q", str(path)])
    if not refused:
        assert r.returncode == ExitCode.CONVERGED, r.stderr
        return
    assert r.returncode == ExitCode.BAD_INPUT
    assert _said(r, f'[scene], key "mesh": the mesh {mesh}.msh is {BAR_WIDTHS[mesh]:.4g} m across')
    if BAR_WIDTHS[mesh] > 2.0:
        assert _said(r, "is the mesh in millimetres?")
    assert not (out / "summary.json").exists()
    allowed = run_in_process(["run", "-q", "--allow-implausible", str(path)])
    assert allowed.returncode == ExitCode.CONVERGED, allowed.stderr
    assert _said(allowed, "warning: implausible value: [scene] mesh")  # still said


@pytest.mark.parametrize("allow", [None, False, True])
@pytest.mark.parametrize("strain", [0.05, 0.099, 0.101, 0.3])
def test_a_strain_beyond_10_percent_is_invalid(tmp_shared_path, meshes, strain, allow):
    """σ = ε E on a ν = 0 bar: the measure is ε exactly; above 10 % the run is "invalid"
    (exit 3, results written) unless [analysis] allow_large_strain = true."""
    E = 1.0e9
    path, out = _scene(tmp_shared_path, meshes, E=E, t=strain * E, name="cancellous", allow=allow)
    r = run_in_process(["run", "-q", str(path)])
    s = _summary(out)
    assert s["strain_measure"] == pytest.approx(strain, rel=1e-8)
    assert s["max_strain"] == pytest.approx(strain, rel=1e-8)
    beyond = strain > SMALL_STRAIN_LIMIT
    assert s["small_strain_valid"] is (not beyond)
    estimate = "an elastic estimate of the strain is"  # before the run: the same limit
    assert _said(r, estimate) if beyond else _not_said(r, estimate)
    accepted = "accepted by [analysis] allow_large_strain = true"
    if beyond and not allow:
        assert r.returncode == ExitCode.INVALID
        assert s["status"] == "invalid"
        assert "small-strain limit 10%" in s["message"] and '"cancellous"' in s["message"]
        assert _said(r, "invalid result: the strain measure reaches")
    else:
        assert r.returncode == ExitCode.CONVERGED, r.stderr
        assert s["status"] == "converged"
        assert _said(r, accepted) if beyond else _not_said(r, accepted)
