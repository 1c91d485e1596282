"""Candidate search between slave and master facets of the mortar, pure NumPy.

Each slave facet is swept along its normal(s) over the search distance; the axis-aligned
box of that sweep is intersected with the master facets' boxes by descending a bounding-box
tree of the master facets (Morton-ordered, vectorised over all slave facets): cost
``O(n log n)`` plus the number of pairs (docs/theory/mortar.md#candidate-search).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bonecontact.contact.geometry import FloatArray, IntArray, facet_normals

__all__ = [
    "facet_bounding_boxes",
    "find_candidate_pairs",
    "morton_order",
    "swept_facet_boxes",
]

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


def swept_facet_boxes(
    coords: npt.ArrayLike,
    facets: npt.ArrayLike,
    radius: float | npt.ArrayLike,
    nodal_normals: npt.ArrayLike | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Axis-aligned boxes of facets swept along their normals over ``[-radius, radius]``.

    The box of facet ``f`` holds every point ``x + s n`` with ``x`` on the facet,
    ``|s| <= radius_f`` and ``n`` its unit facet normal or (if given) any convex
    combination of the unit nodal normals at its vertices: every point that a
    projection along those directions reaches within the search distance.  Unlike a box
    padded by ``radius`` in every direction, it does not grow sideways on a facet
    facing along a coordinate axis, so a large search distance costs few candidates.

    Parameters
    ----------
    coords : array_like, shape (n_vertices, gdim)
    facets : array_like of int, shape (n_facets, gdim)
        Segments (2D) or triangles (3D).
    radius : float or array_like, shape (n_facets,)
        Search distance along the normal (one for all facets, or one per facet).
    nodal_normals : array_like, shape (n_vertices, gdim), optional
        Unit nodal normals, also swept along (2D projections follow the interpolated
        nodal normal).

    Returns
    -------
    lower, upper : ndarray, shape (n_facets, gdim)
    """
    x = np.asarray(coords, dtype=float)
    fc = np.asarray(facets, dtype=np.int64)
    v = x[fc]  # (F, nv, gdim)
    n_f, _ = facet_normals(x, fc)
    r = np.broadcast_to(np.asarray(radius, dtype=float), (len(fc),))[:, None, None]
    dirs = [np.broadcast_to(n_f[:, None, :], v.shape)]
    if nodal_normals is not None:
        nn = np.asarray(nodal_normals, dtype=float)[fc]  # (F, nv, gdim)
        dirs += [np.broadcast_to(nn[:, k : k + 1, :], v.shape) for k in range(fc.shape[1])]
    reach = np.concatenate([v + r * d for d in dirs] + [v - r * d for d in dirs], axis=1)
    return np.minimum(v.min(axis=1), reach.min(axis=1)), np.maximum(
        v.max(axis=1), reach.max(axis=1)
    )


def _spread_bits(v: IntArray, dim: int) -> IntArray:
    """Insert ``dim - 1`` zero bits between the bits of ``v`` (< 2**21 in 3D, < 2**31 in 2D)."""
    v = v.astype(np.uint64)
    if dim == 2:
        masks = [(16, 0x0000FFFF0000FFFF), (8, 0x00FF00FF00FF00FF), (4, 0x0F0F0F0F0F0F0F0F)]
        masks += [(2, 0x3333333333333333), (1, 0x5555555555555555)]
    else:
        masks = [(32, 0x1F00000000FFFF), (16, 0x1F0000FF0000FF), (8, 0x100F00F00F00F00F)]
        masks += [(4, 0x10C30C30C30C30C3), (2, 0x1249249249249249)]
    for shift, mask in masks:
        v = (v | (v << np.uint64(shift))) & np.uint64(mask)
    return v


