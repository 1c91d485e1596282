"""Meshing: gmsh geometries with named physical groups and reading gmsh files.

:mod:`~bonecontact.meshing.shapes` holds the parametric shapes (rectangles, boxes, the
contact test pairs), :mod:`~bonecontact.meshing.anatomy` the bone sections (long bone,
knee), :mod:`~bonecontact.meshing.builder` their shared gmsh plumbing,
:mod:`~bonecontact.meshing.session` the one gmsh session helper of the package and
:mod:`~bonecontact.meshing.io` the reading of gmsh files into DOLFINx meshes.

Geometry from real data: :mod:`~bonecontact.meshing.surface_repair` reads, checks, repairs
and remeshes closed bone surfaces (STL scans), :mod:`~bonecontact.meshing.stl` turns one into
a tetrahedral bone (cortical shell, cancellous core, facet groups selected by region),
:mod:`~bonecontact.meshing.anatomy_data` loads the shipped bone surfaces,
:mod:`~bonecontact.meshing.joint` poses one bone on another, cuts them and meshes a joint
with cartilage layers, and :mod:`~bonecontact.meshing.ct` segments CT images and meshes the
bone found.  :mod:`~bonecontact.meshing.report` measures what a mesh command wrote (the
report of ``bonecontact mesh-surface`` and ``bonecontact mesh-ct``).
"""

from bonecontact.meshing.anatomy import knee_2d, long_bone_2d
from bonecontact.meshing.anatomy_data import ANATOMY_SURFACES, anatomy_surface
from bonecontact.meshing.builder import MeshingError
from bonecontact.meshing.ct import (
    CTImage,
    bone_regions,
    ct_bone_surface,
    ct_slice_mesh,
    mesh_ct,
    read_ct_series,
    read_ct_slice,
)
from bonecontact.meshing.io import read_gmsh_mesh
from bonecontact.meshing.joint import (
    Cartilage,
    JointBone,
    Pose,
    clip_surface,
    joint_from_surfaces,
    pose_on,
)
from bonecontact.meshing.report import GroupMeasure, MeshReport, format_report, msh_report
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
from bonecontact.meshing.stl import SurfaceRegion, bone_from_surface, mesh_surface
from bonecontact.meshing.surface_repair import (
    MeshInputError,
    Surface,
    check_surface,
    prepare_surface,
    read_surface,
    remesh_surface,
    repair_surface,
)

__all__ = [
    "ANATOMY_SURFACES",
    "CTImage",
    "Cartilage",
    "GroupMeasure",
    "JointBone",
    "MeshInputError",
    "MeshReport",
    "MeshingError",
    "Pose",
    "Surface",
    "SurfaceRegion",
    "anatomy_surface",
    "bone_from_surface",
    "bone_regions",
    "box",
    "cantilever",
    "check_surface",
    "clip_surface",
    "ct_bone_surface",
    "ct_slice_mesh",
    "format_report",
    "gmsh_session",
    "hertz_2d",
    "hertz_3d",
    "joint_from_surfaces",
    "knee_2d",
    "long_bone_2d",
    "mesh_ct",
    "mesh_surface",
    "msh_report",
    "pose_on",
    "prepare_surface",
    "quarter_tube",
    "read_ct_series",
    "read_ct_slice",
    "read_gmsh_mesh",
    "read_surface",
    "rectangle",
    "remesh_surface",
    "repair_surface",
    "stacked_blocks_2d",
    "two_blocks_2d",
    "two_boxes_3d",
]
