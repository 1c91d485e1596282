"""The mixed-mode advance of an open front (bonecontact.fracture.open_front3d), against
closed forms and against the closed front's advance:

* a straight front under uniform K: pure mode I translates it by Δa_max along e₁ and
  adds strips of area Δa_max·L, straight behind (ψ = ±π); pure mode II turns every
  vertex by the MTS angle −70.53° (the strip's normal the frame turned by φ₀, the kink
  ψ = π − φ₀ from the closed form of the rotated frame), mode I + II at 0/30/60° of mixity
  by the σ₁′ angle; for a family of front lengths, vertex counts and orientations;
* the inner vertices of an open chain cut out of a closed polygon advance as the closed
  front's (advance3d.advance_mixed_front, not smoothed) to 1e-14, and a held end keeps
  its point exactly with its edge's one triangle;
* the ends average over two vertices (a linear K along a straight front: the ends'
  Δa the closed form of the two-point mean);
* K at the edges' middles (open_mid_edge_modes) on the through crack of a plate
  (bonecontact.verification.surface_crack), its straight front one edge or two: the
  straight front's K at the same points and domains (1e-9 of K_I), K_I at mid-thickness
  within 5 % of the plane-strain K of the 2D section (1, 2 and 3 ranks);
* the front of a non-planar crack cut into a plate (cut_front; the half-disc polygon and
  one strip turned by 0, +30, −45°): its ends the mouth's, every segment on the crack's
  outermost edges, e₂ its patch's normal (the side of the first patch's), e₁ = t × e₂
  pointing away from the patch;
* bad shapes are refused with the key named.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import dataclasses
import math

import _box_surface
import numpy as np
import pytest

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.advance3d import advance_mixed_front
from bonecontact.fracture.body3d import BodySurface
from bonecontact.fracture.front3d import front_interaction_integral
from bonecontact.fracture.nonplanar_surface_body3d import NonplanarSurfaceCrack, cut_mouth_surface
from bonecontact.fracture.open_front3d import (
    OpenTriangulatedCrack,
    advance_open_front,
    cut_front,
    extend_open_surface,
    open_mid_edge_modes,
    vertex_k,
)
from bonecontact.fracture.surface3d import SurfaceCrack
from bonecontact.verification.surface_crack import PlateProblem, plane_strain_edge_k, solve_plate

MTS_MODE_II = -2.0 * math.atan(1.0 / math.sqrt(2.0))  # −70.53°, the MTS angle of pure mode II


def _straight(n: int, length: float, yaw: float) -> OpenTriangulatedCrack:
    """A straight front of ``n`` vertices from the surface z = 0 down to z = −length, the
    crack plane's normal e₂ = (−sin yaw, cos yaw, 0), the crack behind the front a
    rectangle 0.5 wide (one patch), e₁ = t × e₂ ahead."""
    t = np.array([0.0, 0.0, -1.0])
    e2 = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
    e1 = np.cross(t, e2)
    V = np.array([k * length / (n - 1) * t for k in range(n)])
    back = V - 0.5 * e1
    P = np.concatenate([V, back[[0, -1]]])
    patch = (n + 1, n, *range(n))  # back corners then the front (orientation fixed below)
    ring = P[list(patch)]
    area_n = np.cross(ring[1] - ring[0], ring[2] - ring[0])
    if area_n @ e2 < 0:
        patch = patch[::-1]
    return OpenTriangulatedCrack(
        tuple(map(tuple, P)),
        (tuple(int(i) for i in patch),),
        tuple(range(n)),
        tuple(tuple(e2) for _ in range(n - 1)),
        None,
        tuple(e2),
    )


def _frame(crack: OpenTriangulatedCrack) -> tuple[np.ndarray, np.ndarray]:
    V = crack.vertices
    t = (V[1] - V[0]) / np.linalg.norm(V[1] - V[0])
    e2 = np.asarray(crack.normals2[0])
    return np.cross(t, e2), e2


def _patch_area(P: np.ndarray, patch: tuple[int, ...]) -> float:
    ring = P[list(patch)]
    s = sum(np.cross(ring[i], ring[(i + 1) % len(ring)]) for i in range(len(ring)))
    return 0.5 * float(np.linalg.norm(s))


@pytest.mark.parametrize("n", [2, 5])
@pytest.mark.parametrize("yaw_deg", [0.0, 35.0])
@pytest.mark.parametrize("mixity_deg", [0.0, 30.0, 60.0, 90.0])
def test_straight_front_uniform_k(n: int, yaw_deg: float, mixity_deg: float) -> None:
    crack = _straight(n, 0.8, math.radians(yaw_deg))
    e1, e2 = _frame(crack)
    m = math.radians(mixity_deg)
    K = np.tile([math.cos(m), math.sin(m), 0.0], (n - 1, 1))
    da = 0.1
    adv = advance_open_front(crack.vertices, crack.normals2, K, da)
    k1, k2 = math.cos(m), math.sin(m)
    # MTS (σ₁′ with K_III = 0) in closed form: tan(φ₀/2) = (K_I − √(K_I² + 8K_II²))/(4K_II)
    phi0 = 0.0 if k2 == 0 else 2 * math.atan((k1 - math.sqrt(k1**2 + 8 * k2**2)) / (4 * k2))
    if mixity_deg == 90.0:
        assert phi0 == pytest.approx(MTS_MODE_II, abs=1e-12)
    np.testing.assert_allclose(adv.kink, phi0, atol=1e-5)  # σ₁′: 0.05° grid, parabola
    np.testing.assert_allclose(adv.da, da, rtol=1e-14)
    d = math.cos(phi0) * e1 + math.sin(phi0) * e2
    np.testing.assert_allclose(adv.vertices, crack.vertices + da * d, atol=1e-6 * da)
    grown = extend_open_surface(crack, adv.vertices, adv.held)
    P = np.asarray(grown.points)
    # the strips cover the rectangle between the fronts: area Δa × length
    strips = sum(_patch_area(P, p) for p in grown.patches[1:])
    assert strips == pytest.approx(da * 0.8, rel=1e-5)
    # every strip triangle faces the side of the old e₂ turned by φ₀
    n_new = -math.sin(phi0) * e1 + math.cos(phi0) * e2
    for k in range(n - 1):
        np.testing.assert_allclose(grown.normals2[k], n_new, atol=1e-5)
        L, psi = grown.cuts[k]
        assert L == pytest.approx(da, rel=1e-5)
        assert math.cos(psi) == pytest.approx(-math.cos(phi0), abs=1e-5)
        assert math.sin(psi) == pytest.approx(math.sin(phi0), abs=1e-5)
    assert grown.front().perimeter == pytest.approx(0.8, rel=1e-6)


def _closed_polygon(N: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A regular N-gon of radius 1 in z = 0 (counter-clockwise about +z), its edges'
    e₂ tilted differently and K of every mode varying from edge to edge."""
    a = 2 * math.pi * np.arange(N) / N
    V = np.column_stack([np.cos(a), np.sin(a), np.zeros(N)])
    tilt = 0.2 * np.sin(3 * a)
    d = np.roll(V, -1, axis=0) - V
    t = d / np.linalg.norm(d, axis=1)[:, None]
    out = np.cross(t, [0, 0, 1])
    n2 = np.cos(tilt)[:, None] * np.array([0, 0, 1.0]) - np.sin(tilt)[:, None] * out
    K = np.column_stack([1 + 0.3 * np.cos(a), 0.4 * np.sin(2 * a), 0.2 * np.cos(a)])
    return V, n2, K


