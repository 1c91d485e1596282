"""Cracks that join merge into one and grow on (``[fracture] joined = "merge"``, the default;
bonecontact.runners.crack_join, bonecontact.fracture.coalescence), run in-process.

The plate of tests/unit/runners/test_crack_scene_several.py ([−W, W] × [−2W, 2W], W = 100
mm, σ_yy = σ on the top and bottom edges; E = 17 GPa, ν = 0.3) with two collinear cracks
on y = 0.  References built outside the code:

* two equal collinear cracks b ≤ |x| ≤ c: the closed form of the infinite plate (inner and
  outer K; docs/theory/fracture.md#several-cracks);
* after the merge, one crack of half-length a: Feddersen's σ√(πa sec(πa/2W)) within 2 %
  (the tolerance of the centre crack of tests/unit/runners/test_crack_scene.py);
* under fatigue, the cycles from the start to a given half-length: the Paris law
  integrated over both phases (the two cracks by the closed form, an ODE of the inner
  and outer tips until the tips meet; then the centre crack by Feddersen's factor);
  cracks that would meet in the first block: that block shortened and solved, the next
  cut where the tips meet, against the pair's closed form until they meet (+14.5 %,
  where the one-end rule before gave +38.6 %).

On every rank count of the session: the merged runs equal the serial one (fracture.csv
to 1e-10 of each column's scale), and a fatigue run restarted from a checkpoint written
after the merge, or after a block shortened before it, gives the same rows.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import idle_barrier, pinned_plate, run_dir, run_in, same_tables, serial_reference
from coupled_support import gmsh_on_rank0, read_csv, run_text
from scipy.integrate import quad, solve_ivp
from scipy.special import ellipe, ellipkm1
from test_crack_scene_several import SIGMA, W, collinear_k, scene_text

from bonecontact.runners import run_scene
from bonecontact.scene import SceneError, load_scene

PIN = 0.004  # m
DA = 0.00025  # m, the increment of propagation


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("merge")) if comm.rank == 0 else None))
    gmsh_on_rank0(pinned_plate(-W, W, 2 * W, PIN, W / 10), d / "plate.msh", 2)
    return d


def feddersen(a: float) -> float:
    """K of a centre crack of half-length a in the plate of width 2W under σ."""
    return SIGMA * math.sqrt(math.pi * a / math.cos(math.pi * a / (2 * W)))


def _table(d: Path) -> tuple[dict, np.ndarray, np.ndarray]:
    rows = read_csv(d / "fracture.csv")
    raw = np.loadtxt(d / "fracture.csv", delimiter=",", dtype=str, skiprows=1)
    header = (d / "fracture.csv").read_text().splitlines()[0].split(",")
    return rows, raw[:, header.index("crack")], raw[:, header.index("status")]


def _grow(folder: Path, name: str, cracks: list, k_ic: float, extra: str = "") -> tuple:
    d = run_dir(folder, name)
    fracture = f"[fracture]\npropagate = true\nincrement = {DA}\nmax_increments = 6\n{extra}"
    text = scene_text(name, folder, cracks, fracture, K_Ic=k_ic)
    res = run_text(text, d, d / "out")
    assert res.status == "converged", res.summary.get("message")
    return res, *_table(d / "out")


# (left crack, right crack), m: equal (b/c = 0.2) and unequal cracks
CASES = {
    "equal": ([[-0.005, 0.0], [-0.001, 0.0]], [[0.001, 0.0], [0.005, 0.0]]),
    "unequal": ([[-0.004, 0.0], [-0.0012, 0.0]], [[0.0006, 0.0], [0.005, 0.0]]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_joined_cracks_merge_and_the_outer_tips_give_feddersen(folder: Path, case: str) -> None:
    """K_Ic just below the inner K of the equal cracks: the inner tips grow until they meet
    (within Δa), the two cracks become one ``left+right`` from the far tip of one to the
    far tip of the other, and its tips, the former outer tips, give Feddersen's K of a
    centre crack of half its length."""
    left, right = CASES[case]
    _, outer = collinear_k(0.001, 0.005, SIGMA)
    res, rows, crack, status = _grow(
        folder, f"prop_{case}", [("left", left), ("right", right)], 1.01 * outer
    )
    inc, x = rows["increment"].astype(int), rows["x"]
    merged = crack == "left+right"
    assert merged.any() and np.all(np.isin(crack[~merged], ["left", "right"]))
    first = inc[merged].min()
    assert np.all(inc[~merged] < first)
    before = inc == first - 1
    assert sorted(status[before & (np.abs(x) < 0.002)]) == ["merged", "merged"] or (
        "merged" in status[before]
    )
    merges = res.summary["fracture"]["merges"]
    assert [m["cracks"] for m in merges] == [["left", "right"]]
    assert merges[0]["into"] == "left+right" and merges[0]["bridge"] < DA
    assert merges[0]["increment"] == first - 1
    for n in np.unique(inc[merged]):
        here = merged & (inc == n)
        assert np.count_nonzero(here) == 2
        a = 0.5 * (x[here].max() - x[here].min())
        np.testing.assert_allclose(rows["K_I"][here], feddersen(a), rtol=0.02)
        assert np.max(np.abs(rows["K_II"][here])) < 0.01 * feddersen(a)
    np.testing.assert_allclose(rows["y"], 0.0, atol=1e-2 * DA)
    cracks = res.summary["fracture"]["cracks"]
    assert [c["name"] for c in cracks] == ["left+right"]
    pts = np.array(cracks[0]["points"])
    assert pts[0, 0] < pts[-1, 0] and np.all(np.diff(pts[:, 0]) > 0)  # one straight path


C_PARIS, M_PARIS, DA_MAX = 1.0e-20, 2.0, 0.00025  # (m/cycle)/(Pa√m)^m, -, m


def _collinear(b: float, c: float) -> tuple[float, float]:
    """The closed form of ``collinear_k`` with K(k) from k′² = b²/c² (scipy's ellipkm1:
    exact as b → 0, where the inner tips meet)."""
    p = (b / c) ** 2
    kk, ee = ellipkm1(p), ellipe(1.0 - p)
    k = math.sqrt(1.0 - p)
    root = SIGMA * math.sqrt(math.pi * c)
    return root * (ee / kk - p) / (k * math.sqrt(b / c)), root * (1.0 - ee / kk) / k


def paris_cycles(b0: float, c0: float, a1: float) -> tuple[float, float]:
    """Cycles for the equal collinear cracks b0 ≤ |x| ≤ c0 to grow into one centre crack of
    half-length a1, and the half-length where they meet: the inner and outer tips by the
    Paris law of the closed form's K (db/dN = −C K_in^m, dc/dN = C K_out^m, integrated
    over b down to 10⁻⁸ c₀, the rest negligible) until the inner tips meet, then the
    centre crack by Feddersen's K."""

    def rates(b: float, y: np.ndarray) -> list[float]:  # d(N, c)/db
        k_in, k_out = _collinear(b, y[1])
        return [-1.0 / (C_PARIS * k_in**M_PARIS), -((k_out / k_in) ** M_PARIS)]

    sol = solve_ivp(rates, (b0, 1e-8 * c0), [0.0, c0], rtol=1e-11, atol=1e-14, method="LSODA")
    assert sol.success, sol.message
    n1, c1 = float(sol.y[0, -1]), float(sol.y[1, -1])
    n2 = quad(lambda a: 1.0 / (C_PARIS * feddersen(a) ** M_PARIS), c1, a1, epsrel=1e-10)[0]
    return n1 + n2, c1


