"""Tests of bonecontact.common.profiling: phase times add up, peak memory sees an allocation."""

from __future__ import annotations

import time

from mpi4py import MPI

import numpy as np
import pytest

from bonecontact.common.profiling import PhaseTimer, peak_memory_mb


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
