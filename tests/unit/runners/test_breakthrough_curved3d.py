"""An interior crack with a tilted plane breaks through a curved surface
(``[fracture] breakthrough = "surface_crack"`` on a cylinder; runners.breakthrough3d).

The cylinder r ≤ R = 3a, |z| ≤ 3a (a = 1 mm; gmsh, boundary facets a/5 near x = R, z = 0,
1.5a elsewhere), clamped at z = −3a, σ = 1 MPa along its axis on z = 3a, E = 17 GPa,
ν = 0.3; a penny of radius a off the axis at x0 = 1.2a, its plane tilted 25° about y
from the cross-section (n = (sin 25°, 0, cos 25°)), front a/8, cycled with R = 0.1,
C = 1e-20, m = 3, Δa_max = 0.1a.  The front's outer point starts 0.89a from the
cylinder; the first block brings it within the ligament 6 h = 0.75a: ``through``, the
re-characterised crack grows one block as a surface crack.  Checked against references
that do not use the facets the run used:

* the re-characterised crack is the rule applied by hand to the recorded final front with
  the exact cylinder (outward normal (x, y, 0)/R at the front point farthest from the
  axis, the depth line met analytically): depth, half-length, ligament, height within
  the facets' sag plus the direction error of the facet normal over the flaw (measured
  from the mesh), the plane the penny's;
* the surface phase's crack mouth (the nodes of its crack surface within 0.03a of the
  cylinder, ≥ 10 of them) lies on the cylinder within the facets' sag;
* the cycles continuous (the surface phase starts at the last interior solve's) and
  non-decreasing; one table, increments numbered on;
* the second path (serial and 2 ranks): the surface-crack scene given that crack directly
  grown one block gives the surface phase's K, front and (plus the interior cycles)
  cycles to 1e-10;
* 2 (3) ranks: fracture.csv, the stop, the cycles, the crack as serially to 1e-10 (the
  re-characterisation does not depend on the order the partition gathers the facets in).
"""

from __future__ import annotations

import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import idle_barrier, read_table, run_in, serial_reference
from coupled_support import gmsh_on_rank0
from test_breakthrough_scene3d import _same_tables

A = 1.0e-3
R = 3 * A
HZ = 3 * A
H = A / 8
DA = 0.1 * A
TILT = math.radians(25.0)
NORMAL = (math.sin(TILT), 0.0, math.cos(TILT))
X0 = 1.3 * A
FINE = A / 5

SCENE = """format = 1
[scene]
name = "breakthrough_cylinder"
mesh = "{mesh}"
dimension = 3
[analysis]
kind = "static"
load_steps = 1
[[material]]
name = "bone"
regions = ["bar"]
model = "isotropic"
E = 17.0e9
nu = 0.3
sigma_t = 133e6
[[dirichlet]]
boundary = "bottom"
value = [0.0, 0.0, 0.0]
[[traction]]
boundary = "top"
value = [0.0, 0.0, 1.0e6]
[fracture]
breakthrough = "surface_crack"
tip_size = {h!r}
tip_grading = 0.12
[fracture.fatigue]
C = 1e-20
m = 3.0
R = 0.1
da_max = {da!r}
max_blocks = {blocks}
{crack}
[output]
fields_every = 0
"""


def _penny() -> str:
    return (
        f'[[crack]]\nname = "penny"\ncentre = [{X0!r}, 0.0, 0.0]\nnormal = {list(NORMAL)!r}\n'
        f'radius = {A!r}\nregion = "bar"\nfront_points = 1\n'
    )


