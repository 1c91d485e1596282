"""Restart checkpoints of mechanics runs, and the clean stop on SIGINT/SIGTERM (docs/checkpoint.md).

A checkpoint is a directory ``<output>/checkpoints/step_<k>`` (k: 8 digits) holding

* ``state.h5``: HDF5 written collectively by PETSc's HDF5 viewer; every field is a
  dataset in *input order*: entry ``ncomp·i + c`` belongs to node ``i`` of the mesh file
  (``mesh.geometry.input_global_indices``), so the file does not depend on the partition
  and a restart may use another number of ranks;
* ``mesh.vtkhdf``: the mesh of the run (:func:`dolfinx.io.vtkhdf.write_mesh`);
* ``meta.json``: format number, step, time, counters, running energy balance, the
  contact solver's scalar state, and the size and SHA-256 of ``state.h5`` (written last).

It is written under a temporary name (``.step_<k>.tmp``), every file is flushed to disk
(fsync), then the directory is renamed: a checkpoint that exists under its final name is
complete.  The last :data:`KEEP` checkpoints are kept.  On restart, the newest checkpoint
whose ``state.h5`` matches its checksum is used; a damaged one is skipped with a warning.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import re
import shutil
import signal
import threading
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
from dolfinx import fem
from dolfinx.io import vtkhdf

from bonecontact.common.version import __version__
from bonecontact.mechanics.integrator import Integrator

__all__ = [
    "FORMAT_VERSION",
    "KEEP",
    "KIND",
    "CheckpointError",
    "CheckpointSchedule",
    "Checkpointer",
    "InputOrder",
    "RunCounters",
    "StopRequest",
    "checkpoint_dir",
    "checkpoint_summary",
    "find_checkpoint",
    "on_root",
    "read_checkpoint",
    "save_checkpoint",
    "trim_rows",
    "trim_tables",
    "write_checkpoint",
]

#: Format number of a checkpoint (meta.json ``format``); a restart refuses any other.
FORMAT_VERSION = 1
#: How many complete checkpoints a run keeps (the newest ones).
KEEP = 2
#: The ``kind`` of a mechanics checkpoint's meta.json.
KIND = "bonecontact mechanics checkpoint"
_NAME = re.compile(r"^step_(\d{8})$")
_TABLES = ("history.csv", "probes.csv")


class CheckpointError(Exception):
    """A checkpoint cannot be written, found or read (the message says which and why)."""


# ----------------------------------------------------------------------------- ordering
class InputOrder:
    """Moves per-node arrays between this rank's owned nodes and the input order.

    The input order numbers the nodes as the mesh file does
    (``mesh.geometry.input_global_indices``); it is the same for any partition.

    Parameters
    ----------
    V
        A P1 vector space on a mesh with P1 geometry (node = dof block).
    """

    def __init__(self, V: fem.FunctionSpace):
        msh = V.mesh
        cells = V.dofmap.list
        gnodes = msh.geometry.dofmaps[0]
        if cells.shape != gnodes.shape:
            raise CheckpointError("checkpoints need a P1 space on a P1 mesh")
        nblocks = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
        keys = np.full(nblocks, -1, dtype=np.int64)
        inp = np.asarray(msh.geometry.input_global_indices, dtype=np.int64)
        keys[cells.ravel()] = inp[gnodes.ravel()]
        self._init(msh.comm, keys[: V.dofmap.index_map.size_local])

    def _init(self, comm: MPI.Comm, keys: npt.NDArray[np.int64]) -> None:
        self.comm = comm
        self.n_owned = len(keys)
        self.keys = np.asarray(keys, dtype=np.int64)
        self.num_nodes = int(self.comm.allreduce(int(self.keys.max(initial=-1)), op=MPI.MAX)) + 1
        self._scatters: dict[int, tuple[PETSc.Scatter, PETSc.Vec, PETSc.Vec]] = {}

    @classmethod
    def of_keys(cls, comm: MPI.Comm, keys: npt.ArrayLike) -> InputOrder:
        """The order given by ``keys``: the position in the file of each owned entity
        (e.g. the original index of each owned cell); keys are unique over the ranks."""
        order = cls.__new__(cls)
        order._init(comm, np.asarray(keys, dtype=np.int64))
        return order

    def _scatter(self, ncomp: int) -> tuple[PETSc.Scatter, PETSc.Vec, PETSc.Vec]:
        if ncomp not in self._scatters:
            x = PETSc.Vec().createMPI((self.n_owned * ncomp, PETSc.DECIDE), comm=self.comm)
            y = PETSc.Vec().createMPI((PETSc.DECIDE, self.num_nodes * ncomp), comm=self.comm)
            lo = x.getOwnershipRange()[0]
            src = PETSc.IS().createStride(self.n_owned * ncomp, first=lo, step=1, comm=self.comm)
            dst = (ncomp * self.keys[:, None] + np.arange(ncomp)[None, :]).ravel()
            to = PETSc.IS().createGeneral(dst.astype(PETSc.IntType), comm=self.comm)
            sc = PETSc.Scatter().create(x, src, y, to)
            src.destroy()
            to.destroy()
            self._scatters[ncomp] = (sc, x, y)
        return self._scatters[ncomp]

    def to_input(self, owned: npt.ArrayLike, ncomp: int, name: str) -> PETSc.Vec:
        """A vector in input order (named ``name``) from the owned nodes' values."""
        sc, x, y = self._scatter(ncomp)
        x.array[:] = np.asarray(owned, dtype=float).ravel()
        out = y.duplicate()
        out.set(0.0)
        sc.scatter(x, out, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)
        out.setName(name)
        return out

    def from_input(self, vec: PETSc.Vec, ncomp: int) -> npt.NDArray[np.float64]:
        """The owned nodes' values, ``(n_owned, ncomp)``, of a vector in input order."""
        sc, x, _ = self._scatter(ncomp)
        sc.scatter(vec, x, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.REVERSE)
        return x.array.reshape(self.n_owned, ncomp).copy()

    def empty(self, ncomp: int, name: str) -> PETSc.Vec:
        """A vector in input order to load the dataset ``name`` into."""
        vec = self._scatter(ncomp)[2].duplicate()
        vec.setName(name)
        return vec

    def destroy(self) -> None:
        for sc, x, y in self._scatters.values():
            for obj in (sc, x, y):
                obj.destroy()
        self._scatters.clear()


