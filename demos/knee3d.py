# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3 (bonecontact)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # A knee under body weight with a tumour growing in the proximal tibia (3D)
#
# The shipped femur and tibia surfaces (`anatomy_surface("femur")`, `"tibia"`:
# low-resolution scans, 908 and 368 triangles; `data/anatomy/README.md`) come in their
# own body frames.  Their articular ends are rounded (`smooth_surface`), then
# `bonecontact.meshing.joint.pose_on` places the femur on the tibia: vertical rays
# through both surfaces find the smallest gap under each femoral condyle, a rotation in
# the frontal plane levels the two condyles and a vertical shift leaves a 4.5 mm gap at
# both: the femoral cartilage (2 mm), 0.5 mm of clearance closed by the load (why a
# clearance: *The contact pair* below) and 2 mm of tibial cartilage.  Both bones are cut
# 40 mm from the joint (`clip_surface`: the distal femur, the proximal tibia, each closed
# by a flat cap), remeshed and meshed into one body of tetrahedra
# (`joint_from_surfaces`): each bone a 2 mm cortical shell around a cancellous core and a
# **cartilage layer** on its articular facets.  The femoral layer is 2 mm thick, offset
# outward from the femur; the tibial layer's articular surface **is the femoral surface
# lowered by the clearance** (`Cartilage(..., conform_to="femur",
# conform_along="lowered")`), 2–10 mm thick: it fills the incongruity of the two scans
# (as the menisci do in a real knee), so that the two layers meet over a patch of about
# 700 mm² rather than at a few nodes.  A tumour, 3 mm in radius at the start, grows in
# the cancellous bone of the proximal tibia, 16 mm below the plateau.  The femur carries
# 1000 N, the axial load of the cadaver studies we compare with (1.4 body weights of
# 73 kg); the tibia is held at its cut.  At intervals gmsh rebuilds the knee's
# tetrahedra around the current tumour and the loaded knee is solved again.  We follow
# the tumour's volume and the **contact pressure on the plateau** over growth time,
# check the contact force against the load and compare the contact area and pressures
# with published measurements (`docs/validation.md`).  The run is inside the model's
# small-strain range (`summary.json`: `small_strain_valid: true`; no
# `allow_large_strain`).
#
# `python demos/knee3d.py [OUTPUT_DIR]`, `mpiexec -n 2 python demos/knee3d.py`, or as a
# notebook.  Both sizes use the same knee mesh (5 mm elements, 1.25 mm on the articular
# surfaces; shipped, see *The knee mesh*); `BONECONTACT_DEMO_QUICK=1` grows the tumour
# for 8 days with two analyses (days 4 and 8) and a coarser tumour surface (1.5 mm),
# instead of 24 days with three analyses (days 8, 16, 24; 1 mm).  Time on this 2-core
# machine, shared with other jobs (load 3–8, 2026-12-02): quick about 90 s as a notebook on
# 1 rank, full 225 s on 1 rank (2.5 GB; building the mesh instead of using the shipped
# one: 240 s more).
# Units: SI.
#
# ## Mechanics
# Each analysis solves, on the mesh rebuilt around the tumour, from an unstressed state,
# linear elasticity in both bones with unilateral contact and Coulomb friction
# ($\mu = 0.1$) between the cartilage layers (dual mortar, `docs/theory/mortar.md`, `docs/theory/pdas.md`):
#
# $$-\nabla\cdot\mathbb C\,e(u) = 0, \qquad u = 0 \ \text{on the cut of the tibia},
# \qquad \sigma n = -\frac{W}{A}\,e_y \ \text{on the cut of the femur},$$
#
# in two load steps (the first step of a Coulomb pair is frictionless: the friction
# bound is the previous step's pressure).  **Rigid modes.**  The femur is held by the
# contact alone in the vertical direction and against tilting (its two condyles rest on
# the plateau).  Contact cannot hold it sideways, forwards or against a turn about the
# vertical axis, and friction cannot in the first, frictionless step: the cut of the
# femur is therefore guided, $u_x = u_z = 0$, $u_y$ free (as the 2D knee's shaft,
# `demos/knee2d.py`).  The guide takes no vertical force, so the whole body weight goes
# through the contact.  Materials (data/materials.toml): cortical bone $E = 17$ GPa,
# $\nu = 0.3$; cancellous bone $E = 1$ GPa, $\nu = 0.25$; articular cartilage with its
# **short-time** properties (`cartilage_short_time`): $E = 15$ MPa, inside the
# 4.4–27 MPa measured in human knee cartilage loaded over 20 ms (Shepherd & Seedhom
# 1997), and nearly incompressible, $\nu = 0.475$ (a biphasic tissue keeps its volume
# until its fluid has had time to flow; `nodal_pressure`: no locking), the response to
# body weight applied as in a step of gait, not to a load held for minutes; the tumour a
# lytic, nearly incompressible tissue $E = 0.5$ MPa, $\nu = 0.49$ (`nodal_pressure`).
# $\mu = 0.1$ is that of cartilage on cartilage without its synovial lubrication (with
# it, 0.005–0.02).
#
# ## The tumour
# As in `demos/spine3d.py`: quasi-steady nutrient, $\mu_T = 1/(5\ \text{days})$ (the
# volume doubles in about a week; illustrative), growth steps of 2 days, its own mesh
# remeshed every step (docs/theory/growth.md).
#
# **Limits.**  The surfaces are visualisation meshes: the condyles and the plateau are
# polyhedra of 5–15 mm facets, incongruent (posed, they come within 0.5 mm of touching
# over about 55 mm² only, within 2 mm over 250 mm²).  The lowered tibial layer closes the
# incongruity with cartilage where a real knee has menisci (stiffer, fibrous, and able
# to move); the menisci, the ligaments and the muscles are not modelled, and the
# cartilage is a linear elastic solid with its short-time modulus.

