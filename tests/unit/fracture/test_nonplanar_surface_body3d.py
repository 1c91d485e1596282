"""A non-planar surface-breaking crack cut into a 3D body
(bonecontact.fracture.nonplanar_surface_body3d).

The body is the plate [−1, 1] × [−1.5, 1.5] × [−1, 0] (its surface z = 0; boundary facets
0.25, refined near the crack), the crack a polygon inscribed in the half-disc of radius
R = 0.5 in the plane x = 0.1 (its arc from −π/16 to π + π/16, closed above the surface)
with strips of width w = 0.15 along its edges, each turned by θ about the previous front
(a kinked growth step: the strips' corners lie on circles in planes x = const, so every
strip is a planar trapezoid, and the strips reach out of the plate at their ends); and a
twisted strip (width and angle varying along the front by 30 %: its quadrilaterals not
planar, each two triangles).  The references are independent of the cut:

* the mouth: every node on z = 0 and on its patch's plane within its polygon (1e-9 of
  the plate's size), the ends at the crack's outermost edges' crossings with z = 0 and the
  length the sum of the patches' traces on z = 0 (both in closed form);
* the faces: each the sum of the patches clipped to z ≤ 0 (Sutherland–Hodgman; 1e-8),
  the front's nodes shared by both faces, on the front, the mouth's not (only its two
  ends); the meshed volume the plate's (1e-9), no tetrahedron flat; a coarse −60° kink
  whose faces gmsh's Crack plugin left 0.40 % short (one triangle unsplit) whole;
* θ = 0: the disc with one coplanar strip is the disc of radius R + w: the same mouth
  ends, mouth length and face areas as that single patch; the disc's mouth ends those of
  ``cut_mouth``'s semi-circular crack of radius R cos(π/16) (the chord's ends);
* under tension across the crack, the disc with a coplanar strip opens as the disc of
  radius R + W (crack-mouth opening at y = 0 and crack opening volume within 1 %,
  measured 0.10 % and 0.12 % at a tip size of 0.04; 1.4 % and 0.9 % at 0.05);
* a curved body (a gmsh cylinder of radius 1, facets 0.12, the crack's disc of radius
  0.5 in a plane normal to its axis, strips 0.06): the mouth on the patches (1e-9) and
  within 1e-6 of the body's scale of its facets (a vertex within the snap distance of a
  patch moves along the curved surface, off its facets by the move times their angle:
  measured 6e-8; 2.7e-5 with a disc of radius 0.2), the enclosed volume kept (1e-6,
  measured 1.2e-7), the faces 0 to 0.5 % smaller than the patches clipped to the exact
  cylinder (the facets' sagitta, 0.002; measured 0.20-0.24 %);
* bad input: a crack inside or outside the body, a non-planar or non-convex patch,
  disconnected patches, a front that meets the surface four times, a point 2 mm off the
  surface (the centroid of a strip's end quadrilateral fanned as advance3d does).

Every case runs on 1, 2 and 3 ranks against the same references and cell counts.
"""

from __future__ import annotations

import contextlib
import math

from mpi4py import MPI

import _box_surface
import gmsh
import numpy as np
import pytest
import ufl
from dolfinx import fem, geometry, mesh
from dolfinx.io.gmsh import model_to_mesh

from bonecontact.common.errors import ParameterError
from bonecontact.common.geometry import point_triangle_distance
from bonecontact.fracture.body3d import BodySurface, body_surface, front_vertices
from bonecontact.fracture.crack3d import SurfaceBreakingCrack
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.nonplanar_surface_body3d import (
    NonplanarSurfaceCrack,
    cut_mouth_surface,
    drop_boundary_slivers,
    mesh_body_with_nonplanar_surface_crack,
)
from bonecontact.fracture.surface_body3d import cut_mouth
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics
from bonecontact.meshing.session import gmsh_session
from bonecontact.verification.surface_crack import PLATE_MATERIAL

LO = np.array([-1.0, -1.5, -1.0])
SIZE = (2.0, 3.0, 1.0)
H = 0.25
XC, R, W, DELTA, N_ARC = 0.1, 0.5, 0.15, math.pi / 16, 9
NAMES = {1: "left", 2: "right", 3: "bottom", 4: "top", 5: "back", 6: "front"}
TOL = 1e-9 * max(SIZE)


def _plate() -> BodySurface:
    t = _box_surface.box_triangles(SIZE, H) + LO
    c = t.mean(axis=1)
    hi = LO + np.array(SIZE)
    tags = np.zeros(len(t), dtype=np.int32)
    faces = [(0, LO[0]), (0, hi[0]), (1, LO[1]), (1, hi[1]), (2, LO[2]), (2, hi[2])]
    for k, (axis, v) in enumerate(faces):
        tags[np.abs(c[:, axis] - v) < 1e-12] = k + 1
    return BodySurface(t, tags, NAMES, ("plate", 1), H * math.sqrt(2))


PLATE = _plate()


def _kinked(
    thetas_deg: list[float], radius: float = R, w: float = W, xc: float = XC
) -> NonplanarSurfaceCrack:
    """The half-disc polygon of ``radius`` and a strip of width ``w`` per angle (degrees),
    each turned by its angle about the previous front (cumulative)."""
    phi = -DELTA + np.arange(N_ARC + 1) * (math.pi + 2 * DELTA) / N_ARC
    rhat = np.stack([np.zeros_like(phi), np.cos(phi), -np.sin(phi)], axis=1)
    pts = [np.array([xc, 0.0, 0.0]) + radius * r for r in rhat]
    patches = [tuple(range(N_ARC + 1))[::-1]]
    prev, r_cur, x_cur, total = list(range(N_ARC + 1)), radius, 0.0, 0.0
    for th in thetas_deg:
        total += math.radians(th)
        r_cur, x_cur = r_cur + w * math.cos(total), x_cur + w * math.sin(total)
        new = []
        for r in rhat:
            pts.append(np.array([xc + x_cur, 0.0, 0.0]) + r_cur * r)
            new.append(len(pts) - 1)
        patches += [(prev[i], prev[i + 1], new[i + 1], new[i]) for i in range(N_ARC)]
        prev = new
    return NonplanarSurfaceCrack(tuple(map(tuple, pts)), tuple(patches))


def _strip_ends(theta_deg: float, twist: float) -> tuple[list, np.ndarray]:
    """The disc's points and a strip's outer corners: width W (1 + twist sin 3φ), turned
    by θ (1 + twist cos 2φ) about the disc's front."""
    phi = -DELTA + np.arange(N_ARC + 1) * (math.pi + 2 * DELTA) / N_ARC
    rhat = np.stack([np.zeros_like(phi), np.cos(phi), -np.sin(phi)], axis=1)
    disc = [np.array([XC, 0.0, 0.0]) + R * r for r in rhat]
    th = math.radians(theta_deg) * (1 + twist * np.cos(2 * phi))
    w = W * (1 + twist * np.sin(3 * phi))
    out = [
        p + wi * (math.cos(t) * r + math.sin(t) * np.array([1.0, 0.0, 0.0]))
        for p, r, wi, t in zip(disc, rhat, w, th, strict=True)
    ]
    return disc, np.array(out)


