"""Segment-based integration of the mortar matrices D, M and the weighted gap, pure NumPy.

Everything works on plain coordinate / connectivity arrays and is vectorised over
candidate pairs and quadrature points; there is no DOLFINx or MPI dependency, so on a
parallel run every rank calls :func:`assemble_mortar` on its own (local) slave facets
and on whatever master facets it can see, and inserts the returned COO triplets into
distributed PETSc matrices.  2D: overlap of projected segments; 3D: the master
triangle projected into the slave triangle's plane and clipped; exact polygon moments
for D and M, the 7-point rule on a fan of the polygon for the gap.

The gap is ``g = (x_master - x_slave) . n`` with ``n`` the normalised interpolation of
the slave nodal normals (``g >= 0`` means separated, docs/theory/mortar.md#contact-conditions).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from bonecontact.common.geometry import cross2
from bonecontact.contact.clipping import (
    clip_polygons_by_triangles,
    fan_triangle_quadrature,
    polygon_areas,
    polygon_moments,
    project_points_to_lines_along_directions,
    project_points_to_segments_interpolated_normal,
)
from bonecontact.contact.dual_basis import (
    GAUSS_SEGMENT,
    dual_coefficients_from_mass,
    modify_dual_coefficients,
    reference_dual_coefficients,
    shape_segment,
)
from bonecontact.contact.geometry import BoolArray, FloatArray, IntArray, normalise, simplex_measure
from bonecontact.contact.search import (
    facet_bounding_boxes,
    find_candidate_pairs,
    swept_facet_boxes,
)

__all__ = [
    "MortarContributions",
    "MortarPairs",
    "PairIntegrals",
    "assemble_mortar",
    "coincident_pairs",
    "compute_mortar_pairs",
    "integrate_segment_pairs",
    "integrate_triangle_pairs",
]

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
        ``int psi_j phi_k`` (slave x slave).  Diagonal (``d_diag``) on unmodified
        facets once summed over the facet's pairs (dual basis of the covered part).
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
        [
            project_points_to_segments_interpolated_normal(xm[:, k], x1, x2, n1, n2)
            for k in range(2)
        ],
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
    gap = np.einsum("pqg,pqg->pq", y - x, normalise(n))
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
    clipped against the reference triangle (Sutherland-Hodgman), giving a convex
    polygon of at most 6 vertices.  The master shape functions composed with the
    projection are affine in the slave reference coordinates (barycentric
    coordinates in the projected master triangle), so ``D`` and ``M`` (quadratic
    integrands) follow exactly from the polygon's moments up to order 2.  The gap,
    measured along the normalised interpolated slave nodal normal, is not a
    polynomial: it is integrated on the fan of triangles from the polygon's vertex
    centroid with the 7-point degree-5 rule, from two quadratics (``(y - x) . n``
    and ``|n|^2``) formed once per pair.  Vectorised over all pairs.

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
    det_m = cross2(e1, e2)
    scale = np.sqrt(np.sum(e1 * e1, axis=1) * np.sum(e2 * e2, axis=1))
    usable = np.abs(det_m) > 1e-12 * scale
    poly, count = clip_polygons_by_triangles(mref_l, np.where(usable, 3, 0), _REF_TRIANGLE)
    area_ref = polygon_areas(poly, count)
    keep = usable & (count >= 3) & (area_ref > 0.0)
    live, poly, count = live[keep], poly[keep], count[keep]
    mref_l, e1, e2, det_m = mref_l[keep], e1[keep], e2[keep], det_m[keep]

    jac = np.sqrt(det_s[live])  # 2 |T_s| = sqrt(det G): reference area -> area
    # phi^m o Pi is affine in the slave reference coordinates: phi^m = B (1, xi, eta)
    b_m = _master_shape_coefficients(mref_l[:, 0], e1, e2, det_m)  # (L, 3, 3)
    # psi phi and psi phi^m are quadratic: exact polygon moments S = int b b^T
    moments = polygon_moments(poly, count) * jac[:, None, None]
    coeffs_l = all_coeffs[live]
    psi_b = np.matmul(coeffs_l, _SHAPE_COEFFS)  # psi = psi_b (1, xi, eta)
    psi_s = np.matmul(psi_b, moments)  # (L, 3, 3): int psi_j b_l
    gap_moments = _gap_moments(poly, count, x0[live], a1[live], a2[live], xm[live], ns[live], b_m)
    result.area[live] = moments[:, 0, 0]
    result.d[live] = np.matmul(psi_s, _SHAPE_COEFFS.T)
    result.m[live] = np.matmul(psi_s, np.swapaxes(b_m, 1, 2))
    result.gap[live] = np.matmul(psi_b, (gap_moments * jac[:, None])[:, :, None])[:, :, 0]
    return result


#: P1 shape functions on the reference triangle as ``phi = _SHAPE_COEFFS (1, xi, eta)``.
_SHAPE_COEFFS: FloatArray = np.array([[1.0, -1.0, -1.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


def _master_shape_coefficients(
    m0: FloatArray, e1: FloatArray, e2: FloatArray, det_m: FloatArray
) -> FloatArray:
    """Barycentric coordinates of the projected master triangle (vertex ``m0``, edges
    ``e1``, ``e2``, ``det_m = e1 x e2``) as affine functions ``B (1, xi, eta)``.

    Returns
    -------
    (P, 3, 3) the rows of ``B`` for the master vertices 0, 1, 2.
    """
    inv = 1.0 / det_m
    l1 = np.stack([m0[:, 1] * e2[:, 0] - m0[:, 0] * e2[:, 1], e2[:, 1], -e2[:, 0]], axis=1)
    l2 = np.stack([m0[:, 0] * e1[:, 1] - m0[:, 1] * e1[:, 0], -e1[:, 1], e1[:, 0]], axis=1)
    l1, l2 = l1 * inv[:, None], l2 * inv[:, None]
    l0 = np.array([1.0, 0.0, 0.0])[None, :] - l1 - l2
    return np.stack([l0, l1, l2], axis=1)


def _gap_moments(
    poly: FloatArray,
    count: IntArray,
    x0: FloatArray,
    a1: FloatArray,
    a2: FloatArray,
    xm: FloatArray,
    ns: FloatArray,
    b_m: FloatArray,
) -> FloatArray:
    """``int (1, xi, eta) g`` over each clipped polygon (reference measure).

    ``y - x`` (master point opposite minus slave point) and the interpolated nodal
    normal ``n`` are affine in the slave reference coordinates, so ``(y - x) . n`` and
    ``|n|^2`` are quadratics whose coefficients are formed once per pair; the gap
    ``g = (y - x) . n / |n|`` (zero where ``n = 0``) is integrated with the centroid-fan
    7-point rule.

    Returns
    -------
    (L, 3)
    """
    # y - x = c0 + xi c1 + eta c2;  n = n0 + xi n1 + eta n2
    y_coef = np.matmul(np.swapaxes(b_m, 1, 2), xm)  # (L, 3 (1, xi, eta), 3 (xyz))
    c = y_coef - np.stack([x0, a1, a2], axis=1)
    n = np.stack([ns[:, 0], ns[:, 1] - ns[:, 0], ns[:, 2] - ns[:, 0]], axis=1)
    # quadratic coefficients (1, xi, eta, xi^2, xi eta, eta^2) of (y - x).n and |n|^2
    num = _product_quadratic(c, n)
    den = _product_quadratic(n, n)
    owner, qp, w = fan_triangle_quadrature(poly, count)  # (T, 7, 2), (T, 7)
    xi, eta = qp[..., 0], qp[..., 1]
    basis = np.stack([np.ones_like(xi), xi, eta, xi * xi, xi * eta, eta * eta], axis=-1)
    p = np.einsum("tqk,tk->tq", basis, num[owner])
    q = np.einsum("tqk,tk->tq", basis, den[owner])
    g = np.divide(p, np.sqrt(np.maximum(q, 0.0)), out=np.zeros_like(p), where=q > 0.0)
    wg = w * g
    per_triangle = np.stack([wg.sum(axis=1), (wg * xi).sum(axis=1), (wg * eta).sum(axis=1)], 1)
    starts = np.concatenate([[0], np.cumsum(count)[:-1]])
    return np.add.reduceat(per_triangle, starts, axis=0)


def _product_quadratic(u: FloatArray, v: FloatArray) -> FloatArray:
    """Coefficients ``(1, xi, eta, xi^2, xi eta, eta^2)`` of ``u . v`` for affine vector
    fields ``u = u0 + xi u1 + eta u2`` and ``v`` likewise, given as (P, 3, gdim)."""
    dot = np.einsum("pig,pjg->pij", u, v)
    return np.stack(
        [
            dot[:, 0, 0],
            dot[:, 0, 1] + dot[:, 1, 0],
            dot[:, 0, 2] + dot[:, 2, 0],
            dot[:, 1, 1],
            dot[:, 1, 2] + dot[:, 2, 1],
            dot[:, 2, 2],
        ],
        axis=1,
    )


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
    orient = np.sign(cross2(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]))
    for e in range(3):
        a = tri[:, e]
        edge = tri[:, (e + 1) % 3] - a
        dist = orient[:, None] * cross2(edge[:, None, :], _REF_TRIANGLE[None] - a[:, None, :])
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
    timings : dict
        Wall time (s) of the phases: ``search`` (candidate pairs), ``integrate``
        (projection, clipping, quadrature) and, once assembled, ``assemble``.
    candidates : int
        Number of candidate pairs the search returned.
    """

    slave_facet: IntArray
    master_facet: IntArray
    integrals: PairIntegrals
    timings: dict[str, float] = field(default_factory=dict)
    candidates: int = 0


