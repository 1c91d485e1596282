"""Cost of a restart checkpoint against the cost of a step (docs/checkpoint.md).

Each case is a scene run in-process as ``bonecontact run`` runs it
(:func:`bonecontact.runners.dispatch.run_scene`) with ``[output] checkpoint_every`` set,
then continued with ``restart`` from its second-newest checkpoint.  Run the script
serially and under ``mpiexec -n 2``.  Figures (slowest rank):

* *step* = the median wall time of a step after the first (``Integrator.step``, contact
  solve included, or the growth driver's step, remeshing included; timed by wrapping
  that method); *first step* = the first step of the run (it includes the forms'
  just-in-time compilation when they are not cached, the first factorisation with
  contact and caches built once), *first step after restart* = the same for the
  restarted run (a restart pays these set-up costs again);
* *write* = ``summary.json`` ``checkpoints.write_time_s / checkpoints.written`` (the
  state gathered into input order, ``state.h5``, ``mesh.vtkhdf``, ``meta.json``, fsync,
  rename);
* *read* = the restarted run's ``phases_s.checkpoint`` less its own writes: finding
  and verifying the checkpoint (SHA-256 of ``state.h5``), reading it into the model
  (growth: rebuilding and partitioning the mesh and setting the model up on it) and
  trimming the tables;
* *size* = the files of the last checkpoint (bytes), ``state.h5`` alone too;
* *dofs* (mechanics) or *cells* (growth: the final mesh's).

Cases (the scenes of the other studies):

* ``impact2d``: the dynamic 2D Coulomb contact of the restart tests (a cylinder pressed
  into a block and dragged sideways, μ = 0.3, Δt = 0.1 ms, 20 steps), ``hertz_2d`` mesh
  at two sizes (about 10k and 27k dofs);
* ``knee2d_gait``: the shipped dynamic knee scene with Coulomb friction
  (data/scenes/knee2d_gait.toml), its first 20 steps;
* ``contact3d``: the 3D hemisphere on a block of ``bench_contact3d.py`` / ``bench_scale3d.py``
  (frictionless, the ``25k`` mesh), quasi-static in 4 load steps;
* ``tumour2d``: the growth scene data/scenes/tumour_growth_2d.toml (meshless tumour,
  remeshed every step), its first 10 steps;
* ``tumour3d``: a meshless 3D ball tumour (remeshed every step, nutrient with memory),
  6 steps.

Usage:  python benchmarks/bench_checkpoint.py [--quick] [--cases a,b]
            [--out benchmarks/results/checkpoint.csv]
        mpiexec -n 2 python benchmarks/bench_checkpoint.py [--quick]

Rows are appended to the results file, with the machine, the date and the 1-minute load
average at the start of each case.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401  (before dolfinx / petsc4py)

import argparse
import csv
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from mpi4py import MPI

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from bench_contact3d import SIZES  # noqa: E402
from common import machine  # noqa: E402

from bonecontact.mechanics.integrator import Integrator  # noqa: E402
from bonecontact.neoplasm.growth import TumourGrowth  # noqa: E402
from bonecontact.runners.dispatch import run_scene  # noqa: E402
from bonecontact.scene import load_scene  # noqa: E402
from bonecontact.verification.load_driven import (  # noqa: E402
    LOAD_DRIVEN_E,
    LOAD_DRIVEN_NU,
    LOAD_DRIVEN_RADIUS,
    LOAD_DRIVEN_STIFFNESS_RATIO,
)

COMM = MPI.COMM_WORLD
ENV = {**os.environ, "OMP_NUM_THREADS": "1"}
#: Contact zone scale of the 2D impact meshes (m), as in the restart tests.
IMPACT_A = 5.0e-4

IMPACT = """format = 1
[scene]
name = "impact2d"
mesh = "{mesh}"
dimension = 2
[analysis]
kind = "dynamic"
t_end = 2.0e-3
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
fields_every = 0
checkpoint_every = {every}
"""

CONTACT3D = """format = 1
[scene]
name = "contact3d"
mesh = "{mesh}"
dimension = 3
[analysis]
kind = "static"
load_steps = 4
[[material]]
name = "sphere"
regions = ["sphere"]
model = "isotropic"
E = {E1!r}
nu = {nu!r}
[[material]]
name = "block"
regions = ["block"]
model = "isotropic"
E = {E2!r}
nu = {nu!r}
[[contact]]
name = "sphere_block"
slave = "sphere_contact"
master = "block_contact"
[[dirichlet]]
boundary = "block_bottom"
value = [0.0, 0.0, 0.0]
[[dirichlet]]
boundary = "sphere_support_x"
value = [0.0, "free", "free"]
[[dirichlet]]
boundary = "sphere_support_z"
value = ["free", "free", 0.0]
[[traction]]
boundary = "sphere_top"
value = [0.0, -2.0e6, 0.0]
[output]
directory = "results"
fields_every = 0
checkpoint_every = {every}
"""

TUMOUR3D = """format = 1
[scene]
name = "tumour3d"
dimension = 3
[neoplasm]
kind = "tumour"
radius = 1.0
h = {h!r}
t_end = 0.24
dt = 0.04
remesh_every = 1
[neoplasm.tumour]
D_c = 1.0
lambda = 1.0
eps0 = 0.5
K_B = "1.0*(u_c - 0.3)"
K_Q = 0.2
K_P = 0.1
K_R = 0.1
u_p0 = 0.8
u_q0 = 0.1
[output]
directory = "results"
checkpoint_every = {every}
"""


# ----------------------------------------------------------------------------- meshes
def _gmsh_file(path: Path, code: str) -> Path:
    """Run ``code`` (which writes ``path`` with gmsh) in a fresh serial Python, once."""
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        prelude = (
            "import dolfinx_solver\nfrom mpi4py import MPI\n"
            "from bonecontact.meshing import shapes\n"
        )
        subprocess.run([sys.executable, "-c", prelude + code], check=True, env=ENV)
    return path


def impact_mesh(mesh_dir: Path, refine: float) -> Path:
    """The restart tests' 2D cylinder-on-block mesh, contact size ``A/refine``."""
    path = mesh_dir / f"impact2d_{refine:g}.msh"
    h = IMPACT_A / refine
    far = 3e-3 if refine <= 4 else 1e-3
    code = (
        f"shapes.hertz_2d(None, path={str(path)!r}, h_contact={h!r},"
        f" zone={1.5 * IMPACT_A!r}, h_far={far!r})\n"
    )
    return _gmsh_file(path, code)


