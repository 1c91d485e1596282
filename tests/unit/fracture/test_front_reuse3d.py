"""The front points of one crack model share their set-up (fracture.front3d; issue #26:
K at many front points cost more than the solve).

``front_interaction_integral`` keeps, per model, the P1 q-function, the boundary dofs and
the interaction integral compiled once, and assembles each point over its own support
cells (and the crack-face facets next to them).  What is kept must not carry one point's
or one displacement's data into another:

* a point evaluated after others on the same model gives the K of the same point on a
  fresh copy of the model, to 1e-14 (the penny octant: half model; a Newman–Raju surface
  crack, a/c = 0.5, reduced mesh: both faces and their face term) — any stale q, support
  or face facets would change it by far more;
* a second displacement on the same model gives its own K: 2u gives 2K exactly (the
  integral is linear in u; a form kept for the first u would give K again);
* the refusals of a point whose domain holds no cell still come after good points.

Penny octant: radius 1, block 4, front 1/10 (E = 1, ν = 0.3, σ = 1 on top).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import dataclasses
import math

from mpi4py import MPI

import numpy as np
import pytest

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.front3d import (
    EllipticalFront,
    front_interaction_integral,
    mesh_crack_octant,
)
from bonecontact.fracture.surface3d import SurfaceCrack, domain_length
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics
from bonecontact.verification.surface_crack import PlateProblem, solve_plate

MAT = Isotropic(E=1.0, nu=0.3)
R_OUT = 0.3
A = 0.2  # the surface crack's depth (a/t = 0.2)


@pytest.fixture(scope="module")
def penny():
    blk = mesh_crack_octant(EllipticalFront(1.0, 1.0), 4.0, 0.1, 0.12, 1.0, MPI.COMM_WORLD)
    m = Mechanics(blk.mesh, MAT, blk.cell_tags, blk.facet_tags)
    g = blk.groups
    m.add_dirichlet(m.facets(g["sym_x"]), 0, 0.0)
    m.add_dirichlet(m.facets(g["sym_y"]), 1, 0.0)
    m.add_dirichlet(m.facets(g["ligament"]), 2, 0.0)
    m.add_traction(g["top"], (0.0, 0.0, 1.0))
    integ = Integrator(m, "static", 1.0)
    integ.step()
    u = integ.u.copy()
    integ.destroy()
    return blk, u


@pytest.fixture(scope="module")
def plate():
    crack = SurfaceCrack("semi_elliptical", A, 2 * A)
    sizes = {"h_front": A / 10, "grading": 0.15, "h_max": 0.4, "r_out": 0.3 * A}
    return solve_plate(PlateProblem(crack, 2.0, 2.0, 1.0, **sizes))


def _modes(k) -> np.ndarray:
    return np.array([k.K_I, k.K_II, k.K_III, k.G])


def test_penny_point_after_others_equals_a_fresh_model(penny) -> None:
    blk, u = penny
    phis = np.radians([30.0, 60.0, 45.0, 0.0, 45.0])
    seq = [_modes(front_interaction_integral(u, blk, float(p), MAT, R_OUT)) for p in phis]
    fresh = dataclasses.replace(blk)  # the same mesh, nothing kept yet
    alone = _modes(front_interaction_integral(u, fresh, float(phis[2]), MAT, R_OUT))
    np.testing.assert_allclose(seq[2][[0, 3]], alone[[0, 3]], rtol=1e-14)
    np.testing.assert_allclose(seq[4][[0, 3]], alone[[0, 3]], rtol=1e-14)
    assert abs(seq[1][0] / seq[2][0] - 1) > 1e-4  # the points differ (not one answer)
    assert seq[0][0] == pytest.approx(2 * math.sqrt(1 / math.pi), rel=0.05)


def test_penny_second_displacement_gives_its_own_k(penny) -> None:
    blk, u = penny
    k1 = front_interaction_integral(u, blk, math.pi / 4, MAT, R_OUT).K_I
    u2 = u.copy()
    u2.x.array[:] *= 2.0
    k2 = front_interaction_integral(u2, blk, math.pi / 4, MAT, R_OUT).K_I
    assert k2 == pytest.approx(2.0 * k1, rel=1e-14)
    assert front_interaction_integral(u, blk, math.pi / 4, MAT, R_OUT).K_I == k1


def test_penny_refusal_after_good_points(penny) -> None:
    blk, u = penny
    front_interaction_integral(u, blk, math.pi / 4, MAT, R_OUT)
    with pytest.raises(ParameterError, match="holds no cell"):
        front_interaction_integral(u, blk, math.radians(180.0), MAT, R_OUT)
    k = front_interaction_integral(u, blk, math.pi / 4, MAT, R_OUT).K_I
    assert k == pytest.approx(2 * math.sqrt(1 / math.pi), rel=0.05)


def _plate_k(sol, block, phi: float, u=None) -> np.ndarray:
    p = sol.problem
    length = domain_length(block.front, phi, p.r_out, p.h_front)
    u = sol.u if u is None else u
    return _modes(front_interaction_integral(u, block, phi, p.material, p.r_out, None, length))


def test_surface_crack_point_after_others_equals_a_fresh_model(plate) -> None:
    """Both faces meshed: the face term over the facets next to each point's own domain."""
    phis = np.radians([30.0, 135.0, 90.0, 45.0, 90.0])
    seq = [_plate_k(plate, plate.block, float(p)) for p in phis]
    alone = _plate_k(plate, dataclasses.replace(plate.block), float(phis[2]))
    scale = abs(alone[0])
    for got in (seq[2], seq[4]):
        np.testing.assert_allclose(got[:3], alone[:3], rtol=0, atol=1e-14 * scale)
    assert abs(seq[1][0] / seq[2][0] - 1) > 1e-3
    u2 = plate.u.copy()
    u2.x.array[:] *= 2.0
    twice = _plate_k(plate, plate.block, float(phis[2]), u2)
    np.testing.assert_allclose(twice[:3], 2.0 * alone[:3], rtol=0, atol=2e-14 * scale)
