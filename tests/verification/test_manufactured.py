"""Manufactured solutions: spatial rates of P1 in 2D/3D and the temporal rate of the scheme.

Every check compares the finite-element solution with a closed-form exact solution
(docs/theory/verification.md#verification-references, row "forms, time scheme"):

* 2D plane strain, unit square (triangles), orthotropic bone (Ashman 1984 constants)
  with its material axes rotated by 30° about z: L² rate 2 ± 0.2, H¹ rate 1 ± 0.2.
* 3D unit cube (tetrahedra) made of two layers, E₂/E₁ = 10⁵, with a kinked exact
  solution whose traction is continuous across the interface: same rates, also for
  the relative error in the stiff layer alone.
* Kelvin–Voigt dynamics with a solution that P1 represents exactly in space, so the
  error is purely temporal: rate 1 ± 0.2 over Δt halvings.

The body forces are computed from the exact solutions with a fourth-order stiffness
tensor assembled here from the 6×6 matrix of the material, independently of the
package's Voigt/plane-strain reduction in the forms.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh

from bonecontact.materials.laws import Isotropic, Orthotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics

COMM = MPI.COMM_WORLD
QDEG = {"quadrature_degree": 6}
VOIGT_PAIRS = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))


def total(form) -> float:
    """Collective value of a scalar form."""
    return COMM.allreduce(fem.assemble_scalar(fem.form(form)), op=MPI.SUM)


def rate(h, err) -> float:
    """Least-squares slope of log(err) against log(h)."""
    return float(np.polyfit(np.log(h), np.log(err), 1)[0])


def tensor_from_6x6(C6: np.ndarray) -> np.ndarray:
    """Fourth-order stiffness C_ijkl from a Voigt matrix with engineering shears."""
    C4 = np.zeros((3, 3, 3, 3))
    for a, (i, j) in enumerate(VOIGT_PAIRS):
        for b, (k, l) in enumerate(VOIGT_PAIRS):
            for p, q in {(i, j), (j, i)}:
                for r, s in {(k, l), (l, k)}:
                    C4[p, q, r, s] = C6[a, b]
    return C4


def stress_ufl(C4: np.ndarray, u, dim: int):
    """σ_ij = C_ijkl e_kl(u) for i, j < dim (plane strain: e_zz = e_xz = e_yz = 0)."""
    e = ufl.sym(ufl.grad(u))
    return ufl.as_matrix(
        [
            [
                sum(float(C4[i, j, k, l]) * e[k, l] for k in range(dim) for l in range(dim))
                for j in range(dim)
            ]
            for i in range(dim)
        ]
    )


def ashman_rotated(theta_deg: float) -> Orthotropic:
    c, s = np.cos(np.deg2rad(theta_deg)), np.sin(np.deg2rad(theta_deg))
    return Orthotropic(
        E1=12.0e9,
        E2=13.4e9,
        E3=20.0e9,
        nu12=0.376,
        nu13=0.222,
        nu23=0.235,
        G12=4.53e9,
        G13=5.61e9,
        G23=6.23e9,
        axes=((c, s, 0.0), (-s, c, 0.0), (0.0, 0.0, 1.0)),
    )


def test_mms_2d_orthotropic_rotated():
    """2D plane strain, rotated orthotropic material, N = 8, 16, 32, 64 triangles per side.

    Tolerance: fitted L² rate 2 ± 0.2 and H¹ rate 1 ± 0.2 of the relative errors
    (measured 1.99 and 1.00).
    """
    mat = ashman_rotated(30.0)
    C4 = tensor_from_6x6(mat.voigt())
    a = 1.0e-3  # displacement scale (m)

    def exact_np(X):
        return a * np.array(
            [
                np.sin(np.pi * X[0]) * np.cos(1.3 * X[1]) + X[0] ** 2,
                np.exp(X[0] * X[1]) * np.sin(2.0 * X[1]),
            ]
        )

    hs, eL2, eH1 = [], [], []
    for N in (8, 16, 32, 64):
        msh = mesh.create_unit_square(COMM, N, N)
        x = ufl.SpatialCoordinate(msh)
        ue = a * ufl.as_vector(
            [
                ufl.sin(np.pi * x[0]) * ufl.cos(1.3 * x[1]) + x[0] ** 2,
                ufl.exp(x[0] * x[1]) * ufl.sin(2.0 * x[1]),
            ]
        )
        m = Mechanics(msh, mat)
        m.add_body_force(-ufl.div(stress_ufl(C4, ue, 2)))
        msh.topology.create_connectivity(1, 2)
        bf = mesh.exterior_facet_indices(msh.topology)
        for c in range(2):
            m.add_dirichlet(bf, c, lambda X, c=c: exact_np(X)[c])
        integ = Integrator(m, "static", 1.0)
        integ.step()
        u = integ.u
        dx = ufl.dx(domain=msh, metadata=QDEG)
        eL2.append(np.sqrt(total(ufl.inner(u - ue, u - ue) * dx) / total(ufl.inner(ue, ue) * dx)))
        eH1.append(
            np.sqrt(
                total(ufl.inner(ufl.grad(u - ue), ufl.grad(u - ue)) * dx)
                / total(ufl.inner(ufl.grad(ue), ufl.grad(ue)) * dx)
            )
        )
        hs.append(1.0 / N)
        integ.destroy()
    assert rate(hs, eL2) == pytest.approx(2.0, abs=0.2), eL2
    assert rate(hs, eH1) == pytest.approx(1.0, abs=0.2), eH1
    assert eL2[-1] < 1e-3 and eH1[-1] < 5e-2


def test_mms_3d_two_materials_contrast():
    """3D unit cube (tets, N = 4, 8, 16), layers x < ½ (E₁ = 1 kPa) and x > ½ (E₂ = 10⁵ E₁).

    Exact solution u = a(x)/E(x) with a = (x − ½) q(x), q smooth: u is continuous
    (zero on the interface) with a kink, and σ = Ĉ e(a) (Ĉ: the E = 1 stiffness, same
    ν) is the same smooth field in both layers, so the interface traction is continuous
    and the body force −div(Ĉ e(a)) is the same in both layers: a mis-assigned material
    cannot reproduce the solution.  Tolerance: L² rate 2 ± 0.2, H¹ rate 1 ± 0.2 of the
    relative errors, and L² rate 2 ± 0.2 of the relative error in the stiff layer alone
    (measured 2.00, 1.00, 2.00).
    """
    E1, E2, nu = 1.0e3, 1.0e8, 0.3
    soft, stiff = Isotropic(E=E1, nu=nu), Isotropic(E=E2, nu=nu)
    C4 = tensor_from_6x6(Isotropic(E=1.0, nu=nu).voigt())

    def a_np(X):
        return (X[0] - 0.5) * np.array(
            [np.sin(2 * X[1]) + X[2] * X[0], np.cos(X[0] + X[2]) * X[1], np.exp(X[1] * X[2])]
        )

    def exact_np(X):
        return a_np(X) / np.where(X[0] < 0.5, E1, E2)

    hs, eL2, eH1, eL2_stiff = [], [], [], []
    for N in (4, 8, 16):
        msh = mesh.create_unit_cube(COMM, N, N, N)
        im = msh.topology.index_map(3)
        ncells = im.size_local + im.num_ghosts
        left = mesh.locate_entities(msh, 3, lambda X: X[0] <= 0.5 + 1e-12)
        tags = np.full(ncells, 2, dtype=np.int32)
        tags[left] = 1
        ct = mesh.meshtags(msh, 3, np.arange(ncells, dtype=np.int32), tags)
        m = Mechanics(msh, {1: soft, 2: stiff}, ct)
        x = ufl.SpatialCoordinate(msh)
        a = (x[0] - 0.5) * ufl.as_vector(
            [ufl.sin(2 * x[1]) + x[2] * x[0], ufl.cos(x[0] + x[2]) * x[1], ufl.exp(x[1] * x[2])]
        )
        m.add_body_force(-ufl.div(stress_ufl(C4, a, 3)))
        msh.topology.create_connectivity(2, 3)
        bf = mesh.exterior_facet_indices(msh.topology)
        for c in range(3):
            m.add_dirichlet(bf, c, lambda X, c=c: exact_np(X)[c])
        integ = Integrator(m, "static", 1.0)
        integ.step()
        u = integ.u
        dx = ufl.Measure("dx", domain=msh, subdomain_data=ct, metadata=QDEG)
        u1, u2 = a / E1, a / E2
        d1, d2 = u - u1, u - u2
        ref_L2 = total(ufl.inner(u1, u1) * dx(1) + ufl.inner(u2, u2) * dx(2))
        ref_H1 = total(
            ufl.inner(ufl.grad(u1), ufl.grad(u1)) * dx(1)
            + ufl.inner(ufl.grad(u2), ufl.grad(u2)) * dx(2)
        )
        eL2.append(np.sqrt(total(ufl.inner(d1, d1) * dx(1) + ufl.inner(d2, d2) * dx(2)) / ref_L2))
        eH1.append(
            np.sqrt(
                total(
                    ufl.inner(ufl.grad(d1), ufl.grad(d1)) * dx(1)
                    + ufl.inner(ufl.grad(d2), ufl.grad(d2)) * dx(2)
                )
                / ref_H1
            )
        )
        eL2_stiff.append(
            np.sqrt(total(ufl.inner(d2, d2) * dx(2)) / total(ufl.inner(u2, u2) * dx(2)))
        )
        hs.append(1.0 / N)
        integ.destroy()
    assert rate(hs, eL2) == pytest.approx(2.0, abs=0.2), eL2
    assert rate(hs, eH1) == pytest.approx(1.0, abs=0.2), eH1
    assert rate(hs, eL2_stiff) == pytest.approx(2.0, abs=0.2), eL2_stiff
    assert eL2[-1] < 5e-3 and eL2_stiff[-1] < 1e-2


def test_mms_dynamic_kelvin_voigt_temporal_rate():
    """Temporal rate of the semi-implicit scheme (docs/theory/mechanics.md#time-discretisation) with
    Kelvin–Voigt viscosity.

    u(x, t) = sin(ωt) g(x) with g affine on the unit square (8×8 triangles): P1 holds
    it exactly, so the error is purely temporal.  ρü − div τ = −ρω² sin(ωt) g (the
    Kelvin–Voigt stress τ = C e(u) + τ_v C e(u̇) is uniform in space); Dirichlet
    u = sin(ωt) g on x = 0, and on the other sides the traction
    τ n = [sin(ωt) + τ_v ω cos(ωt)] C e(g) n, so the viscous term enters the discrete
    equations.  u(0) = 0, u̇(0) = ω g; T = 1, Δt = T/25 … T/200.
    Tolerance: fitted rate of max_n ‖uⁿ − u(tₙ)‖/‖g‖ (nodal values) 1 ± 0.2
    (measured 0.98); the error at Δt = T/200 below 7 % (measured 5.6 %).
    """
    mat = Isotropic(E=3.0, nu=0.3, rho=2.0, tau_v=0.05)
    omega, T = 2.0 * np.pi, 1.0
    msh = mesh.create_unit_square(COMM, 8, 8)
    msh.topology.create_connectivity(1, 2)
    bf = mesh.exterior_facet_indices(msh.topology)
    left = mesh.locate_entities_boundary(msh, 1, lambda X: np.isclose(X[0], 0.0))
    values = np.full(bf.size, 2, dtype=np.int32)
    values[np.isin(bf, left)] = 1
    ft = mesh.meshtags(msh, 1, bf, values)

    G = np.array([[0.3, -0.2], [0.5, 0.4]])
    g0 = np.array([0.1, -0.05])

    def g_np(X):
        return g0[:, None] + G @ X[:2]

    x = ufl.SpatialCoordinate(msh)
    g = ufl.as_vector([g0[i] + G[i, 0] * x[0] + G[i, 1] * x[1] for i in range(2)])
    traction = ufl.dot(stress_ufl(tensor_from_6x6(mat.voigt()), g, 2), ufl.FacetNormal(msh))

    def s(t):
        return np.sin(omega * t)

    def s_dot(t):
        return omega * np.cos(omega * t)

    dts, errs = [], []
    for nsteps in (25, 50, 100, 200):
        dt = T / nsteps
        m = Mechanics(msh, mat, None, ft)
        m.add_body_force(g, schedule=lambda t: -mat.rho * omega**2 * np.sin(omega * t))
        m.add_traction(2, traction, schedule=s)
        m.add_traction(2, mat.tau_v * traction, schedule=s_dot)
        for c in range(2):
            m.add_dirichlet(left, c, lambda X, c=c: g_np(X)[c], schedule=s)
        integ = Integrator(m, "dynamic", dt)
        gf = fem.Function(m.V)
        gf.interpolate(g_np)
        v0 = fem.Function(m.V)
        v0.x.array[:] = omega * gf.x.array
        integ.set_initial(None, v0)
        gnorm = gf.x.petsc_vec.norm()
        err = 0.0
        e = gf.x.petsc_vec.copy()
        for _ in range(nsteps):
            integ.step()
            integ.u.x.petsc_vec.copy(e)
            e.axpy(-s(integ.t), gf.x.petsc_vec)
            err = max(err, e.norm() / gnorm)
        assert integ.t == pytest.approx(T, rel=1e-12)
        dts.append(dt)
        errs.append(err)
        e.destroy()
        integ.destroy()
    assert rate(dts, errs) == pytest.approx(1.0, abs=0.2), errs
    assert errs[-1] < 0.07, errs