# %%
import hashlib
import json
import sys
import time
import warnings
from pathlib import Path

from mpi4py import MPI  # before dolfinx

import numpy as np
from scipy.spatial import cKDTree

import bonecontact.plot as bp
from bonecontact.common.resources import data_dir, data_file
from bonecontact.materials import load_material_library
from bonecontact.meshing import SurfaceRegion, anatomy_surface
from bonecontact.meshing.joint import (
    Cartilage,
    JointBone,
    clip_surface,
    joint_from_surfaces,
    pose_on,
    smooth_surface,
)
from bonecontact.neoplasm.host3d import (
    build_host_mesh3d,
    read_host_geometry3d,
    sphere_surface,
)
from bonecontact.runners import run_scene
from bonecontact.scene import load_scene

# pyvista's import chain (pooch -> tqdm.auto) warns in a kernel without ipywidgets
warnings.filterwarnings("ignore", message="IProgress not found")
comm = MPI.COMM_WORLD
here = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
args = [a for a in sys.argv[1:] if not a.startswith("-")] if "__file__" in globals() else []
# results: the first argument, else $BONECONTACT_OUTPUT/knee3d, else demos/results/knee3d
output = bp.output_dir("knee3d", here, args)
quick = bp.quick_mode()

MM = 1e-3
DAY = 86400.0
W = 1000.0  # N, the axial load of the cadaver studies (1.4 body weights of 73 kg)
MU = 0.1  # Coulomb coefficient between the cartilage layers
#: everything the knee's mesh is made from (m, degrees, passes); its hash names the mesh
#: shipped in data/scenes/ (see *The knee mesh*)
GEOMETRY = {
    "element_size": 5 * MM,
    "cortex": 2 * MM,
    "keep": 40 * MM,  # length of each bone kept from the joint
    "femoral_cartilage": 2 * MM,
    "tibial_cartilage": (2 * MM, 10 * MM),  # where the bones are closest; at most
    "clearance": 0.5 * MM,  # gap left between the two cartilage layers, closed by the load
    "smoothing": (50, (21 * MM, 30 * MM), (14 * MM, 20 * MM)),  # passes; femur, tibia tapers
    "refine": 2,  # the articular facets split into four twice (1.25 mm)
    "rim_slope": 3.0,  # the tibial layer's outer wall at most 72° steep
    "condyle_cone": 60.0,
    "plateau_cone": 60.0,
    "inset": (5 * MM, 3 * MM),  # femoral layer inside the plateau's box; more on the lateral side
    "spine_notch": (-9 * MM, 1 * MM),  # z range over the tibial spine with no femoral layer
}
G = GEOMETRY
KEEP, CLEARANCE, CARTILAGE = G["keep"], G["clearance"], G["femoral_cartilage"]
R0 = 3.0 * MM  # initial tumour radius
DEPTH = 16 * MM  # tumour centre below the plateau
days, dt, every = (8, 4, 1) if quick else (24, 2, 4)  # growth time, step, steps per analysis
t0 = time.perf_counter()
if comm.rank == 0:
    output.mkdir(parents=True, exist_ok=True)
comm.barrier()

# %% [markdown]
# ## Smoothing and posing the bones
# Axes of the surfaces: $y$ up, $z$ across the knee (medial–lateral), $x$ front–back.
# The scans' articular ends are rounded first (`smooth_surface`: each triangle split into
# 16, then 50 passes of Taubin smoothing, with a weight 1 within 21 mm of the femur's
# lowest point and 14 mm of the tibia's highest, tapering to 0 at 30 and 20 mm: the rest
# of each bone is unchanged): the 5–15 mm scan facets meet at kinks that stand up to
# 1 mm out of the facing surface's chords, more than a linear layer can be compressed.
# The gap is measured by vertical rays on a 0.5 mm grid: in each column, the lowest
# crossing of the femur minus the highest crossing of the tibia.  `pose_on` splits the
# joint at the mean $z$ of the columns where both bones are hit and levels the smallest
# gap of each side (the two condyles) by a rotation about the $x$ axis.

