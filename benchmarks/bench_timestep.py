"""Cost of the Kelvin–Voigt time stepping against the number of dofs, next to its error.

For each mesh (2D unit square, 3D unit cube), each linear solver (direct MUMPS LU, CG +
GAMG with the rigid-body near-nullspace) and each number of ranks (run this script with
``mpiexec -n K``), a dynamic problem with a manufactured solution

    u(x, t) = sin(ωt) w(x),  w smooth and not polynomial,

is advanced ``STEPS`` steps with Δt proportional to h.  Reported: the set-up time
(model, assembly of the time-independent operator, factorisation / preconditioner),
the mean wall time per dynamic step, the linear iterations per step, and the relative
L² error of u at the final time against the exact solution.

Usage:  python benchmarks/bench_timestep.py [--quick] [--out benchmarks/results/timestep.csv]
        mpiexec -n 2 python benchmarks/bench_timestep.py ...
Rows are appended to the CSV (one row per case), so runs on 1 and 2 ranks collect into
one file; ``benchmarks/run_all.sh`` does both and writes the Markdown table.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import argparse
import csv
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
import ufl
from common import machine  # (benchmarks/ is the script directory)
from dolfinx import mesh

from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics

COMM = MPI.COMM_WORLD
MAT = Isotropic(E=17.0e9, nu=0.3, rho=1900.0, tau_v=1.0e-5)
STEPS = 10
FIELDS = [
    "dim",
    "linear",
    "ranks",
    "N",
    "dofs",
    "setup_s",
    "step_s",
    "its_per_step",
    "rel_L2_error",
    "machine",
    "date",
]


def _w_ufl(x, dim):
    if dim == 2:
        return ufl.as_vector(
            [
                ufl.sin(np.pi * x[0]) * ufl.cos(1.3 * x[1]) + x[0] ** 2,
                ufl.exp(x[0] * x[1]) * ufl.sin(2.0 * x[1]),
            ]
        )
    return ufl.as_vector(
        [
            ufl.sin(np.pi * x[0]) * ufl.cos(1.3 * x[1]) + x[2] ** 2,
            ufl.exp(x[0] * x[1]) * ufl.sin(2.0 * x[2]),
            ufl.cos(x[0] + x[1] * x[2]),
        ]
    )


def _w_np(X, dim):
    if dim == 2:
        return np.array(
            [
                np.sin(np.pi * X[0]) * np.cos(1.3 * X[1]) + X[0] ** 2,
                np.exp(X[0] * X[1]) * np.sin(2.0 * X[1]),
            ]
        )
    return np.array(
        [
            np.sin(np.pi * X[0]) * np.cos(1.3 * X[1]) + X[2] ** 2,
            np.exp(X[0] * X[1]) * np.sin(2.0 * X[2]),
            np.cos(X[0] + X[1] * X[2]),
        ]
    )


def run_case(dim: int, N: int, linear: str) -> dict:
    """One manufactured dynamic run; returns a result row (collective)."""
    t0 = time.perf_counter()
    msh = mesh.create_unit_square(COMM, N, N) if dim == 2 else mesh.create_unit_cube(COMM, N, N, N)
    scale = 1.0e-4  # displacement amplitude (m)
    c = np.sqrt(MAT.E / MAT.rho)  # bar wave speed (m/s)
    omega = np.pi * c  # half a wave across the unit domain per period
    h = 1.0 / N
    dt = 0.05 * h / c  # Δt ∝ h
    x = ufl.SpatialCoordinate(msh)
    w = scale * _w_ufl(x, dim)
    lam, mu = MAT.E * MAT.nu / ((1 + MAT.nu) * (1 - 2 * MAT.nu)), MAT.E / (2 * (1 + MAT.nu))
    sig = 2 * mu * ufl.sym(ufl.grad(w)) + lam * ufl.tr(ufl.sym(ufl.grad(w))) * ufl.Identity(dim)
    divsig = ufl.div(sig)
    model = Mechanics(msh, MAT)
    model.add_body_force(w, schedule=lambda t: -MAT.rho * omega**2 * np.sin(omega * t))
    model.add_body_force(-divsig, schedule=lambda t: np.sin(omega * t))
    model.add_body_force(-MAT.tau_v * divsig, schedule=lambda t: omega * np.cos(omega * t))
    fdim = dim - 1
    msh.topology.create_connectivity(fdim, dim)
    bf = mesh.exterior_facet_indices(msh.topology)
    for comp in range(dim):
        model.add_dirichlet(
            bf,
            comp,
            lambda X, comp=comp: scale * _w_np(X, dim)[comp],
            schedule=lambda t: np.sin(omega * t),
        )
    integ = Integrator(model, "dynamic", dt, linear=linear, rtol=1e-10)
    from dolfinx import fem

    v0 = fem.Function(model.V)
    v0.interpolate(lambda X: omega * scale * _w_np(X, dim))
    integ.set_initial(None, v0)
    COMM.barrier()
    setup = time.perf_counter() - t0
    its = 0
    t1 = time.perf_counter()
    for _ in range(STEPS):
        its += integ.step().linear_iterations
    COMM.barrier()
    step = (time.perf_counter() - t1) / STEPS
    ue = float(np.sin(omega * integ.t)) * w
    dx = ufl.dx(domain=msh, metadata={"quadrature_degree": 6})
    num = COMM.allreduce(
        fem.assemble_scalar(fem.form(ufl.inner(integ.u - ue, integ.u - ue) * dx)), MPI.SUM
    )
    den = COMM.allreduce(fem.assemble_scalar(fem.form(ufl.inner(ue, ue) * dx)), MPI.SUM)
    dofs = model.num_dofs
    integ.destroy()
    return {
        "dim": dim,
        "linear": linear,
        "ranks": COMM.size,
        "N": N,
        "dofs": dofs,
        "setup_s": round(setup, 4),
        "step_s": round(step, 5),
        "its_per_step": round(its / STEPS, 1),
        "rel_L2_error": float(f"{np.sqrt(num / den):.3e}"),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="small meshes only (a smoke run)")
    p.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "timestep.csv")
    args = p.parse_args()
    sizes = {2: [16, 32, 64, 128, 256], 3: [4, 8, 12, 16, 20]}
    if args.quick:
        sizes = {2: [8, 16], 3: [3, 4]}
    stamp = time.strftime("%Y-%m-%d", time.gmtime())
    if COMM.rank == 0:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        new = not args.out.exists()
        f = open(args.out, "a", newline="")
        writer = csv.DictWriter(f, FIELDS)
        if new:
            writer.writeheader()
    for dim in (2, 3):
        for linear in ("direct", "iterative"):
            run_case(dim, sizes[dim][0], linear)  # warm-up: JIT-compile the forms, not timed
            for N in sizes[dim]:
                row = run_case(dim, N, linear)
                if COMM.rank == 0:
                    row.update(machine=machine(), date=stamp)
                    writer.writerow(row)
                    f.flush()
                    print(
                        f"{dim}D {linear:9s} ranks={row['ranks']} N={N:4d} dofs={row['dofs']:7d} "
                        f"setup={row['setup_s']:8.3f}s step={row['step_s']:8.4f}s "
                        f"its={row['its_per_step']:5.1f} err={row['rel_L2_error']:.3e}",
                        flush=True,
                    )
    if COMM.rank == 0:
        f.close()


if __name__ == "__main__":
    main()
