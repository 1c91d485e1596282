"""The integrator releases its operator with Dirichlet rows (``A_bc``) once the contact
solver is set up (issue 28: one matrix less during the contact solve).

The two-block scene of ``test_pdas.py`` (partial lift-off) for the direct (low-rank, which
keeps its own reference to the operator) and the iterative solver: after the release a
step still solves, both solvers give the same displacement (to the Krylov tolerance), and
``A_bc`` asked for afterwards is built again equal to that of an integrator without
contact (same entries, to round-off).  A static integrator with contact keeps no step
operator at all: its residual and strain energy equal those of the assembled matrix.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import numpy as np
import pytest
from two_blocks import partial_liftoff_model

from bonecontact.contact.condensed import lean_products
from bonecontact.contact.interface import build_interface, transformed_operator
from bonecontact.contact.pdas import ContactSolver
from bonecontact.mechanics.integrator import Integrator

COMM = MPI.COMM_WORLD


def _model():
    return partial_liftoff_model(COMM)


def _contact_integrator(linear: str, dt: float = 1.0) -> Integrator:
    md, pg, m = _model()
    itf = build_interface(
        m.V, md.facet_tags, pg["upper_contact"], pg["lower_contact"], dirichlet_dofs=m.bc_dofs()
    )
    return Integrator(m, "static", dt, linear=linear, contact=ContactSolver(m.V, [itf]))


@pytest.fixture(scope="module")
def solved() -> dict[str, Integrator]:
    out = {}
    for linear in ("direct", "iterative"):
        integ = _contact_integrator(linear)
        integ.step()
        out[linear] = integ
    return out


def test_step_after_release_same_for_both_solvers(solved):
    ud = solved["direct"].u.x.petsc_vec
    ui = solved["iterative"].u.x.petsc_vec
    diff = ud.copy()
    diff.axpy(-1.0, ui)
    assert diff.norm() <= 1e-6 * ud.norm()
    diff.destroy()


@pytest.mark.parametrize("linear", ["direct", "iterative"])
def test_rebuilt_operator_equals_plain_one(solved, linear):
    integ = solved[linear]
    plain = Integrator(integ.model, "static", 1.0, linear="direct")
    D = integ.A_bc.copy()
    D.axpy(-1.0, plain.A_bc)
    assert D.norm() <= 1e-14 * plain.A_bc.norm()
    D.destroy()
    plain.destroy()


def test_transformed_operator_holds_no_reference_to_the_operator(solved):
    """``T Q A Qᵀ Tᵀ`` is returned without PETSc's product record, which would keep ``A``
    (and so the released ``A_bc``) alive as long as the condensed operator lives."""
    integ = solved["iterative"]
    A = integ.A_bc
    Qt, Tt = integ.contact.Qt, integ.contact.system.Tt
    before = A.getRefCount()
    At = transformed_operator(A, Qt, Tt)
    assert A.getRefCount() == before
    assert At.getRefCount() == 1
    assert At.norm() > 0.0
    At.destroy()


@pytest.mark.parametrize("linear", ["direct", "iterative"])
def test_released_step_operator_gives_the_same_residual_and_energy(solved, linear):
    """A static step with contact keeps no step operator ``A`` (issue 28): the residual
    ``A u − F`` (the support and contact forces) comes from the rows of ``A`` at the
    supports — the matrix product there, so the reactions do not move — and from the
    forms elsewhere; the strain energy ½ uᵀAu from the same product.  Reference:
    the product with ``A`` assembled here."""
    integ = solved[linear]
    assert integ.A is None
    m = integ.model
    A = m.combined_operator(0.0, 1.0, 0.0)
    u = integ.u.x.petsc_vec
    ref = A.createVecLeft()
    A.mult(u, ref)
    energy = 0.5 * ref.dot(u)
    ref.axpy(-1.0, integ.load)
    bc = m.bc_dofs()
    bc = bc[bc < m.num_owned]
    r = integ.residual.array_r

    def largest(values: np.ndarray) -> float:
        return COMM.allreduce(float(np.abs(values).max(initial=0.0)), op=MPI.MAX)

    scale = largest(ref.array_r)
    assert largest(ref.array_r[bc]) > 1e-3 * scale  # (the supports carry the load)
    # the supports' rows: the same entries summed in PETSc's order (bit for bit on one
    # rank; the grouping of its unrolled row sums may differ on several)
    assert largest(r[bc] - ref.array_r[bc]) <= 1e-14 * scale
    assert largest(r - ref.array_r) <= 1e-12 * scale
    assert integ.energy().strain == pytest.approx(energy, rel=1e-12)
    ref.destroy()
    A.destroy()


class _Spy(ContactSolver):
    """A contact solver that remembers the operator it was set up with."""

    def setup(self, A, *args, **kwargs):
        self.given = A
        super().setup(A, *args, **kwargs)


@pytest.mark.parametrize("linear", ["direct", "iterative"])
def test_set_up_destroys_the_operator_unless_the_split_basis_keeps_it(linear):
    """The integrator lets the contact solver destroy ``A_bc`` once transformed (issue 28):
    the iterative solver does, the low-rank solver's split basis keeps it; either way the
    step gives the displacement of the integrator of the fixture (to round-off)."""
    md, pg, m = _model()
    itf = build_interface(
        m.V, md.facet_tags, pg["upper_contact"], pg["lower_contact"], dirichlet_dofs=m.bc_dofs()
    )
    spy = _Spy(m.V, [itf])
    integ = Integrator(m, "static", 1.0, linear=linear, contact=spy)
    assert (spy.given.handle == 0) is (linear == "iterative")
    integ.step()
    ref = _contact_integrator(linear)
    ref.step()
    diff = integ.u.x.petsc_vec.copy()
    diff.axpy(-1.0, ref.u.x.petsc_vec)
    assert diff.norm() <= 1e-12 * ref.u.x.petsc_vec.norm()
    for obj in (diff, integ, ref):
        obj.destroy()


def test_cleared_product_is_returned_without_a_copy(solved):
    """Made inside ``lean_products`` (its record cleared), ``T Q A Qᵀ Tᵀ`` holds no
    reference to ``A`` either, and equals the copy made outside (exactly)."""
    integ = solved["iterative"]
    A = integ.A_bc
    Qt, Tt = integ.contact.Qt, integ.contact.system.Tt
    before = A.getRefCount()
    with lean_products(A.getComm().tompi4py(), all_at_once=True):
        At = transformed_operator(A, Qt, Tt, cleared=True)
    assert A.getRefCount() == before
    assert At.getRefCount() == 1
    with lean_products(A.getComm().tompi4py(), all_at_once=True):
        copy = transformed_operator(A, Qt, Tt)
    copy.axpy(-1.0, At)
    assert copy.norm() == 0.0
    for M in (At, copy):
        M.destroy()


@pytest.mark.parametrize("linear", ["direct", "iterative"])
def test_released_solver_work_solves_the_next_step_the_same(linear):
    """After ``release_solver_work`` (the iterative solver's preconditioner freed, a direct
    factorisation kept) the next load step gives the active set and displacement of an
    integrator that kept everything (to the Krylov tolerance)."""
    runs = []
    for release in (False, True):
        integ = _contact_integrator(linear, dt=0.5)  # (two load steps)
        integ.step()
        if release:
            integ.release_solver_work()
        integ.step()
        runs.append(integ)
    kept, freed = runs
    assert all(np.array_equal(a, b) for a, b in zip(kept.contact.active, freed.contact.active))
    diff = freed.u.x.petsc_vec.copy()
    diff.axpy(-1.0, kept.u.x.petsc_vec)
    assert diff.norm() <= 1e-9 * kept.u.x.petsc_vec.norm()
    for obj in (diff, *runs):
        obj.destroy()