# ----------------------------------------------------------------------------- content
@dataclass
class RunCounters:
    """What a mechanics run counts besides the integrator (kept across a restart)."""

    linear: list[int] = field(default_factory=list)
    pdas: list[int] = field(default_factory=list)
    bound_updates: list[int] = field(default_factory=list)
    e0: float = 0.0
    fields_written: int = -1
    segment: int = 0  # how many restarts led to this run

    def add(self, linear: int, pdas: int | None = None, bound_updates: int | None = None) -> None:
        """Book a step's iteration counts (``pdas`` ``None``: a step without contact)."""
        self.linear.append(int(linear))
        if pdas is not None:
            self.pdas.append(int(pdas))
            self.bound_updates.append(int(bound_updates or 0))


def _fields(integ: Integrator, st: dict) -> list[tuple[str, int, npt.NDArray]]:
    """(name, ncomp, owned values) of every per-node field of the state."""
    bs = integ.model.V.dofmap.index_map_bs
    n = integ.model.V.dofmap.index_map.size_local
    out = [(name, bs, st[name]) for name in ("u_n", "u_nm1", "velocity")]
    c = st.get("contact")
    if c is not None:
        out.append(("Uh", bs, c["Uh"]))
        for k, itf in enumerate(integ.contact.interfaces):
            for key, ncomp in (("active", 1), ("directions", bs - 1), ("lam_n_prev", 1)):
                arr = np.zeros((n, ncomp))
                arr[itf.blocks] = np.asarray(c[key][k], dtype=float).reshape(-1, ncomp)
                out.append((f"contact{k}_{key}", ncomp, arr))
            if c["work_gaps"]:
                arr = np.zeros((n, 1))
                arr[itf.blocks, 0] = c["work_gaps"][k]
                out.append((f"contact{k}_work_gaps", 1, arr))
            mark = np.zeros((n, 1))
            mark[itf.blocks] = 1.0
            out.append((f"contact{k}_slave", 1, mark))
    return out


def _coordinates(integ: Integrator) -> npt.NDArray[np.float64]:
    """Coordinates of the owned nodes (by dof block), ``(n_owned, gdim)``."""
    V = integ.model.V
    msh = V.mesh
    gdim = msh.geometry.dim
    n = V.dofmap.index_map.size_local
    xy = np.zeros((n + V.dofmap.index_map.num_ghosts, gdim))
    xy[V.dofmap.list.ravel()] = msh.geometry.x[msh.geometry.dofmaps[0].ravel(), :gdim]
    return xy[:n]


