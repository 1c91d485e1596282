"""Checks of a scene's mesh before any solve: inverted and degenerate elements, duplicated
nodes, detached pieces of a region, load and contact groups inside the body.

:func:`check_mesh` runs on the distributed DOLFINx mesh read for a scene (collective):
every rank examines its owned cells and facets, the findings are gathered on rank 0 and
the first one is broadcast, so every rank raises the same
:class:`~bonecontact.scene.errors.SceneError` (exit status 2) and no rank waits for
another.  Each message names the group and a location (coordinates in m).  What each
check looks for and its tolerance: docs/scene_format.md, "Checks of the mesh itself".

The plausibility checks of :mod:`bonecontact.scene.checks` need the mesh's size
(:func:`mesh_extent`) and the materials next to each facet group
(:func:`facet_materials`); :func:`scene_issues` measures both and runs them.
:func:`count_bodies` counts the connected pieces of a mesh (for ``bonecontact check``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
from dolfinx import mesh as dmesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from bonecontact.scene.checks import PlausibilityIssue, check_plausibility
from bonecontact.scene.errors import SceneError
from bonecontact.scene.rigid_motions import cell_pieces, find_bodies
from bonecontact.scene.spec import Scene

__all__ = [
    "DEGENERATE_RATIO",
    "DUPLICATE_TOLERANCE",
    "check_mesh",
    "count_bodies",
    "facet_materials",
    "mesh_extent",
    "mesh_findings",
    "scene_issues",
]

#: A cell is degenerate when ``|det J| ≤ DEGENERATE_RATIO · ℓ^d`` (ℓ its longest edge).
DEGENERATE_RATIO = 1e-10
#: Two nodes closer than this fraction of the mesh's bounding-box diagonal coincide.
DUPLICATE_TOLERANCE = 1e-9


def _where(x: npt.ArrayLike) -> str:
    return "(" + ", ".join(f"{float(v):.6g}" for v in np.asarray(x).ravel()) + ")"


def _tag_arrays(tags: Any) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]]:
    """(indices, values) of a meshtags object; empty when the mesh has none."""
    if tags is None:
        return np.zeros(0, dtype=np.int32), np.zeros(0, dtype=np.int32)
    return tags.indices, tags.values


def _names(groups: Mapping[str, tuple[int, int]], dim: int) -> dict[int, str]:
    return {tag: name for name, (d, tag) in groups.items() if d == dim}


def _cell_data(msh: Any) -> tuple[npt.NDArray, npt.NDArray, npt.NDArray]:
    """Vertex coordinates ``(n, d + 1, gdim)`` of the owned cells, their vertex indices
    and the cells' midpoints."""
    tdim = msh.topology.dim
    n = msh.topology.index_map(tdim).size_local
    dofs = np.asarray(msh.geometry.dofmaps[0])[:n, : tdim + 1]
    x = msh.geometry.x[dofs][:, :, : msh.geometry.dim]
    return x, dofs, x.mean(axis=1)


def _signed_measure(x: npt.NDArray) -> tuple[npt.NDArray, npt.NDArray]:
    """``det J`` of every simplex and its longest edge."""
    e = x[:, 1:, :] - x[:, :1, :]
    if e.shape[1] == e.shape[2]:
        det = np.linalg.det(e)
    else:  # a surface in a higher dimension: the Gram determinant, unsigned
        det = np.sqrt(np.abs(np.linalg.det(e @ np.swapaxes(e, 1, 2))))
    k = x.shape[1]
    i, j = np.triu_indices(k, 1)
    longest = np.linalg.norm(x[:, i, :] - x[:, j, :], axis=2).max(axis=1)
    return det, longest


