"""The compressed-aggregation multigrid of the iterative contact path
(bonecontact.contact.compressed_mg, ``LinearOptions.multigrid = "compressed"``).

Family: load-driven (the body held only by the contact) and clamped (the top face
displaced), 2D and 3D, stiffness contrast 1e3 (the problems of test_krylov_tolerance),
solved to the scene tolerance 1e-6 (final Krylov rtol 1e-8).  Reference, independent of
the Krylov path: the direct solver (MUMPS LU, low-rank PDAS).

* The solution: the direct path's active set node by node, its PDAS iterations, its
  displacement and pressure to 1e-6 (the solve tolerance; GAMG's path: ≤ 4e-8).
* Rebuilds keep every level's aggregation (``reuse_aggregates``): the direct path's answer,
  at most one more CG iteration in all than aggregating anew at every build, and within
  10 % of GAMG's total CG iterations; every build after the first keeps all levels'.
* The prolongator (stacked SVDs) equals the one of an SVD per aggregate, column by
  column, on blocks of every rank (zero blocks, rank-deficient ones); an aggregation is
  kept only while the nodes without coarse correction stay the same.
* The coarse grid: the first coarse operator has as many rows as the aggregates have
  columns, and an aggregate away from the contact rows and supports has as many columns
  as the rigid motions of its nodes have independent components — counted here from the
  node coordinates and the bodies (cell tags), not from the condensed near-nullspace the
  hierarchy compresses: six (three in 2D) inside one body, their sum where an aggregate
  reaches into both.
"""

from __future__ import annotations

import functools

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest
from laplacian import laplacian_1d
from test_krylov_tolerance import _clamped, _load_driven, _rel_max

from bonecontact.contact import compressed_mg, krylov
from bonecontact.contact.compressed_mg import CompressedMGOptions, CompressedMultigrid
from bonecontact.contact.krylov import krylov_rtol
from bonecontact.contact.options import LinearOptions, PDASOptions

COMM = MPI.COMM_WORLD
RTOL = krylov_rtol(1e-6)
_CACHE: dict = {}


def _rigid_rank(x: np.ndarray, dim: int) -> int:
    """Independent components of the rigid motions of the points ``x`` (rows)."""
    blocks = []
    for p in x:
        if dim == 2:
            blocks.append([[1.0, 0.0, -p[1]], [0.0, 1.0, p[0]]])
        else:
            blocks.append(
                [
                    [1.0, 0.0, 0.0, 0.0, p[2], -p[1]],
                    [0.0, 1.0, 0.0, -p[2], 0.0, p[0]],
                    [0.0, 0.0, 1.0, p[1], -p[0], 0.0],
                ]
            )
    M = np.concatenate(blocks)
    M[:, dim:] /= max(float(np.abs(x).max()), 1e-300)  # rotations on the translations' scale
    s = np.linalg.svd(M, compute_uv=False)
    return int((s > 1e-8 * s[0]).sum())


def _geometry(integ, m, dim: int) -> dict:
    """Per owned node: coordinates, body (cell tag), slave node, supported (Dirichlet)."""
    V = m.V
    n = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:n, :dim]
    body = np.full(n, -1)
    for tag in np.unique(m.cell_tags.values):
        cells = m.cell_tags.indices[m.cell_tags.values == tag]
        nodes = np.unique(V.dofmap.list[cells].ravel())
        body[nodes[nodes < n]] = tag
    slave = np.zeros(n, bool)
    for itf in integ.contact.interfaces:
        slave[itf.blocks[itf.blocks < n]] = True
    bc = m.bc_dofs() // dim
    supported = np.zeros(n, bool)
    supported[bc[bc < n]] = True
    return {"x": x, "body": body, "slave": slave, "supported": supported}


