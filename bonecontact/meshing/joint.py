"""A joint from bone surfaces: one bone posed on another (:func:`pose_on`), a bone cut by a
plane (:func:`clip_surface`), cartilage layers (:func:`cartilage_layer`) and one
tetrahedral mesh of several bones (:func:`joint_from_surfaces`).

How each step works: docs/meshing.md (two bones in a joint).  Units: m; y up.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from mpi4py import MPI

import gmsh
import numpy as np
from dolfinx.io.gmsh import MeshData
from scipy.spatial import cKDTree

from bonecontact.common.geometry import first_ray_hits
from bonecontact.meshing.builder import PhysicalGroups, check_positive, generate
from bonecontact.meshing.stl import SurfaceRegion, cortical_inner_surface, select_triangles
from bonecontact.meshing.surface_repair import (
    MeshInputError,
    Surface,
    check_surface,
    merge_vertices,
    orient_surface,
    prepare_surface,
)

__all__ = [
    "Cartilage",
    "FacetsOver",
    "JointBone",
    "Pose",
    "cartilage_layer",
    "clip_surface",
    "joint_from_surfaces",
    "pose_on",
    "refine_facets",
    "smooth_surface",
    "vertical_gaps",
]

UP = np.array([0.0, 1.0, 0.0])


# ------------------------------------------------------------------------- measuring
@dataclass(frozen=True)
class GapMap:
    """Vertical gaps between two surfaces on a grid of columns (:func:`vertical_gaps`).

    ``x``, ``z``: the grid's coordinates (m); ``gap[i, j]``: the lowest crossing of the
    upper surface minus the highest crossing of the lower surface below it in column
    ``(x[i], z[j])`` (m; NaN where a ray misses either surface); ``lower_top``: that
    highest crossing (m).
    """

    x: np.ndarray
    z: np.ndarray
    gap: np.ndarray
    lower_top: np.ndarray

    def smallest(self, mask: np.ndarray | None = None) -> tuple[float, np.ndarray]:
        """The smallest gap (m) over the columns of ``mask`` and the point on the lower
        surface below it (m)."""
        g = np.where(np.isfinite(self.gap), self.gap, np.inf)
        if mask is not None:
            g = np.where(mask, g, np.inf)
        i, j = np.unravel_index(int(np.argmin(g)), g.shape)
        if not np.isfinite(g[i, j]):
            raise MeshInputError("no vertical ray crosses both surfaces (they do not face)")
        return float(g[i, j]), np.array([self.x[i], self.lower_top[i, j], self.z[j]])


def _column_crossings(surface: Surface, x: np.ndarray, z: np.ndarray, lowest: bool) -> np.ndarray:
    """The lowest (or highest) y at which each vertical ray (x[i], z[j]) crosses the
    surface (NaN: no crossing).  The rays are shifted by a tiny irrational fraction of the
    spacing so that none runs through a vertex or an edge."""
    dx, dz = x[1] - x[0], z[1] - z[0]
    xs, zs = x + 1e-7 * math.pi * dx, z + 1e-7 * math.e * dz
    out = np.full((len(x), len(z)), np.inf if lowest else -np.inf)
    p = surface.points[surface.triangles]
    lo = np.ceil((p[:, :, [0, 2]].min(axis=1) - [xs[0], zs[0]]) / [dx, dz]).astype(int)
    hi = np.floor((p[:, :, [0, 2]].max(axis=1) - [xs[0], zs[0]]) / [dx, dz]).astype(int)
    for t in np.flatnonzero(np.all(hi >= lo, axis=1)):
        i = np.arange(max(lo[t, 0], 0), min(hi[t, 0], len(x) - 1) + 1)
        j = np.arange(max(lo[t, 1], 0), min(hi[t, 1], len(z) - 1) + 1)
        if not len(i) or not len(j):
            continue
        ii, jj = np.meshgrid(i, j, indexing="ij")
        a, b, c = p[t]
        det = (b[0] - a[0]) * (c[2] - a[2]) - (c[0] - a[0]) * (b[2] - a[2])
        if det == 0:
            continue  # seen edge-on from below
        qx, qz = xs[ii] - a[0], zs[jj] - a[2]
        u = (qx * (c[2] - a[2]) - qz * (c[0] - a[0])) / det
        v = (qz * (b[0] - a[0]) - qx * (b[2] - a[2])) / det
        hit = (u >= 0) & (v >= 0) & (u + v <= 1)
        y = a[1] + u[hit] * (b[1] - a[1]) + v[hit] * (c[1] - a[1])
        cur = out[ii[hit], jj[hit]]
        out[ii[hit], jj[hit]] = np.minimum(cur, y) if lowest else np.maximum(cur, y)
    return np.where(np.isfinite(out), out, np.nan)


def vertical_gaps(upper: Surface, lower: Surface, spacing: float = 0.5e-3) -> GapMap:
    """Vertical gaps between the underside of ``upper`` and the top of ``lower``.

    Vertical rays on a grid of ``spacing`` (m) over the overlap of the two surfaces'
    horizontal extents; in each column the gap is the lowest crossing of ``upper`` minus
    the highest crossing of ``lower`` (negative where they overlap).
    """
    check_positive(spacing=spacing)
    lo = np.maximum(upper.points.min(axis=0), lower.points.min(axis=0))
    hi = np.minimum(upper.points.max(axis=0), lower.points.max(axis=0))
    if np.any(hi[[0, 2]] <= lo[[0, 2]]):
        raise MeshInputError(
            f"{upper.source} and {lower.source}: their horizontal extents do not overlap"
        )
    x = np.arange(lo[0], hi[0] + spacing, spacing)
    z = np.arange(lo[2], hi[2] + spacing, spacing)
    bottom = _column_crossings(upper, x, z, lowest=True)
    top = _column_crossings(lower, x, z, lowest=False)
    return GapMap(x, z, bottom - top, top)


# --------------------------------------------------------------------------- posing
@dataclass(frozen=True)
class Pose:
    """A rigid transform ``x -> R (x - centre) + centre + shift`` found by :func:`pose_on`.

    ``rotation`` (3 × 3), ``centre`` and ``shift`` (m); ``angle`` (degrees) about ``axis``;
    ``gaps``: the vertical gaps at the two contact points after posing (m; the
    measurement of :func:`vertical_gaps`), ``points``: those points on the lower surface;
    ``gaps_before``: the two gaps before (after the first vertical approach, for the
    record); ``iterations``.
    """

    rotation: np.ndarray
    centre: np.ndarray
    shift: np.ndarray
    axis: np.ndarray
    angle: float
    gaps: tuple[float, float]
    points: np.ndarray
    gaps_before: tuple[float, float]
    iterations: int

    def apply(self, points: np.ndarray) -> np.ndarray:
        """The transformed points (m)."""
        return (np.asarray(points) - self.centre) @ self.rotation.T + self.centre + self.shift

    def matrix(self) -> np.ndarray:
        """The 4 × 4 homogeneous matrix of the transform."""
        m = np.eye(4)
        m[:3, :3] = self.rotation
        m[:3, 3] = self.centre + self.shift - self.rotation @ self.centre
        return m


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix about the unit ``axis`` by ``angle`` (radians; Rodrigues)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def _two_gaps(
    upper: Surface, lower: Surface, lateral: np.ndarray, split: float | None, spacing: float
) -> tuple[list[float], list[np.ndarray], float]:
    """The smallest vertical gap on each side of the split (lateral coordinate, m)."""
    gm = vertical_gaps(upper, lower, spacing)
    xx, zz = np.meshgrid(gm.x, gm.z, indexing="ij")
    s = xx * lateral[0] + zz * lateral[2]
    if split is None:
        finite = np.isfinite(gm.gap)
        split = float(s[finite].mean())
    gaps, pts = [], []
    for side in (s < split, s >= split):
        g, p = gm.smallest(side)
        gaps.append(g)
        pts.append(p)
    return gaps, pts, split


def pose_on(
    upper: Surface,
    lower: Surface,
    gap: float,
    *,
    lateral: Sequence[float] = (0.0, 0.0, 1.0),
    split: float | None = None,
    spacing: float = 0.5e-3,
    tolerance: float = 1e-5,
    max_iterations: int = 20,
) -> tuple[Surface, Pose]:
    """Place ``upper`` on ``lower`` with the vertical gap ``gap`` at two contact points.

    The joint is split by a vertical plane normal to the horizontal ``lateral`` direction
    (at the lateral coordinate ``split``; default: the mean over the columns where both
    surfaces are hit) into two sides (the medial and lateral compartments of a knee).
    Repeated until the two gaps differ from ``gap`` by less than ``tolerance``:

    1. vertical rays on a grid of ``spacing`` (:func:`vertical_gaps`) give the smallest
       gap ``g1``, ``g2`` on each side, at lateral coordinates ``s1``, ``s2``;
    2. ``upper`` turns about the horizontal axis ``up × lateral`` through the midpoint of
       the two points by ``(g1 - g2) / (s1 - s2)`` (the small-angle levelling: a point at
       lateral offset ``d`` sinks by ``angle × d``);
    3. ``upper`` moves vertically by ``gap - min(g1, g2)``.

    The first step only moves ``upper`` vertically so that its lowest point is ``gap``
    above the highest point of ``lower`` within its horizontal extent.

    Parameters
    ----------
    upper, lower
        Closed surfaces (m); ``upper`` moves, ``lower`` stays.
    gap
        The vertical gap wanted at both contact points (m, >= 0; the two cartilage
        thicknesses for bones whose cartilage is added afterwards).
    lateral
        Horizontal direction across the joint (default z, the knee's medial-lateral axis).
    split
        Lateral coordinate of the plane between the two sides (m).
    spacing
        Grid spacing of the rays (m): the contact points are found to this resolution.
    tolerance
        Accepted error of the two gaps (m).
    max_iterations
        Refused (MeshInputError) if not converged after this many.

    Returns
    -------
    (Surface, Pose)
        ``upper`` posed, and the transform with the measured gaps.
    """
    if not (math.isfinite(gap) and gap >= 0):
        raise ValueError(f"gap must be >= 0 (m), got {gap!r}")
    check_positive(spacing=spacing, tolerance=tolerance)
    lat = _horizontal_unit(lateral)
    axis = np.cross(UP, lat)
    t = _Transform(np.eye(3), np.zeros(3), _first_approach(upper, lower, gap))
    gaps, pts, split = _two_gaps(t.surface(upper), lower, lat, split, spacing)
    before = (gaps[0], gaps[1])
    iterations = 0
    for iterations in range(1, max_iterations + 1):  # noqa: B007 (the count is reported)
        t = _level(t, pts, gaps, lat, axis, spacing, (upper, lower))
        gaps, pts, _ = _two_gaps(t.surface(upper), lower, lat, split, spacing)
        t = _Transform(t.rot, t.centre, t.shift + UP * (gap - min(gaps)))
        gaps, pts, _ = _two_gaps(t.surface(upper), lower, lat, split, spacing)
        if max(abs(g - gap) for g in gaps) < tolerance:
            break
    else:
        raise MeshInputError(
            f"{upper.source} on {lower.source}: the pose did not converge in {max_iterations} "
            f"iterations (gaps {gaps[0]:.4g}, {gaps[1]:.4g} m, wanted {gap:.4g} m)"
        )
    pose = Pose(
        rotation=t.rot,
        centre=t.centre,
        shift=t.shift,
        axis=axis,
        angle=_rotation_angle(t.rot, axis),
        gaps=(gaps[0], gaps[1]),
        points=np.array(pts),
        gaps_before=before,
        iterations=iterations,
    )
    return t.surface(upper), pose


@dataclass(frozen=True)
class _Transform:
    """``x -> rot (x - centre) + centre + shift`` while :func:`pose_on` iterates."""

    rot: np.ndarray
    centre: np.ndarray
    shift: np.ndarray

    def surface(self, upper: Surface) -> Surface:
        """``upper`` transformed."""
        pts = (upper.points - self.centre) @ self.rot.T + self.centre + self.shift
        return Surface(pts, upper.triangles, upper.source, upper.repairs)


def _horizontal_unit(lateral: Sequence[float]) -> np.ndarray:
    """The horizontal part of ``lateral``, normalised (refused if vertical)."""
    lat = np.asarray(lateral, float)
    lat = lat - (lat @ UP) * UP
    if np.linalg.norm(lat) == 0:
        raise ValueError(f"lateral must be a horizontal direction, got {lateral!r}")
    lat /= np.linalg.norm(lat)
    return lat


def _first_approach(upper: Surface, lower: Surface, gap: float) -> np.ndarray:
    """The vertical shift that puts the lowest point of ``upper`` ``gap`` above the
    highest point of ``lower`` within the horizontal extent of ``upper``."""
    lo, hi = upper.points.min(axis=0), upper.points.max(axis=0)
    under = np.all(
        (lower.points[:, [0, 2]] >= lo[[0, 2]]) & (lower.points[:, [0, 2]] <= hi[[0, 2]]), 1
    )
    top = lower.points[under, 1].max() if under.any() else lower.points[:, 1].max()
    return np.array([0.0, top + gap - lo[1], 0.0])


def _level(
    t: _Transform,
    pts: list[np.ndarray],
    gaps: list[float],
    lat: np.ndarray,
    axis: np.ndarray,
    spacing: float,
    bones: tuple[Surface, Surface],
) -> _Transform:
    """``t`` followed by the levelling rotation about ``axis`` through the midpoint of the
    two contact points ``pts`` (angle: the gap difference over their lateral distance)."""
    s = [p @ lat for p in pts]
    if abs(s[0] - s[1]) < 2 * spacing:
        raise MeshInputError(
            f"{bones[0].source} on {bones[1].source}: the two contact points are not on "
            f"either side of the split (lateral coordinates {s[0]:.4g}, {s[1]:.4g} m)"
        )
    angle = (gaps[0] - gaps[1]) / (s[0] - s[1])
    mid = 0.5 * (pts[0] + pts[1])
    r = _rotation(axis, angle)
    # compose: x -> r (T(x) - mid) + mid with T(x) = rot (x - centre) + centre + shift
    new_off = r @ (t.centre + t.shift - t.rot @ t.centre - mid) + mid
    return _Transform(r @ t.rot, np.zeros(3), new_off)


def _rotation_angle(rot: np.ndarray, axis: np.ndarray) -> float:
    """The angle (degrees) of ``rot``, a rotation about ``axis``, from its skew part."""
    skew = np.array([rot[2, 1] - rot[1, 2], rot[0, 2] - rot[2, 0], rot[1, 0] - rot[0, 1]])
    return float(math.degrees(math.atan2(0.5 * skew @ axis, 0.5 * (np.trace(rot) - 1))))


# ------------------------------------------------------------------------- clipping
def clip_surface(surface: Surface, point: Sequence[float], normal: Sequence[float]) -> Surface:
    """The part of a closed surface behind a plane, closed by a flat cap in the plane.

    Keeps the side ``(x - point) · normal <= 0``; the cap's outward normal is ``normal``
    (select it with ``SurfaceRegion(name, cone=(normal, 10))``).  The cap is triangulated
    as it comes (long thin triangles): remesh the result (``prepare_surface(size=...)``).

    Raises
    ------
    MeshInputError
        If the plane misses the surface or the result is not one closed surface.
    """
    n = np.asarray(normal, float)
    n = n / np.linalg.norm(n)
    side = (surface.points - np.asarray(point, float)) @ n
    if side.min() >= 0 or side.max() <= 0:
        raise MeshInputError(f"{surface.source}: the clipping plane does not cut the surface")
    # clip_closed_surface keeps the side its normal points to
    poly = surface.to_pyvista().clip_closed_surface(normal=tuple(-n), origin=tuple(point))
    poly = poly.triangulate().clean()
    tri = poly.faces.reshape(-1, 4)[:, 1:].astype(np.int64)
    out = orient_surface(
        merge_vertices(Surface(np.asarray(poly.points, float), tri, surface.source))
    )
    if out.volume < 0:
        out = Surface(out.points, out.triangles[:, ::-1], out.source)
    check_surface(out)
    where = np.round(np.asarray(point, float), 5).tolist()
    note = f"clipped by the plane through {where} m, normal {np.round(n, 3).tolist()}"
    return Surface(out.points, out.triangles, surface.source, surface.repairs + (note,))


# ------------------------------------------------------------------------ smoothing
def _umbrella(triangles: np.ndarray, n: int):
    """The sparse operator that maps vertex values to the mean over each vertex's edge
    neighbours."""
    import scipy.sparse as sp

    e = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    a = sp.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n)).tocsr()
    a = ((a + a.T) > 0).astype(float)
    return sp.diags(1.0 / np.asarray(a.sum(axis=1)).ravel()) @ a


def smooth_surface(
    surface: Surface,
    iterations: int = 50,
    *,
    weights: Callable[[np.ndarray], np.ndarray] | None = None,
    subdivide: int = 2,
) -> Surface:
    """A closed surface with its facets' kinks rounded (Taubin's λ|μ smoothing).

    The triangles are first split into four ``subdivide`` times (linear: the shape is
    kept), so that the smoothing has vertices between the scan's; then each of
    ``iterations`` passes moves every vertex towards the mean of its neighbours by
    ``λ w`` (λ = 0.5) and back by ``μ w`` (μ = -0.53), ``w`` in [0, 1] its weight from
    ``weights(points)`` (default 1): the shrinking of plain Laplacian smoothing is
    undone by the second step, so the surface keeps its volume and place while its
    short-wavelength kinks fade.  Vertices of weight 0 stay (smooth only a region, e.g.
    a bone's articular end, with a weight tapering to 0 around it).

    Returns
    -------
    Surface
        Closed and oriented as ``surface``; ``repairs`` notes the smoothing.
    """

    if int(iterations) != iterations or iterations < 0 or subdivide not in (0, 1, 2, 3):
        raise ValueError(
            f"iterations must be an integer >= 0 (got {iterations!r}) and subdivide 0-3 "
            f"(got {subdivide!r})"
        )
    fine = surface
    if subdivide:
        poly = surface.to_pyvista().subdivide(subdivide, "linear")
        tri = np.asarray(poly.faces).reshape(-1, 4)[:, 1:].astype(np.int64)
        fine = orient_surface(merge_vertices(Surface(np.asarray(poly.points, float), tri)))
    x = fine.points.copy()
    w = np.ones(len(x)) if weights is None else np.clip(np.asarray(weights(x), float), 0, 1)
    if w.shape != (len(x),):
        raise ValueError(f"weights must return one value per point ({len(x)}), got {w.shape}")
    mean = _umbrella(fine.triangles, len(x))
    for _ in range(int(iterations)):
        for factor in (0.5, -0.53):
            x += (factor * w)[:, None] * (mean @ x - x)
    note = f"subdivided {subdivide}x and smoothed (Taubin, {iterations} passes)"
    out = Surface(x, fine.triangles, surface.source, surface.repairs + (note,))
    if out.volume * surface.volume <= 0:  # pragma: no cover (a sign change: turned over)
        raise MeshInputError(f"{surface.source}: the smoothing turned the surface over")
    return out


# ------------------------------------------------------------------------ cartilage
@dataclass(frozen=True)
class FacetsOver:
    """A region of an upper bone's facets (a :class:`Cartilage` region, as
    :class:`~bonecontact.meshing.SurfaceRegion`): those facing down (normal within
    ``cone`` degrees of -y) whose vertical ray down meets ``lower`` within ``max_gap`` on
    a facet of ``lower`` facing up (within ``lower_cone`` of +y), and so do the rays
    ``margin`` away from the centroid in ±x and ±z; with ``box = (lo, hi)`` only
    centroids inside it (e.g. one compartment of a knee).  A layer on these facets lies over
    the lower bone's articular surface (a contact pair's slave covered by its master)
    and ends where the bones are ``max_gap`` apart (its tapered rim away from the
    contact)."""

    name: str
    lower: Surface
    max_gap: float
    cone: float = 40.0
    lower_cone: float = 60.0
    margin: float = 0.0
    box: tuple[Sequence[float], Sequence[float]] | None = None

    def __post_init__(self) -> None:
        check_positive(max_gap=self.max_gap)
        if not (0 <= self.cone <= 90 and 0 <= self.lower_cone <= 90 and self.margin >= 0):
            raise ValueError(
                f"region {self.name!r}: cone and lower_cone must be in [0, 90] degrees and "
                f"margin >= 0 (got {self.cone!r}, {self.lower_cone!r}, {self.margin!r})"
            )

    def select(self, centroids: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """Mask of the facets (centroids, unit normals) in the region."""
        up = self.lower.triangle_normals()[:, 1]
        mask = normals[:, 1] <= -math.cos(math.radians(self.cone))
        if self.box is not None:
            lo, hi = (np.asarray(v, float) for v in self.box)
            mask &= np.all((centroids >= lo) & (centroids <= hi), axis=1)
        m = self.margin
        for dx, dz in ((0.0, 0.0), (m, 0.0), (-m, 0.0), (0.0, m), (0.0, -m)):
            if mask.any():
                o = centroids[mask] + [dx, 0.0, dz]
                dist, tri = _ray_hits(o, np.tile(-UP, (len(o), 1)), self.lower)
                ok = (tri >= 0) & (dist < self.max_gap)
                ok[ok] &= up[tri[ok]] >= math.cos(math.radians(self.lower_cone))
                mask[np.flatnonzero(mask)[~ok]] = False
        return mask


@dataclass(frozen=True)
class Cartilage:
    """A cartilage layer on the articular facets of a bone (:func:`joint_from_surfaces`).

    Parameters
    ----------
    name
        Its cell group (``"femur_cartilage"``).
    contact
        The facet group of the layer's free (articular) surface, the one to pair in
        ``[[contact]]`` (``"femur_contact"``).
    regions
        The articular facets of the bone surface: the triangles any of these regions
        selects (several: e.g. one box per compartment of a joint; :class:`FacetsOver`:
        the facets over another bone).
    thickness
        Layer thickness (m), normal to the facets; with ``conform_to``, the largest
        thickness (where the other surface is far).
    conform_to
        The name of a bone listed before this one in :func:`joint_from_surfaces`: the
        layer's articular surface is shaped to that bone's outer surface (its cartilage
        where it has some), ``clearance``
        below it along each vertex normal (:func:`cartilage_layer`), and no thicker than
        ``thickness``.  ``None``: a layer of uniform ``thickness``.
    clearance
        The gap left between the conformed surface and the other one (m, >= 0).
    conform_along
        ``"normal"``: the clearance is measured along each vertex normal;
        ``"vertical"``: along +y, the direction a joint is loaded in, so that a vertical
        approach by the clearance closes the whole conformed patch at once;
        ``"lowered"``: the articular surface is the other surface lowered by the
        clearance: every inner vertex moves straight up (not along its normal) to the
        clearance below the other surface, so the layer's thickness is the vertical gap
        to the other bone less the clearance (at most ``thickness``, at least a tenth
        of it, else refused), and no facet can turn over.
    subchondral
        With ``conform_to``: the cell group of bone under a cartilage of uniform
        ``cartilage_thickness``: of the conformed thickness ``t`` the top
        ``cartilage_thickness`` is cartilage, the rest (at least a fifth of
        it) bone: the subchondral surface, not the cartilage,
        follows the other bone.  ``None``: all of ``t`` is cartilage.
    cartilage_thickness
        The cartilage's thickness over the subchondral group (m).
    refine
        Times the remeshed articular facets are split into four (0, 1 or 2;
        :func:`refine_facets`), the new vertices moved onto the bone's given surface
        (closest point): a finer articular surface, the rest of the bone as remeshed.
    rim_slope
        With ``conform_along="vertical"`` or ``"lowered"``: the layer is at most
        ``rim_slope`` times a vertex's distance from the layer's rim thick (1: no
        steeper than 45° towards its rim; 3: 72°, the steep outer wall of a meniscus).
    """

    name: str
    contact: str
    regions: tuple[SurfaceRegion | FacetsOver, ...]
    thickness: float
    conform_to: str | None = None
    clearance: float = 0.0
    conform_along: str = "normal"
    subchondral: str | None = None
    cartilage_thickness: float | None = None
    refine: int = 0
    rim_slope: float = 1.0

    def __post_init__(self) -> None:
        check_positive(thickness=self.thickness, rim_slope=self.rim_slope)
        if self.refine not in (0, 1, 2):
            raise ValueError(
                f"cartilage {self.name!r}: refine must be 0, 1 or 2 (got {self.refine!r})"
            )
        if (self.subchondral is None) != (self.cartilage_thickness is None) or (
            self.subchondral is not None and self.conform_to is None
        ):
            raise ValueError(
                f"cartilage {self.name!r}: give subchondral and cartilage_thickness together, "
                "with conform_to"
            )
        if self.cartilage_thickness is not None:
            check_positive(cartilage_thickness=self.cartilage_thickness)
        if self.conform_along not in ("normal", "vertical", "lowered"):
            raise ValueError(
                f"cartilage {self.name!r}: conform_along must be 'normal', 'vertical' or "
                f"'lowered' "
                f"(got {self.conform_along!r})"
            )
        if not self.regions:
            raise ValueError(f"cartilage {self.name!r}: give at least one region")
        if not (math.isfinite(self.clearance) and self.clearance >= 0):
            raise ValueError(f"cartilage {self.name!r}: clearance must be >= 0 (m)")

    def select(self, surface: Surface) -> np.ndarray:
        """The triangles of ``surface`` that any region selects."""
        c, n = surface.centroids(), surface.triangle_normals()
        mask = np.zeros(len(c), bool)
        for region in self.regions:
            mask |= region.select(c, n)
        return np.flatnonzero(mask)


@dataclass(frozen=True)
class CartilageLayer:
    """The surfaces of a cartilage layer (:func:`cartilage_layer`): ``points`` = the bone
    surface's points followed by the offset points; triangles into ``points``: ``base``
    (the facets, the bone–cartilage interface, outward from the bone) and ``top`` (the
    offset facets, the articular surface, outward); they share the rim's vertices (the
    layer tapers to nothing there).  ``facets``: the bone surface's triangles used.
    ``mid``: with a subchondral part, the bone–cartilage interface between ``base`` and
    ``top`` (its points after the offset ones)."""

    points: np.ndarray
    base: np.ndarray
    top: np.ndarray
    facets: np.ndarray = field(repr=False)
    mid: np.ndarray | None = None

    @property
    def volume(self) -> float:
        """Enclosed volume of the layer (m³; divergence theorem on its closed surface)."""
        tri = np.vstack([self.top, self.base[:, ::-1]])
        a, b, c = (self.points[tri[:, i]] for i in range(3))
        return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)

    def thickness(self) -> np.ndarray:
        """Distance of each offset vertex from its bone vertex (m; 0 on the rim)."""
        base, top = self.base.ravel(), self.top.ravel()
        _, first = np.unique(base, return_index=True)
        return np.linalg.norm(self.points[top[first]] - self.points[base[first]], axis=1)


def refine_facets(surface: Surface, facets: np.ndarray) -> Surface:
    """``surface`` with the triangles ``facets`` split into four at their edges'
    midpoints (red) and the triangles around them that share one split edge split into
    two (green; a triangle with two or three split edges is split red too, until none is
    left): a conforming, consistently oriented surface, finer on ``facets``, with the
    same shape (the new vertices lie on the old edges, numbered after the old ones)."""
    tri = surface.triangles
    red = np.zeros(len(tri), bool)
    red[np.asarray(facets, np.int64)] = True
    edges = np.sort(np.stack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]], axis=1), axis=2)
    key = edges[..., 0] * len(surface.points) + edges[..., 1]  # (m, 3): edge k = (k, k+1)
    while True:
        more = ~red & (np.isin(key, key[red]).sum(axis=1) >= 2)
        if not more.any():
            break
        red |= more
    split_keys, first = np.unique(key[red], return_index=True)
    pairs = edges[red].reshape(-1, 2)[first]
    mid = 0.5 * (surface.points[pairs[:, 0]] + surface.points[pairs[:, 1]])
    m = len(surface.points) + np.searchsorted(split_keys, key, side="left")
    split = np.isin(key, split_keys)
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    ab, bc, ca = m[:, 0], m[:, 1], m[:, 2]
    r, g = red, ~red & split.any(axis=1)
    out = [tri[~red & ~split.any(axis=1)]]
    out += [np.c_[a, ab, ca][r], np.c_[ab, b, bc][r], np.c_[ca, bc, c][r], np.c_[ab, bc, ca][r]]
    for k, (p, q, o, mm) in enumerate(((a, b, c, ab), (b, c, a, bc), (c, a, b, ca))):
        gk = g & split[:, k]
        out += [np.c_[p, mm, o][gk], np.c_[mm, q, o][gk]]
    points = np.vstack([surface.points, mid])
    return Surface(points, np.vstack(out).astype(np.int64), surface.source, surface.repairs)


def _refine_onto(surface: Surface, facets: np.ndarray, onto: Surface) -> Surface:
    """:func:`refine_facets`, the new vertices moved to their closest points on
    ``onto`` (the smooth surface ``surface`` was remeshed from)."""
    n0 = len(surface.points)
    fine = refine_facets(surface, facets)
    _, on = onto.to_pyvista().find_closest_cell(fine.points[n0:], return_closest_point=True)
    points = np.vstack([fine.points[:n0], np.asarray(on, float)])
    return Surface(points, fine.triangles, fine.source, fine.repairs)


def _rim_edges(tri: np.ndarray) -> np.ndarray:
    """The edges used by one triangle of ``tri`` (oriented as in it)."""
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    _, inv, cnt = np.unique(np.sort(edges, axis=1), axis=0, return_inverse=True, return_counts=True)
    return edges[cnt[inv.ravel()] == 1]


def _clean_facets(surface: Surface, facets: np.ndarray) -> np.ndarray:
    """The facets without those at a pinch (a rim vertex where the facets meet only at
    that vertex: the layer would be non-manifold there) and without those whose three
    vertices are all on the rim (the layer has no thickness there); repeated until none
    is left."""
    for _ in range(100):
        tri = surface.triangles[facets]
        rim = _rim_edges(tri)
        count = np.bincount(rim[:, 0], minlength=len(surface.points))
        bad = np.isin(tri, np.flatnonzero(count > 1)).any(axis=1)
        bad |= (count[tri] > 0).all(axis=1)
        if not bad.any():
            return facets
        facets = facets[~bad]
        if not len(facets):
            break
    raise MeshInputError(
        f"{surface.source}: the cartilage facets are no surface with an interior (too few, "
        "or a strip one triangle wide)"
    )


def _ray_distances(origins: np.ndarray, dirs: np.ndarray, target: Surface) -> np.ndarray:
    """Distance along each ray ``origins + s dirs`` (unit ``dirs``, ``s > 0``) to its
    first crossing of the triangles of ``target`` (m; inf: no crossing; Moller-Trumbore,
    in chunks of rays)."""
    return _ray_hits(origins, dirs, target)[0]


def _ray_hits(
    origins: np.ndarray, dirs: np.ndarray, target: Surface
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_ray_distances` and the triangle of ``target`` each ray crosses first (-1:
    none)."""
    return first_ray_hits(origins, dirs, target.points[target.triangles], tol=0.0)


