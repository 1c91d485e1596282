"""Coplanar interior 3D cracks that meet merge into their convex hull and grow on
(``[fracture] joined = "merge"``, the default; runners.front_growth3d, fracture.coalescence).

The block [−4a, 4a]³ of tests/unit/runners/test_crack_growth_scene3d.py (a = 1 mm, σ = 1
MPa along z, front a/8, Δa = 0.1a, K_Ic below every K) with two pennies of radius a in
z = 0 centred at x = ±1.7a: their facing edges 1.70a apart, just outside the ligament
of each other (6 front elements ahead of a front, 0.75a), and inside it after the first
advance.  The two octagons, advanced, become one crack — their convex hull, a stadium —
that is solved and advanced again:

* the merged front is a convex polygon in z = 0 containing both advanced octagons and no
  edge shorter than the ligament;
* K_I at the middle of its two long sides (the waist, half-width b) lies between the
  penny inscribed there, 2σ√(b/π), and the tunnel crack of that half-width, σ√(πb): the
  stadium is wider than the one and shorter than the other (measured +53 %, +49 % above
  the penny, −2.6 %, −5.0 % below the tunnel crack: a stadium of aspect 2.7 in a block
  only 8a wide);
* two pennies offset by 0.15a in z (parallel, not coplanar: more than half a front
  element) stop ``joined`` and say why; ``joined = "stop"`` stops the coplanar ones;
* on the session's ranks as on one (fracture.csv to 1e-10), and continued from the
  checkpoint written just after the merge.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import (
    block_mesh,
    continued_run,
    idle_barrier,
    run_in,
    same_growth,
    same_tables,
    serial_reference,
)
from test_crack_growth_scene3d import SIGMA, A, H, _scene

X = 1.7 * A  # the pennies' centres at x = ±X


@pytest.fixture(scope="module")
def mesh(tmp_path_factory) -> Path:
    return block_mesh(tmp_path_factory, "merge3d", 4 * A)


def _two(mesh: Path, dz: float = 0.0, steps: int = 2, extra: str = "") -> str:
    text = _scene(mesh / "block.msh", centre=(-X, 0.0, 0.0), steps=steps, extra=extra)
    text = text.replace('name = "penny"', 'name = "left"')
    return text.replace(
        "[output]",
        f'[[crack]]\nname = "right"\ncentre = [{X!r}, 0.0, {dz!r}]\nnormal = [0.0, 0.0, 1.0]\n'
        f'radius = {A!r}\nregion = "block"\nfront_points = 1\n[output]',
    )


def _table(path: Path) -> dict[str, np.ndarray]:
    raw = np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding="utf-8")
    return {k: np.asarray(raw[k]) for k in raw.dtype.names}


@pytest.fixture(scope="module")
def merged(mesh: Path):
    res, d = run_in(mesh, "merged", _two(mesh))
    assert res.status == "converged", res.summary.get("message")
    return res, d


def _inside(P: np.ndarray, V: np.ndarray) -> np.ndarray:
    """Whether the points P (n, 2) lie in the convex polygon V (m, 2; counter-clockwise)."""
    e = np.roll(V, -1, axis=0) - V
    cross = e[None, :, 0] * (P[:, None, 1] - V[None, :, 1]) - e[None, :, 1] * (
        P[:, None, 0] - V[None, :, 0]
    )
    return np.all(cross >= -1e-9 * A * A, axis=1)


def test_coplanar_pennies_merge_into_their_convex_hull(merged) -> None:
    res, d = merged
    g = res.summary["fracture"]["growth"]
    assert g["status"] == "max_increments" and g["increments"] == 2
    assert [m["cracks"] for m in g["merges"]] == [["left", "right"]]
    assert g["merges"][0]["into"] == "left+right" and g["merges"][0]["increment"] == 0
    cracks = res.summary["fracture"]["cracks"]
    assert [c["name"] for c in cracks] == ["left+right"]
    t = _table(d / "out" / "fracture.csv")
    first = t["increment"] == 0
    assert set(t["crack"][first]) == {"left", "right"}
    assert set(t["crack"][~first]) == {"left+right"}
    # the merged front of the solve after the merge: convex, in z = 0, both octagons in it
    V = np.array(cracks[0]["front"])
    assert np.abs(V[:, 2]).max() < 5e-3 * A
    uv = V[:, :2]
    e = np.roll(uv, -1, axis=0) - uv
    turn = e[:, 0] * np.roll(e, -1, axis=0)[:, 1] - e[:, 1] * np.roll(e, -1, axis=0)[:, 0]
    assert np.all(turn > 0)  # convex, counter-clockwise about +z
    assert np.linalg.norm(e, axis=1).min() >= 6 * H * (1 - 1e-9)
    phi = 2 * math.pi * (np.arange(8) + 0.5) / 8
    octagon = 1.1 * A * np.column_stack([np.cos(phi), np.sin(phi)])  # after the advance
    for cx in (-X, X):
        assert np.all(_inside(octagon * 0.99 + [cx, 0.0], uv))


def test_merged_waist_between_penny_and_tunnel_crack(merged) -> None:
    """K_I at the middles of the merged crack's long sides (the solve after the merge)
    between the inscribed penny's and the tunnel crack's of the waist's half-width."""
    res, d = merged
    t = _table(d / "out" / "fracture.csv")
    after = (t["increment"] == 1) & (t["crack"] == "left+right")
    x, y, k = t["x"][after], t["y"][after], t["K_I"][after]
    waist = np.abs(x) < 0.25 * A
    assert np.count_nonzero(waist) == 2
    b = float(np.abs(y[waist]).mean())
    lower, upper = 2 * SIGMA * math.sqrt(b / math.pi), SIGMA * math.sqrt(math.pi * b)
    assert np.all(k[waist] > lower) and np.all(k[waist] < upper), (k[waist], lower, upper)


