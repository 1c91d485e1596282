"""The Krylov tolerance of the iterative contact path (bonecontact.contact.krylov.krylov_rtol).

A scene's ``[solver] tolerance`` of 1e-6 makes the contact solve's final (settled-set)
Krylov solve stop at rtol 1e-8, the criterion of one plain linear solve (the benchmarks'
reference).  The PDAS decides its sets from the signs of ``λ_n + c_n (u_n − g)``; the
question is whether that tolerance changes the sets, the PDAS path or the answer.

Family: load-driven (the body held only by the contact) and clamped (the top face
displaced), 2D and 3D, stiffness contrast 1e3.  Reference, independent of the Krylov
path: the direct solver (MUMPS LU, low-rank PDAS).  Measured (serial): the same active
set and PDAS iterations at rtol 1e-8 as at 1e-12 and as the direct path; displacement
and pressure within 1e-8–4e-8 of the direct ones (4e-13–5e-12 at 1e-12); the final
solve 10–13 CG iterations shorter.
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest

from bonecontact.contact.interface import build_interface
from bonecontact.contact.krylov import PLAIN_RTOL, krylov_rtol
from bonecontact.contact.options import PDASOptions
from bonecontact.contact.pdas import ContactSolver
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics
from bonecontact.meshing import shapes as meshing
from bonecontact.verification.load_driven import (
    half_disc_on_block_2d,
    hertz_errors,
    sphere_on_block_3d,
)

COMM = MPI.COMM_WORLD
E_SOFT, CONTRAST, NU = 2.0e9, 1.0e3, 0.3
#: The runs: the direct reference and the iterative path at the default and the plain tolerance.
RUNS = (("direct", 1e-12), ("iterative", 1e-12), ("iterative", krylov_rtol(1e-6)))
_CACHE: dict = {}


def test_scene_tolerance_to_krylov_rtol():
    """1e-2 · tolerance, at most the plain solve's 1e-8: the default keeps 1e-12."""
    assert krylov_rtol(1e-10) == pytest.approx(1e-12, rel=1e-12)
    assert krylov_rtol(1e-6) == pytest.approx(1e-8, rel=1e-12) == PLAIN_RTOL
    assert krylov_rtol(1e-3) == PLAIN_RTOL
    assert krylov_rtol(1e-14) == pytest.approx(1e-16, rel=1e-12)


def _clamped(dim: int, linear: str, rtol: float, options: PDASOptions | None = None):
    """Hertz by a prescribed approach of the curved body's top face (the block clamped at
    its base): a ≈ 0.05 R in 2D, 0.1 R in 3D."""
    if dim == 2:
        md = meshing.hertz_2d(COMM, h_contact=1.25e-4, zone=7.5e-4, h_far=2e-3)
        body, top, slave, delta = "cylinder", "cyl_top", "cyl_contact", 5e-5
    else:
        md = meshing.hertz_3d(COMM, h_contact=6e-4, zone=1.5e-3)
        body, top, slave, delta = "sphere", "sphere_top", "sphere_contact", 1e-4
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    soft, stiff = Isotropic(E=E_SOFT, nu=NU), Isotropic(E=CONTRAST * E_SOFT, nu=NU)
    materials = {pg[body]: soft, pg["block"]: stiff}
    m = Mechanics(md.mesh, materials, md.cell_tags, md.facet_tags)
    for c in range(dim):
        m.add_dirichlet(m.facets(pg["block_bottom"]), c, 0.0)
        m.add_dirichlet(m.facets(pg[top]), c, -delta if c == 1 else 0.0)
    itf = build_interface(
        m.V, md.facet_tags, pg[slave], pg["block_contact"], dirichlet_dofs=m.bc_dofs()
    )
    contact = ContactSolver(m.V, [itf], options)
    integ = Integrator(m, "static", 1.0, linear=linear, rtol=rtol, contact=contact)
    integ.step()
    return integ, m, None


def _load_driven(dim: int, linear: str, rtol: float, options: PDASOptions | None = None):
    """The load-driven problems of bonecontact.verification.load_driven (contrast 1e3)."""
    if dim == 2:
        pb = half_disc_on_block_2d(COMM, 1e-4, linear=linear, rtol=rtol, options=options)
    else:
        pb = sphere_on_block_3d(COMM, 6e-4, h_far=4.5e-3, linear=linear, rtol=rtol, options=options)
    pb.solve()
    return pb.integrator, pb.model, pb


def _runs(kind: str, dim: int) -> dict:
    """The three runs of one family member: displacement (owned), pressure, status, PDAS
    and Krylov iterations, per-iteration Krylov tolerance, Hertz errors (load-driven)."""
    key = (kind, dim)
    if key in _CACHE:
        return _CACHE[key]
    out = {}
    for linear, rtol in RUNS:
        integ, m, pb = (_load_driven if kind == "load-driven" else _clamped)(dim, linear, rtol)
        r = integ.last_contact
        n = m.V.dofmap.index_map.size_local * dim
        out[(linear, rtol)] = {
            "u": integ.u.x.array[:n].copy(),
            "p": r.pressure[0].copy(),
            "status": list(r.status[0]),
            "pdas": r.iterations,
            "active": int(sum(r.n_active)),
            "its": [h.get("linear_iterations", 0) for h in r.history],
            "hertz": hertz_errors(pb, r) if pb is not None else None,
        }
        integ.destroy()
    _CACHE[key] = out
    return out


def _rel_max(a: np.ndarray, b: np.ndarray) -> float:
    num = COMM.allreduce(float(np.abs(a - b).max(initial=0.0)), op=MPI.MAX)
    den = COMM.allreduce(float(np.abs(b).max(initial=0.0)), op=MPI.MAX)
    return num / den


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("kind", ["load-driven", "clamped"])
def test_plain_tolerance_keeps_sets_and_answer(kind, dim):
    """rtol 1e-8: the direct path's active set (node by node) and PDAS iterations, its
    displacement and pressure to 1e-6 (measured ≤ 4e-8), and shorter final solves."""
    runs = _runs(kind, dim)
    direct, tight, plain = (runs[k] for k in RUNS)
    assert direct["active"] >= 3  # a contact zone, not a point
    for got in (tight, plain):
        assert got["status"] == direct["status"]
        assert got["active"] == direct["active"]
        assert got["pdas"] == direct["pdas"]
    assert _rel_max(tight["u"], direct["u"]) < 1e-10
    assert _rel_max(plain["u"], direct["u"]) < 1e-6
    assert _rel_max(plain["p"], direct["p"]) < 1e-6
    # the same PDAS path: the loose solves alike, only the final solve shorter
    assert plain["its"][:-1] == tight["its"][:-1]
    assert plain["its"][-1] < tight["its"][-1]


@pytest.mark.parametrize("dim", [2, 3])
def test_plain_tolerance_keeps_the_hertz_errors(dim):
    """The Hertz errors of a and p₀ (load-driven) at rtol 1e-8 equal those at 1e-12 and
    of the direct path to 1e-6 (they are 1e-3–1e-2 themselves); the contact resultant
    balances the load to 1e-6."""
    runs = _runs("load-driven", dim)
    ref = runs[RUNS[0]]["hertz"]
    for k in RUNS[1:]:
        got = runs[k]["hertz"]
        assert abs(got["a"] - ref["a"]) < 1e-6
        assert abs(got["p0"] - ref["p0"]) < 1e-6
        assert got["equilibrium"] < 1e-6
