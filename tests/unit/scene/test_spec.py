"""Tests of bonecontact.scene.spec: one case per validation rule, the full example,
schedules and the checks against the mesh.

Pure Python (no DOLFINx objects): also runs under
``mpiexec -n 2 python -m mpi4py -m pytest tests/unit/scene/test_spec.py`` (each rank writes
its own files under its own ``tmp_path``).
"""

from __future__ import annotations

import copy
import json
import math
import pickle
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bonecontact.materials.laws import Isotropic, Orthotropic, TransverselyIsotropic
from bonecontact.scene import (
    Analysis,
    ContactSpec,
    DirichletSpec,
    InitialVelocitySpec,
    LoadSpec,
    SceneError,
    Schedule,
    SolverOptions,
    check_against_mesh,
    default_solver_options,
    format_error,
    load_scene,
)

# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(v)


def dumps(doc: dict[str, Any]) -> str:
    """Minimal TOML writer for the test documents (tables one level deep)."""
    lines: list[str] = []
    for k, v in doc.items():
        if not isinstance(v, dict) and not (
            isinstance(v, list) and v and all(isinstance(x, dict) for x in v)
        ):
            lines.append(f"{k} = {_toml_value(v)}")
    for k, v in doc.items():
        if isinstance(v, dict):
            lines.append(f"\n[{k}]")
            lines += [f"{kk} = {_toml_value(vv)}" for kk, vv in v.items()]
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for entry in v:
                lines.append(f"\n[[{k}]]")
                lines += [f"{kk} = {_toml_value(vv)}" for kk, vv in entry.items()]
    return "\n".join(lines) + "\n"


BASE: dict[str, Any] = {
    "format": 1,
    "scene": {"name": "knee", "mesh": "knee.msh", "dimension": 2},
    "analysis": {"kind": "dynamic", "t_end": 1.0, "dt": 0.1},
    "solver": {"linear": "iterative", "tolerance": 1e-8, "max_iterations": 20},
    "material": [
        {
            "name": "cortical",
            "regions": ["upper"],
            "model": "isotropic",
            "E": 17.0e9,
            "nu": 0.3,
            "rho": 1900.0,
            "tau_v": 1e-3,
        },
        {
            "name": "trabecular",
            "regions": ["lower"],
            "model": "transversely_isotropic",
            "E_p": 1.0e9,
            "E_a": 2.0e9,
            "nu_p": 0.3,
            "nu_pa": 0.2,
            "G_pa": 0.5e9,
            "axis": [0.0, 1.0],
            "rho": 1000.0,
        },
        {
            "name": "plate",
            "regions": ["plate"],
            "model": "orthotropic",
            "E1": 10e9,
            "E2": 12e9,
            "E3": 8e9,
            "nu12": 0.3,
            "nu13": 0.25,
            "nu23": 0.2,
            "G12": 4e9,
            "G13": 3e9,
            "G23": 3.5e9,
            "axes": [[0.0, 1.0], [-1.0, 0.0]],
            "rho": 2000.0,
        },
    ],
    "contact": [
        {
            "name": "joint",
            "slave": "upper_contact",
            "master": "lower_contact",
            "friction": "coulomb",
            "coefficient": 0.3,
            "coulomb_update": "fixed_point",
            "search_distance": 2e-3,
        }
    ],
    "dirichlet": [
        {"boundary": "bottom", "value": [0.0, 0.0]},
        {"boundary": "side", "value": ["free", 1e-3], "schedule": [[0.0, 0.0], [1.0, 1.0]]},
    ],
    "traction": [{"boundary": "top", "value": [0.0, -1.0e6], "ramp": 0.5}],
    "pressure": [{"boundary": "cyst_wall", "value": 6.5e3}],
    "body_force": [{"regions": ["upper"], "value": [0.0, -9.81e3]}],
    "initial_velocity": [{"regions": ["upper"], "value": [0.0, -1.0]}],
    "output": {"directory": "out", "fields_every": 2, "probes": [[0.01, 0.02]]},
}

#: physical groups of the fake mesh matching BASE: name -> (dim, tag)
GROUPS: dict[str, tuple[int, int]] = {
    "upper": (2, 1),
    "lower": (2, 2),
    "plate": (2, 3),
    "upper_contact": (1, 10),
    "lower_contact": (1, 11),
    "bottom": (1, 12),
    "side": (1, 13),
    "top": (1, 14),
    "cyst_wall": (1, 15),
    "origin": (0, 20),
}


def write(tmp_path: Path, doc: dict[str, Any] | str, name: str = "scene.toml") -> Path:
    (tmp_path / "knee.msh").write_text("$MeshFormat\n$EndMeshFormat\n")
    path = tmp_path / name
    path.write_text(doc if isinstance(doc, str) else dumps(doc))
    return path


def base_scene(tmp_path: Path, **kw: Any):
    return load_scene(
        write(tmp_path, copy.deepcopy(BASE)), allow_contact=True, allow_friction=True, **kw
    )


def expect_error(
    path: Path,
    key: str | None,
    table: str | None,
    *,
    allow_contact: bool = True,
    contains: str = "",
) -> SceneError:
    with pytest.raises(SceneError) as info:
        load_scene(path, allow_contact=allow_contact, allow_friction=True)
    exc = info.value
    text = str(exc)
    assert exc.file == str(path)
    assert text.startswith(str(path) + ": ")
    assert exc.key == key, text
    if key is not None:
        assert f'key "{key}"' in text
    if table is not None:
        assert exc.table is not None and table in exc.table, text
        assert table in text
    assert contains in text, text
    assert "\n" not in text
    return exc


