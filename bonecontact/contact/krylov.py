"""The iterative linear-solver path of the PDAS contact solver
(docs/theory/pdas.md#iterative-linear-solver).

Every PDAS iteration solves the condensed system ``B Ũ = r`` in the nodal frames of the
slave nodes: the operator ``At = T Q A Qᵀ Tᵀ`` with the Dirichlet rows, the fixed
contact rows (active normal rows, stick rows) eliminated and, with 3D Newton slip rows,
a few rows replaced by their linearisation.  It is solved by CG (GMRES with the
nonsymmetric slip rows) preconditioned by GAMG (plain aggregation, W-cycles).  This module
provides the three pieces the solver needs:

* :func:`condensed_near_nullspace` — the rigid-body modes of every body, mapped into the
  solved unknowns ``Ũ = T Q⁻ᵀ U`` (null vectors of the condensed operator of floating
  bodies).  Without a near-nullspace GAMG sees only the constant vectors and CG needs
  4–5 times as many iterations; with one set of modes for the whole mesh 4 times.
* :func:`configure_condensed_ksp` — the Krylov method and the GAMG options of the
  condensed system (the size of its coarse grid: :func:`coarse_grid_limit`), or the
  compressed hierarchy of :mod:`~bonecontact.contact.compressed_mg` (:func:`set_multigrid`).
* :class:`PreconditionerReuse` — when to keep the preconditioner of an earlier set
  (from an earlier PDAS iteration or time step) and when to rebuild it.

Units: none (linear algebra).
"""

from __future__ import annotations

from dataclasses import dataclass

from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
from dolfinx import fem

from bonecontact.common.linalg import configure_ksp, rigid_body_modes, solver_options
from bonecontact.contact.compressed_mg import CompressedMGOptions, CompressedMultigrid
from bonecontact.contact.reductions import global_count

__all__ = [
    "DEFAULT_REUSE_ROWS",
    "RESPONSE_RTOL",
    "PreconditionerReuse",
    "allow_hierarchy_update",
    "apply_inverse_transpose",
    "coarse_grid_limit",
    "condensed_near_nullspace",
    "configure_condensed_ksp",
    "krylov_rtol",
    "reduction_decades",
    "scale_initial_guess",
    "set_multigrid",
]

#: The multigrid preconditioners of the condensed system: PETSc's GAMG, or the
#: compressed-aggregation hierarchy of :mod:`bonecontact.contact.compressed_mg`.
MULTIGRIDS = ("gamg", "compressed")

#: :class:`PreconditionerReuse` ``rows`` when the options leave it open: GAMG's
#: preconditioner is kept across small set changes; the compressed hierarchy is rebuilt
#: for every new set (kept only for the same set) — kept across sets, its final solves
#: took 38–42 CG iterations at 200k dofs on 2 ranks against 15 fresh (contact solve
#: 79 → 50 iterations, 20.2 → 18.3 Gflop; 65k: 59 → 49, 6.3 → 5.5 Gflop;
#: benchmarks/README.md, "Compressed coarse grid").
DEFAULT_REUSE_ROWS = {"gamg": 0.25, "compressed": 0.0}

#: GAMG options of the condensed system (:class:`~bonecontact.common.linalg.SolverOptions`:
#: under the solver's own prefix; the command line overrides them under ``prefix``):
#: plain (unsmoothed) aggregation, W-cycles.  The condensation couples
#: every master interface node with the master nodes of all slave nodes around it (rows
#: of up to ~400 entries against ~50 in elasticity), and a smoothed prolongator spreads
#: these rows through the whole hierarchy: coarse operators 3–5 times denser than those
#: of the same mesh without contact, a set-up 5–15 times slower.  Plain aggregation
#: keeps the coarse operators sparse; the W-cycle (the small coarse levels visited
#: more often) keeps the iterations nearly independent of the mesh (load-driven 3D
#: Hertz, rtol 1e-12: 35 and 40 iterations at 25k and 65k dofs; V-cycles 48 and 71).
#: The size of the coarse grid: :func:`coarse_grid_limit`.
#: (``pc_gamg_reuse_interpolation``, keeping the aggregates and prolongators of the first
#: build when a set change rebuilds the preconditioner, was measured and not adopted: it
#: skips only the graph and aggregation, while the stale aggregates cost CG iterations —
#: 67 → 69 at 65k dofs, 75 → 80 at 200k — and operations.  The coarse grid stays
#: factorised by LU: Cholesky for symmetric systems gave the same iterations, half the
#: coarse factor and 12 % fewer operations at 65k, but failed — "PC failed" — where LU
#: did not, with ``pc_gamg_threshold`` 0.05 at 65k: not robust enough for a default.)
GAMG_OPTIONS: dict[str, object] = {"pc_gamg_agg_nsmooths": 0, "pc_mg_cycle_type": "w"}

