"""The scene tables are declared once (bonecontact.scene.spec, ``TABLES``): the docs' key
tables, the reader's checks and messages, and the parsed defaults all follow from the
declarations.

* every declared key is documented in its table of docs/scene_format.md (or
  docs/neoplasm_format.md) with the declared type, unit and default, and no documented key
  is undeclared;
* an unknown key in any table is refused naming the file, the table, the key and exactly
  the declared keys; a wrong value of a key with allowed values names all of them;
* a key left out reads as its declared default, and the dataclass defaults agree with
  the declarations.

Pure Python: also runs under mpiexec (each rank its own tmp_path).
"""

from __future__ import annotations

import copy
import dataclasses
import re
from pathlib import Path
from typing import Any

import pytest

from bonecontact.scene import SceneError, load_scene
from bonecontact.scene import spec as S
from bonecontact.scene.keys import REQUIRED, Key, Table

ROOT = Path(__file__).resolve().parents[3]
DOCS = ROOT / "docs"

#: Where each declared table is documented: (file, heading prefix, n-th key table in the
#: section, counting from 0).
DOC_TABLES: dict[str, tuple[str, str, int]] = {
    "scene": ("scene_format.md", "## `[scene]`", 0),
    "analysis": ("scene_format.md", "## `[analysis]`", 0),
    "solver": ("scene_format.md", "## `[solver]`", 0),
    "material": ("scene_format.md", "## `[[material]]`", 0),
    "contact": ("scene_format.md", "## `[[contact]]`", 0),
    "dirichlet": ("scene_format.md", "## `[[dirichlet]]`", 0),
    "force": ("scene_format.md", "### `[[force]]`", 0),
    "initial_velocity": ("scene_format.md", "## `[[initial_velocity]]`", 0),
    "output": ("scene_format.md", "## `[output]`", 0),
    "fracture": ("scene_format.md", "## Fracture", 0),
    "crack": ("scene_format.md", "## Fracture", 1),
    "fracture.fatigue": ("scene_format.md", "### `[fracture.fatigue]`", 0),
    "crack (3D)": ("scene_format.md", "### 3D crack", 0),
    "neoplasm": ("neoplasm_format.md", "## `[neoplasm]`", 0),
    "neoplasm.tumour": ("neoplasm_format.md", "## `[neoplasm.tumour]`", 0),
    "neoplasm.cyst": ("neoplasm_format.md", "## `[neoplasm.cyst]`", 0),
}
#: Tables documented as one row each of the "Loads" table (table | keys | value).
LOAD_ROWS = ("traction", "pressure", "body_force")


def _section(text: str, heading: str) -> list[str]:
    """The lines under the first heading that starts with ``heading``, up to the next
    heading of the same or a higher level."""
    lines = text.splitlines()
    level = len(heading) - len(heading.lstrip("#"))
    start = next(i for i, ln in enumerate(lines) if ln.startswith(heading))
    out = []
    for ln in lines[start + 1 :]:
        m = re.match(r"^(#+) ", ln)
        if m and len(m.group(1)) <= level:
            break
        out.append(ln)
    return out


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


def _key_tables(lines: list[str]) -> list[tuple[list[str], list[list[str]]]]:
    """The markdown tables whose first column is ``key``: (header, rows)."""
    tables, i = [], 0
    while i < len(lines):
        if lines[i].startswith("| key |"):
            header = _cells(lines[i])
            rows = []
            i += 2
            while i < len(lines) and lines[i].startswith("|"):
                rows.append(_cells(lines[i]))
                i += 1
            tables.append((header, rows))
        else:
            i += 1
    return tables


def _documented(name: str) -> dict[str, dict[str, str]]:
    """key -> {column: cell} of the docs' table of ``name``."""
    file, heading, n = DOC_TABLES[name]
    header, rows = _key_tables(_section((DOCS / file).read_text(), heading))[n]
    out: dict[str, dict[str, str]] = {}
    for row in rows:
        keys = re.findall(r"`([^`]+)`", row[0])
        assert len(keys) == 1, f"{file} {heading}: one key per row, got {row[0]!r}"
        out[keys[0]] = dict(zip(header, row, strict=True))
    return out


