"""3D load-driven contact at scale, run as a user runs it: a scene file, ``bonecontact run``.

The problem is the one of ``bench_contact3d.py`` (a hemisphere of E = 2 GPa held only by
contact on a block a thousand times stiffer, loaded by a uniform traction on its flat
face, target a/R = 0.1), written as a scene that reads a gmsh mesh file, and run by the
command line under ``mpiexec -n N``.  Measured from the outside: the wall time from the
scene file to the written results (mesh read, assembly, mortar geometry, contact solve,
output); from ``summary.json``: the phases, the PDAS and Krylov iterations and the peak
memory (largest rank and all ranks); from ``contact_sphere_block.csv``: the Hertz errors
of a and p₀ (fitted as λ² = p₀²(1 − r²/a²) over r < 0.8 a, as ``hertz_errors`` does).

Usage::

    python benchmarks/bench_scale3d.py --sizes 200k --ranks 1,2 --linear iterative
    python benchmarks/bench_scale3d.py --sizes 1M --ranks 2

Writes ``benchmarks/results/scale3d.csv`` (one row per size, rank count and solver,
appended).  Meshes are made once by gmsh's HXT mesher into ``--mesh-dir``.

Memory per dof: every row has ``bytes_per_dof_rank`` (the largest rank's peak over its
share of the dofs) and, when ``summary.json`` has it, ``memory_bytes_per_dof`` by phase.
``--budget R`` holds the peak to R times that of one plain linear solve of the same mesh
on the same ranks (``results/reference_<size>_<ranks>.json`` of ``bench_reference.py``,
its ``gamg_default`` row — ``mumps`` for the direct path): a row over it gets
``status = over budget`` and the script exits with status 1.  ``--phase-budget`` holds
each phase to :data:`PHASE_BUDGET` (bytes per owned dof of the largest rank: what the
solver set-up and the contact solve keep, what the output adds above them) the same way.
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from bench_contact3d import SIZES  # noqa: E402
from common import machine  # noqa: E402

from bonecontact.verification.analytic import hertz_3d  # noqa: E402
from bonecontact.verification.load_driven import (  # noqa: E402
    LOAD_DRIVEN_E,
    LOAD_DRIVEN_NU,
    LOAD_DRIVEN_RADIUS,
    LOAD_DRIVEN_STIFFNESS_RATIO,
)

OUT = HERE / "results"
A_OVER_R = 0.1

#: Memory budget by phase (issue 28), bytes per owned dof of the largest rank, from
#: ``summary.json``'s ``memory_bytes_per_dof``: ``solver_setup`` what the set-up keeps
#: (resident at its end less the resident after the mortar geometry: the step operator,
#: the condensed operator, its contact rows and stripes, Q, T, the near-nullspace),
#: ``time_stepping`` what the contact solve keeps beyond that (GAMG hierarchy, Krylov and
#: PDAS work), ``output`` the field writer's peak above the resident set of the solve when
#: it raises the run's peak (0 when the output stays below the solve's peak: summary.json's
#: peaks are high-water marks so far, so a lower peak of the output is not known).
#: Their sum, 1850 B/dof, is what a run may add to its mesh and model and stay within
#: 1.5 times one plain linear solve of the same mesh (65k dofs on 1 rank and 1M on 2:
#: 1.5 x 4.5 kB resp. 2.7 kB per dof, of which the mesh read and the model hold 4.9
#: resp. 2.2 kB; issue 28's target).
PHASE_BUDGET = {"solver_setup": 1000.0, "time_stepping": 500.0, "output": 350.0}

SCENE = """\
# 3D load-driven Hertz contact (benchmark scene; SI units)
format = 1

[scene]
name = "scale3d_{label}"
mesh = "{mesh}"
dimension = 3

[analysis]
kind = "static"
load_steps = 1

[solver]
linear = "{linear}"
max_iterations = 40
tolerance = {tolerance!r}
multigrid = "{multigrid}"

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
value = [0.0, {traction!r}, 0.0]

[output]
directory = "{results}"
fields_every = 1
"""


def load() -> float:
    """The resultant P that gives a = A_OVER_R · R by Hertz's formula (N)."""
    R, E1, nu = LOAD_DRIVEN_RADIUS, LOAD_DRIVEN_E, LOAD_DRIVEN_NU
    E2 = LOAD_DRIVEN_STIFFNESS_RATIO * E1
    return hertz_3d.load_for_radius(A_OVER_R * R, R, E1, nu, E2, nu)


def make_mesh(label: str, mesh_dir: Path) -> Path:
    """The gmsh file of ``label`` (made once, serially, by the benchmark's mesher)."""
    h, h_far, mesher = SIZES[label]
    path = mesh_dir / f"contact3d_{label}_{mesher}.msh"
    if not path.exists():
        code = (
            "import dolfinx_solver\n"
            "from mpi4py import MPI\n"
            "from bonecontact.meshing.shapes import hertz_3d\n"
            f"hertz_3d(MPI.COMM_SELF, {str(path)!r}, radius={LOAD_DRIVEN_RADIUS!r},"
            f" h_contact={h!r}, h_far={h_far!r}, zone=1.5e-3, dist_max_factor=4.0,"
            f" lateral_support=True, algorithm_3d={mesher!r})\n"
        )
        mesh_dir.mkdir(parents=True, exist_ok=True)
        subprocess.run([sys.executable, "-c", code], check=True)
    return path


