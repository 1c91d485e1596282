"""Anatomical gmsh geometries: bone sections with named physical groups.

The same conventions as :mod:`bonecontact.meshing.shapes` (SI units, first-order
triangles, rank 0 builds, ``path`` writes a gmsh ``.msh`` file instead of distributing a
DOLFINx mesh; a gmsh error is a :class:`~bonecontact.meshing.builder.MeshingError` on
every rank).  ``data/scenes/make_meshes.py`` writes the scene meshes with these builders.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from mpi4py import MPI

import gmsh
import numpy as np
from dolfinx.io.gmsh import MeshData

from bonecontact.meshing.builder import (
    EPS,
    MeshingError,
    PhysicalGroups,
    check_positive,
    entities_at,
    generate,
    set_size,
)

__all__ = ["knee_2d", "long_bone_2d"]


def long_bone_2d(
    path: str | Path | None = None,
    h: float = 1.6e-3,
    *,
    length: float = 0.2,
    width: float = 0.03,
    cortical_thickness: float = 5e-3,
    flare: float = 4e-3,
    flare_length: float = 0.03,
    comm: MPI.Comm | None = None,
) -> MeshData | Path:
    """Longitudinal section through the diaphysis of a long bone (plane strain).

    The bone axis is y, ``0 <= y <= length``, centred on ``x = 0``.  Its outer half-width
    is ``width/2`` along the shaft and grows linearly to ``width/2 + flare`` over
    ``flare_length`` at each end (the metaphyseal flare; ``flare = 0`` gives a plain
    rectangle).  Two cortical strips of constant horizontal thickness
    ``cortical_thickness`` follow the outer contour and enclose the cancellous/medullary
    core, which runs from end to end.  Cortex and core are one conforming body (OCC
    fragment: the nodes on their interface are shared).

    Exact measures: total area ``width*length + 2*flare*flare_length``, cortical area
    ``2*cortical_thickness*length``; each end has width ``width + 2*flare``.

    Parameters
    ----------
    path
        If given, write a gmsh ``.msh`` file there instead of building a DOLFINx mesh
        (``data/scenes/make_meshes.py`` writes ``data/scenes/long_bone.msh`` this way).
    h
        Target element size in m.
    length, width, cortical_thickness, flare, flare_length
        Geometry in m; ``cortical_thickness < width/2`` and ``2*flare_length < length``.
    comm
        MPI communicator (``None``: ``MPI.COMM_WORLD``).

    Returns
    -------
    dolfinx.io.gmsh.MeshData or pathlib.Path
        Cell groups ``"cortical"`` and ``"cancellous"``; facet groups ``"distal"``
        (y = 0), ``"proximal"`` (y = length) and ``"periosteum"`` (the outer sides).
    """
    _check_long_bone(h, length, width, cortical_thickness, flare, flare_length)
    shape = (width, length, flare, flare_length)

    def build() -> None:
        outer = _long_bone_polygon(shape, 0.0)
        core = _long_bone_polygon(shape, cortical_thickness)
        gmsh.model.occ.fragment([(2, outer)], [(2, core)])
        gmsh.model.occ.synchronize()
        surfaces = [t for _, t in gmsh.model.getEntities(2)]
        cortical, cancellous = _long_bone_parts(surfaces, width)
        set_size([(2, s) for s in surfaces], h)
        _long_bone_groups(cortical, cancellous, length)

    return generate("long_bone_2d", 2, build, comm, path)


def _check_long_bone(
    h: float,
    length: float,
    width: float,
    cortical_thickness: float,
    flare: float,
    flare_length: float,
) -> None:
    """Refuse a geometry :func:`long_bone_2d` cannot build (ValueError naming the key)."""
    check_positive(
        h=h,
        length=length,
        width=width,
        cortical_thickness=cortical_thickness,
        flare_length=flare_length,
    )
    if not (math.isfinite(flare) and flare >= 0):
        raise ValueError(f"flare must be >= 0 (m), got {flare!r}")
    if cortical_thickness >= width / 2:
        raise ValueError(
            f"cortical_thickness ({cortical_thickness}) must be below width/2 ({width / 2})"
        )
    if 2 * flare_length >= length:
        raise ValueError(f"2*flare_length ({2 * flare_length}) must be below length ({length})")


def _long_bone_half_profile(
    shape: tuple[float, float, float, float], offset: float
) -> list[tuple[float, float]]:
    """(x, y) of the right-hand contour of :func:`long_bone_2d` (``shape`` = width,
    length, flare, flare_length), shifted inwards by ``offset``, bottom to top."""
    width, length, flare, flare_length = shape
    w = width / 2 - offset
    if flare == 0:
        return [(w, 0.0), (w, length)]
    return [
        (w + flare, 0.0),
        (w, flare_length),
        (w, length - flare_length),
        (w + flare, length),
    ]


def _long_bone_polygon(shape: tuple[float, float, float, float], offset: float) -> int:
    """The plane surface inside the contour, mirrored about x = 0 (gmsh OCC tag)."""
    right = _long_bone_half_profile(shape, offset)
    ring = right + [(-x, y) for x, y in reversed(right)]
    occ = gmsh.model.occ
    pts = [occ.addPoint(x, y, 0) for x, y in ring]
    lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
    return occ.addPlaneSurface([occ.addCurveLoop(lines)])


def _long_bone_parts(surfaces: list[int], width: float) -> tuple[list[int], list[int]]:
    """``(cortical, cancellous)``: the core is the surface centred on x = 0, the other
    two are the cortical strips (MeshingError otherwise)."""
    cancellous = [s for s in surfaces if abs(gmsh.model.occ.getCenterOfMass(2, s)[0]) < EPS * width]
    cortical = [s for s in surfaces if s not in cancellous]
    if len(cancellous) != 1 or len(cortical) != 2:
        raise MeshingError(
            f"expected 1 core and 2 cortical strips, got {len(cancellous)} and {len(cortical)}"
        )
    return cortical, cancellous


def _long_bone_groups(cortical: list[int], cancellous: list[int], length: float) -> None:
    """Cell groups cortical/cancellous; facet groups distal (y = 0), proximal
    (y = length) and periosteum (the rest of the exterior)."""
    groups = PhysicalGroups()
    groups(2, cortical, "cortical")
    groups(2, cancellous, "cancellous")
    curves = [t for _, t in gmsh.model.getEntities(1)]
    exterior = [c for c in curves if len(gmsh.model.getAdjacencies(1, c)[0]) == 1]
    distal = entities_at(exterior, 1, 1, 0.0, length)
    proximal = entities_at(exterior, 1, 1, length, length)
    groups(1, distal, "distal")
    groups(1, proximal, "proximal")
    groups(1, [c for c in exterior if c not in distal + proximal], "periosteum")


def knee_2d(
    comm: MPI.Comm | None = None,
    path: str | Path | None = None,
    *,
    condyle_radius: float = 0.03,
    shaft_height: float = 0.03,
    plateau_half_width: float = 0.045,
    plateau_depth: float = 0.05,
    cartilage: float = 3e-3,
    cortical: float = 2e-3,
    h_contact: float = 4e-4,
    h_far: float = 4e-3,
    tibia_ratio: float = 1.6,
    tumour: tuple[float, float, float] | None = None,
    plateau_radius: float | None = None,
) -> MeshData | Path:
    """A 2D (frontal-plane) knee: a femoral condyle resting on the tibial plateau.

    Femur: the lower half of a disc of radius ``condyle_radius`` centred at
    ``(0, condyle_radius)`` under a rectangular shaft ``shaft_height`` tall; the condyle
    carries a cartilage layer (thickness ``cartilage``) over a cortical shell
    (``cortical``) around a cancellous core.  Tibia: the block
    ``[-w, w] x [-plateau_depth, 0]`` with a cartilage layer on top over a cortical
    (subchondral) plate and a cancellous core.  The two bones touch at the origin with
    zero gap; they are meshed separately (non-matching at the joint, element sizes
    ``h_contact`` (femur) and ``tibia_ratio * h_contact`` (tibia) near the contact,
    ``h_far`` away from it), each bone's layers conforming.  With ``plateau_radius`` the
    plateau is concave instead of flat: its cartilage surface is the arc of that radius
    (larger than ``condyle_radius``) centred at ``(0, plateau_radius)``, through the
    origin, with the cartilage and cortical layers offset from it (concentric arcs), so
    the joint conforms (``plateau_half_width`` must then be below ``plateau_radius``).

    Returns
    -------
    dolfinx.io.gmsh.MeshData or pathlib.Path
        Cell groups ``femur_cartilage``, ``femur_cortical``, ``femur_cancellous``,
        ``tibia_cartilage``, ``tibia_cortical``, ``tibia_cancellous``; facet groups
        ``femur_contact`` (cartilage surface of the condyle: slave), ``tibia_contact``
        (cartilage surface of the plateau: master), ``femur_top``, ``femur_sides`` (the
        vertical sides of the shaft), ``tibia_bottom``.  With ``tumour = (x, y, r)`` (a
        disc inside the tibial cancellous bone) also the cell group ``tibia_tumour``.
    """
    check_positive(
        condyle_radius=condyle_radius,
        shaft_height=shaft_height,
        plateau_half_width=plateau_half_width,
        plateau_depth=plateau_depth,
        cartilage=cartilage,
        cortical=cortical,
        h_contact=h_contact,
        h_far=h_far,
        tibia_ratio=tibia_ratio,
    )
    knee = _Knee(
        condyle_radius, shaft_height, plateau_half_width, plateau_depth, cartilage, cortical, tumour
    )
    if cartilage + cortical >= knee.R / 2:
        raise ValueError("cartilage + cortical must be well below the condyle radius")
    if plateau_radius is not None:
        if not (condyle_radius < plateau_radius and plateau_half_width < plateau_radius):
            raise ValueError(
                "plateau_radius must exceed condyle_radius and plateau_half_width, got "
                f"{plateau_radius} (condyle {condyle_radius}, half width {plateau_half_width})"
            )
        knee.plateau_radius = plateau_radius

    def build() -> None:
        fem_map = _knee_femur(knee)
        tib_map = _knee_tibia(knee)
        gmsh.model.occ.synchronize()
        _knee_classify_surfaces(knee, fem_map, tib_map)
        _knee_find_curves(knee)
        _knee_size_fields(knee, h_contact, h_far, tibia_ratio)
        _knee_physical_groups(knee)

    return generate("knee_2d", 2, build, comm, path)


@dataclass
class _Knee:
    """Dimensions of :func:`knee_2d` and, once built, its surfaces and curves by group name."""

    R: float
    shaft_height: float
    w: float
    plateau_depth: float
    cartilage: float
    cortical: float
    tumour: tuple[float, float, float] | None
    plateau_radius: float | None = None
    surfaces: dict[str, list[int]] = field(default_factory=dict)
    curves: dict[str, list[int]] = field(default_factory=dict)

    @property
    def big(self) -> float:
        """A length that reaches past the whole geometry."""
        return 4 * self.R

    @property
    def rim(self) -> float:
        """Height of the plateau's cartilage surface at its sides (0 if flat)."""
        if self.plateau_radius is None:
            return 0.0
        return self.plateau_radius - math.sqrt(self.plateau_radius**2 - self.w**2)


