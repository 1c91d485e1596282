"""Osmotic growth of an odontogenic cyst in a Maxwell visco-elastic surrounding: the closed
ODE of a sphere (3D) or of a cylinder per unit length (2D).

Model, closed ODE and its limits: docs/theory/growth.md#cyst-model,
docs/theory/growth.md#closed-cyst-ode and docs/theory/verification.md#cyst-limits.
Units SI: R in m, t in s, f in Pa, β in mol m⁻² s⁻¹, C⁻ in mol m⁻³, T in K, ν in Pa s,
E in Pa.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.integrate import solve_ivp

from bonecontact.common.constants import R_GAS
from bonecontact.common.errors import ParameterError

__all__ = [
    "CystHistory",
    "CystParameterError",
    "CystParameters",
    "equilibrium_radius",
    "grow_sphere",
    "long_time_rate",
    "radius_rate",
]


#: Deprecated alias of :class:`~bonecontact.common.errors.ParameterError` (the one type of
#: a parameter out of range); ``str(error)`` reads ``cyst parameter <key> <message>``.
CystParameterError = ParameterError


def _parameter_error(key: str, message: str) -> ParameterError:
    """A cyst parameter outside its allowed range (``message``: what is allowed)."""
    return ParameterError(key, message, where=f"cyst parameter {key} ")


@dataclass(frozen=True)
class CystParameters:
    """Parameters of the osmotic cyst model (keys of ``[neoplasm.cyst]``).

    Attributes
    ----------
    beta
        Supply rate of osmotic material per lining area (mol m⁻² s⁻¹), ≥ 0.
    C_minus
        Osmolarity outside the cyst (mol m⁻³), > 0.
    temperature
        Absolute temperature (K), > 0.
    E
        Elastic modulus of the surrounding tissue (Pa), > 0 (``inf``: viscous limit).
    viscosity
        Viscosity of the surrounding tissue (Pa s), > 0.
    f0
        Initial osmotic excess pressure P_h⁺ − P_h⁻ (Pa).
    strain
        ``"log"`` or ``"engineering"``.
    """

    beta: float
    C_minus: float
    temperature: float = 310.0
    E: float = 1.0e6
    viscosity: float = 1.0e9
    f0: float = 0.0
    strain: Literal["log", "engineering"] = "log"

    #: Allowed values of ``strain``.
    STRAINS = ("log", "engineering")
    #: Fields that must be >= 0 / > 0 (all finite except ``E``, which may be ``inf``).
    NONNEGATIVE = ("beta",)
    POSITIVE = ("C_minus", "temperature", "E", "viscosity")

    def __post_init__(self) -> None:
        """Check the parameters (raises a :class:`ParameterError` naming the first bad one)."""
        if self.strain not in self.STRAINS:
            choices = ", ".join(f'"{s}"' for s in self.STRAINS)
            raise _parameter_error("strain", f"must be one of {choices}, got {self.strain!r}")
        for key in self.NONNEGATIVE + self.POSITIVE:
            value = getattr(self, key)
            if key != "E" and not np.isfinite(value):
                raise _parameter_error(key, f"must be a finite number, got {value!r}")
            if key in self.NONNEGATIVE and not value >= 0:
                raise _parameter_error(key, f"must be >= 0, got {value!r}")
            if key in self.POSITIVE and not value > 0:
                raise _parameter_error(key, f"must be > 0, got {value!r}")
        if not np.isfinite(self.f0):
            raise _parameter_error("f0", f"must be a finite number, got {self.f0!r}")
        f_min = -self.alpha * self.C_minus
        if self.f0 <= f_min:
            raise _parameter_error(
                "f0",
                f"must be > -R_g T C_minus = {f_min:.6g} Pa "
                f"(the osmolarity inside the cyst must stay positive), got {self.f0!r}",
            )

    @property
    def alpha(self) -> float:
        """α = R_g T (J mol⁻¹)."""
        return R_GAS * self.temperature

    @property
    def tau(self) -> float:
        """Maxwell relaxation time τ = ν/E (s); 0 in the viscous limit E = ∞."""
        return 0.0 if np.isinf(self.E) else self.viscosity / self.E


@dataclass
class CystHistory:
    """Radius and osmotic excess pressure over time (SI)."""

    t: np.ndarray
    R: np.ndarray
    f: np.ndarray
    dim: int

    @property
    def volume(self) -> np.ndarray:
        """Volume (3D, m³) or area per unit length (2D, m²)."""
        return 4.0 / 3.0 * np.pi * self.R**3 if self.dim == 3 else np.pi * self.R**2

    @property
    def surface_area(self) -> np.ndarray:
        """Lining area (3D, m²) or perimeter (2D, m)."""
        return 4.0 * np.pi * self.R**2 if self.dim == 3 else 2.0 * np.pi * self.R


def radius_rate(
    p: CystParameters, R0: float, d: int
) -> Callable[[float, Sequence[float]], list[float]]:
    """Right-hand side of the closed cyst ODE in (R, f), for :func:`scipy.integrate.solve_ivp`.

    Parameters
    ----------
    p
        Model parameters.
    R0
        Initial radius (m); the reference radius of engineering strain.
    d
        3 (sphere) or 2 (cylinder, per unit length).

    Returns
    -------
    callable
        ``rate(t, [R, f]) -> [dR/dt, df/dt]`` (docs/theory/growth.md#closed-cyst-ode).
    """
    a, C, b, nu, tau = p.alpha, p.C_minus, p.beta, p.viscosity, p.tau

    def rhs(t: float, y: Sequence[float]) -> list[float]:
        R, f = y
        visc = nu * (R / R0 if p.strain == "engineering" else 1.0)
        dR = (R * f + d * tau * a * b) / (visc + d * tau * (a * C + f))
        df = (d / R) * (a * b - (a * C + f) * dR)
        return [dR, df]

    return rhs


def grow_sphere(
    p: CystParameters,
    R0: float,
    t_end: float,
    t_eval: np.ndarray | None = None,
    *,
    dim: int = 3,
    rtol: float = 1e-11,
) -> CystHistory:
    """Integrate the closed cyst model from radius ``R0`` (m) over ``[0, t_end]`` (s).

    Parameters
    ----------
    p
        Model parameters.
    R0
        Initial radius (m).
    t_end
        Final time (s).
    t_eval
        Output times (default: 201 equally spaced).
    dim
        3 (sphere) or 2 (cylinder, per unit length).
    rtol
        Relative tolerance of the stiff integrator (Radau).
    """
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim}")
    if not (R0 > 0 and t_end > 0):
        raise ValueError("R0 and t_end must be > 0")
    t_eval = np.linspace(0.0, t_end, 201) if t_eval is None else np.asarray(t_eval, float)
    # f scale for the absolute tolerance: the osmotic pressure scale αC⁻
    sol = solve_ivp(
        radius_rate(p, R0, dim),
        (0.0, t_end),
        [R0, p.f0],
        method="Radau",
        t_eval=t_eval,
        rtol=rtol,
        atol=[1e-14 * R0, 1e-12 * max(p.alpha * p.C_minus, abs(p.f0), 1.0)],
    )
    if not sol.success:
        raise RuntimeError(f"cyst ODE integration failed: {sol.message}")
    return CystHistory(sol.t, sol.y[0], sol.y[1], dim)


def equilibrium_radius(p: CystParameters, R0: float, dim: int = 3) -> float:
    """β = 0: the radius at which the initial osmotic excess is spent,
    R₀ (1 + f₀/(αC⁻))^{1/d} (the solute content s is conserved and C⁺ → C⁻)."""
    return R0 * (1.0 + p.f0 / (p.alpha * p.C_minus)) ** (1.0 / dim)


def long_time_rate(p: CystParameters, R0: float, dim: int = 3) -> float:
    """Long-time growth rate dR/dt (m/s), the same for d = 2 and 3.

    Logarithmic strain: β/C⁻ (f → 0: supply and dilution balance).  Engineering strain:
    f* R₀/ν, where the steady excess pressure solves f (αC⁻ + f) = αβν/R₀, i.e.
    f* = [−αC⁻ + √((αC⁻)² + 4αβν/R₀)]/2.
    """
    if p.strain == "log":
        return p.beta / p.C_minus
    aC = p.alpha * p.C_minus
    # steady f with dR/dt = f R0/ν (τ terms vanish as R grows): d/R[αβ − (αC⁻+f) f R0/ν] → 0
    # gives (αC⁻ + f) f = αβν/R0 independent of d.
    fstar = 0.5 * (-aC + np.sqrt(aC**2 + 4.0 * p.alpha * p.beta * p.viscosity / R0))
    return fstar * R0 / p.viscosity
