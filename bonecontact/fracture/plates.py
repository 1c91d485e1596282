"""Cracked plates under remote tension: the reference problems of the fracture tests and
benchmark (docs/theory/fracture.md#verification).

The plate is a rectangle, loaded by a uniform normal traction σ on its top edge and −σ on
its bottom edge (self-equilibrated); rigid-body motion is removed at the bottom-left
corner: u_x = 0 on the one left-edge facet and u_y = 0 on the one bottom-edge facet
meeting there.  The uniform stress state satisfies these exactly; with a crack they carry
no net force (one redundant constraint acts over one element far from the crack).
Plane stress is solved as plane strain with the equivalent material of
:func:`~bonecontact.fracture.sif.plane_stress_equivalent`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from mpi4py import MPI

import numpy as np
import ufl
from dolfinx import fem, mesh

from bonecontact.contact.interface import ContactInterface
from bonecontact.contact.pdas import PDASResult
from bonecontact.fracture.crack import Crack2D
from bonecontact.fracture.faces import FaceTraction, crack_face_solver, face_traction
from bonecontact.fracture.meshing import CrackedMesh, Hole, TipMesh, mesh_cracked_body
from bonecontact.fracture.sif import plane_stress_equivalent
from bonecontact.fracture.williams import PlaneState
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics

__all__ = [
    "PlateSolution",
    "centre_crack",
    "edge_crack",
    "mesh_plate",
    "rectangle_outline",
    "solve_plate",
    "solve_shear",
    "solve_tension",
]


def rectangle_outline(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    """Counter-clockwise rectangle: edge0 bottom, edge1 right, edge2 top, edge3 left."""
    return np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)], dtype=float)


def centre_crack(
    a: float, beta_deg: float = 0.0, centre: tuple[float, float] = (0.0, 0.0)
) -> Crack2D:
    """Straight interior crack of half-length ``a`` through ``centre``, its line at
    ``beta_deg`` degrees (counter-clockwise) to the x axis; tips at both ends."""
    b = math.radians(beta_deg)
    d = a * np.array([math.cos(b), math.sin(b)])
    c = np.asarray(centre, dtype=float)
    return Crack2D(np.array([c - d, c + d]), "both")


def edge_crack(a: float, x_edge: float = 0.0, y: float = 0.0) -> Crack2D:
    """Straight edge crack of length ``a`` from the edge ``x = x_edge`` along +x at height y."""
    return Crack2D(np.array([(x_edge, y), (x_edge + a, y)]), "end")


@dataclass
class PlateSolution:
    """A solved plate: mesh, model, displacement and potential energy (per unit thickness)."""

    cm: CrackedMesh
    model: Mechanics
    u: fem.Function
    potential: float
    #: P1 traction on the crack faces (contact multipliers or the face pressure), or None
    face_traction: FaceTraction | ufl.core.expr.Expr | None = None
    #: the PDAS result of a run with crack-face contact
    contact: PDASResult | None = None
    #: the crack faces' contact interface of that run
    contact_interface: ContactInterface | None = None


def _corner_facets(cm: CrackedMesh, corner: np.ndarray) -> np.ndarray:
    """The (two) boundary facets meeting at the mesh vertex at ``corner``."""
    msh = cm.mesh
    tol = 1e-9 * float(np.ptp(cm.outline, axis=0).max())
    on_corner = lambda x: np.hypot(x[0] - corner[0], x[1] - corner[1]) <= tol  # noqa: E731
    vertex = mesh.locate_entities_boundary(msh, 0, on_corner)
    facets = np.zeros(0, dtype=np.int32)
    if vertex.size:
        msh.topology.create_connectivity(0, 1)
        v2f = msh.topology.connectivity(0, 1)
        msh.topology.create_connectivity(1, 2)
        ext = mesh.exterior_facet_indices(msh.topology)
        facets = np.intersect1d(v2f.links(int(vertex[0])), ext).astype(np.int32)
    if msh.comm.allreduce(int(facets.size), op=MPI.SUM) == 0:
        raise ValueError(f"no mesh vertex at the corner {corner.tolist()}")
    return facets


def solve_plate(
    cm: CrackedMesh,
    material: Isotropic,
    tractions: Mapping[str, tuple[float, float]],
    plane: PlaneState = "strain",
    face_pressure: float = 0.0,
    face_contact: bool = False,
    friction: float | None = None,
) -> PlateSolution:
    """Solve the rectangle ``cm`` (outline of :func:`rectangle_outline`) under edge tractions.

    Parameters
    ----------
    cm
        Mesh of a rectangle with groups ``edge0`` … ``edge3`` (bottom, right, top, left).
    material
        The real material (plane stress: solved with its plane-strain equivalent).
    tractions
        Edge group name → traction vector (Pa); they must be in equilibrium.
    plane
        ``"strain"`` or ``"stress"``.
    face_pressure
        Pressure on both crack faces (Pa, positive opening the crack).
    face_contact, friction
        Solve with the crack faces as a contact pair (:mod:`bonecontact.fracture.faces`),
        frictionless or with Coulomb coefficient ``friction``.

    Returns
    -------
    PlateSolution
        With the potential energy Π = ½ uᵀKu − Fᵀu = −½ Fᵀu (J/m) at equilibrium (edge
        tractions only) and the face traction for the interaction integral.
    """
    mat = plane_stress_equivalent(material) if plane == "stress" else material
    m = Mechanics(cm.mesh, mat, cm.cell_tags, cm.facet_tags)
    facets = _corner_facets(cm, cm.outline[0])
    mid = mesh.compute_midpoints(cm.mesh, 1, facets)[:, :2] - cm.outline[0]
    vertical = np.abs(mid[:, 0]) < np.abs(mid[:, 1])
    m.add_dirichlet(facets[vertical], 0, 0.0)  # u_x = 0 along the left edge
    m.add_dirichlet(facets[~vertical], 1, 0.0)  # u_y = 0 along the bottom edge
    for name, t in tractions.items():
        m.add_traction(cm.groups[name], tuple(float(v) for v in t))
    face = None
    if face_pressure:
        m.add_pressure(list(cm.face_tags), face_pressure)
        face = -face_pressure * ufl.FacetNormal(cm.mesh)
    solver = crack_face_solver(m, cm, friction) if face_contact else None
    integ = Integrator(m, "static", 1.0, contact=solver)
    integ.step()
    result = integ.last_contact
    if solver is not None:
        tips = [cm.crack.tip(e) for e in cm.crack.tip_ends]
        face = face_traction(m.V, solver.interfaces[0], result, 0, tips)
    u = fem.Function(m.V, name="displacement")
    u.x.array[:] = integ.u.x.array
    integ.destroy()
    work = sum(
        fem.assemble_scalar(
            fem.form(
                ufl.dot(fem.Constant(cm.mesh, np.asarray(t, dtype=float)), u) * m.ds(cm.groups[n])
            )
        )
        for n, t in tractions.items()
    )
    work = cm.mesh.comm.allreduce(work, op=MPI.SUM)
    itf = solver.interfaces[0] if solver is not None else None
    return PlateSolution(cm, m, u, -0.5 * work, face, result, itf)


def solve_tension(
    cm: CrackedMesh, material: Isotropic, sigma: float, plane: PlaneState = "strain"
) -> PlateSolution:
    """The plate under remote normal stress σ_yy = σ: traction (0, σ) on the top edge and
    (0, −σ) on the bottom edge (:func:`solve_plate`)."""
    return solve_plate(cm, material, {"edge2": (0.0, sigma), "edge0": (0.0, -sigma)}, plane)


def solve_shear(
    cm: CrackedMesh, material: Isotropic, tau: float, plane: PlaneState = "strain"
) -> PlateSolution:
    """The plate under remote pure shear σ_xy = τ on all four edges (:func:`solve_plate`)."""
    return solve_plate(
        cm,
        material,
        {"edge2": (tau, 0.0), "edge0": (-tau, 0.0), "edge1": (0.0, tau), "edge3": (0.0, -tau)},
        plane,
    )


def mesh_plate(
    half_width: float,
    half_height: float,
    crack: Crack2D | None,
    size: TipMesh,
    comm: MPI.Comm | None = None,
    holes: tuple[Hole, ...] = (),
    x0: float | None = None,
) -> CrackedMesh:
    """Mesh the rectangle [x0, x0 + 2·half_width] × [−half_height, half_height] (``x0``
    defaults to −half_width: centred) with a crack and holes."""
    x0 = -half_width if x0 is None else x0
    outline = rectangle_outline(x0, -half_height, x0 + 2 * half_width, half_height)
    return mesh_cracked_body(outline, crack, size, comm, holes)
