"""Contact patch tests on non-matching interface meshes
(docs/theory/verification.md#verification-references), 2D and 3D, any rank count.

Two separately meshed blocks (the interface nodes do not match) are pressed together by
a uniform pressure p on the top; the bottom is on rollers and one side of each block
is held in x (and one in z in 3D), so with the same Poisson ratio — or with different
ones, since frictionless contact lets the blocks slide — the exact solution has
σ_yy = −p everywhere.  The mortar multiplier recovered at every slave node must equal p
to 1e-8 relative, and the total normal force must equal p times the contact area.
Hard cases: slave/master element-size ratios 1:5 and 5:1, stiffness contrast 10⁴
(cartilage on bone) with either side as slave; the PDAS must need one iteration (the
initial closed-gap active set is already the solution).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import numpy as np
import pytest

from bonecontact.contact.interface import build_interface
from bonecontact.contact.pdas import ContactSolver
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics
from bonecontact.meshing import shapes as meshing

COMM = MPI.COMM_WORLD
P = 2.0e5  # Pa


def distort(msh, amplitude: float) -> None:
    """Move the nodes inside each block by a smooth field that vanishes on the block
    faces (x, z ∈ {0, 0.02}, y ∈ {0, 0.01, 0.02}): strongly distorted elements, same
    boundaries, so the exact solution of the patch test is unchanged."""
    x = msh.geometry.x
    s = np.sin(np.pi * x[:, 0] / 0.02) * np.sin(np.pi * x[:, 1] / 0.01)
    if msh.geometry.dim == 3:
        s = s * np.sin(np.pi * x[:, 2] / 0.02)
    x[:, 0] += amplitude * s * np.cos(7.0 * x[:, 1] / 0.01)
    x[:, 1] += amplitude * s * np.sin(5.0 * x[:, 0] / 0.02)


def patch(
    dim: int,
    h_lower: float,
    h_upper: float,
    E_lower: float,
    E_upper: float,
    slave: str,
    nu_lower: float = 0.3,
    nu_upper: float = 0.3,
    linear: str = "direct",
    distortion: float = 0.0,
):
    if dim == 2:
        md = meshing.two_blocks_2d(COMM, h_lower=h_lower, h_upper=h_upper)
    else:
        md = meshing.two_boxes_3d(COMM, h_lower=h_lower, h_upper=h_upper)
    if distortion:
        distort(md.mesh, distortion)
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    mats = {
        pg["lower"]: Isotropic(E=E_lower, nu=nu_lower),
        pg["upper"]: Isotropic(E=E_upper, nu=nu_upper),
    }
    m = Mechanics(md.mesh, mats, md.cell_tags, md.facet_tags)
    m.add_dirichlet(m.facets(pg["bottom"]), 1, 0.0)
    for side in ("lower_left", "upper_left"):
        m.add_dirichlet(m.facets(pg[side]), 0, 0.0)
    if dim == 3:
        for side in ("lower_front", "upper_front"):
            m.add_dirichlet(m.facets(pg[side]), 2, 0.0)
    m.add_traction(pg["top"], [0.0, -P] + [0.0] * (dim - 2))
    s, ms = (
        ("upper_contact", "lower_contact")
        if slave == "upper"
        else ("lower_contact", "upper_contact")
    )
    itf = build_interface(
        m.V, md.facet_tags, pg[s], pg[ms], dirichlet_dofs=m.bc_dofs(), name="patch"
    )
    integ = Integrator(m, "static", 1.0, linear=linear, contact=ContactSolver(m.V, [itf]))
    integ.step()
    res = integ.last_contact
    lam = res.pressure[0]
    err = COMM.allreduce(float(np.abs(lam - P).max() / P) if lam.size else 0.0, op=MPI.MAX)
    nodes = COMM.allreduce(lam.size)
    area = itf.slave_area
    out = (err, nodes, res.normal_force[0], area, res.iterations, integ)
    return out


CASES_2D = [
    # (h_lower, h_upper, E_lower, E_upper, slave)
    (0.02 / 7, 0.02 / 23, 17e9, 1.0e6, "upper"),  # ratio ~3.3, soft fine slave on bone
    (0.02 / 5, 0.02 / 25, 17e9, 1.7e6, "upper"),  # slave:master size 1:5, contrast 1e4
    (0.02 / 25, 0.02 / 5, 17e9, 1.7e6, "upper"),  # slave:master size 5:1
    (0.02 / 5, 0.02 / 25, 17e9, 1.7e6, "lower"),  # stiff side as slave
    (0.02 / 25, 0.02 / 5, 1.7e6, 17e9, "lower"),  # soft lower block, coarse... (5:1 slave fine)
]


@pytest.mark.parametrize(
    "case", CASES_2D, ids=["ratio3", "1to5", "5to1", "stiff_slave", "soft_lower"]
)
def test_patch_2d(case):
    err, nodes, force, area, its, integ = patch(2, *case)
    assert nodes > 3
    assert err < 1e-8, err
    assert force == pytest.approx(P * area, rel=1e-10)
    assert its == 1
    integ.destroy()


@pytest.mark.parametrize("dim", [2, 3])
def test_patch_distorted_meshes(dim):
    """Interior nodes moved by up to 0.3 of the finer block's element size (the coarse
    block's elements are distorted by ~0.1 of their size, the fine block's by 0.3)."""
    case = (
        (0.02 / 7, 0.02 / 23, 17e9, 1.7e6, "upper")
        if dim == 2
        else (0.02 / 3, 0.02 / 9, 17e9, 1.7e6, "upper")
    )
    err, nodes, force, area, its, integ = patch(dim, *case, distortion=0.3 * min(case[0], case[1]))
    assert err < 1e-8, err
    assert force == pytest.approx(P * area, rel=1e-10)
    integ.destroy()


def test_patch_2d_different_poisson_ratios_iterative():
    """ν differs across the interface (the blocks slide relative to each other) and the
    condensed system is solved by GMRES + GAMG."""
    err, nodes, force, area, its, integ = patch(
        2,
        0.02 / 7,
        0.02 / 23,
        17e9,
        1.0e7,
        "upper",
        nu_lower=0.3,
        nu_upper=0.45,
        linear="iterative",
    )
    assert err < 1e-8, err
    assert force == pytest.approx(P * area, rel=1e-8)
    integ.destroy()


@pytest.mark.parametrize(
    "case",
    [(0.02 / 3, 0.02 / 9, 17e9, 1.7e6, "upper"), (0.02 / 9, 0.02 / 3, 1.7e6, 17e9, "lower")],
    ids=["soft_slave", "soft_lower_slave"],
)
def test_patch_3d(case):
    err, nodes, force, area, its, integ = patch(3, *case)
    assert nodes > 20
    assert err < 1e-8, err
    assert force == pytest.approx(P * area, rel=1e-10)
    assert its == 1
    integ.destroy()


@pytest.mark.parametrize("kind", ["quasistatic", "dynamic"])
def test_patch_kelvin_voigt_time_stepping(kind):
    """Time-dependent patch test: both blocks Kelvin–Voigt (τ_v = 2 ms), the load ramped
    over 1 ms.  Quasi-static: the contact force equals the applied load p·W at every
    step and λ = p at every node (1e-8).  Dynamic: the blocks ring and settle; after
    4 ms the contact force is p·W within 1 % and the kinetic energy has decayed."""
    md = meshing.two_blocks_2d(COMM, h_lower=0.02 / 7, h_upper=0.02 / 23)
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    mats = {
        pg["lower"]: Isotropic(E=17e9, nu=0.3, rho=1900.0, tau_v=2e-3),
        pg["upper"]: Isotropic(E=1.7e6, nu=0.3, rho=1100.0, tau_v=2e-3),
    }
    m = Mechanics(md.mesh, mats, md.cell_tags, md.facet_tags)
    m.add_dirichlet(m.facets(pg["bottom"]), 1, 0.0)
    for side in ("lower_left", "upper_left"):
        m.add_dirichlet(m.facets(pg[side]), 0, 0.0)
    m.add_traction(pg["top"], [0.0, -P], schedule=lambda t: min(t / 1e-3, 1.0))
    itf = build_interface(
        m.V, md.facet_tags, pg["upper_contact"], pg["lower_contact"], dirichlet_dofs=m.bc_dofs()
    )
    integ = Integrator(m, kind, 1e-4, contact=ContactSolver(m.V, [itf]))
    for _ in range(40):
        integ.step()
        load = P * 0.02 * min(integ.t / 1e-3, 1.0)
        if kind == "quasistatic":
            assert integ.last_contact.normal_force[0] == pytest.approx(load, rel=1e-9)
            lam = integ.last_contact.pressure[0]
            err = COMM.allreduce(
                float(np.abs(lam * 0.02 - load).max()) if lam.size else 0.0, op=MPI.MAX
            )
            assert err < 1e-8 * load
    if kind == "dynamic":
        assert integ.last_contact.normal_force[0] == pytest.approx(P * 0.02, rel=0.01)
        assert integ.energy().kinetic < 1e-3 * integ.energy().strain
    integ.destroy()


def test_patch_two_contact_pairs():
    """Three stacked blocks (17 GPa, 1.7 MPa, 1 GPa), each meshed on its own: two contact
    pairs in one PDAS solve (the middle block is slave of one pair and master of the
    other); the two middle/top blocks are held vertically only by contact.  λ = p at
    every slave node of both pairs (1e-8)."""
    md = meshing.stacked_blocks_2d(COMM)
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    mats = {
        pg["block1"]: Isotropic(E=17e9, nu=0.3),
        pg["block2"]: Isotropic(E=1.7e6, nu=0.3),
        pg["block3"]: Isotropic(E=1e9, nu=0.3),
    }
    m = Mechanics(md.mesh, mats, md.cell_tags, md.facet_tags)
    m.add_dirichlet(m.facets(pg["block1_bottom"]), 1, 0.0)
    for i in (1, 2, 3):
        m.add_dirichlet(m.facets(pg[f"block{i}_left"]), 0, 0.0)
    m.add_traction(pg["block3_top"], [0.0, -P])
    bc = m.bc_dofs()
    pairs = [
        build_interface(
            m.V, md.facet_tags, pg["block2_bottom"], pg["block1_top"], dirichlet_dofs=bc, name="a"
        ),
        build_interface(
            m.V, md.facet_tags, pg["block3_bottom"], pg["block2_top"], dirichlet_dofs=bc, name="b"
        ),
    ]
    integ = Integrator(m, "static", 1.0, contact=ContactSolver(m.V, pairs))
    integ.step()
    r = integ.last_contact
    for k in range(2):
        lam = r.pressure[k]
        err = COMM.allreduce(float(np.abs(lam / P - 1.0).max()) if lam.size else 0.0, op=MPI.MAX)
        assert COMM.allreduce(lam.size) > 5
        assert err < 1e-8, (k, err)
        assert r.normal_force[k] == pytest.approx(P * 0.02, rel=1e-10)
    integ.destroy()
