"""Discrete energy of the semi-implicit scheme (docs/theory/mechanics.md#time-discretisation,
docs/theory/verification.md#verification-references).

For M(uⁿ⁺¹ − 2uⁿ + uⁿ⁻¹)/Δt² + K uⁿ⁺¹ + Kv (uⁿ⁺¹ − uⁿ)/Δt = 0 and
Eⁿ = ½ vⁿᵀ M vⁿ + ½ uⁿᵀ K uⁿ, vⁿ = (uⁿ − uⁿ⁻¹)/Δt, testing with uⁿ⁺¹ − uⁿ gives

    Eⁿ − Eⁿ⁺¹ = ½|vⁿ⁺¹ − vⁿ|²_M + ½|uⁿ⁺¹ − uⁿ|²_K + Δt |vⁿ⁺¹|²_Kv  ≥ 0,

and for one undamped mode K φ = ω² M φ started at rest, uⁿ = aₙ φ with
(1 + ω²Δt²) aₙ₊₁ − 2aₙ + aₙ₋₁ = 0, a₀ = a₋₁ = 1, and Eⁿ/E⁰ = (1 + ω²Δt²)⁻ⁿ.
The eigenpair comes from SLEPc (shift-and-invert, MUMPS) on the Dirichlet-constrained
pencil, independently of the integrator.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest
from dolfinx import fem, mesh
from slepc4py import SLEPc

from bonecontact.common.linalg import owned_global_rows
from bonecontact.materials.laws import Isotropic, Orthotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics

COMM = MPI.COMM_WORLD


def _eps(
    K: PETSc.Mat, M: PETSc.Mat, which, target: float | None, tol: float
) -> tuple[float, PETSc.Vec]:
    """One eigenpair of the pencil (K, M) (GHEP), LU by MUMPS in the spectral transform."""
    eps = SLEPc.EPS().create(COMM)
    eps.setOperators(K, M)
    eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
    eps.setDimensions(1)
    st = eps.getST()
    if target is not None:
        st.setType("sinvert")
        eps.setTarget(target)
    eps.setWhichEigenpairs(which)
    ksp = st.getKSP()
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("mumps")
    eps.setTolerances(tol, 500)
    eps.solve()
    assert eps.getConverged() >= 1
    vec = K.createVecs()[0]
    lam = eps.getEigenpair(0, vec).real
    eps.destroy()
    return lam, vec


def test_single_mode_energy_ratio():
    """Lowest mode of a clamped 2 × 1 plate (plane strain, 16 × 8 × 2 triangles, E = ρ = 1).

    Three step sizes: Δt = 1/ω_max (below the explicit limit 2/ω_max), Δt = 1/ω₁ and
    Δt = 4/ω₁ (≈ 420 × 2/ω_max).  Tolerance: Eⁿ/E⁰ = (1 + ω₁²Δt²)⁻ⁿ to 1e-8 relative for
    n = 1 … 30, and uⁿ = aₙ φ from the scalar recurrence to 1e-8 (relative to ‖φ‖).
    """
    mat = Isotropic(E=1.0, nu=0.3, rho=1.0)
    msh = mesh.create_rectangle(COMM, [[0.0, 0.0], [2.0, 1.0]], [16, 8])
    msh.topology.create_connectivity(1, 2)
    left = mesh.locate_entities_boundary(msh, 1, lambda X: np.isclose(X[0], 0.0))
    m = Mechanics(msh, mat)
    for c in range(2):
        m.add_dirichlet(left, c, 0.0)
    rows = owned_global_rows(m.V, m.bc_dofs())

    # smallest eigenvalue: constrained rows -> K diag 1, M diag 0 (eigenvalue at infinity)
    K0 = m.K.duplicate(copy=True)
    K0.zeroRowsColumns(rows, diag=1.0)
    M0 = m.M.duplicate(copy=True)
    M0.zeroRowsColumns(rows, diag=0.0)
    lam1, phi = _eps(K0, M0, SLEPc.EPS.Which.TARGET_MAGNITUDE, 0.0, 1e-13)
    # largest eigenvalue: constrained rows -> eigenvalue 1 (far below ω_max²)
    M1 = m.M.duplicate(copy=True)
    M1.zeroRowsColumns(rows, diag=1.0)
    lam_max, _ = _eps(K0, M1, SLEPc.EPS.Which.LARGEST_MAGNITUDE, None, 1e-8)

    Kphi, Mphi = phi.duplicate(), phi.duplicate()
    m.K.mult(phi, Kphi)
    m.M.mult(phi, Mphi)
    w2 = Kphi.dot(phi) / Mphi.dot(phi)  # Rayleigh quotient with the unconstrained matrices
    assert w2 == pytest.approx(lam1, rel=1e-10)
    bc_max = np.abs(phi.array[owned_bc_local(m)]).max(initial=0.0)
    assert COMM.allreduce(bc_max, op=MPI.MAX) < 1e-14 * phi.norm(PETSc.NormType.INFINITY)
    res = Kphi.copy()
    res.axpy(-w2, Mphi)
    res.array[owned_bc_local(m)] = 0.0  # reaction rows are not part of the eigenproblem
    assert res.norm() < 1e-10 * Kphi.norm()

    w1, w_max = np.sqrt(w2), np.sqrt(lam_max)
    assert 4.0 / w1 > 100 * (2.0 / w_max)  # the large step is far above the explicit limit
    u0 = fem.Function(m.V)
    u0.x.petsc_vec.array[:] = phi.array_r
    u0.x.scatter_forward()
    phi_norm = phi.norm()
    diff = phi.duplicate()
    for dt in (1.0 / w_max, 1.0 / w1, 4.0 / w1):
        integ = Integrator(m, "dynamic", dt)
        integ.set_initial(u0)
        E0 = integ.energy().total
        r = 1.0 + w2 * dt * dt
        a_prev, a = 1.0, 1.0
        for n in range(1, 31):
            integ.step()
            a_prev, a = a, (2.0 * a - a_prev) / r
            En = integ.energy().total
            assert En / E0 == pytest.approx(r ** (-n), rel=1e-8), (dt, n)
            diff.waxpy(-a, phi, integ.u.x.petsc_vec)
            assert diff.norm() <= 1e-8 * phi_norm, (dt, n)
        integ.destroy()
    for obj in (K0, M0, M1, phi, Kphi, Mphi, res, diff):
        obj.destroy()


def owned_bc_local(m: Mechanics) -> np.ndarray:
    """Owned, unrolled local indices of the constrained dofs."""
    d = m.bc_dofs()
    return d[d < m.num_owned]


_FINAL_ENERGY: dict[float, float] = {}


def _smooth_random(rng: np.random.Generator, scale: float, length: float):
    """A smooth, random-looking field on a beam along x that vanishes at x = 0 (the clamped end)."""
    k = rng.uniform(0.5, 3.0, size=(3, 3)) / np.array([length, 1.0, 1.0])
    ph = rng.uniform(0.0, 2 * np.pi, size=(3, 3))
    amp = rng.uniform(-1.0, 1.0, size=3)

    def f(X):
        return (
            scale
            * X[0]
            / length
            * np.array(
                [
                    amp[i]
                    * np.sin(k[i, 0] * X[0] + ph[i, 0])
                    * np.cos(k[i, 1] * X[1] + ph[i, 1])
                    * np.cos(k[i, 2] * X[2] + ph[i, 2])
                    for i in range(3)
                ]
            )
        )

    return f


@pytest.mark.parametrize("tau_v", [0.0, 2.0e-3])
def test_energy_never_increases(tau_v):
    """10 × 1 × 1 m orthotropic cortical-bone beam (Ashman 1984, axis 3 along x),
    40 × 4 × 4 × 6 tets, clamped at x = 0, free elsewhere, smooth random u⁰ and u̇⁰, no
    load, 40 steps of Δt = 100 h/c_d (h = 0.25 m, c_d the largest longitudinal wave
    speed; the lowest bending mode has ω₁Δt ≈ 0.3, so it survives many steps).

    Tolerance: Eⁿ⁺¹ ≤ Eⁿ (1 + 1e-12) at every step; the energy balance of the module
    docstring holds to 1e-11 E⁰ per step (measured ~1e-16); with τ_v = 2 ms every step
    dissipates strictly, at least Δt |vⁿ⁺¹|²_Kv > 0, and the 40 steps lose more energy
    than without viscosity.
    """
    mat = Orthotropic(
        E1=12.0e9,
        E2=13.4e9,
        E3=20.0e9,
        nu12=0.376,
        nu13=0.222,
        nu23=0.235,
        G12=4.53e9,
        G13=5.61e9,
        G23=6.23e9,
        rho=1900.0,
        tau_v=tau_v,
        axes=((0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (1.0, 0.0, 0.0)),
    )
    length, n = 10.0, (40, 4, 4)
    msh = mesh.create_box(COMM, [[0.0, 0.0, 0.0], [length, 1.0, 1.0]], n, mesh.CellType.tetrahedron)
    h = 0.25
    c_d = mat.wave_speed()
    dt = 100.0 * h / c_d
    clamped = mesh.locate_entities_boundary(msh, 2, lambda X: np.isclose(X[0], 0.0))
    m = Mechanics(msh, mat)
    for c in range(3):
        m.add_dirichlet(clamped, c, 0.0)
    rng = np.random.default_rng(20240611)
    u0, v0 = fem.Function(m.V), fem.Function(m.V)
    u0.interpolate(_smooth_random(rng, 1.0e-3, length))
    v0.interpolate(_smooth_random(rng, 1.0, length))
    integ = Integrator(m, "dynamic", dt)
    integ.set_initial(u0, v0)
    # scale the velocity so that kinetic and strain energy are equal initially
    e0 = integ.energy()
    v0.x.array[:] *= np.sqrt(e0.strain / e0.kinetic)
    integ.set_initial(u0, v0)
    assert (m.Kv is not None) == (tau_v > 0)

    M, K, Kv = m.M, m.K, m.Kv
    work = M.createVecs()[0]

    def sq(A, x):
        A.mult(x, work)
        return work.dot(x)

    E = [integ.energy().total]
    assert integ.energy().kinetic == pytest.approx(0.5 * E[0], rel=1e-10)
    u_old = integ.u_n.x.petsc_vec.copy()
    v_old = integ.velocity.x.petsc_vec.copy()
    du, dv = u_old.duplicate(), v_old.duplicate()
    for _ in range(40):
        integ.step()
        E.append(integ.energy().total)
        u_new, v_new = integ.u_n.x.petsc_vec, integ.velocity.x.petsc_vec
        du.waxpy(-1.0, u_old, u_new)
        dv.waxpy(-1.0, v_old, v_new)
        viscous = dt * sq(Kv, v_new) if Kv is not None else 0.0
        balance = 0.5 * sq(M, dv) + 0.5 * sq(K, du) + viscous
        assert E[-2] - E[-1] == pytest.approx(balance, abs=1e-11 * E[0])
        assert E[-1] <= E[-2] * (1.0 + 1e-12)
        if tau_v > 0:
            assert viscous > 1e-3 * (E[-2] - E[-1])
            assert E[-2] - E[-1] >= viscous * (1.0 - 1e-9)
        u_new.copy(u_old)
        v_new.copy(v_old)
    # what is left after 40 steps is not round-off: the test exercised a live motion
    assert E[-1] > 1e-3 * E[0]
    assert E[-1] < E[0]
    _FINAL_ENERGY[tau_v] = E[-1] / E[0]
    if len(_FINAL_ENERGY) == 2:  # both parameters ran: viscosity dissipated more
        assert _FINAL_ENERGY[2.0e-3] < _FINAL_ENERGY[0.0]
    for obj in (work, u_old, v_old, du, dv):
        obj.destroy()
    integ.destroy()
