"""The first active set of a 3D crack's faces, on a crack closed at one end and open at the
other (bonecontact.contact.cold_start, docs/theory/pdas.md#pairs-that-start-open).

A penny of radius a = 1 mm at the centre of the block [−4a, 4a]³ (E = 17 GPa, ν = 0.3,
rollers on xmin, ymin, zmin), normal to z; on the top face a ``[[force]]`` of net
compression F_z = −σ₀ (2W)² with a moment about y that adds a bending stress ±σ_b at the
block's edges x = ±W: on the crack plane σ_zz ≈ −σ₀ + σ_b x/W, closing the crack for
x < x₀ = W σ₀/σ_b (σ₀ = 0.4 MPa, σ_b = 8 MPa: x₀ = 0.2a) and opening it beyond.

The crack carries compression as a whole, so a start from every face node (all gaps are 0)
sees a patch with a positive force; before, the 3D cold start then kept every node,
pulling ones too, and the unchanged set read as converged after one iteration with
tensile multipliers (the crack glued shut where it opens: −3.1 MPa on the faces of the
scanned L4 at its 8th block).  Checked for the faces' own open start and for the
closed-gap start (the rule of every other pair, forced here), frictionless and Coulomb
(μ = 0.3): the Signorini conditions at every face node — no tensile pressure, no
interpenetration, the pressure zero where the faces are apart — both parts present
(closed for x < −0.2a, open for x > 0.6a), and the same K from both starts.
"""

from __future__ import annotations

import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import run_dir
from coupled_support import gmsh_on_rank0, read_csv, run_text

from bonecontact.verification.problems import crack_block_model, crack_block_scene

A = 1.0e-3  # crack radius, m
W = 4 * A  # half-width of the block
E, NU = 17.0e9, 0.3
SIGMA_0, SIGMA_B = 0.4e6, 8.0e6  # net compression and bending stress at x = ±W, Pa
F_Z = -SIGMA_0 * (2 * W) ** 2
#: M_y = −∫ x t_z dA of t_z = σ_b x / W over the top face (I = (2W)⁴/12)
M_Y = -SIGMA_B / W * (2 * W) ** 4 / 12


def _block(gmsh) -> None:
    crack_block_model(W)


@pytest.fixture(scope="module")
def block_dir(tmp_path_factory) -> Path:
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("bent3d")) if comm.rank == 0 else None))
    gmsh_on_rank0(_block, d / "block.msh", 3)
    return d


def _text(mesh: Path, name: str, mu: float) -> str:
    text = crack_block_scene(
        str(mesh),
        f"centre = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = {A!r}\ncoefficient = {mu!r}",
        E=E,
        nu=NU,
        sigma=0.0,
        h=A / 6,
        points=8,
    )
    traction = '[[traction]]\nboundary = "top"\nvalue = [0.0, 0.0, 0.0]\n'
    force = (
        f'[[force]]\nboundary = "top"\nvalue = [0.0, 0.0, {F_Z!r}]\nmoment = [0.0, {M_Y!r}, 0.0]\n'
    )
    assert traction in text
    return text.replace(traction, force).replace('name = "penny3d"', f'name = "{name}"')


_RUNS: dict[tuple[str, float], tuple[dict, dict]] = {}


def _run(block_dir: Path, start: str, mu: float, closed_gap_start) -> tuple[dict, dict]:
    if (start, mu) not in _RUNS:
        if start == "closed_gap":
            closed_gap_start()
        name = f"bent_{start}_{int(100 * mu)}"
        d = run_dir(block_dir, name)
        res = run_text(_text(block_dir / "block.msh", name, mu), d, d / "out")
        assert res.status == "converged", res.summary.get("message")
        out = d / "out"
        _RUNS[start, mu] = (read_csv(out / "fracture.csv"), read_csv(out / "contact_penny.csv"))
    return _RUNS[start, mu]


@pytest.mark.parametrize("mu", [0.0, 0.3])
@pytest.mark.parametrize("start", ["open", "closed_gap"])
def test_half_closed_penny_meets_signorini(
    block_dir: Path, start: str, mu: float, closed_gap_start
):
    _, faces = _run(block_dir, start, mu, closed_gap_start)
    p, g, x = faces["pressure"], faces["gap"], faces["x"]
    assert p.size > 50
    pmax = float(np.max(p))
    assert pmax > 0.3 * SIGMA_0
    assert np.min(p) >= -1e-6 * pmax, np.min(p)  # no tensile pressure
    assert np.min(g) >= -1e-9 * A  # no interpenetration
    apart = g > 1e-3 * np.max(g)
    assert np.all(np.abs(p[apart]) <= 1e-6 * pmax)  # apart: no pressure
    assert np.all(g[x < -0.2 * A] <= 1e-9 * A)  # the compressed side is closed
    assert np.all(g[x > 0.6 * A] > 1e-3 * np.max(g))  # the stretched side is open


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_both_starts_give_the_same_k(block_dir: Path, mu: float, closed_gap_start) -> None:
    """The converged state does not depend on the first set (frictionless: the unique
    solution; Coulomb in one static step: the same fixed point here)."""
    opened, _ = _run(block_dir, "open", mu, closed_gap_start)
    glued, _ = _run(block_dir, "closed_gap", mu, closed_gap_start)
    scale = 2 * SIGMA_B * (A / W) * math.sqrt(A / math.pi)  # the bending stress at x = a
    assert np.max(opened["K_I"]) > 0.2 * scale  # the open side is loaded
    for key in ("K_I", "K_II", "K_III"):
        np.testing.assert_allclose(opened[key], glued[key], rtol=0, atol=1e-6 * scale)