def _twisted(theta_deg: float, twist: float = 0.3, fan: bool = False) -> NonplanarSurfaceCrack:
    """The disc with a twisted strip (its quadrilaterals not planar): each quadrilateral
    as two triangles, or (``fan``) four to its centroid as advance3d.extend_surface does."""
    disc, outer = _strip_ends(theta_deg, twist)
    pts, n = [*disc, *outer], N_ARC + 1
    patches = [tuple(range(n))[::-1]]
    for i in range(N_ARC):
        a, b, b2, a2 = i, i + 1, n + i + 1, n + i
        if fan:
            pts.append(np.mean([pts[a], pts[b], pts[b2], pts[a2]], axis=0))
            m = len(pts) - 1
            patches += [(a, b, m), (b, b2, m), (b2, a2, m), (a2, a, m)]
        else:
            patches += [(a, b, b2), (a, b2, a2)]
    return NonplanarSurfaceCrack(tuple(map(tuple, pts)), tuple(patches))


# ------------------------------------------------------------------ references
def _area(P: np.ndarray) -> float:
    return 0.5 * float(np.linalg.norm(np.cross(P, np.roll(P, -1, axis=0)).sum(axis=0)))


def _clip_below(P: np.ndarray) -> np.ndarray:
    """The polygon clipped to z ≤ 0 (Sutherland–Hodgman)."""
    out = []
    for a, b in zip(P, np.roll(P, -1, axis=0), strict=True):
        if a[2] <= 0:
            out.append(a)
        if (a[2] <= 0) != (b[2] <= 0):
            out.append(a + a[2] / (a[2] - b[2]) * (b - a))
    return np.array(out)


def _trace(P: np.ndarray) -> np.ndarray:
    """The points where the polygon's edges cross z = 0."""
    return np.array(
        [
            a + a[2] / (a[2] - b[2]) * (b - a)
            for a, b in zip(P, np.roll(P, -1, axis=0), strict=True)
            if (a[2] > 0) != (b[2] > 0)
        ]
    ).reshape(-1, 3)


def _exact(crack: NonplanarSurfaceCrack) -> tuple[float, float, np.ndarray]:
    """The crack's area below z = 0, its trace's length on z = 0 and the front's ends
    (its unshared edges' crossings of z = 0)."""
    polys = [crack.polygon(k) for k in range(len(crack.patches))]
    area = sum(_area(_clip_below(P)) for P in polys if (P[:, 2] < 0).any())
    length = 0.0
    for P in polys:
        t = _trace(P)
        length += float(np.linalg.norm(t[1] - t[0])) if len(t) == 2 else 0.0
    X = np.asarray(crack.points)
    ends = [
        _trace(X[list(e)])[0]
        for e, ps in crack.edges().items()
        if len(ps) == 1 and (X[e[0], 2] > 0) != (X[e[1], 2] > 0)
    ]
    return area, length, np.array(sorted(ends, key=lambda p: p[1]))


def _front_reference(crack: NonplanarSurfaceCrack) -> list[np.ndarray]:
    """The front's segments: the unshared edges clipped to z ≤ 0."""
    X = np.asarray(crack.points)
    segs = []
    for e, ps in crack.edges().items():
        if len(ps) == 1 and min(X[e[0], 2], X[e[1], 2]) < 0:
            seg = _clip_below(X[list(e)])
            segs.append(seg[:2] if len(seg) >= 2 else seg)
    return segs


def _distance_to_segments(x: np.ndarray, segs: list[np.ndarray]) -> np.ndarray:
    out = np.full(len(x), np.inf)
    for a, b in segs:
        d = b - a
        t = np.clip((x - a) @ d / (d @ d), 0, 1)
        out = np.minimum(out, np.linalg.norm(x - a - t[:, None] * d, axis=1))
    return out


# ------------------------------------------------------------------ meshes
CASES = {
    "planar": ([], 0.08),
    "flat strip": ([0.0], 0.08),
    "kink +30": ([30.0], 0.08),
    "kink -30": ([-30.0], 0.08),
    "kink +60": ([60.0], 0.08),
    "kink +60 fine": ([60.0], 0.04),
    "two strips +30 -60": ([30.0, -60.0], 0.08),
    "twisted 0": ("twisted", 0.0, 0.06),
    "twisted +30": ("twisted", 30.0, 0.06),
    "twisted -45": ("twisted", -45.0, 0.06),
    "twisted +60": ("twisted", 60.0, 0.06),
}

#: the cells of every case, measured serially (the mesh is built on rank 0: the same on
#: every rank count)
CELLS = {
    "planar": 2411,
    "flat strip": 2874,
    "kink +30": 2785,
    "kink -30": 2755,
    "kink +60": 2669,
    "kink +60 fine": 5720,
    "two strips +30 -60": 3181,
    "twisted 0": 4118,
    "twisted +30": 3974,
    "twisted -45": 3913,
    "twisted +60": 3847,
}

_MESHES: dict = {}


def _meshed(name: str):
    if name not in _MESHES:
        *shape, h = CASES[name]
        crack = _twisted(shape[1]) if shape[0] == "twisted" else _kinked(shape[0])
        _MESHES[name] = (
            crack,
            *mesh_body_with_nonplanar_surface_crack(PLATE, crack, TipMesh(h, 0.3), MPI.COMM_WORLD),
        )
    return _MESHES[name]


def _face_area(cb, tag: int) -> float:
    ds = ufl.Measure("ds", domain=cb.mesh, subdomain_data=cb.facet_tags)
    local = fem.assemble_scalar(fem.form(1.0 * ds(tag)))
    return cb.mesh.comm.allreduce(local, op=MPI.SUM)


def _face_points(cb, tag: int) -> np.ndarray:
    """The coordinates of the vertices of a face's facets, gathered (with repeats)."""
    m = cb.mesh
    facets = cb.facet_tags.find(tag)
    x = m.geometry.x[mesh.entities_to_geometry(m, 2, facets)].reshape(-1, 3)
    return np.vstack(m.comm.allgather(x))


@pytest.mark.parametrize("name", list(CASES))
def test_mouth_lies_on_both_surfaces_and_has_the_exact_length(name: str) -> None:
    crack = _meshed(name)[0]
    cut = _meshed(name)[3]
    M = cut.nodes[list(cut.mouth)]
    np.testing.assert_allclose(M[:, 2], 0.0, atol=TOL)
    for i, k in enumerate(cut.mouth_patch):  # both ends of a segment on its patch
        seg = M[[i, i + 1]]
        n, P = crack.normal(k), crack.polygon(k)
        assert np.max(np.abs((seg - P[0]) @ n)) <= TOL
        assert crack.contains(k, seg, TOL).all()
    area, length, ends = _exact(crack)
    got = float(np.linalg.norm(np.diff(M, axis=0), axis=1).sum())
    assert got == pytest.approx(length, rel=1e-9)
    np.testing.assert_allclose(np.array(sorted(M[[0, -1]], key=lambda p: p[1])), ends, atol=TOL)
    np.testing.assert_allclose(cut.front()[[0, -1]], M[[0, -1]], atol=TOL)


@pytest.mark.parametrize("name", list(CASES))
def test_cut_boundary_is_closed_and_keeps_the_plate(name: str) -> None:
    cut = _meshed(name)[3]
    t = cut.triangles
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2)
    x = cut.nodes[t]
    vol = np.einsum("ij,ij->i", x[:, 0], np.cross(x[:, 1], x[:, 2])).sum() / 6.0
    assert vol == pytest.approx(math.prod(SIZE), rel=1e-12)


