"""Where a run spends its time and memory: wall time per phase, peak memory per rank.

:class:`PhaseTimer` accumulates the wall time of named phases (mesh read, mortar geometry,
solver set-up, time stepping, output, ...) and the resident memory at the end of each and
the peak reached by its end (:meth:`PhaseTimer.memory_per_dof`: bytes per owned dof per
rank); :func:`peak_memory_mb` reads the peak resident memory of every rank;
:func:`map_large_allocations` makes freed large blocks leave the resident set.  They end up
in ``summary.json`` (``phases_s``, ``peak_memory_mb``, ``memory_bytes_per_dof``) so a user
can see where a run spends its time and memory.  Times are in seconds, memory in MiB
(bytes per dof in bytes).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import resource
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager

from mpi4py import MPI

import numpy as np

__all__ = [
    "MMAP_THRESHOLD",
    "PhaseTimer",
    "map_large_allocations",
    "peak_memory_mb",
    "resident_mib",
]

#: Size from which the C allocator gives a block its own memory mapping (bytes), fixed by
#: :func:`map_large_allocations` (glibc starts at 128 KiB: the same peak at 65k dofs,
#: a third more page-fault time).
MMAP_THRESHOLD = 1024 * 1024


def resident_mib() -> tuple[float, float]:
    """This process's resident set now and its high-water mark so far (MiB; Linux
    ``/proc/self/status`` VmRSS and VmHWM, else ``ru_maxrss`` for both)."""
    now = peak = -1.0
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    now = int(line.split()[1]) / 1024.0
                elif line.startswith("VmHWM:"):
                    peak = int(line.split()[1]) / 1024.0
    except OSError:
        pass
    if now < 0 or peak < 0:
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        now = peak = rss / (1024.0 * 1024.0) if sys.platform == "darwin" else rss / 1024.0
    return now, peak


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
        #: per phase: (resident MiB at its end, high-water mark MiB at its end), the
        #: largest over repeated entries
        self.memory: dict[str, tuple[float, float]] = {}

    @contextmanager
    def phase(self, name: str) -> Iterator[None]:
        """Time the body of the ``with`` block and add it to phase ``name``; record the
        resident memory at its end and the peak so far."""
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.add(name, time.perf_counter() - t0)
            now, peak = resident_mib()
            old = self.memory.get(name, (0.0, 0.0))
            self.memory[name] = (max(old[0], now), max(old[1], peak))

    def memory_per_dof(self, comm: MPI.Comm, owned_dofs: int) -> dict[str, dict[str, float]]:
        """Bytes per owned dof per rank at the end of each timed phase (collective).

        Parameters
        ----------
        comm
            The run's communicator (every rank must have the same phase names).
        owned_dofs
            The dofs (unknowns, all components) this rank owns.

        Returns
        -------
        dict
            Phase → ``resident``: the memory held at the end of the phase, and ``peak``:
            the high-water mark reached by then (both the largest rank's, in bytes per
            owned dof of that rank; the process's libraries included).
        """
        names = list(self.memory)
        local = np.array([self.memory[n] for n in names], dtype=np.float64).reshape(-1, 2)
        local *= 2.0**20 / max(int(owned_dofs), 1)
        worst = np.empty_like(local)
        comm.Allreduce(local, worst, op=MPI.MAX)
        return {
            n: {"resident": round(float(w[0]), 1), "peak": round(float(w[1]), 1)}
            for n, w in zip(names, worst)
        }

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


def map_large_allocations(threshold: int = MMAP_THRESHOLD) -> bool:
    """Give every allocation of at least ``threshold`` bytes its own memory mapping, which
    goes back to the system when it is freed (glibc ``mallopt(M_MMAP_THRESHOLD)``;
    issue 28).  Returns whether the setting was made: not without glibc, nor when the
    user set ``MALLOC_MMAP_THRESHOLD_`` (glibc's own setting is then left as it is).

    glibc starts at a threshold of 128 KiB but raises it to the size of every mapped block
    freed (up to 32 MiB): after the first large temporaries of a run (the mesh read's)
    the matrices, work arrays and preconditioners that the run builds and frees come
    from the heap, where a freed block stays resident unless a later one fits in it.
    The 3D Hertz scene at 65k dofs on 1 rank kept 45 MiB of the mesh read's freed
    temporaries and grew by 27 MiB at every rebuild of the preconditioner that way.
    A fixed threshold costs a mapping and its page faults per large block (a few
    hundred per time step)."""
    if "MALLOC_MMAP_THRESHOLD_" in os.environ:
        return False
    name = ctypes.util.find_library("c")
    try:
        mallopt = ctypes.CDLL(name).mallopt if name else None
    except (OSError, AttributeError):
        mallopt = None
    if mallopt is None:
        return False
    m_mmap_threshold = -3  # (malloc.h)
    return bool(mallopt(m_mmap_threshold, int(threshold)))


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
