"""Several ``[[crack]]`` tables in one 2D body (bonecontact.runners.cracks), run in-process.

A plate [−W, W] × [−H, H] (W = 100 mm, H = 2W; E = 17 GPa, ν = 0.3, plane strain) under
σ_yy = σ on its top and bottom edges, rigid-body motion removed on two short edge pieces
at the bottom-left corner (as tests/unit/runners/test_crack_scene.py).  Every crack is cut
into the body with its own faces (its own contact pair) and its tips get their own rows
in fracture.csv (column ``crack``).  References:

* two equal collinear cracks b ≤ |x| ≤ c on y = 0 (c = 5 mm, c/W = 0.05: the infinite
  plate's closed form, docs/theory/fracture.md#several-cracks): K at the inner tips
  σ√(πc)(E(k)/K(k) − b²/c²)/(k√(b/c)) and at the outer tips σ√(πc)(1 − E(k)/K(k))/k,
  k² = 1 − b²/c², for b/c = 0.1, 0.2, 0.4 (the inner tips 25, 11, 3 % above a single
  crack of the same length) within 2 %;
* two cracks far apart (2 mm each, 50 mm between their centres): each tip's K equal to
  that of the same crack alone in the plate within 1 %, K_II of both ≈ 0;
* three cracks, one inclined: every crack has its rows and its pair in the contact tables;
* crossing, touching and cracks in different regions are refused naming both tables.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import PINNED_PLATE_HEAD, pinned_plate, run_dir
from coupled_support import gmsh_on_rank0, read_csv, run_text
from scipy.special import ellipe, ellipk

from bonecontact.scene import SceneError, load_scene

W, H, PIN = 0.1, 0.2, 0.004  # m
E, NU, SIGMA = 17.0e9, 0.3, 1.0e6
C_OUT = 0.005  # outer tip of the collinear cracks, m

SCENE = (
    PINNED_PLATE_HEAD
    + """{cracks}
