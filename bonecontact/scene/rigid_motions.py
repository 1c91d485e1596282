"""The rigid motions of a scene's bodies that no support and no contact holds.

A static or quasi-static scene is solvable only when every *body* (connected piece of
the mesh) is held against each of its rigid motions — 2 translations and 1 rotation in
2D, 3 and 3 in 3D — by a Dirichlet condition or by a contact; a motion that nothing holds
leaves the displacement undetermined.  :func:`unheld_motions` finds these motions before
anything is solved (small matrices of the constraints of every support and contact pair,
reduced across ranks, their null spaces intersected); :func:`check_rigid_motions` turns
them into a :class:`~bonecontact.scene.errors.SceneError` or a
:class:`UnheldMotionWarning` (``[analysis] unheld_motion``).  Bodies and their names come
from :func:`find_bodies`, collectively and the same on any number of ranks.

The method, its thresholds and its limits: docs/theory/rigid_motions.md.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
from dolfinx import mesh as dmesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from bonecontact.scene.errors import SceneError
from bonecontact.scene.spec import Scene

__all__ = [
    "CONTACT_SHARE",
    "DIRICHLET_SHARE",
    "POINT_RESOLUTION",
    "Bodies",
    "ConstraintSet",
    "UnheldMotion",
    "UnheldMotionWarning",
    "body_geometry",
    "cell_pieces",
    "check_rigid_motions",
    "contact_sets",
    "describe_motions",
    "dirichlet_sets",
    "find_bodies",
    "mode_values",
    "singular_diagnosis",
    "unheld_motions",
    "unheld_subspace",
]

#: A frictionless contact holds a motion when more than this share of the motion's mean
#: squared relative velocity on the slave surface is normal to it.  The faceted normals of
#: a curved surface leave a little of a rotation about its centre of curvature normal:
#: 1.5e-5 of it for facets of size h = R / 10, 7e-5 for R / 5, 5e-4 for 0.3 R, 1.4e-3 for
#: 0.4 R (docs/theory/rigid_motions.md).  A real hold is of order 1: a flat face tilting
#: about 1, a hemisphere sliding sideways 1/3, a cap of half-angle α about α²/4 (8e-3
#: for 10°).
CONTACT_SHARE = 1.0e-3
#: A Dirichlet condition is exact: it holds a motion when more than this share of the
#: motion's velocity on its facets lies in the fixed components (round-off otherwise).
DIRICHLET_SHARE = 1.0e-8
#: A rotation axis is located to this fraction of its body's size (rounded to a power of
#: 10 m): faceted normals place the centre of curvature of a sphere meshed with h = R / 10
#: within 2e-4 of its size.
POINT_RESOLUTION = 1.0e-3


class UnheldMotionWarning(UserWarning):
    """A body of the scene has a rigid motion that no support and no contact holds
    (``[analysis] unheld_motion = "warn"``)."""


# --------------------------------------------------------------------------------------
# bodies
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Bodies:
    """The connected pieces of a mesh, numbered the same way on any number of ranks.

    Parameters
    ----------
    cell_body
        Body of every local cell (owned and ghost).
    names
        Name of each body: the cell groups it is made of, joined by ``" + "``.
    """

    cell_body: npt.NDArray[np.int64]
    names: tuple[str, ...]

    @property
    def count(self) -> int:
        """The number of bodies."""
        return len(self.names)


def cell_pieces(msh: Any) -> tuple[int, npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Connected pieces of this rank's cells (owned and ghost; cells sharing a vertex are
    connected): count, label per cell (0 … count − 1, numbered by their smallest cell),
    label per local vertex (−1 for a vertex of no cell).

    The components of the cell–vertex incidence graph (cells and vertices as nodes, one
    edge per cell vertex): O(cells · vertices per cell) memory, where the cell-to-cell
    graph (cells sharing a vertex) holds ~100 entries per tetrahedron.
    """
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim, 0)
    c2v = msh.topology.connectivity(tdim, 0)
    imap = msh.topology.index_map(0)
    nv = imap.size_local + imap.num_ghosts
    nc = len(c2v.offsets) - 1
    cells = np.repeat(np.arange(nc, dtype=np.int64), np.diff(c2v.offsets))
    verts = nc + np.asarray(c2v.array, dtype=np.int64)
    incidence = coo_matrix(
        (np.ones(len(cells), dtype=np.int8), (cells, verts)), shape=(nc + nv, nc + nv)
    )
    _, comp = connected_components(incidence, directed=False)
    _, label = np.unique(comp[:nc], return_inverse=True)  # pieces with cells only
    label = label.astype(np.int64).ravel()
    vpiece = np.full(nv, -1, dtype=np.int64)
    vpiece[c2v.array] = label[cells]
    n = int(label.max()) + 1 if nc else 0
    return n, label, vpiece


