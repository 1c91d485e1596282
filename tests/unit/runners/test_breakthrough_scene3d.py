"""An interior crack that reaches the surface becomes a surface crack and grows on
(``[fracture] breakthrough = "surface_crack"``; runners.breakthrough3d,
docs/theory/fracture.md#an-interior-crack-that-reaches-the-surface).

The block [−4a, 4a]³ of test_crack_fatigue_scene3d.py (a = 1 mm, rollers on xmin, ymin,
zmin, σ = 1 MPa on top, E = 17 GPa, ν = 0.3) with a penny of radius a normal to the load
near the free face x = 4a, front a/8 (the octagon), cycled with R = 0.1, C = 1e-20,
m = 3, Δa_max = 0.1a; coarse (no accuracy asserted: what is checked is the chaining).

* fatigue, the penny at x = 2.1a: the first block brings it to 2.1a + 1.1a, the next
  would bring its front within the ligament 6 h = 0.75a of x = 4a: the interior phase
  stops ``through`` after solve 1; the re-characterised crack equals the rule applied
  by hand to the recorded final front (depth = 4a − min x, half-length = half the y
  extent, ligament = 4a − max x, centre (4a, mid y, z)); fracture.csv one table with
  increments 0 … 3, the re-characterised rows ``breaks_surface`` at the cycles of their
  solve, the cycles non-decreasing and continuous (the surface phase's first rows at
  those cycles); one crack_surface_<k>.vtk per increment;
* the second path: the surface-crack scene written directly with that crack (its
  centre, depth, half-length, the front size the run chose) grown one block gives the
  surface phase's K, depth, half-length and (plus the interior cycles) cycles to 1e-10;
* 2 (3) ranks: fracture.csv, the stop, the cycles as serially to 1e-10;
* fatigue, the penny at x = 2.28a (through after the first solve, no cycles yet) with
  K_Ic between the interior's and the surface crack's K: the surface crack runs unstably
  at once (``fractured``), the fragments the block split in two (volumes sum to 8W³);
* one load (``propagate``, K_Ic below every K, Δa = 1.5a), the penny at 2.28a:
  interior ``fractured`` at the surface after solve 0, the surface crack lengthens by
  1.5a and its next increment reaches the faces y = ±4a: ``through`` after two surface
  solves, the fragments the block's halves, the cycles column 0;
* restart: the serial run's checkpoint before the last interior block continued on every
  rank of the session gives the serial run to 1e-10, solving from that block on;
* refusals: restart without a checkpoint; two cracks; an unknown value (naming the
  allowed values); a scene that does not grow its crack.
"""

from __future__ import annotations

import json
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import (
    block_mesh,
    continued_run,
    idle_barrier,
    read_table,
    run_in,
    serial_reference,
    write_scene,
)

from bonecontact.common.errors import CheckpointError
from bonecontact.runners import run_scene
from bonecontact.scene import SceneError, load_scene
from bonecontact.verification.problems import crack_block_scene

A = 1.0e-3
W = 4 * A
H = A / 8
DA = 0.1 * A
K_COLS = ("K_I", "K_II", "K_III", "G", "K_V", "kink_deg")


def _growth(fatigue: bool, blocks: int, step: float = DA) -> str:
    if fatigue:
        return (
            f"[fracture.fatigue]\nC = 1e-20\nm = 3.0\nR = 0.1\nda_max = {DA!r}\n"
            f"max_blocks = {blocks}\n"
        )
    return f"propagate = true\nincrement = {step!r}\nmax_increments = {blocks}\n"


def _scene(
    mesh: Path,
    x0: float,
    *,
    fatigue=True,
    blocks=3,
    k_ic="",
    rule="surface_crack",
    every=0,
    step=DA,
):
    geometry = f"centre = [{x0 * A!r}, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = {A!r}"
    text = crack_block_scene(str(mesh), geometry, E=17.0e9, nu=0.3, sigma=1.0e6, h=H, points=1)
    text = text.replace("sigma_t = 133e6", f"sigma_t = 133e6\n{k_ic}")
    text = text.replace("fields_every = 0", f"fields_every = 0\ncheckpoint_every = {every}")
    growth = _growth(fatigue, blocks, step)
    head = f'[fracture]\nbreakthrough = "{rule}"\n' if rule else "[fracture]\n"
    text = text.replace("[fracture]\n", head + ("" if fatigue else growth), 1)
    if fatigue:
        text = text.replace("[[crack]]", f"{growth}\n[[crack]]", 1)
    return text


@pytest.fixture(scope="module")
def mesh(tmp_path_factory) -> Path:
    return block_mesh(tmp_path_factory, "breakthrough3d", W)


