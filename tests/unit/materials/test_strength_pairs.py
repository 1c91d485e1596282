"""Every shipped scene pairs each bone's modulus with the strength of the same bone.

The initiation risk R = sigma_1 / sigma_t of a cell is a strain criterion in disguise:
sigma_t / E is the elastic strain at which the tissue yields.  A modulus of one bone with
the strength of another (E of rho = 0.30 g/cm3 vertebral bone, 723 MPa, with the 1.75 MPa
measured at rho = 0.18) puts that strain far from the measured one and the risk with it.

Scenes read (parsed, nothing is run): ``data/scenes/*.toml`` and the scene texts the demos
build (``demos/*.py``: every string holding a ``[[material]]`` table; the ``{...}`` fields
of an f-string are evaluated from the demo's top-level assignments and library look-ups).
Every ``[[material]]`` table with a ``sigma_t`` is checked (a scene gives one only for a
``[fracture]`` risk): its tissue, from a keyword in its name, else in its regions, must be

* cancellous (``cancellous``, ``trabecular``): sigma_t / E + offset within 2 SD of the
  tensile yield strain of vertebral trabecular bone, 0.78 +/- 0.04 % (Kopperdahl & Keaveny
  1998, ``[reference.trabecular_yield_strain_vertebral]``: independent of the density);
* cortical (``cortical``, ``cortex``, ``shell``): sigma_t / E + offset within the span of
  Reilly & Burstein's own pairs (1975; transverse 51 MPa / 11.5 GPa, longitudinal
  133 MPa / 17 GPa: 0.64-0.98 %).  Their strengths are ultimate ones: no cortical yield
  strain is recorded in data/materials.toml, so this is the strain at sigma_t on a linear
  curve of one paper's same-direction pairs, not a measured yield strain;

or the table states an exception: a comment line ``# strength_pair_exception: <reason>``
inside it (e.g. the disc or the tumour, whose strength only keeps R defined).  Demos that
compute the risk in Python (``risk_field``) declare their pairs in a top-level
``RISK_PAIRS = {tissue: (E, sigma_t)}``, checked the same way.  Moduli: ``E``; ``E_a``
(transversely isotropic) and ``E3`` (orthotropic), the bone axis of the library's entries.
"""

from __future__ import annotations

import ast
import importlib
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from bonecontact.materials.library import (
    load_material_library,
    load_reference_values,
    load_strengths,
)

#: source analysis: nothing collective, so it runs in the serial session only
pytestmark = pytest.mark.serial

ROOT = Path(__file__).resolve().parents[3]
SCENES = sorted((ROOT / "data" / "scenes").glob("*.toml"))
DEMOS = sorted((ROOT / "demos").glob("*.py"))
EXCEPTION = re.compile(r"^\s*#\s*strength_pair_exception\s*:(.*)$")
KEYWORDS = {
    "cancellous": ("cancellous", "trabecular"),
    "cortical": ("cortical", "cortex", "shell"),
}
#: modules a demo's top-level imports may bring into the evaluation (read-only look-ups)
IMPORTABLE = (
    "bonecontact.materials",
    "bonecontact.materials.library",
    "bonecontact.common.constants",
    "numpy",
)
SAFE_BUILTINS = {
    f.__name__: f
    for f in (abs, dict, float, int, len, list, max, min, range, round, str, sum, tuple)
}


@dataclass(frozen=True)
class Table:
    """One ``[[material]]`` table of a scene: where it is, its keys, its exception."""

    where: str
    keys: dict[str, Any]
    exception: str | None


def yield_bands() -> dict[str, tuple[float, float]]:
    """(lowest, highest) sigma_t / E + offset of each tissue, from data/materials.toml."""
    ref = load_reference_values()
    ys = ref["trabecular_yield_strain_vertebral"]
    off, band = ys["offset"], 2.0 * ys["tension_sd"]
    lib, strength = load_material_library(), load_strengths()
    longitudinal = strength["cortical_bone"]["sigma_t"] / lib["cortical_bone"]["E"]
    transverse = (
        ref["cortical_strength"]["tension_transverse"] / lib["cortical_bone_transverse"]["E_p"]
    )
    return {
        "cancellous": (ys["tension"] - band, ys["tension"] + band),
        "cortical": (min(longitudinal, transverse) + off, max(longitudinal, transverse) + off),
    }


def tissue(keys: dict[str, Any]) -> str | None:
    """The tissue of a material table: a keyword in its name, else in its regions."""
    for text in (str(keys.get("name", "")), " ".join(map(str, keys.get("regions", [])))):
        found = [t for t, words in KEYWORDS.items() if any(w in text.lower() for w in words)]
        if found:
            return found[0]
    return None


def modulus(keys: dict[str, Any]) -> Any:
    """The modulus to pair with sigma_t: E, else the bone axis' E_a or E3."""
    return next((keys[k] for k in ("E", "E_a", "E3") if k in keys), None)


