"""Mean curvature of closed polygons (2D) and closed triangulated surfaces (3D).

Convention: kappa = div n (n the outward unit normal), positive for convex bodies:
a circle of radius R has kappa = 1/R, a sphere kappa = 2/R (the SUM of the principal
curvatures, kappa_1 + kappa_2; docs/theory/growth.md#tumour-model's c_kappa = 1).

``polygon_curvature(points)``
    Menger curvature (inverse circumradius of each node and its two neighbours), signed;
    exact for nodes on a circle, second order for smooth curves with uniform node spacing.
``surface_curvature(points, triangles)``
    Cotangent-Laplacian mean-curvature normal with mixed Voronoi areas (Meyer, Desbrun,
    Schröder & Barr 2003): |Delta_s x| = kappa_1 + kappa_2, signed with the outward normal.
``vertex_normals(points, triangles)``
    Area-weighted outward vertex normals of a closed triangulation.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["polygon_curvature", "polygon_normals", "surface_curvature", "vertex_normals"]


def polygon_curvature(points: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Signed curvature at the nodes of a closed polygon (counter-clockwise: convex > 0)."""
    p = np.asarray(points, dtype=np.float64)
    a = p - np.roll(p, 1, axis=0)  # p_i - p_{i-1}
    b = np.roll(p, -1, axis=0) - p  # p_{i+1} - p_i
    c = np.roll(p, -1, axis=0) - np.roll(p, 1, axis=0)
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return (
        2.0
        * cross
        / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1) * np.linalg.norm(c, axis=1))
    )


def polygon_normals(points: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Outward unit normals at the nodes of a counter-clockwise polygon (edge-length weighted)."""
    p = np.asarray(points, dtype=np.float64)
    t = np.roll(p, -1, axis=0) - np.roll(p, 1, axis=0)
    n = np.column_stack([t[:, 1], -t[:, 0]])
    return n / np.linalg.norm(n, axis=1)[:, None]


def vertex_normals(points: npt.ArrayLike, triangles: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Area-weighted unit vertex normals of an outward-oriented closed triangulation."""
    x = np.asarray(points, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    fn = np.cross(x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]])
    n = np.zeros_like(x)
    for k in range(3):
        np.add.at(n, t[:, k], fn)
    return n / np.linalg.norm(n, axis=1)[:, None]


def surface_curvature(points: npt.ArrayLike, triangles: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """kappa_1 + kappa_2 at the vertices of an outward-oriented closed triangulation."""
    x = np.asarray(points, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    lap = np.zeros_like(x)
    area = np.zeros(len(x))
    e = [x[t[:, (k + 2) % 3]] - x[t[:, (k + 1) % 3]] for k in range(3)]  # edge opposite k
    tri_area = 0.5 * np.linalg.norm(np.cross(e[0], e[1]), axis=1)
    cot = []
    for k in range(3):
        u = x[t[:, (k + 1) % 3]] - x[t[:, k]]
        v = x[t[:, (k + 2) % 3]] - x[t[:, k]]
        cot.append(np.einsum("ij,ij->i", u, v) / np.linalg.norm(np.cross(u, v), axis=1))
    cot = np.array(cot)  # (3, M): cotangent of the angle at vertex k
    for k in range(3):
        i, j = t[:, (k + 1) % 3], t[:, (k + 2) % 3]
        d = (x[i] - x[j]) * cot[k][:, None]
        np.add.at(lap, i, d)
        np.add.at(lap, j, -d)
    obtuse = cot < 0
    any_obtuse = obtuse.any(axis=0)
    for k in range(3):
        j, m = (k + 1) % 3, (k + 2) % 3
        # Voronoi area of vertex k: (|e_kj|^2 cot_m + |e_km|^2 cot_j) / 8
        ekj = np.sum((x[t[:, j]] - x[t[:, k]]) ** 2, axis=1)
        ekm = np.sum((x[t[:, m]] - x[t[:, k]]) ** 2, axis=1)
        vor = (ekj * cot[m] + ekm * cot[j]) / 8.0
        a = np.where(any_obtuse, np.where(obtuse[k], tri_area / 2, tri_area / 4), vor)
        np.add.at(area, t[:, k], a)
    hn = lap / (2.0 * area[:, None])  # = (kappa_1 + kappa_2) n
    n = vertex_normals(x, t)
    return np.einsum("ij,ij->i", hn, n)
