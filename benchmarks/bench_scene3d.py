"""3D coupled scenes: the time of each phase against the mesh size, and the accuracy of
the 3D coupling where a closed form exists.

Scenes (each at 2-3 mesh sizes, built with the library functions the demos use):

* ``jaw_block``: ``data/scenes/jaw_cyst3d.toml`` (a cyst growing in a 30 x 16 x 16 mm
  block of cancellous bone under a bite pressure), its mesh rebuilt by
  ``data/scenes/make_meshes.py`` ``block_with_cyst`` at the size ``h_in`` at the cyst
  (``h_out`` away from it); one year of growth in monthly steps, analyses every 6 steps.
* ``mandible``: the cyst in the scanned mandible of ``demos/jaw3d.py``: the surface
  meshed into a 2 mm cortical shell around a cancellous core (``bone_from_surface``,
  largest tetrahedron ``h``; the scan's own 4 mm triangles are kept, as in the demo:
  they and the cortex, not ``h``, set most of the cells), the 2 mm cyst ball put in by
  ``build_host_mesh3d``;
  condyles held, 300 N bite on the teeth facets; one year, analyses every 6 months.
* ``vertebra``: a tumour growing in the L4 vertebra of ``demos/spine3d.py`` (the demo's
  L3-disc-L4 segment builders are script code, not importable: here the L4 vertebra
  alone, ``bone_from_surface`` with a 2 mm cortex, its surface remeshed to ``h`` (the
  scan's triangles are 7 mm), held at its base, 0.35 MPa on its
  upper endplate; the demo's tumour model, 2-day steps remeshed every step, analyses
  every 3 steps).

For each: the wall time of the meshing (``mesh_s``: surface to tetrahedra; ``embed_s``:
the neoplasm ball put into the mesh by gmsh) from this script's timers, then the coupled
run's phases from its ``summary.json`` ``coupling.phases_s`` (``setup``, ``check``: the
host mesh at t = 0 and the model on it, ``growth_steps``, ``host_rebuild``,
``analyses``), the split of ``analyses`` summed over every analysis's own
``summary.json`` ``phases_s`` (``mech_model``: spaces and forms, ``mech_setup``: solver
set-up, ``mech_solve``: the load steps, ``mech_output``: fields and tables,
``mech_other``: mesh read and the rest), the cells and dofs of the last analysis and the
peak resident memory of a rank (``ru_maxrss``: the process's peak so far; the sizes run
from small to large, so with one case per process, as ``run_all.sh`` runs them, it is the
peak of that row's size).

* ``knee``: the knee of ``demos/knee3d.py`` as it was until 2026-12-02
  (``bonecontact.meshing.joint``: the unsmoothed femur posed on the tibia, both cut 40 mm
  from the joint, 2 mm cortex and uniform 2 mm cartilage layers in Coulomb contact; the
  demo now ships a valid knee with a lowered tibial layer), 700 N on the femur, a tumour
  in the proximal tibia; 8 days in 4-day steps, an analysis at each.  Accuracy: the
  contact force of the last analysis on the femur and on the tibia against the body
  weight (``force_err_femur``, ``force_err_tibia``: F/W - 1 from the internal forces K u
  of the cartilage surfaces).

Accuracy (``lame``): the cyst cavity of ``tests/unit/runners/test_coupled3d.py``, a cyst
grown for one year at the centre of a ball of radius 20 mm clamped at its surface, mesh
size ``h_in`` at the 2 mm core (so on the wall); the radial displacement of the wall
vertices against Lamé's thick sphere: mean and largest |u_r / u_Lamé - 1|, next to the
phases.

Usage:  python benchmarks/bench_scene3d.py [--quick] [--cases jaw_block,mandible,...,knee]
        (appends to benchmarks/results/scene3d.csv)
"""

import dolfinx_solver  # noqa: F401

import argparse
import importlib.util
import json
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path

from mpi4py import MPI

import gmsh
import numpy as np
from common import write_rows  # (benchmarks/ is the script directory)
from dolfinx import fem