# %%


def taper(d: np.ndarray, full: float, zero: float) -> np.ndarray:
    """Smoothing weight: 1 up to ``full`` from the joint, 0 beyond ``zero``."""
    return np.clip((zero - d) / (zero - full), 0.0, 1.0)


femur, tibia = anatomy_surface("femur"), anatomy_surface("tibia")
passes, f_taper, t_taper = G["smoothing"]
fy0, ty1 = femur.points[:, 1].min(), tibia.points[:, 1].max()
femur = smooth_surface(femur, passes, weights=lambda p: taper(p[:, 1] - fy0, *f_taper))
tibia = smooth_surface(tibia, passes, weights=lambda p: taper(ty1 - p[:, 1], *t_taper))
posed, pose = pose_on(femur, tibia, CARTILAGE + CLEARANCE + G["tibial_cartilage"][0])
y0 = float(pose.points[:, 1].mean())  # the plateau under the two contact points
if comm.rank == 0:
    print(
        f"pose: femur turned {pose.angle:.2f}° about the x axis and moved by "
        f"{np.round(pose.shift / MM, 1).tolist()} mm ({pose.iterations} iterations); gaps under "
        f"the condyles {pose.gaps_before[0] / MM:.2f} and {pose.gaps_before[1] / MM:.2f} mm "
        f"before levelling, {pose.gaps[0] / MM:.3f} and {pose.gaps[1] / MM:.3f} mm after"
    )

# %% [markdown]
# ## The knee mesh
# The femur cut 40 mm above the plateau (its cap: `femur_top`), the tibia 40 mm below
# (`tibia_base`).  Cartilage facets (`SurfaceRegion` rules on the remeshed surfaces),
# split into four twice (`refine = 2`: 1.25 mm facets on the joint, 5 mm elsewhere):
# on the femur the triangles facing down (normal within 60° of $-y$) less than 10 mm
# above the plateau, inside the plateau's outline less one element (5 mm; on the lateral
# side 3 mm more, so that the femoral layer's edge stays off the plateau's steep lateral
# rim, where it pressed at one node, 50 MPa, in a trial with the 5 mm inset), except
# over the tibial spine ($-9 < z < 1$ mm); on the tibia those facing up (within 60° of
# $+y$) in its top 15 mm, the whole plateau.  The femoral layer is 2 mm thick normal to
# its facets and tapers to nothing over the ring of facets at its rim.  The tibial layer
# is **the femoral surface lowered by the clearance**
# (`Cartilage(..., conform_to="femur", conform_along="lowered")`): each inner vertex of
# the plateau's facets moves straight up to 0.5 mm below the femoral cartilage above
# it, so the two articular surfaces are parallel over the whole patch and a vertical
# approach of 0.5 mm closes it at once; the layer is 2 mm thick where the bones are
# closest, at most 10 mm (it fills the scans' incongruity, as the menisci do in a real
# knee) and no steeper than 72° towards its rim; under the femur's bare bone and its
# tapered rim it stays the clearance plus the femoral layer's thickness away.
#
# **The contact pair.**  `femur_contact` is the slave, `tibia_contact` the master: the
# master must cover every slave node's neighbourhood (a slave node only partly over the
# master gets a dual-mortar weighted gap $d_p/D_{pp}$ far from its geometric gap, and
# the solver refuses it as an initial interpenetration), and the plateau is larger than
# the condyles' underside.  The 0.5 mm left between the layers is closed by a rigid
# approach of the femur (its guide leaves $u_y$ free), which changes no stress.
#
# **The shipped mesh.**  Building this mesh takes 5–13 minutes on this 2-core machine
# (busy, load 3–15: the lowering passes of the tibial layer and gmsh, 44k tetrahedra).
# The mesh is therefore shipped in `data/scenes/knee3d_joint_<hash>.msh`, named by a
# content hash of its inputs: the `GEOMETRY` values above and the two scan files.  The
# demo uses the shipped file when the hash matches and otherwise builds the mesh (into
# the output folder); `python demos/knee3d.py --ship-mesh` builds it and writes it to
# `data/scenes/` (the script that makes the shipped mesh is this cell).  The hash does
# not cover the code of `bonecontact.meshing.joint` and gmsh: after a change there,
# rebuild with `--ship-mesh` and remove the old file.

# %%


def mesh_key(geometry: dict) -> str:
    """12 hex digits of the SHA-256 of the geometry's values and the two scan files."""
    h = hashlib.sha256(json.dumps(geometry, sort_keys=True).encode())
    for name in ("femur.stl", "tibia.stl"):
        h.update(data_file("anatomy", name).read_bytes())
    return h.hexdigest()[:12]


