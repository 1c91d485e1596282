"""Two-bar impact: impact error and energy drift against the time step.

Set-up of :mod:`bonecontact.verification.impact` (L = 0.1 m, H = 0.01 m, ν = 0, E = 1 GPa,
ρ = 1000 kg/m³, c = 1000 m/s, v₀ = 1 m/s, gap 10.2 µm, frictionless dual mortar + PDAS,
MUMPS), run to t₀ + 1.1·2L/c, for N = 2L/(cΔt) steps per contact duration, with the
consistent mass matrix and with the chatter-removal option (``mass_redistribution``).

Columns: relative errors of the contact start (in units of 2L/c), duration and mean
force (impulse / duration); ``v_striker`` = striker velocity after the impact / v₀ (0
exact) next to the prediction √(2/(πN)) of the scheme's damping (tests/test_impact.py);
``energy_loss`` = 1 − E_end/E₀ (the scheme's dissipation; E never increases,
``max_increase`` is the largest step increase / E₀); ``defect`` = largest per-step
energy-balance defect / E₀; ``contact_work`` / E₀; ``force_peak`` = max F/F₀ and
``force_rms`` = RMS of F/F₀ − 1 over the middle of the contact (10 %–80 % of its
steps): the chatter measures; PDAS iterations per step; wall time of the time loop.

Usage:  python benchmarks/bench_impact.py [--quick] [--out benchmarks/results/impact.csv]
"""

import dolfinx_solver  # noqa: F401

import argparse
import csv
import platform
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np

from bonecontact.verification.impact import BarImpact, run_bar_impact


def run(nx: int, n: int, redistribute: bool) -> dict:
    p = BarImpact(nx=nx, ny=2, gap=1.02e-5)
    comm = MPI.COMM_WORLD
    comm.barrier()
    r = run_bar_impact(p, p.duration / n, integrator_options={"mass_redistribution": redistribute})
    err = r.errors()
    on = r.n_active > 0
    f = r.force[on] / p.force
    k = f.size
    mid = f[k // 10 : (8 * k) // 10]
    e0 = r.energy[0]
    return dict(
        mass="redistributed" if redistribute else "consistent",
        nx=nx,
        ny=p.ny,
        dofs=2 * 2 * (nx + 1) * (p.ny + 1),
        N=n,
        dt=p.duration / n,
        courant=p.c * p.duration / n / (p.length / nx),
        start_err=err["start"],
        duration_err=err["duration"],
        mean_force_err=err["mean_force"],
        v_striker=err["v_striker"],
        v_struck_err=err["v_struck"],
        predicted=float(np.sqrt(2 / (np.pi * n))),
        energy_loss=r.energy_loss,
        max_increase=r.energy_increase,
        defect=max(abs(b.defect) for b in r.balance) / e0,
        contact_work=sum(b.contact_work for b in r.balance) / e0,
        force_peak=float(f.max()),
        force_rms=float(np.sqrt(np.mean((mid - 1.0) ** 2))),
        episodes=r.episodes,
        pdas_per_step=r.pdas_iterations / r.time.size,
        steps=r.time.size,
        ranks=comm.size,
        wall_s=comm.allreduce(r.wall_time, op=MPI.MAX),
        setup_s=comm.allreduce(r.setup_time, op=MPI.MAX),
    )


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "impact.csv"))
    args = ap.parse_args()
    steps = [100, 400] if args.quick else [50, 100, 200, 400, 800, 1600]
    cases = [(40, n, False) for n in steps] + [(40, n, True) for n in steps]
    if not args.quick:
        cases += [(160, 400, False), (160, 1600, False), (160, 1600, True)]
    run(40, 20, False)  # warm-up: JIT-compiles the forms
    rows = [run(*c) for c in cases]
    if MPI.COMM_WORLD.rank == 0:
        stamp = time.strftime("%Y-%m-%d", time.gmtime())
        cpu = platform.processor() or "unknown CPU"
        for line in open("/proc/cpuinfo") if Path("/proc/cpuinfo").exists() else []:
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        with open(out, "w", newline="") as fh:
            w = csv.DictWriter(fh, list(rows[0]) + ["machine", "date"])
            w.writeheader()
            for r in rows:
                w.writerow({**r, "machine": cpu, "date": stamp})
        for r in rows:
            print(
                f"{r['mass']:13s} nx={r['nx']:3d} N={r['N']:5d} C={r['courant']:.2f} "
                f"dur={r['duration_err']:+.4f} F={r['mean_force_err']:+.4f} "
                f"v_s={r['v_striker']:.4f} (pred {r['predicted']:.4f}) "
                f"loss={r['energy_loss']:.4f} inc={r['max_increase']:.1e} "
                f"peak={r['force_peak']:.3f} rms={r['force_rms']:.1e} "
                f"pdas={r['pdas_per_step']:.2f} "
                f"wall={r['wall_s']:.2f}s"
            )


if __name__ == "__main__":
    main()