def _knee_femur(k: _Knee) -> list:
    """Condyle (cartilage, cortical shell, cancellous core) and shaft, fragmented: the fragment
    map."""
    occ = gmsh.model.occ
    R, big = k.R, k.big

    def lower_half(r: float) -> int:
        d = occ.addDisk(0, R, 0, r, r)
        cut, _ = occ.cut([(2, d)], [(2, occ.addRectangle(-big, R, 0, 2 * big, big))])
        return cut[0][1]

    outer, mid, inner = (
        lower_half(R),
        lower_half(R - k.cartilage),
        lower_half(R - k.cartilage - k.cortical),
    )
    cart, _ = occ.cut([(2, outer)], [(2, mid)], removeTool=False)
    cort, _ = occ.cut([(2, mid)], [(2, inner)], removeTool=False)
    shaft = occ.addRectangle(-R, R, 0, 2 * R, k.shaft_height)
    fem_parts = [cart[0], cort[0], (2, inner), (2, shaft)]
    _, fem_map = occ.fragment(fem_parts, [])
    return fem_map


def _knee_tumour_disc(k: _Knee) -> list:
    """The tumour disc as a list of one dim-tag (empty without a tumour), checked to lie in
    the tibial cancellous bone."""
    if k.tumour is None:
        return []
    tx, ty, tr = k.tumour
    w, depth, top = k.w, k.plateau_depth, -k.cartilage - k.cortical
    if not (-w < tx - tr and tx + tr < w and -depth < ty - tr and ty + tr < top):
        raise ValueError(f"tumour disc {k.tumour} must lie inside the tibial cancellous bone")
    return [(2, gmsh.model.occ.addDisk(tx, ty, 0, tr, tr))]


