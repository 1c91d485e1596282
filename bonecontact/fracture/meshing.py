"""Meshing a 2D body with a crack: two separate faces, graded towards the tips
(docs/theory/fracture.md#crack-meshing).

The body is a polygon (``outline``) with optional circular holes; the crack polyline is
embedded in it (OCC ``fragment``), the body is meshed with a size field
``h(d) = min(h_tip + grading · d, h_max)`` of the distance ``d`` to the nearest tip (and
to each hole), and gmsh's ``Crack`` plugin then duplicates the nodes along the crack:
the two faces become separate boundaries sharing only the tip nodes (the mouth nodes of
an edge crack are duplicated too).  The faces are the facet groups ``crack_plus`` (the
side to the left of the polyline direction ``points[0] → points[-1]``) and
``crack_minus``.  Everything gmsh does runs on rank 0; the mesh is then distributed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from contextlib import nullcontext
from dataclasses import dataclass, field

from mpi4py import MPI

import gmsh
import numpy as np
import numpy.typing as npt
from dolfinx import mesh
from dolfinx.io.gmsh import model_to_mesh

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.crack import Crack2D, point_segment_distance
from bonecontact.fracture.crack_split import crack_surface, split_checked
from bonecontact.meshing.builder import MeshingError
from bonecontact.meshing.session import gmsh_session

__all__ = ["CrackedMesh", "Hole", "TipMesh", "mesh_cracked_body"]

_CRACK_GROUP = 1000
_PLUS_GROUP = 1001
_MOUTH_GROUP = 1002


@dataclass(frozen=True)
class TipMesh:
    """Mesh sizes around a crack tip.

    Parameters
    ----------
    h_tip
        Element size at the tip (m).
    grading
        Growth of the element size with the distance d to the tip, h = h_tip + grading · d
        (dimensionless; 0.1 fine … 0.5 coarse).
    h_max
        Largest element size (m); ``None``: a tenth of the body's extent.
    """

    h_tip: float
    grading: float = 0.25
    h_max: float | None = None

    def __post_init__(self) -> None:
        for key in ("h_tip", "grading") + (("h_max",) if self.h_max is not None else ()):
            v = getattr(self, key)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(key, f"must be a positive number, got {v!r}")


@dataclass(frozen=True)
class Hole:
    """A circular hole of the body: centre (m), radius (m), element size on its edge (m)."""

    centre: tuple[float, float]
    radius: float
    h: float

    def __post_init__(self) -> None:
        for key in ("radius", "h"):
            v = getattr(self, key)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(f"hole.{key}", f"must be a positive number, got {v!r}")


@dataclass
class CrackedMesh:
    """A distributed mesh of a cracked body and its groups.

    Attributes
    ----------
    mesh, cell_tags, facet_tags
        The DOLFINx mesh and markers.
    crack
        The crack (``None`` for an uncracked body).
    groups
        Group name → tag: ``"body"`` (cells), ``"edge<i>"`` (the outline side from
        ``outline[i]`` to ``outline[i+1]``), ``"hole<j>"``, ``"crack_plus"``,
        ``"crack_minus"`` (facets).
    outline
        The polygon of the body, shape (n, 2).
    """

    mesh: mesh.Mesh
    cell_tags: mesh.MeshTags
    facet_tags: mesh.MeshTags
    crack: Crack2D | None
    groups: dict[str, int] = field(default_factory=dict)
    outline: npt.NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))

    @property
    def face_tags(self) -> tuple[int, int]:
        """Facet tags ``(crack_plus, crack_minus)``."""
        return self.groups["crack_plus"], self.groups["crack_minus"]


# ------------------------------------------------------------------------ gmsh (rank 0)
def _curve_point(tag: int) -> npt.NDArray[np.float64]:
    """A point half-way along curve ``tag`` (by parameter)."""
    lo, hi = gmsh.model.getParametrizationBounds(1, tag)
    return np.asarray(gmsh.model.getValue(1, tag, [0.5 * (lo[0] + hi[0])])[:2])


def _classify_curves(
    outline: np.ndarray, holes: Sequence[Hole], crack: Crack2D | None, tol: float
) -> dict[str, list[int]]:
    """Name every model curve: ``edge<i>``, ``hole<j>`` or ``crack``."""
    names: dict[str, list[int]] = {}
    edges = [(outline[i], outline[(i + 1) % len(outline)]) for i in range(len(outline))]
    for _, tag in gmsh.model.getEntities(1):
        p = _curve_point(tag)
        name = None
        if crack is not None:
            pts = crack.points
            if (
                min(point_segment_distance(p, pts[k], pts[k + 1]) for k in range(len(pts) - 1))
                < tol
            ):
                name = "crack"
        for i, (a, b) in enumerate(edges):
            if name is None and point_segment_distance(p, a, b) < tol:
                name = f"edge{i}"
        for j, h in enumerate(holes):
            if name is None and abs(np.linalg.norm(p - np.asarray(h.centre)) - h.radius) < tol:
                name = f"hole{j}"
        if name is None:
            raise MeshingError(f"curve {tag} at {p.tolist()} belongs to no input boundary")
        names.setdefault(name, []).append(tag)
    return names


def point_tag(p: np.ndarray, tol: float) -> int:
    ents = gmsh.model.getEntitiesInBoundingBox(
        p[0] - tol, p[1] - tol, -tol, p[0] + tol, p[1] + tol, tol, dim=0
    )
    if len(ents) != 1:
        raise MeshingError(f"expected one geometry point at {p.tolist()}, found {len(ents)}")
    return ents[0][1]


def size_fields(
    tips: list[int],
    holes: Sequence[Hole],
    hole_curves: list[list[int]],
    size: TipMesh,
    h_max: float,
) -> None:
    """Background size: the minimum of the tip and hole gradings, capped at ``h_max``."""
    fld = gmsh.model.mesh.field
    evals = []

    def graded(dist: int, h0: float) -> None:
        f = fld.add("MathEval")
        fld.setString(f, "F", f"Min({h0!r} + {size.grading!r}*F{dist}, {h_max!r})")
        evals.append(f)

    for t in tips:
        d = fld.add("Distance")
        fld.setNumbers(d, "PointsList", [t])
        graded(d, size.h_tip)
    for h, curves in zip(holes, hole_curves, strict=True):
        d = fld.add("Distance")
        fld.setNumbers(d, "CurvesList", curves)
        fld.setNumber(d, "Sampling", max(20, int(2 * math.pi * h.radius / h.h)))
        graded(d, h.h)
    if not evals:
        f = fld.add("MathEval")
        fld.setString(f, "F", repr(h_max))
        evals.append(f)
    m = fld.add("Min")
    fld.setNumbers(m, "FieldsList", evals)
    fld.setAsBackgroundMesh(m)
    for opt in ("MeshSizeFromPoints", "MeshSizeExtendFromBoundary", "MeshSizeFromCurvature"):
        gmsh.option.setNumber(f"Mesh.{opt}", 0)


def _build_geometry(outline: np.ndarray, holes: Sequence[Hole], crack: Crack2D | None) -> None:
    occ = gmsh.model.occ
    pts = [occ.addPoint(x, y, 0) for x, y in outline]
    lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
    loops = [occ.addCurveLoop(lines)]
    for h in holes:
        c = occ.addCircle(h.centre[0], h.centre[1], 0, h.radius)
        loops.append(occ.addCurveLoop([c]))
    surface = occ.addPlaneSurface(loops)
    if crack is not None:
        cp = [occ.addPoint(x, y, 0) for x, y in crack.points]
        cl = [occ.addLine(cp[i], cp[i + 1]) for i in range(len(cp) - 1)]
        occ.fragment([(2, surface)], [(1, t) for t in cl])
    occ.synchronize()


def split_crack(
    names: dict[str, list[int]],
    crack: Crack2D,
    tol: float,
    crack_group: int = _CRACK_GROUP,
    plus_group: int = _PLUS_GROUP,
    mouth_group: int = _MOUTH_GROUP,
    label: str = "crack",
    renumber: bool = True,
) -> None:
    """Duplicate the crack nodes (gmsh ``Crack`` plugin); the tips stay shared.  The two
    faces become the physical groups ``crack_group`` and ``plus_group`` (named
    ``<label>_a`` and ``<label>_b``; the curves are ``names["crack"]``).  Several cracks
    are split one after the other, each with its own groups and label, the nodes
    renumbered after the last (``renumber``).  The split is checked and, where the
    plugin left a segment unsplit, redone
    (:func:`~bonecontact.fracture.crack_split.split_checked`; a split still wrong is a
    :class:`MeshingError` naming ``label``)."""
    mouths = [point_tag(crack.points[e], tol) for e in crack.mouth_ends]
    before = crack_surface(names["crack"], mouths, dim=1)
    gmsh.model.addPhysicalGroup(1, names["crack"], crack_group)
    if crack.mouth_ends:
        gmsh.model.addPhysicalGroup(0, mouths, mouth_group)
    plugin = gmsh.plugin
    plugin.setNumber("Crack", "Dimension", 1)
    plugin.setNumber("Crack", "PhysicalGroup", crack_group)
    plugin.setNumber("Crack", "NewPhysicalGroup", plus_group)
    plugin.setNumber("Crack", "OpenBoundaryPhysicalGroup", mouth_group if crack.mouth_ends else 0)
    plugin.run("Crack")
    if crack.mouth_ends:
        gmsh.model.removePhysicalGroups([(0, mouth_group)])
    gmsh.model.setPhysicalName(1, crack_group, f"{label}_a")
    gmsh.model.setPhysicalName(1, plus_group, f"{label}_b")
    split_checked(before, (crack_group, plus_group), label)
    if renumber:  # the plugin leaves node tags with gaps; DOLFINx's reader needs none
        gmsh.model.mesh.renumberNodes()
        gmsh.model.mesh.renumberElements()


def _build_and_mesh(
    outline: np.ndarray,
    holes: Sequence[Hole],
    crack: Crack2D | None,
    size: TipMesh,
    h_max: float,
    scale: float,
) -> dict[str, int]:
    """Geometry, groups, sizes, mesh and crack split on rank 0; returns group name → tag."""
    tol = 1e-7 * scale
    _build_geometry(outline, holes, crack)
    names = _classify_curves(outline, holes, crack, tol)
    tips = [point_tag(crack.points[e], tol) for e in crack.tip_ends] if crack else []
    hole_curves = [names[f"hole{j}"] for j in range(len(holes))]
    size_fields(tips, holes, hole_curves, size, h_max)
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    groups: dict[str, int] = {"body": 1}
    surfaces = [t for _, t in gmsh.model.getEntities(2)]
    gmsh.model.addPhysicalGroup(2, surfaces, 1, name="body")
    for k, (name, curves) in enumerate(sorted(names.items()), start=2):
        if name != "crack":
            gmsh.model.addPhysicalGroup(1, curves, k, name=name)
            groups[name] = k
    gmsh.model.mesh.generate(2)
    if crack is not None:
        split_crack(names, crack, tol)
        groups["crack_a"], groups["crack_b"] = _CRACK_GROUP, _PLUS_GROUP
    return groups


# --------------------------------------------------------------------- DOLFINx side
def left_side_sign(cm: CrackedMesh, tag: int) -> int:
    """+1 if the cells behind facet group ``tag`` lie left of the crack polyline, else −1."""
    msh, crack = cm.mesh, cm.crack
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    facets = cm.facet_tags.find(tag)
    nf = msh.topology.index_map(tdim - 1).size_local
    facets = facets[facets < nf]
    total = 0.0
    if facets.size:
        cells = np.array([f2c.links(f)[0] for f in facets], dtype=np.int32)
        fmid = mesh.compute_midpoints(msh, tdim - 1, facets)[:, :2]
        cmid = mesh.compute_midpoints(msh, tdim, cells)[:, :2]
        pts = crack.points
        for fm, cmd in zip(fmid, cmid, strict=True):
            k = int(
                np.argmin(
                    [point_segment_distance(fm, pts[i], pts[i + 1]) for i in range(len(pts) - 1)]
                )
            )
            t = pts[k + 1] - pts[k]
            left = np.array([-t[1], t[0]])
            total += float(np.sign(np.dot(cmd - fm, left)))
    total = msh.comm.allreduce(total, op=MPI.SUM)
    if total == 0:
        raise MeshingError("cannot tell the sides of the crack faces apart")
    return 1 if total > 0 else -1


def mesh_cracked_body(
    outline: Sequence[Sequence[float]],
    crack: Crack2D | None,
    size: TipMesh,
    comm: MPI.Comm | None = None,
    holes: Sequence[Hole] = (),
) -> CrackedMesh:
    """Mesh a polygonal body with circular holes and a crack with two separate faces.

    Parameters
    ----------
    outline
        Polygon of the body, counter-clockwise or clockwise, shape (n, 2), m.
    crack
        The crack (inside the body; a mouth on the outline), or ``None``.
    size
        Tip size and grading (:class:`TipMesh`).
    comm
        MPI communicator (``None``: ``MPI.COMM_WORLD``).
    holes
        Circular holes (:class:`Hole`), graded like the tips from their own edge size.

    Returns
    -------
    CrackedMesh

    Raises
    ------
    ParameterError
        The crack does not lie in the body (on every rank).
    MeshingError
        gmsh failed (on every rank).
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    poly = np.asarray(outline, dtype=float)
    scale = float(np.ptp(poly, axis=0).max())
    if crack is not None:
        crack.check_inside(poly, [(h.centre[0], h.centre[1], h.radius) for h in holes], scale)
    h_max = size.h_max if size.h_max is not None else scale / 10
    groups, error = None, None
    with gmsh_session("cracked_body") if comm.rank == 0 else nullcontext():
        if comm.rank == 0:
            try:
                groups = _build_and_mesh(poly, holes, crack, size, h_max, scale)
            except Exception as exc:  # reported on every rank below
                error = f"{type(exc).__name__}: {exc}"
        error = comm.bcast(error, root=0)
        if error is not None:
            raise MeshingError(f"cracked body: {error}")
        groups = comm.bcast(groups, root=0)
        md = model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=2)
    cm = CrackedMesh(md.mesh, md.cell_tags, md.facet_tags, crack, groups, poly)
    if crack is not None:
        a, b = groups.pop("crack_a"), groups.pop("crack_b")
        plus, minus = (a, b) if left_side_sign(cm, a) > 0 else (b, a)
        groups["crack_plus"], groups["crack_minus"] = plus, minus
    return cm
