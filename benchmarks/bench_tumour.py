"""Tumour growth: R(t) error against wall time for the radial quasi-steady case
(docs/theory/growth.md#tumour-model).

2D Byrne-Chaplain reduction (u_p = 1, K_B = mu (u_c - u~), mu = 1, u~ = 0.5, R0 = 1,
t in [0, 6]): the equivalent radius sqrt(A/pi) of the free-boundary solution against the
radius ODE dR/dt = mu [I1(R)/I0(R) - u~ R/2] (scipy, rtol 1e-11), over boundary/mesh
spacings h and growth steps dt (remesh every step).

3D cost study (``--study3d``): a meshless ball tumour built the way a growth scene builds it
(:func:`bonecontact.neoplasm.growth.tumour_growth`, R0 = 1, remeshed every step, with
surface tension and nutrient-dependent rates), at mesh sizes giving about 3k, 10k and 24k
cells.  For each size: the wall time of every phase of a growth step
(``TumourModel.timer``: nutrient, curvature, pressure, velocity, extension, transport, move,
reaction, gmsh, setup, transfer), the best of the steps after the first (the machine is
shared: noise only adds), and the ratio of a step to one linear solve of the same mesh
(the pressure system assembled and solved once with the model's solver, MUMPS LU; and with
CG + GAMG for comparison), with and without the remesh (gmsh + setup + transfer).

Usage:  python benchmarks/bench_tumour.py [--quick] [--out benchmarks/results/tumour.csv]
        python benchmarks/bench_tumour.py --study3d [--quick] [--steps 4]
            (appends to benchmarks/results/tumour3d.csv)
"""

import dolfinx_solver  # noqa: F401

import argparse
import csv
import math
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
import ufl
from common import write_rows  # (benchmarks/ is the script directory)
from dolfinx import fem
from dolfinx.fem.petsc import LinearProblem
from scipy.integrate import solve_ivp
from scipy.special import iv

from bonecontact.neoplasm.growth import tumour_growth
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


#: 3D study: mesh sizes of the R0 = 1 ball (about 3k, 10k and 24k cells after a few steps).
H3D = (0.19, 0.13, 0.095)

#: The phases of a remesh (the rest of a step is the growth step on a fixed mesh).
REMESH_PHASES = ("gmsh", "setup", "transfer")

#: The solvers of the reference linear solve.
SOLVERS = {
    "mumps": {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"},
    "cg_gamg": {"ksp_type": "cg", "pc_type": "gamg", "ksp_rtol": 1e-10},
}


def linear_solve_time(m: TumourModel, solver: str, repeat: int = 3) -> tuple[float, int]:
    """Best wall time (s, slowest rank) of one assembly + solve of the pressure system of
    ``m`` on its current mesh, and the Krylov iterations."""
    V = m.V
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    problem = LinearProblem(
        ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx,
        m.h_expr * v * ufl.dx,
        bcs=[fem.dirichletbc(m.sigma, m.bdofs)],
        petsc_options=SOLVERS[solver],
        petsc_options_prefix=f"bench_tumour_{solver}_{id(m)}_",
    )
    problem.solve()  # forms compiled, PETSc objects created
    best = math.inf
    for _ in range(repeat):
        m.comm.barrier()
        t0 = time.perf_counter()
        problem.solve()
        best = min(best, m.comm.allreduce(time.perf_counter() - t0, op=MPI.MAX))
    return best, problem.solver.getIterationNumber()


def study3d(h: float, steps: int, dt: float = 0.04) -> dict:
    """Per-phase cost of the growth steps of a meshless 3D ball tumour of mesh size h."""
    comm = MPI.COMM_WORLD
    p = TumourParameters(
        K_B=lambda c: c - 0.3, K_Q=0.2, K_P=0.1, K_R=0.1, gamma=1e-3, u_p0=0.8, u_q0=0.1
    )
    comm.barrier()
    t0 = time.perf_counter()
    m = tumour_growth(comm, p, 3, h, 1, radius=1.0).model
    build = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    per_step = []
    for _ in range(steps):
        before = dict(m.timer.times)
        comm.barrier()
        t0 = time.perf_counter()
        m.step(dt)
        wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
        local = np.array([v - before.get(k, 0.0) for k, v in m.timer.times.items()])
        slowest = np.empty_like(local)
        comm.Allreduce(local, slowest, op=MPI.MAX)  # every rank has the same phases
        phases = dict(zip(m.timer.times, slowest.tolist()))
        per_step.append((wall, phases))
    later = per_step[1:] or per_step  # the first step may still compile forms
    best = {k: min(ph[k] for _, ph in later) for k in later[0][1]}
    lu, _ = linear_solve_time(m, "mumps")
    cg, its = linear_solve_time(m, "cg_gamg")
    step = min(w for w, _ in later)
    remesh = min(sum(ph.get(k, 0.0) for k in REMESH_PHASES) for _, ph in later)
    return dict(
        h=h,
        ranks=comm.size,
        cells=m.mesh.topology.index_map(3).size_global,
        vertices=m.mesh.topology.index_map(0).size_global,
        build_s=round(build, 3),
        step_s=round(step, 3),
        solve_mumps_s=round(lu, 4),
        solve_cg_gamg_s=round(cg, 4),
        cg_its=its,
        step_per_solve=round(step / lu, 1),
        remesh_s=round(remesh, 3),
        no_remesh_per_solve=round((step - remesh) / lu, 1),
        **{f"{k}_s": round(v, 4) for k, v in best.items()},
    )


def main3d(args: argparse.Namespace) -> None:
    rows = []
    for h in H3D[:1] if args.quick else H3D:
        rows.append(study3d(h, args.steps))
        if MPI.COMM_WORLD.rank == 0:
            print(rows[-1], flush=True)
    write_rows(Path(args.out).parent, "tumour3d", rows)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "tumour.csv"))
    ap.add_argument("--study3d", action="store_true", help="3D cost per step against cells")
    ap.add_argument("--steps", type=int, default=4, help="growth steps per size (3D study)")
    args = ap.parse_args()
    if args.study3d:
        main3d(args)
        return
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