def _knee_tibia(k: _Knee) -> list:
    """Plateau layers (cancellous, cortical, cartilage) and the tumour disc, fragmented: the
    lists of dim-tags of each, in that order."""
    if k.plateau_radius is not None:
        return _knee_tibia_concave(k)
    occ = gmsh.model.occ
    w, plateau_depth, cartilage, cortical = k.w, k.plateau_depth, k.cartilage, k.cortical
    t_canc = occ.addRectangle(-w, -plateau_depth, 0, 2 * w, plateau_depth - cartilage - cortical)
    t_cort = occ.addRectangle(-w, -cartilage - cortical, 0, 2 * w, cortical)
    t_cart = occ.addRectangle(-w, -cartilage, 0, 2 * w, cartilage)
    t_parts = [(2, t_canc), (2, t_cort), (2, t_cart)] + _knee_tumour_disc(k)
    _, tib_map = occ.fragment(t_parts, [])
    return tib_map


def _knee_tibia_concave(k: _Knee) -> list:
    """The concave plateau: the block under the rim minus the disc of ``plateau_radius``,
    split by the concentric arcs of the cartilage and cortical layers."""
    occ = gmsh.model.occ
    Rt, w, depth = k.plateau_radius, k.w, k.plateau_depth
    block = occ.addRectangle(-w, -depth, 0, 2 * w, depth + k.rim)
    discs = [
        occ.addDisk(0, Rt, 0, r, r) for r in (Rt, Rt + k.cartilage, Rt + k.cartilage + k.cortical)
    ]
    tumour = _knee_tumour_disc(k)
    _, fmap = occ.fragment([(2, block)] + [(2, d) for d in discs] + tumour, [])
    in_block, d0, d1, d2 = ({t for _, t in m} for m in fmap[:4])
    cart = sorted((in_block & d1) - d0)
    cort = sorted((in_block & d2) - d1)
    canc = sorted(in_block - d2)
    keep = set(cart) | set(cort) | set(canc)
    drop = sorted((d0 | d1 | d2) - keep)
    if drop:
        occ.remove([(2, t) for t in drop], recursive=True)
    parts = [[(2, t) for t in part] for part in (canc, cort, cart)]
    if tumour:
        parts.append([(2, t) for _, t in fmap[4]])
    return parts