def _fatigue(folder: Path, name: str, cracks: list, blocks: int) -> tuple:
    d = run_dir(folder, name)
    fatigue = (
        f"[fracture]\n[fracture.fatigue]\nC = {C_PARIS}\nm = {M_PARIS}\nda_max = {DA_MAX}\n"
        f"max_blocks = {blocks}\n"
    )
    res = run_text(scene_text(name, folder, cracks, fatigue, K_Ic=None), d, d / "out")
    assert res.status == "converged", res.summary.get("message")
    return res, *_table(d / "out")


@pytest.mark.parametrize("b0, blocks", [(0.001, 9), (0.002, 13)], ids=["b/c=0.2", "b/c=0.4"])
def test_fatigue_cycles_through_the_merge_against_the_paris_integral(
    folder: Path, b0: float, blocks: int
) -> None:
    """Equal collinear cracks b0 ≤ |x| ≤ 5 mm under fatigue (m = 2, Δa_max = 0.25 mm): the
    inner tips run ahead, meet, the cracks merge and the centre crack grows on; the cycles
    at every block end of the merged crack past the closed form's meeting length within
    2 % of the Paris law integrated over both phases (measured −0.3 … +0.5 % at
    b/c = 0.2, +0.9 … +1.1 % at 0.4)."""
    c0 = 0.005
    cracks = [("left", [[-c0, 0.0], [-b0, 0.0]]), ("right", [[b0, 0.0], [c0, 0.0]])]
    res, rows, crack, status = _fatigue(folder, f"fatigue{b0}", cracks, blocks)
    merged = crack == "left+right"
    inc, x, cycles = rows["increment"].astype(int), rows["x"], rows["cycles"]
    assert merged.any() and list(status[status == "merged"]) == ["merged", "merged"]
    assert [m["cracks"] for m in res.summary["fracture"]["merges"]] == [["left", "right"]]
    c_meet = paris_cycles(b0, c0, c0)[1]
    compared = []
    for n in np.unique(inc[merged]):
        here = merged & (inc == n)
        a = 0.5 * (x[here].max() - x[here].min())
        np.testing.assert_allclose(rows["K_I"][here], feddersen(a), rtol=0.02)
        if a > c_meet:
            compared.append(cycles[here][0] / paris_cycles(b0, c0, a)[0] - 1)
    assert len(compared) >= 3
    np.testing.assert_allclose(compared, 0.0, atol=0.02)
    fat = res.summary["fracture"]["crack"]["fatigue"]
    assert fat["status"] == "max_blocks" and set(fat["lengths"]) == {"left+right"}


