"""The 3D host mechanics mesh rebuilt around a neoplasm by gmsh (coupled runs).

The 3D counterpart of :mod:`bonecontact.neoplasm.host`, without boolean geometry: the
scene mesh's surfaces go to gmsh as discrete surfaces (kept node for node), the
neoplasm's surface becomes a hole of the body it lies strictly inside (and, for a tumour,
the boundary of a volume of its own), and only the volumes are meshed again
(:func:`build_host_mesh3d`; the mesh is distributed from gmsh's open model, no file read
back).  Method, group names and accuracy: docs/theory/growth.md#coupling-in-3d.
"""

from __future__ import annotations

import math
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path

from mpi4py import MPI

import gmsh
import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from bonecontact.common.geometry import point_triangle_distance
from bonecontact.meshing.session import gmsh_session
from bonecontact.neoplasm.host import (
    CouplingError,
    HostMesh,
    build_on_rank0,
    distribute_host_mesh,
    read_gmsh_groups,
    wall_name,
    write_result_mesh,
)

__all__ = [
    "HostGeometry3D",
    "build_host_mesh3d",
    "read_host_geometry3d",
    "sphere_surface",
    "surface_volume",
    "write_host_geometry3d",
]

#: Smallest clearance between the neoplasm and its host body's surface, in units of the
#: neoplasm's mesh size.
CLEARANCE = 0.25
#: Growth of the mesh size away from the neoplasm (m per m of distance).
GRADING = 0.12


# ----------------------------------------------------------------------------- scene geometry
@dataclass
class HostGeometry3D:
    """The scene's 3D mesh as plain arrays (rank 0 only).

    Parameters
    ----------
    x
        ``(n, 3)`` node coordinates (m).
    cells
        Cell group name -> ``(tag, tetrahedra)``, ``(m, 4)`` node indices.
    facets
        Facet group name -> ``(tag, triangles)``, ``(k, 3)`` node indices.
    """

    x: npt.NDArray[np.float64]
    cells: dict[str, tuple[int, npt.NDArray[np.int64]]]
    facets: dict[str, tuple[int, npt.NDArray[np.int64]]] = field(default_factory=dict)

    def node_size(self) -> npt.NDArray[np.float64]:
        """Local mesh size at each node: mean length of the tetrahedron edges touching it."""
        tets = np.concatenate([t for _, t in self.cells.values()])
        pairs = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
        e = np.concatenate([tets[:, list(p)] for p in pairs])
        ln = np.linalg.norm(self.x[e[:, 1]] - self.x[e[:, 0]], axis=1)
        s = np.bincount(e.ravel(), weights=np.repeat(ln, 2), minlength=len(self.x))
        c = np.bincount(e.ravel(), minlength=len(self.x))
        return np.where(c > 0, s / np.maximum(c, 1), np.nan)

    def _volumes(self, group: str) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        p = self.x[self.cells[group][1]]
        v = np.abs(
            np.einsum("ij,ij->i", p[:, 1] - p[:, 0], np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]))
        )
        return v / 6.0, p.mean(axis=1)

    def centroid(self, group: str) -> npt.NDArray[np.float64]:
        """Volume centroid of a cell group."""
        v, c = self._volumes(group)
        return (v[:, None] * c).sum(axis=0) / v.sum()

    def volume(self, group: str) -> float:
        """Volume of a cell group (m³)."""
        return float(self._volumes(group)[0].sum())


def read_host_geometry3d(path: str | Path) -> HostGeometry3D:
    """Read a 3D gmsh file (linear tetrahedra and triangles in named physical groups); serial.

    Raises
    ------
    CouplingError
        No 3D cell group, or other elements than 4-node tetrahedra / 3-node triangles.
    """
    x, cells, facets = read_gmsh_groups(path, 3)
    if not cells:
        raise CouplingError(f"{path}: no 3D cell groups")
    return HostGeometry3D(x, cells, facets)


