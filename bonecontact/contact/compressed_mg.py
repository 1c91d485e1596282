"""Compressed-aggregation multigrid for the condensed contact system (issue 28;
docs/theory/pdas.md#compressed-coarse-grid).

GAMG gives every aggregate as many coarse unknowns as the near-nullspace has vectors:
twelve in 3D for the condensed system (each body's six rigid modes), although inside one
body the other body's modes vanish and only six are independent.  Here the aggregates are
formed by this rank alone (greedy maximal independent sets on the strength graph of the
local block: distance two on the finest level, one below), and each aggregate's
prolongator columns are the left singular vectors of its near-nullspace block above
``rank_tol`` of the largest: six columns inside a body, up to twelve at the interface.
The coarse operators are Galerkin products ``Pᵀ A P`` (PETSc's distributed ``MatPtAP``),
the near-nullspace of a coarse level is ``Σ Vᵀ`` of the aggregates' SVDs (``P Z_c = Z``
exactly), and the hierarchy is a PCMG (Chebyshev/Jacobi smoothing as GAMG's, the
coarsest level factorised by Cholesky, LU if nonsymmetric — on one rank, as GAMG's
coarse grid, when there are several).  :class:`CompressedMultigrid` is the context of a
``python`` PC: PETSc calls its set-up when the operator changed and the preconditioner
is not kept; a new PDAS set updates the kept hierarchy (:func:`update_levels`).

Units: none (linear algebra).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Iterator
from dataclasses import dataclass

from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from bonecontact.contact.reductions import global_any, global_count

__all__ = [
    "Aggregation",
    "CompressedMultigrid",
    "KeptColumns",
    "MultigridLevel",
    "aggregate",
    "compressed_prolongator",
    "strength_graph",
]

_COUNTER = itertools.count()


@dataclass
class Aggregation:
    """A level's aggregation, kept across rebuilds of the hierarchy while the level's
    nodes without a coarse correction stay the same: those nodes (``skip``), the
    aggregate of every node and the number of aggregates (this rank's)."""

    skip: npt.NDArray[np.bool_]
    aggregates: npt.NDArray[np.int64]
    count: int


@dataclass
class MultigridLevel:
    """One level of the hierarchy: its operator, the prolongator from the next coarser
    level (``None`` on the coarsest), the aggregate of every node of this level (this
    rank's, ``-1``: none) and per aggregate its number of columns."""

    A: PETSc.Mat
    P: PETSc.Mat | None = None
    aggregates: npt.NDArray[np.int64] | None = None
    ranks: npt.NDArray[np.int64] | None = None
    aggregation: Aggregation | None = None
    #: the rows of ``A`` without a coarse correction (identity rows) at the last build
    isolated: npt.NDArray[np.bool_] | None = None
    #: the coarse near-nullspace ``Z_c`` of ``P`` (``None`` on the coarsest)
    Zc: npt.NDArray[np.float64] | None = None
    #: the smoother's Chebyshev interval (:func:`chebyshev_bounds`; ``None``: not yet)
    bounds: tuple[float, float] | None = None


#: Entries of the rank's block read at once for the strength graph (node-aligned chunks
#: of rows holding about this many entries on average: a copy of one chunk at a time
#: instead of the whole block's CSR arrays; 2^18 entries, about 20 MiB of transient
#: copies and products — 2^15 rows at a time were +60 MiB at 65k dofs, the run's peak).
CHUNK_ENTRIES = 1 << 18


def node_block_norms(
    A: PETSc.Mat, node_of_row: npt.NDArray[np.int64], n_nodes: int
) -> tuple[sp.csr_matrix, npt.NDArray[np.bool_]]:
    """The squared Frobenius norms of the node blocks of this rank's diagonal block of
    ``A`` (``F = R (A∘A) Rᵀ``, ``R`` the rows' nodes; node-aligned chunks of about
    :data:`CHUNK_ENTRIES` entries, so at most one chunk's entries are copied at a time) and
    the rows without a nonzero off-diagonal entry there (eliminated or Dirichlet rows:
    identity rows that need no coarse correction; a row that couples only to other
    ranks' rows does not occur: each row couples to its own node)."""
    D = A.getDiagonalBlock() if A.getComm().getSize() > 1 else A
    n = D.getSize()[0]
    dv = A.getDiagonal()
    diag2 = dv.array**2  # (the squared block's diagonal)
    dv.destroy()
    R = sp.csr_matrix((np.ones(n), (node_of_row, np.arange(n))), shape=(n_nodes, n))
    starts = np.flatnonzero(np.diff(node_of_row, prepend=-1))  # (first row of every node)
    per_row = D.getInfo()["nz_used"] / max(n, 1)
    chunk_rows = max(int(CHUNK_ENTRIES / max(per_row, 1.0)), 1)
    cuts = starts[np.searchsorted(starts, np.arange(0, n, chunk_rows))]
    cuts = np.unique(np.concatenate([cuts, [n]]))
    cols = PETSc.IS().createStride(n, 0, 1, comm=PETSc.COMM_SELF)
    parts, isolated = [], np.zeros(n, bool)
    for r0, r1 in zip(cuts[:-1].tolist(), cuts[1:].tolist()):
        rows = PETSc.IS().createStride(r1 - r0, r0, 1, comm=PETSc.COMM_SELF)
        chunk = D.createSubMatrix(rows, cols)
        ia, ja, a = chunk.getValuesCSR()
        chunk.destroy(), rows.destroy()
        np.multiply(a, a, out=a)
        M2 = sp.csr_matrix((a, ja, ia), shape=(r1 - r0, n))
        off = np.asarray(M2.sum(axis=1)).ravel() - diag2[r0:r1]  # exactly 0 without coupling
        isolated[r0:r1] = ~(off > 0.0)
        Rc = sp.csr_matrix(
            (np.ones(r1 - r0), (node_of_row[r0:r1], np.arange(r1 - r0))), shape=(n_nodes, r1 - r0)
        )
        part = (Rc @ M2 @ R.T).tocoo()  # (the chunk's node rows: disjoint from the others')
        parts.append((part.row, part.col, part.data))
        del ia, ja, a, M2, part
    cols.destroy()
    if not parts:
        return sp.csr_matrix((n_nodes, n_nodes)), isolated
    r, c, v = (np.concatenate(k) for k in zip(*parts))
    return sp.csr_matrix((v, (r, c)), shape=(n_nodes, n_nodes)), isolated


def isolated_rows(A: PETSc.Mat) -> npt.NDArray[np.bool_]:
    """The identity rows of ``A`` (no nonzero off-diagonal entry) without a copy of the
    matrix: the rows ``i`` with ``(A x)_i = A_ii x_i`` exactly for a random positive
    ``x`` (the zero entries of an identity row add exact zeros; a coupling changes the
    product unless it cancels, of probability zero, or lies below the rounding of the
    diagonal term, which the squared row sums of :func:`node_block_norms` miss too)."""
    x, y = A.createVecs()
    d = A.getDiagonal()
    rng = np.random.default_rng(A.getComm().getRank())
    x.array[:] = 1.0 + rng.random(x.getLocalSize())
    A.mult(x, y)
    isolated = y.array == d.array * x.array
    for v in (x, y, d):
        v.destroy()
    return isolated


def strength_graph(F: sp.csr_matrix, threshold: float) -> sp.csr_matrix:
    """The symmetric strength graph of the nodes (boolean, no diagonal) from the squared
    Frobenius norms ``F`` of the node blocks of a matrix ``M``: nodes ``I ≠ J`` are
    strongly connected when the norm of their block exceeds
    ``threshold · sqrt(‖M_II‖ ‖M_JJ‖)``."""
    F = F.tocoo()
    d = np.sqrt(np.maximum(F.diagonal(), 1e-300))
    strong = (F.row != F.col) & (np.sqrt(F.data) > threshold * np.sqrt(d[F.row] * d[F.col]))
    G = sp.csr_matrix(
        (np.ones(int(strong.sum()), bool), (F.row[strong], F.col[strong])), shape=F.shape
    )
    return (G + G.T).tocsr()


def aggregate(
    G: sp.csr_matrix, skip: npt.NDArray[np.bool_], distance: int, seed: int = 0
) -> tuple[npt.NDArray[np.int64], int]:
    """Greedy aggregation: in a random order of the nodes (``seed``), an unassigned node
    becomes a root and takes every unassigned node within ``distance`` edges of it (the
    roots are a maximal set at pairwise distance > ``distance``).  Nodes marked in
    ``skip`` get ``-1``.  Returns the aggregate of every node and the number of
    aggregates.

    (The random order, as in PETSc's MIS: 65k-dof 3D Hertz, the node order gave 1044
    aggregates against 823, a first coarse level of 7 694 unknowns against 5 824 and a
    coarse factorisation with 1.5 times the fill, for 2 fewer CG iterations.)"""
    reach = G.copy()
    for _ in range(distance - 1):
        reach = (reach + reach @ G).tocsr()
    reach.data[:] = 1
    ptr, idx = reach.indptr, reach.indices
    agg = np.full(G.shape[0], -1, np.int64)
    agg[skip] = -2
    count = 0
    for i in np.random.default_rng(seed).permutation(G.shape[0]):
        if agg[i] != -1:
            continue
        nbrs = idx[ptr[i] : ptr[i + 1]]
        agg[nbrs[agg[nbrs] == -1]] = count
        agg[i] = count
        count += 1
    agg[agg == -2] = -1
    return agg, count


def aggregate_blocks(
    agg_of_row: npt.NDArray[np.int64], n_agg: int
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """The aggregated rows grouped by aggregate (ascending rows within one) and where
    every aggregate's group starts (``n_agg + 1`` bounds)."""
    rows = np.flatnonzero(agg_of_row >= 0)
    rows = rows[np.argsort(agg_of_row[rows], kind="stable")]
    return rows, np.searchsorted(agg_of_row[rows], np.arange(n_agg + 1))


def blocks_by_size(bounds: npt.NDArray[np.int64]) -> Iterator[npt.NDArray[np.int64]]:
    """The aggregates grouped by their number of rows (one group per size, ascending
    aggregates), so that each group's blocks stack into one array."""
    sizes = np.diff(bounds)
    if sizes.size == 0:
        return
    order = np.argsort(sizes, kind="stable")
    cuts = np.flatnonzero(np.diff(sizes[order])) + 1
    yield from np.split(order, cuts)


def block_svds(
    Z: npt.NDArray[np.float64],
    rows: npt.NDArray[np.int64],
    bounds: npt.NDArray[np.int64],
    rank_tol: float,
) -> Iterator[tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], tuple]]:
    """Per group of equally sized aggregates (:func:`blocks_by_size`): the aggregates,
    their rows ``(k, m)`` and the thin SVDs ``U, s, Vt`` of their near-nullspace blocks
    ``Z[rows]`` (one stacked LAPACK call, the same per block as a call of its own) with
    the number of singular values above ``rank_tol`` of the largest (0 for a zero block)."""
    for group in blocks_by_size(bounds):
        m = int(bounds[group[0] + 1] - bounds[group[0]])
        block_rows = rows[bounds[group][:, None] + np.arange(m)]
        if m == 0:
            yield group, block_rows, None
            continue
        U, s, Vt = np.linalg.svd(Z[block_rows], full_matrices=False)
        top = s[:, :1]
        r = np.where(top[:, 0] > 0.0, (s > rank_tol * top).sum(axis=1), 0)
        yield group, block_rows, (U, s, Vt, r)