def contact3d_mesh(mesh_dir: Path, label: str) -> Path:
    """The mesh of ``bench_contact3d.py``'s size ``label`` (lateral supports)."""
    h, h_far, mesher = SIZES[label]
    path = mesh_dir / f"contact3d_{label}_{mesher}.msh"
    code = (
        f"shapes.hertz_3d(MPI.COMM_SELF, {str(path)!r}, radius={LOAD_DRIVEN_RADIUS!r},"
        f" h_contact={h!r}, h_far={h_far!r}, zone=1.5e-3, dist_max_factor=4.0,"
        f" lateral_support=True, algorithm_3d={mesher!r})\n"
    )
    return _gmsh_file(path, code)


# ----------------------------------------------------------------------------- scenes
def scene_impact(work: Path, mesh_dir: Path, refine: float, every: int) -> Path:
    path = work / "scene.toml"
    path.write_text(IMPACT.format(mesh=impact_mesh(mesh_dir, refine), every=every))
    return path


def scene_knee(work: Path, mesh_dir: Path, every: int) -> Path:
    text = (ROOT / "data/scenes/knee2d_gait.toml").read_text()
    text = text.replace('mesh = "knee2d.msh"', f'mesh = "{ROOT / "data/scenes/knee2d.msh"}"')
    text = text.replace("t_end = 1.0", "t_end = 0.2")
    text = text.replace("fields_every = 10", "fields_every = 0")
    text = text.replace(
        'directory = "results/knee2d_gait"',
        f'directory = "results"\ncheckpoint_every = {every}',
    )
    path = work / "scene.toml"
    path.write_text(text)
    return path


def scene_contact3d(work: Path, mesh_dir: Path, label: str, every: int) -> Path:
    E1 = LOAD_DRIVEN_E
    path = work / "scene.toml"
    path.write_text(
        CONTACT3D.format(
            mesh=contact3d_mesh(mesh_dir, label),
            E1=E1,
            E2=LOAD_DRIVEN_STIFFNESS_RATIO * E1,
            nu=LOAD_DRIVEN_NU,
            every=every,
        )
    )
    return path


def scene_tumour2d(work: Path, mesh_dir: Path, every: int) -> Path:
    text = (ROOT / "data/scenes/tumour_growth_2d.toml").read_text()
    text = text.replace("t_end = 1.0368e6", "t_end = 1.728e5")  # 10 steps
    text = text.replace(
        'directory = "results/tumour_growth_2d"',
        f'directory = "results"\ncheckpoint_every = {every}',
    )
    path = work / "scene.toml"
    path.write_text(text)
    return path


def scene_tumour3d(work: Path, mesh_dir: Path, h: float, every: int) -> Path:
    path = work / "scene.toml"
    path.write_text(TUMOUR3D.format(h=h, every=every))
    return path


#: name -> (scene writer (work, mesh_dir, every) -> scene path, checkpoint_every, kind).
CASES: dict[str, tuple[Callable[[Path, Path, int], Path], int, str]] = {
    "impact2d_10k": (lambda w, m, e: scene_impact(w, m, 4, e), 5, "mechanics"),
    "impact2d_27k": (lambda w, m, e: scene_impact(w, m, 12, e), 5, "mechanics"),
    "knee2d_gait": (scene_knee, 5, "mechanics"),
    "contact3d_25k": (lambda w, m, e: scene_contact3d(w, m, "25k", e), 1, "mechanics"),
    "tumour2d": (scene_tumour2d, 2, "growth"),
    "tumour3d": (lambda w, m, e: scene_tumour3d(w, m, 0.13, e), 2, "growth"),
}
DEFAULT = list(CASES)
QUICK = ["impact2d_10k", "tumour2d"]


