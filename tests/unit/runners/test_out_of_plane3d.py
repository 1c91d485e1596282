"""The planar model of a growing surface crack says when it has left its validity
(``[fracture] max_kink_deg``, ``stop_out_of_plane``; issue #26).

The plate [−b, b] × [−h, h] × [−t, 0] of the surface-crack scenes (b = h = 2.5, t = 1,
boundary facets 0.4; lengths in mm) with the semi-circular crack a = c = 0.2 at the
middle of the front face z = 0, normal y (its deepest point at φ = 90°, where e₁ = −z),
front a/6, three front points (φ ≈ 24°, 90°, 156°: the three growth points), held on
the "pin" patch of the bottom face.  References:

* pure shear σ_yz = τ (tractions (0, 0, ±τ) on top/bottom, (0, ±τ, 0) on front/back:
  a uniform state that satisfies the pin exactly): the faces slide, K_I = 0 and the
  deepest point is in pure mode II (K_III = 0 by symmetry), whose σ₁′ (MTS) kink is
  arccos(1/3) = 70.53° in magnitude.  The recorded ``max_kink_deg`` is that point's
  within 1° (the kink moves by 19° per unit K_I/K_II and by less for K_III/K_II; both
  ratios are the mesh's error, measured 0.002: 70.49°); it exceeds the default limit
  15° at the first solve (``out_of_plane`` increment 0 at that point) and, without
  ``stop_out_of_plane``, the run goes on (``max_increments``);
* pure tension σ_yy (the surface-crack scenes' load): mode I, every kink below 2°, no
  ``out_of_plane`` with ``stop_out_of_plane = true`` (the run stops ``max_increments``);
* bending σ_yy (8 MPa at the front face falling linearly to 0 at 0.35 mm depth, by
  [[force]] moments) with the shear τ = 1 MPa under fatigue (da/dN = C ΔK², blocks of
  0.1): the deepest point goes down into less tension, so its K_I/K_II falls and its
  kink grows from block to block (measured 30.1°, 33.2°, 35.8°); at max_kink_deg = 31.5
  the first growing point past it is the deepest at block 1 — every recorded kink of
  increment 0 below 31.5 and the deepest's of increment 1 above it — and
  ``stop_out_of_plane`` ends the run there: growth status ``out_of_plane``, not
  fractured, no fragments, the cycles those of block 1's crack (> 0), fracture.csv ending
  at increment 1 (rows marked ``out_of_plane``), the message naming the increment, the
  point and the angle.  Every recorded kink equals the closed-form MTS angle
  2 atan[(K_I − √(K_I² + 8 K_II²))/(4 K_II)] of its row's K_I, K_II where K_III is
  negligible (the deepest point) to 0.1°.

One PlanarModelWarning on rank 0 when ``out_of_plane`` is set (its text the summary's
message at the stop).  On several ranks each run equals the serial one (fracture.csv to
1e-10, the summary's ``max_kink_deg`` and ``out_of_plane``).  About 15 s serial.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import (
    PLATE_B,
    L,
    idle_barrier,
    read_table,
    run_in,
    same_tables,
    serial_reference,
    surface_plate,
    surface_scene,
)
from coupled_support import gmsh_on_rank0

from bonecontact.runners.surface_crack3d import PlanarModelWarning

A = 0.2 * L
T = 1.0 * L
TAU = 1.0e6
MODE_II_KINK = math.degrees(math.acos(1.0 / 3.0))  # 70.53°

# the shear τ on the front and back faces (with τ on top and bottom: a pure shear)
SIDE_SHEAR = f"""[[traction]]
boundary = "front"
value = [0.0, {TAU}, 0.0]
[[traction]]
boundary = "back"
value = [0.0, {-TAU}, 0.0]
"""
SHEAR = (
    f"""[[traction]]
