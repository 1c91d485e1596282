"""A crack in a 2D body: a polyline with one or two tips (docs/theory/fracture.md#crack-geometry).

A :class:`Crack2D` is an open polyline ``points[0] → … → points[-1]``.  An end is either a
*tip* (inside the body; the faces meet there) or a *mouth* (on the free surface; the faces
separate there).  An interior crack has two tips, an edge crack one tip and one mouth.
The crack only describes geometry; :mod:`bonecontact.fracture.meshing` meshes a body
around it and :mod:`bonecontact.fracture.sif` evaluates its stress intensity factors.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from bonecontact.common.errors import ParameterError

__all__ = [
    "Crack2D",
    "FractureError",
    "crack_gap",
    "point_in_polygon",
    "point_segment_distance",
    "points_in_polygon",
    "segments_intersect",
]


#: Deprecated alias of :class:`~bonecontact.common.errors.ParameterError` (the one type of
#: a parameter out of range): invalid fracture input or a fracture computation that cannot
#: be done as asked; ``str(error)`` reads ``<key>: <message>``.
FractureError = ParameterError


def point_segment_distance(p: npt.ArrayLike, a: npt.ArrayLike, b: npt.ArrayLike) -> float:
    """Distance from point ``p`` to the segment ``a``–``b`` (2D)."""
    p, a, b = (np.asarray(v, dtype=float)[:2] for v in (p, a, b))
    ab = b - a
    s = 0.0 if not ab.any() else float(np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + s * ab)))


def _orient(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    return float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))


def segments_intersect(
    p1: npt.ArrayLike, p2: npt.ArrayLike, q1: npt.ArrayLike, q2: npt.ArrayLike, tol: float = 0.0
) -> bool:
    """Whether the closed segments ``p1p2`` and ``q1q2`` meet (touching counts), 2D.

    ``tol`` is a distance: segments closer than it count as meeting.
    """
    p1, p2, q1, q2 = (np.asarray(v, dtype=float)[:2] for v in (p1, p2, q1, q2))
    d1, d2 = _orient(q1, q2, p1), _orient(q1, q2, p2)
    d3, d4 = _orient(p1, p2, q1), _orient(p1, p2, q2)
    if ((d1 > 0) != (d2 > 0)) and ((d3 > 0) != (d4 > 0)) and d1 * d2 < 0 and d3 * d4 < 0:
        return True
    gaps = (
        point_segment_distance(p1, q1, q2),
        point_segment_distance(p2, q1, q2),
        point_segment_distance(q1, p1, p2),
        point_segment_distance(q2, p1, p2),
    )
    return min(gaps) <= tol


def point_in_polygon(p: npt.ArrayLike, polygon: npt.ArrayLike) -> bool:
    """Whether ``p`` lies strictly inside the simple polygon (even–odd rule)."""
    x, y = np.asarray(p, dtype=float)[:2]
    poly = np.asarray(polygon, dtype=float)
    inside = False
    n = len(poly)
    for i in range(n):
        (x1, y1), (x2, y2) = poly[i], poly[(i + 1) % n]
        if (y1 > y) != (y2 > y):
            xc = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
            if xc > x:
                inside = not inside
    return inside


def points_in_polygon(points: npt.ArrayLike, polygon: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """Which of ``points`` (m, 2) lie strictly inside the polygon (n, 2): the even–odd
    rule of :func:`point_in_polygon` for many points at once."""
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    a = np.asarray(polygon, dtype=float)
    b = np.roll(a, -1, axis=0)
    x, y = p[:, :1], p[:, 1:]
    span = (a[:, 1] > y) != (b[:, 1] > y)
    dy = np.where(b[:, 1] == a[:, 1], 1.0, b[:, 1] - a[:, 1])
    xc = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / dy
    return (np.count_nonzero(span & (xc > x), axis=1) % 2) == 1


@dataclass(frozen=True)
class Crack2D:
    """A 2D crack: an open polyline whose ends are tips or mouths.

    Parameters
    ----------
    points
        Polyline vertices, shape (n, 2), n ≥ 2, in m; consecutive points distinct.
    tips
        Which ends are tips: ``"both"`` (interior crack), ``"end"`` (``points[0]`` is the
        mouth on the free surface, ``points[-1]`` the tip) or ``"start"`` (the reverse).
    """

    points: npt.NDArray[np.float64]
    tips: str = "both"

    def __post_init__(self) -> None:
        pts = np.asarray(self.points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or pts.shape[0] < 2:
            raise ParameterError("points", f"need an (n, 2) array with n >= 2, got {pts.shape}")
        if not np.all(np.isfinite(pts)):
            raise ParameterError("points", "must be finite numbers")
        seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        if np.any(seg <= 1e-12 * max(1.0, float(np.abs(pts).max()))):
            raise ParameterError("points", "consecutive points must be distinct")
        if self.tips not in ("both", "start", "end"):
            raise ParameterError("tips", f"must be 'both', 'start' or 'end', got {self.tips!r}")
        object.__setattr__(self, "points", pts)
        self._check_simple(seg)

    def _check_simple(self, seg: npt.NDArray[np.float64]) -> None:
        pts = self.points
        tol = 1e-9 * float(seg.sum())
        for i in range(len(pts) - 1):
            for j in range(i + 2, len(pts) - 1):
                if segments_intersect(pts[i], pts[i + 1], pts[j], pts[j + 1], tol):
                    raise ParameterError("points", f"segments {i} and {j} of the crack intersect")

    # ------------------------------------------------------------ geometry
    @property
    def tip_ends(self) -> tuple[int, ...]:
        """Indices (0 and/or -1) of the polyline ends that are tips."""
        return {"both": (0, -1), "end": (-1,), "start": (0,)}[self.tips]

    @property
    def mouth_ends(self) -> tuple[int, ...]:
        """Indices of the polyline ends on the free surface."""
        return tuple(e for e in (0, -1) if e not in self.tip_ends)

    @property
    def length(self) -> float:
        """Total length of the polyline (m)."""
        return float(np.linalg.norm(np.diff(self.points, axis=0), axis=1).sum())

    def tip(self, end: int) -> npt.NDArray[np.float64]:
        """Position of the tip at polyline end ``end`` (0 or -1)."""
        self._check_tip(end)
        return self.points[end].copy()

    def direction(self, end: int) -> npt.NDArray[np.float64]:
        """Unit vector along the last segment at tip ``end``, pointing ahead of the tip."""
        self._check_tip(end)
        p = self.points
        d = p[0] - p[1] if end == 0 else p[-1] - p[-2]
        return d / np.linalg.norm(d)

    def tip_segment_length(self, end: int) -> float:
        """Length of the straight segment ending at tip ``end``."""
        self._check_tip(end)
        p = self.points
        return float(np.linalg.norm(p[0] - p[1] if end == 0 else p[-1] - p[-2]))

    def distance(self, p: npt.ArrayLike) -> float:
        """Distance from the point ``p`` to the polyline (m)."""
        pts = self.points
        return min(point_segment_distance(p, pts[k], pts[k + 1]) for k in range(len(pts) - 1))

    def _check_tip(self, end: int) -> None:
        if end not in self.tip_ends:
            raise ParameterError("tip", f"end {end} of the crack is not a tip (tips={self.tips!r})")

    def extended(self, end: int, da: float, angle: float) -> Crack2D:
        """The crack grown at tip ``end`` by a straight increment.

        Parameters
        ----------
        end
            The tip that grows (0 or -1).
        da
            Increment length (m), > 0.
        angle
            Kink angle (rad) from the current tip direction, counter-clockwise positive.
        """
        if not (math.isfinite(da) and da > 0):
            raise ParameterError("increment", f"must be a positive length, got {da!r}")
        d = self.direction(end)
        c, s = math.cos(angle), math.sin(angle)
        new_tip = self.tip(end) + da * np.array([c * d[0] - s * d[1], s * d[0] + c * d[1]])
        pts = np.vstack([new_tip, self.points]) if end == 0 else np.vstack([self.points, new_tip])
        return Crack2D(pts, self.tips)

    # ---------------------------------------------------------- validation
    def check_inside(
        self,
        outline: Sequence[Sequence[float]],
        holes: Sequence[tuple[float, float, float]] = (),
        scale: float | None = None,
    ) -> None:
        """Raise :class:`ParameterError` unless the crack lies in the polygon ``outline``.

        Tips and interior vertices must be strictly inside, mouths on the outline, and no
        segment may cross the outline (a segment may touch it only at a mouth) or come
        within a circular hole ``(x, y, radius)``.
        """
        poly = np.asarray(outline, dtype=float)
        scale = float(np.ptp(poly, axis=0).max()) if scale is None else scale
        tol = 1e-9 * scale
        edges = [(poly[i], poly[(i + 1) % len(poly)]) for i in range(len(poly))]
        on_outline = [
            min(point_segment_distance(p, a, b) for a, b in edges) <= tol for p in self.points
        ]
        n = len(self.points)
        for i, p in enumerate(self.points):
            is_mouth = (i == 0 and 0 in self.mouth_ends) or (i == n - 1 and -1 in self.mouth_ends)
            if is_mouth and not on_outline[i]:
                raise ParameterError(
                    "points", f"the crack mouth {p.tolist()} is not on the outline"
                )
            if not is_mouth and (on_outline[i] or not point_in_polygon(p, poly)):
                raise ParameterError("points", f"crack point {p.tolist()} is not inside the body")
        for i in range(n - 1):
            a, b = self.points[i], self.points[i + 1]
            # shrink a segment touching a mouth so that its contact at the mouth is allowed
            a2 = a + 1e-6 * (b - a) if i == 0 and 0 in self.mouth_ends else a
            b2 = b - 1e-6 * (b - a) if i == n - 2 and -1 in self.mouth_ends else b
            for e0, e1 in edges:
                if segments_intersect(a2, b2, e0, e1, tol):
                    raise ParameterError("points", f"crack segment {i} crosses the outline")
            for k, (x, y, r) in enumerate(holes):
                if point_segment_distance((x, y), a, b) <= r + tol:
                    raise ParameterError("points", f"crack segment {i} reaches hole {k}")


def crack_gap(a: Crack2D, b: Crack2D) -> float:
    """The shortest distance between two cracks' polylines (m); 0 when they cross or
    touch (a tolerance of 10⁻⁹ of their extent)."""
    pa, pb = a.points, b.points
    tol = 1e-9 * float(np.ptp(np.vstack([pa, pb]), axis=0).max())
    for i in range(len(pa) - 1):
        for j in range(len(pb) - 1):
            if segments_intersect(pa[i], pa[i + 1], pb[j], pb[j + 1], tol):
                return 0.0
    return min(min(b.distance(p) for p in pa), min(a.distance(p) for p in pb))
