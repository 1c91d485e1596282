"""Columns computed ahead with the base solve (bonecontact.contact.lowrank,
docs/theory/pdas.md#columns-ahead) on a growing contact zone: the 3D hemisphere impact
(stabilized Newmark, split basis), frictionless and oblique with Coulomb friction (3D
Newton slip rows: the tangential rows of nodes about to close or to slip are computed
ahead too).

Reference: the same run with the columns computed only when a set needs them (the
path before; itself checked against refactorising every iteration in test_lowrank.py).
Which columns are cached never changes the solution of a set, so every step's
displacement must agree to round-off (1e-10 of the largest), the PDAS iterations and
active sets exactly; the energy balance of the scheme is unchanged.  Asserted as
behaviour: the columns ahead are computed (with the base solve, or filling the last
chunk of a block on a miss) and the blocks computed on a miss are fewer than without
them; with friction, tangential rows are among them.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import numpy as np
import pytest
from sphere_steps import assert_same_steps, impact, run_steps

from bonecontact.contact.friction import FrictionLaw
from bonecontact.contact.lowrank import LowRankActiveSetSolver
from bonecontact.contact.options import LinearOptions, PDASOptions

COMM = MPI.COMM_WORLD


def _tangential(lr: LowRankActiveSetSolver, qs: list[int]) -> int:
    """How many of the global positions ``qs`` are tangential rows (summed over ranks;
    a rank's contact rows are component-major, normal rows first)."""
    i = np.asarray(qs, dtype=np.int64) - lr.offset
    i = i[(i >= 0) & (i < lr.L.size)]
    return COMM.allreduce(int(np.count_nonzero(i >= lr.L.size // 3)), op=MPI.SUM)


def _impact(
    h: float, memory_ratio: float, steps: int, ahead: bool, monkeypatch, mu: float = 0.0
) -> dict:
    """``steps`` steps of the impact at Δt = t_c/50; with ``ahead`` False the columns
    are computed only on a miss; with ``mu`` > 0 Coulomb friction and a sideways
    velocity of v₀/2.  Per step: displacement, PDAS iterations, active and slipping
    nodes, energy defect; the solver's counters."""
    if not ahead:
        monkeypatch.setattr(LowRankActiveSetSolver, "_prefetch_rows", lambda self, start: [])
        monkeypatch.setattr(LowRankActiveSetSolver, "_fill_chunk", lambda self, *a: [])
    law = FrictionLaw("coulomb", coefficient=mu) if mu > 0 else None
    opts = PDASOptions(linear=LinearOptions(memory_ratio=memory_ratio), friction=law)
    integ, cs = impact(h, opts, sideways=mu > 0)
    lr = cs.linear_solver.lowrank
    misses, ahead_rows = [], []
    compute, base, fill = lr._compute_columns, lr._base_solve, lr._fill_chunk

    def base_solve(prefetch=None):
        ahead_rows.extend(prefetch or [])
        return base(prefetch)

    def fill_chunk(*args):
        rows = fill(*args)
        ahead_rows.extend(rows)
        return rows

    monkeypatch.setattr(lr, "_compute_columns", lambda qs: (misses.append(len(qs)), compute(qs)))
    monkeypatch.setattr(lr, "_base_solve", base_solve)
    if ahead:
        monkeypatch.setattr(lr, "_fill_chunk", fill_chunk)
    out = run_steps(integ, steps)
    out.update(
        ahead=lr.prefetched + lr.filled,
        misses=len(misses),
        columns=lr.columns,
        tangential=_tangential(lr, ahead_rows),
    )
    integ.destroy()
    monkeypatch.undo()
    return out


@pytest.mark.parametrize(
    ("h", "memory_ratio", "steps", "mu"),
    [
        (4e-4, 0.05, 30, 0.0),
        (3e-4, 0.05, 30, 0.0),
        (4e-4, 0.05, 30, 0.3),
        pytest.param(3e-4, 0.05, 30, 0.1, marks=pytest.mark.slow),
        pytest.param(3e-4, 0.01, 50, 0.0, marks=pytest.mark.slow),
    ],
)
def test_columns_ahead_same_solution(h, memory_ratio, steps, mu, monkeypatch):
    """Every step of the growing and shrinking zone as without the columns ahead; the
    columns ahead are computed, and fewer blocks on a miss are needed; with friction,
    the same stick/slip counts, and tangential rows are computed ahead."""
    ref = _impact(h, memory_ratio, steps, False, monkeypatch, mu)
    new = _impact(h, memory_ratio, steps, True, monkeypatch, mu)
    assert_same_steps(ref, new)
    assert max(new["active"]) >= 4  # (the zone grew over several nodes)
    assert ref["ahead"] == 0 < new["ahead"]
    assert new["misses"] <= ref["misses"]
    if ref["misses"] >= 3:  # (a zone that grew over several steps)
        assert new["misses"] < ref["misses"]
    if mu > 0:  # (nodes slipped, and tangential rows were computed ahead)
        assert max(new["slip"]) >= 1
        assert new["tangential"] > 0
