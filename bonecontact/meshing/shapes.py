"""Parametric gmsh geometries with named physical groups (the bone sections are in
:mod:`bonecontact.meshing.anatomy`).

Every builder creates a gmsh model on rank 0 of ``comm`` and either distributes it as a
DOLFINx mesh (returning :class:`dolfinx.io.gmsh.MeshData`, whose ``physical_groups`` maps
each group name to its ``(dim, tag)``) or, when ``path`` is given, writes a gmsh ``.msh``
file there (rank 0 writes, every rank returns the :class:`~pathlib.Path`).  Such a file is
what a scene's ``mesh`` key names; ``dolfinx.io.gmsh.read_from_msh`` reads it back.

Units are SI (m).  Conventions shared by all builders:

* 2D meshes are triangles in the x–y plane, 3D meshes tetrahedra; first order.
* ``y`` is "up": ``bottom`` is the face ``y = 0`` and ``top`` the face of largest ``y``;
  ``left``/``right`` are ``x = 0``/``x = max``; in 3D ``front``/``back`` are
  ``z = 0``/``z = max``.
* ``h`` is the target element size.  Physical-group tags are unique over all dimensions.

gmsh is initialised only if it is not already (and then finalised again), with terminal
output off (:func:`bonecontact.meshing.session.gmsh_session`); a gmsh error on rank 0 is
raised as :class:`~bonecontact.meshing.builder.MeshingError` on every rank.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

import gmsh
from dolfinx.io.gmsh import MeshData

from bonecontact.meshing.builder import (
    PhysicalGroups,
    block_groups,
    boundary_tags,
    bounding_box,
    check_positive,
    entities_at,
    generate,
    set_size,
)

__all__ = [
    "box",
    "cantilever",
    "hertz_2d",
    "hertz_3d",
    "quarter_tube",
    "rectangle",
    "stacked_blocks_2d",
    "two_blocks_2d",
    "two_boxes_3d",
]


# ----------------------------------------------------------------------------- builders
def quarter_tube(
    r_in: float, r_out: float, h: float, comm: MPI.Comm | None, path: str | Path | None = None
) -> MeshData | Path:
    """Quarter of a thick-walled tube cross-section (plane strain; Lamé problem).

    The annulus ``r_in <= r <= r_out`` in the first quadrant ``x, y >= 0``.

    Parameters
    ----------
    r_in, r_out
        Inner and outer radius in m, ``0 < r_in < r_out``.
    h
        Target element size in m.
    comm
        MPI communicator (``None``: ``MPI.COMM_WORLD``).
    path
        If given, write a gmsh ``.msh`` file there instead of building a DOLFINx mesh.

    Returns
    -------
    dolfinx.io.gmsh.MeshData or pathlib.Path
        Cell group ``"tube"``; facet groups ``"inner"`` (r = r_in), ``"outer"``
        (r = r_out), ``"x0"`` (the edge on x = 0) and ``"y0"`` (the edge on y = 0).
    """
    check_positive(r_in=r_in, r_out=r_out, h=h)
    if r_in >= r_out:
        raise ValueError(f"r_in must be smaller than r_out, got r_in={r_in}, r_out={r_out}")

    def build() -> None:
        occ = gmsh.model.occ
        c = occ.addPoint(0, 0, 0)
        p = [
            occ.addPoint(r_in, 0, 0),
            occ.addPoint(r_out, 0, 0),
            occ.addPoint(0, r_out, 0),
            occ.addPoint(0, r_in, 0),
        ]
        y0 = occ.addLine(p[0], p[1])
        outer = occ.addCircleArc(p[1], c, p[2])
        x0 = occ.addLine(p[2], p[3])
        inner = occ.addCircleArc(p[3], c, p[0])
        surface = occ.addPlaneSurface([occ.addCurveLoop([y0, outer, x0, inner])])
        occ.remove([(0, c)])
        occ.synchronize()
        set_size([(2, surface)], h)
        groups = PhysicalGroups()
        groups(2, [surface], "tube")
        for tag, name in ((inner, "inner"), (outer, "outer"), (x0, "x0"), (y0, "y0")):
            groups(1, [tag], name)

    return generate("quarter_tube", 2, build, comm, path)


def rectangle(
    lx: float,
    ly: float,
    nx: int,
    ny: int,
    comm: MPI.Comm | None,
    path: str | Path | None = None,
    structured: bool = False,
) -> MeshData | Path:
    """Rectangle ``[0, lx] x [0, ly]`` with ``nx`` x ``ny`` element edges along its sides.

    Parameters
    ----------
    lx, ly
        Side lengths in m.
    nx, ny
        Number of element edges along the x and y sides (exact on the boundary).
    comm
        MPI communicator (``None``: ``MPI.COMM_WORLD``).
    path
        If given, write a gmsh ``.msh`` file there instead of building a DOLFINx mesh.
    structured
        ``True``: a structured (transfinite) triangulation, two triangles per grid cell;
        ``False``: an unstructured triangulation of the interior.

    Returns
    -------
    dolfinx.io.gmsh.MeshData or pathlib.Path
        Cell group ``"body"``; facet groups ``"left"`` (x = 0), ``"right"`` (x = lx),
        ``"bottom"`` (y = 0), ``"top"`` (y = ly).
    """
    check_positive(lx=lx, ly=ly)
    if int(nx) != nx or int(ny) != ny or nx < 1 or ny < 1:
        raise ValueError(f"nx and ny must be positive integers, got nx={nx!r}, ny={ny!r}")

    def build() -> None:
        surface = gmsh.model.occ.addRectangle(0, 0, 0, lx, ly)
        gmsh.model.occ.synchronize()
        set_size([(2, surface)], min(lx / nx, ly / ny))
        for curve in boundary_tags(2, surface):
            b = bounding_box(1, curve)
            along_x = abs(b[3] - b[0]) > abs(b[4] - b[1])
            gmsh.model.mesh.setTransfiniteCurve(curve, int(nx if along_x else ny) + 1)
        if structured:
            gmsh.model.mesh.setTransfiniteSurface(surface)
        groups = PhysicalGroups()
        groups(2, [surface], "body")
        block_groups(groups, 2, surface, "", (0, 0), (lx, ly), max(lx, ly))

    return generate("rectangle", 2, build, comm, path)


def box(
    lx: float, ly: float, lz: float, h: float, comm: MPI.Comm | None, path: str | Path | None = None
) -> MeshData | Path:
    """Box ``[0, lx] x [0, ly] x [0, lz]`` meshed with tetrahedra of size about ``h``.

    Parameters
    ----------
    lx, ly, lz
        Edge lengths in m.
    h
        Target element size in m.
    comm
        MPI communicator (``None``: ``MPI.COMM_WORLD``).
    path
        If given, write a gmsh ``.msh`` file there instead of building a DOLFINx mesh.

    Returns
    -------
    dolfinx.io.gmsh.MeshData or pathlib.Path
        Cell group ``"body"``; facet groups ``"left"``/``"right"`` (x = 0 / lx),
        ``"bottom"``/``"top"`` (y = 0 / ly), ``"front"``/``"back"`` (z = 0 / lz).
    """
    check_positive(lx=lx, ly=ly, lz=lz, h=h)

    def build() -> None:
        volume = gmsh.model.occ.addBox(0, 0, 0, lx, ly, lz)
        gmsh.model.occ.synchronize()
        set_size([(3, volume)], h)
        groups = PhysicalGroups()
        groups(3, [volume], "body")
        block_groups(groups, 3, volume, "", (0, 0, 0), (lx, ly, lz), max(lx, ly, lz))

    return generate("box", 3, build, comm, path)


def cantilever(
    L: float, H: float, W: float, h: float, comm: MPI.Comm | None, path: str | Path | None = None
) -> MeshData | Path:
    """Slender 3D beam ``[0, L] x [0, H] x [0, W]`` along x (height H along y, width W along z).

    Parameters
    ----------
    L, H, W
        Length (x), height (y) and width (z) in m.
    h
        Target element size in m.
    comm
        MPI communicator (``None``: ``MPI.COMM_WORLD``).
    path
        If given, write a gmsh ``.msh`` file there instead of building a DOLFINx mesh.

    Returns
    -------
    dolfinx.io.gmsh.MeshData or pathlib.Path
        Cell group ``"beam"``; facet groups ``"clamped"`` (x = 0), ``"tip"`` (x = L),
        ``"bottom"`` (y = 0), ``"top"`` (y = H) and ``"sides"`` (z = 0 and z = W).
    """
    check_positive(L=L, H=H, W=W, h=h)

    def build() -> None:
        volume = gmsh.model.occ.addBox(0, 0, 0, L, H, W)
        gmsh.model.occ.synchronize()
        set_size([(3, volume)], h)
        faces = boundary_tags(3, volume)
        scale = max(L, H, W)
        groups = PhysicalGroups()
        groups(3, [volume], "beam")
        groups(2, entities_at(faces, 2, 0, 0.0, scale), "clamped")
        groups(2, entities_at(faces, 2, 0, L, scale), "tip")
        groups(2, entities_at(faces, 2, 1, 0.0, scale), "bottom")
        groups(2, entities_at(faces, 2, 1, H, scale), "top")
        groups(
            2, entities_at(faces, 2, 2, 0.0, scale) + entities_at(faces, 2, 2, W, scale), "sides"
        )

    return generate("cantilever", 3, build, comm, path)


def _two_blocks(
    dim: int,
    size: tuple[float, ...],
    heights: tuple[float, float],
    upper_size: tuple[float, ...],
    upper_offset: tuple[float, ...],
    h: tuple[float, float],
    comm: MPI.Comm | None,
    path: str | Path | None,
    name: str,
) -> MeshData | Path:
    """Two touching, separately meshed blocks: lower at y in [0, h0], upper on top of it."""
    lower_lo = (0.0,) * dim
    lower_hi = (size[0], heights[0]) + tuple(size[1:])
    upper_lo = (upper_offset[0], heights[0]) + tuple(upper_offset[1:])
    upper_hi = (upper_lo[0] + upper_size[0], heights[0] + heights[1]) + tuple(
        upper_lo[2 + i] + upper_size[1 + i] for i in range(dim - 2)
    )
    scale = max(max(lower_hi), max(upper_hi))

    def block(lo: tuple[float, ...], hi: tuple[float, ...]) -> int:
        d = [b - a for a, b in zip(lo, hi)]
        if dim == 2:
            return gmsh.model.occ.addRectangle(lo[0], lo[1], 0, d[0], d[1])
        return gmsh.model.occ.addBox(lo[0], lo[1], lo[2], d[0], d[1], d[2])

    def build() -> None:
        # Two independent OCC entities that merely touch: no fragment, no node merging,
        # so each side of the interface is its own boundary with its own nodes.
        lower = block(lower_lo, lower_hi)
        upper = block(upper_lo, upper_hi)
        gmsh.model.occ.synchronize()
        set_size([(dim, lower)], h[0])
        set_size([(dim, upper)], h[1])
        groups = PhysicalGroups()
        groups(dim, [lower], "lower")
        groups(dim, [upper], "upper")
        block_groups(
            groups,
            dim,
            lower,
            "lower_",
            lower_lo,
            lower_hi,
            scale,
            {"top": "lower_contact", "bottom": "bottom"},
        )
        block_groups(
            groups,
            dim,
            upper,
            "upper_",
            upper_lo,
            upper_hi,
            scale,
            {"bottom": "upper_contact", "top": "top"},
        )

    return generate(name, dim, build, comm, path)


def two_blocks_2d(
    comm: MPI.Comm | None = None,
    path: str | Path | None = None,
    *,
    width: float = 0.02,
    lower_height: float = 0.01,
    upper_height: float = 0.01,
    upper_width: float | None = None,
    upper_offset: float = 0.0,
    h_lower: float = 0.02 / 7,
    h_upper: float = 0.02 / 11,
) -> MeshData | Path:
    """Two touching rectangles with non-matching meshes on their interface (contact tests).

    Lower block ``[0, width] x [0, lower_height]``; upper block
    ``[upper_offset, upper_offset + upper_width] x [lower_height, lower_height + upper_height]``.
    The blocks are separate gmsh entities meshed with their own sizes and share no nodes;
    the defaults put 7 and 11 element edges on the interface, so no interior interface
    nodes coincide.

    Parameters
    ----------
    comm
        MPI communicator (``None``: ``MPI.COMM_WORLD``).
    path
        If given, write a gmsh ``.msh`` file there instead of building a DOLFINx mesh.
    width, lower_height, upper_height, upper_width, upper_offset
        Geometry in m (``upper_width`` defaults to ``width``).
    h_lower, h_upper
        Element sizes of the two blocks in m.

    Returns
    -------
    dolfinx.io.gmsh.MeshData or pathlib.Path
        Cell groups ``"lower"``, ``"upper"``; facet groups ``"bottom"`` (y = 0),
        ``"lower_contact"`` (top of the lower block), ``"upper_contact"`` (bottom of the
        upper block), ``"top"`` (top of the upper block) and the sides
        ``"lower_left"``, ``"lower_right"``, ``"upper_left"``, ``"upper_right"``.
    """
    upper_width = width if upper_width is None else upper_width
    check_positive(
        width=width,
        lower_height=lower_height,
        upper_height=upper_height,
        upper_width=upper_width,
        h_lower=h_lower,
        h_upper=h_upper,
    )
    return _two_blocks(
        2,
        (width,),
        (lower_height, upper_height),
        (upper_width,),
        (upper_offset,),
        (h_lower, h_upper),
        comm,
        path,
        "two_blocks_2d",
    )


def two_boxes_3d(
    comm: MPI.Comm | None = None,
    path: str | Path | None = None,
    *,
    width: float = 0.02,
    depth: float = 0.02,
    lower_height: float = 0.01,
    upper_height: float = 0.01,
    upper_width: float | None = None,
    upper_depth: float | None = None,
    upper_offset: tuple[float, float] = (0.0, 0.0),
    h_lower: float = 0.02 / 5,
    h_upper: float = 0.02 / 7,
) -> MeshData | Path:
    """Two touching boxes with non-matching meshes on their interface (contact tests).

    Lower box ``[0, width] x [0, lower_height] x [0, depth]``; the upper box
    (``upper_width`` x ``upper_height`` x ``upper_depth``, its corner at
    ``(upper_offset[0], lower_height, upper_offset[1])``) sits on it.  The boxes are
    separate gmsh volumes meshed with their own sizes and share no nodes.

    Parameters
    ----------
    comm
        MPI communicator (``None``: ``MPI.COMM_WORLD``).
    path
        If given, write a gmsh ``.msh`` file there instead of building a DOLFINx mesh.
    width, depth, lower_height, upper_height, upper_width, upper_depth, upper_offset
        Geometry in m (x: width, y: height, z: depth; the upper box defaults to the
        lower one's width and depth).
    h_lower, h_upper
        Element sizes of the two boxes in m.

    Returns
    -------
    dolfinx.io.gmsh.MeshData or pathlib.Path
        Cell groups ``"lower"``, ``"upper"``; facet groups ``"bottom"`` (y = 0),
        ``"lower_contact"``, ``"upper_contact"``, ``"top"`` and the sides
        ``"lower_left"``, ``"lower_right"``, ``"lower_front"``, ``"lower_back"`` and the
        same four for ``"upper_"``.
    """
    upper_width = width if upper_width is None else upper_width
    upper_depth = depth if upper_depth is None else upper_depth
    check_positive(
        width=width,
        depth=depth,
        lower_height=lower_height,
        upper_height=upper_height,
        upper_width=upper_width,
        upper_depth=upper_depth,
        h_lower=h_lower,
        h_upper=h_upper,
    )
    return _two_blocks(
        3,
        (width, depth),
        (lower_height, upper_height),
        (upper_width, upper_depth),
        tuple(upper_offset),
        (h_lower, h_upper),
        comm,
        path,
        "two_boxes_3d",
    )


def hertz_2d(
    comm: MPI.Comm | None = None,
    path: str | Path | None = None,
    *,
    radius: float = 0.01,
    block_half_width: float = 0.05,
    block_height: float = 0.05,
    h_contact: float = 1e-4,
    h_far: float = 2e-3,
    zone: float = 2e-3,
    block_ratio: float = 1.7,
    lateral_support: bool = False,
) -> MeshData | Path:
    """A half cylinder resting on a block (plane strain Hertz contact), non-matching meshes.

    The half cylinder (the lower half of a disc of ``radius`` centred at ``(0, radius)``)
    touches the block ``[-w, w] x [-block_height, 0]`` at the origin with zero gap; the two
    bodies are separate gmsh entities (no shared nodes).  Elements have size
    ``h_contact`` (cylinder) and ``block_ratio * h_contact`` (block) within ``zone`` of
    the contact point, growing to ``h_far`` away from it.

    With ``lateral_support``, a segment of the symmetry axis inside the cylinder
    (``x = 0``, ``0.4 radius <= y <= 0.9 radius``) is embedded in its mesh as the facet
    group ``"cyl_support"``: fixing ``u_x`` there removes the two rigid modes that a
    frictionless contact cannot (the horizontal translation and the rotation about the
    centre of the circle) without carrying vertical load, and the symmetric solution
    has ``u_x = 0`` there anyway.

    Returns
    -------
    dolfinx.io.gmsh.MeshData or pathlib.Path
        Cell groups ``"cylinder"``, ``"block"``; facet groups ``"cyl_contact"`` (the arc:
        slave), ``"block_contact"`` (top of the block: master), ``"cyl_top"`` (the flat
        face y = radius), ``"block_bottom"``, ``"block_sides"`` (and ``"cyl_support"``).
    """
    check_positive(
        radius=radius,
        block_half_width=block_half_width,
        block_height=block_height,
        h_contact=h_contact,
        h_far=h_far,
        zone=zone,
        block_ratio=block_ratio,
    )

    def build() -> None:
        e = _half_disc_on_block(radius, block_half_width, block_height, lateral_support)
        cyl_curves = e.arc + e.support + [e.top]
        block_curves = e.block_top + [e.bottom, e.right, e.left]
        dist_max = zone + 20 * h_far
        sizes = [
            (e.disc, cyl_curves, h_contact),
            (e.block, block_curves, block_ratio * h_contact),
        ]
        fields = [
            _restricted_size(
                e.touching, h, h_far, zone, dist_max, {"SurfacesList": [s], "CurvesList": c}
            )
            for s, c, h in sizes
        ]
        _background_size(fields)
        _hertz_2d_groups(e)

    return generate("hertz_2d", 2, build, comm, path)


@dataclass(frozen=True)
class _HalfDiscBlock:
    """gmsh tags of :func:`hertz_2d`'s geometry."""

    disc: int
    block: int
    arc: list[int]  # the half circle (two arcs)
    top: int  # the disc's flat face
    block_top: list[int]  # the block's top (two lines meeting at the origin)
    bottom: int
    right: int
    left: int
    support: list[int]  # the embedded axis segment (or none)
    touching: list[int]  # the two points at the origin (disc, block)


def _half_disc_on_block(R: float, w: float, hb: float, lateral_support: bool) -> _HalfDiscBlock:
    """The half disc of radius ``R`` on the block ``[-w, w] x [-hb, 0]`` (two separate
    surfaces touching at the origin), with the axis segment embedded if asked."""
    occ = gmsh.model.occ
    c = occ.addPoint(0, R, 0)
    pl, p0, pr = occ.addPoint(-R, R, 0), occ.addPoint(0, 0, 0), occ.addPoint(R, R, 0)
    a1, a2 = occ.addCircleArc(pl, c, p0), occ.addCircleArc(p0, c, pr)
    top = occ.addLine(pr, pl)
    cyl = occ.addPlaneSurface([occ.addCurveLoop([a1, a2, top])])
    q = [
        occ.addPoint(-w, -hb, 0),
        occ.addPoint(w, -hb, 0),
        occ.addPoint(w, 0, 0),
        occ.addPoint(0, 0, 0),
        occ.addPoint(-w, 0, 0),
    ]
    bottom, right = occ.addLine(q[0], q[1]), occ.addLine(q[1], q[2])
    t1, t2 = occ.addLine(q[2], q[3]), occ.addLine(q[3], q[4])
    left = occ.addLine(q[4], q[0])
    block = occ.addPlaneSurface([occ.addCurveLoop([bottom, right, t1, t2, left])])
    support = []
    if lateral_support:
        support = [occ.addLine(occ.addPoint(0, 0.4 * R, 0), occ.addPoint(0, 0.9 * R, 0))]
    occ.synchronize()
    if support:
        gmsh.model.mesh.embed(1, support, 2, cyl)
    return _HalfDiscBlock(
        cyl, block, [a1, a2], top, [t1, t2], bottom, right, left, support, [p0, q[3]]
    )


def _hertz_2d_groups(e: _HalfDiscBlock) -> None:
    """The physical groups of :func:`hertz_2d`."""
    groups = PhysicalGroups()
    groups(2, [e.disc], "cylinder")
    groups(2, [e.block], "block")
    groups(1, e.arc, "cyl_contact")
    groups(1, e.block_top, "block_contact")
    groups(1, [e.top], "cyl_top")
    groups(1, [e.bottom], "block_bottom")
    groups(1, [e.left, e.right], "block_sides")
    if e.support:
        groups(1, e.support, "cyl_support")


def _restricted_size(
    points: list[int],
    h: float,
    h_far: float,
    zone: float,
    dist_max: float,
    restrict: dict[str, list[int]],
) -> int:
    """A gmsh size field: ``h`` within ``zone`` of the ``points``, growing linearly to
    ``h_far`` at the distance ``dist_max``, restricted to the entities of ``restrict``
    (gmsh list name, e.g. ``"SurfacesList"``, to tags).  Returns the field's tag."""
    f = gmsh.model.mesh.field
    dist = f.add("Distance")
    f.setNumbers(dist, "PointsList", points)
    thr = f.add("Threshold")
    f.setNumber(thr, "InField", dist)
    f.setNumber(thr, "SizeMin", h)
    f.setNumber(thr, "SizeMax", h_far)
    f.setNumber(thr, "DistMin", zone)
    f.setNumber(thr, "DistMax", dist_max)
    res = f.add("Restrict")
    f.setNumber(res, "InField", thr)
    for key, tags in restrict.items():
        f.setNumbers(res, key, tags)
    return res


def _background_size(fields: list[int]) -> None:
    """The smallest of the size ``fields`` as the only source of element sizes."""
    f = gmsh.model.mesh.field
    fmin = f.add("Min")
    f.setNumbers(fmin, "FieldsList", fields)
    f.setAsBackgroundMesh(fmin)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)


