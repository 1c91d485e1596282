"""Kelvin–Voigt viscous form a⁽¹⁾(u', v) = ∫ c⁽¹⁾ e(u') : e(v) dx (pure UFL).

With a relaxation time τ_v per material, c⁽¹⁾ = τ_v c⁽⁰⁾, so the viscous Voigt
field is ``C_v = τ_v C``.
"""

from __future__ import annotations

import ufl

from .elastic import elastic_form


def viscous_form(w, v, C_v, dim: int, dx: ufl.Measure = ufl.dx) -> ufl.Form:
    """a⁽¹⁾(w, v) = ∫ (C_v ε_v(w)) · ε_v(v) dx; w is a velocity (or rate)."""
    return elastic_form(w, v, C_v, dim, dx)
