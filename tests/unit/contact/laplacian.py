"""The 1D Laplacian (Dirichlet ends) as a distributed PETSc matrix, shared by the
multigrid and warm-start tests: its Jacobi-scaled eigenvalues are ``1 − cos(kπ/(n+1))``.

Not a test module (no ``test_`` prefix); the contact tests import it by name (pytest puts
this folder on ``sys.path``).
"""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc


def laplacian_1d(n: int, comm: MPI.Comm = MPI.COMM_WORLD) -> PETSc.Mat:
    """The tridiagonal ``(-1, 2, -1)`` matrix of order ``n``, rows split over ``comm``."""
    A = PETSc.Mat().createAIJ(((PETSc.DECIDE, n), (PETSc.DECIDE, n)), nnz=(3, 2), comm=comm)
    r0, r1 = A.getOwnershipRange()
    for i in range(r0, r1):
        cols = [j for j in (i - 1, i, i + 1) if 0 <= j < n]
        A.setValues([i], cols, [2.0 if j == i else -1.0 for j in cols])
    A.assemble()
    return A