# ----------------------------------------------------------------------------- writing
def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def on_root(comm: MPI.Comm, action: Callable[[], Any]) -> Any:
    """Run ``action`` on rank 0; its result, or its error as CheckpointError, on every rank."""
    result, error = None, None
    if comm.rank == 0:
        try:
            result = action()
        except Exception as exc:  # reported collectively below
            error = f"{type(exc).__name__}: {exc}"
    result, error = comm.bcast((result, error), root=0)
    if error is not None:
        raise CheckpointError(error)
    return result


def checkpoint_dir(output: Path) -> Path:
    """Where a run in ``output`` keeps its checkpoints."""
    return Path(output) / "checkpoints"


def write_checkpoint(
    output: Path, integ: Integrator, counters: RunCounters, info: dict[str, Any]
) -> Path:
    """Write the state after step ``integ.step_count`` atomically (collective).

    Parameters
    ----------
    output
        The run's output directory.
    integ
        The integrator (its state, with the contact solver's warm start).
    counters
        The run's counters.
    info
        Further entries of meta.json (scene name, analysis kind, dt...).

    Returns
    -------
    Path
        The checkpoint directory.

    Raises
    ------
    CheckpointError
        On every rank, if any part cannot be written (the temporary directory is
        removed; earlier checkpoints are untouched).
    """
    comm = integ.model.mesh.comm

    def files(tmp: Path) -> None:
        _write_state(tmp / "state.h5", integ)
        vtkhdf.write_mesh(str(tmp / "mesh.vtkhdf"), integ.model.mesh)

    st = integ.state()
    meta = {
        "format": FORMAT_VERSION,
        "kind": KIND,
        "bonecontact_version": __version__,
        "step": integ.step_count,
        "time": integ.t,
        "ranks": comm.size,
        "nodes": integ.model.V.dofmap.index_map.size_global,
        "pairs": [itf.name for itf in integ.contact.interfaces] if integ.contact else [],
        "contact_cold": st["contact"]["cold"] if st["contact"] is not None else None,
        "balance": st["balance"],
        "counters": {
            "linear": counters.linear,
            "pdas": counters.pdas,
            "bound_updates": counters.bound_updates,
            "e0": counters.e0,
            "fields_written": counters.fields_written,
            "segment": counters.segment,
        },
        **info,
    }
    return save_checkpoint(output, integ.step_count, comm, files, meta)


def save_checkpoint(
    output: Path,
    step: int,
    comm: MPI.Comm,
    files: Callable[[Path], None],
    meta: dict[str, Any],
) -> Path:
    """Write the checkpoint of ``step`` atomically (collective): ``files(tmp)`` writes
    ``state.h5`` (and any further files) into the temporary directory ``tmp`` (collective),
    then rank 0 flushes every file to disk, adds the size and SHA-256 of ``state.h5`` to
    ``meta`` and writes ``meta.json``, renames the directory to ``step_<step>`` and keeps
    the newest :data:`KEEP` checkpoints.

    Raises
    ------
    CheckpointError
        On every rank, if any part cannot be written (the temporary directory is
        removed; earlier checkpoints are untouched).
    """
    root = checkpoint_dir(output)
    name = f"step_{step:08d}"
    tmp = root / f".{name}.tmp"
    final = root / name

    def prepare() -> None:
        root.mkdir(parents=True, exist_ok=True)
        if tmp.exists():
            shutil.rmtree(tmp)
        tmp.mkdir()

    on_root(comm, prepare)
    try:
        files(tmp)
    except Exception as exc:  # collective writes fail on every rank
        on_root(comm, lambda: shutil.rmtree(tmp, ignore_errors=True))
        raise CheckpointError(f"cannot write checkpoint {final}: {exc}") from None

    def publish() -> str:
        for f in tmp.iterdir():
            _fsync(f)
        h5 = tmp / "state.h5"
        meta["state_size"] = h5.stat().st_size
        meta["state_sha256"] = _sha256(h5)
        with open(tmp / "meta.json", "w") as f:
            json.dump(meta, f, indent=1)
            f.flush()
            os.fsync(f.fileno())
        _fsync(tmp)
        if final.exists():
            shutil.rmtree(final)
        os.rename(tmp, final)
        _fsync(root)
        _prune(root)
        return str(final)

    try:
        return Path(on_root(comm, publish))
    except CheckpointError as exc:
        on_root(comm, lambda: shutil.rmtree(tmp, ignore_errors=True))
        raise CheckpointError(f"cannot write checkpoint {final}: {exc}") from None


