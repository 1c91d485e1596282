"""Reference solver for bound-constrained linear systems: PETSc SNES ``vinewtonrsls``.

An independent check of the PDAS (:mod:`bonecontact.contact.pdas`): for a body pressed
onto a rigid plane the dual-mortar constraint is nodal, so ``A x = b`` with bounds on
the normal unknowns is the same discrete problem.  Used by the tests and benchmarks.
"""

from __future__ import annotations

from petsc4py import PETSc

__all__ = ["snes_vi_solve"]


def snes_vi_solve(
    A: PETSc.Mat, b: PETSc.Vec, lower: PETSc.Vec, upper: PETSc.Vec, prefix: str = "vi_"
) -> tuple[PETSc.Vec, int, int]:
    """Independent reference: solve ``A x = b`` subject to ``lower ≤ x ≤ upper`` with
    PETSc's reduced-space active-set Newton (SNES ``vinewtonrsls``, MUMPS inside).

    For a body pressed onto a rigid plane the dual-mortar constraint is nodal, so this
    is the same discrete problem as the PDAS solves (tests and benchmarks compare them).

    Returns
    -------
    (x, iterations, converged_reason)
    """
    snes = PETSc.SNES().create(A.getComm())
    snes.setOptionsPrefix(prefix)
    r = A.createVecLeft()

    def residual(snes_, x, f):
        A.mult(x, f)
        f.axpy(-1.0, b)

    def jacobian(snes_, x, J, P):
        return True  # linear problem: the Jacobian is A

    snes.setFunction(residual, r)
    snes.setJacobian(jacobian, A, A)
    snes.setType("vinewtonrsls")
    snes.getLineSearch().setType("basic")
    snes.setVariableBounds(lower, upper)
    snes.setTolerances(atol=1e-12 * b.norm(), rtol=1e-12, stol=0.0, max_it=200)
    ksp = snes.getKSP()
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("mumps")
    snes.setFromOptions()
    x = A.createVecRight()
    x.set(0.0)
    snes.solve(None, x)
    out = (x, snes.getIterationNumber(), snes.getConvergedReason())
    snes.destroy()
    r.destroy()
    return out
