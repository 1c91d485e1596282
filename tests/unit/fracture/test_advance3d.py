"""The planar front advance rule (bonecontact.fracture.advance3d)."""

import math

import numpy as np
import pytest

from bonecontact.fracture.advance3d import advance_polygon_front, vertex_directions
from bonecontact.fracture.crack import FractureError

N = np.array([0.0, 0.0, 1.0])


def square(a: float = 1.0) -> np.ndarray:
    return np.array([[a, -a, 0], [a, a, 0], [-a, a, 0], [-a, -a, 0]], dtype=float)


@pytest.mark.parametrize("n", [4, 8, 13])
def test_uniform_k_scales_a_regular_polygon(n):
    """Equal K everywhere: a regular polygon grows into the regular polygon of circumradius
    a + Δa (the vertices move radially by Δa)."""
    t = 2 * math.pi * np.arange(n) / n
    V = np.column_stack([np.cos(t), np.sin(t), 0 * t])
    new, da = advance_polygon_front(V, N, np.full(n, 2.0), 0.1)
    np.testing.assert_allclose(da, 0.1, rtol=1e-14)
    # the advanced vertices lie on the grid 2^(⌊log₂ 0.1⌋ − 20) = 6.0e-8 (advance3d.on_grid)
    np.testing.assert_allclose(np.linalg.norm(new, axis=1), 1.1, rtol=0, atol=5e-8)
    np.testing.assert_array_equal(new, np.round(new / 2.0**-24) * 2.0**-24)
    np.testing.assert_allclose(vertex_directions(V, N), V, atol=1e-12)


def test_advance_scales_with_k_power_and_holds_below_toughness():
    """Δa_i = Δa_max (K_i/K_max)^n with K_i the mean of the two edges at vertex i; vertices
    below K_Ic hold."""
    V = square()
    k = np.array([1.0, 2.0, 2.0, 1.0])  # edges 0..3 (vertex k → k + 1)
    _, da = advance_polygon_front(V, N, k, 0.2, exponent=2.0, smooth=False)
    kv = np.array([1.0, 1.5, 2.0, 1.5])  # vertex k between edges k − 1 and k
    np.testing.assert_allclose(da, 0.2 * (kv / 2.0) ** 2, rtol=1e-14)
    _, da = advance_polygon_front(V, N, k, 0.2, exponent=1.0, k_ic=1.6, smooth=False)
    np.testing.assert_allclose(da, [0.0, 0.0, 0.2, 0.0], atol=1e-15)
    _, ds = advance_polygon_front(V, N, k, 0.2, exponent=1.0, smooth=True)
    np.testing.assert_allclose(ds.sum(), (0.2 * kv / 2.0).sum(), rtol=1e-14)  # mean kept


def test_bad_input_refused():
    with pytest.raises(FractureError, match="k_edges"):
        advance_polygon_front(square(), N, [1.0, 1.0, 1.0], 0.1)
    with pytest.raises(FractureError, match="k_edges"):
        advance_polygon_front(square(), N, [1.0, -1.0, 1.0, 1.0], 0.1)
    t = 2 * math.pi * (np.arange(8) + 0.5) / 8
    octagon = np.column_stack([np.cos(t), np.sin(t), 0 * t])
    k = np.ones(8)
    k[1] = 100.0  # one edge far ahead of the others: a reflex angle at its neighbours
    with pytest.raises(FractureError, match="convex"):
        advance_polygon_front(octagon, N, k, 5.0, smooth=False)


# ------------------------------------------------------------- mixed mode (σ₁′ criterion)
from bonecontact.fracture.advance3d import (  # noqa: E402
    advance_mixed_front,
    equivalent_k,
    extend_surface,
    sigma1_kink,
)
from bonecontact.fracture.crack3d import (  # noqa: E402
    planar_crack_from_table,
    triangulated_from_polygon,
)


