"""Longitudinal impact of two identical elastic bars: the structured mesh
(:func:`two_bars_2d`), the run (:func:`run_bar_impact`) and its figures against
elementary wave theory, with the smearing of the wave fronts by the time scheme
(docs/theory/verification.md#two-bar-impact).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

from mpi4py import MPI

import basix.ufl
import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem, mesh

from bonecontact.contact.interface import build_interface
from bonecontact.contact.pdas import ContactSolver
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import EnergyBalance
from bonecontact.mechanics.model import Mechanics
from bonecontact.mechanics.newmark import make_integrator

__all__ = [
    "STRIKER",
    "STRIKER_END",
    "STRUCK",
    "STRUCK_END",
    "BarImpact",
    "ImpactResult",
    "run_bar_impact",
    "two_bars_2d",
]

#: cell and facet tags of :func:`two_bars_2d`
STRIKER, STRUCK, STRIKER_END, STRUCK_END = 1, 2, 3, 4


@dataclass(frozen=True)
class BarImpact:
    """Parameters of the two-bar impact (SI units; 2D plane strain, per unit thickness).

    Parameters
    ----------
    length, height
        Bar length L and strip height H (m).
    gap
        Initial gap between the bars (m).
    E, rho
        Young's modulus (Pa) and density (kg/m³); ν = 0.
    v0
        Striker velocity (m/s).
    nx, ny
        Elements along and across each bar (``ny`` even).
    """

    length: float = 0.1
    height: float = 0.01
    gap: float = 1.0e-5
    E: float = 1.0e9
    rho: float = 1000.0
    v0: float = 1.0
    nx: int = 40
    ny: int = 2

    @property
    def c(self) -> float:
        """Bar wave speed √(E/ρ) (m/s)."""
        return float(np.sqrt(self.E / self.rho))

    @property
    def t_contact(self) -> float:
        """Time of first contact, gap/v₀ (s)."""
        return self.gap / self.v0

    @property
    def duration(self) -> float:
        """Contact duration 2L/c (s)."""
        return 2.0 * self.length / self.c

    @property
    def force(self) -> float:
        """Contact force ρ c v₀ A / 2 (N/m in 2D)."""
        return 0.5 * self.rho * self.c * self.v0 * self.height

    @property
    def mass(self) -> float:
        """Mass of one bar ρ L H (kg/m)."""
        return self.rho * self.length * self.height


def two_bars_2d(comm: MPI.Comm, p: BarImpact) -> tuple[mesh.Mesh, mesh.MeshTags, mesh.MeshTags]:
    """Structured mesh of the two bars: the striker ``0 ≤ x ≤ L``, the struck bar
    ``L + gap ≤ x ≤ 2L + gap``.

    ``nx`` columns of ``ny`` (even) rows of right triangles per bar, the diagonals mirrored
    about the mid-line ``y = H/2`` so that the discrete problem is symmetric and the bars
    do not rotate.  Both end faces have the same nodes (the meshes match across the gap;
    the mortar treats them as non-matching surfaces).

    Returns
    -------
    (mesh, cell_tags, facet_tags)
        Cells :data:`STRIKER` / :data:`STRUCK`; facets :data:`STRIKER_END` (x = L) and
        :data:`STRUCK_END` (x = L + gap).
    """
    if p.ny < 2 or p.ny % 2:
        raise ValueError(f"ny must be even and >= 2, got {p.ny}")
    if p.nx < 1:
        raise ValueError(f"nx must be >= 1, got {p.nx}")
    if comm.rank == 0:
        xs, cells = [], []
        for b, x0 in enumerate((0.0, p.length + p.gap)):
            base = b * (p.nx + 1) * (p.ny + 1)
            X, Y = np.meshgrid(
                x0 + np.linspace(0.0, p.length, p.nx + 1),
                np.linspace(0.0, p.height, p.ny + 1),
                indexing="ij",
            )
            xs.append(np.column_stack([X.ravel(), Y.ravel()]))
            for i in range(p.nx):
                for j in range(p.ny):
                    a, bb = (
                        base + i * (p.ny + 1) + j,
                        base + (i + 1) * (p.ny + 1) + j,
                    )  # (i,j), (i+1,j)
                    c, d = a + 1, bb + 1  # (i,j+1), (i+1,j+1)
                    if j < p.ny // 2:  # diagonal (i,j)–(i+1,j+1)
                        cells += [[a, bb, d], [a, d, c]]
                    else:  # mirrored: (i,j+1)–(i+1,j)
                        cells += [[a, bb, c], [bb, d, c]]
        x = np.concatenate(xs)
        cells = np.asarray(cells, dtype=np.int64)
    else:
        x = np.zeros((0, 2))
        cells = np.zeros((0, 3), dtype=np.int64)
    domain = ufl.Mesh(basix.ufl.element("Lagrange", "triangle", 1, shape=(2,)))
    msh = mesh.create_mesh(comm, cells, domain, x)
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    split = p.length + 0.5 * p.gap
    n_cells = msh.topology.index_map(tdim).size_local + msh.topology.index_map(tdim).num_ghosts
    mid = mesh.compute_midpoints(msh, tdim, np.arange(n_cells, dtype=np.int32))
    cell_tags = mesh.meshtags(
        msh,
        tdim,
        np.arange(n_cells, dtype=np.int32),
        np.where(mid[:, 0] < split, STRIKER, STRUCK).astype(np.int32),
    )
    tol = 1e-9 * p.length
    f1 = mesh.locate_entities_boundary(msh, tdim - 1, lambda X: np.abs(X[0] - p.length) < tol)
    f2 = mesh.locate_entities_boundary(
        msh, tdim - 1, lambda X: np.abs(X[0] - p.length - p.gap) < tol
    )
    facets = np.concatenate([f1, f2]).astype(np.int32)
    values = np.concatenate([np.full(f1.size, STRIKER_END), np.full(f2.size, STRUCK_END)]).astype(
        np.int32
    )
    order = np.argsort(facets)
    facet_tags = mesh.meshtags(msh, tdim - 1, facets[order], values[order])
    return msh, cell_tags, facet_tags


@dataclass
class ImpactResult:
    """Time series and derived figures of :func:`run_bar_impact`.

    Attributes
    ----------
    params, dt
        The set-up.
    time, force, n_active
        Per step (after the step): time, total contact force (N/m), active slave nodes.
    v_striker, v_struck
        Mean velocities (momentum / mass) of the bars per step (m/s).
    kinetic, strain
        Energies per step, index 0 = initial state (J/m).
    balance
        :class:`~bonecontact.mechanics.integrator.EnergyBalance` per step.
    t_start
        Time of the first step with contact.
    duration
        Contact time: number of steps with contact times Δt (the scheme's contact
        force acts over the step ending at the step time).
    episodes
        Number of separate contact intervals (1 without chatter or re-contact).
    mean_force
        Impulse Σ F Δt over all contact steps divided by ``duration``.
    wall_time
        Seconds for the time loop (set-up excluded), and ``setup_time``.
    """

    params: BarImpact
    dt: float
    time: npt.NDArray[np.float64]
    force: npt.NDArray[np.float64]
    n_active: npt.NDArray[np.int64]
    v_striker: npt.NDArray[np.float64]
    v_struck: npt.NDArray[np.float64]
    kinetic: npt.NDArray[np.float64]
    strain: npt.NDArray[np.float64]
    balance: list[EnergyBalance] = field(repr=False)
    t_start: float = float("nan")
    duration: float = float("nan")
    episodes: int = 0
    mean_force: float = float("nan")
    wall_time: float = 0.0
    setup_time: float = 0.0
    pdas_iterations: int = 0

    @property
    def energy(self) -> npt.NDArray[np.float64]:
        """Kinetic plus strain energy, index 0 = initial state."""
        return self.kinetic + self.strain

    @property
    def energy_increase(self) -> float:
        """Largest step increase of the total energy relative to E⁰ (≤ 0 when it never grows)."""
        e = self.energy
        return float(np.max(np.diff(e)) / e[0])

    @property
    def energy_loss(self) -> float:
        """Relative energy lost over the run, 1 − E_end/E⁰."""
        return float(1.0 - self.energy[-1] / self.energy[0])

    def errors(self) -> dict[str, float]:
        """Relative errors against the references of
        docs/theory/verification.md#two-bar-impact."""
        p = self.params
        return {
            "start": (self.t_start - p.t_contact) / p.duration,
            "duration": self.duration / p.duration - 1.0,
            "mean_force": self.mean_force / p.force - 1.0,
            "v_striker": self.v_striker[-1] / p.v0,
            "v_struck": self.v_struck[-1] / p.v0 - 1.0,
        }


