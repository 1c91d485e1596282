"""The package's import structure: no cycles, imports one way down the layers.

The modules of ``bonecontact`` are parsed (not imported) and every import of another
``bonecontact`` module becomes an edge of a directed graph.  Imports under
``if TYPE_CHECKING:`` are left out: they do not run.  The tests fail on

* any cycle between modules (a strongly connected component with more than one module,
  or a module importing itself);
* an import that goes up the layers (``LAYERS`` below, lowest first);
* a ``bonecontact`` import inside a function (it would hide a cycle);
* a private name (leading underscore) imported from another module.
* a function longer than ``MAX_FUNCTION_LINES`` (split it into named steps);
* ``obj._name`` where ``obj`` is not ``self``/``cls``: no module reads the private
  attributes of another object.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

#: source analysis: nothing collective, so it runs in the serial session only
pytestmark = pytest.mark.serial

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "bonecontact"
FORMS = ROOT / "forms"

#: Subpackages from the bottom up: a module may import its own layer or a lower one.
LAYERS = [
    "forms",
    "common",
    "materials",
    "mechanics",
    "contact",
    "meshing",
    "neoplasm",
    "fracture",
    "scene",
    "plot",
    "runners",
    # problem builders and closed forms for tests and benchmarks: they may drive whole
    # runs (the robustness matrix runs scenes), and no other subpackage imports them
    "verification",
]


def _module_name(path: Path) -> str:
    if path.is_relative_to(FORMS):
        parts = ["bonecontact", "forms", *path.relative_to(FORMS).with_suffix("").parts]
    else:
        parts = ["bonecontact", *path.relative_to(PACKAGE).with_suffix("").parts]
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    files = sorted(PACKAGE.rglob("*.py")) + sorted(FORMS.rglob("*.py"))
    return {_module_name(p): p for p in files if "__pycache__" not in p.parts}


MODULES = _modules()


def _resolve(module: str, name: str | None, current: str, level: int, is_pkg: bool) -> list[str]:
    """The ``bonecontact`` modules an import statement refers to (empty if external)."""
    if level:
        base = current.split(".")
        base = base[: len(base) - level + (1 if is_pkg else 0)]
        module = ".".join(base + ([module] if module else []))
    if not module.startswith("bonecontact"):
        return []
    if name is not None and f"{module}.{name}" in MODULES:
        return [f"{module}.{name}"]
    return [module] if module in MODULES else []


def _is_type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING"
    )


def _imports(path: Path) -> Iterator[tuple[ast.Import | ast.ImportFrom, bool]]:
    """Every runtime import statement of a file, with whether it sits inside a function."""

    def visit(
        node: ast.AST, in_function: bool
    ) -> Iterator[tuple[ast.Import | ast.ImportFrom, bool]]:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child):
                for other in child.orelse:
                    yield from visit(other, in_function)
                continue
            if isinstance(child, ast.Import | ast.ImportFrom):
                yield child, in_function
            yield from visit(
                child,
                in_function
                or isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda),
            )

    yield from visit(ast.parse(path.read_text(), filename=str(path)), False)


def _edges() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {m: set() for m in MODULES}
    for mod, path in MODULES.items():
        is_pkg = path.name == "__init__.py"
        for node, _ in _imports(path):
            if isinstance(node, ast.Import):
                targets = [t for a in node.names for t in _resolve(a.name, None, mod, 0, is_pkg)]
            else:
                targets = [
                    t
                    for a in node.names
                    for t in _resolve(node.module or "", a.name, mod, node.level, is_pkg)
                ]
            graph[mod].update(t for t in targets if t != "bonecontact")
    return graph


def _layer(module: str) -> int | None:
    parts = module.split(".")
    return LAYERS.index(parts[1]) if len(parts) > 1 and parts[1] in LAYERS else None


def _strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's algorithm (iterative): the strongly connected components of the graph."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []
    counter = 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        m = stack.pop()
                        on_stack.discard(m)
                        component.append(m)
                        if m == node:
                            break
                    components.append(component)
    return components


def test_the_parser_sees_the_package():
    """The scan finds the subpackages and real edges (so the checks below can fail)."""
    graph = _edges()
    assert len(MODULES) > 30
    assert {m.split(".")[1] for m in MODULES if m.count(".")} >= set(LAYERS)
    assert "bonecontact.runners.cli" in MODULES
    assert sum(len(v) for v in graph.values()) > 40


def test_tarjan_finds_a_planted_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    components = [sorted(c) for c in _strongly_connected(graph) if len(c) > 1]
    assert components == [["a", "b", "c"]]


def test_no_import_cycle():
    graph = _edges()
    cycles = [sorted(c) for c in _strongly_connected(graph) if len(c) > 1]
    cycles += [[m] for m, targets in graph.items() if m in targets]
    assert not cycles, f"import cycles between modules: {cycles}"


def test_imports_run_down_the_layers():
    upward = []
    for mod, targets in _edges().items():
        here = _layer(mod)
        if here is None:
            continue
        for t in targets:
            there = _layer(t)
            if there is not None and there > here:
                upward.append(f"{mod} -> {t}")
    assert not upward, "imports that go up the layers " + " < ".join(LAYERS) + f": {upward}"


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_package_import_inside_a_function(module):
    path = MODULES[module]
    inner = [
        f"{path.relative_to(ROOT)}:{node.lineno}"
        for node, in_function in _imports(path)
        if in_function and _is_internal(node)
    ]
    assert not inner, f"bonecontact imported inside a function (move it to the top): {inner}"


def _is_internal(node: ast.Import | ast.ImportFrom) -> bool:
    if isinstance(node, ast.Import):
        return any(a.name.startswith("bonecontact") for a in node.names)
    return node.level > 0 or (node.module or "").startswith("bonecontact")


def test_no_private_name_imported_from_another_module():
    private = []
    for mod, path in MODULES.items():
        for node, _ in _imports(path):
            if isinstance(node, ast.ImportFrom) and _is_internal(node):
                private += [
                    f"{mod}: {node.module}.{a.name}"
                    for a in node.names
                    if a.name.startswith("_") and a.name != "__version__"
                ]
    assert not private, f"private names used across modules: {private}"


def _private_uses(path: Path) -> list[str]:
    """Private names a script takes from ``bonecontact``: imported, or as ``module._name``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    aliases: set[str] = set()
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            aliases |= {
                a.asname or a.name.split(".")[0]
                for a in node.names
                if a.name.startswith("bonecontact")
            }
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("bonecontact"):
            for a in node.names:
                if a.name.startswith("_") and not a.name.startswith("__"):
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.module}.{a.name}")
                if f"{node.module}.{a.name}" in MODULES:
                    aliases.add(a.asname or a.name)
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in aliases
            and node.attr.startswith("_")
            and not node.attr.startswith("__")
        ):
            found.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.value.id}.{node.attr}")
    return found


