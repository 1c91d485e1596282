"""A layer whose articular surface is the other surface lowered by the clearance (issue 27).

``cartilage_layer(..., along="lowered")`` on a block's top, flat or tilted about z, under
a sphere: every offset vertex lies straight above its bone vertex; by VTK's ray tracer
(not the layer's own ray code) the vertical gap from each offset vertex up to the sphere
is the clearance, to the chord errors of the two surfaces' facets, wherever the sphere
is within the largest thickness of the block and the rim's slope leaves room; the gap
from each vertex of the sphere down to the layer is never below the clearance; where the
sphere is far the layer has the largest thickness, measured vertically.  The reference
for "where the sphere is within reach" is the analytic sphere.
"""

import math

import numpy as np
import pytest
import pyvista as pv

from bonecontact.meshing import MeshInputError, Surface
from bonecontact.meshing.joint import Cartilage, cartilage_layer
from bonecontact.meshing.stl import SurfaceRegion
from bonecontact.meshing.surface_repair import orient_surface

MM = 1e-3
R = 0.02
UP = np.array([0.0, 1.0, 0.0])


def _poly(mesh: pv.PolyData) -> Surface:
    mesh = mesh.triangulate().clean()
    tri = mesh.faces.reshape(-1, 4)[:, 1:].astype(np.int64)
    return orient_surface(Surface(np.asarray(mesh.points, float), tri, "test"))


def _tilted_block_and_ball(gap: float, tilt: float, dx: float):
    """A 30 x 10 x 30 mm block (top at y = 0, 2 mm squares) turned by ``tilt`` degrees
    about z, and a sphere of radius R, moved by ``dx`` along x, whose smallest vertical
    gap to the block's top plane is ``gap``; the sphere's centre."""
    box = pv.Box((-0.015, 0.015, -0.01, 0.0, -0.015, 0.015), level=14)
    block = _poly(box.rotate_z(tilt, point=(0.0, 0.0, 0.0), inplace=False))
    th = math.radians(tilt)
    # vertical gap of the sphere over the plane y = x tan(th): smallest at x_c + R sin(th)
    centre = np.array([dx, dx * math.tan(th) + gap + R / math.cos(th), 0.0])
    ball = _poly(pv.Icosphere(radius=R, center=tuple(centre), nsub=4))
    return block, ball, centre


def _up_gaps(points: np.ndarray, surface: pv.PolyData, down: bool = False) -> np.ndarray:
    """Vertical distance from each point to its first crossing of ``surface`` (VTK's ray
    tracer; inf: none), upward (or downward)."""
    d = -UP if down else UP
    out = np.full(len(points), np.inf)
    for i, p in enumerate(points):
        hit, _ = surface.ray_trace(p + 1e-9 * d, p + 0.05 * d)
        if len(hit):
            out[i] = np.abs(np.asarray(hit)[:, 1] - p[1]).min()
    return out


def _edge(points: np.ndarray, tri: np.ndarray) -> float:
    return float(np.linalg.norm(points[tri] - points[np.roll(tri, 1, axis=1)], axis=2).max())


@pytest.mark.parametrize(
    ("clearance", "tmax", "tilt", "dx"),
    [
        (0.5 * MM, 4 * MM, 0.0, 0.0),
        (0.5 * MM, 4 * MM, 20.0, 0.0),
        (0.3 * MM, 3 * MM, 10.0, 3 * MM),
        (0.5 * MM, 2.5 * MM, -15.0, -2 * MM),
    ],
)
def test_lowered_layer_is_the_other_surface_lowered(clearance, tmax, tilt, dx):
    t0 = 1.5 * MM
    block, ball, centre = _tilted_block_and_ball(t0 + clearance, tilt, dx)
    up_n = np.array([-math.sin(math.radians(tilt)), math.cos(math.radians(tilt)), 0.0])
    top = np.flatnonzero(block.triangle_normals() @ up_n > 0.99)
    layer = cartilage_layer(block, top, tmax, (ball, clearance), along="lowered")
    p = layer.points
    # straight up: every articular vertex over its bone vertex
    assert np.allclose(p[layer.top][..., [0, 2]], p[layer.base][..., [0, 2]], atol=1e-12)
    rise = (p[layer.top] - p[layer.base])[..., 1]
    assert rise.min() >= 0 and rise.max() <= tmax * (1 + 1e-9)
    inner = np.unique(layer.top[layer.top >= len(block.points)])
    below = {}
    for b, t in zip(layer.base.ravel(), layer.top.ravel(), strict=True):
        below[t] = b
    base = p[[below[i] for i in inner]]
    q = p[inner]
    # the analytic sphere's vertical gap over each bone vertex, less the clearance
    r2 = (base[:, 0] - centre[0]) ** 2 + (base[:, 2] - centre[2]) ** 2
    want = np.where(r2 < R**2, centre[1] - np.sqrt(np.maximum(R**2 - r2, 0)) - base[:, 1], np.inf)
    want -= clearance
    # the rim (the top's edge, 15 mm from its middle along the tilted plane) allows tmax
    # (slope 1) inside 15 mm - tmax
    along = np.abs(base @ np.array([math.cos(math.radians(tilt)), math.sin(math.radians(tilt)), 0]))
    inside = np.maximum(along, np.abs(base[:, 2])) < 0.015 - tmax - 1 * MM
    near = inside & (want < tmax - 0.5 * MM)
    assert near.sum() > 10
    art = pv.PolyData(p, np.hstack([np.full((len(layer.top), 1), 3), layer.top]).ravel())
    gaps = _up_gaps(q[near], ball.to_pyvista())
    chord = (_edge(p, layer.top) ** 2 + _edge(ball.points, ball.triangles) ** 2) / (8 * R)
    assert gaps.min() >= clearance - 1e-9
    assert gaps.max() <= clearance + chord
    # where the sphere is out of reach the layer keeps its largest thickness
    far = inside & (want > tmax + 1 * MM)
    assert far.sum() > 10
    assert np.allclose(q[far, 1] - base[far, 1], tmax, rtol=1e-9)
    # and nowhere is the sphere closer than the clearance above the layer
    over = ball.points[ball.points[:, 1] < centre[1]]
    down = _up_gaps(over, art, down=True)
    assert down[np.isfinite(down)].min() >= clearance * (1 - 1e-6)
    assert np.isfinite(down).sum() > 50


