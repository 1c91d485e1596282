"""When a growing surface crack has broken through (``through``) and when its grown crack
merely cannot be cut (runners.surface_crack3d.breaks_through; issue #26).

The plates of test_surface_crack_scene3d.py ([−b, b] × [−h, h] × [−t, 0], b = h = 2.5 mm,
boundary facets 0.4 mm; t = 1 mm and 0.4 mm) with the crack a = c = 0.2 mm on the front
face, front 0.02 mm: the integration domain r_out = 0.06 mm, the ligament a grown front
must keep to the surface ℓ = r_out + 2h = 0.1 mm.  On a flat plate the point of the front
nearest to the back face is the deepest, so the reference is geometric: a grown crack of
depth a has broken through iff a + ℓ > t.

* The family: grown cracks that stop short (a + ℓ ≤ t − 0.05 mm), whose ligament is below
  ℓ (the mouth cut, the deepest probe beyond the back face), and whose front has left
  the plate (a > t: the ellipse holds part of the back face, the mouth cannot be cut);
  each decided as the reference says.
* The same family with every cut failing (``cut_mouth`` replaced by one that raises):
  the cracks that have broken through are still ``through`` (the ellipse's arc inside
  the body, sampled), the others raise a RunError naming the crack, its depth and
  half-length and the cut's error — before, any failed cut was reported ``through``.
* The runner: a fatigue run whose first grown crack cannot be cut ends ``failed`` (not
  ``through``): the message names the crack and why, growth status ``failed``, not
  fractured, no fragments; fracture.csv holds the first solve's rows marked ``failed``
  with finite K; a run whose K cannot be evaluated (the front moved off its mesh) ends
  ``failed`` naming the front point; a grown crack that gmsh cannot mesh ends ``failed``
  (before: a SceneError, an input error, mid-run).  1, 2 and 3 ranks.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import run_dir, surface_plate, surface_scene, write_scene
from coupled_support import gmsh_on_rank0, read_csv

from bonecontact.common.errors import ParameterError, RunError
from bonecontact.fracture.surface_body3d import cut_mouth
from bonecontact.meshing.builder import MeshingError
from bonecontact.runners import run_scene, surface_crack3d
from bonecontact.runners.surface_crack3d import breaks_through, prepare_surface
from bonecontact.scene import load_scene

L = 1e-3
A = 0.2 * L
H_TIP = A / 10
LIGAMENT = 0.06 * L + 2 * H_TIP  # r_out + 2 h


@pytest.fixture(scope="module")
def plates(tmp_path_factory) -> Path:
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("through3d")) if comm.rank == 0 else None))
    gmsh_on_rank0(surface_plate(1.0 * L), d / "plate.msh", 3)
    gmsh_on_rank0(surface_plate(0.4 * L), d / "thin.msh", 3)
    return d


def _scene(d: Path, mesh: str, name: str, **kw):
    sub = run_dir(d, name)
    return load_scene(write_scene(sub / "scene.toml", surface_scene(d / mesh, **kw)))


@pytest.fixture(scope="module")
def runs(plates: Path) -> dict:
    """The prepared runs (the plate's boundary, the crack cut into it; nothing solved)."""
    comm = MPI.COMM_WORLD
    return {t: prepare_surface(_scene(plates, m, f"prep{t}"), comm) for t, m in THICK.items()}


THICK = {1.0: "plate.msh", 0.4: "thin.msh"}
#: (t, depth, half-length) in mm: stops short, ligament below ℓ, front beyond the back face
FAMILY = [
    (1.0, 0.30, 0.35),
    (1.0, 0.85, 0.90),
    (1.0, 0.95, 1.00),
    (1.0, 1.20, 1.30),
    (0.4, 0.25, 0.30),
    (0.4, 0.32, 0.40),
    (0.4, 0.50, 0.60),
]


def _grown(runs: dict, t: float, a: float, c: float):
    run = runs[t]
    return run, run.crack.grown(a * L, c * L)


@pytest.mark.parametrize(("t", "a", "c"), FAMILY)
def test_through_iff_the_ligament_is_gone(runs: dict, t: float, a: float, c: float) -> None:
    run, crack = _grown(runs, t, a, c)
    assert run.ligament == pytest.approx(LIGAMENT, rel=1e-12)
    assert breaks_through(run, crack) is ((a + 0.1) * L > t * L)


def test_a_front_beyond_the_back_face_cannot_be_cut(runs: dict) -> None:
    """a = 1.2 t: the ellipse holds part of the back face, so the real cut fails and the
    sampled arc decides (``through``: the deepest point lies outside)."""
    run, crack = _grown(runs, 1.0, 1.2, 1.3)
    with pytest.raises(ParameterError, match="half_length"):
        cut_mouth(run.body, crack, run.size)
    assert breaks_through(run, crack) is True


def _failing_cut(*args, **kwargs):
    raise ParameterError("half_length", "forced failure of the cut (test)")


@pytest.mark.parametrize(("t", "a", "c"), FAMILY)
def test_a_failed_cut_is_through_only_when_the_front_has_left(
    runs: dict, t: float, a: float, c: float, monkeypatch
) -> None:
    run, crack = _grown(runs, t, a, c)
    monkeypatch.setattr(surface_crack3d, "cut_mouth", _failing_cut)
    if (a + 0.1) * L > t * L:
        assert breaks_through(run, crack) is True
        return
    with pytest.raises(RunError) as err:
        breaks_through(run, crack)
    text = str(err.value)
    for part in ("'mouth'", f"depth {a * L:.6g} m", f"half-length {c * L:.6g} m", "forced"):
        assert part in text, text
    assert "not broken through" in text


def _fatigue(blocks: int = 2) -> str:
    return f"[fracture.fatigue]\nC = 1e-20\nm = 2.0\nda_max = {0.06 * L}\nmax_blocks = {blocks}"


def _run(scene) -> tuple:
    out = scene.path.parent / "out"
    res = run_scene(scene, MPI.COMM_WORLD, output=out, progress=False)
    return res, out


def test_run_whose_grown_crack_cannot_be_cut_fails(plates: Path, monkeypatch) -> None:
    """The first block's crack (a = 0.26 mm, far from the back face of the 1 mm plate)
    cannot be cut: the run fails with the message; the first solve's rows are kept."""
    real = surface_crack3d.cut_mouth

    def cut(body, crack, size=None):
        if crack.depth > A * (1 + 1e-9):
            _failing_cut()
        return real(body, crack, size)

    monkeypatch.setattr(surface_crack3d, "cut_mouth", cut)
    res, out = _run(_scene(plates, "plate.msh", "cutfail", growth=_fatigue(), h=A / 6))
    assert res.status == "failed"
    msg = res.summary["message"]
    assert "cannot be cut" in msg and "'mouth'" in msg and "stops after increment 0" in msg, msg
    g = res.summary["fracture"]["growth"]
    assert g["status"] == "failed" and not g["fractured"] and g["fragments"] is None
    assert g["increments"] == 0 and len(g["history"]) == 1
    tab = read_csv(out / "fracture.csv")
    assert np.all(np.isfinite(tab["K_I"])) and np.all(tab["K_I"] > 0)
    assert np.all(tab["increment"] == 0)
    MPI.COMM_WORLD.barrier()
    with open(out / "fracture.csv") as f:
        assert {line.rstrip().rsplit(",", 1)[1] for line in list(f)[1:]} == {"failed"}
    assert json.loads((out / "summary.json").read_text())["status"] == "failed"


def test_run_whose_k_cannot_be_evaluated_fails(plates: Path, monkeypatch) -> None:
    """K at a front point whose integration domain holds no cell (the block's front moved
    10 mm off the meshed crack): the run fails naming the point, not ZeroDivisionError."""
    real = surface_crack3d.front_interaction_integral

    def moved(u, block, phi, *args, **kwargs):
        centre = tuple(np.add(block.front.centre, (10 * L, 0.0, 0.0)))
        front = dataclasses.replace(block.front, centre=centre)
        return real(u, dataclasses.replace(block, front=front), phi, *args, **kwargs)

    monkeypatch.setattr(surface_crack3d, "front_interaction_integral", moved)
    res, out = _run(_scene(plates, "plate.msh", "nok", growth=_fatigue(), h=A / 6))
    assert res.status == "failed"
    msg = res.summary["message"]
    assert "no K at the front" in msg and "holds no cell" in msg and "phi = " in msg, msg
    assert len(read_csv(out / "fracture.csv")["K_I"]) == 0  # no row of the failed K


def test_run_whose_grown_crack_cannot_be_meshed_fails(plates: Path, monkeypatch) -> None:
    """The first block's crack is cut but gmsh fails on it: the run fails (it was a
    SceneError on ``depth``, an input error, with no summary.json); the first solve's rows
    stay, summary.json has the grown crack (the one to solve next) as the final one."""
    real = surface_crack3d.mesh_body_with_surface_crack

    def mesh(body, crack, size, comm):
        if crack.depth > A * (1 + 1e-9):
            raise MeshingError("forced meshing failure (test)")
        return real(body, crack, size, comm)

    monkeypatch.setattr(surface_crack3d, "mesh_body_with_surface_crack", mesh)
    res, out = _run(_scene(plates, "plate.msh", "meshfail", growth=_fatigue(), h=A / 6))
    assert res.status == "failed"
    msg = res.summary["message"]
    assert "increment 1" in msg and "cannot be meshed" in msg and "forced" in msg, msg
    g = res.summary["fracture"]["growth"]
    assert g["status"] == "failed" and g["increments"] == 1
    assert res.summary["fracture"]["crack"]["final"]["depth"] > A
    tab = read_csv(out / "fracture.csv")
    assert np.all(tab["increment"] == 0) and np.all(np.isfinite(tab["K_I"]))
