"""Plausibility checks of scene values (unit slips): materials, mesh size, load strains.

The references are the slips themselves: a value written in the wrong unit is off by an
exact power of 10³ from its plausible range, and the suggested reading must be the value
that lies in the range; the shipped scenes and the material library (published values)
must give no finding.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from bonecontact.materials.library import load_material_library, load_strengths
from bonecontact.scene import SceneError, load_scene
from bonecontact.scene.checks import (
    LOAD_STRAIN_LIMIT,
    MESH_SIZE_RANGE,
    MODULUS_FLOOR,
    PlausibilityWarning,
    check_load_strains,
    check_material_ranges,
    check_mesh_scale,
    check_plausibility,
    emit,
    implausible_allowed,
    load_plausibility_ranges,
    material_class,
    unit_slip_hint,
)

ROOT = Path(__file__).resolve().parents[3]
SCENES = ROOT / "data" / "scenes"
KNEE = (SCENES / "knee2d.toml").read_text()
#: the knee mesh's bounding box (m) and the materials next to its loaded boundaries
KNEE_EXTENT = (0.068, 0.11)
KNEE_ADJACENT = {"femur_top": ("cancellous", "cortical")}


def _knee(tmp_path: Path, *edits: tuple[str, str]):
    text = KNEE.replace('mesh = "knee2d.msh"', f'mesh = "{SCENES / "knee2d.msh"}"')
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    path = tmp_path / "knee.toml"
    path.write_text(text)
    return load_scene(path)


def _messages(issues) -> str:
    return "\n".join(str(i) for i in issues)


@pytest.mark.parametrize(
    "name", ["knee2d", "knee2d_gait", "knee2d_tumour", "long_bone", "cyst_radicular"]
)
def test_shipped_scenes_give_no_material_finding(name):
    assert check_material_ranges(load_scene(SCENES / f"{name}.toml")) == []


def test_shipped_knee_on_its_mesh_gives_no_finding(tmp_path):
    assert check_plausibility(_knee(tmp_path), KNEE_EXTENT, KNEE_ADJACENT) == []


def test_library_materials_lie_in_their_class():
    """Every published value of data/materials.toml is inside the range of its class."""
    classes, default = load_plausibility_ranges()
    found = 0
    for name, entry in load_material_library().items():
        cls = next((c for c in classes if any(w in name for w in c.keywords)), default)
        for key, value in entry.items():
            if key in ("E", "E_p", "E_a", "E1", "E2", "E3", "G_pa", "G12", "G13", "G23"):
                assert cls.modulus[0] <= value <= cls.modulus[1], (name, key, value)
                found += 1
            elif key == "rho":
                assert cls.rho[0] <= value <= cls.rho[1], (name, key, value)
                found += 1
    assert found >= 20


def test_library_strengths_lie_in_their_class():
    classes, default = load_plausibility_ranges()
    found = 0
    for name, entry in load_strengths().items():
        cls = next((c for c in classes if any(w in name for w in c.keywords)), default)
        for key in ("sigma_t", "sigma_c"):
            if key in entry:
                assert cls.strength[0] <= entry[key] <= cls.strength[1], (name, key)
                found += 1
    assert found >= 4


def test_strength_in_mpa_written_as_pa():
    classes, _ = load_plausibility_ranges()
    cortical = next(c for c in classes if c.name == "cortical_bone")
    assert unit_slip_hint(133.0, *cortical.strength, "Pa") == "did you mean 133 MPa?"


def test_modulus_in_gpa_written_as_pa(tmp_path):
    """E = 17 (GPa meant) on the cortical bone: 'E = 17 Pa: did you mean 17 GPa?'."""
    scene = _knee(tmp_path, ("E = 17.0e9", "E = 17.0"))
    issues = check_material_ranges(scene)
    assert len(issues) == 1
    text = str(issues[0])
    assert '[[material]] #1 "cortical"' in text
    assert "E = 17 Pa: did you mean 17 GPa?" in text


def test_both_moduli_in_pa(tmp_path):
    """Cortical 17 and cancellous 1 (GPa meant): both named, and the load's strain estimate
    (0.29 MPa on E = 1 Pa) is flagged before solving."""
    scene = _knee(tmp_path, ("E = 17.0e9", "E = 17.0"), ("E = 1.0e9", "E = 1.0"))
    issues = check_plausibility(scene, KNEE_EXTENT, KNEE_ADJACENT)
    text = _messages(issues)
    assert "did you mean 17 GPa?" in text
    assert re.search(r'"cancellous" E: E = 1 Pa: did you mean 1 GPa\?', text)
    strain = [i for i in issues if i.table == "[[traction]] #1"]
    assert len(strain) == 1
    value = float(re.search(r"strain is ([0-9.e+]+)", strain[0].message).group(1))
    assert value == pytest.approx(2.9167e5 / 1.0, rel=1e-3)  # |t| / softest E next to femur_top


def test_density_in_g_per_cm3(tmp_path):
    scene = _knee(tmp_path, ("E = 17.0e9\nnu = 0.3", "E = 17.0e9\nnu = 0.3\nrho = 1.9"))
    (issue,) = check_material_ranges(scene)
    assert issue.key == "rho"
    assert "did you mean 1.9 g/cm³ (1900 kg/m³)?" in issue.message


def test_modulus_in_mpa_too_large(tmp_path):
    """E = 17e12 (17e9 written in 'MPa' by mistake): the value 10⁶ too large is suggested."""
    scene = _knee(tmp_path, ("E = 17.0e9", "E = 17.0e15"))
    (issue,) = check_material_ranges(scene)
    assert "did you mean 1.7e+10 Pa" in issue.message or "17 GPa" in issue.message


def test_mesh_in_millimetres(tmp_path):
    scene = _knee(tmp_path)
    (issue,) = check_mesh_scale(scene, [90.0, 110.0])
    assert issue.table == "[scene]" and issue.key == "mesh"
    assert "is the mesh in millimetres?" in issue.message
    assert "0.11 m" in issue.message  # the size it would have in metres
    assert check_mesh_scale(scene, [0.09, 0.11]) == []
    assert len(check_mesh_scale(scene, [0.5 * MESH_SIZE_RANGE[0]] * 2)) == 1


def test_mesh_in_millimetres_also_flags_prescribed_displacement(tmp_path):
    """A 1 mm displacement written as 1 on a 0.1 m mesh: strain estimate 1 / 0.11."""
    scene = _knee(tmp_path, ("value = [0.0, 0.0]", "value = [0.0, -1.0]"))
    issues = check_load_strains(scene, KNEE_EXTENT, KNEE_ADJACENT)
    (issue,) = [i for i in issues if i.table == "[[dirichlet]] #1"]
    value = float(re.search(r"strain is ([0-9.e+]+)", issue.message).group(1))
    assert value == pytest.approx(1.0 / 0.11, rel=1e-3)


def test_strain_estimate_threshold(tmp_path):
    """Traction 0.29 MPa: E such that |t|/E is just above / below the limit."""
    t = 2.9167e5
    above = t / (1.01 * LOAD_STRAIN_LIMIT)
    below = t / (0.99 * LOAD_STRAIN_LIMIT)
    for E, n in ((above, 1), (below, 0)):
        scene = _knee(tmp_path, ("E = 1.0e9", f"E = {E!r}"))
        issues = check_load_strains(scene, KNEE_EXTENT, KNEE_ADJACENT)
        assert len(issues) == n


def test_unit_slip_hint_prefixes():
    assert unit_slip_hint(17.0, 3e9, 30e9, "Pa") == "did you mean 17 GPa?"
    assert unit_slip_hint(17.0, 1e3, 30e9, "Pa") == "did you mean 17 kPa or 17 MPa or 17 GPa?"
    assert unit_slip_hint(1e-30, 3e9, 30e9, "Pa") == ""
    assert unit_slip_hint(1.1, 900.0, 1300.0, "kg/m³").startswith("did you mean 1.1 g/cm³")
    assert "17 GPa" not in unit_slip_hint(1.7e13, 3e9, 30e9, "Pa")
    assert "17000 Pa" not in unit_slip_hint(1.7e13, 3e9, 30e9, "Pa")
    assert unit_slip_hint(1.7e13, 3e9, 30e9, "Pa").startswith("did you mean 1.7e+10 Pa")


def test_material_class_by_name_then_region(tmp_path):
    classes, default = load_plausibility_ranges()
    scene = _knee(tmp_path)
    names = {m.name: material_class(m, classes, default).name for m in scene.materials}
    assert names == {
        "cortical": "cortical_bone",
        "cancellous": "cancellous_bone",
        "cartilage": "cartilage",
    }
    assert math.isclose(default.modulus[1], 450e9)


@pytest.mark.parametrize(
    "name, E, finding, certain",
    [
        ("cartilage", "17.0", True, True),  # GPa (or MPa) meant
        ("cartilage", "999.0", True, True),  # just below the floor, below the class
        ("cartilage", "1001.0", True, False),  # just above the floor: only doubtful
        ("soft", "500.0", True, True),  # inside the soft-tissue range, below the floor
        ("soft", "2000.0", False, False),  # a soft tissue: plausible
        ("cartilage", "10.0e6", False, False),  # the shipped value
        ("cartilage", "10.0e15", True, False),  # too large: a slip, but only warned
    ],
)
def test_modulus_below_the_floor_is_beyond_doubt(tmp_path, name, E, finding, certain):
    """A modulus below 1 kPa is a slip beyond doubt whatever its class; other findings only
    warn."""
    scene = _knee(tmp_path, ('name = "cartilage"', f'name = "{name}"'), ("E = 10.0e6", f"E = {E}"))
    issues = [i for i in check_material_ranges(scene) if i.table.startswith("[[material]] #3")]
    assert len(issues) == finding
    assert [i.certain for i in issues] == ([certain] if finding else [])
    if certain and float(E) > 100.0:  # inside the [any] envelope: the floor's own message
        assert f"below {MODULUS_FLOOR / 1e3:g} kPa" in issues[0].message or "did you mean" in (
            issues[0].message
        )


@pytest.mark.parametrize(
    "size, certain", [(20.0, True), (2.5, True), (1.9, None), (0.11, None), (5.0e-5, True)]
)
def test_mesh_size_beyond_doubt(tmp_path, size, certain):
    """Larger than 2 m or smaller than 0.1 mm: a slip beyond doubt (no finding between)."""
    issues = check_mesh_scale(_knee(tmp_path), [size, 0.5 * size])
    assert [i.certain for i in issues] == ([] if certain is None else [certain])


@pytest.mark.parametrize("allowed", [False, True])
def test_emit_refuses_a_certain_slip_unless_allowed(tmp_path, allowed):
    """Certain: a SceneError naming the file, table and key (unless allowed: a warning);
    a doubtful finding alone: a warning."""
    scene = _knee(tmp_path, ("E = 17.0e9", "E = 17.0"))
    issues = check_material_ranges(scene)
    with implausible_allowed(allowed), pytest.warns(PlausibilityWarning) as caught:
        if not allowed:
            with pytest.raises(SceneError) as err:
                emit(issues, scene.path)
            assert (err.value.table, err.value.key) == ('[[material]] #1 "cortical"', "E")
            assert str(scene.path) in str(err.value) and "--allow-implausible" in str(err.value)
            emit([], scene.path)
            _emit_doubtful(scene, tmp_path)
        else:
            emit(issues, scene.path)
    assert len(caught) == 1 and "did you mean" in str(caught[0].message)


def _emit_doubtful(scene, tmp_path) -> None:
    """A doubtful finding (cortical E in MPa range) is emitted as a warning."""
    doubtful = check_material_ranges(_knee(tmp_path, ("E = 17.0e9", "E = 17.0e6")))
    assert [i.certain for i in doubtful] == [False]
    emit(doubtful, scene.path)
