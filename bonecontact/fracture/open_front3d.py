"""The mixed-mode advance of an open front: a grown surface-breaking crack
(docs/theory/fracture.md#mixed-mode-advance-of-an-open-front).

The open counterparts of :func:`~bonecontact.fracture.advance3d.advance_mixed_front` and
:func:`~bonecontact.fracture.advance3d.extend_surface`, for a front whose two ends lie on
the free surface (a surface crack that kinks):

* :class:`OpenTriangulatedCrack` — planar patches and an open polyline front (N vertices,
  N − 1 edges with their surface normal e₂ and kink), its front an
  :class:`~bonecontact.fracture.front3d.OpenPolylineFront`;
* :func:`advance_open_front` — every vertex moves by Δa_i = Δa_max (K_V,i/K_V,max)^n (or
  its fatigue weight) in the direction cos φ₀ e₁ + sin φ₀ e₂ of the σ₁′ criterion; an
  inner vertex takes the mean K and frame of its two edges, an end vertex those of its
  one edge (K is not taken at the surface point itself); φ₀ and Δa are averaged over
  each vertex and the neighbours it has;
* :func:`extend_open_surface` — the strip between the old and the new front, edge by
  edge, two triangles each (held vertices keep their point);
* :func:`open_mid_edge_modes` — K_I, K_II, K_III at the middle of every edge;
* :func:`cut_front`, :func:`cut_block` — the front of a non-planar crack cut into a body
  (:mod:`~bonecontact.fracture.nonplanar_surface_body3d`) and its model for the integral.

Where the new ends lie against the body's surface is the caller's (the end vertices move
like the others; :mod:`bonecontact.runners.nonplanar_surface3d` puts them back beyond it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.advance3d import (
    MixedAdvance,
    advance_vertices,
    checked_k_edges,
    equivalent_k,
)
from bonecontact.fracture.front3d import (
    CrackBlock,
    FrontSIF,
    OpenPolylineFront,
    front_interaction_integral,
)

if TYPE_CHECKING:
    from dolfinx import fem

    from bonecontact.fracture.body3d import CrackedBody3D
    from bonecontact.fracture.nonplanar_surface_body3d import NonplanarCut
    from bonecontact.materials.laws import Isotropic

__all__ = [
    "OpenTriangulatedCrack",
    "advance_open_front",
    "cut_block",
    "cut_front",
    "extend_open_surface",
    "open_mid_edge_modes",
    "vertex_k",
]


@dataclass(frozen=True)
class OpenTriangulatedCrack:
    """A grown surface-breaking crack: planar patches with an open polyline front.

    Parameters
    ----------
    points
        Coordinates (m), shape (M, 3).
    patches
        Planar polygons (indices into ``points``), each counter-clockwise seen from the
        side ``normal`` points to (the ``crack_upper`` face).
    front_ids
        Indices of the front's N vertices, in order, the first and the last at the free
        surface; e₁ = t × e₂ points ahead (t the direction of an edge).
    normals2
        The surface normal e₂ of every front edge (vertex k to k + 1), shape (N − 1, 3).
    cuts
        (L, ψ) of every front edge (the kink behind it), or ``None``.
    normal
        A unit normal of the whole crack (the first crack's).
    """

    points: tuple[tuple[float, float, float], ...]
    patches: tuple[tuple[int, ...], ...]
    front_ids: tuple[int, ...]
    normals2: tuple[tuple[float, float, float], ...]
    cuts: tuple[tuple[float, float], ...] | None
    normal: tuple[float, float, float]

    @property
    def vertices(self) -> npt.NDArray[np.float64]:
        """The front's vertices (m), shape (N, 3)."""
        return np.asarray(self.points, dtype=float)[list(self.front_ids)]

    def front(self) -> OpenPolylineFront:
        """The crack front."""
        return OpenPolylineFront(
            tuple(map(tuple, self.vertices)), self.normals2, self.cuts, self.normal
        )


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _edge_frames(V: np.ndarray, normals2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(e₁, e₂) of every edge: e₁ = t × e₂."""
    t = _unit(np.diff(V, axis=0))
    return np.cross(t, normals2), normals2


def _at_vertices(x: np.ndarray) -> np.ndarray:
    """Edge values (N − 1, ...) at the N vertices: the mean of the two edges of an inner
    vertex, the one edge's value at an end."""
    return np.concatenate([x[:1], 0.5 * (x[:-1] + x[1:]), x[-1:]])


def vertex_k(k_edges: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """The equivalent K_V (Pa·√m) at the N vertices of an open front from (K_I, K_II,
    K_III) at the middles of its N − 1 edges: of the mean K of an inner vertex's two edges,
    of its one edge's K at an end (the values :func:`advance_open_front` advances by)."""
    Kv = _at_vertices(np.asarray(k_edges, dtype=float))
    return equivalent_k(Kv[:, 0], Kv[:, 1], Kv[:, 2])


def _vertex_frames(V: np.ndarray, normals2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(e₁, e₂) at the vertices: the means of the frames of their edges (an end: its
    edge's), e₂ made normal to e₁."""
    e1, e2 = _edge_frames(V, normals2)
    e1v = _unit(_at_vertices(e1))
    e2v = _at_vertices(e2)
    e2v = _unit(e2v - np.sum(e2v * e1v, axis=1)[:, None] * e1v)
    return e1v, e2v


def _smooth_open(x: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
    """The mean of x over each vertex and the neighbours it has, counting only the
    vertices of ``mask`` (all by default); a masked-out vertex gets 0."""
    m = np.ones(len(x)) if mask is None else mask.astype(float)
    xm = x * m
    total = xm.copy()
    count = m.copy()
    total[1:] += xm[:-1]
    total[:-1] += xm[1:]
    count[1:] += m[:-1]
    count[:-1] += m[1:]
    return np.where(m > 0, total / np.maximum(count, 1.0), 0.0)


def advance_open_front(
    vertices: npt.ArrayLike,
    normals2: npt.ArrayLike,
    k_edges: npt.ArrayLike,
    da_max: float,
    exponent: float = 2.0,
    smooth: bool = True,
    weights: npt.ArrayLike | None = None,
) -> MixedAdvance:
    """Advance an open polyline front under mixed mode by the σ₁′ criterion.

    Parameters
    ----------
    vertices
        The front's N vertices (m), shape (N, 3), N ≥ 2, ordered as
        :class:`OpenTriangulatedCrack`'s.
    normals2
        e₂ of every edge, shape (N − 1, 3).
    k_edges
        (K_I, K_II, K_III) at the middle of every edge (Pa·√m), shape (N − 1, 3).
    da_max, exponent, smooth, weights
        As :func:`~bonecontact.fracture.advance3d.advance_mixed_front` (``weights`` one
        per vertex; a vertex of weight 0 holds).  The averages over three vertices take
        two at an end.

    Raises
    ------
    ParameterError
        (key ``k_edges``) not finite, the wrong shape, or K_V ≤ 0 somewhere; (key
        ``vertices``) fewer than two.
    """
    V = np.asarray(vertices, dtype=float)
    if len(V) < 2:
        raise ParameterError("vertices", f"an open front needs 2 or more vertices, got {len(V)}")
    K = checked_k_edges(k_edges, len(V) - 1)
    e1, e2 = _vertex_frames(V, _unit(np.asarray(normals2, dtype=float)))
    smoothing = (_smooth_open, lambda da, held: _smooth_open(da, ~held)) if smooth else None
    return advance_vertices(V, e1, e2, _at_vertices(K), da_max, exponent, smoothing, weights)


def _oriented(tri: np.ndarray, up: np.ndarray) -> tuple[bool, np.ndarray]:
    """Whether the triangle (3, 3) runs counter-clockwise seen from ``up``, and its unit
    normal on the side of ``up``."""
    n = _unit(np.cross(tri[1] - tri[0], tri[2] - tri[0]))
    return bool(n @ up > 0), (n if n @ up > 0 else -n)


def _strip(quad: tuple[int, ...], full: bool) -> list[tuple[int, ...]]:
    """The triangles of one edge's strip (V_k, V_k+1, V′_k+1, V′_k): two, split along
    V_k V′_k+1 (no point inside the strip: where the strip crosses the body's surface a
    point there could lie on it), the second on the new edge; or the one triangle of an
    edge with one held end."""
    a, b, b2, a2 = quad
    if full:
        return [(a, b, b2), (a, b2, a2)]
    return [(a, b, b2) if a2 == a else (a, b, a2)]


def extend_open_surface(
    crack: OpenTriangulatedCrack, new_vertices: npt.ArrayLike, held: npt.ArrayLike | None = None
) -> OpenTriangulatedCrack:
    """The crack grown to the front ``new_vertices`` (N, 3): for every edge the strip
    between the old and the new edge as two triangles (:func:`_strip`; a closed front's
    :func:`~bonecontact.fracture.advance3d.extend_surface` takes four to the centroid, a
    point that on the first and last edges would lie near the body's surface), one
    triangle where one end holds, none where both hold (the edge keeping its e₂ and kink);
    the new edge's e₂ the normal of the triangle on it, its kink (L, ψ) the strip's width
    along the new e₁ and the direction of the old surface seen in the new frame."""
    P = np.asarray(crack.points, dtype=float)
    old = np.asarray(crack.front_ids)
    W = np.asarray(new_vertices, dtype=float)
    N = len(old)
    if W.shape != (N, 3):
        raise ParameterError("new_vertices", f"need shape ({N}, 3), got {W.shape}")
    hold = np.zeros(N, dtype=bool) if held is None else np.asarray(held, dtype=bool)
    moving = np.flatnonzero(~hold)
    new = old.copy()
    new[moving] = len(P) + np.arange(len(moving))
    P2 = np.concatenate([P, W[moving]])
    quads = [(old[k], old[k + 1], new[k + 1], new[k]) for k in range(N - 1)]
    e1_old, e2_old = _edge_frames(P[old], np.asarray(crack.normals2, dtype=float))
    patches, normals2, cuts = list(crack.patches), [], []
    for k, quad in enumerate(quads):
        if hold[k] and hold[k + 1]:  # no strip: the edge as it was
            normals2.append(e2_old[k])
            cuts.append(crack.cuts[k] if crack.cuts is not None else (0.0, math.pi))
            continue
        for tri in _strip(quad, not (hold[k] or hold[k + 1])):
            ccw, n = _oriented(P2[list(tri)], e2_old[k])
            patches.append(tuple(int(i) for i in (tri if ccw else tri[::-1])))
        normals2.append(n)  # the last triangle holds the new edge
        a, b, b2, a2 = quad
        e1 = np.cross(_unit(P2[b2] - P2[a2]), n)
        width = float((0.5 * (P2[a2] + P2[b2]) - 0.5 * (P2[a] + P2[b])) @ e1)
        back = -e1_old[k]
        cuts.append((width, math.atan2(float(back @ n), float(back @ e1))))
    return OpenTriangulatedCrack(
        tuple(map(tuple, P2)),
        tuple(patches),
        tuple(int(i) for i in new),
        tuple(tuple(map(float, n)) for n in normals2),
        tuple(tuple(map(float, c)) for c in cuts),
        crack.normal,
    )


def open_mid_edge_modes(
    front: OpenPolylineFront,
    block: CrackBlock,
    u: fem.Function,
    material: Isotropic,
    h_front: float,
    face_traction: tuple | None = None,
) -> list[FrontSIF]:
    """K_I, K_II, K_III at the middle of every edge of an open front by the interaction
    integral (collective), as :func:`~bonecontact.fracture.advance3d.mid_edge_modes` on a
    closed front: the ring r_out = 4 h_f, along the edge up to the distance to its ends (a
    corner, or the free surface on the first and last edges) less a front element.
    ``block`` is the cracked body with this front (:func:`cut_block`); ``face_traction``
    the contact tractions of a closed crack."""
    phis = front.edge_middles()
    r_out = 4.0 * h_front
    length = min(r_out, min(front.corner_distance(float(p)) for p in phis) - h_front)
    return [
        front_interaction_integral(
            u, block, float(p), material, r_out, None, length, face_traction=face_traction
        )
        for p in phis
    ]


def _segment_distance(x: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    d = b - a
    t = float(np.clip((x - a) @ d / (d @ d), 0.0, 1.0))
    return float(np.linalg.norm(x - a - t * d))


def _front_patches(cut: NonplanarCut) -> list[int]:
    """The patch of every front segment: that of the crack's unshared edge it lies on."""
    X = np.asarray(cut.crack.points, dtype=float)
    edges = [(e, ps[0]) for e, ps in cut.crack.edges().items() if len(ps) == 1]
    V = cut.front_points
    out = []
    for p, q in zip(V[:-1], V[1:], strict=True):
        mid = 0.5 * (p + q)
        dist = [_segment_distance(mid, X[a], X[b]) for (a, b), _ in edges]
        out.append(edges[int(np.argmin(dist))][1])
    return out


def cut_front(
    cut: NonplanarCut, cuts: tuple[tuple[float, float], ...] | None = None
) -> OpenPolylineFront:
    """The front of a non-planar crack cut into a body as an :class:`OpenPolylineFront`:
    the cut's front points (the ends where the crack's edges cross the surface), e₂ of
    every segment the normal of its patch (the side of ``crack_upper``), the order such
    that e₁ = t × e₂ points away from the patch (ahead); ``cuts`` the kinks (L, ψ) of the
    segments in the cut's order (the crack's front edges, the first and last crossing the
    surface), or ``None``."""
    crack = cut.crack
    V = np.asarray(cut.front_points, dtype=float)
    patches = _front_patches(cut)
    n2 = np.array([crack.normal(k) for k in patches])
    mid = 0.5 * (V[0] + V[1])
    e1 = np.cross(_unit(V[1] - V[0]), n2[0])
    if (crack.polygon(patches[0]).mean(axis=0) - mid) @ e1 > 0:  # the patch lies ahead
        V, n2 = V[::-1], n2[::-1]
        cuts = None if cuts is None else tuple(cuts[::-1])
    return OpenPolylineFront(
        tuple(map(tuple, V)),
        tuple(tuple(map(float, n)) for n in n2),
        cuts,
        tuple(map(float, crack.normal(0))),
    )


def cut_block(body: CrackedBody3D, front: OpenPolylineFront) -> CrackBlock:
    """The cracked body as the model of
    :func:`~bonecontact.fracture.front3d.front_interaction_integral` (both faces)."""
    return CrackBlock(
        body.mesh, body.cell_tags, body.facet_tags, front, dict(body.groups), half_model=False
    )
