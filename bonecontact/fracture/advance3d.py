"""The advance of a crack front in 3D (docs/theory/fracture.md#front-advance-of-a-planar-crack,
#mixed-mode-advance-in-3d).

* :func:`advance_polygon_front` — a planar convex polygonal front under mode I: every
  vertex moves in the crack plane along the bisector of its edges' outward normals by
  Δa_i = Δa_max (K_i/K_max)^n (optionally smoothed over three vertices); the advanced
  vertices of both advances lie on a grid of about 10⁻⁶ Δa_max (:func:`on_grid`).
* :func:`sigma1_kink`, :func:`equivalent_k` — the σ₁′ criterion of Schöllmann et al.
  (2002): the kink angle φ₀ that maximises σ₁′ = σ_φ/2 + ½√(σ_φ² + 4τ_φz²) of the
  near-front field, the twist angle ψ₀ and K_V = K_I/2 + ½√(K_I² + 5.336K_II² + 4K_III²).
* :func:`advance_mixed_front` — a closed polyline front under mixed mode: every vertex
  moves by Δa_i = Δa_max (K_V,i/K_V,max)^n in the direction cos φ₀ e₁ + sin φ₀ e₂ of its
  frame (φ₀ and Δa smoothed over three vertices; a vertex of growth weight 0 holds), and
  :func:`extend_surface` adds the strip between the old and the new front to a
  :class:`~bonecontact.fracture.crack3d.TriangulatedCrack` (a held vertex keeps its
  point: one triangle on an edge with one held end, none between two held vertices).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from bonecontact.common.errors import ParameterError
from bonecontact.common.geometry import on_advance_grid
from bonecontact.fracture.crack import segments_intersect
from bonecontact.fracture.crack3d import TriangulatedCrack, in_plane_axis
from bonecontact.fracture.front3d import CrackBlock, FrontSIF, front_interaction_integral
from bonecontact.materials.laws import Isotropic

__all__ = [
    "MixedAdvance",
    "advance_mixed_front",
    "advance_polygon_front",
    "advance_vertices",
    "checked_k_edges",
    "equivalent_k",
    "extend_surface",
    "front_defects",
    "mid_edge_modes",
    "on_grid",
    "sigma1_kink",
    "vertex_directions",
]


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
    ParameterError
        (key ``k_edges``) a K that is not positive and finite, or the wrong count; (key
        ``increment``) an advanced front that is no longer convex.
    """
    V = np.asarray(vertices, dtype=float)
    K = np.asarray(k_edges, dtype=float)
    if K.shape != (len(V),) or not np.all(np.isfinite(K)) or np.any(K <= 0):
        raise ParameterError(
            "k_edges", f"need {len(V)} positive finite values (one per edge), got {K}"
        )
    k_vertex = 0.5 * (K + np.roll(K, 1))  # vertex k between edges k − 1 and k
    da = da_max * (k_vertex / k_vertex.max()) ** exponent
    if k_ic is not None:
        da = np.where(k_vertex >= k_ic, da, 0.0)
    if smooth:
        da = (np.roll(da, 1) + da + np.roll(da, -1)) / 3.0
    new = on_grid(V + da[:, None] * vertex_directions(V, normal), da_max)
    d = np.roll(new, -1, axis=0) - new
    turn = np.cross(d, np.roll(d, -1, axis=0)) @ np.asarray(normal, dtype=float)
    if np.any(turn <= 0):
        raise ParameterError("increment", "the advanced front is not convex: take a smaller one")
    return new, da


def on_grid(points: npt.ArrayLike, da_max: float) -> npt.NDArray[np.float64]:
    """``points`` rounded to a grid of spacing 2^(⌊log₂ Δa_max⌋ − 20) (about 10⁻⁶ of the
    advance; :func:`~bonecontact.common.geometry.on_advance_grid`): the advanced vertices
    come from K whose round-off differs with the number of ranks, and gmsh meshes a front
    moved by 10⁻¹⁶ differently (K of the next solve then differed by 1.7·10⁻⁵ between 1
    and 2 ranks); on the grid every rank count meshes the same front."""
    if not da_max > 0:
        raise ParameterError("increment", f"the advance must be positive, got {da_max}")
    return on_advance_grid(points, da_max)


