"""Elastic form a⁽⁰⁾(u, v) = ∫ c⁽⁰⁾ e(u) : e(v) dx (pure UFL).

The stiffness is a Voigt matrix field ``C`` (constant or piecewise constant), so
isotropic, transversely isotropic and orthotropic materials share one form.

Nearly incompressible materials use the *average nodal pressure* split: the
deviatoric part stays in ``C`` while the volumetric strain θ = div u is averaged at
the vertices, θ̄_i = b_i(u)/m_i with b_i(u) = ∫ χ φ_i div u, m_i = ∫ χ φ_i
(χ: indicator of those cells), and the volumetric energy ½ Σ_i k_i θ̄_i²,
k_i = ∫ κ φ_i.  The forms below give b, m and k; the package forms Bᵀ diag(k/m²) B.
"""

from __future__ import annotations

import ufl

from .kinematics import strain, voigt_strain


def elastic_form(u, v, C, dim: int, dx: ufl.Measure = ufl.dx) -> ufl.Form:
    """a⁽⁰⁾(u, v) = ∫ (C ε_v(u)) · ε_v(v) dx."""
    return ufl.inner(ufl.dot(C, voigt_strain(strain(u), dim)), voigt_strain(strain(v), dim)) * dx


def deviatoric_voigt(mu, dim: int) -> ufl.core.expr.Expr:
    """Voigt matrix of 2μ dev(e) (3D deviator; plane strain keeps e_zz = 0)."""
    a, b = 4 * mu / 3, -2 * mu / 3
    if dim == 2:
        return ufl.as_matrix([[a, b, 0], [b, a, 0], [0, 0, mu]])
    return ufl.as_matrix(
        [
            [a, b, b, 0, 0, 0],
            [b, a, b, 0, 0, 0],
            [b, b, a, 0, 0, 0],
            [0, 0, 0, mu, 0, 0],
            [0, 0, 0, 0, mu, 0],
            [0, 0, 0, 0, 0, mu],
        ]
    )


def volumetric_coupling(u, q, chi, dx: ufl.Measure = ufl.dx) -> ufl.Form:
    """b(u, q) = ∫ χ q div u dx (rows: nodal scalar q, columns: displacement u)."""
    return chi * q * ufl.div(u) * dx


def nodal_weight(q, weight, dx: ufl.Measure = ufl.dx) -> ufl.Form:
    """Lumped nodal weight ∫ w q dx (w = χ gives m_i, w = κ gives k_i)."""
    return weight * q * dx
