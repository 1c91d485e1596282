"""Free vibration of one mode of a cantilever strip: the reference of the time schemes'
period and amplitude (tests/verification/test_newmark.py, benchmarks/bench_newmark.py).

The strip 0.1 m × 0.01 m (plane strain, E = 1 GPa, ν = 0.3, ρ = 1000 kg/m³, optional
Kelvin–Voigt time τ_v: Kv = τ_v K) is clamped at x = 0.  Its lowest mode φ and
frequency ω_h are found by inverse iteration with the Rayleigh quotient (independent of
any time scheme); started on the mode at rest, the semi-discrete solution is
q(t) = φᵀM u(t) = e^{−ζω t}(cos ω_d t + ζω/ω_d sin ω_d t), ζ = τ_v ω_h / 2.
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
from dolfinx import fem, mesh

from bonecontact.common.linalg import create_solver, owned_global_rows
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.model import Mechanics
from bonecontact.mechanics.newmark import make_integrator

__all__ = ["cantilever", "crossing_period", "damped_mode", "lowest_mode", "modal_history"]


def cantilever(
    comm: MPI.Comm = MPI.COMM_WORLD, tau_v: float = 0.0, nx: int = 10, ny: int = 2
) -> Mechanics:
    """The clamped strip (module docstring) on an ``nx × ny`` rectangle mesh."""
    msh = mesh.create_rectangle(comm, [[0.0, 0.0], [0.1, 0.01]], [nx, ny])
    m = Mechanics(msh, Isotropic(E=1e9, nu=0.3, rho=1000.0, tau_v=tau_v))
    clamp = mesh.locate_entities_boundary(msh, 1, lambda X: np.isclose(X[0], 0.0))
    for c in range(2):
        m.add_dirichlet(clamp, c, 0.0)
    return m


def lowest_mode(m: Mechanics, iterations: int = 25) -> tuple[fem.Function, float]:
    """Lowest mode φ (φᵀMφ = 1, zero on the supports) and ω_h (rad/s) by inverse
    iteration K φ_{k+1} = M φ_k (distributed; MUMPS)."""
    rows = owned_global_rows(m.V, m.bc_dofs())
    Kbc = m.K.duplicate(copy=True)
    Kbc.zeroRowsColumns(rows, diag=1.0)
    ksp = create_solver(Kbc, "direct")
    phi = fem.Function(m.V)
    phi.interpolate(lambda X: np.vstack([0.0 * X[0], X[0] ** 2]))
    bc = m.bc_dofs()
    bc = bc[bc < m.num_owned]
    b = Kbc.createVecLeft()
    for _ in range(iterations):
        m.M.mult(phi.x.petsc_vec, b)
        b.array[bc] = 0.0
        ksp.solve(b, phi.x.petsc_vec)
        m.M.mult(phi.x.petsc_vec, b)
        phi.x.petsc_vec.scale(1.0 / np.sqrt(phi.x.petsc_vec.dot(b)))
        phi.x.scatter_forward()
    m.K.mult(phi.x.petsc_vec, b)
    omega = float(np.sqrt(phi.x.petsc_vec.dot(b)))
    for obj in (Kbc, ksp, b):
        obj.destroy()
    return phi, omega


def modal_history(
    scheme: str,
    m: Mechanics,
    phi: fem.Function,
    omega: float,
    per_period: int,
    periods: float,
    balance: bool = False,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], list]:
    """Run ``scheme`` from u⁰ = φ, v⁰ = 0 with Δt = 2π/(ω · per_period).

    Returns
    -------
    (t, q, balances)
        Step times (t[0] = 0), modal amplitudes q_n = φᵀM uⁿ, and the per-step
        :class:`~bonecontact.mechanics.integrator.EnergyBalance` (with ``balance``).
    """
    dt = 2.0 * np.pi / omega / per_period
    integ = make_integrator(scheme, m, "dynamic", dt, energy_balance=balance)
    integ.set_initial(phi, None)
    Mphi = m.M.createVecLeft()
    m.M.mult(phi.x.petsc_vec, Mphi)
    q, bal = [1.0], []
    for _ in range(int(round(periods * per_period))):
        integ.step()
        q.append(integ.u_n.x.petsc_vec.dot(Mphi))
        bal.append(integ.last_balance)
    integ.destroy()
    Mphi.destroy()
    return dt * np.arange(len(q)), np.asarray(q), bal


def damped_mode(t: npt.NDArray, omega: float, tau_v: float) -> npt.NDArray[np.float64]:
    """Exact q(t) of q'' + τ_v ω² q' + ω² q = 0, q(0) = 1, q'(0) = 0 (ζ < 1)."""
    zeta = 0.5 * tau_v * omega
    wd = omega * np.sqrt(1.0 - zeta**2)
    return np.exp(-zeta * omega * t) * (np.cos(wd * t) + zeta * omega / wd * np.sin(wd * t))


def crossing_period(t: npt.NDArray, q: npt.NDArray) -> float:
    """Mean period from the first and last zero crossings of q (linear interpolation)."""
    k = np.flatnonzero(np.sign(q[1:]) != np.sign(q[:-1]))
    if k.size < 2:
        return float("nan")
    tc = t[k] - q[k] * (t[k + 1] - t[k]) / (q[k + 1] - q[k])
    return float(2.0 * (tc[-1] - tc[0]) / (tc.size - 1))
