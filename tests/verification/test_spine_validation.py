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
study of lytic lesions (Costa et al. 2020, 0.75–0.87).  Neither is within the published
value on this coarse mesh; the asserted bands are the documented looser ones of
docs/validation.md (the reasons are given there), so that a change of the model that moves
the numbers further away fails.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import tomllib
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from scipy.spatial import cKDTree

from bonecontact.neoplasm.host3d import build_host_mesh3d, read_host_geometry3d, sphere_surface
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
    assert 1.2 <= r["pressure"] / (F / disc_area) <= 1.7


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
