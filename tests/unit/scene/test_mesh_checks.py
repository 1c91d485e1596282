"""Bad meshes are refused before any solve (:mod:`bonecontact.scene.mesh_checks`).

Tiny 2D meshes written node by node with the gmsh API (structured triangles on
squares of side 0.1 m, ``n × n`` cells of size h = 0.1/n) and read like any scene
mesh.  Each bad mesh differs from a valid one by one defect placed at a known point,
and the check must name the group and that point:

* an interior node moved past its neighbours: one element inverted (a fold);
* a zero-area (sliver) triangle on the bottom edge: degenerate element;
* the upper half of the line x = 0.05 with doubled nodes: duplicated nodes (a cut);
* a second, free square with the region's tag: the region is not one piece;
* the traction boundary given an interior line: facet group not on the boundary.

Valid meshes pass: one square, and two bodies touching at matching nodes (coincident
nodes of different regions on the contact surfaces).  On 1 and 2 ranks (the findings
are gathered, every rank raises the same message); ``bonecontact check`` exits 2 with
the message on 1 and 2 ranks.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import os
import re
import subprocess
import sys
from pathlib import Path

from mpi4py import MPI

import gmsh
import numpy as np
import pytest

from bonecontact.meshing.session import gmsh_session
from bonecontact.runners.mechanics import read_mesh
from bonecontact.scene import SceneError, load_scene

COMM = MPI.COMM_WORLD
L, N = 0.1, 4
H = L / N

SCENE = """format = 1

[scene]
name = "meshcheck"
mesh = "{mesh}"
dimension = 2

[analysis]
kind = "static"
t_end = 1.0
dt = 1.0

[[material]]
name = "bone"
regions = {regions}
model = "isotropic"
E = 17.0e9
nu = 0.3

[[dirichlet]]
boundary = "bottom"
value = [0.0, 0.0]

