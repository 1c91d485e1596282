"""3D crack growth in a scene: cost per increment against the front's K error.

A scene (`bonecontact run` path, runners.front_growth3d) with a penny crack of radius
a = 1 mm at the centre of the block [−4a, 4a]³ (E = 17 GPa, ν = 0.3, rollers on xmin,
ymin, zmin, σ = 1 MPa on top), normal to the load, front size h_f = a/n (n = 8, 12, 16;
below 8 the polygon's edges cannot hold the 6h_f integration domain; grading 0.12),
grown by ``propagate`` in 3 advances of Δa = 0.1a (K_Ic far below every K).  Each
increment re-meshes the block with the grown crack (gmsh), solves the crack-face contact
problem (PDAS, dual mortar, MUMPS), evaluates K at the front's mid-edges and advances the
front (σ₁′ criterion).

Per increment (from ``increment<k>/summary.json`` and fracture.csv):

* dofs, PDAS iterations, wall time of the increment's mesh (re-mesh + read), contact
  solve and all its phases (the differences of the run's phases so far, which each
  increment's summary.json holds); the K evaluation and advance of the whole run from
  summary.json's ``fracture`` phase, shared equally by the solves; the peak resident
  memory of the run so far (per rank);
* **the reference**: ONE plain DOLFINx ``LinearProblem`` on the same mesh (read back from
  the increment's ``fields.xdmf``; the open crack, whose faces carry no load, the same
  supports and traction), MUMPS with PETSc's standard options, timed from the form
  assembly to the solution; the ratios of the increment's contact solve and of the whole
  increment to it;
* **error**: the mid-edge mean of K_I against Sneddon's penny, 2σ√(r/π), at the mean
  vertex radius r of the front polygon (the polygon with N = ⌊2πr/(6h_f)⌋ vertices on the
  circle and the block of half-width 4a both raise K above the infinite body's circle;
  the difference falls with n as N grows), and the vertex radius spread (max − min)/mean
  (mode I: the front must stay circular).

Usage: python benchmarks/bench_crack_growth3d.py [--quick]   (also under mpiexec -n K)
Writes benchmarks/results/crack_growth3d.csv.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import argparse
import csv
import json
import math
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
import ufl
from bench_crack_scene3d import block_mesh  # the same block (benchmarks/ is the script directory)
from common import machine, write_rows
from dolfinx import fem, io, mesh
from dolfinx.fem.petsc import LinearProblem

from bonecontact.runners.dispatch import run_scene
from bonecontact.scene import load_scene
from bonecontact.verification.problems import crack_block_scene

COMM = MPI.COMM_WORLD
OUT = Path(__file__).resolve().parent / "results"
A, W, E, NU, SIGMA, DA, STEPS = 1.0e-3, 4.0e-3, 17.0e9, 0.3, 1.0e6, 0.1, 3


def growth_scene(n: int) -> str:
    """The penny scene of front a/n, grown by ``STEPS`` advances of ``DA``·a."""
    geometry = f"centre = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = {A!r}"
    text = crack_block_scene("block.msh", geometry, E=E, nu=NU, sigma=SIGMA, h=A / n, points=1)
    text = text.replace("sigma_t = 133e6", "sigma_t = 133e6\nK_Ic = 1e4")
    growth = f"propagate = true\nincrement = {DA * A!r}\nmax_increments = {STEPS}"
    return text.replace("tip_grading = 0.12", f"tip_grading = 0.12\n{growth}")


def one_linear_solve(xdmf: Path) -> float:
    """Wall time of one plain ``LinearProblem`` (MUMPS) of the block on ``xdmf``'s mesh:
    rollers on xmin, ymin, zmin, σ on top, the crack faces free (collective)."""
    with io.XDMFFile(COMM, str(xdmf), "r") as f:
        msh = f.read_mesh(name="mesh")
    V = fem.functionspace(msh, ("Lagrange", 1, (3,)))
    fdim = msh.topology.dim - 1
    bcs = []
    for axis in range(3):
        facets = mesh.locate_entities_boundary(
            msh, fdim, lambda x, k=axis: np.isclose(x[k], -W, atol=1e-9 * W)
        )
        dofs = fem.locate_dofs_topological(V.sub(axis), fdim, facets)
        bcs.append(fem.dirichletbc(0.0, dofs, V.sub(axis)))
    top = mesh.locate_entities_boundary(msh, fdim, lambda x: np.isclose(x[2], W, atol=1e-9 * W))
    tags = mesh.meshtags(msh, fdim, top, np.full(top.size, 1, dtype=np.int32))
    ds = ufl.Measure("ds", domain=msh, subdomain_data=tags)
    mu, lmbda = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps = lambda w: ufl.sym(ufl.grad(w))  # noqa: E731
    a = ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx
    L = ufl.dot(fem.Constant(msh, np.array([0.0, 0.0, SIGMA])), v) * ds(1)
    opts = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}
    COMM.barrier()
    t0 = time.perf_counter()
    problem = LinearProblem(a, L, bcs=bcs, petsc_options=opts, petsc_options_prefix="bench_ref_")
    problem.solve()
    COMM.barrier()
    return time.perf_counter() - t0


def k_errors(table: Path, radii: list[float]) -> list[tuple[float, float, int]]:
    """Per increment: (mean K_I of the mid-edges / Sneddon at the mean vertex radius − 1,
    mid-edge count).  Rank 0 only."""
    with open(table) as f:
        rows = list(csv.DictReader(f))
    out = []
    for k, r in enumerate(radii):
        kI = np.array([float(x["K_I"]) for x in rows if int(x["increment"]) == k])
        out.append((float(kI.mean() / (2 * SIGMA * math.sqrt(r / math.pi)) - 1), kI.size))
    return out


def spread(front: list[list[float]]) -> float:
    """(max − min)/mean of the vertex radii about the vertices' centroid."""
    V = np.asarray(front)
    r = np.linalg.norm(V[:, :2] - V[:, :2].mean(axis=0), axis=1)
    return float((r.max() - r.min()) / r.mean())