def write_host_geometry3d(g: HostGeometry3D, path: str | Path) -> None:
    """Write ``g`` as a gmsh file (format 4.1): its cell and facet groups as named physical
    groups with their tags, readable by :func:`read_host_geometry3d`; serial (call on one
    rank)."""
    with gmsh_session("host_geometry"):
        m = gmsh.model
        m.mesh.addNodes(0, m.addDiscreteEntity(0), np.arange(1, len(g.x) + 1), g.x.ravel())
        for dim, groups, kind in ((3, g.cells, 4), (2, g.facets, 2)):
            for name, (tag, cells) in groups.items():
                e = m.addDiscreteEntity(dim)
                m.mesh.addElementsByType(e, kind, [], (np.asarray(cells) + 1).ravel())
                m.addPhysicalGroup(dim, [e], tag, name=name)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(str(path))


# ----------------------------------------------------------------------------- neoplasm surface
def sphere_surface(
    center: npt.ArrayLike, radius: float, h: float
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """A closed triangulated sphere (outward triangles, vertices on the sphere), edges ~``h``.

    The icosahedron with every edge divided into ``m`` parts (``m`` from ``h``, at least
    2), projected onto the sphere: 10 m² + 2 vertices.
    """
    m = max(2, int(math.ceil(1.05 * radius / h)))
    t = (1.0 + math.sqrt(5.0)) / 2.0
    v = np.array(
        [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
         [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]],
        dtype=np.float64,
    )  # fmt: skip
    faces = np.array(
        [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]],
        dtype=np.int64,
    )  # fmt: skip
    keys: dict[tuple[int, ...], int] = {}
    pts: list[npt.NDArray[np.float64]] = []
    tris: list[tuple[int, int, int]] = []

    def vid(f: int, i: int, j: int) -> int:
        # barycentric (i, j, m-i-j) on face f; key by the sorted corner weights
        a, b, c = faces[f]
        w = {int(a): m - i - j, int(b): i, int(c): j}
        key = tuple(sorted((k, wk) for k, wk in w.items() if wk > 0))
        if key not in keys:
            keys[key] = len(pts)
            pts.append(((m - i - j) * v[a] + i * v[b] + j * v[c]) / m)
        return keys[key]

    for f in range(len(faces)):
        for i in range(m):
            for j in range(m - i):
                p0, p1, p2 = vid(f, i, j), vid(f, i + 1, j), vid(f, i, j + 1)
                tris.append((p0, p1, p2))
                if i + j < m - 1:
                    tris.append((p1, vid(f, i + 1, j + 1), p2))
    x = np.asarray(pts)
    x = radius * x / np.linalg.norm(x, axis=1)[:, None] + np.asarray(center, dtype=np.float64)
    tri = np.asarray(tris, dtype=np.int64)
    if surface_volume(x, tri) < 0:
        tri = tri[:, [0, 2, 1]]
    return x, tri


def surface_volume(points: npt.ArrayLike, triangles: npt.ArrayLike) -> float:
    """Signed volume enclosed by a closed triangulated surface (> 0 for outward triangles)."""
    p = np.asarray(points, dtype=np.float64)[np.asarray(triangles)]
    return float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0)


# ----------------------------------------------------------------------------- surfaces
_TET_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


@dataclass
class _Surfaces:
    """The recovered surfaces of the scene mesh (rank 0).

    ``tri`` ``(F, 3)`` structural faces (oriented outward from ``side[:, 0]``); ``side``
    ``(F, 2)`` group indices on either side (-1: outside); ``cellcomp`` ``(F, 2)`` the body
    (connected component of one group's cells) on either side (-1: outside); ``key``
    ``(F,)`` surface-kind index; ``names`` facet groups per kind; ``patch`` ``(F,)`` the
    discrete surface of each face.
    """

    tri: npt.NDArray[np.int64]
    side: npt.NDArray[np.int64]
    body: npt.NDArray[np.int64]
    patch: npt.NDArray[np.int64]
    patch_facets: list[tuple[str, ...]]
    body_group: npt.NDArray[np.int64]


