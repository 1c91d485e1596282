"""Verification problems shared by the tests and the benchmarks.

:func:`solve_hertz_3d`: a hemisphere pressed on a block, solved by the PDAS and
compared with Hertz's solution.
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np

from bonecontact.contact.interface import build_interface
from bonecontact.contact.pdas import ContactSolver
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics
from bonecontact.meshing import shapes as meshing
from bonecontact.verification.analytic import hertz_3d

__all__ = ["HERTZ_3D_NU", "HERTZ_3D_RADIUS", "solve_hertz_3d"]

#: Sphere radius (m) and Poisson ratio of :func:`solve_hertz_3d`.
HERTZ_3D_RADIUS, HERTZ_3D_NU = 0.01, 0.3


def solve_hertz_3d(
    h: float, E1: float = 2.0e9, E2: float = 17.0e9, comm: MPI.Comm = MPI.COMM_WORLD
) -> dict:
    """Hemisphere (R = 10 mm) on a block, approach δ = a²/R for a ≈ 1 mm (a/R ≈ 0.1);
    CG + GAMG on the condensed system.  Returns relative errors of the contact radius
    (fit of λ² = p₀²(1 − r²/a²) over r < 0.8a) and of the fitted peak pressure.

    Parameters
    ----------
    h
        Mesh size at the contact (m).
    E1, E2
        Young's moduli of the sphere and of the block (Pa).
    comm
        Communicator.

    Returns
    -------
    dict
        ``a``, ``p0`` (relative errors), ``a_over_R`` and the PDAS ``iterations``.
    """
    R, NU = HERTZ_3D_RADIUS, HERTZ_3D_NU
    a_t = 1.0e-3
    md = meshing.hertz_3d(comm, h_contact=h, zone=1.5 * a_t)
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    m = Mechanics(
        md.mesh,
        {pg["sphere"]: Isotropic(E=E1, nu=NU), pg["block"]: Isotropic(E=E2, nu=NU)},
        md.cell_tags,
        md.facet_tags,
    )
    for c in range(3):
        m.add_dirichlet(m.facets(pg["block_bottom"]), c, 0.0)
        m.add_dirichlet(m.facets(pg["sphere_top"]), c, -(a_t**2) / R if c == 1 else 0.0)
    itf = build_interface(
        m.V, md.facet_tags, pg["sphere_contact"], pg["block_contact"], dirichlet_dofs=m.bc_dofs()
    )
    integ = Integrator(m, "static", 1.0, linear="iterative", contact=ContactSolver(m.V, [itf]))
    integ.step()
    r = integ.last_contact
    X = np.concatenate(comm.allgather(itf.coords))
    lam = np.concatenate(comm.allgather(r.pressure[0]))
    P = comm.allreduce(float(-(itf.weight * r.pressure[0] * itf.normals[:, 1]).sum()), op=MPI.SUM)
    rr = np.hypot(X[:, 0], X[:, 2])
    a_ref, p0_ref = (
        hertz_3d.radius(P, R, E1, NU, E2, NU),
        hertz_3d.peak_pressure(P, R, E1, NU, E2, NU),
    )
    sel = rr < 0.8 * a_ref
    c0, c1 = np.linalg.lstsq(np.c_[np.ones(sel.sum()), rr[sel] ** 2], lam[sel] ** 2, rcond=None)[0]
    out = {
        "a": np.sqrt(-c0 / c1) / a_ref - 1.0,
        "p0": np.sqrt(c0) / p0_ref - 1.0,
        "a_over_R": a_ref / R,
        "iterations": r.iterations,
    }
    integ.destroy()
    return out
