"""Mass form (ρ u, v) (pure UFL)."""

from __future__ import annotations

import ufl


def mass_form(u, v, rho, dx: ufl.Measure = ufl.dx) -> ufl.Form:
    """m(u, v) = ∫ ρ u · v dx."""
    return rho * ufl.inner(u, v) * dx
