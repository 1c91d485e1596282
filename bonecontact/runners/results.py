"""Results: summary.json, history.csv, growth.csv, probes.csv and fields for ParaView/pyvista.

The one writer of every run's result files: mechanics runs (:class:`ResultsWriter`),
growth tables (:class:`GrowthTable`, growth-only and coupled runs), point lists
(:func:`write_points`) and summary.json (:func:`run_summary`, :func:`write_summary`; format
number :data:`SUMMARY_FORMAT`).

Files are written incrementally as a run goes (rows by rank 0 only, flushed each
step; fields every ``fields_every`` steps) so that a failed run leaves its last good
state on disk.  Stresses are in Pa, displacements in m, velocities in m/s, forces in
N (N/m in 2D plane strain), energies in J (J/m in 2D).

Fields are written twice, in the same step, both binary and by every rank for its own
cells: ``fields.xdmf`` (+ ``.h5``; ParaView, "Xdmf3ReaderT") and ``fields.pvd`` (binary
VTK pieces, :mod:`bonecontact.runners.vtu`; ParaView and ``pyvista.read``).
"""

from __future__ import annotations

import csv
import json
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mpi4py import MPI

import dolfinx
import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem, geometry, io

from bonecontact.common.errors import InputError
from bonecontact.common.formatting import format_cell, format_float
from bonecontact.common.profiling import peak_memory_mb
from bonecontact.common.version import __version__
from bonecontact.runners.vtu import VtuSeries

if TYPE_CHECKING:
    from bonecontact.mechanics.integrator import Integrator

__all__ = [
    "ENERGY_COLUMNS",
    "GROWTH_UNITS",
    "HISTORY_COLUMNS",
    "MECHANICS_UNITS",
    "SUMMARY_FORMAT",
    "CsvTable",
    "GrowthTable",
    "ProbeError",
    "Probes",
    "RecordTable",
    "ResultsWriter",
    "RunResult",
    "StressFields",
    "run_summary",
    "write_points",
    "write_summary",
]

#: Format number of summary.json (every run kind).
SUMMARY_FORMAT = 1
#: ``units`` entry of a mechanics (and coupled) run's summary.json
MECHANICS_UNITS = "SI (m, kg, s, Pa, N; 2D plane strain: per unit thickness)"
#: ``units`` entry of a growth-only run's summary.json
GROWTH_UNITS = "SI (m, kg, s, Pa, N; 2D: per unit thickness)"

HISTORY_COLUMNS = [
    "step",
    "time",
    "pair",
    "normal_force",
    "tangential_force",
    "n_active",
    "n_stick",
    "n_slip",
    "pdas_iterations",
    "kinetic_energy",
    "strain_energy",
]
#: extra history.csv columns of dynamic runs: running totals of the energy balance
#: (:class:`bonecontact.mechanics.integrator.EnergyBalance`), J or J/m in 2D
ENERGY_COLUMNS = [
    "external_work",
    "dirichlet_work",
    "contact_work",
    "viscous_dissipation",
    "numerical_dissipation",
]


class ProbeError(InputError):
    """A probe point lies outside the mesh (input refused: exit status 2)."""

    def __init__(self, index: int, point: Sequence[float]):
        super().__init__(f"probe #{index + 1} at {list(point)} lies outside the mesh")
        self.index = index
        self.point = point


