"""The split of a crack surface into two faces in a 3D body (gmsh's ``Crack`` plugin in
bonecontact.fracture.body3d and surface_body3d, checked by
bonecontact.fracture.crack_split).

The plugin left a crack triangle unsplit at a sharp kink of a non-planar surface crack
(both faces 0.40 % short, silently).  A sweep over what the two meshers mesh — interior
discs, ellipses, polygons tilted and off-centre, grown cracks with kinked strips (±30 …
±70°), two cracks in one body, semi-elliptical and corner surface cracks, coarse and
fine — against references independent of the split: each face's area is that of the
crack surface (the exact patch areas of a polygon or grown crack; of a curved front the
polygon of the face's nodes on the curve and the body's surface, 1e-8 relative), every
crack facet is an exterior facet (no triangle glued), the faces' common vertices are
exactly the front's (those on the curve, the surface crack's two ends), the meshed
volume the box's.  A split forced wrong (a face short of a triangle; a triangle given
the other face's nodes; the cell behind a triangle given the other face's nodes, the
plugin's own failure) is a MeshingError naming the crack.  The own node split of
bonecontact.fracture.crack_split (the 2D mesher's repair) repairs such 3D splits too.
"""

from __future__ import annotations

import itertools
import math
from functools import partial

from mpi4py import MPI

import _box_surface
import gmsh
import numpy as np
import pytest
import ufl
from _spoil import after_crack_plugin
from dolfinx import fem, mesh

from bonecontact.fracture import crack_split
from bonecontact.fracture.advance3d import advance_mixed_front, extend_surface
from bonecontact.fracture.body3d import (
    BodySurface,
    front_vertices,
    mesh_body_with_planar_crack,
    mesh_body_with_planar_cracks,
)
from bonecontact.fracture.crack3d import (
    PlanarCrack,
    SurfaceBreakingCrack,
    TriangulatedCrack,
    in_plane_axis,
    planar_crack_from_table,
    triangulated_from_polygon,
)
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.surface_body3d import mesh_body_with_surface_crack
from bonecontact.meshing.builder import MeshingError

CUBE = (2.0, 2.0, 2.0)  # interior cracks
SLAB = (2.0, 2.0, 1.0)  # surface cracks on z = 1, corner cracks on the edge x = 0, z = 1


def _body(size: tuple[float, float, float]) -> BodySurface:
    tri = _box_surface.box_triangles(size, 0.25)
    tags = np.full(len(tri), 2, dtype=np.int32)
    return BodySurface(tri, tags, {2: "outer"}, ("bone", 1), 0.25 * math.sqrt(2))


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _frame(n) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n = _unit(n)
    e1 = _unit(in_plane_axis(n))
    return n, e1, np.cross(n, e1)


def _polygon(c, n, r: float, m: int, rot: float = 0.1) -> PlanarCrack:
    n, e1, e2 = _frame(n)
    t = rot + 2 * math.pi * (np.arange(m) + 0.5) / m
    V = np.asarray(c) + r * (np.outer(np.cos(t), e1) + np.outer(np.sin(t), e2))
    return planar_crack_from_table({"shape": "polygon", "vertices": V.tolist()})


def _ellipse(c, n, a: float, b: float) -> PlanarCrack:
    n, e1, _ = _frame(n)
    return PlanarCrack(tuple(c), tuple(n), a, b, tuple(e1))


def _grown(
    c, n, r: float, m: int, kinks: list, da: float = 0.08, rot: float = 0.1
) -> TriangulatedCrack:
    """A regular m-gon grown by strips kinked by ``kinks`` (deg; one per advance, a number
    or one per vertex): K_I = 3 cos φ − 1, K_II = −sin φ gives the MTS angle φ."""
    crack = triangulated_from_polygon(_polygon(c, n, r, m, rot))
    for kink in kinks:
        phi = np.broadcast_to(np.radians(kink), (m,))
        K = np.column_stack([3 * np.cos(phi) - 1, -np.sin(phi), 0 * phi])
        adv = advance_mixed_front(crack.vertices, crack.normals2, K, da, weights=np.ones(m))
        crack = extend_surface(crack, adv.vertices)
    return crack


