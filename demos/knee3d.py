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
# own body frames.  `bonecontact.meshing.joint.pose_on` places the femur on the tibia:
# vertical rays through both surfaces find the smallest gap under each femoral condyle,
# a rotation in the frontal plane levels the two condyles and a vertical shift leaves
# a 4 mm gap at both: the femoral cartilage (2 mm), 0.5 mm of clearance closed by the
# load (why a clearance: *The contact pair* below) and 1.5 mm of tibial cartilage.  Both
# bones are cut 40 mm from the joint (`clip_surface`: the distal femur, the proximal
# tibia, each closed by a flat cap), remeshed and meshed into one body of tetrahedra
# (`joint_from_surfaces`): each bone a 2 mm cortical shell around a cancellous core and a
# **cartilage layer** on its articular facets, tapering to nothing at its rim.  The
# femoral layer is 2 mm thick, offset outward from the femur; the tibial layer
# **conforms** to it (`Cartilage(..., conform_to="femur", clearance=0.5 mm)`): its
# articular surface is the femoral cartilage's surface 0.5 mm away along the plateau's
# normals, where that is less than 4 mm from the tibia (1.5–4 mm thick there), and 4 mm
# thick elsewhere.  The two layers meet in a frictional **contact pair** over a patch.
# A tumour, 3 mm in radius at the
# start, grows in the cancellous bone of the proximal tibia, 16 mm below the plateau.
# The femur carries 1000 N, the axial load of the cadaver studies we compare with
# (1.4 body weights of 73 kg); the tibia is held at its cut.  At intervals
# gmsh rebuilds the knee's tetrahedra around the current tumour and the loaded knee is
# solved again.  We follow the tumour's volume and the **contact pressure on the
# plateau** over growth time, check the contact force against the load and compare the
# contact area and pressures with published measurements (`docs/validation.md`).
#
# `python demos/knee3d.py [OUTPUT_DIR]`, `mpiexec -n 2 python demos/knee3d.py`, or as a
# notebook.  `BONECONTACT_DEMO_QUICK=1` grows the tumour for 8 days with two analyses
# (days 4 and 8) on a coarser mesh (5 mm), instead of 24 days with three analyses
# (days 8, 16, 24) on a 4 mm mesh.  Time on this 2-core machine, shared with other jobs
# (load about 16, 2026-11-28): quick 92–120 s on 1 rank, 89 s on 2 ranks (the 2-rank
# forces and pressures equal the serial ones to the printed digits), full 114 s on 1
# rank.  Units: SI.
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
# $\nu = 0.3$; cancellous bone $E = 1$ GPa, $\nu = 0.25$; articular cartilage
# $E = 10$ MPa, $\nu = 0.4$ (equilibrium properties); the tumour a lytic, nearly
# incompressible tissue $E = 0.5$ MPa, $\nu = 0.49$ (`nodal_pressure`: no locking).
# $\mu = 0.1$ is that of cartilage on cartilage without its synovial lubrication (with
# it, 0.005–0.02).
#
# ## The tumour
# As in `demos/spine3d.py`: quasi-steady nutrient, $\mu_T = 1/(5\ \text{days})$ (the
# volume doubles in about a week; illustrative), growth steps of 2 days, its own mesh
# remeshed every step (docs/theory/growth.md).
#
# **Limits.**  The surfaces are visualisation meshes: the condyles and the plateau are
# polyhedra of 5–15 mm facets.  Posed, the two surfaces come within 0.5 mm of touching
# over only about 55 mm² (within 1 mm: 120 mm², 2 mm: 250 mm²; vertical rays on a
# 0.5 mm grid, the 4 mm remeshed bones), and rounding the facets (Taubin smoothing, 50
# passes) does not change that (51, 119, 260 mm²): the scanned condyles and plateau are
# incongruent, as real ones are without the menisci.  The conformed tibial cartilage
# closes that incongruence where the bones are within 2.5 mm of their closest gap (about
# 320 mm²); the contact patches are a few 4 mm elements wide and the pressure's peak is
# a coarse-mesh value; the menisci, the ligaments and the muscles are not modelled.

# %%
import sys
import time
import warnings
from pathlib import Path

from mpi4py import MPI  # before dolfinx

import numpy as np
from scipy.spatial import cKDTree

