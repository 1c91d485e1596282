"""A semi-elliptical surface crack cut into a scene's 3D body
(docs/theory/fracture.md#surface-cracks-in-a-scenes-body).

The crack is planar: centre C on the body's surface, unit normal n, depth a (into the
body, along the inward surface normal projected on the crack plane) and half-length c
(along the surface).  :func:`cut_mouth` splits the body's boundary triangles along the
line where the crack plane meets them (vertices within 2 % of an edge of the plane are
moved onto it) and inserts the two points where that line leaves the ellipse: the
*mouth*, a chain of boundary nodes, and the *front*, the arc of the ellipse inside the
body (:class:`BodyArcFront`, its ends on the surface).  :func:`mesh_body_with_surface_crack`
meshes the crack surface (bounded by the mouth and the front) with triangles graded
towards the front, embeds it in the volume bounded by the cut boundary, meshes the volume
by tetrahedra (HXT; Delaunay where HXT leaves a flat tetrahedron, as it can between the
coplanar nodes of a coarse scan's facets) and splits the crack nodes — the mouth's
included, the front's not — into the faces ``crack_upper`` and ``crack_lower`` with
gmsh's ``Crack`` plugin (checked: :mod:`~bonecontact.fracture.crack_split`).  The
boundary's facet groups keep their names and tags.  All gmsh work runs on rank 0.

Several cracks (:func:`cut_mouths`, :func:`mesh_body_with_surface_cracks`): cut one after
the other, embedded together, each split into its own faces.  Limits: planar cracks, one
cell group; the mouth must be one chain of the surface (the plane must not graze the
surface near the crack).
"""

from __future__ import annotations

import math
from contextlib import nullcontext
from dataclasses import dataclass

from mpi4py import MPI

import gmsh
import numpy as np
import numpy.typing as npt
from dolfinx.io.gmsh import model_to_mesh

from bonecontact.common.errors import ParameterError
from bonecontact.common.geometry import point_triangle_distance
from bonecontact.fracture.body3d import BodySurface, CrackedBody3D, face_side_sign
from bonecontact.fracture.crack3d import SurfaceBreakingCrack
from bonecontact.fracture.crack_split import crack_surface, split_checked
from bonecontact.fracture.front3d import EllipticalFront
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.surface3d import EllipticalArcFront
from bonecontact.meshing.builder import MeshingError
from bonecontact.meshing.session import gmsh_session

__all__ = [
    "CORNER",
    "BodyArcFront",
    "CutBody",
    "EdgeFace",
    "corner_angle",
    "corner_frame",
    "corner_parameter",
    "corner_point",
    "crack_frame",
    "cut_mouth",
    "cut_mouths",
    "faces_at",
    "inside_body",
    "mesh_body_with_surface_crack",
    "mesh_body_with_surface_cracks",
    "onto_edge",
]

#: A vertex closer to the crack plane than this fraction of the mean edge is moved onto it.
SNAP_FRACTION = 0.02


@dataclass(frozen=True)
class BodyArcFront(EllipticalArcFront):
    """An :class:`~bonecontact.fracture.surface3d.EllipticalArcFront` whose arc may start
    below φ = 0 (−2π ≤ φ₀ < φ₁ ≤ φ₀ + 2π): on a concave surface the front of a crack
    centred on the surface reaches a little beyond the ends of the major axis (on a
    convex one it stops short of them)."""

    def __post_init__(self) -> None:
        EllipticalFront.__post_init__(self)
        p0, p1 = self.phi_range
        if not (-2 * math.pi <= p0 < p1 <= p0 + 2 * math.pi):
            raise ParameterError("phi_range", f"need phi0 < phi1 <= phi0 + 2 pi, got {p0}, {p1}")


@dataclass(frozen=True)
class CutBody:
    """The body's boundary with the crack's mouth cut into it.

    Attributes
    ----------
    nodes, triangles, tags
        Boundary nodes (M, 3), triangles (node indices, outward) and their facet tags.
    mouth
        Node indices of the mouth, from the front's end at φ₀ to the one at φ₁.
    arc
        The front (the ellipse's arc inside the body).
    crack
        The crack with its ``axis`` (the direction of c) set.
    """

    nodes: npt.NDArray[np.float64]
    triangles: npt.NDArray[np.int64]
    tags: npt.NDArray[np.int32]
    mouth: tuple[int, ...]
    arc: BodyArcFront
    crack: SurfaceBreakingCrack

    def front(self) -> BodyArcFront:
        """The crack front."""
        return self.arc

    @property
    def normal(self) -> tuple[float, float, float]:
        return self.crack.normal

    @property
    def a(self) -> float:
        """The larger semi-axis (m): the scale of tolerances."""
        return self.arc.a


# ------------------------------------------------------------------- geometry (numpy)
def unique_nodes(body: BodySurface) -> tuple[np.ndarray, np.ndarray]:
    """Merged boundary nodes and the triangles' node indices, in a canonical order (the
    gathered order depends on the partition)."""
    tol = 1e-9 * body.scale
    xyz = body.triangles.reshape(-1, 3)
    keys = np.round(xyz / tol).astype(np.int64)
    _, first, inv = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    conn = inv.reshape(-1, 3)
    start = np.argmin(conn, axis=1)
    conn = np.stack([np.roll(c, -k) for c, k in zip(conn, start, strict=True)])
    order = np.lexsort(conn.T[::-1])
    return xyz[first].copy(), conn[order], body.tags[order]


def _edge(t: np.ndarray, k: int) -> tuple[int, int]:
    a, b = int(t[k]), int(t[(k + 1) % 3])
    return (a, b) if a < b else (b, a)


def _split_edges(conn: np.ndarray, marked: np.ndarray) -> set[tuple[int, int]]:
    """The edges to halve: those of the marked triangles, closed so that no triangle has
    exactly two (red-green refinement: a triangle with two gets its third)."""
    edges = {
        tuple(sorted((int(t[k]), int(t[(k + 1) % 3])))) for t in conn[marked] for k in range(3)
    }
    while True:
        more = set()
        for t in conn:
            own = [_edge(t, k) for k in range(3)]
            hit = [e in edges for e in own]
            if sum(hit) == 2:
                more.add(own[hit.index(False)])
        if not more:
            return edges
        edges |= more


