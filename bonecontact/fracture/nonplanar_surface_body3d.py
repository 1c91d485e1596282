"""A non-planar surface-breaking crack (planar patches, e.g. a kinked growth step) cut
into a scene's 3D body — the meshing building block (docs/theory/fracture.md).

The crack is a connected surface of convex planar patches that crosses the body's
surface: its part outside the body lies beyond the mouth, its edges inside the body that
no other patch shares are the front.  :func:`cut_mouth_surface` inserts the points where
the crack's edges cross the surface (the front's two ends and the kinks, where the mouth
passes from one patch to the next) as boundary nodes, then cuts the boundary triangles
along each patch's plane where the cut lies within the patch (crossings on the triangles'
edges, in the patch's plane): the mouth, one chain of boundary nodes from one front end
to the other.  :func:`mesh_body_with_nonplanar_surface_crack` meshes each patch's part
inside the body as a plane surface (the patches share their curves, the mouth's segments
are kept whole, triangles graded towards the front), embeds it in the volume bounded by
the cut boundary and duplicates its nodes but the front's (the mouth's too), each copy
going to the cells that the crack parts from the upper side's around that node (gmsh's
``Crack`` plugin, which sides by the node's mean normal, misplaced a cell at a 60° kink):
faces ``crack_upper`` (the side of the first patch's normal) and ``crack_lower``; a flat
tetrahedron on two coplanar boundary triangles is dropped (:func:`drop_boundary_slivers`).
All gmsh work runs on rank 0.

A building block: the front is returned as a polyline (no stress intensity along it yet,
``CrackedBody3D.block`` does not apply), one cell group; vertices move only where their
facets lie within 30° of each other or along an edge of two such faces (a corner crack's
mouth crosses one), never across another crossing patch's plane, never flattening a facet.
"""

from __future__ import annotations

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
from bonecontact.fracture.crack_split import node_sides
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.surface_body3d import (
    FLAT_VOLUME,
    SNAP_FRACTION,
    PlaneCutter,
    chord_chains,
    compact_nodes,
    inside_body,
    merge_crack,
    refine_near,
    split_triangle,
    unique_nodes,
    volume_mesh,
)
from bonecontact.meshing.builder import MeshingError
from bonecontact.meshing.session import gmsh_session

__all__ = [
    "NonplanarCut",
    "NonplanarSurfaceCrack",
    "cut_mouth_surface",
    "drop_boundary_slivers",
    "mesh_body_with_nonplanar_surface_crack",
]

#: Relative tolerance of planarity, of a point on a plane and of the containment tests.
GEOMETRY_TOL = 1e-9
#: A crack point must lie this fraction of the tip size (without one, of a tenth of the
#: boundary's longest edge) off the body's surface.
NEAR_SURFACE = 0.25
#: Facets within this angle (degrees) of their mean normal are one smooth surface, where a
#: vertex may move along it (farther apart: an edge of the body, whose vertices stay).
SMOOTH_DEG = 30.0
#: A crack edge's crossing closer than this fraction of the facet's shortest edge to one of
#: its corners moves that corner onto it (in a smooth neighbourhood), to an edge splits it.
NEAR_FRACTION = 0.1


@dataclass(frozen=True)
class NonplanarSurfaceCrack:
    """A surface-breaking crack made of convex planar patches.

    Parameters
    ----------
    points
        Coordinates (m), shape (M, 3).
    patches
        Convex planar polygons (indices into ``points``); neighbours share an edge.  They
        are oriented like the first (its normal by the right-hand rule: ``crack_upper``).
    """

    points: tuple[tuple[float, float, float], ...]
    patches: tuple[tuple[int, ...], ...]

    def __post_init__(self) -> None:
        X = np.asarray(self.points, dtype=float)
        if X.ndim != 2 or X.shape[1] != 3 or not np.all(np.isfinite(X)):
            raise ParameterError("points", "must be finite coordinates of shape (M, 3)")
        if not self.patches:
            raise ParameterError("patches", "the crack needs at least one patch")
        for k, p in enumerate(self.patches):
            if len(p) < 3 or len(set(p)) != len(p) or min(p) < 0 or max(p) >= len(X):
                raise ParameterError("patches", f"patch {k} must be >= 3 distinct point indices")
        oriented = _orient(self.patches)
        object.__setattr__(self, "patches", oriented)
        for k in range(len(oriented)):
            _check_convex_planar(X[list(oriented[k])], k, self.scale)

    @property
    def scale(self) -> float:
        X = np.asarray(self.points, dtype=float)
        return float(np.ptp(X, axis=0).max())

    def polygon(self, k: int) -> npt.NDArray[np.float64]:
        """The corners of patch ``k`` (m), shape (n, 3)."""
        return np.asarray(self.points, dtype=float)[list(self.patches[k])]

    def normal(self, k: int) -> npt.NDArray[np.float64]:
        """The unit normal of patch ``k`` (Newell's)."""
        return _newell(self.polygon(k))

    def contains(self, k: int, x: npt.ArrayLike, tol: float) -> npt.NDArray[np.bool_]:
        """Whether points ``x`` (k, 3), projected on patch ``k``'s plane, lie inside it
        (or within ``tol`` of it)."""
        P = self.polygon(k)
        n = self.normal(k)
        X = np.atleast_2d(np.asarray(x, dtype=float))
        ok = np.ones(len(X), dtype=bool)
        for i in range(len(P)):
            m = np.cross(n, P[(i + 1) % len(P)] - P[i])
            m /= np.linalg.norm(m)
            ok &= (X - P[i]) @ m >= -tol
        return ok

    def edges(self) -> dict[tuple[int, int], list[int]]:
        """Every edge (sorted point indices) → the patches that have it."""
        out: dict[tuple[int, int], list[int]] = {}
        for k, p in enumerate(self.patches):
            for a, b in zip(p, p[1:] + p[:1], strict=True):
                out.setdefault((min(a, b), max(a, b)), []).append(k)
        return out


def _newell(P: np.ndarray) -> np.ndarray:
    n = np.cross(P, np.roll(P, -1, axis=0)).sum(axis=0)
    return n / np.linalg.norm(n)


def _check_convex_planar(P: np.ndarray, k: int, scale: float) -> None:
    """Refuse a patch off its plane or not convex (key ``patches``)."""
    n = _newell(P)
    if np.max(np.abs((P - P.mean(axis=0)) @ n)) > GEOMETRY_TOL * scale:
        raise ParameterError("patches", f"patch {k} is not planar")
    turns = np.cross(np.roll(P, -1, axis=0) - P, np.roll(P, -2, axis=0) - np.roll(P, -1, axis=0))
    if np.any(turns @ n <= 0):
        raise ParameterError("patches", f"patch {k} is not a convex polygon")


