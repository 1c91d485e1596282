"""The PDAS set logic is local to the rank that owns the slave node (#24,
docs/theory/pdas.md#distributed-set-logic).

A family of contact problems (2D and 3D; frictionless, Tresca, Coulomb with the fixed
point or the semi-implicit bound, 3D semi-smooth Newton slip rows; static and dynamic;
low-rank, refactorising and Krylov linear solvers) is solved on all ranks of
``COMM_WORLD`` and, as the reference, by rank 0 alone on ``COMM_SELF``: the PDAS
histories (iterations, active/stick/slip counts per iteration) must be identical and
the pressures, tractions, gaps and resultants equal to 1e-10 of their scale.  Run on 1,
2, 3 and 4 ranks (``mpiexec -n 4`` oversubscribed is fine).

On more than one rank the test also checks that the contact logic holds no array over
the slave nodes of all ranks: every per-node array of the solver has this rank's owned
length, the low-rank columns keep this rank's rows, and no reduction or gather of the
set logic receives as many bytes as one number per slave node of all ranks.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from dolfinx import fem

from bonecontact.contact.friction import FrictionLaw
from bonecontact.contact.interface import build_interface
from bonecontact.contact.options import ActiveSetOptions, LinearOptions, PDASOptions, SlipOptions
from bonecontact.contact.pdas import ContactSolver
from bonecontact.contact.reductions import TRAFFIC
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics
from bonecontact.meshing import shapes as meshing

COMM = MPI.COMM_WORLD
W, H = 0.02, 0.01
TOL = 1e-10


def _blocks(comm: MPI.Comm, scene: str, dynamic: bool) -> tuple[Mechanics, object]:
    """Two blocks (20 MPa upper block): ``"liftoff"`` on a stiff lower block, loaded
    ``−P (1 − 1.2 x/W)`` (part of the interface opens); ``"shear"`` pressed and then
    sheared by 0.8 of the Tresca bound; ``"impact"`` (dynamic) hitting obliquely."""
    lower, upper = {"liftoff": (9, 24), "shear": (13, 30), "impact": (7, 12)}[scene]
    md = meshing.two_blocks_2d(
        comm, h_lower=W / lower, h_upper=W / upper, width=W, lower_height=H, upper_height=H
    )
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    stiff = 17.0e9 if scene == "liftoff" else 20.0e6
    mats = {
        pg["lower"]: Isotropic(E=stiff, nu=0.3, rho=1100.0),
        pg["upper"]: Isotropic(E=20.0e6, nu=0.3, rho=1100.0),
    }
    m = Mechanics(md.mesh, mats, md.cell_tags, md.facet_tags)
    for c in (0, 1):
        m.add_dirichlet(m.facets(pg["bottom"]), c, 0.0)
    if scene == "liftoff":
        x = ufl.SpatialCoordinate(md.mesh)
        m.add_dirichlet(m.facets(pg["top"]), 0, 0.0)
        m.add_traction(pg["top"], ufl.as_vector([0.0, -1e5 * (1.0 - 1.2 * x[0] / W)]))
    elif scene == "shear":
        m.add_traction(pg["top"], [0.0, -1e5])
        m.add_traction(pg["top"], [4e4, 0.0], schedule=lambda t: max(t - 1.0, 0.0))
    itf = build_interface(
        m.V, md.facet_tags, pg["upper_contact"], pg["lower_contact"], dirichlet_dofs=m.bc_dofs()
    )
    return m, itf, md, pg


def _boxes(comm: MPI.Comm, held: bool) -> tuple[Mechanics, object]:
    """3D partial lift-off: a soft box (20 MPa) on a stiff one (17 GPa), its top loaded by
    ``−P (1 − 1.2 x/W)`` and held in z (and in x if ``held``); in the second step
    sheared in x by P/10."""
    md = meshing.two_boxes_3d(comm, h_lower=W / 4, h_upper=W / 6)
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    mats = {pg["lower"]: Isotropic(E=17.0e9, nu=0.3), pg["upper"]: Isotropic(E=20.0e6, nu=0.3)}
    m = Mechanics(md.mesh, mats, md.cell_tags, md.facet_tags)
    for c in range(3):
        m.add_dirichlet(m.facets(pg["bottom"]), c, 0.0)
    for c in (0, 2) if held else (2,):
        m.add_dirichlet(m.facets(pg["top"]), c, 0.0)
    x = ufl.SpatialCoordinate(md.mesh)
    m.add_traction(pg["top"], ufl.as_vector([0.0, -1e5 * (1.0 - 1.2 * x[0] / W), 0.0]))
    m.add_traction(pg["top"], [1e4, 0.0, 0.0], schedule=lambda t: max(t - 1.0, 0.0))
    itf = build_interface(
        m.V, md.facet_tags, pg["upper_contact"], pg["lower_contact"], dirichlet_dofs=m.bc_dofs()
    )
    return m, itf


def _sphere(comm: MPI.Comm) -> tuple[Mechanics, object]:
    """Hemisphere (R = 10 mm) on a block of the same material (2 GPa), pressed by
    a²/R with a = 1 mm, then dragged sideways by 12 µm."""
    md = meshing.hertz_3d(comm, h_contact=6e-4, zone=1.5e-3)
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    mats = {pg["sphere"]: Isotropic(E=2e9, nu=0.3), pg["block"]: Isotropic(E=2e9, nu=0.3)}
    m = Mechanics(md.mesh, mats, md.cell_tags, md.facet_tags)
    for c in range(3):
        m.add_dirichlet(m.facets(pg["block_bottom"]), c, 0.0)
    m.add_dirichlet(m.facets(pg["sphere_top"]), 1, -1e-6 / 0.01)
    m.add_dirichlet(m.facets(pg["sphere_top"]), 2, 0.0)
    drag = lambda t: min(max(t - 1.0, 0.0), 1.0)  # noqa: E731
    m.add_dirichlet(m.facets(pg["sphere_top"]), 0, 1.2e-5, schedule=drag)
    itf = build_interface(
        m.V, md.facet_tags, pg["sphere_contact"], pg["block_contact"], dirichlet_dofs=m.bc_dofs()
    )
    return m, itf


#: name -> (scene, friction law, strategy, linear solver, 3D slip rows, steps)
CASES = {
    "2d-frictionless-lowrank": ("liftoff", FrictionLaw(), "lowrank", "direct", "newton", 1),
    "2d-frictionless-refactor": ("liftoff", FrictionLaw(), "refactor", "direct", "newton", 1),
    "2d-frictionless-krylov": ("liftoff", FrictionLaw(), "refactor", "iterative", "newton", 1),
    "2d-tresca-lowrank": ("shear", FrictionLaw("tresca", bound=5e4), "lowrank", "direct", "", 2),
    "2d-coulomb-fp-refactor": (
        "shear",
        FrictionLaw("coulomb", coefficient=0.6, update="fixed_point"),
        "refactor",
        "direct",
        "",
        2,
    ),
    "2d-dynamic-tresca-lowrank": (
        "impact",
        FrictionLaw("tresca", bound=2e5),
        "lowrank",
        "direct",
        "",
        4,
    ),
    # edge nodes (docs/theory/pdas.md#edge-of-the-contact-zone) on one rank, none on
    # another: the replaced rows of the refactorised system (a collective assembly)
    "2d-dynamic-tresca-edges-refactor": (
        "impact",
        FrictionLaw("tresca", bound=1e4),
        "refactor",
        "direct",
        "",
        6,
    ),
    "2d-dynamic-coulomb-refactor": (
        "impact",
        FrictionLaw("coulomb", coefficient=0.5),
        "refactor",
        "direct",
        "",
        4,
    ),
    "3d-liftoff-tresca-lowrank": (
        "boxes",
        FrictionLaw("tresca", bound=2e4),
        "lowrank",
        "direct",
        "newton",
        2,
    ),
    "3d-liftoff-frictionless-refactor": ("boxes", FrictionLaw(), "refactor", "direct", "", 1),
    "3d-frictionless-lowrank": ("sphere", FrictionLaw(), "lowrank", "direct", "newton", 1),
    "3d-coulomb-newton-lowrank": (
        "sphere",
        FrictionLaw("coulomb", coefficient=0.3),
        "lowrank",
        "direct",
        "newton",
        2,
    ),
}
SLOW = {
    "3d-coulomb-newton-lowrank",
    "3d-liftoff-frictionless-refactor",
    "2d-frictionless-refactor",
    "2d-coulomb-fp-refactor",
    "2d-dynamic-tresca-lowrank",
}


def _solver(comm: MPI.Comm, name: str) -> tuple[Integrator, object]:
    scene, law, strategy, linear, slip_3d, _ = CASES[name]
    opts = PDASOptions(
        friction=law,
        max_iterations=60,
        linear=LinearOptions(strategy=strategy),
        slip=SlipOptions(slip_3d=slip_3d or "newton"),
        active_set=ActiveSetOptions(),
    )
    if scene in ("sphere", "boxes"):
        m, itf = _sphere(comm) if scene == "sphere" else _boxes(comm, law.kind == "none")
        return Integrator(
            m, "static", 1.0, linear=linear, contact=ContactSolver(m.V, [itf], opts)
        ), itf
    m, itf, md, pg = _blocks(comm, scene, scene == "impact")
    if scene != "impact":
        contact = ContactSolver(m.V, [itf], opts)
        return Integrator(m, "static", 1.0, linear=linear, contact=contact), itf
    integ = Integrator(m, "dynamic", 2e-4, linear=linear, contact=ContactSolver(m.V, [itf], opts))
    v0 = fem.Function(m.V)
    dofs = fem.locate_dofs_topological(m.V, md.mesh.topology.dim, md.cell_tags.find(pg["upper"]))
    v0.x.array.reshape(-1, 2)[dofs] = [2.0, -1.0]
    integ.set_initial(None, v0)
    return integ, itf


def _gathered(comm: MPI.Comm, values: np.ndarray) -> np.ndarray:
    return np.concatenate(comm.allgather(np.asarray(values)), axis=0)


def _record(comm: MPI.Comm, integ: Integrator, itf) -> dict:
    """The numbers compared: history, resultants, per-node fields in coordinate order."""
    r = integ.last_contact
    X = np.round(_gathered(comm, itf.coords), 12)  # (round-off of 1e-19 m seen at x = 0)
    order = np.lexsort(X.T[::-1])
    fields = {
        "p": _gathered(comm, r.pressure[0])[order],
        "gap": _gathered(comm, r.gap[0])[order],
        # the friction traction as a vector (the tangent frames of a node may differ)
        "tt": _gathered(comm, np.einsum("pj,pjx->px", r.traction_t[0], itf.tangents))[order],
        "status": _gathered(comm, r.status[0])[order],
    }
    hist = [(h["active"], h.get("stick", 0), h.get("slip", 0), h["changed"]) for h in r.history]
    return {"hist": hist, "N": r.normal_force[0], "T": r.tangential_force[0], **fields}


def _run(comm: MPI.Comm, name: str, check=None) -> list[dict]:
    integ, itf = _solver(comm, name)
    out = []
    try:
        for _ in range(CASES[name][-1]):
            TRAFFIC.reset()
            integ.step()
            if check is not None:
                check(integ.contact, itf)
            out.append(_record(comm, integ, itf))
    finally:
        integ.destroy()
    return out


def _local_only(solver: ContactSolver, itf) -> None:
    """No array of the contact logic has the size of the slave nodes of all ranks."""
    lay = solver.system.layout
    n, ng = lay.n_nodes, lay.n_global
    assert n == itf.num_owned
    w = solver.warm
    for a in (w.active, w.directions, w.lam_n_prev, solver.system.D, solver.system.gap):
        assert a.shape[0] == n
    assert solver.system.scale.shape[0] == lay.bs * n
    for a in (solver.friction.kind, solver.friction.mu, solver.friction.bound):
        assert a.shape[0] == n
    lowrank = getattr(solver.linear_solver, "lowrank", None)
    for col, kcol in lowrank.cache.values() if lowrank is not None else []:
        assert col.shape[0] == kcol.shape[0] == lay.bs * n
    # the reductions of the set logic: far less than one number per slave node of all ranks
    largest = TRAFFIC.largest.get("reduce", 0)
    assert largest < 8 * ng, (largest, ng)
    SHARED.append(COMM.allreduce(int(w.active.any()), op=MPI.SUM))


#: per checked step, how many ranks hold active slave nodes
SHARED: list[int] = []


@pytest.mark.parametrize(
    "name", [pytest.param(k, marks=pytest.mark.slow) if k in SLOW else k for k in CASES]
)
def test_distributed_sets_equal_the_serial_solve(name):
    SHARED.clear()
    check = _local_only if COMM.size > 1 else None
    par = _run(COMM, name, check)
    ref = _run(MPI.COMM_SELF, name) if COMM.rank == 0 else None
    ref = COMM.bcast(ref, root=0)
    # the contact zone is split between ranks (else the test would not test anything;
    # the small zone under the sphere may lie on one rank)
    assert COMM.size == 1 or CASES[name][0] == "sphere" or max(SHARED) >= 2
    for k, (a, b) in enumerate(zip(par, ref)):
        assert a["hist"] == b["hist"], (k, a["hist"], b["hist"])
        assert (a["status"] == b["status"]).all()
        pmax = max(float(np.abs(b["p"]).max()), 1e-300)
        assert np.abs(a["p"] - b["p"]).max() <= TOL * pmax
        assert np.abs(a["tt"] - b["tt"]).max() <= TOL * pmax
        gmax = max(float(np.abs(b["gap"]).max()), 1e-9)
        assert np.abs(a["gap"] - b["gap"]).max() <= TOL * gmax
        assert a["N"] == pytest.approx(b["N"], rel=TOL)
        assert abs(a["T"] - b["T"]) <= TOL * abs(b["N"])
