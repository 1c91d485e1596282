"""Checking a ``[[crack]]`` against the mesh: :func:`check_crack_region`.

Every point of a crack must lie in cells of its region: a crack outside its region,
crossing another body or leaving the mesh is refused (collective).  The crack geometry
comes from :mod:`bonecontact.fracture` (a 2D polyline or a planar 3D crack).
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
from dolfinx import geometry, mesh

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.crack3d import PlanarCrack, SurfaceBreakingCrack
from bonecontact.scene.spec import CrackSpec

__all__ = ["check_crack_region"]


def check_crack_region(
    spec: CrackSpec,
    msh: mesh.Mesh,
    cell_tags: mesh.MeshTags,
    region_tag: int,
    increment: float | None = None,
    samples_per_segment: int = 20,
) -> None:
    """Refuse a crack that leaves its region (collective).

    Points sampled along every segment (3D: over the crack, its front included) must each
    lie in a cell tagged ``region_tag``;
    a point in a cell of another tag means the crack crosses another body, a point in no
    cell that it lies outside the mesh.  An ``increment`` must be shorter than the
    region's extent.
    """
    if isinstance(spec.crack, SurfaceBreakingCrack):
        return  # its mouth and front are checked when it is cut into the body (surface_body3d)
    if isinstance(spec.crack, PlanarCrack):
        samples = spec.crack.sample_points()
        x, out_key = samples, spec.crack.size_key
    else:
        pts = spec.crack.points
        t = np.linspace(0.0, 1.0, samples_per_segment + 1)[1:-1]
        samples = np.concatenate(
            [pts[i] + np.outer(t, pts[i + 1] - pts[i]) for i in range(len(pts) - 1)]
        )
        x, out_key = np.column_stack([samples, np.zeros(len(samples))]), "points"
    tdim = msh.topology.dim
    n_cells = msh.topology.index_map(tdim).size_local
    tree = geometry.bb_tree(msh, tdim, padding=0.0)
    cand = geometry.compute_collisions_points(tree, x)
    hits = geometry.compute_colliding_cells(msh, cand, x)
    tag_of = np.full(n_cells + msh.topology.index_map(tdim).num_ghosts, -1, dtype=np.int64)
    tag_of[cell_tags.indices] = cell_tags.values
    found = np.zeros(len(x), dtype=np.int32)
    inside = np.zeros(len(x), dtype=np.int32)
    for i in range(len(x)):
        cells = hits.links(i)
        cells = cells[cells < n_cells]
        found[i] = int(cells.size > 0)
        inside[i] = int(np.any(tag_of[cells] == region_tag))
    msh.comm.Allreduce(MPI.IN_PLACE, found, op=MPI.SUM)
    msh.comm.Allreduce(MPI.IN_PLACE, inside, op=MPI.SUM)
    if np.any(found == 0):
        p = samples[int(np.argmax(found == 0))]
        raise ParameterError(out_key, f"crack {spec.name!r} leaves the mesh near {p.tolist()}")
    if np.any(inside == 0):
        p = samples[int(np.argmax(inside == 0))]
        raise ParameterError(
            "region", f"crack {spec.name!r} is not in region {spec.region!r} near {p.tolist()}"
        )
    if increment is not None:
        cells = cell_tags.find(region_tag)
        xs = mesh.compute_midpoints(msh, tdim, cells[cells < n_cells])[:, :tdim]
        lo = xs.min(axis=0) if xs.size else np.full(tdim, np.inf)
        hi = xs.max(axis=0) if xs.size else np.full(tdim, -np.inf)
        msh.comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)  # buffers: pickled min of arrays fails
        msh.comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
        if increment >= float(np.max(hi - lo)):
            raise ParameterError(
                "increment", f"{increment} m is not smaller than region {spec.region!r}"
            )
