"""Restart checkpoints of every run kind, and the clean stop on SIGINT/SIGTERM (docs/checkpoint.md).

One protocol for every run kind.  What a run kind saves is a :class:`RunState`: its fields
(``state.h5``), a small dict of scalars (``meta.json``) and the result tables it continues;
:class:`MechanicsState` (mechanics runs), :class:`CrackState` (crack scenes: a mechanics
state on the cracked mesh, with fracture.csv) and :class:`GrowthState` (growth-only and
coupled runs).  One :class:`Checkpointer` writes, finds, validates and resumes them:

* a checkpoint is a directory ``<output>/checkpoints/step_<k>`` (k: 8 digits) with
  ``state.h5`` (HDF5 written collectively by PETSc's HDF5 viewer, every field a dataset in
  the *input order* of :class:`InputOrder`, so a restart may use another number of ranks),
  ``mesh.vtkhdf`` (the mesh, for viewing) and ``meta.json`` (format number, kind, step,
  time, ranks, the state's scalars, the run's entries, size and SHA-256 of ``state.h5``);
* it is written under a temporary name (``.step_<k>.tmp``), every file is flushed to disk,
  ``meta.json`` is written last and the directory renamed: a checkpoint under its final
  name is complete (:func:`save_checkpoint`); the last :data:`KEEP` are kept;
* a restart takes the named checkpoint, or the newest whose ``state.h5`` matches its
  checksum (a damaged one is skipped with a warning; :func:`find_checkpoint`), checks its
  kind and the entries the scene must agree on, restores the state and cuts the tables
  after the checkpoint's step (:meth:`Checkpointer.resume`).
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
from typing import Any, Protocol

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
from dolfinx import fem
from dolfinx import mesh as dmesh
from dolfinx.io import vtkhdf

from bonecontact.common.errors import CheckpointError
from bonecontact.common.version import __version__
from bonecontact.fracture.propagation import FRACTURE_COLUMNS
from bonecontact.mechanics.integrator import Integrator
from bonecontact.neoplasm.growth import CystShapeGrowth, CystSphereGrowth, TumourGrowth
from bonecontact.neoplasm.remesh import mesh_from_cells

__all__ = [
    "CRACK_KIND",
    "FORMAT_VERSION",
    "GROWTH_KIND",
    "KEEP",
    "KIND",
    "CheckpointError",
    "CheckpointSchedule",
    "Checkpointer",
    "CrackState",
    "GrowthState",
    "InputOrder",
    "MechanicsState",
    "RunCounters",
    "RunState",
    "StopRequest",
    "checkpoint_dir",
    "checkpoint_summary",
    "find_checkpoint",
    "on_root",
    "read_checkpoint",
    "read_growth_state",
    "save_checkpoint",
    "signal_name",
    "trim_fracture_table",
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
#: The ``kind`` of a crack scene's checkpoint.
CRACK_KIND = "bonecontact crack checkpoint"
#: The ``kind`` of a growth-only or coupled run's checkpoint.
GROWTH_KIND = "bonecontact growth checkpoint"
_NAME = re.compile(r"^step_(\d{8})$")
_TABLES = ("history.csv", "probes.csv")

Driver = CystSphereGrowth | CystShapeGrowth | TumourGrowth


# ----------------------------------------------------------------------------- ordering
def _space_keys(V: fem.FunctionSpace) -> npt.NDArray[np.int64]:
    """The input (mesh file) number of every owned dof block of the P1 space ``V``."""
    msh = V.mesh
    cells = V.dofmap.list
    gnodes = msh.geometry.dofmaps[0]
    if cells.shape != gnodes.shape:
        raise CheckpointError("checkpoints need a P1 space on a P1 mesh")
    nblocks = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    keys = np.full(nblocks, -1, dtype=np.int64)
    inp = np.asarray(msh.geometry.input_global_indices, dtype=np.int64)
    keys[cells.ravel()] = inp[gnodes.ravel()]
    return keys[: V.dofmap.index_map.size_local]


class InputOrder:
    """Moves per-entity arrays between this rank's owned entities and the input order.

    The input order numbers the nodes as the mesh file does
    (``mesh.geometry.input_global_indices``); it is the same for any partition.

    Parameters
    ----------
    V
        A P1 vector space on a mesh with P1 geometry (node = dof block); or ``None`` with
        ``comm`` and ``keys`` (:meth:`of_keys`).
    comm, keys
        The communicator and the position in the file of each owned entity.
    """

    def __init__(
        self,
        V: fem.FunctionSpace | None = None,
        *,
        comm: MPI.Comm | None = None,
        keys: npt.ArrayLike | None = None,
    ):
        if V is not None:
            comm, keys = V.mesh.comm, _space_keys(V)
        self.comm = comm
        self.keys = np.asarray(keys, dtype=np.int64)
        self.n_owned = len(self.keys)
        self.num_nodes = int(self.comm.allreduce(int(self.keys.max(initial=-1)), op=MPI.MAX)) + 1
        self._scatters: dict[int, tuple[PETSc.Scatter, PETSc.Vec, PETSc.Vec]] = {}

    @classmethod
    def of_keys(cls, comm: MPI.Comm, keys: npt.ArrayLike) -> InputOrder:
        """The order given by ``keys``: the position in the file of each owned entity
        (e.g. the original index of each owned cell); keys are unique over the ranks."""
        return cls(comm=comm, keys=keys)

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
        """A vector in input order (named ``name``) from the owned entities' values."""
        sc, x, y = self._scatter(ncomp)
        x.array[:] = np.asarray(owned, dtype=float).ravel()
        out = y.duplicate()
        out.set(0.0)
        sc.scatter(x, out, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)
        out.setName(name)
        return out

    def from_input(self, vec: PETSc.Vec, ncomp: int) -> npt.NDArray[np.float64]:
        """The owned entities' values, ``(n_owned, ncomp)``, of a vector in input order."""
        sc, x, _ = self._scatter(ncomp)
        sc.scatter(vec, x, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.REVERSE)
        return x.array.reshape(self.n_owned, ncomp).copy()

    def empty(self, ncomp: int, name: str) -> PETSc.Vec:
        """A vector in input order to load the dataset ``name`` into."""
        vec = self._scatter(ncomp)[2].duplicate()
        vec.setName(name)
        return vec

    def write(self, viewer: PETSc.Viewer, name: str, ncomp: int, owned: npt.ArrayLike) -> None:
        """Write the owned values as the dataset ``name`` in input order (collective)."""
        vec = self.to_input(owned, ncomp, name)
        vec.view(viewer)
        vec.destroy()

    def read(self, viewer: PETSc.Viewer, name: str, ncomp: int) -> npt.NDArray[np.float64]:
        """The owned values, ``(n_owned, ncomp)``, of the dataset ``name`` (collective)."""
        vec = self.empty(ncomp, name)
        vec.load(viewer)
        out = self.from_input(vec, ncomp)
        vec.destroy()
        return out

    def destroy(self) -> None:
        for sc, x, y in self._scatters.values():
            for obj in (sc, x, y):
                obj.destroy()
        self._scatters.clear()