def _write_state(path: Path, integ: Integrator) -> None:
    """The per-node fields of the state, in input order, into ``path`` (collective)."""
    order = InputOrder(integ.model.V)
    st = integ.state()
    gdim = integ.model.mesh.geometry.dim
    viewer = PETSc.Viewer().createHDF5(str(path), "w", comm=integ.model.mesh.comm)
    try:
        for name, ncomp, values in [("coordinates", gdim, _coordinates(integ))] + _fields(
            integ, st
        ):
            vec = order.to_input(values, ncomp, name)
            vec.view(viewer)
            vec.destroy()
    finally:
        viewer.destroy()
        order.destroy()


def _prune(root: Path) -> None:
    """Keep the newest :data:`KEEP` complete checkpoints; remove stale temporaries."""
    done = sorted(p for p in root.iterdir() if _NAME.match(p.name))
    for old in done[:-KEEP]:
        shutil.rmtree(old, ignore_errors=True)
    for p in root.iterdir():
        if p.name.startswith(".step_") and p.name.endswith(".tmp"):
            shutil.rmtree(p, ignore_errors=True)


# ----------------------------------------------------------------------------- reading
def _read_meta(path: Path) -> dict[str, Any]:
    """meta.json of a checkpoint, checked (rank 0); raises CheckpointError."""
    try:
        meta = json.loads((path / "meta.json").read_text())
    except (OSError, ValueError) as exc:
        raise CheckpointError(f"checkpoint {path}: no readable meta.json ({exc})") from None
    fmt = meta.get("format")
    if fmt != FORMAT_VERSION:
        raise CheckpointError(
            f"checkpoint {path} has format {fmt!r}, but this bonecontact "
            f"({__version__}) reads format {FORMAT_VERSION} only; continue that run with "
            f"the version that wrote it ({meta.get('bonecontact_version', 'unknown')})"
        )
    return meta


def _verify(path: Path) -> dict[str, Any]:
    """meta.json, after checking that state.h5 is complete (size and SHA-256)."""
    meta = _read_meta(path)
    h5 = path / "state.h5"
    if not h5.is_file():
        raise CheckpointError(f"checkpoint {path}: state.h5 is missing")
    if h5.stat().st_size != meta.get("state_size") or _sha256(h5) != meta.get("state_sha256"):
        raise CheckpointError(f"checkpoint {path}: state.h5 is damaged (checksum mismatch)")
    return meta


def find_checkpoint(
    output: Path, comm: MPI.Comm, named: Path | None = None
) -> tuple[Path, dict[str, Any]]:
    """The checkpoint to continue from, and its meta.json (collective).

    ``named``: that checkpoint (a directory), which must be intact.  Otherwise the newest
    intact checkpoint of ``output``; damaged newer ones are skipped with a
    :class:`UserWarning` (rank 0).  A different format number is an error.

    Raises
    ------
    CheckpointError
        On every rank: nothing usable found, or the named one is damaged.
    """

    def search() -> tuple[str, dict, list[str]]:
        if named is not None:
            p = Path(named)
            return str(p), _verify(p), []
        root = checkpoint_dir(output)
        cands = (
            sorted((p for p in root.iterdir() if _NAME.match(p.name)), reverse=True)
            if root.is_dir()
            else []
        )
        skipped = []
        for p in cands:
            try:
                return str(p), _verify(p), skipped
            except CheckpointError as exc:
                if "format" in str(exc) and "reads format" in str(exc):
                    raise
                skipped.append(str(exc))
        why = f" ({'; '.join(skipped)})" if skipped else ""
        raise CheckpointError(f"no intact checkpoint in {root}{why}")

    path, meta, skipped = on_root(comm, search)
    if comm.rank == 0:
        for msg in skipped:
            warnings.warn(f"{msg}; using an older checkpoint", UserWarning, stacklevel=2)
    return Path(path), meta