# ------------------------------------------------------------------ the references
def _patch_area(P: np.ndarray, ids) -> float:
    Q = P[list(ids)]
    return 0.5 * float(np.linalg.norm(np.sum(np.cross(Q - Q[0], np.roll(Q, -1, 0) - Q[0]), 0)))


def _exact_area(crack) -> float:
    if isinstance(crack, TriangulatedCrack):
        P = np.asarray(crack.points)
        return sum(_patch_area(P, p) for p in crack.patches)
    V = np.asarray(crack.vertices)
    return _patch_area(V, range(len(V)))


def _polyline_distance(F: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Distance of the points x to the closed polyline F."""
    a, b = F, np.roll(F, -1, axis=0)
    d = b - a
    t = np.clip(np.einsum("pkj,kj->pk", x[:, None] - a, d) / np.einsum("kj,kj->k", d, d), 0, 1)
    return np.min(np.linalg.norm(x[:, None] - (a + t[..., None] * d), axis=2), axis=1)


def _shoelace(uv: np.ndarray) -> float:
    return 0.5 * abs(
        float(np.sum(uv[:, 0] * np.roll(uv[:, 1], -1) - np.roll(uv[:, 0], -1) * uv[:, 1]))
    )


class Reference:
    """A crack's face area and front nodes from the nodes of one face: a polygon or grown
    crack's exact area and the nodes on its front polyline; an ellipse's (a surface
    crack's: the arc of the cut, ``arc``) polygon of the face's nodes on the curve and on
    the body's surface, and its nodes on the curve (and the arc's two ends)."""

    def __init__(self, crack, size, arc=None) -> None:
        self.crack, self.size, self.arc = crack, np.asarray(size), arc

    def area_and_front(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        cr, tol = self.crack, 1e-9 * float(self.size.max())
        if isinstance(cr, TriangulatedCrack) or getattr(cr, "vertices", None) is not None:
            return _exact_area(cr), x[_polyline_distance(cr.vertices, x) <= tol]
        ell = self.arc if self.arc is not None else cr.front()
        u, v, _ = np.asarray(ell.axes)
        d = x - np.asarray(ell.centre)
        uv = np.column_stack([d @ u, d @ v])
        # the face's other nodes lie ≥ 0.04 off the curve (ρ), an interior crack's front
        # nodes on it (1e-9), a surface crack's ≤ 3e-3 (its front a spline through the
        # ellipse from mouth ends that may be grid nodes near it)
        near = 1e-2 if self.arc is not None else 1e-9
        off = np.abs(np.hypot(uv[:, 0] / ell.a, uv[:, 1] / ell.b) - 1)
        on = off < near
        surface = np.min(np.column_stack([x, self.size - x]), axis=1) < tol
        assert np.all(off[~on & ~surface] > 0.02)  # the classification is clear
        angle = np.arctan2(uv[:, 1], uv[:, 0])
        if self.arc is None:
            order = np.argsort(angle[on])
            return _shoelace(uv[on][order]), x[on]
        # the arc by angle, then the surface's nodes: in along the ray of the arc's
        # last end, out along the other's (one line through the centre, or two rays)
        mid = 0.5 * sum(ell.phi_range)
        angle = np.mod(angle - mid + math.pi, 2 * math.pi) - math.pi
        arc = on & ~surface
        r = np.linalg.norm(uv, axis=1)
        last, first = surface & (angle > 0), surface & (angle <= 0)
        polygon = np.vstack(
            [
                uv[arc][np.argsort(angle[arc])],
                uv[last][np.argsort(-r[last])],
                uv[first][np.argsort(r[first])],
            ]
        )
        ends = [
            np.flatnonzero(last)[np.argmax(r[last])],
            np.flatnonzero(first)[np.argmax(r[first])],
        ]
        return _shoelace(polygon), np.vstack([x[arc], x[ends]])


# ------------------------------------------------------------------ DOLFINx side
def _face_nodes(msh: mesh.Mesh, facet_tags: mesh.MeshTags, tag: int) -> np.ndarray:
    msh.topology.create_connectivity(2, 0)
    facets = facet_tags.find(tag)
    facets = facets[facets < msh.topology.index_map(2).size_local]
    x = msh.geometry.x[mesh.entities_to_geometry(msh, 2, facets).ravel()].reshape(-1, 3)
    x = np.concatenate(msh.comm.allgather(x)).reshape(-1, 3)
    return np.unique(np.round(x, 12), axis=0)


def _same_points(x: np.ndarray, y: np.ndarray, tol: float) -> bool:
    """The point sets x and y are the same (each point of one within tol of one of the
    other, as many of each)."""
    if len(x) != len(y):
        return False
    d = np.linalg.norm(x[:, None] - y[None], axis=2)
    return bool(d.min(axis=0).max() <= tol and d.min(axis=1).max() <= tol)


def _cut_volume(cut) -> float:
    """The volume enclosed by the cut boundary (its vertices moved onto the crack plane
    along the surface: at the box's edges that changes the volume)."""
    T = cut.nodes[cut.triangles]
    return float(np.sum(np.einsum("ij,ij->i", T[:, 0], np.cross(T[:, 1], T[:, 2])))) / 6


def _check(cb, crack, size, arc=None, volume=None) -> None:
    msh, ft = cb.mesh, cb.facet_tags
    comm = msh.comm
    upper, lower = cb.face_tags
    ds = ufl.Measure("ds", domain=msh, subdomain_data=ft)
    one = fem.Constant(msh, 1.0)

    def total(form) -> float:
        return comm.allreduce(fem.assemble_scalar(fem.form(form)), op=MPI.SUM)

    ref = Reference(crack, size, arc)
    area, front = ref.area_and_front(_face_nodes(msh, ft, upper))
    for tag in (upper, lower):
        assert total(one * ds(tag)) == pytest.approx(area, rel=1e-8)
    volume = math.prod(size) if volume is None else volume
    assert total(one * ufl.dx(domain=msh)) == pytest.approx(volume, rel=1e-9)
    msh.topology.create_connectivity(2, 3)
    exterior = set(mesh.exterior_facet_indices(msh.topology).tolist())
    n_local = msh.topology.index_map(2).size_local
    counts = []
    for tag in (upper, lower):
        facets = [f for f in ft.find(tag).tolist() if f < n_local]
        assert set(facets) <= exterior  # no crack triangle left glued
        counts.append(comm.allreduce(len(facets), op=MPI.SUM))
    assert counts[0] == counts[1] > 0
    # no tear: every exterior facet is a face's or the body's surface's (tagged)
    torn = np.setdiff1d([f for f in exterior if f < n_local], ft.indices)
    assert comm.allreduce(len(torn), op=MPI.SUM) == 0
    shared = front_vertices(msh, ft, (upper, lower))
    assert _same_points(shared, front, 1e-9 * max(size))
    assert _pinched_edges(msh, ft, (upper, lower)) == 0


def _pinched_edges(msh: mesh.Mesh, ft: mesh.MeshTags, tags: tuple[int, int]) -> int:
    """The number of edges of two triangles of a face whose both vertices both faces
    have (front vertices): an edge across a corner of the front, the crack closed
    along it (its triangles' vertices all on the front: no node of them split)."""
    msh.topology.create_connectivity(2, 0)
    f2v, vertices = msh.topology.connectivity(2, 0), msh.topology.index_map(0)
    n_local = msh.topology.index_map(2).size_local
    faces = []
    for tag in tags:
        facets = ft.find(tag)
        local = np.array([f2v.links(f) for f in facets[facets < n_local]], dtype=np.int32)
        ids = vertices.local_to_global(local.ravel()).reshape(-1, 3)
        faces.append(np.concatenate(msh.comm.allgather(ids)).reshape(-1, 3))
    shared, pinched = np.intersect1d(faces[0], faces[1]), 0
    for F in faces:
        edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [0, 2]]]), axis=1)
        edges = edges[np.isin(edges, shared).all(axis=1)]
        counts = np.unique(edges, axis=0, return_counts=True)[1]
        pinched = max(pinched, int(np.count_nonzero(counts > 1)))
    return pinched


