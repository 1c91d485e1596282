"""Planar cracks in 3D whose front meets the free surface
(docs/theory/fracture.md#surface-breaking-cracks-in-3d).

* :class:`EllipticalArcFront` — an elliptical front that ends on the free surface: the
  part φ₀ ≤ φ ≤ φ₁ of an :class:`~bonecontact.fracture.front3d.EllipticalFront` (a
  semi-elliptical surface crack: 0 … π; a quarter-elliptical corner crack: 0 … π/2).
* :class:`StraightFront` — the straight front of a through crack, from one free surface
  to the other.
* :class:`SurfaceCrack` — the three crack shapes in a plate: ``"semi_elliptical"`` (depth
  a, half-length c, centred on the front face), ``"corner"`` (depth a along the side face,
  length c along the front face, at the corner of the two) and ``"through"`` (an edge
  crack of length a through the whole thickness).
* :func:`mesh_plate_with_crack` — the plate [−b, b] × [−h, h] × [−t, 0] with the crack
  in the plane y = 0 cut into it (gmsh, OpenCASCADE): tetrahedra graded towards the
  front, the crack nodes — the mouth on the free surface included, the front excepted —
  split by gmsh's ``Crack`` plugin into the faces ``crack_upper`` (y > 0 side) and
  ``crack_lower``, like the interior cracks of :mod:`bonecontact.fracture.body3d`.
* :func:`domain_length` — the integral's half-length along the front at a point: the
  ring radius, at most its distance to the free surface.

Both fronts follow the front protocol of :mod:`bonecontact.fracture.front3d`
(:class:`~bonecontact.fracture.front3d.CrackFront`) with ``closed = False``: the arc
length is not wrapped, the nearest front point of a point beyond an end is that end, and
``corner_distance`` is the distance along the front to the nearer free surface.
"""

from __future__ import annotations

import math
from contextlib import nullcontext
from dataclasses import dataclass

from mpi4py import MPI

import gmsh
import numpy as np
import numpy.typing as npt
from dolfinx import mesh
from dolfinx.io.gmsh import model_to_mesh

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.body3d import face_side_sign, front_vertices
from bonecontact.fracture.front3d import CrackBlock, EllipticalFront
from bonecontact.meshing.builder import MeshingError
from bonecontact.meshing.session import gmsh_session

__all__ = [
    "PLATE_GROUPS",
    "SURFACE_CRACK_KINDS",
    "EllipticalArcFront",
    "FacePair",
    "StraightFront",
    "SurfaceCrack",
    "domain_length",
    "face_pair",
    "front_nodes",
    "mesh_plate_with_crack",
]

#: Shapes of a surface-breaking crack.
SURFACE_CRACK_KINDS = ("semi_elliptical", "corner", "through")
#: Facet groups of :func:`mesh_plate_with_crack` (the crack faces come after them).
PLATE_GROUPS = {"left": 11, "right": 12, "bottom": 13, "top": 14, "back": 15, "front": 16}
_CRACK_A, _CRACK_B, _MOUTH = 21, 22, 23
#: The smallest domain half-length along the front, in front elements.
MIN_DOMAIN_ELEMENTS = 2.0


# ------------------------------------------------------------------------ fronts
@dataclass(frozen=True)
class EllipticalArcFront(EllipticalFront):
    """The arc φ₀ ≤ φ ≤ φ₁ of an elliptical front x = c + a cos φ u + b sin φ v, whose ends
    lie on the free surface.

    Parameters
    ----------
    a, b, centre, axes
        As :class:`~bonecontact.fracture.front3d.EllipticalFront` (a ≥ b).
    phi_range
        (φ₀, φ₁), 0 ≤ φ₀ < φ₁ ≤ 2π: the part of the ellipse that is the front.
    """

    phi_range: tuple[float, float] = (0.0, math.pi)

    def __post_init__(self) -> None:
        super().__post_init__()
        p0, p1 = self.phi_range
        if not (0.0 <= p0 < p1 <= 2.0 * math.pi + 1e-12):
            raise ParameterError(
                "phi_range", f"need 0 <= phi0 < phi1 <= 2 pi, got {self.phi_range}"
            )

    @property
    def closed(self) -> bool:
        """False: the front ends on the free surface."""
        return False

    def nearest(self, x: npt.ArrayLike, iterations: int = 12) -> npt.NDArray[np.float64]:
        """Parameter of the nearest point of the arc: the ellipse's, clipped to the arc
        (a point beyond an end is nearest to that end)."""
        t = super().nearest(x, iterations)
        t = np.mod(t - self.phi_range[0], 2.0 * math.pi) + self.phi_range[0]
        over = t > self.phi_range[1]
        if np.any(over):  # past the far end: the nearer of the two ends
            d0 = np.mod(self.phi_range[0] - t[over], 2.0 * math.pi)
            d1 = t[over] - self.phi_range[1]
            t[over] = np.where(d1 <= d0, self.phi_range[1], self.phi_range[0])
        return t

    @property
    def perimeter(self) -> float:
        """Length of the front (the arc, m)."""
        s = self.arc_length(np.asarray(self.phi_range))
        return float(s[1] - s[0])

    def corner_distance(self, phi: float) -> float:
        """Distance along the front from the point to the nearer free surface (m)."""
        s = self.arc_length(np.array([self.phi_range[0], phi, self.phi_range[1]]))
        return float(min(s[1] - s[0], s[2] - s[1]))

    def parameters(self, n: int, margin: float = 0.0) -> npt.NDArray[np.float64]:
        """``n`` parameters equally spaced in arc length between the points ``margin``
        (m) from either end."""
        phi = np.linspace(*self.phi_range, 4001)
        s = self.arc_length(phi) - self.arc_length(self.phi_range[0])
        return np.interp(np.linspace(margin, s[-1] - margin, n), s, phi)


