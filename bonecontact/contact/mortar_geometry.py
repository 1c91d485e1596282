"""Geometric core of the dual-mortar contact discretisation (SPEC §4), pure NumPy.

Everything here works on plain coordinate / connectivity arrays and is vectorised
over elements, candidate pairs and quadrature points; there is no DOLFINx or MPI
dependency, so on a parallel run every rank calls these functions on its own
(local) slave facets and on whatever master facets it can see, and inserts the
returned COO triplets into distributed PETSc matrices.

Contents
--------
* P1 primal and dual (biorthogonal) shape functions on the reference segment and
  triangle, the general element construction ``A_e = D_e M_e^{-1}`` and the
  boundary (crosspoint / Dirichlet) modification of §4.1.
* Facet normals, area-weighted averaged nodal normals and nodal tangents.
* Candidate search between slave and master facets (bounding boxes on a uniform
  hash grid, O(n) expected).
* Segment-based integration of ``D``, ``M`` and the weighted gap: 2D (overlap of
  projected segments) and 3D (Sutherland-Hodgman clipping of the master triangle
  projected into the slave triangle's plane, fan triangulation, 7-point rule).
* :func:`assemble_mortar`, the per-rank assembly into COO triplets.

Conventions
-----------
Reference segment ``xi in [0, 1]`` with ``phi = (1 - xi, xi)``; reference triangle
``(0,0), (1,0), (0,1)`` with ``phi = (1 - xi - eta, xi, eta)``.  The dual basis on
an element is ``psi_j = sum_k A[j, k] phi_k`` (``A`` is the *coefficient matrix*).
The gap is ``g = (x_master - x_slave) . n`` with ``n`` the normalised interpolation
of the slave nodal normals (``g >= 0`` means separated, SPEC §2.3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = [
    "DUAL_COEFFS_SEGMENT",
    "DUAL_COEFFS_TRIANGLE",
    "GAUSS_SEGMENT",
    "TRIANGLE_RULE",
    "MortarContributions",
    "MortarPairs",
    "PairIntegrals",
    "assemble_mortar",
    "clip_polygons_by_triangles",
    "compute_mortar_pairs",
    "dual_coefficients",
    "dual_coefficients_from_mass",
    "dual_segment",
    "dual_triangle",
    "element_mass_matrices",
    "evaluate_dual",
    "facet_bounding_boxes",
    "facet_normals",
    "find_candidate_pairs",
    "integrate_segment_pairs",
    "integrate_triangle_pairs",
    "modify_dual_coefficients",
    "nodal_normals",
    "nodal_tangents",
    "polygon_areas",
    "project_points_to_lines_along_directions",
    "project_points_to_segments_interpolated_normal",
    "reference_dual_coefficients",
    "shape_segment",
    "shape_triangle",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

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
# Primal and dual P1 shape functions (SPEC §4.1)
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


def _simplex_measure(vertices: FloatArray) -> FloatArray:
    """Measure (length / area) of P1 simplices embedded in any dimension.

    Parameters
    ----------
    vertices : ndarray, shape (n, nv, gdim)

    Returns
    -------
    ndarray, shape (n,)
    """
    jac = vertices[:, 1:, :] - vertices[:, :1, :]  # (n, nv-1, gdim)
    gram = np.einsum("nig,njg->nij", jac, jac)
    fact = 1.0 if jac.shape[1] == 1 else 0.5
    return fact * np.sqrt(np.maximum(np.linalg.det(gram), 0.0))


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
    return _simplex_measure(vertices)[:, None, None] * ref[None]


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
    """Boundary modification of the dual basis (SPEC §4.1).

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


# ----------------------------------------------------------------------------------
# Normals and tangents
# ----------------------------------------------------------------------------------


def _cross2(a: FloatArray, b: FloatArray) -> FloatArray:
    """z-component of the cross product of 2D vectors (broadcasting)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _normalise(v: FloatArray) -> FloatArray:
    """Normalise vectors along the last axis, leaving zero vectors at zero."""
    norm = np.sqrt(np.sum(v * v, axis=-1, keepdims=True))
    return np.divide(v, norm, out=np.zeros_like(v), where=norm > 0.0)


def facet_normals(
    coords: npt.ArrayLike,
    facets: npt.ArrayLike,
    interior_points: npt.ArrayLike | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Unit facet normals and facet measures of a surface mesh.

    Parameters
    ----------
    coords : array_like, shape (n_vertices, gdim)
        Vertex coordinates, ``gdim`` 2 (facets are segments) or 3 (triangles).
    facets : array_like of int, shape (n_facets, gdim)
        Facet-to-vertex connectivity.
    interior_points : array_like, shape (n_facets, gdim), optional
        A point inside the body for every facet (e.g. the vertex of the owning
        cell opposite the facet).  Each normal is flipped to point away from it,
        i.e. outward.  Without it the orientation follows the vertex ordering
        (2D: ``(t_y, -t_x)`` for ``t = x_1 - x_0``; 3D: ``(x_1-x_0) x (x_2-x_0)``).

    Returns
    -------
    normals : ndarray, shape (n_facets, gdim)
    measures : ndarray, shape (n_facets,)
        Lengths (2D) or areas (3D).
    """
    coords = np.asarray(coords, dtype=float)
    facets = np.asarray(facets, dtype=np.int64)
    x = coords[facets]
    gdim = coords.shape[1]
    if gdim == 2 and facets.shape[1] == 2:
        t = x[:, 1] - x[:, 0]
        n = np.stack([t[:, 1], -t[:, 0]], axis=1)
        measure = np.linalg.norm(t, axis=1)
    elif gdim == 3 and facets.shape[1] == 3:
        n = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
        measure = 0.5 * np.linalg.norm(n, axis=1)
    else:
        raise ValueError("expected segments in 2D or triangles in 3D")
    n = _normalise(n)
    if interior_points is not None:
        inner = np.asarray(interior_points, dtype=float)
        side = np.einsum("fg,fg->f", n, x.mean(axis=1) - inner)
        n = np.where(side[:, None] < 0.0, -n, n)
    return n, measure


