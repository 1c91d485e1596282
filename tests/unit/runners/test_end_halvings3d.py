"""The blocks before a 3D crack runs through, halved (``[fracture.fatigue] end_halvings``:
bonecontact.runners.surface_crack3d.halved_block, front_growth3d's interior growth).

Surface crack: the thin plate of test_surface_crack_through3d.py ([−b, b] × [−h, h] × [−t,
0], b = h = 2.5 mm, t = 0.4 mm, boundary facets 0.4 mm) in tension S = 1 MPa, the crack
a = c = 0.2 mm on the front face, front 0.02 mm: the ligament a grown front must keep to
the back face ℓ = r_out + 2h = 0.1 mm, so on the flat plate a crack of depth a has run
through iff a + ℓ > t (the deepest point is nearest to the back face).  Fatigue da/dN =
C ΔK² (C = 1e-20, R = 0), Δa_max = 0.06 mm.  The family n = end_halvings ∈ {0, 1, 3}:

* every run ends ``through``, its final block is Δa_max/2ⁿ (``final_block.da``) and the
  last solved crack fits with less than that left: 0 ≤ t − ℓ − a_last < Δa_max/2ⁿ (the
  geometric reference; measured 0.049, 0.024, 0.0057 mm);
* the blocks before the first halved one are the n = 0 run's (the same solves: history
  and fracture.csv rows equal to 1e-10), each later block's leading advance is
  Δa_max/2ᵏ, k ≤ n, non-increasing, and ``halved_blocks`` counts them;
* cycles against the closed form: Newman and Raju's K integrated by RK4 (bonecontact.
  verification.surface_fatigue.newman_raju_growth, the second method) to the depth of every
  solve within 8 % (the FE deepest point's K deficit: measured +5.1 … +6.1 %), and to the
  limit a = t − ℓ: the run's total approaches it as the final block shrinks (measured
  +13.0, +7.9, +6.6 %; n = 2, 4: +6.9, +6.5 %) — each n closer than the one before, and
  n = 3 within 8 % while n = 0 is not; the final block's share falls with it (measured
  0.46, 0.21, 0.048);
* a restart from the checkpoint after the first halved block equals the uninterrupted run
  (the checkpoint keeps the shortened growth).

Interior crack: the penny of test_crack_fatigue_scene3d.py (radius a = 1 mm in the block
[−4a, 4a]³, front a/8, tension 1 MPa; C = 1e-20, m = 3, R = 0.1) centred at x = 2a: its
front must keep ℓ = 6h = 0.75a from the face x = 4a.  Δa_max = 0.2a: one block fits, the
second would not; n = 2 solves two halved blocks (0.1a, 0.05a) and ends with a final block
of 0.05a, the front's largest x then short of the limit by less than that (measured
0.0102a; n = 0: 0.145a); its first two solves are the n = 0 run's.

Non-planar path: the same thin plate with a = c = 0.25 mm, front a/14, Δa_max = 0.04 mm;
an inner vertex must keep its point 6h ahead inside, so on the flat plate the limit is
depth + 6h = t: n = 0 and 2 end ``through`` with −0.05h ≤ t − 6h − depth_last <
Δa_max/2ⁿ (the point ahead of a vertex leans off the depth by the front's polygon angle),
the n = 2 run's first solves the n = 0 run's, one more solve per halved block.

On 2 ranks each run equals its serial one.  Bad input: end_halvings above 8 or negative (a
SceneError naming the file and the key), in a 2D scene (naming the table and key).
"""

from __future__ import annotations

import json
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import (
    continued_run,
    idle_barrier,
    run_in,
    same_growth,
    same_tables,
    serial_reference,
    surface_plate,
    surface_scene,
)
from coupled_support import gmsh_on_rank0, read_csv

from bonecontact.fracture.fatigue import ParisLaw
from bonecontact.scene import SceneError, load_scene
from bonecontact.scene.fracture_tables import read_fracture
from bonecontact.verification.problems import crack_block_model, crack_block_scene
from bonecontact.verification.surface_fatigue import newman_raju_growth

L = 1e-3
A, T, B, S = 0.2 * L, 0.4 * L, 2.5 * L, 1.0e6
LIGAMENT = 0.06 * L + 2 * A / 10  # r_out + 2 h
DA_MAX, C = 0.06 * L, 1e-20
AHEAD = 6  # the non-planar path's probe ahead of an inner vertex, in front elements
HALVINGS = (0, 1, 3)


