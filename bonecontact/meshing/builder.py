"""The gmsh plumbing shared by the mesh builders of :mod:`bonecontact.meshing.shapes` and
:mod:`bonecontact.meshing.anatomy`.

A builder describes its geometry, sizes and physical groups in a ``build`` callback;
:func:`generate` runs it on rank 0 of ``comm`` inside a
:func:`~bonecontact.meshing.session.gmsh_session`,
meshes, and either distributes the mesh (:class:`dolfinx.io.gmsh.MeshData`) or writes a
gmsh ``.msh`` file.  A gmsh error on rank 0 is raised as :class:`MeshingError` on every rank.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from contextlib import nullcontext
from pathlib import Path

from mpi4py import MPI

import gmsh
from dolfinx.io.gmsh import MeshData, model_to_mesh

from bonecontact.common.errors import RunError
from bonecontact.meshing.session import gmsh_session

__all__ = [
    "EPS",
    "MeshingError",
    "PhysicalGroups",
    "block_groups",
    "boundary_tags",
    "bounding_box",
    "check_positive",
    "entities_at",
    "generate",
    "set_size",
]

#: relative tolerance for picking entities by their centre of mass
EPS = 1e-9


class MeshingError(RunError):
    """gmsh failed to build or mesh a geometry."""


# ----------------------------------------------------------------------------- plumbing
def generate(
    name: str, dim: int, build: Callable[[], None], comm: MPI.Comm | None, path: str | Path | None
) -> MeshData | Path:
    """Run ``build`` (geometry, sizes, physical groups) on rank 0, mesh, then distribute or
    write."""
    comm = MPI.COMM_WORLD if comm is None else comm
    with gmsh_session(name) if comm.rank == 0 else nullcontext():
        error = None
        if comm.rank == 0:
            try:
                build()
                gmsh.model.mesh.generate(dim)
                if path is not None:
                    Path(path).parent.mkdir(parents=True, exist_ok=True)
                    gmsh.write(str(path))
            except Exception as exc:  # reported on every rank below
                error = f"{type(exc).__name__}: {exc}"
        error = comm.bcast(error, root=0)
        if error is not None:
            raise MeshingError(f"{name}: {error}")
        if path is not None:
            comm.barrier()
            return Path(path)
        return model_to_mesh(gmsh.model, comm, 0, gdim=dim)


def bounding_box(dim: int, tag: int) -> tuple[float, ...]:
    """``(xmin, ymin, zmin, xmax, ymax, zmax)`` of the entity (dim, tag)."""
    return gmsh.model.getBoundingBox(dim, tag)


def boundary_tags(dim: int, tag: int) -> list[int]:
    """Tags of the (dim-1)-entities bounding entity (dim, tag)."""
    return [abs(t) for _, t in gmsh.model.getBoundary([(dim, tag)], combined=False, oriented=False)]


def entities_at(tags: list[int], dim: int, axis: int, value: float, scale: float) -> list[int]:
    """The entities among ``tags`` whose centre of mass has ``x[axis] = value``.

    (For the axis-aligned faces of a block this picks exactly the face in that plane; OCC
    bounding boxes are padded by its tolerance, centres of mass are not.)
    """
    tol = EPS * scale
    return [t for t in tags if abs(gmsh.model.occ.getCenterOfMass(dim, t)[axis] - value) < tol]


def set_size(dimtags: list[tuple[int, int]], h: float) -> None:
    """Target size ``h`` at every point of the given entities."""
    points = gmsh.model.getBoundary(dimtags, combined=False, oriented=False, recursive=True)
    gmsh.model.mesh.setSize(points, h)


class PhysicalGroups:
    """Adds named physical groups with tags that are unique over all dimensions."""

    def __init__(self) -> None:
        self._next = 1

    def __call__(self, dim: int, tags: list[int], name: str) -> None:
        if not tags:
            raise MeshingError(f"physical group {name!r} would be empty")
        gmsh.model.addPhysicalGroup(dim, sorted(set(tags)), self._next, name=name)
        self._next += 1


def check_positive(**values: float) -> None:
    """Raise ValueError naming the first keyword whose value is not a finite positive number."""
    for key, v in values.items():
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"{key} must be a positive number (SI units), got {v!r}")


def block_groups(
    groups: PhysicalGroups,
    dim: int,
    tag: int,
    prefix: str,
    lo: tuple[float, ...],
    hi: tuple[float, ...],
    scale: float,
    names: dict[str, str] | None = None,
) -> None:
    """Tag the faces of an axis-aligned block by side: left/right (x), bottom/top (y),
    front/back (z, 3D), named ``prefix + side`` unless ``names`` renames a side."""
    sides = boundary_tags(dim, tag)
    names = names or {}
    for axis, (low, high) in enumerate(
        (("left", "right"), ("bottom", "top"), ("front", "back"))[:dim]
    ):
        for side, value in ((low, lo[axis]), (high, hi[axis])):
            groups(
                dim - 1,
                entities_at(sides, dim - 1, axis, value, scale),
                names.get(side, prefix + side),
            )