def nodal_normals(
    coords: npt.ArrayLike,
    facets: npt.ArrayLike,
    interior_points: npt.ArrayLike | None = None,
) -> FloatArray:
    """Averaged nodal normals (facet normals weighted by facet measure).

    Parameters
    ----------
    coords, facets, interior_points
        As in :func:`facet_normals`.

    Returns
    -------
    ndarray, shape (n_vertices, gdim)
        Unit outward normals; zero rows for vertices not in any facet.
    """
    coords = np.asarray(coords, dtype=float)
    facets = np.asarray(facets, dtype=np.int64)
    n, measure = facet_normals(coords, facets, interior_points)
    weighted = np.repeat(n * measure[:, None], facets.shape[1], axis=0)
    flat = facets.ravel()
    acc = np.stack(
        [
            np.bincount(flat, weights=weighted[:, d], minlength=coords.shape[0])
            for d in range(coords.shape[1])
        ],
        axis=1,
    )
    return _normalise(acc)


def nodal_tangents(normals: npt.ArrayLike) -> FloatArray:
    """Orthonormal tangents completing the nodal normals to a right-handed frame.

    Parameters
    ----------
    normals : array_like, shape (n, gdim)
        Unit normals.

    Returns
    -------
    ndarray, shape (n, gdim - 1, gdim)
        2D: ``t = (-n_y, n_x)``; 3D: ``t1 ⟂ n`` built from the coordinate axis least
        aligned with ``n`` and ``t2 = n x t1`` (so ``t1 x t2 = n``).  Zero normals
        give zero tangents.
    """
    n = np.asarray(normals, dtype=float)
    if n.shape[1] == 2:
        return np.stack([-n[:, 1], n[:, 0]], axis=1)[:, None, :]
    axis = np.eye(3)[np.argmin(np.abs(n), axis=1)]
    t1 = _normalise(axis - np.einsum("ng,ng->n", axis, n)[:, None] * n)
    t1 = np.where(np.linalg.norm(n, axis=1)[:, None] > 0.0, t1, 0.0)
    t2 = np.cross(n, t1)
    return np.stack([t1, t2], axis=1)


# ----------------------------------------------------------------------------------
# Candidate search
# ----------------------------------------------------------------------------------


def facet_bounding_boxes(
    coords: npt.ArrayLike, facets: npt.ArrayLike, pad: float = 0.0
) -> tuple[FloatArray, FloatArray]:
    """Axis-aligned bounding boxes of facets, enlarged by ``pad`` on every side.

    Returns
    -------
    lower, upper : ndarray, shape (n_facets, gdim)
    """
    x = np.asarray(coords, dtype=float)[np.asarray(facets, dtype=np.int64)]
    return x.min(axis=1) - pad, x.max(axis=1) + pad


def _expand_cells(cmin: IntArray, cmax: IntArray) -> tuple[IntArray, IntArray]:
    """List every grid cell touched by every box.

    Returns
    -------
    ids : ndarray (n_entries,) box index of each entry.
    cells : ndarray (n_entries, gdim) integer cell coordinates.
    """
    span = cmax - cmin + 1
    count = span.prod(axis=1)
    ids = np.repeat(np.arange(len(cmin), dtype=np.int64), count)
    local = np.arange(count.sum(), dtype=np.int64) - np.repeat(np.cumsum(count) - count, count)
    cells = np.empty((len(ids), cmin.shape[1]), dtype=np.int64)
    for d in reversed(range(cmin.shape[1])):
        s = span[ids, d]
        cells[:, d] = cmin[ids, d] + local % s
        local //= s
    return ids, cells


