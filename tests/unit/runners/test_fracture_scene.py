"""The ``[fracture]`` initiation check through a scene and the ``bonecontact`` command.

Kirsch: a plate (width 2, height 4) with a central hole of radius R = 0.05 (1/40 of the
width) under uniaxial tension σ, as its symmetric quarter (u_x = 0 on x = 0, u_y = 0 on
y = 0).  The stress concentration at the hole edge on the axis normal to the load is 3
(Heywood's finite-width value 3.0075), so the tension risk σ₁/σ_t peaks there at 3σ/σ_t.
The static analysis ramps σ over two load steps to 3σ/σ_t = 1.128: the risk is half
of that at t = 0.5 (linear elasticity) and initiation (risk ≥ 1) happens at t = 1.
The same numbers on 1, 2 and 3 ranks; a crack outside its region is exit 2 naming the key.
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.serial

BIN = Path(sys.executable).parent
ENV = {**os.environ, "OMP_NUM_THREADS": "1"}
R, W, H = 0.05, 1.0, 2.0  # hole radius, half-width, half-height (m)
SIGMA, SIGMA_T = 50.0e6, 133.0e6  # Pa

SCENE = """format = 1
[scene]
name = "kirsch"
mesh = "{mesh}"
dimension = 2
[analysis]
kind = "static"
load_steps = 2
[[material]]
name = "cortical"
regions = ["plate"]
model = "isotropic"
E = 17.0e9
nu = 0.3
sigma_t = {sigma_t}
[[dirichlet]]
boundary = "left"
value = [0.0, "free"]
[[dirichlet]]
boundary = "bottom"
value = ["free", 0.0]
[[traction]]
boundary = "top"
value = [0.0, {sigma}]
[fracture]
criterion = "tension"
[output]
fields_every = 1
{extra}"""


def _mesh(path: Path) -> None:
    """Quarter plate [0, W] × [0, H] without the quarter disc of radius R at the origin,
    graded from R/80 at the hole edge."""
    import gmsh

    gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        occ = gmsh.model.occ
        rect = occ.addRectangle(0.0, 0.0, 0.0, W, H)
        disc = occ.addDisk(0.0, 0.0, 0.0, R, R)
        (surf,), _ = occ.cut([(2, rect)], [(2, disc)])
        occ.synchronize()
        edges = [abs(c) for _, c in gmsh.model.getBoundary([surf], oriented=False)]
        com = {e: occ.getCenterOfMass(1, e) for e in edges}
        pick = {
            "left": [e for e in edges if abs(com[e][0]) < 1e-9],
            "bottom": [e for e in edges if abs(com[e][1]) < 1e-9],
            "top": [e for e in edges if abs(com[e][1] - H) < 1e-9],
            "hole": [e for e in edges if 0 < com[e][0] < R and 0 < com[e][1] < R],
        }
        gmsh.model.addPhysicalGroup(2, [surf[1]], 1, name="plate")
        for k, (name, es) in enumerate(pick.items()):
            assert len(es) == 1, (name, es)
            gmsh.model.addPhysicalGroup(1, es, 2 + k, name=name)
        dist = gmsh.model.mesh.field.add("Distance")
        gmsh.model.mesh.field.setNumbers(dist, "CurvesList", pick["hole"])
        thr = gmsh.model.mesh.field.add("Threshold")
        gmsh.model.mesh.field.setNumber(thr, "InField", dist)
        gmsh.model.mesh.field.setNumber(thr, "SizeMin", R / 80)
        gmsh.model.mesh.field.setNumber(thr, "SizeMax", 0.1)
        gmsh.model.mesh.field.setNumber(thr, "DistMin", 0.0)
        gmsh.model.mesh.field.setNumber(thr, "DistMax", 1.0)
        gmsh.model.mesh.field.setAsBackgroundMesh(thr)
        for key in ("MeshSizeFromPoints", "MeshSizeFromCurvature", "MeshSizeExtendFromBoundary"):
            gmsh.option.setNumber(f"Mesh.{key}", 0)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


@pytest.fixture(scope="module")
def mesh(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("kirsch") / "kirsch.msh"
    _mesh(path)
    return path


def _run(scene: Path, out: Path, n: int = 1) -> subprocess.CompletedProcess:
    cmd = [str(BIN / "bonecontact"), "run", str(scene), "-q", "-o", str(out)]
    if n > 1:
        cmd = [str(BIN / "mpiexec"), "-n", str(n), *cmd]
    return subprocess.run(
        cmd, capture_output=True, text=True, timeout=600, env=ENV, stdin=subprocess.DEVNULL
    )


def _scene(tmp_path: Path, mesh: Path, extra: str = "") -> Path:
    path = tmp_path / "kirsch.toml"
    path.write_text(SCENE.format(mesh=mesh, sigma=SIGMA, sigma_t=SIGMA_T, extra=extra))
    return path


@pytest.fixture(scope="module")
def runs(mesh: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[int, Path]:
    tmp = tmp_path_factory.mktemp("kirsch_runs")
    scene = _scene(tmp, mesh)
    out = {}
    for n in (1, 2, 3):
        res = _run(scene, tmp / f"out{n}", n)
        assert res.returncode == 0, res.stderr
        out[n] = tmp / f"out{n}"
    return out


def _history(out: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(open(out / "history.csv")))


def test_max_risk_is_kirsch_at_the_hole_edge(runs: dict[int, Path]) -> None:
    rows = _history(runs[1])
    assert [float(r["time"]) for r in rows] == [0.0, 0.5, 1.0]
    risks = [float(r["max_risk"]) for r in rows]
    assert risks[0] == 0.0
    assert risks[2] == pytest.approx(3 * SIGMA / SIGMA_T, rel=2e-2)
    assert risks[1] == pytest.approx(0.5 * risks[2], rel=1e-10)  # linear in the load
    x, y = float(rows[2]["max_risk_x"]), float(rows[2]["max_risk_y"])
    assert (x**2 + y**2) ** 0.5 == pytest.approx(R, abs=R / 40)  # a cell at the hole edge
    assert y < R / 20  # on the axis normal to the load
    info = json.loads((runs[1] / "summary.json").read_text())["fracture"]
    assert info["max_risk"] == pytest.approx(risks[2], rel=1e-12)
    assert info["location"] == pytest.approx([x, y], rel=1e-12)
    assert info["time"] == 1.0 and info["initiated"] is True and info["initiation_time"] == 1.0
    assert abs(info["crack_direction"][0]) > 0.99  # a crack would run normal to the load
    assert "fracture_risk" in (runs[1] / "fields.xdmf").read_text()


@pytest.mark.parametrize("n", [2, 3])
def test_ranks_give_the_serial_numbers(runs: dict[int, Path], n: int) -> None:
    serial, parallel = _history(runs[1]), _history(runs[n])
    for a, b in zip(serial, parallel, strict=True):
        for key in ("max_risk", "max_risk_x", "max_risk_y"):
            assert float(b[key]) == pytest.approx(float(a[key]), rel=1e-8, abs=1e-12)


def test_crack_leaving_the_mesh_is_exit_2(mesh: Path, tmp_path: Path) -> None:
    crack = '[[crack]]\nname = "c"\npoints = [[0.5, 1.0], [1.5, 1.0]]\nregion = "plate"\n'
    res = _run(_scene(tmp_path, mesh, crack), tmp_path / "out")
    assert res.returncode == 2, res.stderr
    assert '[[crack]] #1 "c", key "points"' in res.stderr and "leaves the mesh" in res.stderr
