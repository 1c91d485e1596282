"""Cost of a dynamic step of the 3D knee gait in contact against a contact-free step of the
same mesh, at a chosen element size (issue #24: "a step in contact ≤ 1.3× a contact-free
step at ≥ 10⁵ dofs").

The mesh is built by the geometry section of ``demos/knee3d_gait.py`` (the shipped femur
and tibia, cortical shell, cancellous core, 2 mm cartilage layers, 0.5 mm clearance)
with the element size ``--h-mm`` instead of the demo's 5/4 mm (the demo's text is run up
to its mesh, so the two cannot drift apart), then split uniformly ``--refine`` times
(gmsh: every tetrahedron into eight, the groups kept).  The joint builder does not give
every size: on 2026-12-02 3.0, 3.3, 3.5 and 3.7 mm failed in gmsh (overlapping facets,
a segment through a facet), 3.6 mm had one degenerate tetrahedron, 1.6 mm turned the
cartilage layer over; 3.4 mm refined once is 126,234 dofs (the default), 3.8 mm 96,924.
The scene is ``data/scenes/knee3d_gait.toml``
(stabilized-newmark, Coulomb μ = 0.02, Δt = 5 ms, MUMPS; μ = 0.1 and Δt = 20 ms before
2026-12-02 18:00 UTC) on that mesh, run by
``run_scene`` (the function ``bonecontact run`` calls) twice: with the contact pair and
without it (the ``[[contact]]`` table removed; the femur then falls through the tibia,
which does not change the cost of a step).  ``--t-end`` shortens the stance phase.

Measured per step (steps after the first, which carries the factorisations): CPU and
wall time of ``Integrator.step``; in contact, the CPU time of its phases, from wrappers
around the package's methods (no change to the package): ``contact`` (the PDAS),
``base_solve`` (the low-rank strategy's base solve, with the columns computed ahead in
the same solve when there are any), ``compute_columns`` (column blocks on a miss), the
small dense systems and set logic (``solve`` minus those); columns ``*_cpu_s``, s per
step.  The ``phases_s`` of both
runs' summary.json are copied into the row (wall, whole run).

``--dt`` replaces the scene's step (5 ms): the zone's growth (steps up to
``SETTLED`` = 0.18 s, the load rising to 2.5 W at 0.15 s) is then spread over more
steps.  Reported: the ratio of the steps after the first (``ratio_cpu``), of the growing
steps (t < 0.18 s) and of the settled ones (t ≥ 0.18 s), and of every step including the
first (``ratio_cpu_all``; not like for like: the contact run's first step carries the
split basis's factorisation and the cold start's columns, the free run factorises in its
set-up, outside the steps); ``--json`` writes the row with every
step's CPU time of both runs and the column blocks of each step (size, with the base
solve or not) to a JSON file, the load (``os.getloadavg``) before and after each run.

Usage:  python benchmarks/bench_knee_gait_cost.py [--h-mm 3.4 --refine 1] [--t-end 0.6]
        [--dt 0.005] [--memory-ratio 0.05] [--out benchmarks/results/knee_gait_cost.csv]
        [--json benchmarks/results/knee_gait_cost_dt.json]
"""

import dolfinx_solver  # noqa: F401

import argparse
import json
import os
import re
import sys
import time
import tomllib
from pathlib import Path

from mpi4py import MPI

import numpy as np
from bench_dynamic_cost import Phases
from common import machine, write_rows

from bonecontact.contact.lowrank import LowRankActiveSetSolver
from bonecontact.contact.pdas import ContactSolver
from bonecontact.mechanics.newmark import StabilizedNewmark
from bonecontact.runners import run_scene
from bonecontact.scene import load_scene

COMM = MPI.COMM_WORLD
ROOT = Path(__file__).resolve().parent.parent
DEMO = ROOT / "demos" / "knee3d_gait.py"
SCENE = ROOT / "data" / "scenes" / "knee3d_gait.toml"
#: time (s) from which the gait's contact zone has settled (no column block after it)
SETTLED = 0.18


def build_mesh(h_mm: float, out: Path) -> Path:
    """The demo's knee mesh with elements of ``h_mm`` mm (its text up to the mesh); an
    existing one in ``out`` is reused."""
    if (out / "knee.msh").exists():
        return out / "knee.msh"
    text = DEMO.read_text()
    head = text[: text.index("\nMATERIALS = ")]
    head, n = re.subn(r"\nH = .*\n", f"\nH = {h_mm} * MM\n", head, count=1)
    if n != 1:
        raise RuntimeError(f"{DEMO}: no line 'H = ...' (element size) to replace")
    argv = sys.argv
    sys.argv = [str(DEMO), str(out)]
    try:
        ns = {"__file__": str(DEMO), "__name__": "knee3d_gait_mesh"}
        exec(compile(head, str(DEMO), "exec"), ns)
    finally:
        sys.argv = argv
    return Path(ns["knee_msh"])


