"""The polygon an interior 3D crack grows from, and the front it refuses (issue 26;
runners.front_growth3d.as_polygon, equal_chords; fracture.advance3d.front_defects;
docs/theory/fracture.md#front-growth-in-3d-scenes).

* An ellipse becomes the inscribed polygon of equal edges, N even, the largest N whose
  edges hold the integration domain (6 h_f): its vertices on the ellipse (to 1e-12), its
  edges equal (to 1e-12), symmetric about both axes, for b/a = 0.5, 0.33, 0.2 at h_f =
  0.0475a (N = 16, 14, 10; N + 2 equal edges would be shorter than 6 h_f).  The earlier
  rule — N = ⌊P/(6h_f)⌋ vertices at equal parameter steps — gave the 16-gon of b/a = 0.5
  an edge of 0.195a across the ends of the major axis, and the runner refused it (6 h_f =
  0.285a); it refused every b/a = 0.5 ellipse at any h_f (its shortest edge ≈ 2πb/N <
  P/N).
* A disc keeps its polygon, bit for bit (vertices at 2π(k + ½)/N, the octagon at a/8);
  one whose ⌊P/(6h_f)⌋-gon has edges a little short of 6 h_f (h_f = 0.0475a: 22 edges of
  0.998 × 6 h_f, refused before) takes the 21-gon.
* A front that an advance makes non-convex: the penny of radius a at front a/8 (the
  octagon, block [−4a, 4a]³ under tension, ``propagate``, every vertex at K_Ic), the first
  advance constructed so that vertex 3 sits at half its radius (the real advance with
  that vertex pulled in): the run stops ``not_convex`` after one solve, the front the
  octagon it started from (exactly), fracture.csv's rows marked ``not_convex`` with ``da``
  0, and ``fracture.growth.front_defect`` names the crack, the increment (0) and the
  vertex (3); the same on 2 and 3 ranks.
* slow: the mid-edge K of the ellipse b/a = 0.5 (both 16-gons given as polygons, h_f =
  0.0325a, the block and load of test_crack_fatigue_hold3d.py) against Irwin's K at the
  mid-edge's elliptic angle atan2(y/b, x/a): vertices at equal parameter steps (the
  earlier rule; edges 0.195a … 0.390a) −0.8 … +7.6 % on the fourteen edges away from the
  major axis ends (mean |error| 4.4 %), equal edges (0.299a) −0.4 … +2.7 % (mean 1.0 %);
  on the two edges across the ends +4.1, +5.0 % against +9.2, +9.4 % (an edge longer
  than the end's radius of curvature b²/a = 0.25a cuts off its tip: the polygon's K there
  is not the ellipse's).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from _crack_scenes import block_mesh, read_table, run_in

from bonecontact.fracture.crack3d import planar_crack_from_table
from bonecontact.fracture.front3d import irwin_k
from bonecontact.runners import front_growth3d
from bonecontact.runners.front_growth3d import as_polygon, equal_chords
from bonecontact.verification.problems import crack_block_scene

A = 1.0e-3
W = 4 * A
SIGMA = 1.0e6


def _ellipse(b: float):
    return planar_crack_from_table(
        {
            "shape": "ellipse",
            "centre": [0.0, 0.0, 0.0],
            "normal": [0.0, 0.0, 1.0],
            "semi_axes": [A, b],
            "axis": [1.0, 0.0, 0.0],
        }
    )


@pytest.mark.parametrize(("ratio", "n"), [(0.5, 16), (0.33, 14), (0.2, 10)])
def test_an_ellipse_becomes_the_polygon_of_equal_edges(ratio: float, n: int) -> None:
    h = 0.0475 * A
    b = ratio * A
    V = as_polygon(_ellipse(b), h).vertices
    assert V.shape == (n, 3)
    np.testing.assert_allclose((V[:, 0] / A) ** 2 + (V[:, 1] / b) ** 2, 1.0, rtol=0, atol=1e-12)
    edges = np.linalg.norm(np.roll(V, -1, axis=0) - V, axis=1)
    np.testing.assert_allclose(edges, edges.mean(), rtol=1e-12)
    assert edges.min() >= 6 * h
    more = equal_chords(A, b, n + 2)
    p = np.column_stack([A * np.cos(more), b * np.sin(more)])
    assert np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1).max() < 6 * h
    # symmetric about both axes: y -> -y maps vertex k to n - 1 - k, x -> -x to n/2 - 1 - k
    k = np.arange(n)
    np.testing.assert_allclose(V[n - 1 - k] * [1, -1, 1], V, atol=1e-12 * A)
    np.testing.assert_allclose(V[(n // 2 - 1 - k) % n] * [-1, 1, 1], V, atol=1e-12 * A)
    assert V[0, 0] > 0 and V[0, 1] > 0 and V[-1, 1] < 0  # edge n-1 -> 0 across x = a


def test_the_equal_parameter_polygon_was_too_short_for_the_domain() -> None:
    """The earlier rule's 16-gon of b/a = 0.5 at h_f = 0.0475a: its shortest edge."""
    h, b, n = 0.0475 * A, 0.5 * A, 16
    t = 2 * math.pi * (np.arange(n) + 0.5) / n
    p = np.column_stack([A * np.cos(t), b * np.sin(t)])
    edges = np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)
    assert edges.min() == pytest.approx(0.195 * A, rel=1e-3) and edges.min() < 6 * h
    assert len(as_polygon(_ellipse(b), h).vertices) == n


