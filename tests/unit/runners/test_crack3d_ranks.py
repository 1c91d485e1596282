"""Every kind of 3D crack scene gives the same answer on 2 and 3 ranks as on one
(issue 26): the scene run on ``MPI.COMM_WORLD`` against the same scene run on rank 0
alone (``MPI.COMM_SELF``) in the same session, at reduced sizes (coarse fronts, K at
one front point of each interior crack, at three of the surface crack).  The re-meshed
body is the same on any number of ranks (gmsh on rank 0 from the boundary gathered in a
canonical order), so every number of ``fracture.csv``
(front points, K_I, K_II, K_III, G, the displacement-correlation cross-check, the kink,
the cycles) and of the growth history must agree to round-off: 1e-10 of the column's
largest value (of the largest |K| for the K columns).  A grown crack too: its advances
are rounded to a grid before gmsh meshes it (runners.surface_crack3d; without that, the
K's round-off reached gmsh and the grown crack's K differed by 1.4e-10 of the largest K).

The family (the closed forms of each kind are checked by their own modules:
test_crack_scene3d.py, test_crack_scene3d_several.py, test_crack_restart3d.py,
test_surface_crack_scene3d.py):

* ``interior``: two interior planar cracks in one block under tension in two load
  steps — a penny normal to the load and an ellipse inclined at 30° (mixed mode I, II,
  III) — with checkpoints; and the run continued on n ranks from the serial run's
  checkpoint of step 1 equals the serial run's step 2 (checkpoints continue on any number
  of ranks);
* ``closed``: a penny inclined at 45°, closed by compression, Coulomb faces (μ = 0.3):
  the PDAS contact solution and the recovered face tractions of the face term;
* ``surface fatigue``: a semi-elliptical surface crack (a = c = 0.2 mm in a plate 1 mm
  thick, front a/6, 3 points) grown by one block of the Paris law: K of the first solve,
  the cycles of the block, the grown crack (the body re-meshed around it) and its K.  The
  growth under one load (``propagate``) takes the same path but for the rates of the
  three points (``(K_V/K_V,max)²`` of those at K_Ic);
* ``interior fatigue``: a penny (radius a, front a/7: the heptagon)
  grown by one block of the Paris law (m = 3, R = 0.1): K of every mid-edge, the block's
  cycles, the grown front (re-meshed) and its K (test_crack_fatigue_scene3d.py checks it
  against the closed form).

The corner and through cracks and the front advance of a penny (verification modules)
have their own rank comparisons: tests/verification/test_fracture_surface3d.py
(``test_same_on_every_partition``, ``test_through_crack_same_on_every_partition``),
test_fracture_advance3d.py (``test_mixed_advance_same_on_any_rank_count``) and
test_fracture_front3d.py (``test_penny_same_on_every_partition``).

On one rank the module is skipped (there is nothing to compare).
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

from mpi4py import MPI

import pytest
from _crack_scenes import (
    L,
    run_dir,
    run_serial_on_rank0,
    same_tables,
    surface_plate,
    surface_scene,
    write_scene,
)
from coupled_support import gmsh_on_rank0

from bonecontact.runners import run_scene
from bonecontact.scene import load_scene
from bonecontact.verification.problems import crack_block_model, crack_block_scene

pytestmark = pytest.mark.skipif(
    MPI.COMM_WORLD.size == 1, reason="compares a distributed run with a serial one"
)

A = 1.0e-3  # the interior cracks' length scale (m)
W = 4 * A  # half-width of the block
RTOL = 1e-10
S30, C30 = math.sin(math.radians(30.0)), math.cos(math.radians(30.0))
S45 = math.sqrt(0.5)


def _interior(d: Path) -> str:
    """A penny (radius a at x = −2a, normal z) and an ellipse (a × 0.95a at x = 2a, normal
    at 30° to z) in tension, front a/7, two load steps, a checkpoint every step."""
    first = f"centre = [{-2 * A!r}, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = {A!r}"
    second = (
        'region = "block"\nfront_points = 1\n[[crack]]\nname = "ellipse"\nshape = "ellipse"\n'
        f"centre = [{2 * A!r}, 0.0, 0.0]\nnormal = [{S30!r}, 0.0, {C30!r}]\n"
        f"semi_axes = [{A!r}, {0.95 * A!r}]\naxis = [0.0, 1.0, 0.0]"
    )
    text = crack_block_scene(
        str(d / "block.msh"), f"{first}\n{second}", E=17.0e9, nu=0.3, sigma=1.0e6, h=A / 7, points=1
    )
    text = text.replace("load_steps = 1", "load_steps = 2")
    return text.replace("fields_every = 0", "fields_every = 0\ncheckpoint_every = 1")


def _closed(d: Path) -> str:
    """The penny (radius a) at 45° closed by compression, Coulomb faces μ = 0.3."""
    geometry = f"centre = [0.0, 0.0, 0.0]\nnormal = [{S45!r}, 0.0, {S45!r}]\nradius = {A!r}"
    return crack_block_scene(
        str(d / "block.msh"),
        geometry,
        E=17.0e9,
        nu=0.3,
        sigma=-1.0e6,
        h=A / 6,
        points="1\ncoefficient = 0.3",
    )


def _surface_fatigue(d: Path) -> str:
    """One block of da/dN = C ΔK² (R = 0) advancing the fastest point by 0.03 mm."""
    growth = f"[fracture.fatigue]\nC = 1e-20\nm = 2.0\nda_max = {0.03 * L}\nmax_blocks = 1"
    return surface_scene(d / "plate.msh", h=0.2 * L / 6, points=3, growth=growth)


def _interior_fatigue(d: Path) -> str:
    """One block of da/dN = C ΔK³ (R = 0.1) advancing the fastest vertex by 0.1a."""
    geometry = f"centre = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = {A!r}"
    text = crack_block_scene(
        str(d / "block.msh"), geometry, E=17.0e9, nu=0.3, sigma=1.0e6, h=A / 7, points=1
    )
    growth = (
        f"[fracture.fatigue]\nC = 1e-20\nm = 3.0\nR = 0.1\nda_max = {0.1 * A!r}\nmax_blocks = 1"
    )
    return text.replace("[[crack]]", f"{growth}\n[[crack]]", 1)


CASES = {
    "interior": _interior,
    "closed": _closed,
    "surface_fatigue": _surface_fatigue,
    "interior_fatigue": _interior_fatigue,
}


@pytest.fixture(scope="module")
def meshes(tmp_path_factory) -> Path:
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("ranks3d")) if comm.rank == 0 else None))
    gmsh_on_rank0(lambda gmsh: crack_block_model(W), d / "block.msh", 3)
    gmsh_on_rank0(surface_plate(1.0 * L), d / "plate.msh", 3)
    return d


def _same_summary(got: dict, ref: dict) -> None:
    """The same dofs, status and (growth runs) history, numbers to RTOL."""
    assert got["status"] == ref["status"] == "converged"
    assert got.get("dofs") == ref.get("dofs")
    g, r = got["fracture"].get("growth"), ref["fracture"].get("growth")
    assert (g is None) == (r is None)
    if r is None:
        return
    assert g["status"] == r["status"] and g["increments"] == r["increments"]
    for hg, hr in zip(g["history"], r["history"], strict=True):
        for key, v in hr.items():
            assert hg[key] == pytest.approx(v, rel=RTOL, abs=1e-300), key


@pytest.fixture(scope="module")
def runs(meshes: Path) -> dict:
    """Every case run on COMM_WORLD (``par``) and on rank 0 alone (``ser``), run once per
    case on first use."""
    return {}


def _run_case(meshes: Path, runs: dict, name: str) -> Path:
    if name in runs:
        return runs[name]
    d = run_dir(meshes, name)
    scene = write_scene(d / "scene.toml", CASES[name](meshes))
    res = run_scene(load_scene(scene), MPI.COMM_WORLD, output=d / "par", progress=False)
    assert res.status == "converged", res.summary.get("message")
    ser = run_serial_on_rank0(scene, d / "ser")
    if ser is not None:
        assert ser.status == "converged", ser.summary.get("message")
    runs[name] = d
    return d


@pytest.mark.parametrize("name", list(CASES))
def test_same_answer_as_serial(meshes: Path, runs: dict, name: str) -> None:
    d = _run_case(meshes, runs, name)
    same_tables(d / "par" / "fracture.csv", d / "ser" / "fracture.csv")
    got = json.loads((d / "par" / "summary.json").read_text())
    ref = json.loads((d / "ser" / "summary.json").read_text())
    _same_summary(got, ref)


def test_serial_checkpoint_continued_on_n_ranks(meshes: Path, runs: dict) -> None:
    """The serial run's checkpoint of step 1 continued on n ranks: step 2 as the serial
    run's, every row once."""
    d = _run_case(meshes, runs, "interior")
    out = d / "continued"
    if MPI.COMM_WORLD.rank == 0:
        shutil.copytree(d / "ser", out)
    MPI.COMM_WORLD.barrier()
    ck = out / "checkpoints" / "step_00000001"
    res = run_scene(
        load_scene(d / "scene.toml"), MPI.COMM_WORLD, output=out, progress=False, restart=ck
    )
    assert res.status == "converged", res.summary.get("message")
    assert res.summary["restarted_from"]["step"] == 1
    same_tables(out / "fracture.csv", d / "ser" / "fracture.csv")
