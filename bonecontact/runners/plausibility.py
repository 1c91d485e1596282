"""Plausibility of a scene on its mesh, and the small-strain check of a result.

Before solving, :func:`scene_issues` measures what the checks of
:func:`bonecontact.scene.checks.check_plausibility` need from the mesh (its bounding box and
the materials next to each facet group) and :func:`emit` turns the findings into
:class:`~bonecontact.scene.checks.PlausibilityWarning` (``warnings.simplefilter("error",
PlausibilityWarning)`` or ``bonecontact run --strict`` makes them errors).  After solving,
:class:`StrainMonitor` holds the largest principal strain reached; above
:data:`SMALL_STRAIN_LIMIT` the result is outside small-strain validity and the summary says so.
:func:`count_bodies` counts the connected pieces of a mesh (for ``bonecontact check``).

Everything here is collective on the mesh's communicator and gives the same answer on
every rank.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import Any

from mpi4py import MPI

import numpy as np
import ufl
from dolfinx import fem

from bonecontact.scene import Scene
from bonecontact.scene.checks import PlausibilityIssue, PlausibilityWarning, check_plausibility
from bonecontact.scene.rigid_motions import find_bodies

__all__ = [
    "SMALL_STRAIN_LIMIT",
    "StrainMonitor",
    "count_bodies",
    "emit",
    "facet_materials",
    "mesh_extent",
    "scene_issues",
]

#: A computed principal strain above this is outside the small-strain model's validity.
SMALL_STRAIN_LIMIT = 0.5


def mesh_extent(mesh: Any, comm: MPI.Comm) -> list[float]:
    """Size of the mesh's bounding box along each axis (m), over all ranks."""
    gdim = mesh.geometry.dim
    x = mesh.geometry.x[:, :gdim]
    lo = x.min(axis=0) if len(x) else np.full(gdim, np.inf)
    hi = x.max(axis=0) if len(x) else np.full(gdim, -np.inf)
    glo, ghi = np.empty(gdim), np.empty(gdim)
    comm.Allreduce(np.ascontiguousarray(lo, dtype=np.float64), glo, op=MPI.MIN)
    comm.Allreduce(np.ascontiguousarray(hi, dtype=np.float64), ghi, op=MPI.MAX)
    return [float(v) for v in ghi - glo]


def facet_materials(
    scene: Scene, md: Any, groups: Mapping[str, tuple[int, int]], comm: MPI.Comm
) -> dict[str, tuple[str, ...]]:
    """Facet group → names of the materials of the cells next to it (all ranks)."""
    mesh = md.mesh
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    n_cells = mesh.topology.index_map(tdim).size_local + mesh.topology.index_map(tdim).num_ghosts
    cell_tag = np.full(n_cells, -1, dtype=np.int64)
    cell_tag[md.cell_tags.indices] = md.cell_tags.values
    material = {groups[r][1]: m.name for m in scene.materials for r in m.regions if r in groups}
    out: dict[str, tuple[str, ...]] = {}
    for name, (dim, tag) in sorted(groups.items()):
        if dim != tdim - 1:
            continue
        facets = md.facet_tags.find(tag)
        cells = np.concatenate([f2c.links(f) for f in facets]) if len(facets) else []
        tags = {int(t) for t in np.unique(cell_tag[np.asarray(cells, dtype=np.int64)])}
        tags = set().union(*comm.allgather(tags))
        out[name] = tuple(sorted({material[t] for t in tags if t in material}))
    return out


def scene_issues(
    scene: Scene, md: Any, groups: Mapping[str, tuple[int, int]], comm: MPI.Comm
) -> list[PlausibilityIssue]:
    """Every plausibility finding of a scene on its mesh (collective)."""
    extent = mesh_extent(md.mesh, comm)
    return check_plausibility(scene, extent, facet_materials(scene, md, groups, comm))


def emit(issues: Sequence[PlausibilityIssue]) -> None:
    """One :class:`PlausibilityWarning` listing every finding, on every rank (so that an
    ``"error"`` warnings filter raises on every rank at the same point, with all of them)."""
    if not issues:
        return
    if len(issues) == 1:
        text = f"implausible value: {issues[0]}"
    else:
        text = f"{len(issues)} implausible values:\n" + "\n".join(f"  - {i}" for i in issues)
    warnings.warn(text, PlausibilityWarning, stacklevel=3)


def count_bodies(mesh: Any, comm: MPI.Comm) -> int:
    """The number of connected pieces of a mesh (cells sharing a vertex are connected;
    :func:`bonecontact.scene.rigid_motions.find_bodies`, which joins the pieces of the
    ranks through the vertices on the partition boundary only)."""
    return find_bodies(mesh, None, {}, comm).count


class StrainMonitor:
    """The largest principal strain (absolute value) of a displacement field over a run.

    Parameters
    ----------
    u
        The displacement (P1 here, so the strain is constant in each cell and the cell
        value is exact).
    """

    def __init__(self, u: fem.Function):
        mesh = u.function_space.mesh
        gdim = mesh.geometry.dim
        T = fem.functionspace(mesh, ("DG", 0, (gdim, gdim)))
        self._eps = fem.Function(T)
        self._expr = fem.Expression(ufl.sym(ufl.grad(u)), T.element.interpolation_points)
        self._n_owned = mesh.topology.index_map(mesh.topology.dim).size_local
        self._comm = mesh.comm
        self._gdim = gdim
        self.max_strain = 0.0

    def update(self) -> float:
        """Evaluate the current state; return the largest principal strain so far (collective)."""
        self._eps.interpolate(self._expr)
        e = self._eps.x.array.reshape(-1, self._gdim, self._gdim)[: self._n_owned]
        local = float(np.abs(np.linalg.eigvalsh(e)).max()) if len(e) else 0.0
        self.max_strain = max(self.max_strain, self._comm.allreduce(local, op=MPI.MAX))
        return self.max_strain

    def summary(self) -> dict[str, Any]:
        """The summary.json entries: ``max_strain`` and ``small_strain_valid``."""
        return {
            "max_strain": self.max_strain,
            "small_strain_valid": bool(self.max_strain <= SMALL_STRAIN_LIMIT),
        }
