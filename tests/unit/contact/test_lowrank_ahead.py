"""Columns computed ahead with the base solve (bonecontact.contact.lowrank,
docs/theory/pdas.md#columns-ahead) on a growing contact zone: the 3D hemisphere impact
(stabilized Newmark, frictionless, split basis).

Reference: the same run with the columns computed only when a set needs them (the
path before; itself checked against refactorising every iteration in test_lowrank.py).
Which columns are cached never changes the solution of a set, so every step's
displacement must agree to round-off (1e-10 of the largest), the PDAS iterations and
active sets exactly; the energy balance of the scheme is unchanged.  Asserted as
behaviour: the columns ahead are computed (``prefetched`` > 0) and the blocks computed
on a miss are fewer than without them.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import fem

from bonecontact.contact.lowrank import LowRankActiveSetSolver
from bonecontact.contact.options import LinearOptions, PDASOptions
from bonecontact.contact.pdas import ContactSolver
from bonecontact.mechanics.newmark import make_integrator
from bonecontact.verification.sphere_impact import SphereImpact, sphere_model

COMM = MPI.COMM_WORLD


def _impact(h: float, memory_ratio: float, steps: int, ahead: bool, monkeypatch) -> dict:
    """``steps`` steps of the impact at Δt = t_c/50; with ``ahead`` False the columns
    are computed only on a miss.  Per step: displacement, PDAS iterations, active
    nodes, energy defect; the solver's counters."""
    if not ahead:
        monkeypatch.setattr(LowRankActiveSetSolver, "_prefetch_rows", lambda self, start: [])
    p = SphereImpact(h_contact=h, h_far=10 * h)
    m, itf, sphere = sphere_model(p, COMM)
    opts = PDASOptions(linear=LinearOptions(memory_ratio=memory_ratio))
    cs = ContactSolver(m.V, [itf], opts)
    integ = make_integrator(
        "stabilized-newmark", m, "dynamic", p.contact_time / 50, contact=cs, energy_balance=True
    )
    v0 = fem.Function(m.V)
    v0.x.array[:] = -p.v0 * sphere.x.array
    integ.set_initial(None, v0)
    lr = cs.linear_solver.lowrank
    misses = []
    compute = lr._compute_columns
    monkeypatch.setattr(lr, "_compute_columns", lambda qs: (misses.append(len(qs)), compute(qs)))
    out = {"u": [], "its": [], "active": [], "energy": []}
    for _ in range(steps):
        integ.step()
        out["u"].append(integ.u.x.array.copy())
        out["its"].append(integ.last_contact.iterations)
        out["active"].append(integ.last_contact.n_active[0])
        b = integ.last_balance
        out["energy"].append((b.kinetic + b.strain, b.numerical_dissipation, b.contact_work))
    out.update(prefetched=lr.prefetched, misses=len(misses), columns=lr.columns)
    integ.destroy()
    monkeypatch.undo()
    return out


@pytest.mark.parametrize(
    ("h", "memory_ratio", "steps"),
    [
        (4e-4, 0.05, 30),
        (3e-4, 0.05, 30),
        pytest.param(3e-4, 0.01, 50, marks=pytest.mark.slow),
    ],
)
def test_columns_ahead_same_solution(h, memory_ratio, steps, monkeypatch):
    """Every step of the growing and shrinking zone as without the columns ahead; the
    columns ahead are computed, and fewer blocks on a miss are needed."""
    ref = _impact(h, memory_ratio, steps, False, monkeypatch)
    new = _impact(h, memory_ratio, steps, True, monkeypatch)
    assert new["its"] == ref["its"]
    assert new["active"] == ref["active"]
    assert max(new["active"]) >= 4  # (the zone grew over several nodes)
    scale = COMM.allreduce(max(np.abs(u).max() for u in ref["u"]), op=MPI.MAX)
    diff = COMM.allreduce(max(np.abs(a - b).max() for a, b in zip(new["u"], ref["u"])), op=MPI.MAX)
    assert diff <= 1e-10 * scale
    e_ref, e_new = np.array(ref["energy"]), np.array(new["energy"])
    assert np.abs(e_new - e_ref).max() <= 1e-10 * np.abs(e_ref).max()
    assert ref["prefetched"] == 0 < new["prefetched"]
    assert new["misses"] <= ref["misses"]
    if ref["misses"] >= 3:  # (a zone that grew over several steps)
        assert new["misses"] < ref["misses"]
