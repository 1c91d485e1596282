"""What the runner tests share: the ``bonecontact`` command run in a subprocess (serially
or under ``mpiexec``; every converged run is checked for reactions that balance the
loads) or in this process, the dynamic Coulomb contact scene of the checkpoint and restart
tests, the bar under uniaxial traction of the plausibility and validity tests, and the
reaction-balance check itself.

Not a test module (no ``test_`` prefix); the runner tests import it by name (pytest puts
this folder on ``sys.path``).
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from mpi4py import MPI

import numpy as np

from bonecontact.runners.cli import main

BIN = Path(sys.executable).parent
CLI = str(BIN / "bonecontact")
MPIEXEC = str(BIN / "mpiexec")
ENV = {**os.environ, "OMP_NUM_THREADS": "1"}


def cli_command(args: list[str], n: int = 1) -> list[str]:
    """The command line of ``bonecontact ARGS`` on ``n`` ranks."""
    return [CLI, *args] if n == 1 else [MPIEXEC, "-n", str(n), CLI, *args]


def run_cli(
    args: list[str], n: int = 1, timeout: float = 600, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess:
    """Run ``bonecontact ARGS`` on ``n`` ranks (environment ``env``, default ``ENV``);
    stdout and stderr captured as text.  A converged ``run`` with ``-o OUT`` must show
    reactions that balance the loads in every row of ``OUT/history.csv``
    (:func:`check_reaction_balance`)."""
    res = subprocess.run(
        cli_command(args, n),
        capture_output=True,
        text=True,
        timeout=timeout,
        env=ENV if env is None else env,
        stdin=subprocess.DEVNULL,
    )
    if res.returncode == 0 and args[:1] == ["run"] and "-o" in args:
        check_reaction_balance(Path(args[args.index("-o") + 1]))
    return res


def scene_args(scene: Path, out: Path | None, *extra: str) -> list[str]:
    """``run SCENE -q [-o OUT] EXTRA...``: a quiet run, results in ``out`` if given."""
    return ["run", str(scene), "-q", *(["-o", str(out)] if out is not None else []), *extra]


def run_scene(
    scene: Path,
    out: Path | None,
    n: int = 1,
    *extra: str,
    timeout: float = 600,
    env: dict[str, str] | None = None,
) -> subprocess.CompletedProcess:
    """``bonecontact run SCENE -q -o OUT EXTRA...`` on ``n`` ranks, to completion."""
    return run_cli(scene_args(scene, out, *extra), n, timeout, env)


def run_in_process(args: list[str]) -> subprocess.CompletedProcess:
    """``bonecontact ARGS`` through its entry point in this process (collective; the exit
    status is ``main``'s return value), stdout and stderr captured — for the refusals,
    which need no process of their own."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(args)
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


def start_scene(scene: Path, out: Path, n: int = 1) -> subprocess.Popen:
    """Start ``bonecontact run SCENE -q -o OUT`` on ``n`` ranks without waiting."""
    return subprocess.Popen(
        cli_command(scene_args(scene, out), n),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ENV,
        stdin=subprocess.DEVNULL,
    )


def wait_for_lines(proc: subprocess.Popen, table: Path, lines: int, limit: float = 300) -> None:
    """Wait until ``table`` has ``lines`` lines (header included); fail if the run ends
    first or takes longer than ``limit`` seconds."""
    t0 = time.monotonic()
    while not (table.is_file() and len(table.read_text().splitlines()) >= lines):
        assert proc.poll() is None, "the run ended early"
        assert time.monotonic() - t0 < limit, f"{table.name} has fewer than {lines} lines"
        time.sleep(0.02)


def finish(proc: subprocess.Popen, timeout: float = 60) -> subprocess.CompletedProcess:
    """Wait for ``proc`` (``timeout`` seconds at most, then kill it and raise)."""
    try:
        stdout, stderr = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        raise
    return subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr)


