"""Friction laws of the PDAS contact solver: bounds, slip sets and 3D slip linearisation.

Everything here works on the per-node arrays of
:class:`bonecontact.contact.pdas.ContactSolver` (one entry per slave node owned by this
rank); what needs the other ranks is a scalar reduction
(:mod:`bonecontact.contact.reductions`):

* :class:`FrictionLaw`, the friction of one contact pair;
* the friction bounds ``ĝ_p``: Tresca, the given bound; Coulomb, ``μ λ_n,p`` of the
  previous step (:func:`step_bounds`) or of the current iterate (Algorithm FP,
  :func:`coulomb_fixed_point_bounds`);
* the slip set ``|λ_t + c_t Δu_t| > ĝ_p`` (:func:`slip_set`), the slip directions and
  the stick rule for a reversed slip (:func:`slip_directions`);
* 3D slip nodes: the damped semi-smooth Newton rows of ``|ξ| λ_t − ĝ ξ = 0``
  (:func:`slip_newton_rows`) and the Aitken-accelerated fixed point of the slip
  directions (:func:`aitken_directions`);
* the edge of the contact zone for bounds that do not vanish with the pressure
  (:func:`update_edge_sets`, :func:`edge_groups`): touching nodes with zero pressure and
  a friction traction between 0 and the bound.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from bonecontact.contact.reductions import global_any, global_dot

__all__ = [
    "EDGE_AFTER_RELEASES",
    "FRICTION_KIND",
    "EdgeSets",
    "FrictionLaw",
    "NodalFriction",
    "aitken_directions",
    "coulomb_fixed_point_bounds",
    "edge_groups",
    "merge_groups",
    "slip_directions",
    "slip_newton_rows",
    "slip_set",
    "step_bounds",
    "update_edge_sets",
    "with_normal_row",
]

#: Integer codes of the friction kinds in the per-node arrays.
FRICTION_KIND = {"none": 0, "tresca": 1, "coulomb": 2}


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
            raise ValueError(
                f"friction kind must be 'none', 'tresca' or 'coulomb', got {self.kind!r}"
            )
        if self.update not in ("previous_step", "fixed_point"):
            raise ValueError(
                f"coulomb update must be 'previous_step' or 'fixed_point', got {self.update!r}"
            )
        if self.coefficient < 0 or self.bound < 0:
            raise ValueError("friction coefficient and bound must be >= 0")


@dataclass(frozen=True)
class NodalFriction:
    """The friction laws of all contact pairs, node by node (this rank's owned nodes).

    Built once per operator (:meth:`of_pairs`); gives the friction bounds of a step and
    of the Coulomb fixed point.  Bounds are in operator units (Pa divided by the
    operator's force scale).  ``any_active``, ``any_fixed_point`` and ``any_rigid`` say
    whether some node of some rank has friction, the FP update, a rigid bound.
    """

    kind: npt.NDArray[np.int_]  # FRICTION_KIND code per node
    mu: npt.NDArray[np.float64]  # Coulomb coefficient
    bound: npt.NDArray[np.float64]  # Tresca bound (operator units)
    fixed_point: npt.NDArray[np.bool_]  # Coulomb with the Algorithm FP update
    comm: MPI.Comm | None = None
    any_active: bool = False
    any_fixed_point: bool = False
    any_rigid: bool = False

    @classmethod
    def of_pairs(
        cls,
        laws: list[FrictionLaw],
        sizes: list[int],
        comm: MPI.Comm | None,
        force_scale: float,
    ) -> NodalFriction:
        """Per-node arrays of the laws of the pairs, ``sizes[k]`` owned nodes of pair
        ``k`` on this rank (collective over ``comm``)."""

        def per(f: Callable[[FrictionLaw], float]) -> npt.NDArray[np.float64]:
            parts = [np.full(n, f(fl), dtype=float) for n, fl in zip(sizes, laws)]
            return np.concatenate(parts + [np.zeros(0)])

        kind = per(lambda fl: FRICTION_KIND[fl.kind]).astype(int)
        fixed_point = (kind == 2) & (per(lambda fl: fl.update == "fixed_point") > 0)
        return cls(
            kind=kind,
            mu=per(lambda fl: fl.coefficient),
            bound=per(lambda fl: fl.bound) / force_scale,
            fixed_point=fixed_point,
            comm=comm,
            any_active=global_any(comm, kind > 0),
            any_fixed_point=global_any(comm, fixed_point),
            any_rigid=global_any(comm, (kind > 0) & ~fixed_point),
        )

    @property
    def active(self) -> npt.NDArray[np.bool_]:
        """Nodes with friction."""
        return self.kind > 0

    @property
    def rigid(self) -> npt.NDArray[np.bool_]:
        """Friction nodes whose bound does not follow the current pressure (Tresca,
        semi-implicit Coulomb): the nodes of the edge rule."""
        return self.active & ~self.fixed_point

    def step_bounds(self, lam_n_prev: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Bounds at the start of a step (:func:`step_bounds`)."""
        return step_bounds(self.kind, self.bound, self.mu, lam_n_prev)

    def fixed_point_bounds(
        self, g: npt.NDArray[np.float64], lam_n: npt.NDArray[np.float64]
    ) -> tuple[npt.NDArray[np.float64], float]:
        """Algorithm FP bounds of the current iterate (:func:`coulomb_fixed_point_bounds`)."""
        return coulomb_fixed_point_bounds(g, self.fixed_point, self.mu, lam_n, self.comm)


def step_bounds(
    kind: npt.NDArray[np.int_],
    bound: npt.NDArray[np.float64],
    mu: npt.NDArray[np.float64],
    lam_n_prev: npt.NDArray[np.float64],
) -> npt.NDArray[np.float64]:
    """Friction bounds at the start of a step: the Tresca bound, or Coulomb ``μ max(0, λ_n)``
    with the normal multipliers of the previous step (semi-implicit)."""
    return np.where(kind == FRICTION_KIND["tresca"], bound, mu * np.maximum(lam_n_prev, 0.0))


def coulomb_fixed_point_bounds(
    g: npt.NDArray[np.float64],
    fp: npt.NDArray[np.bool_],
    mu: npt.NDArray[np.float64],
    lam_n: npt.NDArray[np.float64],
    comm: MPI.Comm | None = None,
) -> tuple[npt.NDArray[np.float64], float]:
    """Algorithm FP: the bounds ``μ max(0, λ_n)`` of the current iterate at the nodes ``fp``.

    Returns the new bounds and their relative change over the nodes of all ranks of
    ``comm`` (0 when they are all zero).
    """
    g_new = g.copy()
    g_new[fp] = mu[fp] * np.maximum(lam_n[fp], 0.0)
    diff = g_new[fp] - g[fp]
    den = float(np.sqrt(global_dot(comm, g_new[fp], g_new[fp])))
    change = float(np.sqrt(global_dot(comm, diff, diff))) / den if den > 0 else 0.0
    return g_new, change


def slip_set(
    an: npt.NDArray[np.bool_],
    fric: npt.NDArray[np.bool_],
    zn: npt.NDArray[np.float64],
    g: npt.NDArray[np.float64],
    eps: float,
    gmax: float | None = None,
) -> npt.NDArray[np.bool_]:
    """Active friction nodes with ``|λ_t + c_t Δu_t|`` (``zn``) above the bound
    (docs/theory/pdas.md#active-set-rule).

    A node with a zero bound (Coulomb with no pressure yet) slips: it carries no
    tangential traction (a "stick" decided on round-off of ξ ≈ 0 could only toggle).
    ``gmax`` is the largest bound of all ranks (default: of ``g``).
    """
    if gmax is None:
        gmax = float(g.max()) if g.size else 0.0
    gtol = 1e-10 * max(gmax, eps)
    return an & fric & ((zn > g + gtol) | (g <= 0.0))


def slip_directions(
    new_slip: npt.NDArray[np.bool_],
    slip: npt.NDArray[np.bool_],
    z: npt.NDArray[np.float64],
    zn: npt.NDArray[np.float64],
    g: npt.NDArray[np.float64],
    dirs: npt.NDArray[np.float64],
) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.float64]]:
    """Slip directions ``ξ/|ξ|`` of the new slip nodes, and the slip set without reversals.

    A node whose slip reverses under the prescribed traction overshot: it sticks next
    (without this, large ``c_t`` makes whole slip zones flip back and forth).

    Returns
    -------
    (new_slip, new_dirs)
    """
    new_dirs = dirs.copy()
    nz = new_slip & (zn > 0)
    new_dirs[nz] = z[nz] / zn[nz, None]
    reverse = new_slip & slip & (g > 0.0) & ((new_dirs * dirs).sum(axis=1) < 0.0)
    return new_slip & ~reverse, new_dirs


