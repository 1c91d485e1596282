"""gmsh's ``Crack`` plugin spoiled after one of its runs, for the crack-split tests
(test_crack_split.py in 3D, test_crack_split2d.py in 2D): each test file's ``_spoil``
says how to change the new face, this module when and on what.

Not a test module (no ``test_`` prefix); the tests import it by name (pytest puts this
folder on ``sys.path``).
"""

from __future__ import annotations

from collections.abc import Callable

import gmsh
import numpy as np


def facets(dim: int, entities) -> np.ndarray:
    """The segments (``dim`` 1) or triangles (``dim`` 2) of the gmsh ``entities``: one
    row of node tags each."""
    return np.vstack(
        [
            np.asarray(gmsh.model.mesh.getElementsByType(dim, e)[1], dtype=np.int64).reshape(
                -1, dim + 1
            )
            for e in entities
        ]
    )


def after_crack_plugin(monkeypatch, dim: int, call: int, spoil: Callable[..., None]) -> None:
    """After the ``call``-th run of the Crack plugin (of facets of dimension ``dim``),
    ``spoil(entity, tags, new, old)``: the new face's entity (the last physical group of
    dimension ``dim``), its elements' tags and nodes (:func:`facets`) and the nodes of
    the other face (the group before it)."""
    real = gmsh.plugin.run
    calls = []

    def run(name: str) -> None:
        real(name)
        calls.append(name)
        if name != "Crack" or len(calls) - 1 != call:
            return
        second = max(t for _, t in gmsh.model.getPhysicalGroups(dim))  # the new face's
        (entity,) = gmsh.model.getEntitiesForPhysicalGroup(dim, second)
        tags, _ = gmsh.model.mesh.getElementsByType(dim, entity)
        new = facets(dim, [entity])
        old = facets(dim, gmsh.model.getEntitiesForPhysicalGroup(dim, second - 1))
        spoil(entity, tags, new, old)

    monkeypatch.setattr(gmsh.plugin, "run", run)
