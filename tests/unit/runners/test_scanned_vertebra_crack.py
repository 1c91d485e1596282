"""A fatigue crack in the posterior wall of the scanned L4 (``anatomy_surface("L4")``, the
424-triangle scan of demos/spine3d.py), loaded as demos/vertebra_fracture.py's flexion.

The body: the whole shipped L4 surface, one material (the cancellous bone of
vertebra_fracture's crack runs, ``cancellous_bone_vertebral_018``, K_Ic and the Paris law of
``[reference.cancellous_*]``), its triangles split once into four at their edges' midpoints
(the surface unchanged; the body's longest boundary edge, the crack mesh's size away from
the front, 12 instead of 24 mm).  The whole L4 rather than its vertebral body alone: the
scan is one closed surface, its body cannot be cut off without inventing a surface.
Groups as spine3d's endplate fans: ``lower`` held, ``upper`` loaded by the published
flexion (1175 N and 7.5 N·m, ``[reference.lumbar_spine_loads]``; y up, x forwards: the
force (0, −F, 0), the moment (0, 0, −M) presses the front).

The crack: a = c = 2 mm, centred on the posterior wall of the body (mid-sagittal, 14 mm
above the base: x = −16.26 mm) in the plane that contains the wall's normal and is
nearest to horizontal (normal (0.234, 0.972, 0): the wall leans 13.5° back); front a/8.
References and measured values (serial; 2 ranks):

* the crack's mouth nodes lie on the scan (distance < 1e-13 m, 1e-12 of the body; measured
  1.3e-14 m: the .msh round trip and the midpoints) and in the crack plane;
* K_I at the deepest point at the first solve against Newman–Raju's surface crack in a
  plate of the local thickness t (the body's depth along the crack's depth direction,
  by ray casting on the scan: 28.1 mm) under S = the mean normal stress over the crack's
  depth in the uncracked body (cell stresses at 0.1a … 0.9a on a 1.5 mm mesh: 0.97 MPa;
  1.16 MPa at 0.1a, 1.00 at 0.9a): within 15 % — the stress over the depth varies by
  ±10 % about S (the body bends; the cells' constant stresses), the wall under the mouth
  is two facets meeting at 9°, and the plate's formula is a fit within ±5 %; measured
  −4.7 % (48.7 against 51.1 kPa√m);
* cycles: the runner's block cycles (ln da/dN interpolated between block ends) against
  an RK4 integration of dN/ds = 1/(C K_lead^m) with the lead point's recorded K_V linear
  in s between block ends, within 1 % (measured −0.27 %: 85 535 against 85 770);
* growth: three blocks of Δa_max = 1.5 mm (the surface points lead: K_V there 27 % above
  the deepest point's at the start); the third block's crack (a = 4.07, c = 6.39 mm)
  reaches past the flat posterior wall, where the crack plane's intersection with the
  scan is the closed loop of the spinal canal's wall: it is cut (it was refused — "not
  one stretch" — while a closed chain started at its lowest node index, inside the
  ellipse); the HXT meshes of the cracked body had 4, 5 and 1 flat tetrahedra (zero
  volume: a singular system) and are replaced by Delaunay meshes, and at the first solve
  the domain at one end of the front reached the surface and was shortened once (0.8);
* 2 ranks = serial (fracture.csv, cycles, final crack: 1e-10);
* a long crack (a = 6.99, c = 17.4 mm: a 4 mm block's, past the wall's posterolateral
  corners) is cut, its mouth on the scan (the vertices the cut moves onto the plane within
  the snap distance, measured 9.3e-6 m; the others to round-off), its front inside: it was
  refused "(nearly) tangent" while the side of a grown crack's depth came from the facets
  within max(a, c) (the base of the body, 14 mm below and normal to the plane, among them).

Slow: blocks of 4 mm until the crack runs through the body (11 blocks, 4.96·10⁵ cycles;
test_the_crack_runs_through_the_body has the figures and why the cycles are checked
against the recorded K, not pinned), the same on 2 and 3 ranks.  K_V peaks at 117.1
kPa√m (c = 13.8 mm) and falls to 53.8 at a = 13.2 mm as the front enters the half of the
body the flexion's follower load compresses; from a = 17.2 mm the faces are closed at the
front (|K_I| ≤ 0.14 K_II) and the planar crack grows by mode II (kink −69 … −73°: a real
crack would leave its plane here; the planar model goes on, summary.json's
``out_of_plane`` says from which block: the deepest point's kink passes the default 15° at
the 3rd crack, −22°) until its front leaves the body (the 11th crack a = 25.3, c = 43.6
mm).  About 12 solves: 7 min serial on a quiet 2-core machine, 12 min
with a 2-rank run beside it.  Serial (fast part) about 60 s.  Slow too: the same crack on the
non-planar path (4 mm blocks halved up to 3 times before the final one, front a₀/12):
``through`` after 11 solves, 2.61·10⁷ cycles, about 11 min serial
(test_the_crack_leaves_its_plane_and_runs_through).
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import idle_barrier, run_dir, run_serial_on_rank0, same_tables
from coupled_support import read_csv, run_text

from bonecontact.common.geometry import line_triangle_hits, point_triangle_distance
from bonecontact.fracture.advance3d import equivalent_k
from bonecontact.fracture.body3d import body_surface
from bonecontact.fracture.crack3d import SurfaceBreakingCrack
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.surface_body3d import SNAP_FRACTION, cut_mouth, inside_body
from bonecontact.materials.library import load_reference_values, stiffness_and_strength
from bonecontact.meshing import Surface, SurfaceRegion, anatomy_surface, mesh_surface
from bonecontact.meshing.io import read_gmsh_mesh
from bonecontact.verification.surface_crack import surface_crack_k

MM = 1e-3
REF = load_reference_values()
LOADS = REF["lumbar_spine_loads"]
F, M = LOADS["flexion_force"], LOADS["flexion_moment"]
E, NU, SIGMA_T = stiffness_and_strength("cancellous_bone_vertebral_018")
K_IC = REF["cancellous_fracture_toughness"]["K_Ic"]
PARIS = REF["cancellous_fatigue_crack_growth"]
M_PARIS = PARIS["m"]
C_PARIS = PARIS["rate_at_K_Ic"] / K_IC**M_PARIS
A0 = 2.0 * MM
TIP = A0 / 8
DA_MAX = 1.5 * MM
CENTRE = np.array([-16.257, 14.0, 0.3]) * MM
NORMAL = np.array([0.23416107, 0.97219782, 0.0])
DEPTH_DIR = np.array([0.97219782, -0.23416107, 0.0])  # inwards, in the crack plane

SCENE = """format = 1
[scene]
name = "{name}"
mesh = "{mesh}"
dimension = 3
[analysis]
kind = "static"
load_steps = 1
[[material]]
name = "cancellous"
regions = ["L4"]
model = "isotropic"
E = {E!r}
nu = {NU!r}
sigma_t = {ST!r}
K_Ic = {KIC!r}
[[dirichlet]]
boundary = "lower"
value = [0.0, 0.0, 0.0]
[[force]]
boundary = "upper"
value = [0.0, {fy!r}, 0.0]
moment = [0.0, 0.0, {mz!r}]
{extra}
[output]
fields_every = 0
{probes}
"""


def _vec(v) -> str:
    return ", ".join(f"{float(x)!r}" for x in v)


def crack_text(da_max: float = DA_MAX, blocks: int = 3) -> str:
    return (
        f'[fracture]\ncriterion = "tension"\ntip_size = {TIP!r}\n'
        f"[fracture.fatigue]\nC = {C_PARIS!r}\nm = {M_PARIS!r}\nda_max = {da_max!r}\n"
        f'max_blocks = {blocks}\n[[crack]]\nname = "wall"\nshape = "semi_elliptical"\n'
        f"centre = [{_vec(CENTRE)}]\nnormal = [{_vec(NORMAL)}]\ndepth = {A0!r}\n"
        f'half_length = {A0!r}\nregion = "L4"\nfront_points = 3\n'
    )


def scene_text(name: str, mesh: Path, extra: str = "", probes: str = "") -> str:
    return SCENE.format(
        name=name,
        mesh=mesh,
        E=E,
        NU=NU,
        ST=SIGMA_T,
        KIC=K_IC,
        fy=-F,
        mz=-M,
        extra=extra,
        probes=probes,
    )


def subdivided(s: Surface) -> Surface:
    """Every triangle split into four at its edges' midpoints (the surface unchanged)."""
    x, t = s.points, s.triangles
    e = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    u, inv = np.unique(e, axis=0, return_inverse=True)
    mid = len(x) + inv.reshape(3, -1).T
    x2 = np.vstack([x, 0.5 * (x[u[:, 0]] + x[u[:, 1]])])
    a, b, c = t.T
    ab, bc, ca = mid.T
    t2 = np.concatenate([np.c_[a, ab, ca], np.c_[ab, b, bc], np.c_[ca, bc, c], np.c_[ab, bc, ca]])
    return Surface(x2, t2, s.source)