def _pair_cycles(b0: float, c0: float, b1: float) -> float:
    """Cycles of the closed form's pair b0 ≤ |x| ≤ c0 until the inner tips are at ±b1 (the
    ODE of the inner and outer tips of :func:`paris_cycles`)."""

    def rates(b: float, y: np.ndarray) -> list[float]:  # d(N, c)/db of the pair
        k_in, k_out = _collinear(b, y[1])
        return [-1.0 / (C_PARIS * k_in**M_PARIS), -((k_out / k_in) ** M_PARIS)]

    sol = solve_ivp(rates, (b0, b1), [0.0, c0], rtol=1e-11, atol=1e-14, method="LSODA")
    assert sol.success, sol.message
    return float(sol.y[0, -1])


def test_fatigue_merge_in_the_first_block_is_solved_before_it(
    folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Equal collinear cracks 0.3 mm ≤ |x| ≤ 5 mm under fatigue (m = 2, Δa_max = 0.25 mm):
    a full first block would bring the inner tips within Δa_max and merge them with only
    its start known.  It is shortened — the leading tip grows midway between the floor
    0.6 Δa_max and the length at which the gap would reach Δa_max, 0.1625 mm — and solved;
    the next block, cut where the inner tips meet, merges with ln r continued from those
    two ends.  Against the closed form's pair (the ODE of the inner and outer tips): the
    solved block +1.3 % (measured; the inner K −1.2 %), the cycles to the merge +14.5 %
    (measured) of the pair's cycles until the tips meet, where the one-end rule before
    counted +38.6 % of the pair's cycles to b0 − Δa_max (its merge left a 0.1 mm bridge;
    +31.5 % of the cycles until they meet).  The checkpoint after the shortened block,
    restarted, gives the same rows; every rank count gives the serial table (1e-10)."""
    from bonecontact.runners.cracks import CrackSteps

    b0, c0 = 0.0003, 0.005
    cracks = [("left", [[-c0, 0.0], [-b0, 0.0]]), ("right", [[b0, 0.0], [c0, 0.0]])]
    extra = (
        f"checkpoint_every = 1\n[fracture]\n[fracture.fatigue]\nC = {C_PARIS}\n"
        f"m = {M_PARIS}\nda_max = {DA_MAX}\nmax_blocks = 2\n"
    )
    comm, d = MPI.COMM_WORLD, folder / "first"
    write = CrackSteps.block_checkpoint

    def keep_first(self: CrackSteps, k: int) -> None:  # the checkpoint after block 1 kept
        write(self, k)
        if self.state.increment == 1:
            if self.comm.rank == 0:
                shutil.copytree(self.outdir / "checkpoints" / "step_00000000", d / "block1")
            self.comm.barrier()

    monkeypatch.setattr(CrackSteps, "block_checkpoint", keep_first)
    res, d = run_in(folder, "first", scene_text("first", folder, cracks, extra, None))
    monkeypatch.undo()
    assert res.status == "converged", res.summary.get("message")
    rows, crack, status = _table(d / "out")
    merges = res.summary["fracture"]["merges"]
    assert [m["increment"] for m in merges] == [1] and merges[0]["bridge"] < 0.01 * DA_MAX
    inc, x, cycles = rows["increment"].astype(int), rows["x"], rows["cycles"]
    inner = np.abs(x) < 0.001
    assert list(status[(inc == 0) & inner]) == ["grows", "grows"]
    assert list(status[(inc == 0) & ~inner]) == ["holds", "holds"]  # shares below 0.6 Δa
    assert list(status[(inc == 1) & inner]) == ["merged", "merged"]
    assert rows["K_eq"][(inc == 0) & inner].max() == pytest.approx(_collinear(b0, c0)[0], rel=0.02)
    b1 = np.abs(x[(inc == 1) & inner]).min()  # the leading tip after the shortened block
    assert b0 - b1 == pytest.approx(0.5 * (0.6 * DA_MAX + b0 - 0.5 * DA_MAX), rel=2e-3)
    assert set(crack[inc == 2]) == {"left+right"}
    solved = cycles[inc == 1][0] / _pair_cycles(b0, c0, b1) - 1.0
    assert solved == pytest.approx(0.013, abs=0.005), solved
    err = cycles[inc == 2][0] / _pair_cycles(b0, c0, 1e-8 * c0) - 1.0
    assert err == pytest.approx(0.145, abs=0.01), err

    block1 = d / "again" / "checkpoints" / "step_00000000"
    if comm.rank == 0:
        shutil.copytree(d / "out", d / "again")
        shutil.rmtree(block1)
        shutil.copytree(d / "block1", block1)
    comm.barrier()
    meta = json.loads((block1 / "meta.json").read_text())["crack_run"]
    assert meta["increment"] == 1 and meta["fatigue"]["shortened"] is True
    assert meta["fatigue"]["shortfall"] == pytest.approx(DA_MAX - (b0 - b1), rel=1e-5)
    again = run_scene(load_scene(d / "scene.toml"), comm, d / "again", False, block1)
    assert again.status == "converged", again.summary.get("message")
    idle_barrier(comm)
    full, cont = read_csv(d / "out" / "fracture.csv"), read_csv(d / "again" / "fracture.csv")
    n = len(full["K_I"])
    assert len(cont["K_I"]) == n
    for key in ("increment", "x", "y", "K_I", "K_eq", "cycles"):
        np.testing.assert_allclose(cont[key], full[key], rtol=1e-10, atol=1e-10, err_msg=key)
    assert again.summary["fracture"]["merges"] == merges
    ref = serial_reference(d)
    idle_barrier(comm)
    same_tables(d / "out" / "fracture.csv", ref / "fracture.csv")


def test_joined_cracks_stop_with_the_key_or_at_a_t_junction(folder: Path) -> None:
    """``joined = "stop"``: the equal cracks stop ``joined`` when their inner tips meet
    (after four increments, as before merging existed); a crack growing into the flank of
    a crossing crack (a T) is not merged: the run stops ``joined`` and says why."""
    left, right = CASES["equal"]
    _, outer = collinear_k(0.001, 0.005, SIGMA)
    res, rows, crack, status = _grow(
        folder, "stop", [("left", left), ("right", right)], 1.01 * outer, 'joined = "stop"\n'
    )
    frac = res.summary["fracture"]
    assert frac["crack"]["propagation"]["status"] == "joined" and frac["merges"] == []
    assert frac["crack"]["propagation"]["increments"] == 4 and "merged" not in status
    assert frac["joined"] == '[fracture] joined = "stop"'
    tee = [("across", [[-0.002, 0.0], [-0.0003, 0.0]]), ("along", [[0.0, -0.003], [0.0, 0.003]])]
    k_ic = 0.8 * SIGMA * math.sqrt(math.pi * 0.00085)  # below the K of "across" alone
    res, rows, crack, status = _grow(folder, "tee", tee, k_ic)
    frac = res.summary["fracture"]
    assert frac["crack"]["propagation"]["status"] == "joined" and frac["merges"] == []
    assert "T-junction" in frac["joined"] and "'across'" in frac["joined"], frac["joined"]
    assert list(status[status == "joined"]) == ["joined"]


def test_a_wrong_joined_value_is_refused_naming_the_allowed_ones(folder: Path) -> None:
    left, right = CASES["equal"]
    text = scene_text(
        "bad", folder, [("left", left), ("right", right)], '[fracture]\njoined = "fuse"\n'
    )
    path = folder / "bad.toml"
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(text)
    MPI.COMM_WORLD.barrier()
    with pytest.raises(SceneError) as err:
        load_scene(path)
    msg = str(err.value)
    assert str(path) in msg and "[fracture]" in msg and "joined" in msg
    assert "merge" in msg and "stop" in msg and "fuse" in msg


@pytest.mark.parametrize("kind", ["propagate", "fatigue"])
def test_merged_growth_is_the_same_on_every_rank_count(folder: Path, kind: str) -> None:
    """The unequal cracks grown by K_Ic, the equal ones by fatigue (b/c = 0.2, 6 blocks),
    each through its merge: fracture.csv of this session's ranks equals the serial run's
    (1e-10 of each column's scale), and so do the merge and the merged crack's points."""
    _, outer = collinear_k(0.001, 0.005, SIGMA)
    if kind == "propagate":
        left, right = CASES["unequal"]
        extra = f"[fracture]\npropagate = true\nincrement = {DA}\nmax_increments = 6\n"
        k_ic = 1.01 * outer
    else:
        left, right = CASES["equal"]
        extra = (
            f"[fracture]\n[fracture.fatigue]\nC = {C_PARIS}\nm = {M_PARIS}\n"
            f"da_max = {DA_MAX}\nmax_blocks = 6\n"
        )
        k_ic = None
    text = scene_text(f"ranks_{kind}", folder, [("left", left), ("right", right)], extra, k_ic)
    res, d = run_in(folder, f"ranks_{kind}", text)
    assert res.status == "converged", res.summary.get("message")
    ref = serial_reference(d)
    idle_barrier(MPI.COMM_WORLD)
    same_tables(d / "out" / "fracture.csv", ref / "fracture.csv")
    got = json.loads((d / "out" / "summary.json").read_text())["fracture"]
    want = json.loads((ref / "summary.json").read_text())["fracture"]
    assert [m["into"] for m in got["merges"]] == [m["into"] for m in want["merges"]] != []
    assert got["merges"][0]["increment"] == want["merges"][0]["increment"]
    assert abs(got["merges"][0]["bridge"] - want["merges"][0]["bridge"]) <= 1e-10 * DA
    np.testing.assert_allclose(
        got["crack"]["points"], want["crack"]["points"], rtol=0, atol=1e-10 * W
    )


def test_restart_after_the_merge_gives_the_same_tables(folder: Path) -> None:
    """The equal cracks under fatigue (b/c = 0.2, 6 blocks, a checkpoint every 4 blocks:
    after the merge at the end of block 3) restarted from that checkpoint: the merged
    crack comes back with its name, face pair and phase of the block rule, and the
    restarted run writes the same rows and cycles (1e-10)."""
    left, right = CASES["equal"]
    extra = (
        f"checkpoint_every = 4\n[fracture]\n[fracture.fatigue]\nC = {C_PARIS}\n"
        f"m = {M_PARIS}\nda_max = {DA_MAX}\nmax_blocks = 6\n"
    )
    text = scene_text("restart", folder, [("left", left), ("right", right)], extra, None)
    res, d = run_in(folder, "restart", text)
    assert res.status == "converged", res.summary.get("message")
    comm = MPI.COMM_WORLD
    if comm.rank == 0:
        shutil.copytree(d / "out", d / "again")
    comm.barrier()
    step0 = d / "again" / "checkpoints" / "step_00000000"
    meta = json.loads((step0 / "meta.json").read_text())["crack_run"]
    assert meta["increment"] == 4 and [c["name"] for c in meta["cracks"]] == ["left+right"]
    assert meta["fatigue"]["phases"] == [0, 4] and len(meta["merges"]) == 1
    again = run_scene(load_scene(d / "scene.toml"), comm, d / "again", False, step0)
    assert again.status == "converged", again.summary.get("message")
    assert again.summary["restarted_from"]["step"] == 0
    idle_barrier(comm)
    full, cont = read_csv(d / "out" / "fracture.csv"), read_csv(d / "again" / "fracture.csv")
    n = len(full["K_I"])
    assert len(cont["K_I"]) >= n
    for key in ("increment", "x", "y", "K_I", "K_eq", "cycles"):
        np.testing.assert_allclose(cont[key][-n:], full[key], rtol=1e-10, atol=1e-10, err_msg=key)
    assert again.summary["fracture"]["merges"] == res.summary["fracture"]["merges"]