def _text(mesh: Path, n: int, every: int = 0) -> str:
    growth = (
        f"[fracture.fatigue]\nC = {C}\nm = 2.0\nda_max = {DA_MAX}\nmax_blocks = 20\n"
        f"end_halvings = {n}"
    )
    text = surface_scene(mesh, S=S, minus_S=-S, a=A, c=A, growth=growth)
    return text.replace("fields_every = 0", f"fields_every = 0\ncheckpoint_every = {every}")


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[int, tuple[dict, Path]]:
    """Each n's run (summary's ``fracture.growth``, its folder); n = 1 with checkpoints."""
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("halvings")) if comm.rank == 0 else None))
    gmsh_on_rank0(surface_plate(T), d / "thin.msh", 3)
    out = {}
    for n in HALVINGS:
        res, sub = run_in(d, f"n{n}", _text(d / "thin.msh", n, every=1 if n == 1 else 0))
        assert res.status == "converged", res.summary.get("message")
        out[n] = (res.summary["fracture"]["growth"], sub)
    return out


def _lead_advances(g: dict) -> np.ndarray:
    """Each block's leading advance, about: the larger of the depth's and the
    half-length's (the surface points lead)."""
    h = g["history"]
    depth, half = (np.array([e[k] for e in h]) for k in ("depth", "half_length"))
    return np.maximum(np.diff(depth), np.diff(half))


@pytest.mark.parametrize("n", HALVINGS)
def test_final_block_and_the_gap_left(runs: dict, n: int) -> None:
    g, _ = runs[n]
    assert g["status"] == "through" and g["fractured"]
    assert g["final_block"]["da"] == DA_MAX / 2**n
    gap = T - LIGAMENT - g["history"][-1]["depth"]
    assert 0.0 <= gap < DA_MAX / 2**n


@pytest.mark.parametrize("n", HALVINGS[1:])
def test_blocks_halve_after_the_plain_ones(runs: dict, n: int) -> None:
    g, sub = runs[n]
    plain, plain_sub = runs[0]
    k = len(plain["history"])  # the plain run's solves come first, unchanged
    for got_h, ref_h in zip(g["history"][:k], plain["history"], strict=True):
        assert got_h == pytest.approx(ref_h, rel=1e-10)  # on 2 ranks: to round-off
    got, ref = read_csv(sub / "out" / "fracture.csv"), read_csv(plain_sub / "out" / "fracture.csv")
    rows = ref["increment"] < k - 1  # the last plain solve's rows end "through" there
    for key in ("depth", "half_length", "K_I", "K_V", "cycles"):
        np.testing.assert_allclose(got[key][: rows.sum()], ref[key][rows], rtol=1e-10, err_msg=key)
    lead = _lead_advances(g)
    ratio = lead / DA_MAX
    levels = np.round(-np.log2(ratio))
    # c grows by the mean of its two ends' advances, the faster one the block's: the slower
    # end (the mesh is not symmetric about the crack's centre) keeps it 1 % below
    np.testing.assert_allclose(ratio, 2.0**-levels, rtol=0.02)
    assert np.all(np.diff(levels) >= 0) and levels.max() <= n
    assert g["halved_blocks"] == int(np.count_nonzero(levels > 0)) >= 1


def test_cycles_against_newman_raju(runs: dict) -> None:
    a_ref, _, n_ref = newman_raju_growth(ParisLaw(C, 2.0), S, A, A, T, B, T - LIGAMENT)
    errors = []
    for n in HALVINGS:
        g, _ = runs[n]
        depth = np.array([e["depth"] for e in g["history"]])
        cycles = np.array([e["cycles"] for e in g["history"]])
        np.testing.assert_allclose(cycles[1:], np.interp(depth[1:], a_ref, n_ref), rtol=0.08)
        errors.append(g["cycles"] / n_ref[-1] - 1.0)
    assert errors[0] > 0.08 and abs(errors[-1]) < 0.08
    assert np.all(np.diff(np.abs(errors)) < 0)
    shares = [runs[n][0]["final_block"]["share"] for n in HALVINGS]
    assert np.all(np.diff(shares) < 0)


