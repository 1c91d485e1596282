"""Checkpoints and restart of growth-only and coupled runs, through the ``bonecontact``
command: a run killed at a step and continued from its last checkpoint gives the tables of
an uninterrupted run.

Scenes (small, a few seconds each):

* growth: a meshless 2D tumour (nutrient with memory, eps0 = 0.5, so the checkpoint's
  nutrient and mesh displacement matter; proliferating and quiescent cells), 10 steps,
  gmsh-remeshed every 2 steps;
* coupled: a plate with a tumour inclusion that grows (remeshed every 2 steps), the
  plate's static analysis on the host mesh rebuilt around it after steps 2, 4 and 6.

Tests (the reference is always an uninterrupted run of the same scene without
checkpoints, on the same number of ranks unless said otherwise):

* kill and restart (1 and 2 ranks): checkpoints every step; once growth.csv shows a step
  drawn by a seeded generator, one rank is killed with SIGKILL (the process itself
  serially, rank 1 of 2 under ``mpiexec``); the run ends within 60 s (no hang) without a
  summary, then is continued with ``--restart``.  growth.csv, every analysis's
  history.csv and the coupling records equal the uninterrupted run's to 1e-10 of each
  value (measured: identical serially, within 2e-16 on 2 ranks; the restart rebuilds
  the mesh with the partition of the killed run), every step once.
* another number of ranks (2 -> 1): supported; the tables agree to 1e-10 (round-off).
* SIGTERM (1 and 2 ranks): exit 143, status "interrupted", a checkpoint of the last step;
  the restart completes the run with the uninterrupted rows.
* refused restarts exit 2 naming the problem: no checkpoint, another dt, another scene,
  a growth checkpoint for a mechanics scene.
* a signal during a coupled run's analysis (in-process: SIGTERM sent to this process at
  the analysis's first or last step) stops the coupled run with its own checkpoint;
  the restart gives the uninterrupted tables and records.
* SIGTERM to ``mpiexec`` during a coupled run on 2 ranks (slow); a host mesh that gmsh
  cannot rebuild (injected) fails the coupled run cleanly, and the restart from the
  last checkpoint completes it.

The default suite runs the serial cases, the 2-rank kill of the growth scene, the
2 -> 1 restart of the growth scene and the in-process tests (10 tests: 2.1 min on the
shared 2-core machine, 6 min under a load of 8); the 2-rank coupled kill, the coupled
2 -> 1 restart and the SIGTERM tests on 2 ranks are marked ``slow``.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from cli_support import (
    ENV,
    cli_command,
    finish,
    rank_pids,
    run_in_process,
    run_scene,
    scene_args,
    wait_for_lines,
)
from coupled_support import gmsh_on_rank0, plate_with_disc, read_csv

pytestmark = pytest.mark.serial

SEED = 20261125  # the steps at which the runs are killed
RTOL = 1e-10

TUMOUR = """format = 1
[scene]
name = "tumour"
dimension = 2

[neoplasm]
kind = "tumour"
radius = 1.0
h = 0.25
t_end = 2.0
dt = 0.2
remesh_every = 2

[neoplasm.tumour]
D_c = 1.0
lambda = 1.0
eps0 = 0.5
u_c1 = 1.0
K_B = "1.0*(u_c - 0.5)"
K_Q = "0.3*(0.8 - u_c)"
K_P = 0.1
K_R = 0.05
u_p0 = 0.9
u_q0 = 0.05

[output]
directory = "unused"
checkpoint_every = {every}
"""

PLATE = """format = 1
[scene]
name = "inclusion"
mesh = "{mesh}"
dimension = 2

[analysis]
kind = "static"
load_steps = 1

[[material]]
name = "bone"
regions = ["plate"]
model = "isotropic"
E = 1.0e9
nu = 0.3

[[material]]
name = "tumour"
regions = ["tumour"]
model = "isotropic"
E = 1.0e6
nu = 0.45

[[dirichlet]]
boundary = "left"
value = [0.0, "free"]

[[dirichlet]]
boundary = "bottom"
value = ["free", 0.0]

[[traction]]
boundary = "right"
value = [1.0e6, 0.0]

[neoplasm]
kind = "tumour"
region = "tumour"
host = ["plate"]
t_end = 1.5
dt = 0.25
h = 4.0e-4
remesh_every = 2
mechanics_every = 2

[neoplasm.tumour]
D_c = 4.0e-6
K_B = "2.0*(u_c - 0.5)"

