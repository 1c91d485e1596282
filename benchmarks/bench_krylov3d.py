"""Krylov settings of the iterative 3D contact solve, compared in one process.

The load-driven 3D Hertz problem of ``bench_contact3d.py`` (hemisphere held only by
contact, CG + GAMG) is built once per size; then the contact solve is repeated from a
cold start with each variant of the Krylov settings, the variants alternating over
``--rounds`` rounds so that all see the same machine load.  Per solve: PDAS and CG
iterations, preconditioner builds, PETSc floating-point operations of the contact solve
(summed over the ranks: independent of the load), its wall time and CPU time (summed over
the ranks: less sensitive to other processes on the cores), the active nodes, the
Hertz errors, the equilibrium defect and the largest displacement difference from the
first variant (relative to the largest displacement).  Once per size and round, one
iterative linear solve of the same mesh (``bench_contact3d.linear_solve``: the hemisphere
supported at the slave nodes within the Hertz radius, a fresh CG + GAMG, tight
tolerance); every row of the round gives the contact solve's wall time, CPU time and
flops as ratios to it.

Variants (``--variants``, comma-separated): ``tight`` (every Krylov solve to the tight
tolerance), ``loose1e-2`` … (inexact PDAS with that loose tolerance), and suffixes
``+cheb1`` (one Chebyshev iteration per level), ``+v`` (V-cycles), ``+reuseP`` /
``+noreuseP`` (``pc_gamg_reuse_interpolation`` on / off; off by default),
``+chol`` / ``+lu`` (the coarse grid's factorisation; LU by default), ``+agg1`` (one
level of aggressive coarsening),
``+th0.05``, ``+th0``, ``+thcoarse0.05`` (``pc_gamg_threshold``; 0.01 on the fine level, 0.05
below), ``+agg0`` / ``+agg2`` (aggressive coarsening on no / two levels; one by default),
``+eig10`` (10 Chebyshev eigenvalue-estimate steps), ``+fv1`` (a V-cycle on the finest
level, W-cycles below), ``+sm1x1`` (one Chebyshev step on the first coarse level),
``+cel<n>`` (a coarse grid of at most n equations; ``+cel50``: GAMG's default, the
setting before 2026-11-27), ``+cmg`` / ``+cmgv`` (the compressed-aggregation hierarchy
instead of GAMG, W- / V-cycles: ``LinearOptions.multigrid = "compressed"``), e.g.
``loose1e-4+cheb1``.

Usage (also under ``mpiexec -n 2``)::

    python benchmarks/bench_krylov3d.py --sizes 65k,200k --variants tight,loose1e-4 --rounds 2

Appends rows to ``results/krylov3d.csv`` (the figures: benchmarks/README.md, "Inexact
PDAS").
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import argparse
import os
import tempfile
import time
from pathlib import Path

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
from bench_contact3d import SIZES, linear_solve
from common import machine, write_rows

from bonecontact.common.linalg import set_solver_options, solver_options
from bonecontact.contact.krylov import GAMG_OPTIONS, coarse_grid_limit, set_multigrid
from bonecontact.verification.load_driven import hertz_errors, sphere_on_block_3d

COMM = MPI.COMM_WORLD
OUT = Path(__file__).parent / "results"
PREFIX = "bc_contact_"

#: PETSc options of the suffixes (under the contact solver's prefix).
SUFFIXES: dict[str, dict[str, object]] = {
    "cheb1": {"mg_levels_ksp_max_it": 1},
    "v": {"pc_mg_cycle_type": "v"},
    "reuseP": {"pc_gamg_reuse_interpolation": True},
    "noreuseP": {"pc_gamg_reuse_interpolation": False},
    "chol": {"mg_coarse_sub_pc_type": "cholesky"},
    "lu": {"mg_coarse_sub_pc_type": "lu"},
    "agg1": {"pc_gamg_aggressive_coarsening": 1},
    "th0.05": {"pc_gamg_threshold": 0.05},
    "th-1": {"pc_gamg_threshold": -1.0},
    "th0": {"pc_gamg_threshold": 0.0},
    "thcoarse0.05": {"pc_gamg_threshold": "0.01,0.05,0.05"},
    "agg0": {"pc_gamg_aggressive_coarsening": 0},
    "agg2": {"pc_gamg_aggressive_coarsening": 2},
    "eig10": {"mg_levels_ksp_chebyshev_esteig_steps": 10},
}
#: Suffixes set on the hierarchy after each build (not PETSc options): ``fv1`` a
#: V-cycle on the finest level (the first coarse level visited once per cycle, W-cycles
#: below), ``sm1x1`` one Chebyshev step (instead of 2) on the first coarse level.
LEVEL_SUFFIXES = ("fv1", "sm1x1")
#: Suffixes choosing the multigrid (not PETSc options): kind and cycle.
MULTIGRID_SUFFIXES = {"cmg": ("compressed", "w"), "cmgv": ("compressed", "v")}
DEFAULTS = {"pc_mg_cycle_type": "w", "pc_gamg_threshold": 0.01}


def parse_variant(name: str, tight: float) -> tuple[float, dict[str, object]]:
    """Loose tolerance and PETSc options of a variant name (module docstring)."""
    base, *suffixes = name.split("+")
    loose = tight if base == "tight" else float(base.removeprefix("loose"))
    opts: dict[str, object] = {}
    for sfx in suffixes:
        if sfx in LEVEL_SUFFIXES or sfx in MULTIGRID_SUFFIXES:
            continue
        if sfx.startswith("cel") and sfx[3:].isdigit():  # coarse grid size, e.g. cel1000
            opts["pc_gamg_coarse_eq_limit"] = int(sfx[3:])
            continue
        if sfx not in SUFFIXES:
            raise SystemExit(f"unknown variant suffix {sfx!r}; allowed: {', '.join(SUFFIXES)}")
        opts.update(SUFFIXES[sfx])
    return loose, opts


def apply_variant(solver, loose: float, popts: dict[str, object], name: str = "") -> None:
    """Set the variant's options (the solver's own, :func:`set_solver_options`: options
    of an earlier variant are reset to the defaults) and its multigrid
    (:data:`MULTIGRID_SUFFIXES`, GAMG without one) and drop the preconditioner (rebuilt
    at the next solve)."""
    reset = {"mg_levels_ksp_max_it": 2, "pc_gamg_reuse_interpolation": False}
    reset |= {**GAMG_OPTIONS, "mg_coarse_sub_pc_type": "lu"}
    size = {"pc_gamg_coarse_eq_limit": coarse_grid_limit(solver.B.getSize()[0])}  # the solver's
    solver.ksp.getPC().reset()
    set_solver_options(solver.ksp, {**reset, **DEFAULTS, **size, **popts}, PREFIX)
    found = [MULTIGRID_SUFFIXES[s] for s in name.split("+")[1:] if s in MULTIGRID_SUFFIXES]
    kind, cycle = found[-1] if found else ("gamg", "w")
    set_multigrid(solver.ksp, kind, cycle, False, solver.B.getSize()[0])
    solver.pc_reuse.forget()
    solver.loose_rtol = max(loose, solver.rtol)


def level_hook(solver, name: str) -> None:
    """After every preconditioner build of the contact solver: the :data:`LEVEL_SUFFIXES`
    of the variant ``name`` set on the GAMG hierarchy (none: the hook removed)."""
    levels = [s for s in name.split("+")[1:] if s in LEVEL_SUFFIXES]
    reuse = solver.pc_reuse
    if "decide" in vars(reuse):
        del reuse.decide  # the class's method again
    if not levels:
        return
    decide = reuse.decide

    def decide_and_set(ksp, replaced):
        keep = decide(ksp, replaced)
        if not keep:
            opts = solver_options(ksp)
            with opts.applied():
                ksp.setUp()
            pc = ksp.getPC()
            n = pc.getMGLevels()
            if "fv1" in levels:
                pc.setMGCycleTypeOnLevel(n - 1, PETSc.PC.MGCycleType.V)
            if "sm1x1" in levels and n > 2:
                pc.getMGSmoother(n - 2).setTolerances(max_it=1)
        return keep

    reuse.decide = decide_and_set


def one_linear_solve(pb, tight: float) -> dict:
    """Time, flops (summed over the ranks) and CG iterations of one iterative linear solve
    of the same mesh (``bench_contact3d.linear_solve``)."""
    f0, c0 = PETSc.Log.getFlops(), time.process_time()
    t, its, reason = linear_solve(pb, "iterative", tight)
    cpu = COMM.allreduce(time.process_time() - c0, op=MPI.SUM)
    flops = COMM.allreduce(PETSc.Log.getFlops() - f0, op=MPI.SUM)
    if reason < 0:
        raise RuntimeError(f"the reference linear solve diverged (reason {reason})")
    return {"t": COMM.allreduce(t, op=MPI.MAX), "flops": flops, "its": its, "cpu": cpu}


def solve_once(pb, name: str, tight: float, ref: np.ndarray | None) -> tuple[dict, np.ndarray]:
    """One cold contact solve with the variant ``name``: its CSV row and the displacement."""
    solver, integ = pb.integrator.contact, pb.integrator
    loose, popts = parse_variant(name, tight)
    apply_variant(solver, loose, popts, name)
    level_hook(solver, name)
    solver.reset()
    integ.u.x.array[:] = 0.0
    b = integ.rhs(1.0)
    integ.apply_dirichlet(1.0, b)
    builds0 = solver.pc_reuse.builds
    COMM.barrier()
    f0 = PETSc.Log.getFlops()
    t0, c0 = time.perf_counter(), time.process_time()
    res = solver.solve(b, integ.u)
    cpu = COMM.allreduce(time.process_time() - c0, op=MPI.SUM)
    t = COMM.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    flops = COMM.allreduce(PETSc.Log.getFlops() - f0, op=MPI.SUM)
    integ.last_contact = res
    err = hertz_errors(pb, res)
    u = integ.u.x.array[: integ.u.function_space.dofmap.index_map.size_local * 3].copy()
    umax = COMM.allreduce(float(np.abs(u).max(initial=0.0)), op=MPI.MAX)
    diff = 0.0
    if ref is not None:
        diff = COMM.allreduce(float(np.abs(u - ref).max(initial=0.0)), op=MPI.MAX) / umax
    per_it = [h.get("linear_iterations", 0) for h in res.history]
    row = {
        "variant": name,
        "ranks": COMM.size,
        "dofs": pb.model.num_dofs,
        "pdas_iterations": res.iterations,
        "krylov_iterations": res.linear_iterations,
        "per_pdas_iteration": "/".join(map(str, per_it)),
        "pc_builds": solver.pc_reuse.builds - builds0,
        "gflops": round(flops / 1e9, 2),
        "t_contact_s": round(t, 2),
        "cpu_contact_s": round(cpu, 2),
        "active": err["active"],
        "err_a": float(f"{err['a']:.4e}"),
        "err_p0": float(f"{err['p0']:.4e}"),
        "equilibrium": float(f"{err['equilibrium']:.1e}"),
        "u_diff": float(f"{diff:.1e}"),
    }
    b.destroy()
    return row, u


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="65k", help="labels of bench_contact3d.SIZES")
    p.add_argument("--variants", default="tight,loose1e-4")
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--rtol", type=float, default=1e-12, help="tight Krylov tolerance")
    p.add_argument(
        "--mesh-dir", default=os.path.join(tempfile.gettempdir(), "bonecontact-bench-meshes")
    )
    p.add_argument("--out", default=str(OUT))
    p.add_argument("--load", default="", help="machine load during the run (recorded)")
    p.add_argument("--quick", action="store_true", help="25k dofs, one round (a smoke run)")
    args = p.parse_args()
    if args.quick:
        args.sizes, args.rounds = "25k", 1
    variants = args.variants.split(",")
    for label in args.sizes.split(","):
        h, h_far, mesher = SIZES[label]
        pb = sphere_on_block_3d(
            COMM, h, h_far=h_far, linear="iterative", rtol=args.rtol,
            mesh_file=Path(args.mesh_dir) / f"contact3d_{label}_{mesher}.msh",
            algorithm_3d=mesher,
        )  # fmt: skip
        ref = None
        for rnd in range(args.rounds):
            lin = one_linear_solve(pb, args.rtol)
            for name in variants:
                row, u = solve_once(pb, name, args.rtol, ref)
                if ref is None:
                    ref = u
                row |= {
                    "t_linear_s": round(lin["t"], 2),
                    "linear_its": lin["its"],
                    "ratio_time": round(row["t_contact_s"] / lin["t"], 2),
                    "ratio_flops": round(row["gflops"] * 1e9 / max(lin["flops"], 1.0), 2),
                    "cpu_linear_s": round(lin["cpu"], 2),
                    "ratio_cpu": round(row["cpu_contact_s"] / lin["cpu"], 2),
                }
                row = {"size": label, "round": rnd + 1, **row, "load": args.load}
                row["machine"] = machine()
                if COMM.rank == 0:
                    print("krylov3d", row, flush=True)
                write_rows(Path(args.out), "krylov3d", [row])
        pb.destroy()


if __name__ == "__main__":
    main()