CASES = {
    "disc": (CUBE, lambda: _ellipse((1.0, 1.0, 1.0), (0, 0, 1), 0.3, 0.3), 0.1),
    "disc_tilted_fine": (CUBE, lambda: _ellipse((1.1, 0.93, 1.0), (1, 0, 1), 0.3, 0.3), 0.03),
    "ellipse_tilted": (CUBE, lambda: _ellipse((1.0, 1.0, 1.0), (0.3, -0.4, 1), 0.35, 0.2), 0.05),
    "pentagon_on_grid": (CUBE, lambda: _polygon((0.9, 1.05, 1.0), (0, 0, 1), 0.3, 5), 0.05),
    "octagon_diagonal": (CUBE, lambda: _polygon((1.0, 1.0, 1.0), (1, 1, 1), 0.3, 8), 0.1),
    "grown_+70": (CUBE, lambda: _grown((1.0, 1.0, 1.0), (0, 0, 1), 0.25, 8, [70]), 0.1),
    "grown_-70_coarse": (
        CUBE,
        lambda: _grown((0.97, 1.06, 1.13), (0.2, 0.1, 1), 0.25, 6, [-70], 0.15),
        0.2,
    ),
    "grown_+30_-60": (
        CUBE,
        lambda: _grown((1.05, 0.97, 1.1), (1, 0.5, 2), 0.25, 8, [30, -60]),
        0.05,
    ),
    "grown_alternating": (
        CUBE,
        lambda: _grown(
            (1.0, 1.0, 1.0), (0, 0, 1), 0.25, 8, [[-70, -30, 30, 70, 30, -30, -70, -50]]
        ),
        0.05,
    ),
    "semi_elliptical": (
        SLAB,
        lambda: SurfaceBreakingCrack((1.0, 1.0, 1.0), (0, 1, 0), 0.2, 0.3),
        0.06,
    ),
    "semi_tilted_fine": (
        SLAB,
        lambda: SurfaceBreakingCrack((0.93, 1.07, 1.0), tuple(_unit((0, 1, 0.4))), 0.25, 0.15),
        0.03,
    ),
    "corner": (
        SLAB,
        lambda: SurfaceBreakingCrack(
            (0.0, 1.03, 1.0), (0, 1, 0), 0.3, 0.15, (1, 0, 0), "quarter_elliptical"
        ),
        0.03,
    ),
}