def _refine_once(nodes: np.ndarray, conn: np.ndarray, tags: np.ndarray, marked: np.ndarray):
    """One red-green step: marked triangles in four, their neighbours halved."""
    edges = _split_edges(conn, marked)
    X = list(nodes)
    mid = {}
    for e in sorted(edges):
        X.append(0.5 * (nodes[e[0]] + nodes[e[1]]))
        mid[e] = len(X) - 1
    out, out_tags = [], []
    for t, tag in zip(conn, tags, strict=True):
        a, b, c = (int(v) for v in t)
        m = [mid.get(tuple(sorted(e))) for e in ((a, b), (b, c), (c, a))]
        if all(k is None for k in m):
            new = [(a, b, c)]
        elif all(k is not None for k in m):
            new = [(a, m[0], m[2]), (m[0], b, m[1]), (m[2], m[1], c), (m[0], m[1], m[2])]
        else:
            k = next(i for i in range(3) if m[i] is not None)
            v = (a, b, c)
            p, q, r = v[k], v[(k + 1) % 3], v[(k + 2) % 3]
            new = [(p, m[k], r), (m[k], q, r)]
        out += new
        out_tags += [tag] * len(new)
    return np.asarray(X), np.asarray(out, dtype=np.int64), np.asarray(out_tags, dtype=np.int32)


def refine_near(nodes, conn, tags, size, levels: int = 6):
    """Halve the boundary triangles whose longest edge exceeds twice ``size`` (a function
    of points) at their centroid, level by level."""
    for _ in range(levels):
        tri = nodes[conn]
        longest = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
        marked = longest > 2.0 * size(tri.mean(axis=1))
        if not marked.any():
            break
        nodes, conn, tags = _refine_once(nodes, conn, tags, marked)
    return nodes, conn, tags


def _nearest_triangle(nodes: np.ndarray, conn: np.ndarray, x: np.ndarray) -> int:
    """The boundary triangle nearest to ``x`` (by distance, not by centroid: a large facet's
    centroid can lie farther than a small facet's of another surface nearby)."""
    return int(np.argmin(point_triangle_distance(x, nodes[conn])))


def crack_frame(
    crack: SurfaceBreakingCrack, nodes: np.ndarray, conn: np.ndarray
) -> tuple[EllipticalFront, SurfaceBreakingCrack]:
    """The crack's ellipse (the major semi-axis along u) and the crack with its axis: the
    centre is moved onto the plane of the nearest boundary triangle (the faceted surface),
    the depth direction is the inward mean normal of the boundary triangles with a corner
    within :func:`_normal_reach` of it projected on the crack plane; c lies along ``axis``
    (default: normal to the depth and to n; given, the depth is n × axis on the side the
    mean normal points away from, the mean taken with the centre's facet).

    Raises
    ------
    ParameterError
        (key ``normal``) the crack plane is tangent to the surface at the centre; (key
        ``centre``) the centre lies farther than min(a, c)/4 from the surface.
    """
    if crack.shape == CORNER:
        return corner_frame(crack, nodes, conn)
    n = np.asarray(crack.normal, dtype=float)
    C = np.asarray(crack.centre, dtype=float)
    nearest = _nearest_triangle(nodes, conn, C)
    tri = nodes[conn[nearest]]
    m = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    off = abs(float((C - tri[0]) @ m)) / math.sqrt(float(m @ m))
    if off > 0.25 * min(crack.depth, crack.half_length):
        raise ParameterError(
            "centre",
            f"is {off:.3g} m from the body's surface (the nearest facet's plane): more than a "
            "quarter of the smaller semi-axis",
        )
    C = C - ((C - tri[0]) @ m) / (m @ m) * m  # onto the discrete surface
    _refuse_edge(crack, nodes, conn, C)
    x = nodes[conn]
    near = np.min(np.linalg.norm(x - C, axis=2), axis=1) < _normal_reach(crack)  # a corner
    if crack.axis is not None:  # the centre's own facet, however large
        near[nearest] = True
    if near.any():  # the mean (area-weighted) normal around the centre
        m = np.cross(x[near, 1] - x[near, 0], x[near, 2] - x[near, 0]).sum(axis=0)
    m = m / np.linalg.norm(m)
    v0 = -(m - (m @ n) * n)
    if np.linalg.norm(v0) < 0.2:
        raise ParameterError(
            "normal", "the crack plane is (nearly) tangent to the body's surface at its centre"
        )
    v0 = v0 / np.linalg.norm(v0)
    if crack.axis is not None:
        t = np.asarray(crack.axis, dtype=float)
        v0 = np.cross(n, t)  # depth normal to the given axis, on the inward side
        v0 = v0 if v0 @ -m > 0 else -v0
    t = np.cross(v0, n)
    a, c = crack.depth, crack.half_length
    axes = (t, v0, n) if c >= a else (v0, np.cross(n, v0), n)
    ell = EllipticalFront(max(a, c), min(a, c), tuple(C), tuple(map(tuple, axes)))
    return ell, crack.with_axis(tuple(map(float, t)), tuple(map(float, C)))


# ------------------------------------------------------------ corner cracks (numpy)
#: The shape of a quarter-elliptical corner crack.
CORNER = "quarter_elliptical"
#: A corner crack's edge: its faces' dihedral angle within this of 90° (degrees).
CORNER_ANGLE_TOL = 20.0
#: Facet normals farther apart than this (degrees) belong to different faces.
FACE_SPLIT_DEG = 30.0
#: A corner crack's plane: its normal within this of the edge's direction (degrees); its
#: ``axis`` within this of the plane's line in a face.
CORNER_ALIGN_DEG = 30.0


@dataclass(frozen=True)
class EdgeFace:
    """One face at an edge: its unit outward normal (area-weighted over its facets near
    the centre), a point on it and the mean of its facets' centroids."""

    normal: npt.NDArray[np.float64]
    point: npt.NDArray[np.float64]
    centroid: npt.NDArray[np.float64]


def faces_at(nodes: np.ndarray, conn: np.ndarray, C: np.ndarray, reach: float) -> list[EdgeFace]:
    """The faces of the boundary within ``reach`` of ``C``: the facets there grouped by
    their normals (a facet joins the first group whose normal lies within
    :data:`FACE_SPLIT_DEG` of its own), the group of the nearest facet first."""
    tris = nodes[conn]
    dist = point_triangle_distance(C, tris)
    near = np.flatnonzero(dist < reach)
    near = near[np.argsort(dist[near], kind="stable")]
    m = np.cross(tris[near, 1] - tris[near, 0], tris[near, 2] - tris[near, 0])
    unit = m / np.linalg.norm(m, axis=1)[:, None]
    groups: list[list[int]] = []
    for i in range(len(near)):
        for g in groups:
            if unit[g[0]] @ unit[i] > math.cos(math.radians(FACE_SPLIT_DEG)):
                g.append(i)
                break
        else:
            groups.append([i])
    out = []
    for g in groups:
        mean = m[g].sum(axis=0)
        unit_mean = mean / np.linalg.norm(mean)
        out.append(EdgeFace(unit_mean, tris[near[g[0]], 0], tris[near[g]].mean(axis=(0, 1))))
    return out


def onto_edge(C: np.ndarray, faces: list[EdgeFace]) -> np.ndarray:
    """The point of the line where the two faces' planes meet nearest to ``C``."""
    M = np.array([f.normal for f in faces[:2]])
    r = np.array([f.normal @ (f.point - C) for f in faces[:2]])
    return C + M.T @ np.linalg.solve(M @ M.T, r)


