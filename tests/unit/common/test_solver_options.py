"""PETSc options of the package's solvers: each under a prefix of its own, in PETSc's
global options database only while the solver sets up or solves
(bonecontact.common.linalg.SolverOptions).

References: the options database before the solvers were made (nothing of ours may be
left in it); a direct (MUMPS) solve of the same system (every iterative solve, whatever
its options, must give the same displacement); the options each solver was given (its
level smoothers after a rebuild of its preconditioner, when another solver with other
options has been set up and solved in between).
"""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from dolfinx.fem.petsc import apply_lifting, assemble_matrix, assemble_vector, set_bc

from bonecontact.common.linalg import configure_ksp, create_solver, rigid_body_modes

COMM = MPI.COMM_WORLD


@pytest.fixture(scope="module")
def system():
    """A clamped elastic cube (6×6×6 cells), body force: operator, right-hand side,
    near-nullspace and the MUMPS solution."""
    msh = mesh.create_box(COMM, [[0, 0, 0], [1, 1, 1]], [6, 6, 6], mesh.CellType.tetrahedron)
    V = fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps = ufl.sym(ufl.grad(u))
    sig = 2.0 * eps + 1.5 * ufl.tr(eps) * ufl.Identity(3)
    a = fem.form(ufl.inner(sig, ufl.sym(ufl.grad(v))) * ufl.dx)
    L = fem.form(ufl.inner(fem.Constant(msh, (0.0, -1.0, 0.3)), v) * ufl.dx)
    facets = mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[0], 0.0))
    bc = fem.dirichletbc(np.zeros(3), fem.locate_dofs_topological(V, 2, facets), V)
    A = assemble_matrix(a, bcs=[bc])
    A.assemble()
    b = assemble_vector(L)
    apply_lifting(b, [a], [[bc]])
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    set_bc(b, [bc])
    nns = rigid_body_modes(V)
    ref = _solve(create_solver(A, "direct", prefix="test_ref_"), b)
    yield {"A": A, "b": b, "nns": nns, "ref": ref}
    for obj in (A, b, nns):
        obj.destroy()


def _solve(ksp: PETSc.KSP, b: PETSc.Vec) -> np.ndarray:
    x = b.duplicate()
    ksp.solve(b, x)
    assert ksp.getConvergedReason() > 0
    out = x.array.copy()
    x.destroy()
    return out


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    num = COMM.allreduce(float(np.sum((a - b) ** 2)), op=MPI.SUM)
    return float(np.sqrt(num / COMM.allreduce(float(np.sum(b**2)), op=MPI.SUM)))


def _ours(before: dict, prefixes: tuple[str, ...]) -> dict:
    """Options in the database now that were not there before and carry our prefixes."""
    now = PETSc.Options().getAll()
    return {k: v for k, v in now.items() if k not in before and k.startswith(prefixes)}


@pytest.mark.parametrize("kind", ["direct", "iterative"])
@pytest.mark.parametrize("extra", [None, {"mg_levels_ksp_max_it": 1, "ksp_norm_type": "natural"}])
def test_no_option_left_after_solve(system, kind, extra):
    """After creating, configuring, solving and re-solving with a new operator, the
    options database holds nothing it did not hold before; the solve is right."""
    before = PETSc.Options().getAll()
    extra = extra if kind == "iterative" else {"mat_mumps_icntl_24": 1}
    ksp = create_solver(system["A"], kind, system["nns"], rtol=1e-10, prefix="t1_", options=extra)
    assert _ours(before, ("t1_",)) == {}
    x = _solve(ksp, system["b"])
    assert _ours(before, ("t1_",)) == {}
    B = system["A"].duplicate(copy=True)
    B.scale(2.0)
    ksp.setOperators(B)  # a new operator: the preconditioner is rebuilt, options re-read
    x2 = _solve(ksp, system["b"])
    assert PETSc.Options().getAll() == before
    assert _rel(x, system["ref"]) < 1e-7
    assert _rel(2.0 * x2, system["ref"]) < 1e-7
    ksp.destroy()
    B.destroy()