[output]
directory = "unused"
fields_every = 0
checkpoint_every = {every}
"""


def _plate_mesh(path: Path, L: float = 0.01, R: float = 0.002) -> None:
    """Square [0, 2L]² ("plate", facet groups left/bottom/right/top) with a disc of radius
    R at its centre ("tumour"), 0.4 mm at the disc, 2 mm away from it."""

    def build(gmsh):
        inner = plate_with_disc(gmsh, L, R)
        gmsh.option.setNumber("Mesh.MeshSizeMax", 2e-3)
        gmsh.option.setNumber("Mesh.MeshSizeMin", 4e-4)
        gmsh.model.mesh.setSize(
            gmsh.model.getBoundary([(2, t) for t in inner], recursive=True), 4e-4
        )

    gmsh_on_rank0(build, path, 2)


# ----------------------------------------------------------------------------- helpers
def _kill_step(name: str, n: int, nsteps: int) -> int:
    """A step in 2..nsteps-2 drawn from a generator seeded with SEED, the scene and n."""
    rng = np.random.default_rng([SEED, n, sum(map(ord, name))])
    return int(rng.integers(2, nsteps - 1))


def _start(scene: Path, out: Path, n: int) -> subprocess.Popen:
    """``bonecontact run`` in its own process group (mpiexec and every rank)."""
    return subprocess.Popen(
        cli_command(scene_args(scene, out), n),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ENV,
        stdin=subprocess.DEVNULL,
        start_new_session=True,
    )


def _kill_at(scene: Path, out: Path, n: int, step: int) -> None:
    """Run, and SIGKILL one rank (the last) once growth.csv has the row of ``step``; the
    run must end within 60 s (the other ranks do not hang) and leave no summary."""
    proc = _start(scene, out, n)
    try:
        wait_for_lines(proc, out / "growth.csv", step + 2)
        pids = [proc.pid] if n == 1 else rank_pids(out)
        assert len(pids) == n, pids
        os.kill(pids[-1], signal.SIGKILL)
        try:
            res = finish(proc)
        except subprocess.TimeoutExpired:
            pytest.fail(f"the run hangs after one of {n} ranks was killed")
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
    assert res.returncode != 0
    assert not (out / "summary.json").exists()


def _rows(path: Path) -> np.ndarray:
    return np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def _same(ref: Path, out: Path, name: str) -> float:
    """``out/name`` equals ``ref/name`` to RTOL of each value (plus 1e-300; a resultant
    column: of the largest resultant); returns the largest relative difference."""
    a, b = read_csv(ref / name), read_csv(out / name)
    assert list(a) == list(b), name
    # a resultant that balances to zero (a support's reaction across the load) is round-off
    # of the table's forces: its values are compared to the largest resultant instead
    resultant = [k for k in a if k.startswith(("reaction_", "load_", "inertia_"))]
    scale = max((float(np.max(np.abs(np.asarray(a[k])))) for k in resultant), default=0.0)
    worst = 0.0
    for key in a:
        x, y = np.asarray(a[key]), np.asarray(b[key])
        assert x.shape == y.shape, f"{name}:{key}: {x.shape} rows, {y.shape} after the restart"
        if x.dtype.kind not in "fi":
            assert (x == y).all(), f"{name}:{key}"
            continue
        floor = scale if key in resultant else 1e-300
        rel = np.abs(y - x) / np.maximum(np.abs(x), floor)
        rel[(x == y) | (np.isnan(x) & np.isnan(y))] = 0.0
        assert rel.max(initial=0.0) <= RTOL, f"{name}:{key}: {rel.max():.3g}"
        worst = max(worst, float(rel.max(initial=0.0)))
    return worst


def _records(out: Path) -> list[dict]:
    """The coupling records without what depends on the output directory."""
    recs = json.loads((out / "summary.json").read_text())["coupling"]["analyses"]
    return [{k: v for k, v in r.items() if k != "directory"} for r in recs]


def _same_records(ref: Path, out: Path) -> None:
    a, b = _records(ref), _records(out)
    assert [r["growth_step"] for r in a] == [r["growth_step"] for r in b]
    for ra, rb in zip(a, b, strict=True):
        for key, value in ra.items():
            if isinstance(value, float):
                assert rb[key] == pytest.approx(value, rel=RTOL), key
            else:
                assert rb[key] == value, key


def _coupled_tables(out: Path) -> list[str]:
    return ["growth.csv", "history.csv"] + sorted(
        f"{d.name}/history.csv" for d in out.glob("mechanics_*")
    )


# ----------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """The scenes and ``ref(name, n)``: the uninterrupted run of scene ``name`` on ``n``
    ranks without checkpoints (run once, when first asked for)."""
    tmp = tmp_path_factory.mktemp("growth_restart")
    _plate_mesh(tmp / "plate.msh")
    scenes = {}
    for name, text in (("tumour", TUMOUR), ("coupled", PLATE)):
        for every in (0, 1):
            path = tmp / f"{name}_{every}.toml"
            path.write_text(text.format(every=every, mesh=tmp / "plate.msh"))
            scenes[name, every] = path
    refs: dict[tuple[str, int], Path] = {}

    def ref(name: str, n: int) -> Path:
        if (name, n) not in refs:
            out = tmp / f"ref_{name}_{n}"
            res = run_scene(scenes[name, 0], out, n)
            assert res.returncode == 0, res.stderr[-3000:]
            refs[name, n] = out
        return refs[name, n]

    return {"dir": tmp, "scenes": scenes, "ref": ref}


# ----------------------------------------------------------------------------- tests
def test_uninterrupted_runs_are_repeatable_and_remesh(case, tmp_path):
    """Two runs of the growth scene give the same growth.csv bit for bit (gmsh is run
    with one thread: the same boundary gives the same mesh); the runs remesh and grow."""
    out = tmp_path / "again"
    res = run_scene(case["scenes"]["tumour", 0], out, 1)
    assert res.returncode == 0, res.stderr
    ref = case["ref"]("tumour", 1)
    assert (out / "growth.csv").read_bytes() == (ref / "growth.csv").read_bytes()
    s = json.loads((ref / "summary.json").read_text())
    assert s["growth"]["remeshes"] == 5 and s["steps"] == 10
    g = _rows(ref / "growth.csv")
    assert g[-1, 3] > 1.1 * g[0, 3]
    c = json.loads((case["ref"]("coupled", 1) / "summary.json").read_text())
    assert [a["growth_step"] for a in c["coupling"]["analyses"]] == [2, 4, 6]
    assert c["growth"]["remeshes"] == 3


@pytest.mark.parametrize(
    "name,n",
    [
        pytest.param("tumour", 1, marks=pytest.mark.slow),
        ("tumour", 2),
        ("coupled", 1),
        pytest.param("coupled", 2, marks=pytest.mark.slow),
    ],
)
def test_killed_run_restarted_equals_uninterrupted(case, tmp_path, name, n):
    nsteps = 10 if name == "tumour" else 6
    step = _kill_step(name, n, nsteps)
    out = tmp_path / "out"
    _kill_at(case["scenes"][name, 1], out, n, step)
    done = sorted(p.name for p in (out / "checkpoints").iterdir() if p.name.startswith("step_"))
    assert 1 <= len(done) <= 2 and int(done[-1][5:]) >= step - 1, done
    res = run_scene(case["scenes"][name, 1], out, n, "--restart")
    assert res.returncode == 0, res.stderr[-3000:]
    ref = case["ref"](name, n)
    tables = ["growth.csv"] if name == "tumour" else _coupled_tables(ref)
    assert tables == (["growth.csv"] if name == "tumour" else _coupled_tables(out))
    worst = max(_same(ref, out, t) for t in tables)
    assert len(_rows(out / "growth.csv")) == nsteps + 1  # every step once
    s = json.loads((out / "summary.json").read_text())
    r = json.loads((ref / "summary.json").read_text())
    assert s["status"] == "converged" and s["restarted_from"]["ranks"] == n
    assert s["restarted_from"]["step"] >= step - 1
    assert s["growth"]["remeshes"] == r["growth"]["remeshes"]
    assert s["growth"]["final_radius"] == pytest.approx(r["growth"]["final_radius"], rel=RTOL)
    if name == "coupled":
        _same_records(ref, out)
    print(f"{name}, {n} rank(s), killed after step {step}: largest difference {worst:.2e}")


@pytest.mark.parametrize("name", ["tumour", pytest.param("coupled", marks=pytest.mark.slow)])
def test_restart_on_another_number_of_ranks(case, tmp_path, name):
    """Written on 2 ranks, continued on 1: the mesh is partitioned anew, the tables agree
    with the serial run's to round-off."""
    scene = case["scenes"][name, 1]
    out = tmp_path / "out"
    res = run_scene(scene, out, 2)
    assert res.returncode == 0, res.stderr[-3000:]
    ckpt = sorted((out / "checkpoints").iterdir())[0]  # the second newest
    res = run_scene(scene, out, 1, "--restart", str(ckpt))
    assert res.returncode == 0, res.stderr[-3000:]
    ref = case["ref"](name, 1)
    for table in ["growth.csv"] if name == "tumour" else _coupled_tables(ref):
        _same(ref, out, table)
    s = json.loads((out / "summary.json").read_text())
    assert s["restarted_from"]["ranks"] == 2 and s["ranks"] == 1