def rank_pids(out: Path) -> list[int]:
    """Process ids of the ``bonecontact`` ranks writing to ``out`` (not mpiexec/hydra)."""
    pids = []
    for proc in Path("/proc").iterdir():
        try:
            cmd = (proc / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        text = [c.decode(errors="replace") for c in cmd]
        if str(out) in text and not any("mpiexec" in c or "hydra" in c for c in text):
            pids.append(int(proc.name))
    return sorted(pids)


#: Contact zone size of the impact scene's mesh (m): ``hertz_2d(h_contact=IMPACT_A / 4,
#: zone=1.5 * IMPACT_A, h_far=3e-3)``.
IMPACT_A = 5.0e-4

_IMPACT_SCENE = """format = 1
[scene]
name = "impact"
mesh = "{mesh}"
dimension = 2
[analysis]
kind = "dynamic"
t_end = {t_end}
dt = 1.0e-4
[[material]]
name = "cylinder"
regions = ["cylinder"]
model = "isotropic"
E = 2.0e9
nu = 0.3
rho = 1200.0
tau_v = 1.0e-5
[[material]]
name = "block"
regions = ["block"]
model = "isotropic"
E = 17.0e9
nu = 0.3
rho = 1900.0
[[contact]]
name = "hertz"
slave = "cyl_contact"
master = "block_contact"
friction = "coulomb"
coefficient = 0.3
[[dirichlet]]
boundary = "block_bottom"
value = [0.0, 0.0]
[[dirichlet]]
boundary = "cyl_top"
value = [4.0e-6, -3.0e-6]
schedule = [[0.0, 0.0], [1.0e-3, 1.0], [2.0e-3, 1.0]]
[output]
directory = "results"
fields_every = {fields_every}
checkpoint_every = {every}
"""


def impact_scene(
    mesh: Path | str,
    t_end: float,
    every: int = 4,
    fields_every: int = 0,
    probes: list[tuple[float, float]] | None = None,
) -> str:
    """The scene text of a dynamic 2D contact with Coulomb friction (μ = 0.3).

    A cylinder (E = 2 GPa, Kelvin–Voigt τ = 10 µs) pressed into a block (17 GPa) and
    dragged sideways by its top over 1 ms, then held; Δt = 0.1 ms, so ``t_end = 2e-3``
    is 20 steps. Stick and slip nodes occur and the active set grows during the run.
    ``every`` is ``[output] checkpoint_every`` (0: none).
    """
    text = _IMPACT_SCENE.format(mesh=mesh, t_end=t_end, every=every, fields_every=fields_every)
    if probes:
        text += f"probes = {[list(p) for p in probes]}\n"
    return text


# ----------------------------------------------------------------------------- reactions
#: Largest relative force-balance defect a converged run's history.csv may show.
BALANCE_TOLERANCE = 1e-6


def reaction_balance(
    history: dict[str, Sequence[str]], dim: int, floor: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Per row of a history table (column → values): the relative defects of the force
    and of the moment balance, ``|Σ_groups R + load − inertia|`` over the largest of
    those terms and ``floor`` (0 where all vanish), from the ``reaction_<group>_<c>``,
    ``load_<c>`` and ``inertia_<c>`` columns."""
    parts: dict[str, list[np.ndarray]] = {}
    for name, values in history.items():
        kind, comp = name.partition("_")[0], name.rsplit("_", 1)[-1]
        if kind not in ("reaction", "load", "inertia"):
            continue
        sign = -1.0 if kind == "inertia" else 1.0
        parts.setdefault(comp, []).append(sign * np.asarray(values, dtype=float))
    forces, moments = list("xyz"[:dim]), ["mz"] if dim == 2 else ["mx", "my", "mz"]

    def defect(comps: list[str]) -> np.ndarray:
        terms = np.array([parts[c] for c in comps])  # (component, term, row)
        total = np.linalg.norm(terms.sum(axis=1), axis=0)
        size = np.linalg.norm(terms, axis=0).max(axis=0)
        # a row with no load and no contact yet has reactions of round-off size: its
        # defect is measured on a thousandth of the run's largest term, not on itself
        scale = np.maximum(size, max(floor, 1e-3 * size.max(initial=0.0)))
        return np.where(scale > 0, total / np.where(scale > 0, scale, 1.0), 0.0)

    return defect(forces), defect(moments)


def check_reaction_balance(out: Path, tolerance: float = BALANCE_TOLERANCE) -> None:
    """Assert that the supports' reactions in ``out/history.csv`` balance the applied loads
    (and the inertia of a dynamic run) in every row; contact forces are internal."""
    table = out / "history.csv"
    if not table.is_file():
        return
    rows = list(csv.reader(open(table)))
    if not rows or "load_x" not in rows[0]:
        return
    history = {c: [r[k] for r in rows[1:]] for k, c in enumerate(rows[0])}
    dim = 3 if "load_z" in history else 2
    # the loads' size however they cancel (a pressure in a closed cavity has resultant 0)
    summary = out / "summary.json"
    floor = 0.0
    if summary.is_file():
        floor = json.loads(summary.read_text()).get("reactions", {}).get("load_gross_max", 0.0)
    force, _ = reaction_balance(history, dim, floor)
    assert (force <= tolerance).all(), (
        f"{table}: the reactions do not balance the loads (relative defect up to "
        f"{force.max():.3g} > {tolerance:g})"
    )


BAR = """format = 1

[scene]
name = "bar"
mesh = "{mesh}"
dimension = 2

[analysis]
kind = "static"
load_steps = 1
{allow}

[[material]]
name = "{name}"
regions = ["body"]
model = "isotropic"
E = {E}
nu = 0.0

[[dirichlet]]
boundary = "left"
value = [0.0, "free"]

[[dirichlet]]
boundary = "bottom"
value = ["free", 0.0]

[[traction]]
boundary = "right"
value = [{t}, 0.0]

[output]
directory = "{out}"
fields_every = 0
"""

#: bar mesh name → its width (m): 20 mm (a bone piece), the same numbers in metres (a mesh
#: in millimetres), 20 µm (a micro-CT voxel unit slip) and 1.5 m (large but plausible)
BAR_WIDTHS = {"rect_m": 0.02, "rect_mm": 20.0, "rect_um": 2.0e-5, "rect_1m": 1.5}


def write_bar_meshes(directory: Path, comm: MPI.Comm = MPI.COMM_WORLD) -> Path:
    """The bars of :data:`BAR_WIDTHS` (aspect 2:1, 8 × 4 cells) as ``<name>.msh`` in
    ``directory``, written on rank 0 of ``comm``."""
    from bonecontact.meshing import shapes

    if comm.rank == 0:
        for name, w in BAR_WIDTHS.items():
            shapes.rectangle(w, w / 2, 8, 4, MPI.COMM_SELF, path=directory / f"{name}.msh")
    comm.barrier()
    return directory


def write_bar_scene(
    directory: Path,
    meshes: Path,
    E: float = 17.0e9,
    t: float = 1.0e6,
    mesh: str = "rect_m",
    name: str = "cortical",
    allow: bool | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> tuple[Path, Path]:
    """``directory/bar.toml``: the bar ``mesh`` (ν = 0, held by rollers on its left and
    bottom edges) of material ``name`` with modulus ``E`` (Pa) under the traction ``t``
    (Pa) on its right edge, so that its strain is t/E everywhere; ``allow`` sets
    ``[analysis] allow_large_strain`` when given.  Returns the scene and its output
    directory."""
    out = directory / "results"
    path = directory / "bar.toml"
    line = "" if allow is None else f"allow_large_strain = {str(allow).lower()}"
    text = BAR.format(
        mesh=meshes / f"{mesh}.msh",
        name=name,
        E=repr(float(E)),
        t=repr(float(t)),
        out=out,
        allow=line,
    )
    if comm.rank == 0:
        path.write_text(text)
    comm.barrier()
    return path, out