def read_checkpoint(path: Path, meta: dict[str, Any], integ: Integrator) -> RunCounters:
    """Restore the integrator (and its contact solver) from a checkpoint (collective).

    The mesh must be the one the checkpoint was written on (same nodes at the same
    coordinates, 1e-12 of the mesh size); any number of ranks.

    Returns
    -------
    RunCounters
        The run's counters at the checkpoint.
    """
    comm = integ.model.mesh.comm
    order = InputOrder(integ.model.V)
    nodes = integ.model.V.dofmap.index_map.size_global
    if meta["nodes"] != nodes:
        raise CheckpointError(
            f"checkpoint {path} was written on a mesh with {meta['nodes']} nodes; "
            f"this scene's mesh has {nodes}"
        )
    pairs = [itf.name for itf in integ.contact.interfaces] if integ.contact else []
    if meta["pairs"] != pairs:
        raise CheckpointError(
            f"checkpoint {path} has contact pairs {meta['pairs']}; this scene has {pairs}"
        )
    st = integ.state()  # the layout to fill
    gdim = integ.model.mesh.geometry.dim
    viewer = PETSc.Viewer().createHDF5(str(path / "state.h5"), "r", comm=comm)
    try:

        def load(name: str, ncomp: int) -> npt.NDArray[np.float64]:
            vec = order.empty(ncomp, name)
            vec.load(viewer)
            out = order.from_input(vec, ncomp)
            vec.destroy()
            return out

        _check_coordinates(path, load("coordinates", gdim), _coordinates(integ), comm)
        new = {name: load(name, ncomp) for name, ncomp, _ in _fields(integ, st)}
    finally:
        viewer.destroy()
        order.destroy()
    _fill_state(st, new, integ, meta)
    integ.restore_state(st)
    c = meta["counters"]
    return RunCounters(
        list(c["linear"]),
        list(c["pdas"]),
        list(c["bound_updates"]),
        float(c["e0"]),
        int(c["fields_written"]),
        int(c["segment"]),
    )


def _check_coordinates(path: Path, saved: npt.NDArray, here: npt.NDArray, comm: MPI.Comm) -> None:
    size = comm.allreduce(float(np.abs(here).max(initial=0.0)), op=MPI.MAX)
    err = comm.allreduce(float(np.abs(saved - here).max(initial=0.0)), op=MPI.MAX)
    if err > 1e-12 * max(size, 1e-300):
        raise CheckpointError(
            f"checkpoint {path} was written on another mesh (nodes moved by up to {err:.3g} m)"
        )


def _fill_state(st: dict, new: dict[str, npt.NDArray], integ: Integrator, meta: dict) -> None:
    """Put the loaded per-node values into the layout of ``integ.state()``."""
    for name in ("u_n", "u_nm1", "velocity"):
        st[name] = new[name].ravel()
    st["t"], st["step_count"] = float(meta["time"]), int(meta["step"])
    st["balance"] = dict(meta["balance"])
    c = st.get("contact")
    if c is None:
        return
    c["Uh"] = new["Uh"].ravel()
    c["cold"] = bool(meta["contact_cold"])
    for k, itf in enumerate(integ.contact.interfaces):
        if not np.all(new[f"contact{k}_slave"][itf.blocks] == 1.0):
            raise CheckpointError(f"contact pair {itf.name!r}: the slave nodes have changed")
        c["active"][k] = new[f"contact{k}_active"][itf.blocks, 0] > 0.5
        c["directions"][k] = new[f"contact{k}_directions"][itf.blocks]
        c["lam_n_prev"][k] = new[f"contact{k}_lam_n_prev"][itf.blocks, 0]
        if c["work_gaps"]:
            c["work_gaps"][k] = new[f"contact{k}_work_gaps"][itf.blocks, 0]


# ----------------------------------------------------------------------------- tables
def trim_tables(output: Path, step: int, comm: MPI.Comm) -> None:
    """Cut history.csv and probes.csv after the rows of ``step`` (rank 0; collective).

    A run that went on after its last checkpoint wrote rows the restart writes again.

    Raises
    ------
    CheckpointError
        If history.csv is missing or ends before ``step`` (rows would be missing).
    """

    def trim() -> None:
        for name in _TABLES:
            path = Path(output) / name
            if not path.is_file():
                if name == "history.csv":
                    raise CheckpointError(f"{path} is missing: cannot append to it")
                continue
            with open(path, newline="") as f:
                rows = list(csv.reader(f))
            keep = [rows[0]] + [r for r in rows[1:] if r and int(r[0]) <= step]
            if int(keep[-1][0] if len(keep) > 1 else -1) != step:
                raise CheckpointError(
                    f"{path} has no rows of step {step} (the checkpoint is newer than the "
                    "table): cannot continue it without missing rows"
                )
            tmp = path.with_suffix(".csv.tmp")
            with open(tmp, "w", newline="") as f:
                csv.writer(f).writerows(keep)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)

    on_root(comm, trim)


