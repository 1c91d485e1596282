"""Stress intensity factors along the front of a crack in 3D
(docs/theory/fracture.md#3d-crack-fronts).

* :class:`EllipticalFront`, :class:`PolygonFront`, :class:`PolylineFront`,
  :class:`OpenPolylineFront` — a penny or elliptical front, the straight edges of a planar
  convex polygon, the closed polyline front of a grown (non-planar) crack with a frame per
  edge, and the open one of a grown surface crack: points, the local frame (e₁
  ahead of the front, e₂ the crack-surface normal, e₃ = e₁ × e₂ along the front), arc
  length (:class:`CrackFront`, the protocol the integrals use).
* :func:`mesh_crack_octant` — one eighth of a block with a planar crack at its centre
  and its three symmetry planes (mode I only), graded by gmsh towards the front; models
  with both faces come from :mod:`bonecontact.fracture.body3d`.
* :func:`front_interaction_integral` — K_I, K_II, K_III at one front point by the 3D
  domain interaction integral (Williams and anti-plane auxiliary fields in the
  coordinates of the ellipse the front lies on, singular along the whole front, a ring ×
  plateau q-function, the faces' part of the boundary on a two-face model).
* :func:`front_displacement_correlation` — K from the face opening (the cheap cross-check).
* :func:`penny_k`, :func:`irwin_k` — closed forms of a penny and an elliptical crack.

The domain must be small against the front's radius of curvature and must not reach a
corner of a polygonal front; one homogeneous isotropic material around the front.
"""

from __future__ import annotations

import math
import weakref
from contextlib import nullcontext
from dataclasses import dataclass, field
from functools import cached_property
from typing import Protocol

from mpi4py import MPI

import gmsh
import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import default_scalar_type, fem, geometry, mesh
from dolfinx.io.gmsh import model_to_mesh
from scipy.special import ellipe, ellipeinc

from bonecontact.common.errors import ParameterError, RunError
from bonecontact.fracture.williams import elastic_constants
from bonecontact.materials.laws import Isotropic
from bonecontact.meshing.builder import MeshingError
from bonecontact.meshing.session import gmsh_session

__all__ = [
    "OCTANT_GROUPS",
    "CrackBlock",
    "CrackFront",
    "EllipticalFront",
    "FrontSIF",
    "OpenPolylineFront",
    "PolygonFront",
    "PolylineFront",
    "front_displacement_correlation",
    "front_interaction_integral",
    "irwin_k",
    "mesh_crack_octant",
    "penny_k",
]

#: Boundary groups of :func:`mesh_crack_octant` (facet tags).
OCTANT_GROUPS = {
    "crack": 2,
    "ligament": 3,
    "sym_x": 4,
    "sym_y": 5,
    "top": 6,
    "side_x": 7,
    "side_y": 8,
}
_SAMPLES = 4001  # points of the front segment in the normalising integral
#: The least normalising front integral ∫ q_h (e₁·e₁(s)) ds of a domain, in units of its
#: half-length along the front: a whole domain gives about 1.5 (measured 1.43–1.53), one
#: halved by a symmetry plane through the point 0.73; less means the front within the
#: domain lies mostly outside the mesh, and K = I/∫ would be a ratio of two slivers.
NORM_FLOOR = 0.5


# ------------------------------------------------------------------- closed forms
def penny_k(sigma: float, a: float) -> float:
    """K_I = 2σ√(a/π) of a penny-shaped crack of radius ``a`` under remote tension σ."""
    return 2.0 * sigma * math.sqrt(a / math.pi)


