"""Neoplasm growth coupled to the loaded bone in 3D (``bonecontact.neoplasm.host3d``).

Collective tests (serial session and ``mpiexec -n 2 / -n 3``); the one marked ``serial``
runs the command on 1, 2 and 3 ranks.

References (independent of the code under test):

* **pressurised spherical cavity**: a cyst grown from r0 = 2 mm for one year at the
  centre of a ball of radius b = 20 mm clamped at r = b.  Lamé's thick sphere,
  u(r) = A r + B / r², σ_rr = (3λ+2μ) A − 4μ B / r³, with u(b) = 0 and σ_rr(R) = −f:
  B = f / (4μ/R³ + (3λ+2μ)/b³), A = −B/b³ (b → ∞: u_r = f R³ / (4 μ r²)); the hoop
  stress at the wall σ_θθ = (3λ+2μ) A + 2μ B / R³ is the [fracture] check's σ₁ there.
* **soft spherical inclusion** at the centre of a cube of side 20 R under uniaxial
  stress σ0 (rollers on three faces, traction on the fourth): the stress inside a
  sphere in an infinite matrix is uniform (Eshelby 1957).  With the Eshelby tensor of a
  sphere (volumetric part α = (1+ν)/(3(1−ν)), deviatoric part β = 2(4−5ν)/(15(1−ν)), ν
  of the matrix) the inside strain is θ = θ∞ K_m / (K_m + α (K_i − K_m)) (volumetric) and
  e = e∞ μ_m / (μ_m + β (μ_i − μ_m)) (deviatoric); finite-cube effects are O((R/L)³).

Measured (serial; the asserts state the tolerances): see the comments at each assert.
Finer meshes than these defaults, measured once: the cavity wall u_r / Lamé 0.9914 on
average at wall edge R/32 (262k cells; the slow test), the inclusion's mean σ_xx 1.5 %
(0.29 % of σ0) below Eshelby at R/14 (148k cells).  Default tests on a loaded 2-core
machine: Lamé 116 s, Eshelby 225 s, 1/2/3 ranks 150 s, the growing tumour 16 s.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from cli_support import ENV as BASE_ENV
from cli_support import run_scene as run_cli_scene
from coupled_support import gmsh_on_rank0, read_csv, refine_near, run_text
from dolfinx import fem

from bonecontact.common.constants import SECONDS_PER_YEAR
from bonecontact.neoplasm.host import CouplingError
from bonecontact.neoplasm.host3d import (
    build_host_mesh3d,
    read_host_geometry3d,
    sphere_surface,
    surface_volume,
)
from bonecontact.scene import SceneError, load_scene

#: growth tests: the 2-rank session and the serial one run them; the 3-rank session
#: leaves them to the tests that spawn 3 ranks (make test-all runs them on 3 ranks too)
pytestmark = pytest.mark.growth

ENV = {**BASE_ENV, "PYTHONWARNINGS": "ignore"}
YEAR = SECONDS_PER_YEAR
E_BONE, NU_BONE = 1.0e9, 0.3
B_BALL, R0_CYST = 0.02, 0.002


# ----------------------------------------------------------------------------- meshes
def ball_with_core(path: Path, b: float, r0: float, h_in: float, h_out: float) -> None:
    """Ball of radius ``b`` ("bone", outer facet group "outer") around a core ball ``r0``
    ("cyst")."""

    def build(gmsh):
        occ = gmsh.model.occ
        _, m = occ.fragment([(3, occ.addSphere(0, 0, 0, b))], [(3, occ.addSphere(0, 0, 0, r0))])
        occ.synchronize()
        inner = [t for _, t in m[1]]
        outer = [t for _, t in m[0] if t not in inner]
        gmsh.model.addPhysicalGroup(3, outer, 1, name="bone")
        gmsh.model.addPhysicalGroup(3, inner, 2, name="cyst")
        rim = gmsh.model.getBoundary([(3, s) for s in outer + inner], combined=True)
        gmsh.model.addPhysicalGroup(2, [abs(t) for _, t in rim], 3, name="outer")
        core = [abs(t) for _, t in gmsh.model.getBoundary([(3, s) for s in inner])]
        refine_near(gmsh, core, h_in, h_out, 4 * r0)

    gmsh_on_rank0(build, path, 3)


def cube_with_inclusion(path: Path, L: float, R: float, h_in: float, h_out: float) -> None:
    """Cube [0, 2L]³ ("block") with a ball of radius R at its centre ("tumour"); facet
    groups "x0", "y0", "z0", "x1"."""

    def build(gmsh):
        occ = gmsh.model.occ
        box, ball = occ.addBox(0, 0, 0, 2 * L, 2 * L, 2 * L), occ.addSphere(L, L, L, R)
        _, m = occ.fragment([(3, box)], [(3, ball)])
        occ.synchronize()
        inner = [t for _, t in m[1]]
        outer = [t for _, t in m[0] if t not in inner]
        gmsh.model.addPhysicalGroup(3, outer, 1, name="block")
        gmsh.model.addPhysicalGroup(3, inner, 2, name="tumour")
        faces = [abs(t) for _, t in gmsh.model.getBoundary([(3, t) for t in outer + inner])]
        for k, (name, axis, val) in enumerate(
            [("x0", 0, 0.0), ("y0", 1, 0.0), ("z0", 2, 0.0), ("x1", 0, 2 * L)]
        ):
            pick = [f for f in faces if abs(occ.getCenterOfMass(2, f)[axis] - val) < 1e-9 * L]
            gmsh.model.addPhysicalGroup(2, pick, 3 + k, name=name)
        core = [abs(t) for _, t in gmsh.model.getBoundary([(3, t) for t in inner])]
        refine_near(gmsh, core, h_in, h_out, 4 * R)

    gmsh_on_rank0(build, path, 3)


# ----------------------------------------------------------------------------- scenes
CYST_SCENE = """format = 1
[scene]
name = "cyst3d"
mesh = "{mesh}"
dimension = 3