@pytest.mark.parametrize("start", [0, 3])
def test_inner_vertices_advance_as_the_closed_front(start: int) -> None:
    V, n2, K = _closed_polygon(12)
    closed = advance_mixed_front(V, n2, K, 0.05, smooth=False)
    idx = np.arange(start, start + 7) % 12  # an open chain of 7 vertices, 6 edges
    opened = advance_open_front(V[idx], n2[idx[:-1]], K[idx[:-1]], 0.05, smooth=False)
    # the weights are relative to the chain's own largest K_V: compare the directions and
    # the relative advances of the inner vertices
    np.testing.assert_allclose(opened.directions[1:-1], closed.directions[idx[1:-1]], atol=1e-14)
    np.testing.assert_allclose(opened.kink[1:-1], closed.kink[idx[1:-1]], atol=1e-14)
    np.testing.assert_allclose(opened.k_v[1:-1], closed.k_v[idx[1:-1]], rtol=1e-14)
    # an end vertex takes its one edge's K and frame
    kv_end = opened.k_v[0]
    k = K[idx[0]]
    assert kv_end == pytest.approx(
        0.5 * k[0] + 0.5 * math.sqrt(k[0] ** 2 + 5.336 * k[1] ** 2 + 4 * k[2] ** 2), rel=1e-14
    )
    t = (V[idx[1]] - V[idx[0]]) / np.linalg.norm(V[idx[1]] - V[idx[0]])
    e1 = np.cross(t, n2[idx[0]])
    phi0 = opened.kink[0]
    np.testing.assert_allclose(
        opened.directions[0], math.cos(phi0) * e1 + math.sin(phi0) * n2[idx[0]], atol=1e-14
    )


