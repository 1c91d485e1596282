"""Turn benchmarks/results/*.csv into the Markdown tables of benchmarks/results/*.md."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

RESULTS = Path(__file__).parent / "results"


def timestep_table(path: Path) -> str:
    rows = list(csv.DictReader(open(path)))
    if not rows:
        return ""
    out = [
        f"Machine: {rows[-1]['machine']}; date: {rows[-1]['date']}.",
        "",
        "| dim | solver | ranks | dofs | set-up (s) | per step (s) | its/step | rel. L² error |",
        "|---|---|---|---|---|---|---|---|",
    ]
    key = lambda r: (int(r["dim"]), r["linear"], int(r["ranks"]), int(r["dofs"]))  # noqa: E731
    for r in sorted(rows, key=key):
        solver = "MUMPS LU" if r["linear"] == "direct" else "CG+GAMG"
        out.append(
            f"| {r['dim']}D | {solver} | {r['ranks']} | {r['dofs']} | "
            f"{float(r['setup_s']):.3f} | {float(r['step_s']):.4f} | {r['its_per_step']} | "
            f"{float(r['rel_L2_error']):.2e} |"
        )
    return "\n".join(out) + "\n"


def generic_table(path: Path) -> str:
    rows = list(csv.DictReader(open(path)))
    if not rows:
        return ""
    cols = list(rows[0])
    out = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    out += ["| " + " | ".join(r[c] for c in cols) + " |" for r in rows]
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    for name in sys.argv[1:] or ["timestep"]:
        src = RESULTS / f"{name}.csv"
        if not src.exists():
            continue
        text = timestep_table(src) if name == "timestep" else generic_table(src)
        (RESULTS / f"{name}.md").write_text(text)
        print(f"## {name}\n{text}")
