"""Growing neoplasms: the avascular tumour model on a moving, remeshed mesh
(:mod:`~bonecontact.neoplasm.tumour`), the osmotic cyst as a closed ODE
(:mod:`~bonecontact.neoplasm.cyst`) and with a moving wall
(:mod:`~bonecontact.neoplasm.cyst_shape`), boundary curvature
(:mod:`~bonecontact.neoplasm.curvature`) and meshing, mesh motion and field transfer
(:mod:`~bonecontact.neoplasm.remesh`), the growth drivers of growth runs
(:mod:`~bonecontact.neoplasm.growth`) and the host mesh rebuilt around a neoplasm
(:mod:`~bonecontact.neoplasm.host`)."""

from bonecontact.neoplasm.curvature import (
    polygon_curvature,
    polygon_normals,
    surface_curvature,
    vertex_normals,
)
from bonecontact.neoplasm.cyst import (
    CystHistory,
    CystParameterError,
    CystParameters,
    equilibrium_radius,
    grow_sphere,
    long_time_rate,
    radius_rate,
)
from bonecontact.neoplasm.cyst_shape import CystShapeModel, boundary_measures, offset_directions
from bonecontact.neoplasm.growth import (
    GROWTH_COLUMNS,
    CystShapeGrowth,
    CystSphereGrowth,
    TumourGrowth,
    cyst_shape_growth,
    equivalent_radius,
    mesh_measure,
    region_boundary,
    region_submesh,
    surface_tension_dt_limit,
    tumour_growth,
)
from bonecontact.neoplasm.host import (
    CouplingError,
    HostGeometry,
    HostMesh,
    build_host_mesh,
    neoplasm_polygon,
    read_host_geometry,
    wall_name,
)
from bonecontact.neoplasm.remesh import (
    Boundary,
    CoverageError,
    MeshMotion,
    RemeshError,
    gather_boundary,
    moved_surface_mesh,
    polygon_mesh,
    resample_closed_curve,
    smooth_surface,
    sphere_mesh,
    surface_mesh,
    transfer,
    vertex_to_geometry,
)
from bonecontact.neoplasm.tumour import (
    TumourError,
    TumourModel,
    TumourParameterError,
    TumourParameters,
)

__all__ = [
    # growth drivers
    "GROWTH_COLUMNS",
    # remesh
    "Boundary",
    # host mesh rebuilt around a neoplasm
    "CouplingError",
    "CoverageError",
    # cyst
    "CystHistory",
    "CystParameterError",
    "CystParameters",
    "CystShapeGrowth",
    "CystShapeModel",
    "CystSphereGrowth",
    "HostGeometry",
    "HostMesh",
    "MeshMotion",
    "RemeshError",
    # tumour
    "TumourError",
    "TumourGrowth",
    "TumourModel",
    "TumourParameterError",
    "TumourParameters",
    "boundary_measures",
    "build_host_mesh",
    "cyst_shape_growth",
    "equilibrium_radius",
    "equivalent_radius",
    "gather_boundary",
    "grow_sphere",
    "long_time_rate",
    "mesh_measure",
    "moved_surface_mesh",
    "neoplasm_polygon",
    "offset_directions",
    # curvature
    "polygon_curvature",
    "polygon_mesh",
    "polygon_normals",
    "radius_rate",
    "read_host_geometry",
    "region_boundary",
    "region_submesh",
    "resample_closed_curve",
    "smooth_surface",
    "sphere_mesh",
    "surface_curvature",
    "surface_mesh",
    "surface_tension_dt_limit",
    "transfer",
    "tumour_growth",
    "vertex_normals",
    "vertex_to_geometry",
    "wall_name",
]
