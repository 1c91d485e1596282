"""The contact robustness matrix (bonecontact.verification.robustness): every configuration
of the covering design (pairwise cover of the parameters, hard corners, ill-posed
configurations), generated as a gmsh mesh and a scene, run through ``run_scene`` (what
``bonecontact run`` calls) on the ranks of this process, and recorded: status, PDAS
iterations, wall time, force-balance and closed-form errors, outcome.  Run it on 1, 2
and 3 ranks; ``--compare`` then adds, on rank counts > 1, whether the pressures equal
those of the 1-rank rows of the CSV (1e-8 of the peak) with the same PDAS iterations.

Usage:
    python benchmarks/bench_robustness.py [--quick] [--out benchmarks/results/robustness.csv]
    mpiexec -n 2 python benchmarks/bench_robustness.py --compare
    python benchmarks/bench_robustness.py --table    # the Markdown table of the CSV

``--quick``: the 2D configurations only.
"""

import dolfinx_solver  # noqa: F401

import argparse
import csv
import math
import sys
import tempfile
from pathlib import Path

from mpi4py import MPI

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from common import machine, write_rows

from bonecontact.verification.robustness import (
    matrix,
    run_config,
)

ROOT = Path(__file__).resolve().parents[1]
COMM = MPI.COMM_WORLD


def _agreement(name: str, rec, store: Path) -> str:
    """``same`` / ``DIFFERENT (...)`` against the 1-rank pressures saved in ``store``."""
    ref = store / f"{name}.npy"
    if not ref.exists() or rec.pressures.size == 0:
        return ""
    a, dim = np.load(ref), rec.config.dim
    b = rec.pressures
    if a.shape != b.shape or np.abs(a[:, :dim] - b[:, :dim]).max() > 1e-12:
        return "DIFFERENT (nodes)"
    d = float(np.abs(a[:, dim] - b[:, dim]).max() / max(np.abs(a[:, dim]).max(), 1e-300))
    return "same" if d <= 1e-8 else f"DIFFERENT ({d:.1e})"


def run(args) -> None:
    configs = [c for c in matrix() if not args.quick or c.dim == 2]
    store = Path(args.out).with_suffix("")  # 1-rank pressures, for --compare
    if COMM.rank == 0:
        store.mkdir(parents=True, exist_ok=True)
    folder = Path(COMM.bcast(tempfile.mkdtemp(prefix="robustness-") if COMM.rank == 0 else None))
    for cfg in configs:
        sub = folder / cfg.name
        if COMM.rank == 0:
            sub.mkdir()
        COMM.barrier()
        rec = run_config(cfg, sub, COMM)
        row = rec.row()
        row["ranks_agree"] = ""
        if COMM.rank == 0:
            if COMM.size == 1 and rec.pressures.size:
                np.save(store / f"{cfg.name}.npy", rec.pressures)
            elif args.compare:
                row["ranks_agree"] = _agreement(cfg.name, rec, store)
            print(
                f"{cfg.name:70s} {rec.ranks} {rec.status:9s} its {rec.iterations:3d} "
                f"{rec.time:7.2f} s  {rec.outcome} {row['ranks_agree']}",
                flush=True,
            )
        write_rows(Path(args.out).parent, Path(args.out).stem, [row], {"machine": machine()})


def table(path: Path) -> str:
    """The Markdown table of the CSV (one line per configuration; iterations, time and
    outcome per rank count)."""
    rows = list(csv.DictReader(path.open()))
    ranks = sorted({int(r["ranks"]) for r in rows})
    by = {(r["name"], int(r["ranks"])): r for r in rows}
    names = list(dict.fromkeys(r["name"] for r in rows))
    head = "| configuration | dofs | " + " | ".join(f"{n} rank{'s' * (n > 1)}" for n in ranks)
    head += " | force balance | closed form | outcome |"
    lines = [head, "|" + "---|" * (4 + len(ranks) + 1)]
    for name in names:
        cells = []
        for n in ranks:
            r = by.get((name, n))
            if r is None:
                cells.append("–")
                continue
            agree = f", {r['ranks_agree']}" if r.get("ranks_agree") else ""
            cells.append(f"{r['iterations']} its, {float(r['time_s']):.1f} s{agree}")
        first = by.get((name, ranks[0]))
        outcomes = sorted({by[(name, n)]["outcome"] for n in ranks if (name, n) in by})
        lines.append(
            f"| `{name}` | {first['dofs']} | "
            + " | ".join(cells)
            + f" | {_num(first['balance'])} | {_num(first['closed_form'])} | "
            + "; ".join(outcomes)
            + " |"
        )
    return "\n".join(lines)


def _num(text: str) -> str:
    v = float(text)
    return "–" if math.isnan(v) else f"{v:.1e}"


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--quick", action="store_true")
    p.add_argument("--compare", action="store_true")
    p.add_argument("--table", action="store_true")
    p.add_argument("--out", default=str(ROOT / "benchmarks/results/robustness.csv"))
    args = p.parse_args()
    if args.table:
        if COMM.rank == 0:
            print(table(Path(args.out)))
        return
    run(args)


if __name__ == "__main__":
    main()