#: gmsh's volume meshers by name (the value of its ``Mesh.Algorithm3D`` option).
VOLUME_MESHERS = {"delaunay": 1, "hxt": 10}


def hertz_3d(
    comm: MPI.Comm | None = None,
    path: str | Path | None = None,
    *,
    radius: float = 0.01,
    block_half_width: float = 0.02,
    block_height: float = 0.02,
    h_contact: float = 2e-4,
    h_far: float = 3e-3,
    zone: float = 1.5e-3,
    block_ratio: float = 1.5,
    lateral_support: bool = False,
    dist_max_factor: float = 8.0,
    algorithm_3d: str = "delaunay",
) -> MeshData | Path:
    """A hemisphere resting on a block (3D Hertz contact), non-matching meshes.

    The hemisphere (the lower half of a ball of ``radius`` centred at ``(0, radius, 0)``)
    touches the block ``[-w, w] x [-block_height, 0] x [-w, w]`` at the origin; the bodies
    are separate gmsh volumes.  Element size ``h_contact`` (hemisphere) and
    ``block_ratio * h_contact`` (block) within ``zone`` of the contact point, growing
    linearly to ``h_far`` at the distance ``zone + dist_max_factor * h_far``.

    With ``lateral_support``, two rectangles inside the hemisphere, away from its
    surface, are embedded in its mesh: ``"sphere_support_x"`` in the plane ``x = 0``
    (``0.1 R <= z <= 0.35 R``) and ``"sphere_support_z"`` in the plane ``z = 0``
    (``0.1 R <= x <= 0.35 R``), both over ``0.4 R <= y <= 0.9 R``.  Fixing ``u_x`` on the
    first and ``u_z`` on the second removes the five rigid modes that a frictionless
    contact cannot (the horizontal translations and the three rotations about the
    centre of the sphere) without carrying vertical load; the axisymmetric solution
    has ``u_x = 0`` and ``u_z = 0`` on these planes anyway.

    ``algorithm_3d`` is gmsh's volume mesher: ``"delaunay"`` (the default) or ``"hxt"``
    (gmsh's parallel Delaunay: a 1M-dof mesh in seconds instead of tens of minutes, of
    the same quality; used by the 3D scaling benchmark).

    Returns
    -------
    dolfinx.io.gmsh.MeshData or pathlib.Path
        Cell groups ``"sphere"``, ``"block"``; facet groups ``"sphere_contact"`` (the
        curved surface: slave), ``"block_contact"`` (top of the block: master),
        ``"sphere_top"`` (the flat face y = radius), ``"block_bottom"`` (and
        ``"sphere_support_x"``, ``"sphere_support_z"``).
    """
    check_positive(
        radius=radius,
        block_half_width=block_half_width,
        block_height=block_height,
        h_contact=h_contact,
        h_far=h_far,
        zone=zone,
        block_ratio=block_ratio,
        dist_max_factor=dist_max_factor,
    )
    if algorithm_3d not in VOLUME_MESHERS:
        raise ValueError(
            f"hertz_3d: algorithm_3d must be one of {sorted(VOLUME_MESHERS)}, got {algorithm_3d!r}"
        )

    def build() -> None:
        e = _hemisphere_on_block(radius, block_half_width, block_height, lateral_support)
        dist_max = zone + dist_max_factor * h_far
        fields = []
        for vol, h in ((e.sphere, h_contact), (e.block, block_ratio * h_contact)):
            faces = e.sphere_faces + e.supports if vol == e.sphere else e.block_faces
            restrict = {"VolumesList": [vol], "SurfacesList": faces, "CurvesList": _curves(faces)}
            fields.append(_restricted_size([e.origin], h, h_far, zone, dist_max, restrict))
        _background_size(fields)
        gmsh.option.setNumber("Mesh.Algorithm3D", VOLUME_MESHERS[algorithm_3d])
        _hertz_3d_groups(e)

    return generate("hertz_3d", 3, build, comm, path)


