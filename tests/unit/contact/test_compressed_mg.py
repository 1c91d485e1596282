"""The compressed-aggregation multigrid of the iterative contact path
(bonecontact.contact.compressed_mg, ``LinearOptions.multigrid = "compressed"``).

Family: load-driven (the body held only by the contact) and clamped (the top face
displaced), 2D and 3D, stiffness contrast 1e3 (the problems of test_krylov_tolerance),
solved to the scene tolerance 1e-6 (final Krylov rtol 1e-8).  Reference, independent of
the Krylov path: the direct solver (MUMPS LU, low-rank PDAS).

* The solution: the direct path's active set node by node, its PDAS iterations, its
  displacement and pressure to 1e-6 (the solve tolerance; GAMG's path: ≤ 4e-8).
* The coarse grid: the first coarse operator has as many rows as the aggregates have
  columns, and an aggregate away from the contact rows and supports has as many columns
  as the rigid motions of its nodes have independent components — counted here from the
  node coordinates and the bodies (cell tags), not from the condensed near-nullspace the
  hierarchy compresses: six (three in 2D) inside one body, their sum where an aggregate
  reaches into both.
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest
from test_krylov_tolerance import _clamped, _load_driven, _rel_max

from bonecontact.contact.compressed_mg import CompressedMultigrid
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


def _run(kind: str, dim: int, linear: str, cycle: str = "w") -> dict:
    """One contact solve: displacement (owned), pressure, status, PDAS iterations and,
    with the compressed hierarchy, its first level and the geometry of the nodes."""
    key = (kind, dim, linear, cycle)
    if key in _CACHE:
        return _CACHE[key]
    options = None
    if linear == "iterative":
        options = PDASOptions(linear=LinearOptions(multigrid="compressed", multigrid_cycle=cycle))
    build = _load_driven if kind == "load-driven" else _clamped
    integ, m, _ = build(dim, linear, RTOL if linear == "iterative" else 1e-12, options)
    r = integ.last_contact
    n = m.V.dofmap.index_map.size_local * dim
    out = {
        "u": integ.u.x.array[:n].copy(),
        "p": r.pressure[0].copy(),
        "status": list(r.status[0]),
        "pdas": r.iterations,
        "active": int(sum(r.n_active)),
    }
    if linear == "iterative":
        ctx = integ.contact.ksp.getPC().getPythonContext()
        assert isinstance(ctx, CompressedMultigrid)
        out |= {"sizes": list(ctx.sizes), "ranks": ctx.ranks.copy()}
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