def _knee_classify_surfaces(k: _Knee, fem_map: list, tib_map: list) -> None:
    """The surfaces of each cell group, from the fragment maps."""
    f_cart = [t for _, t in fem_map[0]]
    f_cort = [t for _, t in fem_map[1]]
    f_canc = [t for _, t in fem_map[2]] + [t for _, t in fem_map[3]]
    tb_canc, tb_cort, tb_cart = ([t for _, t in tib_map[i]] for i in range(3))
    tb_tum = [t for _, t in tib_map[3]] if k.tumour is not None else []
    tb_canc = [t for t in tb_canc if t not in tb_tum]
    k.surfaces = {
        "femur_cartilage": f_cart,
        "femur_cortical": f_cort,
        "femur_cancellous": f_canc,
        "tibia_cartilage": tb_cart,
        "tibia_cortical": tb_cort,
        "tibia_cancellous": tb_canc,
        "tibia_tumour": tb_tum,
    }


def _curves_of(surfs: list[int]) -> set[int]:
    return {abs(c) for s in surfs for _, c in gmsh.model.getBoundary([(2, s)], oriented=False)}


def _knee_find_curves(k: _Knee) -> None:
    """The curves of each facet group: contact surfaces, femur top and sides, tibia bottom."""
    R, s = k.R, k.surfaces
    f_cart, f_canc = s["femur_cartilage"], s["femur_cancellous"]
    tb_canc = s["tibia_cancellous"]
    tol = 1e-7 * R

    def midpoint(c):
        lo, hi = gmsh.model.getParametrizationBounds(1, c)
        return np.asarray(gmsh.model.getValue(1, c, [0.5 * (lo[0] + hi[0])])[:2])

    com = gmsh.model.occ.getCenterOfMass
    fem_contact = [
        c
        for c in _curves_of(f_cart)
        if abs(np.hypot(*(midpoint(c) - np.array([0.0, R]))) - R) < 1e-6 * R
        and midpoint(c)[1] < R - tol
    ]
    fem_top = [c for c in _curves_of(f_canc) if abs(com(1, c)[1] - (R + k.shaft_height)) < tol]
    fem_sides = [
        c for c in _curves_of(f_canc) if abs(abs(com(1, c)[0]) - R) < tol and com(1, c)[1] > R + tol
    ]
    tib_contact = _knee_tibia_contact(k, midpoint)
    tib_bottom = [c for c in _curves_of(tb_canc) if abs(com(1, c)[1] + k.plateau_depth) < tol]
    k.curves = {
        "femur_contact": fem_contact,
        "tibia_contact": tib_contact,
        "femur_top": fem_top,
        "femur_sides": fem_sides,
        "tibia_bottom": tib_bottom,
    }


