"""Coplanar interior 3D cracks that meet while growing by fatigue merge into their convex
hull and grow on (``[fracture.fatigue]``; runners.front_growth3d, runners.crack_fatigue).

The fatigue block of test_crack_fatigue_scene3d.py ([−4a₀, 4a₀]³, a₀ = 1 mm, σ = 1 MPa,
R = 0.1, C = 1e-20, m = 3, Δa_max = 0.1a₀, front a₀/8: the octagons) with two pennies of
radius a₀ in z = 0 at x = ±1.86a₀: facing mid-edges 1.87a₀ apart, so the mid-edge probes
(the ligament 0.75a₀ ahead) reach the other crack at the third block's advance.  Blocks
1–3 grow the pennies, the hull is solved after block 3 and grows by block 4 (5 solves):

* before the merge each block's cycles within 6 % (m × the 2 % K error of the penny
  tests) of the Paris law integrated in closed form for a penny with the octagon's
  K = κ₈ 2σ√(a/π) from a₀ + (k−1)Δa to a₀ + kΔa (measured −3.6, −2.4 %; the merging
  block −3.0 %: the neighbour's raised K, which the closed form does not have);
* the merging block's cycles are the pennies' lead rate at the two ends before it, ln r
  extrapolated; the next block's those of the merged front's largest vertex ΔK at its two
  ends, ln r linear: both recomputed from fracture.csv's K (1e-9), the latter also
  between the Paris cycles of the tunnel crack and of the penny of the waist's half-width;
* K_I at the merged crack's waist between the inscribed penny's and the tunnel crack's
  (as test_crack_merge3d.py; measured +52.6 %, +52.5 % and −2.9 %, −2.9 %);
* pennies at ±1.7a₀ merge at the first advance: that block, one end known, ∫ ds/r with
  ln r of the self-similar slope (m/2)/a₀ (1e-9), within 6 % of the penny's closed form
  from a₀ to a₀ + Δa (measured −3.5 %; the start rate alone, the rule before, +3.9 %)
  — one block, two solves (the block after a merge, ln r linear between the merged
  front's two ends, is the run above's block 4);
* fracture.csv: the cycles one per solve, increasing, the merging solve's rows ``merged``,
  the merged crack's under ``left+right``; the same on the session's ranks as on one and
  continued from the serial checkpoints before and just after the merge (1e-10).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import (
    block_mesh,
    continued_run,
    read_table,
    run_in,
    same_growth,
    serial_reference,
)
from test_crack_fatigue_scene3d import DA, SIGMA, TOL, A, C, M, R, W, _scene, kappa, paris_cycles

from bonecontact.fracture.advance3d import equivalent_k

X = 1.86 * A  # the pennies' centres at x = ±X
BLOCKS = 4
MERGE = 3  # the block at whose end the pennies merged (solve 3 is the merged crack's)
H = A / 8  # the front size


@pytest.fixture(scope="module")
def mesh(tmp_path_factory) -> Path:
    return block_mesh(tmp_path_factory, "merge_fatigue3d", W)


def two_pennies(mesh: Path, x: float = X, blocks: int = BLOCKS) -> str:
    """The scene of the two pennies at x = ±``x`` under fatigue."""
    text = _scene(mesh / "block.msh", centre=(-x, 0.0, 0.0), blocks=blocks)
    text = text.replace('name = "penny"', 'name = "left"')
    return text.replace(
        "[output]",
        f'[[crack]]\nname = "right"\ncentre = [{x!r}, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n'
        f'radius = {A!r}\nregion = "block"\nfront_points = 1\n[output]',
    )


@pytest.fixture(scope="module")
def merged(mesh: Path):
    res, d = run_in(mesh, "merged", two_pennies(mesh))
    assert res.status == "converged", res.summary.get("message")
    return res, d, read_table(d / "out" / "fracture.csv")


def lead_rates(t: dict[str, np.ndarray], blocks: int = BLOCKS) -> np.ndarray:
    """da/dN of the fastest vertex of all the fronts at every solve, from fracture.csv's
    K: a vertex's K the mean of its two edges' (K_I, K_II, K_III), ΔK = (1 − R) K_V."""
    out = []
    for k in range(blocks + 1):
        kv = []
        for name in dict.fromkeys(t["crack"][t["increment"] == k]):
            sel = (t["increment"] == k) & (t["crack"] == name)
            K = np.stack([t["K_I"][sel], t["K_II"][sel], t["K_III"][sel]], axis=1)
            kv.append(equivalent_k(*(0.5 * (K + np.roll(K, 1, axis=0))).T))
        out.append(C * ((1 - R) * np.concatenate(kv).max()) ** M)
    return np.array(out)


def block_cycles_by_end(t: dict[str, np.ndarray], blocks: int = BLOCKS) -> np.ndarray:
    """The cycles of every block from fracture.csv's cycles column (one value per solve)."""
    cyc = [t["cycles"][t["increment"] == k] for k in range(blocks + 1)]
    assert all(np.all(c == c[0]) for c in cyc)
    return np.diff([c[0] for c in cyc])