# the families: interior shapes at off-grid points and tilts, coarse and fine
_PLACES = [((1.1, 0.93, 1.0), (1, 0, 1)), ((0.9, 1.05, 1.125), (0, 0, 1)), ((1, 1, 1), (1, 1, 1))]
for (_c, _n), _h in itertools.product(_PLACES, [0.1, 0.05]):
    CASES[f"disc{_c}{_n}h{_h}"] = (CUBE, partial(_ellipse, _c, _n, 0.3, 0.3), _h)
    CASES[f"ellipse{_c}{_n}h{_h}"] = (CUBE, partial(_ellipse, _c, _n, 0.35, 0.2), _h)
    CASES[f"hexagon{_c}{_n}h{_h}"] = (CUBE, partial(_polygon, _c, _n, 0.3, 6), _h)
# grown cracks: one strip kinked by ±30 … ±70°, then a second strip kinked back
for _k, _h in itertools.product([30, -30, 50, -50, 70, -70], [0.1, 0.05]):
    _g = partial(_grown, (1.05, 0.97, 1.1), (1, 0.5, 2), 0.25, 8, [_k, -_k])
    CASES[f"grown{_k:+d}{-_k:+d}h{_h}"] = (CUBE, _g, _h)
# surface cracks: semi-elliptical (off-grid, tilted) and corner cracks
for (_a, _cc), _h in itertools.product([(0.2, 0.3), (0.25, 0.15)], [0.06, 0.03]):
    _semi = partial(SurfaceBreakingCrack, (0.93, 1.07, 1.0), tuple(_unit((0.3, 1, 0))), _a, _cc)
    CASES[f"semi{_a},{_cc}h{_h}"] = (SLAB, _semi, _h)
    _corner = partial(
        SurfaceBreakingCrack, (0.0, 0.9, 1.0), (0, 1, 0), _a, _cc, (1, 0, 0), "quarter_elliptical"
    )
    CASES[f"corner{_a},{_cc}h{_h}"] = (SLAB, _corner, _h)


