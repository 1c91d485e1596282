"""The code of docs/meshing.md runs as written and builds what the page says.

References: the applied load (the contact force of the disc held only by contact equals
it, equilibrium), the element sizes the page asks for, the physical-group names and the
millimetre-to-metre conversion of the imported mesh.
"""

from __future__ import annotations

import re
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

pytestmark = pytest.mark.serial  # gmsh writes files from one process

DOC = Path(__file__).resolve().parents[3] / "docs" / "meshing.md"


def _blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)


@pytest.fixture(scope="module")
def ran(tmp_path_factory):
    """Every python block of the page, in order, in one namespace, in an empty directory."""
    import os

    d = tmp_path_factory.mktemp("meshing-doc")
    cwd = os.getcwd()
    os.chdir(d)
    ns: dict = {}
    try:
        for code in _blocks():
            exec(compile(code, str(DOC), "exec"), ns)
    finally:
        os.chdir(cwd)
    return d, ns


def test_page_has_the_examples():
    assert len(_blocks()) == 7


def test_disc_on_plate_groups_and_sizes(ran):
    import meshio

    from bonecontact.meshing import read_gmsh_mesh

    d, ns = ran
    _, md = read_gmsh_mesh(d / "disc_on_plate.msh", MPI.COMM_SELF, 2)
    assert set(md.physical_groups) == {
        "disc",
        "plate",
        "disc_contact",
        "disc_top",
        "plate_contact",
        "plate_bottom",
    }
    m = meshio.read(d / "disc_on_plate.msh")
    tri = np.vstack([c.data for c in m.cells if c.type == "triangle"])
    p = m.points[:, :2]
    edges = np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    length = np.linalg.norm(p[edges[:, 0]] - p[edges[:, 1]], axis=1)
    dist = np.linalg.norm(0.5 * (p[edges[:, 0]] + p[edges[:, 1]]), axis=1)
    h_contact, h_far, zone = ns["h_contact"], ns["h_far"], ns["zone"]
    assert length[dist < 1e-3].max() < 1.6 * h_contact
    assert np.median(length[dist > 1.2 * zone]) > 0.6 * h_far


def test_disc_on_plate_contact_carries_the_load(ran):
    d, ns = ran
    history = ns["history"]
    applied = 1.0e6 * 2 * ns["R"]  # 1 MPa over the 40 mm top (N/m)
    # normal_force sums |λ_n| along the slave normals, which tilt away from y on the curved
    # disc: at least the applied vertical load, and only slightly more (contact half-width
    # a few mm on R = 20 mm: cos > 0.998)
    assert applied <= history["normal_force"][-1] <= 1.002 * applied
    assert ns["result"].status == "converged"
    assert ns["result"].summary["warnings"] == []


def test_external_mesh_in_metres_with_groups(ran):
    from bonecontact.meshing import read_gmsh_mesh

    d, _ = ran
    _, md = read_gmsh_mesh(d / "external.msh", MPI.COMM_SELF, 2)
    assert set(md.physical_groups) == {"cortical", "cancellous", "bottom", "top"}
    x = md.mesh.geometry.x
    np.testing.assert_allclose(x.max(axis=0)[:2] - x.min(axis=0)[:2], [0.01, 0.02], rtol=1e-12)
    assert len(md.facet_tags.find(md.physical_groups["top"].tag)) == 1
    assert len(md.cell_tags.find(md.physical_groups["cortical"].tag)) == 2


def test_surface_scan_and_ct_examples(ran):
    """The L4 written in mm and read with scale 1e-3 keeps its volume; the CT slice meshes."""
    import meshio

    from bonecontact.meshing import anatomy_surface, read_gmsh_mesh

    d, ns = ran
    _, md = read_gmsh_mesh(d / "L4.msh", MPI.COMM_SELF, 3)
    assert set(md.physical_groups) == {
        "L4_cortical",
        "L4_cancellous",
        "L4_endplate",
        "L4_base",
        "L4_surface",
    }
    m = meshio.read(d / "L4.msh")
    a, b, c, e = (m.points[m.cells_dict["tetra"][:, i]] for i in range(4))
    volume = np.abs(np.einsum("ij,ij->i", b - a, np.cross(c - a, e - a))).sum() / 6
    assert volume == pytest.approx(anatomy_surface("L4").volume, rel=0.05)  # remeshed to 4 mm
    _, md = read_gmsh_mesh(d / "vertebra.msh", MPI.COMM_SELF, 2)
    assert {"vertebra", "vertebra_outer"} <= set(md.physical_groups)
    assert len(ns["regions"]) >= 1


def test_knee_joint_example(ran):
    """The knee of the page: the femur posed 4.5 mm above the plateau at both condyles
    (within 0.05 mm), both bones with cortex, core and cartilage, the contact layers named."""
    from bonecontact.meshing import read_gmsh_mesh

    d, ns = ran
    np.testing.assert_allclose(ns["pose"].gaps, 4.5e-3, atol=5e-5)
    _, md = read_gmsh_mesh(d / "knee.msh", MPI.COMM_SELF, 3)
    groups = set(md.physical_groups)
    for bone in ("femur", "tibia"):
        assert {f"{bone}_cartilage", f"{bone}_contact"} <= groups, groups
    assert {"femur_top", "tibia_base"} <= groups
