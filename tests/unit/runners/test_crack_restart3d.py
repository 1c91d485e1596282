"""Checkpoints and restarts of a 3D crack scene (bonecontact.runners.cracks3d).

The penny of test_crack_scene3d.py (a = 1 mm, block of 8a, front a/6, 4 front points)
under tension in 3 static load steps (σ/3, 2σ/3, σ), checkpoints every step:

* the uninterrupted run writes three checkpoints (the newest two kept) with the crack's
  geometry, and K_I grows with the load (K_I ∝ σ: step 3 / step 1 = 3 to 10⁻⁶);
* the run continued from the checkpoint of step 2 (the body meshed around the stored
  crack again, the state read, the tables cut after step 2) writes the front and K of
  step 3 equal to the uninterrupted run's to 10⁻¹⁰ relative (1, 2 and 3 ranks: each
  against its own uninterrupted run), every row once;
* a checkpoint continued by a scene with another crack (radius 1.1a) is refused with a
  CheckpointError naming the key, before anything is changed.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import write_scene
from coupled_support import gmsh_on_rank0, read_csv

from bonecontact.common.errors import CheckpointError
from bonecontact.runners.dispatch import run_scene
from bonecontact.scene import load_scene
from bonecontact.verification.problems import crack_block_model, crack_block_scene

A = 1.0e-3
W = 4 * A


def _text(mesh: Path, radius: float = A) -> str:
    text = crack_block_scene(
        str(mesh),
        f"centre = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = {radius!r}",
        E=17.0e9,
        nu=0.3,
        sigma=1.0e6,
        h=A / 6,
        points=4,
    )
    text = text.replace("load_steps = 1", "load_steps = 3")
    return text.replace("fields_every = 0", "fields_every = 0\ncheckpoint_every = 1")


@pytest.fixture(scope="module")
def case(tmp_path_factory) -> dict:
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("restart3d")) if comm.rank == 0 else None))
    gmsh_on_rank0(lambda gmsh: crack_block_model(W), d / "block.msh", 3)
    scene = write_scene(d / "scene.toml", _text(d / "block.msh"))
    out = d / "full"
    res = run_scene(load_scene(scene), comm, output=out, progress=False)
    assert res.status == "converged", res.summary.get("message")
    return {"dir": d, "scene": scene, "full": out, "summary": res.summary}


def test_uninterrupted_run_checkpoints_every_step(case: dict) -> None:
    s = case["summary"]
    assert s["checkpoints"]["written"] == 3
    meta = json.loads((case["full"] / "checkpoints" / "step_00000002" / "meta.json").read_text())
    assert meta["crack_run"]["crack"]["shape"] == "disc"
    assert meta["crack_run"]["crack"]["semi_axes"] == [A, A]
    tab = read_csv(case["full"] / "fracture.csv")
    k1, k3 = tab["K_I"][tab["step"] == 1], tab["K_I"][tab["step"] == 3]
    np.testing.assert_allclose(k3 / k1, 3.0, rtol=1e-6)  # linear elastic, open crack


def _copy_to(case: dict, name: str) -> Path:
    out = case["dir"] / name
    if MPI.COMM_WORLD.rank == 0:
        shutil.copytree(case["full"], out)
    MPI.COMM_WORLD.barrier()
    return out


def test_restart_from_step_2_gives_the_same_fronts(case: dict) -> None:
    out = _copy_to(case, "restarted")
    ck = out / "checkpoints" / "step_00000002"
    res = run_scene(
        load_scene(case["scene"]), MPI.COMM_WORLD, output=out, progress=False, restart=ck
    )
    assert res.status == "converged", res.summary.get("message")
    assert res.summary["restarted_from"]["step"] == 2
    ref, got = read_csv(case["full"] / "fracture.csv"), read_csv(out / "fracture.csv")
    assert list(got["step"]) == list(ref["step"])  # every row once
    for col in ("x", "y", "z", "phi_deg", "K_I", "K_II", "K_III", "G"):
        scale = np.max(np.abs(ref[col])) or 1.0
        np.testing.assert_allclose(got[col], ref[col], rtol=1e-10, atol=1e-10 * scale)


def test_restart_with_another_crack_is_refused(case: dict) -> None:
    out = _copy_to(case, "other")
    scene = write_scene(case["dir"] / "other.toml", _text(case["dir"] / "block.msh", 1.1 * A))
    before = (out / "fracture.csv").read_text()
    with pytest.raises(CheckpointError, match="semi_axes"):
        run_scene(load_scene(scene), MPI.COMM_WORLD, output=out, progress=False, restart=True)
    assert (out / "fracture.csv").read_text() == before