def endplates() -> list[SurfaceRegion]:
    """spine3d's endplate fans of L4: normals within 30° of ±y, centroids in a box."""
    lo, hi = -14 * MM, 20 * MM
    return [
        SurfaceRegion(
            "upper", cone=((0, 1, 0), 30.0), box=((lo, 24 * MM, -40 * MM), (hi, 32 * MM, 40 * MM))
        ),
        SurfaceRegion(
            "lower", cone=((0, -1, 0), 30.0), box=((lo, -5 * MM, -40 * MM), (hi, 6 * MM, 40 * MM))
        ),
    ]


def ray_exit(tri: np.ndarray, p: np.ndarray, d: np.ndarray) -> float:
    """The farthest hit of the ray p + s d (s > 1e-9) with the triangles."""
    s = line_triangle_hits(p, d, tri, tol=0.0)
    return float(s[s > 1e-9].max())


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict:
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("scanned_l4")) if comm.rank == 0 else None))
    scan = anatomy_surface("L4")
    body = subdivided(scan)
    mesh_surface(body, d / "l4.msh", 4 * MM, None, name="L4", regions=endplates(), remesh=False)
    mesh_surface(body, d / "fine.msh", 1.5 * MM, None, name="L4", regions=endplates(), remesh=False)
    depths = np.linspace(0.1, 0.9, 9) * A0
    pts = [CENTRE + s * DEPTH_DIR for s in depths]
    probes = "probes = [" + ", ".join(f"[{_vec(p)}]" for p in pts) + "]"
    sub = run_dir(d, "uncracked")
    plain = run_text(scene_text("uncracked", d / "fine.msh", probes=probes), sub, sub / "out")
    assert plain.status == "converged", plain.summary.get("message")
    sub = run_dir(d, "crack")
    res = run_text(scene_text("crack", d / "l4.msh", extra=crack_text()), sub, sub / "out")
    return {
        "dir": d,
        "scan": scan,
        "plain": sub.parent / "uncracked" / "out",
        "crack": res,
        "crack_dir": sub,
        "depths": depths,
    }


