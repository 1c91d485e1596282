"""Restart of a growing surface crack (runners.growth_state3d, docs/checkpoint.md).

The semi-elliptical surface crack of test_surface_crack_scene3d.py (a = c = 0.2 mm in a
plate 1 mm thick, front a/6, three points) grown by two blocks of the Paris law
(da/dN = C ΔK², the fastest point 0.03 mm per block), a checkpoint after every increment
(``checkpoint_every = 1``).  The uninterrupted run is the serial one (rank 0 on
COMM_SELF; on one rank the run itself); its checkpoint before increment 1 is continued
on every rank of the session: fracture.csv (cut to the checkpoint's rows, then
appended), the growth history, the cycles and the final crack equal the uninterrupted
run's to 1e-10 of each column's largest value (the checkpoint's floats read back exactly
and the re-meshed body is the same on any number of ranks; on the same rank count the
continued run equals the uninterrupted one bit for bit).  A checkpoint of another crack
is refused (CheckpointError) before the table is touched.
"""

from __future__ import annotations

import json
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import (
    L,
    continued_run,
    copied_run,
    read_table,
    same_tables,
    surface_scene,
    uninterrupted_run,
    write_scene,
)

from bonecontact.common.errors import CheckpointError
from bonecontact.runners import run_scene
from bonecontact.scene import load_scene

H_FRONT = 0.2 * L / 6  # a/6
GROWTH = f"[fracture.fatigue]\nC = 1e-20\nm = 2.0\nda_max = {0.03 * L}\nmax_blocks = 2"


def _scene_text(mesh: Path, a: float = 0.2 * L) -> str:
    text = surface_scene(mesh, h=H_FRONT, points=3, growth=GROWTH, a=a)
    return text.replace("fields_every = 0", "fields_every = 0\ncheckpoint_every = 1")


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory) -> Path:
    """The serial run (on rank 0 alone when the session has more ranks)."""
    return uninterrupted_run(tmp_path_factory, "srestart", _scene_text)


def test_checkpoints_written(uninterrupted: Path) -> None:
    full = json.loads((uninterrupted / "full" / "summary.json").read_text())
    g = full["fracture"]["growth"]
    assert g["status"] == "max_blocks" and g["increments"] == 2
    ck = sorted(p.name for p in (uninterrupted / "full" / "checkpoints").iterdir())
    assert ck == ["increment_00001", "increment_00002"]
    state = json.loads((uninterrupted / "full" / "checkpoints" / ck[0] / "growth.json").read_text())
    assert state["increment"] == 1 and state["rows"] == 3 and len(state["history"]) == 1
    # what the restarts compare changes from increment to increment
    t = read_table(uninterrupted / "full" / "fracture.csv")
    K = t["K_I"].reshape(3, 3)
    assert np.all(np.abs(np.diff(K, axis=0)) > 1e-4 * np.abs(K).max())
    assert g["history"][1]["depth"] > g["history"][0]["depth"] and g["cycles"] > 0


@pytest.mark.parametrize("k", [1, 2])
def test_restart_equals_the_uninterrupted_run(uninterrupted: Path, k: int) -> None:
    full = uninterrupted / "full"
    _, out = continued_run(uninterrupted, full, k)
    same_tables(out / "fracture.csv", full / "fracture.csv")
    if MPI.COMM_WORLD.size == 1:  # the same rank count: bit for bit
        assert (out / "fracture.csv").read_bytes() == (full / "fracture.csv").read_bytes()
    got = json.loads((out / "summary.json").read_text())["fracture"]
    ref = json.loads((full / "summary.json").read_text())["fracture"]
    g, r = got["growth"], ref["growth"]
    assert (g["status"], g["increments"]) == (r["status"], r["increments"])
    assert g["cycles"] == pytest.approx(r["cycles"], rel=1e-10)
    for hg, hr in zip(g["history"], r["history"], strict=True):
        for key, v in hr.items():
            assert hg[key] == pytest.approx(v, rel=1e-10, abs=1e-300), key
    final_g, final_r = got["crack"]["final"], ref["crack"]["final"]
    for key in ("depth", "half_length"):
        assert final_g[key] == pytest.approx(final_r[key], rel=1e-10), key


def test_checkpoint_of_another_crack_is_refused(uninterrupted: Path) -> None:
    d = uninterrupted
    out = copied_run(d / "full", d / "other")
    scene = write_scene(out / "other.toml", _scene_text(d / "plate.msh", a=0.19 * L))
    ck = out / "checkpoints" / "increment_00001"
    with pytest.raises(CheckpointError, match="depth"):
        run_scene(load_scene(scene), MPI.COMM_WORLD, output=out, progress=False, restart=ck)
