"""Williams near-tip fields (bonecontact.fracture.williams) against their defining
properties: the stresses are the elastic stresses of the displacements (finite
differences), the faces are traction-free, and the face opening is the closed form."""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

import numpy as np
import pytest

from bonecontact.fracture.crack import FractureError
from bonecontact.fracture.williams import (
    elastic_constants,
    williams_displacement,
    williams_stress,
)

E, NU = 10.0e9, 0.3


def test_elastic_constants():
    s = elastic_constants(E, NU, "strain")
    assert s["kappa"] == pytest.approx(3 - 4 * NU) and s["E_prime"] == pytest.approx(E / 0.91)
    p = elastic_constants(E, NU, "stress")
    assert p["kappa"] == pytest.approx(2.7 / 1.3) and p["E_prime"] == E
    # plane stress: in-plane lambda = E nu / (1 - nu^2)
    assert p["lmbda"] == pytest.approx(E * NU / (1 - NU**2), rel=1e-14)
    with pytest.raises(FractureError, match="plane"):
        elastic_constants(E, NU, "axisymmetric")


@pytest.mark.parametrize("plane", ["strain", "stress"])
@pytest.mark.parametrize("k1, k2", [(1.0, 0.0), (0.0, 1.0), (0.7, -0.4)])
def test_stress_is_the_elastic_stress_of_the_displacement(plane, k1, k2):
    """Central differences of u (tip at the origin, crack along -x) against williams_stress."""
    c = elastic_constants(E, NU, plane)
    r, th = 0.01, np.array([-2.5, -1.0, 0.0, 0.7, 2.0, 3.0])
    x = np.vstack([r * np.cos(th), r * np.sin(th)])
    h = 1e-7
    grad = np.empty((2, 2, th.size))
    for j in range(2):
        dx = np.zeros((2, 1))
        dx[j] = h
        up = williams_displacement(x + dx, (0, 0), (1, 0), E, NU, plane, k1, k2)
        um = williams_displacement(x - dx, (0, 0), (1, 0), E, NU, plane, k1, k2)
        grad[:, j] = (up - um) / (2 * h)
    eps = 0.5 * (grad + grad.transpose(1, 0, 2))
    tr = eps[0, 0] + eps[1, 1]
    s11 = c["lmbda"] * tr + 2 * c["mu"] * eps[0, 0]
    s22 = c["lmbda"] * tr + 2 * c["mu"] * eps[1, 1]
    s12 = 2 * c["mu"] * eps[0, 1]
    ref = williams_stress(np.full(th.size, r), th, k1, k2)
    scale = 1 / math.sqrt(2 * math.pi * r)
    np.testing.assert_allclose(np.vstack([s11, s22, s12]), ref, atol=1e-6 * scale)


def test_faces_are_traction_free_and_open_as_the_closed_form():
    r = np.array([1e-3, 1e-2])
    for th in (math.pi, -math.pi):
        s = williams_stress(r, np.full(2, th), 1.3, 0.6)
        np.testing.assert_allclose(s[1:], 0.0, atol=1e-12 * np.abs(s).max())
    c = elastic_constants(E, NU, "strain")
    # tip at (1, 2), crack direction at 30 degrees: points just above and below the face
    b = math.radians(30)
    e1, e2 = np.array([math.cos(b), math.sin(b)]), np.array([-math.sin(b), math.cos(b)])
    rr = 0.004
    up = np.array([1, 2]) - rr * e1 + 1e-12 * e2
    lo = np.array([1, 2]) - rr * e1 - 1e-12 * e2
    args = ((1, 2), e1, E, NU, "strain", 2.0, 0.5)
    jump = (
        williams_displacement(up[:, None], *args)[:, 0]
        - williams_displacement(lo[:, None], *args)[:, 0]
    )
    opening = (c["kappa"] + 1) / c["mu"] * math.sqrt(rr / (2 * math.pi))
    assert jump @ e2 == pytest.approx(2.0 * opening, rel=1e-8)
    assert jump @ e1 == pytest.approx(0.5 * opening, rel=1e-8)
