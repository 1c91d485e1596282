"""The contact robustness matrix (bonecontact.verification.robustness): every configuration
of the covering design (pairwise cover of the parameters, hard corners, ill-posed
configurations), generated as a gmsh mesh and a scene, run through ``run_scene`` (what
``bonecontact run`` calls) on the ranks of this process, and recorded: status, PDAS
iterations, wall time, force-balance and closed-form errors, outcome.  Run it on 1, 2
and 3 ranks; the 1-rank run keeps its pressures in ``$TMPDIR/bonecontact-robustness``,
and ``--compare`` adds, on rank counts > 1, whether the pressures equal those (1e-8 of
the peak; column ``ranks_agree``).

Usage:
    python benchmarks/bench_robustness.py [--quick] [--out benchmarks/results/robustness.csv]
    mpiexec -n 2 python benchmarks/bench_robustness.py --compare
    python benchmarks/bench_robustness.py --table    # the Markdown table of the CSV

``--quick``: the 2D configurations only; ``--only TEXT``: the configurations whose name
contains TEXT (the table keeps the last row of each configuration and rank count).
"""

import dolfinx_solver  # noqa: F401

import argparse
import csv
import math
import shutil
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
    configs = [c for c in configs if args.only is None or args.only in c.name]
    store = Path(tempfile.gettempdir()) / "bonecontact-robustness"  # 1-rank pressures
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
    COMM.barrier()
    if COMM.rank == 0:
        shutil.rmtree(folder, ignore_errors=True)


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
            if r["status"] == "refused":
                cells.append("refused (exit 2)")
                continue
            agree = f", {r['ranks_agree']}" if r.get("ranks_agree") else ""
            touch = f", touch on {r['touch_ranks']}" if int(r.get("touch_ranks") or 1) > 1 else ""
            cells.append(f"{r['iterations']} its, {_time(r['time_s'])}{agree}{touch}")
        first = by.get((name, ranks[0]))
        outcomes = sorted({by[(name, n)]["outcome"] for n in ranks if (name, n) in by})
        lines.append(
            f"| `{name}` | {first['dofs'] if int(first['dofs']) else '–'} | "
            + " | ".join(cells)
            + f" | {_num(first['balance'])} | {_num(first['closed_form'])} | "
            + "; ".join(outcomes)
            + " |"
        )
    return "\n".join(lines)


def _time(text: str) -> str:
    v = float(text)
    return "–" if math.isnan(v) else f"{v:.1f} s"


def _num(text: str) -> str:
    v = float(text)
    return "–" if math.isnan(v) else f"{v:.1e}"


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--quick", action="store_true")
    p.add_argument("--compare", action="store_true")
    p.add_argument("--table", action="store_true")
    p.add_argument("--only", help="run only the configurations whose name contains this")
    p.add_argument("--out", default=str(ROOT / "benchmarks/results/robustness.csv"))
    args = p.parse_args()
    if args.table:
        if COMM.rank == 0:
            print(table(Path(args.out)))
        return
    run(args)


if __name__ == "__main__":
    main()
