"""Cost of a dynamic step in contact against a contact-free step of the same mesh
(issue #24: "a step in contact ≤ 1.3× a contact-free step").

The hemisphere impact of :mod:`bonecontact.verification.sphere_impact`
(``scheme = "stabilized-newmark"``, frictionless dual mortar, Δt = t_c/50) is run twice
on one mesh: with the contact pair (the 40 steps from 0.1 t_c to 0.9 t_c are timed: the
contact zone grows, then shrinks) and without it (10 steps timed before the contact run
and 10 after, their mean: the load of a shared machine drifts)
(the same integrator, a plain linear solve per step; the hemisphere passes through the
block, which does not change the cost of a step).  Both use the direct solver (MUMPS),
one factorisation for all steps (the dynamic operator is constant for fixed Δt).

Where the time of a step in contact goes is measured by wrapping the methods of the
integrator and the contact solver of this run (no change to the package): ``rhs`` (loads,
predictor and its gaps), ``dirichlet``, ``contact`` (the PDAS: ``pdas_rhs``,
``pdas_begin`` = the base solve of the low-rank strategy, ``pdas_iterations`` = set
updates and small dense systems, ``new_columns`` = new low-rank columns (MUMPS
multi-right-hand-side solves), ``refactor``, ``pdas_finish`` = the final solve and
the result), ``velocity``; the contact-free step's ``solve``.

Columns: case, h_contact, dofs, ranks, steps_free, steps_contact, free_step_s (the
mean of the runs before and after), free_before_s, free_after_s, contact_step_s, ratio;
free_step_cpu_s, contact_step_cpu_s, ratio_cpu (the same from the process's CPU time:
MUMPS runs on one thread, so these are far less sensitive to the load of a shared
machine than the wall times); free_solve_s, the phase means (s per step in contact),
n_pdas_iterations (mean per contact step), n_n_active (at the end), n_factorizations,
n_columns (in the timed steps), n_solves_per_step (base and final MUMPS solves, single
right-hand side; n_final_per_step: the final ones) and n_blocks_per_step (multi-right-hand-side
column blocks): counts that do
not depend on the load; n_full_cap, n_full_used, n_full_peak_mib (the full columns kept:
their cap, the most a set used, their peak memory), machine, date.

Usage:  python benchmarks/bench_dynamic_cost.py [--sizes 5e-4,3e-4] [--steps 40]
        [--out benchmarks/results/dynamic_cost.csv]
"""

import dolfinx_solver  # noqa: F401

import argparse
import resource
import time
from collections import defaultdict
from pathlib import Path

from mpi4py import MPI

import numpy as np
from common import machine, write_rows
from dolfinx import fem

from bonecontact.contact.options import LinearOptions, PDASOptions
from bonecontact.contact.pdas import ContactSolver
from bonecontact.mechanics.newmark import make_integrator
from bonecontact.verification.sphere_impact import SphereImpact, sphere_model

COMM = MPI.COMM_WORLD


class Phases:
    """Wall and CPU time of wrapped methods, per name (s, accumulated; CPU as
    ``<name>_cpu``)."""

    def __init__(self):
        self.t = defaultdict(float)

    def wrap(self, obj, method: str, name: str) -> None:
        """Time ``obj.method`` under ``name`` (an instance attribute shadows the method)."""
        f = getattr(obj, method)

        def timed(*a, **k):
            t0, c0 = time.perf_counter(), time.process_time()
            try:
                return f(*a, **k)
            finally:
                self.t[name] += time.perf_counter() - t0
                self.t[f"{name}_cpu"] += time.process_time() - c0

        setattr(obj, method, timed)

    def snapshot(self) -> dict:
        return dict(self.t)


def _instrument(integ, ph: Phases) -> None:
    ph.wrap(integ, "rhs", "rhs")
    ph.wrap(integ, "apply_dirichlet", "dirichlet")
    ph.wrap(integ, "_new_velocity", "velocity")
    if integ.contact is None:
        ph.wrap(integ, "solve_linear", "solve")
        return
    cs = integ.contact
    ph.wrap(cs, "solve", "contact")
    ph.wrap(cs, "contact_gaps", "predictor_gaps")
    ph.wrap(cs, "_assemble_rhs", "pdas_rhs")
    ph.wrap(cs, "_predict", "pdas_begin")
    ph.wrap(cs, "_finish", "pdas_finish")
    lr = getattr(cs.linear_solver, "lowrank", None)
    if lr is not None:
        ph.wrap(lr, "_compute_columns", "new_columns")
        ph.wrap(lr, "factorize", "refactor")
        ph.wrap(lr, "finish", "final_solve")


