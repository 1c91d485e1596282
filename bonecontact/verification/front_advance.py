"""A penny crack that grows under mode I: the planar front advance of
:mod:`bonecontact.fracture.advance3d` in a block under uniaxial tension
(docs/theory/fracture.md#front-advance-of-a-planar-crack).

The block [−W, W]³ (rollers on x = −W, y = −W, z = −W, tension σ on z = W), a planar crack
in z = 0 whose front is a regular N-gon of circumradius a (the penny's polygon).  Each
increment: the body is re-meshed with the crack (:mod:`bonecontact.fracture.body3d`: two
faces, graded towards the front), solved, K_I taken at the middle of every edge by the
interaction integral (domain as a scene's: ring max(0.3 b, 4 h_f), along the edge up to
its distance to the corners less a front element), and the vertices advanced.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
from dolfinx import mesh

from bonecontact.fracture.advance3d import advance_polygon_front
from bonecontact.fracture.body3d import body_surface, mesh_body_with_planar_crack
from bonecontact.fracture.crack3d import PlanarCrack, planar_crack_from_table
from bonecontact.fracture.front3d import front_interaction_integral
from bonecontact.fracture.meshing import TipMesh
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics

__all__ = ["GrowthRecord", "grow_polygon_penny", "regular_polygon"]

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
        m = Mechanics(cb.mesh, material, cb.cell_tags, cb.facet_tags)
        for name, comp in (("xmin", 0), ("ymin", 1), ("zmin", 2)):
            m.add_dirichlet(m.facets(_GROUPS[name][1]), comp, 0.0)
        m.add_traction(_GROUPS["top"][1], (0.0, 0.0, 1.0))
        integ = Integrator(m, "static", 1.0)
        integ.step()
        k = _mid_edge_k(crack, cb, integ.u, material, h_front)
        integ.destroy()
        rec.vertices.append(np.asarray(crack.vertices))
        rec.k_edges.append(k)
        rec.dofs.append(m.num_dofs)
        V, _ = advance_polygon_front(crack.vertices, crack.normal, k, da)
    rec.vertices.append(V)
    return rec
