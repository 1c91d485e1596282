"""Serial runs of crack scenes kept for the later sessions of one ``make test``.

``make test`` runs the suite serially, then on 2 and on 3 ranks.  The rank-count tests
compare a distributed run with the serial run of the same scene; without this store each
MPI session runs that serial reference again on rank 0 (the other ranks idle), although
the serial session (or the 2-rank session) already ran the same scene with the same code.

With the environment variable :data:`STORE` naming a folder, a serial run of a fracture
scene (its summary.json has a ``fracture`` entry; its field output left out) is copied
there under a key, and a later serial reference of the same key is copied back instead
of being run again.  The key is the
SHA-256 of: every file of the package (``bonecontact``, its ``forms`` and ``data``), the
versions of DOLFINx, PETSc and gmsh, the scene text with every quoted path of an existing
file replaced by the SHA-256 of that file's bytes (the mesh; the temporary folders differ
between sessions), and the run's keyword arguments.  Anything else that differs makes
another key: the reference is then run as before.  Unset (plain ``pytest``): nothing is
stored or read.  The Makefile empties the folder at the start of ``make test``.

Not a test module (no ``test_`` prefix); imported by name (pytest puts this folder on
``sys.path``).
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import re
import shutil
import uuid
from pathlib import Path

import petsc4py

import dolfinx
import gmsh

import bonecontact
import bonecontact.data
import bonecontact.forms
from bonecontact.runners import RunResult

#: The environment variable naming the folder of the stored serial runs (unset: none).
STORE = "BONECONTACT_TEST_SERIAL_STORE"
#: Not stored: the field output (tens of MB a run; no rank comparison reads a reference's
#: fields: one that did would fail on the missing file, not pass).
FIELD_FILES = shutil.ignore_patterns("fields.*", "fields_*")


@functools.cache
def code_digest() -> str:
    """SHA-256 of every file of the package (``__pycache__`` left out) and of the versions
    of the libraries the runs use."""
    h = hashlib.sha256()
    h.update(f"{dolfinx.__version__} {petsc4py.__version__} {gmsh.__version__}".encode())
    for pkg in (bonecontact, bonecontact.forms, bonecontact.data):
        root = Path(pkg.__path__[0])
        for path in sorted(root.rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                h.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
    return h.hexdigest()


def scene_key(scene: Path, **kw) -> str:
    """The key of the run of ``scene`` with the keyword arguments ``kw`` (see the module)."""

    def content(m: re.Match) -> str:
        path = scene.parent / m.group(1)
        if m.group(1) and path.is_file():
            return '"sha256:' + hashlib.sha256(path.read_bytes()).hexdigest() + '"'
        return m.group(0)

    text = re.sub(r'"([^"\n]*)"', content, scene.read_text())
    extra = json.dumps(sorted((k, repr(v)) for k, v in kw.items()))
    return hashlib.sha256((code_digest() + "\0" + text + "\0" + extra).encode()).hexdigest()


def _folder() -> Path | None:
    name = os.environ.get(STORE, "")
    return Path(name) if name else None


def keep(scene: Path, out: Path, **kw) -> None:
    """On one rank: the converged serial fracture run of ``scene`` in ``out`` copied to
    the store (nothing without a store, for a failed run or one whose summary has no
    ``fracture`` entry)."""
    folder = _folder()
    summary = out / "summary.json"
    if folder is None or not summary.is_file():
        return
    data = json.loads(summary.read_text())
    if data.get("status") != "converged" or "fracture" not in data:
        return
    target = folder / scene_key(scene, **kw)
    if target.exists():
        return
    part = folder / f"{target.name}.{uuid.uuid4().hex}.part"
    shutil.copytree(out, part, ignore=FIELD_FILES)
    try:
        part.rename(target)  # whole or not at all; another process may have kept it first
    except OSError:
        shutil.rmtree(part, ignore_errors=True)


def fetch(scene: Path, out: Path, **kw) -> RunResult | None:
    """On one rank: the stored serial run of ``scene`` copied into ``out`` and its
    result (status and summary from summary.json), or ``None`` if none is stored."""
    folder = _folder()
    if folder is None:
        return None
    stored = folder / scene_key(scene, **kw)
    if not stored.is_dir():
        return None
    shutil.copytree(stored, out, dirs_exist_ok=True)
    summary = json.loads((out / "summary.json").read_text())
    return RunResult(summary["status"], summary, None, out)
