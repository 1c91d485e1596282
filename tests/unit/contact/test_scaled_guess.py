"""The scaled warm start of the Krylov strategy (bonecontact.contact.krylov.scale_initial_guess).

References, independent of the code under test: a system ``B x* = r`` made from a chosen
``x*`` (``r := B x*``), so its solution is known exactly; the energy norm of the error
``(x − x*)ᵀ B (x − x*)``, whose minimiser on the line ``α y`` is ``α = yᵀ r / yᵀ B y``
(a quadratic in ``α``); for a guess ``c x*`` the minimiser is ``1/c``.

Family: the condensed contact operator of the load-driven hemisphere (fixed normal rows
and supports eliminated, as the PDAS does) and a 1D Laplacian with eliminated rows ×
guesses (zero, ``c x*`` for several ``c``, ``x*`` plus noise); serially and under
``mpiexec -n 2`` / ``-n 3``.
"""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest
from laplacian import laplacian_1d

from bonecontact.contact.krylov import scale_initial_guess
from bonecontact.verification.load_driven import sphere_on_block_3d

COMM = MPI.COMM_WORLD
SIZE = (6e-4, 4.5e-3)  # (h_contact, h_far): 4551 dofs


def _laplacian(n: int = 400) -> tuple[PETSc.Mat, np.ndarray]:
    """The 1D Laplacian (Dirichlet ends) with every 37th row eliminated as the PDAS
    eliminates rows (row and column zeroed, diagonal 3): the matrix and this rank's
    eliminated local rows."""
    A = laplacian_1d(n, COMM)
    r0, r1 = A.getOwnershipRange()
    rows = np.arange(0, n, 37, dtype=PETSc.IntType)
    A.zeroRowsColumns(rows, diag=3.0)
    mine = rows[(rows >= r0) & (rows < r1)] - r0
    return A, mine.astype(np.int64)


@pytest.fixture(scope="module")
def contact_system():
    """The condensed operator of the load-driven problem after its solve (the settled
    set's fixed rows and the supports eliminated) and those eliminated local rows."""
    pb = sphere_on_block_3d(COMM, SIZE[0], h_far=SIZE[1], linear="iterative")
    pb.solve()
    B = pb.integrator.contact.linear_solver.B
    yield B, _identity_rows(B)
    pb.destroy()


def _identity_rows(B: PETSc.Mat) -> np.ndarray:
    """This rank's rows of ``B`` with no off-diagonal entry (the eliminated rows)."""
    r0, r1 = B.getOwnershipRange()
    out = []
    for i in range(r0, r1):
        cols, vals = B.getRow(i)
        if np.all((cols == i) | (vals == 0.0)):
            out.append(i - r0)
    return np.asarray(out, dtype=np.int64)


def _system(kind: str, contact_system) -> tuple[PETSc.Mat, np.ndarray]:
    return _laplacian() if kind == "laplacian" else contact_system


def _energy_error(B: PETSc.Mat, x: PETSc.Vec, xs: PETSc.Vec) -> float:
    e = x.copy()
    e.axpy(-1.0, xs)
    Be = e.duplicate()
    B.mult(e, Be)
    out = e.dot(Be)
    e.destroy(), Be.destroy()
    return float(out)


def _exact(B: PETSc.Mat, eliminated: np.ndarray) -> tuple[PETSc.Vec, PETSc.Vec]:
    """A smooth solution ``x*`` (nonzero also in the eliminated rows) and ``r = B x*``."""
    xs, r = B.createVecs()
    r0 = xs.getOwnershipRange()[0]
    g = np.arange(r0, r0 + xs.getLocalSize(), dtype=float)
    xs.array[:] = np.sin(0.01 * g) + 0.3 * np.cos(0.003 * g)
    B.mult(xs, r)
    return xs, r


KINDS = ["laplacian", "contact"]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("c", [0.06, 0.5, 1.0, 1.5, 17.0])
def test_a_multiple_of_the_solution_is_scaled_back(kind, c, contact_system):
    """A guess ``c x*`` (eliminated rows off too) becomes ``x*``: ``α = 1/c`` and the
    guess equals ``x*`` to round-off (``c = 1``: kept, already ``x*``)."""
    B, elim = _system(kind, contact_system)
    xs, r = _exact(B, elim)
    x = xs.copy()
    x.scale(c)
    alpha = scale_initial_guess(B, r, x, elim, xs.array[elim])
    assert abs(alpha * c - 1.0) < 1e-10
    x.axpy(-1.0, xs)
    assert x.norm() <= 1e-10 * xs.norm()


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("c", [0.95, 1.08])
def test_a_guess_near_its_best_multiple_is_kept(kind, c, contact_system):
    """A guess ``c x*`` with ``|1/c − 1|`` within ``SCALE_KEEP_WITHIN``: ``α = 1/c``
    reported, the guess left exactly as it was (eliminated rows included)."""
    B, elim = _system(kind, contact_system)
    xs, r = _exact(B, elim)
    x = xs.copy()
    x.scale(c)
    before = x.array.copy()
    alpha = scale_initial_guess(B, r, x, elim, xs.array[elim])
    assert abs(alpha * c - 1.0) < 1e-10
    assert np.array_equal(x.array, before)


@pytest.mark.parametrize("kind", KINDS)
def test_a_zero_guess_gives_the_lift(kind, contact_system):
    """A zero guess: ``α = 0``, the eliminated rows at their values, zero elsewhere."""
    B, elim = _system(kind, contact_system)
    xs, r = _exact(B, elim)
    x = xs.duplicate()
    x.set(0.0)
    alpha = scale_initial_guess(B, r, x, elim, xs.array[elim])
    assert alpha == 0.0
    assert np.array_equal(x.array[elim], xs.array[elim])
    free = np.ones(x.getLocalSize(), bool)
    free[elim] = False
    assert not np.any(x.array[free])
    assert COMM.allreduce(elim.size, op=MPI.SUM) > 0


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("seed", [0, 1])
def test_the_factor_minimises_the_energy_error(kind, seed, contact_system):
    """A noisy guess ``3 x* + noise``: the scaled guess's energy error is below that of
    the guess with its eliminated rows set and of the lift alone, and below that of
    ``α (1 ± 1 %)`` (the minimum of the quadratic)."""
    B, elim = _system(kind, contact_system)
    xs, r = _exact(B, elim)
    rng = np.random.default_rng(seed + 10 * COMM.rank)
    guess = xs.copy()
    guess.scale(3.0)
    guess.array[:] += 0.5 * rng.standard_normal(guess.getLocalSize())
    x = guess.copy()
    alpha = scale_initial_guess(B, r, x, elim, xs.array[elim])
    e_scaled = _energy_error(B, x, xs)
    others = []
    for a in (1.0 / alpha, 0.0, 0.99, 1.01):  # (relative to the scaled guess: factor a)
        y = x.copy()
        y.array[elim] = 0.0
        y.scale(a)
        y.array[elim] = xs.array[elim]
        others.append(_energy_error(B, y, xs))
        y.destroy()
    assert all(e_scaled < e for e in others)
