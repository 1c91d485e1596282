"""Communication of the PDAS set logic per iteration against the number of ranks (#24).

The 3D load-driven Hertz problem (hemisphere on a block, held only by contact, a/R =
0.1; :func:`bonecontact.verification.load_driven.sphere_on_block_3d`) is solved once
from a cold start with MUMPS (``--strategy lowrank``, the default, or ``refactor``) and
the compliance cold start.  Counted: the bytes each rank contributes to and receives
from the exchanges of the contact logic (set decisions, convergence test, cold start,
the low-rank update's small system), per PDAS iteration, the largest single message,
and the number of exchanges; not counted: the distributed linear algebra (PETSc/MUMPS products and
solves), which is the same before and after.

The counts come from :data:`bonecontact.contact.reductions.TRAFFIC`.  Run against the
code before the change (``--before``: a copy of the package whose ``contact`` modules
are those of the parent commit, given by ``--tree``), the replicating gathers
(``RowLayout.gather``, the low-rank ``_gather``) are wrapped and counted instead (their
scalar reductions are not: a lower bound).

Usage: mpiexec -n K python benchmarks/bench_set_comm.py [--h 1e-3 6e-4] [--before --tree DIR]
Writes (appends) benchmarks/results/set_comm.csv.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def _use_tree(tree: str) -> None:
    """Import the package from ``tree`` instead of the editable install."""
    sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in type(f).__name__.lower()]
    sys.path.insert(0, tree)


def _count_gathers(counter: dict) -> None:
    """(``--before``) Wrap the replicating gathers of the old contact modules."""
    import numpy as np

    from bonecontact.contact import condensed, lowrank

    def wrap(fn):
        def counted(self, local):
            out = fn(self, local)
            counter["calls"] += 1
            counter["sent"] += np.asarray(local).nbytes
            counter["received"] += out.nbytes
            counter["largest"] = max(counter["largest"], out.nbytes)
            return out

        return counted

    condensed.RowLayout.gather = wrap(condensed.RowLayout.gather)
    lowrank.LowRankActiveSetSolver._gather = wrap(lowrank.LowRankActiveSetSolver._gather)


def run(h: float, before: bool, counter: dict, strategy: str) -> dict:
    """One cold-started solve at contact mesh size ``h``; the counts per iteration."""
    from mpi4py import MPI

    from bonecontact.contact.options import PDASOptions
    from bonecontact.verification.load_driven import sphere_on_block_3d

    comm = MPI.COMM_WORLD
    options = PDASOptions.from_fields(strategy=strategy)
    prob = sphere_on_block_3d(comm, h, h_far=4e-3, options=options)
    integ = prob.integrator
    if before:
        for k in counter:
            counter[k] = 0
    else:
        from bonecontact.contact.reductions import TRAFFIC

        TRAFFIC.reset()
    t0 = time.perf_counter()
    integ.step()
    wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    if before:
        calls, sent, recv, largest = (counter[k] for k in ("calls", "sent", "received", "largest"))
    else:
        calls, sent, recv = TRAFFIC.calls, TRAFFIC.sent, TRAFFIC.received
        largest = max(TRAFFIC.largest.values(), default=0)
    r = integ.last_contact
    its = max(r.iterations, 1)
    n_slave = comm.allreduce(prob.interface.num_owned, op=MPI.SUM)
    dofs = prob.model.V.dofmap.index_map.size_global * prob.model.V.dofmap.index_map_bs
    row = {
        "code": "before" if before else "after",
        "strategy": strategy,
        "ranks": comm.size,
        "h_contact_mm": 1e3 * h,
        "dofs": dofs,
        "slave_nodes": n_slave,
        "iterations": r.iterations,
        "exchanges_per_it": comm.allreduce(calls, op=MPI.MAX) / its,
        "sent_bytes_per_it": comm.allreduce(sent, op=MPI.MAX) / its,
        "received_bytes_per_it": comm.allreduce(recv, op=MPI.MAX) / its,
        "largest_message_bytes": comm.allreduce(largest, op=MPI.MAX),
        "n_active": r.n_active[0],
        "wall_s": round(wall, 3),
    }
    integ.destroy()
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--h", type=float, nargs="+", default=[1.2e-3, 8e-4])
    ap.add_argument("--before", action="store_true")
    ap.add_argument("--strategy", default="lowrank", choices=["lowrank", "refactor"])
    ap.add_argument("--tree", default=None, help="package tree to import (with --before)")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results"))
    args = ap.parse_args()
    if args.tree:
        _use_tree(args.tree)
    import dolfinx_solver  # noqa: F401

    from mpi4py import MPI

    counter = {"calls": 0, "sent": 0, "received": 0, "largest": 0}
    if args.before:
        _count_gathers(counter)
    sys.path.insert(0, str(Path(__file__).parent))
    from common import write_rows

    rows = [run(h, args.before, counter, args.strategy) for h in args.h]
    if MPI.COMM_WORLD.rank == 0:
        for r in rows:
            print(r, flush=True)
    write_rows(Path(args.out), "set_comm", rows)


if __name__ == "__main__":
    main()
