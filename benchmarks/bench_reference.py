"""The reference of the 3D contact figures: ONE linear solve of the same mesh, done plainly.

The mesh is the load-driven 3D Hertz mesh of ``bench_contact3d.py``, ``bench_krylov3d.py``
and ``bench_scale3d.py`` (the same ``.msh`` file, read the way a scene reads it,
:func:`bonecontact.meshing.io.read_gmsh_mesh`).  The problem is linear elasticity of
both bodies *without* contact, each body clamped: the block at its base
(``block_bottom``), the hemisphere at its flat loaded face (``sphere_top``), loaded by a
uniform body force whose resultant is the Hertz load P of the contact benchmark.  It is
solved by a plain DOLFINx :class:`dolfinx.fem.petsc.LinearProblem` (no bonecontact
solver code) with one of

* ``gamg_nns`` — CG + GAMG with the rigid-body near-nullspace (six modes per body),
  Chebyshev/Jacobi smoothing (the options of DOLFINx's elasticity demo), rtol 1e-8;
* ``gamg_default`` — CG + GAMG with PETSc's defaults and no near-nullspace, rtol 1e-8;
* ``mumps`` — LU by MUMPS (the direct path's reference);

a suffix ``@<rtol>`` (e.g. ``gamg_default@1e-12``) solves to that relative tolerance
instead (the contact solve's final Krylov solves use 1e-12).

Each run is a fresh process under ``mpiexec -n N`` (so its peak resident memory,
``ru_maxrss``, is its own): wall time of assemble + solve (``LinearProblem`` built — matrix,
vector, KSP — and ``solve()``: assembly, preconditioner set-up, solve; the forms are
compiled before the clock starts), the Krylov iterations, the peak resident memory per
rank (largest rank, and the sum) of the whole process (mesh read included, as a scene
run's ``summary.json`` counts it), and bytes per dof per rank.

With ``--contact`` the same loop runs ``bench_scale3d.py``'s scene run (``bonecontact run``,
``linear = "iterative"``; ``"direct"`` too with ``mumps`` among the variants) for the same
mesh and ranks right after the reference runs of each repeat, so that both see the same
machine state; ratios contact / reference (time, CG iterations, peak memory) are taken
between medians.  The scene's ``[solver] tolerance`` is ``--contact-tolerance``: 1e-6 by
default, so that its final Krylov solve stops at rtol 1e-8 like the reference
(``bonecontact.contact.krylov.krylov_rtol``); 1e-10 (the scene default) gives 1e-12.

Usage::

    python benchmarks/bench_reference.py --sizes 65k --ranks 1 --repeats 3 --contact
    python benchmarks/bench_reference.py --sizes 200k --ranks 2 --variants gamg_nns,mumps

Writes ``results/reference_<size>_<ranks>.json`` (every run, the medians, the ratios, the
machine and its load average at each run).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

OUT = HERE / "results"
VARIANTS = ("gamg_nns", "gamg_default", "mumps")
RTOL = 1e-8

#: PETSc options of each variant (under the LinearProblem's own prefix).
OPTIONS: dict[str, dict[str, object]] = {
    "gamg_nns": {
        "ksp_type": "cg",
        "ksp_rtol": RTOL,
        "pc_type": "gamg",
        "pc_gamg_type": "agg",
        "mg_levels_ksp_type": "chebyshev",
        "mg_levels_pc_type": "jacobi",
        "mg_levels_esteig_ksp_type": "cg",
        "mg_levels_ksp_chebyshev_esteig_steps": 20,
    },
    "gamg_default": {"ksp_type": "cg", "ksp_rtol": RTOL, "pc_type": "gamg"},
    "mumps": {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"},
}


# ------------------------------------------------------------------------- worker (MPI)
def variant_options(variant: str) -> dict[str, object]:
    """PETSc options of a variant name (``name`` or ``name@rtol``)."""
    base, _, rtol = variant.partition("@")
    if base not in OPTIONS:
        raise SystemExit(f"unknown variant {variant!r}; allowed: {', '.join(OPTIONS)}[@rtol]")
    opts = dict(OPTIONS[base])
    if rtol:
        opts["ksp_rtol"] = float(rtol)
    return opts


def _peak_mib() -> float:
    """This process's peak resident set so far (MiB, Linux)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _forms(md, P: float):
    """Bilinear and linear forms of the clamped two-body problem, and the space."""
    from petsc4py import PETSc

    import ufl
    from dolfinx import fem

    from bonecontact.verification.load_driven import (
        LOAD_DRIVEN_E,
        LOAD_DRIVEN_NU,
        LOAD_DRIVEN_STIFFNESS_RATIO,
    )

    msh = md.mesh
    V = fem.functionspace(msh, ("Lagrange", 1, (3,)))
    Q = fem.functionspace(msh, ("DG", 0))
    E = fem.Function(Q)
    E.x.array[:] = LOAD_DRIVEN_E
    block = md.cell_tags.find(md.physical_groups["block"].tag)
    E.x.array[block] = LOAD_DRIVEN_STIFFNESS_RATIO * LOAD_DRIVEN_E
    nu = LOAD_DRIVEN_NU
    mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def sigma(w):
        eps = ufl.sym(ufl.grad(w))
        return 2 * mu * eps + lmbda * ufl.tr(eps) * ufl.Identity(3)

    one = fem.Constant(msh, PETSc.ScalarType(1.0))
    vol = msh.comm.allreduce(fem.assemble_scalar(fem.form(one * ufl.dx)), op=_sum())
    f = fem.Constant(msh, PETSc.ScalarType((0.0, -P / vol, 0.0)))
    a = ufl.inner(sigma(u), ufl.sym(ufl.grad(v))) * ufl.dx
    L = ufl.inner(f, v) * ufl.dx
    return V, a, L


