"""Automatic crack initiation (``[fracture] initiate = true``) against Kirsch's solution.

A plate [−W, W] × [−H, H] (W = 20 mm, H = 2W) with a central hole of radius R = 1 mm
(1/40 of the width) under uniaxial tension σ = 64 MPa on its top edge (u_y = 0 on the
bottom edge, u_x = 0 on its middle 0.4 mm: the uniform uniaxial state satisfies both up
to ν σ/E times 0.2 mm), cortical bone (E = 17 GPa, ν = 0.3, σ_t = 133 MPa), plane
strain, static analysis in four load steps (load factor t = 0.25 … 1).

Kirsch: the stress concentration at the hole edge on the axis normal to the load is 3
(Heywood's finite-width value 3.0075), so the tension risk max σ₁/σ_t reaches 1 first
there, at the load factor σ_t/(3σ) = 0.6927: between steps 2 (t = 0.5) and 3 (t = 0.75).
The run must insert the crack at step 3, with the interpolated load factor within 2 % of
σ_t/(3σ) (the risk is linear in the load: the interpolation between t = 0.5 and 0.75 is
exact for the discrete problem; measured −0.8 %: the P1 cell stresses are the stress
a third of an element inside the edge), at the hole edge on the line through the centre
normal to the load (within one element), running normal to the load (within 3°), away
from the hole, four elements long.  The new edge crack of length a at the hole edge then
has K_I = F σ√(πa) with Bowie's F between F(a/R = 0.1) = 2.73 and F(0) = 3.39 (a/R =
0.05 here; measured F = 2.97).  The same insertion on 2 and 3 ranks.  Bad initiation
input is exit 2 naming the key, from ``bonecontact run`` and ``bonecontact check``: the
command's entry point called in this process (``bonecontact.runners.cli.main``: the same
parsing, checks, message and exit status; a new process cost 2 s of start-up a case, the
exit status of the real command is test_cli.py's), the runs in a new process each.
"""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bonecontact.runners.cli import main

pytestmark = pytest.mark.serial

BIN = Path(sys.executable).parent
ENV = {**os.environ, "OMP_NUM_THREADS": "1"}
R, W, H, PIN = 1.0e-3, 20.0e-3, 40.0e-3, 0.2e-3  # m
SIGMA, SIGMA_T = 64.0e6, 133.0e6  # Pa
T_INIT = SIGMA_T / (3 * SIGMA)  # Kirsch: the load factor at which the risk reaches 1

SCENE = """format = 1
[scene]
name = "kirsch_initiation"
mesh = "{mesh}"
dimension = 2
[analysis]
kind = "static"
load_steps = 4
[[material]]
name = "cortical"
regions = ["plate"]
model = "isotropic"
E = 17.0e9
nu = 0.3
sigma_t = {sigma_t}
[[dirichlet]]
boundary = "bottom"
value = ["free", 0.0]
[[dirichlet]]
boundary = "pin"
value = [0.0, 0.0]
[[traction]]
boundary = "top"
value = [0.0, {sigma}]
[fracture]
criterion = "tension"
initiate = true
{extra}
[output]
fields_every = 1
{crack}"""