@pytest.mark.parametrize("ratio", [0.0, 0.1, 0.5, 1.0, 3.0, -0.7, 1e6])
def test_sigma1_without_mode_three_is_mts(ratio):
    """K_III = 0: σ₁′ is the hoop stress, so φ₀ is the MTS angle
    2 atan[(K_I − √(K_I² + 8K_II²))/(4K_II)] (pure mode II: ∓70.53°), ψ₀ = 0."""
    k1, k2 = (1.0, ratio) if ratio < 1e5 else (0.0, 1.0)
    phi, psi = sigma1_kink([k1], [k2], [0.0])
    mts = 0.0 if k2 == 0 else 2 * math.atan((k1 - math.sqrt(k1**2 + 8 * k2**2)) / (4 * k2))
    assert math.degrees(phi[0]) == pytest.approx(math.degrees(mts), abs=0.01)
    assert psi[0] == pytest.approx(0.0, abs=1e-12)


def test_sigma1_mode_three_twists_without_kinking():
    """Pure K_III: no kink, a twist of 45° (σ_φ = 0, τ_φz the largest at φ = 0); adding
    K_I lowers the twist to ½ atan(2K_III/K_I)."""
    phi, psi = sigma1_kink([0.0, 1.0], [0.0, 0.0], [1.0, 1.0])
    np.testing.assert_allclose(phi, 0.0, atol=1e-12)
    np.testing.assert_allclose(psi, [math.pi / 4, 0.5 * math.atan(2.0)], rtol=1e-12)


def test_equivalent_k_is_the_largest_sigma1():
    """K_V (Schöllmann's fit) against σ₁′(φ₀)√(2πr) maximised numerically: exact for the
    pure modes (K_I, 2/√3 K_II, K_III; the fit's 5.336 gives 1.00025 × 2/√3), within 5 %
    for any mixture (measured 4.5 %)."""
    np.testing.assert_allclose(
        equivalent_k([1, 0, 0], [0, 1, 0], [0, 0, 1]), [1, 2 / math.sqrt(3), 1], rtol=3e-4
    )
    rng = np.random.default_rng(1)
    K = np.abs(rng.normal(size=(300, 3)))
    K[:, 1] *= np.sign(rng.normal(size=300))
    phi, _ = sigma1_kink(*K.T)
    c = np.cos(phi / 2)
    s_phi = c * (K[:, 0] * c**2 - 1.5 * K[:, 1] * np.sin(phi))
    top = 0.5 * s_phi + 0.5 * np.sqrt(s_phi**2 + 4 * (K[:, 2] * c) ** 2)
    ratio = equivalent_k(*K.T) / top
    assert ratio.max() <= 1.0003 and ratio.min() > 0.95


def _octagon_crack():
    t = 2 * math.pi * (np.arange(8) + 0.5) / 8
    V = np.column_stack([np.cos(t), np.sin(t), 0 * t])
    return triangulated_from_polygon(
        planar_crack_from_table({"shape": "polygon", "vertices": V.tolist()})
    )


def test_mode_one_mixed_advance_is_the_planar_advance():
    """K_II = K_III = 0: the mixed-mode rule moves the vertices as the planar rule."""
    crack = _octagon_crack()
    k = np.linspace(1.0, 1.5, 8)
    adv = advance_mixed_front(
        crack.vertices, crack.normals2, np.column_stack([k, 0 * k, 0 * k]), 0.1
    )
    ref, da = advance_polygon_front(crack.vertices, N, k, 0.1)
    np.testing.assert_allclose(adv.vertices, ref, atol=1e-13)
    np.testing.assert_allclose(adv.da, da, rtol=1e-13)


