"""A scene's 3D body re-meshed around a planar crack (docs/theory/fracture.md#3d-crack-fronts).

The counterpart of :mod:`bonecontact.fracture.body` in 3D.  The boundary triangles of the
scene's mesh (with their facet groups) are gathered on rank 0 and become discrete gmsh
surfaces, one per facet group, which bound the volume; the crack (a
:class:`~bonecontact.fracture.crack3d.PlanarCrack`: disc, ellipse or convex polygon) is a
plane surface of the built-in kernel embedded in that volume.  The volume is meshed with tetrahedra
graded towards the front, h = min(h_f + g·d, h_max) (d the distance to the front, h_max
the largest boundary facet of the scene's mesh), and gmsh's ``Crack`` plugin duplicates
the nodes of the crack surface except those of the front: the two faces become the facet
groups ``crack_upper`` (the side the crack normal points to) and ``crack_lower`` (the
split checked: :mod:`~bonecontact.fracture.crack_split`).  The
scene's boundary triangulation is kept as it is, so every facet group keeps its name,
tag and shape (curved surfaces stay the facets of the given mesh).  All gmsh work runs
on rank 0; DOLFINx distributes the mesh.

Limits: the body is one cell group (the crack's region); the crack is interior (its
front does not reach the surface).
"""

from __future__ import annotations

import math
from contextlib import nullcontext
from dataclasses import dataclass, field
from typing import Any

from mpi4py import MPI

import gmsh
import numpy as np
import numpy.typing as npt
from dolfinx import mesh
from dolfinx.io.gmsh import model_to_mesh

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.crack3d import PlanarCrack, TriangulatedCrack
from bonecontact.fracture.crack_split import crack_surface, split_checked
from bonecontact.fracture.front3d import CrackBlock
from bonecontact.fracture.meshing import TipMesh
from bonecontact.meshing.builder import MeshingError
from bonecontact.meshing.session import gmsh_session

__all__ = [
    "BodySurface",
    "CrackedBody3D",
    "body_surface",
    "face_side_sign",
    "mesh_body_with_planar_crack",
    "mesh_body_with_planar_cracks",
]


@dataclass(frozen=True)
class BodySurface:
    """The boundary triangulation of a 3D body (the same on every rank).

    Attributes
    ----------
    triangles
        Vertex coordinates of every boundary facet, shape (n, 3, 3) (m).
    tags
        Facet-group tag of every facet (0: in no group).
    names
        Facet-group tag → name.
    region
        (name, tag) of the body's cell group.
    h_max
        Longest boundary edge (m): the element size away from the front.
    """

    triangles: npt.NDArray[np.float64]
    tags: npt.NDArray[np.int32]
    names: dict[int, str]
    region: tuple[str, int]
    h_max: float

    @property
    def scale(self) -> float:
        return float(np.ptp(self.triangles.reshape(-1, 3), axis=0).max())

    def distance(self, points: npt.ArrayLike) -> float:
        """Smallest distance from ``points`` (m, 3) to the boundary vertices (m): an upper
        bound of the distance to the surface, within a facet size."""
        p = np.atleast_2d(np.asarray(points, dtype=float))
        v = np.unique(self.triangles.reshape(-1, 3), axis=0)
        return float(min(np.min(np.linalg.norm(v - q, axis=1)) for q in p))


@dataclass
class CrackedBody3D:
    """A distributed 3D mesh with a planar crack whose faces are separate boundaries.

    Attributes
    ----------
    mesh, cell_tags, facet_tags
        The DOLFINx mesh and markers (the scene's groups under their tags).
    crack
        The crack.
    groups
        ``"crack_upper"``, ``"crack_lower"`` → facet tag.
    """

    mesh: mesh.Mesh
    cell_tags: mesh.MeshTags
    facet_tags: mesh.MeshTags
    crack: PlanarCrack | TriangulatedCrack
    groups: dict[str, int] = field(default_factory=dict)

    @property
    def face_tags(self) -> tuple[int, int]:
        """Facet tags ``(crack_upper, crack_lower)`` (the slave and master of the pair)."""
        return self.groups["crack_upper"], self.groups["crack_lower"]

    def block(self) -> CrackBlock:
        """The model for :func:`~bonecontact.fracture.front3d.front_interaction_integral`
        (both faces meshed: K_I, K_II, K_III)."""
        return CrackBlock(
            self.mesh,
            self.cell_tags,
            self.facet_tags,
            self.crack.front(),
            dict(self.groups),
            half_model=False,
        )