@pytest.mark.parametrize("n", [1, pytest.param(2, marks=pytest.mark.slow)])
def test_sigterm_interrupts_growth_with_checkpoint(case, tmp_path, n):
    """SIGTERM once step 3 is in growth.csv (20 steps): the step in progress finishes, a
    checkpoint, exit 143; the restart finishes the run, and its rows up to step 10 (those
    after the stop included) are the uninterrupted 10-step run's."""
    scene = tmp_path / "long.toml"
    scene.write_text(case["scenes"]["tumour", 0].read_text().replace("t_end = 2.0", "t_end = 4.0"))
    out = tmp_path / "out"
    proc = _start(scene, out, n)
    wait_for_lines(proc, out / "growth.csv", 5)
    proc.send_signal(signal.SIGTERM)
    res = finish(proc)
    assert res.returncode == 128 + signal.SIGTERM, res.stderr
    assert "continue with --restart" in res.stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "interrupted" and s["signal"] == "SIGTERM"
    stopped = s["steps"]
    assert 3 <= stopped <= 8 and len(_rows(out / "growth.csv")) == stopped + 1
    assert [p.name for p in (out / "checkpoints").iterdir()] == [f"step_{stopped:08d}"]
    res = run_scene(scene, out, n, "--restart")
    assert res.returncode == 0, res.stderr[-3000:]
    g, ref = _rows(out / "growth.csv"), _rows(case["ref"]("tumour", n) / "growth.csv")
    assert len(g) == 21 and len(ref) == 11
    np.testing.assert_allclose(g[: len(ref)], ref, rtol=RTOL)