def _orient(patches: tuple[tuple[int, ...], ...]) -> tuple[tuple[int, ...], ...]:
    """The patches turned like the first (a shared edge runs opposite ways in its two
    patches).  Raises ParameterError (``patches``) when they are not connected, an edge
    has more than two patches or the surface is not orientable."""
    out: list[tuple[int, ...] | None] = [tuple(patches[0])] + [None] * (len(patches) - 1)
    todo = [0]
    while todo:
        k = todo.pop()
        own = {(a, b) for a, b in zip(out[k], out[k][1:] + out[k][:1], strict=True)}
        for j, p in enumerate(patches):
            if j == k:
                continue
            pe = {(a, b) for a, b in zip(p, p[1:] + p[:1], strict=True)}
            same = own & pe
            opposite = {(b, a) for a, b in own} & pe
            if not same and not opposite:
                continue
            turned = tuple(p) if opposite else tuple(p[::-1])
            if out[j] is None:
                out[j] = turned
                todo.append(j)
            elif out[j] != turned:
                raise ParameterError("patches", "the crack surface is not orientable")
    if any(p is None for p in out):
        raise ParameterError("patches", "the patches do not form one connected surface")
    counts: dict[tuple[int, int], int] = {}
    for p in out:
        for a, b in zip(p, p[1:] + p[:1], strict=True):
            counts[(min(a, b), max(a, b))] = counts.get((min(a, b), max(a, b)), 0) + 1
    if max(counts.values()) > 2:
        raise ParameterError("patches", "an edge belongs to more than two patches")
    return tuple(out)


@dataclass(frozen=True)
class NonplanarCut:
    """The body's boundary with a non-planar crack's mouth cut into it.

    Attributes
    ----------
    nodes, triangles, tags
        Boundary nodes (M, 3), triangles (node indices, outward) and their facet tags.
    mouth
        Node indices of the mouth, from the front's first end to its last.
    mouth_patch
        The patch of every mouth segment (mouth[i] → mouth[i + 1]).
    front_points
        The front: the crack's unshared edges inside the body (m), shape (m, 3), from
        ``nodes[mouth[0]]`` to ``nodes[mouth[-1]]``.
    inner
        Whether each crack point lies inside the body.
    crossings
        Crack edge (sorted point indices) from inside to outside → its mouth node.
    crack
        The crack (patches oriented like the first).
    """

    nodes: npt.NDArray[np.float64]
    triangles: npt.NDArray[np.int64]
    tags: npt.NDArray[np.int32]
    mouth: tuple[int, ...]
    mouth_patch: tuple[int, ...]
    front_points: npt.NDArray[np.float64]
    inner: npt.NDArray[np.bool_]
    crossings: dict[tuple[int, int], int]
    crack: NonplanarSurfaceCrack

    def front(self) -> npt.NDArray[np.float64]:
        """The front polyline (m), shape (m, 3)."""
        return self.front_points