def test_weights_replace_the_power_rule():
    """Given weights w: Δa = Δa_max w (averaged over three vertices), the direction as
    without them; w = (K_V/K_V,max)² is the default rule (the fatigue weights are the
    Paris rates over the largest).  A vertex of weight 0 holds (its point exactly the
    old one) and the average runs over the growing vertices only."""
    crack = _octagon_crack()
    k = np.linspace(1.0, 1.5, 8)
    K = np.column_stack([k, 0.1 * k, 0 * k])
    plain = advance_mixed_front(crack.vertices, crack.normals2, K, 0.1)
    same = advance_mixed_front(
        crack.vertices, crack.normals2, K, 0.1, weights=(plain.k_v / plain.k_v.max()) ** 2
    )
    np.testing.assert_array_equal(same.vertices, plain.vertices)
    assert not plain.held.any()
    w = np.array([1.0, 0.5, 0.0, 0.0, 0.0, 0.25, 0.5, 0.75])
    adv = advance_mixed_front(crack.vertices, crack.normals2, K, 0.1, weights=w)
    expect = 0.1 * np.array([2.25 / 3, 1.5 / 2, 0, 0, 0, 0.75 / 2, 1.5 / 3, 2.25 / 3])
    np.testing.assert_allclose(adv.da, expect, rtol=1e-13)
    np.testing.assert_array_equal(adv.held, w == 0)
    np.testing.assert_array_equal(adv.vertices[w == 0], crack.vertices[w == 0])
    moved = np.linalg.norm(adv.vertices - crack.vertices, axis=1)
    np.testing.assert_allclose(moved, expect, rtol=0, atol=6e-8)  # on the grid 2^-24 (on_grid)
    np.testing.assert_allclose(adv.directions, plain.directions, atol=1e-13)


def _area(P: np.ndarray, ids) -> float:
    """The signed area of the polygon ``ids`` of ``P`` about +z."""
    Q = P[list(ids)]
    return 0.5 * np.sum(np.cross(Q - Q[0], np.roll(Q, -1, axis=0) - Q[0]), axis=0) @ [0, 0, 1]


@pytest.mark.parametrize(
    "w",
    [
        [1.0, 0.5, 0.0, 0.0, 0.0, 0.25, 0.5, 0.75],  # three held in a row
        [1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0],  # every other vertex held
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],  # one vertex grows alone
    ],
)
def test_held_vertices_keep_their_points(w):
    """A held vertex keeps its point on the new front: an edge with one held end gets one
    triangle, an edge with both ends held none (its e₂ and kink kept); no triangle of zero
    area, every strip triangle counter-clockwise about +z, and the strips cover the area
    between the old and the new front; a second advance from the grown crack (its kinks
    read back) holds the same way."""
    w = np.asarray(w)
    crack = _octagon_crack()
    k = np.linspace(1.0, 1.4, 8)
    K = np.column_stack([k, 0 * k, 0 * k])
    adv = advance_mixed_front(crack.vertices, crack.normals2, K, 0.2, weights=w)
    grown = extend_surface(crack, adv.vertices, adv.held)
    held = w == 0
    both = held & np.roll(held, -1)  # edge k: vertex k to k + 1
    one = held ^ np.roll(held, -1)
    P = np.asarray(grown.points)
    assert len(P) == 8 + int((~held).sum()) + int((~(held | np.roll(held, -1))).sum())
    np.testing.assert_array_equal(np.asarray(grown.front_ids)[held], np.arange(8)[held])
    np.testing.assert_array_equal(grown.vertices, adv.vertices)
    assert len(grown.patches) == 1 + int(one.sum()) + 4 * int((~(held | np.roll(held, -1))).sum())
    strips = [_area(P, t) for t in grown.patches[1:]]
    assert min(strips) > 1e-3 * 0.2**2
    assert sum(strips) == pytest.approx(
        _area(P, grown.front_ids) - _area(P, crack.front_ids), rel=1e-12
    )
    e2 = np.asarray(grown.normals2)
    np.testing.assert_allclose(e2, np.tile([0.0, 0.0, 1.0], (8, 1)), atol=1e-12)
    cuts = np.asarray(grown.cuts)
    np.testing.assert_array_equal(cuts[both], np.tile([0.0, math.pi], (int(both.sum()), 1)))
    assert np.all(cuts[~both, 0] > 0) and np.allclose(np.abs(cuts[~both, 1]), math.pi)
    again = advance_mixed_front(grown.vertices, grown.normals2, K, 0.2, weights=w)
    twice = extend_surface(grown, again.vertices, again.held)
    np.testing.assert_array_equal(np.asarray(twice.cuts)[both], cuts[both])
    np.testing.assert_array_equal(twice.vertices[held], crack.vertices[held])