def _components(n: int, pairs: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Connected components of ``n`` nodes joined by ``pairs`` ``(k, 2)``."""
    if len(pairs) == 0:
        return np.arange(n)
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(g, directed=False)[1].astype(np.int64)


def _edge_pairs(tri: npt.NDArray[np.int64], label: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Pairs of faces with the same ``label`` that share an edge."""
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    e = np.sort(e, axis=1)
    f = np.tile(np.arange(len(tri)), 3)
    key = np.column_stack([label[f], e])
    order = np.lexsort(key.T[::-1])
    ks, fs = key[order], f[order]
    same = np.all(ks[1:] == ks[:-1], axis=1)
    return np.column_stack([fs[:-1][same], fs[1:][same]])


def _recover_surfaces(
    geo: HostGeometry3D, label: npt.NDArray[np.int64], tets: npt.NDArray[np.int64]
) -> _Surfaces:
    """Boundary and interface faces, the bodies and the discrete surface patches."""
    nt = len(tets)
    p = geo.x[tets]
    neg = (
        np.einsum("ij,ij->i", p[:, 1] - p[:, 0], np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0])) < 0
    )
    tets = tets.copy()
    tets[neg] = tets[neg][:, [0, 1, 3, 2]]
    faces = tets[:, _TET_FACES].reshape(-1, 3)  # outward from their tet
    owner = np.repeat(np.arange(nt), 4)
    skey = np.sort(faces, axis=1)
    _, first, count = np.unique(skey, axis=0, return_index=True, return_counts=True)
    _, rlast = np.unique(skey[::-1], axis=0, return_index=True)
    last = len(skey) - 1 - rlast
    if np.any(count > 2):
        raise CouplingError("the scene mesh has a face shared by more than two tetrahedra")
    # cell adjacency through faces inside one group -> bodies
    own = owner[first]
    other = np.where(count == 2, owner[last], -1)
    internal = other >= 0
    same = internal & (label[own] == label[np.maximum(other, 0)])
    body = _components(nt, np.column_stack([own[same], other[same]]))
    _, body = np.unique(body, return_inverse=True)
    body_group = np.zeros(body.max() + 1, dtype=np.int64)
    body_group[body] = label
    struct = ~same
    fi = np.where(struct)[0]
    tri = faces[first[fi]]
    a, b = own[fi], other[fi]
    side = np.column_stack([label[a], np.where(b >= 0, label[np.maximum(b, 0)], -1)])
    bodies = np.column_stack([body[a], np.where(b >= 0, body[np.maximum(b, 0)], -1)])
    # facet groups per structural face
    fkey = {tuple(k): i for i, k in enumerate(np.sort(tri, axis=1).tolist())}
    names: list[set[str]] = [set() for _ in range(len(tri))]
    for g, (_, t) in geo.facets.items():
        for k in np.sort(t, axis=1).tolist():
            i = fkey.get(tuple(k))
            if i is not None:
                names[i].add(g)
    kinds: dict[tuple, int] = {}
    kind = np.empty(len(tri), dtype=np.int64)
    for i in range(len(tri)):
        k = (tuple(sorted(bodies[i].tolist())), tuple(sorted(names[i])))
        kind[i] = kinds.setdefault(k, len(kinds))
    patch = _components(len(tri), _edge_pairs(np.sort(tri, axis=1), kind))
    _, patch = np.unique(patch, return_inverse=True)
    patch_facets: list[tuple[str, ...]] = [()] * (patch.max() + 1 if len(patch) else 0)
    for i in range(len(tri)):
        patch_facets[patch[i]] = tuple(sorted(names[i]))
    return _Surfaces(tri, side, bodies, patch, patch_facets, body_group)


