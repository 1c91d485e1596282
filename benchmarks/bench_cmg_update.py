"""Updated against rebuilt compressed hierarchies in the 3D contact solve, one process (#28).

The load-driven 3D Hertz problem of ``bench_contact3d.py`` (compressed multigrid, scene
tolerance 1e-6: final Krylov rtol 1e-8, the reference's) is built once; then the contact
solve is repeated from a cold start (hierarchy freed, warm start reset) with each
variant, alternating over ``--rounds`` rounds so that all see the same machine load:

* ``before``: every hierarchy built anew for a new set (``local_update = False``) and
  the coarsest level factorised by LU — the code before 2026-12-02 10:00 UTC;
* ``update``: new sets update the kept hierarchy (``local_update``), LU;
* ``previous``: update, Cholesky — the defaults before 2026-12-02 13:30 UTC;
* ``unscaled``: ``after`` with the warm start as it is, coarse factor by MUMPS;
* ``petsc_coarse``: ``after`` with PETSc's own coarse factorisation;
* ``mumps_coarse``: ``after`` with the coarse factorisation by MUMPS;
* ``after``: the defaults: update, Cholesky coarse factor (``coarse_solver = "mumps"``:
  MUMPS; before 2026-12-02 14:25 UTC PETSc's own on one rank), the smoothers' intervals kept by
  updates (``reuse_bounds``),
  the rescaled warm start (``KrylovStrategy.scale_guess``).

(``before``/``update``/``previous`` as the code was: PETSc's own coarse factorisation,
the intervals estimated at every set-up, the warm start as it is.)

Per solve: PDAS and CG iterations (per PDAS iteration), builds and of them updates,
PETSc operations (summed over the ranks; independent of the load), wall time, CPU time
(summed over the ranks), the hierarchy's set-up time (its own timer, max over the
ranks), the largest displacement difference from the round's first variant (relative
to the largest displacement), the active nodes and the Hertz errors.  Once per round,
one plain DOLFINx ``LinearProblem`` solve of the same mesh (``bench_reference.py``'s
``gamg_default``, a fresh process of the same ranks) gives the ratios.

Usage (also under ``mpiexec -n 2``)::

    python benchmarks/bench_cmg_update.py --size 65k --rounds 2

Appends rows to ``results/cmg_update.csv``.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import argparse
import dataclasses
import os
import tempfile
import time
from pathlib import Path

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
from bench_contact3d import SIZES
from bench_reference import run_reference
from common import machine, write_rows

from bonecontact.contact.krylov import krylov_rtol
from bonecontact.contact.options import LinearOptions, PDASOptions
from bonecontact.verification.load_driven import hertz_errors, sphere_on_block_3d

COMM = MPI.COMM_WORLD
OUT = Path(__file__).parent / "results"
#: The defaults before 2026-12-02 13:30 UTC: PETSc's own coarse factorisation, every
#: set-up estimating the smoothers' intervals, the warm start as it is.
OLD = {"coarse_solver": "petsc", "reuse_bounds": False, "scale_guess": False}
VARIANTS = {
    "before": {"local_update": False, "coarse_factor": "lu", **OLD},
    "update": {"local_update": True, "coarse_factor": "lu", **OLD},
    "previous": {"local_update": True, "coarse_factor": "cholesky", **OLD},
    "unscaled": {
        "local_update": True,
        "coarse_factor": "cholesky",
        "coarse_solver": "mumps",
        "reuse_bounds": True,
        "scale_guess": False,
    },
    "petsc_coarse": {
        "local_update": True,
        "coarse_factor": "cholesky",
        "coarse_solver": "petsc",
        "reuse_bounds": True,
    },
    "mumps_coarse": {
        "local_update": True,
        "coarse_factor": "cholesky",
        "coarse_solver": "mumps",
        "reuse_bounds": True,
    },
    "after": {
        "local_update": True,
        "coarse_factor": "cholesky",
        "coarse_solver": "mumps",
        "reuse_bounds": True,
    },
}


def solve_once(pb, name: str, ref: np.ndarray | None) -> tuple[dict, np.ndarray]:
    """One cold contact solve with the variant ``name``: its row and the displacement."""
    solver, integ = pb.integrator.contact, pb.integrator
    pc = solver.ksp.getPC()
    ctx = pc.getPythonContext()
    ctx.destroy(pc)  # (a cold start: no hierarchy, no aggregation kept)
    fields = dict(VARIANTS[name])
    solver.linear_solver.scale_guess = fields.pop("scale_guess", True)
    ctx.options = dataclasses.replace(ctx.options, **fields)
    solver.pc_reuse.forget()
    solver.reset()
    integ.u.x.array[:] = 0.0
    b = integ.rhs(1.0)
    integ.apply_dirichlet(1.0, b)
    builds0, updates0, setup0 = ctx.builds, ctx.updates, ctx.setup_seconds
    load0 = os.getloadavg()[0]
    COMM.barrier()
    f0, t0, c0 = PETSc.Log.getFlops(), time.perf_counter(), time.process_time()
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
    row = {
        "variant": name,
        "ranks": COMM.size,
        "dofs": pb.model.num_dofs,
        "pdas_iterations": res.iterations,
        "cg_iterations": res.linear_iterations,
        "per_pdas_iteration": "/".join(str(h.get("linear_iterations", 0)) for h in res.history),
        "builds": ctx.builds - builds0,
        "updates": ctx.updates - updates0,
        "gflops": round(flops / 1e9, 3),
        "t_contact_s": round(t, 3),
        "cpu_contact_s": round(cpu, 3),
        "t_setup_s": round(COMM.allreduce(ctx.setup_seconds - setup0, op=MPI.MAX), 3),
        "u_diff_rel": float(f"{diff:.2e}"),
        "active": err["active"],
        "err_a": float(f"{err['a']:.6e}"),
        "err_p0": float(f"{err['p0']:.6e}"),
        "load": f"{load0:.1f}-{os.getloadavg()[0]:.1f}",
    }
    return row, u


def reference(label: str, mesh_dir: Path) -> dict:
    """One plain linear solve of the mesh (``bench_reference.py``, ``gamg_default``) in a
    fresh serial process (serial runs only: an ``mpiexec`` inside ``mpiexec`` fails; on
    several ranks run ``bench_reference.py`` right after)."""
    if COMM.size > 1:
        return {}
    return run_reference(label, 1, "gamg_default", mesh_dir)


def ratios(row: dict, plain: dict) -> dict:
    """The plain solve's figures and the contact solve's ratios to them (none without)."""
    out = {
        "plain_s": plain.get("t_assemble_solve_s"),
        "plain_cpu_s": plain.get("cpu_assemble_solve_s"),
        "plain_gflops": plain.get("gflops"),
        "plain_its": plain.get("iterations"),
    }
    for key, mine, theirs in (
        ("ratio_wall", "t_contact_s", "plain_s"),
        ("ratio_cpu", "cpu_contact_s", "plain_cpu_s"),
        ("ratio_flops", "gflops", "plain_gflops"),
    ):
        out[key] = round(row[mine] / out[theirs], 2) if out[theirs] else None
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", default="65k", help="label of bench_contact3d.SIZES")
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--variants", default="before,after")
    p.add_argument(
        "--mesh-dir", default=os.path.join(tempfile.gettempdir(), "bonecontact-bench-meshes")
    )
    p.add_argument("--out", default=str(OUT))
    args = p.parse_args()
    h, h_far, mesher = SIZES[args.size]
    mesh_dir = Path(args.mesh_dir)
    options = PDASOptions(linear=LinearOptions(multigrid="compressed"))
    pb = sphere_on_block_3d(
        COMM, h, h_far=h_far, linear="iterative", rtol=krylov_rtol(1e-6), options=options,
        mesh_file=mesh_dir / f"contact3d_{args.size}_{mesher}.msh", algorithm_3d=mesher,
    )  # fmt: skip
    rows = []
    for k in range(args.rounds):
        ref_u = None
        for name in args.variants.split(","):
            row, u = solve_once(pb, name, ref_u)
            ref_u = u if ref_u is None else ref_u
            rows.append({"size": args.size, "round": k, **row})
            if COMM.rank == 0:
                print("cmg_update", rows[-1], flush=True)
        plain = reference(args.size, mesh_dir)
        for row in rows[-len(args.variants.split(",")) :]:
            row |= ratios(row, plain)
        if COMM.rank == 0:
            print("reference", plain, flush=True)
    for row in rows:
        row |= {"machine": machine(), "time_utc": time.strftime("%H:%M", time.gmtime())}
    pb.destroy()
    write_rows(Path(args.out), "cmg_update", rows)


if __name__ == "__main__":
    main()