def run_bar_impact(
    p: BarImpact,
    dt: float,
    *,
    t_end: float | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    linear: str = "direct",
    integrator_options: dict | None = None,
    scheme: str = "backward-difference",
) -> ImpactResult:
    """Run the two-bar impact with the dynamic
    :class:`~bonecontact.mechanics.integrator.Integrator`.

    Parameters
    ----------
    p
        Set-up.
    dt
        Time step (s).
    t_end
        End time (default ``t₀ + 1.1 · 2L/c``: the bars have separated).
    comm
        Communicator.
    linear
        ``"direct"`` or ``"iterative"``.
    integrator_options
        Extra keyword arguments for the Integrator (e.g. ``mass_redistribution``).
    scheme
        Time scheme (:data:`bonecontact.mechanics.newmark.SCHEMES`).

    Returns
    -------
    ImpactResult
    """
    integ, setup = _impact_integrator(p, dt, comm, linear, integrator_options or {}, scheme)
    momentum = _BarMomentum(integ, p.length + 0.5 * p.gap, comm)
    t_end = p.t_contact + 1.1 * p.duration if t_end is None else t_end
    res = _run_steps(integ, p, dt, int(np.ceil(t_end / dt - 1e-9)), momentum)
    integ.destroy()
    res.setup_time = setup
    _contact_figures(res)
    return res