def _smoother(ksp: PETSc.KSP) -> tuple[str, int]:
    """Type and iteration count of the finest-level smoother of a GAMG KSP."""
    pc = ksp.getPC()
    sm = pc.getMGSmoother(pc.getMGLevels() - 1)
    return sm.getType(), sm.getTolerances()[3]


@pytest.mark.parametrize("same_prefix", [True, False])
@pytest.mark.parametrize("second", ["iterative", "direct"])
def test_two_solvers_keep_their_options(system, same_prefix, second):
    """Solver 1 (GAMG with Richardson/SOR smoothing, 3 sweeps) and solver 2 (default
    GAMG, or MUMPS) in one process, under the same or different user prefixes, set up
    and solved alternately, each operator changed in between: each keeps its own
    smoothers through every rebuild, and both give the direct solution."""
    p1 = "t2_"
    p2 = p1 if same_prefix else "t3_"
    before = PETSc.Options().getAll()
    o1 = {"mg_levels_ksp_type": "richardson", "mg_levels_pc_type": "sor", "mg_levels_ksp_max_it": 3}
    A1, A2 = system["A"].duplicate(copy=True), system["A"].duplicate(copy=True)
    k1 = create_solver(A1, "iterative", system["nns"], rtol=1e-10, prefix=p1, options=o1)
    k2 = create_solver(A2, second, system["nns"], rtol=1e-10, prefix=p2)
    for rnd in range(2):
        for ksp, A in ((k1, A1), (k2, A2)):
            if rnd:
                A.scale(1.0 + rnd)
                ksp.setOperators(A)
            x = _solve(ksp, system["b"])
            assert _rel((1.0 + rnd) * x, system["ref"]) < 1e-7
        assert _smoother(k1) == ("richardson", 3)
        if second == "iterative":
            assert _smoother(k2) == ("chebyshev", 2)
    assert PETSc.Options().getAll() == before
    for obj in (k1, k2, A1, A2):
        obj.destroy()


@pytest.mark.parametrize("same_prefix", [True, False])
def test_command_line_override_reaches_its_prefix_only(system, same_prefix):
    """A user option under one prefix (as from the command line) overrides the
    package's option of the solvers under that prefix, and of no other; it stays the
    user's (still in the database after the solves)."""
    p1, p2 = "t4_", ("t4_" if same_prefix else "t5_")
    opts = PETSc.Options()
    opts[f"{p1}mg_levels_ksp_max_it"] = 4
    try:
        k1 = PETSc.KSP().create(COMM)
        k1.setOperators(system["A"])
        configure_ksp(k1, "iterative", rtol=1e-10, prefix=p1)
        k2 = create_solver(system["A"], "iterative", system["nns"], rtol=1e-10, prefix=p2)
        for ksp in (k1, k2):
            assert _rel(_solve(ksp, system["b"]), system["ref"]) < 1e-7
        assert _smoother(k1) == ("chebyshev", 4)
        assert _smoother(k2) == ("chebyshev", 4 if same_prefix else 2)
        assert opts.getInt(f"{p1}mg_levels_ksp_max_it") == 4
    finally:
        opts.delValue(f"{p1}mg_levels_ksp_max_it")
    for ksp in (k1, k2):
        ksp.destroy()


@pytest.mark.parametrize(
    "linear, strategy", [("direct", "lowrank"), ("direct", "refactor"), ("iterative", "auto")]
)
def test_contact_solve_leaves_no_option(linear, strategy):
    """A whole PDAS contact solve (2D load-driven Hertz: MUMPS low-rank, MUMPS
    refactorising, CG + GAMG on the condensed system) leaves the options database as
    it found it; its contact resultant balances the applied load (force balance)."""
    from bonecontact.contact.options import LinearOptions, PDASOptions
    from bonecontact.verification.load_driven import half_disc_on_block_2d, hertz_errors

    before = PETSc.Options().getAll()
    opts = PDASOptions(linear=LinearOptions(strategy=strategy))
    pb = half_disc_on_block_2d(COMM, 1.0e-3, linear=linear, options=opts)
    res = pb.solve()
    err = hertz_errors(pb, res)
    pb.destroy()
    assert PETSc.Options().getAll() == before
    assert sum(np.atleast_1d(res.n_active)) >= 3
    assert err["equilibrium"] < 1e-8
