"""Restart through the ``bonecontact`` command: a stopped run continued from its checkpoint
gives the tables of an uninterrupted run.

The scene: a dynamic 2D contact with Coulomb friction (μ = 0.3; a cylinder pressed into
a block and dragged sideways by its top, then held; stick and slip nodes, the active set
grows during the run), 20 steps, checkpoints every 4 steps.

* Stopped run: the same scene with ``t_end`` at step 10, continued with
  ``--restart <checkpoint of step 8>`` to step 20 (the rows of steps 9 and 10 are cut):
  history.csv, probes.csv and contact_<pair>.csv equal those of the uninterrupted run to
  1e-10 of each value plus the column's magnitude (the restarted run refactorises: the
  low-rank updates of the direct solver differ by round-off); every step appears once;
  the summary's iteration totals and final energy equal the uninterrupted run's.  On 1
  and 2 ranks, and across rank counts (2 → 1, 1 → 3).
* SIGTERM (1 and 2 ranks): exit 143, status "interrupted", a checkpoint of the last
  recorded step; the restart completes the run with the uninterrupted run's rows.
* Refused restarts exit 2 with a message: no checkpoint, another time step.
* One rank killed (SIGKILL; serially the process, on 2 ranks rank 1) at a seeded step:
  the run ends within 60 s (no hang), and the restart from the last intact checkpoint
  completes the run with the uninterrupted rows.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
from pathlib import Path

import numpy as np
import pytest
from cli_support import (
    IMPACT_A,
    finish,
    impact_scene,
    rank_pids,
    run_scene,
    start_scene,
    wait_for_lines,
)

pytestmark = pytest.mark.serial

A_REF = IMPACT_A  # contact zone size of the mesh (m)
WORDS = ("hertz", "open", "stick", "slip")


def _scene(mesh: Path, t_end: float, every: int = 4) -> str:
    return impact_scene(mesh, t_end, every, fields_every=5, probes=[(0.0, 0.005)])


_run = run_scene


def _table(path: Path) -> tuple[list[str], np.ndarray, list[str]]:
    rows = list(csv.reader(open(path)))
    num = np.array([[0.0 if v in WORDS else float(v) for v in r] for r in rows[1:]])
    return rows[0], num, [r[-1] for r in rows[1:]]


def _assert_same_tables(ref: Path, out: Path) -> float:
    """Every table of ``out`` equals that of ``ref`` to 1e-10 (value + column magnitude,
    floored at 1e-3 of the contact zone); returns the largest relative difference."""
    worst = 0.0
    for name in ("history.csv", "probes.csv", "contact_hertz.csv"):
        h1, a1, s1 = _table(ref / name)
        h2, a2, s2 = _table(out / name)
        assert h1 == h2 and a1.shape == a2.shape, name
        if name == "contact_hertz.csv":
            assert s1 == s2  # open / stick / slip node by node
        scale = np.maximum(np.abs(a1).max(axis=0), 1e-3 * A_REF)
        rel = np.abs(a2 - a1) / (np.abs(a1) + scale)
        assert rel.max() <= 1e-10, f"{name}: rows/cols {np.argwhere(rel > 1e-10)[:5].tolist()}"
        worst = max(worst, float(rel.max()))
    return worst


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """The mesh, the scenes (20 steps; stopped at 10) and the uninterrupted runs."""
    from bonecontact.meshing import shapes as meshing

    tmp = tmp_path_factory.mktemp("restart")
    mesh = meshing.hertz_2d(
        None, path=tmp / "hertz.msh", h_contact=A_REF / 4, zone=1.5 * A_REF, h_far=3e-3
    )
    full, short = tmp / "full.toml", tmp / "short.toml"
    full.write_text(_scene(mesh, 2.0e-3))
    short.write_text(_scene(mesh, 1.0e-3))
    refs = {}
    for n in (1, 2):
        res = _run(full, tmp / f"ref{n}", n)
        assert res.returncode == 0, res.stderr
        refs[n] = tmp / f"ref{n}"
    return {"dir": tmp, "mesh": mesh, "full": full, "short": short, "refs": refs}


@pytest.mark.parametrize(
    "first,then",
    [
        pytest.param(1, 1, marks=pytest.mark.slow),
        pytest.param(2, 2, marks=pytest.mark.slow),
        (2, 1),
        (1, 3),
    ],
)
def test_restart_equals_uninterrupted(case, tmp_path, first, then):
    out = tmp_path / "out"
    res = _run(case["short"], out, first)
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == [
        "step_00000008",
        "step_00000010",  # the last step's
    ]
    res = _run(case["full"], out, then, "--restart", str(out / "checkpoints" / "step_00000008"))
    assert res.returncode == 0, res.stderr
    ref = case["refs"][then if then in case["refs"] else 1]
    worst = _assert_same_tables(ref, out)
    _, hist, _ = _table(out / "history.csv")
    assert hist[:, 0].tolist() == list(range(21))  # every step once, none missing
    s, r = (json.loads((d / "summary.json").read_text()) for d in (out, ref))
    assert s["status"] == "converged" and s["steps"] == 20
    assert s["restarted_from"]["step"] == 8 and s["restarted_from"]["ranks"] == first
    assert s["contact"]["pdas_iterations"] == r["contact"]["pdas_iterations"]
    assert s["linear_iterations"] == r["linear_iterations"]
    assert s["energy"]["final"] == pytest.approx(r["energy"]["final"], rel=1e-10)
    assert s["energy"]["initial"] == r["energy"]["initial"]
    # the contact changes after the restart: the run is a real test of the warm start
    assert len({int(x) for x in hist[9:, 5]}) > 1
    print(f"restart {first} -> {then} ranks: largest relative difference {worst:.2e}")


def _stop_with_sigterm(scene: Path, out: Path, n: int):
    """Start the run, send SIGTERM once step 2 is in history.csv; wait (60 s at most)."""
    proc = start_scene(scene, out, n)
    wait_for_lines(proc, out / "history.csv", 4)
    proc.send_signal(signal.SIGTERM)
    return finish(proc)


@pytest.mark.parametrize("n", [pytest.param(1, marks=pytest.mark.slow), 2])
def test_sigterm_interrupts_with_checkpoint(case, tmp_path, n):
    """60 steps (the drag then a hold), stopped by SIGTERM after step ≥ 2."""
    scene = tmp_path / "long.toml"
    scene.write_text(_scene(case["mesh"], 6.0e-3, every=0))
    out = tmp_path / "out"
    res = _stop_with_sigterm(scene, out, n)
    assert res.returncode == 128 + signal.SIGTERM, res.stderr
    assert "continue with --restart" in res.stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "interrupted" and s["signal"] == "SIGTERM"
    _, hist, _ = _table(out / "history.csv")
    stopped = int(hist[-1, 0])
    assert 2 <= stopped < 60 and s["steps"] == stopped
    assert s["checkpoints"]["last"].endswith(f"step_{stopped:08d}")
    assert [p.name for p in (out / "checkpoints").iterdir()] == [f"step_{stopped:08d}"]
    res = _run(scene, out, n, "--restart")
    assert res.returncode == 0, res.stderr
    _, hist, _ = _table(out / "history.csv")
    assert hist[:, 0].tolist() == list(range(61))
    # the first 20 steps are those of the 20-step scene's uninterrupted run
    _, ref, _ = _table(case["refs"][n] / "history.csv")
    scale = np.maximum(np.abs(ref).max(axis=0), 1e-3 * A_REF)
    assert (np.abs(hist[:21] - ref) <= 1e-10 * (np.abs(ref) + scale)).all()


def test_restart_refused_with_a_message(case, tmp_path):
    out = tmp_path / "out"
    res = _run(case["full"], out, 1, "--restart")
    assert res.returncode == 2 and "no intact checkpoint" in res.stderr
    assert "Traceback" not in res.stderr
    res = _run(case["short"], out, 1)
    assert res.returncode == 0, res.stderr
    other = tmp_path / "other_dt.toml"
    other.write_text(case["full"].read_text().replace("dt = 1.0e-4", "dt = 5.0e-5"))
    res = _run(other, out, 2, "--restart")
    assert res.returncode == 2 and "dt = 0.0001" in res.stderr, res.stderr
    assert "Traceback" not in res.stderr
    _, hist, _ = _table(out / "history.csv")
    assert hist[:, 0].tolist() == list(range(11))  # nothing changed


@pytest.mark.parametrize("n", [pytest.param(1, marks=pytest.mark.slow), 2])
def test_one_rank_killed_no_hang_and_restart(case, tmp_path, n):
    """SIGKILL to one rank (serially the process, else rank 1 of 2) once history.csv has
    the row of a step drawn by a seeded generator from 2..17 (checkpoints every step):
    the run ends within 60 s with a failure status (mpiexec ends the other rank), no
    checkpoint is damaged (a half-written one keeps its temporary name), and the restart
    completes the run with the uninterrupted rows."""
    step = int(np.random.default_rng([20261127, n]).integers(2, 18))
    scene = tmp_path / "every.toml"
    scene.write_text(
        case["full"].read_text().replace("checkpoint_every = 4", "checkpoint_every = 1")
    )
    out = tmp_path / "out"
    proc = start_scene(scene, out, n)
    wait_for_lines(proc, out / "history.csv", step + 2)
    pids = [proc.pid] if n == 1 else rank_pids(out)
    assert len(pids) == n, pids
    os.kill(pids[-1], signal.SIGKILL)
    try:
        res = finish(proc)
    except subprocess.TimeoutExpired:
        pytest.fail("the surviving rank hangs after one rank was killed")
    assert res.returncode != 0
    assert not (out / "summary.json").exists()
    res = _run(scene, out, n, "--restart")
    assert res.returncode == 0, res.stderr
    _, hist_rows, _ = _table(out / "history.csv")
    assert hist_rows[:, 0].tolist() == list(range(21))
    s = json.loads((out / "summary.json").read_text())
    assert s["restarted_from"]["step"] >= step - 1, (step, s["restarted_from"])
    _assert_same_tables(case["refs"][n], out)
