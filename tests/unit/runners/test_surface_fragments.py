"""The fragments of a body cut by a grown, bent crack (runners.surface_crack3d.
surface_fragments): every cell on the side of the plane of the crack triangle nearest its
midpoint — the crack as grown, continued beyond its front by its last strip — not on the
side of the first crack's plane.

The box [−1, 1]³ (DOLFINx, n³ × 6 tetrahedra) and a crack bent along the line y = z = 0:
the half-plane y = 0 for z ≤ 0 (a patch to z = −1.5, normal +y), then a strip of length
0.5 turned by θ about the x axis (direction (0, sin θ, cos θ), normal (0, cos θ, −sin θ)),
its front at the strip's end, inside the box.  References:

* the closed form: the side +normal is {z < 0, y > 0} ∪ {z > 0, y > z tan θ}, of volume
  2 + 2(1 − tan θ / 2) = 4 − tan θ (tan θ ≤ 1), the other 4 + tan θ; the cells cut by the
  surface are given whole to one side, so within the cut cells' volume (asserted 2 %
  at n = 12);
* the same rule written for this surface alone (sign y below the bend, sign of
  y cos θ − z sin θ above it) on the cell midpoints: equal to 1e-12 (the nearest-triangle
  rule reproduces the bent surface exactly, also beyond the front and at the bend);
* the first plane's split (runners.surface_crack3d.fragments), which the non-planar path
  used before: 4 and 4, off by tan θ — the error this removes;
* 1, 2 and 3 ranks: the same volumes to 1e-12.
"""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import fem, mesh

from bonecontact.runners.surface_crack3d import (
    fragments,
    patch_triangles,
    surface_fragments,
    ufl_volume,
)

N = 12


def _bent(theta: float, turned: float = 0.5) -> tuple[np.ndarray, list[tuple[int, ...]]]:
    """Points and counter-clockwise patches (seen from the +normal side) of the crack."""
    d = np.array([0.0, math.sin(theta), math.cos(theta)])
    pts = np.array(
        [
            [-1.5, 0.0, -1.5],
            [1.5, 0.0, -1.5],
            [1.5, 0.0, 0.0],
            [-1.5, 0.0, 0.0],
            [1.5, 0.0, 0.0] + turned * d,
            [-1.5, 0.0, 0.0] + turned * d,
        ]
    )
    # seen from +y, (x, z) counter-clockwise: (−1.5,−1.5) → (−1.5, 0) → (1.5, 0) → (1.5, −1.5)
    return pts, [(0, 3, 2, 1), (3, 5, 4, 2)]


@pytest.fixture(scope="module")
def box() -> mesh.Mesh:
    return mesh.create_box(
        MPI.COMM_WORLD, [[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]], [N, N, N], mesh.CellType.tetrahedron
    )


def _by_rule(msh: mesh.Mesh, theta: float) -> tuple[float, float]:
    tdim = msh.topology.dim
    cells = np.arange(msh.topology.index_map(tdim).size_local, dtype=np.int32)
    x = mesh.compute_midpoints(msh, tdim, cells)
    s = np.where(
        x[:, 2] <= 0.0,
        np.sign(x[:, 1]),
        np.sign(x[:, 1] * math.cos(theta) - x[:, 2] * math.sin(theta)),
    )
    V = fem.functionspace(msh, ("DG", 0))
    vol = fem.assemble_vector(fem.form(ufl_volume(V))).array[: len(cells)]
    return tuple(float(msh.comm.allreduce(vol[s == k].sum())) for k in (1.0, -1.0))


@pytest.mark.parametrize("deg", [0.0, 17.0, 31.0, 44.0])
def test_bent_crack_splits_the_box_by_its_surface(box: mesh.Mesh, deg: float) -> None:
    theta = math.radians(deg)
    pts, patches = _bent(theta)
    T = patch_triangles(pts, patches)
    n = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    assert np.all(n[:2] @ [0.0, 1.0, 0.0] > 0)  # the patches face +normal = +y below
    got = {f["side"]: f["volume"] for f in surface_fragments(box, T)}
    plus, minus = _by_rule(box, theta)
    assert got["+normal"] == pytest.approx(plus, rel=1e-12)
    assert got["-normal"] == pytest.approx(minus, rel=1e-12)
    assert got["+normal"] + got["-normal"] == pytest.approx(8.0, rel=1e-12)
    t = math.tan(theta)
    assert got["+normal"] == pytest.approx(4.0 - t, rel=0.02)
    assert got["-normal"] == pytest.approx(4.0 + t, rel=0.02)
    old = {f["side"]: f["volume"] for f in fragments(box, pts[:4].mean(axis=0), (0, 1, 0))}
    assert old["+normal"] == pytest.approx(4.0, rel=1e-12)  # the first plane's split
    if deg > 0:
        assert abs(old["+normal"] - (4.0 - t)) > 5 * abs(got["+normal"] - (4.0 - t))


def test_patch_triangles_fan_each_patch() -> None:
    """A square and a pentagon: 2 + 3 triangles, their areas the polygons' (1 and the
    regular pentagon's 5/2 sin 72°), all facing +z."""
    a = np.linspace(0.0, 2 * math.pi, 6)[:-1]
    pts = np.concatenate(
        [[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.c_[np.cos(a), np.sin(a), 0 * a] + 5]
    )
    T = patch_triangles(pts, [(0, 1, 2, 3), (4, 5, 6, 7, 8)])
    n = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    assert T.shape == (5, 3, 3) and np.all(n[:, 2] > 0)
    area = 0.5 * n[:, 2]
    assert area[:2].sum() == pytest.approx(1.0, rel=1e-14)
    assert area[2:].sum() == pytest.approx(2.5 * math.sin(math.radians(72.0)), rel=1e-14)