#: Relative tolerance of the response to a shift of the fixed values (the cold start's
#: patch-stiffness solve, :meth:`~bonecontact.contact.linear_strategy.KrylovStrategy.respond`),
#: solved alone from zero: the tolerance is relative to the shift's own right-hand side.
#: ``None``: the whole shifted system is solved again from the last solution.
RESPONSE_RTOL: float | None = 1e-4


#: The loosest relative tolerance of the Krylov solves of a run: that of one plain linear
#: solve (the benchmarks' reference, ``benchmarks/bench_reference.py``: CG + GAMG, PETSc's
#: default test — the preconditioned residual relative to the preconditioned right-hand
#: side).  A contact solve's final solve measured to it keeps the active sets, the PDAS
#: iterations and the Hertz errors of the solve to 1e-12 (docs/theory/pdas.md#inexact-solves).
PLAIN_RTOL = 1e-8


def krylov_rtol(tolerance: float) -> float:
    """Relative tolerance of the Krylov solves for a scene's ``[solver] tolerance``:
    ``1e-2 · tolerance``, at most :data:`PLAIN_RTOL` (the default tolerance 1e-10 gives
    1e-12; 1e-6 gives the criterion of one plain linear solve, 1e-8).

    The contact solve's test is on its sets, not on a residual: the tolerance sets how
    accurately its final (settled-set) system is solved, as it does for a solve without
    contact.
    """
    return min(1e-2 * float(tolerance), PLAIN_RTOL)