@dataclass(frozen=True)
class _HemisphereBlock:
    """gmsh tags of :func:`hertz_3d`'s geometry."""

    sphere: int
    block: int
    sphere_faces: list[int]
    block_faces: list[int]
    sphere_top: list[int]  # the flat face y = R
    sphere_contact: list[int]  # the curved surface
    block_top: list[int]
    block_bottom: list[int]
    supports: list[int]  # the embedded rectangles (x = 0 first), or none
    origin: int  # a point at the touching point


def _hemisphere_on_block(R: float, w: float, hb: float, lateral_support: bool) -> _HemisphereBlock:
    """The hemisphere of radius ``R`` on the block ``[-w, w] x [-hb, 0] x [-w, w]`` (two
    separate volumes touching at the origin), its faces sorted, supports embedded if asked."""
    occ = gmsh.model.occ
    ball = occ.addSphere(0, R, 0, R)
    cut, _ = occ.cut([(3, ball)], [(3, occ.addBox(-2 * R, R, -2 * R, 4 * R, 2 * R, 4 * R))])
    sph = cut[0][1]
    block = occ.addBox(-w, -hb, -w, 2 * w, hb, 2 * w)
    occ.synchronize()
    s_faces = [t for _, t in gmsh.model.getBoundary([(3, sph)], oriented=False)]
    b_faces = [t for _, t in gmsh.model.getBoundary([(3, block)], oriented=False)]
    com = {t: gmsh.model.occ.getCenterOfMass(2, t) for t in s_faces + b_faces}
    tol = 1e-7 * R
    s_top = [t for t in s_faces if abs(com[t][1] - R) < tol]
    s_contact = [t for t in s_faces if t not in s_top]
    b_top = [t for t in b_faces if abs(com[t][1]) < tol]
    b_bottom = [t for t in b_faces if abs(com[t][1] + hb) < tol]
    supports = _sphere_supports(R, sph) if lateral_support else []
    origin = occ.addPoint(0, 0, 0)
    occ.synchronize()
    return _HemisphereBlock(
        sph, block, s_faces, b_faces, s_top, s_contact, b_top, b_bottom, supports, origin
    )


