"""Helpers shared by the benchmark scripts (imported from the script directory)."""

from __future__ import annotations

import csv
import time
from pathlib import Path

from mpi4py import MPI

__all__ = ["write_rows"]


def write_rows(
    out_dir: Path,
    name: str,
    rows: list[dict],
    extra_columns: dict[str, str] | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> None:
    """Append ``rows`` to ``out_dir/<name>.csv`` on rank 0, with a ``date`` column.

    The header (written when the file is new) is the keys of the first row, then
    ``extra_columns`` (column → value of rows without it), then ``date``.
    """
    if comm.rank != 0 or not rows:
        return
    extra = extra_columns or {}
    path = out_dir / f"{name}.csv"
    new = not path.exists()
    with open(path, "a", newline="") as f:
        w = csv.DictWriter(f, list(rows[0]) + list(extra) + ["date"])
        if new:
            w.writeheader()
        for r in rows:
            w.writerow({**extra, **r, "date": time.strftime("%Y-%m-%d", time.gmtime())})