def _outward_triangles(msh: mesh.Mesh, ext: npt.NDArray[np.int32]) -> npt.NDArray[np.float64]:
    """Vertex coordinates (n, 3, 3) of the exterior facets ``ext``, each turned so that its
    normal points out of its cell.  The vertex order of a facet follows the local
    numbering, which changes with the partition; so would the orientation that gmsh's
    discrete surfaces were given."""
    if not ext.size:
        return np.zeros((0, 3, 3))
    tdim = msh.topology.dim
    tri = msh.geometry.x[mesh.entities_to_geometry(msh, tdim - 1, ext)].copy()
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    cells = np.array([f2c.links(f)[0] for f in ext], dtype=np.int32)
    centre = mesh.compute_midpoints(msh, tdim, cells)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    flip = np.einsum("ij,ij->i", normal, tri.mean(axis=1) - centre) < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    return tri


def body_surface(
    msh: mesh.Mesh,
    cell_tags: mesh.MeshTags,
    facet_tags: mesh.MeshTags,
    groups: dict[str, tuple[int, int]],
    region: str,
) -> BodySurface:
    """The boundary of a one-region 3D mesh, gathered on every rank (collective).

    Raises
    ------
    ParameterError
        The mesh has cells outside ``region`` (key ``region``), on every rank.
    """
    comm = msh.comm
    tdim = msh.topology.dim
    n_cells = msh.topology.index_map(tdim).size_local
    region_tag = groups[region][1]
    own = cell_tags.indices < n_cells
    other = int(int(own.sum()) < n_cells or np.any(cell_tags.values[own] != region_tag))
    if comm.allreduce(other, op=MPI.MAX):
        raise ParameterError(
            "region",
            f"a scene with a crack needs a mesh of one cell group (the crack's region "
            f"{region!r}); this mesh has cells outside it",
        )
    msh.topology.create_connectivity(tdim - 1, tdim)
    ext = mesh.exterior_facet_indices(msh.topology)
    ext = ext[ext < msh.topology.index_map(tdim - 1).size_local]
    tri = _outward_triangles(msh, ext)
    tag_of = dict(zip(facet_tags.indices.tolist(), facet_tags.values.tolist(), strict=True))
    tags = np.array([tag_of.get(int(f), 0) for f in ext], dtype=np.int32)
    parts = comm.allgather((tri, tags))
    tri = np.concatenate([p[0] for p in parts]).reshape(-1, 3, 3)
    tags = np.concatenate([p[1] for p in parts]).astype(np.int32)
    tri, tags = _canonical(tri, tags)
    edges = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2)
    names = {t: n for n, (d, t) in groups.items() if d == tdim - 1}
    return BodySurface(tri, tags, names, (region, region_tag), float(edges.max()))


def _canonical(
    T: npt.NDArray[np.float64], tags: npt.NDArray[np.int32]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]:
    """The triangles ``T`` (n, 3, 3) each started at its least vertex (lexicographic; the
    cyclic order, so the orientation, kept) and sorted, with their ``tags``: the same
    arrays whatever order the partition gathered them in (sums over them then agree to
    the last bit on any rank count)."""
    n = len(T)
    first = np.zeros(n, dtype=int)
    for k in (1, 2):
        a, b = T[np.arange(n), first], T[:, k]
        less = (b[:, 0] < a[:, 0]) | (
            (b[:, 0] == a[:, 0])
            & ((b[:, 1] < a[:, 1]) | ((b[:, 1] == a[:, 1]) & (b[:, 2] < a[:, 2])))
        )
        first = np.where(less, k, first)
    T = T[np.arange(n)[:, None], (first[:, None] + np.arange(3)) % 3]
    order = np.lexsort(T.reshape(n, 9).T[::-1])
    return T[order], tags[order]


# ---------------------------------------------------------------------- gmsh (rank 0)
def _boundary_surfaces(body: BodySurface) -> list[int]:
    """One discrete surface per facet tag with the body's triangles; their tags."""
    tol = 1e-9 * body.scale
    xyz = body.triangles.reshape(-1, 3)
    _, first, inv = np.unique(
        np.round(xyz / tol).astype(np.int64), axis=0, return_index=True, return_inverse=True
    )
    conn = inv.reshape(-1, 3) + 1
    # gmsh's input in the order of the rounded nodes: each triangle from its smallest
    # node, orientation kept; rows sorted
    first_node = np.argmin(conn, axis=1)
    conn = np.stack([np.roll(c, -k) for c, k in zip(conn, first_node, strict=True)])
    order = np.lexsort(conn.T[::-1])
    conn, tags = conn[order], body.tags[order]
    values = np.unique(tags)
    surfaces = []
    for k, _ in enumerate(values, start=1):
        gmsh.model.addDiscreteEntity(2, k)
        surfaces.append(k)
    gmsh.model.mesh.addNodes(2, surfaces[0], np.arange(1, len(first) + 1), xyz[first].ravel())
    for k, t in zip(surfaces, values, strict=True):
        gmsh.model.mesh.addElementsByType(k, 2, [], conn[tags == t].ravel())
    for k, t in zip(surfaces, values, strict=True):
        if t > 0:
            gmsh.model.addPhysicalGroup(2, [k], int(t), name=body.names.get(int(t), f"facets{t}"))
    return surfaces


