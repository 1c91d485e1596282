"""Tests of the candidate search between slave and master facets.

Pure NumPy: safe to run redundantly on every rank under
``mpiexec -n 2 python -m mpi4py -m pytest``.
"""

from __future__ import annotations

import numpy as np
import pytest

from bonecontact.contact.search import find_candidate_pairs


@pytest.mark.parametrize("gdim", [2, 3])
def test_candidate_pairs_match_brute_force(gdim):
    rng = np.random.default_rng(7 + gdim)
    ca, cb = rng.uniform(0, 1, (300, gdim)), rng.uniform(0, 1, (500, gdim))
    ha, hb = rng.uniform(0, 0.08, (300, gdim)), rng.uniform(0, 0.03, (500, gdim))
    ha[:5] *= 6.0  # a few large boxes
    amin, amax, bmin, bmax = ca - ha, ca + ha, cb - hb, cb + hb
    ia, ib = find_candidate_pairs(amin, amax, bmin, bmax)
    brute = np.all((amin[:, None] <= bmax[None]) & (bmin[None] <= amax[:, None]), axis=2)
    bi, bj = np.nonzero(brute)
    np.testing.assert_array_equal(ia, bi)
    np.testing.assert_array_equal(ib, bj)
    for h in (0.005, 0.3):  # result independent of the grid spacing
        ja, jb = find_candidate_pairs(amin, amax, bmin, bmax, cell_size=h)
        np.testing.assert_array_equal(ja, bi)
        np.testing.assert_array_equal(jb, bj)