def _mesh(path: Path) -> None:
    """The plate with its hole; facet groups bottom (two pieces), pin (the middle of the
    bottom edge), top, sides, hole; graded from R/80 at the hole edge."""
    import gmsh

    gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        occ = gmsh.model.occ
        corners = [(-W, -H), (-PIN, -H), (PIN, -H), (W, -H), (W, H), (-W, H)]
        p = [occ.addPoint(x, y, 0) for x, y in corners]
        lines = [occ.addLine(p[i], p[(i + 1) % 6]) for i in range(6)]
        circle = occ.addCircle(0, 0, 0, R)
        surf = occ.addPlaneSurface([occ.addCurveLoop(lines), occ.addCurveLoop([circle])])
        occ.synchronize()
        gmsh.model.addPhysicalGroup(2, [surf], 1, name="plate")
        groups = {
            "bottom": [lines[0], lines[2]],
            "pin": [lines[1]],
            "top": [lines[4]],
            "sides": [lines[3], lines[5]],
            "hole": [circle],
        }
        for k, (name, curves) in enumerate(groups.items()):
            gmsh.model.addPhysicalGroup(1, curves, 2 + k, name=name)
        fld = gmsh.model.mesh.field
        dist = fld.add("Distance")
        fld.setNumbers(dist, "CurvesList", [circle])
        fld.setNumber(dist, "Sampling", 400)
        thr = fld.add("Threshold")
        fld.setNumber(thr, "InField", dist)
        fld.setNumber(thr, "SizeMin", R / 80)
        fld.setNumber(thr, "SizeMax", W / 10)
        fld.setNumber(thr, "DistMin", 0.0)
        fld.setNumber(thr, "DistMax", W)
        fld.setAsBackgroundMesh(thr)
        for key in ("MeshSizeFromPoints", "MeshSizeFromCurvature", "MeshSizeExtendFromBoundary"):
            gmsh.option.setNumber(f"Mesh.{key}", 0)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