def test_a_disc_keeps_its_polygon() -> None:
    disc = planar_crack_from_table(
        {"shape": "disc", "centre": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0], "radius": A}
    )
    V = as_polygon(disc, A / 8).vertices
    assert V.shape == (8, 3)
    np.testing.assert_array_equal(V, disc.front().point(2 * math.pi * (np.arange(8) + 0.5) / 8))
    h = 0.0475 * A  # 2πa/(6h) = 22.04: 22 edges of 2a sin(π/22) = 0.9987 × 6h
    assert 2 * A * math.sin(math.pi / 22) < 6 * h
    V = as_polygon(disc, h).vertices
    assert V.shape == (21, 3)
    np.testing.assert_array_equal(V, disc.front().point(2 * math.pi * (np.arange(21) + 0.5) / 21))


def _scene(mesh: Path, geometry: str, h: float, extra: str) -> str:
    text = crack_block_scene(str(mesh), geometry, E=17.0e9, nu=0.3, sigma=SIGMA, h=h, points=1)
    text = text.replace("sigma_t = 133e6", f"sigma_t = 133e6\n{extra[0]}")
    return text.replace("tip_grading = 0.12", f"tip_grading = 0.12\n{extra[1]}")


@pytest.fixture(scope="module")
def mesh(tmp_path_factory) -> Path:
    return block_mesh(tmp_path_factory, "polygon3d", W)


def test_a_front_made_non_convex_stops_the_run(mesh: Path, monkeypatch) -> None:
    real = front_growth3d.advance_mixed_front

    def pulled_in(*args, **kw):
        adv = real(*args, **kw)
        V = adv.vertices.copy()
        V[3, :2] *= 0.5  # the penny's centre at the origin, in z = 0
        return dataclasses.replace(adv, vertices=V)

    monkeypatch.setattr(front_growth3d, "advance_mixed_front", pulled_in)
    geometry = f"centre = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = {A!r}"
    growth = f"propagate = true\nincrement = {0.1 * A!r}\nmax_increments = 2"
    text = _scene(mesh / "block.msh", geometry, A / 8, ("K_Ic = 1e4", growth))
    res, d = run_in(mesh, "folded", text)
    assert res.status == "converged"
    g = res.summary["fracture"]["growth"]
    assert g["status"] == "not_convex" and g["increments"] == 0 and g["stopped_by"] == "penny"
    assert g["front_defect"] == (
        "crack 'penny', increment 0: the advanced front is not a convex polygon (turns right "
        "at vertices 3); the front before it kept"
    )
    front = np.asarray(res.summary["fracture"]["crack"]["front"])
    disc = planar_crack_from_table(
        {"shape": "disc", "centre": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0], "radius": A}
    )
    np.testing.assert_array_equal(front, as_polygon(disc, A / 8).vertices)
    t = read_table(d / "out" / "fracture.csv")
    assert len(t["status"]) == 8 and set(t["status"]) == {"not_convex"}
    assert np.all(t["da"] == 0.0) and g["fragments"] is None
    assert (d / "out" / "crack_surface_0.vtk").is_file()
    assert not (d / "out" / "crack_surface_1.vtk").exists()


def _mid_edge_error(mesh: Path, name: str, vertices: np.ndarray, b: float, h: float):
    """K_I/Irwin − 1 at the mid-edges of one solve of the polygon ``vertices`` inscribed
    in the ellipse (a, b), and its edge lengths."""
    geometry = f'shape = "polygon"\nvertices = {vertices.tolist()!r}\nnormal = [0.0, 0.0, 1.0]'
    growth = f"propagate = true\nincrement = {0.025 * A!r}"
    res, d = run_in(mesh, name, _scene(mesh / "block.msh", geometry, h, ("K_Ic = 1e9", growth)))
    assert res.summary["fracture"]["growth"]["status"] == "arrested"
    t = read_table(d / "out" / "fracture.csv")
    phi = np.arctan2(t["y"] / b, t["x"] / A)
    V = np.asarray(res.summary["fracture"]["crack"]["front"])
    edges = np.linalg.norm(np.roll(V, -1, axis=0) - V, axis=1)
    return t["K_I"] / irwin_k(SIGMA, A, b, phi) - 1, edges


@pytest.mark.slow
def test_equal_edges_bring_the_mid_edge_k_to_irwin(mesh: Path) -> None:
    b, h, n = 0.5 * A, 0.0325 * A, 16
    t = 2 * math.pi * (np.arange(n) + 0.5) / n
    steps = np.column_stack([A * np.cos(t), b * np.sin(t), 0 * t])
    c = equal_chords(A, b, n)  # the runner's rule (it would take N = 24 at this h_f)
    chords = np.column_stack([A * np.cos(c), b * np.sin(c), 0 * c])
    before, e0 = _mid_edge_error(mesh, "parameter_steps", steps, b, h)
    after, e1 = _mid_edge_error(mesh, "equal_edges", chords, b, h)
    assert len(e1) == n and np.ptp(e1) < 1e-12 * A and e0.min() < 0.66 * e1.min()
    ends = np.array([7, 15])  # the edges across x = −a and x = a
    away = np.setdiff1d(np.arange(n), ends)
    assert np.abs(after[away]).max() < 0.03  # measured −0.4 … +2.7 %
    assert before[away].max() > 0.06  # measured −0.8 … +7.6 %
    assert np.mean(np.abs(after[away])) < 0.4 * np.mean(np.abs(before[away]))  # 1.0 vs 4.4 %
    assert np.all(after[ends] > before[ends]) and np.all(after[ends] < 0.11)  # 9.2, 9.4 vs 4.1, 5.0
