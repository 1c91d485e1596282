"""Restart checkpoints of crack scenes (``[[crack]]`` or ``[fracture] initiate = true``;
docs/checkpoint.md).

A crack checkpoint is a mechanics checkpoint
(:func:`bonecontact.runners.checkpoint.write_checkpoint`: the same directories, atomic
writer, format number, ``state.h5`` with the fields and the contact solver's warm start
in input order, ``mesh.vtkhdf``), written between load steps on the mesh of the current
crack.  Its meta.json has ``kind`` :data:`KIND` and a ``crack_run`` entry: whether the
crack was initiated and the initiation record (the initiated crack sets the tip mesh),
the current crack (polyline points and tips; ``None`` before an initiation), the
increment counter, the propagation status, the tips of the last evaluation, the risk
summary of the uncracked body and the risk monitor's maxima.

A restart rebuilds the body meshed around the stored crack with the same gmsh call as
the run (deterministic: the node coordinates are checked against the stored ones to
1e-12 of the mesh size), restores the integrator, cuts history.csv, probes.csv and
fracture.csv after the checkpoint's step and continues with the next step.  Growth
increments inside a step are not checkpointed: a run stopped during a step repeats that
step from the crack at its start.
"""

from __future__ import annotations

import csv
import os
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

from bonecontact.fracture.propagation import FRACTURE_COLUMNS
from bonecontact.mechanics.integrator import Integrator
from bonecontact.runners.checkpoint import (
    CheckpointError,
    CheckpointSchedule,
    RunCounters,
    StopRequest,
    checkpoint_summary,
    find_checkpoint,
    on_root,
    trim_tables,
    write_checkpoint,
)

__all__ = ["KIND", "CrackCheckpoints", "trim_fracture_table"]

#: The ``kind`` of a crack scene's checkpoint meta.json.
KIND = "bonecontact crack checkpoint"


def trim_fracture_table(output: Path, step: int, comm: MPI.Comm) -> None:
    """Cut fracture.csv after the rows of ``step`` (rank 0; collective).

    Raises
    ------
    CheckpointError
        If fracture.csv is missing.
    """
    col = FRACTURE_COLUMNS.index("step")

    def trim() -> None:
        path = Path(output) / "fracture.csv"
        if not path.is_file():
            raise CheckpointError(f"{path} is missing: cannot append to it")
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
        keep = [rows[0]] + [r for r in rows[1:] if r and int(r[col]) <= step]
        tmp = path.with_suffix(".csv.tmp")
        with open(tmp, "w", newline="") as f:
            csv.writer(f).writerows(keep)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)

    on_root(comm, trim)


class CrackCheckpoints:
    """A crack scene's checkpoints: finding the one to continue from, periodic writes
    between load steps, the stop on a signal.

    Parameters
    ----------
    output
        The run's output directory.
    comm
        The run's communicator.
    every
        Steps between checkpoints (``[output] checkpoint_every``; 0: none).
    interval
        Simulated time between checkpoints, s (``[output] checkpoint_time``; 0: none).
    info
        Entries a checkpoint and the run continuing it must agree on.
    """

    def __init__(
        self, output: Path, comm: MPI.Comm, every: int, interval: float, info: dict[str, Any]
    ):
        self.output, self.comm, self.every = Path(output), comm, int(every)
        self.schedule = CheckpointSchedule(every, interval, 0.0)
        self.info = dict(info)
        self.stop = StopRequest()
        self.restarted_from: dict[str, Any] | None = None
        self.last: Path | None = None
        self.written = 0
        self.time_s = 0.0
        self.signum = 0

    def find(self, named: str | Path | bool) -> tuple[Path, dict[str, Any]]:
        """The checkpoint to continue from (the newest, or the named one) and its
        meta.json, checked against the scene (collective; nothing is changed).

        Raises
        ------
        CheckpointError
            On every rank.
        """
        path, meta = find_checkpoint(
            self.output, self.comm, None if named is True or not named else Path(named)
        )
        if meta.get("kind") != KIND:
            raise CheckpointError(
                f"checkpoint {path} is a {meta.get('kind')!r}, not a crack scene's: "
                "a restart continues the same scene"
            )
        for key, value in self.info.items():
            if meta.get(key) != value:
                raise CheckpointError(
                    f"checkpoint {path} has {key} = {meta.get(key)!r}, the scene {value!r}: "
                    "a restart continues the same scene"
                )
        return path, meta

    def resumed(self, path: Path, meta: dict[str, Any]) -> None:
        """After the integrator is restored: cut the tables after the checkpoint's step
        (collective)."""
        step = int(meta["step"])
        trim_tables(self.output, step, self.comm)
        trim_fracture_table(self.output, step, self.comm)
        self.schedule.t_last = float(meta["time"])
        self.restarted_from = {
            "checkpoint": str(path),
            "step": step,
            "time": float(meta["time"]),
            "ranks": int(meta["ranks"]),
        }
        self.last = path

    def after_step(
        self, integ: Integrator, counters: RunCounters, state: dict[str, Any], last: bool
    ) -> int:
        """Between load steps (collective): write a checkpoint when one is due or a signal
        came; ``state``: the ``crack_run`` entry of meta.json.  Returns the signal number
        (0: go on)."""
        self.signum = self.stop.agreed(self.comm)
        due = self.schedule.due(integ.step_count, integ.t, last)
        if self.signum or due:
            t0 = time.perf_counter()
            info = {**self.info, "kind": KIND, "crack_run": state}
            self.last = write_checkpoint(self.output, integ, counters, info)
            self.time_s += time.perf_counter() - t0
            self.written += 1
        return self.signum

    def summary(self) -> dict[str, Any]:
        """The summary.json entries: ``checkpoints``, after a restart ``restarted_from``,
        after a signal ``signal``."""
        return checkpoint_summary(self)
