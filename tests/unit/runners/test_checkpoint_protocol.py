"""The one checkpoint protocol (bonecontact.runners.checkpoint.Checkpointer) with a minimal
run state, on any number of ranks: the path every run kind takes, apart from its fields.

The state is one number that changes every step (x_k = 1/(k+1), exact in binary only by
accident: it goes through state.h5 bit for bit or the test fails) and a table with one row
per step.  Families over the checkpoint interval and the step a run is stopped after:

* the steps written are those of the schedule (every N-th and the last), the newest
  :data:`KEEP` are kept;
* resuming from the newest (or a named) checkpoint gives the state of that step, cuts the
  table after it and records where the run continued from; continuing to the end gives
  the table of an uninterrupted run;
* a checkpoint of another kind or with another agreed entry is refused on every rank with
  a message naming both, before the table is touched.
"""

from __future__ import annotations

import csv
import struct
from pathlib import Path
from typing import Any

from mpi4py import MPI

import pytest

from bonecontact.runners.checkpoint import (
    KEEP,
    Checkpointer,
    CheckpointError,
    on_root,
    trim_rows,
)

N_STEPS = 7


class Counter:
    """A run state of one number x_k = 1/(k+1) and a table of one row per step."""

    label = "a counter run's"

    def __init__(self, comm: MPI.Comm, output: Path, kind: str = "test counter"):
        self.comm, self.output, self.kind = comm, output, kind
        self.step, self.t, self.x = 0, 0.0, 1.0

    def advance(self) -> None:
        self.step += 1
        self.t = 0.25 * self.step
        self.x = 1.0 / (self.step + 1)
        if self.comm.rank == 0:
            with open(self.output / "table.csv", "a", newline="") as f:
                csv.writer(f).writerow([self.step, repr(self.x)])

    def position(self) -> tuple[int, float]:
        return self.step, self.t

    def write(self, tmp: Path) -> None:
        if self.comm.rank == 0:
            (tmp / "state.h5").write_bytes(struct.pack("<d", self.x))

    def scalars(self) -> dict[str, Any]:
        return {"x_copy": self.x}

    def read(self, path: Path, meta: dict[str, Any]) -> None:
        raw = on_root(self.comm, lambda: (path / "state.h5").read_bytes())
        self.x = struct.unpack("<d", raw)[0]
        self.step, self.t = int(meta["step"]), float(meta["time"])

    def trim(self, output: Path, step: int) -> None:
        trim_rows(output / "table.csv", step + 1, self.comm)


def _start(path: Path, kind: str = "test counter") -> Counter:
    state = Counter(MPI.COMM_WORLD, path, kind)
    if state.comm.rank == 0:
        with open(path / "table.csv", "w", newline="") as f:
            csv.writer(f).writerows([["step", "x"], [0, repr(1.0)]])
    state.comm.barrier()
    return state


def _run(ck: Checkpointer, state: Counter, stop_after: int | None) -> None:
    while state.step < N_STEPS:
        state.advance()
        ck.after_step(state.step == N_STEPS, {"run_entry": [state.step, "s"]})
        if state.step == stop_after:
            return


def _table(path: Path) -> list[list[str]]:
    """The table as every rank reads it (collective: rank 0 appends to it)."""
    MPI.COMM_WORLD.barrier()
    with open(path / "table.csv", newline="") as f:
        rows = list(csv.reader(f))
    MPI.COMM_WORLD.barrier()
    return rows


@pytest.mark.parametrize("every", [1, 2, 3])
@pytest.mark.parametrize("stop_after", [3, 5, 6])
def test_stop_resume_continue_equals_uninterrupted(tmp_shared_path, every, stop_after):
    ref_dir, out = tmp_shared_path / "ref", tmp_shared_path / "out"
    for d in (ref_dir, out):
        on_root(MPI.COMM_WORLD, lambda d=d: d.mkdir())
    ref = _start(ref_dir)
    _run(Checkpointer(ref_dir, ref, every, {"scene": "counter"}), ref, None)

    state = _start(out)
    ck = Checkpointer(out, state, every, {"scene": "counter"})
    _run(ck, state, stop_after)
    due = [k for k in range(1, stop_after + 1) if k % every == 0]
    kept = sorted(p.name for p in (out / "checkpoints").iterdir())
    assert kept == [f"step_{k:08d}" for k in due[-KEEP:]]
    assert ck.written == len(due)

    # a new process: a fresh state (as built from the scene), resumed from the newest
    state = Counter(state.comm, out)
    ck = Checkpointer(out, state, every, {"scene": "counter"})
    meta = ck.resume(None)
    assert state.step == due[-1] and state.x == 1.0 / (due[-1] + 1)
    assert meta["x_copy"] == state.x and meta["run_entry"] == [due[-1], "s"]
    assert ck.restarted_from == {
        "checkpoint": str(out / "checkpoints" / f"step_{due[-1]:08d}"),
        "step": due[-1],
        "time": 0.25 * due[-1],
        "ranks": MPI.COMM_WORLD.size,
    }
    assert [int(r[0]) for r in _table(out)[1:]] == list(range(due[-1] + 1))
    _run(ck, state, None)
    assert _table(out) == _table(ref_dir)
    assert ck.summary()["restarted_from"]["step"] == due[-1]


def test_named_checkpoint_and_refusals(tmp_shared_path):
    comm = MPI.COMM_WORLD
    state = _start(tmp_shared_path)
    _run(Checkpointer(tmp_shared_path, state, 2, {"scene": "counter"}), state, 5)
    older = tmp_shared_path / "checkpoints" / "step_00000002"
    before = _table(tmp_shared_path)

    other_kind = Checkpointer(tmp_shared_path, Counter(comm, tmp_shared_path, "x"), 2, {})
    with pytest.raises(CheckpointError, match="is a 'test counter', not a counter run's"):
        other_kind.resume(None)
    other_scene = Checkpointer(tmp_shared_path, Counter(comm, tmp_shared_path), 2, {"scene": "b"})
    with pytest.raises(CheckpointError, match="has scene = 'counter', the scene 'b'"):
        other_scene.resume(older)
    assert _table(tmp_shared_path) == before  # nothing changed

    fresh = Counter(comm, tmp_shared_path)
    ck = Checkpointer(tmp_shared_path, fresh, 2, {"scene": "counter"})
    path, meta = ck.find(older)  # validated, nothing changed yet
    assert path == older and meta["step"] == 2 and _table(tmp_shared_path) == before
    ck.continue_from(path, meta)
    assert fresh.step == 2 and fresh.x == 1.0 / 3.0
    assert [int(r[0]) for r in _table(tmp_shared_path)[1:]] == [0, 1, 2]
