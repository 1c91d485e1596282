"""Small geometry helpers shared by the contact, neoplasm, fracture and run layers."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

__all__ = [
    "ADVANCE_GRID_BITS",
    "cross2",
    "first_ray_hits",
    "line_triangle_hits",
    "nearest_triangle",
    "nearest_triangle_distance",
    "on_advance_grid",
    "point_triangle_distance",
    "polygon_area",
    "signed_polygon_area",
]

#: The grid of a crack advance: 2^(⌊log₂ Δa⌋ − ADVANCE_GRID_BITS), between 2⁻²⁰ and 2⁻¹⁹
#: (about 1e-6) of the advance Δa (:func:`on_advance_grid`).
ADVANCE_GRID_BITS = 20


def on_advance_grid(
    values: npt.ArrayLike, step: float, bits: int = ADVANCE_GRID_BITS
) -> npt.NDArray[np.float64]:
    """``values`` (advances or advanced points, in m) rounded to a grid of spacing
    q = 2^(⌊log₂ step⌋ − bits), exact arithmetic.

    A crack's advances come from K, whose round-off differs with the number of ranks, and
    gmsh meshes a crack moved by 1e-19 m differently; on the grid every rank count hands
    gmsh the same crack.  A value lands on another grid point only when it lies within its
    round-off of a midpoint: the probability is about round-off / q per value.  The grid
    was 2⁻³² of the step (2e-10) until a scanned-vertebra fatigue run of 11 advances × 3
    points met such a midpoint on 2 ranks (c 4.5e-13 m apart for a 4 mm step, then
    another mesh); at 2⁻²⁰ (1e-6 of the step) that is about 4000 times rarer, and the
    rounding moves a point by at most 5e-7 of the step, far below a front element.

    Raises
    ------
    ValueError
        ``step`` is not positive and finite.
    """
    if not (step > 0 and math.isfinite(step)):
        raise ValueError(f"the advance must be positive and finite, got {step}")
    q = 2.0 ** (math.floor(math.log2(step)) - bits)
    return np.round(np.asarray(values, dtype=float) / q) * q


def cross2(a: npt.ArrayLike, b: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """z-component of the cross product of 2D vectors.

    Parameters
    ----------
    a, b : array_like, shape (..., 2)
        2D vectors; leading axes broadcast (e.g. one vector per row).

    Returns
    -------
    ndarray, shape (...)
        ``a_x * b_y - a_y * b_x`` for each pair of vectors.
    """
    a = np.asarray(a)
    b = np.asarray(b)
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def signed_polygon_area(points: npt.ArrayLike) -> float:
    """Signed area of a closed polygon (shoelace formula).

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Polygon vertices in order; the closing edge from the last vertex back to the
        first is implied (do not repeat the first vertex).

    Returns
    -------
    float
        Area, positive when the vertices run counter-clockwise, negative clockwise.
    """
    p = np.asarray(points, dtype=np.float64)
    q = np.roll(p, -1, axis=0)
    return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))


def polygon_area(points: npt.ArrayLike) -> float:
    """Unsigned area of a closed polygon.

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Polygon vertices in order (closing edge implied).

    Returns
    -------
    float
        ``abs(signed_polygon_area(points))``.
    """
    return abs(signed_polygon_area(points))


def point_triangle_distance(
    p: npt.ArrayLike, t: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]:
    """Euclidean distance from points to triangles in 3D, pairwise.

    The distance from the triangle's plane where the point's projection falls inside the
    triangle (barycentric coordinates), else from the nearest of its three edges.

    Parameters
    ----------
    p : array_like, shape (k, 3) or (3,)
        The points; one point is measured against every triangle.
    t : ndarray, shape (k, 3, 3)
        The triangles' corners (triangle, corner, coordinate).

    Returns
    -------
    ndarray, shape (k,)
        The distance of point i from triangle i.
    """
    t = np.asarray(t, dtype=np.float64)
    p = np.broadcast_to(np.asarray(p, dtype=np.float64), (len(t), 3))
    a, b, c = t[:, 0], t[:, 1], t[:, 2]
    ab, ac = b - a, c - a
    n = np.cross(ab, ac)
    nn = np.maximum(np.einsum("ij,ij->i", n, n), 1e-300)
    d = np.einsum("ij,ij->i", p - a, n) / nn  # signed offset from the plane / |n|
    v0 = p - d[:, None] * n - a
    d00, d01, d11 = (
        np.einsum("ij,ij->i", ab, ab),
        np.einsum("ij,ij->i", ab, ac),
        np.einsum("ij,ij->i", ac, ac),
    )
    d20, d21 = np.einsum("ij,ij->i", v0, ab), np.einsum("ij,ij->i", v0, ac)
    den = np.maximum(d00 * d11 - d01 * d01, 1e-300)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    inside = (v >= 0) & (w >= 0) & (v + w <= 1)
    dist = np.where(inside, np.abs(d) * np.sqrt(nn), np.inf)
    for s0, s1 in ((a, b), (b, c), (c, a)):
        e = s1 - s0
        ee = np.maximum(np.einsum("ij,ij->i", e, e), 1e-300)
        u = np.clip(np.einsum("ij,ij->i", p - s0, e) / ee, 0.0, 1.0)
        dist = np.minimum(dist, np.linalg.norm(s0 + u[:, None] * e - p, axis=1))
    return dist


def nearest_triangle_distance(
    points: npt.ArrayLike, t: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]:
    """Distance from each point to the nearest of the triangles ``t``, exact
    (:func:`nearest_triangle`'s distances)."""
    return nearest_triangle(points, t)[0]


def nearest_triangle(
    points: npt.ArrayLike, t: npt.NDArray[np.float64]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """The nearest of the triangles ``t`` to each point and its distance, exact.

    Each point is measured against the triangles that can be nearest, not all of them: a
    triangle with centroid c and circumradius about c of r is at least |p − c| − r from p.
    With U the distance to the triangle of the nearest centroid, the triangles of ordinary
    size (r up to four times the median) whose centroid lies within U + their largest r
    hold the nearest one among them (a k-d tree of their centroids finds them); the few
    larger ones are measured against every point.  The distances are
    :func:`point_triangle_distance`'s, so they equal the minimum over all triangles to the
    last bit; of triangles at the same distance, the first.

    Parameters
    ----------
    points : array_like, shape (n, 3) or (3,)
    t : ndarray, shape (k, 3, 3), k ≥ 1
        The triangles' corners (triangle, corner, coordinate).

    Returns
    -------
    distance : ndarray, shape (n,)
    index : ndarray, shape (n,)
        The nearest triangle of each point.
    """
    t = np.asarray(t, dtype=np.float64)
    pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
    centre = t.mean(axis=1)
    r = np.linalg.norm(t - centre[:, None, :], axis=2).max(axis=1)
    big = r > 4.0 * np.median(r)
    small = np.flatnonzero(~big)
    _, first = cKDTree(centre).query(pts)
    first = np.atleast_1d(first).astype(np.int64)
    best = point_triangle_distance(pts, t[first])
    index = first.copy()
    _pair_minimum(pts, t, np.flatnonzero(big), best, index)
    if len(small):
        reach = float(r[small].max()) * (1.0 + 1e-12)
        near = cKDTree(centre[small]).query_ball_point(pts, best + reach)
        lists = np.empty(len(pts), dtype=object)
        for i, w in enumerate(near):
            lists[i] = small[np.asarray(w, dtype=np.int64)]
        near = lists
        _pair_minimum(pts, t, near, best, index)
    return best, index


def _pair_minimum(
    pts: np.ndarray,
    t: np.ndarray,
    which: np.ndarray,
    best: np.ndarray,
    index: np.ndarray,
    chunk: int = 1 << 20,
) -> None:
    """Lower ``best`` (and set ``index``) of every point to the least
    :func:`point_triangle_distance` to its triangles, in place (of triangles at the same
    distance, the lowest index): ``which`` the same triangle indices for every
    point, or (an object array) an index array per point."""
    if which.dtype != object:
        counts = np.full(len(pts), len(which))
        tri = np.tile(which, len(pts))
    else:
        counts = np.fromiter((len(w) for w in which), dtype=np.int64, count=len(pts))
        tri = np.concatenate([np.asarray(w, dtype=np.int64) for w in which] + [np.zeros(0, int)])
    point = np.repeat(np.arange(len(pts)), counts)
    for s in range(0, len(tri), chunk):
        p, k = point[s : s + chunk], tri[s : s + chunk]
        d = point_triangle_distance(pts[p], t[k])
        order = np.lexsort((k, d, p))  # by point, then distance, then triangle
        head = order[np.r_[True, p[order][1:] != p[order][:-1]]] if len(order) else order
        q, dq, kq = p[head], d[head], k[head]
        lower = (dq < best[q]) | ((dq == best[q]) & (kq < index[q]))
        best[q[lower]], index[q[lower]] = dq[lower], kq[lower]


def _ray_parameters(
    o: np.ndarray, d: np.ndarray, a: np.ndarray, e1: np.ndarray, e2: np.ndarray, tol: float
) -> np.ndarray:
    """Möller–Trumbore for rays (r, 3) against triangles (corner ``a``, edges ``e1``,
    ``e2``; each (k, 3)): the (r, k) line parameters, ``nan`` where a line misses or
    runs parallel to a triangle's plane (determinant below 1e-14 of |d||e1||e2|)."""
    h = np.cross(d[:, None, :], e2[None, :, :])
    det = np.einsum("rtk,tk->rt", h, e1)
    scale = np.linalg.norm(d, axis=1)[:, None] * (
        np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)
    )
    ok = np.abs(det) > 1e-14 * np.maximum(scale, 1e-300)
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    r = o[:, None, :] - a[None, :, :]
    u = np.einsum("rtk,rtk->rt", r, h) * inv
    q = np.cross(r, e1[None, :, :])
    v = np.einsum("rtk,rk->rt", q, d) * inv
    s = np.einsum("rtk,tk->rt", q, e2) * inv
    hit = ok & (u >= -tol) & (v >= -tol) & (u + v <= 1 + tol)
    return np.where(hit, s, np.nan)


def line_triangle_hits(
    p: npt.ArrayLike, d: npt.ArrayLike, t: npt.NDArray[np.float64], tol: float = 1e-12
) -> npt.NDArray[np.float64]:
    """Where the line x = p + s d meets each triangle (Möller–Trumbore): the parameter s,
    ``nan`` where it misses (or runs parallel to the triangle's plane).

    Parameters
    ----------
    p, d : array_like, shape (3,)
        A point of the line and its direction (not necessarily unit).
    t : ndarray, shape (k, 3, 3)
        The triangles' corners (triangle, corner, coordinate).
    tol
        Barycentric slack: a line through an edge or a corner within ``tol`` hits both
        triangles that share it.

    Returns
    -------
    ndarray, shape (k,)
        s of the hit on triangle i, or ``nan``.
    """
    t = np.asarray(t, dtype=np.float64)
    p = np.asarray(p, dtype=np.float64).reshape(1, 3)
    d = np.asarray(d, dtype=np.float64).reshape(1, 3)
    return _ray_parameters(p, d, t[:, 0], t[:, 1] - t[:, 0], t[:, 2] - t[:, 0], tol)[0]


def first_ray_hits(
    origins: npt.ArrayLike,
    dirs: npt.ArrayLike,
    t: npt.NDArray[np.float64],
    tol: float = 1e-12,
    chunk: int = 256,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """The first crossing of each ray ``origins[i] + s dirs[i]``, s > 0, with the
    triangles (Möller–Trumbore as :func:`line_triangle_hits`, ``chunk`` rays at a time).

    Parameters
    ----------
    origins, dirs : array_like, shape (r, 3)
        The rays' starts and directions (the distance is in units of |dirs|).
    t : ndarray, shape (k, 3, 3)
        The triangles' corners.
    tol
        Barycentric slack (0: a ray through a shared edge may miss both triangles).
    chunk
        Rays per block (memory r_chunk × k).

    Returns
    -------
    s : ndarray, shape (r,)
        The least positive parameter of a hit (``inf``: none).
    which : ndarray, shape (r,)
        The triangle hit first (-1: none).
    """
    t = np.asarray(t, dtype=np.float64)
    o = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
    d = np.asarray(dirs, dtype=np.float64).reshape(-1, 3)
    a, e1, e2 = t[:, 0], t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    out = np.full(len(o), np.inf)
    which = np.full(len(o), -1, np.int64)
    if len(t) == 0:
        return out, which
    for lo in range(0, len(o), chunk):
        s = _ray_parameters(o[lo : lo + chunk], d[lo : lo + chunk], a, e1, e2, tol)
        dist = np.where(s > 0, s, np.inf)  # nan > 0 is False
        first = dist.argmin(axis=1)
        best = dist[np.arange(len(dist)), first]
        out[lo : lo + chunk] = best
        which[lo : lo + chunk] = np.where(np.isfinite(best), first, -1)
    return out, which