def _shared_links(msh: Any, vpiece: npt.NDArray[np.int64], comm: MPI.Comm) -> tuple:
    """(global vertex, local piece) of the vertices other ranks also have."""
    imap = msh.topology.index_map(0)
    nv = imap.size_local + imap.num_ghosts
    if comm.size == 1:
        shared = np.zeros(0, dtype=np.int32)
    else:
        dest = imap.index_to_dest_ranks(0)
        owned = np.flatnonzero(np.diff(dest.offsets)[: imap.size_local] > 0)
        shared = np.union1d(owned, np.arange(imap.size_local, nv)).astype(np.int32)
    return imap.local_to_global(shared), vpiece[shared]


def _piece_keys(msh: Any, label: npt.NDArray, n: int, cell_tag: npt.NDArray) -> tuple:
    """Per local piece: the smallest input index of its nodes (orders the bodies
    independently of the partition) and the cell tags of its cells."""
    nodes = np.asarray(msh.geometry.dofmaps[0])
    inputs = np.asarray(msh.geometry.input_global_indices, dtype=np.int64)[nodes].min(axis=1)
    key = np.full(n, np.iinfo(np.int64).max, dtype=np.int64)
    np.minimum.at(key, label[: len(inputs)], inputs)
    tags = [sorted({int(t) for t in np.unique(cell_tag[label == p])}) for p in range(n)]
    return key, tags


def _join_pieces(gathered: list) -> tuple[list[npt.NDArray[np.int64]], list[list[int]]]:
    """Rank 0: the pieces of all ranks joined by shared vertices into bodies, numbered by
    their smallest node input index.  Returns each rank's piece → body map and the cell
    tags of each body."""
    offsets = np.cumsum([0] + [g[0] for g in gathered])
    npieces = int(offsets[-1])
    rows, cols = [np.arange(npieces)], [np.arange(npieces)]
    for r, (_, (glob, piece), _, _) in enumerate(gathered):
        ok = piece >= 0
        rows.append(offsets[r] + piece[ok])
        cols.append(npieces + np.asarray(glob, dtype=np.int64)[ok])
    ra, ca = np.concatenate(rows), np.concatenate(cols)
    size = max(int(ca.max()) + 1 if ca.size else 0, npieces)
    graph = coo_matrix((np.ones(ra.size), (ra, ca)), shape=(size, size))
    _, comp = connected_components(graph, directed=False)
    comp = comp[:npieces]
    keys = np.concatenate([g[2] for g in gathered]) if npieces else np.zeros(0, np.int64)
    first: dict[int, int] = {}
    for c, k in zip(comp, keys, strict=True):
        first[int(c)] = min(first.get(int(c), int(k)), int(k))
    order = {c: i for i, c in enumerate(sorted(first, key=lambda c: first[c]))}
    body = np.array([order[int(c)] for c in comp], dtype=np.int64)
    tags: list[set[int]] = [set() for _ in order]
    for r, g in enumerate(gathered):
        for p, t in enumerate(g[3]):
            tags[body[offsets[r] + p]].update(t)
    maps = [body[offsets[r] : offsets[r + 1]] for r in range(len(gathered))]
    return maps, [sorted(t) for t in tags]


def _body_names(tags: Sequence[Sequence[int]], names: Mapping[int, str]) -> tuple[str, ...]:
    """Each body's cell groups by name; a name shared by several bodies gets ``#k``."""
    base = [" + ".join(names.get(t, f"tag {t}") for t in ts) or "(untagged)" for ts in tags]
    out = []
    for i, b in enumerate(base):
        same = [j for j, o in enumerate(base) if o == b]
        out.append(b if len(same) == 1 else f"{b} #{same.index(i) + 1}")
    return tuple(out)


def find_bodies(msh: Any, cell_tags: Any, names: Mapping[int, str], comm: MPI.Comm) -> Bodies:
    """The bodies (connected pieces, cells sharing a vertex) of a distributed mesh.

    Each rank finds the pieces of its cells; only the global indices of the vertices on
    the partition boundary, one key and the cell tags of each piece are gathered to join
    them (collective; the same numbering and names on any number of ranks).

    Parameters
    ----------
    msh
        The mesh.
    cell_tags
        Its cell tags (``None``: untagged).
    names
        Cell tag → physical-group name.
    comm
        The mesh's communicator.
    """
    tdim = msh.topology.dim
    n, label, vpiece = cell_pieces(msh)
    ncells = len(label)
    cell_tag = np.full(ncells, -1, dtype=np.int64)
    if cell_tags is not None:
        cell_tag[cell_tags.indices] = cell_tags.values
    owned = msh.topology.index_map(tdim).size_local
    key, tags = _piece_keys(msh, label, n, np.where(np.arange(ncells) < owned, cell_tag, -1))
    tags = [[t for t in ts if t >= 0] for ts in tags]
    gathered = comm.gather((n, _shared_links(msh, vpiece, comm), key, tags), root=0)
    maps, body_tags = _join_pieces(gathered) if comm.rank == 0 else (None, None)
    body_tags = comm.bcast(body_tags, root=0)
    mine = comm.scatter(maps, root=0)
    return Bodies(mine[label], _body_names(body_tags, names))


