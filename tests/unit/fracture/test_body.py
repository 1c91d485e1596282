"""The body of a crack scene (bonecontact.fracture.body): outline loops and the cracked mesh.

A square plate [−L, L]² with a circular hole of radius R at its centre (facet groups
``outer`` and ``hole``), meshed by gmsh with the hole's curve turning either way:

* every loop of the outline turns counter-clockwise whatever order the facets chain up
  in; the outer loop's signed area is 4L² and the hole's that of its inscribed polygon
  (≤ πR², within the chord error of its segments); every segment keeps its facet group;
* the body meshed around a crack between the hole and the outer edge uses every node (a
  hole loop turning the other way than the outer one used to leave one face's nodes
  unused) and the two crack faces have the crack's length each;
* a crack's mouth may lie on the hole's edge (an edge crack from the hole) as on the outer
  edge; a tip in the hole, a segment across the hole or the outer edge, or a mouth off
  the outline is refused, naming the key ``points``.
"""

from __future__ import annotations

from mpi4py import MPI

import gmsh
import numpy as np
import pytest
from dolfinx.io.gmsh import model_to_mesh
from dolfinx.mesh import entities_to_geometry

from bonecontact.fracture.body import body_outline, mesh_body_with_crack
from bonecontact.fracture.crack import Crack2D, FractureError
from bonecontact.fracture.meshing import TipMesh
from bonecontact.meshing.session import gmsh_session

L, R, H = 1.0, 0.3, 0.08


def _signed_area(p: np.ndarray) -> float:
    q = np.roll(p, -1, axis=0)
    return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))


def _plate_with_hole(comm: MPI.Comm, reverse_hole: bool):
    """The plate meshed by gmsh (rank 0) and distributed; the hole's curve loop is
    given clockwise or counter-clockwise."""
    with gmsh_session("plate_with_hole"):
        if comm.rank == 0:
            geo = gmsh.model.geo
            corners = [geo.addPoint(x, y, 0, H) for x, y in ((-L, -L), (L, -L), (L, L), (-L, L))]
            sides = [geo.addLine(corners[i], corners[(i + 1) % 4]) for i in range(4)]
            centre = geo.addPoint(0, 0, 0, H)
            rim = [
                geo.addPoint(R * np.cos(t), R * np.sin(t), 0, H / 2)
                for t in np.pi * np.arange(4) / 2
            ]
            arcs = [geo.addCircleArc(rim[i], centre, rim[(i + 1) % 4]) for i in range(4)]
            outer = geo.addCurveLoop(sides)
            hole = geo.addCurveLoop([-a for a in reversed(arcs)] if reverse_hole else arcs)
            surface = geo.addPlaneSurface([outer, hole])
            geo.synchronize()
            gmsh.model.addPhysicalGroup(2, [surface], 1, name="plate")
            gmsh.model.addPhysicalGroup(1, sides, 2, name="outer")
            gmsh.model.addPhysicalGroup(1, arcs, 3, name="hole")
            gmsh.model.mesh.generate(2)
        md = model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=2)
    groups = {"plate": (2, 1), "outer": (1, 2), "hole": (1, 3)}
    return md, groups


@pytest.mark.parametrize("reverse_hole", [False, True])
def test_outline_loops_turn_counter_clockwise(reverse_hole: bool) -> None:
    comm = MPI.COMM_WORLD
    md, groups = _plate_with_hole(comm, reverse_hole)
    body = body_outline(md.mesh, md.cell_tags, md.facet_tags, groups, "plate")
    assert len(body.loops) == 2
    outer, hole = body.loops
    assert _signed_area(outer) == pytest.approx(4 * L**2, rel=1e-12)
    # the hole: an inscribed polygon with segments of at most ~H/2 (chord error < 1 %)
    assert 0.99 * np.pi * R**2 < _signed_area(hole) <= np.pi * R**2
    assert set(body.loop_tags[0].tolist()) == {2}
    assert set(body.loop_tags[1].tolist()) == {3}
    # every hole segment joins two points of the circle, tagged 'hole'
    assert np.allclose(np.linalg.norm(hole, axis=1), R, rtol=1e-6)