def find_candidate_pairs(
    lower_a: npt.ArrayLike,
    upper_a: npt.ArrayLike,
    lower_b: npt.ArrayLike,
    upper_b: npt.ArrayLike,
    cell_size: float | None = None,
) -> tuple[IntArray, IntArray]:
    """All pairs of intersecting axis-aligned boxes (set A x set B).

    Boxes are hashed to a uniform grid (cell size ~ the median box size), pairs
    sharing a cell are tested exactly; each pair is reported once (in the cell
    holding the lower corner of the boxes' intersection).  Expected cost is
    linear in the number of boxes plus the number of pairs.

    Parameters
    ----------
    lower_a, upper_a : array_like, shape (n_a, gdim)
    lower_b, upper_b : array_like, shape (n_b, gdim)
    cell_size : float, optional
        Grid spacing; default: geometric mean of the median box extents of A and B.
        It is doubled while the number of (box, cell) entries would exceed
        ``max(32 (n_a + n_b), 1e5)``.

    Returns
    -------
    ia, ib : ndarray of int64, shape (n_pairs,)
        Intersecting pairs, sorted by ``ia`` then ``ib``.
    """
    amin = np.asarray(lower_a, dtype=float)
    amax = np.asarray(upper_a, dtype=float)
    bmin = np.asarray(lower_b, dtype=float)
    bmax = np.asarray(upper_b, dtype=float)
    empty = np.zeros(0, dtype=np.int64)
    if len(amin) == 0 or len(bmin) == 0:
        return empty, empty.copy()
    origin = np.minimum(amin.min(axis=0), bmin.min(axis=0))
    top = np.maximum(amax.max(axis=0), bmax.max(axis=0))
    span = float(np.max(top - origin))
    if cell_size is None:
        cell_size = float(
            np.sqrt(np.median((amax - amin).max(axis=1)) * np.median((bmax - bmin).max(axis=1)))
        )
    # keep the grid at most ~1e5 cells per axis (int64 keys) and the number of
    # (box, cell) entries within a budget (boxes much larger than the cells)
    h = max(cell_size, span * 1e-5, np.finfo(float).tiny)
    budget = max(32 * (len(amin) + len(bmin)), 100_000)
    ext = np.concatenate([amax - amin, bmax - bmin])
    while np.sum(np.prod(np.floor(ext / h) + 2.0, axis=1)) > budget and h < span:
        h *= 2.0

    def cell(p: FloatArray) -> IntArray:
        return np.floor((p - origin) / h).astype(np.int64)

    ncell = cell(top[None])[0] + 1
    stride = np.concatenate([np.cumprod(ncell[::-1][:-1])[::-1], [1]]).astype(np.int64)  # row-major

    ida, ca = _expand_cells(cell(amin), cell(amax))
    idb, cb = _expand_cells(cell(bmin), cell(bmax))
    ka = ca @ stride
    kb = cb @ stride
    order = np.argsort(kb, kind="stable")
    kb, idb = kb[order], idb[order]
    left = np.searchsorted(kb, ka, side="left")
    nmatch = np.searchsorted(kb, ka, side="right") - left
    pa = np.repeat(ida, nmatch)
    key = np.repeat(ka, nmatch)
    pos = np.repeat(left, nmatch) + (
        np.arange(nmatch.sum(), dtype=np.int64) - np.repeat(np.cumsum(nmatch) - nmatch, nmatch)
    )
    pb = idb[pos]
    lo = np.maximum(amin[pa], bmin[pb])
    ok = np.all(lo <= np.minimum(amax[pa], bmax[pb]), axis=1)
    ok &= cell(lo) @ stride == key  # report each pair once
    pa, pb = pa[ok], pb[ok]
    order = np.lexsort((pb, pa))
    return pa[order], pb[order]


# ----------------------------------------------------------------------------------
# Polygon clipping (Sutherland-Hodgman, padded arrays)
# ----------------------------------------------------------------------------------


def _clip_halfplane(poly: FloatArray, count: IntArray, dist: FloatArray) -> tuple[FloatArray, IntArray]:
    """Clip padded convex polygons by the half-planes ``dist >= 0``.

    Parameters
    ----------
    poly : (P, K, 2) vertices, valid for ``k < count``.
    count : (P,) number of valid vertices.
    dist : (P, K) signed distance (any positive scaling) of each vertex.

    Returns
    -------
    poly : (P, K + 1, 2), count : (P,)
    """
    n_poly, k_max, _ = poly.shape
    idx = np.arange(k_max)
    valid = idx[None, :] < count[:, None]
    nxt = np.where(idx[None, :] + 1 < count[:, None], idx[None, :] + 1, 0)
    p_next = np.take_along_axis(poly, nxt[:, :, None], axis=1)
    d_next = np.take_along_axis(dist, nxt, axis=1)
    inside = dist >= 0.0
    keep = valid & inside
    crossing = valid & (inside != (d_next >= 0.0))
    t = dist / np.where(crossing, dist - d_next, 1.0)
    inter = poly + t[:, :, None] * (p_next - poly)
    out = np.stack([poly, inter], axis=2).reshape(n_poly, 2 * k_max, 2)
    emit = np.stack([keep, crossing], axis=2).reshape(n_poly, 2 * k_max)
    order = np.argsort(~emit, axis=1, kind="stable")[:, : k_max + 1]
    out = np.take_along_axis(out, order[:, :, None], axis=1)
    return out, np.minimum(emit.sum(axis=1), k_max + 1)


def clip_polygons_by_triangles(
    subject: npt.ArrayLike, count: npt.ArrayLike, clip: npt.ArrayLike
) -> tuple[FloatArray, IntArray]:
    """Sutherland-Hodgman clipping of convex polygons by triangles (vectorised).

    Parameters
    ----------
    subject : array_like, shape (P, K, 2)
        Convex subject polygons (either orientation), padded to ``K`` vertices.
    count : array_like of int, shape (P,)
        Number of valid vertices of each subject polygon.
    clip : array_like, shape (P, 3, 2) or (3, 2)
        Clip triangles (either orientation).

    Returns
    -------
    poly : ndarray, shape (P, K + 3, 2)
        Intersection polygons, padded (entries beyond ``count`` are meaningless).
    count : ndarray of int64, shape (P,)
        Number of vertices (0 if the intersection is empty).
    """
    poly = np.asarray(subject, dtype=float)
    cnt = np.asarray(count, dtype=np.int64)
    tri = np.broadcast_to(np.asarray(clip, dtype=float), (poly.shape[0], 3, 2))
    orient = np.sign(_cross2(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]))
    for e in range(3):
        a = tri[:, e]
        edge = tri[:, (e + 1) % 3] - a
        dist = orient[:, None] * _cross2(edge[:, None, :], poly - a[:, None, :])
        poly, cnt = _clip_halfplane(poly, cnt, dist)
    return poly, cnt


