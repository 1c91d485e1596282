"""Friction laws of the PDAS contact solver: bounds, slip sets and 3D slip linearisation.

Everything here works on the replicated per-node arrays of
:class:`bonecontact.contact.pdas.ContactSolver` (one entry per slave node of every rank,
identical on all ranks), pure NumPy:

* :class:`FrictionLaw`, the friction of one contact pair;
* the friction bounds ``ĝ_p``: Tresca, the given bound; Coulomb, ``μ λ_n,p`` of the
  previous step (:func:`step_bounds`) or of the current iterate (Algorithm FP,
  :func:`coulomb_fixed_point_bounds`);
* the slip set ``|λ_t + c_t Δu_t| > ĝ_p`` (:func:`slip_set`), the slip directions and
  the stick rule for a reversed slip (:func:`slip_directions`);
* 3D slip nodes: the damped semi-smooth Newton rows of ``|ξ| λ_t − ĝ ξ = 0``
  (:func:`slip_newton_rows`) and the Aitken-accelerated fixed point of the slip
  directions (:func:`aitken_directions`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

__all__ = [
    "FRICTION_KIND",
    "FrictionLaw",
    "aitken_directions",
    "coulomb_fixed_point_bounds",
    "slip_directions",
    "slip_newton_rows",
    "slip_set",
    "step_bounds",
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
) -> tuple[npt.NDArray[np.float64], float]:
    """Algorithm FP: the bounds ``μ max(0, λ_n)`` of the current iterate at the nodes ``fp``.

    Returns the new bounds and their relative change (0 when they are all zero).
    """
    g_new = g.copy()
    g_new[fp] = mu[fp] * np.maximum(lam_n[fp], 0.0)
    den = float(np.linalg.norm(g_new[fp]))
    change = float(np.linalg.norm(g_new[fp] - g[fp])) / den if den > 0 else 0.0
    return g_new, change


def slip_set(
    an: npt.NDArray[np.bool_],
    fric: npt.NDArray[np.bool_],
    zn: npt.NDArray[np.float64],
    g: npt.NDArray[np.float64],
    eps: float,
) -> npt.NDArray[np.bool_]:
    """Active friction nodes with ``|λ_t + c_t Δu_t|`` (``zn``) above the bound
    (docs/theory/pdas.md#active-set-rule).

    A node with a zero bound (Coulomb with no pressure yet) slips: it carries no
    tangential traction (a "stick" decided on round-off of ξ ≈ 0 could only toggle).
    """
    gtol = 1e-10 * max(float(g.max()) if g.size else 0.0, eps)
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
        ``(n, gdim − 1)`` tangential rows (replicated numbering) of the slip nodes.
    D, lam_t, z, g
        ``D_pp``, the traction ``λ^k``, ``ξ^k`` and the bound ``ĝ`` of the slip nodes.
    c_t
        Tangential complementarity parameter.
    xold
        The replicated unknowns at the start of the step.

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
) -> None:
    """Aitken-accelerated fixed point of the 3D slip directions (in place).

    ``aitken`` is ``[previous residual, relaxation]``, carried between iterations; the
    relaxation is reset to 1 whenever the sets changed.  ``new_dirs`` of the nodes
    ``both`` (slipping before and after) is replaced by the relaxed, normalised update.
    """
    res_d = np.where(both[:, None], new_dirs - dirs, 0.0).ravel()
    if not sets_changed and aitken[0] is not None and aitken[0].shape == res_d.shape:
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