def _knee_tibia_contact(k: _Knee, midpoint) -> list[int]:
    """The curves of the plateau's cartilage surface (flat: on y = 0; concave: on its arc)."""
    tb_cart, R = k.surfaces["tibia_cartilage"], k.R
    if k.plateau_radius is None:
        return [
            c
            for c in _curves_of(tb_cart)
            if abs(gmsh.model.occ.getCenterOfMass(1, c)[1]) < 1e-7 * R
        ]
    Rt = k.plateau_radius
    centre = np.array([0.0, Rt])
    return [
        c
        for c in _curves_of(tb_cart)
        if abs(np.hypot(*(midpoint(c) - centre)) - Rt) < 1e-6 * Rt and midpoint(c)[1] < Rt
    ]


def _knee_size_fields(k: _Knee, h_contact: float, h_far: float, tibia_ratio: float) -> None:
    """Background size: fine near the joint in each bone, the thin tibial layers resolved."""
    R, s, big, cartilage, cortical = k.R, k.surfaces, k.big, k.cartilage, k.cortical
    tb_cart = s["tibia_cartilage"]
    femur = s["femur_cartilage"] + s["femur_cortical"] + s["femur_cancellous"]
    tibia = tb_cart + s["tibia_cortical"] + s["tibia_cancellous"] + s["tibia_tumour"]
    f = gmsh.model.mesh.field
    fields = []
    for surfs, h in ((femur, h_contact), (tibia, tibia_ratio * h_contact)):
        dist = f.add("Distance")
        f.setNumbers(dist, "CurvesList", k.curves["femur_contact"] + k.curves["tibia_contact"])
        f.setNumber(dist, "Sampling", 200)
        thr = f.add("Threshold")
        f.setNumber(thr, "InField", dist)
        f.setNumber(thr, "SizeMin", h)
        f.setNumber(thr, "SizeMax", h_far)
        f.setNumber(thr, "DistMin", 0.15 * R)
        f.setNumber(thr, "DistMax", 0.8 * R)
        box = f.add("Box")  # keep the thin layers resolved everywhere
        f.setNumber(box, "VIn", min(h_far, cartilage / 2))
        f.setNumber(box, "VOut", h_far)
        f.setNumber(box, "XMin", -big)
        f.setNumber(box, "XMax", big)
        f.setNumber(box, "YMin", -cartilage - cortical)
        f.setNumber(box, "YMax", k.rim)
        res = f.add("Restrict")
        mn = f.add("Min")
        f.setNumbers(mn, "FieldsList", [thr] + ([box] if surfs[0] in tb_cart else []))
        f.setNumber(res, "InField", mn)
        f.setNumbers(res, "SurfacesList", surfs)
        f.setNumbers(res, "CurvesList", sorted(_curves_of(surfs)))
        fields.append(res)
    fmin = f.add("Min")
    f.setNumbers(fmin, "FieldsList", fields)
    f.setAsBackgroundMesh(fmin)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)


def _knee_physical_groups(k: _Knee) -> None:
    """Cell groups (non-empty ones), then the facet groups, in a fixed order (fixed tags)."""
    groups = PhysicalGroups()
    for name, tags in k.surfaces.items():
        if tags:
            groups(2, tags, name)
    for name, tags in k.curves.items():
        groups(1, tags, name)
