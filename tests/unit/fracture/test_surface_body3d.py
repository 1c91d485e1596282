"""A semi-elliptical surface crack cut into a given 3D body
(bonecontact.fracture.surface_body3d).

The body is a mesh given from outside (a gmsh box, a gmsh cylinder), as a scene's mesh is:
its boundary triangulation is kept, refined near the crack, cut along the mouth, and the
volume re-meshed around the crack.

* the cut boundary: still closed (every edge in two triangles), of the same area and
  enclosed volume as before (the refinement and the cut move no surface), the mouth in the
  crack plane, inside the ellipse, its ends on the ellipse (within the snap fraction);
* a plate [−5, 5] × [−5, 5] × [−1, 0] (boundary facets 0.4) under tension S with a
  semi-elliptical crack (a/t = 0.2) at the centre of its front face: K_I against Newman
  and Raju's equation (the reference of the OpenCASCADE plate of bonecontact.verification.
  surface_crack) at 20°, 45°, 90°, 135°, 160°.  a/c = 1, front a/10 (20k dofs): deepest
  within 4 %, the others within 7 % (measured with front3d of 7f6172c −2.6 % and
  −3.1 … +0.7 %; with the front3d before it −3.7 % and −6.2 … −1.7 %, the same to 10⁻¹³
  on 2 ranks); slow: a/c = 0.5,
  front a/14 (47k dofs): deepest within 4 %, the others within 6 % (measured −3.3 % and
  −4.7 … −2.9 % with the auxiliary field in the ellipse's coordinates, 2026-12-02; −3.3 %
  and −7.7 % at 20° with the osculating circle's of 7f6172c; at a/10 −6.7 % deepest: the
  cut body's unstructured mesh scatters more than the OpenCASCADE plate's, −2.6 % there at
  a/10); K_II, K_III below 3 % of K_I;
* a cylinder (radius 1, the crack plane normal to its axis, a = c = 0.15): the front's
  ends stop short of the major axis (a convex surface), on the cylinder;
* bad input: a centre away from the surface, a plane tangent to the surface;
* the nearest boundary triangle (the crack centre's facet) by distance: against the closed
  forms for a right triangle and against a dense sampling of random triangles; a centre on
  a large facet whose centroid is farther than a small facet of another surface nearby
  (the vertebra demo's wall and cavity) is accepted on its own facet.

Every case runs on 1, 2 and 3 ranks against the same references (the mesh is built on
rank 0 from the boundary gathered in a canonical order: the same mesh on every count).
"""

from __future__ import annotations

import contextlib
import math

from mpi4py import MPI

import gmsh
import numpy as np
import pytest
from dolfinx import mesh
from dolfinx.io.gmsh import model_to_mesh

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.body3d import body_surface
from bonecontact.fracture.crack3d import SurfaceBreakingCrack
from bonecontact.fracture.front3d import front_interaction_integral
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.surface3d import PLATE_GROUPS, domain_length
from bonecontact.fracture.surface_body3d import (
    SNAP_FRACTION,
    crack_frame,
    cut_mouth,
    inside_body,
    mesh_body_with_surface_crack,
)
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics
from bonecontact.meshing.session import gmsh_session
from bonecontact.verification.surface_crack import PLATE_MATERIAL, surface_crack_k

B, H, T = 5.0, 5.0, 1.0


def _plate() -> None:
    box = gmsh.model.occ.addBox(-B, -H, -T, 2 * B, 2 * H, T)
    gmsh.model.occ.synchronize()
    gmsh.model.addPhysicalGroup(3, [box], 1, name="plate")
    for _, s in gmsh.model.getEntities(2):
        x, y, z = gmsh.model.occ.getCenterOfMass(2, s)
        hits = {
            "left": abs(x + B),
            "right": abs(x - B),
            "bottom": abs(y + H),
            "top": abs(y - H),
            "back": abs(z + T),
            "front": abs(z),
        }
        name = min(hits, key=hits.get)
        gmsh.model.addPhysicalGroup(2, [s], PLATE_GROUPS[name], name=name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.4)
    gmsh.model.mesh.generate(3)