def test_the_mouth_lies_on_the_scan(runs) -> None:
    md = read_gmsh_mesh(runs["dir"] / "l4.msh", MPI.COMM_WORLD, 3)[1]
    groups = {name: (dim, tag) for name, (dim, tag) in md.physical_groups.items()}
    body = body_surface(md.mesh, md.cell_tags, md.facet_tags, groups, "L4")
    crack = SurfaceBreakingCrack(tuple(CENTRE), tuple(NORMAL), A0, A0)
    cut = cut_mouth(body, crack, TipMesh(TIP, 0.12))
    scan = runs["scan"]
    tri = scan.points[scan.triangles]
    mouth = cut.nodes[list(cut.mouth)]
    dist = [float(point_triangle_distance(p, tri).min()) for p in mouth]
    assert len(mouth) > 10 and max(dist) < 1e-13  # 1e-12 of the body (90 mm): round-off
    np.testing.assert_allclose((mouth - cut.crack.centre) @ NORMAL, 0.0, atol=1e-13)


def test_a_long_crack_along_the_wall_is_cut(runs) -> None:
    """The grown crack a = 6.99, c = 17.4 mm (a 4 mm block's, its axis set) reaches the
    wall's posterolateral corners; it was refused "(nearly) tangent" while the side of its
    depth was taken over the facets within max(a, c) (the base 14 mm below, normal to the
    plane): its mouth lies on the scan (the vertices the cut moved onto the plane within the
    snap distance, the others to round-off), in the plane, and its front inside the body."""
    md = read_gmsh_mesh(runs["dir"] / "l4.msh", MPI.COMM_WORLD, 3)[1]
    groups = {name: (dim, tag) for name, (dim, tag) in md.physical_groups.items()}
    body = body_surface(md.mesh, md.cell_tags, md.facet_tags, groups, "L4")
    size = TipMesh(TIP, 0.12)
    first = cut_mouth(body, SurfaceBreakingCrack(tuple(CENTRE), tuple(NORMAL), A0, A0), size)
    cut = cut_mouth(body, first.crack.grown(6.99 * MM, 17.4 * MM), size)
    np.testing.assert_allclose(cut.arc.rotation[1], DEPTH_DIR, atol=1e-6)  # depth: inwards
    scan = runs["scan"]
    tri = scan.points[scan.triangles]
    mouth = cut.nodes[list(cut.mouth)]
    dist = [float(point_triangle_distance(p, tri).min()) for p in mouth]
    x = body.triangles
    snap = SNAP_FRACTION * float(np.linalg.norm(x - np.roll(x, 1, axis=1), axis=2).max())
    print(f"mouth: {len(mouth)} nodes, farthest {max(dist):.3g} m from the scan (snap {snap:.3g})")
    assert max(dist) < snap  # vertices within 2 % of an edge moved onto the plane
    assert np.mean(np.asarray(dist) < 1e-13) > 0.9  # the others on the scan
    np.testing.assert_allclose((mouth - cut.crack.centre) @ NORMAL, 0.0, atol=1e-12)  # 1.2e-13
    p0, p1 = cut.arc.phi_range
    assert np.all(inside_body(body, cut.arc.point(np.linspace(p0, p1, 11)[1:-1])))