def _same_growth(out: Path, ref: Path) -> tuple[dict, dict]:
    """The surface-crack growth in ``out`` equals ``ref``'s: fracture.csv to 1e-10, the
    stop, the blocks, halved blocks, the cycles and the final block to 1e-10 and the final
    crack to 1e-10 of its depth; returns both summaries' ``fracture.growth``."""
    idle_barrier(MPI.COMM_WORLD)  # rank 0 writes summary.json after the last collective
    same_tables(out / "fracture.csv", ref / "fracture.csv")
    got, want = (json.loads((p / "summary.json").read_text())["fracture"] for p in (out, ref))
    for key in ("status", "increments", "halved_blocks"):
        assert got["growth"][key] == want["growth"][key], key
    assert got["growth"]["cycles"] == pytest.approx(want["growth"]["cycles"], rel=1e-10)
    fb, fb_ref = got["growth"]["final_block"], want["growth"]["final_block"]
    assert fb == pytest.approx(fb_ref, rel=1e-10)
    final, final_ref = got["crack"]["final"], want["crack"]["final"]
    for key in ("depth", "half_length"):
        assert final[key] == pytest.approx(final_ref[key], rel=1e-10), key
    return got["growth"], want["growth"]


def test_restart_after_a_halved_block(runs: dict) -> None:
    g, sub = runs[1]
    k = len(runs[0][0]["history"])  # the first halved block's crack is solved k-th
    assert g["halved_blocks"] == 1 and len(g["history"]) == k + 1
    res, out = continued_run(sub, serial_reference(sub), k)
    got, _ = _same_growth(out, serial_reference(sub))
    assert got["halved_blocks"] == 1


@pytest.mark.parametrize("n", HALVINGS)
def test_ranks_equal_serial(runs: dict, n: int) -> None:
    _, sub = runs[n]
    _same_growth(sub / "out", serial_reference(sub))


BAD = {
    "above_8": ("end_halvings = 9", "0 … 8"),
    "negative": ("end_halvings = -1", "end_halvings"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_end_halvings(runs: dict, tmp_path: Path, case: str) -> None:
    line, words = BAD[case]
    mesh = runs[0][1].parent / "thin.msh"
    path = tmp_path / f"{case}.toml"
    path.write_text(_text(mesh, 0).replace("end_halvings = 0", line))
    with pytest.raises(SceneError, match=r"end_halvings") as err:
        load_scene(path)
    assert words in str(err.value) and str(path) in str(err.value)


def test_end_halvings_in_2d_is_refused() -> None:
    doc = {
        "fracture": {"fatigue": {"C": 1e-20, "m": 2.0, "da_max": 1e-4, "end_halvings": 1}},
        "crack": [{"region": "plate", "points": [[0.0, 0.0], [1e-3, 0.0]]}],
    }
    with pytest.raises(SceneError, match=r"end_halvings.*2D") as err:
        read_fracture(doc, 2, [], False)
    assert err.value.table == "[fracture.fatigue]" and err.value.key == "end_halvings"


def test_summary_counts_no_halved_block_by_default(runs: dict) -> None:
    g, sub = runs[0]
    assert g["halved_blocks"] == 0
    if MPI.COMM_WORLD.rank == 0:
        summary = json.loads((sub / "out" / "summary.json").read_text())
        assert summary["fracture"]["growth"]["halved_blocks"] == 0


# ------------------------------------------------------------------------ interior crack
W, H_BLOCK = 4 * L, L / 8
DA_PENNY = 0.2 * L


def _penny(mesh: Path, n: int) -> str:
    geometry = f"centre = {[2 * L, 0.0, 0.0]!r}\nnormal = [0.0, 0.0, 1.0]\nradius = {L!r}"
    text = crack_block_scene(str(mesh), geometry, E=17.0e9, nu=0.3, sigma=1e6, h=H_BLOCK, points=1)
    fatigue = (
        f"[fracture.fatigue]\nC = 1e-20\nm = 3.0\nR = 0.1\nda_max = {DA_PENNY!r}\n"
        f"max_blocks = 10\nend_halvings = {n}"
    )
    return text.replace("[[crack]]", f"{fatigue}\n[[crack]]", 1)


@pytest.fixture(scope="module")
def pennies(tmp_path_factory) -> dict[int, tuple[dict, Path]]:
    """The penny near the face x = 4a with n = 0 and 2 (summary's ``fracture``, folder)."""
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("penny")) if comm.rank == 0 else None))
    gmsh_on_rank0(lambda gmsh: crack_block_model(W), d / "block.msh", 3)
    out = {}
    for n in (0, 2):
        res, sub = run_in(d, f"n{n}", _penny(d / "block.msh", n))
        assert res.status == "converged", res.summary.get("message")
        out[n] = (res.summary["fracture"], sub)
    return out