def test_ends_average_over_two_vertices() -> None:
    """K_I rising linearly along a straight front of 5 vertices, pure mode I, n = 2:
    Δa_i ∝ K_V,i² before the average; the ends' mean over themselves and one neighbour,
    the inner vertices' over three."""
    crack = _straight(5, 1.0, 0.0)
    k_edge = np.array([1.0, 1.5, 2.0, 2.5])
    K = np.column_stack([k_edge, 0 * k_edge, 0 * k_edge])
    adv = advance_open_front(crack.vertices, crack.normals2, K, 0.1)
    kv = np.array([1.0, 1.25, 1.75, 2.25, 2.5])
    w = 0.1 * (kv / kv.max()) ** 2
    expect = [
        (w[0] + w[1]) / 2,
        *((w[i - 1] + w[i] + w[i + 1]) / 3 for i in (1, 2, 3)),
        (w[3] + w[4]) / 2,
    ]
    np.testing.assert_allclose(adv.da, expect, rtol=1e-14)
    np.testing.assert_allclose(vertex_k(K), kv, rtol=1e-15)
    np.testing.assert_array_equal(vertex_k(K), adv.k_v)


@pytest.mark.parametrize("mixity_deg", [0.0, 30.0, 90.0])
def test_vertex_k_is_the_equivalent_k_of_the_mean(mixity_deg: float) -> None:
    """K_V at the vertices: at an inner vertex the σ₁′ equivalent K of its two edges' mean
    K, at an end its edge's; a uniform K gives the edges' own K_V everywhere (pure mode I:
    K_I; pure mode II: the equivalent K of K_II alone)."""
    m = math.radians(mixity_deg)
    K = np.tile([math.cos(m), math.sin(m), 0.3 * math.sin(m)], (4, 1))
    one = vertex_k(K[:1])
    np.testing.assert_allclose(vertex_k(K), np.full(5, one[0]), rtol=1e-15)
    if mixity_deg == 0.0:
        assert one[0] == pytest.approx(1.0, rel=1e-15)
    K2 = K * np.array([1.0, 2.0, 3.0, 4.0])[:, None]
    np.testing.assert_allclose(
        vertex_k(K2), np.array([1.0, 1.5, 2.5, 3.5, 4.0]) * one[0], rtol=1e-14
    )


def test_held_end_keeps_its_point() -> None:
    crack = _straight(4, 0.6, 0.0)
    K = np.tile([1.0, 0.2, 0.0], (3, 1))
    adv = advance_open_front(crack.vertices, crack.normals2, K, 0.1, weights=[0.0, 1.0, 1.0, 0.5])
    assert adv.held.tolist() == [True, False, False, False]
    np.testing.assert_array_equal(adv.vertices[0], crack.vertices[0])
    # Δa of the growing vertices averaged over their growing neighbours only
    np.testing.assert_allclose(adv.da, [0.0, 0.1, (0.1 + 0.1 + 0.05) / 3, 0.075], rtol=1e-14)
    grown = extend_open_surface(crack, adv.vertices, adv.held)
    assert grown.front_ids[0] == crack.front_ids[0]  # the same point, no new one
    # edge 0 (one end held): one triangle; edges 1, 2: two each
    assert len(grown.patches) == 1 + 1 + 2 + 2
    P = np.asarray(grown.points)
    tri = grown.patches[1]
    assert set(tri) == {crack.front_ids[0], crack.front_ids[1], grown.front_ids[1]}
    assert _patch_area(P, tri) > 0


def test_bad_input_is_refused() -> None:
    crack = _straight(3, 0.5, 0.0)
    with pytest.raises(ParameterError, match="k_edges"):
        advance_open_front(crack.vertices, crack.normals2, np.ones((3, 3)), 0.1)
    with pytest.raises(ParameterError, match="k_edges"):
        advance_open_front(crack.vertices, crack.normals2, -np.ones((2, 3)) * [1, 0, 0], 0.1)
    with pytest.raises(ParameterError, match="new_vertices"):
        extend_open_surface(crack, np.zeros((2, 3)))
    with pytest.raises(ParameterError, match="vertices"):
        advance_open_front(crack.vertices[:1], crack.normals2[:0], np.ones((0, 3)), 0.1)


#: The through crack of the surface-crack verification: an edge crack of length 0.4
#: through the thickness 1, front 0.05.
THROUGH = PlateProblem(
    SurfaceCrack("through", 0.4), b=2.0, h=2.0, t=1.0, h_front=0.05, grading=0.15, h_max=0.4
)
_SOLVED: dict = {}