def test_deepest_k_against_newman_raju(runs) -> None:
    tab = read_csv(runs["crack_dir"] / "out" / "fracture.csv")
    first = tab["increment"] == 0
    phi = np.radians(tab["phi_deg"][first])
    deep = int(np.argmin(np.abs(phi - 0.5 * math.pi)))
    probes = read_csv(runs["plain"] / "probes.csv")
    last = probes["step"] == probes["step"].max()
    n = NORMAL
    s = np.array(
        [
            [probes[f"s_{a}{b}" if f"s_{a}{b}" in probes else f"s_{b}{a}"][last] for b in "xyz"]
            for a in "xyz"
        ]
    )  # (3, 3, points)
    snn = np.einsum("i,ijp,j->p", n, s, n)
    S = float(np.trapezoid(snn, runs["depths"]) / (runs["depths"][-1] - runs["depths"][0]))
    scan = runs["scan"]
    t = ray_exit(scan.points[scan.triangles], CENTRE + 1e-6 * DEPTH_DIR, DEPTH_DIR)
    ref = float(surface_crack_k(S, A0, A0, t, 20 * MM, np.array([0.5 * math.pi]))[0])
    print(
        f"S {S:.4g} Pa (surface {snn[0]:.4g}, at a {snn[-1]:.4g}), t {t:.4g} m, "
        f"K_I {tab['K_I'][first][deep]:.5g}, NR {ref:.5g}"
    )
    assert tab["K_I"][first][deep] == pytest.approx(ref, rel=0.15)


def test_three_blocks_past_the_canal_loop(runs) -> None:
    """The third block's crack (c = 6.4 mm) is cut into the canal's loop of the plane's
    intersection with the scan (it failed before the closed chain was opened outside the
    ellipse); the lead point is a surface point (K_V there above the deepest point's).
    Every crack follows from the K of fracture.csv by the Paris law: its three points (the
    front's ends, the deepest point φ = 90°) advance by Δa_max da/dN / max da/dN, the depth
    by the deepest point's, the half-length by the mean of the ends' (to 1e-8 m: the
    advances are rounded to 1e-6 of Δa_max).  The final half-length 6.37 mm lies within
    2 % of 6.39 mm, the run's with the advances rounded to 2⁻³² instead of 2⁻²⁰ of Δa_max
    (other meshes: the noise of K at this mesh, measured −0.4 %)."""
    res = runs["crack"]
    g = res.summary["fracture"]["growth"]
    assert res.status == "converged", res.summary.get("message")
    assert g["status"] == "max_blocks" and g["increments"] == 3 and not g["fractured"]
    tab = read_csv(runs["crack_dir"] / "out" / "fracture.csv")
    a, c = A0, A0
    for k in range(g["increments"]):
        rows = tab["increment"] == k
        assert tab["depth"][rows][0] == pytest.approx(a, abs=1e-8)
        assert tab["half_length"][rows][0] == pytest.approx(c, abs=1e-8)
        kv, phi = tab["K_V"][rows], tab["phi_deg"][rows]
        rate = C_PARIS * kv[[0, int(np.argmin(np.abs(phi - 90.0))), -1]] ** M_PARIS
        d = DA_MAX * rate / rate.max()
        a, c = a + d[1], c + 0.5 * (d[0] + d[2])
    final = res.summary["fracture"]["crack"]["final"]
    assert final["depth"] == pytest.approx(a, abs=1e-8)
    assert final["half_length"] == pytest.approx(c, abs=1e-8)
    assert final["half_length"] == pytest.approx(6.39e-3, rel=0.02)
    assert final["depth"] == pytest.approx(4.07e-3, rel=0.05)
    for h in g["history"]:
        assert h["K_V_surface"] > h["K_V_deepest"]


