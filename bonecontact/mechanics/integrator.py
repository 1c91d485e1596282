"""Static, quasi-static and dynamic integrators with the semi-implicit (backward-difference)
scheme (docs/theory/mechanics.md#time-discretisation).

Each integrator assembles and factorises (or sets up the preconditioner of) its
time-independent operator once; a step costs one right-hand side and one solve.
Dirichlet conditions are eliminated symmetrically; the discrete energy balance
(``energy_balance=True``) is that of docs/theory/mechanics.md#energy-balance.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field, fields
from typing import Literal

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
from dolfinx import fem

from bonecontact.common.linalg import (
    create_solver,
    owned_global_rows,
    release_petsc_garbage,
    rigid_body_modes,
)
from bonecontact.mechanics.model import Mechanics
from bonecontact.mechanics.step_solver import StepSolver

__all__ = ["Energy", "EnergyBalance", "Integrator", "StepInfo", "redistributed_mass"]

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
class EnergyBalance:
    """Energy balance of one step, or of a run (cumulative), in J (J/m in 2D).

    See docs/theory/mechanics.md#energy-balance: ``kinetic + strain`` after the step(s)
    equals the value before plus ``external_work + dirichlet_work + contact_work −
    viscous_dissipation − numerical_dissipation`` up to ``defect``.

    Attributes
    ----------
    kinetic, strain
        Energies after the step (for a cumulative record: at the current time).
    external_work
        Work of the applied loads, Fⁿ⁺¹·Δu.
    dirichlet_work
        Work of the support reactions on prescribed (moving) displacements.
    contact_work
        Work of the contact pressures, Σ D_pp λ_p Δg_p (≤ 0), from the multipliers.
    contact_work_residual
        The same from the step residual on the dofs without Dirichlet conditions
        (without contact: the residual of the linear solve, ~ solver tolerance).
    viscous_dissipation
        Kelvin–Voigt dissipation Δt |vⁿ⁺¹|²_Kv (≥ 0).
    numerical_dissipation
        Dissipation of the first-order scheme, ½|Δv|²_M + ½|Δu|²_K (≥ 0).
    defect
        ``ΔE − (W_ext + W_dir + W_c − D_visc − D_num)``; round-off / solver tolerance.
    """

    kinetic: float = 0.0
    strain: float = 0.0
    external_work: float = 0.0
    dirichlet_work: float = 0.0
    contact_work: float = 0.0
    contact_work_residual: float = 0.0
    viscous_dissipation: float = 0.0
    numerical_dissipation: float = 0.0
    defect: float = 0.0

    @property
    def total(self) -> float:
        """Kinetic plus strain energy."""
        return self.kinetic + self.strain

    @classmethod
    def of_step(cls, part: np.ndarray, comm: MPI.Comm, before: float) -> EnergyBalance:
        """The balance of a step from this rank's parts — kinetic, strain, external,
        Dirichlet, residual contact, multiplier contact work, viscous and numerical
        dissipation, in that order — summed over the ranks (collective); ``before`` is the
        total energy before the step."""
        kin, strain, w_ext, w_dir, w_res, w_c, visc, num = comm.allreduce(part, op=MPI.SUM)
        return cls(
            kinetic=kin,
            strain=strain,
            external_work=w_ext,
            dirichlet_work=w_dir,
            contact_work=w_c,
            contact_work_residual=w_res,
            viscous_dissipation=visc,
            numerical_dissipation=num,
            defect=(kin + strain) - before - (w_ext + w_dir + w_c - visc - num),
        )

    def accumulate(self, step: EnergyBalance) -> None:
        """Add the works of ``step`` and take its energies (running totals)."""
        for f in fields(self):
            if f.name in ("kinetic", "strain"):
                setattr(self, f.name, getattr(step, f.name))
            else:
                setattr(self, f.name, getattr(self, f.name) + getattr(step, f.name))


def redistributed_mass(model: Mechanics, slave_blocks: list[np.ndarray]) -> PETSc.Mat:
    """Mass matrix without inertia at the slave contact nodes (chatter removal).

    Mass redistribution in the spirit of Khenous, Laborde & Renard (Eur. J. Mech. A
    27, 2008) and, for dual mortars, Hager, Hüeber & Wohlmuth (IJNME 73, 2008): in
    every cell that has slave nodes carrying a multiplier (set C) and other nodes
    (set N), the element mass matrix M_e is replaced by PᵀM_eP, where P sets the
    value at each node of C to the mean of the values at the nodes of N.  Then the
    rows and columns of the contact nodes vanish, the matrix stays symmetric positive
    semi-definite on each cell (definite overall as long as every body has interior
    nodes), and the total mass of each cell (P reproduces constants) and hence
    momentum are kept; the cell's centre of mass moves towards its interior nodes by
    O(h) (first moments are not kept).  Cells whose nodes all lie in C are unchanged.
    Element matrices use the cell density (DG0 ``rho``) and the exact P1 mass matrix
    ρ|T|(1 + δ_ij)/((d+1)(d+2)).

    Parameters
    ----------
    model
        The mechanics model (P1 vector space ``model.V``).
    slave_blocks
        Local dof blocks of the slave contact nodes, per contact pair (e.g.
        ``interface.blocks``, or :attr:`StepSolver.slave_blocks`).

    Returns
    -------
    PETSc.Mat
        ``M + ΔM`` (a new matrix with the pattern of ``model.M``).
    """
    V, msh = model.V, model.mesh
    bs = V.dofmap.index_map_bs
    tdim = msh.topology.dim
    mark = fem.Function(V)
    for blocks in slave_blocks:
        mark.x.array[bs * blocks] = 1.0
    mark.x.scatter_forward()  # owned slave blocks → ghosts
    contact_block = mark.x.array[::bs] > 0.0
    cells = np.arange(msh.topology.index_map(tdim).size_local, dtype=np.int32)
    blocks = V.dofmap.list[cells]
    flags = contact_block[blocks]
    sel = flags.any(axis=1) & ~flags.all(axis=1)
    cells, blocks, flags = cells[sel], blocks[sel], flags[sel]
    M = model.M.duplicate(copy=True)
    M.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
    if cells.size:
        x = msh.geometry.x[msh.geometry.dofmaps[0][cells]][:, :, :tdim]  # (n, d+1, d)
        jac = x[:, 1:, :] - x[:, :1, :]
        vol = np.abs(np.linalg.det(jac)) / np.prod(np.arange(1, tdim + 1))
        rho = model.fields.rho
        rho_c = rho.x.array[rho.function_space.dofmap.list[cells, 0]]
        nn = tdim + 1
        base = (np.ones((nn, nn)) + np.eye(nn)) / (nn * (nn + 1))
        gblocks = V.dofmap.index_map.local_to_global(blocks.ravel()).reshape(blocks.shape)
        comp = np.arange(bs)
        for c in range(cells.size):
            Me = rho_c[c] * vol[c] * base
            P = np.eye(nn)
            interior = ~flags[c]
            for k in np.flatnonzero(flags[c]):
                P[k, :] = interior / interior.sum()
            dMe = P.T @ Me @ P - Me
            dofs = (bs * gblocks[c][:, None] + comp[None, :]).ravel().astype(PETSc.IntType)
            M.setValues(
                dofs, dofs, np.kron(dMe, np.eye(bs)).ravel(), addv=PETSc.InsertMode.ADD_VALUES
            )
    M.assemble()
    return M


@dataclass
class StepInfo:
    """What one step did."""

    step: int
    time: float
    linear_iterations: int
    solve_time: float
    extra: dict = field(default_factory=dict)


class Integrator:
    """Time integrator for a :class:`~bonecontact.mechanics.model.Mechanics` model.

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
        A step solver (:class:`~bonecontact.mechanics.step_solver.StepSolver`), in practice
        the contact solver: every step is then solved by it instead of a single linear
        solve.  The integrator sets it up with its operator (Dirichlet rows eliminated),
        its Dirichlet rows, the force scale of the scheme, ``linear`` and ``rtol``;
        ``self.last_contact`` holds the result of the last step (for the PDAS a
        :class:`~bonecontact.contact.pdas.PDASResult`).  From a notebook::

            itf = build_interface(model.V, facet_tags, slave=3, master=4)
            integ = Integrator(model, "static", 1.0,
                               contact=ContactSolver(model.V, [itf],
                               PDASOptions(max_iterations=30)))

        (``ContactSolver``, ``PDASOptions`` and ``build_interface`` from
        :mod:`bonecontact.contact`).  The integrator destroys the solver in
        :meth:`destroy`.
    energy_balance
        Compute the energy balance of every step (docs/theory/mechanics.md; a few
        matrix–vector products per step): ``self.last_balance`` holds the last
        step's :class:`EnergyBalance`, ``self.balance`` the running totals since
        :meth:`set_initial`.
    mass_redistribution
        Dynamic contact only: use the mass matrix of :func:`redistributed_mass` (no
        inertia at slave contact nodes; total mass kept) instead of the consistent
        one — the chatter-removal option.  ``self.M`` is the mass matrix
        in use (kinetic energy and balance are computed with it).
    """

    def __init__(
        self,
        model: Mechanics,
        kind: Kind,
        dt: float,
        linear: str = "direct",
        rtol: float = 1e-12,
        contact: StepSolver | None = None,
        energy_balance: bool = False,
        mass_redistribution: bool = False,
    ):
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
        coeffs, force_scale = self.scheme_coefficients()
        if kind == "dynamic":
            _ = model.M  # raises a clear error without density
        self._coeffs = coeffs
        self.M = model.M if kind == "dynamic" else None
        self._dM = None
        if mass_redistribution:
            if kind != "dynamic" or not contact:
                raise ValueError("mass_redistribution needs a dynamic analysis with contact")
            self.M = redistributed_mass(model, contact.slave_blocks)
            self._dM = self.M.duplicate(copy=True)
            self._dM.axpy(-1.0, model.M, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        #: the step operator; ``None`` when released (static with contact: the contact
        #: solver holds its own operator and a step needs ``A`` for two products only,
        #: taken from the forms instead, :meth:`operator_product`; issue 28)
        self.A: PETSc.Mat | None = self._assemble_operator()
        self._b, self._w = self.A.createVecs()
        #: ``A uⁿ⁺¹`` of the last step and that ``uⁿ⁺¹`` (owned), once ``A`` is released
        self._Au: tuple[PETSc.Vec, np.ndarray] | None = None
        self._bc_local = model.bc_dofs()
        self._bc_rows = owned_global_rows(V, self._bc_local)
        self._bc_owned_local = self._bc_local[self._bc_local < model.num_owned]
        # decided collectively: a rank without constrained dofs must still take part
        # in the collective lifting product of the other ranks
        self._has_bc = model.mesh.comm.allreduce(int(self._bc_local.size)) > 0
        release = contact is not None and kind == "static"
        #: the rows of A at the supports (kept when A is released: the reactions exactly)
        self._A_rows = self._support_rows() if release else None
        # (released: A itself becomes A_bc, never two matrices of its size at once)
        self._A_bc: PETSc.Mat | None = self._eliminated_operator(in_place=release)
        if release:
            self.A = None
        self.contact = contact
        self.last_contact = None
        if contact is not None:
            self.ksp = None
            contact.setup(
                self._A_bc,
                self._bc_rows,
                force_scale=force_scale,
                linear=linear,
                rtol=rtol,
                release_operator=True,
            )
            # the contact solver has built its own operators: no step needs A_bc again
            # (the residual uses A or its forms); a solver that kept it holds its own reference
            self._A_bc = None
            # in parallel petsc4py parks what Python frees until a collective clean-up:
            # without it the released operator (270 MiB per rank at 1M dofs on 2 ranks)
            # stayed resident through the contact solve (issue 28)
            release_petsc_garbage(model.mesh.comm, collect=False)
        else:
            nns = rigid_body_modes(V) if linear == "iterative" else None
            self.ksp = create_solver(self._A_bc, linear, nns, rtol=rtol)
        self.setup_time = _time.perf_counter() - t0
        self._F = self._b.duplicate()
        self._rhs0 = self._b.duplicate()
        #: force residual r of the last step (owned entries): the support and contact forces
        self.residual = self._b.duplicate()
        self.residual.zeroEntries()
        #: inertial force M(uⁿ⁺¹ − 2uⁿ + uⁿ⁻¹)/Δt² of the last step (dynamic only)
        self.inertia = self._b.duplicate() if kind == "dynamic" else None
        if self.inertia is not None:
            self.inertia.zeroEntries()
        self.energy_balance = bool(energy_balance)
        self.last_balance: EnergyBalance | None = None
        self.balance = EnergyBalance()
        self._eb: dict = {}
        if self.energy_balance:
            self._eb = {k: self._b.duplicate() for k in ("du", "du_prev", "r", "tmp")}
            self._reset_balance()

    # -------------------------------------------------------------- set-up
    def _assemble_operator(self) -> PETSc.Mat:
        """The step operator c_M M + c_K K + c_V Kv (with the redistributed mass's
        change, if any; collective)."""
        A = self.model.combined_operator(*self._coeffs)
        if self._dM is not None:
            A.axpy(self._coeffs[0], self._dM, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        return A

    def _eliminated_operator(self, in_place: bool = False) -> PETSc.Mat:
        """A copy of the step operator with the Dirichlet rows and columns eliminated
        (unit diagonal; collective; assembled again if the operator was released);
        ``in_place``: the step operator itself, eliminated."""
        if self.A is None:
            A_bc = self._assemble_operator()
        else:
            A_bc = self.A if in_place else self.A.duplicate(copy=True)
        A_bc.zeroRowsColumns(self._bc_rows, diag=1.0)
        return A_bc

    def _support_rows(self) -> PETSc.Mat:
        """The rows of the step operator at this rank's Dirichlet dofs, all columns
        (collective)."""
        comm = self.A.getComm()
        lo, hi = self.A.getOwnershipRangeColumn()
        isrow = PETSc.IS().createGeneral(self._bc_rows, comm=comm)
        iscol = PETSc.IS().createStride(hi - lo, first=lo, step=1, comm=comm)
        try:
            return self.A.createSubMatrix(isrow, iscol)
        finally:
            isrow.destroy()
            iscol.destroy()

    def operator_product(self, x: PETSc.Vec, out: PETSc.Vec) -> None:
        """``out = A x`` for the step operator ``A`` (collective): the matrix product, or,
        once ``A`` is released, the action of its forms
        (:meth:`~bonecontact.mechanics.model.Mechanics.operator_action`; equal up to
        round-off), zero without assembly for ``x = 0``."""
        if self.A is not None:
            self.A.mult(x, out)
            return
        comm = self.model.mesh.comm
        if not comm.allreduce(bool(np.any(x.array_r != 0.0)), op=MPI.LOR):
            out.set(0.0)
            return
        self.model.operator_action(self._coeffs, x, out)
        if self._dM is not None:
            dm = self._dM.createVecLeft()
            self._dM.mult(x, dm)
            out.axpy(self._coeffs[0], dm)
            dm.destroy()

    @property
    def A_bc(self) -> PETSc.Mat:
        """The step operator with the Dirichlet rows and columns eliminated.  With
        contact it is released once the contact solver is set up (it builds its own
        operators) and built again here on demand (collective then)."""
        if self._A_bc is None:
            self._A_bc = self._eliminated_operator()
        return self._A_bc

    def scheme_coefficients(self) -> tuple[tuple[float, float, float], float]:
        """``(c_M, c_K, c_V)`` of the step operator c_M M + c_K K + c_V Kv (module
        docstring) and the factor turning its forces into physical ones (1/c_K).  A
        scheme in a subclass (:class:`~bonecontact.mechanics.newmark.StabilizedNewmark`)
        overrides it."""
        has_visc = self.model.fields.has_viscosity
        if self.kind == "static":
            coeffs = (0.0, 1.0, 0.0)
        elif self.kind == "quasistatic":
            coeffs = (0.0, self.dt, 1.0 if has_visc else 0.0)
        else:
            coeffs = (1.0, self.dt**2, self.dt if has_visc else 0.0)
        return coeffs, 1.0 / coeffs[1]

    def set_initial(self, u0: fem.Function | None = None, v0: fem.Function | None = None) -> None:
        """Initial displacement u⁰ and velocity u¹ (u⁻¹ = u⁰ − Δt u¹)."""
        self.u_n.x.array[:] = 0.0 if u0 is None else u0.x.array
        self.velocity.x.array[:] = 0.0 if v0 is None else v0.x.array
        self.u_nm1.x.array[:] = self.u_n.x.array - self.dt * self.velocity.x.array
        self.u.x.array[:] = self.u_n.x.array
        if self.energy_balance:
            self._reset_balance()

    def state(self) -> dict:
        """What the next step needs (for a checkpoint): ``t``, ``step_count``, the owned
        values of ``u_n``, ``u_nm1`` and ``velocity`` (copies), the running energy
        balance (``balance``, a dict) and the contact solver's warm start (``contact``,
        :meth:`ContactSolver.state <bonecontact.contact.pdas.ContactSolver.state>`)."""
        n = self.model.num_owned
        return {
            "t": self.t,
            "step_count": self.step_count,
            "u_n": self.u_n.x.array[:n].copy(),
            "u_nm1": self.u_nm1.x.array[:n].copy(),
            "velocity": self.velocity.x.array[:n].copy(),
            "balance": {f.name: getattr(self.balance, f.name) for f in fields(self.balance)},
            "contact": self.contact.state() if self.contact is not None else None,
        }

    def restore_state(self, state: dict) -> None:
        """Continue from :meth:`state` (same layout; collective)."""
        n = self.model.num_owned
        for name in ("u_n", "u_nm1", "velocity"):
            f = getattr(self, name)
            f.x.array[:n] = state[name]
            f.x.scatter_forward()
        self.u.x.array[:] = self.u_n.x.array
        self.t, self.step_count = float(state["t"]), int(state["step_count"])
        self.balance = EnergyBalance(**state["balance"])
        self.last_balance = None
        if self.contact is not None and state.get("contact") is not None:
            self.contact.restore_state(state["contact"])

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
            self.M.multAdd(w, b, b)
            if m.Kv is not None:
                m.Kv.mult(self.u_n.x.petsc_vec, w)
                b.axpy(dt, w)
        return b

    def apply_dirichlet(self, t: float, b: PETSc.Vec) -> None:
        """Lift the Dirichlet values at time ``t`` into ``b`` (symmetric elimination)."""
        if not self._has_bc:
            return
        g = self._g
        self.model.dirichlet_values(t, g)
        self.operator_product(g.x.petsc_vec, self._w)
        b.axpy(-1.0, self._w)
        b.array[self._bc_owned_local] = g.x.array[self._bc_owned_local]

    def solve_linear(self, b: PETSc.Vec, x: fem.Function) -> int:
        """Solve A_bc x = b; raises if the Krylov solver fails."""
        self.ksp.solve(b, x.x.petsc_vec)
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise RuntimeError(
                f"linear solver failed (PETSc reason {reason}, "
                f"{self.ksp.getIterationNumber()} iterations, "
                f"residual {self.ksp.getResidualNorm():.3e})"
            )
        x.x.scatter_forward()
        return self.ksp.getIterationNumber()

    def step(self) -> StepInfo:
        """Advance one step: t ← t + Δt, solve, update history and velocity."""
        t = (self.step_count + 1) * self.dt  # not a running sum: no round-off drift in t
        t0 = _time.perf_counter()
        b = self.rhs(t)
        b.copy(self._rhs0)
        self.apply_dirichlet(t, b)
        if self.contact is not None:
            self.last_contact = self.contact.solve(b, self.u)
            its = self.last_contact.linear_iterations
        else:
            its = self.solve_linear(b, self.u)
        self._check_finite(t)
        self._residual_force()
        if self.energy_balance:
            self.last_balance = self._balance_step()
            self.balance.accumulate(self.last_balance)
        self._advance(t)
        return StepInfo(self.step_count, t, its, _time.perf_counter() - t0)

    @property
    def load(self) -> PETSc.Vec:
        """The external load vector F(t) of the last step (owned entries; N, N/m in 2D)."""
        return self._F

    def _residual_force(self) -> None:
        """r = M(uⁿ⁺¹ − 2uⁿ + uⁿ⁻¹)/Δt² + K uⁿ⁺¹ + Kv vⁿ⁺¹ − Fⁿ⁺¹ of the step just solved, as
        ``(A uⁿ⁺¹ − b)/c_K`` with ``b`` the right-hand side before Dirichlet lifting; nonzero
        only where supports and contact act (elsewhere: solver tolerance).  Dynamic runs
        also get the inertial term ``M(uⁿ⁺¹ − 2uⁿ + uⁿ⁻¹)/Δt²``."""
        r, u = self.residual, self.u.x.petsc_vec
        self.operator_product(u, r)
        if self.A is None:
            self._keep_product(r)  # (for the strain energy of this state)
            # the supports' rows as the matrix product gives them (the reactions)
            rows = self._A_rows.createVecLeft()
            self._A_rows.mult(u, rows)
            r.array[self._bc_owned_local] = rows.array_r
            rows.destroy()
        r.axpy(-1.0, self._rhs0)
        r.scale(1.0 / self._coeffs[1])
        if self.inertia is not None:
            w = self._w
            w.waxpy(-2.0, self.u_n.x.petsc_vec, self.u.x.petsc_vec)
            w.axpy(1.0, self.u_nm1.x.petsc_vec)
            self.M.mult(w, self.inertia)
            self.inertia.scale(1.0 / self.dt**2)

    def _check_finite(self, t: float) -> None:
        """Raise (on every rank) if the step's solution holds a NaN or an infinity."""
        ok = bool(np.isfinite(self.u.x.array).all())
        if not self.model.mesh.comm.allreduce(ok, op=MPI.LAND):
            raise RuntimeError(
                f"the solver returned a non-finite displacement (NaN or inf) at t = {t:.6g} s"
            )

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
        u = self.u_n.x.petsc_vec
        scale = self._stiffness_product(u, self._w)
        strain = 0.5 * scale * self._w.dot(u)
        kin = 0.0
        if self.kind == "dynamic":
            v = self.velocity.x.petsc_vec
            self.M.mult(v, self._w)
            kin = 0.5 * self._w.dot(v)
        return Energy(kin, strain)

    def _stiffness_product(self, u: PETSc.Vec, out: PETSc.Vec) -> float:
        """``out = K' u`` and ``s`` with ``K = s K'``: ``K'`` the step operator when it is
        a multiple of the stiffness alone (no mass, no viscous term; its product with
        the last step's solution kept from the residual once ``A`` is released), else
        the model's ``K`` (assembled once on demand; a static run then holds no second
        copy of its operator)."""
        c_mass, c_elastic, c_viscous = self._coeffs
        if c_mass == 0.0 and c_viscous == 0.0 and self._dM is None:
            same = self._Au is not None and np.array_equal(self._Au[1], u.array_r)
            if self.model.mesh.comm.allreduce(same, op=MPI.LAND):  # (collective choice)
                self._Au[0].copy(out)
            else:
                self.operator_product(u, out)
            return 1.0 / c_elastic
        self.model.K.mult(u, out)
        return 1.0

    def _keep_product(self, Au: PETSc.Vec) -> None:
        """Keep ``A uⁿ⁺¹`` (``Au``) and ``uⁿ⁺¹`` of the step just solved."""
        if self._Au is None:
            self._Au = (Au.duplicate(), np.empty(0))
        Au.copy(self._Au[0])
        self._Au = (self._Au[0], self.u.x.petsc_vec.array_r.copy())

    # ------------------------------------------------------- energy balance
    def contact_gaps(self, u: fem.Function | None = None) -> list[np.ndarray]:
        """Nodal normal gaps g_p = d_p/D_pp − n_p·(U_p − Σ_q M̂_pq U_q) of every contact
        interface for the displacement ``u`` (default: the current state ``u_n``), in
        the order of ``interface.blocks`` (owned slave nodes), from the contact solver.
        Needs ``energy_balance``.
        """
        if self.contact is None or not self.energy_balance:
            raise RuntimeError(
                "contact_gaps needs "
                "Integrator(..., contact=ContactSolver(...), energy_balance=True)"
            )
        return self.contact.contact_gaps(self.u_n if u is None else u)

    def _reset_balance(self) -> None:
        e = self.energy()
        self.balance = EnergyBalance(kinetic=e.kinetic, strain=e.strain)
        self.last_balance = None
        if self.contact is not None:
            self.contact.start_contact_work(self.u_n)

    def _balance_step(self) -> EnergyBalance:
        """Energy balance of the step just solved (``self.u`` holds uⁿ⁺¹; history not shifted).

        Local dot products and one collective reduction per step."""
        m, eb = self.model, self._eb
        c_mass, c_el, c_visc = self._coeffs
        du, dup, r, tmp = eb["du"], eb["du_prev"], eb["r"], eb["tmp"]
        u, un, unm1 = self.u.x.petsc_vec, self.u_n.x.petsc_vec, self.u_nm1.x.petsc_vec
        du.waxpy(-1.0, un, u)
        dup.waxpy(-1.0, unm1, un)

        def ldot(a: PETSc.Vec, b: PETSc.Vec) -> float:
            return float(np.dot(a.array_r, b.array_r))

        # local parts of: kinetic, strain, W_ext, W_dir, W_res, W_c, D_visc, D_num
        part = np.zeros(8)
        # r = (c_M M (Δu − Δu_prev) + c_K K u + c_V Kv Δu)/c_K − F
        m.K.mult(u, r)
        part[1] = 0.5 * ldot(r, u)
        r.axpy(-1.0, self._F)
        if c_mass:
            self.M.mult(du, tmp)
            part[0] = 0.5 * c_mass / c_el * ldot(tmp, du)
            dup.aypx(-1.0, du)  # Δu − Δu_prev
            self.M.mult(dup, tmp)
            r.axpy(c_mass / c_el, tmp)
            part[7] += 0.5 * c_mass / c_el * ldot(tmp, dup)
        if c_visc and m.Kv is not None:
            m.Kv.mult(du, tmp)
            r.axpy(c_visc / c_el, tmp)
            part[6] = c_visc / c_el * ldot(tmp, du)
        m.K.mult(du, tmp)
        part[7] += 0.5 * ldot(tmp, du)
        part[2] = ldot(self._F, du)
        # split r·Δu into Dirichlet rows and the rest
        rdu = r.array_r * du.array_r
        bc = self._bc_owned_local
        part[3] = float(rdu[bc].sum()) if bc.size else 0.0
        part[4] = float(rdu.sum()) - part[3]
        if self.contact is not None:
            # from the multipliers and the gaps the contact solver returned
            part[5] = self.contact.contact_work(self.u)
        return EnergyBalance.of_step(part, self.model.mesh.comm, self.balance.total)

    def release_solver_work(self) -> None:
        """Free what the step solver rebuilds at its next solve anyway (the contact
        solver's preconditioner; collective): for a run that solves no step after this
        one and records its state, whose output then has the room (issue 28)."""
        release = getattr(self.contact, "release_work", None)
        if release is not None:
            release()

    def destroy(self) -> None:
        """Free the PETSc objects."""
        if self.contact is not None:
            self.contact.destroy()
        for obj in self._eb.values():
            obj.destroy()
        if self._dM is not None:
            for obj in (self._dM, self.M):
                obj.destroy()
        for obj in (self.ksp, self.A, self._A_bc, self._A_rows, self._b, self._w, self._F):
            if obj is not None:
                obj.destroy()
        for obj in (self._rhs0, self.residual, self.inertia, self._Au[0] if self._Au else None):
            if obj is not None:
                obj.destroy()