def polygon_areas(poly: npt.ArrayLike, count: npt.ArrayLike) -> FloatArray:
    """Unsigned areas of padded simple polygons (shoelace formula).

    Parameters
    ----------
    poly : array_like, shape (P, K, 2)
    count : array_like of int, shape (P,)

    Returns
    -------
    ndarray, shape (P,)
    """
    poly = np.asarray(poly, dtype=float)
    cnt = np.asarray(count, dtype=np.int64)
    idx = np.arange(poly.shape[1])
    nxt = np.where(idx[None, :] + 1 < cnt[:, None], idx[None, :] + 1, 0)
    p_next = np.take_along_axis(poly, nxt[:, :, None], axis=1)
    terms = np.where(idx[None, :] < cnt[:, None], _cross2(poly, p_next), 0.0)
    return 0.5 * np.abs(terms.sum(axis=1))


def _fan_quadrature(poly: FloatArray, count: IntArray) -> tuple[FloatArray, FloatArray]:
    """Quadrature on padded convex polygons: centroid fan + 7-point rule.

    Returns
    -------
    points : (P, K * 7, 2) quadrature points.
    weights : (P, K * 7) weights (sum = polygon area; zero on padding).
    """
    n_poly, k_max, _ = poly.shape
    idx = np.arange(k_max)
    valid = idx[None, :] < count[:, None]
    centre = np.where(valid[:, :, None], poly, 0.0).sum(axis=1) / np.maximum(count, 1)[:, None]
    nxt = np.where(idx[None, :] + 1 < count[:, None], idx[None, :] + 1, 0)
    p_next = np.take_along_axis(poly, nxt[:, :, None], axis=1)
    c = centre[:, None, :]
    area = np.where(valid, 0.5 * np.abs(_cross2(poly - c, p_next - c)), 0.0)  # (P, K)
    bary, w = TRIANGLE_RULE
    points = (
        bary[None, None, :, 0, None] * c[:, :, None, :]
        + bary[None, None, :, 1, None] * poly[:, :, None, :]
        + bary[None, None, :, 2, None] * p_next[:, :, None, :]
    )
    weights = area[:, :, None] * w[None, None, :]
    return points.reshape(n_poly, -1, 2), weights.reshape(n_poly, -1)


# ----------------------------------------------------------------------------------
# Projections
# ----------------------------------------------------------------------------------


def project_points_to_segments_interpolated_normal(
    points: npt.ArrayLike,
    x1: npt.ArrayLike,
    x2: npt.ArrayLike,
    n1: npt.ArrayLike,
    n2: npt.ArrayLike,
) -> FloatArray:
    """Project 2D points onto slave segments along the interpolated nodal normal.

    Solves ``(x(xi) - p) x n(xi) = 0`` with ``x(xi) = (1-xi) x1 + xi x2`` and
    ``n(xi) = (1-xi) n1 + xi n2`` -- a quadratic in ``xi``, solved in closed form
    (cancellation-free).  Of two real roots the one nearest the segment centre
    is returned.

    Parameters
    ----------
    points, x1, x2, n1, n2 : array_like, shape (P, 2)

    Returns
    -------
    ndarray, shape (P,)
        Slave parameter ``xi`` (NaN where no real solution exists).
    """
    p = np.asarray(points, dtype=float)
    a0 = np.asarray(x1, dtype=float) - p
    a1 = np.asarray(x2, dtype=float) - np.asarray(x1, dtype=float)
    b0 = np.asarray(n1, dtype=float)
    b1 = np.asarray(n2, dtype=float) - b0
    c0 = _cross2(a0, b0)
    c1 = _cross2(a0, b1) + _cross2(a1, b0)
    c2 = _cross2(a1, b1)
    disc = c1 * c1 - 4.0 * c2 * c0
    with np.errstate(divide="ignore", invalid="ignore"):
        q = -0.5 * (c1 + np.copysign(np.sqrt(np.maximum(disc, 0.0)), c1))
        r1 = q / c2
        r2 = c0 / q
    r1 = np.where(np.isfinite(r1), r1, np.inf)
    r2 = np.where(np.isfinite(r2), r2, np.inf)
    xi = np.where(np.abs(r1 - 0.5) < np.abs(r2 - 0.5), r1, r2)
    return np.where((disc >= 0.0) & np.isfinite(xi), xi, np.nan)


