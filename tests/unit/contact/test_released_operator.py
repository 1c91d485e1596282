"""The integrator releases its operator with Dirichlet rows (``A_bc``) once the contact
solver is set up (issue 28: one matrix less during the contact solve).

The two-block scene of ``test_pdas.py`` (partial lift-off) for the direct (low-rank, which
keeps its own reference to the operator) and the iterative solver: after the release a
step still solves, both solvers give the same displacement (to the Krylov tolerance), and
``A_bc`` asked for afterwards is built again equal to that of an integrator without
contact (same entries, to round-off).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import pytest
from two_blocks import partial_liftoff_model

from bonecontact.contact.interface import build_interface, transformed_operator
from bonecontact.contact.pdas import ContactSolver
from bonecontact.mechanics.integrator import Integrator

COMM = MPI.COMM_WORLD


def _model():
    return partial_liftoff_model(COMM)


def _contact_integrator(linear: str) -> Integrator:
    md, pg, m = _model()
    itf = build_interface(
        m.V, md.facet_tags, pg["upper_contact"], pg["lower_contact"], dirichlet_dofs=m.bc_dofs()
    )
    return Integrator(m, "static", 1.0, linear=linear, contact=ContactSolver(m.V, [itf]))


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
