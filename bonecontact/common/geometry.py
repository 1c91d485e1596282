"""Small 2D geometry helpers shared by the contact, neoplasm and run layers."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["cross2", "polygon_area", "signed_polygon_area"]


def cross2(a: npt.ArrayLike, b: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """z-component of the cross product of 2D vectors.

    Parameters
    ----------
    a, b : array_like, shape (..., 2)
        2D vectors; leading axes broadcast (e.g. one vector per row).

    Returns
    -------
    ndarray, shape (...)
        ``a_x * b_y - a_y * b_x`` for each pair of vectors.
    """
    a = np.asarray(a)
    b = np.asarray(b)
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def signed_polygon_area(points: npt.ArrayLike) -> float:
    """Signed area of a closed polygon (shoelace formula).

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Polygon vertices in order; the closing edge from the last vertex back to the
        first is implied (do not repeat the first vertex).

    Returns
    -------
    float
        Area, positive when the vertices run counter-clockwise, negative clockwise.
    """
    p = np.asarray(points, dtype=np.float64)
    q = np.roll(p, -1, axis=0)
    return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))


def polygon_area(points: npt.ArrayLike) -> float:
    """Unsigned area of a closed polygon.

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Polygon vertices in order (closing edge implied).

    Returns
    -------
    float
        ``abs(signed_polygon_area(points))``.
    """
    return abs(signed_polygon_area(points))
