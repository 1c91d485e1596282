"""The set update of the PDAS: active/inactive, stick/slip, slip directions, friction
bounds and the edge of the contact zone (docs/theory/pdas.md#active-set-rule,
docs/theory/pdas.md#tresca-and-coulomb-friction).

:class:`SetUpdate` turns the solution of one iteration into the sets of the next and
says which rows the next system prescribes (:meth:`SetUpdate.system_rows`).  It works
on the per-node arrays of this rank's owned slave nodes — each node is decided by its
rank, the counts and tolerances are scalar reductions
(docs/theory/pdas.md#distributed-set-logic) — and does no linear algebra.
:class:`PDASState` is what one contact solve carries from iteration to iteration,
:class:`Iterate` what one iteration computed, :class:`WarmStart` what is carried from
one step to the next.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from bonecontact.contact.condensed import CondensedSystem
from bonecontact.contact.friction import (
    EdgeSets,
    NodalFriction,
    aitken_directions,
    edge_groups,
    merge_groups,
    slip_directions,
    slip_newton_rows,
    slip_set,
    update_edge_sets,
    with_normal_row,
)
from bonecontact.contact.linear_strategy import SetRows
from bonecontact.contact.options import ActiveSetOptions, SlipOptions
from bonecontact.contact.reductions import (
    global_any,
    global_count,
    global_dot,
    global_max,
    set_signature,
)

__all__ = ["Iterate", "PDASState", "SetUpdate", "WarmStart"]


@dataclass
class WarmStart:
    """The sets carried from one contact solve to the next (owned nodes)."""

    active: npt.NDArray[np.bool_]  # active set A_n
    directions: npt.NDArray[np.float64]  # slip directions, (NS, gdim − 1)
    lam_n_prev: npt.NDArray[np.float64]  # normal multipliers of the last step
    cold: bool = True  # no step solved yet: the cold-start rules apply
    #: the friction state of the last step (docs/theory/pdas.md#warm-started-friction):
    #: its stick set, tangential traction λ_t and ξ = λ_t + c_t Δu_t (NS, gdim − 1);
    #: ``None``: every active friction node starts sticking
    stick: npt.NDArray[np.bool_] | None = None
    lam_t: npt.NDArray[np.float64] | None = None
    xi: npt.NDArray[np.float64] | None = None


@dataclass
class PDASState:
    """The state of one contact solve carried from one PDAS iteration to the next
    (per-node arrays of the owned nodes)."""

    an: npt.NDArray[np.bool_]  # active set A_n
    stick: npt.NDArray[np.bool_]  # stick set (active friction nodes without slip)
    dirs: npt.NDArray[np.float64]  # slip directions s_p, (NS, gdim − 1)
    g: npt.NDArray[np.float64]  # friction bounds ĝ_p (in operator units)
    xold: npt.NDArray[np.float64]  # unknowns at the start of the step
    values: npt.NDArray[np.float64]  # prescribed values of fixed rows (gap, old slip)
    x_prev: npt.NDArray[np.float64]  # unknowns of the previous iteration
    edges: EdgeSets  # edge of the contact zone (docs/theory/pdas.md)
    switches: npt.NDArray[np.int_]  # stick <-> slip switches in this solve
    margin: npt.NDArray[np.float64] | None = None  # rows' distance to switching
    lam_t_k: npt.NDArray[np.float64] | None = None  # 3D Newton: last traction
    z_k: npt.NDArray[np.float64] | None = None  # 3D Newton: last ξ = λ_t + c_t Δu_t
    aitken: list = field(
        default_factory=lambda: [None, 1.0]
    )  # 3D slip directions: residual, relaxation
    history: list[dict] = field(default_factory=list)
    #: the sets of earlier iterations (fingerprints) with, in 3D, the points their slip
    #: rows were linearised at (:meth:`SetUpdate.accept`)
    seen: dict = field(default_factory=dict)
    lin_total: int = 0
    n_bound: int = 0


@dataclass
class Iterate:
    """What one PDAS iteration computed from its linear solve (owned nodes)."""

    x: npt.NDArray[np.float64]
    lam_n: npt.NDArray[np.float64]
    lam_t: npt.NDArray[np.float64]
    un: npt.NDArray[np.float64]
    dut: npt.NDArray[np.float64]
    eps: float
    ind_n: npt.NDArray[np.float64]
    z: npt.NDArray[np.float64]
    zn: npt.NDArray[np.float64]
    new_an: npt.NDArray[np.bool_] | None = None
    new_stick: npt.NDArray[np.bool_] | None = None
    new_dirs: npt.NDArray[np.float64] | None = None
    changed_sets: int = 0
    changed_t: int = 0
    turned: int = 0
    bound_change: float = 0.0
    new_edges: EdgeSets | None = None


class SetUpdate:
    """The PDAS set rules on the condensed system ``system`` with the friction
    ``friction`` (docs/theory/pdas.md#active-set-rule).

    Parameters
    ----------
    system
        The condensed system (layout, ``D_pp``, gaps, row scales).
    friction
        The friction laws node by node.
    active_set, slip
        The option groups of the normal rule (``c_n``, ``c_t``, cold start) and of the
        friction iteration.
    """

    def __init__(
        self,
        system: CondensedSystem,
        friction: NodalFriction,
        active_set: ActiveSetOptions,
        slip: SlipOptions,
    ):
        self.system, self.friction = system, friction
        fs = system.force_scale
        c_n, c_t = active_set.c_n, active_set.c_t
        self.c_n = float(c_n) / fs if c_n is not None else system.stiffness_ratio
        self.c_t = float(c_t) / fs if c_t is not None else self.c_n
        self.cold_start_fraction = float(active_set.cold_start_fraction)
        #: the nodes of pairs that start open (crack faces): their first update is the
        #: plain rule, undamped (docs/theory/pdas.md#pairs-that-start-open)
        self.open_start = np.concatenate(
            [np.full(itf.num_owned, itf.start_open) for itf in system.interfaces]
            + [np.zeros(0, dtype=bool)]
        )
        self.fp_every, self.fp_tol = max(int(slip.fp_every), 1), float(slip.fp_tol)
        self.direction_tol = float(slip.direction_tol)
        self.bs = system.layout.bs
        self.comm = system.layout.comm
        self.newton_3d = self.bs == 3 and slip.slip_3d == "newton" and friction.any_active
        self.warm_slip = bool(slip.warm_slip)

    # ------------------------------------------------------------------ start and rows
    def start(self, warm: WarmStart, xold: npt.NDArray[np.float64]) -> PDASState:
        """The state at the start of a solve: the warm-started active set; friction nodes
        stick (the elastic trial state; the first solve shows where the bound is
        exceeded), except, with ``warm_slip``, those that slipped at the end of the last
        solve: they start slipping along their last direction, their 3D Newton rows
        linearised at the last traction and ξ (the slip of the last step as the
        predictor of this one's; docs/theory/pdas.md#warm-started-friction)."""
        ns = self.system.layout.n_nodes
        stick, lam_t_k, z_k = self._warm_slip(warm)
        return PDASState(
            an=warm.active.copy(),
            stick=stick,
            lam_t_k=lam_t_k,
            z_k=z_k,
            dirs=warm.directions.copy(),
            g=self.friction.step_bounds(warm.lam_n_prev),
            xold=xold,
            values=self.system.fixed_values(xold),
            x_prev=xold,
            edges=EdgeSets.empty(ns),
            switches=np.zeros(ns, dtype=int),
        )

    def _warm_slip(self, warm: WarmStart) -> tuple:
        """The stick set a solve starts from and the last traction and ξ of its slip
        nodes (:meth:`start`); a slip node with ``ξ = 0`` starts sticking (no direction
        to linearise at)."""
        stick = warm.active & self.friction.active
        if not self.warm_slip or warm.stick is None or not self.friction.any_active:
            return stick, None, None
        slip = stick & ~warm.stick & (np.linalg.norm(warm.xi, axis=1) > 0.0)
        return stick & ~slip, warm.lam_t.copy(), warm.xi.copy()

    def fixed_rows(self, st: PDASState) -> npt.NDArray[np.bool_]:
        """Rows prescribed by the sets of ``st``: active normal rows, stick rows."""
        return self.system.layout.fixed_rows(st.an, st.an & st.stick & self.friction.active)

    def system_rows(self, st: PDASState) -> SetRows:
        """The rows of the system of the current sets
        (docs/theory/pdas.md#linear-system-of-one-iteration).

        Active normal rows and stick rows are prescribed (``values``); 2D slip rows (and
        3D fixed-point slip rows) carry the prescribed force ``ĝ D s``; 3D Newton slip
        rows are replaced by their linearisation, edge nodes by their group.
        """
        sy, g = self.system, st.g
        R, D, bs = sy.layout.rows_of, sy.D, self.bs
        fixed = self.fixed_rows(st)
        slip = st.an & self.friction.active & ~st.stick
        wg = np.zeros(sy.layout.n_rows)
        coupled = None
        if self.newton_3d:
            # (a slip node with a zero bound is a free row with zero force: no Newton row)
            if (slip & (g > 0.0)).any():
                S = np.flatnonzero(slip & (g > 0.0))
                rows = np.stack([R[j][S] for j in range(1, bs)], axis=1)
                coupled = slip_newton_rows(
                    rows, D[S], self.c_t, st.lam_t_k[S], st.z_k[S], g[S], st.xold
                )
        else:
            for j in range(1, bs):
                wg[R[j][slip]] = (g * D * st.dirs[:, j - 1])[slip]
        coupled = self._with_edge_rows(st, fixed, coupled)
        return SetRows(fixed, st.values, wg, coupled, st.margin)

    def _with_edge_rows(self, st: PDASState, fixed: np.ndarray, coupled: tuple | None):
        """Edge nodes (docs/theory/pdas.md#edge-of-the-contact-zone): their normal and
        tangential rows become one coupled group (zero pressure, touching, traction along
        the slip direction); 3D Newton slip groups then take their normal row along
        (``u_n = g``) so that all groups have the same size.  ``fixed`` loses the normal
        rows moved into groups (in place)."""
        edge = st.edges.edge
        if not edge.any():
            return coupled
        sy = self.system
        R = sy.layout.rows_of
        nodes = np.flatnonzero(edge)
        groups = edge_groups(nodes, R, st.dirs, sy.gap, sy.scale[R[0]])
        fixed[R[0][nodes]] = False
        if coupled is not None:
            normal = R[0][np.searchsorted(R[1], coupled[0][:, 0])]
            coupled = with_normal_row(
                coupled, normal, sy.gap[np.searchsorted(R[0], normal)], sy.scale[normal]
            )
            fixed[normal] = False
        return merge_groups(coupled, groups)

    # ------------------------------------------------------------------ multipliers
    def iterate(
        self, st: PDASState, x: npt.NDArray[np.float64], w: npt.NDArray[np.float64]
    ) -> Iterate:
        """``λ = w / D``, the normal approach, the slip of the step, the normal indicator
        ``λ_n + c_n (u_n − g)`` and ``ξ = λ_t + c_t Δu_t`` of the solution ``x, w``."""
        sy, bs = self.system, self.bs
        R = sy.layout.rows_of
        Dsafe = np.where(sy.D > 0, sy.D, 1.0)
        lam_n = w[R[0]] / Dsafe
        lam_t = np.stack([w[R[j]] / Dsafe for j in range(1, bs)], axis=1)
        un = x[R[0]]
        dut = np.stack([x[R[j]] - st.xold[R[j]] for j in range(1, bs)], axis=1)
        lam_scale = global_max(self.comm, np.abs(lam_n), 0.0)
        eps = 1e-10 * max(lam_scale, 1e-300)
        z = lam_t + self.c_t * dut
        return Iterate(
            x=x,
            lam_n=lam_n,
            lam_t=lam_t,
            un=un,
            dut=dut,
            eps=eps,
            ind_n=lam_n + self.c_n * (un - sy.gap),
            z=z,
            zn=np.linalg.norm(z, axis=1),
        )

    # ------------------------------------------------------------------ the set rules
    def update_active(self, st: PDASState, it: Iterate, damp_first: bool) -> None:
        """``p ∈ A_n`` where ``λ_n + c_n (u_n − g) > 0``; ``damp_first`` (the first update
        of a cold start): of the newly penetrating nodes only those within
        ``cold_start_fraction`` of the deepest penetration (not on pairs that start open:
        their first set is empty, there is no overshoot to damp)."""
        an = st.an
        # an indicator within ±ε of zero keeps the node's state: an active node whose
        # multiplier is zero to round-off (λ ≈ −ε, a degenerate node at the edge of the
        # zone) stays active instead of toggling (docs/theory/pdas.md#active-set-rule)
        new_an = (it.ind_n > it.eps) | (an & (it.ind_n >= -it.eps))
        newly = new_an & ~an & ~self.open_start
        if damp_first and self.cold_start_fraction > 0 and global_any(self.comm, newly):
            pen = it.un - self.system.gap
            deepest = global_max(self.comm, pen[newly])
            new_an &= an | self.open_start | (pen > self.cold_start_fraction * deepest)
        self.take_active(st, it, new_an)

    def take_active(self, st: PDASState, it: Iterate, new_an: npt.NDArray[np.bool_]) -> None:
        """Take ``new_an`` as the new active set of ``it`` (e.g. a predicted one)."""
        it.new_an = new_an
        it.changed_sets = global_count(self.comm, new_an != st.an)

    def update_bounds(self, st: PDASState, it: Iterate, k: int) -> None:
        """Coulomb fixed point (Algorithm FP): bounds from the current normal multipliers,
        every ``fp_every`` iterations and whenever the sets have settled for the current
        bounds."""
        it.bound_change = 0.0
        fr = self.friction
        if not fr.any_fixed_point:
            return
        fric, g, new_an = fr.active, st.g, it.new_an
        gmax = global_max(self.comm, g, 0.0)
        trial_stick = new_an & fric & ~slip_set(new_an, fric, it.zn, g, it.eps, gmax)
        settle = it.changed_sets == 0 and not global_any(
            self.comm, (trial_stick != st.stick) & new_an & fric
        )
        if k % self.fp_every == 0 or settle:
            g_new, it.bound_change = fr.fixed_point_bounds(g, it.lam_n)
            if it.bound_change > 0.0:
                st.g = g_new
                st.n_bound += 1
                st.seen.clear()

    def update_slip(self, st: PDASState, it: Iterate) -> None:
        """Stick/slip sets and slip directions, and how many of them changed.

        2D: a slip node changes when its direction (sign) flips, unless its bound is
        zero (its direction is then round-off and does not enter the system).  3D Newton: directions
        settled and ``λ_t = ĝ s`` on the slip nodes (ĝ > 0).  3D fixed point: directions
        converge (linearly, Aitken-accelerated) to a fixed point.
        """
        fric, g, dirs = self.friction.active, st.g, st.dirs
        slip = st.an & fric & ~st.stick
        held = self._hold_reversed_releases(st, it, slip)
        new_an = it.new_an
        gmax = global_max(self.comm, g, 0.0)
        new_slip, new_dirs = slip_directions(
            slip_set(new_an, fric, it.zn, g, it.eps, gmax), slip, it.z, it.zn, g, dirs
        )
        new_slip &= ~held
        new_stick = new_an & fric & ~new_slip
        both = new_slip & slip
        if self.bs == 2:
            turned = 0
        elif self.newton_3d:
            turning, turned = self._newton_turns(st, it, both, new_dirs)
            if turning + turned:  # (a node held is not converged: counted)
                turned += self._hold_switches(st, new_an, new_stick, new_dirs)
        else:
            turned = global_count(
                self.comm,
                np.linalg.norm(new_dirs[both] - dirs[both], axis=1) > self.direction_tol,
            )
            stick_changes = global_count(self.comm, (new_stick != st.stick) & new_an & fric)
            changed = it.changed_sets + stick_changes != 0
            aitken_directions(both, dirs, new_dirs, changed, st.aitken, self.comm)
        changed_t = global_count(self.comm, (new_stick != st.stick) & new_an & fric)
        if self.bs == 2:
            # a flip where the bound is zero changes nothing (λ_t = ĝ s = 0) and the sign
            # of its ξ ≈ 0 is round-off: not a set change
            bound = both & (g > 0.0)
            flips = np.sign(new_dirs[bound, 0]) != np.sign(dirs[bound, 0])
            changed_t += global_count(self.comm, flips)
        st.switches += (new_stick != st.stick) & new_an & st.an & fric
        it.new_stick, it.new_dirs, it.changed_t, it.turned = new_stick, new_dirs, changed_t, turned

    def _newton_turns(
        self,
        st: PDASState,
        it: Iterate,
        both: npt.NDArray[np.bool_],
        new_dirs: npt.NDArray[np.float64],
    ) -> tuple[int, int]:
        """3D Newton slip rows: the slip nodes (ĝ > 0) whose direction still turns, and
        those whose traction is not yet ``ĝ s`` (``s = ξ/|ξ|`` of this iterate).

        Only the second count enters the convergence test: with the stick/slip sets
        unchanged, a traction ``λ_t = ĝ ξ/|ξ|`` at every slip node is the slip condition
        ``|ξ| λ_t − ĝ ξ = 0`` of this iterate to ``direction_tol`` (every other row of its
        system holds exactly); how far the direction moved from the linearisation point
        says how good that point was, not this iterate
        (docs/theory/pdas.md#warm-started-friction)."""
        g, dirs = st.g, st.dirs
        bg = both & (g > 0.0)
        turned = global_count(
            self.comm, np.linalg.norm(new_dirs[bg] - dirs[bg], axis=1) > self.direction_tol
        )
        gs = max(global_max(self.comm, g, 0.0), it.eps)
        off = (
            np.linalg.norm(it.lam_t[bg] - g[bg, None] * new_dirs[bg], axis=1)
            > self.direction_tol * gs
        )
        return turned, global_count(self.comm, off)

    def _hold_reversed_releases(
        self, st: PDASState, it: Iterate, slip: npt.NDArray[np.bool_]
    ) -> npt.NDArray[np.bool_]:
        """Slip nodes that the solve released (``λ_n < 0``) while they slipped against
        the direction of their traction (``Δu_t · s < 0``) stay active and stick
        (docs/theory/pdas.md#active-set-rule): their pressure was computed with a
        friction traction outside the law, so their normal indicator is not trusted.

        ``it.new_an`` and ``it.changed_sets`` are updated; returns the nodes held.
        """
        back = (it.dut * st.dirs).sum(axis=1)
        tol = 1e-12 * max(global_max(self.comm, np.abs(it.dut), 0.0), 1e-300)
        held = slip & ~it.new_an & (st.g > 0.0) & (back < -tol)
        if global_any(self.comm, held):
            it.new_an = it.new_an | held
            it.changed_sets = global_count(self.comm, it.new_an != st.an)
        return held

    def _hold_switches(
        self,
        st: PDASState,
        new_an: npt.NDArray[np.bool_],
        new_stick: npt.NDArray[np.bool_],
        new_dirs: npt.NDArray[np.float64],
    ) -> int:
        """3D Newton slip rows, while slip directions still turn: a node that already
        switched between stick and slip in this solve keeps its state (``new_stick``,
        ``new_dirs`` in place) until the directions have settled
        (docs/theory/pdas.md#active-set-rule).  Its indicator is taken on a linearisation
        point that is still moving; deciding on it toggles the node at the rim of the
        friction disc.  Once no direction turns, the plain rule decides again.  Returns
        the number of nodes held (all ranks)."""
        fric = self.friction.active
        hold = (new_stick != st.stick) & new_an & st.an & fric & (st.switches >= 1)
        new_stick[hold] = st.stick[hold]
        new_dirs[hold & st.stick] = st.dirs[hold & st.stick]
        return global_count(self.comm, hold)

    def update_edges(self, st: PDASState, it: Iterate) -> None:
        """The edge rule for friction nodes whose bound does not follow the current
        pressure (docs/theory/pdas.md#edge-of-the-contact-zone), and the set changes
        counted again when it moved a node."""
        rigid = self.friction.rigid
        if not self.friction.any_rigid:
            return
        new_an, new_stick = it.new_an.copy(), it.new_stick.copy()
        gs = max(global_max(self.comm, st.g, 0.0), it.eps)
        it.new_edges = update_edge_sets(
            st.an, it.new_an, st.stick, it.new_stick, it.new_dirs, st.dirs, st.edges, rigid,
            st.g, it.lam_t, it.z, it.zn, 1e-10 * gs, self.comm,
            turn_tol=self.direction_tol if self.bs == 3 else np.inf,
        )  # fmt: skip
        old, new = st.edges.edge, it.new_edges.edge
        moved = (new_an != it.new_an) | (new_stick != it.new_stick)
        if not global_any(self.comm, moved | old | new):
            return
        fric, comm = self.friction.active, self.comm
        it.changed_sets = global_count(comm, it.new_an != st.an) + global_count(comm, new != old)
        changed_t = global_count(comm, (it.new_stick != st.stick) & it.new_an & fric)
        both_e = new & old
        if self.bs == 2:
            slip = st.an & fric & ~st.stick
            both = it.new_an & fric & ~it.new_stick & slip
            flips = np.sign(it.new_dirs[:, 0]) != np.sign(st.dirs[:, 0])
            changed_t += global_count(comm, flips & (both | both_e))
        else:
            turn = np.linalg.norm(it.new_dirs[both_e] - st.dirs[both_e], axis=1)
            it.turned += global_count(comm, turn > self.direction_tol)
        it.changed_t = changed_t

    # ------------------------------------------------------------------ convergence
    def record(self, st: PDASState, it: Iterate, k: int, its: int, extra: dict) -> bool:
        """Record iteration ``k`` in the history; converged when no set, sign or
        direction changed and the friction bounds are settled."""
        changed = it.changed_sets + it.changed_t + it.turned
        comm, dx = self.comm, it.x - st.x_prev
        nrm = float(np.sqrt(global_dot(comm, it.x, it.x)))
        update = float(np.sqrt(global_dot(comm, dx, dx))) / nrm if nrm > 0 else 0.0
        st.x_prev = it.x
        an, fric = st.an, self.friction.active
        st.history.append(
            {
                "iteration": k,
                "active": global_count(comm, an),
                "stick": global_count(comm, an & st.stick & fric),
                "slip": global_count(comm, an & fric & ~st.stick),
                "changed": changed,
                "update": update,
                "bound_change": it.bound_change,
                "edge": global_count(comm, st.edges.edge),
                "linear_iterations": its,
                **extra,
            }
        )
        return changed == 0 and it.bound_change <= self.fp_tol

    def accept(self, st: PDASState, it: Iterate) -> bool:
        """Take the new sets, with the margins of every row to switching (for the
        speculative low-rank columns; an open friction node's tangential rows take the
        margin of its normal row: they are needed once it closes).  Returns ``True``
        when the sets repeat an earlier iteration's with unchanged bounds (cycling); the
        signs of the slip directions count in 3D too (a node stuck by the reversal rule
        that slips again the other way repeats no set), and in 3D the point the slip rows
        are linearised at must repeat as well (:meth:`_linearisation`): the same sets
        with other slip directions are another system
        (docs/theory/pdas.md#convergence-and-failure)."""
        bs, fric = self.bs, self.friction.active
        R = self.system.layout.rows_of
        margin = np.full(self.system.layout.n_rows, np.inf)
        margin[R[0]] = np.abs(it.ind_n - it.eps)
        shut = ~it.new_an & fric  # (an open node's rows are needed when it closes)
        for j in range(1, bs):
            margin[R[j][it.new_an & fric]] = np.abs(it.zn - st.g)[it.new_an & fric]
            margin[R[j][shut]] = margin[R[0][shut]]
        st.margin = margin
        st.an, st.stick, st.dirs = it.new_an, it.new_stick, it.new_dirs
        st.lam_t_k, st.z_k = it.lam_t, it.z
        if it.new_edges is not None:
            st.edges = it.new_edges
        if it.changed_sets + it.changed_t == 0:
            return False  # only 3D slip directions still turning: not a cycle
        sig = (st.an.tobytes(), st.stick.tobytes(), np.sign(st.dirs).tobytes())
        sig = set_signature(self.comm, sig + (st.edges.signature(),))
        point = self._linearisation(st)
        earlier = st.seen.setdefault(sig, [])
        if any(self._same_point(point, old) for old in earlier):
            return True
        earlier.append(point)
        return False

    def _linearisation(self, st: PDASState) -> npt.NDArray[np.float64] | None:
        """What, besides the sets, the next system depends on (``None``: nothing, as in
        2D): in 3D the slip rows' point, per slip node with a bound and per edge node —
        with Newton rows ``λ^k/ĝ`` and ``ξ^k/max(|ξ^k|, ĝ)`` (scale-free), with the
        direction fixed point the direction ``s``."""
        if self.bs != 3 or not self.friction.any_active:
            return None
        on = (st.an & self.friction.active & ~st.stick & (st.g > 0.0)) | st.edges.edge
        if not self.newton_3d:
            return st.dirs[on].copy()
        g = st.g[on, None]
        zn = np.linalg.norm(st.z_k[on], axis=1)[:, None]
        scale = np.maximum(np.maximum(zn, g), 1e-300)
        return np.hstack([st.lam_t_k[on] / np.maximum(g, 1e-300), st.z_k[on] / scale])

    def _same_point(
        self, a: npt.NDArray[np.float64] | None, b: npt.NDArray[np.float64] | None
    ) -> bool:
        """Whether two linearisation points (:meth:`_linearisation`, of the same sets)
        agree to ``direction_tol`` on every rank (collective)."""
        if a is None or b is None:
            return True
        return global_max(self.comm, np.abs(a - b), 0.0) <= self.direction_tol
