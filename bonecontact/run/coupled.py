"""Neoplasm growth coupled to the loaded bone (issue #5, SPEC §6; 2D).

A *coupled* scene has ``[neoplasm]`` **and** ``[analysis]`` (``docs/neoplasm_format.md``).
:func:`run_coupled` (called by :func:`bonecontact.run.dispatch.run_scene`) runs it:

1. the growth model of :func:`bonecontact.run.growth.build_growth` (tumour: Problem P_T on its
   own gmsh-remeshed mesh; cyst: the cylinder ODE of :mod:`bonecontact.neoplasm.cyst`) advances
   step by step and writes ``growth.csv`` as a growth-only run does;
2. every ``mechanics_every`` growth steps (``0``: once, after the growth) the **host
   mechanics mesh is rebuilt by gmsh** with the current neoplasm boundary embedded
   (:func:`build_host_mesh`): the geometry of the scene's mesh is recovered from its
   cell groups (their boundary edges become OCC lines, so every original boundary and
   interface is kept exactly), the neoplasm polygon is fragmented into the body that
   holds the ``region``, and the pieces are classified

   * inside the neoplasm and in ``region`` or a ``host`` group -> **neoplasm**: a tumour
     keeps the tag/name of ``region`` and takes its ``[[material]]`` (near-fluid tissue,
     use ``formulation = "nodal_pressure"``); a cyst is removed, leaving a **cavity**;
   * inside the neoplasm but in another group -> that group (the neoplasm grows only
     into ``host``);
   * the part of ``region`` the neoplasm no longer covers -> ``host[0]`` (with
     ``host = []`` the neoplasm stays the region);

   the neoplasm boundary inside the bone becomes the facet group ``"<region>_wall"``;
   every facet group of the scene keeps its name and tag (split where the neoplasm
   crosses it; removed where a cyst has eaten it);
3. the scene's ``[analysis]`` runs on that mesh (:func:`bonecontact.run.dispatch.run_scene`,
   all loads, supports, contacts and probes of the scene).  A cyst adds the load
   ``[[pressure]] boundary = "<region>_wall"`` with value f = P_h⁺ − P_h⁻, the osmotic
   excess pressure of the lumen at that time (the hydrostatic pressure P_h⁻ of the
   surrounding tissue is the reference, zero, state of the mechanics); in a static
   analysis it ramps with the pseudo-time like the scene's own loads, otherwise it is
   constant.

Results: ``growth.csv`` in the output directory; the last analysis (after the growth)
writes the usual mechanics results into the output directory itself, earlier ones into
``mechanics_<step>/``; each analysis directory also holds ``host_mesh.msh`` (the rebuilt
mesh) and ``neoplasm_boundary.csv`` (the polygon embedded).  ``summary.json`` is the
final analysis's summary plus ``growth`` (as a growth-only run) and ``coupling`` (one
record per analysis).

The growth does not feel the mechanics (one-way coupling): the cyst ODE has its own
Maxwell surrounding, the tumour its own pressure.  The rebuilt mesh is a fresh
reference configuration (no stress is carried over from an earlier analysis).
"""

from __future__ import annotations

import csv
import json
import math
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from bonecontact.scene.spec import LoadSpec, Scene, SceneError, Schedule

__all__ = ["HostGeometry", "HostMesh", "read_host_geometry", "neoplasm_polygon", "build_host_mesh",
           "mechanics_scene", "check_coupled", "run_coupled", "wall_name"]


class CouplingError(RuntimeError):
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
        a = 0.5 * np.abs(_cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]))
        return (a[:, None] * p.mean(axis=1)).sum(axis=0) / a.sum()

    def area(self, group: str) -> float:
        """Area of a cell group (m²)."""
        p = self.x[self.cells[group][1]]
        return float(0.5 * np.abs(_cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])).sum())


