"""The geometry of cracks that merge (bonecontact.fracture.coalescence), against cases
worked by hand.

* 2D: collinear facing tips merge into one polyline from far end to far end (the far
  ends' tips kept, a mouth kept as a mouth, a bridge shorter than the given length closed
  at its midpoint); a tip at another crack's flank, tips at 30°, tips side by side and a
  crack from mouth to mouth are refused with the reason.
* 3D: the hull of two coplanar octagons contains both, is convex, counter-clockwise
  about the normal and has no edge shorter than asked (a short edge removed by extending
  its neighbours: the hull only grows); points off the plane are not coplanar.
* The fatigue bookkeeping across a merge: the block that merged integrates the leading
  rate extrapolated from the two ends before it (ln r linear), by hand; with one end
  known, by the self-similar slope (m/2)/ρ, against the Paris law in closed form for a
  penny (m = 2, 3, 4) and a 2D centre crack, blocks of 0.05 … 0.2ρ: below it by less
  than m x²/4 (m = 3, x = 0.1: −0.23 %, where the start rate gave +7.4 %); no slope
  (older checkpoints) the start rate; ρ of 2D and 3D cracks by hand.
* A block shortened before a merge (bonecontact.runners.crack_fatigue.block_shares): the
  shares of a block of length L < Δa_max, the floor 0.6 Δa_max kept (the tips that must
  meet grow below it), the leading growth blocks × Δa_max less the shortfall, through a
  checkpoint; the merge after it by the two-end slope, by hand.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.coalescence import coplanar, facing_tips, hull_polygon, merged_crack
from bonecontact.fracture.crack import Crack2D
from bonecontact.runners.crack_fatigue import FatigueProgress

L = 1.0e-3


def test_collinear_tips_merge_far_end_to_far_end() -> None:
    a = Crack2D(np.array([[-4.0, 0.0], [-1.0, 0.0], [-0.1, 0.0]]) * L)
    b = Crack2D(np.array([[3.0, 0.0], [0.1, 0.0]]) * L)  # its tip 0 far, -1 facing
    end_b, why = facing_tips(a, -1, b, 0.25 * L, 0.01 * L)
    assert (end_b, why) == (-1, "")
    m = merged_crack(a, -1, b, end_b, 0.01 * L)
    np.testing.assert_allclose(m.points / L, [[-4, 0], [-1, 0], [-0.1, 0], [0.1, 0], [3, 0]])
    assert m.tips == "both" and m.length == pytest.approx(7.0 * L)
    closed = merged_crack(a, -1, b, end_b, 0.5 * L)  # a bridge of 0.2 < 0.5: its midpoint
    np.testing.assert_allclose(closed.points / L, [[-4, 0], [-1, 0], [0, 0], [3, 0]], atol=1e-12)


def test_an_edge_crack_merging_keeps_its_mouth() -> None:
    edge = Crack2D(np.array([[-5.0, 0.0], [-0.1, 0.0]]) * L, "end")  # mouth at x = -5
    inner = Crack2D(np.array([[0.1, 0.0], [2.0, 0.0]]) * L)
    m = merged_crack(edge, -1, inner, 0, 0.01 * L)
    assert m.tips == "end" and m.points[0, 0] == pytest.approx(-5 * L)
    m = merged_crack(inner, 0, edge, -1, 0.01 * L)  # the other way round
    assert m.tips == "start" and m.points[-1, 0] == pytest.approx(-5 * L)
    other = Crack2D(np.array([[0.1, 0.0], [5.0, 0.0]]) * L, "start")  # mouth at x = 5
    with pytest.raises(ParameterError, match="cut the body through"):
        merged_crack(edge, -1, other, 0, 0.01 * L)


@pytest.mark.parametrize(
    ("b_points", "reason"),
    [
        ([[0.0, -2.0], [0.0, 2.0]], "T-junction"),  # the flank of a crossing crack
        (
            [[0.1, 0.0], [0.1 + 2 * math.cos(math.radians(30)), 2 * math.sin(math.radians(30))]],
            "not collinear",
        ),
        ([[-2.0, 0.15], [0.05, 0.15]], "not collinear"),  # side by side, parallel
        ([[0.1, 0.1], [2.1, 0.1]], "do not face each other"),  # offset: the bridge at 45°
    ],
    ids=["tee", "angle30", "side_by_side", "offset"],
)
def test_tips_that_do_not_face_each_other_are_refused(b_points: list, reason: str) -> None:
    a = Crack2D(np.array([[-3.0, 0.0], [-0.0, 0.0]]) * L)
    b = Crack2D(np.array(b_points) * L)
    end_b, why = facing_tips(a, -1, b, 0.25 * L, 0.01 * L)
    assert reason in why, why


def _octagon(cx: float, r: float) -> np.ndarray:
    t = 2 * math.pi * (np.arange(8) + 0.5) / 8
    return np.column_stack([cx + r * np.cos(t), r * np.sin(t), np.zeros(8)])


def test_the_hull_of_two_coplanar_octagons() -> None:
    P = np.concatenate([_octagon(-1.7, 1.1), _octagon(1.7, 1.1)]) * L
    for min_edge in (0.75 * L, 1.2 * L):
        V = hull_polygon(P, [0.0, 0.0, 1.0], min_edge)
        e = np.roll(V, -1, axis=0) - V
        assert np.linalg.norm(e, axis=1).min() >= min_edge or len(V) == 6
        turn = np.cross(e, np.roll(e, -1, axis=0))[:, 2]
        assert np.all(turn > 0)  # convex, counter-clockwise about +z
        normals = np.cross(e, [0.0, 0.0, 1.0])  # outward
        dist = ((P[:, None, :] - V[None, :, :]) * normals[None]).sum(axis=2)
        assert np.all(dist <= 1e-12 * L)  # every point of both octagons inside
        assert np.abs(V[:, 2]).max() < 1e-15
    # 0.842 mm edges at the ends, the two long sides 4.39 mm: all kept at 0.75 mm
    assert len(hull_polygon(P, [0.0, 0.0, 1.0], 0.75 * L)) == 8
    assert coplanar(P, [0, 0, 1], 0.01 * L) == ""
    P[:8, 2] += 0.1 * L
    assert "not coplanar" in coplanar(P, [0, 0, 1], 0.01 * L)


def test_the_merging_block_extrapolates_the_leading_rate() -> None:
    prog = FatigueProgress()
    r0, r1 = 1.0e-9, 2.0e-9  # the rate doubles over the second block
    for s, r in ((0.0, r0), (1.0e-4, r1)):
        prog.add_end(s, r)
    prog.merged({("a", -1): ("a+b", 0), ("a", 0): ("a+b", 0)})
    n = prog.add_end(2.0e-4, 0.5e-9)  # the merged crack's rate is not used
    g = math.log(r1 / r0) / 1.0e-4
    block = (1.0 - math.exp(-g * 1.0e-4)) / (g * r1)
    assert n - prog.cycles[-2] == pytest.approx(block, rel=1e-12)
    assert prog.phases == [0, 2]


def _paris_integral(C: float, kappa: float, m: float, a0: float, a1: float) -> float:
    """Cycles from a0 to a1 at da/dN = C (κ√a)^m, in closed form."""
    if m == 2.0:
        return math.log(a1 / a0) / (C * kappa**2)
    return (a0 ** (1 - m / 2) - a1 ** (1 - m / 2)) / ((m / 2 - 1) * C * kappa**m)


@pytest.mark.parametrize("x", [0.05, 0.1, 0.2])  # the block over the crack size, Δa/ρ
@pytest.mark.parametrize(
    ("m", "kappa"),
    [
        (2.0, 2.0 / math.sqrt(math.pi)),  # a penny, K = 2σ√(a/π) (σ = 1)
        (3.0, 2.0 / math.sqrt(math.pi)),
        (4.0, 2.0 / math.sqrt(math.pi)),
        (3.0, math.sqrt(math.pi)),  # a 2D centre crack, K = σ√(πa), a the half-length
        (4.0, math.sqrt(math.pi)),
    ],
)
def test_a_merge_in_the_first_block_takes_the_self_similar_slope(
    m: float, kappa: float, x: float
) -> None:
    """One end known, a merge, the next end: the merging block's cycles with ln r of the
    self-similar slope (m/2)/ρ against the Paris law integrated in closed form from ρ to
    ρ(1 + x).  ln r linear lies above the true (m/2) ln(1 + s/ρ) by at most
    (m/2)(x − ln(1 + x)) < m x²/4 at the block's end, so the cycles are below the closed
    form by less than that (m = 3, x = 0.1: −0.23 %; the start rate alone +7.4 %)."""
    from bonecontact.runners.crack_fatigue import self_similar_slope

    C, rho = 1.0e-12, 2.0e-3
    h = x * rho
    prog = FatigueProgress()
    prog.add_end(0.0, C * (kappa * math.sqrt(rho)) ** m)
    prog.merged({}, slope=self_similar_slope(m, rho))
    back = FatigueProgress.from_state(json.loads(json.dumps(prog.state())))  # a checkpoint
    assert back.slope == prog.slope == pytest.approx(0.5 * m / rho, rel=1e-15)
    n = back.add_end(h, 1.0)  # the merged crack's rate is not used
    exact = _paris_integral(C, kappa, m, rho, rho + h)
    err = n / exact - 1.0
    assert -m * x**2 / 4 < err < 0.0, err
    start = h / (C * (kappa * math.sqrt(rho)) ** m)  # the rule without the slope
    assert start / exact - 1.0 > 0.9 * (m / 4) * x, start / exact - 1.0  # ≈ (m/4) x, over
    if (m, x) == (3.0, 0.1) and kappa < 1.5:
        assert err == pytest.approx(-0.0023, abs=1e-4)
        assert start / exact - 1.0 == pytest.approx(0.0744, abs=1e-4)


def test_a_merge_in_the_first_block_without_a_slope_takes_the_start_rate() -> None:
    """No slope (an older checkpoint, or a caller that gives none) or one not positive:
    the start rate over the block, as before the slope existed."""
    for slope in (None, 0.0, -5.0):
        prog = FatigueProgress()
        prog.add_end(0.0, 2.0e-9)
        prog.merged({}, **({} if slope is None else {"slope": slope}))
        state = prog.state()
        if slope is None:
            del state["slope"]  # as a checkpoint written before the slope was stored
        back = FatigueProgress.from_state(state)
        assert back.add_end(1.0e-4, 7.0e-9) == pytest.approx(1.0e-4 / 2.0e-9, rel=1e-15)


def test_the_crack_size_seen_from_a_tip_or_a_vertex() -> None:
    """ρ of the self-similar slope: a 2D centre crack's half-length (tip to the other end
    over 2) from either tip, an edge crack's length (tip to mouth), a regular 3D octagon's
    circumradius, a 3D rectangle's half-diagonal (its corners the vertices)."""
    from bonecontact.runners.crack_fatigue import size_from_tip, size_from_vertex

    centre = Crack2D(np.array([[-3.0e-3, 1.0e-3], [0.0, 1.5e-3], [3.0e-3, 1.0e-3]]))
    edge = Crack2D(np.array([[0.0, 0.0], [0.0, 2.0e-3], [0.0, 5.0e-3]]), tips="end")
    assert size_from_tip(centre, 0) == size_from_tip(centre, -1) == pytest.approx(3.0e-3)
    assert size_from_tip(edge, -1) == pytest.approx(5.0e-3, rel=1e-15)
    t = np.arange(8) * math.pi / 4
    octagon = np.stack([1.0e-3 * np.cos(t) + 0.5, 1.0e-3 * np.sin(t), 0 * t + 2.0], axis=1)
    for k in range(8):
        assert size_from_vertex(octagon, k) == pytest.approx(1.0e-3, rel=1e-9)
    rect = np.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [4.0, 3.0, 0.0], [0.0, 3.0, 0.0]])
    assert size_from_vertex(rect, 1) == pytest.approx(2.5, rel=1e-15)