from bonecontact.common.constants import SECONDS_PER_YEAR
from bonecontact.meshing import SurfaceRegion, anatomy_surface, bone_from_surface
from bonecontact.meshing.joint import (
    Cartilage,
    JointBone,
    clip_surface,
    joint_from_surfaces,
    pose_on,
)
from bonecontact.meshing.session import gmsh_session
from bonecontact.neoplasm.host3d import build_host_mesh3d, read_host_geometry3d, sphere_surface
from bonecontact.runners import RunResult, run_scene
from bonecontact.scene import load_scene

warnings.filterwarnings("ignore", message="IProgress not found")
ROOT = Path(__file__).resolve().parents[1]
COMM = MPI.COMM_WORLD
MM, YEAR, DAY = 1e-3, SECONDS_PER_YEAR, 86400.0
E_BONE, NU_BONE, B_BALL, R0_CYST = 1.0e9, 0.3, 0.02, 0.002

#: mesh sizes of each case (quick: the first two), smallest mesh first
SIZES = {
    "jaw_block": [(1.0e-3, 4.0e-3), (5.0e-4, 2.5e-3), (3.0e-4, 1.5e-3)],  # (h_in, h_out)
    "mandible": [(8.0e-3,), (3.0e-3,), (2.0e-3,)],  # (h,)
    "vertebra": [(5.0e-3,), (3.5e-3,), (2.5e-3,)],  # (h,)
    "lame": [(8.0e-4, 4.0e-3), (4.0e-4, 4.0e-3), (2.5e-4, 4.0e-3)],  # (h_in, h_out)
    "knee": [(5.0e-3,), (4.5e-3,), (4.0e-3,)],  # (h,): 3.5 mm: gmsh refuses the tibia; 6 mm:
    # the Coulomb active set cycles
}
W_KNEE = 700.0  # N, body weight on the knee

#: the mechanics phases reported on their own (the rest: mech_other)
MECH = {
    "model": "mech_model",
    "solver_setup": "mech_setup",
    "time_stepping": "mech_solve",
    "output": "mech_output",
}
COUPLING = ("setup", "check", "growth_steps", "host_rebuild", "analyses")


def timed(fn: Callable, *args, **kwargs) -> tuple[object, float]:
    """``fn(*args, **kwargs)`` and its wall time (slowest rank; collective)."""
    COMM.barrier()
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, COMM.allreduce(time.perf_counter() - t0, op=MPI.MAX)


def on_rank0(fn: Callable, *args) -> None:
    """``fn(*args)`` on rank 0 only; every rank waits."""
    if COMM.rank == 0:
        fn(*args)
    COMM.barrier()


def run_text(text: str, work: Path) -> RunResult:
    """Write ``text`` to ``work/scene.toml`` and run it into ``work/out`` (in-process)."""
    if COMM.rank == 0:
        (work / "scene.toml").write_text(text)
    COMM.barrier()
    return run_scene(load_scene(work / "scene.toml"), COMM, output=work / "out", progress=False)


def embed_ball(bone_msh: Path, out_msh: Path, region: str, host: str, centre, r0, h_ball):
    """The neoplasm cell group ``region`` (a ball) put into the cell group ``host`` of
    ``bone_msh`` by the coupling's gmsh rebuild (as the 3D demos do)."""
    geo = read_host_geometry3d(bone_msh) if COMM.rank == 0 else None
    if COMM.rank == 0:
        tag, tets = geo.cells[host]
        c = int(np.argmin(np.linalg.norm(geo.x[tets].mean(axis=1) - centre, axis=1)))
        geo.cells[host] = (tag, np.delete(tets, c, axis=0))
        geo.cells[region] = (1 + max(t for t, _ in geo.cells.values()), tets[[c]])
    ball = sphere_surface(centre, r0, h_ball)
    build_host_mesh3d(
        geo, region, (host,), *ball, cavity=False, h_neo=h_ball, path=out_msh, comm=COMM
    )