def pair_strain(E: float, sigma_t: float) -> float:
    """sigma_t / E plus the yield point's offset (sigma_y = E (eps_y - offset))."""
    return sigma_t / E + load_reference_values()["trabecular_yield_strain_vertebral"]["offset"]


def check_pair(what: str, kind: str | None, E: Any, sigma_t: Any) -> None:
    """Assert that (E, sigma_t) of tissue ``kind`` lies in its band; the message names
    ``what`` (file, line, material), the strain and the band."""
    assert kind in KEYWORDS, (
        f"{what}: sigma_t given but the tissue is neither {sorted(KEYWORDS)} (keywords "
        f"{KEYWORDS}): name it, or state '# strength_pair_exception: <reason>' in the table"
    )
    assert isinstance(E, (int, float)) and isinstance(sigma_t, (int, float)), (
        f"{what}: E = {E!r}, sigma_t = {sigma_t!r}: not numbers (unresolved?)"
    )
    lo, hi = yield_bands()[kind]
    eps = pair_strain(E, sigma_t)
    assert lo * (1 - 1e-9) <= eps <= hi * (1 + 1e-9), (
        f"{what}: {kind} E = {E / 1e6:.4g} MPa with sigma_t = {sigma_t / 1e6:.4g} MPa: "
        f"sigma_t/E + offset = {100 * eps:.3f} %, outside {100 * lo:.3f}-{100 * hi:.3f} % "
        f"(a modulus and a strength of different bones?  data/materials.toml pairs)"
    )


def material_tables(text: str, where: str) -> list[Table]:
    """The ``[[material]]`` tables of a scene text (each up to the next table header),
    each parsed on its own so that the rest of a demo's template need not be TOML."""
    lines, out, k = text.splitlines(), [], 0
    while k < len(lines):
        if lines[k].strip() != "[[material]]":
            k += 1
            continue
        start, k = k, k + 1
        # a table ends at the next header or at an unresolved field standing for text
        while k < len(lines) and not lines[k].strip().startswith(("[", '"unresolved:')):
            k += 1
        block = lines[start:k]
        try:
            keys = tomllib.loads("\n".join(block))["material"][0]
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"{where}+{start}: not TOML ({exc}):\n" + "\n".join(block)) from exc
        reasons = [m.group(1).strip() for m in map(EXCEPTION.match, block) if m]
        out.append(
            Table(f"{where}+{start} {keys.get('name')!r}", keys, reasons[0] if reasons else None)
        )
    return out


