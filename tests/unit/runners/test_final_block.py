"""The final block of a fatigue run that ends ``through`` (runners.crack_fatigue.final_block):
da_max at the leading rate of the last solved crack, extrapolated (no solve at its end).
Its cycles are da/rate, its share n / (N_before + n); above FINAL_BLOCK_SHARE the run's
message says that the count is set by the extrapolation, with one FinalBlockWarning on
rank 0 (the scanned L4 on the non-planar path: 2.46e6 of 3.66e6 cycles, K_V fallen to
32 kPa√m in the compressed half).  The runners' use: tests/unit/runners/
test_crack_fatigue_scene3d.py (``test_stops``, interior crack) and
test_surface_crack_scene3d.py (the thin plate, slow)."""

from __future__ import annotations

import warnings

from mpi4py import MPI

import pytest

from bonecontact.runners.crack_fatigue import (
    FINAL_BLOCK_SHARE,
    FinalBlockWarning,
    final_block,
    final_block_note,
)


@pytest.mark.parametrize("before", [0.0, 1.0e5, 3.0e5, 1.0e7])
@pytest.mark.parametrize(("da", "rate"), [(4.0e-3, 1.0e-9), (1.0e-4, 3.0e-8)])
def test_final_block_cycles_and_share(before: float, da: float, rate: float) -> None:
    b = final_block(before, da, rate)
    n = da / rate
    assert b["cycles"] == n and b["da"] == da and b["rate"] == rate
    assert b["share"] == pytest.approx(n / (before + n), rel=1e-15)
    comm = MPI.COMM_WORLD
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always", FinalBlockWarning)
        note = final_block_note(comm, b)
    said = [w for w in seen if w.category is FinalBlockWarning]
    if b["share"] > FINAL_BLOCK_SHARE:
        assert note is not None and f"{100 * b['share']:.0f} %" in note
        assert f"{n:.4g}" in note and "da_max" in note
        assert len(said) == (1 if comm.rank == 0 else 0)
    else:
        assert note is None and not said


def test_no_final_block_no_note() -> None:
    assert final_block_note(MPI.COMM_WORLD, None) is None
