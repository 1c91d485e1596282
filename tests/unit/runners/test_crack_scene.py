"""Scenes with a ``[[crack]]`` through the ``bonecontact`` command (bonecontact.runners.cracks).

A plate [−W, W] × [−H, H] (W = 20 mm, H = 2W), E = 17 GPa, ν = 0.3, plane strain, loaded
by σ_yy = σ on its top and bottom edges; rigid-body motion is removed on two short edge
pieces at the bottom-left corner (u_x = 0 on 2 mm of the left edge, u_y = 0 on 2 mm of the
bottom edge), which the uniform stress state satisfies exactly.  The runner cuts the crack
into the body, makes its faces a contact pair and writes fracture.csv.

* Centre crack 2a, a/W = 0.3, tension: K_I = σ√(πa)√(sec(πa/2W)) (Feddersen) within 2 %
  at both tips, K_II ≈ 0, J ≈ G; displacement correlation (the cross-check) within 15 %.
* Inclined centre crack (45°, a/W = 0.1) under compression, faces with friction
  μ = 0.3: closed (no interpenetration), K_I ≈ 0 and
  |K_II| = √(πa)(|τ| − μ|σ_n|) within 3 %.
* The inclined crack in tension, propagating: the first kink is the MTS angle of the
  computed K (−53.1° for K_I = K_II), later increments run normal to the load.
* A crack near the right edge: it grows until it reaches the free surface; the run
  reports ``fractured`` with the load at which it happened.
* 1, 2 and 3 ranks give the same K and the same path.
"""

from __future__ import annotations

import csv
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from _crack_scenes import PINNED_PLATE_HEAD, pinned_plate
from coupled_support import gmsh_on_rank0

pytestmark = pytest.mark.serial

BIN = Path(sys.executable).parent
ENV = {**os.environ, "OMP_NUM_THREADS": "1"}
W, H, PIN = 0.02, 0.04, 0.002  # m
E, NU = 17.0e9, 0.3
SIGMA = 1.0e6  # Pa

SCENE = (
    PINNED_PLATE_HEAD
    + """[[crack]]
name = "c"
points = {points}
region = "plate"
coefficient = {friction}
[output]
fields_every = 0
{extra}"""
)


def _mesh(path: Path, h: float = 0.002) -> None:
    """The plate with its edge groups (pin_y, bottom, right, top, left, pin_x)."""
    gmsh_on_rank0(pinned_plate(-W, W, H, PIN, h), path, 2)


