"""3D scenes with a semi-elliptical surface crack (bonecontact.runners.surface_crack3d),
run through the runner of the ``bonecontact`` command.

The plate [−b, b] × [−h, h] × [−t, 0] (b = h = 2.5, boundary facets 0.4) of the
Newman–Raju references, in a scene: traction S on ``top`` (y = h) and −S on ``bottom``,
u = 0 on a 0.5 × 0.5 patch ``pin`` of the bottom face (self-equilibrated remote tension,
as bonecontact.verification.surface_crack's plate); the crack (a = c = 0.2, centre on the
front face z = 0, normal y; all lengths in mm) given by centre/normal/depth/
half_length.  References:

* stationary (and ``propagate`` with K_Ic above K: arrested at once): K_I against Newman
  and Raju's equation at the deepest point within 5 % (t = 1; measured −4.6 % on 2 ranks
  with HEAD's front3d.py), the others within 7 %;
  K_V of Schöllmann's σ₁′ criterion equals K_I within 1 % (mode I), kink below 2°;
* fatigue, da/dN = C ΔK² (R = 0): three blocks, the fastest point (here the points at
  20°: K 5 % above the deepest's) 0.04 per block; the cycles at the depths of the block
  ends agree with the same three-point growth integrated by RK4 with Newman and Raju's K
  (bonecontact.verification.surface_fatigue.newman_raju_growth) within 15 % (cycles go as
  K^−m, and compared at equal depth they also carry the FE deepest point's larger deficit:
  measured +12.9, +11.1, +5.9 % with HEAD's front3d.py (K 3–6 % low), +3.1 … +3.3 % with
  a working copy of front3d.py in progress on 2026-12-01), the
  half-length at those depths within 3 % (measured +1.4, +2.0, +0.9 %; +0.2 … +0.4 % with
  the working copy);
* a thin plate (t = 0.4): the second block would bring the front within r_out + 2h of the
  back face:
  status ``through``, the fragments the two halves of the plate (each 2b·h·t within 3 %:
  cells are counted by the side of their midpoint);
* boundary facets five times the crack: one block grows it (not "through");
* the crack surface and front VTK per increment; bad input: a centre off the surface.
"""

from __future__ import annotations

import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import run_dir, surface_plate, surface_scene
from coupled_support import gmsh_on_rank0, read_csv, run_text

from bonecontact.fracture.fatigue import ParisLaw
from bonecontact.scene import SceneError
from bonecontact.verification.surface_crack import surface_crack_k
from bonecontact.verification.surface_fatigue import newman_raju_growth

L = 1e-3  # the plate in millimetres
B = H = 2.5 * L
A = 0.2 * L
T = 1.0 * L
S = 1.0e6
E, NU = 17.0e9, 0.3


def _text(mesh: Path, **kw) -> str:
    return surface_scene(mesh, **({"E": E, "nu": NU, "S": S, "minus_S": -S, "a": A, "c": A} | kw))


@pytest.fixture(scope="module")
def plates(tmp_path_factory) -> Path:
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("surface3d")) if comm.rank == 0 else None))
    gmsh_on_rank0(surface_plate(T), d / "plate.msh", 3)
    gmsh_on_rank0(surface_plate(0.4 * L), d / "thin.msh", 3)
    gmsh_on_rank0(surface_plate(T, size=1.0 * L), d / "coarse.msh", 3)
    return d


def _run(d: Path, name: str, mesh: str = "plate.msh", **kw):
    sub = run_dir(d, name)
    res = run_text(_text(d / mesh, **kw), sub, sub / "out")
    return res, sub / "out"


def test_stationary_and_arrested_at_once(plates: Path) -> None:
    res, out = _run(plates, "arrest", growth=f"propagate = true\nincrement = {0.02 * L}")
    assert res.status == "converged", res.summary.get("message")
    tab = read_csv(out / "fracture.csv")
    phi = np.radians(tab["phi_deg"])
    ref = surface_crack_k(S, A, A, T, B, phi)
    deep = int(np.argmin(np.abs(phi - 0.5 * math.pi)))
    assert phi[deep] == pytest.approx(0.5 * math.pi, abs=1e-9)
    assert tab["K_I"][deep] == pytest.approx(ref[deep], rel=0.05)
    np.testing.assert_allclose(tab["K_I"], ref, rtol=0.07)
    np.testing.assert_allclose(tab["K_V"], tab["K_I"], rtol=0.01)
    assert np.max(np.abs(tab["kink_deg"])) < 2.0
    assert phi.min() >= math.radians(20.0) - 1e-9 and phi.max() <= math.radians(160.0) + 1e-9
    growth = res.summary["fracture"]["growth"]
    assert growth["status"] == "arrested" and growth["increments"] == 0
    if MPI.COMM_WORLD.rank == 0:
        assert "POLYGONS 1" in (out / "crack_surface_0.vtk").read_text()
        assert "SCALARS K_I double 1" in (out / "crack_front_0.vtk").read_text()


