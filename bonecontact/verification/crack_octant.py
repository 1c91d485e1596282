"""The octant of a block with a planar crack at its centre under remote tension, solved.

The shared problem of the 3D front tests and benchmarks: one eighth of a block around a
planar crack (:func:`~bonecontact.fracture.front3d.mesh_crack_octant`), held by the two
symmetry planes through the crack's axes and the uncracked ligament of the crack plane,
pulled by a uniform traction σ on the top face (SI units).  Its K_I has closed forms for
a penny (Sneddon) and an ellipse (Irwin).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics

if TYPE_CHECKING:
    from dolfinx import fem

    from bonecontact.fracture.front3d import CrackBlock
    from bonecontact.materials.laws import Material

__all__ = ["solve_crack_octant"]


def solve_crack_octant(block: CrackBlock, material: Material, sigma: float) -> fem.Function:
    """The static displacement of a meshed crack octant under the remote tension ``sigma``.

    Parameters
    ----------
    block
        The octant from :func:`~bonecontact.fracture.front3d.mesh_crack_octant` (its groups
        ``sym_x``, ``sym_y``, ``ligament`` and ``top``).
    material
        The block's material.
    sigma
        Normal traction on the top face (Pa).

    Returns
    -------
    dolfinx.fem.Function
        The displacement (a copy; the solver is destroyed).
    """
    m = Mechanics(block.mesh, material, block.cell_tags, block.facet_tags)
    g = block.groups
    m.add_dirichlet(m.facets(g["sym_x"]), 0, 0.0)
    m.add_dirichlet(m.facets(g["sym_y"]), 1, 0.0)
    m.add_dirichlet(m.facets(g["ligament"]), 2, 0.0)
    m.add_traction(g["top"], (0.0, 0.0, sigma))
    integ = Integrator(m, "static", 1.0)
    integ.step()
    u = integ.u.copy()
    integ.destroy()
    return u