@dataclass
class KeptColumns:
    """A level's prolongator and coarse near-nullspace from an earlier build, the columns
    per aggregate, and the aggregates whose near-nullspace block changed since (``hit``):
    the others keep their columns (:func:`compressed_prolongator`)."""

    P: PETSc.Mat
    ranks: npt.NDArray[np.int64]
    Zc: npt.NDArray[np.float64]
    hit: npt.NDArray[np.bool_]
    #: the new local row of each of ``P``'s local rows (``-1``: none; ``None``: the same)
    row_map: npt.NDArray[np.int64] | None = None


def compressed_prolongator(
    A: PETSc.Mat,
    Z: npt.NDArray[np.float64],
    agg_of_row: npt.NDArray[np.int64],
    n_agg: int,
    rank_tol: float,
    kept: KeptColumns | None = None,
) -> tuple[PETSc.Mat, npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """The prolongator whose columns are, per aggregate, the left singular vectors of
    the near-nullspace block ``Z[rows]`` above ``rank_tol`` of its largest singular value
    (the blocks' SVDs stacked by size, :func:`block_svds`; with ``kept``, only those of
    the aggregates ``kept.hit``, the others' columns and coarse near-nullspace copied
    from ``kept``, renumbered).

    Returns ``P`` (local rows of ``A`` × this rank's coarse columns), the coarse
    near-nullspace ``Z_c`` (``Σ Vᵀ`` per aggregate, so ``P Z_c = Z`` on the aggregated
    rows) and the number of columns of every aggregate."""
    comm = A.getComm().tompi4py()
    todo = np.ones(n_agg, bool) if kept is None else kept.hit
    ids = np.flatnonzero(todo)
    pos = np.full(n_agg + 1, -1, np.int64)  # (pos[-1] = -1: rows without aggregate)
    pos[ids] = np.arange(len(ids))
    rows, bounds = aggregate_blocks(pos[agg_of_row], len(ids))
    svds = list(block_svds(Z, rows, bounds, rank_tol))
    ranks = np.zeros(n_agg, np.int64) if kept is None else kept.ranks.copy()
    for group, _, svd in svds:
        ranks[ids[group]] = svd[3] if svd is not None else 0
    offsets = np.concatenate([[0], np.cumsum(ranks)])
    n_c = int(offsets[-1])
    c0 = int(comm.exscan(n_c) or 0) if comm.size > 1 else 0
    row_nnz = np.where(agg_of_row >= 0, ranks[agg_of_row], 0)
    indptr = np.concatenate([[0], np.cumsum(row_nnz)]).astype(PETSc.IntType)
    indices = np.empty(indptr[-1], PETSc.IntType)
    data = np.empty(indptr[-1])
    Zc = np.zeros((n_c, Z.shape[1]))
    for group, block_rows, svd in svds:
        if svd is None:
            continue
        U, s, Vt, r = svd
        first = offsets[ids[group]][:, None]
        keep = np.arange(s.shape[1]) < r[:, None]  # (k, columns)
        at = indptr[block_rows][:, :, None] + np.arange(s.shape[1])  # (k, m, columns)
        cols = c0 + first + np.arange(s.shape[1])
        mask = np.broadcast_to(keep[:, None, :], at.shape)
        indices[at[mask]] = np.broadcast_to(cols[:, None, :], at.shape)[mask]
        data[at[mask]] = U[mask]
        Zc[(first + np.arange(s.shape[1]))[keep]] = (s[..., None] * Vt)[keep]
    if kept is not None:
        copy_kept_columns(kept, agg_of_row, offsets, c0, (indptr, indices, data), Zc)
    n = A.getLocalSize()[0]
    P = PETSc.Mat().createAIJ(
        size=((n, A.getSize()[0]), (n_c, comm.allreduce(n_c))),
        csr=(indptr, indices, data),
        comm=A.getComm(),
    )
    P.assemble()
    return P, Zc, ranks


def copy_kept_columns(
    kept: KeptColumns,
    agg_of_row: npt.NDArray[np.int64],
    offsets: npt.NDArray[np.int64],
    c0: int,
    csr: tuple[npt.NDArray, npt.NDArray, npt.NDArray],
    Zc: npt.NDArray[np.float64],
) -> None:
    """Into the new prolongator's ``csr`` (rows sized) and ``Zc``: the entries and coarse
    near-nullspace rows of the aggregates not in ``kept.hit``, from ``kept`` (their
    columns moved from the old first column of the aggregate to the new, ``offsets``),
    in chunks of rows (:func:`row_chunks`): the copy's index arrays of the whole
    prolongator were the 65k-dof run's peak (19 MiB above the resident memory, at the
    first update of the hierarchy; issue 28)."""
    indptr, indices, data = csr
    ia, ja, a = kept.P.getValuesCSR()
    old = np.concatenate([[0], np.cumsum(kept.ranks)])
    shift = c0 + offsets[:-1] - kept.P.getOwnershipRangeColumn()[0] - old[:-1]  # per aggregate
    n_old = len(ia) - 1
    new_row = np.arange(n_old) if kept.row_map is None else kept.row_map
    agg = np.where(new_row >= 0, agg_of_row[np.maximum(new_row, 0)], -1)
    copy = (agg >= 0) & ~kept.hit[np.maximum(agg, 0)]
    for r0, r1 in row_chunks(ia):  # (the index temporaries of one chunk at a time)
        e0, e1 = int(ia[r0]), int(ia[r1])
        row = np.repeat(np.arange(r0, r1, dtype=PETSc.IntType), np.diff(ia[r0 : r1 + 1]))
        sel = copy[row]
        row = row[sel]
        dest = indptr[new_row[row]] + (e0 + np.flatnonzero(sel) - ia[row])
        indices[dest] = ja[e0:e1][sel] + shift[agg[row]]
        data[dest] = a[e0:e1][sel]
    same = np.flatnonzero(~kept.hit)
    counts = kept.ranks[same]
    within = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    Zc[np.repeat(offsets[same], counts) + within] = kept.Zc[np.repeat(old[same], counts) + within]


def node_skip(
    isolated: npt.NDArray[np.bool_], node_of_row: npt.NDArray[np.int64], n_nodes: int
) -> npt.NDArray[np.bool_]:
    """The nodes all of whose rows are isolated (no coarse correction)."""
    weights = (~isolated).astype(float)
    return np.bincount(node_of_row, weights=weights, minlength=n_nodes) == 0


def aggregation(
    A: PETSc.Mat,
    node_of_row: npt.NDArray[np.int64],
    distance: int,
    threshold: float,
    kept: Aggregation | None,
) -> tuple[Aggregation, npt.NDArray[np.bool_]]:
    """The aggregation of ``A``'s nodes and its isolated rows: ``kept`` (an earlier
    build's) when it has the same nodes without coarse correction — the operator
    changed only in values, e.g. in the contact rows of another PDAS set — else a new
    one from the strength graph (:func:`strength_graph`, :func:`aggregate`)."""
    n_nodes = int(node_of_row.max(initial=-1)) + 1
    comm = A.getComm().tompi4py()
    # (decided by all ranks together: isolated_rows is collective, and a rank that kept
    # its aggregation while another did not left the ranks at different products: 2D
    # Tresca + iterative on 2 ranks hung in ptap)
    candidate = kept is not None and len(kept.skip) == n_nodes
    if global_any(comm, candidate):
        isolated = isolated_rows(A)
        same = candidate and np.array_equal(node_skip(isolated, node_of_row, n_nodes), kept.skip)
        if global_count(comm, np.array([not same])) == 0:
            return kept, isolated
    F, isolated = node_block_norms(A, node_of_row, n_nodes)
    G = strength_graph(F, threshold)
    del F
    skip = node_skip(isolated, node_of_row, n_nodes)
    return Aggregation(skip, *aggregate(G, skip, distance)), isolated


def coarsen(
    A: PETSc.Mat,
    Z: npt.NDArray[np.float64],
    node_of_row: npt.NDArray[np.int64],
    distance: int,
    opts: CompressedMGOptions,
    kept: Aggregation | None = None,
) -> tuple[MultigridLevel, PETSc.Mat, npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """One coarsening step of ``A`` (rows grouped into nodes by ``node_of_row``; the
    aggregation ``kept`` of an earlier build if it still applies, :func:`aggregation`):
    the level of ``A`` with its prolongator, aggregation and columns per aggregate,
    ``Pᵀ A P``, the coarse near-nullspace and the aggregate of every coarse row."""
    agg, isolated = aggregation(A, node_of_row, distance, opts.threshold, kept)
    Z = Z.copy()
    Z[isolated] = 0.0  # identity rows: solved by the smoother, no coarse correction
    P, Zc, ranks = compressed_prolongator(
        A, Z, agg.aggregates[node_of_row], agg.count, opts.rank_tol
    )
    level = MultigridLevel(A, P, agg.aggregates, ranks, agg, isolated, Zc)
    return level, A.ptap(P), Zc, np.repeat(np.arange(agg.count), ranks)


@dataclass(frozen=True)
class CompressedMGOptions:
    """Settings of :class:`CompressedMultigrid`."""

    #: ``"w"`` or ``"v"`` cycles.
    cycle: str = "w"
    #: Strength threshold of the aggregation graph (block norms, scaled by the diagonal).
    threshold: float = 0.01
    #: Singular values of an aggregate's near-nullspace block kept, relative to its largest.
    rank_tol: float = 1e-8
    #: Coarsen until at most this many equations remain (then factorised).
    coarse_limit: int = 5000
    #: Factorisation of the coarsest level: ``"cholesky"`` (the Galerkin products of a
    #: symmetric operator are symmetric; half of LU's fill and operations: 65k dofs,
    #: 280 → 115 Mflop per set-up, the same iterations) or ``"lu"`` (nonsymmetric).
    coarse_factor: str = "cholesky"
    #: Who factorises the coarsest level: MUMPS (``"mumps"``) or PETSc's own
    #: (``"petsc"``); on several ranks the coarse grid is factorised on one of them while
    #: the others wait.  The factorisation is redone at every build and update;
    #: PETSc's own Cholesky of the AIJ coarse operator took 0.10–0.11 s of CPU per
    #: set-up at 65k dofs (1620 equations, 0.26 million nonzeros), MUMPS's 0.018 s,
    #: with a coarse solve of 0.9 ms against 0.45 ms (two per cycle); the same CG
    #: iterations.  MUMPS's memory left the 65k-dof run's peak (the first update's
    #: copy of the kept prolongator, :func:`copy_kept_columns`) 3.4 MiB higher:
    #: 394.8 MiB with the copy by chunks, below the 417 MB = 397.7 MiB of issue 28's peer.
    coarse_solver: str = "mumps"
    #: Chebyshev/Jacobi smoothing steps per level and visit.
    smooth_steps: int = 2
    #: Chebyshev eigenvalue-estimate steps and their Krylov method (``"cg"`` for
    #: symmetric operators, ``"gmres"`` otherwise).
    esteig_steps: int = 10
    esteig_ksp: str = "cg"
    #: Every level's Chebyshev interval estimated once per build
    #: (:func:`chebyshev_bounds`) and kept by the updates of the hierarchy (the operators
    #: changed only in the rows of another PDAS set; :func:`update_levels`); ``False``:
    #: PETSc's Chebyshev estimates it at every set-up (10 Krylov steps per level:
    #: 65k dofs, 3.88 against 4.21 Gflop for the contact solve with two updates).
    reuse_bounds: bool = True
    #: At most this many levels.
    max_levels: int = 10
    #: Keep every level's aggregation across rebuilds while its nodes without coarse
    #: correction stay the same (:func:`aggregation`): a new PDAS set changes the
    #: operator in the contact rows only; the prolongators and Galerkin products are
    #: computed anew from the kept aggregates.
    reuse_aggregates: bool = True
    #: When told that the operator changed only in eliminated rows since the last build
    #: (:meth:`CompressedMultigrid.allow_update`): update the kept hierarchy instead of
    #: building it anew — the prolongators from the kept aggregates, the coarse
    #: operators only in the aggregates whose rows changed (:func:`update_levels`;
    #: with ``reuse_aggregates`` only).
    local_update: bool = True

    def __post_init__(self) -> None:
        if self.coarse_factor not in ("cholesky", "lu"):
            raise ValueError(
                f"multigrid coarse_factor must be 'cholesky' or 'lu', got {self.coarse_factor!r}"
            )
        if self.coarse_solver not in ("mumps", "petsc"):
            raise ValueError(
                f"multigrid coarse_solver must be 'mumps' or 'petsc', got {self.coarse_solver!r}"
            )
        if self.cycle not in ("v", "w"):
            raise ValueError(f"multigrid cycle must be 'v' or 'w', got {self.cycle!r}")


def fine_near_nullspace(A: PETSc.Mat) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """The near-nullspace of ``A`` as this rank's rows × vectors and the node of every
    row (rows grouped by ``A``'s block size)."""
    nns = A.getNearNullSpace()
    if nns is None or not nns.getVecs():
        raise ValueError("compressed multigrid: the operator has no near-nullspace")
    Z = np.array([v.getArray(readonly=True) for v in nns.getVecs()]).T.copy()
    node_of_row = np.arange(A.getLocalSize()[0], dtype=np.int64) // A.getBlockSize()
    return Z, node_of_row


def build_levels(
    A: PETSc.Mat, opts: CompressedMGOptions, kept: list[Aggregation] | None = None
) -> list[MultigridLevel]:
    """The hierarchy of ``A`` (its block size and near-nullspace set), finest first,
    with the aggregations ``kept`` of an earlier build (level by level, while each
    applies: :func:`aggregation`; the levels below a new one are aggregated anew)."""
    Z, node_of_row = fine_near_nullspace(A)
    levels = [MultigridLevel(A)]
    kept = list(kept or [])
    while len(levels) < opts.max_levels and levels[-1].A.getSize()[0] > opts.coarse_limit:
        distance = 2 if len(levels) == 1 else 1
        old = kept[len(levels) - 1] if len(levels) <= len(kept) else None
        level, Ac, Z, node_of_row = coarsen(levels[-1].A, Z, node_of_row, distance, opts, old)
        if level.aggregation is not old:
            kept = []  # (the coarser levels' nodes are this level's aggregates)
        if Ac.getSize()[0] >= 0.9 * level.A.getSize()[0]:
            level.P.destroy(), Ac.destroy()  # no coarsening any more
            break
        levels[-1] = level
        levels.append(MultigridLevel(Ac))
    return levels


def columns_of(
    P: PETSc.Mat, ranks: npt.NDArray[np.int64], aggregates: npt.NDArray[np.int64]
) -> npt.NDArray[np.int64]:
    """The global columns of ``P`` (this rank's, ascending) of the given ascending
    aggregates of this rank (``ranks``: columns per aggregate, in aggregate order)."""
    offsets = np.concatenate([[0], np.cumsum(ranks)])
    counts = ranks[aggregates]
    first = np.repeat(offsets[aggregates], counts)
    within = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    return P.getOwnershipRangeColumn()[0] + first + within


def column_restriction(P: PETSc.Mat, cols: npt.NDArray[np.int64]) -> PETSc.Mat:
    """``P`` with the entries outside the columns ``cols`` (global, this rank's: ``P``'s
    rows have entries only in their aggregate's columns, this rank's) removed."""
    ia, ja, a = P.getValuesCSR()
    c0, c1 = P.getOwnershipRangeColumn()
    mask = np.zeros(c1 - c0, bool)
    mask[cols - c0] = True
    keep = mask[ja - c0]
    n = len(ia) - 1
    counts = np.bincount(np.repeat(np.arange(n), np.diff(ia))[keep], minlength=n)
    Pa = PETSc.Mat().createAIJ(
        size=P.getSizes(),
        csr=(np.concatenate([[0], np.cumsum(counts)]).astype(PETSc.IntType), ja[keep], a[keep]),
        comm=P.getComm(),
    )
    Pa.assemble()
    return Pa


def remote_columns(
    Ac: PETSc.Mat, ja: npt.NDArray, new_of_local: npt.NDArray
) -> tuple[npt.NDArray, npt.NDArray]:
    """The other ranks' columns among ``ja`` (``Ac``'s, this rank's entries; ascending)
    and their new global indices (``-1``: none) from their ranks' ``new_of_local``
    (the new index of each of a rank's columns; collective: a scatter; empty on one rank)."""
    none = np.zeros(0, PETSc.IntType)
    if Ac.getComm().getSize() == 1:
        return none, none
    c0, c1 = Ac.getOwnershipRangeColumn()
    remote = np.unique(ja[(ja < c0) | (ja >= c1)]).astype(PETSc.IntType)
    x = Ac.createVecRight()
    x.array[:] = new_of_local  # (exact: indices below 2^53)
    y = PETSc.Vec().createSeq(len(remote), comm=PETSc.COMM_SELF)
    where = PETSc.IS().createGeneral(remote, comm=PETSc.COMM_SELF)
    scatter = PETSc.Scatter().create(x, where, y, None)
    scatter.scatter(x, y, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)
    mapped = y.array.astype(PETSc.IntType)
    for obj in (x, y, where, scatter):
        obj.destroy()
    return remote, mapped


def csr_entries(M: PETSc.Mat) -> tuple[npt.NDArray, ...]:
    """This rank's entries of ``M`` by local row: (row, global column, value)."""
    ia, ja, v = M.getValuesCSR()
    return np.repeat(np.arange(len(ia) - 1, dtype=PETSc.IntType), np.diff(ia)), ja, v


#: Entries of the old coarse operator mapped, or of the kept prolongator copied, at once
#: by an update (bounds the update's transient arrays: mapping all at once made the
#: update the 65k run's peak, +18 MiB; so did the copy, +19 MiB).
UPDATE_CHUNK = 1 << 17


def row_chunks(ia: npt.NDArray) -> Iterator[tuple[int, int]]:
    """Consecutive row ranges ``[r0, r1)`` of a CSR row pointer ``ia`` holding about
    :data:`UPDATE_CHUNK` entries each (a row is never split)."""
    n = len(ia) - 1
    cuts = np.searchsorted(ia, np.arange(UPDATE_CHUNK, ia[-1], UPDATE_CHUNK))
    cuts = np.unique(np.concatenate([[0], cuts, [n]]))
    yield from zip(cuts[:-1].tolist(), cuts[1:].tolist())


@dataclass
class OldEntries:
    """The entries of an earlier coarse operator (this rank's rows, CSR) and how its
    rows and columns map to the new operator (:func:`update_galerkin`)."""

    ia: npt.NDArray
    ja: npt.NDArray
    v: npt.NDArray
    col_range: tuple[int, int]  # (this rank's old columns)
    new_row: npt.NDArray  # (new local row of each old local row, -1: none)
    new_col: npt.NDArray  # (new global index of each of this rank's old columns, -1: none)
    remote: tuple[npt.NDArray, npt.NDArray]  # (other ranks' old columns, their new index)

    def chunks(self) -> Iterator[tuple[npt.NDArray, npt.NDArray, npt.NDArray]]:
        """The kept entries (row and column kept), rows of about :data:`UPDATE_CHUNK` old
        entries at a time, by new local row: (row, new global column, value)."""
        c0, c1 = self.col_range
        remote, mapped = self.remote
        ia = self.ia
        for r0, r1 in row_chunks(ia):
            e0, e1 = int(ia[r0]), int(ia[r1])
            j = self.ja[e0:e1]
            rows = np.repeat(np.arange(r0, r1), np.diff(ia[r0 : r1 + 1]))
            own = (j >= c0) & (j < c1)
            cols = np.full(e1 - e0, -1, PETSc.IntType)
            cols[own] = self.new_col[j[own] - c0]
            if remote.size:
                cols[~own] = mapped[np.searchsorted(remote, j[~own])]
            r = self.new_row[rows]
            keep = (r >= 0) & (cols >= 0)
            yield r[keep], cols[keep], self.v[e0:e1][keep]


def old_entries(Ac: PETSc.Mat, new_of_old: npt.NDArray[np.int64], r0: int) -> OldEntries:
    """The entries of ``Ac`` and their map (``new_of_old``: the new global index of each
    of this rank's rows and columns, ``-1``: replaced; ``r0``: the new first local row)."""
    ia, ja, v = Ac.getValuesCSR()
    new_col = new_of_old.astype(PETSc.IntType)
    new_row = np.where(new_of_old >= 0, new_of_old - r0, -1).astype(PETSc.IntType)
    rng = Ac.getOwnershipRangeColumn()
    return OldEntries(ia, ja, v, rng, new_row, new_col, remote_columns(Ac, ja, new_col))


def set_rows(M: PETSc.Mat, rows: npt.NDArray, cols: npt.NDArray, vals: npt.NDArray) -> None:
    """Insert entries grouped by ascending local row (columns in any order) into ``M``."""
    n = M.getLocalSize()[0]
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=n))])
    M.setValuesCSR(indptr.astype(PETSc.IntType), np.asarray(cols, dtype=PETSc.IntType), vals)


