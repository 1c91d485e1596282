"""Meshing: gmsh geometries with named physical groups and reading gmsh files.

:mod:`~bonecontact.meshing.shapes` holds the parametric shapes (rectangles, boxes, the
contact test pairs), :mod:`~bonecontact.meshing.anatomy` the bone sections (long bone,
knee), :mod:`~bonecontact.meshing.builder` their shared gmsh plumbing,
:mod:`~bonecontact.meshing.session` the one gmsh session helper of the package and
:mod:`~bonecontact.meshing.io` the reading of gmsh files into DOLFINx meshes.
"""

from bonecontact.meshing.anatomy import knee_2d, long_bone_2d
from bonecontact.meshing.builder import MeshingError
from bonecontact.meshing.io import read_gmsh_mesh
from bonecontact.meshing.session import gmsh_session
from bonecontact.meshing.shapes import (
    box,
    cantilever,
    hertz_2d,
    hertz_3d,
    quarter_tube,
    rectangle,
    stacked_blocks_2d,
    two_blocks_2d,
    two_boxes_3d,
)

__all__ = [
    "MeshingError",
    "box",
    "cantilever",
    "gmsh_session",
    "hertz_2d",
    "hertz_3d",
    "knee_2d",
    "long_bone_2d",
    "quarter_tube",
    "read_gmsh_mesh",
    "rectangle",
    "stacked_blocks_2d",
    "two_blocks_2d",
    "two_boxes_3d",
]