@pytest.mark.parametrize("name", list(DOC_TABLES))
def test_docs_table_matches_the_declaration(name: str) -> None:
    """Same keys; each row's type (and unit), and default, as declared."""
    table = S.TABLES[name]
    rows = _documented(name)
    # sub-tables ([neoplasm.tumour], ...) are documented in their own sections
    declared = {k.name for k in table.keys if k.type != "table"}
    assert set(rows) == declared, (
        f"documented but not declared: {sorted(set(rows) - declared)}; "
        f"declared but not documented: {sorted(declared - set(rows))}"
    )
    for key in (k for k in table.keys if k.type != "table"):
        row = rows[key.name]
        if "unit" in row:  # the neoplasm tables: unit in its own column
            assert row["type"] == key.doc_type().split(",")[0], (key.name, row)
            assert row["unit"] == (key.unit or "–"), (key.name, row)
        else:
            assert row["type"] == key.doc_type(), (key.name, row)
        assert row["default"] == key.doc_default_text(), (key.name, row)


@pytest.mark.parametrize("name", LOAD_ROWS)
def test_docs_load_rows_list_the_declared_keys(name: str) -> None:
    lines = _section((DOCS / "scene_format.md").read_text(), "## Loads")
    row = next(_cells(ln) for ln in lines if ln.startswith(f"| `[[{name}]]`"))
    assert set(re.findall(r"`([^`]+)`", row[1])) == set(S.TABLES[name].names)


def test_docs_top_level_lists_every_table() -> None:
    lines = _section((DOCS / "scene_format.md").read_text(), "## Top level")
    text = " ".join(lines)
    listed = set(re.findall(r"`\[\[?([a-z_]+)\]?\]`", text.split("Allowed tables:")[1]))
    assert listed == set(S.TOP_LEVEL.names) - {"format"}
    assert _key_tables(lines)[0][1][0][0] == "`format`"


@pytest.mark.parametrize("model", list(S.MODEL_CONSTANTS))
def test_docs_material_constants(model: str) -> None:
    lines = _section((DOCS / "scene_format.md").read_text(), "## `[[material]]`")
    row = next(_cells(ln) for ln in lines if ln.startswith(f"| `{model}` |"))
    documented = set(re.findall(r"`([A-Za-z_0-9]+)`", row[1].replace(" ", "` `")))
    assert {k.name for k in S.MODEL_CONSTANTS[model]} <= documented


def test_declarations_are_consistent() -> None:
    """Types known, defaults of the declared type, allowed values in their own default."""
    for name, table in S.TABLES.items():
        for key in table.keys:
            if key.choices and key.default not in (None, REQUIRED):
                assert key.default in key.choices, (name, key)
            if key.type == "boolean" and not key.required:
                assert isinstance(key.default, bool), (name, key)
            if key.type == "integer" and key.default not in (None, REQUIRED):
                assert isinstance(key.default, int), (name, key)
            if key.type == "number" and key.default not in (None, REQUIRED):
                assert isinstance(key.default, float), (name, key)


#: (table, the dataclass holding it): the defaults of fields named like a key must agree.
DATACLASSES = [
    ("analysis", S.Analysis),
    ("solver", S.SolverOptions),
    ("contact", S.ContactSpec),
    ("output", S.OutputSpec),
    ("fracture", S.FractureSpec),
    ("fracture.fatigue", S.FatigueSpec),
    ("crack", S.CrackSpec),
    ("neoplasm", S.NeoplasmSpec),
]


@pytest.mark.parametrize("name, cls", DATACLASSES, ids=[d[0] for d in DATACLASSES])
def test_dataclass_defaults_follow_the_declaration(name: str, cls: type) -> None:
    table = S.TABLES[name]
    compared = 0
    for f in dataclasses.fields(cls):
        if f.name not in table.names or f.default is dataclasses.MISSING:
            continue
        key = table[f.name]
        if key.required or key.doc_default is not None:
            continue  # required in the file, or a default that depends on other keys
        declared = tuple(key.default) if isinstance(key.default, list) else key.default
        assert f.default == declared, (name, f.name, f.default, declared)
        compared += 1
    assert compared >= 1, f"{name}: nothing compared"


