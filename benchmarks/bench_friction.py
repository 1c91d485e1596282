"""Friction: Cattaneo–Mindlin stick-zone error against wall time, PDAS iterations
against μ and mesh size, and the semi-implicit Coulomb law against Algorithm FP.

Plane-strain half cylinder (R = 10 mm) on a block of the same material (E = 2 GPa,
ν = 0.3, so the tangential load leaves the pressure unchanged), pressed to a/R = 0.05
(step 1), then dragged sideways in 4 equal increments to Q/(μP) ≈ 0.55.  Errors: the
stick half-width c (least-squares fit of (μp − q)² = A + Bx² over the stick nodes,
c² = −A/B) against c = a√(1 − Q/(μP)); the slip-zone traction against μp (max over slip
nodes, relative to μp₀); for the Coulomb variants also the traction difference to a
tightly converged fixed-point reference (fp_tol = 1e-12).  Time = all 5 contact steps
(MUMPS, low-rank PDAS).

Usage: python benchmarks/bench_friction.py [--quick]   (also under mpiexec -n K)
Writes benchmarks/results/friction.csv (and friction.md via summarize.py).
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
from bonecontact.verification.analytic import contact_modulus, hertz_2d

COMM = MPI.COMM_WORLD
R, A_REF, E, NU = 0.01, 5.0e-4, 2.0e9, 0.3
DRAG_PER_MU = 1.2e-5 / 0.3  # drag giving Q/(μP) ≈ 0.55
OUT = Path(__file__).parent / "results"


def _g(x) -> np.ndarray:
    return np.concatenate(COMM.allgather(np.asarray(x)))


def mindlin(
    a_over_h: float, mu: float, update: str, increments: int = 4, fp_tol: float = 1e-8
) -> dict:
    h = A_REF / a_over_h
    delta = (
        2.5 * hertz_2d.load_for_half_width(A_REF, R, E, NU, E, NU) / contact_modulus(E, NU, E, NU)
    )
    md = meshing.hertz_2d(COMM, h_contact=h, zone=1.5 * A_REF, h_far=2e-3)
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    m = Mechanics(
        md.mesh,
        {pg["cylinder"]: Isotropic(E=E, nu=NU), pg["block"]: Isotropic(E=E, nu=NU)},
        md.cell_tags,
        md.facet_tags,
    )
    for c in (0, 1):
        m.add_dirichlet(m.facets(pg["block_bottom"]), c, 0.0)
    m.add_dirichlet(m.facets(pg["cyl_top"]), 1, -delta)
    m.add_dirichlet(
        m.facets(pg["cyl_top"]),
        0,
        DRAG_PER_MU * mu,
        schedule=lambda t: min(max(t - 1.0, 0.0) / increments, 1.0),
    )
    itf = build_interface(
        m.V, md.facet_tags, pg["cyl_contact"], pg["block_contact"], dirichlet_dofs=m.bc_dofs()
    )
    integ = Integrator(
        m,
        "static",
        1.0,
        contact=ContactSolver(
            m.V,
            [itf],
            PDASOptions.from_fields(
                friction=FrictionLaw("coulomb", coefficient=mu, update=update),
                fp_tol=fp_tol,
                max_iterations=200,
            ),
        ),
    )
    its, outer = [], []
    COMM.barrier()
    t0 = time.perf_counter()
    for _ in range(increments + 1):
        integ.step()
        its.append(integ.last_contact.iterations)
        outer.append(integ.last_contact.bound_updates)
    COMM.barrier()
    wall = time.perf_counter() - t0
    r = integ.last_contact
    x = _g(itf.coords[:, 0])
    o = np.argsort(x)
    x, p, q, st = (
        x[o],
        _g(r.pressure[0])[o],
        np.abs(_g(r.traction_t[0][:, 0])[o]),
        _g(r.status[0])[o],
    )
    P, Q = r.normal_force[0], r.tangential_force[0]
    a = hertz_2d.half_width(P, R, E, NU, E, NU)
    p0 = hertz_2d.peak_pressure(P, R, E, NU, E, NU)
    ratio = Q / (mu * P)
    stick, slip = st == "stick", st == "slip"
    d = mu * p[stick] - q[stick]
    A, B = np.linalg.lstsq(np.c_[np.ones(stick.sum()), x[stick] ** 2], d**2, rcond=None)[0]
    c_fit = np.sqrt(-A / B) if A > 0 > B else float("nan")
    c_ref = a * np.sqrt(max(1.0 - ratio, 0.0))
    row = {
        "a_over_h": a_over_h,
        "dofs": m.num_dofs,
        "ranks": COMM.size,
        "mu": mu,
        "update": update,
        "Q_over_muP": round(ratio, 3),
        "err_c": float(f"{c_fit / c_ref - 1:.2e}"),
        "err_slip_traction": float(f"{np.abs(q[slip] - mu * p[slip]).max() / (mu * p0):.2e}")
        if slip.any()
        else 0.0,
        "pdas_its_per_step": " ".join(map(str, its)),
        "bound_updates": int(sum(outer)),
        "t_s": round(wall, 3),
    }
    integ.destroy()
    return row, q / (mu * p0)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    mindlin(10, 0.3, "previous_step")  # warm-up (JIT), not recorded
    rows = []
    sizes = [10, 20] if args.quick else [10, 20, 40]
    mus = [0.3] if args.quick else [0.1, 0.3, 0.6, 1.0]
    for k in sizes:
        for mu in mus if k == 20 else [0.3]:
            ref = None
            for update in ("fixed_point", "previous_step"):
                row, qn = mindlin(k, mu, update)
                if update == "fixed_point":
                    _, ref = mindlin(k, mu, "fixed_point", fp_tol=1e-12)
                row["q_diff_to_fp_ref"] = float(f"{np.abs(qn - ref).max():.2e}")
                rows.append(row)
                if COMM.rank == 0:
                    print("friction", row, flush=True)
    write_rows(OUT, "friction", rows, extra_columns={"q_diff_to_fp_ref": ""})


if __name__ == "__main__":
    main()
