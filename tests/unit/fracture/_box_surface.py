"""A box's boundary as triangles, for the geometry tests of cracks at a body's edges
(test_corner_crack_geometry.py, tests/unit/runners/test_breakthrough_corner_rule.py)."""

from __future__ import annotations

import numpy as np


def box_triangles(size: tuple[float, float, float], h: float, inside_out: bool = False):
    """The boundary of the box [0, size]: a grid of spacing ``h`` (a divisor of each size)
    on each face, two triangles a square, outward (inward when ``inside_out``); shape
    (n, 3, 3)."""
    tris = []
    for axis in range(3):
        others = [k for k in range(3) if k != axis]
        u, v = (np.linspace(0.0, size[k], round(size[k] / h) + 1) for k in others)
        for side in (0.0, size[axis]):
            out = np.zeros(3)
            out[axis] = 1.0 if side > 0 else -1.0
            for i in range(len(u) - 1):
                for j in range(len(v) - 1):
                    q = []
                    for a, b in ((i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)):
                        p = np.zeros(3)
                        p[axis], p[others[0]], p[others[1]] = side, u[a], v[b]
                        q.append(p)
                    for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3])):
                        t = np.array(t)
                        if (np.cross(t[1] - t[0], t[2] - t[0]) @ out < 0) != inside_out:
                            t = t[[0, 2, 1]]
                        tris.append(t)
    return np.array(tris)