def waist(t: dict[str, np.ndarray], k: int) -> tuple[np.ndarray, float]:
    """K_I at the middles of the merged crack's long sides at solve ``k`` (|x| < a/4) and
    the waist's half-width b there."""
    sel = (t["increment"] == k) & (t["crack"] == "left+right")
    mid = sel & (np.abs(t["x"]) < 0.25 * A)
    assert np.count_nonzero(mid) >= 1
    return t["K_I"][mid], float(np.abs(t["y"][mid]).mean())


def test_pennies_merge_and_the_merged_crack_grows_on(merged) -> None:
    res, d, t = merged
    g = res.summary["fracture"]["growth"]
    assert g["status"] == "max_blocks" and g["increments"] == BLOCKS
    assert g["merges"] == [{"cracks": ["left", "right"], "into": "left+right", "increment": 2}]
    assert [c["name"] for c in res.summary["fracture"]["cracks"]] == ["left+right"]
    inc = t["increment"]
    assert list(t["crack"][inc < MERGE]) == (["left"] * 8 + ["right"] * 8) * MERGE
    assert set(t["crack"][inc >= MERGE]) == {"left+right"}
    n = np.count_nonzero(inc == MERGE)
    assert list(t["point"][inc >= MERGE]) == list(range(n)) * (BLOCKS + 1 - MERGE)
    cyc = np.array([t["cycles"][inc == k][0] for k in range(BLOCKS + 1)])
    assert cyc[0] == 0.0 and np.all(np.diff(cyc) > 0) and np.all(np.diff(inc) >= 0)
    np.testing.assert_allclose(cyc, [h["cycles"] for h in g["history"]], rtol=1e-12)
    assert cyc[-1] == pytest.approx(g["cycles"], rel=1e-12)
    assert set(t["status"][inc < MERGE - 1]) == {"grows"}
    assert set(t["status"][inc == MERGE - 1]) == {"merged"}  # the merging solve's rows
    assert set(t["status"][(inc >= MERGE) & (inc < BLOCKS)]) == {"grows"}
    assert set(t["status"][inc == BLOCKS]) == {"max_blocks"}
    # the merged front: convex in z = 0, its edges at least the ligament
    V = np.array(res.summary["fracture"]["crack"]["front"])
    assert np.abs(V[:, 2]).max() < 5e-3 * A
    e = np.roll(V[:, :2], -1, axis=0) - V[:, :2]
    f = np.roll(e, -1, axis=0)
    assert np.all(e[:, 0] * f[:, 1] - e[:, 1] * f[:, 0] > 0)  # left turns about +z
    assert np.linalg.norm(e, axis=1).min() >= 6 * H * (1 - 1e-9)
    state = json.loads((d / "out/checkpoints/increment_00003/growth.json").read_text())
    assert state["names"] == ["left+right"] and state["fatigue"]["phases"] == [0, MERGE]


def test_cycles_before_the_merge_against_the_penny(merged) -> None:
    """Blocks 1 … 3 (the last the merging one) against the closed form of a penny with
    the octagon's K from a₀ + (k − 1)Δa to a₀ + kΔa (the leading vertex grows Δa_max per
    block); the first solve's mean K of each penny within 2 % of κ₈ 2σ√(a₀/π)."""
    _, _, t = merged
    got = block_cycles_by_end(t)[:MERGE]
    ref = [paris_cycles(A + k * DA, A + (k + 1) * DA, kappa(8)) for k in range(MERGE)]
    np.testing.assert_allclose(got / ref, 1.0, atol=TOL)  # measured -3.6, -2.4, -3.0 %
    k0 = kappa(8) * 2 * SIGMA * math.sqrt(A / math.pi)
    for name in ("left", "right"):
        sel = (t["increment"] == 0) & (t["crack"] == name)
        assert t["K_I"][sel].mean() == pytest.approx(k0, rel=0.02)


