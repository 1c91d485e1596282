"""A planar crack in 3D: a disc (penny), an ellipse or a convex polygon
(docs/theory/fracture.md#3d-crack-fronts).

:class:`PlanarCrack` is the 3D ``[[crack]]`` of a scene: centre, unit normal, semi-axes and
the in-plane direction of the first semi-axis (a polygon: its vertices, the centroid, the
circum- and inradius about it).  Its front is an
:class:`~bonecontact.fracture.front3d.EllipticalFront` or a
:class:`~bonecontact.fracture.front3d.PolygonFront` (in the crack's frame), which gives
points, the local frame and arc length along the front for the stress intensity factors.
:class:`SurfaceBreakingCrack` is a semi-elliptical crack whose front meets the body's
surface (cut into the body by :mod:`bonecontact.fracture.surface_body3d`).
:func:`planar_crack_from_table` parses and checks the table (errors name the key).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.front3d import EllipticalFront, PolygonFront, PolylineFront

__all__ = [
    "CORNER_FRACTION",
    "CRACK3D_SHAPES",
    "SURFACE_SHAPES",
    "PlanarCrack",
    "SurfaceBreakingCrack",
    "TriangulatedCrack",
    "in_plane_axis",
    "planar_crack_from_table",
    "triangulated_from_polygon",
]

#: Shapes of a 3D crack.
CRACK3D_SHAPES = ("disc", "ellipse", "polygon", "semi_elliptical", "quarter_elliptical")
#: The shapes whose front meets the body's surface (:class:`SurfaceBreakingCrack`).
SURFACE_SHAPES = ("semi_elliptical", "quarter_elliptical")
_CORNER = "quarter_elliptical"
_UNIT_TOL = 1e-6
_PLANE_TOL = 1e-6  # distance from the best-fit plane, relative to the polygon's size
#: Front points on a polygon edge keep at least this fraction of the edge from its ends.
CORNER_FRACTION = 0.15


@dataclass(frozen=True)
class PlanarCrack:
    """A planar elliptical crack (a = b: a disc) or a convex polygon, with an interior
    front.

    Parameters
    ----------
    centre
        Centre (m); of a polygon its centroid.
    normal
        Unit normal of the crack plane; the ``crack_upper`` face is on its side.
    a, b
        Semi-axes (m), a ≥ b > 0; of a polygon the largest distance from the centroid to
        a vertex and the smallest to an edge.
    axis
        Unit in-plane direction of the semi-axis ``a`` (normal to ``normal``); of a
        polygon towards its first vertex.
    shape
        ``"disc"``, ``"ellipse"`` or ``"polygon"`` (names the size key in messages:
        ``radius``, ``semi_axes`` or ``vertices``).
    vertices
        The polygon's corners, counter-clockwise about ``normal`` (``None``: not a
        polygon).
    """

    centre: tuple[float, float, float]
    normal: tuple[float, float, float]
    a: float
    b: float
    axis: tuple[float, float, float]
    shape: str = "disc"
    vertices: tuple[tuple[float, float, float], ...] | None = None

    @property
    def size_key(self) -> str:
        """The key that sets the crack's size."""
        return {"disc": "radius", "ellipse": "semi_axes"}.get(self.shape, "vertices")

    @property
    def axes(self) -> npt.NDArray[np.float64]:
        """Rows (u, v, n): u = ``axis``, v = n × u, n = ``normal`` (right-handed)."""
        n, u = np.asarray(self.normal, dtype=float), np.asarray(self.axis, dtype=float)
        return np.vstack([u, np.cross(n, u), n])

    def front(self) -> EllipticalFront | PolygonFront:
        """The crack front."""
        centre = tuple(map(float, self.centre))
        axes = tuple(map(tuple, self.axes))
        if self.vertices is not None:
            return PolygonFront(self.vertices, centre, axes)
        return EllipticalFront(self.a, self.b, centre, axes)

    def front_parameters(self, n: int, margin: float = 0.0) -> npt.NDArray[np.float64]:
        """Front parameters φ of the points where K is evaluated.

        Disc, ellipse: ``n`` points equally spaced in arc length from φ = 0 (the end of
        the semi-axis ``a``).  Polygon: ``n`` points on every edge, away from its ends —
        one at the middle, several evenly from c to L − c, c = max(0.15 L, ``margin``)
        (L the edge's length; ``margin`` e.g. two front elements).
        """
        front = self.front()
        if isinstance(front, PolygonFront):
            out = []
            for k, L in enumerate(front.edge_lengths):
                c = min(max(CORNER_FRACTION * L, margin), 0.5 * L)
                t = [0.5 * L] if n == 1 else np.linspace(c, L - c, n)
                out.extend(float(np.sum(front.edge_lengths[:k])) + np.asarray(t))
            return 2 * math.pi * np.asarray(out) / front.perimeter
        phi = np.linspace(0.0, 2.0 * math.pi, 4001)
        s = front.arc_length(phi)
        s = s - s[0]
        target = np.arange(n) * front.perimeter / n
        return np.interp(target, s, phi)

    def sample_points(self, rings: int = 8, per_ring: int = 48) -> npt.NDArray[np.float64]:
        """Points covering the crack (its centre, ``rings`` ellipses or scaled polygons
        out to the front itself, a polygon's vertices), shape (m, 3)."""
        t = np.linspace(0.0, 2.0 * math.pi, per_ring, endpoint=False)
        c = np.asarray(self.centre, dtype=float)
        R = self.axes
        pts = [np.zeros((1, 3))]
        if self.vertices is not None:
            edge = self.front().point(t) - c
            edge = np.concatenate([edge, np.asarray(self.vertices, dtype=float) - c])
        else:
            edge = np.column_stack([self.a * np.cos(t), self.b * np.sin(t), 0 * t]) @ R
        for f in np.linspace(1.0 / rings, 1.0, rings):
            pts.append(f * edge)
        return c + np.concatenate(pts)