# ----------------------------------------------------------------------------- inside checks
def _winding(
    points: npt.NDArray[np.float64], tri_x: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]:
    """Generalised winding number of points w.r.t. an oriented closed triangle set."""
    out = np.zeros(len(points))
    for s in range(0, len(points), 256):
        p = points[s : s + 256, None, None, :]
        r = tri_x[None, :, :, :] - p  # (P, F, 3, 3)
        n = np.linalg.norm(r, axis=-1)
        a, b, c = r[..., 0, :], r[..., 1, :], r[..., 2, :]
        num = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
        den = (
            n[..., 0] * n[..., 1] * n[..., 2]
            + np.einsum("pfi,pfi->pf", a, b) * n[..., 2]
            + np.einsum("pfi,pfi->pf", b, c) * n[..., 0]
            + np.einsum("pfi,pfi->pf", c, a) * n[..., 1]
        )
        out[s : s + 256] = 2.0 * np.arctan2(num, den).sum(axis=1) / (4.0 * math.pi)
    return out


def _distance_to_surface(
    pts: npt.NDArray[np.float64], x: npt.NDArray[np.float64], tri: npt.NDArray[np.int64]
) -> npt.NDArray[np.float64]:
    """Distance from each point to a triangle set (exact; candidates found by a k-d tree)."""
    cen = x[tri].mean(axis=1)
    rad = np.linalg.norm(x[tri] - cen[:, None, :], axis=2).max(axis=1)
    tree = cKDTree(cen)
    d0, _ = tree.query(pts)
    out = np.full(len(pts), np.inf)
    cands = tree.query_ball_point(pts, d0 + rad.max())  # every triangle that can be nearest
    counts = np.fromiter((len(c) for c in cands), dtype=np.int64, count=len(pts))
    point = np.repeat(np.arange(len(pts)), counts)
    face = np.fromiter((f for c in cands for f in c), dtype=np.int64, count=int(counts.sum()))
    for s in range(0, len(point), 1 << 18):  # all pairs at once, in chunks
        i, f = point[s : s + (1 << 18)], face[s : s + (1 << 18)]
        np.minimum.at(out, i, point_triangle_distance(pts[i], x[tri[f]]))
    return out


def _body_surface(sf: _Surfaces, bd: int) -> npt.NDArray[np.int64]:
    """The structural faces of body ``bd``, oriented outward from it."""
    fw, bw = sf.body[:, 0] == bd, sf.body[:, 1] == bd
    return np.concatenate([sf.tri[fw], sf.tri[bw][:, [0, 2, 1]]])


def _host_body(
    sf: _Surfaces, x: npt.NDArray[np.float64], gname: str, gidx: int,
    npts: npt.NDArray[np.float64], ntri: npt.NDArray[np.int64], h_neo: float,
) -> int:  # fmt: skip
    """The body of the host group that holds the neoplasm strictly inside (CouplingError else).

    Strictly inside: every neoplasm vertex inside the body (winding number of its closed
    surface), no vertex of the body's surface inside the neoplasm (an engulfed hole), and
    the two surfaces at least ``CLEARANCE`` neoplasm mesh sizes apart.
    """
    limit = " (3D coupling needs the neoplasm strictly inside one body of the group it grows "
    limit += "into; crossing an interface or the outer surface is not supported)"
    away = math.inf
    for bd in np.where(sf.body_group == gidx)[0]:
        tri = _body_surface(sf, int(bd))
        if not len(tri):
            continue
        inside = _winding(npts, x[tri]) > 0.5
        if not inside.any():
            away = min(away, float(_distance_to_surface(npts, x, tri).min()))
            continue
        if not inside.all():
            out = float(_distance_to_surface(npts[~inside], x, tri).max())
            raise CouplingError(
                f'the neoplasm is not strictly inside the cell group "{gname}": it reaches '
                f"{out:.4g} m beyond its surface{limit}"
            )
        bn = np.unique(tri)
        lo, hi = npts.min(axis=0), npts.max(axis=0)
        near = bn[np.all((x[bn] >= lo) & (x[bn] <= hi), axis=1)]
        if len(near) and np.any(_winding(x[near], npts[ntri]) > 0.5):
            raise CouplingError(
                f'the neoplasm engulfs part of the surface of the cell group "{gname}" (a '
                f"hole or an interface with another group){limit}"
            )
        gap = min(
            float(_distance_to_surface(npts, x, tri).min()),
            float(_distance_to_surface(x[bn], npts, ntri).min()),
        )
        if gap < CLEARANCE * h_neo:
            raise CouplingError(
                f'the neoplasm is not strictly inside the cell group "{gname}": it comes '
                f"within {gap:.4g} m of its surface (at least {CLEARANCE} x its mesh size = "
                f"{CLEARANCE * h_neo:.4g} m needed in 3D){limit}"
            )
        return int(bd)
    raise CouplingError(
        f'the neoplasm is not inside the cell group "{gname}": it lies {away:.4g} m away from '
        f"it{limit}"
    )