#: Expected fill of ``A P_c`` relative to ``A`` and ``P_c`` (PETSc's default 2 reserves
#: room for twice ``A``'s entries; the product has few columns).
MATMULT_FILL = 0.05


def new_columns_part(
    A: PETSc.Mat, P: PETSc.Mat, cols: npt.NDArray[np.int64]
) -> list[tuple[npt.NDArray, npt.NDArray, npt.NDArray]]:
    """The entries of ``Pᵀ A P`` in the columns ``cols`` (this rank's, global) and their
    rows, by local row: ``Wᵀ = (A P_c)ᵀ P`` (``P_c``: ``P``'s columns ``cols``; the
    transpose of the small ``A P_c``, not of ``P``) gives the rows, ``W`` the columns
    outside them (``A`` symmetric)."""
    Pa = column_restriction(P, cols)
    APa = A.matMult(Pa, fill=MATMULT_FILL)
    Wt = APa.transposeMatMult(P)
    W = Wt.transpose(PETSc.Mat())
    for m in (Pa, APa):
        m.destroy()
    c0, c1 = P.getOwnershipRangeColumn()
    in_cols = np.zeros(c1 - c0, bool)
    in_cols[cols - c0] = True
    rw, cw, vw = csr_entries(W)
    fresh = ~in_cols[rw]  # (the rows of cols come from Wᵀ)
    parts = [csr_entries(Wt), (rw[fresh], cw[fresh], vw[fresh])]
    for m in (W, Wt):
        m.destroy()
    return parts


