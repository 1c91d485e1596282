"""Validation of the lumbar motion segment of demos/spine3d.py against published numbers
(data/validation/spine.toml; docs/validation.md, "Lumbar motion segment").

The segment (data/scenes/spine_segment.msh: the demo's quick mesh, L3–disc–L4 with the
disc split into a nucleus and an annulus) carries 500 N of axial compression on the upper
endplate of L3 (relaxed standing) and is held at the base of L4; a soft tumour (a ball of
radius R in the cancellous core of the L4 body, meshed in by the growth's gmsh rebuild)
or none.  Each configuration asserts: the run is valid as shipped (strain measure ≤ 10 %);
the support reaction balances the load (to 1e-6 of it); the L4 endplate sinks more with a
tumour than without.  Against the published numbers: the nucleus pressure without a
tumour against the in vivo pressure of relaxed standing (Wilke et al. 1999, 0.5 MPa), and
the loss of the L4 body's axial stiffness per unit lesion volume share against the micro-FE
study of lytic lesions (Costa et al. 2020, 0.75–0.87).  Neither is like for like in the
segment, and neither is within the published value; the asserted bands there are the
documented looser ones of docs/validation.md.

Like for like (issue #27): L4 alone between rigid plates, as the micro-FE study loaded its
vertebral body (axial compression, lesions as holes, 4–22 % of the body): the loss is
linear in the lesion's share; with the cortical shell at its measured thickness
(0.29–0.35 mm, two studies) the slope reaches into the published band, with the shipped
2 mm cortex it lies below it (documented).  The nucleus pressure per mean axial stress,
p / (F/A), has no published value we could read; its band is documented, not published.

The cancellous core keeps E = 723 MPa (``[material.cancellous_bone_vertebral]``, apparent
density 0.30 g/cm3; no strength, no risk here); the demo's core is 326 MPa since 2026-12-03
(the density of its strength), with which these runs give other numbers (docs/validation.md,
"Sensitivity to the core's modulus": the plate slopes fall below the published band).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import tomllib
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from scipy.spatial import cKDTree

from bonecontact.neoplasm.host3d import (
    HostGeometry3D,
    build_host_mesh3d,
    read_host_geometry3d,
    sphere_surface,
    write_host_geometry3d,
)
from bonecontact.runners import run_scene
from bonecontact.scene import load_scene

COMM = MPI.COMM_WORLD
ROOT = Path(__file__).resolve().parents[2]
MESH = ROOT / "data" / "scenes" / "spine_segment.msh"
REF = tomllib.loads((ROOT / "data" / "validation" / "spine.toml").read_text())
F = 500.0  # N, relaxed standing
CENTRE = np.array([0.0, 0.016, 0.0])  # the tumour's centre in the L4 body (as the demo)
X_BODY = -0.016  # the back wall of the vertebral bodies
#: documented bands (docs/validation.md): the nucleus pressure over the measured 0.5 MPa,
#: the stiffness loss per unit lesion share over the published 0.75-0.87
PRESSURE_RATIO_BAND = (0.7, 1.6)
LOSS_RATIO_BAND = (0.75, 2.0)

MATERIALS = """
[[material]]
name = "cortical"
regions = ["L3_cortical", "L4_cortical"]
model = "isotropic"
E = 17.0e9
nu = 0.3

[[material]]
name = "cancellous"
regions = ["L3_cancellous", "L4_cancellous"]
model = "isotropic"
E = 723.05e6
nu = 0.25

[[material]]
name = "annulus"
regions = ["annulus"]
model = "isotropic"
E = 4.2e6
nu = 0.45

[[material]]
name = "nucleus"
regions = ["nucleus"]
model = "isotropic"
E = 1.0e6
nu = 0.499
formulation = "nodal_pressure"
"""

TUMOUR = """
[[material]]
name = "tumour"
regions = ["tumour"]
model = "isotropic"
E = 0.5e6
nu = 0.49
formulation = "nodal_pressure"
"""


def shared_dir(tmp_path: Path) -> Path:
    """Rank 0's temporary directory on every rank."""
    return Path(COMM.bcast(str(tmp_path) if COMM.rank == 0 else None, root=0))


