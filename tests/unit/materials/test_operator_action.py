"""The step operator's product without its matrix (issue 28, memory).

:meth:`Mechanics.operator_action` assembles ``(c_M M + c_K K + c_V Kv) x`` from the forms
(in chunks of cells; the nodal-pressure terms as ``Bᵀ diag(w) B x``); a static run with
contact keeps no step operator and takes its residual and strain energy from it.  The
reference is the product with the assembled matrix of :meth:`Mechanics.combined_operator`
(the same forms, assembled as a matrix): equal to round-off for every family member.

Families: 2D and 3D; isotropic, viscous, nodal-pressure and transversely isotropic
materials; the coefficients of static, quasistatic and dynamic steps; one form for all
cells or chunks of 7 cells (different numbers of chunks per rank); 1, 2 and 3 ranks.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import mesh

from bonecontact.materials.laws import Isotropic, TransverselyIsotropic
from bonecontact.mechanics import model as model_module
from bonecontact.mechanics.model import Mechanics

COMM = MPI.COMM_WORLD
E, NU, RHO = 2.0e9, 0.3, 1800.0

MATERIALS = {
    "isotropic": lambda: Isotropic(E=E, nu=NU, rho=RHO),
    "viscous": lambda: Isotropic(E=E, nu=NU, rho=RHO, tau_v=0.02),
    "nodal_pressure": lambda: Isotropic(
        E=E, nu=0.49, rho=RHO, tau_v=0.01, formulation="nodal_pressure"
    ),
    "transverse": lambda: TransverselyIsotropic(
        E_p=E, E_a=3 * E, nu_p=0.3, nu_pa=0.25, G_pa=0.4 * E, rho=RHO
    ),
}
#: (c_M, c_K, c_V) of a static, a quasistatic (Δt = 0.1) and a dynamic (Δt = 1e-3) step
COEFFS = {"static": (0.0, 1.0, 0.0), "quasistatic": (0.0, 0.1, 1.0), "dynamic": (1.0, 1e-6, 1e-3)}


def _box(dim: int) -> mesh.Mesh:
    if dim == 2:
        return mesh.create_unit_square(COMM, 5, 4)
    return mesh.create_unit_cube(COMM, 3, 3, 2)


CASES = [(d, m, s, 7) for d in (2, 3) for m in sorted(MATERIALS) for s in sorted(COEFFS)]


@pytest.mark.parametrize(
    ("dim", "material", "scheme", "chunk"), CASES + [(3, "isotropic", "static", 16384)]
)
def test_action_equals_the_matrix_product(dim, material, scheme, chunk, monkeypatch):
    monkeypatch.setattr(model_module, "ACTION_CHUNK", chunk)
    model = Mechanics(_box(dim), MATERIALS[material]())
    coeffs = COEFFS[scheme]
    A = model.combined_operator(*coeffs)
    x, ref = A.createVecs()
    rng = np.random.default_rng(7 + COMM.rank)
    x.array[:] = rng.standard_normal(x.getLocalSize())
    A.mult(x, ref)
    out = ref.duplicate()
    model.operator_action(coeffs, x, out)
    scale = ref.norm(3)  # (max norm)
    assert scale > 0.0
    out.axpy(-1.0, ref)
    assert out.norm(3) <= 1e-12 * scale
    for v in (x, ref, out):
        v.destroy()
    A.destroy()
