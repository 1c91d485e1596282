"""Restart of a surface crack grown out of its plane (runners.nonplanar_surface3d with
runners.growth_state3d; docs/checkpoint.md).

The plate of test_nonplanar_surface_scene3d.py (1 mm thick, boundary facets 0.4 mm,
tension 1 MPa along y), its semi-circular crack a = c = 0.3 mm inclined at 45° to the
load (normal (0, cos 45°, sin 45°): modes I, II and III along the front, so the grown
crack leaves its plane and the checkpoint holds a non-planar crack), front a/14, grown by
three blocks of the Paris law (da/dN = C ΔK², the fastest vertex 0.03 mm a block), a
checkpoint after every advance (``checkpoint_every = 1``: before the solves 1, 2, 3).
The uninterrupted run is the serial one (rank 0 on COMM_SELF; on one rank the run
itself); its checkpoints before increments 1 and 2 are continued on every rank of the
session: fracture.csv (cut to the checkpoint's rows, then appended), the cycles, the
growth history and the final front equal the uninterrupted run's to 1e-10 (the
checkpoint's floats read back exactly and the re-meshed body is the same on any number
of ranks; on one rank the continued table is the uninterrupted one byte for byte).  A
checkpoint of another crack is refused (CheckpointError naming the differing key) before
the table is touched.
"""

from __future__ import annotations

import json
import math
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

A = 0.3 * L
BLOCKS = 3
GROWTH = (
    'surface_growth = "nonplanar"\n[fracture.fatigue]\nC = 1e-20\nm = 2.0\n'
    f"da_max = {0.03 * L}\nmax_blocks = {BLOCKS}"
)
NORMAL = [0.0, math.cos(math.radians(45.0)), math.sin(math.radians(45.0))]


def _scene_text(mesh: Path, a: float = A) -> str:
    text = surface_scene(mesh, h=A / 14, points=5, growth=GROWTH, a=a, c=a)
    text = text.replace("normal = [0.0, 1.0, 0.0]", f"normal = {NORMAL}")
    return text.replace("fields_every = 0", "fields_every = 0\ncheckpoint_every = 1")


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory) -> Path:
    """The serial run (on rank 0 alone when the session has more ranks)."""
    return uninterrupted_run(tmp_path_factory, "nprestart", _scene_text)


def test_checkpoints_hold_the_turned_crack(uninterrupted: Path) -> None:
    """One checkpoint per advance (the last before the solve that stops); the crack it
    stores has left the initial plane (front normals off the initial one: what a restart
    must carry)."""
    full = uninterrupted / "full"
    g = json.loads((full / "summary.json").read_text())["fracture"]["growth"]
    assert (g["model"], g["status"], g["increments"]) == ("nonplanar", "max_blocks", BLOCKS)
    ck = sorted(p.name for p in (full / "checkpoints").iterdir())
    assert ck == [f"increment_{k:05d}" for k in range(1, BLOCKS + 1)]
    state = json.loads((full / "checkpoints" / ck[-2] / "growth.json").read_text())
    assert state["kind"] == "nonplanar_surface_crack" and state["increment"] == BLOCKS - 1
    t = read_table(full / "fracture.csv")
    edges = int(np.sum(t["increment"] == 0))
    assert edges >= 5 and len(t["increment"]) == (BLOCKS + 1) * edges
    assert state["rows"] == (BLOCKS - 1) * edges and len(state["history"]) == BLOCKS - 1
    n2 = np.asarray(state["crack"]["normals2"])
    off = np.degrees(np.arccos(np.clip(np.abs(n2 @ np.asarray(NORMAL)), 0.0, 1.0)))
    assert off.max() > 5.0  # the grown strips have turned away from the 45 deg plane
    K = t["K_II"].reshape(BLOCKS + 1, edges)
    assert np.all(np.abs(np.diff(K, axis=0)) > 1e-4 * np.abs(K).max())  # K changes


@pytest.mark.parametrize("k", [1, 2])
def test_restart_equals_the_uninterrupted_run(uninterrupted: Path, k: int) -> None:
    full = uninterrupted / "full"
    _, out = continued_run(uninterrupted, full, k)
    same_tables(out / "fracture.csv", full / "fracture.csv")
    if MPI.COMM_WORLD.size == 1:  # the same rank count: byte for byte
        assert (out / "fracture.csv").read_bytes() == (full / "fracture.csv").read_bytes()
    got = json.loads((out / "summary.json").read_text())["fracture"]
    ref = json.loads((full / "summary.json").read_text())["fracture"]
    g, r = got["growth"], ref["growth"]
    assert (g["status"], g["increments"]) == (r["status"], r["increments"])
    assert g["cycles"] == pytest.approx(r["cycles"], rel=1e-10)
    for hg, hr in zip(g["history"], r["history"], strict=True):
        for key, v in hr.items():
            assert hg[key] == pytest.approx(v, rel=1e-10, abs=1e-300), key
    np.testing.assert_allclose(got["crack"]["front"], ref["crack"]["front"], rtol=0, atol=1e-10 * A)


def test_checkpoint_of_another_crack_is_refused(uninterrupted: Path) -> None:
    d = uninterrupted
    out = copied_run(d / "full", d / "other")  # every rank reads the copied table
    rows = (out / "fracture.csv").read_bytes()
    scene = write_scene(out / "other.toml", _scene_text(d / "plate.msh", a=0.29 * L))
    ck = out / "checkpoints" / "increment_00001"
    with pytest.raises(CheckpointError, match="depth"):
        run_scene(load_scene(scene), MPI.COMM_WORLD, output=out, progress=False, restart=ck)
    MPI.COMM_WORLD.barrier()
    assert (out / "fracture.csv").read_bytes() == rows
