"""K_I of a nearly circular planar crack under uniform tension σ normal to it, to first order
in the front's deviation from a circle (Rice's front perturbation of a planar crack, J.
Appl. Mech. 52, 1985; its penny-crack form, Gao & Rice, Int. J. Fracture 33, 1987):

    K(θ₀) / K₀(a₀) = 1 + δa(θ₀)/(2a₀) + (1/(8πa₀)) PV∫ [δa(θ) − δa(θ₀)] / sin²((θ − θ₀)/2) dθ,

the front at polar angle θ at radius a₀ + δa(θ), K₀(a₀) = 2σ√(a₀/π) (Sneddon). Taking a₀
= the front's radius at θ₀ makes the first term vanish and the integral regular. A mode
δa = εa₀ cos nθ gives δK/K₀ = ε(1 − n)/2 cos nθ (n = 0: √a; n = 1: a translation, 0;
large n: the half-plane crack's −|k|δa/2). Checked against Irwin's ellipse (b/a = 0.95:
within 0.02 %; 0.9: 0.09 %, the second order).

At the middle of a side of a regular n-gon (inradius a₀) about the inscribed penny, δa
≈ a₀u²/2 on the side at angle u from the middle; summed over the sides
(Σ_k (2k + v)⁻² = (π/2)²/sin²(πv/2), ∫₀^{π/2} w²/sin²w dw = π ln 2) K_I exceeds the
inscribed penny's by ln 2/n + O(n⁻²) (n = 24: +2.90 %, +2.75 % over the equal-area
penny): the straight sides lack the circle's curvature. The inscribed, equal-area and
circumscribed pennies differ by O(n⁻²) only (docs/theory/fracture.md, polygonal cracks).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.integrate import quad


def first_order_k_ratio(radius: Callable[[float], float], theta0: float) -> float:
    """K_I(θ₀) over Sneddon's K of the penny of radius ``radius(θ₀)``, to first order in
    the front's deviation ``radius(θ) − radius(θ₀)`` (the module's formula; the front
    star-shaped about the origin, ``radius`` 2π-periodic, continuous, smooth near θ₀)."""
    a0 = radius(theta0)

    def integrand(t: float) -> float:
        s = math.sin(0.5 * t)
        if abs(s) < 1e-7:  # δa ≈ a0-curvature term × t²/2: finite, of measure zero
            return 0.0
        return (radius(theta0 + t) - a0) / (s * s)

    kinks = _kinks(radius, theta0)
    edges = [-math.pi, *kinks, math.pi]
    total = sum(quad(integrand, lo, hi, limit=200)[0] for lo, hi in zip(edges, edges[1:]))
    return 1.0 + total / (8.0 * math.pi * a0)


def _kinks(radius: Callable[[float], float], theta0: float) -> list[float]:
    """The polygon corners of a :func:`polygon_radius` relative to θ₀ in (−π, π), else
    none."""
    n = getattr(radius, "sides", 0)
    if not n:
        return [0.0]
    corners = 2 * math.pi * np.arange(-n, n + 1) / n - theta0
    return sorted({0.0, *[float(c) for c in corners if -math.pi < c < math.pi]})


def polygon_radius(n: int, circumradius: float) -> Callable[[float], float]:
    """r(θ) of the regular n-gon with vertices at θ = 2πk/n (the distance from the centre
    to its boundary along the direction θ); the function carries ``sides = n``."""
    half = math.pi / n
    inradius = circumradius * math.cos(half)

    def r(theta: float) -> float:
        off = theta % (2 * half) - half  # angle from the nearest mid-side
        return inradius / math.cos(off)

    r.sides = n  # type: ignore[attr-defined]
    return r


def polygon_mid_side_k(sigma: float, circumradius: float, n: int) -> float:
    """First-order K_I at the middle of a side of a regular n-gon crack (circumradius
    ``circumradius``, in an infinite body under uniform tension ``sigma`` normal to it)."""
    if n < 3:
        raise ValueError(f"a polygon needs n >= 3 sides, got {n}")
    inradius = circumradius * math.cos(math.pi / n)
    ratio = first_order_k_ratio(polygon_radius(n, circumradius), math.pi / n)
    return 2.0 * sigma * math.sqrt(inradius / math.pi) * ratio