def _run(mesh: Path, name: str, **kw):
    res, d = run_in(mesh, name, _scene(mesh / "block.msh", **kw))
    assert res.status == "converged", res.summary.get("message")
    idle_barrier(MPI.COMM_WORLD)
    return res, d


def _numeric(col: np.ndarray) -> np.ndarray:
    """A column of the two phases' table as numbers (empty cells NaN), text if it is."""
    if col.dtype.kind == "f":
        return col
    try:
        return np.array([float(v) if v != "" else np.nan for v in col])
    except ValueError:
        return col


def _same_tables(got: Path, ref: Path) -> None:
    """:func:`same_tables` for fracture.csv of both phases (empty cells in the columns
    one phase does not have): text exactly, numbers to 1e-10 of their scale."""
    a, b = read_table(got), read_table(ref)
    assert list(a) == list(b)
    for key in b:
        x, y = _numeric(a[key]), _numeric(b[key])
        if y.dtype.kind != "f":
            assert list(x) == list(y), key
            continue
        scale = np.nanmax(np.abs(_numeric(b["K_I"]) if key.startswith("K_") else y)) or 1.0
        scale = 360.0 if key.endswith("_deg") else scale
        np.testing.assert_allclose(
            x, y, rtol=1e-10, atol=1e-10 * scale, equal_nan=True, err_msg=key
        )


def _by_hand(front: np.ndarray) -> dict[str, float]:
    """The rule on the flat face x = W (outward e = x, axis t = n × e = y)."""
    return {
        "depth": W - front[:, 0].min(),
        "half_length": 0.5 * np.ptp(front[:, 1]),
        "ligament": W - front[:, 0].max(),
        "height": np.ptp(front[:, 0]),
    }


def _check_rule(summary: dict) -> dict:
    fr = summary["fracture"]
    front = np.asarray(fr["interior"]["crack"]["front"])
    crack = fr["breakthrough"]["crack"]
    for key, want in _by_hand(front).items():
        assert crack[key] == pytest.approx(want, rel=1e-12, abs=1e-15), key
    mid_y = 0.5 * (front[:, 1].max() + front[:, 1].min())
    np.testing.assert_allclose(crack["centre"], [W, mid_y, front[:, 2].mean()], atol=1e-12 * A)
    np.testing.assert_allclose(crack["axis"], [0.0, 1.0, 0.0], atol=1e-14)
    assert crack["depth"] == pytest.approx(crack["ligament"] + crack["height"], rel=1e-14)
    return crack


@pytest.fixture(scope="module")
def fatigue(mesh: Path):
    return _run(mesh, "fatigue", x0=2.1, blocks=4, every=1)


@pytest.fixture(scope="module")
def serial(fatigue) -> Path:
    """The serial run of the fatigue scene (the run itself on one rank)."""
    return serial_reference(fatigue[1])


def test_recharacterised_by_the_rule(fatigue) -> None:
    res, _ = fatigue
    fr = res.summary["fracture"]
    assert fr["interior"]["growth"]["status"] == "through"
    assert fr["interior"]["growth"]["increments"] == 2
    assert len(fr["interior"]["crack"]["front"]) == 8
    crack = _check_rule(res.summary)
    # the octagon grown two blocks: within 6 h + Δa_max of the face, over twice as deep
    # as long
    assert 0.65 * A < crack["ligament"] < 0.85 * A and crack["depth"] > 2.0 * crack["half_length"]
    assert fr["breakthrough"]["increment"] == 3 and fr["growth"]["status"] == "max_blocks"


def test_one_table_cycles_continue(fatigue) -> None:
    res, d = fatigue
    fr = res.summary["fracture"]
    t = read_table(d / "out" / "fracture.csv")
    assert list(t["phase"]) == ["interior"] * 24 + ["surface"] * 6
    assert list(t["increment"]) == [0] * 8 + [1] * 8 + [2] * 8 + [3] * 3 + [4] * 3
    status = ["grows"] * 16 + ["breaks_surface"] * 8 + ["grows"] * 3 + ["max_blocks"] * 3
    assert list(t["status"]) == status
    cyc = t["cycles"]
    assert np.all(np.diff(cyc) >= 0) and cyc[8] > 0
    n2 = fr["interior"]["growth"]["history"][-1]["cycles"]
    assert fr["breakthrough"]["cycles"] == n2 and np.all(cyc[16:27] == n2)  # continuous
    assert cyc[-1] > n2 and fr["growth"]["cycles"] == pytest.approx(cyc[-1], rel=1e-12)
    assert fr["growth"]["increments"] == 4
    crack = fr["breakthrough"]["crack"]
    np.testing.assert_allclose(t["depth"][24:27].astype(float), crack["depth"], rtol=1e-12)
    if MPI.COMM_WORLD.rank == 0:
        out = d / "out"
        assert sorted(p.name for p in out.glob("crack_surface_*.vtk")) == [
            f"crack_surface_{k}.vtk" for k in range(5)
        ]
        assert not (out / "fracture_interior.csv").exists()


