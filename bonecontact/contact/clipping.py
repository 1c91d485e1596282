"""Mortar segments: 3D polygon clipping and the projections of 2D segments, pure NumPy.

Sutherland-Hodgman clipping of (projected) master triangles by slave triangles on padded
arrays, polygon areas, exact moments up to order 2 and fan quadrature of the clipped
polygons; projection of points
onto master segments along the interpolated slave normal and onto lines along given
directions.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bonecontact.common.geometry import cross2
from bonecontact.contact.dual_basis import TRIANGLE_RULE
from bonecontact.contact.geometry import FloatArray, IntArray

__all__ = [
    "clip_polygons_by_triangles",
    "fan_quadrature",
    "fan_triangle_quadrature",
    "polygon_areas",
    "polygon_moments",
    "project_points_to_lines_along_directions",
    "project_points_to_segments_interpolated_normal",
]

# ----------------------------------------------------------------------------------
# Polygon clipping (Sutherland-Hodgman, padded arrays)
# ----------------------------------------------------------------------------------


def _clip_halfplane(
    poly: FloatArray, count: IntArray, dist: FloatArray
) -> tuple[FloatArray, IntArray]:
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
    orient = np.sign(cross2(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]))
    for e in range(3):
        a = tri[:, e]
        edge = tri[:, (e + 1) % 3] - a
        dist = orient[:, None] * cross2(edge[:, None, :], poly - a[:, None, :])
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
    terms = np.where(idx[None, :] < cnt[:, None], cross2(poly, p_next), 0.0)
    return 0.5 * np.abs(terms.sum(axis=1))


def fan_quadrature(poly: FloatArray, count: IntArray) -> tuple[FloatArray, FloatArray]:
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
    area = np.where(valid, 0.5 * np.abs(cross2(poly - c, p_next - c)), 0.0)  # (P, K)
    bary, w = TRIANGLE_RULE
    points = (
        bary[None, None, :, 0, None] * c[:, :, None, :]
        + bary[None, None, :, 1, None] * poly[:, :, None, :]
        + bary[None, None, :, 2, None] * p_next[:, :, None, :]
    )
    weights = area[:, :, None] * w[None, None, :]
    return points.reshape(n_poly, -1, 2), weights.reshape(n_poly, -1)


def polygon_moments(poly: npt.ArrayLike, count: npt.ArrayLike) -> FloatArray:
    """Exact moments up to order 2 of padded simple polygons (Green's theorem).

    Parameters
    ----------
    poly : array_like, shape (P, K, 2)
        Vertices ``(x, y)`` in either orientation, valid for ``k < count``.
    count : array_like of int, shape (P,)

    Returns
    -------
    ndarray, shape (P, 3, 3)
        ``S[p] = int_polygon b b^T`` with ``b = (1, x, y)``: the area, the first
        moments ``int x``, ``int y`` and the second moments ``int x^2``, ``int x y``,
        ``int y^2``.
    """
    poly = np.asarray(poly, dtype=float)
    cnt = np.asarray(count, dtype=np.int64)
    idx = np.arange(poly.shape[1])
    nxt = np.where(idx[None, :] + 1 < cnt[:, None], idx[None, :] + 1, 0)
    x0, y0 = poly[..., 0], poly[..., 1]
    x1 = np.take_along_axis(x0, nxt, axis=1)
    y1 = np.take_along_axis(y0, nxt, axis=1)
    c = np.where(idx[None, :] < cnt[:, None], x0 * y1 - x1 * y0, 0.0)  # (P, K)
    area = 0.5 * c.sum(axis=1)
    sign = np.where(area < 0.0, -1.0, 1.0)
    m = np.empty((len(cnt), 3, 3))
    m[:, 0, 0] = sign * area
    m[:, 0, 1] = m[:, 1, 0] = sign * np.sum((x0 + x1) * c, axis=1) / 6.0
    m[:, 0, 2] = m[:, 2, 0] = sign * np.sum((y0 + y1) * c, axis=1) / 6.0
    m[:, 1, 1] = sign * np.sum((x0 * x0 + x0 * x1 + x1 * x1) * c, axis=1) / 12.0
    m[:, 2, 2] = sign * np.sum((y0 * y0 + y0 * y1 + y1 * y1) * c, axis=1) / 12.0
    m[:, 1, 2] = m[:, 2, 1] = (
        sign * np.sum((x0 * y1 + 2.0 * (x0 * y0 + x1 * y1) + x1 * y0) * c, axis=1) / 24.0
    )
    return m


def fan_triangle_quadrature(
    poly: FloatArray, count: IntArray
) -> tuple[IntArray, FloatArray, FloatArray]:
    """The centroid-fan 7-point rule of :func:`fan_quadrature`, without padding.

    The polygons' fan triangles (from the vertex centroid to each edge) are listed one
    after the other, polygon by polygon.

    Returns
    -------
    owner : (T,) polygon of each fan triangle (non-decreasing).
    points : (T, 7, 2) quadrature points.
    weights : (T, 7) weights (summing to each fan triangle's area).
    """
    n_poly, k_max, _ = poly.shape
    idx = np.arange(k_max)
    valid = idx[None, :] < count[:, None]
    centre = np.where(valid[:, :, None], poly, 0.0).sum(axis=1) / np.maximum(count, 1)[:, None]
    owner, k = np.nonzero(valid)
    nxt = np.where(k + 1 < count[owner], k + 1, 0)
    a, b, c = centre[owner], poly[owner, k], poly[owner, nxt]
    area = 0.5 * np.abs(cross2(b - a, c - a))
    bary, w = TRIANGLE_RULE
    points = (
        bary[None, :, 0, None] * a[:, None, :]
        + bary[None, :, 1, None] * b[:, None, :]
        + bary[None, :, 2, None] * c[:, None, :]
    )
    return owner, points, area[:, None] * w[None, :]


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
    c0 = cross2(a0, b0)
    c1 = cross2(a0, b1) + cross2(a1, b0)
    c2 = cross2(a1, b1)
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
        return cross2(x - y1, d) / cross2(y2 - y1, d)