femur_cut = clip_surface(posed, (0.0, y0 + KEEP, 0.0), (0.0, 1.0, 0.0))
tibia_cut = clip_surface(tibia, (0.0, y0 - KEEP, 0.0), (0.0, -1.0, 0.0))
BIG = 1.0
top = tibia_cut.points[tibia_cut.points[:, 1] > y0 - 15 * MM]
inset, lateral = G["inset"]
lo = (top[:, 0].min() + inset, -BIG, top[:, 2].min() + inset)
hi = (top[:, 0].max() - inset, y0 + 10 * MM, top[:, 2].max() - inset - lateral)
za, zb = G["spine_notch"]
condyles = (
    SurfaceRegion("condyles", cone=((0, -1, 0), G["condyle_cone"]), box=(lo, (*hi[:2], za))),
    SurfaceRegion("condyles", cone=((0, -1, 0), G["condyle_cone"]), box=((*lo[:2], zb), hi)),
)
plateau = SurfaceRegion(
    "plateau", cone=((0, 1, 0), G["plateau_cone"]), box=((-BIG, y0 - 15 * MM, -BIG), (BIG,) * 3)
)
bones = [
    JointBone(
        "femur",
        femur_cut,
        G["cortex"],
        regions=[
            SurfaceRegion(
                "femur_top", cone=((0, 1, 0), 10), box=((-BIG, y0 + KEEP - MM, -BIG), (BIG,) * 3)
            )
        ],
        cartilage=Cartilage(
            "femur_cartilage", "femur_contact", condyles, CARTILAGE, refine=G["refine"]
        ),
    ),
    JointBone(
        "tibia",
        tibia_cut,
        G["cortex"],
        regions=[
            SurfaceRegion(
                "tibia_base", cone=((0, -1, 0), 10), box=((-BIG,) * 3, (BIG, y0 - KEEP + MM, BIG))
            )
        ],
        cartilage=Cartilage(
            "tibia_cartilage",
            "tibia_contact",
            (plateau,),
            G["tibial_cartilage"][1],
            conform_to="femur",
            clearance=CLEARANCE,
            conform_along="lowered",
            refine=G["refine"],
            rim_slope=G["rim_slope"],
        ),
    ),
]
t_mesh = time.perf_counter()
key = mesh_key(GEOMETRY)
shipped = Path(str(data_dir())) / "scenes" / f"knee3d_joint_{key}.msh"
ship = "--ship-mesh" in sys.argv
if shipped.is_file() and not ship:
    base_msh, built = shipped, False
else:
    base_msh, built = (shipped if ship else output / "knee_bones.msh"), True
    joint_from_surfaces(bones, G["element_size"], comm=comm, path=base_msh)
knee_msh = output / "knee.msh"
if comm.rank == 0:
    print(
        f"knee mesh {'built' if built else 'shipped'}: {base_msh.name} (key {key}), "
        f"{time.perf_counter() - t_mesh:.0f} s"
    )

# %% [markdown]
# The tumour's cell group `tumour` (a ball of radius $R_0$, centred 16 mm below the
# plateau, in the middle of the tibia's extent at that depth) is put into the
# cancellous core by the same gmsh rebuild the growth uses
# (`bonecontact.neoplasm.host3d.build_host_mesh3d`).

# %%
slab = np.abs(tibia_cut.points[:, 1] - (y0 - DEPTH)) < 3 * MM
mid = 0.5 * (tibia_cut.points[slab].min(axis=0) + tibia_cut.points[slab].max(axis=0))
TUMOUR = np.array([mid[0], y0 - DEPTH, mid[2]])
geo = read_host_geometry3d(base_msh) if comm.rank == 0 else None
if comm.rank == 0:
    tag, tets = geo.cells["tibia_cancellous"]
    centre_cell = int(np.argmin(np.linalg.norm(geo.x[tets].mean(axis=1) - TUMOUR, axis=1)))
    geo.cells["tibia_cancellous"] = (tag, np.delete(tets, centre_cell, axis=0))
    geo.cells["tumour"] = (1 + max(t for t, _ in geo.cells.values()), tets[[centre_cell]])
h_tumour = R0 / 2 if quick else R0 / 3
ball = sphere_surface(TUMOUR, R0, h_tumour)
knee = build_host_mesh3d(
    geo, "tumour", ("tibia_cancellous",), *ball, cavity=False, h_neo=h_tumour, path=knee_msh,
    comm=comm,
)  # fmt: skip
t_mesh = time.perf_counter() - t_mesh
if comm.rank == 0:
    print(
        f"knee mesh: {knee.cells} tetrahedra, tumour {knee.neoplasm_area * 1e9:.1f} mm³ at "
        f"{np.round(TUMOUR / MM, 1).tolist()} mm, built in {t_mesh:.1f} s"
    )


