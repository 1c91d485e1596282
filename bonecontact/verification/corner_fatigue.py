"""Newman and Raju's corner crack grown by fatigue: the reference of a scene's corner-crack
growth (docs/theory/fracture.md#corner-cracks-in-a-scenes-body).

A quarter-elliptical corner crack (length c along one face, depth a along the other) in a
plate of thickness t and width w under cyclic tension S keeps its shape and grows by two
degrees of freedom, as :mod:`bonecontact.runners.surface_crack3d` grows it: c by the
Paris rate of K_I at the K point nearest the face of c (Newman and Raju's angle ψ_c), a
by the rate at the point nearest the face of a (ψ_a), K from Newman and Raju's
corner-crack equation (:func:`~bonecontact.verification.surface_crack.corner_crack_k`,
a/c ≤ 1).  The runner's K points start at max(10°, two and a half front elements) from
each face (:func:`corner_growth_angles` computes where for a front of size h_f).

:func:`newman_raju_corner_growth` integrates dc/da = ċ/ȧ and dN/da = 1/ȧ by RK4 in a:
the reference.  :func:`corner_block_growth` applies the runner's block rule to the same
rates (the faster end advances Δa_max a block, the other in proportion, the advances on
:func:`~bonecontact.common.geometry.on_advance_grid`, the cycles by
:func:`~bonecontact.fracture.fatigue.block_cycles` over the block ends known so far): its
distance from the RK4 curve is the error of the blocks alone, without the finite-element K.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from bonecontact.common.errors import ParameterError
from bonecontact.common.geometry import on_advance_grid
from bonecontact.fracture.fatigue import ParisLaw, block_cycles
from bonecontact.verification.surface_crack import corner_crack_k
from bonecontact.verification.surface_fatigue import rk4_in_depth

__all__ = [
    "CornerBlocks",
    "CornerPlate",
    "corner_block_growth",
    "corner_growth_angles",
    "corner_rates",
    "newman_raju_corner_growth",
]

#: The least angle of the runner's corner K points from either face (radians).
LEAST_ANGLE = math.radians(10.0)

#: (a, c) -> (ψ_c, ψ_a): the angles whose K grow c and a (radians).
Angles = Callable[[float, float], tuple[float, float]]


@dataclass(frozen=True)
class CornerPlate:
    """The plate of Newman and Raju's corner crack: remote tension ``S`` (Pa; the peak of
    the cycle), thickness ``t`` (the direction of a) and whole width ``width`` (the
    direction of c) (m)."""

    S: float
    t: float
    width: float

    def __post_init__(self) -> None:
        for key in ("t", "width"):
            v = getattr(self, key)
            if not (math.isfinite(v) and v > 0):
                raise ParameterError(key, f"must be a positive length (m), got {v!r}")


def corner_growth_angles(a: float, c: float, h_front: float, least: float = LEAST_ANGLE):
    """(ψ_c, ψ_a): Newman and Raju's angles of the runner's K points nearest the face of c
    and of a, for a front from ψ = 0 to 90° meshed with elements ``h_front`` (m).

    The runner starts its K points at the margin max(``least``, Δ₀, Δ₁) from both ends, in
    the parameter of the ellipse (the same angle as ψ up to a mirror), Δ₀ and Δ₁ the angles
    from either end along which the front's arc length is 2.5 ``h_front``; so ψ_c is that
    margin and ψ_a = 90° − margin.  The arc length is s(ψ) = ∫ √(c² sin²ψ + a² cos²ψ) dψ,
    here by the trapezoid rule on 4001 points (the runner interpolates it on 2001)."""
    if not (a > 0 and c > 0 and h_front > 0):
        raise ParameterError("h_front", f"need a, c, h_front > 0, got {a!r}, {c!r}, {h_front!r}")
    psi = np.linspace(0.0, 0.5 * math.pi, 4001)
    speed = np.sqrt((c * np.sin(psi)) ** 2 + (a * np.cos(psi)) ** 2)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(psi))])
    ds = 2.5 * h_front
    d0 = float(np.interp(ds, s, psi))
    d1 = 0.5 * math.pi - float(np.interp(s[-1] - ds, s, psi))
    margin = max(least, d0, d1)
    return margin, 0.5 * math.pi - margin


def _angles(psi: Angles | tuple[float, float], a: float, c: float) -> tuple[float, float]:
    return psi(a, c) if callable(psi) else (float(psi[0]), float(psi[1]))


def corner_rates(
    law: ParisLaw, plate: CornerPlate, a: float, c: float, psi: Angles | tuple[float, float]
) -> npt.NDArray[np.float64]:
    """(ċ, ȧ): the Paris rates (m/cycle) of Newman and Raju's K at (ψ_c, ψ_a) (``psi``: the
    two angles, or a function of (a, c) giving them).

    Raises
    ------
    ParameterError
        (key ``a/c``) a/c > 1: Newman and Raju's equation is implemented for a/c ≤ 1.
    """
    k = corner_crack_k(plate.S, a, c, plate.t, plate.width, np.array(_angles(psi, a, c)))
    return law.rate(k)


def newman_raju_corner_growth(
    law: ParisLaw,
    plate: CornerPlate,
    a0: float,
    c0: float,
    a_end: float,
    psi: Angles | tuple[float, float],
    steps: int = 400,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(a, c, N) on ``steps`` + 1 depths from ``a0`` to ``a_end``: dc/da = ċ/ȧ and
    dN/da = 1/ȧ (:func:`corner_rates`) integrated by RK4 in a from c = ``c0``, N = 0."""
    if not (a_end > a0 > 0 and c0 > 0):
        raise ParameterError("a_end", f"need a_end > a0 > 0 and c0 > 0, got {a_end!r}, {a0!r}")

    def f(a: float, y: np.ndarray) -> np.ndarray:
        rc, ra = corner_rates(law, plate, a, float(y[0]), psi)
        if ra <= 0:
            raise ParameterError("delta_K_th", f"the face of a does not grow at a = {a:.6g} m")
        return np.array([rc / ra, 1.0 / ra])

    return rk4_in_depth(f, a0, a_end, c0, steps)


