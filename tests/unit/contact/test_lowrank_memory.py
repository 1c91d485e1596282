"""What the direct (low-rank, split basis) path keeps beside its factorisation (issue 28:
a contact run within 1.3 times the memory of one MUMPS solve).

Counted, not timed: the matrices of operator size alive after a contact solve (none:
the factorised split operator is freed once factorised, there is no copy of it to
factorise and no full condensed operator ``Ã``, whose contact rows are all the residuals
need), and the reference count of
the operator the split basis is built from (a PETSc product keeps its factors alive for
as long as it lives).  Re-splitting (a new basis, factorised in place again) and never
re-splitting give the solution of the refactorising strategy to 1e-10, on the two-block
partial lift-off model (serial and on ranks).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import numpy as np
import pytest
from two_blocks import partial_liftoff_model

from bonecontact.contact.interface import build_interface
from bonecontact.contact.lowrank import SplitBasis
from bonecontact.contact.options import PDASOptions
from bonecontact.contact.pdas import ContactSolver
from bonecontact.mechanics.integrator import Integrator

COMM = MPI.COMM_WORLD
#: rebase_ratio of the cases: never re-split, always re-split (a new basis per new set)
POLICIES = {"never_resplit": 1e12, "always_resplit": 0.0}


def _integrator(**options) -> Integrator:
    md, pg, m = partial_liftoff_model(COMM)
    itf = build_interface(
        m.V, md.facet_tags, pg["upper_contact"], pg["lower_contact"], dirichlet_dofs=m.bc_dofs()
    )
    contact = ContactSolver(m.V, [itf], PDASOptions.from_fields(cold_start_fraction=0.0, **options))
    return Integrator(m, "static", 1.0, linear="direct", contact=contact)


def _nnz(M) -> int:
    return int(COMM.allreduce(int(M.getInfo(M.InfoType.LOCAL)["nz_used"]), op=MPI.SUM))


@pytest.fixture(scope="module")
def reference() -> tuple[np.ndarray, list]:
    integ = _integrator(strategy="refactor")
    integ.step()
    out = integ.u.x.petsc_vec.copy(), integ.last_contact.history
    integ.destroy()
    return out


@pytest.mark.parametrize("policy", list(POLICIES))
def test_split_path_keeps_one_operator(reference, policy):
    integ = _integrator(rebase_ratio=POLICIES[policy])
    integ.step()
    u_ref, history = reference
    lr = integ.contact.linear_solver.lowrank
    assert lr.split is not None
    resplits = lr.resplits
    assert (resplits > 0) == (policy == "always_resplit")
    # the solution of the refactorising strategy, through the same sets
    assert [h["active"] for h in integ.last_contact.history] == [h["active"] for h in history]
    d = integ.u.x.petsc_vec.copy()
    d.axpy(-1.0, u_ref)
    assert d.norm() <= 1e-10 * u_ref.norm()
    d.destroy()
    # matrices alive: once factorised, the split operator itself is freed (its values are
    # in the factors; the KSP keeps the factors and a diagonal), and no matrix of its size
    # is held by the solver or the condensed system (no copy of it, no Ã)
    size = _nnz(integ.A_bc)
    held = [lr.AL, lr.AC, lr.split.J, lr.split.Jt, *integ.contact.system.matrices().values()]
    held += [M for M in lr.ksp.getOperators() if M.handle]
    large = [M for M in held if M.handle and _nnz(M) >= 0.5 * size]
    assert large == []
    assert lr.ksp.getOperators()[0].getSizes() == integ.A_bc.getSizes()
    assert _nnz(lr.ksp.getOperators()[0]) == integ.A_bc.getSize()[0]  # (a diagonal)
    integ.destroy()


def test_split_operator_holds_no_reference_to_its_factors():
    """``K = T Q_P A Q_Pᵀ Tᵀ`` and ``J`` are kept without PETSc's product record: ``A``'s
    reference count is that of before, and ``K`` is referenced once."""
    integ = _integrator()
    A = integ.A_bc
    sy = integ.contact.system
    lay = sy.layout
    patch = lay.local_rows[: lay.bs * min(lay.n_nodes, 3)].astype(np.int64) + sy.start
    before = A.getRefCount()
    split = SplitBasis(A, sy.Qt, sy.T, sy.Tt, patch, np.ones(lay.n_rows, dtype=bool))
    assert A.getRefCount() == before
    assert split.K.getRefCount() == 1 and split.J.getRefCount() == 1
    assert split.K.norm() > 0.0
    split.destroy()
    integ.destroy()