@pytest.mark.parametrize("name", list(CASES))
def test_faces_have_the_clipped_patches_area(name: str) -> None:
    crack, cb, _, _ = _meshed(name)
    area = _exact(crack)[0]
    up, low = (_face_area(cb, t) for t in cb.face_tags)
    assert up == pytest.approx(area, rel=1e-8)
    assert low == pytest.approx(up, rel=1e-12)


@pytest.mark.parametrize("name", list(CASES))
def test_front_is_shared_and_the_mouth_is_split(name: str) -> None:
    crack, cb, _, cut = _meshed(name)
    shared = front_vertices(cb.mesh, cb.facet_tags, cb.face_tags)
    assert len(shared) > 2 * N_ARC
    assert np.max(_distance_to_segments(shared, _front_reference(crack))) <= TOL
    on_surface = shared[np.abs(shared[:, 2]) <= TOL]
    ends = _exact(crack)[2]
    np.testing.assert_allclose(np.array(sorted(on_surface, key=lambda p: p[1])), ends, atol=TOL)
    for tag in cb.face_tags:  # every mouth node on each face (a copy each)
        pts = _face_points(cb, tag)
        mouth = cut.nodes[list(cut.mouth)]
        d = np.linalg.norm(mouth[:, None] - pts[None], axis=2).min(axis=1)
        assert np.max(d) <= TOL


@pytest.mark.parametrize("name", list(CASES))
def test_volume_is_the_plates_and_no_tetrahedron_is_flat(name: str) -> None:
    _, cb, _, _ = _meshed(name)
    m = cb.mesh
    vol = m.comm.allreduce(fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=m))), op=MPI.SUM)
    assert vol == pytest.approx(math.prod(SIZE), rel=1e-9)
    n = m.topology.index_map(3).size_local
    x = m.geometry.x[np.asarray(m.geometry.dofmaps[0])[:n]]
    six = np.einsum("ij,ij->i", np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), x[:, 3] - x[:, 0])
    h = CASES[name][-1]
    smallest = m.comm.allreduce(float(np.abs(six).min()) / 6.0, op=MPI.MIN)
    assert smallest > 1e-6 * h**3
    assert m.topology.index_map(3).size_global == CELLS[name]


def test_coarse_sixty_degree_kink_splits_every_face() -> None:
    """A −60° kink at x = −0.17 meshed coarsely (tip 0.1): gmsh's Crack plugin, siding
    the cells at a node by its mean normal, left one crack triangle unsplit there (both
    faces 0.40 % short); the split by the cells' connections keeps them whole."""
    crack = _kinked([-60.0], xc=-0.17)
    cb = mesh_body_with_nonplanar_surface_crack(PLATE, crack, TipMesh(0.1, 0.3))[0]
    area = _exact(crack)[0]
    for tag in cb.face_tags:
        assert _face_area(cb, tag) == pytest.approx(area, rel=1e-8)


def test_upper_face_lies_on_the_first_patch_normal_side() -> None:
    crack, cb, _, _ = _meshed("kink +60")
    m = cb.mesh
    m.topology.create_connectivity(2, 3)
    f2c = m.topology.connectivity(2, 3)
    n = crack.normal(0)
    facets = cb.facet_tags.find(cb.groups["crack_upper"])
    facets = facets[facets < m.topology.index_map(2).size_local]
    mid = mesh.compute_midpoints(m, 2, facets)
    on_disc = crack.contains(0, mid, 0.0) & (np.abs((mid - crack.polygon(0)[0]) @ n) < TOL)
    cells = np.array([f2c.links(f)[0] for f in facets[on_disc]], dtype=np.int32)
    side = (mesh.compute_midpoints(m, 3, cells) - mid[on_disc]) @ n
    assert np.all(side > 0)


def test_flat_strip_is_the_larger_disc() -> None:
    """θ = 0: the disc and a coplanar strip are the disc of radius R + W."""
    crack, cb, _, cut = _meshed("flat strip")
    one = _kinked([], radius=R + W)
    assert len(one.patches) == 1 and len(crack.patches) == 1 + N_ARC
    single = cut_mouth_surface(PLATE, one, TipMesh(CASES["flat strip"][1], 0.3))
    a, b = (c.nodes[list(c.mouth)] for c in (cut, single))
    np.testing.assert_allclose(a[[0, -1]], b[[0, -1]], atol=TOL)
    la, lb = (float(np.linalg.norm(np.diff(x, axis=0), axis=1).sum()) for x in (a, b))
    assert la == pytest.approx(lb, rel=1e-9)
    assert _face_area(cb, cb.face_tags[0]) == pytest.approx(_area(_clip_below(one.polygon(0))))


def test_disc_mouth_matches_the_planar_cut() -> None:
    """The disc's mouth is that of ``cut_mouth``'s semi-circle of radius R cos δ (the
    chord's ends): the same ends and length (at a tip size where ``cut_mouth`` inserts
    its ends rather than taking a node within a tenth of a segment)."""
    c, size = R * math.cos(DELTA), TipMesh(0.05, 0.3)
    ours = cut_mouth_surface(PLATE, _kinked([]), size)
    planar = cut_mouth(PLATE, SurfaceBreakingCrack((XC, 0.0, 0.0), (1.0, 0.0, 0.0), c, c), size)
    a, b = (x.nodes[list(x.mouth)] for x in (ours, planar))
    ends = [np.array(sorted(x[[0, -1]], key=lambda p: p[1])) for x in (a, b)]
    np.testing.assert_allclose(ends[0], ends[1], atol=TOL)
    np.testing.assert_allclose(ends[0], [[XC, -c, 0.0], [XC, c, 0.0]], atol=TOL)
    la, lb = (float(np.linalg.norm(np.diff(x, axis=0), axis=1).sum()) for x in (a, b))
    assert la == pytest.approx(lb, rel=1e-9) and la == pytest.approx(2 * c, rel=1e-12)


def _flat(points: list[tuple[float, float]], x: float = XC) -> tuple:
    return tuple((x, y, z) for y, z in points)


def _cylinder() -> BodySurface:
    comm = MPI.COMM_WORLD
    with gmsh_session("bar") if comm.rank == 0 else contextlib.nullcontext():
        if comm.rank == 0:
            cyl = gmsh.model.occ.addCylinder(0, 0, -2, 0, 0, 4, 1.0)
            gmsh.model.occ.synchronize()
            gmsh.model.addPhysicalGroup(3, [cyl], 1, name="bar")
            for _, s in gmsh.model.getEntities(2):
                z = gmsh.model.occ.getCenterOfMass(2, s)[2]
                tag = 11 if abs(z) < 1.0 else (12 if z < 0 else 13)
                gmsh.model.addPhysicalGroup(2, [s], tag, name=f"s{tag}")
            gmsh.option.setNumber("Mesh.MeshSizeMax", 0.12)
            gmsh.model.mesh.generate(3)
        md = model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=3)
    groups = {"s11": (2, 11), "s12": (2, 12), "s13": (2, 13), "bar": (3, 1)}
    return body_surface(md.mesh, md.cell_tags, md.facet_tags, groups, "bar")