def _default_search_radius(coords: FloatArray, facets: IntArray) -> float:
    """Mean facet diameter (used as default contact search radius)."""
    if len(facets) == 0:
        return 0.0
    x = coords[facets]
    diam = np.linalg.norm(x[:, :, None, :] - x[:, None, :, :], axis=-1).max(axis=(1, 2))
    return float(diam.mean())


def coincident_pairs(
    slave_x: npt.NDArray[np.float64], master_x: npt.NDArray[np.float64], tol: float
) -> BoolArray:
    """Which facet pairs ``(p, nv, gdim)`` lie on each other: every slave vertex within
    ``tol`` (m) of a vertex of the master facet.

    Two faces duplicated node by node pair only so: along the averaged nodal normals a
    facet next to a sharp kink of a crack also overlaps the adjacent facet of the other
    leg, and the default search reaches the opposite face of a leg a few facets away
    (a nodal gap of -2.7 mm between coincident faces of a grown crack)."""
    d = np.linalg.norm(slave_x[:, :, None, :] - master_x[:, None, :, :], axis=-1)
    return np.all(d.min(axis=2) <= tol, axis=1)


def _candidates(
    xs: FloatArray,
    fs: IntArray,
    ns: FloatArray,
    xm: FloatArray,
    fm: IntArray,
    search_radius: float | npt.ArrayLike,
    coincident: float | None,
) -> tuple[IntArray, IntArray]:
    """Candidate (slave, master) facet pairs of :func:`compute_mortar_pairs`."""
    ia, ib = find_candidate_pairs(
        *swept_facet_boxes(xs, fs, search_radius, ns if xs.shape[1] == 2 else None),
        *facet_bounding_boxes(xm, fm),
    )
    if coincident is not None:  # (a crack's faces)
        keep = coincident_pairs(xs[fs[ia]], xm[fm[ib]], coincident)
        ia, ib = ia[keep], ib[keep]
    return ia, ib


