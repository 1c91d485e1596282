"""Closed-form reference solutions used by the tests, benchmarks and demos (SI units).

Hertz contact of elastic bodies (docs/theory/verification.md#hertz-contact; K. L. Johnson,
*Contact Mechanics*, Cambridge University Press 1985, §4.2–4.3):

* plane strain, a cylinder on a half-space (or two cylinders), load P per unit
  thickness [N/m]: a = √(4PR/(πE*)), p₀ = 2P/(πa), p(x) = p₀ √(1 − x²/a²);
* 3D, a sphere on a half-space, load P [N]: a = (3PR/(4E*))^(1/3), p₀ = 3P/(2πa²),
  p(r) = p₀ √(1 − r²/a²);

with the contact modulus 1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂ and R the relative
radius of curvature (1/R = 1/R₁ + 1/R₂; R for a cylinder/sphere on a flat).

The functions are grouped in two namespaces with the same argument convention
``(P, R, E1, nu1, E2=inf, nu2=0)`` (``E2 = inf``: rigid counterpart)::

    hertz_2d.half_width, hertz_2d.peak_pressure, hertz_2d.pressure(x, ...),
    hertz_2d.load_for_half_width(a, ...)
    hertz_3d.radius, hertz_3d.peak_pressure, hertz_3d.pressure(r, ...),
    hertz_3d.load_for_radius(a, ...)

Hertz's theory assumes a ≪ R and bodies large compared with a (half-spaces); the
finite-size corrections must be kept small by the geometry of a verification model.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import numpy.typing as npt

__all__ = [
    "contact_modulus",
    "cylinder_half_width",
    "cylinder_load",
    "cylinder_peak_pressure",
    "cylinder_pressure",
    "hertz_2d",
    "hertz_3d",
    "sphere_load",
    "sphere_peak_pressure",
    "sphere_pressure",
    "sphere_radius",
]


def contact_modulus(E1: float, nu1: float, E2: float = np.inf, nu2: float = 0.0) -> float:
    """Hertz contact (plane-strain) modulus of two isotropic bodies.

    Parameters
    ----------
    E1, nu1
        Young's modulus [Pa] and Poisson ratio of body 1.
    E2, nu2
        The same for body 2; ``E2 = inf`` is a rigid counterpart.

    Returns
    -------
    float
        E* [Pa] with 1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂ (Johnson 1985, §4.2).
    """
    return 1.0 / ((1.0 - nu1**2) / E1 + (0.0 if np.isinf(E2) else (1.0 - nu2**2) / E2))


def cylinder_half_width(
    P: float, R: float, E1: float, nu1: float, E2: float = np.inf, nu2: float = 0.0
) -> float:
    """Half-width of the plane-strain Hertz contact strip of a cylinder on a flat.

    Parameters
    ----------
    P
        Load per unit thickness [N/m].
    R
        Relative radius of curvature [m].
    E1, nu1, E2, nu2
        Elastic constants of the two bodies (see :func:`contact_modulus`).

    Returns
    -------
    float
        a = √(4PR/(πE*)) [m] (Johnson 1985, §4.3).
    """
    return float(np.sqrt(4.0 * P * R / (np.pi * contact_modulus(E1, nu1, E2, nu2))))


def cylinder_peak_pressure(
    P: float, R: float, E1: float, nu1: float, E2: float = np.inf, nu2: float = 0.0
) -> float:
    """Peak pressure of the plane-strain Hertz contact: p₀ = 2P/(πa) [Pa] (Johnson 1985, §4.3).

    Arguments as in :func:`cylinder_half_width`.
    """
    return 2.0 * P / (np.pi * cylinder_half_width(P, R, E1, nu1, E2, nu2))


def cylinder_pressure(
    x: npt.ArrayLike,
    P: float,
    R: float,
    E1: float,
    nu1: float,
    E2: float = np.inf,
    nu2: float = 0.0,
) -> np.ndarray:
    """Plane-strain Hertz pressure profile p(x) = p₀ √(1 − x²/a²), zero for |x| ≥ a.

    Parameters
    ----------
    x
        Distance(s) from the centre of the contact strip [m].
    P, R, E1, nu1, E2, nu2
        As in :func:`cylinder_half_width`.

    Returns
    -------
    numpy.ndarray
        Contact pressure [Pa] at ``x``.
    """
    a = cylinder_half_width(P, R, E1, nu1, E2, nu2)
    p0 = cylinder_peak_pressure(P, R, E1, nu1, E2, nu2)
    return p0 * np.sqrt(np.clip(1.0 - np.asarray(x, dtype=float) ** 2 / a**2, 0.0, None))


def cylinder_load(
    a: float, R: float, E1: float, nu1: float, E2: float = np.inf, nu2: float = 0.0
) -> float:
    """Load per unit thickness that gives the half-width ``a``: P = πa²E*/(4R) [N/m].

    Inverse of :func:`cylinder_half_width`.
    """
    return np.pi * a**2 * contact_modulus(E1, nu1, E2, nu2) / (4.0 * R)


def sphere_radius(
    P: float, R: float, E1: float, nu1: float, E2: float = np.inf, nu2: float = 0.0
) -> float:
    """Radius of the Hertz contact circle of a sphere on a flat.

    Parameters
    ----------
    P
        Load [N].
    R
        Relative radius of curvature [m].
    E1, nu1, E2, nu2
        Elastic constants of the two bodies (see :func:`contact_modulus`).

    Returns
    -------
    float
        a = (3PR/(4E*))^(1/3) [m] (Johnson 1985, §4.2).
    """
    return float((3.0 * P * R / (4.0 * contact_modulus(E1, nu1, E2, nu2))) ** (1.0 / 3.0))


def sphere_peak_pressure(
    P: float, R: float, E1: float, nu1: float, E2: float = np.inf, nu2: float = 0.0
) -> float:
    """Peak pressure of the sphere-on-flat Hertz contact: p₀ = 3P/(2πa²) [Pa] (Johnson 1985, §4.2).

    Arguments as in :func:`sphere_radius`.
    """
    return 3.0 * P / (2.0 * np.pi * sphere_radius(P, R, E1, nu1, E2, nu2) ** 2)


def sphere_pressure(
    r: npt.ArrayLike,
    P: float,
    R: float,
    E1: float,
    nu1: float,
    E2: float = np.inf,
    nu2: float = 0.0,
) -> np.ndarray:
    """Sphere-on-flat Hertz pressure p(r) = p₀ √(1 − r²/a²), zero for r ≥ a.

    Parameters
    ----------
    r
        Distance(s) from the centre of the contact circle [m].
    P, R, E1, nu1, E2, nu2
        As in :func:`sphere_radius`.

    Returns
    -------
    numpy.ndarray
        Contact pressure [Pa] at ``r``.
    """
    a = sphere_radius(P, R, E1, nu1, E2, nu2)
    p0 = sphere_peak_pressure(P, R, E1, nu1, E2, nu2)
    return p0 * np.sqrt(np.clip(1.0 - np.asarray(r, dtype=float) ** 2 / a**2, 0.0, None))


def sphere_load(
    a: float, R: float, E1: float, nu1: float, E2: float = np.inf, nu2: float = 0.0
) -> float:
    """Load that gives the contact radius ``a``: P = 4E*a³/(3R) [N].

    Inverse of :func:`sphere_radius`.
    """
    return 4.0 * contact_modulus(E1, nu1, E2, nu2) * a**3 / (3.0 * R)


#: Plane-strain cylinder contact (load per unit thickness).
hertz_2d = SimpleNamespace(
    half_width=cylinder_half_width,
    peak_pressure=cylinder_peak_pressure,
    pressure=cylinder_pressure,
    load_for_half_width=cylinder_load,
)
#: Sphere on a half-space.
hertz_3d = SimpleNamespace(
    radius=sphere_radius,
    peak_pressure=sphere_peak_pressure,
    pressure=sphere_pressure,
    load_for_radius=sphere_load,
)