def _patches(crack: TriangulatedCrack) -> tuple[list[int], list[int]]:
    """A non-planar crack as plane surfaces of the built-in kernel sharing their edges:
    the surface tags and the front's lines."""
    geo = gmsh.model.geo
    pts = [geo.addPoint(*p) for p in crack.points]
    lines: dict[tuple[int, int], int] = {}

    def line(i: int, j: int) -> int:
        if (j, i) in lines:
            return -lines[(j, i)]
        if (i, j) not in lines:
            lines[(i, j)] = geo.addLine(pts[i], pts[j])
        return lines[(i, j)]

    surfaces = []
    for patch in crack.patches:
        loop = [line(i, j) for i, j in zip(patch, patch[1:] + patch[:1], strict=True)]
        surfaces.append(geo.addPlaneSurface([geo.addCurveLoop(loop)]))
    ids = crack.front_ids
    front = [abs(line(i, j)) for i, j in zip(ids, ids[1:] + ids[:1], strict=True)]
    return surfaces, front


def _crack_surface(crack: PlanarCrack | TriangulatedCrack) -> tuple[list[int], list[int]]:
    """The crack as plane surfaces of the built-in kernel: their tags and the front curves
    (four arcs, a polygon's edges or a grown crack's front polyline)."""
    geo = gmsh.model.geo
    if isinstance(crack, TriangulatedCrack):
        return _patches(crack)
    if crack.vertices is not None:
        corners = [geo.addPoint(*p) for p in crack.vertices]
        edges = [geo.addLine(p, q) for p, q in zip(corners, corners[1:] + corners[:1], strict=True)]
        return [geo.addPlaneSurface([geo.addCurveLoop(edges)])], edges
    c = np.asarray(crack.centre, dtype=float)
    R = crack.axes
    centre = geo.addPoint(*c)
    ends = [
        geo.addPoint(*(c + crack.a * math.cos(t) * R[0] + crack.b * math.sin(t) * R[1]))
        for t in 0.5 * math.pi * np.arange(4)
    ]
    if crack.a == crack.b:
        arcs = [geo.addCircleArc(ends[i], centre, ends[(i + 1) % 4]) for i in range(4)]
    else:
        arcs = [geo.addEllipseArc(ends[i], centre, ends[0], ends[(i + 1) % 4]) for i in range(4)]
    return [geo.addPlaneSurface([geo.addCurveLoop(arcs)])], arcs


def _size_field(
    front: list[int],
    crack: PlanarCrack | TriangulatedCrack | list[PlanarCrack | TriangulatedCrack],
    size: TipMesh,
    h_max: float,
) -> None:
    """Sizes graded from the front curves ``front`` (of one crack or of several)."""
    fld = gmsh.model.mesh.field
    d = fld.add("Distance")
    fld.setNumbers(d, "CurvesList", front)
    perimeter = sum(c.front().perimeter for c in (crack if isinstance(crack, list) else [crack]))
    fld.setNumber(d, "Sampling", max(100, int(4 * perimeter / size.h_tip / 4)))
    f = fld.add("MathEval")
    fld.setString(f, "F", f"Min({size.h_tip!r} + {size.grading!r}*F{d}, {h_max!r})")
    fld.setAsBackgroundMesh(f)
    for opt in ("MeshSizeFromPoints", "MeshSizeExtendFromBoundary", "MeshSizeFromCurvature"):
        gmsh.option.setNumber(f"Mesh.{opt}", 0)