@pytest.fixture(scope="module")
def mesh(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("plate") / "plate.msh"
    _mesh(path)
    return path


def _scene(
    folder: Path,
    mesh: Path,
    name: str,
    points: list,
    sigma: float = SIGMA,
    friction: float = 0.0,
    K_Ic: float = 1.0e6,
    steps: int = 1,
    extra: str = "",
) -> Path:
    path = folder / f"{name}.toml"
    path.write_text(
        SCENE.format(
            name=name,
            mesh=mesh,
            steps=steps,
            E=E,
            nu=NU,
            material=f"K_Ic = {K_Ic}",
            sigma=sigma,
            minus_sigma=-sigma,
            points=points,
            friction=friction,
            extra=extra,
        )
    )
    return path


def _run(scene: Path, out: Path, n: int = 1) -> Path:
    cmd = [str(BIN / "bonecontact"), "run", str(scene), "-q", "-o", str(out)]
    if n > 1:
        cmd = [str(BIN / "mpiexec"), "-n", str(n), *cmd]
    res = subprocess.run(
        cmd, capture_output=True, text=True, timeout=900, env=ENV, stdin=subprocess.DEVNULL
    )
    assert res.returncode == 0, res.stderr
    return out


def _rows(out: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(open(out / "fracture.csv")))


def _f(row: dict[str, str], key: str) -> float:
    return float(row[key])


A_CENTRE = 0.3 * W
CENTRE = [[-A_CENTRE, 0.0], [A_CENTRE, 0.0]]
A_INCL = 0.1 * W
S45 = A_INCL / math.sqrt(2)
INCLINED = [[-S45, -S45], [S45, S45]]


def feddersen(a: float) -> float:
    return SIGMA * math.sqrt(math.pi * a / math.cos(math.pi * a / (2 * W)))


def _clamped(scene: Path) -> Path:
    """The scene with its bottom edge clamped (u = 0) instead of loaded by −σ."""
    text = scene.read_text()
    loaded = f'[[traction]]\nboundary = "bottom"\nvalue = [0.0, {-SIGMA}]\n'
    assert loaded in text
    scene.write_text(
        text.replace(loaded, '[[dirichlet]]\nboundary = "bottom"\nvalue = [0.0, 0.0]\n')
    )
    return scene


@pytest.fixture(scope="module", params=["free", "clamped"])
def centre(
    mesh: Path, tmp_path_factory: pytest.TempPathFactory, request: pytest.FixtureRequest
) -> dict:
    """The centre-cracked plate on 1, 2 and 3 ranks (the outputs by rank count, and
    ``"support"``): bottom edge loaded (free) or clamped."""
    tmp = tmp_path_factory.mktemp(f"centre_{request.param}")
    scene = _scene(tmp, mesh, "centre", CENTRE)
    if request.param == "clamped":
        _clamped(scene)
    return {"support": request.param} | {n: _run(scene, tmp / f"out{n}", n) for n in (1, 2, 3)}


# Feddersen's plate is loaded on both edges: the clamped variant is compared across ranks only
@pytest.mark.parametrize("centre", ["free"], indirect=True)
def test_centre_crack_in_tension_gives_feddersen(centre: dict) -> None:
    rows = _rows(centre[1])
    assert [r["tip"] for r in rows] == ["0", "-1"]
    k_ref = feddersen(A_CENTRE)
    e_prime = E / (1 - NU**2)
    for r in rows:
        assert _f(r, "K_I") == pytest.approx(k_ref, rel=2e-2)
        assert abs(_f(r, "K_II")) < 1e-2 * k_ref
        assert _f(r, "G") == pytest.approx(_f(r, "K_I") ** 2 / e_prime, rel=1e-2)
        assert _f(r, "J") == pytest.approx(_f(r, "G"), rel=3e-2)
        assert _f(r, "K_I_dc") == pytest.approx(_f(r, "K_I"), rel=0.15)
        assert r["status"] == "stationary" and r["step"] == "1" and r["time"] == "1.0"
    info = json.loads((centre[1] / "summary.json").read_text())
    crack = info["fracture"]["crack"]
    assert crack["length"] == pytest.approx(2 * A_CENTRE, rel=1e-12)
    assert [t["K_I"] for t in crack["tips"]] == [_f(r, "K_I") for r in rows]
    assert info["contact"]["pairs"] == ["c"]
    assert (centre[1] / "contact_c.csv").is_file()


@pytest.mark.parametrize("n", [2, 3])
def test_centre_crack_ranks_give_the_serial_k(centre: dict, n: int) -> None:
    """The same mesh on every number of ranks (the outline's loops start at their smallest
    vertex: before, 3802 dofs on 1 rank and 3804 on 2, K_I 7.6e-6 apart, 1.5e-3 with the
    bottom clamped), so the same dof count and K to 1e-10 (measured 5e-14)."""
    s1, sn = (json.loads((centre[k] / "summary.json").read_text()) for k in (1, n))
    assert sn["dofs"] == s1["dofs"] and sn["ranks"] == n
    k_scale = SIGMA * math.sqrt(math.pi * A_CENTRE)
    for a, b in zip(_rows(centre[1]), _rows(centre[n]), strict=True):
        for key in ("K_I", "K_II", "J", "K_I_dc"):
            assert _f(b, key) == pytest.approx(_f(a, key), rel=1e-10, abs=1e-10 * k_scale), key


#: (β, μ) of the closed crack; two of the six slow (make test-all)
CLOSED = [
    (45.0, 0.0),
    (45.0, 0.3),
    (30.0, 0.3),
    (60.0, 0.0),
    pytest.param(30.0, 0.0, marks=pytest.mark.slow),
    pytest.param(60.0, 0.3, marks=pytest.mark.slow),
]


@pytest.mark.parametrize("beta, mu", CLOSED)
def test_closed_inclined_crack(mesh: Path, tmp_path: Path, beta: float, mu: float) -> None:
    """A crack at β to the x axis (a/W = 0.1, default tip mesh) closed by uniaxial
    compression, frictionless or Coulomb faces: at both tips |K_I| ≤ 1 % of |σ|√(πa) and
    |K_II| = √(πa)(|τ| − μ|σ_n|) within 3 %, σ_n = |σ|cos²β, τ = |σ| sinβ cosβ.  (The
    raw nodal multipliers in the face term gave |K_I| up to 1.5 % at one tip; the face
    tractions near the tips are now recovered by a linear fit: measured ≤ 0.55 %, K_II
    within 0.5 %.)"""
    b = math.radians(beta)
    points = [
        [-A_INCL * math.cos(b), -A_INCL * math.sin(b)],
        [A_INCL * math.cos(b), A_INCL * math.sin(b)],
    ]
    scene = _scene(tmp_path, mesh, "closed", points, sigma=-SIGMA, friction=mu)
    out = _run(scene, tmp_path / "out")
    k0 = SIGMA * math.sqrt(math.pi * A_INCL)
    expected = k0 * (math.sin(b) * math.cos(b) - mu * math.cos(b) ** 2)
    rows = _rows(out)
    assert [r["tip"] for r in rows] == ["0", "-1"]
    for r in rows:
        assert abs(_f(r, "K_I")) <= 1e-2 * k0, (r["tip"], _f(r, "K_I") / k0)
        assert abs(_f(r, "K_II")) == pytest.approx(expected, rel=3e-2)
    nodes = list(csv.DictReader(open(out / "contact_c.csv")))
    assert len(nodes) > 10
    assert min(float(n["gap"]) for n in nodes) > -1e-9 * A_INCL
    assert all(n["status"] in ("stick", "slip") for n in nodes)


def _propagating(folder: Path, mesh: Path, n: int) -> Path:
    extra = "[fracture]\npropagate = true\nincrement = 0.001\nmax_increments = 3\n"
    scene = _scene(folder, mesh, "kink", INCLINED, K_Ic=1.0e4, extra=extra)
    return _run(scene, folder / f"out{n}", n)


def test_inclined_crack_kinks_by_mts_and_turns_normal_to_the_load(
    mesh: Path, tmp_path: Path
) -> None:
    from bonecontact.fracture.criteria import mts_angle

    out = _propagating(tmp_path, mesh, 1)
    rows = _rows(out)
    assert [int(r["increment"]) for r in rows] == [0, 0, 1, 1, 2, 2, 3, 3]
    for r in rows[:2]:
        theta = mts_angle(_f(r, "K_I"), _f(r, "K_II"))
        assert _f(r, "angle_deg") == pytest.approx(math.degrees(theta), abs=1e-9)
        assert _f(r, "angle_deg") == pytest.approx(-53.13, abs=1.0)
    info = json.loads((out / "summary.json").read_text())["fracture"]["crack"]
    pts = info["points"]
    assert len(pts) == 2 + 2 * 3
    for a, b in ((pts[1], pts[0]), (pts[-2], pts[-1])):  # the last segment at each tip
        angle = math.degrees(math.atan2(b[1] - a[1], b[0] - a[0]))
        assert min(abs(angle), 180 - abs(angle)) < 10.0  # normal to the load (y)
    for r in rows[-2:]:
        assert abs(_f(r, "K_II")) < 0.05 * _f(r, "K_I")
    assert info["propagation"]["status"] == "max_increments"
    assert info["propagation"]["fractured"] is False
    # the crack path with each mesh's fields: the initial crack, then one per increment
    import pyvista

    first = pyvista.read(out / "fields_crack.vtk")
    assert first.n_points == 2 and first.n_lines == 1
    last = pyvista.read(out / "fields_increment3_crack.vtk")
    np.testing.assert_allclose(last.points[:, :2], pts, rtol=0, atol=1e-15)


@pytest.mark.slow
@pytest.mark.parametrize("n", [2, 3])
def test_propagation_same_path_on_ranks(mesh: Path, tmp_path: Path, n: int) -> None:
    serial = json.loads((_propagating(tmp_path, mesh, 1) / "summary.json").read_text())
    par = json.loads((_propagating(tmp_path, mesh, n) / "summary.json").read_text())
    a, b = serial["fracture"]["crack"]["points"], par["fracture"]["crack"]["points"]
    # the same mesh at every increment (the grown tips rounded to a grid of ~1e-11 m, so
    # that the solvers' round-off in K cannot reach gmsh): the same path to 1e-10 of Δa
    np.testing.assert_allclose(np.asarray(b), np.asarray(a), rtol=0, atol=1e-10 * 0.001)
    for r, q in zip(_rows(tmp_path / "out1"), _rows(tmp_path / f"out{n}"), strict=True):
        assert _f(q, "K_I") == pytest.approx(_f(r, "K_I"), rel=1e-10, abs=1e-10 * SIGMA)


@pytest.mark.slow
def test_crack_near_the_edge_fractures_the_plate(mesh: Path, tmp_path: Path) -> None:
    """Load in 4 steps; K_Ic 0.6 of the initial K_eq at full load: nothing grows at
    t = 0.5, the crack grows at t = 0.75 (K rises as it nears the edge) through to the
    free surface: fractured at t = 0.75."""
    points = [[0.25 * W, 0.0], [0.7 * W, 0.0]]
    stationary = _run(_scene(tmp_path, mesh, "edge0", points, steps=4), tmp_path / "s")
    k_eq = _f([r for r in _rows(stationary) if r["time"] == "1.0"][1], "K_eq")
    extra = "[fracture]\npropagate = true\nincrement = 0.002\nmax_increments = 20\n"
    scene = _scene(tmp_path, mesh, "edge", points, K_Ic=0.6 * k_eq, steps=4, extra=extra)
    out = _run(scene, tmp_path / "p")
    info = json.loads((out / "summary.json").read_text())["fracture"]["crack"]["propagation"]
    assert info["fractured"] is True and info["status"] == "fractured"
    assert info["fracture_time"] == 0.75 and info["fracture_step"] == 3
    rows = _rows(out)
    assert {r["status"] for r in rows if r["time"] == "0.5"} == {"holds"}
    assert rows[-1]["status"] == "fractured" or rows[-2]["status"] == "fractured"


def test_closed_crack_propagates_in_shear(mesh: Path, tmp_path: Path) -> None:
    """Frictionless 45° crack under compression, one increment: the faces stay closed
    (K_I ≈ 0, no interpenetration before and after the increment) and the tips kink by
    the MTS angle of pure mode II, ∓70.53°."""
    extra = "[fracture]\npropagate = true\nincrement = 0.001\nmax_increments = 1\n"
    scene = _scene(tmp_path, mesh, "shear", INCLINED, sigma=-SIGMA, K_Ic=1.0e4, extra=extra)
    out = _run(scene, tmp_path / "out")
    rows = _rows(out)
    k0 = SIGMA * math.sqrt(math.pi * A_INCL)
    for r in rows[:2]:
        assert abs(_f(r, "K_I")) < 3e-2 * k0
        assert abs(_f(r, "K_II")) == pytest.approx(0.5 * k0, rel=3e-2)
        assert abs(_f(r, "angle_deg")) == pytest.approx(70.53, abs=1.0)
        assert r["status"] == "grows"
    assert [r["status"] for r in rows[2:]] == ["max_increments"] * 2
    nodes = list(csv.DictReader(open(out / "contact_c.csv")))  # the state after the increment
    assert min(float(n["gap"]) for n in nodes) > -1e-9 * A_INCL


@pytest.mark.parametrize(
    "edit, where",
    [
        (
            lambda s: (
                s + '[[crack]]\nname = "d"\npoints = [[0.0, -0.002], [0.0, 0.002]]\n'
                'region = "plate"\n'
            ),
            '[[crack]] #2 "d", key "points": crosses or touches [[crack]] #1 "c"',
        ),
        (
            lambda s: (
                s.replace('kind = "static"', 'kind = "quasistatic"\nt_end = 1.0\ndt = 1.0')
                + "[fracture]\npropagate = true\nincrement = 0.001\n"
            ),
            '[fracture], key "propagate"',
        ),
    ],
    ids=["crossing_cracks", "quasistatic_propagation"],
)
def test_what_is_not_run_is_exit_2(mesh: Path, tmp_path: Path, edit, where: str) -> None:
    path = _scene(tmp_path, mesh, "refused", CENTRE)
    path.write_text(edit(path.read_text()))
    cmd = [str(BIN / "bonecontact"), "run", str(path), "-q", "-o", str(tmp_path / "out")]
    res = subprocess.run(
        cmd, capture_output=True, text=True, timeout=300, env=ENV, stdin=subprocess.DEVNULL
    )
    assert res.returncode == 2, res.stderr
    assert where in res.stderr
    assert not (tmp_path / "out" / "fracture.csv").exists()