# ----------------------------------------------------------------------------- gmsh model
def _add_patches(sf: _Surfaces, x: npt.NDArray[np.float64]) -> dict[int, int]:
    """One discrete gmsh surface per patch (nodes added once, by the first patch using them)."""
    added = np.zeros(len(x), dtype=bool)
    ent = {}
    for p in range(len(sf.patch_facets)):
        tri = sf.tri[sf.patch == p]
        s = gmsh.model.addDiscreteEntity(2)
        nodes = np.unique(tri)
        new = nodes[~added[nodes]]
        added[new] = True
        if len(new):
            gmsh.model.mesh.addNodes(2, s, new + 1, x[new].ravel())
        gmsh.model.mesh.addElementsByType(s, 2, [], (tri + 1).ravel())
        ent[p] = s
    return ent


def _shells(sf: _Surfaces, bd: int, x: npt.NDArray[np.float64]) -> list[list[int]]:
    """Patches bounding body ``bd`` grouped into shells, the outer shell first."""
    fi = np.where((sf.body[:, 0] == bd) | (sf.body[:, 1] == bd))[0]
    tri = np.sort(sf.tri[fi], axis=1)
    comp = _components(len(fi), _edge_pairs(tri, np.zeros(len(fi), dtype=np.int64)))
    shells = []
    for c in np.unique(comp):
        f = fi[comp == c]
        ext = np.ptp(x[np.unique(sf.tri[f])], axis=0)
        shells.append((float(np.linalg.norm(ext)), sorted({int(p) for p in sf.patch[f]})))
    shells.sort(key=lambda s: -s[0])
    return [s for _, s in shells]


def _size_callback(npts: npt.NDArray[np.float64], h_neo: float, h_max: float):
    tree = cKDTree(npts)

    def size(dim: int, tag: int, px: float, py: float, pz: float, lc: float) -> float:
        d, _ = tree.query((px, py, pz))
        return min(lc, h_max, h_neo + GRADING * d)

    return size


def _build_serial(
    geo: HostGeometry3D,
    region: str,
    host: tuple[str, ...],
    points: npt.NDArray[np.float64],
    triangles: npt.NDArray[np.int64],
    cavity: bool,
    h_neo: float,
    path: Path | None,
) -> HostMesh:
    """:func:`build_host_mesh3d` on rank 0: surfaces, checks, volumes, groups, mesh."""
    if region not in geo.cells:
        raise CouplingError(f'the mesh has no cell group "{region}"')
    gname = host[0] if host else region
    group, label, tets = _host_groups(geo, region, gname)
    npts, ntri = _neoplasm_surface(points, triangles)
    sf = _recover_surfaces(geo, label, tets)
    hb = _host_body(sf, geo.x, gname, group.index(gname), npts, ntri, h_neo)
    tags = {n: t for n, (t, _) in geo.cells.items()}
    ent = _add_patches(sf, geo.x)
    s_neo = _add_neoplasm_surface(npts, ntri, len(geo.x) + 1)
    vols, neo_vol = _add_volumes(sf, geo.x, ent, group, hb, s_neo, cavity)
    _cell_groups(vols, neo_vol, tags, region)
    facet_names = _facet_groups(geo, sf, ent, s_neo, tags, region)
    _mesh_volumes(npts, h_neo, float(np.nanmax(geo.node_size())))
    ncells = 0
    for _, v in gmsh.model.getEntities(3):
        types, etags, _ = gmsh.model.mesh.getElements(3, v)
        ncells += sum(len(t) for t in etags)
    neo_volume = surface_volume(npts, ntri) if cavity else _meshed_volume(neo_vol)
    write_result_mesh(path)
    cell_groups = tuple(sorted(set(vols) | ({region} if neo_vol is not None else set())))
    return HostMesh(
        path, cell_groups, tuple(facet_names), float(neo_volume), wall_name(region), int(ncells)
    )


