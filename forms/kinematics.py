"""Small-strain kinematics and Voigt notation (pure UFL).

Voigt ordering ``[xx, yy, zz, yz, xz, xy]`` in 3D and ``[xx, yy, xy]`` in 2D plane
strain, with engineering shear strains γ_ij = 2 e_ij.
"""

from __future__ import annotations

import ufl


def strain(u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """Small strain e(u) = sym(∇u)."""
    return ufl.sym(ufl.grad(u))


def voigt_strain(e: ufl.core.expr.Expr, dim: int) -> ufl.core.expr.Expr:
    """Engineering-strain Voigt vector of a strain tensor."""
    if dim == 2:
        return ufl.as_vector([e[0, 0], e[1, 1], 2 * e[0, 1]])
    if dim == 3:
        return ufl.as_vector([e[0, 0], e[1, 1], e[2, 2], 2 * e[1, 2], 2 * e[0, 2], 2 * e[0, 1]])
    raise ValueError(f"dim must be 2 or 3, got {dim}")


def tensor_from_voigt(s: ufl.core.expr.Expr, dim: int) -> ufl.core.expr.Expr:
    """Symmetric tensor from a (stress) Voigt vector."""
    if dim == 2:
        return ufl.as_matrix([[s[0], s[2]], [s[2], s[1]]])
    if dim == 3:
        return ufl.as_matrix([[s[0], s[5], s[4]], [s[5], s[1], s[3]], [s[4], s[3], s[2]]])
    raise ValueError(f"dim must be 2 or 3, got {dim}")


def stress(C: ufl.core.expr.Expr, u: ufl.core.expr.Expr, dim: int) -> ufl.core.expr.Expr:
    """Stress tensor σ = C e(u) for a Voigt stiffness C (3×3 in 2D, 6×6 in 3D)."""
    return tensor_from_voigt(ufl.dot(C, voigt_strain(strain(u), dim)), dim)


def isotropic_voigt(
    lmbda: ufl.core.expr.Expr, mu: ufl.core.expr.Expr, dim: int
) -> ufl.core.expr.Expr:
    """Voigt stiffness λ δ_ij δ_kl + μ(δ_ik δ_jl + δ_il δ_jk) (plane strain in 2D)."""
    if dim == 2:
        return ufl.as_matrix([[lmbda + 2 * mu, lmbda, 0], [lmbda, lmbda + 2 * mu, 0], [0, 0, mu]])
    d = lmbda + 2 * mu
    return ufl.as_matrix(
        [
            [d, lmbda, lmbda, 0, 0, 0],
            [lmbda, d, lmbda, 0, 0, 0],
            [lmbda, lmbda, d, 0, 0, 0],
            [0, 0, 0, mu, 0, 0],
            [0, 0, 0, 0, mu, 0],
            [0, 0, 0, 0, 0, mu],
        ]
    )