def refined(mesh: Path, times: int) -> Path:
    """``mesh`` with every tetrahedron split into eight ``times`` times (gmsh's uniform
    refinement: the physical groups kept, the new nodes on the old facets, so the
    geometry is the same), for element sizes at which the cartilage layer cannot be
    built (at 1.6 mm a layer of 2 mm turns the finer surface's facets over)."""
    if times == 0:
        return mesh
    out = mesh.with_name(f"{mesh.stem}_r{times}.msh")
    if COMM.rank == 0 and not out.exists():
        import gmsh

        gmsh.initialize()
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("Mesh.SecondOrderLinear", 1)  # (midpoints on the edges)
        gmsh.open(str(mesh))
        for _ in range(times):
            gmsh.model.mesh.refine()
        gmsh.write(str(out))
        gmsh.finalize()
    COMM.barrier()
    return out


def scene_file(mesh: Path, out: Path, contact: bool, t_end: float, dt: float = 0.0) -> Path:
    """The shipped gait scene on ``mesh`` (with or without its contact pair; with the
    step ``dt`` if > 0)."""
    text = SCENE.read_text().replace('mesh = "knee3d_gait.msh"', f'mesh = "{mesh}"')
    text = re.sub(r"\nt_end = .*\n", f"\nt_end = {t_end}\n", text, count=1)
    if dt > 0:
        text = re.sub(r"\ndt = .*\n", f"\ndt = {dt}\n", text, count=1)
    if not contact:
        text = text.replace(text[text.index("[[contact]]") : text.index("[[dirichlet]]")], "")
    path = out / f"knee3d_gait_{'contact' if contact else 'free'}.toml"
    if COMM.rank == 0:
        path.write_text(text)
    COMM.barrier()
    return path


class StepClock:
    """CPU and wall time of every ``StabilizedNewmark.step`` (max over ranks)."""

    def __init__(self):
        self.cpu: list[float] = []
        self.wall: list[float] = []
        #: per step, the column blocks of the contact solver: (columns, with the base solve)
        self.blocks: list[list[tuple[int, bool]]] = []
        f = StabilizedNewmark.step

        def step(integ, *a, **k):
            self.blocks.append([])
            c0, t0 = time.process_time(), time.perf_counter()
            try:
                return f(integ, *a, **k)
            finally:
                self.cpu.append(time.process_time() - c0)
                self.wall.append(time.perf_counter() - t0)

        self._orig = f
        StabilizedNewmark.step = step

    def restore(self) -> None:
        StabilizedNewmark.step = self._orig

    def per_step(self) -> np.ndarray:
        """CPU time of every step (s, max over ranks)."""
        cpu = np.asarray(self.cpu, dtype=np.float64)
        COMM.Allreduce(MPI.IN_PLACE, cpu, op=MPI.MAX)
        return cpu

    def means(self) -> tuple[float, float, int]:
        """Mean CPU and wall time of the steps after the first, their number."""
        cpu = COMM.allreduce(np.asarray(self.cpu[1:]), op=MPI.MAX)
        wall = COMM.allreduce(np.asarray(self.wall[1:]), op=MPI.MAX)
        return float(np.mean(cpu)), float(np.mean(wall)), len(cpu)


def run(scene: Path, out: Path, memory_ratio: float) -> tuple[dict, StepClock, Phases]:
    """Run the scene (the low-rank solver with ``memory_ratio``: not a scene key); its
    summary, the step clock and the contact phases."""
    clock, ph = StepClock(), Phases()
    init = LowRankActiveSetSolver.__init__

    def init_ratio(self, *args, **kw):
        init(self, *args, **{**kw, "memory_ratio": memory_ratio})

    LowRankActiveSetSolver.__init__ = init_ratio
    saved = [
        (cls, name, getattr(cls, name))
        for cls, name in (
            (ContactSolver, "solve"),
            (LowRankActiveSetSolver, "_base_solve"),
            (LowRankActiveSetSolver, "_compute_columns"),
        )
    ]
    for cls, name, _ in saved:
        ph.wrap(cls, name, name.strip("_"))
    block = LowRankActiveSetSolver._compute_block
    saved.append((LowRankActiveSetSolver, "_compute_block", block))

    def logged_block(self, qs, rhs=None):
        clock.blocks[-1].append((len(qs), rhs is not None))
        return block(self, qs, rhs)

    LowRankActiveSetSolver._compute_block = logged_block
    try:
        res = run_scene(load_scene(scene), COMM, output=out, progress=False)
    finally:
        clock.restore()
        LowRankActiveSetSolver.__init__ = init
        for cls, name, f in saved:
            setattr(cls, name, f)
    if res.status != "converged":
        raise SystemExit(f"{scene}: {res.status}: {res.summary.get('message')}")
    return res.summary, clock, ph


