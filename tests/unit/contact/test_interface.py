"""Distributed mortar operators (docs/theory/mortar.md#dual-mortar-discretisation): row sums, areas,
and independence of the partition.

* Σ_q M̂[p, q] = 1 on every slave row (Σ_q M = D on fully covered rows) to 1e-12, in 2D
  and 3D, with slave/master element-size ratios ≥ 3 in both directions.
* Σ_p D_pp (and Σ_p ∫ψ_p) equals the slave contact area; the covered area too.
* D, the nodal gaps, the normals and M̂ (Qᵀ applied to a nonlinear field) at every
  slave node are the same whether the mesh is distributed over all ranks or held whole
  by each rank (COMM_SELF).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import basix.ufl
import numpy as np
import pytest
from dolfinx import fem

from bonecontact.contact.interface import basis_transform, build_interface
from bonecontact.meshing import shapes as meshing

COMM = MPI.COMM_WORLD


def _interface(comm, dim, h_lower, h_upper):
    if dim == 2:
        md = meshing.two_blocks_2d(comm, h_lower=h_lower, h_upper=h_upper)
    else:
        md = meshing.two_boxes_3d(comm, h_lower=h_lower, h_upper=h_upper)
    msh = md.mesh
    V = fem.functionspace(msh, basix.ufl.element("Lagrange", msh.basix_cell(), 1, shape=(dim,)))
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    return V, build_interface(V, md.facet_tags, pg["upper_contact"], pg["lower_contact"])


CASES = [
    (2, 0.02 / 7, 0.02 / 23),
    (2, 0.02 / 23, 0.02 / 7),
    (3, 0.02 / 3, 0.02 / 9),
    (3, 0.02 / 9, 0.02 / 3),
]


@pytest.mark.parametrize(
    "case", CASES, ids=["2d_fine_slave", "2d_coarse_slave", "3d_fine_slave", "3d_coarse_slave"]
)
def test_row_sums_and_areas(case):
    dim, hl, hu = case
    V, itf = _interface(COMM, dim, hl, hu)
    area = 0.02 ** (dim - 1)
    assert itf.slave_area == pytest.approx(area, rel=1e-12)
    assert itf.covered_area == pytest.approx(area, rel=1e-10)
    assert COMM.allreduce(float(itf.D.sum())) == pytest.approx(area, rel=1e-12)
    assert COMM.allreduce(float(itf.weight.sum())) == pytest.approx(area, rel=1e-12)
    Qt = basis_transform(V, [itf])
    one, y = Qt.createVecRight(), Qt.createVecLeft()
    one.set(1.0)
    Qt.mult(one, y)  # slave rows: 1 + Σ_q M̂_pq
    rows = (dim * itf.blocks[:, None] + np.arange(dim)).ravel()
    err = COMM.allreduce(float(np.abs(y.array[rows] - 2.0).max()) if rows.size else 0.0, op=MPI.MAX)
    assert err < 1e-12
    assert COMM.allreduce(float(np.abs(itf.gap).max()) if itf.gap.size else 0.0, op=MPI.MAX) < 1e-12
    for obj in (Qt, one, y):
        obj.destroy()


def _qt_applied(V, itf):
    """(Qᵀ u) at the slave nodes, u a nonlinear field: u_p + Σ_q M̂_pq u_q per component."""
    dim = V.mesh.geometry.dim

    def field(x):
        return np.stack([np.sin(90 * x[0]) + x[1], 1e3 * x[0] * x[1], np.cos(70 * x[2])][:dim])

    u = fem.Function(V)
    u.interpolate(field)
    u.x.scatter_forward()
    Qt = basis_transform(V, [itf])
    y = Qt.createVecLeft()
    Qt.mult(u.x.petsc_vec, y)
    rows = itf.gdim * itf.blocks[:, None] + np.arange(itf.gdim)
    out = y.array[rows].copy()
    Qt.destroy()
    y.destroy()
    return out


def _per_node(comm, itf, V=None):
    extra = [] if V is None else [_qt_applied(V, itf)]
    vals = np.column_stack([itf.coords, itf.D, itf.gap, itf.normals, *extra])
    allv = np.concatenate(comm.allgather(vals))
    key = np.round(allv[:, : itf.gdim] / 1e-9).astype(np.int64)  # robust to round-off in x
    return allv[np.lexsort(key.T[::-1])]


@pytest.mark.parametrize("dim", [2, 3])
def test_same_on_any_partition(dim):
    hl, hu = (0.02 / 7, 0.02 / 23) if dim == 2 else (0.02 / 3, 0.02 / 7)
    V_dist, dist = _interface(COMM, dim, hl, hu)
    V_whole, whole = _interface(MPI.COMM_SELF, dim, hl, hu)
    a, b = _per_node(COMM, dist, V_dist), _per_node(MPI.COMM_SELF, whole, V_whole)
    assert a.shape == b.shape
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-13)  # round-off in values that are ~0


def test_degenerate_slave_facet_is_an_input_error():
    """A slave facet of zero length (two coincident vertices) is rejected with a clear
    ContactInputError on every rank, not integrated into a wrong D."""
    import ufl
    from dolfinx import mesh

    from bonecontact.contact.interface import ContactInputError

    x = np.array(
        [
            [0, 0],
            [1, 0],
            [1, 1],
            [0, 1],  # lower square
            [0, 1],
            [0.5, 1],
            [0.5, 1],
            [1, 1],
            [1, 2],
            [0, 2],
        ],
        float,
    )  # upper, sliver at x = 0.5
    cells = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 9], [5, 6, 9], [6, 7, 8], [6, 8, 9]], np.int64)
    el = ufl.Mesh(basix.ufl.element("Lagrange", "triangle", 1, shape=(2,)))
    root = COMM.rank == 0
    msh = mesh.create_mesh(
        COMM, cells if root else np.zeros((0, 3), np.int64), el, x if root else np.zeros((0, 2))
    )
    msh.topology.create_connectivity(1, 2)
    facets = mesh.locate_entities_boundary(msh, 1, lambda X: np.isclose(X[1], 1.0))
    f2c = msh.topology.connectivity(1, 2)
    cy = np.array(
        [msh.geometry.x[msh.geometry.dofmaps[0][f2c.links(f)[0]], 1].mean() for f in facets]
    )
    tags = np.where(cy > 1.0, 2, 1).astype(np.int32)
    order = np.argsort(facets)
    ft = mesh.meshtags(msh, 1, facets[order], tags[order])
    V = fem.functionspace(msh, basix.ufl.element("Lagrange", "triangle", 1, shape=(2,)))
    with pytest.raises(ContactInputError, match="degenerate"):
        build_interface(V, ft, 2, 1, name="sliver")


@pytest.mark.parametrize("approach", [False, True])
def test_bodies_apart_are_searched_from_their_closest_distance(approach):
    """The upper block lifted by 5 of its slave element sizes: the default search (three
    facet sizes beyond the closest distance) covers every slave node, and its nodal gap is
    the lift, with or without the rigid approach (flat surfaces: the approach changes no
    gap).  A search distance below the lift finds nothing and the error names the pair,
    both groups, the smallest distance and the key that sets the search distance."""
    from bonecontact.contact.interface import ContactInputError

    h_upper = 0.02 / 11
    lift = 5.0 * h_upper
    md = meshing.two_blocks_2d(COMM, h_lower=0.02 / 7, h_upper=h_upper)
    msh = md.mesh
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    upper = md.cell_tags.find(pg["upper"])
    nodes = np.unique(msh.geometry.dofmaps[0][upper])
    msh.geometry.x[nodes, 1] += lift
    V = fem.functionspace(msh, basix.ufl.element("Lagrange", msh.basix_cell(), 1, shape=(2,)))
    itf = build_interface(
        V, md.facet_tags, pg["upper_contact"], pg["lower_contact"], approach=approach
    )
    assert COMM.allreduce(float(itf.D.sum())) == pytest.approx(0.02, rel=1e-12)
    assert itf.covered_area == pytest.approx(0.02, rel=1e-10)
    np.testing.assert_allclose(itf.gap, lift, rtol=1e-10)
    with pytest.raises(ContactInputError) as err:
        build_interface(
            V,
            md.facet_tags,
            pg["upper_contact"],
            pg["lower_contact"],
            name="joint",
            search_radius=0.5 * lift,
            groups=("upper_contact", "lower_contact"),
        )
    msg = str(err.value)
    assert "'joint'" in msg and '"upper_contact"' in msg and '"lower_contact"' in msg
    assert "search_distance" in msg and f"{0.5 * lift:.3g} m" in msg
    # the smallest node-to-node distance: the lift (nodes above each other at the ends)
    assert f"is {lift:.3g} m" in msg


def test_surface_separation_is_the_smallest_node_distance():
    """surface_separation against brute force on random surfaces, the same on every rank."""
    from bonecontact.contact.interface import surface_separation

    rng = np.random.default_rng(7)
    xs = rng.random((40, 2))
    facets = np.c_[np.arange(39), np.arange(1, 40)]
    measure = np.linalg.norm(xs[facets[:, 1]] - xs[facets[:, 0]], axis=1)
    mine = rng.random((5 + COMM.rank, 2, 2)) + 0.3 * (COMM.rank + 1)
    sep = surface_separation(COMM, xs, facets, measure, mine)
    allm = np.concatenate(COMM.allgather(mine.reshape(-1, 2)))
    brute = np.linalg.norm(allm[:, None, :] - xs[None, :, :], axis=2).min()
    assert sep.distance == pytest.approx(brute, rel=1e-14)
    assert COMM.allgather(sep.distance) == [sep.distance] * COMM.size


@pytest.mark.parametrize(
    ("gaps", "expected"),
    [((0.0, 0.1, 0.3), 0.0), ((-0.1, 0.2), 0.0), ((0.2, 0.2, 0.5), 0.2)],
)
def test_approach_vector_closes_the_smallest_gap(gaps, expected):
    """The approach: zero for touching or interpenetrating surfaces; otherwise the smallest
    gap along the mean normal of the closest nodes — for two symmetric closest nodes the
    symmetric direction, whatever their order."""
    from bonecontact.contact.interface import approach_vector

    g = np.asarray(gaps, float)
    s = 0.1
    n = np.array([[s, -1.0], [-s, -1.0], [0.0, -1.0]])[: g.size]
    n /= np.linalg.norm(n, axis=1)[:, None]
    a = approach_vector(n, g, 1e-12)
    if expected == 0.0:
        assert not a.any()
        return
    assert a[0] == pytest.approx(0.0, abs=1e-15)
    # along -y: the closest nodes' gap along the normal, divided by n·e
    assert a[1] == pytest.approx(-expected / (1.0 / np.hypot(s, 1.0)), rel=1e-12)
    b = approach_vector(n[[1, 0, 2]], g[[1, 0, 2]], 1e-12)
    np.testing.assert_array_equal(a, b)
