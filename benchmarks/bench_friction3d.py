"""3D friction: semi-smooth Newton slip rows against the slip-direction fixed point.

Hemisphere (R = 10 mm) on a block of the same material (E = 2 GPa, ν = 0.3), pressed to
a ≈ 1 mm (step 1), then dragged sideways in 4 increments to Q/(μP) ≈ 0.48 (μ = 0.3,
semi-implicit Coulomb).  For each mesh and each 3D slip treatment (``slip_3d`` =
``"newton"``, the damped Hüeber–Stadler–Wohlmuth linearisation; ``"fixed_point"``, the
Aitken-accelerated slip-direction iteration): PDAS iterations per step, factorisations
and low-rank columns, wall time of the 5 contact steps, the stick-radius error against
Cattaneo–Mindlin c = a(1 − Q/(μP))^(1/3), and the traction difference to a reference
converged to ``direction_tol`` = 1e-11 (relative to μp₀).

Usage: python benchmarks/bench_friction3d.py [--quick]   (also under mpiexec -n K)
Writes benchmarks/results/friction3d.csv (and friction3d.md via summarize.py).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import argparse
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
from common import write_rows  # (benchmarks/ is the script directory)

from bonecontact.contact.friction import FrictionLaw
from bonecontact.contact.interface import build_interface
from bonecontact.contact.options import PDASOptions
from bonecontact.contact.pdas import ContactSolver
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics
from bonecontact.meshing import shapes as meshing
from bonecontact.verification.analytic import hertz_3d

COMM = MPI.COMM_WORLD
R, E, NU, MU, A_T, DRAG, INCR = 0.01, 2.0e9, 0.3, 0.3, 1.0e-3, 1.5e-5, 4
OUT = Path(__file__).parent / "results"


def _g(x) -> np.ndarray:
    return np.concatenate(COMM.allgather(np.asarray(x)))


def mindlin_3d(h: float, slip_3d: str, tol: float = 1e-6) -> tuple[dict, np.ndarray]:
    md = meshing.hertz_3d(COMM, h_contact=h, zone=1.5 * A_T)
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    m = Mechanics(
        md.mesh,
        {pg["sphere"]: Isotropic(E=E, nu=NU), pg["block"]: Isotropic(E=E, nu=NU)},
        md.cell_tags,
        md.facet_tags,
    )
    for c in range(3):
        m.add_dirichlet(m.facets(pg["block_bottom"]), c, 0.0)
    m.add_dirichlet(m.facets(pg["sphere_top"]), 1, -(A_T**2) / R)
    m.add_dirichlet(m.facets(pg["sphere_top"]), 2, 0.0)
    m.add_dirichlet(
        m.facets(pg["sphere_top"]), 0, DRAG, schedule=lambda t: min(max(t - 1.0, 0.0) / INCR, 1.0)
    )
    itf = build_interface(
        m.V, md.facet_tags, pg["sphere_contact"], pg["block_contact"], dirichlet_dofs=m.bc_dofs()
    )
    integ = Integrator(
        m,
        "static",
        1.0,
        contact=ContactSolver(
            m.V,
            [itf],
            PDASOptions.from_fields(
                friction=FrictionLaw("coulomb", coefficient=MU),
                max_iterations=100,
                slip_3d=slip_3d,
                direction_tol=tol,
            ),
        ),
    )
    its, fac, cols = [], 0, 0
    COMM.barrier()
    t0 = time.perf_counter()
    for _ in range(INCR + 1):
        integ.step()
        r = integ.last_contact
        its.append(r.iterations)
        fac += r.factorizations
        cols += r.columns
    COMM.barrier()
    wall = time.perf_counter() - t0
    X = _g(itf.coords)
    rr = np.hypot(X[:, 0], X[:, 2])
    p, q = _g(r.pressure[0]), _g(r.traction_t[0])
    qn = np.linalg.norm(q, axis=1)
    st = _g(r.status[0])
    P, Q = r.normal_force[0], r.tangential_force[0]
    a = hertz_3d.radius(P, R, E, NU, E, NU)
    p0 = hertz_3d.peak_pressure(P, R, E, NU, E, NU)
    ratio = Q / (MU * P)
    stick = st == "stick"
    d = MU * p[stick] - qn[stick]
    A, B = np.linalg.lstsq(np.c_[np.ones(stick.sum()), rr[stick] ** 2], d**2, rcond=None)[0]
    c_fit = np.sqrt(-A / B) if A > 0 > B else float("nan")
    row = {
        "h_mm": h * 1e3,
        "a_over_h": round(a / h, 1),
        "dofs": m.num_dofs,
        "ranks": COMM.size,
        "slip_3d": slip_3d,
        "Q_over_muP": round(ratio, 3),
        "err_c": float(f"{c_fit / (a * (1 - ratio) ** (1 / 3)) - 1:.2e}"),
        "pdas_its_per_step": " ".join(map(str, its)),
        "factorizations": fac,
        "columns": cols,
        "t_s": round(wall, 2),
    }
    integ.destroy()
    return row, q / (MU * p0)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    mindlin_3d(6e-4, "newton")  # warm-up (JIT), not recorded
    rows = []
    for h in [4e-4] if args.quick else [4e-4, 3e-4, 2.2e-4]:
        _, ref = mindlin_3d(h, "newton", tol=1e-11)
        for slip_3d in ("newton", "fixed_point"):
            row, qn = mindlin_3d(h, slip_3d)
            row["q_diff_to_ref"] = float(f"{np.abs(qn - ref).max():.2e}")
            rows.append(row)
            if COMM.rank == 0:
                print("friction3d", row, flush=True)
    write_rows(OUT, "friction3d", rows)


if __name__ == "__main__":
    main()
