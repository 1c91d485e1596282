"""PDAS: partial lift-off, complementarity, non-convergence, and PETSc SNES VI as a second method.

* A soft block on a stiff block, loaded by a linearly varying traction that pulls up
  its right end: part of the interface opens.  The converged state must satisfy the
  discrete complementarity conditions at every slave node (λ ≥ 0, gap ≥ 0, λ·gap = 0),
  the total contact force must balance the applied load, and with the iteration limit
  set to 1 the solver must raise :class:`ContactConvergenceError` with its history
  instead of returning the wrong state.
* The same block pressed onto a rigid plane: with the dual basis the constraint is
  nodal (n·u_p ≤ g_p), so the discrete problem is the bound-constrained one that
  PETSc's reduced-space active-set Newton (``vinewtonrsls``) solves; the displacements
  agree to 1e-6 relative.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import numpy as np
import pytest
from two_blocks import P0, H, W, partial_liftoff_model

from bonecontact.contact.interface import RigidPlane, build_interface
from bonecontact.contact.options import PDASOptions
from bonecontact.contact.pdas import ContactConvergenceError, ContactSolver
from bonecontact.contact.snes_vi import snes_vi_solve
from bonecontact.mechanics.integrator import Integrator

COMM = MPI.COMM_WORLD


def _model():
    return partial_liftoff_model(COMM)


def _gathered(values, coords):
    allv = np.concatenate(COMM.allgather(values))
    allx = np.concatenate(COMM.allgather(coords))
    order = np.lexsort(allx.T[::-1])
    return allv[order], allx[order]


def test_partial_liftoff_complementarity_and_force_balance():
    md, pg, m = _model()
    itf = build_interface(
        m.V, md.facet_tags, pg["upper_contact"], pg["lower_contact"], dirichlet_dofs=m.bc_dofs()
    )
    integ = Integrator(m, "static", 1.0, contact=ContactSolver(m.V, [itf]))
    integ.step()
    r = integ.last_contact
    lam, gap = r.pressure[0], r.gap[0]
    scale_g = COMM.allreduce(float(np.abs(gap).max()) if gap.size else 0.0, op=MPI.MAX)
    assert scale_g > 1e-9  # something did open
    assert COMM.allreduce(int((lam < -1e-8 * P0).sum())) == 0
    assert COMM.allreduce(int((gap < -1e-9 * scale_g).sum())) == 0
    assert (
        COMM.allreduce(float(np.abs(lam * gap).max()) if lam.size else 0.0, op=MPI.MAX)
        < 1e-10 * P0 * scale_g
    )
    n_open = r.n_active[0]
    total = COMM.allreduce(itf.num_owned)
    assert 0 < n_open < total
    # the load is −P0 (1 − 1.2 x/W): resultant 0.4 P0 W (per unit thickness)
    assert r.normal_force[0] == pytest.approx(0.4 * P0 * W, rel=1e-9)
    assert 2 <= r.iterations <= 8
    integ.destroy()


def test_iteration_limit_raises_with_history():
    md, pg, m = _model()
    itf = build_interface(
        m.V, md.facet_tags, pg["upper_contact"], pg["lower_contact"], dirichlet_dofs=m.bc_dofs()
    )
    integ = Integrator(
        m, "static", 1.0, contact=ContactSolver(m.V, [itf], PDASOptions(max_iterations=1))
    )
    with pytest.raises(ContactConvergenceError) as info:
        integ.step()
    assert len(info.value.history) == 1 and info.value.history[0]["changed"] > 0
    assert "no convergence in 1 PDAS iterations" in str(info.value)
    assert integ.step_count == 0  # no step was accepted
    integ.destroy()


def test_pdas_equals_snes_vi_on_rigid_plane():
    md, pg, m = _model()
    plane = RigidPlane(point=(0.0, H), normal=(0.0, -1.0))
    itf = build_interface(
        m.V, md.facet_tags, pg["upper_contact"], plane, dirichlet_dofs=m.bc_dofs()
    )
    integ = Integrator(m, "static", 1.0, contact=ContactSolver(m.V, [itf]))
    integ.step()
    u_pdas = integ.u.x.petsc_vec.copy()
    its = integ.last_contact.iterations

    # the same discrete problem for SNES VI: A_bc u = b with u_y ≥ −g at the slave nodes
    ref = Integrator(m, "static", 1.0)
    b = ref.rhs(1.0)
    ref.apply_dirichlet(1.0, b)
    A = ref.A_bc
    lb, ub = A.createVecRight(), A.createVecRight()
    lb.set(-1e30)
    ub.set(1e30)
    bs = 2
    lb.array[bs * itf.blocks + 1] = -itf.gap
    x, _, reason = snes_vi_solve(A, b, lb, ub, prefix="test_vi_")
    assert reason > 0, reason
    diff = x.copy()
    diff.axpy(-1.0, u_pdas)
    rel = diff.norm() / x.norm()
    assert rel < 1e-6, rel
    assert its <= 8
    for obj in (x, diff, lb, ub, u_pdas):
        obj.destroy()
    ref.destroy()
    integ.destroy()