def test_restart_refused_with_a_message(case, tmp_path):
    """Refused restarts (no checkpoint, another dt, another scene, a mechanics scene on a
    growth checkpoint): exit 2 with the reason, nothing changed.  Through the entry point
    in this process (the real command's exit status: the 1/2-rank restart tests)."""
    out = tmp_path / "out"
    scene = case["scenes"]["tumour", 1]
    res = run_in_process(scene_args(scene, out, "--restart"))
    assert res.returncode == 2 and "no intact checkpoint" in res.stderr
    short = tmp_path / "short.toml"
    short.write_text(scene.read_text().replace("t_end = 2.0", "t_end = 0.8"))
    assert run_in_process(scene_args(short, out)).returncode == 0
    other = tmp_path / "other_dt.toml"
    other.write_text(scene.read_text().replace("dt = 0.2", "dt = 0.1"))
    res = run_in_process(scene_args(other, out, "--restart"))
    assert res.returncode == 2 and "dt = 0.2" in res.stderr, res.stderr
    assert "Traceback" not in res.stderr
    res = run_in_process(
        scene_args(case["scenes"]["coupled", 1], out, "--restart")
    )  # another scene
    assert res.returncode == 2 and "scene = 'tumour'" in res.stderr, res.stderr
    plate = tmp_path / "plate_only.toml"  # the coupled scene without growth: mechanics
    text = case["scenes"]["coupled", 1].read_text()
    plate.write_text(text[: text.index("[neoplasm]")] + text[text.index("[output]") :])
    res = run_in_process(scene_args(plate, out, "--restart"))
    assert res.returncode == 2, res.stderr
    assert "'bonecontact growth checkpoint', not a mechanics run's" in res.stderr, res.stderr
    assert len(_rows(out / "growth.csv")) == 5  # nothing changed


@pytest.mark.parametrize("at", [pytest.param(1, marks=pytest.mark.slow), 2])
def test_signal_during_a_coupled_analysis(case, tmp_path, monkeypatch, at):
    """SIGTERM (sent to this process) during step ``at`` of the 2-step analysis after
    growth step 2 of the coupled scene, run in-process: the analysis's own run takes the
    signal and passes it on.  At its first step the analysis stops ("interrupted", no
    record) and the coupled checkpoint of step 2 marks it as still to run; at its last
    step it finishes and the checkpoint follows it.  Either way the run ends
    "interrupted" with that checkpoint and no checkpoint of the analysis, and the
    restart gives growth.csv, every history.csv and the records of the uninterrupted
    run (1e-10)."""
    from bonecontact.mechanics.integrator import Integrator
    from bonecontact.runners import run_scene as run_in_process
    from bonecontact.scene import load_scene

    scene = tmp_path / "coupled.toml"
    text = case["scenes"]["coupled", 0].read_text()  # no periodic checkpoints
    scene.write_text(text.replace("load_steps = 1", "load_steps = 2"))
    ref = tmp_path / "ref"
    assert run_in_process(load_scene(scene), output=ref, progress=False).status == "converged"
    calls = []
    step = Integrator.step

    def signalled(self):
        calls.append(1)
        if len(calls) == at:
            os.kill(os.getpid(), signal.SIGTERM)
        return step(self)

    monkeypatch.setattr(Integrator, "step", signalled)
    out = tmp_path / "out"
    res = run_in_process(load_scene(scene), output=out, progress=False)
    monkeypatch.undo()
    s = json.loads((out / "summary.json").read_text())
    assert res.status == "interrupted" and s["status"] == "interrupted", s.get("message")
    assert s["signal"] == "SIGTERM"
    assert [p.name for p in (out / "checkpoints").iterdir()] == ["step_00000002"]
    meta = json.loads((out / "checkpoints/step_00000002/meta.json").read_text())
    assert meta["analysis_pending"] == (at == 1)
    assert len(meta["records"]) == (0 if at == 1 else 1)
    assert not (out / "mechanics_00002" / "checkpoints").exists()
    assert len(_rows(out / "growth.csv")) == 3
    res = run_in_process(load_scene(scene), output=out, progress=False, restart=True)
    assert res.status == "converged"
    for table in _coupled_tables(ref):
        _same(ref, out, table)
    _same_records(ref, out)