def _edge_faces(crack: SurfaceBreakingCrack, nodes: np.ndarray, conn: np.ndarray) -> list[EdgeFace]:
    """The two faces of the (convex, about right-angled) edge at the crack's centre.

    Raises
    ------
    ParameterError
        (``centre``) one face or more than two within min(a, c)/4 of the centre, an edge
        far from 90° or a re-entrant one.
    """
    C = np.asarray(crack.centre, dtype=float)
    reach = 0.25 * min(crack.depth, crack.half_length)
    faces = faces_at(nodes, conn, C, reach)
    if len(faces) != 2:
        raise ParameterError(
            "centre",
            f"must lie on an edge of the body, where two faces meet (a quarter_elliptical "
            f"crack): {len(faces)} face(s) lie within {reach:.3g} m of it (a quarter of the "
            "smaller of depth and length)",
        )
    fa, fb = faces
    angle = 180.0 - math.degrees(math.acos(float(np.clip(fa.normal @ fb.normal, -1, 1))))
    if abs(angle - 90.0) > CORNER_ANGLE_TOL:
        raise ParameterError(
            "centre",
            f"the faces at the centre meet at {angle:.0f} deg; a quarter_elliptical crack "
            f"needs an edge of 90 +- {CORNER_ANGLE_TOL:g} deg",
        )
    if (fb.centroid - C) @ fa.normal > 0 or (fa.centroid - C) @ fb.normal > 0:
        raise ParameterError(
            "centre", "lies on a re-entrant edge (a quarter_elliptical crack needs a convex one)"
        )
    return faces


def _corner_axis(
    crack: SurfaceBreakingCrack, faces: list[EdgeFace]
) -> tuple[np.ndarray, np.ndarray]:
    """The directions of c (the given ``axis`` moved onto the line of the crack plane in
    the face it lies along, from the edge into that face) and of a (the line in the other
    face, into it).

    Raises
    ------
    ParameterError
        (``normal``) the crack plane does not cross the edge; (``axis``) not along a face,
        or pointing out of the body.
    """
    n = np.asarray(crack.normal, dtype=float)
    edge = np.cross(faces[0].normal, faces[1].normal)
    edge /= np.linalg.norm(edge)
    if abs(edge @ n) < math.cos(math.radians(CORNER_ALIGN_DEG)):
        raise ParameterError(
            "normal",
            f"a quarter_elliptical crack's plane must cross the edge: its normal within "
            f"{CORNER_ALIGN_DEG:g} deg of the edge's direction {_fmt(edge)}",
        )
    lines = []
    for f, other in (faces, faces[::-1]):
        d = np.cross(n, f.normal)
        d /= np.linalg.norm(d)
        lines.append(d if d @ other.normal < 0 else -d)  # into the face f, off the edge
    u = np.asarray(crack.axis, dtype=float)
    k = int(np.argmax([abs(u @ d) for d in lines]))
    if abs(u @ lines[k]) < math.cos(math.radians(CORNER_ALIGN_DEG)):
        raise ParameterError(
            "axis",
            f"must lie along one of the faces at the edge (in the crack plane: {_fmt(lines[0])} "
            f"or {_fmt(lines[1])}), within {CORNER_ALIGN_DEG:g} deg",
        )
    if u @ lines[k] < 0:
        raise ParameterError(
            "axis", f"points out of the body: from the edge into the face it is {_fmt(lines[k])}"
        )
    return lines[k], lines[1 - k]


def _refuse_edge(
    crack: SurfaceBreakingCrack, nodes: np.ndarray, conn: np.ndarray, C: np.ndarray
) -> None:
    """Refuse a semi-elliptical crack centred on an edge (two faces at 90 ± 20° within
    min(a, c)/4 of the centre): its depth direction would be the faces' mean normal, the
    diagonal, and its ellipse neither face's (key ``centre``; a corner crack is
    ``shape = "quarter_elliptical"``)."""
    faces = faces_at(nodes, conn, C, 0.25 * min(crack.depth, crack.half_length))
    for f in faces[1:]:
        if abs(float(faces[0].normal @ f.normal)) <= math.sin(math.radians(CORNER_ANGLE_TOL)):
            raise ParameterError(
                "centre",
                "lies on an edge of the body (two faces meet within a quarter of the smaller "
                'semi-axis): a crack there is a corner crack, shape = "quarter_elliptical" '
                "(with length, depth and axis)",
            )


def _fmt(v: np.ndarray) -> str:
    return "[" + ", ".join(f"{float(x):.3g}" for x in v) + "]"


def corner_frame(
    crack: SurfaceBreakingCrack, nodes: np.ndarray, conn: np.ndarray
) -> tuple[EllipticalFront, SurfaceBreakingCrack]:
    """The ellipse of a quarter-elliptical corner crack and the crack with its centre on
    the edge and its ``axis`` along its face: c along the face ``axis`` lies along, a
    along the other (:func:`_corner_axis`; the plane's in-plane depth direction made
    normal to the axis).  The frame is :func:`crack_frame`'s (the larger semi-axis along
    u, right-handed about n).

    Raises
    ------
    ParameterError
        See :func:`_edge_faces` and :func:`_corner_axis`.
    """
    faces = _edge_faces(crack, nodes, conn)
    n = np.asarray(crack.normal, dtype=float)
    C = onto_edge(np.asarray(crack.centre, dtype=float), faces)
    t, depth = _corner_axis(crack, faces)
    v0 = np.cross(n, t)
    v0 = v0 if v0 @ depth > 0 else -v0
    a, c = crack.depth, crack.half_length
    axes = (np.cross(v0, n), v0, n) if c >= a else (v0, np.cross(n, v0), n)
    ell = EllipticalFront(max(a, c), min(a, c), tuple(C), tuple(map(tuple, axes)))
    return ell, crack.with_axis(tuple(map(float, t)), tuple(map(float, C)))


def corner_point(crack: SurfaceBreakingCrack, ell: EllipticalFront, psi: float) -> np.ndarray:
    """The point of a corner crack's ellipse at Newman and Raju's angle ψ: C + c cos ψ t +
    a sin ψ d (t the crack's ``axis``, d its depth direction in the frame ``ell``): ψ = 0
    on the face of c, π/2 on the face of a."""
    t = np.asarray(crack.axis, dtype=float)
    d = _depth_direction(ell, crack)
    C = np.asarray(ell.centre, dtype=float)
    return C + crack.half_length * math.cos(psi) * t + crack.depth * math.sin(psi) * d


