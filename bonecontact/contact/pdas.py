"""Primal–dual active set (semi-smooth Newton) contact solver for dual-mortar contact
with Tresca/Coulomb friction: :class:`ContactSolver`.

The algorithm, its set rules, friction, cold start and linear solvers are described in
docs/theory/pdas.md (the condensed system in docs/theory/mortar.md).  The solver is
assembled from four parts, each in its own module:

* :class:`~bonecontact.contact.condensed.CondensedSystem` — the condensed, rotated
  system of the time step's operator and the layout of the contact rows;
* a :class:`~bonecontact.contact.linear_strategy.LinearStrategy` — low-rank updates,
  refactorisation or Krylov, chosen once in :meth:`ContactSolver.setup`;
* :class:`~bonecontact.contact.set_update.SetUpdate` — active/inactive, stick/slip,
  slip directions, bounds and the edge rule;
* :class:`~bonecontact.contact.friction.NodalFriction` — the friction laws node by node.

Set decisions are taken node by node on the rank that owns the slave node, with scalar
reductions only (docs/theory/pdas.md#distributed-set-logic); the linear algebra stays
distributed.  Units: λ in Pa (N/m² — per unit thickness in 2D),
forces in N (N/m in 2D), slips in m.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
from dolfinx import fem

from bonecontact.common.errors import RunError
from bonecontact.contact import cold_start
from bonecontact.contact.cold_start import SUPPORT_RADIUS, support_patch
from bonecontact.contact.condensed import CondensedSystem
from bonecontact.contact.friction import NodalFriction
from bonecontact.contact.interface import ContactInterface
from bonecontact.contact.linear_strategy import (
    LinearStrategy,
    SetRows,
    SetSolution,
    make_strategy,
    strategy_name,
)
from bonecontact.contact.lowrank import SingularActiveSetError
from bonecontact.contact.options import PDASOptions
from bonecontact.contact.reductions import global_sum, global_vsum
from bonecontact.contact.set_update import Iterate, PDASState, SetUpdate, WarmStart

__all__ = [
    "SUPPORT_RADIUS",
    "ContactConvergenceError",
    "ContactSolver",
    "PDASResult",
    "support_patch",
]


class ContactConvergenceError(RunError):
    """The PDAS iteration did not converge; ``history`` holds one dict per iteration."""

    def __init__(self, message: str, history: list[dict]):
        lines = [message, "  it  active  stick  slip  changed  |dU|/|U|    bound_change"]
        for h in history:
            lines.append(
                f"  {h['iteration']:2d}  {h['active']:6d}  {h.get('stick', 0):5d}  "
                f"{h.get('slip', 0):4d}  "
                f"{h['changed']:7d}  {h['update']:.3e}  {h.get('bound_change', 0.0):.3e}"
            )
        super().__init__("\n".join(lines))
        self.history = history


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
    return global_sum(comm, x)


class ContactSolver:
    """PDAS for mortar contact with Tresca/Coulomb friction (docs/theory/pdas.md).

    The solver is built in two stages: the constructor takes the space, the contact
    pairs and the options; :meth:`setup` (called by
    :class:`bonecontact.mechanics.integrator.Integrator`, which is handed the solver)
    takes the operator of the time step, its Dirichlet rows, the force scale and the
    linear solver.  The solver is the integrator's
    :class:`~bonecontact.mechanics.step_solver.StepSolver`: besides :meth:`solve` it
    provides the contact gaps and contact work of the energy balance.

    After :meth:`setup`: :attr:`system` (the condensed system), :attr:`linear_solver`
    (the linear strategy), :attr:`sets` (the set update), :attr:`friction` (the laws
    node by node) and :attr:`warm` (the warm start of the next solve).

    Parameters
    ----------
    V
        The P1 vector space of the model.
    interfaces
        The contact pairs (:func:`bonecontact.contact.interface.build_interface`).
    options
        :class:`~bonecontact.contact.options.PDASOptions` (default: all defaults,
        frictionless).
    """

    def __init__(
        self,
        V: fem.FunctionSpace,
        interfaces: list[ContactInterface],
        options: PDASOptions | None = None,
    ):
        self.V, self.interfaces = V, list(interfaces)
        self.options = options if options is not None else PDASOptions()
        self.frictions = self.options.frictions(len(self.interfaces))
        self.comm = V.mesh.comm
        self.bs = V.dofmap.index_map_bs
        self.last_result: PDASResult | None = None
        #: ``on_singular(active, stick)`` (per interface, over its owned slave nodes;
        #: collective) → the bodies the sets leave without support, in words, added to
        #: the message of a singular system; set by the runner
        #: (:func:`bonecontact.scene.rigid_motions.singular_diagnosis`), or ``None``.
        self.on_singular = None
        self.system: CondensedSystem | None = None
        self.linear_solver: LinearStrategy | None = None
        self.sets: SetUpdate | None = None
        self.friction: NodalFriction | None = None
        self.warm: WarmStart | None = None
        self._gap_vecs: tuple[PETSc.Vec, PETSc.Vec] | None = None
        self._work_gaps: list[npt.NDArray[np.float64]] = []

    @property
    def slave_blocks(self) -> list[npt.NDArray[np.int32]]:
        """Local blocks of the owned slave nodes that carry a multiplier, per pair."""
        return [itf.blocks for itf in self.interfaces]

    def setup(
        self,
        A: PETSc.Mat,
        bc_rows: npt.ArrayLike | None = None,
        *,
        force_scale: float = 1.0,
        linear: str = "direct",
        rtol: float = 1e-12,
        release_operator: bool = False,
    ) -> None:
        """Transform and factorise (or precondition) the operator of the time step.

        Parameters
        ----------
        A
            The operator of one time step with Dirichlet rows and columns already
            eliminated (e.g. ``Integrator.A_bc``); it is transformed once here.
        bc_rows
            Global PETSc rows (owned) with Dirichlet conditions.
        force_scale
            Factor turning the operator's forces into physical ones (1 for static;
            1/Δt quasistatic; 1/Δt² dynamic, matching ``combined_operator``).
        linear
            ``"direct"`` or ``"iterative"``.
        rtol
            Krylov tolerance (iterative solver).
        release_operator
            The caller needs ``A`` no more: it is destroyed as soon as it is transformed
            (collective), unless the low-rank solver's split basis keeps it — the
            set-up's peak then holds one matrix of ``A``'s size less (issue 28).
        """
        t0 = time.perf_counter()
        opts = self.options
        strategy_name(opts.linear.strategy, linear)  # (a wrong choice fails before the work)
        self.force_scale = float(force_scale)
        self.max_iterations = int(opts.max_iterations)
        self.linear = linear
        self.system = sy = CondensedSystem.build(
            self.V, self.interfaces, A, bc_rows, self.force_scale
        )
        sizes = [itf.num_owned for itf in self.interfaces]
        self.friction = NodalFriction.of_pairs(
            self.frictions, sizes, sy.layout.comm, self.force_scale
        )
        self.sets = SetUpdate(sy, self.friction, opts.active_set, opts.slip)
        self.gap_tol = self._gap_tolerance()
        self.reset()
        split = self._split_basis(A)
        if release_operator and strategy_name(opts.linear.strategy, linear) != "lowrank":
            A.destroy()  # (only its transformation is needed from here on)
        self.linear_solver = make_strategy(
            sy, opts.linear, linear, rtol, self.V, self.sets.newton_3d, split
        )
        self.rtol = float(rtol)
        # inexact PDAS (docs/theory/pdas.md#inexact-solves): frictionless iterative only
        loose = opts.linear.loose_rtol
        inexact = linear == "iterative" and not self.friction.any_active
        self.loose_rtol = float(loose) if inexact and loose > self.rtol else self.rtol
        self.setup_time = time.perf_counter() - t0

    def _gap_tolerance(self) -> float:
        """``gap_tol`` of the options, or 1e-9 of the largest slave surface size."""
        gap_tol = self.options.active_set.gap_tol
        if gap_tol is not None:
            return float(gap_tol)
        gdim = self.V.mesh.geometry.dim
        size = max([itf.slave_area ** (1.0 / (gdim - 1)) for itf in self.interfaces] + [1e-300])
        return 1e-9 * size

    def _split_basis(self, A: PETSc.Mat) -> tuple | None:
        """Arguments of the low-rank solver's split basis (``None`` without one): the
        operator in the original basis, the rows (all components) of the cold-start
        support patch and the rows fixed in its first system (the base)."""
        if not self.options.linear.split_basis:
            return None
        sy, an = self.system, self.warm.active
        lay = sy.layout
        allowed = np.zeros(lay.n_rows, dtype=bool)
        for j in range(lay.bs):
            allowed[lay.rows_of[j][an]] = True
        first = lay.fixed_rows(an, an & self.friction.active)
        return (A, sy.Qt, sy.T, sy.Tt, allowed, first)

    # ------------------------------------------------------------ older attribute names
    @property
    def Qt(self) -> PETSc.Mat | None:
        """``Qᵀ`` of :attr:`system` (``None`` before :meth:`setup`)."""
        return None if self.system is None else self.system.Qt

    @property
    def T(self) -> PETSc.Mat:
        """The rotation ``T`` of :attr:`system`."""
        return self.system.T

    @property
    def At(self) -> PETSc.Mat | None:
        """The condensed operator ``Ã`` of :attr:`system` (``None`` once a strategy has
        taken it over: the refactor/Krylov strategies' :attr:`B` is ``Ã`` changed in
        place)."""
        return self.system.At

    @property
    def B(self) -> PETSc.Mat | None:
        """The eliminated matrix of the refactor/Krylov strategy (else ``None``)."""
        return getattr(self.linear_solver, "B", None)

    @property
    def ksp(self) -> PETSc.KSP | None:
        """The KSP of the refactor/Krylov strategy (else ``None``)."""
        return getattr(self.linear_solver, "ksp", None)

    @property
    def pc_reuse(self):
        """The preconditioner reuse rule of the Krylov strategy (else ``None``)."""
        return getattr(self.linear_solver, "pc_reuse", None)

    # ------------------------------------------------------------------ warm start
    def _unsupported(self, st: PDASState) -> str:
        """What :attr:`on_singular` says about the sets of ``st`` (empty without it)."""
        if self.on_singular is None:
            return ""
        own = self.system.layout.own
        text = self.on_singular(own(st.an), own(st.an & st.stick))
        return f"; with this active set: {text}" if text else ""

    @property
    def active(self) -> list[npt.NDArray[np.bool_]]:
        """The current (warm-start) active set, per interface, owned nodes."""
        return [a.copy() for a in self.system.layout.own(self.warm.active)]

    def reset(self) -> None:
        """Forget the warm start (cold start from the closed-gap set next time)."""
        lay = self.system.layout
        self.warm = WarmStart(
            active=cold_start.initial_set(lay, self.interfaces, self.gap_tol),
            directions=np.zeros((lay.n_nodes, self.bs - 1)),
            lam_n_prev=np.zeros(lay.n_nodes),
        )
        self.system.Uh.set(0.0)

    def state(self) -> dict:
        """The warm start carried from one step to the next (for a checkpoint).

        Per pair, on this rank's owned slave nodes (the order of ``interface.blocks``):
        ``active`` (bool), ``directions`` (slip directions, (n, gdim − 1)), ``lam_n_prev``
        (previous normal multipliers, operator units), ``stick``, ``lam_t`` and ``xi``
        (the friction state of the last step: stick set, tangential traction and
        ``ξ``, operator units; a cold start's: every active node sticking, zeros) and
        ``work_gaps`` (gaps before the next step, for the contact work); ``Uh`` the last
        solution in the nodal frames (owned rows, a copy) and ``cold`` whether no step
        has been solved yet.
        """
        own, w = self.system.layout.own, self.warm
        zt = np.zeros_like(w.directions)
        stick = w.active if w.stick is None else w.stick
        return {
            "active": [a.copy() for a in own(w.active)],
            "directions": [a.copy() for a in own(w.directions)],
            "lam_n_prev": [a.copy() for a in own(w.lam_n_prev)],
            "stick": [a.copy() for a in own(stick)],
            "lam_t": [a.copy() for a in own(zt if w.lam_t is None else w.lam_t)],
            "xi": [a.copy() for a in own(zt if w.xi is None else w.xi)],
            "work_gaps": [g.copy() for g in self._work_gaps],
            "Uh": self.system.Uh.array.copy(),
            "cold": bool(w.cold),
        }

    def restore_state(self, state: dict) -> None:
        """Take the warm start of :meth:`state` (same layout; collective)."""
        lay = self.system.layout

        def rep(key: str, dtype: type) -> npt.NDArray:
            parts = [np.asarray(a, dtype=dtype) for a in state[key]]
            return np.concatenate(parts) if parts else np.zeros(0, dtype)

        tang = (lay.n_nodes, self.bs - 1)
        # (a state without the friction keys: every active node starts sticking)
        friction = "stick" in state and not state["cold"]
        self.warm = WarmStart(
            active=rep("active", bool),
            directions=rep("directions", float).reshape(tang),
            lam_n_prev=rep("lam_n_prev", float),
            cold=bool(state["cold"]),
            stick=rep("stick", bool) if friction else None,
            lam_t=rep("lam_t", float).reshape(tang) if friction else None,
            xi=rep("xi", float).reshape(tang) if friction else None,
        )
        self._work_gaps = [np.asarray(g, dtype=float).copy() for g in state["work_gaps"]]
        self.system.Uh.array[:] = state["Uh"]

    # -------------------------------------------------------------------- solve
    def solve(self, b: PETSc.Vec, u: fem.Function) -> PDASResult:
        """Solve one contact problem ``A U = b + contact forces``; write ``U`` into ``u``.

        ``b`` is the right-hand side of the step with Dirichlet lifting applied (as
        for the plain linear solve).  Sets, slip directions and ``Ũ`` are warm-started
        from the previous call; the slip of this step is measured from its ``Ũ``.

        The algorithm (docs/theory/pdas.md), one PDAS iteration per pass of steps 3–9:

        1. right-hand side in the slave frames (:meth:`_assemble_rhs`);
        2. stick predictor from the previous step (:meth:`_predict`);
        3. solve the system of the current sets (:meth:`_solve_linear_system`);
        4. multipliers and indicators from the solution (:meth:`_update_multipliers`);
        5. new active set (:meth:`_update_active_set`);
        6. Coulomb fixed point: friction bounds (:meth:`_update_friction_bounds`);
        7. new stick/slip sets, slip directions and edge nodes (:meth:`_update_slip_sets`);
        8. converged when nothing changed (:meth:`_check_convergence`);
        9. accept the new sets, detect cycling (:meth:`_accept_sets`);
        10. ``U = Qᵀ Tᵀ Ũ`` and the result (:meth:`_finish`).

        Steps 3–5 are repeated to the tight Krylov tolerance once a loose (inexact)
        solve leaves the active set unchanged (docs/theory/pdas.md#inexact-solves).
        """
        if self.system is None:
            raise RuntimeError(
                "ContactSolver.solve before setup (the Integrator sets the solver up)"
            )
        t0 = time.perf_counter()
        self._assemble_rhs(b)
        st = self._predict()
        loose = self.loose_rtol > self.rtol
        for k in range(1, self.max_iterations + 1):
            it, its, extra, now_loose = self._solve_and_update_active(st, k, loose)
            if loose and not now_loose:
                st.seen.clear()  # a cycle is one of tight solves: loose sets do not count
            loose = now_loose
            self._update_friction_bounds(st, it, k)
            self._update_slip_sets(st, it)
            if self._check_convergence(st, it, k, its, extra) and not loose:
                break
            try:
                self._accept_sets(st, it, k)
            except ContactConvergenceError:
                if not loose:
                    raise
                # a set repeated under loose solves: from here on every solve is tight
                loose = False
                st.seen.clear()
        else:
            raise ContactConvergenceError(
                f"contact: no convergence in {self.max_iterations} PDAS iterations", st.history
            )
        self.last_result = self._finish(st, it, u, t0)
        return self.last_result

    def _solve_and_update_active(
        self, st: PDASState, k: int, loose: bool
    ) -> tuple[Iterate, int, dict, bool]:
        """Steps 3–5, with the inexact PDAS's tight re-solve of a settled set; returns the
        iterate, the linear iterations, the history extras and whether solves stay loose."""
        self.linear_solver.set_rtol(self.loose_rtol if loose else self.rtol)
        sol = self._solve_linear_system(st, k)
        it = self._update_multipliers(st, sol)
        self._update_active_set(st, it, k)
        its, extra = sol.iterations, sol.info
        if loose and it.changed_sets == 0:
            # the set settled under a loose solve: the same set to the tight tolerance,
            # from the loose iterate; the tests below see only this solve
            loose = False
            self.linear_solver.set_rtol(self.rtol)
            sol = self._solve_linear_system(st, k)
            its, extra = its + sol.iterations, sol.info
            it = self._update_multipliers(st, sol)
            self._update_active_set(st, it, k)
        extra["krylov_rtol"] = self.loose_rtol if loose else self.rtol
        return it, its, extra, loose

    def _assemble_rhs(self, b: PETSc.Vec) -> None:
        """Step 1: ``T F̂ = T Q b`` (Dirichlet rows keep their prescribed values)."""
        self.system.assemble_rhs(b)

    def _predict(self) -> PDASState:
        """Step 2: the warm-started sets with every active friction node sticking (the
        elastic trial state); the linear strategy starts its solve."""
        st = self.sets.start(self.warm, self.system.unknowns())
        try:
            zero = np.zeros(self.system.layout.n_rows)
            self.linear_solver.begin(SetRows(self.sets.fixed_rows(st), st.values, zero))
        except SingularActiveSetError as exc:
            raise ContactConvergenceError(
                f"contact: {exc} (first PDAS iteration){self._unsupported(st)}", st.history
            ) from None
        return st

    def _solve_linear_system(self, st: PDASState, k: int) -> SetSolution:
        """Step 3: solve with the rows of the current sets replaced
        (:meth:`SetUpdate.system_rows`); returns the replicated unknowns and forces
        ``w`` of the contact rows, the linear iterations and extra history."""
        rows = self.sets.system_rows(st)
        try:
            sol = self.linear_solver.solve(rows)
        except SingularActiveSetError as exc:
            raise ContactConvergenceError(
                f"contact: {exc} (PDAS iteration {k}){self._unsupported(st)}", st.history
            ) from None
        st.lin_total += sol.iterations
        return sol

    def _update_multipliers(self, st: PDASState, sol: SetSolution) -> Iterate:
        """Step 4: ``λ = w / D``, the normal approach, the slip of the step, the normal
        indicator ``λ_n + c_n (u_n − g)`` and ``ξ = λ_t + c_t Δu_t``."""
        return self.sets.iterate(st, sol.x, sol.w)

    def _update_active_set(self, st: PDASState, it: Iterate, k: int) -> None:
        """Step 5: ``p ∈ A_n`` where ``λ_n + c_n (u_n − g) > 0``
        (docs/theory/pdas.md#active-set-rule).

        First update of a cold start: in 3D the set predicted from the compliance of the
        support patch (:func:`bonecontact.contact.cold_start.predicted_set`); in 2D (or
        with ``cold_start_3d="damped"``) of the newly penetrating nodes those within
        ``cold_start_fraction`` of the deepest penetration.  A prediction that keeps the
        first set is checked by the plain rule (else it would read as converged).
        """
        first = k == 1 and self.warm.cold
        if first and self.bs == 3 and self.options.active_set.cold_start_3d == "compliance":
            rows = SetRows(self.sets.fixed_rows(st), st.values, np.zeros(self.system.layout.n_rows))
            new_an, its = cold_start.predicted_set(self.system, self.linear_solver, rows, st.an, it)
            st.lin_total += its
            self.sets.take_active(st, it, new_an)
            if it.changed_sets == 0:
                # the prediction kept the first set: converged only if the plain rule
                # keeps it too (no node pulls, none penetrates)
                self.sets.update_active(st, it, damp_first=False)
        else:
            self.sets.update_active(st, it, damp_first=first)

    def _update_friction_bounds(self, st: PDASState, it: Iterate, k: int) -> None:
        """Step 6: Coulomb fixed point (Algorithm FP): bounds from the current normal
        multipliers, every ``fp_every`` iterations and whenever the sets have settled."""
        self.sets.update_bounds(st, it, k)

    def _update_slip_sets(self, st: PDASState, it: Iterate) -> None:
        """Step 7: stick/slip sets and slip directions, then the edge rule for bounds that
        do not follow the pressure (docs/theory/pdas.md#edge-of-the-contact-zone)."""
        self.sets.update_slip(st, it)
        self.sets.update_edges(st, it)

    def _check_convergence(self, st: PDASState, it: Iterate, k: int, its: int, extra: dict) -> bool:
        """Step 8: record the iteration; converged when no set, sign or direction changed
        and the friction bounds are settled."""
        return self.sets.record(st, it, k, its, extra)

    def _accept_sets(self, st: PDASState, it: Iterate, k: int) -> None:
        """Step 9: take the new sets; a repeated set with unchanged bounds is cycling."""
        if self.sets.accept(st, it):
            raise ContactConvergenceError(
                f"contact: the active set cycles (iteration {k + 1} repeats an earlier set)",
                st.history,
            )

    def _finish(self, st: PDASState, it: Iterate, u: fem.Function, t0: float) -> PDASResult:
        """Step 10: keep the sets for the next warm start, write ``U = Qᵀ Tᵀ Ũ`` into ``u``.

        With the low-rank strategy the multipliers are taken from the full field ``Ũ``:
        the small system gives ``w`` as a sum of column responses that cancel where a set
        differs much from the factorised one (round-off of 1e-9 of the load measured on a
        2D body held at three nodes); recomputed from the field, the contact resultant
        balances the load to the accuracy of the solve.
        """
        sy, lin = self.system, self.linear_solver
        n_fact, n_cols = lin.finish(len(st.history))
        if lin.field_multipliers:
            it = self.sets.iterate(st, sy.unknowns(), sy.contact_residual())
        an = st.an | st.edges.edge  # edge nodes touch (with zero pressure)
        self.warm = WarmStart(
            active=an,
            directions=st.dirs,
            lam_n_prev=np.where(an, it.lam_n, 0.0),
            cold=False,
            stick=(st.stick & st.an) | st.edges.edge,  # (edge nodes start sticking)
            lam_t=it.lam_t,
            xi=it.z,
        )
        sy.write_solution(u)
        return self._result(
            an,
            st.stick,
            it.lam_n,
            it.lam_t,
            it.un,
            it.dut,
            st.history,
            st.lin_total,
            n_fact,
            n_cols,
            st.n_bound,
            t0,
        )

    def _result(
        self, an, stick, lam_n, lam_t, un, dut, history, lin_total, n_fact, n_cols, n_bound, t0
    ):
        comm, fs = self.comm, self.force_scale
        fric = self.friction.active
        own = self.system.layout.own
        pressure_r = np.where(an, lam_n, 0.0) * fs
        trac_r = np.where(an[:, None] & fric[:, None], lam_t, 0.0) * fs
        status_r = np.where(~an, "open", np.where(fric & stick, "stick", "slip"))
        act, pres, gaps, slips, tracs, stats = (
            own(an),
            own(pressure_r),
            own(self.system.gap - un),
            own(dut),
            own(trac_r),
            own(status_r),
        )
        forces, tforces, n_active, n_stick, n_slip = [], [], [], [], []
        for k, itf in enumerate(self.interfaces):
            forces.append(_allsum(comm, float((itf.weight * pres[k]).sum())))
            ft = np.zeros(itf.gdim)
            for j in range(self.bs - 1):
                if itf.num_owned:
                    ft += ((itf.weight * tracs[k][:, j])[:, None] * itf.tangents[:, j, :]).sum(
                        axis=0
                    )
            ft = global_vsum(comm, ft)
            tforces.append(float(np.linalg.norm(ft)))
            n_active.append(_allsum(comm, int(act[k].sum())))
            n_stick.append(_allsum(comm, int((stats[k] == "stick").sum())))
            n_slip.append(_allsum(comm, int((stats[k] == "slip").sum())))
        return PDASResult(
            iterations=len(history),
            linear_iterations=lin_total,
            active=[a.copy() for a in act],
            pressure=pres,
            gap=gaps,
            slip=slips,
            normal_force=forces,
            n_active=n_active,
            history=history,
            wall_time=time.perf_counter() - t0,
            factorizations=n_fact,
            columns=n_cols,
            traction_t=tracs,
            status=stats,
            tangential_force=tforces,
            n_stick=n_stick,
            n_slip=n_slip,
            bound_updates=n_bound,
        )

    # ------------------------------------------------------------------ energy balance
    def contact_force(self, out: PETSc.Vec) -> None:
        """The contact forces of the last solve on the nodes of the original basis (N; N/m
        in 2D; collective; ``out``: a vector of the original space).

        The contact rows carry ``w = T F̂ − Ã Ũ`` (force ``−w``); a virtual displacement
        ``δU = Qᵀ Tᵀ δŨ`` gives the force ``−Q⁻¹ Tᵀ w`` in the original basis, and
        ``Q⁻¹ = 2I − Q`` (``Q − I`` maps slave rows to master nodes and to the slave nodes
        without a multiplier only, so its square vanishes).  Besides the slave and master
        nodes, a slave node without a multiplier (a Dirichlet node at the edge of the slave
        surface) receives its share ``(D_pq/D_pp) w_p`` of its neighbour's multiplier: there
        the residual of the assembled system is that share plus the support's reaction
        (docs/theory/mortar.md#boundary-modification-of-the-dual-basis).
        """
        self.system.contact_force(out)

    def contact_gaps(self, u: fem.Function) -> list[npt.NDArray[np.float64]]:
        """Nodal normal gaps g_p = d_p/D_pp − n_p·(U_p − Σ_q M̂_pq U_q) of every pair for the
        displacement ``u``, in the order of ``interface.blocks`` (owned slave nodes)."""
        if self._gap_vecs is None:
            self._gap_vecs = (self.system.Qt.createVecLeft(), self.system.T.createVecLeft())
        tmp, r = self._gap_vecs
        U = u.x.petsc_vec
        self.system.Qt.mult(U, tmp)
        tmp.aypx(-1.0, U)
        tmp.axpy(1.0, U)  # Û = (2I − Qᵀ) U  (Qᵀ − I is nilpotent)
        self.system.T.mult(tmp, r)  # rows bs·p: n_p·Û_p
        bs = self.bs
        return [itf.gap - r.array[bs * itf.blocks] for itf in self.interfaces]

    def _snap(self, gaps: list[npt.NDArray[np.float64]]) -> list[npt.NDArray[np.float64]]:
        """Gaps with |g| below 1e-12 of the slave surface size (geometric round-off of
        touching bodies) set to 0, so that closed contact does exactly no work."""
        out = []
        for itf, g in zip(self.interfaces, gaps):
            tol = 1e-12 * itf.slave_area ** (1.0 / max(itf.gdim - 1, 1))
            out.append(np.where(np.abs(g) <= tol, 0.0, g))
        return out

    def start_contact_work(self, u: fem.Function) -> None:
        """Take the gaps of ``u`` (the initial state) as those before the next step."""
        self._work_gaps = self._snap(self.contact_gaps(u))

    def contact_work(self, u: fem.Function) -> float:
        """This rank's part of the contact work of the step just solved (``u``: its solution).

        ``W_c = Σ_p D_pp λ_p (g_pⁿ⁺¹ − g_pⁿ)`` over the owned slave nodes, minus the friction
        work ``Σ_p D_pp λ_t,p · Δu_t,p`` (≤ 0).  The gaps after the step are those the PDAS
        returned (exactly 0 at active nodes, so persistent contact does exactly no work);
        before: those of the previous step (or of :meth:`start_contact_work`).
        """
        res = self.last_result
        gaps = self._snap(res.gap if res is not None else self.contact_gaps(u))
        work = 0.0
        for k, itf in enumerate(self.interfaces):
            p = res.pressure[k] if res is not None else np.zeros(itf.num_owned)
            work += float((itf.D * p * (gaps[k] - self._work_gaps[k])).sum())
            if res is not None and res.traction_t and itf.num_owned:
                # friction: the force −D λ_t on the slip Δu_t of the step (≤ 0)
                work -= float((itf.D[:, None] * res.traction_t[k] * res.slip[k]).sum())
        self._work_gaps = gaps
        return work

    def column_report(self) -> dict:
        """Counts and memory of the low-rank strategy since set-up (empty with another
        strategy): single-right-hand-side solves (base and final; final), column blocks,
        columns, the full columns the largest set used, their cap and peak memory on
        the largest rank (MB; docs/theory/pdas.md#full-columns-across-steps)."""
        lr = getattr(self.linear_solver, "lowrank", None)
        if lr is None:
            return {}
        return {
            "base_and_final_solves": lr.n_solves,
            "final_solves": lr.n_final,
            "column_blocks": lr.n_blocks,
            "columns": lr.columns,
            "full_columns_used": lr.full_used,
            "full_columns_cap": lr.full_cap,
            "full_columns_peak_mb": lr.full_bytes_peak / 1.0e6,
        }

    def release_work(self) -> None:
        """Free the iterative solver's preconditioner (its multigrid hierarchy; collective):
        the next solve builds it anew.  A direct solver keeps its factorisation."""
        ls = self.linear_solver
        if ls is None or getattr(ls, "kind", None) != "iterative":
            return
        ls.pc_reuse.forget()
        ls.ksp.reset()

    def destroy(self) -> None:
        """Free the PETSc objects."""
        if self.system is None:
            return
        self.linear_solver.destroy()
        self.system.destroy()
        for obj in self._gap_vecs or ():
            obj.destroy()
