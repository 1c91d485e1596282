"""Candidate search between slave and master facets of the mortar, pure NumPy.

Axis-aligned facet bounding boxes hashed on a uniform grid: O(n) expected.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bonecontact.contact.geometry import FloatArray, IntArray

__all__ = ["facet_bounding_boxes", "find_candidate_pairs"]

# ----------------------------------------------------------------------------------
# Candidate search
# ----------------------------------------------------------------------------------


def facet_bounding_boxes(
    coords: npt.ArrayLike, facets: npt.ArrayLike, pad: float = 0.0
) -> tuple[FloatArray, FloatArray]:
    """Axis-aligned bounding boxes of facets, enlarged by ``pad`` on every side.

    Returns
    -------
    lower, upper : ndarray, shape (n_facets, gdim)
    """
    x = np.asarray(coords, dtype=float)[np.asarray(facets, dtype=np.int64)]
    return x.min(axis=1) - pad, x.max(axis=1) + pad


def _expand_cells(cmin: IntArray, cmax: IntArray) -> tuple[IntArray, IntArray]:
    """List every grid cell touched by every box.

    Returns
    -------
    ids : ndarray (n_entries,) box index of each entry.
    cells : ndarray (n_entries, gdim) integer cell coordinates.
    """
    span = cmax - cmin + 1
    count = span.prod(axis=1)
    ids = np.repeat(np.arange(len(cmin), dtype=np.int64), count)
    local = np.arange(count.sum(), dtype=np.int64) - np.repeat(np.cumsum(count) - count, count)
    cells = np.empty((len(ids), cmin.shape[1]), dtype=np.int64)
    for d in reversed(range(cmin.shape[1])):
        s = span[ids, d]
        cells[:, d] = cmin[ids, d] + local % s
        local //= s
    return ids, cells


def find_candidate_pairs(
    lower_a: npt.ArrayLike,
    upper_a: npt.ArrayLike,
    lower_b: npt.ArrayLike,
    upper_b: npt.ArrayLike,
    cell_size: float | None = None,
) -> tuple[IntArray, IntArray]:
    """All pairs of intersecting axis-aligned boxes (set A x set B).

    Boxes are hashed to a uniform grid (cell size ~ the median box size), pairs
    sharing a cell are tested exactly; each pair is reported once (in the cell
    holding the lower corner of the boxes' intersection).  Expected cost is
    linear in the number of boxes plus the number of pairs.

    Parameters
    ----------
    lower_a, upper_a : array_like, shape (n_a, gdim)
    lower_b, upper_b : array_like, shape (n_b, gdim)
    cell_size : float, optional
        Grid spacing; default: geometric mean of the median box extents of A and B.
        It is doubled while the number of (box, cell) entries would exceed
        ``max(32 (n_a + n_b), 1e5)``.

    Returns
    -------
    ia, ib : ndarray of int64, shape (n_pairs,)
        Intersecting pairs, sorted by ``ia`` then ``ib``.
    """
    amin = np.asarray(lower_a, dtype=float)
    amax = np.asarray(upper_a, dtype=float)
    bmin = np.asarray(lower_b, dtype=float)
    bmax = np.asarray(upper_b, dtype=float)
    empty = np.zeros(0, dtype=np.int64)
    if len(amin) == 0 or len(bmin) == 0:
        return empty, empty.copy()
    origin = np.minimum(amin.min(axis=0), bmin.min(axis=0))
    top = np.maximum(amax.max(axis=0), bmax.max(axis=0))
    span = float(np.max(top - origin))
    if cell_size is None:
        cell_size = float(
            np.sqrt(np.median((amax - amin).max(axis=1)) * np.median((bmax - bmin).max(axis=1)))
        )
    # keep the grid at most ~1e5 cells per axis (int64 keys) and the number of
    # (box, cell) entries within a budget (boxes much larger than the cells)
    h = max(cell_size, span * 1e-5, np.finfo(float).tiny)
    budget = max(32 * (len(amin) + len(bmin)), 100_000)
    ext = np.concatenate([amax - amin, bmax - bmin])
    while np.sum(np.prod(np.floor(ext / h) + 2.0, axis=1)) > budget and h < span:
        h *= 2.0

    def cell(p: FloatArray) -> IntArray:
        return np.floor((p - origin) / h).astype(np.int64)

    ncell = cell(top[None])[0] + 1
    stride = np.concatenate([np.cumprod(ncell[::-1][:-1])[::-1], [1]]).astype(np.int64)  # row-major

    ida, ca = _expand_cells(cell(amin), cell(amax))
    idb, cb = _expand_cells(cell(bmin), cell(bmax))
    ka = ca @ stride
    kb = cb @ stride
    order = np.argsort(kb, kind="stable")
    kb, idb = kb[order], idb[order]
    left = np.searchsorted(kb, ka, side="left")
    nmatch = np.searchsorted(kb, ka, side="right") - left
    pa = np.repeat(ida, nmatch)
    key = np.repeat(ka, nmatch)
    pos = np.repeat(left, nmatch) + (
        np.arange(nmatch.sum(), dtype=np.int64) - np.repeat(np.cumsum(nmatch) - nmatch, nmatch)
    )
    pb = idb[pos]
    lo = np.maximum(amin[pa], bmin[pb])
    ok = np.all(lo <= np.minimum(amax[pa], bmax[pb]), axis=1)
    ok &= cell(lo) @ stride == key  # report each pair once
    pa, pb = pa[ok], pb[ok]
    order = np.lexsort((pb, pa))
    return pa[order], pb[order]
