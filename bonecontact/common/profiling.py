"""Where a run spends its time and memory: wall time per phase, peak memory per rank.

:class:`PhaseTimer` accumulates the wall time of named phases (mesh read, mortar geometry,
solver set-up, time stepping, output, ...); :func:`peak_memory_mb` reads the peak resident
memory of every rank.  Both end up in ``summary.json`` (``phases_s``, ``peak_memory_mb``)
so a user can see where a run spends its time.  Times are in seconds, memory in MiB.
"""

from __future__ import annotations

import resource
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager

from mpi4py import MPI

import numpy as np

__all__ = ["PhaseTimer", "peak_memory_mb"]


class PhaseTimer:
    """Wall time (s) of named phases, accumulated over repeated entries.

    Examples
    --------
    >>> timer = PhaseTimer()
    >>> with timer.phase("mesh_read"):
    ...     pass
    >>> sorted(timer.times)
    ['mesh_read']
    """

    def __init__(self) -> None:
        self.times: dict[str, float] = {}

    @contextmanager
    def phase(self, name: str) -> Iterator[None]:
        """Time the body of the ``with`` block and add it to phase ``name``."""
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.add(name, time.perf_counter() - t0)

    def add(self, name: str, seconds: float) -> None:
        """Add ``seconds`` to phase ``name`` (measured elsewhere, e.g. inside a solver)."""
        self.times[name] = self.times.get(name, 0.0) + float(seconds)

    def summary(self, comm: MPI.Comm) -> dict[str, float]:
        """The slowest rank's time of every phase, in the order the phases first ran
        (collective: every rank must have the same phase names)."""
        names = list(self.times)
        local = np.array([self.times[n] for n in names], dtype=np.float64)
        values = np.empty_like(local)
        comm.Allreduce(local, values, op=MPI.MAX)
        return {n: round(float(v), 6) for n, v in zip(names, values)}


def peak_memory_mb(comm: MPI.Comm) -> dict[str, float]:
    """Peak resident memory of the processes of ``comm`` so far (collective).

    Returns
    -------
    dict
        ``max_rank``: the largest peak of one rank (MiB); ``total``: the sum over ranks
        (MiB) — an upper bound of the run's peak, since the ranks need not peak together.
    """
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux, bytes on macOS
    mib = rss / (1024.0 * 1024.0) if sys.platform == "darwin" else rss / 1024.0
    return {
        "max_rank": round(comm.allreduce(mib, op=MPI.MAX), 1),
        "total": round(comm.allreduce(mib, op=MPI.SUM), 1),
    }
