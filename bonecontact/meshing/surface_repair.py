"""Closed triangulated surfaces (bone scans): reading, checking, repairing, remeshing.

A bone surface from a scanner or a segmentation comes as an STL (or OBJ, PLY, OFF, VTK)
file: a soup of triangles with every vertex repeated once per triangle, often with a few
inconsistently oriented triangles, small holes, non-manifold edges and triangles far
coarser or more irregular than the volume mesh should be.  :func:`prepare_surface` turns
such a file into a :class:`Surface` fit to bound a tetrahedral mesh (closed, 2-manifold,
outward normals), or refuses it with a :class:`MeshInputError` that names the file, the
defect and where it is:

* always repaired (they are artefacts of the format): duplicate vertices (merged),
  degenerate and repeated triangles (dropped), inconsistently oriented triangles (flipped
  to agree with the majority of their shell);
* repaired with ``repair=True``, refused otherwise: an **open surface** (boundary edges:
  holes filled by pymeshfix), a **non-manifold edge** (an edge shared by more than two
  triangles: pymeshfix), an **inverted shell** (negative signed volume: every normal
  points inwards; flipped);
* remeshed on request (``size=``): pyacvd clusters the surface into nearly equilateral
  triangles of the requested edge length.

Volumes and areas use the divergence theorem on the triangles: ``V = Σ (a · (b × c)) / 6``
over the outward-oriented triangles ``(a, b, c)``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from bonecontact.common.errors import InputError

__all__ = [
    "MeshInputError",
    "Surface",
    "check_surface",
    "merge_vertices",
    "orient_surface",
    "prepare_surface",
    "read_surface",
    "remesh_surface",
    "repair_surface",
    "split_components",
    "surface_defects",
]


class MeshInputError(InputError):
    """A surface (or image) file cannot be meshed; the message names the file and the defect."""


@dataclass(frozen=True)
class Surface:
    """A triangulated surface: ``points`` (n, 3) in m, ``triangles`` (m, 3) vertex indices.

    ``source`` names where it came from (the file, in error messages); ``repairs`` lists
    what :func:`prepare_surface` changed, in words.
    """

    points: np.ndarray
    triangles: np.ndarray
    source: str = "<array>"
    repairs: tuple[str, ...] = field(default=())

    @property
    def volume(self) -> float:
        """Signed enclosed volume (m³; positive for outward normals)."""
        a, b, c = (self.points[self.triangles[:, i]] for i in range(3))
        return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)

    @property
    def area(self) -> float:
        """Total area (m²)."""
        return float(self.triangle_areas().sum())

    def triangle_areas(self) -> np.ndarray:
        """Area of each triangle (m²)."""
        return 0.5 * np.linalg.norm(self.triangle_normals(unit=False), axis=1)

    def triangle_normals(self, unit: bool = True) -> np.ndarray:
        """Normal of each triangle (``(b - a) × (c - a)``; unit length if ``unit``)."""
        a, b, c = (self.points[self.triangles[:, i]] for i in range(3))
        n = np.cross(b - a, c - a)
        if unit:
            n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        return n

    def centroids(self) -> np.ndarray:
        """Centroid of each triangle (m)."""
        return self.points[self.triangles].mean(axis=1)

    @property
    def extent(self) -> float:
        """Length of the bounding-box diagonal (m)."""
        return float(np.linalg.norm(np.ptp(self.points, axis=0))) if len(self.points) else 0.0

    def mean_edge(self) -> float:
        """Mean edge length (m)."""
        e = self.points[self.triangles] - self.points[np.roll(self.triangles, 1, axis=1)]
        return float(np.linalg.norm(e, axis=2).mean())

    def scaled(self, factor: float) -> Surface:
        """The surface with every coordinate multiplied by ``factor``."""
        return Surface(self.points * factor, self.triangles, self.source, self.repairs)

    def with_repairs(self, points, triangles, note: str | None) -> Surface:
        """A new surface of the same source, with ``note`` appended to the repairs."""
        repairs = self.repairs + ((note,) if note else ())
        pts, tri = np.asarray(points, float), np.asarray(triangles, np.int64)
        return Surface(pts, tri, self.source, repairs)

    def to_pyvista(self):
        """The surface as a ``pyvista.PolyData``."""
        import pyvista as pv

        faces = np.hstack([np.full((len(self.triangles), 1), 3), self.triangles]).ravel()
        return pv.PolyData(self.points, faces)


# ------------------------------------------------------------------------------ reading
def read_surface(path: str | Path, scale: float = 1.0) -> Surface:
    """Read the triangles of a surface file (STL, OBJ, PLY, OFF, VTK/VTU, … via meshio).

    Parameters
    ----------
    path
        The file.
    scale
        Factor applied to the coordinates (``1e-3`` for a file in millimetres).

    Raises
    ------
    MeshInputError
        If the file cannot be read or holds no triangles.
    """
    import meshio

    path = Path(path)
    if not path.is_file():
        raise MeshInputError(f"{path}: no such file")
    try:
        m = meshio.read(path)
    except Exception as exc:  # meshio raises many kinds
        raise MeshInputError(f"{path}: cannot be read as a surface ({exc})") from exc
    blocks = [c.data for c in m.cells if c.type == "triangle"]
    if not blocks:
        kinds = sorted({c.type for c in m.cells}) or ["none"]
        raise MeshInputError(f"{path}: holds no triangles (cells: {', '.join(kinds)})")
    points = np.asarray(m.points, float)
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    return Surface(points * scale, np.vstack(blocks).astype(np.int64), source=str(path))


# ------------------------------------------------------------------ always-safe clean-up
def merge_vertices(surface: Surface, tolerance: float = 1e-9) -> Surface:
    """Merge vertices closer than ``tolerance`` × the bounding-box diagonal; drop degenerate
    (two equal vertices) and repeated triangles, and unused vertices."""
    pts, tri = surface.points, surface.triangles
    if len(tri) == 0:
        raise MeshInputError(f"{surface.source}: the surface has no triangles")
    tol = max(tolerance * surface.extent, 1e-300)
    keys = np.round(pts / tol).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    tri = inverse.reshape(-1)[tri]
    n_merged = len(pts) - len(first)
    degenerate = (tri[:, 0] == tri[:, 1]) | (tri[:, 1] == tri[:, 2]) | (tri[:, 2] == tri[:, 0])
    tri = tri[~degenerate]
    _, keep = np.unique(np.sort(tri, axis=1), axis=0, return_index=True)
    n_repeated = len(tri) - len(keep)
    tri = tri[np.sort(keep)]
    used, tri = np.unique(tri, return_inverse=True)
    tri = tri.reshape(-1, 3)
    notes = [
        f"{n} {what}"
        for n, what in (
            (n_merged, "duplicate vertices merged"),
            (int(degenerate.sum()), "degenerate triangles dropped"),
            (n_repeated, "repeated triangles dropped"),
        )
        if n
    ]
    return surface.with_repairs(pts[first][used], tri, "; ".join(notes) or None)


def _edges(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unique undirected edges, the edge of each triangle side (m, 3) and each edge's count."""
    directed = np.stack([triangles, np.roll(triangles, -1, axis=1)], axis=2).reshape(-1, 2)
    pairs = np.sort(directed, axis=1)
    n = int(triangles.max()) + 1 if len(triangles) else 1
    keys, inverse, counts = np.unique(
        pairs[:, 0] * n + pairs[:, 1], return_inverse=True, return_counts=True
    )
    edges = np.column_stack([keys // n, keys % n])
    return edges, inverse.reshape(-1, 3), counts


def orient_surface(surface: Surface) -> Surface:
    """Flip triangles so that neighbours across every manifold edge agree; in each connected
    shell the orientation of the majority of its triangles wins."""
    tri = surface.triangles
    edges, side_edge, counts = _edges(tri)
    m = len(tri)
    # pairs of triangles across manifold edges, and whether they already agree
    owner = np.repeat(np.arange(m), 3)
    flat = side_edge.ravel()
    manifold = counts[flat] == 2
    order = np.argsort(flat[manifold], kind="stable")
    f = owner[manifold][order].reshape(-1, 2)
    starts = tri.ravel()[np.flatnonzero(manifold)[order]].reshape(-1, 2)
    agree = starts[:, 0] != starts[:, 1]  # consistent neighbours traverse the edge oppositely
    graph = sp.coo_matrix((np.ones(len(f)), (f[:, 0], f[:, 1])), shape=(m, m)).tocsr()
    n_comp, labels = connected_components(graph, directed=False)
    # parity of each triangle relative to the root of its component (breadth first)
    adj = [[] for _ in range(m)]
    for (a, b), ok in zip(f.tolist(), agree.tolist()):
        adj[a].append((b, ok))
        adj[b].append((a, ok))
    parity = np.full(m, -1, np.int8)
    for root in range(m):
        if parity[root] >= 0:
            continue
        parity[root] = 0
        stack = [root]
        while stack:
            t = stack.pop()
            for nb, ok in adj[t]:
                if parity[nb] < 0:
                    parity[nb] = parity[t] ^ (0 if ok else 1)
                    stack.append(nb)
    flip = np.zeros(m, bool)
    for c in range(n_comp):
        members = labels == c
        odd = parity[members] == 1
        flip[members] = odd if odd.sum() <= (~odd).sum() else ~odd
    if not flip.any():
        return surface
    out = tri.copy()
    out[flip] = out[flip][:, ::-1]
    return surface.with_repairs(surface.points, out, f"{int(flip.sum())} triangles reoriented")


# ------------------------------------------------------------------------------- checks
def _where(p: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.4g}" for v in p) + ") m"


def surface_defects(surface: Surface) -> list[str]:
    """The defects that stop a surface from bounding a volume mesh, in words (empty: none).

    Open surface (boundary edges, the number of holes and where the largest is),
    non-manifold edges (where the first one is), inverted shell (negative volume).
    """
    pts, tri = surface.points, surface.triangles
    edges, _, counts = _edges(tri)
    defects = []
    boundary = edges[counts == 1]
    if len(boundary):
        n = len(pts)
        g = sp.coo_matrix((np.ones(len(boundary)), (boundary[:, 0], boundary[:, 1])), (n, n))
        _, lab = connected_components(g, directed=False)
        loops = lab[boundary[:, 0]]
        ids, sizes = np.unique(loops, return_counts=True)
        big = ids[np.argmax(sizes)]
        centre = pts[boundary[loops == big].ravel()].mean(axis=0)
        defects.append(
            f"open surface: {len(boundary)} boundary edges in {len(ids)} hole(s), the largest "
            f"({sizes.max()} edges) around {_where(centre)}"
        )
    nonmanifold = edges[counts > 2]
    if len(nonmanifold):
        defects.append(
            f"non-manifold edge: {len(nonmanifold)} edge(s) shared by more than two triangles, "
            f"the first at {_where(pts[nonmanifold[0]].mean(axis=0))}"
        )
    if not defects and surface.volume <= 0:
        defects.append(
            f"inverted shell: signed volume {surface.volume:.4g} m³ is negative "
            "(the triangle normals point inwards)"
        )
    return defects


def check_surface(surface: Surface) -> None:
    """Raise :class:`MeshInputError` naming the file and every defect of
    :func:`surface_defects`; return quietly for a closed, manifold, outward surface."""
    defects = surface_defects(surface)
    if defects:
        raise MeshInputError(f"{surface.source}: " + "; ".join(defects))


def split_components(surface: Surface) -> list[Surface]:
    """The connected pieces of a surface (sharing vertices), largest area first."""
    tri = surface.triangles
    n = len(surface.points)
    rows = np.concatenate([tri[:, 0], tri[:, 1]])
    cols = np.concatenate([tri[:, 1], tri[:, 2]])
    g = sp.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    k, labels = connected_components(g, directed=False)
    out = []
    for c in range(k):
        t = tri[labels[tri[:, 0]] == c]
        if len(t):
            used, t = np.unique(t, return_inverse=True)
            out.append(Surface(surface.points[used], t.reshape(-1, 3), surface.source))
    return sorted(out, key=lambda s: -s.area)


# ------------------------------------------------------------------------------ repairs
def repair_surface(surface: Surface) -> Surface:
    """Fill holes, remove non-manifold edges and self-intersections (pymeshfix: keeps the
    largest connected shell), and flip an inverted shell."""
    from pymeshfix import MeshFix

    out = surface
    if surface_defects(surface) and not surface_defects(surface)[0].startswith("inverted"):
        fix = MeshFix(surface.points, surface.triangles.astype(np.int32))
        fix.repair(joincomp=False, remove_smallest_components=True)
        area = surface.area
        out = surface.with_repairs(fix.points, fix.faces, None)
        out = orient_surface(out)
        out = out.with_repairs(
            out.points,
            out.triangles,
            f"pymeshfix: holes filled and non-manifold edges removed (area {area:.4g} -> "
            f"{out.area:.4g} m²)",
        )
    if not surface_defects(out) or surface_defects(out)[0].startswith("inverted"):
        if out.volume < 0:
            out = out.with_repairs(out.points, out.triangles[:, ::-1], "inverted shell flipped")
    return out


def remesh_surface(surface: Surface, size: float, max_volume_change: float = 0.05) -> Surface:
    """Remesh a closed surface into nearly equilateral triangles of edge ``size`` (m) by
    Voronoi clustering (pyacvd).

    The input is subdivided first (linear: the geometry is unchanged) until it has four
    times more vertices than the result will, so coarse input surfaces can be refined.  The
    cluster centres are then projected onto the input surface (closest point), which keeps
    the enclosed volume, and pymeshfix removes any self-intersection.

    Raises
    ------
    MeshInputError
        If the enclosed volume changed by more than ``max_volume_change`` (relative): the
        surface has parts thinner than ``size`` that the remeshing folded or cut away.
    """
    import pyacvd
    import pyvista as pv

    if not (math.isfinite(size) and size > 0):
        raise ValueError(f"size must be a positive length (m), got {size!r}")
    n_target = max(int(round(2.0 * surface.area / (math.sqrt(3.0) * size * size))), 20)
    with warnings.catch_warnings():  # pyacvd 0.4 uses a deprecated pyvista attribute
        warnings.simplefilter("ignore", pv.PyVistaDeprecationWarning)
        clus = pyacvd.Clustering(surface.to_pyvista())
        ratio = 4.0 * n_target / len(surface.points)
        nsub = int(min(max(math.ceil(math.log(ratio, 4.0)), 0), 4)) if ratio > 1 else 0
        if nsub:
            clus.subdivide(nsub)
        clus.cluster(n_target)
        new = clus.create_mesh()
    if not isinstance(new, pv.PolyData):  # pragma: no cover
        new = new.extract_surface()
    new = new.triangulate()
    tri = new.faces.reshape(-1, 4)[:, 1:]
    # cluster centres lie off the surface (inside where it is convex): project them back
    _, on_surface = surface.to_pyvista().find_closest_cell(
        np.asarray(new.points, float), return_closest_point=True
    )
    out = Surface(np.asarray(on_surface, float), tri.astype(np.int64), surface.source)
    out = orient_surface(merge_vertices(out))
    # clusters across a part thinner than ``size`` fold the surface through itself:
    # pymeshfix removes the self-intersections (and any hole or non-manifold edge)
    from pymeshfix import MeshFix

    fix = MeshFix(out.points, out.triangles.astype(np.int32))
    fix.repair(joincomp=False, remove_smallest_components=True)
    out = orient_surface(Surface(np.asarray(fix.points, float), fix.faces.astype(np.int64)))
    if out.volume < 0:
        out = Surface(out.points, out.triangles[:, ::-1], out.source)
    change = out.volume / surface.volume - 1.0
    if abs(change) > max_volume_change:
        raise MeshInputError(
            f"{surface.source}: remeshing to {size:.3g} m changes the enclosed volume by "
            f"{100 * change:+.1f} % (parts thinner than the size fold or are cut away): use "
            "a smaller size, or keep the surface's own triangles (remesh=False, "
            "--keep-triangles)"
        )
    note = f"remeshed to {len(out.triangles)} triangles of size {size:.3g} m (pyacvd)"
    return Surface(out.points, out.triangles, surface.source, surface.repairs + (note,))


def prepare_surface(
    source: str | Path | Surface,
    *,
    scale: float = 1.0,
    repair: bool = False,
    size: float | None = None,
) -> Surface:
    """Read (or take), clean, check and optionally repair and remesh a closed surface.

    Parameters
    ----------
    source
        A surface file (:func:`read_surface`) or a :class:`Surface`.
    scale
        Coordinate factor for a file (``1e-3``: millimetres to metres).
    repair
        Repair holes, non-manifold edges and an inverted shell instead of refusing them.
    size
        If given, remesh to triangles of about this edge length (m) with pyacvd.

    Returns
    -------
    Surface
        Closed, 2-manifold, outward-oriented; ``repairs`` says what was changed.

    Raises
    ------
    MeshInputError
        Naming the file and each defect (open surface with the number of boundary edges
        and the location of the largest hole, non-manifold edges with a location, inverted
        shell with its negative volume) when ``repair`` is off, or when the repair failed.
    """
    surface = source.scaled(scale) if isinstance(source, Surface) else read_surface(source, scale)
    surface = orient_surface(merge_vertices(surface))
    if repair:
        surface = repair_surface(surface)
    check_surface(surface)
    if size is not None:
        surface = remesh_surface(surface, size)
        check_surface(surface)
    return surface