def _element_findings(
    msh: Any, tags: npt.NDArray, names: dict[int, str], comm: MPI.Comm
) -> list[tuple[int, str]]:
    """Inverted and degenerate cells (this rank's owned cells; majority signs collective)."""
    x, _, mid = _cell_data(msh)
    det, longest = _signed_measure(x)
    out = []
    flat = np.abs(det) <= DEGENERATE_RATIO * longest**msh.topology.dim
    n_flat = comm.allreduce(int(flat.sum()), op=MPI.SUM)
    if flat.any():
        i = int(np.flatnonzero(flat)[0])
        name = names.get(int(tags[i]), f"tag {int(tags[i])}")
        out.append(
            (
                0,
                f"region {name!r}: degenerate element (zero area or volume; {n_flat} in "
                f"the mesh) at {_where(mid[i])}",
            )
        )
    keys = sorted(names) + [-1]
    pos = np.array([[np.sum((tags == t) & (det > 0) & ~flat) for t in keys]])
    neg = np.array([[np.sum((tags == t) & (det < 0) & ~flat) for t in keys]])
    pos, neg = comm.allreduce(pos, op=MPI.SUM)[0], comm.allreduce(neg, op=MPI.SUM)[0]
    for k, t in enumerate(keys):
        if pos[k] == 0 or neg[k] == 0:
            continue
        minority = (det < 0) if neg[k] <= pos[k] else (det > 0)
        bad = minority & ~flat & (tags == t)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            name = names.get(t, "untagged cells")
            out.append(
                (
                    1,
                    f"region {name!r}: inverted element (oriented against the other "
                    f"{max(pos[k], neg[k])} cells of the region; {min(pos[k], neg[k])} such) "
                    f"at {_where(mid[i])}",
                )
            )
    return out


def _cell_tag_array(msh: Any, cell_tags: Any) -> npt.NDArray[np.int64]:
    """The tag of every local cell (owned and ghost; -1 untagged)."""
    tdim = msh.topology.dim
    imap = msh.topology.index_map(tdim)
    tags = np.full(imap.size_local + imap.num_ghosts, -1, dtype=np.int64)
    idx, val = _tag_arrays(cell_tags)
    tags[idx] = val
    return tags


def _used_facet_tags(scene: Scene, groups: Mapping[str, tuple[int, int]], tdim: int) -> tuple:
    """Tags of the contact surfaces, of the traction/pressure boundaries and of the
    Dirichlet boundaries used by the scene."""

    def tag(name: str) -> int | None:
        d, t = groups.get(name, (-1, -1))
        return t if d == tdim - 1 else None

    contact = {tag(n) for c in scene.contacts for n in (c.slave, c.master)} - {None}
    loads = {tag(n) for ld in scene.loads if ld.kind != "body_force" for n in ld.target} - {None}
    dirichlet = {tag(d.boundary) for d in scene.dirichlet} - {None}
    return contact, loads, dirichlet


def _facet_findings(
    msh: Any, facet_tags: Any, names: dict[int, str], checked: set[int]
) -> list[tuple[int, str]]:
    """Facets of the checked groups that are not on the boundary (owned facets)."""
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    exterior = dmesh.exterior_facet_indices(msh.topology)
    n_owned = msh.topology.index_map(tdim - 1).size_local
    idx, val = _tag_arrays(facet_tags)
    sel = np.isin(val, sorted(checked)) & (idx < n_owned) & ~np.isin(idx, exterior)
    if not sel.any():
        return []
    f = int(idx[np.flatnonzero(sel)[0]])
    mid = dmesh.compute_midpoints(msh, tdim - 1, np.array([f], dtype=np.int32))[0]
    t = int(val[np.flatnonzero(sel)[0]])
    return [
        (
            4,
            f"facet group {names.get(t, str(t))!r} is not on the boundary: a facet between "
            f"two cells at {_where(mid[: msh.geometry.dim])} (contact surfaces and loaded "
            "boundaries must lie on the surface of a body)",
        )
    ]


def _boundary_vertex_rows(
    msh: Any, ctags: npt.NDArray, facet_tags: Any, contact: set[int]
) -> tuple[npt.NDArray, ...]:
    """(global vertex, region, on a contact surface, coordinates) of the vertices of the
    owned exterior facets, one row per facet vertex."""
    tdim, gdim = msh.topology.dim, msh.geometry.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    msh.topology.create_connectivity(tdim - 1, 0)
    ext = dmesh.exterior_facet_indices(msh.topology)
    ext = ext[ext < msh.topology.index_map(tdim - 1).size_local]
    f2c, f2v = msh.topology.connectivity(tdim - 1, tdim), msh.topology.connectivity(tdim - 1, 0)
    cell = f2c.array[f2c.offsets[ext]]
    verts = f2v.array[(f2v.offsets[ext][:, None] + np.arange(tdim)[None, :])].ravel()
    region = np.repeat(ctags[cell], tdim)
    on_contact = np.zeros(len(ext), dtype=bool)
    if contact:
        fidx, fval = _tag_arrays(facet_tags)
        tagged = fidx[np.isin(fval, sorted(contact))]
        on_contact = np.isin(ext, tagged)
    on_contact = np.repeat(on_contact, tdim)
    imap = msh.topology.index_map(0)
    glob = imap.local_to_global(verts.astype(np.int32))
    msh.topology.create_connectivity(0, tdim)
    xv = dmesh.entities_to_geometry(msh, 0, verts.astype(np.int32)).ravel()
    return glob, region, on_contact, msh.geometry.x[xv][:, :gdim]


