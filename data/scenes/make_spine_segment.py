"""Write data/scenes/spine_segment.msh, the lumbar motion segment of the validation test
(tests/verification/test_spine_validation.py): the quick mesh of demos/spine3d.py before
its tumour is put in (``segment_bone.msh`` of ``BONECONTACT_DEMO_QUICK=1 python
demos/spine3d.py OUT``), with its cell group ``disc`` split into ``annulus`` and
``nucleus`` as the demo's ``split_disc`` does (the disc's cells whose centroid lies, seen
from above, inside the rim of the L4 endplate shrunk to 44 % of its area).

Usage: ``python data/scenes/make_spine_segment.py OUT/segment_bone.msh``.
"""

import dolfinx_solver  # noqa: F401  (before dolfinx / mpi4py)

import sys
from pathlib import Path

import numpy as np
from matplotlib.path import Path as PolygonPath

from bonecontact.neoplasm.host3d import (
    HostGeometry3D,
    read_host_geometry3d,
    write_host_geometry3d,
)

NUCLEUS_SHARE = 0.44
TARGET = Path(__file__).resolve().parent / "spine_segment.msh"


def rim(tri: np.ndarray) -> np.ndarray:
    """The boundary vertices of a patch of triangles, in order around it."""
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    _, inv, cnt = np.unique(np.sort(e, axis=1), axis=0, return_inverse=True, return_counts=True)
    b = e[cnt[inv.ravel()] == 1]
    nxt = dict(zip(b[:, 0].tolist(), b[:, 1].tolist()))
    loop = [int(b[0, 0])]
    while (n := nxt[loop[-1]]) != loop[0]:
        loop.append(n)
    return np.array(loop)


def split_disc(g: HostGeometry3D, share: float) -> None:
    """The cell group ``disc`` of ``g`` split into ``annulus`` and ``nucleus``."""
    tag, tets = g.cells.pop("disc")
    ring = g.x[rim(g.facets["L4_endplate"][1])][:, [0, 2]]
    centre = ring.mean(axis=0)
    inner = PolygonPath(centre + np.sqrt(share) * (ring - centre))
    inside = inner.contains_points(g.x[tets].mean(axis=1)[:, [0, 2]])
    g.cells["annulus"] = (tag, tets[~inside])
    g.cells["nucleus"] = (1 + max(t for t, _ in g.cells.values()), tets[inside])


if __name__ == "__main__":
    geo = read_host_geometry3d(sys.argv[1])
    split_disc(geo, NUCLEUS_SHARE)
    write_host_geometry3d(geo, TARGET)
    print(f"{TARGET}: " + ", ".join(f"{k} {len(t)}" for k, (_, t) in geo.cells.items()))
