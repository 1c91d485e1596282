"""The strain measure of a run and its verdict (bonecontact.scene.validity).

References: the volume quantile against a sort of all the cells (every rank draws the same
random cells and keeps its share); a uniform strain ``u = ε x`` (a bar in uniaxial strain,
which P1 elements hold exactly) whose measure is ``ε`` in every material; the same bar with a
strain concentration in a strip of known volume fraction (the measure ignores it below 1 %
of the volume and sees it above); the limit of 10 % on both sides.
"""

from __future__ import annotations

from types import SimpleNamespace

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import fem, mesh

from bonecontact.scene import validity
from bonecontact.scene.checks import LOAD_STRAIN_LIMIT
from bonecontact.scene.validity import (
    SMALL_STRAIN_LIMIT,
    VOLUME_FRACTION,
    StrainMonitor,
    judge_run,
    volume_quantile,
)

COMM = MPI.COMM_WORLD


def _reference_quantile(values: np.ndarray, volumes: np.ndarray, fraction: float) -> float:
    """The smallest cell value ``s`` (or 0) with at most ``fraction`` of the volume above it,
    by sorting all the cells (distinct values)."""
    allowed = fraction * volumes.sum()
    if volumes[values > 0].sum() <= allowed:
        return 0.0
    order = np.argsort(values)
    w = volumes[order]
    above = np.append(np.cumsum(w[::-1])[::-1][1:], 0.0)  # volume above each sorted value
    return float(values[order][np.argmax(above <= allowed)])


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("fraction", [0.0, 0.01, 0.05, 0.5])
def test_volume_quantile_matches_a_sort(seed: int, fraction: float) -> None:
    rng = np.random.default_rng(seed)
    n = 2000
    values = rng.lognormal(-3.0, 1.0, n)
    volumes = rng.uniform(0.5, 2.0, n)
    mine = np.arange(n) % COMM.size == COMM.rank  # each rank its share
    q = volume_quantile(values[mine], volumes[mine], fraction, COMM)
    ref = _reference_quantile(values, volumes, fraction)
    assert q == pytest.approx(ref, rel=1e-10)
    assert volumes[values > q].sum() <= fraction * volumes.sum() * (1 + 1e-12)
    assert volumes[values >= ref].sum() > fraction * volumes.sum()  # the smallest such s


def test_volume_quantile_of_nothing_is_zero() -> None:
    assert volume_quantile(np.zeros(0), np.zeros(0), 0.01, COMM) == 0.0
    assert volume_quantile(np.zeros(5), np.ones(5), 0.01, COMM) == 0.0


def _bar(dim: int, n: int) -> mesh.Mesh:
    if dim == 2:
        return mesh.create_rectangle(COMM, [[0.0, 0.0], [1.0, 0.2]], [n, 4])
    return mesh.create_box(COMM, [[0.0, 0.0, 0.0], [1.0, 0.2, 0.2]], [n, 2, 2])


def _monitor(msh: mesh.Mesh, ux) -> StrainMonitor:
    V = fem.functionspace(msh, ("Lagrange", 1, (msh.geometry.dim,)))
    u = fem.Function(V)
    u.interpolate(lambda x: np.vstack([ux(x[0])] + [0.0 * x[0]] * (msh.geometry.dim - 1)))
    mon = StrainMonitor(u)
    mon.update()
    return mon


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("strain", [0.01, 0.099, 0.101, 0.3])
def test_uniform_strain_is_measured_exactly(dim: int, strain: float) -> None:
    """A bar in uniaxial strain ε: measure = max = ε; valid iff ε ≤ 10 %."""
    mon = _monitor(_bar(dim, 10), lambda x: strain * x)
    s = mon.summary()
    assert s["strain_measure"] == pytest.approx(strain, rel=1e-9)
    assert s["max_strain"] == pytest.approx(strain, rel=1e-9)
    assert s["small_strain_valid"] is (strain <= SMALL_STRAIN_LIMIT)
    assert s["small_strain_limit"] == SMALL_STRAIN_LIMIT == LOAD_STRAIN_LIMIT == 0.10


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("cells_in_strip, valid", [(1, True), (4, False)])
def test_a_strip_below_one_percent_of_the_volume_is_ignored(
    dim: int, cells_in_strip: int, valid: bool
) -> None:
    """Background strain 2 %, and 50 % in the last ``k`` of 200 columns of cells: the strip
    holds k/200 of the volume (0.5 % or 2 %); the cell maximum sees it either way, the
    measure only when it holds more than 1 %."""
    n, background, peak = 200, 0.02, 0.5
    x0 = 1.0 - cells_in_strip / n
    jump = peak - background
    mon = _monitor(_bar(dim, n), lambda x: background * x + jump * np.maximum(x - x0, 0.0))
    s = mon.summary()
    assert s["max_strain"] == pytest.approx(peak, rel=1e-9)
    expected = background if cells_in_strip / n <= VOLUME_FRACTION else peak
    assert s["strain_measure"] == pytest.approx(expected, rel=1e-9)
    assert s["small_strain_valid"] is valid
    assert s["volume_above_strain_limit"] == {"all": pytest.approx(cells_in_strip / n)}


@pytest.mark.parametrize("allow", [False, True])
@pytest.mark.parametrize(
    "status, measure", [("converged", 0.05), ("converged", 0.2), ("failed", 0.2)]
)
def test_verdict(status: str, measure: float, allow: bool) -> None:
    """Only a converged run beyond the limit, without allow_large_strain, is invalid."""
    scene = SimpleNamespace(analysis=SimpleNamespace(allow_large_strain=allow))
    info = {
        "strain_measure": measure,
        "max_strain": 2 * measure,
        "strain_measure_material": "cartilage",
        "small_strain_valid": measure <= SMALL_STRAIN_LIMIT,
    }
    new, message = judge_run(scene, status, "why", info)
    invalid = status == "converged" and measure > SMALL_STRAIN_LIMIT and not allow
    assert new == ("invalid" if invalid else status)
    if invalid:
        assert '"cartilage"' in message and "small-strain limit 10%" in message
        assert "0.2" in message and "allow_large_strain" in message
    else:
        assert message == "why"


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("chunk", [7, 1 << 14])
def test_chunked_and_released_strains_measure_the_same(
    monkeypatch: pytest.MonkeyPatch, dim: int, chunk: int
) -> None:
    """A bar strained as 2 % + 48 % x⁴ (every cell another strain): cells evaluated in
    chunks of ``chunk`` give the strains of one evaluation of all cells (bit for bit), and
    a monitor whose cell strains were freed (``release``) measures the same again."""
    msh = _bar(dim, 40)

    def ux(x):
        return 0.02 * x + 0.48 * x**5 / 5.0

    whole = _monitor(msh, ux).summary()  # (the default chunk holds every cell here)
    monkeypatch.setattr(validity, "CHUNK_CELLS", chunk)
    mon = _monitor(msh, ux)
    assert mon.summary() == whole
    mon.release()
    mon.update()
    assert mon.summary() == whole
    assert whole["max_strain"] == pytest.approx(0.5, rel=0.1)  # (the last column of cells)
