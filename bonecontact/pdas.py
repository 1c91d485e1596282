"""Primal–dual active set (semi-smooth Newton) solver for frictionless mortar contact.

Algorithm (SPEC §5.1–5.3), on the condensed system of SPEC §4.3
-----------------------------------------------------------------
With ``Qᵀ`` from :func:`bonecontact.mortar.basis_transform`, the unknowns are
``Û = Q⁻ᵀ U`` (relative displacements at slave nodes), ``Â = Q A Qᵀ`` and
``F̂ = Q F``; the multipliers act only on the slave rows and the weak non-penetration
condition is nodal: ``n_pᵀ Û_p ≤ g_p = d_p / D_pp``.  The rows of every slave node are
rotated into its frame ``[n_p; t_p]`` (matrix ``T``), so that each node has one normal
row and ``gdim − 1`` tangential rows.  At iteration k, with the active set ``A``:

* ``p ∉ A``: the rows stay ``(T Â Û)_p = (T F̂)_p`` (λ_p = 0);
* ``p ∈ A``: the normal row is replaced by ``s_p n_pᵀ Û_p = s_p g_p`` (``s_p`` the
  diagonal of the row it replaces, for conditioning); the tangential rows stay
  (frictionless: λ_t = 0).

After the solve, ``λ_n,p = (T(F̂ − ÂÛ))_{p,n} / D_pp`` (SPEC (46)) and the new set is
``A = {p : λ_n,p + c_n (n_pᵀÛ_p − g_p) > 0}``.  The iteration stops when the set does
not change — the last solve is then the exact discrete solution of the linear
complementarity problem.  It fails with :class:`ContactConvergenceError` (iteration
history attached) when the iteration limit is reached or a set repeats (cycling), and
never returns an unconverged state.  ``c_n`` defaults to the mean ratio of the normal
rows' diagonal to ``D_pp`` (≈ E/h: stiffness per contact area), so the set update
weighs gaps and pressures on the scale of the problem.

Dirichlet rows of master dofs, mixed with slave rows by ``Q``, are reset to the
identity after the transformation, so ``U = Qᵀ Û`` meets every Dirichlet condition.

Non-singular first systems: without a warm start the active set begins with every
node whose gap is within ``gap_tol`` of the smallest gap of its pair (the closed-gap
nodes when the bodies touch, the closest ones when they start apart).  A body held only by contact therefore
starts supported wherever it touches; then the PDAS keeps at least those nodes whose
pressure stays positive.  (The remaining rigid modes that frictionless contact cannot
remove — sliding along the contact plane — must be fixed by the scene.)

Linear solvers: ``"direct"`` — MUMPS LU.  By default (``strategy="lowrank"``) one
set is factorised and the systems of the other sets are solved exactly by low-rank
updates of it (:mod:`bonecontact.lowrank`): a contact solve costs about one
factorisation plus a few multi-right-hand-side solves, and later steps of a run reuse
the factorisation.  ``strategy="refactor"`` re-factorises (numerically; the symbolic
analysis is reused) in every iteration — the reference the tests compare against.
``"iterative"`` — CG/GMRES preconditioned by GAMG (smoothed aggregation) on the
eliminated matrix of every iteration (``strategy="refactor"`` only).  Warm starts make
the iterative solves cheap in time-stepping runs.

Units: λ_n in Pa (N/m² — in 2D plane strain per unit thickness); forces in N (N/m in 2D).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from .linalg import configure_ksp
from .lowrank import LowRankActiveSetSolver, SingularActiveSetError, null_pivots
from .mortar import ContactInterface, basis_transform, rotation_matrix

__all__ = ["ContactConvergenceError", "ContactSolver", "PDASResult", "snes_vi_solve"]


class ContactConvergenceError(RuntimeError):
    """The PDAS iteration did not converge; ``history`` holds one dict per iteration."""

    def __init__(self, message: str, history: list[dict]):
        lines = [message, "  it  active  changed  |dU|/|U|      linear_its"]
        for h in history:
            lines.append(f"  {h['iteration']:2d}  {h['active']:6d}  {h['changed']:7d}  {h['update']:.3e}  "
                         f"{h['linear_iterations']:6d}")
        super().__init__("\n".join(lines))
        self.history = history


@dataclass
class PDASResult:
    """Outcome of one contact solve (per interface lists hold owned slave nodes)."""

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


def _allsum(comm: MPI.Comm, x) -> float:
    return comm.allreduce(x, op=MPI.SUM)


class ContactSolver:
    """Frictionless PDAS on the condensed mortar system (see the module docstring).

    Parameters
    ----------
    V
        The P1 vector space of the model.
    A
        The operator of one time step with Dirichlet rows and columns already
        eliminated (e.g. ``Integrator.A_bc``); it is transformed once here.
    interfaces
        The contact pairs (:func:`bonecontact.mortar.build_interface`).
    bc_rows
        Global PETSc rows (owned) with Dirichlet conditions.
    linear
        ``"direct"`` or ``"iterative"``.
    force_scale
        Factor turning the operator's forces into physical ones (1 for static;
        1/Δt quasistatic; 1/Δt² dynamic, matching ``combined_operator``).
    c_n
        Complementarity parameter (default: see the module docstring).
    max_iterations
        PDAS iteration limit.
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
        (:class:`bonecontact.lowrank.LowRankActiveSetSolver`).
    """

    def __init__(self, V: fem.FunctionSpace, A: PETSc.Mat, interfaces: list[ContactInterface],
                 bc_rows: npt.ArrayLike | None = None, *, linear: str = "direct", force_scale: float = 1.0,
                 c_n: float | None = None, max_iterations: int = 50, gap_tol: float | None = None,
                 rtol: float = 1e-12, prefix: str = "bc_contact_", strategy: str = "auto",
                 max_columns: int = 2000, rebase_ratio: float = 1.0):
        t0 = time.perf_counter()
        self.V, self.interfaces = V, list(interfaces)
        self.comm = V.mesh.comm
        self.bs = V.dofmap.index_map_bs
        self.force_scale = float(force_scale)
        self.max_iterations = int(max_iterations)
        self.linear = linear
        self.Qt = basis_transform(V, self.interfaces)
        self.Ahat = A.PtAP(self.Qt)
        self.T = rotation_matrix(V, self.interfaces)
        self.Tt = self.T.transpose(PETSc.Mat())  # (transpose() without an argument is in place)
        self.At = self.Ahat.PtAP(self.Tt)          # T Â Tᵀ: unknowns in the nodal frames
        start = self.bs * V.dofmap.index_map.local_range[0]
        self.bc_rows = np.asarray(bc_rows if bc_rows is not None else [], dtype=PETSc.IntType)
        self.bc_local = (self.bc_rows - start).astype(np.int32)
        if strategy == "auto":
            strategy = "lowrank" if linear == "direct" else "refactor"
        if strategy not in ("lowrank", "refactor") or (strategy == "lowrank" and linear != "direct"):
            raise ValueError(f"contact strategy must be 'lowrank' (direct solver only) or 'refactor', "
                             f"got {strategy!r} with linear={linear!r}")
        self.strategy = strategy
        self.nrow_local = [self.bs * itf.blocks.astype(np.int64) for itf in self.interfaces]
        self.nrow_global = [self.bs * itf.global_blocks for itf in self.interfaces]
        diag = self.At.getDiagonal()
        self.row_scale = [np.abs(diag.array[r]) for r in self.nrow_local]
        num = _allsum(self.comm, float(sum((s / itf.D).sum() for s, itf in zip(self.row_scale, self.interfaces))))
        cnt = _allsum(self.comm, sum(itf.num_owned for itf in self.interfaces))
        self.c_n = float(c_n) / self.force_scale if c_n is not None else (num / max(cnt, 1))
        # value on the diagonal of eliminated rows: the mean normal-row stiffness
        self.diag_value = float(num / max(cnt, 1)) * float(np.mean(np.concatenate(
            [i.D for i in self.interfaces] + [np.ones(1)]))) if cnt else 1.0
        self.diag_value = self.comm.allreduce(self.diag_value, op=MPI.MAX)
        gdim = V.mesh.geometry.dim
        size = max([itf.slave_area ** (1.0 / (gdim - 1)) for itf in self.interfaces] + [1e-300])
        self.gap_tol = float(gap_tol) if gap_tol is not None else 1e-9 * size
        self.active = self._cold_start()
        self.Uh = self.At.createVecRight()
        self.Uh.set(0.0)
        self._r0, self._rhs, self._w = self.At.createVecLeft(), self.At.createVecLeft(), self.At.createVecLeft()
        self._Fh = self.Qt.createVecRight()
        self.B = self.ksp = self.lowrank = None
        if strategy == "lowrank":
            self.lowrank = LowRankActiveSetSolver(self.At, self.bc_rows, self.nrow_local, self.diag_value,
                                                  prefix=prefix, max_columns=max_columns,
                                                  rebase_ratio=rebase_ratio)
        else:
            self.B = self.At.duplicate(copy=True)
            self.B.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
            self.ksp = PETSc.KSP().create(self.comm)
            self.ksp.setOptionsPrefix(prefix)
            configure_ksp(self.ksp, linear, rtol=rtol, prefix=prefix, max_it=3000)
            if linear == "direct":
                PETSc.Options()[f"{prefix}mat_mumps_icntl_24"] = 1    # detect null pivots (singular sets)
            if linear == "iterative":
                self.ksp.setInitialGuessNonzero(True)
            self.ksp.setFromOptions()
        self.setup_time = time.perf_counter() - t0

    # ------------------------------------------------------------------ helpers
    def _cold_start(self) -> list[np.ndarray]:
        """Initial active set: the nodes of each pair whose gap is within ``gap_tol`` of
        the smallest gap of that pair (the closed-gap nodes when the bodies touch; the
        closest nodes when they start apart, so a body held only by contact is
        supported from the first solve)."""
        out = []
        for itf in self.interfaces:
            gmin = self.comm.allreduce(float(itf.gap.min()) if itf.num_owned else np.inf, op=MPI.MIN)
            out.append(itf.gap <= max(gmin, 0.0) + self.gap_tol)
        return out


    def _operator(self, active: list[np.ndarray], rhs: PETSc.Vec, values: PETSc.Vec) -> None:
        """B = At with the Dirichlet rows and the active normal rows (and columns)
        eliminated: Ũ_i = values_i there, lifted into ``rhs`` (B stays symmetric)."""
        self.At.copy(self.B, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        rows = np.concatenate([self.bc_rows.astype(np.int64)]
                              + [g[a] for g, a in zip(self.nrow_global, active)]).astype(PETSc.IntType)
        self.B.zeroRowsColumns(rows, diag=self.diag_value, x=values, b=rhs)

    def _signature(self, active: list[np.ndarray]) -> tuple:
        local = tuple(int(b) for itf, a in zip(self.interfaces, active) for b in itf.global_blocks[a])
        return tuple(sorted(sum(self.comm.allgather(local), ())))

    # -------------------------------------------------------------------- solve
    def solve(self, b: PETSc.Vec, u: fem.Function) -> PDASResult:
        """Solve one contact problem ``A U = b + contact forces``; write ``U`` into ``u``.

        ``b`` is the right-hand side of the step with Dirichlet lifting applied (as
        for the plain linear solve).  The active set and ``Û`` are warm-started from
        the previous call.
        """
        t0 = time.perf_counter()
        comm = self.comm
        self.Qt.multTranspose(b, self._Fh)
        self.T.mult(self._Fh, self._r0)
        r0 = self._r0
        if self.bc_local.size:
            r0.array[self.bc_local] = b.array[self.bc_local]
        active = [a.copy() for a in self.active]
        history: list[dict] = []
        seen = {self._signature(active): 0}
        lin_total = 0
        lam_list = un_list = None
        lr = self.lowrank
        split = np.cumsum([r.size for r in self.nrow_local])[:-1]
        if lr is not None:
            f0, c0 = lr.factorizations, lr.columns
            lr.begin(r0, b.array[self.bc_local], self._concat([itf.gap for itf in self.interfaces]),
                     self._replicate(active))
            scale = self._replicate(self.row_scale)
            x_prev = lr._gather(self.Uh.array[lr.L])
            margin = None
        else:
            values = self._rhs.duplicate()
            Uh_new = self.Uh.duplicate()
        for k in range(1, self.max_iterations + 1):
            if lr is not None:
                try:
                    xN, wN, info = lr.solve_set(self._replicate(active), scale, margin)
                except SingularActiveSetError as exc:
                    raise ContactConvergenceError(f"contact: {exc} (PDAS iteration {k})", history) from None
                its = 1
                un_list = np.split(lr._own(xN), split)
                w_list = np.split(lr._own(wN), split)
                nrm = float(np.linalg.norm(xN))
                update = float(np.linalg.norm(xN - x_prev)) / nrm if nrm > 0 else 0.0
                x_prev = xN
                extra = {"columns": info["columns"], "refactorized": info["refactorized"]}
            else:
                values.set(0.0)
                if self.bc_local.size:
                    values.array[self.bc_local] = b.array[self.bc_local]
                for itf, rl, a in zip(self.interfaces, self.nrow_local, active):
                    values.array[rl[a]] = itf.gap[a]
                r0.copy(self._rhs)
                self._operator(active, self._rhs, values)
                self.ksp.setOperators(self.B)
                self.Uh.copy(Uh_new)
                try:
                    self.ksp.solve(self._rhs, Uh_new)
                except PETSc.Error as exc:
                    raise ContactConvergenceError(f"contact: linear solve failed in PDAS iteration {k} "
                                                  f"(singular system? PETSc error {exc.ierr})", history) from None
                if null_pivots(self.ksp):
                    raise ContactConvergenceError(f"contact: the system of the active set is singular "
                                                  f"({null_pivots(self.ksp)} null pivots: a body without support?) "
                                                  f"in PDAS iteration {k}", history)
                reason = self.ksp.getConvergedReason()
                its = self.ksp.getIterationNumber()
                if reason < 0:
                    raise ContactConvergenceError(f"contact: linear solver diverged (reason {reason}) in PDAS "
                                                  f"iteration {k}", history)
                self.At.mult(Uh_new, self._w)
                self._w.aypx(-1.0, r0)                       # w = T F̂ − At Û
                w_list = [self._w.array[rl] for rl in self.nrow_local]
                un_list = [Uh_new.array[rl] for rl in self.nrow_local]
                self._w.waxpy(-1.0, self.Uh, Uh_new)
                nrm = Uh_new.norm()
                update = self._w.norm() / nrm if nrm > 0 else 0.0
                Uh_new.copy(self.Uh)
                extra = {}
            lin_total += its
            # multipliers (SPEC (46)) and the new active set
            lam_list = [w / itf.D for w, itf in zip(w_list, self.interfaces)]
            lam_scale = comm.allreduce(max([float(np.abs(x).max()) if x.size else 0.0 for x in lam_list] + [0.0]),
                                       op=MPI.MAX)
            eps = 1e-10 * max(lam_scale, 1e-300)
            ind = [lam + self.c_n * (un - itf.gap) for lam, un, itf in zip(lam_list, un_list, self.interfaces)]
            new = [i > eps for i in ind]
            if lr is not None:
                margin = np.abs(self._replicate(ind) - eps)
            changed = _allsum(comm, int(sum(int((n != a).sum()) for n, a in zip(new, active))))
            n_act = _allsum(comm, int(sum(int(a.sum()) for a in active)))
            history.append({"iteration": k, "active": n_act, "changed": changed, "update": update,
                            "linear_iterations": its, **extra})
            if changed == 0:
                break
            active = new
            sig = self._signature(active)
            if sig in seen:
                raise ContactConvergenceError(f"contact: the active set cycles (iteration {k + 1} repeats "
                                              f"iteration {seen[sig]})", history)
            seen[sig] = k
        else:
            raise ContactConvergenceError(f"contact: no convergence in {self.max_iterations} PDAS iterations",
                                          history)
        if lr is not None:
            lr.finish(self.Uh)
            n_fact, n_cols = lr.factorizations - f0, lr.columns - c0
        else:
            values.destroy()
            Uh_new.destroy()
            n_fact, n_cols = (len(history) if self.linear == "direct" else 0), 0
        self.active = active
        uhat = self.Tt.createVecLeft()
        self.Tt.mult(self.Uh, uhat)                   # Û = Tᵀ Ũ
        self.Qt.mult(uhat, u.x.petsc_vec)             # U = Qᵀ Û
        uhat.destroy()
        u.x.scatter_forward()
        pressure = [np.where(a, lam, 0.0) * self.force_scale for lam, a in zip(lam_list, active)]
        gaps = [itf.gap - un for itf, un in zip(self.interfaces, un_list)]
        slips = [np.stack([self.Uh.array[rl + j] for j in range(1, self.bs)], axis=1) for rl in self.nrow_local]
        forces = [_allsum(comm, float((itf.weight * p).sum())) for itf, p in zip(self.interfaces, pressure)]
        n_active = [_allsum(comm, int(a.sum())) for a in active]
        return PDASResult(iterations=len(history), linear_iterations=lin_total, active=[a.copy() for a in active],
                          pressure=pressure, gap=gaps, slip=slips, normal_force=forces, n_active=n_active,
                          history=history, wall_time=time.perf_counter() - t0, factorizations=n_fact,
                          columns=n_cols)

    def _concat(self, parts: list[np.ndarray]) -> np.ndarray:
        return np.concatenate([np.asarray(p, dtype=np.float64) for p in parts] + [np.zeros(0)])

    def _replicate(self, parts: list[np.ndarray]) -> np.ndarray:
        """Per-interface owned arrays → one array over all slave nodes, identical on every rank."""
        dtype = parts[0].dtype if parts else np.float64
        return self.lowrank._gather(np.concatenate(list(parts) + [np.zeros(0, dtype=dtype)]))

    def reset(self) -> None:
        """Forget the warm start (cold start from the closed-gap set next time)."""
        self.active = self._cold_start()
        self.Uh.set(0.0)

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
