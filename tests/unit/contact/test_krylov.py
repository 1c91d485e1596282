"""The iterative linear-solver path of the PDAS (bonecontact.contact.krylov).

References, independent of the code under test: the rigid-body modes of a body without
supports are null vectors of its stiffness (their image under the condensation must be
null vectors of the condensed operator); the direct solver (MUMPS LU, low-rank PDAS) on
the same load-driven problem; the reuse rule's definition.

Measured on the load-driven 3D Hertz problem (hemisphere held in the load direction
only by the contact, every solve to rtol 1e-12; coarse grid N/16), Krylov iterations
per PDAS iteration: serial 24–28 at 4.6k dofs and 25–31 at 9.1k dofs, on 2 ranks 25–31
and 27–34 (with GAMG's default coarse grid: serial 28–29 and 30–31, on 2 ranks 44–46
and 41–45); with the default loose solves while the set changes 6–9 and then 24–26.
The iterative solution equals the direct one to 1e-12 (contrasts 1e3 and 1e4).
Without the condensed near-nullspace the same systems took 115–180 iterations.
"""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest

import bonecontact.verification.load_driven as load_driven
from bonecontact.common.linalg import rigid_body_modes
from bonecontact.contact.krylov import (
    PreconditionerReuse,
    apply_inverse_transpose,
    condensed_near_nullspace,
)
from bonecontact.contact.options import PDASOptions
from bonecontact.contact.pdas import ContactSolver
from bonecontact.verification.load_driven import hertz_errors, sphere_on_block_3d

COMM = MPI.COMM_WORLD
COARSE, FINE = (6e-4, 4.5e-3), (4e-4, 3e-3)  # (h_contact, h_far): 4551 and 9114 dofs
_CACHE: dict = {}


def _solve(
    size: tuple[float, float],
    linear: str,
    ratio: float = 1e3,
    loose: float | None = None,
    multigrid: str = "gamg",
) -> dict:
    """Build and solve the load-driven problem once per (size, solver, contrast, loose
    Krylov tolerance; ``None``: the default, multigrid); keep the owned displacement, the
    result, the equilibrium defect and the reuse counters; then a second step with the
    same load (a warm-started time step)."""
    key = (size, linear, ratio, loose, multigrid)
    if key in _CACHE:
        return _CACHE[key]
    old = load_driven.LOAD_DRIVEN_STIFFNESS_RATIO
    load_driven.LOAD_DRIVEN_STIFFNESS_RATIO = ratio
    fields_ = (
        {"multigrid": multigrid} if loose is None else {"multigrid": multigrid, "loose_rtol": loose}
    )
    opts = PDASOptions.from_fields(**fields_)
    try:
        pb = sphere_on_block_3d(COMM, size[0], h_far=size[1], linear=linear, options=opts)
    finally:
        load_driven.LOAD_DRIVEN_STIFFNESS_RATIO = old
    res = pb.solve()
    n = pb.model.V.dofmap.index_map.size_local * 3
    out = {"u": pb.integrator.u.x.array[:n].copy(), "res": res, "dofs": pb.model.num_dofs}
    out["equilibrium"] = hertz_errors(pb, res)["equilibrium"]
    solver = pb.integrator.contact
    if linear == "iterative":
        out["builds"], out["reuses"] = solver.pc_reuse.builds, solver.pc_reuse.reuses
        pb.integrator.step()  # the same load again
        out["step2"] = pb.integrator.last_contact
        out["builds2"], out["reuses2"] = solver.pc_reuse.builds, solver.pc_reuse.reuses
    pb.destroy()
    _CACHE[key] = out
    return out


def _rel_diff(a: np.ndarray, b: np.ndarray) -> float:
    num = COMM.allreduce(float(np.sum((a - b) ** 2)), op=MPI.SUM)
    den = COMM.allreduce(float(np.sum(b**2)), op=MPI.SUM)
    return float(np.sqrt(num / den))


@pytest.fixture(scope="module")
def floating_pair():
    """The hemisphere and the block without any Dirichlet condition: the contact
    solver's transformed operator of the stiffness (two floating bodies)."""
    pb = sphere_on_block_3d(COMM, COARSE[0], h_far=COARSE[1], linear="iterative")
    solver = ContactSolver(pb.model.V, [pb.interface])
    solver.setup(pb.model.K, None, linear="iterative")
    yield pb, solver
    solver.destroy()
    pb.destroy()