def read_host_geometry(path: str | Path) -> HostGeometry:
    """Read a 2D gmsh file (linear triangles and lines in named physical groups); serial.

    Raises
    ------
    CouplingError
        Not 2D, or other elements than 3-node triangles / 2-node lines in a group.
    """
    import gmsh

    own = not gmsh.isInitialized()
    if own:
        gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("bonecontact-host-read")
    try:
        gmsh.merge(str(path))
        tags, coords, _ = gmsh.model.mesh.getNodes()
        index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        x = coords.reshape(-1, 3)[:, :2].copy()
        cells: dict[str, tuple[int, npt.NDArray[np.int64]]] = {}
        facets: dict[str, tuple[int, npt.NDArray[np.int64]]] = {}
        for dim, ptag in gmsh.model.getPhysicalGroups():
            if dim not in (1, 2):
                continue
            name = gmsh.model.getPhysicalName(dim, ptag) or str(ptag)
            want, nn = (2, 3) if dim == 2 else (1, 2)
            conn = []
            for ent in gmsh.model.getEntitiesForPhysicalGroup(dim, ptag):
                types, _, ntags = gmsh.model.mesh.getElements(dim, int(ent))
                for t, nt in zip(types, ntags):
                    if t != want:
                        raise CouplingError(f'physical group "{name}" holds gmsh elements of type {t}; the '
                                            "coupled host mesh needs linear triangles and 2-node lines")
                    conn.append(index[np.asarray(nt, dtype=np.int64)].reshape(-1, nn))
            arr = np.concatenate(conn) if conn else np.zeros((0, nn), dtype=np.int64)
            (cells if dim == 2 else facets)[name] = (int(ptag), arr)
    finally:
        if own:
            gmsh.finalize()
        else:
            gmsh.model.remove()
    if not cells:
        raise CouplingError(f"{path}: no 2D cell groups")
    for name, (tag, t) in cells.items():  # counter-clockwise triangles
        p = x[t]
        neg = _cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]) < 0
        t[neg] = t[neg][:, [0, 2, 1]]
    return HostGeometry(x, cells, facets)


