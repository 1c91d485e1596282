"""Williams' near-tip fields of a straight crack in a homogeneous isotropic plane
(docs/theory/fracture.md#auxiliary-fields).

In the tip frame (x₁ ahead of the tip along the crack, x₂ normal to it, polar (r, θ),
θ = ±π on the faces) the leading displacement terms are

    u₁ = √(r/2π)/(2μ) {K_I cos(θ/2) [κ − 1 + 2 sin²(θ/2)] + K_II sin(θ/2) [κ + 1 + 2 cos²(θ/2)]}
    u₂ = √(r/2π)/(2μ) {K_I sin(θ/2) [κ + 1 − 2 cos²(θ/2)] − K_II cos(θ/2) [κ − 1 − 2 sin²(θ/2)]}

with κ = 3 − 4ν (plane strain) or (3 − ν)/(1 + ν) (plane stress).  The same formulae
give a NumPy field (for interpolation, tests) and a UFL expression (the auxiliary field
of the interaction integral, differentiated by UFL).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
import numpy.typing as npt
import ufl

from bonecontact.common.errors import ParameterError

__all__ = [
    "PlaneState",
    "elastic_constants",
    "williams_displacement",
    "williams_displacement_ufl",
    "williams_stress",
]

PlaneState = Literal["strain", "stress"]


def elastic_constants(E: float, nu: float, plane: PlaneState) -> dict[str, float]:
    """In-plane constants of an isotropic material in plane strain or plane stress.

    Returns
    -------
    dict
        ``mu`` (shear modulus), ``lmbda`` (the in-plane Lamé constant: λ in plane strain,
        2λμ/(λ + 2μ) in plane stress), ``kappa`` (Kolosov constant) and ``E_prime``
        (E/(1 − ν²) in plane strain, E in plane stress), SI units.
    """
    if plane not in ("strain", "stress"):
        raise ParameterError("plane", f"must be 'strain' or 'stress', got {plane!r}")
    if not (E > 0 and -1.0 < nu < 0.5):
        raise ParameterError("material", f"needs E > 0 and -1 < nu < 0.5, got E={E}, nu={nu}")
    mu = E / (2 * (1 + nu))
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    if plane == "strain":
        return {"mu": mu, "lmbda": lam, "kappa": 3 - 4 * nu, "E_prime": E / (1 - nu**2)}
    return {
        "mu": mu,
        "lmbda": 2 * lam * mu / (lam + 2 * mu),
        "kappa": (3 - nu) / (1 + nu),
        "E_prime": E,
    }


def _local_displacement(r, th, mu: float, kappa: float, k1: float, k2: float, m):
    """(u₁, u₂) in the tip frame; ``m`` supplies sin/cos/sqrt (NumPy or UFL)."""
    c = m.sqrt(r / (2 * math.pi)) / (2 * mu)
    ch, sh = m.cos(th / 2), m.sin(th / 2)
    u1 = c * (k1 * ch * (kappa - 1 + 2 * sh**2) + k2 * sh * (kappa + 1 + 2 * ch**2))
    u2 = c * (k1 * sh * (kappa + 1 - 2 * ch**2) - k2 * ch * (kappa - 1 - 2 * sh**2))
    return u1, u2


def _frame(direction: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    e1 = np.asarray(direction, dtype=float)[:2]
    e1 = e1 / np.linalg.norm(e1)
    return e1, np.array([-e1[1], e1[0]])


def williams_displacement(
    x: npt.ArrayLike,
    tip: npt.ArrayLike,
    direction: npt.ArrayLike,
    E: float,
    nu: float,
    plane: PlaneState,
    K_I: float,
    K_II: float,
    side: npt.ArrayLike | None = None,
) -> npt.NDArray[np.float64]:
    """Near-tip displacement at points ``x`` (shape (2 or 3, n)), global frame, shape (2, n).

    ``direction`` is the crack direction at the tip (pointing ahead); θ = ±π on the faces.
    ``side`` (+1 or −1 per point, optional) says which face a point on the crack line
    behind the tip belongs to (+1: the face on the e₂ = ẑ × e₁ side, θ = π).
    """
    x = np.asarray(x, dtype=float)
    e1, e2 = _frame(direction)
    d = x[:2] - np.asarray(tip, dtype=float)[:2, None]
    x1, x2 = e1 @ d, e2 @ d
    r = np.hypot(x1, x2)
    th = np.arctan2(x2, x1)
    if side is not None:
        on_cut = (x1 < 0) & (np.abs(x2) <= 1e-9 * r)
        th = np.where(on_cut, np.pi * np.sign(np.broadcast_to(side, th.shape)), th)
    c = elastic_constants(E, nu, plane)
    u1, u2 = _local_displacement(r, th, c["mu"], c["kappa"], K_I, K_II, np)
    return np.outer(e1, u1) + np.outer(e2, u2)


def williams_stress(
    r: npt.ArrayLike, theta: npt.ArrayLike, K_I: float, K_II: float
) -> npt.NDArray[np.float64]:
    """Near-tip stresses (σ₁₁, σ₂₂, σ₁₂) in the tip frame at polar points, shape (3, n)."""
    r, th = np.asarray(r, dtype=float), np.asarray(theta, dtype=float)
    f = 1.0 / np.sqrt(2 * np.pi * r)
    c, s = np.cos(th / 2), np.sin(th / 2)
    c3, s3 = np.cos(3 * th / 2), np.sin(3 * th / 2)
    s11 = K_I * c * (1 - s * s3) - K_II * s * (2 + c * c3)
    s22 = K_I * c * (1 + s * s3) + K_II * s * c * c3
    s12 = K_I * c * s * c3 + K_II * c * (1 - s * s3)
    return f * np.vstack([s11, s22, s12])


def williams_displacement_ufl(
    x: ufl.SpatialCoordinate,
    tip: npt.ArrayLike | ufl.core.expr.Expr,
    direction: npt.ArrayLike | ufl.core.expr.Expr,
    mu: float | ufl.core.expr.Expr,
    kappa: float | ufl.core.expr.Expr,
    K_I: float | ufl.core.expr.Expr,
    K_II: float | ufl.core.expr.Expr,
) -> ufl.core.expr.Expr:
    """The near-tip displacement as a UFL vector of the spatial coordinate ``x`` (2D).

    ``tip`` and ``direction`` (a unit vector) may be numbers or UFL expressions such as
    ``dolfinx.fem.Constant``; with constants one compiled form serves every tip.
    """
    if not isinstance(tip, ufl.core.expr.Expr):
        tip = ufl.as_vector([float(v) for v in np.asarray(tip, dtype=float)[:2]])
    if not isinstance(direction, ufl.core.expr.Expr):
        e1n, _ = _frame(direction)
        direction = ufl.as_vector([float(e1n[0]), float(e1n[1])])
    e1 = direction
    e2 = ufl.as_vector([-e1[1], e1[0]])
    d = ufl.as_vector([x[0] - tip[0], x[1] - tip[1]])
    x1, x2 = ufl.dot(d, e1), ufl.dot(d, e2)
    r = ufl.sqrt(x1**2 + x2**2)
    u1, u2 = _local_displacement(r, ufl.atan2(x2, x1), mu, kappa, K_I, K_II, ufl)
    return u1 * e1 + u2 * e2