@pytest.mark.parametrize("k2", [0.3, -1.0])
def test_uniform_shear_kinks_every_vertex_by_the_criterion(k2):
    """Equal (K_I, K_II, 0) on every edge of a planar octagon: every vertex moves by Δa
    at the MTS angle out of the plane; the strips (planar trapezoids) rise at
    α = atan(tan φ₀ / cos(π/8)), their normals turned by α and the kink behind the new
    front at ψ = π − α, the strip's width back."""
    crack = _octagon_crack()
    K = np.tile([1.0, k2, 0.0], (8, 1))
    adv = advance_mixed_front(crack.vertices, crack.normals2, K, 0.1)
    phi = 2 * math.atan((1 - math.sqrt(1 + 8 * k2**2)) / (4 * k2))
    np.testing.assert_allclose(adv.kink, phi, atol=1e-5)
    r = np.linalg.norm(adv.vertices[:, :2], axis=1)
    np.testing.assert_allclose(r, 1 + 0.1 * math.cos(phi), rtol=1e-4)
    np.testing.assert_allclose(adv.vertices[:, 2], 0.1 * math.sin(phi), atol=1e-6)
    grown = extend_surface(crack, adv.vertices)
    assert len(grown.patches) == 1 + 4 * 8
    # the strips are planar trapezoids: the mid-edges move by Δa cos φ₀ cos(π/8) outwards
    # and Δa sin φ₀ up, so each strip rises at α = atan(tan φ₀ / cos(π/8))
    c8 = math.cos(math.pi / 8)
    alpha = math.atan(math.tan(phi) / c8)
    e2 = np.asarray(grown.normals2)
    np.testing.assert_allclose(e2[:, 2], math.cos(alpha), atol=1e-5)
    cuts = np.asarray(grown.cuts)
    np.testing.assert_allclose(np.cos(cuts[:, 1]), -math.cos(alpha), atol=1e-5)
    np.testing.assert_allclose(np.sin(cuts[:, 1]), math.sin(alpha), atol=1e-5)
    width = 0.1 * math.hypot(math.cos(phi) * c8, math.sin(phi))
    np.testing.assert_allclose(cuts[:, 0], width, rtol=1e-4)


def test_planar_strips_add_the_area_between_the_fronts():
    """A planar advance: every strip triangle runs counter-clockwise about +z, and the
    strips cover the area between the old and the new octagon."""
    crack = _octagon_crack()
    k = np.linspace(1.0, 1.4, 8)
    adv = advance_mixed_front(
        crack.vertices, crack.normals2, np.column_stack([k, 0 * k, 0 * k]), 0.2
    )
    grown = extend_surface(crack, adv.vertices)
    P = np.asarray(grown.points)

    def area(ids):
        Q = P[list(ids)]
        return 0.5 * np.sum(np.cross(Q - Q[0], np.roll(Q, -1, axis=0) - Q[0]), axis=0) @ [0, 0, 1]

    strips = [area(t) for t in grown.patches[1:]]
    assert min(strips) > 0
    assert sum(strips) == pytest.approx(area(grown.front_ids) - area(crack.front_ids), rel=1e-12)


def test_mixed_advance_bad_input_refused():
    crack = _octagon_crack()
    with pytest.raises(FractureError, match="k_edges"):
        advance_mixed_front(crack.vertices, crack.normals2, np.ones((7, 3)), 0.1)
    with pytest.raises(FractureError, match="k_edges"):
        advance_mixed_front(crack.vertices, crack.normals2, np.tile([-1.0, 0, 0], (8, 1)), 0.1)
