"""A planar crack in 3D: a disc (penny) or an ellipse (docs/theory/fracture.md#3d-crack-fronts).

:class:`PlanarCrack` is the 3D ``[[crack]]`` of a scene: centre, unit normal, semi-axes and
the in-plane direction of the first semi-axis.  Its front is an
:class:`~bonecontact.fracture.front3d.EllipticalFront` (in the crack's frame), which gives
points, the local frame and arc length along the front for the stress intensity factors.
:func:`planar_crack_from_table` parses and checks the table (errors name the key).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from bonecontact.fracture.crack import FractureError
from bonecontact.fracture.front3d import EllipticalFront

__all__ = ["CRACK3D_KEYS", "CRACK3D_SHAPES", "PlanarCrack", "planar_crack_from_table"]

#: Keys of a 3D ``[[crack]]`` table.
CRACK3D_KEYS = (
    "name",
    "shape",
    "centre",
    "normal",
    "radius",
    "semi_axes",
    "axis",
    "region",
    "friction",
    "front_points",
)
#: Shapes of a 3D crack.
CRACK3D_SHAPES = ("disc", "ellipse")
_UNIT_TOL = 1e-6


@dataclass(frozen=True)
class PlanarCrack:
    """A planar elliptical crack (a = b: a disc) with an interior front.

    Parameters
    ----------
    centre
        Centre (m).
    normal
        Unit normal of the crack plane; the ``crack_upper`` face is on its side.
    a, b
        Semi-axes (m), a ≥ b > 0.
    axis
        Unit in-plane direction of the semi-axis ``a`` (normal to ``normal``).
    shape
        ``"disc"`` or ``"ellipse"`` (names the size key in messages: ``radius`` or
        ``semi_axes``).
    """

    centre: tuple[float, float, float]
    normal: tuple[float, float, float]
    a: float
    b: float
    axis: tuple[float, float, float]
    shape: str = "disc"

    @property
    def size_key(self) -> str:
        """The key that sets the crack's size."""
        return "radius" if self.shape == "disc" else "semi_axes"

    @property
    def axes(self) -> npt.NDArray[np.float64]:
        """Rows (u, v, n): u = ``axis``, v = n × u, n = ``normal`` (right-handed)."""
        n, u = np.asarray(self.normal, dtype=float), np.asarray(self.axis, dtype=float)
        return np.vstack([u, np.cross(n, u), n])

    def front(self) -> EllipticalFront:
        """The crack front."""
        return EllipticalFront(
            self.a, self.b, tuple(map(float, self.centre)), tuple(map(tuple, self.axes))
        )

    def front_parameters(self, n: int) -> npt.NDArray[np.float64]:
        """``n`` front parameters φ equally spaced in arc length from φ = 0 (the end of the
        semi-axis ``a``)."""
        front = self.front()
        phi = np.linspace(0.0, 2.0 * math.pi, 4001)
        s = front.arc_length(phi)
        s = s - s[0]
        target = np.arange(n) * front.perimeter / n
        return np.interp(target, s, phi)

    def sample_points(self, rings: int = 8, per_ring: int = 48) -> npt.NDArray[np.float64]:
        """Points covering the crack (its centre, ``rings`` ellipses out to the front
        itself), shape (m, 3)."""
        t = np.linspace(0.0, 2.0 * math.pi, per_ring, endpoint=False)
        R = self.axes
        pts = [np.zeros((1, 3))]
        for f in np.linspace(1.0 / rings, 1.0, rings):
            pts.append(np.column_stack([f * self.a * np.cos(t), f * self.b * np.sin(t), 0 * t]) @ R)
        return np.asarray(self.centre, dtype=float) + np.concatenate(pts)


def _vector(table: Mapping, key: str) -> npt.NDArray[np.float64]:
    v = table.get(key)
    if (
        not isinstance(v, (list, tuple))
        or len(v) != 3
        or not all(isinstance(c, (int, float)) and not isinstance(c, bool) for c in v)
        or not all(math.isfinite(c) for c in v)
    ):
        raise FractureError(key, f"must be [x, y, z] (three numbers), got {v!r}")
    return np.asarray(v, dtype=float)


def _unit(table: Mapping, key: str) -> npt.NDArray[np.float64]:
    v = _vector(table, key)
    length = float(np.linalg.norm(v))
    if abs(length - 1.0) > _UNIT_TOL:
        raise FractureError(key, f"must be a unit vector, got {v.tolist()} (length {length:.6g})")
    return v / length


def _positive(v: object, key: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise FractureError(key, f"must be a positive number (m), got {v!r}")
    return float(v)


def _default_axis(n: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """An in-plane unit vector: the coordinate axis least aligned with n, projected."""
    e = np.eye(3)[int(np.argmin(np.abs(n)))]
    u = e - np.dot(e, n) * n
    return u / np.linalg.norm(u)


def planar_crack_from_table(table: Mapping) -> PlanarCrack:
    """Parse the geometry of a 3D ``[[crack]]``: ``shape = "disc"`` (``radius``) or
    ``"ellipse"`` (``semi_axes = [a, b]``, a ≥ b, and ``axis``, the in-plane direction of
    ``a``); ``centre`` and the unit ``normal`` always.

    Raises
    ------
    FractureError
        Naming the key: a missing or malformed value, a non-unit normal or axis, an axis
        not in the crack plane, a size ≤ 0, a key of the other shape.
    """
    shape = table.get("shape", "disc")
    if shape not in CRACK3D_SHAPES:
        raise FractureError("shape", f"must be one of {', '.join(CRACK3D_SHAPES)}, got {shape!r}")
    for key in ("centre", "normal", "radius" if shape == "disc" else "semi_axes"):
        if key not in table:
            raise FractureError(key, f"is required (shape = {shape!r})")
    centre = _vector(table, "centre")
    n = _unit(table, "normal")
    if shape == "disc":
        for key in ("semi_axes", "axis"):
            if key in table:
                raise FractureError(key, 'applies to shape = "ellipse" only')
        a = b = _positive(table["radius"], "radius")
        u = _default_axis(n)
    else:
        if "radius" in table:
            raise FractureError("radius", 'applies to shape = "disc" only (ellipse: semi_axes)')
        ab = table["semi_axes"]
        if not isinstance(ab, (list, tuple)) or len(ab) != 2:
            raise FractureError("semi_axes", f"must be [a, b] (m), got {ab!r}")
        a, b = (_positive(v, "semi_axes") for v in ab)
        if b > a:
            raise FractureError("semi_axes", f"need a >= b (a along axis), got [{a}, {b}]")
        if "axis" not in table:
            raise FractureError("axis", 'is required (shape = "ellipse")')
        u = _unit(table, "axis")
        if abs(float(np.dot(u, n))) > _UNIT_TOL:
            raise FractureError("axis", "must lie in the crack plane (normal to `normal`)")
        u = u - np.dot(u, n) * n
        u = u / np.linalg.norm(u)
    return PlanarCrack(
        tuple(map(float, centre)), tuple(map(float, n)), a, b, tuple(map(float, u)), shape
    )
