"""The [fracture] initiation check of a 3D scene against Goodier's spherical cavity.

An octant [0, W]³ of a block with a spherical cavity of radius R = W/10 at the origin
(symmetry planes x = 0, y = 0, z = 0 held normal to themselves), uniaxial tension σ on
z = W; cortical bone E = 17 GPa, ν = 0.3, σ_t = 133 MPa.  Goodier (1933): the largest
stress is the hoop stress σ_zz on the cavity's equator,
σ_max = (27 − 15ν) / (2(7 − 5ν)) σ = 2.045 σ for ν = 0.3 (the finite block, R/W = 0.1,
changes it by O((R/W)³)).  So the tension risk is largest at the equator (z ≈ 0,
x² + y² ≈ R²) with the value 2.045 σ/σ_t, and the crack plane's normal (the σ₁ axis)
is the load axis z.  The mesh is graded from R/12 at the cavity (31k dofs).  The largest
single cell value on a faceted wall overshoots the smooth value (the facets' kinks; the
2D coupled cyst test sees 8–10 %): measured +5.5 % at R/12 and +8.6 % at R/20, so the
value is asserted within −2 … +10 % — a check of the 3D risk, its place and its
direction, not a converged stress concentration.  history.csv gets
``max_risk_z``; 1, 2 and 3 ranks give the same maximum.  A 2D ``[[crack]]`` (a polyline)
or ``initiate``/``propagate`` in a 3D scene is refused naming the table and key (3D
cracks: test_crack_scene3d.py).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import run_serial_on_rank0
from coupled_support import gmsh_on_rank0, read_csv, refine_near, run_text

from bonecontact.scene import SceneError, load_scene

W, R = 10.0e-3, 1.0e-3  # m
NU, SIGMA, SIGMA_T = 0.3, 20.0e6, 133.0e6
SCF = (27 - 15 * NU) / (2 * (7 - 5 * NU))  # Goodier

SCENE = """format = 1
[scene]
name = "goodier_cavity"
mesh = "{mesh}"
dimension = 3
[analysis]
kind = "static"
load_steps = 1
[[material]]
name = "cortical"
regions = ["block"]
model = "isotropic"
E = 17.0e9
nu = {nu}
sigma_t = {sigma_t}
[[dirichlet]]
boundary = "sym_x"
value = [0.0, "free", "free"]
[[dirichlet]]
boundary = "sym_y"
value = ["free", 0.0, "free"]
[[dirichlet]]
boundary = "sym_z"
value = ["free", "free", 0.0]
[[traction]]
boundary = "top"
value = [0.0, 0.0, {sigma}]
[fracture]
criterion = "tension"
{extra}
[output]
fields_every = 1
"""


def _octant(gmsh) -> None:
    occ = gmsh.model.occ
    box = occ.addBox(0, 0, 0, W, W, W)
    ball = occ.addSphere(0, 0, 0, R)
    out, _ = occ.cut([(3, box)], [(3, ball)])
    occ.synchronize()
    vol = [t for d, t in out if d == 3]
    gmsh.model.addPhysicalGroup(3, vol, 1, name="block")
    faces = [t for _, t in gmsh.model.getBoundary([(3, v) for v in vol], oriented=False)]
    com = {f: gmsh.model.occ.getCenterOfMass(2, f) for f in faces}
    tol = 1e-9
    groups = {
        "sym_x": [f for f in faces if abs(com[f][0]) < tol],
        "sym_y": [f for f in faces if abs(com[f][1]) < tol],
        "sym_z": [f for f in faces if abs(com[f][2]) < tol],
        "top": [f for f in faces if abs(com[f][2] - W) < tol],
    }
    cavity = [f for f in faces if max(abs(c) for c in com[f]) < R]
    for k, (name, fs) in enumerate(groups.items()):
        gmsh.model.addPhysicalGroup(2, fs, 2 + k, name=name)
    refine_near(gmsh, cavity, R / 12, W / 5, 3 * W)


@pytest.fixture(scope="module")
def cavity_run(tmp_path_factory) -> Path:
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("goodier")) if comm.rank == 0 else None))
    gmsh_on_rank0(_octant, d / "octant.msh", 3)
    text = SCENE.format(mesh=d / "octant.msh", nu=NU, sigma=SIGMA, sigma_t=SIGMA_T, extra="")
    res = run_text(text, d, d / "out")
    assert res.status == "converged"
    return d / "out"


def test_risk_is_goodier_at_the_equator(cavity_run: Path) -> None:
    fr = json.loads((cavity_run / "summary.json").read_text())["fracture"]
    expected = SCF * SIGMA / SIGMA_T
    assert 0.98 * expected < fr["max_risk"] < 1.10 * expected
    x, y, z = fr["location"]
    assert math.hypot(x, y) == pytest.approx(R, abs=R / 6)  # within a cell of the wall
    assert z < R / 4  # at the equator
    assert abs(fr["crack_normal"][2]) > math.cos(math.radians(5.0))  # normal to the load
    assert fr["crack_direction"] is None and fr["mode"] == "tension"
    assert fr["initiated"] is False  # 0.31 < 1
    hist = read_csv(cavity_run / "history.csv")
    assert hist["max_risk"][-1] == pytest.approx(fr["max_risk"], rel=1e-12)
    assert hist["max_risk_z"][-1] == pytest.approx(z, abs=1e-15)


def test_same_risk_on_any_rank_count(cavity_run: Path) -> None:
    """The distributed run against the serial run of the same scene and mesh: the risk
    maximum, its cell midpoint, the crack normal and history.csv's columns to 1e-10."""
    if MPI.COMM_WORLD.size == 1:
        pytest.skip("compares a distributed run with a serial one")
    ser = run_serial_on_rank0(cavity_run.parent / "scene.toml", cavity_run.parent / "ser")
    ser_dir = cavity_run.parent / "ser"
    if ser is not None:
        assert ser.status == "converged"
    MPI.COMM_WORLD.barrier()
    got = json.loads((cavity_run / "summary.json").read_text())["fracture"]
    ref = json.loads((ser_dir / "summary.json").read_text())["fracture"]
    assert got["max_risk"] == pytest.approx(ref["max_risk"], rel=1e-10)
    np.testing.assert_allclose(got["location"], ref["location"], rtol=0, atol=1e-10 * W)
    np.testing.assert_allclose(got["crack_normal"], ref["crack_normal"], rtol=0, atol=1e-10)
    assert got["initiated"] == ref["initiated"] and got["mode"] == ref["mode"]
    h_got, h_ref = read_csv(cavity_run / "history.csv"), read_csv(ser_dir / "history.csv")
    for key, scale in (("max_risk", 1.0), ("max_risk_x", W), ("max_risk_y", W), ("max_risk_z", W)):
        np.testing.assert_allclose(h_got[key], h_ref[key], rtol=1e-10, atol=1e-10 * scale)


@pytest.mark.parametrize(
    ("extra", "table", "key"),
    [
        ("propagate = true\nincrement = 1e-3", "[fracture]", "propagate"),
        ("initiate = true", "[fracture]", "initiate"),
        (
            '[[crack]]\npoints = [[0.002, 0.0], [0.003, 0.0]]\nregion = "block"',
            "[[crack]]",
            "points",
        ),
    ],
)
def test_what_3d_scenes_do_not_run_is_refused(
    tmp_path: Path, extra: str, table: str, key: str | None
) -> None:
    (tmp_path / "octant.msh").touch()  # read when the scene runs, not here
    path = tmp_path / "scene.toml"
    text = SCENE.format(mesh="octant.msh", nu=NU, sigma=SIGMA, sigma_t=SIGMA_T, extra=extra)
    path.write_text(text)
    with pytest.raises(SceneError) as err:
        load_scene(path)
    assert err.value.table.startswith(table) and err.value.key == key