def update_galerkin(
    A: PETSc.Mat,
    P: PETSc.Mat,
    Ac: PETSc.Mat,
    new_of_old: npt.NDArray[np.int64],
    cols: npt.NDArray[np.int64],
) -> PETSc.Mat:
    """``Pᵀ A P`` from the earlier product ``Ac`` where only the coarse columns ``cols``
    (this rank's, global, of ``P``) are new (their aggregates' rows of ``A`` or of the
    near-nullspace changed); every other column is one of ``Ac``'s (``new_of_old``: the
    new index of each of this rank's columns of ``Ac``, ``-1``: replaced) with the same
    entries in the same rows (:func:`new_columns_part` gives the new ones).  The pattern
    is that of the product (the entries of ``A`` and ``P`` as stored).  ``Ac`` is
    destroyed once its entries are read; they are mapped and inserted in chunks
    (:data:`UPDATE_CHUNK`), so the old and the new product and their entries are not
    held at once."""
    parts = new_columns_part(A, P, cols)
    c0, c1 = P.getOwnershipRangeColumn()
    old = old_entries(Ac, new_of_old, c0)
    Ac.destroy()
    d_nnz, o_nnz = np.zeros(c1 - c0, np.int64), np.zeros(c1 - c0, np.int64)
    for r, c, _ in itertools.chain(parts, old.chunks()):
        diag = (c >= c0) & (c < c1)
        d_nnz += np.bincount(r[diag], minlength=c1 - c0)
        o_nnz += np.bincount(r[~diag], minlength=c1 - c0)
    N = P.getSize()[1]
    new = PETSc.Mat().createAIJ(
        size=((c1 - c0, N), (c1 - c0, N)),
        nnz=(d_nnz.astype(PETSc.IntType), o_nnz.astype(PETSc.IntType)),
        comm=P.getComm(),
    )
    for r, c, v in itertools.chain(parts, old.chunks()):  # (disjoint entries)
        set_rows(new, r, c, v)
    new.assemble()
    return new