def run(p: SphereImpact, contact: bool, steps: int, t_start: float, memory_ratio: float) -> dict:
    """Time ``steps`` steps after ``t_start`` (s after the first touch; the steps before
    are run untimed), with or without the contact pair; the phase means per step."""
    m, itf, sphere = sphere_model(p, COMM)
    dt = p.contact_time / 50
    opts = PDASOptions(linear=LinearOptions(memory_ratio=memory_ratio))
    cs = ContactSolver(m.V, [itf], opts) if contact else None
    integ = make_integrator("stabilized-newmark", m, "dynamic", dt, contact=cs)
    v0 = fem.Function(m.V)
    v0.x.array[:] = -p.v0 * sphere.x.array
    integ.set_initial(None, v0)
    ph = Phases()
    # the steps before t_start (approach and first contact): not timed
    while integ.t < t_start - 0.5 * dt:
        integ.step()
    _instrument(integ, ph)
    times, cpu, its, cols0 = [], [], [], None
    lr = getattr(getattr(cs, "linear_solver", None), "lowrank", None)
    counters = ("factorizations", "columns", "prefetched", "n_solves", "n_final", "n_blocks")
    f0 = {c: getattr(lr, c) for c in counters} if lr is not None else {}
    for _ in range(steps):
        COMM.barrier()
        t0, c0 = time.perf_counter(), time.process_time()
        integ.step()
        cpu.append(COMM.allreduce(time.process_time() - c0, op=MPI.MAX))
        times.append(COMM.allreduce(time.perf_counter() - t0, op=MPI.MAX))
        if contact:
            its.append(integ.last_contact.iterations)
            cols0 = integ.last_contact.n_active[0]
    out = {k: COMM.allreduce(v, op=MPI.MAX) / steps for k, v in ph.snapshot().items()}
    out["step"] = float(np.mean(times))
    out["step_median"] = float(np.median(times))
    out["step_cpu"] = float(np.mean(cpu))
    out["dofs"] = int(3 * m.V.dofmap.index_map.size_global)
    if contact:
        out["pdas_iterations"] = float(np.mean(its))
        out["n_active"] = cols0
        for c in counters:  # (n_solves, n_blocks: per step below)
            out[c] = getattr(lr, c) - f0[c] if lr is not None else -1
        out["solves_per_step"] = out["n_solves"] / steps
        out["blocks_per_step"] = out["n_blocks"] / steps
        out["final_per_step"] = out["n_final"] / steps
        out["full_limit"] = lr.full_limit if lr is not None else -1
        out["full_cap"] = lr.full_cap if lr is not None else -1
        out["full_used"] = lr.full_used if lr is not None else -1
        out["full_peak_mib"] = lr.full_bytes_peak / 2**20 if lr is not None else -1
    out["peak_rss_mib"] = COMM.allreduce(
        resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, op=MPI.MAX
    )
    integ.destroy()
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="5e-4", help="h_contact values (m), comma-separated")
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--out", default="benchmarks/results/dynamic_cost.csv")
    ap.add_argument(
        "--memory-ratio",
        type=float,
        default=LinearOptions().memory_ratio,
        help="[contact.linear] memory_ratio of the contact run (default: the package's)",
    )
    a = ap.parse_args()
    rows = []
    for h in (float(s) for s in a.sizes.split(",")):
        p = SphereImpact(h_contact=h, h_far=10 * h)
        # contact: every step from 0.1 t_c to 0.9 t_c (the zone grows, then shrinks)
        # (the contact-free steps before and after the contact run: the machine's load drifts)
        mr = a.memory_ratio
        before = run(p, False, min(a.steps, 10), 0.0, mr)
        con = run(p, True, a.steps, 0.1 * p.contact_time, mr)
        after = run(p, False, min(a.steps, 10), 0.0, mr)
        free = {
            k: 0.5 * (before.get(k, 0.0) + after.get(k, 0.0))
            for k in ("step", "solve", "step_cpu", "solve_cpu")
        }
        row = dict(
            case="sphere",
            h_contact=h,
            dofs=con["dofs"],
            ranks=COMM.size,
            steps_free=min(a.steps, 10),
            steps_contact=a.steps,
            free_step_s=free["step"],
            free_before_s=before["step"],
            free_after_s=after["step"],
            contact_step_s=con["step"],
            ratio=con["step"] / free["step"],
            free_step_cpu_s=free["step_cpu"],
            contact_step_cpu_s=con["step_cpu"],
            ratio_cpu=con["step_cpu"] / free["step_cpu"],
            free_solve_s=free.get("solve", 0.0),
            free_solve_cpu_s=free.get("solve_cpu", 0.0),
            memory_ratio=mr,
        )
        for k in (
            "rhs", "predictor_gaps", "dirichlet", "contact", "pdas_rhs", "pdas_begin",
            "new_columns", "refactor", "final_solve", "pdas_finish", "velocity",
        ):  # fmt: skip
            row[f"{k}_s"] = con.get(k, 0.0)
            row[f"{k}_cpu_s"] = con.get(f"{k}_cpu", 0.0)
        for k in (
            "pdas_iterations", "n_active", "factorizations", "columns", "prefetched", "full_limit",
            "solves_per_step", "blocks_per_step", "final_per_step", "full_cap", "full_used",
            "full_peak_mib",
        ):  # fmt: skip
            row[f"n_{k}"] = con.get(k, 0)
        row["peak_rss_free_mib"] = before["peak_rss_mib"]  # (the process's peak: measured first)
        row["peak_rss_contact_mib"] = con["peak_rss_mib"]
        row["machine"] = machine() + " (busy)"
        rows.append(row)
        if COMM.rank == 0:
            print({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in row.items()})
    out = Path(a.out)
    write_rows(out.parent, out.stem, rows)


if __name__ == "__main__":
    main()