def slip_newton_rows(
    rows: npt.NDArray[np.int64],
    D: npt.NDArray[np.float64],
    c_t: float,
    lam_t: npt.NDArray[np.float64],
    z: npt.NDArray[np.float64],
    g: npt.NDArray[np.float64],
    xold: npt.NDArray[np.float64],
) -> tuple:
    """The damped semi-smooth Newton rows of 3D slip nodes (Hüeber–Stadler–Wohlmuth).

    At a slip node, ``C_t = |ξ| λ_t − ĝ ξ = 0`` with ``ξ = λ_t + c_t Δu_t``.  Linearised at
    the last iterate ``(λ^k, ξ^k)``, ``n = ξ^k/|ξ^k|``:

    ``|ξ^k| λ_t − ĝ ξ + θ λ̃ nᵀ (ξ − ξ^k) = 0``,

    with ``λ̃ = ĝ λ^k / max(ĝ, |λ^k|)`` (the traction projected on the friction disc) and
    ``θ = β = 1/(1 − αδ)`` where ``λ^k`` points away from ``ξ^k``
    (``α = λ^kᵀn/|λ^k| < 0``, ``δ = min(|λ^k|/ĝ, 1)``), else θ = 1: the damping of
    Hüeber–Stadler–Wohlmuth (docs/theory/pdas.md#slip-rows-in-three-dimensions).  θ = 1 with ``|λ^k|
    ≤ ĝ`` is the exact
    Newton step; every θ keeps the solution (at ``ξ = ξ^k`` the row reads
    ``λ_t = ĝ n``).  With ``λ_t = w_t / D``, ``Δu_t = x_t − x_t^{old}`` the rows read
    ``G w_t + H x_t = h``.

    Parameters
    ----------
    rows
        ``(n, gdim − 1)`` tangential rows (this rank's numbering) of the slip nodes.
    D, lam_t, z, g
        ``D_pp``, the traction ``λ^k``, ``ξ^k`` and the bound ``ĝ`` of the slip nodes.
    c_t
        Tangential complementarity parameter.
    xold
        This rank's unknowns of the contact rows at the start of the step.

    Returns
    -------
    (rows, G, D·H, D·h)
    """
    zk, lk, gk = z, lam_t, g
    zn = np.linalg.norm(zk, axis=1)
    n = zk / zn[:, None]
    lt = lk * (gk / np.maximum(np.maximum(gk, np.linalg.norm(lk, axis=1)), 1e-300))[:, None]
    # HSW damping (docs/theory/pdas.md#slip-rows-in-three-dimensions): where λ^k points away from
    # ξ^k (α < 0) the term is
    # scaled by β = 1/(1 − αδ) ∈ [1/2, 1), δ = min(|λ^k|/ĝ, 1)
    lnorm = np.linalg.norm(lk, axis=1)
    alpha = (lk * n).sum(axis=1) / np.maximum(lnorm, 1e-300)
    delta = np.minimum(lnorm / np.maximum(gk, 1e-300), 1.0)
    theta = 1.0 / (1.0 - np.minimum(alpha, 0.0) * delta)
    eye = np.eye(rows.shape[1])[None, :, :]
    outer = (theta[:, None] * lt)[:, :, None] * n[:, None, :]  # θ λ̃ nᵀ
    Gm = (1.0 - gk / zn)[:, None, None] * eye + outer / zn[:, None, None]
    Hp = c_t * (outer - gk[:, None, None] * eye) / zn[:, None, None]
    xo = xold[rows]
    h = D[:, None] * (theta[:, None] * lt + np.einsum("iab,ib->ia", Hp, xo))
    return rows, Gm, D[:, None, None] * Hp, h