def _owned_coordinates(V: fem.FunctionSpace) -> npt.NDArray[np.float64]:
    """Coordinates of the owned dof blocks of the P1 space ``V``, ``(n_owned, gdim)``."""
    msh = V.mesh
    gdim = msh.geometry.dim
    n = V.dofmap.index_map.size_local
    xy = np.zeros((n + V.dofmap.index_map.num_ghosts, gdim))
    xy[V.dofmap.list.ravel()] = msh.geometry.x[msh.geometry.dofmaps[0].ravel(), :gdim]
    return xy[:n]


# ----------------------------------------------------------------------------- files
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


def _jsonable(o: object) -> Any:
    """meta.json of NumPy scalars and arrays and of paths."""
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"cannot store {type(o).__name__} in a checkpoint")


def _plain(entries: dict[str, Any]) -> dict[str, Any]:
    """``entries`` as plain JSON values (what meta.json reads back)."""
    return json.loads(json.dumps(entries, default=_jsonable))


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


# ----------------------------------------------------------------------------- writing
def _header(kind: str, step: int, t: float, comm: MPI.Comm) -> dict[str, Any]:
    """The meta.json entries every checkpoint has."""
    return {
        "format": FORMAT_VERSION,
        "kind": kind,
        "bonecontact_version": __version__,
        "step": int(step),
        "time": float(t),
        "ranks": comm.size,
    }


def _publish(tmp: Path, final: Path, meta: dict[str, Any]) -> str:
    """Rank 0: flush the files of ``tmp``, write meta.json with the checksum of state.h5,
    rename ``tmp`` to ``final`` and prune the older checkpoints."""
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
    _fsync(final.parent)
    _prune(final.parent)
    return str(final)


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
    try:
        return Path(on_root(comm, lambda: _publish(tmp, final, meta)))
    except CheckpointError as exc:
        on_root(comm, lambda: shutil.rmtree(tmp, ignore_errors=True))
        raise CheckpointError(f"cannot write checkpoint {final}: {exc}") from None