def compute_mortar_pairs(
    slave_coords: npt.ArrayLike,
    slave_facets: npt.ArrayLike,
    slave_normals: npt.ArrayLike,
    master_coords: npt.ArrayLike,
    master_facets: npt.ArrayLike,
    *,
    search_radius: float | npt.ArrayLike | None = None,
    dual_coeffs: npt.ArrayLike | None = None,
    chunk_size: int = 50_000,
    coincident: float | None = None,
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
    search_radius : float or array_like, shape (f_s,), optional
        Search distance along the slave normals, one for all slave facets or one per
        facet (must exceed the largest gap of interest); default the mean slave facet
        diameter.  A master facet is a candidate when its bounding box meets the box of
        the slave facet swept along its normal over ``[-r, r]``
        (:func:`~bonecontact.contact.search.swept_facet_boxes`).  Every candidate whose
        projection overlaps is integrated: choose the radius so that no facet of the
        far side of a thin body is within reach.
    dual_coeffs : array_like, shape (f_s, nv, nv), optional
        Per-slave-facet dual coefficients (default: closed form).
    chunk_size : int
        Maximum number of pairs integrated at once (bounds memory).
    coincident : float, optional
        Only pairs that lie on each other to this distance (m) (:func:`coincident_pairs`).

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
        None
        if dual_coeffs is None
        else np.broadcast_to(np.asarray(dual_coeffs, float), (len(fs), nv, nv))
    )

    t0 = time.perf_counter()
    ia, ib = _candidates(xs, fs, ns, xm, fm, search_radius, coincident)
    t1 = time.perf_counter()
    integrate = integrate_segment_pairs if gdim == 2 else integrate_triangle_pairs
    parts: list[tuple[IntArray, IntArray, PairIntegrals]] = []
    for start in range(0, len(ia), chunk_size):
        sa, sb = ia[start : start + chunk_size], ib[start : start + chunk_size]
        res = integrate(xs[fs[sa]], ns[fs[sa]], xm[fm[sb]], None if coeffs is None else coeffs[sa])
        keep = res.area > 0.0
        parts.append(
            (
                sa[keep],
                sb[keep],
                PairIntegrals(res.area[keep], res.d[keep], res.m[keep], res.gap[keep]),
            )
        )
    timings = {"search": t1 - t0, "integrate": time.perf_counter() - t1}
    if not parts:
        z = np.zeros(0, dtype=np.int64)
        return MortarPairs(
            z,
            z.copy(),
            PairIntegrals(
                np.zeros(0), np.zeros((0, nv, nv)), np.zeros((0, nv, nv)), np.zeros((0, nv))
            ),
            timings,
            len(ia),
        )
    return MortarPairs(
        np.concatenate([p[0] for p in parts]),
        np.concatenate([p[1] for p in parts]),
        PairIntegrals(
            *(np.concatenate([getattr(p[2], f) for p in parts]) for f in ("area", "d", "m", "gap"))
        ),
        timings,
        len(ia),
    )


