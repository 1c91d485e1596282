"""The first active set of a cold-started 3D contact solve, from the compliance of the
support patch (docs/theory/pdas.md#cold-start).

A cold start solves first with only the support patch ``S`` of the closest nodes held
(:func:`bonecontact.contact.pdas.support_patch`).  Held at a few nodes, a body pushed
by a load sinks far into the obstacle: the patch acts as a small flat punch, whose
approach ``δ₁`` is ``ρ_S/a`` times larger than that of the final contact zone of radius
``a`` (``ρ_S``: the patch radius).  Every node within a large radius then penetrates,
and activating them all (or all within a fraction of the deepest penetration) makes the
PDAS start from a set several times too large, which it then releases ring by ring.

Here the first solve is read as a measurement instead.  It gives the force on the
patch ``P₁``, the approach ``δ₁`` (the largest normal displacement of the slave nodes
relative to the closest gap) and, with one more solve, the stiffness ``K`` with which
the patch force grows when the patch is pushed further.  A flat punch of radius ``ρ``
has the contact compliance ``1/(2E*ρ)``, so ``2E* ≈ P₁/(δ₁ρ_S)`` and the structure
behind the contact has the stiffness ``K_b = 1/(1/K − δ₁/P₁)`` (0 for a body held in
the load direction only by the contact, ∞ for a rigidly driven one).  For a locally
paraboloidal contact of radius ``a`` (Hertz: ``δ = a²/R``, ``P = 4E*a³/(3R)``; the zone
ends where the gap is ``t = δ/2``) with the structure in series, ``P = P₀ − K_b δ`` and
``P₀ = P₁ + K_b δ₁``::

    (4/3) · P₁/(δ₁ ρ_S) · a(t) · t = P₁ + K_b (δ₁ − 2t),

where ``a(t) = √(area{g ≤ t}/π)`` is the radius of the nodes whose gap is within ``t``
of the smallest (areas ``D_pp``).  The left side grows with ``t``, the right side
falls: the root is unique.  The first set is ``{g ≤ t}`` together with the patch.  Only
the path of the PDAS changes; its converged solution is the same.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = [
    "edge_gap",
    "first_set",
    "patch_response",
    "predicted_set",
    "punch_approach",
    "structure_stiffness",
]


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

    Returns
    -------
    float
        The smallest gap at which the left side of the balance reaches the right side
        (``δ₁/2`` for a rigidly driven body).
    """
    if not np.isfinite(Kb):
        return 0.5 * delta1
    order = np.argsort(gap, kind="stable")
    g = gap[order]
    a = np.sqrt(np.cumsum(np.abs(area[order])) / np.pi)
    lhs = (4.0 / 3.0) * P1 / (delta1 * rho) * a * g
    rhs = P1 + Kb * (delta1 - 2.0 * g)
    hit = np.flatnonzero(lhs >= rhs)
    return float(g[hit[0]]) if hit.size else float(g[-1])


def punch_approach(
    coords: npt.NDArray[np.float64],
    un: npt.NDArray[np.float64],
    force: npt.NDArray[np.float64],
    patch: npt.NDArray[np.bool_],
    rho: float,
) -> float:
    """The approach ``δ₁`` of the patch solve, from the surface around the patch.

    Outside a flat punch of radius ``ρ`` pressed in by ``δ`` the surface moves by
    ``δ (1 − (2/π) arcsin(ρ/r))`` (Johnson, Contact Mechanics, §3.8); the median of
    ``u_n / (1 − (2/π) arcsin(ρ/r))`` over the nodes at ``2ρ ≤ r ≤ 4ρ`` from the patch's
    force centre estimates ``δ``.  Far nodes are not used: there the bending of a body
    held at a few nodes adds to ``u_n``.  Falls back to the largest ``u_n`` outside the
    patch if no node lies in that ring.
    """
    outside = ~patch
    if not outside.any():
        return 0.0
    wgt = np.maximum(force[patch], 0.0)
    c = (
        (wgt[:, None] * coords[patch]).sum(axis=0) / wgt.sum()
        if wgt.sum() > 0
        else coords[patch].mean(axis=0)
    )
    r = np.linalg.norm(coords - c, axis=1)
    ring = outside & (r >= 2.0 * rho) & (r <= 4.0 * rho)
    if not ring.any():
        return float(un[outside].max())
    shape = 1.0 - (2.0 / np.pi) * np.arcsin(rho / r[ring])
    return float(np.median(un[ring] / shape))