# --------------------------------------------------------------------------------------
# rigid modes
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BodyGeometry:
    """Centroid, size and the metric of each body's rigid modes.

    Parameters
    ----------
    centre
        ``(nb, gdim)`` centroids (volume-weighted).
    size
        ``(nb,)`` root-mean-square distance of the body's points from its centroid.
    metric
        ``(nb, nm, nm)`` mean over the body of ``Φᵀ Φ`` (``Φ`` the modes,
        :func:`mode_values`): the norm that measures a motion.
    """

    centre: npt.NDArray[np.float64]
    size: npt.NDArray[np.float64]
    metric: npt.NDArray[np.float64]

    @property
    def modes(self) -> int:
        """Rigid modes per body (3 in 2D, 6 in 3D)."""
        return self.metric.shape[1]


def mode_values(
    x: npt.NDArray[np.float64], centre: npt.NDArray[np.float64], size: float
) -> npt.NDArray[np.float64]:
    """The rigid modes of a body at points ``x`` (``(n, gdim)``): ``(n, gdim, nm)``.

    The modes are the translations along the axes, then the rotations about the axes
    through ``centre`` (2D: about the point), scaled by ``1 / size`` so that all have a
    velocity of about 1 on the body.
    """
    r = (np.asarray(x, dtype=np.float64) - centre) / size
    n, d = r.shape
    if d == 2:
        out = np.zeros((n, 2, 3))
        out[:, 0, 0] = out[:, 1, 1] = 1.0
        out[:, 0, 2], out[:, 1, 2] = -r[:, 1], r[:, 0]
        return out
    out = np.zeros((n, 3, 6))
    out[:, 0, 0] = out[:, 1, 1] = out[:, 2, 2] = 1.0
    for i in range(3):  # e_i × r
        e = np.zeros(3)
        e[i] = 1.0
        out[:, :, 3 + i] = np.cross(e, r)
    return out


def _cell_centroids(msh: Any) -> tuple[npt.NDArray, npt.NDArray]:
    """Centroids and measures of the owned cells (simplices)."""
    tdim, gdim = msh.topology.dim, msh.geometry.dim
    n = msh.topology.index_map(tdim).size_local
    nodes = np.asarray(msh.geometry.dofmaps[0])[:n, : tdim + 1]
    x = msh.geometry.x[nodes][:, :, :gdim]
    e = x[:, 1:, :] - x[:, :1, :]
    if tdim == gdim:
        vol = np.abs(np.linalg.det(e)) if n else np.zeros(0)
    else:  # pragma: no cover - manifold meshes are not scenes
        vol = np.sqrt(np.abs(np.linalg.det(e @ e.transpose(0, 2, 1))))
    return x.mean(axis=1), vol / math.factorial(tdim)


def body_geometry(msh: Any, bodies: Bodies, comm: MPI.Comm) -> BodyGeometry:
    """Centroid, size and metric of each body from its owned cells (collective)."""
    tdim, gdim = msh.topology.dim, msh.geometry.dim
    nb = bodies.count
    xc, vol = _cell_centroids(msh)
    b = bodies.cell_body[: msh.topology.index_map(tdim).size_local]
    sums = np.zeros((nb, 1 + gdim))
    np.add.at(sums, b, np.column_stack([vol, vol[:, None] * xc]))
    sums = comm.allreduce(sums, op=MPI.SUM)
    volume = np.maximum(sums[:, 0], np.finfo(float).tiny)
    centre = sums[:, 1:] / volume[:, None]
    spread = np.zeros(nb)
    np.add.at(spread, b, vol * np.sum((xc - centre[b]) ** 2, axis=1))
    size = np.sqrt(comm.allreduce(spread, op=MPI.SUM) / volume)
    size = np.where(size > 0, size, 1.0)
    nm = 3 if gdim == 2 else 6
    metric = np.zeros((nb, nm, nm))
    for k in range(nb):
        sel = b == k
        phi = mode_values(xc[sel], centre[k], size[k])
        metric[k] = np.einsum("n,nci,ncj->ij", vol[sel], phi, phi)
    metric = comm.allreduce(metric, op=MPI.SUM) / volume[:, None, None]
    return BodyGeometry(centre, size, metric)