def _host_groups(
    geo: HostGeometry3D, region: str, gname: str
) -> tuple[list[str], npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """The cell groups with ``region`` counted as the host group ``gname`` (sorted), the
    index of each tetrahedron's group and the tetrahedra."""
    names = list(geo.cells)
    merged = [gname if n == region else n for n in names]
    group = sorted(set(merged))
    gi = {g: i for i, g in enumerate(group)}
    tets = np.concatenate([geo.cells[n][1] for n in names])
    label = np.concatenate([np.full(len(geo.cells[n][1]), gi[m]) for n, m in zip(names, merged)])
    return group, label, tets


def _neoplasm_surface(
    points: npt.ArrayLike, triangles: npt.ArrayLike
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """The neoplasm surface rounded to 0.1 nm and oriented outward.  (The surface comes
    from reductions whose round-off may differ with the number of ranks, and gmsh's mesh
    is not continuous in its input.)"""
    npts = np.round(np.asarray(points, dtype=np.float64), 10)
    ntri = np.asarray(triangles, dtype=np.int64)
    if surface_volume(npts, ntri) < 0:
        ntri = ntri[:, [0, 2, 1]]
    return npts, ntri


def _add_neoplasm_surface(
    npts: npt.NDArray[np.float64], ntri: npt.NDArray[np.int64], off: int
) -> int:
    """The neoplasm surface as a discrete gmsh surface, its nodes numbered from ``off``."""
    s_neo = gmsh.model.addDiscreteEntity(2)
    gmsh.model.mesh.addNodes(2, s_neo, np.arange(len(npts)) + off, npts.ravel())
    gmsh.model.mesh.addElementsByType(s_neo, 2, [], (ntri + off).ravel())
    return s_neo


def _add_volumes(
    sf: _Surfaces,
    x: npt.NDArray[np.float64],
    ent: dict[int, int],
    group: list[str],
    hb: int,
    s_neo: int,
    cavity: bool,
) -> tuple[dict[str, list[int]], int | None]:
    """One volume per body (its shells; the neoplasm surface a hole of body ``hb``) by
    group name, and the neoplasm's own volume (``None`` for a cavity)."""
    vols: dict[str, list[int]] = {}
    kernel = gmsh.model.geo
    for bd in range(len(sf.body_group)):
        loops = [kernel.addSurfaceLoop([ent[p] for p in sh]) for sh in _shells(sf, bd, x)]
        if bd == hb:
            loops.append(kernel.addSurfaceLoop([s_neo]))
        vols.setdefault(group[sf.body_group[bd]], []).append(kernel.addVolume(loops))
    neo_vol = None if cavity else kernel.addVolume([kernel.addSurfaceLoop([s_neo])])
    kernel.synchronize()
    return vols, neo_vol


def _cell_groups(
    vols: dict[str, list[int]], neo_vol: int | None, tags: dict[str, int], region: str
) -> None:
    """Every cell group under its name and tag; a tumour's volume under ``region``'s."""
    for g, vs in vols.items():
        tag = tags[g] if g in tags else tags[region]
        gmsh.model.addPhysicalGroup(3, vs, tag, name=g)
    if neo_vol is not None:
        if region in vols:  # host = []: the neoplasm joins its region
            gmsh.model.removePhysicalGroups([(3, tags[region])])
            gmsh.model.addPhysicalGroup(3, vols[region] + [neo_vol], tags[region], name=region)
        else:
            gmsh.model.addPhysicalGroup(3, [neo_vol], tags[region], name=region)


def _facet_groups(
    geo: HostGeometry3D,
    sf: _Surfaces,
    ent: dict[int, int],
    s_neo: int,
    tags: dict[str, int],
    region: str,
) -> list[str]:
    """The scene's facet groups that still have patches, and the neoplasm wall under a new
    tag; returns their names."""
    facet_names = []
    for g, (tag, _) in geo.facets.items():
        members = [ent[p] for p, fs in enumerate(sf.patch_facets) if g in fs]
        if members:
            gmsh.model.addPhysicalGroup(2, members, tag, name=g)
            facet_names.append(g)
    wname = wall_name(region)
    used = list(tags.values()) + [t for t, _ in geo.facets.values()]
    gmsh.model.addPhysicalGroup(2, [s_neo], max(used) + 1, name=wname)
    facet_names.append(wname)
    return facet_names


def _mesh_volumes(npts: npt.NDArray[np.float64], h_neo: float, h_max: float) -> None:
    """Tetrahedra (Delaunay) of a size growing with the distance from the neoplasm."""
    gmsh.model.mesh.setSizeCallback(_size_callback(npts, h_neo, h_max))
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.Algorithm3D", 1)
    gmsh.model.mesh.generate(3)


def _meshed_volume(vol: int) -> float:
    """Volume of the tetrahedra of a gmsh volume."""
    types, _, ntags = gmsh.model.mesh.getElements(3, vol)
    tags, coords, _ = gmsh.model.mesh.getNodes()
    pos = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    pos[tags.astype(np.int64)] = np.arange(len(tags))
    x = coords.reshape(-1, 3)
    total = 0.0
    for t, nt in zip(types, ntags):
        if t != 4:
            continue
        p = x[pos[np.asarray(nt, dtype=np.int64)].reshape(-1, 4)]
        total += float(
            np.abs(
                np.einsum(
                    "ij,ij->i", p[:, 1] - p[:, 0], np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0])
                )
            ).sum()
            / 6.0
        )
    return total


