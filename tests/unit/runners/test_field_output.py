"""The field files of a mechanics run (``fields.xdmf`` and ``fields.pvd``): which fields they
hold and their values, read back the way users read them (``bonecontact.plot.read_fields``).

Reference: a bar under uniaxial traction σ with ν = 0, held by rollers on its left and
bottom edges, has the uniform stress σ_xx = σ and the displacement u_x = σx/E, which P1
elements reproduce exactly.  A static analysis's velocity is zero and is not written (issue
28: one field less to format in the output phase); a quasistatic one writes it, and from
rest its first step's velocity is u/Δt.
"""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from cli_support import BAR, BAR_WIDTHS, run_in_process, write_bar_meshes

from bonecontact.plot import read_fields

COMM = MPI.COMM_WORLD
E = 17.0e9
DT = 0.5


@pytest.fixture(scope="module")
def meshes(tmp_path_factory) -> Path:
    """The bars of :data:`cli_support.BAR_WIDTHS`, on a path every rank sees."""
    d = COMM.bcast(str(tmp_path_factory.mktemp("fields")) if COMM.rank == 0 else None)
    return write_bar_meshes(Path(d), COMM)


def _bar(directory: Path, meshes: Path, kind: str, t: float) -> tuple[Path, Path]:
    """The bar scene of ``cli_support.BAR`` as a ``kind`` analysis under the traction t."""
    out = directory / "results"
    text = BAR.format(mesh=meshes / "rect_m.msh", name="cortical", E=E, t=t, out=out, allow="")
    if kind == "quasistatic":
        text = text.replace(
            'kind = "static"\nload_steps = 1', f'kind = "quasistatic"\nt_end = {DT}\ndt = {DT}'
        )
    path = directory / "bar.toml"
    if COMM.rank == 0:
        path.write_text(text)
    COMM.barrier()
    return path, out


@pytest.mark.parametrize("kind", ["static", "quasistatic"])
@pytest.mark.parametrize("t", [1.0e6, -3.0e6])
def test_field_files_hold_the_exact_bar_fields(tmp_shared_path, meshes, kind, t):
    """Both files list the same fields; velocity only when the analysis has one; the
    displacement, stress and von Mises stress of the .pvd equal the bar's exact fields."""
    path, out = _bar(tmp_shared_path, meshes, kind, t)
    assert run_in_process(["run", "-q", str(path)]).returncode == 0
    expected = {"displacement", "stress", "von_mises", "principal_stress"}
    if kind == "quasistatic":
        expected.add("velocity")
    grid = read_fields(out / "fields.pvd")
    names = set(grid.point_data.keys()) | set(grid.cell_data.keys())
    assert {n for n in names if not n.startswith("vtk")} == expected
    xdmf = (out / "fields.xdmf").read_text()
    assert ('Name="velocity"' in xdmf) == (kind == "quasistatic")
    x = np.asarray(grid.points)[:, 0]
    u = np.asarray(grid.point_data["displacement"])
    scale = abs(t) / E * BAR_WIDTHS["rect_m"]
    assert np.abs(u[:, 0] - t * x / E).max() < 1e-9 * scale
    sxx = np.asarray(grid.cell_data["stress"]).reshape(-1, 9)[:, 0]
    assert np.abs(sxx - t).max() < 1e-6 * abs(t)
    assert np.abs(np.asarray(grid.cell_data["von_mises"]) - abs(t)).max() < 1e-6 * abs(t)
    if kind == "quasistatic":
        v = np.asarray(grid.point_data["velocity"])
        assert np.abs(v[:, 0] - t * x / E / DT).max() < 1e-9 * scale / DT
