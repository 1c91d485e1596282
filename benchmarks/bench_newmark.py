"""Error against wall time of the two time schemes (backward-difference,
stabilized-newmark) on three problems with exact or analytic references, for Δt
halved three or four times.

* ``bar``: the two-bar impact of :mod:`bonecontact.verification.impact` (40 × 2 × 2
  triangles per bar; N = 2L/(cΔt) = 50 … 400): errors of the contact time, the mean
  force (impulse / duration) and the velocity the striker keeps (/v₀); ``error`` is the
  largest of the three.
* ``vibration``: the lowest mode of the clamped strip of
  :mod:`bonecontact.verification.vibration` over 100 periods, 10 … 80 steps per period:
  ``amplitude_err`` = 1 − max|q| over the last period, ``period_err`` = measured /
  exact semi-discrete period − 1; ``error`` the larger.
* ``sphere``: the hemisphere impact of :mod:`bonecontact.verification.sphere_impact`
  (reduced mesh), Δt = t_c/25 … t_c/100 (t_c/200 without ``--quick``): errors of the
  contact time and the peak force against Hertz, and the energy not returned;
  ``error`` the largest.
* ``knee``: the 3D knee gait of ``data/scenes/knee3d_gait.toml`` (7083 dofs, Coulomb
  μ = 0.1, the stance load of Bergmann et al. 2014) over its first 0.32 s (heel strike
  to past the first peak), Δt = 40 ms halved four times (to 2.5 ms), against a
  reference run with ``stabilized-newmark`` at Δt = 1.25 ms: ``error`` = the largest
  difference of the strain energy at the coarse times (multiples of 40 ms) / its
  largest reference value (a state quantity, at tⁿ for both schemes); ``force_err`` the
  same for the total normal contact force (a mean over the step for the Newmark scheme,
  the end-of-step value for the backward differences).  ``wall_s``: the run's
  ``time_stepping`` phase.

Columns: case, scheme, level (steps per reference time), dt, steps, error, the case's
error columns (empty where they do not apply), dofs, ranks, wall_s (time loop, set-up
excluded; max over ranks), machine, date.  Timings on a shared machine are indicative.

Usage:  python benchmarks/bench_newmark.py [--quick] [--cases bar,vibration,sphere,knee]
        [--out benchmarks/results/newmark.csv]
"""

import dolfinx_solver  # noqa: F401

import argparse
import csv
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
from common import machine

from bonecontact.mechanics.newmark import SCHEMES
from bonecontact.verification import vibration
from bonecontact.verification.impact import BarImpact, run_bar_impact
from bonecontact.verification.sphere_impact import SphereImpact, run_sphere_impact

COMM = MPI.COMM_WORLD
COLUMNS = (
    "case scheme level dt steps error duration_err force_err v_striker amplitude_err "
    "period_err energy_lost rebound dofs ranks wall_s"
).split()


def bar(scheme: str, n: int) -> dict:
    p = BarImpact(nx=40, ny=2, gap=1.02e-5)
    COMM.barrier()
    r = run_bar_impact(p, p.duration / n, scheme=scheme)
    err = r.errors()
    e = {k: err[k] for k in ("duration", "mean_force", "v_striker")}
    return dict(
        case="bar",
        scheme=scheme,
        level=n,
        dt=p.duration / n,
        steps=r.time.size,
        error=max(abs(v) for v in e.values()),
        duration_err=e["duration"],
        force_err=e["mean_force"],
        v_striker=e["v_striker"],
        energy_lost=r.energy_loss,
        dofs=2 * 2 * (p.nx + 1) * (p.ny + 1),
        wall_s=COMM.allreduce(r.wall_time, op=MPI.MAX),
    )


_MODE: list = []


def vib(scheme: str, per_period: int) -> dict:
    if not _MODE:
        m = vibration.cantilever(COMM)
        _MODE.extend([m, *vibration.lowest_mode(m)])
    m, phi, omega = _MODE
    COMM.barrier()
    t0 = time.perf_counter()
    t, q, _ = vibration.modal_history(scheme, m, phi, omega, per_period, 100)
    wall = time.perf_counter() - t0
    amp = 1.0 - float(np.abs(q[-per_period - 1 :]).max())
    period = vibration.crossing_period(t, q) * omega / (2.0 * np.pi) - 1.0
    return dict(
        case="vibration",
        scheme=scheme,
        level=per_period,
        dt=float(t[1]),
        steps=q.size - 1,
        error=max(abs(amp), abs(period)) if np.isfinite(period) else abs(amp),
        amplitude_err=amp,
        period_err=period,
        dofs=m.V.dofmap.index_map.size_global * 2,
        wall_s=COMM.allreduce(wall, op=MPI.MAX),
    )


def sphere(scheme: str, n: int, p: SphereImpact) -> dict:
    COMM.barrier()
    r = run_sphere_impact(p, p.contact_time / n, scheme=scheme)
    err = r.errors()
    return dict(
        case="sphere",
        scheme=scheme,
        level=n,
        dt=r.dt,
        steps=r.steps,
        error=max(abs(v) for v in err.values()),
        duration_err=err["contact_time"],
        force_err=err["peak_force"],
        energy_lost=err["energy_lost"],
        rebound=r.rebound,
        dofs=r.dofs,
        wall_s=COMM.allreduce(r.wall_time, op=MPI.MAX),
    )


