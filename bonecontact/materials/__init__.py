"""Material laws of bone and soft tissue: linear elastic laws (isotropic, transversely
isotropic, orthotropic) with their validation (:mod:`~bonecontact.materials.laws`), the
per-cell material fields on a DOLFINx mesh (:mod:`~bonecontact.materials.constitutive`)
and the library of literature values (:mod:`~bonecontact.materials.library`)."""

from bonecontact.materials.constitutive import MaterialFields, deviatoric_block, material_fields
from bonecontact.materials.laws import (
    FORMULATIONS,
    Isotropic,
    Material,
    MaterialError,
    Orthotropic,
    TransverselyIsotropic,
    plane_strain_block,
    voigt_rotation,
)
from bonecontact.materials.library import (
    DATA_DIR,
    MATERIALS_FILE,
    METADATA_KEYS,
    BoneProperties,
    load_material_library,
    load_reference_values,
    stiffness_and_strength,
)

__all__ = [
    "DATA_DIR",
    "FORMULATIONS",
    "MATERIALS_FILE",
    "METADATA_KEYS",
    "BoneProperties",
    "Isotropic",
    "Material",
    "MaterialError",
    "MaterialFields",
    "Orthotropic",
    "TransverselyIsotropic",
    "deviatoric_block",
    "load_material_library",
    "load_reference_values",
    "material_fields",
    "plane_strain_block",
    "stiffness_and_strength",
    "voigt_rotation",
]