def tumour_mesh(radius: float, path: Path) -> Path:
    """The segment with a tumour ball of ``radius`` at CENTRE (the gmsh rebuild of the
    growth; collective); ``MESH`` itself for radius 0."""
    if radius == 0.0:
        return MESH
    geo = read_host_geometry3d(MESH) if COMM.rank == 0 else None
    if COMM.rank == 0:
        tag, tets = geo.cells["L4_cancellous"]
        seed = int(np.argmin(np.linalg.norm(geo.x[tets].mean(axis=1) - CENTRE, axis=1)))
        geo.cells["L4_cancellous"] = (tag, np.delete(tets, seed, axis=0))
        geo.cells["tumour"] = (1 + max(t for t, _ in geo.cells.values()), tets[[seed]])
    h = radius / 3
    ball = sphere_surface(CENTRE, radius, h)
    build_host_mesh3d(geo, "tumour", ("L4_cancellous",), *ball, cavity=False, h_neo=h,
                      path=path, comm=COMM)  # fmt: skip
    COMM.barrier()
    return path


def scene_text(mesh: Path, tumour: bool) -> str:
    """The static standing scene: F spread uniformly over the loaded endplate's bins."""
    g = read_host_geometry3d(mesh) if COMM.rank == 0 else None
    bins = COMM.bcast(sorted(k for k in g.facets if k.startswith("L3_top_")) if g else None)
    area = COMM.bcast(sum(_areas(g, [k]).sum() for k in bins) if g else None)
    trac = "".join(
        f'\n[[traction]]\nboundary = "{k}"\nvalue = [0.0, {-F / area:.9e}, 0.0]\n' for k in bins
    )
    head = f'format = 1\n[scene]\nname = "spine_segment"\nmesh = "{mesh}"\ndimension = 3\n'
    head += '[analysis]\nkind = "static"\nload_steps = 1\n'
    bc = '\n[[dirichlet]]\nboundary = "L4_base"\nvalue = [0.0, 0.0, 0.0]\n'
    return head + MATERIALS + (TUMOUR if tumour else "") + bc + trac


def _areas(g, groups: list[str]) -> np.ndarray:
    tri = np.concatenate([g.facets[k][1] for k in groups])
    p = g.x[tri]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def measures(directory: Path, mesh: Path) -> dict[str, float]:
    """Rank 0: the L4 endplate's subsidence (area mean of -u_y), the nucleus pressure
    (volume mean of -tr σ/3), the lesion's share of the L4 body's volume."""
    from bonecontact.plot import read_fields

    grid = read_fields(directory / "fields.pvd")
    g = read_host_geometry3d(mesh)
    _, idx = cKDTree(np.asarray(grid.points)).query(g.x)
    uy = np.asarray(grid.point_data["displacement"])[idx, 1]
    tri = g.facets["L4_endplate"][1]
    a = _areas(g, ["L4_endplate"])
    p = g.x[g.cells["nucleus"][1]]
    vol = np.abs(np.linalg.det(p[:, 1:] - p[:, :1])) / 6
    _, ci = cKDTree(np.asarray(grid.cell_centers().points)).query(p.mean(axis=1))
    sig = np.asarray(grid.cell_data["stress"]).reshape(-1, 3, 3)[ci]
    body = {}
    for k in ("L4_cortical", "L4_cancellous", "tumour"):
        q = g.x[g.cells[k][1]] if k in g.cells else np.zeros((0, 4, 3))
        front = q.mean(axis=1)[:, 0] >= X_BODY
        body[k] = float(np.abs(np.linalg.det(q[front, 1:] - q[front, :1])).sum() / 6)
    return {
        "subsidence": float(-(a * uy[tri].mean(axis=1)).sum() / a.sum()),
        "pressure": float(-(vol * np.trace(sig, axis1=1, axis2=2) / 3).sum() / vol.sum()),
        "lesion_share": body["tumour"] / sum(body.values()),
    }


_RUNS: dict[float, dict] = {}


def standing_run(radius: float, tmp_path: Path) -> dict:
    """The standing scene with a tumour of ``radius`` (0: none), run once per session."""
    if radius not in _RUNS:
        d = shared_dir(tmp_path)
        mesh = tumour_mesh(radius, d / "segment.msh")
        if COMM.rank == 0:
            (d / "scene.toml").write_text(scene_text(mesh, radius > 0))
        else:
            scene_text(mesh, radius > 0)
        COMM.barrier()
        res = run_scene(load_scene(d / "scene.toml"), COMM, output=d, progress=False)
        out = {"status": res.status, "summary": res.summary}
        out |= COMM.bcast(measures(d, mesh) if COMM.rank == 0 else None, root=0)
        hist = np.genfromtxt(d / "history.csv", delimiter=",", names=True)
        out["reaction"] = [float(np.atleast_1d(hist[f"reaction_L4_base_{c}"])[-1]) for c in "xyz"]
        _RUNS[radius] = out
    return _RUNS[radius]


