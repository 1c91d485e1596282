"""Friction with the iterative linear solver (issue 28; docs/theory/pdas.md#friction-rows-in-
the-iterative-solver): the coupled rows (3D Newton slip rows, edge nodes) posed for the
Krylov solver give the direct path's answer.

A soft block (20 MPa) on a stiff one (17 GPa, clamped at its base), non-matching meshes.
Family: 2D/3D × Tresca/Coulomb × static load-driven (the soft block held only by the
contact under a graded pressure and a tangential traction of half the friction
capacity: it sticks in the middle and slips at the edges) / dynamic oblique impact (no
loads, initial velocity) × GAMG/compressed hierarchy.  Static Coulomb uses the fixed
point (its bound follows the current pressure: a load-driven block has no frictionless
first step), the impact the semi-implicit rule.  Reference: the direct path (MUMPS,
low-rank PDAS) of the same problem.  Before the fix, the 2D drag's edge node made CG
stop with an indefinite preconditioner and the compressed hierarchy's GMRES broke down.

Bound: the answer is the solution of the last system to the Krylov tolerance (rtol
1e-12, on the true residual with GMRES and right preconditioning, the preconditioned one
with CG): the displacement error is at most ``κ · rtol``; pressures and tractions are
residuals of the contact rows (``w = r − Ã Ũ``), their error ``Ã δŨ`` can be larger by
the operator's norm over theirs.  Measured (serial, the 16 cases): displacements within
5e-12, pressures and tractions within 8.4e-10 (the impacts; 1.2e-12 static) of their
largest values; the test allows 1e-8.  The sets and PDAS iterations are the direct
path's exactly.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from dolfinx import fem
from two_blocks import P0, W, friction_blocks

from bonecontact.contact.coupled_rows import krylov_groups, spring_split
from bonecontact.contact.friction import FrictionLaw, slip_newton_rows, with_normal_row
from bonecontact.contact.interface import build_interface
from bonecontact.contact.options import LinearOptions, PDASOptions
from bonecontact.contact.pdas import ContactSolver
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics

COMM = MPI.COMM_WORLD
DT, STEPS = 2.0e-4, {"static": 1, "dynamic": 4}
TOL = 1e-8  # (module docstring)
#: Krylov iterations of one solve at most (measured ≤ 59; the failure mode: 3000, or a
#: breakdown)
MAX_ITS = 100
_DIRECT: dict = {}


def _g(x) -> np.ndarray:
    return np.concatenate(COMM.allgather(np.asarray(x)))


def _law(name: str, kind: str) -> FrictionLaw:
    if name == "tresca":
        return FrictionLaw("tresca", bound=0.3 * P0)
    update = "fixed_point" if kind == "static" else "previous_step"
    return FrictionLaw("coulomb", coefficient=0.3, update=update)


def _blocks(dim: int, kind: str, law: FrictionLaw, linear: str, multigrid: str):
    """The two blocks (module docstring), their contact solver and integrator."""
    md, pg = friction_blocks(COMM, dim)
    soft = Isotropic(E=20.0e6, nu=0.3, rho=1100.0)
    lower = Isotropic(E=17.0e9, nu=0.3) if kind == "static" else soft
    mats = {pg["lower"]: lower, pg["upper"]: soft}
    m = Mechanics(md.mesh, mats, md.cell_tags, md.facet_tags)
    for c in range(dim):
        m.add_dirichlet(m.facets(pg["bottom"]), c, 0.0)
    if kind == "static":
        x = ufl.SpatialCoordinate(md.mesh)
        load = [0.0] * dim
        load[0] = 0.5 * 0.3 * P0  # half the Tresca capacity (Coulomb: about half)
        load[1] = -P0 * (1.0 - 0.8 * x[0] / W)
        m.add_traction(pg["top"], ufl.as_vector(load))
    itf = build_interface(
        m.V, md.facet_tags, pg["upper_contact"], pg["lower_contact"], dirichlet_dofs=m.bc_dofs()
    )
    opts = PDASOptions(friction=law, max_iterations=60, linear=LinearOptions(multigrid=multigrid))
    contact = ContactSolver(m.V, [itf], opts)
    scheme, dt = ("static", 1.0) if kind == "static" else ("dynamic", DT)
    integ = Integrator(m, scheme, dt, linear=linear, rtol=1e-12, contact=contact)
    if kind == "dynamic":
        v0 = fem.Function(m.V)
        cells = md.cell_tags.find(pg["upper"])
        dofs = fem.locate_dofs_topological(m.V, md.mesh.topology.dim, cells)
        v0.x.array.reshape(-1, dim)[dofs] = [2.0, -1.0, 1.0][:dim]
        integ.set_initial(None, v0)
    return m, integ


def _run(dim: int, law: str, kind: str, linear: str, multigrid: str = "gamg") -> list[dict]:
    """Per step: gathered status, pressure, traction, displacement, PDAS iterations and
    the Krylov iterations of every PDAS iteration."""
    m, integ = _blocks(dim, kind, _law(law, kind), linear, multigrid)
    n = m.V.dofmap.index_map.size_local * dim
    out = []
    for _ in range(STEPS[kind]):
        integ.step()
        r = integ.last_contact
        out.append(
            {
                "status": _g(r.status[0]),
                "p": _g(r.pressure[0]),
                "q": _g(r.traction_t[0]),
                "u": _g(integ.u.x.array[:n]),
                "pdas": r.iterations,
                "its": [h.get("linear_iterations", 0) for h in r.history],
            }
        )
    integ.destroy()
    return out


def _direct(dim: int, law: str, kind: str) -> list[dict]:
    key = (dim, law, kind)
    if key not in _DIRECT:
        _DIRECT[key] = _run(dim, law, kind, "direct")
    return _DIRECT[key]


def _rel(a: np.ndarray, b: np.ndarray, scale: np.ndarray) -> float:
    return float(np.abs(a - b).max(initial=0.0)) / max(float(np.abs(scale).max()), 1e-300)


@pytest.mark.parametrize("multigrid", ["gamg", "compressed"])
@pytest.mark.parametrize("kind", ["static", "dynamic"])
@pytest.mark.parametrize("law", ["tresca", "coulomb"])
@pytest.mark.parametrize("dim", [2, 3])
def test_iterative_friction_gives_the_direct_answer(dim, law, kind, multigrid):
    """Every step: the direct path's statuses node by node and PDAS iterations, its
    displacement, pressure and tangential traction to 1e-8 of their largest values (the
    traction: or of the pressure), every
    Krylov solve within :data:`MAX_ITS`; the run is a friction case (stick and slip
    nodes in the static load, slip in some step of the impact)."""
    ref = _direct(dim, law, kind)
    got = _run(dim, law, kind, "iterative", multigrid)
    for k, (g, d) in enumerate(zip(got, ref)):
        assert np.array_equal(g["status"], d["status"]), f"step {k + 1}"
        assert g["pdas"] == d["pdas"], f"step {k + 1}"
        # (the traction relative to the larger of it and the pressure: a frictionless
        # step's traction is the Krylov residual of the tangential rows)
        scale = {"u": d["u"], "p": d["p"], "q": np.concatenate([d["q"].ravel(), d["p"]])}
        for key in ("u", "p", "q"):
            assert _rel(g[key], d[key], scale[key]) <= TOL, (k + 1, key)
        assert max(g["its"]) <= MAX_ITS, g["its"]
    assert any((d["status"] == "slip").any() for d in ref)
    if kind == "static":
        assert (ref[-1]["status"] == "stick").any()


def _random_spd(n: int, rng: np.random.Generator) -> np.ndarray:
    M = rng.standard_normal((n, n))
    return M @ M.T + n * np.eye(n)


def _direct_rows(B, r, coupled, fixed, values):
    """The system as the direct solvers pose it: fixed rows eliminated, each group's rows
    ``G B x − H x = G r − h`` (dense, for the check)."""
    A, b = B.copy(), r.copy()
    rows, G, Hm, h = coupled
    for i in range(rows.shape[0]):
        q = rows[i]
        newA = G[i] @ A[q]
        newA[:, q] -= Hm[i]
        b[q] = G[i] @ b[q] - h[i]
        A[q] = newA
    for q in np.flatnonzero(fixed):
        A[q], b[q] = 0.0, values[q]
        A[q, q] = 1.0
    return np.linalg.solve(A, b)


def _krylov_rows(B, r, groups, fixed, values):
    """The system in the Krylov form: elastic rows plus ``−H`` for scaled groups, the
    rows ``G B x − H x`` for the others, the prescribed rows fixed."""
    A, b = B.copy(), r.copy()
    for grp in groups:
        q = grp.rows
        newA = grp.G @ A[q]
        newA[:, q] -= grp.H
        b[q] = grp.G @ b[q] - grp.h
        A[q] = newA
    for q in np.flatnonzero(fixed):
        A[q], b[q] = 0.0, values[q]
        A[q, q] = 1.0
    return np.linalg.solve(A, b)


@pytest.mark.parametrize("with_normal", [False, True])
def test_krylov_groups_keep_the_solution(with_normal):
    """Newton slip groups (and, with edge nodes present, the same groups carrying their
    normal row ``u_n = g``): the Krylov form has the direct form's solution to 1e-12;
    the normal rows become fixed rows with the gap, the tangential groups are scaled
    (``G = I``)."""
    rng = np.random.default_rng(7)
    n_nodes, n = 4, 12  # 3 rows per node: normal, two tangential
    B, r = _random_spd(n, rng), rng.standard_normal(n)
    tang = np.array([[3 * i + 1, 3 * i + 2] for i in range(n_nodes)])
    lam, z = rng.standard_normal((n_nodes, 2)), 3.0 * rng.standard_normal((n_nodes, 2))
    coupled = slip_newton_rows(
        tang, 1.0 + rng.random(n_nodes), 5.0, lam, z, np.ones(n_nodes), rng.standard_normal(n)
    )
    fixed, values = np.zeros(n, bool), rng.standard_normal(n)
    if with_normal:
        gap, k = rng.standard_normal(n_nodes), 2.0 + rng.random(n_nodes)
        coupled = with_normal_row(coupled, tang[:, 0] - 1, gap, k)
    new_fixed, new_values, groups = krylov_groups(coupled, fixed, values)
    ref = _direct_rows(B, r, coupled, fixed, values)
    got = _krylov_rows(B, r, groups, new_fixed, new_values)
    assert np.abs(got - ref).max() <= 1e-12 * np.abs(ref).max()
    assert all(g.scaled and g.rows.size == 2 for g in groups)
    assert new_fixed.sum() == (n_nodes if with_normal else 0)
    if with_normal:
        assert np.allclose(new_values[tang[:, 0] - 1], gap, rtol=1e-14)


def test_converged_slip_group_is_a_spring_across_the_slip():
    """At a converged slip state (``λ = ĝ n``, ``θ = 1``) the scaled group adds
    ``K = D c_t ĝ/(|ξ| − ĝ) (I − n nᵀ)`` to the elastic rows: symmetric positive
    semidefinite, all of it in the preconditioner's matrix (``spring_split``)."""
    c_t, g, D = 4.0, 2.0, 1.5
    zeta = np.array([[3.0, 4.0]])  # |ξ| = 5
    n = zeta / 5.0
    coupled = slip_newton_rows(
        np.array([[1, 2]]), np.array([D]), c_t, g * n, zeta, np.array([g]), np.zeros(3)
    )
    _, _, groups = krylov_groups(coupled, np.zeros(3, bool), np.zeros(3))
    S, rest = spring_split(groups[0].H)
    K = D * c_t * g / (5.0 - g) * (np.eye(2) - n.T @ n)
    assert np.allclose(S, K, rtol=1e-12, atol=1e-12 * np.abs(K).max())
    assert np.abs(rest).max() <= 1e-12 * np.abs(K).max()


def test_edge_group_is_kept():
    """An edge node's group (``G`` singular: the normal residual vanishes, the
    tangential row holds ``u_n = g``) is kept as the direct solvers insert it."""
    from bonecontact.contact.friction import edge_groups

    rows = [np.array([0, 2]), np.array([1, 3])]
    coupled = edge_groups(
        np.array([1]), rows, np.zeros((2, 1)), np.array([0.0, 0.1]), np.array([1.0, 3.0])
    )
    fixed, values, groups = krylov_groups(coupled, np.zeros(4, bool), np.zeros(4))
    assert not fixed.any() and len(groups) == 1 and not groups[0].scaled
    assert np.array_equal(groups[0].G, coupled[1][0])