def facet_area(msh: Path, group: str) -> float:
    """Area of a facet group of a gmsh file (collective; read on rank 0)."""
    a = None
    if COMM.rank == 0:
        g = read_host_geometry3d(msh)
        t = g.x[g.facets[group][1]]
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        a = float(0.5 * np.linalg.norm(n, axis=1).sum())
    return COMM.bcast(a, root=0)


# ----------------------------------------------------------------------------- scenes
def jaw_block(work: Path, size: tuple) -> tuple[str, dict]:
    """The shipped jaw_cyst3d scene on a block mesh of the given sizes."""
    src = ROOT / "data" / "scenes" / "make_meshes.py"
    spec = importlib.util.spec_from_file_location("make_meshes", src)
    mm = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mm)
    msh = work / "block.msh"
    _, t_mesh = timed(on_rank0, mm.block_with_cyst, msh, *size)
    text = (ROOT / "data/scenes/jaw_cyst3d.toml").read_text()
    text = text.replace('mesh = "jaw_cyst3d.msh"', f'mesh = "{msh}"')
    text = text.replace("t_end = 6.31152e7", f"t_end = {YEAR:.9e}")
    text = text.replace("mechanics_every = 12", "mechanics_every = 6")
    return text, {"mesh_s": t_mesh, "embed_s": 0.0}


def mandible(work: Path, size: tuple) -> tuple[str, dict]:
    """demos/jaw3d.py's jaw and cyst (one year, analyses every 6 months)."""
    centre, r0 = np.array([45.0, -13.0, 30.0]) * MM, 2.0 * MM
    regions = [
        SurfaceRegion("condyles", box=((0.0, 0.025, -0.06), (0.05, 0.05, 0.06))),
        SurfaceRegion(
            "teeth", cone=((0.0, 1.0, 0.0), 45.0), box=((0.03, -0.01, -0.05), (0.09, 0.01, 0.05))
        ),
    ]
    bone, jaw = work / "bone.msh", work / "jaw.msh"
    _, t_mesh = timed(
        bone_from_surface,
        anatomy_surface("mandible"),
        h=size[0],
        cortical_thickness=2 * MM,
        name="mandible",
        regions=regions,
        remesh=False,
        path=bone,
        comm=COMM,
    )
    _, t_embed = timed(embed_ball, bone, jaw, "cyst", "mandible_cancellous", centre, r0, r0 / 8)
    t_bite = 300.0 / facet_area(jaw, "teeth")
    text = f"""format = 1
[scene]
name = "mandible"
mesh = "{jaw}"
dimension = 3
[analysis]
kind = "static"
load_steps = 1
[[material]]
name = "cortical"
regions = ["mandible_cortical"]
model = "isotropic"
E = 15.0e9
nu = 0.3
[[material]]
name = "cancellous"
regions = ["mandible_cancellous"]
model = "isotropic"
E = 1.0e9
nu = 0.3
[[dirichlet]]
boundary = "condyles"
value = [0.0, 0.0, 0.0]
[[traction]]
boundary = "teeth"
value = [0.0, {-t_bite:.9e}, 0.0]
[neoplasm]
kind = "cyst"
region = "cyst"
host = ["mandible_cancellous"]
t_end = {YEAR:.9e}
dt = {YEAR / 12:.9e}
mechanics_every = 6
[neoplasm.cyst]
model = "sphere"
beta = 3.2e-11
C_minus = 1.0
[output]
directory = "results"
fields_every = 1
"""
    return text, {"mesh_s": t_mesh, "embed_s": t_embed}