def _run(
    kind: str,
    dim: int,
    linear: str,
    cycle: str = "w",
    multigrid: str = "compressed",
    keep=True,
    update=True,
    factor="cholesky",
    solver="mumps",
    bounds=True,
) -> dict:
    """One contact solve: displacement (owned), pressure, status, PDAS and CG iterations
    and, with the compressed hierarchy (aggregations kept across rebuilds: ``keep``;
    hierarchies updated for a new set: ``update``; coarsest level factorised by
    ``factor`` by ``solver``; updated hierarchies keep their smoothers' intervals:
    ``bounds``), its first level, its builds and the geometry of the nodes."""
    key = (kind, dim, linear, cycle, multigrid, keep, update, factor, solver, bounds)
    if key in _CACHE:
        return _CACHE[key]
    options = None
    if linear == "iterative":
        lin = LinearOptions(multigrid=multigrid, multigrid_cycle=cycle)
        options = PDASOptions(linear=lin)
    build = _load_driven if kind == "load-driven" else _clamped
    made = functools.partial(
        CompressedMGOptions,
        reuse_aggregates=keep,
        local_update=update,
        coarse_factor=factor,
        coarse_solver=solver,
        reuse_bounds=bounds,
    )
    saved, krylov.CompressedMGOptions = krylov.CompressedMGOptions, made
    try:
        integ, m, _ = build(dim, linear, RTOL if linear == "iterative" else 1e-12, options)
    finally:
        krylov.CompressedMGOptions = saved
    r = integ.last_contact
    n = m.V.dofmap.index_map.size_local * dim
    out = {
        "u": integ.u.x.array[:n].copy(),
        "p": r.pressure[0].copy(),
        "status": list(r.status[0]),
        "pdas": r.iterations,
        "active": int(sum(r.n_active)),
        "its": [h.get("linear_iterations", 0) for h in r.history],
    }
    if linear == "iterative" and multigrid == "compressed":
        ctx = integ.contact.ksp.getPC().getPythonContext()
        assert isinstance(ctx, CompressedMultigrid)
        out |= {"sizes": list(ctx.sizes), "ranks": ctx.ranks.copy()}
        out |= {"builds": ctx.builds, "kept_levels": ctx.kept_levels, "updates": ctx.updates}
        out |= {"aggregates": ctx.aggregates.copy(), **_geometry(integ, m, dim)}
    integ.destroy()
    _CACHE[key] = out
    return out


CASES = [(k, d, "w") for k in ("load-driven", "clamped") for d in (2, 3)]
CASES += [("load-driven", 3, "v"), ("clamped", 3, "v")]


@pytest.mark.parametrize("kind,dim,cycle", CASES)
def test_compressed_hierarchy_gives_the_direct_solution(kind, dim, cycle):
    """The direct path's active set (node by node) and PDAS iterations; displacement and
    pressure to the solve tolerance (1e-6)."""
    direct, got = _run(kind, dim, "direct"), _run(kind, dim, "iterative", cycle)
    assert direct["active"] >= 3  # a contact zone, not a point
    assert got["status"] == direct["status"]
    assert got["active"] == direct["active"]
    assert got["pdas"] == direct["pdas"]
    assert _rel_max(got["u"], direct["u"]) < 1e-6
    assert _rel_max(got["p"], direct["p"]) < 1e-6


@pytest.mark.parametrize("kind,dim", [(k, d) for k in ("load-driven", "clamped") for d in (2, 3)])
def test_coarse_grid_has_the_columns_of_the_rigid_motions(kind, dim):
    """First coarse operator: rows = Σ columns of the aggregates; an aggregate without
    slave nodes or supported nodes: the independent rigid motions of its nodes, body by
    body (6 / 3 inside one body); the coarse grid smaller than GAMG's 12 (6) per aggregate."""
    got = _run(kind, dim, "iterative")
    ranks, agg = got["ranks"], got["aggregates"]
    assert len(got["sizes"]) >= 2
    assert COMM.allreduce(int(ranks.sum()), op=MPI.SUM) == got["sizes"][1]
    checked = 0
    for a in range(len(ranks)):
        nodes = np.flatnonzero(agg == a)
        if got["slave"][nodes].any() or got["supported"][nodes].any():
            continue
        x, body = got["x"][nodes], got["body"][nodes]
        expected = sum(_rigid_rank(x[body == b], dim) for b in np.unique(body))
        assert ranks[a] == expected
        checked += 1
    nmodes = 3 if dim == 2 else 6
    assert COMM.allreduce(checked, op=MPI.SUM) >= 0.5 * COMM.allreduce(len(ranks), op=MPI.SUM)
    assert int(ranks.max(initial=0)) <= 2 * nmodes
    n_agg = COMM.allreduce(len(ranks), op=MPI.SUM)
    assert got["sizes"][1] < 2 * nmodes * n_agg