def increment_phases(now: dict[str, float], before: dict[str, float]) -> dict[str, float]:
    """The phases of one increment: an increment's summary.json holds the run's phases
    so far (``contact_solve`` is part of ``time_stepping``)."""
    return {key: v - before.get(key, 0.0) for key, v in now.items()}


def level(directory: Path, n: int) -> list[dict]:
    """Grow the penny at front a/n; one row per increment."""
    d = directory / f"n{n}"
    if COMM.rank == 0:
        d.mkdir(parents=True, exist_ok=True)
        (d / "block.msh").symlink_to(directory / "block.msh")
        (d / "scene.toml").write_text(growth_scene(n))
    COMM.barrier()
    t0 = time.perf_counter()
    res = run_scene(load_scene(d / "scene.toml"), COMM, output=d / "out", progress=False)
    wall = time.perf_counter() - t0
    growth = res.summary["fracture"]["growth"]
    radii = [h["mean_radius"] for h in growth["history"]]
    table = d / "out" / "fracture.csv"
    errs = k_errors(table, radii) if COMM.rank == 0 else [(0.0, 0)] * len(radii)
    k_share = res.summary["phases_s"].get("fracture", 0.0) / len(radii)
    rows, before = [], {}
    for k, r in enumerate(radii):
        inc = d / "out" / f"increment{k}"
        s = json.loads((inc / "summary.json").read_text())
        ph = increment_phases(s["phases_s"], before)
        before = s["phases_s"]
        t_ref = one_linear_solve(inc / "fields.xdmf")
        t_inc = sum(v for key, v in ph.items() if key != "contact_solve") + k_share
        rows.append(
            {
                "h_front/a": f"1/{n}",
                "increment": k,
                "ranks": COMM.size,
                "dofs": s["dofs"],
                "front_points": errs[k][1],
                "radius/a": f"{r / A:.4f}",
                "err_K_I_vs_sneddon_%": f"{100 * errs[k][0]:.2f}",
                "pdas_its": s["contact"]["pdas_iterations"]["total"],
                "t_mesh_s": f"{ph.get('mesh_read', 0.0):.2f}",
                "t_contact_solve_s": f"{ph.get('contact_solve', 0.0):.2f}",
                "t_K_advance_s": f"{k_share:.2f}",
                "t_increment_s": f"{t_inc:.2f}",
                "t_one_linear_solve_s": f"{t_ref:.3f}",
                "solve/linear": f"{ph.get('contact_solve', 0.0) / t_ref:.2f}",
                "increment/linear": f"{t_inc / t_ref:.1f}",
                "peak_MiB_per_rank": f"{s['peak_memory_mb']['max_rank']:.0f}",
            }
        )
    rows[-1]["final_spread_%"] = f"{100 * spread(res.summary['fracture']['crack']['front']):.2f}"
    rows[-1]["t_run_s"] = f"{wall:.1f}"
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer refinement levels")
    args = parser.parse_args()
    tmp = COMM.bcast(tempfile.mkdtemp(prefix="bench_growth3d_") if COMM.rank == 0 else None)
    directory = Path(tmp)
    block_mesh(directory / "block.msh")
    rows = []
    for n in (8, 12) if args.quick else (8, 12, 16):
        rows += level(directory, n)
        if COMM.rank == 0:
            for r in rows[-STEPS - 1 :]:
                print(r, flush=True)
    extra = {"final_spread_%": "", "t_run_s": "", "machine": machine()}
    write_rows(OUT, "crack_growth3d", rows, extra)


if __name__ == "__main__":
    main()
