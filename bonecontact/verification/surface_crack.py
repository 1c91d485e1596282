"""Surface-breaking cracks in a plate under tension, against Newman and Raju's empirical
stress intensity factors (docs/theory/fracture.md#surface-breaking-cracks-in-3d).

References
----------
J. C. Newman Jr. and I. S. Raju, "An empirical stress-intensity factor equation for the
surface crack", Engineering Fracture Mechanics 15 (1981) 185–192 (semi-elliptical surface
cracks in a finite plate under tension or bending; fitted to their finite-element
results, within ±5 % for 0 < a/c ≤ 1 and a/t ≤ 0.8).

J. C. Newman Jr. and I. S. Raju, "Stress-intensity factor equations for cracks in
three-dimensional finite bodies subjected to tension and bending loads", chapter 9 of
*Computational Methods in the Mechanics of Fracture* (S. N. Atluri, ed.), Elsevier 1986
(also NASA TM 85793, 1984): the quarter-elliptical corner crack.

Both write K_I = S √(πa/Q) F(a/c, a/t, c/b, φ) with the shape factor
Q = 1 + 1.464 (a/c)^1.65 (the square of the elliptic integral, approximated), S the
remote tension, a the depth, c the half-length (corner crack: the length along the
surface), t the thickness, b the half-width (corner crack: the width) and φ the
parametric angle of the ellipse (x = c cos φ along the surface, depth a sin φ; φ = 0 on
the front face).  Only a/c ≤ 1 is implemented.

:func:`solve_plate` solves the plate of :func:`~bonecontact.fracture.surface3d.
mesh_plate_with_crack` under uniform tension: K along the front by the interaction integral.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
from dolfinx import mesh

from bonecontact.common.errors import ParameterError
from bonecontact.contact.friction import FrictionLaw
from bonecontact.contact.options import PDASOptions
from bonecontact.contact.pdas import ContactSolver
from bonecontact.fracture.faces import face_interface, face_traction
from bonecontact.fracture.front3d import CrackBlock, FrontSIF, front_interaction_integral
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.plates import edge_crack, mesh_plate, solve_tension
from bonecontact.fracture.sif import interaction_integral
from bonecontact.fracture.surface3d import (
    PLATE_GROUPS,
    SurfaceCrack,
    domain_length,
    face_pair,
    front_nodes,
    mesh_plate_with_crack,
)
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics

__all__ = [
    "PLATE_MATERIAL",
    "PlateProblem",
    "PlateSolution",
    "corner_crack_k",
    "plane_strain_edge_k",
    "shape_factor",
    "solve_plate",
    "surface_crack_k",
]


def shape_factor(a_c: float) -> float:
    """Q = 1 + 1.464 (a/c)^1.65, a/c ≤ 1 (Newman–Raju's approximation of E(k)²)."""
    if not 0 < a_c <= 1:
        raise ParameterError("a/c", f"Newman-Raju is implemented for 0 < a/c <= 1, got {a_c}")
    return 1.0 + 1.464 * a_c**1.65


def _f_phi(a_c: float, phi: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The angular function of the elliptical crack, ((a/c)² cos²φ + sin²φ)^¼."""
    return (a_c**2 * np.cos(phi) ** 2 + np.sin(phi) ** 2) ** 0.25


def surface_crack_k(
    S: float, a: float, c: float, t: float, b: float, phi: npt.ArrayLike
) -> npt.NDArray[np.float64]:
    """K_I of a semi-elliptical surface crack in a plate under remote tension S
    (Newman & Raju 1981, a/c ≤ 1).

    F = [M₁ + M₂(a/t)² + M₃(a/t)⁴] g f_φ f_w with M₁ = 1.13 − 0.09 a/c,
    M₂ = −0.54 + 0.89/(0.2 + a/c), M₃ = 0.5 − 1/(0.65 + a/c) + 14(1 − a/c)²⁴,
    g = 1 + [0.1 + 0.35(a/t)²](1 − sin φ)², f_w = √sec(πc/(2b) √(a/t)).

    Parameters
    ----------
    S
        Remote tension (Pa).
    a, c, t, b
        Depth, half-length, thickness, half-width of the plate (m).
    phi
        Parametric angle(s), 0 … π (symmetric about π/2).
    """
    ac, at = a / c, a / t
    phi = np.asarray(phi, dtype=float)
    phi = np.where(phi > 0.5 * math.pi, math.pi - phi, phi)
    M1 = 1.13 - 0.09 * ac
    M2 = -0.54 + 0.89 / (0.2 + ac)
    M3 = 0.5 - 1.0 / (0.65 + ac) + 14.0 * (1.0 - ac) ** 24
    g = 1.0 + (0.1 + 0.35 * at**2) * (1.0 - np.sin(phi)) ** 2
    fw = math.sqrt(1.0 / math.cos(0.5 * math.pi * c / b * math.sqrt(at)))
    F = (M1 + M2 * at**2 + M3 * at**4) * g * _f_phi(ac, phi) * fw
    return S * np.sqrt(math.pi * a / shape_factor(ac)) * F


def corner_crack_k(
    S: float, a: float, c: float, t: float, width: float, phi: npt.ArrayLike
) -> npt.NDArray[np.float64]:
    """K_I of a quarter-elliptical corner crack in a plate under remote tension S
    (Newman & Raju 1986, a/c ≤ 1).

    F = [M₁ + M₂(a/t)² + M₃(a/t)⁴] g₁ g₂ f_φ f_w with M₁ = 1.08 − 0.03 a/c,
    M₂ = −0.44 + 1.06/(0.3 + a/c), M₃ = −0.5 + 0.25 a/c + 14.8(1 − a/c)¹⁵,
    g₁ = 1 + [0.08 + 0.4(a/t)²](1 − sin φ)³, g₂ = 1 + [0.08 + 0.15(a/t)²](1 − cos φ)³,
    f_w = 1 − 0.2λ + 9.4λ² − 19.4λ³ + 27.1λ⁴, λ = (c/width)√(a/t).

    Parameters
    ----------
    S
        Remote tension (Pa).
    a, c, t, width
        Depth (along the side face), length along the front face, thickness and the
        plate's whole width (m).
    phi
        Parametric angle(s), 0 (front face) … π/2 (side face).
    """
    ac, at = a / c, a / t
    phi = np.asarray(phi, dtype=float)
    M1 = 1.08 - 0.03 * ac
    M2 = -0.44 + 1.06 / (0.3 + ac)
    M3 = -0.5 + 0.25 * ac + 14.8 * (1.0 - ac) ** 15
    g1 = 1.0 + (0.08 + 0.4 * at**2) * (1.0 - np.sin(phi)) ** 3
    g2 = 1.0 + (0.08 + 0.15 * at**2) * (1.0 - np.cos(phi)) ** 3
    lam = c / width * math.sqrt(at)
    fw = 1.0 - 0.2 * lam + 9.4 * lam**2 - 19.4 * lam**3 + 27.1 * lam**4
    F = (M1 + M2 * at**2 + M3 * at**4) * g1 * g2 * _f_phi(ac, phi) * fw
    return S * np.sqrt(math.pi * a / shape_factor(ac)) * F


#: The plate's material (E = 1 Pa, ν = 0.3: K scales with S, not with E).
PLATE_MATERIAL = Isotropic(E=1.0, nu=0.3)


@dataclass(frozen=True)
class PlateProblem:
    """A cracked plate [−b, b] × [−h, h] × [−t, 0] under uniform tension S on y = ±h.

    ``h_front`` is the element size at the front, ``grading`` its growth per unit distance,
    ``h_max`` the largest size; ``r_out`` the ring radius of the interaction integral
    (its half-length along the front is r_out, less near the free surface:
    :func:`~bonecontact.fracture.surface3d.domain_length`).  ``contact``: the crack faces
    are a frictionless dual-mortar contact pair (``crack_upper`` slave), solved by the
    PDAS, and K takes their contact tractions as the face term.
    """

    crack: SurfaceCrack
    b: float
    h: float
    t: float
    h_front: float
    grading: float = 0.12
    h_max: float | None = None
    r_out: float | None = None
    S: float = 1.0
    material: Isotropic = PLATE_MATERIAL
    contact: bool = False

    def reference(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Newman–Raju's K_I at parametric angles ``phi`` (elliptical cracks)."""
        a, c = self.crack.depth, self.crack.half_length
        if self.crack.kind == "semi_elliptical":
            return surface_crack_k(self.S, a, c, self.t, self.b, phi)
        if self.crack.kind == "corner":
            return corner_crack_k(self.S, a, c, self.t, 2.0 * self.b, phi)
        raise ParameterError("kind", "Newman-Raju covers the elliptical cracks only")


@dataclass
class PlateSolution:
    """The solved plate: its model and displacement (``block``, ``u``), the number of
    dofs."""

    problem: PlateProblem
    block: CrackBlock
    u: object
    dofs: int
    contact: object = None  # the PDAS result of a contact run
    face_traction: tuple | None = None  # (upper, lower) contact tractions

    def k(self, phi: float) -> FrontSIF:
        """K at the front parameter ``phi`` by the interaction integral, the domain shortened
        along the front near the free surface."""
        p = self.problem
        r_out = p.r_out if p.r_out is not None else 0.25 * p.crack.depth
        length = domain_length(self.block.front, phi, r_out, p.h_front)
        return front_interaction_integral(
            self.u,
            self.block,
            phi,
            p.material,
            r_out,
            None,
            length,
            face_traction=self.face_traction,
        )


def _pin_patch(blk: CrackBlock, centre: np.ndarray, radius: float) -> npt.NDArray[np.int32]:
    """The facets of ``bottom`` whose midpoints lie within ``radius`` of ``centre``: the
    patch that holds the rigid motions (collective; refused if empty on every rank)."""
    msh = blk.mesh
    facets = blk.facet_tags.find(PLATE_GROUPS["bottom"])
    mid = mesh.compute_midpoints(msh, 2, facets)
    patch = facets[np.linalg.norm(mid - centre, axis=1) <= radius].astype(np.int32)
    if msh.comm.allreduce(patch.size, op=MPI.SUM) == 0:
        raise ParameterError("h_max", f"no bottom facet within {radius:g} m of {centre}")
    return patch


def solve_plate(problem: PlateProblem, comm: MPI.Comm | None = None) -> PlateSolution:
    """Mesh and solve the plate (collective): traction S on ``top`` and −S on ``bottom``
    (self-equilibrated remote tension), u = 0 on the bottom facets whose midpoints lie
    within max(t/4, h_max) of (0, −h, −t/2) — a small patch, 2h from the crack, that
    holds the rigid motions and carries no net force."""
    comm = MPI.COMM_WORLD if comm is None else comm
    p = problem
    blk = mesh_plate_with_crack(p.crack, p.b, p.h, p.t, p.h_front, p.grading, p.h_max, comm)
    m = Mechanics(blk.mesh, p.material, blk.cell_tags, blk.facet_tags)
    h_max = p.h_max if p.h_max is not None else 0.5 * p.t
    patch = _pin_patch(blk, np.array([0.0, -p.h, -0.5 * p.t]), max(0.25 * p.t, h_max))
    for i in range(3):
        m.add_dirichlet(patch, i, 0.0)
    m.add_traction(PLATE_GROUPS["top"], (0.0, p.S, 0.0))
    m.add_traction(PLATE_GROUPS["bottom"], (0.0, -p.S, 0.0))
    solver = None
    if p.contact:
        itf = face_interface(m, face_pair(blk), "crack")
        opts = PDASOptions(friction=FrictionLaw(), max_iterations=50)
        solver = ContactSolver(m.V, [itf], opts)
    integ = Integrator(m, "static", 1.0, contact=solver)
    integ.step()
    u = integ.u.copy()
    result = integ.last_contact
    integ.destroy()
    dofs = u.function_space.dofmap.index_map.size_global * 3
    traction = None
    closed = solver is not None and comm.allreduce(int(np.any(result.active[0])), op=MPI.MAX)
    if closed:  # (collective: a rank may hold no slave node)
        r_out = p.r_out if p.r_out is not None else 0.25 * p.crack.depth
        ft = face_traction(m.V, solver.interfaces[0], result, 0, front_nodes(blk), r_out, 6.0)
        traction = (ft.plus, ft.minus)
    return PlateSolution(p, blk, u, dofs, result, traction)


def plane_strain_edge_k(problem: PlateProblem, comm: MPI.Comm | None = None) -> float:
    """K_I of the through crack's 2D counterpart: the x-y section of the plate with the
    edge crack of length a from x = −b, in plane strain under the same self-equilibrated
    tension (:func:`bonecontact.fracture.plates.solve_tension`, tip mesh a/100, domain
    a/4).  The reference of the 3D through crack's mid-thickness K."""
    p = problem
    a = p.crack.depth
    cm = mesh_plate(p.b, p.h, edge_crack(a, -p.b), TipMesh(a / 100, 0.25, 0.1 * p.b), comm)
    sol = solve_tension(cm, p.material, p.S, "strain")
    return interaction_integral(sol.u, cm, -1, p.material, 0.25 * a).K_I