def _cylinder(gmsh) -> None:
    occ = gmsh.model.occ
    occ.addCylinder(0, 0, -HZ, 0, 0, 2 * HZ, R)
    occ.synchronize()
    gmsh.model.addPhysicalGroup(3, [1], 1, name="bar")
    groups: dict[str, list[int]] = {}
    for _, s in gmsh.model.getEntities(2):
        z = occ.getCenterOfMass(2, s)[2]
        name = "top" if z > 0.99 * HZ else "bottom" if z < -0.99 * HZ else "side"
        groups.setdefault(name, []).append(s)
    for k, (name, tags) in enumerate(sorted(groups.items()), start=2):
        gmsh.model.addPhysicalGroup(2, tags, k, name=name)
    f = gmsh.model.mesh.field
    ball = f.add("Ball")
    ball_at = (("XCenter", R), ("YCenter", 0.3 * A), ("ZCenter", -0.5 * A))
    for key, v in (("Radius", 2.5 * A), *ball_at, ("VIn", FINE), ("VOut", 1.5 * A)):
        f.setNumber(ball, key, v)
    f.setAsBackgroundMesh(ball)
    for key in ("MeshSizeFromPoints", "MeshSizeFromCurvature", "MeshSizeExtendFromBoundary"):
        gmsh.option.setNumber(f"Mesh.{key}", 0)


def _side_facets(path: Path) -> np.ndarray:
    """The mesh's triangles on the cylinder's side (rank 0 reads, every rank gets them)."""
    tri = None
    if MPI.COMM_WORLD.rank == 0:
        import gmsh

        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        try:
            gmsh.open(str(path))
            tags, xyz, _ = gmsh.model.mesh.getNodes()
            xyz = xyz.reshape(-1, 3)[np.argsort(tags)]
            order = np.sort(tags)
            _, _, nodes = gmsh.model.mesh.getElements(2)
            T = xyz[np.searchsorted(order, nodes[0].astype(np.int64))].reshape(-1, 3, 3)
        finally:
            gmsh.finalize()
        r = np.hypot(T[..., 0], T[..., 1])
        tri = T[np.all(np.abs(r - R) < 1e-9 * R, axis=1)]
    return MPI.COMM_WORLD.bcast(tri)


def _vtk_points(path: Path) -> np.ndarray:
    """The points of a legacy ASCII VTK file (crack_surface_<k>.vtk)."""
    lines = path.read_text().splitlines()
    i = next(j for j, line in enumerate(lines) if line.startswith("POINTS"))
    n = int(lines[i].split()[1])
    return np.array([[float(v) for v in line.split()] for line in lines[i + 1 : i + 1 + n]])


def _sag_and_turn(T: np.ndarray, near: np.ndarray) -> tuple[float, float]:
    """The largest distance of the facets near ``near`` (within 1.3a: the mouth) from the cylinder
    (sampled) and the largest angle between a facet's normal and the cylinder's normal
    at a point of it."""
    T = T[np.linalg.norm(T.mean(axis=1) - near, axis=1) < 1.3 * A]
    w = np.array([(i, j, 8 - i - j) for i in range(9) for j in range(9 - i)]) / 8.0
    P = np.einsum("sk,tkd->tsd", w, T)
    sag = float((R - np.hypot(P[..., 0], P[..., 1])).max())
    m = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    m /= np.linalg.norm(m, axis=1)[:, None]
    radial = P[..., :2] / np.linalg.norm(P[..., :2], axis=2)[..., None]
    cosang = np.abs(np.einsum("td,tsd->ts", m[:, :2], radial))
    return sag, float(np.arccos(np.clip(cosang.min(), -1, 1)))


@pytest.fixture(scope="module")
def mesh(tmp_path_factory) -> Path:
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("curved")) if comm.rank == 0 else None))
    gmsh_on_rank0(_cylinder, d / "bar.msh", 3)
    return d


def _scene(mesh: Path, blocks: int, crack: str, h: float = H) -> str:
    return SCENE.format(mesh=mesh / "bar.msh", h=h, da=DA, blocks=blocks, crack=crack)


@pytest.fixture(scope="module")
def run(mesh: Path):
    res, d = run_in(mesh, "tilted", _scene(mesh, 3, _penny()))
    assert res.status == "converged", res.summary.get("message")
    idle_barrier(MPI.COMM_WORLD)
    return res, d


