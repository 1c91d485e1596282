"""Crack fronts that grow in 3D (docs/theory/fracture.md#front-advance-of-a-planar-crack,
#mixed-mode-advance-in-3d).

The block [−W, W]³ (rollers on x = −W, y = −W, z = −W, tension σ on z = W) with a
penny-like crack: the regular N-gon of circumradius a, centred at the origin.

* :func:`grow_polygon_penny` — the crack in z = 0 (mode I), its vertices advanced in the
  plane (:func:`~bonecontact.fracture.advance3d.advance_polygon_front`).
* :func:`grow_inclined_penny` — the crack's normal at β to the load (mixed mode); every
  increment meshes the grown, non-planar crack, solves, takes K_I, K_II, K_III at the
  mid-edges and advances the front by the σ₁′ criterion
  (:func:`~bonecontact.fracture.advance3d.advance_mixed_front`), the crack surface
  extended by a strip (:func:`~bonecontact.fracture.advance3d.extend_surface`).

Each increment re-meshes the block with the crack (:mod:`bonecontact.fracture.body3d`:
two faces, graded towards the front); the interaction integral's domain is a ring
max(0.3 b, 4 h_f) (mixed: 4 h_f), along the edge up to its distance to the corners less
a front element.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
from dolfinx import mesh

from bonecontact.fracture.advance3d import (
    MixedAdvance,
    advance_mixed_front,
    advance_polygon_front,
    extend_surface,
    mid_edge_modes,
)
from bonecontact.fracture.body3d import body_surface, mesh_body_with_planar_crack
from bonecontact.fracture.crack3d import (
    PlanarCrack,
    planar_crack_from_table,
    triangulated_from_polygon,
)
from bonecontact.fracture.front3d import front_interaction_integral
from bonecontact.fracture.meshing import TipMesh
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics

__all__ = [
    "GrowthRecord",
    "MixedRecord",
    "grow_inclined_penny",
    "grow_polygon_penny",
    "inclined_polygon",
    "kassir_sih_modes",
    "regular_polygon",
]

_GROUPS = {"block": (3, 1), "xmin": (2, 2), "ymin": (2, 3), "zmin": (2, 4), "top": (2, 5)}


@dataclass
class GrowthRecord:
    """The front after every increment: ``vertices`` (list of (N, 3)), ``k_edges`` (K_I at
    the mid-edges before each advance), ``dofs``."""

    vertices: list = field(default_factory=list)
    k_edges: list = field(default_factory=list)
    dofs: list = field(default_factory=list)

    def radii(self, k: int) -> npt.NDArray[np.float64]:
        """Distances of the vertices of front ``k`` from their centroid (m)."""
        V = self.vertices[k]
        return np.linalg.norm(V - V.mean(axis=0), axis=1)


def regular_polygon(n: int, a: float) -> npt.NDArray[np.float64]:
    """The regular n-gon of circumradius ``a`` in z = 0, counter-clockwise about +z."""
    t = 2 * math.pi * np.arange(n) / n + math.pi / n
    return np.column_stack([a * np.cos(t), a * np.sin(t), 0 * t])


def _block(W: float, n: int, comm: MPI.Comm):
    msh = mesh.create_box(comm, [[-W, -W, -W], [W, W, W]], [n, n, n], mesh.CellType.tetrahedron)
    tdim = 3
    im = msh.topology.index_map(tdim)
    cells = np.arange(im.size_local + im.num_ghosts, dtype=np.int32)
    ct = mesh.meshtags(msh, tdim, cells, np.ones(cells.size, dtype=np.int32))
    msh.topology.create_connectivity(tdim - 1, tdim)
    ent, val = [], []
    for name, (ax, v) in {"xmin": (0, -W), "ymin": (1, -W), "zmin": (2, -W), "top": (2, W)}.items():
        f = mesh.locate_entities_boundary(msh, 2, lambda x, ax=ax, v=v: np.isclose(x[ax], v))
        ent.append(f)
        val.append(np.full(f.size, _GROUPS[name][1], dtype=np.int32))
    ent, val = np.concatenate(ent), np.concatenate(val)
    order = np.argsort(ent)
    ft = mesh.meshtags(msh, 2, ent[order].astype(np.int32), val[order])
    return body_surface(msh, ct, ft, _GROUPS, "block")


def _mid_edge_k(crack: PlanarCrack, cb, u, material: Isotropic, h: float) -> np.ndarray:
    front = crack.front()
    phis = crack.front_parameters(1)
    r_out = max(0.3 * crack.b, 4 * h)
    length = min(r_out, min(front.corner_distance(float(p)) for p in phis) - h)
    blk = cb.block()
    return np.array(
        [
            front_interaction_integral(u, blk, float(p), material, r_out, None, length).K_I
            for p in phis
        ]
    )


def grow_polygon_penny(
    n_sides: int = 8,
    a: float = 1.0,
    increments: int = 5,
    da: float = 0.1,
    h_front: float = 0.1,
    grading: float = 0.12,
    W: float = 4.0,
    comm: MPI.Comm | None = None,
    material: Isotropic = Isotropic(E=1.0, nu=0.3),  # noqa: B008
) -> GrowthRecord:
    """Grow the polygonal penny by ``increments`` advances of at most ``da`` (collective);
    the record holds the initial front and every advanced one."""
    comm = MPI.COMM_WORLD if comm is None else comm
    body = _block(W, 4, comm)
    rec = GrowthRecord()
    V = regular_polygon(n_sides, a)
    for _ in range(increments):
        crack = planar_crack_from_table({"shape": "polygon", "vertices": V.tolist()})
        cb, _md = mesh_body_with_planar_crack(body, crack, TipMesh(h_front, grading), comm)
        m, integ = _solve_block(cb, material, 1.0)
        k = _mid_edge_k(crack, cb, integ.u, material, h_front)
        integ.destroy()
        rec.vertices.append(np.asarray(crack.vertices))
        rec.k_edges.append(k)
        rec.dofs.append(m.num_dofs)
        V, _ = advance_polygon_front(crack.vertices, crack.normal, k, da)
    rec.vertices.append(V)
    return rec


# ----------------------------------------------------------------------------- mixed mode
@dataclass
class MixedRecord:
    """The grown crack after every increment: ``cracks`` (the
    :class:`~bonecontact.fracture.crack3d.TriangulatedCrack` before each advance and the
    last one), ``k_edges`` ((N, 3) K_I, K_II, K_III at the mid-edges), ``advances``
    (:class:`~bonecontact.fracture.advance3d.MixedAdvance`), ``dofs``."""

    cracks: list = field(default_factory=list)
    k_edges: list = field(default_factory=list)
    advances: list = field(default_factory=list)
    dofs: list = field(default_factory=list)

    def front(self, k: int) -> npt.NDArray[np.float64]:
        """The front's vertices after ``k`` advances, shape (N, 3)."""
        return np.asarray(self.cracks[k].vertices)


