"""Verification problems shared by the tests and the benchmarks.

:func:`solve_hertz_3d`: a hemisphere pressed on a block, solved by the PDAS and
compared with Hertz's solution.  :func:`crack_block_model` and
:func:`crack_block_scene`: a planar crack in a block under uniaxial stress, as a mesh
and a scene (the 3D crack-scene tests and benchmark).
"""

from __future__ import annotations

from mpi4py import MPI

import gmsh
import numpy as np

from bonecontact.contact.interface import build_interface
from bonecontact.contact.pdas import ContactSolver
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics
from bonecontact.meshing import shapes as meshing
from bonecontact.verification.analytic import hertz_3d

__all__ = [
    "CRACK_BLOCK_SCENE",
    "HERTZ_3D_NU",
    "HERTZ_3D_RADIUS",
    "crack_block_model",
    "crack_block_scene",
    "solve_hertz_3d",
]

#: Sphere radius (m) and Poisson ratio of :func:`solve_hertz_3d`.
HERTZ_3D_RADIUS, HERTZ_3D_NU = 0.01, 0.3


def solve_hertz_3d(
    h: float, E1: float = 2.0e9, E2: float = 17.0e9, comm: MPI.Comm = MPI.COMM_WORLD
) -> dict:
    """Hemisphere (R = 10 mm) on a block, approach δ = a²/R for a ≈ 1 mm (a/R ≈ 0.1);
    CG + GAMG on the condensed system.  Returns relative errors of the contact radius
    (fit of λ² = p₀²(1 − r²/a²) over r < 0.8a) and of the fitted peak pressure.

    Parameters
    ----------
    h
        Mesh size at the contact (m).
    E1, E2
        Young's moduli of the sphere and of the block (Pa).
    comm
        Communicator.

    Returns
    -------
    dict
        ``a``, ``p0`` (relative errors), ``a_over_R`` and the PDAS ``iterations``.
    """
    R, NU = HERTZ_3D_RADIUS, HERTZ_3D_NU
    a_t = 1.0e-3
    md = meshing.hertz_3d(comm, h_contact=h, zone=1.5 * a_t)
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    m = Mechanics(
        md.mesh,
        {pg["sphere"]: Isotropic(E=E1, nu=NU), pg["block"]: Isotropic(E=E2, nu=NU)},
        md.cell_tags,
        md.facet_tags,
    )
    for c in range(3):
        m.add_dirichlet(m.facets(pg["block_bottom"]), c, 0.0)
        m.add_dirichlet(m.facets(pg["sphere_top"]), c, -(a_t**2) / R if c == 1 else 0.0)
    itf = build_interface(
        m.V, md.facet_tags, pg["sphere_contact"], pg["block_contact"], dirichlet_dofs=m.bc_dofs()
    )
    integ = Integrator(m, "static", 1.0, linear="iterative", contact=ContactSolver(m.V, [itf]))
    integ.step()
    r = integ.last_contact
    X = np.concatenate(comm.allgather(itf.coords))
    lam = np.concatenate(comm.allgather(r.pressure[0]))
    P = comm.allreduce(float(-(itf.weight * r.pressure[0] * itf.normals[:, 1]).sum()), op=MPI.SUM)
    rr = np.hypot(X[:, 0], X[:, 2])
    a_ref, p0_ref = (
        hertz_3d.radius(P, R, E1, NU, E2, NU),
        hertz_3d.peak_pressure(P, R, E1, NU, E2, NU),
    )
    sel = rr < 0.8 * a_ref
    c0, c1 = np.linalg.lstsq(np.c_[np.ones(sel.sum()), rr[sel] ** 2], lam[sel] ** 2, rcond=None)[0]
    out = {
        "a": np.sqrt(-c0 / c1) / a_ref - 1.0,
        "p0": np.sqrt(c0) / p0_ref - 1.0,
        "a_over_R": a_ref / R,
        "iterations": r.iterations,
    }
    integ.destroy()
    return out


# ----------------------------------------------------------------------------- crack in a block
#: Scene of a planar ``[[crack]]`` in the block of :func:`crack_block_model` (SI units):
#: rollers on xmin, ymin, zmin, a normal traction ``sigma`` on top, K along the front.
#: Placeholders: mesh, regions, E, nu, sigma, h (front element size), geometry (the
#: crack's shape keys), points (front points).
CRACK_BLOCK_SCENE = """format = 1
[scene]
name = "penny3d"
mesh = "{mesh}"
dimension = 3
[analysis]
kind = "static"
load_steps = 1
[[material]]
name = "bone"
regions = {regions}
model = "isotropic"
E = {E}
nu = {nu}
sigma_t = 133e6
[[dirichlet]]
boundary = "xmin"
value = [0.0, "free", "free"]
[[dirichlet]]
boundary = "ymin"
value = ["free", 0.0, "free"]
[[dirichlet]]
boundary = "zmin"
value = ["free", "free", 0.0]
[[traction]]
boundary = "top"
value = [0.0, 0.0, {sigma}]
[fracture]
tip_size = {h}
tip_grading = 0.12
[[crack]]
name = "penny"
{geometry}
region = "block"
front_points = {points}
[output]
fields_every = 0
"""


def crack_block_scene(
    mesh: str,
    geometry: str,
    *,
    E: float,
    nu: float,
    sigma: float,
    h: float,
    regions: str = '["block"]',
    points: int = 8,
) -> str:
    """The text of :data:`CRACK_BLOCK_SCENE`; ``geometry`` is the crack's shape keys, e.g.
    ``"centre = [0.0, 0.0, 0.0]\\nnormal = [0.0, 0.0, 1.0]\\nradius = 0.001"``."""
    return CRACK_BLOCK_SCENE.format(
        mesh=mesh, regions=regions, E=E, nu=nu, sigma=sigma, h=h, geometry=geometry, points=points
    )


def crack_block_model(half_width: float, insert: bool = False) -> None:
    """The block ``[−W, W]³`` in the current gmsh model (``W = half_width``): cell group
    "block" (with ``insert``: the slab ``z > W/2`` is the group "insert"), facet groups
    xmin, ymin, zmin and top, largest element ``W/2`` (the crack's front sets the size
    near it).  Call on the rank that builds the mesh, between ``gmsh.initialize`` and
    ``gmsh.model.mesh.generate``."""
    W = half_width
    occ = gmsh.model.occ
    box = occ.addBox(-W, -W, -W, 2 * W, 2 * W, 2 * W)
    if insert:
        occ.fragment([(3, box)], [(3, occ.addBox(-W, -W, W / 2, 2 * W, 2 * W, W / 2))])
    occ.synchronize()
    vols = [t for _, t in gmsh.model.getEntities(3)]
    upper = [v for v in vols if occ.getCenterOfMass(3, v)[2] > W / 2]
    gmsh.model.addPhysicalGroup(3, [v for v in vols if v not in upper], 1, name="block")
    if insert:
        gmsh.model.addPhysicalGroup(3, upper, 6, name="insert")
    faces = [t for _, t in gmsh.model.getEntities(2)]
    com = {f: occ.getCenterOfMass(2, f) for f in faces}
    for k, (name, ax, v) in enumerate(
        [("xmin", 0, -W), ("ymin", 1, -W), ("zmin", 2, -W), ("top", 2, W)], start=2
    ):
        sel = [f for f in faces if abs(com[f][ax] - v) < 1e-9 * W]
        gmsh.model.addPhysicalGroup(2, sel, k, name=name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", W / 2)