def test_inverse_transpose_of_the_basis_transform(floating_pair):
    """Qᵀ (Q⁻ᵀ z) = z to round-off for the rigid modes and a random vector."""
    pb, solver = floating_pair
    modes = rigid_body_modes(pb.model.V).getVecs()
    rnd = modes[0].duplicate()
    rnd.setRandom(PETSc.Random().create(COMM))
    y, back = rnd.duplicate(), rnd.duplicate()
    for z in [*modes, rnd]:
        apply_inverse_transpose(solver.Qt, z, y)
        solver.Qt.mult(y, back)
        back.axpy(-1.0, z)
        assert back.norm() <= 1e-14 * z.norm()
    apply_inverse_transpose(solver.Qt, rnd, y)
    y.axpy(-1.0, rnd)
    assert y.norm() > 1e-3 * rnd.norm()  # Q is not the identity on the interface


def test_condensed_modes_are_null_vectors_of_a_floating_pair(floating_pair):
    """T Q⁻ᵀ z of the six rigid modes of each body: At v = 0 to round-off (relative to
    ‖At‖∞‖v‖∞); the rotated but untransformed modes T z are not null vectors."""
    pb, solver = floating_pair
    At = solver.B  # (the Krylov strategy's B is Ã itself until a solve eliminates rows)
    scale = At.norm(PETSc.NormType.INFINITY)
    r = At.createVecLeft()
    nns = condensed_near_nullspace(pb.model.V, solver.Qt, solver.T)
    vecs = nns.getVecs()
    assert len(vecs) == 12  # two bodies
    for v in vecs:
        At.mult(v, r)
        assert r.norm(PETSc.NormType.INFINITY) <= 1e-12 * scale * v.norm(PETSc.NormType.INFINITY)
    worst = 0.0
    for z in rigid_body_modes(pb.model.V).getVecs():
        tz = At.createVecRight()
        solver.T.mult(z, tz)
        At.mult(tz, r)
        rel = r.norm(PETSc.NormType.INFINITY) / (scale * tz.norm(PETSc.NormType.INFINITY))
        worst = max(worst, rel)
    assert worst > 1e-6


@pytest.mark.parametrize("ratio", [1e3, 1e4])
def test_iterative_equals_direct(ratio):
    """A body held only by contact, stiffness contrast 1e3 and 1e4: CG + GAMG gives the
    direct solver's displacement to solver tolerance and the same active set, in a
    bounded number of Krylov iterations per PDAS iteration."""
    it = _solve(COARSE, "iterative", ratio)
    di = _solve(COARSE, "direct", ratio)
    assert _rel_diff(it["u"], di["u"]) < 1e-9
    assert it["res"].n_active == di["res"].n_active
    assert it["res"].iterations == di["res"].iterations
    per = [h["linear_iterations"] for h in it["res"].history]
    assert max(per) <= 60
    assert sum(per) <= it["res"].linear_iterations  # (+ the cold start's extra solve)


def test_krylov_iterations_do_not_grow_with_the_mesh():
    """Twice the dofs (4.6k → 9.1k, h 0.6 → 0.4 mm): the largest Krylov count of a PDAS
    iteration grows by at most 20 %, and the fine solution equals the direct one."""
    coarse = _solve(COARSE, "iterative")
    fine = _solve(FINE, "iterative")
    assert fine["dofs"] > 1.9 * coarse["dofs"]
    mc = max(h["linear_iterations"] for h in coarse["res"].history)
    mf = max(h["linear_iterations"] for h in fine["res"].history)
    assert mf <= 1.2 * mc
    assert _rel_diff(fine["u"], _solve(FINE, "direct")["u"]) < 1e-9


