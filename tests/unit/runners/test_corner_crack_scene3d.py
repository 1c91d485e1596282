"""3D scenes with a quarter-elliptical corner crack (``shape = "quarter_elliptical"``,
bonecontact.runners.surface_crack3d), run through the runner of the ``bonecontact``
command.

The plate [−b, b] × [−h, h] × [−t, 0] (b = h = 2.5, t = 1, boundary facets 0.4; all
lengths in mm) of the surface-crack scenes (``_crack_scenes.surface_plate``): traction S on
``top`` and −S on ``bottom``, held on a patch of the bottom face (self-equilibrated remote
tension).  The crack, normal y, is centred on the edge x = −b, z = 0 where the side face
x = −b meets the front face z = 0: ``length`` c along ``axis`` = +x on the front face,
``depth`` a along −z on the side face; the front a quarter ellipse from one face to the
other.  Reference: Newman and Raju's corner-crack equation (1986;
bonecontact.verification.surface_crack.corner_crack_k, the plate's whole width 2b) at
Newman and Raju's angle ψ of each front point (ψ = 0 on the front face, 90° on the side
face; from the point's coordinates: tan ψ = (−z/a)/((x + b)/c)).

* A family, a/t = 0.2 and less (front a/10, the scene's default): every front point —
  from 10° off each face (or two and a half front elements, if more) on, the 45° point
  included — within 5 % of Newman and Raju; K_II and K_III below 5 % of K_I; K_V equals K_I
  within 1 %.  Measured 2026-12-04 (ψ ≈ 14°, 29°, 45°, 61°, 76°), K_I/K_NR − 1 in %:
  a/c = 1, a/t = 0.2: −0.8, −1.2, −1.9, −0.1, −1.7; a/c = 0.5, a/t = 0.2: −0.5, −1.8, −1.0,
  −2.6, −3.8; a/c = 0.5, a/t = 0.15: −2.0, −1.7, −1.7, −1.6, −2.5; the same K on 1, 2 and
  3 ranks to 7e-14 of the largest K_I; 1–2.5 s a case serially.
* Fatigue (two blocks): c and a grow from the K_V of the points nearest their faces, by
  hand from fracture.csv; continued from its checkpoint before the second block it is
  the same run (the checkpoint keeps the shape).
* Bad input: a centre off the edge (the middle of the front face) and an ``axis`` along
  no face are refused naming the key, as is a semi-elliptical crack centred on the edge
  (key ``centre``, pointing at ``quarter_elliptical``).
"""

from __future__ import annotations

import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import (
    continued_run,
    idle_barrier,
    run_dir,
    same_tables,
    surface_plate,
    surface_scene,
)
from coupled_support import gmsh_on_rank0, read_csv, run_text

from bonecontact.scene import SceneError
from bonecontact.verification.surface_crack import corner_crack_k

L = 1e-3  # the plate in millimetres
B = 2.5 * L
T = 1.0 * L
S = 1.0e6
EDGE = f"[{-B}, 0.0, 0.0]"
#: K_I against Newman–Raju at every front point (from 10° off each face on).
TOL = 0.05


def corner_text(mesh: Path, a: float, c: float, **kw) -> str:
    """A corner-crack scene on ``mesh``: the semi-elliptical scene of ``_crack_scenes``
    with ``shape = "quarter_elliptical"``, ``length`` c and ``axis`` +x (``kw``: the
    placeholders of ``surface_scene``, ``axis`` the axis's text)."""
    axis = kw.pop("axis", "[1.0, 0.0, 0.0]")
    text = surface_scene(mesh, **({"a": a, "c": c, "h": min(a, c) / 10, "centre": EDGE} | kw))
    text = text.replace('shape = "semi_elliptical"', 'shape = "quarter_elliptical"')
    return text.replace(f"half_length = {c}\n", f"length = {c}\naxis = {axis}\n")


@pytest.fixture(scope="module")
def plate(tmp_path_factory) -> Path:
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("corner3d")) if comm.rank == 0 else None))
    gmsh_on_rank0(surface_plate(T), d / "plate.msh", 3)
    return d


def _run(d: Path, name: str, text: str):
    sub = run_dir(d, name)
    return run_text(text, sub, sub / "out"), sub / "out"


def nr_angle(tab: dict, a: float, c: float) -> np.ndarray:
    """Newman and Raju's ψ of the front points (from their coordinates)."""
    return np.arctan2(-tab["z"] / a, (tab["x"] + B) / c)


