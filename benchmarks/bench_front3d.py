"""3D crack front: K_I error along a penny-shaped crack against dofs and wall time.

One octant of the block [−4a, 4a]³ with a penny crack of radius a at its centre, remote
tension σ (E = 1, ν = 0.3), front sizes h_f = a/10 … a/32 with the grading (1.92/n) and
the largest size (min(a, 8a/n)) refined with it (n = a/h_f).  K_I by the 3D domain
interaction integral (r_out = 0.3a) at φ = 0, 22.5°, …, 90° against 2σ√(a/π): the largest
error, the spread along the front, the wall time of meshing, of the linear solve and of one
front point (best of 2, after the form is compiled).

Usage: python benchmarks/bench_front3d.py [--quick]   (also under mpiexec -n K)
Writes benchmarks/results/front3d.csv.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import argparse
import math
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
from common import machine, write_rows  # (benchmarks/ is the script directory)

from bonecontact.fracture.front3d import (
    EllipticalFront,
    front_interaction_integral,
    mesh_crack_octant,
    penny_k,
)
from bonecontact.materials.laws import Isotropic
from bonecontact.verification.crack_octant import solve_crack_octant

COMM = MPI.COMM_WORLD
MAT = Isotropic(E=1.0, nu=0.3)
OUT = Path(__file__).resolve().parent / "results"


def level(n: int) -> dict:
    COMM.barrier()
    t0 = time.perf_counter()
    blk = mesh_crack_octant(
        EllipticalFront(1.0, 1.0), 4.0, 1.0 / n, 1.92 / n, min(1.0, 8.0 / n), COMM
    )
    t1 = time.perf_counter()
    u = solve_crack_octant(blk, MAT, 1.0)
    t2 = time.perf_counter()
    phis = np.radians(np.arange(0, 91, 22.5))
    ks = [front_interaction_integral(u, blk, p, MAT, 0.3).K_I for p in phis]
    best = math.inf
    for _ in range(2):
        COMM.barrier()
        t = time.perf_counter()
        front_interaction_integral(u, blk, math.pi / 4, MAT, 0.3)
        best = min(best, time.perf_counter() - t)
    err = np.array(ks) / penny_k(1.0, 1.0) - 1
    return {
        "h_front/a": f"1/{n}",
        "dofs": u.function_space.dofmap.index_map.size_global
        * u.function_space.dofmap.index_map_bs,
        "ranks": COMM.size,
        "max_abs_err_%": f"{100 * np.abs(err).max():.2f}",
        "err_range_%": f"{100 * err.min():+.2f} .. {100 * err.max():+.2f}",
        "t_mesh_s": f"{t1 - t0:.2f}",
        "t_solve_s": f"{t2 - t1:.2f}",
        "t_point_s": f"{best:.2f}",
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer refinement levels")
    args = parser.parse_args()
    rows = [level(n) for n in ((10, 16) if args.quick else (10, 16, 24, 32))]
    if COMM.rank == 0:
        for r in rows:
            print(r)
    write_rows(OUT, "front3d", rows, {"machine": machine()})


if __name__ == "__main__":
    main()
