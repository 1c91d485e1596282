"""What a mesh command made: cells, vertices, groups and their measures, repairs, frame.

:func:`msh_report` reads a gmsh ``.msh`` file (on the calling rank, serially) and measures
every physical group from the file's own nodes: the area of a facet group of a 3D mesh (the
length of one of a 2D mesh), the volume of a cell group (area in 2D).  The mesh commands
(``bonecontact mesh-surface``, ``bonecontact mesh-ct``) add what they know about the input
(its volume or area, the repairs made) and print :func:`format_report`.

Coordinate frame: the package takes every file's axes as they are (nothing is rotated);
every mesh of the package has y up (gravity and body-weight loads along −y,
``docs/meshing.md``).  The report names the bounding box and the axis of the largest extent
(a long bone's shaft) so that a file in another frame or in millimetres is seen at once.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from mpi4py import MPI

import gmsh
import numpy as np

from bonecontact.meshing.builder import MeshingError
from bonecontact.meshing.session import gmsh_session
from bonecontact.meshing.surface_repair import MeshInputError

__all__ = ["GroupMeasure", "MeshReport", "format_report", "msh_report"]

#: gmsh element types measured: 1 line, 2 triangle, 4 tetrahedron
_SIMPLEX = {1: 1, 2: 2, 4: 3}


@dataclass(frozen=True)
class GroupMeasure:
    """One physical group: name, dimension, number of entities, measure (m, m² or m³)."""

    name: str
    dim: int
    count: int
    measure: float


@dataclass(frozen=True)
class MeshReport:
    """The summary of a written mesh.

    ``input_measure`` is the volume (3D) or area (2D) enclosed by the input (the surface
    before remeshing, the segmented CT polygons); ``volume_change`` the relative change
    from it to the mesh's cells; ``repairs`` every change made to the input;
    ``notes`` other facts (bodies dropped, the groups' rule).
    """

    path: str
    dim: int
    cells: int
    vertices: int
    groups: tuple[GroupMeasure, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    input_measure: float | None = None
    repairs: tuple[str, ...] = ()
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def cell_measure(self) -> float:
        """Volume (3D) or area (2D) of the cells of every cell group."""
        return sum(g.measure for g in self.groups if g.dim == self.dim)

    @property
    def volume_change(self) -> float | None:
        """``cell_measure / input_measure - 1`` (``None`` without an input measure)."""
        if not self.input_measure:
            return None
        return self.cell_measure / self.input_measure - 1.0

    @property
    def long_axis(self) -> str:
        """The axis (x, y, z) along which the bounding box is longest."""
        extent = np.subtract(self.upper, self.lower)
        return "xyz"[int(np.argmax(extent))]

    def group(self, name: str) -> GroupMeasure:
        """The group of that name (KeyError naming the groups there are)."""
        for g in self.groups:
            if g.name == name:
                return g
        raise KeyError(f"{self.path}: no group {name!r} (groups: {[g.name for g in self.groups]})")


def _simplex_measures(kind: int, nodes: np.ndarray, coords: dict[int, np.ndarray]) -> float:
    """Total length / area / volume of gmsh elements of one simplex type."""
    d = _SIMPLEX[kind]
    x = np.array([coords[t] for t in nodes]).reshape(-1, d + 1, 3)
    edges = x[:, 1:] - x[:, :1]
    if d == 1:
        return float(np.linalg.norm(edges[:, 0], axis=1).sum())
    if d == 2:
        return float(0.5 * np.linalg.norm(np.cross(edges[:, 0], edges[:, 1]), axis=1).sum())
    return float(np.abs(np.linalg.det(edges)).sum() / 6.0)


def _group_measure(dim: int, tag: int, coords: dict[int, np.ndarray]) -> tuple[int, float]:
    """Number of elements and total measure of a physical group of the current model."""
    count, total = 0, 0.0
    for entity in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
        kinds, _, nodes = gmsh.model.mesh.getElements(dim, int(entity))
        for kind, nd in zip(kinds, nodes):
            if int(kind) not in _SIMPLEX:
                raise ValueError(f"element type {kind} is not a simplex of order 1")
            count += len(nd) // (_SIMPLEX[int(kind)] + 1)
            total += _simplex_measures(int(kind), nd.tolist(), coords)
    return count, total


def msh_report(path: str | Path, **extra) -> MeshReport:
    """Read a gmsh file and measure its physical groups (serial, on the calling rank).

    ``extra`` are passed to :class:`MeshReport` (``input_measure``, ``repairs``, ``notes``).
    """
    with gmsh_session("report"):
        gmsh.open(str(path))
        tags, x, _ = gmsh.model.mesh.getNodes()
        x = np.asarray(x).reshape(-1, 3)
        coords = dict(zip(tags.tolist(), x))
        groups = []
        for dim, tag in gmsh.model.getPhysicalGroups():
            count, total = _group_measure(dim, tag, coords)
            name = gmsh.model.getPhysicalName(dim, tag) or f"{dim}:{tag}"
            groups.append(GroupMeasure(name, dim, count, total))
        mesh_dim = max(g.dim for g in groups) if groups else gmsh.model.getDimension()
        cells = sum(g.count for g in groups if g.dim == mesh_dim)
        lower, upper = x.min(axis=0)[:mesh_dim], x.max(axis=0)[:mesh_dim]
    return MeshReport(
        str(path),
        mesh_dim,
        cells,
        len(x),
        tuple(groups),
        tuple(map(float, lower)),
        tuple(map(float, upper)),
        **extra,
    )


def _units(dim: int) -> str:
    return {1: "m", 2: "m²", 3: "m³"}[dim]


def format_report(r: MeshReport) -> str:
    """The report as lines of text (what the mesh commands print)."""
    kind = {2: "triangles", 3: "tetrahedra"}.get(r.dim, "cells")
    lines = [f"{r.path}: written, {r.cells} {kind}, {r.vertices} vertices"]
    for g in r.groups:
        what = {1: "length", 2: "area", 3: "volume"}[g.dim]
        role = "cells" if g.dim == r.dim else "facets"
        lines.append(
            f"  group {g.name!r} ({role}, {g.count}): {what} {g.measure:.6g} {_units(g.dim)}"
        )
    if r.volume_change is not None:
        what = "volume" if r.dim == 3 else "area"
        lines.append(
            f"  {what}: input {r.input_measure:.6g} {_units(r.dim)}, mesh "
            f"{r.cell_measure:.6g} {_units(r.dim)}, change {100 * r.volume_change:+.3f} %"
        )
    lines.append("  repairs: " + ("; ".join(r.repairs) if r.repairs else "none"))
    lo = ", ".join(f"{v:.4g}" for v in r.lower)
    hi = ", ".join(f"{v:.4g}" for v in r.upper)
    size = " × ".join(f"{u - v:.4g}" for u, v in zip(r.upper, r.lower))
    lines.append(
        f"  frame: bounding box ({lo}) to ({hi}) m, {size} m; longest along {r.long_axis}; "
        "axes kept as in the input, y is up for loads and gravity (docs/meshing.md)"
    )
    lines.extend(f"  note: {n}" for n in r.notes)
    return "\n".join(lines)


def run_report_command(build: Callable[[], MeshReport | None], comm: MPI.Comm) -> int:
    """Run a mesh command's ``build`` (collective) and print its report on rank 0.

    Returns the exit status: 0, 2 for refused input (the message on rank 0), 1 if gmsh
    failed.
    """
    try:
        report = build()
    except (MeshInputError, ValueError) as exc:
        if comm.rank == 0:
            print(f"error: {exc}", file=sys.stderr)
        return 2
    except MeshingError as exc:
        if comm.rank == 0:
            print(f"error: {exc}", file=sys.stderr)
        return 1
    if report is not None:
        print(format_report(report))
    return 0