# %% [markdown]
# ## The coupled scene
# `[neoplasm]` grows the tumour and runs `[analysis]` on the rebuilt knee at intervals;
# the traction on the femur's cut is the body weight over the cut's area (from the
# mesh's triangles), so its resultant is exactly $W$.


# %%
def triangle_areas(x: np.ndarray, tri: np.ndarray) -> np.ndarray:
    p = x[tri]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


top_area = None
if comm.rank == 0:
    g = read_host_geometry3d(knee_msh)
    top_area = float(triangle_areas(g.x, g.facets["femur_top"][1]).sum())
top_area = comm.bcast(top_area, root=0)
SHORT_TIME = load_material_library()["cartilage_short_time"]  # data/materials.toml
SCENE = f"""format = 1
[scene]
name = "knee3d"
mesh = "{knee_msh}"
dimension = 3

[analysis]
kind = "static"
load_steps = 2

[solver]
linear = "direct"
max_iterations = 40

[[material]]
name = "cortical"
regions = ["femur_cortical", "tibia_cortical"]
model = "isotropic"
E = 17.0e9
nu = 0.3

[[material]]
name = "cancellous"
regions = ["femur_cancellous", "tibia_cancellous"]
model = "isotropic"
E = 1.0e9
nu = 0.25

[[material]]
name = "cartilage"
regions = ["femur_cartilage", "tibia_cartilage"]
model = "isotropic"
E = {SHORT_TIME["E"]:.6g}
nu = {SHORT_TIME["nu"]}
formulation = "nodal_pressure"

[[material]]
name = "tumour"
regions = ["tumour"]
model = "isotropic"
E = 0.5e6
nu = 0.49
formulation = "nodal_pressure"

[[contact]]
name = "tibiofemoral"
slave = "femur_contact"
master = "tibia_contact"
friction = "coulomb"
coefficient = {MU}

[[dirichlet]]
boundary = "tibia_base"
value = [0.0, 0.0, 0.0]

[[dirichlet]]
boundary = "femur_top"
value = [0.0, "free", 0.0]

[[traction]]
boundary = "femur_top"
value = [0.0, {-W / top_area:.9e}, 0.0]

[neoplasm]
kind = "tumour"
region = "tumour"
host = ["tibia_cancellous"]
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
if comm.rank == 0:
    (output / "knee3d.toml").write_text(SCENE)
comm.barrier()
t_run = time.perf_counter()
res = run_scene(load_scene(output / "knee3d.toml"), comm, output=output, progress=False)
t_run = time.perf_counter() - t_run
if res.status != "converged":
    raise SystemExit(f"the coupled run failed: {res.summary.get('message')}")
analyses = res.summary["coupling"]["analyses"]

# %% [markdown]
# ## The contact force against the body weight
# The contact forces are measured independently of the solver's multipliers: the
# discrete nodal forces $f_i = \int \sigma : \nabla(\varphi_i e_k)\,dx$ of the written
# cell stresses (P1 hat functions $\varphi_i$), summed over the nodes of the femur's
# cartilage surface (`femur_contact`), of the tibia's (`tibia_contact`) and of the
# tibia's cut (`tibia_base`, the support reaction).  On the femur the contact must
# carry the whole body weight $W$ (its guide takes no vertical force; the femur's own
# equilibrium).  The tibia receives what the mortar coupling passes on: exactly the
# femur's force if the master surface covered every slave node's neighbourhood
# exactly, $\sum_q M_{pq} = D_{pp}$.  The femoral layer lies inside the plateau's
# outline, so the master covers every slave node, and the tibia receives the body
# weight within 0.1 % (measured −0.09 %; the former layers, whose slave nodes reached
# over the tibial spine and the plateau's rim, passed on 2–3 % less), and the tibia's
# cut balances what it receives.  `history.csv` reports the total normal force
# $\sum_p D_{pp}\lambda_{n,p}$ of the multipliers, larger than $W$ by the tilt of the
# contact normals.  From `contact_tibiofemoral.csv` (the femur's cartilage nodes that
# carry a multiplier): the contact area (a third of the area of the triangles around
# each closed node) and the peak pressure.
#
# What to expect (quick run, 2026-12-02): the femur turns 4.75° and the gaps under the
# condyles go from 10.5 and 14.1 mm to 4.5 mm; the femur's contact force is $W$ to
# 1e-8, the tibia receives 999.1 N vertically; two contact patches, one per condyle,
# 626 mm² and 401 nodes together, the peak pressure 4.08 MPa in the medial patch
# (4.5 mm inside the layer's edge on the side of the tibial spine; the next nodes
# 4.04, 3.92 MPa), the mean 1.72 MPa; the total normal force 1072 N.  Full run: the
# same to the printed digits at days 8, 16 and 24 (peak 4.08, 4.08, 4.07 MPa) while the
# tumour grows from 3.8 to 6.3 mm in radius.  The tumour
# grows 16 mm below the plateau, under the cortical plate and the cartilage: it does
# not change the contact (the peak and the area equal to the printed digits at every
# analysis): the figure's title states the change.
#
# **Validity.**  The strain measure of the cartilage (the principal strain exceeded in
# 1 % of its volume, summary.json `strain_measure`) is 8.9 %, under the small-strain
# limit of 10 % (docs/scene_format.md, "Validity of the model"): `small_strain_valid`
# is true and the scene does not need `allow_large_strain`; 0.42 % of the cartilage's
# volume is strained beyond 10 %.  Two things make it so (docs/validation.md): the
# lowered tibial surface makes the two articular surfaces parallel before loading
# (most femoral nodes start within 0.1 mm of the clearance), so the load closes the
# patch at once instead of compressing the layers by the scans' incongruity, and the
# short-time modulus, nearly incompressible, is the layer's response to a load applied
# over a step of gait (with the equilibrium $E = 10$ MPa, $\nu = 0.4$, the same
# construction, frictionless and without the lateral inset, reached 15 %).  The model before 2026-12-02 (unsmoothed scans, the tibial layer
# conformed along the normals, equilibrium cartilage) reached 39 % and was accepted
# only with `allow_large_strain`.


# %%
def nodal_forces(directory: Path, groups: tuple[str, ...]) -> list[np.ndarray]:
    """The resultant of the nodal forces ∫ σ : ∇(φ_i e_k) dx over the nodes of each facet
    group (N), from the last written fields of an analysis (rank 0; on several ranks the
    pieces' shared points and any repeated cell are merged by the mesh's nodes)."""
    d = Path(directory)
    grid = bp.read_fields(sorted(d.glob("fields*.pvd"))[-1])
    geo = read_host_geometry3d(d / "host_mesh.msh")
    dist, node = cKDTree(geo.x).query(np.asarray(grid.points))
    cells = grid.cells_dict  # linear tetrahedra: VTK_LAGRANGE_TETRAHEDRON or VTK_TETRA
    tet = node[np.asarray(cells[71] if 71 in cells else cells[10]).reshape(-1, 4)]
    _, first = np.unique(np.sort(tet, axis=1), axis=0, return_index=True)
    tet = tet[first]
    sig = np.asarray(grid.cell_data["stress"]).reshape(-1, 3, 3)[first]
    edges = np.transpose(geo.x[tet[:, 1:]] - geo.x[tet[:, :1]], (0, 2, 1))
    vol = np.abs(np.linalg.det(edges)) / 6
    ref = np.array([[-1.0, -1.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    grad = np.einsum("cji,aj->cai", np.linalg.inv(edges), ref)
    f = np.zeros((len(geo.x), 3))
    np.add.at(f, tet.ravel(), np.einsum("c,cij,caj->cai", vol, sig, grad).reshape(-1, 3))
    return [f[np.unique(geo.facets[g][1])].sum(axis=0) for g in groups]


def contact_state(directory: Path) -> dict:
    """Forces, contact area and the pressure map of one analysis (rank 0)."""
    d = Path(directory)
    geo = read_host_geometry3d(d / "host_mesh.msh")
    table = np.genfromtxt(d / "contact_tibiofemoral.csv", delimiter=",", names=True, dtype=None,
                          encoding="utf-8")  # fmt: skip
    xs = np.c_[table["x"], table["y"], table["z"]]
    tri = geo.facets["femur_contact"][1]
    nodal_area = np.zeros(len(geo.x))
    np.add.at(nodal_area, tri.ravel(), np.repeat(triangle_areas(geo.x, tri) / 3, 3))
    _, idx = cKDTree(geo.x).query(xs)
    closed = table["status"] != "open"
    area_i = nodal_area[idx[closed]]
    hist = np.genfromtxt(d / "history.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    on_plateau, reaction, on_femur = nodal_forces(
        d, ("tibia_contact", "tibia_base", "femur_contact")
    )
    return {
        "normal_force": float(hist["normal_force"][-1]),
        "on_plateau": on_plateau,
        "on_femur": on_femur,
        "reaction": reaction,
        "area": float(area_i.sum()),
        "active_nodes": int(closed.sum()),
        "mean_pressure": float((table["pressure"][closed] * area_i).sum() / area_i.sum()),
        "max_pressure": float(table["pressure"].max()),
        "points": xs,
        "pressure": table["pressure"],
        "x": geo.x,
        "triangles": tri,
        "nodal_pressure": np.bincount(idx, weights=table["pressure"], minlength=len(geo.x)),
    }


if comm.rank == 0:
    growth = np.genfromtxt(output / "growth.csv", delimiter=",", names=True)
    rows, maps = [], []
    for a in analyses:
        c = contact_state(Path(a["directory"]))
        maps.append(c)
        rows.append(
            (a["time"], a["equivalent_radius"], a["neoplasm_volume_in_bone"], c["normal_force"],
             *c["on_femur"], *c["on_plateau"], *c["reaction"], c["area"], c["max_pressure"])
        )  # fmt: skip
    rows = np.array(rows)
    with open(output / "contact_force.csv", "w") as f:
        f.write(
            "time,equivalent_radius,tumour_volume,normal_force,femur_force_x,femur_force_y,"
            "femur_force_z,plateau_force_x,plateau_force_y,plateau_force_z,base_reaction_x,"
            "base_reaction_y,base_reaction_z,contact_area,max_pressure\n"
        )
        for r in rows:
            f.write(",".join(f"{v:.9g}" for v in r) + "\n")
    for r in rows:
        print(
            f"day {r[0] / DAY:.0f}: tumour R = {r[1] / MM:.2f} mm ({r[2] * 1e9:.0f} mm³); contact "
            f"force on the femur ({r[4]:.2f}, {r[5]:.2f}, {r[6]:.2f}) N (vertical "
            f"{100 * (r[5] / W - 1):+.4f} % of W = {W:.0f} N), on the plateau ({r[7]:.2f}, "
            f"{r[8]:.2f}, {r[9]:.2f}) N (vertical {100 * (-r[8] / W - 1):+.2f} % of W); reaction "
            f"at the tibia's cut ({r[10]:.2f}, {r[11]:.2f}, {r[12]:.2f}) N; total normal force "
            f"{r[3]:.1f} N; contact area {r[13] * 1e6:.0f} mm², peak pressure "
            f"{r[14] / 1e6:.2f} MPa"
        )

# %% [markdown]
# ## Against published measurements
# `data/validation/knee_tibiofemoral.toml` holds cadaver measurements of the
# tibiofemoral joint at 0° flexion under an axial load of 1000 N, the load applied here
# (Fukubayashi & Kurosawa 1980, Acta Orthop Scand 51:871–879: seven knees, casting and
# pressure-sensitive sheets).  The model has no menisci: it is compared with the knees
# after the menisci were removed (the intact knees are listed for the bound they set).
# The model's contact area is that of the femoral cartilage nodes in contact, its mean
# pressure the area-weighted mean over them, at the last analysis.  The measurement's
# spread is not in what was read (the abstract): the comparison is of the means only;
# docs/validation.md discusses it, with the other measurements in that file (Baratz et
# al. 1986, Shrive et al. 1978: changes with meniscectomy and meniscal load shares, for a
# model with menisci; Shepherd & Seedhom 1997: the short-time cartilage modulus).

# %%
if comm.rank == 0:
    import tomllib

    ref = tomllib.loads(data_file("validation", "knee_tibiofemoral.toml").read_text())
    c = maps[-1]
    print(f"{'':34s}{'area (mm²)':>12s}{'peak (MPa)':>12s}{'mean (MPa)':>12s}")
    print(
        f"{'this model (no menisci)':34s}{c['area'] * 1e6:12.0f}{c['max_pressure'] / 1e6:12.2f}"
        f"{c['mean_pressure'] / 1e6:12.2f}   ({c['active_nodes']} nodes in contact)"
    )
    for m in ref["measurement"]:
        label = f"{m['name'].split('_')[0]} ({'with' if m['menisci'] else 'without'} menisci)"
        print(
            f"{label:34s}{m['contact_area'] * 1e6:12.0f}{m['peak_pressure'] / 1e6:12.2f}{'—':>12s}"
        )
    without = next(m for m in ref["measurement"] if not m["menisci"])
    print(
        f"contact area {c['area'] / without['contact_area']:.2f} × and peak pressure "
        f"{c['max_pressure'] / without['peak_pressure']:.2f} × the measured ones without menisci"
    )

# %% [markdown]
# ## The pressure map over growth time
# The contact pressure at the slave nodes (the femur's cartilage surface, where it
# presses on the plateau), projected on the transverse plane and seen from above
# (anterior up the page), one panel per analysis, one colour range for all; the
# tumour's equator (projected) in cyan and the node of the peak pressure starred.
# Then the pressure on the femur's cartilage surface at the last analysis, projected
# the same way, as a picture of its own (projected to the vertices within the surface).

# %%
if comm.rank == 0:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    peak = [m["points"][int(np.argmax(m["pressure"]))] for m in maps]
    nodal = np.concatenate([m["nodal_pressure"] for m in maps]) / 1e6
    weights = np.concatenate(  # each node's share of the surface's area
        [
            bp.lumped_projection(
                m["triangles"], np.zeros(len(m["triangles"])),
                triangle_areas(m["x"], m["triangles"]), len(m["x"]),
            )[1]
            for m in maps
        ]
    )  # fmt: skip
    cr = bp.auto_range(nodal, weights)  # one range for all panels, ≤ 1 % of the area above
    fig, axes = plt.subplots(
        1, len(maps) + 1, figsize=(4.6 * (len(maps) + 1), 5.2), layout="constrained"
    )
    for ax, m, a, top in zip(axes, maps, analyses, peak):
        sc = ax.tripcolor(
            m["x"][:, 2] / MM, m["x"][:, 0] / MM, m["triangles"], m["nodal_pressure"] / 1e6,
            shading="gouraud", cmap="inferno", vmin=cr.vmin, vmax=cr.vmax,
        )  # fmt: skip
        phi = np.linspace(0, 2 * np.pi, 100)
        r = a["equivalent_radius"] / MM
        ax.plot(TUMOUR[2] / MM + r * np.cos(phi), TUMOUR[0] / MM + r * np.sin(phi), "c-", lw=1.5,
                label="tumour equator (projected)")  # fmt: skip
        ax.plot(top[2] / MM, top[0] / MM, "*", color="deepskyblue", mec="k", ms=12,
                label="peak pressure")  # fmt: skip
        ax.set_aspect("equal")
        ax.set_title(f"day {a['time'] / DAY:.0f}, tumour R = {r:.1f} mm", fontsize=10)
        ax.set_xlabel("z, across the knee (mm)")
        bp.draw_directions(ax, {"anterior": np.array([0.0, 1.0])}, corner="upper right")
    axes[0].set_ylabel("x, back to front (mm)")
    bar = fig.colorbar(sc, ax=axes[: len(maps)], extend=cr.extend, shrink=0.8)
    bar.set_label(cr.bar_label("contact pressure (MPa)"))
    axes[0].legend(loc="upper left", fontsize=8)
    ax = axes[-1]
    ax.plot(growth["time"] / DAY, growth["volume"] * 1e9, "-", label="tumour volume (growth.csv)")
    ax.plot(rows[:, 0] / DAY, rows[:, 2] * 1e9, "o", label="tumour volume (analyses)")
    ax2 = ax.twinx()
    ax2.plot(rows[:, 0] / DAY, rows[:, 14] / 1e6, "s--", color="C3", label="peak pressure")
    ax2.set_ylabel("peak contact pressure (MPa)", color="C3")
    ax2.set_ylim(0.0, 1.2 * rows[:, 14].max() / 1e6)
    handles = ax.get_legend_handles_labels()[0] + ax2.get_legend_handles_labels()[0]
    ax.legend(handles=handles, loc="upper left", fontsize=8)
    bp.line_axes(ax, ("growth time", "days"), ("tumour volume", "mm³"), zero=True)
    change = np.abs(rows[:, 14] / rows[0, 14] - 1).max()  # the peak's largest change
    said = f"by {100 * change:.1f} %" if change >= 5e-4 else "by less than 0.05 %"
    fig.suptitle(
        f"knee3d: contact pressure on the femoral cartilage under {W:.0f} N, tumour in the "
        f"tibia (seen from above)\nthe growing tumour changes the peak pressure {said}"
    )
    bp.show(fig, output / "knee3d_pressure.png", dpi=110)

    import pyvista as pv

    last = Path(analyses[-1]["directory"])
    g = read_host_geometry3d(last / "host_mesh.msh")
    tri = g.facets["femur_contact"][1]
    surf = pv.PolyData(g.x, np.hstack([np.full((len(tri), 1), 3), tri]).ravel())
    _, idx = cKDTree(maps[-1]["points"]).query(g.x)
    surf.point_data["contact_pressure"] = maps[-1]["pressure"][idx]
    r = analyses[-1]["equivalent_radius"]
    phi = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    equator = TUMOUR + r * np.c_[np.sin(phi), np.zeros_like(phi), np.cos(phi)]
    png = bp.field_view(
        surf.extract_cells(np.arange(len(tri))),
        "contact_pressure",
        output / "knee3d_pressure_3d.png",
        quantity="contact pressure",
        unit="MPa",
        title=(
            "knee3d: contact pressure on the femoral cartilage surface, "
            f"day {analyses[-1]['time'] / DAY:.0f} (projected, seen from above)"
        ),
        cmap="inferno",
        view="xz",
        up="x",
        axis_titles={"x": "x, back to front", "z": "z, across the knee"},
        directions={"anterior": (1.0, 0.0, 0.0)},
        outline=equator,
        outline_label="tumour equator (projected)",
        markers=[bp.Marker([peak[-1]], "peak pressure", "deepskyblue", "*", 12)],
    )
    bp.show(png, png)
    print(f"pictures and ParaView files (fields.xdmf, fields.pvd) in {output}")
    print(
        f"wall time {time.perf_counter() - t0:.0f} s on {comm.size} rank(s) "
        f"(meshing {t_mesh:.0f} s, growth + rebuilds + mechanics {t_run:.0f} s)"
    )
comm.barrier()
