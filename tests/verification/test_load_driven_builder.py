"""The load-driven Hertz builders (bonecontact.verification.load_driven) at coarse sizes.

The curved body is held in the load direction only by the contact, so its vertical
contact resultant must equal the applied load (the sum of the assembled load vector) to
round-off — equilibrium, independent of the mesh.  a and p₀ (fitted) are compared with
Hertz's solution for the measured resultant (docs/theory/verification.md#hertz-contact)
within bounds that fit these coarse meshes; measured (serial, 2 ranks: the same):

* 3D, h_contact = 0.4 mm (a/h = 2.5, 9114 dofs): a −6.4 %, p₀ +14.2 %, 4 PDAS its;
* 2D, h_contact = 0.2 mm (a/h = 5, 8992 dofs): a −1.6 %, p₀ +1.9 %, 2 PDAS its.
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest

from bonecontact.verification import (
    LOAD_DRIVEN_E,
    LOAD_DRIVEN_NU,
    LOAD_DRIVEN_RADIUS,
    LOAD_DRIVEN_STIFFNESS_RATIO,
    half_disc_on_block_2d,
    hertz_2d,
    hertz_3d,
    hertz_errors,
    sphere_on_block_3d,
)

R, E1, NU = LOAD_DRIVEN_RADIUS, LOAD_DRIVEN_E, LOAD_DRIVEN_NU
E2 = LOAD_DRIVEN_STIFFNESS_RATIO * E1


def _solve(builder, h: float) -> tuple[dict, object]:
    pb = builder(MPI.COMM_WORLD, h)
    pb.solve()
    err = hertz_errors(pb)
    timings = dict(pb.timings)
    pb.destroy()
    return err, timings


def test_sphere_on_block_3d_equilibrium_and_hertz():
    err, timings = _solve(sphere_on_block_3d, 4e-4)
    # held only by contact: the resultant is the applied load
    assert err["equilibrium"] < 1e-8
    # the applied load is the traction over the faceted flat face (area within 3 % of
    # πR²) for the Hertz load of a = 0.1 R
    P_hertz = hertz_3d.load_for_radius(0.1 * R, R, E1, NU, E2, NU)
    assert err["P_applied"] == pytest.approx(P_hertz, rel=0.03)
    assert abs(err["a"]) < 0.10
    assert abs(err["p0"]) < 0.20
    assert err["active"] > 10
    assert set(timings) >= {"mesh", "assembly", "mortar", "setup", "contact_solve"}


def test_half_disc_on_block_2d_equilibrium_and_hertz():
    err, _ = _solve(half_disc_on_block_2d, 2e-4)
    assert err["equilibrium"] < 1e-8
    # the flat face is exactly 2R long: the applied load is exactly Hertz's
    P_hertz = hertz_2d.load_for_half_width(0.1 * R, R, E1, NU, E2, NU)
    assert err["P_applied"] == pytest.approx(P_hertz, rel=1e-10)
    assert abs(err["a"]) < 0.05
    assert abs(err["p0"]) < 0.05
    assert np.isfinite(err["a_over_R"]) and err["a_over_R"] == pytest.approx(0.1, rel=0.01)
