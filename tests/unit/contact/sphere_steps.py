"""The 3D hemisphere impact stepped by stabilized Newmark (Δt = t_c/50), shared by the
low-rank tests that compare two runs of it step by step (columns ahead, full columns).

Not a test module (no ``test_`` prefix); the contact tests import it by name (pytest puts
this folder on ``sys.path``).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import numpy as np
from dolfinx import fem

from bonecontact.contact.options import PDASOptions
from bonecontact.contact.pdas import ContactSolver
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.newmark import make_integrator
from bonecontact.verification.sphere_impact import SphereImpact, sphere_model

COMM = MPI.COMM_WORLD


def impact(h: float, opts: PDASOptions, sideways: bool = False) -> tuple[Integrator, ContactSolver]:
    """The impact with contact mesh size ``h`` (far field 10 h) and the contact solver's
    ``opts``, started at the velocity v₀ towards the block (and v₀/2 along x with
    ``sideways``, for a frictional run)."""
    p = SphereImpact(h_contact=h, h_far=10 * h)
    m, itf, sphere = sphere_model(p, COMM)
    cs = ContactSolver(m.V, [itf], opts)
    integ = make_integrator(
        "stabilized-newmark", m, "dynamic", p.contact_time / 50, contact=cs, energy_balance=True
    )
    v0 = fem.Function(m.V)
    v0.x.array[:] = -p.v0 * sphere.x.array
    if sideways:  # (along x: the dof before each vertical one)
        v0.x.array[np.flatnonzero(sphere.x.array) - 1] = 0.5 * p.v0
    integ.set_initial(None, v0)
    return integ, cs


def run_steps(integ: Integrator, steps: int) -> dict[str, list]:
    """Step ``integ`` ``steps`` times; per step the displacement, PDAS iterations, active
    and slipping nodes and the energy terms."""
    out: dict[str, list] = {"u": [], "its": [], "active": [], "slip": [], "energy": []}
    for _ in range(steps):
        integ.step()
        res = integ.last_contact
        out["u"].append(integ.u.x.array.copy())
        out["its"].append(res.iterations)
        out["active"].append(res.n_active[0])
        out["slip"].append(res.n_slip[0])
        b = integ.last_balance
        out["energy"].append((b.kinetic + b.strain, b.numerical_dissipation, b.contact_work))
    return out


def assert_same_steps(ref: dict[str, list], new: dict[str, list]) -> None:
    """The two runs took the same steps: PDAS iterations, active and slipping counts
    exactly, every displacement to 1e-10 of the largest, the energy terms to 1e-10."""
    assert new["its"] == ref["its"]
    assert new["active"] == ref["active"]
    assert new["slip"] == ref["slip"]
    scale = COMM.allreduce(max(np.abs(u).max() for u in ref["u"]), op=MPI.MAX)
    diff = COMM.allreduce(max(np.abs(a - b).max() for a, b in zip(new["u"], ref["u"])), op=MPI.MAX)
    assert diff <= 1e-10 * scale
    e_ref, e_new = np.array(ref["energy"]), np.array(new["energy"])
    assert np.abs(e_new - e_ref).max() <= 1e-10 * np.abs(e_ref).max()