@pytest.mark.two_ranks  # no rank comparison: serial and 2 ranks only
def test_surface_phase_equals_a_direct_surface_scene(mesh: Path, fatigue) -> None:
    """The second path: the re-characterised crack as a scene's own surface crack."""
    res, d = fatigue
    fr = res.summary["fracture"]
    crack, h = fr["breakthrough"]["crack"], fr["breakthrough"]["front_size"]
    text = (d / "scene.toml").read_text()
    start = text.index("[[crack]]")
    text = text[:start] + (
        f'[[crack]]\nname = "penny"\nshape = "semi_elliptical"\ncentre = {crack["centre"]!r}\n'
        f"normal = [0.0, 0.0, 1.0]\ndepth = {crack['depth']!r}\n"
        f'half_length = {crack["half_length"]!r}\nregion = "block"\nfront_points = 1\n'
        "[output]\nfields_every = 0\n"
    )
    text = text.replace('breakthrough = "surface_crack"\n', "")
    text = text.replace(f"tip_size = {H!r}", f"tip_size = {h!r}").replace(
        "max_blocks = 4", "max_blocks = 1"
    )
    direct, dd = run_in(mesh, "direct", text)
    assert direct.status == "converged", direct.summary.get("message")
    idle_barrier(MPI.COMM_WORLD)
    got = read_table(d / "out" / "fracture.csv")
    want = read_table(dd / "out" / "fracture.csv")
    surf = got["phase"] == "surface"
    n1 = fr["breakthrough"]["cycles"]
    assert list(got["increment"][surf]) == list(want["increment"] + 3)
    scale = np.abs(want["K_I"]).max()
    for key in ("K_I", "K_II", "K_III", "K_V"):
        np.testing.assert_allclose(got[key][surf], want[key], rtol=0, atol=1e-10 * scale)
    for key in ("depth", "half_length", "x", "y", "z"):
        col = got[key][surf].astype(float)  # the interior rows leave depth empty
        np.testing.assert_allclose(col, want[key], rtol=0, atol=1e-10 * A)
    np.testing.assert_allclose(got["cycles"][surf], want["cycles"] + n1, rtol=1e-10)
    g = direct.summary["fracture"]["growth"]
    assert fr["growth"]["cycles"] == pytest.approx(g["cycles"] + n1, rel=1e-10)


@pytest.mark.skipif(MPI.COMM_WORLD.size == 1, reason="compares a distributed run with a serial one")
def test_same_answer_on_any_rank_count(fatigue, serial: Path) -> None:
    res, d = fatigue
    ref = serial
    idle_barrier(MPI.COMM_WORLD)
    _same_tables(d / "out" / "fracture.csv", ref / "fracture.csv")
    want = json.loads((ref / "summary.json").read_text())["fracture"]
    got = res.summary["fracture"]
    assert got["growth"]["status"] == want["growth"]["status"]
    assert got["growth"]["cycles"] == pytest.approx(want["growth"]["cycles"], rel=1e-10)
    for key, v in want["breakthrough"]["crack"].items():
        np.testing.assert_allclose(got["breakthrough"]["crack"][key], v, rtol=1e-10, atol=1e-13)


@pytest.mark.two_ranks  # no rank comparison: serial and 2 ranks only
def test_fractures_once_at_the_surface(mesh: Path) -> None:
    """K_Ic = 45 kPa√m between the interior K (≤ 38 kPa√m) and the surface crack's
    (≈ 49 kPa√m at its surface points): it fractures at its first solve."""
    res, d = _run(mesh, "unstable", x0=2.28, k_ic="K_Ic = 45e3")
    fr = res.summary["fracture"]
    assert fr["interior"]["growth"]["status"] == "through"
    assert fr["interior"]["growth"]["increments"] == 0
    _check_rule(res.summary)
    g = fr["growth"]
    assert g["status"] == "fractured" and g["fractured"] and g["increments"] == 1
    assert g["cycles"] == 0.0  # no block made before the transition, none after it
    vols = [f["volume"] for f in g["fragments"]]
    assert len(vols) == 2 and min(vols) > 0
    assert sum(vols) == pytest.approx((2 * W) ** 3, rel=1e-10)
    t = read_table(d / "out" / "fracture.csv")
    assert list(t["status"]) == ["breaks_surface"] * 8 + ["fractured"] * 3
    assert t["K_V"][8:].max() >= 45e3 > t["K_V"][:8].max()


