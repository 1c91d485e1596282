"""A semi-elliptical surface crack grown through the thickness of a plate by the Paris law
(bonecontact.verification.surface_fatigue; docs/theory/fracture.md, fatigue of a surface crack).

The plate [−2, 2] × [−2, 2] × [−1, 0] (t = 1) of test_fracture_surface3d.py under cyclic
tension S = 1 (R = 0, ΔK = K_max), Paris law da/dN = C ΔK^m with C = 1; the crack starts
semi-circular, a = c = 0.2t, and grows by two degrees of freedom: a by the rate at the
deepest point, c by the rate at φ_s = 20° (K is refused nearer the surface).

* The block integration (helper F's ParisLaw and block_cycles) with Newman–Raju's K in
  place of the solve, against the same two equations integrated by RK4 (800 steps), to
  a/t = 0.8 (the equation's range): cycles within 3 % (measured m = 3: 1.4 %, m = 4:
  2.5 % at Δa_max = 0.05t), c within 1 %; halving Δa_max halves the error (first order:
  each block advances at its starting rates); the run ends "through" at a = t − (r_out +
  2h_f).
* With the finite-element K (reduced mesh of the surface-crack tests: front a₀/10, 12k–15k
  dofs), one block of 0.05t (on 2 and 3 ranks the same block as on one: K of the first
  solve, a and c, K of the grown crack and the cycles to 1e-10): K at the
  deepest point and at 20° within 7 % of Newman–Raju at
  both ends of the block (measured −5.2 … +1.1 %), and the cycles at the depth reached
  within 25 % of the Newman–Raju integration (measured +21 %: N ∝ K^−m, and the reduced
  mesh's deepest-point K is 4–5 % low).
* Slow: front a₀/16 (the benchmark's mesh, 28k–39k dofs), three blocks: K within 3 %
  (measured −1.6 … +0.1 %), cycles within 8 % (measured +3.5 … +4.0 %); and the reduced
  mesh through the whole thickness (blocks of 0.1t, 10 blocks, 12k–38k dofs, 584 s on
  the loaded machine): status "through" at a = 0.9t, a/c within
  [0.75, 1] (measured 0.78 … 1), the cycles at every block end to a/t = 0.8 within 25 % of
  Newman–Raju (measured +20 % after the first block, then +6 … +2 %), and the cycles to
  the back face within 10 % of Newman–Raju's to the same depth (measured 1.185 against
  1.120: +5.8 %; the deepest-point K falls to −10 … −16 % of Newman–Raju beyond
  a/t = 0.7, where the ring nears the back face and the equation is at its limit).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

from mpi4py import MPI

import numpy as np
import pytest

from bonecontact.fracture.fatigue import ParisLaw
from bonecontact.fracture.surface3d import SurfaceCrack
from bonecontact.verification.surface_crack import PlateProblem, surface_crack_k
from bonecontact.verification.surface_fatigue import (
    grow_surface_crack,
    newman_raju_growth,
    newman_raju_k,
)

A0 = 0.2
PHI_S = math.radians(20.0)
REDUCED = {"h_front": A0 / 10, "grading": 0.15, "h_max": 0.4, "r_out": 0.3 * A0}
FINE = {"h_front": A0 / 16, "grading": 0.12, "h_max": 0.25, "r_out": 0.25 * A0}


def _problem(**sizes) -> PlateProblem:
    return PlateProblem(SurfaceCrack("semi_elliptical", A0, A0), b=2.0, h=2.0, t=1.0, **sizes)


def _against_newman_raju(rec, law: ParisLaw, a_max: float = 0.8):
    """(cycles, c) of the run and of the RK4 integration at the run's depths ≤ a_max."""
    a = np.asarray(rec.a)
    sel = a <= a_max + 1e-12
    ag, cg, Ng = newman_raju_growth(law, 1.0, A0, A0, 1.0, 2.0, float(a[sel].max()), steps=800)
    ref_n, ref_c = np.interp(a[sel], ag, Ng), np.interp(a[sel], ag, cg)
    return rec.cycles[sel], np.asarray(rec.c)[sel], ref_n, ref_c