def _prune(root: Path) -> None:
    """Keep the newest :data:`KEEP` complete checkpoints; remove stale temporaries."""
    done = sorted(p for p in root.iterdir() if _NAME.match(p.name))
    for old in done[:-KEEP]:
        shutil.rmtree(old, ignore_errors=True)
    for p in root.iterdir():
        if p.name.startswith(".step_") and p.name.endswith(".tmp"):
            shutil.rmtree(p, ignore_errors=True)


# ----------------------------------------------------------------------------- finding
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


def _newest_intact(root: Path) -> tuple[str, dict, list[str]]:
    """Rank 0: the newest intact checkpoint in ``root``, its meta.json and the messages of
    the damaged newer ones (another format number is an error at once)."""
    cands = sorted(
        (p for p in root.iterdir() if _NAME.match(p.name)) if root.is_dir() else [],
        reverse=True,
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
            return str(named), _verify(Path(named)), []
        return _newest_intact(checkpoint_dir(output))

    path, meta, skipped = on_root(comm, search)
    if comm.rank == 0:
        for msg in skipped:
            warnings.warn(f"{msg}; using an older checkpoint", UserWarning, stacklevel=2)
    return Path(path), meta


# ----------------------------------------------------------------------------- tables
def _cut_table(path: Path, keep: Callable[[list[list[str]]], list[list[str]]]) -> None:
    """Rank 0: replace the table ``path`` by ``keep(rows)`` (header included), atomically."""
    if not path.is_file():
        raise CheckpointError(f"{path} is missing: cannot append to it")
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    kept = keep(rows)
    tmp = path.with_suffix(".csv.tmp")
    with open(tmp, "w", newline="") as f:
        csv.writer(f).writerows(kept)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _upto_step(path: Path, step: int, col: int, exact: bool) -> Callable:
    """The rows of steps ≤ ``step`` (column ``col``); ``exact``: the table must reach it."""

    def keep(rows: list[list[str]]) -> list[list[str]]:
        kept = [rows[0]] + [r for r in rows[1:] if r and int(r[col]) <= step]
        if exact and int(kept[-1][col] if len(kept) > 1 else -1) != step:
            raise CheckpointError(
                f"{path} has no rows of step {step} (the checkpoint is newer than the "
                "table): cannot continue it without missing rows"
            )
        return kept

    return keep


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
            if path.is_file() or name == "history.csv":
                _cut_table(path, _upto_step(path, step, 0, exact=True))

    on_root(comm, trim)


def trim_fracture_table(
    output: Path,
    step: int,
    comm: MPI.Comm,
    increments: int = 0,
    columns: tuple[str, ...] = FRACTURE_COLUMNS,
) -> None:
    """Cut fracture.csv after the rows of ``step`` and the rows of the next step on fewer
    than ``increments`` crack increments (a checkpoint between the fatigue blocks of a
    step; rank 0; collective).  ``columns``: the table's (a 3D crack's has no
    ``increment``).

    Raises
    ------
    CheckpointError
        If fracture.csv is missing.
    """
    path = Path(output) / "fracture.csv"
    col = columns.index("step")
    inc = columns.index("increment") if "increment" in columns else None
    upto = _upto_step(path, step, col, exact=False)

    def keep(rows: list[list[str]]) -> list[list[str]]:
        if inc is None:
            return upto(rows)
        within = [r for r in rows[1:] if r and int(r[col]) == step + 1 and int(r[inc]) < increments]
        return upto(rows) + within

    on_root(comm, lambda: _cut_table(path, keep))


def trim_rows(path: Path, rows: int, comm: MPI.Comm) -> None:
    """Keep the header and the first ``rows`` rows of the table ``path`` (rank 0; collective).

    For tables with one row per step and no step column (growth.csv: row k is step k).

    Raises
    ------
    CheckpointError
        If the table is missing or has fewer rows (rows would be missing).
    """

    def keep(table: list[list[str]]) -> list[list[str]]:
        if len(table) - 1 < rows:
            raise CheckpointError(
                f"{path} has {len(table) - 1} rows, the checkpoint needs {rows} (the checkpoint "
                "is newer than the table): cannot continue it without missing rows"
            )
        return table[: rows + 1]

    on_root(comm, lambda: _cut_table(Path(path), keep))


# ----------------------------------------------------------------------------- the protocol
class RunState(Protocol):
    """What a run kind saves in a checkpoint and restores from one.

    ``kind`` goes into meta.json and must match on restart (``label`` words the refusal:
    ``"a mechanics run's"``); ``comm`` is the run's communicator.
    """

    kind: str
    label: str
    comm: MPI.Comm

    def position(self) -> tuple[int, float]:
        """The step and time the state is at."""
        ...

    def write(self, tmp: Path) -> None:
        """Write ``state.h5`` (and ``mesh.vtkhdf``) into ``tmp`` (collective)."""
        ...

    def scalars(self) -> dict[str, Any]:
        """The state's meta.json entries (plain JSON values)."""
        ...

    def read(self, path: Path, meta: dict[str, Any]) -> None:
        """Restore the state from the checkpoint ``path`` (collective)."""
        ...

    def trim(self, output: Path, step: int) -> None:
        """Cut the run's tables after ``step`` (collective)."""
        ...


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

    def as_meta(self) -> dict[str, Any]:
        """The ``counters`` entry of meta.json."""
        return {
            "linear": self.linear,
            "pdas": self.pdas,
            "bound_updates": self.bound_updates,
            "e0": self.e0,
            "fields_written": self.fields_written,
            "segment": self.segment,
        }

    @classmethod
    def from_meta(cls, c: dict[str, Any]) -> RunCounters:
        """The counters of a meta.json ``counters`` entry."""
        return cls(
            list(c["linear"]),
            list(c["pdas"]),
            list(c["bound_updates"]),
            float(c["e0"]),
            int(c["fields_written"]),
            int(c["segment"]),
        )


# ----------------------------------------------------------------------------- mechanics state
#: contact warm-start fields a checkpoint may lack (written since the warm-started
#: friction state; without them the friction state restarts cold)
OPTIONAL_CONTACT_FIELDS = ("_stick", "_lam_t", "_xi")


def contact_fields(bs: int) -> tuple[tuple[str, int], ...]:
    """(key, components) of the per-node contact warm start in a checkpoint."""
    t = bs - 1
    return (("active", 1), ("directions", t), ("lam_n_prev", 1), ("stick", 1), ("lam_t", t),
            ("xi", t))  # fmt: skip


def _read_fields(viewer, order, fields: list) -> dict[str, npt.NDArray]:
    """The per-node fields ``(name, ncomp, _)`` from ``viewer`` (collective); an
    optional contact field missing from an older checkpoint is left out."""
    new = {}
    for name, ncomp, _ in fields:
        try:
            new[name] = order.read(viewer, name, ncomp)
        except PETSc.Error:
            if not name.endswith(OPTIONAL_CONTACT_FIELDS):
                raise
    return new


def _fields(integ: Integrator, st: dict) -> list[tuple[str, int, npt.NDArray]]:
    """(name, ncomp, owned values) of every per-node field of the state."""
    bs = integ.model.V.dofmap.index_map_bs
    n = integ.model.V.dofmap.index_map.size_local
    out = [(name, bs, st[name]) for name in ("u_n", "u_nm1", "velocity")]
    c = st.get("contact")
    if c is None:
        return out
    out.append(("Uh", bs, c["Uh"]))
    for k, itf in enumerate(integ.contact.interfaces):
        for key, ncomp in contact_fields(bs):
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


def _write_state(path: Path, integ: Integrator) -> None:
    """The per-node fields of the state, in input order, into ``path`` (collective)."""
    order = InputOrder(integ.model.V)
    st = integ.state()
    gdim = integ.model.mesh.geometry.dim
    viewer = PETSc.Viewer().createHDF5(str(path), "w", comm=integ.model.mesh.comm)
    try:
        order.write(viewer, "coordinates", gdim, _owned_coordinates(integ.model.V))
        for name, ncomp, values in _fields(integ, st):
            order.write(viewer, name, ncomp, values)
    finally:
        viewer.destroy()
        order.destroy()


def _mechanics_scalars(integ: Integrator, counters: RunCounters) -> dict[str, Any]:
    """meta.json entries of a mechanics state."""
    st = integ.state()
    return {
        "nodes": integ.model.V.dofmap.index_map.size_global,
        "pairs": [itf.name for itf in integ.contact.interfaces] if integ.contact else [],
        "contact_cold": st["contact"]["cold"] if st["contact"] is not None else None,
        "balance": st["balance"],
        "counters": counters.as_meta(),
    }


def write_checkpoint(
    output: Path, integ: Integrator, counters: RunCounters, info: dict[str, Any]
) -> Path:
    """Write the mechanics state after step ``integ.step_count`` atomically (collective).

    ``info``: further entries of meta.json (scene name, analysis kind, dt...; a ``kind``
    entry replaces :data:`KIND`).

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

    meta = {
        **_header(KIND, integ.step_count, integ.t, comm),
        **_mechanics_scalars(integ, counters),
        **info,
    }
    return save_checkpoint(output, integ.step_count, comm, files, meta)


def _check_mesh_matches(path: Path, meta: dict[str, Any], integ: Integrator) -> None:
    """The node count and contact pairs of the checkpoint are the scene's."""
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
    _check_mesh_matches(path, meta, integ)
    order = InputOrder(integ.model.V)
    st = integ.state()  # the layout to fill
    gdim = integ.model.mesh.geometry.dim
    viewer = PETSc.Viewer().createHDF5(str(path / "state.h5"), "r", comm=comm)
    try:
        saved = order.read(viewer, "coordinates", gdim)
        _check_coordinates(path, saved, _owned_coordinates(integ.model.V), comm)
        new = _read_fields(viewer, order, _fields(integ, st))
    finally:
        viewer.destroy()
        order.destroy()
    _fill_state(st, new, integ, meta)
    integ.restore_state(st)
    return RunCounters.from_meta(meta["counters"])


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
        if f"contact{k}_stick" in new:  # (older checkpoints: the friction state is cold)
            c["stick"][k] = new[f"contact{k}_stick"][itf.blocks, 0] > 0.5
            c["lam_t"][k] = new[f"contact{k}_lam_t"][itf.blocks]
            c["xi"][k] = new[f"contact{k}_xi"][itf.blocks]
        else:
            for key in ("stick", "lam_t", "xi"):
                c.pop(key, None)
        if c["work_gaps"]:
            c["work_gaps"][k] = new[f"contact{k}_work_gaps"][itf.blocks, 0]


class MechanicsState:
    """The state of a mechanics run: the integrator (fields, contact warm start) and the
    run's :class:`RunCounters`.

    Parameters
    ----------
    integ
        The run's integrator (after ``set_initial``).
    counters
        The counters (default: new ones starting from the integrator's energy).
    """

    kind = KIND
    label = "a mechanics run's"

    def __init__(self, integ: Integrator, counters: RunCounters | None = None):
        self.integ = integ
        self.comm = integ.model.mesh.comm
        self.counters = counters if counters is not None else RunCounters(e0=integ.balance.total)

    def position(self) -> tuple[int, float]:
        return int(self.integ.step_count), float(self.integ.t)

    def write(self, tmp: Path) -> None:
        _write_state(tmp / "state.h5", self.integ)
        vtkhdf.write_mesh(str(tmp / "mesh.vtkhdf"), self.integ.model.mesh)

    def scalars(self) -> dict[str, Any]:
        return _mechanics_scalars(self.integ, self.counters)

    def read(self, path: Path, meta: dict[str, Any]) -> None:
        """Restore the integrator and the counters (a new segment of the run)."""
        self.counters = read_checkpoint(path, meta, self.integ)
        self.counters.segment += 1

    def trim(self, output: Path, step: int) -> None:
        trim_tables(output, step, self.comm)


class CrackState(MechanicsState):
    """The state of a crack scene: a mechanics state on the mesh of the current crack
    (``integ``: set by the run whenever it builds an integrator) and fracture.csv; the
    crack itself is a run entry (``crack_run``) of meta.json.

    Parameters
    ----------
    comm
        The run's communicator.
    columns
        The columns of the run's fracture.csv.
    """

    kind = CRACK_KIND
    label = "a crack scene's"

    def __init__(self, comm: MPI.Comm, columns: tuple[str, ...] = FRACTURE_COLUMNS):
        self.comm = comm
        self.integ: Integrator | None = None
        self.counters = RunCounters()
        self.increments = 0  # crack increments of the checkpoint read (fatigue blocks)
        self.columns = tuple(columns)  # of fracture.csv (a 3D crack's: FRONT_COLUMNS)

    def position(self) -> tuple[int, float]:
        return (0, 0.0) if self.integ is None else super().position()

    def read(self, path: Path, meta: dict[str, Any]) -> None:
        """The mechanics state, and the crack increments made (fracture.csv keeps the rows
        of fewer increments of the step after the checkpoint's)."""
        super().read(path, meta)
        self.increments = int((meta.get("crack_run") or {}).get("increment", 0))

    def trim(self, output: Path, step: int) -> None:
        trim_tables(output, step, self.comm)
        trim_fracture_table(output, step, self.comm, self.increments, self.columns)


# ----------------------------------------------------------------------------- growth state
def _model_kind(driver: Driver) -> str:
    if isinstance(driver, TumourGrowth):
        return "tumour"
    if isinstance(driver, CystShapeGrowth):
        return "cyst_shape"
    return "cyst_sphere"


def _cells_order(msh: dmesh.Mesh) -> tuple[InputOrder, npt.NDArray[np.int32]]:
    """The order of gmsh's cells over the owned cells, and the owned cells."""
    n = msh.topology.index_map(msh.topology.dim).size_local
    keys = np.asarray(msh.topology.original_cell_index, dtype=np.int64)[:n]
    return InputOrder.of_keys(msh.comm, keys), np.arange(n, dtype=np.int32)


def _cell_nodes(msh: dmesh.Mesh, cells: npt.NDArray[np.int32]) -> npt.NDArray[np.float64]:
    """The input (gmsh) node numbers of ``cells``, as floats (exact below 2⁵³)."""
    inp = np.asarray(msh.geometry.input_global_indices, dtype=np.int64)
    return inp[msh.geometry.dofmaps[0][cells]].astype(np.float64)


def _is_cellwise(u: fem.Function) -> bool:
    return u.function_space.dofmap.list.shape[1] == 1


def _write_model_fields(viewer: PETSc.Viewer, driver: Driver, orders: list[InputOrder]) -> None:
    """The mesh (coordinates, cells) and fields of a growth model with a mesh (collective)."""
    msh = driver.model.mesh
    nodes = InputOrder(driver.model.motion.V)
    cells_order, cells = _cells_order(msh)
    orders += [nodes, cells_order]
    nodes.write(viewer, "coordinates", msh.geometry.dim, _owned_coordinates(driver.model.motion.V))
    cells_order.write(viewer, "cells", msh.topology.dim + 1, _cell_nodes(msh, cells))
    for name, u in driver.fields().items():
        if _is_cellwise(u):
            cells_order.write(viewer, name, 1, u.x.array[u.function_space.dofmap.list[cells, 0]])
            continue
        order = InputOrder(u.function_space)
        orders.append(order)
        bs = u.function_space.dofmap.index_map_bs
        n = u.function_space.dofmap.index_map.size_local
        order.write(viewer, name, bs, u.x.array[: n * bs])


def _write_growth_state(path: Path, driver: Driver, comm: MPI.Comm) -> None:
    """state.h5 of a growth model (collective)."""
    viewer = PETSc.Viewer().createHDF5(str(path), "w", comm=comm)
    orders: list[InputOrder] = []
    try:
        if isinstance(driver, CystSphereGrowth):
            order = InputOrder.of_keys(comm, [0, 1] if comm.rank == 0 else [])
            orders.append(order)
            order.write(viewer, "ode", 1, [driver.R, driver.f] if comm.rank == 0 else [])
        else:
            _write_model_fields(viewer, driver, orders)
    finally:
        viewer.destroy()
        for order in orders:
            order.destroy()


def _load_whole(path: Path, names: list[str]) -> dict[str, npt.NDArray[np.float64]]:
    """Whole datasets of ``path`` (rank 0 only, sequential)."""
    viewer = PETSc.Viewer().createHDF5(str(path), "r", comm=MPI.COMM_SELF)
    out = {}
    try:
        for name in names:
            vec = PETSc.Vec().create(comm=MPI.COMM_SELF)
            vec.setType("seq")
            vec.setName(name)
            vec.load(viewer)
            out[name] = vec.array.copy()
            vec.destroy()
    finally:
        viewer.destroy()
    return out


def _rebuild_mesh(path: Path, dim: int, comm: MPI.Comm) -> dmesh.Mesh:
    """The checkpoint's mesh, rebuilt as a remesh builds one (collective)."""
    cells = np.empty((0, dim + 1), dtype=np.int64)
    x = np.empty((0, dim))
    error = None
    if comm.rank == 0:
        try:
            data = _load_whole(path / "state.h5", ["cells", "coordinates"])
            cells = np.rint(data["cells"]).astype(np.int64).reshape(-1, dim + 1)
            x = data["coordinates"].reshape(-1, dim)
        except Exception as exc:  # reported collectively below
            error = f"{type(exc).__name__}: {exc}"
    error = comm.bcast(error, root=0)
    if error is not None:
        raise CheckpointError(f"checkpoint {path}: cannot read the mesh ({error})")
    return mesh_from_cells(comm, cells, x, dim)


def _read_model_fields(path: Path, driver: Driver, comm: MPI.Comm) -> None:
    """The fields of a growth model with a mesh, on its rebuilt mesh (collective)."""
    cells_order, cells = _cells_order(driver.model.mesh)
    orders = [cells_order]
    viewer = PETSc.Viewer().createHDF5(str(path / "state.h5"), "r", comm=comm)
    try:
        for name, u in driver.fields().items():
            if _is_cellwise(u):
                dofs = u.function_space.dofmap.list[cells, 0]
                u.x.array[dofs] = cells_order.read(viewer, name, 1)[:, 0]
            else:
                order = InputOrder(u.function_space)
                orders.append(order)
                bs = u.function_space.dofmap.index_map_bs
                n = u.function_space.dofmap.index_map.size_local
                u.x.array[: n * bs] = order.read(viewer, name, bs).ravel()
            u.x.scatter_forward()
    finally:
        viewer.destroy()
        for order in orders:
            order.destroy()


def read_growth_state(path: Path, meta: dict[str, Any], driver: Driver, comm: MPI.Comm) -> None:
    """Put the growth model of a checkpoint into ``driver`` (built from the same scene;
    collective)."""
    kind = _model_kind(driver)
    if meta.get("model") != kind:
        raise CheckpointError(
            f"checkpoint {path} holds a {meta.get('model')!r} growth model, the scene a {kind!r}"
        )
    if not isinstance(driver, CystSphereGrowth):
        driver.replace_mesh(_rebuild_mesh(path, driver.dim, comm))
        _read_model_fields(path, driver, comm)
    driver.restore_checkpoint_state(meta["model_state"])


class GrowthState:
    """The state of a growth-only or coupled run: the growth model (its mesh, as gmsh made
    it at the last remesh, its fields and scalars); growth.csv is continued.

    Parameters
    ----------
    driver
        The growth model (built from the scene).
    comm
        The run's communicator.
    """

    kind = GROWTH_KIND
    label = "a growth run's"

    def __init__(self, driver: Driver, comm: MPI.Comm):
        self.driver, self.comm = driver, comm

    def position(self) -> tuple[int, float]:
        return int(self.driver.steps), float(self.driver.t)

    def write(self, tmp: Path) -> None:
        _write_growth_state(tmp / "state.h5", self.driver, self.comm)
        if not isinstance(self.driver, CystSphereGrowth):
            vtkhdf.write_mesh(str(tmp / "mesh.vtkhdf"), self.driver.model.mesh)

    def scalars(self) -> dict[str, Any]:
        return {"model": _model_kind(self.driver), "model_state": self.driver.checkpoint_state()}

    def read(self, path: Path, meta: dict[str, Any]) -> None:
        read_growth_state(path, meta, self.driver, self.comm)

    def trim(self, output: Path, step: int) -> None:
        trim_rows(Path(output) / "growth.csv", step + 1, self.comm)


def _write(output: Path, state: RunState, entries: dict[str, Any]) -> Path:
    """Write the checkpoint of ``state`` with the run's meta.json ``entries`` (collective)."""
    step, t = state.position()
    meta = {**_header(state.kind, step, t, state.comm), **state.scalars(), **entries}
    return save_checkpoint(output, step, state.comm, state.write, meta)


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
def checkpoint_summary(ck: Checkpointer) -> dict[str, Any]:
    """The summary.json entries of a run's checkpointer: ``checkpoints``, after a restart
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
    """A run's checkpoints, for every run kind: restart, periodic writes, the stop on a
    signal.

    Parameters
    ----------
    output
        The run's output directory.
    state
        What the run saves (:class:`MechanicsState`, :class:`CrackState`,
        :class:`GrowthState`).
    every
        Write a checkpoint every this many steps (0: only when stopped by a signal).
    info
        Entries that must agree between a checkpoint and the run continuing it
        (scene name, analysis or run kind, dt...).
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
        state: RunState,
        every: int,
        info: dict[str, Any],
        interval: float = 0.0,
        on_signal: bool = True,
    ):
        self.output, self.state, self.every = Path(output), state, int(every)
        self.comm = state.comm
        self.info = dict(info)
        self.on_signal = bool(on_signal)
        self.schedule = CheckpointSchedule(every, interval, state.position()[1])
        #: further meta.json entries: name -> a function giving its JSON value at a write
        self.extra: dict[str, Callable[[], Any]] = {}
        #: the meta.json of the checkpoint the run continues from (after :meth:`resume`)
        self.resumed: dict[str, Any] = {}
        self.stop = StopRequest()
        self.restarted_from: dict[str, Any] | None = None
        self.last: Path | None = None
        self.written = 0
        self.time_s = 0.0
        self.signum = 0

    @property
    def counters(self) -> RunCounters:
        """The counters of a mechanics or crack state (``state.counters``)."""
        return self.state.counters

    @property
    def fields_stem(self) -> str:
        """Field files of this segment: ``fields`` (first run), ``fields_restart<n>`` after."""
        counters = getattr(self.state, "counters", None)
        seg = 0 if counters is None else counters.segment
        return "fields" if seg == 0 else f"fields_restart{seg}"

    def find(self, named: str | Path | bool | None) -> tuple[Path, dict[str, Any]]:
        """The checkpoint to continue from (``named``: that directory; ``None``/``True``:
        the newest intact one) and its meta.json, checked against the run: format,
        checksum, kind and every entry of ``info`` (collective; nothing is changed).

        Raises
        ------
        CheckpointError
            On every rank.
        """
        which = None if named is None or isinstance(named, bool) else Path(named)
        path, meta = find_checkpoint(self.output, self.comm, which)
        if meta.get("kind") != self.state.kind:
            raise CheckpointError(
                f"checkpoint {path} is a {meta.get('kind')!r}, not {self.state.label}: "
                "a restart continues the same scene"
            )
        for key, value in self.info.items():
            if meta.get(key) != value:
                raise CheckpointError(
                    f"checkpoint {path} has {key} = {meta.get(key)!r}, the scene {value!r}: "
                    "a restart continues the same scene"
                )
        return path, meta

    def continue_from(self, path: Path, meta: dict[str, Any]) -> dict[str, Any]:
        """Restore the state from the checkpoint ``path`` (found by :meth:`find`), cut the
        tables after its step and note the restart (collective).  Returns ``meta``."""
        self.state.read(path, meta)
        step = int(meta["step"])
        self.state.trim(self.output, step)
        self.resumed = meta
        self.schedule.t_last = float(meta["time"])
        self.restarted_from = {
            "checkpoint": str(path),
            "step": step,
            "time": float(meta["time"]),
            "ranks": int(meta["ranks"]),
        }
        self.last = path
        return meta

    def resume(self, named: str | Path | bool | None) -> dict[str, Any]:
        """Continue from the newest (or the named) checkpoint: :meth:`find`, then
        :meth:`continue_from` (collective).

        Returns
        -------
        dict
            The checkpoint's meta.json (the run's further entries).

        Raises
        ------
        CheckpointError
            On every rank, before any file is changed.
        """
        return self.continue_from(*self.find(named))

    def after_step(self, last: bool = False, scalars: dict[str, Any] | None = None) -> int:
        """Between steps (collective): write a checkpoint when one is due
        (:class:`CheckpointSchedule`) or a signal came; ``scalars``: further meta.json
        entries of this write.  Returns the signal number (0: go on)."""
        self.signum = max(self.signum, self.stop.agreed(self.comm))
        step, t = self.state.position()
        due = self.schedule.due(step, t, last)
        if (self.signum and self.on_signal) or due:
            self.write(scalars)
        return self.signum

    def write(self, scalars: dict[str, Any] | None = None) -> Path:
        """Write a checkpoint of the current state now (collective)."""
        t0 = time.perf_counter()
        entries = {name: get() for name, get in self.extra.items()}
        entries = _plain({**entries, **(scalars or {})})
        self.last = _write(self.output, self.state, {**entries, **self.info})
        self.time_s += time.perf_counter() - t0
        self.written += 1
        return self.last

    def summary(self) -> dict[str, Any]:
        """The summary.json entries: ``checkpoints``, after a restart ``restarted_from``,
        after a signal ``signal``."""
        return checkpoint_summary(self)
