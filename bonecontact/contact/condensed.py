"""The condensed contact system of one time step
(docs/theory/mortar.md#condensation-of-the-multipliers,
docs/theory/pdas.md#linear-system-of-one-iteration).

:class:`CondensedSystem` holds what every PDAS iteration works on: the operator in the
nodal frames ``Ã = T Q A Qᵀ Tᵀ``, its right-hand side ``T Q b``, the solution ``Ũ`` and
the layout of the contact rows, with the per-node data (``D_pp``, gaps, row scales) of
this rank's owned slave nodes (docs/theory/pdas.md#distributed-set-logic).  It is built
once per operator by :meth:`CondensedSystem.build` and knows nothing of active sets or
friction.
A solver that changes the operator in place (the refactor and Krylov strategies'
eliminated matrix) takes ``Ã`` over with :meth:`CondensedSystem.take_operator`; the system
then keeps only ``Ã``'s stripes (its contact and Dirichlet rows and columns), from which
:meth:`CondensedSystem.restore_operator` resets that matrix to ``Ã`` for the next set.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
from dolfinx import fem

from bonecontact.contact.interface import (
    ContactInterface,
    basis_transform,
    rotation_matrix,
    transformed_operator,
)
from bonecontact.contact.reductions import global_sum

__all__ = ["CondensedSystem", "RowLayout", "lean_products"]


@contextmanager
def lean_products(comm: MPI.Comm, clear: bool = True, all_at_once: bool = False) -> Iterator[None]:
    """PETSc's matrix products made inside the block keep no intermediate data
    (issue 28): each product frees it once computed (``mat_product_clear``; ``clear=False``
    for a caller that recomputes a product in place) — the Galerkin products of GAMG's
    coarse levels otherwise keep it as long as they live.  ``all_at_once`` (on more than
    one rank): the triple products ``PᵀAP`` are made all at once (``matptap_via
    allatonce``: ``AP`` is never formed; the condensed operator's one product — for GAMG's
    it made the contact solve 1.5–1.8 times the CPU time at 25k dofs on 2 ranks).  Options
    the user has set are left as they are."""
    opts = PETSc.Options()
    wanted = {"mat_product_clear": "true"} if clear else {}
    if all_at_once and comm.size > 1:
        wanted["matptap_via"] = "allatonce"
    added = [k for k in wanted if not opts.hasName(k)]
    for key in added:
        opts[key] = wanted[key]
    try:
        yield
    finally:
        for key in added:
            opts.delValue(key)


@dataclass
class RowLayout:
    """Where the contact rows are: this rank's owned slave nodes and their rows.

    The per-node arrays of the PDAS have one entry per slave node owned by this rank
    (interface by interface); the per-row arrays are component-major over them:
    ``rows_of[j][p] = j n_nodes + p`` is the row of component ``j`` (0 normal, then the
    tangents) of node ``p``, and ``local_rows`` its row in the PETSc vectors.  Across
    ranks, the contact rows are numbered rank after rank: this rank's row ``r`` is the
    global contact row ``row_offset + r``.  No array here has the global size.
    """

    comm: MPI.Comm
    bs: int  # block size = gdim
    n_nodes: int  # slave nodes of this rank (owned)
    n_global: int  # slave nodes of all ranks
    node_offset: int  # this rank's first node in the rank-after-rank numbering
    split: npt.NDArray[np.int64]  # where this rank's nodes change interface
    local_rows: npt.NDArray[np.int32]  # this rank's contact rows (local, component-major)
    rows_of: list[npt.NDArray[np.int64]]  # per component, the row of every node

    @classmethod
    def of(cls, comm: MPI.Comm, bs: int, interfaces: list[ContactInterface]) -> RowLayout:
        """The layout of the owned slave nodes of ``interfaces`` (collective)."""
        sizes = [itf.num_owned for itf in interfaces]
        m = int(sum(sizes))
        offset = comm.exscan(m) if comm.size > 1 else 0
        nodes_local = np.concatenate(
            [bs * itf.blocks.astype(np.int64) for itf in interfaces] + [np.zeros(0, np.int64)]
        )
        local_rows = np.concatenate([nodes_local + j for j in range(bs)]).astype(np.int32)
        return cls(
            comm=comm,
            bs=bs,
            n_nodes=m,
            n_global=int(comm.allreduce(m, op=MPI.SUM)),
            node_offset=int(offset or 0),
            split=np.cumsum(sizes)[:-1],
            local_rows=local_rows,
            rows_of=[j * m + np.arange(m, dtype=np.int64) for j in range(bs)],
        )

    @property
    def n_owned(self) -> int:
        """Slave nodes of this rank (:attr:`n_nodes`)."""
        return self.n_nodes

    @property
    def n_rows(self) -> int:
        """Contact rows of this rank (``bs × n_nodes``)."""
        return self.bs * self.n_nodes

    @property
    def row_offset(self) -> int:
        """Global contact row of this rank's row 0."""
        return self.bs * self.node_offset

    def own(self, values: npt.NDArray) -> list[npt.NDArray]:
        """A per-node array → this rank's nodes split by interface."""
        return np.split(values, self.split)

    def fixed_rows(
        self, normal: npt.NDArray[np.bool_], tangential: npt.NDArray[np.bool_]
    ) -> npt.NDArray[np.bool_]:
        """Mask of the rows with a prescribed value: the normal rows of the nodes
        ``normal`` (active), the tangential rows of the nodes ``tangential`` (sticking)."""
        fixed = np.zeros(self.n_rows, dtype=bool)
        fixed[self.rows_of[0][normal]] = True
        for j in range(1, self.bs):
            fixed[self.rows_of[j][tangential]] = True
        return fixed