def _sum():
    from mpi4py import MPI

    return MPI.SUM


def _clamps(md, V):
    """u = 0 on the block's base and on the hemisphere's flat face."""
    import numpy as np
    from dolfinx import fem

    fdim = md.mesh.topology.dim - 1
    bcs = []
    for name in ("block_bottom", "sphere_top"):
        facets = md.facet_tags.find(md.physical_groups[name].tag)
        dofs = fem.locate_dofs_topological(V, fdim, facets)
        bcs.append(fem.dirichletbc(np.zeros(3), dofs, V))
    return bcs


def worker(label: str, variant: str, mesh_dir: Path) -> None:
    """One reference run in this (fresh) process; rank 0 prints one JSON line."""
    import dolfinx_solver  # noqa: F401

    from mpi4py import MPI
    from petsc4py import PETSc

    from bench_contact3d import SIZES
    from bench_scale3d import load
    from dolfinx import fem
    from dolfinx.fem.petsc import LinearProblem

    from bonecontact.common.linalg import rigid_body_modes
    from bonecontact.meshing.io import read_gmsh_mesh

    comm = MPI.COMM_WORLD
    mesher = SIZES[label][2]
    _, md = read_gmsh_mesh(mesh_dir / f"contact3d_{label}_{mesher}.msh", comm, 3)
    mem_mesh = _peak_mib()
    V, a, L = _forms(md, load())
    fem.form(a), fem.form(L)  # JIT-compile (cached) before the clock starts
    bcs = _clamps(md, V)
    nns = rigid_body_modes(V, per_body=True) if variant.startswith("gamg_nns") else None
    comm.barrier()
    t0, c0, f0 = time.perf_counter(), time.process_time(), PETSc.Log.getFlops()
    problem = LinearProblem(
        a, L, bcs=bcs, petsc_options=variant_options(variant), petsc_options_prefix="ref_"
    )
    if nns is not None:
        problem.A.setNearNullSpace(nns)
    uh = problem.solve()
    comm.barrier()
    t = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    cpu = comm.allreduce(time.process_time() - c0, op=MPI.SUM)
    flops = comm.allreduce(PETSc.Log.getFlops() - f0, op=MPI.SUM)
    ksp = problem.solver
    its, reason = ksp.getIterationNumber(), ksp.getConvergedReason()
    dofs = V.dofmap.index_map.size_global * 3
    local = V.dofmap.index_map.size_local * 3
    umax = comm.allreduce(float(abs(uh.x.array).max(initial=0.0)), op=MPI.MAX)
    peak = _peak_mib()
    row = {
        "kind": "reference",
        "variant": variant,
        "size": label,
        "ranks": comm.size,
        "dofs": dofs,
        "t_assemble_solve_s": round(t, 3),
        "cpu_assemble_solve_s": round(cpu, 3),  # (summed over the ranks)
        "gflops": round(flops / 1e9, 3),  # (PETSc's count, summed over the ranks)
        "iterations": its,
        "reason": reason,
        "u_max": umax,
        "peak_mib_max_rank": round(comm.allreduce(peak, op=MPI.MAX), 1),
        "peak_mib_total": round(comm.allreduce(peak, op=MPI.SUM), 1),
        "mesh_read_peak_mib_max_rank": round(comm.allreduce(mem_mesh, op=MPI.MAX), 1),
        "bytes_per_dof_per_rank": round(
            comm.allreduce(peak * 2**20 / max(local, 1), op=MPI.MAX), 1
        ),
    }
    if comm.rank == 0:
        print("RESULT " + json.dumps(row), flush=True)


# ----------------------------------------------------------------------- driver (serial)
def _load_average() -> float:
    return round(os.getloadavg()[0], 2)


def run_reference(label: str, ranks: int, variant: str, mesh_dir: Path) -> dict:
    """One reference run in a fresh ``mpiexec -n ranks`` process."""
    venv = Path(sys.executable).parent
    cmd = [str(venv / "mpiexec"), "-n", str(ranks), sys.executable, str(Path(__file__).resolve())]
    cmd += ["--worker", "--sizes", label, "--variants", variant, "--mesh-dir", str(mesh_dir)]
    load0 = _load_average()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    lines = [x for x in proc.stdout.splitlines() if x.startswith("RESULT ")]
    if proc.returncode != 0 or not lines:
        return {"kind": "reference", "variant": variant, "status": proc.stderr[-400:]}
    return {**json.loads(lines[-1][7:]), "load_before": load0, "status": "ok"}


