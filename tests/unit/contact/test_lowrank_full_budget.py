"""The full solution columns kept across the steps of a time-stepped run
(bonecontact.contact.lowrank, ``LinearOptions.full_ratio``,
docs/theory/pdas.md#full-columns-across-steps): the 3D hemisphere impact (stabilized
Newmark, frictionless, split basis) with a ``memory_ratio`` so small that the contact
zone's columns do not fit its budget.

Reference: the same run with ``full_ratio = 0`` (the full columns within the
``memory_ratio`` budget only: the steps whose set has a column without its full
solution take a second, final solve).  Which columns are kept in full never changes
the solution of a set, so every step's displacement must agree to round-off (1e-10 of
the largest), the PDAS iterations and active sets exactly, the energy balance to 1e-10.
Asserted as behaviour: the reference takes final solves, the run with its own budget
none, and the memory of its full columns stays within ``full_ratio`` of the LU factors'
(reported by ``ContactSolver.column_report``).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import pytest
from sphere_steps import assert_same_steps, impact, run_steps

from bonecontact.contact.options import LinearOptions, PDASOptions


def _impact(h: float, memory_ratio: float, full_ratio: float, steps: int) -> dict:
    """``steps`` steps of the impact (:func:`sphere_steps.run_steps`); the column report
    at the end and the LU factors' memory (bytes, largest rank)."""
    lin = LinearOptions(memory_ratio=memory_ratio, full_ratio=full_ratio)
    integ, cs = impact(h, PDASOptions(linear=lin))
    out = run_steps(integ, steps)
    out["report"] = cs.column_report()
    pc = cs.linear_solver.lowrank.ksp.getPC()
    out["factor_bytes"] = 1.0e6 * float(pc.getFactorMatrix().getMumpsInfog(21))
    integ.destroy()
    return out


@pytest.mark.parametrize(("h", "memory_ratio"), [(4e-4, 0.004), (3e-4, 0.002)])
def test_full_column_budget_same_solution_without_final_solves(h, memory_ratio):
    """Every step as with the full columns within ``memory_ratio`` only; no final solve
    (the reference takes some), and the kept columns' memory within ``full_ratio``."""
    steps = 30
    ref = _impact(h, memory_ratio, 0.0, steps)
    new = _impact(h, memory_ratio, 0.25, steps)
    assert_same_steps(ref, new)
    assert max(new["active"]) >= 4  # (the zone grew over several nodes)
    assert ref["report"]["final_solves"] > 0
    assert new["report"]["final_solves"] == 0
    rep = new["report"]
    assert rep["full_columns_used"] > ref["report"]["full_columns_cap"]  # (beyond the floor)
    assert 0.0 < 1.0e6 * rep["full_columns_peak_mb"] <= 0.25 * new["factor_bytes"]