[output]
fields_every = 0
{extra}"""
)


def scene_text(
    name: str, folder: Path, cracks: list[tuple[str, list]], extra: str = "", K_Ic=1.0e6
) -> str:
    """The scene ``name`` of the plate in ``folder`` with ``cracks`` (``K_Ic = None``:
    none given)."""
    material = "" if K_Ic is None else f"K_Ic = {float(K_Ic)!r}"
    return SCENE.format(
        name=name,
        mesh=folder / "plate.msh",
        steps=1,
        E=E,
        nu=NU,
        material=material,
        sigma=SIGMA,
        minus_sigma=-SIGMA,
        cracks=crack_tables(cracks),
        extra=extra,
    )


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("several")) if comm.rank == 0 else None))
    gmsh_on_rank0(pinned_plate(-W, W, H, PIN, W / 10), d / "plate.msh", 2)
    return d


def crack_tables(cracks: list[tuple[str, list]], extra: str = "") -> str:
    return "\n".join(
        f'[[crack]]\nname = "{n}"\npoints = {pts}\nregion = "plate"\n{extra}' for n, pts in cracks
    )


def _run(folder: Path, name: str, cracks: list[tuple[str, list]], extra: str = "") -> tuple:
    d = run_dir(folder, name)
    text = scene_text(name, folder, cracks, extra)
    res = run_text(text, d, d / "out")
    assert res.status == "converged", res.summary.get("message")
    rows = read_csv(d / "out" / "fracture.csv")
    names = np.loadtxt(d / "out" / "fracture.csv", delimiter=",", dtype=str, skiprows=1, usecols=3)
    return rows, np.atleast_1d(names), res.summary


def collinear_k(b: float, c: float, sigma: float) -> tuple[float, float]:
    """K at the inner (x = b) and outer (x = c) tips of two equal collinear cracks
    b ≤ |x| ≤ c in an infinite plate under remote tension σ (docs/theory/fracture.md)."""
    k2 = 1.0 - (b / c) ** 2
    kk, ee = ellipk(k2), ellipe(k2)  # scipy: the parameter m = k²
    k = math.sqrt(k2)
    root = sigma * math.sqrt(math.pi * c)
    inner = root * (ee / kk - (b / c) ** 2) / (k * math.sqrt(b / c))
    outer = root * (1.0 - ee / kk) / k
    return inner, outer


@pytest.mark.parametrize("ratio", [0.1, 0.2, 0.4])
def test_two_collinear_cracks_against_the_closed_form(folder: Path, ratio: float) -> None:
    b, c = ratio * C_OUT, C_OUT
    rows, names, summary = _run(
        folder,
        f"collinear{ratio}",
        [("left", [[-c, 0.0], [-b, 0.0]]), ("right", [[b, 0.0], [c, 0.0]])],
    )
    inner, outer = collinear_k(b, c, SIGMA)
    assert list(names) == ["left", "left", "right", "right"]
    x = rows["x"]
    for k_i, x_i in zip(rows["K_I"], x, strict=True):
        ref = inner if abs(abs(x_i) - b) < 1e-9 else outer
        assert k_i == pytest.approx(ref, rel=0.02), (x_i, k_i / ref - 1)
    # the interaction itself, the mesh's common bias (−1 … −1.5 %) divided out
    k_in = rows["K_I"][np.abs(np.abs(x) - b) < 1e-9]
    k_out = rows["K_I"][np.abs(np.abs(x) - c) < 1e-9]
    np.testing.assert_allclose(k_in / k_out, inner / outer, rtol=0.005)
    assert np.max(np.abs(rows["K_II"])) < 0.01 * outer
    assert [c["name"] for c in summary["fracture"]["cracks"]] == ["left", "right"]
    assert summary["fracture"]["crack"]["name"] == "left"


FAR = 0.025  # m, the centres of the separated cracks at x = ±FAR
A_FAR = 0.001  # their half-length, m


@pytest.fixture(scope="module")
def alone(folder: Path) -> dict:
    """The crack at x = +FAR alone in the plate."""
    rows, _, _ = _run(folder, "alone", [("right", [[FAR - A_FAR, 0.0], [FAR + A_FAR, 0.0]])])
    return rows


@pytest.mark.parametrize("dy", [0.0, 0.03], ids=["collinear", "offset"])
def test_separated_cracks_each_as_alone(folder: Path, alone: dict, dy: float) -> None:
    """Two cracks 50 mm apart (25 half-lengths): each tip's K that of the crack alone."""
    cracks = [
        ("left", [[-FAR - A_FAR, dy], [-FAR + A_FAR, dy]]),
        ("right", [[FAR - A_FAR, 0.0], [FAR + A_FAR, 0.0]]),
    ]
    rows, names, _ = _run(folder, f"apart{dy}", cracks)
    right = names == "right"
    np.testing.assert_allclose(rows["x"][right], alone["x"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(rows["K_I"][right], alone["K_I"], rtol=0.01)
    # the left crack, the mirror image of the right one (dy = 0) or shifted: as alone too
    np.testing.assert_allclose(np.sort(rows["K_I"][~right]), np.sort(alone["K_I"]), rtol=0.01)
    ref = SIGMA * math.sqrt(math.pi * A_FAR)
    assert np.max(np.abs(rows["K_II"])) < 0.01 * ref
    np.testing.assert_allclose(alone["K_I"], ref, rtol=0.02)  # the plate is wide


DA = 0.00025  # m, the increment of the growing collinear cracks


def test_each_tip_grows_by_its_own_criterion_until_the_cracks_join(folder: Path) -> None:
    """b/c = 0.2 with K_Ic between the inner and the outer K: at first only the inner tips
    grow, every tip later as its own K_eq reaches K_Ic (the outer tips from the second
    increment); the cracks grow straight and stay collinear, so every increment is again
    the closed form's case (b, c from the table's tips); the run stops when a grown tip
    comes within Δa of the other crack (status ``joined``; ``joined = "stop"``, else the
    cracks would merge)."""
    b, c = 0.2 * C_OUT, C_OUT
    inner, outer = collinear_k(b, c, SIGMA)
    k_ic = 0.5 * (inner + outer)  # 2.8 % from either
    extra = f"[fracture]\npropagate = true\nincrement = {DA}\nmax_increments = 8\n"
    extra += 'joined = "stop"\n'  # merging: tests/unit/runners/test_crack_merge.py
    d = folder / "grow"
    if MPI.COMM_WORLD.rank == 0:
        d.mkdir(exist_ok=True)
    MPI.COMM_WORLD.barrier()
    cracks = [("left", [[-c, 0.0], [-b, 0.0]]), ("right", [[b, 0.0], [c, 0.0]])]
    text = scene_text("grow", folder, cracks, extra, K_Ic=k_ic)
    res = run_text(text, d, d / "out")
    assert res.status == "converged", res.summary.get("message")
    rows = read_csv(d / "out" / "fracture.csv")
    status = np.loadtxt(d / "out" / "fracture.csv", delimiter=",", dtype=str, skiprows=1)[:, -1]
    inc, x = rows["increment"].astype(int), rows["x"]
    is_inner = np.abs(x) < 0.5 * (b + c)
    assert list(status[inc == 0]) == ["holds", "grows", "grows", "holds"]
    grows = np.isin(status, ["grows", "joined"])
    np.testing.assert_array_equal(grows, rows["K_eq"] >= k_ic)  # each tip by its own K
    for n in np.unique(inc):
        here = inc == n
        b_n, c_n = np.abs(x[here & is_inner]).mean(), np.abs(x[here & ~is_inner]).mean()
        np.testing.assert_allclose(np.abs(x[here]), np.where(is_inner[here], b_n, c_n), rtol=1e-6)
        k_in, k_out = collinear_k(b_n, c_n, SIGMA)
        np.testing.assert_allclose(rows["K_I"][here & is_inner], k_in, rtol=0.025)
        np.testing.assert_allclose(rows["K_I"][here & ~is_inner], k_out, rtol=0.025)
    np.testing.assert_allclose(rows["y"], 0.0, atol=1e-2 * DA)  # straight, by symmetry
    # the gap 2b = 2 mm closes by 2Δa an increment: after 4 the inner tips meet
    prop = res.summary["fracture"]["crack"]["propagation"]
    assert prop["status"] == "joined" and prop["increments"] == 4 and not prop["fractured"]
    assert list(status[inc == 3][is_inner[inc == 3]]) == ["joined", "joined"]


C_PARIS, M_PARIS, DA_MAX = 1.0e-30, 4.0, 0.0004  # (m/cycle)/(Pa√m)^m, -, m


def test_several_cracks_grow_by_paris_per_block(folder: Path) -> None:
    """Two collinear cracks (b/c = 0.4) and a short inclined one under fatigue: at every
    block end each tip's share of the block is Δa_max (rate/fastest rate) = Δa_max
    (K_eq/K_eq,max)^m (plus what it kept; grown once ≥ 0.6 Δa_max), the fastest tip of
    all the cracks setting the block's cycles (the block rule on the table's own K_eq,
    to 1e-9); the grown tips are where those shares put them (1e-9)."""
    b, c = 0.4 * C_OUT, C_OUT
    cracks = [
        ("left", [[-c, 0.0], [-b, 0.0]]),
        ("right", [[b, 0.0], [c, 0.0]]),
        ("short", [[-0.001, 0.02], [0.001, 0.021]]),
    ]
    extra = (
        f"[fracture]\n[fracture.fatigue]\nC = {C_PARIS}\nm = {M_PARIS}\nda_max = {DA_MAX}\n"
        "max_blocks = 3\n"
    )
    d = folder / "fatigue"
    if MPI.COMM_WORLD.rank == 0:
        d.mkdir(exist_ok=True)
    MPI.COMM_WORLD.barrier()
    text = scene_text("fatigue", folder, cracks, extra, K_Ic=None)
    res = run_text(text, d, d / "out")
    assert res.status == "converged", res.summary.get("message")
    table = np.loadtxt(d / "out" / "fracture.csv", delimiter=",", dtype=str, skiprows=1)
    rows = read_csv(d / "out" / "fracture.csv")
    inc, names, status = rows["increment"].astype(int), table[:, 3], table[:, -2]
    assert sorted(set(names)) == ["left", "right", "short"] and np.all(inc <= 3)
    kept: dict[tuple[str, int], float] = {}
    for n in range(3):
        here = np.flatnonzero(inc == n)
        k_eq = rows["K_eq"][here]
        share = {
            (names[i], int(rows["tip"][i])): kept.get((names[i], int(rows["tip"][i])), 0.0)
            + DA_MAX * (rows["K_eq"][i] / k_eq.max()) ** M_PARIS
            for i in here
        }
        grows = {t for t, v in share.items() if v >= 0.6 * DA_MAX * (1 - 1e-12)}
        kept = {t: v for t, v in share.items() if t not in grows}
        for i in here:
            key = (names[i], int(rows["tip"][i]))
            assert (status[i] == "grows") == (key in grows), (n, key, share[key])
            later = np.flatnonzero((inc == n + 1) & (names == names[i]) & (rows["tip"] == key[1]))
            if key in grows and later.size:  # straight enough: the advance is the share
                moved = math.hypot(
                    rows["x"][later[0]] - rows["x"][i], rows["y"][later[0]] - rows["y"][i]
                )
                assert moved == pytest.approx(share[key], rel=1e-6), key
    # the block rule on the fastest tip of all the cracks (the table's own K_eq)
    from bonecontact.fracture.fatigue import block_cycles

    lead = np.array([rows["K_eq"][inc == n].max() for n in range(4)])
    rate = C_PARIS * lead**M_PARIS
    s = DA_MAX * np.arange(4)
    ref = np.cumsum(
        [0.0] + [float(block_cycles(s[: i + 1], rate[: i + 1])[-1]) for i in range(1, 4)]
    )
    cyc = np.array([rows["cycles"][inc == n][0] for n in range(4)])
    np.testing.assert_allclose(cyc, ref, rtol=1e-9)
    fat = res.summary["fracture"]["crack"]["fatigue"]
    assert fat["status"] == "max_blocks" and fat["blocks"] == 3
    assert set(fat["lengths"]) == {"left", "right", "short"}


@pytest.mark.parametrize(
    "second, key, where",
    [
        ([[0.0, -0.002], [0.0, 0.002]], "points", 'crosses or touches [[crack]] #1 "a"'),
        ([[0.002, 0.0], [0.004, 0.0]], "points", 'crosses or touches [[crack]] #1 "a"'),
    ],
    ids=["crossing", "touching"],
)
def test_cracks_that_meet_are_refused_naming_file_and_both(
    folder: Path, second: list, key: str, where: str
) -> None:
    text = scene_text("refused", folder, [("a", [[-0.002, 0.0], [0.002, 0.0]]), ("b", second)], "")
    path = folder / "refused.toml"
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(text)
    MPI.COMM_WORLD.barrier()
    with pytest.raises(SceneError) as err:
        load_scene(path)
    msg = str(err.value)
    assert str(path) in msg and f'[[crack]] #2 "b", key "{key}"' in msg and where in msg


@pytest.mark.serial
def test_several_cracks_same_answer_on_1_2_3_ranks(folder: Path) -> None:
    """The growing collinear cracks (b/c = 0.2, to ``joined``) through the command on 1, 2
    and 3 ranks: the same dofs, tips and K (1e-8 relative)."""
    from cli_support import run_scene

    b, c = 0.2 * C_OUT, C_OUT
    inner, outer = collinear_k(b, c, SIGMA)
    extra = f"[fracture]\npropagate = true\nincrement = {DA}\nmax_increments = 8\n"
    extra += 'joined = "stop"\n'  # merging: tests/unit/runners/test_crack_merge.py
    cracks = [("left", [[-c, 0.0], [-b, 0.0]]), ("right", [[b, 0.0], [c, 0.0]])]
    text = scene_text("ranks", folder, cracks, extra, K_Ic=0.5 * (inner + outer))
    path = folder / "ranks.toml"
    path.write_text(text)
    tabs, dofs = [], []
    for n in (1, 2, 3):
        out = folder / f"ranks{n}"
        res = run_scene(path, out, n, timeout=1200)
        assert res.returncode == 0, res.stderr
        tabs.append(read_csv(out / "fracture.csv"))
        dofs.append(json.loads((out / "summary.json").read_text())["dofs"])
    assert dofs[1] == dofs[0] and dofs[2] == dofs[0]
    for tab in tabs[1:]:
        assert len(tab["K_I"]) == len(tabs[0]["K_I"]) == 16
        for key in ("x", "y", "K_I", "K_II", "J"):
            scale = np.max(np.abs(tabs[0][key])) or 1.0
            np.testing.assert_allclose(tab[key], tabs[0][key], rtol=1e-8, atol=1e-8 * scale)