def _vector(table: Mapping, key: str) -> npt.NDArray[np.float64]:
    v = table.get(key)
    if (
        not isinstance(v, (list, tuple))
        or len(v) != 3
        or not all(isinstance(c, (int, float)) and not isinstance(c, bool) for c in v)
        or not all(math.isfinite(c) for c in v)
    ):
        raise ParameterError(key, f"must be [x, y, z] (three numbers), got {v!r}")
    return np.asarray(v, dtype=float)


def _unit(table: Mapping, key: str) -> npt.NDArray[np.float64]:
    v = _vector(table, key)
    length = float(np.linalg.norm(v))
    if abs(length - 1.0) > _UNIT_TOL:
        raise ParameterError(key, f"must be a unit vector, got {v.tolist()} (length {length:.6g})")
    return v / length


def _positive(v: object, key: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise ParameterError(key, f"must be a positive number (m), got {v!r}")
    return float(v)


def in_plane_axis(n: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """A unit vector in the plane normal to the unit vector ``n``: the coordinate axis
    least aligned with n, projected on the plane (the default axis of a disc, the first
    axis of a plane's basis)."""
    n = np.asarray(n, dtype=float)
    e = np.eye(3)[int(np.argmin(np.abs(n)))]
    u = e - np.dot(e, n) * n
    return u / np.linalg.norm(u)


@dataclass(frozen=True)
class SurfaceBreakingCrack:
    """A planar semi-elliptical crack centred on the body's surface, or (``shape =
    "quarter_elliptical"``) a quarter-elliptical corner crack centred on an edge of it.

    Parameters
    ----------
    centre
        A point of the body's surface (m): the middle of the crack's mouth; of a corner
        crack a point of the edge.
    normal
        Unit normal of the crack plane (the ``crack_upper`` side).
    depth, half_length
        a (into the body) and c (along the surface), m; of a corner crack a along one
        face and c (the scene's ``length``) along ``axis`` on the other.
    axis
        Unit in-plane direction of c (``None``: normal to the depth direction, the inward
        surface normal at the centre projected on the crack plane); a corner crack's is
        required: along a face, from the edge into it.
    shape
        ``"semi_elliptical"`` or ``"quarter_elliptical"``.
    """

    centre: tuple[float, float, float]
    normal: tuple[float, float, float]
    depth: float
    half_length: float
    axis: tuple[float, float, float] | None = None
    shape: str = "semi_elliptical"

    @property
    def size_key(self) -> str:
        """The key that sets the crack's size."""
        return "depth"

    @property
    def a(self) -> float:
        """The larger semi-axis (m)."""
        return max(self.depth, self.half_length)

    @property
    def b(self) -> float:
        """The smaller semi-axis (m)."""
        return min(self.depth, self.half_length)

    def with_axis(
        self, axis: tuple[float, float, float], centre: tuple[float, float, float] | None = None
    ) -> SurfaceBreakingCrack:
        """The same crack with its ``axis`` set (and its centre moved to ``centre``)."""
        c = self.centre if centre is None else centre
        return SurfaceBreakingCrack(c, self.normal, self.depth, self.half_length, axis, self.shape)

    def grown(self, depth: float, half_length: float, shift: float = 0.0) -> SurfaceBreakingCrack:
        """The crack with new semi-axes, its centre moved by ``shift`` (m) along ``axis``."""
        c = np.asarray(self.centre, dtype=float) + shift * np.asarray(self.axis, dtype=float)
        return SurfaceBreakingCrack(
            tuple(map(float, c)), self.normal, depth, half_length, self.axis, self.shape
        )


def _corner_crack_from_table(table: Mapping) -> SurfaceBreakingCrack:
    """A quarter-elliptical corner crack: ``centre`` (on an edge), ``normal``, ``depth``
    (a), ``length`` (c) and ``axis`` (the direction of c, in the crack plane)."""
    shape = 'shape = "quarter_elliptical"'
    for key in ("radius", "semi_axes", "vertices", "half_length"):
        if key in table:
            raise ParameterError(key, f"does not apply to {shape} (depth, length, axis)")
    for key in ("centre", "normal", "depth", "length", "axis"):
        if key not in table:
            raise ParameterError(key, f"is required ({shape})")
    centre = _vector(table, "centre")
    n = _unit(table, "normal")
    a, c = _positive(table["depth"], "depth"), _positive(table["length"], "length")
    u = _unit(table, "axis")
    if abs(float(np.dot(u, n))) > _UNIT_TOL:
        raise ParameterError("axis", "must lie in the crack plane (normal to `normal`)")
    return SurfaceBreakingCrack(
        tuple(map(float, centre)), tuple(map(float, n)), a, c, tuple(map(float, u)), _CORNER
    )


def _surface_crack_from_table(table: Mapping) -> SurfaceBreakingCrack:
    if "length" in table:
        raise ParameterError(
            "length", 'applies to shape = "quarter_elliptical" only (semi_elliptical: half_length)'
        )
    for key in ("radius", "semi_axes", "vertices"):
        if key in table:
            raise ParameterError(
                key, 'does not apply to shape = "semi_elliptical" (depth, half_length)'
            )
    for key in ("centre", "normal", "depth", "half_length"):
        if key not in table:
            raise ParameterError(key, 'is required (shape = "semi_elliptical")')
    centre = _vector(table, "centre")
    n = _unit(table, "normal")
    a, c = _positive(table["depth"], "depth"), _positive(table["half_length"], "half_length")
    axis = None
    if "axis" in table:
        u = _unit(table, "axis")
        if abs(float(np.dot(u, n))) > _UNIT_TOL:
            raise ParameterError("axis", "must lie in the crack plane (normal to `normal`)")
        axis = tuple(map(float, u))
    return SurfaceBreakingCrack(tuple(map(float, centre)), tuple(map(float, n)), a, c, axis)


def planar_crack_from_table(table: Mapping) -> PlanarCrack | SurfaceBreakingCrack:
    """Parse the geometry of a 3D ``[[crack]]``: ``shape = "disc"`` (``radius``) or
    ``"ellipse"`` (``semi_axes = [a, b]``, a ≥ b, and ``axis``, the in-plane direction of
    ``a``), with ``centre`` and the unit ``normal``; or ``"polygon"``: ``vertices``, a
    convex polygon in one plane, counter-clockwise about ``normal`` (optional; default
    the normal that makes them counter-clockwise).

    Raises
    ------
    ParameterError
        Naming the key: a missing or malformed value, a non-unit normal or axis, an axis
        not in the crack plane, a size ≤ 0, a key of another shape; a polygon with fewer
        than 3 vertices, off one plane (more than 10⁻⁶ of its size from the best-fit
        plane), of zero area, not convex or self-intersecting, or clockwise about the
        given normal.
    """
    shape = table.get("shape", "disc")
    if shape not in CRACK3D_SHAPES:
        raise ParameterError("shape", f"must be one of {', '.join(CRACK3D_SHAPES)}, got {shape!r}")
    if shape == "polygon":
        return _polygon_from_table(table)
    if shape == "semi_elliptical":
        return _surface_crack_from_table(table)
    if shape == _CORNER:
        return _corner_crack_from_table(table)
    for key in ("depth", "half_length", "length"):
        if key in table:
            raise ParameterError(
                key, 'applies to shape = "semi_elliptical" or "quarter_elliptical" only'
            )
    if "vertices" in table:
        raise ParameterError("vertices", 'applies to shape = "polygon" only')
    for key in ("centre", "normal", "radius" if shape == "disc" else "semi_axes"):
        if key not in table:
            raise ParameterError(key, f"is required (shape = {shape!r})")
    centre = _vector(table, "centre")
    n = _unit(table, "normal")
    if shape == "disc":
        for key in ("semi_axes", "axis"):
            if key in table:
                raise ParameterError(key, 'applies to shape = "ellipse" only')
        a = b = _positive(table["radius"], "radius")
        u = in_plane_axis(n)
    else:
        if "radius" in table:
            raise ParameterError("radius", 'applies to shape = "disc" only (ellipse: semi_axes)')
        ab = table["semi_axes"]
        if not isinstance(ab, (list, tuple)) or len(ab) != 2:
            raise ParameterError("semi_axes", f"must be [a, b] (m), got {ab!r}")
        a, b = (_positive(v, "semi_axes") for v in ab)
        if b > a:
            raise ParameterError("semi_axes", f"need a >= b (a along axis), got [{a}, {b}]")
        if "axis" not in table:
            raise ParameterError("axis", 'is required (shape = "ellipse")')
        u = _unit(table, "axis")
        if abs(float(np.dot(u, n))) > _UNIT_TOL:
            raise ParameterError("axis", "must lie in the crack plane (normal to `normal`)")
        u = u - np.dot(u, n) * n
        u = u / np.linalg.norm(u)
    return PlanarCrack(
        tuple(map(float, centre)), tuple(map(float, n)), a, b, tuple(map(float, u)), shape
    )


def _polygon_vertices(table: Mapping) -> npt.NDArray[np.float64]:
    v = table.get("vertices")
    if not isinstance(v, (list, tuple)) or len(v) < 3:
        raise ParameterError(
            "vertices", f"must be a list of at least 3 points [x, y, z], got {v!r}"
        )
    return np.array([_vector({"vertices": p}, "vertices") for p in v])


def _polygon_normal(table: Mapping, V: npt.NDArray[np.float64], size: float) -> np.ndarray:
    """The unit normal about which the vertices run counter-clockwise (checked against a
    given ``normal``); refuses vertices off one plane and a zero area."""
    c0 = V.mean(axis=0)
    fit = np.linalg.svd(V - c0)[2][2]  # the best-fit plane's normal
    dist = np.abs((V - c0) @ fit)
    if dist.max() > _PLANE_TOL * size:
        k = int(np.argmax(dist))
        raise ParameterError(
            "vertices",
            f"must lie in one plane: vertex {k + 1} is {dist[k]:.3g} m from the best-fit plane "
            f"(tolerance {_PLANE_TOL:g} of the polygon's size, {size:.3g} m)",
        )
    area_vec = 0.5 * np.sum(np.cross(V - c0, np.roll(V, -1, axis=0) - c0), axis=0)
    if float(np.linalg.norm(area_vec)) <= 1e-9 * size**2:
        raise ParameterError(
            "vertices",
            "the polygon has zero area (collinear vertices, or a boundary crossing itself)",
        )
    n = fit if area_vec @ fit > 0 else -fit
    if "normal" in table:
        given = _unit(table, "normal")
        if abs(float(given @ n)) < 1.0 - _UNIT_TOL:
            raise ParameterError(
                "normal", "must be normal to the plane of the vertices (or left out)"
            )
        if given @ n < 0:
            raise ParameterError(
                "vertices",
                "must run counter-clockwise about `normal` (they run clockwise: reverse "
                "them, or flip or leave out the normal)",
            )
    return n


def _check_convex(V: npt.NDArray[np.float64], n: np.ndarray, size: float) -> None:
    """Refuse coincident vertices, a turn that is not to the left, and a boundary that
    winds more than once (self-intersecting)."""
    d = np.roll(V, -1, axis=0) - V
    lengths = np.linalg.norm(d, axis=1)
    if lengths.min() <= 1e-9 * size:
        k = int(np.argmin(lengths))
        raise ParameterError("vertices", f"vertices {k + 1} and {(k + 1) % len(V) + 1} coincide")
    d = d / lengths[:, None]
    turn = np.cross(d, np.roll(d, -1, axis=0)) @ n  # sin of the turn at vertex k + 1
    if turn.min() <= 1e-9:
        k = int(np.argmin(turn))
        raise ParameterError(
            "vertices",
            f"must form a convex polygon (no turn to the right or straight on: vertex "
            f"{(k + 1) % len(V) + 1}); concave and self-intersecting polygons are not "
            "supported",
        )
    angles = np.arctan2(turn, np.sum(d * np.roll(d, -1, axis=0), axis=1))
    if abs(float(angles.sum()) - 2 * math.pi) > 1e-6:
        raise ParameterError(
            "vertices",
            "the polygon intersects itself (its boundary turns "
            f"{math.degrees(float(angles.sum())):.0f} deg, not 360)",
        )


def _polygon_from_table(table: Mapping) -> PlanarCrack:
    """A ``shape = "polygon"`` crack: its vertices checked, centroid, circum/inradius."""
    for key in ("centre", "radius", "semi_axes", "axis"):
        if key in table:
            raise ParameterError(key, 'does not apply to shape = "polygon" (its vertices set it)')
    if "vertices" not in table:
        raise ParameterError("vertices", 'is required (shape = "polygon")')
    V = _polygon_vertices(table)
    size = float(max(np.linalg.norm(V - p, axis=1).max() for p in V))
    if size == 0.0:
        raise ParameterError("vertices", "the polygon has zero area (coincident vertices)")
    n = _polygon_normal(table, V, size)
    _check_convex(V, n, size)
    tri = np.cross(V[1:-1] - V[0], V[2:] - V[0]) @ n  # twice the fan triangles' areas
    centre = np.sum(tri[:, None] * (V[0] + V[1:-1] + V[2:]) / 3, axis=0) / tri.sum()
    V = V - np.outer((V - centre) @ n, n)  # exactly in the plane
    u = V[0] - centre
    u = u / np.linalg.norm(u)
    verts = tuple(tuple(map(float, p)) for p in V)
    front = PolygonFront(
        verts, tuple(map(float, centre)), (tuple(u), tuple(np.cross(n, u)), tuple(n))
    )
    return PlanarCrack(
        tuple(map(float, centre)),
        tuple(map(float, n)),
        front.a,
        front.b,
        tuple(map(float, u)),
        "polygon",
        verts,
    )


@dataclass(frozen=True)
class TriangulatedCrack:
    """A grown, non-planar crack: planar patches (the first crack and the strips of
    every advance) with a closed polyline front (docs/theory/fracture.md#mixed-mode-advance-in-3d).

    Parameters
    ----------
    points
        Coordinates (m), shape (M, 3).
    patches
        Planar polygons (indices into ``points``), each counter-clockwise seen from the
        side ``normal`` points to (the ``crack_upper`` face).
    front
        Indices of the front's vertices, in order (counter-clockwise about ``normal``).
    normals2
        The surface normal e₂ at every front edge (front vertex k to k + 1), shape (N, 3).
    cuts
        (L, ψ) of every front edge (the kink behind it, see
        :class:`~bonecontact.fracture.front3d.PolylineFront`), or ``None``.
    normal
        A unit normal of the whole crack (the first crack's).
    """

    points: tuple[tuple[float, float, float], ...]
    patches: tuple[tuple[int, ...], ...]
    front_ids: tuple[int, ...]
    normals2: tuple[tuple[float, float, float], ...]
    cuts: tuple[tuple[float, float], ...] | None
    normal: tuple[float, float, float]
    shape: str = "surface"

    @property
    def vertices(self) -> npt.NDArray[np.float64]:
        """The front's vertices (m), shape (N, 3)."""
        return np.asarray(self.points, dtype=float)[list(self.front_ids)]

    def front(self) -> PolylineFront:
        """The crack front."""
        return PolylineFront(
            tuple(map(tuple, self.vertices)), self.normals2, self.cuts, self.normal
        )

    @property
    def a(self) -> float:
        """The largest distance from the front's centroid to a front vertex (m)."""
        return self.front().a

    @property
    def b(self) -> float:
        """The smallest distance from the front's centroid to a front edge (m)."""
        return self.front().b

    def front_parameters(self, n: int, margin: float = 0.0) -> npt.NDArray[np.float64]:
        """``n`` points on every front edge, as for a polygon
        (:meth:`PlanarCrack.front_parameters`)."""
        front = self.front()
        out = []
        for k, L in enumerate(front.edge_lengths):
            c = min(max(CORNER_FRACTION * L, margin), 0.5 * L)
            t = [0.5 * L] if n == 1 else np.linspace(c, L - c, n)
            out.extend(float(np.sum(front.edge_lengths[:k])) + np.asarray(t))
        return 2 * math.pi * np.asarray(out) / front.perimeter


def triangulated_from_polygon(crack: PlanarCrack) -> TriangulatedCrack:
    """A polygonal :class:`PlanarCrack` as a one-patch :class:`TriangulatedCrack`."""
    if crack.vertices is None:
        raise ParameterError("shape", f'needs shape = "polygon", got {crack.shape!r}')
    V = np.asarray(crack.vertices, dtype=float)
    ids = tuple(range(len(V)))
    n = tuple(map(float, crack.normal))
    return TriangulatedCrack(tuple(map(tuple, V)), (ids,), ids, tuple(n for _ in ids), None, n)