# --------------------------------------------------------------------------------------
# one case per validation rule of load_scene
# --------------------------------------------------------------------------------------
# (id, operations, offending key, table substring, substring of the message)
# operations: ("set", path, value) or ("del", path); path = tuple of keys/indices
CASES: list[tuple[str, list[tuple], str | None, str | None, str]] = [
    # format and top level
    ("format-missing", [("del", ("format",))], "format", None, "missing required key"),
    ("format-version", [("set", ("format",), 2)], "format", None, "format 1"),
    ("format-string", [("set", ("format",), "1")], "format", None, "integer 1"),
    ("format-bool", [("set", ("format",), True)], "format", None, "boolean"),
    (
        "unknown-top-level-key",
        [("set", ("colour",), "red")],
        "colour",
        None,
        "allowed: format, scene",
    ),
    (
        "fracture-unknown-key",
        [("set", ("fracture",), {"kind": "brittle"})],
        "kind",
        "[fracture]",
        "unknown key",
    ),
    ("scene-table-missing", [("del", ("scene",))], None, "[scene]", "missing required table"),
    ("scene-not-a-table", [("set", ("scene",), 3)], "scene", None, "must be a table"),
    (
        "material-not-array-of-tables",
        [("set", ("material",), {"name": "x"})],
        "material",
        None,
        "[[material]]",
    ),
    # [scene]
    (
        "scene-unknown-key",
        [("set", ("scene", "units"), "mm")],
        "units",
        "[scene]",
        "allowed: name, mesh, dimension",
    ),
    ("scene-mesh-missing", [("del", ("scene", "mesh"))], "mesh", "[scene]", "missing required key"),
    ("scene-mesh-type", [("set", ("scene", "mesh"), 3)], "mesh", "[scene]", "must be a string"),
    (
        "scene-mesh-not-found",
        [("set", ("scene", "mesh"), "nowhere.msh")],
        "mesh",
        "[scene]",
        "not found",
    ),
    (
        "scene-name-type",
        [("set", ("scene", "name"), ["knee"])],
        "name",
        "[scene]",
        "must be a string",
    ),
    ("scene-name-empty", [("set", ("scene", "name"), " ")], "name", "[scene]", "non-empty"),
    (
        "scene-dimension-missing",
        [("del", ("scene", "dimension"))],
        "dimension",
        "[scene]",
        "missing",
    ),
    (
        "scene-dimension-value",
        [("set", ("scene", "dimension"), 4)],
        "dimension",
        "[scene]",
        "2 (plane strain) or 3",
    ),
    (
        "scene-dimension-float",
        [("set", ("scene", "dimension"), 2.0)],
        "dimension",
        "[scene]",
        "integer",
    ),
    # [analysis]
    ("analysis-missing", [("del", ("analysis",))], None, "[analysis]", "missing required table"),
    (
        "analysis-unknown-key",
        [("set", ("analysis", "steps"), 3)],
        "steps",
        "[analysis]",
        "allowed: kind, t_end",
    ),
    ("analysis-kind-missing", [("del", ("analysis", "kind"))], "kind", "[analysis]", "missing"),
    (
        "analysis-kind-value",
        [("set", ("analysis", "kind"), "transient")],
        "kind",
        "[analysis]",
        '"static", "quasistatic", "dynamic"',
    ),
    (
        "analysis-t_end-required-dynamic",
        [("del", ("analysis", "t_end"))],
        "t_end",
        "[analysis]",
        "missing",
    ),
    (
        "analysis-dt-required-quasistatic",
        [("set", ("analysis", "kind"), "quasistatic"), ("del", ("analysis", "dt"))],
        "dt",
        "[analysis]",
        "missing",
    ),
    (
        "analysis-t_end-positive",
        [("set", ("analysis", "t_end"), 0.0)],
        "t_end",
        "[analysis]",
        "> 0",
    ),
    ("analysis-dt-positive", [("set", ("analysis", "dt"), -0.1)], "dt", "[analysis]", "> 0"),
    ("analysis-dt-le-t_end", [("set", ("analysis", "dt"), 2.0)], "dt", "[analysis]", "<= t_end"),
    (
        "analysis-allow_large_strain-string",
        [("set", ("analysis", "allow_large_strain"), "yes")],
        "allow_large_strain",
        "[analysis]",
        'must be true or false, got string "yes"',
    ),
    (
        "analysis-allow_large_strain-integer",
        [("set", ("analysis", "allow_large_strain"), 1)],
        "allow_large_strain",
        "[analysis]",
        "must be true or false, got integer 1",
    ),
    (
        "analysis-t_end-bool",
        [("set", ("analysis", "t_end"), True)],
        "t_end",
        "[analysis]",
        "boolean",
    ),
    (
        "analysis-t_end-string",
        [("set", ("analysis", "t_end"), "1 s")],
        "t_end",
        "[analysis]",
        "must be a number",
    ),
    (
        "analysis-t_end-inf",
        [("set", ("analysis", "t_end"), math.inf)],
        "t_end",
        "[analysis]",
        "finite",
    ),
    ("analysis-dt-nan", [("set", ("analysis", "dt"), math.nan)], "dt", "[analysis]", "finite"),
    (
        "analysis-load_steps-zero",
        [("set", ("analysis", "load_steps"), 0)],
        "load_steps",
        "[analysis]",
        ">= 1",
    ),
    (
        "analysis-load_steps-float",
        [("set", ("analysis", "load_steps"), 2.5)],
        "load_steps",
        "[analysis]",
        "integer",
    ),
    (
        "analysis-load_steps-bool",
        [("set", ("analysis", "load_steps"), True)],
        "load_steps",
        "[analysis]",
        "integer",
    ),
    (
        "analysis-static-t_end-positive",
        [("set", ("analysis", "kind"), "static"), ("set", ("analysis", "t_end"), -1.0)],
        "t_end",
        "[analysis]",
        "> 0",
    ),
    # [solver]
    (
        "solver-unknown-key",
        [("set", ("solver", "preconditioner"), "ilu")],
        "preconditioner",
        "[solver]",
        "allowed: linear, tolerance, max_iterations, multigrid",
    ),
    (
        "solver-multigrid-value",
        [("set", ("solver", "multigrid"), "ml")],
        "multigrid",
        "[solver]",
        '"gamg", "compressed"',
    ),
    (
        "solver-multigrid-type",
        [("set", ("solver", "multigrid"), 2)],
        "multigrid",
        "[solver]",
        "string",
    ),
    (
        "solver-linear-value",
        [("set", ("solver", "linear"), "lu")],
        "linear",
        "[solver]",
        '"direct", "iterative"',
    ),
    (
        "solver-tolerance-positive",
        [("set", ("solver", "tolerance"), 0)],
        "tolerance",
        "[solver]",
        "> 0",
    ),
    (
        "solver-tolerance-type",
        [("set", ("solver", "tolerance"), "tight")],
        "tolerance",
        "[solver]",
        "number",
    ),
    (
        "solver-max_iterations-min",
        [("set", ("solver", "max_iterations"), 0)],
        "max_iterations",
        "[solver]",
        ">= 1",
    ),
    (
        "solver-max_iterations-float",
        [("set", ("solver", "max_iterations"), 10.0)],
        "max_iterations",
        "[solver]",
        "integer",
    ),
    # [[material]]
    ("material-none", [("del", ("material",))], None, "[[material]]", "at least one material"),
    (
        "material-empty-array",
        [("set", ("material",), [])],
        None,
        "[[material]]",
        "at least one material",
    ),
    (
        "material-name-missing",
        [("del", ("material", 1, "name"))],
        "name",
        "[[material]] #2",
        "missing",
    ),
    (
        "material-name-duplicate",
        [("set", ("material", 1, "name"), "cortical")],
        "name",
        '[[material]] #2 "cortical"',
        "already used",
    ),
    (
        "material-regions-missing",
        [("del", ("material", 0, "regions"))],
        "regions",
        '[[material]] #1 "cortical"',
        "missing",
    ),
    (
        "material-regions-empty",
        [("set", ("material", 0, "regions"), [])],
        "regions",
        "[[material]] #1",
        "at least one",
    ),
    (
        "material-regions-string",
        [("set", ("material", 0, "regions"), "upper")],
        "regions",
        "[[material]] #1",
        'regions = ["upper"]',
    ),
    (
        "material-regions-entry-type",
        [("set", ("material", 0, "regions"), ["upper", 3])],
        "regions",
        "[[material]] #1",
        "integer 3",
    ),
    (
        "material-region-repeated",
        [("set", ("material", 0, "regions"), ["upper", "upper"])],
        "regions",
        "[[material]] #1",
        "listed twice",
    ),
    (
        "material-region-two-materials",
        [("set", ("material", 2, "regions"), ["plate", "lower"])],
        "regions",
        '[[material]] #3 "plate"',
        'already claimed by material "trabecular"',
    ),
    (
        "material-model-missing",
        [("del", ("material", 0, "model"))],
        "model",
        "[[material]] #1",
        "missing",
    ),
    (
        "material-model-value",
        [("set", ("material", 0, "model"), "anisotropic")],
        "model",
        "[[material]] #1",
        '"isotropic", "transversely_isotropic", "orthotropic"',
    ),
    (
        "material-isotropic-E-missing",
        [("del", ("material", 0, "E"))],
        "E",
        "[[material]] #1",
        "missing",
    ),
    (
        "material-key-of-other-model",
        [("set", ("material", 0, "E1"), 1e9)],
        "E1",
        '[[material]] #1 "cortical"',
        "allowed: name, regions, model, rho, tau_v, formulation, E, nu",
    ),
    (
        "material-nu-0.5",
        [("set", ("material", 0, "nu"), 0.5)],
        "nu",
        '[[material]] #1 "cortical"',
        "-1 < nu < 0.5, got 0.5",
    ),
    (
        "material-nu-minus-1",
        [("set", ("material", 0, "nu"), -1)],
        "nu",
        "[[material]] #1",
        "-1 < nu < 0.5",
    ),
    (
        "material-E-nonpositive",
        [("set", ("material", 0, "E"), 0.0)],
        "E",
        "[[material]] #1",
        "positive",
    ),
    ("material-E-bool", [("set", ("material", 0, "E"), True)], "E", "[[material]] #1", "boolean"),
    (
        "material-ti-axis-missing",
        [("del", ("material", 1, "axis"))],
        "axis",
        "[[material]] #2",
        "missing",
    ),
    (
        "material-ti-axis-length",
        [("set", ("material", 1, "axis"), [0.0, 0.0, 1.0])],
        "axis",
        "[[material]] #2",
        "2 components",
    ),
    (
        "material-ti-not-positive-definite",
        [("set", ("material", 1, "nu_pa"), 2.0)],
        "nu_pa",
        "[[material]] #2",
        "positive definite",
    ),
    (
        "material-ti-nu_p-range",
        [("set", ("material", 1, "nu_p"), -1.0)],
        "nu_p",
        "[[material]] #2",
        "-1 < nu_p < 1",
    ),
    (
        "material-ti-G_pa-positive",
        [("set", ("material", 1, "G_pa"), -5.0)],
        "G_pa",
        "[[material]] #2",
        "positive",
    ),
    (
        "material-ortho-G23-missing",
        [("del", ("material", 2, "G23"))],
        "G23",
        "[[material]] #3",
        "missing",
    ),
    (
        "material-ortho-axes-shape",
        [("set", ("material", 2, "axes"), [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])],
        "axes",
        "[[material]] #3",
        "2 material axes",
    ),
    (
        "material-ortho-axes-row-length",
        [("set", ("material", 2, "axes"), [[1.0, 0.0], [0.0, 1.0, 0.0]])],
        "axes",
        "[[material]] #3",
        "row 2",
    ),
    (
        "material-ortho-axes-not-orthonormal",
        [("set", ("material", 2, "axes"), [[1.0, 0.0], [1.0, 1.0]])],
        "axes",
        "[[material]] #3",
        "orthonormal",
    ),
    (
        "material-ortho-not-positive-definite",
        [("set", ("material", 2, "nu12"), 1.5)],
        "nu12",
        "[[material]] #3",
        "positive definite",
    ),
    (
        "material-rho-required-dynamic",
        [("del", ("material", 1, "rho"))],
        "rho",
        '[[material]] #2 "trabecular"',
        "missing",
    ),
    (
        "material-rho-positive",
        [("set", ("material", 0, "rho"), -1.0)],
        "rho",
        "[[material]] #1",
        "positive",
    ),
    (
        "material-tau_v-nonnegative",
        [("set", ("material", 0, "tau_v"), -0.1)],
        "tau_v",
        "[[material]] #1",
        ">= 0",
    ),
    (
        "material-formulation-value",
        [("set", ("material", 0, "formulation"), "mixed")],
        "formulation",
        "[[material]] #1",
        '"displacement", "nodal_pressure"',
    ),
    (
        "material-formulation-anisotropic",
        [("set", ("material", 1, "formulation"), "nodal_pressure")],
        "formulation",
        "[[material]] #2",
        "only isotropic",
    ),
    # [[contact]]
    (
        "contact-unknown-key",
        [("set", ("contact", 0, "penalty"), 1e9)],
        "penalty",
        '[[contact]] #1 "joint"',
        "allowed: name, slave, master",
    ),
    (
        "contact-name-missing",
        [("del", ("contact", 0, "name"))],
        "name",
        "[[contact]] #1",
        "missing",
    ),
    (
        "contact-name-characters",
        [("set", ("contact", 0, "name"), "knee joint")],
        "name",
        "[[contact]] #1",
        "output files",
    ),
    (
        "contact-name-duplicate",
        [("set", ("contact",), [BASE["contact"][0], BASE["contact"][0]])],
        "name",
        "[[contact]] #2",
        "already used",
    ),
    (
        "contact-slave-missing",
        [("del", ("contact", 0, "slave"))],
        "slave",
        "[[contact]] #1",
        "missing",
    ),
    (
        "contact-master-type",
        [("set", ("contact", 0, "master"), ["lower_contact"])],
        "master",
        "[[contact]] #1",
        "must be a string",
    ),
    (
        "contact-slave-equals-master",
        [("set", ("contact", 0, "master"), "upper_contact")],
        "master",
        "[[contact]] #1",
        "must differ from slave",
    ),
    (
        "contact-friction-value",
        [("set", ("contact", 0, "friction"), "viscous")],
        "friction",
        "[[contact]] #1",
        '"none", "tresca", "coulomb"',
    ),
    (
        "contact-coefficient-negative",
        [("set", ("contact", 0, "coefficient"), -0.1)],
        "coefficient",
        "[[contact]] #1",
        ">= 0",
    ),
    (
        "contact-bound-negative",
        [("set", ("contact", 0, "bound"), -1.0)],
        "bound",
        "[[contact]] #1",
        ">= 0",
    ),
    (
        "contact-search_distance-zero",
        [("set", ("contact", 0, "search_distance"), 0.0)],
        "search_distance",
        "[[contact]] #1",
        "> 0",
    ),
    (
        "contact-coulomb_update-value",
        [("set", ("contact", 0, "coulomb_update"), "implicit")],
        "coulomb_update",
        "[[contact]] #1",
        '"previous_step", "fixed_point"',
    ),
    # [[dirichlet]]
    (
        "dirichlet-unknown-key",
        [("set", ("dirichlet", 0, "components"), [0])],
        "components",
        "[[dirichlet]] #1",
        "allowed: boundary, value, ramp, schedule",
    ),
    (
        "dirichlet-boundary-missing",
        [("del", ("dirichlet", 0, "boundary"))],
        "boundary",
        "[[dirichlet]] #1",
        "missing",
    ),
    (
        "dirichlet-value-missing",
        [("del", ("dirichlet", 0, "value"))],
        "value",
        "[[dirichlet]] #1",
        "missing",
    ),
    (
        "dirichlet-value-length",
        [("set", ("dirichlet", 0, "value"), [0.0, 0.0, 0.0])],
        "value",
        "[[dirichlet]] #1",
        "2 entries",
    ),
    (
        "dirichlet-value-scalar",
        [("set", ("dirichlet", 0, "value"), 0.0)],
        "value",
        "[[dirichlet]] #1",
        "array of 2 entries",
    ),
    (
        "dirichlet-value-other-string",
        [("set", ("dirichlet", 0, "value"), ["fixed", 0.0])],
        "value",
        "[[dirichlet]] #1",
        '"free"',
    ),
    (
        "dirichlet-value-bool",
        [("set", ("dirichlet", 0, "value"), [False, 0.0])],
        "value",
        "[[dirichlet]] #1",
        "boolean",
    ),
    (
        "dirichlet-value-all-free",
        [("set", ("dirichlet", 0, "value"), ["free", "free"])],
        "value",
        "[[dirichlet]] #1",
        "all components",
    ),
    # loads
    (
        "traction-unknown-key",
        [("set", ("traction", 0, "direction"), [0.0, 1.0])],
        "direction",
        "[[traction]] #1",
        "allowed: boundary, value, ramp, schedule",
    ),
    (
        "traction-boundary-missing",
        [("del", ("traction", 0, "boundary"))],
        "boundary",
        "[[traction]] #1",
        "missing",
    ),
    (
        "traction-value-length",
        [("set", ("traction", 0, "value"), [1.0])],
        "value",
        "[[traction]] #1",
        "2 components",
    ),
    (
        "traction-value-entry-type",
        [("set", ("traction", 0, "value"), [1.0, "x"])],
        "value",
        "[[traction]] #1",
        "must be a number",
    ),
    (
        "pressure-value-array",
        [("set", ("pressure", 0, "value"), [1.0, 2.0])],
        "value",
        "[[pressure]] #1",
        "single number",
    ),
    (
        "pressure-value-missing",
        [("del", ("pressure", 0, "value"))],
        "value",
        "[[pressure]] #1",
        "missing",
    ),
    (
        "body_force-regions-missing",
        [("del", ("body_force", 0, "regions"))],
        "regions",
        "[[body_force]] #1",
        "missing",
    ),
    (
        "body_force-value-length",
        [("set", ("body_force", 0, "value"), [0.0, 1.0, 2.0])],
        "value",
        "[[body_force]] #1",
        "2 components",
    ),
    (
        "body_force-boundary-key",
        [("set", ("body_force", 0, "boundary"), "top")],
        "boundary",
        "[[body_force]] #1",
        "allowed: regions, value",
    ),
    # ramp / schedule
    ("ramp-negative", [("set", ("traction", 0, "ramp"), -1.0)], "ramp", "[[traction]] #1", ">= 0"),
    (
        "ramp-string",
        [("set", ("traction", 0, "ramp"), "slow")],
        "ramp",
        "[[traction]] #1",
        "must be a number",
    ),
    (
        "ramp-and-schedule",
        [("set", ("traction", 0, "schedule"), [[0.0, 0.0], [1.0, 1.0]])],
        "schedule",
        "[[traction]] #1",
        "not both",
    ),
    (
        "schedule-empty",
        [("set", ("pressure", 0, "schedule"), [])],
        "schedule",
        "[[pressure]] #1",
        "non-empty",
    ),
    (
        "schedule-not-increasing",
        [("set", ("dirichlet", 1, "schedule"), [[0.0, 0.0], [1.0, 1.0], [1.0, 2.0]])],
        "schedule",
        "[[dirichlet]] #2",
        "strictly increasing",
    ),
    (
        "schedule-pair-length",
        [("set", ("body_force", 0, "schedule"), [[0.0, 0.0, 1.0]])],
        "schedule",
        "[[body_force]] #1",
        "[time, factor] pair",
    ),
    (
        "schedule-flat",
        [("set", ("pressure", 0, "schedule"), [0.0, 1.0])],
        "schedule",
        "[[pressure]] #1",
        "[time, factor] pair",
    ),
    (
        "schedule-factor-type",
        [("set", ("pressure", 0, "schedule"), [[0.0, "full"]])],
        "schedule",
        "[[pressure]] #1",
        "factor must be a number",
    ),
    # [[initial_velocity]]
    (
        "initial_velocity-unknown-key",
        [("set", ("initial_velocity", 0, "ramp"), 1.0)],
        "ramp",
        "[[initial_velocity]] #1",
        "allowed: regions, value",
    ),
    (
        "initial_velocity-regions-missing",
        [("del", ("initial_velocity", 0, "regions"))],
        "regions",
        "[[initial_velocity]] #1",
        "missing",
    ),
    (
        "initial_velocity-value-length",
        [("set", ("initial_velocity", 0, "value"), [1.0])],
        "value",
        "[[initial_velocity]] #1",
        "2 components",
    ),
    (
        "initial_velocity-region-twice",
        [("set", ("initial_velocity",), [BASE["initial_velocity"][0]] * 2)],
        "regions",
        "[[initial_velocity]] #2",
        "already has an initial velocity",
    ),
    # [output]
    (
        "output-unknown-key",
        [("set", ("output", "format"), "vtk")],
        "format",
        "[output]",
        "allowed: directory, fields_every, probes",
    ),
    (
        "output-directory-type",
        [("set", ("output", "directory"), 1)],
        "directory",
        "[output]",
        "must be a string",
    ),
    (
        "output-fields_every-negative",
        [("set", ("output", "fields_every"), -1)],
        "fields_every",
        "[output]",
        ">= 0",
    ),
    (
        "output-fields_every-float",
        [("set", ("output", "fields_every"), 1.5)],
        "fields_every",
        "[output]",
        "integer",
    ),
    (
        "output-probes-length",
        [("set", ("output", "probes"), [[0.0, 0.0], [0.1, 0.2, 0.3]])],
        "probes",
        "[output]",
        "point 2 must have 2 components",
    ),
    (
        "output-probes-flat",
        [("set", ("output", "probes"), [0.01, 0.02])],
        "probes",
        "[output]",
        "array of points",
    ),
]