# --------------------------------------------------------------------------------------
# constraint sets
# --------------------------------------------------------------------------------------
@dataclass
class ConstraintSet:
    """What one support or contact pair holds: ``G`` (its constraint rows) and ``W`` (the
    velocity on its facets), both over the rigid modes of all bodies (``nb · nm``).

    Parameters
    ----------
    label
        The scene table it comes from (for the report).
    G, W
        Symmetric positive semi-definite matrices, ``G ≤ W``.
    share
        A motion is held when ``qᵀGq > share · qᵀWq``.
    """

    label: str
    G: npt.NDArray[np.float64]
    W: npt.NDArray[np.float64]
    share: float


def _facet_points(msh: Any, facets: npt.NDArray[np.int32]) -> tuple:
    """Vertices ``(n, k, gdim)``, measures and the cell of each owned facet of ``facets``;
    the facet normal pointing out of its cell (``(n, gdim)``)."""
    tdim, gdim = msh.topology.dim, msh.geometry.dim
    fdim = tdim - 1
    nf = msh.topology.index_map(fdim).size_local
    facets = np.asarray(facets, dtype=np.int32)
    facets = facets[facets < nf]
    msh.topology.create_connectivity(fdim, tdim)
    f2c = msh.topology.connectivity(fdim, tdim)
    cells = f2c.array[f2c.offsets[facets]] if len(facets) else np.zeros(0, np.int32)
    if not len(facets):
        return np.zeros((0, tdim, gdim)), np.zeros(0), cells, np.zeros((0, gdim))
    nodes = dmesh.entities_to_geometry(msh, fdim, facets)
    x = msh.geometry.x[nodes][:, :, :gdim]
    e = x[:, 1:, :] - x[:, :1, :]
    if gdim == 2:
        normal = np.column_stack([e[:, 0, 1], -e[:, 0, 0]])
    else:
        normal = np.cross(e[:, 0, :], e[:, 1, :])
    length = np.linalg.norm(normal, axis=1)
    measure = length / (1.0 if gdim == 2 else 2.0)
    normal = normal / np.where(length > 0, length, 1.0)[:, None]
    cnodes = np.asarray(msh.geometry.dofmaps[0])[cells, : tdim + 1]
    inside = msh.geometry.x[cnodes][:, :, :gdim].mean(axis=1) - x.mean(axis=1)
    normal *= np.where(np.sum(normal * inside, axis=1) > 0, -1.0, 1.0)[:, None]
    return x, measure, cells, normal


def _relative_modes(
    x: npt.NDArray, body: int, other: int | None, geo: BodyGeometry
) -> tuple[list[int], npt.NDArray[np.float64]]:
    """The bodies and the modes ``(n, gdim, k)`` of the velocity of body ``body`` at points
    ``x`` — relative to body ``other`` when given (its modes with a minus sign)."""
    phi = mode_values(x, geo.centre[body], geo.size[body])
    if other is None:
        return [body], phi
    return [body, other], np.concatenate(
        [phi, -mode_values(x, geo.centre[other], geo.size[other])], axis=2
    )


def _add(A: npt.NDArray, bodies: Sequence[int], nm: int, Q: npt.NDArray) -> None:
    """Add ``Q`` (over the modes of ``bodies``) into ``A`` (over every body's modes)."""
    idx = np.concatenate([np.arange(b * nm, (b + 1) * nm) for b in bodies])
    A[np.ix_(idx, idx)] += Q


def _accumulate(
    G: npt.NDArray,
    W: npt.NDArray,
    bodies: Sequence[int],
    nm: int,
    phi: npt.NDArray,
    w: npt.NDArray,
    normal: npt.NDArray,
    full: npt.NDArray | None = None,
) -> None:
    """``W += Σ w Φᵀ Φ``; ``G += Σ w rrᵀ`` with ``r = Φᵀ n`` (the normal rows), the whole
    ``Φᵀ Φ`` where ``full`` (sticking nodes)."""
    whole = np.einsum("n,nci,ncj->ij", w, phi, phi)
    _add(W, bodies, nm, whole)
    rn = np.einsum("nc,nci->ni", normal, phi)
    _add(G, bodies, nm, np.einsum("n,ni,nj->ij", w, rn, rn))
    if full is not None and full.any():
        f = full.astype(float) * w
        _add(G, bodies, nm, np.einsum("n,nci,ncj->ij", f, phi, phi))
        _add(G, bodies, nm, -np.einsum("n,ni,nj->ij", f, rn, rn))