def _split(
    surfaces: list[int],
    crack_group: int,
    second_group: int,
    label: str = "crack",
    last: bool = True,
) -> None:
    """Duplicate the crack surface's nodes (not the front's): two physical groups
    (``<label>_a``, ``<label>_b``; several cracks split one after the other, the nodes
    renumbered after the ``last``), checked and, where the plugin left a triangle unsplit
    or a cell on the wrong side, split again by the cells' connections
    (:func:`~bonecontact.fracture.crack_split.split_checked`; a split still wrong is a
    :class:`MeshingError` naming ``label``)."""
    before = crack_surface(surfaces)
    gmsh.model.addPhysicalGroup(2, surfaces, crack_group, name=f"{label}_a")
    plugin = gmsh.plugin
    plugin.setNumber("Crack", "Dimension", 2)
    plugin.setNumber("Crack", "PhysicalGroup", crack_group)
    plugin.setNumber("Crack", "NewPhysicalGroup", second_group)
    plugin.setNumber("Crack", "OpenBoundaryPhysicalGroup", 0)
    plugin.run("Crack")
    gmsh.model.setPhysicalName(2, second_group, f"{label}_b")
    split_checked(before, (crack_group, second_group), label)
    if last:  # the plugin leaves gaps; DOLFINx needs them contiguous
        gmsh.model.mesh.renumberNodes()
        gmsh.model.mesh.renumberElements()


def _build(
    body: BodySurface,
    crack: PlanarCrack | TriangulatedCrack | list[PlanarCrack | TriangulatedCrack],
    size: TipMesh,
    tags: tuple[int, int] | list[tuple[int, int]],
) -> None:
    """The body with one crack, or several (``crack`` and ``tags`` lists: each crack
    embedded and split into its own faces, labelled ``crack<i>``)."""
    several = isinstance(crack, list)
    cracks, tags = (crack, tags) if several else ([crack], [tags])
    surfaces = _boundary_surfaces(body)
    geo = gmsh.model.geo
    volume = geo.addVolume([geo.addSurfaceLoop(surfaces)])
    pieces = [_crack_surface(c) for c in cracks]
    geo.synchronize()
    gmsh.model.mesh.embed(2, [t for faces, _ in pieces for t in faces], 3, volume)
    region, region_tag = body.region
    gmsh.model.addPhysicalGroup(3, [volume], region_tag, name=region)
    front = [t for _, fr in pieces for t in fr]
    _size_field(front, cracks, size, min(size.h_max or body.h_max, body.h_max))
    gmsh.option.setNumber("Mesh.Algorithm3D", 10)  # HXT (honours the embedded crack)
    gmsh.model.mesh.generate(3)
    for i, ((faces, _), t) in enumerate(zip(pieces, tags, strict=True)):
        _split(faces, *t, label=f"crack{i}" if several else "crack", last=i == len(pieces) - 1)


# --------------------------------------------------------------------- DOLFINx side
def face_side_sign(msh: mesh.Mesh, facet_tags: mesh.MeshTags, tag: int, n: np.ndarray) -> int:
    """+1 if the cells behind facet group ``tag`` lie on the side ``n`` points to, else −1
    (collective): the sign of the group's area projected on ``n``, each facet's normal
    turned towards its cell (a grown crack's strip facet, 54° off ``n``, can have its
    cell's centroid on the other side of it along ``n``: counting those signs tied)."""
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    facets = facet_tags.find(tag)
    facets = facets[facets < msh.topology.index_map(tdim - 1).size_local]
    total = area = 0.0
    if facets.size:
        cells = np.array([f2c.links(f)[0] for f in facets], dtype=np.int32)
        fmid = mesh.compute_midpoints(msh, tdim - 1, facets)
        cmid = mesh.compute_midpoints(msh, tdim, cells)
        x = msh.geometry.x[mesh.entities_to_geometry(msh, tdim - 1, facets)]
        m = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])  # twice the area times the normal
        m *= np.sign(np.einsum("ij,ij->i", cmid - fmid, m))[:, None]
        total, area = float(np.sum(m @ n)), float(np.linalg.norm(m, axis=1).sum())
    total, area = msh.comm.allreduce(np.array([total, area]), op=MPI.SUM)
    if abs(total) <= 1e-12 * area or area == 0:
        raise MeshingError("cannot tell the sides of the crack faces apart")
    return 1 if total > 0 else -1


def front_vertices(
    msh: mesh.Mesh, facet_tags: mesh.MeshTags, face_tags: tuple[int, int]
) -> npt.NDArray[np.float64]:
    """Coordinates (m, 3) of the vertices shared by the two crack faces ``face_tags`` —
    the front's — on every rank, sorted by coordinates (collective).

    gmsh's ``Crack`` plugin duplicated the faces' other vertices (a copy on each face at
    the same point), so the front is told by the vertex (its global index), not by its
    coordinates (which would return every face node)."""
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, 0)
    msh.topology.create_connectivity(0, tdim)  # entities_to_geometry of vertices
    f2v = msh.topology.connectivity(tdim - 1, 0)
    imap = msh.topology.index_map(0)
    faces = []
    for tag in face_tags:
        facets = facet_tags.find(tag)
        verts = np.unique([v for f in facets for v in f2v.links(f)]).astype(np.int32)
        x = msh.geometry.x[mesh.entities_to_geometry(msh, 0, verts).ravel()].reshape(-1, 3)
        g = np.concatenate(msh.comm.allgather(imap.local_to_global(verts)))
        faces.append(dict(zip(g.tolist(), np.concatenate(msh.comm.allgather(x)).reshape(-1, 3))))
    shared = set(faces[0]) & set(faces[1])
    x = np.array([faces[0][g] for g in shared]).reshape(-1, 3)
    return x[np.lexsort(x.T[::-1])]


