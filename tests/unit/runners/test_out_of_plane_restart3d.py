"""Restart of a growing surface crack keeps the record of the planar model's validity
(``fracture.growth`` ``max_kink_deg`` and ``out_of_plane``; issue #26).

The bending-and-shear scene of test_out_of_plane3d.py (the deepest point's σ₁′ kink grows
from block to block: 30.1°, 33.2°, 35.8° measured) at ``max_kink_deg = 31.5`` without
``stop_out_of_plane``: two blocks, a checkpoint after every increment; ``out_of_plane``
is set at block 1 and the run goes on to ``max_blocks``.  Continued from the checkpoint
before increment 1 (saved before the flag: it must be set by the continued run) and
from the one before increment 2 (saved after it: it must come back from the checkpoint,
with no second warning), on every rank of the session, the summary's ``max_kink_deg``,
``max_kink_increment``, ``out_of_plane`` and fracture.csv equal the uninterrupted
serial run's (1e-10).  About 25 s serial.
"""

from __future__ import annotations

import json
import shutil
import warnings
from pathlib import Path

from mpi4py import MPI

import pytest
from _crack_scenes import (
    L,
    idle_barrier,
    run_dir,
    run_serial_on_rank0,
    same_tables,
    surface_plate,
    write_scene,
)
from coupled_support import gmsh_on_rank0
from test_out_of_plane3d import bending_and_shear, scene

from bonecontact.runners import run_scene
from bonecontact.runners.surface_crack3d import PlanarModelWarning
from bonecontact.scene import load_scene

GROWTH = (
    "max_kink_deg = 31.5\n[fracture.fatigue]\n"
    f"C = 1e-20\nm = 2.0\nda_max = {0.1 * L}\nmax_blocks = 2"
)


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory) -> Path:
    """The serial run with checkpoints (on rank 0 alone when the session has more)."""
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("ooprestart")) if comm.rank == 0 else None))
    gmsh_on_rank0(surface_plate(1.0 * L), d / "plate.msh", 3)
    text = scene(d / "plate.msh", GROWTH, bending_and_shear(), K_Ic=1e9)
    text = text.replace("fields_every = 0", "fields_every = 0\ncheckpoint_every = 1")
    path = write_scene(d / "scene.toml", text)
    res = run_serial_on_rank0(path, d / "full")
    if res is not None:
        assert res.status == "converged", res.summary.get("message")
    return d


def _growth(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())["fracture"]["growth"]


def test_the_flag_is_set_and_the_run_goes_on(uninterrupted: Path) -> None:
    g = _growth(uninterrupted / "full")
    assert g["status"] == "max_blocks" and g["increments"] == 2
    assert g["out_of_plane"]["increment"] == 1 and g["out_of_plane"]["point"] == 1
    assert g["max_kink_increment"] == 2 and g["max_kink_deg"] > abs(g["out_of_plane"]["kink_deg"])
    ck = uninterrupted / "full" / "checkpoints"
    states = [json.loads((ck / f"increment_{k:05d}" / "growth.json").read_text()) for k in (1, 2)]
    assert states[0]["out_of_plane"] is None and states[0]["max_kink"]["increment"] == 0
    assert states[1]["out_of_plane"] == g["out_of_plane"]


@pytest.mark.parametrize("k", [1, 2])
def test_restart_keeps_the_record(uninterrupted: Path, k: int) -> None:
    d = uninterrupted
    out = run_dir(d, f"continued{k}")
    if MPI.COMM_WORLD.rank == 0:
        shutil.rmtree(out)
        shutil.copytree(d / "full", out)
    MPI.COMM_WORLD.barrier()
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always", PlanarModelWarning)
        res = run_scene(
            load_scene(d / "scene.toml"),
            MPI.COMM_WORLD,
            output=out,
            progress=False,
            restart=out / "checkpoints" / f"increment_{k:05d}",
        )
    assert res.status == "converged", res.summary.get("message")
    said = [w for w in seen if w.category is PlanarModelWarning]
    assert len(said) == int(k == 1 and MPI.COMM_WORLD.rank == 0)
    idle_barrier(MPI.COMM_WORLD)
    same_tables(out / "fracture.csv", d / "full" / "fracture.csv")
    got, want = _growth(out), _growth(d / "full")
    assert (got["status"], got["increments"]) == (want["status"], want["increments"])
    assert got["max_kink_increment"] == want["max_kink_increment"]
    assert got["max_kink_deg"] == pytest.approx(want["max_kink_deg"], rel=1e-10)
    assert got["out_of_plane"].keys() == want["out_of_plane"].keys()
    for key, v in want["out_of_plane"].items():
        assert got["out_of_plane"][key] == pytest.approx(v, rel=1e-10), key