def dirichlet_sets(
    scene: Scene,
    msh: Any,
    facet_tags: Any,
    tags: Mapping[str, int],
    bodies: Bodies,
    geo: BodyGeometry,
    comm: MPI.Comm,
) -> list[ConstraintSet]:
    """One set per ``[[dirichlet]]`` entry: its fixed components at the vertices of its
    facets (lumped, each vertex weighted by its share of the facet's measure)."""
    out = []
    n = bodies.count * geo.modes
    for i, bc in enumerate(scene.dirichlet):
        G, W = np.zeros((n, n)), np.zeros((n, n))
        x, measure, cells, _ = _facet_points(msh, facet_tags.find(tags[bc.boundary]))
        k = x.shape[1]
        pts = x.reshape(-1, x.shape[2])
        w = np.repeat(measure / k, k)
        owner = np.repeat(bodies.cell_body[cells], k)
        for b in np.unique(owner):
            sel = owner == b
            body, phi = _relative_modes(pts[sel], int(b), None, geo)
            _add(W, body, geo.modes, np.einsum("n,nci,ncj->ij", w[sel], phi, phi))
            fixed = phi[:, list(bc.components), :]
            _add(G, body, geo.modes, np.einsum("n,nci,ncj->ij", w[sel], fixed, fixed))
        G, W = comm.allreduce(G, op=MPI.SUM), comm.allreduce(W, op=MPI.SUM)
        out.append(ConstraintSet(f"[[dirichlet]] #{i + 1}", G, W, DIRICHLET_SHARE))
    return out


def _present(msh: Any, facet_tags: Any, tag: int, bodies: Bodies, comm: MPI.Comm) -> list[int]:
    """The bodies that own facets of group ``tag`` (all ranks)."""
    _, _, cells, _ = _facet_points(msh, facet_tags.find(tag))
    mine = np.zeros(bodies.count, dtype=np.int64)
    mine[np.unique(bodies.cell_body[cells])] = 1
    return [int(b) for b in np.flatnonzero(comm.allreduce(mine, op=MPI.SUM))]


def contact_sets(
    scene: Scene,
    msh: Any,
    facet_tags: Any,
    tags: Mapping[str, int],
    bodies: Bodies,
    geo: BodyGeometry,
    comm: MPI.Comm,
) -> list[ConstraintSet]:
    """One set per ``[[contact]]`` pair: the normal component of the relative velocity
    (slave body minus each master body) at the centroids of the slave facets, weighted by
    their measure; a Tresca or Coulomb pair holds the whole relative velocity."""
    out = []
    n = bodies.count * geo.modes
    for i, c in enumerate(scene.contacts):
        masters = _present(msh, facet_tags, tags[c.master], bodies, comm)
        x, measure, cells, normal = _facet_points(msh, facet_tags.find(tags[c.slave]))
        G, W = np.zeros((n, n)), np.zeros((n, n))
        mid, slave = x.mean(axis=1), bodies.cell_body[cells]
        for b in np.unique(slave):
            for m in masters:
                sel = slave == b
                if m != b:  # a pair within one body (crack faces) holds nothing
                    pair, rel = _relative_modes(mid[sel], int(b), m, geo)
                    _accumulate(G, W, pair, geo.modes, rel, measure[sel], normal[sel])
        G, W = comm.allreduce(G, op=MPI.SUM), comm.allreduce(W, op=MPI.SUM)
        if c.friction != "none":
            G = W.copy()
        out.append(ConstraintSet(f'[[contact]] #{i + 1} "{c.name}"', G, W, CONTACT_SHARE))
    return out


# --------------------------------------------------------------------------------------
# null space
# --------------------------------------------------------------------------------------
def _orthonormal(N: npt.NDArray, M: npt.NDArray) -> npt.NDArray:
    """Columns spanning the same space as ``N``, orthonormal in the metric ``M``."""
    if N.shape[1] == 0:
        return N
    g = N.T @ M @ N
    w, U = np.linalg.eigh(0.5 * (g + g.T))
    keep = w > 1e-12 * max(w.max(), 1e-300)
    return N @ U[:, keep] / np.sqrt(w[keep])


def _restrict(N: npt.NDArray, s: ConstraintSet) -> tuple[npt.NDArray, npt.NDArray]:
    """The part of span ``N`` that ``s`` does not hold, and the shares of those motions."""
    Wh, Gh = N.T @ s.W @ N, N.T @ s.G @ N
    w, U = np.linalg.eigh(0.5 * (Wh + Wh.T))
    scale = max(float(w.max()) if len(w) else 0.0, 1.0)
    still = w <= 1e-12 * scale  # motions that do not move the set's facets at all
    free = [U[:, still]]
    shares = [np.zeros(int(still.sum()))]
    if (~still).any():
        T = U[:, ~still] / np.sqrt(w[~still])
        lam, Y = np.linalg.eigh(0.5 * (T.T @ Gh @ T + (T.T @ Gh @ T).T))
        low = lam <= s.share
        free.append(T @ Y[:, low])
        shares.append(np.clip(lam[low], 0.0, None))
    return N @ np.column_stack(free), np.concatenate(shares)