def vertebra(work: Path, size: tuple) -> tuple[str, dict]:
    """A tumour growing in the L4 vertebra of demos/spine3d.py (6 days in 2-day steps)."""
    centre, r0 = np.array([0.0, 16.0, 0.0]) * MM, 3.0 * MM
    x0, x1 = -14 * MM, 20 * MM  # the vertebral body, as the demo's endplate groups
    regions = [
        SurfaceRegion(
            "L4_top", cone=((0, 1, 0), 30.0), box=((x0, 0.024, -0.04), (x1, 0.032, 0.04))
        ),
        SurfaceRegion(
            "L4_base", cone=((0, -1, 0), 30.0), box=((x0, -0.005, -0.04), (x1, 0.006, 0.04))
        ),
    ]
    bone, l4 = work / "bone.msh", work / "l4.msh"
    _, t_mesh = timed(
        bone_from_surface,
        anatomy_surface("L4"),
        h=size[0],
        cortical_thickness=2 * MM,
        name="L4",
        regions=regions,
        remesh=True,  # the scan's 7 mm triangles remeshed to h
        path=bone,
        comm=COMM,
    )
    _, t_embed = timed(embed_ball, bone, l4, "tumour", "L4_cancellous", centre, r0, r0 / 3)
    return vertebra_text(l4, "vertebra", 6, 2, 3), {"mesh_s": t_mesh, "embed_s": t_embed}


def vertebra_text(msh: Path, name: str, days: int, dt: int, every: int) -> str:
    """The vertebra's coupled scene (L4 groups) on ``msh``: ``days`` of growth in steps of
    ``dt`` days, an analysis every ``every`` steps."""
    return f"""format = 1
[scene]
name = "{name}"
mesh = "{msh}"
dimension = 3
[analysis]
kind = "static"
load_steps = 1
[[material]]
name = "cortical"
regions = ["L4_cortical"]
model = "isotropic"
E = 17.0e9
nu = 0.3
[[material]]
name = "cancellous"
regions = ["L4_cancellous"]
model = "isotropic"
E = 723.0e6
nu = 0.25
[[material]]
name = "tumour"
regions = ["tumour"]
model = "isotropic"
E = 0.5e6
nu = 0.49
formulation = "nodal_pressure"
[[dirichlet]]
boundary = "L4_base"
value = [0.0, 0.0, 0.0]
[[pressure]]
boundary = "L4_top"
value = 0.35e6
[neoplasm]
kind = "tumour"
region = "tumour"
host = ["L4_cancellous"]
t_end = {days * DAY:.9e}
dt = {dt * DAY:.9e}
remesh_every = 1
mechanics_every = {every}
[neoplasm.tumour]
D_c = 1.0e-9
lambda = 1.0e-5
eps0 = 0.0
u_c1 = 1.0
K_B = "{1 / (5 * DAY):.8e}*(u_c - 0.5)"
K_Q = 0.0
K_A = 0.0
K_P = 0.0
K_D = 0.0
K_R = 0.0
gamma = 0.0
u_p0 = 1.0
u_q0 = 0.0
[output]
directory = "results"
fields_every = 1
"""


