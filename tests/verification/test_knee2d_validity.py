"""The shipped 2D knee scenes stay in the small-strain model's range and balance their load.

A family over data/scenes/knee2d.toml (static, body weight), knee2d_gait.toml (dynamic,
Coulomb friction; reduced to the first stance peak, 1.2 x body weight at t = 0.15 s, with
dt = 25 ms) and knee2d_tumour.toml (its contact analysis on the shipped tumour mesh, the
growth left out), each with the model as shipped (materials, mesh, load; the static ones in
one load step: frictionless static contact does not depend on the load path).  Each run
asserts: status ``converged`` and ``small_strain_valid`` (strain measure ≤ 10 %) without
``allow_large_strain``; the tibia's base reaction equals the applied load (1e-4 static,
1e-3 with inertia), the horizontal reactions of the tibia and the guided femoral shaft
cancel, and the load is the scene's 17.5 kN/m times the schedule.

The contact patch of the static runs is compared with an independent thin-layer
estimate: the two cartilage layers (thickness h each, on bone 100-1700 times stiffer)
compressed in confined compression (modulus M = E(1 - ν)/((1 + ν)(1 - 2ν))) between the
condyle (radius R_f) and the concave seat (R_t), gap x²/(2 R_eq), 1/R_eq = 1/R_f - 1/R_t:
p(x) = M (a² - x²)/(4 h R_eq), hence the half width a = (3 h R_eq P / M)^(1/3) and the peak
p0 = M a² / (4 h R_eq) for the load P per metre.  Both within 10 % (the estimate neglects
lateral bulging and the bones' compliance; the edge node spacing is 0.4 mm of ~9.5 mm).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import re
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

from bonecontact.runners import run_scene
from bonecontact.scene import load_scene

COMM = MPI.COMM_WORLD
SCENES = Path(__file__).resolve().parents[2] / "data" / "scenes"
LOAD = 2.9167e5 * 0.06  # N/m: the femoral traction over the 60 mm shaft (700 N / 40 mm)
#: the geometry of data/scenes/make_meshes.py and the cartilage of the scenes (SI)
R_F, R_T, H_CART, E_CART, NU_CART = 0.03, 0.04, 3e-3, 10.0e6, 0.4

_RUNS: dict[str, dict] = {}


def reduced_scene(name: str, directory: Path) -> str:
    """The shipped scene ``name`` with absolute mesh path and the reduced cost."""
    text = (SCENES / f"{name}.toml").read_text()
    text = re.sub(r'mesh = "([^"]+)"', lambda m: f'mesh = "{SCENES / m.group(1)}"', text)
    text = re.sub(r'directory = "[^"]+"', f'directory = "{directory}"', text)
    text = re.sub(r"(?m)^load_steps = \d+$", "load_steps = 1", text)
    if name == "knee2d_gait":
        text = text.replace("t_end = 1.0", "t_end = 0.15").replace("dt = 0.01", "dt = 0.025")
    if name == "knee2d_tumour":  # the contact analysis alone: no [neoplasm*] sections
        text = text[: text.index("[neoplasm]")]
        text = text.replace("results/knee2d_tumour", str(directory))
    assert "allow_large_strain" not in text
    return text


def knee_run(name: str, tmp_path_factory: pytest.TempPathFactory) -> dict:
    """Run the reduced scene once per session; its summary and history."""
    if name not in _RUNS:
        d = Path(COMM.bcast(str(tmp_path_factory.mktemp(name)) if COMM.rank == 0 else None))
        if COMM.rank == 0:
            (d / "scene.toml").write_text(reduced_scene(name, d))
        COMM.barrier()
        res = run_scene(load_scene(d / "scene.toml"), COMM, output=d, progress=False)
        COMM.barrier()
        hist = np.genfromtxt(d / "history.csv", delimiter=",", names=True, dtype=None)
        rows = np.genfromtxt(d / "contact_tibiofemoral.csv", delimiter=",", names=True)
        _RUNS[name] = {"status": res.status, "summary": res.summary, "hist": hist, "rows": rows}
    return _RUNS[name]


@pytest.mark.parametrize(
    ("name", "factor", "rtol"),
    [("knee2d", 1.0, 1e-4), ("knee2d_gait", 1.2, 1e-3), ("knee2d_tumour", 1.0, 1e-4)],
)
def test_knee2d_scene_valid_and_balanced(name, factor, rtol, tmp_path_factory):
    """Valid as shipped (strain measure ≤ 10 %) and the tibia carries the applied load."""
    r = knee_run(name, tmp_path_factory)
    s, h = r["summary"], r["hist"]
    assert r["status"] == "converged", s.get("message")
    assert s["small_strain_valid"] is True and s["strain_measure"] <= 0.10, s["strain_measure"]
    assert float(h["load_y"][-1]) == pytest.approx(-factor * LOAD, rel=1e-4)
    assert float(h["reaction_tibia_bottom_y"][-1]) == pytest.approx(factor * LOAD, rel=rtol)
    # horizontal: the tibia's base and the guided femoral sides balance each other
    rx = float(h["reaction_tibia_bottom_x"][-1]) + float(h["reaction_femur_sides_x"][-1])
    assert abs(rx) < rtol * LOAD


@pytest.mark.parametrize("name", ["knee2d", "knee2d_tumour"])
def test_knee2d_contact_patch_against_thin_layer_estimate(name, tmp_path_factory):
    """Half width and peak pressure of the static contact against the thin-layer estimate
    (module docstring): a = 9.6 mm, p0 = 1.37 MPa at 17.5 kN/m; within 10 %."""
    rows = knee_run(name, tmp_path_factory)["rows"]
    m = E_CART * (1 - NU_CART) / ((1 + NU_CART) * (1 - 2 * NU_CART))
    r_eq = 1.0 / (1.0 / R_F - 1.0 / R_T)
    a = (3 * H_CART * r_eq * LOAD / m) ** (1 / 3)
    p0 = m * a**2 / (4 * H_CART * r_eq)
    on = rows["pressure"] > 0
    assert rows["x"][on].max() == pytest.approx(a, rel=0.10)
    assert -rows["x"][on].min() == pytest.approx(a, rel=0.10)
    assert rows["pressure"].max() == pytest.approx(p0, rel=0.10)
