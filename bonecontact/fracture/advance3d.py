"""The advance of a planar crack front in 3D under mode I
(docs/theory/fracture.md#front-advance-of-a-planar-crack).

The front is a convex polygon in the crack plane (:class:`~bonecontact.fracture.front3d.
PolygonFront`, the ``shape = "polygon"`` crack of :mod:`bonecontact.fracture.crack3d`), K
is evaluated at the middle of every edge, and every vertex moves in the crack plane along
the bisector of its two edges' outward normals by

    Δa_i = Δa_max (K_i / K_max)^n,

K_i the mean of its two edges' K (a vertex lies between them), optionally smoothed along
the front (a periodic moving average of Δa over three vertices, removing the
point-to-point scatter of the domain integral).  Under mode I the crack stays in its plane
(the kink angle of MTS, or of any 3D criterion, is zero); a mixed-mode kink is not
implemented.  Points below K_Ic do not advance.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bonecontact.fracture.crack import FractureError

__all__ = ["advance_polygon_front", "vertex_directions"]


def vertex_directions(vertices: npt.ArrayLike, normal: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Unit in-plane directions in which the vertices of a convex polygon (counter-clockwise
    about ``normal``) advance: the bisectors of the outward normals of their two edges,
    shape (N, 3)."""
    V = np.asarray(vertices, dtype=float)
    n = np.asarray(normal, dtype=float)
    d = np.roll(V, -1, axis=0) - V
    d = d / np.linalg.norm(d, axis=1)[:, None]
    out = np.cross(d, n)  # outward normal of edge k (vertex k → k + 1)
    b = out + np.roll(out, 1, axis=0)  # vertex k: edges k − 1 and k
    return b / np.linalg.norm(b, axis=1)[:, None]


def advance_polygon_front(
    vertices: npt.ArrayLike,
    normal: npt.ArrayLike,
    k_edges: npt.ArrayLike,
    da_max: float,
    exponent: float = 2.0,
    k_ic: float | None = None,
    smooth: bool = True,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Advance the vertices of a planar polygonal front.

    Parameters
    ----------
    vertices
        The front's corners (m), convex, counter-clockwise about ``normal``, shape (N, 3).
    normal
        The crack-plane normal.
    k_edges
        K (Pa·√m; mode I: K_I, else an equivalent K) at the middle of every edge k (vertex
        k → k + 1), shape (N,).
    da_max
        The advance of the point of largest K (m).
    exponent
        n of Δa_i = Δa_max (K_i/K_max)^n.
    k_ic
        Toughness: vertices with K_i < K_Ic hold (``None``: every vertex advances).
    smooth
        Average Δa over each vertex and its two neighbours.

    Returns
    -------
    (new vertices (N, 3), Δa (N,))

    Raises
    ------
    FractureError
        (key ``k_edges``) a K that is not positive and finite, or the wrong count; (key
        ``increment``) an advanced front that is no longer convex.
    """
    V = np.asarray(vertices, dtype=float)
    K = np.asarray(k_edges, dtype=float)
    if K.shape != (len(V),) or not np.all(np.isfinite(K)) or np.any(K <= 0):
        raise FractureError(
            "k_edges", f"need {len(V)} positive finite values (one per edge), got {K}"
        )
    k_vertex = 0.5 * (K + np.roll(K, 1))  # vertex k between edges k − 1 and k
    da = da_max * (k_vertex / k_vertex.max()) ** exponent
    if k_ic is not None:
        da = np.where(k_vertex >= k_ic, da, 0.0)
    if smooth:
        da = (np.roll(da, 1) + da + np.roll(da, -1)) / 3.0
    new = V + da[:, None] * vertex_directions(V, normal)
    d = np.roll(new, -1, axis=0) - new
    turn = np.cross(d, np.roll(d, -1, axis=0)) @ np.asarray(normal, dtype=float)
    if np.any(turn <= 0):
        raise FractureError("increment", "the advanced front is not convex: take a smaller one")
    return new, da