class StressFields:
    """Cell-wise (DG0) stress, von Mises and principal stresses of a state.

    Parameters
    ----------
    msh
        Mesh.
    sigma
        3×3 UFL stress tensor (plane strain: zz entry is σ_zz).
    """

    #: cells per evaluation of the stress expression (bounds its packed coefficients)
    CHUNK = 16384

    def __init__(self, msh: dolfinx.mesh.Mesh, sigma: ufl.core.expr.Expr):
        T = fem.functionspace(msh, ("DG", 0, (3, 3)))
        S = fem.functionspace(msh, ("DG", 0))
        P = fem.functionspace(msh, ("DG", 0, (3,)))
        self._spaces = (T, S, P)
        self._expr = fem.Expression(sigma, T.element.interpolation_points)
        self._allocate()

    def _allocate(self) -> None:
        T, S, P = self._spaces
        self.stress = fem.Function(T, name="stress")
        self.von_mises = fem.Function(S, name="von_mises")
        self.principal = fem.Function(P, name="principal_stress")

    def release(self) -> None:
        """Free the three fields' values until the next :meth:`update` (the attributes
        are ``None`` meanwhile): 13 values per cell, which a run between two records —
        its solves — does not need (issue 28: 104 MiB per rank at 1M dofs on 2 ranks)."""
        self.stress = self.von_mises = self.principal = None

    def update(self) -> None:
        """Re-evaluate from the current state (the fields made again if released), in
        chunks of cells (evaluated at once, the expression's coefficients of every cell —
        48 values per cell in 3D — would be packed together, 43 MiB at 118k cells, and the
        symmetric part, deviator and eigenvalues three more arrays of 9 values per cell;
        issue 28)."""
        if self.stress is None:
            self._allocate()
        imap = self.stress.function_space.mesh.topology.index_map(
            self.stress.function_space.mesh.topology.dim
        )
        ncells = imap.size_local + imap.num_ghosts
        for start in range(0, ncells, self.CHUNK):
            cells = np.arange(start, min(start + self.CHUNK, ncells), dtype=np.int32)
            self.stress.interpolate(self._expr, cells0=cells)
        stress = self.stress.x.array.reshape(-1, 3, 3)
        von_mises = self.von_mises.x.array
        principal = self.principal.x.array.reshape(-1, 3)
        for start in range(0, stress.shape[0], self.CHUNK):
            part = slice(start, start + self.CHUNK)
            von_mises[part], principal[part] = _invariants(stress[part])


