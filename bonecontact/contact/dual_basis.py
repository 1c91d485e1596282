"""P1 primal and dual (biorthogonal) shape functions of the mortar, pure NumPy.

Quadrature rules on the reference segment and triangle, the primal and dual P1 shape
functions, the general element construction ``A_e = D_e M_e^{-1}`` and the boundary
(crosspoint / Dirichlet) modification.

Conventions: reference segment ``xi in [0, 1]`` with ``phi = (1 - xi, xi)``; reference
triangle ``(0,0), (1,0), (0,1)`` with ``phi = (1 - xi - eta, xi, eta)``.  The dual basis
on an element is ``psi_j = sum_k A[j, k] phi_k`` (``A`` is the *coefficient matrix*).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bonecontact.contact.geometry import FloatArray, simplex_measure

__all__ = [
    "DUAL_COEFFS_SEGMENT",
    "DUAL_COEFFS_TRIANGLE",
    "GAUSS_SEGMENT",
    "TRIANGLE_RULE",
    "dual_coefficients",
    "dual_coefficients_from_mass",
    "dual_segment",
    "dual_triangle",
    "element_mass_matrices",
    "evaluate_dual",
    "modify_dual_coefficients",
    "reference_dual_coefficients",
    "shape_segment",
    "shape_triangle",
]

# ----------------------------------------------------------------------------------
# Quadrature rules
# ----------------------------------------------------------------------------------


def _gauss_segment() -> tuple[FloatArray, FloatArray]:
    """3-point Gauss-Legendre rule on ``[0, 1]`` (exact to degree 5), weights sum to 1."""
    r = np.sqrt(3.0 / 5.0) / 2.0
    points = np.array([0.5 - r, 0.5, 0.5 + r])
    weights = np.array([5.0, 8.0, 5.0]) / 18.0
    return points, weights


def _radon_triangle() -> tuple[FloatArray, FloatArray]:
    """7-point Radon rule (degree 5) in barycentric coordinates; weights sum to 1.

    Returns
    -------
    bary : (7, 3) barycentric coordinates of the points.
    weights : (7,) weights normalised to the triangle's area.
    """
    s15 = np.sqrt(15.0)
    a = (6.0 - s15) / 21.0
    b = (6.0 + s15) / 21.0
    wa = (155.0 - s15) / 1200.0
    wb = (155.0 + s15) / 1200.0
    bary = np.array(
        [
            [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
            [a, a, 1.0 - 2.0 * a],
            [a, 1.0 - 2.0 * a, a],
            [1.0 - 2.0 * a, a, a],
            [b, b, 1.0 - 2.0 * b],
            [b, 1.0 - 2.0 * b, b],
            [1.0 - 2.0 * b, b, b],
        ]
    )
    weights = np.array([9.0 / 40.0, wa, wa, wa, wb, wb, wb])
    return bary, weights


#: 3-point Gauss rule on [0, 1]: ``(points (3,), weights (3,))``, weights sum to 1.
GAUSS_SEGMENT: tuple[FloatArray, FloatArray] = _gauss_segment()
#: 7-point degree-5 triangle rule: ``(barycentric (7, 3), weights (7,))``, sum to 1.
TRIANGLE_RULE: tuple[FloatArray, FloatArray] = _radon_triangle()

# ----------------------------------------------------------------------------------
# Primal and dual P1 shape functions (docs/theory/mortar.md#dual-basis)
# ----------------------------------------------------------------------------------

#: Closed-form dual coefficients on an affine segment: psi_1 = 2 phi_1 - phi_2, ...
DUAL_COEFFS_SEGMENT: FloatArray = np.array([[2.0, -1.0], [-1.0, 2.0]])
#: Closed-form dual coefficients on an affine triangle: psi_i = 4 phi_i - 1.
DUAL_COEFFS_TRIANGLE: FloatArray = 4.0 * np.eye(3) - 1.0


def shape_segment(xi: npt.ArrayLike) -> FloatArray:
    """P1 shape functions on the reference segment.

    Parameters
    ----------
    xi : array_like, shape (...)
        Reference coordinates in ``[0, 1]``.

    Returns
    -------
    ndarray, shape (..., 2)
        ``(1 - xi, xi)``.
    """
    xi = np.asarray(xi, dtype=float)
    return np.stack([1.0 - xi, xi], axis=-1)


def dual_segment(xi: npt.ArrayLike) -> FloatArray:
    """Dual (biorthogonal) P1 shape functions on the reference segment.

    Parameters
    ----------
    xi : array_like, shape (...)
        Reference coordinates.

    Returns
    -------
    ndarray, shape (..., 2)
        ``(2 - 3 xi, 3 xi - 1)``.
    """
    xi = np.asarray(xi, dtype=float)
    return np.stack([2.0 - 3.0 * xi, 3.0 * xi - 1.0], axis=-1)


def shape_triangle(xi: npt.ArrayLike) -> FloatArray:
    """P1 shape functions on the reference triangle.

    Parameters
    ----------
    xi : array_like, shape (..., 2)
        Reference coordinates ``(xi, eta)``.

    Returns
    -------
    ndarray, shape (..., 3)
        ``(1 - xi - eta, xi, eta)``.
    """
    xi = np.asarray(xi, dtype=float)
    return np.stack([1.0 - xi[..., 0] - xi[..., 1], xi[..., 0], xi[..., 1]], axis=-1)


def dual_triangle(xi: npt.ArrayLike) -> FloatArray:
    """Dual (biorthogonal) P1 shape functions on the reference triangle.

    Parameters
    ----------
    xi : array_like, shape (..., 2)
        Reference coordinates ``(xi, eta)``.

    Returns
    -------
    ndarray, shape (..., 3)
        ``psi_i = 4 phi_i - 1``.
    """
    return 4.0 * shape_triangle(xi) - 1.0


def reference_dual_coefficients(n_vertices: int) -> FloatArray:
    """Closed-form dual coefficient matrix of an affine P1 simplex.

    Parameters
    ----------
    n_vertices : int
        2 (segment) or 3 (triangle).

    Returns
    -------
    ndarray, shape (n_vertices, n_vertices)
    """
    if n_vertices == 2:
        return DUAL_COEFFS_SEGMENT.copy()
    if n_vertices == 3:
        return DUAL_COEFFS_TRIANGLE.copy()
    raise ValueError(f"unsupported number of element vertices: {n_vertices}")


def evaluate_dual(coeffs: npt.ArrayLike, phi: npt.ArrayLike) -> FloatArray:
    """Evaluate dual functions ``psi_j = sum_k A[j, k] phi_k`` from primal values.

    Parameters
    ----------
    coeffs : array_like, shape (nv, nv) or (n, nv, nv)
        Dual coefficient matrices (one per element, or one shared).
    phi : array_like, shape (..., nv) or (n, ..., nv)
        Primal shape function values; a leading element axis must match ``coeffs``.

    Returns
    -------
    ndarray, same shape as ``phi``
    """
    coeffs = np.asarray(coeffs, dtype=float)
    phi = np.asarray(phi, dtype=float)
    if coeffs.ndim == 2:
        return phi @ coeffs.T
    return np.einsum("n...k,njk->n...j", phi, coeffs)


def element_mass_matrices(vertices: npt.ArrayLike) -> FloatArray:
    """P1 element mass matrices ``M_e[j, k] = int_e phi_j phi_k`` by quadrature.

    Parameters
    ----------
    vertices : array_like, shape (n, nv, gdim)
        Vertex coordinates of affine segments (``nv = 2``) or triangles (``nv = 3``),
        embedded in any dimension ``gdim >= nv - 1``.

    Returns
    -------
    ndarray, shape (n, nv, nv)
    """
    vertices = np.asarray(vertices, dtype=float)
    nv = vertices.shape[1]
    if nv == 2:
        pts, w = GAUSS_SEGMENT
        phi = shape_segment(pts)
    elif nv == 3:
        bary, w = TRIANGLE_RULE
        phi = bary
    else:
        raise ValueError(f"unsupported number of element vertices: {nv}")
    ref = np.einsum("q,qj,qk->jk", w, phi, phi)
    return simplex_measure(vertices)[:, None, None] * ref[None]


def dual_coefficients_from_mass(mass: npt.ArrayLike) -> FloatArray:
    """General dual coefficient matrices ``A_e = D_e M_e^{-1}``.

    ``D_e = diag(int phi_k)`` equals the row sums of ``M_e`` because the primal
    functions sum to one.  Valid for any (non-affine, weighted, higher order)
    element whose mass matrix is supplied.

    Parameters
    ----------
    mass : array_like, shape (..., nv, nv)
        Element mass matrices ``M_e``.

    Returns
    -------
    ndarray, shape (..., nv, nv)
        ``A_e`` with ``int psi_j phi_k = delta_jk int phi_k``.
    """
    mass = np.asarray(mass, dtype=float)
    d = mass.sum(axis=-1)
    diag = d[..., :, None] * np.eye(mass.shape[-1])
    # A M = D  <=>  M^T A^T = D
    return np.swapaxes(np.linalg.solve(np.swapaxes(mass, -1, -2), diag), -1, -2)


def dual_coefficients(vertices: npt.ArrayLike) -> FloatArray:
    """Dual coefficient matrices of P1 simplices from their geometry.

    Parameters
    ----------
    vertices : array_like, shape (n, nv, gdim)

    Returns
    -------
    ndarray, shape (n, nv, nv)
        Equals :data:`DUAL_COEFFS_SEGMENT` / :data:`DUAL_COEFFS_TRIANGLE` for
        non-degenerate affine elements.
    """
    return dual_coefficients_from_mass(element_mass_matrices(vertices))


def modify_dual_coefficients(coeffs: npt.ArrayLike, mask: npt.ArrayLike) -> FloatArray:
    """Boundary modification of the dual basis (docs/theory/mortar.md#dual-basis).

    On each element the dual function of every masked node (multiplier must
    vanish there: Dirichlet node, crosspoint, end of the contact zone) is set to
    zero and distributed in equal shares to the element's unmasked nodes::

        psi~_j = psi_j + (1 / n_free) sum_{b masked} psi_b    (j unmasked)
        psi~_b = 0                                            (b masked)

    so ``sum_j psi~_j = 1`` (constants are reproduced).  In 2D the interior node
    of an end segment gets ``psi~ = 1``.  Elements with all nodes masked carry no
    multiplier (all coefficients zero).  Biorthogonality is kept between unmasked
    nodes, but ``int psi~_j phi_b = int phi_b / n_free`` couples to masked nodes.

    Parameters
    ----------
    coeffs : array_like, shape (n, nv, nv) or (nv, nv)
        Unmodified coefficient matrices (a single matrix is broadcast to ``n``).
    mask : array_like of bool, shape (n, nv)
        ``True`` for element nodes at which the multiplier vanishes.

    Returns
    -------
    ndarray, shape (n, nv, nv)
    """
    mask = np.asarray(mask, dtype=bool)
    coeffs = np.broadcast_to(np.asarray(coeffs, dtype=float), mask.shape + mask.shape[-1:])
    free = ~mask
    n_free = free.sum(axis=1)
    masked_sum = np.einsum("nj,njk->nk", mask.astype(float), coeffs)
    share = np.divide(1.0, n_free, out=np.zeros(n_free.shape), where=n_free > 0)
    out = coeffs + share[:, None, None] * masked_sum[:, None, :]
    return np.where(free[:, :, None], out, 0.0)