def irwin_k(sigma: float, a: float, b: float, phi: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Irwin's K_I of an elliptical crack (semi-axes a ≥ b) under remote tension σ.

    K_I(φ) = σ√(πb)/E(k) · (sin²φ + (b/a)² cos²φ)^¼, k² = 1 − b²/a², at the front point
    (a cos φ, b sin φ); E the complete elliptic integral of the second kind.
    """
    if not (a >= b > 0):
        raise ParameterError("b", f"need a >= b > 0, got a={a}, b={b}")
    phi = np.asarray(phi, dtype=float)
    E = ellipe(1.0 - (b / a) ** 2)  # scipy's argument is m = k²
    return (
        sigma
        * math.sqrt(math.pi * b)
        / E
        * (np.sin(phi) ** 2 + (b / a) ** 2 * np.cos(phi) ** 2) ** 0.25
    )


# ------------------------------------------------------------------------ the front
@dataclass(frozen=True)
class EllipticalFront:
    """The front of a planar elliptical crack x = c + a cos φ u + b sin φ v (a = b: penny).

    Parameters
    ----------
    a, b
        Semi-axes (m), a ≥ b > 0: ``a`` along u, ``b`` along v.
    centre
        Centre of the crack (m).
    axes
        Rows (u, v, n): orthonormal, right-handed; u the direction of the semi-axis ``a``,
        n the crack-plane normal.  ``None``: (x, y, z), the crack plane z = centre[2].
    """

    a: float
    b: float
    centre: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axes: tuple[tuple[float, float, float], ...] | None = None

    def __post_init__(self) -> None:
        for key in ("a", "b"):
            v = getattr(self, key)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(key, f"must be a positive number, got {v!r}")
        if self.b > self.a:
            raise ParameterError(
                "b", f"the semi-axis along y must not exceed a, got b={self.b} > a={self.a}"
            )
        if self.axes is not None:
            R = np.asarray(self.axes, dtype=float)
            if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9):
                raise ParameterError("axes", "must be three orthonormal rows (u, v, n)")
            if np.linalg.det(R) < 0:
                raise ParameterError("axes", "must be right-handed: n = u × v")

    @property
    def rotation(self) -> npt.NDArray[np.float64]:
        """Rows (u, v, n) of the crack's frame, shape (3, 3)."""
        return np.eye(3) if self.axes is None else np.asarray(self.axes, dtype=float)

    @property
    def normal(self) -> npt.NDArray[np.float64]:
        """The crack-plane normal n (the side of the ``upper`` face)."""
        return self.rotation[2].copy()

    def point(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Front points at parameters ``phi``, shape (n, 3)."""
        phi = np.atleast_1d(np.asarray(phi, dtype=float))
        c = np.asarray(self.centre, dtype=float)
        local = np.column_stack([self.a * np.cos(phi), self.b * np.sin(phi), 0 * phi])
        return c + local @ self.rotation

    def frame(self, phi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(e₁, e₂, e₃) at ``phi``: e₁ the outward in-plane normal of the front (ahead of
        the crack), e₂ = n (the crack-plane normal), e₃ = e₁ × e₂ (along the front)."""
        R = self.rotation
        n = np.array([self.b * math.cos(phi), self.a * math.sin(phi), 0.0])
        e1 = (n / np.linalg.norm(n)) @ R
        e2 = R[2].copy()
        return e1, e2, np.cross(e1, e2)

    def radius_of_curvature(self, phi: float) -> float:
        """ρ(φ) = (a² sin²φ + b² cos²φ)^{3/2}/(ab) (m)."""
        s, c = math.sin(phi), math.cos(phi)
        return (self.a**2 * s * s + self.b**2 * c * c) ** 1.5 / (self.a * self.b)

    def local(self, x: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Coordinates of points ``x`` (n, 3) in the crack's frame (along u, v, n)."""
        d = np.atleast_2d(np.asarray(x, dtype=float)) - np.asarray(self.centre, dtype=float)
        return d @ self.rotation.T

    def nearest(self, x: npt.ArrayLike, iterations: int = 12) -> npt.NDArray[np.float64]:
        """Parameter φ of the nearest front point of each point ``x`` (n, 3): Newton on
        d/dφ |x − x(φ)|² = 0 from φ = atan2(a·y, b·x) (points near the front)."""
        d = self.local(x)
        X, Y = d[:, 0], d[:, 1]
        a, b = self.a, self.b
        t = np.arctan2(a * Y, b * X)
        for _ in range(iterations):
            f = (a * a - b * b) * np.sin(t) * np.cos(t) - X * a * np.sin(t) + Y * b * np.cos(t)
            df = (a * a - b * b) * np.cos(2 * t) - X * a * np.cos(t) - Y * b * np.sin(t)
            t = t - f / np.where(np.abs(df) > 1e-300, df, 1e-300)
        return t

    def arc_length(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Arc length from φ = 0 to ``phi`` (m): a[E(m) − E(π/2 − φ | m)], m = 1 − b²/a²."""
        m = 1.0 - (self.b / self.a) ** 2
        return self.a * (ellipe(m) - ellipeinc(0.5 * math.pi - np.asarray(phi, dtype=float), m))

    @property
    def perimeter(self) -> float:
        """Length of the whole front (m)."""
        return 4.0 * self.a * float(ellipe(1.0 - (self.b / self.a) ** 2))

    def normals(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """e₁ (the outward in-plane normal of the front) at parameters ``phi``, shape (n, 3)."""
        phi = np.atleast_1d(np.asarray(phi, dtype=float))
        e1 = np.column_stack([self.b * np.cos(phi), self.a * np.sin(phi), 0 * phi])
        return (e1 / np.linalg.norm(e1, axis=1)[:, None]) @ self.rotation

    def parameter_span(self, length: float) -> float:
        """A parameter half-range about any point that covers arc length ``length`` each
        way (|dx/dφ| ≥ b)."""
        return min(math.pi, 1.01 * length / self.b)

    def corner_distance(self, phi: float) -> float:
        """Arc length from the point to the nearest corner of the front: ∞ (smooth)."""
        return math.inf

    @property
    def closed(self) -> bool:
        """True: the front is a closed curve (arc length wraps at the perimeter)."""
        return True


class CrackFront(Protocol):
    """The front protocol of :func:`front_interaction_integral` and
    :func:`front_displacement_correlation` (:class:`EllipticalFront`,
    :class:`PolygonFront`): a closed planar curve with a parameter φ ∈ [0, 2π)."""

    a: float  # the largest distance from the centre to the front (m)
    b: float  # the smallest (m)
    centre: tuple[float, float, float]

    @property
    def rotation(self) -> npt.NDArray[np.float64]: ...  # rows (u, v, n)

    @property
    def normal(self) -> npt.NDArray[np.float64]: ...

    @property
    def perimeter(self) -> float: ...

    def point(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]: ...

    def frame(self, phi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    def normals(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]: ...

    def radius_of_curvature(self, phi: float) -> float: ...  # ∞ on a straight edge

    def corner_distance(self, phi: float) -> float: ...  # or to the free surface

    @property
    def closed(self) -> bool: ...  # False: the front ends on the free surface

    def nearest(self, x: npt.ArrayLike) -> npt.NDArray[np.float64]: ...

    def arc_length(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]: ...

    def parameter_span(self, length: float) -> float: ...


class _ClosedPolyline:
    """What the straight-edged fronts share: a closed polyline through ``vertices``
    parametrised by φ = 2π s/P (s the arc length from the first vertex, P the perimeter).
    The classes that use it give ``vertices`` and ``centre``."""

    @cached_property
    def _v(self) -> npt.NDArray[np.float64]:
        return np.asarray(self.vertices, dtype=float)

    @cached_property
    def _dirs(self) -> npt.NDArray[np.float64]:
        d = np.roll(self._v, -1, axis=0) - self._v
        return d / self.edge_lengths[:, None]

    @cached_property
    def edge_lengths(self) -> npt.NDArray[np.float64]:
        """Length of every edge (vertex k to k + 1), m."""
        return np.linalg.norm(np.roll(self._v, -1, axis=0) - self._v, axis=1)

    @cached_property
    def _cum(self) -> npt.NDArray[np.float64]:
        return np.concatenate([[0.0], np.cumsum(self.edge_lengths)])

    @property
    def perimeter(self) -> float:
        """Length of the whole front (m)."""
        return float(self._cum[-1])

    @property
    def a(self) -> float:
        """The largest distance from the centre to a vertex (circumradius, m)."""
        return float(np.max(np.linalg.norm(self._v - np.asarray(self.centre), axis=1)))

    @property
    def b(self) -> float:
        """The smallest distance from the centre to an edge (inradius, m)."""
        d = np.asarray(self.centre) - self._v
        off = d - np.sum(d * self._dirs, axis=1)[:, None] * self._dirs
        return float(np.min(np.linalg.norm(off, axis=1)))

    def _edge(self, phi: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Edge index and distance along it of the points at ``phi``."""
        s = np.mod(np.atleast_1d(np.asarray(phi, dtype=float)), 2 * math.pi)
        s = s * self.perimeter / (2 * math.pi)
        k = np.clip(np.searchsorted(self._cum, s, side="right") - 1, 0, len(self._v) - 1)
        return k, s - self._cum[k]

    def point(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Front points at parameters ``phi``, shape (n, 3)."""
        k, t = self._edge(phi)
        return self._v[k] + t[:, None] * self._dirs[k]


@dataclass(frozen=True)
class PolygonFront(_ClosedPolyline):
    """The front of a planar convex polygonal crack: its straight edges.

    The parameter is φ = 2π s/P, s the arc length from the first vertex along the edges
    in the vertices' order, P the perimeter.  On an edge the frame is constant: e₁ the
    in-plane normal of the edge pointing out of the crack, e₂ = n, e₃ = e₁ × e₂ (along
    the edge, against the vertices' order); the radius of curvature is ∞.

    Parameters
    ----------
    vertices
        Corners (m), counter-clockwise about n = ``axes[2]``, convex, in the plane
        through ``centre`` normal to n.
    centre
        A point inside (the centroid).
    axes
        Rows (u, v, n), orthonormal and right-handed.
    """

    vertices: tuple[tuple[float, float, float], ...]
    centre: tuple[float, float, float]
    axes: tuple[tuple[float, float, float], ...]

    @property
    def rotation(self) -> npt.NDArray[np.float64]:
        """Rows (u, v, n) of the crack's frame, shape (3, 3)."""
        return np.asarray(self.axes, dtype=float)

    @property
    def normal(self) -> npt.NDArray[np.float64]:
        """The crack-plane normal n (the side of the ``upper`` face)."""
        return self.rotation[2].copy()

    def normals(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """e₁ (the outward in-plane normal of the edge) at parameters ``phi``, (n, 3)."""
        k, _ = self._edge(phi)
        return np.cross(self._dirs[k], self.rotation[2])

    def frame(self, phi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(e₁, e₂, e₃) at ``phi``: e₁ the outward normal of the edge in the plane, e₂ = n,
        e₃ = e₁ × e₂ (along the edge)."""
        e1 = self.normals(phi)[0]
        e2 = self.rotation[2].copy()
        return e1, e2, np.cross(e1, e2)

    def radius_of_curvature(self, phi: float) -> float:
        """∞: the edges are straight."""
        return math.inf

    @property
    def closed(self) -> bool:
        """True: the front is a closed polygon."""
        return True

    def corner_distance(self, phi: float) -> float:
        """Distance from the point at ``phi`` to the nearer end of its edge (m)."""
        k, t = self._edge(phi)
        return float(min(t[0], self.edge_lengths[k[0]] - t[0]))

    def local(self, x: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Coordinates of points ``x`` (n, 3) in the crack's frame (along u, v, n)."""
        d = np.atleast_2d(np.asarray(x, dtype=float)) - np.asarray(self.centre, dtype=float)
        return d @ self.rotation.T

    def nearest(self, x: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Parameter φ of the nearest front point of each point ``x`` (n, 3)."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        d = x[:, None, :] - self._v[None, :, :]  # (n, m, 3)
        t = np.clip(np.einsum("nmk,mk->nm", d, self._dirs), 0.0, self.edge_lengths[None, :])
        dist = np.linalg.norm(d - t[:, :, None] * self._dirs[None, :, :], axis=2)
        k = np.argmin(dist, axis=1)
        s = self._cum[k] + t[np.arange(len(x)), k]
        return 2 * math.pi * s / self.perimeter

    def arc_length(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Arc length from the first vertex to ``phi`` (m): s = φP/2π (unwrapped)."""
        return np.asarray(phi, dtype=float) * self.perimeter / (2 * math.pi)

    def parameter_span(self, length: float) -> float:
        """A parameter half-range about any point that covers arc length ``length`` each
        way."""
        return min(math.pi, 1.01 * length * 2 * math.pi / self.perimeter)


@dataclass(frozen=True)
class PolylineFront(_ClosedPolyline):
    """The closed polyline front of a grown, non-planar crack: straight edges, each with
    its own frame.

    The parameter is φ = 2π s/P as on :class:`PolygonFront`.  On edge k (vertex k to
    k + 1, t its direction) the frame is e₂ = ``normals2[k]`` (the normal of the crack
    surface at the edge, on the ``upper`` side), e₁ = t × e₂ (ahead of the front), e₃ =
    e₁ × e₂ = −t.  ``cuts[k]`` = (L, ψ): the crack surface behind the edge is straight for
    L (m) and then turns into the direction ψ (the angle from e₁ towards e₂ of the older
    surface, seen from the kink); ``None`` or L = ∞: straight as far as the integral
    reaches.  The auxiliary field's branch cut is laid along that kink
    (docs/theory/fracture.md#mixed-mode-advance-in-3d).

    Parameters
    ----------
    vertices
        The front's corners (m), shape (N, 3), in the order the ``upper`` side sees as
        counter-clockwise.
    normals2
        e₂ of every edge, shape (N, 3), unit and normal to the edge.
    cuts
        (L, ψ) of every edge, or ``None``.
    reference
        A unit normal of the whole crack (the side of ``crack_upper``).
    """

    vertices: tuple[tuple[float, float, float], ...]
    normals2: tuple[tuple[float, float, float], ...]
    cuts: tuple[tuple[float, float], ...] | None = None
    reference: tuple[float, float, float] = (0.0, 0.0, 1.0)

    @property
    def centre(self) -> tuple[float, float, float]:
        """The mean of the vertices (m)."""
        return tuple(map(float, self._v.mean(axis=0)))

    @property
    def normal(self) -> npt.NDArray[np.float64]:
        """The crack's reference normal (the side of the ``upper`` face)."""
        return np.asarray(self.reference, dtype=float)

    @property
    def rotation(self) -> npt.NDArray[np.float64]:
        """Rows (u, v, n): n the reference normal, u towards the first vertex."""
        n = self.normal
        u = self._v[0] - np.asarray(self.centre)
        u = u - (u @ n) * n
        u = u / np.linalg.norm(u)
        return np.vstack([u, np.cross(n, u), n])

    def normals(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """e₁ = t × e₂ of the edges at parameters ``phi``, (n, 3)."""
        k, _ = self._edge(phi)
        return np.cross(self._dirs[k], np.asarray(self.normals2, dtype=float)[k])

    def frame(self, phi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(e₁, e₂, e₃) of the edge at ``phi``."""
        k, _ = self._edge(phi)
        e2 = np.asarray(self.normals2[int(k[0])], dtype=float)
        e1 = np.cross(self._dirs[int(k[0])], e2)
        return e1, e2, np.cross(e1, e2)

    def cut(self, phi: float) -> tuple[float, float] | None:
        """(L, ψ) of the edge at ``phi`` (``None``: the surface behind it is straight)."""
        if self.cuts is None:
            return None
        k, _ = self._edge(phi)
        c = self.cuts[int(k[0])]
        return None if math.isinf(c[0]) or abs(math.sin(c[1])) < 1e-9 else c

    def radius_of_curvature(self, phi: float) -> float:
        """∞: the edges are straight."""
        return math.inf

    @property
    def closed(self) -> bool:
        """True: the front is a closed polyline."""
        return True

    def corner_distance(self, phi: float) -> float:
        """Distance from the point at ``phi`` to the nearer end of its edge (m)."""
        k, t = self._edge(phi)
        return float(min(t[0], self.edge_lengths[k[0]] - t[0]))

    def nearest(self, x: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Parameter φ of the nearest front point of each point ``x`` (n, 3)."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        d = x[:, None, :] - self._v[None, :, :]
        t = np.clip(np.einsum("nmk,mk->nm", d, self._dirs), 0.0, self.edge_lengths[None, :])
        dist = np.linalg.norm(d - t[:, :, None] * self._dirs[None, :, :], axis=2)
        k = np.argmin(dist, axis=1)
        s = self._cum[k] + t[np.arange(len(x)), k]
        return 2 * math.pi * s / self.perimeter

    def arc_length(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Arc length from the first vertex to ``phi`` (m)."""
        return np.asarray(phi, dtype=float) * self.perimeter / (2 * math.pi)

    def parameter_span(self, length: float) -> float:
        """A parameter half-range that covers arc length ``length`` each way."""
        return min(math.pi, 1.01 * length * 2 * math.pi / self.perimeter)


@dataclass(frozen=True)
class OpenPolylineFront(PolylineFront):
    """The open polyline front of a grown (non-planar) surface-breaking crack: N vertices,
    the first and the last on the free surface, N − 1 straight edges, each with its own
    frame as on :class:`PolylineFront`.

    The parameter is φ = 2π s/L ∈ [0, 2π], s the arc length from the first vertex and L
    the front's length; it is not wrapped (φ = 2π is the last vertex) and points beyond
    either end are clipped to it.  :meth:`corner_distance` is the distance to the nearer
    end of the point's edge: a corner of the front or, on the first and last edges, the
    free surface (:func:`~bonecontact.fracture.surface3d.domain_length` keeps the domain
    off both).

    Parameters
    ----------
    vertices
        The front's points (m), shape (N, 3), N ≥ 2, ordered so that e₁ = t × e₂ points
        ahead of the front (t the edge's direction).
    normals2
        e₂ of every edge, shape (N − 1, 3), unit and normal to the edge.
    cuts
        (L, ψ) of every edge, or ``None``.
    reference
        A unit normal of the whole crack (the side of ``crack_upper``).
    """

    def __post_init__(self) -> None:
        if len(self.vertices) < 2 or len(self.normals2) != len(self.vertices) - 1:
            raise ParameterError(
                "normals2",
                f"need N >= 2 vertices and N - 1 edge normals, got {len(self.vertices)} "
                f"and {len(self.normals2)}",
            )
        if self.cuts is not None and len(self.cuts) != len(self.normals2):
            raise ParameterError("cuts", "need one (L, psi) per edge")
        if np.min(self.edge_lengths) <= 0:
            raise ParameterError("vertices", "two consecutive vertices coincide")

    @cached_property
    def edge_lengths(self) -> npt.NDArray[np.float64]:
        """Length of every edge (vertex k to k + 1), m."""
        return np.linalg.norm(np.diff(self._v, axis=0), axis=1)

    @cached_property
    def _dirs(self) -> npt.NDArray[np.float64]:
        return np.diff(self._v, axis=0) / self.edge_lengths[:, None]

    @property
    def b(self) -> float:
        """The smallest distance from the centre to an edge's line (m)."""
        d = np.asarray(self.centre) - self._v[:-1]
        off = d - np.sum(d * self._dirs, axis=1)[:, None] * self._dirs
        return float(np.min(np.linalg.norm(off, axis=1)))

    def _edge(self, phi: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Edge index and distance along it of the points at ``phi`` (clipped to the
        front)."""
        s = np.atleast_1d(np.asarray(phi, dtype=float)) * self.perimeter / (2 * math.pi)
        s = np.clip(s, 0.0, self.perimeter)
        k = np.clip(np.searchsorted(self._cum, s, side="right") - 1, 0, len(self._v) - 2)
        return k, s - self._cum[k]

    @property
    def closed(self) -> bool:
        """False: the front ends on the free surface."""
        return False

    def nearest(self, x: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Parameter φ of the nearest front point of each point ``x`` (n, 3)."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        d = x[:, None, :] - self._v[None, :-1, :]
        t = np.clip(np.einsum("nmk,mk->nm", d, self._dirs), 0.0, self.edge_lengths[None, :])
        dist = np.linalg.norm(d - t[:, :, None] * self._dirs[None, :, :], axis=2)
        k = np.argmin(dist, axis=1)
        s = self._cum[k] + t[np.arange(len(x)), k]
        return 2 * math.pi * s / self.perimeter

    def edge_middles(self) -> npt.NDArray[np.float64]:
        """The parameters of the edges' midpoints, shape (N − 1,)."""
        return 2 * math.pi * (self._cum[:-1] + 0.5 * self.edge_lengths) / self.perimeter


# ------------------------------------------------------------------------- meshing
@dataclass
class CrackBlock:
    """A meshed block with a planar crack (one octant, see :func:`mesh_crack_octant`).

    Attributes
    ----------
    mesh, cell_tags, facet_tags
        The DOLFINx mesh and markers (cells: tag 1; facets: :data:`OCTANT_GROUPS`).
    front
        The crack front (:class:`EllipticalFront` or :class:`PolygonFront`).
    groups
        Facet group name → tag.
    half_model
        The crack plane is a symmetry plane of the model (only one face is meshed).
    """

    mesh: mesh.Mesh
    cell_tags: mesh.MeshTags
    facet_tags: mesh.MeshTags
    front: EllipticalFront | PolygonFront | PolylineFront | OpenPolylineFront
    groups: dict[str, int] = field(default_factory=lambda: dict(OCTANT_GROUPS))
    half_model: bool = True


def _classify_surfaces(
    front: EllipticalFront, W: float, H: float, tol: float
) -> dict[str, list[int]]:
    names: dict[str, list[int]] = {}
    for _, tag in gmsh.model.getEntities(2):
        x, y, z = gmsh.model.occ.getCenterOfMass(2, tag)
        if abs(z) < tol:
            inside = (x / front.a) ** 2 + (y / front.b) ** 2 < 1.0
            name = "crack" if inside else "ligament"
        elif abs(x) < tol:
            name = "sym_x"
        elif abs(y) < tol:
            name = "sym_y"
        elif abs(z - H) < tol:
            name = "top"
        elif abs(x - W) < tol:
            name = "side_x"
        elif abs(y - W) < tol:
            name = "side_y"
        else:
            raise MeshingError(f"surface {tag} at {(x, y, z)} belongs to no block face")
        names.setdefault(name, []).append(tag)
    return names


def _front_curves(front: EllipticalFront, tol: float) -> list[int]:
    """The elliptic arc: the curve in z = 0 off both symmetry planes, inside the front's box."""
    out = []
    for _, tag in gmsh.model.getEntities(1):
        x, y, z = gmsh.model.occ.getCenterOfMass(1, tag)
        if abs(z) < tol and tol < x < front.a and tol < y < front.b:
            out.append(tag)
    if len(out) != 1:
        raise MeshingError(f"expected one front curve, found {len(out)}")
    return out


def _build_octant(
    front: EllipticalFront, W: float, H: float, h_front: float, grading: float, h_max: float
) -> None:
    occ = gmsh.model.occ
    tol = 1e-7 * W
    box = occ.addBox(0, 0, 0, W, W, H)
    disk = occ.addDisk(0, 0, 0, front.a, front.b)
    rect = occ.addRectangle(0, 0, 0, W, W)
    quarter, _ = occ.intersect([(2, disk)], [(2, rect)])
    occ.fragment([(3, box)], quarter)
    occ.synchronize()
    vols = [t for _, t in gmsh.model.getEntities(3)]
    gmsh.model.addPhysicalGroup(3, vols, 1, name="body")
    for name, tags in _classify_surfaces(front, W, H, tol).items():
        gmsh.model.addPhysicalGroup(2, tags, OCTANT_GROUPS[name], name=name)
    fld = gmsh.model.mesh.field
    d = fld.add("Distance")
    fld.setNumbers(d, "CurvesList", _front_curves(front, tol))
    fld.setNumber(d, "Sampling", max(50, int(2.0 * front.perimeter / 4 / h_front)))
    f = fld.add("MathEval")
    fld.setString(f, "F", f"Min({h_front!r} + {grading!r}*F{d}, {h_max!r})")
    fld.setAsBackgroundMesh(f)
    for opt in ("MeshSizeFromPoints", "MeshSizeExtendFromBoundary", "MeshSizeFromCurvature"):
        gmsh.option.setNumber(f"Mesh.{opt}", 0)
    gmsh.option.setNumber("Mesh.Algorithm3D", 10)  # HXT
    gmsh.model.mesh.generate(3)


def mesh_crack_octant(
    front: EllipticalFront,
    half_size: float,
    h_front: float,
    grading: float = 0.3,
    h_max: float | None = None,
    comm: MPI.Comm | None = None,
    half_height: float | None = None,
) -> CrackBlock:
    """Mesh the octant x, y, z ≥ 0 of the block [−W, W]² × [−H, H] with the crack at its centre.

    Parameters
    ----------
    front
        The crack (centre at the origin).
    half_size, half_height
        W and H (m); H defaults to W.  The crack must fit: a < W.
    h_front, grading, h_max
        Element size at the front, its growth per unit distance from the front and the
        largest size (default W/4).
    comm
        MPI communicator (``None``: ``MPI.COMM_WORLD``); gmsh runs on rank 0.

    Returns
    -------
    CrackBlock
        Facet groups: ``crack`` (z = 0 inside the front: the traction-free face),
        ``ligament`` (z = 0 outside it), ``sym_x`` (x = 0), ``sym_y`` (y = 0), ``top``
        (z = H), ``side_x`` (x = W), ``side_y`` (y = W).
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    W = float(half_size)
    H = W if half_height is None else float(half_height)
    if any(abs(c) > 0 for c in front.centre):
        raise ParameterError("centre", "the octant model needs the crack centred at the origin")
    if not (front.a < W and front.b < H):
        raise ParameterError(
            "half_size", f"the crack (a={front.a}) must lie inside the block (W={W})"
        )
    for key, v in (("h_front", h_front), ("grading", grading)):
        if not (math.isfinite(v) and v > 0):
            raise ParameterError(key, f"must be a positive number, got {v!r}")
    h_max = W / 4 if h_max is None else float(h_max)
    error = None
    with gmsh_session("crack_octant") if comm.rank == 0 else nullcontext():
        if comm.rank == 0:
            try:
                _build_octant(front, W, H, h_front, grading, h_max)
            except Exception as exc:  # reported on every rank below
                error = f"{type(exc).__name__}: {exc}"
        error = comm.bcast(error, root=0)
        if error is not None:
            raise MeshingError(f"crack octant: {error}")
        md = model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=3)
    return CrackBlock(md.mesh, md.cell_tags, md.facet_tags, front)


# ------------------------------------------------------------ the interaction integral
@dataclass(frozen=True)
class FrontSIF:
    """Stress intensity factors at one front point.

    Attributes
    ----------
    phi
        Front parameter of the point.
    point, e1
        The point (m) and the in-plane direction ahead of the front.
    K_I, K_II, K_III
        Pa·√m (``nan`` where the model cannot give them: K_II, K_III of a half model).
    G
        (K_I² + K_II²)(1 − ν²)/E + K_III²/(2μ) (J/m²), with the available modes.
    method
        ``"interaction"`` or ``"displacement"``.
    """

    phi: float
    point: tuple[float, float, float]
    e1: tuple[float, float, float]
    K_I: float
    K_II: float
    K_III: float
    G: float
    method: str


def _front_coordinates(
    front: CrackFront, x: np.ndarray, phi0: float
) -> tuple[np.ndarray, np.ndarray]:
    """Distance r of points ``x`` (n, 3) to the front and the arc length s of their nearest
    front point measured from the point φ₀ (on a closed front wrapped to (−P/2, P/2], P
    the perimeter)."""
    t = front.nearest(x)
    r = np.linalg.norm(x - front.point(t), axis=1)
    s = front.arc_length(t) - front.arc_length(phi0)
    if front.closed:
        per = front.perimeter
        s = (s + 0.5 * per) % per - 0.5 * per
    return r, s


def _q_values(front, x, phi0, r_in, r_out, l_in, l_out) -> np.ndarray:
    r, s = _front_coordinates(front, x, phi0)
    ring = np.clip((r_out - r) / (r_out - r_in), 0.0, 1.0)
    along = np.clip((l_out - np.abs(s)) / (l_out - l_in), 0.0, 1.0)
    return ring * along


def _q_function(shared: _Shared, front, phi0, r_in, r_out, l_in, l_out, p0) -> fem.Function:
    """The P1 q-function of the point, written into the block's shared q; evaluated only at
    nodes near the point (zero elsewhere)."""
    x = shared.x
    near = np.linalg.norm(x - p0, axis=1) <= r_out + l_out + 1e-9 * (r_out + l_out)
    vals = np.zeros(len(x))
    if near.any():
        vals[near] = _q_values(front, x[near], phi0, r_in, r_out, l_in, l_out)
    shared.q.x.array[:] = vals
    return shared.q


def _q_at_points(q: fem.Function, support: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """The P1 function ``q`` at points ``pts`` (n, 3), on every rank: each rank evaluates the
    points in every cell of ``support`` (owned cells where q > 0) that holds them, and a
    point takes the largest of these values over all cells and ranks — the same choice on
    any partition (the values differ only by round-off and the collision tolerance); a
    point found on no rank has q = 0 (outside the support or the model) (collective)."""
    msh = q.function_space.mesh
    vals = np.full(len(pts), -np.inf)
    if support.size:
        tree = geometry.bb_tree(msh, msh.topology.dim, entities=support)
        which, cells = _colliding(msh, geometry.compute_collisions_points(tree, pts), pts)
        if which.size:
            found = q.eval(pts[which], cells).ravel()
            np.maximum.at(vals, which, found)
    msh.comm.Allreduce(MPI.IN_PLACE, vals, op=MPI.MAX)  # a buffer: a pickled max of arrays fails
    return np.where(np.isfinite(vals), vals, 0.0)


#: DOLFINx's ``compute_colliding_cells``: a cell holds a point when their squared distance
#: (GJK) is below this (m²).
_COLLISION_EPS2 = 1e-12


def _colliding(msh: mesh.Mesh, candidates, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(point, cell) pairs of the bounding-box ``candidates`` whose cell holds the point,
    in the candidates' order: the pairs of ``geometry.compute_colliding_cells``, with GJK
    distances only where the barycentric coordinates λ of the point in an affine
    tetrahedron leave it open.  A point at distance d from the cell has λᵢ ≥ −|∇λᵢ| d, so
    λᵢ < −1.5|∇λᵢ|√eps2 for some i means d > 1.5√eps2 (out); and d ≤ |x − y|, y the
    cell's point with the coordinates max(λ, 0)/Σ max(λ, 0), so |x − y| < √eps2/2 means
    in.  Between the two, the distance to the cell's faces and edges
    (:func:`_cell_distance2`), and GJK where that lies within 10⁻⁶ of eps2 or is not a
    number.  Most boxes near a front hold the point without their cell doing so, and most
    points lie well inside or on a face of a cell: the distances were 2/3 of a point's
    cost."""
    geo = msh.geometry
    cand = candidates.array
    which = np.repeat(np.arange(len(pts)), np.diff(candidates.offsets))
    affine = geo.cmaps[0].degree == 1 and msh.topology.cell_type == mesh.CellType.tetrahedron
    if not affine or cand.size == 0:
        cells = geometry.compute_colliding_cells(msh, candidates, pts)
        which = np.repeat(np.arange(len(pts)), np.diff(cells.offsets))
        return which, cells.array.astype(np.int32)
    unique, inverse = np.unique(cand, return_inverse=True)
    X = geo.x[geo.dofmaps[0][unique]]  # (n, 4, 3)
    edges = X[:, 1:] - X[:, :1]
    try:  # rows: ∇λ₁, ∇λ₂, ∇λ₃ of each cell
        G = np.linalg.inv(np.transpose(edges, (0, 2, 1)))
    except np.linalg.LinAlgError:  # a degenerate cell: GJK decides every pair
        G = np.full((len(unique), 3, 3), np.nan)
    G = np.concatenate([-G.sum(axis=1, keepdims=True), G], axis=1)  # (n, 4, 3)
    lam = np.einsum("mij,mj->mi", G[inverse], pts[which] - X[inverse, 0])
    lam[:, 0] += 1.0
    reach = math.sqrt(_COLLISION_EPS2)
    out = np.any(lam < -(np.linalg.norm(G, axis=2)[inverse] * 1.5 * reach + 1e-9), axis=1)
    pos = np.maximum(lam, 0.0)
    shift = (lam - pos / pos.sum(axis=1, keepdims=True))[:, 1:]  # x − y along the edges
    inside = np.linalg.norm(np.einsum("mi,mik->mk", shift, edges[inverse]), axis=1) < 0.5 * reach
    keep = inside & ~out
    idx = np.flatnonzero(~(inside | out))  # NaN (degenerate cells) falls here
    d2 = _cell_distance2(pts[which[idx]], X[inverse[idx]], lam[idx], G[inverse[idx]])
    sure = np.abs(d2 - _COLLISION_EPS2) > 1e-6 * _COLLISION_EPS2  # False where NaN
    keep[idx[sure]] = d2[sure] < _COLLISION_EPS2
    rest = idx[~sure]
    if rest.size:
        d2 = geometry.squared_distance(msh, msh.topology.dim, cand[rest], pts[which[rest]])
        keep[rest] = d2 < _COLLISION_EPS2
    return which[keep], cand[keep].astype(np.int32)


#: The edges of a tetrahedron (local vertex pairs).
_TET_EDGES = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))


def _cell_distance2(x: np.ndarray, X: np.ndarray, lam: np.ndarray, G: np.ndarray) -> np.ndarray:
    """Squared distance of points ``x`` (m, 3) outside tetrahedra ``X`` (m, 4, 3), with
    their barycentric coordinates ``lam`` (m, 4) and gradients ``G`` (m, 4, 3): the least
    of the distances to the planes of the faces the point lies outside of whose projection
    onto the plane lies in the face (d = −λᵢ/|∇λᵢ|) and of the distances to the six
    edges (segments) — each the distance to a part of the cell, and the nearest part is a
    face's interior or an edge; NaN for a degenerate cell."""
    norm2 = np.einsum("mij,mij->mi", G, G)
    d2 = np.full(len(x), np.inf)
    for i in range(4):
        li, ni = lam[:, i], norm2[:, i]
        projected = lam - (li / ni)[:, None] * np.einsum("mjk,mk->mj", G, G[:, i])
        projected[:, i] = 0.0
        face = (li < 0.0) & np.all(projected >= 0.0, axis=1)
        d2 = np.where(face, np.minimum(d2, li * li / ni), d2)
    for k, m in _TET_EDGES:
        e, w = X[:, m] - X[:, k], x - X[:, k]
        t = np.clip(np.einsum("ij,ij->i", w, e) / np.einsum("ij,ij->i", e, e), 0.0, 1.0)
        r = w - t[:, None] * e
        d2 = np.minimum(d2, np.einsum("ij,ij->i", r, r))
    d2[np.all(lam >= 0.0, axis=1)] = 0.0  # inside
    d2[np.isnan(lam).any(axis=1)] = np.nan  # a degenerate cell: GJK decides
    return d2


def _normalisation(
    q: fem.Function, support: np.ndarray, front, phi0: float, e1_0: np.ndarray, l_out: float
) -> float:
    """∫ q_h (e₁(φ₀)·e₁(s)) ds along the front, q_h the P1 function of the volume integral
    itself (its nodal values along the front, interpolated linearly between the front
    nodes), not the continuous plateau it interpolates: the volume integral equals the
    front integral of the q it uses, and a plateau a few front elements long differs from
    its interpolant by several per cent depending on where the nodes fall
    (docs/theory/fracture.md#3d-crack-fronts).  Trapezoidal rule in s over |s| ≤ l_out;
    the front outside the model (a half model, a front ending on the surface) adds 0."""
    half = front.parameter_span(l_out)
    phi = np.linspace(phi0 - half, phi0 + half, _SAMPLES)
    values = _q_at_points(q, support, front.point(phi))
    s = front.arc_length(phi) - front.arc_length(phi0)
    return float(np.trapezoid(values * (front.normals(phi) @ e1_0), s))


#: Facet groups that are not the outer boundary: crack faces and symmetry planes.
_INNER_GROUPS = ("crack", "ligament", "sym_x", "sym_y", "crack_upper", "crack_lower")
#: Compiled interaction integrals one block keeps (the oldest is dropped beyond this).
_MAX_FORMS = 16


@dataclass
class _Integral:
    """One compiled interaction integral (:func:`_integral`): the UFL form compiled once,
    the constants it reads (set per point), the maps of ``fem.create_form`` and the objects
    whose identity is part of its key (held, so that their ids are not reused)."""

    compiled: fem.CompiledForm
    const: dict
    coefficients: dict
    constants: dict
    held: tuple


@dataclass
class _Shared:
    """What the front points of one block share, built once (collectively): the P1 space's
    q-function and node coordinates, the P1 dofs on the outer boundary and on each symmetry
    plane (``None``: no such group), the crack faces' integration entities (tag, (cell,
    local facet) pairs) and the compiled integrals; ``owner`` the block's mesh, facet tags,
    groups and half_model it was built for."""

    owner: tuple
    q: fem.Function
    x: np.ndarray
    outer: np.ndarray
    sym: dict
    faces: list
    forms: dict = field(default_factory=dict)


#: The shared data of each live block, by id(block) (dropped when the block is collected).
_SHARED: dict[int, _Shared] = {}


def _block_owner(block: CrackBlock) -> tuple:
    return (block.mesh, block.facet_tags, tuple(sorted(block.groups.items())), block.half_model)


def _shared(block: CrackBlock) -> _Shared:
    """The block's shared data, built on its first front point or when its mesh, tags or
    groups were replaced since (collective: every rank evaluates the same points)."""
    owner = _block_owner(block)
    old = _SHARED.get(id(block))
    if old is not None and all(a is b or a == b for a, b in zip(old.owner, owner, strict=True)):
        return old
    if old is None:
        weakref.finalize(block, _SHARED.pop, id(block), None)
    _SHARED[id(block)] = new = _build_shared(block, owner)
    return new


def _build_shared(block: CrackBlock, owner: tuple) -> _Shared:
    """The P1 space and q, the boundary dofs and the face entities of ``block``
    (collective)."""
    msh = block.mesh
    tdim = msh.topology.dim
    V1 = fem.functionspace(msh, ("Lagrange", 1))
    msh.topology.create_connectivity(tdim - 1, tdim)
    msh.topology.create_connectivity(tdim, tdim - 1)
    ext = mesh.exterior_facet_indices(msh.topology)
    inner = [block.facet_tags.find(block.groups[k]) for k in _INNER_GROUPS if k in block.groups]
    outer = np.setdiff1d(ext, np.concatenate(inner)) if inner else ext
    outer_dofs = fem.locate_dofs_topological(V1, tdim - 1, outer.astype(np.int32))
    sym = {}
    for name in ("sym_x", "sym_y"):
        sym[name] = None
        if name in block.groups:
            facets = block.facet_tags.find(block.groups[name]).astype(np.int32)
            sym[name] = fem.locate_dofs_topological(V1, tdim - 1, facets)
    faces = []
    if not block.half_model and "crack_upper" in block.groups:  # the face term's facets
        for name in ("crack_upper", "crack_lower"):
            tag = block.groups[name]
            facets = np.intersect1d(block.facet_tags.find(tag), ext)
            pairs = fem.compute_integration_domains(
                fem.IntegralType.exterior_facet, msh.topology, facets
            )
            faces.append((tag, np.asarray(pairs)))
    x = V1.tabulate_dof_coordinates()
    return _Shared(owner, fem.Function(V1), x, outer_dofs, sym, faces)


def _check_domain(
    block: CrackBlock, shared: _Shared, p0: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Owned cells where q > 0, and a mask of the local cells (ghosts too) with q > 0 at a
    node.  Refuse a domain that touches the outer boundary, or a symmetry plane x = 0 or
    y = 0 that does not pass through the point (there the mirrored part of the domain
    would be missing; through the point it cancels) (collective)."""
    msh, q = block.mesh, shared.q
    n_owned = msh.topology.index_map(msh.topology.dim).size_local
    positive = q.x.array[q.function_space.dofmap.list].max(axis=1) > 0
    support = np.flatnonzero(positive[:n_owned]).astype(np.int32)
    scale = float(np.linalg.norm(p0)) or 1.0

    def touches(dofs: np.ndarray) -> bool:
        return bool(msh.comm.allreduce(int(np.any(q.x.array[dofs] > 0)), op=MPI.MAX))

    if touches(shared.outer):
        raise ParameterError(
            "r_out", "the integration domain reaches the outer boundary; take a smaller r_out"
        )
    for name, axis in (("sym_x", 0), ("sym_y", 1)):
        dofs = shared.sym[name]
        if abs(p0[axis]) > 1e-9 * scale and dofs is not None and touches(dofs):
            raise ParameterError(
                "length",
                f"the integration domain reaches the symmetry plane {name} away from the "
                "point; take a shorter length (or r_out) or a point on that plane",
            )
    return support, positive


def _auxiliary_displacement(
    x, const: dict, rho: float, mu: float, kappa: float, face=None, scale: float = 1.0
):
    """The near-front field of unit K (``const["k"]`` = (K_I, K_II, K_III)) in front
    coordinates (x₁ ahead of the front, x₂ = (x − p₀)·e₂ normal to the crack plane, e₁(x),
    e₃(x) = e₁(x) × e₂): on an elliptical front (``const`` holds its ``centre``, ``u``,
    ``v`` and ``semi`` = (a, b)) its own coordinates (:func:`_ellipse_coordinates`: the
    singular curve is the whole front, not only the point's neighbourhood); on a straight
    front (ρ = ∞) its tangent line: x₁ = (x − p₀)·e₁, e₁, e₃ constant.  Plane-strain
    Williams displacements (modes I, II) and u₃ = (2K_III/μ)√(r/2π) sin(θ/2) (mode III).
    ``face`` = ±1: the field on the upper (θ → π) or lower (θ → −π) crack face, where
    atan2 cannot tell the sides apart (x₂ is shifted by ±10⁻⁹b, or ±10⁻⁹ ``scale`` on a
    straight front)."""
    e2 = const["e2"]
    if "centre" in const:
        x1, E1 = _ellipse_coordinates(x, const)
        shift = 1e-9 * const["semi"][1]
    elif math.isinf(rho):
        E1 = const["e1"]
        x1 = ufl.dot(x - const["p0"], E1)
        shift = 1e-9 * scale
    else:
        raise ParameterError("front", "a curved front needs its ellipse (centre, axes)")
    x2 = ufl.dot(x - const["p0"], e2)
    E3 = ufl.cross(E1, e2)
    if face is not None:  # on a crack face: θ → ±π from that side (x₂ = 0 on both faces)
        x2 = x2 + face * shift  # the faces lie in x₂ = 0 (to round-off)
    r = ufl.sqrt(x1**2 + x2**2)
    th = _branch(ufl.atan2(x2, x1), x1, x2, const.get("cut"))
    k1, k2, k3 = const["k"][0], const["k"][1], const["k"][2]
    cc = ufl.sqrt(r / (2 * math.pi)) / (2 * mu)
    ch, sh = ufl.cos(th / 2), ufl.sin(th / 2)
    u1 = cc * (k1 * ch * (kappa - 1 + 2 * sh**2) + k2 * sh * (kappa + 1 + 2 * ch**2))
    u2 = cc * (k1 * sh * (kappa + 1 - 2 * ch**2) - k2 * ch * (kappa - 1 - 2 * sh**2))
    u3 = 4 * cc * k3 * sh
    return u1 * E1 + u2 * e2 + u3 * E3


def _ellipse_coordinates(x, const: dict):
    """(x₁, e₁(x)) of an elliptical front X²/a² + Y²/b² = 1 (X = (x − c)·u, Y = (x − c)·v)
    in its homothetic coordinates: m = √(X²/a² + Y²/b²) (the front is m = 1), e₁ the unit
    in-plane normal of the ellipse m = const through x, G = (X/a²) u + (Y/b²) v, and
    x₁ = (m − 1) m/|G| — zero on the whole front, with ∇x₁ = e₁ there (so the auxiliary
    field has unit K at every front point), the exact polar coordinates on a circle
    (x₁ = R − a).  Smooth in the crack plane except at the centre."""
    d = x - const["centre"]
    a, b = const["semi"][0], const["semi"][1]
    X, Y = ufl.dot(d, const["u"]), ufl.dot(d, const["v"])
    G = (X / a**2) * const["u"] + (Y / b**2) * const["v"]
    g = ufl.sqrt(ufl.dot(G, G))
    m = ufl.sqrt((X / a) ** 2 + (Y / b) ** 2)
    return (m - 1.0) * m / g, G / g


def _branch(th, x1, x2, cut):
    """θ with its branch cut along a kinked crack: behind a kink L behind the front, in
    the wedge between the straight extension of the last increment and the older surface
    (direction ψ from the kink), θ ± 2π — the auxiliary field is then continuous off the
    crack.  ``cut``: ``None`` or a constant (L, cos ψ, sin ψ)."""
    if cut is None:
        return th
    sgn = 1.0 if float(cut.value[2]) < 0 else -1.0  # the wedge below (+1) or above x₂ = 0
    wx, wy = x1 + cut[0], sgn * x2
    inside = ufl.And(ufl.lt(wy, 0.0), ufl.gt(wx * sgn * cut[2] - wy * cut[1], 0.0))
    return ufl.conditional(inside, th + sgn * 2 * math.pi, th)


def front_interaction_integral(
    u: fem.Function,
    block: CrackBlock,
    phi: float,
    material: Isotropic,
    r_out: float,
    r_in: float | None = None,
    length: float | None = None,
    quadrature_degree: int = 4,
    face_traction: tuple | None = None,
) -> FrontSIF:
    """K at the front point ``phi`` by the 3D domain interaction integral.

    The virtual extension is q(x) e₁(φ): q = ring(r) · plateau(s), r the distance to the
    front, s the arc length from the point; ring falls linearly from 1 at ``r_in`` to 0 at
    ``r_out``, the plateau from 1 at |s| = ``length``/2 to 0 at ``length``.  The auxiliary
    fields are the plane-strain Williams fields (modes I, II) and the anti-plane field
    (mode III) in the ellipse's own front coordinates (the tangent line on a straight
    front), and

        K_I = E′ I_I / 2,  K_II = E′ I_II / 2,  K_III = μ I_III,  E′ = E/(1 − ν²),

    with I = {∫_V [σ:∂u^a/∂x₁ + σ^a:∂u/∂x₁ − σ^a:ε δ₁ⱼ] ∂q/∂xⱼ + q div σ^a·∂u/∂x₁ dV
    − ∫_faces [t·∂u^a/∂x₁ + (σ^a n)·∂u/∂x₁] q dS} / ∫_front q (e₁·e₁(s)) ds, the face
    integral on a model with both faces (``crack_upper``, ``crack_lower`` in
    ``block.groups``).  On a half model (the crack plane a symmetry plane) the volume
    integral is doubled and only K_I is computed.

    Parameters
    ----------
    u
        Displacement (vector Lagrange on ``block.mesh``).
    block
        The meshed body and its front.
    phi
        Front parameter of the point.
    material
        The homogeneous isotropic material.
    r_out, r_in, length
        Domain sizes (m): ``r_in`` defaults to r_out/2, ``length`` (half-length along the
        front) to r_out.  Keep them small against the radius of curvature of the front;
        on a polygon ``length`` must not exceed the distance to the nearest corner (the
        ring may be wider: a convex polygon's other edges lie beyond it).
    quadrature_degree
        Degree of the Gauss–Jacobi rule of the domain cells (no points on cell edges).
    face_traction
        Loaded faces (a model with both faces): the tractions (Pa) on ``crack_upper`` and
        ``crack_lower`` (UFL vectors, e.g. the contact tractions of
        :func:`~bonecontact.fracture.faces.face_traction`); adds the face term
        −∫ t·∂₁u^a q dS with the face values of the auxiliary field (θ = ±π).
        ``None``: traction-free faces.

    Returns
    -------
    FrontSIF

    Notes
    -----
    The points of one ``block`` share its P1 space, q-function, boundary dofs and the
    integral compiled once per (u, face tractions, material, r_out, degree); each point
    assembles over its own support cells and the face facets next to them.
    """
    r_in, length, rho = _domain_sizes(block.front, phi, material, r_out, r_in, length)
    p0 = block.front.point(phi)[0]
    e1, e2, _ = block.front.frame(phi)
    shared = _shared(block)
    support, positive, norm = _domain(block, shared, phi, (r_in, r_out, length))
    values = [("p0", p0), ("e1", e1), ("e2", e2), ("k", (1.0, 0.0, 0.0))]
    values += _front_values(block.front, phi)
    integral = _integral(
        shared, block, u, material, (rho, r_out), quadrature_degree, face_traction, values
    )
    form = _point_form(integral, block, shared, support, positive)
    K_I, K_II, K_III, G = _mode_values(form, integral.const, block, norm, material)
    computed = (K_I,) if block.half_model else (K_I, K_II, K_III)
    if not all(math.isfinite(k) for k in computed):
        raise RunError(
            f"the interaction integral at {_point_text(phi, p0)} is not finite (K_I, K_II, "
            f"K_III = {K_I!r}, {K_II!r}, {K_III!r}): the auxiliary field was evaluated on "
            "its singular front or the displacement is not finite"
        )
    return FrontSIF(
        float(phi), tuple(map(float, p0)), tuple(map(float, e1)), K_I, K_II, K_III, G, "interaction"
    )


def _front_values(front: CrackFront, phi: float) -> list[tuple[str, tuple]]:
    """The front's constants of the auxiliary field: an ellipse's centre, axes u, v and
    semi-axes; a kinked polyline edge's cut (L, cos ψ, sin ψ)."""
    if isinstance(front, EllipticalFront):
        R = front.rotation
        return [
            ("centre", tuple(front.centre)),
            ("u", tuple(R[0])),
            ("v", tuple(R[1])),
            ("semi", (front.a, front.b)),
        ]
    cut = front.cut(phi) if isinstance(front, PolylineFront) else None
    return [] if cut is None else [("cut", (cut[0], math.cos(cut[1]), math.sin(cut[1])))]


def _domain_sizes(
    front: CrackFront,
    phi: float,
    material: Isotropic,
    r_out: float,
    r_in: float | None,
    length: float | None,
) -> tuple[float, float, float]:
    """Check the material and the domain against the front at ``phi``: (r_in, length, ρ),
    the defaults filled in and ρ the front's radius of curvature there."""
    if not isinstance(material, Isotropic):
        raise ParameterError(
            "material", f"needs a homogeneous isotropic material, got {type(material).__name__}"
        )
    r_in = 0.5 * r_out if r_in is None else r_in
    length = r_out if length is None else length
    if not (0 <= r_in < r_out) or not length > 0:
        raise ParameterError(
            "r_out", f"need 0 <= r_in < r_out and length > 0, got {r_in}, {r_out}, {length}"
        )
    rho = float(front.radius_of_curvature(phi))  # a NumPy scalar would swallow UFL operands
    if max(r_out, length) > 0.75 * rho:
        raise ParameterError(
            "r_out",
            f"the domain (r_out={r_out:g}, length={length:g}) must be smaller than 0.75 times the "
            f"front's radius of curvature there ({rho:g})",
        )
    corner = front.corner_distance(phi)
    if length > corner:  # the ring may be wider: a convex polygon's other edges lie beyond
        raise ParameterError(
            "length",
            f"the domain along the front (length={length:g}) reaches a corner of the front or "
            f"the free surface ({corner:g} m from the point); take a shorter length or a "
            "point farther from it",
        )
    return r_in, length, rho


def _domain(
    block: CrackBlock, shared: _Shared, phi: float, radii: tuple[float, float, float]
) -> tuple[np.ndarray, np.ndarray, float]:
    """The q-function of the point (in ``shared.q``), its support (owned cells, checked
    against the boundary), the mask of local cells with q > 0 and the normalising front
    integral ∫ q_h (e₁·e₁(s)) ds; ``radii`` = (r_in, r_out, length)."""
    front, msh = block.front, block.mesh
    r_in, r_out, length = radii
    p0 = front.point(phi)[0]
    e1, _, _ = front.frame(phi)
    q = _q_function(shared, front, phi, r_in, r_out, 0.5 * length, length, p0)
    support, positive = _check_domain(block, shared, p0)
    norm = _normalisation(q, support, front, phi, e1, length)
    _check_normalisation(msh.comm, support, norm, phi, p0, radii)
    return support, positive, norm


def _point_text(phi: float, p0: np.ndarray) -> str:
    return f"the front point phi = {phi:.6g} at ({', '.join(f'{float(v):.6g}' for v in p0)})"


def _check_normalisation(
    comm: MPI.Comm, support: np.ndarray, norm: float, phi: float, p0: np.ndarray, radii
) -> None:
    """Refuse a domain without cells or whose front integral is below :data:`NORM_FLOOR`
    times its length (K would divide by 0 or by a sliver; collective)."""
    _, r_out, length = radii
    where = f"{_point_text(phi, p0)} (r_out = {r_out:.3g} m, length = {length:.3g} m)"
    if comm.allreduce(int(support.size), op=MPI.SUM) == 0:
        raise ParameterError(
            "phi",
            f"the integration domain of {where} holds no cell of the mesh: the point lies "
            "outside the meshed body (beyond the end of its front, or cut away by the "
            "surface); no K there",
        )
    if not norm >= NORM_FLOOR * length:  # NaN too
        raise ParameterError(
            "phi",
            f"the front integral of q in the integration domain of {where} is {norm:.3g} m, "
            f"less than {NORM_FLOOR:g} times the length (a whole domain gives 1.5, one "
            "halved by a symmetry plane through the point 0.73): the front there lies "
            "mostly outside the mesh; no K there",
        )


def _interaction_form(
    u: fem.Function,
    block: CrackBlock,
    q: fem.Function,
    degree: int,
    const: dict,
    radii: tuple[float, float],
    material: Isotropic,
    face_traction: tuple | None,
) -> ufl.Form:
    """The interaction integral (the mode is ``const["k"]``): the volume terms over the
    cells of subdomain 1 (given per point, :func:`_point_form`) and, on a model with both
    faces, the face term; ``radii`` = (ρ, r_out)."""
    rho, r_out = radii
    mu, lmbda = material.mu, material.lmbda
    kappa = elastic_constants(material.E, material.nu, "strain")["kappa"]
    x = ufl.SpatialCoordinate(block.mesh)
    ua = _auxiliary_displacement(x, const, rho, mu, kappa, scale=r_out)

    def sigma(v):
        eps = ufl.sym(ufl.grad(v))
        return lmbda * ufl.tr(eps) * ufl.Identity(3) + 2 * mu * eps

    s, eps_u, sa = sigma(u), ufl.sym(ufl.grad(u)), sigma(ua)
    du1 = ufl.dot(ufl.grad(u), const["e1"])
    dua1 = ufl.dot(ufl.grad(ua), const["e1"])
    gq = ufl.grad(q)
    flux = ufl.dot(s, dua1) + ufl.dot(sa, du1) - ufl.inner(sa, eps_u) * const["e1"]
    dx = ufl.Measure("dx", domain=block.mesh, metadata=_rule(degree))(1)
    # the curved auxiliary field is not in equilibrium: its divergence adds a volume term
    integrand = (ufl.dot(flux, gq) + q * ufl.dot(ufl.div(sa), du1)) * dx
    if not block.half_model and "crack_upper" in block.groups:  # both faces meshed
        integrand = integrand - _face_term(
            block, face_traction, u, x, const, (rho, r_out), mu, lmbda, kappa, q
        )
    elif face_traction is not None:
        raise ParameterError("face_traction", "the face term needs a model with both faces")
    return integrand


def _integral(
    shared: _Shared,
    block: CrackBlock,
    u: fem.Function,
    material: Isotropic,
    radii: tuple[float, float],
    degree: int,
    face_traction: tuple | None,
    values: list[tuple[str, tuple]],
) -> _Integral:
    """The compiled interaction integral of the point, its constants set to ``values``.

    Compiled once per block and (u, face tractions, material, kind of front, side of the
    kink's cut, r_out, quadrature degree) — what the form's code depends on — and reused
    at every point with these (collective when it compiles)."""
    rho, r_out = radii
    names = dict(values)
    cut = names.get("cut")
    kind = "ellipse" if "centre" in names else math.isinf(rho)
    mu, lmbda = material.mu, material.lmbda
    kappa = elastic_constants(material.E, material.nu, "strain")["kappa"]
    held = (u, face_traction)
    key = (id(u), id(face_traction), mu, lmbda, kappa, kind, None if cut is None else cut[2] < 0)
    key += (r_out, degree)
    entry = shared.forms.get(key)
    if entry is None:
        const = {
            k: fem.Constant(block.mesh, np.asarray(v, dtype=default_scalar_type)) for k, v in values
        }
        form = _interaction_form(u, block, shared.q, degree, const, radii, material, face_traction)
        compiled = fem.compile_form(
            block.mesh.comm, form, form_compiler_options={"scalar_type": default_scalar_type}
        )
        coefficients = {c: c for c in form.coefficients()}
        constants = {c: c for c in form.constants()}
        entry = _Integral(compiled, const, coefficients, constants, held)
        if len(shared.forms) >= _MAX_FORMS:
            shared.forms.pop(next(iter(shared.forms)))
        shared.forms[key] = entry
    for k, v in values:
        entry.const[k].value[...] = np.asarray(v, dtype=default_scalar_type)
    return entry


def _point_form(
    integral: _Integral, block: CrackBlock, shared: _Shared, support, positive
) -> fem.Form:
    """The point's form: the compiled integral over the support cells and the crack-face
    facets of cells with q > 0 at a node — the face term vanishes on the others
    (q and ∇q are zero there) — instead of the whole faces."""
    msh = block.mesh
    cells = fem.compute_integration_domains(fem.IntegralType.cell, msh.topology, support)
    subdomains = {fem.IntegralType.cell: [(1, np.asarray(cells))]}
    if shared.faces:
        faces = []
        for tag, pairs in shared.faces:
            p = pairs.reshape(-1, 2)
            kept = np.ascontiguousarray(p[positive[p[:, 0]]], dtype=pairs.dtype)
            faces.append((tag, kept if pairs.ndim == 2 else kept.ravel()))
        subdomains[fem.IntegralType.exterior_facet] = faces
    return fem.create_form(
        integral.compiled, [], msh, subdomains, integral.coefficients, integral.constants
    )


def _mode_values(
    form: fem.Form, const: dict, block: CrackBlock, norm: float, material: Isotropic
) -> tuple[float, float, float, float]:
    """(K_I, K_II, K_III, G) from the form assembled with the unit auxiliary field of
    each mode (a half model: K_I only, the volume integral doubled); the coefficients are
    packed once for all modes."""
    c = elastic_constants(material.E, material.nu, "strain")
    mu = material.mu
    factor = 2.0 if block.half_model else 1.0
    modes = (
        ((1.0, 0.0, 0.0),)
        if block.half_model
        else ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    )
    comm = block.mesh.comm
    coeffs = fem.pack_coefficients(form)
    values = []
    for k in modes:
        const["k"].value[:] = k
        local = fem.assemble_scalar(form, fem.pack_constants(form), coeffs)
        values.append(factor * comm.allreduce(local, op=MPI.SUM) / norm)
    K_I = 0.5 * c["E_prime"] * values[0]
    K_II, K_III = (
        (0.5 * c["E_prime"] * values[1], mu * values[2])
        if len(values) == 3
        else (math.nan, math.nan)
    )
    G = (K_I**2 + (0.0 if math.isnan(K_II) else K_II**2)) / c["E_prime"] + (
        0.0 if math.isnan(K_III) else K_III**2 / (2 * mu)
    )
    return K_I, K_II, K_III, G


#: Quadrature of the face term.
FACE_QUADRATURE_DEGREE = 12


def _rule(degree: int) -> dict:
    """Quadrature metadata: Gauss–Jacobi, whose points all lie inside the cell.  The
    default degree-4 tetrahedron rule has six points at edge midpoints: on a straight front
    an edge of the front is where the auxiliary field is singular (r = 0, NaN); on a
    curved front the front's edges are chords, whose midpoints lie a sagitta h²/8ρ from
    the singular curve, and those single points weighed the 1/r integrand next to the
    front by up to ten times a typical point's (K spiked by −6 % at single front points of
    an a/c = 0.5 surface crack: docs/theory/fracture.md#surface-breaking-cracks-in-3d)."""
    return {"quadrature_degree": degree, "quadrature_rule": "gauss_jacobi"}


def _face_term(block: CrackBlock, traction, u, x, const: dict, radii, mu, lmbda, kappa, q):
    """The crack-face part of the boundary of the domain, over both faces:
    ∫ [t·∂₁u^a + (σ^a n)·∂₁u − (σ^a:ε)(n·e₁)] q dS, with the auxiliary field on
    ``crack_upper`` from the side θ → π and on ``crack_lower`` from θ → −π, n the outward
    normal (n·e₁ = 0 on a planar crack; not on the older surface behind a kink).

    * (σ^a n)·∂₁u: the curved auxiliary field is not traction-free on the faces (the hoop
      strain u^a₁/R of modes II: σ^a₂₂ = λu^a₁/R), so this term is there even for
      traction-free faces (without it K_II of an inclined penny crack came out 19 % low).
    * t·∂₁u^a (``traction`` = (t_upper, t_lower), loaded faces) is integrated by parts in
      the crack plane, −∫ u^a·∂₁(t q) dS: u^a (∝ √r) vanishes at the front and q at the
      edge of the domain, and the integrand is bounded where ∂₁u^a (∝ 1/√r) is not —
      Gauss rules lose several per cent on the 1/√r of the elements along the front
      (−5 % of K_I on a closed penny crack at h = a/8).

    ``radii`` = (ρ, the domain radius): the auxiliary field's curvature and length scale."""
    # the facets of each face are given per point (:func:`_point_form`)
    ds = ufl.Measure("ds", domain=block.mesh, metadata=_rule(FACE_QUADRATURE_DEGREE))
    n = ufl.FacetNormal(block.mesh)
    du1 = ufl.dot(ufl.grad(u), const["e1"])
    ts = (None, None) if traction is None else traction
    term = 0
    for t, name, side in zip(ts, ("crack_upper", "crack_lower"), (1.0, -1.0), strict=True):
        ua = _auxiliary_displacement(x, const, radii[0], mu, kappa, face=side, scale=radii[1])
        eps = ufl.sym(ufl.grad(ua))
        sa = lmbda * ufl.tr(eps) * ufl.Identity(3) + 2 * mu * eps
        # W n·e₁: zero on faces in the plane of e₁, not on an older kinked surface
        w_n1 = ufl.inner(sa, ufl.sym(ufl.grad(u))) * ufl.dot(n, const["e1"])
        integrand = (ufl.dot(ufl.dot(sa, n), du1) - w_n1) * q
        if t is not None:
            integrand = integrand - ufl.dot(ua, ufl.dot(ufl.grad(t * q), const["e1"]))
        term = term + integrand * ds(block.groups[name])
    return term


# --------------------------------------------------------- displacement correlation
def _face_nodes(u: fem.Function, block: CrackBlock, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates and displacements of the owned nodes of facet group ``name``."""
    V = u.function_space
    blocks = fem.locate_dofs_topological(V, 2, block.facet_tags.find(block.groups[name]))
    blocks = blocks[blocks < V.dofmap.index_map.size_local]
    x = V.tabulate_dof_coordinates()[blocks]
    return x, u.x.array.reshape(-1, V.dofmap.index_map_bs)[blocks]


def _face_jumps(u: fem.Function, block: CrackBlock) -> tuple[np.ndarray, np.ndarray]:
    """The nodes of the face ``crack`` and the displacement jump there: 2u (half model:
    the mirrored face moves by −u_n) or u_upper − u_lower at coincident nodes of the two
    faces (gathered on every rank)."""
    comm = block.mesh.comm
    if block.half_model:
        x, uu = _face_nodes(u, block, "crack")
        x, uu = np.concatenate(comm.allgather(x)), np.concatenate(comm.allgather(uu))
        n = block.front.normal
        return x, 2.0 * np.outer(uu @ n, n)
    xu, uu = (np.concatenate(comm.allgather(a)) for a in _face_nodes(u, block, "crack_upper"))
    xl, ul = (np.concatenate(comm.allgather(a)) for a in _face_nodes(u, block, "crack_lower"))
    scale = block.front.a
    key = lambda p: tuple(np.round(p / (1e-9 * scale)).astype(np.int64))  # noqa: E731
    lower = {key(p): v for p, v in zip(xl, ul, strict=True)}
    pairs = [(p, v - lower[key(p)]) for p, v in zip(xu, uu, strict=True) if key(p) in lower]
    if not pairs:
        return np.zeros((0, 3)), np.zeros((0, 3))
    return np.array([p for p, _ in pairs]), np.array([j for _, j in pairs])


def front_displacement_correlation(
    u: fem.Function,
    block: CrackBlock,
    phi: float,
    material: Isotropic,
    r_max: float,
    slab: float,
    skip: float = 0.0,
) -> FrontSIF:
    """K from the opening of the crack faces near the front point ``phi``.

    Crack-face nodes whose nearest front point lies within arc length ``slab`` of the point
    and whose distance r to the front is in (``skip``, ``r_max``] give
    K_I(r) = μ/(κ + 1) √(2π/r) [u]·e₂, K_II(r) = μ/(κ + 1) √(2π/r) [u]·e₁ and
    K_III(r) = μ/4 √(2π/r) [u]·e₃ (κ = 3 − 4ν), [u] the jump upper − lower face
    (half model: [u]·e₂ = 2u·n and only K_I); each K(r) is fitted by a straight line in r
    and taken at r = 0.  P1 elements open too little near the front: a cross-check,
    20–25 % low on coarse meshes.
    """
    front = block.front
    x, jump = _face_jumps(u, block)
    r, s = _front_coordinates(front, x, phi) if len(x) else (np.zeros(0), np.zeros(0))
    keep = (np.abs(s) <= slab) & (r > skip) & (r <= r_max)
    if int(keep.sum()) < 2:
        raise ParameterError("r_max", "needs at least two crack-face nodes near the point")
    r, jump = r[keep], jump[keep]
    c = elastic_constants(material.E, material.nu, "strain")
    e1, e2, e3 = front.frame(phi)
    A = np.column_stack([np.ones(len(r)), r])
    root = np.sqrt(2 * np.pi / r)

    def fit(values: np.ndarray) -> float:
        return float(np.linalg.lstsq(A, values, rcond=None)[0][0])

    K_I = fit(c["mu"] / (c["kappa"] + 1) * root * (jump @ e2))
    K_II, K_III = math.nan, math.nan
    if not block.half_model:
        K_II = fit(c["mu"] / (c["kappa"] + 1) * root * (jump @ e1))
        K_III = fit(c["mu"] / 4 * root * (jump @ e3))
    G = (K_I**2 + (0.0 if math.isnan(K_II) else K_II**2)) / c["E_prime"] + (
        0.0 if math.isnan(K_III) else K_III**2 / (2 * c["mu"])
    )
    p0 = front.point(phi)[0]
    return FrontSIF(
        float(phi),
        tuple(map(float, p0)),
        tuple(map(float, e1)),
        K_I,
        K_II,
        K_III,
        G,
        "displacement",
    )