def _by_hand(front: np.ndarray, n: np.ndarray) -> dict[str, float]:
    """The rule with the exact cylinder: e from its normal at the front point farthest
    from the axis (16 points per edge), the depth line met at r = R."""
    V = front - np.outer((front - front.mean(axis=0)) @ n, n)
    s = np.arange(16)[:, None, None] / 16
    X = (V[None] + s * (np.roll(V, -1, axis=0) - V)[None]).reshape(-1, 3)
    p = X[np.argmax(np.hypot(X[:, 0], X[:, 1]))]
    m = np.array([p[0], p[1], 0.0]) / np.hypot(p[0], p[1])
    e = m - (m @ n) * n
    e /= np.linalg.norm(e)
    t = np.cross(n, e)
    along, up = V @ t, V @ e
    p0 = p + (0.5 * (along.max() + along.min()) - p @ t) * t + (up.max() - p @ e) * e
    # |p0 + s e|_xy = R
    a2 = e[0] ** 2 + e[1] ** 2
    b = p0[0] * e[0] + p0[1] * e[1]
    c = p0[0] ** 2 + p0[1] ** 2 - R**2
    lig = (-b + math.sqrt(b * b - a2 * c)) / a2
    return {
        "ligament": lig,
        "height": float(np.ptp(up)),
        "length": float(np.ptp(along)),
        "depth": lig + float(np.ptp(up)),
        "half_length": 0.5 * float(np.ptp(along)),
        "centre": p0 + lig * e,
        "axis": t,
    }


def test_recharacterised_against_the_exact_cylinder(mesh: Path, run) -> None:
    res, _ = run
    fr = res.summary["fracture"]
    assert fr["interior"]["growth"]["status"] == "through"
    crack = fr["breakthrough"]["crack"]
    n = np.asarray(NORMAL)
    np.testing.assert_allclose(crack["normal"], n, atol=1e-12)  # the penny's plane
    front = np.asarray(fr["interior"]["crack"]["front"])
    want = _by_hand(front, n)
    sag, turn = _sag_and_turn(_side_facets(mesh / "bar.msh"), np.asarray(crack["centre"]))
    assert 0 < sag < 0.01 * A and 0 < turn < 0.3  # the fine patch: a/5 facets on R = 3a
    # the run's depth direction (the facets' mean normal) against the cylinder's
    delta = math.acos(min(1.0, abs(float(np.asarray(crack["axis"]) @ want["axis"]))))
    assert delta < 0.1 * turn
    size = np.ptp(front, axis=0).max()
    tol = sag / math.cos(TILT) + delta * size  # the depth line's slant, the normal's turn
    for key in ("ligament", "height", "length", "depth", "half_length"):
        assert abs(crack[key] - want[key]) <= tol, (key, crack[key], want[key], tol)
    assert np.linalg.norm(np.asarray(crack["centre"]) - want["centre"]) <= tol
    assert crack["depth"] == pytest.approx(crack["ligament"] + crack["height"], rel=1e-14)
    # the centre on the cylinder within the sag
    assert R - sag - 1e-12 * A <= np.hypot(*crack["centre"][:2]) <= R + 1e-12 * A


