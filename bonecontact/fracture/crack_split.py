"""A check of a crack surface's split into two faces (gmsh, rank 0).

gmsh's ``Crack`` plugin duplicates the nodes of a crack surface but the front's and sides
each cell by the node's mean normal; it reports nothing when it leaves a triangle unsplit
(seen at a sharp kink near a body's surface: both face groups whole, but the cells on
both sides of one triangle kept the same nodes, so the triangle is glued, one copy a face
of two cells and the other of none; DOLFINx's faces are then short of it: a wrong K with
no error).  :func:`check_crack_split` compares the faces after the split with the crack
surface before it: each face's area must equal the surface's (``SPLIT_AREA_TOL``
relative), the faces may share only the front's nodes, and every face triangle must be a
face of exactly one tetrahedron; otherwise a
:class:`~bonecontact.meshing.builder.MeshingError` names the crack.
"""

from __future__ import annotations

from dataclasses import dataclass

import gmsh
import numpy as np
import numpy.typing as npt

from bonecontact.meshing.builder import MeshingError

__all__ = ["SPLIT_AREA_TOL", "CrackSurface", "check_crack_split", "crack_surface"]

#: the largest relative difference between a face's area and the crack surface's
SPLIT_AREA_TOL = 1e-9


@dataclass(frozen=True)
class CrackSurface:
    """The crack surface as meshed, before its split.

    Attributes
    ----------
    area
        The sum of its triangles' areas (m²).
    front
        gmsh tags of its front nodes (those of the edges of one triangle that are not
        the mouth's): the nodes the two faces keep in common.
    """

    area: float
    front: frozenset[int]


def _nodes() -> npt.NDArray[np.float64]:
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    X = np.zeros((int(tags.max()) + 1, 3))
    X[tags.astype(np.int64)] = xyz.reshape(-1, 3)
    return X


def _triangles(entities: list[int]) -> npt.NDArray[np.int64]:
    out = [np.zeros((0, 3), dtype=np.int64)]
    for s in entities:
        _, conn = gmsh.model.mesh.getElementsByType(2, s)
        out.append(np.asarray(conn, dtype=np.int64).reshape(-1, 3))
    return np.vstack(out)


def _area(X: npt.NDArray[np.float64], T: npt.NDArray[np.int64]) -> float:
    n = np.cross(X[T[:, 1]] - X[T[:, 0]], X[T[:, 2]] - X[T[:, 0]])
    return 0.5 * float(np.linalg.norm(n, axis=1).sum())


def crack_surface(entities: list[int], mouth: int | None = None) -> CrackSurface:
    """The crack surface of the gmsh surfaces ``entities`` (meshed, not yet split) and,
    for a surface crack, the curve ``mouth`` (its nodes are split, not front)."""
    T = _triangles(entities)
    edges = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(edges, axis=0, return_counts=True)
    once = uniq[count == 1]
    if mouth is not None:
        _, conn = gmsh.model.mesh.getElementsByType(1, mouth)
        m = np.sort(np.asarray(conn, dtype=np.int64).reshape(-1, 2), axis=1)
        mouth_edges = {tuple(e) for e in m.tolist()}
        once = np.array([e for e in once.tolist() if tuple(e) not in mouth_edges])
    front = frozenset(int(v) for v in np.unique(once)) if len(once) else frozenset()
    return CrackSurface(_area(_nodes(), T), front)


def _glued(faces: list[npt.NDArray[np.int64]]) -> int:
    """The number of the triangles ``faces`` that are not a face of exactly one
    tetrahedron of the model."""
    _, conn = gmsh.model.mesh.getElementsByType(4)
    tets = np.asarray(conn, dtype=np.int64).reshape(-1, 4)
    own = np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 2, 3]], tets[:, [0, 1, 3]], tets[:, :3]])
    tri = np.concatenate(faces)
    rows = np.sort(np.concatenate([own, tri]), axis=1)
    n = int(rows.max()) + 1
    if n**3 < 2**62:  # one integer per face: a 1D unique, ~10x faster than rows
        rows = (rows[:, 0] * n + rows[:, 1]) * n + rows[:, 2]
    _, inv = np.unique(rows, axis=0, return_inverse=True)
    inv = inv.ravel()
    count = np.bincount(inv[: len(own)], minlength=int(inv.max()) + 1)
    return int(np.count_nonzero(count[inv[len(own) :]] != 1))


def check_crack_split(before: CrackSurface, tags: tuple[int, int], label: str) -> None:
    """Raise :class:`MeshingError` (naming ``label``) unless the faces in the physical
    groups ``tags`` each have the area of the surface ``before`` the split, share only
    its front nodes and each of their triangles is a face of one tetrahedron."""
    X = _nodes()
    faces = [_triangles(list(gmsh.model.getEntitiesForPhysicalGroup(2, t))) for t in tags]
    areas = [_area(X, T) for T in faces]
    tol = SPLIT_AREA_TOL * before.area
    if any(abs(a - before.area) > tol for a in areas):
        raise MeshingError(
            f"{label}: the split faces' areas {areas[0]:.12g} and {areas[1]:.12g} m² differ "
            f"from the crack surface's {before.area:.12g} m² (a triangle left unsplit)"
        )
    shared = set(np.unique(faces[0]).tolist()) & set(np.unique(faces[1]).tolist())
    glued = shared - before.front
    if glued:
        raise MeshingError(
            f"{label}: the split faces share {len(glued)} nodes that are not the front's "
            f"(a triangle left unsplit)"
        )
    if n := _glued(faces):
        raise MeshingError(
            f"{label}: {n} triangles of the split faces are not a face of exactly one "
            f"tetrahedron (a triangle left unsplit: the cells on both its sides share its "
            f"nodes)"
        )
