"""The first active set of a cold-started 3D contact solve, from the compliance of the
support patch (docs/theory/pdas.md#cold-start).

A cold start solves first with only the support patch ``S`` of the closest nodes held
(:func:`support_patch`).  Held at a few nodes, a body pushed by a load sinks far into
the obstacle (the patch acts as a small flat punch), and activating every penetrating
node makes the PDAS start from a set several times too large.

Here the first solve is read as a measurement instead: the patch force ``P₁``, the
approach ``δ₁`` and, with one more solve, the patch stiffness ``K`` give the contact
modulus ``2E* ≈ P₁/(δ₁ρ_S)`` (a flat punch of radius ``ρ_S``) and the stiffness of the
structure behind the contact ``K_b = 1/(1/K − δ₁/P₁)``.  For a locally paraboloidal
contact of radius ``a`` with the structure in series, the zone ends at the gap ``t``
with::

    (4/3) · P₁/(δ₁ ρ_S) · a(t) · t = P₁ + K_b (δ₁ − 2t),

``a(t) = √(area{g ≤ t}/π)`` (areas ``D_pp``); the left side grows with ``t``, the right
side falls, the root is unique.  The first set is ``{g ≤ t}`` with the patch; only the
path of the PDAS changes.  Derivation: docs/theory/pdas.md#cold-start.  Every function
works on the owned slave nodes of each rank with scalar reductions; the support patch
takes the closest nodes of neighbouring ranks (docs/theory/pdas.md#distributed-set-logic).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from bonecontact.contact.condensed import CondensedSystem, RowLayout
from bonecontact.contact.interface import ContactInterface
from bonecontact.contact.linear_strategy import LinearStrategy, SetRows
from bonecontact.contact.reductions import (
    global_any,
    global_count,
    global_first,
    global_kth,
    global_max,
    global_min,
    global_sum,
    global_vsum,
    neighbour_points,
)

if TYPE_CHECKING:
    from bonecontact.contact.set_update import Iterate

__all__ = [
    "SUPPORT_RADIUS",
    "edge_gap",
    "first_set",
    "initial_set",
    "patch_response",
    "predicted_set",
    "punch_approach",
    "structure_stiffness",
    "support_patch",
]

#: Radius of the cold-start support patch in local slave mesh sizes (``D_pp`` in 2D,
#: ``√D_pp`` in 3D): the closest nodes' immediate neighbours on every side.
SUPPORT_RADIUS = 1.6


def structure_stiffness(P1: float, delta1: float, K: float) -> float:
    """Stiffness ``K_b`` of the structure behind the contact (force per approach).

    ``1/K = 1/K_b + δ₁/P₁``: the measured patch stiffness ``K`` is the structure in
    series with the patch's contact compliance ``δ₁/P₁``.  Returns ``inf`` when the
    contact compliance alone explains ``K`` (a rigidly driven body) and 0 for ``K ≤ 0``
    (a body held only by the contact).
    """
    if K <= 0.0 or not np.isfinite(K):
        return 0.0 if K <= 0.0 else float("inf")
    rest = 1.0 / K - delta1 / P1
    return float("inf") if rest <= 0.0 else 1.0 / rest


def edge_gap(
    gap: npt.NDArray[np.float64],
    area: npt.NDArray[np.float64],
    P1: float,
    delta1: float,
    rho: float,
    Kb: float,
    comm: MPI.Comm | None = None,
) -> float:
    """The gap ``t`` at which the predicted contact zone ends (module docstring).

    Parameters
    ----------
    gap
        Gaps of the pair's slave nodes relative to the smallest (≥ 0).
    area
        Their areas ``D_pp``.
    P1, delta1, rho
        Patch force, approach and radius of the first solve (all > 0).
    Kb
        Stiffness of the structure behind the contact (0 … ∞).
    comm
        With more than one rank: ``gap`` and ``area`` are this rank's nodes, the search
        runs over the nodes of all ranks (collective).

    Returns
    -------
    float
        The smallest gap at which the left side of the balance reaches the right side
        (``δ₁/2`` for a rigidly driven body).
    """
    if not np.isfinite(Kb):
        return 0.5 * delta1
    if comm is not None and comm.size > 1:
        return _edge_gap_distributed(comm, gap, area, P1, delta1, rho, Kb)
    order = np.argsort(gap, kind="stable")
    g = gap[order]
    a = np.sqrt(np.cumsum(np.abs(area[order])) / np.pi)
    lhs = (4.0 / 3.0) * P1 / (delta1 * rho) * a * g
    rhs = P1 + Kb * (delta1 - 2.0 * g)
    hit = np.flatnonzero(lhs >= rhs)
    return float(g[hit[0]]) if hit.size else float(g[-1])


def _edge_gap_distributed(
    comm: MPI.Comm,
    gap: npt.NDArray[np.float64],
    area: npt.NDArray[np.float64],
    P1: float,
    delta1: float,
    rho: float,
    Kb: float,
) -> float:
    """:func:`edge_gap` over the nodes of all ranks: the smallest gap at which the balance
    holds, found by bisection over the gaps (scalar reductions only)."""

    def holds(t: float) -> bool:
        a = np.sqrt(global_sum(comm, float(np.abs(area[gap <= t]).sum())) / np.pi)
        return (4.0 / 3.0) * P1 / (delta1 * rho) * a * t >= P1 + Kb * (delta1 - 2.0 * t)

    t = global_first(comm, gap, holds)
    return t if t is not None else global_max(comm, gap)


def _median(comm: MPI.Comm | None, values: npt.NDArray[np.float64]) -> float:
    """The median of the values of all ranks (as :func:`numpy.median`)."""
    if comm is None or comm.size == 1:
        return float(np.median(values))
    n = global_count(comm, np.ones(values.size, dtype=bool))
    hi = global_kth(comm, values, n // 2)
    return hi if n % 2 else (global_kth(comm, values, n // 2 - 1) + hi) / 2.0


def punch_approach(
    coords: npt.NDArray[np.float64],
    un: npt.NDArray[np.float64],
    force: npt.NDArray[np.float64],
    patch: npt.NDArray[np.bool_],
    rho: float,
    comm: MPI.Comm | None = None,
) -> float:
    """The approach ``δ₁`` of the patch solve, from the surface around the patch.

    Outside a flat punch of radius ``ρ`` pressed in by ``δ`` the surface moves by
    ``δ (1 − (2/π) arcsin(ρ/r))`` (Johnson, Contact Mechanics, §3.8); the median of
    ``u_n / (1 − (2/π) arcsin(ρ/r))`` over the nodes at ``2ρ ≤ r ≤ 4ρ`` from the patch's
    force centre estimates ``δ``.  Far nodes are not used: there the bending of a body
    held at a few nodes adds to ``u_n``.  Falls back to the largest ``u_n`` outside the
    patch if no node lies in that ring.  ``comm``: the nodes are this rank's, the
    estimate is over the nodes of all ranks (collective).
    """
    outside = ~patch
    if not global_any(comm, outside):
        return 0.0
    wgt = np.maximum(force[patch], 0.0)
    wsum = global_sum(comm, float(wgt.sum()))
    c = (
        global_vsum(comm, (wgt[:, None] * coords[patch]).sum(axis=0)) / wsum
        if wsum > 0
        else global_vsum(comm, coords[patch].sum(axis=0)) / global_count(comm, patch)
    )
    r = np.linalg.norm(coords - c, axis=1)
    ring = outside & (r >= 2.0 * rho) & (r <= 4.0 * rho)
    if not global_any(comm, ring):
        return global_max(comm, un[outside])
    shape = 1.0 - (2.0 / np.pi) * np.arcsin(rho / r[ring])
    return _median(comm, un[ring] / shape)


def first_set(
    coords: npt.NDArray[np.float64],
    gap: npt.NDArray[np.float64],
    area: npt.NDArray[np.float64],
    un: npt.NDArray[np.float64],
    force: npt.NDArray[np.float64],
    patch: npt.NDArray[np.bool_],
    dforce: npt.NDArray[np.float64] | None,
    shift: float,
    comm: MPI.Comm | None = None,
) -> npt.NDArray[np.bool_]:
    """The first active set of one contact pair after the patch solve.

    Parameters
    ----------
    coords
        Reference coordinates of the pair's slave nodes (this rank's, with ``comm``).
    gap, area
        Gaps ``g_p`` and areas ``D_pp`` of the pair's slave nodes.
    un
        Normal approach ``u_n,p`` of the first solve.
    force
        Nodal contact forces ``w_p = D_pp λ_p`` of the first solve (compressive > 0).
    patch
        The support patch (the first set).
    dforce
        Change of the nodal forces when every patch node is pushed ``shift`` further
        (``None``: the structure is taken as absent, ``K_b = 0``).
    shift
        The push (m) ``dforce`` belongs to.
    comm
        The ranks over which the pair's nodes are spread (``None``: all here).

    Returns
    -------
    numpy.ndarray
        Mask of the first set; the patch itself if the first solve gives no usable
        measurement (no compressive patch force, no approach).
    """
    if not global_any(comm, patch):
        return patch.copy()
    g0 = global_min(comm, gap[patch])
    g = np.maximum(gap - g0, 0.0)
    P1 = global_sum(comm, float(force[patch].sum()))
    rho = float(np.sqrt(global_sum(comm, float(np.abs(area[patch]).sum())) / np.pi))
    delta1 = punch_approach(coords, un - g0, force, patch, rho, comm)
    if P1 <= 0.0 or delta1 <= 0.0:
        return patch.copy()
    Kb = 0.0
    if dforce is not None and shift > 0.0:
        K = global_sum(comm, float(dforce[patch].sum())) / shift
        Kb = structure_stiffness(P1, delta1, K)
    t = edge_gap(g, area, P1, delta1, rho, Kb, comm)
    return patch | (g <= t)


def patch_response(
    system: CondensedSystem,
    strategy: LinearStrategy,
    rows: SetRows,
    patch: npt.NDArray[np.bool_],
    lam_n: npt.NDArray[np.float64],
    shift: float,
) -> tuple[npt.NDArray[np.float64], int]:
    """Change of the normal contact forces ``w`` of all slave nodes when every node of
    the first set ``patch`` is pushed ``shift`` further (one more solve of the same set).

    ``rows`` are the rows of the first system (a cold start: no slip rows, no given
    forces) and ``lam_n`` its normal multipliers.  Returns the change and the linear
    iterations of the extra solve.
    """
    R0 = system.layout.rows_of[0]
    dvals = np.zeros(system.layout.n_rows)
    dvals[R0[patch]] = shift
    sol = strategy.respond(rows, dvals)
    return sol.w[R0] - lam_n * system.D, sol.iterations


def predicted_set(
    system: CondensedSystem,
    strategy: LinearStrategy,
    rows: SetRows,
    patch: npt.NDArray[np.bool_],
    it: Iterate,
) -> tuple[npt.NDArray[np.bool_], int]:
    """The first set update of a 3D cold start, pair by pair (:func:`first_set`).

    ``rows`` are the rows of the first system, ``patch`` its active set (the support
    patch) and ``it`` the first iterate.  Patch nodes that pull in the first solve are
    released in every pair (the plain rule's release).  A pair whose patch carries no
    compressive force in the first solve (pulled apart), or that has no patch (it started
    open), takes the plain active-set rule instead: an empty patch measures nothing, and
    keeping it would accept the first solve's penetrations as converged.  Returns the set
    and the linear iterations of the extra solve.
    """
    lay, gap, D, comm = system.layout, system.gap, system.D, system.layout.comm
    force = it.lam_n * D
    g0 = global_min(comm, gap[patch]) if global_any(comm, patch) else 0.0
    shift = max(global_max(comm, it.un - g0, 0.0), 0.0)
    dforce, its = None, 0
    if shift > 0.0 and global_any(comm, patch):
        dforce, its = patch_response(system, strategy, rows, patch, it.lam_n, shift)
    interfaces = system.interfaces
    X = np.concatenate([itf.coords for itf in interfaces])
    pair = np.concatenate(
        [np.full(itf.num_owned, k) for k, itf in enumerate(interfaces)] + [np.zeros(0, int)]
    )
    new = np.zeros(lay.n_nodes, dtype=bool)
    release = it.ind_n > it.eps  # the plain rule (docs/theory/pdas.md#active-set-rule)
    for k in range(len(interfaces)):
        m = pair == k
        pulled = global_sum(comm, float(force[m & patch].sum())) <= 0.0
        if pulled:
            # a pair pulled apart (e.g. crack faces in tension) or started open: nothing
            # to measure the compliance with, and keeping the patch would accept tensile
            # multipliers (an empty one: penetrations)
            new[m] = release[m]
            continue
        new[m] = first_set(
            X[m],
            gap[m],
            D[m],
            it.un[m],
            force[m],
            patch[m],
            None if dforce is None else dforce[m],
            shift,
            comm,
        )
    # a patch node that pulls (its indicator below −ε) is released, as by the plain rule:
    # a patch that carries compression as a whole may pull at some nodes (a crack closed
    # at one end and opened at the other); kept, the unchanged set reads as converged
    return new & ~(patch & (it.ind_n < -it.eps)), its


def support_patch(
    coords: npt.NDArray[np.float64],
    D: npt.NDArray[np.float64],
    closest: npt.NDArray[np.bool_],
    gdim: int,
    radius: float = SUPPORT_RADIUS,
    comm: MPI.Comm | None = None,
) -> npt.NDArray[np.bool_]:
    """The closest slave nodes and every slave node within ``radius`` local mesh sizes of
    one of them (docs/theory/pdas.md#cold-start).

    A single touching node cannot hold a body against its rotations (two in 3D, one in
    2D) about that node; its neighbours on the surface, in every direction, can.  The
    local mesh size of node ``p`` is ``D_pp`` (2D; the length it carries) or
    ``√(D_pp)`` (3D; ``D_pp ≈ 0.87 h²`` on equilateral triangles).

    Parameters
    ----------
    coords, D
        Reference coordinates ``(n, gdim)`` and ``D_pp`` of the slave nodes of a pair
        (this rank's, with ``comm``).
    closest
        Mask of the closest nodes.
    gdim
        Geometric dimension.
    radius
        Patch radius in local mesh sizes.
    comm
        The ranks over which the pair's nodes are spread: the closest nodes of
        neighbouring ranks within reach are exchanged (collective).

    Returns
    -------
    numpy.ndarray
        Mask of the patch (``closest`` included).
    """
    if not global_any(comm, closest):
        return closest.copy()
    h = np.abs(D[closest]) ** (1.0 / max(gdim - 1, 1))
    reach = radius * global_max(comm, h, 0.0)
    pts, hs = neighbour_points(comm, coords[closest], h, reach, coords)
    if not hs.size:
        return closest.copy()
    tree = cKDTree(pts)
    dist, j = tree.query(coords, k=1)
    return closest | (dist <= radius * hs[j])


def initial_set(
    layout: RowLayout, interfaces: list[ContactInterface], gap_tol: float
) -> npt.NDArray[np.bool_]:
    """The first active set of a cold start (docs/theory/pdas.md#cold-start): per pair, the
    nodes whose gap is within ``gap_tol`` of the smallest gap of that pair (the
    closed-gap nodes when the bodies touch, the closest ones when they start apart), and
    the support patch around them (:func:`support_patch`), so that a body held only by
    contact is supported against its rigid modes from the first solve even when it
    touches at a single node; none of a pair that starts open
    (:attr:`~bonecontact.contact.interface.ContactInterface.start_open`: a crack's faces).
    This rank's owned nodes (collective)."""
    out = []
    comm = layout.comm
    for itf in interfaces:
        if itf.start_open:
            out.append(np.zeros(itf.num_owned, dtype=bool))
            continue
        gmin = global_min(comm, itf.gap)
        closest = itf.gap <= max(gmin if np.isfinite(gmin) else 0.0, 0.0) + gap_tol
        out.append(support_patch(itf.coords, itf.D, closest, itf.gdim, comm=comm))
    return np.concatenate(out + [np.zeros(0, bool)])