# ----------------------------------------------------------------------------- runs
class StepTimer:
    """The wall time of every call of ``cls.step`` while it is installed (the benchmark's
    instrumentation: the integrator's or the growth driver's step)."""

    def __init__(self, cls: type):
        self.cls, self.real, self.times = cls, cls.step, []
        real, times = self.real, self.times

        def step(obj, *args, **kwargs):
            t0 = time.perf_counter()
            try:
                return real(obj, *args, **kwargs)
            finally:
                times.append(time.perf_counter() - t0)

        cls.step = step

    def close(self) -> np.ndarray:
        """Uninstall; the times of the steps, slowest rank (collective)."""
        self.cls.step = self.real
        t = np.array(self.times)
        out = np.empty_like(t)
        COMM.Allreduce(t, out, op=MPI.MAX)
        return out


def _run(scene_path: Path, out: Path, kind: str, restart: Path | None = None):
    """Run the scene in-process (collective); the summary and the step times."""
    timer = StepTimer(Integrator if kind == "mechanics" else TumourGrowth)
    try:
        res = run_scene(load_scene(scene_path), COMM, out, progress=False, restart=restart)
    finally:
        times = timer.close()
    if res.status != "converged":
        raise RuntimeError(f"{scene_path}: {res.status}: {res.summary.get('message')}")
    return res.summary, times


def _size(path: Path) -> int:
    return sum(p.stat().st_size for p in path.iterdir() if p.is_file())


def measure(name: str, mesh_dir: Path) -> dict:
    """Run case ``name`` with checkpoints, then restart it from the second-newest one
    (collective)."""
    write_scene, every, kind = CASES[name]
    load = os.getloadavg()[0]
    work = Path(COMM.bcast(tempfile.mkdtemp(prefix=f"ckpt-{name}-") if COMM.rank == 0 else None))
    try:
        scene = COMM.bcast(write_scene(work, mesh_dir, every) if COMM.rank == 0 else None)
        out = work / "out"
        s, times = _run(scene, out, kind)
        steps = int(s["steps"])
        written = int(s["checkpoints"]["written"])
        write_s = float(s["checkpoints"]["write_time_s"]) / written
        ckpts = sorted(p for p in (out / "checkpoints").iterdir() if p.name.startswith("step_"))
        size, state = _size(ckpts[-1]), (ckpts[-1] / "state.h5").stat().st_size
        r, times2 = _run(scene, out, kind, restart=ckpts[0])
        read_s = float(r["phases_s"]["checkpoint"]) - float(r["checkpoints"]["write_time_s"])
        assert r["restarted_from"]["step"] == int(ckpts[0].name[5:])
        assert len(times) == steps and int(r["steps"]) == steps
    finally:
        COMM.barrier()
        if COMM.rank == 0:
            shutil.rmtree(work, ignore_errors=True)
    step_s = float(np.median(times[1:]))  # the first step may compile forms, build caches
    dofs = s.get("dofs")
    cells = s.get("growth", {}).get("final_cells")
    return {
        "case": name,
        "kind": kind,
        "ranks": COMM.size,
        "dofs": "" if dofs is None else dofs,
        "cells": "" if cells is None else cells,
        "steps": steps,
        "step_s": round(step_s, 4),
        "first_step_s": round(float(times[0]), 4),
        "first_step_after_restart_s": round(float(times2[0]), 4),
        "write_s": round(write_s, 4),
        "read_s": round(read_s, 4),
        "size_mb": round(size / 1e6, 3),
        "state_mb": round(state / 1e6, 3),
        "write_per_step": round(write_s / step_s, 3),
        "read_per_step": round(read_s / step_s, 3),
        "load_1min": round(load, 2),
        "machine": machine(),
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help=f"only {', '.join(QUICK)}")
    ap.add_argument("--cases", default=None, help=f"comma-separated, of {', '.join(CASES)}")
    ap.add_argument("--mesh-dir", default=str(Path(tempfile.gettempdir()) / "bench_checkpoint"))
    ap.add_argument("--out", default=str(HERE / "results/checkpoint.csv"))
    args = ap.parse_args()
    names = args.cases.split(",") if args.cases else (QUICK if args.quick else DEFAULT)
    out = Path(args.out)
    for name in names:
        row = measure(name, Path(args.mesh_dir))
        row["date"] = time.strftime("%Y-%m-%d", time.gmtime())
        if COMM.rank == 0:
            print(row, flush=True)
            out.parent.mkdir(parents=True, exist_ok=True)
            new = not out.exists()
            with open(out, "a", newline="") as f:
                w = csv.DictWriter(f, list(row))
                if new:
                    w.writeheader()
                w.writerow(row)


if __name__ == "__main__":
    main()
