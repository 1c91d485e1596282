"""3D crack scene: K_I, K_II, K_III error of an inclined penny crack against dofs and time.

A scene (`bonecontact run` path, runners.cracks3d) with a penny crack of radius a at the
centre of the block [−4a, 4a]³ (E = 17 GPa, ν = 0.3), its normal at β = 30° to the uniaxial
stress σ (traction on the top, rollers on three faces), front size h_f = a/n, grading
0.12, 8 front points.  References (infinite body): K_I = 2σcos²β√(a/π); Kassir–Sih
K_II = 4τ√(a/π)/(2 − ν)·cos ω, K_III = (1 − ν)·that·sin ω (τ = σ sinβ cosβ); the errors
are relative to the largest value of each mode.  Wall time of the phases of the run
(re-meshing with the crack, mortar set-up + contact solve, K at the 8 points) from
summary.json.

Usage: python benchmarks/bench_crack_scene3d.py [--quick]   (also under mpiexec -n K)
Writes benchmarks/results/crack_scene3d.csv.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import argparse
import csv
import math
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

import gmsh
import numpy as np
from common import machine, write_rows  # (benchmarks/ is the script directory)

from bonecontact.runners.dispatch import run_scene
from bonecontact.scene import load_scene
from bonecontact.verification.problems import crack_block_model, crack_block_scene

COMM = MPI.COMM_WORLD
OUT = Path(__file__).resolve().parent / "results"
A, W, E, NU, SIGMA = 1.0e-3, 4.0e-3, 17.0e9, 0.3, 1.0e6
BETA = math.radians(30.0)


def block_mesh(path: Path) -> None:
    """The scene's block [−W, W]³ (``crack_block_model``), meshed on rank 0."""
    if COMM.rank == 0:
        gmsh.initialize()
        gmsh.option.setNumber("General.Terminal", 0)
        crack_block_model(W)
        gmsh.model.mesh.generate(3)
        gmsh.write(str(path))
        gmsh.finalize()
    COMM.barrier()


def errors(path: Path) -> dict[str, float]:
    """Largest error of each mode relative to its largest reference value (%)."""
    with open(path) as f:
        rows = list(csv.DictReader(f))
    phi = np.radians([float(r["phi_deg"]) for r in rows])
    k = {m: np.array([float(r[m]) for r in rows]) for m in ("K_I", "K_II", "K_III", "K_I_dc")}
    tau = SIGMA * math.sin(BETA) * math.cos(BETA)
    k1 = 2 * SIGMA * math.cos(BETA) ** 2 * math.sqrt(A / math.pi)
    k2 = 4 * tau * math.sqrt(A / math.pi) / (2 - NU)
    omega = phi - math.pi / 2  # the shear direction is the crack's v axis (φ = 90°)
    return {
        "K_I": 100 * float(np.max(np.abs(k["K_I"] / k1 - 1))),
        "K_II": 100 * float(np.max(np.abs(k["K_II"] - k2 * np.cos(omega)))) / k2,
        "K_III": 100
        * float(np.max(np.abs(np.abs(k["K_III"]) - (1 - NU) * k2 * np.abs(np.sin(omega)))))
        / ((1 - NU) * k2),
        "dc_K_I": 100 * float(np.mean(k["K_I_dc"] / k1 - 1)),
    }


def level(directory: Path, n: int) -> dict:
    d = directory / f"n{n}"
    if COMM.rank == 0:
        d.mkdir(parents=True, exist_ok=True)
        (d / "block.msh").symlink_to(directory / "block.msh")
        shape = f"centre = [0.0, 0.0, 0.0]\nnormal = [{math.sin(BETA)}, 0.0, {math.cos(BETA)}]"
        text = crack_block_scene(
            "block.msh", f"{shape}\nradius = {A}", E=E, nu=NU, sigma=SIGMA, h=A / n
        )
        (d / "scene.toml").write_text(text)
    COMM.barrier()
    t0 = time.perf_counter()
    res = run_scene(load_scene(d / "scene.toml"), COMM, output=d / "out", progress=False)
    wall = time.perf_counter() - t0
    err = errors(d / "out" / "fracture.csv") if COMM.rank == 0 else {}
    ph = res.summary["phases_s"]
    return {
        "h_front/a": f"1/{n}",
        "dofs": res.summary["dofs"],
        "ranks": COMM.size,
        **{f"err_{m}_%": f"{v:.2f}" for m, v in err.items()},
        "t_mesh_s": f"{ph.get('mesh_read', 0.0):.2f}",
        "t_solve_s": f"{ph.get('solver_setup', 0.0) + ph.get('time_stepping', 0.0):.2f}",
        "t_K_8_points_s": f"{ph.get('fracture', 0.0):.2f}",
        "t_run_s": f"{wall:.2f}",
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer refinement levels")
    args = parser.parse_args()
    tmp = COMM.bcast(tempfile.mkdtemp(prefix="bench_crack3d_") if COMM.rank == 0 else None)
    directory = Path(tmp)
    block_mesh(directory / "block.msh")
    rows = [level(directory, n) for n in ((6, 8) if args.quick else (6, 8, 12, 16))]
    if COMM.rank == 0:
        for r in rows:
            print(r)
    write_rows(OUT, "crack_scene3d", rows, {"machine": machine()})


if __name__ == "__main__":
    main()
