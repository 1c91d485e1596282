"""Every relative reference in the documentation resolves, and nothing links outside.

The repository explains itself: the pages in ``docs/``, the demos' text, README.md,
benchmarks/README.md, CHANGELOG.md and data/ READMEs may refer to each other and to the
code, and every such reference must name a file that exists.  Two forms are checked:

* Markdown links ``[text](target)`` — resolved from the file that holds them; a link
  with a scheme (``https:`` …) is refused (no link to anything outside the repository);
* code spans that name a repository path (```docs/theory/pdas.md```,
  ```tests/unit/contact/test_pdas.py```) — resolved from the repository root.  Patterns
  (``*``, ``<name>``) are skipped, and so is ``docs/api/``, which ``make docs`` generates.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

#: source analysis: nothing collective, so it runs in the serial session only
pytestmark = pytest.mark.serial

ROOT = Path(__file__).resolve().parents[2]

LINK = re.compile(r"\]\(([^)\s#]+)(#[^)]*)?\)")
SPAN = re.compile(r"`((?:docs|demos|data|benchmarks|tests|bonecontact|forms)/[\w/.\-]+)`")
GENERATED = ("docs/api",)


def documents() -> list[Path]:
    """The files whose text is documentation."""
    files = [
        *ROOT.glob("docs/**/*.md"),
        *ROOT.glob("demos/*.py"),
        *ROOT.glob("data/**/*.md"),
        ROOT / "README.md",
        ROOT / "benchmarks" / "README.md",
        ROOT / "CHANGELOG.md",
    ]
    return sorted(f for f in files if not f.relative_to(ROOT).as_posix().startswith(GENERATED))


def broken_references(path: Path) -> list[str]:
    """The references in ``path`` that do not resolve (or leave the repository)."""
    text = path.read_text(encoding="utf-8")
    broken = []
    for match in LINK.finditer(text):
        target = match.group(1)
        if re.match(r"[a-z][a-z0-9+.-]*:", target):
            broken.append(f"external link {target}")
        elif not (path.parent / target).exists():
            broken.append(f"link {target}")
    for match in SPAN.finditer(text):
        target = match.group(1)
        if any(c in target for c in "*<") or target.startswith(GENERATED):
            continue
        if not (ROOT / target).exists():
            broken.append(f"path {target}")
    return broken


def test_documents_found() -> None:
    """The scan sees the documentation (a glob that finds nothing would pass vacuously)."""
    names = {f.relative_to(ROOT).as_posix() for f in documents()}
    assert {"README.md", "docs/scene_format.md", "docs/theory/pdas.md"} <= names
    assert len(names) > 20


@pytest.mark.parametrize("path", documents(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_references_resolve(path: Path) -> None:
    """Every link and repository path named in ``path`` exists."""
    assert broken_references(path) == []


def test_a_broken_reference_is_found(tmp_path: Path) -> None:
    """The checker itself: a missing page, a missing path and an external link are found."""
    page = tmp_path / "page.md"
    page.write_text(
        "[a](missing.md) see `docs/theory/nothing.md` and [b](https://example.org)\n"
        "`docs/theory/pdas.md` exists, `data/scenes/<name>.toml` is a pattern\n",
        encoding="utf-8",
    )
    assert broken_references(page) == [
        "link missing.md",
        "external link https://example.org",
        "path docs/theory/nothing.md",
    ]
