"""Tests of the P1 dual basis of the mortar (docs/theory/mortar.md#dual-basis,
docs/theory/verification.md#verification-references "dual basis").

Pure NumPy: safe to run redundantly on every rank under
``mpiexec -n 2 python -m mpi4py -m pytest``.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from bonecontact.contact.dual_basis import (
    DUAL_COEFFS_SEGMENT,
    DUAL_COEFFS_TRIANGLE,
    GAUSS_SEGMENT,
    TRIANGLE_RULE,
    dual_coefficients,
    dual_coefficients_from_mass,
    dual_segment,
    dual_triangle,
    element_mass_matrices,
    evaluate_dual,
    modify_dual_coefficients,
    shape_segment,
    shape_triangle,
)

# ----------------------------------------------------------------------------------
# dual basis
# ----------------------------------------------------------------------------------


def test_quadrature_rules_exact():
    t, w = GAUSS_SEGMENT
    for k in range(6):
        assert np.isclose(np.sum(w * t**k), 1.0 / (k + 1), rtol=0, atol=1e-15)
    bary, w = TRIANGLE_RULE
    # int over the reference triangle of xi^a eta^b = a! b! / (a+b+2)!, area 1/2
    from math import factorial

    for a, b in itertools.product(range(6), repeat=2):
        if a + b <= 5:
            exact = factorial(a) * factorial(b) / factorial(a + b + 2)
            num = 0.5 * np.sum(w * bary[:, 1] ** a * bary[:, 2] ** b)
            assert abs(num - exact) < 1e-15


def test_biorthogonality_segment():
    t, w = GAUSS_SEGMENT
    phi, psi = shape_segment(t), dual_segment(t)
    gram = np.einsum("q,qj,qk->jk", w, psi, phi)
    np.testing.assert_allclose(gram, 0.5 * np.eye(2), atol=1e-15)
    np.testing.assert_allclose(dual_segment([0.0, 1.0]), [[2.0, -1.0], [-1.0, 2.0]])


def test_biorthogonality_reference_triangle():
    bary, w = TRIANGLE_RULE
    xi = bary[:, 1:]
    phi, psi = shape_triangle(xi), dual_triangle(xi)
    gram = 0.5 * np.einsum("q,qj,qk->jk", w, psi, phi)
    np.testing.assert_allclose(gram, np.eye(3) / 6.0, atol=1e-15)
    np.testing.assert_allclose(
        dual_triangle([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), 4 * np.eye(3) - 1
    )


def test_biorthogonality_random_affine_triangle():
    rng = np.random.default_rng(1)
    for _ in range(10):
        v = rng.normal(size=(3, 3))
        area = 0.5 * np.linalg.norm(np.cross(v[1] - v[0], v[2] - v[0]))
        bary, w = TRIANGLE_RULE
        # physical quadrature: psi / phi are the same functions of barycentrics
        phi = bary
        psi = evaluate_dual(DUAL_COEFFS_TRIANGLE, phi)
        gram = area * np.einsum("q,qj,qk->jk", w, psi, phi)
        np.testing.assert_allclose(gram, area / 3.0 * np.eye(3), atol=1e-14 * area)
        np.testing.assert_allclose(psi, dual_triangle(bary[:, 1:]), atol=1e-15)


def test_general_constructor_matches_closed_form():
    rng = np.random.default_rng(2)
    for gdim in (2, 3):
        segs = rng.normal(size=(20, 2, gdim))
        np.testing.assert_allclose(
            dual_coefficients(segs), np.broadcast_to(DUAL_COEFFS_SEGMENT, (20, 2, 2)), atol=1e-12
        )
    tris = rng.normal(size=(20, 3, 3))
    np.testing.assert_allclose(
        dual_coefficients(tris), np.broadcast_to(DUAL_COEFFS_TRIANGLE, (20, 3, 3)), atol=1e-12
    )
    # element mass matrix against the closed form |T|/12 (1 + delta)
    area = 0.5 * np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    np.testing.assert_allclose(
        element_mass_matrices(tris),
        area[:, None, None] / 12.0 * (np.ones((3, 3)) + np.eye(3)),
        rtol=1e-13,
    )


def test_general_constructor_nonaffine_weight():
    """A_e = D_e M_e^-1 with a non-constant weight (e.g. a non-affine Jacobian)."""
    # 5-point rule to integrate weight * phi * phi exactly (weight quadratic)
    x, wx = np.polynomial.legendre.leggauss(5)
    x, wx = 0.5 * (x + 1.0), 0.5 * wx
    weight = 1.0 + x + 2.0 * x**2
    phi = shape_segment(x)
    mass = np.einsum("q,q,qj,qk->jk", wx, weight, phi, phi)
    A = dual_coefficients_from_mass(mass)
    psi = evaluate_dual(A, phi)
    gram = np.einsum("q,q,qj,qk->jk", wx, weight, psi, phi)
    np.testing.assert_allclose(gram, np.diag(mass.sum(axis=1)), atol=1e-14)
    np.testing.assert_allclose(psi.sum(axis=1), 1.0, atol=1e-14)


def test_partition_of_unity():
    rng = np.random.default_rng(3)
    xi = rng.uniform(-0.5, 1.5, 50)
    np.testing.assert_allclose(dual_segment(xi).sum(axis=1), 1.0, atol=1e-14)
    pts = rng.uniform(-0.5, 1.5, (50, 2))
    np.testing.assert_allclose(dual_triangle(pts).sum(axis=1), 1.0, atol=1e-14)
    np.testing.assert_allclose(shape_triangle(pts).sum(axis=1), 1.0, atol=1e-14)


def test_boundary_modification_segment():
    A = modify_dual_coefficients(DUAL_COEFFS_SEGMENT, [[True, False], [False, False]])
    xi = np.linspace(0.0, 1.0, 7)
    psi0 = evaluate_dual(A[0], shape_segment(xi))
    np.testing.assert_allclose(psi0[:, 0], 0.0, atol=0)  # masked node: multiplier vanishes
    np.testing.assert_allclose(psi0[:, 1], 1.0, atol=1e-15)  # interior node: psi = 1 on end segment
    np.testing.assert_allclose(A[1], DUAL_COEFFS_SEGMENT)  # untouched element
    none = modify_dual_coefficients(DUAL_COEFFS_SEGMENT, [[True, True]])
    np.testing.assert_array_equal(none, 0.0)


@pytest.mark.parametrize("mask", [(True, False, False), (False, True, True), (False, False, False)])
def test_boundary_modification_triangle(mask):
    rng = np.random.default_rng(4)
    A = modify_dual_coefficients(DUAL_COEFFS_TRIANGLE, [mask])[0]
    pts = rng.uniform(0.0, 1.0, (40, 2))
    psi = evaluate_dual(A, shape_triangle(pts))
    np.testing.assert_allclose(psi.sum(axis=1), 1.0, atol=1e-14)  # constants reproduced
    m = np.array(mask)
    np.testing.assert_array_equal(psi[:, m], 0.0)
    # biorthogonality kept between free nodes; int psi~_j phi_b = int phi_b / n_free
    bary, w = TRIANGLE_RULE
    gram = np.einsum("q,qj,qk->jk", w, evaluate_dual(A, bary), bary)  # area 1
    free = ~m
    expected = np.diag(np.where(free, 1.0 / 3.0, 0.0))
    expected[np.ix_(free, m)] = (1.0 / 3.0) / free.sum()
    np.testing.assert_allclose(gram, expected, atol=1e-15)
