"""Helpers shared by the benchmark scripts (imported from the script directory)."""

from __future__ import annotations

import csv
import os
import platform
import time
from pathlib import Path
from typing import TYPE_CHECKING

from mpi4py import MPI

from bonecontact.common.linalg import create_solver

if TYPE_CHECKING:
    from bonecontact.mechanics.integrator import Integrator

__all__ = ["machine", "time_one_direct_solve", "write_rows"]


def machine() -> str:
    """CPU model and core count of this machine (for the results tables)."""
    model = platform.processor() or "unknown CPU"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores"


def time_one_direct_solve(integ: Integrator, prefix: str = "bench_lin_") -> float:
    """Wall time of ONE linear solve of the step operator without contact (fresh MUMPS
    KSP: symbolic + numeric factorisation + solve; collective)."""
    b = integ.rhs(1.0)
    integ.apply_dirichlet(1.0, b)
    integ.A_bc.getComm().tompi4py().barrier()
    t0 = time.perf_counter()
    ksp = create_solver(integ.A_bc, "direct", prefix=prefix)
    x = b.duplicate()
    ksp.solve(b, x)
    integ.A_bc.getComm().tompi4py().barrier()
    t = time.perf_counter() - t0
    for o in (ksp, x, b):
        o.destroy()
    return t


def write_rows(
    out_dir: Path,
    name: str,
    rows: list[dict],
    extra_columns: dict[str, str] | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> None:
    """Append ``rows`` to ``out_dir/<name>.csv`` on rank 0, with a ``date`` column.

    The header (written when the file is new) is the keys of the first row, then
    ``extra_columns`` not among them (column → value of rows without it), then ``date``.
    """
    if comm.rank != 0 or not rows:
        return
    extra = extra_columns or {}
    path = out_dir / f"{name}.csv"
    new = not path.exists()
    with open(path, "a", newline="") as f:
        columns = list(rows[0]) + [c for c in extra if c not in rows[0]] + ["date"]
        w = csv.DictWriter(f, columns)
        if new:
            w.writeheader()
        for r in rows:
            w.writerow({**extra, **r, "date": time.strftime("%Y-%m-%d", time.gmtime())})