# ------------------------------------------------------------ geometry (numpy)
def _segment_hits(p: np.ndarray, q: np.ndarray, tris: np.ndarray) -> list[np.ndarray]:
    """Points where the segment p → q crosses the triangles (Möller–Trumbore), merged.

    Not :func:`~bonecontact.common.geometry.line_triangle_hits`: that kernel multiplies by
    1/det where this divides by det, which moves the crossings by an ulp, and gmsh meshes
    the cut differently for it (8 of the mesher tests' cell counts changed; 2026-12-05)."""
    d = q - p
    e1, e2 = tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    h = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, h)
    ok = np.abs(det) > 1e-300
    s = p - tris[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.einsum("ij,ij->i", s, h) / det
        qv = np.cross(s, e1)
        v = (qv @ d) / det
        t = np.einsum("ij,ij->i", e2, qv) / det
        eps = 1e-12
        hit = ok & (u >= -eps) & (v >= -eps) & (u + v <= 1 + eps) & (t >= 0) & (t <= 1)
    pts: list[np.ndarray] = []
    for x in p + t[hit, None] * d:
        if all(np.linalg.norm(x - y) > 1e-9 * np.linalg.norm(d) for y in pts):
            pts.append(x)
    return pts


def _edge_crossings(
    crack: NonplanarSurfaceCrack, tris: np.ndarray, inner: np.ndarray
) -> dict[tuple[int, int], np.ndarray]:
    """The point where every crack edge from inside the body to outside crosses its
    surface (key ``patches`` when one crosses it more than once, or an edge with both
    ends on one side crosses it: a patch's trace would leave it through that edge)."""
    X = np.asarray(crack.points, dtype=float)
    out = {}
    for (a, b), _ in sorted(crack.edges().items()):
        hits = _segment_hits(X[a], X[b], tris)
        if inner[a] == inner[b]:
            if hits:
                side = "inside" if inner[a] else "outside"
                raise ParameterError(
                    "patches",
                    f"the crack edge {a}-{b} has both ends {side} the body but crosses its "
                    f"surface {len(hits)} times",
                )
            continue
        if len(hits) != 1:
            raise ParameterError(
                "patches", f"the crack edge {a}-{b} crosses the body's surface {len(hits)} times"
            )
        out[(a, b)] = hits[0]
    return out


def _smooth_at(nodes: np.ndarray, conn: np.ndarray, vertices: list[int]) -> np.ndarray | None:
    """The mean unit normal of the triangles at the vertices when they all lie within
    :data:`SMOOTH_DEG` of it (no edge of the body there), else ``None``."""
    at = np.flatnonzero(np.isin(conn, vertices).any(axis=1))
    if not at.size:
        return None
    x = nodes[conn[at]]
    m = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    m /= np.linalg.norm(m, axis=1)[:, None]
    mean = m.sum(axis=0)
    mean /= np.linalg.norm(mean)
    return mean if np.all(m @ mean >= np.cos(np.radians(SMOOTH_DEG))) else None


def _insert_point(nodes, conn, tags, x: np.ndarray, locked: set[int]):
    """Make ``x`` (on the surface) a boundary node: a nearby unlocked corner moved onto it
    (smooth neighbourhood), a nearby edge split at it (both triangles), else its triangle
    split in three.  Returns (nodes, conn, tags, node index)."""
    t = int(np.argmin(point_triangle_distance(x, nodes[conn])))
    tri = conn[t]
    P = nodes[tri]
    lam = np.linalg.lstsq(np.vstack([P.T, np.ones(3)]), np.append(x, 1.0), rcond=None)[0]
    k = int(np.argmax(lam))
    if (
        lam[k] > 1 - NEAR_FRACTION
        and int(tri[k]) not in locked
        and _smooth_at(nodes, conn, [tri[k]]) is not None
    ):
        nodes = nodes.copy()
        nodes[tri[k]] = x
        return nodes, conn, tags, int(tri[k])
    nodes = np.vstack([nodes, x])
    new = len(nodes) - 1
    j = int(np.argmin(lam))
    a, b = int(tri[(j + 1) % 3]), int(tri[(j + 2) % 3])
    if lam[j] < NEAR_FRACTION and _smooth_at(nodes, conn, [a, b]) is not None:
        rows, repl = [], []
        for s, tr in enumerate(conn):
            if a in tr and b in tr:
                c = next(int(v) for v in tr if v not in (a, b))
                u, w = (a, b) if _follows(tr, a, b) else (b, a)
                rows.append(s)
                repl += [(u, new, c, tags[s]), (new, w, c, tags[s])]
        return _replace(nodes, conn, tags, rows, repl, new)
    c = int(tri[j])
    repl = [(a, b, new, tags[t]), (b, c, new, tags[t]), (c, a, new, tags[t])]
    return _replace(nodes, conn, tags, [t], repl, new)


def _follows(tr: np.ndarray, a: int, b: int) -> bool:
    i = list(map(int, tr)).index(a)
    return int(tr[(i + 1) % 3]) == b


def _replace(nodes, conn, tags, rows: list[int], repl: list[tuple], new: int):
    keep = np.setdiff1d(np.arange(len(conn)), rows)
    add = np.array([r[:3] for r in repl], dtype=np.int64)
    conn = np.vstack([conn[keep], add])
    tags = np.concatenate([tags[keep], np.array([r[3] for r in repl], dtype=np.int32)])
    return nodes, conn, tags, new


def _snap_in_surface(nodes, conn, sign_dist, n, movable, h, keep=()) -> np.ndarray:
    """Move the movable vertices within SNAP_FRACTION h of the plane onto it along the
    surface (the plane's normal projected on their mean facet normal's tangent plane;
    exact in a flat neighbourhood, off a curved one by the snap times the facets' angle;
    a vertex on an edge of the body along the edge: :func:`_edge_tangent`), but none
    across a plane of ``keep`` ((point, normal, reach mask) each) within reach, and none
    that would leave one of its facets below KEEP_AREA of its area or turned."""
    nodes = nodes.copy()
    for i in np.flatnonzero(movable & (np.abs(sign_dist) < SNAP_FRACTION * h)):
        mean = _smooth_at(nodes, conn, [i])
        if mean is not None:
            t = n - (n @ mean) * mean
        else:
            t = _edge_tangent(nodes, conn, i)
            if t is None:
                continue
            t = (n @ t) * t
        if t @ n < 0.2:  # the plane near tangent to the surface (or to the edge)
            continue
        x = nodes[i] - sign_dist[i] / (t @ n) * t
        if any(r[i] and ((nodes[i] - C) @ m) * ((x - C) @ m) < 0 for C, m, r in keep):
            continue
        if _flattens(nodes, conn[(conn == i).any(axis=1)], i, x):
            continue
        nodes[i] = x
        sign_dist[i] = 0.0
    return nodes


def _edge_tangent(nodes: np.ndarray, conn: np.ndarray, i: int) -> np.ndarray | None:
    """The unit direction of the body's edge through vertex ``i`` when its facets form two
    smooth faces (each within :data:`SMOOTH_DEG` of its mean normal, the two farther
    apart): the cross product of their mean normals; else ``None`` (a corner, smooth, or
    no facets).
    A corner crack's plane crosses such an edge: a vertex there within the snap distance
    moves along it onto the plane (cut 1e-12 from it, the mouth lost a node)."""
    x = nodes[conn[(conn == i).any(axis=1)]]
    if not len(x):
        return None
    m = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    m /= np.linalg.norm(m, axis=1)[:, None]
    cos = np.cos(np.radians(SMOOTH_DEG))
    first = m @ m[0] >= cos
    faces = []
    for group in (m[first], m[~first]):
        mean = group.sum(axis=0) if len(group) else np.zeros(3)
        if not len(group) or np.any(group @ (mean / np.linalg.norm(mean)) < cos):
            return None
        faces.append(mean / np.linalg.norm(mean))
    e = np.cross(faces[0], faces[1])
    return e / np.linalg.norm(e)


#: A snap may leave each facet at a vertex no less than this fraction of its area (a thin
#: facet's corner moved across its opposite edge folded the surface: gmsh found two
#: coincident facets).
KEEP_AREA = 0.1


def _flattens(nodes: np.ndarray, star: np.ndarray, i: int, x: np.ndarray) -> bool:
    """Whether moving vertex ``i`` to ``x`` leaves a facet of its ``star`` below
    :data:`KEEP_AREA` of its area on its side (or turned over)."""
    moved = nodes[star]
    old = np.cross(moved[:, 1] - moved[:, 0], moved[:, 2] - moved[:, 0])
    moved = np.where((star == i)[..., None], x, moved)
    new = np.cross(moved[:, 1] - moved[:, 0], moved[:, 2] - moved[:, 0])
    kept = np.einsum("ij,ij->i", new, old) / np.einsum("ij,ij->i", old, old)
    return bool(np.any(kept < KEEP_AREA))


#: A vertex snaps onto a patch's plane only when the snap is below this fraction of its
#: distance to the patch's crossing nodes (the trace's direction there turned < 6°).
SNAP_TURN = 0.1


def _sides_kept(nodes: np.ndarray, crack: NonplanarSurfaceCrack, fixed: dict, h: float):
    """The other crossing patches' planes as (point, normal, reach mask) for
    :func:`_snap_in_surface`: a snap onto one patch's plane must leave every vertex within
    2 h of another crossing patch (projected on it) on its side of that patch's plane.
    The scanned L4's 15th mesh: strips 0.8 h wide at the surface, 0.12° apart; a vertex
    over strip 89, 0.06 h from its crossing node on edge 72-73, was snapped onto strip
    81's plane and so crossed strip 89's: all the node's neighbours then lay on one side
    of it, strip 89's trace passed it by and "ended inside a facet".  In a flat star a
    vertex cannot pass that way without turning a facet at the node over (the snap did,
    a 0.0014 h² one), which :func:`_flattens` refuses too; on a curved surface, where a
    snap moves the facets and the traces, this rule still keeps the sides."""
    return [
        (crack.polygon(j).mean(axis=0), crack.normal(j), crack.contains(j, nodes, 2.0 * h))
        for j in fixed["others"]
    ]


def _snap_small(nodes: np.ndarray, s: np.ndarray, ends: list[int]) -> np.ndarray:
    """Whether each vertex's snap (its distance ``s`` to the plane) is small beside its
    distance to the crossing nodes ``ends`` (a front end inserted 0.003 h from a vertex
    that was then snapped 0.003 h: the trace ran past the end and back, a spur)."""
    if not ends:
        return np.ones(len(nodes), dtype=bool)
    d = np.linalg.norm(nodes[:, None, :] - nodes[ends][None], axis=2).min(axis=1)
    return np.abs(s) <= SNAP_TURN * d


def _unsnap_flat(snapped, nodes, conn, s, C: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Put back the snapped vertices of a triangle whose three corners the snap left on
    the plane (s = 0, updated): such a triangle would lie in the patch's plane, the trace
    a face rather than a line (at a front end inserted into a triangle whose other two
    corners lie within the snap distance, the trace branched there)."""
    moved = np.any(snapped != nodes, axis=1)
    flat = (s[conn] == 0).all(axis=1) & moved[conn].any(axis=1)
    back = np.unique(conn[flat].ravel())
    back = back[moved[back]]
    if not back.size:
        return snapped
    snapped = snapped.copy()
    snapped[back] = nodes[back]
    s[back] = (nodes[back] - C) @ n
    return snapped


def _edge_triangles(conn: np.ndarray) -> dict[tuple[int, int], list[int]]:
    out: dict[tuple[int, int], list[int]] = {}
    for t, tr in enumerate(conn):
        for k in range(3):
            a, b = int(tr[k]), int(tr[(k + 1) % 3])
            out.setdefault((min(a, b), max(a, b)), []).append(t)
    return out


def _cut_patch(nodes, conn, tags, crack: NonplanarSurfaceCrack, k: int, fixed, h: float):
    """Cut the boundary along patch ``k``'s plane where the cut lies in the patch (the
    crossing points of its edges ``fixed`` on the plane).  Returns the new nodes,
    triangles, tags and the mouth segments (node pairs)."""
    n, C = crack.normal(k), crack.polygon(k).mean(axis=0)
    tol = GEOMETRY_TOL * crack.scale
    near = crack.contains(k, nodes, 2.0 * h)
    s = (nodes - C) @ n
    movable = near.copy()
    movable[list(fixed["locked"])] = False
    movable &= _snap_small(nodes, s, list(fixed["on_plane"]))
    snapped = _snap_in_surface(nodes, conn, s, n, movable, h, _sides_kept(nodes, crack, fixed, h))
    s[np.abs(s) < 1e-3 * tol] = 0.0
    s[list(fixed["on_plane"])] = 0.0
    nodes = _unsnap_flat(snapped, nodes, conn, s, C, n)
    cut = PlaneCutter(nodes, np.sign(s), C, n)
    close = np.flatnonzero(near[conn].any(axis=1))
    for t in close:
        cut.chord(int(t), conn[t])
    X = np.asarray(cut.nodes)
    accepted = {
        t: pq
        for t, pq in cut.chords.items()
        if crack.contains(k, 0.5 * (X[pq[0]] + X[pq[1]]), tol)[0]
    }
    _check_cut_closed(conn, np.sign(s), accepted, k)
    repl = {
        t: split_triangle(cut, conn[t], None)
        for t, (p, q) in accepted.items()
        if not (p in conn[t] and q in conn[t])
    }
    tris, out_tags = [], []
    for t, (tri, tag) in enumerate(zip(conn, tags, strict=True)):
        new = repl.get(t, [tuple(int(v) for v in tri)])
        tris += new
        out_tags += [tag] * len(new)
    segs = sorted({(min(p, q), max(p, q)) for p, q in accepted.values()})
    conn = np.asarray(tris, dtype=np.int64)
    return np.asarray(cut.nodes), conn, np.asarray(out_tags, dtype=np.int32), segs


def _check_cut_closed(conn: np.ndarray, sign: np.ndarray, accepted: dict, k: int) -> None:
    """Refuse a cut that stops inside a triangle's edge (key ``patches``): every edge an
    accepted triangle's cut crosses must have its other triangle cut too."""
    et = _edge_triangles(conn)
    for t in accepted:
        tri = conn[t]
        for j in range(3):
            a, b = int(tri[j]), int(tri[(j + 1) % 3])
            if sign[a] * sign[b] < 0 and any(u not in accepted for u in et[(min(a, b), max(a, b))]):
                raise ParameterError(
                    "patches",
                    f"the trace of patch {k} on the body's surface ends inside a facet (the "
                    "patch's edges must cross the surface only at the mouth's ends and kinks)",
                )


def _front_edges(crack: NonplanarSurfaceCrack, inner: np.ndarray, cross: dict) -> list:
    """The front's pieces as pairs of items, ('v', point) or ('x', crack edge)."""
    out = []
    for e, ps in sorted(crack.edges().items()):
        if len(ps) != 1 or not (inner[e[0]] or inner[e[1]]):
            continue
        a, b = e
        if inner[a] and inner[b]:
            out.append((("v", a), ("v", b)))
        else:
            out.append((("v", a if inner[a] else b), ("x", e)))
    return out


def _walk(pairs: list, start, key: str) -> list:
    """The chain of ``pairs`` from ``start`` to the other end (key ``key`` when the
    pairs are not one open chain)."""
    adj: dict = {}
    for p, q in pairs:
        adj.setdefault(p, []).append(q)
        adj.setdefault(q, []).append(p)
    if start not in adj or any(len(v) > 2 for v in adj.values()):
        raise ParameterError(key, "is not one open polyline between the mouth's two ends")
    chain, prev = [start], None
    while True:
        nxt = [v for v in adj[chain[-1]] if v != prev]
        if not nxt or (len(chain) > 1 and len(adj[chain[-1]]) == 1):
            break
        prev = chain[-1]
        chain.append(nxt[0])
    if len(chain) != len(adj):
        raise ParameterError(key, "is not one open polyline between the mouth's two ends")
    return chain


def _front_points(crack, inner, cross_xyz: dict) -> np.ndarray:
    """The front as points (m, 3) from one of its ends (before the mouth is cut)."""
    pairs = _front_edges(crack, inner, cross_xyz)
    ends = sorted(v for p in pairs for v in p if v[0] == "x")
    if len(ends) != 2:
        raise ParameterError(
            "patches", f"the front must meet the body's surface twice, not {len(ends)} times"
        )
    X = np.asarray(crack.points, dtype=float)
    chain = _walk(pairs, ends[0], "patches")
    return np.array([X[v[1]] if v[0] == "v" else cross_xyz[v[1]] for v in chain])


def _polyline_distance(front: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Distance from points ``x`` (k, 3) to the polyline ``front``."""
    a, b = front[:-1], front[1:]
    d = b - a
    t = np.einsum("kij,ij->ki", x[:, None, :] - a[None], d) / np.einsum("ij,ij->i", d, d)
    t = np.clip(t, 0.0, 1.0)
    foot = a[None] + t[..., None] * d[None]
    return np.linalg.norm(x[:, None, :] - foot, axis=2).min(axis=1)


def _size_function(front: np.ndarray, size: TipMesh, h_max: float):
    def h(x: np.ndarray) -> np.ndarray:
        return np.minimum(size.h_tip + size.grading * _polyline_distance(front, x), h_max)

    return h


def _mouth_chain(segments: list, special: dict, front_ends: list[tuple[int, int]]) -> list[int]:
    """The mouth segments as one chain from the front end of the first front edge to
    the other (key ``patches`` when they are not one chain through every crossing)."""
    chains = chord_chains(dict(enumerate(segments)))
    ends = [special[e] for e in front_ends]
    if len(chains) != 1 or {chains[0][0], chains[0][-1]} != set(ends):
        raise ParameterError(
            "patches",
            f"the mouth is not one chain of the surface from one front end to the other "
            f"({len(chains)} chain(s))",
        )
    chain = chains[0] if chains[0][0] == ends[0] else chains[0][::-1]
    if not set(special.values()) <= set(chain):
        raise ParameterError("patches", "a kink of the crack is not on its mouth")
    return chain


def _crossing_nodes(nodes, conn, tags, cross: dict):
    """The crack edges' crossing points made boundary nodes: (nodes, conn, tags, map
    edge → node)."""
    special: dict[tuple[int, int], int] = {}
    for e, x in sorted(cross.items()):
        nodes, conn, tags, i = _insert_point(nodes, conn, tags, x, set(special.values()))
        special[e] = i
    return nodes, conn, tags, special


def _cut_all(nodes, conn, tags, crack, inner, special, h: float):
    """Every patch that crosses the surface cut in turn.  Returns the nodes, triangles,
    tags, the mouth segments and the patch of each."""
    segments, patch_of, locked = [], [], set(special.values())
    edges = crack.edges()
    crossing = [k for k, p in enumerate(crack.patches) if 0 < inner[list(p)].sum() < len(p)]
    for k in crossing:
        on_plane = {special[e] for e, ps in edges.items() if e in special and k in ps}
        others = [j for j in crossing if j != k]
        fixed = {"locked": locked, "on_plane": on_plane, "others": others}
        nodes, conn, tags, segs = _cut_patch(nodes, conn, tags, crack, k, fixed, h)
        segments += segs
        patch_of += [k] * len(segs)
        locked = locked | {i for s in segs for i in s}
    return nodes, conn, tags, segments, patch_of


def _check_crosses(body: BodySurface, crack: NonplanarSurfaceCrack, h: float) -> np.ndarray:
    """Which crack points lie inside the body.  Raises ParameterError: (``points``) the
    crack does not cross the surface, or a point lies within :data:`NEAR_SURFACE` h of it
    (its trace would be shorter than the boundary's facets resolve)."""
    X = np.asarray(crack.points, dtype=float)
    gap = np.array([point_triangle_distance(x, body.triangles).min() for x in X])
    if gap.min() < NEAR_SURFACE * h:
        k = int(np.argmin(gap))
        raise ParameterError(
            "points",
            f"point {k} lies {gap[k]:.3g} m from the body's surface: keep the crack's points "
            f"at least {NEAR_SURFACE * h:.3g} m ({NEAR_SURFACE:g} of the tip size) off it",
        )
    inner = inside_body(body, X)
    if inner.all() or not inner.any():
        raise ParameterError(
            "points",
            "the crack surface does not cross the body's surface (its points lie all "
            + ("inside" if inner.all() else "outside")
            + " the body)",
        )
    return inner


def cut_mouth_surface(
    body: BodySurface, crack: NonplanarSurfaceCrack, size: TipMesh | None = None
) -> NonplanarCut:
    """Cut a non-planar crack's mouth into the body's boundary (numpy; the same on every
    rank); with ``size``, the boundary triangles near the front are first refined
    (red-green) to about its mesh size.

    Raises
    ------
    ParameterError
        (``points``) the crack does not cross the body's surface or a point lies within
        :data:`NEAR_SURFACE` of the tip size of it; (``patches``) an edge
        crosses it more than once, the front does not meet it twice, or the mouth is not
        one chain from one front end to the other through every kink.
    """
    nodes, conn, tags = unique_nodes(body)
    inner = _check_crosses(body, crack, size.h_tip if size is not None else 0.1 * body.h_max)
    cross = _edge_crossings(crack, nodes[conn], inner)
    front0 = _front_points(crack, inner, cross)
    if size is not None:
        h = _size_function(front0, size, body.h_max)
        nodes, conn, tags = refine_near(nodes, conn, tags, h)
    nodes, conn, tags, special = _crossing_nodes(nodes, conn, tags, cross)
    h_loc = _local_size(nodes, conn, front0)
    nodes, conn, tags, segs, patch_of = _cut_all(nodes, conn, tags, crack, inner, special, h_loc)
    front_ends = sorted(e for e in special if len(crack.edges()[e]) == 1)
    chain = _mouth_chain(segs, special, front_ends)
    seg_patch = dict(zip(segs, patch_of, strict=True))
    mp = [seg_patch[(min(p, q), max(p, q))] for p, q in zip(chain, chain[1:], strict=False)]
    X, tris, mouth = compact_nodes(list(nodes), conn, chain)
    front = front0 if np.allclose(front0[0], X[mouth[0]]) else front0[::-1]
    at = {v: i for i, v in enumerate(chain)}
    crossings = {e: mouth[at[v]] for e, v in special.items()}
    return NonplanarCut(X, tris, tags, tuple(mouth), tuple(mp), front, inner, crossings, crack)


def _local_size(nodes: np.ndarray, conn: np.ndarray, front: np.ndarray) -> float:
    """The mean boundary edge within reach of the front's ends."""
    x = nodes[conn]
    edges = np.linalg.norm(x - np.roll(x, 1, axis=1), axis=2)
    reach = 0.5 * float(np.linalg.norm(front[0] - front[-1]))
    close = _polyline_distance(front[[0, -1]], x.mean(axis=1)) < reach
    return float(edges[close].mean()) if close.any() else float(edges.mean())


# ------------------------------------------------------------------ gmsh (rank 0)
def _patch_loop(cut: NonplanarCut, k: int, special: dict) -> list:
    """Patch ``k``'s part inside the body as a loop of items ('v', crack point) or ('b',
    boundary node): its inner corners between the crossings, then the mouth back."""
    p, inner = cut.crack.patches[k], cut.inner
    if inner[list(p)].all():
        return [("v", i) for i in p]
    j = next(i for i in range(len(p)) if inner[p[i]] and not inner[p[i - 1]])
    seq = p[j:] + p[:j]
    n_in = next(i for i in range(len(seq)) if not inner[seq[i]])
    if inner[list(seq[n_in:])].any():
        raise ParameterError("patches", f"patch {k} crosses the body's surface more than twice")
    x_in = special[tuple(sorted((seq[-1], seq[0])))]
    x_out = special[tuple(sorted((seq[n_in - 1], seq[n_in])))]
    pos = {v: i for i, v in enumerate(cut.mouth)}
    a, b = pos[x_out], pos[x_in]
    path = list(cut.mouth[a + 1 : b]) if a < b else list(cut.mouth[b + 1 : a])[::-1]
    lo, hi = min(a, b), max(a, b)
    if any(m != k for m in cut.mouth_patch[lo:hi]):
        raise ParameterError("patches", f"the mouth between patch {k}'s crossings leaves it")
    return [("b", x_in), *[("v", i) for i in seq[:n_in]], ("b", x_out), *[("b", v) for v in path]]


def _num(v: float) -> str:
    return "(" + np.format_float_positional(float(v), unique=True, trim="0") + ")"


def _size_formula(front: np.ndarray, size: TipMesh, h_max: float) -> str:
    """h = min(h_tip + g·d, h_max), d the distance to the front's points sampled at
    h_tip / 2 (within h_tip / 4 of the distance to the polyline)."""
    pts = [front[0]]
    for a, b in zip(front[:-1], front[1:], strict=True):
        m = max(1, int(np.ceil(np.linalg.norm(b - a) / (0.5 * size.h_tip))))
        pts += [a + (b - a) * t for t in np.linspace(0, 1, m + 1)[1:]]
    terms = [
        "Sqrt(" + "+".join(f"(({c})-{_num(p[i])})^2" for i, c in enumerate("xyz")) + ")"
        for p in pts
    ]
    while len(terms) > 1:
        terms = [
            f"Min({terms[i]},{terms[i + 1]})" if i + 1 < len(terms) else terms[i]
            for i in range(0, len(terms), 2)
        ]
    return f"Min({_num(size.h_tip)}+{_num(size.grading)}*{terms[0]},{_num(h_max)})"


def _set_size(formula: str) -> None:
    f = gmsh.model.mesh.field.add("MathEval")
    gmsh.model.mesh.field.setString(f, "F", formula)
    gmsh.model.mesh.field.setAsBackgroundMesh(f)
    for opt in ("MeshSizeFromPoints", "MeshSizeExtendFromBoundary", "MeshSizeFromCurvature"):
        gmsh.option.setNumber(f"Mesh.{opt}", 0)


def _crack_geometry(cut: NonplanarCut) -> tuple[list[int], set[int]]:
    """The patches' parts inside the body as gmsh plane surfaces sharing their curves.
    Returns the surfaces (one per patch, -1 for a patch outside) and the mouth's lines."""
    geo = gmsh.model.geo
    X = np.asarray(cut.crack.points, dtype=float)
    special, pos = cut.crossings, {v: i for i, v in enumerate(cut.mouth)}
    points: dict = {}
    lines: dict = {}
    mouth_lines: set[int] = set()

    def point(item) -> int:
        if item not in points:
            points[item] = geo.addPoint(*(X[item[1]] if item[0] == "v" else cut.nodes[item[1]]))
        return points[item]

    def line(u, v) -> int:
        key = (min(u, v), max(u, v))
        if key not in lines:
            lines[key] = geo.addLine(point(key[0]), point(key[1]))
            if u[0] == v[0] == "b" and abs(pos[u[1]] - pos[v[1]]) == 1:
                mouth_lines.add(lines[key])
        return lines[key] if key == (u, v) else -lines[key]

    surfaces = []
    for k, p in enumerate(cut.crack.patches):
        if not cut.inner[list(p)].any():
            surfaces.append(-1)
            continue
        loop = _patch_loop(cut, k, special)
        curves = [line(u, v) for u, v in zip(loop, loop[1:] + loop[:1], strict=True)]
        surfaces.append(geo.addPlaneSurface([geo.addCurveLoop(curves)]))
    geo.synchronize()
    return surfaces, mouth_lines


def _crack_mesh(cut: NonplanarCut, size: TipMesh, h_max: float):
    """Triangles of the crack surface (a separate gmsh model), each turned to its patch's
    normal.  Returns the node coordinates and the triangles (node indices)."""
    surfaces, mouth_lines = _crack_geometry(cut)
    for ln in mouth_lines:
        gmsh.model.mesh.setTransfiniteCurve(ln, 2)
    _set_size(_size_formula(cut.front_points, size, h_max))
    gmsh.model.mesh.generate(2)
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    xyz = xyz.reshape(-1, 3)
    index = {int(t): i for i, t in enumerate(tags)}
    out = []
    for k, s in enumerate(surfaces):
        if s < 0:
            continue
        _, el = gmsh.model.mesh.getElementsByType(2, s)
        tri = np.array([index[int(t)] for t in el], dtype=np.int64).reshape(-1, 3)
        x = xyz[tri]
        m = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
        flip = m @ cut.crack.normal(k) < 0
        tri[flip] = tri[flip][:, [0, 2, 1]]
        out.append(tri)
    return xyz, np.vstack(out)


def _boundary_entities(cut: NonplanarCut, body: BodySurface) -> list[int]:
    """The cut boundary as discrete surfaces, one per facet tag (with its group)."""
    values = np.unique(cut.tags)
    surfaces = list(range(1, len(values) + 1))
    for k in surfaces:
        gmsh.model.addDiscreteEntity(2, k)
    gmsh.model.mesh.addNodes(2, 1, np.arange(1, len(cut.nodes) + 1), cut.nodes.ravel())
    for k, t in zip(surfaces, values, strict=True):
        gmsh.model.mesh.addElementsByType(k, 2, [], (cut.triangles[cut.tags == t] + 1).ravel())
        if t > 0:
            gmsh.model.addPhysicalGroup(2, [k], int(t), name=body.names.get(int(t), f"facets{t}"))
    return surfaces


def _build(cut: NonplanarCut, body: BodySurface, size: TipMesh, tags: tuple[int, int]) -> None:
    """The cracked volume mesh in a new gmsh model (rank 0)."""
    h_max = min(size.h_max or body.h_max, body.h_max)
    current = gmsh.model.getCurrent()
    gmsh.model.add("nonplanar_surface_crack")
    pts, tri = _crack_mesh(cut, size, h_max)
    gmsh.model.remove()
    gmsh.model.setCurrent(current)
    new, crack_tri = merge_crack(cut, pts, tri)
    surfaces = _boundary_entities(cut, body)
    n0 = len(cut.nodes)
    crack = gmsh.model.addDiscreteEntity(2)
    gmsh.model.mesh.addNodes(2, crack, np.arange(n0 + 1, n0 + len(new) + 1), new.ravel())
    gmsh.model.mesh.addElementsByType(crack, 2, [], (crack_tri + 1).ravel())
    geo = gmsh.model.geo
    volume = geo.addVolume([geo.addSurfaceLoop(surfaces)])
    geo.synchronize()
    gmsh.model.mesh.embed(2, [crack], 3, volume)
    _set_size(_size_formula(cut.front_points, size, h_max))
    X, tets, boundary, boundary_tags = _volume(volume, size.h_tip, cut, crack_tri + 1)
    split = _split_nodes(X, tets, crack_tri + 1, np.asarray(cut.mouth) + 1, boundary)
    gmsh.model.remove()  # the session's model: its place taken by the split one
    gmsh.model.add("nonplanar_surface_crack_split")
    _split_model(split, boundary_tags, body, tags)


def _tetrahedra() -> tuple[np.ndarray, np.ndarray]:
    """The current model's nodes (indexed by tag) and tetrahedra (node tags)."""
    tags_, xyz, _ = gmsh.model.mesh.getNodes()
    X = np.zeros((int(tags_.max()) + 1, 3))
    X[tags_.astype(np.int64)] = xyz.reshape(-1, 3)
    _, conn = gmsh.model.mesh.getElementsByType(4)
    return X, np.asarray(conn, dtype=np.int64).reshape(-1, 4)


def _volume(volume: int, h_tip: float, cut: NonplanarCut, crack_tri: np.ndarray):
    """The volume meshed by HXT, its boundary slivers peeled (:func:`drop_boundary_slivers`);
    where that leaves a flat tetrahedron, the meshers of ``volume_mesh`` in turn.
    Returns the nodes, the tetrahedra, the boundary triangles (node tags) and their tags."""
    gmsh.option.setNumber("Mesh.Algorithm3D", 10)
    gmsh.option.setNumber("Mesh.RandomFactor3D", 1e-12)
    gmsh.model.mesh.generate(3)
    X, tets = _tetrahedra()
    dropped = drop_boundary_slivers(X, tets, cut.triangles + 1, cut.tags, h_tip, crack_tri)
    if dropped is not None:
        return X, *dropped
    gmsh.model.mesh.clear([(3, volume)])
    volume_mesh(volume, h_tip)
    return *_tetrahedra(), cut.triangles + 1, cut.tags


def _six_volumes(X: np.ndarray, tets: np.ndarray) -> np.ndarray:
    t = X[tets]
    return np.einsum("ij,ij->i", np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), t[:, 3] - t[:, 0])


def drop_boundary_slivers(
    X: np.ndarray,
    tets: np.ndarray,
    boundary: np.ndarray,
    tags: np.ndarray,
    h_tip: float,
    crack: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Peel the flat tetrahedra (volume below ``FLAT_VOLUME`` h_tip³) off the boundary:
    four boundary nodes in one plane (a facet of the scan refined red-green has many;
    where the boundary's diagonal of two triangles is not the Delaunay one the mesher
    keeps it by such a tetrahedron, or by a few stacked).  A flat tetrahedron whose faces
    on the boundary (one tag) cover the plane as its other faces do (equal areas: two and
    two, or one and three) is dropped, the others taking the place of those (outward as
    they were), until none is left: the boundary's surface and the volume are unchanged.

    Parameters
    ----------
    X, tets
        Node coordinates (indexed by node) and tetrahedra.
    boundary, tags
        Boundary triangles (outward) and their tags.
    h_tip
        The front's element size (the scale of ``FLAT_VOLUME``).
    crack
        Embedded crack triangles: a flat tetrahedron on one is not dropped.

    Returns
    -------
    (tetrahedra, boundary, tags), or ``None`` when a flat tetrahedron cannot be peeled.
    """
    flat = set(np.flatnonzero(np.abs(_six_volumes(X, tets)) < 6 * FLAT_VOLUME * h_tip**3))
    if not flat:
        return tets, boundary, tags
    faces = _faces(tets)
    bnd = {_key(t): (list(map(int, t)), int(g)) for t, g in zip(boundary, tags, strict=True)}
    keep = set() if crack is None else {_key(t) for t in crack}
    gone = []
    while flat:
        done = [t for t in sorted(flat) if _peel(X, tets, int(t), faces, bnd, keep)]
        if not done:
            return None
        flat -= set(done)
        gone += done
    tris = np.asarray([v[0] for v in bnd.values()], dtype=boundary.dtype)
    return np.delete(tets, gone, axis=0), tris, np.asarray([v[1] for v in bnd.values()], tags.dtype)


def _key(tri) -> tuple[int, int, int]:
    return tuple(sorted(int(v) for v in tri))


def _peel(X, tets, t: int, faces: dict, bnd: dict, keep: set) -> bool:
    """Drop the flat tetrahedron ``t`` from ``faces`` and ``bnd`` (updated) when its
    boundary faces (one tag) and its other faces (each shared with one tetrahedron, none
    a crack triangle) cover the same part of its plane (their areas equal to 1e-6)."""
    fs = [_key(v for k, v in enumerate(tets[t]) if k != d) for d in range(4)]
    on = [f for f in fs if f in bnd]
    off = [f for f in fs if f not in bnd]
    if not on or not off or len({bnd[f][1] for f in on}) != 1:
        return False
    if any(len(faces[f]) != 2 or f in keep for f in off):
        return False
    a_on = sum(np.linalg.norm(_tri_normal(X, f)) for f in on)
    a_off = sum(np.linalg.norm(_tri_normal(X, f)) for f in off)
    if abs(a_on - a_off) > 1e-6 * (a_on + a_off):
        return False
    out = sum(_tri_normal(X, bnd[f][0]) for f in on)
    tag = bnd[on[0]][1]
    for f in on:
        del bnd[f]
    for f in off:
        bnd[f] = (list(f) if _tri_normal(X, f) @ out > 0 else [f[0], f[2], f[1]], tag)
    for f in fs:
        faces[f].remove(t)
    return True


def _tri_normal(X: np.ndarray, tri) -> np.ndarray:
    a, b, c = X[list(tri)]
    return np.cross(b - a, c - a)


@dataclass(frozen=True)
class _Split:
    """The volume mesh with the crack's nodes duplicated (gmsh node tags)."""

    nodes: np.ndarray  # (N + 1, 3), row 0 unused
    tets: np.ndarray
    upper: np.ndarray  # crack triangles with the original nodes
    lower: np.ndarray  # the same triangles with the lower side's nodes
    boundary: np.ndarray  # the boundary triangles, the lower side's mouth nodes renamed


def _faces(tets: np.ndarray) -> dict[tuple[int, int, int], list[int]]:
    out: dict[tuple[int, int, int], list[int]] = {}
    for t, tet in enumerate(tets):
        for drop in range(4):
            f = tuple(sorted(int(v) for k, v in enumerate(tet) if k != drop))
            out.setdefault(f, []).append(t)
    return out


def _front_nodes(crack_tri: np.ndarray, mouth: np.ndarray) -> set[int]:
    """The nodes of the crack mesh's boundary edges that are not the mouth's: the front
    (its ends included)."""
    count: dict[tuple[int, int], int] = {}
    for tri in crack_tri:
        for k in range(3):
            e = tuple(sorted((int(tri[k]), int(tri[(k + 1) % 3]))))
            count[e] = count.get(e, 0) + 1
    mouth_edges = {tuple(sorted((int(a), int(b)))) for a, b in zip(mouth, mouth[1:], strict=False)}
    return {v for e, c in count.items() if c == 1 and e not in mouth_edges for v in e}


def _sides(v: int, around: list[int], tets, faces, crack_faces, X, crack_at) -> list[int]:
    """The tetrahedra at node ``v`` on the lower side of the crack: of the two groups of
    :func:`~bonecontact.fracture.crack_split.node_sides` (joined by faces at v that are
    not the crack's), the one without the tetrahedron in front of a crack triangle at v.
    Raises MeshingError unless the crack parts them in two."""
    groups = node_sides(v, around, tets, crack_faces)
    tri = crack_at[v][0]
    n = np.cross(X[tri[1]] - X[tri[0]], X[tri[2]] - X[tri[0]])
    f = tuple(sorted(int(u) for u in tri))
    up = [t for t in faces[f] if (X[tets[t]].mean(axis=0) - X[tri[0]]) @ n > 0]
    if len(up) != 1:
        raise MeshingError("cannot tell the sides of a crack triangle apart")
    return groups[1] if up[0] in groups[0] else groups[0]


def _split_nodes(X, tets, crack_tri, mouth, boundary) -> _Split:
    """Duplicate the crack's nodes but the front's: the copy goes to the cells on the
    lower side (the side its triangles' normals point away from), found per node by the
    cells' face connections around it (robust at kinks, where a side test by the node's
    mean normal is not)."""
    faces = _faces(tets)
    crack_faces = {tuple(sorted(int(u) for u in t)) for t in crack_tri}
    front = _front_nodes(crack_tri, mouth)
    crack_at: dict[int, list[np.ndarray]] = {}
    for t in crack_tri:
        for u in t:
            crack_at.setdefault(int(u), []).append(t)
    order = np.argsort(tets.ravel(), kind="stable")
    sorted_nodes = tets.ravel()[order]
    split_tets, nodes, rename = tets.copy(), [X], {}
    for v in sorted(set(crack_at) - front):
        lo, hi = np.searchsorted(sorted_nodes, [v, v + 1])
        around = sorted(set((order[lo:hi] // 4).tolist()))
        lower = _sides(v, around, tets, faces, crack_faces, X, crack_at)
        new = len(X) + len(rename)
        rename[v] = new
        nodes.append(X[v][None])
        for t in lower:
            split_tets[t][split_tets[t] == v] = new
    lower_tri = np.array([[rename.get(int(u), int(u)) for u in t] for t in crack_tri])
    bnd = _renamed(boundary, rename, faces, split_tets)
    return _Split(np.vstack(nodes), split_tets, crack_tri, lower_tri, bnd)


def _renamed(boundary: np.ndarray, rename: dict[int, int], faces: dict, tets: np.ndarray):
    """The boundary triangles with the mouth nodes of the lower side's cells renamed (a
    boundary triangle is a face of one cell: it takes that cell's nodes)."""
    out = boundary.copy()
    for i in np.flatnonzero(np.isin(boundary, list(rename)).any(axis=1)):
        (t,) = faces[tuple(sorted(int(u) for u in boundary[i]))]
        own = set(tets[t].tolist())
        out[i] = [u if u in own else rename[u] for u in map(int, boundary[i])]
    return out


def _split_model(split: _Split, boundary_tags: np.ndarray, body: BodySurface, tags) -> None:
    """The split mesh as a discrete gmsh model (nodes numbered 1…N, the cells' only): the
    volume, the boundary's groups, the crack's two faces."""
    used = np.unique(split.tets)
    number = np.zeros(len(split.nodes), dtype=np.int64)
    number[used] = np.arange(1, len(used) + 1)
    vol = gmsh.model.addDiscreteEntity(3)
    gmsh.model.mesh.addNodes(3, vol, np.arange(1, len(used) + 1), split.nodes[used].ravel())
    gmsh.model.mesh.addElementsByType(vol, 4, [], number[split.tets].ravel())
    region, region_tag = body.region
    gmsh.model.addPhysicalGroup(3, [vol], region_tag, name=region)
    groups = [
        (split.boundary[boundary_tags == t], int(t), body.names.get(int(t), f"facets{t}"))
        for t in np.unique(boundary_tags)
        if t > 0
    ]
    groups += [(split.upper, tags[0], "crack_a"), (split.lower, tags[1], "crack_b")]
    for tri, tag, name in groups:
        e = gmsh.model.addDiscreteEntity(2)
        gmsh.model.mesh.addElementsByType(e, 2, [], number[tri].ravel())
        gmsh.model.addPhysicalGroup(2, [e], tag, name=name)


def mesh_body_with_nonplanar_surface_crack(
    body: BodySurface,
    crack: NonplanarSurfaceCrack,
    size: TipMesh,
    comm: MPI.Comm | None = None,
) -> tuple[CrackedBody3D, object, NonplanarCut]:
    """Mesh a 3D body with a non-planar surface crack cut into it (collective; gmsh on
    rank 0).

    Returns
    -------
    (CrackedBody3D, dolfinx.io.gmsh.MeshData, NonplanarCut)
        The cracked mesh (faces ``crack_upper`` on the side of the first patch's normal
        and ``crack_lower``; its ``crack`` is the cut, whose ``front()`` is a polyline:
        ``block()`` does not apply), its mesh data and the cut boundary.

    Raises
    ------
    ParameterError
        The crack does not fit the surface (:func:`cut_mouth_surface`), on every rank.
    MeshingError
        gmsh failed (on every rank).
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    cut = cut_mouth_surface(body, crack, size)
    top = max([body.region[1], *body.names, 0])
    tags = (top + 1, top + 2)
    error = None
    with gmsh_session("nonplanar_surface_body3d") if comm.rank == 0 else nullcontext():
        if comm.rank == 0:
            try:
                _build(cut, body, size, tags)
            except Exception as exc:  # reported on every rank below
                error = (type(exc).__name__, getattr(exc, "key", None), str(exc))
        error = comm.bcast(error, root=0)
        if error is not None:
            if error[0] == "ParameterError":
                raise ParameterError(error[1], error[2].split(": ", 1)[-1])
            raise MeshingError(f"non-planar surface crack in a 3D body: {error[0]}: {error[2]}")
        md = model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=3)
    n = crack.normal(0)
    a, b = tags
    upper, lower = (a, b) if face_side_sign(md.mesh, md.facet_tags, a, n) > 0 else (b, a)
    body3 = CrackedBody3D(
        md.mesh, md.cell_tags, md.facet_tags, cut, {"crack_upper": upper, "crack_lower": lower}
    )
    return body3, md, cut