# --------------------------------------------------------------------------------------
# the reader follows the declarations
# --------------------------------------------------------------------------------------
MESH_SCENE: dict[str, Any] = {
    "format": 1,
    "scene": {"name": "plate", "mesh": "plate.msh", "dimension": 2},
    "analysis": {"kind": "static"},
    "solver": {},
    "material": [
        {"name": "bone", "regions": ["plate"], "model": "isotropic", "E": 1e10, "nu": 0.3}
        | {"sigma_t": 1e8}
    ],
    "contact": [{"name": "pair", "slave": "a", "master": "b"}],
    "dirichlet": [{"boundary": "bottom", "value": [0.0, 0.0]}],
    "traction": [{"boundary": "top", "value": [0.0, -1.0]}],
    "pressure": [{"boundary": "top", "value": 1.0}],
    "body_force": [{"regions": ["plate"], "value": [0.0, -1.0]}],
    "force": [{"boundary": "top", "value": [0.0, -1.0]}],
    "initial_velocity": [{"regions": ["plate"], "value": [0.0, 0.0]}],
    "output": {},
    "fracture": {},
    "crack": [{"name": "c", "points": [[0.0, 0.0], [1e-3, 0.0]], "region": "plate"}],
}
GROWTH_SCENE: dict[str, Any] = {
    "format": 1,
    "scene": {"name": "growth", "dimension": 2},
    "neoplasm": {"kind": "tumour", "radius": 1e-3, "t_end": 1.0, "dt": 0.5, "tumour": {}},
}
CYST_SCENE: dict[str, Any] = {
    "format": 1,
    "scene": {"name": "cyst", "dimension": 2},
    "neoplasm": {"kind": "cyst", "radius": 1e-3, "t_end": 1.0, "dt": 0.5}
    | {"cyst": {"beta": 1e-11, "C_minus": 1.0}},
}
FATIGUE_SCENE: dict[str, Any] = copy.deepcopy(MESH_SCENE) | {
    "fracture": {"fatigue": {"C": 1e-30, "m": 4.0, "da_max": 1e-4}}
}
#: declared table -> (document, path of the table in it)
WHERE: dict[str, tuple[dict[str, Any], tuple[Any, ...]]] = {
    "top level": (MESH_SCENE, ()),
    "scene": (MESH_SCENE, ("scene",)),
    "analysis": (MESH_SCENE, ("analysis",)),
    "solver": (MESH_SCENE, ("solver",)),
    "contact": (MESH_SCENE, ("contact", 0)),
    "dirichlet": (MESH_SCENE, ("dirichlet", 0)),
    "traction": (MESH_SCENE, ("traction", 0)),
    "pressure": (MESH_SCENE, ("pressure", 0)),
    "body_force": (MESH_SCENE, ("body_force", 0)),
    "force": (MESH_SCENE, ("force", 0)),
    "initial_velocity": (MESH_SCENE, ("initial_velocity", 0)),
    "output": (MESH_SCENE, ("output",)),
    "fracture": (MESH_SCENE, ("fracture",)),
    "crack": (MESH_SCENE, ("crack", 0)),
    "fracture.fatigue": (FATIGUE_SCENE, ("fracture", "fatigue")),
    "neoplasm": (GROWTH_SCENE, ("neoplasm",)),
    "neoplasm.tumour": (GROWTH_SCENE, ("neoplasm", "tumour")),
    "neoplasm.cyst": (CYST_SCENE, ("neoplasm", "cyst")),
}


def _toml(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_toml(x)}" for k, x in v.items()) + "}"
    return repr(v)


def _write(tmp_path: Path, doc: dict[str, Any]) -> Path:
    """A TOML file of ``doc`` (inline tables for the sub-tables)."""
    lines = [f"{k} = {_toml(v)}" for k, v in doc.items() if not isinstance(v, (dict, list))]
    for k, v in doc.items():
        if isinstance(v, dict):
            lines += [f"[{k}]"] + [f"{a} = {_toml(b)}" for a, b in v.items()]
        elif isinstance(v, list):
            for entry in v:
                lines += [f"[[{k}]]"] + [f"{a} = {_toml(b)}" for a, b in entry.items()]
    (tmp_path / "plate.msh").write_text("")
    path = tmp_path / "scene.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def _with(name: str, key: str, value: Any) -> dict[str, Any]:
    doc, where = WHERE[name]
    doc = copy.deepcopy(doc)
    node = doc
    for k in where:
        node = node[k]
    node[key] = value
    return doc