def update_levels(levels: list[MultigridLevel], opts: CompressedMGOptions) -> bool:
    """Update the hierarchy ``levels`` of an operator that changed since its build only
    in rows and columns turned into identity rows or back (eliminated contact rows of
    another PDAS set): per level, the prolongator anew from the kept aggregation with
    the new identity rows, and the coarse operator anew only in the columns (and rows)
    of the aggregates whose rows or near-nullspace changed (:func:`update_galerkin`; the
    others' entries are those of the new product: their rows of ``A`` and ``P`` did not
    change).  Returns ``False`` (collective; the hierarchy is then to be built anew)
    when a level's nodes without coarse correction changed (another aggregation)."""
    comm = levels[0].A.getComm().tompi4py()
    Z, node_of_row = fine_near_nullspace(levels[0].A)
    changed, row_map = None, None
    for k, lev in enumerate(levels[:-1]):
        agg = lev.aggregation
        isolated = isolated_rows(lev.A)
        same = np.array_equal(node_skip(isolated, node_of_row, len(agg.skip)), agg.skip)
        if global_count(comm, np.array([not same])) > 0:
            return False
        moved = isolated != lev.isolated if changed is None else changed
        Z[isolated] = 0.0
        agg_of_row = agg.aggregates[node_of_row]
        hit = np.zeros(agg.count, bool)
        hit[agg_of_row[moved & (agg_of_row >= 0)]] = True
        kept = KeptColumns(lev.P, lev.ranks, lev.Zc, hit, row_map)
        P, Zc, ranks = compressed_prolongator(lev.A, Z, agg_of_row, agg.count, opts.rank_tol, kept)
        lev.P.destroy()  # (its kept columns copied: not held through the product)
        old_cols = np.repeat(np.where(hit, -1, ranks), lev.ranks)  # (-1 or the count)
        new_of_old = np.full(len(old_cols), -1, np.int64)
        new_of_old[old_cols >= 0] = columns_of(P, ranks, np.flatnonzero(~hit))
        cols = columns_of(P, ranks, np.flatnonzero(hit))
        Ac = update_galerkin(lev.A, P, levels[k + 1].A, new_of_old, cols)  # (frees the old)
        levels[k + 1].A, lev.P, lev.isolated, lev.ranks, lev.Zc = Ac, P, isolated, ranks, Zc
        changed = np.zeros(P.getLocalSize()[1], bool)
        changed[cols - P.getOwnershipRangeColumn()[0]] = True
        row_map = np.where(new_of_old >= 0, new_of_old - P.getOwnershipRangeColumn()[0], -1)
        Z, node_of_row = Zc, np.repeat(np.arange(agg.count), ranks)
    return global_count(comm, np.array([not same_depth(levels, opts)])) == 0


