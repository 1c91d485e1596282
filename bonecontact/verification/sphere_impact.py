"""Impact of an elastic hemisphere on a stiff block (3D Hertz impact): set-up and run.

The hemisphere of :func:`bonecontact.meshing.shapes.hertz_3d` (radius R, flat face up,
E, ν, ρ) touches the block (E_b ≫ E, fixed at its bottom) at the origin at t = 0 and
moves down at v₀; frictionless dual mortar contact (slave: the curved surface).
Reference (quasi-static Hertz impact, Johnson, *Contact Mechanics*, §11.4), with the
hemisphere's mass m = ⅔πR³ρ and 1/E* = (1 − ν²)/E + (1 − ν_b²)/E_b:

* largest approach δ* = (15 m v₀² / (16 E* √R))^(2/5);
* peak force F* = (4/3) E* √R δ*^(3/2);
* contact time t_c = 2.9432 δ*/v₀;
* the elastic impact returns the kinetic energy: the sphere leaves at −v₀ up to what
  its vibrations keep (small when t_c is many times the wave transit time R/c).

The hemisphere's lateral rigid motions are not held (the contact is frictionless) but
nothing excites them; the dynamic operator is regular with the mass.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from mpi4py import MPI

import numpy as np
from dolfinx import fem

from bonecontact.contact.interface import build_interface
from bonecontact.contact.pdas import ContactSolver
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.model import Mechanics
from bonecontact.mechanics.newmark import make_integrator
from bonecontact.meshing import shapes as meshing

__all__ = ["SphereImpact", "SphereImpactResult", "run_sphere_impact", "sphere_model"]


@dataclass(frozen=True)
class SphereImpact:
    """Parameters (SI units) and the Hertz references (module docstring)."""

    radius: float = 0.01
    E: float = 2.0e9
    nu: float = 0.3
    rho: float = 1000.0
    E_block: float = 2.0e11
    v0: float = 1.0
    h_contact: float = 2.5e-4
    h_far: float = 3.0e-3

    @property
    def mass(self) -> float:
        """Mass of the hemisphere ⅔πR³ρ (kg)."""
        return 2.0 / 3.0 * np.pi * self.radius**3 * self.rho

    @property
    def E_star(self) -> float:
        """Contact modulus E* (Pa)."""
        return 1.0 / ((1.0 - self.nu**2) / self.E + (1.0 - self.nu**2) / self.E_block)

    @property
    def approach(self) -> float:
        """Largest approach δ* (m)."""
        return (15.0 * self.mass * self.v0**2 / (16.0 * self.E_star * np.sqrt(self.radius))) ** 0.4

    @property
    def peak_force(self) -> float:
        """Peak force F* (N)."""
        return 4.0 / 3.0 * self.E_star * np.sqrt(self.radius) * self.approach**1.5

    @property
    def contact_time(self) -> float:
        """Contact time t_c (s)."""
        return 2.9432 * self.approach / self.v0


@dataclass
class SphereImpactResult:
    """Figures of :func:`run_sphere_impact`.

    Attributes
    ----------
    contact_time, peak_force
        Steps with contact × Δt (s) and the largest step force (N).
    energy_returned
        Kinetic + strain energy after separation / before (the time scheme's loss).
    rebound
        Vertical velocity of the hemisphere's centre of mass after separation / (−v₀)
        (its square: the share of the kinetic energy left in the rigid motion).
    dofs, steps, wall_time
        Size, steps run, seconds of the time loop (set-up excluded).
    """

    params: SphereImpact
    dt: float
    contact_time: float
    peak_force: float
    energy_returned: float
    rebound: float
    dofs: int
    steps: int
    wall_time: float
    setup_time: float

    def errors(self) -> dict[str, float]:
        """Relative errors against Hertz, and the energy not returned."""
        p = self.params
        return {
            "contact_time": self.contact_time / p.contact_time - 1.0,
            "peak_force": self.peak_force / p.peak_force - 1.0,
            "energy_lost": 1.0 - self.energy_returned,
        }


def sphere_model(p: SphereImpact, comm: MPI.Comm) -> tuple:
    """The model, the contact interface and the hemisphere's vertical indicator (a
    function: 1 on the vertical dofs of the hemisphere) of the impact ``p``."""
    md = meshing.hertz_3d(comm, radius=p.radius, h_contact=p.h_contact, h_far=p.h_far)
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    mats = {
        pg["sphere"]: Isotropic(E=p.E, nu=p.nu, rho=p.rho),
        pg["block"]: Isotropic(E=p.E_block, nu=p.nu, rho=p.rho),
    }
    m = Mechanics(md.mesh, mats, md.cell_tags, md.facet_tags)
    for c in range(3):
        m.add_dirichlet(m.facets(pg["block_bottom"]), c, 0.0)
    itf = build_interface(
        m.V, md.facet_tags, pg["sphere_contact"], pg["block_contact"], dirichlet_dofs=m.bc_dofs()
    )
    sphere = fem.Function(m.V)  # vertical indicator of the hemisphere
    cells = md.cell_tags.find(pg["sphere"])
    dofs = fem.locate_dofs_topological(m.V.sub(1), 3, cells)
    sphere.x.array[dofs] = 1.0
    return m, itf, sphere


def run_sphere_impact(
    p: SphereImpact,
    dt: float,
    scheme: str = "stabilized-newmark",
    comm: MPI.Comm = MPI.COMM_WORLD,
    t_max: float | None = None,
) -> SphereImpactResult:
    """Run the impact with ``scheme`` until two steps after separation (or ``t_max``,
    default 2 t_c); see :class:`SphereImpactResult`."""
    t0 = time.perf_counter()
    m, itf, sphere = sphere_model(p, comm)
    integ = make_integrator(
        scheme, m, "dynamic", dt, contact=ContactSolver(m.V, [itf]), energy_balance=True
    )
    v0 = fem.Function(m.V)
    v0.x.array[:] = -p.v0 * sphere.x.array
    integ.set_initial(None, v0)
    setup = time.perf_counter() - t0
    w = integ.M.createVecLeft()
    integ.M.mult(sphere.x.petsc_vec, w)  # momentum = wᵀ v
    mass = sphere.x.petsc_vec.dot(w)
    e0 = integ.balance.total
    t_max = 2.0 * p.contact_time if t_max is None else t_max
    forces, after, k = [], 0, 0
    t1 = time.perf_counter()
    while k * dt < t_max and after < 2:
        integ.step()
        k += 1
        forces.append(integ.last_contact.normal_force[0] if integ.last_contact.n_active[0] else 0.0)
        if forces[-1] == 0.0 and any(forces):
            after += 1
    wall = time.perf_counter() - t1
    f = np.asarray(forces)
    res = SphereImpactResult(
        p,
        dt,
        contact_time=float(np.count_nonzero(f) * dt),
        peak_force=float(f.max()),
        energy_returned=float(integ.balance.total / e0),
        rebound=float(integ.velocity.x.petsc_vec.dot(w) / mass / p.v0),
        dofs=int(m.V.dofmap.index_map.size_global * 3),
        steps=k,
        wall_time=wall,
        setup_time=setup,
    )
    w.destroy()
    integ.destroy()
    return res
