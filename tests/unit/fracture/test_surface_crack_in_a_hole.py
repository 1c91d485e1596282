"""A grown semi-elliptical crack on the wall of a hole (bonecontact.fracture.surface_body3d):
the long mouth of a crack in the scanned L4's posterior wall, on a geometry with an exact
surface.

The body: a tube, inner radius R = 1, outer 4, z ∈ [0, 6] (inner wall facets about 0.12);
the crack plane z = 1.5 (normal to the axis), the centre (R, 0, 1.5) on the inner wall,
``axis`` = (0, 1, 0) given (a grown crack), depth a = 1 along +x, half-length c = 2.5.
Within max(a, c) = 2.5 of the centre lie the whole ring of the inner wall (its normals
cancel) and the end face z = 0 (normal −z, normal to the crack plane): their mean normal
has an in-plane part below 0.2 (measured 0.127), and while the depth side and the
tangency check used the facets within max(a, c) the crack was refused "(nearly) tangent";
they now use the facets within min(a, c)/4 and the centre's own (the surface at the
centre; with the old rule this crack is refused).  References:

* the depth direction n × axis on the body's side: +x (1e-12);
* the mouth: on the cylinder r = R within the facets' sagitta, in the plane z = 1.5, its
  ends where the ellipse (y/c)² + ((x − R)/a)² = 1 meets the circle x² + y² = R²
  (ψ₁ = ±85.25° by hand; within 0.05 rad, measured 0.003°), the front's parameter range
  starting below 0 (a concave surface: the front reaches beyond the major axis) at
  sin φ₀ = (cos ψ₁ − 1) R / a (φ₀ = −1.161; within 0.005, measured 5e-4);
* the cut boundary closed, its area and enclosed volume those of the tube's facets within
  1e-7 (the vertices within 2 % of an edge of the plane are moved onto it, along the
  axis: they stay on the cylinder, its facets tilt; measured 2.3e-9 and 5.7e-9);
* meshed with the crack: the volume of the cells the cut boundary's volume (1e-10), the
  crack's two faces of equal area (1e-10) and that area the one enclosed by the ellipse's
  arc and the circle's (the front's ends at the exact φ₀, φ₁ of the cut) within 0.5 % (the
  mouth's chords; measured −0.17 %: 6.3271 against 6.3377).  Serial about 35 s.

Runs on 1, 2 and 3 ranks against the same references.
"""

from __future__ import annotations

import contextlib
import math

from mpi4py import MPI

import gmsh
import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx.io.gmsh import model_to_mesh

from bonecontact.fracture.body3d import body_surface
from bonecontact.fracture.crack3d import SurfaceBreakingCrack
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.surface_body3d import (
    crack_frame,
    cut_mouth,
    inside_body,
    mesh_body_with_surface_crack,
)
from bonecontact.meshing.session import gmsh_session

R, RO, HEIGHT, Z0 = 1.0, 4.0, 6.0, 1.5
A, C = 1.0, 2.5
H_WALL = 0.12
GROUPS = {"inner": (2, 11), "outer": (2, 12), "ends": (2, 13), "tube": (3, 1)}
CRACK = SurfaceBreakingCrack((R, 0.0, Z0), (0.0, 0.0, 1.0), A, C, (0.0, 1.0, 0.0))


