"""The warm-started friction state (``SlipOptions.warm_slip``,
docs/theory/pdas.md#warm-started-friction): a contact solve that starts from the last
step's stick/slip set, slip directions, traction and ξ converges to the solution of the
solve that starts with every active node sticking (the elastic trial state).

A soft block (20 MPa) pressed by a graded pressure ``P0 (1 − 0.8 x/W)`` onto a stiff one
(17 GPa, clamped), its top dragged sideways step by step (quasi-static); in 3D the drag
turns by 25° a step, so the slip directions change and the 3D Newton slip rows are
iterated.  Family: 2D/3D, Tresca (ĝ = 0.3 P0) and semi-implicit Coulomb (μ = 0.3), a
small drag (most active nodes stick) and a large one (most slip).  References: the
cold-started solve of the same step (same sets, tractions and pressures to the
solver's tolerance ``direction_tol`` = 1e-6 of the largest bound, displacements to
1e-6 of their maximum) and the friction law at every node (stick: no slip of the
step; slip: ``|λ_t| = ĝ`` along the slip).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import numpy as np
import pytest
from two_blocks import P0, W, friction_blocks

from bonecontact.contact.friction import FrictionLaw
from bonecontact.contact.interface import build_interface
from bonecontact.contact.options import PDASOptions, SlipOptions
from bonecontact.contact.pdas import ContactSolver
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics

COMM = MPI.COMM_WORLD
STEPS = 4  # (step 1 presses, steps 2-4 drag)
#: drag amplitudes (m) of the last step: most active nodes stick / slip
DRAGS = {"stick": 4.0e-6, "slip": 6.0e-5}
TOL = 1e-6  # SlipOptions.direction_tol (default)


def _g(x) -> np.ndarray:
    return np.concatenate(COMM.allgather(np.asarray(x)))


def _model(dim: int, drag: float):
    """The two blocks (module docstring) and their interface."""
    md, pg = friction_blocks(COMM, dim)
    mats = {pg["lower"]: Isotropic(E=17.0e9, nu=0.3), pg["upper"]: Isotropic(E=20.0e6, nu=0.3)}
    m = Mechanics(md.mesh, mats, md.cell_tags, md.facet_tags)
    for c in range(dim):
        m.add_dirichlet(m.facets(pg["bottom"]), c, 0.0)

    def ramp(t: float) -> float:
        return max(t - 1.0, 0.0) / (STEPS - 1)

    def turn(t: float) -> float:  # (3D: the drag turns; 2D: it grows along x)
        return np.deg2rad(25.0) * max(t - 1.0, 0.0) if dim == 3 else 0.0

    top = m.facets(pg["top"])
    m.add_dirichlet(top, 0, drag, schedule=lambda t: ramp(t) * np.cos(turn(t)))
    if dim == 3:
        m.add_dirichlet(top, 2, drag, schedule=lambda t: ramp(t) * np.sin(turn(t)))
    import ufl

    x = ufl.SpatialCoordinate(md.mesh)
    load = [0.0] * dim
    load[1] = -P0 * (1.0 - 0.8 * x[0] / W)
    m.add_traction(pg["top"], ufl.as_vector(load))
    itf = build_interface(
        m.V, md.facet_tags, pg["upper_contact"], pg["lower_contact"], dirichlet_dofs=m.bc_dofs()
    )
    return m, itf


def _run(dim: int, law: FrictionLaw, drag: float, warm: bool) -> list[dict]:
    """The steps of the drag, with or without the warm-started friction state: per step
    the gathered status, pressure, traction, slip, displacement, PDAS iterations and the
    slip count of the first iteration."""
    m, itf = _model(dim, drag)
    opts = PDASOptions(friction=law, max_iterations=60, slip=SlipOptions(warm_slip=warm))
    integ = Integrator(m, "static", 1.0, contact=ContactSolver(m.V, [itf], opts))
    out = []
    for _ in range(STEPS):
        integ.step()
        r = integ.last_contact
        n = m.V.dofmap.index_map.size_local * m.V.dofmap.index_map_bs
        out.append(
            {
                "status": _g(r.status[0]),
                "p": _g(r.pressure[0]),
                "q": _g(r.traction_t[0]).reshape(-1, dim - 1),
                "slip": _g(r.slip[0]).reshape(-1, dim - 1),
                "u": _g(integ.u.x.array[:n]),
                "its": r.iterations,
                "first_slip": r.history[0]["slip"],
            }
        )
    integ.destroy()
    return out


def _check_law(s: dict, bound: np.ndarray, drag: float) -> None:
    """Stick: no slip of the step (1e-10 of the drag); slip under pressure:
    ``|λ_t| = ĝ`` (to the solver's tolerance) and the traction along the slip."""
    gmax = float(bound.max())
    stick, slip = s["status"] == "stick", s["status"] == "slip"
    assert np.abs(s["slip"][stick]).max(initial=0.0) <= 1e-10 * drag
    q = np.linalg.norm(s["q"], axis=1)
    # (a slip node without pressure is at the edge of the zone: |λ_t| < ĝ there)
    pressed = slip & (bound > 1e-9 * gmax) & (s["p"] > 1e-9 * float(s["p"].max()))
    assert np.abs(q[pressed] - bound[pressed]).max(initial=0.0) <= 10 * TOL * gmax
    assert np.all((s["q"][pressed] * s["slip"][pressed]).sum(axis=1) >= 0.0)


LAWS = {
    "tresca": FrictionLaw("tresca", bound=0.3 * P0),
    "coulomb": FrictionLaw("coulomb", coefficient=0.3),
}


@pytest.mark.parametrize("regime", ["stick", "slip"])
@pytest.mark.parametrize("law", ["tresca", "coulomb"])
@pytest.mark.parametrize("dim", [2, 3])
def test_warm_started_friction_gives_the_cold_started_solution(dim, law, regime):
    """Every step of the drag: the warm-started solve has the cold-started one's sets,
    pressures and tractions (to ``direction_tol`` of the largest bound) and displacements
    (1e-6 of their maximum), both satisfy the friction law, the regime is the one named
    (most active nodes stick / slip at the last step) and, where nodes slipped at the
    end of a step, the next warm-started solve starts with them slipping (the cold one
    with none)."""
    warm = _run(dim, LAWS[law], DRAGS[regime], True)
    cold = _run(dim, LAWS[law], DRAGS[regime], False)
    for k, (w, c) in enumerate(zip(warm, cold)):
        assert np.array_equal(w["status"], c["status"]), f"step {k + 1}"
        pmax = float(np.abs(c["p"]).max())
        gmax = 0.3 * (P0 if law == "tresca" else pmax)
        assert np.abs(w["p"] - c["p"]).max() <= TOL * pmax, f"step {k + 1}"
        assert np.abs(w["q"] - c["q"]).max() <= TOL * gmax, f"step {k + 1}"
        umax = float(np.abs(c["u"]).max())
        assert np.abs(w["u"] - c["u"]).max() <= TOL * umax, f"step {k + 1}"
        assert c["first_slip"] == 0
        if k > 0 and (cold[k - 1]["status"] == "slip").any():
            assert w["first_slip"] > 0, f"step {k + 1}"
    last = cold[-1]["status"]
    n_stick, n_slip = int((last == "stick").sum()), int((last == "slip").sum())
    assert (n_stick > n_slip) if regime == "stick" else (n_slip > n_stick), (n_stick, n_slip)
    # the friction law at every node of the last step (Tresca: the bound; Coulomb: μ
    # times the previous step's pressure, semi-implicit)
    bound = np.full(last.size, 0.3 * P0) if law == "tresca" else 0.3 * cold[-2]["p"]
    for s in (warm[-1], cold[-1]):
        _check_law(s, bound, DRAGS[regime])


@pytest.mark.parametrize("dim", [2, 3])
def test_warm_friction_state_survives_a_restart(dim):
    """``Integrator.state`` carries the friction state of the warm start (stick set,
    ``λ_t``, ``ξ``: the checkpoint's fields): a run restored after step 2 repeats steps
    3 and 4 of the uninterrupted run (the same PDAS iterations, displacements to 1e-12
    of the largest); restored without those keys (an older checkpoint) it starts them
    cold and reaches the same solution to the solver's tolerance."""
    law = LAWS["coulomb"]

    def integrator():
        m, itf = _model(dim, DRAGS["slip"])
        opts = PDASOptions(friction=law, max_iterations=60, slip=SlipOptions(warm_slip=True))
        return m, Integrator(m, "static", 1.0, contact=ContactSolver(m.V, [itf], opts))

    def steps(integ, m, k):
        out = []
        for _ in range(k):
            integ.step()
            n = m.V.dofmap.index_map.size_local * m.V.dofmap.index_map_bs
            out.append((integ.last_contact.iterations, _g(integ.u.x.array[:n])))
        return out

    m, ref = integrator()
    full = steps(ref, m, STEPS)
    ref.destroy()
    m, first = integrator()
    steps(first, m, 2)
    saved = first.state()
    first.destroy()
    old = {**saved, "contact": {k: v for k, v in saved["contact"].items()}}
    for key in ("stick", "lam_t", "xi"):
        del old["contact"][key]
    for state, exact in ((saved, True), (old, False)):
        m, again = integrator()
        again.restore_state(state)
        rest = steps(again, m, STEPS - 2)
        again.destroy()
        umax = float(np.abs(full[-1][1]).max())
        for (its, u), (its_ref, u_ref) in zip(rest, full[2:]):
            if exact:
                assert its == its_ref
            tol = 1e-12 if exact else TOL
            assert np.abs(u - u_ref).max() <= tol * umax