# ------------------------------------------------------------------ mixed mode (σ₁′)
_GRID = np.radians(np.linspace(-100.0, 100.0, 4001))  # candidate kink angles, 0.05°


def _sigma1(phi, k1, k2, k3):
    """σ₁′ √(2πr) of the near-front field at the angle ``phi`` (broadcast) and σ_φ, τ_φz."""
    c = np.cos(phi / 2)
    s_phi = c * (k1 * c**2 - 1.5 * k2 * np.sin(phi))
    tau = k3 * c
    return 0.5 * s_phi + 0.5 * np.sqrt(s_phi**2 + 4 * tau**2), s_phi, tau


def sigma1_kink(
    k_i: npt.ArrayLike, k_ii: npt.ArrayLike, k_iii: npt.ArrayLike
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Kink angle φ₀ and twist angle ψ₀ (rad) of the σ₁′ criterion (Schöllmann et al.
    2002) at every point.

    φ₀ maximises σ₁′(φ) = σ_φ/2 + ½√(σ_φ² + 4τ_φz²), σ_φ = cos(φ/2)[K_I cos²(φ/2) −
    (3/2)K_II sin φ], τ_φz = K_III cos(φ/2) (the factor 1/√(2πr) dropped), over
    |φ| ≤ 100° (a grid of 0.05° refined by a parabola through the best three); ψ₀ =
    ½ atan(2τ_φz/σ_φ) at φ₀.  K_III = 0 gives the MTS angle; K_II > 0 a negative φ₀
    (towards −e₂).
    """
    k1, k2, k3 = (np.atleast_1d(np.asarray(k, dtype=float))[:, None] for k in (k_i, k_ii, k_iii))
    val, _, _ = _sigma1(_GRID[None, :], k1, k2, k3)
    j = np.clip(np.argmax(val, axis=1), 1, len(_GRID) - 2)
    rows = np.arange(len(j))
    y0, y1, y2 = val[rows, j - 1], val[rows, j], val[rows, j + 1]
    den = y0 - 2 * y1 + y2
    step = _GRID[1] - _GRID[0]
    shift = np.where(np.abs(den) > 0, 0.5 * (y0 - y2) / np.where(den == 0, 1, den), 0.0)
    phi0 = _GRID[j] + np.clip(shift, -1, 1) * step
    _, s_phi, tau = _sigma1(phi0, k1[:, 0], k2[:, 0], k3[:, 0])
    psi0 = 0.5 * np.arctan2(2 * tau, s_phi)
    return phi0, psi0


def equivalent_k(k_i: npt.ArrayLike, k_ii: npt.ArrayLike, k_iii: npt.ArrayLike):
    """K_V = K_I/2 + ½√(K_I² + 5.336 K_II² + 4 K_III²) (Schöllmann et al. 2002)."""
    k1, k2, k3 = (np.asarray(k, dtype=float) for k in (k_i, k_ii, k_iii))
    return 0.5 * k1 + 0.5 * np.sqrt(k1**2 + 5.336 * k2**2 + 4 * k3**2)


@dataclass(frozen=True)
class MixedAdvance:
    """One mixed-mode advance: the new front vertices, Δa, φ₀, ψ₀ and the unit
    direction of every vertex, K_V at the vertices, and which vertices hold (weight 0:
    their new vertex is the old one, exactly)."""

    vertices: npt.NDArray[np.float64]
    da: npt.NDArray[np.float64]
    kink: npt.NDArray[np.float64]
    twist: npt.NDArray[np.float64]
    directions: npt.NDArray[np.float64]
    k_v: npt.NDArray[np.float64]
    held: npt.NDArray[np.bool_]


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _vertex_frames(V: np.ndarray, normals2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(e₁, e₂) at the vertices of a closed polyline: the means of the frames of its two
    edges (e₁ = t × e₂ on an edge), e₂ made normal to e₁."""
    t = _unit(np.roll(V, -1, axis=0) - V)
    e1 = np.cross(t, normals2)
    e1v = _unit(e1 + np.roll(e1, 1, axis=0))
    e2v = normals2 + np.roll(normals2, 1, axis=0)
    e2v = _unit(e2v - np.sum(e2v * e1v, axis=1)[:, None] * e1v)
    return e1v, e2v


def _smooth(x: np.ndarray) -> np.ndarray:
    return (np.roll(x, 1, axis=0) + x + np.roll(x, -1, axis=0)) / 3.0


def _smooth_growing(da: np.ndarray, held: np.ndarray) -> np.ndarray:
    """Δa averaged over each growing vertex and its growing neighbours (the held ones 0);
    with none held exactly :func:`_smooth`."""
    grows = np.where(held, 0.0, 1.0)
    return np.where(held, 0.0, _smooth(da) / np.maximum(_smooth(grows), 1.0 / 3.0))


def advance_mixed_front(
    vertices: npt.ArrayLike,
    normals2: npt.ArrayLike,
    k_edges: npt.ArrayLike,
    da_max: float,
    exponent: float = 2.0,
    smooth: bool = True,
    weights: npt.ArrayLike | None = None,
) -> MixedAdvance:
    """Advance a closed polyline front under mixed mode by the σ₁′ criterion.

    Parameters
    ----------
    vertices
        The front's vertices (m), shape (N, 3), counter-clockwise seen from the side e₂
        points to.
    normals2
        The crack-surface normal e₂ of every edge (vertex k → k + 1), shape (N, 3).
    k_edges
        (K_I, K_II, K_III) at the middle of every edge (Pa·√m), shape (N, 3).
    da_max
        The advance of the vertex of largest K_V (m).
    exponent
        n of Δa_i = Δa_max (K_V,i/K_V,max)^n.
    smooth
        Average φ₀ and Δa over each vertex and its two neighbours.
    weights
        The vertices' growth weights w_i in [0, 1] (shape (N,)): Δa_i = Δa_max w_i instead
        of (K_V,i/K_V,max)^n (fatigue: the Paris rate over the largest rate).  A vertex of
        weight 0 holds: Δa_i = 0 and its new vertex is the old one; the average of Δa over
        three vertices then runs over the vertex and its neighbours that grow (with no
        vertex held, the plain three-vertex average).

    Raises
    ------
    ParameterError
        (key ``k_edges``) not finite, the wrong shape, or K_V ≤ 0 somewhere.
    """
    V = np.asarray(vertices, dtype=float)
    K = checked_k_edges(k_edges, len(V))
    K_vertex = 0.5 * (K + np.roll(K, 1, axis=0))
    e1, e2 = _vertex_frames(V, _unit(np.asarray(normals2, dtype=float)))
    smoothing = (_smooth, _smooth_growing) if smooth else None
    return advance_vertices(V, e1, e2, K_vertex, da_max, exponent, smoothing, weights)


def checked_k_edges(k_edges: npt.ArrayLike, n_edges: int) -> npt.NDArray[np.float64]:
    """(K_I, K_II, K_III) at a front's ``n_edges`` edge middles as an (n_edges, 3) array.

    Raises
    ------
    ParameterError
        (key ``k_edges``) not finite, the wrong shape, or K_V ≤ 0 at an edge.
    """
    K = np.asarray(k_edges, dtype=float)
    if K.shape != (n_edges, 3) or not np.all(np.isfinite(K)):
        raise ParameterError("k_edges", f"need shape ({n_edges}, 3), finite, got {K.shape}")
    if np.any(equivalent_k(K[:, 0], K[:, 1], K[:, 2]) <= 0):
        raise ParameterError("k_edges", "the equivalent K must be positive at every edge")
    return K


def advance_vertices(
    V: npt.NDArray[np.float64],
    e1: npt.NDArray[np.float64],
    e2: npt.NDArray[np.float64],
    K_vertex: npt.NDArray[np.float64],
    da_max: float,
    exponent: float = 2.0,
    smoothing: tuple[Callable, Callable] | None = None,
    weights: npt.ArrayLike | None = None,
) -> MixedAdvance:
    """The σ₁′ step of a front's vertices, closed or open: kink φ₀ and twist ψ₀ of the
    vertices' K, Δa_i = Δa_max (K_V,i/K_V,max)^n (or Δa_max w_i; w_i = 0 holds), φ₀ and
    Δa smoothed along the front, each vertex moved by Δa_i along cos φ₀ e₁ + sin φ₀ e₂
    (on the advance grid of Δa_max).

    Parameters
    ----------
    V, e1, e2
        The vertices (m) and their unit frames, each shape (N, 3).
    K_vertex
        (K_I, K_II, K_III) at the vertices, shape (N, 3) (Pa·√m).
    da_max, exponent, weights
        As :func:`advance_mixed_front`.
    smoothing
        ``(smooth_phi(φ₀), smooth_da(Δa, held))`` along the front (a closed front's average
        over three vertices; an open front's over the neighbours an end has); ``None``: none.
    """
    kv = equivalent_k(K_vertex[:, 0], K_vertex[:, 1], K_vertex[:, 2])
    phi0, psi0 = sigma1_kink(K_vertex[:, 0], K_vertex[:, 1], K_vertex[:, 2])
    w = (kv / kv.max()) ** exponent if weights is None else np.asarray(weights, dtype=float)
    held = w <= 0.0
    da = np.where(held, 0.0, da_max * w)
    if smoothing is not None:
        phi0 = smoothing[0](phi0)
        da = smoothing[1](da, held)
    d = np.cos(phi0)[:, None] * e1 + np.sin(phi0)[:, None] * e2
    new = np.where(held[:, None], V, on_grid(V + da[:, None] * d, da_max))
    return MixedAdvance(new, da, phi0, psi0, d, kv, held)


def _oriented(tri: np.ndarray, up: np.ndarray) -> tuple[bool, np.ndarray]:
    """Whether the triangle (3, 3) runs counter-clockwise seen from ``up``, and its unit
    normal on the side of ``up``."""
    n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    n = n / np.linalg.norm(n)
    return bool(n @ up > 0), (n if n @ up > 0 else -n)


def extend_surface(
    crack: TriangulatedCrack, new_vertices: npt.ArrayLike, held: npt.ArrayLike | None = None
) -> TriangulatedCrack:
    """The crack grown to the front ``new_vertices`` (N, 3): the strip between the old and
    the new front as four triangles per edge, from the sides of the quadrilateral
    (V_k, V_k+1, V′_k+1, V′_k) to its centroid (a twisted quadrilateral keeps a symmetric
    triangle on the new edge); the new front's e₂ the normal of the triangle on the new
    edge, and its kink (L, ψ): L the strip's width along the new e₁, ψ the direction of
    the old surface behind the old edge seen in the new frame.

    ``held`` (N booleans): those vertices stay where they are and keep their point (no new
    point); an edge with one held end gets the one triangle (V_k, V_k+1, the moved end's
    new vertex), an edge with both ends held no strip: it keeps its e₂ and kink (the first
    polygon's edge the kink (0, π): straight behind).  No triangle has zero area."""
    P = np.asarray(crack.points, dtype=float)
    old = np.asarray(crack.front_ids)
    W = np.asarray(new_vertices, dtype=float)
    N = len(old)
    hold = np.zeros(N, dtype=bool) if held is None else np.asarray(held, dtype=bool)
    moving = np.flatnonzero(~hold)
    new = old.copy()
    new[moving] = len(P) + np.arange(len(moving))
    P2 = np.concatenate([P, W[moving]])
    quads = [(old[k], old[(k + 1) % N], new[(k + 1) % N], new[k]) for k in range(N)]
    full = [k for k in range(N) if not (hold[k] or hold[(k + 1) % N])]
    mid = dict(zip(full, range(len(P2), len(P2) + len(full)), strict=True))
    centres = [np.mean(P2[list(quads[k])], axis=0) for k in full]
    P2 = np.concatenate([P2, np.reshape(centres, (-1, 3))])
    e2_old = np.asarray(crack.normals2, dtype=float)
    t_old = _unit(np.roll(P[old], -1, axis=0) - P[old])
    e1_old = np.cross(t_old, e2_old)
    patches, normals2, cuts = list(crack.patches), [], []
    for k, (a, b, b2, a2) in enumerate(quads):
        if hold[k] and hold[(k + 1) % N]:  # no strip: the edge as it was
            normals2.append(e2_old[k])
            cuts.append(crack.cuts[k] if crack.cuts is not None else (0.0, math.pi))
            continue
        if k in mid:
            tris = [(p, q, mid[k]) for p, q in ((a, b), (b, b2), (a2, a), (b2, a2))]
        else:  # one end held: one triangle, the new edge its side (a2, b2)
            tris = [(a, b, b2) if a2 == a else (a, b, a2)]
        for tri in tris:
            ccw, n = _oriented(P2[list(tri)], e2_old[k])
            patches.append(tuple(int(i) for i in (tri if ccw else tri[::-1])))
        normals2.append(n)  # the last triangle holds the new edge
        t = _unit(P2[b2] - P2[a2])
        e1 = np.cross(t, n)
        width = float((0.5 * (P2[a2] + P2[b2]) - 0.5 * (P2[a] + P2[b])) @ e1)
        back = -e1_old[k]
        cuts.append((width, math.atan2(float(back @ n), float(back @ e1))))
    return TriangulatedCrack(
        tuple(map(tuple, P2)),
        tuple(patches),
        tuple(int(i) for i in new),
        tuple(tuple(map(float, n)) for n in normals2),
        tuple(tuple(map(float, c)) for c in cuts),
        crack.normal,
    )


def front_defects(vertices: npt.ArrayLike, normal: npt.ArrayLike) -> str | None:
    """What keeps a closed front from being a convex polygon seen along ``normal`` (its
    vertices projected on the plane normal to it), ``None`` when it is one.

    The mid-edge K (:func:`mid_edge_modes`) and the advance (:func:`vertex_directions`)
    take a convex front: every other edge beyond the integration ring of an edge.  A
    vertex where the front turns to the right (clockwise about ``normal``) or folds back
    on itself, and two edges that cross or touch, are named (vertex k as ``point`` k of
    ``fracture.csv``, edge k from vertex k to k + 1), e.g. ``"turns right at vertices 3,
    4; edges 2 and 6 cross"``.
    """
    V = np.asarray(vertices, dtype=float)
    n = _unit(np.asarray(normal, dtype=float))
    u = in_plane_axis(n)
    P = np.column_stack([V @ u, V @ np.cross(n, u)])
    d = np.roll(P, -1, axis=0) - P  # edge k: vertex k to k + 1
    before = np.roll(d, 1, axis=0)  # edge k − 1, into vertex k
    cross = before[:, 0] * d[:, 1] - before[:, 1] * d[:, 0]
    dot = np.sum(before * d, axis=1)
    scale = np.linalg.norm(before, axis=1) * np.linalg.norm(d, axis=1)
    right = np.flatnonzero((cross < 0) | ((cross <= 1e-12 * scale) & (dot < 0)))
    N = len(P)
    pairs = [
        (i, j)
        for i in range(N)
        for j in range(i + 2, N - (i == 0))
        if segments_intersect(P[i], P[(i + 1) % N], P[j], P[(j + 1) % N])
    ]
    parts = []
    if len(right):
        parts.append("turns right at vertices " + ", ".join(map(str, right)))
    parts += [f"edges {i} and {j} cross" for i, j in pairs]
    return "; ".join(parts) if parts else None


def mid_edge_modes(
    crack: TriangulatedCrack,
    block: CrackBlock,
    u: Any,
    material: Isotropic,
    h_front: float,
    face_traction: tuple | None = None,
) -> list[FrontSIF]:
    """K_I, K_II, K_III at the middle of every front edge of a polygonal (grown) crack by
    the interaction integral (collective): the ring r_out = 4 h_f, along the edge up to
    the distance to its corners less a front element (the straight-edge auxiliary field
    holds up to the corner); ``face_traction`` the contact tractions of a closed crack."""
    front = crack.front()
    phis = crack.front_parameters(1)
    r_out = 4.0 * h_front
    length = min(r_out, min(front.corner_distance(float(p)) for p in phis) - h_front)
    return [
        front_interaction_integral(
            u, block, float(p), material, r_out, None, length, face_traction=face_traction
        )
        for p in phis
    ]