def project_points_to_lines_along_directions(
    points: npt.ArrayLike, directions: npt.ArrayLike, y1: npt.ArrayLike, y2: npt.ArrayLike
) -> FloatArray:
    """Intersect the 2D lines ``x + s d`` with the lines through ``y1, y2``.

    Used for the slave-to-master projection (a slave point along its
    (interpolated) normal onto a master segment).

    Parameters
    ----------
    points, directions : array_like, shape (..., 2)
    y1, y2 : array_like, shape (..., 2)
        Master segment end points (broadcast against ``points``).

    Returns
    -------
    ndarray, shape (...)
        Master parameter ``eta`` with intersection ``(1-eta) y1 + eta y2`` (inf/NaN
        when the direction is parallel to the segment).
    """
    x = np.asarray(points, dtype=float)
    d = np.asarray(directions, dtype=float)
    y1 = np.asarray(y1, dtype=float)
    y2 = np.asarray(y2, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return _cross2(x - y1, d) / _cross2(y2 - y1, d)


# ----------------------------------------------------------------------------------
# Segment-based integration
# ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class PairIntegrals:
    """Local mortar integrals of slave/master facet pairs over their overlap.

    Attributes
    ----------
    area : ndarray, shape (P,)
        Measure of the overlap (mortar segment) on the slave facet.
    d : ndarray, shape (P, nv, nv)
        ``int psi_j phi_k`` (slave x slave).  Diagonal (``d_diag``) on fully
        covered unmodified facets once summed over the facet's pairs.
    m : ndarray, shape (P, nv, nv)
        ``int psi_j (phi^m_k o Pi)`` (slave x master).
    gap : ndarray, shape (P, nv)
        ``int psi_j g``.
    """

    area: FloatArray
    d: FloatArray
    m: FloatArray
    gap: FloatArray

    @property
    def d_diag(self) -> FloatArray:
        """``D_e`` diagonal, shape (P, nv)."""
        return np.diagonal(self.d, axis1=1, axis2=2).copy()


def _coeffs_for(coeffs: npt.ArrayLike | None, n_pairs: int, nv: int) -> FloatArray:
    """Per-pair dual coefficient matrices (closed form if ``coeffs`` is None)."""
    if coeffs is None:
        return np.broadcast_to(reference_dual_coefficients(nv), (n_pairs, nv, nv))
    return np.broadcast_to(np.asarray(coeffs, dtype=float), (n_pairs, nv, nv))


def _integrals(
    weights: FloatArray,
    phi_s: FloatArray,
    phi_m: FloatArray,
    gap: FloatArray,
    coeffs: FloatArray,
) -> PairIntegrals:
    """Contract quadrature data (P, Q, ...) into :class:`PairIntegrals`."""
    psi = np.matmul(phi_s, np.swapaxes(coeffs, 1, 2))  # (P, Q, nv)
    wpsi_t = np.swapaxes(weights[:, :, None] * psi, 1, 2)  # (P, nv, Q)
    return PairIntegrals(
        area=weights.sum(axis=1),
        d=np.matmul(wpsi_t, phi_s),
        m=np.matmul(wpsi_t, phi_m),
        gap=np.matmul(wpsi_t, gap[:, :, None])[:, :, 0],
    )


def integrate_segment_pairs(
    slave: npt.ArrayLike,
    slave_normals: npt.ArrayLike,
    master: npt.ArrayLike,
    coeffs: npt.ArrayLike | None = None,
) -> PairIntegrals:
    """2D segment-based mortar integrals for slave/master segment pairs.

    The master end points are projected onto the slave segment along the
    interpolated slave normal (quadratic, closed form); their images bound the
    overlap interval ``[xi_a, xi_b] ∩ [0, 1]``.  A 3-point Gauss rule on it
    (exact for ``psi phi`` products) gives the slave values; at each Gauss point
    the slave point is projected along its interpolated normal onto the master
    segment (linear) for ``phi^m`` and the gap.

    Parameters
    ----------
    slave : array_like, shape (P, 2, 2)
        Slave segment vertex coordinates.
    slave_normals : array_like, shape (P, 2, 2)
        Averaged nodal normals at the slave segment's vertices.
    master : array_like, shape (P, 2, 2)
        Master segment vertex coordinates.
    coeffs : array_like, shape (P, 2, 2) or (2, 2), optional
        Dual coefficients of the slave segments (default: closed form).

    Returns
    -------
    PairIntegrals
        Zero contributions for pairs without overlap.
    """
    xs = np.asarray(slave, dtype=float)
    ns = np.asarray(slave_normals, dtype=float)
    xm = np.asarray(master, dtype=float)
    n_pairs = xs.shape[0]
    x1, x2 = xs[:, 0], xs[:, 1]
    n1, n2 = ns[:, 0], ns[:, 1]
    xi_ends = np.stack(
        [project_points_to_segments_interpolated_normal(xm[:, k], x1, x2, n1, n2) for k in range(2)],
        axis=1,
    )
    lo = np.clip(np.min(xi_ends, axis=1), 0.0, 1.0)
    hi = np.clip(np.max(xi_ends, axis=1), 0.0, 1.0)
    width = np.where(np.isfinite(hi - lo), np.maximum(hi - lo, 0.0), 0.0)
    lo = np.where(np.isfinite(lo), lo, 0.0)
    length = np.linalg.norm(x2 - x1, axis=1)

    t, w = GAUSS_SEGMENT
    xi = lo[:, None] + width[:, None] * t[None, :]  # (P, 3)
    weights = (width * length)[:, None] * w[None, :]
    phi_s = shape_segment(xi)
    x = x1[:, None] + xi[:, :, None] * (x2 - x1)[:, None]
    n = n1[:, None] + xi[:, :, None] * (n2 - n1)[:, None]
    eta = project_points_to_lines_along_directions(x, n, xm[:, None, 0], xm[:, None, 1])
    eta = np.where(weights > 0.0, eta, 0.0)
    phi_m = shape_segment(eta)
    y = xm[:, None, 0] + eta[:, :, None] * (xm[:, 1] - xm[:, 0])[:, None]
    gap = np.einsum("pqg,pqg->pq", y - x, _normalise(n))
    return _integrals(weights, phi_s, phi_m, gap, _coeffs_for(coeffs, n_pairs, 2))


def integrate_triangle_pairs(
    slave: npt.ArrayLike,
    slave_normals: npt.ArrayLike,
    master: npt.ArrayLike,
    coeffs: npt.ArrayLike | None = None,
) -> PairIntegrals:
    """3D segment-based mortar integrals for slave/master triangle pairs.

    The master triangle is projected into the slave triangle's plane along the
    slave facet normal and expressed in the slave's reference coordinates; it is
    clipped against the reference triangle (Sutherland-Hodgman), the polygon
    (at most 6 vertices) is fan-triangulated from its vertex centroid and
    integrated with the 7-point degree-5 rule.  Master barycentric coordinates of
    the quadrature points are those w.r.t. the projected master triangle (the
    projection is affine), the gap is measured along the normalised interpolated
    slave nodal normal.

    Parameters
    ----------
    slave : array_like, shape (P, 3, 3)
        Slave triangle vertex coordinates.
    slave_normals : array_like, shape (P, 3, 3)
        Averaged nodal normals at the slave triangle's vertices.
    master : array_like, shape (P, 3, 3)
        Master triangle vertex coordinates.
    coeffs : array_like, shape (P, 3, 3) or (3, 3), optional
        Dual coefficients of the slave triangles (default: closed form).

    Returns
    -------
    PairIntegrals
        Zero contributions for pairs without overlap.
    """
    xs = np.asarray(slave, dtype=float)
    ns = np.asarray(slave_normals, dtype=float)
    xm = np.asarray(master, dtype=float)
    n_pairs = xs.shape[0]
    all_coeffs = _coeffs_for(coeffs, n_pairs, 3)
    x0 = xs[:, 0]
    a1 = xs[:, 1] - x0
    a2 = xs[:, 2] - x0
    g11 = np.sum(a1 * a1, axis=1)
    g12 = np.sum(a1 * a2, axis=1)
    g22 = np.sum(a2 * a2, axis=1)
    det_s = g11 * g22 - g12 * g12
    inv_det = 1.0 / np.where(det_s > 0.0, det_s, 1.0)
    # master vertices -> slave reference coordinates (orthogonal projection)
    rel_m = xm - x0[:, None]
    b1 = np.sum(rel_m * a1[:, None], axis=2)
    b2 = np.sum(rel_m * a2[:, None], axis=2)
    mref = np.stack(
        [
            (g22[:, None] * b1 - g12[:, None] * b2) * inv_det[:, None],
            (g11[:, None] * b2 - g12[:, None] * b1) * inv_det[:, None],
        ],
        axis=-1,
    )  # (P, 3, 2)

    live = np.flatnonzero((det_s > 0.0) & _triangles_may_overlap(mref))
    result = PairIntegrals(
        area=np.zeros(n_pairs),
        d=np.zeros((n_pairs, 3, 3)),
        m=np.zeros((n_pairs, 3, 3)),
        gap=np.zeros((n_pairs, 3)),
    )
    if len(live) == 0:
        return result
    mref_l = mref[live]
    e1 = mref_l[:, 1] - mref_l[:, 0]
    e2 = mref_l[:, 2] - mref_l[:, 0]
    det_m = _cross2(e1, e2)
    scale = np.sqrt(np.sum(e1 * e1, axis=1) * np.sum(e2 * e2, axis=1))
    usable = np.abs(det_m) > 1e-12 * scale
    poly, count = clip_polygons_by_triangles(mref_l, np.where(usable, 3, 0), _REF_TRIANGLE)
    area_ref = polygon_areas(poly, count)
    keep = usable & (count >= 3) & (area_ref > 0.0)
    live, poly, count = live[keep], poly[keep], count[keep]
    mref_l, e1, e2, det_m = mref_l[keep], e1[keep], e2[keep], det_m[keep]

    qp, wref = _fan_quadrature(poly, count)
    weights = wref * np.sqrt(det_s[live])[:, None]  # 2 |T_s| = sqrt(det G)
    phi_s = shape_triangle(qp)  # (L, Q, 3)
    rel = qp - mref_l[:, None, 0]
    l1 = _cross2(rel, e2[:, None]) / det_m[:, None]
    l2 = _cross2(e1[:, None], rel) / det_m[:, None]
    phi_m = np.stack([1.0 - l1 - l2, l1, l2], axis=-1)

    x = x0[live, None] + qp[..., 0:1] * a1[live, None] + qp[..., 1:2] * a2[live, None]
    y = np.matmul(phi_m, xm[live])
    n = _normalise(np.matmul(phi_s, ns[live]))
    gap = np.sum((y - x) * n, axis=-1)
    part = _integrals(weights, phi_s, phi_m, gap, all_coeffs[live])
    result.area[live] = part.area
    result.d[live] = part.d
    result.m[live] = part.m
    result.gap[live] = part.gap
    return result


_REF_TRIANGLE: FloatArray = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])