@pytest.mark.parametrize(
    ("a", "c"),
    [(0.2 * L, 0.2 * L), (0.2 * L, 0.4 * L), (0.15 * L, 0.3 * L)],
    ids=["a/c=1,a/t=0.2", "a/c=0.5,a/t=0.2", "a/c=0.5,a/t=0.15"],
)
def test_corner_crack_against_newman_raju(plate: Path, a: float, c: float) -> None:
    res, out = _run(plate, f"corner_{a / L:g}_{c / L:g}", corner_text(plate / "plate.msh", a, c))
    assert res.status == "converged", res.summary.get("message")
    assert res.summary["fracture"]["crack"]["shape"] == "quarter_elliptical"
    tab = read_csv(out / "fracture.csv")
    psi = nr_angle(tab, a, c)
    ref = corner_crack_k(S, a, c, T, 2 * B, psi)
    err = tab["K_I"] / ref - 1.0
    mid = int(np.argmin(np.abs(psi - 0.25 * math.pi)))
    if MPI.COMM_WORLD.rank == 0:
        print(
            f"\ncorner a={a / L:g} c={c / L:g} mm: psi {np.round(np.degrees(psi), 2)} deg, "
            f"K_I/K_NR - 1 {np.round(100 * err, 2)} %, 45 deg: K_I {tab['K_I'][mid]:.6g} "
            f"K_NR {ref[mid]:.6g}"
        )
    assert psi[mid] == pytest.approx(0.25 * math.pi, abs=1e-6)
    assert psi.min() >= math.radians(10.0) - 1e-6 and psi.max() <= math.radians(80.0) + 1e-6
    assert np.all(np.abs(err) <= TOL), np.round(100 * err, 2)
    assert np.max(np.abs(tab["K_II"])) < 0.05 * np.min(tab["K_I"])
    assert np.max(np.abs(tab["K_III"])) < 0.05 * np.min(tab["K_I"])
    np.testing.assert_allclose(tab["K_V"], tab["K_I"], rtol=0.01)


def test_centre_off_the_edge_is_refused(plate: Path) -> None:
    text = corner_text(plate / "plate.msh", 0.2 * L, 0.2 * L, centre="[0.0, 0.0, 0.0]")
    with pytest.raises(SceneError, match=r"centre.*edge"):
        _run(plate, "off_edge", text)


def test_semi_elliptical_crack_on_the_edge_is_refused(plate: Path) -> None:
    """Before the corner crack a semi-elliptical crack there was accepted with its depth
    along the faces' mean normal (the diagonal) and its ellipse along neither face."""
    text = surface_scene(plate / "plate.msh", a=0.2 * L, c=0.4 * L, h=0.02 * L, centre=EDGE)
    with pytest.raises(SceneError, match=r"centre.*edge.*quarter_elliptical"):
        _run(plate, "semi_on_edge", text)


def test_axis_along_no_face_is_refused(plate: Path) -> None:
    diagonal = "[0.7071067811865476, 0.0, -0.7071067811865476]"
    text = corner_text(plate / "plate.msh", 0.2 * L, 0.2 * L, axis=diagonal)
    with pytest.raises(SceneError, match=r"axis.*along one of the faces"):
        _run(plate, "diagonal", text)


def test_fatigue_grows_a_and_c_from_the_points_near_the_faces(plate: Path) -> None:
    """Two blocks of da/dN = C ΔK² (R = 0): c grows from the point nearest the face of c,
    a from the one nearest the face of a (the 45° point is reported, not grown); the
    faster by da_max, the other by da_max (K_V,other/K_V,faster)² — by hand from
    fracture.csv; a block's cycles near da_max over the faster rate."""
    a, c, C, da = 0.2 * L, 0.4 * L, 1e-20, 0.04 * L
    growth = f"[fracture.fatigue]\nC = {C}\nm = 2.0\nda_max = {da}\nmax_blocks = 2"
    text = corner_text(plate / "plate.msh", a, c, growth=growth)
    text = text.replace("fields_every = 0", "fields_every = 0\ncheckpoint_every = 1")
    res, out = _run(plate, "fatigue", text)
    assert res.status == "converged", res.summary.get("message")
    g = res.summary["fracture"]["growth"]
    assert g["status"] == "max_blocks" and g["increments"] == 2
    tab = read_csv(out / "fracture.csv")
    depth, length, cycles = a, c, 0.0
    for inc, h in enumerate(g["history"][:2]):
        rows = tab["increment"] == inc
        psi = nr_angle({k: v[rows] for k, v in tab.items()}, depth, length)
        kv = tab["K_V"][rows]
        k_c, k_a = kv[np.argmin(psi)], kv[np.argmax(psi)]
        rate_c, rate_a = C * k_c**2, C * k_a**2
        lead = max(rate_c, rate_a)
        # the advances on a grid of ~1e-6 of da_max (on_advance_grid); the blocks' cycles
        # by block_cycles' rule over the rates at both ends (here: at the start, 15 %)
        assert h["depth"] == pytest.approx(depth, rel=1e-6)
        assert h["half_length"] == pytest.approx(length, rel=1e-6)
        assert h["cycles"] == pytest.approx(cycles, rel=0.15)
        depth, length = depth + da * rate_a / lead, length + da * rate_c / lead
        cycles += da / lead
    final = res.summary["fracture"]["crack"]["final"]
    assert final["depth"] == pytest.approx(depth, rel=1e-5)
    assert final["half_length"] == pytest.approx(length, rel=1e-5)
    # a restart from the checkpoint before block 2 goes on as a corner crack, the same run
    again, cont = continued_run(plate / "fatigue", out, 1)
    idle_barrier(MPI.COMM_WORLD)
    assert again.summary["fracture"]["crack"]["final"] == res.summary["fracture"]["crack"]["final"]
    assert again.summary["fracture"]["growth"]["cycles"] == pytest.approx(g["cycles"], rel=1e-10)
    same_tables(cont / "fracture.csv", out / "fracture.csv")