@pytest.mark.parametrize("edges", [1, 2])
def test_mid_edge_k_on_a_through_crack(edges: int) -> None:
    if "through" not in _SOLVED:
        _SOLVED["through"] = solve_plate(THROUGH)
    sol = _SOLVED["through"]
    straight = sol.block.front
    V = straight.point(np.linspace(0.0, 1.0, edges + 1))
    n = tuple(map(float, straight.normal))
    back = V - 0.4 * np.asarray(straight.frame(0.5)[0])
    P = np.concatenate([V, back[[0, -1]]])
    crack = OpenTriangulatedCrack(
        tuple(map(tuple, P)), (), tuple(range(edges + 1)), (n,) * edges, None, n
    )
    h = THROUGH.h_front
    front = crack.front()
    block = dataclasses.replace(sol.block, front=front)
    got = open_mid_edge_modes(front, block, sol.u, THROUGH.material, h)
    length = min(4 * h, 0.5 / edges - h)
    for k, r in enumerate(got):
        z = (k + 0.5) / edges
        ref = front_interaction_integral(sol.u, sol.block, z, THROUGH.material, 4 * h, None, length)
        np.testing.assert_allclose(r.point, ref.point, atol=1e-12)
        for key in ("K_I", "K_II", "K_III"):
            assert getattr(r, key) == pytest.approx(getattr(ref, key), abs=1e-9 * ref.K_I)
    if edges == 1:
        assert got[0].K_I == pytest.approx(plane_strain_edge_k(THROUGH), rel=0.05)


def _plate() -> BodySurface:
    """The plate [−1, 1] × [−1.5, 1.5] × [−1, 0], facets 0.25, its surface z = 0."""
    lo, size = np.array([-1.0, -1.5, -1.0]), (2.0, 3.0, 1.0)
    t = _box_surface.box_triangles(size, 0.25) + lo
    return BodySurface(t, np.ones(len(t), dtype=np.int32), {1: "all"}, ("plate", 1), 0.36)


def _kinked(theta: float | None) -> NonplanarSurfaceCrack:
    """A half-disc polygon of radius 0.5 in x = 0.1 (7 edges from −π/16 to π + π/16, its
    ends above z = 0), with one strip 0.15 wide turned by ``theta`` (rad) about its
    edges, or none."""
    phi = -math.pi / 16 + np.arange(8) * (math.pi + math.pi / 8) / 7
    r = np.stack([np.zeros_like(phi), np.cos(phi), -np.sin(phi)], axis=1)
    pts = [np.array([0.1, 0, 0]) + 0.5 * v for v in r]
    patches = [tuple(range(8))[::-1]]
    if theta is not None:
        off = np.array([0.1 + 0.15 * math.sin(theta), 0, 0])
        pts += [off + (0.5 + 0.15 * math.cos(theta)) * v for v in r]
        patches += [(i, i + 1, 9 + i, 8 + i) for i in range(7)]
    return NonplanarSurfaceCrack(tuple(map(tuple, pts)), tuple(patches))


@pytest.mark.parametrize("theta_deg", [None, 0.0, 30.0, -45.0])
def test_front_of_a_cut_crack(theta_deg: float | None) -> None:
    crack = _kinked(None if theta_deg is None else math.radians(theta_deg))
    cut = cut_mouth_surface(_plate(), crack)
    front = cut_front(cut)
    V = np.asarray(front.vertices)
    ends = {tuple(np.round(cut.nodes[k], 12)) for k in (cut.mouth[0], cut.mouth[-1])}
    assert {tuple(np.round(V[0], 12)), tuple(np.round(V[-1], 12))} == ends
    assert np.all(np.abs(V[[0, -1], 2]) < 1e-12)  # on the surface z = 0
    assert np.all(V[1:-1, 2] < 0)
    last = len(crack.patches) > 1
    for p in front.edge_middles():
        e1, e2, _ = front.frame(float(p))
        x = front.point(float(p))[0]
        patch = 0  # the disc, or the strip whose centroid is nearest
        if last:
            centroids = [crack.polygon(j).mean(axis=0) for j in range(1, 8)]
            patch = 1 + int(np.argmin(np.linalg.norm(np.array(centroids) - x, axis=1)))
        n = crack.normal(patch)
        assert abs((x - crack.polygon(patch)[0]) @ n) < 1e-9  # the point on its patch
        np.testing.assert_allclose(e2, crack.normal(patch), atol=1e-12)
        assert e2 @ crack.normal(0) > 0
        assert (crack.polygon(patch).mean(axis=0) - x) @ e1 < 0  # the patch lies behind
        if theta_deg is not None:  # e₁ across the trapezoid: its height's direction
            th, half = math.radians(theta_deg), 0.5 * (math.pi + math.pi / 8) / 7
            ex = math.sin(th) / math.hypot(math.sin(th), math.cos(th) * math.cos(half))
            assert e1[0] == pytest.approx(ex, abs=1e-9)
