"""Low-rank columns solved with sparse right-hand sides (bonecontact.contact.lowrank,
``LowRankActiveSetSolver.sparse_rhs``, docs/theory/pdas.md#sparse-right-hand-sides): the
3D hemisphere impact (stabilized Newmark, split basis), frictionless and oblique with
Coulomb friction.

References: (1) every column of a block against one MUMPS solve of its right-hand side
built densely by matrix-vector products (``−A e_q`` through the operator's columns,
``Jᵀ e_q`` through ``Jᵀ``), both types (rows fixed in the base and free rows), to 1e-12
of the column; (2) the whole run with dense right-hand sides (the path before): a
column does not depend on how its right-hand side is stored, so every step's
displacement agrees to round-off (1e-10 of the largest), the PDAS iterations, active
and slipping counts exactly, the energy balance to 1e-10, with the same columns and
blocks.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest
from sphere_steps import assert_same_steps, impact, run_steps

from bonecontact.contact.friction import FrictionLaw
from bonecontact.contact.lowrank import LowRankActiveSetSolver
from bonecontact.contact.options import PDASOptions

COMM = MPI.COMM_WORLD


def _options(mu: float) -> PDASOptions:
    return PDASOptions(friction=FrictionLaw("coulomb", coefficient=mu) if mu > 0 else None)


def _dense_column(lr: LowRankActiveSetSolver, q: int, fixed: bool) -> PETSc.Vec:
    """The right-hand side of the column of global position ``q``, densely: ``−A e_q`` off
    the base's fixed rows and ``δ`` at ``q`` (``fixed``), else ``e_q − Jᵀ e_q`` off the
    Dirichlet rows."""
    rhs = lr._xb.duplicate()
    rhs.set(0.0)
    mine = lr.offset <= q < lr.offset + lr.L.size
    row = int(lr.L[q - lr.offset]) if mine else -1
    if fixed:
        e = lr.AC.createVecRight()
        e.set(0.0)
        if mine:
            e.array[int(np.searchsorted(lr._cols, row))] = 1.0
        lr.AC.mult(e, rhs)
        rhs.scale(-1.0)
        rhs.array[lr._fixed_local(lr.base)] = 0.0
        if mine:
            rhs.array[row] = lr.diag_value
        e.destroy()
        return rhs
    e = rhs.duplicate()
    e.set(0.0)
    if mine:
        e.array[row] = 1.0
    lr.split.Jt.mult(e, rhs)
    rhs.aypx(-1.0, e)
    rhs.array[lr.bc_local] = 0.0
    e.destroy()
    return rhs


def _positions(lr: LowRankActiveSetSolver, mask: np.ndarray, n: int) -> list[int]:
    """Up to ``n`` global positions of this solver's rows in ``mask`` (the same list on
    every rank: every third one of all ranks')."""
    q = np.concatenate(COMM.allgather(np.flatnonzero(mask) + lr.offset))
    return [int(v) for v in q[::3][:n]]


@pytest.mark.parametrize(("h", "mu"), [(4e-4, 0.0), (4e-4, 0.3)])
def test_sparse_columns_equal_dense_solves(h, mu):
    """After 12 impact steps (a zone of several nodes), a block of columns of rows fixed
    in the base and of free rows equals one solve per column of its dense right-hand side:
    the contact rows, ``Ã`` times the column there, and the full column."""
    integ, cs = impact(h, _options(mu), sideways=mu > 0)
    run_steps(integ, 12)
    lr = cs.linear_solver.lowrank
    fixed, free = _positions(lr, lr.base, 6), _positions(lr, ~lr.base, 10)
    assert fixed and len(free) == 10
    qs = fixed + free
    for q in qs:
        lr.cache.pop(q, None)
    lr.full_cols = {q: c for q, c in lr.full_cols.items() if q not in qs}
    lr.full_limit = len(lr.full_cols) + len(qs)
    lr._compute_block(qs)
    x, ax = lr._xb.duplicate(), lr.AL.createVecLeft()
    worst = 0.0
    for q in qs:
        rhs = _dense_column(lr, q, q in fixed)
        lr.ksp.solve(rhs, x)
        lr.AL.mult(x, ax)
        got_n, got_a = lr.cache[q]
        scale = COMM.allreduce(float(np.abs(x.array).max()), op=MPI.MAX)
        err = max(
            float(np.abs(lr._full(x)[lr.L] - got_n).max(initial=0.0)),
            float(np.abs(ax.array - got_a).max(initial=0.0))
            * scale
            / max(COMM.allreduce(float(np.abs(ax.array).max(initial=0.0)), op=MPI.MAX), 1e-300),
            float(np.abs(x.array - lr.full_cols[q]).max()),
        )
        worst = max(worst, COMM.allreduce(err, op=MPI.MAX) / scale)
        rhs.destroy()
    x.destroy()
    ax.destroy()
    integ.destroy()
    assert worst <= 1e-12


def _run(h: float, mu: float, sparse: bool, steps: int, monkeypatch) -> dict:
    monkeypatch.setattr(LowRankActiveSetSolver, "sparse_rhs", sparse)
    integ, cs = impact(h, _options(mu), sideways=mu > 0)
    out = run_steps(integ, steps)
    lr = cs.linear_solver.lowrank
    out.update(columns=lr.columns, blocks=lr.n_blocks)
    integ.destroy()
    monkeypatch.undo()
    return out


@pytest.mark.parametrize(
    ("h", "mu"),
    [
        pytest.param(4e-4, 0.0, marks=pytest.mark.slow),  # (the column test covers it)
        (4e-4, 0.3),
        pytest.param(3e-4, 0.1, marks=pytest.mark.slow),
    ],
)
def test_sparse_rhs_run_equals_dense_rhs_run(h, mu, monkeypatch):
    """30 impact steps with sparse right-hand sides as with dense ones, step by step."""
    ref = _run(h, mu, False, 30, monkeypatch)
    new = _run(h, mu, True, 30, monkeypatch)
    assert_same_steps(ref, new)
    assert max(new["active"]) >= 4  # (the zone grew over several nodes)
    assert (new["columns"], new["blocks"]) == (ref["columns"], ref["blocks"]) and new["blocks"] > 0
    if mu > 0:
        assert max(new["slip"]) >= 1
