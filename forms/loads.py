"""Load forms (pure UFL).  Units: traction and pressure in Pa, body force in N/m³."""

from __future__ import annotations

import ufl


def traction_form(t, v, ds: ufl.Measure) -> ufl.Form:
    """∫_Γτ t · v ds (t: traction vector τ n)."""
    return ufl.inner(t, v) * ds


def pressure_form(p, v, n, ds: ufl.Measure) -> ufl.Form:
    """−∫ p n · v ds: a positive pressure pushes into the body (n: outward normal)."""
    return -p * ufl.inner(n, v) * ds


def body_force_form(f, v, dx: ufl.Measure) -> ufl.Form:
    """∫ f · v dx."""
    return ufl.inner(f, v) * dx
