"""The one exit-status table (bonecontact.scene.errors) and the exception types mapped to it.

* Every exception type the package defines (found by parsing every module, so a new type
  cannot be forgotten) has an exit status, and it agrees with the type's Python base, an
  independent classification: a ``ValueError`` is refused input (2), a ``RuntimeError`` a
  computation that cannot go on (1), a checkpoint or scene error 2.
* A finished run's status gives the status the command returns (converged 0, failed 1,
  invalid 3, interrupted 128 + the signal's number from the ``signal`` module).
* docs/scene_format.md shows exactly the rows of the table.
* The merged meshing failure: ``RemeshError`` is ``MeshingError``.
"""

from __future__ import annotations

import ast
import importlib
import re
import signal
from pathlib import Path

import pytest

from bonecontact.common.errors import EXIT_CODES, ExitCode
from bonecontact.scene.errors import (
    CheckpointError,
    SceneError,
    error_exit_code,
    exit_code,
    exit_code_for_status,
)

pytestmark = pytest.mark.serial

ROOT = Path(__file__).resolve().parents[3]
PACKAGE = ROOT / "bonecontact"


def _exception_classes() -> list[tuple[str, str]]:
    """(module, class name) of every class in the package whose name ends in Error."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        module = ".".join(("bonecontact", *path.relative_to(PACKAGE).with_suffix("").parts))
        module = module.removesuffix(".__init__")
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef) and node.name.endswith("Error"):
                out.append((module, node.name))
    return out


CLASSES = _exception_classes()


def test_the_package_defines_a_small_set_of_types():
    names = {name for _, name in CLASSES}
    assert "RemeshError" not in names  # merged into MeshingError
    assert {"InputError", "RunError", "CheckpointError", "SceneError"} <= names
    assert len(CLASSES) == len(names)  # no name defined twice


@pytest.mark.parametrize(("module", "name"), CLASSES, ids=[n for _, n in CLASSES])
def test_every_exception_type_has_its_exit_status(module: str, name: str):
    kind = getattr(importlib.import_module(module), name)
    code = error_exit_code(kind)
    assert code in EXIT_CODES, f"{module}.{name} has no exit status"
    if issubclass(kind, (SceneError, CheckpointError)):
        expected = ExitCode.BAD_INPUT
    elif issubclass(kind, ValueError):
        expected = ExitCode.BAD_INPUT
    elif issubclass(kind, RuntimeError):
        expected = ExitCode.FAILED
    else:
        expected = kind.exit_code  # the common base
    assert code == expected


def test_remesh_error_is_the_meshing_error():
    from bonecontact.meshing import MeshingError
    from bonecontact.neoplasm import RemeshError

    assert RemeshError is MeshingError
    assert exit_code(RemeshError("gmsh failed")) == 1


@pytest.mark.parametrize(
    ("exc", "code"),
    [
        (SceneError("s.toml", "[analysis]", "dt", "must be > 0"), 2),
        (CheckpointError("no intact checkpoint in out/checkpoints"), 2),
        (UserWarning("E = 17 Pa: did you mean 17 GPa?"), 2),  # --strict
        (KeyboardInterrupt(), 128 + signal.SIGINT),
        (ZeroDivisionError("internal"), 1),
        (ValueError("not one of ours: internal"), 1),
    ],
)
def test_exit_code_of_an_exception(exc: BaseException, code: int):
    assert exit_code(exc) == code


@pytest.mark.parametrize(
    ("status", "sig", "code"),
    [
        ("converged", None, 0),
        ("failed", None, 1),
        ("invalid", None, 3),
        ("interrupted", "SIGTERM", 128 + signal.SIGTERM),
        ("interrupted", "SIGINT", 128 + signal.SIGINT),
        ("interrupted", None, 128 + signal.SIGINT),
        ("something new", None, 1),
    ],
)
def test_exit_code_of_a_run_status(status: str, sig: str | None, code: int):
    assert exit_code_for_status(status, sig) == code


def test_the_documented_table_is_the_table():
    text = (ROOT / "docs" / "scene_format.md").read_text()
    section = text[text.index("### Exit status") :]
    rows = re.findall(r"^\| `(\d+)[^`]*` \|", section, flags=re.M)
    assert [int(r) for r in rows] == sorted(int(c) for c in EXIT_CODES)


def _documented_types() -> dict[int, set[str]]:
    """Exit status -> the exception type names listed under it in docs/scene_format.md."""
    text = (ROOT / "docs" / "scene_format.md").read_text()
    section = text[text.index("Exception types, under their exit status") :]
    section = section[: section.index("\n\n", section.index("- status 1"))]
    items = re.split(r"^- status (\d+)", section, flags=re.M)[1:]
    return {
        int(code): set(re.findall(r"`(\w+Error)`", body)) for code, body in zip(*[iter(items)] * 2)
    }


def _type_by_name(name: str) -> type:
    import bonecontact.common.errors as common
    import bonecontact.contact as contact
    import bonecontact.fracture as fracture
    import bonecontact.materials as materials
    import bonecontact.meshing as meshing
    import bonecontact.neoplasm as neoplasm
    import bonecontact.runners.results as results
    import bonecontact.scene.errors as scene_errors
    import bonecontact.scene.expressions as expressions

    modules = (common, scene_errors, contact, fracture, materials, meshing, neoplasm)
    for module in (*modules, results, expressions):
        if hasattr(module, name):
            return getattr(module, name)
    raise AssertionError(f"{name} is documented but not defined")


def test_the_documented_types_are_the_types():
    """Every type named under a status in docs/scene_format.md has that status, and every
    row of ERROR_EXIT_CODES is named under its status."""
    from bonecontact.scene.errors import ERROR_EXIT_CODES

    documented = _documented_types()
    assert set(documented) == {ExitCode.FAILED, ExitCode.BAD_INPUT}
    for code, names in documented.items():
        for name in names:
            assert error_exit_code(_type_by_name(name)) == code, name
    for kind, code in ERROR_EXIT_CODES.items():
        assert kind.__name__ in documented[int(code)], kind.__name__


def test_the_deprecated_names_are_the_one_types():
    """The former parameter error types are one ParameterError with the same messages; the
    former empty RunError subclasses are RunError."""
    from bonecontact.common.errors import ParameterError, RunError
    from bonecontact.fracture import FractureError
    from bonecontact.materials import Isotropic, MaterialError
    from bonecontact.neoplasm import (
        CoverageError,
        CystParameterError,
        CystParameters,
        TumourError,
        TumourParameterError,
        TumourParameters,
    )

    assert MaterialError is FractureError is ParameterError
    assert CystParameterError is TumourParameterError is ParameterError
    assert TumourError is CoverageError is RunError
    assert exit_code(FractureError("a", "must be > 0, got 0.0")) == ExitCode.BAD_INPUT
    assert str(FractureError("a", "must be > 0, got 0.0")) == "a: must be > 0, got 0.0"
    with pytest.raises(MaterialError) as material:
        Isotropic(E=-1.0, nu=0.3)
    assert str(material.value) == "must be a positive number, got -1.0"
    with pytest.raises(CystParameterError) as cyst:
        CystParameters(beta=-1.0, C_minus=1.0)
    assert str(cyst.value) == "cyst parameter beta must be >= 0, got -1.0"
    with pytest.raises(TumourParameterError) as tumour:
        TumourParameters.from_dict({"u_p0": 2.0})
    assert str(tumour.value) == "[neoplasm.tumour]: 'u_p0' must satisfy 0 <= u_p0 <= 1, got 2.0"
    assert (tumour.value.key, tumour.value.message) == (
        "u_p0",
        "must satisfy 0 <= u_p0 <= 1, got 2.0",
    )
