"""Where a crack starts and which way it runs (docs/theory/fracture.md#criteria).

* :func:`mts_angle` — the maximum-tangential-stress kink angle from (K_I, K_II), and
  :func:`mts_equivalent_k`, the K_I-equivalent the criterion compares with K_Ic.
* :func:`principal_direction_average` — the direction normal to the average principal
  direction of the cells nearest the tip, weighted by inverse distance to the tip.
* :func:`risk_field` — the initiation risk of every cell from its principal stresses:
  ``"tension"`` σ₁/σ_t, or ``"tension_compression"`` max(σ₁/σ_t, −σ₃/σ_c); with the
  location, value and crack direction of its maximum (:class:`RiskMaximum`).

Stresses come from the mechanics model (P1 displacements: constant per cell), so every
cell quantity is exact for the discrete solution and computed without projection.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
from dolfinx import fem, mesh

from bonecontact.common.errors import ParameterError
from bonecontact.mechanics.model import Mechanics

__all__ = [
    "RISK_CRITERIA",
    "CellPrincipal",
    "CellStresses",
    "RiskMaximum",
    "cell_principal",
    "cell_stresses",
    "mts_angle",
    "mts_equivalent_k",
    "principal_direction_average",
    "risk_field",
]

Criterion = Literal["tension", "tension_compression"]
#: The initiation criteria a scene can choose.
RISK_CRITERIA = ("tension", "tension_compression")


# ------------------------------------------------------------------------------- MTS
def mts_angle(K_I: float, K_II: float) -> float:
    """Kink angle θ (rad, counter-clockwise from the crack direction) of maximum
    tangential stress: θ = 2 arctan[(K_I − √(K_I² + 8K_II²)) / (4K_II)] (0 for K_II = 0).

    K_II > 0 gives θ < 0; pure mode II gives ∓70.53°.  For K_I < 0 (a closed crack) the
    formula still gives the angle of maximum hoop stress of the shear field.
    """
    if K_II == 0.0:
        return 0.0
    return 2.0 * math.atan((K_I - math.sqrt(K_I**2 + 8.0 * K_II**2)) / (4.0 * K_II))


def mts_equivalent_k(K_I: float, K_II: float, theta: float | None = None) -> float:
    """K_eq = cos(θ/2) [K_I cos²(θ/2) − (3/2) K_II sin θ] at the MTS angle: the hoop stress
    ahead of the kinked tip as a mode-I intensity, compared with K_Ic."""
    th = mts_angle(K_I, K_II) if theta is None else theta
    c = math.cos(th / 2)
    return c * (K_I * c * c - 1.5 * K_II * math.sin(th))


# ----------------------------------------------------------------- cell stresses
@dataclass
class CellStresses:
    """Stresses of the owned cells of a 2D model.

    Attributes
    ----------
    cells
        Owned cell indices.
    midpoints
        Cell midpoints, shape (n, 2).
    in_plane
        (σ_xx, σ_yy, σ_xy) per cell, shape (n, 3).
    sigma_zz
        Out-of-plane stress (plane strain), shape (n,).
    """

    cells: npt.NDArray[np.int32]
    midpoints: npt.NDArray[np.float64]
    in_plane: npt.NDArray[np.float64]
    sigma_zz: npt.NDArray[np.float64]

    def principal(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(σ₁, σ₃, φ₁): the largest and smallest of the three principal stresses and the
        angle (rad, from x) of the in-plane direction of the larger in-plane one."""
        sxx, syy, sxy = self.in_plane.T
        c, r = 0.5 * (sxx + syy), np.hypot(0.5 * (sxx - syy), sxy)
        p1, p2 = c + r, c - r
        phi = 0.5 * np.arctan2(2 * sxy, sxx - syy)
        return np.maximum(p1, self.sigma_zz), np.minimum(p2, self.sigma_zz), phi


def cell_stresses(model: Mechanics, u: fem.Function) -> CellStresses:
    """Stress of every owned cell from the model's constitutive law (2D)."""
    msh = model.mesh
    if model.dim != 2:
        raise ParameterError("dimension", "the 2D fracture criteria need a 2D model")
    T = fem.functionspace(msh, ("DG", 0, (3, 3)))
    s = fem.Function(T)
    s.interpolate(fem.Expression(model.stress_expression(u), T.element.interpolation_points))
    n = msh.topology.index_map(2).size_local
    vals = s.x.array.reshape(-1, 9)[T.dofmap.list[:n, 0]]
    cells = np.arange(n, dtype=np.int32)
    mid = mesh.compute_midpoints(msh, 2, cells)[:, :2]
    return CellStresses(cells, mid, vals[:, [0, 4, 1]].copy(), vals[:, 8].copy())