def _duplicate_finding(rows: list, names: dict[int, str], tol: float) -> list[tuple[int, str]]:
    """Rank 0: different nodes of one region at the same point (not both on contact)."""
    glob = np.concatenate([r[0] for r in rows])
    region = np.concatenate([r[1] for r in rows])
    contact = np.concatenate([r[2] for r in rows])
    x = np.concatenate([r[3] for r in rows])
    for t in np.unique(region):
        rows_t = np.flatnonzero(region == t)
        _, keep, inv = np.unique(glob[rows_t], return_index=True, return_inverse=True)
        sel = rows_t[keep]
        on_c = np.zeros(len(sel), dtype=bool)
        np.logical_or.at(on_c, inv, contact[rows_t])  # any contact row of the vertex
        pairs = cKDTree(x[sel]).query_pairs(tol, output_type="ndarray")
        if pairs.size:
            pairs = pairs[~(on_c[pairs[:, 0]] & on_c[pairs[:, 1]])]
        if pairs.size:
            name = names.get(int(t), f"tag {int(t)}")
            return [
                (
                    2,
                    f"region {name!r}: duplicated nodes ({len(pairs)} pairs of different "
                    f"nodes at the same point; the region is cut there) at "
                    f"{_where(x[sel[pairs[0, 0]]])}",
                )
            ]
    return []


def _pieces(msh: Any, comm: MPI.Comm) -> tuple[int, npt.NDArray, list]:
    """Connected pieces of this rank's cells (owned + ghost; cells sharing a vertex) and
    the links to other ranks: (n_local, label per cell, (global vertex, local piece))."""
    n_local, label, vpiece = cell_pieces(msh)
    nv = len(vpiece)
    imap = msh.topology.index_map(0)
    if comm.size > 1:
        ghosts = np.arange(imap.size_local, nv)
        dest = imap.index_to_dest_ranks(0)
        owned = np.flatnonzero(np.diff(dest.offsets)[: imap.size_local] > 0)
        shared = np.union1d(owned, ghosts).astype(np.int32)
    else:
        shared = np.zeros(0, dtype=np.int32)
    links = (imap.local_to_global(shared), vpiece[shared])
    return int(n_local), label, links


def _piece_rows(
    msh: Any, ctags: npt.NDArray, label: npt.NDArray, n_local: int, facet_tags: Any, held: set
) -> list[tuple]:
    """Per local piece: (regions of its owned cells, owned cells, held, a point)."""
    tdim = msh.topology.dim
    n_owned = msh.topology.index_map(tdim).size_local
    _, _, mid = _cell_data(msh)
    held_piece = np.zeros(n_local, dtype=bool)
    if held:
        msh.topology.create_connectivity(tdim - 1, tdim)
        f2c = msh.topology.connectivity(tdim - 1, tdim)
        fidx, fval = _tag_arrays(facet_tags)
        f = fidx[np.isin(fval, sorted(held))]
        held_piece[label[f2c.array[f2c.offsets[f]]]] = True
    rows = []
    own_label = label[:n_owned]
    for p in range(n_local):
        mine = np.flatnonzero(own_label == p)
        regions = tuple(sorted({int(t) for t in ctags[:n_owned][mine]}))
        point = mid[mine[0]] if mine.size else None
        rows.append((regions, int(mine.size), bool(held_piece[p]), point))
    return rows