def _conformed_thickness(
    origins: np.ndarray,
    normals: np.ndarray,
    thickness: float,
    conform: tuple[Surface, float],
    source: str,
    along: str = "normal",
) -> np.ndarray:
    """Per-vertex thickness of a layer shaped to ``conform = (surface, clearance)``: the
    distance along the normal to that surface less the clearance (``along="vertical"``:
    the clearance measured vertically, :func:`_vertical_thickness`), at most
    ``thickness``; refused where it would be below a tenth of ``thickness`` (the bones
    too close)."""
    target, clearance = conform
    t = np.minimum(_ray_distances(origins, normals, target) - clearance, thickness)
    if along == "vertical":
        t = _vertical_thickness(origins, normals, t, thickness, conform)
    if np.any(t < 0.1 * thickness):
        k = int(np.argmin(t))
        raise MeshInputError(
            f"{source}: the surface to conform to ({target.source}) is {t[k] + clearance:.3g} m "
            f"from the bone at {np.round(origins[k], 5).tolist()} m, less than the clearance "
            f"{clearance:.3g} m plus a tenth of the thickness: pose the bones further apart"
        )
    return t


def _vertical_thickness(
    origins: np.ndarray,
    normals: np.ndarray,
    t: np.ndarray,
    thickness: float,
    conform: tuple[Surface, float],
) -> np.ndarray:
    """The thicknesses ``t`` (offsets along the unit ``normals``, first guesses) solved
    so that the point ``origins + t normals`` lies ``clearance`` below ``target``
    measured vertically (+y, the direction the joint is loaded in): Newton steps on the
    vertical gap ``g(t)`` with the slope ``dg/dt = -n_y`` of a level target (12 steps,
    each at most a quarter of ``thickness``).  Vertices whose normal is within 30° of
    horizontal, or whose solution is beyond ``thickness`` or whose upward ray misses
    ``target``, keep ``min(t, thickness)``."""
    target, clearance = conform
    ny = normals[:, 1]
    move = ny > 0.5
    t = np.minimum(t, thickness)
    up = np.tile(UP, (len(t), 1))
    for _ in range(12):
        gap = _ray_distances(origins + t[:, None] * normals, up, target)
        ok = move & np.isfinite(gap)
        step = np.where(ok, (gap - clearance) / np.where(move, ny, 1.0), 0.0)
        t = np.clip(t + np.clip(step, -0.25 * thickness, 0.25 * thickness), 0.0, thickness)
    return t