def knee(work: Path, size: tuple) -> tuple[str, dict]:
    """demos/knee3d.py's former knee: the shipped femur posed on the tibia (``pose_on``, 4.5 mm
    for two 2 mm cartilage layers), both cut 40 mm from the joint, 2 mm cortex, the
    demo's cartilage facet rules, Coulomb pair (mu 0.1, femur slave), 700 N on the
    femur's cut (guided u_x = u_z = 0), tibia held at its cut; the 3 mm tumour 16 mm below
    the plateau; 8 days in 4-day steps, an analysis at each (as the quick demo)."""
    h, big, mm2 = size[0], 1.0, 2 * MM
    posed, pose = pose_on(anatomy_surface("femur"), anatomy_surface("tibia"), 4.5 * MM)
    y0 = float(pose.points[:, 1].mean())
    femur = clip_surface(posed, (0.0, y0 + 40 * MM, 0.0), (0.0, 1.0, 0.0))
    tibia = clip_surface(anatomy_surface("tibia"), (0.0, y0 - 40 * MM, 0.0), (0.0, -1.0, 0.0))
    top_y = y0 - 15 * MM  # the plateau: the tibia's top 15 mm
    top = tibia.points[tibia.points[:, 1] > top_y]
    m = h + mm2  # the femur's cartilage one element and 2 mm inside the plateau's edge
    over = ((top[:, 0].min() + m, -big, top[:, 2].min() + m),
            (top[:, 0].max() - m, y0 + 10 * MM, top[:, 2].max() - m))  # fmt: skip
    up, down = ((0, 1, 0), 10), ((0, -1, 0), 10)
    femur_top = SurfaceRegion("femur_top", cone=up, box=((-big, y0 + 39 * MM, -big), (big,) * 3))
    tibia_base = SurfaceRegion("tibia_base", cone=down, box=((-big,) * 3, (big, y0 - 39 * MM, big)))
    condyles = SurfaceRegion("condyles", cone=((0, -1, 0), 40), box=over)
    plateau = SurfaceRegion("plateau", cone=((0, 1, 0), 60), box=((-big, top_y, -big), (big,) * 3))
    bones = [
        JointBone("femur", femur, mm2, [femur_top],
                  Cartilage("femur_cartilage", "femur_contact", (condyles,), mm2)),
        JointBone("tibia", tibia, mm2, [tibia_base],
                  Cartilage("tibia_cartilage", "tibia_contact", (plateau,), mm2)),
    ]  # fmt: skip
    bone, knee_msh = work / "bones.msh", work / "knee.msh"
    _, t_mesh = timed(joint_from_surfaces, bones, h, comm=COMM, path=bone)
    slab = tibia.points[np.abs(tibia.points[:, 1] - (y0 - 16 * MM)) < 3 * MM]
    mid = 0.5 * (slab.min(axis=0) + slab.max(axis=0))
    centre = np.array([mid[0], y0 - 16 * MM, mid[2]])
    _, t_embed = timed(
        embed_ball, bone, knee_msh, "tumour", "tibia_cancellous", centre, 3 * MM, 1.5 * MM
    )
    text = vertebra_text(knee_msh, "knee", 8, 4, 1)
    for old, new in (
        ('"L4_cortical"', '"femur_cortical", "tibia_cortical"'),
        ('"L4_cancellous"]\nmodel', '"femur_cancellous", "tibia_cancellous"]\nmodel'),
        ("E = 723.0e6", "E = 1.0e9"),
        ("L4_cancellous", "tibia_cancellous"),
        ("L4_base", "tibia_base"),
    ):
        text = text.replace(old, new)
    pair = f"""[[material]]
name = "cartilage"
regions = ["femur_cartilage", "tibia_cartilage"]
model = "isotropic"
E = 10.0e6
nu = 0.4
[[contact]]
name = "tibiofemoral"
slave = "femur_contact"
master = "tibia_contact"
friction = "coulomb"
coefficient = 0.1
[[dirichlet]]
boundary = "femur_top"
value = [0.0, "free", 0.0]
[[traction]]
boundary = "femur_top"
value = [0.0, {-W_KNEE / facet_area(knee_msh, "femur_top"):.9e}, 0.0]
"""
    text = text.replace('[[pressure]]\nboundary = "L4_top"\nvalue = 0.35e6\n', pair)
    text = text.replace(
        "load_steps = 1", 'load_steps = 2\n[solver]\nlinear = "direct"\nmax_iterations = 40'
    )
    return text, {"mesh_s": t_mesh, "embed_s": t_embed}


def ball_with_core(path: Path, h_in: float, h_out: float) -> None:
    """Rank 0: a ball of radius B_BALL ("bone", surface "outer") around a core ball of
    radius R0_CYST ("cyst"), size h_in at the core growing to h_out at 4 R0_CYST."""
    with gmsh_session("lame"):
        occ = gmsh.model.occ
        _, m = occ.fragment(
            [(3, occ.addSphere(0, 0, 0, B_BALL))], [(3, occ.addSphere(0, 0, 0, R0_CYST))]
        )
        occ.synchronize()
        inner = [t for _, t in m[1]]
        outer = [t for _, t in m[0] if t not in inner]
        gmsh.model.addPhysicalGroup(3, outer, 1, name="bone")
        gmsh.model.addPhysicalGroup(3, inner, 2, name="cyst")
        rim = gmsh.model.getBoundary([(3, s) for s in outer + inner], combined=True)
        gmsh.model.addPhysicalGroup(2, [abs(t) for _, t in rim], 3, name="outer")
        core = [abs(t) for _, t in gmsh.model.getBoundary([(3, s) for s in inner])]
        f = gmsh.model.mesh.field
        d = f.add("Distance")
        f.setNumbers(d, "SurfacesList", core)
        th = f.add("Threshold")
        for key, v in (("SizeMin", h_in), ("SizeMax", h_out), ("DistMin", 0.0)):
            f.setNumber(th, key, v)
        f.setNumber(th, "InField", d)
        f.setNumber(th, "DistMax", 4 * R0_CYST)
        f.setAsBackgroundMesh(th)
        for key in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints", "MeshSizeFromCurvature"):
            gmsh.option.setNumber(f"Mesh.{key}", 0)
        gmsh.model.mesh.generate(3)
        gmsh.write(str(path))