def _curves(faces: list[int]) -> list[int]:
    """The curves bounding the surfaces ``faces`` (sorted tags)."""
    boundary = gmsh.model.getBoundary([(2, t) for t in faces], combined=False, oriented=False)
    return sorted({abs(c) for _, c in boundary})


def _hertz_3d_groups(e: _HemisphereBlock) -> None:
    """The physical groups of :func:`hertz_3d`."""
    groups = PhysicalGroups()
    groups(3, [e.sphere], "sphere")
    groups(3, [e.block], "block")
    groups(2, e.sphere_contact, "sphere_contact")
    groups(2, e.block_top, "block_contact")
    groups(2, e.sphere_top, "sphere_top")
    groups(2, e.block_bottom, "block_bottom")
    if e.supports:
        groups(2, e.supports[:1], "sphere_support_x")
        groups(2, e.supports[1:], "sphere_support_z")


def _sphere_supports(R: float, sphere: int) -> list[int]:
    """Two rectangles inside the hemisphere of :func:`hertz_3d` (planes x = 0 and z = 0,
    not intersecting), embedded in its mesh; returns their surface tags (x = 0 first)."""
    occ = gmsh.model.occ
    y0, y1, s0, s1 = 0.4 * R, 0.9 * R, 0.1 * R, 0.35 * R
    corners = (
        [(0, y0, s0), (0, y1, s0), (0, y1, s1), (0, y0, s1)],  # plane x = 0
        [(s0, y0, 0), (s1, y0, 0), (s1, y1, 0), (s0, y1, 0)],  # plane z = 0
    )
    surfaces = []
    for quad in corners:
        pts = [occ.addPoint(*c) for c in quad]
        lines = [occ.addLine(pts[i], pts[(i + 1) % 4]) for i in range(4)]
        surfaces.append(occ.addPlaneSurface([occ.addCurveLoop(lines)]))
    occ.synchronize()
    gmsh.model.mesh.embed(2, surfaces, 3, sphere)
    return surfaces