def _lower_under_target(
    bone: np.ndarray,
    verts: np.ndarray,
    normals: np.ndarray,
    t: np.ndarray,
    top: np.ndarray,
    conform: tuple[Surface, float],
    probes: np.ndarray | None = None,
) -> np.ndarray:
    """The vertically conformed thicknesses ``t`` (:func:`_vertical_thickness`) lowered
    where a vertex of ``target`` is less than ``clearance`` above the layer's articular
    triangles ``top`` (measured by a vertical ray down from it): between its own
    vertices a triangle follows ``target`` only by its chord, and where ``target``
    curves away (a convex condyle over it) the chord stands above ``target`` less the
    clearance.  Each such target vertex lowers the three vertices of the triangle under
    it by its deficit (along their normals, by deficit / n_y); the largest deficit
    counts; up to 30 passes.  Lowering only: no gap becomes smaller than the clearance.
    ``probes``: the points of ``target`` to cast the rays from (default its vertices;
    :func:`_surface_probes` adds points on its edges and facets, where an edge of
    ``target`` passes over an edge of the layer between both surfaces' vertices)."""
    target, clearance = conform
    n0 = len(bone)
    t = t.copy()
    probes = target.points if probes is None else probes
    down = np.tile(-UP, (len(probes), 1))
    ny = np.maximum(normals[:, 1], 0.5)
    for _ in range(30):
        pts = np.vstack([bone, bone[verts] + t[:, None] * normals])
        gap, tri = _ray_hits(probes, down, Surface(pts, top, "layer"))
        need = np.where(tri >= 0, clearance - gap, 0.0)
        bad = need > 1e-3 * clearance
        if not bad.any():
            break
        lower = np.zeros(len(pts))
        for k in range(3):
            np.maximum.at(lower, top[tri[bad], k], need[bad])
        inner = lower[n0:]
        t = np.maximum(t - inner / ny, 0.0)
    return t