@pytest.mark.parametrize(
    "radius",
    [0.0, 9.0e-3, pytest.param(6.5e-3, marks=pytest.mark.slow)],
    ids=["none", "R9", "R6.5"],
)
def test_standing_segment_valid_and_balanced(radius, tmp_path):
    """Valid as shipped (strain measure ≤ 10 %, status converged) and the support
    reaction equal to the applied 500 N (to 1e-6 of it), with and without a tumour."""
    r = standing_run(radius, tmp_path)
    assert r["status"] == "converged", r["summary"].get("message")
    assert r["summary"]["small_strain_valid"] and r["summary"]["strain_measure"] <= 0.10
    np.testing.assert_allclose(r["reaction"], [0.0, F, 0.0], atol=1e-6 * F)


def test_intradiscal_pressure_against_wilke_1999(tmp_path):
    """The nucleus pressure of the segment without a tumour over the in vivo 0.5 MPa of
    relaxed standing, within the documented band (0.7–1.6; 1.41 on this mesh); and the
    pressure 1.2–1.7 times the mean axial stress F/A of the disc (1.49 here: a confined,
    nearly incompressible nucleus carries more than the average)."""
    r = standing_run(0.0, tmp_path)
    ratio = r["pressure"] / REF["intradiscal_pressure"]["value"]
    assert PRESSURE_RATIO_BAND[0] <= ratio <= PRESSURE_RATIO_BAND[1], ratio
    g = read_host_geometry3d(MESH) if COMM.rank == 0 else None
    disc_area = COMM.bcast(_areas(g, ["L4_endplate"]).sum() if g else None)
    band = REF["intradiscal_pressure_per_stress"]
    assert band["band_min"] <= r["pressure"] / (F / disc_area) <= band["band_max"]


def test_tumour_stiffness_loss_against_costa_2020(tmp_path):
    """The L4 body's stiffness F/s without and with a 9 mm tumour (about 12 % of the body,
    inside the published 4–35 %): it falls, and the loss per unit lesion share lies in the
    documented band (0.75–2.0 around the published 0.75–0.87; 1.41 on this mesh, 1.39
    with a 6.5 mm tumour; see docs/validation.md)."""
    r0, r9 = standing_run(0.0, tmp_path), standing_run(9.0e-3, tmp_path)
    loss = 1.0 - r0["subsidence"] / r9["subsidence"]
    share = r9["lesion_share"]
    lo, hi = REF["lytic_lesion_stiffness_loss"]["lesion_fraction_min"], 0.35
    assert lo <= share <= hi and loss > 0
    assert LOSS_RATIO_BAND[0] <= loss / share <= LOSS_RATIO_BAND[1], (loss, share)


# ---------------------------------------------------------------- L4 alone between rigid plates
# The protocol of the micro-FE study of lytic lesions (Costa et al. 2020) as far as we could
# read it (data/validation/spine.toml, [lytic_lesion_stiffness_loss]): the vertebral body
# alone in axial compression, the lesions holes in the bone, several sizes.  Here: the L4 of
# the segment's mesh without L3 and the disc, its lower endplate held (u = 0), its upper
# endplate moved down by DELTA as a whole (both endplates bonded to rigid plates); the
# stiffness is the reaction of the lower plate over DELTA; a lesion is an ellipsoidal hole in
# the cancellous core; the loss is 1 - K_lesion / K_intact with the intact stiffness computed
# on the same mesh (the lesion's cells given the cancellous bone's modulus), so that the
# remeshing around the lesion does not enter the loss.
DELTA = 5.0e-5  # m: 0.2 % of the body's height (24.7 mm)
#: the cancellous core's centre and its half-extents along x, y, z through it (m; read off
#: the quick mesh's core surface: x -14.2..10.2 mm, y 3.5..25.8 mm, z -15.5..15.5 mm)
CORE_CENTRE = np.array([-2.0, 14.6, 0.0]) * 1e-3
CORE_AXES = np.array([11.5, 10.5, 14.5]) * 1e-3
#: the lesions: ellipsoids of these fractions of the core's half-extents (4.3, 10.8, 21 % of
#: the body), inside the published 4-35 % (0.9: about the largest that stays in the core)
LESION_SCALES = (0.53, 0.72, 0.9)
CORTEX = 2.0e-3  # m: the meshed cortical layer of demos/spine3d.py
E_CORTICAL, E_CANCELLOUS = 17.0e9, 723.05e6
SHELL = REF["cortical_shell"]