def _impact_integrator(
    p: BarImpact, dt: float, comm: MPI.Comm, linear: str, options: dict, scheme: str
) -> tuple[Any, float]:
    """The bars' model with their contact pair, the integrator with the striker moving
    at ``v₀``, and the seconds of the integrator's set-up."""
    msh, ct, ft = two_bars_2d(comm, p)
    mat = Isotropic(E=p.E, nu=0.0, rho=p.rho)
    model = Mechanics(msh, {STRIKER: mat, STRUCK: mat}, ct, ft)
    itf = build_interface(model.V, ft, STRUCK_END, STRIKER_END, name="impact")
    t0 = time.perf_counter()
    integ = make_integrator(
        scheme,
        model,
        "dynamic",
        dt,
        linear=linear,
        contact=ContactSolver(model.V, [itf]),
        energy_balance=True,
        **options,
    )
    setup = time.perf_counter() - t0
    split = p.length + 0.5 * p.gap
    v0 = fem.Function(model.V)
    v0.interpolate(lambda X: np.vstack([np.where(X[0] < split, p.v0, 0.0), 0.0 * X[1]]))
    integ.set_initial(None, v0)
    return integ, setup


class _BarMomentum:
    """The mean velocities of the two bars: momentum ``(M e)ᵀ v`` over mass ``(M e)ᵀ e``,
    ``e`` the x-indicator of a bar and ``M`` the scheme's mass matrix (collective)."""

    def __init__(self, integ: Any, split: float, comm: MPI.Comm):
        model = integ.model
        ind = []
        for side in (1.0, 0.0):
            e = fem.Function(model.V)
            e.interpolate(
                lambda X, s=side: np.vstack(
                    [np.where((X[0] < split) == bool(s), 1.0, 0.0), 0.0 * X[1]]
                )
            )
            ind.append(e)
        self.Me = np.empty((2, model.num_owned))
        w = integ.M.createVecLeft()
        for k, e in enumerate(ind):
            integ.M.mult(e.x.petsc_vec, w)
            self.Me[k] = w.array_r
        w.destroy()
        mass = comm.allreduce(
            self.Me @ np.concatenate([e.x.array[: model.num_owned][None] for e in ind]).T,
            op=MPI.SUM,
        )
        self.mass = np.diag(mass)
        self.comm, self.integ, self.n = comm, integ, model.num_owned

    def __call__(self) -> npt.NDArray[np.float64]:
        """``(v_striker, v_struck)`` now (m/s)."""
        v = self.integ.velocity.x.array[: self.n]
        return self.comm.allreduce(self.Me @ v, op=MPI.SUM) / self.mass


def _run_steps(
    integ: Any, p: BarImpact, dt: float, nsteps: int, momentum: _BarMomentum
) -> ImpactResult:
    """``nsteps`` steps of ``integ``, recorded (force, active nodes, velocities, energies)."""
    times, forces, n_act, vs, vt, bal = [], [], [], [], [], []
    kin, strain = [integ.balance.kinetic], [integ.balance.strain]
    pdas = 0
    t1 = time.perf_counter()
    for _ in range(nsteps):
        integ.step()
        r = integ.last_contact
        pdas += r.iterations
        times.append(integ.t)
        forces.append(r.normal_force[0])
        n_act.append(r.n_active[0])
        a, b = momentum()
        vs.append(a)
        vt.append(b)
        bal.append(integ.last_balance)
        kin.append(integ.last_balance.kinetic)
        strain.append(integ.last_balance.strain)
    wall = time.perf_counter() - t1
    return ImpactResult(
        p,
        dt,
        np.asarray(times),
        np.asarray(forces),
        np.asarray(n_act),
        np.asarray(vs),
        np.asarray(vt),
        np.asarray(kin),
        np.asarray(strain),
        bal,
        wall_time=wall,
        pdas_iterations=pdas,
    )


def _contact_figures(res: ImpactResult) -> None:
    """Start, duration, number of episodes and mean force of the contact, from the
    steps with active nodes (left as NaN / 0 without contact)."""
    on = np.asarray(res.n_active) > 0
    if on.any():
        res.t_start = float(res.time[np.argmax(on)])
        res.duration = float(on.sum() * res.dt)
        res.episodes = int(on[0]) + int(np.count_nonzero(on[1:] & ~on[:-1]))
        res.mean_force = float(res.force[on].sum() * res.dt / res.duration)
