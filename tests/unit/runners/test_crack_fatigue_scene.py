"""A crack scene with ``[fracture.fatigue]`` through the ``bonecontact`` command
(bonecontact.runners.cracks, bonecontact.runners.crack_fatigue; docs/scene_format.md).

The strip [0, W] × [−H, H] (W = 20 mm, H = 2W; E = 17 GPa, ν = 0.3, plane strain) under
σ_yy = 1 MPa on its top and bottom edges (the peak of the cycle), rigid-body motion removed
on two 2 mm edge pieces at the bottom-left corner, an edge crack of a0 = 6 mm from the left
edge at y = 0; C = 1e-30 (m/cycle)/(Pa√m)^m, m = 4, Δa_max = 2 mm.

* To fracture: 6 blocks, the tip at W − Δa_max, status ``fractured`` in summary.json; the
  ``cycles`` column is the block rule applied to the table's own K_eq (to 1e-9: the
  bookkeeping) and within 7 % of the Paris law integrated with Tada's factor (measured
  +4.2 … +4.5 %: the scene's 2 mm cells, tip 0.1 mm, blocks of a0/3; the 2 % check on a
  fine mesh is tests/verification/test_fracture_fatigue.py); the bound of the cycles to
  separation is at least the closed form to a = W.
* The stops, each with the reference's K and cycles up to it (1e-9): ΔK_th above the
  first ΔK (``arrested``, no block), a K_Ic reached after 4 blocks (``K_Ic``),
  and ``max_blocks = 2`` with R = 0.5 (the same crack and K, the cycles × (1 − R)^−m = 16)
  in a 2-step ramp (step 1 ``stationary`` at half the K, blocks at step 2 only).
* A restart from the checkpoint written after block 4 gives the same tables (1e-10).
* On 2 ranks (slow): the same cycles (1e-6).
"""

from __future__ import annotations

import csv
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from _crack_scenes import PINNED_PLATE_HEAD, pinned_plate
from cli_support import run_scene
from coupled_support import gmsh_on_rank0
from scipy.integrate import quad

from bonecontact.fracture.fatigue import block_cycles

pytestmark = pytest.mark.serial

W, H, PIN = 0.02, 0.04, 0.002  # m
A0, DA = 0.006, 0.002  # m
SIGMA, C, M = 1.0e6, 1.0e-30, 4.0
TIP = 1.0e-4  # m

SCENE = (
    PINNED_PLATE_HEAD
    + """[[crack]]
name = "c"
points = [[0.0, 0.0], [{a0}, 0.0]]
tips = "end"
region = "plate"
[fracture]
tip_size = {tip}
tip_grading = 0.12
[fracture.fatigue]
C = {C}
m = {m}
da_max = {da}
{fatigue}
[output]
fields_every = 0
checkpoint_every = {every}
"""
)


def _mesh(path: Path, h: float = 0.002) -> None:
    """The strip with its edge groups (pin_y, bottom, right, top, left, pin_x)."""
    gmsh_on_rank0(pinned_plate(0.0, W, H, PIN, h), path, 2)


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("fatigue_scene")
    _mesh(tmp / "strip.msh")
    return tmp


def _scene(folder: Path, name: str, fatigue: str = "", **kw) -> Path:
    values = {"steps": 1, "K_Ic": "", "every": 0, "fatigue": fatigue, "tip": TIP}
    path = folder / f"{name}.toml"
    values |= {"name": "sent", "E": 17.0e9, "nu": 0.3, "sigma": SIGMA, "minus_sigma": -SIGMA}
    values = values | kw
    values["material"] = values.pop("K_Ic")
    text = SCENE.format(mesh=folder / "strip.msh", a0=A0, C=C, m=M, da=DA, **values)
    path.write_text(text)
    return path


def _run(scene: Path, out: Path, n: int = 1, *extra: str) -> tuple[list[dict], dict]:
    res = run_scene(scene, out, n, *extra)
    assert res.returncode == 0, res.stderr
    rows = list(csv.DictReader(open(out / "fracture.csv")))
    return rows, json.loads((out / "summary.json").read_text())


def _col(rows: list[dict], name: str) -> np.ndarray:
    return np.array([float(r[name]) for r in rows])


def tada_cycles(a0: float, a1: float, R: float = 0.0) -> float:
    """The Paris law integrated with Tada's factor of the edge-cracked strip."""

    def dn_da(a: float) -> float:
        t = math.pi * a / (2 * W)
        f = math.sqrt(math.tan(t) / t) * (0.752 + 2.02 * a / W + 0.37 * (1 - math.sin(t)) ** 3)
        dk = (1 - R) * SIGMA * math.sqrt(math.pi * a) * f / math.cos(t)
        return 1.0 / (C * dk**M)

    return quad(dn_da, a0, a1, epsabs=0.0, epsrel=1e-12, limit=200)[0]


@pytest.fixture(scope="module")
def reference(folder: Path) -> tuple[list[dict], dict]:
    """The run to fracture, with a checkpoint after every 4th block."""
    return _run(_scene(folder, "ref", every=4), folder / "ref")


