"""Dual-mortar contact interfaces as distributed PETSc operators
(docs/theory/mortar.md#dual-mortar-discretisation).

A :class:`ContactInterface` is built from two facet groups of one mesh — the slave
surface (it carries the multiplier) and the master surface — on bodies whose
interfaces do not share nodes, or from a slave group and a rigid plane.  It holds, for
the slave nodes that this rank owns and that carry a multiplier (``D_pp > 0``):
averaged unit nodal normals ``n_p`` (out of the slave body) and tangents ``t_p``, the
diagonal mortar matrix ``D_pp = ∫ ψ_p φ_p``, the weighted gap ``d_p = ∫ ψ_p g``, the
nodal gap ``d_p / D_pp``, and the triplets of ``M̂ = D⁻¹M`` in global dof numbering.
:func:`basis_transform` turns those into ``Qᵀ`` (``U = Qᵀ Û``,
docs/theory/mortar.md#condensation-of-the-multipliers), so that ``Â = Q A Qᵀ`` and
``F̂ = Q F``; :func:`transformed_operator` forms ``T Q A Qᵀ Tᵀ`` in one product.

Parallel design: a contact surface is small compared with the mesh, so the slave
surface's nodes and facets (not the system) are gathered on every rank; every rank
integrates an equal, spatially compact share of the slave facets
(:mod:`bonecontact.contact.mortar_assembly`) against the master facets within the
bounding box of their search region (each rank sends the others only those),
``D`` and the weighted gap are summed over ranks, and each row of ``M̂`` is sent to
the rank owning it.  Normals come from the gathered surface, so a node shared by
several ranks has the same normal everywhere and results do not depend on the partition.

Units: coordinates in m; ``D`` in m (2D, per unit thickness) or m²; gaps in m.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
from dolfinx import fem
from scipy.spatial import cKDTree

from bonecontact.common.errors import InputError
from bonecontact.contact.dual_basis import (
    element_mass_matrices,
    modify_dual_coefficients,
    reference_dual_coefficients,
)
from bonecontact.contact.geometry import facet_normals, nodal_normals, nodal_tangents
from bonecontact.contact.mortar_assembly import assemble_mortar
from bonecontact.contact.search import morton_order, swept_facet_boxes

__all__ = [
    "ContactInputError",
    "ContactInterface",
    "RigidPlane",
    "basis_transform",
    "build_interface",
    "rotation_matrix",
    "transformed_operator",
]


#: Initial interpenetration accepted by default, as a fraction of the local slave facet
#: size (docs/theory/mortar.md#candidate-search): deeper overlaps are refused.
PENETRATION_FRACTION = 0.5


class ContactInputError(InputError):
    """A contact interface cannot be built from the given surfaces (collective)."""


@dataclass(frozen=True)
class RigidPlane:
    """A rigid, fixed obstacle ``{x : (x − point)·normal = 0}``.

    ``normal`` points from the deformable body into the obstacle.
    """

    point: tuple[float, ...]
    normal: tuple[float, ...]


@dataclass
class ContactInterface:
    """One slave/master contact pair, distributed (see the module docstring).

    Attributes
    ----------
    name
        Pair name (used in output file names).
    gdim
        Geometric dimension.
    blocks, global_blocks
        Local and global block (node) indices in ``V`` of the owned slave nodes that
        carry a multiplier.
    coords, normals, tangents
        Their reference coordinates, unit normals (out of the slave body) and tangents
        (``(n, gdim-1, gdim)``).
    D, weighted_gap
        ``D_pp`` and ``d_p``; ``gap = d_p / D_pp`` is the nodal (normal) gap in m.
    weight
        ``∫ψ_p``, the measure a nodal multiplier acts on (``= D_pp`` except next to
        nodes without a multiplier); the contact force is ``Σ_p weight_p λ_p``.
    qt_rows, qt_cols, qt_vals
        Entries of ``M̂`` (rows: slave dofs, columns: master dofs, global dof numbers)
        that this rank owns — the off-identity part of ``Qᵀ``.
    slave_area, covered_area
        Measure of the whole slave surface and of its part covered by the master.
    rigid
        Whether the master is a :class:`RigidPlane`.
    start_open
        A cold start begins with none of the pair's nodes active (the plain active-set
        rule then closes the nodes that penetrate): the two faces of a crack, whose gaps
        are all zero by construction, so that the closed-gap start would glue the whole
        crack (docs/theory/pdas.md#cold-start).  ``False``: the closed-gap nodes and their
        support patch.
    build_stats
        What :func:`build_interface` did on this rank: wall times (s) of its phases,
        ``t_gather`` (surfaces, normals, nearby master facets), ``t_search`` (candidate
        pairs), ``t_integrate`` (projection, clipping, quadrature), ``t_assemble``
        (local D, M, gap), ``t_distribute`` (sums over ranks, rows of M̂ to their
        owners, checks) and ``t_total``; and counts ``n_slave_facets`` (integrated here),
        ``n_master_facets`` (received), ``n_candidates`` and ``n_pairs`` (integrated).
    """

    name: str
    gdim: int
    blocks: npt.NDArray[np.int32]
    global_blocks: npt.NDArray[np.int64]
    coords: npt.NDArray[np.float64]
    normals: npt.NDArray[np.float64]
    tangents: npt.NDArray[np.float64]
    D: npt.NDArray[np.float64]
    weighted_gap: npt.NDArray[np.float64]
    weight: npt.NDArray[np.float64]
    qt_rows: npt.NDArray[np.int64] = field(repr=False)
    qt_cols: npt.NDArray[np.int64] = field(repr=False)
    qt_vals: npt.NDArray[np.float64] = field(repr=False)
    slave_area: float = 0.0
    covered_area: float = 0.0
    rigid: bool = False
    start_open: bool = False
    build_stats: dict[str, float] = field(default_factory=dict, repr=False)

    @property
    def gap(self) -> npt.NDArray[np.float64]:
        """Nodal normal gap ``d_p / D_pp`` (m, ≥ 0 when open)."""
        return self.weighted_gap / self.D

    @property
    def num_owned(self) -> int:
        return int(self.blocks.size)


# ------------------------------------------------------------------------ surfaces
def _vertex_to_block(V: fem.FunctionSpace) -> npt.NDArray[np.int32]:
    """Local dof block of every local vertex (P1 Lagrange on a P1 geometry)."""
    msh = V.mesh
    tdim = msh.topology.dim
    c2v = msh.topology.connectivity(tdim, 0)
    nv = tdim + 1
    nverts = msh.topology.index_map(0).size_local + msh.topology.index_map(0).num_ghosts
    v2b = np.full(nverts, -1, dtype=np.int32)
    v2b[c2v.array.reshape(-1, nv)] = V.dofmap.list
    return v2b


def _local_surface(V: fem.FunctionSpace, facet_tags, tag: int):
    """Owned facets of group ``tag``: global blocks, vertex coords, interior points."""
    msh = V.mesh
    tdim, gdim = msh.topology.dim, msh.geometry.dim
    fdim = tdim - 1
    msh.topology.create_connectivity(fdim, 0)
    msh.topology.create_connectivity(fdim, tdim)
    msh.topology.create_connectivity(tdim, 0)
    n_owned_f = msh.topology.index_map(fdim).size_local
    facets = facet_tags.find(tag)
    facets = facets[facets < n_owned_f]
    f2v = msh.topology.connectivity(fdim, 0)
    f2c = msh.topology.connectivity(fdim, tdim)
    verts = f2v.array.reshape(-1, gdim)[facets] if facets.size else np.zeros((0, gdim), np.int32)
    blocks = _vertex_to_block(V)[verts]
    xdof = V.tabulate_dof_coordinates()[:, :gdim]
    coords = xdof[blocks]
    cells = f2c.array[f2c.offsets[facets]] if facets.size else np.zeros(0, np.int32)
    gx = msh.geometry.x[:, :gdim]
    interior = (
        gx[msh.geometry.dofmaps[0][cells]].mean(axis=1) if facets.size else np.zeros((0, gdim))
    )
    imap = V.dofmap.index_map
    gblocks = imap.local_to_global(blocks.ravel().astype(np.int32)).reshape(blocks.shape)
    return gblocks.astype(np.int64), coords, interior


def _gather_surface(comm: MPI.Comm, gblocks, coords, interior):
    """Gather a surface on every rank; compact node numbering.

    Returns (node_gids, node_coords, facets (compact), interior), the same on every rank.
    """
    parts = comm.allgather((gblocks, coords, interior))
    gdim = coords.shape[-1] if coords.size else parts[0][1].shape[-1]
    gb = np.concatenate([p[0] for p in parts]).reshape(-1, gdim)
    xc = np.concatenate([p[1] for p in parts]).reshape(-1, gdim, gdim)
    inner = np.concatenate([p[2] for p in parts]).reshape(-1, gdim)
    gids, inv = np.unique(gb.ravel(), return_inverse=True)
    facets = inv.reshape(gb.shape)
    node_x = np.zeros((gids.size, gdim))
    node_x[facets.ravel()] = xc.reshape(-1, gdim)
    return gids, node_x, facets, inner


def _allreduce(comm: MPI.Comm, a: np.ndarray, op, dtype=np.float64) -> np.ndarray:
    """Element-wise reduction of a NumPy array over all ranks (as ``dtype`` on every
    rank: an empty ``bincount`` is int64 on one rank and float64 on another)."""
    a = np.ascontiguousarray(a, dtype=dtype)
    out = np.empty_like(a)
    comm.Allreduce(a, out, op=op)
    return out


def _owner_ranges(comm: MPI.Comm, V: fem.FunctionSpace) -> npt.NDArray[np.int64]:
    r = V.dofmap.index_map.local_range
    return np.array(comm.allgather(int(r[0])) + [V.dofmap.index_map.size_global], dtype=np.int64)


@dataclass
class _SlaveSurface:
    """The slave surface gathered on every rank (compact node numbering)."""

    gids: npt.NDArray[np.int64]  # global block of every node
    x: npt.NDArray[np.float64]  # node coordinates
    facets: npt.NDArray[np.int64]  # facets (compact node numbers)
    interior: npt.NDArray[np.float64]  # a point inside the cell of every facet
    mine: npt.NDArray[np.int64]  # the facets this rank integrates (its share of the work)
    measure: npt.NDArray[np.float64]  # facet measures
    normals: npt.NDArray[np.float64]  # averaged unit nodal normals
    size: float  # largest extent of the surface (m)


@dataclass
class _MortarData:
    """Mortar integrals of a slave surface, summed over ranks where they are nodal.

    ``d`` and ``wgap`` (``D_pp``, ``d_p``) are per slave node; ``m_rows/m_cols/m_vals``
    the local ``M`` triplets (slave node, master node), ``off_*`` the local off-diagonal
    ``D`` triplets; ``normals`` the nodal normals the gap is measured along.
    """

    d: npt.NDArray[np.float64]
    wgap: npt.NDArray[np.float64]
    normals: npt.NDArray[np.float64]
    m_gids: npt.NDArray[np.int64]
    m_rows: npt.NDArray[np.int64]
    m_cols: npt.NDArray[np.int64]
    m_vals: npt.NDArray[np.float64]
    off_r: npt.NDArray[np.int64]
    off_c: npt.NDArray[np.int64]
    off_v: npt.NDArray[np.float64]
    covered: float


def _gather_slave_surface(V: fem.FunctionSpace, facet_tags, slave: int, name: str) -> _SlaveSurface:
    """Gather the slave group on every rank, check it, and compute its nodal normals."""
    comm, gdim = V.mesh.comm, V.mesh.geometry.dim
    s_gids, s_x, s_f, s_in = _gather_surface(comm, *_local_surface(V, facet_tags, slave))
    if s_f.shape[0] == 0:
        raise ContactInputError(f"contact {name!r}: the slave facet group {slave} is empty")
    _, measure = facet_normals(s_x, s_f, s_in)
    size = float(np.ptp(s_x, axis=0).max()) or 1.0
    if (measure <= 1e-12 * size ** (gdim - 1)).any():
        raise ContactInputError(
            f"contact {name!r}: degenerate (zero-measure) facets in slave group {slave}"
        )
    normals = nodal_normals(s_x, s_f, s_in)
    mine = _share_of_facets(comm, s_x[s_f].mean(axis=1))
    return _SlaveSurface(s_gids, s_x, s_f, s_in, mine, measure, normals, size)


def _share_of_facets(comm: MPI.Comm, centres: npt.NDArray[np.float64]) -> npt.NDArray[np.int64]:
    """The slave facets this rank integrates: the ``rank``-th of ``size`` equal, contiguous
    pieces of the facets' Morton order (every facet once, spatially compact pieces).

    The mesh partition may put a whole contact zone on one rank; the gathered slave
    surface is the same on every rank, so the work is shared out evenly instead.
    """
    order = morton_order(centres) if len(centres) else np.zeros(0, dtype=np.int64)
    bounds = np.linspace(0, len(order), comm.size + 1).round().astype(np.int64)
    return np.sort(order[bounds[comm.rank] : bounds[comm.rank + 1]])


def _dirichlet_node_mask(
    V: fem.FunctionSpace, gids: npt.NDArray[np.int64], dirichlet_dofs: npt.ArrayLike | None
) -> npt.NDArray[np.bool_]:
    """Slave nodes with Dirichlet dofs (they carry no multiplier); collective."""
    bs = V.dofmap.index_map_bs
    mask = np.zeros(gids.size, dtype=np.int32)
    if dirichlet_dofs is not None:
        bc_blocks = np.unique(np.asarray(dirichlet_dofs, dtype=np.int64) // bs)
        bc_blocks = bc_blocks[bc_blocks < V.dofmap.index_map.size_local]
        gbc = V.dofmap.index_map.local_to_global(bc_blocks.astype(np.int32)).astype(np.int64)
        mask[np.isin(gids, gbc)] = 1
    return _allreduce(V.mesh.comm, mask, MPI.MAX, dtype=np.int32).astype(bool)


def _rigid_plane_mortar(
    comm: MPI.Comm, surf: _SlaveSurface, plane: RigidPlane, mask: npt.NDArray[np.bool_]
) -> _MortarData:
    """``D`` and the weighted gap against a rigid plane (no master nodes, ``M = 0``)."""
    s_x, n_nodes = surf.x, surf.gids.size
    gdim = s_x.shape[1]
    own_f = surf.facets[surf.mine]
    nu = np.asarray(plane.normal, dtype=float)[:gdim]
    nu = nu / np.linalg.norm(nu)
    x0 = np.asarray(plane.point, dtype=float)[:gdim]
    base = reference_dual_coefficients(gdim)
    coeffs = modify_dual_coefficients(base, mask[own_f]) if mask.any() else base
    # facet matrices D_f[j, k] = ∫ψ_j φ_k (diagonal unless the basis was modified)
    mass = element_mass_matrices(s_x[own_f]) if own_f.size else np.zeros((0, gdim, gdim))
    c = np.broadcast_to(coeffs, (own_f.shape[0], gdim, gdim))
    dfac = np.einsum("fjl,flk->fjk", c, mass)
    gap_nodal = (x0 - s_x) @ nu
    d = _allreduce(
        comm,
        np.bincount(own_f.ravel(), weights=np.einsum("fjj->fj", dfac).ravel(), minlength=n_nodes),
        MPI.SUM,
    )
    wgap = _allreduce(
        comm,
        np.bincount(
            own_f.ravel(),
            weights=np.einsum("fjk,fk->fj", dfac, gap_nodal[own_f]).ravel(),
            minlength=n_nodes,
        ),
        MPI.SUM,
    )
    jj, kk = np.nonzero(~np.eye(gdim, dtype=bool))
    empty = np.zeros(0, np.int64)
    return _MortarData(
        d=d,
        wgap=wgap,
        normals=np.broadcast_to(nu, s_x.shape).copy(),
        m_gids=empty,
        m_rows=empty,
        m_cols=empty,
        m_vals=np.zeros(0),
        off_r=own_f[:, jj].ravel(),
        off_c=own_f[:, kk].ravel(),
        off_v=dfac[:, jj, kk].ravel(),
        covered=float(surf.measure.sum()),
    )


def _slave_search_radius(
    surf: _SlaveSurface, search_radius: float | None, extension: float = 0.0
) -> np.ndarray:
    """Search distance of every slave facet this rank integrates: ``search_radius``, or by
    default three times the facet's size (its length in 2D, ``sqrt(2 |facet|)`` in 3D)
    plus ``extension``, the separation of surfaces that start apart
    (:func:`_search_extension`)."""
    measure = surf.measure[surf.mine]
    if search_radius is not None:
        return np.full(measure.shape, float(search_radius))
    return 3.0 * _facet_sizes(surf.x.shape[1], measure) + extension


def _facet_sizes(gdim: int, measure: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Size of facets of the given measures: the length in 2D, ``sqrt(2 |facet|)`` in 3D."""
    return measure if gdim == 2 else np.sqrt(2.0 * measure)


@dataclass(frozen=True)
class Separation:
    """Where a slave and a master surface come closest (node to node).

    Attributes
    ----------
    distance
        Smallest distance between a slave node and a master node (m).
    slave_point
        That slave node's coordinates.
    facet_size
        The larger of the two facet sizes there (m): node-to-node distances of
        touching surfaces are up to about this.
    ahead
        Whether that master node lies on the side the slave normal points to (else the
        master is behind the slave surface: a wrong group, or a thin slave body).
    """

    distance: float
    slave_point: npt.NDArray[np.float64]
    facet_size: float
    ahead: bool = True


def surface_separation(
    comm: MPI.Comm,
    slave_x: npt.NDArray[np.float64],
    slave_facets: npt.NDArray[np.int64],
    slave_measure: npt.NDArray[np.float64],
    master_coords: npt.NDArray[np.float64],
    slave_normals: npt.NDArray[np.float64] | None = None,
) -> Separation:
    """The closest slave/master node pair of two surfaces (collective).

    ``slave_x``, ``slave_facets`` and ``slave_measure`` describe the slave surface
    (replicated on every rank); ``master_coords`` ``(f, gdim, gdim)`` the vertices of
    this rank's master facets; ``slave_normals`` (optional) the slave nodal normals,
    which tell whether that master node lies ahead of the slave surface.  Nearest slave
    node of every master vertex (k-d tree), the smallest over all ranks; the same on
    every rank and for every partition.
    """
    gdim = slave_x.shape[1]
    size_s = np.zeros(slave_x.shape[0])
    np.maximum.at(size_s, slave_facets, _facet_sizes(gdim, slave_measure)[:, None])
    best = (np.inf, 0, 0.0, True)
    if master_coords.shape[0] and slave_x.shape[0]:
        mx = master_coords.reshape(-1, gdim)
        dist, j = cKDTree(slave_x).query(mx, k=1)
        i = int(np.argmin(dist))
        _, m_measure = facet_normals(master_coords[i // gdim], np.arange(gdim)[None, :])
        h_m = float(_facet_sizes(gdim, m_measure)[0])
        ahead = slave_normals is None or float((mx[i] - slave_x[j[i]]) @ slave_normals[j[i]]) >= 0
        best = (float(dist[i]), int(j[i]), max(h_m, float(size_s[j[i]])), bool(ahead))
    dist, node, h, ahead = min(comm.allgather(best), key=lambda b: (b[0], b[1]))
    return Separation(dist, slave_x[node].copy(), h, ahead)


def _search_extension(sep: Separation) -> float:
    """How much farther than the default the slave facets search: the separation of
    surfaces that start apart, less one facet size (0 for touching surfaces, whose
    closest nodes may be up to a facet size apart), so the default search reaches three
    facet sizes beyond the first contact (docs/theory/mortar.md#candidate-search)."""
    if not (np.isfinite(sep.distance) and sep.ahead):
        return 0.0  # (a master behind the slave surface is not searched for)
    return max(sep.distance - sep.facet_size, 0.0)


def _master_near_slave(
    comm: MPI.Comm,
    local_master: tuple[np.ndarray, np.ndarray, np.ndarray],
    box: tuple[np.ndarray, np.ndarray],
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """The master facets (of all ranks) whose bounding box meets each rank's search box.

    ``box`` is the bounding box of the sweeps of this rank's slave facets (``lower >
    upper`` when it has none); every rank sends each other rank its owned master facets
    inside that rank's box, so no rank holds the whole master surface.

    Returns (node_gids, node_coords, facets (compact)) of the master facets received.
    """
    gblocks, coords, _ = local_master
    gdim = box[0].shape[0]
    boxes = comm.allgather(box)
    lo_f, hi_f = coords.min(axis=1), coords.max(axis=1)
    send = []
    for lo, hi in boxes:
        near = np.all((lo_f <= hi) & (hi_f >= lo), axis=1)
        send.append((gblocks[near], coords[near]))
    recv = comm.alltoall(send)
    gb = np.concatenate([r[0] for r in recv]).reshape(-1, gdim).astype(np.int64)
    xc = np.concatenate([r[1] for r in recv]).reshape(-1, gdim, gdim)
    gids, inv = np.unique(gb.ravel(), return_inverse=True)
    facets = inv.reshape(gb.shape)
    node_x = np.zeros((gids.size, gdim))
    node_x[facets.ravel()] = xc.reshape(-1, gdim)
    return gids, node_x, facets


@dataclass(frozen=True)
class _PairLabels:
    """How messages name a pair: its name and its two groups (physical-group names when
    known, else the tags)."""

    name: str
    slave: str
    master: str

    @classmethod
    def of(cls, name: str, slave: int, master: int, groups: tuple[str, str] | None):
        if groups is None:
            return cls(name, f"group {slave}", f"group {master}")
        return cls(name, f'"{groups[0]}" (tag {slave})', f'"{groups[1]}" (tag {master})')


def _nothing_opposite(labels: _PairLabels, r_max: float, sep: Separation) -> ContactInputError:
    """The error for a slave surface with no master facet within the search distance."""
    where = ", ".join(f"{c:.4g}" for c in sep.slave_point)
    behind = (
        ""
        if sep.ahead
        else " The closest master node lies behind the slave surface (against its normal):"
        " is the slave group the surface that faces the other body?"
    )
    return ContactInputError(
        f"contact {labels.name!r}: no master facet of {labels.master} lies opposite the "
        f"slave surface {labels.slave} within the search distance {r_max:.3g} m (along "
        f"the slave normals); the smallest distance between the two surfaces is "
        f"{sep.distance:.3g} m (at the slave node ({where})). The key [[contact]] "
        f"search_distance sets how far the slave facets search (default: three slave "
        f"facet sizes beyond the closest distance); check that the master surface faces "
        f"the slave one.{behind}"
    )


def _master_surface_mortar(
    V: fem.FunctionSpace,
    surf: _SlaveSurface,
    mask: npt.NDArray[np.bool_],
    radius: npt.NDArray[np.float64],
    stats: dict[str, float],
    local_master: tuple[np.ndarray, np.ndarray, np.ndarray],
    shift: npt.NDArray[np.float64] | None = None,
    coincident: float | None = None,
) -> _MortarData:
    """Gather the master facets near each rank's slave facets and integrate the owned slave
    facets (moved by ``shift``, if given) against them within the search distances
    ``radius`` (only the coincident ones, see :func:`build_interface`); phase times and
    counts are added to ``stats``."""
    comm, gdim = V.mesh.comm, V.mesh.geometry.dim
    t0 = time.perf_counter()
    xs = surf.x if shift is None else surf.x + shift
    own_f = surf.facets[surf.mine]
    normals = surf.normals if gdim == 2 else None
    lower, upper = swept_facet_boxes(xs, own_f, radius, normals)
    box = (
        (lower.min(axis=0), upper.max(axis=0))
        if own_f.size
        else (np.full(gdim, np.inf), np.full(gdim, -np.inf))
    )
    m_gids, m_x, m_f = _master_near_slave(comm, local_master, box)
    stats["t_gather"] = stats.get("t_gather", 0.0) + time.perf_counter() - t0
    contrib = assemble_mortar(
        xs,
        own_f,
        surf.normals,
        m_x,
        m_f,
        search_radius=radius,
        slave_node_mask=mask if mask.any() else None,
        coincident=coincident,
    )
    for key, value in contrib.pairs.timings.items():
        stats[f"t_{key}"] = value
    stats["n_slave_facets"] = own_f.shape[0]
    stats["n_master_facets"] = m_f.shape[0]
    stats["n_candidates"] = contrib.pairs.candidates
    stats["n_pairs"] = contrib.pairs.slave_facet.size
    d = _allreduce(comm, contrib.d, MPI.SUM)
    wgap = _allreduce(comm, contrib.gap, MPI.SUM)
    covered = comm.allreduce(float(contrib.covered_area.sum()), op=MPI.SUM)
    return _MortarData(
        d=d,
        wgap=wgap,
        normals=surf.normals,
        m_gids=m_gids,
        m_rows=contrib.m_rows,
        m_cols=contrib.m_cols,
        m_vals=contrib.m_vals,
        off_r=contrib.d_off_rows,
        off_c=contrib.d_off_cols,
        off_v=contrib.d_off_vals,
        covered=covered,
    )


def _check_master(
    comm: MPI.Comm,
    labels: _PairLabels,
    local_master: tuple[np.ndarray, np.ndarray, np.ndarray],
    shared: npt.NDArray[np.bool_],
) -> None:
    """Refuse an empty master group and surfaces that share nodes (collective)."""
    if comm.allreduce(local_master[0].shape[0], op=MPI.SUM) == 0:
        raise ContactInputError(
            f"contact {labels.name!r}: the master facet group {labels.master} is empty"
        )
    if shared.any():
        raise ContactInputError(
            f"contact {labels.name!r}: slave and master surfaces share nodes; the bodies "
            "must be meshed separately (no shared interface nodes)"
        )


def approach_vector(
    normals: npt.NDArray[np.float64],
    gap: npt.NDArray[np.float64],
    tol: float,
) -> npt.NDArray[np.float64]:
    """The rigid translation of the slave surface that closes the smallest gap
    (docs/theory/pdas.md#bodies-that-start-apart).

    The direction is the mean normal of the closest nodes (gap within ``tol`` of the
    smallest; the mean, not one node's normal, so that nodes with equal gaps — a
    symmetric contact — give the same direction whatever their numbering); the
    distance is the smallest gap along it, ``min_p g_p / (n_p · e)`` over the nodes
    facing that way (``n_p · e > 1/2``).  Zero if the surfaces touch or interpenetrate.

    Parameters
    ----------
    normals, gap
        Unit nodal normals and nodal gaps of the slave nodes that carry a multiplier.
    tol
        Gaps within ``tol`` of the smallest count as equal.
    """
    gdim = normals.shape[1] if normals.ndim == 2 else 2
    if gap.size == 0 or float(gap.min()) <= tol:
        return np.zeros(gdim)
    closest = gap <= float(gap.min()) + tol
    e = normals[closest].sum(axis=0)
    e = e / np.linalg.norm(e)
    ne = normals @ e
    facing = ne > 0.5
    return float(np.min(gap[facing] / ne[facing])) * e


def _multiplier_nodes(surf: _SlaveSurface, d: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
    """Slave nodes that carry a multiplier.

    A node carries a multiplier when at least a tenth of its support is covered by the
    master: barely covered nodes (D_pp = ∫_cov φ_p → 0) would give an ill-determined
    M̂ = D⁻¹M and d_p/D_pp.  Such nodes only occur where the master
    ends (far from any contact zone when the master is sized as it should be).
    """
    gdim = surf.x.shape[1]
    full = np.bincount(
        surf.facets.ravel(), weights=np.repeat(surf.measure / gdim, gdim), minlength=surf.gids.size
    )
    return d >= 0.1 * full


def _check_initial_gap(
    comm: MPI.Comm,
    surf: _SlaveSurface,
    mortar: _MortarData,
    carries: npt.NDArray[np.bool_],
    max_penetration: float | None,
    name: str,
) -> None:
    """Reject an initial interpenetration deeper than ``max_penetration``, by default
    :data:`PENETRATION_FRACTION` of the size of the slave facets at the node (collective).

    A slighter overlap (a segmentation voxel between two scanned bones) is a negative
    initial gap that the contact solve pushes apart; a deeper one is taken as a mistake
    in the meshes.
    """
    d, wgap = mortar.d, mortar.wgap
    gap_all = np.where(carries, wgap / np.where(carries, d, 1.0), np.inf)
    if max_penetration is not None:
        tol = np.full(gap_all.shape, float(max_penetration))
    else:
        size = np.zeros(surf.x.shape[0])
        np.maximum.at(size, surf.facets, _facet_sizes(surf.x.shape[1], surf.measure)[:, None])
        tol = PENETRATION_FRACTION * size
    excess = np.where(carries, gap_all + tol, np.inf)
    worst = int(np.argmin(excess)) if excess.size else 0
    if excess.size and excess[worst] < 0.0:
        where = ", ".join(f"{c:.4g}" for c in surf.x[worst])
        raise ContactInputError(
            f"contact {name!r}: the bodies interpenetrate initially (nodal gap "
            f"{gap_all[worst]:.3e} m at the slave node ({where}), deeper than the "
            f"{tol[worst]:.1e} m accepted there: {PENETRATION_FRACTION:g} of the slave "
            f"facet size); move them apart or fix the meshes"
        )


def _mhat_triplets(
    comm: MPI.Comm,
    surf: _SlaveSurface,
    mortar: _MortarData,
    carries: npt.NDArray[np.bool_],
    bs: int,
) -> tuple[
    npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64]
]:
    """Local triplets of ``M̂ = D⁻¹M`` in global dof numbers and the weights ``∫ψ_p``.

    Rows are slave dofs, columns master dofs.  Off-diagonal D entries that couple a
    node carrying a multiplier to a slave node without one (boundary-modified dual
    basis) act like master entries with −D_pq.  Returns ``(rows, cols, vals, weight)``,
    ``weight`` per slave node, summed over ranks.
    """
    s_gids, d = surf.gids, mortar.d
    m_rows, m_cols, m_vals = mortar.m_rows, mortar.m_cols, mortar.m_vals
    off_r, off_c, off_v = mortar.off_r, mortar.off_c, mortar.off_v
    comp = np.arange(bs)
    rows_l, cols_l, vals_l = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)], [np.zeros(0)]
    if m_vals.size:
        keep = carries[m_rows]
        r, c, v = m_rows[keep], m_cols[keep], m_vals[keep] / d[m_rows[keep]]
        rows_l.append((bs * s_gids[r][:, None] + comp[None, :]).ravel())
        cols_l.append((bs * mortar.m_gids[c][:, None] + comp[None, :]).ravel())
        vals_l.append(np.repeat(v, bs))
    sel = carries[off_r] & ~carries[off_c] & (off_v != 0.0)
    if sel.any():
        r, c, v = off_r[sel], off_c[sel], -off_v[sel] / d[off_r[sel]]
        rows_l.append((bs * s_gids[r][:, None] + comp[None, :]).ravel())
        cols_l.append((bs * s_gids[c][:, None] + comp[None, :]).ravel())
        vals_l.append(np.repeat(v, bs))
    rows, cols, vals = np.concatenate(rows_l), np.concatenate(cols_l), np.concatenate(vals_l)
    # ∫ψ_p: the area a nodal multiplier acts on (D_pp plus the modified-basis part)
    extra = (
        np.bincount(off_r[sel], weights=off_v[sel], minlength=s_gids.size)
        if sel.any()
        else np.zeros(s_gids.size)
    )
    weight = d + _allreduce(comm, extra, MPI.SUM)
    return rows, cols, vals, weight


def _send_rows_to_owners(
    comm: MPI.Comm,
    row_ranges: npt.NDArray[np.int64],
    rows: npt.NDArray[np.int64],
    cols: npt.NDArray[np.int64],
    vals: npt.NDArray[np.float64],
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    """Send every triplet to the rank owning its row (``row_ranges``: first row of every
    rank, then the global size); returns the triplets this rank owns."""
    owner = np.searchsorted(row_ranges, rows, side="right") - 1
    send = [(rows[owner == k], cols[owner == k], vals[owner == k]) for k in range(comm.size)]
    recv = comm.alltoall(send)
    q_rows = np.concatenate([x[0] for x in recv]).astype(np.int64)
    q_cols = np.concatenate([x[1] for x in recv]).astype(np.int64)
    q_vals = np.concatenate([x[2] for x in recv])
    return q_rows, q_cols, q_vals


def _surface_pair_mortar(
    V: fem.FunctionSpace,
    surf: _SlaveSurface,
    mask: npt.NDArray[np.bool_],
    search_radius: float | None,
    stats: dict[str, float],
    local_master: tuple[np.ndarray, np.ndarray, np.ndarray],
    labels: _PairLabels,
    approach: bool,
    coincident: float | None = None,
) -> _MortarData:
    """The mortar integrals of a slave surface against a master surface: searched from
    where the surfaces are closest, and (``approach``) evaluated after the rigid
    approach that closes the smallest gap (collective); ``coincident``: see
    :func:`build_interface`."""
    comm = V.mesh.comm
    sep = surface_separation(comm, surf.x, surf.facets, surf.measure, local_master[1], surf.normals)
    radius = _slave_search_radius(surf, search_radius, _search_extension(sep))
    mortar = _master_surface_mortar(
        V, surf, mask, radius, stats, local_master, coincident=coincident
    )
    if mortar.covered <= 0.0:
        r_max = comm.allreduce(float(radius.max(initial=0.0)), op=MPI.MAX)
        raise _nothing_opposite(labels, r_max, sep)
    if not approach:
        return mortar
    carries = _multiplier_nodes(surf, mortar.d)
    gap = mortar.wgap[carries] / mortar.d[carries]
    shift = approach_vector(surf.normals[carries], gap, 1e-9 * surf.size)
    stats["approach"] = float(np.linalg.norm(shift))
    if not shift.any():
        return mortar
    moved = _master_surface_mortar(
        V, surf, mask, _slave_search_radius(surf, search_radius), stats, local_master, shift
    )
    if moved.covered <= 0.0:  # (the approach brings the surfaces closer: never seen)
        return mortar
    # gaps measured from the initial position: g = g' + n_p · shift (D biorthogonal)
    moved.wgap += moved.d * (surf.normals @ shift)
    return moved


def build_interface(
    V: fem.FunctionSpace,
    facet_tags,
    slave: int,
    master: int | RigidPlane,
    *,
    dirichlet_dofs: npt.ArrayLike | None = None,
    name: str = "contact",
    search_radius: float | None = None,
    max_penetration: float | None = None,
    shared_nodes: str = "refuse",
    groups: tuple[str, str] | None = None,
    approach: bool = False,
    coincident: float | None = None,
) -> ContactInterface:
    """Build a contact interface (collective).

    Parameters
    ----------
    V
        P1 vector function space of the mesh that holds all bodies.
    facet_tags
        Facet ``MeshTags`` with the slave and master groups.
    slave
        Tag of the slave facets (the multiplier lives here; choose the finer or the
        softer side, as usual for mortar methods).
    master
        Tag of the master facets, or a :class:`RigidPlane`.
    dirichlet_dofs
        Local dof indices (unrolled) with Dirichlet conditions: slave nodes with any
        of them carry no multiplier (the dual basis is modified there,
        docs/theory/mortar.md#dual-basis).
    name
        Pair name.
    search_radius
        Search distance for master facets along the slave normals (m); default three
        times the size of each slave facet (docs/theory/mortar.md#candidate-search).
    max_penetration
        Initial interpenetration (negative nodal gap) beyond which the input is
        rejected (m); default half the size of the slave facets at each node.
    shared_nodes
        Nodes that belong to both surfaces (the tip of a crack whose two faces are the
        pair): ``"refuse"`` (default; bodies must be meshed separately) or
        ``"no_multiplier"``: such a node carries no multiplier (the dual basis is
        modified there as at a Dirichlet node, so its neighbour's multiplier covers the
        whole facet) and acts as a master node only; the jump across the pair vanishes
        there identically (docs/theory/fracture.md#crack-faces-in-contact).
    groups
        Names of the slave and master groups (physical-group names), used in messages.
    approach
        For surfaces that start apart (static and quasi-static analyses): evaluate the
        mortar geometry after a rigid approach of the slave surface that closes the
        smallest gap (:func:`approach_vector`), the gaps corrected by that translation
        so that they still measure from the initial position
        (docs/theory/pdas.md#bodies-that-start-apart).
    coincident
        Surfaces that lie on each other node by node (a crack's faces): a slave facet is
        paired only with master facets whose vertices are its own to this distance (m),
        not with every one whose projection overlaps it (``None``;
        :func:`~bonecontact.contact.mortar_assembly.coincident_pairs`).

    Raises
    ------
    ContactInputError
        Empty groups, degenerate facets, a slave surface that no master facet covers,
        initial interpenetration.
    """
    t_start = time.perf_counter()
    stats: dict[str, float] = {}
    # slave surface on every rank, its normals
    surf = _gather_slave_surface(V, facet_tags, slave, name)
    # slave nodes with Dirichlet dofs carry no multiplier
    mask = _dirichlet_node_mask(V, surf.gids, dirichlet_dofs)
    if shared_nodes not in ("refuse", "no_multiplier"):
        raise ValueError(f"shared_nodes: 'refuse' or 'no_multiplier', not {shared_nodes!r}")
    stats["t_gather"] = time.perf_counter() - t_start
    # mortar integrals: D, weighted gap, M
    if isinstance(master, RigidPlane):
        mortar = _rigid_plane_mortar(V.mesh.comm, surf, master, mask)
    else:
        labels = _PairLabels.of(name, slave, master, groups)
        mortar = _two_surface_mortar(
            V,
            facet_tags,
            master,
            surf,
            mask,
            labels,
            shared_nodes,
            search_radius,
            stats,
            approach,
            coincident,
        )
    # nodes carrying a multiplier, initial interpenetration
    carries = _multiplier_nodes(surf, mortar.d)
    _check_initial_gap(V.mesh.comm, surf, mortar, carries, max_penetration, name)
    return _distributed_interface(
        V, surf, mortar, carries, name, isinstance(master, RigidPlane), stats, t_start
    )


def _two_surface_mortar(
    V: fem.FunctionSpace,
    facet_tags,
    master: int,
    surf: _SlaveSurface,
    mask: npt.NDArray[np.bool_],
    labels: _PairLabels,
    shared_nodes: str,
    search_radius: float | None,
    stats: dict[str, float],
    approach: bool,
    coincident: float | None = None,
) -> _MortarData:
    """The mortar integrals of a slave surface against master facets (the arguments of
    :func:`build_interface`): nodes shared by both surfaces refused or, with
    ``shared_nodes="no_multiplier"``, added to the nodes without a multiplier."""
    comm = V.mesh.comm
    local_master = _local_surface(V, facet_tags, master)
    shared = _allreduce(
        comm, np.isin(surf.gids, local_master[0]).astype(np.int32), MPI.MAX, np.int32
    ).astype(bool)
    if shared_nodes == "no_multiplier":
        mask, shared = mask | shared, np.zeros_like(shared)
    _check_master(comm, labels, local_master, shared)
    return _surface_pair_mortar(
        V, surf, mask, search_radius, stats, local_master, labels, approach, coincident
    )


def _distributed_interface(
    V: fem.FunctionSpace,
    surf: _SlaveSurface,
    mortar: _MortarData,
    carries: npt.NDArray[np.bool_],
    name: str,
    rigid: bool,
    stats: dict[str, float],
    t_start: float,
) -> ContactInterface:
    """The interface of this rank: its owned slave nodes that carry a multiplier and the
    rows of ``M̂`` sent to the ranks that own them (collective)."""
    comm, gdim, bs = V.mesh.comm, V.mesh.geometry.dim, V.dofmap.index_map_bs
    ranges = _owner_ranges(comm, V)
    lo, hi = ranges[comm.rank], ranges[comm.rank + 1]
    # M̂ rows to their owners
    rows, cols, vals, weight = _mhat_triplets(comm, surf, mortar, carries, bs)
    q_rows, q_cols, q_vals = _send_rows_to_owners(comm, bs * ranges, rows, cols, vals)
    # owned slave nodes
    idx = np.flatnonzero((surf.gids >= lo) & (surf.gids < hi) & carries)
    n = mortar.normals[idx]
    stats["t_total"] = time.perf_counter() - t_start
    stats["t_distribute"] = stats["t_total"] - sum(
        stats.get(k, 0.0) for k in ("t_gather", "t_search", "t_integrate", "t_assemble")
    )
    return ContactInterface(
        name=name,
        gdim=gdim,
        blocks=(surf.gids[idx] - lo).astype(np.int32),
        global_blocks=surf.gids[idx],
        coords=surf.x[idx],
        normals=n,
        tangents=nodal_tangents(n) if idx.size else np.zeros((0, gdim - 1, gdim)),
        D=mortar.d[idx],
        weighted_gap=mortar.wgap[idx],
        weight=weight[idx],
        qt_rows=q_rows,
        qt_cols=q_cols,
        qt_vals=q_vals,
        slave_area=float(surf.measure.sum()),
        covered_area=float(mortar.covered),
        rigid=rigid,
        build_stats=stats,
    )


# ------------------------------------------------------------------------ operators
def _csr_matrix(
    comm: MPI.Comm,
    n_local: int,
    n_global: int,
    row_start: int,
    rows: np.ndarray,
    cols: np.ndarray,
    vals: np.ndarray,
) -> PETSc.Mat:
    """Distributed AIJ matrix from owned-row triplets (duplicates summed)."""
    order = np.lexsort((cols, rows))
    rows, cols, vals = rows[order], cols[order], vals[order]
    if rows.size:
        first = np.ones(rows.size, dtype=bool)
        first[1:] = (rows[1:] != rows[:-1]) | (cols[1:] != cols[:-1])
        starts = np.flatnonzero(first)
        vals = np.add.reduceat(vals, starts)
        rows, cols = rows[starts], cols[starts]
    indptr = np.zeros(n_local + 1, dtype=PETSc.IntType)
    np.add.at(indptr, rows - row_start + 1, 1)
    indptr = np.cumsum(indptr).astype(PETSc.IntType)
    A = PETSc.Mat().createAIJ(
        size=((n_local, n_global), (n_local, n_global)),
        csr=(indptr, cols.astype(PETSc.IntType), vals),
        comm=comm,
    )
    A.assemble()
    return A


def basis_transform(V: fem.FunctionSpace, interfaces: list[ContactInterface]) -> PETSc.Mat:
    """``Qᵀ = I + Σ (M̂ in slave rows / master columns)``, so that ``U = Qᵀ Û``.

    ``Â = A.PtAP(Qᵀ) = Q A Qᵀ`` and ``F̂ = Q F = (Qᵀ)ᵀ F``.
    """
    comm = V.mesh.comm
    imap, bs = V.dofmap.index_map, V.dofmap.index_map_bs
    n_local, n_global = bs * imap.size_local, bs * imap.size_global
    start = bs * imap.local_range[0]
    diag = np.arange(start, start + n_local, dtype=np.int64)
    rows = np.concatenate([diag] + [i.qt_rows for i in interfaces])
    cols = np.concatenate([diag] + [i.qt_cols for i in interfaces])
    vals = np.concatenate([np.ones(n_local)] + [i.qt_vals for i in interfaces])
    return _csr_matrix(comm, n_local, n_global, start, rows, cols, vals)


def transformed_operator(
    A: PETSc.Mat, Qt: PETSc.Mat, Tt: PETSc.Mat, cleared: bool = False
) -> PETSc.Mat:
    """``T Q A Qᵀ Tᵀ``: the operator in the dual basis and the nodal frames.

    One triple product with ``P = Qᵀ Tᵀ`` (both factors are the identity outside the
    slave rows, so ``P`` costs little) instead of two: at 10⁶ dofs the second product of
    the whole matrix and the intermediate ``Â = Q A Qᵀ`` held beside ``A`` were seconds
    and a matrix's memory.  PETSc's product record would hold a reference to ``A`` (and
    ``P``) for as long as the result lives, so an ``A`` its owner releases after set-up
    could never be freed: the product is returned as a plain copy, or as it is when the
    caller has made its record be cleared (``cleared``: inside
    :func:`~bonecontact.contact.condensed.lean_products`; no copy, whose transient was the
    set-up's peak: +470 MiB per rank at 1M dofs on 2 ranks, issue 28).
    """
    P = Qt.matMult(Tt)
    try:
        product = A.PtAP(P)
        if cleared:
            return product
        try:
            return product.duplicate(copy=True)
        finally:
            product.destroy()
    finally:
        P.destroy()


def rotation_matrix(V: fem.FunctionSpace, interfaces: list[ContactInterface]) -> PETSc.Mat:
    """Row rotation ``T``: identity except at slave nodes, whose rows become ``[n_p; t_p]``.

    Row ``bs·p`` of ``T·x`` is the normal component of node ``p``, rows
    ``bs·p + 1 …`` its tangential components.
    """
    comm = V.mesh.comm
    imap, bs = V.dofmap.index_map, V.dofmap.index_map_bs
    n_local, n_global = bs * imap.size_local, bs * imap.size_global
    start = bs * imap.local_range[0]
    special = np.zeros(n_local, dtype=bool)
    r_list, c_list, v_list = [], [], []
    for itf in interfaces:
        if itf.num_owned == 0:
            continue
        frame = np.concatenate([itf.normals[:, None, :], itf.tangents], axis=1)  # (n, bs, bs)
        base = bs * itf.global_blocks
        rr = (base[:, None, None] + np.arange(bs)[None, :, None]) + 0 * np.arange(bs)[None, None, :]
        cc = (base[:, None, None] + np.arange(bs)[None, None, :]) + 0 * np.arange(bs)[None, :, None]
        r_list.append(rr.ravel())
        c_list.append(cc.ravel())
        v_list.append(frame.ravel())
        special[(bs * itf.blocks[:, None] + np.arange(bs)[None, :]).ravel()] = True
    plain = np.flatnonzero(~special).astype(np.int64) + start
    rows = np.concatenate([plain] + r_list)
    cols = np.concatenate([plain] + c_list)
    vals = np.concatenate([np.ones(plain.size)] + v_list)
    return _csr_matrix(
        comm, n_local, n_global, start, rows.astype(np.int64), cols.astype(np.int64), vals
    )