def _apply(doc: dict[str, Any], ops: list[tuple]) -> dict[str, Any]:
    doc = copy.deepcopy(doc)
    for op in ops:
        *parents, last = op[1]
        node: Any = doc
        for k in parents:
            node = node[k]
        if op[0] == "set":
            node[last] = copy.deepcopy(op[2])
        else:
            del node[last]
    return doc


@pytest.mark.parametrize(
    "ops, key, table, contains", [c[1:] for c in CASES], ids=[c[0] for c in CASES]
)
def test_rule(tmp_path, ops, key, table, contains):
    path = write(tmp_path, _apply(BASE, ops))
    expect_error(path, key, table, contains=contains)


def test_base_document_is_valid(tmp_path):
    scene = base_scene(tmp_path)
    assert scene.name == "knee"
    assert scene.path == (tmp_path / "scene.toml").absolute()
    assert scene.mesh_path == (tmp_path / "knee.msh").resolve()
    assert scene.dimension == 2 and scene.neoplasm is None and not scene.growth_only
    assert [(m.name, m.regions) for m in scene.materials] == [
        ("cortical", ("upper",)),
        ("trabecular", ("lower",)),
        ("plate", ("plate",)),
    ]
    cort, trab, plate = (m.material for m in scene.materials)
    assert (cort.E, cort.nu, cort.rho, cort.tau_v) == (17.0e9, 0.3, 1900.0, 1e-3)
    assert (trab.E_p, trab.E_a, trab.nu_p, trab.nu_pa, trab.G_pa, trab.rho) == (
        1.0e9,
        2.0e9,
        0.3,
        0.2,
        0.5e9,
        1000.0,
    )
    assert (
        plate.E1,
        plate.E2,
        plate.E3,
        plate.nu12,
        plate.nu13,
        plate.nu23,
        plate.G12,
        plate.G13,
        plate.G23,
        plate.rho,
    ) == (10e9, 12e9, 8e9, 0.3, 0.25, 0.2, 4e9, 3e9, 3.5e9, 2000.0)
    assert scene.contacts == (
        ContactSpec(
            "joint", "upper_contact", "lower_contact", "coulomb", 0.3, 0.0, "fixed_point", 2e-3
        ),
    )
    assert [(d.boundary, d.value) for d in scene.dirichlet] == [
        ("bottom", (0.0, 0.0)),
        ("side", (None, 1e-3)),
    ]
    assert [(ld.kind, ld.target, ld.value) for ld in scene.loads] == [
        ("traction", ("top",), (0.0, -1.0e6)),
        ("pressure", ("cyst_wall",), 6.5e3),
        ("body_force", ("upper",), (0.0, -9.81e3)),
    ]
    assert scene.initial_velocities == (InitialVelocitySpec(("upper",), (0.0, -1.0)),)
    assert scene.output.probes == ((0.01, 0.02),)
    assert scene.cell_regions == ("upper", "lower", "plate")