def _triangles_may_overlap(tri: FloatArray) -> BoolArray:
    """Separating-axis test of triangles against the reference triangle.

    Parameters
    ----------
    tri : (P, 3, 2) triangles in reference coordinates.

    Returns
    -------
    (P,) bool, False where the triangle is certainly disjoint from (or only
    touches) the reference triangle.
    """
    xi, eta = tri[..., 0], tri[..., 1]
    out = (xi.max(axis=1) <= 0.0) | (eta.max(axis=1) <= 0.0) | ((xi + eta).min(axis=1) >= 1.0)
    # edges of the subject triangle as separating axes
    orient = np.sign(_cross2(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]))
    for e in range(3):
        a = tri[:, e]
        edge = tri[:, (e + 1) % 3] - a
        dist = orient[:, None] * _cross2(edge[:, None, :], _REF_TRIANGLE[None] - a[:, None, :])
        out |= dist.max(axis=1) <= 0.0
    return ~out


# ----------------------------------------------------------------------------------
# Pairs and assembly
# ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class MortarPairs:
    """Overlapping slave/master facet pairs with their local integrals.

    Attributes
    ----------
    slave_facet, master_facet : ndarray of int64, shape (P,)
        Facet indices into the slave / master facet arrays.
    integrals : PairIntegrals
        Local ``D_e``, ``M_e``, weighted gap and overlap measure.
    """

    slave_facet: IntArray
    master_facet: IntArray
    integrals: PairIntegrals


def _default_search_radius(coords: FloatArray, facets: IntArray) -> float:
    """Mean facet diameter (used as default contact search radius)."""
    if len(facets) == 0:
        return 0.0
    x = coords[facets]
    diam = np.linalg.norm(x[:, :, None, :] - x[:, None, :, :], axis=-1).max(axis=(1, 2))
    return float(diam.mean())


