"""Plate problems (bonecontact.fracture.plates) without a crack: the uniform stress state
is reproduced exactly (P1 contains it) and the potential energy is −σ²A/(2E′).

Runs serially and under ``mpiexec -n 2/3``.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

from mpi4py import MPI

import numpy as np
import pytest

from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.plates import centre_crack, edge_crack, mesh_plate, solve_tension
from bonecontact.materials.laws import Isotropic

COMM = MPI.COMM_WORLD
MAT = Isotropic(E=10.0e9, nu=0.3)
SIGMA = 2.0e6


@pytest.mark.parametrize(
    "plane, E_prime, lateral",
    [
        ("strain", MAT.E / (1 - MAT.nu**2), -MAT.nu * (1 + MAT.nu) / MAT.E),
        ("stress", MAT.E, -MAT.nu / MAT.E),
    ],
)
def test_uniform_tension(plane, E_prime, lateral):
    cm = mesh_plate(0.5, 1.0, None, TipMesh(0.1), COMM)
    sol = solve_tension(cm, MAT, SIGMA, plane)
    # the corner (-0.5, -1) is clamped: u = (eps_xx (x + 0.5), eps_yy (y + 1))
    x = sol.u.function_space.tabulate_dof_coordinates()[:, :2]
    u = sol.u.x.array.reshape(-1, 2)
    exact = np.vstack([SIGMA * lateral * (x[:, 0] + 0.5), SIGMA / E_prime * (x[:, 1] + 1.0)]).T
    assert np.max(np.abs(u - exact)) < 1e-9 * np.max(np.abs(exact))
    assert sol.potential == pytest.approx(-(SIGMA**2) * 2.0 / (2 * E_prime), rel=1e-9)


def test_crack_helpers():
    c = centre_crack(0.2, 30.0, (0.1, 0.0))
    np.testing.assert_allclose(c.tip(-1), (0.1 + 0.2 * math.cos(math.pi / 6), 0.1), rtol=1e-14)
    e = edge_crack(0.3, x_edge=-0.5, y=0.2)
    assert e.mouth_ends == (0,) and e.length == pytest.approx(0.3)
