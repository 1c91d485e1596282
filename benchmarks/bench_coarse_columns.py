"""How many coarse unknowns the first GAMG level of the 3D contact system needs (issue 28).

GAMG gives every aggregate as many coarse unknowns as the near-nullspace has vectors:
twelve (six rigid modes per body) for the condensed contact system, although inside one
body only six of them are independent.  This script measures what a prolongator with
the columns of each aggregate compressed to the rank of the near-nullspace there would
save: the load-driven 3D Hertz problem of ``bench_contact3d.py`` is solved once
(iterative, rtol 1e-8); then, on the matrix ``B`` of the settled set and the first level
of its GAMG hierarchy (``P``, coarse operator ``Pᵀ B P``), each aggregate's block of the
near-nullspace is reduced by an SVD to its rank (singular values above 1e-8 of the
largest), giving ``P_c`` and ``P_cᵀ B P_c``.  Both two-level methods (Chebyshev/Jacobi, two
steps, on the fine level as GAMG's; the coarse level by LU; V-cycle) then precondition
CG on the same random right-hand side to rtol 1e-8: iterations, operations of the set-up
(the coarse LU) and of the solve (per iteration: the fine level's products and the coarse
triangular solves).

Serial only (a study, not a solver).  Usage::

    python benchmarks/bench_coarse_columns.py --sizes 25k,65k

Writes ``results/coarse_columns_<size>.json``.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import argparse
import json
import time
from pathlib import Path

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import scipy.sparse as sp
from bench_contact3d import SIZES
from common import machine

from bonecontact.verification.load_driven import sphere_on_block_3d

OUT = Path(__file__).parent / "results"


def to_scipy(M: PETSc.Mat) -> sp.csr_matrix:
    ia, ja, a = M.getValuesCSR()
    return sp.csr_matrix((a, ja, ia), shape=M.getSize())


def to_petsc(M: sp.spmatrix) -> PETSc.Mat:
    M = M.tocsr()
    out = PETSc.Mat().createAIJ(size=M.shape, csr=(M.indptr, M.indices, M.data), comm=MPI.COMM_SELF)
    out.assemble()
    return out


def compressed_prolongator(P: sp.csr_matrix, Z: np.ndarray, width: int) -> tuple:
    """``P_c`` (each aggregate's ``width`` columns replaced by the left singular vectors of
    the near-nullspace block ``Z[rows]`` above 1e-8 of its largest) and the ranks."""
    Pc = P.tocsc()
    rows_l, cols_l, vals_l, ranks, col = [], [], [], [], 0
    for c in range(P.shape[1] // width):
        rows = np.unique(Pc[:, width * c : width * (c + 1)].indices)
        U, s, _ = np.linalg.svd(Z[rows, :], full_matrices=False)
        r = int((s > 1e-8 * s[0]).sum())
        ranks.append(r)
        for j in range(r):
            rows_l.append(rows)
            cols_l.append(np.full(len(rows), col + j))
            vals_l.append(U[:, j])
        col += r
    data = (np.concatenate(vals_l), (np.concatenate(rows_l), np.concatenate(cols_l)))
    return sp.csr_matrix(data, shape=(P.shape[0], col)), np.array(ranks)


def two_level(B: PETSc.Mat, P: PETSc.Mat, Ac: PETSc.Mat) -> dict:
    """CG with a two-level V-cycle (fine: 2 Chebyshev/Jacobi steps; coarse: LU), rtol 1e-8,
    on a fixed random right-hand side: iterations, Mflop of the set-up and of the solve."""
    ksp = PETSc.KSP().create(MPI.COMM_SELF)
    ksp.setOperators(B)
    ksp.setType("cg")
    ksp.setTolerances(rtol=1e-8, max_it=500)
    pc = ksp.getPC()
    pc.setType("mg")
    pc.setMGLevels(2)
    pc.setMGInterpolation(1, P)
    coarse = pc.getMGCoarseSolve()
    coarse.setType("preonly")
    coarse.getPC().setType("lu")
    coarse.setOperators(Ac)
    smooth = pc.getMGSmoother(1)
    smooth.setType("chebyshev")
    smooth.getPC().setType("jacobi")
    smooth.setTolerances(max_it=2)
    smooth.setOperators(B)
    pc.setMGCycleType(PETSc.PC.MGCycleType.V)
    b, x = B.createVecLeft(), B.createVecRight()
    b.setArray(np.random.default_rng(0).standard_normal(b.getLocalSize()))
    x.set(0.0)
    f0 = PETSc.Log.getFlops()
    ksp.setUp()  # the coarse LU
    f1, t0 = PETSc.Log.getFlops(), time.perf_counter()
    ksp.solve(b, x)
    its = ksp.getIterationNumber()
    out = {
        "its": its,
        "reason": ksp.getConvergedReason(),
        "setup_mflop": round((f1 - f0) / 1e6, 1),
        "solve_mflop": round((PETSc.Log.getFlops() - f1) / 1e6, 1),
        "mflop_per_it": round((PETSc.Log.getFlops() - f1) / 1e6 / max(its, 1), 2),
        "solve_s": round(time.perf_counter() - t0, 2),
    }
    ksp.destroy()
    return out


def study(label: str, mesh_dir: Path) -> dict:
    """The measurements of one size (module docstring)."""
    h, h_far, mesher = SIZES[label]
    pb = sphere_on_block_3d(
        MPI.COMM_SELF, h, h_far=h_far, linear="iterative", rtol=1e-8,
        mesh_file=mesh_dir / f"contact3d_{label}_{mesher}.msh", algorithm_3d=mesher,
    )  # fmt: skip
    res = pb.solve()
    solver = pb.integrator.contact
    B, pc = solver.B, solver.ksp.getPC()
    n = pc.getMGLevels()
    P, Ac = pc.getMGInterpolation(n - 1), pc.getMGSmoother(n - 2).getOperators()[0]
    Bs, Ps, Acs = to_scipy(B), to_scipy(P), to_scipy(Ac)
    vecs = B.getNearNullSpace().getVecs()
    Z = np.array([v.getArray(readonly=True).copy() for v in vecs]).T
    Pn, ranks = compressed_prolongator(Ps, Z, len(vecs))
    An = (Pn.T @ Bs @ Pn).tocsr()
    Pp, Ap = to_petsc(Pn), to_petsc(An)
    row = {
        "size": label,
        "dofs": pb.model.num_dofs,
        "contact_cg_its": res.linear_iterations,
        "fine_nnz": Bs.nnz,
        "aggregates": len(ranks),
        "rank_histogram": {int(k): int((ranks == k).sum()) for k in np.unique(ranks)},
        "gamg_coarse": {"n": Acs.shape[0], "nnz": Acs.nnz, **two_level(B, P, Ac)},
        "compressed_coarse": {"n": An.shape[0], "nnz": An.nnz, **two_level(B, Pp, Ap)},
        "machine": machine(),
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
    }
    Pp.destroy(), Ap.destroy()
    pb.destroy()
    return row


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="25k")
    p.add_argument("--mesh-dir", type=Path, default=Path("/tmp/bonecontact-bench-meshes"))
    p.add_argument("--out", type=Path, default=OUT)
    args = p.parse_args()
    for label in args.sizes.split(","):
        row = study(label, args.mesh_dir)
        print(json.dumps(row), flush=True)
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / f"coarse_columns_{label}.json").write_text(json.dumps(row, indent=1))


if __name__ == "__main__":
    main()
