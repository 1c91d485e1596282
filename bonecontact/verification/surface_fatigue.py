"""A semi-elliptical surface crack grown through the thickness of a plate by fatigue
(docs/theory/fracture.md#fatigue-of-a-surface-crack-in-3d).

The plate of :mod:`bonecontact.verification.surface_crack` under cyclic tension; the crack
keeps its semi-elliptical shape and grows by two degrees of freedom, as in Newman and
Raju's own growth computations: the depth a by the Paris rate of K_I at the deepest point
(φ = 90°) and the half-length c by the rate at the point φ_s near the free surface
(default 20°: K is refused within two front elements of the surface).  Each block of
cycles re-meshes the plate with the crack (a, c), solves, and advances the faster point by
Δa_max, the other in proportion to its rate; the cycles of a block are
:func:`~bonecontact.fracture.fatigue.block_cycles` of the leading rate (the Paris law
and the block integral are helper F's :mod:`bonecontact.fracture.fatigue`).  The run stops
when the ligament t − a left under the deepest point is too thin for the mesh (r_out +
2 h_front): the front has reached the back face (``status = "through"``), and the last
stretch is counted at the last deepest-point rate.

:func:`newman_raju_growth` integrates the same two equations with Newman–Raju's K
(RK4 in a): the reference of the cycle count.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from bonecontact.common.errors import ParameterError
from bonecontact.common.geometry import on_advance_grid
from bonecontact.fracture.fatigue import ParisLaw, block_cycles
from bonecontact.fracture.surface3d import SurfaceCrack
from bonecontact.verification.surface_crack import PlateProblem, solve_plate, surface_crack_k

__all__ = [
    "SurfaceFatigue",
    "front_k",
    "grow_surface_crack",
    "newman_raju_growth",
    "newman_raju_k",
    "rk4_in_depth",
]


@dataclass
class SurfaceFatigue:
    """The history of a run, one entry per block end (entry 0: the start): depth ``a``
    and half-length ``c`` (m), ``k`` = (K_I deepest, K_I at φ_s) (Pa·√m), ``growth`` (the
    leading point's growth summed), ``dofs``; ``status`` ``"through"`` or ``"max_blocks"``
    and ``final_cycles`` (to the back face when through)."""

    a: list[float] = field(default_factory=list)
    c: list[float] = field(default_factory=list)
    k: list[npt.NDArray[np.float64]] = field(default_factory=list)
    growth: list[float] = field(default_factory=list)
    dofs: list[int] = field(default_factory=list)
    status: str = "max_blocks"
    final_cycles: float = math.nan
    law: ParisLaw | None = None

    @property
    def cycles(self) -> npt.NDArray[np.float64]:
        """Cumulative cycles N at every block end (N[0] = 0)."""
        lead = np.array([float(self.law.rate(k).max()) for k in self.k])
        return np.concatenate([[0.0], np.cumsum(block_cycles(self.growth, lead))])


def front_k(problem: PlateProblem, phi_s: float, comm: MPI.Comm) -> tuple[np.ndarray, int]:
    """(K_I at the deepest point, K_I at φ_s) of the plate solved by finite elements, and
    its dofs (collective)."""
    sol = solve_plate(problem, comm)
    k = np.array([sol.k(0.5 * math.pi).K_I, sol.k(phi_s).K_I])
    return k, sol.dofs


def newman_raju_k(problem: PlateProblem, phi_s: float, comm: MPI.Comm) -> tuple[np.ndarray, int]:
    """The same two K by Newman–Raju's equation (no solve; 0 dofs): to check the block
    integration against :func:`newman_raju_growth`."""
    c = problem.crack
    phi = np.array([0.5 * math.pi, phi_s])
    return surface_crack_k(problem.S, c.depth, c.half_length, problem.t, problem.b, phi), 0


def _check(problem: PlateProblem, da_max: float, phi_s: float) -> None:
    if problem.crack.kind != "semi_elliptical":
        raise ParameterError("kind", f'needs a "semi_elliptical" crack, got {problem.crack.kind!r}')
    if not (0 < da_max < problem.t):
        raise ParameterError("da_max", f"must be in (0, t = {problem.t}), got {da_max!r}")
    if not (0 < phi_s < 0.5 * math.pi):
        raise ParameterError("phi_s", f"must be in (0, π/2), got {phi_s!r}")


def grow_surface_crack(
    problem: PlateProblem,
    law: ParisLaw,
    da_max: float,
    max_blocks: int = 20,
    phi_s: float = math.radians(20.0),
    comm: MPI.Comm | None = None,
    k_of: Callable[[PlateProblem, float, MPI.Comm], tuple[np.ndarray, int]] = front_k,
) -> SurfaceFatigue:
    """Grow the semi-elliptical crack of ``problem`` (its ``S`` the peak tension) by
    blocks of cycles until it reaches the back face or ``max_blocks`` blocks (collective).
    ``problem.r_out`` must be set (the domain radius stays fixed as the crack grows).
    ``k_of``: the two K of a plate (:func:`front_k`, or :func:`newman_raju_k`)."""
    comm = MPI.COMM_WORLD if comm is None else comm
    _check(problem, da_max, phi_s)
    if problem.r_out is None:
        raise ParameterError("r_out", "set the domain radius (it stays fixed while growing)")
    rec = SurfaceFatigue(law=law)
    a, c, s = problem.crack.depth, problem.crack.half_length, 0.0
    ligament = problem.r_out + 2 * problem.h_front
    for _ in range(max_blocks + 1):
        p = replace(problem, crack=SurfaceCrack("semi_elliptical", a, c))
        k, dofs = k_of(p, phi_s, comm)
        rate = law.rate(k)
        for name, value in (("a", a), ("c", c), ("k", k), ("growth", s), ("dofs", dofs)):
            getattr(rec, name).append(value)
        if problem.t - a <= ligament + 1e-12 * problem.t:
            rec.status = "through"
            rec.final_cycles = float(rec.cycles[-1] + (problem.t - a) / rate[0])
            break
        if len(rec.a) > max_blocks or float(rate.max()) <= 0:
            break
        ds = da_max
        land = a + ds * rate[0] / rate.max() > problem.t - ligament  # on the thin ligament
        if land:
            ds = (problem.t - ligament - a) * rate.max() / rate[0]
        da, dc = on_advance_grid(ds * rate / rate.max(), da_max)
        a_new = float(problem.t - ligament) if land else float(a + da)
        c = max(float(c + dc), a_new)  # a/c <= 1 (Newman-Raju's range)
        a, s = a_new, float(s + ds)
    return rec


def _nr_rates(law: ParisLaw, S: float, a: float, c: float, t: float, b: float, phi_s: float):
    k = surface_crack_k(S, a, max(c, a), t, b, np.array([0.5 * math.pi, phi_s]))
    return law.rate(k)


def newman_raju_growth(
    law: ParisLaw,
    S: float,
    a0: float,
    c0: float,
    t: float,
    b: float,
    a_end: float,
    phi_s: float = math.radians(20.0),
    steps: int = 400,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(a, c, N): dc/da = ċ/ȧ and dN/da = 1/ȧ with the Paris rates of Newman–Raju's K at
    the deepest point (ȧ) and at φ_s (ċ), integrated by RK4 in a from a0 to ``a_end``."""

    def f(a: float, y: np.ndarray) -> np.ndarray:
        ra, rc = _nr_rates(law, S, a, y[0], t, b, phi_s)
        return np.array([rc / ra, 1.0 / ra])

    return rk4_in_depth(f, a0, a_end, c0, steps)


def rk4_in_depth(
    f: Callable[[float, np.ndarray], np.ndarray], a0: float, a_end: float, c0: float, steps: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(a, c, N) of ``(c, N)′ = f(a, (c, N))`` from ``(c0, 0)`` by classical RK4 on
    ``steps`` equal steps in a from ``a0`` to ``a_end`` (the growth of a surface or
    corner crack with a as the variable: f = (ċ/ȧ, 1/ȧ))."""
    a_grid = np.linspace(a0, a_end, steps + 1)
    h = a_grid[1] - a_grid[0]
    y = np.array([c0, 0.0])
    out = [y.copy()]
    for a in a_grid[:-1]:
        k1 = f(a, y)
        k2 = f(a + h / 2, y + h / 2 * k1)
        k3 = f(a + h / 2, y + h / 2 * k2)
        k4 = f(a + h, y + h * k3)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(y.copy())
    arr = np.asarray(out)
    return a_grid, arr[:, 0], arr[:, 1]
