"""One LU factorisation for a whole PDAS solve (and for many of them): low-rank updates.

One *base* set is factorised; the condensed system of any other active set is solved
exactly through a small dense system with one unknown per row in which the set differs
from the base (a force that fixes a newly active row, a value that frees a released
one, or a replaced 3D slip equation). Columns of the base's inverse are computed in
blocks by MUMPS multi-right-hand-side solves (with sparse right-hand sides: the forward
substitution visits only the fronts their entries reach) when first needed and cached
across iterations and steps; when they would cost more than a factorisation, the current set
becomes the new base. With a :class:`SplitBasis` (the default) only the cold start's
support patch is in the contact basis of the factorised operator, so its LU factors are
those of the plain operator. The result equals refactorising every iteration, to
round-off. Theory: docs/theory/pdas.md#low-rank-updates, #split-basis and
#sparse-right-hand-sides.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
from scipy.linalg import lapack
from scipy.linalg.blas import daxpy as _daxpy

from bonecontact.common.blas import one_blas_thread
from bonecontact.common.errors import RunError
from bonecontact.common.linalg import configure_ksp, set_solver_options, solver_options
from bonecontact.contact.reductions import (
    gather_rows,
    global_any,
    global_count,
    global_op,
    global_vsum,
)

__all__ = [
    "DENSE_BLOCKS",
    "MIN_BLOCK",
    "RESPLIT_FIXED",
    "RESPLIT_GROWTH",
    "SOLVE_RATE",
    "SOLVE_RATE_PARALLEL",
    "SOLVE_RATE_SPARSE",
    "SPARSE_BLOCKS",
    "LowRankActiveSetSolver",
    "SingularActiveSetError",
    "SplitBasis",
    "factorise_with_workspace_retry",
    "mumps_failure",
    "mumps_workspace_short",
    "null_pivots",
    "retry_workspace",
    "solve_small_system",
]


class SingularActiveSetError(RunError):
    """The system of an active set is singular (e.g. a body left without support)."""


def null_pivots(ksp: PETSc.KSP) -> int:
    """Null pivots MUMPS found in the last factorisation of ``ksp`` (needs ICNTL(24) = 1)."""
    pc = ksp.getPC()
    if pc.getType() != "lu" or pc.getFactorSolverType() != "mumps":
        return 0
    return int(pc.getFactorMatrix().getMumpsInfog(28))


def mumps_failure(ksp: PETSc.KSP) -> str | None:
    """What went wrong in the last MUMPS factorisation of ``ksp`` (``None``: nothing).

    PETSc records a failed MUMPS factorisation without raising; a solve with it then fails
    with INFOG(1) = -3 ("factorisation not done"), far from the cause.  Collective values:
    INFOG is the same on every rank.
    """
    pc = ksp.getPC()
    if pc.getType() != "lu" or pc.getFactorSolverType() != "mumps":
        return None
    F = pc.getFactorMatrix()
    info1, info2 = int(F.getMumpsInfog(1)), int(F.getMumpsInfog(2))
    if info1 >= 0:
        return None
    return f"MUMPS factorisation failed: INFOG(1) = {info1}, INFOG(2) = {info2}"


#: MUMPS errors (INFOG(1)) of a work space estimated too small in the analysis: integer
#: or real work space of the factorisation or the solution, send or receive buffers.  A
#: factorisation that fails with one of them is redone with ICNTL(14), the extra work
#: space in per cent of the estimate, raised to 40, 80, 160 (at most ``WORKSPACE_RETRIES`` times):
#: the estimate can fall short on several ranks when the pivoting differs from the
#: analysis's guess (a 3-rank restart of a surface-crack scene, INFOG(1) = -9).
MUMPS_WORKSPACE_ERRORS = frozenset({-8, -9, -11, -14, -17, -20})
WORKSPACE_RETRIES = 3


def mumps_workspace_short(ksp: PETSc.KSP) -> bool:
    """Whether the last MUMPS factorisation of ``ksp`` failed for lack of work space
    (:data:`MUMPS_WORKSPACE_ERRORS`; collective: INFOG is the same on every rank)."""
    pc = ksp.getPC()
    if pc.getType() != "lu" or pc.getFactorSolverType() != "mumps":
        return False
    return int(pc.getFactorMatrix().getMumpsInfog(1)) in MUMPS_WORKSPACE_ERRORS


def retry_workspace(ksp: PETSc.KSP, workspace: int | None, attempt: int) -> int | None:
    """The ICNTL(14) with which to redo the last MUMPS factorisation of ``ksp``: twice
    ``workspace`` (at least 40 %) if it ran out of work space and ``attempt`` (0 for the
    first factorisation) is below :data:`WORKSPACE_RETRIES`, else ``None`` (keep it).
    Collective."""
    if attempt >= WORKSPACE_RETRIES or not mumps_workspace_short(ksp):
        return None
    return 2 * max(workspace or 20, 20)


def factorise_with_workspace_retry(
    ksp: PETSc.KSP, factorise: Callable[[], None], workspace: int | None, what: str
) -> int | None:
    """Run ``factorise`` (a set-up or solve of ``ksp`` that factorises with MUMPS); while
    the factorisation runs out of work space, redo it with a new factor and ICNTL(14)
    doubled (:func:`retry_workspace`).  Shared by the low-rank solver's base factorisation
    and the refactorising strategy
    (:class:`~bonecontact.contact.linear_strategy.RefactorStrategy`).

    Returns the ICNTL(14) in force afterwards (``workspace`` if no retry was needed); a
    PETSc error raises :class:`SingularActiveSetError` naming ``what``.  Collective."""
    for attempt in range(WORKSPACE_RETRIES + 1):
        try:
            factorise()
        except PETSc.Error as exc:
            raise SingularActiveSetError(f"{what} failed (PETSc error {exc.ierr})") from None
        more = retry_workspace(ksp, workspace, attempt)
        if more is None:
            break
        workspace = more
        set_solver_options(ksp, {"mat_mumps_icntl_14": workspace})
        ksp.getPC().reset()  # (a new factor, which reads ICNTL(14))
    return workspace


#: Dense ``n_local × k`` arrays alive while a block of ``k`` columns is computed (right-hand
#: sides, solutions, A times them, a copy for the rows, MUMPS's work space).
DENSE_BLOCKS = 5
#: The same for a block with sparse right-hand sides: the solutions, the solver's own copy
#: of them and its work space (the right-hand sides are a sparse matrix, and the split
#: basis's correction is taken at the contact rows only: no other ``n_local × k`` array).
SPARSE_BLOCKS = 3
#: Smallest chunk of columns and smallest cache (columns), whatever the memory.
MIN_BLOCK = 16
#: Rate of a block of columns (forward and backward substitutions) relative to a
#: factorisation, in floating-point operations per second: MUMPS on the 3D load-driven
#: Hertz benchmark, 65k dofs, serially (2.3 against 4.5 GFlop/s); on more than one rank
#: the distributed substitutions gain far less from blocking.
SOLVE_RATE, SOLVE_RATE_PARALLEL = 0.5, 0.33
#: The same for a block with sparse right-hand sides on one rank (the forward
#: substitution visits only the fronts their entries reach): 0.55 of a dense block's time
#: on the knee's 126k-dof factors (0.9), 1.0-1.5 measured on the 2D Hertz meshes of 28k
#: and 53k dofs.  On two ranks a sparse block measured 0.26-0.29 (SOLVE_RATE_PARALLEL).
SOLVE_RATE_SPARSE = 0.9
#: A new split basis with the contact zone in it, relative to the present factorisation
#: (operations): the zone's interface coupling adds fill (1.4 times the operations with
#: the 452 contact nodes at 65k dofs), and the new pattern a new analysis and the
#: rebuilt operators.  At 65k dofs the two choices measured alike on a loaded machine
#: (452 columns: ratio 2.2-2.8 to a linear solve, a re-split: 2.7-3.1), so a re-split
#: is made only when it is clearly cheaper.
RESPLIT_GROWTH = 2.0
#: What a re-split costs beyond ``RESPLIT_GROWTH`` factorisations, in operations per
#: entry of the present LU factors (one rank, more ranks): the new split's products
#: (``K``, ``J``, their rows and columns), MUMPS's new analysis (ordering, symbolic
#: factorisation; on several ranks the matrix is gathered for it) and the base solve.
#: Measured on the 2D Hertz meshes of 28k and 53k dofs: 64-88 entries' worth on one rank
#: and 199-258 on two, whose factorisations have only 100-140 operations per entry; on
#: 3D factors (400 and more per entry) it adds a tenth or less.
RESPLIT_FIXED = (100.0, 200.0)


class SplitBasis:
    """The operator with only the support patch in the contact basis.

    The contact basis ``Ũ = T Q⁻ᵀ U`` couples every slave node within the search
    distance with the master nodes it faces, and its operator ``T Q A Qᵀ Tᵀ`` has
    the interface coupling of all of them: on the 3D load-driven Hertz benchmark
    (25k dofs, 1098 slave nodes) 1.8× the nonzeros of ``A`` and 1.9× the entries in the
    LU factors, whose factorisation takes 2–3 times as long as one of ``A``.  Only the
    nodes in contact need the basis.  With ``Q_P`` the transformation restricted to
    the nodes of the support patch ``P`` (their rows of ``Q``; identity rows for the
    other slave nodes), the base operator is ``K = T Q_P A Q_Pᵀ Tᵀ`` and its unknowns
    ``V = T Q_P⁻ᵀ U``.  With ``N = Qᵀ − I`` (slave rows, master columns; ``N² = 0``) and
    ``N_R`` its rows outside ``P``, ``J = T N_R Tᵀ``:

    * ``Ũ = (I − J) V`` (``J`` has only non-patch slave rows);
    * the residual ``T Q (F − A U)`` equals ``T Q_P (F − A U)`` at every slave row, so
      the contact forces are the residuals of ``K`` there;
    * a contact force ``f`` at slave rows outside ``P`` is ``(I − Jᵀ) f`` in ``K``'s
      rows (the master side of the mortar), and ``T Q b = T Q_P b + Jᵀ T b``.

    Rows of ``P`` are rows of the contact basis in both, so the base can fix them (the
    cold start's first system, with the bodies tied at the patch); every other set is
    reached by force columns.  ``K`` has the fill of the patch only.

    Parameters
    ----------
    A
        The operator with Dirichlet rows eliminated (original basis).
    Qt, T, Tt
        ``Qᵀ``, the rotation ``T`` and ``Tᵀ`` of the contact solver.
    patch_rows
        Owned global rows (all components) of the patch's slave nodes.
    allowed
        Mask of this rank's contact rows that may be fixed in the base.
    """

    def __init__(
        self,
        A: PETSc.Mat,
        Qt: PETSc.Mat,
        T: PETSc.Mat,
        Tt: PETSc.Mat,
        patch_rows: npt.NDArray,
        allowed: npt.NDArray[np.bool_],
    ):
        self.allowed = np.asarray(allowed, dtype=bool)
        QtP = _rows_outside_identity(Qt, np.asarray(patch_rows, dtype=np.int64), keep=True)
        NR = _rows_outside_identity(Qt, np.asarray(patch_rows, dtype=np.int64), keep=False)
        P = QtP.matMult(Tt)
        # one triple product, kept as a plain copy: a product keeps its factors (and its
        # intermediate data) alive for as long as it lives (issue 28)
        self.K = _plain(A.PtAP(P))
        TN = T.matMult(NR)  # (NR = Qᵀ − Q_Pᵀ: the coupling of the non-patch rows)
        self.J = _plain(TN.matMult(Tt))
        self.Jt = self.J.transpose(PETSc.Mat())
        self._jt: tuple[npt.NDArray, ...] | None = None
        for M in (QtP, NR, TN, P):
            M.destroy()

    def jt_entries(self) -> tuple[npt.NDArray, npt.NDArray, npt.NDArray]:
        """This rank's entries of ``Jᵀ`` as ``(local row, global column, value)`` (kept:
        a force column's master side is a column of it, :meth:`LowRankActiveSetSolver.
        _split_forces`, without a product per block)."""
        if self._jt is None:
            ai, aj, av = self.Jt.getValuesCSR()
            rows = np.repeat(np.arange(ai.size - 1, dtype=np.int64), np.diff(ai))
            self._jt = (rows, aj.astype(np.int64), av.copy())
        return self._jt

    def destroy(self) -> None:
        for M in (self.K, self.J, self.Jt):
            M.destroy()


def _plain(product: PETSc.Mat) -> PETSc.Mat:
    """A copy of a matrix product without its product record (which holds references to
    the factors and intermediate data); the product is destroyed."""
    try:
        return product.duplicate(copy=True)
    finally:
        product.destroy()


def _rows_outside_identity(Qt: PETSc.Mat, patch_rows: npt.NDArray, keep: bool) -> PETSc.Mat:
    """``keep``: ``Qᵀ`` with identity rows outside ``patch_rows`` (``Q_Pᵀ``); otherwise
    ``Qᵀ − Q_Pᵀ``: the off-diagonal entries of the other rows.  A fresh pattern (no
    stored zeros, so products do not fill in)."""
    lo, hi = Qt.getOwnershipRange()
    ai, aj, av = Qt.getValuesCSR()
    rows = np.repeat(np.arange(lo, hi, dtype=np.int64), np.diff(ai))
    aj = aj.astype(np.int64)
    in_patch = np.isin(rows, patch_rows)
    diag = aj == rows
    sel = (in_patch | diag) if keep else (~in_patch & ~diag)
    r, c, v = rows[sel], aj[sel], av[sel]
    counts = np.bincount(r - lo, minlength=hi - lo)
    indptr = np.concatenate([[0], np.cumsum(counts)]).astype(PETSc.IntType)
    M = PETSc.Mat().createAIJ(
        size=Qt.getSizes(),
        csr=(indptr, c.astype(PETSc.IntType), v),
        comm=Qt.getComm(),
    )
    M.assemble()
    return M


def _exscan(comm: MPI.Comm, n: int) -> int:
    """Sum of ``n`` over the lower ranks."""
    return int(comm.exscan(n) or 0) if comm.size > 1 else 0


def _dense(comm: MPI.Comm, nloc: int, k: int) -> PETSc.Mat:
    M = PETSc.Mat().createDense(((nloc, PETSc.DECIDE), (PETSc.DECIDE, k)), comm=comm)
    M.setUp()  # PETSc allocates the dense block zeroed
    M.assemble()
    return M


def _equilibration(M: npt.NDArray) -> tuple[npt.NDArray, npt.NDArray]:
    """Row and column scales ``r, c`` making every row and then every column of
    ``diag(r) M diag(c)`` of largest magnitude one (a zero row or column keeps scale 1)."""
    big = np.abs(M).max(axis=1)
    r = 1.0 / np.where(big > 0.0, big, 1.0)
    big = np.abs(M * r[:, None]).max(axis=0)
    return r, 1.0 / np.where(big > 0.0, big, 1.0)


def solve_small_system(
    M: npt.NDArray, rhs: npt.NDArray, cols: list[int] | None = None
) -> npt.NDArray:
    """Solve the small dense system of a set, equilibrated (rows, then columns, scaled to
    a largest entry of one); one LU and LAPACK's O(m²) 1-norm condition estimate of the
    equilibrated matrix (not an SVD per iteration).

    The rows of the small system mix prescribed values, forces and 3D slip equations
    whose scale grows as ``1/|ξ|`` (``|ξ| ≪ ĝ`` gives rows 10⁸ × the others): the
    condition of the unscaled matrix measures that scale, not the set (measured on a
    knee: 1-norm condition > 1e13 unscaled, 214 equilibrated, the same solution to
    1e-14; docs/theory/pdas.md#small-system-scaling).  Raises
    :class:`SingularActiveSetError` above an equilibrated condition number of 1e13,
    naming the global positions ``cols`` of the rows the near-null vector involves."""
    r, c = _equilibration(M)
    Me = M * r[:, None] * c[None, :]
    with one_blas_thread():  # (threads cost more than they save here, and spin)
        lu, piv, info = lapack.dgetrf(Me)
        norm1 = float(np.abs(Me).sum(axis=0).max())
        rcond = lapack.dgecon(lu, norm1, norm="1")[0] if info == 0 else 0.0
    if rcond < 1e-13:
        n = M.shape[0]
        raise SingularActiveSetError(
            f"the system of the active set is singular (condition number of the "
            f"{n}×{n} update > 1e13 after equilibration){_null_rows(Me, cols)}"
        )
    with one_blas_thread():
        return c * lapack.dgetrs(lu, piv, r * rhs)[0]


def _null_rows(Me: npt.NDArray, cols: list[int] | None) -> str:
    """The contact rows (global positions ``cols``) carrying most of the near-null
    vector of ``Me`` (an SVD, on failure only)."""
    if not cols:
        return ""
    v = np.abs(np.linalg.svd(Me)[2][-1])
    top = np.argsort(-v)[: min(6, v.size)]
    shown = ", ".join(f"{cols[i]} ({v[i]:.2f})" for i in top)
    return f"; near-null vector on the contact rows (global position, weight): {shown}"


class LowRankActiveSetSolver:
    """Solve ``B_A x = b_A`` for changing sets ``A`` of fixed slave-normal unknowns.

    Parameters
    ----------
    A
        The operator in the nodal frames (``T Â Tᵀ`` of
        :class:`bonecontact.contact.pdas.ContactSolver`).
    bc_rows
        Owned global rows with Dirichlet conditions (always eliminated).
    rows
        The owned *local* rows of the contact unknowns (slave normal and tangential
        rows in the nodal frames), in the order of the PDAS's per-row arrays.
    diag_value
        Diagonal put on eliminated rows (as in the refactorising solver).
    prefix
        PETSc options prefix of the LU solver (MUMPS by default).
    max_columns
        Cache limit (columns); beyond it the base is refactorised.
    rebase_ratio
        Refactorise when the columns an iteration needs are estimated to cost more than
        ``rebase_ratio`` factorisations.
    memory_ratio
        Memory of the column blocks, and of the column cache, each at most this
        fraction of the memory of the LU factors (blocks are computed in chunks; the
        cache limit is the smaller of this and ``max_columns``).
    full_ratio
        Memory bound of the full solution columns kept across contact solves (the final
        field ``x_b + X y`` without a second solve), as a fraction of the LU factors'
        memory: within it, the columns kept are sized by the expected contact zone
        (:meth:`_size_full_columns`; docs/theory/pdas.md#full-columns-across-steps).
    split
        Optional ``(A, Qᵀ, T, Tᵀ, allowed, first)``: factorise the operator with only the
        contact rows ``allowed`` (this rank's rows; all rows of the support patch's
        nodes) in the contact basis, :class:`SplitBasis`, and with the rows ``first``
        fixed (the cold start's first set), whatever set a solve starts from (the
        first argument ``A`` is then not used).
    """

    #: column blocks solved with sparse right-hand sides (MUMPS only; otherwise, and for a
    #: block with the base solve, dense): the same columns to round-off, in about half the
    #: operations (docs/theory/pdas.md#sparse-right-hand-sides)
    sparse_rhs: bool = True

    def __init__(
        self,
        A: PETSc.Mat,
        bc_rows: npt.NDArray,
        rows: npt.NDArray,
        diag_value: float,
        prefix: str = "bc_contact_lr_",
        max_columns: int = 2000,
        rebase_ratio: float = 1.0,
        memory_ratio: float = 0.05,
        split: tuple | None = None,
        full_ratio: float = 0.25,
    ):
        self.split: SplitBasis | None = None
        if split is not None:
            A0, Qt, T, Tt, allowed, first = split
            self._split_args = (A0, Qt, T, Tt)
            self.split = self._make_split(np.asarray(allowed, dtype=bool), rows)
            self.split.first = np.asarray(first, dtype=bool)
            A = self.split.K
        self.A = A
        self.comm: MPI.Comm = A.getComm().tompi4py()
        self.start = A.getOwnershipRange()[0]
        self.nloc = A.getLocalSize()[0]
        self.bc_rows = np.asarray(bc_rows, dtype=PETSc.IntType)
        self.bc_local = (self.bc_rows - self.start).astype(np.int32)
        self.L = np.asarray(rows, dtype=np.int32)
        # this rank's contact rows are the global positions offset … offset + L.size − 1
        self.offset = _exscan(self.comm, int(self.L.size))
        self.diag_value = float(diag_value)
        self.max_columns = int(max_columns)
        self.rebase_ratio = float(rebase_ratio)
        self.memory_ratio = float(memory_ratio)
        self.full_ratio = float(full_ratio)
        self.block_limit = self.column_limit = self.sparse_limit = self.max_columns
        # the contact rows of A (A·X is only ever needed there) and its columns at the
        # rows a set may fix (A·v is only ever needed for v zero elsewhere)
        self.AL = self._contact_rows(A)
        self.JL = self._contact_rows(self.split.J) if self.split is not None else None
        self.AC, self._cols = self._fixed_columns(A)
        self.B0 = self._base_matrix(A)
        self.prefix = prefix
        #: ICNTL(14) after a factorisation ran out of work space (``None``: MUMPS's own)
        self.workspace: int | None = None
        self.ksp = self._make_ksp()
        self.resplits = 0
        self._new_pattern = True
        self._in_respond = False
        self._r0_orig: PETSc.Vec | None = None
        if self.split is not None:  # the node of every contact row of this rank
            bs = max(self._split_args[0].getBlockSize(), 1)
            self._node = (self.L.astype(np.int64) + self.start) // bs
        self.base: npt.NDArray[np.bool_] | None = None
        self.cache: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        #: full columns X (this rank's rows) of cached positions, within ``full_limit``:
        #: the final field of a solve is then ``x_b + X y`` without a second solve
        self.full_cols: dict[int, np.ndarray] = {}
        self.full_limit = 0
        #: full columns within ``memory_ratio`` (the floor of :attr:`full_limit`), within
        #: ``full_ratio`` (its cap), the most a finished solve used, and the largest
        #: memory the kept ones took on any rank (bytes; reported)
        self.full_floor = self.full_cap = self.full_used = 0
        self.full_bytes_peak = 0.0
        #: single-right-hand-side solves (base and final solves; the final ones also
        #: apart) and multi-right-hand-side column blocks: counts that do not depend on
        #: the load
        self.n_solves = self.n_final = self.n_blocks = 0
        #: the last margins of the rows (:meth:`solve_set`), the fixed rows of the last
        #: contact solve's start, and the columns computed ahead (:meth:`_prefetch_rows`)
        self._margin: npt.NDArray[np.float64] | None = None
        self._start_prev: npt.NDArray[np.bool_] | None = None
        self.prefetched = 0
        #: columns that filled the last chunk of a block on a miss (:meth:`_fill_chunk`)
        self.filled = 0
        self._stack: tuple | None = None  # (:meth:`_stacked`)
        self.t_factor = 0.0
        self.t_column = 0.0
        self.t_block = 0.0
        self.t_solve = 0.0
        self.factorizations = 0
        self.columns = 0
        self._r0 = A.createVecLeft()
        self._values = A.createVecLeft()
        self._rhs = A.createVecLeft()
        self._xb = A.createVecRight()
        self._vals: npt.NDArray[np.float64] = np.zeros(self.L.size)
        self._wg: npt.NDArray[np.float64] = np.zeros(self.L.size)
        self._reff = A.createVecLeft()

    def _base_matrix(self, A: PETSc.Mat) -> PETSc.Mat:
        """The matrix factorised: a split basis's operator itself (factorised once per
        split: after :attr:`AL` and :attr:`AC` are taken, no product needs it), otherwise
        a copy of ``A`` (a rebase factorises another set)."""
        B0 = A if self.split is not None else A.duplicate(copy=True)
        B0.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
        return B0

    def _fixed_columns(self, A: PETSc.Mat) -> tuple[PETSc.Mat, npt.NDArray[np.int32]]:
        """The columns of ``A`` at this rank's Dirichlet and contact rows (all rows), and
        those local rows (sorted)."""
        cols = np.unique(np.concatenate([self.bc_local, self.L])).astype(np.int32)
        lo, hi = A.getOwnershipRange()
        isrow = PETSc.IS().createStride(hi - lo, first=lo, step=1, comm=self.comm)
        iscol = PETSc.IS().createGeneral(
            (cols.astype(np.int64) + self.start).astype(PETSc.IntType), comm=self.comm
        )
        AC = A.createSubMatrix(isrow, iscol)
        isrow.destroy()
        iscol.destroy()
        return AC, cols

    def _columns_of_ac(self, qs: list[int], xq: list[int]) -> tuple[npt.NDArray, ...]:
        """``A e_q`` for the contact positions ``qs[j]``, ``j`` in ``xq``: this rank's entries
        of those columns of :attr:`AC` as ``(local row, j, value)`` (no product)."""
        lo, hi = self.offset, self.offset + self.L.size
        col = np.full(len(qs), -1, dtype=np.int64)
        first = self.AC.getOwnershipRangeColumn()[0]
        for j in xq:
            if lo <= qs[j] < hi:
                col[j] = first + int(np.searchsorted(self._cols, self.L[qs[j] - lo]))
        self.comm.Allreduce(MPI.IN_PLACE, col, op=MPI.MAX)
        ai, aj, av = self.AC.getValuesCSR()
        rows = np.repeat(np.arange(self.nloc), np.diff(ai))
        hits = [(j, aj == col[j]) for j in xq]
        out = [(rows[h], np.full(int(h.sum()), j), av[h]) for j, h in hits]
        return tuple(np.concatenate(a) for a in zip(*out))

    def _make_split(self, allowed: npt.NDArray[np.bool_], rows: npt.NDArray) -> SplitBasis:
        """The split basis with this rank's contact rows ``allowed`` in the contact basis."""
        A0, Qt, T, Tt = self._split_args
        patch = np.asarray(rows, dtype=np.int64)[allowed] + A0.getOwnershipRange()[0]
        return SplitBasis(A0, Qt, T, Tt, patch, allowed)

    def _contact_rows(self, A: PETSc.Mat) -> PETSc.Mat:
        """The contact rows of ``A`` (``A·X`` is only ever needed there)."""
        lo_c, hi_c = A.getOwnershipRangeColumn()
        isrow = PETSc.IS().createGeneral(
            (self.L.astype(np.int64) + self.start).astype(PETSc.IntType), comm=self.comm
        )
        iscol = PETSc.IS().createStride(hi_c - lo_c, first=lo_c, step=1, comm=self.comm)
        AL = A.createSubMatrix(isrow, iscol)
        isrow.destroy()
        iscol.destroy()
        return AL

    def _make_ksp(self) -> PETSc.KSP:
        ksp = PETSc.KSP().create(self.comm)
        # (icntl 24: detect null pivots; icntl 14: extra work space after a shortfall)
        options: dict[str, object] = {"mat_mumps_icntl_24": 1}
        if self.workspace is not None:
            options["mat_mumps_icntl_14"] = self.workspace
        configure_ksp(ksp, "direct", prefix=self.prefix, options=options)
        return ksp

    def _set_up_factor(self) -> None:
        """Factorise :attr:`B0` in :attr:`ksp`; a factorisation that ran out of work space
        is redone with ICNTL(14) doubled (:func:`factorise_with_workspace_retry`)."""

        def set_up() -> None:
            self.ksp.setOperators(self.B0)
            with solver_options(self.ksp).applied():  # (the MUMPS options are read here)
                self.ksp.setUp()

        self.workspace = factorise_with_workspace_retry(
            self.ksp, set_up, self.workspace, "LU factorisation"
        )

    # ------------------------------------------------------------------ small utilities
    def _local(self, qs: list[int] | npt.NDArray) -> tuple[npt.NDArray, npt.NDArray]:
        """Of the global positions ``qs``: the indices ``i`` of those of this rank and
        their local rows ``qs[i] − offset``."""
        q = np.asarray(qs, dtype=np.int64)
        i = np.flatnonzero((q >= self.offset) & (q < self.offset + self.L.size))
        return i, q[i] - self.offset

    def _flags(self, mask: npt.NDArray[np.bool_], qs: list[int] | npt.NDArray) -> npt.NDArray:
        """``mask`` (this rank's rows) at the global positions ``qs``, on every rank (one
        entry per position, from the rank that holds it)."""
        out = np.zeros(len(qs), dtype=np.int8)
        i, r = self._local(qs)
        out[i] = mask[r]
        return global_vsum(self.comm, out).astype(bool)

    def _full(self, v: PETSc.Vec) -> npt.NDArray:
        """Local values of ``v`` in the contact basis (``(I − J) v`` with a split basis)."""
        if self.split is None:
            return v.array
        jv = self.split.J.createVecLeft()
        self.split.J.mult(v, jv)
        out = v.array - jv.array
        jv.destroy()
        return out

    def _fixed_local(self, mask: npt.NDArray[np.bool_]) -> npt.NDArray[np.int32]:
        """Local rows eliminated for the set ``mask``: Dirichlet rows and fixed normal rows."""
        return np.concatenate([self.bc_local, self.L[mask]]).astype(np.int32)

    def _lift(self, v: PETSc.Vec, fixed_local: npt.NDArray[np.int32], out: PETSc.Vec) -> None:
        """``out = r − A v`` on free rows and ``δ v`` on the fixed ones (what
        ``MatZeroRowsColumns`` does to a right-hand side), ``r = r0 − w_given``; ``v`` is
        zero outside the fixed rows (a product with :attr:`AC`)."""
        vc = self.AC.createVecRight()
        vc.array[:] = v.array_r[self._cols]
        self.AC.mult(vc, out)
        vc.destroy()
        out.aypx(-1.0, self._reff)
        out.array[fixed_local] = self.diag_value * v.array[fixed_local]

    # ------------------------------------------------------------------ factorisation
    def factorize(self, mask: npt.NDArray[np.bool_]) -> None:
        """Make ``mask`` (this rank's contact rows) the base set: assemble and factorise
        ``B_C``."""
        t0 = time.perf_counter()
        if self.split is not None and global_any(self.comm, mask & ~self.split.allowed):
            raise ValueError("split basis: only rows of the support patch can be fixed in the base")
        if self.B0 is not self.A:
            self.A.copy(self.B0, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        rows = (self._fixed_local(mask).astype(np.int64) + self.start).astype(PETSc.IntType)
        self.B0.zeroRowsColumns(rows, diag=self.diag_value)
        self._set_up_factor()
        nulls = null_pivots(self.ksp)
        if nulls:
            raise SingularActiveSetError(
                f"the system of the active set is singular ({nulls} null pivots: "
                f"a body without support?)"
            )
        failure = mumps_failure(self.ksp)
        if failure is not None:
            raise SingularActiveSetError(failure)
        if self.B0 is self.A:
            self._release_operator()
        self.base = mask.copy()
        self.cache.clear()
        self._stack = None
        self.full_cols.clear()
        self._set_memory_limits()
        dt = global_op(self.comm, time.perf_counter() - t0, MPI.MAX)
        # the first factorisation includes the symbolic analysis, which later ones reuse:
        # count half of it as the cost of a refactorisation until one is measured
        # (numeric / first = 0.37-0.50 measured on 2D Hertz meshes, 1 and 2 ranks)
        self.t_factor = 0.5 * dt if self._new_pattern else dt
        self._new_pattern = False
        self.factorizations += 1

    def _release_operator(self) -> None:
        """Free a split basis's operator once it is factorised (it is factorised once per
        split, and every product goes through :attr:`AL` and :attr:`AC`): the KSP keeps
        its factors (reused, never rebuilt) and a diagonal as its operator (issue 28)."""
        eye = PETSc.Mat().createAIJ(self.B0.getSizes(), nnz=1, comm=self.comm)
        diag = self.B0.createVecLeft()
        diag.set(1.0)
        eye.setDiagonal(diag)
        eye.assemble()
        self.ksp.getPC().setReusePreconditioner(True)
        self.ksp.setOperators(eye)
        for obj in (diag, eye, self.B0):
            obj.destroy()

    def _set_memory_limits(self) -> None:
        """Column limits from the memory of the factorisation (the memory part of the cost
        model; docs/theory/pdas.md#cost-model-and-rebase).

        A block of ``k`` columns holds about ``DENSE_BLOCKS`` dense ``n_local × k`` arrays
        at once (right-hand sides, solutions, ``A·X``, MUMPS's work space); the cache
        keeps two numbers per contact row of the rank and column, and a set update
        stacks the columns it uses once more.  Both are limited to ``memory_ratio``
        times the factors' memory on the largest rank (MUMPS INFOG(21)), so a contact
        solve stays within about ``1 + memory_ratio`` linear solves of memory: blocks are
        computed in chunks, and a cache that would outgrow its share rebases instead.
        """
        budget = self.memory_ratio * self._factor_bytes()
        if not np.isfinite(budget):
            self.block_limit = self.column_limit = self.sparse_limit = self.max_columns
            self.full_limit = 0
            return
        # full columns kept for the final field: this budget at least, the expected
        # contact zone within ``full_ratio`` (collective minimum; :meth:`_size_full_columns`)
        per_full = 8.0 * max(self.nloc, 1)
        self.full_floor = global_op(self.comm, int(budget // per_full), MPI.MIN)
        cap = self.full_ratio * self._factor_bytes()
        self.full_cap = max(global_op(self.comm, int(cap // per_full), MPI.MIN), self.full_floor)
        self.full_limit = self.full_floor
        per_column = DENSE_BLOCKS * 8.0 * max(self.nloc, 1)
        chunk = global_op(self.comm, int(budget // per_column), MPI.MIN)
        self.block_limit = max(chunk, MIN_BLOCK)
        per_sparse = SPARSE_BLOCKS * 8.0 * max(self.nloc, 1)
        chunk = global_op(self.comm, int(budget // per_sparse), MPI.MIN)
        self.sparse_limit = max(chunk, self.block_limit)
        cached = global_op(self.comm, int(budget // (4 * 8.0 * max(self.L.size, 1))), MPI.MIN)
        self.column_limit = min(self.max_columns, max(cached, MIN_BLOCK))

    def _factor_bytes(self) -> float:
        """Memory of the LU factors on the largest rank (bytes; MUMPS INFOG(21), MB)."""
        pc = self.ksp.getPC()
        if pc.getFactorSolverType() != "mumps":
            return float("inf")
        return 1.0e6 * float(pc.getFactorMatrix().getMumpsInfog(21))

    # ------------------------------------------------------------------ one contact solve
    def begin(
        self,
        r0: PETSc.Vec,
        bc_values: npt.NDArray,
        values: npt.NDArray,
        initial: npt.NDArray[np.bool_],
    ) -> None:
        """Start a contact solve with right-hand side ``r0`` (nodal frames, Dirichlet rows
        holding their values ``bc_values``) and the values this rank's contact rows
        take when fixed (gaps for normal rows, the previous slip for tangential ones);
        factorise at ``initial`` (this rank's rows) if there is no base yet."""
        if self.split is not None:  # (kept for a re-split)
            if self._r0_orig is None:
                self._r0_orig = r0.duplicate()
            r0.copy(self._r0_orig)
        self._bc_values = np.asarray(bc_values, dtype=np.float64)
        self._vals = np.asarray(values, dtype=np.float64).copy()
        self._wg = np.zeros(self.L.size)
        self._set_r0(r0)
        if self.base is None:
            self.factorize(initial if self.split is None else self.split.first)
        self._size_full_columns(self._base_chunk())
        self._base_solve(self._prefetch_rows(np.asarray(initial, dtype=bool)))

    def _size_full_columns(self, k: int) -> None:
        """The full columns kept (:attr:`full_limit`) before ``k`` new ones are
        computed, sized by the expected contact zone: the columns the sets have needed
        so far (the most a finished solve used, :attr:`full_used`, or all cached ones:
        the zone of the previous steps and the rows computed ahead as about to close)
        plus the ``k`` new ones, at least the ``memory_ratio`` budget and at most the
        ``full_ratio`` one (docs/theory/pdas.md#full-columns-across-steps).  Without a
        factors' memory (not MUMPS) no full column is kept."""
        if self.full_cap == 0:
            return
        want = max(self.full_used, len(self.cache)) + k
        self.full_limit = min(max(self.full_floor, want), self.full_cap)

    def _set_r0(self, r0: PETSc.Vec) -> None:
        """The right-hand side in the rows of the factorised operator."""
        r0.copy(self._r0)
        if self.split is not None:  # T Q_P b = T Q b − Jᵀ T b (docstring of SplitBasis)
            jr = self.split.Jt.createVecLeft()
            self.split.Jt.mult(r0, jr)
            self._r0.axpy(-1.0, jr)
            jr.destroy()
        self._r0.copy(self._reff)
        self._r0N = self._r0.array[self.L].copy()

    # ------------------------------------------------------------------ re-split
    def _factor_counts(self) -> tuple[float, float]:
        """Entries of the LU factors and flops of the last factorisation (MUMPS
        INFOG(29), RINFOG(3)); ``(nan, nan)`` for another factorisation package."""
        pc = self.ksp.getPC()
        if pc.getFactorSolverType() != "mumps":
            return float("nan"), float("nan")
        F = pc.getFactorMatrix()
        nnz = float(F.getMumpsInfog(29))
        if nnz < 0:  # (MUMPS gives large counts in millions, negated)
            nnz = -1.0e6 * nnz
        return nnz, float(F.getMumpsRinfog(3))

    def _resplit_pays(self, new_columns: int) -> bool:
        """Is a new split basis with the current set in it cheaper than ``new_columns``
        force columns?  (docs/theory/pdas.md#split-basis)

        Counted in floating-point operations of the present factors, so that the choice
        (and with it the path of the solve) does not depend on the machine or its load:
        a column is a forward and a backward substitution, ``2 · nnz(LU)`` operations
        done at about half the rate of a factorisation (``SOLVE_RATE``; 0.9 of it with
        sparse right-hand sides on one rank, ``SOLVE_RATE_SPARSE``; a third of it on more
        than one rank); the re-split is counted as the present factorisation's
        operations times ``RESPLIT_GROWTH`` (more fill, a new analysis) plus
        ``RESPLIT_FIXED`` operations per entry of the factors (the new analysis and
        products, which dominate on 2D meshes), times ``rebase_ratio``."""
        nnz, flops = self._factor_counts()
        if not (np.isfinite(nnz) and np.isfinite(flops)) or self._in_respond:
            return False
        serial = self.comm.size == 1
        rate = SOLVE_RATE_PARALLEL
        if serial:
            rate = SOLVE_RATE_SPARSE if self._sparse() else SOLVE_RATE
        cost_columns = new_columns * 2.0 * nnz / rate
        cost_resplit = RESPLIT_GROWTH * flops + RESPLIT_FIXED[0 if serial else 1] * nnz
        return cost_columns > self.rebase_ratio * cost_resplit

    def _resplit(self, mask: npt.NDArray[np.bool_]) -> None:
        """Rebuild the split basis with the nodes of ``mask`` (this rank's fixed rows)
        added to the contact basis, and make ``mask`` the factorised base set: the
        columns the set would need become one factorisation."""
        nodes = np.unique(self._node[mask])
        allowed = self.split.allowed | np.isin(self._node, nodes)
        first = self.split.first
        self.split.destroy()
        for obj in (self.ksp, self.B0, self.AL, self.JL, self.AC):
            obj.destroy()
        self.split = self._make_split(allowed, self.L)
        self.split.first = first
        self.A = self.split.K
        self.AL = self._contact_rows(self.A)
        self.JL = self._contact_rows(self.split.J)
        self.AC, self._cols = self._fixed_columns(self.A)
        self.B0 = self._base_matrix(self.A)
        self.ksp = self._make_ksp()
        self.resplits += 1
        self.base = None
        self._new_pattern = True  # (its first factorisation includes the analysis)
        self._set_r0(self._r0_orig)
        wg, self._wg = self._wg, np.zeros(self.L.size)
        self._set_given(wg)
        self.factorize(mask)
        self._base_solve()

    def _set_given(self, wgiven: npt.NDArray | None) -> bool:
        """Prescribed residuals ``w`` (e.g. friction forces at slip rows); True if changed."""
        wg = np.zeros(self.L.size) if wgiven is None else np.asarray(wgiven, dtype=np.float64)
        if not global_any(self.comm, not np.array_equal(wg, self._wg)):
            return False
        self._wg = wg.copy()
        self._r0.copy(self._reff)
        f = self._reff.duplicate()
        f.set(0.0)
        f.array[self.L] = wg
        if self.split is not None:  # the master side of the given forces
            jf = self.split.Jt.createVecLeft()
            self.split.Jt.mult(f, jf)
            f.axpy(-1.0, jf)
            jf.destroy()
        self._reff.axpy(-1.0, f)
        f.destroy()
        return True

    def _values_for(
        self, mask: npt.NDArray[np.bool_], extra: npt.NDArray | None = None
    ) -> PETSc.Vec:
        v = self._values
        v.set(0.0)
        if self.bc_local.size:
            v.array[self.bc_local] = self._bc_values
        vals = self._vals if extra is None else self._vals + extra
        v.array[self.L[mask]] = vals[mask]
        return v

    def _base_solve(self, prefetch: list[int] | None = None) -> None:
        """``x_b``: the solution of the base set with this solve's right-hand side and
        values; with ``prefetch`` (global positions), their columns in the same
        multi-right-hand-side solve (:meth:`_prefetch_rows`)."""
        fixed = self._fixed_local(self.base)
        self._lift(self._values_for(self.base), fixed, self._rhs)
        if prefetch:
            self._make_room(len(prefetch))
            self._compute_block(prefetch, rhs=self._rhs)
            self.prefetched += len(prefetch)
            return
        t1 = time.perf_counter()
        self.ksp.solve(self._rhs, self._xb)
        self.n_solves += 1
        t_solve = time.perf_counter() - t1
        axb = self.AL.createVecLeft()
        self.AL.mult(self._xb, axb)
        self._xbN = self._full(self._xb)[self.L].copy()
        self._AxbN = axb.array_r.copy()
        axb.destroy()
        self.t_solve = global_op(self.comm, t_solve, MPI.MAX)
        if self.t_column == 0.0:
            # first estimate of a block of k columns: (1.3 + c k) solves, c = 0.15 serially
            # and 0.45 in parallel (MUMPS multi-right-hand-side solves measured on 2D Hertz
            # meshes: the distributed solve gains far less from blocking); then measured
            self.t_column = (0.15 if self.comm.size == 1 else 0.45) * self.t_solve
            self.t_block = 1.3 * self.t_solve

    def _compute_columns(self, qs: list[int]) -> None:
        """Columns for the global positions ``qs``, in chunks of at most
        :meth:`_chunk` (memory)."""
        chunk = self._chunk()
        for i in range(0, len(qs), chunk):
            self._compute_block(qs[i : i + chunk])

    def _sparse(self) -> bool:
        """Are blocks without a base solve solved with sparse right-hand sides?"""
        return self.sparse_rhs and self.ksp.getPC().getFactorSolverType() == "mumps"

    def _chunk(self) -> int:
        """Columns of a block on a miss: :attr:`sparse_limit` with sparse right-hand sides
        (fewer dense arrays per column), else :attr:`block_limit`."""
        return self.sparse_limit if self._sparse() else self.block_limit

    def _base_chunk(self) -> int:
        """Columns of a block with the base solve (the base solve's column included):
        :attr:`sparse_limit` when that block is solved with sparse right-hand sides (MUMPS
        on one rank, :meth:`_rhs_matrix`: its memory is that of a sparse block), else
        :attr:`block_limit`."""
        return self.sparse_limit if self._sparse() and self.comm.size == 1 else self.block_limit

    def _compute_block(self, qs: list[int], rhs: PETSc.Vec | None = None) -> None:
        """Columns for the global positions ``qs`` (X-type if in the base, W-type if not),
        in one MUMPS solve with sparse right-hand sides (:meth:`_rhs_entries`; the forward
        substitution then only visits the part of the elimination tree that the columns'
        few entries reach: docs/theory/pdas.md#sparse-right-hand-sides); with ``rhs``, the
        base solve of that right-hand side in the same solve (one more, dense, column:
        :attr:`_xb` and its contact rows; :meth:`_rhs_matrix`)."""
        t0 = time.perf_counter()
        k = len(qs)
        Xm = _dense(self.comm, self.nloc, k + (rhs is not None))
        F = self.ksp.getPC().getFactorMatrix()
        B, Bt = self._rhs_matrix(self._rhs_entries(qs), k, rhs)
        F.matSolve(B, Xm)
        self.n_blocks += 1
        KXm = self.AL.matMult(Xm)
        Xraw = Xm.getDenseArray()
        colN = Xraw[self.L, :]  # (this rank's contact rows of the columns, contact basis:
        if self.JL is not None:  # (I − J) X there, J at the contact rows only)
            JX = self.JL.matMult(Xm)
            colN = colN - JX.getDenseArray()
            JX.destroy()
        kcolN = KXm.getDenseArray()
        keep_full = len(self.full_cols) + k <= self.full_limit  # (same on every rank)
        for j, q in enumerate(qs):
            self.cache[q] = (colN[:, j].copy(), kcolN[:, j].copy())
            if keep_full:
                self.full_cols[q] = Xraw[:, j].copy()
        if rhs is not None:  # (the base solve's column)
            self._xb.array[:] = Xraw[:, k]
            self._xbN, self._AxbN = colN[:, k].copy(), kcolN[:, k].copy()
        for M in {id(M): M for M in (B, Bt, Xm, KXm)}.values():
            M.destroy()
        self.columns += k
        full_bytes = 8.0 * self.nloc * len(self.full_cols)
        self.full_bytes_peak = max(self.full_bytes_peak, global_op(self.comm, full_bytes, MPI.MAX))
        dt = global_op(self.comm, time.perf_counter() - t0, MPI.MAX)
        dt -= self.t_solve if rhs is not None else 0.0
        self.t_column = max(dt - self.t_block, 0.1 * dt) / k

    def _rhs_matrix(
        self, entries: tuple[npt.NDArray, ...], k: int, rhs: PETSc.Vec | None
    ) -> tuple[PETSc.Mat, PETSc.Mat]:
        """The right-hand sides of a block (``entries`` of :meth:`_rhs_entries`, and the
        base solve's ``rhs`` as column ``k``) as the matrix ``B`` handed to the solve, and
        the matrix to destroy with it.  Sparse (MUMPS): a ``MATTRANSPOSEVIRTUAL`` of a
        ``k × n`` matrix on the first rank; on one rank a block with the base solve is
        sparse too, its dense column among the sparse ones (15 columns and the base solve
        at 126k dofs: 0.23-0.30 s against 0.28-0.35 s with all of them dense,
        docs/theory/pdas.md#sparse-right-hand-sides); with more ranks that column would
        be gathered to the first rank, so the block is dense.  Otherwise a dense
        ``n_local × (k + 1)`` matrix."""
        if self._sparse() and (rhs is None or self.comm.size == 1):
            r, c, v = entries
            if rhs is not None:
                dense = np.flatnonzero(rhs.array_r)
                r = np.concatenate([r, dense])
                c = np.concatenate([c, np.full(dense.size, k, dtype=np.int64)])
                v = np.concatenate([v, rhs.array_r[dense]])
            Bt = self._centralised(r, c, v, k + (rhs is not None))
            return PETSc.Mat().createTranspose(Bt), Bt
        B = _dense(self.comm, self.nloc, k + (rhs is not None))
        R = B.getDenseArray(readonly=False)
        np.add.at(R, entries[:2], entries[2])
        if rhs is not None:
            R[:, k] = rhs.array_r
        B.assemble()
        return B, B

    def _rhs_entries(self, qs: list[int]) -> tuple[npt.NDArray, npt.NDArray, npt.NDArray]:
        """This rank's entries ``(local row, j, value)`` of the right-hand sides of the
        columns ``qs`` (repeated entries add up; a column has a few dozen): for a row fixed
        in the base (X-type) ``−A e_q`` off the base's fixed rows and ``δ`` at ``q``; for a
        free one (W-type) a unit force at ``q``, with a split basis ``e_q − Jᵀ e_q`` off
        the Dirichlet rows."""
        k = len(qs)
        lo, hi = self.offset, self.offset + self.L.size
        in_base = self._flags(self.base, qs)
        xq = [j for j in range(k) if in_base[j]]
        wq = [j for j in range(k) if not in_base[j]]
        own = np.array([j for j in range(k) if lo <= qs[j] < hi], dtype=np.int64)
        q_own = np.array([qs[j] for j in own], dtype=np.int64) - lo
        parts = [(self.L[q_own], own, np.where(in_base[own], self.diag_value, 1.0))]
        if xq:  # (A times unit columns at contact rows: columns of AC)
            r, c, v = self._columns_of_ac(qs, xq)
            keep = ~np.isin(r, self._fixed_local(self.base))
            parts.append((r[keep], c[keep], -v[keep]))
        if self.split is not None and wq:
            parts.append(self._split_forces(qs, wq))
        r, c, v = (np.concatenate([np.asarray(p[i]) for p in parts]) for i in range(3))
        r, c = r.astype(np.int64), c.astype(np.int64)
        if self.split is not None and wq and self.bc_local.size:
            drop = np.isin(r, self.bc_local) & ~in_base[c]
            r, c, v = r[~drop], c[~drop], v[~drop]
        return r, c, v

    def _centralised(self, rows: npt.NDArray, cols: npt.NDArray, vals: npt.NDArray, k: int):
        """The ``k × n`` sparse matrix with this rank's entries ``(cols, rows, vals)`` (local
        rows of the operator as its columns; repeated entries summed), all of it on the
        first rank: MUMPS takes sparse right-hand sides centralised."""
        n = self._xb.getSize()
        rows = rows + self.start
        if self.comm.size > 1:
            got = self.comm.gather((rows, cols, vals), root=0)
            if self.comm.rank == 0:
                rows, cols, vals = (np.concatenate([g[i] for g in got]) for i in range(3))
        first = self.comm.rank == 0
        if first:
            order = np.lexsort((rows, cols))
            key = cols[order] * n + rows[order]
            uniq, start = np.unique(key, return_index=True)
            data = np.add.reduceat(vals[order], start) if key.size else np.zeros(0)
            indptr = np.searchsorted(uniq // n, np.arange(k + 1)) if k else np.zeros(1)
            csr = (indptr.astype(PETSc.IntType), (uniq % n).astype(PETSc.IntType), data)
        else:
            csr = (np.zeros(1, dtype=PETSc.IntType), np.zeros(0, dtype=PETSc.IntType), np.zeros(0))
        Bt = PETSc.Mat().createAIJ(
            size=((k if first else 0, k), (n if first else 0, n)), csr=csr, comm=self.comm
        )
        Bt.assemble()
        return Bt

    def _split_forces(self, qs: list[int], wq: list[int]) -> tuple[npt.NDArray, ...]:
        """The master side of force columns in a split basis: a unit contact force at a
        slave row ``q`` also acts there, ``e_q − Jᵀ e_q`` (:class:`SplitBasis`); returns
        this rank's entries of ``−Jᵀ e_q`` as ``(local row, j, value)``: the entries of
        ``Jᵀ`` (:meth:`SplitBasis.jt_entries`) in the global columns of the rows ``q``."""
        lo, hi = self.offset, self.offset + self.L.size
        col = np.full(len(qs), -1, dtype=np.int64)
        for j in wq:
            if lo <= qs[j] < hi:
                col[j] = self.start + int(self.L[qs[j] - lo])
        self.comm.Allreduce(MPI.IN_PLACE, col, op=MPI.MAX)
        jw = np.asarray(wq, dtype=np.int64)
        order = np.argsort(col[jw])
        g_sorted, j_sorted = col[jw][order], jw[order]
        rows, cols, vals = self.split.jt_entries()
        sel = np.isin(cols, g_sorted)
        j = j_sorted[np.searchsorted(g_sorted, cols[sel])]
        return rows[sel], j, -vals[sel]

    def solve_set(
        self,
        active: npt.NDArray[np.bool_],
        scale: npt.NDArray[np.float64],
        wgiven: npt.NDArray[np.float64] | None = None,
        margin: npt.NDArray[np.float64] | None = None,
        coupled: tuple | None = None,
    ) -> tuple[npt.NDArray, npt.NDArray, dict]:
        """Solve the system of the set ``active`` (this rank's contact rows).

        Every array is over this rank's contact rows; the rows in which the set differs
        from the base are numbered globally (rank after rank), and the small dense
        system of their amplitudes is formed from the rows each rank holds and solved on
        every rank (docs/theory/pdas.md#distributed-set-logic).

        Parameters
        ----------
        active
            Mask of the fixed (active) contact rows.
        scale
            Stiffness scale of the rows (balances the small system).
        wgiven
            Prescribed residual ``w = r0 − A x`` at free rows (friction forces
            at slip rows; zero elsewhere).
        margin
            Optional distance of each row from switching (e.g.
            ``|λ + c_n (u_n − g)|`` of the previous iteration).  When columns must be
            computed anyway, as many again are computed for the fixed rows of the base
            closest to being released (one block costs little more than a few columns).
        coupled
            Optional rows whose equation is replaced by a small coupled one (the
            linearised slip condition of 3D friction):
            ``(rows, G, H, h)`` with ``rows`` (m, r) this rank's row indices (free in
            ``active``, zero ``wgiven``) and, for every group ``i``,
            ``G_i w[rows_i] + H_i x[rows_i] = h_i`` with ``G_i, H_i`` (r × r).  Each such row
            gets one unknown (a force if free in the base, a value if fixed in it).

        Returns
        -------
        (x_N, w_N, info)
            This rank's contact unknowns and residual ``r0 − A x`` at the contact rows, and
            ``{"columns": new columns, "refactorized": bool, "size": unknowns of the small
            system}``.
        """
        if margin is not None:
            self._margin = np.asarray(margin, dtype=np.float64).copy()
        if self._set_given(wgiven):
            self._base_solve()
        crow = (
            np.zeros(0, dtype=np.int64)
            if coupled is None
            else np.asarray(coupled[0], dtype=np.int64)
        )
        diff, new_cols, refactorized = self._prepare_columns(active, margin, crow)
        cols = [int(q) for q in diff]
        xN, wN = self._xbN.copy(), self._r0N - self._AxbN
        self._y = (cols, np.zeros(0))
        if cols:
            G, KG = self._stacked(cols)
            M, rhs, csc = self._small_system(
                cols, (active, scale), (G, KG), (xN, wN), coupled, crow
            )
            y = solve_small_system(M, rhs, cols) * csc
            with one_blas_thread():  # (small products: see solve_small_system)
                xN += G @ y
                wN -= KG @ y
            self._y = (cols, y)
        return xN, wN, {"columns": new_cols, "refactorized": refactorized, "size": len(cols)}

    def _stacked(self, cols: list[int]) -> tuple[npt.NDArray, npt.NDArray]:
        """The cached columns of ``cols`` side by side (values and ``Ã`` times them at
        this rank's contact rows), kept while the list is the same (PDAS iterations and
        steps of a settled zone)."""
        key = tuple(cols)
        if self._stack is None or self._stack[0] != key:
            G = np.column_stack([self.cache[q][0] for q in cols])
            KG = np.column_stack([self.cache[q][1] for q in cols])
            self._stack = (key, G, KG)
        return self._stack[1], self._stack[2]

    def _differing(self, active: npt.NDArray[np.bool_], crow: npt.NDArray) -> npt.NDArray:
        """Global positions of the rows in which the set ``active`` differs from the base,
        or whose equation is replaced (``crow``): one column each (the same list on
        every rank, gathered: its size is the number of such rows)."""
        d = active != self.base
        d[crow.ravel()] = True
        return gather_rows(self.comm, np.flatnonzero(d) + self.offset)[0]

    def _prepare_columns(
        self,
        active: npt.NDArray[np.bool_],
        margin: npt.NDArray[np.float64] | None,
        crow: npt.NDArray,
    ) -> tuple[npt.NDArray, int, bool]:
        """Make the columns of the set ``active`` available: re-split, rebase or compute
        the missing ones (with speculative release columns, see :meth:`solve_set`).
        Returns the rows that need a column, the columns computed and whether the base
        was refactorised."""
        refactorized = False
        diff = self._differing(active, crow)
        missing = [int(q) for q in diff if int(q) not in self.cache]
        too_many = len(self.cache) + len(missing) > self.column_limit
        cost_columns = self.t_block + len(missing) * self.t_column
        cost_rebase = self.rebase_ratio * self.t_factor + self.t_solve
        if self.split is not None and missing and self._resplit_pays(len(missing)):
            self._resplit(active)
            refactorized = True
            diff = self._differing(active, crow)
            missing = [int(q) for q in diff if int(q) not in self.cache]
        elif self.split is not None:
            if too_many:  # (no rebase: keep the columns of this set only)
                keep = {int(q) for q in diff}
                self.cache = {q: c for q, c in self.cache.items() if q in keep}
                self.full_cols = {q: c for q, c in self.full_cols.items() if q in keep}
        elif missing and (too_many or cost_columns > cost_rebase):
            self.factorize(active)
            self._base_solve()
            refactorized = True
            diff = self._differing(active, crow)
            missing = [int(q) for q in diff if int(q) not in self.cache]
        if missing and margin is not None and self.split is None:
            # speculate on releases only: fixed rows of the base closest to being freed
            # (a cold-started PDAS overshoots, then releases nodes for several iterations)
            extra = self._closest(active & self.base, margin, len(missing))
            room = self.column_limit - len(self.cache) - len(missing)
            missing += extra[: max(room, 0)]
        elif missing and margin is not None:  # (split basis: fill the last chunk)
            missing += self._fill_chunk(active, margin, missing)
        if missing:
            self._size_full_columns(len(missing))
        if missing and len(self.full_cols) + len(missing) > self.full_limit:
            # room for this set's full columns: drop those of rows outside it (their reduced
            # columns stay cached; a set that needs one again takes the final solve)
            keep = {int(q) for q in diff}
            self.full_cols = {q: c for q, c in self.full_cols.items() if q in keep}
        if missing:
            self._compute_columns(missing)
        return diff, len(missing), refactorized

    def _fill_chunk(
        self, active: npt.NDArray[np.bool_], margin: npt.NDArray[np.float64], missing: list[int]
    ) -> list[int]:
        """Rows without a column closest to switching (:meth:`_prefetch_rows`: closing,
        released or starting to slip) that fill the last chunk of the ``missing``
        columns of a block computed anyway, within the cache limit (the sets of the next
        iterations of a growing zone then need no block of their own)."""
        n = (-len(missing)) % self._chunk()
        n = min(n, self.column_limit - len(self.cache) - len(missing))
        if n <= 0:
            return []
        cand = (active == self.base) & ~self._flags_of(missing)
        fill = self._closest(cand, margin, n)
        self.filled += len(fill)
        return fill

    def _closest(
        self,
        cand: npt.NDArray[np.bool_],
        margin: npt.NDArray[np.float64],
        n: int,
        uncached: bool = True,
    ) -> list[int]:
        """Global positions of the ``n`` rows of ``cand`` (this rank's rows; ``uncached``:
        without a cached column) with the smallest finite ``margin`` (ties by position):
        each rank offers its ``n`` closest, the ranks' offers are merged (the same list
        on every rank)."""
        if uncached:
            cand = cand & ~self._cached_mask()
        idx = np.flatnonzero(cand & np.isfinite(margin))
        q = idx + self.offset
        order = np.lexsort((q, margin[idx]))[:n]
        m_all, q_all = gather_rows(self.comm, margin[idx][order], q[order])
        return [int(v) for v in q_all[np.lexsort((q_all, m_all))][:n]]

    def _cached_mask(self) -> npt.NDArray[np.bool_]:
        """This rank's rows with a cached column."""
        return self._flags_of(list(self.cache))

    def _prefetch_rows(self, start: npt.NDArray[np.bool_]) -> list[int]:
        """Rows whose columns are computed together with the base solve of a contact
        solve starting from the fixed rows ``start`` (docs/theory/pdas.md#columns-ahead).

        First the rows in which ``start`` differs from the base and that have no column
        (the first set needs them: e.g. the tangential rows of nodes that closed in the
        last step, sticking at the start).  Then, when there are such rows or the start
        fixed rows ``g`` that the previous start did not and the ``2g`` open rows closest
        to closing (the margin of the last solve, :attr:`_margin`) are not all cached,
        the rows without a column closest to switching (below), up to a dense block
        besides the base solve (:attr:`block_limit` − 1), within the cache limit.  The
        first rows (certain: the first set needs them) may fill the block up to
        :meth:`_base_chunk` − 1 (a sparse block's size on one rank); the rows closest to
        switching (a guess) never go beyond a dense block: past 16 columns the block
        with the base solve costs ≈ 12 ms CPU per column at 126k dofs, a column the
        sets then do not use is lost (docs/theory/pdas.md#columns-ahead).
        A split basis only (its sets are reached by columns, never by a rebase).
        Collective; the same list on every rank."""
        prev, self._start_prev = self._start_prev, start.copy()
        if self.split is None or self._margin is None or prev is None:
            return []
        room = min(self._base_chunk() - 1, self.column_limit - len(self.cache))
        if room <= 0:
            return []
        cached = self._cached_mask()
        sure = gather_rows(self.comm, np.flatnonzero((start != self.base) & ~cached) + self.offset)
        sure_q = [int(q) for q in sure[0]][:room]
        grown = global_count(self.comm, start & ~prev)
        open_rows = ~start & ~self.base
        if not sure_q:
            if grown == 0:
                return []
            near = self._closest(open_rows, self._margin, 2 * grown, uncached=False)
            if all(q in self.cache for q in near):  # (the cache is the same on every rank)
                return []
        # rows that need a column when they switch: open rows outside the base (fixed once
        # their node closes: normal and, with friction, tangential rows) and rows fixed at
        # the start and in the base (released, or a sticking node's tangential rows when
        # it starts to slip: they are then replaced by the slip equations)
        cand = open_rows | (start & self.base)
        guess = max(min(self.block_limit - 1, room) - len(sure_q), 0)
        more = self._closest(cand & ~self._flags_of(sure_q), self._margin, guess)
        return sure_q + more

    def _flags_of(self, qs: list[int]) -> npt.NDArray[np.bool_]:
        """This rank's rows among the global positions ``qs``."""
        mask = np.zeros(self.L.size, dtype=bool)
        q = np.asarray(qs, dtype=np.int64) - self.offset
        mask[q[(q >= 0) & (q < self.L.size)]] = True
        return mask

    def _make_room(self, k: int) -> None:
        """Room for ``k`` more full columns: when the kept ones and ``k`` exceed
        :attr:`full_limit`, those of rows outside the base-solve's set are dropped."""
        if len(self.full_cols) + k <= self.full_limit or self._start_prev is None:
            return
        keep = {int(q) for q in self._differing(self._start_prev, np.zeros(0, dtype=np.int64))}
        self.full_cols = {q: c for q, c in self.full_cols.items() if q in keep}

    def _small_system(
        self,
        cols: list[int],
        sets: tuple[npt.NDArray[np.bool_], npt.NDArray[np.float64]],
        columns: tuple[npt.NDArray, npt.NDArray],
        base_state: tuple[npt.NDArray, npt.NDArray],
        coupled: tuple | None,
        crow: npt.NDArray,
    ) -> tuple[npt.NDArray, npt.NDArray, npt.NDArray]:
        """The dense system of the column amplitudes ``y = csc · ỹ``: a fixed row takes its
        value, a free row its given force, a coupled row its equation (rows scaled by
        ``scale``).  ``sets = (active, scale)``, ``columns = (G, KG)`` and ``base_state =
        (xN, wN)`` are this rank's rows; each rank forms the equations of the rows it
        holds, and the rows of all ranks are gathered (``len(cols)²`` numbers).  Returns
        ``(M, rhs, csc)``."""
        (active, scale), (G, KG), (xN, wN) = sets, columns, base_state
        k = len(cols)
        mine, r = self._local(cols)
        # unknowns: value shifts s (base-fixed rows) and forces mu = scale * mu~ (base-free
        # rows)
        csc = np.where(self.base[r], 1.0, scale[r])
        M = np.empty((mine.size, k))
        rhs = np.empty(mine.size)
        fix = active[r]
        M[fix] = G[r[fix], :]
        rhs[fix] = (self._vals - xN)[r[fix]]
        c_free = r[~fix]
        M[~fix] = KG[c_free, :] / scale[c_free, None]
        rhs[~fix] = (wN - self._wg)[c_free] / scale[c_free]
        if coupled is not None and crow.size:
            _, Gc, Hc, hc = coupled
            q = crow.ravel()
            pos = {int(v): i for i, v in enumerate(r)}
            idx = np.array([pos[int(v)] for v in q], dtype=np.int64)
            Mc = np.einsum("iab,ibk->iak", Hc, G[crow]) - np.einsum("iab,ibk->iak", Gc, KG[crow])
            rc = hc - np.einsum("iab,ib->ia", Gc, wN[crow]) - np.einsum("iab,ib->ia", Hc, xN[crow])
            M[idx] = Mc.reshape(q.size, k) / scale[q, None]
            rhs[idx] = rc.ravel() / scale[q]
        M, rhs, csc = gather_rows(self.comm, M, rhs, csc)  # (rows in the order of cols)
        M *= csc[None, :]
        return M, rhs, csc

    def respond(
        self, active: npt.NDArray[np.bool_], scale: npt.NDArray[np.float64], dvals: npt.NDArray
    ) -> tuple[npt.NDArray, npt.NDArray]:
        """The solution of the set ``active`` with the values of the fixed rows shifted by
        ``dvals`` (this rank's rows), e.g. a push of the cold start's support patch; the state of
        the current contact solve is kept (one extra base solve).

        Returns
        -------
        (x_N, w_N)
            As :meth:`solve_set`.
        """
        saved = (self._vals, self._xbN, self._AxbN, self._y, self.t_solve)
        xb = self._xb.copy()
        self._vals = self._vals + np.asarray(dvals, dtype=np.float64)
        self._in_respond = True  # (no re-split: the state restored below is of this basis)
        try:
            self._base_solve()
            xN, wN, _ = self.solve_set(active, scale)
        finally:
            self._in_respond = False
            self._vals, self._xbN, self._AxbN, self._y, self.t_solve = saved
            xb.copy(self._xb)
            xb.destroy()
        return xN, wN

    def finish(self, out: PETSc.Vec) -> None:
        """Write the full solution of the last :meth:`solve_set` into ``out``: ``x_b + X y``
        when every column of the set is kept in full (:attr:`full_cols`), else one solve."""
        cols, y = self._y
        if not self._in_respond:
            self.full_used = max(self.full_used, len(cols))
        if all(q in self.full_cols for q in cols):  # (the same on every rank)
            out.array[:] = self._final_field(cols, y)
            if self.split is not None:
                out.array[:] = self._full(out)
            return
        mine, r = self._local(cols)
        base = self.base[r]
        extra = np.zeros(self.L.size)
        extra[r[base]] = y[mine[base]]
        v = self._values_for(self.base, extra)
        self._lift(v, self._fixed_local(self.base), self._rhs)
        self._rhs.array[self.L[r[~base]]] += y[mine[~base]]
        if self.split is not None and cols:
            forces = np.zeros(self.L.size)
            forces[r[~base]] = y[mine[~base]]
            self._split_rhs(forces)
        self.ksp.solve(self._rhs, out)
        self.n_solves += 1
        self.n_final += 1
        if self.split is not None:
            out.array[:] = self._full(out)

    def _final_field(self, cols: list[int], y: npt.NDArray) -> npt.NDArray:
        """``x_b + X y`` from the kept full columns: one BLAS ``axpy`` per column, in
        place, on one thread (no ``n × k`` temporary; numpy's ``x += y_q X_q`` makes a
        temporary and two passes per column, a threaded BLAS call spins on a busy
        machine): the final field of a settled knee-gait step at 126k dofs with ~230
        columns, ≈ 0.011 s against 0.017–0.024 s (CPU)."""
        x = self._xb.array.copy()
        with one_blas_thread():
            for q, yq in zip(cols, y):
                x = _daxpy(self.full_cols[q], x, a=float(yq))
        return x

    def _split_rhs(self, forces: npt.NDArray) -> None:
        """Add the master side ``−Jᵀ f`` of the contact forces ``f`` (this rank's contact
        rows) to the right-hand side (split basis)."""
        f = self._rhs.duplicate()
        f.array[self.L] = forces
        jf = self.split.Jt.createVecLeft()
        self.split.Jt.mult(f, jf)
        self._rhs.array[:] -= jf.array
        if self.bc_local.size:
            self._rhs.array[self.bc_local] = self._lift_bc()
        f.destroy()
        jf.destroy()

    def _lift_bc(self) -> npt.NDArray:
        return self.diag_value * self._values.array[self.bc_local]

    def destroy(self) -> None:
        if self.split is not None:
            self.split.destroy()
            self.JL.destroy()
        if self._r0_orig is not None:
            self._r0_orig.destroy()
        for obj in (
            self.ksp,
            self.B0,
            self.AL,
            self.AC,
            self._r0,
            self._reff,
            self._values,
            self._rhs,
            self._xb,
        ):
            obj.destroy()
