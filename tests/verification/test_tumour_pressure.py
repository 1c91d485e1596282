"""The pressure of a nearly incompressible tumour in bone under compression
(demos/vertebra_fracture.py: the undrained tumour pushes on the thinned wall).

A spherical inclusion of radius a (E_f = 0.5 MPa, bulk modulus K_f, the
average-nodal-pressure formulation) in a cube of cancellous bone (E = 723 MPa, ν = 0.25)
of side 8a, modelled as an octant with symmetry planes, under a uniaxial compression s.
Reference: the inclusion of vanishing shear modulus in an infinite matrix (K, G) under a
remote mean stress S = −s/3 keeps a volume strain −p/K_f while the cavity's volume strain is
S/K + 3(S + p)/(4G) (Lamé's hollow sphere; the deviatoric part of the remote stress does
not change a spherical cavity's volume), so

    p = (s/3) (1/K + 3/(4G)) / (3/(4G) + 1/K_f)

(0.6 s for an incompressible inclusion with ν = 0.25).  Families: K_f of water (the demo's
undrained tumour) and of the library's drained ν = 0.49 (K_f = 8.3 MPa, p ≈ 0.013 s): the
pressure the demo puts on the cavity follows the bulk modulus as the closed form says.
Within 3 % (measured +0.9 % and −1.6 % on 9.7k cells, both the same on 2 ranks): the faceted
sphere, the finite octant and the inclusion's small shear modulus.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import gmsh
import numpy as np
import pytest

import bonecontact.plot as bp
from bonecontact.runners import run_scene
from bonecontact.scene import load_scene

COMM = MPI.COMM_WORLD
A = 1.0e-3  # inclusion radius (m)
L = 8.0 * A  # side of the octant
E_M, NU_M = 723.05e6, 0.25
E_F = 0.5e6
S = 1.0e6  # compression (Pa)


def reference_pressure(k_f: float) -> float:
    """Closed form above."""
    K = E_M / (3 * (1 - 2 * NU_M))
    G = E_M / (2 * (1 + NU_M))
    return S / 3 * (1 / K + 3 / (4 * G)) / (3 / (4 * G) + 1 / k_f)


def build_octant(path) -> None:
    """Rank 0: the octant [0, L]^3 with the inclusion's octant at the origin; cell groups
    ``bone``, ``tumour``; facet groups ``x0``, ``y0``, ``z0``, ``top``."""
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    occ = gmsh.model.occ
    box = occ.addBox(0, 0, 0, L, L, L)
    ball = occ.addSphere(0, 0, 0, A)
    cut = occ.intersect([(3, ball)], [(3, occ.addBox(0, 0, 0, L, L, L))])[0]
    occ.fragment([(3, box)], cut)
    occ.synchronize()
    vols = gmsh.model.getEntities(3)
    small = [t for _, t in vols if occ.getMass(3, t) < 0.01 * L**3]
    gmsh.model.addPhysicalGroup(3, small, 1, name="tumour")
    gmsh.model.addPhysicalGroup(3, [t for _, t in vols if t not in small], 2, name="bone")
    faces: dict[str, list[int]] = {}
    for _, s in gmsh.model.getBoundary(vols, combined=True, oriented=False):
        c = occ.getCenterOfMass(2, abs(s))
        for name, k, v in (("x0", 0, 0.0), ("y0", 1, 0.0), ("z0", 2, 0.0), ("top", 2, L)):
            if abs(c[k] - v) < 1e-12:
                faces.setdefault(name, []).append(abs(s))
    for k, (name, tags) in enumerate(sorted(faces.items()), start=3):
        gmsh.model.addPhysicalGroup(2, tags, k, name=name)
    f = gmsh.model.mesh.field
    th = f.add("MathEval")
    f.setString(th, "F", f"Min({A / 12} + 0.3 * Max(Sqrt(x*x+y*y+z*z) - {A}, 0), {L / 6})")
    f.setAsBackgroundMesh(th)
    gmsh.model.mesh.generate(3)
    gmsh.write(str(path))
    gmsh.finalize()


SCENE = """format = 1
[scene]
name = "inclusion"
mesh = "{mesh}"
dimension = 3
[analysis]
kind = "static"
[[material]]
name = "bone"
regions = ["bone"]
model = "isotropic"
E = {E_M!r}
nu = {NU_M!r}
[[material]]
name = "tumour"
regions = ["tumour"]
model = "isotropic"
E = {E_F!r}
nu = {nu_f!r}
formulation = "nodal_pressure"
[[dirichlet]]
boundary = "x0"
value = [0.0, "free", "free"]
[[dirichlet]]
boundary = "y0"
value = ["free", 0.0, "free"]
[[dirichlet]]
boundary = "z0"
value = ["free", "free", 0.0]
[[pressure]]
boundary = "top"
value = {S!r}
[output]
fields_every = 1
"""


@pytest.fixture(scope="module")
def octant(tmp_path_factory):
    path = tmp_path_factory.mktemp("octant") / "octant.msh" if COMM.rank == 0 else None
    path = COMM.bcast(path, root=0)
    if COMM.rank == 0:
        build_octant(path)
    COMM.barrier()
    return path


@pytest.mark.parametrize("k_f", [2.2e9, E_F / (3 * (1 - 2 * 0.49))], ids=["undrained", "nu049"])
def test_inclusion_pressure_matches_closed_form(octant, tmp_shared_path, k_f):
    nu_f = 0.5 - E_F / (6 * k_f)
    text = SCENE.format(mesh=octant, E_M=E_M, NU_M=NU_M, E_F=E_F, nu_f=nu_f, S=S)
    if COMM.rank == 0:
        (tmp_shared_path / "scene.toml").write_text(text)
    COMM.barrier()
    res = run_scene(load_scene(tmp_shared_path / "scene.toml"), COMM, tmp_shared_path / "out")
    assert res.status == "converged"
    p = None
    if COMM.rank == 0:
        grid = bp.read_fields(tmp_shared_path / "out" / "fields.pvd")
        x = np.asarray(grid.cell_centers().points)
        inside = np.linalg.norm(x, axis=1) < A
        sigma = np.asarray(grid.cell_data["stress"]).reshape(-1, 3, 3)[inside]
        vol = np.asarray(grid.compute_cell_sizes(length=False, area=False)["Volume"])[inside]
        p = float(-np.trace(sigma, axis1=1, axis2=2) @ vol / (3 * vol.sum()))
    p = COMM.bcast(p, root=0)
    assert p == pytest.approx(reference_pressure(k_f), rel=0.03)