def _label(name: str) -> str | None:
    table = S.TABLES[name]
    if name == "top level":
        return None
    return f"{table.label} #1" if table.array else table.label


@pytest.mark.parametrize("name", list(WHERE))
def test_unknown_key_lists_the_declared_keys(tmp_path: Path, name: str) -> None:
    path = _write(tmp_path, _with(name, "colour", "red"))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    exc = info.value
    assert (exc.file, exc.key) == (str(path), "colour"), str(exc)
    label = _label(name)
    assert exc.table is None if label is None else exc.table.startswith(label), str(exc)
    allowed = exc.message.split("allowed: ")[1]
    assert allowed == ", ".join(S.TABLES[name].names), str(exc)


CHOICE_KEYS = [
    (name, key.name)
    for name, table in S.TABLES.items()
    if name in WHERE
    for key in table.keys
    if key.choices
]


@pytest.mark.parametrize("name, key", CHOICE_KEYS, ids=[f"{n}.{k}" for n, k in CHOICE_KEYS])
def test_wrong_value_names_every_allowed_value(tmp_path: Path, name: str, key: str) -> None:
    path = _write(tmp_path, _with(name, key, "nonsense"))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    exc = info.value
    assert (exc.file, exc.key) == (str(path), key), str(exc)
    assert 'got "nonsense"' in exc.message, str(exc)
    for choice in S.TABLES[name][key].choices:
        assert f'"{choice}"' in exc.message, (choice, str(exc))


def _parsed(name: str, scene: Any) -> Any:
    """The parsed object of table ``name`` in ``scene``."""
    return {
        "analysis": scene.analysis,
        "solver": scene.solver,
        "contact": scene.contacts[0] if scene.contacts else None,
        "output": scene.output,
        "fracture": scene.fracture,
        "fracture.fatigue": scene.fracture.fatigue if scene.fracture else None,
        "crack": scene.cracks[0] if scene.cracks else None,
        "neoplasm": scene.neoplasm,
    }[name]


ABSENT = [
    (name, key.name)
    for name, _ in DATACLASSES
    if name in WHERE
    for key in S.TABLES[name].keys
    if not key.required
    and key.doc_default is None
    and key.type != "table"
    and key.name in {f.name for f in dataclasses.fields(dict(DATACLASSES)[name])}
]


@pytest.mark.parametrize("name, key", ABSENT, ids=[f"{n}.{k}" for n, k in ABSENT])
def test_absent_key_reads_as_its_declared_default(tmp_path: Path, name: str, key: str) -> None:
    doc, where = WHERE[name]
    scene = load_scene(_write(tmp_path, copy.deepcopy(doc)))
    node = doc
    for k in where:
        node = node[k]
    assert key not in node
    value = getattr(_parsed(name, scene), key)
    declared = S.TABLES[name][key].default
    if key == "directory":
        assert value == Path.cwd() / declared
    elif isinstance(declared, list):
        assert tuple(value) == tuple(declared)
    else:
        assert value == declared and type(value) is type(declared), (value, declared)


def test_key_and_table_declarations_refuse_mistakes() -> None:
    with pytest.raises(ValueError, match="unknown type"):
        Key("x", "float")
    with pytest.raises(ValueError, match="choices are for string keys"):
        Key("x", "number", choices=("a",))
    with pytest.raises(ValueError, match="declared twice"):
        Table("t", (Key("x", "number"), Key("x", "string")))
    with pytest.raises(ValueError, match="is not a key"):
        Table("t", (Key("x", "number"),), renamed={"y": "z"})