[analysis]
kind = "static"
load_steps = 1

[[material]]
name = "bone"
regions = ["bone"]
model = "isotropic"
E = {E}
nu = {nu}
sigma_t = 1.0e8

[[dirichlet]]
boundary = "outer"
value = [0.0, 0.0, 0.0]

[fracture]
criterion = "tension"

[neoplasm]
kind = "cyst"
region = "cyst"
host = ["bone"]
t_end = {t_end}
dt = {dt}
mechanics_every = {every}

[neoplasm.cyst]
beta = 1.28e-10
C_minus = 1.0

[output]
directory = "{out}"
fields_every = 0
"""

BLOCK_SCENE = """format = 1
[scene]
name = "inclusion3d"
mesh = "{mesh}"
dimension = 3

[analysis]
kind = "static"
load_steps = 1

[[material]]
name = "bone"
regions = ["block"]
model = "isotropic"
E = {E}
nu = {nu}

[[material]]
name = "tumour"
regions = ["tumour"]
model = "isotropic"
E = {E_i}
nu = {nu_i}
formulation = "{formulation}"

[[dirichlet]]
boundary = "x0"
value = [0.0, "free", "free"]

[[dirichlet]]
boundary = "y0"
value = ["free", 0.0, "free"]

[[dirichlet]]
boundary = "z0"
value = ["free", "free", 0.0]

[[traction]]
boundary = "x1"
value = [{sigma0}, 0.0, 0.0]

[neoplasm]
kind = "tumour"
region = "tumour"
host = ["block"]
t_end = 1.0
dt = 1.0
remesh_every = 0

[neoplasm.tumour]
K_B = 0.0