def unheld_subspace(sets: Sequence[ConstraintSet], metric: npt.NDArray) -> npt.NDArray[np.float64]:
    """The rigid motions (columns, over all bodies' modes) that no set holds.

    Starts from every motion and lets each set in turn remove what it holds (the
    intersection of the sets' null spaces, each measured by its share
    ``qᵀGq / qᵀWq``); the columns are orthonormal in ``metric``.
    """
    N = _orthonormal(np.eye(metric.shape[0]), metric)
    for s in sets:
        if N.shape[1] == 0:
            break
        N, _ = _restrict(N, s)
        N = _orthonormal(N, metric)
    return N


# --------------------------------------------------------------------------------------
# words
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class UnheldMotion:
    """One rigid motion of one body that nothing holds.

    Parameters
    ----------
    body
        The body's name.
    kind
        ``"translation"``, ``"rotation"`` or ``"screw"`` (a rotation with a translation
        along its axis, ``pitch`` m per radian).
    direction
        Unit direction of the translation or of the rotation axis (3D; ``(0, 0, 1)`` for
        a 2D rotation).
    point
        A point of the rotation axis (the one nearest the body's centroid), or ``None``.
    pitch
        Of a screw motion (m/rad), else 0.
    """

    body: str
    kind: str
    direction: tuple[float, ...]
    point: tuple[float, ...] | None = None
    pitch: float = 0.0

    def __str__(self) -> str:
        d = _axis_name(self.direction)
        if self.kind == "translation":
            what = f"translation along {d}"
        elif self.point is not None and len(self.point) == 2:
            what = f"rotation about the point {_coords(self.point)}"
        else:
            what = f"rotation about the axis through {_coords(self.point)} along {d}"
            if self.kind == "screw":
                what = what.replace("rotation", "screw motion") + f" (pitch {self.pitch:.4g} m/rad)"
        return f'body "{self.body}": {what} is not held'


def _clean(v: float) -> float:
    return 0.0 if abs(v) < 1e-12 else float(v)


def _coords(x: Sequence[float] | None) -> str:
    return "(" + ", ".join(f"{_clean(v):.4g}" for v in (x or ())) + ")"


def _axis_name(d: Sequence[float]) -> str:
    d = np.asarray(d, dtype=float)
    for i, name in enumerate("xyz"[: len(d)]):
        if abs(abs(d[i]) - 1.0) < 1e-6:
            return name if d[i] > 0 else f"-{name}"
    return _coords(d)


def _span_basis(V: npt.NDArray, tol: float = 1e-6) -> npt.NDArray:
    """An orthonormal basis (rows) of the row span of ``V``, coordinate axes first when
    they lie in it; a direction is snapped to its sign convention (largest entry > 0)."""
    if V.size == 0:
        return np.zeros((0, V.shape[1] if V.ndim == 2 else 0))
    _, s, Vt = np.linalg.svd(V, full_matrices=False)
    P = Vt[s > tol * max(s.max(), 1e-300)]
    out: list[npt.NDArray] = []
    for e in np.eye(V.shape[1]):
        if len(out) == len(P):
            break
        if np.linalg.norm(P @ e) > 1 - tol and all(abs(o @ e) < tol for o in out):
            out.append(e)
    for p in P:
        if len(out) == len(P):
            break
        q = p - sum((o @ p) * o for o in out)
        if np.linalg.norm(q) > tol:
            q = q / np.linalg.norm(q)
            q = q * np.sign(q[np.argmax(np.abs(q))])
            out.append(q)
    return np.array(out).reshape(len(out), V.shape[1])


def _body_motions(Z: npt.NDArray, name: str, c: npt.NDArray, L: float) -> list[UnheldMotion]:
    """Words for the span of ``Z`` (``(nm, k)``: columns are motions of one body, in the
    scaled modes of :func:`mode_values`)."""
    gdim = 2 if Z.shape[0] == 3 else 3
    if Z.shape[1] == 0:
        return []
    a, om = Z[:gdim], Z[gdim:]  # translation and scaled angular velocity of each column
    _, s, Vt = np.linalg.svd(om, full_matrices=True)
    rank = int(np.sum(s > 1e-6))
    pure = Vt[rank:].T  # combinations of the columns without rotation
    T = a @ pure
    out = [UnheldMotion(name, "translation", tuple(float(v) for v in d)) for d in _span_basis(T.T)]
    if rank == 0:
        return out
    rot = Vt[:rank].T  # combinations with independent rotations
    A, Om = a @ rot, om @ rot / L  # (gdim, r), (nω, r): translation, angular velocity
    for w in _span_basis(Om.T):
        coef = np.linalg.lstsq(Om, w, rcond=None)[0]
        t = A @ coef
        if T.shape[1]:  # less the free translations: the axis nearest the centroid
            t = t - T @ np.linalg.lstsq(T, t, rcond=None)[0]
        out.append(_rotation(name, c, w, t, L))
    return out