def corner_angle(cut: CutBody, x: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Newman and Raju's angle ψ of points ``x`` (m, (k, 3)) of a corner crack's front:
    tan ψ = (x − C)·d / a ÷ (x − C)·t / c (t the ``axis``, d the depth direction).  Of a
    semi-elliptical crack the same formula gives Newman and Raju's parametric angle φ (0
    and π at the surface ends, the end along +t at 0; π/2 at the deepest point)."""
    X = np.atleast_2d(np.asarray(x, dtype=float)) - np.asarray(cut.arc.centre)
    t = np.asarray(cut.crack.axis, dtype=float)
    d = _depth_direction(cut.arc, cut.crack)
    return np.arctan2(X @ d / cut.crack.depth, X @ t / cut.crack.half_length)


def corner_parameter(cut: CutBody, psi: float) -> float:
    """The front parameter φ (within the arc's range) of Newman and Raju's angle ψ."""
    x = corner_point(cut.crack, cut.arc, psi)
    phi = _arc_parameter(cut.arc, x)
    return phi + 2 * math.pi if phi < cut.arc.phi_range[0] - 1e-9 else phi


def _normal_reach(crack: SurfaceBreakingCrack) -> float:
    """The radius around the centre whose facets' mean normal is the surface's: max(a, c)
    when the crack has no ``axis`` (the mean normal sets the depth direction: the surface
    over the mouth's extent); min(a, c)/4 (the centre's tolerance; with the centre's own
    facet) when it has one (a grown crack: the axis fixes the depth direction, the normal
    only its side and the tangency check — the surface at the centre).  Within max(a, c)
    of a grown crack lie other faces of the body: 17 mm from the centre of a crack in the
    scanned L4's posterior wall its base, 14 mm below and normal to the crack plane, made
    the plane look tangent (the in-plane part of the mean normal 0.12)."""
    a, c = crack.depth, crack.half_length
    return max(a, c) if crack.axis is None else 0.25 * min(a, c)


def _ellipse_rho(ell: EllipticalFront, x: np.ndarray) -> np.ndarray:
    loc = ell.local(x)
    return np.hypot(loc[:, 0] / ell.a, loc[:, 1] / ell.b)


def _snap(nodes: np.ndarray, conn: np.ndarray, C: np.ndarray, n: np.ndarray, reach: float):
    """Move the vertices near the crack within the snap distance onto its plane."""
    edges = np.linalg.norm(nodes[conn] - nodes[np.roll(conn, 1, axis=1)], axis=2)
    near_t = np.linalg.norm(nodes[conn].mean(axis=1) - C, axis=1) < reach
    h = float(np.mean(edges[near_t])) if near_t.any() else float(np.mean(edges))
    s = (nodes - C) @ n
    near = np.linalg.norm(nodes - C, axis=1) < reach
    snap = near & (np.abs(s) < SNAP_FRACTION * h) & (s != 0)
    nodes = nodes.copy()
    nodes[snap] -= s[snap, None] * n
    s[snap] = 0.0
    s[~near] = np.where(s[~near] == 0, 1e-300, s[~near])  # far vertices never on the plane
    return nodes, np.sign(s)


class PlaneCutter:
    """Splits the triangles crossed by the plane; collects the chords (plane ∩ triangle)."""

    def __init__(self, nodes: np.ndarray, sign: np.ndarray, C: np.ndarray, n: np.ndarray):
        self.nodes = [p for p in nodes]
        self.sign = list(sign)
        self.C, self.n = C, n
        self.crossing: dict[tuple[int, int], int] = {}
        self.chords: dict[int, tuple[int, int]] = {}  # triangle → chord (p, q)

    def _cross(self, i: int, j: int) -> int:
        key = (min(i, j), max(i, j))
        if key not in self.crossing:
            p, q = self.nodes[i], self.nodes[j]
            sp, sq = (p - self.C) @ self.n, (q - self.C) @ self.n
            x = p + sp / (sp - sq) * (q - p)
            x = x - ((x - self.C) @ self.n) * self.n
            self.nodes.append(x)
            self.sign.append(0.0)
            self.crossing[key] = len(self.nodes) - 1
        return self.crossing[key]

    def polygon(self, tri: np.ndarray) -> list[int]:
        """The triangle's corners with the crossing points inserted, in its order."""
        out = []
        for k in range(3):
            i, j = int(tri[k]), int(tri[(k + 1) % 3])
            out.append(i)
            if self.sign[i] * self.sign[j] < 0:
                out.append(self._cross(i, j))
        return out

    def chord(self, t: int, tri: np.ndarray) -> None:
        poly = self.polygon(tri)
        zero = [p for p in poly if self.sign[p] == 0]
        if len(zero) == 2:
            self.chords[t] = (zero[0], zero[1])


def chord_chains(chords: dict[int, tuple[int, int]]) -> list[list[int]]:
    """The chords joined into chains of nodes (each chain open or closed)."""
    adj: dict[int, list[int]] = {}
    for p, q in set(tuple(sorted(c)) for c in chords.values()):
        adj.setdefault(p, []).append(q)
        adj.setdefault(q, []).append(p)
    seen: set[int] = set()
    chains = []
    for start in sorted(adj, key=lambda k: (len(adj[k]) != 1, k)):
        if start in seen:
            continue
        chain, prev, cur = [start], None, start
        seen.add(start)
        while True:
            nxt = [k for k in adj[cur] if k != prev and k not in seen]
            if not nxt:
                break
            prev, cur = cur, nxt[0]
            chain.append(cur)
            seen.add(cur)
        chains.append(chain)
    return chains


def _segment_exit(ell: EllipticalFront, p: np.ndarray, q: np.ndarray) -> float:
    """The fraction t ∈ (0, 1] along p → q where the segment leaves the ellipse (p inside)."""
    lp, lq = ell.local(np.array([p, q]))
    d = lq - lp
    A = (d[0] / ell.a) ** 2 + (d[1] / ell.b) ** 2
    B = 2 * (lp[0] * d[0] / ell.a**2 + lp[1] * d[1] / ell.b**2)
    Cc = (lp[0] / ell.a) ** 2 + (lp[1] / ell.b) ** 2 - 1.0
    return float((-B + math.sqrt(max(B * B - 4 * A * Cc, 0.0))) / (2 * A))


def _opened(cut: PlaneCutter, chain: list[int], ell: EllipticalFront) -> list[int]:
    """A closed chain (its ends joined by a chord: the plane cuts a loop of the surface
    such as a canal's wall) started at its node farthest outside the ellipse (it starts at
    its lowest node index, wherever that lies: the stretch inside the ellipse could wrap
    round its ends); an open chain as it is.  The order along the loop is kept."""
    ends = tuple(sorted((chain[0], chain[-1])))
    closed = len(chain) > 2 and any(tuple(sorted(c)) == ends for c in cut.chords.values())
    rho = _ellipse_rho(ell, np.asarray(cut.nodes)[chain])
    if not closed:
        return chain
    k = int(np.argmax(rho))
    return chain[k:] + chain[:k]


def _mouth_chain(cut: PlaneCutter, ell: EllipticalFront) -> tuple[list[int], list[float]]:
    """The chain through the crack's centre: its nodes inside the ellipse and the exit
    fractions on the segments beyond each end."""
    C = np.asarray(ell.centre)
    X = np.asarray(cut.nodes)
    best = None
    for chain in chord_chains(cut.chords):
        d = float(np.min(np.linalg.norm(X[chain] - C, axis=1)))
        if best is None or d < best[0]:
            best = (d, chain)
    if best is None or best[0] > ell.b:
        raise ParameterError("centre", "the crack plane does not cut the body's surface there")
    chain = _opened(cut, best[1], ell)
    rho = _ellipse_rho(ell, X[chain])
    inside = np.flatnonzero(rho < 1.0)
    k0 = int(np.argmin(np.linalg.norm(X[chain] - C, axis=1)))
    lo = hi = k0
    while lo - 1 >= 0 and rho[lo - 1] < 1.0:
        lo -= 1
    while hi + 1 < len(chain) and rho[hi + 1] < 1.0:
        hi += 1
    if rho[k0] >= 1.0 or lo == 0 or hi == len(chain) - 1 or len(inside) > hi - lo + 1:
        raise ParameterError(
            "half_length",
            "the mouth of the crack is not one stretch of the surface inside the ellipse "
            "(the crack reaches too far along the surface, or the centre is off it)",
        )
    nodes = chain[lo : hi + 1]
    ends = [chain[lo - 1], chain[hi + 1]]
    t = [_segment_exit(ell, X[nodes[0]], X[ends[0]]), _segment_exit(ell, X[nodes[-1]], X[ends[1]])]
    return [ends[0], *nodes, ends[1]], t


def _end_node(cut: PlaneCutter, p: int, q: int, t: float, edge: bool) -> tuple[int, bool]:
    """The front's end on the chord p (inside) → q at fraction t: p if t < 0.1, q if q is
    a vertex and t > 0.9 (or the chord is a mesh edge: the nearer of the two), else a new
    node inside the triangle (t at most 0.9).  Returns (node, whether it is new)."""
    if edge:
        return (p if t < 0.5 else q), False
    if t < 0.1:
        return p, False
    if t > 0.9 and q not in cut.crossing.values():
        return q, False
    P, Q = cut.nodes[p], cut.nodes[q]
    cut.nodes.append(P + min(t, 0.9) * (Q - P))
    cut.sign.append(0.0)
    return len(cut.nodes) - 1, True


def _fan(poly: list[int], nodes: list[np.ndarray], centre: int | None = None):
    """A convex polygon as triangles: a fan from ``centre`` (a node inside it), from a new
    centroid node when it has more than 3 corners, else the polygon itself."""
    if centre is None:
        if len(poly) == 3:
            return [tuple(poly)]
        nodes.append(np.mean([nodes[k] for k in poly], axis=0))
        centre = len(nodes) - 1
    pairs = [(poly[k], poly[(k + 1) % len(poly)]) for k in range(len(poly))]
    return [(centre, p, q) for p, q in pairs if centre not in (p, q)]


def split_triangle(cut: PlaneCutter, tri: np.ndarray, end: tuple[int, int] | None):
    """The triangles that replace a cut one: both sides of its chord, or — the triangle
    where the front meets the surface — a fan from the end node over its corners and the
    chord's inner point (``end`` = (inner point, end node))."""
    poly = cut.polygon(tri)
    if end is not None:
        inner, node = end
        corners = [k for k in poly if k == inner or k in tri]
        return _fan(corners, cut.nodes, node)
    out = []
    for side in (1, -1):
        out += _fan([k for k in poly if cut.sign[k] * side >= 0], cut.nodes)
    return out


def compact_nodes(nodes: list, tris: np.ndarray, mouth: list[int]):
    """Drop the nodes no triangle uses; renumber."""
    used = np.unique(tris)
    new = -np.ones(len(nodes), dtype=np.int64)
    new[used] = np.arange(len(used))
    return np.asarray(nodes)[used], new[tris], [int(new[k]) for k in mouth]


def _segment_triangles(cut: PlaneCutter) -> dict[tuple[int, int], list[int]]:
    out: dict[tuple[int, int], list[int]] = {}
    for t, (p, q) in cut.chords.items():
        out.setdefault((min(p, q), max(p, q)), []).append(t)
    return out


def _cut_triangles(cut: PlaneCutter, conn, chain: list[int], frac: list[float]):
    """The end nodes of the mouth and the replacement of every cut triangle."""
    seg = _segment_triangles(cut)
    tri_of = {k: seg[(min(p, q), max(p, q))] for k, (p, q) in enumerate(zip(chain, chain[1:]))}
    ends, repl = [], {}
    for k, (inner, outer, t) in enumerate(
        ((chain[1], chain[0], frac[0]), (chain[-2], chain[-1], frac[1]))
    ):
        tris = tri_of[0 if k == 0 else len(chain) - 2]
        node, new = _end_node(cut, inner, outer, t, len(tris) > 1)
        ends.append(node)
        if len(tris) > 1:  # the chord is a mesh edge: nothing to split
            continue
        if new or (node == inner and inner in cut.crossing.values()):
            repl[tris[0]] = split_triangle(cut, conn[tris[0]], (inner, node))
        elif node == outer:
            repl[tris[0]] = split_triangle(cut, conn[tris[0]], None)
    for k in range(1, len(chain) - 2):
        if len(tri_of[k]) == 1:
            repl[tri_of[k][0]] = split_triangle(cut, conn[tri_of[k][0]], None)
    return ends, repl


def _arc_parameter(ell: EllipticalFront, x: np.ndarray) -> float:
    loc = ell.local(x[None, :])[0]
    return math.atan2(loc[1] / ell.b, loc[0] / ell.a)


def _front_of(ell: EllipticalFront, x0: np.ndarray, x1: np.ndarray, deep: np.ndarray):
    """The arc from x0 to x1 through the body (the side of ``deep``), ``None`` if the arc
    from x0 to x1 counter-clockwise misses ``deep``."""
    p0, p1 = _arc_parameter(ell, x0), _arc_parameter(ell, x1)
    pd = _arc_parameter(ell, deep)
    p1 = p1 if p1 > p0 else p1 + 2 * math.pi
    pd = pd if pd > p0 else pd + 2 * math.pi
    if pd > p1:
        return None
    return BodyArcFront(ell.a, ell.b, ell.centre, ell.axes, (p0, p1))


def _size_function(ell: EllipticalFront, size: TipMesh, h_max: float):
    """h(x) = min(h_f + g·d, h_max) with d the distance estimate of the size field."""

    def h(x: np.ndarray) -> np.ndarray:
        loc = ell.local(x)
        rho = np.hypot(loc[:, 0] / ell.a, loc[:, 1] / ell.b)
        d = np.hypot((rho - 1.0) * ell.b, loc[:, 2])
        return np.minimum(size.h_tip + size.grading * d, h_max)

    return h


def cut_mouth(
    body: BodySurface, crack: SurfaceBreakingCrack, size: TipMesh | None = None
) -> CutBody:
    """Cut the crack's mouth into the body's boundary (numpy; the same on every rank); with
    ``size``, the boundary triangles near the crack are first refined (red-green) to
    about the front's mesh size.

    Raises
    ------
    ParameterError
        (``centre``) the plane does not cut the surface near the centre; (``half_length``)
        the mouth is not one stretch of surface inside the ellipse; (``normal``) the plane
        is tangent to the surface.
    """
    nodes, conn, tags = unique_nodes(body)
    ell, crack = crack_frame(crack, nodes, conn)
    if size is not None:
        nodes, conn, tags = refine_near(nodes, conn, tags, _size_function(ell, size, body.h_max))
    C, n = np.asarray(ell.centre), ell.normal
    reach = 1.5 * ell.a + 3 * body.h_max
    nodes, sign = _snap(nodes, conn, C, n, reach)
    cut = PlaneCutter(nodes, sign, C, n)
    for t, tri in enumerate(conn):
        if np.min(np.linalg.norm(nodes[tri] - C, axis=1)) < reach:
            cut.chord(t, tri)
    try:
        chain, frac = _mouth_chain(cut, ell)
    except ParameterError as exc:
        if crack.shape != CORNER or exc.key != "half_length":
            raise
        raise ParameterError("length", str(exc).removeprefix("half_length: ")) from None
    ends, repl = _cut_triangles(cut, conn, chain, frac)
    tris, out_tags = [], []
    for t, (tri, tag) in enumerate(zip(conn, tags, strict=True)):
        for tr in repl.get(t, [tuple(int(k) for k in tri)]):
            tris.append(tr)
            out_tags.append(tag)
    mouth = [ends[0], *[k for k in chain[1:-1] if k not in ends], ends[1]]
    X, tris, mouth = compact_nodes(cut.nodes, np.asarray(tris, dtype=np.int64), mouth)
    deep = _inside_point(ell, crack)
    front = _front_of(ell, X[mouth[0]], X[mouth[-1]], deep)
    if front is None:
        mouth = mouth[::-1]
        front = _front_of(ell, X[mouth[0]], X[mouth[-1]], deep)
    return CutBody(X, tris, np.asarray(out_tags, dtype=np.int32), tuple(mouth), front, crack)


def cut_mouths(
    body: BodySurface, cracks: list[SurfaceBreakingCrack], size: TipMesh | None = None
) -> list[CutBody]:
    """Cut the mouths of several cracks into the body's boundary, one after the other
    (each cut into the boundary the ones before left; numpy, the same on every rank).
    Every returned :class:`CutBody` holds the final boundary; its mouth is its own, found
    again on that boundary (a later refinement may have halved a mouth's edges).

    Raises
    ------
    ParameterError
        As :func:`cut_mouth`; (``centre``) a later cut moved a node of an earlier mouth
        (the cracks lie too close).
    """
    cuts: list[CutBody] = []
    current = body
    for crack in cracks:
        cut = cut_mouth(current, crack, size)
        cuts.append(cut)
        tri = cut.nodes[cut.triangles]
        current = BodySurface(tri, cut.tags, body.names, body.region, body.h_max)
    last = cuts[-1]
    tol = 1e-9 * body.scale
    out = []
    for cut in cuts:
        mouth = _mouth_on(last.nodes, cut.nodes[list(cut.mouth)], tol)
        out.append(CutBody(last.nodes, last.triangles, last.tags, mouth, cut.arc, cut.crack))
    return out


def _mouth_on(X: np.ndarray, polyline: np.ndarray, tol: float) -> tuple[int, ...]:
    """The nodes of ``X`` on the mouth ``polyline`` (within ``tol``), in its order."""
    found: list[tuple[float, int]] = []
    for k, (p, q) in enumerate(zip(polyline, polyline[1:], strict=False)):
        d = q - p
        t = np.clip((X - p) @ d / (d @ d), 0.0, 1.0)
        dist = np.linalg.norm(X - (p + t[:, None] * d), axis=1)
        for i in np.flatnonzero(dist <= tol):
            found.append((k + float(t[i]), int(i)))
    order = []
    for _, i in sorted(found):
        if i not in order:
            order.append(i)
    ends = [np.linalg.norm(X[order[j]] - polyline[j and -1]) for j in (0, -1)] if order else [1]
    if len(order) < len(polyline) or max(ends) > tol:
        raise ParameterError(
            "centre", "cutting a later crack's mouth moved an earlier one (cracks too close)"
        )
    return tuple(order)


def _inside_point(ell: EllipticalFront, crack: SurfaceBreakingCrack) -> np.ndarray:
    """A point of the front inside the body: the deepest point, of a corner crack the
    point at ψ = 45°."""
    if crack.shape == CORNER:
        return corner_point(crack, ell, 0.25 * math.pi)
    return np.asarray(ell.centre) + crack.depth * _depth_direction(ell, crack)


def _depth_direction(ell: EllipticalFront, crack: SurfaceBreakingCrack) -> np.ndarray:
    """The unit depth direction (v of the frame when c ≥ a, else u)."""
    R = ell.rotation
    return R[1] if crack.half_length >= crack.depth else R[0]


def inside_body(body: BodySurface, points: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """Whether points lie inside the closed boundary (the winding number of its
    triangles, > 1/2)."""
    P = np.atleast_2d(np.asarray(points, dtype=float))
    T = body.triangles
    out = np.zeros(len(P), dtype=bool)
    for i, p in enumerate(P):
        a, b, c = (T[:, k] - p for k in range(3))
        la, lb, lc = (np.linalg.norm(v, axis=1) for v in (a, b, c))
        num = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = (
            la * lb * lc
            + np.einsum("ij,ij->i", a, b) * lc
            + np.einsum("ij,ij->i", b, c) * la
            + np.einsum("ij,ij->i", c, a) * lb
        )
        out[i] = abs(np.sum(2 * np.arctan2(num, den))) / (4 * math.pi) > 0.5
    return out


# ------------------------------------------------------------------ gmsh (rank 0)
def _num(v: float) -> str:
    """A number as gmsh's expression parser reads it (no exponent)."""
    return "(" + np.format_float_positional(float(v), unique=True, trim="0") + ")"


def _size_formula(front: BodyArcFront, size: TipMesh, h_max: float) -> str:
    """h = min(h_f + g·d, h_max), d the estimate of :func:`_distance_formula`."""
    d = _distance_formula(front)
    return f"Min({_num(size.h_tip)}+{_num(size.grading)}*{d},{_num(h_max)})"


def _distance_formula(front: BodyArcFront) -> str:
    """An estimate of the distance to the front's ellipse as a gmsh expression (exact on
    the axes, never larger than the in-plane distance times max/min semi-axis)."""
    c = np.asarray(front.centre, dtype=float)
    R = front.rotation
    lx = [
        "(" + "+".join(f"{_num(R[k][i])}*({xyz}-{_num(c[i])})" for i, xyz in enumerate("xyz")) + ")"
        for k in range(3)
    ]
    rho = f"Sqrt(({lx[0]}/{_num(front.a)})^2+({lx[1]}/{_num(front.b)})^2)"
    return f"Sqrt((({rho})-1)^2*{_num(front.b)}^2+({lx[2]})^2)"


def _crack_mesh(cb: CutBody, size: TipMesh, h_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Triangles of the crack surface (a separate gmsh model): the mouth's segments kept
    whole (they are the boundary's), the front a spline through the ellipse graded by
    ``size``.  Returns the node coordinates and the triangles (node indices)."""
    geo = gmsh.model.geo
    X = cb.nodes
    mouth = [geo.addPoint(*X[k]) for k in cb.mouth]
    p0, p1 = cb.arc.phi_range
    nseg = max(8, int(math.ceil((p1 - p0) / math.radians(4.0))))
    inner = cb.arc.point(np.linspace(p1, p0, nseg + 1)[1:-1])  # from the mouth's last end
    spline = [mouth[-1], *[geo.addPoint(*p) for p in inner], mouth[0]]
    lines = [geo.addLine(a, b) for a, b in zip(mouth, mouth[1:], strict=False)]
    front = geo.addSpline(spline)
    surf = geo.addPlaneSurface([geo.addCurveLoop([*lines, front])])
    geo.synchronize()
    for ln in lines:
        gmsh.model.mesh.setTransfiniteCurve(ln, 2)
    fld = gmsh.model.mesh.field
    f = fld.add("MathEval")
    fld.setString(f, "F", _size_formula(cb.arc, size, h_max))
    fld.setAsBackgroundMesh(f)
    for opt in ("MeshSizeFromPoints", "MeshSizeExtendFromBoundary", "MeshSizeFromCurvature"):
        gmsh.option.setNumber(f"Mesh.{opt}", 0)
    gmsh.model.mesh.generate(2)
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    index = {int(t): i for i, t in enumerate(tags)}
    _, el = gmsh.model.mesh.getElementsByType(2, surf)
    tri = np.array([index[int(t)] for t in el], dtype=np.int64).reshape(-1, 3)
    return xyz.reshape(-1, 3), tri


def merge_crack(cb: CutBody, pts: np.ndarray, tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The crack's nodes numbered after the boundary's: its mouth nodes are the
    boundary's own (matched by coordinates); the triangles in the joint numbering."""
    X = cb.nodes
    tol = 1e-9 * float(np.ptp(X, axis=0).max())
    key = {tuple(np.round(X[k] / tol).astype(np.int64)): k for k in cb.mouth}
    used = np.unique(tri)
    ids, new = np.full(len(pts), -1, dtype=np.int64), []
    for i in used:
        p = pts[i]
        k = key.get(tuple(np.round(p / tol).astype(np.int64)))
        if k is None:
            new.append(p)
            k = len(X) + len(new) - 1
        ids[i] = k
    if not set(cb.mouth) <= set(ids[used].tolist()):
        raise MeshingError("the crack surface lost a mouth node")
    return np.asarray(new).reshape(-1, 3), ids[tri]


def _build(
    cuts: list[CutBody], body: BodySurface, size: TipMesh, tags: list[tuple[int, int]], mouth_tags
):
    """Mesh the body with the cracks ``cuts`` (sharing one cut boundary; gmsh, rank 0):
    crack k's faces get ``tags[k]``, its mouth ``mouth_tags[k]`` while it is split."""
    h_max = min(size.h_max or body.h_max, body.h_max)
    current = gmsh.model.getCurrent()
    merged = []
    offset = 0
    for cb in cuts:
        gmsh.model.add("surface_crack")
        pts, tri = _crack_mesh(cb, size, h_max)
        gmsh.model.remove()
        gmsh.model.setCurrent(current)
        new, crack_tri = merge_crack(cb, pts, tri)
        crack_tri = np.where(crack_tri >= len(cb.nodes), crack_tri + offset, crack_tri)
        merged.append((new, crack_tri))
        offset += len(new)
    cb = cuts[0]
    values = np.unique(cb.tags)
    surfaces = list(range(1, len(values) + 1))
    for k in surfaces:
        gmsh.model.addDiscreteEntity(2, k)
    n0 = len(cb.nodes)
    gmsh.model.mesh.addNodes(2, 1, np.arange(1, n0 + 1), cb.nodes.ravel())
    for k, t in zip(surfaces, values, strict=True):
        gmsh.model.mesh.addElementsByType(k, 2, [], (cb.triangles[cb.tags == t] + 1).ravel())
        if t > 0:
            gmsh.model.addPhysicalGroup(2, [k], int(t), name=body.names.get(int(t), f"facets{t}"))
    cracks, mouths, first = [], [], n0 + 1
    for new, crack_tri in merged:
        crack = gmsh.model.addDiscreteEntity(2)
        gmsh.model.mesh.addNodes(2, crack, np.arange(first, first + len(new)), new.ravel())
        gmsh.model.mesh.addElementsByType(crack, 2, [], (crack_tri + 1).ravel())
        first += len(new)
        cracks.append(crack)
    for cut in cuts:
        mouth = gmsh.model.addDiscreteEntity(1)
        m = np.asarray(cut.mouth) + 1
        gmsh.model.mesh.addElementsByType(mouth, 1, [], np.column_stack([m[:-1], m[1:]]).ravel())
        mouths.append(mouth)
    geo = gmsh.model.geo
    volume = geo.addVolume([geo.addSurfaceLoop(surfaces)])
    geo.synchronize()
    gmsh.model.mesh.embed(2, cracks, 3, volume)
    region, region_tag = body.region
    gmsh.model.addPhysicalGroup(3, [volume], region_tag, name=region)
    f = gmsh.model.mesh.field.add("MathEval")
    gmsh.model.mesh.field.setString(f, "F", _size_formulas(cuts, size, h_max))
    gmsh.model.mesh.field.setAsBackgroundMesh(f)
    for opt in ("MeshSizeFromPoints", "MeshSizeExtendFromBoundary", "MeshSizeFromCurvature"):
        gmsh.option.setNumber(f"Mesh.{opt}", 0)
    volume_mesh(volume, size.h_tip)
    for k, (crack, mouth) in enumerate(zip(cracks, mouths, strict=True)):
        suffix = str(k) if len(cuts) > 1 else ""
        split_crack_nodes(crack, mouth, tags[k], mouth_tags[k], suffix)


def _size_formulas(cuts: list[CutBody], size: TipMesh, h_max: float) -> str:
    """The size field of the cracks: the least of their own (:func:`_size_formula`)."""
    out = _size_formula(cuts[0].arc, size, h_max)
    for cut in cuts[1:]:
        out = f"Min({out},{_size_formula(cut.arc, size, h_max)})"
    return out


#: the volume meshers tried in turn until no tetrahedron is flat: gmsh's 3D algorithm
#: and its random factor (the perturbation of the points in the Delaunay kernel)
VOLUME_MESHERS = ((10, 1e-12), (1, 1e-12), (1, 1e-9))


def volume_mesh(volume: int, h_tip: float) -> None:
    """Mesh the volume (gmsh, rank 0): HXT; where it leaves a flat tetrahedron (four
    nodes of the body's surface in one plane: zero volume, a singular stiffness), gmsh's
    Delaunay; where that does too, Delaunay with its points perturbed by 10⁻⁹ of the
    model's size instead of 10⁻¹² (the scanned L4's crack at its 10th block: one flat
    tetrahedron on the vertebral wall, 7 mm from the crack, after both; none after the
    third).  Raises :class:`MeshingError` when every mesher leaves one."""
    try:
        for k, (algorithm, random) in enumerate(VOLUME_MESHERS):
            if k:
                gmsh.model.mesh.clear([(3, volume)])
            gmsh.option.setNumber("Mesh.Algorithm3D", algorithm)
            gmsh.option.setNumber("Mesh.RandomFactor3D", random)
            gmsh.model.mesh.generate(3)
            if not (n := _flat_tetrahedra(h_tip)):
                return
        raise MeshingError(f"the volume mesh has {n} flat tetrahedra (zero volume)")
    finally:
        gmsh.option.setNumber("Mesh.RandomFactor3D", 1e-12)


#: a tetrahedron of volume below this fraction of h_tip³ is flat (a sliver: the stiffness
#: matrix is singular)
FLAT_VOLUME = 1e-9


def _flat_tetrahedra(h_tip: float) -> int:
    """The number of tetrahedra of the current model whose volume is below
    :data:`FLAT_VOLUME` h_tip³ (gmsh, rank 0)."""
    tags, coords, _ = gmsh.model.mesh.getNodes()
    x = np.zeros((int(tags.max()) + 1, 3))
    x[tags.astype(np.int64)] = coords.reshape(-1, 3)
    _, conn = gmsh.model.mesh.getElementsByType(4)
    t = x[np.asarray(conn, dtype=np.int64).reshape(-1, 4)]
    six_vol = np.einsum(
        "ij,ij->i", np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), t[:, 3] - t[:, 0]
    )
    return int(np.count_nonzero(np.abs(six_vol) < 6.0 * FLAT_VOLUME * h_tip**3))


def split_crack_nodes(
    crack: int, mouth: int, tags: tuple[int, int], mouth_tag: int, suffix: str = ""
) -> None:
    """Duplicate the crack's nodes, the mouth's included, the front's not (checked, and
    redone where the plugin is wrong, by
    :func:`~bonecontact.fracture.crack_split.split_checked`); the faces' groups are named
    ``crack_a`` and ``crack_b`` followed by ``suffix``."""
    before = crack_surface([crack], mouth)
    gmsh.model.addPhysicalGroup(2, [crack], tags[0], name=f"crack_a{suffix}")
    gmsh.model.addPhysicalGroup(1, [mouth], mouth_tag)
    plugin = gmsh.plugin
    plugin.setNumber("Crack", "Dimension", 2)
    plugin.setNumber("Crack", "PhysicalGroup", tags[0])
    plugin.setNumber("Crack", "NewPhysicalGroup", tags[1])
    plugin.setNumber("Crack", "OpenBoundaryPhysicalGroup", mouth_tag)
    plugin.run("Crack")
    gmsh.model.removePhysicalGroups([(1, mouth_tag)])
    gmsh.model.setPhysicalName(2, tags[1], f"crack_b{suffix}")
    split_checked(before, tags, "surface crack")
    gmsh.model.mesh.renumberNodes()
    gmsh.model.mesh.renumberElements()


def mesh_body_with_surface_crack(
    body: BodySurface,
    crack: SurfaceBreakingCrack,
    size: TipMesh,
    comm: MPI.Comm | None = None,
) -> tuple[CrackedBody3D, object, CutBody]:
    """Mesh a 3D body with a semi-elliptical surface crack cut into it (collective; gmsh
    on rank 0).

    Returns
    -------
    (CrackedBody3D, dolfinx.io.gmsh.MeshData, CutBody)
        The cracked mesh (faces ``crack_upper`` on the side of the normal and
        ``crack_lower``; ``block()`` has the arc front), its mesh data and the cut
        boundary (the front, the mouth).

    Raises
    ------
    ParameterError
        The crack does not fit the surface (:func:`cut_mouth`), on every rank.
    MeshingError
        gmsh failed (on every rank).
    """
    bodies, md, cuts = mesh_body_with_surface_cracks(body, [crack], size, comm)
    return bodies[0], md, cuts[0]


def mesh_body_with_surface_cracks(
    body: BodySurface,
    cracks: list[SurfaceBreakingCrack],
    size: TipMesh,
    comm: MPI.Comm | None = None,
) -> tuple[list[CrackedBody3D], object, list[CutBody]]:
    """Mesh a 3D body with several surface cracks (:func:`cut_mouths`; collective, gmsh on
    rank 0): each crack's view of the one mesh (its own faces ``crack_upper`` and
    ``crack_lower``), the mesh data and the cuts.  Raises as
    :func:`mesh_body_with_surface_crack`."""
    comm = MPI.COMM_WORLD if comm is None else comm
    cuts = [cut_mouth(body, cracks[0], size)] if len(cracks) == 1 else []
    cuts = cuts or cut_mouths(body, list(cracks), size)
    top = max([body.region[1], *body.names, 0])
    tags = [(top + 1 + 3 * k, top + 2 + 3 * k) for k in range(len(cracks))]
    error = None
    with gmsh_session("cracked_surface_body3d") if comm.rank == 0 else nullcontext():
        if comm.rank == 0:
            try:
                _build(cuts, body, size, tags, [t[1] + 1 for t in tags])
            except Exception as exc:  # reported on every rank below
                error = f"{type(exc).__name__}: {exc}"
        error = comm.bcast(error, root=0)
        if error is not None:
            raise MeshingError(f"surface crack in a 3D body: {error}")
        md = model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=3)
    bodies = []
    for crack, cb, (a, b) in zip(cracks, cuts, tags, strict=True):
        n = np.asarray(crack.normal, dtype=float)
        upper, lower = (a, b) if face_side_sign(md.mesh, md.facet_tags, a, n) > 0 else (b, a)
        faces = {"crack_upper": upper, "crack_lower": lower}
        bodies.append(CrackedBody3D(md.mesh, md.cell_tags, md.facet_tags, cb, faces))
    return bodies, md, cuts