def test_a_block_shortened_before_a_merge_and_the_merge_after_it() -> None:
    """Four tips at rates 1, 0.9801, 0.64 and 0.36 (× r0; K_eq 1, 0.99, 0.8, 0.6, m = 2)
    in a block of L = 0.65 Δa_max: shares 0.65, 0.637, 0.416 and 0.234 Δa_max, the first
    two at or above the floor 0.6 Δa_max grow, the others keep theirs; a full block gives
    the old shares.  The end after it lies at Δa_max − shortfall = L (a checkpoint
    between), its cycles by the two ends; the block after it, cut to 0.5 Δa_max where the
    facing tips meet (both grow below the floor: ``must``; the third now above it with
    what it kept), merges, and its
    cycles are ∫ ds/r with ln r continued from the two ends, by hand."""
    from bonecontact.fracture.propagation import IncrementRecord
    from bonecontact.runners.crack_fatigue import block_end, block_shares
    from bonecontact.scene.spec import FatigueSpec

    spec = FatigueSpec(C=1.0e-20, m=2.0, da_max=2.5e-4)
    da, r0 = spec.da_max, 1.0e-20 * 1.0e10

    def rows(scale: float) -> list:
        k = [1.0e5, 0.99e5, 0.8e5, 0.6e5]
        names = [("a", -1), ("b", 0), ("a", 0), ("b", -1)]
        return [
            IncrementRecord(
                0, e, 0.0, 0.0, 1.0, kk, 0.0, 0.0, 0.0, 1.0, "", K_eq=scale * kk, crack=c
            )
            for kk, (c, e) in zip(k, names, strict=True)
        ]

    length = 0.65 * da
    grow, kept = block_shares(rows(1.0), spec, {}, length)
    assert grow == pytest.approx({("a", -1): 0.65 * da, ("b", 0): 0.65 * 0.9801 * da})
    assert kept == pytest.approx({("a", 0): 0.65 * 0.64 * da, ("b", -1): 0.65 * 0.36 * da})
    full, _ = block_shares(rows(1.0), spec, {}, da)
    assert full == pytest.approx({("a", -1): da, ("b", 0): 0.9801 * da, ("a", 0): 0.64 * da})
    prog = FatigueProgress()
    block_end(rows(1.0), spec, None, prog, 0)  # the start
    prog.shortfall, prog.shortened, prog.waiting = da - length, True, kept
    back = FatigueProgress.from_state(json.loads(json.dumps(prog.state())))  # a checkpoint
    assert (back.shortfall, back.shortened) == (prog.shortfall, True)
    before = dict(back.waiting)  # what the tips kept before this end
    block_end(rows(1.1), spec, None, back, 1)  # the rate 1.21 r0 at L
    assert back.growth == pytest.approx([0.0, length], rel=1e-15)
    g = math.log(1.21) / length
    n1 = (1.0 - math.exp(-g * length)) / (g * r0)
    assert back.cycles[-1] == pytest.approx(n1, rel=1e-12)
    cut = 0.5 * da
    grow, kept = block_shares(rows(1.1), spec, before, cut, must=(("a", -1), ("b", 0)))
    assert grow == pytest.approx(
        {("a", -1): cut, ("b", 0): 0.9801 * cut, ("a", 0): (0.65 + 0.5) * 0.64 * da}
    )
    assert kept == pytest.approx({("b", -1): (0.65 + 0.5) * 0.36 * da})
    back.shortfall += da - cut
    back.merged({("a", 0): ("a+b", 0), ("b", -1): ("a+b", -1)}, slope=1.0e9)  # not used
    block_end(rows(2.0), spec, None, back, 2)  # the merged crack: its rate not used
    assert back.growth[-1] == pytest.approx(length + cut, rel=1e-15)
    n2 = (1.0 - math.exp(-g * cut)) / (g * 1.21 * r0)
    assert back.cycles[-1] == pytest.approx(n1 + n2, rel=1e-12)