@pytest.mark.slow
def test_sigterm_stops_a_coupled_run_on_two_ranks(case, tmp_path):
    """SIGTERM to ``mpiexec`` once the first analysis (after growth step 2) has started:
    every rank stops, exit 143, status "interrupted" with one checkpoint (of step 2 with
    the analysis pending, or of a later step); the restart on 2 ranks gives the tables
    and records of the uninterrupted 2-rank run."""
    scene = case["scenes"]["coupled", 0]
    out = tmp_path / "out"
    proc = _start(scene, out, 2)
    t0 = time.monotonic()
    while not (out / "mechanics_00002").is_dir():
        assert proc.poll() is None, "the run ended early"
        assert time.monotonic() - t0 < 300
        time.sleep(0.02)
    proc.send_signal(signal.SIGTERM)
    res = finish(proc)
    assert res.returncode == 128 + signal.SIGTERM, res.stderr[-3000:]
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "interrupted" and s["signal"] == "SIGTERM"
    (ckpt,) = (out / "checkpoints").iterdir()
    assert int(ckpt.name[5:]) >= 2
    res = run_scene(scene, out, 2, "--restart")
    assert res.returncode == 0, res.stderr[-3000:]
    ref = case["ref"]("coupled", 2)
    for table in _coupled_tables(ref):
        _same(ref, out, table)
    _same_records(ref, out)


def test_host_remesh_failure_in_a_coupled_run(case, tmp_path, monkeypatch):
    """gmsh cannot rebuild the host mesh for the analysis after growth step 4 (injected:
    the host-mesh builder raises CouplingError, as a gmsh failure does; in-process): the
    run ends "failed" with a message naming that analysis and the error; growth.csv
    holds the rows to step 4, the record of the analysis after step 2 is kept, the
    newest checkpoint is step 3's (step 4's is written after its analysis), and the
    restart without the fault gives the uninterrupted tables and records."""
    from bonecontact.neoplasm.host import CouplingError
    from bonecontact.runners import coupled
    from bonecontact.runners import run_scene as run_in_process
    from bonecontact.scene import load_scene

    scene = case["scenes"]["coupled", 1]  # checkpoints every step
    real, calls = coupled.build_host_mesh, []

    def failing(*args):
        calls.append(1)
        if len(calls) == 3:  # 1: the check at t = 0, 2: after step 2, 3: after step 4
            raise CouplingError("injected: gmsh could not mesh the host")
        return real(*args)

    monkeypatch.setattr(coupled, "build_host_mesh", failing)
    out = tmp_path / "out"
    res = run_in_process(load_scene(scene), output=out, progress=False)
    monkeypatch.undo()
    s = json.loads((out / "summary.json").read_text())
    assert res.status == "failed" and s["status"] == "failed"
    assert s["message"].startswith("analysis after growth step 4"), s["message"]
    assert "injected: gmsh could not mesh the host" in s["message"]
    assert len(_rows(out / "growth.csv")) == 5
    assert [r["growth_step"] for r in s["coupling"]["analyses"]] == [2]
    names = sorted(p.name for p in (out / "checkpoints").iterdir())
    assert names == ["step_00000002", "step_00000003"]
    res = run_in_process(load_scene(scene), output=out, progress=False, restart=True)
    assert res.status == "converged"
    ref = case["ref"]("coupled", 1)
    for table in _coupled_tables(ref):
        _same(ref, out, table)
    _same_records(ref, out)