@pytest.mark.parametrize("kind,dim", [(k, d) for k in ("load-driven", "clamped") for d in (2, 3)])
def test_kept_aggregations_keep_the_answer_and_iterations(kind, dim):
    """Aggregations kept across the rebuilds of the PDAS sets (the default): the direct
    path's set and answer, every build after the first keeps every level's aggregation,
    at most two CG iterations more in all than aggregating anew at every build
    (measured: equal, and 48 against 46 on the 2D load-driven case since the rescaled
    warm start, which took the fresh hierarchies' second solve from 12 to 10 iterations
    and left the kept ones' at 11), and at most 10 % more than GAMG's path (measured
    2D 48/51, 32/33; 3D 32/37, 29/27)."""
    direct = _run(kind, dim, "direct")
    kept, fresh = _run(kind, dim, "iterative"), _run(kind, dim, "iterative", keep=False)
    gamg = _run(kind, dim, "iterative", multigrid="gamg")
    for got in (kept, fresh, gamg):
        assert got["status"] == direct["status"]
        assert got["pdas"] == direct["pdas"]
        assert _rel_max(got["u"], direct["u"]) < 1e-6
        assert _rel_max(got["p"], direct["p"]) < 1e-6
    levels = len(kept["sizes"]) - 1
    assert kept["builds"] >= direct["pdas"] and levels >= 1
    assert kept["kept_levels"] == (kept["builds"] - 1) * levels
    assert fresh["kept_levels"] == 0
    assert sum(kept["its"]) <= sum(fresh["its"]) + 2
    assert sum(kept["its"]) <= 1.1 * sum(gamg["its"])


def _chain(n_nodes: int, bs: int, isolated: np.ndarray) -> PETSc.Mat:
    """A block chain of this rank's ``n_nodes`` nodes (rows of node ``i`` coupled to
    those of ``i ± 1``, distributed rank after rank without coupling between ranks);
    ``isolated`` rows keep only their diagonal (eliminated rows)."""
    n = n_nodes * bs
    start = COMM.exscan(n) or 0
    rows = []
    for r in range(n):
        node = r // bs
        cols = [c for c in range(max(node - 1, 0) * bs, min(node + 2, n_nodes) * bs)]
        if isolated[r]:
            cols = [r]
        rows.append([(c, 4.0 if c == r else -0.5) for c in cols])
    indptr = np.concatenate([[0], np.cumsum([len(x) for x in rows])]).astype(PETSc.IntType)
    indices = np.array([c + start for x in rows for c, _ in x], PETSc.IntType)
    data = np.array([v for x in rows for _, v in x])
    A = PETSc.Mat().createAIJ(size=((n, None), (n, None)), csr=(indptr, indices, data), comm=COMM)
    A.assemble()
    return A


def _reference_prolongator(Z, agg_of_row, n_agg, tol):
    """An SVD per aggregate (the independent reference): per aggregate its rows, its
    kept left singular vectors and ``Σ Vᵀ``."""
    out = []
    for a in range(n_agg):
        rows = np.flatnonzero(agg_of_row == a)
        U, s, Vt = np.linalg.svd(Z[rows], full_matrices=False)
        r = int((s > tol * s[0]).sum()) if s.size and s[0] > 0.0 else 0
        out.append((rows, U[:, :r], s[:r, None] * Vt[:r]))
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_stacked_svds_give_the_per_aggregate_prolongator(seed):
    """Random aggregates of 1-9 nodes of three rows, near-nullspace blocks of 6 columns
    with zero blocks and rank-deficient ones (columns zero or repeated): the prolongator's
    rows, columns and values, the coarse near-nullspace and the columns per aggregate
    equal an SVD per aggregate exactly (the same LAPACK call per block)."""
    rng = np.random.default_rng(seed + 10 * COMM.rank)
    bs, n_nodes = 3, 60 + 7 * COMM.rank
    agg_of_node = np.sort(rng.integers(-1, 14, n_nodes))  # (-1: not aggregated)
    n_agg = 14
    Z = rng.standard_normal((n_nodes * bs, 6))
    agg_of_row = np.repeat(agg_of_node, bs)
    Z[agg_of_row == 3] = 0.0  # a zero block
    Z[agg_of_row % 4 == 1, 3:] = 0.0  # rank ≤ 3
    Z[agg_of_row % 5 == 2, 5] = Z[agg_of_row % 5 == 2, 0]  # a repeated column
    A = _chain(n_nodes, bs, np.zeros(n_nodes * bs, bool))
    P, Zc, ranks = compressed_mg.compressed_prolongator(A, Z, agg_of_row, n_agg, 1e-8)
    ref = _reference_prolongator(Z, agg_of_row, n_agg, 1e-8)
    c0 = P.getOwnershipRangeColumn()[0]
    dense = P.getDiagonalBlock().convert("dense") if COMM.size > 1 else P.convert("dense")
    D = dense.getDenseArray()
    col = 0
    for a, (rows, U, zc) in enumerate(ref):
        r = U.shape[1]
        assert ranks[a] == r
        assert np.array_equal(D[rows, col : col + r], U)
        assert np.array_equal(Zc[col : col + r], zc)
        others = np.setdiff1d(np.arange(D.shape[0]), rows)
        assert not D[others, col : col + r].any()
        col += r
    assert col == D.shape[1] == P.getLocalSize()[1] and c0 == (COMM.exscan(col) or 0)
    assert not D[agg_of_row < 0].any()
    assert ranks[3] == 0 and ranks[1] <= 3
    for obj in (P, A, dense):
        obj.destroy()


