"""Linear algebra helpers: bodies, rigid-body near-nullspace, linear solvers.

PETSc objects are the currency: matrices are distributed ``mpiaij`` with the
displacement block size, vectors share the DOLFINx layout.
"""

from __future__ import annotations

import gc
import itertools
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
from dolfinx import fem, la

__all__ = [
    "ITERATIVE_OPTIONS",
    "LinearSolverInfo",
    "SolverOptions",
    "body_labels",
    "configure_ksp",
    "create_solver",
    "owned_global_rows",
    "rigid_body_modes",
    "set_solver_options",
    "solver_options",
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


_OPTIONS_ATTR = "bonecontact_solver_options"
_COUNTER = itertools.count()


class SolverOptions:
    """The PETSc options of one KSP, under a prefix of its own, in PETSc's global options
    database only while the KSP sets up or solves.

    PETSc reads a solver's options from one global database, and not all at
    ``setFromOptions``: GAMG creates its level smoothers and coarse solver, and MUMPS its
    factor, at every preconditioner set-up, and reads their options (``mg_levels_*``,
    ``mg_coarse_*``, ``mat_mumps_*``) then.  So the options are kept here, and
    :meth:`applied` puts them into the database under the KSP's unique prefix
    (``<prefix><n>_``) and takes them out again; it wraps every ``KSPSolve`` of the KSP
    (its pre- and post-solve hooks) and its configuration.  Two solvers in one process
    thus never see each other's options, and none of ours is left in the database.

    The user's options under the documented ``prefix`` (the command line, e.g.
    ``-bc_contact_pc_gamg_threshold 0.05``) are read at every application and win over
    ours; they are the user's and stay in the database.

    Parameters
    ----------
    ksp
        The solver; its options prefix is set to the unique prefix.
    prefix
        The prefix under which the user overrides the options.
    """

    def __init__(self, ksp: PETSc.KSP, prefix: str):
        self.prefix = prefix
        self.unique = f"{prefix}{next(_COUNTER)}_"
        self.options: dict[str, object] = {}
        self._inserted: list[str] = []
        ksp.setOptionsPrefix(self.unique)
        ksp.setPreSolve(lambda _ksp, _b, _x: self._insert())
        ksp.setPostSolve(lambda _ksp, _b, _x: self._remove())

    @classmethod
    def of(cls, ksp: PETSc.KSP, prefix: str) -> SolverOptions:
        """The options object of ``ksp`` (made, and the KSP given its prefix, at the first call)."""
        found = ksp.getAttr(_OPTIONS_ATTR)
        if found is None:
            found = cls(ksp, prefix)
            ksp.setAttr(_OPTIONS_ATTR, found)
        return found

    def user_options(self) -> dict[str, str]:
        """The options in the database under the user's prefix (not under another
        solver's unique prefix), keys without the prefix."""
        n = len(self.prefix)
        return {
            k[n:]: v
            for k, v in PETSc.Options().getAll().items()
            if k.startswith(self.prefix) and not k[n:].split("_", 1)[0].isdigit()
        }

    def _insert(self) -> None:
        self._remove()
        opts = PETSc.Options()
        for key, value in {**self.options, **self.user_options()}.items():
            name = f"{self.unique}{key}"
            opts[name] = value
            self._inserted.append(name)

    def _remove(self) -> None:
        opts = PETSc.Options()
        for name in self._inserted:
            if opts.hasName(name):
                opts.delValue(name)
        self._inserted = []

    @contextmanager
    def applied(self) -> Iterator[None]:
        """The options in the database for the body of the ``with`` block (e.g. an
        explicit ``ksp.setUp()`` or ``ksp.setFromOptions()``)."""
        self._insert()
        try:
            yield
        finally:
            self._remove()


def set_solver_options(
    ksp: PETSc.KSP, options: dict[str, object], prefix: str = "bc_"
) -> SolverOptions:
    """Add ``options`` (PETSc option names without a prefix) to the options of ``ksp``
    (:class:`SolverOptions`), then apply them (``ksp.setFromOptions``).

    A value ``None`` removes the option."""
    so = SolverOptions.of(ksp, prefix)
    for key, value in options.items():
        if value is None:
            so.options.pop(key, None)
        else:
            so.options[key] = value
    with so.applied():
        ksp.setFromOptions()
    return so


def solver_options(ksp: PETSc.KSP) -> SolverOptions | None:
    """The :class:`SolverOptions` of ``ksp`` (``None`` if it has none)."""
    return ksp.getAttr(_OPTIONS_ATTR)


#: PETSc options of the package's iterative solver (CG set by ``configure_ksp``).
ITERATIVE_OPTIONS: dict[str, object] = {
    "pc_gamg_type": "agg",
    "pc_gamg_threshold": 0.01,
    "mg_levels_ksp_type": "chebyshev",
    "mg_levels_pc_type": "jacobi",
    "mg_levels_ksp_chebyshev_esteig_steps": 20,
}


def configure_ksp(
    ksp: PETSc.KSP,
    kind: str,
    rtol: float = 1e-12,
    prefix: str = "bc_",
    max_it: int = 2000,
    options: dict[str, object] | None = None,
) -> SolverOptions:
    """Set a KSP up as the package's direct (MUMPS LU) or iterative (CG + smoothed-
    aggregation GAMG, Chebyshev/Jacobi smoothing) solver.

    The options live under a prefix of the KSP's own and are in PETSc's options
    database only while it sets up or solves (:class:`SolverOptions`); the user
    overrides them on the command line under ``prefix``.  ``options``: further PETSc
    options of this solver (e.g. ``{"mat_mumps_icntl_24": 1}``).
    """
    pc = ksp.getPC()
    if kind == "direct":
        ksp.setType("preonly")
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        base: dict[str, object] = {}
    elif kind == "iterative":
        ksp.setType("cg")
        ksp.setTolerances(rtol=rtol, atol=1e-300, max_it=max_it)
        pc.setType("gamg")
        base = dict(ITERATIVE_OPTIONS)
    else:
        raise ValueError(f"linear solver kind must be 'direct' or 'iterative', got {kind!r}")
    return set_solver_options(ksp, {**base, **(options or {})}, prefix)


def create_solver(
    A: PETSc.Mat,
    kind: str = "direct",
    near_nullspace: PETSc.NullSpace | None = None,
    rtol: float = 1e-12,
    prefix: str = "bc_",
    options: dict[str, object] | None = None,
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
        PETSc options prefix under which users override the options from the command
        line (the KSP's own prefix is unique: :class:`SolverOptions`).
    options
        Further PETSc options of this solver.
    """
    ksp = PETSc.KSP().create(A.getComm())
    ksp.setOperators(A)
    if kind == "iterative":
        if near_nullspace is not None:
            A.setNearNullSpace(near_nullspace)
        A.setOption(PETSc.Mat.Option.SPD, True)
    so = configure_ksp(ksp, kind, rtol=rtol, prefix=prefix, max_it=2000, options=options)
    with so.applied():
        ksp.setUp()
    return ksp


def release_petsc_garbage(comm: MPI.Comm, collect: bool = True) -> None:
    """Destroy the PETSc objects Python has freed on ``comm`` (collective: every rank of
    ``comm`` at the same point).

    In parallel petsc4py does not destroy an object Python frees: it parks it until a
    collective ``PETSc.garbage_cleanup`` on the object's own communicator, and DOLFINx
    gives every mesh (and index map) a communicator of its own.  Each parked MUMPS factor
    keeps its duplicated MPI communicators, and MPICH runs out of them after about 400
    factorisations on 2 ranks (MUMPS then fails with INFOG(1) = -3).  Pass the mesh's
    communicator of what you made (``mesh.comm``) while the mesh is alive; with
    ``collect`` objects in reference cycles are collected first (a full ``gc.collect()``).
    The package's own solvers are destroyed explicitly when replaced; this is for scripts
    and test sessions that make many models on one set of ranks.
    """
    if comm.size > 1:
        if collect:
            gc.collect()
        PETSc.garbage_cleanup(comm)