def _meshed(body: BodySurface, crack: Any, size: TipMesh, tags: Any, comm: MPI.Comm) -> Any:
    """:func:`_build` on rank 0 (one crack, or a list) and the mesh distributed; a gmsh
    failure is a :class:`MeshingError` on every rank."""
    error = None
    with gmsh_session("cracked_body3d") if comm.rank == 0 else nullcontext():
        if comm.rank == 0:
            try:
                _build(body, crack, size, tags)
            except Exception as exc:  # reported on every rank below
                error = f"{type(exc).__name__}: {exc}"
        error = comm.bcast(error, root=0)
        if error is not None:
            raise MeshingError(f"cracked 3D body: {error}")
        return model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=3)


def mesh_body_with_planar_crack(
    body: BodySurface,
    crack: PlanarCrack | TriangulatedCrack,
    size: TipMesh,
    comm: MPI.Comm | None = None,
) -> tuple[CrackedBody3D, object]:
    """Mesh a 3D body with a planar crack cut into it (collective; gmsh on rank 0).

    Parameters
    ----------
    body
        The body's boundary (:func:`body_surface` of the scene's mesh).
    crack
        The crack (planar, or a grown :class:`~bonecontact.fracture.crack3d.
        TriangulatedCrack`), inside the body (checked against the cells beforehand:
        :func:`~bonecontact.scene.crack_region.check_crack_region`).
    size
        Element size at the front, its growth per unit distance from the front and the
        largest size (:class:`~bonecontact.fracture.meshing.TipMesh`; ``h_max`` at most
        the body's longest boundary edge).
    comm
        MPI communicator (``None``: ``MPI.COMM_WORLD``).

    Returns
    -------
    (CrackedBody3D, dolfinx.io.gmsh.MeshData)
        The cracked mesh (the crack faces ``crack_upper``, on the side the normal points
        to, and ``crack_lower``) and the mesh data with its physical groups.

    Raises
    ------
    MeshingError
        gmsh failed (on every rank).
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    top = max([body.region[1], *body.names, 0])
    tags = (top + 1, top + 2)  # the crack surface, its second face
    md = _meshed(body, crack, size, tags, comm)
    n = np.asarray(crack.normal, dtype=float)
    a, b = tags
    upper, lower = (a, b) if face_side_sign(md.mesh, md.facet_tags, a, n) > 0 else (b, a)
    cb = CrackedBody3D(
        md.mesh, md.cell_tags, md.facet_tags, crack, {"crack_upper": upper, "crack_lower": lower}
    )
    return cb, md


def mesh_body_with_planar_cracks(
    body: BodySurface,
    cracks: list[PlanarCrack],
    size: TipMesh,
    comm: MPI.Comm | None = None,
) -> tuple[list[CrackedBody3D], object]:
    """Mesh a 3D body with several planar cracks cut into it (collective; gmsh on rank
    0), graded from all the fronts, each crack split into its own two faces (as
    :func:`mesh_body_with_planar_crack`; the cracks must not meet, which the scene reader
    checks).

    Returns
    -------
    (list of CrackedBody3D, dolfinx.io.gmsh.MeshData)
        One view of the mesh per crack (the same mesh and markers; that crack and its
        ``crack_upper``/``crack_lower`` tags) and the mesh data (groups ``crack<i>_a``,
        ``crack<i>_b``).

    Raises
    ------
    MeshingError
        gmsh failed (on every rank).
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    top = max([body.region[1], *body.names, 0])
    tags = [(top + 1 + 2 * i, top + 2 + 2 * i) for i in range(len(cracks))]
    md = _meshed(body, list(cracks), size, tags, comm)
    views = []
    for crack, (a, b) in zip(cracks, tags, strict=True):
        n = np.asarray(crack.normal, dtype=float)
        upper, lower = (a, b) if face_side_sign(md.mesh, md.facet_tags, a, n) > 0 else (b, a)
        groups = {"crack_upper": upper, "crack_lower": lower}
        views.append(CrackedBody3D(md.mesh, md.cell_tags, md.facet_tags, crack, groups))
    return views, md