def test_aggregation_kept_only_while_the_skipped_nodes_stay():
    """A kept aggregation is returned (the same object) when the values change but the
    nodes without coarse correction do not; a node whose rows all become isolated makes
    a new aggregation that skips it."""
    bs, n_nodes = 3, 40
    node_of_row = np.arange(n_nodes * bs) // bs
    iso = np.zeros(n_nodes * bs, bool)
    A = _chain(n_nodes, bs, iso)
    first, isolated = compressed_mg.aggregation(A, node_of_row, 2, 0.01, None)
    assert not isolated.any() and first.count >= 1 and (first.aggregates >= 0).all()
    iso[[4, 5 * bs + 1]] = True  # single rows of two nodes: their nodes still aggregated
    B = _chain(n_nodes, bs, iso)
    again, isolated = compressed_mg.aggregation(B, node_of_row, 2, 0.01, first)
    assert again is first and np.array_equal(isolated, iso)
    iso[6 * bs : 7 * bs] = True  # all rows of node 6
    C = _chain(n_nodes, bs, iso)
    new, isolated = compressed_mg.aggregation(C, node_of_row, 2, 0.01, first)
    assert new is not first and np.array_equal(isolated, iso)
    assert new.aggregates[6] == -1 and new.skip[6] and new.skip.sum() == 1
    for obj in (A, B, C):
        obj.destroy()


@pytest.mark.parametrize("kind,dim", [(k, d) for k in ("load-driven", "clamped") for d in (2, 3)])
def test_updated_hierarchy_gives_the_answer_of_a_built_one(kind, dim):
    """A new PDAS set updates the kept hierarchy (``local_update``, the default) instead
    of building it anew: the same sets node by node, PDAS iterations and CG iterations
    per PDAS iteration as with every hierarchy built (the same preconditioner up to
    rounding), the displacement to 1e-10 and the pressure to 1e-9; every build after
    the first is an update (measured: all).  Both with the smoothers' intervals
    estimated at every set-up (an update keeps them by default: compared in
    :func:`test_kept_smoother_intervals_give_the_answer_of_new_estimates`)."""
    updated = _run(kind, dim, "iterative", bounds=False)
    built = _run(kind, dim, "iterative", update=False, bounds=False)
    assert updated["status"] == built["status"]
    assert updated["pdas"] == built["pdas"]
    assert updated["its"] == built["its"]
    assert _rel_max(updated["u"], built["u"]) < 1e-10
    assert _rel_max(updated["p"], built["p"]) < 1e-9
    assert built["updates"] == 0 and updated["builds"] == built["builds"] >= 2
    assert updated["updates"] == updated["builds"] - 1


@pytest.mark.parametrize("kind,dim", [(k, d) for k in ("load-driven", "clamped") for d in (2, 3)])
def test_cholesky_coarse_grid_gives_the_answer_of_lu(kind, dim):
    """The coarsest level factorised by Cholesky (the default) against LU: the same sets,
    PDAS and CG iterations per PDAS iteration, displacement to 1e-10, pressure to 1e-9
    (the two factors solve the same symmetric system; measured at 65k dofs 9e-15)."""
    chol, lu = _run(kind, dim, "iterative"), _run(kind, dim, "iterative", factor="lu")
    assert chol["status"] == lu["status"]
    assert chol["pdas"] == lu["pdas"]
    assert chol["its"] == lu["its"]
    assert _rel_max(chol["u"], lu["u"]) < 1e-10
    assert _rel_max(chol["p"], lu["p"]) < 1e-9