def split_ratios(free: np.ndarray, contact: np.ndarray, dt: float) -> dict:
    """Contact/free CPU ratios of the steps after the first, of the growing steps
    (t < :data:`SETTLED`), of the settled ones and of every step (with the first)."""
    t = dt * np.arange(1, contact.size + 1)
    grow = (t < SETTLED - 1e-9) & (np.arange(contact.size) > 0)
    settled = t >= SETTLED - 1e-9
    out = {
        "ratio_cpu_growing": float(contact[grow].mean() / free[grow].mean()),
        "ratio_cpu_settled": float(contact[settled].mean() / free[settled].mean()),
        "ratio_cpu_all": float(contact.sum() / free.sum()),  # (not like for like: below)
        "extra_growing_s": float((contact[grow] - free[grow]).sum()),
        "extra_settled_s": float((contact[settled] - free[settled]).sum()),
    }
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--h-mm", type=float, default=3.4, help="element size (mm)")
    ap.add_argument("--t-end", type=float, default=0.6)
    ap.add_argument("--refine", type=int, default=1, help="uniform refinements of the mesh")
    ap.add_argument("--memory-ratio", type=float, default=0.05)
    ap.add_argument("--work", default="/tmp/knee_gait_cost", help="meshes and run outputs")
    ap.add_argument("--out", default="benchmarks/results/knee_gait_cost.csv")
    ap.add_argument("--dt", type=float, default=0.0, help="time step (s); 0: the scene's")
    ap.add_argument("--json", default="", help="also write the row and per-step data here")
    a = ap.parse_args()
    if a.dt <= 0:
        a.dt = float(tomllib.loads(SCENE.read_text())["analysis"]["dt"])
    work = Path(a.work) / f"h{a.h_mm}"
    t0 = time.perf_counter()
    mesh = refined(build_mesh(a.h_mm, work), a.refine)
    t_mesh = time.perf_counter() - t0
    rows, loads = {}, []
    for contact in (False, True):
        scene = scene_file(mesh, work, contact, a.t_end, a.dt)
        out = work / ("contact" if contact else "free")
        loads.append(os.getloadavg()[0])
        rows[contact] = run(scene, out, a.memory_ratio)
    loads.append(os.getloadavg()[0])
    (s_free, c_free, _), (s_con, c_con, ph) = rows[False], rows[True]
    cpu_f, wall_f, n_f = c_free.means()
    cpu_c, wall_c, n_c = c_con.means()
    steps_all = len(c_con.cpu)
    phase = {k: COMM.allreduce(v, op=MPI.MAX) / steps_all for k, v in ph.snapshot().items()}
    row = dict(
        case="knee_gait",
        h_mm=a.h_mm,
        refine=a.refine,
        dofs=s_con.get("dofs", -1),
        ranks=COMM.size,
        steps=n_c,
        memory_ratio=a.memory_ratio,
        free_step_cpu_s=cpu_f,
        contact_step_cpu_s=cpu_c,
        ratio_cpu=cpu_c / cpu_f,
        dt=a.dt,
        **split_ratios(c_free.per_step(), c_con.per_step(), a.dt),
        blocks=sum(len(b) for b in c_con.blocks),
        columns=sum(k for b in c_con.blocks for k, _ in b),
        free_step_s=wall_f,
        contact_step_s=wall_c,
        ratio=wall_c / wall_f,
        mesh_s=t_mesh,
    )
    for k in ("solve", "base_solve", "compute_columns"):
        row[f"{k}_cpu_s"] = phase.get(f"{k}_cpu", 0.0)
    row["phases_contact"] = json.dumps(s_con.get("phases_s", {}))
    row["phases_free"] = json.dumps(s_free.get("phases_s", {}))
    row["machine"] = machine() + " (busy)"
    row["load_1min"] = "/".join(f"{v:.1f}" for v in loads)
    if COMM.rank == 0:
        print({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in row.items()})
    out = Path(a.out)
    write_rows(out.parent, out.stem, [row])
    if a.json and COMM.rank == 0:
        steps = {"free_cpu": c_free.cpu, "contact_cpu": c_con.cpu, "step_blocks": c_con.blocks}
        data = {**row, **steps}
        Path(a.json).write_text(json.dumps(data, indent=1))


if __name__ == "__main__":
    main()