[[traction]]
boundary = "top"
value = [0.0, -1.0e6]
{extra}
[output]
directory = "out"
fields_every = 0
"""

CONTACT = """
[[contact]]
name = "joint"
slave = "upper_contact"
master = "lower_contact"
"""


def _grid(x0: float, y0: float, n: int = N, h: float = H) -> tuple[np.ndarray, np.ndarray]:
    """Structured square: nodes ``(n+1)²`` and triangles (counter-clockwise)."""
    X, Y = np.meshgrid(x0 + h * np.arange(n + 1), y0 + h * np.arange(n + 1), indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel()])
    tri = []
    for i in range(n):
        for j in range(n):
            a, b = i * (n + 1) + j, (i + 1) * (n + 1) + j
            tri += [[a, b, b + 1], [a, b + 1, a + 1]]
    return pts, np.asarray(tri)


def _edges_on(pts: np.ndarray, tri: np.ndarray, on) -> np.ndarray:
    """The triangle edges with both nodes where ``on(x, y)`` holds."""
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    ok = on(pts[edges[:, 0], 0], pts[edges[:, 0], 1]) & on(pts[edges[:, 1], 0], pts[edges[:, 1], 1])
    return edges[ok]


def _write(path: Path, pts: np.ndarray, cells: dict, facets: dict) -> None:
    """gmsh file: ``cells`` name → triangles, ``facets`` name → edges (node indices)."""
    with gmsh_session("bad"):
        gmsh.model.addDiscreteEntity(2, 1)
        gmsh.model.mesh.addNodes(2, 1, np.arange(1, len(pts) + 1), np.column_stack(
            [pts, np.zeros(len(pts))]).ravel())  # fmt: skip
        etag = 1
        for k, (name, tri) in enumerate(cells.items(), start=1):
            if k > 1:
                gmsh.model.addDiscreteEntity(2, k)
            gmsh.model.mesh.addElementsByType(
                k, 2, np.arange(etag, etag + len(tri)), (np.asarray(tri) + 1).ravel()
            )
            etag += len(tri)
            gmsh.model.addPhysicalGroup(2, [k], k, name)
        for k, (name, edges) in enumerate(facets.items(), start=1):
            gmsh.model.addDiscreteEntity(1, k)
            gmsh.model.mesh.addElementsByType(
                k, 1, np.arange(etag, etag + len(edges)), (np.asarray(edges) + 1).ravel()
            )
            etag += len(edges)
            gmsh.model.addPhysicalGroup(1, [k], 10 + k, name)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(str(path))


def _square(pts, tri, extra_cells=None, top=None) -> tuple:
    bottom = _edges_on(pts, tri, lambda x, y: np.isclose(y, 0.0) & (x <= L + 1e-12))
    top = top if top is not None else _edges_on(pts, tri, lambda x, y: np.isclose(y, L))
    cells = {"body": tri} if extra_cells is None else {"body": np.vstack([tri, extra_cells])}
    return pts, cells, {"bottom": bottom, "top": top}


def _valid():
    return _square(*_grid(0.0, 0.0))


def _inverted():
    pts, tri = _grid(0.0, 0.0)
    k = 1 * (N + 1) + 1  # node (h, h) moved to (2.2 h, 1.3 h), past its neighbour (2h, h):
    pts[k] = [2.2 * H, 1.3 * H]  # the cell (h, h), (2h, h), (2h, 2h) turns over
    return _square(pts, tri)


def _degenerate():
    pts, tri = _grid(0.0, 0.0)
    # a sliver on the bottom edge: nodes (0,0), (h,0) and a new node at (h/2, 0)
    pts = np.vstack([pts, [[0.5 * H, 0.0]]])
    m = len(pts) - 1
    sliver = np.array([[0, N + 1, m]])
    return _square(pts, np.vstack([tri, sliver]))


def _duplicated():
    pts, tri = _grid(0.0, 0.0)
    # the cells right of x = 2h above y = 2h take copies of the nodes (2h, 3h) and (2h, 4h):
    # a cut from (2h, 2h) (still shared) up to the top edge
    line = [2 * (N + 1) + j for j in range(N // 2 + 1, N + 1)]
    copies = {q: len(pts) + i for i, q in enumerate(line)}
    pts = np.vstack([pts, pts[line]])
    mid = pts[tri].mean(axis=1)
    right = (mid[:, 0] > 2 * H) & (mid[:, 1] > 2 * H)
    tri = tri.copy()
    for q, c in copies.items():
        tri[right] = np.where(tri[right] == q, c, tri[right])
    return _square(pts, tri)


def _detached():
    pts, tri = _grid(0.0, 0.0)
    p2, t2 = _grid(3 * L, 0.5 * L, n=1, h=H)
    return _square(np.vstack([pts, p2]), tri, extra_cells=t2 + len(pts))


def _interior_top():
    pts, tri = _grid(0.0, 0.0)
    inner = _edges_on(pts, tri, lambda x, y: np.isclose(y, 2 * H))
    return _square(pts, tri, top=inner)


def _two_bodies():
    """Two squares on top of each other, coincident nodes at y = L (not shared)."""
    p1, t1 = _grid(0.0, 0.0)
    p2, t2 = _grid(0.0, L)
    pts = np.vstack([p1, p2])
    t2 = t2 + len(p1)
    bottom = _edges_on(p1, t1, lambda x, y: np.isclose(y, 0.0))
    lower_c = _edges_on(p1, t1, lambda x, y: np.isclose(y, L))
    upper_c = _edges_on(p2, t2 - len(p1), lambda x, y: np.isclose(y, L)) + len(p1)
    top = _edges_on(p2, t2 - len(p1), lambda x, y: np.isclose(y, 2 * L)) + len(p1)
    return (
        pts,
        {"lower": t1, "upper": t2},
        {"bottom": bottom, "top": top, "lower_contact": lower_c, "upper_contact": upper_c},
    )


CASES = {
    "valid": (_valid, None, None),
    "two_bodies": (_two_bodies, None, None),
    "inverted": (_inverted, "region 'body': inverted element", (2.07 * H, 1.43 * H)),
    "degenerate": (_degenerate, "region 'body': degenerate element", (0.5 * H, 0.0)),
    "duplicated": (_duplicated, "region 'body': duplicated nodes", (2 * H, None)),
    "detached": (_detached, "region 'body' is not one piece: a part of 2 cells", (3 * L, None)),
    "interior_top": (_interior_top, "facet group 'top' is not on the boundary", (None, 2 * H)),
}


@pytest.fixture(scope="module")
def scenes(tmp_path_factory) -> dict[str, Path]:
    """Every case's mesh and scene, written on rank 0 into one directory."""
    d = Path(
        COMM.bcast(str(tmp_path_factory.mktemp("meshcheck")) if COMM.rank == 0 else None, root=0)
    )
    out = {}
    for name, (make, _, _) in CASES.items():
        scene = d / f"{name}.toml"
        if COMM.rank == 0:
            pts, cells, facets = make()
            _write(d / f"{name}.msh", pts, cells, facets)
            regions = "[" + ", ".join(f'"{c}"' for c in cells) + "]"
            extra = CONTACT if "lower_contact" in facets else ""
            scene.write_text(SCENE.format(mesh=f"{name}.msh", regions=regions, extra=extra))
        out[name] = scene
    COMM.barrier()
    return out