def first_set(
    coords: npt.NDArray[np.float64],
    gap: npt.NDArray[np.float64],
    area: npt.NDArray[np.float64],
    un: npt.NDArray[np.float64],
    force: npt.NDArray[np.float64],
    patch: npt.NDArray[np.bool_],
    dforce: npt.NDArray[np.float64] | None,
    shift: float,
) -> npt.NDArray[np.bool_]:
    """The first active set of one contact pair after the patch solve.

    Parameters
    ----------
    coords
        Reference coordinates of the pair's slave nodes (replicated).
    gap, area
        Gaps ``g_p`` and areas ``D_pp`` of the pair's slave nodes (replicated).
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

    Returns
    -------
    numpy.ndarray
        Mask of the first set; the patch itself if the first solve gives no usable
        measurement (no compressive patch force, no approach).
    """
    if not patch.any():
        return patch.copy()
    g0 = float(gap[patch].min())
    g = np.maximum(gap - g0, 0.0)
    P1 = float(force[patch].sum())
    rho = float(np.sqrt(np.abs(area[patch]).sum() / np.pi))
    delta1 = punch_approach(coords, un - g0, force, patch, rho)
    if P1 <= 0.0 or delta1 <= 0.0:
        return patch.copy()
    Kb = 0.0
    if dforce is not None and shift > 0.0:
        Kb = structure_stiffness(P1, delta1, float(dforce[patch].sum()) / shift)
    t = edge_gap(g, area, P1, delta1, rho, Kb)
    return patch | (g <= t)


def patch_response(solver, st, it, shift: float) -> npt.NDArray[np.float64]:
    """Change of the normal contact forces ``w`` of all slave nodes when every node of
    the first set is pushed ``shift`` further (one more solve of the same set).

    ``solver`` is the :class:`~bonecontact.contact.pdas.ContactSolver`, ``st`` and
    ``it`` its state and first iterate (a cold start: no slip rows, no given forces).
    """
    R0 = solver._ridx[0]
    fixed = solver._fixed_rows(st.an, st.stick)
    dvals = np.zeros(solver.bs * solver.NS)
    dvals[R0[st.an]] = shift
    if solver.lowrank is not None:
        _, w2 = solver.lowrank.respond(fixed, solver._scale, dvals)
    else:
        # the solve overwrites the field Ũ: keep the first iterate's (the PDAS may stop
        # at this iteration, and the next solve starts from it)
        kept = solver.Uh.copy()
        zero = np.zeros(solver.bs * solver.NS)
        _, w2, its = solver._solve_refactor(fixed, st.values + dvals, zero, st.b)
        kept.copy(solver.Uh)
        kept.destroy()
        st.lin_total += its
    return w2[R0] - it.lam_n * solver._D


def predicted_set(solver, st, it) -> npt.NDArray[np.bool_]:
    """The first set update of a 3D cold start, pair by pair (:func:`first_set`).

    ``solver`` is the :class:`~bonecontact.contact.pdas.ContactSolver`, ``st`` its
    state (``st.an``: the support patch) and ``it`` the first iterate.  A pair whose
    patch carries no compressive force in the first solve (pulled apart) takes the plain
    active-set rule instead.
    """
    gap, D = solver._gap, solver._D
    force = it.lam_n * D
    g0 = float(gap[st.an].min()) if st.an.any() else 0.0
    shift = max(float((it.un - g0).max()), 0.0) if solver.NS else 0.0
    dforce = patch_response(solver, st, it, shift) if shift > 0.0 else None
    X = solver._gn(np.concatenate([itf.coords for itf in solver.interfaces]))
    pair = solver._gn(
        np.concatenate(
            [np.full(itf.num_owned, k) for k, itf in enumerate(solver.interfaces)]
            + [np.zeros(0, int)]
        )
    )
    new = np.zeros(solver.NS, dtype=bool)
    release = it.ind_n > it.eps  # the plain rule (docs/theory/pdas.md#active-set-rule)
    for k in range(len(solver.interfaces)):
        m = pair == k
        if st.an[m].any() and float(force[m & st.an].sum()) <= 0.0:
            # a pair pulled apart (e.g. crack faces in tension): nothing to measure the
            # compliance with, and keeping the patch would accept tensile multipliers
            new[m] = release[m]
            continue
        new[m] = first_set(
            X[m],
            gap[m],
            D[m],
            it.un[m],
            force[m],
            st.an[m],
            None if dforce is None else dforce[m],
            shift,
        )
    return new