# -------------------------------------------------------------- direction average
def principal_direction_average(
    stresses: CellStresses,
    comm: MPI.Comm,
    tip: npt.ArrayLike,
    direction: npt.ArrayLike,
    n_points: int = 12,
    r_min: float = 0.0,
) -> float:
    """Kink angle (rad, counter-clockwise from ``direction``) normal to the average maximum
    principal direction of the ``n_points`` cells nearest the tip.

    The principal directions are axes (φ and φ + π are the same), so they are averaged as
    doubled angles, weight 1/d (d: cell midpoint to tip), and the crack runs normal to
    the mean axis, on the side ahead of the tip.  Cells closer than ``r_min`` to the tip
    (the tip cells, whose P1 stress is the least accurate) are left out.
    """
    tip = np.asarray(tip, dtype=float)[:2]
    e1 = np.asarray(direction, dtype=float)[:2]
    e1 = e1 / np.linalg.norm(e1)
    d = np.hypot(*(stresses.midpoints - tip).T)
    d = np.where(d < r_min, np.inf, d)
    mine = np.argsort(d)[:n_points]
    mine = mine[np.isfinite(d[mine])]
    _, _, phi = stresses.principal()
    local = np.column_stack([d[mine], phi[mine], stresses.midpoints[mine]])
    rows = np.concatenate(comm.allgather(local))
    if len(rows) < n_points:
        raise ParameterError("n_points", f"only {len(rows)} cells in the mesh")
    rows = rows[np.lexsort((rows[:, 3], rows[:, 2], rows[:, 0]))][:n_points]
    w = 1.0 / np.maximum(rows[:, 0], 1e-300)
    mean2 = math.atan2(float(w @ np.sin(2 * rows[:, 1])), float(w @ np.cos(2 * rows[:, 1])))
    normal = 0.5 * mean2 + 0.5 * math.pi  # the crack plane is normal to sigma_1
    t = np.array([math.cos(normal), math.sin(normal)])
    if t @ e1 < 0:
        t = -t
    return math.atan2(e1[0] * t[1] - e1[1] * t[0], float(e1 @ t))


# ------------------------------------------------------------------- risk field
@dataclass(frozen=True)
class RiskMaximum:
    """The largest initiation risk: value, cell midpoint (2 or 3 coordinates, m), the
    crack a crack started there would open, and which term governs.

    ``crack_normal`` is the unit σ₁ axis (the normal of the crack plane, 2 or 3
    components; the sign makes its largest component positive).  In 2D
    ``crack_direction`` is the unit vector along the crack line (normal to the in-plane
    σ₁ axis); in 3D the crack is a plane and ``crack_direction`` is ``None``.  For the
    compression term the crack is likewise taken normal to σ₁.
    """

    value: float
    location: tuple[float, ...]
    crack_direction: tuple[float, float] | None
    mode: str
    crack_normal: tuple[float, ...] = ()


@dataclass(frozen=True)
class CellPrincipal:
    """σ₁ ≥ … ≥ σ₃ of the owned cells of a 2D or 3D model and the σ₁ axis.

    In 2D σ₁ and σ₃ include σ_zz (plane strain) and ``axis`` is the in-plane direction of
    the larger in-plane principal stress; in 3D ``axis`` is the σ₁ eigenvector.
    """

    cells: npt.NDArray[np.int32]
    midpoints: npt.NDArray[np.float64]  # (n, gdim)
    sigma_1: npt.NDArray[np.float64]
    sigma_3: npt.NDArray[np.float64]
    axis: npt.NDArray[np.float64]  # (n, gdim) unit vectors


def cell_principal(model: Mechanics, u: fem.Function) -> CellPrincipal:
    """Principal stresses and σ₁ axis of every owned cell (2D: :func:`cell_stresses`;
    3D: the eigen-decomposition of the cell's 3×3 stress)."""
    if model.dim == 2:
        cs = cell_stresses(model, u)
        s1, s3, phi = cs.principal()
        axis = np.column_stack([np.cos(phi), np.sin(phi)])
        return CellPrincipal(cs.cells, cs.midpoints, s1, s3, axis)
    msh = model.mesh
    T = fem.functionspace(msh, ("DG", 0, (3, 3)))
    s = fem.Function(T)
    s.interpolate(fem.Expression(model.stress_expression(u), T.element.interpolation_points))
    n = msh.topology.index_map(3).size_local
    tensors = s.x.array.reshape(-1, 3, 3)[T.dofmap.list[:n, 0]]
    w, v = np.linalg.eigh(0.5 * (tensors + np.transpose(tensors, (0, 2, 1))))
    cells = np.arange(n, dtype=np.int32)
    mid = mesh.compute_midpoints(msh, 3, cells)
    return CellPrincipal(cells, mid, w[:, 2].copy(), w[:, 0].copy(), v[:, :, 2].copy())