def aitken_directions(
    both: npt.NDArray[np.bool_],
    dirs: npt.NDArray[np.float64],
    new_dirs: npt.NDArray[np.float64],
    sets_changed: bool,
    aitken: list,
    comm: MPI.Comm | None = None,
) -> None:
    """Aitken-accelerated fixed point of the 3D slip directions (in place).

    ``aitken`` is ``[previous residual, relaxation]``, carried between iterations; the
    relaxation is reset to 1 whenever the sets changed.  ``new_dirs`` of the nodes
    ``both`` (slipping before and after) is replaced by the relaxed, normalised update.
    """
    res_d = np.where(both[:, None], new_dirs - dirs, 0.0).ravel()
    if not sets_changed and aitken[0] is not None and aitken[0].shape == res_d.shape:
        dr = res_d - aitken[0]
        den = global_dot(comm, dr, dr)
        if den > 0:
            step = -aitken[1] * global_dot(comm, aitken[0], dr) / den
            aitken[1] = float(np.clip(step, 0.2, 20.0))
    else:
        aitken[1] = 1.0
    aitken[0] = res_d
    if aitken[1] != 1.0:
        upd = dirs[both] + aitken[1] * (new_dirs[both] - dirs[both])
        nrm_d = np.linalg.norm(upd, axis=1)
        ok = nrm_d > 1e-12
        idx = np.flatnonzero(both)[ok]
        new_dirs[idx] = upd[ok] / nrm_d[ok, None]