# --------------------------------------------------------------------------------------
# one name per meaning: friction is a law, coefficient a number; FrictionLaw in one place
# --------------------------------------------------------------------------------------
CONTACT_LAWS = [
    ("none", {}),
    ("tresca", {"bound": 2.5e5}),
    ("coulomb", {"coefficient": 0.3}),
    ("coulomb", {"coefficient": 0.3, "coulomb_update": "fixed_point"}),
    ("coulomb", {"coefficient": 0.0}),
]


@pytest.mark.parametrize(
    "law, values",
    CONTACT_LAWS,
    ids=[f"{law}-{len(v)}-{i}" for i, (law, v) in enumerate(CONTACT_LAWS)],
)
def test_contact_friction_law_is_built_from_the_file(tmp_path: Path, law: str, values) -> None:
    """``[[contact]] friction`` names the law and ``coefficient`` / ``bound`` its numbers:
    ContactSpec.friction_law() is the solver's law with the file's values and the declared
    defaults for the rest."""
    from bonecontact.contact.friction import FrictionLaw

    entry = {"name": "pair", "slave": "a", "master": "b", "friction": law, **values}
    doc = copy.deepcopy(MESH_SCENE) | {"contact": [entry]}
    pair = load_scene(_write(tmp_path, doc)).contacts[0]
    got = pair.friction_law()
    expected = FrictionLaw(
        law,
        values.get("coefficient", S.CONTACT_TABLE.default("coefficient")),
        values.get("bound", S.CONTACT_TABLE.default("bound")),
        values.get("coulomb_update", S.CONTACT_TABLE.default("coulomb_update")),
    )
    assert got == expected
    assert (got.kind, got.coefficient, got.bound) == (
        law,
        float(values.get("coefficient", 0.0)),
        float(values.get("bound", 0.0)),
    )


@pytest.mark.parametrize("mu", [0.0, 0.2, 1.5])
@pytest.mark.parametrize("dim", [2, 3])
def test_crack_face_pair_follows_its_coefficient(tmp_path: Path, mu: float, dim: int) -> None:
    """A crack's face pair: Coulomb with the fixed-point bound and the crack's coefficient
    when it is > 0, else frictionless (the same ContactSpec a [[contact]] with these values
    gives)."""
    crack = (
        {"name": "c", "points": [[0.0, 0.0], [1e-3, 0.0]], "region": "plate"}
        if dim == 2
        else {"name": "c", "centre": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0]}
        | {"radius": 1e-3, "region": "plate"}
    )
    doc = copy.deepcopy(MESH_SCENE) | {"crack": [crack | {"coefficient": mu}]}
    doc["scene"]["dimension"] = dim
    if dim == 3:
        doc = {k: v for k, v in doc.items() if k in ("format", "scene", "analysis", "material")}
        doc |= {"crack": [crack | {"coefficient": mu}], "fracture": {}}
    spec = load_scene(_write(tmp_path, doc)).cracks[0]
    assert spec.coefficient == mu
    pair = spec.face_pair("c", "crack_plus", "crack_minus")
    law = pair.friction_law()
    if mu > 0:
        assert (law.kind, law.coefficient, law.update) == ("coulomb", mu, "fixed_point")
    else:
        assert (law.kind, law.coefficient, law.update) == ("none", 0.0, "previous_step")
    assert (pair.name, pair.slave, pair.master, pair.bound) == (
        "c",
        "crack_plus",
        "crack_minus",
        0.0,
    )


def test_friction_is_a_law_and_coefficient_a_number_in_every_table() -> None:
    """Across the declarations, ``friction`` is only ever a string key (a law) and
    ``coefficient`` only ever a number; the old ``friction = <number>`` of the crack tables
    is a declared rename to ``coefficient``."""
    kinds = {
        (key.name, key.type)
        for table in S.TABLES.values()
        for key in table.keys
        if key.name in ("friction", "coefficient")
    }
    assert kinds == {("friction", "string"), ("coefficient", "number")}
    assert S.CONTACT_TABLE["friction"].choices == ("none", "tresca", "coulomb")
    renamed = {name for name, t in S.TABLES.items() if t.renamed}
    assert renamed == {"fracture", "crack", "crack (3D)"}
    assert all(S.TABLES[n].renamed == {"friction": "coefficient"} for n in renamed)