def test_tests_benchmarks_and_demos_use_the_public_api():
    scripts = [
        p
        for d in ("tests", "benchmarks", "demos")
        for p in sorted((ROOT / d).rglob("*.py"))
        if "__pycache__" not in p.parts
    ]
    assert len(scripts) > 20
    private = [use for p in scripts for use in _private_uses(p)]
    assert not private, f"private bonecontact names used outside the package: {private}"


#: The longest function the package may hold (lines, docstring included): a longer one is
#: split into named steps.
MAX_FUNCTION_LINES = 100


def _function_lengths(path: Path) -> Iterator[tuple[str, int, int]]:
    """``(name, first line, length)`` of every function and method of a file."""
    tree = ast.parse(path.read_text(), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            yield node.name, node.lineno, node.end_lineno - node.lineno + 1


def test_the_length_scan_measures_functions():
    """The scan counts a function's lines from ``def`` to its last line (so it can fail)."""
    lengths = {name: n for name, _, n in _function_lengths(Path(__file__))}
    assert lengths["test_the_length_scan_measures_functions"] == 4


def test_no_function_longer_than_the_limit():
    long = [
        f"{path.relative_to(ROOT)}:{line} {name} ({n} lines)"
        for path in MODULES.values()
        for name, line, n in _function_lengths(path)
        if n > MAX_FUNCTION_LINES
    ]
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines (split them): {long}"


def _foreign_private_attributes(source: str) -> list[tuple[int, str]]:
    """``(line, "obj._name")`` where ``obj`` is not ``self``/``cls``: another object's private."""
    return [
        (node.lineno, f"{ast.unparse(node.value)}.{node.attr}")
        for node in ast.walk(ast.parse(source))
        if isinstance(node, ast.Attribute)
        and node.attr.startswith("_")
        and not node.attr.startswith("__")
        and not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"))
    ]


def test_the_attribute_scan_finds_a_planted_access():
    source = "def f(solver):\n    return solver._gap + self._own + solver.model._w + x.__len__\n"
    assert sorted(_foreign_private_attributes(source)) == [
        (2, "solver._gap"),
        (2, "solver.model._w"),
    ]


def test_no_private_attribute_of_another_object_is_read():
    found = [
        f"{path.relative_to(ROOT)}:{line} {use}"
        for path in MODULES.values()
        for line, use in _foreign_private_attributes(path.read_text())
    ]
    assert not found, f"private attributes read from outside their object: {found}"


#: A module docstring says what the module is for and points at the theory page; the
#: maths lives once, in docs/theory (issue 25: "module docstrings short").
MAX_MODULE_DOCSTRING_LINES = 25


def _module_docstring_lines(source: str) -> int:
    """Lines of a module's docstring, its quotes included (0 without one)."""
    tree = ast.parse(source)
    first = tree.body[0] if tree.body else None
    if not (isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)):
        return 0
    if not isinstance(first.value.value, str):
        return 0
    return first.end_lineno - first.lineno + 1


def test_the_docstring_scan_counts_lines():
    assert _module_docstring_lines('"""One.\n\nTwo\nthree.\n"""\nx = 1\n') == 5
    assert _module_docstring_lines('"""One line."""\n') == 1
    assert _module_docstring_lines("x = 1\n") == 0


def test_module_docstrings_are_short():
    long = [
        f"{path.relative_to(ROOT)} ({n} lines)"
        for path in MODULES.values()
        if (n := _module_docstring_lines(path.read_text())) > MAX_MODULE_DOCSTRING_LINES
    ]
    assert not long, (
        f"module docstrings over {MAX_MODULE_DOCSTRING_LINES} lines (move the maths to "
        f"docs/theory and point at it): {long}"
    )