def same_depth(levels: list[MultigridLevel], opts: CompressedMGOptions) -> bool:
    """Whether :func:`build_levels` would stop coarsening where ``levels`` end (an
    updated hierarchy's coarse sizes may differ from the built one's)."""
    sizes = [lev.A.getSize()[0] for lev in levels]
    deep = all(n > opts.coarse_limit for n in sizes[:-1])
    shrink = all(c < 0.9 * f for f, c in zip(sizes[:-1], sizes[1:]))
    return deep and shrink and (sizes[-1] <= opts.coarse_limit or len(sizes) == opts.max_levels)


def _coarse_options(
    nranks: int, factor: str = "cholesky", solver: str = "mumps"
) -> dict[str, object]:
    """PETSc options of the coarse solve: the factorisation ``factor`` (``"cholesky"`` or
    ``"lu"``) by ``solver`` (``"mumps"`` or PETSc's own ``"petsc"``), on one rank
    (telescope) when there are several.  PETSc's own is ordered by quotient minimum
    degree (the coarse operators have no block size: nested dissection of their scalar
    graph gave 1.3–1.6 times the fill of GAMG's block-ordered coarse grid of the same
    size and nonzeros, QMD the same); MUMPS orders by its own choice."""
    lu: dict[str, object] = {"ksp_type": "preonly", "pc_type": factor}
    if solver == "mumps":
        lu["pc_factor_mat_solver_type"] = "mumps"
    else:
        lu["pc_factor_mat_ordering_type"] = "qmd"
    if nranks == 1:
        return {f"mg_coarse_{k}": v for k, v in lu.items()}
    return {
        "mg_coarse_ksp_type": "preonly",
        "mg_coarse_pc_type": "telescope",
        "mg_coarse_pc_telescope_reduction_factor": nranks,
        **{f"mg_coarse_telescope_{k}": v for k, v in lu.items()},
    }