@pytest.mark.parametrize("name", list(CASES))
def test_every_crack_triangle_is_split(name: str) -> None:
    size, make, h = CASES[name]
    crack, comm = make(), MPI.COMM_WORLD
    if isinstance(crack, SurfaceBreakingCrack):
        cb, _, cut = mesh_body_with_surface_crack(_body(size), crack, TipMesh(h, 0.12, 0.4), comm)
        assert _cut_volume(cut) == pytest.approx(math.prod(size), rel=1e-4)
        _check(cb, crack, size, cut.arc, _cut_volume(cut))
    else:
        cb, _ = mesh_body_with_planar_crack(_body(size), crack, TipMesh(h, 0.3), comm)
        _check(cb, crack, size)


@pytest.mark.parametrize("h", [0.1, 0.03])
def test_two_cracks_each_split(h: float) -> None:
    """A disc and a grown crack (±40° strips) in one body: each split into its faces."""
    cracks = [
        _ellipse((1.0, 1.0, 0.8), (0, 0, 1), 0.25, 0.25),
        _grown((0.6, 1.4, 1.2), (0, 1, 0.3), 0.15, 6, [40, -40]),
    ]
    views, _ = mesh_body_with_planar_cracks(_body(CUBE), cracks, TipMesh(h, 0.3), MPI.COMM_WORLD)
    for cb, crack in zip(views, cracks, strict=True):
        _check(cb, crack, CUBE)


# ------------------------------------------------------------------ a bad split
def _spoil(monkeypatch, how: str, call: int = 0) -> None:
    """After the ``call``-th run of the Crack plugin, drop one triangle of its new face
    (``"drop"``), give it the other face's nodes (``"glue"``: the areas unchanged) or give
    the cell behind it the other face's nodes (``"side"``: the faces whole, sharing no
    node, but the triangle glued: the plugin's failure at a sharp kink)."""

    def spoil(entity: int, tags, new: np.ndarray, old: np.ndarray) -> None:
        node_tags, xyz, _ = gmsh.model.mesh.getNodes()
        X = dict(zip(node_tags.tolist(), np.round(xyz, 9).reshape(-1, 3).tolist(), strict=True))

        def where(t) -> frozenset:
            return frozenset(tuple(X[v]) for v in t.tolist())

        twin = {where(t): t for t in old}
        moved = [len(set(t.tolist()) - set(twin[where(t)].tolist())) for t in new]
        k = int(np.argmax(moved))
        if how == "side":
            cells, conn = gmsh.model.mesh.getElementsByType(4)
            conn = np.asarray(conn, dtype=np.int64).reshape(-1, 4)
            (t,) = np.flatnonzero(np.isin(conn, new[k]).sum(axis=1) == 3)
            _, _, _, volume = gmsh.model.mesh.getElement(int(cells[t]))
            back = {
                u: v for u in new[k].tolist() for v in twin[where(new[k])].tolist() if X[u] == X[v]
            }
            gmsh.model.mesh.removeElements(3, volume, [int(cells[t])])
            gmsh.model.mesh.addElementsByType(
                volume, 4, [], [back.get(u, u) for u in conn[t].tolist()]
            )
            return
        gmsh.model.mesh.removeElements(2, entity, [int(tags[k])])
        if how == "glue":
            gmsh.model.mesh.addElementsByType(entity, 2, [], twin[where(new[k])].tolist())

    after_crack_plugin(monkeypatch, 2, call, spoil)


@pytest.fixture
def no_resplit(monkeypatch) -> None:
    """The meshers' repair (:func:`crack_split.resplit_crack`) switched off: a bad split
    must then be a MeshingError naming the crack."""

    def refuse(tags, dim) -> int:
        raise RuntimeError("resplit switched off")

    monkeypatch.setattr(crack_split, "resplit_crack", refuse)


def _surface() -> SurfaceBreakingCrack:
    return SurfaceBreakingCrack((1.0, 1.0, 1.0), (0, 1, 0), 0.2, 0.3)