def run_contact(label: str, ranks: int, linear: str, mesh: Path, tolerance: float) -> dict:
    """One scene run of ``bench_scale3d.py`` (the contact problem of the same mesh, the
    scene's ``[solver] tolerance``)."""
    from bench_scale3d import run_case

    load0 = _load_average()
    row = run_case(label, ranks, linear, mesh, None, tolerance)
    return {"kind": "contact", "variant": linear, **row, "load_before": load0}


def _median(rows: list[dict], key: str) -> float | None:
    vals = [float(r[key]) for r in rows if r.get(key) is not None]
    return statistics.median(vals) if vals else None


def summarize(runs: list[dict]) -> dict:
    """Medians per (kind, variant) and the contact / reference ratios."""
    med: dict[str, dict] = {}
    keys = {
        "reference": ("t_assemble_solve_s", "iterations", "peak_mib_max_rank", "peak_mib_total"),
        "contact": ("t_contact_solve", "t_solver_setup", "wall_s", "linear_iterations",
                    "mem_max_rank_mb", "mem_total_mb", "t_output", "t_mesh_read"),
    }  # fmt: skip
    for r in runs:
        if r.get("status") not in ("ok", "converged"):
            continue
        name = f"{r['kind']}:{r['variant']}"
        group = [x for x in runs if f"{x['kind']}:{x['variant']}" == name]
        med[name] = {k: _median(group, k) for k in keys[r["kind"]]} | {"runs": len(group)}
    ratios: dict[str, dict] = {}
    for name, m in med.items():
        if not name.startswith("contact:"):
            continue
        for ref in [k.split(":", 1)[1] for k in med if k.startswith("reference:")]:
            if (ref.startswith("mumps")) != name.endswith("direct"):
                continue
            rm = med[f"reference:{ref}"]
            ratios[f"{name} / {ref}"] = _ratios(m, rm)
    return {"medians": med, "ratios": ratios}


def _ratios(m: dict, rm: dict) -> dict:
    def q(a, b):
        return round(a / b, 2) if a is not None and b else None

    setup_solve = (m["t_contact_solve"] or 0.0) + (m["t_solver_setup"] or 0.0)
    return {
        "time_contact_solve": q(m["t_contact_solve"], rm["t_assemble_solve_s"]),
        "time_setup_plus_solve": q(setup_solve, rm["t_assemble_solve_s"]),
        "iterations": q(m["linear_iterations"], rm["iterations"]),
        "peak_memory_max_rank": q(m["mem_max_rank_mb"], rm["peak_mib_max_rank"]),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="65k", help="labels of bench_contact3d.SIZES")
    p.add_argument("--ranks", default="1", help="comma-separated rank counts")
    p.add_argument("--variants", default=",".join(VARIANTS))
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--contact", action="store_true", help="also run the contact scene")
    p.add_argument("--mesh-dir", type=Path, default=Path("/tmp/bonecontact-bench-meshes"))
    p.add_argument("--out", type=Path, default=OUT)
    p.add_argument(
        "--contact-tolerance",
        type=float,
        default=1e-6,
        help="the contact scene's [solver] tolerance (1e-6: final Krylov rtol 1e-8, the "
        "reference's; 1e-10, the scene default: 1e-12)",
    )
    p.add_argument("--tag", default="", help="suffix of the output file (e.g. 'before')")
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = p.parse_args()
    variants = args.variants.split(",")
    if args.worker:
        worker(args.sizes, variants[0], args.mesh_dir)
        return
    import dolfinx_solver  # noqa: F401

    from bench_scale3d import make_mesh
    from common import machine

    for label in args.sizes.split(","):
        mesh = make_mesh(label, args.mesh_dir)
        for ranks in map(int, args.ranks.split(",")):
            runs: list[dict] = []
            for rep in range(args.repeats):
                for v in variants:
                    runs.append(run_reference(label, ranks, v, args.mesh_dir) | {"repeat": rep})
                    print(json.dumps(runs[-1]), flush=True)
                linears = ["iterative"] + (["direct"] if "mumps" in variants else [])
                for linear in linears if args.contact else []:
                    runs.append(
                        run_contact(label, ranks, linear, mesh, args.contact_tolerance)
                        | {"repeat": rep}
                    )
                    print(json.dumps(runs[-1]), flush=True)
            out = {"size": label, "ranks": ranks, "machine": machine(),
                   "contact_tolerance": args.contact_tolerance,
                   "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                   "runs": runs, **summarize(runs)}  # fmt: skip
            tag = f"_{args.tag}" if args.tag else ""
            path = args.out / f"reference_{label}_{ranks}{tag}.json"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(out, indent=1))
            print(json.dumps({"medians": out["medians"], "ratios": out["ratios"]}, indent=1))


if __name__ == "__main__":
    main()