def inclined_polygon(n: int, a: float, beta: float) -> npt.NDArray[np.float64]:
    """The regular n-gon of circumradius ``a`` whose normal (−sin β, 0, cos β) makes the
    angle β (rad) with the z axis (the load), counter-clockwise about that normal."""
    R = np.array(
        [
            [math.cos(beta), 0.0, -math.sin(beta)],
            [0.0, 1.0, 0.0],
            [math.sin(beta), 0.0, math.cos(beta)],
        ]
    )
    return regular_polygon(n, a) @ R.T


def kassir_sih_modes(
    frames: npt.ArrayLike, normal: npt.ArrayLike, a: float, sigma: float, nu: float
) -> npt.NDArray[np.float64]:
    """(K_I, K_II, K_III) of a penny crack of radius ``a`` with unit ``normal`` under
    uniaxial tension σ along z (Kassir & Sih 1966; Tada, Paris & Irwin, penny-shaped
    crack under shear) at front points with frames ``frames`` ((n, 3, 3): rows e₁, e₂,
    e₃): K_I = 2σ_n√(a/π), K_II = 4/(2 − ν) √(a/π) τ·e₁, K_III = 4(1 − ν)/(2 − ν) √(a/π)
    τ·e₃, σ_n and τ the normal and shear traction on the crack plane; shape (n, 3)."""
    n = np.asarray(normal, dtype=float)
    t = sigma * n[2] * np.array([0.0, 0.0, 1.0])
    s_n = float(t @ n)
    tau = t - s_n * n
    F = np.asarray(frames, dtype=float)
    root = math.sqrt(a / math.pi)
    k1 = np.full(len(F), 2 * s_n * root)
    k2 = 4 / (2 - nu) * root * (F[:, 0] @ tau)
    k3 = 4 * (1 - nu) / (2 - nu) * root * (F[:, 2] @ tau)
    return np.column_stack([k1, k2, k3])


def _solve_block(cb, material: Isotropic, sigma: float):
    m = Mechanics(cb.mesh, material, cb.cell_tags, cb.facet_tags)
    for name, comp in (("xmin", 0), ("ymin", 1), ("zmin", 2)):
        m.add_dirichlet(m.facets(_GROUPS[name][1]), comp, 0.0)
    m.add_traction(_GROUPS["top"][1], (0.0, 0.0, sigma))
    integ = Integrator(m, "static", 1.0)
    integ.step()
    return m, integ


def grow_inclined_penny(
    beta_deg: float = 45.0,
    n_sides: int = 8,
    a: float = 1.0,
    increments: int = 1,
    da: float = 0.2,
    h_front: float = 0.125,
    grading: float = 0.12,
    W: float = 4.0,
    comm: MPI.Comm | None = None,
    material: Isotropic = Isotropic(E=1.0, nu=0.3),  # noqa: B008
) -> MixedRecord:
    """Grow the inclined polygonal penny by ``increments`` mixed-mode advances of at most
    ``da`` under unit tension along z (collective)."""
    comm = MPI.COMM_WORLD if comm is None else comm
    body = _block(W, 4, comm)
    V = inclined_polygon(n_sides, a, math.radians(beta_deg))
    crack = triangulated_from_polygon(
        planar_crack_from_table({"shape": "polygon", "vertices": V.tolist()})
    )
    rec = MixedRecord()
    for _ in range(increments):
        cb, _md = mesh_body_with_planar_crack(body, crack, TipMesh(h_front, grading), comm)
        m, integ = _solve_block(cb, material, 1.0)
        sifs = mid_edge_modes(crack, cb.block(), integ.u, material, h_front)
        k = np.array([(f.K_I, f.K_II, f.K_III) for f in sifs])
        integ.destroy()
        adv: MixedAdvance = advance_mixed_front(crack.vertices, crack.normals2, k, da)
        rec.cracks.append(crack)
        rec.k_edges.append(k)
        rec.advances.append(adv)
        rec.dofs.append(m.num_dofs)
        crack = extend_surface(crack, adv.vertices)
    rec.cracks.append(crack)
    return rec
