"""Transitional: the former crack-scene checkpoints, now
:class:`~bonecontact.runners.checkpoint.Checkpointer` with a
:class:`~bonecontact.runners.checkpoint.CrackState` (docs/checkpoint.md).

Kept only until the crack runner calls the one checkpoint module directly; no logic lives
here: :meth:`CrackCheckpoints.resumed` is :meth:`Checkpointer.restored` (the caller has
read the state with :func:`~bonecontact.runners.checkpoint.read_checkpoint`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mpi4py import MPI

from bonecontact.mechanics.integrator import Integrator
from bonecontact.runners.checkpoint import CRACK_KIND as KIND
from bonecontact.runners.checkpoint import (
    Checkpointer,
    CrackState,
    RunCounters,
    trim_fracture_table,
)

__all__ = ["KIND", "CrackCheckpoints", "trim_fracture_table"]


class CrackCheckpoints:
    """The former interface over ``Checkpointer(output, CrackState(comm), every, info,
    interval)`` (:attr:`checkpointer`)."""

    def __init__(
        self, output: Path, comm: MPI.Comm, every: int, interval: float, info: dict[str, Any]
    ):
        self.checkpointer = Checkpointer(output, CrackState(comm), every, info, interval)
        self.stop = self.checkpointer.stop

    def find(self, named: str | Path | bool) -> tuple[Path, dict[str, Any]]:
        """:meth:`Checkpointer.find`."""
        return self.checkpointer.find(named)

    def resumed(self, path: Path, meta: dict[str, Any]) -> None:
        """:meth:`Checkpointer.restored`."""
        self.checkpointer.restored(path, meta)

    def after_step(
        self, integ: Integrator, counters: RunCounters, state: dict[str, Any], last: bool
    ) -> int:
        """:meth:`Checkpointer.after_step` of this integrator and counters, with the
        ``crack_run`` entry ``state``."""
        self.checkpointer.state.integ = integ
        self.checkpointer.state.counters = counters
        return self.checkpointer.after_step(last, {"crack_run": state})

    def summary(self) -> dict[str, Any]:
        """:meth:`Checkpointer.summary`."""
        return self.checkpointer.summary()