def test_cycles_against_rk4_of_the_recorded_k(runs) -> None:
    g = runs["crack"].summary["fracture"]["growth"]
    tab = read_csv(runs["crack_dir"] / "out" / "fracture.csv")
    inc = tab["increment"].astype(int)
    lead = np.array([tab["K_V"][inc == k].max() for k in range(g["increments"] + 1)])
    s_end = DA_MAX * np.arange(len(lead))

    def rate(s: float) -> float:
        return C_PARIS * float(np.interp(s, s_end, lead)) ** M_PARIS

    n, steps = 0.0, 200
    h = s_end[-1] / steps
    for i in range(steps):
        s = i * h
        k1, k2, k4 = 1 / rate(s), 1 / rate(s + h / 2), 1 / rate(s + h)
        n += h / 6 * (k1 + 4 * k2 + k4)
    print(f"cycles {g['cycles']:.6g}, RK4 {n:.6g}")
    assert g["cycles"] == pytest.approx(n, rel=0.01)


def test_ranks_equal_serial(runs) -> None:
    """fracture.csv (cycles included) to 1e-10, the stop, the cycles and the final crack."""
    if MPI.COMM_WORLD.size == 1:
        pytest.skip("serial")
    d = runs["crack_dir"]
    run_serial_on_rank0(d / "scene.toml", d / "ser")  # stops as the distributed run
    idle_barrier(MPI.COMM_WORLD)
    same_tables(d / "out" / "fracture.csv", d / "ser" / "fracture.csv")
    got, want = (
        json.loads((d / k / "summary.json").read_text())["fracture"] for k in ("out", "ser")
    )
    for key in ("status", "increments"):
        assert got["growth"][key] == want["growth"][key]
    assert got["growth"]["cycles"] == pytest.approx(want["growth"]["cycles"], rel=1e-10)
    for key in ("centre", "depth", "half_length"):
        np.testing.assert_allclose(
            got["crack"]["final"][key], want["crack"]["final"][key], rtol=0, atol=1e-10 * A0
        )


# ----------------------------------------------------------------- to the break (slow)
DA_THROUGH = 4.0 * MM
#: the σ₁′ (and maximum tangential stress) kink angle of pure mode II: −arccos(1/3)
KINK_MODE_II = -math.degrees(math.acos(1.0 / 3.0))


def clipped_volume(tri: np.ndarray, x0: np.ndarray, n: np.ndarray) -> float:
    """The volume of the closed outward triangulation ``tri`` on the side of ``n`` of the
    plane through ``x0``: Σ (p − x0)·A/3 over the triangles clipped to that side (p a
    corner, A the area vector; the cap lies in the plane and adds nothing)."""
    vol = 0.0
    for t in tri:
        s = (t - x0) @ n
        poly = []
        for i in range(3):
            p, q, sp, sq = t[i], t[(i + 1) % 3], s[i], s[(i + 1) % 3]
            if sp >= 0:
                poly.append(p)
            if sp * sq < 0:
                poly.append(p + sp / (sp - sq) * (q - p))
        if len(poly) >= 3:
            P = np.asarray(poly)
            area = 0.5 * sum(np.cross(P[k] - P[0], P[k + 1] - P[0]) for k in range(1, len(P) - 1))
            vol += float((P[0] - x0) @ area) / 3.0
    return vol


@pytest.fixture(scope="module")
def through(tmp_path_factory) -> dict:
    comm = MPI.COMM_WORLD
    d = Path(
        comm.bcast(str(tmp_path_factory.mktemp("scanned_l4_through")) if comm.rank == 0 else None)
    )
    mesh_surface(
        subdivided(anatomy_surface("L4")),
        d / "l4.msh",
        4 * MM,
        None,
        name="L4",
        regions=endplates(),
        remesh=False,
    )
    sub = run_dir(d, "through")
    extra = crack_text(DA_THROUGH, 16)
    res = run_text(scene_text("through", d / "l4.msh", extra=extra), sub, sub / "out")
    return {"res": res, "table": read_csv(sub / "out" / "fracture.csv"), "dir": sub}