@dataclass(frozen=True)
class MortarContributions:
    """Local (per-rank) mortar contributions as COO triplets and nodal vectors.

    Node ids are local indices into the slave / master coordinate arrays passed
    to :func:`assemble_mortar`; each block multiplies the ``gdim x gdim``
    identity (docs/theory/mortar.md#mortar-matrices).

    Attributes
    ----------
    m_rows, m_cols : ndarray of int64
        Slave node / master node of each ``M`` entry (duplicates already summed).
    m_vals : ndarray of float
    d : ndarray, shape (n_slave_vertices,)
        Diagonal ``D[p, p] = int psi_p phi_p`` over the covered part of the slave
        surface (``= int phi_p`` over the covered part for unmasked nodes).
    gap : ndarray, shape (n_slave_vertices,)
        Weighted gap ``d_p = int psi_p g``.
    covered_area : ndarray, shape (n_slave_facets,)
        Measure of the part of each slave facet covered by master projections.
    facet_area : ndarray, shape (n_slave_facets,)
        Measure of each slave facet.
    d_off_rows, d_off_cols, d_off_vals : ndarray
        Off-diagonal ``D`` entries (slave node, slave node), only from facets that
        carry masked (boundary-modified) nodes: elsewhere, fully or partly covered,
        the dual basis is biorthogonal on the covered part and they vanish.  With a
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


#: Partly covered slave facets whose covered part is smaller than this fraction of the
#: facet, or whose covered mass matrix is this ill-conditioned (after diagonal scaling),
#: are left out of the mortar integrals altogether (docs/theory/mortar.md#partly-covered-facets).
MIN_COVERED_FRACTION = 1e-12
MAX_COVERED_MASS_CONDITION = 1e10


def _facet_sums(slave_facet: IntArray, values: FloatArray, n_facets: int) -> FloatArray:
    """Sum per-pair arrays (P, ...) over the pairs of each slave facet."""
    out = np.zeros((n_facets, *values.shape[1:]))
    np.add.at(out, slave_facet, values)
    return out


def _scaled_condition(mass: FloatArray) -> FloatArray:
    """2-norm condition numbers of mass matrices scaled to a unit diagonal."""
    diag = np.sqrt(np.maximum(np.diagonal(mass, axis1=1, axis2=2), 0.0))
    ok = np.all(diag > 0.0, axis=1)
    inv = np.divide(1.0, diag, out=np.zeros_like(diag), where=diag > 0.0)
    scaled = mass * inv[:, :, None] * inv[:, None, :]
    cond = np.full(len(mass), np.inf)
    if ok.any():
        cond[ok] = np.linalg.cond(scaled[ok])
    return cond


def _covered_dual_coefficients(
    raw: MortarPairs,
    n_facets: int,
    facet_area: FloatArray,
    dual_coeffs: npt.ArrayLike | None,
    coverage_rtol: float,
) -> tuple[MortarPairs, FloatArray, FloatArray]:
    """Dual coefficients of every slave facet, built on its covered part.

    ``raw`` holds the primal integrals (identity coefficients).  A fully covered facet
    keeps ``dual_coeffs`` (default the closed form); a partly covered one gets
    ``A_e = D_e M_e^{-1}`` from its mass matrix over the covered part only, so that
    ``int_cov psi_j phi_k = delta_jk int_cov phi_k`` (biorthogonal where the mortar
    integrals live; docs/theory/mortar.md#partly-covered-facets).  Facets covered too
    little for that (:data:`MIN_COVERED_FRACTION`, :data:`MAX_COVERED_MASS_CONDITION`)
    lose their pairs.

    Returns
    -------
    pairs : MortarPairs
        ``raw`` without the pairs of dropped facets.
    covered : (n_facets,) covered measure of each facet.
    coeffs : (n_facets, nv, nv) dual coefficients before any boundary modification.
    """
    nv = raw.integrals.d.shape[1]
    sf = raw.slave_facet
    base = reference_dual_coefficients(nv) if dual_coeffs is None else dual_coeffs
    coeffs = np.array(np.broadcast_to(np.asarray(base, dtype=float), (n_facets, nv, nv)))
    covered = np.bincount(sf, weights=raw.integrals.area, minlength=n_facets)
    partial = np.flatnonzero((covered > 0.0) & (covered < (1.0 - coverage_rtol) * facet_area))
    if partial.size == 0:
        return raw, covered, coeffs
    mass = _facet_sums(sf, raw.integrals.d, n_facets)[partial]
    usable = (covered[partial] >= MIN_COVERED_FRACTION * facet_area[partial]) & (
        _scaled_condition(mass) <= MAX_COVERED_MASS_CONDITION
    )
    coeffs[partial[usable]] = dual_coefficients_from_mass(mass[usable])
    dropped = partial[~usable]
    if dropped.size == 0:
        return raw, covered, coeffs
    covered[dropped] = 0.0
    keep = ~np.isin(sf, dropped)
    integ = raw.integrals
    kept = PairIntegrals(integ.area[keep], integ.d[keep], integ.m[keep], integ.gap[keep])
    pairs = MortarPairs(sf[keep], raw.master_facet[keep], kept, raw.timings, raw.candidates)
    return pairs, covered, coeffs


def _apply_dual_coefficients(raw: MortarPairs, coeffs: FloatArray) -> MortarPairs:
    """Pair integrals with the dual basis ``psi = A phi`` of each slave facet from the
    primal ones (``D``, ``M`` and the weighted gap are linear in ``A``)."""
    a = coeffs[raw.slave_facet]
    integ = raw.integrals
    dual = PairIntegrals(
        area=integ.area,
        d=np.matmul(a, integ.d),
        m=np.matmul(a, integ.m),
        gap=np.matmul(a, integ.gap[:, :, None])[:, :, 0],
    )
    return MortarPairs(raw.slave_facet, raw.master_facet, dual, raw.timings, raw.candidates)


def assemble_mortar(
    slave_coords: npt.ArrayLike,
    slave_facets: npt.ArrayLike,
    slave_normals: npt.ArrayLike,
    master_coords: npt.ArrayLike,
    master_facets: npt.ArrayLike,
    *,
    search_radius: float | npt.ArrayLike | None = None,
    slave_node_mask: npt.ArrayLike | None = None,
    dual_coeffs: npt.ArrayLike | None = None,
    coverage_rtol: float = 1e-10,
    coincident: float | None = None,
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
        Dual coefficients of the fully covered facets before the mask is applied
        (default: closed form).  A partly covered facet gets its dual basis from its
        mass matrix over the covered part (:func:`_covered_dual_coefficients`), so that
        ``sum_q M[p, q] = D[p, p]`` on every unmasked node and the slave and master
        receive equal and opposite forces (docs/theory/mortar.md#partly-covered-facets).
    coverage_rtol : float
        Relative tolerance deciding that a slave facet is fully covered.
    coincident : float, optional
        See :func:`compute_mortar_pairs`.

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

    facet_mask = (
        np.asarray(slave_node_mask, dtype=bool)[fs]
        if slave_node_mask is not None
        else np.zeros(fs.shape, dtype=bool)
    )
    # primal integrals (identity coefficients): the dual basis depends on the coverage
    raw = compute_mortar_pairs(
        xs,
        fs,
        slave_normals,
        master_coords,
        fm,
        search_radius=search_radius,
        dual_coeffs=np.eye(nv),
        coincident=coincident,
    )
    facet_area = simplex_measure(xs[fs]) if len(fs) else np.zeros(0)
    raw, covered, base = _covered_dual_coefficients(
        raw, len(fs), facet_area, dual_coeffs, coverage_rtol
    )
    coeffs = modify_dual_coefficients(base, facet_mask) if facet_mask.any() else base
    pairs = _apply_dual_coefficients(raw, coeffs)
    return _assemble_pairs(pairs, fs, fm, facet_mask, n_s, n_m, covered, facet_area)


def _assemble_pairs(
    pairs: MortarPairs,
    fs: npt.NDArray[np.int64],
    fm: npt.NDArray[np.int64],
    facet_mask: npt.NDArray[np.bool_],
    n_s: int,
    n_m: int,
    covered: float,
    facet_area: npt.NDArray[np.float64],
) -> MortarContributions:
    """Sum the integrals of the facet pairs into ``M`` (triplets), the diagonal of ``D``,
    the weighted gap and the off-diagonal ``D`` of boundary-modified facets."""
    nv = fs.shape[1]
    t0 = time.perf_counter()
    integ = pairs.integrals
    sf, mf = pairs.slave_facet, pairs.master_facet
    srows = fs[sf]  # (P, nv)

    m_rows = np.repeat(srows, nv, axis=1).ravel()
    m_cols = np.tile(fm[mf], (1, nv)).ravel()
    m_rows, m_cols, m_vals = _sum_duplicates(m_rows, m_cols, integ.m.ravel(), n_m)

    d = np.bincount(srows.ravel(), weights=integ.d_diag.ravel(), minlength=n_s)
    gap = np.bincount(srows.ravel(), weights=integ.gap.ravel(), minlength=n_s)

    # off-diagonal D on boundary-modified facets (elsewhere the dual basis is
    # biorthogonal on the covered part: zero up to round-off)
    d_facet = _facet_sums(sf, integ.d, len(fs))
    special = facet_mask.any(axis=1)
    off = ~np.eye(nv, dtype=bool)
    sel = special[:, None, None] & off[None] & (d_facet != 0.0)
    f_idx, j_idx, k_idx = np.nonzero(sel)
    d_off_rows, d_off_cols, d_off_vals = _sum_duplicates(
        fs[f_idx, j_idx], fs[f_idx, k_idx], d_facet[f_idx, j_idx, k_idx], n_s
    )
    pairs.timings["assemble"] = time.perf_counter() - t0
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