def compute_mortar_pairs(
    slave_coords: npt.ArrayLike,
    slave_facets: npt.ArrayLike,
    slave_normals: npt.ArrayLike,
    master_coords: npt.ArrayLike,
    master_facets: npt.ArrayLike,
    *,
    search_radius: float | None = None,
    dual_coeffs: npt.ArrayLike | None = None,
    chunk_size: int = 50_000,
) -> MortarPairs:
    """Candidate search and segment-based integration for all facet pairs.

    Parameters
    ----------
    slave_coords : array_like, shape (n_s, gdim)
    slave_facets : array_like of int, shape (f_s, gdim)
    slave_normals : array_like, shape (n_s, gdim)
        Averaged outward nodal normals of the slave surface.
    master_coords : array_like, shape (n_m, gdim)
    master_facets : array_like of int, shape (f_m, gdim)
    search_radius : float, optional
        Slave facet boxes are enlarged by this distance before intersecting them
        with master facet boxes (must exceed the largest gap of interest); default
        the mean slave facet diameter.  Every candidate whose projection
        overlaps is integrated: choose the radius so that no facet of the far
        side of a thin body is within reach.
    dual_coeffs : array_like, shape (f_s, nv, nv), optional
        Per-slave-facet dual coefficients (default: closed form).
    chunk_size : int
        Maximum number of pairs integrated at once (bounds memory).

    Returns
    -------
    MortarPairs
        Only pairs with a positive overlap measure.
    """
    xs = np.asarray(slave_coords, dtype=float)
    fs = np.asarray(slave_facets, dtype=np.int64).reshape(-1, xs.shape[1])
    ns = np.asarray(slave_normals, dtype=float)
    xm = np.asarray(master_coords, dtype=float)
    fm = np.asarray(master_facets, dtype=np.int64).reshape(-1, xm.shape[1])
    gdim = xs.shape[1]
    nv = fs.shape[1]
    if gdim not in (2, 3) or nv != gdim:
        raise ValueError("expected segments in 2D or triangles in 3D")
    if search_radius is None:
        search_radius = _default_search_radius(xs, fs)
    coeffs = (
        None if dual_coeffs is None else np.broadcast_to(np.asarray(dual_coeffs, float), (len(fs), nv, nv))
    )

    ia, ib = find_candidate_pairs(*facet_bounding_boxes(xs, fs, search_radius), *facet_bounding_boxes(xm, fm))
    integrate = integrate_segment_pairs if gdim == 2 else integrate_triangle_pairs
    parts: list[tuple[IntArray, IntArray, PairIntegrals]] = []
    for start in range(0, len(ia), chunk_size):
        sa, sb = ia[start : start + chunk_size], ib[start : start + chunk_size]
        res = integrate(xs[fs[sa]], ns[fs[sa]], xm[fm[sb]], None if coeffs is None else coeffs[sa])
        keep = res.area > 0.0
        parts.append(
            (sa[keep], sb[keep], PairIntegrals(res.area[keep], res.d[keep], res.m[keep], res.gap[keep]))
        )
    if not parts:
        z = np.zeros(0, dtype=np.int64)
        return MortarPairs(
            z,
            z.copy(),
            PairIntegrals(np.zeros(0), np.zeros((0, nv, nv)), np.zeros((0, nv, nv)), np.zeros((0, nv))),
        )
    return MortarPairs(
        np.concatenate([p[0] for p in parts]),
        np.concatenate([p[1] for p in parts]),
        PairIntegrals(
            *(np.concatenate([getattr(p[2], f) for p in parts]) for f in ("area", "d", "m", "gap"))
        ),
    )


@dataclass(frozen=True)
class MortarContributions:
    """Local (per-rank) mortar contributions as COO triplets and nodal vectors.

    Node ids are local indices into the slave / master coordinate arrays passed
    to :func:`assemble_mortar`; each block multiplies the ``gdim x gdim``
    identity (SPEC §4.2).

    Attributes
    ----------
    m_rows, m_cols : ndarray of int64
        Slave node / master node of each ``M`` entry (duplicates already summed).
    m_vals : ndarray of float
    d : ndarray, shape (n_slave_vertices,)
        Diagonal ``D[p, p] = int psi_p phi_p`` over the covered part of the slave
        surface (``= int phi_p`` on fully covered nodes).
    gap : ndarray, shape (n_slave_vertices,)
        Weighted gap ``d_p = int psi_p g``.
    covered_area : ndarray, shape (n_slave_facets,)
        Measure of the part of each slave facet covered by master projections.
    facet_area : ndarray, shape (n_slave_facets,)
        Measure of each slave facet.
    d_off_rows, d_off_cols, d_off_vals : ndarray
        Off-diagonal ``D`` entries (slave node, slave node), only from facets that
        are partially covered or carry masked (boundary-modified) nodes.  With a
        node mask, ``d_off`` couples free nodes to masked nodes; a caller that
        treats masked nodes like master nodes subtracts these into ``M``.
    pairs : MortarPairs
        The per-pair local contributions they were assembled from.
    """

    m_rows: IntArray
    m_cols: IntArray
    m_vals: FloatArray
    d: FloatArray
    gap: FloatArray
    covered_area: FloatArray
    facet_area: FloatArray
    d_off_rows: IntArray
    d_off_cols: IntArray
    d_off_vals: FloatArray
    pairs: MortarPairs

    def fully_covered_facets(self, rtol: float = 1e-10) -> BoolArray:
        """Slave facets whose covered measure equals their measure (to ``rtol``)."""
        return self.covered_area >= (1.0 - rtol) * self.facet_area

    def fully_covered_nodes(self, slave_facets: npt.ArrayLike, rtol: float = 1e-10) -> BoolArray:
        """Slave nodes all of whose facets are fully covered (and that have a facet)."""
        fs = np.asarray(slave_facets, dtype=np.int64)
        n = len(self.d)
        bad = np.bincount(fs[~self.fully_covered_facets(rtol)].ravel(), minlength=n) > 0
        used = np.bincount(fs.ravel(), minlength=n) > 0
        return used & ~bad