def _cross(a: npt.NDArray[np.float64], b: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """z-component of the cross product of 2D vectors."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


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


def _signed_area(p: npt.NDArray[np.float64]) -> float:
    q = np.roll(p, -1, axis=0)
    return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))


def _inside(poly: npt.NDArray[np.float64], pts: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
    """Even-odd point-in-polygon test."""
    x, y = pts[:, 0][:, None], pts[:, 1][:, None]
    a, b = poly[None, :, :], np.roll(poly, -1, axis=0)[None, :, :]
    cross = (a[..., 1] > y) != (b[..., 1] > y)
    xi = a[..., 0] + (y - a[..., 1]) * (b[..., 0] - a[..., 0]) / np.where(b[..., 1] == a[..., 1], 1.0,
                                                                          b[..., 1] - a[..., 1])
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
    """What :func:`build_host_mesh` built (rank 0's numbers, broadcast).

    Parameters
    ----------
    path
        The written gmsh file (``None`` if only checked).
    cell_groups, facet_groups
        Names of the non-empty groups of the new mesh.
    neoplasm_area
        Area (m²) of the neoplasm inside the bone: the tumour cells, or the cavity.
    wall
        Name of the wall facet group, ``None`` when the neoplasm has no boundary in the bone.
    cells
        Number of triangles.
    """

    path: Path | None
    cell_groups: tuple[str, ...]
    facet_groups: tuple[str, ...]
    neoplasm_area: float
    wall: str | None
    cells: int


def _build_host_serial(geo: HostGeometry, region: str, host: tuple[str, ...], polygon: npt.NDArray[np.float64],
                       cavity: bool, h_neo: float, path: Path | None) -> HostMesh:
    import gmsh
    from scipy.spatial import cKDTree

    if region not in geo.cells:
        raise CouplingError(f'the mesh has no cell group "{region}"')
    # rounded to 0.1 nm: the polygon comes from reductions whose round-off differs with
    # the number of ranks, and gmsh's mesh is not continuous in its input (1e-15 changes
    # of the radius gave a different mesh on 2 ranks)
    poly = np.round(np.asarray(polygon, dtype=np.float64), 10)
    if _signed_area(poly) < 0:
        poly = poly[::-1]
    size = geo.node_size()
    bodies = _bodies(geo)
    grow = {region, *host}
    own = not gmsh.isInitialized()
    if own:
        gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("bonecontact-host")
    occ = gmsh.model.occ
    try:
        points: dict[int, int] = {}
        lines: dict[tuple[int, int], int] = {}

        def point(i: int) -> int:
            if i not in points:
                points[i] = occ.addPoint(geo.x[i, 0], geo.x[i, 1], 0.0, float(size[i]))
            return points[i]

        def line(a: int, b: int) -> int:
            """The OCC line a-b, signed by the direction of travel (OCC wires need it)."""
            key = (min(a, b), max(a, b))
            if key not in lines:
                lines[key] = occ.addLine(point(key[0]), point(key[1]))
            return lines[key] if a < b else -lines[key]

        surf_group: dict[int, str] = {}
        for name, (_, tris) in geo.cells.items():
            loops = _boundary_loops(tris)
            polys = [geo.x[lp] for lp in loops]
            areas = [_signed_area(p) for p in polys]
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
                wires = []  # gmsh's OCC wants every loop counter-clockwise (it reverses the holes itself)
                for lp in [loops[k]] + [loops[j][::-1] for j in holes[k]]:
                    wires.append(occ.addCurveLoop([line(lp[i], lp[(i + 1) % len(lp)]) for i in range(len(lp))]))
                surf_group[occ.addPlaneSurface(wires)] = name
        # the neoplasm polygon
        ptags = [occ.addPoint(px, py, 0.0, h_neo) for px, py in poly]
        n = len(ptags)
        nl = [occ.addLine(ptags[i], ptags[(i + 1) % n]) for i in range(n)]
        neo = occ.addPlaneSurface([occ.addCurveLoop(nl)])
        body = bodies[region]
        objects = [(2, s) for s, g in surf_group.items() if bodies[g] == body]
        _, out_map = occ.fragment(objects, [(2, neo)])
        inside = {t for d, t in out_map[-1] if d == 2}
        origin: dict[int, str] = {}
        for (d, s), pieces in zip(objects, out_map[:-1]):
            for _, p in pieces:
                origin[p] = surf_group[s]
        group_of: dict[int, str] = {s: g for s, g in surf_group.items() if bodies[g] != body}
        neo_pieces, outside = [], []
        for p in set(origin) | inside:
            g = origin.get(p)
            if g is None:  # neoplasm outside the bone: not part of the mechanics
                outside.append(p)
            elif p in inside and g in grow:
                neo_pieces.append(p)
            elif p not in inside and g == region and host:
                group_of[p] = host[0]
            else:
                group_of[p] = g
        if not neo_pieces:
            raise CouplingError(f'the neoplasm does not overlap the region "{region}" or its host groups')
        occ.synchronize()
        neo_area = sum(occ.getMass(2, p) for p in neo_pieces)

        def bnd(surfs: list[int]) -> set[int]:
            if not surfs:
                return set()
            return {abs(t) for _, t in gmsh.model.getBoundary([(2, s) for s in surfs], combined=False,
                                                              oriented=False)}

        kept = list(group_of) + ([] if cavity else neo_pieces)
        wall = sorted(bnd(neo_pieces) & bnd(list(group_of)))
        drop = outside + (neo_pieces if cavity else [])
        if drop:
            occ.remove([(2, s) for s in drop])
        occ.synchronize()
        used_c = bnd(kept)
        stray_c = [(1, c) for _, c in gmsh.model.getEntities(1) if c not in used_c]
        if stray_c:
            occ.remove(stray_c)
            occ.synchronize()
        used_p = {abs(t) for _, t in gmsh.model.getBoundary([(1, c) for c in used_c], combined=False,
                                                            oriented=False)}
        stray_p = [(0, p) for _, p in gmsh.model.getEntities(0) if p not in used_p]
        if stray_p:
            occ.remove(stray_p)
            occ.synchronize()
        # sizes: the original local size at each point, the neoplasm spacing on its boundary
        bnodes = np.unique(np.concatenate([lk for lk in lines]))
        src = np.vstack([geo.x[bnodes], poly])
        hs = np.concatenate([size[bnodes], np.full(len(poly), h_neo)])
        tree = cKDTree(src)
        for _, p in gmsh.model.getEntities(0):
            xyz = gmsh.model.getValue(0, p, [])
            _, j = tree.query(xyz[:2])
            gmsh.model.mesh.setSize([(0, p)], float(hs[j]))
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
        gmsh.option.setNumber("Mesh.Algorithm", 6)
        # physical groups: original names and tags; the wall gets a new tag
        groups: dict[str, list[int]] = {}
        for s, g in group_of.items():
            groups.setdefault(g, []).append(s)
        if not cavity:
            groups.setdefault(region, []).extend(neo_pieces)
        for g, surfs in groups.items():
            gmsh.model.addPhysicalGroup(2, sorted(surfs), geo.cells[g][0], name=g)
        # facet groups: a kept curve belongs to a group if its midpoint lies on one of its edges
        mids = {}
        for c in sorted(used_c):
            a, b = gmsh.model.getParametrizationBounds(1, c)
            mids[c] = np.asarray(gmsh.model.getValue(1, c, [0.5 * (a[0] + b[0])]))[:2]
        facet_names = []
        # the body of every kept curve (from the surfaces it bounds) and of every facet
        # group (from the cell group holding its first edge): bodies that touch (contact
        # pairs with zero gap) must not take each other's curves
        surf_body = {p: bodies[g] for p, g in group_of.items()}
        if not cavity:
            surf_body.update({p: bodies[region] for p in neo_pieces})
        curve_body = {}
        for c in mids:
            up, _ = gmsh.model.getAdjacencies(1, c)
            bs = {surf_body[int(u)] for u in up if int(u) in surf_body}
            curve_body[c] = bs.pop() if len(bs) == 1 else None
        cell_nodes = {n: set(np.unique(t).tolist()) for n, (_, t) in geo.cells.items()}
        for g, (tag, edges) in geo.facets.items():
            if not len(edges):
                continue
            owner = next((bodies[n] for n, nodes in cell_nodes.items() if int(edges[0, 0]) in nodes), None)
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
        wname = None
        wall = [c for c in wall if c in used_c]
        if wall:
            wname = wall_name(region)
            used_tags = [t for t, _ in geo.cells.values()] + [t for t, _ in geo.facets.values()]
            gmsh.model.addPhysicalGroup(1, wall, max(used_tags) + 1, name=wname)
            facet_names.append(wname)
        gmsh.model.mesh.generate(2)
        ncells = sum(len(gmsh.model.mesh.getElements(2, s)[1][0]) for s in kept)
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
            gmsh.write(str(path))
        return HostMesh(path, tuple(sorted(groups)), tuple(facet_names), float(neo_area), wname, int(ncells))
    finally:
        if own:
            gmsh.finalize()
        else:
            gmsh.model.remove()


def build_host_mesh(geo: HostGeometry | None, region: str, host: tuple[str, ...],
                    polygon: npt.ArrayLike | None, cavity: bool, h_neo: float, path: Path | None,
                    comm: MPI.Comm = MPI.COMM_WORLD) -> HostMesh:
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
        Where rank 0 writes the gmsh file (``None``: build and check only).

    Returns
    -------
    HostMesh
        The same on every rank.

    Raises
    ------
    CouplingError
        On every rank, when gmsh fails or the neoplasm does not overlap the region/hosts.
    """
    res, err = None, None
    if comm.rank == 0:
        try:
            res = _build_host_serial(geo, region, host, np.asarray(polygon), cavity, h_neo, path)
        except Exception as exc:  # reported on every rank
            err = f"{type(exc).__name__}: {exc}"
    res, err = comm.bcast((res, err), root=0)
    if err is not None:
        raise CouplingError(f"cannot rebuild the host mesh around the neoplasm: {err}")
    return res


# ----------------------------------------------------------------------------- mechanics scene
def mechanics_scene(scene: Scene, hm: HostMesh, pressure: float | None, output: Path) -> Scene:
    """The scene's mechanics on a rebuilt host mesh: no ``[neoplasm]``, the cyst pressure added.

    Materials keep only the cell groups that still exist; a cyst adds
    ``[[pressure]] boundary = "<region>_wall", value = pressure`` (ramped with the
    pseudo-time in a static analysis like the scene's own loads, else constant).
    """
    assert hm.path is not None and scene.analysis is not None
    present = set(hm.cell_groups)
    materials = tuple(replace(m, regions=tuple(r for r in m.regions if r in present))
                      for m in scene.materials if any(r in present for r in m.regions))
    loads = scene.loads
    if pressure is not None and hm.wall is not None:
        sched = Schedule.from_ramp(1.0) if scene.analysis.kind == "static" else Schedule()
        loads = loads + (LoadSpec(kind="pressure", target=(hm.wall,), value=float(pressure), schedule=sched),)
    return replace(scene, mesh_path=hm.path, neoplasm=None, materials=materials, loads=loads,
                   output=replace(scene.output, directory=output))


# ----------------------------------------------------------------------------- driver
class _Coupled:
    """Growth driver + host geometry + the neoplasm polygon of the current state."""

    def __init__(self, scene: Scene, comm: MPI.Comm):
        from bonecontact.run.growth import build_growth

        neo = scene.neoplasm
        assert neo is not None and neo.region is not None
        self.scene, self.comm, self.neo = scene, comm, neo
        self.driver = build_growth(scene, comm)   # checks the scene against the mesh
        geo, info, err = None, None, None
        if comm.rank == 0:
            try:
                geo = read_host_geometry(scene.mesh_path)
                size = geo.node_size()
                nodes = np.unique(geo.cells[neo.region][1])
                info = (geo.centroid(neo.region), float(np.median(size[nodes])))
            except Exception as exc:
                err = f"{type(exc).__name__}: {exc}"
        info, err = comm.bcast((info, err), root=0)
        if err is not None:
            raise SceneError(str(scene.path), "[scene]", "mesh", f"cannot read the host geometry: {err}")
        self.geo = geo
        self.center, self.h_region = info
        self.cavity = neo.kind == "cyst"

    def polygon(self) -> tuple[npt.NDArray[np.float64], float]:
        """Current neoplasm boundary (ccw) and the mesh size on it (collective)."""
        if self.cavity and hasattr(self.driver, "R"):  # cyst ODE: a circle about the region's centroid
            R = self.driver.R
            h = min(max(self.h_region, 2 * math.pi * R / 256), 2 * math.pi * R / 32)
            return neoplasm_polygon(self.center, R, h), h
        # tumour (or a moving-wall cyst): the current boundary of the growth mesh
        m = self.driver.model
        b = m.boundary()
        h = float(m.h) if hasattr(m, "h") else float(np.mean(np.linalg.norm(np.diff(b.points[:, :2], axis=0), axis=1)))
        return np.asarray(b.points[:, :2]), h

    def pressure(self) -> float | None:
        """Cyst: P_h+ - P_h- now (Pa); tumour: ``None``."""
        if not self.cavity:
            return None
        return float(self.driver.f if hasattr(self.driver, "f") else self.driver.model.f)

    def host_mesh(self, path: Path | None) -> tuple[HostMesh, npt.NDArray[np.float64]]:
        poly, h = self.polygon()
        return build_host_mesh(self.geo, self.neo.region, self.neo.host, poly, self.cavity, h, path,
                               self.comm), poly


def check_coupled(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """Every check of a coupled scene without running it (collective; nothing written).

    Builds the growth model, the host mesh at t = 0 (in a temporary directory) and the
    mechanics model on it.

    Raises
    ------
    SceneError
        On every rank.
    """
    _check(scene, comm, _Coupled(scene, comm))


def _check(scene: Scene, comm: MPI.Comm, cp: _Coupled) -> None:
    from bonecontact.run.dispatch import build_model

    tmp = tempfile.mkdtemp(prefix="bonecontact-host-") if comm.rank == 0 else None
    tmp = Path(comm.bcast(tmp, root=0))
    try:
        try:
            hm, _ = cp.host_mesh(tmp / "host_mesh.msh")
        except CouplingError as exc:
            raise SceneError(str(scene.path), "[neoplasm]", "region", str(exc)) from None
        build_model(mechanics_scene(scene, hm, cp.pressure(), tmp), comm)
    finally:
        comm.barrier()
        if comm.rank == 0:
            import shutil

            shutil.rmtree(tmp, ignore_errors=True)


def run_coupled(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD, output: Path | None = None,
                progress: bool = True):
    """Run a coupled scene: growth, host remeshing and the scene's analysis (collective).

    Returns
    -------
    bonecontact.run.dispatch.RunResult
        The final analysis's result (``status`` ``"failed"`` if the growth or an analysis
        failed; ``summary`` then has the message), with ``summary["growth"]`` and
        ``summary["coupling"]``.
    """
    from tqdm import tqdm

    from bonecontact.run.growth import _fmt
    from bonecontact.run.dispatch import RunResult, run_scene

    t_start = time.perf_counter()
    cp = _Coupled(scene, comm)
    _check(scene, comm, cp)   # SceneError before anything is written
    driver, neo = cp.driver, cp.neo
    outdir = Path(output) if output is not None else scene.output.directory
    times = np.concatenate([[0.0], neo.times()])
    nsteps = len(times) - 1
    every = neo.mechanics_every
    fh = writer = None
    if comm.rank == 0:
        outdir.mkdir(parents=True, exist_ok=True)
        fh = open(outdir / "growth.csv", "w", newline="")
        writer = csv.writer(fh)
        writer.writerow(driver.columns)
    comm.barrier()

    def record(t: float) -> list[float]:
        vals = driver.row()
        if writer is not None:
            writer.writerow([f"{t:.15g}"] + [_fmt(v) for v in vals])
            fh.flush()
        return vals

    analyses: list[dict[str, Any]] = []
    result = None

    def mechanics(step: int, t: float, row: list[float]) -> bool:
        nonlocal result
        final = step == nsteps
        where = outdir if final else outdir / f"mechanics_{step:05d}"
        hm, poly = cp.host_mesh(where / "host_mesh.msh")
        if comm.rank == 0:
            with open(where / "neoplasm_boundary.csv", "w", newline="") as f:
                w = csv.writer(f)
                w.writerow(["x", "y"])
                w.writerows([[_fmt(a), _fmt(b)] for a, b in poly])
        pressure = cp.pressure()
        res = run_scene(mechanics_scene(scene, hm, pressure, where), comm, output=where, progress=False)
        rec = {"growth_step": step, "time": t, "equivalent_radius": row[2], "neoplasm_area_in_bone": hm.neoplasm_area,
               "cells": hm.cells, "status": res.status, "directory": str(where),
               "wall_group": hm.wall, "cavity_pressure_Pa": pressure}
        if "message" in res.summary:
            rec["message"] = res.summary["message"]
        analyses.append(rec)
        result = res
        return res.status == "converged"

    status, message = "converged", None
    first = record(0.0)
    last, t_done = first, 0.0
    bar = tqdm(total=nsteps, desc=scene.name, unit="step", disable=(comm.rank != 0) or not progress,
               dynamic_ncols=True)
    try:
        for k in range(1, nsteps + 1):
            driver.step(float(times[k] - times[k - 1]))
            last, t_done = record(float(times[k])), float(times[k])
            bar.update(1)
            if k == nsteps or (every > 0 and k % every == 0):
                if not mechanics(k, t_done, last):
                    status = "failed"
                    message = f"analysis after growth step {k} (t = {t_done:.6g} s): {analyses[-1].get('message')}"
                    break
    except (RuntimeError, CouplingError) as exc:
        status = "failed"
        message = f"growth step {driver.steps + 1} (t = {times[min(driver.steps + 1, nsteps)]:.6g} s): {exc}"
    finally:
        bar.close()
        if fh is not None:
            fh.close()
    growth = {
        "kind": neo.kind, "dimension": driver.dim, "steps": driver.steps, "steps_planned": nsteps,
        "remeshes": driver.remeshes, "t_end": neo.t_end, "dt": neo.dt, "final_time": t_done,
        "initial_radius": first[2], "final_radius": last[2], "initial_volume": first[0], "final_volume": last[0],
        "final_surface_area": last[1], "geometry": f'cell group "{neo.region}" of {scene.mesh_path.name}',
        "units": {"time": "s", "radius": "m", "volume": "m^2 (area)", "surface_area": "m (perimeter)",
                  "pressure": "Pa"},
        **driver.info(),
    }
    summary: dict[str, Any] = dict(result.summary) if result is not None else {
        "scene": scene.name, "format": 1, "ranks": comm.size, "steps": 0}
    summary["status"] = status
    summary["growth"] = growth
    summary["coupling"] = {
        "mechanics_every": every, "analyses": analyses, "wall_time_s": time.perf_counter() - t_start,
        "model": ("cyst: cavity in the rebuilt host mesh, wall pressure = P_h+ - P_h- (osmotic excess)"
                  if cp.cavity else "tumour: region cells with the region's [[material]] in the rebuilt host mesh"),
        "one_way": "the growth does not feel the mechanics"}
    if message is not None:
        summary["message"] = message
    if comm.rank == 0:
        with open(outdir / "summary.json", "w") as f:
            json.dump(summary, f, indent=2, default=str)
    comm.barrier()
    return RunResult(status, summary, result.integrator if result is not None else None, outdir)
