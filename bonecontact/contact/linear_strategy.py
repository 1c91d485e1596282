"""How the PDAS solves the linear system of one active set
(docs/theory/pdas.md#low-rank-updates, docs/theory/pdas.md#iterative-linear-solver).

Every PDAS iteration solves the condensed system of
:class:`~bonecontact.contact.condensed.CondensedSystem` with some contact rows
prescribed (:class:`SetRows`).  Three strategies do it, chosen once per operator by
:func:`make_strategy`:

* :class:`LowRankStrategy` — one LU factorisation, other sets by low-rank updates
  (:mod:`bonecontact.contact.lowrank`); the default with the direct solver;
* :class:`RefactorStrategy` — eliminate the rows and refactorise (MUMPS) every
  iteration, the reference;
* :class:`KrylovStrategy` — eliminate the rows and solve by CG/GMRES + GAMG, keeping
  the preconditioner while the set changes little (:mod:`bonecontact.contact.krylov`).

All three have the interface of :class:`LinearStrategy`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, Protocol

from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
from dolfinx import fem

from bonecontact.common.linalg import SolverOptions, configure_ksp
from bonecontact.contact.condensed import CondensedSystem, lean_products
from bonecontact.contact.coupled_rows import CoupledGroup, krylov_groups, spring_split
from bonecontact.contact.krylov import (
    DEFAULT_REUSE_ROWS,
    RESPONSE_RTOL,
    PreconditionerReuse,
    allow_hierarchy_update,
    configure_condensed_ksp,
    reduction_decades,
    scale_initial_guess,
)
from bonecontact.contact.lowrank import (
    LowRankActiveSetSolver,
    SingularActiveSetError,
    factorise_with_workspace_retry,
    mumps_failure,
    null_pivots,
)
from bonecontact.contact.options import LinearOptions
from bonecontact.contact.reductions import global_any

__all__ = [
    "KrylovStrategy",
    "LinearStrategy",
    "LowRankStrategy",
    "RefactorStrategy",
    "SetRows",
    "SetSolution",
    "make_strategy",
]


@dataclass
class SetRows:
    """The rows of one active set's system (this rank's contact rows, in the numbering of
    :class:`~bonecontact.contact.condensed.RowLayout`).

    ``fixed`` rows take ``values`` (active normal rows: the gap; stick rows: the old
    slip); free rows carry the given residual ``forces`` (2D / fixed-point slip rows:
    the friction force; zero elsewhere); the groups ``coupled = (rows, G, H, h)``
    replace their rows' equations by ``G w + H x = h`` (3D Newton slip rows, edge
    nodes).  ``margin`` is each row's distance from switching (low-rank speculation),
    or ``None``.
    """

    fixed: npt.NDArray[np.bool_]
    values: npt.NDArray[np.float64]
    forces: npt.NDArray[np.float64]
    coupled: tuple | None = None
    margin: npt.NDArray[np.float64] | None = None


class SetSolution(NamedTuple):
    """Unknowns ``x`` and residual ``w = T F̂ − Ã Ũ`` of this rank's contact rows,
    the linear iterations of the solve and what the history records of it."""

    x: npt.NDArray[np.float64]
    w: npt.NDArray[np.float64]
    iterations: int
    info: dict


class LinearStrategy(Protocol):
    """The linear solver of the PDAS (one object per operator)."""

    #: the contact forces of the result are recomputed from the field ``Ũ``
    field_multipliers: bool

    def begin(self, rows: SetRows) -> None:
        """Start a contact solve whose first system is ``rows`` (after
        :meth:`CondensedSystem.assemble_rhs`)."""

    def solve(self, rows: SetRows) -> SetSolution:
        """Solve the system of ``rows``; ``Ũ`` may be updated. Raises
        :class:`~bonecontact.contact.lowrank.SingularActiveSetError`."""

    def respond(self, rows: SetRows, shift: npt.NDArray[np.float64]) -> SetSolution:
        """The solution with the fixed values shifted by ``shift``, the state of the
        contact solve (and ``Ũ``) kept."""

    def finish(self, iterations: int) -> tuple[int, int]:
        """End the contact solve (``Ũ`` holds its solution); returns the factorisations
        and low-rank columns it took."""

    def set_rtol(self, rtol: float) -> None:
        """Relative tolerance of the next solves (Krylov only)."""

    def destroy(self) -> None:
        """Free the PETSc objects."""


class LowRankStrategy:
    """One factorisation reused through low-rank updates
    (:class:`~bonecontact.contact.lowrank.LowRankActiveSetSolver`)."""

    field_multipliers = True

    def __init__(
        self,
        system: CondensedSystem,
        options: LinearOptions,
        split: tuple | None,
    ):
        self.system = system
        self.lowrank = LowRankActiveSetSolver(
            system.At,
            system.bc_rows,
            system.layout.local_rows,
            system.diag_value,
            prefix=options.prefix,
            max_columns=options.max_columns,
            rebase_ratio=options.rebase_ratio,
            memory_ratio=options.memory_ratio,
            split=split,
            full_ratio=options.full_ratio,
        )
        if split is not None:
            # a split basis factorises its own operator: Ã is not needed beside it (the
            # system keeps its contact rows for the residuals; issue 28)
            system.take_operator(stripes=False).destroy()
        self._counts = (0, 0)

    def begin(self, rows: SetRows) -> None:
        lr, sy = self.lowrank, self.system
        self._counts = (lr.factorizations, lr.columns)
        lr.begin(sy.r0, sy.r0.array[sy.bc_local], rows.values, rows.fixed)

    def solve(self, rows: SetRows) -> SetSolution:
        x, w, info = self.lowrank.solve_set(
            rows.fixed, self.system.scale, rows.forces, rows.margin, rows.coupled
        )
        return SetSolution(
            x, w, 1, {"columns": info["columns"], "refactorized": info["refactorized"]}
        )

    def respond(self, rows: SetRows, shift: npt.NDArray[np.float64]) -> SetSolution:
        x, w = self.lowrank.respond(rows.fixed, self.system.scale, shift)
        return SetSolution(x, w, 0, {})

    def finish(self, iterations: int) -> tuple[int, int]:
        lr = self.lowrank
        lr.finish(self.system.Uh)
        return lr.factorizations - self._counts[0], lr.columns - self._counts[1]

    def set_rtol(self, rtol: float) -> None:
        pass

    def destroy(self) -> None:
        self.lowrank.destroy()


class RefactorStrategy:
    """Eliminate the fixed rows (symmetrically) and refactorise with MUMPS every
    iteration (the symbolic analysis is reused)."""

    field_multipliers = False
    kind = "direct"

    def __init__(
        self,
        system: CondensedSystem,
        options: LinearOptions,
        rtol: float,
        V: fem.FunctionSpace,
        nonsymmetric: bool,
    ):
        self.system = system
        # Ã itself, changed in place per set (the system keeps its stripes to restore it)
        self.B = system.take_operator()
        self.B.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
        self.ksp = PETSc.KSP().create(system.layout.comm)
        self.ksp.setOptionsPrefix(options.prefix)
        #: MUMPS ICNTL(14) after a factorisation ran out of work space (``None``: MUMPS's own)
        self.workspace: int | None = None
        self._configure(options, rtol, V, nonsymmetric)
        self.ksp.setFromOptions()
        self._rhs = self.B.createVecLeft()

    def _configure(
        self, options: LinearOptions, rtol: float, V: fem.FunctionSpace, nonsymmetric: bool
    ) -> None:
        """MUMPS LU with null-pivot detection (singular sets)."""
        configure_ksp(
            self.ksp,
            "direct",
            rtol=rtol,
            prefix=options.prefix,
            max_it=3000,
            options={"mat_mumps_icntl_24": 1},
        )

    def begin(self, rows: SetRows) -> None:
        pass

    def solve(self, rows: SetRows) -> SetSolution:
        self._eliminate(rows)
        self._ksp_solve(rows)
        sy = self.system
        x = sy.unknowns()
        w = sy.contact_residual()
        return SetSolution(x, w, self.ksp.getIterationNumber(), {})

    def respond(self, rows: SetRows, shift: npt.NDArray[np.float64]) -> SetSolution:
        # the solve overwrites the field Ũ: keep the current one (the PDAS may stop at
        # this iteration, and the next solve starts from it)
        Uh = self.system.Uh
        kept = Uh.copy()
        shifted = SetRows(rows.fixed, rows.values + shift, np.zeros_like(rows.forces))
        out = self.solve(shifted)
        kept.copy(Uh)
        kept.destroy()
        return out

    def finish(self, iterations: int) -> tuple[int, int]:
        return iterations, 0

    def set_rtol(self, rtol: float) -> None:
        pass

    def _eliminate(self, rows: SetRows) -> None:
        """``B``: ``Ã`` with the Dirichlet and fixed rows eliminated (symmetric), the given
        forces in the right-hand side, the coupled rows replaced."""
        sy, lay = self.system, self.system.layout
        v = self._rhs.duplicate()
        v.set(0.0)
        if sy.bc_local.size:
            v.array[sy.bc_local] = sy.r0.array[sy.bc_local]
        own_fixed = rows.fixed  # (the rows of this rank)
        v.array[lay.local_rows[own_fixed]] = rows.values[own_fixed]
        sy.r0.copy(self._rhs)
        self._rhs.array[lay.local_rows] -= rows.forces
        sy.restore_operator(self.B)
        eliminated = np.concatenate(
            [
                sy.bc_rows.astype(np.int64),
                lay.local_rows[own_fixed].astype(np.int64) + sy.start,
            ]
        ).astype(PETSc.IntType)
        self.B.zeroRowsColumns(eliminated, diag=sy.diag_value, x=v, b=self._rhs)
        v.destroy()
        # (the rows are this rank's: another rank may have groups when this one has
        # none, and the assembly that follows is collective)
        if global_any(lay.comm, rows.coupled is not None):
            self._replace_rows(rows.coupled)

    def _replace_rows(self, coupled: tuple | None) -> None:
        """Rows ``q`` of a slip node (free, no prescribed force): with ``w = rhs − B x``
        there, ``G w + H x = h`` becomes ``G B x − H x = G rhs − h`` (same pattern: the
        rows of one node share their columns).  ``None``: no group on this rank (it
        takes part in the assembly)."""
        if coupled is None:
            coupled = (np.zeros((0, 0), dtype=np.int64), None, None, None)
        crow, Gc, Hc, hc = coupled
        sy, lay = self.system, self.system.layout
        updates = []
        for i in range(crow.shape[0]):  # (the groups of this rank's nodes)
            grows = [int(lay.local_rows[q]) + sy.start for q in crow[i]]
            cols, vals = self._node_rows(grows)
            rhs_loc = np.array([self._rhs.array[r - sy.start] for r in grows])
            new = Gc[i] @ vals
            for a in range(len(grows)):
                for b_, c in enumerate(grows):
                    new[a, int(np.flatnonzero(cols == c)[0])] -= Hc[i, a, b_]
            updates.append((grows, cols, new))
            self._rhs.array[np.array(grows) - sy.start] = Gc[i] @ rhs_loc - hc[i]
        for grows, cols, new in updates:  # (no MatGetRow once values are set)
            for a, r in enumerate(grows):
                self.B.setValues([r], cols, new[a], addv=PETSc.InsertMode.INSERT_VALUES)
        self.B.assemble()

    def _node_rows(self, grows: list[int]) -> tuple[npt.NDArray, npt.NDArray[np.float64]]:
        """The shared columns and the values (one row each) of the global rows ``grows``
        of one slave node in ``B``."""
        data = [self.B.getRow(r) for r in grows]
        cols = data[0][0]
        if any(not np.array_equal(d[0], cols) for d in data):
            raise RuntimeError(
                "contact: the rows of a slave node do not share their sparsity pattern"
            )
        return cols, np.array([d[1] for d in data])

    def _ksp_solve(self, rows: SetRows) -> None:
        """Factorise ``B`` and solve into ``Ũ``; a factorisation that ran out of MUMPS work
        space is redone with ICNTL(14) doubled (as the low-rank solver's:
        :func:`~bonecontact.contact.lowrank.factorise_with_workspace_retry`); a singular
        or failed solve raises."""

        def solve() -> None:
            self.ksp.setOperators(self.B)
            self.ksp.solve(self._rhs, self.system.Uh)

        self.workspace = factorise_with_workspace_retry(
            self.ksp, solve, self.workspace, "linear solve (singular system?)"
        )
        self._check()

    def _check(self) -> None:
        """Null pivots or a diverged solve: the system of the set is singular."""
        nulls = null_pivots(self.ksp)
        if nulls:
            raise SingularActiveSetError(
                f"the system of the active set is singular ({nulls} "
                f"null pivots: a body without support?)"
            )
        failure = mumps_failure(self.ksp)
        if failure is not None:
            raise SingularActiveSetError(failure)
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise SingularActiveSetError(f"the linear solver diverged (reason {reason})")

    def destroy(self) -> None:
        for obj in (self.ksp, self.B, self._rhs):
            obj.destroy()


#: GMRES restart of the systems with coupled rows (Krylov strategy): the P2 runs of
#: issue 28 stopped after 60 iterations (compressed hierarchy, PETSc's restart 30).
GMRES_RESTART = 100


class _SumOperator:
    """``y = P x + C x`` (a ``python`` Mat's context): the exact matrix of a system with
    coupled rows, as the preconditioner's matrix ``P`` plus the rows ``C`` that differ."""

    def __init__(self, P: PETSc.Mat):
        self.P, self.C = P, None

    def mult(self, mat: PETSc.Mat, x: PETSc.Vec, y: PETSc.Vec) -> None:
        self.P.mult(x, y)
        self.C.multAdd(x, y, y)


class KrylovStrategy(RefactorStrategy):
    """Eliminate the fixed rows and solve by CG + GAMG (or the compressed hierarchy) with
    the rigid-body modes in the nodal frames; the preconditioner of an earlier set is
    kept while the set changes little
    (:class:`~bonecontact.contact.krylov.PreconditionerReuse`).

    Coupled rows (3D Newton slip rows, edge nodes; docs/theory/pdas.md#friction-rows-in-
    the-iterative-solver) are posed by :func:`~bonecontact.contact.coupled_rows.krylov_groups`;
    ``B`` stays symmetric (the elastic rows plus the positive part of the slip springs)
    and is the preconditioner's matrix, the exact system is ``B + C`` (``C`` the few
    differing entries), solved by right-preconditioned GMRES.
    """

    kind = "iterative"
    #: Start symmetric solves from the rescaled last solution (:meth:`_scale_guess`);
    #: ``False``: from the last solution as it is (the benchmarks' comparison).
    scale_guess = True

    def __init__(
        self,
        system: CondensedSystem,
        options: LinearOptions,
        rtol: float,
        V: fem.FunctionSpace,
        nonsymmetric: bool,
    ):
        rows = options.pc_reuse_rows
        if rows is None:
            rows = DEFAULT_REUSE_ROWS[options.multigrid]
        self.pc_reuse = PreconditionerReuse(rows, options.pc_reuse_growth)
        super().__init__(system, options, rtol, V, nonsymmetric)
        self._sum = _SumOperator(self.B)
        self._op = PETSc.Mat().createPython(self.B.getSizes(), self._sum, comm=self.B.getComm())
        self._op.setUp()
        self._sym_type = self.ksp.getType()
        self._plain_build = False  # (B of the last build had no springs; none yet)

    def _configure(
        self, options: LinearOptions, rtol: float, V: fem.FunctionSpace, nonsymmetric: bool
    ) -> None:
        """(docs/theory/pdas.md#iterative-linear-solver)"""
        sy, prefix = self.system, options.prefix
        configure_ksp(self.ksp, "iterative", rtol=rtol, prefix=prefix, max_it=3000)
        configure_condensed_ksp(
            self.ksp,
            self.B,
            V,
            sy.Qt,
            sy.T,
            prefix=prefix,
            rtol=rtol,
            nonsymmetric=False,  # (B is symmetric; coupled rows are applied apart)
            multigrid=options.multigrid,
            cycle=options.multigrid_cycle,
        )
        self.ksp.getPC().setUseAmat(False)  # (the multigrid smooths with B, not B + C)

    def solve(self, rows: SetRows) -> SetSolution:
        """The system of ``rows`` with its coupled rows in the Krylov form
        (:func:`~bonecontact.contact.coupled_rows.krylov_groups`: the same solution)."""
        fixed, values, groups = krylov_groups(rows.coupled, rows.fixed, rows.values)
        if self._sum.C is not None:  # (the last system's; _replace_rows sets this one's)
            self._sum.C.destroy()
            self._sum.C = None
        return super().solve(SetRows(fixed, values, rows.forces, groups or None, rows.margin))

    def _replace_rows(self, groups: list[CoupledGroup] | None) -> None:
        """The coupled groups of this rank (``None``: none; collective): scaled groups
        add the positive part ``S`` of their spring to ``B`` and the rest ``K − S`` to
        ``C``; other groups put their rows ``G B x − H x`` less ``B``'s into ``C``; the
        right-hand side of the rows becomes ``G r − h``."""
        sy, lay = self.system, self.system.layout
        adds, diffs = [], []
        for grp in groups or []:
            grows = [int(lay.local_rows[q]) + sy.start for q in grp.rows]
            if grp.scaled:
                S, rest = spring_split(grp.H)
                adds.append((grows, S))
                diffs.append((grows, np.asarray(grows, dtype=PETSc.IntType), rest))
            else:
                cols, vals = self._node_rows(grows)
                new = grp.G @ vals
                new[:, [int(np.flatnonzero(cols == c)[0]) for c in grows]] -= grp.H
                diffs.append((grows, cols, new - vals))
            idx = np.asarray(grows) - sy.start
            self._rhs.array[idx] = grp.G @ self._rhs.array[idx] - grp.h
        for grows, S in adds:  # (no MatGetRow once values are set)
            self.B.setValues(grows, grows, S.ravel(), addv=PETSc.InsertMode.ADD_VALUES)
        self.B.assemble()
        self._sum.C = self._difference(diffs)

    def _difference(self, diffs: list[tuple]) -> PETSc.Mat:
        """The matrix ``C`` of ``B``'s layout with the rows ``(rows, cols, values)``."""
        B, start = self.B, self.system.start
        (n, N), (m, M) = B.getSizes()
        nnz = np.zeros(n, dtype=PETSc.IntType)
        for grows, cols, _ in diffs:
            nnz[np.asarray(grows) - start] = len(cols)
        C = PETSc.Mat().createAIJ(B.getSizes(), comm=B.getComm())
        C.setPreallocationNNZ((np.minimum(nnz, m), np.minimum(nnz, M - m)))
        for grows, cols, vals in diffs:
            C.setValues(grows, cols, vals, addv=PETSc.InsertMode.INSERT_VALUES)
        C.assemble()
        return C

    def _use_method(self) -> None:
        """GMRES (right-preconditioned: its test is on the true residual) on ``B + C``
        while a system has coupled rows, else the symmetric method on ``B``."""
        ksp, nonsym = self.ksp, self._sum.C is not None
        if nonsym and ksp.getType() != PETSc.KSP.Type.GMRES:
            ksp.setType(PETSc.KSP.Type.GMRES)
            ksp.setGMRESRestart(GMRES_RESTART)
            ksp.setPCSide(PETSc.PC.Side.RIGHT)
            ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
        elif not nonsym and ksp.getType() != self._sym_type:
            ksp.setType(self._sym_type)
            ksp.setPCSide(PETSc.PC.Side.LEFT)
            ksp.setNormType(PETSc.KSP.NormType.DEFAULT)
        ksp.setOperators(self._op if nonsym else self.B, self.B)

    def finish(self, iterations: int) -> tuple[int, int]:
        return 0, 0

    def destroy(self) -> None:
        if self._sum.C is not None:
            self._sum.C.destroy()
        self._op.destroy()
        super().destroy()

    def set_rtol(self, rtol: float) -> None:
        self.ksp.setTolerances(rtol=rtol)

    def respond(self, rows: SetRows, shift: npt.NDArray[np.float64]) -> SetSolution:
        """The solution with the fixed values shifted by ``shift``, by linearity: the
        solution ``Ũ`` of the last solve (same rows, so the same ``B`` and preconditioner)
        plus the response ``y = s + z`` to the shift alone: ``s`` the shift in the fixed
        rows, ``B z = −Ã s`` in the free rows (zero in the fixed ones) solved from zero
        to :data:`~bonecontact.contact.krylov.RESPONSE_RTOL` of that load
        (docs/theory/pdas.md#iterative-linear-solver); ``Ũ`` is kept.  Systems with
        replaced (slip) rows take the full shifted solve."""
        if global_any(self.system.layout.comm, rows.coupled is not None) or RESPONSE_RTOL is None:
            return super().respond(rows, shift)
        sy, Uh = self.system, self.system.Uh
        rhs, lift = self._response_rhs(rows, shift)
        y = Uh.duplicate()
        y.set(0.0)
        rtol = self.ksp.getTolerances()[0]
        self.ksp.setInitialGuessNonzero(False)
        self.ksp.setTolerances(rtol=RESPONSE_RTOL)
        try:
            with self._products():
                self.ksp.solve(rhs, y)
        except PETSc.Error as exc:
            raise SingularActiveSetError(
                f"linear solve failed (singular system? PETSc error {exc.ierr})"
            ) from None
        finally:
            self.ksp.setInitialGuessNonzero(True)
            self.ksp.setTolerances(rtol=rtol)
        self._check()
        its = self.ksp.getIterationNumber()
        kept = Uh.copy()
        Uh.axpy(1.0, y)  # the shifted solution, for its contact rows
        Uh.axpy(1.0, lift)
        x, w = sy.unknowns(), sy.contact_residual()
        kept.copy(Uh)
        for obj in (rhs, lift, y, kept):
            obj.destroy()
        return SetSolution(x, w, its, {})

    def _products(self):
        """The GAMG set-ups of the solves keep no product data
        (:func:`~bonecontact.contact.condensed.lean_products`), unless GAMG is told to
        recompute its coarse operators in place (``pc_gamg_reuse_interpolation``)."""
        so = SolverOptions.of(self.ksp, self.ksp.getOptionsPrefix())
        reuse = {**so.options, **so.user_options()}.get("pc_gamg_reuse_interpolation", False)
        clear = str(reuse).lower() not in ("1", "true", "yes")
        return lean_products(self.system.layout.comm, clear=clear)

    def _response_rhs(
        self, rows: SetRows, shift: npt.NDArray[np.float64]
    ) -> tuple[PETSc.Vec, PETSc.Vec]:
        """The lift ``s`` (``shift`` in the fixed rows, zero elsewhere) and the load of the
        rest of the response: ``−Ã[:, F] shift`` in the free rows, zero in the fixed and
        Dirichlet rows (``B`` as eliminated by :meth:`_eliminate`, ``zeroRowsColumns``,
        with zero load and Dirichlet values).  The fixed rows carry no load, so the
        Krylov test weighs only the free rows whatever the preconditioner does with the
        fixed ones (with the fixed rows' ``diag · shift`` in the load, the compressed
        hierarchy's preconditioned norm stopped the solve at 1e-4 with the patch
        stiffness of the 3D test 114 % off)."""
        sy, lay = self.system, self.system.layout
        lift = self._rhs.duplicate()
        lift.set(0.0)
        fixed_local = lay.local_rows[rows.fixed]  # (the rows of this rank)
        lift.array[fixed_local] = shift[rows.fixed]
        rhs = self._rhs.duplicate()
        sy.operator_product(lift, rhs)
        rhs.scale(-1.0)
        rhs.array[fixed_local] = 0.0
        if sy.bc_local.size:
            rhs.array[sy.bc_local] = 0.0
        return rhs, lift

    def _scale_guess(self, rows: SetRows) -> float:
        """The initial guess of a symmetric system: the last solution ``Ũ`` rescaled in
        its free rows, the fixed and Dirichlet rows at their values
        (:func:`~bonecontact.contact.krylov.scale_initial_guess`); returns the factor."""
        sy = self.system
        fixed_local = sy.layout.local_rows[rows.fixed]
        eliminated = np.concatenate([fixed_local, sy.bc_local]).astype(np.int64)
        values = np.concatenate([rows.values[rows.fixed], sy.r0.array[sy.bc_local]])
        return scale_initial_guess(self.B, self._rhs, sy.Uh, eliminated, values)

    def _ksp_solve(self, rows: SetRows) -> None:
        """Keep or rebuild the preconditioner, solve from the scaled last solution
        (:meth:`_scale_guess`, symmetric systems); a kept preconditioner that fails is
        rebuilt and the solve repeated."""
        self._use_method()
        coupled = np.zeros_like(rows.fixed)
        for grp in rows.coupled or []:
            coupled[grp.rows] = True
        # (fixed and coupled rows apart: a stick row that slips changes the rows of B)
        replaced = np.concatenate([rows.fixed, coupled])
        if self._sum.C is not None:
            # (the springs change B at every iteration, stiff ones by orders of magnitude
            # beyond the kept smoother's bounds: 3D Tresca drag 4-5x the iterations)
            self.pc_reuse.forget()
        plain = self._sum.C is None
        allow_hierarchy_update(self.ksp, plain and self._plain_build)
        kept = self.pc_reuse.decide(self.ksp, replaced)
        self._plain_build = plain if not kept else self._plain_build
        Uh = self.system.Uh
        if plain and self.scale_guess:
            self._scale_guess(rows)
        try:
            with self._products():
                self.ksp.solve(self._rhs, Uh)
                if kept and self.ksp.getConvergedReason() < 0:
                    self.pc_reuse.forget()  # a kept preconditioner failed: rebuild, solve again
                    self.pc_reuse.decide(self.ksp, replaced)
                    self.ksp.solve(self._rhs, Uh)
        except PETSc.Error as exc:
            raise SingularActiveSetError(
                f"linear solve failed (singular system? PETSc error {exc.ierr})"
            ) from None
        self.pc_reuse.record(self.ksp.getIterationNumber(), reduction_decades(self.ksp))
        self._check()


def make_strategy(
    system: CondensedSystem,
    options: LinearOptions,
    linear: str,
    rtol: float,
    V: fem.FunctionSpace,
    nonsymmetric: bool,
    split: tuple | None,
) -> LowRankStrategy | RefactorStrategy:
    """The strategy of ``options.strategy`` for the linear solver ``linear`` (``"direct"``
    or ``"iterative"``); ``"auto"``: low-rank with the direct solver, else Krylov.

    ``nonsymmetric``: the systems have nonsymmetric rows (3D Newton slip rows);
    ``split``: the low-rank split basis arguments, or ``None``.
    """
    strategy = strategy_name(options.strategy, linear)
    if strategy == "lowrank":
        return LowRankStrategy(system, options, split)
    cls = KrylovStrategy if linear == "iterative" else RefactorStrategy
    return cls(system, options, rtol, V, nonsymmetric)


def strategy_name(strategy: str, linear: str) -> str:
    """``"lowrank"`` or ``"refactor"`` for the option ``strategy`` and the linear solver
    (``"auto"`` resolved); raises for low-rank with an iterative solver."""
    if strategy == "auto":
        strategy = "lowrank" if linear == "direct" else "refactor"
    if strategy not in ("lowrank", "refactor") or (strategy == "lowrank" and linear != "direct"):
        raise ValueError(
            f"contact strategy must be 'lowrank' (direct solver only) or 'refactor', "
            f"got {strategy!r} with linear={linear!r}"
        )
    return strategy