def test_interior_crack_halves_its_last_blocks(pennies: dict) -> None:
    (plain, _), (halved, _) = pennies[0], pennies[2]
    gaps = {}
    for n, f in ((0, plain), (2, halved)):
        g = f["growth"]
        assert g["status"] == "through" and g["final_block"]["da"] == DA_PENNY / 2**n
        front = np.asarray(f["crack"]["front"])
        gaps[n] = W - front[:, 0].max() - 6 * H_BLOCK  # to the ligament's limit
        assert 0.0 <= gaps[n] < DA_PENNY / 2**n
    assert plain["growth"]["halved_blocks"] == 0 and halved["growth"]["halved_blocks"] == 2
    assert gaps[2] < 0.1 * gaps[0]
    k = len(plain["growth"]["history"])
    for got, ref in zip(halved["growth"]["history"][:k], plain["growth"]["history"], strict=True):
        assert got == pytest.approx(ref, rel=1e-10)
    assert len(halved["growth"]["history"]) == k + 2
    fb = halved["growth"]["final_block"]
    assert halved["growth"]["cycles"] == pytest.approx(
        halved["growth"]["history"][-1]["cycles"] + fb["cycles"], rel=1e-12
    )


def test_interior_ranks_equal_serial(pennies: dict) -> None:
    for n in (0, 2):
        _, sub = pennies[n]
        ser = serial_reference(sub)
        same_growth(sub / "out", ser, L)


# ------------------------------------------------------------------ non-planar path
A_NP, DA_NP = 0.25 * L, 0.04 * L
H_NP = A_NP / 14


def _nonplanar(mesh: Path, n: int) -> str:
    growth = (
        f'surface_growth = "nonplanar"\n[fracture.fatigue]\nC = {C}\nm = 2.0\n'
        f"da_max = {DA_NP}\nmax_blocks = 20\nend_halvings = {n}"
    )
    return surface_scene(mesh, h=H_NP, points=5, growth=growth, a=A_NP, c=A_NP, S=S, minus_S=-S)


@pytest.fixture(scope="module")
def nonplanar(runs: dict) -> dict[int, tuple[dict, Path]]:
    """The non-planar path on the thin plate, n = 0 and 2 (summary's ``fracture``,
    folder)."""
    base = runs[0][1].parent
    out = {}
    for n in (0, 2):
        res, sub = run_in(base, f"nonplanar{n}", _nonplanar(base / "thin.msh", n))
        assert res.status == "converged", res.summary.get("message")
        out[n] = (res.summary["fracture"], sub)
    return out


def test_nonplanar_path_halves_its_last_blocks(nonplanar: dict) -> None:
    (plain, _), (halved, _) = nonplanar[0], nonplanar[2]
    gaps = {}
    for n, f in ((0, plain), (2, halved)):
        g = f["growth"]
        assert g["status"] == "through" and g["final_block"]["da"] == DA_NP / 2**n
        gaps[n] = T - AHEAD * H_NP - g["history"][-1]["depth"]  # to the ligament's limit
        # a vertex's point ahead leans off the depth direction (the front's polygon angle
        # θ, a few degrees): its depth is 6h cos θ, not 6h (measured −1.9e-7 m = −0.011 h)
        assert -0.05 * H_NP <= gaps[n] < DA_NP / 2**n
    assert plain["growth"]["halved_blocks"] == 0 and halved["growth"]["halved_blocks"] >= 1
    k = len(plain["growth"]["history"])
    hist = halved["growth"]["history"]
    for got, ref in zip(hist[:k], plain["growth"]["history"], strict=True):
        # da: the block after the solve, the n = 0 run's last the final one
        assert {**got, "da": 0} == pytest.approx({**ref, "da": 0}, rel=1e-10)
    assert len(hist) == k + halved["growth"]["halved_blocks"]
    da = [h["da"] for h in hist]  # Δa_max, then halved, the final block Δa_max/2²
    assert da[: k - 1] == [DA_NP] * (k - 1) and da[-1] == DA_NP / 4
    assert all(DA_NP / 4 <= x <= DA_NP / 2 for x in da[k - 1 : -1])


def test_nonplanar_ranks_equal_serial(nonplanar: dict) -> None:
    for n in (0, 2):
        _, sub = nonplanar[n]
        ser = serial_reference(sub)
        idle_barrier(MPI.COMM_WORLD)
        same_tables(sub / "out" / "fracture.csv", ser / "fracture.csv", rtol=1e-9)