def test_malformed_toml_names_line_and_column(tmp_path):
    path = write(tmp_path, 'format = 1\n[scene]\nname = "x"\nmesh = \n')
    exc = expect_error(path, None, None, contains="invalid TOML")
    assert "line 4" in str(exc) and "column" in str(exc)


def test_missing_file(tmp_path):
    path = tmp_path / "absent.toml"
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.file == str(path)
    assert str(path) in str(info.value) and "cannot read" in str(info.value)


def test_contact_not_supported_by_default(tmp_path):
    path = write(tmp_path, copy.deepcopy(BASE))
    exc = expect_error(
        path, None, "[[contact]]", allow_contact=False, contains="contact is not supported yet"
    )
    assert exc.table == "[[contact]]"
    doc = _apply(BASE, [("del", ("contact",))])
    assert load_scene(write(tmp_path, doc, "nocontact.toml")).contacts == ()


def test_message_example_format():
    exc = SceneError(
        "scene.toml", '[[material]] #2 "cortical"', "nu", "must satisfy -1 < nu < 0.5, got 0.5"
    )
    assert (
        str(exc)
        == 'scene.toml: [[material]] #2 "cortical", key "nu": must satisfy -1 < nu < 0.5, got 0.5'
    )
    assert (exc.file, exc.table, exc.key, exc.message) == (
        "scene.toml",
        '[[material]] #2 "cortical"',
        "nu",
        "must satisfy -1 < nu < 0.5, got 0.5",
    )
    assert str(SceneError("a.msh", None, None, "no cells")) == "a.msh: no cells"
    assert str(SceneError(None, "[scene]", None, "x")) == "[scene]: x"
    assert format_error(exc) == "error: " + str(exc)
    assert str(pickle.loads(pickle.dumps(exc))) == str(exc)