def morton_order(points: npt.ArrayLike) -> IntArray:
    """Permutation sorting points along the Z-order (Morton) curve of their bounding box.

    Parameters
    ----------
    points : array_like, shape (n, gdim), gdim 2 or 3

    Returns
    -------
    ndarray of int64, shape (n,)
        Consecutive points of the order are close in space (stable for equal codes).
    """
    points = np.asarray(points, dtype=float)
    dim = points.shape[1]
    bits = 21 if dim == 3 else 31
    lo = points.min(axis=0)
    span = np.maximum(points.max(axis=0) - lo, np.finfo(float).tiny)
    q = np.minimum(((points - lo) / span * (2**bits)).astype(np.int64), 2**bits - 1)
    code = np.zeros(len(points), dtype=np.uint64)
    for d in range(dim):
        code |= _spread_bits(q[:, d], dim) << np.uint64(d)
    return np.argsort(code, kind="stable")


def _box_tree(lower: FloatArray, upper: FloatArray) -> tuple[IntArray, list]:
    """Complete binary tree of boxes over their Morton order (a linear bounding-volume
    hierarchy).

    Returns ``(order, levels)``: ``order`` maps leaf ``k`` to box ``order[k]``;
    ``levels[l]`` holds the ``(lower, upper)`` corners, shape ``(gdim, 2**l)`` (axis
    first), of the nodes of depth ``l`` (node ``i`` has children ``2i`` and
    ``2i + 1``); the last level is the leaves, padded with empty boxes.
    """
    n, dim = lower.shape
    order = morton_order(0.5 * (lower + upper))
    depth = int(np.ceil(np.log2(n))) if n > 1 else 0
    lo = np.full((dim, 2**depth), np.inf)
    hi = np.full((dim, 2**depth), -np.inf)
    lo[:, :n], hi[:, :n] = lower[order].T, upper[order].T
    levels = [(lo, hi)]
    while lo.shape[1] > 1:
        lo = np.minimum(lo[:, 0::2], lo[:, 1::2])
        hi = np.maximum(hi[:, 0::2], hi[:, 1::2])
        levels.append((lo, hi))
    return order, levels[::-1]


def find_candidate_pairs(
    lower_a: npt.ArrayLike,
    upper_a: npt.ArrayLike,
    lower_b: npt.ArrayLike,
    upper_b: npt.ArrayLike,
) -> tuple[IntArray, IntArray]:
    """All pairs of intersecting axis-aligned boxes (set A x set B).

    The boxes of B are sorted along a Z-order (Morton) curve of their centres and
    gathered in a complete binary tree of bounding boxes; all boxes of A descend the
    tree together, level by level, keeping the (box, node) pairs whose boxes
    intersect (vectorised breadth-first traversal).  Cost ``O(n log n)`` plus the
    pairs visited, about the number of intersecting pairs times the depth, and
    insensitive to how much the box sizes and shapes vary.

    Parameters
    ----------
    lower_a, upper_a : array_like, shape (n_a, gdim)
    lower_b, upper_b : array_like, shape (n_b, gdim)

    Returns
    -------
    ia, ib : ndarray of int64, shape (n_pairs,)
        Intersecting pairs (touching boxes included), sorted by ``ia`` then ``ib``.
    """
    amin = np.asarray(lower_a, dtype=float)
    amax = np.asarray(upper_a, dtype=float)
    bmin = np.asarray(lower_b, dtype=float)
    bmax = np.asarray(upper_b, dtype=float)
    empty = np.zeros(0, dtype=np.int64)
    if len(amin) == 0 or len(bmin) == 0:
        return empty, empty.copy()
    order, levels = _box_tree(bmin, bmax)
    a_lo, a_hi = np.ascontiguousarray(amin.T), np.ascontiguousarray(amax.T)
    qa = np.arange(len(amin), dtype=np.int64)
    node = np.zeros(len(amin), dtype=np.int64)
    for depth, (lo, hi) in enumerate(levels):
        if depth > 0:  # descend: both children of every surviving pair
            qa = np.repeat(qa, 2)
            node = np.repeat(2 * node, 2)
            node[1::2] += 1
        for d in range(len(lo)):  # axis by axis, dropping misses early
            hit = (a_lo[d][qa] <= hi[d][node]) & (lo[d][node] <= a_hi[d][qa])
            qa, node = qa[hit], node[hit]
    pb = order[node]
    sort = np.lexsort((pb, qa))
    return qa[sort], pb[sort]
