"""Crack faces as a contact pair (bonecontact.fracture.faces): the pair's facets, and the
face traction of a frictionless closed crack under uniform compression against the
closed-form normal stress on the crack plane.

Runs serially and under ``mpiexec -n 2/3``.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from dolfinx import fem

from bonecontact.fracture.faces import MASTER_TAG, SLAVE_TAG, contact_tags
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.plates import centre_crack, mesh_plate, solve_plate
from bonecontact.materials.laws import Isotropic

COMM = MPI.COMM_WORLD
MAT = Isotropic(E=10.0e9, nu=0.3)
A, H_TIP = 0.1, 0.005


def total(form) -> float:
    return COMM.allreduce(fem.assemble_scalar(fem.form(form)), op=MPI.SUM)


@pytest.fixture(scope="module")
def closed():
    cm = mesh_plate(1.0, 1.0, centre_crack(A, 30.0), TipMesh(H_TIP, 0.3, 0.2), COMM)
    return solve_plate(cm, MAT, {"edge2": (0.0, -1e6), "edge0": (0.0, 1e6)}, face_contact=True)


def test_pair_leaves_out_the_tip_facets(closed):
    cm = closed.cm
    tags = contact_tags(cm)
    ds = ufl.Measure("ds", domain=cm.mesh, subdomain_data=tags)
    slave, master = total(1.0 * ds(SLAVE_TAG)), total(1.0 * ds(MASTER_TAG))
    assert master == pytest.approx(2 * A, rel=1e-12)
    # two tip facets of about h_tip each are left out of the slave side
    assert 2 * A - 2 * 1.5 * H_TIP < slave < 2 * A - 2 * 0.5 * H_TIP


def test_face_traction_is_the_normal_stress_on_the_crack_plane(closed):
    """Frictionless: t = -sigma_n n on both faces, sigma_n = |sigma| cos^2(30 deg)."""
    cm, t = closed.cm, closed.face_traction
    ds = ufl.Measure("ds", domain=cm.mesh, subdomain_data=cm.facet_tags)
    n = ufl.FacetNormal(cm.mesh)
    e1 = ufl.as_vector([math.cos(math.pi / 6), math.sin(math.pi / 6)])
    sn = 1e6 * math.cos(math.pi / 6) ** 2
    for tag in cm.face_tags:
        length = total(1.0 * ds(tag))
        assert total(ufl.dot(t, n) * ds(tag)) / length == pytest.approx(-sn, rel=2e-2)
        assert abs(total(ufl.dot(t, e1) * ds(tag))) / length < 1e-9 * sn
    # action and reaction: coincident face nodes carry opposite tractions
    x = t.function_space.tabulate_dof_coordinates()[:, :2]
    vals = t.x.array.reshape(-1, 2)
    loaded = np.linalg.norm(vals, axis=1) > 0
    pts = {}
    for p, v in zip(map(tuple, np.round(x[loaded] / 1e-12).astype(np.int64)), vals[loaded]):
        pts.setdefault(p, []).append(v)
    pairs = [v for v in pts.values() if len(v) == 2]
    assert COMM.allreduce(len(pairs), op=MPI.SUM) > 0
    for a, b in pairs:
        np.testing.assert_allclose(a, -b, rtol=1e-12, atol=1e-9)