@pytest.mark.parametrize(
    ("dz", "extra", "why"),
    [(0.15 * A, "", "not coplanar"), (0.0, 'joined = "stop"\n', 'joined = "stop"')],
    ids=["offset", "stop"],
)
def test_pennies_that_cannot_merge_stop_joined(mesh: Path, dz: float, extra: str, why: str):
    res, _ = run_in(mesh, f"joined_{'stop' if extra else 'offset'}", _two(mesh, dz, 1, extra))
    assert res.status == "converged", res.summary.get("message")
    g = res.summary["fracture"]["growth"]
    assert g["status"] == "joined" and g["increments"] == 0 and g["merges"] == []
    assert why in g["joined"], g["joined"]


def test_merge_same_on_any_rank_count(merged) -> None:
    _, d = merged
    ref = serial_reference(d)
    idle_barrier(MPI.COMM_WORLD)
    same_tables(d / "out" / "fracture.csv", ref / "fracture.csv")
    got = json.loads((d / "out" / "summary.json").read_text())["fracture"]
    want = json.loads((ref / "summary.json").read_text())["fracture"]
    np.testing.assert_allclose(
        got["crack"]["front"], want["crack"]["front"], rtol=0, atol=1e-10 * A
    )


def test_restart_after_the_merge(merged) -> None:
    """The serial run's checkpoint before increment 1 (just after the merge) continued on
    every rank of the session: the merged crack comes back under its name with one face
    pair, and fracture.csv, the stop and the front equal the serial run's (1e-10)."""
    _, d = merged
    serial = serial_reference(d)
    state = json.loads((serial / "checkpoints" / "increment_00001" / "growth.json").read_text())
    assert state["names"] == ["left+right"] and len(state["merges"]) == 1, state.get("names")
    _, out = continued_run(d, serial, 1)
    got, _ = same_growth(out, serial, A)
    assert [c["name"] for c in got["cracks"]] == ["left+right"]
    assert got["growth"]["merges"][0]["into"] == "left+right"