boundary = "top"
value = [0.0, 0.0, {TAU}]
[[traction]]
boundary = "bottom"
value = [0.0, 0.0, {-TAU}]
"""
    + SIDE_SHEAR
)


def bending_and_shear(s_front: float = 8e6, zero: float = 0.35 * L) -> str:
    """σ_yy = s_front (1 + z/zero) (a tension and a moment about x on top and bottom,
    [[force]] spread linearly over the faces) and the shear τ: the loads of the plate."""
    area, inertia = 2 * PLATE_B * T, 2 * PLATE_B * T**3 / 12
    s_b = s_front * T / (2 * zero)  # σ_yy = s_m + s_b (1 + 2z/t)
    s_m, moment = s_front - s_b, s_b * inertia / (T / 2)
    return (
        f"""[[force]]
boundary = "top"
value = [0.0, {s_m * area}, {TAU * area}]
moment = [{-moment}, 0.0, 0.0]
[[force]]
boundary = "bottom"
value = [0.0, {-s_m * area}, {-TAU * area}]
moment = [{moment}, 0.0, 0.0]
"""
    ) + SIDE_SHEAR


def scene(mesh: Path, growth: str, loads: str | None = None, K_Ic: float = 1e3) -> str:
    """The surface-crack scene of the plate (front a/6, 3 points) with ``growth`` in
    [fracture] and ``loads`` instead of the tension (``None``: the tension)."""
    text = surface_scene(mesh, h=A / 6, points=3, growth=growth, K_Ic=K_Ic, a=A, c=A)
    if loads is None:
        return text
    return text[: text.index("[[traction]]")] + loads + text[text.index("[fracture]") :]


@pytest.fixture(scope="module")
def plate(tmp_path_factory) -> Path:
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("oop3d")) if comm.rank == 0 else None))
    gmsh_on_rank0(surface_plate(T), d / "plate.msh", 3)
    return d


def _run(plate: Path, name: str, text: str) -> tuple[dict, Path]:
    """Run on every rank; on several, compare with the serial run; the growth summary."""
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always", PlanarModelWarning)
        res, d = run_in(plate, name, text)
    said = [str(w.message) for w in seen if w.category is PlanarModelWarning]
    assert len(said) == int(res.summary["fracture"]["growth"]["out_of_plane"] is not None) * (
        MPI.COMM_WORLD.rank == 0
    )  # one warning, on rank 0
    if said:
        assert said[0] in res.summary.get("message", said[0])
    assert res.status == "converged", res.summary.get("message")
    ser = serial_reference(d)
    idle_barrier(MPI.COMM_WORLD)
    out = d / "out"
    growth = res.summary["fracture"]["growth"]
    if MPI.COMM_WORLD.size > 1:
        same_tables(out / "fracture.csv", ser / "fracture.csv")
        want = json.loads((ser / "summary.json").read_text())["fracture"]["growth"]
        assert growth["status"] == want["status"]
        assert growth["max_kink_deg"] == pytest.approx(want["max_kink_deg"], abs=1e-8)
        got_o, want_o = growth["out_of_plane"], want["out_of_plane"]
        assert (got_o is None) == (want_o is None)
        if want_o is not None:
            assert (got_o["increment"], got_o["point"]) == (want_o["increment"], want_o["point"])
            assert got_o["kink_deg"] == pytest.approx(want_o["kink_deg"], abs=1e-8)
    return growth, out


def _mts_kink(k1: np.ndarray, k2: np.ndarray) -> np.ndarray:
    """The MTS kink angle (degrees) of K_I, K_II (K_III = 0): 2 atan[(K_I − √(K_I² +
    8K_II²))/(4K_II)], its sign opposite to K_II's."""
    return np.degrees(2 * np.arctan((k1 - np.sqrt(k1**2 + 8 * k2**2)) / (4 * k2)))