def _mesh_right(crack, size, h: float) -> None:
    """Mesh ``crack`` in the box ``size`` and check the split (:func:`_check`)."""
    comm = MPI.COMM_WORLD
    if isinstance(crack, SurfaceBreakingCrack):
        cb, _, cut = mesh_body_with_surface_crack(_body(size), crack, TipMesh(h, 0.12, 0.4), comm)
        _check(cb, crack, size, cut.arc, _cut_volume(cut))
    else:
        cb, _ = mesh_body_with_planar_crack(_body(size), crack, TipMesh(h, 0.3), comm)
        _check(cb, crack, size)


def test_a_face_short_of_a_triangle_is_an_error(monkeypatch) -> None:
    """A triangle missing from a face cannot be split again: an error, with or without the
    repair."""
    _spoil(monkeypatch, "drop")
    crack = _ellipse((1.0, 1.0, 1.0), (0, 0, 1), 0.3, 0.3)
    with pytest.raises(MeshingError, match=r"crack: the split faces' areas"):
        mesh_body_with_planar_crack(_body(CUBE), crack, TipMesh(0.1, 0.3), MPI.COMM_WORLD)


@pytest.mark.parametrize("surface", [False, True])
def test_a_cell_on_the_wrong_side_is_an_error(monkeypatch, no_resplit, surface: bool) -> None:
    """The plugin's own failure (seen at a −60° kink of a non-planar surface crack): the
    cell behind a triangle of the new face kept the first face's nodes; both faces are
    whole and share no node, the triangle glued (one copy a face of two cells, the other
    of none).  Without the repair: an error."""
    _spoil(monkeypatch, "side")
    with pytest.raises(MeshingError, match=r"2 triangles of the split faces are not a face"):
        if surface:
            mesh_body_with_surface_crack(_body(SLAB), _surface(), TipMesh(0.06, 0.12, 0.4))
        else:
            crack = _grown((1.0, 1.0, 1.0), (0, 0, 1), 0.25, 8, [-60])
            mesh_body_with_planar_crack(_body(CUBE), crack, TipMesh(0.1, 0.3))


def test_a_glued_triangle_of_the_second_crack_is_an_error(monkeypatch) -> None:
    """A face triangle given the other face's nodes (not the plugin's failure: its face
    groups come out whole) is no cell's to regroup: refused after the repair's try."""
    _spoil(monkeypatch, "glue", call=1)
    cracks = [
        _ellipse((1.0, 1.0, 0.8), (0, 0, 1), 0.25, 0.25),
        _grown((0.6, 1.4, 1.2), (0, 1, 0.3), 0.15, 6, [40, -40]),
    ]
    with pytest.raises(MeshingError, match=r"crack1: the split faces share 3 nodes.*resplit"):
        mesh_body_with_planar_cracks(_body(CUBE), cracks, TipMesh(0.1, 0.3), MPI.COMM_WORLD)


def test_a_glued_surface_crack_triangle_is_an_error(monkeypatch) -> None:
    _spoil(monkeypatch, "glue")
    glued = r"surface crack: the split faces share \d nodes.*resplit"
    with pytest.raises(MeshingError, match=glued):
        mesh_body_with_surface_crack(_body(SLAB), _surface(), TipMesh(0.06, 0.12, 0.4))


@pytest.mark.parametrize("case", ["interior", "surface", "second"])
def test_a_cell_on_the_wrong_side_is_repaired(monkeypatch, case: str) -> None:
    """The plugin's failure (a cell on the wrong side of a face triangle) with the meshers'
    repair on (body3d and surface_body3d split through :func:`crack_split.split_checked`):
    the nodes split again by the cells' connections, the mesh right (areas and volume
    against the closed forms, every face triangle exterior, the faces sharing only the
    front), for an interior crack, a surface crack and the second of two cracks."""
    _spoil(monkeypatch, "side", call=1 if case == "second" else 0)
    if case == "second":
        cracks = [
            _ellipse((1.0, 1.0, 0.8), (0, 0, 1), 0.25, 0.25),
            _grown((0.6, 1.4, 1.2), (0, 1, 0.3), 0.15, 6, [40, -40]),
        ]
        views, _ = mesh_body_with_planar_cracks(
            _body(CUBE), cracks, TipMesh(0.1, 0.3), MPI.COMM_WORLD
        )
        for cb, crack in zip(views, cracks, strict=True):
            _check(cb, crack, CUBE)
    elif case == "surface":
        _mesh_right(_surface(), SLAB, 0.06)
    else:
        _mesh_right(_grown((1.0, 1.0, 1.0), (0, 0, 1), 0.25, 8, [-60]), CUBE, 0.1)