def stacked_blocks_2d(
    comm: MPI.Comm | None = None,
    path: str | Path | None = None,
    *,
    width: float = 0.02,
    heights: tuple[float, ...] = (0.01, 0.01, 0.01),
    sizes: tuple[float, ...] = (0.02 / 5, 0.02 / 13, 0.02 / 8),
) -> MeshData | Path:
    """Rectangles stacked on top of each other, each meshed on its own (several
    non-matching contact interfaces; multi-pair contact tests).

    Returns
    -------
    dolfinx.io.gmsh.MeshData or pathlib.Path
        Cell groups ``"block<i>"`` (i = 1 at the bottom); facet groups ``"block<i>_top"``,
        ``"block<i>_bottom"``, ``"block<i>_left"``, ``"block<i>_right"``.
    """
    if len(heights) != len(sizes) or len(heights) < 2:
        raise ValueError("heights and sizes must have the same length (>= 2)")
    check_positive(
        width=width,
        **{f"height{i}": h for i, h in enumerate(heights)},
        **{f"size{i}": h for i, h in enumerate(sizes)},
    )

    def build() -> None:
        y0, tags = 0.0, []
        for h in heights:
            tags.append(gmsh.model.occ.addRectangle(0, y0, 0, width, h))
            y0 += h
        gmsh.model.occ.synchronize()
        groups = PhysicalGroups()
        y0 = 0.0
        scale = max(width, sum(heights))
        for i, (t, h, hs) in enumerate(zip(tags, heights, sizes), start=1):
            set_size([(2, t)], hs)
            groups(2, [t], f"block{i}")
            block_groups(groups, 2, t, f"block{i}_", (0.0, y0), (width, y0 + h), scale)
            y0 += h

    return generate("stacked_blocks_2d", 2, build, comm, path)