def _namespace(tree: ast.Module, path: Path) -> dict[str, Any]:
    """The demo's top-level constants: its imports of IMPORTABLE modules and the plain
    assignments that evaluate with them (others, e.g. calls of the demo's own functions,
    raise and are skipped), with a few side-effect-free builtins only."""
    ns: dict[str, Any] = {"__builtins__": SAFE_BUILTINS}
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and node.module in IMPORTABLE:
            mod = importlib.import_module(node.module)
            ns.update({a.asname or a.name: getattr(mod, a.name) for a in node.names})
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name in IMPORTABLE:
                    ns[a.asname or a.name] = importlib.import_module(a.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            try:
                exec(compile(ast.Module([node], []), str(path), "exec"), ns)
            except Exception:
                pass
    return ns


def _render(node: ast.JoinedStr, ns: dict[str, Any]) -> str:
    """An f-string's text with its fields evaluated in ``ns`` (an unresolved field becomes
    a TOML string naming the expression)."""
    parts = []
    for v in node.values:
        if isinstance(v, ast.Constant):
            parts.append(v.value)
            continue
        try:
            value = eval(compile(ast.Expression(v.value), "<field>", "eval"), ns)
            value = {115: str, 114: repr, 97: ascii}.get(v.conversion, lambda x: x)(value)
            spec = _render(v.format_spec, ns) if v.format_spec else ""
            parts.append(format(value, spec))
        except Exception:
            parts.append('"unresolved: ' + ast.unparse(v.value).replace('"', "'") + '"')
    return "".join(parts)


def demo_scene_texts(path: Path) -> tuple[list[tuple[int, str]], dict[str, Any]]:
    """(line, text) of every string of a demo that holds a ``[[material]]`` table, and the
    demo's evaluated top-level constants."""
    tree = ast.parse(path.read_text(), str(path))
    ns = _namespace(tree, path)
    texts = []
    pieces = {id(v) for n in ast.walk(tree) if isinstance(n, ast.JoinedStr) for v in n.values}
    for node in ast.walk(tree):
        if id(node) in pieces:  # a piece of an f-string, read with it
            continue
        if isinstance(node, ast.JoinedStr):
            text = _render(node, ns)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            text = node.value
        else:
            continue
        if "[[material]]" in text:
            texts.append((node.lineno, text))
    return texts, ns


def shipped_tables() -> list[Table]:
    """Every material table of the shipped scenes and of the scenes the demos build."""
    tables = []
    for path in SCENES:
        tables += material_tables(path.read_text(), str(path.relative_to(ROOT)))
    for path in DEMOS:
        for line, text in demo_scene_texts(path)[0]:
            tables += material_tables(text, f"{path.relative_to(ROOT)}:{line}")
    return tables


TABLES = shipped_tables()
RISK_TABLES = [t for t in TABLES if "sigma_t" in t.keys]
API_RISK_DEMOS = [p for p in DEMOS if "risk_field(" in p.read_text()]


def test_the_scenes_are_read():
    """The parser sees every shipped scene file's materials and the demos' scene texts:
    the demos with a risk (spine3d, vertebra_tumour, vertebra_fracture) among them, and
    every value of a checked table resolved (no field left unevaluated)."""
    assert len(SCENES) >= 8 and len({t.where.split("+")[0] for t in TABLES}) >= len(SCENES)
    demos = {t.where.split(":")[0] for t in RISK_TABLES}
    for name in ("spine3d", "vertebra_tumour", "vertebra_fracture"):
        assert f"demos/{name}.py" in demos, name
    for t in RISK_TABLES:
        assert not any("unresolved" in str(v) for v in t.keys.values()), t


@pytest.mark.parametrize("table", RISK_TABLES, ids=[t.where for t in RISK_TABLES])
def test_risk_pair_is_one_bone(table: Table):
    """A table whose risk is computed pairs E and sigma_t of one bone, or says why not."""
    if table.exception is not None:
        assert len(table.exception) >= 10, f"{table.where}: the exception needs a reason"
        return
    k = table.keys
    check_pair(table.where, tissue(k), modulus(k), k["sigma_t"])


@pytest.mark.parametrize("demo", API_RISK_DEMOS, ids=[p.stem for p in API_RISK_DEMOS])
def test_python_risk_pairs_are_one_bone(demo: Path):
    """A demo computing the risk in Python declares its pairs (RISK_PAIRS) and they hold."""
    ns = demo_scene_texts(demo)[1]
    assert "RISK_PAIRS" in ns, f"{demo.name}: computes a risk, declares no RISK_PAIRS"
    for kind, (E, sigma_t) in ns["RISK_PAIRS"].items():
        check_pair(f"{demo.name} RISK_PAIRS[{kind!r}]", kind, E, sigma_t)


def test_library_pairs_pass_and_mixed_pairs_fail():
    """The check itself: the library's one-bone pairs pass; a modulus of one bone with the
    strength of another fails (the pairs the demos used until 2026-12-03): rho = 0.30
    vertebral bone (723 MPa) or 1 GPa with the 1.75 MPa of rho = 0.18 bone, and the
    transverse cortical modulus (12 GPa) with the longitudinal strength (133 MPa)."""
    lib, strength = load_material_library(), load_strengths()
    for name, kind in (
        ("cancellous_bone_vertebral_018", "cancellous"),
        ("cortical_bone", "cortical"),
    ):
        check_pair(name, kind, lib[name]["E"], strength[name]["sigma_t"])
    lo, hi = yield_bands()["cancellous"]
    assert (lo, hi) == pytest.approx((0.0070, 0.0086))
    for kind, E, sigma_t in (
        ("cancellous", lib["cancellous_bone_vertebral"]["E"], 1.75e6),
        ("cancellous", 1.0e9, 1.75e6),
        ("cortical", 12.0e9, 133.0e6),
        (None, 4.2e6, 10.0e6),
    ):
        with pytest.raises(AssertionError):
            check_pair("mixed", kind, E, sigma_t)


def test_parser_reads_fields_and_exceptions(tmp_path):
    """An f-string's fields are evaluated from the demo's constants and library look-ups,
    an exception comment is read with its reason, a call of the demo's own code is not run."""
    demo = tmp_path / "demo.py"
    demo.write_text(
        "from bonecontact.materials.library import load_strengths\n"
        "S = load_strengths()['cortical_bone']['sigma_t']\nE = 2 * 8.5e9\nX = run_it()\n"
        'A = f"""[[material]]\nname = "cortical"\nregions = ["c"]\nE = {E!r}\nsigma_t = {S}\n'
        '[[material]]\nname = "disc"\n# strength_pair_exception: not bone, R kept defined\n'
        'E = {X}\nsigma_t = 1.0e7\n[fracture]\n"""\n'
    )
    ((line, text),) = demo_scene_texts(demo)[0]
    cort, disc = material_tables(text, "demo")
    assert cort.keys == {"name": "cortical", "regions": ["c"], "E": 17.0e9, "sigma_t": 133.0e6}
    assert cort.exception is None and disc.exception == "not bone, R kept defined"
    assert disc.keys["E"] == "unresolved: X"
