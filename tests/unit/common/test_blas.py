"""One OpenBLAS thread for the small dense work of the contact solver
(:mod:`bonecontact.common.blas`).

References: the thread count each loaded OpenBLAS reports (its own getter) inside and
after the block, and the solution of a small system by NumPy's solver (the LU of
:func:`bonecontact.contact.lowrank.solve_small_system` with one thread gives the same
solution to round-off)."""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import numpy as np
import pytest
import scipy.linalg  # noqa: F401  (loads SciPy's OpenBLAS)

from bonecontact.common import blas
from bonecontact.contact.lowrank import solve_small_system


def test_one_thread_inside_and_restored_after():
    controls = blas.openblas_controls()
    if not controls:
        pytest.skip("no OpenBLAS with thread controls loaded in this process")
    before = [get() for _, get in controls]
    with blas.one_blas_thread():
        assert [get() for _, get in controls] == [1] * len(controls)
        with blas.one_blas_thread():  # (nested: restores the outer block's count)
            pass
        assert [get() for _, get in controls] == [1] * len(controls)
    assert [get() for _, get in controls] == before


def test_restored_after_an_exception():
    controls = blas.openblas_controls()
    before = [get() for _, get in controls]
    with pytest.raises(ZeroDivisionError), blas.one_blas_thread():
        1 / 0  # noqa: B018
    assert [get() for _, get in controls] == before


@pytest.mark.parametrize("n", [3, 60, 250])
def test_small_system_solution_unchanged(n):
    rng = np.random.default_rng(n)
    M = rng.standard_normal((n, n)) + n * np.eye(n)
    M[0] *= 1e8  # (a row on another scale: the equilibration's case)
    b = rng.standard_normal(n)
    x = solve_small_system(M, b)
    ref = np.linalg.solve(M, b)
    assert np.abs(x - ref).max() <= 1e-12 * np.abs(ref).max()
