"""The quality of the tetrahedra that crack_split.bisect_pinched halves: a crack triangle
with all three nodes on the front (a triangular crack's corners, a coarse narrow ellipse)
is opened by halving its edge across the corner, which halves every tetrahedron at that
edge.  Measured on the sweep's cases of tests/unit/fracture/test_crack_split.py (radius
ratio q = 3 r_in / r_circ, 1 for the regular tetrahedron; 2026-12-05): the halved
tetrahedra are the mesh's worst, q ≥ 0.20 (triangle, fine triangle), 0.24 (coarse
ellipse), 0.29 (coarse triangle), median 0.39–0.49, against the whole mesh's first
percentile 0.35–0.38 and median 0.69–0.75; no other tetrahedron is below them.  Asserted:
q ≥ 0.15 at the halved tetrahedra, a fair linear-elastic element (the halving at most
about halves q), and every other tetrahedron above the halved ones' least q / 1.5 (the
split itself does not spoil the rest).  On 1–3 ranks (the mesh is made on rank 0 and
distributed; q is taken on each rank's cells).
"""

from __future__ import annotations

from mpi4py import MPI

import gmsh
import numpy as np
import pytest
import test_crack_split as tcs

from bonecontact.fracture import crack_split
from bonecontact.fracture.body3d import mesh_body_with_planar_crack
from bonecontact.fracture.meshing import TipMesh

CASES = ["triangle_coarse", "triangle", "ellipse_coarse"]


def radius_ratio(P: np.ndarray) -> np.ndarray:
    """3 r_in / r_circ of the tetrahedra P (k, 4, 3)."""
    a, b, c, d = (P[:, i] for i in range(4))
    vol = np.abs(np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a))) / 6.0
    faces = ((a, b, c), (a, b, d), (a, c, d), (b, c, d))
    area = sum(0.5 * np.linalg.norm(np.cross(q - p, r - p), axis=1) for p, q, r in faces)
    E = np.stack([b - a, c - a, d - a], axis=1)
    rhs = 0.5 * np.einsum("kij,kij->ki", E, E)
    centre = np.linalg.solve(E, rhs[..., None])[..., 0]
    return 9.0 * vol / area / np.linalg.norm(centre, axis=1)


def test_radius_ratio_closed_forms() -> None:
    """1 for the regular tetrahedron; the corner tetrahedron of a cube (0, e₁, e₂, e₃):
    r_in = 1/(3 + √3), r_circ = √3/2."""
    reg = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    corner = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    q = radius_ratio(np.stack([reg, corner]))
    assert q[0] == pytest.approx(1.0, rel=1e-14)
    assert q[1] == pytest.approx(3.0 / (3.0 + np.sqrt(3.0)) / (np.sqrt(3.0) / 2.0), rel=1e-14)


@pytest.mark.parametrize("name", CASES)
def test_halved_tetrahedra_stay_fair(monkeypatch, name: str) -> None:
    mids: list[np.ndarray] = []
    real = crack_split.bisect_pinched

    def recorded(tags, front) -> int:  # the nodes it adds: the midpoints (and copies)
        top = int(gmsh.model.mesh.getMaxNodeTag())
        count = real(tags, front)
        tags_, x, _ = gmsh.model.mesh.getNodes()
        new = np.asarray(tags_) > top
        mids.extend(np.asarray(x).reshape(-1, 3)[new])
        return count

    monkeypatch.setattr(crack_split, "bisect_pinched", recorded)
    make, h = tcs.SWEPT[name]
    cb, _ = mesh_body_with_planar_crack(
        tcs._body(tcs.CUBE), make(), TipMesh(h, 0.3), MPI.COMM_WORLD
    )
    comm = cb.mesh.comm
    mids = comm.bcast(mids, root=0)  # gmsh (and the bisection) ran on rank 0
    mids = list(np.unique(np.round(np.asarray(mids), 12), axis=0))  # a node and its copy
    assert len(mids) >= 2
    P = cb.mesh.geometry.x[cb.mesh.geometry.dofmap]
    q = radius_ratio(P)
    at = np.zeros(len(P), dtype=bool)
    for m in mids:
        at |= np.any(np.linalg.norm(P - m, axis=2) < 1e-9 * h, axis=1)
    q_at = comm.allreduce(float(q[at].min(initial=np.inf)), op=MPI.MIN)
    q_rest = comm.allreduce(float(q[~at].min(initial=np.inf)), op=MPI.MIN)
    assert comm.allreduce(int(at.sum())) >= 6 * len(mids)  # the tets around each edge
    assert q_at >= 0.15, q_at
    assert q_rest >= q_at / 1.5, (q_rest, q_at)
