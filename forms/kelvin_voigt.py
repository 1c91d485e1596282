"""Time-discrete Kelvin–Voigt operator of the semi-implicit scheme
(docs/theory/mechanics.md#time-discretisation).

With u'' ≈ (u^{i+1} − 2u^i + u^{i−1})/Δt² and u' ≈ (u^{i+1} − u^i)/Δt, each level
solves A(u, v) = ℓ(v) for u = u^{i+1}:

    A(u, v) = (ρu, v) + Δt² a⁽⁰⁾(u, v) + Δt a⁽¹⁾(u, v)
    ℓ(v)    = Δt² f^{i+1}(v) + (ρ(2u^i − u^{i−1}), v) + Δt a⁽¹⁾(u^i, v)

Quasi-static (no mass, viscous term with the step as rate):

    A_qs(u, v) = Δt a⁽⁰⁾(u, v) + a⁽¹⁾(u, v),   ℓ_qs(v) = Δt f^{i+1}(v) + a⁽¹⁾(u^i, v)

Running ``ffcx forms/kelvin_voigt.py`` compiles the concrete 2D plane-strain instance
defined at the bottom (``forms`` list), which shows the forms are ahead-of-time
compilable.  The package builds the same forms on its own meshes.
"""

from __future__ import annotations

import basix.ufl
import ufl

if globals().get("__package__"):
    from .elastic import elastic_form
    from .loads import body_force_form
    from .mass import mass_form
    from .viscous import viscous_form
else:  # pragma: no cover - ffcx exec()s this file without a package context
    from bonecontact.forms.elastic import elastic_form
    from bonecontact.forms.loads import body_force_form
    from bonecontact.forms.mass import mass_form
    from bonecontact.forms.viscous import viscous_form


def dynamic_lhs(u, v, rho, C, C_v, dt, dim: int, dx: ufl.Measure = ufl.dx) -> ufl.Form:
    """A(u, v) = (ρu, v) + Δt² a⁽⁰⁾(u, v) + Δt a⁽¹⁾(u, v)."""
    return (
        mass_form(u, v, rho, dx)
        + dt**2 * elastic_form(u, v, C, dim, dx)
        + dt * viscous_form(u, v, C_v, dim, dx)
    )


def dynamic_rhs(v, f, u_n, u_nm1, rho, C_v, dt, dim: int, dx: ufl.Measure = ufl.dx) -> ufl.Form:
    """ℓ(v) = Δt² (f, v) + (ρ(2uⁿ − uⁿ⁻¹), v) + Δt a⁽¹⁾(uⁿ, v)."""
    return (
        dt**2 * body_force_form(f, v, dx)
        + mass_form(2 * u_n - u_nm1, v, rho, dx)
        + dt * viscous_form(u_n, v, C_v, dim, dx)
    )


def quasistatic_lhs(u, v, C, C_v, dt, dim: int, dx: ufl.Measure = ufl.dx) -> ufl.Form:
    """A_qs(u, v) = Δt a⁽⁰⁾(u, v) + a⁽¹⁾(u, v)."""
    return dt * elastic_form(u, v, C, dim, dx) + viscous_form(u, v, C_v, dim, dx)


def quasistatic_rhs(v, f, u_n, C_v, dt, dim: int, dx: ufl.Measure = ufl.dx) -> ufl.Form:
    """ℓ_qs(v) = Δt (f, v) + a⁽¹⁾(uⁿ, v)."""
    return dt * body_force_form(f, v, dx) + viscous_form(u_n, v, C_v, dim, dx)


# --- concrete instance for ahead-of-time compilation with ffcx --------------------
_cell = "triangle"
_coord = basix.ufl.element("Lagrange", _cell, 1, shape=(2,))
_domain = ufl.Mesh(_coord)
_V = ufl.FunctionSpace(_domain, basix.ufl.element("Lagrange", _cell, 1, shape=(2,)))
_Q0 = ufl.FunctionSpace(_domain, basix.ufl.element("DG", _cell, 0))
_T0 = ufl.FunctionSpace(_domain, basix.ufl.element("DG", _cell, 0, shape=(3, 3)))
_u, _v = ufl.TrialFunction(_V), ufl.TestFunction(_V)
_rho = ufl.Coefficient(_Q0)
_C = ufl.Coefficient(_T0)
_Cv = ufl.Coefficient(_T0)
_un, _unm1, _f = ufl.Coefficient(_V), ufl.Coefficient(_V), ufl.Coefficient(_V)
_dt = ufl.Constant(_domain)

a = dynamic_lhs(_u, _v, _rho, _C, _Cv, _dt, 2)
L = dynamic_rhs(_v, _f, _un, _unm1, _rho, _Cv, _dt, 2)
forms = [a, L]