@pytest.mark.slow  # four re-meshed solves: 290 s on 1 rank at load 20
def test_fatigue_against_newman_raju_growth(plates: Path) -> None:
    C = 1e-20
    growth = f"[fracture.fatigue]\nC = {C}\nm = 2.0\nda_max = {0.04 * L}\nmax_blocks = 3"
    res, out = _run(plates, "fatigue", growth=growth)
    assert res.status == "converged", res.summary.get("message")
    g = res.summary["fracture"]["growth"]
    assert g["status"] == "max_blocks" and g["increments"] == 3
    hist = g["history"]
    depth = np.array([h["depth"] for h in hist])
    cycles = np.array([h["cycles"] for h in hist])
    c = np.array([h["half_length"] for h in hist])
    # a/c = 1: the points at 20 deg lead (K 5 % above the deepest point's); c grows by the
    # mean of its two ends, one of them the fastest
    lead = np.maximum(np.diff(depth), np.diff(c))  # c: the mean of the fastest end and the other
    assert np.all(lead <= 0.04 * L * (1 + 1e-9)) and np.all(lead > 0.95 * 0.04 * L)
    assert np.all(np.diff(depth) < np.diff(c))
    a_ref, c_ref, n_ref = newman_raju_growth(ParisLaw(C, 2.0), S, A, A, T, B, depth[-1])
    n_at = np.interp(depth, a_ref, n_ref)
    np.testing.assert_allclose(cycles[1:], n_at[1:], rtol=0.15)
    np.testing.assert_allclose(c, np.interp(depth, a_ref, c_ref), rtol=0.03)
    tab = read_csv(out / "fracture.csv")
    assert sorted(set(tab["increment"].astype(int))) == [0, 1, 2, 3]


@pytest.mark.slow  # three re-meshed solves
def test_through_the_thin_plate_reports_the_fragments(plates: Path) -> None:
    growth = f"[fracture.fatigue]\nC = 1e-20\nm = 2.0\nda_max = {0.06 * L}\nmax_blocks = 5"
    res, _ = _run(plates, "through", mesh="thin.msh", growth=growth)
    assert res.status == "converged", res.summary.get("message")
    g = res.summary["fracture"]["growth"]
    assert g["status"] == "through" and g["fractured"]
    vols = [f["volume"] for f in g["fragments"]]
    np.testing.assert_allclose(vols, 2 * B * H * 0.4 * L, rtol=0.03)
    assert g["cycles"] > 0
    # the block that carries it through: da_max at the last solve's leading rate, on top
    # of the cycles to that solve
    fb, before = g["final_block"], g["history"][-1]["cycles"]
    assert fb["da"] == 0.06 * L and fb["cycles"] == pytest.approx(fb["da"] / fb["rate"])
    assert g["cycles"] == pytest.approx(before + fb["cycles"], rel=1e-12)
    assert fb["share"] == pytest.approx(fb["cycles"] / g["cycles"], rel=1e-12)
    assert 0 < fb["cycles_trend"] <= fb["cycles"]  # K rises towards the back face


def test_grown_crack_on_coarse_facets_is_not_through(plates: Path) -> None:
    """Boundary facets (1 mm) five times the crack (0.2 mm): the grown crack's mouth is cut
    into the boundary refined near it, as the mesh is, so that the check for a front
    leaving the body does not stop the run "through" after the first block (it did when
    the mouth was cut into the unrefined facets: no facet edge crossed the small ellipse)."""
    growth = f"[fracture.fatigue]\nC = 1e-20\nm = 2.0\nda_max = {0.04 * L}\nmax_blocks = 1"
    centre = f"[{0.3137 * L}, 0.0, 0.0]"  # off the facets' vertices
    res, _ = _run(plates, "coarse", mesh="coarse.msh", growth=growth, centre=centre)
    assert res.status == "converged", res.summary.get("message")
    g = res.summary["fracture"]["growth"]
    assert g["status"] == "max_blocks" and g["increments"] == 1
    assert g["history"][-1]["depth"] > A


def test_centre_off_the_surface_is_refused(plates: Path) -> None:
    with pytest.raises(SceneError, match="centre"):
        _run(plates, "off", centre=f"[0.0, 0.0, {-0.6 * L}]")
