"""3D scenes with a planar ``[[crack]]`` (bonecontact.runners.cracks3d), run through the
runner functions of the ``bonecontact`` command.

A penny-shaped crack of radius a = 1 mm at the centre of a block [−4a, 4a]³ (cortical bone
E = 17 GPa, ν = 0.3), uniaxial stress σ along z: traction on the top face, rollers on the
faces x = −4a, y = −4a and z = −4a (which the uncracked uniform state satisfies exactly).
The runner re-meshes the block around the crack (front size a/8, grading 0.12), makes the
faces a contact pair and writes K at 8 front points to fracture.csv.  References (an
infinite body; the block of 8a adds about +1.5 % — the octant study of
docs/theory/fracture.md#3d-crack-fronts):

* crack normal to the load, tension: K_I = 2σ√(a/π) (Sneddon) within 3 % (measured
  −0.0 … −1.1 %), K_II, K_III below 3 % of it; displacement correlation, the P1
  cross-check, 15–35 % low (measured ≈ 25 %).
* the same crack in compression (front a/6, 4 points): every face node closed (no
  interpenetration), the contact pressure σ, K_I, K_II, K_III below 3 % of 2|σ|√(a/π)
  (measured 0.1 %: the contact tractions enter the integral as the face term).
* crack normal at β = 30° to the load, tension: σ_n = σcos²β, τ = σ sinβ cosβ;
  K_I = 2σ_n√(a/π), and the shear of a penny crack (Kassir & Sih 1966; Tada, Paris &
  Irwin, *The Stress Analysis of Cracks Handbook*, 3rd ed., penny-shaped crack under
  shear): K_II = 4τ√(a/π)/(2 − ν)·cos ω, K_III = 4(1 − ν)τ√(a/π)/(2 − ν)·sin ω, ω the
  angle between the shear direction and the radius to the front point.  K_I within 3 %
  (measured −1.4 … +0.2 %), the shear modes within 7 % of their maxima at a/8 (measured
  3.9 % and 5.0 %; slow: within 4 % at a/12, measured 2.7 %).  The unstructured mesh
  adds a point-to-point scatter of 1–2 % (benchmarks/README.md, 3D crack scene: K_III
  5.8, 3.2, 4.4 % at a/8, a/12, a/16 on a slightly different block mesh).
* slow: an ellipse a = 2b against Irwin's K_I(φ) within 3.5 % (measured −3.1 … +0.1 %).
* the penny at 45° closed by compression, frictionless and with Coulomb faces (μ = 0.3):
  K_II, K_III of the effective shear τ − μσ_n within 10 %, |K_I| ≤ 2 % of |σ|√(πa) at
  a/6; slow: β = 30° and 45°, μ = 0 and 0.3 with the default front a/10, |K_I| ≤ 1 %.
* a square crack of side 2a (a = 0.75 mm), front a/6: K_I at the mid-sides between the
  inscribed penny and the tunnel crack (measured 0.727 … 0.737σ√(πa)), the four equal
  within 1.5 % (measured 0.8 %).  Slow: regular 24- and 12-gons (circumradius a, front
  a/25) against the first-order mid-edge K (Rice's front perturbation of the inscribed
  penny: +ln 2/n) within 3.5 % and 2.5 % (measured −2.5 … +1.3 %, −1.6 … −0.8 %).
* bad input: a crack (disc or polygon) larger than the block, crossing its surface,
  reaching into another cell group, a polygon whose edges are too short for the front
  size, exit 2 naming the key; 2 and 3 ranks give the serial K (serial test).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from _crack_scenes import run_dir
from cli_support import run_cli, run_scene
from coupled_support import gmsh_on_rank0, read_csv, run_text

from bonecontact.fracture.front3d import irwin_k
from bonecontact.runners.dispatch import check
from bonecontact.scene import SceneError, load_scene
from bonecontact.verification.planar_crack import polygon_mid_side_k
from bonecontact.verification.problems import crack_block_model, crack_block_scene

A = 1.0e-3  # crack radius, m
W = 4 * A  # half-width of the block
E, NU, SIGMA = 17.0e9, 0.3, 1.0e6
REF = 2 * SIGMA * math.sqrt(A / math.pi)
BETA = math.radians(30.0)


def _block(gmsh, insert: bool = False) -> None:
    """[−W, W]³ (``crack_block_model``; with ``insert``: the slab z > W/2 is "insert")."""
    crack_block_model(W, insert)


def _text(mesh: str, **kw) -> str:
    values = {
        "mesh": mesh,
        "regions": '["block"]',
        "E": E,
        "nu": NU,
        "sigma": SIGMA,
        "h": A / 8,
        "centre": "[0.0, 0.0, 0.0]",
        "normal": "[0.0, 0.0, 1.0]",
        "size": f"radius = {A!r}",
        "points": 8,
    }
    values.update(kw)
    if "geometry" not in values:
        values["geometry"] = "centre = {centre}\nnormal = {normal}\n{size}".format(**values)
    return crack_block_scene(
        values["mesh"],
        values["geometry"],
        E=values["E"],
        nu=values["nu"],
        sigma=values["sigma"],
        h=values["h"],
        regions=values["regions"],
        points=values["points"],
    )


@pytest.fixture(scope="module")
def block_dir(tmp_path_factory) -> Path:
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp("penny3d")) if comm.rank == 0 else None))
    gmsh_on_rank0(_block, d / "block.msh", 3)
    return d


def _run(block_dir: Path, name: str, **kw) -> tuple[dict, dict, Path]:
    d = run_dir(block_dir, name)
    res = run_text(_text(str(block_dir / "block.msh"), **kw), d, d / "out")
    assert res.status == "converged", res.summary.get("message")
    return read_csv(d / "out" / "fracture.csv"), res.summary, d / "out"


@pytest.fixture(scope="module")
def tension(block_dir: Path):
    return _run(block_dir, "tension")


def test_penny_in_tension(tension) -> None:
    tab, summary, out = tension
    assert len(tab["K_I"]) == 8 and np.all(tab["step"] == 1)
    np.testing.assert_allclose(tab["phi_deg"], np.arange(8) * 45.0, atol=1e-9)
    np.testing.assert_allclose(tab["K_I"], REF, rtol=0.03)
    assert np.max(np.abs(tab["K_II"])) < 0.03 * REF
    assert np.max(np.abs(tab["K_III"])) < 0.03 * REF
    np.testing.assert_allclose(tab["G"], tab["K_I"] ** 2 * (1 - NU**2) / E, rtol=0.01)
    ratio = tab["K_I_dc"] / tab["K_I"]  # the cross-check: P1 opens too little
    assert np.all((0.65 < ratio) & (ratio < 1.0)), ratio
    crack = summary["fracture"]["crack"]
    assert crack["max_K_I"] == pytest.approx(np.max(tab["K_I"]), rel=1e-12)
    x, y, z = crack["max_K_I_location"]
    assert math.hypot(x, y) == pytest.approx(A, rel=1e-9) and abs(z) < 1e-12
    assert crack["pair"] == "penny" and crack["semi_axes"] == [A, A]
    if MPI.COMM_WORLD.rank == 0:
        text = (out / "fields_crack_front.vtk").read_text()
        assert "POINTS 8 double" in text and "SCALARS K_III double 1" in text


def test_closed_penny_in_compression(block_dir: Path) -> None:
    tab, summary, out = _run(block_dir, "compression", sigma=-SIGMA, h=A / 6, points=4)
    for key in ("K_I", "K_II", "K_III"):
        assert np.max(np.abs(tab[key])) < 0.03 * REF, (key, tab[key] / REF)
    faces = read_csv(out / "contact_penny.csv")
    assert faces["gap"].size > 50
    assert np.min(faces["gap"]) >= -1e-9 * A  # no interpenetration
    np.testing.assert_allclose(faces["pressure"], SIGMA, rtol=0.01)  # closed: carries σ
    with open(out / "contact_penny.csv") as f:
        status = [line.rsplit(",", 1)[1].strip() for line in f.readlines()[1:]]
    assert set(status) <= {"slip", "stick"}, set(status)  # every node in contact


def _inclined(tab: dict[str, np.ndarray], rtol_shear: float) -> None:
    """K along the front of the penny inclined at β: the crack normal (sin β, 0, cos β);
    its first axis u = y, v = n × u = (−cos β, 0, sin β) is the shear direction, so
    ω = φ − 90°."""
    tau = SIGMA * math.sin(BETA) * math.cos(BETA)
    k2 = 4 * tau * math.sqrt(A / math.pi) / (2 - NU)
    k3 = (1 - NU) * k2
    omega = np.radians(tab["phi_deg"] - 90.0)
    np.testing.assert_allclose(tab["K_I"], REF * math.cos(BETA) ** 2, rtol=0.03)
    np.testing.assert_allclose(tab["K_II"], k2 * np.cos(omega), atol=rtol_shear * k2)
    # mode III's sign follows e3 = e1 × e2: compare magnitudes
    np.testing.assert_allclose(
        np.abs(tab["K_III"]), k3 * np.abs(np.sin(omega)), atol=rtol_shear * k3
    )


def test_inclined_penny(block_dir: Path) -> None:
    normal = f"[{math.sin(BETA)!r}, 0.0, {math.cos(BETA)!r}]"
    tab, _, _ = _run(block_dir, "inclined", normal=normal)
    _inclined(tab, 0.07)


@pytest.mark.slow
def test_inclined_penny_finer(block_dir: Path) -> None:
    normal = f"[{math.sin(BETA)!r}, 0.0, {math.cos(BETA)!r}]"
    tab, _, _ = _run(block_dir, "inclined_fine", normal=normal, h=A / 12)
    _inclined(tab, 0.04)


#: the closed inclined penny: (β, μ, front size); the default front (a/10) is slow, the
#: reduced one (a/6) runs in the default suite
CLOSED_PENNY = [
    (45.0, 0.0, 6),
    (45.0, 0.3, 6),
    *[pytest.param(b, m, 10, marks=pytest.mark.slow) for b in (30.0, 45.0) for m in (0.0, 0.3)],
]


@pytest.mark.parametrize("beta_deg, mu, per_a", CLOSED_PENNY)
def test_closed_inclined_penny(block_dir: Path, beta_deg: float, mu: float, per_a: int) -> None:
    """The penny at β closed by compression, frictionless or Coulomb faces: it slides
    under the effective shear τ − μσ_n (uniform, along the shear: the Kassir–Sih sliding
    is parallel to τ), so K_II, K_III are Kassir–Sih's with τ_eff = σ(sinβcosβ − μcos²β),
    within 10 % of their maxima; K_I = 0: |K_I| ≤ 1 % of |σ|√(πa) with the default front
    (a/10; measured 0.20–0.81 %), ≤ 2 % at a/6 (measured 1.15 %, 0.86 %).  The face
    term takes the recovered contact tractions (the raw multipliers scatter 0.2–0.8 MPa
    for σ_n = 0.5 MPa; with them |K_I| reached 3.4 % (45°, μ = 0) and 2.3 % (45°,
    μ = 0.3) of |σ|√(πa) at a/10)."""
    beta = math.radians(beta_deg)
    normal = f"[{math.sin(beta)!r}, 0.0, {math.cos(beta)!r}]"
    points = "8" + (f"\ncoefficient = {mu!r}" if mu > 0 else "")
    tab, _, out = _run(
        block_dir,
        f"closed{beta_deg:g}_{mu:g}_{per_a}",
        normal=normal,
        sigma=-SIGMA,
        points=points,
        h=A / per_a,
    )
    tau = SIGMA * (math.sin(beta) * math.cos(beta) - mu * math.cos(beta) ** 2)
    k2 = 4 * tau * math.sqrt(A / math.pi) / (2 - NU)
    omega = np.radians(tab["phi_deg"] - 90.0)
    # compression: the upper face slides the other way than in tension
    np.testing.assert_allclose(-tab["K_II"], k2 * np.cos(omega), atol=0.10 * k2)
    k3 = (1 - NU) * k2
    np.testing.assert_allclose(np.abs(tab["K_III"]), k3 * np.abs(np.sin(omega)), atol=0.10 * k3)
    bound = 0.01 if per_a >= 10 else 0.02
    assert np.max(np.abs(tab["K_I"])) <= bound * SIGMA * math.sqrt(math.pi * A)
    faces = read_csv(out / "contact_penny.csv")
    assert np.min(faces["gap"]) >= -1e-9 * A


@pytest.mark.slow
def test_elliptical_crack(block_dir: Path) -> None:
    """An ellipse a = 2b = a_penny normal to the load, front b/12: Irwin's K_I(φ) within
    3.5 % (measured −3.1 … +0.1 %; the largest at the ends of the major axis, where the
    front's radius of curvature b²/a is smallest — the octant model gave −2.3 % there)."""
    size = f'shape = "ellipse"\nsemi_axes = [{A!r}, {A / 2!r}]\naxis = [1.0, 0.0, 0.0]'
    tab, _, _ = _run(block_dir, "ellipse", size=size, h=A / 24)
    ref = irwin_k(SIGMA, A, A / 2, np.radians(tab["phi_deg"]))
    np.testing.assert_allclose(tab["K_I"], ref, rtol=0.035)
    assert np.max(np.abs(tab["K_II"])) < 0.03 * np.max(ref)


def _polygon(vertices: np.ndarray | list) -> str:
    """The geometry keys of a polygonal crack."""
    return f'shape = "polygon"\nvertices = {np.asarray(vertices, dtype=float).tolist()!r}'


def _regular(n: int, radius: float) -> np.ndarray:
    """A regular n-gon in z = 0 with circumradius ``radius``, counter-clockwise about z."""
    t = 2 * math.pi * np.arange(n) / n
    return np.column_stack([radius * np.cos(t), radius * np.sin(t), 0 * t])


AS = 0.75 * A  # half-side of the square crack


def test_square_crack(block_dir: Path) -> None:
    """A square crack of side 2a (a = 0.75 mm: corners 1.06 mm from the centre) normal to
    the load, front a/6, K at the middle of each side (front_points = 1).  References:
    the comparison principle of planar cracks under uniform mode-I load (K at a front
    point grows when the crack grows elsewhere) puts K at the mid-side between the
    inscribed penny (radius a, touching there), 2σ√(a/π) = 0.637σ√(πa), and the tunnel
    crack of width 2a containing the square, σ√(πa) (measured 0.727 … 0.737σ√(πa); at
    a/8 0.740 … 0.751, at a/12 0.746 … 0.752; the block adds about 1.5 %, see the module
    docstring).  Symmetry: the four mid-sides within 1.5 % of their mean (measured
    0.8 %; 0.4 % at a/12); K_II, K_III below 2 % of K_I (measured 0.7 %); the
    displacement-correlation cross-check 65–100 % (measured 71–76 %)."""
    square = [[-AS, -AS, 0.0], [AS, -AS, 0.0], [AS, AS, 0.0], [-AS, AS, 0.0]]
    tab, summary, _ = _run(block_dir, "square", geometry=_polygon(square), h=AS / 6, points=1)
    mids = 0.5 * (np.array(square) + np.roll(square, -1, axis=0))
    np.testing.assert_allclose(np.column_stack([tab["x"], tab["y"], tab["z"]]), mids, atol=1e-12)
    np.testing.assert_allclose(tab["phi_deg"], [45.0, 135.0, 225.0, 315.0], atol=1e-9)
    k = tab["K_I"]
    inscribed, tunnel = 2 * SIGMA * math.sqrt(AS / math.pi), SIGMA * math.sqrt(math.pi * AS)
    assert np.all((inscribed < k) & (k < tunnel)), k / tunnel
    np.testing.assert_allclose(k, np.mean(k), rtol=0.015)
    assert np.max(np.abs(np.concatenate([tab["K_II"], tab["K_III"]]))) < 0.02 * np.min(k)
    np.testing.assert_allclose(tab["G"], k**2 * (1 - NU**2) / E, rtol=0.01)
    ratio = tab["K_I_dc"] / k
    assert np.all((0.65 < ratio) & (ratio < 1.0)), ratio
    crack = summary["fracture"]["crack"]
    assert crack["shape"] == "polygon" and crack["vertices"] == square
    assert crack["length"] <= AS - AS / 6 + 1e-15  # the domain stops a front element short


#: regular n-gons of circumradius a against the first-order mid-side K_I: (n, front size
#: a/per_a, bound per point, bound on the mean); measured below
POLYGONS = [(24, 25, 0.035, 0.01), (12, 25, 0.025, 0.02)]


@pytest.mark.slow
@pytest.mark.parametrize(("n", "per_a", "rtol", "mean_tol"), POLYGONS)
def test_regular_polygon(block_dir: Path, n: int, per_a: int, rtol: float, mean_tol: float):
    """A regular n-gon of circumradius a = 1 mm normal to the load, K at every mid-edge,
    against K_I of Rice's first-order front perturbation of the inscribed penny
    (bonecontact.verification.planar_crack: +ln 2/n, +2.90 % (n = 24), +5.85 % (n = 12);
    the straight sides lack the circle's curvature).  Not the equal-area penny: it lies
    2.75 % (n = 24) and 5.23 % (n = 12) below the mid-edge value (this test's reference
    until 2026-12-02, passed then only through a front integral of the continuous q
    plateau; the front trace of the P1 q that the volume integral uses, 84dc996, raised
    the 24-gon's K by 3.2 %: on every edge the front nodes' trace integrates to 0.969 of
    the continuous plateau).

    24-gon at a/25 (the domain along an edge 2.3 front elements): −2.5 … +1.3 % (mean
    −0.16 %); at a/40 −1.1 … +0.7 % (mean −0.22 %).  12-gon at a/25 (5.5 elements):
    −1.6 … −0.8 % (mean −1.30 %); at a/40 mean −1.66 %: what first order leaves out at
    n = 12 (its second order, a quarter of it at n = 24).  The block adds about as much
    to the penny as the mesh takes (the disc at a/25: −0.5 … +0.3 %, mean −0.05 %).  Its
    fast sibling is :func:`test_square_crack` (the same code path at a/6)."""
    h = A / per_a
    tab, _, _ = _run(block_dir, f"{n}gon", geometry=_polygon(_regular(n, A)), h=h, points=1)
    ref = polygon_mid_side_k(SIGMA, A, n)
    assert len(tab["K_I"]) == n
    np.testing.assert_allclose(tab["K_I"], ref, rtol=rtol)
    assert abs(np.mean(tab["K_I"]) / ref - 1) < mean_tol
    assert np.max(np.abs(tab["K_II"])) < 0.03 * ref


@pytest.mark.parametrize(
    ("kw", "key"),
    [
        ({"size": f"radius = {5 * A!r}"}, "radius"),  # larger than the block
        ({"centre": f"[{W - 0.5 * A!r}, 0.0, 0.0]"}, "radius"),  # crosses the surface
        ({"centre": f"[0.0, 0.0, {W / 2!r}]", "normal": "[1.0, 0.0, 0.0]"}, "region"),
        ({"geometry": _polygon(_regular(5, A) + [W - 0.5 * A, 0.0, 0.0])}, "vertices"),
        (  # upright, reaching into the insert
            {"geometry": _polygon(_regular(6, A)[:, [2, 0, 1]] + [0.0, 0.0, W / 2])},
            "region",
        ),
    ],
)
def test_crack_outside_its_region_is_refused(tmp_shared_path: Path, kw: dict, key: str) -> None:
    gmsh_on_rank0(lambda g: _block(g, insert=True), tmp_shared_path / "two.msh", 3)
    path = tmp_shared_path / "scene.toml"
    regions = '["block", "insert"]'
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(_text(str(tmp_shared_path / "two.msh"), regions=regions, **kw))
    MPI.COMM_WORLD.barrier()
    with pytest.raises(SceneError) as err:
        check(load_scene(path))
    assert err.value.table.startswith("[[crack]]") and err.value.key == key, str(err.value)


def test_polygon_edges_too_short_for_the_front_size(block_dir: Path) -> None:
    """A 24-gon (edges 0.26a) at front size a/12: the domain along an edge (0.13a less a
    front element) spans fewer than 2 elements: exit 2 naming tip_size."""
    path = block_dir / "short_edges.toml"
    if MPI.COMM_WORLD.rank == 0:
        text = _text(str(block_dir / "block.msh"), geometry=_polygon(_regular(24, A)), h=A / 12)
        path.write_text(text)
    MPI.COMM_WORLD.barrier()
    with pytest.raises(SceneError) as err:
        check(load_scene(path))
    assert err.value.table == "[fracture]" and err.value.key == "tip_size", str(err.value)


@pytest.mark.serial
def test_cli_exit_code(tmp_path: Path) -> None:
    """``bonecontact check`` of a bad crack exits 2 naming the key."""
    gmsh_on_rank0(_block, tmp_path / "block.msh", 3)
    bad = tmp_path / "bad.toml"
    bad.write_text(_text("block.msh", normal="[0.0, 0.0, 0.5]"))
    proc = run_cli(["check", str(bad)])
    assert proc.returncode == 2 and 'key "normal"' in proc.stderr, proc.stderr


@pytest.mark.serial
@pytest.mark.slow
def test_cli_same_on_one_two_three_ranks(tmp_path: Path) -> None:
    """``bonecontact run`` on 2 and 3 ranks gives the serial K (the same mesh: gmsh on rank
    0 from the boundary in a canonical order).  Slow: the MPI sessions run this file's
    scene tests on 2 and 3 ranks against the same closed forms."""
    gmsh_on_rank0(_block, tmp_path / "block.msh", 3)
    scene = tmp_path / "scene.toml"
    normal = f"[{math.sin(BETA)!r}, 0.0, {math.cos(BETA)!r}]"
    scene.write_text(_text("block.msh", normal=normal, h=A / 6, points=4))
    tabs = []
    for n in (1, 2, 3):
        proc = run_scene(scene, tmp_path / f"out{n}", n)
        assert proc.returncode == 0, proc.stderr
        tabs.append(read_csv(tmp_path / f"out{n}" / "fracture.csv"))
        summary = json.loads((tmp_path / f"out{n}" / "summary.json").read_text())
        assert summary["status"] == "converged"
    for tab in tabs[1:]:
        for key in ("K_I", "K_II", "K_III", "K_I_dc"):
            np.testing.assert_allclose(tab[key], tabs[0][key], rtol=1e-10, atol=1e-10 * REF)
