"""The contact-stabilised Newmark scheme (``[analysis] scheme = "stabilized-newmark"``).

Average acceleration in the interior, the predictor projected onto the admissible set at
the contact nodes before the step, and by default the redistributed mass with contact:
docs/theory/mechanics.md#contact-stabilised-newmark (its energy balance too).
"""

from __future__ import annotations

import time as _time

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
from dolfinx import fem

from bonecontact.mechanics.integrator import EnergyBalance, Integrator, StepInfo
from bonecontact.mechanics.model import Mechanics

__all__ = ["SCHEMES", "StabilizedNewmark", "make_integrator"]

#: Values of ``[analysis] scheme``: the integrator class of each.
SCHEMES = ("backward-difference", "stabilized-newmark")


def make_integrator(scheme: str, model: Mechanics, kind: str, dt: float, **kwargs) -> Integrator:
    """The integrator of ``scheme`` (one of :data:`SCHEMES`).

    ``"stabilized-newmark"`` applies to dynamic analyses; static and quasi-static ones
    always use :class:`~bonecontact.mechanics.integrator.Integrator`.  ``kwargs`` go to
    the constructor.
    """
    if scheme not in SCHEMES:
        raise ValueError(f"scheme must be one of {', '.join(SCHEMES)}, got {scheme!r}")
    if scheme == "stabilized-newmark" and kind == "dynamic":
        return StabilizedNewmark(model, kind, dt, **kwargs)
    return Integrator(model, kind, dt, **kwargs)


def _ldot(a: PETSc.Vec, b: PETSc.Vec) -> float:
    """This rank's part of aᵀb (NumPy's own loop: ``np.dot`` calls BLAS, whose threads
    spun on a loaded machine for 5.7 ms a call at 126k dofs, 14 % of a free step)."""
    return float(np.einsum("i,i->", a.array_r, b.array_r))


def _all_finite(u: fem.Function) -> bool:
    """True on every rank if ``u`` holds no NaN or infinity (collective)."""
    ok = bool(np.isfinite(u.x.array).all())
    return bool(u.function_space.mesh.comm.allreduce(ok, op=MPI.LAND))