@dataclass
class CornerBlocks:
    """The block ends of :func:`corner_block_growth` (entry 0: the start): ``a``, ``c``
    (m), the cumulative ``cycles`` and the rates (ċ, ȧ) there."""

    a: list[float] = field(default_factory=list)
    c: list[float] = field(default_factory=list)
    cycles: list[float] = field(default_factory=list)
    rates: list[npt.NDArray[np.float64]] = field(default_factory=list)


def corner_block_growth(
    law: ParisLaw,
    plate: CornerPlate,
    a0: float,
    c0: float,
    da_max: float,
    blocks: int,
    psi: Angles | tuple[float, float],
) -> CornerBlocks:
    """The runner's block rule with Newman and Raju's rates: each block the faster end
    grows by ``da_max`` and the other by ``da_max`` times its rate over the faster one
    (both rounded by :func:`~bonecontact.common.geometry.on_advance_grid`), ``blocks``
    blocks; the cumulative cycles at a block end are those of the block before plus
    :func:`~bonecontact.fracture.fatigue.block_cycles`' last block over the ends known so
    far (as :class:`~bonecontact.runners.crack_fatigue.FatigueProgress` counts them)."""
    if not (da_max > 0):
        raise ParameterError("da_max", f"must be > 0, got {da_max!r}")
    out = CornerBlocks()
    a, c, lead = a0, c0, []
    for k in range(blocks + 1):
        r = corner_rates(law, plate, a, c, psi)
        lead.append(float(r.max()))
        n = 0.0 if k == 0 else float(block_cycles(da_max * np.arange(k + 1), lead)[-1])
        out.a.append(a)
        out.c.append(c)
        out.rates.append(r)
        out.cycles.append((out.cycles[-1] if out.cycles else 0.0) + n)
        if k == blocks:
            break
        dc, da = on_advance_grid(da_max * r / r.max(), da_max)
        a, c = float(a + da), float(c + dc)
    return out