def layer_modulus(thickness: float) -> float:
    """The axial (parallel, Voigt) modulus of the 2 mm layer when only ``thickness`` of it
    is cortical bone and the rest cancellous bone."""
    return (E_CORTICAL * thickness + E_CANCELLOUS * (CORTEX - thickness)) / CORTEX


#: the cortical layer's modulus: as shipped (2 mm of cortical bone), and with the measured
#: shell thicknesses (the thinnest and thickest of the two studies read)
SHELLS = {
    "shipped": E_CORTICAL,
    "measured_thin": layer_modulus(SHELL["thickness_min"]),
    "measured_thick": layer_modulus(SHELL["thickness_max"]),
}


def l4_alone() -> HostGeometry3D:
    """Rank 0: L4's cells and its two endplates from the segment's mesh, nodes renumbered."""
    g = read_host_geometry3d(MESH)
    cells = {k: v for k, v in g.cells.items() if k.startswith("L4_")}
    facets = {k: v for k, v in g.facets.items() if k in ("L4_endplate", "L4_base")}
    used = np.unique(np.concatenate([t.ravel() for _, t in cells.values()]))
    new = np.full(len(g.x), -1)
    new[used] = np.arange(len(used))
    return HostGeometry3D(
        g.x[used],
        {k: (t, new[c]) for k, (t, c) in cells.items()},
        {k: (t, new[c]) for k, (t, c) in facets.items()},
    )


def body_volume(g: HostGeometry3D) -> float:
    """The vertebral body's volume: L4's bone in front of its back wall."""
    out = 0.0
    for k in ("L4_cortical", "L4_cancellous"):
        q = g.x[g.cells[k][1]]
        front = q.mean(axis=1)[:, 0] >= X_BODY
        out += float(np.abs(np.linalg.det(q[front, 1:] - q[front, :1])).sum() / 6)
    return out


def refine_uniform(g: HostGeometry3D) -> HostGeometry3D:
    """Each tetrahedron split into eight and each facet triangle into four at the edges'
    midpoints (the geometry is unchanged); children oriented as their parent."""
    tets = np.concatenate([t for _, t in g.cells.values()])
    e = np.sort(tets[:, [0, 1, 0, 2, 0, 3, 1, 2, 1, 3, 2, 3]].reshape(-1, 2), axis=1)
    edges = np.unique(e, axis=0)
    x = np.vstack([g.x, 0.5 * (g.x[edges[:, 0]] + g.x[edges[:, 1]])])
    key = edges[:, 0] * len(g.x) + edges[:, 1]

    def mid(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        k = np.minimum(a, b) * len(g.x) + np.maximum(a, b)
        return len(g.x) + np.searchsorted(key, k)

    cells = {}
    for name, (tag, t) in g.cells.items():
        a, b, c, d = t.T
        ab, ac, ad, bc, bd, cd = mid(a, b), mid(a, c), mid(a, d), mid(b, c), mid(b, d), mid(c, d)
        kids = np.concatenate([np.stack(k, axis=1) for k in (
            (a, ab, ac, ad), (ab, b, bc, bd), (ac, bc, c, cd), (ad, bd, cd, d),
            (ab, ac, ad, bd), (ab, ac, bc, bd), (ac, ad, bd, cd), (ac, bc, bd, cd))])  # fmt: skip
        sign = np.sign(_signed_volumes(g.x, np.tile(t, (8, 1))))
        flip = np.sign(_signed_volumes(x, kids)) != sign
        kids[flip] = kids[flip][:, [0, 1, 3, 2]]
        cells[name] = (tag, kids)
    facets = {}
    for name, (tag, t) in g.facets.items():
        a, b, c = t.T
        ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
        kids = ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))
        facets[name] = (tag, np.concatenate([np.stack(k, axis=1) for k in kids]))
    return HostGeometry3D(x, cells, facets)


def _signed_volumes(x: np.ndarray, tets: np.ndarray) -> np.ndarray:
    p = x[tets]
    return np.einsum("ij,ij->i", p[:, 1] - p[:, 0], np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]))


