"""Coupled contact rows (3D Newton slip rows, edge nodes) posed for the Krylov solver
(docs/theory/pdas.md#friction-rows-in-the-iterative-solver).

A group of rows ``q`` of one slave node replaces its equations by ``G w + H x = h``
(``w`` the residual ``r − B x`` of the rows, ``x`` their unknowns).  The direct solvers
insert the rows ``G B x − H x = G r − h`` as they are; the Krylov solver needs a
symmetric positive definite matrix to build its multigrid from and a system close to it.
:func:`krylov_groups` rewrites the groups into an equivalent form:

* a row with no residual in any equation and one unknown of its own (``k x_i = k g``:
  the normal row that 3D Newton slip groups carry while edge nodes are present) is a
  prescribed value: it joins the fixed rows (eliminated symmetrically);
* a group whose remaining ``G`` is invertible is multiplied by ``G⁻¹``: its rows become
  the elastic rows plus a nodal block ``K = −G⁻¹H`` (a tangential spring;
  symmetric positive semidefinite at a converged slip state);
* any other group (edge nodes: ``G`` singular) is kept as it is.

Units: those of the operator (the caller's).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["COND_MAX", "CoupledGroup", "krylov_groups", "spring_split"]

#: Largest condition number of a group's ``G`` that is inverted (larger: the group is
#: kept as the direct solvers insert it).
COND_MAX = 1e8


@dataclass
class CoupledGroup:
    """One node's replaced rows ``G w + H x = h`` (``rows``: this rank's contact-row
    indices); ``scaled``: ``G`` is the identity (the rows are the elastic rows plus
    ``−H`` on the group's own columns)."""

    rows: npt.NDArray[np.int64]
    G: npt.NDArray[np.float64]
    H: npt.NDArray[np.float64]
    h: npt.NDArray[np.float64]
    scaled: bool


def _constraint_rows(G: np.ndarray, H: np.ndarray) -> list[int]:
    """Rows ``i`` with ``G`` zero in row and column ``i`` and ``H`` only on ``(i, i)``."""
    out = []
    for i in range(G.shape[0]):
        own = H[i, i] != 0.0 and np.count_nonzero(H[i]) == 1
        if own and not G[i].any() and not G[:, i].any():
            out.append(i)
    return out


def krylov_groups(
    coupled: tuple | None,
    fixed: npt.NDArray[np.bool_],
    values: npt.NDArray[np.float64],
) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.float64], list[CoupledGroup]]:
    """The groups of ``coupled = (rows, G, H, h)`` in the Krylov solver's form (module
    docstring), and the fixed rows and values extended by the prescribed rows.

    Returns
    -------
    fixed, values, groups
        Copies of ``fixed``/``values`` with the prescribed rows added, and the groups.
    """
    fixed, values = fixed.copy(), values.copy()
    groups: list[CoupledGroup] = []
    if coupled is None:
        return fixed, values, groups
    crow, Gc, Hc, hc = coupled
    for i in range(np.asarray(crow).shape[0]):
        rows = np.asarray(crow[i], dtype=np.int64)
        G, H, h = np.array(Gc[i], float), np.array(Hc[i], float), np.array(hc[i], float)
        gone = _constraint_rows(G, H)
        for k in gone:
            value = h[k] / H[k, k]
            fixed[rows[k]], values[rows[k]] = True, value
            h -= H[:, k] * value  # (the column of a prescribed unknown goes to h)
        keep = [k for k in range(rows.size) if k not in gone]
        if not keep:
            continue
        G, H, h = G[np.ix_(keep, keep)], H[np.ix_(keep, keep)], h[keep]
        scaled = bool(np.linalg.cond(G) < COND_MAX)
        if scaled:
            H, h = np.linalg.solve(G, H), np.linalg.solve(G, h)
            G = np.eye(len(keep))
        groups.append(CoupledGroup(rows[keep], G, H, h, scaled))
    return fixed, values, groups


def spring_split(H: npt.NDArray[np.float64]) -> tuple[np.ndarray, np.ndarray]:
    """``K = −H`` of a scaled group split as ``S + (K − S)``: ``S`` the symmetric positive
    semidefinite part of ``K`` (negative eigenvalues of ``(K + Kᵀ)/2`` set to zero; it
    goes into the preconditioner's matrix), ``K − S`` the rest (applied apart)."""
    K = -H
    lam, V = np.linalg.eigh(0.5 * (K + K.T))
    S = (V * np.maximum(lam, 0.0)) @ V.T
    return S, K - S