KNEE_SCENE = Path(__file__).resolve().parents[1] / "data" / "scenes" / "knee3d_gait.toml"
KNEE_T_END, KNEE_COARSE = 0.32, 0.04


def _knee_run(scheme: str, dt: float, work: Path) -> tuple[dict, float, int]:
    """Run the knee gait scene with ``scheme`` and ``dt`` up to KNEE_T_END: (history
    columns, wall time of the time loop, dofs)."""
    import re

    from bonecontact.runners import run_scene
    from bonecontact.scene import load_scene

    name = f"knee_{scheme}_{dt:.6f}"
    toml = work / f"{name}.toml"
    if COMM.rank == 0:
        text = KNEE_SCENE.read_text()
        mesh = KNEE_SCENE.parent / "knee3d_gait.msh"
        text = text.replace('mesh = "knee3d_gait.msh"', f'mesh = "{mesh}"')
        text = re.sub(r"(?m)^scheme = .*$", f'scheme = "{scheme}"', text)
        text = re.sub(r"(?m)^t_end = .*$", f"t_end = {KNEE_T_END}", text)
        text = re.sub(r"(?m)^dt = .*$", f"dt = {dt!r}", text)
        toml.write_text(text)
    COMM.barrier()
    res = run_scene(load_scene(toml), COMM, output=work / name, progress=False)
    if res.status != "converged":
        raise RuntimeError(f"knee {scheme} dt={dt}: {res.summary.get('message')}")
    h = np.genfromtxt(work / name / "history.csv", delimiter=",", names=True, dtype=None,
                      encoding="utf-8") if COMM.rank == 0 else None  # fmt: skip
    h = COMM.bcast(h, root=0)
    cols = {k: np.asarray(h[k], dtype=float) for k in ("time", "strain_energy", "normal_force")}
    return cols, float(res.summary["phases_s"]["time_stepping"]), int(res.summary["dofs"])


def knee_rows(levels: int = 5) -> list[dict]:
    """The knee gait case (module docstring): the reference, then both schemes at Δt =
    40 ms / 2^k, k < ``levels``."""
    import tempfile

    work = Path(tempfile.mkdtemp(prefix="bench_knee_")) if COMM.rank == 0 else None
    work = Path(COMM.bcast(str(work) if work else None, root=0))
    ref, _, _ = _knee_run("stabilized-newmark", KNEE_COARSE / 2**levels, work)
    grid = np.arange(1, round(KNEE_T_END / KNEE_COARSE) + 1) * KNEE_COARSE

    def at(h: dict, key: str) -> np.ndarray:
        return np.interp(grid, h["time"], h[key])

    rows = []
    for k in range(levels):
        dt = KNEE_COARSE / 2**k
        for scheme in SCHEMES:
            try:
                h, wall, dofs = _knee_run(scheme, dt, work)
            except RuntimeError as exc:  # (a PDAS failure is a result of the table)
                if COMM.rank == 0:
                    print(f"knee {scheme} dt={dt}: failed: {exc}".splitlines()[0], flush=True)
                continue
            err = {
                key: float(np.abs(at(h, key) - at(ref, key)).max() / np.abs(at(ref, key)).max())
                for key in ("strain_energy", "normal_force")
            }
            rows.append(
                dict(case="knee", scheme=scheme, level=2**k, dt=dt, steps=h["time"].size - 1,
                     error=err["strain_energy"], force_err=err["normal_force"], dofs=dofs,
                     wall_s=wall, ranks=COMM.size)
            )  # fmt: skip
            if COMM.rank == 0:
                e, f = err["strain_energy"], err["normal_force"]
                print(f"knee {scheme:19s} dt={dt:.5f} error={e:.4f} force_err={f:.4f} "
                      f"wall={wall:.1f}s", flush=True)  # fmt: skip
    return rows


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--cases", default="bar,vibration,sphere")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "newmark.csv"))
    args = ap.parse_args()
    cases = args.cases.split(",")
    runs = []
    if "bar" in cases:
        runs += [(bar, n) for n in (50, 100, 200, 400)]
    if "vibration" in cases:
        runs += [(vib, n) for n in (10, 20, 40, 80)]
    if "sphere" in cases:
        p = SphereImpact(h_contact=5e-4, h_far=4e-3) if args.quick else SphereImpact()
        levels = (25, 50, 100) if args.quick else (25, 50, 100, 200)
        runs += [(lambda s, n, p=p: sphere(s, n, p), n) for n in levels]
    rows = []
    if "knee" in cases:
        rows += [{c: "" for c in COLUMNS} | r for r in knee_rows()]
    for f, n in runs:
        for scheme in SCHEMES:
            row = {c: "" for c in COLUMNS} | f(scheme, n) | {"ranks": COMM.size}
            rows.append(row)
            if COMM.rank == 0:
                print(
                    f"{row['case']:9s} {scheme:19s} level={n:4d} error={row['error']:.4f} "
                    f"wall={row['wall_s']:.2f}s",
                    flush=True,
                )
    if COMM.rank == 0:
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        stamp, cpu = time.strftime("%Y-%m-%d", time.gmtime()), machine()
        with open(out, "w", newline="") as fh:
            w = csv.DictWriter(fh, [*COLUMNS, "machine", "date"])
            w.writeheader()
            for r in rows:
                w.writerow({**r, "machine": cpu, "date": stamp})


if __name__ == "__main__":
    main()