def _invariants(
    sigma: npt.NDArray[np.float64],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Von Mises stress and principal stresses σ1 ≥ σ2 ≥ σ3 of the symmetric parts of
    the (n, 3, 3) stresses ``sigma``."""
    s = sigma + sigma.transpose(0, 2, 1)
    s *= 0.5
    tr = np.trace(s, axis1=1, axis2=2)
    dev = s.copy()
    for i in range(3):
        dev[:, i, i] -= tr / 3.0
    vm = np.sqrt(1.5 * np.einsum("kij,kij->k", dev, dev))
    return vm, np.linalg.eigvalsh(s)[:, ::-1]


class Probes:
    """Point evaluation of displacement, velocity and stress, gathered on rank 0.

    Each point is evaluated in the containing cell of lowest input-mesh index (by the
    rank that owns it), so the values are the same whatever the number of ranks.
    """

    def __init__(self, msh: dolfinx.mesh.Mesh, points: Sequence[Sequence[float]]):
        self.comm = msh.comm
        self.gdim = msh.geometry.dim
        pts = np.zeros((len(points), 3))
        if len(points):
            pts[:, : self.gdim] = np.asarray(points, dtype=np.float64)
        self.points = pts
        tdim = msh.topology.dim
        ncells = msh.topology.index_map(tdim).size_local
        tree = geometry.bb_tree(msh, tdim, padding=1e-12)
        cand = geometry.compute_collisions_points(tree, pts)
        coll = geometry.compute_colliding_cells(msh, cand, pts)
        # A point on a cell boundary touches several cells; pick the one with the lowest
        # ORIGINAL (input-mesh) index over all ranks, so the cell — and therefore the
        # value of a discontinuous field such as the DG0 stress — is the same whatever
        # the partition.
        orig = np.asarray(msh.topology.original_cell_index, dtype=np.int64)
        big = np.iinfo(np.int64).max
        found = np.full(len(points), -1, dtype=np.int32)
        key = np.full(len(points), big, dtype=np.int64)
        for i in range(len(points)):
            cells = coll.links(i)
            cells = cells[cells < ncells]
            if cells.size:
                j = int(np.argmin(orig[cells]))
                found[i], key[i] = cells[j], orig[cells[j]]
        best = np.empty_like(key)
        self.comm.Allreduce(key, best, op=MPI.MIN)
        missing = np.flatnonzero(best == big)
        if missing.size:
            raise ProbeError(int(missing[0]), list(points[missing[0]]))
        have = np.where((key == best) & (found >= 0), self.comm.rank, self.comm.size)
        owner = np.empty_like(have)
        self.comm.Allreduce(have, owner, op=MPI.MIN)
        self.mine = np.flatnonzero(owner == self.comm.rank)
        self.cells = found[self.mine]

    def evaluate(
        self, u: fem.Function, v: fem.Function, stress: StressFields
    ) -> npt.NDArray[np.float64] | None:
        """Rows ``[x.., u.., v.., s.., von_mises]`` per probe on rank 0 (``None`` elsewhere)."""
        g = self.gdim
        p = self.points[self.mine]
        if self.mine.size:
            uu = u.eval(p, self.cells)
            vv = v.eval(p, self.cells)
            ss = stress.stress.eval(p, self.cells).reshape(-1, 3, 3)
            vm = stress.von_mises.eval(p, self.cells).reshape(-1)
        else:
            uu = vv = np.zeros((0, g))
            ss = np.zeros((0, 3, 3))
            vm = np.zeros(0)
        if g == 2:
            sc = (
                np.column_stack([ss[:, 0, 0], ss[:, 1, 1], ss[:, 2, 2], ss[:, 0, 1]])
                if ss.size
                else np.zeros((0, 4))
            )
        else:
            sc = (
                np.column_stack(
                    [ss[:, 0, 0], ss[:, 1, 1], ss[:, 2, 2], ss[:, 0, 1], ss[:, 0, 2], ss[:, 1, 2]]
                )
                if ss.size
                else np.zeros((0, 6))
            )
        rows = (
            np.column_stack([p[:, :g], uu.reshape(-1, g), vv.reshape(-1, g), sc, vm])
            if self.mine.size
            else None
        )
        gathered = self.comm.gather((self.mine, rows), root=0)
        if self.comm.rank != 0:
            return None
        ncol = g + g + g + sc.shape[1] + 1
        out = np.zeros((len(self.points), ncol))
        for idx, r in gathered:
            if r is not None:
                out[idx] = r
        return out

    def header(self) -> list[str]:
        g = self.gdim
        ax = "xyz"[:g]
        s = (
            ["s_xx", "s_yy", "s_zz", "s_xy"]
            if g == 2
            else ["s_xx", "s_yy", "s_zz", "s_xy", "s_xz", "s_yz"]
        )
        return (
            ["step", "time", "probe"]
            + list(ax)
            + [f"u_{a}" for a in ax]
            + [f"v_{a}" for a in ax]
            + s
            + ["von_mises"]
        )


@dataclass
class RunResult:
    """Outcome of a run (:func:`bonecontact.runners.dispatch.run_scene`)."""

    status: str
    summary: dict
    integrator: Integrator | None
    output: Path


def run_summary(
    scene: str,
    status: str,
    comm: MPI.Comm,
    wall_time_s: float,
    /,
    *,
    units: str = MECHANICS_UNITS,
    **info: Any,
) -> dict[str, Any]:
    """The content of summary.json: the common header, then ``info`` (which may override it).

    Collective (the header holds the peak memory of every rank, :func:`peak_memory_mb`).

    Parameters
    ----------
    scene
        Scene name.
    status
        ``"converged"`` or ``"failed"``.
    comm
        Communicator of the run (its size is ``ranks``).
    wall_time_s
        Wall time of the run (s).
    units
        The ``units`` entry (:data:`MECHANICS_UNITS` or :data:`GROWTH_UNITS`).
    **info
        Further entries, in order (``wall_time_s`` here overrides the argument).
    """
    data = {
        "scene": scene,
        "format": SUMMARY_FORMAT,
        "status": status,
        "ranks": comm.size,
        "wall_time_s": wall_time_s,
        "peak_memory_mb": peak_memory_mb(comm),
        "units": units,
        "bonecontact_version": __version__,
        "dolfinx_version": dolfinx.__version__,
    }
    data.update(info)  # callers may override wall_time_s with the whole run's time
    return data


def write_summary(comm: MPI.Comm, directory: Path, summary: dict[str, Any]) -> None:
    """Write ``summary.json`` into ``directory`` (rank 0; not collective)."""
    if comm.rank == 0:
        with open(Path(directory) / "summary.json", "w") as f:
            json.dump(summary, f, indent=2, default=_json_default)


class CsvTable:
    """A CSV file that rank 0 writes row by row (each row flushed) as a run goes.

    Parameters
    ----------
    comm
        Communicator of the run (collective constructor: rank 0 creates the file).
    path
        The file (its directory is created).
    columns
        Header row.
    append
        Continue an existing file (a restart) instead of starting it (no header).
    """

    def __init__(
        self, comm: MPI.Comm, path: Path, columns: Sequence[str], append: bool = False
    ) -> None:
        self.comm = comm
        self._file = self._writer = None
        if comm.rank == 0:
            Path(path).parent.mkdir(parents=True, exist_ok=True)
            self._file = open(path, "a" if append else "w", newline="")
            self._writer = csv.writer(self._file)
            if not append:
                self._writer.writerow(columns)
        comm.barrier()

    def write(self, rows: Sequence[Sequence[str]]) -> None:
        """Append already formatted rows (rank 0; a no-op elsewhere) and flush."""
        if self._writer is not None:
            self._writer.writerows(rows)
            self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = self._writer = None


class GrowthTable(CsvTable):
    """``growth.csv`` (directory ``directory``; header ``time`` and the driver's columns),
    written by rank 0 row by row as a growth runs; ``append`` continues it (a restart)."""

    def __init__(
        self, comm: MPI.Comm, directory: Path, columns: Sequence[str], append: bool = False
    ) -> None:
        super().__init__(comm, Path(directory) / "growth.csv", columns, append)

    def row(self, t: float, values: Sequence[float]) -> None:
        """Append ``t`` (printed as written: ``k*dt`` to 15 digits) and the values."""
        self.write([[f"{t:.15g}"] + [format_float(v) for v in values]])


class RecordTable(CsvTable):
    """A table of records, each giving its cells by ``row()`` (``fracture.csv`` of the 2D
    and 3D crack scenes), written by rank 0 as the run goes."""

    def rows(self, records: Sequence[Any]) -> None:
        self.write([[format_cell(v) for v in r.row()] for r in records])


def write_points(path: Path, columns: Sequence[str], points: npt.ArrayLike) -> None:
    """Write a point list (one row per point, :func:`format_float` text); call on rank 0."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(list(columns))
        w.writerows([[format_float(x) for x in p] for p in points])


class ResultsWriter:
    """Incremental writer of a run's results (rank 0 writes tables; fields collectively).

    Parameters
    ----------
    comm
        Communicator of the run.
    directory
        Output directory (created).
    scene
        Scene name (for the summary).
    probes
        Probe points (``probes.csv``), if any.
    extra_history_columns
        Columns appended to ``HISTORY_COLUMNS`` (dynamic runs: ``ENERGY_COLUMNS``).
    append
        Continue existing history.csv and probes.csv (a restart) instead of starting them.
    fields_stem
        Name of the field files (``<stem>.xdmf``, ``<stem>.pvd``).
    """

    def __init__(
        self,
        comm: MPI.Comm,
        directory: Path,
        scene: str,
        probes: Probes | None = None,
        extra_history_columns: Sequence[str] = (),
        append: bool = False,
        fields_stem: str = "fields",
    ):
        self.comm = comm
        self.fields_stem = fields_stem
        self.dir = Path(directory)
        self.scene = scene
        self.probes = probes
        self.t0 = time.perf_counter()
        self._xdmf = None
        self._vtk = None
        self._hist = self._probe_file = None
        if comm.rank == 0:
            self.dir.mkdir(parents=True, exist_ok=True)
            mode = "a" if append else "w"
            self._hist = open(self.dir / "history.csv", mode, newline="")
            self._hist_w = csv.writer(self._hist)
            if not append:
                self._hist_w.writerow(HISTORY_COLUMNS + list(extra_history_columns))
            if probes is not None and len(probes.points):
                self._probe_file = open(self.dir / "probes.csv", mode, newline="")
                self._probe_w = csv.writer(self._probe_file)
                if not append:
                    self._probe_w.writerow(probes.header())
        comm.barrier()

    # ------------------------------------------------------------- tables
    def history(self, rows: Sequence[Sequence]) -> None:
        """Append history rows (rank 0 only writes)."""
        if self.comm.rank == 0:
            for r in rows:
                self._hist_w.writerow([format_cell(x) for x in r])
            self._hist.flush()

    def probe_rows(
        self, step: int, t: float, u: fem.Function, v: fem.Function, stress: StressFields
    ) -> None:
        """Evaluate the probes (collective) and append their rows."""
        if self.probes is None or not len(self.probes.points):
            return
        vals = self.probes.evaluate(u, v, stress)
        if self.comm.rank == 0:
            for i, r in enumerate(vals):
                self._probe_w.writerow(
                    [str(step), format_cell(t), str(i + 1)] + [format_cell(x) for x in r]
                )
            self._probe_file.flush()

    def contact_table(
        self,
        name: str,
        coords: np.ndarray,
        gap: np.ndarray,
        pressure: np.ndarray,
        traction_t: np.ndarray,
        slip_t: np.ndarray,
        status: Sequence[str],
    ) -> None:
        """(Re)write ``contact_<name>.csv``: one row per slave node, gathered on rank 0
        and sorted by coordinates, so the file does not depend on the partition
        (collective)."""
        gdim = coords.shape[1]
        parts = self.comm.gather((coords, gap, pressure, traction_t, slip_t, list(status)), root=0)
        if self.comm.rank != 0:
            return
        x = np.concatenate([q[0] for q in parts]).reshape(-1, gdim)
        cols = [np.concatenate([q[k] for q in parts]) for k in (1, 2)]
        tt = np.concatenate([q[3] for q in parts]).reshape(-1, gdim - 1)
        st = np.concatenate([q[4] for q in parts]).reshape(-1, gdim - 1)
        stat = sum((q[5] for q in parts), [])
        key = (
            np.round(x / (1e-9 * max(float(np.abs(x).max()), 1e-30))).astype(np.int64)
            if x.size
            else x
        )
        order = np.lexsort(key.T[::-1]) if x.size else np.zeros(0, dtype=int)
        ax = "xyz"[:gdim]
        t_names = ["traction_t"] if gdim == 2 else ["traction_t", "traction_t2"]
        s_names = ["slip_t"] if gdim == 2 else ["slip_t", "slip_t2"]
        with open(self.dir / f"contact_{name}.csv", "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(list(ax) + ["gap", "pressure"] + t_names + s_names + ["status"])
            for i in order:
                w.writerow(
                    [format_cell(v) for v in x[i]]
                    + [format_cell(cols[0][i]), format_cell(cols[1][i])]
                    + [format_cell(v) for v in tt[i]]
                    + [format_cell(v) for v in st[i]]
                    + [stat[i]]
                )

    # ------------------------------------------------------------- fields
    def fields(self, t: float, functions: Sequence[fem.Function]) -> None:
        """Write fields at time ``t`` to fields.xdmf and fields.pvd (collective)."""
        msh = functions[0].function_space.mesh
        if self._xdmf is None:
            stem = self.dir / self.fields_stem
            self._xdmf = io.XDMFFile(self.comm, str(stem.with_suffix(".xdmf")), "w")
            self._xdmf.write_mesh(msh)
            self._vtk = VtuSeries(self.comm, stem.with_suffix(".pvd"))
        for f in functions:
            self._xdmf.write_function(f, t)
        self._vtk.write(t, functions)

    def release_fields(self) -> None:
        """Free what the field writer keeps for the next save (the binary pieces' mesh in
        VTK form), made again then (issue 28)."""
        if self._vtk is not None:
            self._vtk.release()

    # ------------------------------------------------------------ summary
    def summary(self, status: str, **info) -> dict:
        """Write summary.json (rank 0) and return its content."""
        data = run_summary(self.scene, status, self.comm, time.perf_counter() - self.t0, **info)
        write_summary(self.comm, self.dir, data)
        return data

    def close(self) -> None:
        if self._xdmf is not None:
            self._xdmf.close()
        self._xdmf = self._vtk = None
        if self.comm.rank == 0:
            for f in (self._hist, self._probe_file):
                if f is not None:
                    f.close()


def _json_default(o: object) -> int | float | str:
    """NumPy numbers as numbers; anything else json cannot write (paths...) as its text."""
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    return str(o)