def lesion_mesh(scale: float, cavity: bool, level: int, path: Path) -> float:
    """L4 with an ellipsoid of ``scale`` times the core's half-extents as a hole
    (``cavity``) or as a cell group ``lesion`` (the intact reference on the same mesh),
    refined ``level`` times; written to ``path``; returns the ellipsoid's volume.
    Collective."""
    g = l4_alone() if COMM.rank == 0 else None
    if COMM.rank == 0:
        tag, tets = g.cells["L4_cancellous"]
        seed = int(np.argmin(np.linalg.norm(g.x[tets].mean(axis=1) - CORE_CENTRE, axis=1)))
        g.cells["L4_cancellous"] = (tag, np.delete(tets, seed, axis=0))
        g.cells["lesion"] = (1 + max(t for t, _ in g.cells.values()), tets[[seed]])
    r = scale * CORE_AXES.min()
    p, t = sphere_surface(CORE_CENTRE, r, r / 3)
    p = CORE_CENTRE + (np.asarray(p) - CORE_CENTRE) * CORE_AXES / CORE_AXES.min()
    coarse = path.with_suffix(".coarse.msh")
    hm = build_host_mesh3d(g, "lesion", ("L4_cancellous",), p, t, cavity, r / 3, coarse, COMM)
    if COMM.rank == 0:
        h = read_host_geometry3d(coarse)
        for _ in range(level):
            h = refine_uniform(h)
        write_host_geometry3d(h, path)
    COMM.barrier()
    return hm.neoplasm_area


def plates_scene(mesh: Path, e_cortex: float, lesion_is_bone: bool) -> str:
    """The static scene: L4_base held, L4_endplate moved down by DELTA."""
    can = '["L4_cancellous", "lesion"]' if lesion_is_bone else '["L4_cancellous"]'
    return f"""format = 1
[scene]
name = "l4_between_plates"
mesh = "{mesh}"
dimension = 3
[analysis]
kind = "static"
load_steps = 1

[[material]]
name = "cortical"
regions = ["L4_cortical"]
model = "isotropic"
E = {e_cortex:.9e}
nu = 0.3

[[material]]
name = "cancellous"
regions = {can}
model = "isotropic"
E = {E_CANCELLOUS:.9e}
nu = 0.25

[[dirichlet]]
boundary = "L4_base"
value = [0.0, 0.0, 0.0]

[[dirichlet]]
boundary = "L4_endplate"
value = [0.0, {-DELTA:.9e}, 0.0]
"""


def plates_run(mesh: Path, e_cortex: float, lesion_is_bone: bool, d: Path) -> dict:
    """One run between the plates: status, strain measure, the plates' reactions (N)."""
    if COMM.rank == 0:
        d.mkdir(parents=True, exist_ok=True)
        (d / "scene.toml").write_text(plates_scene(mesh, e_cortex, lesion_is_bone))
    COMM.barrier()
    res = run_scene(load_scene(d / "scene.toml"), COMM, output=d, progress=False)
    hist = np.genfromtxt(d / "history.csv", delimiter=",", names=True)
    react = {
        b: np.array([float(np.atleast_1d(hist[f"reaction_{b}_{c}"])[-1]) for c in "xyz"])
        for b in ("L4_base", "L4_endplate")
    }
    return {"status": res.status, "summary": res.summary, **react}


_MESHES: dict[int, list[tuple[float, Path, Path]]] = {}
_PLATES: dict[tuple[str, int], dict] = {}


def plates_meshes(level: int, tmp_path: Path) -> list[tuple[float, Path, Path]]:
    """Per lesion size: its share of the body's volume, the filled and the holed mesh."""
    if level not in _MESHES:
        d = shared_dir(tmp_path)
        volume = COMM.bcast(body_volume(l4_alone()) if COMM.rank == 0 else None, root=0)
        out = []
        for i, s in enumerate(LESION_SCALES):
            filled, holed = d / f"l{level}_filled_{i}.msh", d / f"l{level}_holed_{i}.msh"
            lesion_mesh(s, False, level, filled)
            out.append((lesion_mesh(s, True, level, holed) / volume, filled, holed))
        _MESHES[level] = out
    return _MESHES[level]


