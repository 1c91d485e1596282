"""Tests of bonecontact.common.profiling: phase times add up, peak memory sees an allocation,
a freed large block leaves the resident set once large allocations are mapped."""

from __future__ import annotations

import os
import subprocess
import sys
import time

from mpi4py import MPI

import numpy as np
import pytest

from bonecontact.common.profiling import (
    PhaseTimer,
    map_large_allocations,
    peak_memory_mb,
)


def test_phase_times_accumulate_and_take_the_slowest_rank():
    comm = MPI.COMM_WORLD
    timer = PhaseTimer()
    timer.add("solve", 1.5)
    timer.add("solve", 0.25 * (comm.rank + 1))
    with timer.phase("sleep"):
        time.sleep(0.02)
    out = timer.summary(comm)
    assert list(out) == ["solve", "sleep"]  # order of first use
    assert out["solve"] == pytest.approx(1.5 + 0.25 * comm.size, abs=1e-6)  # max over ranks
    assert out["sleep"] >= 0.02


def test_phase_timed_even_when_the_body_raises():
    timer = PhaseTimer()
    with pytest.raises(ValueError), timer.phase("failing"):
        time.sleep(0.01)
        raise ValueError("boom")
    assert timer.times["failing"] >= 0.01


def test_peak_memory_sees_an_allocation():
    comm = MPI.COMM_WORLD
    before = peak_memory_mb(comm)
    block = np.ones(40 * 2**20 // 8 * (comm.rank + 1) + 2**27 // 8)  # 128 MiB + 40 MiB per rank
    block[::512] += 1.0  # touch every page
    after = peak_memory_mb(comm)
    assert after["max_rank"] >= 128.0 + 40.0 * comm.size
    assert after["total"] >= sum(128.0 + 40.0 * (r + 1) for r in range(comm.size))
    assert after["total"] >= before["total"] and after["max_rank"] <= after["total"]
    del block


@pytest.mark.parametrize("owned", [1, 1000, 123457])
def test_memory_per_dof_sees_an_allocation_and_its_release(owned):
    """Bytes per dof by phase: a phase that allocates and touches 96 MiB (+8 MiB per rank)
    ends with that much more resident memory than the phase before (the peak so far at
    least as high); after freeing it, the resident memory falls back while the peak
    stays.  Reference: the size of the allocation, per owned dof of the rank."""
    comm = MPI.COMM_WORLD
    timer = PhaseTimer()
    nbytes = (96 + 8 * comm.rank) * 2**20
    with timer.phase("before"):
        pass
    with timer.phase("allocate"):
        block = np.ones(nbytes // 8)
        block[::512] += 1.0  # touch every page
    with timer.phase("release"):
        del block
    before, alloc, rel = (timer.memory[n] for n in ("before", "allocate", "release"))
    assert alloc[0] - before[0] >= 0.95 * nbytes / 2**20
    assert alloc[1] >= alloc[0]  # the peak so far holds the allocation
    assert rel[0] <= alloc[0] - 0.9 * nbytes / 2**20  # freed (large blocks go back to the OS)
    # (the kernel's RSS counters are batched per thread, up to 64 pages: 0.25 MiB)
    assert rel[1] >= alloc[1] - 1.0
    per = timer.memory_per_dof(comm, owned)
    assert list(per) == ["before", "allocate", "release"]
    want = max(comm.allgather(alloc[0] * 2**20 / owned))  # the largest rank's
    assert per["allocate"]["resident"] == pytest.approx(want, rel=1e-6, abs=0.1)
    assert per["allocate"]["peak"] >= per["allocate"]["resident"] - 0.1


#: run in a fresh interpreter, as `bonecontact run` calls it at its start: in a long-lived
#: test worker other libraries' allocations (MPI transports, earlier tests) change the
#: heap the setting acts on
_FREED_BLOCK = """
import numpy as np
from bonecontact.common.profiling import map_large_allocations, resident_mib
big = np.ones(24 * 2**17)  # 24 MiB, mapped; freeing it raises glibc's threshold
del big
if not map_large_allocations():
    print("skip")
else:
    block = np.ones(16 * 2**17)  # 16 MiB, touched
    after = np.ones(1000)  # (a heap block after it: the heap's top is not free)
    before = resident_mib()[0]
    del block
    print(before - resident_mib()[0], after.sum())
"""


@pytest.mark.serial
def test_freed_large_block_leaves_the_resident_set():
    """After :func:`map_large_allocations` a freed 16 MiB block goes back to the system,
    even after a larger mapped block was freed (glibc's own threshold then grows to that
    size: the 16 MiB came from the heap and, with a small block after it, stayed
    resident — a drop of 0 MiB without the setting)."""
    env = {k: v for k, v in os.environ.items() if k != "MALLOC_MMAP_THRESHOLD_"}
    out = subprocess.run(
        [sys.executable, "-c", _FREED_BLOCK], env=env, capture_output=True, text=True, check=True
    ).stdout.split()
    if out == ["skip"]:
        pytest.skip("no glibc")
    assert float(out[0]) >= 12.0
    assert float(out[1]) == 1000.0


def test_user_allocator_setting_is_left_alone(monkeypatch):
    monkeypatch.setenv("MALLOC_MMAP_THRESHOLD_", "131072")
    assert map_large_allocations() is False
