"""Facets of an upper bone over a lower one, and the steepness of a conformed layer's rim
(issue 27).

``FacetsOver``: the facets of a sphere over a block that it selects are checked against
VTK's ray tracer (not the region's own ray code): from each selected facet's centroid,
and from the points ``margin`` away in ±x and ±z, a vertical ray down meets the block's
top within ``max_gap``; every facet facing down within the cone and inside the box that
is left out fails that test at one of the five points.  ``Cartilage.rim_slope``: the
vertically conformed layer is nowhere thicker than ``rim_slope`` times its vertex's
distance from the layer's rim (or a tenth of the thickness), and a steeper rim keeps
more of the conformed thickness.
"""

import numpy as np
import pytest
import pyvista as pv

from bonecontact.meshing import Surface
from bonecontact.meshing.joint import Cartilage, FacetsOver, cartilage_layer
from bonecontact.meshing.stl import SurfaceRegion
from bonecontact.meshing.surface_repair import orient_surface

MM = 1e-3
R = 0.02


def _poly(mesh: pv.PolyData) -> Surface:
    mesh = mesh.triangulate().clean()
    tri = mesh.faces.reshape(-1, 4)[:, 1:].astype(np.int64)
    return orient_surface(Surface(np.asarray(mesh.points, float), tri, "test"))


def _block_and_ball(gap: float, nsub: int = 4):
    """A 30 x 10 x 30 mm block with its top at y = 0 and a sphere of radius R whose
    lowest point is ``gap`` above it."""
    block = _poly(pv.Box((-0.015, 0.015, -0.01, 0.0, -0.015, 0.015), level=14))
    ball = _poly(pv.Icosphere(radius=R, center=(0.0, R + gap, 0.0), nsub=nsub))
    return block, ball


def _hits_top(block: Surface, points: np.ndarray, max_gap: float) -> np.ndarray:
    mesh = block.to_pyvista()
    top = block.triangle_normals()[:, 1] > 0.5
    out = np.zeros(len(points), bool)
    for i, p in enumerate(points):
        hit, cell = mesh.ray_trace(p, p - np.array([0.0, 0.1, 0.0]), first_point=True)
        out[i] = len(hit) > 0 and top[cell[0]] and p[1] - hit[1] < max_gap
    return out


@pytest.mark.parametrize("margin", [0.0, 2 * MM])
@pytest.mark.parametrize("max_gap", [3 * MM, 6 * MM])
@pytest.mark.parametrize("box", [None, ((-1.0, -1.0, 0.0), (1.0, 1.0, 1.0))])
def test_facets_over_meet_the_lower_surface_within_the_gap(margin, max_gap, box):
    block, ball = _block_and_ball(1 * MM, nsub=3)
    region = FacetsOver("over", block, max_gap, cone=60, margin=margin, box=box)
    c, n = ball.centroids(), ball.triangle_normals()
    mask = region.select(c, n)
    assert mask.any()
    facing = n[:, 1] <= -np.cos(np.radians(60))
    if box is not None:
        facing &= c[:, 2] >= 0.0
    assert not (mask & ~facing).any()
    ok = np.ones(len(c), bool)
    for dx, dz in ((0, 0), (margin, 0), (-margin, 0), (0, margin), (0, -margin)):
        ok &= _hits_top(block, c + [dx, 0.0, dz], max_gap)
    assert np.array_equal(mask, facing & ok)
    # the selection's footprint: the ball's circle at height max_gap, less the margin
    r_gap = np.sqrt(R**2 - (R - (max_gap - 1 * MM)) ** 2)
    assert np.hypot(c[mask, 0], c[mask, 2]).max() <= r_gap


def test_facets_over_as_a_cartilage_region_and_bad_values():
    block, ball = _block_and_ball(1 * MM, nsub=3)
    region = FacetsOver("over", block, 4 * MM)
    cart = Cartilage("c", "c_contact", (region,), 1 * MM)
    assert np.array_equal(
        np.flatnonzero(region.select(ball.centroids(), ball.triangle_normals())),
        cart.select(ball),
    )
    with pytest.raises(ValueError, match="max_gap"):
        FacetsOver("over", block, 0.0)
    with pytest.raises(ValueError, match="cone"):
        FacetsOver("over", block, 1 * MM, cone=120)
    with pytest.raises(ValueError, match="rim_slope"):
        Cartilage("c", "c_contact", (SurfaceRegion("r", cone=((0, 1, 0), 10)),), 1e-3, rim_slope=0)


@pytest.mark.parametrize("slope", [1.0, 3.0])
def test_conformed_layer_no_steeper_than_its_rim_slope(slope):
    block, ball = _block_and_ball(2 * MM, nsub=3)
    top = np.flatnonzero(block.triangle_normals()[:, 1] > 0.9)
    tmax = 8 * MM
    layer = cartilage_layer(block, top, tmax, (ball, 0.5 * MM), along="vertical", rim_slope=slope)
    t = layer.thickness()
    base = np.unique(layer.base.ravel())
    rim = base[t == 0.0]
    assert len(rim) > 0
    gaps = block.points[base][:, None] - block.points[rim][None]
    d = np.linalg.norm(gaps, axis=2).min(axis=1)
    assert np.all(t <= np.maximum(slope * d, 0.1 * tmax) + 1e-12)
    if slope > 1.0:
        flat = cartilage_layer(block, top, tmax, (ball, 0.5 * MM), along="vertical")
        assert layer.volume > flat.volume