def test_int_accepted_where_float_expected(tmp_path):
    doc = _apply(
        BASE,
        [
            ("set", ("material", 0, "E"), 17_000_000_000),
            ("set", ("analysis", "t_end"), 1),
            ("set", ("traction", 0, "value"), [0, -1000000]),
        ],
    )
    scene = load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True)
    assert (
        isinstance(scene.materials[0].material.E, float) and scene.materials[0].material.E == 17e9
    )
    assert scene.analysis.t_end == 1.0
    assert scene.loads[0].value == (0.0, -1e6)


def test_quasistatic_needs_no_rho(tmp_path):
    doc = _apply(
        BASE, [("set", ("analysis", "kind"), "quasistatic"), ("del", ("material", 0, "rho"))]
    )
    scene = load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True)
    assert scene.materials[0].material.rho is None
    assert scene.analysis == Analysis("quasistatic", 1.0, 0.1, 1)
    assert (scene.materials[0].material.E, scene.materials[0].material.tau_v) == (17.0e9, 1e-3)
    assert scene.materials[1].material.rho == 1000.0


# --------------------------------------------------------------------------------------
# the full example of docs/scene_format.md
# --------------------------------------------------------------------------------------
EXAMPLE = """\
format = 1

[scene]
name = "hertz2d"             # used in messages and output names
mesh = "hertz.msh"           # gmsh .msh with NAMED physical groups; path relative to this file
dimension = 2                # 2 = plane strain, 3; must match the mesh

[analysis]
kind = "static"              # "static" | "quasistatic" | "dynamic"
t_end = 1.0                  # quasistatic and dynamic
dt = 0.01                    # quasistatic and dynamic
load_steps = 1               # static: loads ramp linearly over this many increments

[solver]                     # all optional; defaults chosen by the package
linear = "direct"            # "direct" (MUMPS) | "iterative" (Krylov + GAMG)
tolerance = 1e-10            # PDAS / nonlinear stopping tolerance
max_iterations = 50

[[material]]
name = "cortical"
regions = ["upper"]          # cell physical groups
model = "isotropic"          # "isotropic" | "transversely_isotropic" | "orthotropic"
E = 17.0e9
nu = 0.3
rho = 1900.0                 # required for "dynamic"
tau_v = 0.0                  # Kelvin-Voigt relaxation time

[[contact]]
name = "joint"
slave = "upper_contact"      # facet physical group on the slave body
master = "lower_contact"     # facet physical group on the master body
friction = "none"            # "none" | "tresca" | "coulomb"
coefficient = 0.0            # Coulomb coefficient
bound = 0.0                  # Tresca friction bound (Pa)
coulomb_update = "previous_step"   # "previous_step" (semi-implicit) | "fixed_point"

[[dirichlet]]
boundary = "bottom"          # facet physical group
value = [0.0, 0.0]           # one entry per component; the string "free" leaves that component free

[[traction]]
boundary = "top"
value = [0.0, -1.0e6]        # Pa
ramp = 0.0                   # > 0: ramps linearly from 0 over [0, ramp] s (dynamic/quasistatic)
# schedule = [[0.0, 0.0], [1.0, 1.0], [2.0, 1.0]]

[[pressure]]
boundary = "cyst_wall"
value = 6.5e3                # Pa, normal pressure, positive pushes into the body

[[body_force]]
regions = ["upper"]
value = [0.0, -9.81e3]       # N/m^3

[[initial_velocity]]
regions = ["upper"]
value = [0.0, -1.0]          # m/s

[output]
directory = "results"        # relative to the current directory unless absolute
fields_every = 1             # write fields every N steps (0 = last only)
probes = [[0.01, 0.02]]      # optional points (in the reference configuration) sampled every step
"""

