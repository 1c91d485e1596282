"""Linear algebra helpers: bodies, rigid-body near-nullspace, linear solvers.

PETSc objects are the currency: matrices are distributed ``mpiaij`` with the
displacement block size, vectors share the DOLFINx layout.
"""

from __future__ import annotations

from dataclasses import dataclass

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
from dolfinx import fem, la

__all__ = [
    "LinearSolverInfo",
    "body_labels",
    "configure_ksp",
    "create_solver",
    "owned_global_rows",
    "rigid_body_modes",
]


def owned_global_rows(
    V: fem.FunctionSpace, local_dofs: npt.NDArray[np.int32]
) -> npt.NDArray[np.int32]:
    """Global PETSc rows of the *owned* entries among unrolled local dof indices."""
    bs = V.dofmap.index_map_bs
    imap = V.dofmap.index_map
    local_dofs = np.asarray(local_dofs, dtype=np.int32)
    owned = local_dofs[local_dofs < bs * imap.size_local]
    blocks, comps = np.divmod(owned, bs)
    return (bs * imap.local_to_global(blocks.astype(np.int32)) + comps).astype(PETSc.IntType)


def body_labels(V: fem.FunctionSpace) -> tuple[npt.NDArray[np.int32], int]:
    """Connected components ("bodies") of the mesh, per dof block.

    Label propagation over the cell–dof graph with ghost synchronisation, so that
    bodies split across ranks get one label.

    Returns
    -------
    labels
        Body number (0 … n_bodies−1, ordered by smallest global dof) for every local
        dof block (owned and ghost).
    n_bodies
        Number of bodies in the whole mesh.
    """
    comm = V.mesh.comm
    imap = V.dofmap.index_map
    nloc = imap.size_local + imap.num_ghosts
    vec = la.vector(imap, 1, dtype=np.float64)
    lab = vec.array
    lab[:] = imap.local_to_global(np.arange(nloc, dtype=np.int32)).astype(np.float64)
    dofs = V.dofmap.list
    while True:
        changed_any = False
        while True:
            cmin = lab[dofs].min(axis=1)
            new = lab.copy()
            np.minimum.at(new, dofs, cmin[:, None] * np.ones((1, dofs.shape[1])))
            if np.array_equal(new, lab):
                break
            lab[:] = new
            changed_any = True
        before = lab[: imap.size_local].copy()
        vec.scatter_reverse(la.InsertMode.insert)
        lab[: imap.size_local] = np.minimum(before, lab[: imap.size_local])
        vec.scatter_forward()
        changed_any = changed_any or not np.array_equal(before, lab[: imap.size_local])
        if not comm.allreduce(changed_any, op=MPI.LOR):
            break
    roots = np.unique(lab[: imap.size_local])
    all_roots = np.unique(np.concatenate(comm.allgather(roots)))
    labels = np.searchsorted(all_roots, lab).astype(np.int32)
    return labels, int(all_roots.size)


def rigid_body_modes(V: fem.FunctionSpace, per_body: bool = True) -> PETSc.NullSpace:
    """Rigid-body modes (3 in 2D, 6 in 3D), one set per body, orthonormalised.

    Used as the near-nullspace of GAMG for elasticity.
    """
    msh = V.mesh
    gdim = msh.geometry.dim
    bs = V.dofmap.index_map_bs
    imap = V.dofmap.index_map
    n = imap.size_local
    x = V.tabulate_dof_coordinates()[:n]
    if per_body:
        labels, nb = body_labels(V)
        labels = labels[:n]
    else:
        labels, nb = np.zeros(n, dtype=np.int32), 1
    nmodes = 3 if gdim == 2 else 6
    basis = []
    for b in range(nb):
        mask = labels == b
        modes = [np.zeros((n, bs)) for _ in range(nmodes)]
        for i in range(gdim):
            modes[i][mask, i] = 1.0
        if gdim == 2:
            modes[2][mask, 0] = -x[mask, 1]
            modes[2][mask, 1] = x[mask, 0]
        else:
            modes[3][mask, 0] = -x[mask, 1]
            modes[3][mask, 1] = x[mask, 0]
            modes[4][mask, 0] = x[mask, 2]
            modes[4][mask, 2] = -x[mask, 0]
            modes[5][mask, 2] = x[mask, 1]
            modes[5][mask, 1] = -x[mask, 2]
        for m in modes:
            v = PETSc.Vec().createMPI((n * bs, PETSc.DECIDE), bsize=bs, comm=msh.comm)
            v.array[:] = m.ravel()
            basis.append(v)
    # Gram–Schmidt (modes of distinct bodies are orthogonal already)
    for i, v in enumerate(basis):
        for w in basis[:i]:
            v.axpy(-v.dot(w), w)
        nrm = v.norm()
        if nrm > 0:
            v.scale(1.0 / nrm)
    basis = [v for v in basis if v.norm() > 0.5]
    return PETSc.NullSpace().create(vectors=basis, comm=msh.comm)


@dataclass
class LinearSolverInfo:
    """What a linear solve did (for reports and benchmarks)."""

    kind: str
    iterations: int = 0
    setup_time: float = 0.0


def configure_ksp(
    ksp: PETSc.KSP, kind: str, rtol: float = 1e-12, prefix: str = "bc_", max_it: int = 2000
) -> None:
    """Set a KSP up as the package's direct (MUMPS LU) or iterative (CG + smoothed-
    aggregation GAMG, Chebyshev/Jacobi smoothing) solver; the options can be overridden
    on the command line under ``prefix``."""
    pc = ksp.getPC()
    if kind == "direct":
        ksp.setType("preonly")
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
    elif kind == "iterative":
        ksp.setType("cg")
        ksp.setTolerances(rtol=rtol, atol=1e-300, max_it=max_it)
        pc.setType("gamg")
        opts = PETSc.Options()
        opts[f"{prefix}pc_gamg_type"] = "agg"
        opts[f"{prefix}pc_gamg_threshold"] = 0.01
        opts[f"{prefix}mg_levels_ksp_type"] = "chebyshev"
        opts[f"{prefix}mg_levels_pc_type"] = "jacobi"
        opts[f"{prefix}mg_levels_ksp_chebyshev_esteig_steps"] = 20
    else:
        raise ValueError(f"linear solver kind must be 'direct' or 'iterative', got {kind!r}")


def create_solver(
    A: PETSc.Mat,
    kind: str = "direct",
    near_nullspace: PETSc.NullSpace | None = None,
    rtol: float = 1e-12,
    prefix: str = "bc_",
) -> PETSc.KSP:
    """A KSP for the (symmetric positive definite) operator ``A``.

    Parameters
    ----------
    A
        Assembled operator (boundary rows already replaced).
    kind
        ``"direct"``: MUMPS LU; ``"iterative"``: CG preconditioned by GAMG
        (smoothed aggregation with the rigid-body near-nullspace, Chebyshev/Jacobi
        smoothing).
    near_nullspace
        Rigid-body modes (required for a good GAMG on elasticity).
    rtol
        Relative tolerance of the Krylov solver.
    prefix
        PETSc options prefix, so users can override from the command line.
    """
    ksp = PETSc.KSP().create(A.getComm())
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(A)
    if kind == "iterative":
        if near_nullspace is not None:
            A.setNearNullSpace(near_nullspace)
        A.setOption(PETSc.Mat.Option.SPD, True)
    configure_ksp(ksp, kind, rtol=rtol, prefix=prefix, max_it=2000)
    ksp.setFromOptions()
    ksp.setUp()
    return ksp
