"""3D load-driven contact at scale: phases, iterations, memory and the cost of a linear solve.

The load-driven Hertz problem of :func:`bonecontact.verification.sphere_on_block_3d`
(hemisphere R = 10 mm, E = 2 GPa, ν = 0.3, on a block 1000× stiffer, its flat face
loaded by a uniform traction with a/R = 0.1, held in the load direction only by the
contact) on a family of meshes refined near the contact, from ≈ 25k to ≈ 1M dofs, with
the direct (MUMPS, low-rank PDAS) and the iterative (CG/GMRES + GAMG) linear solver.
For every case (one row of ``results/contact3d.csv``):

* errors of the fitted a and p₀ against Hertz (from the contact resultant), and the
  equilibrium defect |P_contact − P_applied| / P_applied;
* PDAS iterations, Krylov iterations (sum over the PDAS iterations), active nodes;
* wall time of each phase: mesh generation (gmsh, written to a ``.msh`` file once and
  cached in ``--mesh-dir``), mesh read (+ distribution), assembly (model, operator,
  Dirichlet elimination, load), mortar geometry (``build_interface``), solver set-up,
  contact solve, output (fields and the contact table through the run layer's
  ``ResultsWriter``, in a temporary directory);
* one linear solve of the same mesh and solver without contact: the operator with the
  contact replaced by a fixed support (u_y = 0 at the slave nodes within the Hertz
  radius), a fresh KSP (factorisation or GAMG set-up) and one solve; its Krylov
  iterations; ratio = contact solve / linear solve;
* memory per rank, max over ranks: the peak resident set of the case
  (``ru_maxrss``; the high-water mark is reset before every phase through
  ``/proc/self/clear_refs`` so that cases do not see each other's peaks), and the growth
  of the high-water mark over the resident set during the contact solve and during the
  linear solve.

A case whose PDAS fails (``ContactConvergenceError``, or ``SingularActiveSetError`` from
the first factorisation of the low-rank start) is written with status ``failed`` and the
first line of the error message; the study goes on.

Usage (also under ``mpiexec -n K``)::

    python benchmarks/bench_contact3d.py [--quick | --full] [--sizes 25k,65k] [--linear direct]
        [--rtol 1e-12] [--max-iterations 50] [--mesh-dir DIR] [--out DIR]

Default sizes: 25k and 65k; ``--quick``: 25k only; ``--full``: 25k … 1M (``--sizes
smoke`` is a 9k-dof check of the script).  Appends rows
to ``results/contact3d.csv``; ``python benchmarks/summarize.py contact3d`` writes the
table ``results/contact3d.md``.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import argparse
import gc
import os
import resource
import shutil
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
from common import machine, write_rows  # (benchmarks/ is the script directory)

from bonecontact.common.linalg import create_solver, owned_global_rows, rigid_body_modes
from bonecontact.contact.lowrank import SingularActiveSetError
from bonecontact.contact.options import PDASOptions
from bonecontact.contact.pdas import ContactConvergenceError
from bonecontact.runners.results import ResultsWriter, StressFields
from bonecontact.verification.load_driven import (
    LoadDrivenHertz,
    hertz_errors,
    sphere_on_block_3d,
)

COMM = MPI.COMM_WORLD
OUT = Path(__file__).parent / "results"

#: Mesh family: label → (h_contact, h_far, volume mesher) in m (zone 1.5 mm, the size
#: reaching h_far at zone + 4 h_far): a graded mesh refined everywhere, as an anatomical
#: mesh grows.  25k and 65k (gmsh's Delaunay: 25 818 and 64 398 dofs, 5 s and 10 s) are
#: the meshes of the earlier figures; from 200k on gmsh's parallel HXT mesher (198 645,
#: 502 317 and 1 003 509 dofs in 3, 7 and 16 s; Delaunay took 2 min at 200k and 14 min
#: at 490k, of the same element quality: minimum gamma 0.23 in both).
SIZES = {
    "25k": (1.4e-4, 3.0e-3, "delaunay"),
    "65k": (0.9e-4, 2.0e-3, "delaunay"),
    "200k": (5.3e-5, 1.23e-3, "hxt"),
    "500k": (3.75e-5, 0.87e-3, "hxt"),
    "1M": (2.92e-5, 0.68e-3, "hxt"),
    "smoke": (4.0e-4, 3.0e-3, "delaunay"),  # 9k dofs: a check of the script itself
}
DEFAULT, QUICK = ["25k", "65k"], ["25k"]


# ----------------------------------------------------------------------------- memory
def _rss_mb() -> float:
    """Current resident set of this process (MiB)."""
    try:
        for line in open("/proc/self/status"):
            if line.startswith("VmRSS:"):
                return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def _peak_mb() -> float:
    """High-water mark of the resident set since the last reset (MiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


class MemoryTracker:
    """Peak memory per phase of a case on this rank (Linux).

    ``mark()`` records the high-water mark since the previous mark and resets it (by
    writing 5 to ``/proc/self/clear_refs``, which resets ``ru_maxrss`` too);
    ``peak`` is the largest of them, the case's peak.
    """

    def __init__(self) -> None:
        self.peak = 0.0
        self.mark()
        self.peak = _rss_mb()

    def mark(self) -> float:
        """Take the high-water mark since the last mark, reset it; returns it (MiB)."""
        gc.collect()
        hwm = _peak_mb()
        self.peak = max(self.peak, hwm)
        try:
            with open("/proc/self/clear_refs", "w") as f:
                f.write("5")
        except OSError:
            pass
        return hwm


def _max(x: float) -> float:
    return float(COMM.allreduce(x, op=MPI.MAX))


# ----------------------------------------------------------------------------- phases
def write_output(pb: LoadDrivenHertz, directory: Path) -> None:
    """What a run writes at the end of a step: displacement, stresses, contact table."""
    integ, itf, res = pb.integrator, pb.interface, pb.integrator.last_contact
    stress = StressFields(pb.model.mesh, pb.model.stress_expression(integ.u, integ.velocity))
    stress.update()
    writer = ResultsWriter(COMM, directory, "contact3d")
    writer.fields(1.0, [integ.u, stress.stress, stress.von_mises, stress.principal])
    writer.contact_table(
        itf.name,
        itf.coords,
        res.gap[0],
        res.pressure[0],
        res.traction_t[0],
        res.slip[0],
        list(res.status[0]),
    )
    writer.close()


def linear_solve(pb: LoadDrivenHertz, linear: str, rtol: float) -> tuple[float, int, int]:
    """One linear solve of the same operator without contact: the hemisphere supported
    (u_y = 0) at the slave nodes within the Hertz radius, a fresh KSP, one solve.

    Returns the wall time (KSP creation, factorisation / preconditioner set-up and
    solve), the Krylov iterations and the KSP's converged reason."""
    integ, itf, V = pb.integrator, pb.interface, pb.model.V
    r = np.hypot(itf.coords[:, 0], itf.coords[:, 2])
    local = (3 * itf.blocks[r < pb.a_target] + 1).astype(np.int32)
    B = integ.A_bc.duplicate(copy=True)
    B.zeroRowsColumns(owned_global_rows(V, local), diag=1.0)
    b = integ.rhs(1.0).copy()
    integ.apply_dirichlet(1.0, b)
    b.array[local] = 0.0
    x = b.duplicate()
    nns = rigid_body_modes(V) if linear == "iterative" else None
    COMM.barrier()
    t0 = time.perf_counter()
    ksp = create_solver(B, linear, nns, rtol=rtol, prefix="bench_lin_")
    ksp.solve(b, x)
    COMM.barrier()
    t = time.perf_counter() - t0
    its, reason = ksp.getIterationNumber(), ksp.getConvergedReason()
    for o in (ksp, B, b, x):
        o.destroy()
    return t, its, reason


def run_case(
    label: str, linear: str, mesh_dir: Path, rtol: float, options: PDASOptions | None = None
) -> dict:
    """One size and linear solver: build, solve, write, one linear solve (a CSV row)."""
    h, h_far, mesher = SIZES[label]
    mem = MemoryTracker()
    COMM.barrier()
    t_start = time.perf_counter()
    pb = sphere_on_block_3d(
        COMM,
        h,
        h_far=h_far,
        linear=linear,
        rtol=rtol,
        options=options,
        mesh_file=mesh_dir / f"contact3d_{label}_{mesher}.msh",
        algorithm_3d=mesher,
    )
    mem.mark()
    rss0 = _rss_mb()
    status, message, res, failed_its = "converged", "", None, ""
    try:
        res = pb.solve()
    except (ContactConvergenceError, SingularActiveSetError) as exc:  # (collective)
        # timings["contact_solve"] is the time to the failure; a singular first
        # factorisation (low-rank start) raises SingularActiveSetError, before any history
        status, message = "failed", str(exc).splitlines()[0]
        failed_its = len(getattr(exc, "history", []))
    mem_contact = mem.mark() - rss0
    t_output = float("nan")
    if res is not None:
        tmp = Path(COMM.bcast(tempfile.mkdtemp(prefix="bench3d-") if COMM.rank == 0 else None))
        COMM.barrier()
        t0 = time.perf_counter()
        write_output(pb, tmp)
        COMM.barrier()
        t_output = time.perf_counter() - t0
        if COMM.rank == 0:
            shutil.rmtree(tmp, ignore_errors=True)
    t_total = time.perf_counter() - t_start
    mem.mark()
    rss1 = _rss_mb()
    t_linear, lin_its, lin_reason = linear_solve(pb, linear, rtol)
    mem_linear = mem.mark() - rss1
    err = hertz_errors(pb) if res is not None else {}
    tm = pb.timings
    t_contact = tm.get("contact_solve", float("nan"))
    row = {
        "size": label,
        "dofs": pb.model.num_dofs,
        "ranks": COMM.size,
        "linear": linear,
        "status": status,
        "h_contact_mm": round(h * 1e3, 4),
        "a_over_h": round(pb.a_target / h, 1),
        "pdas_iterations": res.iterations if res is not None else failed_its,
        "krylov_iterations": res.linear_iterations if res is not None else "",
        "active": err.get("active", ""),
        "err_a": float(f"{err['a']:.2e}") if err else "",
        "err_p0": float(f"{err['p0']:.2e}") if err else "",
        "equilibrium": float(f"{err['equilibrium']:.1e}") if err else "",
        "t_mesh_generate_s": round(tm["mesh_generate"], 2) if "mesh_generate" in tm else "",
        "t_mesh_read_s": round(tm["mesh"], 2),
        "t_assembly_s": round(tm["assembly"], 2),
        "t_mortar_s": round(tm["mortar"], 2),
        "t_setup_s": round(tm["setup"], 2),
        "t_contact_s": round(t_contact, 2),
        "t_output_s": round(t_output, 2),
        "t_total_s": round(t_total, 1),
        "t_linear_s": round(t_linear, 2),
        "linear_its": lin_its if linear == "iterative" else 1,
        "linear_reason": lin_reason,
        "ratio": round(t_contact / t_linear, 1) if res is not None else "",
        "peak_mem_mb": round(_max(mem.peak)),
        "mem_contact_solve_mb": round(_max(mem_contact)),
        "mem_linear_solve_mb": round(_max(mem_linear)),
        "message": message,
        "machine": machine(),
    }
    pb.destroy()
    return row


def warm_up(mesh_dir: Path) -> None:
    """A small case, not recorded: JIT-compiles the forms and the stress expression."""
    pb = sphere_on_block_3d(
        COMM, 6e-4, h_far=5e-3, linear="direct", mesh_file=mesh_dir / "contact3d_warmup.msh"
    )
    pb.solve()
    tmp = Path(COMM.bcast(tempfile.mkdtemp(prefix="bench3d-") if COMM.rank == 0 else None))
    write_output(pb, tmp)
    COMM.barrier()
    if COMM.rank == 0:
        shutil.rmtree(tmp, ignore_errors=True)
    pb.destroy()


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quick", action="store_true", help="the smallest size only")
    g.add_argument("--full", action="store_true", help="every size up to 1M dofs")
    p.add_argument("--sizes", help="comma-separated labels, e.g. 25k,65k (overrides)")
    p.add_argument("--linear", default="iterative,direct", help="iterative,direct")
    p.add_argument("--rtol", type=float, default=1e-12, help="Krylov tolerance (as a run)")
    p.add_argument("--max-iterations", type=int, default=50, help="PDAS iteration limit")
    p.add_argument(
        "--mesh-dir",
        default=os.path.join(tempfile.gettempdir(), "bonecontact-bench-meshes"),
        help="cache of the generated .msh files",
    )
    p.add_argument("--out", default=str(OUT), help="directory of contact3d.csv")
    args = p.parse_args()
    sizes = (
        args.sizes.split(",")
        if args.sizes
        else QUICK
        if args.quick
        else [k for k in SIZES if k != "smoke"]
        if args.full
        else DEFAULT
    )
    options = PDASOptions(max_iterations=args.max_iterations)
    mesh_dir = Path(args.mesh_dir)
    if COMM.rank == 0:
        mesh_dir.mkdir(parents=True, exist_ok=True)
    out = Path(args.out)
    if COMM.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
    warm_up(mesh_dir)
    for label in sizes:
        for linear in args.linear.split(","):
            row = run_case(label, linear, mesh_dir, args.rtol, options)
            if COMM.rank == 0:
                print("contact3d", row, flush=True)
            write_rows(out, "contact3d", [row])


if __name__ == "__main__":
    main()