EXAMPLE_GROUPS = {
    "upper": (2, 1),
    "upper_contact": (1, 2),
    "lower_contact": (1, 3),
    "bottom": (1, 4),
    "top": (1, 5),
    "cyst_wall": (1, 6),
}


def test_full_example(tmp_path, monkeypatch):
    sub = tmp_path / "scenes"
    sub.mkdir()
    (sub / "hertz.msh").write_text("")
    (sub / "hertz.toml").write_text(EXAMPLE)
    monkeypatch.chdir(tmp_path)
    scene = load_scene(Path("scenes/hertz.toml"), allow_contact=True, allow_friction=True)

    assert scene.path == sub / "hertz.toml"
    assert scene.name == "hertz2d"
    assert scene.mesh_path == (sub / "hertz.msh").resolve()
    assert scene.dimension == 2
    assert scene.analysis == Analysis(kind="static", t_end=1.0, dt=0.01, load_steps=1)
    assert scene.solver == SolverOptions("direct", 1e-10, 50) == default_solver_options()

    (m,) = scene.materials
    assert (m.name, m.regions, m.index) == ("cortical", ("upper",), 0)
    assert isinstance(m.material, Isotropic)
    assert (m.material.E, m.material.nu, m.material.rho, m.material.tau_v) == (
        17e9,
        0.3,
        1900.0,
        0.0,
    )
    assert m.material.formulation == "displacement"

    assert scene.contacts == (
        ContactSpec("joint", "upper_contact", "lower_contact", "none", 0.0, 0.0, "previous_step"),
    )
    static_ramp = Schedule.from_ramp(1.0)  # static default: linear over the load steps
    assert scene.dirichlet == (DirichletSpec("bottom", (0.0, 0.0), static_ramp),)
    assert scene.loads == (
        LoadSpec("traction", ("top",), (0.0, -1.0e6), static_ramp),  # ramp = 0 is the default
        LoadSpec("pressure", ("cyst_wall",), 6.5e3, static_ramp),
        LoadSpec("body_force", ("upper",), (0.0, -9.81e3), static_ramp),
    )
    assert scene.initial_velocities == (InitialVelocitySpec(("upper",), (0.0, -1.0)),)
    assert scene.output.directory == tmp_path / "results"
    assert scene.output.directory.is_absolute()
    assert scene.output.fields_every == 1
    assert scene.output.probes == ((0.01, 0.02),)
    assert scene.raw["scene"]["mesh"] == "hertz.msh"
    assert scene.material_of("upper") is m
    assert scene.analysis.n_steps == 1
    np.testing.assert_allclose(scene.analysis.times(), [1.0])

    check_against_mesh(scene, EXAMPLE_GROUPS, 2, 2)


@pytest.mark.parametrize("multigrid", [None, "gamg", "compressed"])
def test_solver_multigrid_key(tmp_path, multigrid):
    """``[solver] multigrid`` is read as given; absent, the compressed hierarchy."""
    doc = copy.deepcopy(BASE)
    if multigrid is not None:
        doc["solver"]["multigrid"] = multigrid
    scene = load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True)
    assert scene.solver.multigrid == (multigrid or "compressed")
    assert default_solver_options().multigrid == "compressed"


def test_base_document_values(tmp_path):
    scene = base_scene(tmp_path)
    assert scene.analysis == Analysis("dynamic", 1.0, 0.1, 1)
    assert scene.analysis.n_steps == 10
    np.testing.assert_allclose(scene.analysis.times(), np.arange(1, 11) * 0.1)
    assert scene.solver == SolverOptions("iterative", 1e-8, 20)
    cort, trab, plate = (s.material for s in scene.materials)
    assert isinstance(trab, TransverselyIsotropic) and trab.axis == (0.0, 1.0)
    assert isinstance(plate, Orthotropic) and plate.axes == ((0.0, 1.0), (-1.0, 0.0))
    assert cort.tau_v == 1e-3
    assert [s.index for s in scene.materials] == [0, 1, 2]
    c = scene.contacts[0]
    assert (c.friction, c.coefficient, c.bound, c.coulomb_update, c.search_distance) == (
        "coulomb",
        0.3,
        0.0,
        "fixed_point",
        2e-3,
    )
    d0, d1 = scene.dirichlet
    assert d0.schedule == Schedule() and d0.components == (0, 1)
    assert d1.value == (None, 1e-3) and d1.components == (1,)
    assert d1.schedule == Schedule((0.0, 1.0), (0.0, 1.0))
    assert scene.loads[0].schedule == Schedule.from_ramp(0.5)
    assert scene.loads[1].schedule(0.0) == 1.0  # dynamic default: constant 1
    assert scene.output.directory == Path.cwd() / "out"
    assert scene.output.fields_every == 2
    check_against_mesh(scene, GROUPS, 2, 2)


def test_output_defaults_and_absolute_directory(tmp_path):
    doc = _apply(BASE, [("del", ("output",)), ("del", ("solver",)), ("del", ("scene", "name"))])
    scene = load_scene(
        write(tmp_path, doc, "myscene.toml"), allow_contact=True, allow_friction=True
    )
    assert scene.name == "myscene"
    assert scene.solver == default_solver_options()
    assert scene.output.directory == Path.cwd() / "results"
    assert scene.output.fields_every == 1 and scene.output.probes == ()
    doc = _apply(BASE, [("set", ("output", "directory"), str(tmp_path / "abs"))])
    assert (
        load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True).output.directory
        == tmp_path / "abs"
    )


