"""Surface-breaking cracks in 3D: K_I along the front against Newman–Raju.

The plate [−2, 2] × [−2, 2] × [−1, 0] (t = 1) under self-equilibrated tension S = 1
(E = 1, ν = 0.3) with a semi-elliptical surface crack or a quarter-elliptical corner
crack, depth a = 0.2 (a/t = 0.2), a/c = 0.5 and 1
(:func:`bonecontact.verification.surface_crack.solve_plate`).  K_I by the domain
interaction integral (ring r_out = 0.3a, its half-length along the front r_out or less
near the free surface) at parametric angles from 10° off the surface, against Newman and
Raju's equations: one row per case and angle (error in %), with the dofs and the wall
times of meshing + solve and of the front points.  And the through crack (edge crack of
length 0.4 through the thickness): K_I at z = −t/2 against the plane-strain K of the 2D
section.

Usage: python benchmarks/bench_surface_crack3d.py [--quick] [--front N]
(h_front = a/N, default 16; ``--quick``: the reduced mesh a/10 of the test suite; also
under mpiexec -n K).  Writes benchmarks/results/surface_crack3d.csv.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import argparse
import math
import time
from pathlib import Path

from mpi4py import MPI

from common import machine, write_rows  # (benchmarks/ is the script directory)

from bonecontact.fracture.crack import FractureError
from bonecontact.fracture.surface3d import SurfaceCrack
from bonecontact.verification.surface_crack import (
    PlateProblem,
    plane_strain_edge_k,
    solve_plate,
)

COMM = MPI.COMM_WORLD
OUT = Path(__file__).resolve().parent / "results"
A = 0.2
CASES = (("semi_elliptical", 0.5), ("semi_elliptical", 1.0), ("corner", 0.5), ("corner", 1.0))
SEMI_ANGLES = (10, 15, 20, 30, 45, 60, 75, 90, 105, 120, 135, 150, 165, 170)
CORNER_ANGLES = (10, 15, 20, 30, 45, 60, 70, 75, 80)


def sizes(n: int) -> dict:
    """Front a/n; grading and largest element as the test suite's meshes."""
    if n <= 10:
        return {"h_front": A / n, "grading": 0.15, "h_max": 0.4, "r_out": 0.3 * A}
    return {"h_front": A / n, "grading": 0.12, "h_max": 0.2, "r_out": 0.3 * A}


def elliptical_case(kind: str, a_c: float, n: int) -> list[dict]:
    p = PlateProblem(SurfaceCrack(kind, A, A / a_c), b=2.0, h=2.0, t=1.0, **sizes(n))
    COMM.barrier()
    t0 = time.perf_counter()
    sol = solve_plate(p, COMM)
    t1 = time.perf_counter()
    rows = []
    for deg in CORNER_ANGLES if kind == "corner" else SEMI_ANGLES:
        phi = math.radians(deg)
        try:
            k = sol.k(phi)
        except FractureError:  # closer to the surface than two front elements
            continue
        ref = float(p.reference(phi))
        rows.append(
            {
                "case": f"{kind} a/c={a_c:g}",
                "h_front/a": f"1/{n}",
                "dofs": sol.dofs,
                "ranks": COMM.size,
                "phi_deg": deg,
                "K_I": f"{k.K_I:.5f}",
                "reference": f"{ref:.5f}",
                "err_%": f"{100 * (k.K_I / ref - 1):+.2f}",
                "K_II/K_I_%": f"{100 * k.K_II / k.K_I:+.2f}",
                "K_III/K_I_%": f"{100 * k.K_III / k.K_I:+.2f}",
                "t_mesh_solve_s": f"{t1 - t0:.1f}",
            }
        )
    t2 = time.perf_counter()
    for r in rows:
        r["t_points_s"] = f"{t2 - t1:.1f}"
    return rows


def through_case(n: int) -> list[dict]:
    h = 0.05 if n <= 16 else 0.025  # the test suite's front: 0.05 (20 elements through t)
    p = PlateProblem(
        SurfaceCrack("through", 0.4), 2.0, 2.0, 1.0, h, 0.12, 0.2 if n > 10 else 0.4, 3 * h
    )
    COMM.barrier()
    t0 = time.perf_counter()
    sol = solve_plate(p, COMM)
    t1 = time.perf_counter()
    ref = plane_strain_edge_k(p, COMM)
    rows = []
    for z in (0.12, 0.25, 0.5, 0.75, 0.88):
        try:
            k = sol.k(z)
        except FractureError:  # closer to the surface than two front elements
            continue
        rows.append(
            {
                "case": "through a=0.4",
                "h_front/a": f"{h / 0.4:.3g}",
                "dofs": sol.dofs,
                "ranks": COMM.size,
                "phi_deg": f"z/t={z}",
                "K_I": f"{k.K_I:.5f}",
                "reference": f"{ref:.5f} (2D plane strain)",
                "err_%": f"{100 * (k.K_I / ref - 1):+.2f}",
                "K_II/K_I_%": f"{100 * k.K_II / k.K_I:+.2f}",
                "K_III/K_I_%": f"{100 * k.K_III / k.K_I:+.2f}",
                "t_mesh_solve_s": f"{t1 - t0:.1f}",
                "t_points_s": "",
            }
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the reduced mesh a/10")
    parser.add_argument("--front", type=int, default=16, help="h_front = a/N")
    args = parser.parse_args()
    n = 10 if args.quick else args.front
    rows = [r for kind, a_c in CASES for r in elliptical_case(kind, a_c, n)]
    rows += through_case(n)
    if COMM.rank == 0:
        for r in rows:
            print(r)
    write_rows(OUT, "surface_crack3d", rows, {"machine": machine()})


if __name__ == "__main__":
    main()