@pytest.mark.parametrize("m", [3.0, 4.0])
def test_block_integration_against_rk4(m: float) -> None:
    law = ParisLaw(C=1.0, m=m)
    errors = []
    for da in (0.05, 0.025):
        rec = grow_surface_crack(_problem(**REDUCED), law, da, max_blocks=200, k_of=newman_raju_k)
        assert rec.status == "through"
        assert rec.a[-1] == pytest.approx(1.0 - (0.3 * A0 + 2 * A0 / 10), rel=1e-12)
        n, c, ref_n, ref_c = _against_newman_raju(rec, law)
        errors.append(np.max(np.abs(n[1:] / ref_n[1:] - 1)))
        np.testing.assert_allclose(c, ref_c, rtol=0.01)
    assert errors[0] < 0.03
    assert errors[1] < 0.7 * errors[0]  # first order in the block size


def _fe_checks(rec, law: ParisLaw, k_tol: float, n_tol: float) -> None:
    for a, c, k in zip(rec.a, rec.c, rec.k, strict=True):
        ref = surface_crack_k(1.0, a, c, 1.0, 2.0, np.array([0.5 * math.pi, PHI_S]))
        np.testing.assert_allclose(k, ref, rtol=k_tol)
    n, _, ref_n, _ = _against_newman_raju(rec, law)
    np.testing.assert_allclose(n[1:], ref_n[1:], rtol=n_tol)


LAW = ParisLaw(C=1.0, m=3.0)


@pytest.fixture(scope="module")
def one_block():
    return grow_surface_crack(_problem(**REDUCED), LAW, 0.05, max_blocks=1)


def test_one_block_with_finite_element_k(one_block) -> None:
    rec = one_block
    assert rec.status == "max_blocks" and len(rec.a) == 2
    assert rec.c[1] - rec.c[0] == pytest.approx(0.05)  # the 20° point leads at a = c
    _fe_checks(rec, LAW, 0.07, 0.25)


def test_one_block_same_on_every_partition(one_block) -> None:
    """On 2 and 3 ranks the block (its K at both ends, the grown a and c, the cycles)
    equals the same block on one rank (rank 0 on COMM_SELF: the same gmsh meshes) to
    1e-10; the advance is rounded to a grid before the grown crack is meshed (without
    that, round-off of K reached gmsh: K of the grown crack 0.8 % apart on 2 ranks)."""
    comm = MPI.COMM_WORLD
    if comm.size == 1:
        pytest.skip("compares a distributed run with a serial one")
    serial = None
    if comm.rank == 0:
        rec = grow_surface_crack(_problem(**REDUCED), LAW, 0.05, max_blocks=1, comm=MPI.COMM_SELF)
        serial = (rec.a, rec.c, rec.cycles, rec.k)
    a, c, n, k = comm.bcast(serial, root=0)
    rec = one_block
    scale = float(np.max(np.abs(k)))
    np.testing.assert_allclose(rec.k, k, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose([rec.a, rec.c], [a, c], rtol=1e-10)
    np.testing.assert_allclose(rec.cycles, n, rtol=1e-10)


@pytest.mark.slow
def test_three_blocks_on_the_fine_mesh() -> None:
    law = ParisLaw(C=1.0, m=3.0)
    rec = grow_surface_crack(_problem(**FINE), law, 0.05, max_blocks=3)
    _fe_checks(rec, law, 0.03, 0.08)


@pytest.mark.slow
def test_surface_crack_grows_through_the_thickness() -> None:
    law = ParisLaw(C=1.0, m=3.0)
    rec = grow_surface_crack(_problem(**REDUCED), law, 0.1, max_blocks=20)
    assert rec.status == "through" and math.isfinite(rec.final_cycles)
    ratio = np.asarray(rec.a) / np.asarray(rec.c)
    assert ratio.min() >= 0.75 and ratio.max() <= 1.0
    n, _, ref_n, _ = _against_newman_raju(rec, law)
    np.testing.assert_allclose(n[1:], ref_n[1:], rtol=0.25)
    _, _, to_end = newman_raju_growth(law, 1.0, A0, A0, 1.0, 2.0, rec.a[-1], steps=800)
    assert rec.final_cycles == pytest.approx(to_end[-1], rel=0.10)