def test_lowered_layer_refuses_bones_too_close_and_unknown_modes():
    block, ball, _ = _tilted_block_and_ball(0.5 * MM + 0.1 * MM, 0.0, 0.0)
    top = np.flatnonzero(block.triangle_normals()[:, 1] > 0.99)
    with pytest.raises(MeshInputError, match="pose the bones further apart"):
        cartilage_layer(block, top, 4 * MM, (ball, 0.5 * MM), along="lowered")
    region = (SurfaceRegion("r", cone=((0, 1, 0), 10)),)
    Cartilage("c", "c_contact", region, 1e-3, conform_to="a", conform_along="lowered")
    with pytest.raises(ValueError, match="'normal', 'vertical' or 'lowered'"):
        Cartilage("c", "c_contact", region, 1e-3, conform_to="a", conform_along="sideways")


@pytest.mark.parametrize("clearance", [0.5 * MM, 0.3 * MM])
def test_lowered_joint_opens_under_bare_bone_and_tapered_rim(tmp_path, clearance):
    """Meshed with joint_from_surfaces: a sphere with a 1 mm cartilage cap (its facets
    within 25° of -y, tapering over its rim's ring) over a block whose layer is lowered
    to it.  Read back from the written mesh, by VTK's rays up from the block's articular
    vertices: under the cap's full thickness the gap to the cap is the clearance (to the
    chords); under the sphere's bare bone (beyond the cap's projection) the gap to the
    bone is the clearance plus the cap's thickness, so neither bare bone nor the tapered
    rim is in reach of the clearance."""
    from mpi4py import MPI

    from bonecontact.meshing.joint import JointBone, joint_from_surfaces
    from bonecontact.neoplasm.host3d import read_host_geometry3d

    t_cap, t0, tmax = 1 * MM, 1.5 * MM, 6 * MM
    block = _poly(pv.Box((-0.015, 0.015, -0.01, 0.0, -0.015, 0.015), level=14))
    centre = np.array([0.0, R + t_cap + clearance + t0, 0.0])
    ball = _poly(pv.Icosphere(radius=R, center=tuple(centre), nsub=3))
    cap = Cartilage("cap", "cap_contact", (SurfaceRegion("c", cone=((0, -1, 0), 25)),), t_cap)
    top = Cartilage(
        "layer", "layer_contact", (SurfaceRegion("t", cone=((0, 1, 0), 10)),), tmax,
        conform_to="ball", clearance=clearance, conform_along="lowered", rim_slope=3,
    )  # fmt: skip
    bones = [JointBone("ball", ball, cartilage=cap), JointBone("block", block, cartilage=top)]
    path = joint_from_surfaces(bones, 4 * MM, remesh=False, comm=MPI.COMM_SELF,
                               path=tmp_path / "j.msh")  # fmt: skip
    geo = read_host_geometry3d(path)

    def group(name: str) -> pv.PolyData:
        tri = geo.facets[name][1]
        return pv.PolyData(geo.x, np.hstack([np.full((len(tri), 1), 3), tri]).ravel())

    q = geo.x[np.unique(geo.facets["layer_contact"][1])]
    r = np.hypot(q[:, 0] - centre[0], q[:, 2] - centre[2])
    to_cap = _up_gaps(q, group("cap_contact"))
    to_bone = _up_gaps(q, group("ball_surface"))
    edge = max(_edge(geo.x, geo.facets[g][1]) for g in ("cap_contact", "layer_contact"))
    chord = 2 * edge**2 / (8 * R)
    rim = R * math.sin(math.radians(25))  # the cap's projected radius
    ring = 1.3 * _edge(ball.points, ball.triangles)  # the cap's tapered ring
    inner = r < rim - ring
    bare = (r > rim + 0.5 * ring) & (r < 12 * MM)
    assert inner.sum() > 5 and bare.sum() > 5
    assert np.all(to_cap[inner] >= clearance - 1e-9)
    assert np.all(to_cap[inner] <= clearance + chord)
    assert np.all(to_bone[bare] >= clearance + t_cap - 1e-9)
    assert np.all(to_bone[bare] <= clearance + t_cap + chord)
    assert np.minimum(to_cap, to_bone).min() >= clearance - 1e-9