def build_host_mesh3d(
    geo: HostGeometry3D | None,
    region: str,
    host: tuple[str, ...],
    points: npt.ArrayLike | None,
    triangles: npt.ArrayLike | None,
    cavity: bool,
    h_neo: float,
    path: Path | None,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> HostMesh:
    """Rebuild the 3D host mesh with the neoplasm surface embedded (gmsh on rank 0; collective).

    Parameters
    ----------
    geo
        The scene's mesh (:func:`read_host_geometry3d`); used on rank 0 only.
    region, host
        ``[neoplasm] region`` and ``host``.
    points, triangles
        The neoplasm's closed surface: ``(N, 3)`` vertices and ``(M, 3)`` triangles (either
        orientation); rank 0's are used.
    cavity
        ``True`` for a cyst: no cells inside the neoplasm.
    h_neo
        Mesh size on the neoplasm surface (m); the size grows away from it.
    path
        Where rank 0 writes the gmsh file for the user (``None``: none); nothing reads it.

    Returns
    -------
    HostMesh
        The same numbers on every rank, with the distributed mesh and its groups;
        ``neoplasm_area`` is the neoplasm's volume (m³) and ``cells`` the number of
        tetrahedra.

    Raises
    ------
    CouplingError
        On every rank: the neoplasm is not strictly inside one body of the group it grows
        in (the message names the group and the distance), or gmsh fails.
    """
    with gmsh_session("bonecontact-host3d") if comm.rank == 0 else nullcontext():
        hm = build_on_rank0(
            lambda: _build_serial(
                geo, region, host, np.asarray(points), np.asarray(triangles), cavity, h_neo, path
            ),
            "rebuild the 3D host mesh around the neoplasm",
            comm,
        )
        return distribute_host_mesh(hm, 3, comm)