def _tube() -> None:
    occ = gmsh.model.occ
    outer = occ.addCylinder(0, 0, 0, 0, 0, HEIGHT, RO)
    inner = occ.addCylinder(0, 0, 0, 0, 0, HEIGHT, R)
    (vol,), _ = occ.cut([(3, outer)], [(3, inner)])
    occ.synchronize()
    gmsh.model.addPhysicalGroup(3, [vol[1]], 1, name="tube")
    by = {"inner": [], "outer": [], "ends": []}
    for _, s in gmsh.model.getEntities(2):
        z = occ.getCenterOfMass(2, s)[2]
        r = gmsh.model.getBoundingBox(2, s)[3]  # x_max: the wall's radius
        by[
            "ends" if abs(z - 0.5 * HEIGHT) > 0.4 * HEIGHT else ("inner" if r < 2 else "outer")
        ].append(s)
    for name, ents in by.items():
        gmsh.model.addPhysicalGroup(2, ents, GROUPS[name][1], name=name)
    gmsh.model.mesh.setSize(gmsh.model.getEntities(0), 0.5)
    f = gmsh.model.mesh.field.add("MathEval")
    gmsh.model.mesh.field.setString(f, "F", f"Min({H_WALL} + 0.2*(Sqrt(x*x+y*y)-1), 0.6)")
    gmsh.model.mesh.field.setAsBackgroundMesh(f)
    for opt in ("MeshSizeFromPoints", "MeshSizeExtendFromBoundary", "MeshSizeFromCurvature"):
        gmsh.option.setNumber(f"Mesh.{opt}", 0)
    gmsh.model.mesh.generate(3)


@pytest.fixture(scope="module")
def tube():
    comm = MPI.COMM_WORLD
    with gmsh_session("tube") if comm.rank == 0 else contextlib.nullcontext():
        if comm.rank == 0:
            _tube()
        md = model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=3)
    return body_surface(md.mesh, md.cell_tags, md.facet_tags, GROUPS, "tube")


def _area_volume(x: np.ndarray) -> tuple[float, float]:
    area = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1).sum()
    vol = np.einsum("ij,ij->i", x[:, 0], np.cross(x[:, 1], x[:, 2])).sum() / 6.0
    return float(area), float(vol)


def _sagitta(body) -> float:
    """The largest sagitta of the inner wall's facets (their longest edge e: e²/8R)."""
    x = body.triangles[body.tags == GROUPS["inner"][1]]
    e = np.linalg.norm(x - np.roll(x, 1, axis=1), axis=2).max()
    return float(e * e / (8 * R))


def _mouth_angle() -> float:
    """ψ₁ where the ellipse (y/c)² + ((x − R)/a)² = 1 meets the circle x = R cos ψ,
    y = R sin ψ: (sin ψ/c)² + ((1 − cos ψ)/a)² R² = 1, a quadratic in cos ψ."""
    # (1 - w²)/c² + (1 - w)²/a² = 1/R² with w = cos ψ
    qa = 1 / A**2 - 1 / C**2
    qb = -2 / A**2
    qc = 1 / C**2 + 1 / A**2 - 1 / R**2
    w = (-qb - math.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa)
    return math.acos(w)


def test_the_facets_within_max_a_c_look_tangent(tube) -> None:
    """Why the old rule refused the crack (the inner ring cancels, the end face remains)."""
    x = tube.triangles
    near = np.min(np.linalg.norm(x - np.array(CRACK.centre), axis=2), axis=1) < max(A, C)
    m = np.cross(x[near, 1] - x[near, 0], x[near, 2] - x[near, 0]).sum(axis=0)
    m /= np.linalg.norm(m)
    inplane = math.hypot(m[0], m[1])
    print(f"in-plane part of the mean normal within max(a, c): {inplane:.3g}")
    assert inplane < 0.2