@pytest.mark.slow
def test_the_crack_runs_through_the_body(through) -> None:
    """Blocks of 4 mm from a = c = 2 mm: the crack passes the wall's posterolateral corners,
    its K_V peaks (117.1 kPa√m at c = 13.8 mm, the 4th crack) and falls below half (53.8 at
    a = 13.2 mm: the front reaches the body's compressed front half), then the faces close
    at the front and mode II drives it (kink −arccos(1/3) within 2.5°) until the
    12th crack's front leaves the body: ``through`` after 11 blocks, 4.96·10⁵ cycles,
    K_V = 237 kPa√m < K_Ic.  "Closed at the front": at the 9th crack 830 of the 1520 face
    nodes are in contact, the rest, away from the front, open; at the front points |K_I|
    ≤ 0.14 K_II (the face term of a closed front: its tip nodes carry no multiplier) and
    the kink −69.1 … −72.6° (pure mode II −70.5°).  Until 2026-12-04 the 3D cold start
    held every face node shut there, pulling ones too (tensile pressures down to
    −3.1 MPa), and this run was counted 4.32·10⁵ cycles with K_I ≈ 0 at the front: the
    blocks up to the 8th crack are unchanged (the faces' net force was tensile).

    Cycles: no closed form exists for this body, and the count carries the noise of the
    mesh at 4 mm blocks (m = 4.4 turns 1 % in K into 4.4 % in a block's cycles): a run
    whose advances were rounded to a grid of 2⁻³² instead of 2⁻²⁰ of the block (the
    cracks up to 2e-9 m apart, other meshes) gave the same 11 blocks and the peak K_V
    116.6 kPa√m (−0.4 %).  So the cycles are checked against what the recorded K imply:
    every block's count lies between the block length over the larger and over the
    smaller of its end rates (any rate between them), the last block (whose end is
    through) counts at its start rate, and the total lies within 5 % of integrating
    ln(da/dN) linear between block ends (5.07·10⁵; measured −2.3 %: the block rule's cubic
    on the other blocks).  The block rule's cubic through the four ends around K's sharp
    minimum had dipped below it (5.07·10⁵ cycles, +17 %); it now takes the line there
    (fatigue.block_cycles).

    Fragments: the body on either side of the crack plane — their sum the scan's enclosed
    volume (divergence theorem; 1e-5: the cut moves vertices within 2 % of an edge onto
    the plane, measured −7.9e-7), each the scan clipped by the plane (exact for the faceted
    scan) within 0.1 % (cells by their midpoints; measured +0.006 %, −0.011 %)."""
    res = through["res"]
    assert res.status == "converged", res.summary.get("message")
    g = res.summary["fracture"]["growth"]
    print({k: g[k] for k in ("status", "increments", "cycles", "fragments")})
    assert g["status"] == "through" and g["fractured"] and g["increments"] == 11
    hist = g["history"]
    lead = np.array([max(h["K_V_surface"], h["K_V_deepest"]) for h in hist])
    print("lead K_V", lead)
    assert int(np.argmax(lead[:8])) == 3 and lead[3] == pytest.approx(117e3, rel=0.02)
    assert lead[7] < 0.5 * lead[3] and lead[-1] < K_IC
    # the planar model's validity: the largest kink is the closed front's mode II
    # (−arccos(1/3), with the K_I residue below); the 15° limit is passed long before
    # (serial run: the 3rd crack, −22°)
    assert g["max_kink_deg"] == pytest.approx(-KINK_MODE_II, abs=2.5)
    oop = g["out_of_plane"]
    assert oop is not None and oop["increment"] < 8 and abs(oop["kink_deg"]) > 15.0
    rate = C_PARIS * lead**M_PARIS
    blocks = np.diff([h["cycles"] for h in hist])
    assert np.all(blocks >= DA_THROUGH / np.maximum(rate[:-1], rate[1:]))
    assert np.all(blocks <= DA_THROUGH / np.minimum(rate[:-1], rate[1:]))
    last = g["cycles"] - hist[-1]["cycles"]
    assert last == pytest.approx(DA_THROUGH / rate[-1], rel=1e-12)
    r0, r1 = rate[:-1], rate[1:]
    loglin = float(np.sum(DA_THROUGH * (1 / r0 - 1 / r1) / np.log(r1 / r0))) + last
    print(f"cycles {g['cycles']:.6g}, ln(da/dN) linear between block ends {loglin:.6g}")
    assert g["cycles"] == pytest.approx(loglin, rel=0.05)
    tab = through["table"]
    late = tab["increment"] >= 8
    # a closed front (measured |K_I| ≤ 0.135 K_II, kinks −69.1 … −72.6°)
    assert np.all(np.abs(tab["K_I"][late]) < 0.15 * np.abs(tab["K_II"][late]))
    np.testing.assert_allclose(tab["kink_deg"][late], KINK_MODE_II, atol=2.5)
    scan = anatomy_surface("L4")
    tri = scan.points[scan.triangles]
    vol = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0
    final = res.summary["fracture"]["crack"]["final"]
    c, n = np.asarray(final["centre"]), np.asarray(final["normal"])
    frag = {f["side"]: f["volume"] for f in g["fragments"]}
    assert frag["+normal"] + frag["-normal"] == pytest.approx(vol, rel=1e-5)
    assert frag["+normal"] == pytest.approx(clipped_volume(tri, c, n), rel=1e-3)
    assert frag["-normal"] == pytest.approx(clipped_volume(tri, c, -n), rel=1e-3)


