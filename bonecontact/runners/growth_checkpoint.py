"""Transitional: the former growth-run checkpointer, now
:class:`~bonecontact.runners.checkpoint.Checkpointer` with a
:class:`~bonecontact.runners.checkpoint.GrowthState` (docs/checkpoint.md).

Kept only until the runners call the one checkpoint module directly; no logic lives here.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mpi4py import MPI

from bonecontact.runners.checkpoint import (
    GROWTH_KIND as KIND,
)
from bonecontact.runners.checkpoint import (
    Checkpointer,
    Driver,
    GrowthState,
    read_growth_state,
    write_growth_checkpoint,
)

__all__ = ["KIND", "GrowthCheckpointer", "read_growth_state", "write_growth_checkpoint"]


class GrowthCheckpointer(Checkpointer):
    """``Checkpointer(output, GrowthState(driver, comm), every, info, interval)``."""

    def __init__(
        self,
        output: Path,
        driver: Driver,
        comm: MPI.Comm,
        every: int,
        info: dict[str, Any],
        interval: float = 0.0,
    ):
        super().__init__(output, GrowthState(driver, comm), every, info, interval)