def hertz_from_table(table: Path) -> dict[str, float]:
    """Relative errors of a and p₀ fitted from the contact table against Hertz for the
    applied load."""
    R, E1, nu = LOAD_DRIVEN_RADIUS, LOAD_DRIVEN_E, LOAD_DRIVEN_NU
    E2 = LOAD_DRIVEN_STIFFNESS_RATIO * E1
    P = load()
    with open(table) as f:
        rows = [r for r in csv.DictReader(f)]
    x = np.array([float(r["x"]) for r in rows])
    z = np.array([float(r["z"]) for r in rows])
    lam = np.array([float(r["pressure"]) for r in rows])
    a_ref = hertz_3d.radius(P, R, E1, nu, E2, nu)
    p0_ref = hertz_3d.peak_pressure(P, R, E1, nu, E2, nu)
    rr = np.hypot(x, z)
    sel = rr < 0.8 * a_ref
    c0, c1 = np.linalg.lstsq(np.c_[np.ones(sel.sum()), rr[sel] ** 2], lam[sel] ** 2, rcond=None)[0]
    return {
        "err_a": float(np.sqrt(-c0 / c1) / a_ref - 1.0),
        "err_p0": float(np.sqrt(c0) / p0_ref - 1.0),
    }


def run_case(
    label: str,
    ranks: int,
    linear: str,
    mesh: Path,
    keep: Path | None,
    tolerance: float = 1e-10,
    multigrid: str = "compressed",
) -> dict:
    """Write the scene, run ``bonecontact run`` on ``ranks`` ranks, collect the figures.
    ``tolerance``: the scene's ``[solver] tolerance`` (the default 1e-10: Krylov rtol
    1e-12; 1e-6: rtol 1e-8, the plain linear solve's; ``contact.krylov.krylov_rtol``);
    ``multigrid``: its ``[solver] multigrid`` (``"gamg"`` or ``"compressed"``)."""
    work = Path(tempfile.mkdtemp(prefix=f"scale3d-{label}-")) if keep is None else keep
    work.mkdir(parents=True, exist_ok=True)
    results = work / "results"
    R = LOAD_DRIVEN_RADIUS
    text = SCENE.format(
        label=label,
        mesh=mesh,
        linear=linear,
        tolerance=float(tolerance),
        multigrid=multigrid,
        E1=LOAD_DRIVEN_E,
        E2=LOAD_DRIVEN_STIFFNESS_RATIO * LOAD_DRIVEN_E,
        nu=LOAD_DRIVEN_NU,
        traction=-load() / (np.pi * R**2),
        results=results,
    )
    scene = work / "scene.toml"
    scene.write_text(text)
    venv = Path(sys.executable).parent
    cmd = [str(venv / "mpiexec"), "-n", str(ranks), str(venv / "bonecontact"), "run", str(scene)]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    row: dict = {"label": label, "ranks": ranks, "linear": linear, "wall_s": round(wall, 2)}
    row["tolerance"] = float(tolerance)
    row["multigrid"] = multigrid
    if proc.returncode != 0:
        row["status"] = f"failed (exit {proc.returncode}): " + proc.stderr.strip()[-300:]
        return row
    summary = json.loads((results / "summary.json").read_text())
    row["status"] = "converged"
    row.update(_summary_figures(summary))
    row.update(hertz_from_table(results / "contact_sphere_block.csv"))
    return row


def _summary_figures(summary: dict) -> dict:
    """The figures of ``summary.json`` this study reports."""
    out: dict = {"dofs": summary.get("dofs")}
    mem = summary.get("peak_memory_mb", {})
    out["mem_max_rank_mb"] = mem.get("max_rank")
    out["mem_total_mb"] = mem.get("total")
    if out["dofs"] and mem.get("max_rank"):
        share = out["dofs"] / max(int(summary.get("ranks", 1)), 1)
        out["bytes_per_dof_rank"] = round(mem["max_rank"] * 2**20 / share, 1)
    if "memory_bytes_per_dof" in summary:
        out["memory_bytes_per_dof"] = json.dumps(summary["memory_bytes_per_dof"])
    out["pdas_iterations"] = summary.get("contact", {}).get("pdas_iterations", {}).get("total")
    out["linear_iterations"] = summary.get("linear_iterations", {}).get("total")
    for name, value in summary.get("phases_s", {}).items():
        out[f"t_{name}"] = round(float(value), 2)
    return out