def test_grown_crack_on_the_wall_of_a_hole(tube) -> None:
    ell, placed = crack_frame(CRACK, *_nodes(tube))
    np.testing.assert_allclose(ell.rotation[1], [1.0, 0.0, 0.0], atol=1e-12)  # depth +x
    cut = cut_mouth(tube, CRACK, TipMesh(A / 8, 0.12))
    sag = _sagitta(tube)
    edges = np.sort(
        np.concatenate(
            [cut.triangles[:, [0, 1]], cut.triangles[:, [1, 2]], cut.triangles[:, [2, 0]]]
        ),
        axis=1,
    )
    assert np.all(np.unique(edges, axis=0, return_counts=True)[1] == 2)  # closed
    area0, vol0 = _area_volume(tube.triangles)
    area1, vol1 = _area_volume(cut.nodes[cut.triangles])
    print(f"area {area1 / area0 - 1:.3g}, volume {vol1 / vol0 - 1:.3g} (relative change)")
    assert area1 == pytest.approx(area0, rel=1e-7) and vol1 == pytest.approx(vol0, rel=1e-7)
    m = cut.nodes[list(cut.mouth)]
    np.testing.assert_allclose(m[:, 2], Z0, atol=1e-12)
    r = np.hypot(m[:, 0], m[:, 1])
    assert np.all(r <= R + 1e-12) and np.all(r >= R - sag)
    psi1 = _mouth_angle()
    ends = np.sort(np.arctan2(m[[0, -1], 1], m[[0, -1], 0]))
    snap = 0.05 * A  # the end's node: on the chord within 10 % of a facet (0.12 A)
    np.testing.assert_allclose(ends, [-psi1, psi1], atol=snap / R)
    p0, p1 = cut.arc.phi_range
    phi0 = math.asin((math.cos(psi1) - 1) * R / A)
    print(
        f"psi1 {math.degrees(psi1):.4g} deg, ends {np.degrees(ends)}, phi0 {phi0:.4g}, "
        f"phi range {p0:.4g} {p1:.4g}, sagitta {sag:.3g}"
    )
    print(f"phi0 - exact {p0 - phi0:.3g}, phi1 - exact {p1 - math.pi + phi0:.3g}")
    assert p0 < 0 and p0 == pytest.approx(phi0, abs=0.005)
    assert p1 == pytest.approx(math.pi - phi0, abs=0.005)
    inner = cut.arc.point(np.linspace(p0, p1, 11)[1:-1])
    assert np.all(inside_body(tube, inner))


def _nodes(body):
    """The boundary's merged nodes and triangles (for crack_frame)."""
    xyz = body.triangles.reshape(-1, 3)
    keys = np.round(xyz / (1e-9 * body.scale)).astype(np.int64)
    _, first, inv = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    return xyz[first], inv.reshape(-1, 3)


def test_the_cracked_tube_meshes(tube) -> None:
    comm = MPI.COMM_WORLD
    cb, md, cut = mesh_body_with_surface_crack(tube, CRACK, TipMesh(A / 6, 0.15), comm)
    one = fem.Constant(cb.mesh, 1.0)
    vol = comm.allreduce(fem.assemble_scalar(fem.form(one * ufl.dx)), op=MPI.SUM)
    vol0 = _area_volume(cut.nodes[cut.triangles])[1]  # the cut boundary's
    ds = ufl.Measure("ds", domain=cb.mesh, subdomain_data=md.facet_tags)
    up, lo = (
        comm.allreduce(fem.assemble_scalar(fem.form(one * ds(k))), op=MPI.SUM) for k in cb.face_tags
    )
    p0, p1 = cut.arc.phi_range
    print(f"volume {vol:.12g} (boundary {vol0:.12g}), faces {up:.10g} {lo:.10g}")
    assert vol == pytest.approx(vol0, rel=1e-10)
    assert up == pytest.approx(lo, rel=1e-10)
    # the crack's area: the ellipse's sector between the front's ends less the hole's
    # segment cut off by the mouth (by hand: the area enclosed by the front and the mouth)
    front = cut.arc.point(np.linspace(p0, p1, 4001))  # the ellipse's arc, φ₀ → φ₁
    psi1 = math.copysign(_mouth_angle(), front[-1, 1])  # the mouth: back along the circle
    psi = np.linspace(psi1, -psi1, 4001)
    x = np.concatenate([front[:, 0], R * np.cos(psi)])
    y = np.concatenate([front[:, 1], R * np.sin(psi)])
    exact = 0.5 * abs(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))
    print(f"crack area {up:.6g}, enclosed by the arcs {exact:.6g}")
    assert up == pytest.approx(exact, rel=0.005)