@pytest.mark.slow
def test_the_through_run_on_ranks_equals_serial(through) -> None:
    """On 2 and 3 ranks the whole run to the break equals the serial one (rank 0 alone):
    fracture.csv to 1e-10 of each column's scale, the stop, the cycles and the fragments
    (measured on 2 ranks: cycles 6e-14 apart, the fragments equal; passed on 3 ranks,
    1460 s on a loaded machine).  It departed at the
    8th block while the advances were rounded to 2⁻³² of the block (one advance within
    round-off of a grid midpoint: docs/theory/fracture.md, *The same answer on any number
    of ranks*)."""
    if MPI.COMM_WORLD.size == 1:
        pytest.skip("serial")
    sub = through["dir"]
    run_serial_on_rank0(sub / "scene.toml", sub / "ser")
    idle_barrier(MPI.COMM_WORLD)
    same_tables(sub / "out" / "fracture.csv", sub / "ser" / "fracture.csv")
    got, want = (
        json.loads((sub / k / "summary.json").read_text())["fracture"]["growth"]
        for k in ("out", "ser")
    )
    assert (got["status"], got["increments"]) == (want["status"], want["increments"])
    assert got["cycles"] == pytest.approx(want["cycles"], rel=1e-10)
    for a, b in zip(got["fragments"], want["fragments"], strict=True):
        assert a["side"] == b["side"] and a["volume"] == pytest.approx(b["volume"], rel=1e-10)


# ------------------------------------------------- to the break out of plane (slow)
#: the non-planar path's front element: a₀/12 (a coarser front puts the start crack's
#: end points within h/4 of the scan, refused by design)
NP_TIP = 0.000166
#: the blocks before the final one halved up to three times (``end_halvings``): 4 mm → 0.5 mm
NP_HALVINGS = 3


def vertex_lead_k(table: dict, increment: int) -> float:
    """The largest K_V at the front's vertices after solve ``increment``, as the runner
    takes it from the edges' K (an end vertex its edge's, an inner one the mean of its two
    edges')."""
    rows = table["increment"] == increment
    K = np.column_stack([table[c][rows] for c in ("K_I", "K_II", "K_III")])
    Kv = np.vstack([K[:1], 0.5 * (K[:-1] + K[1:]), K[-1:]])
    return float(equivalent_k(Kv[:, 0], Kv[:, 1], Kv[:, 2]).max())


@pytest.fixture(scope="module")
def nonplanar(tmp_path_factory) -> dict:
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("scanned_l4_np")) if comm.rank == 0 else None))
    mesh_surface(
        subdivided(anatomy_surface("L4")),
        d / "l4.msh",
        4 * MM,
        None,
        name="L4",
        regions=endplates(),
        remesh=False,
    )
    sub = run_dir(d, "nonplanar")
    extra = re.sub(
        r"tip_size = [0-9.e-]+",
        f'surface_growth = "nonplanar"\ntip_size = {NP_TIP!r}',
        crack_text(DA_THROUGH, 30),
    ).replace("max_blocks = 30\n", f"max_blocks = 30\nend_halvings = {NP_HALVINGS}\n")
    res = run_text(scene_text("nonplanar", d / "l4.msh", extra=extra), sub, sub / "out")
    return {"res": res, "table": read_csv(sub / "out" / "fracture.csv")}


