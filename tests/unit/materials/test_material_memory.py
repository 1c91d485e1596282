"""Material fields and strain energy without duplicated storage (issue 28, memory).

* The viscous stiffness ``C_v`` is only allocated when a material is viscous; when it
  is, it equals τ_v C cell by cell (the Kelvin–Voigt definition), and the viscous
  stress adds τ_v σ(w) to the elastic one.
* The strain energy ½ uᵀKu of an integrator whose step operator is a multiple of the
  stiffness (static, quasistatic without viscosity) is taken from that operator
  instead of a second assembled ``K``: it must equal the energy computed from a
  separately assembled ``K`` and, for a homogeneous strain, the analytic ½ ε:C:ε V.

Families: 2D and 3D, elastic and viscous materials, static and quasistatic analyses,
serial and parallel.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import mesh

from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics

COMM = MPI.COMM_WORLD
E, NU = 2.0e9, 0.3


def _box(dim: int) -> mesh.Mesh:
    if dim == 2:
        return mesh.create_unit_square(COMM, 4, 3)
    return mesh.create_unit_cube(COMM, 3, 2, 2)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("tau_v", [0.0, 0.02])
def test_viscous_field_only_when_viscous(dim, tau_v):
    model = Mechanics(_box(dim), Isotropic(E=E, nu=NU, tau_v=tau_v))
    f = model.fields
    assert f.has_viscosity == (tau_v > 0)
    if tau_v == 0:
        assert f.C_v is None
        assert model.Kv is None
        return
    assert np.allclose(f.C_v.x.array, tau_v * f.C.x.array, rtol=1e-15, atol=0.0)
    assert np.abs(f.C.x.array).max() > 0.1 * E


def _homogeneous_strain(dim: int) -> tuple[np.ndarray, float]:
    """u = G x with a symmetric G: the strain is G everywhere; returns (G, analytic
    energy ½ G:C:G over the unit box)."""
    rng = np.random.default_rng(7)
    G = rng.normal(size=(dim, dim)) * 1e-3
    G = 0.5 * (G + G.T)
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    mu = E / (2 * (1 + NU))
    energy = 0.5 * (lam * np.trace(G) ** 2 + 2 * mu * np.sum(G * G))
    return G, energy


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("kind", ["static", "quasistatic"])
def test_energy_from_step_operator(dim, kind):
    msh = _box(dim)
    model = Mechanics(msh, Isotropic(E=E, nu=NU))
    msh.topology.create_connectivity(dim - 1, dim)
    base = mesh.locate_entities_boundary(msh, dim - 1, lambda x: np.isclose(x[0], 0.0))
    for c in range(dim):  # clamped at x = 0 (a regular step operator)
        model.add_dirichlet(base, c)
    integ = Integrator(model, kind, 0.25, linear="direct")
    G, analytic = _homogeneous_strain(dim)
    integ.u_n.interpolate(lambda x: G @ x[:dim])
    e = integ.energy()
    K = model.K  # assembled separately: the second method
    w = K.createVecLeft()
    u = integ.u_n.x.petsc_vec
    K.mult(u, w)
    reference = 0.5 * w.dot(u)
    w.destroy()
    assert e.kinetic == 0.0
    assert abs(e.strain - reference) <= 1e-12 * abs(reference)
    assert abs(e.strain - analytic) <= 1e-10 * analytic