@pytest.mark.parametrize("multigrid", ["gamg", "compressed"])
def test_preconditioner_reused_across_iterations_and_steps(multigrid):
    """GAMG: the first set (the cold start's support patch) and the predicted zone differ
    in most rows: rebuilt; later PDAS iterations change few rows: kept; a second step
    with the same load keeps it too.  The compressed hierarchy (``pc_reuse_rows`` 0 by
    default, docs/theory/pdas.md#compressed-coarse-grid) is rebuilt for every new set
    and kept for the same set: the second step's solve keeps it.  Either way the second
    step converges in one PDAS iteration and needs almost no Krylov iterations (its
    initial guess is the solution)."""
    it = _solve(COARSE, "iterative", multigrid=multigrid)
    solves = it["builds"] + it["reuses"]
    assert solves >= it["res"].iterations
    if multigrid == "gamg":
        assert it["reuses"] >= 1
        assert it["builds"] >= 2
        assert it["builds2"] == it["builds"]
        assert it["reuses2"] > it["reuses"]
    else:  # a new set is rebuilt, the same set (tight after loose; step 2) kept
        assert it["builds"] >= 2
        assert it["reuses2"] > it["reuses"]
        assert it["builds2"] == it["builds"]
    assert it["step2"].iterations == 1
    assert it["step2"].linear_iterations <= 2


def test_inexact_pdas_gives_the_tight_solution():
    """Inexact PDAS (loose Krylov tolerance while the set changes, the settled set
    solved again to the tight one) against every solve tight (``loose_rtol = 0``) and
    the direct solver: the same active set and displacement to the solver tolerance,
    the contact resultant equal to the load, the last PDAS iteration tight and the
    earlier ones loose, and fewer Krylov iterations in all."""
    tight = _solve(COARSE, "iterative", loose=0.0)
    loose = _solve(COARSE, "iterative")
    direct = _solve(COARSE, "direct")
    assert loose["res"].n_active == tight["res"].n_active == direct["res"].n_active
    assert _rel_diff(loose["u"], tight["u"]) < 1e-9
    assert _rel_diff(loose["u"], direct["u"]) < 1e-9
    assert loose["equilibrium"] < 1e-10
    rtols = [h["krylov_rtol"] for h in loose["res"].history]
    assert rtols[-1] == 1e-12 and all(r == 1e-4 for r in rtols[:-1]) and len(rtols) >= 2
    assert all(h["krylov_rtol"] == 1e-12 for h in tight["res"].history)
    assert loose["res"].linear_iterations < 0.75 * tight["res"].linear_iterations


def test_reuse_rule():
    """The rule of PreconditionerReuse: rebuild at the first solve, after too many
    changed rows (25 % of the rows replaced in the preconditioner's set, at least one),
    after a solve that took more than 1.5 times the first one's iterations per decade
    of residual reduction; keep otherwise; rows = 0 rebuilds for every other set and
    keeps the same set."""
    ksp = PETSc.KSP().create(COMM)
    rule = PreconditionerReuse(rows=0.25, growth=1.5)
    base = np.zeros(40, dtype=bool)
    base[:8] = True  # 8 rows fixed: up to 2 may change
    assert rule.decide(ksp, base) is False  # first solve
    rule.record(20)
    two = base.copy()
    two[[0, 20]] = [False, True]
    assert rule.decide(ksp, two) is True  # 2 rows changed
    rule.record(30)  # 1.5 × 20: still fine
    three = two.copy()
    three[21] = True
    assert rule.decide(ksp, three) is False  # 3 rows changed
    rule.record(10)
    assert rule.decide(ksp, three) is True
    rule.record(16)  # > 1.5 × 10
    assert rule.decide(ksp, three) is False
    assert (rule.builds, rule.reuses) == (3, 2)
    rule.record(12, decades=4.0)  # a loose solve: 3 iterations per decade
    assert rule.decide(ksp, three) is True
    rule.record(36, decades=8.0)  # a tight one: 4.5 per decade = 1.5 × 3, kept
    assert rule.decide(ksp, three) is True
    rule.record(40, decades=8.0)  # 5 per decade > 1.5 × 3
    assert rule.decide(ksp, three) is False
    never = PreconditionerReuse(rows=0.0)  # rebuilt for every other set, kept for the same
    for mask, kept in ((base, False), (base, True), (three, False), (three, True), (base, False)):
        assert never.decide(ksp, mask) is kept
        never.record(5)
    assert (never.builds, never.reuses) == (3, 2)
    ksp.destroy()