def test_pure_mode_ii_is_out_of_plane_at_once(plate: Path) -> None:
    growth = "propagate = true\nincrement = 3e-5\nmax_increments = 1"
    g, out = _run(plate, "shear", scene(plate / "plate.msh", growth, SHEAR))
    assert g["status"] == "max_increments" and g["increments"] == 1  # it goes on
    assert not g["fractured"]
    assert g["max_kink_deg"] == pytest.approx(MODE_II_KINK, abs=1.0)
    assert g["max_kink_phi_deg"] == pytest.approx(90.0, abs=1e-9)  # the deepest point
    assert g["kink_limit_deg"] == 15.0
    o = g["out_of_plane"]
    assert (o["increment"], o["point"], o["limit_deg"]) == (0, 1, 15.0)
    assert abs(o["kink_deg"]) == pytest.approx(MODE_II_KINK, abs=1.0)
    t = read_table(out / "fracture.csv")
    deep = np.abs(t["phi_deg"] - 90.0) < 1e-9
    assert np.all(np.abs(t["K_I"][deep]) < 0.01 * np.abs(t["K_II"][deep]))
    assert np.all(np.abs(t["K_III"][deep]) < 0.01 * np.abs(t["K_II"][deep]))
    np.testing.assert_allclose(np.abs(t["kink_deg"][deep]), MODE_II_KINK, atol=1.0)
    assert "out_of_plane" not in set(t["status"])  # recorded, not a stop


def test_pure_mode_i_stays_in_plane(plate: Path) -> None:
    growth = "propagate = true\nincrement = 3e-5\nmax_increments = 1\nstop_out_of_plane = true"
    g, out = _run(plate, "tension", scene(plate / "plate.msh", growth))
    assert g["status"] == "max_increments" and g["increments"] == 1
    assert g["out_of_plane"] is None
    assert 0.0 <= g["max_kink_deg"] < 2.0
    t = read_table(out / "fracture.csv")
    assert np.abs(t["kink_deg"]).max() < 2.0
    assert sorted(set(t["increment"].astype(int))) == [0, 1]


def test_stop_at_the_first_block_past_the_limit(plate: Path) -> None:
    growth = (
        "max_kink_deg = 31.5\nstop_out_of_plane = true\n[fracture.fatigue]\n"
        f"C = 1e-20\nm = 2.0\nda_max = {0.1 * L}\nmax_blocks = 3"
    )
    text = scene(plate / "plate.msh", growth, bending_and_shear(), K_Ic=1e9)
    g, out = _run(plate, "bending", text)
    assert g["status"] == "out_of_plane" and g["increments"] == 1
    assert not g["fractured"] and g["fragments"] is None
    o = g["out_of_plane"]
    assert (o["increment"], o["point"], o["limit_deg"]) == (1, 1, 31.5)
    assert o["phi_deg"] == pytest.approx(90.0, abs=1e-9)
    assert abs(o["kink_deg"]) > 31.5
    assert (g["max_kink_deg"], g["max_kink_increment"]) == (abs(o["kink_deg"]), 1)
    t = read_table(out / "fracture.csv")
    inc = t["increment"].astype(int)
    assert inc.max() == 1 and list(t["status"][inc == 1]) == ["out_of_plane"] * 3
    assert np.abs(t["kink_deg"][inc == 0]).max() < 31.5  # below the limit at block 0
    assert g["cycles"] > 0 and g["cycles"] == g["history"][-1]["cycles"]
    assert np.all(t["cycles"][inc == 1] == g["cycles"])
    deep = np.abs(t["phi_deg"] - 90.0) < 1e-9
    assert np.all(np.abs(t["K_III"][deep]) < 0.05 * np.abs(t["K_II"][deep]))
    mts = _mts_kink(t["K_I"][deep], t["K_II"][deep])
    np.testing.assert_allclose(t["kink_deg"][deep], mts, atol=0.1)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "converged"
    text = summary["message"]
    assert "increment 1" in text and "point 1" in text and f"{o['kink_deg']:.1f} deg" in text
