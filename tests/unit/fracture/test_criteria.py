"""Fracture criteria (bonecontact.fracture.criteria): the MTS angle maximises the hoop
stress of the Williams field, the K_IIc/K_Ic = √3/2 limit, principal stresses, the risk
field and the principal-direction average of exactly known stress states.

Runs serially and under ``mpiexec -n 2/3``.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import fem
from dolfinx import mesh as dmesh

from bonecontact.fracture.crack import FractureError
from bonecontact.fracture.criteria import (
    cell_stresses,
    mts_angle,
    mts_equivalent_k,
    principal_direction_average,
    risk_field,
)
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.plates import mesh_plate, solve_tension
from bonecontact.fracture.williams import williams_stress
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.model import Mechanics

COMM = MPI.COMM_WORLD
MAT = Isotropic(E=10.0e9, nu=0.25)


def hoop_stress(theta, k1, k2):
    s11, s22, s12 = williams_stress(np.ones_like(theta), theta, k1, k2)
    c, s = np.cos(theta), np.sin(theta)
    return s11 * s * s + s22 * c * c - 2 * s12 * s * c


@pytest.mark.parametrize("k1, k2", [(1.0, 1.0), (0.0, 1.0), (1.0, -0.3), (1.0, 2.5), (1.0, 0.0)])
def test_mts_angle_maximises_the_hoop_stress(k1, k2):
    theta = np.linspace(-math.pi * 0.99, math.pi * 0.99, 200001)
    best = theta[np.argmax(hoop_stress(theta, k1, k2))]
    assert mts_angle(k1, k2) == pytest.approx(best, abs=1e-4)
    # the equivalent K is the maximum hoop stress times sqrt(2 pi r)
    assert mts_equivalent_k(k1, k2) == pytest.approx(
        math.sqrt(2 * math.pi) * hoop_stress(np.array([best]), k1, k2)[0], rel=1e-6
    )


def test_mts_closed_forms():
    assert math.degrees(mts_angle(1.0, 1.0)) == pytest.approx(-53.130, abs=1e-3)
    assert math.degrees(mts_angle(0.0, 1.0)) == pytest.approx(-70.529, abs=1e-3)
    assert mts_angle(2.0, 0.0) == 0.0 and mts_equivalent_k(2.0, 0.0) == 2.0
    assert mts_equivalent_k(0.0, 1.0) == pytest.approx(2 / math.sqrt(3), rel=1e-12)


@pytest.fixture(scope="module")
def square():
    return mesh_plate(0.5, 0.5, None, TipMesh(0.1, 0.3, 0.1), COMM)


def linear_field(square, grad):
    """Model and the displacement u = G x (exact in P1: uniform stress)."""
    m = Mechanics(square.mesh, MAT, square.cell_tags, square.facet_tags)
    u = fem.Function(m.V)
    G = np.asarray(grad, dtype=float)
    u.interpolate(lambda x: G @ x[:2])
    return m, u


def test_principal_stresses_of_a_uniform_state(square):
    """eps = diag(1e-4, -2e-4) + shear: compare with the eigenvalues of the plane-strain stress."""
    G = np.array([[1e-4, 3e-5], [3e-5, -2e-4]])
    m, u = linear_field(square, G)
    cs = cell_stresses(m, u)
    lam, mu = MAT.lmbda, MAT.mu
    s = lam * np.trace(G) * np.eye(2) + 2 * mu * G
    szz = lam * np.trace(G)
    w, v = np.linalg.eigh(s)
    s1, s3, phi = cs.principal()
    np.testing.assert_allclose(s1, max(w[1], szz), rtol=1e-9)
    np.testing.assert_allclose(s3, min(w[0], szz), rtol=1e-9)
    axis = np.array([np.cos(phi), np.sin(phi)])
    np.testing.assert_allclose(np.abs(v[:, 1] @ axis), 1.0, rtol=1e-9)


def test_risk_field_tension_and_compression(square):
    sol = solve_tension(square, MAT, 2.0e6)
    f, mx = risk_field(sol.model, sol.u, 40e6)
    owned = f.function_space.dofmap.index_map.size_local
    np.testing.assert_allclose(f.x.array[:owned], 0.05, rtol=1e-9)
    assert mx.value == pytest.approx(0.05, rel=1e-9) and mx.mode == "tension"
    assert abs(mx.crack_direction[0]) == pytest.approx(1.0, rel=1e-9)  # normal to the load
    comp = solve_tension(square, MAT, -2.0e6)
    f, mx = risk_field(comp.model, comp.u, 40e6)
    assert mx.value == pytest.approx(0.0, abs=1e-9)  # sigma_1 = 0 (sigma_zz < 0 too)
    f, mx = risk_field(comp.model, comp.u, 40e6, 100e6, "tension_compression")
    assert mx.value == pytest.approx(0.02, rel=1e-9) and mx.mode == "compression"
    with pytest.raises(FractureError, match="sigma_c"):
        risk_field(comp.model, comp.u, 40e6, None, "tension_compression")
    with pytest.raises(FractureError, match="criterion"):
        risk_field(comp.model, comp.u, 40e6, 1e6, "von_mises")


@pytest.mark.parametrize("phi_deg, crack_deg", [(90.0, 0.0), (60.0, 10.0), (120.0, -30.0)])
def test_principal_direction_average_of_a_uniform_state(square, phi_deg, crack_deg):
    """Uniaxial strain along phi: sigma_1 along phi, the crack runs at phi + 90 degrees."""
    phi = math.radians(phi_deg)
    n = np.array([math.cos(phi), math.sin(phi)])
    m, u = linear_field(square, 1e-4 * np.outer(n, n))
    cs = cell_stresses(m, u)
    c = math.radians(crack_deg)
    theta = principal_direction_average(cs, COMM, (0.0, 0.0), (math.cos(c), math.sin(c)), 10)
    expected = (phi + math.pi / 2 - c + math.pi / 2) % math.pi - math.pi / 2
    assert theta == pytest.approx(expected, abs=1e-9)


def _all_cells_on_rank_0():
    """A cell partitioner that puts every cell on rank 0: the other ranks own none."""
    from dolfinx.cpp.graph import AdjacencyList_int32

    def partition(comm, nparts, graph, ghosting):
        n = graph.num_nodes
        return AdjacencyList_int32(np.zeros(n, np.int32), np.arange(n + 1, dtype=np.int32))

    return dmesh.create_cell_partitioner(partition, dmesh.GhostMode.none, 2)


def test_risk_field_on_ranks_without_cells():
    """Uniaxial strain ε_xx on a mesh that only rank 0 holds: every rank gets the exact
    risk E(1−ν)/((1+ν)(1−2ν)) ε/σ_t (ranks with no cells take part in the reductions),
    and a strength that is not given is refused on every rank."""
    part = _all_cells_on_rank_0() if COMM.size > 1 else None
    msh = dmesh.create_rectangle(COMM, [[0.0, 0.0], [1.0, 1.0]], [4, 4], partitioner=part)
    model = Mechanics(msh, MAT)
    u = fem.Function(model.V)
    eps = 1e-3
    u.interpolate(lambda x: np.vstack([eps * x[0], 0.0 * x[1]]))
    n = msh.topology.index_map(2).size_local
    assert COMM.allreduce(n, op=MPI.SUM) == 32
    s_xx = MAT.E * (1 - MAT.nu) / ((1 + MAT.nu) * (1 - 2 * MAT.nu)) * eps
    f, mx = risk_field(model, u, np.full(n, 10e6))
    assert mx.value == pytest.approx(s_xx / 10e6, rel=1e-10)
    assert COMM.allgather(mx.location) == [mx.location] * COMM.size
    sigma_t = np.full(n, 10e6)
    sigma_t[:1] = np.nan  # not given for one cell (on rank 0 only)
    with pytest.raises(FractureError, match="sigma_t"):
        risk_field(model, u, sigma_t)


def test_risk_field_3d_uniform_state():
    """u = G x in a 3D box (exact in P1: the uniform stress σ = λ tr ε I + 2μ ε, ε the
    symmetric part of G): every cell's risk is the largest eigenvalue of σ over σ_t (or
    −smallest/σ_c), the crack normal is its eigenvector, the location a cell midpoint,
    the same on every rank."""
    msh = dmesh.create_box(COMM, [[0.0, 0.0, 0.0], [1.0, 0.5, 0.5]], [4, 2, 2])
    model = Mechanics(msh, MAT)
    G = np.array([[1e-4, 4e-5, -2e-5], [1e-5, -3e-4, 5e-5], [0.0, 2e-5, 2e-4]])
    u = fem.Function(model.V)
    u.interpolate(lambda x: G @ x)
    eps = 0.5 * (G + G.T)
    sig = MAT.lmbda * np.trace(eps) * np.eye(3) + 2 * MAT.mu * eps
    w, v = np.linalg.eigh(sig)
    f, mx = risk_field(model, u, 10e6)
    owned = f.function_space.dofmap.index_map.size_local
    np.testing.assert_allclose(f.x.array[:owned], w[2] / 10e6, rtol=1e-9)
    assert mx.value == pytest.approx(w[2] / 10e6, rel=1e-9) and mx.mode == "tension"
    assert mx.crack_direction is None and len(mx.location) == 3
    assert abs(float(np.dot(mx.crack_normal, v[:, 2]))) == pytest.approx(1.0, rel=1e-9)
    mids = dmesh.compute_midpoints(msh, 3, np.arange(msh.topology.index_map(3).size_local))
    all_mids = np.concatenate(COMM.allgather(mids))
    assert np.min(np.linalg.norm(all_mids - np.array(mx.location), axis=1)) < 1e-12  # a cell
    assert (
        COMM.allgather((mx.location, mx.crack_normal))
        == [(mx.location, mx.crack_normal)] * COMM.size
    )
    f, mx = risk_field(model, u, 10e6, 5e6, "tension_compression")
    expected = max(w[2] / 10e6, -w[0] / 5e6)
    assert mx.value == pytest.approx(expected, rel=1e-9)
    assert mx.mode == ("compression" if -w[0] / 5e6 > w[2] / 10e6 else "tension")