#: The Chebyshev interval from the largest estimated eigenvalue ``e`` of the
#: Jacobi-preconditioned operator: ``(0.05 e, 1.05 e)`` (GAMG's smoothers' transform).
CHEBYSHEV_INTERVAL = (0.05, 1.05)


def chebyshev_bounds(A: PETSc.Mat, steps: int, ksp_type: str) -> tuple[float, float]:
    """The smoother's Chebyshev interval of ``A`` (:data:`CHEBYSHEV_INTERVAL`) as PETSc's
    Chebyshev estimates it: the largest Ritz value of ``steps`` Krylov steps
    (``ksp_type``) with Jacobi on ``A`` from a random right-hand side (fixed seed per
    rank)."""
    ksp = PETSc.KSP().create(A.getComm())
    ksp.setType(ksp_type)
    ksp.getPC().setType("jacobi")
    ksp.setOperators(A, A)
    ksp.setNormType(PETSc.KSP.NormType.NONE)
    ksp.setConvergenceTest(lambda *_: PETSc.KSP.ConvergedReason.ITERATING)
    ksp.setTolerances(max_it=steps)
    ksp.setComputeEigenvalues(True)
    b, x = A.createVecs()
    rng = np.random.default_rng(A.getComm().getRank())
    b.array[:] = rng.uniform(-1.0, 1.0, b.getLocalSize())
    x.set(0.0)
    ksp.solve(b, x)
    eig = ksp.computeEigenvalues()
    for obj in (ksp, b, x):
        obj.destroy()
    e = float(np.max(np.real(eig))) if len(eig) else 1.0
    return CHEBYSHEV_INTERVAL[0] * e, CHEBYSHEV_INTERVAL[1] * e


def smoother_options(levels: list[MultigridLevel], opts: CompressedMGOptions) -> dict:
    """The PCMG smoothers' options: Chebyshev/Jacobi, every level's interval given
    (estimated by :func:`chebyshev_bounds` where the level has none yet); without
    ``reuse_bounds``, PETSc's Chebyshev estimates them itself at every set-up."""
    out: dict[str, object] = {
        "mg_levels_ksp_type": "chebyshev",
        "mg_levels_pc_type": "jacobi",
        "mg_levels_ksp_max_it": opts.smooth_steps,
        "mg_levels_ksp_norm_type": "none",
        "mg_levels_ksp_convergence_test": "skip",
    }
    if not opts.reuse_bounds:
        lo, hi = CHEBYSHEV_INTERVAL
        return out | {
            "mg_levels_ksp_chebyshev_esteig": f"0,{lo},0,{hi}",
            "mg_levels_ksp_chebyshev_esteig_steps": opts.esteig_steps,
            "mg_levels_esteig_ksp_type": opts.esteig_ksp,
        }
    n = len(levels)
    for k, lev in enumerate(levels[:-1]):
        if lev.bounds is None:
            lev.bounds = chebyshev_bounds(lev.A, opts.esteig_steps, opts.esteig_ksp)
        emin, emax = lev.bounds
        out[f"mg_levels_{n - 1 - k}_ksp_chebyshev_eigenvalues"] = f"{emin!r},{emax!r}"
    return out