@pytest.mark.parametrize(
    "kind,dim,factor",
    [(k, d, f) for k in ("load-driven", "clamped") for d in (2, 3) for f in ("cholesky", "lu")],
)
def test_mumps_coarse_grid_gives_the_answer_of_petscs(kind, dim, factor):
    """The coarsest level factorised by MUMPS (the default) against PETSc's own
    factorisation of the same kind: the same sets, PDAS
    and CG iterations per PDAS iteration, displacement to 1e-10, pressure to 1e-9 (two
    direct solves of the same coarse system; measured at 65k dofs 3e-14)."""
    mumps = _run(kind, dim, "iterative", factor=factor, solver="mumps")
    petsc = _run(kind, dim, "iterative", factor=factor, solver="petsc")
    assert mumps["status"] == petsc["status"]
    assert mumps["pdas"] == petsc["pdas"]
    assert mumps["its"] == petsc["its"]
    assert _rel_max(mumps["u"], petsc["u"]) < 1e-10
    assert _rel_max(mumps["p"], petsc["p"]) < 1e-9


@pytest.mark.parametrize("kind,dim", [(k, d) for k in ("load-driven", "clamped") for d in (2, 3)])
def test_kept_smoother_intervals_give_the_answer_of_new_estimates(kind, dim):
    """Updated hierarchies keeping every level's Chebyshev interval from the build (the
    default) against intervals estimated anew at every set-up: the same sets and PDAS
    iterations, at most one CG iteration more in all, displacement and pressure within
    the Krylov tolerance's 1e-6 of each other (measured: the same iterations)."""
    kept, new = _run(kind, dim, "iterative"), _run(kind, dim, "iterative", bounds=False)
    assert kept["updates"] >= 1
    assert kept["status"] == new["status"]
    assert kept["pdas"] == new["pdas"]
    assert sum(kept["its"]) <= sum(new["its"]) + 1
    assert _rel_max(kept["u"], new["u"]) < 1e-6
    assert _rel_max(kept["p"], new["p"]) < 1e-6


@pytest.mark.parametrize("n", [50, 400])
def test_chebyshev_interval_of_a_laplacian(n):
    """The smoother's interval of the 1D Laplacian (Dirichlet ends), whose Jacobi-scaled
    eigenvalues are ``1 − cos(kπ/(n+1))``: from 10 CG steps the largest estimate ``e`` is
    at most the largest eigenvalue (a Ritz value) and within 2 % of it, and the interval
    is ``(0.05 e, 1.05 e)``, covering the largest eigenvalue."""
    A = laplacian_1d(n, COMM)
    lam = 1.0 + np.cos(np.pi / (n + 1))
    lo, hi = compressed_mg.chebyshev_bounds(A, 10, "cg")
    A.destroy()
    e = hi / 1.05
    assert lo == pytest.approx(0.05 * e, rel=1e-12)
    assert 0.98 * lam <= e <= lam * (1.0 + 1e-10)
    assert hi >= lam


def test_coarse_factor_is_checked():
    """An unknown coarse factorisation or factoring package is refused, naming the
    allowed ones."""
    with pytest.raises(ValueError, match="'cholesky' or 'lu'"):
        CompressedMGOptions(coarse_factor="qr")
    with pytest.raises(ValueError, match="'mumps' or 'petsc'"):
        CompressedMGOptions(coarse_solver="superlu")


def _nodal_modes(n_nodes: int, bs: int) -> PETSc.NullSpace:
    """Translations and ``x``-weighted translations of a chain of nodes (``x`` the
    node's global index): six independent vectors per aggregate of two or more nodes."""
    start = COMM.exscan(n_nodes) or 0
    x = (start + np.arange(n_nodes, dtype=float)) / 10.0
    vecs = []
    for weight in (np.ones(n_nodes), x):
        for c in range(bs):
            v = PETSc.Vec().createMPI((n_nodes * bs, None), comm=COMM)
            arr = np.zeros(n_nodes * bs)
            arr[c::bs] = weight
            v.array[:] = arr
            vecs.append(v)
    return PETSc.NullSpace().create(vectors=vecs, comm=COMM)


def _free_levels(levels: list, B: PETSc.Mat) -> None:
    """Destroy the levels' prolongators and coarse operators (not the fine ``B``)."""
    for lev in levels:
        if lev.P is not None:
            lev.P.destroy()
        if lev.A.handle != B.handle:
            lev.A.destroy()