def trim_rows(path: Path, rows: int, comm: MPI.Comm) -> None:
    """Keep the header and the first ``rows`` rows of the table ``path`` (rank 0; collective).

    For tables with one row per step and no step column (growth.csv: row k is step k).

    Raises
    ------
    CheckpointError
        If the table is missing or has fewer rows (rows would be missing).
    """

    def trim() -> None:
        if not path.is_file():
            raise CheckpointError(f"{path} is missing: cannot append to it")
        with open(path, newline="") as f:
            table = list(csv.reader(f))
        if len(table) - 1 < rows:
            raise CheckpointError(
                f"{path} has {len(table) - 1} rows, the checkpoint needs {rows} (the checkpoint "
                "is newer than the table): cannot continue it without missing rows"
            )
        tmp = path.with_suffix(".csv.tmp")
        with open(tmp, "w", newline="") as f:
            csv.writer(f).writerows(table[: rows + 1])
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)

    on_root(comm, trim)


# ----------------------------------------------------------------------------- stopping
class StopRequest:
    """SIGINT and SIGTERM ask the run to stop after the current step (context manager).

    The first signal sets a flag; the run checks :meth:`agreed` between steps (all ranks
    together), writes a checkpoint and stops.  A second signal interrupts at once
    (``KeyboardInterrupt``).  Outside the main thread nothing is installed.
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.signum = 0
        self._old: dict[int, Any] = {}

    def _handler(self, signum: int, frame: FrameType | None) -> None:
        if self.signum:
            raise KeyboardInterrupt
        self.signum = signum

    def __enter__(self) -> StopRequest:
        if threading.current_thread() is threading.main_thread():
            for s in self.SIGNALS:
                self._old[s] = signal.signal(s, self._handler)
        return self

    def __exit__(self, *exc: object) -> None:
        for s, h in self._old.items():
            signal.signal(s, h)
            outer = getattr(h, "__self__", None)
            if isinstance(outer, StopRequest) and self.signum and not outer.signum:
                outer.signum = self.signum  # a nested run's signal stops the enclosing run
        self._old.clear()

    def agreed(self, comm: MPI.Comm) -> int:
        """The signal number if any rank got a signal, else 0 (collective)."""
        return int(comm.allreduce(self.signum, op=MPI.MAX))


class CheckpointSchedule:
    """When periodic checkpoints are due: every ``every`` steps, after the first step that
    reaches each multiple of ``interval`` of simulated time, and after the last step when
    either is set (0 turns each off).

    Parameters
    ----------
    every
        Steps between checkpoints (``[output] checkpoint_every``).
    interval
        Simulated time between checkpoints, s (``[output] checkpoint_time``).
    t0
        The time the run starts (or continues) from, s.
    """

    def __init__(self, every: int, interval: float, t0: float = 0.0):
        self.every, self.interval = int(every), float(interval)
        self.t_last = float(t0)

    def _slot(self, t: float) -> int:
        """How many whole intervals ``t`` has reached (a relative 1e-9 of slack for the
        round-off of summed steps)."""
        return math.floor(t / self.interval + 1e-9)

    def due(self, step: int, t: float, last: bool) -> bool:
        """Whether a checkpoint is due after ``step``, which reached time ``t`` (call once
        per step)."""
        by_time = self.interval > 0 and self._slot(t) > self._slot(self.t_last)
        self.t_last = float(t)
        by_step = self.every > 0 and step % self.every == 0
        return by_step or by_time or (last and (self.every > 0 or self.interval > 0))


def signal_name(signum: int) -> str:
    """``"SIGTERM"`` for 15, etc."""
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


# ----------------------------------------------------------------------------- the run's side
def checkpoint_summary(ck: Any) -> dict[str, Any]:
    """The summary.json entries of a run's checkpointer ``ck`` (:class:`Checkpointer`, or the
    growth and crack ones: attributes ``every``, ``schedule``, ``written``, ``time_s``,
    ``last``, ``restarted_from``, ``signum``): ``checkpoints``, after a restart
    ``restarted_from``, after a signal ``signal``."""
    out: dict[str, Any] = {
        "checkpoints": {
            "every": ck.every,
            "time": ck.schedule.interval,
            "written": ck.written,
            "write_time_s": ck.time_s,
            "last": None if ck.last is None else str(ck.last),
        }
    }
    if ck.restarted_from is not None:
        out["restarted_from"] = ck.restarted_from
    if ck.signum:
        out["signal"] = signal_name(ck.signum)
    return out


class Checkpointer:
    """A mechanics run's checkpoints: restart, periodic writes, the stop on a signal.

    Parameters
    ----------
    output
        The run's output directory.
    integ
        The run's integrator (after ``set_initial``).
    every
        Write a checkpoint every this many steps (0: only when stopped by a signal).
    info
        Entries that must agree between a checkpoint and the run continuing it
        (scene name, analysis kind, dt).
    interval
        Also write one after the first step that reaches each multiple of this much
        simulated time, s (0: none).
    on_signal
        Write a checkpoint when a signal stops the run (``False`` for an analysis run by
        a coupled run: the coupled run checkpoints, the signal reaches it).
    """

    def __init__(
        self,
        output: Path,
        integ: Integrator,
        every: int,
        info: dict[str, Any],
        interval: float = 0.0,
        on_signal: bool = True,
    ):
        self.output, self.integ, self.every = Path(output), integ, int(every)
        self.on_signal = bool(on_signal)
        self.schedule = CheckpointSchedule(every, interval, integ.t)
        #: further state for meta.json: entry name -> a function giving its JSON value
        self.extra: dict[str, Callable[[], Any]] = {}
        #: the meta.json of the checkpoint the run continues from (after :meth:`resume`)
        self.resumed: dict[str, Any] = {}
        self.comm = integ.model.mesh.comm
        self.info = dict(info)
        self.counters = RunCounters(e0=integ.balance.total)
        self.stop = StopRequest()
        self.restarted_from: dict[str, Any] | None = None
        self.last: Path | None = None
        self.written = 0
        self.time_s = 0.0
        self.signum = 0

    @property
    def fields_stem(self) -> str:
        """Field files of this segment: ``fields`` (first run), ``fields_restart<n>`` after."""
        seg = self.counters.segment
        return "fields" if seg == 0 else f"fields_restart{seg}"

    def resume(self, named: str | Path | None) -> None:
        """Continue from the newest (or the named) checkpoint: restore the integrator and
        the counters, cut the tables after the checkpoint's step (collective).

        Raises
        ------
        CheckpointError
            On every rank, before any file is changed.
        """
        path, meta = find_checkpoint(self.output, self.comm, None if not named else Path(named))
        if meta.get("kind") != KIND:
            raise CheckpointError(
                f"checkpoint {path} is a {meta.get('kind')!r}, not a mechanics run's: "
                "a restart continues the same scene"
            )
        for key, value in self.info.items():
            if meta.get(key) != value:
                raise CheckpointError(
                    f"checkpoint {path} has {key} = {meta.get(key)!r}, the scene {value!r}: "
                    "a restart continues the same scene"
                )
        self.counters = read_checkpoint(path, meta, self.integ)
        self.resumed = meta
        self.counters.segment += 1
        self.schedule.t_last = self.integ.t
        trim_tables(self.output, int(meta["step"]), self.comm)
        self.restarted_from = {
            "checkpoint": str(path),
            "step": int(meta["step"]),
            "time": float(meta["time"]),
            "ranks": int(meta["ranks"]),
        }
        self.last = path

    def after_step(self, last: bool = False) -> int:
        """Between steps (collective): write a checkpoint when one is due
        (:class:`CheckpointSchedule`) or a signal came.

        Returns the signal number (0: go on)."""
        self.signum = self.stop.agreed(self.comm)
        due = self.schedule.due(self.integ.step_count, self.integ.t, last)
        if (self.signum and self.on_signal) or due:
            self.write()
        return self.signum

    def write(self) -> Path:
        """Write a checkpoint of the current state now (collective)."""
        t0 = time.perf_counter()
        info = {**self.info, **{name: get() for name, get in self.extra.items()}}
        self.last = write_checkpoint(self.output, self.integ, self.counters, info)
        self.time_s += time.perf_counter() - t0
        self.written += 1
        return self.last

    def summary(self) -> dict[str, Any]:
        """The summary.json entries: ``checkpoints`` and, after a restart, ``restarted_from``."""
        return checkpoint_summary(self)