def _surface_probes(surface: Surface, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Points of ``surface`` whose horizontal position (x, z) is within ``lo``–``hi``:
    its vertices, the points at a quarter, half and three quarters of each edge, and
    each facet's centroid (to find where it dips below another piecewise-flat surface
    between both surfaces' vertices)."""
    tri = surface.triangles
    p = surface.points
    pts = [p, p[tri].mean(axis=1)]
    for a, b in ((0, 1), (1, 2), (2, 0)):
        for w in (0.25, 0.5, 0.75):
            pts.append((1 - w) * p[tri[:, a]] + w * p[tri[:, b]])
    pts = np.vstack(pts)
    inside = np.all((pts[:, [0, 2]] >= lo[[0, 2]]) & (pts[:, [0, 2]] <= hi[[0, 2]]), axis=1)
    return pts[inside]


def _thin_where_turned(
    bone: np.ndarray,
    verts: np.ndarray,
    normals: np.ndarray,
    t: np.ndarray,
    top: np.ndarray,
    facet_normals: np.ndarray,
) -> np.ndarray:
    """The thicknesses ``t`` of a conformed layer lowered by a fifth, 20 passes at most,
    at the inner vertices of every articular triangle that the offset turned over (its
    normal against its facet's ``facet_normals``): where the bone curves more tightly
    than the layer is thick (a plateau's rim).  A layer of variable thickness can thin
    there; a uniform layer is refused instead (:func:`cartilage_layer`)."""
    n0 = len(bone)
    t = t.copy()
    for _ in range(20):
        p = np.vstack([bone, bone[verts] + t[:, None] * normals])
        nt = np.cross(p[top[:, 1]] - p[top[:, 0]], p[top[:, 2]] - p[top[:, 0]])
        bad = np.einsum("ij,ij->i", nt, facet_normals) <= 0
        if not bad.any():
            break
        k = np.unique(top[bad])
        t[k[k >= n0] - n0] *= 0.8
    return t


def _thin_where_crossing(
    bone: np.ndarray,
    verts: np.ndarray,
    normals: np.ndarray,
    t: np.ndarray,
    top: np.ndarray,
    target: Surface,
    step: float | None = None,
) -> np.ndarray:
    """The conformed thicknesses ``t`` of the inner vertices ``verts`` (unit ``normals``)
    of a layer on the points ``bone``, lowered where an articular triangle (``top``,
    into ``bone`` followed by the offset points) still crosses ``target``: it may bulge
    between the vertices by more than the clearance (its facets' chord).  Each pass
    lowers the crossing triangles' inner vertices by a quarter, or by ``step`` (m) if
    given (at most 30 passes)."""
    other = target.to_pyvista()
    n0 = len(bone)
    t = t.copy()
    for _ in range(30):
        pts = np.vstack([bone, bone[verts] + t[:, None] * normals])
        hits, count = Surface(pts, top, "layer").to_pyvista().collision(other, contact_mode=0)
        if not count:
            break
        cells = np.asarray(hits["ContactCells"])
        bad = np.unique(top[cells[cells >= 0]])
        k = bad[bad >= n0] - n0
        t[k] = t[k] * 0.75 if step is None else np.maximum(t[k] - step, 0.0)
    return t


def _shaped_thickness(
    surface: Surface,
    verts: np.ndarray,
    dirs: np.ndarray,
    facets: tuple[np.ndarray, np.ndarray],
    thickness: float,
    conform: tuple[Surface, float],
    along: str,
    rim_cap: np.ndarray,
) -> np.ndarray:
    """The offsets (m, along the unit ``dirs``) of the inner vertices ``verts`` of a layer
    conformed to ``conform = (other, clearance)`` (:func:`cartilage_layer`); ``facets`` =
    (the articular triangles into the bone's points followed by the offset ones, the
    facets' normals); ``rim_cap``: the largest offset of each vertex allowed by the rim's
    slope (vertical and lowered layers)."""
    bone, (top, fn) = surface.points, facets
    t = _conformed_thickness(bone[verts], dirs, thickness, conform, surface.source, along)
    if along != "normal":
        # no steeper than rim_slope (1: 45 degrees) towards the rim: no wall for the other
        # layer to hit
        t = np.minimum(t, np.maximum(rim_cap, 0.1 * thickness))
        probes = None
        if along == "lowered":
            region = bone[np.unique(top[top < len(bone)])]
            probes = _surface_probes(conform[0], region.min(axis=0), region.max(axis=0))
        t = _lower_under_target(bone, verts, dirs, t, top, conform, probes)
    # lowered: the layer is the other surface's copy, so it crosses only by the chords'
    # error left over: lowered in steps of a fifth of the clearance, not of the thickness
    step = 0.2 * conform[1] if along == "lowered" and conform[1] > 0 else None
    t = _thin_where_crossing(bone, verts, dirs, t, top, conform[0], step)
    if along == "vertical":
        t = _thin_where_turned(bone, verts, dirs, t, top, fn)
    return t


def cartilage_layer(
    surface: Surface,
    facets: np.ndarray,
    thickness: float,
    conform: tuple[Surface, float] | None = None,
    along: str = "normal",
    cartilage_thickness: float | None = None,
    rim_slope: float = 1.0,
) -> CartilageLayer:
    """The layer of ``thickness`` (m) on the triangles ``facets`` of a closed surface.

    With ``conform = (other, clearance)`` the layer is shaped to the surface ``other``
    (another bone's cartilage surface, facing this one): each inner vertex is offset
    along its normal to ``clearance`` short of ``other`` (the first crossing of the
    normal ray), and by ``thickness`` at most (where ``other`` is far or not crossed).
    The articular surface then follows ``other`` at the distance ``clearance`` (to the
    facets' resolution) where the two bones are close: the layers meet over a patch.
    ``along="vertical"`` measures the clearance vertically instead (+y), lowers the
    layer where a vertex of ``other`` is less than the clearance above it, keeps it no
    steeper than 45° towards its rim (``rim_slope`` = 1; thickness at most ``rim_slope``
    times the distance from the rim) and thins it where the offset would turn a facet
    over (a vertical load then closes the patch at once).  ``along="lowered"`` offsets
    every inner vertex straight up instead of along its normal, to ``clearance`` below
    ``other`` (the articular surface is ``other`` lowered by the clearance, lowered
    further where a vertex of ``other`` dips below its facets' chords), with the same
    rim slope; its top facets project onto the bone's, so none turns over.  With
    ``cartilage_thickness`` the layer is split by a middle surface (``mid``): the top
    ``cartilage_thickness`` of each offset is cartilage, the rest subchondral bone (at
    least a fifth of the offset).

    Every inner vertex of the facets is offset outward along its normal (the
    area-weighted mean of the normals of its facets) by ``thickness``; the vertices of
    the facets' rim (edges used by one facet) stay, so the layer tapers to nothing over
    the ring of facets at its rim (as articular cartilage thins at its edge) and its
    articular surface meets the bone surface there without a step.  Facets at a pinch
    of the selection, and facets with all three vertices on the rim, are left out.

    Raises
    ------
    MeshInputError
        If an offset triangle turns over (the facets curve more tightly than the
        thickness), nothing is left of the selection, or the layer encloses no volume.
    """
    check_positive(thickness=thickness)
    facets = _clean_facets(surface, np.asarray(facets, np.int64))
    base = surface.triangles[facets]
    fn = surface.triangle_normals(unit=False)[facets]
    on_rim = np.zeros(len(surface.points), bool)
    on_rim[_rim_edges(base).ravel()] = True
    verts = np.unique(base)
    verts = verts[~on_rim[verts]]
    vn = np.zeros((len(surface.points), 3))
    for k in range(3):
        np.add.at(vn, base[:, k], fn)
    vn = vn[verts] / np.linalg.norm(vn[verts], axis=1, keepdims=True)
    if along == "lowered":  # offset straight up: the top facets project onto the base's
        vn = np.tile(UP, (len(verts), 1))
    n0 = len(surface.points)
    new_id = np.arange(n0, dtype=np.int64)
    new_id[verts] = n0 + np.arange(len(verts))
    top = new_id[base]
    t = np.full(len(verts), thickness)
    if conform is not None:
        rim_distance = cKDTree(surface.points[on_rim]).query(surface.points[verts])[0]
        t = _shaped_thickness(
            surface, verts, vn, (top, fn), thickness, conform, along, rim_slope * rim_distance
        )
    points = np.vstack([surface.points, surface.points[verts] + t[:, None] * vn])
    nt = np.cross(points[top[:, 1]] - points[top[:, 0]], points[top[:, 2]] - points[top[:, 0]])
    # turned over: against its facet; lowered, the facet and its top project alike (a top
    # facet may tilt the other way, but its side facing up must stay up)
    ref = fn * [0.0, 1.0, 0.0] if along == "lowered" else fn
    if np.any(np.einsum("ij,ij->i", nt, ref) <= 0):
        raise MeshInputError(
            f"{surface.source}: a cartilage layer of {thickness:.3g} m turns a facet over "
            "(the facets curve more tightly than the thickness): use a thinner layer"
        )
    mid = None
    if cartilage_thickness is not None:
        sub = np.maximum(t - cartilage_thickness, 0.2 * t)
        new_id[verts] = len(points) + np.arange(len(verts))
        mid = new_id[base]
        points = np.vstack([points, surface.points[verts] + sub[:, None] * vn])
    layer = CartilageLayer(points, base, top, facets, mid)
    if layer.volume <= 0:
        raise MeshInputError(f"{surface.source}: the cartilage layer encloses no volume")
    return layer


# -------------------------------------------------------------------------- meshing
@dataclass(frozen=True)
class JointBone:
    """One bone of :func:`joint_from_surfaces`.

    Parameters
    ----------
    name
        Prefix of its groups: ``<name>_cortical``, ``<name>_cancellous`` (or ``<name>``
        without a cortex), ``<name>_surface`` (the facets no region took).
    surface
        Its closed surface (m).
    cortical_thickness
        Thickness of the cortical shell (m); ``None``: one cell group ``<name>``.
    regions
        Facet groups on its surface (first match wins), after the cartilage's facets.
    cartilage
        An optional cartilage layer.
    """

    name: str
    surface: Surface
    cortical_thickness: float | None = None
    regions: Sequence[SurfaceRegion] = ()
    cartilage: Cartilage | None = None


@dataclass
class _BoneParts:
    name: str
    points: np.ndarray
    patches: dict[str, np.ndarray]  # facet group -> triangles into points
    inner: list[Surface]
    layer: CartilageLayer | None
    cartilage: Cartilage | None


def _conform_target(cart: Cartilage, done: Sequence[_BoneParts]) -> tuple[Surface, float] | None:
    """The outer surface (cartilage included; and the clearance) a layer is shaped to,
    from a bone built before it."""
    if cart.conform_to is None:
        return None
    for part in done:
        if part.name == cart.conform_to and part.layer is not None:
            if cart.conform_along == "lowered":
                return _lowered_target(part), cart.clearance
            return _outer_surface(part), cart.clearance
    names = [p.name for p in done if p.layer is not None]
    raise MeshInputError(
        f"cartilage {cart.name!r}: conform_to = {cart.conform_to!r} is no bone with cartilage "
        f"listed before it (allowed: {names})"
    )


def _bone_parts(
    bone: JointBone, h: float, remesh: bool, done: Sequence[_BoneParts] = ()
) -> _BoneParts:
    """A bone's remeshed surface split into facet groups, its cartilage layer (shaped to
    an earlier bone's layer if asked) and its cortical inner surface."""
    outer = prepare_surface(bone.surface, size=h if remesh else None)
    facets = None
    regions = list(bone.regions)
    layer = None
    if bone.cartilage is not None:
        for _ in range(bone.cartilage.refine):
            outer = _refine_onto(outer, bone.cartilage.select(outer), bone.surface)
        facets = bone.cartilage.select(outer)
        if not len(facets):
            raise MeshInputError(
                f"{outer.source}: the regions of the cartilage {bone.cartilage.name!r} select "
                "no triangle of the surface"
            )
        conform = _conform_target(bone.cartilage, done)
        cart = bone.cartilage
        layer = cartilage_layer(
            outer,
            facets,
            cart.thickness,
            conform,
            cart.conform_along,
            cart.cartilage_thickness,
            cart.rim_slope,
        )
    keep = np.ones(len(outer.triangles), bool)
    if layer is not None:
        keep[layer.facets] = False
    rest = Surface(outer.points, outer.triangles[keep], outer.source)
    groups = select_triangles(rest, regions, f"{bone.name}_surface")
    patches = {g: rest.triangles[idx] for g, idx in groups.items()}
    points = outer.points if layer is None else layer.points
    t = bone.cortical_thickness
    inner = [] if t is None else cortical_inner_surface(outer, t, h)
    return _BoneParts(bone.name, points, patches, inner, layer, bone.cartilage)


def _lowered_target(part: _BoneParts) -> Surface:
    """The surface a ``"lowered"`` layer follows: the other bone's outer surface
    (cartilage included) together with its bone surface (bare and under its cartilage)
    lowered by its cartilage's thickness (not a closed surface: rays and collisions take
    the nearer of the two).  Where that bone is bare, or its layer tapers towards its rim,
    the layer beneath then stays the clearance below a full-thickness layer and the gap
    opens: no bare bone or tapered rim in the contact."""
    tri = [*part.patches.values(), part.layer.base]
    n = len(part.points)
    low = part.points - part.cartilage.thickness * UP
    bone = np.vstack(tri) + n
    outer = _outer_surface(part)
    return Surface(np.vstack([part.points, low]), np.vstack([outer.triangles, bone]), part.name)


def _outer_surface(part: _BoneParts) -> Surface:
    """The closed outer surface of a bone with its cartilage (for the intersection check)."""
    tri = list(part.patches.values())
    if part.layer is not None:
        tri += [part.layer.top]
    return Surface(part.points, np.vstack(tri), part.name)


def _check_apart(parts: list[_BoneParts]) -> None:
    """Refuse bones whose outer surfaces (cartilage included) cross each other."""
    for i, a in enumerate(parts):
        for b in parts[i + 1 :]:
            hits, n = (
                _outer_surface(a)
                .to_pyvista()
                .collision(_outer_surface(b).to_pyvista(), contact_mode=0)
            )
            if n:
                where = np.asarray(hits.extract_cells(hits["ContactCells"]).points).mean(axis=0)
                raise MeshInputError(
                    f"the surfaces of {a.name!r} and {b.name!r} (with their cartilage) cross "
                    f"each other at {n} triangle(s), near {np.round(where, 5).tolist()} m: "
                    "leave a larger gap between the bones (pose_on) or use thinner layers"
                )


def _add_bone(part: _BoneParts, tags: PhysicalGroups, next_node: int, facet_groups: dict) -> int:
    """Discrete surfaces, volumes and cell groups of one bone; facet groups collected in
    ``facet_groups`` (name -> entities).  Returns the next free node tag."""
    m, x = gmsh.model, part.points
    added = np.zeros(len(x), bool)

    def entity(tri: np.ndarray) -> int:
        e = m.addDiscreteEntity(2)
        new = np.unique(tri)
        new = new[~added[new]]
        added[new] = True
        if len(new):
            m.mesh.addNodes(2, e, new + next_node, x[new].ravel())
        m.mesh.addElementsByType(e, 2, [], (tri + next_node).ravel())
        return e

    ent = {g: entity(tri) for g, tri in part.patches.items()}
    for g, e in ent.items():
        facet_groups.setdefault(g, []).append(e)
    outer = list(ent.values())
    layer_ents = None
    if part.layer is not None:
        base, top = entity(part.layer.base), entity(part.layer.top)
        outer.append(base)
        layer_ents = (base, top)
        if part.layer.mid is not None:
            layer_ents = (base, entity(part.layer.mid), top)
        facet_groups.setdefault(part.cartilage.contact, []).append(top)
    next_node += len(x)
    kernel = m.geo
    holes = []
    for s in part.inner:
        e = m.addDiscreteEntity(2)
        m.mesh.addNodes(2, e, np.arange(len(s.points)) + next_node, s.points.ravel())
        m.mesh.addElementsByType(e, 2, [], (s.triangles + next_node).ravel())
        next_node += len(s.points)
        holes.append(kernel.addSurfaceLoop([e]))
    shell = kernel.addVolume([kernel.addSurfaceLoop(outer), *holes])
    cores = [kernel.addVolume([loop]) for loop in holes]
    cart, sub = None, None
    if layer_ents is not None:
        cart = kernel.addVolume([kernel.addSurfaceLoop(list(layer_ents[-2:]))])
    if layer_ents is not None and len(layer_ents) == 3:
        sub = kernel.addVolume([kernel.addSurfaceLoop(list(layer_ents[:2]))])
    kernel.synchronize()
    if part.inner:
        tags(3, [shell], f"{part.name}_cortical")
        tags(3, cores, f"{part.name}_cancellous")
    else:
        tags(3, [shell], part.name)
    if cart is not None:
        tags(3, [cart], part.cartilage.name)
    if sub is not None:
        tags(3, [sub], part.cartilage.subchondral)
    return next_node


def joint_from_surfaces(
    bones: Sequence[JointBone],
    h: float,
    *,
    remesh: bool = True,
    comm: MPI.Comm | None = None,
    path: str | Path | None = None,
) -> MeshData | Path:
    """Tetrahedral mesh of several bones (a joint), each with its cortex and cartilage.

    Each bone's surface is checked and (``remesh``) remeshed to ``h`` (pyacvd; a coarse
    surface is refined), its cartilage facets selected and offset outward
    (:func:`cartilage_layer`), the rest of its surface split into its regions' facet
    groups, its cortical inner surface built
    (:func:`~bonecontact.meshing.stl.cortical_inner_surface`); gmsh tetrahedralises
    every volume with tetrahedra no larger than ``h``.

    Returns
    -------
    dolfinx.io.gmsh.MeshData or pathlib.Path
        Per bone: cell groups ``<name>_cortical``, ``<name>_cancellous`` (or ``<name>``)
        and the cartilage's ``name``; facet groups: the regions' names, the cartilage's
        ``contact`` (its articular surface), ``<name>_surface`` (the rest of the
        surface).  Groups named alike in several bones are
        merged.

    Raises
    ------
    MeshInputError
        On every rank: a broken surface, a region or cartilage region selecting nothing,
        a layer that turns over, two bones whose surfaces (with their cartilage) cross.
    bonecontact.meshing.MeshingError
        On every rank: gmsh failed.
    """
    check_positive(h=h)
    comm = MPI.COMM_WORLD if comm is None else comm
    parts, error = None, None
    if comm.rank == 0:
        try:
            parts = []
            for b in bones:
                parts.append(_bone_parts(b, h, remesh, parts))
            _check_apart(parts)
        except (MeshInputError, ValueError) as exc:
            error = exc
    error = comm.bcast(error, root=0)
    if error is not None:
        raise error

    def build() -> None:
        tags, facet_groups, next_node = PhysicalGroups(), {}, 1
        for part in parts:
            next_node = _add_bone(part, tags, next_node, facet_groups)
        for g, ents in facet_groups.items():
            tags(2, ents, g)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.Algorithm3D", 1)  # Delaunay

    return generate("joint", 3, build, comm, path)