@pytest.mark.parametrize("reverse_hole", [False, True])
def test_cracked_body_with_a_hole_uses_every_node(reverse_hole: bool) -> None:
    comm = MPI.COMM_WORLD
    md, groups = _plate_with_hole(comm, reverse_hole)
    body = body_outline(md.mesh, md.cell_tags, md.facet_tags, groups, "plate")
    a = 0.3  # a crack between the hole (x = R) and the outer edge (x = L)
    crack = Crack2D(np.array([[0.45, 0.0], [0.45 + a, 0.0]]))
    cm, _ = mesh_body_with_crack(body, crack, TipMesh(h_tip=a / 10), comm)
    msh = cm.mesh
    # every node is a vertex of some cell: the cells' nodes cover the owned nodes
    n_owned = msh.geometry.index_map().size_local
    used = np.zeros(n_owned + msh.geometry.index_map().num_ghosts, dtype=bool)
    used[msh.geometry.dofmaps[0].ravel()] = True
    assert comm.allreduce(int((~used[:n_owned]).sum()), op=MPI.SUM) == 0
    # each face of the crack is as long as the crack
    msh.topology.create_connectivity(1, 2)
    n_facets = msh.topology.index_map(1).size_local
    for name in ("crack_plus", "crack_minus"):
        facets = cm.facet_tags.find(cm.groups[name])
        facets = facets[facets < n_facets].astype(np.int32)
        x = msh.geometry.x[entities_to_geometry(msh, 1, facets)][:, :, :2]
        length = float(np.linalg.norm(x[:, 1] - x[:, 0], axis=1).sum())
        assert comm.allreduce(length, op=MPI.SUM) == pytest.approx(a, rel=1e-9), name