def _rounded(p: npt.NDArray, L: float) -> tuple[float, ...]:
    """A point to the resolution :data:`POINT_RESOLUTION` ``· L`` (what faceted normals
    determine), the same on any number of ranks."""
    res = POINT_RESOLUTION * L
    step = 10.0 ** np.ceil(np.log10(res))
    return tuple(float(v) + 0.0 for v in np.round(np.asarray(p) / step) * step)


def _rotation(name: str, c: npt.NDArray, w: npt.NDArray, t: npt.NDArray, L: float) -> UnheldMotion:
    """The rotation ``v = t + ω × (x − c)`` in words: axis point nearest ``c``, pitch."""
    if len(c) == 2:  # v = t + ω (−(y − cy), x − cx): centre p = c + (−t_y, t_x)/ω
        p = c + np.array([-t[1], t[0]]) / w[0]
        return UnheldMotion(name, "rotation", (0.0, 0.0, 1.0), _rounded(p, L))
    ww = float(w @ w)
    p = c + np.cross(w, t) / ww
    pitch = float(t @ w) / ww
    kind = "screw" if abs(pitch) > POINT_RESOLUTION * L else "rotation"
    d = w / np.sqrt(ww)
    return UnheldMotion(name, kind, tuple(float(v) for v in d), _rounded(p, L), pitch)


def describe_motions(N: npt.NDArray, bodies: Bodies, geo: BodyGeometry) -> list[UnheldMotion]:
    """Each body's share of the unheld motions ``N`` in words, body by body."""
    nm = geo.modes
    out = []
    for k, name in enumerate(bodies.names):
        Z = N[k * nm : (k + 1) * nm]
        if Z.size == 0 or np.linalg.norm(Z) < 1e-9:
            continue
        U, s, _ = np.linalg.svd(Z, full_matrices=False)
        Zk = U[:, s > 1e-6 * s.max()]
        out += _body_motions(Zk, name, geo.centre[k], float(geo.size[k]))
    return out


# --------------------------------------------------------------------------------------
# the check
# --------------------------------------------------------------------------------------
def unheld_motions(
    scene: Scene, md: Any, groups: Mapping[str, tuple[int, int]], comm: MPI.Comm
) -> list[UnheldMotion]:
    """The rigid motions of the scene's bodies that no support and no contact holds
    (collective; the same list on every rank and any number of ranks).

    Parameters
    ----------
    scene
        The scene.
    md
        Its mesh data (mesh, cell and facet tags).
    groups
        Physical-group name → ``(dim, tag)``.
    comm
        The mesh's communicator.
    """
    msh = md.mesh
    tdim = msh.topology.dim
    names = {t: n for n, (d, t) in groups.items() if d == tdim}
    tags = {n: t for n, (d, t) in groups.items()}
    bodies = find_bodies(msh, md.cell_tags, names, comm)
    geo = body_geometry(msh, bodies, comm)
    sets = dirichlet_sets(scene, msh, md.facet_tags, tags, bodies, geo, comm)
    sets += contact_sets(scene, msh, md.facet_tags, tags, bodies, geo, comm)
    return describe_motions(unheld_subspace(sets, _metric(bodies, geo)), bodies, geo)


def _metric(bodies: Bodies, geo: BodyGeometry) -> npt.NDArray[np.float64]:
    """The block-diagonal metric of all bodies' rigid modes."""
    metric = np.zeros((bodies.count * geo.modes,) * 2)
    for k in range(bodies.count):
        sl = slice(k * geo.modes, (k + 1) * geo.modes)
        metric[sl, sl] = geo.metric[k]
    return metric


def unheld_message(scene: Scene, motions: Sequence[UnheldMotion]) -> str:
    """The report of :func:`check_rigid_motions`: every unheld motion, one a line, and
    what to do about them."""
    lines = "\n".join(f"  - {m}" for m in motions)
    n = len(motions)
    head = (
        f"{n} rigid motion{'s' if n > 1 else ''} of the bodies {'are' if n > 1 else 'is'} "
        "held by no [[dirichlet]] support and no [[contact]] (a frictionless contact holds "
        "only motion normal to its surface), so the displacement is not determined"
    )
    if scene.analysis is not None and scene.analysis.unheld_motion == "warn":
        tail = 'the run goes on ([analysis] unheld_motion = "warn")'
    else:
        tail = (
            "fix the motion (a [[dirichlet]] component on a group of that body), or set "
            '[analysis] unheld_motion = "warn" to run anyway'
        )
    return f"{head}:\n{lines}\n{tail}"


