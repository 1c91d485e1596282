"""Bodies held in the load direction only by contact, on any number of ranks.

A block is pushed by a uniform traction on its bottom face against a fixed half
cylinder (2D) or hemisphere (3D); its only other condition holds it sideways (the
tangential components of its bottom face), so the contact alone carries the load and
removes its tilt.  The curved body touches the block at a single node at the start:
the cold start must support the block from the first solve, on one rank and on two or
three, also when that node lies on a partition boundary (a partitioner that splits the
cells into sectors around it, checked with the index map).

References, independent of the PDAS:

* equilibrium: the vertical resultant of the contact pressure equals the applied load
  (to 1e-8 relative);
* the serial solution of the same problem (every rank solves it on its own, direct
  solver): the distributed pressures equal it (to 1e-8 of the peak), and so do those of
  the iterative path (CG + GAMG, inexact PDAS) on any number of ranks;
* Hertz (docs/theory/verification.md#verification-references): the peak pressure of the
  applied load, within 3 % (2D, a/h = 10) and 12 % (3D, a/h ≈ 4; the 3D discretisation
  error at that size is documented in tests/verification/test_hertz.py).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import tempfile
from pathlib import Path

from mpi4py import MPI

import gmsh
import numpy as np
import pytest
from dolfinx.cpp.graph import AdjacencyList_int32
from dolfinx.cpp.mesh import GhostMode, create_cell_partitioner
from dolfinx.io.gmsh import extract_topology_and_markers, read_from_msh

from bonecontact.contact.interface import build_interface
from bonecontact.contact.options import PDASOptions
from bonecontact.contact.pdas import ContactSolver
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics
from bonecontact.meshing import shapes
from bonecontact.verification.analytic import hertz_2d, hertz_3d
from bonecontact.verification.load_driven import hertz_errors, sphere_on_block_3d

COMM = MPI.COMM_WORLD
R, NU, E_SOFT, E_STIFF = 0.01, 0.3, 2.0e9, 17.0e9
A_2D, A_3D = 5.0e-4, 1.0e-3  # Hertz half-width / radius the load is chosen for


def _lowest_slave_node(x: np.ndarray) -> np.ndarray:
    """The node of the curved (slave) surface of the gmsh model with the smallest y: the
    one that touches the block."""
    dim = gmsh.model.getDimension() - 1
    tag = next(
        t
        for d, t in gmsh.model.getPhysicalGroups(dim)
        if gmsh.model.getPhysicalName(d, t) in ("cyl_contact", "sphere_contact")
    )
    nodes = gmsh.model.mesh.getNodesForPhysicalGroup(dim, tag)[0] - 1
    return x[nodes[np.argmin(x[nodes, 1])]]


def _sector_partitioner(gdim: int):
    """Cells to ranks by the angle of their centroid around the touching node, in the
    x–y plane (2D) or the x–z plane (3D): every rank's sector meets the others there, so
    the touching node lies on a partition boundary."""

    def graph_partitioner(comm, nparts, graph, ghosting):
        n = graph.num_nodes
        if n == 0:
            return AdjacencyList_int32(np.zeros(0, np.int32), np.zeros(1, np.int32))
        _, x, _ = gmsh.model.mesh.getNodes()  # rank 0 reads the file: gmsh holds it
        x = x.reshape(-1, 3)
        tops = extract_topology_and_markers(gmsh.model)[0]
        cells = next(
            t["topology"]
            for k, t in tops.items()
            if gmsh.model.mesh.getElementProperties(k)[1] == gdim
        )
        assert cells.shape[0] == n
        c = x[cells].mean(axis=1) - _lowest_slave_node(x)
        angle = np.arctan2(c[:, 2] if gdim == 3 else c[:, 1], c[:, 0]) + np.pi
        dest = np.minimum((angle / (2 * np.pi) * nparts).astype(np.int32), nparts - 1)
        return AdjacencyList_int32(dest, np.arange(n + 1, dtype=np.int32))

    return create_cell_partitioner(graph_partitioner, GhostMode.none, 2)


def _mesh(comm: MPI.Comm, gdim: int, h: float, partition: str):
    kw = {"h_contact": h, "zone": 1.5 * (A_2D if gdim == 2 else A_3D)}
    if gdim == 2:
        kw["h_far"] = 2e-3
    else:
        kw |= {"h_far": 4e-3, "block_half_width": 0.015, "block_height": 0.015}
    build = shapes.hertz_2d if gdim == 2 else shapes.hertz_3d
    if partition == "default":
        return build(comm, **kw)
    folder = comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None)
    path = Path(folder) / f"load_driven_{gdim}d.msh"
    build(comm, path, **kw)
    return read_from_msh(path, comm, 0, gdim=gdim, partitioner=_sector_partitioner(gdim))


def _ranks_holding(md, point: np.ndarray) -> int:
    """On how many ranks the mesh node at ``point`` is local (owned or ghost)."""
    x = md.mesh.geometry.x[:, : point.size]
    here = bool((np.linalg.norm(x - point, axis=1) < 1e-12).any())
    return md.mesh.comm.allreduce(int(here), op=MPI.SUM)


def _solve(
    comm: MPI.Comm, gdim: int, h: float, partition: str = "default", linear: str = "direct"
) -> dict:
    """The block pushed against the fixed curved body; the load is that of Hertz's
    solution with half-width/radius A_2D or A_3D; ``linear``: the solver of the PDAS
    systems."""
    md = _mesh(comm, gdim, h, partition)
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    curved, c_top, c_contact = (
        ("cylinder", "cyl_top", "cyl_contact")
        if gdim == 2
        else ("sphere", "sphere_top", "sphere_contact")
    )
    m = Mechanics(
        md.mesh,
        {pg[curved]: Isotropic(E=E_SOFT, nu=NU), pg["block"]: Isotropic(E=E_STIFF, nu=NU)},
        md.cell_tags,
        md.facet_tags,
    )
    for c in range(gdim):
        m.add_dirichlet(m.facets(pg[c_top]), c, 0.0)
    for c in (0, 2)[: gdim - 1]:
        m.add_dirichlet(m.facets(pg["block_bottom"]), c, 0.0)  # sideways only
    if gdim == 2:
        load = hertz_2d.load_for_half_width(A_2D, R, E_SOFT, NU, E_STIFF, NU)
        area = 2 * 0.05  # bottom of the block (per unit thickness)
    else:
        load = hertz_3d.load_for_radius(A_3D, R, E_SOFT, NU, E_STIFF, NU)
        area = (2 * 0.015) ** 2
    m.add_traction(pg["block_bottom"], [0.0, load / area, 0.0][:gdim])
    itf = build_interface(
        m.V, md.facet_tags, pg[c_contact], pg["block_contact"], dirichlet_dofs=m.bc_dofs()
    )
    gaps = np.concatenate(comm.allgather(itf.gap))
    touching = np.concatenate(comm.allgather(itf.coords))[np.argmin(gaps)]
    integ = Integrator(m, "static", 1.0, linear=linear, contact=ContactSolver(m.V, [itf]))
    integ.step()
    r = integ.last_contact
    force = comm.allreduce(
        float(-(itf.weight * r.pressure[0] * itf.normals[:, 1]).sum()), op=MPI.SUM
    )
    X = np.concatenate(comm.allgather(itf.coords))
    p = np.concatenate(comm.allgather(r.pressure[0]))
    order = np.lexsort(X.T[::-1])
    out = {
        "load": load,
        "force": force,
        "x": X[order],
        "p": p[order],
        "iterations": r.iterations,
        "touching": int((gaps <= gaps.min() + 1e-9 * R).sum()),
        "ranks_at_touching_node": _ranks_holding(md, touching),
    }
    integ.destroy()
    return out


def _check(gdim: int, h: float, partition: str, p0_tol: float, linear: str = "direct") -> None:
    got = _solve(COMM, gdim, h, partition, linear)
    assert got["touching"] == 1  # a single touching node at the start
    if partition == "boundary" and COMM.size > 1:
        assert got["ranks_at_touching_node"] >= 2  # ... on a partition boundary
    assert got["force"] == pytest.approx(got["load"], rel=1e-8)
    if COMM.size > 1 or linear != "direct":
        ref = _solve(MPI.COMM_SELF, gdim, h)  # the serial direct solution, on every rank
        assert np.abs(got["x"] - ref["x"]).max() < 1e-12
        assert np.abs(got["p"] - ref["p"]).max() < 1e-8 * ref["p"].max()
        assert got["iterations"] == ref["iterations"]
    hertz = hertz_2d if gdim == 2 else hertz_3d
    p0 = hertz.peak_pressure(got["load"], R, E_SOFT, NU, E_STIFF, NU)
    assert got["p"].max() == pytest.approx(p0, rel=p0_tol)


@pytest.mark.parametrize("partition", ["default", "boundary"])
def test_block_held_by_contact_2d(partition):
    _check(2, A_2D / 10, partition, 0.03)


@pytest.mark.parametrize("partition", ["default", "boundary"])
def test_block_held_by_contact_3d(partition):
    _check(3, A_3D / 2.5, partition, 0.25)


@pytest.mark.parametrize("gdim", [2, 3])
def test_block_held_by_contact_iterative(gdim):
    """The iterative path (CG + GAMG on the condensed system, inexact PDAS) from the
    single touching node on a partition boundary: the serial direct solution."""
    _check(
        gdim,
        A_2D / 10 if gdim == 2 else A_3D / 2.5,
        "boundary",
        0.03 if gdim == 2 else 0.25,
        "iterative",
    )


def _sphere_on_block(h: float, cold_start_3d: str, **options) -> dict:
    """The load-driven 3D Hertz problem of the benchmarks (a hemisphere loaded on its flat
    face, held in the load direction only by the contact): a cold solve, then a warm
    solve with the load raised by 10 %."""
    opts = PDASOptions.from_fields(cold_start_3d=cold_start_3d, **options)
    pb = sphere_on_block_3d(COMM, h, h_far=3e-3, options=opts)
    cold = pb.solve()
    err = hertz_errors(pb)
    b = pb.integrator.rhs(1.0).copy()
    pb.integrator.apply_dirichlet(1.0, b)
    b.scale(1.1)  # (the Dirichlet values are zero)
    warm = pb.integrator.contact.solve(b, pb.integrator.u)
    err_warm = hertz_errors(pb, warm)
    p = np.concatenate(COMM.allgather(cold.pressure[0]))
    X = np.concatenate(COMM.allgather(pb.interface.coords))
    pb.destroy()
    return {"cold": cold, "warm": warm, "err": err, "err_warm": err_warm, "p": p[np.lexsort(X.T)]}


@pytest.mark.parametrize(
    "h, p0_tol, a_tol",
    [
        (4.0e-4, 0.15, 0.07),
        pytest.param(2.8e-4, 0.07, 0.02, marks=pytest.mark.two_ranks),  # the refinement
    ],
)
def test_cold_start_3d_hertz_iterations(h, p0_tol, a_tol):
    """The cold start predicted from the support patch's compliance
    (docs/theory/pdas.md#cold-start): at two refinements (a/h = 2.5, 3.6) a cold solve
    takes at most 6 PDAS iterations and a warm step (+10 % load) at most 2, with the
    same pressures as the damped 2D rule (a second path to the same discrete solution),
    the resultant equal to the load, and Hertz's p0 and a to the discretisation error of
    these meshes.  The split basis of the low-rank solver (the operator with only the
    support patch in the contact basis, factorised once, and at most once more with the
    predicted contact zone added when its force columns would cost more) gives the same
    pressures as the full contact basis."""
    got = _sphere_on_block(h, "compliance")
    ref = _sphere_on_block(h, "damped")
    full = _sphere_on_block(h, "compliance", split_basis=False)
    assert got["cold"].factorizations <= 2
    assert np.abs(got["p"] - full["p"]).max() <= 1e-8 * full["p"].max()
    assert got["cold"].iterations <= 6
    assert got["cold"].iterations <= ref["cold"].iterations
    assert got["warm"].iterations <= 2
    assert np.abs(got["p"] - ref["p"]).max() <= 1e-8 * ref["p"].max()
    assert got["err"]["equilibrium"] < 1e-10
    assert got["err_warm"]["P_contact"] == pytest.approx(1.1 * got["err"]["P_applied"], rel=1e-10)
    assert abs(got["err"]["p0"]) < p0_tol
    assert abs(got["err"]["a"]) < a_tol


def test_cold_start_3d_block_on_hemisphere_iterations():
    """The block pushed onto the fixed hemisphere (the load-driven body is the master side
    here, and bends on the few patch nodes): a cold solve in at most 6 PDAS iterations,
    the resultant equal to the load."""
    got = _solve(COMM, 3, A_3D / 4)
    assert got["iterations"] <= 6
    assert got["force"] == pytest.approx(got["load"], rel=1e-8)