def test_restart_from_an_interior_checkpoint(fatigue, serial: Path) -> None:
    """The serial run's checkpoint before interior block 2 (the last interior solve)
    continued on every rank of the session: it solves increments 2 … 4 only (the
    re-characterisation and the surface phase again) and gives the serial fracture.csv,
    stop, cycles and re-characterised crack to 1e-10."""
    _, d = fatigue
    cont, out = continued_run(d, serial, 2)
    idle_barrier(MPI.COMM_WORLD)
    _same_tables(out / "fracture.csv", serial / "fracture.csv")
    want = json.loads((serial / "summary.json").read_text())["fracture"]
    got = cont.summary["fracture"]
    assert got["growth"]["status"] == want["growth"]["status"] == "max_blocks"
    assert got["growth"]["cycles"] == pytest.approx(want["growth"]["cycles"], rel=1e-10)
    for key, v in want["breakthrough"]["crack"].items():
        np.testing.assert_allclose(got["breakthrough"]["crack"][key], v, rtol=1e-10, atol=1e-13)


@pytest.mark.two_ranks  # no rank comparison: serial and 2 ranks only
def test_one_load_runs_through(mesh: Path) -> None:
    """One load with Δa = 1.5a: the surface crack's surface points (K_V ≈ 49 kPa√m, the
    deepest 28.5) lengthen it by 1.5a per increment; the second increment would bring its
    ends (c = 3.9a) to the faces y = ±4a: ``through`` after two surface solves, the
    fragments the block cut by the crack plane z = 0."""
    res, d = _run(
        mesh, "through", x0=2.28, fatigue=False, blocks=5, k_ic="K_Ic = 1e4", step=1.5 * A
    )
    fr = res.summary["fracture"]
    assert fr["interior"]["growth"]["status"] == "fractured"
    g = fr["growth"]
    assert g["status"] == "through" and g["fractured"] and g["increments"] == 2
    vols = [f["volume"] for f in g["fragments"]]
    assert sum(vols) == pytest.approx((2 * W) ** 3, rel=1e-10)
    assert vols == pytest.approx([0.5 * (2 * W) ** 3] * 2, rel=1e-3)  # cells split by midpoint
    t = read_table(d / "out" / "fracture.csv")
    assert list(t["status"]) == ["breaks_surface"] * 8 + ["grows"] * 3 + ["through"] * 3
    assert list(t["increment"]) == [0] * 8 + [1] * 3 + [2] * 3 and np.all(t["cycles"] == 0.0)
    c, depth = (t[k][8:].astype(float) for k in ("half_length", "depth"))
    w = (t["K_V"][8:11] / t["K_V"][8:11].max()) ** 2  # the three points, all above K_Ic
    # to the grid of the advances, 2^-20 of the step (on_advance_grid)
    assert c[3] == pytest.approx(c[0] + 0.75 * A * (w[0] + w[2]), abs=1e-6 * 1.5 * A)
    assert depth[3] == pytest.approx(depth[0] + 1.5 * A * w[1], abs=1e-6 * 1.5 * A)


def test_refusals(mesh: Path, fatigue) -> None:
    _, d = fatigue
    with pytest.raises(CheckpointError, match="no growth checkpoint"):
        run_scene(load_scene(d / "scene.toml"), MPI.COMM_WORLD, output=d / "again", restart=True)
    text = _scene(mesh / "block.msh", 2.1)
    bad = write_scene(d / "bad.toml", text.replace('"surface_crack"', '"continue"'))
    with pytest.raises(SceneError, match=r"bad\.toml.*\[fracture\].*breakthrough.*surface_crack"):
        load_scene(bad)
    second = '[[crack]]\nname = "second"\ncentre = [-0.002, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n'
    second += f'radius = {A!r}\nregion = "block"\nfront_points = 1\n'
    two = write_scene(d / "two.toml", text + second)
    with pytest.raises(SceneError, match=r"two\.toml.*breakthrough.*single growing interior"):
        load_scene(two)
    still = _scene(mesh / "block.msh", 2.1).replace("[fracture.fatigue]", "[fatigue_off]")
    still = still[: still.index("[fatigue_off]")] + still[still.index("[[crack]]") :]
    still = write_scene(d / "still.toml", still)
    with pytest.raises(SceneError, match=r"still\.toml.*breakthrough.*applies to a growing crack"):
        load_scene(still)
