"""Smooth articular surfaces and a vertically conforming layer (issue 27).

``smooth_surface``: a coarse polyhedron of a sphere (an icosahedron split once) is rounded
towards the sphere it was cut from (reference: the sphere's radius), stays closed, keeps
its volume and stays within a bound of the polyhedron; vertices of weight 0 do not move.
``refine_facets``: the split surface keeps its area exactly and stays closed.
``cartilage_layer(..., along="vertical")``: a layer on a flat-topped block under a
sphere; the vertical gap from each vertex of the sphere down to the layer's articular
surface, measured by VTK's ray tracer (not the layer's own ray code), is never below the
clearance and within the chord error above it over the conformed patch; with a
subchondral part the cartilage over it has the given thickness.
"""

import numpy as np
import pytest
import pyvista as pv

from bonecontact.meshing import Surface
from bonecontact.meshing.joint import cartilage_layer, refine_facets, smooth_surface
from bonecontact.meshing.surface_repair import check_surface, orient_surface

MM = 1e-3
R = 0.02


def _poly(mesh: pv.PolyData) -> Surface:
    mesh = mesh.triangulate().clean()
    tri = mesh.faces.reshape(-1, 4)[:, 1:].astype(np.int64)
    return orient_surface(Surface(np.asarray(mesh.points, float), tri, "test"))


def _distance(points: np.ndarray, surface: Surface) -> np.ndarray:
    d = pv.PolyData(points).compute_implicit_distance(surface.to_pyvista())
    return np.abs(np.asarray(d["implicit_distance"]))


@pytest.mark.parametrize(("iterations", "subdivide"), [(20, 1), (50, 2), (100, 2)])
def test_smoothing_rounds_a_polyhedron_towards_its_sphere(iterations, subdivide):
    coarse = _poly(pv.Icosphere(radius=R, nsub=1))  # 80 facets, chord error ~ 0.1 R
    out = smooth_surface(coarse, iterations, subdivide=subdivide)
    check_surface(out)  # closed, 2-manifold
    spread = lambda s: np.ptp(np.linalg.norm(s.points, axis=1)) / R  # noqa: E731
    fine = smooth_surface(coarse, 0, subdivide=subdivide)  # the same points, not smoothed
    assert spread(out) < 0.5 * spread(fine)  # closer to the sphere than the polyhedron
    # Taubin: no shrinking; rounded, it lies between the polyhedron and its sphere
    assert 0.99 * coarse.volume < out.volume < 1.01 * 4 / 3 * np.pi * R**3
    # within the polyhedron's own distance from the sphere (its chord error)
    chord = R - np.linalg.norm(coarse.centroids(), axis=1).min()
    assert _distance(out.points, coarse).max() <= chord


def test_smoothing_leaves_vertices_of_weight_zero_in_place():
    coarse = _poly(pv.Icosphere(radius=R, nsub=1))
    fine = smooth_surface(coarse, 0, subdivide=1)
    out = smooth_surface(coarse, 40, subdivide=1, weights=lambda p: (p[:, 1] > 0).astype(float))
    still = fine.points[:, 1] <= 0
    assert np.array_equal(out.points[still], fine.points[still])
    assert np.abs(out.points[~still] - fine.points[~still]).max() > 1e-4 * R
    with pytest.raises(ValueError, match="one value per point"):
        smooth_surface(coarse, 1, weights=lambda p: np.ones(3))


@pytest.mark.parametrize("which", ["one", "patch", "all"])
def test_refined_facets_keep_the_shape(which):
    s = _poly(pv.Icosphere(radius=R, nsub=2))
    facets = {"one": [0], "patch": np.flatnonzero(s.centroids()[:, 1] > 0.5 * R), "all": None}
    f = np.arange(len(s.triangles)) if which == "all" else np.asarray(facets[which])
    out = refine_facets(s, f)
    check_surface(out)
    assert out.area == pytest.approx(s.area, rel=1e-12)
    assert out.volume == pytest.approx(s.volume, rel=1e-12)
    assert len(out.triangles) >= len(s.triangles) + 3 * len(f)
    assert np.array_equal(out.points[: len(s.points)], s.points)


def _block_and_ball(gap: float):
    """A 30 x 10 x 30 mm block with its top at y = 0 (split into 2 mm squares) and a
    sphere of radius R whose lowest point is ``gap`` above it."""
    block = _poly(pv.Box((-0.015, 0.015, -0.01, 0.0, -0.015, 0.015), level=14))
    ball = _poly(pv.Icosphere(radius=R, center=(0.0, R + gap, 0.0), nsub=4))
    return block, ball


@pytest.mark.parametrize(
    ("clearance", "tmax", "subchondral"), [(0.5 * MM, 4 * MM, None), (0.3 * MM, 3 * MM, 1 * MM)]
)
def test_vertical_layer_leaves_the_clearance_under_every_vertex(clearance, tmax, subchondral):
    t0 = 1.5 * MM
    block, ball = _block_and_ball(t0 + clearance)
    top = np.flatnonzero(block.triangle_normals()[:, 1] > 0.9)
    layer = cartilage_layer(
        block, top, tmax, (ball, clearance), along="vertical", cartilage_thickness=subchondral
    )
    art = pv.PolyData(layer.points, np.hstack([np.full((len(layer.top), 1), 3), layer.top]).ravel())
    over = ball.points[(ball.points[:, 1] < R) & (np.hypot(*ball.points[:, [0, 2]].T) < 0.012)]
    gaps = []
    for p in over:  # VTK's ray tracer, down from each vertex of the ball
        hit, _ = art.ray_trace(p, p - np.array([0.0, 0.05, 0.0]), first_point=True)
        gaps.append(p[1] - hit[1] if len(hit) else np.inf)
    gaps = np.array(gaps)
    assert gaps.min() >= clearance * (1 - 1e-3)
    # where the sphere is within tmax + clearance of the block the layer conforms: the
    # gap exceeds the clearance by at most the chord errors of the layer's facets and
    # the sphere's under R (edge^2 / (8 R) each, the longest edges)
    near = over[:, 1] < tmax + clearance - 1 * MM
    assert near.sum() > 10
    edge = lambda s, tri: np.linalg.norm(s[tri] - s[np.roll(tri, 1, axis=1)], axis=2).max()  # noqa: E731
    chord = (edge(layer.points, layer.top) ** 2 + edge(ball.points, ball.triangles) ** 2) / (8 * R)
    assert gaps[near].max() <= clearance + chord
    if subchondral is not None:
        t = np.linalg.norm(layer.points[layer.top] - layer.points[layer.mid], axis=2)
        inner = np.linalg.norm(layer.points[layer.mid] - layer.points[layer.base], axis=2)
        deep = inner > 0.2 * (t + inner) + 1e-9  # full cartilage over its bone
        assert np.allclose(t[deep], subchondral, rtol=1e-9)
