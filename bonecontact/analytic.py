"""Closed-form reference solutions used by the tests and benchmarks (SI units).

Hertz contact (K. L. Johnson, *Contact Mechanics*, Cambridge 1985, §4.2–4.3):

* plane strain, two cylinders (or a cylinder on a half-space) with load P per unit
  thickness: a = √(4PR/(πE*)), p₀ = 2P/(πa), p(x) = p₀ √(1 − x²/a²);
* 3D, a sphere on a half-space with load P: a = (3PR/(4E*))^(1/3), p₀ = 3P/(2πa²),
  p(r) = p₀ √(1 − r²/a²);

with the contact modulus 1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂ and R the (relative)
radius of curvature.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

__all__ = ["contact_modulus", "hertz_2d", "hertz_3d"]


def contact_modulus(E1: float, nu1: float, E2: float = np.inf, nu2: float = 0.0) -> float:
    """E* with 1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂ (E₂ = inf: rigid counterpart)."""
    return 1.0 / ((1.0 - nu1**2) / E1 + (0.0 if np.isinf(E2) else (1.0 - nu2**2) / E2))


def _h2_half_width(P, R, E1, nu1, E2=np.inf, nu2=0.0):
    return float(np.sqrt(4.0 * P * R / (np.pi * contact_modulus(E1, nu1, E2, nu2))))


def _h2_peak(P, R, E1, nu1, E2=np.inf, nu2=0.0):
    return 2.0 * P / (np.pi * _h2_half_width(P, R, E1, nu1, E2, nu2))


def _h2_pressure(x, P, R, E1, nu1, E2=np.inf, nu2=0.0):
    a = _h2_half_width(P, R, E1, nu1, E2, nu2)
    return _h2_peak(P, R, E1, nu1, E2, nu2) * np.sqrt(np.clip(1.0 - np.asarray(x) ** 2 / a**2, 0.0, None))


def _h2_load(a, R, E1, nu1, E2=np.inf, nu2=0.0):
    return np.pi * a**2 * contact_modulus(E1, nu1, E2, nu2) / (4.0 * R)


def _h3_radius(P, R, E1, nu1, E2=np.inf, nu2=0.0):
    return float((3.0 * P * R / (4.0 * contact_modulus(E1, nu1, E2, nu2))) ** (1.0 / 3.0))


def _h3_peak(P, R, E1, nu1, E2=np.inf, nu2=0.0):
    return 3.0 * P / (2.0 * np.pi * _h3_radius(P, R, E1, nu1, E2, nu2) ** 2)


def _h3_pressure(r, P, R, E1, nu1, E2=np.inf, nu2=0.0):
    a = _h3_radius(P, R, E1, nu1, E2, nu2)
    return _h3_peak(P, R, E1, nu1, E2, nu2) * np.sqrt(np.clip(1.0 - np.asarray(r) ** 2 / a**2, 0.0, None))


def _h3_load(a, R, E1, nu1, E2=np.inf, nu2=0.0):
    return 4.0 * contact_modulus(E1, nu1, E2, nu2) * a**3 / (3.0 * R)


#: Plane-strain cylinder contact: ``half_width``, ``peak_pressure``, ``pressure(x, ...)``,
#: ``load_for_half_width(a, ...)``; arguments ``(P, R, E1, nu1, E2=inf, nu2=0)``.
hertz_2d = SimpleNamespace(half_width=_h2_half_width, peak_pressure=_h2_peak, pressure=_h2_pressure,
                           load_for_half_width=_h2_load)
#: Sphere on a half-space: ``radius``, ``peak_pressure``, ``pressure(r, ...)``, ``load_for_radius(a, ...)``.
hertz_3d = SimpleNamespace(radius=_h3_radius, peak_pressure=_h3_peak, pressure=_h3_pressure,
                           load_for_radius=_h3_load)
