"""Primal–dual active set (semi-smooth Newton) solver for mortar contact with friction.

Algorithm (SPEC §5), on the condensed system of SPEC §4.3
----------------------------------------------------------
With ``Qᵀ`` from :func:`bonecontact.contact.interface.basis_transform`, the unknowns are
``Û = Q⁻ᵀ U`` (relative displacements at slave nodes), ``Â = Q A Qᵀ`` and
``F̂ = Q F``; the multipliers act only on the slave rows and the weak contact
conditions are nodal.  The rows of every slave node are rotated into its frame
``[n_p; t_p(; t2_p)]`` (matrix ``T``): one normal row and ``gdim − 1`` tangential rows,
whose unknowns are the normal approach ``u_n,p`` and the relative tangential
displacement ``u_t,p``.  The contact force on the rows is ``−w`` with
``w = T(F̂ − ÂÛ)`` and the multipliers are ``λ = w / D_pp`` (SPEC (46)); ``λ_n > 0`` is
a pressure.  The slip of a step is ``Δu_t = u_t − u_t^{old}``.

Sets at iteration k (SPEC §5.2) and what each does to the rows (SPEC §5.3):

* open (``p ∉ A_n``): all rows stay (λ = 0);
* ``p ∈ A_n``: the normal row is replaced by ``u_n,p = g_p`` (gap ``d_p / D_pp``);
* stick (``p ∈ A_n``, ``|λ_t + c_t Δu_t| ≤ ĝ_p``, or a slip node whose slip reversed
  under the prescribed traction): the tangential rows are replaced by
  ``u_t,p = u_t^{old}`` (no slip in the step);
* slip (``|λ_t + c_t Δu_t| > ĝ_p``): in 2D the tangential rows carry the traction
  ``λ_t = ĝ_p s_p`` with ``s_p = sign(λ_t + c_t Δu_t)`` of the previous iterate —
  exactly the semi-smooth Newton step of C_t (SPEC (51)).  In 3D (default
  ``slip_3d="newton"``) the rows are replaced by the damped semi-smooth Newton
  linearisation of ``|ξ| λ_t − ĝ ξ = 0``, ``ξ = λ_t + c_t Δu_t``
  (Hüeber–Stadler–Wohlmuth 2008; see :meth:`ContactSolver._slip_newton_rows`): a
  nonsymmetric 2×2 coupling of traction and slip per node, locally superlinear
  (4–6 iterations per Cattaneo–Mindlin increment).  ``slip_3d="fixed_point"``
  prescribes ``λ_t = ĝ_p s_p`` along the previous direction and iterates the
  direction to a fixed point (Aitken-accelerated; symmetric systems, linear
  convergence, 6–18 iterations).  In 3D the sets *and* the directions must settle
  (to ``direction_tol``), and with Newton rows ``|λ_t − ĝ s| ≤ direction_tol · max ĝ``.
* frictionless pairs: the tangential rows always stay (λ_t = 0); their active nodes
  are reported as ``slip``.

Friction bounds ``ĝ_p``: Tresca, the given bound; Coulomb ``previous_step`` (semi-
implicit), ``μ λ_n,p`` of the previous step — one Tresca problem per step; Coulomb
``fixed_point`` (Algorithm FP), ``μ max(0, λ_n,p)`` from the current iterate, updated
every ``fp_every`` iterations until its relative change is below ``fp_tol``.  Any
other outcome — iteration limit, a repeated set (cycling) with unchanged bounds, a
singular system — raises :class:`ContactConvergenceError` with the iteration history;
an unconverged state is never returned.  ``c_n = c_t`` default to the mean ratio of
the normal rows' diagonal to ``D_pp`` (≈ E/h), so the set updates weigh gaps, slips
and tractions on the scale of the problem.

Dirichlet rows of master dofs, mixed with slave rows by ``Q``, are reset to the
identity after the transformation, so ``U = Qᵀ Û`` meets every Dirichlet condition.

Non-singular first systems: without a warm start the active set begins with every
node whose gap is within ``gap_tol`` of the smallest gap of its pair (the closed-gap
nodes when the bodies touch, the closest ones when they start apart), sticking if the
pair has friction.  A body held only by contact therefore starts supported wherever
it touches.  (Rigid modes that the contact cannot remove — sliding along a
frictionless contact plane — must be fixed by the scene.)  Held at those few nodes,
the first solve overestimates the contact zone (≈ √2 in radius for a Hertzian
contact), so the first set update of a cold start is damped: of the newly
penetrating nodes only those deeper than ``cold_start_fraction`` (0.7) of the deepest
are activated.  The PDAS then approaches the final set from near it (Hertz 2D: 2–5
iterations instead of 4–7 for a/h = 5–40, no overshoot); the solution is the same.

Linear solvers: ``"direct"`` — MUMPS LU.  By default (``strategy="lowrank"``) one
set is factorised and the systems of the other sets are solved exactly by low-rank
updates of it (:mod:`bonecontact.contact.lowrank`): a contact solve costs about one
factorisation plus a few multi-right-hand-side solves, and later steps of a run reuse
the factorisation.  ``strategy="refactor"`` re-factorises (numerically; the symbolic
analysis is reused) in every iteration — the reference the tests compare against.
``"iterative"`` — CG preconditioned by GAMG (smoothed aggregation) on the eliminated
matrix of every iteration (``strategy="refactor"`` only).

All set decisions are taken on arrays gathered over the slave nodes of every rank
(``n_slave × gdim`` numbers), identically on every rank; the linear algebra stays
distributed.

Units: λ in Pa (N/m² — in 2D plane strain per unit thickness); forces in N (N/m in 2D);
slips in m.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from bonecontact.common.linalg import configure_ksp
from bonecontact.contact.lowrank import LowRankActiveSetSolver, SingularActiveSetError, null_pivots
from bonecontact.contact.interface import ContactInterface, basis_transform, rotation_matrix

__all__ = ["ContactConvergenceError", "ContactSolver", "FrictionLaw", "PDASResult", "snes_vi_solve"]


class ContactConvergenceError(RuntimeError):
    """The PDAS iteration did not converge; ``history`` holds one dict per iteration."""

    def __init__(self, message: str, history: list[dict]):
        lines = [message, "  it  active  stick  slip  changed  |dU|/|U|    bound_change"]
        for h in history:
            lines.append(f"  {h['iteration']:2d}  {h['active']:6d}  {h.get('stick', 0):5d}  {h.get('slip', 0):4d}  "
                         f"{h['changed']:7d}  {h['update']:.3e}  {h.get('bound_change', 0.0):.3e}")
        super().__init__("\n".join(lines))
        self.history = history


@dataclass(frozen=True)
class FrictionLaw:
    """Friction of one contact pair.

    Parameters
    ----------
    kind
        ``"none"``, ``"tresca"`` (bound ``bound`` in Pa) or ``"coulomb"`` (coefficient
        ``coefficient``).
    update
        Coulomb only: ``"previous_step"`` (bound μ λ_n of the previous step) or
        ``"fixed_point"`` (Algorithm FP).
    """

    kind: Literal["none", "tresca", "coulomb"] = "none"
    coefficient: float = 0.0
    bound: float = 0.0
    update: Literal["previous_step", "fixed_point"] = "previous_step"

    def __post_init__(self) -> None:
        if self.kind not in ("none", "tresca", "coulomb"):
            raise ValueError(f"friction kind must be 'none', 'tresca' or 'coulomb', got {self.kind!r}")
        if self.update not in ("previous_step", "fixed_point"):
            raise ValueError(f"coulomb update must be 'previous_step' or 'fixed_point', got {self.update!r}")
        if self.coefficient < 0 or self.bound < 0:
            raise ValueError("friction coefficient and bound must be >= 0")


@dataclass
class PDASResult:
    """Outcome of one contact solve (per interface lists hold owned slave nodes).

    ``traction_t`` (Pa) and ``slip`` (the tangential slip of the step, m) have
    ``gdim − 1`` columns; ``status`` is ``"open"``, ``"stick"`` or ``"slip"`` per node.
    """

    iterations: int
    linear_iterations: int
    active: list[npt.NDArray[np.bool_]]
    pressure: list[npt.NDArray[np.float64]]
    gap: list[npt.NDArray[np.float64]]
    slip: list[npt.NDArray[np.float64]]
    normal_force: list[float]
    n_active: list[int]
    history: list[dict] = field(default_factory=list)
    wall_time: float = 0.0
    factorizations: int = 0
    columns: int = 0
    traction_t: list[npt.NDArray[np.float64]] = field(default_factory=list)
    status: list[npt.NDArray[np.str_]] = field(default_factory=list)
    tangential_force: list[float] = field(default_factory=list)
    n_stick: list[int] = field(default_factory=list)
    n_slip: list[int] = field(default_factory=list)
    bound_updates: int = 0


def _allsum(comm: MPI.Comm, x) -> float:
    return comm.allreduce(x, op=MPI.SUM)


class ContactSolver:
    """PDAS for mortar contact with Tresca/Coulomb friction (see the module docstring).

    Parameters
    ----------
    V
        The P1 vector space of the model.
    A
        The operator of one time step with Dirichlet rows and columns already
        eliminated (e.g. ``Integrator.A_bc``); it is transformed once here.
    interfaces
        The contact pairs (:func:`bonecontact.contact.interface.build_interface`).
    bc_rows
        Global PETSc rows (owned) with Dirichlet conditions.
    linear
        ``"direct"`` or ``"iterative"``.
    force_scale
        Factor turning the operator's forces into physical ones (1 for static;
        1/Δt quasistatic; 1/Δt² dynamic, matching ``combined_operator``).
    friction
        One :class:`FrictionLaw` for every pair, or a list with one per pair
        (default: frictionless).
    c_n, c_t
        Complementarity parameters (default: see the module docstring), in Pa/m.
    max_iterations
        PDAS iteration limit (all iterations of a solve, bound updates included).
    gap_tol
        Gaps below this (m) count as closed for the cold start (default 1e-9 × the
        slave surface size).
    rtol
        Krylov tolerance (iterative solver).
    strategy
        ``"lowrank"`` (default with ``linear="direct"``): one factorisation reused through
        low-rank updates; ``"refactor"``: factorise/precondition every iteration
        (the only choice with ``linear="iterative"``).
    max_columns, rebase_ratio
        Low-rank strategy: cache limit (columns) and the cost ratio (columns against one
        factorisation) beyond which the current set is refactorised instead
        (:class:`bonecontact.contact.lowrank.LowRankActiveSetSolver`).
    fp_every, fp_tol
        Coulomb ``fixed_point``: update the bounds every ``fp_every`` iterations (and
        whenever the sets have settled); converged when their relative change is
        below ``fp_tol``.
    direction_tol
        3D friction: slip directions must change by less than this between iterations
        (and, with ``slip_3d="newton"``, the slip traction must equal the bound times the
        direction to this relative accuracy).
    cold_start_fraction
        Cold start only (no warm start): the first set update activates, of the nodes
        that penetrate after the first solve, only those whose penetration exceeds this
        fraction of the deepest (0 = all).  The first solve holds the bodies at the
        closest nodes only, so it overestimates the contact zone (by ≈ √2 in radius for
        a Hertzian contact); the damped update starts the PDAS near the final set and
        saves iterations and low-rank columns.  Only the path changes: the converged
        solution is the same.
    slip_3d
        3D slip nodes: ``"newton"`` (default) — the damped semi-smooth Newton
        linearisation of C_t (Hüeber–Stadler–Wohlmuth), nonsymmetric rows;
        ``"fixed_point"`` — the traction is prescribed along the previous slip direction
        and the direction iterated (Aitken-accelerated) to a fixed point.
    """

    def __init__(self, V: fem.FunctionSpace, A: PETSc.Mat, interfaces: list[ContactInterface],
                 bc_rows: npt.ArrayLike | None = None, *, linear: str = "direct", force_scale: float = 1.0,
                 friction: FrictionLaw | list[FrictionLaw] | None = None,
                 c_n: float | None = None, c_t: float | None = None, max_iterations: int = 50,
                 gap_tol: float | None = None, rtol: float = 1e-12, prefix: str = "bc_contact_",
                 strategy: str = "auto", max_columns: int = 2000, rebase_ratio: float = 1.0,
                 fp_every: int = 1, fp_tol: float = 1e-8, direction_tol: float = 1e-6,
                 slip_3d: str = "newton", cold_start_fraction: float = 0.7):
        t0 = time.perf_counter()
        self.V, self.interfaces = V, list(interfaces)
        self.comm = V.mesh.comm
        comm = self.comm
        self.bs = bs = V.dofmap.index_map_bs
        self.force_scale = float(force_scale)
        self.max_iterations = int(max_iterations)
        self.linear = linear
        self.fp_every, self.fp_tol, self.direction_tol = max(int(fp_every), 1), float(fp_tol), float(direction_tol)
        if slip_3d not in ("newton", "fixed_point"):
            raise ValueError(f"slip_3d must be 'newton' or 'fixed_point', got {slip_3d!r}")
        self.slip_3d = slip_3d
        if not 0.0 <= cold_start_fraction < 1.0:
            raise ValueError(f"cold_start_fraction must be in [0, 1), got {cold_start_fraction}")
        self.cold_start_fraction = float(cold_start_fraction)
        if friction is None:
            friction = FrictionLaw()
        self.frictions = list(friction) if isinstance(friction, (list, tuple)) else [friction] * len(self.interfaces)
        if len(self.frictions) != len(self.interfaces):
            raise ValueError(f"{len(self.frictions)} friction laws for {len(self.interfaces)} contact pairs")
        self.Qt = basis_transform(V, self.interfaces)
        self.Ahat = A.PtAP(self.Qt)
        self.T = rotation_matrix(V, self.interfaces)
        self.Tt = self.T.transpose(PETSc.Mat())  # (transpose() without an argument is in place)
        self.At = self.Ahat.PtAP(self.Tt)          # T Â Tᵀ: unknowns in the nodal frames
        start = bs * V.dofmap.index_map.local_range[0]
        self.bc_rows = np.asarray(bc_rows if bc_rows is not None else [], dtype=PETSc.IntType)
        self.bc_local = (self.bc_rows - start).astype(np.int32)
        self._start = start
        if strategy == "auto":
            strategy = "lowrank" if linear == "direct" else "refactor"
        if strategy not in ("lowrank", "refactor") or (strategy == "lowrank" and linear != "direct"):
            raise ValueError(f"contact strategy must be 'lowrank' (direct solver only) or 'refactor', "
                             f"got {strategy!r} with linear={linear!r}")
        self.strategy = strategy
        # ---- layout: owned slave nodes (interface by interface) and their contact rows
        self.nrow_local = [bs * itf.blocks.astype(np.int64) for itf in self.interfaces]
        sizes = [itf.num_owned for itf in self.interfaces]
        self._m = int(sum(sizes))
        self._split = np.cumsum(sizes)[:-1]
        counts = comm.allgather(self._m)
        self._node_off = int(sum(counts[: comm.rank]))
        self.NS = int(sum(counts))
        nodes_local = np.concatenate(self.nrow_local + [np.zeros(0, np.int64)])
        self._L = np.concatenate([nodes_local + j for j in range(bs)]).astype(np.int32)   # component-major
        offs = np.cumsum([0] + counts[:-1])
        self._ridx = [np.concatenate([bs * o + j * c + np.arange(c) for o, c in zip(offs, counts)]).astype(np.int64)
                      for j in range(bs)]
        # ---- replicated node data
        self._D = self._gn(np.concatenate([itf.D for itf in self.interfaces] + [np.zeros(0)]))
        self._gap = self._gn(np.concatenate([itf.gap for itf in self.interfaces] + [np.zeros(0)]))
        kind = {"none": 0, "tresca": 1, "coulomb": 2}
        per = lambda f: self._gn(np.concatenate([np.full(n, f(fl), dtype=float)  # noqa: E731
                                                 for n, fl in zip(sizes, self.frictions)] + [np.zeros(0)]))
        self._fkind = per(lambda fl: kind[fl.kind]).astype(int)
        self._fric = self._fkind > 0
        self._mu = per(lambda fl: fl.coefficient)
        self._bound = per(lambda fl: fl.bound) / self.force_scale
        self._fp = (self._fkind == 2) & (per(lambda fl: fl.update == "fixed_point") > 0)
        self._newton_3d = bs == 3 and slip_3d == "newton" and bool(self._fric.any())
        diag = self.At.getDiagonal()
        self._scale = np.maximum(self._gn(np.abs(diag.array[self._L])), 1e-300)
        diag.destroy()
        sn = self._scale[self._ridx[0]]
        num = float((sn / np.where(self._D > 0, self._D, 1.0)).sum())
        self.c_n = float(c_n) / self.force_scale if c_n is not None else (num / max(self.NS, 1))
        self.c_t = float(c_t) / self.force_scale if c_t is not None else self.c_n
        # value on the diagonal of eliminated rows: the mean normal-row stiffness
        self.diag_value = (num / max(self.NS, 1)) * float(np.mean(self._D)) if self.NS else 1.0
        gdim = V.mesh.geometry.dim
        size = max([itf.slave_area ** (1.0 / (gdim - 1)) for itf in self.interfaces] + [1e-300])
        self.gap_tol = float(gap_tol) if gap_tol is not None else 1e-9 * size
        self.Uh = self.At.createVecRight()
        self._r0, self._rhs, self._w = self.At.createVecLeft(), self.At.createVecLeft(), self.At.createVecLeft()
        self._Fh = self.Qt.createVecRight()
        self.reset()
        self.B = self.ksp = self.lowrank = None
        if strategy == "lowrank":
            self.lowrank = LowRankActiveSetSolver(self.At, self.bc_rows, self._L, self.diag_value,
                                                  prefix=prefix, max_columns=max_columns,
                                                  rebase_ratio=rebase_ratio)
        else:
            self.B = self.At.duplicate(copy=True)
            self.B.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
            self.ksp = PETSc.KSP().create(comm)
            self.ksp.setOptionsPrefix(prefix)
            configure_ksp(self.ksp, linear, rtol=rtol, prefix=prefix, max_it=3000)
            if linear == "direct":
                PETSc.Options()[f"{prefix}mat_mumps_icntl_24"] = 1    # detect null pivots (singular sets)
            if linear == "iterative":
                self.ksp.setInitialGuessNonzero(True)
                if self._newton_3d:
                    self.ksp.setType("gmres")       # the linearised slip rows are nonsymmetric
            self.ksp.setFromOptions()
        self.setup_time = time.perf_counter() - t0

    # ------------------------------------------------------------------ layout helpers
    def _gn(self, local: npt.NDArray) -> npt.NDArray:
        """Local per-node (or per-row) values → the replicated array, identical on all ranks."""
        return np.concatenate(self.comm.allgather(np.ascontiguousarray(local)), axis=0)

    def _own(self, rep: npt.NDArray) -> list[npt.NDArray]:
        """Replicated per-node array → this rank's nodes, split by interface."""
        return np.split(rep[self._node_off:self._node_off + self._m], self._split)

    def _cold_start(self) -> npt.NDArray[np.bool_]:
        """Initial active set: the nodes of each pair whose gap is within ``gap_tol`` of
        the smallest gap of that pair (the closed-gap nodes when the bodies touch; the
        closest nodes when they start apart, so a body held only by contact is
        supported from the first solve)."""
        out = []
        for itf in self.interfaces:
            gmin = self.comm.allreduce(float(itf.gap.min()) if itf.num_owned else np.inf, op=MPI.MIN)
            out.append(itf.gap <= max(gmin, 0.0) + self.gap_tol)
        return self._gn(np.concatenate(out + [np.zeros(0, bool)]))

    @property
    def active(self) -> list[npt.NDArray[np.bool_]]:
        """The current (warm-start) active set, per interface, owned nodes."""
        return [a.copy() for a in self._own(self._an)]

    def reset(self) -> None:
        """Forget the warm start (cold start from the closed-gap set next time)."""
        self._an = self._cold_start()
        self._cold = True
        self._dir = np.zeros((self.NS, self.bs - 1))
        self._lam_n_prev = np.zeros(self.NS)
        self.Uh.set(0.0)

    def _fixed_rows(self, an: npt.NDArray, stick: npt.NDArray) -> npt.NDArray[np.bool_]:
        fixed = np.zeros(self.bs * self.NS, dtype=bool)
        fixed[self._ridx[0][an]] = True
        st = an & stick & self._fric
        for j in range(1, self.bs):
            fixed[self._ridx[j][st]] = True
        return fixed

    # ------------------------------------------------------------------ linear solves
    def _solve_refactor(self, fixed, values, wg, b, coupled=None) -> tuple[np.ndarray, np.ndarray, int]:
        """Eliminate the fixed rows (symmetric), prescribe ``w`` at force rows, replace the
        rows of ``coupled`` by their linearised slip equations, solve."""
        v = self._rhs.duplicate()
        v.set(0.0)
        if self.bc_local.size:
            v.array[self.bc_local] = b.array[self.bc_local]
        lo = self.bs * self._node_off
        own_fixed = fixed[lo:lo + self._L.size]
        v.array[self._L[own_fixed]] = values[lo:lo + self._L.size][own_fixed]
        self._r0.copy(self._rhs)
        self._rhs.array[self._L] -= wg[lo:lo + self._L.size]
        self.At.copy(self.B, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        rows = np.concatenate([self.bc_rows.astype(np.int64),
                               self._L[own_fixed].astype(np.int64) + self._start]).astype(PETSc.IntType)
        self.B.zeroRowsColumns(rows, diag=self.diag_value, x=v, b=self._rhs)
        v.destroy()
        if coupled is not None:
            self._replace_rows(coupled, lo)
        self.ksp.setOperators(self.B)
        try:
            self.ksp.solve(self._rhs, self.Uh)
        except PETSc.Error as exc:
            raise SingularActiveSetError(f"linear solve failed (singular system? PETSc error {exc.ierr})") from None
        if null_pivots(self.ksp):
            raise SingularActiveSetError(f"the system of the active set is singular ({null_pivots(self.ksp)} "
                                         f"null pivots: a body without support?)")
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise SingularActiveSetError(f"the linear solver diverged (reason {reason})")
        self.At.mult(self.Uh, self._w)
        self._w.aypx(-1.0, self._r0)                       # w = T F̂ − At Û
        return self._gn(self.Uh.array[self._L]), self._gn(self._w.array[self._L]), self.ksp.getIterationNumber()

    def _replace_rows(self, coupled, lo: int) -> None:
        """Rows ``q`` of a slip node (free, no prescribed force): with ``w = rhs − B x``
        there, ``G w + H x = h`` becomes ``G B x − H x = G rhs − h`` (same pattern: the
        rows of one node share their columns)."""
        crow, Gc, Hc, hc = coupled
        hi = lo + self._L.size
        mine = np.flatnonzero((crow[:, 0] >= lo) & (crow[:, 0] < hi))
        updates = []
        for i in mine:
            grows = [int(self._L[q - lo]) + self._start for q in crow[i]]
            data = [self.B.getRow(r) for r in grows]
            cols = data[0][0]
            vals = np.array([d[1] for d in data])
            if any(not np.array_equal(d[0], cols) for d in data):
                raise RuntimeError("contact: the rows of a slave node do not share their sparsity pattern")
            rhs_loc = np.array([self._rhs.array[r - self._start] for r in grows])
            new = Gc[i] @ vals
            for a, r in enumerate(grows):
                for b_, c in enumerate(grows):
                    new[a, int(np.flatnonzero(cols == c)[0])] -= Hc[i, a, b_]
            updates.append((grows, cols, new))
            self._rhs.array[np.array(grows) - self._start] = Gc[i] @ rhs_loc - hc[i]
        for grows, cols, new in updates:          # (no MatGetRow once values are set)
            for a, r in enumerate(grows):
                self.B.setValues([r], cols, new[a], addv=PETSc.InsertMode.INSERT_VALUES)
        self.B.assemble()

    # -------------------------------------------------------------------- solve
    def solve(self, b: PETSc.Vec, u: fem.Function) -> PDASResult:
        """Solve one contact problem ``A U = b + contact forces``; write ``U`` into ``u``.

        ``b`` is the right-hand side of the step with Dirichlet lifting applied (as
        for the plain linear solve).  Sets, slip directions and ``Û`` are warm-started
        from the previous call; the slip of this step is measured from its ``Û``.
        """
        t0 = time.perf_counter()
        comm, bs, NS = self.comm, self.bs, self.NS
        self.Qt.multTranspose(b, self._Fh)
        self.T.mult(self._Fh, self._r0)
        if self.bc_local.size:
            self._r0.array[self.bc_local] = b.array[self.bc_local]
        R = self._ridx
        D, gap, fric = self._D, self._gap, self._fric
        Dsafe = np.where(D > 0, D, 1.0)
        xold = self._gn(self.Uh.array[self._L])
        values = xold.copy()
        values[R[0]] = gap
        # stick predictor: every active friction node starts the step sticking (the
        # elastic trial state); the first solve shows where the bound is exceeded
        an, stick, dirs = self._an.copy(), self._an & fric, self._dir.copy()
        g = np.where(self._fkind == 1, self._bound, self._mu * np.maximum(self._lam_n_prev, 0.0))
        lr = self.lowrank
        if lr is not None:
            f0, c0 = lr.factorizations, lr.columns
            lr.begin(self._r0, b.array[self.bc_local], values, self._fixed_rows(an, stick))
        history: list[dict] = []
        seen: set = set()
        lin_total, n_bound = 0, 0
        margin = None
        x_prev = xold
        aitken: list = [None, 1.0]       # 3D slip directions: previous residual, relaxation
        lam_t_k = z_k = None             # 3D Newton: traction and ξ = λ_t + c_t Δu_t of the last iterate
        newton = self._newton_3d
        for k in range(1, self.max_iterations + 1):
            fixed = self._fixed_rows(an, stick)
            slip = an & fric & ~stick
            wg = np.zeros(bs * NS)
            coupled = None
            if newton:
                # (a slip node with a zero bound is a free row with zero force: no Newton row)
                if (slip & (g > 0.0)).any():
                    coupled = self._slip_newton_rows(np.flatnonzero(slip & (g > 0.0)), lam_t_k, z_k, g, xold)
            else:
                for j in range(1, bs):
                    wg[R[j][slip]] = (g * D * dirs[:, j - 1])[slip]
            try:
                if lr is not None:
                    x, w, info = lr.solve_set(fixed, self._scale, wg, margin, coupled)
                    its = 1
                    extra = {"columns": info["columns"], "refactorized": info["refactorized"]}
                else:
                    x, w, its = self._solve_refactor(fixed, values, wg, b, coupled)
                    extra = {}
            except SingularActiveSetError as exc:
                raise ContactConvergenceError(f"contact: {exc} (PDAS iteration {k})", history) from None
            lin_total += its
            lam_n = w[R[0]] / Dsafe
            lam_t = np.stack([w[R[j]] / Dsafe for j in range(1, bs)], axis=1)
            un = x[R[0]]
            dut = np.stack([x[R[j]] - xold[R[j]] for j in range(1, bs)], axis=1)
            lam_scale = float(np.abs(lam_n).max()) if NS else 0.0
            eps = 1e-10 * max(lam_scale, 1e-300)
            ind_n = lam_n + self.c_n * (un - gap)
            new_an = ind_n > eps
            if k == 1 and self._cold and self.cold_start_fraction > 0 and (new_an & ~an).any():
                # damped first activation (cold start only): of the newly penetrating nodes
                # keep those within cold_start_fraction of the deepest penetration
                pen = un - gap
                new_an &= an | (pen > self.cold_start_fraction * float(pen[new_an & ~an].max()))
            # Coulomb fixed point (Algorithm FP): bounds from the current normal multipliers
            changed_sets = int((new_an != an).sum())
            z = lam_t + self.c_t * dut
            zn = np.linalg.norm(z, axis=1)
            bound_change = 0.0
            if self._fp.any():
                # the sets have settled for the current bounds: update them now
                trial_stick = new_an & fric & ~self._slip_set(new_an, zn, g, eps)
                settle = changed_sets == 0 and not ((trial_stick != stick) & new_an & fric).any()
                if k % self.fp_every == 0 or settle:
                    g_new = g.copy()
                    g_new[self._fp] = self._mu[self._fp] * np.maximum(lam_n[self._fp], 0.0)
                    den = float(np.linalg.norm(g_new[self._fp]))
                    bound_change = float(np.linalg.norm(g_new[self._fp] - g[self._fp])) / den if den > 0 else 0.0
                    if bound_change > 0.0:
                        g = g_new
                        n_bound += 1
                        seen.clear()
            new_slip = self._slip_set(new_an, zn, g, eps)
            new_dirs = dirs.copy()
            nz = new_slip & (zn > 0)
            new_dirs[nz] = z[nz] / zn[nz, None]
            # a node whose slip reverses under the prescribed traction overshot: it sticks
            # next (without this, large c_t makes whole slip zones flip back and forth)
            reverse = new_slip & slip & (g > 0.0) & ((new_dirs * dirs).sum(axis=1) < 0.0)
            new_slip &= ~reverse
            new_stick = new_an & fric & ~new_slip
            changed_t = int(((new_stick != stick) & new_an & fric).sum())
            both = new_slip & slip
            if bs == 2:
                changed_t += int((np.sign(new_dirs[both, 0]) != np.sign(dirs[both, 0])).sum())
                turned = 0
            elif newton:   # 3D Newton: directions settled and λ_t = ĝ s on the slip nodes (ĝ > 0)
                bg = both & (g > 0.0)
                turned = int((np.linalg.norm(new_dirs[bg] - dirs[bg], axis=1) > self.direction_tol).sum())
                gs = max(float(g.max()) if NS else 0.0, eps)
                off = np.linalg.norm(lam_t[bg] - g[bg, None] * new_dirs[bg], axis=1) > self.direction_tol * gs
                turned += int(off.sum())
            else:   # 3D: slip directions converge (linearly) to a fixed point
                turned = int((np.linalg.norm(new_dirs[both] - dirs[both], axis=1) > self.direction_tol).sum())
                # Aitken-accelerated direction update while the sets stay the same
                res_d = np.where(both[:, None], new_dirs - dirs, 0.0).ravel()
                if (changed_sets + changed_t == 0 and aitken[0] is not None
                        and aitken[0].shape == res_d.shape):
                    dr = res_d - aitken[0]
                    den = float(dr @ dr)
                    if den > 0:
                        aitken[1] = float(np.clip(-aitken[1] * float(aitken[0] @ dr) / den, 0.2, 20.0))
                else:
                    aitken[1] = 1.0
                aitken[0] = res_d
                if aitken[1] != 1.0:
                    upd = dirs[both] + aitken[1] * (new_dirs[both] - dirs[both])
                    nrm_d = np.linalg.norm(upd, axis=1)
                    ok = nrm_d > 1e-12
                    idx = np.flatnonzero(both)[ok]
                    new_dirs[idx] = upd[ok] / nrm_d[ok, None]
            changed = changed_sets + changed_t + turned
            nrm = float(np.linalg.norm(x))
            update = float(np.linalg.norm(x - x_prev)) / nrm if nrm > 0 else 0.0
            x_prev = x
            history.append({"iteration": k, "active": int(an.sum()), "stick": int((an & stick & fric).sum()),
                            "slip": int(slip.sum()), "changed": changed, "update": update,
                            "bound_change": bound_change, "linear_iterations": its, **extra})
            if changed == 0 and bound_change <= self.fp_tol:
                break
            # margins: how close each row is to switching (for speculative low-rank columns)
            margin = np.full(bs * NS, np.inf)
            margin[R[0]] = np.abs(ind_n - eps)
            for j in range(1, bs):
                margin[R[j][new_an & fric]] = np.abs(zn - g)[new_an & fric]
            an, stick, dirs = new_an, new_stick, new_dirs
            lam_t_k, z_k = lam_t, z
            if changed_sets + changed_t == 0:
                continue          # only 3D slip directions still turning: not a cycle
            sig = (an.tobytes(), stick.tobytes(), np.sign(dirs).tobytes() if bs == 2 else b"")
            if sig in seen:
                raise ContactConvergenceError(f"contact: the active set cycles (iteration {k + 1} repeats an "
                                              f"earlier set)", history)
            seen.add(sig)
        else:
            raise ContactConvergenceError(f"contact: no convergence in {self.max_iterations} PDAS iterations",
                                          history)
        if lr is not None:
            lr.finish(self.Uh)
            n_fact, n_cols = lr.factorizations - f0, lr.columns - c0
        else:
            n_fact, n_cols = (len(history) if self.linear == "direct" else 0), 0
        self._an, self._dir = an, dirs
        self._cold = False
        self._lam_n_prev = np.where(an, lam_n, 0.0)
        uhat = self.Tt.createVecLeft()
        self.Tt.mult(self.Uh, uhat)                   # Û = Tᵀ Ũ
        self.Qt.mult(uhat, u.x.petsc_vec)             # U = Qᵀ Û
        uhat.destroy()
        u.x.scatter_forward()
        return self._result(an, stick, lam_n, lam_t, un, dut, history, lin_total, n_fact, n_cols, n_bound, t0)

    def _slip_newton_rows(self, S: npt.NDArray, lam_t: npt.NDArray, z: npt.NDArray, g: npt.NDArray,
                          xold: npt.NDArray) -> tuple:
        """The damped semi-smooth Newton rows of 3D slip nodes ``S`` (Hüeber–Stadler–Wohlmuth).

        At a slip node, ``C_t = |ξ| λ_t − ĝ ξ = 0`` with ``ξ = λ_t + c_t Δu_t``.  Linearised at
        the last iterate ``(λ^k, ξ^k)``, ``n = ξ^k/|ξ^k|``:

        ``|ξ^k| λ_t − ĝ ξ + θ λ̃ nᵀ (ξ − ξ^k) = 0``,

        with ``λ̃ = ĝ λ^k / max(ĝ, |λ^k|)`` (the traction projected on the friction disc) and
        ``θ = β = 1/(1 − αδ)`` where ``λ^k`` points away from ``ξ^k``
        (``α = λ^kᵀn/|λ^k| < 0``, ``δ = min(|λ^k|/ĝ, 1)``), else θ = 1: the damping of
        Hüeber–Stadler–Wohlmuth (SPEC appendix A).  θ = 1 with ``|λ^k| ≤ ĝ`` is the exact
        Newton step; every θ keeps the solution (at ``ξ = ξ^k`` the row reads
        ``λ_t = ĝ n``).  With ``λ_t = w_t / D``, ``Δu_t = x_t − x_t^{old}`` the rows read
        ``G w_t + H x_t = h``.
        """
        R, D, c = self._ridx, self._D[S], self.c_t
        rows = np.stack([R[j][S] for j in range(1, self.bs)], axis=1)
        zk, lk, gk = z[S], lam_t[S], g[S]
        zn = np.linalg.norm(zk, axis=1)
        n = zk / zn[:, None]
        lt = lk * (gk / np.maximum(np.maximum(gk, np.linalg.norm(lk, axis=1)), 1e-300))[:, None]
        # HSW damping (SPEC appendix A): where λ^k points away from ξ^k (α < 0) the term is
        # scaled by β = 1/(1 − αδ) ∈ [1/2, 1), δ = min(|λ^k|/ĝ, 1)
        lnorm = np.linalg.norm(lk, axis=1)
        alpha = (lk * n).sum(axis=1) / np.maximum(lnorm, 1e-300)
        delta = np.minimum(lnorm / np.maximum(gk, 1e-300), 1.0)
        theta = 1.0 / (1.0 - np.minimum(alpha, 0.0) * delta)
        eye = np.eye(self.bs - 1)[None, :, :]
        outer = (theta[:, None] * lt)[:, :, None] * n[:, None, :]                    # θ λ̃ nᵀ
        Gm = (1.0 - gk / zn)[:, None, None] * eye + outer / zn[:, None, None]
        Hp = c * (outer - gk[:, None, None] * eye) / zn[:, None, None]
        xo = xold[rows]
        h = D[:, None] * (theta[:, None] * lt + np.einsum("iab,ib->ia", Hp, xo))
        return rows, Gm, D[:, None, None] * Hp, h

    def _slip_set(self, an: np.ndarray, zn: np.ndarray, g: np.ndarray, eps: float) -> np.ndarray:
        """Active friction nodes with |λ_t + c_t Δu_t| above the bound (SPEC §5.2); a node
        with a zero bound (Coulomb with no pressure yet) slips: it carries no tangential
        traction (a "stick" decided on round-off of ξ ≈ 0 could only toggle)."""
        gtol = 1e-10 * max(float(g.max()) if self.NS else 0.0, eps)
        return an & self._fric & ((zn > g + gtol) | (g <= 0.0))

    def _result(self, an, stick, lam_n, lam_t, un, dut, history, lin_total, n_fact, n_cols, n_bound, t0):
        comm, fs = self.comm, self.force_scale
        fric = self._fric
        pressure_r = np.where(an, lam_n, 0.0) * fs
        trac_r = np.where(an[:, None] & fric[:, None], lam_t, 0.0) * fs
        status_r = np.where(~an, "open", np.where(fric & stick, "stick", "slip"))
        act, pres, gaps, slips, tracs, stats = (self._own(an), self._own(pressure_r), self._own(self._gap - un),
                                                self._own(dut), self._own(trac_r), self._own(status_r))
        forces, tforces, n_active, n_stick, n_slip = [], [], [], [], []
        for k, itf in enumerate(self.interfaces):
            forces.append(_allsum(comm, float((itf.weight * pres[k]).sum())))
            ft = np.zeros(itf.gdim)
            for j in range(self.bs - 1):
                if itf.num_owned:
                    ft += ((itf.weight * tracs[k][:, j])[:, None] * itf.tangents[:, j, :]).sum(axis=0)
            ft = comm.allreduce(ft, op=MPI.SUM)
            tforces.append(float(np.linalg.norm(ft)))
            n_active.append(_allsum(comm, int(act[k].sum())))
            n_stick.append(_allsum(comm, int((stats[k] == "stick").sum())))
            n_slip.append(_allsum(comm, int((stats[k] == "slip").sum())))
        return PDASResult(iterations=len(history), linear_iterations=lin_total, active=[a.copy() for a in act],
                          pressure=pres, gap=gaps, slip=slips, normal_force=forces, n_active=n_active,
                          history=history, wall_time=time.perf_counter() - t0, factorizations=n_fact,
                          columns=n_cols, traction_t=tracs, status=stats, tangential_force=tforces,
                          n_stick=n_stick, n_slip=n_slip, bound_updates=n_bound)

    def destroy(self) -> None:
        if self.lowrank is not None:
            self.lowrank.destroy()
        for obj in (self.ksp, self.B, self.At, self.T, self.Tt, self.Ahat, self.Qt, self.Uh, self._r0, self._rhs,
                    self._w, self._Fh):
            if obj is not None:
                obj.destroy()


def snes_vi_solve(A: PETSc.Mat, b: PETSc.Vec, lower: PETSc.Vec, upper: PETSc.Vec,
                  prefix: str = "vi_") -> tuple[PETSc.Vec, int, int]:
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
