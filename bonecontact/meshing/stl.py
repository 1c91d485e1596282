"""A tetrahedral bone from a closed surface (an STL scan): cortical shell, cancellous core,
named contact and support surfaces.

:func:`bone_from_surface` reads and checks the surface
(:func:`~bonecontact.meshing.surface_repair.prepare_surface`), optionally remeshes it to the
element size, builds the **inner surface of the cortex** as the level set ``depth = t`` of
the depth below the bone surface (a distance transform on a grid, marching cubes, remeshed), and
tetrahedralises with gmsh the shell between the two surfaces (``<name>_cortical``) and the
core inside the inner one (``<name>_cancellous``): one conforming body.  Where the bone is
thinner than twice the cortical thickness the level set is empty and the bone is all cortex
(a vertebra's processes).

The outer surface keeps its triangles (they become the boundary facets); they are split into
facet groups by :class:`SurfaceRegion` selections (a box, a side of a plane, a cone of
outward normals, or several of these at once): the first region that selects a triangle
takes it, the remaining triangles form ``<name>_surface``.

Mesh generation runs on rank 0 (serial); the mesh is distributed to ``comm`` or written to a
gmsh file, as for every builder of :mod:`bonecontact.meshing`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

import gmsh
import numpy as np
from dolfinx.io.gmsh import MeshData

from bonecontact.meshing.builder import PhysicalGroups, check_positive, generate
from bonecontact.meshing.report import MeshReport, msh_report, run_report_command
from bonecontact.meshing.surface_repair import (
    MeshInputError,
    Surface,
    check_surface,
    prepare_surface,
    remesh_surface,
    split_components,
    surface_defects,
)

__all__ = [
    "SurfaceRegion",
    "bone_from_surface",
    "check_region_names",
    "cortical_inner_surface",
    "depth_field",
    "inside_mask",
    "mesh_surface",
    "select_triangles",
]

Vector = Sequence[float]


@dataclass(frozen=True)
class SurfaceRegion:
    """A facet group on the bone surface, selected by the triangles' centroids and normals.

    Every criterion given must hold (they are combined with *and*).

    Parameters
    ----------
    name
        Name of the facet physical group.
    box
        ``(lo, hi)``: the centroid lies in the axis-aligned box ``lo <= x <= hi`` (m).
    plane
        ``(point, normal)``: the centroid lies on the side of the plane the normal points
        to, ``(x - point) · normal >= 0``.
    cone
        ``(direction, angle)``: the outward normal of the triangle is within ``angle``
        degrees of ``direction`` (a joint surface facing up: ``((0, 1, 0), 45)``).
    """

    name: str
    box: tuple[Vector, Vector] | None = None
    plane: tuple[Vector, Vector] | None = None
    cone: tuple[Vector, float] | None = None

    def __post_init__(self) -> None:
        if self.box is None and self.plane is None and self.cone is None:
            raise ValueError(f"region {self.name!r}: give at least one of box, plane, cone")
        if self.cone is not None and not (0 <= self.cone[1] <= 180):
            raise ValueError(f"region {self.name!r}: cone angle must be in [0, 180] degrees")

    def select(self, centroids: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """Boolean mask of the triangles (centroids, unit outward normals) in the region."""
        mask = np.ones(len(centroids), bool)
        if self.box is not None:
            lo, hi = (np.asarray(v, float) for v in self.box)
            mask &= np.all((centroids >= lo) & (centroids <= hi), axis=1)
        if self.plane is not None:
            p, n = (np.asarray(v, float) for v in self.plane)
            mask &= (centroids - p) @ n >= 0
        if self.cone is not None:
            d = np.asarray(self.cone[0], float)
            d = d / np.linalg.norm(d)
            mask &= normals @ d >= math.cos(math.radians(self.cone[1])) - 1e-12
        return mask


def check_region_names(regions: Sequence[SurfaceRegion], rest: str) -> None:
    """Raise ValueError if two regions share a name, or one is named like the rest group.

    A facet group takes the triangles of one region; to select by several criteria at once
    give them to one :class:`SurfaceRegion` (they combine with *and*).
    """
    seen: set[str] = set()
    for region in regions:
        if region.name in seen or region.name == rest:
            raise ValueError(
                f"region {region.name!r} is given twice (or names the rest of the surface, "
                f"{rest!r}): each facet group takes one region; several criteria of one "
                "region combine with 'and' (SurfaceRegion(name, box=..., cone=...))"
            )
        seen.add(region.name)


def select_triangles(
    surface: Surface, regions: Sequence[SurfaceRegion], rest: str
) -> dict[str, np.ndarray]:
    """Triangle indices of each region (first region wins), and of ``rest`` for the others.

    Raises
    ------
    MeshInputError
        If a region selects no triangle (naming the region and the surface's extent).
    """
    check_region_names(regions, rest)
    c, n = surface.centroids(), surface.triangle_normals()
    free = np.ones(len(c), bool)
    out = {}
    for region in regions:
        chosen = region.select(c, n) & free
        if not chosen.any():
            lo, hi = surface.points.min(axis=0), surface.points.max(axis=0)
            raise MeshInputError(
                f"{surface.source}: region {region.name!r} selects no triangle of the surface "
                f"(bounding box {np.round(lo, 5).tolist()} to {np.round(hi, 5).tolist()} m)"
            )
        out[region.name] = np.flatnonzero(chosen)
        free &= ~chosen
    if free.any():
        out[rest] = np.flatnonzero(free)
    return out


def cortical_inner_surface(
    surface: Surface, thickness: float, size: float, spacing: float | None = None
) -> list[Surface]:
    """The inner surface(s) of a cortical shell: the level set at depth ``thickness``.

    The depth below ``surface`` is sampled on a grid of ``spacing`` (default
    ``min(thickness, size) / 4``, :func:`depth_field`), its level set ``thickness`` extracted
    by marching cubes
    and each closed piece of it remeshed to ``size``.  Pieces enclosing less than ``size³``
    are dropped (the bone is all cortex there).

    Returns
    -------
    list of Surface
        Closed, outward-oriented; empty where the bone is nowhere thicker than twice the
        cortex.
    """
    from skimage.measure import marching_cubes

    d = spacing if spacing is not None else min(thickness, size) / 4.0
    depth, lo = depth_field(surface, d)
    if depth.max() <= thickness:
        return []
    with warnings.catch_warnings():  # scikit-image 0.26 sets an array's shape (NumPy 2.5)
        warnings.simplefilter("ignore", DeprecationWarning)
        verts, faces, _, _ = marching_cubes(depth, level=thickness, spacing=(d, d, d))
    # marching cubes shares its vertices and orients its triangles consistently
    level = Surface(verts + lo, faces.astype(np.int64), surface.source)
    pieces = []
    for piece in split_components(level):
        if surface_defects(piece) and not surface_defects(piece)[0].startswith("inverted"):
            continue  # open or pinched (a non-manifold edge where the core nearly vanishes)
        if piece.volume < 0:
            piece = Surface(piece.points, piece.triangles[:, ::-1], piece.source)
        if piece.volume < size**3:
            continue
        pieces.append(_remesh_inside(piece, depth, lo, d, thickness, size))
    return pieces


def _remesh_inside(
    piece: Surface, depth: np.ndarray, lo: np.ndarray, d: float, thickness: float, size: float
) -> Surface:
    """Remesh a level-set piece to ``size``, finer where the chords of its triangles would
    come closer than half the cortical thickness to the bone surface (a coarse triangle
    bulging out of a concave inner surface)."""
    from scipy.ndimage import map_coordinates

    at = np.zeros(1)
    for attempt in range(5):
        try:
            out = remesh_surface(piece, size * 0.7**attempt)
        except MeshInputError:  # a thin part of the core lost: finer
            continue
        a, b, c = (out.points[out.triangles[:, i]] for i in range(3))
        probes = np.vstack([(a + b + c) / 3, (a + b) / 2, (b + c) / 2, (c + a) / 2])
        at = map_coordinates(depth, ((probes - lo) / d).T, order=1)
        if at.min() >= 0.5 * thickness:
            return out
    raise MeshInputError(
        f"{piece.source}: the inner surface of the cortex cannot be meshed within "
        f"{size:.3g} m of the bone surface (depth {at.min():.3g} m < half the cortical "
        f"thickness {thickness:.3g} m): use a thicker cortex or a smaller element size"
    )


def inside_mask(surface: Surface, axes: Sequence[np.ndarray]) -> np.ndarray:
    """Which points of the grid ``axes`` (x, y, z coordinates) lie inside a closed surface.

    Rays along z through every (x, y) grid column are intersected with the triangles and
    the crossings below each grid point counted (odd: inside).  The rays are shifted by a
    tiny irrational fraction of the spacing so that none runs through a vertex or an edge.
    """
    x, y, z = (np.asarray(a, float) for a in axes)
    dx, dy, dz = x[1] - x[0], y[1] - y[0], z[1] - z[0]
    xs, ys = x + 1e-7 * math.pi * dx, y + 1e-7 * math.e * dy
    crossings = np.zeros((len(x), len(y), len(z) + 1), np.int32)
    p = surface.points[surface.triangles]  # (m, 3 vertices, 3 coordinates)
    lo = np.ceil((p[:, :, :2].min(axis=1) - [xs[0], ys[0]]) / [dx, dy]).astype(int)
    hi = np.floor((p[:, :, :2].max(axis=1) - [xs[0], ys[0]]) / [dx, dy]).astype(int)
    for t in np.flatnonzero(np.all(hi >= lo, axis=1)):
        i = np.arange(max(lo[t, 0], 0), min(hi[t, 0], len(x) - 1) + 1)
        j = np.arange(max(lo[t, 1], 0), min(hi[t, 1], len(y) - 1) + 1)
        ii, jj = np.meshgrid(i, j, indexing="ij")
        a, b, c = p[t]
        det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
        if det == 0:
            continue  # a triangle seen edge-on from below: no ray crosses it
        qx, qy = xs[ii] - a[0], ys[jj] - a[1]
        u = (qx * (c[1] - a[1]) - qy * (c[0] - a[0])) / det
        v = (qy * (b[0] - a[0]) - qx * (b[1] - a[1])) / det
        hit = (u >= 0) & (v >= 0) & (u + v <= 1)
        zc = a[2] + u[hit] * (b[2] - a[2]) + v[hit] * (c[2] - a[2])
        k = np.clip(np.ceil((zc - z[0]) / dz).astype(int), 0, len(z))
        np.add.at(crossings, (ii[hit], jj[hit], k), 1)
    return (np.cumsum(crossings, axis=2)[:, :, :-1] % 2).astype(bool)


def depth_field(surface: Surface, spacing: float, pad: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Depth below a closed surface on a grid of the given spacing (0 outside).

    The Euclidean distance transform of the inside mask (:func:`inside_mask`): the distance
    to the nearest outside grid point, which lies on average about 0.16 spacings beyond the
    surface (measured on spheres with 25 to 40 grid points per radius); that offset is
    subtracted.  Accurate to a fraction of the spacing.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        The depth (nx, ny, nz) in m and the grid's origin.
    """
    from scipy.ndimage import distance_transform_edt

    lo = surface.points.min(axis=0) - pad * spacing
    n = np.ceil((surface.points.max(axis=0) + pad * spacing - lo) / spacing).astype(int) + 1
    axes = [lo[i] + spacing * np.arange(n[i]) for i in range(3)]
    inside = inside_mask(surface, axes)
    depth = distance_transform_edt(inside, sampling=spacing) - 0.16 * spacing
    return np.where(inside, depth, 0.0), lo


def bone_from_surface(
    source: str | Path | Surface,
    h: float,
    cortical_thickness: float | None = None,
    *,
    name: str = "bone",
    regions: Sequence[SurfaceRegion] = (),
    scale: float = 1.0,
    repair: bool = False,
    remesh: bool = True,
    comm: MPI.Comm | None = None,
    path: str | Path | None = None,
) -> MeshData | Path:
    """Tetrahedral mesh of the bone bounded by a closed surface.

    Parameters
    ----------
    source
        Surface file (STL, OBJ, PLY, OFF, VTK) or a
        :class:`~bonecontact.meshing.surface_repair.Surface`.
    h
        Element size (m): the surface is remeshed to it (``remesh``) and it bounds the
        tetrahedra's size.
    cortical_thickness
        Thickness of the cortical shell (m); ``None``: one cell group ``name``.
    name
        Prefix of the group names.
    regions
        Facet groups on the surface (:class:`SurfaceRegion`), first match wins.
    scale
        Coordinate factor of the file (``1e-3`` for millimetres).
    repair
        Repair holes, non-manifold edges and an inverted shell instead of refusing them.
    remesh
        Remesh the surface to ``h`` (pyacvd); ``False`` keeps the file's triangles.
    comm
        Communicator (``None``: ``MPI.COMM_WORLD``); the mesh is built on its rank 0.
    path
        If given, write a gmsh ``.msh`` file there (and return the path).

    Returns
    -------
    dolfinx.io.gmsh.MeshData or pathlib.Path
        Cell groups ``<name>_cortical`` and ``<name>_cancellous`` (or ``<name>``); facet
        groups: the regions' names and ``<name>_surface`` for the rest of the surface.

    Raises
    ------
    MeshInputError
        On every rank: the surface file is broken (message names the file and the defect)
        or a region selects nothing.
    bonecontact.meshing.MeshingError
        On every rank: gmsh failed (e.g. a cortex thinner than the surface's sagitta).
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    parts = _prepare_on_root(
        comm, source, h, cortical_thickness, name, regions, scale, repair, remesh
    )

    def build() -> None:
        _add_to_gmsh(*parts[:3], name=name, h=h)

    return generate(name, 3, build, comm, path)


def mesh_surface(
    source: str | Path | Surface,
    path: str | Path,
    h: float,
    cortical_thickness: float | None = None,
    *,
    name: str = "bone",
    regions: Sequence[SurfaceRegion] = (),
    scale: float = 1.0,
    repair: bool = False,
    remesh: bool = True,
    comm: MPI.Comm | None = None,
) -> MeshReport | None:
    """:func:`bone_from_surface` written to ``path``, with the report of what was made.

    Returns
    -------
    MeshReport or None
        On rank 0: cells, vertices, each group's area or volume, the volume enclosed by the
        input surface (after the repairs, before remeshing) and the change to the mesh's
        volume, every repair and remeshing, the bounding box.  ``None`` on other ranks.

    Raises
    ------
    As :func:`bone_from_surface`.
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    parts = _prepare_on_root(
        comm, source, h, cortical_thickness, name, regions, scale, repair, remesh
    )

    def build() -> None:
        _add_to_gmsh(*parts[:3], name=name, h=h)

    generate(name, 3, build, comm, path)
    if comm.rank != 0:
        return None
    outer, input_volume = parts[0], parts[3]
    notes = (f"coordinates of the file multiplied by {scale:g} (to m)",) if scale != 1 else ()
    return msh_report(path, input_measure=input_volume, repairs=outer.repairs, notes=notes)


def _prepare_on_root(comm, source, h, thickness, name, regions, scale, repair, remesh):
    """:func:`_prepare` on rank 0; its error raised on every rank (``None`` parts elsewhere)."""
    check_positive(h=h)
    if thickness is not None:
        check_positive(cortical_thickness=thickness)
    parts, error = None, None
    if comm.rank == 0:
        try:
            parts = _prepare(source, h, thickness, name, regions, scale, repair, remesh)
        except (MeshInputError, ValueError) as exc:
            error = exc
    error = comm.bcast(error, root=0)
    if error is not None:
        raise error
    return parts if parts is not None else (None,) * 4


def _prepare(source, h, thickness, name, regions, scale, repair, remesh):
    """Rank 0: the outer surface, its facet groups, the inner cortical surfaces and the
    volume enclosed by the input surface (after repairs, before remeshing)."""
    check_region_names(regions, f"{name}_surface")
    outer = prepare_surface(source, scale=scale, repair=repair)
    input_volume = outer.volume
    if remesh:
        outer = remesh_surface(outer, h)
        check_surface(outer)
    groups = select_triangles(outer, regions, f"{name}_surface")
    inner = [] if thickness is None else cortical_inner_surface(outer, thickness, h)
    return outer, groups, inner, input_volume


def _add_to_gmsh(
    outer: Surface, groups: dict[str, np.ndarray], inner: list[Surface], *, name: str, h: float
) -> None:
    """Discrete surfaces (outer patches, inner pieces), volumes and physical groups."""
    model = gmsh.model
    next_node = 1
    tags = PhysicalGroups()

    def add_surface(points: np.ndarray, triangles_by_patch: list[np.ndarray]) -> list[int]:
        nonlocal next_node
        node_tags = np.arange(next_node, next_node + len(points))
        next_node += len(points)
        entities = []
        for k, tri in enumerate(triangles_by_patch):
            e = model.addDiscreteEntity(2)
            if k == 0:
                model.mesh.addNodes(2, e, node_tags, points.ravel())
            model.mesh.addElementsByType(e, 2, [], node_tags[tri].ravel())
            entities.append(e)
        return entities

    patch_names = list(groups)
    outer_entities = add_surface(outer.points, [outer.triangles[groups[g]] for g in patch_names])
    inner_entities = [add_surface(s.points, [s.triangles])[0] for s in inner]
    geo = model.geo
    outer_loop = geo.addSurfaceLoop(outer_entities)
    inner_loops = [geo.addSurfaceLoop([e]) for e in inner_entities]
    shell = geo.addVolume([outer_loop, *inner_loops])
    cores = [geo.addVolume([loop]) for loop in inner_loops]
    geo.synchronize()
    if inner:
        tags(3, [shell], f"{name}_cortical")
        tags(3, cores, f"{name}_cancellous")
    else:
        tags(3, [shell], name)
    for g, e in zip(patch_names, outer_entities):
        tags(2, [e], g)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.option.setNumber("Mesh.Algorithm3D", 1)  # Delaunay


# ------------------------------------------------------------------------- command line
def _region_args(p) -> None:
    p.add_argument(
        "--box",
        nargs=7,
        action="append",
        default=[],
        metavar=("NAME", "X0", "Y0", "Z0", "X1", "Y1", "Z1"),
        help="facet group: triangles whose centroid lies in the box (m)",
    )
    p.add_argument(
        "--side",
        nargs=7,
        action="append",
        default=[],
        metavar=("NAME", "PX", "PY", "PZ", "NX", "NY", "NZ"),
        help="facet group: triangles on the side of the plane (point, normal) the normal points to",
    )
    p.add_argument(
        "--cone",
        nargs=5,
        action="append",
        default=[],
        metavar=("NAME", "DX", "DY", "DZ", "DEGREES"),
        help="facet group: triangles whose outward normal is within DEGREES of (DX, DY, DZ)",
    )


def surface_parser(prog: str = "bonecontact mesh-surface"):
    """The arguments of ``bonecontact mesh-surface``."""
    import argparse

    p = argparse.ArgumentParser(
        prog=prog,
        description="Tetrahedral bone (gmsh .msh) from a closed surface file (STL, OBJ, PLY, "
        "OFF, VTK): cortical shell, cancellous core, facet groups by region (first match "
        "wins). Exit status 2 for a broken surface (open, non-manifold, inverted).",
    )
    p.add_argument("surface", type=Path, help="closed surface file")
    p.add_argument("output", type=Path, help="gmsh file to write (.msh)")
    p.add_argument("--size", type=float, required=True, help="element size (m)")
    p.add_argument("--cortical", type=float, default=None, help="cortical thickness (m)")
    p.add_argument("--name", default="bone", help="prefix of the group names")
    p.add_argument("--scale", type=float, default=1.0, help="coordinate factor (1e-3: mm)")
    p.add_argument("--repair", action="store_true", help="fill holes, fix non-manifold edges")
    p.add_argument(
        "--keep-triangles", action="store_true", help="do not remesh the surface to --size"
    )
    _region_args(p)
    return p


def _regions_from_args(args) -> list[SurfaceRegion]:
    """The regions of ``--box``, ``--side``, ``--cone`` in the order of the options.

    Raises
    ------
    ValueError
        If a group name is given twice (naming both options): a facet group takes one
        region (first match wins), so a repeated name would silently drop a selection.
    """
    found: list[tuple[str, SurfaceRegion]] = []
    for b in args.box:
        box = (tuple(map(float, b[1:4])), tuple(map(float, b[4:7])))
        found.append(("--box", SurfaceRegion(b[0], box=box)))
    for p in args.side:
        plane = (tuple(map(float, p[1:4])), tuple(map(float, p[4:7])))
        found.append(("--side", SurfaceRegion(p[0], plane=plane)))
    for c in args.cone:
        found.append(("--cone", SurfaceRegion(c[0], cone=(tuple(map(float, c[1:4])), float(c[4])))))
    first: dict[str, str] = {}
    for option, region in found:
        if region.name in first or region.name == f"{args.name}_surface":
            before = first.get(region.name, "--name")
            raise ValueError(
                f"{option} {region.name}: the group {region.name!r} is already named by "
                f"{before}; each facet group takes one region option (first match wins), "
                "give each a name of its own"
            )
        first[region.name] = option
    return [region for _, region in found]


def main(argv: Sequence[str] | None = None) -> int:
    """``bonecontact mesh-surface``; prints the report (:func:`format_report`) on rank 0 and
    returns the exit status (2: bad input, 1: gmsh failed)."""
    args = surface_parser().parse_args(argv)
    comm = MPI.COMM_WORLD
    return run_report_command(
        lambda: mesh_surface(
            args.surface,
            args.output,
            args.size,
            args.cortical,
            name=args.name,
            regions=_regions_from_args(args),
            scale=args.scale,
            repair=args.repair,
            remesh=not args.keep_triangles,
            comm=comm,
        ),
        comm,
    )