import bonecontact.plot as bp
from bonecontact.meshing import SurfaceRegion, anatomy_surface
from bonecontact.meshing.joint import (
    Cartilage,
    JointBone,
    clip_surface,
    joint_from_surfaces,
    pose_on,
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
CARTILAGE = 2 * MM  # thickness of the femoral cartilage layer
TIBIAL = (1.5 * MM, 4 * MM)  # the tibial layer's thickness where the bones are closest, largest
CORTEX = 2 * MM
KEEP = 40 * MM  # length of each bone kept from the joint
H = 5 * MM if quick else 4 * MM  # element size
CLEARANCE = 0.5 * MM  # gap left between the two cartilage layers, closed by the load
R0 = 3.0 * MM  # initial tumour radius
DEPTH = 16 * MM  # tumour centre below the plateau
days, dt, every = (8, 4, 1) if quick else (24, 2, 4)  # growth time, step, steps per analysis
t0 = time.perf_counter()
if comm.rank == 0:
    output.mkdir(parents=True, exist_ok=True)
comm.barrier()

# %% [markdown]
# ## Posing the femur on the tibia
# Axes of the surfaces: $y$ up, $z$ across the knee (medial–lateral), $x$ front–back.
# The gap is measured by vertical rays on a 0.5 mm grid: in each column, the lowest
# crossing of the femur minus the highest crossing of the tibia.  `pose_on` splits the
# joint at the mean $z$ of the columns where both bones are hit and levels the smallest
# gap of each side (the two condyles) by a rotation about the $x$ axis.

# %%
femur, tibia = anatomy_surface("femur"), anatomy_surface("tibia")
posed, pose = pose_on(femur, tibia, CARTILAGE + CLEARANCE + TIBIAL[0])
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
# (`tibia_base`).  Cartilage facets (`SurfaceRegion` rules on the remeshed surfaces): on
# the femur the triangles facing down (normal within 45° of $-y$) less than 12 mm above
# the plateau, the underside of the two condyles; on the tibia those facing up (within
# 60° of $+y$) in its top 15 mm, the whole plateau.  Each layer is 2 mm thick normal to
# its facets and tapers to nothing over the ring of facets at its rim (no step where it
# ends).  Their articular surfaces are the facet groups `femur_contact` and
# `tibia_contact`.
#
# **The contact pair.**  `femur_contact` is the slave, `tibia_contact` the master: the
# master must cover every slave node's neighbourhood (a slave node only partly over the
# master loses part of its force: the force on the tibia then differs from the body
# weight by a few per cent, as measured with the roles swapped), and the plateau is
# larger than the condyles' underside; the slave facets are kept one element inside the
# plateau's edge (a slave node only partly over the master gets a dual-mortar weighted
# gap $d_p/D_{pp}$ far from its geometric gap, and the solver would refuse it as an
# initial interpenetration).  The 0.5 mm left between the layers: posed with no
# clearance, the offset layers of these faceted surfaces cross each other and the mesh
# is refused.  The load closes the 0.5 mm by a rigid approach of the femur (its guide
# leaves $u_y$ free), which changes no stress.

# %%
t_mesh = time.perf_counter()
femur_cut = clip_surface(posed, (0.0, y0 + KEEP, 0.0), (0.0, 1.0, 0.0))
tibia_cut = clip_surface(tibia, (0.0, y0 - KEEP, 0.0), (0.0, -1.0, 0.0))
BIG = 1.0


def compartments(name: str, half: tuple[float, float], up: int, angle: float, height: float):
    """One region per compartment: the facets whose normal is within ``angle`` of ``up``·y,
    in a box about the compartment's contact point (half-widths ``half`` in x and z) and
    within ``height`` of the plateau (above it for the femur, below for the tibia)."""
    out = []
    for p in pose.points:
        lo = [p[0] - half[0], y0 - (height if up > 0 else 0.0), p[2] - half[1]]
        hi = [p[0] + half[0], y0 + (height if up < 0 else 0.0), p[2] + half[1]]
        out.append(SurfaceRegion(name, cone=((0, up, 0), angle), box=(lo, hi)))
    return tuple(out)


# the femur's cartilage facets lie over the plateau, one element and 2 mm inside its edge
top = tibia_cut.points[tibia_cut.points[:, 1] > y0 - 15 * MM]
margin = H + 2 * MM
over_plateau = (
    (top[:, 0].min() + margin, -BIG, top[:, 2].min() + margin),
    (top[:, 0].max() - margin, y0 + 10 * MM, top[:, 2].max() - margin),
)
bones = [
    JointBone(
        "femur",
        femur_cut,
        CORTEX,
        regions=[
            SurfaceRegion(
                "femur_top", cone=((0, 1, 0), 10), box=((-BIG, y0 + KEEP - MM, -BIG), (BIG,) * 3)
            )
        ],
        cartilage=Cartilage(
            "femur_cartilage",
            "femur_contact",
            (SurfaceRegion("condyles", cone=((0, -1, 0), 40), box=over_plateau),),
            CARTILAGE,
        ),
    ),
    JointBone(
        "tibia",
        tibia_cut,
        CORTEX,
        regions=[
            SurfaceRegion(
                "tibia_base", cone=((0, -1, 0), 10), box=((-BIG,) * 3, (BIG, y0 - KEEP + MM, BIG))
            )
        ],
        cartilage=Cartilage(
            "tibia_cartilage",
            "tibia_contact",
            (
                SurfaceRegion(
                    "plateau", cone=((0, 1, 0), 60), box=((-BIG, y0 - 15 * MM, -BIG), (BIG,) * 3)
                ),
            ),
            TIBIAL[1],
            conform_to="femur",
            clearance=CLEARANCE,
        ),
    ),
]
base_msh, knee_msh = output / "knee_bones.msh", output / "knee.msh"
joint_from_surfaces(bones, H, comm=comm, path=base_msh)

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
SCENE = f"""format = 1
[scene]
name = "knee3d"
mesh = "{knee_msh}"
dimension = 3

[analysis]
kind = "static"
load_steps = 2
# the cartilage strain exceeds the small-strain limit (10 %): strain measure 39 % (principal
# strain exceeded in 1 % of the cartilage volume; full and quick runs 2026-11-28, conformed
# tibial cartilage); accepted explicitly (see "A limit of this model")
allow_large_strain = true

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
E = 10.0e6
nu = 0.4

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
# exactly, $\sum_q M_{pq} = D_{pp}$.  Here it differs by 1–3 % (measured: −1.8 % on the
# 4 mm mesh, +2.6 % on the quick one, with the former uniform layers under 700 N; −3.0 %
# and −2.0 % with the conformed layer under 1000 N), and the tibia's cut balances what it
# receives.  Why (full run, day 8, the former layers): at most active nodes the row sums of the mortar matrix $M$
# match $D_{pp}$ within 7 %, but one active node, on the inner flank of the
# condyle at $z < 0$, presses (6 MPa) on the tibial spine, whose steep facets are not in the
# master (normals beyond 60° of $+y$): only 15 % of its neighbourhood is covered, and
# $\sum_p \lambda_p \sum_q M_{pq}$ = 720.6 N against $\sum_p D_{pp}\lambda_p$ =
# 737.7 N.  Taking the steep facets into the master (75°) makes other barely covered
# slave nodes report initial penetrations of centimetres (their weighted gaps), which
# the solver refuses.  `history.csv` reports the total normal force $\sum_p D_{pp}\lambda_{n,p}$
# of the multipliers, larger than $W$ by the tilt of the contact normals.  From
# `contact_tibiofemoral.csv` (the femur's cartilage nodes that carry a multiplier): the
# contact area (a third of the area of the triangles around each closed node) and the
# peak pressure.
#
# What to expect (full run, 29k tetrahedra, 2026-11-28): the femur turns 6.0° and the
# gaps under the condyles go from 9.9 and 14.5 mm to 4.0 mm; the femur's contact force
# is $W$ to 1e-8, the tibia receives 970.2 N vertically; two contact patches, one per
# condyle, 312 mm² and 21 nodes together (the former uniform layers: 160 mm² under
# 700 N, a few nodes each), the peak pressure 10.1 MPa at the lateral patch's edge, the
# mean 3.45 MPa; the total normal force 1066 N.  Quick (5 mm): 289 mm², 9.2 MPa.  The
# tumour grows from 3 to 6.3 mm in radius 16 mm below the plateau, under the cortical
# plate and the cartilage: it does not change the contact (peak 10.07, 10.08,
# 10.07 MPa, area 312 mm² at days 8, 16, 24): the figure's title states the change.
#
# **A limit of this model.**  1 % of the cartilage's volume is strained by more than
# 39 % (summary.json `strain_measure`) and 15 % of it by more than 10 %
# (`volume_above_strain_limit`), far beyond the small-strain limit of
# 10 % (docs/scene_format.md, "Validity of the model"): the scene accepts it explicitly
# (`allow_large_strain = true`; without it the run ends `"invalid"`, exit status 3).
# A linear layer of shear modulus $E/(2(1+\nu))$ = 3.6 MPa strains by 30–50 % under the
# 2–4 MPa deviatoric stress of a 6–10 MPa contact; the measured peak without menisci,
# 6 MPa, would strain it as much (docs/validation.md).  The bone's strains stay
# below 2 %.  The pressure's peak and the cartilage's deformation are therefore
# indicative; the load each bone carries is fixed by equilibrium.  Why the strain
# concentrates (measured 2026-12-01): before loading, the vertical gaps of the femoral
# cartilage nodes over the patch spread from 0.02 to 2 mm, since the scanned femur's
# 5 mm facets meet at kinks that stand up to 1 mm out of the tibial facets' chords; the
# layers (3.5–6 mm together) must be compressed by that spread before the patch closes,
# 15–30 % whatever the modulus.  A short-time cartilage modulus, a "meniscus" conformed
# to the gap and split facets were tried and measured (docs/validation.md): none brings
# the measure near 10 % without shrinking the patch.


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

    from bonecontact.common.resources import data_file

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