def _causal_cycles(rows: list[dict], R: float = 0.0) -> np.ndarray:
    """N at every block end by the block rule over the ends known at it (from the table)."""
    rate = C * ((1 - R) * _col(rows, "K_eq")) ** M
    s = DA * _col(rows, "increment")
    n = [0.0] + [float(block_cycles(s[: i + 1], rate[: i + 1])[-1]) for i in range(1, len(s))]
    return np.cumsum(n)


def test_edge_crack_grows_to_fracture(reference) -> None:
    rows, summary = reference
    fatigue = summary["fracture"]["crack"]["fatigue"]
    assert summary["status"] == "converged"
    assert [r["status"] for r in rows] == ["grows"] * 6 + ["fractured"]
    assert _col(rows, "increment").tolist() == list(range(7))
    assert _col(rows, "length") == pytest.approx(A0 + DA * np.arange(7), abs=1e-8)
    assert abs(_col(rows, "y")).max() < 1e-4  # mode I: straight
    cycles = _col(rows, "cycles")
    assert cycles == pytest.approx(_causal_cycles(rows), rel=1e-9)
    for a, n in zip(_col(rows, "length")[1:], cycles[1:], strict=True):
        assert n == pytest.approx(tada_cycles(A0, a), rel=0.07), a
    assert (fatigue["status"], fatigue["blocks"], fatigue["fractured"]) == ("fractured", 6, True)
    assert fatigue["cycles"] == pytest.approx(cycles[-1], rel=1e-12)
    assert fatigue["length"] == pytest.approx(W, abs=1e-8)  # the last block reaches the edge
    assert cycles[-1] < fatigue["cycles_bound"]
    assert fatigue["cycles_bound"] >= tada_cycles(A0, W)
    assert (fatigue["C"], fatigue["m"], fatigue["da_max"]) == (C, M, DA)


@pytest.mark.parametrize(
    "name, fatigue, K_Ic, steps, statuses, blocks",
    [
        ("arrest", "delta_K_th = 3.0e5", "", 1, ["arrested"], 0),
        ("toughness", "", "K_Ic = 1.0e6", 1, ["grows"] * 4 + ["K_Ic"], 4),
        (
            "ramp",
            "max_blocks = 2\nR = 0.5",
            "",
            2,
            ["stationary", "grows", "grows", "max_blocks"],
            2,
        ),
    ],
)
def test_the_blocks_stop(folder, reference, name, fatigue, K_Ic, steps, statuses, blocks) -> None:
    rows, summary = _run(_scene(folder, name, fatigue, K_Ic=K_Ic, steps=steps), folder / name)
    fat = summary["fracture"]["crack"]["fatigue"]
    assert [r["status"] for r in rows] == statuses
    assert (fat["status"], fat["blocks"], fat["fractured"]) == (statuses[-1], blocks, False)
    peak = [r for r in rows if int(r["step"]) == steps]
    ref = reference[0][: len(peak)]
    assert _col(peak, "K_eq") == pytest.approx(_col(ref, "K_eq"), rel=1e-9)
    scale = 2.0**M if "R = 0.5" in fatigue else 1.0  # ΔK = (1 - R) K_max: N × (1 - R)^-m
    assert _col(peak, "cycles") == pytest.approx(_col(ref, "cycles") * scale, rel=1e-9)
    if name == "toughness":
        assert _col(rows, "K_eq")[-1] >= 1.0e6 > _col(rows, "K_eq")[:-1].max()
    if name == "ramp":  # the ramp: half the load, K halved, no cycles
        assert float(rows[0]["K_eq"]) == pytest.approx(0.5 * float(rows[1]["K_eq"]), rel=1e-6)
        assert float(rows[0]["cycles"]) == 0.0


def test_restart_between_blocks_gives_the_same_tables(folder: Path, reference) -> None:
    out = folder / "restart"
    shutil.copytree(folder / "ref", out)
    step0 = out / "checkpoints" / "step_00000000"
    meta = json.loads((step0 / "meta.json").read_text())
    assert meta["crack_run"]["increment"] == 4 and len(meta["crack_run"]["fatigue"]["cycles"]) == 4
    rows, summary = _run(folder / "ref.toml", out, 1, "--restart", str(step0))
    assert summary["restarted_from"]["step"] == 0
    assert (out / "fields_restart1_crack.vtk").is_file()
    ref = reference[0]
    assert [r["status"] for r in rows] == [r["status"] for r in ref]
    for col in ("increment", "x", "y", "length", "K_I", "K_eq", "cycles"):
        assert _col(rows, col) == pytest.approx(_col(ref, col), rel=1e-10, abs=1e-12), col
    assert summary["fracture"]["crack"]["fatigue"]["cycles"] == pytest.approx(
        reference[1]["fracture"]["crack"]["fatigue"]["cycles"], rel=1e-10
    )
    shutil.rmtree(out)


@pytest.mark.slow
def test_two_ranks_give_the_same_cycles(folder: Path, reference) -> None:
    rows, summary = _run(_scene(folder, "ranks2"), folder / "ranks2", 2)
    assert [r["status"] for r in rows] == [r["status"] for r in reference[0]]
    assert _col(rows, "cycles") == pytest.approx(_col(reference[0], "cycles"), rel=1e-6)
