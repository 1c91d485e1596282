"""Static, quasi-static and dynamic (semi-implicit, SPEC §3.1) integrators.

Each integrator assembles and factorises (or sets up the preconditioner of) its
time-independent operator once; a step costs one right-hand side (a few
matrix–vector products and scaled, pre-assembled load vectors) and one solve.

=============  ======================================  ===================================
kind           operator A                              right-hand side
=============  ======================================  ===================================
static         K                                       F(t)
quasistatic    Δt K + Kv                               Δt F(t) + Kv uⁿ
dynamic        M + Δt² K + Δt Kv                       Δt² F(t) + M(2uⁿ − uⁿ⁻¹) + Δt Kv uⁿ
=============  ======================================  ===================================

Dirichlet conditions are imposed by symmetric elimination on the fixed operator
(rows and columns of A replaced by the identity, prescribed values lifted into the
right-hand side with the unmodified operator).
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from typing import Literal

from dolfinx import fem
from petsc4py import PETSc

from .linalg import create_solver, owned_global_rows, rigid_body_modes
from .mechanics import Mechanics

__all__ = ["Integrator", "StepInfo", "Energy"]

Kind = Literal["static", "quasistatic", "dynamic"]


@dataclass
class Energy:
    """Discrete energies (J, or J/m in 2D): E = ½ vᵀMv + ½ uᵀKu."""

    kinetic: float
    strain: float

    @property
    def total(self) -> float:
        return self.kinetic + self.strain


@dataclass
class StepInfo:
    """What one step did."""

    step: int
    time: float
    linear_iterations: int
    solve_time: float
    extra: dict = field(default_factory=dict)


class Integrator:
    """Time integrator for a :class:`~bonecontact.mechanics.Mechanics` model.

    Parameters
    ----------
    model
        The mechanics model (materials, loads, Dirichlet conditions).
    kind
        ``"static"``, ``"quasistatic"`` or ``"dynamic"``.
    dt
        Time step (s); for ``"static"`` the load-step size in pseudo-time [0, 1].
    linear
        ``"direct"`` (MUMPS) or ``"iterative"`` (CG + GAMG).
    rtol
        Krylov tolerance for the iterative solver.
    contact
        Contact interfaces (:func:`bonecontact.mortar.build_interface`): every step is
        then solved by the PDAS (:class:`bonecontact.pdas.ContactSolver`) instead of a
        single linear solve; ``self.last_contact`` holds the last
        :class:`~bonecontact.pdas.PDASResult`.
    contact_options
        Keyword arguments for :class:`~bonecontact.pdas.ContactSolver`
        (``max_iterations``, ``c_n``, ``gap_tol``).
    """

    def __init__(self, model: Mechanics, kind: Kind, dt: float, linear: str = "direct", rtol: float = 1e-12,
                 contact: list | None = None, contact_options: dict | None = None):
        if dt <= 0:
            raise ValueError(f"dt must be > 0, got {dt}")
        if kind not in ("static", "quasistatic", "dynamic"):
            raise ValueError(f"kind must be static, quasistatic or dynamic, got {kind!r}")
        self.model, self.kind, self.dt, self.linear = model, kind, float(dt), linear
        V = model.V
        self.u = fem.Function(V, name="displacement")
        self.u_n = fem.Function(V, name="u_n")
        self.u_nm1 = fem.Function(V, name="u_nm1")
        self.velocity = fem.Function(V, name="velocity")
        self._g = fem.Function(V)
        self.t = 0.0
        self.step_count = 0
        t0 = _time.perf_counter()
        has_visc = model.fields.has_viscosity
        if kind == "static":
            coeffs = (0.0, 1.0, 0.0)
        elif kind == "quasistatic":
            coeffs = (0.0, self.dt, 1.0 if has_visc else 0.0)
        else:
            coeffs = (1.0, self.dt**2, self.dt if has_visc else 0.0)
        if kind == "dynamic":
            _ = model.M  # raises a clear error without density
        self.A = model.combined_operator(*coeffs)
        self._bc_local = model.bc_dofs()
        self._bc_rows = owned_global_rows(V, self._bc_local)
        self._bc_owned_local = self._bc_local[self._bc_local < model.num_owned]
        # decided collectively: a rank without constrained dofs must still take part
        # in the collective lifting product of the other ranks
        self._has_bc = model.mesh.comm.allreduce(int(self._bc_local.size)) > 0
        self.A_bc = self.A.duplicate(copy=True)
        self.A_bc.zeroRowsColumns(self._bc_rows, diag=1.0)
        self.contact = None
        self.last_contact = None
        if contact:
            from .pdas import ContactSolver

            self.ksp = None
            self.contact = ContactSolver(V, self.A_bc, contact, self._bc_rows, linear=linear,
                                         force_scale=1.0 / coeffs[1], rtol=rtol, **(contact_options or {}))
        else:
            nns = rigid_body_modes(V) if linear == "iterative" else None
            self.ksp = create_solver(self.A_bc, linear, nns, rtol=rtol)
        self.setup_time = _time.perf_counter() - t0
        self._b, self._w = self.A.createVecs()
        self._F = self._b.duplicate()

    # -------------------------------------------------------------- set-up
    def set_initial(self, u0: fem.Function | None = None, v0: fem.Function | None = None) -> None:
        """Initial displacement u⁰ and velocity u¹ (u⁻¹ = u⁰ − Δt u¹)."""
        self.u_n.x.array[:] = 0.0 if u0 is None else u0.x.array
        self.velocity.x.array[:] = 0.0 if v0 is None else v0.x.array
        self.u_nm1.x.array[:] = self.u_n.x.array - self.dt * self.velocity.x.array
        self.u.x.array[:] = self.u_n.x.array

    # ---------------------------------------------------------------- steps
    def rhs(self, t: float) -> PETSc.Vec:
        """Right-hand side at time ``t`` (before Dirichlet lifting)."""
        m, b, w = self.model, self._b, self._w
        m.load_vector(t, self._F)
        dt = self.dt
        if self.kind == "static":
            self._F.copy(b)
        elif self.kind == "quasistatic":
            self._F.copy(b)
            b.scale(dt)
            if m.Kv is not None:
                m.Kv.multAdd(self.u_n.x.petsc_vec, b, b)
        else:
            self._F.copy(b)
            b.scale(dt * dt)
            w.waxpy(-1.0, self.u_nm1.x.petsc_vec, self.u_n.x.petsc_vec)
            w.axpy(1.0, self.u_n.x.petsc_vec)  # w = 2uⁿ − uⁿ⁻¹
            m.M.multAdd(w, b, b)
            if m.Kv is not None:
                m.Kv.mult(self.u_n.x.petsc_vec, w)
                b.axpy(dt, w)
        return b

    def _apply_dirichlet(self, t: float, b: PETSc.Vec) -> None:
        if not self._has_bc:
            return
        g = self._g
        self.model.dirichlet_values(t, g)
        self.A.mult(g.x.petsc_vec, self._w)
        b.axpy(-1.0, self._w)
        b.array[self._bc_owned_local] = g.x.array[self._bc_owned_local]

    def solve_linear(self, b: PETSc.Vec, x: fem.Function) -> int:
        """Solve A_bc x = b; raises if the Krylov solver fails."""
        self.ksp.solve(b, x.x.petsc_vec)
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise RuntimeError(f"linear solver failed (PETSc reason {reason}, "
                               f"{self.ksp.getIterationNumber()} iterations, residual {self.ksp.getResidualNorm():.3e})")
        x.x.scatter_forward()
        return self.ksp.getIterationNumber()

    def step(self) -> StepInfo:
        """Advance one step: t ← t + Δt, solve, update history and velocity."""
        t = (self.step_count + 1) * self.dt  # not a running sum: no round-off drift in t
        t0 = _time.perf_counter()
        b = self.rhs(t)
        self._apply_dirichlet(t, b)
        if self.contact is not None:
            self.last_contact = self.contact.solve(b, self.u)
            its = self.last_contact.linear_iterations
        else:
            its = self.solve_linear(b, self.u)
        self._advance(t)
        return StepInfo(self.step_count, t, its, _time.perf_counter() - t0)

    def _advance(self, t: float) -> None:
        """Shift the history after ``self.u`` has been solved for time ``t``."""
        if self.kind == "static":
            self.velocity.x.array[:] = 0.0
        else:
            self.velocity.x.array[:] = (self.u.x.array - self.u_n.x.array) / self.dt
        self.u_nm1.x.array[:] = self.u_n.x.array
        self.u_n.x.array[:] = self.u.x.array
        self.t = t
        self.step_count += 1

    # --------------------------------------------------------------- energy
    def energy(self) -> Energy:
        """E = ½ vᵀMv + ½ uᵀKu for the current state (kinetic 0 unless dynamic)."""
        m = self.model
        u = self.u_n.x.petsc_vec
        m.K.mult(u, self._w)
        strain = 0.5 * self._w.dot(u)
        kin = 0.0
        if self.kind == "dynamic":
            v = self.velocity.x.petsc_vec
            m.M.mult(v, self._w)
            kin = 0.5 * self._w.dot(v)
        return Energy(kin, strain)

    def destroy(self) -> None:
        """Free the PETSc objects."""
        if self.contact is not None:
            self.contact.destroy()
        for obj in (self.ksp, self.A, self.A_bc, self._b, self._w, self._F):
            if obj is not None:
                obj.destroy()

