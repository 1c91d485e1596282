"""The compressed-aggregation multigrid against GAMG on the 3D contact solve (issue 28).

The load-driven 3D Hertz problem of ``bench_contact3d.py`` is built and solved once per
process with one multigrid (``--variant``: ``gamg`` — PETSc's GAMG, W-cycles, the
default; ``cmg`` — :mod:`bonecontact.contact.compressed_mg`, W-cycles; ``cmgv`` — the
same, V-cycles; ``cmg-built`` — W-cycles with every hierarchy built anew, no
``local_update``, the code before; each with the default preconditioner reuse, GAMG's
kept across small set changes, the compressed one rebuilt (or updated) for every new
set; ``-reuse``: kept as GAMG's, ``pc_reuse_rows = 0.25``), at the scene tolerance 1e-6
(final Krylov rtol 1e-8, loose 1e-4).  Per run: PDAS and CG iterations, preconditioner
builds (and of them updates), PETSc operations of the contact solve (summed over the
ranks), its wall time (busy machine: the load is recorded) and CPU time (summed over the
ranks), of which the preconditioner set-ups' (GAMG: PETSc's ``PCSetUp`` event, which
counts the coarse factorisation twice; compressed: the hierarchy's own timer) and the
rest (Krylov iterations, PDAS, products) — max over the ranks —, the peak resident
memory of the process (max over the ranks: one variant per process, so the peaks
compare), the first level's aggregates by their columns and the hierarchy's rows and
nonzeros (compressed), the Hertz errors and the equilibrium defect.

Usage (one process per variant; also under ``mpiexec -n 2``)::

    python benchmarks/bench_compressed_mg.py --size 65k --variant cmg

Appends a row to ``results/compressed_mg_update.csv`` (``compressed_mg_setup.csv``: the
rows before the CPU time and update columns; ``compressed_mg.csv``: before the set-up
time columns).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import argparse
import functools
import os
import resource
import tempfile
import time
from pathlib import Path

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
from bench_contact3d import SIZES
from common import machine, write_rows

from bonecontact.contact import krylov
from bonecontact.contact.compressed_mg import CompressedMGOptions
from bonecontact.contact.krylov import krylov_rtol
from bonecontact.contact.options import LinearOptions, PDASOptions
from bonecontact.verification.load_driven import hertz_errors, sphere_on_block_3d

COMM = MPI.COMM_WORLD
OUT = Path(__file__).parent / "results"
VARIANTS = {
    "gamg": ("gamg", "w", None),
    "cmg": ("compressed", "w", None),
    "cmg-built": ("compressed", "w", None),
    "cmgv": ("compressed", "v", None),
    "cmg-reuse": ("compressed", "w", 0.25),
    "cmgv-reuse": ("compressed", "v", 0.25),
}
#: Variants whose hierarchy is built anew for every set (no ``local_update``: the code
#: before the updated hierarchies).
BUILT = ("cmg-built",)


def hierarchy(solver) -> dict:
    """Rows, nonzeros and first-level columns of the compressed hierarchy (empty for GAMG)."""
    pc = solver.ksp.getPC()
    ctx = pc.getPythonContext() if pc.getType() == "python" else None
    if ctx is None:
        return {"level_rows": "", "level_nnz": "", "columns_histogram": ""}
    hist = np.bincount(ctx.ranks, minlength=13)
    hist = COMM.allreduce(hist, op=MPI.SUM)
    return {
        "level_rows": "/".join(map(str, ctx.sizes)),
        "level_nnz": "/".join(map(str, ctx.nonzeros)),
        "columns_histogram": " ".join(f"{k}:{int(n)}" for k, n in enumerate(hist) if n),
    }


def run(label: str, variant: str, mesh_dir: Path) -> dict:
    """One contact solve with the variant (module docstring): its row."""
    h, h_far, mesher = SIZES[label]
    kind, cycle, reuse = VARIANTS[variant]
    lin = LinearOptions(multigrid=kind, multigrid_cycle=cycle, pc_reuse_rows=reuse)
    options = PDASOptions(linear=lin)
    made = CompressedMGOptions  # (the package default; also for code before local_update)
    if variant in BUILT:
        made = functools.partial(CompressedMGOptions, local_update=False)
    saved, krylov.CompressedMGOptions = krylov.CompressedMGOptions, made
    try:
        pb = sphere_on_block_3d(
            COMM, h, h_far=h_far, linear="iterative", rtol=krylov_rtol(1e-6), options=options,
            mesh_file=mesh_dir / f"contact3d_{label}_{mesher}.msh", algorithm_3d=mesher,
        )  # fmt: skip
    finally:
        krylov.CompressedMGOptions = saved
    load0 = os.getloadavg()[0]
    events = {name: PETSc.Log.Event(name) for name in ("PCSetUp",)}
    before = {name: ev.getPerfInfo() for name, ev in events.items()}
    COMM.barrier()
    f0, t0, c0 = PETSc.Log.getFlops(), time.perf_counter(), time.process_time()
    res = pb.solve()
    t = COMM.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    cpu = COMM.allreduce(time.process_time() - c0, op=MPI.SUM)
    spent = {
        name: COMM.allreduce(ev.getPerfInfo()["time"] - before[name]["time"], op=MPI.MAX)
        for name, ev in events.items()
    }
    ctx = pb.integrator.contact.ksp.getPC()
    updates = ""
    if ctx.getType() == "python":  # (its own timer: PCSetUp also counts its inner PCMG's)
        spent["PCSetUp"] = COMM.allreduce(ctx.getPythonContext().setup_seconds, op=MPI.MAX)
        updates = getattr(ctx.getPythonContext(), "updates", "")
    flops = COMM.allreduce(PETSc.Log.getFlops() - f0, op=MPI.SUM)
    err = hertz_errors(pb, res)
    solver = pb.integrator.contact
    peak = COMM.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, op=MPI.MAX)
    row = {
        "size": label,
        "variant": variant,
        "ranks": COMM.size,
        "dofs": pb.model.num_dofs,
        "pdas_iterations": res.iterations,
        "cg_iterations": res.linear_iterations,
        "per_pdas_iteration": "/".join(str(x.get("linear_iterations", 0)) for x in res.history),
        "pc_builds": solver.pc_reuse.builds,
        "pc_updates": updates,
        "gflops": round(flops / 1e9, 2),
        "t_contact_s": round(t, 2),
        "cpu_contact_s": round(cpu, 2),
        "t_pc_setup_s": round(spent["PCSetUp"], 2),
        "t_other_s": round(t - spent["PCSetUp"], 2),
        "peak_mib_max_rank": round(peak, 1),
        "active": err["active"],
        "err_a": float(f"{err['a']:.4e}"),
        "err_p0": float(f"{err['p0']:.4e}"),
        "equilibrium": float(f"{err['equilibrium']:.1e}"),
        **hierarchy(solver),
        "load": f"{load0:.1f}-{os.getloadavg()[0]:.1f}",
        "machine": machine(),
        "time_utc": time.strftime("%H:%M", time.gmtime()),
    }
    pb.destroy()
    return row


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", default="25k", help="label of bench_contact3d.SIZES")
    p.add_argument("--variant", default="cmg", choices=sorted(VARIANTS))
    p.add_argument(
        "--mesh-dir", default=os.path.join(tempfile.gettempdir(), "bonecontact-bench-meshes")
    )
    p.add_argument("--out", default=str(OUT))
    args = p.parse_args()
    PETSc.Log.begin()  # (the set-up and Krylov times by event)
    row = run(args.size, args.variant, Path(args.mesh_dir))
    if COMM.rank == 0:
        print("compressed_mg", row, flush=True)
    write_rows(Path(args.out), "compressed_mg_update", [row])


if __name__ == "__main__":
    main()