def test_surface_points_on_the_cylinder_cycles_continue(mesh: Path, run) -> None:
    res, d = run
    fr = res.summary["fracture"]
    t = read_table(d / "out" / "fracture.csv")
    surf = t["phase"] == "surface"
    k0 = fr["breakthrough"]["increment"]
    assert k0 == fr["interior"]["growth"]["increments"] + 1 and surf.sum() > 0
    assert set(t["increment"][surf]) == set(range(k0, fr["growth"]["increments"] + 1))
    sag, _ = _sag_and_turn(
        _side_facets(mesh / "bar.msh"), np.asarray(fr["breakthrough"]["crack"]["centre"])
    )
    for k in range(k0, fr["growth"]["increments"] + 1):
        P = _vtk_points(d / "out" / f"crack_surface_{k}.vtk")
        r = np.hypot(P[:, 0], P[:, 1])
        assert r.max() <= R + 1e-9 * A
        mouth = r > R - 0.03 * A  # the next nodes in lie a front element (≥ 0.07a) deeper
        assert mouth.sum() >= 10 and r[mouth].min() >= R - sag - 1e-9 * A, (k, r[mouth].min())
        # the K points: the deepest inside, all away from the surface
        xyz = np.stack([t[c][t["increment"] == k].astype(float) for c in ("x", "y", "z")], 1)
        assert np.hypot(xyz[:, 0], xyz[:, 1]).max() < R - 0.5 * A
    cyc = t["cycles"]
    assert np.all(np.diff(cyc) >= 0) and cyc[-1] > 0
    n1 = fr["interior"]["growth"]["history"][-1]["cycles"]
    assert fr["breakthrough"]["cycles"] == n1
    first = t["increment"] == k0
    assert np.all(cyc[first] == n1) and np.all(cyc[t["status"] == "breaks_surface"] == n1)
    assert fr["growth"]["cycles"] == pytest.approx(cyc[-1], rel=1e-12) and cyc[-1] > n1


@pytest.mark.two_ranks  # no rank comparison: serial and 2 ranks only
def test_surface_phase_equals_a_direct_surface_scene(mesh: Path, run) -> None:
    res, d = run
    fr = res.summary["fracture"]
    crack, h = fr["breakthrough"]["crack"], fr["breakthrough"]["front_size"]
    blocks = fr["growth"]["increments"] - fr["breakthrough"]["increment"]
    text = (
        f'[[crack]]\nname = "penny"\nshape = "semi_elliptical"\ncentre = {crack["centre"]!r}\n'
        f"normal = {crack['normal']!r}\naxis = {crack['axis']!r}\ndepth = {crack['depth']!r}\n"
        f'half_length = {crack["half_length"]!r}\nregion = "bar"\nfront_points = 1\n'
    )
    text = _scene(mesh, blocks, text, h).replace('breakthrough = "surface_crack"\n', "")
    direct, dd = run_in(mesh, "direct", text)
    assert direct.status == "converged", direct.summary.get("message")
    idle_barrier(MPI.COMM_WORLD)
    got = read_table(d / "out" / "fracture.csv")
    want = read_table(dd / "out" / "fracture.csv")
    surf = got["phase"] == "surface"
    n1 = fr["breakthrough"]["cycles"]
    k0 = fr["breakthrough"]["increment"]
    assert list(got["increment"][surf]) == list(want["increment"] + k0)
    scale = np.abs(want["K_I"]).max()
    for key in ("K_I", "K_II", "K_III", "K_V"):
        np.testing.assert_allclose(got[key][surf], want[key], rtol=0, atol=1e-10 * scale)
    for key in ("depth", "half_length", "x", "y", "z"):
        col = got[key][surf].astype(float)
        np.testing.assert_allclose(col, want[key], rtol=0, atol=1e-10 * A)
    np.testing.assert_allclose(got["cycles"][surf], want["cycles"] + n1, rtol=1e-10)


@pytest.mark.skipif(MPI.COMM_WORLD.size == 1, reason="compares a distributed run with a serial one")
def test_same_answer_on_any_rank_count(run) -> None:
    import json

    res, d = run
    ref = serial_reference(d)
    idle_barrier(MPI.COMM_WORLD)
    _same_tables(d / "out" / "fracture.csv", ref / "fracture.csv")
    want = json.loads((ref / "summary.json").read_text())["fracture"]
    got = res.summary["fracture"]
    assert got["growth"]["status"] == want["growth"]["status"]
    assert got["growth"]["cycles"] == pytest.approx(want["growth"]["cycles"], rel=1e-10)
    for key, v in want["breakthrough"]["crack"].items():
        np.testing.assert_allclose(got["breakthrough"]["crack"][key], v, rtol=1e-10, atol=1e-13)
