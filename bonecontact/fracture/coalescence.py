"""Coalescence of two 2D cracks whose facing tips meet (docs/theory/fracture.md#several-cracks).

When a grown tip of one crack comes within the ligament (the growth increment) of a tip of
another crack, the tips face each other (their directions opposite and the bridge between
them along both, within :data:`MERGE_ANGLE_DEG`) and the crack made of both paths and the
bridge is simple, lies in the body and keeps clear of the other cracks, the two cracks
become one: a polyline from the far end of the first to the far end of the second
(:func:`merged_crack`).  Anything else — a tip that meets another crack's flank (a T), tips
side by side, a merged crack that would cut the body from surface to surface, different
face friction — is not merged; :func:`facing_tips` says why.  In 3D two planar cracks
that meet and lie in one plane (:func:`coplanar`) become the convex hull of both, its
edges no shorter than the integration domain (:func:`hull_polygon`).  Geometry only.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy.spatial import ConvexHull

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.crack import Crack2D
from bonecontact.fracture.crack3d import in_plane_axis

__all__ = [
    "MERGE_ANGLE_DEG",
    "coplanar",
    "facing_tips",
    "far_end",
    "hull_polygon",
    "merged_crack",
]

#: The largest angle (°) between a tip's direction and the opposite of the other tip's
#: direction, and between either and the bridge, for two tips to face each other.
MERGE_ANGLE_DEG = 15.0


def far_end(end: int) -> int:
    """The other polyline end (0 ↔ −1)."""
    return -1 if end == 0 else 0


def facing_tips(
    a: Crack2D, end_a: int, b: Crack2D, reach: float, min_bridge: float
) -> tuple[int, str]:
    """The tip of ``b`` that tip ``end_a`` of ``a`` faces within ``reach`` (m), or why none.

    Returns ``(end_b, "")`` when tip ``end_a`` of ``a`` and tip ``end_b`` of ``b`` are at most
    ``reach`` apart, their directions opposite within :data:`MERGE_ANGLE_DEG` and (when the
    bridge between them is at least ``min_bridge`` long) the bridge along both within that
    angle; else ``(0, reason)``.
    """
    p, d_a = a.tip(end_a), a.direction(end_a)
    if not b.tip_ends:
        return 0, "the other crack has no tip (it runs from surface to surface)"
    end_b = min(b.tip_ends, key=lambda e: float(np.linalg.norm(b.tip(e) - p)))
    v = b.tip(end_b) - p
    gap = float(np.linalg.norm(v))
    if gap > reach:
        return 0, (
            f"the tip meets the other crack's flank {b.distance(p):.3g} m away, not its tip "
            f"({gap:.3g} m away): a T-junction is not merged"
        )
    cos_max = math.cos(math.radians(MERGE_ANGLE_DEG))
    d_b = b.direction(end_b)
    opposite = -float(np.dot(d_a, d_b))
    if opposite < cos_max:
        angle = math.degrees(math.acos(max(-1.0, min(1.0, opposite))))
        return 0, (
            f"the tips are not collinear: their directions are {angle:.1f}° from opposite "
            f"(at most {MERGE_ANGLE_DEG:g}°)"
        )
    if gap >= min_bridge:
        along = min(float(np.dot(v, d_a)), -float(np.dot(v, d_b))) / gap
        if along < cos_max:
            angle = math.degrees(math.acos(max(-1.0, min(1.0, along))))
            return 0, (
                f"the tips do not face each other: the bridge between them is {angle:.1f}° "
                f"off a tip's direction (at most {MERGE_ANGLE_DEG:g}°)"
            )
    return end_b, ""


def merged_crack(a: Crack2D, end_a: int, b: Crack2D, end_b: int, min_bridge: float) -> Crack2D:
    """The crack from the far end of ``a`` through tip ``end_a`` of ``a``, the bridge and tip
    ``end_b`` of ``b`` to the far end of ``b`` (points[0] is ``a``'s far end).  A bridge
    shorter than ``min_bridge`` (m) is closed at its midpoint instead (the two tips become
    that one vertex), so that no segment is shorter than the mesh can resolve.

    Raises
    ------
    ParameterError
        Both far ends are mouths (the merged crack would cut the body through), or the
        merged polyline is not simple.
    """
    pa = a.points if end_a == -1 else a.points[::-1]
    pb = b.points if end_b == 0 else b.points[::-1]
    start_tip = far_end(end_a) in a.tip_ends
    end_tip = far_end(end_b) in b.tip_ends
    if not (start_tip or end_tip):
        raise ParameterError(
            "points", "both far ends are mouths: the merged crack would cut the body through"
        )
    tips = "both" if start_tip and end_tip else ("end" if end_tip else "start")
    if float(np.linalg.norm(pb[0] - pa[-1])) < min_bridge:
        mid = 0.5 * (pa[-1] + pb[0])
        pts = np.vstack([pa[:-1], mid, pb[1:]])
    else:
        pts = np.vstack([pa, pb])
    return Crack2D(pts, tips)


def coplanar(points: npt.ArrayLike, normal: npt.ArrayLike, tol: float) -> str:
    """Why the ``points`` (n, 3) of two cracks do not lie in one plane ("" if they do):
    the plane through their centroid normal to ``normal``, every point within ``tol``."""
    P = np.asarray(points, dtype=float)
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    off = float(np.abs((P - P.mean(axis=0)) @ n).max())
    if off > tol:
        return (
            f"the cracks are not coplanar: their points lie up to {off:.3g} m off a common "
            f"plane (at most {tol:.3g} m)"
        )
    return ""


def _plane_basis(normal: np.ndarray) -> np.ndarray:
    """Two unit vectors e1, e2 with (e1, e2, normal) right-handed, shape (2, 3)."""
    n = normal / np.linalg.norm(normal)
    e1 = in_plane_axis(n)
    return np.array([e1, np.cross(n, e1)])


def _drop_short_edge(poly: np.ndarray, k: int) -> np.ndarray:
    """The convex polygon (m, 2; counter-clockwise) without its edge k (vertex k to k + 1):
    the edges before and after it extended to their intersection, which replaces both
    ends (the polygon grows and stays convex); when they do not meet ahead (a turn of
    180° or more over the two corners), vertex k + 1 is dropped."""
    m = len(poly)
    a0, a1 = poly[(k - 1) % m], poly[k]
    b0, b1 = poly[(k + 2) % m], poly[(k + 1) % m]
    da, db = a1 - a0, b1 - b0
    det = da[0] * db[1] - da[1] * db[0]
    keep = [i for i in range(m) if i != (k + 1) % m]
    if abs(det) > 1e-12 * float(np.linalg.norm(da) * np.linalg.norm(db)):
        rhs = b0 - a0
        s = (rhs[0] * db[1] - rhs[1] * db[0]) / det
        t = (rhs[0] * da[1] - rhs[1] * da[0]) / det
        if s >= 1.0 and t >= 1.0:
            out = poly[keep].copy()
            out[keep.index(k)] = a0 + s * da
            return out
    return poly[keep]


def hull_polygon(
    points: npt.ArrayLike, normal: npt.ArrayLike, min_edge: float
) -> npt.NDArray[np.float64]:
    """The convex hull of ``points`` (n, 3) projected on the plane through their centroid
    normal to ``normal``, counter-clockwise about it, with every edge at least
    ``min_edge`` long: the shortest edge removed (:func:`_drop_short_edge`, the hull only
    grows) until none is shorter or 6 vertices are left; shape (m, 3)."""
    P = np.asarray(points, dtype=float)
    n = np.asarray(normal, dtype=float)
    origin = P.mean(axis=0)
    basis = _plane_basis(n)
    uv = (P - origin) @ basis.T
    poly = uv[ConvexHull(uv).vertices]  # counter-clockwise in (e1, e2)
    while len(poly) > 6:
        edges = np.linalg.norm(np.roll(poly, -1, axis=0) - poly, axis=1)
        k = int(np.argmin(edges))
        if edges[k] >= min_edge:
            break
        poly = _drop_short_edge(poly, k)
    return origin + poly @ basis
