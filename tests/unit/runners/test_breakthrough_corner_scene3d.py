"""An interior crack that reaches two faces at an edge becomes a quarter-elliptical corner
crack and grows on (``[fracture] breakthrough = "surface_crack"``; runners.breakthrough3d,
docs/theory/fracture.md#corner-cracks-in-a-scenes-body).

The block [−4a, 4a]³ of test_breakthrough_scene3d.py (a = 1 mm, rollers on xmin, ymin,
zmin, σ = 1 MPa on top, E = 17 GPa, ν = 0.3, front a/8, R = 0.1, C = 1e-20, m = 3,
Δa_max = 0.1a; coarse: what is checked is the chaining) with the penny of radius a normal
to the load centred at (2.2a, 2.0a, 0), next to the edge x = y = 4a: the interior phase
stops ``through`` when its front comes within the ligament of the face x = 4a; the face
y = 4a is then within twice that ligament of the front, so the flaw becomes a corner
crack, by the rule done by hand on the recorded final front: centred on the edge at
(4a, 4a, mean z), ``axis`` −y (along the face x = 4a, from the edge), c = 4a − min y,
a = 4a − min x, ligament 4a − max x, ligament₂ 4a − max y.  The corner crack is cut into
the block and grows on one fatigue block; fracture.csv holds both phases.
"""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import block_mesh, idle_barrier, read_table, run_in

from bonecontact.verification.problems import crack_block_scene

A = 1.0e-3
W = 4 * A
H = A / 8
DA = 0.1 * A


def _scene(mesh: Path, blocks: int) -> str:
    geometry = f"centre = [{2.2 * A!r}, {2.0 * A!r}, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = {A!r}"
    text = crack_block_scene(str(mesh), geometry, E=17.0e9, nu=0.3, sigma=1.0e6, h=H, points=1)
    growth = (
        f"[fracture.fatigue]\nC = 1e-20\nm = 3.0\nR = 0.1\nda_max = {DA!r}\nmax_blocks = {blocks}\n"
    )
    text = text.replace("[fracture]\n", '[fracture]\nbreakthrough = "surface_crack"\n', 1)
    return text.replace("[[crack]]", f"{growth}\n[[crack]]", 1)


@pytest.fixture(scope="module")
def mesh(tmp_path_factory) -> Path:
    return block_mesh(tmp_path_factory, "breakthrough_corner3d", W)


def test_interior_crack_at_an_edge_becomes_a_corner_crack(mesh: Path) -> None:
    res, d = run_in(mesh, "edge", _scene(mesh / "block.msh", 3))
    assert res.status == "converged", res.summary.get("message")
    idle_barrier(MPI.COMM_WORLD)
    fr = res.summary["fracture"]
    assert fr["interior"]["growth"]["status"] == "through"
    front = np.asarray(fr["interior"]["crack"]["front"])
    crack = fr["breakthrough"]["crack"]
    assert crack["shape"] == "quarter_elliptical"
    by_hand = {
        "half_length": W - front[:, 1].min(),
        "depth": W - front[:, 0].min(),
        "ligament": W - front[:, 0].max(),
        "ligament2": W - front[:, 1].max(),
    }
    for key, want in by_hand.items():
        assert crack[key] == pytest.approx(want, rel=1e-9), key
    assert by_hand["ligament2"] <= 2.0 * by_hand["ligament"]
    np.testing.assert_allclose(crack["centre"], [W, W, front[:, 2].mean()], atol=1e-9 * A)
    np.testing.assert_allclose(crack["axis"], [0.0, -1.0, 0.0], atol=1e-12)
    assert fr["crack"]["shape"] == "quarter_elliptical"
    g = fr["growth"]
    assert g["status"] in ("max_blocks", "through", "fractured"), g["status"]
    assert g["history"][-1]["depth"] >= crack["depth"]
    tab = read_table(d / "out" / "fracture.csv")
    assert set(tab["phase"]) == {"interior", "surface"}