def lame(work: Path, size: tuple) -> tuple[str, dict]:
    """The clamped ball with the cyst at its centre (one year, one analysis at the end)."""
    msh = work / "ball.msh"
    _, t_mesh = timed(on_rank0, ball_with_core, msh, *size)
    text = f"""format = 1
[scene]
name = "lame"
mesh = "{msh}"
dimension = 3
[analysis]
kind = "static"
load_steps = 1
[[material]]
name = "bone"
regions = ["bone"]
model = "isotropic"
E = {E_BONE}
nu = {NU_BONE}
[[dirichlet]]
boundary = "outer"
value = [0.0, 0.0, 0.0]
[neoplasm]
kind = "cyst"
region = "cyst"
host = ["bone"]
t_end = {YEAR:.9e}
dt = {YEAR / 12:.9e}
mechanics_every = 0
[neoplasm.cyst]
beta = 1.28e-10
C_minus = 1.0
[output]
directory = "results"
fields_every = 0
"""
    return text, {"mesh_s": t_mesh, "embed_s": 0.0}


def lame_wall_error(res: RunResult) -> tuple[float, float, float]:
    """The mean of u_r / u_Lamé, the mean and the largest |u_r / u_Lamé - 1| over the
    cavity wall vertices (collective)."""
    g = res.summary["growth"]
    R, f = g["final_radius"], res.summary["growth"]["final_pressure_Pa"]
    integ = res.integrator
    model = integ.model
    V = model.V
    blocks = fem.locate_dofs_topological(V, 2, model.facet_tags.find(max(model.facet_tags.values)))
    blocks = blocks[blocks < V.dofmap.index_map.size_local]
    x = V.tabulate_dof_coordinates()[blocks]
    r = np.linalg.norm(x, axis=1)
    lam, mu = E_BONE * NU_BONE / ((1 + NU_BONE) * (1 - 2 * NU_BONE)), E_BONE / (2 * (1 + NU_BONE))
    B = f / (4 * mu / R**3 + (3 * lam + 2 * mu) / B_BALL**3)
    u_ref = -B / B_BALL**3 * r + B / r**2
    ratio = np.einsum("ij,ij->i", integ.u.x.array.reshape(-1, 3)[blocks], x) / r / u_ref
    ratio = np.concatenate(COMM.allgather(ratio))
    err = np.abs(ratio - 1)
    return float(ratio.mean()), float(err.mean()), float(err.max())


def knee_forces(res: RunResult) -> tuple[float, float]:
    """The vertical force of the last analysis's contact on the femur and on the tibia
    over the body weight, minus 1: the internal forces K u summed over the nodes of
    ``femur_contact`` and of ``tibia_contact`` (collective).  The femur's must be W (its
    guide takes no vertical force); the tibia receives what the mortar passes on."""
    model, u = res.integrator.model, res.integrator.u
    ku = model.K.createVecLeft()
    model.K.mult(u.x.petsc_vec, ku)
    msh = Path(res.summary["coupling"]["analyses"][-1]["directory"]) / "host_mesh.msh"
    tags = read_host_geometry3d(msh).facets if COMM.rank == 0 else None
    tags = COMM.bcast({k: tags[k][0] for k in ("femur_contact", "tibia_contact")} if tags else None)
    out = []
    for group, sign in (("femur_contact", 1.0), ("tibia_contact", -1.0)):
        blocks = fem.locate_dofs_topological(model.V, 2, model.facets(tags[group]))
        blocks = blocks[blocks < model.V.dofmap.index_map.size_local]
        fy = COMM.allreduce(float(ku.array[3 * blocks + 1].sum()), op=MPI.SUM)
        out.append(sign * fy / W_KNEE - 1.0)
    return out[0], out[1]