[output]
directory = "{out}"
fields_every = 0
"""


def lame_sphere_clamped(r, R, b, p, E, nu):
    """u_r of a thick sphere R < r < b, pressure p at r = R, u = 0 at r = b."""
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    B = p / (4 * mu / R**3 + (3 * lam + 2 * mu) / b**3)
    return -B / b**3 * r + B / r**2


def lame_sphere_clamped_hoop(R, b, p, E, nu):
    """σ_θθ at the inner wall r = R of the same thick sphere:
    (3λ+2μ) A + 2μ B / R³ with A = −B/b³."""
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    B = p / (4 * mu / R**3 + (3 * lam + 2 * mu) / b**3)
    return -(3 * lam + 2 * mu) * B / b**3 + 2 * mu * B / R**3


def eshelby_sphere(E_m, nu_m, E_i, nu_i, sigma0):
    """Uniform stress tensor inside a spherical inclusion, remote uniaxial σ_xx = σ0."""
    K_m, mu_m = E_m / (3 * (1 - 2 * nu_m)), E_m / (2 * (1 + nu_m))
    K_i, mu_i = E_i / (3 * (1 - 2 * nu_i)), E_i / (2 * (1 + nu_i))
    alpha = (1 + nu_m) / (3 * (1 - nu_m))
    beta = 2 * (4 - 5 * nu_m) / (15 * (1 - nu_m))
    theta_inf = sigma0 / (3 * K_m)
    e_inf = np.diag([2.0, -1.0, -1.0]) * sigma0 / 3 / (2 * mu_m)
    theta = theta_inf * K_m / (K_m + alpha * (K_i - K_m))
    e = e_inf * mu_m / (mu_m + beta * (mu_i - mu_m))
    return K_i * theta * np.eye(3) + 2 * mu_i * e


def _wall_ratio(result, R: float, f: float, b: float) -> np.ndarray:
    """u_r / u_Lamé at the owned wall vertices (gathered on every rank)."""
    integ = result.integrator
    model = integ.model
    wall = max(model.facet_tags.values)  # the wall group has the largest tag
    V = model.V
    blocks = fem.locate_dofs_topological(V, 2, model.facet_tags.find(wall))
    blocks = blocks[blocks < V.dofmap.index_map.size_local]
    x = V.tabulate_dof_coordinates()[blocks]
    r = np.linalg.norm(x, axis=1)
    u = integ.u.x.array.reshape(-1, 3)[blocks]
    ratio = np.einsum("ij,ij->i", u, x) / r / lame_sphere_clamped(r, R, b, f, E_BONE, NU_BONE)
    return np.concatenate(MPI.COMM_WORLD.allgather(ratio))


def _inclusion_mean_stress(result, tag: int) -> np.ndarray:
    """Mean stress tensor over the cells of ``tag``."""
    integ = result.integrator
    model = integ.model
    model.update_nodal_volumetric(integ.u)
    s = model.stress_expression(integ.u)
    dx = model.dx(tag)
    comm = MPI.COMM_WORLD
    vol = comm.allreduce(
        fem.assemble_scalar(fem.form(fem.Constant(model.mesh, 1.0) * dx)), op=MPI.SUM
    )
    out = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = comm.allreduce(fem.assemble_scalar(fem.form(s[i, j] * dx)), op=MPI.SUM)
    return out / vol


def _shared_dir(factory, name: str) -> Path:
    comm = MPI.COMM_WORLD
    return Path(comm.bcast(str(factory.mktemp(name)) if comm.rank == 0 else None, root=0))


@pytest.fixture(scope="module")
def ball_mesh(tmp_path_factory):
    d = _shared_dir(tmp_path_factory, "coupling3d")
    ball_with_core(d / "ball.msh", B_BALL, R0_CYST, 4e-4, 4e-3)
    return d / "ball.msh"


# ----------------------------------------------------------------------------- unit checks
def test_sphere_surface_is_closed_and_outward():
    p, t = sphere_surface((1.0, 2.0, 3.0), 0.5, 0.05)
    assert np.allclose(np.linalg.norm(p - [1.0, 2.0, 3.0], axis=1), 0.5)
    e = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    assert np.all(counts == 2)  # closed, manifold
    assert len(p) - len(e) // 2 + len(t) == 2  # Euler characteristic of a sphere
    v = surface_volume(p, t)
    assert 0.98 < v / (4 / 3 * math.pi * 0.5**3) < 1.0  # inscribed polyhedron, outward


def test_neoplasm_outside_its_region_is_refused(ball_mesh):
    """A cyst crossing the outer surface, or grazing it, is refused naming the group and
    the distance; an inside one is embedded with its volume."""
    geo = read_host_geometry3d(ball_mesh) if MPI.COMM_WORLD.rank == 0 else None
    R, h = 0.003, 0.001
    p, t = sphere_surface((0.0, 0.0, B_BALL - 0.002), R, h)
    with pytest.raises(CouplingError, match=r'"bone": it reaches 0\.00[01]\d* m beyond'):
        build_host_mesh3d(geo, "cyst", ("bone",), p, t, True, h, None)
    # 0.7 mm from the sphere r = b, less from its facets: closer than h/4 = 1 mm
    p, t = sphere_surface((0.0, 0.0, B_BALL - R - 7e-4), R, 0.004)
    with pytest.raises(CouplingError, match=r'"bone": it comes within 0\.000[4-7]\d* m of its'):
        build_host_mesh3d(geo, "cyst", ("bone",), p, t, True, 0.004, None)
    p, t = sphere_surface((0.0, 0.0, 0.05), R, h)  # 27 mm from the ball, less to its facets
    with pytest.raises(CouplingError, match=r'not inside the cell group "bone": it lies 0\.02[67]'):
        build_host_mesh3d(geo, "cyst", ("bone",), p, t, True, h, None)
    p, t = sphere_surface((0.001, 0.0, 0.0), R, h)
    hm = build_host_mesh3d(geo, "cyst", ("bone",), p, t, False, h, None)
    assert hm.cell_groups == ("bone", "cyst") and hm.wall == "cyst_wall"
    assert set(hm.facet_groups) == {"outer", "cyst_wall"}
    assert hm.neoplasm_area == pytest.approx(surface_volume(p, t), rel=1e-9)


# ----------------------------------------------------------------------------- coupled runs
def _cyst_lame_run(mesh: Path, tmp: Path) -> np.ndarray:
    """Grow the cyst for a year in the clamped ball; u_r / Lamé on the cavity wall."""
    out = tmp / "out"
    res = run_text(
        CYST_SCENE.format(
            mesh=mesh, E=E_BONE, nu=NU_BONE, t_end=YEAR, dt=YEAR / 12, every=0, out=out
        ),
        tmp,
        out,
    )
    assert res.status == "converged", res.summary.get("message")
    g = read_csv(out / "growth.csv")
    R, f = g["equivalent_radius"][-1], g["pressure"][-1]
    assert R > 2 * g["equivalent_radius"][0] and f > 1.0
    an = res.summary["coupling"]["analyses"]
    assert len(an) == 1 and an[0]["wall_group"] == "cyst_wall"
    assert an[0]["cavity_pressure_Pa"] == f
    # the embedded geodesic sphere (vertices on r = R) holds slightly less than 4/3 pi R^3
    assert an[0]["neoplasm_volume_in_bone"] == pytest.approx(4 / 3 * math.pi * R**3, rel=0.01)
    s = json.loads((out / "summary.json").read_text())
    assert s["growth"]["units"]["volume"] == "m^3"
    # the [fracture] check in a coupled 3D scene: the largest tension risk lies at the
    # wall, where sigma_1 is the Lamé hoop stress, with the crack plane normal to the wall
    # (its normal tangent to the sphere).  Its value is that of the largest single cell
    # on the coarse geodesic wall (edges R/15), whose kinks concentrate the P1 stress:
    # measured 1.49 times the smooth hoop stress (u_r on the wall: within 2.3 %); the
    # bound checks the plumbing, the converging check is Goodier's cavity
    # (test_fracture_scene3d.py).
    hoop = lame_sphere_clamped_hoop(R, B_BALL, f, E_BONE, NU_BONE)
    assert 1.0 < an[0]["max_risk"] * 1.0e8 / hoop < 1.6, (an[0]["max_risk"], hoop)
    x = np.asarray(an[0]["max_risk_location"])
    assert np.linalg.norm(x) == pytest.approx(R, rel=0.1)
    assert abs(float(np.dot(an[0]["max_risk_crack_normal"], x / np.linalg.norm(x)))) < 0.3
    assert an[0]["max_risk_crack_direction"] is None
    return _wall_ratio(res, R, f, B_BALL)


@pytest.mark.serial
def test_cyst_cavity_3d_matches_lame_sphere(ball_mesh, tmp_shared_path):
    """Coarse: wall edge R/15 (the scene mesh's size at the cyst), 61k tetrahedra.
    Serial session only (a long verification case): the parallel 3D coupled run is
    test_coupled_3d_same_on_one_and_three_ranks (a cyst scene on 1 and 3 ranks) and,
    in-process on 2 ranks, test_growing_tumour_3d_is_embedded_at_its_volume."""
    ratio = _cyst_lame_run(ball_mesh, tmp_shared_path)
    assert len(ratio) > 500
    # P1 tetrahedra are too stiff at this size: measured mean 0.977 (0.958 ... 0.996)
    assert np.mean(ratio) == pytest.approx(1.0, abs=0.03)
    assert np.abs(ratio - 1).max() < 0.06


@pytest.mark.slow
def test_cyst_cavity_3d_matches_lame_sphere_fine(tmp_shared_path):
    """Fine: wall edge R/32 (the cyst's smallest), 262k tetrahedra: within 1 %."""
    mesh = tmp_shared_path / "ball_fine.msh"
    ball_with_core(mesh, B_BALL, R0_CYST, 1.5e-4, 4e-3)
    ratio = _cyst_lame_run(mesh, tmp_shared_path)
    assert len(ratio) > 5000
    # measured mean 0.9914 (0.9867 ... 0.9967); 334 s serial (811 s on a busier machine)
    assert np.mean(ratio) == pytest.approx(1.0, abs=0.01)
    assert np.abs(ratio - 1).max() < 0.015


@pytest.mark.serial
def test_soft_inclusion_3d_matches_eshelby(tmp_shared_path):
    """Eshelby's soft sphere in a cube under uniaxial stress.  Serial session only (a long
    verification case; its parallel coverage: test_cyst_cavity_3d_matches_lame_sphere)."""
    L, R, sigma0 = 0.02, 0.002, 1.0e6
    E_i, nu_i = E_BONE / 10, 0.3
    mesh, out = tmp_shared_path / "cube.msh", tmp_shared_path / "out"
    cube_with_inclusion(mesh, L, R, R / 8, L / 3)
    res = run_text(
        BLOCK_SCENE.format(
            mesh=mesh,
            E=E_BONE,
            nu=NU_BONE,
            E_i=E_i,
            nu_i=nu_i,
            formulation="displacement",
            sigma0=sigma0,
            out=out,
        ),
        tmp_shared_path,
        out,
    )
    assert res.status == "converged", res.summary.get("message")
    an = res.summary["coupling"]["analyses"][0]
    assert an["wall_group"] == "tumour_wall"
    s = _inclusion_mean_stress(res, 2)
    ref = eshelby_sphere(E_BONE, NU_BONE, E_i, nu_i, sigma0)
    assert ref[0, 0] < 0.2 * sigma0  # the soft sphere carries much less than sigma0
    # wall edge R/8: measured sigma_xx 0.1863 sigma0 (Eshelby 0.1919: -0.56 % of sigma0,
    # -2.9 % of itself), sigma_yy = sigma_zz +0.05 % of sigma0, shear < 3e-5 sigma0
    np.testing.assert_allclose(s, ref, atol=0.01 * sigma0)
    assert s[0, 0] == pytest.approx(ref[0, 0], rel=0.04)


def test_growing_tumour_3d_is_embedded_at_its_volume(tmp_shared_path):
    """A tumour growing in the block (remeshed every step): each analysis's mesh holds the
    tumour's current volume (growth.csv) as tumour cells."""
    L, R = 0.01, 0.002
    mesh, out = tmp_shared_path / "cube.msh", tmp_shared_path / "out"
    cube_with_inclusion(mesh, L, R, R / 3, L / 2)
    text = BLOCK_SCENE.format(
        mesh=mesh,
        E=E_BONE,
        nu=NU_BONE,
        E_i=1e6,
        nu_i=0.45,
        formulation="displacement",
        sigma0=1e6,
        out=out,
    )
    text = text.replace(
        "t_end = 1.0\ndt = 1.0\nremesh_every = 0",
        "t_end = 0.5\ndt = 0.25\nremesh_every = 1\nmechanics_every = 1",
    ).replace("K_B = 0.0", 'K_B = "2.0*(u_c - 0.5)"\nD_c = 4.0e-6')
    res = run_text(text, tmp_shared_path, out)
    assert res.status == "converged", res.summary.get("message")
    g = read_csv(out / "growth.csv")
    an = res.summary["coupling"]["analyses"]
    assert [a["growth_step"] for a in an] == [1, 2]
    assert g["volume"][-1] > 1.05 * g["volume"][0]
    for a in an:
        assert a["wall_group"] == "tumour_wall" and a["cavity_pressure_Pa"] is None
        v = g["volume"][a["growth_step"]]
        assert a["neoplasm_volume_in_bone"] == pytest.approx(v, rel=1e-6)


def test_coupled_3d_check_refuses_a_neoplasm_outside_its_group(ball_mesh, tmp_shared_path):
    """With host = [] the cyst must stay inside its own region, which the sphere of the
    region's volume does not: a SceneError on [neoplasm] region, before anything runs."""
    text = CYST_SCENE.format(
        mesh=ball_mesh, E=E_BONE, nu=NU_BONE, t_end=YEAR, dt=YEAR, every=0, out="unused"
    )
    scene_file = tmp_shared_path / "scene.toml"
    if MPI.COMM_WORLD.rank == 0:
        scene_file.write_text(text.replace('host = ["bone"]', "host = []"))
    MPI.COMM_WORLD.barrier()
    from bonecontact.runners.coupled import check_coupled

    with pytest.raises(SceneError, match=r'cell group "cyst"'):
        check_coupled(load_scene(scene_file))


def _rank_atol(out: Path, column: str, values: np.ndarray) -> float:
    """The absolute tolerance of a rank comparison: 1e-14 of the column's magnitude, but a
    load or a support's reaction (round-off of a self-equilibrated cavity pressure, ~1e-19
    N) against 1e-10 of the wall's pressure force (moments: times the body's radius)."""
    if not column.startswith(("load_", "reaction_")):
        return 1e-14 * float(np.nan_to_num(np.abs(values)).max())
    g = read_csv(out / "growth.csv")
    force = (
        float(np.nanmax(np.abs(g["pressure"]))) * 4 * math.pi * g["equivalent_radius"].max() ** 2
    )
    return 1e-10 * force * (B_BALL if re.search(r"_m[xyz]$", column) else 1.0)


@pytest.mark.serial
def test_coupled_3d_same_on_one_and_three_ranks(ball_mesh, tmp_path):
    """The command on 1 and 3 ranks: growth.csv and history.csv agree to 1e-10 (measured
    2.6e-13: the host mesh is rebuilt from rank-independent input; 2 ranks: this module's
    tests in the 2-rank session, against the same references)."""
    scene = tmp_path / "cyst.toml"
    scene.write_text(
        CYST_SCENE.format(
            mesh=ball_mesh,
            E=E_BONE,
            nu=NU_BONE,
            t_end=YEAR / 4,
            dt=YEAR / 12,
            every=0,
            out=tmp_path / "unused",
        )
    )
    outs = []
    for n in (1, 3):
        out = tmp_path / f"r{n}"
        r = run_cli_scene(scene, out, n, env=ENV)
        assert r.returncode == 0, r.stderr[-3000:]
        outs.append(out)
    for o in outs[1:]:
        for name in ("growth.csv", "history.csv"):
            a, b = read_csv(outs[0] / name), read_csv(o / name)
            for k in a:
                np.testing.assert_allclose(
                    a[k],
                    b[k],
                    rtol=1e-10,
                    atol=_rank_atol(outs[0], k, a[k]),
                    equal_nan=True,
                    err_msg=f"{name}:{k}",
                )
    s = [json.loads((o / "summary.json").read_text()) for o in outs]
    assert len({a["coupling"]["analyses"][0]["cells"] for a in s}) == 1
