"""Fracture: stress intensity factor error against dofs and wall time, and the cost of one
propagation increment.

1. Centre crack (a/W = 0.3, plane strain, half-height 2W) over tip sizes a/20 … a/160
   (grading and h_max refined with it): K_I error against Feddersen's closed form for the
   domain interaction integral (r_out = 0.3a) and displacement correlation (r_max = 0.3a),
   their wall times (best of 2) and the time of the linear solve.
2. Inclined centre crack β = 45° (a/W = 0.05) over tip sizes a/20 … a/160: K_I and K_II
   errors of both methods against σ√(πa)cos²β, σ√(πa)sinβcosβ, with their times; and
   over β = 0 … 60° the MTS and principal-direction-average kink angles against the MTS
   angle of the exact K (−53.13° at 45°).
3. One propagation increment (mesh + solve + SIF + direction) of the β = 45° crack against
   one linear solve (assembly + MUMPS factorisation + solve) of the same mesh.

Usage: python benchmarks/bench_fracture.py [--quick]   (also under mpiexec -n K)
Writes benchmarks/results/fracture.csv, fracture_mixed.csv, fracture_direction.csv,
fracture_increment.csv.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import argparse
import math
import time
from pathlib import Path

from mpi4py import MPI

from common import machine, write_rows  # (benchmarks/ is the script directory)

from bonecontact.fracture.criteria import (
    cell_stresses,
    mts_angle,
    principal_direction_average,
)
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.plates import centre_crack, mesh_plate, rectangle_outline, solve_tension
from bonecontact.fracture.propagation import PropagationOptions, propagate
from bonecontact.fracture.sif import displacement_correlation, interaction_integral
from bonecontact.materials.laws import Isotropic

COMM = MPI.COMM_WORLD
MAT = Isotropic(E=17.0e9, nu=0.3)
SIGMA = 1.0e6
OUT = Path(__file__).resolve().parent / "results"


def best_time(f, repeat: int = 2):
    """(result, best wall time) of ``f()`` over ``repeat`` runs (collective)."""
    best, out = math.inf, None
    for _ in range(repeat):
        COMM.barrier()
        t0 = time.perf_counter()
        out = f()
        COMM.barrier()
        best = min(best, time.perf_counter() - t0)
    return out, best


def sif_study(quick: bool) -> list[dict]:
    W, a = 1.0, 0.3
    ref = SIGMA * math.sqrt(math.pi * a / math.cos(math.pi * a / (2 * W)))
    rows = []
    levels = (20, 40, 80) if quick else (20, 40, 80, 160)
    for n in levels:
        size = TipMesh(a / n, max(0.06, 0.25 * (20 / n) ** 0.5), W * 5 / n)
        cm = mesh_plate(W, 2 * W, centre_crack(a), size, COMM)
        sol, t_solve = best_time(lambda cm=cm: solve_tension(cm, MAT, SIGMA))
        ii, t_ii = best_time(lambda s=sol, c=cm: interaction_integral(s.u, c, -1, MAT, 0.3 * a))
        dc, t_dc = best_time(lambda s=sol, c=cm: displacement_correlation(s.u, c, -1, MAT, 0.3 * a))
        rows.append(
            {
                "h_tip/a": f"1/{n}",
                "dofs": sol.model.num_dofs,
                "ranks": COMM.size,
                "err_interaction_%": f"{100 * (ii.K_I / ref - 1):+.3f}",
                "err_displacement_%": f"{100 * (dc.K_I / ref - 1):+.3f}",
                "t_solve_s": f"{t_solve:.3f}",
                "t_interaction_s": f"{t_ii:.4f}",
                "t_displacement_s": f"{t_dc:.4f}",
            }
        )
        if COMM.rank == 0:
            print(rows[-1], flush=True)
    return rows


def mixed_mode_study(quick: bool) -> list[dict]:
    """Inclined centre crack β = 45° (a/W = 0.05): K_I and K_II errors against
    σ√(πa)cos²β and σ√(πa)sinβcosβ (infinite plate; the finite width adds ~+0.15 %) for
    both methods over tip sizes a/20 … a/160, with their times."""
    a, beta = 0.05, math.radians(45.0)
    ref_1 = SIGMA * math.sqrt(math.pi * a) * math.cos(beta) ** 2
    ref_2 = SIGMA * math.sqrt(math.pi * a) * math.sin(beta) * math.cos(beta)
    rows = []
    for n in (20, 40, 80) if quick else (20, 40, 80, 160):
        size = TipMesh(a / n, max(0.06, 0.25 * (20 / n) ** 0.5), 0.1)
        cm = mesh_plate(1.0, 2.0, centre_crack(a, 45.0), size, COMM)
        sol, t_solve = best_time(lambda cm=cm: solve_tension(cm, MAT, SIGMA))
        ii, t_ii = best_time(lambda s=sol, c=cm: interaction_integral(s.u, c, -1, MAT, 0.3 * a))
        dc, t_dc = best_time(lambda s=sol, c=cm: displacement_correlation(s.u, c, -1, MAT, 0.3 * a))
        rows.append(
            {
                "h_tip/a": f"1/{n}",
                "dofs": sol.model.num_dofs,
                "ranks": COMM.size,
                "err_KI_interaction_%": f"{100 * (ii.K_I / ref_1 - 1):+.3f}",
                "err_KII_interaction_%": f"{100 * (ii.K_II / ref_2 - 1):+.3f}",
                "err_KI_displacement_%": f"{100 * (dc.K_I / ref_1 - 1):+.3f}",
                "err_KII_displacement_%": f"{100 * (dc.K_II / ref_2 - 1):+.3f}",
                "t_solve_s": f"{t_solve:.3f}",
                "t_interaction_s": f"{t_ii:.4f}",
                "t_displacement_s": f"{t_dc:.4f}",
            }
        )
        if COMM.rank == 0:
            print(rows[-1], flush=True)
    return rows


def direction_study() -> list[dict]:
    a = 0.05
    rows = []
    for beta in (0.0, 30.0, 45.0, 60.0):
        cm = mesh_plate(1.0, 2.0, centre_crack(a, beta), TipMesh(a / 80, 0.12, 0.1), COMM)
        sol = solve_tension(cm, MAT, SIGMA)
        k = interaction_integral(sol.u, cm, -1, MAT, 0.4 * a)
        b = math.radians(beta)
        exact = mts_angle(math.cos(b) ** 2, math.sin(b) * math.cos(b))
        cs = cell_stresses(sol.model, sol.u)
        avg = principal_direction_average(
            cs, COMM, cm.crack.tip(-1), cm.crack.direction(-1), 48, 2 * a / 80
        )
        rows.append(
            {
                "beta_deg": beta,
                "mts_exact_deg": f"{math.degrees(exact):.2f}",
                "mts_computed_deg": f"{math.degrees(mts_angle(k.K_I, k.K_II)):.2f}",
                "principal_average_deg": f"{math.degrees(avg):.2f}",
                "ranks": COMM.size,
            }
        )
        if COMM.rank == 0:
            print(rows[-1], flush=True)
    return rows


def increment_study() -> list[dict]:
    a = 0.05
    da = a / 3
    outline = rectangle_outline(-0.5, -1.0, 0.5, 1.0)
    opts = PropagationOptions(da, TipMesh(da / 8, 0.15, 0.1), max_increments=1)

    def solve(cm):
        s = solve_tension(cm, MAT, SIGMA)
        return s.model, s.u

    _, t_inc = best_time(lambda: propagate(outline, centre_crack(a, 45.0), solve, MAT, opts, COMM))
    cm = mesh_plate(0.5, 1.0, centre_crack(a, 45.0), opts.tip_mesh, COMM)
    sol, t_lin = best_time(lambda: solve_tension(cm, MAT, SIGMA))
    row = {
        "dofs": sol.model.num_dofs,
        "ranks": COMM.size,
        "t_increment_s": f"{t_inc:.3f}",
        "t_linear_solve_s": f"{t_lin:.3f}",
        "ratio": f"{t_inc / t_lin:.2f}",
    }
    if COMM.rank == 0:
        print(row, flush=True)
    return [row]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer refinement levels")
    args = parser.parse_args()
    OUT.mkdir(exist_ok=True)
    extra = {"machine": machine()}
    write_rows(OUT, "fracture", sif_study(args.quick), extra)
    write_rows(OUT, "fracture_mixed", mixed_mode_study(args.quick), extra)
    write_rows(OUT, "fracture_direction", direction_study(), extra)
    write_rows(OUT, "fracture_increment", increment_study(), extra)


if __name__ == "__main__":
    main()