def _numbers(text: str) -> np.ndarray:
    inside = re.findall(r"\(([-0-9.e, ]+)\)", text)[-1]  # the last coordinates
    return np.array([float(v) for v in inside.split(",")])


@pytest.mark.parametrize("case", list(CASES))
def test_mesh_checks(scenes, case):
    """Valid meshes pass; each bad one gives its message with the group and the point of
    the defect (within one cell), the same on every rank."""
    scene = load_scene(scenes[case])
    _, expected, where = CASES[case]
    if expected is None:
        md, groups = read_mesh(scene, COMM)
        assert md.mesh.topology.index_map(2).size_global > 0
        return
    with pytest.raises(SceneError) as info:
        read_mesh(scene, COMM)
    msg = str(info.value)
    assert expected in msg, msg
    assert 'key "mesh"' in msg and f"{case}.msh" in msg
    xy = _numbers(msg)
    for k, ref in enumerate(where):
        if ref is not None:
            assert abs(xy[k] - ref) <= H, (msg, where)
    assert COMM.allgather(msg) == [msg] * COMM.size


@pytest.mark.serial
@pytest.mark.parametrize("ranks", [1, 2])
def test_check_command_exits_2(scenes, ranks):
    """``bonecontact check`` on a bad mesh: exit status 2 and the message, also on 2 ranks
    (one finding stops every rank; no hang)."""
    bin_ = Path(sys.executable).parent
    cmd = [str(bin_ / "bonecontact"), "check", str(scenes["detached"])]
    if ranks > 1:
        cmd = [str(bin_ / "mpiexec"), "-n", str(ranks), *cmd]
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONWARNINGS": "ignore"}
    res = subprocess.run(
        cmd, capture_output=True, text=True, timeout=300, env=env, stdin=subprocess.DEVNULL
    )
    assert res.returncode == 2, res.stdout + res.stderr
    assert "region 'body' is not one piece" in res.stdout + res.stderr


def test_mesh_without_tags(scenes):
    """A mesh read without cell or facet tags (a growth scene's region mesh) is checked
    all the same: no finding on a valid mesh."""
    from types import SimpleNamespace

    from bonecontact.scene.mesh_checks import mesh_findings

    scene = load_scene(scenes["valid"])
    md, groups = read_mesh(scene, COMM)
    bare = SimpleNamespace(mesh=md.mesh, cell_tags=None, facet_tags=None)
    assert mesh_findings(scene, bare, groups, COMM) == []