def _on_cylinder(thetas: list[float], z: float) -> NonplanarSurfaceCrack:
    """The kinked crack (strips 0.06) turned into the plane z (its depth along −x from the
    cylinder's surface at x = 1)."""
    P = np.asarray(_kinked(thetas, R, 0.06).points) - [XC, 0.0, 0.0]
    P = P @ np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]]).T + [1.0, 0.0, z]
    return NonplanarSurfaceCrack(tuple(map(tuple, P)), _kinked(thetas, R, 0.06).patches)


def _clip_to_cylinder(P: np.ndarray, n: np.ndarray, m: int = 4096) -> np.ndarray:
    """The planar polygon clipped to x² + y² ≤ 1 (the ellipse where its plane meets the
    cylinder as an m-gon)."""
    t = np.linspace(0, 2 * np.pi, m, endpoint=False)
    E = np.stack([np.cos(t), np.sin(t), (n @ P[0] - n[0] * np.cos(t) - n[1] * np.sin(t)) / n[2]], 1)
    centre = E.mean(axis=0)
    for a, b in zip(E, np.roll(E, -1, axis=0), strict=True):
        inward = np.cross(n, b - a)
        inward = inward if inward @ (centre - a) > 0 else -inward
        out, s = [], (P - a) @ inward
        for i in range(len(P)):
            if s[i] >= 0:
                out.append(P[i])
            if (s[i] >= 0) != (s[(i + 1) % len(P)] >= 0):
                out.append(
                    P[i] + s[i] / (s[i] - s[(i + 1) % len(P)]) * (P[(i + 1) % len(P)] - P[i])
                )
        P = np.array(out).reshape(-1, 3)
        if len(P) < 3:
            break
    return P


@pytest.fixture(scope="module")
def bar() -> BodySurface:
    return _cylinder()


@pytest.mark.parametrize(
    "thetas, z", [([], 0.0), ([30.0], 0.0123), ([-60.0, 30.0], 0.0)], ids=["disc", "+30", "two"]
)
def test_curved_body(bar: BodySurface, thetas: list[float], z: float) -> None:
    crack = _on_cylinder(thetas, z)
    cb, _, cut = mesh_body_with_nonplanar_surface_crack(bar, crack, TipMesh(0.03, 0.3))
    M = cut.nodes[list(cut.mouth)]
    for i, k in enumerate(cut.mouth_patch):
        assert np.max(np.abs((M[[i, i + 1]] - crack.polygon(k)[0]) @ crack.normal(k))) <= TOL
    gap = max(float(point_triangle_distance(x, bar.triangles).min()) for x in M)
    assert gap <= 1e-6 * bar.scale
    x, x0 = cut.nodes[cut.triangles], bar.triangles
    vol, vol0 = (
        np.einsum("ij,ij->i", y[:, 0], np.cross(y[:, 1], y[:, 2])).sum() / 6 for y in (x, x0)
    )
    assert vol == pytest.approx(vol0, rel=1e-6)
    m = cb.mesh
    meshed = m.comm.allreduce(fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=m))), op=MPI.SUM)
    assert meshed == pytest.approx(vol, rel=1e-9)
    up, low = (_face_area(cb, t) for t in cb.face_tags)
    assert low == pytest.approx(up, rel=1e-12)
    polys = [
        _clip_to_cylinder(crack.polygon(k), crack.normal(k)) for k in range(len(crack.patches))
    ]
    exact = sum(_area(P) for P in polys if len(P) >= 3)
    assert -0.005 < up / exact - 1 < 0


def test_bad_input_names_the_key() -> None:
    inside = _flat([(-0.3, -0.1), (-0.3, -0.5), (0.3, -0.5), (0.3, -0.1)])
    with pytest.raises(ParameterError, match="points"):
        cut_mouth_surface(PLATE, NonplanarSurfaceCrack(inside, ((0, 1, 2, 3),)))
    outside = _flat([(-0.3, 0.1), (-0.3, 0.5), (0.3, 0.5), (0.3, 0.1)])
    with pytest.raises(ParameterError, match="points"):
        cut_mouth_surface(PLATE, NonplanarSurfaceCrack(outside, ((0, 1, 2, 3),)))
    bent = inside[:3] + ((XC + 0.1, 0.3, -0.1),)
    with pytest.raises(ParameterError, match="patches: patch 0 is not planar"):
        NonplanarSurfaceCrack(bent, ((0, 1, 2, 3),))
    dart = _flat([(-0.3, 0.2), (0.0, -0.1), (0.3, 0.2), (0.0, -0.5)])
    with pytest.raises(ParameterError, match="not a convex"):
        NonplanarSurfaceCrack(dart, ((0, 1, 2, 3),))
    apart = _flat([(-0.3, 0.2), (-0.3, -0.2), (-0.1, -0.2), (0.1, 0.2), (0.1, -0.2), (0.3, 0.2)])
    with pytest.raises(ParameterError, match="one connected surface"):
        NonplanarSurfaceCrack(apart, ((0, 1, 2), (3, 4, 5)))
    fanned = _twisted(30.0, fan=True)  # the end quadrilaterals' centroids 2 mm deep
    with pytest.raises(ParameterError, match=r"points: point 20 lies 0\.00191 m from the body"):
        cut_mouth_surface(PLATE, fanned, TipMesh(0.06, 0.3))
    valley = _flat([(-0.7, 0.2), (-0.5, 0.2), (0.0, -0.3), (0.0, -0.5), (0.5, 0.2), (0.7, 0.2)])
    crack = NonplanarSurfaceCrack(valley, ((0, 1, 2, 3), (3, 2, 4, 5)))
    with pytest.raises(ParameterError, match=r"patches: the front must meet .* twice, not 4"):
        cut_mouth_surface(PLATE, crack)


def _point_values(u: fem.Function, pts: np.ndarray) -> np.ndarray:
    """u's x-component at the points, each from the lowest rank owning a cell there."""
    msh = u.function_space.mesh
    tree = geometry.bb_tree(msh, 3)
    hits = geometry.compute_colliding_cells(msh, geometry.compute_collisions_points(tree, pts), pts)
    n_own = msh.topology.index_map(3).size_local
    local = []
    for i in range(len(pts)):
        cells = [c for c in hits.links(i) if c < n_own]
        local.append(float(u.eval(pts[i], cells[:1])[0]) if cells else None)
    found = msh.comm.allgather(local)
    return np.array([next(r[i] for r in found if r[i] is not None) for i in range(len(pts))])


def _openings(cb) -> tuple[float, float]:
    """The crack-mouth opening at y = 0 and the crack opening volume under a unit
    tension across the crack (the left face fixed near its centre)."""
    m = Mechanics(cb.mesh, PLATE_MATERIAL, cb.cell_tags, cb.facet_tags)
    facets = cb.facet_tags.find(1)
    mid = mesh.compute_midpoints(cb.mesh, 2, facets)
    patch = facets[np.linalg.norm(mid - np.array([LO[0], 0.0, -0.5]), axis=1) <= 0.4]
    for i in range(3):
        m.add_dirichlet(patch.astype(np.int32), i, 0.0)
    m.add_traction(1, (-1.0, 0.0, 0.0))
    m.add_traction(2, (1.0, 0.0, 0.0))
    integ = Integrator(m, "static", 1.0)
    integ.step()
    u = integ.u
    ds = ufl.Measure("ds", domain=cb.mesh, subdomain_data=cb.facet_tags)
    up, low = cb.face_tags
    cov = fem.assemble_scalar(fem.form(u[0] * ds(low) - u[0] * ds(up)))
    cov = abs(cb.mesh.comm.allreduce(cov, op=MPI.SUM))
    eps = 1e-7
    right, left = _point_values(u, np.array([[XC + eps, 0.0, -eps], [XC - eps, 0.0, -eps]]))
    integ.destroy()
    return right - left, cov