@dataclass
class CondensedSystem:
    """The condensed, rotated contact system of one operator (docs/theory/pdas.md).

    Unknowns ``Ũ = T Q⁻ᵀ U``: relative displacements of the slave nodes in their frames
    ``[n; t(; t2)]``; the contact rows carry ``w = T F̂ − Ã Ũ`` (the contact force is
    ``−w``) and the multipliers are ``λ = w / D_pp``.  Per-node arrays hold this rank's
    owned slave nodes.
    """

    layout: RowLayout
    interfaces: list[ContactInterface]
    Qt: PETSc.Mat  # Qᵀ (basis transformation)
    T: PETSc.Mat  # rotation into the nodal frames
    Tt: PETSc.Mat  # Tᵀ
    At: PETSc.Mat | None  # Ã = T Q A Qᵀ Tᵀ (Dirichlet rows eliminated); None once taken
    bc_rows: npt.NDArray  # owned global Dirichlet rows
    bc_local: npt.NDArray[np.int32]  # the same, local
    start: int  # first owned global row
    D: npt.NDArray[np.float64]  # D_pp
    gap: npt.NDArray[np.float64]  # nodal gaps g_p = d_p / D_pp
    scale: npt.NDArray[np.float64]  # |diagonal| of every contact row (this rank's rows)
    stiffness_ratio: float  # mean of (normal-row diagonal / D_pp) (≈ E/h)
    diag_value: float  # diagonal of eliminated rows
    force_scale: float  # operator forces → N (1, 1/Δt or 1/Δt²)
    Uh: PETSc.Vec  # Ũ, the last solution
    r0: PETSc.Vec  # T F̂ = T Q b, Dirichlet rows holding their values
    w: PETSc.Vec  # work: T F̂ − Ã Ũ
    Fh: PETSc.Vec  # work: F̂ = Q b
    AtL: PETSc.Mat | None = None  # the contact rows of Ã (built on first use)
    #: the entries of Ã in the contact and Dirichlet rows and columns (the rest zero),
    #: once Ã is taken over (:meth:`take_operator`), else ``None``
    stripes: PETSc.Mat | None = None

    @classmethod
    def build(
        cls,
        V: fem.FunctionSpace,
        interfaces: list[ContactInterface],
        A: PETSc.Mat,
        bc_rows: npt.ArrayLike | None,
        force_scale: float,
    ) -> CondensedSystem:
        """Transform ``A`` (Dirichlet rows and columns eliminated) once and lay out the
        contact rows (collective)."""
        bs = V.dofmap.index_map_bs
        layout = RowLayout.of(V.mesh.comm, bs, interfaces)
        Qt = basis_transform(V, interfaces)
        T = rotation_matrix(V, interfaces)
        Tt = T.transpose(PETSc.Mat())  # (transpose() without an argument is in place)
        with lean_products(layout.comm, all_at_once=True):
            At = transformed_operator(A, Qt, Tt, cleared=True)
        start = bs * V.dofmap.index_map.local_range[0]
        bc = np.asarray(bc_rows if bc_rows is not None else [], dtype=PETSc.IntType)
        D = np.concatenate([itf.D for itf in interfaces] + [np.zeros(0)])
        gap = np.concatenate([itf.gap for itf in interfaces] + [np.zeros(0)])
        diag = At.getDiagonal()
        scale = np.maximum(np.abs(diag.array[layout.local_rows]), 1e-300)
        diag.destroy()
        ns, comm = layout.n_global, layout.comm
        sn = scale[layout.rows_of[0]]
        ratio = global_sum(comm, float((sn / np.where(D > 0, D, 1.0)).sum())) / max(ns, 1)
        mean_d = global_sum(comm, float(D.sum())) / max(ns, 1)
        return cls(
            layout=layout,
            interfaces=list(interfaces),
            Qt=Qt,
            T=T,
            Tt=Tt,
            At=At,
            bc_rows=bc,
            bc_local=(bc - start).astype(np.int32),
            start=start,
            D=D,
            gap=gap,
            scale=scale,
            stiffness_ratio=ratio,
            # the mean normal-row stiffness
            diag_value=ratio * mean_d if ns else 1.0,
            force_scale=float(force_scale),
            Uh=At.createVecRight(),
            r0=At.createVecLeft(),
            w=At.createVecLeft(),
            Fh=Qt.createVecRight(),
        )

    # ------------------------------------------------------------------ vectors
    def assemble_rhs(self, b: PETSc.Vec) -> None:
        """``T F̂ = T Q b`` into :attr:`r0` (Dirichlet rows keep their prescribed values)."""
        self.Qt.multTranspose(b, self.Fh)
        self.T.mult(self.Fh, self.r0)
        if self.bc_local.size:
            self.r0.array[self.bc_local] = b.array[self.bc_local]

    def unknowns(self) -> npt.NDArray[np.float64]:
        """The unknowns ``Ũ`` of this rank's contact rows."""
        return self.Uh.array[self.layout.local_rows].copy()

    def contact_residual(self) -> npt.NDArray[np.float64]:
        """This rank's contact rows of ``w = T F̂ − Ã Ũ`` (a product with the contact
        rows of ``Ã`` only, :attr:`AtL`, or, once ``Ã`` is taken over, with its stripes,
        whose contact rows are those rows: the same sums, exactly)."""
        rows = self.layout.local_rows
        if self.stripes is not None:
            full = self.stripes.createVecLeft()
            self.stripes.mult(self.Uh, full)
            w = self.r0.array_r[rows] - full.array_r[rows]
            full.destroy()
            return w
        AtL = self._contact_rows()
        wl = AtL.createVecLeft()
        AtL.mult(self.Uh, wl)
        w = self.r0.array_r[rows] - wl.array_r
        wl.destroy()
        return w

    def _contact_rows(self) -> PETSc.Mat:
        """:attr:`AtL`, the contact rows of ``Ã`` (built from ``Ã`` on first use)."""
        if self.AtL is None:
            rows = self.layout.local_rows.astype(np.int64) + self.start
            self.AtL = row_block(self.At, rows.astype(PETSc.IntType))
        return self.AtL

    # ------------------------------------------------- the operator taken over
    def take_operator(self, stripes: bool = True) -> PETSc.Mat:
        """Hand ``Ã`` over to a solver that changes it in place (collective).

        The system keeps ``Ã``'s stripes (:attr:`stripes`: the entries in the contact and
        Dirichlet rows and columns, the only ones a set's elimination or replaced rows
        change), from which :meth:`restore_operator` makes the changed matrix ``Ã`` again
        and whose contact rows give :meth:`contact_residual`; :attr:`At` is ``None``
        afterwards.  One matrix of ``Ã``'s size is kept instead of two.
        ``stripes=False``: a caller that never restores ``Ã`` (nor needs
        :meth:`operator_product`) leaves the stripes out and keeps the contact rows
        (:attr:`AtL`) only.
        """
        if self.At is None:
            raise RuntimeError("contact: the condensed operator has been taken over already")
        if stripes:
            self.stripes = operator_stripes(self.At, self.stripe_rows())
        else:
            self._contact_rows()
        At, self.At = self.At, None
        return At

    def stripe_rows(self) -> npt.NDArray:
        """The owned global rows whose rows and columns a set may change: the contact
        rows and the Dirichlet rows (sorted)."""
        rows = np.concatenate(
            [self.layout.local_rows.astype(np.int64) + self.start, self.bc_rows.astype(np.int64)]
        )
        return np.unique(rows).astype(PETSc.IntType)

    def restore_operator(self, B: PETSc.Mat) -> None:
        """``B ← Ã`` for a matrix ``B`` taken by :meth:`take_operator` and changed only in
        the stripes since (collective; exact: the stripes are zeroed and ``Ã``'s entries
        added there, the rest of ``B`` is not touched)."""
        B.zeroRowsColumns(self.stripe_rows(), diag=0.0)
        B.axpy(1.0, self.stripes, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)

    def operator_product(self, v: PETSc.Vec, out: PETSc.Vec) -> None:
        """``out = Ã v`` for a ``v`` that is zero outside the contact and Dirichlet rows
        (from the stripes once ``Ã`` is taken over: the same sums, exactly)."""
        (self.At if self.At is not None else self.stripes).mult(v, out)

    def fixed_values(self, xold: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Values of rows when prescribed: the gap for normal rows, the unknowns ``xold``
        at the start of the step (no slip) for tangential ones."""
        values = xold.copy()
        values[self.layout.rows_of[0]] = self.gap
        return values

    def write_solution(self, u: fem.Function) -> None:
        """``U = Qᵀ Tᵀ Ũ`` into ``u`` (ghosts updated)."""
        uhat = self.Tt.createVecLeft()
        self.Tt.mult(self.Uh, uhat)  # Û = Tᵀ Ũ
        self.Qt.mult(uhat, u.x.petsc_vec)  # U = Qᵀ Û
        uhat.destroy()
        u.x.scatter_forward()

    def contact_force(self, out: PETSc.Vec) -> None:
        """The contact forces of :attr:`Uh` in the original basis (N; N/m in 2D;
        ``−Q⁻¹ Tᵀ w`` with ``Q⁻¹ = 2I − Q``, times the force scale; see
        :meth:`bonecontact.contact.pdas.ContactSolver.contact_force`)."""
        wv = self.w
        wv.set(0.0)
        wv.array[self.layout.local_rows] = self.contact_residual()
        tw = self.Tt.createVecLeft()
        self.Tt.mult(wv, tw)
        self.Qt.multTranspose(tw, out)
        out.aypx(-1.0, tw)  # Q⁻¹ Tᵀ w = 2 Tᵀ w − Q Tᵀ w
        out.axpy(1.0, tw)
        out.scale(-self.force_scale)
        tw.destroy()

    def destroy(self) -> None:
        """Free the PETSc objects."""
        for obj in (self.T, self.Tt, self.Qt, self.Uh, self.r0, self.w, self.Fh):
            obj.destroy()
        for mat in (self.At, self.AtL, self.stripes):
            if mat is not None:
                mat.destroy()

    def matrices(self) -> dict[str, PETSc.Mat]:
        """The matrices the system holds (name → matrix; those not built left out)."""
        named = {"At": self.At, "AtL": self.AtL, "stripes": self.stripes}
        named.update(Qt=self.Qt, T=self.T, Tt=self.Tt)
        return {k: m for k, m in named.items() if m is not None}


def row_block(A: PETSc.Mat, rows: npt.NDArray) -> PETSc.Mat:
    """The owned global ``rows`` of ``A`` with all its columns (collective; rows numbered
    in the order given, rank after rank; columns as ``A``'s)."""
    comm = A.getComm()
    lo, hi = A.getOwnershipRangeColumn()
    isrow = PETSc.IS().createGeneral(rows, comm=comm)
    iscol = PETSc.IS().createStride(hi - lo, first=lo, step=1, comm=comm)
    try:
        return A.createSubMatrix(isrow, iscol)
    finally:
        isrow.destroy()
        iscol.destroy()


def operator_stripes(A: PETSc.Mat, rows: npt.NDArray) -> PETSc.Mat:
    """The entries of ``A`` in the rows and the columns ``rows`` (owned global rows,
    sorted), the others left out, as a matrix of ``A``'s size and layout (collective;
    exact zeros left out too).  Built from two submatrices (the rows, the columns), never
    a copy of ``A``."""
    comm = A.getComm()
    lo, hi = A.getOwnershipRange()
    rows64 = np.asarray(rows, dtype=np.int64)
    block = row_block(A, rows)
    ri, rj, rv = block.getValuesCSR()
    block.destroy()
    keep = rv != 0.0
    row_part = (np.repeat(rows64 - lo, np.diff(ri))[keep], rj[keep], rv[keep])
    del ri, rj, rv, keep
    isall = PETSc.IS().createStride(hi - lo, first=lo, step=1, comm=comm)
    iscol = PETSc.IS().createGeneral(rows, comm=comm)
    cols = A.createSubMatrix(isall, iscol)
    ci, cj, cv = cols.getValuesCSR()
    for obj in (isall, iscol, cols):
        obj.destroy()
    all_rows = np.concatenate(comm.tompi4py().allgather(rows64)).astype(PETSc.IntType)
    in_rows = np.zeros(hi - lo, dtype=bool)
    in_rows[rows64 - lo] = True
    c_i = np.repeat(np.arange(hi - lo, dtype=PETSc.IntType), np.diff(ci))
    keep = (cv != 0.0) & ~in_rows[c_i]  # (entries of the rows are in the first part)
    col_part = (c_i[keep], all_rows[cj[keep]], cv[keep])
    del ci, cj, cv, c_i, keep
    return _csr_matrix(A, *(np.concatenate(k) for k in zip(row_part, col_part)))


def _csr_matrix(
    A: PETSc.Mat, local_rows: npt.NDArray, cols: npt.NDArray, values: npt.NDArray
) -> PETSc.Mat:
    """A matrix of ``A``'s sizes and layout with the entries (this rank's local row,
    global column, value), no two at the same place, from its rows' CSR arrays (a COO
    assembly would keep two index arrays of 8 bytes per entry for as long as the
    matrix lives)."""
    order = np.lexsort((cols, local_rows))
    n = A.getLocalSize()[0]
    counts = np.bincount(local_rows, minlength=n)
    indptr = np.concatenate([[0], np.cumsum(counts)]).astype(PETSc.IntType)
    S = PETSc.Mat().createAIJ(
        size=A.getSizes(),
        csr=(indptr, cols[order].astype(PETSc.IntType), values[order]),
        comm=A.getComm(),
    )
    S.assemble()
    return S