def _cylinder() -> None:
    cyl = gmsh.model.occ.addCylinder(0, 0, -2, 0, 0, 4, 1.0)
    gmsh.model.occ.synchronize()
    gmsh.model.addPhysicalGroup(3, [cyl], 1, name="bar")
    for _, s in gmsh.model.getEntities(2):
        z = gmsh.model.occ.getCenterOfMass(2, s)[2]
        name, tag = (
            ("side", 11) if abs(z) < 1.0 else (("end_low", 12) if z < 0 else ("end_high", 13))
        )
        gmsh.model.addPhysicalGroup(2, [s], tag, name=name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.12)
    gmsh.model.mesh.generate(3)


def _body(build, groups: dict, region: str):
    comm = MPI.COMM_WORLD
    with gmsh_session("body") if comm.rank == 0 else contextlib.nullcontext():
        if comm.rank == 0:
            build()
        md = model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=3)
    return body_surface(md.mesh, md.cell_tags, md.facet_tags, groups, region)


@pytest.fixture(scope="module")
def plate():
    groups = {n: (2, t) for n, t in PLATE_GROUPS.items()} | {"plate": (3, 1)}
    return _body(_plate, groups, "plate")


@pytest.fixture(scope="module")
def bar():
    groups = {"side": (2, 11), "end_low": (2, 12), "end_high": (2, 13), "bar": (3, 1)}
    return _body(_cylinder, groups, "bar")


def _closed(tris: np.ndarray) -> bool:
    edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return bool(np.all(counts == 2))


def _area_volume(x: np.ndarray) -> tuple[float, float]:
    """Area and enclosed volume of outward triangles (n, 3, 3)."""
    area = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1).sum()
    vol = np.einsum("ij,ij->i", x[:, 0], np.cross(x[:, 1], x[:, 2])).sum() / 6.0
    return float(area), float(vol)


@pytest.mark.parametrize("c", [0.2, 0.4])
def test_cut_boundary_is_closed_and_keeps_the_surface(plate, c: float) -> None:
    a = 0.2
    crack = SurfaceBreakingCrack((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), a, c)
    cut = cut_mouth(plate, crack, TipMesh(a / 10, 0.12))
    assert _closed(cut.triangles)
    area0, vol0 = _area_volume(plate.triangles)
    area1, vol1 = _area_volume(cut.nodes[cut.triangles])
    assert area1 == pytest.approx(area0, rel=1e-12) and vol1 == pytest.approx(vol0, rel=1e-12)
    m = cut.nodes[list(cut.mouth)]
    np.testing.assert_allclose(m[:, 1], 0.0, atol=1e-12)  # in the crack plane
    np.testing.assert_allclose(m[:, 2], 0.0, atol=1e-12)  # on the front face
    assert np.all(np.abs(m[1:-1, 0]) < c)  # inside the ellipse
    # the ends: on the ellipse within the snap distance of the refined boundary
    np.testing.assert_allclose(np.sort(m[[0, -1], 0]), [-c, c], atol=5 * SNAP_FRACTION * a)
    p0, p1 = cut.arc.phi_range
    assert p0 == pytest.approx(0.0, abs=0.05) and p1 == pytest.approx(math.pi, abs=0.05)
    deepest = cut.arc.point(0.5 * (p0 + p1))[0]
    np.testing.assert_allclose(deepest, [0.0, 0.0, -a], atol=1e-12)


def test_convex_surface_front_stops_short_of_the_major_axis(bar) -> None:
    a = c = 0.15
    crack = SurfaceBreakingCrack((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), a, c)
    cut = cut_mouth(bar, crack, TipMesh(a / 8, 0.12))
    assert _closed(cut.triangles)
    p0, p1 = cut.arc.phi_range
    # the surface bends into the crack's side: sin(phi0) = (1 - cos(c/R)) R / a nearly
    assert 0.0 < p0 < 0.15 and math.pi - 0.15 < p1 < math.pi
    ends = cut.arc.point(np.array([p0, p1]))
    # on the (faceted) cylinder: radius 1 less the sagitta of its facets (0.002)
    np.testing.assert_allclose(np.hypot(ends[:, 0], ends[:, 1]), 1.0, atol=0.005)
    inner = cut.arc.point(np.linspace(p0, p1, 9)[1:-1])
    assert np.all(inside_body(bar, inner))
    assert not inside_body(bar, np.array([[1.2, 0.0, 0.0]]))[0]


