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


def contact3d_table(path: Path) -> str:
    """The 3D load-driven contact study (bench_contact3d.py): one row per case, phases in
    seconds, memory in MiB per rank (max over ranks); failed cases with their message."""
    rows = list(csv.DictReader(open(path)))
    if not rows:
        return ""
    out = [
        f"Machine: {rows[-1]['machine']}; date: {rows[-1]['date']}.",
        "",
        "| dofs | ranks | solver | status | a/h | PDAS its | Krylov its | err a | err p₀ "
        "| mesh gen (s) | mesh read (s) | assembly (s) | mortar (s) | set-up (s) "
        "| contact solve (s) | output (s) | linear solve (s) [its] | ratio "
        "| peak mem (MiB) | mem contact / linear (MiB) |",
        "|" + "---|" * 20,
    ]

    def pct(v: str) -> str:
        return f"{100 * float(v):+.1f} %" if v else ""

    def key(r: dict) -> tuple:
        return (int(r["dofs"]), int(r["ranks"]), r["linear"])

    failed = []
    for r in sorted(rows, key=key):
        solver = "MUMPS" if r["linear"] == "direct" else "Krylov+GAMG"
        its = r["linear_its"] if r["linear"] == "iterative" else ""
        krylov = r["krylov_iterations"] if r["linear"] == "iterative" else "—"
        out.append(
            f"| {r['dofs']} | {r['ranks']} | {solver} | {r['status']} | {r['a_over_h']} "
            f"| {r['pdas_iterations']} | {krylov} | {pct(r['err_a'])} "
            f"| {pct(r['err_p0'])} | {r['t_mesh_generate_s']} | {r['t_mesh_read_s']} "
            f"| {r['t_assembly_s']} | {r['t_mortar_s']} | {r['t_setup_s']} "
            f"| {r['t_contact_s']} | {r['t_output_s']} | {r['t_linear_s']}"
            f"{f' [{its}]' if its else ''} | {r['ratio']} | {r['peak_mem_mb']} "
            f"| {r['mem_contact_solve_mb']} / {r['mem_linear_solve_mb']} |"
        )
        if r["status"] != "converged":
            failed.append(f"* {r['dofs']} dofs, {r['ranks']} rank(s), {solver}: {r['message']}")
    if failed:
        out += ["", "Failed cases:", ""] + failed
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
        tables = {"timestep": timestep_table, "contact3d": contact3d_table}
        text = tables.get(name, generic_table)(src)
        (RESULTS / f"{name}.md").write_text(text)
        print(f"## {name}\n{text}")