@pytest.mark.parametrize("kinks, centre", [([60], (1.0, 1.0, 1.0)), ([-60], (0.97, 1.06, 1.13))])
def test_a_narrow_kinked_strip_is_split(kinks: list, centre: tuple) -> None:
    """A hexagon grown by one strip of 0.05 kinked by ±60°, meshed with tip size 0.2 (4×
    the strip): gmsh's Crack plugin (gmsh 4.15.2) leaves a triangle glued at −60° (at
    +60° not, though it does for a hexagon of the same points given with its normal).
    The mesher splits that triangle again (:func:`crack_split.split_checked`): the mesh
    is right (the sweep's checks), never silently wrong."""
    crack = _grown(centre, (0.2, 0.1, 1), 0.25, 6, kinks, 0.05, rot=0.0)
    _mesh_right(crack, CUBE, 0.2)  # the plugin's glued triangle resplit by the mesher


@pytest.mark.parametrize(
    "kinks, centre, h, spoil",
    [
        ([-60], (0.97, 1.06, 1.13), 0.2, False),
        ([-80], (1.0, 1.0, 1.0), 0.1, False),
        ([-60], (1.0, 1.0, 1.0), 0.1, True),
    ],
)
def test_the_own_split_repairs_a_glued_triangle(monkeypatch, kinks, centre, h, spoil) -> None:
    """The 3D mesher's split (:func:`crack_split.split_checked`: check, resplit, check,
    the 2D mesher's too): the plugin's glued triangles at a narrow strip kinked by −60° or
    −80° (gmsh 4.15.2) and a cell put on the wrong side by hand are resplit, the mesh
    right (the one implementation serves both dimensions)."""
    resplits = []
    real = crack_split.resplit_crack

    def counted(tags, dim) -> int:
        resplits.append(real(tags, dim))
        return resplits[-1]

    monkeypatch.setattr(crack_split, "resplit_crack", counted)
    if spoil:
        _spoil(monkeypatch, "side")
    crack = _grown(centre, (0.2, 0.1, 1), 0.25, 6, kinks, 0.05, rot=0.0)
    cb, _ = mesh_body_with_planar_crack(_body(CUBE), crack, TipMesh(h, 0.3))
    _check(cb, crack, CUBE)
    if spoil and MPI.COMM_WORLD.rank == 0:  # gmsh runs there
        assert resplits and resplits[0] >= 1


# ------------------------------------------------------------------ the sweep's failures
# Cases of a seeded random sweep (interior planar, grown, two cracks, surface; 2026-12-05,
# gmsh 4.15.2) where the split came out wrong: the plugin's glued triangles and torn
# cells at grown kinked strips (repaired by the own node split), and a triangular crack
# and a coarse narrow ellipse with crack triangles whose three nodes are all on the
# front (no node split opens them: their edge across the corner is halved, then the
# nodes split).
def _triangle(c, n, r: float, rot: float) -> PlanarCrack:
    return _polygon(c, n, r, 3, rot)