def _eliminated(A0: PETSc.Mat, B: PETSc.Mat, rows: list[int]) -> None:
    """``B ← A0`` with the (this rank's, local) ``rows`` eliminated symmetrically, in
    place as the contact solver does (same pattern)."""
    A0.copy(B, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
    start = B.getOwnershipRange()[0]
    B.zeroRowsColumns(np.asarray(rows, PETSc.IntType) + start, diag=4.0)


def _chain_to_update(n_nodes: int = 60, bs: int = 3):
    """The chain operator ``A0`` (nothing eliminated), its copy ``B`` to eliminate rows
    in, with the nodal modes as near-nullspace, and those modes."""
    A0 = _chain(n_nodes, bs, np.zeros(n_nodes * bs, bool))
    B = A0.duplicate(copy=True)
    B.setBlockSize(bs)
    nns = _nodal_modes(n_nodes, bs)
    B.setNearNullSpace(nns)
    return A0, B, nns


@pytest.mark.parametrize(
    "first,second",
    [
        ([], [4, 10, 11]),  # rows eliminated
        ([4, 10, 11], [7]),  # eliminated rows restored, another one eliminated
        ([30, 31, 33, 34, 36, 37], []),  # restored: two of three rows of three nodes
        ([], [30, 31, 33, 34, 36, 37]),  # an aggregate loses columns (rank 6 → fewer)
        ([4, 10, 11], [4, 10, 11]),  # nothing changed: no aggregate recomputed
        ("rank 0", [4, 10, 11]),  # changed on the first rank only (others: nothing)
    ],
)
@pytest.mark.parametrize("chunk", [compressed_mg.UPDATE_CHUNK, 7])
def test_update_equals_a_new_build(first, second, chunk, monkeypatch):
    """The hierarchy of an operator with rows ``first`` eliminated, updated after the
    same matrix changed to rows ``second`` eliminated (:func:`update_levels`), against a
    hierarchy built anew from it with the same aggregations: the same levels and sizes,
    the prolongators exactly, the coarse operators to 1e-14 of their norm (the changed
    entries are summed in another order); the update is taken (it returns ``True``),
    and in each case that changes rows some aggregate's columns change (the coarse
    level's size); also when nothing changed, or only on one rank.  The update's old
    entries are mapped and the kept prolongator copied in chunks of ``chunk`` entries
    (7: many chunks of a few rows each, as the large meshes' updates)."""
    monkeypatch.setattr(compressed_mg, "UPDATE_CHUNK", chunk)
    opts = CompressedMGOptions(coarse_limit=24)
    A0, B, nns = _chain_to_update()
    if first == "rank 0":
        first, second = [], second if COMM.rank == 0 else []
    _eliminated(A0, B, first)
    levels = compressed_mg.build_levels(B, opts)
    columns = levels[0].ranks.copy()
    _eliminated(A0, B, second)
    assert compressed_mg.update_levels(levels, opts)
    if first != second:  # (each such case: 96 ↔ 95 or 94 rows)
        assert not np.array_equal(levels[0].ranks, columns)
    fresh = compressed_mg.build_levels(B, opts, [lev.aggregation for lev in levels[:-1]])
    assert len(levels) == len(fresh) >= 3
    for got, ref in zip(levels, fresh):
        assert got.A.getSizes() == ref.A.getSizes()
        if ref.P is not None:
            assert np.array_equal(got.ranks, ref.ranks)
            diff = got.P.copy()
            diff.axpy(-1.0, ref.P)
            assert diff.norm(PETSc.NormType.INFINITY) == 0.0
            diff.destroy()
        if got.A.handle != B.handle:
            diff = got.A.copy()
            diff.axpy(-1.0, ref.A)
            assert diff.norm() <= 1e-14 * ref.A.norm()
            diff.destroy()
    _free_levels(levels + fresh, B)
    for obj in (A0, B, nns):
        obj.destroy()


def test_update_refused_when_a_node_loses_its_coarse_correction():
    """All rows of a node eliminated after the build: another aggregation is needed, the
    update returns ``False`` (the caller builds anew)."""
    opts = CompressedMGOptions(coarse_limit=24)
    A0, B, nns = _chain_to_update()
    levels = compressed_mg.build_levels(B, opts)
    _eliminated(A0, B, [9, 10, 11])
    assert not compressed_mg.update_levels(levels, opts)
    _free_levels(levels, B)
    for obj in (A0, B, nns):
        obj.destroy()