def test_3d_scene(tmp_path):
    doc = _apply(
        BASE,
        [
            ("set", ("scene", "dimension"), 3),
            ("set", ("material", 1, "axis"), [0.0, 0.0, 1.0]),
            ("set", ("material", 2, "axes"), [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
            ("set", ("dirichlet", 0, "value"), [0.0, 0.0, 0.0]),
            ("set", ("dirichlet", 1, "value"), ["free", "free", 0.0]),
            ("set", ("traction", 0, "value"), [0.0, 0.0, -1.0]),
            ("set", ("body_force", 0, "value"), [0.0, 0.0, -1.0]),
            ("set", ("initial_velocity", 0, "value"), [0.0, 0.0, -1.0]),
            ("set", ("output", "probes"), [[0.0, 0.0, 0.0]]),
        ],
    )
    scene = load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True)
    assert scene.dimension == 3 and scene.dirichlet[1].value == (None, None, 0.0)
    assert scene.dirichlet[0].value == (0.0, 0.0, 0.0) and scene.dirichlet[1].components == (2,)
    assert scene.materials[1].material.axis == (0.0, 0.0, 1.0)
    assert scene.materials[2].material.axes == ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    assert [ld.value for ld in scene.loads] == [(0.0, 0.0, -1.0), 6.5e3, (0.0, 0.0, -1.0)]
    assert scene.initial_velocities[0].value == (0.0, 0.0, -1.0)
    assert scene.output.probes == ((0.0, 0.0, 0.0),)
    groups = {k: (d + 1, t) for k, (d, t) in GROUPS.items()}
    assert check_against_mesh(scene, groups, 3, 3) is None


def test_nodal_pressure_formulation(tmp_path):
    doc = _apply(
        BASE,
        [
            ("set", ("material", 0, "formulation"), "nodal_pressure"),
            ("set", ("material", 0, "nu"), 0.4999),
        ],
    )
    scene = load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True)
    assert scene.materials[0].material.formulation == "nodal_pressure"
    assert (scene.materials[0].material.E, scene.materials[0].material.nu) == (17.0e9, 0.4999)
    assert scene.materials[1].material.formulation == "displacement"


# --------------------------------------------------------------------------------------
# schedules
# --------------------------------------------------------------------------------------
def test_schedule_default_is_constant_one():
    s = Schedule()
    assert s.is_constant
    assert [s(t) for t in (-1.0, 0.0, 0.5, 1e6)] == [1.0, 1.0, 1.0, 1.0]
    assert Schedule.from_ramp(0.0) == s
    assert Schedule.constant(2.5)(3.0) == 2.5


def test_schedule_ramp():
    s = Schedule.from_ramp(0.4)  # factor = min(t / 0.4, 1)
    for t, expected in [
        (0.0, 0.0),
        (0.1, 0.25),
        (0.2, 0.5),
        (0.3, 0.75),
        (0.4, 1.0),
        (0.9, 1.0),
        (5.0, 1.0),
    ]:
        assert s(t) == pytest.approx(expected, abs=1e-15)
    assert s(-1.0) == 0.0
    assert not s.is_constant


def test_schedule_interpolation():
    # a load that rises, holds, unloads and reverses
    s = Schedule.from_pairs([[0.0, 0.0], [1.0, 2.0], [2.0, 2.0], [4.0, -1.0]])
    hand = {
        -0.5: 0.0,
        0.0: 0.0,
        0.25: 0.5,
        0.5: 1.0,
        1.0: 2.0,
        1.5: 2.0,
        2.0: 2.0,
        2.5: 1.25,
        3.0: 0.5,
        3.5: -0.25,
        4.0: -1.0,
        10.0: -1.0,
    }
    for t, expected in hand.items():
        assert s(t) == pytest.approx(expected, abs=1e-14), t
    ts = np.array(list(hand))
    np.testing.assert_allclose(s.values(ts), list(hand.values()), atol=1e-14)
    np.testing.assert_allclose(
        s.values(ts.reshape(3, 4)), np.reshape(list(hand.values()), (3, 4)), atol=1e-14
    )


def test_schedule_single_pair_is_constant():
    s = Schedule.from_pairs([[0.3, 0.7]])
    assert s.is_constant and s(0.0) == 0.7 and s(100.0) == 0.7


def test_schedule_from_file(tmp_path):
    doc = _apply(BASE, [("set", ("pressure", 0, "schedule"), [[0, 0], [1, 1], [2, 1], [3, 0]])])
    sched = (
        load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True).loads[1].schedule
    )
    np.testing.assert_allclose(sched.values([0.5, 1.5, 2.75, 4.0]), [0.5, 1.0, 0.25, 0.0])


def test_schedule_constructor_checks():
    with pytest.raises(ValueError):
        Schedule((0.0, 0.0), (1.0, 2.0))
    with pytest.raises(ValueError):
        Schedule((), ())
    with pytest.raises(ValueError):
        Schedule((0.0, 1.0), (1.0,))
    with pytest.raises(ValueError):
        Schedule.from_ramp(-1.0)
    with pytest.raises(ValueError):
        Schedule.from_pairs([[0.0, 1.0, 2.0]])


def test_static_pseudo_time(tmp_path):
    doc = _apply(
        BASE, [("set", ("analysis", "kind"), "static"), ("set", ("analysis", "load_steps"), 4)]
    )
    scene = load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True)
    np.testing.assert_allclose(scene.analysis.times(), [0.25, 0.5, 0.75, 1.0])
    assert scene.dirichlet[0].schedule(0.25) == 0.25  # default: linear in pseudo-time
    assert scene.loads[0].schedule(0.25) == 0.5  # explicit ramp = 0.5 kept


def test_times_last_step_shortened():
    a = Analysis("dynamic", t_end=1.0, dt=0.3)
    assert a.n_steps == 4
    np.testing.assert_allclose(a.times(), [0.3, 0.6, 0.9, 1.0])
    assert Analysis("quasistatic", t_end=0.3, dt=0.1).n_steps == 3


# --------------------------------------------------------------------------------------
# check_against_mesh
# --------------------------------------------------------------------------------------
def _mesh_error(scene, groups, tdim=2, gdim=2, *, key, table, contains=()) -> SceneError:
    with pytest.raises(SceneError) as info:
        check_against_mesh(scene, groups, tdim, gdim)
    exc = info.value
    text = str(exc)
    assert exc.file == str(scene.path) and text.startswith(str(scene.path))
    assert exc.key == key, text
    assert table in (exc.table or "") and table in text, text
    for c in contains:
        assert c in text, text
    return exc


def _without(name: str) -> dict[str, tuple[int, int]]:
    return {k: v for k, v in GROUPS.items() if k != name}