def _check_strengths(criterion: str, sigma_t: float | None, sigma_c: float | None) -> None:
    if criterion not in RISK_CRITERIA:
        raise ParameterError("criterion", f"must be one of {RISK_CRITERIA}, got {criterion!r}")
    needed = {"sigma_t": sigma_t} | ({"sigma_c": sigma_c} if criterion != "tension" else {})
    for key, v in needed.items():
        if v is None or not (math.isfinite(v) and v > 0):
            raise ParameterError(key, f"the {criterion!r} criterion needs a positive strength")


def _smallest_strength(comm: MPI.Comm, values: float | npt.ArrayLike) -> float:
    """The smallest strength over all ranks (collective, so that a missing or invalid
    value is refused on every rank; a rank with no cells contributes nothing).  ``nan``
    when any value is ``nan`` (a strength that is not given)."""
    a = np.asarray(values, dtype=float).ravel()
    local = float(np.min(a, initial=np.inf)) if not np.isnan(a).any() else np.nan
    has_nan = comm.allreduce(int(math.isnan(local)), op=MPI.MAX)
    smallest = comm.allreduce(np.inf if math.isnan(local) else local, op=MPI.MIN)
    return math.nan if has_nan else smallest


def risk_field(
    model: Mechanics,
    u: fem.Function,
    sigma_t: float | npt.ArrayLike,
    sigma_c: float | npt.ArrayLike | None = None,
    criterion: Criterion = "tension",
) -> tuple[fem.Function, RiskMaximum]:
    """Initiation risk per cell and its maximum.

    Parameters
    ----------
    model, u
        The 2D or 3D mechanics model and its displacement.
    sigma_t, sigma_c
        Tensile and compressive strengths (Pa, > 0): numbers, or one value per owned
        cell (heterogeneous strengths).
    criterion
        ``"tension"``: risk = max(σ₁, 0)/σ_t; ``"tension_compression"``:
        max(σ₁/σ_t, −σ₃/σ_c, 0).  σ₁ ≥ σ₂ ≥ σ₃ include σ_zz (plane strain).

    Returns
    -------
    (dolfinx.fem.Function, RiskMaximum)
        The DG0 risk (named ``"fracture_risk"``; initiation where it reaches 1) and its
        maximum over all ranks (ties: the smallest x, then y, then z).
    """
    comm = model.mesh.comm
    st = _smallest_strength(comm, sigma_t)
    sc = None if sigma_c is None else _smallest_strength(comm, sigma_c)
    _check_strengths(criterion, st, sc)
    cp = cell_principal(model, u)
    s1, s3 = cp.sigma_1, cp.sigma_3
    tension = np.maximum(s1, 0.0) / np.asarray(sigma_t, dtype=float)
    risk, mode = tension, np.zeros(s1.shape, dtype=int)
    if criterion == "tension_compression":
        compression = np.maximum(-s3, 0.0) / np.asarray(sigma_c, dtype=float)
        mode = (compression > tension).astype(int)
        risk = np.maximum(tension, compression)
    V0 = fem.functionspace(model.mesh, ("DG", 0))
    f = fem.Function(V0, name="fracture_risk")
    f.x.array[V0.dofmap.list[cp.cells, 0]] = risk
    f.x.scatter_forward()
    return f, _maximum(model.mesh.comm, cp, risk, mode)


def _maximum(comm: MPI.Comm, cp: CellPrincipal, risk: np.ndarray, mode: np.ndarray) -> RiskMaximum:
    gdim = cp.midpoints.shape[1]
    best: tuple = (-1.0, (0.0,) * gdim, (0.0,) * gdim, 0)
    if risk.size:  # ties (a uniform or zero field): the smallest x, then y (then z)
        ties = np.flatnonzero(risk == risk.max())
        keys = tuple(cp.midpoints[ties, k] for k in reversed(range(gdim)))
        i = int(ties[np.lexsort(keys)[0]])
        best = (
            float(risk[i]),
            tuple(map(float, cp.midpoints[i])),
            tuple(map(float, cp.axis[i])),
            int(mode[i]),
        )
    rows = comm.allgather(best)
    top = max(r[0] for r in rows)
    value, x, axis, m = min((r for r in rows if r[0] == top), key=lambda r: r[1])
    a = np.asarray(axis)
    a = a if a[int(np.argmax(np.abs(a)))] >= 0 else -a
    along = None
    if gdim == 2:  # along the crack line: the sigma_1 angle phi (from the cell) + 90 degrees
        normal = math.atan2(axis[1], axis[0]) + 0.5 * math.pi
        along = (math.cos(normal), math.sin(normal))
    return RiskMaximum(value, x, along, ("tension", "compression")[m], tuple(map(float, a)))