def reference_peak_mb(out: Path, label: str, ranks: int, linear: str) -> float | None:
    """Peak memory per rank (MiB, median) of one plain linear solve of the same mesh and
    ranks, from ``bench_reference.py``'s results (``None`` if it has not been run)."""
    path = out / f"reference_{label}_{ranks}.json"
    if not path.exists():
        return None
    med = json.loads(path.read_text()).get("medians", {})
    ref = med.get("reference:mumps" if linear == "direct" else "reference:gamg_default")
    return ref.get("peak_mib_max_rank") if ref else None


def check_budget(row: dict, out: Path, budget: float | None) -> bool:
    """Add the peak-memory ratio to the reference to ``row``; ``False`` if over ``budget``."""
    ref = reference_peak_mb(out, row["label"], row["ranks"], row["linear"])
    if ref is None or row.get("mem_max_rank_mb") is None:
        return True
    row["mem_ratio_to_reference"] = round(row["mem_max_rank_mb"] / ref, 2)
    if budget is not None and row["mem_ratio_to_reference"] > budget:
        row["status"] = f"over budget ({row['mem_ratio_to_reference']} > {budget})"
        return False
    return True


def phase_growth(memory: dict[str, dict[str, float]]) -> dict[str, float]:
    """What each budgeted phase adds (bytes per dof; :data:`PHASE_BUDGET`) from
    ``summary.json``'s ``memory_bytes_per_dof`` (phases missing there are left out)."""
    res = {k: v["resident"] for k, v in memory.items()}
    out: dict[str, float] = {}
    if "solver_setup" in res and "mortar_geometry" in res:
        out["solver_setup"] = res["solver_setup"] - res["mortar_geometry"]
    if "time_stepping" in res and "solver_setup" in res:
        out["time_stepping"] = res["time_stepping"] - res["solver_setup"]
    if "output" in memory and "time_stepping" in memory:
        # (the peaks are high-water marks so far: the output's own peak is known only when
        # it raised the run's; below the solve's peak it adds nothing to the run's peak)
        raised = memory["output"]["peak"] > memory["time_stepping"]["peak"]
        out["output"] = memory["output"]["peak"] - res["time_stepping"] if raised else 0.0
    return {k: round(v, 1) for k, v in out.items()}


def check_phase_budget(row: dict, enforce: bool) -> bool:
    """Add each phase's growth and its ratio to :data:`PHASE_BUDGET` to ``row``
    (``phase_bytes_per_dof``); ``False`` if ``enforce`` and a phase is over its budget."""
    if "memory_bytes_per_dof" not in row:
        return True
    growth = phase_growth(json.loads(row["memory_bytes_per_dof"]))
    row["phase_bytes_per_dof"] = json.dumps(growth)
    over = {k: v for k, v in growth.items() if v > PHASE_BUDGET[k]}
    row["phase_budget"] = "ok" if not over else "over: " + ", ".join(sorted(over))
    if enforce and over:
        row["status"] = f"over phase budget ({row['phase_budget']})"
        return False
    return True


def append_row(target: Path, row: dict) -> None:
    """Append ``row`` to the CSV file; a column the file does not have yet is added (the
    file rewritten with the union of the columns, old rows empty there)."""
    rows: list[dict] = []
    columns = list(row)
    if target.exists():
        with open(target, newline="") as f:
            reader = csv.DictReader(f)
            rows = list(reader)
            old = list(reader.fieldnames or [])
            columns = old + [k for k in row if k not in old]
    with open(target, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns)
        w.writeheader()
        w.writerows(rows + [row])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="200k", help="labels of bench_contact3d.SIZES, e.g. 200k,1M")
    p.add_argument("--ranks", default="1,2", help="comma-separated rank counts")
    p.add_argument("--linear", default="iterative", help="iterative and/or direct")
    p.add_argument("--mesh-dir", type=Path, default=Path("/tmp/bonecontact-bench-meshes"))
    p.add_argument("--out", type=Path, default=OUT)
    p.add_argument("--keep", type=Path, default=None, help="keep the scene and results here")
    p.add_argument(
        "--budget", type=float, default=None, help="peak memory / one plain linear solve's"
    )
    p.add_argument(
        "--phase-budget", action="store_true", help="hold each phase to PHASE_BUDGET (B/dof)"
    )
    p.add_argument("--tolerance", type=float, default=1e-10, help="the scene's [solver] tolerance")
    p.add_argument("--multigrid", default="compressed", help="the scene's [solver] multigrid")
    args = p.parse_args()
    within = True
    args.out.mkdir(parents=True, exist_ok=True)
    target = args.out / "scale3d.csv"
    info = machine()
    for label in args.sizes.split(","):
        mesh = make_mesh(label, args.mesh_dir)
        for linear in args.linear.split(","):
            for n in map(int, args.ranks.split(",")):
                row = run_case(label, n, linear, mesh, args.keep, args.tolerance, args.multigrid)
                within = check_budget(row, args.out, args.budget) and within
                within = check_phase_budget(row, args.phase_budget) and within
                row["machine"] = info
                print(json.dumps(row), flush=True)
                append_row(target, row)
    if not within:
        raise SystemExit(1)


if __name__ == "__main__":
    main()