# ----------------------------------------------------------------------- the edge rule
@dataclass
class EdgeSets:
    """Edge nodes of one contact solve (docs/theory/pdas.md#edge-of-the-contact-zone).

    ``edge`` marks the nodes held at the edge state (touching, zero pressure, friction
    traction ``β s_p`` with ``0 ≤ β ≤ ĝ_p``); ``releases`` counts, per node, how often
    the node left the active set with a non-zero, pressure-independent bound during
    this solve.
    """

    edge: npt.NDArray[np.bool_]
    releases: npt.NDArray[np.int_]

    @classmethod
    def empty(cls, n: int) -> EdgeSets:
        """No edge node, no release (the start of a solve)."""
        return cls(np.zeros(n, dtype=bool), np.zeros(n, dtype=int))

    def signature(self) -> bytes:
        """What the cycling test must tell apart: the edge set and the releases up to
        :data:`EDGE_AFTER_RELEASES` (a set repeated with a node one release closer to the
        edge state is not a cycle)."""
        capped = np.minimum(self.releases, EDGE_AFTER_RELEASES).astype(np.int8)
        return self.edge.tobytes() + capped.tobytes()


#: An inactive node with a pressure-independent bound is taken to the edge state when it
#: penetrates again after this many releases from the active set within one solve.
EDGE_AFTER_RELEASES = 2


def edge_groups(
    nodes: npt.NDArray[np.int64],
    rows: list[npt.NDArray[np.int64]],
    dirs: npt.NDArray[np.float64],
    gap: npt.NDArray[np.float64],
    stiffness: npt.NDArray[np.float64],
) -> tuple:
    """The replaced rows of edge nodes: ``w_n = 0``, ``u_n = g`` and, in 3D, the friction
    traction along the slip direction (``s⊥ · w_t = 0``).

    The normal and tangential rows of an edge node form one group of the linear
    solvers' coupled rows ``G w + H x = h`` (``w`` the residual, ``x`` the unknowns of
    the group's rows): the normal residual vanishes (zero pressure), the normal
    approach equals the gap (touching), and the tangential residual — the friction
    force, an unknown — is free in 2D and along ``s_p`` in 3D.

    Parameters
    ----------
    nodes
        The edge nodes (this rank's numbering).
    rows
        Per component ``j``, the replicated row of component ``j`` of every node.
    dirs
        Slip directions ``s_p`` of all nodes, ``(n, gdim − 1)``.
    gap
        Nodal gaps of all nodes.
    stiffness
        A row scale per node (the normal-row stiffness), so that ``u_n = g`` is weighed
        like the other rows.

    Returns
    -------
    (rows, G, H, h)
        ``rows`` is ``(m, gdim)``; ``G, H`` are ``(m, gdim, gdim)``; ``h`` is ``(m, gdim)``.
    """
    bs = len(rows)
    m = nodes.size
    grp = np.stack([rows[j][nodes] for j in range(bs)], axis=1).astype(np.int64)
    G = np.zeros((m, bs, bs))
    H = np.zeros((m, bs, bs))
    h = np.zeros((m, bs))
    k = stiffness[nodes]
    G[:, 0, 0] = 1.0  # w_n = 0
    H[:, 1, 0] = k  # k u_n = k g
    h[:, 1] = k * gap[nodes]
    if bs == 3:  # the traction along s: (−s₂, s₁) · w_t = 0
        G[:, 2, 1] = -dirs[nodes, 1]
        G[:, 2, 2] = dirs[nodes, 0]
    return grp, G, H, h


def with_normal_row(
    coupled: tuple,
    normal_rows: npt.NDArray[np.int64],
    gap: npt.NDArray[np.float64],
    stiffness: npt.NDArray[np.float64],
) -> tuple:
    """Groups of tangential coupled rows (3D Newton slip rows) extended by the node's
    normal row with the equation ``u_n = g``, so that they can be solved together with
    the (normal + tangential) groups of edge nodes.

    ``normal_rows``, ``gap`` and ``stiffness`` are per group.
    """
    rows, G, H, h = coupled
    m, r = rows.shape
    rows3 = np.concatenate([normal_rows[:, None].astype(np.int64), rows], axis=1)
    G3 = np.zeros((m, r + 1, r + 1))
    H3 = np.zeros((m, r + 1, r + 1))
    G3[:, 1:, 1:] = G
    H3[:, 1:, 1:] = H
    H3[:, 0, 0] = stiffness
    h3 = np.concatenate([(stiffness * gap)[:, None], h], axis=1)
    return rows3, G3, H3, h3


