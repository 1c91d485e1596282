"""The small dense system of a low-rank set update (issue 27): equilibrated before its
condition is judged.

Rows of 3D Newton slip nodes scale as ``1/|ξ|``: at a node with ``|ξ| ≪ ĝ`` they are 10⁸
times the others, and the unscaled 1-norm condition exceeds 1e13 on a well-posed set
(the knee with smoothed scan surfaces, μ = 0.1: step 2 stopped "singular" at PDAS
iteration 6).  The reference of every solve is a manufactured solution ``y``
(``b = M y``) and the componentwise backward error of LU; genuinely singular systems
(a repeated row, as at a kink where two rows coincide; a column of zeros, a row's
unknown that nothing determines) must still stop, naming the rows.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bonecontact.contact.lowrank import SingularActiveSetError, solve_small_system

KNEE = Path(__file__).parent / "data" / "knee_slip_small_system.npz"


def _backward_error(M: np.ndarray, y: np.ndarray, b: np.ndarray) -> float:
    """Componentwise backward error ``max |M y − b| / (|M| |y| + |b|)``."""
    return float((np.abs(M @ y - b) / (np.abs(M) @ np.abs(y) + np.abs(b))).max())


def _rel(x: np.ndarray, ref: np.ndarray) -> float:
    return float(np.abs(x - ref).max() / np.abs(ref).max())


def test_knee_slip_system_is_solved():
    """The 53×53 system recorded where the knee's friction step failed (12 Newton slip
    groups, one with ``|G| ≈ 2.3e3``, ``|H| ≈ 7.7e11``): unscaled 1-norm condition above
    1e13 (what stopped the solve): its recorded right-hand side solved to a backward
    error of round-off, a manufactured solution recovered within 1e-11 (equilibrated
    condition ≈ 214)."""
    data = np.load(KNEE)
    M, b = data["M"], data["rhs"]
    assert np.linalg.cond(M, 1) > 1e13  # the case that failed before equilibration
    assert _backward_error(M, solve_small_system(M, b), b) < 1e-14
    y = np.random.default_rng(0).standard_normal(M.shape[0])
    assert _rel(solve_small_system(M, M @ y), y) < 1e-11


def _system(n: int, rng: np.random.Generator) -> np.ndarray:
    """A well-conditioned nonsymmetric system like a set's (diagonally dominant)."""
    return np.eye(n) * n + rng.standard_normal((n, n))


@pytest.mark.parametrize("n", [6, 30])
@pytest.mark.parametrize("row_scale", [1.0, 1e8, 1e12])
@pytest.mark.parametrize("col_scale", [1.0, 1e-7])
@pytest.mark.parametrize("groups", [1, 3])
def test_badly_scaled_rows_and_columns_are_solved(n, row_scale, col_scale, groups):
    """Slip-row groups of 2 rows scaled by ``row_scale`` (``1/|ξ|``), force unknowns
    scaled by ``col_scale`` (value and force columns): a manufactured solution recovered."""
    rng = np.random.default_rng(n + groups)
    M = _system(n, rng)
    rows = rng.choice(n, size=min(2 * groups, n), replace=False)
    M[rows] *= row_scale
    M[:, ::2] *= col_scale
    y = rng.standard_normal(n)
    got = solve_small_system(M, M @ y)
    assert _rel(got, y) < 1e-8  # (b = M y rounds at 1e-16 of the largest rows)
    assert _backward_error(M, got, M @ y) < 1e-14


@pytest.mark.parametrize("kind", ["repeated_row", "zero_column", "dependent_rows"])
@pytest.mark.parametrize("row_scale", [1.0, 1e8])
def test_singular_system_names_the_rows(kind, row_scale):
    """A genuinely singular system stops with :class:`SingularActiveSetError` naming the
    global rows of its near-null vector, whatever the scale of its rows."""
    n = 12
    rng = np.random.default_rng(3)
    M = _system(n, rng)
    if kind == "repeated_row":  # two rows of one node at a kink, the same equation
        M[5] = M[4] * row_scale
    elif kind == "zero_column":  # an amplitude no equation sees
        M[:, 7] = 0.0
    else:  # a row a combination of two others
        M[9] = (M[2] - 3.0 * M[8]) * row_scale
    cols = [100 + 3 * i for i in range(n)]
    with pytest.raises(SingularActiveSetError) as info:
        solve_small_system(M, rng.standard_normal(n), cols)
    msg = str(info.value)
    assert "after equilibration" in msg and "near-null vector" in msg
    if kind == "zero_column":
        assert f"{cols[7]} (1.00)" in msg
