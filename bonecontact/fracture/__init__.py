"""Fracture of the weakened bone (docs/theory/fracture.md): crack geometry
(:mod:`~bonecontact.fracture.crack`), meshing a body with a crack whose faces are separate
boundaries graded towards the tips (:mod:`~bonecontact.fracture.meshing`), Williams'
near-tip fields (:mod:`~bonecontact.fracture.williams`), stress intensity factors by the
domain interaction integral and displacement correlation (:mod:`~bonecontact.fracture.sif`),
the initiation risk and the direction criteria (:mod:`~bonecontact.fracture.criteria`),
the crack faces as a dual-mortar contact pair (:mod:`~bonecontact.fracture.faces`),
quasi-static propagation by remeshing (:mod:`~bonecontact.fracture.propagation`), the
cracked-plate reference problems (:mod:`~bonecontact.fracture.plates`), and in 3D K along a
planar crack front (:mod:`~bonecontact.fracture.front3d`), the planar disc, ellipse or polygon crack
of a scene (:mod:`~bonecontact.fracture.crack3d`) and a body re-meshed around it with two
faces (:mod:`~bonecontact.fracture.body3d`)."""

from bonecontact.fracture.crack import (
    Crack2D,
    FractureError,
    point_in_polygon,
    point_segment_distance,
    segments_intersect,
)
from bonecontact.fracture.criteria import (
    RISK_CRITERIA,
    CellStresses,
    RiskMaximum,
    cell_stresses,
    mts_angle,
    mts_equivalent_k,
    principal_direction_average,
    risk_field,
)
from bonecontact.fracture.faces import (
    FaceTraction,
    contact_tags,
    crack_face_solver,
    face_interface,
    face_traction,
)
from bonecontact.fracture.meshing import CrackedMesh, Hole, TipMesh, mesh_cracked_body
from bonecontact.fracture.plates import (
    PlateSolution,
    centre_crack,
    edge_crack,
    mesh_plate,
    rectangle_outline,
    solve_plate,
    solve_shear,
    solve_tension,
)
from bonecontact.fracture.propagation import (
    FRACTURE_COLUMNS,
    IncrementRecord,
    PropagationOptions,
    PropagationResult,
    propagate,
    write_fracture_table,
)
from bonecontact.fracture.sif import (
    SIFResult,
    displacement_correlation,
    energy_release_rate,
    interaction_integral,
    plane_stress_equivalent,
)
from bonecontact.fracture.williams import (
    PlaneState,
    elastic_constants,
    williams_displacement,
    williams_displacement_ufl,
    williams_stress,
)

__all__ = [
    "FRACTURE_COLUMNS",
    "RISK_CRITERIA",
    "CellStresses",
    "Crack2D",
    "CrackedMesh",
    "FaceTraction",
    "FractureError",
    "Hole",
    "IncrementRecord",
    "PlaneState",
    "PlateSolution",
    "PropagationOptions",
    "PropagationResult",
    "RiskMaximum",
    "SIFResult",
    "TipMesh",
    "cell_stresses",
    "centre_crack",
    "contact_tags",
    "crack_face_solver",
    "displacement_correlation",
    "edge_crack",
    "elastic_constants",
    "energy_release_rate",
    "face_interface",
    "face_traction",
    "interaction_integral",
    "mesh_cracked_body",
    "mesh_plate",
    "mts_angle",
    "mts_equivalent_k",
    "plane_stress_equivalent",
    "point_in_polygon",
    "point_segment_distance",
    "principal_direction_average",
    "propagate",
    "rectangle_outline",
    "risk_field",
    "segments_intersect",
    "solve_plate",
    "solve_shear",
    "solve_tension",
    "williams_displacement",
    "williams_displacement_ufl",
    "williams_stress",
    "write_fracture_table",
]