@pytest.fixture(scope="module")
def mesh(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("kirsch_initiation") / "plate.msh"
    _mesh(path)
    return path


def _scene(folder: Path, mesh: Path, extra: str = "", crack: str = "") -> Path:
    path = folder / "kirsch_initiation.toml"
    text = SCENE.format(mesh=mesh, sigma=SIGMA, sigma_t=SIGMA_T, extra=extra, crack=crack)
    path.write_text(text)
    return path


def _run(scene: Path, out: Path, n: int = 1) -> subprocess.CompletedProcess:
    cmd = [str(BIN / "bonecontact"), "run", str(scene), "-q", "-o", str(out)]
    return _spawn(cmd, n)


def _here(args: list[str], capsys: pytest.CaptureFixture) -> subprocess.CompletedProcess:
    """``bonecontact <args>`` through the command's entry point in this process (serial):
    its exit status and what it wrote (as :func:`_spawn`'s, without a new interpreter)."""
    capsys.readouterr()
    status = main(args)
    out, err = capsys.readouterr()
    return subprocess.CompletedProcess(["bonecontact", *args], status, out, err)


def _spawn(cmd: list[str], n: int = 1) -> subprocess.CompletedProcess:
    if n > 1:
        cmd = [str(BIN / "mpiexec"), "-n", str(n), *cmd]
    return subprocess.run(
        cmd, capture_output=True, text=True, timeout=600, env=ENV, stdin=subprocess.DEVNULL
    )


def _initiation(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())["fracture"]


@pytest.fixture(scope="module")
def serial(mesh: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("kirsch_initiation_serial")
    res = _run(_scene(tmp, mesh), tmp / "out")
    assert res.returncode == 0, res.stderr
    return tmp / "out"


def test_crack_is_inserted_at_the_kirsch_load_at_the_hole_edge(serial: Path) -> None:
    fr = _initiation(serial)
    ini = fr["initiation"]
    # when: the first step whose risk reaches 1, and the load factor of risk 1
    assert ini["step"] == 3 and ini["time"] == pytest.approx(0.75)
    assert ini["load_factor"] == pytest.approx(T_INIT, rel=2e-2)
    rows = list(csv.DictReader(open(serial / "history.csv")))
    risk = {int(r["step"]): float(r["max_risk"]) for r in rows if r["pair"] == ""}
    assert risk[2] < 1.0 <= ini["risk"]
    assert ini["risk"] == pytest.approx(0.75 / 0.5 * risk[2], rel=1e-9)  # linear in the load
    # where: at the hole edge, on the line through the centre normal to the load
    h = ini["cell_size"]
    assert h < R / 40
    x, y = ini["point"]
    assert ini["on_surface"] is True
    assert math.hypot(x, y) == pytest.approx(R, abs=h)
    assert abs(y) < h
    # which way: normal to the load (along x), away from the hole, four elements long
    dx, dy = ini["direction"]
    assert abs(dx) > math.cos(math.radians(3.0))
    assert dx * x > 0
    assert ini["length"] == pytest.approx(4 * h, rel=1e-12)
    crack = fr["crack"]
    assert crack["name"] == "initiated" and crack["points"][0] == pytest.approx([x, y], abs=1e-15)
    # its ends rounded to the grid of the re-meshing (2^-36 m for this 80 mm body)
    assert crack["length"] == pytest.approx(ini["length"], rel=0, abs=2 * 2.0**-36)
    # the new crack solved from the same step on: history and fracture.csv go on
    assert [int(r["step"]) for r in rows] == [0, 1, 2, 3, 4]
    tips = list(csv.DictReader(open(serial / "fracture.csv")))
    assert [(int(r["step"]), int(r["tip"])) for r in tips] == [(3, -1), (4, -1)]
    assert (serial / "fields_initiated.xdmf").exists()
    # the crack path with the fields of the cracked body (none before: no crack yet)
    import pyvista

    path = pyvista.read(serial / "fields_initiated_crack.vtk")
    assert path.n_points == 2 and path.n_lines == 1
    assert path.points[:, :2].ravel() == pytest.approx(sum(crack["points"], []), abs=1e-15)
    assert not (serial / "fields_crack.vtk").exists()
    # an edge crack at the hole: Bowie's factor for a/R = 0.05 lies between F(0.1), F(0)
    last = tips[-1]
    a = float(last["length"])
    F = float(last["K_I"]) / (SIGMA * math.sqrt(math.pi * a))
    assert 2.73 < F < 3.39
    assert abs(float(last["K_II"])) < 0.02 * float(last["K_I"])


@pytest.mark.parametrize("n", [2, pytest.param(3, marks=pytest.mark.slow)])
def test_ranks_insert_the_same_crack(serial: Path, mesh: Path, tmp_path: Path, n: int) -> None:
    res = _run(_scene(tmp_path, mesh), tmp_path / "out", n)
    assert res.returncode == 0, res.stderr
    a, b = _initiation(serial)["initiation"], _initiation(tmp_path / "out")["initiation"]
    assert b["step"] == a["step"]
    assert b["load_factor"] == pytest.approx(a["load_factor"], rel=1e-10)
    flat = [x for p in a["points"] for x in p]
    assert [x for p in b["points"] for x in p] == pytest.approx(flat, abs=1e-12)
    ka = [float(r["K_I"]) for r in csv.DictReader(open(serial / "fracture.csv"))]
    kb = [float(r["K_I"]) for r in csv.DictReader(open(tmp_path / "out" / "fracture.csv"))]
    assert kb == pytest.approx(ka, rel=1e-10)


def _numbers(path: Path) -> list[list[float | str]]:
    """The rows of a table, numbers as floats, words as they are."""

    def cell(v: str) -> float | str:
        try:
            return float(v)
        except ValueError:
            return v

    return [[cell(v) for v in r] for r in csv.reader(open(path))]


def _assert_same_tables(ref: Path, out: Path) -> None:
    """history.csv and fracture.csv of ``out`` equal those of ``ref`` to 1e-10 relative,
    every row once."""
    for name in ("history.csv", "fracture.csv"):
        a, b = _numbers(ref / name), _numbers(out / name)
        assert len(a) == len(b), name
        for ra, rb in zip(a, b, strict=True):
            assert len(ra) == len(rb)
            for x, y in zip(ra, rb, strict=True):
                if isinstance(x, str) or math.isnan(x):
                    assert str(x) == str(y), name
                else:
                    assert y == pytest.approx(x, rel=1e-10, abs=1e-300), name


@pytest.mark.slow
def test_restart_before_and_after_the_initiation(mesh: Path, tmp_path: Path) -> None:
    """Checkpoints at t = 0.5 and 1 (``checkpoint_time = 0.5``); continued from step 2
    (before the crack; checkpoints now every step) the run inserts the same crack at
    step 3, and continued again from step 3 (the initiated crack re-meshed from the
    checkpoint) it gives the same step 4: the tables equal the uninterrupted run's."""
    ref, out = tmp_path / "ref", tmp_path / "out"
    (tmp_path / "every").mkdir()
    timed = _scene(tmp_path, mesh, crack="checkpoint_time = 0.5")  # a key of [output]
    every = _scene(tmp_path / "every", mesh, crack="checkpoint_every = 1")
    res = _run(timed, ref)
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in (ref / "checkpoints").iterdir()) == [
        "step_00000002",
        "step_00000004",
    ]
    shutil.copytree(ref, out)
    for step in (2, 3):
        named = out / "checkpoints" / f"step_{step:08d}"
        cmd = [str(BIN / "bonecontact"), "run", str(every), "-q", "-o", str(out)]
        res = _spawn([*cmd, "--restart", str(named)])
        assert res.returncode == 0, res.stderr
        _assert_same_tables(ref, out)
        s, r = _initiation(out), _initiation(ref)
        assert s["initiation"] == r["initiation"] and s["crack"] == r["crack"]
        restarted = json.loads((out / "summary.json").read_text())["restarted_from"]
        assert restarted["step"] == step


@pytest.mark.parametrize(
    ("extra", "crack", "key", "text"),
    [
        ("initiation_length = 0.03", "", "initiation_length", "not smaller than half"),
        ("initiation_length = 0.0195", "", "initiation_length", "leaves the body"),
        (
            "",
            '[[crack]]\npoints = [[0.005, 0.0], [0.006, 0.0]]\nregion = "plate"\n',
            "initiate",
            "not both",
        ),
        ("initiation_length = -1.0", "", "initiation_length", "positive"),
    ],
)
def test_bad_initiation_input_is_exit_2(
    mesh: Path, tmp_path: Path, capsys, extra: str, crack: str, key: str, text: str
) -> None:
    scene = _scene(tmp_path, mesh, extra, crack)
    res = _here(["run", str(scene), "-q", "-o", str(tmp_path / "out")], capsys)
    assert res.returncode == 2, res.stderr
    assert f'[fracture], key "{key}"' in res.stderr and text in res.stderr, res.stderr


def test_check_accepts_an_initiating_scene(mesh: Path, tmp_path: Path, capsys) -> None:
    res = _here(["check", str(_scene(tmp_path, mesh, "coefficient = 0.3"))], capsys)
    assert res.returncode == 0, res.stderr
    assert "initiated: the faces of the crack inserted at risk 1, Coulomb 0.3" in res.stdout


@pytest.mark.parametrize(
    ("extra", "key", "text"),
    [
        ("initiation_length = 0.03", "initiation_length", "not smaller than half"),
        ("friction = -0.2", "friction", ">= 0"),
    ],
)
def test_check_refuses_bad_initiation_input(
    mesh: Path, tmp_path: Path, capsys, extra: str, key: str, text: str
) -> None:
    res = _here(["check", str(_scene(tmp_path, mesh, extra))], capsys)
    assert res.returncode == 2, res.stderr
    assert f'[fracture], key "{key}"' in res.stderr and text in res.stderr, res.stderr


def test_initiation_in_a_quasistatic_analysis_is_refused(
    mesh: Path, tmp_path: Path, capsys
) -> None:
    path = _scene(tmp_path, mesh)
    quasistatic = 'kind = "quasistatic"\nt_end = 1.0\ndt = 0.25'
    text = path.read_text().replace('kind = "static"', quasistatic)
    path.write_text(text.replace("load_steps = 4\n", ""))
    res = _here(["check", str(path)], capsys)
    assert res.returncode == 2, res.stderr
    assert '[fracture], key "initiate"' in res.stderr and "static" in res.stderr, res.stderr


def _two_region_mesh(path: Path) -> None:
    """The plate without hole as two cell groups, plate (y < 0) and cap (y > 0)."""
    import gmsh

    gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        occ = gmsh.model.occ
        lower = occ.addRectangle(-W, -H, 0, 2 * W, H)
        upper = occ.addRectangle(-W, 0, 0, 2 * W, H)
        occ.fragment([(2, lower)], [(2, upper)])
        occ.synchronize()
        eps = 1e-3 * W  # gmsh pads bounding boxes by 1e-7 m
        gmsh.model.addPhysicalGroup(2, [lower], 1, name="plate")
        gmsh.model.addPhysicalGroup(2, [upper], 2, name="cap")
        for k, (name, y) in enumerate((("bottom", -H), ("top", H))):
            curves = gmsh.model.getEntitiesInBoundingBox(-2 * W, y - eps, -1, 2 * W, y + eps, 1, 1)
            gmsh.model.addPhysicalGroup(1, [c for _, c in curves], 3 + k, name=name)
        pin = gmsh.model.getEntitiesInBoundingBox(-2 * W, -H - eps, -1, 2 * W, -H + eps, 1, 1)
        gmsh.model.addPhysicalGroup(1, [c for _, c in pin], 5, name="pin")
        gmsh.option.setNumber("Mesh.MeshSizeMax", W / 4)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def test_initiation_in_a_mesh_of_two_regions_is_refused(tmp_path: Path, capsys) -> None:
    mesh = tmp_path / "two.msh"
    _two_region_mesh(mesh)
    path = _scene(tmp_path, mesh)
    path.write_text(path.read_text().replace('regions = ["plate"]', 'regions = ["plate", "cap"]'))
    res = _here(["check", str(path)], capsys)
    assert res.returncode == 2, res.stderr
    assert '[fracture], key "initiate"' in res.stderr and "one cell group" in res.stderr, res.stderr


# --------------------------------------------------- initiated, then grown (2026-12-03)
#: Bowie's factor F(a/R) of one radial crack at a hole in a plate under uniaxial tension
#: normal to it, K_I = F σ √(πa) (Tada, Paris and Irwin's table), at the lengths the
#: initiated crack grows through: 0.1R (as inserted: one increment long) to 0.4R.
BOWIE = {0.1: 2.73, 0.2: 2.30, 0.3: 2.04, 0.4: 1.86}
GROWTH = "propagate = true\nincrement = 1.0e-4\nmax_increments = 3"
K_IC = 1.0e6  # below K_I of the inserted crack at t = 0.75 (2.3 MPa √m): it grows


def _growth_scene(folder: Path, mesh: Path) -> Path:
    path = _scene(folder, mesh, GROWTH)
    text = path.read_text().replace(f"sigma_t = {SIGMA_T}", f"sigma_t = {SIGMA_T}\nK_Ic = {K_IC}")
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def grown(mesh: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("kirsch_initiation_grown")
    res = _run(_growth_scene(tmp, mesh), tmp / "out")
    assert res.returncode == 0, res.stderr
    return tmp / "out"


def test_initiated_crack_grows_with_bowies_k(grown: Path) -> None:
    """The crack inserted at the hole edge at t = 0.75 (one increment Δa = 0.1R long)
    grows at that load by three increments, straight (within 1°) along the symmetry
    line (within two cells), its faces
    paired (the run went on: a face pair with a gap is refused), and K_I at every length
    a = 0.1R … 0.4R is Bowie's F σ√(πa) within 2 % (measured −1.1, +1.1, +0.7, −0.4 %;
    finite width W = 20R: below 0.5 %); K_II within 0.5 % of K_I (measured ≤ 0.27 %);
    the face gaps after each solve are not negative."""
    fr = _initiation(grown)
    crack = fr["crack"]
    assert fr["initiation"]["step"] == 3 and fr["initiation"]["length"] == pytest.approx(1e-4)
    assert crack["propagation"]["increments"] == 3
    assert crack["propagation"]["status"] == "max_increments"
    pts = np.array(crack["points"])
    assert len(pts) == 5 and np.abs(pts[:, 1]).max() < R / 40  # on y = 0 (two cells)
    step = np.diff(pts, axis=0)
    assert np.all(np.abs(step[:, 1]) < math.tan(math.radians(1.0)) * np.abs(step[:, 0]))
    rows = [r for r in csv.DictReader(open(grown / "fracture.csv")) if int(r["step"]) == 3]
    assert [int(r["increment"]) for r in rows] == [0, 1, 2, 3]
    sigma = 0.75 * SIGMA
    for r in rows:
        a = float(r["length"])
        F = float(r["K_I"]) / (sigma * math.sqrt(math.pi * a))
        assert F == pytest.approx(BOWIE[round(a / R, 6)], rel=0.02), (a, F)
        assert abs(float(r["K_II"])) < 0.005 * float(r["K_I"])
    gaps = [float(r["gap"]) for r in csv.DictReader(open(grown / "contact_initiated.csv"))]
    assert min(gaps) > -1e-9 * R


@pytest.mark.parametrize("n", [2, pytest.param(3, marks=pytest.mark.slow)])
def test_ranks_grow_the_initiated_crack_alike(
    grown: Path, mesh: Path, tmp_path: Path, n: int
) -> None:
    res = _run(_growth_scene(tmp_path, mesh), tmp_path / "out", n)
    assert res.returncode == 0, res.stderr
    a, b = _initiation(grown)["crack"], _initiation(tmp_path / "out")["crack"]
    assert np.array(b["points"]) == pytest.approx(np.array(a["points"]), abs=1e-12)
    ka = [float(r["K_I"]) for r in csv.DictReader(open(grown / "fracture.csv"))]
    kb = [float(r["K_I"]) for r in csv.DictReader(open(tmp_path / "out" / "fracture.csv"))]
    assert kb == pytest.approx(ka, rel=1e-8)


def test_a_crack_the_run_made_that_cannot_be_cut_fails_naming_it(mesh: Path, tmp_path: Path):
    """A crack the run inserted or grew that cannot be cut into the body, meshed or
    paired ends the run ``"failed"`` (a RunError naming the crack, its points and the
    reason), not as an input error of ``[fracture] initiation_length`` (exit 2) as
    before; the scene's own crack stays an input error."""
    from mpi4py import MPI

    from bonecontact.common.errors import RunError
    from bonecontact.common.profiling import PhaseTimer
    from bonecontact.fracture.crack import Crack2D
    from bonecontact.runners.cracks import build_cracked, prepare, with_cracks
    from bonecontact.scene import SceneError, load_scene
    from bonecontact.scene.spec import CrackSpec

    scene = load_scene(_growth_scene(tmp_path, mesh))
    run = prepare(scene, MPI.COMM_SELF)
    inserted = Crack2D(np.array([[0.01, 0.0], [0.011, 0.0]]), "both")
    run = with_cracks(run, (CrackSpec("initiated", inserted, "plate", 0.0),), True)
    out = Crack2D(np.array([[0.01, 0.0], [0.011, 0.0], [W + 1e-3, 0.0]]), "both")  # past x = W
    for made in ("inserted", "grown"):
        with pytest.raises(RunError, match=f"the {made} crack 'initiated'") as err:
            build_cracked(scene, run, [out], MPI.COMM_SELF, PhaseTimer(), made)
        assert "(points (0.01, 0), (0.011, 0), (0.021, 0))" in str(err.value)
        assert "cannot be meshed: " in str(err.value) and "not inside the body" in str(err.value)
    with pytest.raises(SceneError, match="initiation_length"):
        build_cracked(scene, run, [out], MPI.COMM_SELF, PhaseTimer())