def merge_groups(a: tuple | None, b: tuple | None) -> tuple | None:
    """Concatenate two sets of coupled row groups of the same group size."""
    if a is None:
        return b
    if b is None:
        return a
    return tuple(np.concatenate([x, y], axis=0) for x, y in zip(a, b))


def update_edge_sets(
    an: npt.NDArray[np.bool_],
    new_an: npt.NDArray[np.bool_],
    stick: npt.NDArray[np.bool_],
    new_stick: npt.NDArray[np.bool_],
    new_dirs: npt.NDArray[np.float64],
    dirs: npt.NDArray[np.float64],
    sets: EdgeSets,
    rigid: npt.NDArray[np.bool_],
    g: npt.NDArray[np.float64],
    lam_t: npt.NDArray[np.float64],
    z: npt.NDArray[np.float64],
    zn: npt.NDArray[np.float64],
    tol: float,
    comm: MPI.Comm | None = None,
    turn_tol: float = np.inf,
) -> EdgeSets:
    """The edge rule (docs/theory/pdas.md#edge-of-the-contact-zone): new normal, stick and
    edge sets (``new_an``, ``new_stick``, ``new_dirs`` updated in place).

    * releases: a node of ``rigid`` (friction bound > 0 that does not follow the current
      pressure: Tresca, semi-implicit Coulomb) in ``an`` but not in ``new_an``;
    * entry: such a node, released at least :data:`EDGE_AFTER_RELEASES` times, that
      penetrates again (in ``new_an``, not in ``an``) becomes an edge node, slipping
      along ``ξ/|ξ|``;
    * an edge node whose friction traction ``β = λ_t · s`` exceeds the bound
      (``β > ĝ``) returns to the active set (slip), unless its direction ``ξ/|ξ|`` turned
      by more than ``turn_tol`` (3D): then ``β`` was taken along a direction it does not
      slip in, and it stays with the new direction; one that slipped against ``s``
      (``(ξ − λ_t) · s = c_t Δu_t · s < 0``) returns to the active set and sticks; with
      ``β < 0`` it opens; otherwise it stays and its direction follows ``ξ``.  When an
      edge node leaves, the other nodes keep their sets for one iteration: the traction
      of that solve is outside the friction law, and the sets it suggests elsewhere are
      not to be trusted.  When a node enters the edge state, the other nodes keep their
      sets for one iteration too (their indicators were computed with it open).
    """
    edge, releases = sets.edge, sets.releases.copy()
    releases += (an & ~new_an & rigid & (g > 0.0) & ~edge).astype(int)
    enter = new_an & ~an & ~edge & rigid & (g > 0.0) & (releases >= EDGE_AFTER_RELEASES)
    turn = (edge | enter) & (zn > 0.0)
    new_dirs[turn] = z[turn] / zn[turn, None]
    beta = (lam_t * new_dirs).sum(axis=1)
    # (3D: a β measured along a direction the node no longer slips in decides nothing)
    turned = np.linalg.norm(new_dirs - dirs, axis=1) > turn_tol
    up = edge & (beta > g + tol) & ~turned
    # slipped against the direction of its traction (c_t Δu_t · s < 0): sticks
    back = edge & ~up & (((z - lam_t) * dirs).sum(axis=1) < -tol)
    down = edge & ~back & (beta < -tol)
    stay = edge & ~up & ~down & ~back
    if global_any(comm, up | down | back):
        # the solve gave an edge node a traction outside [0, ĝ]: only the edge nodes
        # change in this iteration (the other nodes' indicators were computed with it)
        others = ~edge
        new_an[others], new_stick[others] = an[others], stick[others]
        new_dirs[others] = dirs[others]
        releases = sets.releases.copy()
        enter[:] = False
    elif global_any(comm, enter):
        # a node enters the edge state: the others keep their sets for this iteration
        # (their indicators were computed with the entering node open)
        others = ~(edge | enter)
        new_an[others], new_stick[others] = an[others], stick[others]
        new_dirs[others] = dirs[others]
        releases = sets.releases.copy()
    new_edge = enter | stay
    new_an[new_edge | down] = False
    new_an[up | back] = True
    new_stick[new_edge | up] = False
    new_stick[back] = True
    return EdgeSets(new_edge, releases)