SWEPT = {
    "grown_glued": (
        partial(
            _grown,
            (1.1271, 0.8882, 1.0207),
            (0.7553, -0.6188, -0.2158),
            0.20350930398962597,
            7,
            [-63.624924436494254],
            0.0404848174109909,
            0.9640964895574898,
        ),
        0.2,
    ),
    "grown_torn": (
        partial(
            _grown,
            (1.1199, 0.9125, 1.123),
            (-0.2255, -0.9729, -0.0503),
            0.2160005672194414,
            5,
            [-34.85818373263013, 66.21711208345894, 62.34754228144045],
            0.04443733297750628,
            0.3555523268252556,
        ),
        0.15,
    ),
    "grown_torn_per_vertex": (
        partial(
            _grown,
            (0.87, 0.9491, 1.1399),
            (0.3486, -0.9353, 0.0603),
            0.2657788862565532,
            9,
            [
                [-62.2, -64.0, -25.8, -60.9, -76.2, 31.1, -3.7, -23.3, 13.4],
                -73.06883178520555,
                -79.2949515789917,
            ],
            0.04967452190177118,
            0.9477490813822089,
        ),
        0.1,
    ),
    "ellipse_coarse": (
        partial(
            _ellipse,
            (0.8938, 1.0687, 1.0407),
            (-0.4835, 0.8514, 0.2033),
            0.3313285986671249,
            0.13635472021178455,
        ),
        0.2,
    ),
    "triangle_coarse": (
        partial(
            _triangle,
            (1.0416, 0.9951, 1.1222),
            (-0.4608, -0.8833, -0.0867),
            0.3185924470707102,
            0.19329259298501678,
        ),
        0.2,
    ),
    "triangle": (
        partial(
            _triangle,
            (0.9241, 0.8706, 1.1397),
            (-0.7054, 0.1482, -0.6931),
            0.3923846597247326,
            0.24148070685523382,
        ),
        0.1,
    ),
    "triangle_fine": (
        partial(_triangle, (0.9241, 0.8706, 1.1397), (-0.7054, 0.1482, -0.6931), 0.39, 0.24),
        0.02,
    ),
}


def _counted_resplits(monkeypatch) -> list[int]:
    """The cells each :func:`crack_split.resplit_crack` changed (rank 0: gmsh's)."""
    resplits: list[int] = []
    real = crack_split.resplit_crack

    def counted(tags, dim) -> int:
        resplits.append(real(tags, dim))
        return resplits[-1]

    monkeypatch.setattr(crack_split, "resplit_crack", counted)
    return resplits


@pytest.mark.parametrize("name", list(SWEPT))
def test_a_swept_failure_is_repaired(monkeypatch, name: str) -> None:
    """Each wrong split of the sweep is redone by the mesher: the mesh right against the
    closed forms (face areas = the polygon's, volume = the box's, every face triangle
    exterior, no torn facet, the faces sharing exactly the front's vertices and no edge
    but the front's)."""
    resplits = _counted_resplits(monkeypatch)
    make, h = SWEPT[name]
    crack = make()
    cb, _ = mesh_body_with_planar_crack(_body(CUBE), crack, TipMesh(h, 0.3), MPI.COMM_WORLD)
    _check(cb, crack, CUBE)
    if MPI.COMM_WORLD.rank == 0:  # gmsh runs there: the plugin's split was redone
        assert resplits and resplits[0] >= 1


def test_a_swept_second_crack_is_repaired(monkeypatch) -> None:
    """The sweep's two-crack case whose second (grown, −75° strip) crack the plugin left
    glued: resplit, both cracks right."""
    resplits = _counted_resplits(monkeypatch)
    cracks = [
        _ellipse(
            (1.0, 1.0, 0.6832129758415421),
            (0.27533713628275575, -0.08260172088988128, 0.9577924707835415),
            0.2,
            0.2,
        ),
        _grown(
            (0.7798961692722061, 1.000698656270952, 1.2570143189434304),
            (0.46828425790996175, 0.1956314571578266, 0.8616485285567557),
            0.2,
            8,
            [-75.32697306921482],
            0.0832437109351483,
        ),
    ]
    views, _ = mesh_body_with_planar_cracks(_body(CUBE), cracks, TipMesh(0.15, 0.3))
    for cb, crack in zip(views, cracks, strict=True):
        _check(cb, crack, CUBE)
    if MPI.COMM_WORLD.rank == 0:
        assert len(resplits) == 1 and resplits[0] >= 1


def test_an_edge_across_a_corner_is_an_error_without_the_repair(no_resplit) -> None:
    """A crack triangle with all three nodes on the front (a triangular crack's corner):
    the faces share its edge across the corner, not the front's — the crack closed along
    it.  Without the repair: an error naming it."""
    make, h = SWEPT["triangle_coarse"]
    with pytest.raises(MeshingError, match=r"crack: the split faces share 3 edges that are not"):
        mesh_body_with_planar_crack(_body(CUBE), make(), TipMesh(h, 0.3))
