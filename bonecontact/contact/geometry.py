"""Vector primitives and surface frames of the mortar geometry, pure NumPy.

Array type aliases, the 2D cross product, normalisation, simplex measures, unit facet
normals, area-weighted averaged nodal normals and nodal tangent frames of a surface
mesh given as plain coordinate / connectivity arrays.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = [
    "BoolArray",
    "FloatArray",
    "IntArray",
    "facet_normals",
    "nodal_normals",
    "nodal_tangents",
    "normalise",
    "simplex_measure",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]


def simplex_measure(vertices: FloatArray) -> FloatArray:
    """Measure (length / area) of P1 simplices embedded in any dimension.

    Parameters
    ----------
    vertices : ndarray, shape (n, nv, gdim)

    Returns
    -------
    ndarray, shape (n,)
    """
    jac = vertices[:, 1:, :] - vertices[:, :1, :]  # (n, nv-1, gdim)
    gram = np.einsum("nig,njg->nij", jac, jac)
    fact = 1.0 if jac.shape[1] == 1 else 0.5
    return fact * np.sqrt(np.maximum(np.linalg.det(gram), 0.0))


def normalise(v: FloatArray) -> FloatArray:
    """Normalise vectors along the last axis, leaving zero vectors at zero."""
    norm = np.sqrt(np.sum(v * v, axis=-1, keepdims=True))
    return np.divide(v, norm, out=np.zeros_like(v), where=norm > 0.0)


def facet_normals(
    coords: npt.ArrayLike,
    facets: npt.ArrayLike,
    interior_points: npt.ArrayLike | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Unit facet normals and facet measures of a surface mesh.

    Parameters
    ----------
    coords : array_like, shape (n_vertices, gdim)
        Vertex coordinates, ``gdim`` 2 (facets are segments) or 3 (triangles).
    facets : array_like of int, shape (n_facets, gdim)
        Facet-to-vertex connectivity.
    interior_points : array_like, shape (n_facets, gdim), optional
        A point inside the body for every facet (e.g. the vertex of the owning
        cell opposite the facet).  Each normal is flipped to point away from it,
        i.e. outward.  Without it the orientation follows the vertex ordering
        (2D: ``(t_y, -t_x)`` for ``t = x_1 - x_0``; 3D: ``(x_1-x_0) x (x_2-x_0)``).

    Returns
    -------
    normals : ndarray, shape (n_facets, gdim)
    measures : ndarray, shape (n_facets,)
        Lengths (2D) or areas (3D).
    """
    coords = np.asarray(coords, dtype=float)
    facets = np.asarray(facets, dtype=np.int64)
    x = coords[facets]
    gdim = coords.shape[1]
    if gdim == 2 and facets.shape[1] == 2:
        t = x[:, 1] - x[:, 0]
        n = np.stack([t[:, 1], -t[:, 0]], axis=1)
        measure = np.linalg.norm(t, axis=1)
    elif gdim == 3 and facets.shape[1] == 3:
        n = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
        measure = 0.5 * np.linalg.norm(n, axis=1)
    else:
        raise ValueError("expected segments in 2D or triangles in 3D")
    n = normalise(n)
    if interior_points is not None:
        inner = np.asarray(interior_points, dtype=float)
        side = np.einsum("fg,fg->f", n, x.mean(axis=1) - inner)
        n = np.where(side[:, None] < 0.0, -n, n)
    return n, measure


def nodal_normals(
    coords: npt.ArrayLike,
    facets: npt.ArrayLike,
    interior_points: npt.ArrayLike | None = None,
) -> FloatArray:
    """Averaged nodal normals (facet normals weighted by facet measure).

    Parameters
    ----------
    coords, facets, interior_points
        As in :func:`facet_normals`.

    Returns
    -------
    ndarray, shape (n_vertices, gdim)
        Unit outward normals; zero rows for vertices not in any facet.
    """
    coords = np.asarray(coords, dtype=float)
    facets = np.asarray(facets, dtype=np.int64)
    n, measure = facet_normals(coords, facets, interior_points)
    weighted = np.repeat(n * measure[:, None], facets.shape[1], axis=0)
    flat = facets.ravel()
    acc = np.stack(
        [
            np.bincount(flat, weights=weighted[:, d], minlength=coords.shape[0])
            for d in range(coords.shape[1])
        ],
        axis=1,
    )
    return normalise(acc)


def nodal_tangents(normals: npt.ArrayLike) -> FloatArray:
    """Orthonormal tangents completing the nodal normals to a right-handed frame.

    Parameters
    ----------
    normals : array_like, shape (n, gdim)
        Unit normals.

    Returns
    -------
    ndarray, shape (n, gdim - 1, gdim)
        2D: ``t = (-n_y, n_x)``; 3D: ``t1 ⟂ n`` built from the coordinate axis least
        aligned with ``n`` and ``t2 = n x t1`` (so ``t1 x t2 = n``).  Zero normals
        give zero tangents.
    """
    n = np.asarray(normals, dtype=float)
    if n.shape[1] == 2:
        return np.stack([-n[:, 1], n[:, 0]], axis=1)[:, None, :]
    axis = np.eye(3)[np.argmin(np.abs(n), axis=1)]
    t1 = normalise(axis - np.einsum("ng,ng->n", axis, n)[:, None] * n)
    t1 = np.where(np.linalg.norm(n, axis=1)[:, None] > 0.0, t1, 0.0)
    t2 = np.cross(n, t1)
    return np.stack([t1, t2], axis=1)