@pytest.mark.slow
def test_the_crack_leaves_its_plane_and_runs_through(nonplanar) -> None:
    """The same crack on the non-planar path (``surface_growth = "nonplanar"``, front
    a₀/12, blocks of 4 mm, ``end_halvings = 3``).  Without the halvings (2026-12-05, 476 s
    quiet) it ran ``through`` after 9 blocks with 4.35·10⁶ cycles, 2.98·10⁶ (69 %) of them
    the final 4-mm block at the rate of its start: K_V peaks at 118 kPa√m at the 5th crack
    (the planar path's 117.1), then falls as the front enters the half of the body the
    follower load compresses, to 32 kPa√m at the 9th solve (K_I 16, K_II −12, kink +48°:
    the crack turns instead of running on in mode II at a closed front).  With the
    halvings (measured 2026-12-05, 673 s serial, a helper's tests beside it) the blocks of
    2 and 1 mm after the 9th solve are solved: K_V falls on, 30.6 → 21.1 → 17.8 kPa√m, the
    depth grows by 0.27 mm per block while the cycles go 1.36·10⁶ → 5.12·10⁶ → 1.50·10⁷,
    and the final 0.5-mm block at the last rate adds 1.11·10⁷ (43 %): ``through`` after 11
    solves, 2.61·10⁷ cycles — six times the count without them, which the falling rate
    had hidden in its extrapolated last block (a lower bound still: the rate falls).
    Checked without the run's own numbers: the fragments sum to the scan's enclosed volume
    (1e-5; measured −8.9e-9); each block's cycles lie between the block (its ``da``) over
    the larger and over the smaller of its end rates, C K^m of the largest vertex K_V from
    fracture.csv; the blocks are Δa_max until the first halved one, then Δa_max/2^k with k
    rising, ``halved_blocks`` of them; the last is the block Δa_max/2³ over its start
    rate; the total within 5 % of ln(da/dN) linear between block ends (measured −3.2 %:
    2.61·10⁷ against 2.70·10⁷; the test passed in 819 s beside a helper's runs)."""
    res = nonplanar["res"]
    assert res.status == "converged", res.summary.get("message")
    g = res.summary["fracture"]["growth"]
    assert g["status"] in ("through", "fractured") and g["fractured"]
    assert g["increments"] >= 5
    scan = anatomy_surface("L4")
    tri = scan.points[scan.triangles]
    vol = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0
    assert sum(f["volume"] for f in g["fragments"]) == pytest.approx(vol, rel=1e-5)
    hist = g["history"]
    lead = np.array([vertex_lead_k(nonplanar["table"], h["increment"]) for h in hist])
    rate = C_PARIS * lead**M_PARIS
    da = np.array([h["da"] for h in hist])
    levels = np.log2(DA_THROUGH / da)
    np.testing.assert_allclose(levels, np.round(levels), atol=1e-9)
    assert np.all(np.diff(levels) >= 0) and levels[-1] == NP_HALVINGS
    assert g["halved_blocks"] == int(np.count_nonzero(levels[:-1] > 0)) >= 1
    blocks = np.diff([h["cycles"] for h in hist])
    assert np.all(blocks >= da[:-1] / np.maximum(rate[:-1], rate[1:]) * (1 - 1e-9))
    assert np.all(blocks <= da[:-1] / np.minimum(rate[:-1], rate[1:]) * (1 + 1e-9))
    last = g["cycles"] - hist[-1]["cycles"]
    assert last == pytest.approx(da[-1] / rate[-1], rel=1e-9)
    fb = g["final_block"]  # reported, and said to set the count when it holds most
    assert fb["cycles"] == pytest.approx(last, rel=1e-9) and fb["da"] == da[-1]
    assert fb["share"] == pytest.approx(last / g["cycles"], rel=1e-9)
    assert ("final block" in res.summary.get("message", "")) == (fb["share"] > 0.5)
    r0, r1 = rate[:-1], rate[1:]
    loglin = float(np.sum(da[:-1] * (1 / r0 - 1 / r1) / np.log(r1 / r0))) + last
    print(f"cycles {g['cycles']:.6g}, ln(da/dN) linear between block ends {loglin:.6g}")
    assert g["cycles"] == pytest.approx(loglin, rel=0.05)
