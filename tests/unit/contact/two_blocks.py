"""The two-block contact model shared by the PDAS tests: a soft block (20 MPa) on a stiff
block (17 GPa), pulled up at its right end so that part of the interface opens.

Not a test module (no ``test_`` prefix); the contact tests import it by name (pytest puts
this folder on ``sys.path``).
"""

from __future__ import annotations

from mpi4py import MPI

import ufl

from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.model import Mechanics
from bonecontact.meshing import shapes as meshing

W, H = 0.02, 0.01
P0 = 1.0e5


def partial_liftoff_model(comm: MPI.Comm = MPI.COMM_WORLD):
    """The two blocks, both held sideways, the lower one clamped at its base; the top face
    loaded by ``-P0 (1 - 1.2 x/W)``: compression on the left, tension on the right, with
    the resultant 0.4 P0 W (per unit thickness) acting at x = W/4.

    Returns
    -------
    The mesh data, the physical-group tags by name and the :class:`Mechanics` model.
    """
    md = meshing.two_blocks_2d(
        comm, h_lower=W / 9, h_upper=W / 24, width=W, lower_height=H, upper_height=H
    )
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    mats = {pg["lower"]: Isotropic(E=17.0e9, nu=0.3), pg["upper"]: Isotropic(E=20.0e6, nu=0.3)}
    m = Mechanics(md.mesh, mats, md.cell_tags, md.facet_tags)
    m.add_dirichlet(m.facets(pg["bottom"]), 1, 0.0)
    m.add_dirichlet(m.facets(pg["bottom"]), 0, 0.0)
    m.add_dirichlet(m.facets(pg["top"]), 0, 0.0)  # holds the upper block sideways
    x = ufl.SpatialCoordinate(md.mesh)
    m.add_traction(pg["top"], ufl.as_vector([0.0, -P0 * (1.0 - 1.2 * x[0] / W)]))
    return md, pg, m


def friction_blocks(comm: MPI.Comm, dim: int):
    """The two blocks of the friction tests (2D: upper W/16, lower W/9; 3D: boxes at
    W/6 and W/4) before any material or load.

    Returns
    -------
    The mesh data and the physical-group tags by name.
    """
    if dim == 2:
        md = meshing.two_blocks_2d(
            comm, h_lower=W / 9, h_upper=W / 16, width=W, lower_height=H, upper_height=H
        )
    else:
        md = meshing.two_boxes_3d(comm, h_lower=W / 4, h_upper=W / 6)
    return md, {k: v.tag for k, v in md.physical_groups.items()}