@pytest.mark.parametrize("reverse_hole", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_outline_and_cracked_mesh_do_not_depend_on_the_partition(reverse_hole: bool) -> None:
    """The outline gathered from the distributed mesh equals, bit for bit, the one of the
    same mesh on one rank (each loop from its smallest vertex, holes sorted), and so the
    cracked body has the same nodes: before, a loop started at the first rank's first
    facet and gmsh meshed it differently (1410 nodes on one rank, 1411 on two)."""
    bodies, nodes = {}, {}
    for name, comm in (("world", MPI.COMM_WORLD), ("self", MPI.COMM_SELF)):
        md, groups = _plate_with_hole(comm, reverse_hole)
        bodies[name] = body_outline(md.mesh, md.cell_tags, md.facet_tags, groups, "plate")
        crack = Crack2D(np.array([[0.45, 0.0], [0.75, 0.0]]))
        cm, _ = mesh_body_with_crack(bodies[name], crack, TipMesh(h_tip=0.03), comm)
        n_owned = cm.mesh.geometry.index_map().size_local
        x = np.concatenate(comm.allgather(cm.mesh.geometry.x[:n_owned, :2]))
        nodes[name] = x[np.lexsort(x.T[::-1])]
    for a, b in zip(bodies["world"].loops, bodies["self"].loops, strict=True):
        np.testing.assert_array_equal(a, b)
        assert tuple(a[0]) == min(map(tuple, a))  # from its smallest vertex
    for a, b in zip(bodies["world"].loop_tags, bodies["self"].loop_tags, strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(nodes["world"], nodes["self"])


def test_crack_mouths_on_either_loop_and_what_is_refused() -> None:
    comm = MPI.COMM_WORLD
    md, groups = _plate_with_hole(comm, False)
    body = body_outline(md.mesh, md.cell_tags, md.facet_tags, groups, "plate")
    hole = body.loops[1]
    k = int(np.argmax(hole[:, 0]))  # the hole's vertex on the +x axis
    mouth = hole[k]
    out = mouth / np.linalg.norm(mouth)
    body.check_crack(Crack2D(np.array([mouth, mouth + 0.2 * out]), "end"))  # from the hole
    body.check_crack(Crack2D(np.array([[L, 0.5], [L - 0.2, 0.5]]), "end"))  # from the edge
    refused = [
        Crack2D(np.array([mouth + 0.01 * out, mouth + 0.2 * out]), "end"),  # mouth off a loop
        Crack2D(np.array([[-0.5, 0.0], [0.5, 0.0]])),  # across the hole
        Crack2D(np.array([[0.0, 0.0], [0.0, 0.5]])),  # a tip in the hole
        Crack2D(np.array([[0.8, 0.5], [1.2, 0.5]])),  # a tip outside the plate
        Crack2D(np.array([mouth, mouth - 0.1 * out]), "end"),  # from the hole into it
    ]
    for crack in refused:
        with pytest.raises(FractureError) as err:
            body.check_crack(crack)
        assert err.value.key == "points", crack.points


def _face_length(cm, name: str) -> float:
    msh, comm = cm.mesh, cm.mesh.comm
    n_facets = msh.topology.index_map(1).size_local
    facets = cm.facet_tags.find(cm.groups[name])
    facets = facets[facets < n_facets].astype(np.int32)
    x = msh.geometry.x[entities_to_geometry(msh, 1, facets)][:, :, :2]
    return comm.allreduce(float(np.linalg.norm(x[:, 1] - x[:, 0], axis=1).sum()), op=MPI.SUM)


@pytest.mark.parametrize(
    "cracks",
    [
        # two interior cracks on either side of the hole, one inclined
        [[[0.45, 0.0], [0.75, 0.0]], [[-0.8, 0.4], [-0.5, 0.6]]],
        # an edge crack from the outer edge and an interior crack, three of them
        [[[1.0, 0.7], [0.7, 0.7]], [[-0.45, 0.0], [-0.75, 0.0]], [[0.0, -0.5], [0.1, -0.8]]],
    ],
    ids=["two", "three-with-edge"],
)
def test_several_cracks_each_with_its_own_faces(cracks: list) -> None:
    """Every crack of the body is split into its own two faces: each face as long as
    its crack, the face tags of different cracks distinct, every node used."""
    from bonecontact.fracture.body import mesh_body_with_cracks

    comm = MPI.COMM_WORLD
    md, groups = _plate_with_hole(comm, False)
    body = body_outline(md.mesh, md.cell_tags, md.facet_tags, groups, "plate")
    objs = [Crack2D(np.array(p), "end" if abs(p[0][0]) == L else "both") for p in cracks]
    views, _ = mesh_body_with_cracks(body, objs, TipMesh(h_tip=0.02), comm)
    assert len(views) == len(objs)
    tags = [t for cm in views for t in cm.face_tags]
    assert len(set(tags)) == 2 * len(objs)
    for cm, c in zip(views, objs, strict=True):
        assert cm.crack is c and cm.mesh is views[0].mesh
        for name in ("crack_plus", "crack_minus"):
            assert _face_length(cm, name) == pytest.approx(c.length, rel=1e-9), name
    msh = views[0].mesh
    n_owned = msh.geometry.index_map().size_local
    used = np.zeros(n_owned + msh.geometry.index_map().num_ghosts, dtype=bool)
    used[msh.geometry.dofmaps[0].ravel()] = True
    assert comm.allreduce(int((~used[:n_owned]).sum()), op=MPI.SUM) == 0


@pytest.mark.parametrize(
    "second",
    [[[0.6, -0.2], [0.6, 0.2]], [[0.75, 0.0], [0.9, 0.0]]],
    ids=["crossing", "touching"],
)
def test_cracks_that_meet_are_refused(second: list) -> None:
    from bonecontact.fracture.body import mesh_body_with_cracks

    comm = MPI.COMM_WORLD
    md, groups = _plate_with_hole(comm, False)
    body = body_outline(md.mesh, md.cell_tags, md.facet_tags, groups, "plate")
    cracks = [Crack2D(np.array([[0.45, 0.0], [0.75, 0.0]])), Crack2D(np.array(second))]
    with pytest.raises(FractureError, match="points: crack 1 crosses or touches crack 0"):
        mesh_body_with_cracks(body, cracks, TipMesh(h_tip=0.02), comm)