def _detached_finding(gathered: list, names: dict[int, str]) -> list[tuple[int, str]]:
    """Rank 0: join the pieces of all ranks into bodies; a region in several bodies with
    one of them made of that region only and held by nothing is an error."""
    offsets = np.cumsum([0] + [g[0] for g in gathered])
    npieces = int(offsets[-1])
    rows, cols = [np.arange(npieces)], [np.arange(npieces)]
    for r, (_, _, (glob, piece), _) in enumerate(gathered):
        ok = piece >= 0
        rows.append(offsets[r] + piece[ok])
        cols.append(npieces + np.asarray(glob, dtype=np.int64)[ok])
    ra, ca = np.concatenate(rows), np.concatenate(cols)
    n = int(ca.max()) + 1 if ca.size else npieces
    graph = coo_matrix((np.ones(ra.size), (ra, ca)), shape=(n, n))
    _, body_of = connected_components(graph, directed=False, return_labels=True)

    def find(a: int) -> int:
        return int(body_of[a])

    bodies: dict[int, dict] = {}
    for r, (_, _, _, rows) in enumerate(gathered):
        for p, (regions, ncell, held, point) in enumerate(rows):
            b = bodies.setdefault(find(int(offsets[r] + p)), {"r": set(), "n": 0, "held": False})
            b["r"] |= set(regions)
            b["n"] += ncell
            b["held"] |= held
            if point is not None and "x" not in b:
                b["x"] = point
    count: dict[int, int] = {}
    for b in bodies.values():
        for t in b["r"]:
            count[t] = count.get(t, 0) + 1
    for b in sorted(bodies.values(), key=lambda b: b["n"]):
        if len(b["r"]) == 1 and not b["held"] and b["n"] > 0:
            (t,) = b["r"]
            if count[t] > 1:
                name = names.get(t, f"tag {t}")
                return [
                    (
                        3,
                        f"region {name!r} is not one piece: a part of {b['n']} cells near "
                        f"{_where(b['x'])} is attached to no other cell and has no Dirichlet "
                        "boundary or contact surface",
                    )
                ]
    return []


def mesh_findings(
    scene: Scene, md: Any, groups: Mapping[str, tuple[int, int]], comm: MPI.Comm
) -> list[str]:
    """Every finding of the checks of the module docstring, the same list on every rank
    (collective), in the order of the checks."""
    msh = md.mesh
    tdim = msh.topology.dim
    names_c, names_f = _names(groups, tdim), _names(groups, tdim - 1)
    ctags = _cell_tag_array(msh, md.cell_tags)
    n_owned = msh.topology.index_map(tdim).size_local
    local = _element_findings(msh, ctags[:n_owned], names_c, comm)
    contact, loads, dirichlet = _used_facet_tags(scene, groups, tdim)
    local += _facet_findings(msh, md.facet_tags, names_f, contact | loads)
    lo = msh.geometry.x[:, : msh.geometry.dim].min(axis=0) if len(msh.geometry.x) else None
    hi = msh.geometry.x[:, : msh.geometry.dim].max(axis=0) if len(msh.geometry.x) else None
    ext = comm.gather((lo, hi), root=0)
    vrows = comm.gather(_boundary_vertex_rows(msh, ctags, md.facet_tags, contact), root=0)
    n_local, label, links = _pieces(msh, comm)
    prow = _piece_rows(msh, ctags, label, n_local, md.facet_tags, contact | dirichlet)
    pieces = comm.gather((n_local, None, links, prow), root=0)
    found = comm.gather(local, root=0)
    out = None
    if comm.rank == 0:
        lows = np.array([e[0] for e in ext if e[0] is not None])
        highs = np.array([e[1] for e in ext if e[1] is not None])
        diag = float(np.linalg.norm(highs.max(axis=0) - lows.min(axis=0)))
        allf = [f for part in found for f in part]
        allf += _duplicate_finding(vrows, names_c, DUPLICATE_TOLERANCE * diag)
        allf += _detached_finding(pieces, names_c)
        first: dict[int, str] = {}
        for kind, text in allf:  # the first finding of each kind (ranks in order)
            first.setdefault(kind, text)
        out = [first[k] for k in sorted(first)]
    return comm.bcast(out, root=0)


def check_mesh(
    scene: Scene, md: Any, groups: Mapping[str, tuple[int, int]], comm: MPI.Comm
) -> None:
    """Raise one :class:`~bonecontact.scene.errors.SceneError` (key ``mesh`` of
    ``[scene]``) on every rank for the first finding of :func:`mesh_findings`, with the
    number of further findings (collective)."""
    found = mesh_findings(scene, md, groups, comm)
    if found:
        more = f" (and {len(found) - 1} other kinds of problem)" if len(found) > 1 else ""
        raise SceneError(
            str(scene.path), "[scene]", "mesh", f"{scene.mesh_path.name}: {found[0]}{more}"
        )


# ----------------------------------------------------------------------------- plausibility
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


def count_bodies(mesh: Any, comm: MPI.Comm) -> int:
    """The number of connected pieces of a mesh (cells sharing a vertex are connected;
    :func:`bonecontact.scene.rigid_motions.find_bodies`, which joins the pieces of the
    ranks through the vertices on the partition boundary only)."""
    return find_bodies(mesh, None, {}, comm).count