class StabilizedNewmark(Integrator):
    """Contact-stabilised Newmark integrator (docs/theory/mechanics.md#contact-stabilised-newmark);
    dynamic analyses only.

    The constructor takes the arguments of
    :class:`~bonecontact.mechanics.integrator.Integrator` (``kind`` must be
    ``"dynamic"``) and has its public interface: :meth:`set_initial`, :meth:`step`,
    :meth:`state` / :meth:`restore_state` (u, u_prev, v, the energy balance and the
    contact warm start: a restart continues bit for bit), :meth:`energy`,
    :meth:`contact_gaps`, :meth:`destroy`; ``u``, ``u_n``, ``velocity``, ``M``,
    ``last_contact``, ``last_balance``, ``balance``.

    ``mass_redistribution`` defaults to ``True`` with a contact solver: the scheme then
    runs with the mass matrix of
    :func:`~bonecontact.mechanics.integrator.redistributed_mass` (no inertia at the slave
    contact nodes), the stabilisation dissipates nothing (``M δ = 0``) and the energy
    never grows in a step without loads and moving supports
    (``Eⁿ⁺¹ − Eⁿ = W_c = −Σ D_pp λ_p g_pⁿ ≤ 0``).  ``False`` gives the plain
    Deuflhard–Krause–Ertel scheme with the consistent mass, whose stabilisation term
    ``D_stab`` has no sign step by step.

    Attributes
    ----------
    predictor_corrections
        Slave nodes moved by the stabilisation in the last step (all ranks).
    """

    def __init__(
        self,
        model: Mechanics,
        kind: str = "dynamic",
        dt: float = 1.0,
        *,
        mass_redistribution: bool | None = None,
        **kwargs,
    ):
        if mass_redistribution is None:  # default: on with contact (docs/theory)
            mass_redistribution = kwargs.get("contact") is not None
        kwargs["mass_redistribution"] = bool(mass_redistribution)
        if kind != "dynamic":
            raise ValueError(
                f"the stabilized-newmark scheme is a dynamic scheme, got kind={kind!r} "
                "(static and quasistatic analyses use Integrator)"
            )
        super().__init__(model, kind, dt, **kwargs)
        self._K_mat = model.K
        self._C_mat = model.Kv if model.fields.has_viscosity else None
        self._rhs, self._wk = self.A.createVecs()
        names = ("F_old", "F_new", "F_bar", "delta", "du", "dv", "v_new", "tmp")
        self._vec = {k: self._rhs.duplicate() for k in names}
        self._z = fem.Function(model.V, name="predictor")
        bc = model.bc_dofs()
        self._bc_owned = bc[bc < model.num_owned]
        self._proj = self._projection_data()
        self.predictor_corrections = 0

    def scheme_coefficients(self) -> tuple[tuple[float, float, float], float]:
        """``(1, τ²/4, τ/2)`` (no viscous term without viscosity) and force scale 2/τ²."""
        tau = self.dt
        visc = 0.5 * tau if self.model.fields.has_viscosity else 0.0
        return (1.0, 0.25 * tau * tau, visc), 2.0 / (tau * tau)

    # ------------------------------------------------------------ predictor
    def _projection_data(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per contact pair: the local dofs (``n × gdim``) of the owned slave nodes and
        their unit normals; Dirichlet dofs are left out of the projection (row ``−1``)."""
        if self.contact is None:
            return []
        bs = self.model.V.dofmap.index_map_bs
        fixed = np.zeros(self.model.num_owned, dtype=bool)
        fixed[self._bc_owned] = True
        out = []
        for itf in self.contact.interfaces:
            dofs = bs * itf.blocks[:, None].astype(np.int64) + np.arange(bs)[None, :]
            dofs = np.where(fixed[dofs], -1, dofs)
            out.append((dofs, np.asarray(itf.normals)[:, :bs]))
        return out

    def _stabilised_predictor(self) -> None:
        """``z = uⁿ + τ vⁿ`` with every penetrating slave node moved back onto the master
        surface along its normal; ``δ = z − (uⁿ + τ vⁿ)`` into ``self._vec["delta"]``."""
        z, delta = self._z, self._vec["delta"]
        z.x.array[:] = self.u_n.x.array + self.dt * self.velocity.x.array
        delta.zeroEntries()
        if not self._proj:
            return
        gaps = self.contact.contact_gaps(z)
        d = delta.array
        moved = 0
        for (dofs, normals), g in zip(self._proj, gaps):
            pen = np.flatnonzero(g < 0.0)
            moved += pen.size
            for j in range(dofs.shape[1]):
                rows = dofs[pen, j]
                keep = rows >= 0
                d[rows[keep]] += (g[pen] * normals[pen, j])[keep]
        n = self.model.num_owned
        z.x.array[:n] += d[:n]
        z.x.scatter_forward()
        self.predictor_corrections = int(self.model.mesh.comm.allreduce(moved, op=MPI.SUM))

    # ---------------------------------------------------------------- steps
    def rhs(self, t: float) -> PETSc.Vec:
        """``M z + τ²/4 (Fⁿ + Fⁿ⁺¹ − K uⁿ) + τ/2 C uⁿ`` (before Dirichlet lifting); forms
        the stabilised predictor ``z`` first."""
        tau, b, w = self.dt, self._rhs, self._wk
        vec = self._vec
        self.model.load_vector(t - tau, vec["F_old"])
        self.model.load_vector(t, vec["F_new"])
        self._stabilised_predictor()
        b.waxpy(1.0, vec["F_old"], vec["F_new"])
        b.copy(vec["F_bar"])
        vec["F_bar"].scale(0.5)
        self._K_mat.mult(self.u_n.x.petsc_vec, w)
        b.axpy(-1.0, w)
        b.scale(0.25 * tau * tau)
        self.M.multAdd(self._z.x.petsc_vec, b, b)
        if self._C_mat is not None:
            self._C_mat.mult(self.u_n.x.petsc_vec, w)
            b.axpy(0.5 * tau, w)
        return b

    def step(self) -> StepInfo:
        """Advance one step: t ← t + Δt, stabilised predictor, one contact (or linear)
        solve, velocity update."""
        t = (self.step_count + 1) * self.dt  # not a running sum: no round-off drift in t
        t0 = _time.perf_counter()
        b = self.rhs(t)
        self.apply_dirichlet(t, b)
        if self.contact is not None:
            self.last_contact = self.contact.solve(b, self.u)
            its = self.last_contact.linear_iterations
        else:
            its = self.solve_linear(b, self.u)
        if not _all_finite(self.u):
            raise RuntimeError(
                f"the solver returned a non-finite displacement (NaN or inf) at t = {t:.6g} s"
            )
        self._new_velocity()
        self._mean_forces()
        if self.energy_balance:
            self.last_balance = self._newmark_balance()
            self.balance.accumulate(self.last_balance)
        self._shift(t)
        info = StepInfo(self.step_count, t, its, _time.perf_counter() - t0)
        info.extra["predictor_corrections"] = self.predictor_corrections
        return info

    def _new_velocity(self) -> None:
        """``vⁿ⁺¹ − vⁿ = 2/τ (uⁿ⁺¹ − z)`` into ``self._vec["dv"]``; ``Δu`` into ``du``."""
        dv, du = self._vec["dv"], self._vec["du"]
        dv.waxpy(-1.0, self._z.x.petsc_vec, self.u.x.petsc_vec)
        dv.scale(2.0 / self.dt)
        du.waxpy(-1.0, self.u_n.x.petsc_vec, self.u.x.petsc_vec)

    def _shift(self, t: float) -> None:
        """vⁿ⁺¹, uⁿ⁻¹ ← uⁿ, uⁿ ← uⁿ⁺¹, t, step count."""
        n = self.model.num_owned
        self.velocity.x.array[:n] += self._vec["dv"].array_r[:n]
        self.velocity.x.scatter_forward()
        self.u_nm1.x.array[:] = self.u_n.x.array
        self.u_n.x.array[:] = self.u.x.array
        self.t = t
        self.step_count += 1

    @property
    def load(self) -> PETSc.Vec:
        """The mean external load (Fⁿ + Fⁿ⁺¹)/2 of the last step (owned entries; N, N/m
        in 2D): the load the trapezoidal rule balances."""
        return self._vec["F_bar"]

    def _mean_forces(self) -> None:
        """``inertia = M (vⁿ⁺¹ − vⁿ)/τ`` and ``residual = inertia + K(uⁿ + uⁿ⁺¹)/2 + C Δu/τ
        − F̄`` of the step just solved: the mean force of supports and contact over the
        step (elsewhere: solver tolerance); ``self.residual`` / ``self.inertia`` as in
        :class:`~bonecontact.mechanics.integrator.Integrator`."""
        vec, tau, r, tmp = self._vec, self.dt, self.residual, self._vec["tmp"]
        self.M.mult(vec["dv"], self.inertia)
        self.inertia.scale(1.0 / tau)
        tmp.waxpy(1.0, self.u_n.x.petsc_vec, self.u.x.petsc_vec)
        self._K_mat.mult(tmp, r)
        r.scale(0.5)
        r.axpy(-1.0, vec["F_bar"])
        r.axpy(1.0, self.inertia)
        if self._C_mat is not None:
            self._C_mat.mult(vec["du"], tmp)
            r.axpy(1.0 / tau, tmp)

    # ------------------------------------------------------- energy balance
    def _newmark_balance(self) -> EnergyBalance:
        """Energy balance of the step just solved (docs/theory/mechanics.md), from the vectors of
        :meth:`_mean_forces`; history not shifted.  Local dot products and one
        collective reduction."""
        vec, tau = self._vec, self.dt
        du, tmp, delta, v_new = vec["du"], vec["tmp"], vec["delta"], vec["v_new"]
        v_new.waxpy(1.0, self.velocity.x.petsc_vec, vec["dv"])
        part = np.zeros(8)  # kinetic, strain, W_ext, W_dir, W_res, W_c, D_visc, D_stab
        self.M.mult(v_new, tmp)
        part[0] = 0.5 * _ldot(tmp, v_new)
        self._K_mat.mult(self.u.x.petsc_vec, tmp)
        part[1] = 0.5 * _ldot(tmp, self.u.x.petsc_vec)
        part[7] = _ldot(delta, self.inertia)  # δᵀ M (vⁿ⁺¹ − vⁿ)/τ
        if self._C_mat is not None:
            self._C_mat.mult(du, tmp)
            part[6] = _ldot(tmp, du) / tau
        part[2] = _ldot(vec["F_bar"], du)
        rdu = self.residual.array_r * du.array_r
        bc = self._bc_owned
        part[3] = float(rdu[bc].sum()) if bc.size else 0.0
        part[4] = float(rdu.sum()) - part[3]
        if self.contact is not None:
            part[5] = self.contact.contact_work(self.u)
        # the stabilisation's dissipation is booked as the numerical dissipation
        return EnergyBalance.of_step(part, self.model.mesh.comm, self.balance.total)

    def destroy(self) -> None:
        """Free the PETSc objects."""
        for obj in (self._rhs, self._wk, *self._vec.values()):
            obj.destroy()
        super().destroy()