def test_bad_input_names_the_key(plate) -> None:
    with pytest.raises(ParameterError, match="centre"):
        cut_mouth(plate, SurfaceBreakingCrack((0.0, 0.0, -0.5), (0.0, 1.0, 0.0), 0.1, 0.1))
    with pytest.raises(ParameterError, match="normal"):
        cut_mouth(plate, SurfaceBreakingCrack((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 0.1, 0.1))


def test_centre_on_a_large_facet_next_to_a_small_one() -> None:
    """A centre on an 8 mm facet (its centroid 1.67 mm off) with a 1 mm facet of another
    surface 1.2 mm below it (centroid 1.50 mm off): the frame's centre stays where it was given."""
    nodes = np.array(
        [[-4.0, -2.0, 0.0], [4.0, -2.0, 0.0], [0.0, 6.0, 0.0]]
        + [[0.0, -0.5, -1.2], [1.0, -0.5, -1.2], [0.0, 0.5, -1.2]]
    )
    conn = np.array([[0, 1, 2], [3, 4, 5]])
    crack = SurfaceBreakingCrack((0.0, -1.0, 0.0), (1.0, 0.0, 0.0), 0.25, 0.25)
    _, placed = crack_frame(crack, nodes, conn)
    np.testing.assert_allclose(placed.centre, crack.centre, atol=1e-15)


def _solve(body, a: float, c: float, h: float):
    crack = SurfaceBreakingCrack((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), a, c)
    cb, _, cut = mesh_body_with_surface_crack(body, crack, TipMesh(h, 0.12, 0.4))
    blk = cb.block()
    m = Mechanics(blk.mesh, PLATE_MATERIAL, blk.cell_tags, blk.facet_tags)
    facets = blk.facet_tags.find(PLATE_GROUPS["bottom"])
    mid = mesh.compute_midpoints(blk.mesh, 2, facets)
    patch = facets[np.linalg.norm(mid - np.array([0.0, -H, -0.5 * T]), axis=1) <= 0.5]
    for i in range(3):
        m.add_dirichlet(patch.astype(np.int32), i, 0.0)
    m.add_traction(PLATE_GROUPS["top"], (0.0, 1.0, 0.0))
    m.add_traction(PLATE_GROUPS["bottom"], (0.0, -1.0, 0.0))
    integ = Integrator(m, "static", 1.0)
    integ.step()
    r_out = 0.25 * a
    out = []
    p0, p1 = cut.arc.phi_range
    for phi in np.radians([20.0, 45.0, 90.0, 135.0, 160.0]):
        length = domain_length(blk.front, float(phi), r_out, h)
        k = front_interaction_integral(
            integ.u, blk, float(phi), PLATE_MATERIAL, r_out, None, length
        )
        out.append((k.K_I, k.K_II, k.K_III))
    integ.destroy()
    return np.asarray(out), (p0, p1)


@pytest.mark.parametrize(
    "c, h, deepest, along",
    [
        (0.2, 0.02, 0.04, 0.07),
        pytest.param(0.4, 0.014, 0.04, 0.06, marks=pytest.mark.slow),
    ],
)
def test_plate_k_against_newman_raju(
    plate, c: float, h: float, deepest: float, along: float
) -> None:
    a = 0.2
    k, _ = _solve(plate, a, c, h)
    phi = np.radians([20.0, 45.0, 90.0, 135.0, 160.0])
    ref = surface_crack_k(1.0, a, c, T, B, phi)
    assert k[2, 0] == pytest.approx(ref[2], rel=deepest)
    np.testing.assert_allclose(k[:, 0], ref, rtol=along)
    assert np.max(np.abs(k[:, 1:])) < 0.03 * ref.max()