def test_mesh_valid(tmp_path):
    scene = base_scene(tmp_path)
    assert check_against_mesh(scene, GROUPS, 2, 2) is None
    # every name the scene uses is a group of the right dimension of the fake mesh
    assert {r: GROUPS[r][0] for r in scene.cell_regions} == {"upper": 2, "lower": 2, "plate": 2}
    facets = {d.boundary for d in scene.dirichlet} | {
        ld.target[0] for ld in scene.loads if ld.kind != "body_force"
    }
    assert facets == {"bottom", "side", "top", "cyst_wall"} and all(
        GROUPS[f][0] == 1 for f in facets
    )
    # and the check is active: dropping one of them fails
    with pytest.raises(SceneError):
        check_against_mesh(scene, _without("side"), 2, 2)


@pytest.mark.parametrize("tdim, gdim", [(3, 3), (2, 3), (3, 2)])
def test_mesh_dimension_mismatch(tmp_path, tdim, gdim):
    _mesh_error(
        base_scene(tmp_path),
        GROUPS,
        tdim,
        gdim,
        key="dimension",
        table="[scene]",
        contains=[f"topological dimension {tdim}", f"geometric dimension {gdim}"],
    )


def test_mesh_material_region_missing(tmp_path):
    _mesh_error(
        base_scene(tmp_path),
        _without("plate"),
        key="regions",
        table='[[material]] #3 "plate"',
        contains=['no physical group "plate"', '"lower", "upper"'],
    )


def test_mesh_material_region_is_facet_group(tmp_path):
    groups = {**GROUPS, "plate": (1, 3)}
    _mesh_error(
        base_scene(tmp_path),
        groups,
        key="regions",
        table="[[material]] #3",
        contains=['"plate" is a facet group', '"lower", "upper"'],
    )


def test_mesh_cell_group_without_material(tmp_path):
    groups = {**GROUPS, "tumour": (2, 7)}
    _mesh_error(
        base_scene(tmp_path),
        groups,
        key="regions",
        table="[[material]]",
        contains=['cell group "tumour" has no material'],
    )


def test_mesh_two_materials_same_cells(tmp_path):
    groups = {**GROUPS, "plate": (2, 2)}  # "plate" and "lower" are the same cells
    _mesh_error(
        base_scene(tmp_path),
        groups,
        key="regions",
        table='[[material]] #3 "plate"',
        contains=["same cells", '"trabecular"'],
    )


def test_mesh_dirichlet_boundary_missing(tmp_path):
    facets = '"bottom", "cyst_wall", "lower_contact", "side", "top", "upper_contact"'
    _mesh_error(
        base_scene(tmp_path),
        _without("side"),
        key="boundary",
        table="[[dirichlet]] #2",
        contains=['no physical group "side"', facets.replace('"side", ', "")],
    )


def test_mesh_traction_boundary_is_cell_group(tmp_path):
    # "top" is a cell group here (given a material so that it is not reported as unassigned first)
    doc = _apply(BASE, [("set", ("material", 0, "regions"), ["upper", "top"])])
    scene = load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True)
    _mesh_error(
        scene,
        {**GROUPS, "top": (2, 99)},
        key="boundary",
        table="[[traction]] #1",
        contains=['"top" is a cell group', "facet groups"],
    )


def test_mesh_pressure_boundary_missing(tmp_path):
    _mesh_error(
        base_scene(tmp_path),
        _without("cyst_wall"),
        key="boundary",
        table="[[pressure]] #1",
        contains=['no physical group "cyst_wall"'],
    )


def test_mesh_body_force_region_not_cell_group(tmp_path):
    doc = _apply(BASE, [("set", ("body_force", 0, "regions"), ["bottom"])])
    scene = load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True)
    _mesh_error(
        scene,
        GROUPS,
        key="regions",
        table="[[body_force]] #1",
        contains=['"bottom" is a facet group', '"lower", "plate", "upper"'],
    )


def test_mesh_initial_velocity_region_missing(tmp_path):
    doc = _apply(BASE, [("set", ("initial_velocity", 0, "regions"), ["femur"])])
    scene = load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True)
    _mesh_error(
        scene,
        GROUPS,
        key="regions",
        table="[[initial_velocity]] #1",
        contains=['no physical group "femur"', '"lower", "plate", "upper"'],
    )


@pytest.mark.parametrize("key", ["slave", "master"])
def test_mesh_contact_surface_missing(tmp_path, key):
    name = BASE["contact"][0][key]
    _mesh_error(
        base_scene(tmp_path),
        _without(name),
        key=key,
        table='[[contact]] #1 "joint"',
        contains=[f'no physical group "{name}"', "facet groups"],
    )


def test_mesh_contact_surface_is_point_group(tmp_path):
    groups = {**GROUPS, "lower_contact": (0, 11)}
    _mesh_error(
        base_scene(tmp_path),
        groups,
        key="master",
        table="[[contact]] #1",
        contains=["dimension-0 group"],
    )


def test_mesh_dirichlet_same_component_twice(tmp_path):
    doc = _apply(
        BASE,
        [
            ("set", ("dirichlet", 1, "boundary"), "bottom"),
            ("set", ("dirichlet", 1, "value"), ["free", 0.0]),
        ],
    )
    scene = load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True)
    _mesh_error(
        scene,
        GROUPS,
        key="value",
        table="[[dirichlet]] #2",
        contains=['component 2 of boundary "bottom"', "[[dirichlet]] #1"],
    )


def test_mesh_dirichlet_same_component_through_alias(tmp_path):
    groups = {**GROUPS, "side": GROUPS["bottom"]}  # two names, one facet tag
    _mesh_error(
        base_scene(tmp_path),
        groups,
        key="value",
        table="[[dirichlet]] #2",
        contains=["component 2", "already fixed"],
    )


def test_mesh_dirichlet_different_components_same_boundary(tmp_path):
    doc = _apply(
        BASE,
        [
            ("set", ("dirichlet", 0, "value"), [0.0, "free"]),
            ("set", ("dirichlet", 1, "boundary"), "bottom"),
        ],
    )
    check_against_mesh(
        load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True), GROUPS, 2, 2
    )


def test_mesh_traction_on_fixed_component(tmp_path):
    doc = _apply(BASE, [("set", ("traction", 0, "boundary"), "side")])
    scene = load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True)
    _mesh_error(
        scene,
        GROUPS,
        key="value",
        table="[[traction]] #1",
        contains=['component 2 of boundary "side"', "[[dirichlet]] #2"],
    )
    # a load in the free component of the same boundary is fine
    doc = _apply(
        BASE,
        [("set", ("traction", 0, "boundary"), "side"), ("set", ("traction", 0, "value"), [5.0, 0])],
    )
    check_against_mesh(
        load_scene(write(tmp_path, doc), allow_contact=True, allow_friction=True), GROUPS, 2, 2
    )


@pytest.mark.parametrize("value", [None, False, True])
def test_allow_large_strain(tmp_path, value):
    """``[analysis] allow_large_strain``: absent is false; a given boolean is kept."""
    doc = copy.deepcopy(BASE)
    if value is not None:
        doc["analysis"]["allow_large_strain"] = value
    scene = load_scene(write(tmp_path, doc))
    assert scene.analysis.allow_large_strain is bool(value)
    assert Analysis().allow_large_strain is False