@dataclass(frozen=True)
class StraightFront:
    """The straight front of a through crack, from ``start`` to ``end`` (both on the free
    surface); the parameter φ ∈ [0, 1] runs from ``start`` to ``end``.

    Parameters
    ----------
    start, end
        The ends of the front (m).
    normal
        Unit normal of the crack plane (the ``crack_upper`` side).
    ahead
        Unit in-plane direction ahead of the front (normal to it and to ``normal``).
    """

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    normal_vector: tuple[float, float, float]
    ahead: tuple[float, float, float]

    def __post_init__(self) -> None:
        d = np.subtract(self.end, self.start)
        n, e = np.asarray(self.normal_vector), np.asarray(self.ahead)
        if np.linalg.norm(d) <= 0:
            raise ParameterError("end", "the front has zero length")
        if abs(float(d @ n)) + abs(float(d @ e)) + abs(float(n @ e)) > 1e-9 * np.linalg.norm(d):
            raise ParameterError("ahead", "front, normal and ahead must be orthogonal")

    @property
    def closed(self) -> bool:
        """False: the front ends on the free surface."""
        return False

    @property
    def length(self) -> float:
        return float(np.linalg.norm(np.subtract(self.end, self.start)))

    @property
    def a(self) -> float:
        """The front's length (m): the scale of tolerances."""
        return self.length

    @property
    def b(self) -> float:
        return self.length

    @property
    def centre(self) -> tuple[float, float, float]:
        return tuple(0.5 * (np.asarray(self.start) + np.asarray(self.end)))

    @property
    def rotation(self) -> npt.NDArray[np.float64]:
        """Rows (ahead, n × ahead, n)."""
        e, n = np.asarray(self.ahead, dtype=float), np.asarray(self.normal_vector, dtype=float)
        return np.vstack([e, np.cross(n, e), n])

    @property
    def normal(self) -> npt.NDArray[np.float64]:
        return np.asarray(self.normal_vector, dtype=float).copy()

    @property
    def perimeter(self) -> float:
        return self.length

    def point(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]:
        phi = np.atleast_1d(np.asarray(phi, dtype=float))
        s, e = np.asarray(self.start, dtype=float), np.asarray(self.end, dtype=float)
        return s + phi[:, None] * (e - s)

    def normals(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]:
        phi = np.atleast_1d(np.asarray(phi, dtype=float))
        return np.tile(np.asarray(self.ahead, dtype=float), (len(phi), 1))

    def frame(self, phi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(e₁, e₂, e₃): ahead, the crack normal, e₁ × e₂ (along the front)."""
        e1, e2 = np.asarray(self.ahead, dtype=float), self.normal
        return e1.copy(), e2, np.cross(e1, e2)

    def radius_of_curvature(self, phi: float) -> float:
        return math.inf

    def corner_distance(self, phi: float) -> float:
        """Distance along the front to the nearer free surface (m)."""
        return float(min(phi, 1.0 - phi) * self.length)

    def nearest(self, x: npt.ArrayLike) -> npt.NDArray[np.float64]:
        x = np.atleast_2d(np.asarray(x, dtype=float))
        s, e = np.asarray(self.start, dtype=float), np.asarray(self.end, dtype=float)
        return np.clip((x - s) @ (e - s) / self.length**2, 0.0, 1.0)

    def arc_length(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]:
        return np.asarray(phi, dtype=float) * self.length

    def parameter_span(self, length: float) -> float:
        return 1.01 * length / self.length

    def parameters(self, n: int, margin: float = 0.0) -> npt.NDArray[np.float64]:
        """``n`` parameters equally spaced between the points ``margin`` (m) from either
        end."""
        f = margin / self.length
        return np.linspace(f, 1.0 - f, n)


def domain_length(front, phi: float, r_out: float, h_front: float) -> float:
    """Half-length along the front of the interaction-integral domain at ``phi``: r_out,
    less near the free surface — the point's distance along the front to the surface, so
    that q vanishes on it (the domain does not cross the surface).  (The auxiliary field
    is singular along the whole elliptical front, so the front's changing curvature sets
    no limit: docs/theory/fracture.md#surface-breaking-cracks-in-3d.)

    Raises
    ------
    ParameterError
        (key ``phi``) the point lies closer to the surface than
        :data:`MIN_DOMAIN_ELEMENTS` front elements: no domain resolves q along the front
        there.
    """
    reach = front.corner_distance(phi)
    floor = MIN_DOMAIN_ELEMENTS * h_front
    length = min(r_out, reach * (1.0 - 1e-6))  # q = 0 on the surface, not round-off
    if length < floor * (1.0 - 1e-9):
        raise ParameterError(
            "phi",
            f"the point is {reach:.3g} m from the free surface along the front, less than "
            f"{MIN_DOMAIN_ELEMENTS:g} front elements of {h_front:.3g} m: no K there (the "
            "domain must not cross the surface)",
        )
    return length


# ---------------------------------------------------------------------- the crack
@dataclass(frozen=True)
class SurfaceCrack:
    """A planar crack in the plane y = 0 of the plate [−b, b] × [−h, h] × [−t, 0] whose
    front meets the free surface; the faces' normal is +y.

    Parameters
    ----------
    kind
        ``"semi_elliptical"``: centred at the origin on the front face z = 0, depth
        ``depth`` along −z, half-length ``half_length`` along x; ``"corner"``: centred on
        the corner edge x = −b, z = 0, depth along −z on the side face, length along +x on
        the front face; ``"through"``: from the side face x = −b, length ``depth`` along
        +x, through the whole thickness (``half_length`` unused).
    depth, half_length
        a and c (m); a ≤ c for the elliptical shapes.
    """

    kind: str
    depth: float
    half_length: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in SURFACE_CRACK_KINDS:
            raise ParameterError(
                "kind", f"must be one of {', '.join(SURFACE_CRACK_KINDS)}, got {self.kind!r}"
            )
        if not (math.isfinite(self.depth) and self.depth > 0):
            raise ParameterError("depth", f"must be a positive number (m), got {self.depth!r}")
        if self.kind != "through" and not (self.half_length >= self.depth):
            raise ParameterError(
                "half_length",
                f"need half_length >= depth (a/c <= 1), got a={self.depth}, c={self.half_length}",
            )

    def front(self, b: float, t: float) -> EllipticalArcFront | StraightFront:
        """The front in the plate of half-width ``b`` and thickness ``t``."""
        axes = ((1.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0))  # u, v = depth, n
        if self.kind == "semi_elliptical":
            return EllipticalArcFront(self.half_length, self.depth, (0.0, 0.0, 0.0), axes)
        if self.kind == "corner":
            return EllipticalArcFront(
                self.half_length, self.depth, (-b, 0.0, 0.0), axes, (0.0, 0.5 * math.pi)
            )
        x = -b + self.depth
        return StraightFront((x, 0.0, 0.0), (x, 0.0, -t), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))


# ------------------------------------------------------------------ gmsh (rank 0)
def _crack_surface(crack: SurfaceCrack, b: float, t: float) -> list[tuple[int, int]]:
    """The crack surface in the plane y = 0 (before it is cut to the plate)."""
    occ = gmsh.model.occ
    if crack.kind == "through":
        s = occ.addRectangle(-b, -t, 0.0, crack.depth, t)
    else:
        xc = 0.0 if crack.kind == "semi_elliptical" else -b
        s = occ.addDisk(xc, 0.0, 0.0, crack.half_length, crack.depth)
    occ.rotate([(2, s)], 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5 * math.pi)  # y → z
    return [(2, s)]


def _on_plate_face(box: tuple, dims: tuple[float, float, float], tol: float) -> bool:
    """Whether a curve's bounding box lies in a face of the plate x = ±b, z = 0 or −t."""
    b, _, t = dims
    xmin, _, zmin, xmax, _, zmax = box
    return (
        (abs(xmin + b) < tol and abs(xmax + b) < tol)
        or (abs(xmin - b) < tol and abs(xmax - b) < tol)
        or (abs(zmin) < tol and abs(zmax) < tol)
        or (abs(zmin + t) < tol and abs(zmax + t) < tol)
    )


def _plate_face(com: tuple, dims: tuple[float, float, float], tol: float) -> str:
    b, h, t = dims
    x, y, z = com
    for name, hit in (
        ("left", abs(x + b) < tol),
        ("right", abs(x - b) < tol),
        ("bottom", abs(y + h) < tol),
        ("top", abs(y - h) < tol),
        ("back", abs(z + t) < tol),
        ("front", abs(z) < tol),
    ):
        if hit:
            return name
    raise MeshingError(f"surface at {com} belongs to no face of the plate")


def _classify(dims: tuple[float, float, float], tol: float) -> tuple[list[int], list, list]:
    """Physical groups of the fragmented plate; the crack surfaces, front and mouth curves."""
    gmsh.model.addPhysicalGroup(3, [t for _, t in gmsh.model.getEntities(3)], 1, name="body")
    crack, faces = [], {}
    for _, tag in gmsh.model.getEntities(2):
        com = gmsh.model.occ.getCenterOfMass(2, tag)
        if abs(com[1]) < tol and abs(gmsh.model.getBoundingBox(2, tag)[4]) < tol:
            crack.append(tag)
        else:
            faces.setdefault(_plate_face(com, dims, tol), []).append(tag)
    for name, tags in faces.items():
        gmsh.model.addPhysicalGroup(2, tags, PLATE_GROUPS[name], name=name)
    if not crack:
        raise MeshingError("the crack surface was lost when it was cut into the plate")
    edges = gmsh.model.getBoundary([(2, s) for s in crack], combined=True, oriented=False)
    front, mouth = [], []
    for _, c in edges:
        box = gmsh.model.getBoundingBox(1, abs(c))
        (mouth if _on_plate_face(box, dims, tol) else front).append(abs(c))
    if not front or not mouth:
        raise MeshingError(f"expected a front and a mouth, got {len(front)} and {len(mouth)}")
    return crack, front, mouth


def _size_field(front: list[int], h_front: float, grading: float, h_max: float, n: int) -> None:
    fld = gmsh.model.mesh.field
    d = fld.add("Distance")
    fld.setNumbers(d, "CurvesList", front)
    fld.setNumber(d, "Sampling", max(100, n))
    f = fld.add("MathEval")
    fld.setString(f, "F", f"Min({h_front!r} + {grading!r}*F{d}, {h_max!r})")
    fld.setAsBackgroundMesh(f)
    for opt in ("MeshSizeFromPoints", "MeshSizeExtendFromBoundary", "MeshSizeFromCurvature"):
        gmsh.option.setNumber(f"Mesh.{opt}", 0)


def _split_faces(crack: list[int], mouth: list[int]) -> None:
    """Duplicate the crack nodes, the mouth's included, the front's not."""
    gmsh.model.addPhysicalGroup(2, crack, _CRACK_A, name="crack_a")
    gmsh.model.addPhysicalGroup(1, mouth, _MOUTH)
    plugin = gmsh.plugin
    plugin.setNumber("Crack", "Dimension", 2)
    plugin.setNumber("Crack", "PhysicalGroup", _CRACK_A)
    plugin.setNumber("Crack", "NewPhysicalGroup", _CRACK_B)
    plugin.setNumber("Crack", "OpenBoundaryPhysicalGroup", _MOUTH)
    plugin.run("Crack")
    gmsh.model.removePhysicalGroups([(1, _MOUTH)])
    gmsh.model.setPhysicalName(2, _CRACK_B, "crack_b")
    gmsh.model.mesh.renumberNodes()  # the plugin leaves gaps; DOLFINx needs them contiguous
    gmsh.model.mesh.renumberElements()


def _build_plate(crack: SurfaceCrack, dims, h_front: float, grading: float, h_max: float) -> None:
    b, h, t = dims
    occ = gmsh.model.occ
    box = occ.addBox(-b, -h, -t, 2 * b, 2 * h, t)
    piece, _ = occ.intersect(_crack_surface(crack, b, t), [(3, box)], removeTool=False)
    occ.fragment([(3, box)], piece)
    occ.synchronize()
    surfaces, front, mouth = _classify(dims, 1e-7 * max(dims))
    length = crack.front(b, t).perimeter
    _size_field(front, h_front, grading, h_max, int(4 * length / h_front))
    gmsh.option.setNumber("Mesh.Algorithm3D", 10)  # HXT
    gmsh.model.mesh.generate(3)
    _split_faces(surfaces, mouth)


def mesh_plate_with_crack(
    crack: SurfaceCrack,
    half_width: float,
    half_height: float,
    thickness: float,
    h_front: float,
    grading: float = 0.12,
    h_max: float | None = None,
    comm: MPI.Comm | None = None,
) -> CrackBlock:
    """Mesh the plate [−b, b] × [−h, h] × [−t, 0] with a surface-breaking crack in y = 0.

    Parameters
    ----------
    crack
        The crack (it must fit: depth < t and, for the elliptical shapes, c < b).
    half_width, half_height, thickness
        b, h, t (m).
    h_front, grading, h_max
        Element size at the front, its growth per unit distance from the front and the
        largest size (default t/2).
    comm
        MPI communicator (``None``: ``MPI.COMM_WORLD``); gmsh runs on rank 0.

    Returns
    -------
    CrackBlock
        Both faces meshed (``half_model = False``); facet groups :data:`PLATE_GROUPS`
        (``left`` x = −b, ``right`` x = b, ``bottom`` y = −h, ``top`` y = h, ``back``
        z = −t, ``front`` z = 0) and ``crack_upper`` (y > 0 side), ``crack_lower``.

    Raises
    ------
    ParameterError
        A crack that does not fit the plate (key ``depth`` or ``half_length``).
    MeshingError
        gmsh failed (on every rank).
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    dims = (float(half_width), float(half_height), float(thickness))
    b, _, t = dims
    if crack.kind != "through" and crack.depth >= t:
        raise ParameterError("depth", f"the crack (a={crack.depth}) must be shallower than t={t}")
    if crack.kind == "through" and crack.depth >= 2 * b:
        raise ParameterError("depth", f"the crack (a={crack.depth}) must be shorter than 2b")
    if crack.kind != "through" and crack.half_length >= (2 * b if crack.kind == "corner" else b):
        raise ParameterError("half_length", f"the crack (c={crack.half_length}) must fit b={b}")
    h_max = 0.5 * t if h_max is None else float(h_max)
    error = None
    with gmsh_session("cracked_plate") if comm.rank == 0 else nullcontext():
        if comm.rank == 0:
            try:
                _build_plate(crack, dims, h_front, grading, h_max)
            except Exception as exc:  # reported on every rank below
                error = f"{type(exc).__name__}: {exc}"
        error = comm.bcast(error, root=0)
        if error is not None:
            raise MeshingError(f"cracked plate: {error}")
        md = model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=3)
    n = np.array([0.0, 1.0, 0.0])
    sign = face_side_sign(md.mesh, md.facet_tags, _CRACK_A, n)
    upper, lower = (_CRACK_A, _CRACK_B) if sign > 0 else (_CRACK_B, _CRACK_A)
    groups = dict(PLATE_GROUPS) | {"crack_upper": upper, "crack_lower": lower}
    return CrackBlock(
        md.mesh, md.cell_tags, md.facet_tags, crack.front(b, t), groups, half_model=False
    )


# ------------------------------------------------------------------ the face pair
@dataclass(frozen=True)
class FacePair:
    """What :func:`~bonecontact.fracture.faces.face_interface` needs of a cracked mesh:
    the mesh, its facet tags, ``face_tags`` = (``crack_upper`` slave, ``crack_lower``
    master) and the crack (its front)."""

    mesh: mesh.Mesh
    facet_tags: mesh.MeshTags
    face_tags: tuple[int, int]
    crack: object


def face_pair(block: CrackBlock) -> FacePair:
    """The crack faces of a two-face model as a contact pair's input (the faces meet
    only at the front, whose nodes carry no multiplier, as for an interior crack)."""
    groups = block.groups
    return FacePair(
        block.mesh, block.facet_tags, (groups["crack_upper"], groups["crack_lower"]), block.front
    )


def front_nodes(block: CrackBlock) -> npt.NDArray[np.float64]:
    """Coordinates of the front nodes — the vertices of both faces — on every rank, sorted
    by coordinates (collective; :func:`~bonecontact.fracture.body3d.front_vertices`)."""
    groups = block.groups
    return front_vertices(
        block.mesh, block.facet_tags, (groups["crack_upper"], groups["crack_lower"])
    )
