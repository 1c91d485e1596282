"""The host mechanics mesh rebuilt around a neoplasm by gmsh (2D; coupled runs).

:func:`build_host_mesh` recovers the geometry of a scene's mesh from its cell groups
(:func:`read_host_geometry`; their boundary edges become OCC lines, so every original
boundary and interface is kept exactly), fragments the neoplasm polygon into the body
that holds the ``region``, and classifies the pieces

* inside the neoplasm and in ``region`` or a ``host`` group -> **neoplasm**: a tumour
  keeps the tag/name of ``region``; a cyst is removed, leaving a **cavity**;
* inside the neoplasm but in another group -> that group (the neoplasm grows only
  into ``host``);
* the part of ``region`` the neoplasm no longer covers -> ``host[0]`` (with
  ``host = []`` the neoplasm stays the region);

the neoplasm boundary inside the bone becomes the facet group ``"<region>_wall"``
(:func:`wall_name`); every facet group keeps its name and tag (split where the neoplasm
crosses it; removed where a cyst has eaten it).  gmsh runs on rank 0; the mesh is
distributed from its open model (:func:`distribute_host_mesh`, no file read back) and
the numbers broadcast.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from mpi4py import MPI

import gmsh
import numpy as np
import numpy.typing as npt
from dolfinx.io.gmsh import model_to_mesh
from scipy.spatial import cKDTree

from bonecontact.common.errors import RunError
from bonecontact.common.geometry import cross2, signed_polygon_area
from bonecontact.meshing.session import gmsh_session

__all__ = [
    "CouplingError",
    "HostGeometry",
    "HostMesh",
    "build_host_mesh",
    "distribute_host_mesh",
    "neoplasm_polygon",
    "read_host_geometry",
    "wall_name",
]


class CouplingError(RunError):
    """The host mesh cannot be rebuilt around the neoplasm."""


def wall_name(region: str) -> str:
    """Name of the facet group on the neoplasm boundary: ``"<region>_wall"``."""
    return f"{region}_wall"


# ----------------------------------------------------------------------------- scene geometry
@dataclass
class HostGeometry:
    """The scene's 2D mesh as plain arrays (rank 0 only).

    Parameters
    ----------
    x
        ``(n, 2)`` node coordinates (m).
    cells
        Cell group name -> ``(tag, triangles)``; triangles ``(m, 3)`` node indices,
        counter-clockwise.
    facets
        Facet group name -> ``(tag, edges)``; edges ``(k, 2)`` node indices.
    """

    x: npt.NDArray[np.float64]
    cells: dict[str, tuple[int, npt.NDArray[np.int64]]]
    facets: dict[str, tuple[int, npt.NDArray[np.int64]]] = field(default_factory=dict)

    def node_size(self) -> npt.NDArray[np.float64]:
        """Local mesh size at each node: mean length of the triangle edges touching it."""
        tris = np.concatenate([t for _, t in self.cells.values()])
        e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
        ln = np.linalg.norm(self.x[e[:, 1]] - self.x[e[:, 0]], axis=1)
        s = np.bincount(e.ravel(), weights=np.repeat(ln, 2), minlength=len(self.x))
        c = np.bincount(e.ravel(), minlength=len(self.x))
        return np.where(c > 0, s / np.maximum(c, 1), np.nan)

    def centroid(self, group: str) -> npt.NDArray[np.float64]:
        """Area centroid of a cell group."""
        t = self.cells[group][1]
        p = self.x[t]
        a = 0.5 * np.abs(cross2(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]))
        return (a[:, None] * p.mean(axis=1)).sum(axis=0) / a.sum()

    def area(self, group: str) -> float:
        """Area of a cell group (m²)."""
        p = self.x[self.cells[group][1]]
        return float(0.5 * np.abs(cross2(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])).sum())


#: gmsh element types of the coupled host meshes: cell dimension -> (cells, facets), each
#: (gmsh type, nodes per element, name).
_HOST_ELEMENTS = {
    2: ((2, 3, "linear triangles"), (1, 2, "2-node lines")),
    3: ((4, 4, "linear tetrahedra"), (2, 3, "3-node triangles")),
}


def read_gmsh_groups(
    path: str | Path, tdim: int
) -> tuple[
    npt.NDArray[np.float64],
    dict[str, tuple[int, npt.NDArray[np.int64]]],
    dict[str, tuple[int, npt.NDArray[np.int64]]],
]:
    """Read a gmsh file's nodes and its named cell and facet groups; serial.

    Parameters
    ----------
    path
        The gmsh file.
    tdim
        2 (triangles and lines, coordinates x, y) or 3 (tetrahedra and triangles).

    Returns
    -------
    x, cells, facets
        ``(N, tdim)`` node coordinates, and per group name its physical tag and
        connectivity (rows of node indices into ``x``).

    Raises
    ------
    CouplingError
        A group holds other elements than the linear ones of ``tdim``.
    """
    (cell_type, cell_nodes, cell_name), (facet_type, facet_nodes, facet_name) = _HOST_ELEMENTS[tdim]
    with gmsh_session("bonecontact-host-read"):
        gmsh.merge(str(path))
        tags, coords, _ = gmsh.model.mesh.getNodes()
        index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        x = coords.reshape(-1, 3)[:, :tdim].copy()
        cells: dict[str, tuple[int, npt.NDArray[np.int64]]] = {}
        facets: dict[str, tuple[int, npt.NDArray[np.int64]]] = {}
        for dim, ptag in gmsh.model.getPhysicalGroups():
            if dim not in (tdim - 1, tdim):
                continue
            name = gmsh.model.getPhysicalName(dim, ptag) or str(ptag)
            want, nn = (cell_type, cell_nodes) if dim == tdim else (facet_type, facet_nodes)
            conn = []
            for ent in gmsh.model.getEntitiesForPhysicalGroup(dim, ptag):
                types, _, ntags = gmsh.model.mesh.getElements(dim, int(ent))
                for t, nt in zip(types, ntags):
                    if t != want:
                        raise CouplingError(
                            f'physical group "{name}" holds gmsh elements of type {t}; the '
                            f"coupled {tdim}D host mesh needs {cell_name} and {facet_name}"
                        )
                    conn.append(index[np.asarray(nt, dtype=np.int64)].reshape(-1, nn))
            arr = np.concatenate(conn) if conn else np.zeros((0, nn), dtype=np.int64)
            (cells if dim == tdim else facets)[name] = (int(ptag), arr)
    return x, cells, facets


def read_host_geometry(path: str | Path) -> HostGeometry:
    """Read a 2D gmsh file (linear triangles and lines in named physical groups); serial.

    Raises
    ------
    CouplingError
        Not 2D, or other elements than 3-node triangles / 2-node lines in a group.
    """
    x, cells, facets = read_gmsh_groups(path, 2)
    if not cells:
        raise CouplingError(f"{path}: no 2D cell groups")
    for _name, (_tag, t) in cells.items():  # counter-clockwise triangles
        p = x[t]
        neg = cross2(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]) < 0
        t[neg] = t[neg][:, [0, 2, 1]]
    return HostGeometry(x, cells, facets)


def _boundary_loops(tris: npt.NDArray[np.int64]) -> list[list[int]]:
    """Closed node loops of the boundary of a set of ccw triangles (ccw outer, cw holes)."""
    e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    fwd = {(int(a), int(b)) for a, b in e}
    bnd = [(a, b) for a, b in fwd if (b, a) not in fwd]
    nxt: dict[int, list[int]] = {}
    for a, b in bnd:
        nxt.setdefault(a, []).append(b)
    loops, used = [], set()
    for a0, b0 in sorted(bnd):
        if (a0, b0) in used:
            continue
        loop, a, b = [a0], a0, b0
        while True:
            used.add((a, b))
            if b == a0:
                break
            loop.append(b)
            cand = [c for c in nxt[b] if (b, c) not in used]
            if not cand:
                raise CouplingError("a cell group's boundary is not made of closed loops")
            a, b = b, cand[0]
        loops.append(loop)
    return loops


def _inside(poly: npt.NDArray[np.float64], pts: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
    """Even-odd point-in-polygon test."""
    x, y = pts[:, 0][:, None], pts[:, 1][:, None]
    a, b = poly[None, :, :], np.roll(poly, -1, axis=0)[None, :, :]
    cross = (a[..., 1] > y) != (b[..., 1] > y)
    xi = a[..., 0] + (y - a[..., 1]) * (b[..., 0] - a[..., 0]) / np.where(
        b[..., 1] == a[..., 1], 1.0, b[..., 1] - a[..., 1]
    )
    return (np.count_nonzero(cross & (x < xi), axis=1) % 2) == 1


def _bodies(geo: HostGeometry) -> dict[str, int]:
    """Cell group -> body id (groups sharing a node are one body)."""
    names = list(geo.cells)
    parent = list(range(len(names)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    nodes = [set(np.unique(geo.cells[n][1]).tolist()) for n in names]
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            if nodes[i] & nodes[j]:
                parent[find(i)] = find(j)
    return {n: find(i) for i, n in enumerate(names)}


def neoplasm_polygon(center: npt.ArrayLike, radius: float, h: float) -> npt.NDArray[np.float64]:
    """Regular polygon (ccw) approximating a circle, spacing about ``h`` (at least 32 sides)."""
    n = max(32, int(math.ceil(2 * math.pi * radius / h)))
    th = 2 * math.pi * np.arange(n) / n
    c = np.asarray(center, dtype=np.float64)
    return np.column_stack([c[0] + radius * np.cos(th), c[1] + radius * np.sin(th)])


@dataclass
class HostMesh:
    """What :func:`build_host_mesh` built (rank 0's numbers, broadcast) and the mesh.

    Parameters
    ----------
    path
        The gmsh file written for the user (``None``: none written); nothing reads it.
    cell_groups, facet_groups
        Names of the non-empty groups of the new mesh.
    neoplasm_area
        Area (m²) of the neoplasm inside the bone: the tumour cells, or the cavity.
    wall
        Name of the wall facet group, ``None`` when the neoplasm has no boundary in the bone.
    cells
        Number of triangles.
    mesh_data
        The distributed mesh with its cell and facet tags
        (:class:`dolfinx.io.gmsh.MeshData`, every rank; ``None`` before
        :func:`distribute_host_mesh`).
    groups
        Physical-group name -> ``(dim, tag)`` of ``mesh_data``.
    """

    path: Path | None
    cell_groups: tuple[str, ...]
    facet_groups: tuple[str, ...]
    neoplasm_area: float
    wall: str | None
    cells: int
    mesh_data: Any = None
    groups: dict[str, tuple[int, int]] = field(default_factory=dict)


@dataclass
class _HostBuild:
    """The state of one host-mesh build in the gmsh model (rank 0)."""

    geo: HostGeometry
    region: str
    host: tuple[str, ...]
    cavity: bool
    h_neo: float
    poly: npt.NDArray[np.float64]
    size: npt.NDArray[np.float64]
    bodies: dict[str, int]
    points: dict[int, int] = field(default_factory=dict)
    lines: dict[tuple[int, int], int] = field(default_factory=dict)
    surf_group: dict[int, str] = field(default_factory=dict)
    group_of: dict[int, str] = field(default_factory=dict)
    neo_pieces: list[int] = field(default_factory=list)
    outside: list[int] = field(default_factory=list)
    kept: list[int] = field(default_factory=list)
    wall: list[int] = field(default_factory=list)
    used_c: set[int] = field(default_factory=set)
    groups: dict[str, list[int]] = field(default_factory=dict)

    def point(self, i: int) -> int:
        if i not in self.points:
            self.points[i] = gmsh.model.occ.addPoint(
                self.geo.x[i, 0], self.geo.x[i, 1], 0.0, float(self.size[i])
            )
        return self.points[i]

    def line(self, a: int, b: int) -> int:
        """The OCC line a-b, signed by the direction of travel (OCC wires need it)."""
        key = (min(a, b), max(a, b))
        if key not in self.lines:
            self.lines[key] = gmsh.model.occ.addLine(self.point(key[0]), self.point(key[1]))
        return self.lines[key] if a < b else -self.lines[key]


def _build_host_serial(
    geo: HostGeometry,
    region: str,
    host: tuple[str, ...],
    polygon: npt.NDArray[np.float64],
    cavity: bool,
    h_neo: float,
    path: Path | None,
) -> HostMesh:
    if region not in geo.cells:
        raise CouplingError(f'the mesh has no cell group "{region}"')
    # rounded to 0.1 nm: the polygon comes from reductions whose round-off differs with
    # the number of ranks, and gmsh's mesh is not continuous in its input (1e-15 changes
    # of the radius gave a different mesh on 2 ranks)
    poly = np.round(np.asarray(polygon, dtype=np.float64), 10)
    if signed_polygon_area(poly) < 0:
        poly = poly[::-1]
    hb = _HostBuild(geo, region, host, cavity, h_neo, poly, geo.node_size(), _bodies(geo))
    _add_cell_group_surfaces(hb)
    neo = _add_neoplasm_surface(hb)
    _fragment_and_classify(hb, neo)
    gmsh.model.occ.synchronize()
    neo_area = sum(gmsh.model.occ.getMass(2, p) for p in hb.neo_pieces)
    _remove_unused_entities(hb)
    _set_point_sizes(hb)
    _add_cell_groups(hb)
    facet_names = _add_facet_groups(hb)
    wname = _add_wall_group(hb, facet_names)
    gmsh.model.mesh.generate(2)
    ncells = sum(len(gmsh.model.mesh.getElements(2, s)[1][0]) for s in hb.kept)
    write_result_mesh(path)
    return HostMesh(
        path, tuple(sorted(hb.groups)), tuple(facet_names), float(neo_area), wname, int(ncells)
    )


def write_result_mesh(path: Path | None) -> None:
    """Write the open gmsh model's mesh to ``path`` for the user (rank 0; ``None``: not)."""
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        gmsh.write(str(path))


def _add_cell_group_surfaces(hb: _HostBuild) -> None:
    """One OCC plane surface per outer boundary loop of each cell group (its holes cut out)."""
    occ = gmsh.model.occ
    geo = hb.geo
    for name, (_, tris) in geo.cells.items():
        loops = _boundary_loops(tris)
        polys = [geo.x[lp] for lp in loops]
        areas = [signed_polygon_area(p) for p in polys]
        outer = [k for k, a in enumerate(areas) if a > 0]
        holes: dict[int, list[int]] = {k: [] for k in outer}
        for k, a in enumerate(areas):
            if a > 0:
                continue
            probe = 0.5 * (polys[k][0] + polys[k][1])[None, :]
            inside = [j for j in outer if _inside(polys[j], probe)[0]]
            if not inside:
                raise CouplingError(f'cell group "{name}": a hole outside every outer boundary')
            holes[min(inside, key=lambda j: areas[j])].append(k)
        for k in outer:
            # gmsh's OCC wants every loop counter-clockwise (it reverses the holes itself)
            wires = []
            for lp in [loops[k]] + [loops[j][::-1] for j in holes[k]]:
                wires.append(
                    occ.addCurveLoop(
                        [hb.line(lp[i], lp[(i + 1) % len(lp)]) for i in range(len(lp))]
                    )
                )
            hb.surf_group[occ.addPlaneSurface(wires)] = name


def _add_neoplasm_surface(hb: _HostBuild) -> int:
    """The neoplasm polygon as an OCC plane surface."""
    occ = gmsh.model.occ
    ptags = [occ.addPoint(px, py, 0.0, hb.h_neo) for px, py in hb.poly]
    n = len(ptags)
    nl = [occ.addLine(ptags[i], ptags[(i + 1) % n]) for i in range(n)]
    return occ.addPlaneSurface([occ.addCurveLoop(nl)])


def _fragment_and_classify(hb: _HostBuild, neo: int) -> None:
    """Fragment the region's body by the neoplasm; sort the pieces into neoplasm, outside,
    groups."""
    occ = gmsh.model.occ
    bodies, region, host = hb.bodies, hb.region, hb.host
    grow = {region, *host}
    body = bodies[region]
    objects = [(2, s) for s, g in hb.surf_group.items() if bodies[g] == body]
    _, out_map = occ.fragment(objects, [(2, neo)])
    inside = {t for d, t in out_map[-1] if d == 2}
    origin: dict[int, str] = {}
    for (_d, s), pieces in zip(objects, out_map[:-1]):
        for _, p in pieces:
            origin[p] = hb.surf_group[s]
    hb.group_of = {s: g for s, g in hb.surf_group.items() if bodies[g] != body}
    for p in set(origin) | inside:
        g = origin.get(p)
        if g is None:  # neoplasm outside the bone: not part of the mechanics
            hb.outside.append(p)
        elif p in inside and g in grow:
            hb.neo_pieces.append(p)
        elif p not in inside and g == region and host:
            hb.group_of[p] = host[0]
        else:
            hb.group_of[p] = g
    if not hb.neo_pieces:
        raise CouplingError(
            f'the neoplasm does not overlap the region "{region}" or its host groups'
        )


def _boundary_curves(surfs: list[int]) -> set[int]:
    if not surfs:
        return set()
    return {
        abs(t)
        for _, t in gmsh.model.getBoundary([(2, s) for s in surfs], combined=False, oriented=False)
    }


def _remove_unused_entities(hb: _HostBuild) -> None:
    """Drop the neoplasm outside the bone (and a cyst's cavity), then stray curves and points."""
    occ = gmsh.model.occ
    hb.kept = list(hb.group_of) + ([] if hb.cavity else hb.neo_pieces)
    hb.wall = sorted(_boundary_curves(hb.neo_pieces) & _boundary_curves(list(hb.group_of)))
    drop = hb.outside + (hb.neo_pieces if hb.cavity else [])
    if drop:
        occ.remove([(2, s) for s in drop])
    occ.synchronize()
    hb.used_c = _boundary_curves(hb.kept)
    stray_c = [(1, c) for _, c in gmsh.model.getEntities(1) if c not in hb.used_c]
    if stray_c:
        occ.remove(stray_c)
        occ.synchronize()
    used_p = {
        abs(t)
        for _, t in gmsh.model.getBoundary(
            [(1, c) for c in hb.used_c], combined=False, oriented=False
        )
    }
    stray_p = [(0, p) for _, p in gmsh.model.getEntities(0) if p not in used_p]
    if stray_p:
        occ.remove(stray_p)
        occ.synchronize()


def _set_point_sizes(hb: _HostBuild) -> None:
    """Sizes: the original local size at each point, the neoplasm spacing on its boundary."""
    geo = hb.geo
    bnodes = np.unique(np.concatenate([lk for lk in hb.lines]))
    src = np.vstack([geo.x[bnodes], hb.poly])
    hs = np.concatenate([hb.size[bnodes], np.full(len(hb.poly), hb.h_neo)])
    tree = cKDTree(src)
    for _, p in gmsh.model.getEntities(0):
        xyz = gmsh.model.getValue(0, p, [])
        _, j = tree.query(xyz[:2])
        gmsh.model.mesh.setSize([(0, p)], float(hs[j]))
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
    gmsh.option.setNumber("Mesh.Algorithm", 6)


def _add_cell_groups(hb: _HostBuild) -> None:
    """Physical groups: original names and tags (a tumour's pieces join its region)."""
    for s, g in hb.group_of.items():
        hb.groups.setdefault(g, []).append(s)
    if not hb.cavity:
        hb.groups.setdefault(hb.region, []).extend(hb.neo_pieces)
    for g, surfs in hb.groups.items():
        gmsh.model.addPhysicalGroup(2, sorted(surfs), hb.geo.cells[g][0], name=g)


def _add_facet_groups(hb: _HostBuild) -> list[str]:
    """Facet groups: a kept curve belongs to a group if its midpoint lies on one of its edges."""
    geo, bodies = hb.geo, hb.bodies
    mids = {}
    for c in sorted(hb.used_c):
        a, b = gmsh.model.getParametrizationBounds(1, c)
        mids[c] = np.asarray(gmsh.model.getValue(1, c, [0.5 * (a[0] + b[0])]))[:2]
    facet_names = []
    # the body of every kept curve (from the surfaces it bounds) and of every facet
    # group (from the cell group holding its first edge): bodies that touch (contact
    # pairs with zero gap) must not take each other's curves
    surf_body = {p: bodies[g] for p, g in hb.group_of.items()}
    if not hb.cavity:
        surf_body.update({p: bodies[hb.region] for p in hb.neo_pieces})
    curve_body = {}
    for c in mids:
        up, _ = gmsh.model.getAdjacencies(1, c)
        bs = {surf_body[int(u)] for u in up if int(u) in surf_body}
        curve_body[c] = bs.pop() if len(bs) == 1 else None
    cell_nodes = {n: set(np.unique(t).tolist()) for n, (_, t) in geo.cells.items()}
    for g, (tag, edges) in geo.facets.items():
        if not len(edges):
            continue
        owner = next(
            (bodies[n] for n, nodes in cell_nodes.items() if int(edges[0, 0]) in nodes), None
        )
        pa, pb = geo.x[edges[:, 0]], geo.x[edges[:, 1]]
        d = pb - pa
        ll = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
        tol = 1e-6 * np.sqrt(ll)
        members = []
        for c, m in mids.items():
            if owner is not None and curve_body.get(c) not in (None, owner):
                continue
            s = np.clip(np.einsum("ij,ij->i", m - pa, d) / ll, 0.0, 1.0)
            dist = np.linalg.norm(pa + s[:, None] * d - m, axis=1)
            if np.any(dist < tol):
                members.append(c)
        if members:
            gmsh.model.addPhysicalGroup(1, members, tag, name=g)
            facet_names.append(g)
    return facet_names


def _add_wall_group(hb: _HostBuild, facet_names: list[str]) -> str | None:
    """The neoplasm boundary inside the bone as ``"<region>_wall"`` with a new tag (``None``: no
    wall)."""
    geo = hb.geo
    wall = [c for c in hb.wall if c in hb.used_c]
    if not wall:
        return None
    wname = wall_name(hb.region)
    used_tags = [t for t, _ in geo.cells.values()] + [t for t, _ in geo.facets.values()]
    gmsh.model.addPhysicalGroup(1, wall, max(used_tags) + 1, name=wname)
    facet_names.append(wname)
    return wname


def build_host_mesh(
    geo: HostGeometry | None,
    region: str,
    host: tuple[str, ...],
    polygon: npt.ArrayLike | None,
    cavity: bool,
    h_neo: float,
    path: Path | None,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> HostMesh:
    """Rebuild the host mesh with the neoplasm polygon embedded (gmsh on rank 0; collective).

    Parameters
    ----------
    geo
        The scene's mesh (:func:`read_host_geometry`); used on rank 0 only.
    region, host
        ``[neoplasm] region`` and ``host``.
    polygon
        ``(N, 2)`` neoplasm boundary, closed (last point not repeated); rank 0's is used.
    cavity
        ``True`` for a cyst: the neoplasm cells are removed.
    h_neo
        Mesh size on the neoplasm boundary (m).
    path
        Where rank 0 writes the gmsh file for the user (``None``: none); nothing reads it.

    Returns
    -------
    HostMesh
        The same numbers on every rank, with the distributed mesh and its groups
        (``mesh_data``, ``groups``; :func:`distribute_host_mesh`).

    Raises
    ------
    CouplingError
        On every rank, when gmsh fails or the neoplasm does not overlap the region/hosts.
    """
    with gmsh_session("bonecontact-host") if comm.rank == 0 else nullcontext():
        hm = build_on_rank0(
            lambda: _build_host_serial(geo, region, host, np.asarray(polygon), cavity, h_neo, path),
            "rebuild the host mesh around the neoplasm",
            comm,
        )
        return distribute_host_mesh(hm, 2, comm)


def distribute_host_mesh(hm: HostMesh, gdim: int, comm: MPI.Comm) -> HostMesh:
    """``hm`` with the mesh of rank 0's open gmsh model distributed over ``comm``
    (:func:`dolfinx.io.gmsh.model_to_mesh`, the cell and facet tags of its physical
    groups; collective, inside rank 0's gmsh session).  The same mesh as reading the
    written file back gives, without the file."""
    md = model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=gdim)
    groups = {name: (int(pg.dim), int(pg.tag)) for name, pg in md.physical_groups.items()}
    return replace(hm, mesh_data=md, groups=groups)


def build_on_rank0(build: Callable[[], HostMesh], what: str, comm: MPI.Comm) -> HostMesh:
    """Run a serial gmsh build on rank 0 and give its result, or its error, to every rank.

    Parameters
    ----------
    build
        The build, called on rank 0 only.
    what
        What it does, for the message of an unexpected exception ("rebuild the host mesh").
    comm
        The communicator; collective.

    Returns
    -------
    HostMesh
        Rank 0's result, on every rank.

    Raises
    ------
    CouplingError
        On every rank: the build's own :class:`CouplingError` message as it is, any other
        exception as "cannot <what>: <type>: <message>" (so no rank waits for another).
    """
    res, err = None, None
    if comm.rank == 0:
        try:
            res = build()
        except CouplingError as exc:
            err = str(exc)
        except Exception as exc:  # reported on every rank
            err = f"cannot {what}: {type(exc).__name__}: {exc}"
    res, err = comm.bcast((res, err), root=0)
    if err is not None:
        raise CouplingError(err)
    return res
