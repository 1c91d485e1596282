"""A check, and a repair, of a crack's split into two faces (gmsh, rank 0; 2D and 3D).

gmsh's ``Crack`` plugin duplicates the crack's nodes but the front's (the tips') and
sides each cell at a node by a normal test; it reports nothing when it sides one wrongly
(seen at sharp kinks): a facet left glued (the cells on both its sides kept its nodes;
DOLFINx's faces short of it) or a cell at a crack node only given the other side's node
(bridging the faces, torn from its neighbours): a wrong K with no error.
:func:`check_crack_split` compares the faces after the split with the crack before it (a
surface of triangles in 3D, a polyline of segments in 2D): each face's measure must
equal the crack's (``SPLIT_AREA_TOL`` relative), the faces may share only the front's
nodes and (3D) no edge but the front's (a crack triangle whose three nodes are all on
the front, at a sharp or coarse corner of it: no node split opens it), every face facet
must be a facet of exactly one cell and every other facet at the faces' nodes a facet of
two cells or a boundary element; otherwise a
:class:`~bonecontact.meshing.builder.MeshingError` names the crack.
:func:`resplit_crack` redoes a split by its own rule: the cells around a split node
grouped by their facets at the node that are not the crack's (two groups), the copy to
one group, consistently along the crack, on the side the plugin gave most copies.
:func:`split_checked` checks, resplits a bad split (in 3D after halving the edges
across the front's corners, :func:`bisect_pinched`) and checks again (2D and 3D).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import gmsh
import numpy as np
import numpy.typing as npt

from bonecontact.meshing.builder import MeshingError

__all__ = [
    "SPLIT_AREA_TOL",
    "CrackSurface",
    "bisect_pinched",
    "check_crack_split",
    "crack_surface",
    "node_sides",
    "resplit_crack",
    "split_checked",
]

#: the largest relative difference between a face's measure and the crack's
SPLIT_AREA_TOL = 1e-9

#: gmsh's element type of the simplex of each dimension (point, line, triangle, tetrahedron)
_SIMPLEX = {0: 15, 1: 1, 2: 2, 3: 4}

#: per crack dimension: measure, unit, the crack, a facet, facets, a cell, the front
_WORDS = {
    1: ("lengths", "m", "crack's", "segment", "segments", "side of exactly one triangle", "tips'"),
    2: (
        "areas",
        "m²",
        "crack surface's",
        "triangle",
        "triangles",
        "face of exactly one tetrahedron",
        "front's",
    ),
}

_log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CrackSurface:
    """The crack as meshed, before its split.

    Attributes
    ----------
    measure
        The sum of its facets' measures: areas of a surface (m², ``dim`` 2), lengths of
        a polyline (m, ``dim`` 1).
    front
        gmsh tags of its front nodes (those of the facets' boundary that are not the
        mouth's): the nodes the two faces keep in common.
    dim
        The crack's dimension (2: a surface in a 3D body; 1: a polyline in a 2D body).
    """

    measure: float
    front: frozenset[int]
    dim: int = 2

    @property
    def area(self) -> float:
        """The measure (the name of a surface's)."""
        return self.measure


def _nodes() -> npt.NDArray[np.float64]:
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    X = np.zeros((int(tags.max()) + 1, 3))
    X[tags.astype(np.int64)] = xyz.reshape(-1, 3)
    return X


def _simplices(dim: int, entities: list[int]) -> npt.NDArray[np.int64]:
    """The nodes of the ``dim``-simplices of the gmsh entities (of dimension ``dim``)."""
    out = [np.zeros((0, dim + 1), dtype=np.int64)]
    for s in entities:
        _, conn = gmsh.model.mesh.getElementsByType(_SIMPLEX[dim], s)
        out.append(np.asarray(conn, dtype=np.int64).reshape(-1, dim + 1))
    return np.vstack(out)


def _measure(X: npt.NDArray[np.float64], T: npt.NDArray[np.int64]) -> float:
    if T.shape[1] == 2:
        return float(np.linalg.norm(X[T[:, 1]] - X[T[:, 0]], axis=1).sum())
    n = np.cross(X[T[:, 1]] - X[T[:, 0]], X[T[:, 2]] - X[T[:, 0]])
    return 0.5 * float(np.linalg.norm(n, axis=1).sum())


def _local_facets(T: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """The facets of the simplices T (each a row of nodes), all of the first local facet,
    then all of the second, …"""
    k = T.shape[1]
    return np.concatenate([T[:, [j for j in range(k) if j != i]] for i in range(k)])


def crack_surface(
    entities: list[int], mouth: int | list[int] | None = None, dim: int = 2
) -> CrackSurface:
    """The crack of the gmsh entities ``entities`` of dimension ``dim`` (surfaces in 3D,
    curves in 2D; meshed, not yet split) and the entities ``mouth`` of dimension
    ``dim - 1`` on the body's boundary (a curve, points; their nodes are split, not
    front)."""
    T = _simplices(dim, entities)
    uniq, count = np.unique(np.sort(_local_facets(T), axis=1), axis=0, return_counts=True)
    once = uniq[count == 1]
    mouths = [] if mouth is None else [mouth] if isinstance(mouth, int) else list(mouth)
    if mouths:
        m = np.sort(_simplices(dim - 1, mouths), axis=1)
        mouth_facets = {tuple(e) for e in m.tolist()}
        once = np.array([e for e in once.tolist() if tuple(e) not in mouth_facets])
    front = frozenset(int(v) for v in np.unique(once)) if len(once) else frozenset()
    return CrackSurface(_measure(_nodes(), T), front, dim)


def _cells(dim: int) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """The element tags and nodes of all cells of the model around a crack of dimension
    ``dim``."""
    tags, conn = gmsh.model.mesh.getElementsByType(_SIMPLEX[dim + 1])
    return np.asarray(tags, dtype=np.int64), np.asarray(conn, dtype=np.int64).reshape(-1, dim + 2)


def _keys(*arrays: npt.NDArray[np.int64]) -> list[npt.NDArray[np.int64]]:
    """One integer per row (its sorted nodes) of each array, equal for equal rows."""
    rows = np.sort(np.concatenate(arrays), axis=1)
    n = int(rows.max()) + 1 if len(rows) else 1
    if float(n) ** rows.shape[1] < 2**62:  # a dot product: ~10x faster than a row unique
        keys = rows @ (n ** np.arange(rows.shape[1] - 1, -1, -1, dtype=np.int64))
    else:
        keys = np.unique(rows, axis=0, return_inverse=True)[1].ravel()
    return np.split(keys, np.cumsum([len(a) for a in arrays])[:-1])


def _glued(faces: list[npt.NDArray[np.int64]], dim: int) -> int:
    """The number of the facets ``faces`` that are not a facet of exactly one cell."""
    tri = np.concatenate(faces)
    _, cells = _cells(dim)
    cells = cells[np.isin(cells, tri).sum(axis=1) >= dim + 1]  # those that may own one
    own, ask = _keys(_local_facets(cells), tri)
    uniq, count = np.unique(own, return_counts=True)
    pos = np.clip(np.searchsorted(uniq, ask), 0, max(len(uniq) - 1, 0))
    found = (uniq[pos] == ask) if len(uniq) else np.zeros(len(ask), dtype=bool)
    return int(np.count_nonzero(~found | (count[pos] != 1)))


def _torn(faces: list[npt.NDArray[np.int64]], dim: int) -> int:
    """The number of facets at the faces' nodes that are a facet of one cell but no
    facet element of the model (a face's or the boundary's): the mesh torn there."""
    nodes = np.unique(np.concatenate(faces))
    _, cells = _cells(dim)
    own = _local_facets(cells[np.isin(cells, nodes).any(axis=1)])
    own = own[np.isin(own, nodes).any(axis=1)]  # all the cells of these are in the set
    _, conn = gmsh.model.mesh.getElementsByType(_SIMPLEX[dim])
    own_keys, model = _keys(own, np.asarray(conn, dtype=np.int64).reshape(-1, dim + 1))
    uniq, count = np.unique(own_keys, return_counts=True)
    return int(np.count_nonzero(~np.isin(uniq[count == 1], model)))


def _pinched(face: npt.NDArray[np.int64], shared: set[int]) -> list[tuple[int, int]]:
    """The edges of the triangles ``face`` (one face of a split crack) between two
    ``shared`` nodes (the front's) that are an edge of two of its triangles: not the
    front's, yet not split (the crack closed along them)."""
    edges = np.sort(np.concatenate([face[:, [0, 1]], face[:, [1, 2]], face[:, [0, 2]]]), axis=1)
    edges = edges[np.isin(edges, list(shared)).all(axis=1)]
    uniq, count = np.unique(edges, axis=0, return_counts=True)
    return [(int(a), int(b)) for a, b in uniq[count > 1]]


def check_crack_split(before: CrackSurface, tags: tuple[int, int], label: str) -> None:
    """Raise :class:`MeshingError` (naming ``label``) unless the faces in the physical
    groups ``tags`` each have the measure of the crack ``before`` the split, share only
    its front nodes, each of their facets is a facet of one cell and every other facet
    at their nodes is a facet of two cells or the boundary's (no tear); of a surface,
    they share no edge but the front's."""
    dim = before.dim
    measure, unit, crack, facet, facets, owner, front = _WORDS[dim]
    X = _nodes()
    faces = [_simplices(dim, list(gmsh.model.getEntitiesForPhysicalGroup(dim, t))) for t in tags]
    sizes = [_measure(X, T) for T in faces]
    tol = SPLIT_AREA_TOL * before.measure
    if any(abs(a - before.measure) > tol for a in sizes):
        raise MeshingError(
            f"{label}: the split faces' {measure} {sizes[0]:.12g} and {sizes[1]:.12g} {unit} "
            f"differ from the {crack} {before.measure:.12g} {unit} (a {facet} left unsplit)"
        )
    shared = set(np.unique(faces[0]).tolist()) & set(np.unique(faces[1]).tolist())
    glued = shared - before.front
    if glued:
        raise MeshingError(
            f"{label}: the split faces share {len(glued)} nodes that are not the {front} "
            f"(a {facet} left unsplit)"
        )
    if dim == 2 and (n := len(_pinched(faces[0], shared))):
        raise MeshingError(
            f"{label}: the split faces share {n} edges that are not the {front} (the crack "
            f"closed along them: an edge across a corner of the front, its triangles unsplit)"
        )
    if n := _glued(faces, dim):
        raise MeshingError(
            f"{label}: {n} {facets} of the split faces are not a {owner} (a {facet} left "
            f"unsplit: the cells on both its sides share its nodes)"
        )
    if n := _torn(faces, dim):
        raise MeshingError(
            f"{label}: {n} {facets} at the crack's nodes are a facet of one cell but neither "
            f"a face's nor the boundary's (a cell sided wrongly: the mesh torn there)"
        )


# ------------------------------------------------------------------ the own split
def _copies(tags: tuple[int, int], dim: int) -> dict[int, int]:
    """Each split node of the faces in ``tags`` (the crack's, then the copy's) → its
    copy (the node of the copy face at the same point)."""
    X = _nodes()
    old = _simplices(dim, list(gmsh.model.getEntitiesForPhysicalGroup(dim, tags[0])))
    new = _simplices(dim, list(gmsh.model.getEntitiesForPhysicalGroup(dim, tags[1])))
    at = {tuple(X[v]): v for v in np.unique(old).tolist()}
    return {at[tuple(X[c])]: c for c in sorted(set(np.unique(new).tolist()) - set(at.values()))}


class _Root:
    """Union-find of cells."""

    def __init__(self, cells: list[int]) -> None:
        self.parent = {c: c for c in cells}

    def __call__(self, c: int) -> int:
        while self.parent[c] != c:
            self.parent[c] = self.parent[self.parent[c]]
            c = self.parent[c]
        return c

    def join(self, a: int, b: int) -> None:
        self.parent[self(a)] = self(b)


def _groups(
    v: int, around: list[int], T0: npt.NDArray[np.int64], crack: set[tuple[int, ...]]
) -> _Root:
    """The cells ``around`` node v grouped by their facets at v that are not the
    ``crack``'s; raises unless they are two groups."""
    root, by_facet = _Root(around), {}
    for c in around:
        for f in _local_facets(T0[c][None]).tolist():
            key = tuple(sorted(f))
            if v in key and key not in crack:
                by_facet.setdefault(key, []).append(c)
    for cs in by_facet.values():
        for c in cs[1:]:
            root.join(c, cs[0])
    if len({root(c) for c in around}) != 2:
        raise MeshingError("the crack parts the cells at a node into other than two groups")
    return root


def node_sides(
    v: int, around: list[int], cells: npt.NDArray[np.int64], crack: set[tuple[int, ...]]
) -> tuple[list[int], list[int]]:
    """The cells ``around`` node v (rows of ``cells``) in the two groups joined by their
    facets at v that are not the ``crack``'s (sorted node tuples), the first that of
    ``around[0]``, each in the order of ``around`` (the rule of :func:`resplit_crack`);
    raises :class:`MeshingError` unless two."""
    root = _groups(v, around, cells, crack)
    first = root(around[0])
    return [c for c in around if root(c) == first], [c for c in around if root(c) != first]


def _choose(
    copies: dict[int, int],
    around: dict[int, list[int]],
    roots: dict[int, _Root],
    T1: npt.NDArray[np.int64],
    crack_facets: list[tuple[int, ...]],
) -> dict[int, int]:
    """Per split node, the group (its root) that takes the copy: consistent along the
    crack (the two cells at a crack facet take the copies of all its split nodes or of
    none), per connected part of the crack the side the plugin gave more copies."""
    nodes_of = {}
    for f in crack_facets:
        for v in f:
            nodes_of.setdefault(v, []).append(f)
    choice: dict[int, int] = {}
    for start in copies:
        if start in choice:
            continue
        part, stack = [start], [start]
        choice[start] = roots[start](around[start][0])
        while stack:
            v = stack.pop()
            for f in nodes_of[v]:
                cells = set(around[v]).intersection(*(around[u] for u in f))
                mine = [c for c in cells if roots[v](c) == choice[v]]
                if len(cells) != 2 or len(mine) != 1:
                    raise MeshingError("a crack facet is not a facet of two cells")
                for u in f:
                    if u in copies and u not in choice:
                        choice[u] = roots[u](mine[0])
                        part.append(u)
                        stack.append(u)
        vote = sum(
            (1 if roots[v](c) == choice[v] else -1) * int(copies[v] in T1[c])
            for v in part
            for c in around[v]
        )
        if vote < 0:
            for v in part:
                choice[v] = next(roots[v](c) for c in around[v] if roots[v](c) != choice[v])
    return choice


def _write_cells(dim: int, cell_tags: npt.NDArray[np.int64], split: np.ndarray) -> None:
    """Give the cells ``cell_tags`` the nodes ``split`` (where they changed)."""
    order = np.argsort(cell_tags)
    for _, e in gmsh.model.getEntities(dim + 1):
        tags, conn = gmsh.model.mesh.getElementsByType(_SIMPLEX[dim + 1], e)
        tags = np.asarray(tags, dtype=np.int64)
        rows = split[order[np.searchsorted(cell_tags[order], tags)]]
        changed = np.flatnonzero(np.any(rows != np.asarray(conn).reshape(-1, dim + 2), axis=1))
        if len(changed):
            gmsh.model.mesh.removeElements(dim + 1, e, tags[changed].tolist())
            gmsh.model.mesh.addElementsByType(
                e, _SIMPLEX[dim + 1], tags[changed].tolist(), rows[changed].ravel().tolist()
            )


def _write_boundary(
    dim: int,
    tags: tuple[int, int],
    copies: dict[int, int],
    around: dict[int, list[int]],
    split: npt.NDArray[np.int64],
) -> None:
    """Give every other facet at a split node (a boundary facet at a mouth: a facet of
    one cell) the nodes of its cell."""
    faces = {e for t in tags for e in gmsh.model.getEntitiesForPhysicalGroup(dim, t)}
    back = {c: v for v, c in copies.items()}
    for _, e in gmsh.model.getEntities(dim):
        if e in faces:
            continue
        etags, conn = gmsh.model.mesh.getElementsByType(_SIMPLEX[dim], e)
        F = np.asarray(conn, dtype=np.int64).reshape(-1, dim + 1)
        F0 = np.vectorize(lambda u: back.get(u, u), otypes=[np.int64])(F) if len(F) else F
        rows = np.flatnonzero(np.isin(F0, list(copies)).any(axis=1))
        for i in rows.tolist():
            f = F0[i].tolist()
            cells = set(around[f[0]]).intersection(*(around[u] for u in f[1:]))
            if len(cells) != 1:
                continue
            own = set(split[cells.pop()].tolist())
            F[i] = [copies[u] if u in copies and copies[u] in own else u for u in f]
        if len(rows):
            gmsh.model.mesh.removeElements(dim, e, etags[rows].tolist())
            gmsh.model.mesh.addElementsByType(
                e, _SIMPLEX[dim], etags[rows].tolist(), F[rows].ravel().tolist()
            )


def _bisect(edge: tuple[int, int], tags: tuple[int, int]) -> None:
    """Split the crack edge ``edge`` (between two front nodes, not the front's) at its
    midpoint: a node for the first face and its copy for the second (the cells take the
    first; :func:`resplit_crack` sides them), each tetrahedron and triangle at the edge
    halved (volumes and areas kept exactly)."""
    a, b = edge
    X = _nodes()
    mid = 0.5 * (X[a] + X[b])
    m = int(gmsh.model.mesh.getMaxNodeTag()) + 1
    first, second = (set(gmsh.model.getEntitiesForPhysicalGroup(2, t)) for t in tags)
    added: set[int] = set()
    for dim, etype in ((2, 2), (3, 4)):  # the nodes added with the triangles
        for _, e in gmsh.model.getEntities(dim):
            etags, conn = gmsh.model.mesh.getElementsByType(etype, e)
            E = np.asarray(conn, dtype=np.int64).reshape(-1, dim + 1)
            rows = np.flatnonzero(np.isin(E, edge).sum(axis=1) == 2)
            if not len(rows):
                continue
            node = m + 1 if dim == 2 and e in second else m
            if dim == 2 and e in first | second and node not in added:
                gmsh.model.mesh.addNodes(2, e, [node], mid.tolist())
                added.add(node)
            halves = np.concatenate([np.where(E[rows] == b, node, E[rows]), E[rows]])
            halves[len(rows) :][halves[len(rows) :] == a] = node
            gmsh.model.mesh.removeElements(dim, e, np.asarray(etags)[rows].tolist())
            gmsh.model.mesh.addElementsByType(e, etype, [], halves.ravel().tolist())


def bisect_pinched(tags: tuple[int, int], front: frozenset[int]) -> int:
    """Halve every edge between two ``front`` nodes that the split faces ``tags`` (of a
    surface crack) share and is not the front's (an edge across a corner of the front:
    no node split can open it), each half-edge's node to be split by
    :func:`resplit_crack`; returns how many edges."""
    faces = [_simplices(2, list(gmsh.model.getEntitiesForPhysicalGroup(2, t))) for t in tags]
    shared = set(np.unique(faces[0]).tolist()) & set(np.unique(faces[1]).tolist()) & front
    edges = _pinched(faces[0], shared)
    for edge in edges:
        _bisect(edge, tags)
    return len(edges)


def resplit_crack(tags: tuple[int, int], dim: int) -> int:
    """Redo the split of the crack whose faces are the physical groups ``tags`` (the
    crack's facets, then their copies; dimension ``dim``) by the cells' connections at
    each split node; returns how many cells changed nodes."""
    copies = _copies(tags, dim)
    back = np.arange(int(gmsh.model.mesh.getMaxNodeTag()) + 1)
    back[list(copies.values())] = list(copies)
    cell_tags, T1 = _cells(dim)
    T0 = back[T1]
    old = _simplices(dim, list(gmsh.model.getEntitiesForPhysicalGroup(dim, tags[0])))
    crack_facets = [tuple(sorted(f)) for f in old.tolist()]
    near = np.flatnonzero(np.isin(T0, old).any(axis=1))
    around: dict[int, list[int]] = {}
    for c in near.tolist():
        for v in T0[c].tolist():
            around.setdefault(v, []).append(c)
    roots = {v: _groups(v, around[v], T0, set(crack_facets)) for v in copies}
    choice = _choose(copies, around, roots, T1, crack_facets)
    split = T0.copy()
    for v, keep in choice.items():
        for c in around[v]:
            if roots[v](c) == keep:
                split[c][split[c] == v] = copies[v]
    changed = int(np.count_nonzero(np.any(split != T1, axis=1)))
    _write_cells(dim, cell_tags, split)
    _write_boundary(dim, tags, copies, around, split)
    return changed


def split_checked(before: CrackSurface, tags: tuple[int, int], label: str) -> int:
    """Check the split faces ``tags`` of the crack ``before`` (:func:`check_crack_split`);
    if bad, redo the split (:func:`bisect_pinched` for a surface, then
    :func:`resplit_crack`) and check again.  Returns how many
    cells the resplit changed (0: the split was right); raises :class:`MeshingError`
    naming ``label`` when the resplit fails too."""
    try:
        check_crack_split(before, tags, label)
        return 0
    except MeshingError as exc:
        first = str(exc)
    try:
        if before.dim == 2:
            bisect_pinched(tags, before.front)
        changed = resplit_crack(tags, before.dim)
        check_crack_split(before, tags, label)
    except Exception as exc:  # any failure of the resplit names the crack
        raise MeshingError(f"{first}; resplit: {exc}") from exc
    _log.warning("%s; resplit: %d cells changed", first, changed)
    return changed