def test_flat_strip_opens_as_the_larger_disc() -> None:
    size = TipMesh(0.04, 0.3)
    two = mesh_body_with_nonplanar_surface_crack(PLATE, _kinked([0.0]), size)[0]
    one = mesh_body_with_nonplanar_surface_crack(PLATE, _kinked([], radius=R + W), size)[0]
    cmod, cov = _openings(two)
    cmod1, cov1 = _openings(one)
    assert cmod > 0
    assert cmod == pytest.approx(cmod1, rel=0.01)
    assert cov == pytest.approx(cov1, rel=0.01)


def _faces_volume_no_flat(cb, area: float, volume: float, h: float) -> None:
    """Both crack faces of ``area`` (1e-8; equal to 1e-12), the body's ``volume`` (1e-9)
    and no tetrahedron below 1e-6 h³."""
    up, low = (_face_area(cb, t) for t in cb.face_tags)
    assert up == pytest.approx(area, rel=1e-8)
    assert low == pytest.approx(up, rel=1e-12)
    m = cb.mesh
    vol = m.comm.allreduce(fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=m))), op=MPI.SUM)
    assert vol == pytest.approx(volume, rel=1e-9)
    n = m.topology.index_map(3).size_local
    x = m.geometry.x[np.asarray(m.geometry.dofmaps[0])[:n]]
    six = np.einsum("ij,ij->i", np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), x[:, 3] - x[:, 0])
    assert m.comm.allreduce(float(np.abs(six).min()) / 6.0, op=MPI.MIN) > 1e-6 * h**3


# --------------------------------------------- robustness: a family of configurations
@pytest.mark.parametrize("offset", [0.0, 1e-12, 1e-6, 1e-2], ids=["0", "1e-12", "1e-6h", "0.01h"])
@pytest.mark.parametrize("grid_x", [0.0, 0.125], ids=["coarse-line", "refined-line"])
@pytest.mark.parametrize("thetas", [[0.0], [30.0], [-60.0]], ids=["flat", "+30", "-60"])
def test_trace_near_facet_edges_and_vertices(thetas: list, grid_x: float, offset: float) -> None:
    """The first patch's plane at ``offset`` h from a line of facet edges (x = 0: the
    plate's; x = 0.125: the refined boundary's) and the crack shifted in y so that its
    first front end crosses z = 0 ``offset`` h from a facet vertex (y on the grid): the
    mouth on z = 0 and on the patches, its exact length, the faces the clipped patches'
    area (1e-8), the plate's volume (1e-9), no flat tetrahedron."""
    h = 0.08
    base = _kinked(thetas)
    y_end = _exact(base)[2][0][1]
    shift = [grid_x + offset * h - XC, 0.25 * round(y_end / 0.25) + offset * h - y_end, 0.0]
    crack = NonplanarSurfaceCrack(tuple(map(tuple, np.asarray(base.points) + shift)), base.patches)
    cb, _, cut = mesh_body_with_nonplanar_surface_crack(PLATE, crack, TipMesh(h, 0.3))
    area, length, ends = _exact(crack)
    M = cut.nodes[list(cut.mouth)]
    np.testing.assert_allclose(M[:, 2], 0.0, atol=TOL)
    for i, k in enumerate(cut.mouth_patch):
        assert np.max(np.abs((M[[i, i + 1]] - crack.polygon(k)[0]) @ crack.normal(k))) <= TOL
    assert float(np.linalg.norm(np.diff(M, axis=0), axis=1).sum()) == pytest.approx(length, 1e-9)
    np.testing.assert_allclose(np.array(sorted(M[[0, -1]], key=lambda p: p[1])), ends, atol=TOL)
    _faces_volume_no_flat(cb, area, math.prod(SIZE), h)


def _chord_patch(width: float, gap: float, z: float = 0.0) -> NonplanarSurfaceCrack:
    """A trapezoid in the plane z across the cylinder of radius 1 at x = 1: its inner edge
    at radius 0.6, its outer corners at radius 1 + gap, ``width`` radians apart (the outer
    edge a chord at least (1 + gap) cos(width / 2) from the axis)."""
    a = np.array([-0.5, -0.5, 0.5, 0.5]) * width
    r = np.array([1.0 + gap, 0.6, 0.6, 1.0 + gap])
    pts = np.stack([r * np.cos(a), r * np.sin(a), np.full(4, z)], axis=1)
    return NonplanarSurfaceCrack(tuple(map(tuple, pts)), ((0, 1, 2, 3),))


@pytest.mark.parametrize("width", [0.2, 0.35, 0.45, 0.6, 0.9, 1.2])
def test_outer_edge_through_the_surface_is_refused(bar: BodySurface, width: float) -> None:
    """An edge with both ends outside the cylinder that dips into it (a chord of width w
    between corners 1 + g from its axis: its nearest point (1 + g) cos(w/2), g = 0.02,
    facets' sagitta <= 0.0018) is refused naming it (``patches``); one that stays out is
    cut: its mouth on the trapezoid's plane (1e-9) and within 1e-6 of the facets."""
    gap = 0.02
    crack = _chord_patch(width, gap)
    nearest = (1 + gap) * math.cos(width / 2)
    if nearest < 1.0 - 0.002:
        with pytest.raises(ParameterError, match=r"patches: the crack edge 0-3 has both ends"):
            cut_mouth_surface(bar, crack, TipMesh(0.03, 0.3))
        return
    assert nearest > 1.0 + 0.002  # the sweep has no case within the facets' sagitta
    cut = cut_mouth_surface(bar, crack, TipMesh(0.03, 0.3))
    M = cut.nodes[list(cut.mouth)]
    np.testing.assert_allclose(M[:, 2], 0.0, atol=TOL)
    gap_m = max(float(point_triangle_distance(x, bar.triangles).min()) for x in M)
    assert gap_m <= 1e-6 * bar.scale