def multigrid_pc(levels: list[MultigridLevel], opts: CompressedMGOptions) -> PETSc.PC:
    """A PCMG over ``levels`` (finest first): Chebyshev/Jacobi smoothers
    (:func:`smoother_options`), the coarsest level factorised (``coarse_factor``)."""
    A = levels[0].A
    comm = A.getComm()
    prefix = f"bc_cmg{next(_COUNTER)}_"
    options = {
        **smoother_options(levels, opts),
        **_coarse_options(comm.getSize(), opts.coarse_factor, opts.coarse_solver),
    }
    db = PETSc.Options()
    for key, value in options.items():
        db[prefix + key] = value
    try:
        pc = PETSc.PC().create(comm)
        pc.setOptionsPrefix(prefix)
        pc.setType("mg")
        n = len(levels)
        pc.setMGLevels(n)
        pc.setMGType(PETSc.PC.MGType.MULTIPLICATIVE)
        cycle = PETSc.PC.MGCycleType.W if opts.cycle == "w" else PETSc.PC.MGCycleType.V
        pc.setMGCycleType(cycle)
        for k, lev in enumerate(levels):  # PCMG numbers the levels coarsest first
            level = n - 1 - k
            if lev.P is not None:
                pc.setMGInterpolation(level, lev.P)
            ksp = pc.getMGCoarseSolve() if level == 0 else pc.getMGSmoother(level)
            ksp.setOperators(lev.A, lev.A)
            ksp.setFromOptions()
        pc.setOperators(A, A)
        pc.setUp()
    finally:
        for key in options:
            db.delValue(prefix + key)
    return pc


class CompressedMultigrid:
    """Context of a ``python`` PC: the compressed-aggregation hierarchy of the PC's
    operator (module docstring), rebuilt by PETSc's set-up when the operator changed
    and the preconditioner is not kept.

    Attributes
    ----------
    sizes, nonzeros
        Global rows and nonzeros of every level's operator, finest first (last build).
    aggregates, ranks
        The aggregate of every node of the finest level (this rank's local nodes,
        ``-1``: none) and per aggregate its number of columns.
    setup_flops
        This rank's operations of the last build: the Galerkin products, and the
        smoothers' eigenvalue estimates with the coarse factorisation.
    builds, kept_levels, setup_seconds
        Builds of the hierarchy, the levels over all builds whose aggregation was kept
        from the build before (this rank's; ``reuse_aggregates``) and the wall time of
        all builds on this rank.
    updates
        The builds that updated the kept hierarchy (``local_update``).
    """

    def __init__(self, options: CompressedMGOptions | None = None):
        self.options = options or CompressedMGOptions()
        self.levels: list[MultigridLevel] = []
        self.mg: PETSc.PC | None = None
        self.sizes: list[int] = []
        self.nonzeros: list[int] = []
        self.ranks: npt.NDArray[np.int64] = np.zeros(0, np.int64)
        self.aggregates: npt.NDArray[np.int64] = np.zeros(0, np.int64)
        self.setup_flops = (0.0, 0.0)
        self.builds = 0
        self.kept_levels = 0
        self.setup_seconds = 0.0
        self.updates = 0
        self._update_allowed = False

    def allow_update(self, allowed: bool) -> None:
        """Tell the next set-up whether the operator differs from that of the last
        build only in rows and columns eliminated (identity rows) in one and not in the
        other — then the hierarchy may be updated (``local_update``) — or otherwise."""
        self._update_allowed = bool(allowed)

    def setUp(self, pc: PETSc.PC) -> None:
        """Build the hierarchy of the PC's preconditioning matrix (or update it:
        :meth:`allow_update`)."""
        t0 = time.perf_counter()
        _, A = pc.getOperators()
        f0 = PETSc.Log.getFlops()
        if not self._update(A):
            kept = self.kept_aggregations() if self.options.reuse_aggregates else None
            self._free()
            self.levels = build_levels(A, self.options, kept)
            self.kept_levels += sum(
                1
                for k, lev in enumerate(self.levels[:-1])
                if kept and k < len(kept) and lev.aggregation is kept[k]
            )
        self.builds += 1
        f1 = PETSc.Log.getFlops()
        self.mg = multigrid_pc(self.levels, self.options)
        self.setup_flops = (f1 - f0, PETSc.Log.getFlops() - f1)
        self.sizes = [lev.A.getSize()[0] for lev in self.levels]
        self.nonzeros = [
            int(lev.A.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"]) for lev in self.levels
        ]
        first = self.levels[0]
        none = np.zeros(0, np.int64)
        self.aggregates = first.aggregates if first.aggregates is not None else none
        self.ranks = first.ranks if first.ranks is not None else none
        self.setup_seconds += time.perf_counter() - t0

    def _update(self, A: PETSc.Mat) -> bool:
        """Update the kept hierarchy of ``A`` in place if allowed and possible
        (:func:`update_levels`)."""
        allowed, self._update_allowed = self._update_allowed, False
        opts = self.options
        if not (allowed and opts.local_update and opts.reuse_aggregates and len(self.levels) > 1):
            return False
        if self.levels[0].A.handle != A.handle:
            return False
        if self.mg is not None:
            self.mg.destroy()
            self.mg = None
        if not update_levels(self.levels, self.options):
            return False
        self.updates += 1
        self.kept_levels += len(self.levels) - 1
        return True

    def kept_aggregations(self) -> list[Aggregation] | None:
        """The aggregations of the current hierarchy, finest first (``None``: none)."""
        kept = [lev.aggregation for lev in self.levels[:-1]]
        return kept if kept and all(a is not None for a in kept) else None

    def apply(self, pc: PETSc.PC, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """One cycle."""
        self.mg.apply(x, y)

    def applyTranspose(self, pc: PETSc.PC, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """One transposed cycle."""
        self.mg.applyTranspose(x, y)

    def view(self, pc: PETSc.PC, viewer: PETSc.Viewer) -> None:
        """The level sizes."""
        viewer.printfASCII(f"compressed multigrid: rows {self.sizes}, nonzeros {self.nonzeros}\n")

    def destroy(self, pc: PETSc.PC) -> None:
        """Free the hierarchy."""
        self._free()

    def reset(self, pc: PETSc.PC) -> None:
        """Free the hierarchy (``PCReset``, e.g. ``KSPReset``: the next set-up builds it)."""
        self._free()

    def _free(self) -> None:
        if self.mg is not None:
            self.mg.destroy()
            self.mg = None
        for k, lev in enumerate(self.levels):
            if lev.P is not None:
                lev.P.destroy()
            if k > 0:
                lev.A.destroy()
        self.levels = []
