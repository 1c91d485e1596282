"""The re-characterisation rule of an interior flaw near the surface
(runners.breakthrough3d.surface_flaw; docs/theory/fracture.md#an-interior-crack-that-
reaches-the-surface) on a faceted cylinder, against the rule done by hand.

The cylinder of radius R = 3 mm, |z| ≤ 2 mm, 64 side facets (a facet centred at θ = 0:
its plane x = R cos(π/64), outward normal x).  A regular 10-gon front of radius 1 mm
centred at x = 1.5 mm, symmetric about the x-z plane (ligament ≈ 0.5 mm to that facet; the
depth line through the middle of its length meets that facet):

* in the plane z = 0 (normal z): e = x, t = z × x = y; depth = x_s − min x, half-length =
  half the y extent, ligament = x_s − max x, centre (x_s, mid y, 0);
* in a plane tilted 30° about y (normal (sin 30°, 0, cos 30°)): e the facet normal x
  projected on the plane, t = n × e; the extents along e and t, and the centre where the
  line along e through the middle of the length at the highest level meets x = x_s, by
  hand;
* a crack plane parallel to the facet (normal x; a 0.3 mm penny 0.2 mm from it, the
  nearest facet's normal 5.6° from x) is refused naming ``breakthrough``.

Pure numpy: runs under mpiexec too (the same on every rank).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.body3d import BodySurface
from bonecontact.runners.breakthrough3d import surface_flaw

R, Z, N = 3.0e-3, 2.0e-3, 64
XS = R * math.cos(math.pi / N)


def _cylinder() -> BodySurface:
    """The faceted cylinder's boundary, its triangles outward."""
    th = 2 * math.pi * (np.arange(N) + 0.5) / N
    ring = np.column_stack([R * np.cos(th), R * np.sin(th), np.zeros(N)])
    lo, hi = ring - [0, 0, Z], ring + [0, 0, Z]
    tris = []
    for k in range(N):
        j = (k + 1) % N
        tris += [(lo[k], lo[j], hi[j]), (lo[k], hi[j], hi[k])]
        tris += [((0, 0, Z), hi[k], hi[j]), ((0, 0, -Z), lo[j], lo[k])]
    T = np.asarray(tris, dtype=float)
    return BodySurface(T, np.zeros(len(T), dtype=np.int32), {}, ("body", 1), 2 * Z / 4)


def _front(normal: np.ndarray, centre=(1.5e-3, 0.0, 0.0), r=1.0e-3, n=10) -> np.ndarray:
    """The regular n-gon of radius r about ``centre`` in the plane of ``normal``."""
    u = np.cross(normal, [0.0, 1.0, 0.0])
    u = u / np.linalg.norm(u) if np.linalg.norm(u) > 0 else np.array([1.0, 0.0, 0.0])
    v = np.cross(normal, u)
    phi = 2 * math.pi * np.arange(n) / n  # symmetric about the x-z plane
    return np.asarray(centre) + r * (np.outer(np.cos(phi), u) + np.outer(np.sin(phi), v))


def test_perpendicular_plane() -> None:
    n = np.array([0.0, 0.0, 1.0])
    V = _front(n)
    f = surface_flaw(_cylinder(), V, n)
    c = f.crack
    assert c.depth == pytest.approx(XS - V[:, 0].min(), rel=1e-12)
    assert c.half_length == pytest.approx(0.5 * np.ptp(V[:, 1]), rel=1e-12)
    assert f.ligament == pytest.approx(XS - V[:, 0].max(), rel=1e-12)
    assert f.height == pytest.approx(np.ptp(V[:, 0]), rel=1e-12)
    mid = 0.5 * (V[:, 1].max() + V[:, 1].min())
    np.testing.assert_allclose(c.centre, [XS, mid, 0.0], atol=1e-15)
    np.testing.assert_allclose(c.axis, [0.0, 1.0, 0.0], atol=1e-14)
    np.testing.assert_allclose(c.normal, n, atol=0)


def test_tilted_plane() -> None:
    b = math.radians(30.0)
    n = np.array([math.sin(b), 0.0, math.cos(b)])
    V = _front(n)
    f = surface_flaw(_cylinder(), V, n)
    e = np.array([math.cos(b), 0.0, -math.sin(b)])  # x on the plane: x − (x·n) n, unit
    t = np.array([0.0, 1.0, 0.0])  # n × e
    along, up = V @ t, V @ e
    top = V[np.argmax(up)]
    p0 = top + (0.5 * (along.max() + along.min()) - top @ t) * t  # on the depth line
    s = (XS - p0[0]) / e[0]  # to the facet's plane x = x_s
    assert f.ligament == pytest.approx(s, rel=1e-12)
    assert f.crack.depth == pytest.approx(s + np.ptp(up), rel=1e-12)
    assert f.crack.half_length == pytest.approx(0.5 * np.ptp(along), rel=1e-12)
    np.testing.assert_allclose(f.crack.centre, p0 + s * e, atol=1e-15)
    np.testing.assert_allclose(f.crack.axis, t, atol=1e-14)
    assert f.crack.centre[0] == pytest.approx(XS, rel=1e-12)


def test_plane_parallel_to_the_surface_is_refused() -> None:
    n = np.array([1.0, 0.0, 0.0])
    V = _front(n, centre=(2.5e-3, 0.0, 0.0), r=0.3e-3)
    with pytest.raises(ParameterError, match=r"breakthrough.*parallel"):
        surface_flaw(_cylinder(), V, n)
