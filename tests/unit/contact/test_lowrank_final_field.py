"""The final field of a contact solve from the kept full columns and the block that
carries the base solve (bonecontact.contact.lowrank: ``_final_field``, ``x_b + X y`` by
one BLAS ``axpy`` per column on one thread; ``_prefetch_rows`` with ``_base_chunk``: the
certain rows fill the block of the base solve up to a sparse block's size on one rank,
the guessed ones only up to a dense block's), on the 3D hemisphere impact (stabilized
Newmark, split basis), frictionless and with Coulomb friction.

Reference for the final field: every step's ``x_b + X y`` against one MUMPS solve of the
set's right-hand side with the contact forces of the same solve (the path the solver
takes when a column is not kept in full), to 1e-10 of its largest entry.  Which columns
are computed ahead never changes a solution (test_lowrank_ahead.py compares whole runs
with and without them); here the rule itself is checked on a solver state of the impact:
how many certain and guessed rows go with the base solve, on one rank and on more.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import numpy as np
import pytest
from sphere_steps import impact, run_steps

from bonecontact.contact.friction import FrictionLaw
from bonecontact.contact.lowrank import LowRankActiveSetSolver
from bonecontact.contact.options import LinearOptions, PDASOptions

COMM = MPI.COMM_WORLD


def _options(memory_ratio: float, mu: float) -> PDASOptions:
    law = FrictionLaw("coulomb", coefficient=mu) if mu > 0 else None
    return PDASOptions(linear=LinearOptions(memory_ratio=memory_ratio), friction=law)


def _gmax(a: np.ndarray) -> float:
    return COMM.allreduce(float(np.abs(a).max()) if a.size else 0.0, op=MPI.MAX)


@pytest.mark.parametrize(("h", "mu"), [(4e-4, 0.0), (4e-4, 0.3), (3e-4, 0.0)])
def test_final_field_equals_final_solve(h, mu, monkeypatch):
    """Every step's ``x_b + X y`` from the kept columns equals one solve of the set's
    right-hand side (contact forces and values of the same solve) to 1e-10."""
    integ, cs = impact(h, _options(0.05, mu), sideways=mu > 0)
    lr = cs.linear_solver.lowrank
    finish, errors, sizes, in_contact = lr.finish, [], [], [0]

    def finish_both(out):
        finish(out)
        cols = lr._y[0]
        in_contact[0] += bool(cols)
        if not cols or not all(q in lr.full_cols for q in cols):
            return
        ref, kept = out.duplicate(), lr.full_cols
        lr.full_cols = {}  # (no kept column: the final solve)
        try:
            finish(ref)
        finally:
            lr.full_cols = kept
        errors.append(_gmax(ref.array - out.array) / _gmax(ref.array))
        sizes.append(len(cols))
        ref.destroy()

    monkeypatch.setattr(lr, "finish", finish_both)
    run_steps(integ, 30)
    integ.destroy()
    assert len(errors) >= max(in_contact[0] // 2, 5)  # (most steps took the kept columns)
    assert max(sizes) >= 4  # (a zone of several rows)
    assert max(errors) <= 1e-10


def _sure_and_guessed(lr: LowRankActiveSetSolver, start: np.ndarray) -> tuple[list, set]:
    """Rows computed ahead for a contact solve starting from ``start`` (this rank's
    rows) with an empty cache, and the rows that differ from the base there (global
    positions, every rank's)."""
    lr.cache.clear()
    lr._start_prev = start.copy()  # (no growth: only the certain rows decide)
    rows = lr._prefetch_rows(start)
    sure = np.flatnonzero(start != lr.base) + lr.offset
    return rows, {int(q) for q in np.concatenate(COMM.allgather(sure))}


def test_certain_rows_fill_the_base_block(monkeypatch):
    """After 12 steps of the oblique impact (Coulomb, μ = 0.3), with a dense block of 4
    columns and a sparse one of 9: the rows in which the start differs from the base
    (certain) fill the block with the base solve up to its own size (8 besides the
    base solve on one rank: sparse; 3 on more ranks: dense); with fewer certain rows
    than a dense block holds, the rows closest to switching fill it to 3, not 8."""
    integ, cs = impact(4e-4, _options(0.05, 0.3), sideways=True)
    run_steps(integ, 12)
    lr = cs.linear_solver.lowrank
    monkeypatch.setattr(lr, "block_limit", 4)
    monkeypatch.setattr(lr, "sparse_limit", 9)
    room = (9 if COMM.size == 1 else 4) - 1
    assert lr._base_chunk() - 1 == room
    start = ~lr.base.copy()  # (every row differs from the base)
    rows, sure = _sure_and_guessed(lr, start)
    assert len(sure) > 8
    assert len(rows) == room and set(rows) <= sure
    start = lr.base.copy()  # (two certain rows: the first two outside the base of the
    owner = int(np.argmax(COMM.allgather(int(np.count_nonzero(~lr.base)))))  # rank with most)
    start[np.flatnonzero(~lr.base)[:2]] = COMM.rank == owner
    rows, sure = _sure_and_guessed(lr, start)
    assert len(sure) == 2 and set(rows[:2]) == sure
    assert len(rows) == 3  # (one guess: a dense block, not the sparse one)
    integ.destroy()