def _sum_duplicates(
    rows: IntArray, cols: IntArray, vals: FloatArray, n_cols: int
) -> tuple[IntArray, IntArray, FloatArray]:
    """Sum COO entries with equal (row, col); result sorted by row, then col."""
    if len(rows) == 0:
        return rows, cols, vals
    key = rows * np.int64(max(n_cols, 1)) + cols
    uniq, inv = np.unique(key, return_inverse=True)
    return uniq // max(n_cols, 1), uniq % max(n_cols, 1), np.bincount(inv, weights=vals)


def assemble_mortar(
    slave_coords: npt.ArrayLike,
    slave_facets: npt.ArrayLike,
    slave_normals: npt.ArrayLike,
    master_coords: npt.ArrayLike,
    master_facets: npt.ArrayLike,
    *,
    search_radius: float | None = None,
    slave_node_mask: npt.ArrayLike | None = None,
    dual_coeffs: npt.ArrayLike | None = None,
    coverage_rtol: float = 1e-10,
) -> MortarContributions:
    """Assemble the local mortar matrices ``D``, ``M`` and the weighted gap.

    Parameters
    ----------
    slave_coords : array_like, shape (n_s, gdim)
    slave_facets : array_like of int, shape (f_s, gdim)
        Slave facets this rank integrates (normally the owned ones).
    slave_normals : array_like, shape (n_s, gdim)
        Averaged outward nodal normals (:func:`nodal_normals`).
    master_coords : array_like, shape (n_m, gdim)
    master_facets : array_like of int, shape (f_m, gdim)
    search_radius : float, optional
        See :func:`compute_mortar_pairs`.
    slave_node_mask : array_like of bool, shape (n_s,), optional
        Slave nodes where the multiplier must vanish; the dual basis is modified
        accordingly (:func:`modify_dual_coefficients`).
    dual_coeffs : array_like, shape (f_s, nv, nv) or (nv, nv), optional
        Dual coefficients before the mask is applied (default: closed form).
    coverage_rtol : float
        Relative tolerance deciding that a slave facet is fully covered.

    Returns
    -------
    MortarContributions
    """
    xs = np.asarray(slave_coords, dtype=float)
    gdim = xs.shape[1]
    fs = np.asarray(slave_facets, dtype=np.int64).reshape(-1, gdim)
    fm = np.asarray(master_facets, dtype=np.int64).reshape(-1, gdim)
    n_s = xs.shape[0]
    n_m = np.asarray(master_coords).shape[0]
    nv = gdim

    coeffs = None
    facet_mask = np.zeros(fs.shape, dtype=bool)
    if dual_coeffs is not None:
        coeffs = np.broadcast_to(np.asarray(dual_coeffs, dtype=float), (len(fs), nv, nv))
    if slave_node_mask is not None:
        facet_mask = np.asarray(slave_node_mask, dtype=bool)[fs]
        base = coeffs if coeffs is not None else reference_dual_coefficients(nv)
        coeffs = modify_dual_coefficients(base, facet_mask)

    pairs = compute_mortar_pairs(
        xs, fs, slave_normals, master_coords, fm, search_radius=search_radius, dual_coeffs=coeffs
    )
    integ = pairs.integrals
    sf, mf = pairs.slave_facet, pairs.master_facet
    srows = fs[sf]  # (P, nv)

    m_rows = np.repeat(srows, nv, axis=1).ravel()
    m_cols = np.tile(fm[mf], (1, nv)).ravel()
    m_rows, m_cols, m_vals = _sum_duplicates(m_rows, m_cols, integ.m.ravel(), n_m)

    d = np.bincount(srows.ravel(), weights=integ.d_diag.ravel(), minlength=n_s)
    gap = np.bincount(srows.ravel(), weights=integ.gap.ravel(), minlength=n_s)
    covered = np.bincount(sf, weights=integ.area, minlength=len(fs))
    facet_area = _simplex_measure(xs[fs]) if len(fs) else np.zeros(0)

    # off-diagonal D on partially covered or boundary-modified facets
    d_facet = np.zeros((len(fs), nv, nv))
    np.add.at(d_facet, sf, integ.d)
    special = (covered < (1.0 - coverage_rtol) * facet_area) | facet_mask.any(axis=1)
    off = ~np.eye(nv, dtype=bool)
    sel = special[:, None, None] & off[None] & (d_facet != 0.0)
    f_idx, j_idx, k_idx = np.nonzero(sel)
    d_off_rows, d_off_cols, d_off_vals = _sum_duplicates(
        fs[f_idx, j_idx], fs[f_idx, k_idx], d_facet[f_idx, j_idx, k_idx], n_s
    )
    return MortarContributions(
        m_rows=m_rows,
        m_cols=m_cols,
        m_vals=m_vals,
        d=d,
        gap=gap,
        covered_area=covered,
        facet_area=facet_area,
        d_off_rows=d_off_rows,
        d_off_cols=d_off_cols,
        d_off_vals=d_off_vals,
        pairs=pairs,
    )
