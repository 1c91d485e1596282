"""The final block of a fatigue run that ends ``through`` (runners.crack_fatigue.final_block):
da_max at the leading rate of the last solved crack, extrapolated (no solve at its end).
Its cycles are da/rate, its share n / (N_before + n); above FINAL_BLOCK_SHARE the run's
message says that the count is set by the extrapolation, with one FinalBlockWarning on
rank 0 (the scanned L4 on the non-planar path: 2.46e6 of 3.66e6 cycles, K_V fallen to
32 kPa√m in the compressed half).  The runners' use: tests/unit/runners/
test_crack_fatigue_scene3d.py (``test_stops``, interior crack) and
test_surface_crack_scene3d.py (the thin plate, slow)."""

from __future__ import annotations

import math
import warnings

from mpi4py import MPI

import pytest

from bonecontact.runners.crack_fatigue import (
    FINAL_BLOCK_SHARE,
    FatigueProgress,
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
    assert b["cycles_trend"] == n  # no history: the start rate
    comm = MPI.COMM_WORLD
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always", FinalBlockWarning)
        note = final_block_note(comm, b)
    said = [w for w in seen if w.category is FinalBlockWarning]
    if b["share"] > FINAL_BLOCK_SHARE:
        assert note is not None and f"{100 * b['share']:.0f} %" in note
        assert f"{n:.4g}" in note and "da_max" in note and "last two solves" in note
        assert len(said) == (1 if comm.rank == 0 else 0)
    else:
        assert note is None and not said


def test_no_final_block_no_note() -> None:
    assert final_block_note(MPI.COMM_WORLD, None) is None


@pytest.mark.parametrize("g", [-40.0, 0.0, 25.0, 400.0])
@pytest.mark.parametrize("da", [1.0e-4, 2.0e-3])
def test_trend_block_integrates_an_exponential_rate(g: float, da: float) -> None:
    """Ends on r(s) = r0 e^(g s) (two blocks of 1 mm): the next block's ∫ ds / r in
    closed form, (1 − e^(−g da)) / (g r(s₂)) for g > 0; a falling or constant rate keeps
    the last one (da / r(s₂)) — and a single end too."""
    r0 = 3.0e-9
    p = FatigueProgress()
    for s in (0.0, 1.0e-3, 2.0e-3):
        p.add_end(s, r0 * math.exp(g * s))
    r2 = r0 * math.exp(g * 2.0e-3)
    want = (1.0 - math.exp(-g * da)) / (g * r2) if g > 0 else da / r2
    assert p.trend_block(da) == pytest.approx(want, rel=1e-12)
    b = final_block(p.cycles[-1], da, r2, p)
    assert b["cycles_trend"] == pytest.approx(want, rel=1e-12) and b["cycles"] == da / r2
    assert b["cycles_trend"] <= b["cycles"]
    one = FatigueProgress()
    one.add_end(0.0, r0)
    assert one.trend_block(da) == da / r0


def test_trend_block_starts_again_after_a_merge() -> None:
    """After cracks merge the slope comes from the ends of the merged crack only: with one
    end since the merge, the last rate."""
    p = FatigueProgress()
    for s, r in ((0.0, 1e-9), (1e-3, 4e-9)):
        p.add_end(s, r)
    p.merged({}, 0.0)
    p.add_end(2e-3, 2e-9)  # the merged crack's first end
    assert p.trend_block(1e-3) == pytest.approx(1e-3 / 2e-9, rel=1e-15)
