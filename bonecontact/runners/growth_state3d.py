"""Checkpoints of a growing 3D crack (surface cracks, interior cracks; docs/checkpoint.md).

A growing 3D crack is re-meshed and solved from scratch at every increment, so its state
between increments is small: the crack to solve next, the increment and cycle counts,
the fatigue history, the growth history and the number of ``fracture.csv`` rows written.
After every ``checkpoint_every``-th increment rank 0 writes it as JSON (floats as
``repr``: they read back exactly) to ``checkpoints/increment_<k>/growth.json``, atomically;
a restart reads the newest (or a named) one on rank 0, cuts ``fracture.csv`` to its rows
and continues with increment k, on any number of ranks (the gmsh mesh of a crack is the
same on every rank count).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np

from bonecontact.common.errors import CheckpointError
from bonecontact.runners.checkpoint import on_root, trim_rows

__all__ = ["check_initial", "find_growth_state", "save_growth_state"]

STATE_FILE = "growth.json"


def save_growth_state(comm: MPI.Comm, outdir: Path, increment: int, state: dict[str, Any]) -> None:
    """Write ``state`` as ``outdir/checkpoints/increment_<increment>/growth.json`` (rank
    0, atomically; collective)."""

    def write() -> None:
        d = Path(outdir) / "checkpoints" / f"increment_{increment:05d}"
        d.mkdir(parents=True, exist_ok=True)
        tmp = d / (STATE_FILE + ".tmp")
        tmp.write_text(json.dumps({"increment": increment, **state}, indent=1))
        os.replace(tmp, d / STATE_FILE)

    on_root(comm, write)


def _read(restart: str | Path | bool, outdir: Path) -> tuple[str, dict[str, Any]]:
    if restart is True:
        found = sorted((Path(outdir) / "checkpoints").glob(f"increment_*/{STATE_FILE}"))
        if not found:
            raise CheckpointError(f"no growth checkpoint under {Path(outdir) / 'checkpoints'}")
        path = found[-1]
    else:
        path = Path(restart)
        path = path / STATE_FILE if path.is_dir() else path
        if not path.is_file():
            raise CheckpointError(f"{path} is not a growth checkpoint ({STATE_FILE})")
    return str(path), json.loads(path.read_text())


def find_growth_state(
    comm: MPI.Comm,
    outdir: Path,
    restart: str | Path | bool,
    kind: str,
    initial: dict[str, Any],
    size: float,
) -> dict[str, Any]:
    """The state of the checkpoint to continue from (the newest with ``restart = True``)
    on every rank, with ``fracture.csv`` cut to the rows it had (collective); its
    initial crack must be the scene's, ``initial`` (:func:`check_initial`).

    Raises
    ------
    CheckpointError
        No checkpoint, one of another kind of run or crack, or a table with fewer rows.
    """
    path, state = on_root(comm, lambda: _read(restart, outdir))
    if state.get("kind") != kind:
        raise CheckpointError(f"{path} is a checkpoint of {state.get('kind')!r}, not {kind!r}")
    check_initial(Path(path), state["initial"], initial, size)
    trim_rows(Path(outdir) / "fracture.csv", int(state["rows"]), comm)
    return state


def check_initial(path: Path, saved: dict[str, Any], here: dict[str, Any], size: float) -> None:
    """Refuse a checkpoint whose initial crack (``saved``) is not the scene's (``here``)
    within 10⁻¹² of the crack's ``size``."""
    for key, value in here.items():
        other = saved.get(key)
        same = (
            other == value
            if isinstance(value, str) or value is None or other is None
            else np.shape(other) == np.shape(value)
            and np.allclose(other, value, rtol=0, atol=1e-12 * size)
        )
        if not same:
            raise CheckpointError(
                f"checkpoint {path} has the crack's {key} = {other}, the scene {value}: a "
                "restart continues the same crack"
            )