CASES = {
    "jaw_block": jaw_block,
    "mandible": mandible,
    "vertebra": vertebra,
    "lame": lame,
    "knee": knee,
}


def mech_phases(res: RunResult) -> dict[str, float]:
    """The phases of every analysis of a coupled run, summed (from their summary.json)."""
    out = dict.fromkeys([*MECH.values(), "mech_other"], 0.0)
    for a in res.summary["coupling"]["analyses"]:
        ph = json.loads((Path(a["directory"]) / "summary.json").read_text()).get("phases_s", {})
        for k, v in ph.items():
            out[MECH.get(k, "mech_other")] += v
    return out


def one(case: str, size: tuple) -> dict:
    """Build, run and time one case at one size (collective)."""
    tmp = tempfile.mkdtemp(prefix=f"bench_scene3d_{case}_") if COMM.rank == 0 else None
    work = Path(COMM.bcast(tmp, root=0))
    text, times = CASES[case](work, size)
    res, wall = timed(run_text, text, work)
    if res.status != "converged":
        raise SystemExit(f"{case} {size}: {res.summary.get('message')}")
    V = res.integrator.model.V
    row = {
        "case": case,
        "size_m": "/".join(f"{s:g}" for s in size),
        "ranks": COMM.size,
        "cells": res.summary["coupling"]["analyses"][-1]["cells"],
        "dofs": V.dofmap.index_map.size_global * V.dofmap.index_map_bs,
        "n_steps": res.summary["growth"]["steps"],
        "n_analyses": len(res.summary["coupling"]["analyses"]),
        **{k: round(v, 3) for k, v in times.items()},
        "run_s": round(wall, 3),
        **{f"{k}_s": round(res.summary["coupling"]["phases_s"].get(k, 0.0), 3) for k in COUPLING},
        **{k: round(v, 3) for k, v in mech_phases(res).items()},
        "peak_mb": res.summary.get("peak_memory_mb", {}).get("max_rank"),
        "wall_ratio_mean": "",
        "wall_err_mean": "",
        "wall_err_max": "",
        "force_err_femur": "",
        "force_err_tibia": "",
    }
    if case == "lame":
        ratio, mean, worst = lame_wall_error(res)
        row["wall_ratio_mean"] = f"{ratio:.4f}"
        row["wall_err_mean"], row["wall_err_max"] = f"{mean:.4g}", f"{worst:.4g}"
    if case == "knee":
        femur, tibia = knee_forces(res)
        row["force_err_femur"], row["force_err_tibia"] = f"{femur:.3e}", f"{tibia:.4g}"
    return row


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="the two smaller sizes of each case")
    ap.add_argument("--cases", default=",".join(CASES), help="comma-separated: " + ",".join(CASES))
    ap.add_argument("--out", default=str(Path(__file__).parent / "results"))
    args = ap.parse_args()
    if COMM.rank == 0:
        Path(args.out).mkdir(parents=True, exist_ok=True)
    cases = args.cases.split(",")
    bad = [c for c in cases if c not in CASES]
    if bad:
        print(f"--cases: unknown {bad}; allowed: {', '.join(CASES)}", file=sys.stderr)
        raise SystemExit(2)
    for case in cases:
        for size in SIZES[case][:2] if args.quick else SIZES[case]:
            row = one(case, size)
            if COMM.rank == 0:
                print(row, flush=True)
            write_rows(Path(args.out), "scene3d", [row])


if __name__ == "__main__":
    main()
