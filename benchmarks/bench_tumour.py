"""Tumour growth: R(t) error against wall time for the radial quasi-steady case
(docs/theory/growth.md#tumour-model).

2D Byrne-Chaplain reduction (u_p = 1, K_B = mu (u_c - u~), mu = 1, u~ = 0.5, R0 = 1,
t in [0, 6]): the equivalent radius sqrt(A/pi) of the free-boundary solution against the
radius ODE dR/dt = mu [I1(R)/I0(R) - u~ R/2] (scipy, rtol 1e-11), over boundary/mesh
spacings h and growth steps dt (remesh every step).

Usage:  python benchmarks/bench_tumour.py [--quick] [--out benchmarks/results/tumour.csv]
"""

import dolfinx_solver  # noqa: F401

import argparse
import csv
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
from scipy.integrate import solve_ivp
from scipy.special import iv

from bonecontact.neoplasm.tumour import TumourModel, TumourParameters


def run(h: float, dt: float, t_end: float = 6.0) -> dict:
    mu, ut = 1.0, 0.5
    p = TumourParameters(K_B=lambda c: mu * (c - ut), u_p0=1.0)
    comm = MPI.COMM_WORLD
    comm.barrier()
    t0 = time.perf_counter()
    m = TumourModel.disc(comm, 1.0, p, h)
    ts, rs = [0.0], [m.equivalent_radius()]
    while m.t < t_end - 1e-12:
        m.step(dt)
        ts.append(m.t)
        rs.append(m.equivalent_radius())
    wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    ode = solve_ivp(
        lambda t, R: mu * (iv(1, R) / iv(0, R) - ut * R / 2),
        (0, ts[-1]),
        [rs[0]],
        t_eval=ts,
        rtol=1e-11,
        atol=1e-12,
    )
    err = float(np.max(np.abs(np.array(rs) / ode.y[0] - 1)))
    return dict(
        h=h,
        dt=dt,
        ranks=comm.size,
        cells=m.mesh.topology.index_map(2).size_global,
        R_end=rs[-1],
        R_ode=float(ode.y[0][-1]),
        max_rel_error=err,
        wall_s=wall,
    )


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "tumour.csv"))
    args = ap.parse_args()
    cases = (
        [(0.4, 0.4), (0.25, 0.2)]
        if args.quick
        else [
            (0.4, 0.4),
            (0.4, 0.2),
            (0.25, 0.4),
            (0.25, 0.2),
            (0.25, 0.1),
            (0.15, 0.2),
            (0.15, 0.1),
        ]
    )
    rows = [run(h, dt) for h, dt in cases]
    if MPI.COMM_WORLD.rank == 0:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        with open(args.out, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        for r in rows:
            print(r)


if __name__ == "__main__":
    main()