def _kuhn_box(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The unit cube in n³ cubes of six tetrahedra each (all about the cube's diagonal)."""
    g = np.linspace(0.0, 1.0, n + 1)
    X = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    idx = np.arange((n + 1) ** 3).reshape(n + 1, n + 1, n + 1)
    paths = [(0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)]
    tets = []
    for i, j, k in np.ndindex(n, n, n):
        for p in paths:
            c, corners = [i, j, k], [idx[i, j, k]]
            for axis in p:
                c[axis] += 1
                corners.append(idx[tuple(c)])
            tets.append(corners)
    return X, np.asarray(tets, dtype=np.int64)


def _outer_faces(X: np.ndarray, tets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The faces of one tetrahedron, outward, tagged 1…6 by the cube's face."""
    count: dict = {}
    for t in tets:
        for d in range(4):
            f = tuple(sorted(int(v) for k, v in enumerate(t) if k != d))
            count[f] = count.get(f, 0) + 1
    tris, tags = [], []
    for f, c in count.items():
        if c != 1:
            continue
        p = X[list(f)]
        axis = int(np.argmin(np.ptp(p, axis=0)))
        out = np.zeros(3)
        out[axis] = 1.0 if p[0, axis] > 0.5 else -1.0
        tris.append(list(f) if np.cross(p[1] - p[0], p[2] - p[0]) @ out > 0 else [f[0], f[2], f[1]])
        tags.append(2 * axis + (out[axis] > 0) + 1)
    return np.asarray(tris, dtype=np.int64), np.asarray(tags, dtype=np.int32)


def _with_slivers(X, tets, tris, tags, cells: list[int]):
    """Each boundary square of ``cells`` (index of its first triangle among the
    boundary's square pairs) given the other diagonal, a flat tetrahedron on its four
    corners: as gmsh returns a boundary whose diagonal is not the Delaunay one."""
    pairs = _square_pairs(X, tris, tags)
    tris, tags, tets = tris.copy(), tags.copy(), tets.copy()
    for c in cells:
        i, j = pairs[c]
        quad = list(dict.fromkeys([*tris[i], *tris[j]]))
        shared = set(tris[i]) & set(tris[j])
        a, b = sorted(set(quad) - shared)
        s, t = sorted(shared)
        out = np.cross(*(X[tris[i][1:]] - X[tris[i][0]]))
        new = []
        for tri in ([a, b, s], [a, b, t]):
            p = X[tri]
            new.append(tri if np.cross(p[1] - p[0], p[2] - p[0]) @ out > 0 else tri[::-1])
        tris[i], tris[j] = new
        tets = np.vstack([tets, [[a, b, s, t]]])
    return tets, tris, tags


def _square_pairs(X: np.ndarray, tris: np.ndarray, tags: np.ndarray) -> list[tuple[int, int]]:
    """Boundary triangles paired by their square (same tag, sharing their longest edge)."""

    def longest(tri: np.ndarray) -> list[int]:
        edges = [sorted((int(tri[k]), int(tri[(k + 1) % 3]))) for k in range(3)]
        return max(edges, key=lambda e: float(np.linalg.norm(X[e[0]] - X[e[1]])))

    out, seen = [], set()
    for i in range(len(tris)):
        for j in range(i + 1, len(tris)):
            if i in seen or j in seen or tags[i] != tags[j]:
                continue
            shared = sorted(set(tris[i]) & set(tris[j]))
            if len(shared) == 2 and longest(tris[i]) == shared:
                out.append((i, j))
                seen |= {i, j}
    return out


def _first_on(pairs: list[tuple[int, int]], tags: np.ndarray, face: int) -> int:
    return next(k for k, p in enumerate(pairs) if tags[p[0]] == face)


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("which", ["one", "one per face", "every other"])
def test_boundary_slivers_are_dropped(n: int, which: str) -> None:
    """A cube of n³ Kuhn cubes whose boundary squares (one; one on each face; every other
    one) have the other diagonal and a flat tetrahedron on their corners: dropped, the
    boundary is the cube's again (every edge of two triangles, each a face of one
    tetrahedron, outward: its enclosed volume 1 and the tetrahedra's 1, exactly; every
    face of area 1), no tetrahedron flat."""
    X, tets = _kuhn_box(n)
    tris, tags = _outer_faces(X, tets)
    pairs = _square_pairs(X, tris, tags)
    cells = {
        "one": [0],
        "one per face": [
            next(k for k, p in enumerate(pairs) if tags[p[0]] == f) for f in range(1, 7)
        ],
        "every other": list(range(0, len(pairs), 2)),
    }[which]
    t2, b2, g2 = _with_slivers(X, tets, tris, tags, cells)
    assert len(t2) == len(tets) + len(cells)
    out = drop_boundary_slivers(X, t2, b2, g2, 1.0 / n)
    assert out is not None
    t3, b3, g3 = out
    assert sorted(map(tuple, np.sort(t3, axis=1))) == sorted(map(tuple, np.sort(tets, axis=1)))
    edges = np.sort(np.concatenate([b3[:, [0, 1]], b3[:, [1, 2]], b3[:, [2, 0]]]), axis=1)
    assert np.all(np.unique(edges, axis=0, return_counts=True)[1] == 2)
    faces = {tuple(sorted(int(v) for k, v in enumerate(t) if k != d)) for t in t3 for d in range(4)}
    assert all(tuple(sorted(int(v) for v in f)) in faces for f in b3)
    x = X[b3]
    assert np.einsum("ij,ij->i", x[:, 0], np.cross(x[:, 1], x[:, 2])).sum() / 6 == pytest.approx(
        1.0, abs=1e-14
    )
    six = np.abs(
        np.einsum(
            "ij,ij->i",
            np.cross(X[t3[:, 1]] - X[t3[:, 0]], X[t3[:, 2]] - X[t3[:, 0]]),
            X[t3[:, 3]] - X[t3[:, 0]],
        )
    )
    assert six.sum() / 6 == pytest.approx(1.0, abs=1e-14)
    assert six.min() / 6 > 0.1 / n**3
    area = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
    for f in range(1, 7):
        assert area[g3 == f].sum() == pytest.approx(1.0, abs=1e-14)


@pytest.mark.parametrize("n", [1, 2])
@pytest.mark.parametrize("offset", [0.0, 1e-12])
def test_a_flat_tetrahedron_on_a_point_inside_a_triangle_is_dropped(n: int, offset: float) -> None:
    """A boundary triangle split in three at a point inside it (its centroid, ``offset``
    off its plane) with a flat tetrahedron on the four (one face inside, three on the
    boundary): dropped, the boundary the cube's again (enclosed volume 1 to 1e-12, each
    face's area 1), the point in no tetrahedron."""
    X, tets = _kuhn_box(n)
    tris, tags = _outer_faces(X, tets)
    a, b, c = tris[0]
    out = np.cross(X[b] - X[a], X[c] - X[a])
    d = len(X)
    X = np.vstack([X, X[[a, b, c]].mean(axis=0) + offset * out / np.linalg.norm(out)])
    split = np.array([[a, b, d], [b, c, d], [c, a, d]])
    b2 = np.vstack([tris[1:], split])
    g2 = np.concatenate([tags[1:], [tags[0]] * 3])
    got = drop_boundary_slivers(X, np.vstack([tets, [[a, b, c, d]]]), b2, g2, 1.0 / n)
    assert got is not None
    t3, b3, g3 = got
    assert len(t3) == len(tets) and d not in t3 and d not in b3
    x = X[b3]
    vol = np.einsum("ij,ij->i", x[:, 0], np.cross(x[:, 1], x[:, 2])).sum() / 6
    assert vol == pytest.approx(1.0, abs=1e-12)
    area = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
    for f in range(1, 7):
        assert area[g3 == f].sum() == pytest.approx(1.0, abs=1e-12)


def test_flat_tetrahedra_that_are_no_boundary_slivers_are_kept() -> None:
    """A flat tetrahedron with one boundary face, or two stacked on one square, is left
    to the other volume meshers (``None``)."""
    X, tets = _kuhn_box(2)
    tris, tags = _outer_faces(X, tets)
    t2, b2, g2 = _with_slivers(X, tets, tris, tags, [0])
    stacked = np.vstack([t2, t2[-1:]])
    assert drop_boundary_slivers(X, stacked, b2, g2, 0.5) is None
    one_face = np.vstack([tets, t2[-1:]])  # the square's diagonal not changed
    assert drop_boundary_slivers(X, one_face, tris, tags, 0.5) is None
    assert drop_boundary_slivers(X, tets, tris, tags, 0.5)[0] is tets
    on_crack = drop_boundary_slivers(X, t2, b2, g2, 0.5, crack=tris[:0])
    assert on_crack is not None  # no crack triangle among its faces
    faces = [sorted(int(v) for k, v in enumerate(t2[-1]) if k != d) for d in range(4)]
    inner = [f for f in faces if sorted(f) not in [sorted(t) for t in b2]]
    assert drop_boundary_slivers(X, t2, b2, g2, 0.5, crack=np.array(inner[:1])) is None


def _line_distance(x: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    d = (b - a) / np.linalg.norm(b - a)
    return float(np.linalg.norm(np.cross(x - a, d)))


@pytest.mark.parametrize("dphi", [0.0, 1e-4, 1e-3, 1e-2])
@pytest.mark.parametrize("eps", [1e-4, 3e-4, 1e-3])
def test_crack_end_next_to_a_surface_vertex(bar: BodySurface, eps: float, dphi: float) -> None:
    """A trapezoid (_chord_patch's, width 0.3) in the plane ``eps`` above a vertex v of the
    cylinder's facets (within the snap distance: 0.02 of the facets' 0.12 … 0.003 h), its
    first front end edge ``dphi`` radians round from v: the crossing lands next to v
    (the scanned L4's 16th mesh: a front end 0.003 h from a vertex snapped 0.003 h, the
    mouth ran past the end and back).  The mouth is one chain from one front end to the
    other, on the plane (1e-9), within 1e-6 of the scale of the facets, its ends on the
    front end edges (1e-9)."""
    V = np.unique(bar.triangles.reshape(-1, 3), axis=0)
    on_side = (np.abs(V[:, 2]) < 0.3) & (np.abs(np.hypot(V[:, 0], V[:, 1]) - 1) < 1e-9)
    v = V[on_side][np.argmin(np.abs(np.arctan2(V[on_side, 1], V[on_side, 0])))]
    base = np.asarray(_chord_patch(0.3, 0.02).points)
    turn = math.atan2(v[1], v[0]) + dphi + 0.15
    rot = np.array([[math.cos(turn), -math.sin(turn), 0], [math.sin(turn), math.cos(turn), 0]])
    pts = np.column_stack([base @ rot.T, np.full(4, v[2] + eps)])
    crack = NonplanarSurfaceCrack(tuple(map(tuple, pts)), ((0, 1, 2, 3),))
    cut = cut_mouth_surface(bar, crack, TipMesh(0.03, 0.3))
    M = cut.nodes[list(cut.mouth)]
    np.testing.assert_allclose(M[:, 2], v[2] + eps, atol=TOL)
    assert (
        max(float(point_triangle_distance(x, bar.triangles).min()) for x in M) <= 1e-6 * bar.scale
    )
    ends = sorted([M[0], M[-1]], key=lambda x: math.atan2(x[1], x[0]))
    assert _line_distance(ends[0], pts[0], pts[1]) <= TOL
    assert _line_distance(ends[1], pts[2], pts[3]) <= TOL


# ------------------- narrow, nearly coplanar strips: a snap must not cross the next plane
BOX_LO, BOX_SIZE, BOX_H = np.array([-1.0, -1.0, -1.0]), (2.0, 2.0, 1.0), 0.25


def _split_top_at(tris: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The top-face triangle (z = 0) that contains ``p`` (x, y) split in three at it."""
    for i, t in enumerate(tris):
        if np.all(np.abs(t[:, 2]) < 1e-12):
            lam = np.linalg.solve(np.vstack([t[:, :2].T, np.ones(3)]), [p[0], p[1], 1.0])
            if lam.min() > 1e-12:
                q = np.array([p[0], p[1], 0.0])
                new = np.array([[t[0], t[1], q], [t[1], t[2], q], [t[2], t[0], q]])
                return np.concatenate([np.delete(tris, i, axis=0), new])
    raise AssertionError(f"no top triangle holds {p}")


def _strips_over_a_thin_triangle(tilt: float, side: float, gap: float):
    """The box [−1, 1]² × [−1, 0] (facets 0.25) and three strips (patches 0, 1, 2, cut in
    that order) whose traces on z = 0 run along y, each 0.19 long, through c0 … c3: c1 =
    (0.05, −0.04), c2 = (0.05, 0.15) (trace 1 on x = 0.05), traces 0 and 2 turned by ∓0.6°
    so that trace 0, extended, passes ``gap`` beyond x = 0.05 (on the ``side`` opposite to
    v) at the height of a facet vertex v = (0.05 + 0.002 side, 0.14) over strip 1; the
    kink c2 lies in the thin facet (v, w1, w2), w1 and w2 beyond x = 0.05 (barycentric
    0.75, 0.125, 0.125: inserted by a split in three).  The strips' planes contain the
    direction (side · tilt, 0, 1), reach 0.1 above the surface and 0.3 below it.
    Returns the body, the crack and v."""
    e, r, L, X, y2 = 0.002, 0.01, 0.19, 0.05, 0.15
    v = np.array([X + side * e, y2 - r])
    wm = np.array([X - 3 * side * e, y2 + 3 * r])
    w1, w2 = wm - [2 * side * e, 2 * r], wm + [2 * side * e, 2 * r]
    c1, c2 = np.array([X, y2 - L]), np.array([X, y2])
    slope = -side * gap / (v[1] - c1[1])
    c0, c3 = c1 - L * np.array([slope, 1.0]), c2 + L * np.array([-slope, 1.0])
    tris = _box_surface.box_triangles(BOX_SIZE, BOX_H) + BOX_LO
    for p in (w2, v, w1):
        tris = _split_top_at(tris, p)
    c = tris.mean(axis=1)
    hi = BOX_LO + np.array(BOX_SIZE)
    tags = np.zeros(len(tris), dtype=np.int32)
    for k, (axis, val) in enumerate(
        [(0, BOX_LO[0]), (0, hi[0]), (1, BOX_LO[1]), (1, hi[1]), (2, BOX_LO[2]), (2, hi[2])]
    ):
        tags[np.abs(c[:, axis] - val) < 1e-12] = k + 1
    body = BodySurface(tris, tags, NAMES, ("box", 1), BOX_H * math.sqrt(2))
    thin = {tuple(p) for p in (v, w1, w2)}
    assert any({tuple(x[:2]) for x in t} == thin for t in tris)  # the facet (v, w1, w2)
    d = np.array([side * tilt, 0.0, 1.0])
    top = [np.array([p[0], p[1], 0.0]) for p in (c0, c1, c2, c3)]
    pts = [p + 0.1 * d for p in top] + [p - 0.3 * d for p in top]
    crack = NonplanarSurfaceCrack(
        tuple(map(tuple, pts)), tuple((i, 4 + i, 5 + i, i + 1) for i in range(3))
    )
    return body, crack, np.array([v[0], v[1], 0.0])


@pytest.mark.parametrize("gap", [0.001, 0.002, 0.004])
@pytest.mark.parametrize("side", [1.0, -1.0], ids=["v+x", "v-x"])
@pytest.mark.parametrize("tilt", [0.0, 0.4])
def test_snap_onto_one_strip_keeps_a_vertex_on_its_side_of_the_next(
    tilt: float, side: float, gap: float
) -> None:
    """Strips narrower than twice the facets, 0.6° apart (the scanned L4's 15th mesh:
    strips 0.8 h wide at the surface, 0.12° apart): v, over strip 1 and 0.002 from its
    plane, lies 0.002 + ``gap`` from strip 0's plane, within the snap distance (0.02 of
    the mean facet edge 0.248, 0.005) for gaps 0.001 and 0.002.  Snapped onto strip 0's
    plane (the cut of strip 0 moves the vertices within 2 h of it), v crossed strip 1's
    plane: the kink c2 then had all its neighbours v, w1, w2 on one side, strip 1's trace
    passed it by ("the trace of patch 1 ... ends inside a facet"; gap 0.004: no snap,
    no failure; all 8 cases with gaps 0.001 and 0.002 failed so on the old code).  Now v
    keeps its side; either rule alone mends the 8 (v cannot cross the trace through c2
    without turning the facet (v, w2, c2) over).  With the side rule alone, tilt 0, v+x,
    gaps 0.001 and 0.002: w2, over strip 2 and 0.002 from strip 1's plane, snapped onto
    it, landed on the line through (0, 0) and w1: its thin facet flat (HXT: "two exactly
    self-intersecting facets"); a snap now keeps every facet at its vertex ≥ 0.1 of its
    area.  The mouth on z = 0 and on its patches (1e-9), its exact length, ends and
    kinks, the faces the strips clipped to z ≤ 0 (1e-8), the box's volume (1e-9), no
    flat tetrahedron."""
    body, crack, v = _strips_over_a_thin_triangle(tilt, side, gap)
    h = 0.18
    cb, _, cut = mesh_body_with_nonplanar_surface_crack(body, crack, TipMesh(h, 0.3))
    n1, p1 = crack.normal(1), crack.polygon(1)[0]
    nearest = cut.nodes[np.argmin(np.linalg.norm(cut.nodes - v, axis=1))]
    assert np.linalg.norm(nearest - v) < 1e-3 or (nearest - p1) @ n1 * ((v - p1) @ n1) > 0
    M = cut.nodes[list(cut.mouth)]
    np.testing.assert_allclose(M[:, 2], 0.0, atol=TOL)
    for i, k in enumerate(cut.mouth_patch):
        seg = M[[i, i + 1]]
        assert np.max(np.abs((seg - crack.polygon(k)[0]) @ crack.normal(k))) <= TOL
        assert crack.contains(k, seg, TOL).all()
    area, length, ends = _exact(crack)
    assert float(np.linalg.norm(np.diff(M, axis=0), axis=1).sum()) == pytest.approx(length, 1e-9)
    np.testing.assert_allclose(np.array(sorted(M[[0, -1]], key=lambda p: p[1])), ends, atol=TOL)
    kinks = np.asarray(crack.points)[[1, 2]] - 0.1 * np.array([side * tilt, 0.0, 1.0])
    assert np.linalg.norm(M[:, None] - kinks[None], axis=2).min(axis=0).max() <= TOL
    _faces_volume_no_flat(cb, area, math.prod(BOX_SIZE), h)


# ------------------------------------------- a corner crack: the mouth over two faces
def _corner_patch(y0: float, tilt_deg: float) -> NonplanarSurfaceCrack:
    """A quarter-disc polygon of radius R about the plate's edge x = −1, z = 0 (at y0) in
    the plane through it tilted by ``tilt_deg`` about x (normal (0, cos, sin)): 9 points
    from −π/16 to π/2 + π/16 (beyond the faces z = 0 and x = −1), closed around the
    corner by the edge's point moved 0.1 out of both faces (as the runner's start patch)."""
    t = math.radians(tilt_deg)
    u, d = np.array([1.0, 0.0, 0.0]), np.array([0.0, math.sin(t), -math.cos(t)])
    C = np.array([-1.0, y0, 0.0])
    psi = -DELTA + np.arange(N_ARC) * (0.5 * math.pi + 2 * DELTA) / (N_ARC - 1)
    arc = C + R * (np.cos(psi)[:, None] * u + np.sin(psi)[:, None] * d)
    P = np.vstack([arc, C - 0.1 * (u + d)])
    return NonplanarSurfaceCrack(tuple(map(tuple, P)), (tuple(range(len(P))),))


def _clip(P: np.ndarray, axis: int, v: float, sign: float) -> np.ndarray:
    """The polygon clipped to sign·(x[axis] − v) ≤ 0 (Sutherland–Hodgman)."""
    out = []
    for a, b in zip(P, np.roll(P, -1, axis=0), strict=True):
        fa, fb = sign * (a[axis] - v), sign * (b[axis] - v)
        if fa <= 0:
            out.append(a)
        if (fa <= 0) != (fb <= 0):
            out.append(a + fa / (fa - fb) * (b - a))
    return np.array(out)


@pytest.mark.parametrize("tilt", [0.0, 25.0])
@pytest.mark.parametrize(
    "y0", [0.0, 1e-12, 8e-8, 8e-4, 0.1], ids=["on-node", "1e-12", "1e-6h", "0.01h", "between"]
)
def test_corner_crack_mouth_runs_over_two_faces(y0: float, tilt: float) -> None:
    """The mouth of a corner patch (its plane ``y0`` from a node of the plate's edge; h =
    0.08): every node on the face z = 0 or x = −1 and on the patch's plane (1e-9), through
    the edge's point (at 1e-12 of a node it failed before edge vertices snapped along the
    edge: "the crack surface lost a mouth node"), its length the clipped polygon's edges
    on the two faces (closed form, 1e-9), its ends on the two faces; the faces the patch
    clipped to x ≥ −1, z ≤ 0 (1e-8), the plate's volume, no flat tetrahedron."""
    h = 0.08
    crack = _corner_patch(y0, tilt)
    cb, _, cut = mesh_body_with_nonplanar_surface_crack(PLATE, crack, TipMesh(h, 0.3))
    M = cut.nodes[list(cut.mouth)]
    P = crack.polygon(0)
    assert np.max(np.abs((M - P[0]) @ crack.normal(0))) <= TOL
    assert np.all(np.minimum(np.abs(M[:, 0] + 1.0), np.abs(M[:, 2])) <= TOL)
    edge = np.array([-1.0, y0, 0.0])
    assert np.linalg.norm(M - edge, axis=1).min() <= TOL
    ends = M[[0, -1]]
    assert {int(np.abs(e[2]) <= TOL) for e in ends} == {0, 1}  # one end on each face
    Q = _clip(_clip(P, 2, 0.0, 1.0), 0, -1.0, -1.0)
    on_face = np.minimum(np.abs(Q[:, 2]), np.abs(Q[:, 0] + 1.0)) <= TOL
    on = [
        float(np.linalg.norm(b - a))
        for a, b, fa, fb in zip(Q, np.roll(Q, -1, axis=0), on_face, np.roll(on_face, -1))
        if fa and fb and (abs(a[2] - b[2]) <= TOL or abs(a[0] - b[0]) <= TOL)
    ]
    got = float(np.linalg.norm(np.diff(M, axis=0), axis=1).sum())
    assert got == pytest.approx(sum(on), rel=1e-9)
    _faces_volume_no_flat(cb, _area(Q), math.prod(SIZE), h)