def check_rigid_motions(
    scene: Scene, md: Any, groups: Mapping[str, tuple[int, int]], comm: MPI.Comm
) -> list[UnheldMotion]:
    """Refuse (or warn about) a static or quasi-static scene with an unheld rigid motion.

    Dynamic analyses are not checked: the mass holds a free body (it moves as the loads
    say).  Collective.

    Returns
    -------
    list of UnheldMotion
        The unheld motions (empty: every body is held).

    Raises
    ------
    SceneError
        On every rank, when a motion is unheld and ``[analysis] unheld_motion`` is
        ``"error"`` (the default).  With ``"warn"`` an :class:`UnheldMotionWarning` is
        issued instead.
    """
    if scene.analysis is None or scene.analysis.kind == "dynamic":
        return []
    motions = unheld_motions(scene, md, groups, comm)
    if motions:
        text = unheld_message(scene, motions)
        if scene.analysis.unheld_motion == "warn":
            warnings.warn(text, UnheldMotionWarning, stacklevel=2)
        else:
            raise SceneError(str(scene.path), "[analysis]", "unheld_motion", text)
    return motions


# --------------------------------------------------------------------------------------
# a singular system during the contact iterations
# --------------------------------------------------------------------------------------
def _block_bodies(V: Any, bodies: Bodies) -> npt.NDArray[np.int64]:
    """Body of every local block (node) of the vector space ``V``."""
    imap = V.dofmap.index_map
    out = np.full(imap.size_local + imap.num_ghosts, -1, dtype=np.int64)
    cells = np.asarray(V.dofmap.list)
    out[cells] = bodies.cell_body[: len(cells), None]
    return out


def _active_set(
    itf: Any,
    on: npt.NDArray,
    full: npt.NDArray,
    body: npt.NDArray,
    masters: Sequence[int],
    geo: BodyGeometry,
    n: int,
    comm: MPI.Comm,
) -> ConstraintSet:
    """What the active nodes ``on`` of one interface hold: the normal relative velocity
    (the whole relative velocity at the sticking nodes ``full``), weighted by ``∫ψ_p``."""
    G, W = np.zeros((n, n)), np.zeros((n, n))
    sel = np.flatnonzero(on)
    slave = body[itf.blocks[sel]]
    for b in np.unique(slave):
        for m in masters:
            if m != b:
                k = sel[slave == b]
                pair, rel = _relative_modes(itf.coords[k], int(b), m, geo)
                w = np.abs(itf.weight[k])
                _accumulate(G, W, pair, geo.modes, rel, w, itf.normals[k], full[k])
    G, W = comm.allreduce(G, op=MPI.SUM), comm.allreduce(W, op=MPI.SUM)
    return ConstraintSet(f'contact "{itf.name}"', G, W, CONTACT_SHARE)


def singular_diagnosis(
    scene: Scene,
    md: Any,
    groups: Mapping[str, tuple[int, int]],
    V: Any,
    interfaces: Sequence[Any],
    comm: MPI.Comm,
) -> Callable[[Sequence[npt.NDArray], Sequence[npt.NDArray]], str]:
    """Which bodies an active set leaves without support (for the contact solver).

    Parameters
    ----------
    scene, md, groups
        The scene, its mesh data and physical groups.
    V
        The displacement space the interfaces' nodes (``blocks``) belong to.
    interfaces
        The mortar interfaces, one per ``[[contact]]`` pair in scene order.
    comm
        The mesh's communicator.

    Returns
    -------
    callable
        ``diagnose(active, stick)`` (per interface, booleans over its owned slave nodes;
        collective) → the motions that the supports and the active nodes (sticking
        nodes holding every direction, the other active nodes the normal one) leave
        free, in words (empty when there is none).
    """
    cache: dict[str, Any] = {}

    def prepare() -> dict[str, Any]:  # on the first call only: a run that never fails pays nothing
        msh = md.mesh
        tdim = msh.topology.dim
        names = {t: n for n, (d, t) in groups.items() if d == tdim}
        tags = {n: t for n, (d, t) in groups.items()}
        bodies = find_bodies(msh, md.cell_tags, names, comm)
        geo = body_geometry(msh, bodies, comm)
        return {
            "bodies": bodies,
            "geo": geo,
            "supports": dirichlet_sets(scene, msh, md.facet_tags, tags, bodies, geo, comm),
            # a pair whose groups the run made itself (a crack's faces, inside one body)
            # holds no motion between bodies:
            "masters": [
                _present(msh, md.facet_tags, tags[c.master], bodies, comm)
                if c.master in tags
                else []
                for c in scene.contacts
            ],
            "body": _block_bodies(V, bodies),
            "metric": _metric(bodies, geo),
        }

    def diagnose(active: Sequence[npt.NDArray], stick: Sequence[npt.NDArray]) -> str:
        if not cache:
            cache.update(prepare())
        c = cache
        n = c["metric"].shape[0]
        sets = list(c["supports"])
        for itf, on, full, m in zip(interfaces, active, stick, c["masters"], strict=False):
            sets.append(_active_set(itf, on, full & on, c["body"], m, c["geo"], n, comm))
        N = unheld_subspace(sets, c["metric"])
        return "; ".join(str(m) for m in describe_motions(N, c["bodies"], c["geo"]))

    return diagnose
