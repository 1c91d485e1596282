"""A scene's 2D body re-meshed around a crack (docs/theory/fracture.md#scene-tables).

A scene gives its body as a gmsh mesh.  To cut a crack into it, the body's boundary is
taken from that mesh (:func:`body_outline`): the exterior facets are chained into closed
loops (the outer boundary and the holes), and runs of collinear facets of one facet
group are merged into one straight segment; every segment keeps its facet group.  The
body is then rebuilt from these loops with the OpenCASCADE kernel of gmsh, the crack is
embedded (``fragment``), the body is meshed graded towards the tips and the crack nodes
are duplicated (:func:`mesh_body_with_crack`, as :mod:`bonecontact.fracture.meshing`).
The new mesh carries the scene's cell group and facet groups under their names and tags,
so every boundary condition of the scene applies to it unchanged.

Limits: the body is one cell group (one region); curved boundaries are kept as the
polylines of the given mesh's boundary facets.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from contextlib import nullcontext
from dataclasses import dataclass

from mpi4py import MPI

import gmsh
import numpy as np
import numpy.typing as npt
from dolfinx import mesh
from dolfinx.io.gmsh import model_to_mesh

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.crack import (
    Crack2D,
    crack_gap,
    point_in_polygon,
    segments_intersect,
)
from bonecontact.fracture.meshing import (
    CrackedMesh,
    TipMesh,
    left_side_sign,
    point_tag,
    size_fields,
    split_crack,
)
from bonecontact.meshing.builder import MeshingError
from bonecontact.meshing.session import gmsh_session

__all__ = [
    "BodyOutline",
    "body_outline",
    "check_gaps",
    "mesh_body_with_crack",
    "mesh_body_with_cracks",
]


@dataclass(frozen=True)
class BodyOutline:
    """The boundary of a 2D body: closed loops of straight segments with facet groups.

    Attributes
    ----------
    loops
        Vertices of every loop, shape (n_i, 2) (the segment ``k`` runs from vertex ``k``
        to ``k + 1``, the last back to the first), every loop counter-clockwise;
        ``loops[0]`` is the outer boundary.
    loop_tags
        Facet-group tag of every segment of every loop (0: in no group).
    names
        Facet-group tag → name.
    region
        (name, tag) of the body's cell group.
    h_max
        Largest boundary facet of the given mesh (m): the size away from the tips.
    """

    loops: tuple[npt.NDArray[np.float64], ...]
    loop_tags: tuple[npt.NDArray[np.int32], ...]
    names: dict[int, str]
    region: tuple[str, int]
    h_max: float

    @property
    def outer(self) -> npt.NDArray[np.float64]:
        return self.loops[0]

    @property
    def scale(self) -> float:
        return float(np.ptp(self.outer, axis=0).max())

    def segments(self) -> npt.NDArray[np.float64]:
        """All boundary segments, shape (n, 2, 2)."""
        return np.concatenate(
            [np.stack([lp, np.roll(lp, -1, axis=0)], axis=1) for lp in self.loops]
        )

    def distance(self, p: npt.ArrayLike) -> float:
        """Distance from ``p`` to the boundary (m)."""
        return float(_distances(np.asarray(p, dtype=float)[:2], self.segments()).min())

    def nearest(self, p: npt.ArrayLike) -> tuple[npt.NDArray[np.float64], float]:
        """The boundary point nearest to ``p`` and its distance (m)."""
        p = np.asarray(p, dtype=float)[:2]
        best, dist = p, np.inf
        for a, b in self.segments():
            ab = b - a
            s = float(np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0))
            q = a + s * ab
            d = float(np.linalg.norm(p - q))
            if d < dist:
                best, dist = q, d
        return best, dist

    def inside(self, p: npt.ArrayLike) -> bool:
        """Whether ``p`` lies strictly inside the body (in the outer loop, in no hole)."""
        return point_in_polygon(p, self.outer) and not any(
            point_in_polygon(p, hole) for hole in self.loops[1:]
        )

    def check_crack(self, crack: Crack2D) -> None:
        """Raise :class:`ParameterError` unless the crack lies in the body: tips and interior
        vertices strictly inside (in the outer loop, outside every hole), a mouth on a loop
        (the outer boundary or a hole's edge), no segment crossing or touching a loop
        except at its mouth."""
        tol = 1e-9 * self.scale
        pts = crack.points
        n = len(pts)
        mouth = [
            (i == 0 and 0 in crack.mouth_ends) or (i == n - 1 and -1 in crack.mouth_ends)
            for i in range(n)
        ]
        for i, p in enumerate(pts):
            on_loop = self.distance(p) <= tol
            if mouth[i] and not on_loop:
                raise ParameterError(
                    "points", f"the crack mouth {p.tolist()} is not on the outline"
                )
            if not mouth[i] and (on_loop or not self.inside(p)):
                raise ParameterError("points", f"crack point {p.tolist()} is not inside the body")
        segs = self.segments()
        for i in range(n - 1):
            a, b = pts[i], pts[i + 1]
            # shrink a segment ending at a mouth so that its contact there is allowed
            shrink = 1e-6 + 10.0 * tol / float(np.linalg.norm(b - a))
            a2 = a + shrink * (b - a) if mouth[i] else a
            b2 = b - shrink * (b - a) if mouth[i + 1] else b
            for e0, e1 in segs:
                if segments_intersect(a2, b2, e0, e1, tol):
                    raise ParameterError("points", f"crack segment {i} crosses the outline")


# ------------------------------------------------------------------ the given mesh
def _boundary_edges(
    msh: mesh.Mesh, facet_tags: mesh.MeshTags
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]:
    """Owned exterior facets of all ranks: vertex coordinates (n, 2, 2) and tag (0: none)."""
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    ext = mesh.exterior_facet_indices(msh.topology)
    ext = ext[ext < msh.topology.index_map(tdim - 1).size_local]
    geom = mesh.entities_to_geometry(msh, tdim - 1, ext)
    xy = msh.geometry.x[geom][:, :, :2] if ext.size else np.zeros((0, 2, 2))
    tag_of = dict(zip(facet_tags.indices.tolist(), facet_tags.values.tolist(), strict=True))
    tags = np.array([tag_of.get(int(f), 0) for f in ext], dtype=np.int32)
    parts = msh.comm.allgather((xy, tags))
    return np.concatenate([p[0] for p in parts]).reshape(-1, 2, 2), np.concatenate(
        [p[1] for p in parts]
    ).astype(np.int32)


def _chain_loops(
    edges: npt.NDArray[np.float64], tags: npt.NDArray[np.int32], tol: float
) -> list[tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]]:
    """Chain boundary edges into closed loops: [(vertices, segment tags)]."""
    keys = np.round(edges.reshape(-1, 2) / tol).astype(np.int64)
    _, node = np.unique(keys, axis=0, return_inverse=True)
    node = node.reshape(-1, 2)
    coords = np.zeros((node.max() + 1 if node.size else 0, 2))
    coords[node.ravel()] = edges.reshape(-1, 2)
    incident: dict[int, list[int]] = {}
    for e, (a, b) in enumerate(node):
        incident.setdefault(int(a), []).append(e)
        incident.setdefault(int(b), []).append(e)
    if any(len(v) != 2 for v in incident.values()):
        raise MeshingError("the mesh boundary is not a set of closed loops (a non-manifold vertex)")
    used = np.zeros(len(node), dtype=bool)
    loops = []
    for start in range(len(node)):
        if used[start]:
            continue
        verts, seg_tags = [int(node[start, 0])], []
        e, v = start, int(node[start, 1])
        while True:
            used[e] = True
            seg_tags.append(int(tags[e]))
            if v == verts[0]:
                break
            verts.append(v)
            e = next(k for k in incident[v] if k != e)
            v = int(node[e, 1]) if int(node[e, 0]) == v else int(node[e, 0])
        loops.append((coords[verts], np.array(seg_tags, dtype=np.int32)))
    return loops


def _merge_collinear(
    verts: npt.NDArray[np.float64], tags: npt.NDArray[np.int32], rtol: float = 1e-9
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]:
    """Drop the vertices between two collinear segments of one facet group."""
    n = len(verts)

    def straight(i: int) -> bool:  # vertex i joins segment i-1 and segment i
        a, b, c = verts[i - 1], verts[i], verts[(i + 1) % n]
        u, w = b - a, c - b
        cross = abs(u[0] * w[1] - u[1] * w[0])
        return tags[i - 1] == tags[i] and cross <= rtol * np.linalg.norm(u) * np.linalg.norm(w)

    keep = np.array([not straight(i) for i in range(n)])
    if not keep.any():
        raise MeshingError("a boundary loop of the mesh is degenerate")
    idx = np.flatnonzero(keep)
    return verts[idx], tags[idx]


def _signed_area(p: npt.NDArray[np.float64]) -> float:
    q = np.roll(p, -1, axis=0)
    return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))


def _counter_clockwise(
    verts: npt.NDArray[np.float64], tags: npt.NDArray[np.int32]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]:
    """The loop turned counter-clockwise if it is not: vertices reversed, and the tag of
    segment ``j`` (from vertex ``j`` to ``j + 1``) that of the old segment ``n − 2 − j``.

    The facets chain up in whatever order the mesh numbers them, so a hole's loop may
    turn either way; gmsh's crack splitting needs every loop of the cracked body in one
    orientation (with a hole turning the other way, the nodes of one crack face were
    left unused)."""
    if _signed_area(verts) >= 0.0:
        return verts, tags
    return verts[::-1].copy(), np.roll(tags[::-1], -1).copy()


def _canonical_start(
    verts: npt.NDArray[np.float64], tags: npt.NDArray[np.int32]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]:
    """The loop rotated to start at its lexicographically smallest vertex (x, then y).

    The facets are gathered in rank order, so the chain starts wherever the first rank's
    first facet lies; gmsh meshes a loop differently from another start point (3802 dofs
    on one rank, 3804 on two).  Rotated, the loop is the same on any number of ranks."""
    k = int(np.lexsort((verts[:, 1], verts[:, 0]))[0])
    return np.roll(verts, -k, axis=0), np.roll(tags, -k)


def body_outline(
    msh: mesh.Mesh,
    cell_tags: mesh.MeshTags,
    facet_tags: mesh.MeshTags,
    groups: dict[str, tuple[int, int]],
    region: str,
) -> BodyOutline:
    """The boundary of a one-region 2D mesh as loops of facet-group segments (collective).

    Raises
    ------
    ParameterError
        The mesh has cells outside ``region`` (key ``region``), on every rank.
    MeshingError
        The boundary is not a set of closed loops.
    """
    comm = msh.comm
    tdim = msh.topology.dim
    n_cells = msh.topology.index_map(tdim).size_local
    region_tag = groups[region][1]
    own = cell_tags.indices[cell_tags.indices < n_cells]
    vals = cell_tags.values[cell_tags.indices < n_cells]
    other = int(own.size < n_cells or np.any(vals != region_tag))
    if comm.allreduce(other, op=MPI.MAX):
        raise ParameterError(
            "region",
            f"a scene with a crack needs a mesh of one cell group (the crack's region "
            f"{region!r}); this mesh has cells outside it",
        )
    edges, tags = _boundary_edges(msh, facet_tags)
    scale = float(np.ptp(edges.reshape(-1, 2), axis=0).max())
    loops = _chain_loops(edges, tags, 1e-9 * scale)
    merged = [_canonical_start(*_counter_clockwise(*_merge_collinear(v, t))) for v, t in loops]
    # the outer loop first, the holes by their first vertex (ties in area cannot reorder)
    outer = max(range(len(merged)), key=lambda i: abs(_signed_area(merged[i][0])))
    holes = [vt for i, vt in enumerate(merged) if i != outer]
    holes.sort(key=lambda vt: tuple(vt[0][0]))
    merged = [merged[outer], *holes]
    h_max = float(np.linalg.norm(edges[:, 1] - edges[:, 0], axis=1).max())
    names = {t: n for n, (d, t) in groups.items() if d == tdim - 1}
    return BodyOutline(
        tuple(v for v, _ in merged),
        tuple(t for _, t in merged),
        names,
        (region, region_tag),
        h_max,
    )


def _distances(p: npt.NDArray[np.float64], segs: npt.NDArray[np.float64]) -> np.ndarray:
    """Distance from ``p`` to every segment of ``segs`` (shape (n, 2, 2))."""
    a, ab = segs[:, 0], segs[:, 1] - segs[:, 0]
    s = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    return np.linalg.norm(p - (a + s[:, None] * ab), axis=1)


# ---------------------------------------------------------------- gmsh (rank 0)
def _name_curves(body: BodyOutline, cracks: Sequence[Crack2D], tol: float) -> dict[str, list[int]]:
    """Every model curve named: ``crack<i>`` (on crack ``i``) or ``tag<t>`` (a boundary
    segment of facet group ``t``)."""
    segs = body.segments()
    seg_tags = np.concatenate(body.loop_tags)
    names: dict[str, list[int]] = {}
    for _, curve in gmsh.model.getEntities(1):
        lo, hi = gmsh.model.getParametrizationBounds(1, curve)
        p = np.asarray(gmsh.model.getValue(1, curve, [0.5 * (lo[0] + hi[0])])[:2])
        on = [i for i, c in enumerate(cracks) if c.distance(p) < tol]
        if on:
            names.setdefault(f"crack{on[0]}", []).append(curve)
            continue
        d = _distances(p, segs)
        k = int(np.argmin(d))
        if d[k] > tol:
            raise MeshingError(f"curve {curve} at {p.tolist()} belongs to no boundary segment")
        names.setdefault(f"tag{int(seg_tags[k])}", []).append(curve)
    return names


def _build(
    body: BodyOutline,
    cracks: Sequence[Crack2D],
    size: TipMesh,
    tags: Sequence[tuple[int, int, int]],
) -> None:
    occ = gmsh.model.occ
    loops = []
    for verts in body.loops:
        pts = [occ.addPoint(x, y, 0) for x, y in verts]
        lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
        loops.append(occ.addCurveLoop(lines))
    surface = occ.addPlaneSurface(loops)
    cl = []
    for crack in cracks:
        cp = [occ.addPoint(x, y, 0) for x, y in crack.points]
        cl += [occ.addLine(cp[i], cp[i + 1]) for i in range(len(cp) - 1)]
    occ.fragment([(2, surface)], [(1, t) for t in cl])
    occ.synchronize()
    tol = 1e-7 * body.scale
    names = _name_curves(body, cracks, tol)
    tips = [point_tag(c.points[e], tol) for c in cracks for e in c.tip_ends]
    size_fields(tips, (), [], size, min(size.h_max or body.h_max, body.h_max))
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    region, region_tag = body.region
    gmsh.model.addPhysicalGroup(2, [t for _, t in gmsh.model.getEntities(2)], region_tag, region)
    for key, curves in names.items():
        tag = int(key[3:]) if key.startswith("tag") else 0
        if tag > 0:
            gmsh.model.addPhysicalGroup(1, curves, tag, name=body.names.get(tag, f"facets{tag}"))
    gmsh.model.mesh.generate(2)
    for i, (crack, t) in enumerate(zip(cracks, tags, strict=True)):
        label = "crack" if len(cracks) == 1 else f"crack{i}"
        last = i == len(cracks) - 1
        split_crack({"crack": names[f"crack{i}"]}, crack, tol, *t, label=label, renumber=last)


def check_gaps(cracks: Sequence[Crack2D], body: BodyOutline) -> None:
    """Raise :class:`ParameterError` (key ``points``) when two cracks cross or touch (the
    message names them by index, from 0)."""
    for i in range(len(cracks)):
        for j in range(i):
            if crack_gap(cracks[i], cracks[j]) <= 1e-9 * body.scale:
                raise ParameterError(
                    "points", f"crack {i} crosses or touches crack {j}: cracks may not meet"
                )


def mesh_body_with_cracks(
    body: BodyOutline, cracks: Sequence[Crack2D], size: TipMesh, comm: MPI.Comm | None = None
) -> tuple[list[CrackedMesh], object]:
    """Mesh ``body`` with the ``cracks`` cut into it (collective; gmsh on rank 0), graded
    towards every tip, every crack split into its own two faces.

    Returns
    -------
    (list of CrackedMesh, dolfinx.io.gmsh.MeshData)
        One view of the cracked mesh per crack (the same mesh and markers; its crack and
        its ``crack_plus``/``crack_minus`` tags) and the mesh data with its physical
        groups (one crack: ``crack_a``/``crack_b``; several: ``crack<i>_a``/``_b``).

    Raises
    ------
    ParameterError
        A crack does not lie in the body, or two cracks meet (on every rank).
    MeshingError
        gmsh failed (on every rank).
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    for crack in cracks:
        body.check_crack(crack)
    check_gaps(cracks, body)
    top = max([body.region[1], *body.names, 0])
    # per crack: its face, its second face, its mouth points
    tags = [(top + 1 + 3 * i, top + 2 + 3 * i, top + 3 + 3 * i) for i in range(len(cracks))]
    error = None
    with gmsh_session("cracked_scene") if comm.rank == 0 else nullcontext():
        if comm.rank == 0:
            try:
                _build(body, cracks, size, tags)
            except Exception as exc:  # reported on every rank below
                error = f"{type(exc).__name__}: {exc}"
        error = comm.bcast(error, root=0)
        if error is not None:
            raise MeshingError(f"cracked body: {error}")
        md = model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=2)
    groups = {
        n: int(pg.tag) for n, pg in md.physical_groups.items() if not re.match(r"crack\d*_[ab]$", n)
    }
    views = []
    for crack, (a, b, _) in zip(cracks, tags, strict=True):
        cm = CrackedMesh(md.mesh, md.cell_tags, md.facet_tags, crack, dict(groups), body.outer)
        plus, minus = (a, b) if left_side_sign(cm, a) > 0 else (b, a)
        cm.groups["crack_plus"], cm.groups["crack_minus"] = plus, minus
        views.append(cm)
    return views, md


def mesh_body_with_crack(
    body: BodyOutline, crack: Crack2D, size: TipMesh, comm: MPI.Comm | None = None
) -> tuple[CrackedMesh, object]:
    """Mesh ``body`` with one ``crack`` cut into it (:func:`mesh_body_with_cracks`).

    Returns
    -------
    (CrackedMesh, dolfinx.io.gmsh.MeshData)
        The cracked mesh (groups: the region, the facet groups by name, ``crack_plus``,
        ``crack_minus``) and the mesh data with its physical groups.
    """
    views, md = mesh_body_with_cracks(body, [crack], size, comm)
    return views[0], md


def tip_size_default(crack: Crack2D, increment: float | None) -> float:
    """Default tip element size: Δa/8 with an increment, else 1/100 of the shortest tip
    segment (m)."""
    if increment is not None:
        return increment / 8
    return min(crack.tip_segment_length(e) for e in crack.tip_ends) / 100
