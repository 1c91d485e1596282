"""Strength and toughness tables of the material library (materials.library accessors used
by the fracture checks): published values, sources, and missing values named."""

import dolfinx_solver  # noqa: F401  (must precede dolfinx / petsc4py)

import pytest

from bonecontact.materials.library import (
    STRENGTH_KEYS,
    load_material_library,
    load_reference_values,
    load_strengths,
    material_strength,
)


def test_tables_name_library_materials_and_cite_sources():
    strengths, materials = load_strengths(), load_material_library()
    assert {"cortical_bone", "cancellous_bone_vertebral"} <= set(strengths)
    for name, table in strengths.items():
        assert name in materials
        assert set(table) - {"source", "notes"} <= set(STRENGTH_KEYS)
        assert len(table["source"]) > 10


def test_published_values():
    cortical = material_strength("cortical_bone")
    ref = load_reference_values()
    assert cortical["sigma_t"] == ref["cortical_strength"]["tension_longitudinal"]  # 133 MPa
    assert cortical["sigma_c"] == ref["cortical_strength"]["compression_longitudinal"]
    tough = ref["cortical_fracture_toughness"]
    assert tough["K_Ic_min"] <= cortical["K_Ic"] <= tough["K_Ic_max"]
    assert material_strength("cancellous_bone_vertebral", ("sigma_t", "sigma_c")) == {
        "sigma_t": 1.75e6,
        "sigma_c": 1.92e6,
    }


def test_missing_values_are_named():
    with pytest.raises(KeyError, match=r"cancellous_bone_vertebral\.K_Ic"):
        material_strength("cancellous_bone_vertebral")
    with pytest.raises(KeyError, match=r"materials\.toml: strength\.cartilage\.sigma_t: missing"):
        material_strength("cartilage", ("sigma_t",))