def plates_series(shell: str, level: int, tmp_path: Path) -> dict:
    """The shares, losses and every run of the lesion sizes with the cortical layer
    ``shell``, on meshes refined ``level`` times (run once per session)."""
    if (shell, level) not in _PLATES:
        d = shared_dir(tmp_path)
        shares, losses, runs = [], [], []
        for i, (share, filled, holed) in enumerate(plates_meshes(level, tmp_path)):
            r0 = plates_run(filled, SHELLS[shell], True, d / f"{shell}_{level}_{i}_intact")
            r1 = plates_run(holed, SHELLS[shell], False, d / f"{shell}_{level}_{i}_lesion")
            shares.append(share)
            losses.append(1.0 - r1["L4_base"][1] / r0["L4_base"][1])
            runs += [r0, r1]
        _PLATES[(shell, level)] = {"shares": np.array(shares), "losses": np.array(losses),
                                   "runs": runs}  # fmt: skip
    return _PLATES[(shell, level)]


def linear_fit(shares: np.ndarray, losses: np.ndarray) -> tuple[float, float]:
    """Slope of the least-squares line of loss against share, and its R²."""
    slope, icpt = np.polyfit(shares, losses, 1)
    res = losses - (slope * shares + icpt)
    return float(slope), float(1.0 - (res**2).sum() / ((losses - losses.mean()) ** 2).sum())


@pytest.mark.parametrize("shell", ["shipped", "measured_thick"])
def test_l4_between_plates_valid_and_balanced(shell, tmp_path):
    """Every run between the plates converges and is valid as shipped (strain measure ≤
    10 %); the two plates' reactions balance (to 1e-6 of the axial force); the body
    compresses (axial reaction > 0 at the base); each hole lowers the stiffness, a larger
    hole more."""
    series = plates_series(shell, 0, tmp_path)
    for r in series["runs"]:
        assert r["status"] == "converged", r["summary"].get("message")
        assert r["summary"]["small_strain_valid"] and r["summary"]["strain_measure"] <= 0.10
        force = r["L4_base"][1]
        assert force > 0
        np.testing.assert_allclose(r["L4_base"] + r["L4_endplate"], 0.0, atol=1e-6 * force)
    assert np.all(series["losses"] > 0) and np.all(np.diff(series["losses"]) > 0)


def _fitted(shell: str, level: int, tmp_path: Path) -> float:
    """The slope of the loss against the share (asserting the shares inside the published
    range and the relation linear); returns the slope."""
    ref = REF["lytic_lesion_stiffness_loss"]
    series = plates_series(shell, level, tmp_path)
    shares, losses = series["shares"], series["losses"]
    assert ref["lesion_fraction_min"] <= shares.min() and shares.max() <= ref["lesion_fraction_max"]
    slope, r2 = linear_fit(shares, losses)
    assert r2 >= ref["linearity_r2_min"], (shell, shares, losses)
    return slope


def _check_measured_shell(level: int, tmp_path: Path) -> None:
    ref = REF["lytic_lesion_stiffness_loss"]
    thin, thick = (
        _fitted("measured_thin", level, tmp_path),
        _fitted("measured_thick", level, tmp_path),
    )
    assert thick < thin  # a thinner shell leaves more of the load to the core
    assert thick <= ref["ratio_max"] and thin >= ref["ratio_min"], (thin, thick)


def test_l4_stiffness_loss_between_plates_against_costa_2020(tmp_path):
    """Costa et al. 2020's protocol as read (L4 alone in axial compression between rigid
    plates, lesions as holes, 4-22 % of the body): the loss of stiffness is linear in the
    lesion's share (R² ≥ the recorded bound), and with the cortical shell at its measured
    thickness (0.29-0.35 mm, as the axially equivalent modulus of the meshed 2 mm layer) the
    model's slopes (0.29 mm: the larger) reach into the published 0.75-0.87: the thicker
    shell's slope at most its top, the thinner shell's at least its bottom."""
    _check_measured_shell(0, tmp_path)


def test_l4_stiffness_loss_between_plates_shipped_shell(tmp_path):
    """With the shipped 2 mm cortex (17 GPa) the loss is linear too but its slope lies
    below the published band (the shell carries most of the load): within the documented
    band (its floor not published) up to the published top."""
    slope = _fitted("shipped", 0, tmp_path)
    lo = REF["lytic_lesion_plates_shipped"]["slope_band_min"]
    assert lo <= slope <= REF["lytic_lesion_stiffness_loss"]["ratio_max"], slope


@pytest.mark.slow
def test_l4_stiffness_loss_between_plates_refined(tmp_path):
    """The measured-shell comparison on the meshes refined once (each tetrahedron split
    into eight)."""
    _check_measured_shell(1, tmp_path)