def coarse_grid_limit(num_equations: int) -> int:
    """Largest coarse grid of the GAMG hierarchy (``pc_gamg_coarse_eq_limit``) for a
    condensed system of ``num_equations``: ``N/16``, at most 5000 (at least GAMG's 50).

    A W-cycle visits level ``k`` ``2^k`` times, so GAMG's default coarse grid (50
    equations: 7–8 levels at 10⁵–10⁶ dofs) made each cycle hundreds of latency-bound
    products with tiny matrices (200k dofs on 2 ranks: 576 matrix products per cycle).
    Stopping the coarsening earlier and solving that grid directly removes them and
    gives a better preconditioner, while a coarse grid too large for the problem costs
    more in its factorisation and solves than it saves.  Measured on the load-driven 3D
    Hertz problem (benchmarks/README.md, "Coarse grid"): 25k dofs best near 1600 (5000
    costs 3.5 times the operations), 65k dofs 1600–5000 alike, 200k and 1M dofs best at
    5000 (1M on 2 ranks: contact solve 183 → 87 s, CG iterations 100 → 83).
    """
    return int(min(5000, max(50, num_equations // 16)))


def apply_inverse_transpose(
    Qt: PETSc.Mat, z: PETSc.Vec, out: PETSc.Vec, max_terms: int = 8
) -> None:
    """``out = Q⁻ᵀ z`` for the basis transformation ``Qᵀ = I + N`` with nilpotent ``N``.

    ``N`` holds ``M̂`` in slave rows and master columns, so ``N² = 0`` for one pair (a
    body that is the slave of one pair and the master of another makes a longer chain).
    The Neumann series ``Q⁻ᵀ z = Σ_k (−N)^k z`` is then finite: iterate
    ``y ← z − N y`` until ``y`` no longer changes, without a global inverse.

    Raises
    ------
    RuntimeError
        If the series has not terminated after ``max_terms`` terms (``N`` not nilpotent).
    """
    N = Qt.duplicate(copy=True)
    N.shift(-1.0)  # (exact zeros on the diagonal: N y is exact where y is)
    ny, nxt = z.duplicate(), z.duplicate()
    z.copy(out)
    scale = z.norm(PETSc.NormType.INFINITY)
    try:
        for _ in range(max_terms):
            N.mult(out, ny)
            z.copy(nxt)
            nxt.axpy(-1.0, ny)  # z − N y
            nxt.axpy(-1.0, out)  # its change
            out.axpy(1.0, nxt)
            if nxt.norm(PETSc.NormType.INFINITY) <= 1e-14 * scale:
                return
    finally:
        for obj in (N, ny, nxt):
            obj.destroy()
    raise RuntimeError(
        f"contact: Qᵀ − I is not nilpotent of index ≤ {max_terms} (a cycle of contact pairs?)"
    )


def condensed_near_nullspace(V: fem.FunctionSpace, Qt: PETSc.Mat, T: PETSc.Mat) -> PETSc.NullSpace:
    """The rigid-body modes of every body in the unknowns of the condensed system.

    With ``U = Qᵀ Tᵀ Ũ`` a displacement ``z`` is ``Ũ = T Q⁻ᵀ z`` there: at a slave node
    the relative displacement ``z_p − Σ_q M̂_pq z_q`` in the node's frame.  A rigid mode
    ``z`` of one body (``A z = 0`` for a body without supports) is then a null vector of
    ``At = T Q A Qᵀ Tᵀ``: ``At Ũ = T Q A z = 0``.  The modes of the master body are not
    zero at the slave nodes, and those of the slave body not zero in their relative
    unknowns, so each body keeps its own six (three in 2D) modes: aggregates that
    contain slave and master nodes need both sets.

    Parameters
    ----------
    V
        The vector P1 space.
    Qt, T
        The basis transformation ``Qᵀ`` and the rotation ``T`` of the contact solver.

    Returns
    -------
    PETSc.NullSpace
        Orthonormalised vectors (6 or 3 per body), layout of ``At``.
    """
    modes = rigid_body_modes(V, per_body=True)
    vecs = []
    uhat = T.createVecRight()
    for z in modes.getVecs():
        apply_inverse_transpose(Qt, z, uhat)
        v = T.createVecLeft()
        T.mult(uhat, v)
        vecs.append(v)
    uhat.destroy()
    modes.destroy()
    basis = []
    for v in vecs:  # modified Gram–Schmidt (twice is enough)
        for _ in range(2):
            for w in basis:
                v.axpy(-v.dot(w), w)
        nrm = v.norm()
        if nrm > 1e-10 * np.sqrt(v.getSize()):
            v.scale(1.0 / nrm)
            basis.append(v)
        else:
            v.destroy()
    return PETSc.NullSpace().create(vectors=basis, comm=V.mesh.comm)


def configure_condensed_ksp(
    ksp: PETSc.KSP,
    B: PETSc.Mat,
    V: fem.FunctionSpace,
    Qt: PETSc.Mat,
    T: PETSc.Mat,
    *,
    prefix: str,
    rtol: float,
    nonsymmetric: bool,
    max_it: int = 3000,
    multigrid: str = "gamg",
    cycle: str = "w",
) -> None:
    """CG (GMRES if ``nonsymmetric``) + multigrid on the condensed matrix ``B``
    (:func:`set_multigrid`: GAMG or the compressed hierarchy, ``cycle`` ``"w"``/``"v"``).

    Sets the block size of ``B`` (the transformations lose it; GAMG aggregates nodes,
    not single rows, only with it), the near-nullspace of
    :func:`condensed_near_nullspace`, :data:`GAMG_OPTIONS` and the coarse grid of
    :func:`coarse_grid_limit` (options under the KSP's own prefix, in the options
    database only while it sets up or solves; the command line overrides them under
    ``prefix``) and a nonzero initial guess (the previous PDAS iterate).
    """
    bs = V.dofmap.index_map_bs
    B.setBlockSize(bs)
    nns = condensed_near_nullspace(V, Qt, T)
    B.setNearNullSpace(nns)
    nns.destroy()
    B.setOption(PETSc.Mat.Option.SPD, not nonsymmetric)
    gamg = {**GAMG_OPTIONS, "pc_gamg_coarse_eq_limit": coarse_grid_limit(B.getSize()[0])}
    gamg["pc_mg_cycle_type"] = cycle
    configure_ksp(ksp, "iterative", rtol=rtol, prefix=prefix, max_it=max_it, options=gamg)
    set_multigrid(ksp, multigrid, cycle, nonsymmetric, B.getSize()[0])
    if nonsymmetric:
        ksp.setType("gmres")  # the linearised slip rows are nonsymmetric
    ksp.setInitialGuessNonzero(True)
    ksp.setConvergenceHistory(length=max_it + 1, reset=True)  # (for reduction_decades)


def set_multigrid(
    ksp: PETSc.KSP, multigrid: str, cycle: str, nonsymmetric: bool, num_equations: int
) -> None:
    """Precondition ``ksp`` (its operators of ``num_equations`` with block size and
    near-nullspace set) by GAMG (the options :func:`configure_condensed_ksp` set) or by
    the compressed hierarchy (:class:`~bonecontact.contact.compressed_mg.CompressedMultigrid`,
    a ``python`` PC; its coarse grid as GAMG's, :func:`coarse_grid_limit`)."""
    if multigrid not in MULTIGRIDS:
        raise ValueError(f"multigrid must be one of {MULTIGRIDS}, got {multigrid!r}")
    pc = ksp.getPC()
    if multigrid == "gamg":
        if pc.getType() != "gamg":  # (GAMG reads its options when set from them)
            pc.setType("gamg")
            so = solver_options(ksp)
            if so is not None:
                with so.applied():
                    ksp.setFromOptions()
        return
    opts = CompressedMGOptions(
        cycle=cycle,
        coarse_limit=coarse_grid_limit(num_equations),
        esteig_ksp="gmres" if nonsymmetric else "cg",
        coarse_factor="lu" if nonsymmetric else "cholesky",
    )
    pc.setType("python")
    pc.setPythonContext(CompressedMultigrid(opts))


def allow_hierarchy_update(ksp: PETSc.KSP, allowed: bool) -> None:
    """Tell the compressed hierarchy of ``ksp`` (if it has one) whether its next set-up
    may update it (:meth:`~bonecontact.contact.compressed_mg.CompressedMultigrid.allow_update`:
    the operator changed since its build only in eliminated rows and columns)."""
    pc = ksp.getPC()
    if pc.getType() == "python":
        ctx = pc.getPythonContext()
        if isinstance(ctx, CompressedMultigrid):
            ctx.allow_update(allowed)


def reduction_decades(ksp: PETSc.KSP) -> float:
    """Decades by which the last solve of ``ksp`` reduced its residual norm (from the
    convergence history; 0 without one).  Solves to different tolerances, or from
    different initial guesses, compare by their iterations per decade."""
    hist = ksp.getConvergenceHistory()
    if len(hist) < 2 or not hist[-1] > 0.0 or not hist[0] > 0.0:
        return 0.0
    return float(max(np.log10(hist[0] / hist[-1]), 0.0))


#: :func:`scale_initial_guess` keeps a warm start whose best factor is within this of 1:
#: then its error is where the set changed, not in its overall size, and a factor
#: near 1 only spreads that error over the field (measured on the 4.5k-dof clamped 3D
#: problem: 0.998 took the second solve from 5 to 6 CG iterations; the load-driven
#: 65k-dof hemisphere's 0.063 took it from 15 to 11).
SCALE_KEEP_WITHIN = 0.1


def scale_initial_guess(
    B: PETSc.Mat,
    rhs: PETSc.Vec,
    x: PETSc.Vec,
    eliminated: npt.NDArray[np.int64],
    values: npt.NDArray[np.float64],
    keep_within: float = SCALE_KEEP_WITHIN,
) -> float:
    """Rescale the warm start ``x`` of the symmetric system ``B x = rhs`` in place
    (docs/theory/pdas.md#scaled-warm-start): with ``y`` = ``x`` with the eliminated rows
    zeroed, ``x ← α y + s`` where ``s`` holds ``values`` in the eliminated rows (this
    rank's local indices ``eliminated``: ``B``'s decoupled scaled identity rows, solved
    exactly by their values) and ``α = yᵀ(rhs − B s) / yᵀ B y`` minimises the energy norm
    of the error on that line (``yᵀ B s = 0``: the columns of eliminated rows are zero).
    ``α`` is 0 for ``y = 0`` (a first solve), 1 when ``x`` solves the system already,
    ``1/c`` when ``x`` is ``c`` times its solution.  ``x`` is left as it is when
    ``|α − 1| ≤ keep_within`` (:data:`SCALE_KEEP_WITHIN`).  One product with ``B``.

    Returns
    -------
    float
        The factor ``α``.
    """
    y = x.copy()
    y.array[eliminated] = 0.0
    By = y.duplicate()
    B.mult(y, By)
    den = By.dot(y)
    alpha = rhs.dot(y) / den if den > 0.0 else 0.0
    By.destroy()
    if abs(alpha - 1.0) <= keep_within:
        y.destroy()
        return float(alpha)
    y.scale(alpha)
    y.array[eliminated] = values
    y.copy(x)
    y.destroy()
    return float(alpha)


@dataclass
class PreconditionerReuse:
    """When to keep the GAMG preconditioner of an earlier set
    (docs/theory/pdas.md#preconditioner-reuse).

    The preconditioner of the condensed matrix ``B_C`` of a set ``C`` is kept for the
    matrix ``B_A`` of a later set ``A`` (a later PDAS iteration, or a later time step
    with the same operator) while

    * ``A`` and ``C`` differ in at most ``max(1, rows · n_C)`` contact rows (fixed or
      replaced in one and not in the other), ``n_C`` the contact rows fixed or
      replaced in ``C``, and
    * the last solve with it needed at most ``growth`` times the Krylov iterations per
      decade of residual reduction of the first solve after it was built (per decade:
      the loose and tight solves of an inexact PDAS reduce the residual by different
      factors);

    otherwise it is rebuilt from ``B_A``.  The kept cycle smooths the finest level
    with ``B_A`` but the diagonal and eigenvalue bounds of ``B_C``; should that make it
    indefinite, CG stops within a few iterations and the caller rebuilds
    (:meth:`forget`) and solves again.  ``rows = 0`` rebuilds for every other set and
    keeps the preconditioner for the same set (e.g. the settled set's tight solve after
    its loose one: the same matrix; slip rows' values may change, as with ``rows > 0``).

    Attributes
    ----------
    builds, reuses
        How many solves built a new preconditioner / kept the last one.
    """

    rows: float = 0.25
    growth: float = 1.5
    builds: int = 0
    reuses: int = 0
    _mask: npt.NDArray[np.bool_] | None = None
    _first_rate: float = 0.0
    _last_rate: float = 0.0
    _fresh: bool = False

    def decide(self, ksp: PETSc.KSP, replaced: npt.NDArray[np.bool_]) -> bool:
        """Before a solve: keep the preconditioner (``True``) or rebuild it, and tell
        ``ksp``.  ``replaced`` marks this rank's contact rows that are fixed or replaced
        in the set of the solve (the counts are summed over the ranks)."""
        keep = self._mask is not None
        if keep:
            comm = ksp.getComm().tompi4py()
            changed = global_count(comm, replaced != self._mask)
            n_c = global_count(comm, self._mask)
            keep = changed <= (max(1, int(self.rows * n_c)) if self.rows > 0.0 else 0)
            keep = keep and self._last_rate <= self.growth * max(self._first_rate, 1.0)
        ksp.getPC().setReusePreconditioner(keep)
        if keep:
            self.reuses += 1
        else:
            self.builds += 1
            self._mask = replaced.copy()
        self._fresh = not keep
        return keep

    def record(self, its: int, decades: float | None = None) -> None:
        """After the solve: its Krylov iterations and, if known, the decades by which
        it reduced the residual (:func:`reduction_decades`; the rate compared is
        iterations per decade, at least one decade counted)."""
        rate = its / max(decades if decades is not None else 1.0, 1.0)
        if self._fresh:
            self._first_rate = rate
        self._last_rate = rate

    def forget(self) -> None:
        """Rebuild at the next solve (a new operator, or a failed solve)."""
        self._mask = None
