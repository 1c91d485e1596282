"""Fatigue crack growth by the Paris law, integrated over blocks of load cycles
(docs/theory/fracture.md#fatigue).

A block of cycles ΔN is chosen so that the tip growing fastest advances by a prescribed
Δa_max; every tip advances by its own da/dN·ΔN (rates at the start of the block) in the
direction of the maximum tangential stress, and the body is re-meshed and solved again.
The cycle count is not the explicit ΔN of the block: once the rate at the end of the
block is known (it is needed for the next block anyway), the cycles of the block are the
integral of ds / (da/dN)_max over the block with ln(da/dN)_max interpolated by the
cubic through the four nearest block ends (fewer while fewer exist: the counts of the
last blocks are revised as the run goes on), integrated by 8-point Gauss–Legendre.  The
rule is exact for a rate that varies exponentially with the growth and converges with
order about 3 otherwise (tests/unit/fracture/test_fatigue.py).

The loading is cyclic at constant amplitude: the solve gives the state at the peak load
(K_max); the load ratio R = K_min/K_max sets ΔK.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.crack import Crack2D
from bonecontact.fracture.criteria import mts_angle, mts_equivalent_k
from bonecontact.fracture.meshing import Hole, TipMesh, mesh_cracked_body
from bonecontact.fracture.propagation import PropagationOptions, Solver, domain_radius
from bonecontact.fracture.sif import interaction_integral
from bonecontact.fracture.williams import PlaneState
from bonecontact.materials.laws import Isotropic

__all__ = [
    "K_UNITS",
    "LENGTH_UNITS",
    "CrackFatigueBody",
    "FatigueBody",
    "FatigueResult",
    "ParisLaw",
    "block_cycles",
    "grow_by_fatigue",
    "paris_coefficient_si",
]

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(8)


def _positive(key: str, value: float) -> None:
    if not (math.isfinite(value) and value > 0):
        raise ParameterError(key, f"must be a positive number, got {value!r}")


#: Units in which published ΔK are given, in Pa·√m (MN·m^-3/2 = MPa·√m).
K_UNITS: dict[str, float] = {
    "Pa*m^0.5": 1.0,
    "MPa*m^0.5": 1.0e6,
    "MPa*mm^0.5": 1.0e6 * math.sqrt(1.0e-3),
    "ksi*in^0.5": 6.894757293168361e6 * math.sqrt(0.0254),
}
#: Units in which published crack growth per cycle is given, in m.
LENGTH_UNITS: dict[str, float] = {"m": 1.0, "mm": 1.0e-3, "um": 1.0e-6, "in": 0.0254}


def paris_coefficient_si(
    C: float, m: float, k_unit: str = "MPa*m^0.5", length_unit: str = "m"
) -> float:
    """The Paris coefficient in SI units ((m/cycle)/(Pa·√m)^m) of a published law.

    A law da/dN = C ΔK^m with da in ``length_unit`` per cycle and ΔK in ``k_unit``
    gives the same rates as C_SI ΔK_SI^m with C_SI = C · L / K^m, L and K the two units
    in m and Pa·√m: ΔK in MPa·√m multiplies C by 10^(-6m)
    (docs/theory/fracture.md#material-constants-of-cortical-bone).

    Parameters
    ----------
    C, m
        The published coefficient and exponent.
    k_unit
        A key of :data:`K_UNITS`.
    length_unit
        A key of :data:`LENGTH_UNITS`.

    Raises
    ------
    ParameterError
        For an unknown unit or a C or m that is not a positive number.
    """
    _positive("C", C)
    _positive("m", m)
    if k_unit not in K_UNITS:
        raise ParameterError("k_unit", f"must be one of {sorted(K_UNITS)}, got {k_unit!r}")
    if length_unit not in LENGTH_UNITS:
        raise ParameterError(
            "length_unit", f"must be one of {sorted(LENGTH_UNITS)}, got {length_unit!r}"
        )
    return C * LENGTH_UNITS[length_unit] / K_UNITS[k_unit] ** m


@dataclass(frozen=True)
class ParisLaw:
    """da/dN = C (ΔK)^m for ΔK > ΔK_th, else 0.

    Parameters
    ----------
    C
        Coefficient in (m/cycle)/(Pa·√m)^m.
    m
        Exponent (dimensionless).
    delta_K_th
        Threshold range ΔK_th (Pa·√m); no growth at or below it.
    R
        Load ratio K_min/K_max of the cycle, −∞ < R < 1.  For R ≥ 0, ΔK = (1 − R) K_max;
        for R < 0 the compressive part of the cycle closes the crack and does not drive
        it: ΔK = K_max (the convention of ASTM E647).
    """

    C: float
    m: float
    delta_K_th: float = 0.0
    R: float = 0.0

    def __post_init__(self) -> None:
        _positive("C", self.C)
        _positive("m", self.m)
        if not (math.isfinite(self.delta_K_th) and self.delta_K_th >= 0):
            raise ParameterError("delta_K_th", f"must be >= 0, got {self.delta_K_th!r}")
        if not (math.isfinite(self.R) and self.R < 1):
            raise ParameterError("R", f"the load ratio must be a number < 1, got {self.R!r}")

    def delta_k(self, k_max: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """ΔK of a cycle with peak ``k_max`` (negative peaks: 0)."""
        k = np.maximum(np.asarray(k_max, dtype=float), 0.0)
        return (1.0 - self.R) * k if self.R >= 0 else k

    def rate(self, k_max: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """da/dN (m/cycle) for the peak K ``k_max`` (array or scalar)."""
        dk = self.delta_k(k_max)
        return np.where(dk > self.delta_K_th, self.C * dk**self.m, 0.0)


class FatigueBody(Protocol):
    """A cracked body seen by :func:`grow_by_fatigue`."""

    def k_max(self) -> npt.NDArray[np.float64]:
        """Equivalent peak K (Pa·√m) at every tip of the current crack."""
        ...

    def grow(self, advances: npt.NDArray[np.float64]) -> None:
        """Advance every tip by its length (m; 0 leaves the tip where it is)."""
        ...


@dataclass
class FatigueResult:
    """The history of a fatigue run, one entry per block end (entry 0: the start).

    ``growth`` is the growth s of the leading tip summed over the blocks (m), ``k_max``
    and ``rates`` the per-tip peak K and da/dN at each block end, ``status``
    ``"grown"`` (the prescribed growth reached), ``"arrested"`` (every ΔK at or below
    the threshold) or ``"max_blocks"``.
    """

    growth: list[float] = field(default_factory=list)
    k_max: list[npt.NDArray[np.float64]] = field(default_factory=list)
    rates: list[npt.NDArray[np.float64]] = field(default_factory=list)
    status: str = "max_blocks"

    @property
    def cycles(self) -> npt.NDArray[np.float64]:
        """Cumulative cycles N at every block end (N[0] = 0)."""
        lead = np.array([float(r.max()) for r in self.rates])
        per_block = block_cycles(np.asarray(self.growth), lead)
        return np.concatenate([[0.0], np.cumsum(per_block)])


def _block_integral(s: np.ndarray, log_r: np.ndarray, i: int) -> float:
    """∫ ds / r(s) over block i, ln r interpolated through the (up to) 4 nearest ends; on a
    block where that cubic leaves the range of the ends it passes through (a sharp extremum
    of the rate, which it would overshoot), the line through the block's two ends."""
    npts = min(len(s), 4)
    lo = min(max(i - 1, 0), len(s) - npts)
    idx = list(range(lo, lo + npts))
    coef = np.polyfit(s[idx] - s[i], log_r[idx], len(idx) - 1)
    h = s[i + 1] - s[i]
    x = 0.5 * h * (1.0 + _GAUSS_X)
    log_rx = np.polyval(coef, x)
    if _leaves_range(coef, h, log_r[idx]):
        log_rx = log_r[i] + (log_r[i + 1] - log_r[i]) * x / h
    return float(0.5 * h * np.sum(_GAUSS_W * np.exp(-log_rx)))


def _leaves_range(coef: np.ndarray, h: float, values: np.ndarray) -> bool:
    """Whether the polynomial ``coef`` leaves [min, max] of ``values`` on [0, h] (its values
    at 0, h and its stationary points inside; slack 1e-12 of the values' size)."""
    crit = np.roots(np.polyder(coef)) if len(coef) > 2 else np.zeros(0)
    crit = crit.real[(np.abs(crit.imag) < 1e-12 * h) & (crit.real > 0) & (crit.real < h)]
    p = np.polyval(coef, np.concatenate([[0.0, h], crit]))
    lo, hi = float(values.min()), float(values.max())
    slack = 1e-12 * max(1.0, abs(lo), abs(hi))
    return bool(p.min() < lo - slack or p.max() > hi + slack)


def block_cycles(growth: npt.ArrayLike, lead_rate: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Cycles of each block: ∫ ds / (da/dN) between consecutive block ends.

    Parameters
    ----------
    growth
        Growth of the leading tip at the block ends s_0 < s_1 < … (m).
    lead_rate
        da/dN of the leading tip at those ends (m/cycle), all > 0.

    Returns
    -------
    numpy.ndarray
        One entry per block (``len(growth) - 1``).
    """
    s = np.asarray(growth, dtype=float)
    r = np.asarray(lead_rate, dtype=float)
    if s.size < 2:
        return np.zeros(0)
    if np.any(r <= 0):
        raise ParameterError("rate", "the leading tip's da/dN must be positive at every block end")
    log_r = np.log(r)
    return np.array([_block_integral(s, log_r, i) for i in range(s.size - 1)])


def _check_growth(da_max: float, total: float, max_blocks: int) -> None:
    _positive("da_max", da_max)
    _positive("total_growth", total)
    if int(max_blocks) != max_blocks or max_blocks < 1:
        raise ParameterError("max_blocks", f"must be a positive integer, got {max_blocks!r}")


def grow_by_fatigue(
    body: FatigueBody,
    law: ParisLaw,
    da_max: float,
    total_growth: float,
    max_blocks: int = 1000,
) -> FatigueResult:
    """Grow the crack of ``body`` by blocks of cycles until the leading tip has grown by
    ``total_growth`` (the last block is shortened to land on it).

    Parameters
    ----------
    body
        The cracked body (:class:`FatigueBody`).
    law
        :class:`ParisLaw`.
    da_max
        Growth of the fastest tip per block (m).
    total_growth
        Growth of the leading tip at which the run stops (m).
    max_blocks
        Upper bound on the number of blocks.

    Returns
    -------
    FatigueResult
        With the cycle count :attr:`FatigueResult.cycles`.
    """
    _check_growth(da_max, total_growth, max_blocks)
    result = FatigueResult()
    s = 0.0
    k = np.asarray(body.k_max(), dtype=float)
    for _ in range(max_blocks + 1):
        rate = law.rate(k)
        result.growth.append(s)
        result.k_max.append(k)
        result.rates.append(rate)
        if s >= total_growth * (1.0 - 1e-12):
            result.status = "grown"
            break
        if len(result.growth) > max_blocks or float(rate.max()) <= 0.0:
            result.status = "arrested" if float(rate.max()) <= 0.0 else "max_blocks"
            break
        ds = min(da_max, total_growth - s)
        body.grow(rate * (ds / float(rate.max())))
        s += ds
        k = np.asarray(body.k_max(), dtype=float)
    return result


@dataclass
class CrackFatigueBody:
    """A 2D cracked body re-meshed and solved at every block end (:class:`FatigueBody`).

    ``k_max`` meshes the body around ``crack``, solves it at the peak load, evaluates K_I
    and K_II at every tip by the interaction integral and returns the MTS equivalent K;
    ``grow`` extends every tip along its MTS kink angle.  ``da_max`` bounds the domain
    radius of the interaction integral as in :func:`~bonecontact.fracture.propagation.propagate`
    (r_out ≤ 2·da_max, 0.8 × the last segment and the distance to the free surface).
    """

    outline: npt.NDArray[np.float64]
    crack: Crack2D
    solve: Solver
    material: Isotropic
    tip_mesh: TipMesh
    da_max: float
    plane: PlaneState = "strain"
    comm: MPI.Comm = field(default_factory=lambda: MPI.COMM_WORLD)
    holes: Sequence[Hole] = ()
    angles: npt.NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    def k_max(self) -> npt.NDArray[np.float64]:
        poly = np.asarray(self.outline, dtype=float)
        opts = PropagationOptions(self.da_max, self.tip_mesh, plane=self.plane)
        cm = mesh_cracked_body(poly, self.crack, self.tip_mesh, self.comm, self.holes)
        _model, u, *face = self.solve(cm)
        k_eq, angles = [], []
        for end in self.crack.tip_ends:
            r_out = domain_radius(self.crack, end, poly, self.holes, opts)
            k = interaction_integral(
                u, cm, end, self.material, r_out, plane=self.plane,
                face_traction=face[0] if face else None,
            )  # fmt: skip
            angles.append(mts_angle(k.K_I, k.K_II))
            k_eq.append(mts_equivalent_k(k.K_I, k.K_II, angles[-1]))
        self.angles = np.array(angles)
        return np.array(k_eq)

    def grow(self, advances: npt.NDArray[np.float64]) -> None:
        crack = self.crack
        for end, da, theta in zip(self.crack.tip_ends, advances, self.angles, strict=True):
            if da > 0:
                crack = crack.extended(end, float(da), float(theta))
        self.crack = crack