def test_cycles_across_the_merge_follow_the_lead_rates(merged) -> None:
    """The merging block: ∫ ds/r with ln r extrapolated from the pennies' two ends
    before it; the next block: ln r linear between the merged front's two ends, from the
    merged crack's largest vertex ΔK (both 1e-9), and between the Paris cycles of the
    tunnel crack and of the penny of the waist's half-width."""
    _, _, t = merged
    r, got, h = lead_rates(t), block_cycles_by_end(t), DA
    g = math.log(r[MERGE - 1] / r[MERGE - 2]) / h
    assert g > 0  # the pennies' rate rises
    merging = (1.0 - math.exp(-g * h)) / (g * r[MERGE - 1])
    assert got[MERGE - 1] == pytest.approx(merging, rel=1e-9)
    after = h * (1 / r[MERGE] - 1 / r[MERGE + 1]) / math.log(r[MERGE + 1] / r[MERGE])
    assert got[MERGE] == pytest.approx(after, rel=1e-9)
    b3, b4 = waist(t, MERGE)[1], waist(t, MERGE + 1)[1]
    tunnel = h / (C * ((1 - R) * SIGMA * math.sqrt(math.pi * b4)) ** M)
    penny = h / (C * ((1 - R) * 2 * SIGMA * math.sqrt(b3 / math.pi)) ** M)
    assert tunnel < got[MERGE] < penny, (tunnel, got[MERGE], penny)


@pytest.mark.parametrize("k", [MERGE, MERGE + 1])
def test_merged_waist_between_penny_and_tunnel_crack(merged, k: int) -> None:
    _, _, t = merged
    K, b = waist(t, k)
    lower, upper = 2 * SIGMA * math.sqrt(b / math.pi), SIGMA * math.sqrt(math.pi * b)
    assert np.all(K > lower) and np.all(K < upper), (K, lower, upper)


@pytest.mark.skipif(MPI.COMM_WORLD.size == 1, reason="compares a distributed run with a serial one")
def test_same_answer_on_any_rank_count(merged) -> None:
    """fracture.csv (the cycles too), the stop, the cycles and the front as serial."""
    _, d, _ = merged
    same_growth(d / "out", serial_reference(d), A)


@pytest.mark.parametrize("k", [MERGE - 1, MERGE], ids=["before", "after"])
def test_restart_around_the_merge(merged, k: int) -> None:
    """The serial run's checkpoint before the merging block (the continued run merges
    the pennies itself) and the one just after it (the merged crack and the new phase of
    the block history come back) continued on every rank of the session."""
    _, d, _ = merged
    serial = serial_reference(d)
    _, out = continued_run(d, serial, k)
    got, _ = same_growth(out, serial, A)
    assert got["growth"]["merges"][0]["into"] == "left+right"


def test_merge_in_the_first_block_counts_it_by_the_self_similar_slope(mesh: Path) -> None:
    """Pennies at x = ±1.7a₀ meet at the first advance: the merging block, whose start is
    the only end known, ∫ ds/r with ln r of slope (m/2)/ρ from the start rate (ρ the
    leading vertex's distance to the octagon's centre, from fracture.csv's mid-edges; 1e-9)
    and within m × 2 % of the penny's Paris law from a₀ to a₀ + Δa.  One block (two
    solves): the next block's cycles, from the merged crack's two ends (ln r linear),
    are the rule :func:`test_cycles_across_the_merge_follow_the_lead_rates` checks on the
    run above's block after its merge (until 2026-12-05 a second block here checked it
    again, a third solve of the merged crack)."""
    res, d = run_in(mesh, "first_block", two_pennies(mesh, 1.7 * A, 1))
    assert res.status == "converged", res.summary.get("message")
    g = res.summary["fracture"]["growth"]
    assert g["status"] == "max_blocks" and [m["increment"] for m in g["merges"]] == [0]
    assert g["increments"] == 1
    t = read_table(d / "out" / "fracture.csv")
    assert set(t["status"][t["increment"] == 0]) == {"merged"}
    assert set(t["crack"][t["increment"] == 1]) == {"left+right"}
    r, got = lead_rates(t, 1), block_cycles_by_end(t, 1)
    sel = (t["increment"] == 0) & (t["crack"] == "left")
    mid = np.stack([t["x"][sel], t["y"][sel], t["z"][sel]], axis=1)
    rho = np.linalg.norm(mid - mid.mean(axis=0), axis=1).mean() / math.cos(math.pi / 8)
    assert rho == pytest.approx(A, rel=1e-6)  # the octagon's circumradius
    slope = 0.5 * M / rho
    merging = (1.0 - math.exp(-slope * DA)) / (slope * r[0])
    assert got[0] == pytest.approx(merging, rel=1e-9)
    ref = paris_cycles(A, A + DA, kappa(8))
    print("first block vs closed form", got[0] / ref - 1, "start rate", DA / r[0] / ref - 1)
    assert got[0] == pytest.approx(ref, rel=TOL)  # measured -3.5 %
