"""The condensed operator taken over by the refactor and Krylov strategies (issue 28: one
matrix of the size of ``Ã = T Q A Qᵀ Tᵀ`` kept instead of two).

The strategies eliminate each set's rows in ``Ã`` itself and reset it from its stripes
(the contact and Dirichlet rows and columns) before the next set.  References independent
of that code: ``Ã`` recomputed by its triple product from the integrator's operator, and
the path that keeps ``Ã`` beside a copy (the code before), whose solution and iteration
counts the taken-over operator must reproduce exactly.  A family of problems: 2D and 3D
load-driven Hertz (a body held only by contact), the Krylov (iterative) and the refactor
(MUMPS) strategy; on 1, 2 and 3 ranks.  The products that build the condensed operator and
GAMG's coarse levels keep no intermediate data (``lean_products``): the same solution.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import contextlib

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest

from bonecontact.contact.condensed import CondensedSystem, lean_products
from bonecontact.contact.interface import transformed_operator
from bonecontact.contact.options import PDASOptions
from bonecontact.verification.load_driven import half_disc_on_block_2d, sphere_on_block_3d

COMM = MPI.COMM_WORLD
#: (builder, h_contact, h_far): 3D 4.6k dofs, 2D ~3k dofs
PROBLEMS = {
    "3d": (sphere_on_block_3d, 6e-4, 4.5e-3),
    "2d": (half_disc_on_block_2d, 2.5e-4, 2.0e-3),
}
#: (linear, strategy)
STRATEGIES = {"krylov": ("iterative", "auto"), "refactor": ("direct", "refactor")}
CASES = [(p, s) for p in PROBLEMS for s in STRATEGIES]


def _problem(problem: str, strategy: str):
    build, h, h_far = PROBLEMS[problem]
    linear, name = STRATEGIES[strategy]
    options = PDASOptions.from_fields(strategy=name)
    return build(COMM, h, h_far=h_far, linear=linear, options=options)


def _nnz(M: PETSc.Mat) -> int:
    return int(COMM.allreduce(M.getInfo(PETSc.Mat.InfoType.LOCAL)["nz_used"], op=MPI.SUM))


def _max_diff(X: PETSc.Mat, Y: PETSc.Mat) -> float:
    """max |X − Y| over the entries (same layout)."""
    D = X.duplicate(copy=True)
    D.axpy(-1.0, Y, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
    out = D.norm(PETSc.NormType.INFINITY)
    D.destroy()
    return out


@pytest.mark.parametrize("problem,strategy", CASES)
def test_one_operator_of_its_size_is_kept(problem, strategy):
    """After set-up the system holds no ``Ã``: of the matrices the contact solver holds
    (the system's and the strategy's ``B``) exactly one has ``Ã``'s nonzeros, ``B``; the
    stripes and the contact rows together hold less than half as many."""
    pb = _problem(problem, strategy)
    solver = pb.integrator.contact
    held = dict(solver.system.matrices(), B=solver.B)
    assert "At" not in held and solver.system.At is None
    n_b = _nnz(solver.B)
    large = [k for k, M in held.items() if _nnz(M) >= n_b // 2]
    assert large == ["B"]
    assert "AtL" not in held  # (the contact rows are the stripes' own)
    assert _nnz(held["stripes"]) < n_b // 2
    pb.destroy()


@pytest.mark.parametrize("problem,strategy", CASES)
def test_restore_gives_the_operator_exactly(problem, strategy):
    """``B`` changed in its stripes (rows and columns eliminated with another diagonal,
    contact rows overwritten) and restored equals the ``Ã`` it was handed entry by entry
    (difference exactly zero); that ``Ã`` is its triple product recomputed from the
    integrator's operator to round-off (a parallel product may sum the off-rank parts in
    another order: 2⁻¹⁰ = 4e-17 of the norm, seen once on 3 ranks)."""
    pb = _problem(problem, strategy)
    solver, integ = pb.integrator.contact, pb.integrator
    sy, B = solver.system, solver.B
    recomputed = transformed_operator(integ.A_bc, sy.Qt, sy.Tt)
    scale = recomputed.norm(PETSc.NormType.INFINITY)
    assert _max_diff(B, recomputed) <= 1e-14 * scale  # (Ã handed over unchanged)
    recomputed.destroy()
    reference = B.copy()
    rng = np.random.default_rng(7 + COMM.rank)
    stripes = sy.stripe_rows()
    for trial in range(2):
        chosen = stripes[rng.random(stripes.size) < 0.5]
        B.zeroRowsColumns(chosen, diag=3.0 + trial)
        rows = sy.layout.local_rows[: max(sy.layout.n_rows // 3, 0)].astype(np.int64) + sy.start
        replaced = [(int(r), *B.getRow(int(r))) for r in rows]  # (no MatGetRow after)
        for r, cols, vals in replaced:  # a replaced row keeps its pattern, not its values
            B.setValues([r], cols, vals + 1.0 + np.arange(cols.size))
        B.assemble()
        assert _max_diff(B, reference) > 0.0
        sy.restore_operator(B)
        assert _max_diff(B, reference) == 0.0
    reference.destroy()
    pb.destroy()


def _solve(problem: str, strategy: str) -> dict:
    pb = _problem(problem, strategy)
    res = pb.solve()
    n = pb.model.V.dofmap.index_map.size_local * pb.model.V.dofmap.index_map_bs
    force = pb.integrator.residual.duplicate()
    pb.integrator.contact.contact_force(force)
    out = {
        "u": pb.integrator.u.x.array[:n].copy(),
        "force": force.array.copy(),
        "its": (res.iterations, res.linear_iterations),
        "active": res.n_active,
    }
    force.destroy()
    pb.destroy()
    return out


def _kept_operator(monkeypatch) -> None:
    """The path before: ``Ã`` kept beside its copy ``B``, restored by copying it."""
    monkeypatch.setattr(CondensedSystem, "take_operator", lambda self: self.At.duplicate(copy=True))
    monkeypatch.setattr(
        CondensedSystem,
        "restore_operator",
        lambda self, B: self.At.copy(B, PETSc.Mat.Structure.SAME_NONZERO_PATTERN),
    )


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    num = COMM.allreduce(float(np.sum((a - b) ** 2)), op=MPI.SUM)
    den = COMM.allreduce(float(np.sum(b**2)), op=MPI.SUM)
    return float(np.sqrt(num / max(den, 1e-300)))


@pytest.mark.parametrize("problem,strategy", CASES)
def test_same_solution_as_with_the_operator_kept(problem, strategy, monkeypatch):
    """The taken-over operator gives the displacement, the contact forces, the PDAS and
    Krylov iterations and the active set of the path that keeps ``Ã`` beside a copy
    (measured: identical to the last bit on 1–3 ranks; asserted to 1e-12)."""
    taken = _solve(problem, strategy)
    _kept_operator(monkeypatch)
    kept = _solve(problem, strategy)
    assert taken["its"] == kept["its"]
    assert taken["active"] == kept["active"]
    assert _rel(taken["u"], kept["u"]) <= 1e-12
    assert _rel(taken["force"], kept["force"]) <= 1e-12
    assert _rel(kept["force"], 0.0 * kept["force"]) > 0.0  # (a contact force to compare)


# ------------------------------------------------------------------ lean products
def test_lean_products_options_are_scoped():
    """Inside the block: the product options (all-at-once triple products on more than
    one rank); after it none is left; an option the user has set is neither changed nor
    removed."""
    opts = PETSc.Options()
    with lean_products(COMM):
        assert "matptap_via" not in opts.getAll()
    with lean_products(COMM, all_at_once=True):
        inside = opts.getAll()
    assert inside.get("mat_product_clear") == "true"
    assert ("matptap_via" in inside) == (COMM.size > 1)
    assert "mat_product_clear" not in opts.getAll() and "matptap_via" not in opts.getAll()
    opts["mat_product_clear"] = "false"
    try:
        with lean_products(COMM, clear=False):
            assert opts.getAll()["mat_product_clear"] == "false"
        assert opts.getAll()["mat_product_clear"] == "false"
    finally:
        opts.delValue("mat_product_clear")


def _plain_products(monkeypatch) -> None:
    """The path before: products keep their data (PETSc's defaults)."""
    import bonecontact.contact.condensed as condensed
    import bonecontact.contact.linear_strategy as linear_strategy

    plain = contextlib.contextmanager(lambda *args, **kwargs: (yield))
    monkeypatch.setattr(condensed, "lean_products", plain)
    monkeypatch.setattr(linear_strategy, "lean_products", plain)


@pytest.mark.parametrize("problem", list(PROBLEMS))
def test_lean_products_same_solution(problem, monkeypatch):
    """The condensed operator and GAMG's coarse levels built without product data (and
    all at once on several ranks) give the displacement (1e-12), PDAS and Krylov
    iterations of PETSc's default products (measured: identical serially, 1.6e-14 on 3
    ranks, 4.6k dofs; 65k dofs on 2 ranks: peak 466 -> 425 MiB per rank)."""
    results = []
    for lean in (True, False):
        if not lean:
            _plain_products(monkeypatch)
        pb = _problem(problem, "krylov")
        res = pb.solve()
        n = pb.model.V.dofmap.index_map.size_local * pb.model.V.dofmap.index_map_bs
        results.append((pb.integrator.u.x.array[:n].copy(), res.iterations, res.linear_iterations))
        pb.destroy()
    assert results[0][1:] == results[1][1:]
    assert _rel(results[0][0], results[1][0]) <= 1e-12
