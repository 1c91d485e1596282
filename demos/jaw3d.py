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
# # A cyst growing in a real mandible under a bite (3D)
#
# The shipped mandible surface (`anatomy_surface("mandible")`, a low-resolution human
# lower jaw, 2734 triangles; `data/anatomy/README.md`) is meshed into tetrahedra with a
# 2 mm cortical shell around a cancellous core, keeping the surface's own triangles.  A
# radicular cyst, 2 mm in radius at the start, sits in the cancellous core of the
# mandibular body (on the side $z > 0$, below the molar region).  The jaw is held at its condyles and bitten on: a
# bite force of 300 N pushes down on the upper (occlusal) surface of the teeth region.
# The cyst grows (the osmotic/Maxwell cyst ODE of `data/scenes/jaw_cyst3d.toml`); at
# intervals gmsh rebuilds the jaw's tetrahedra around the current cyst (a cavity with the
# lumen's excess pressure on its wall) and the bitten jaw is solved again.  We follow
# the cyst's radius and the largest stress in the bone next to it.
#
# `python demos/jaw3d.py [OUTPUT_DIR]`, `mpiexec -n 2 python demos/jaw3d.py`, or as a
# notebook.  `BONECONTACT_DEMO_QUICK=1` grows the cyst for one year with two analyses
# (half-yearly) instead of two years with four.  Units: SI.
#
# ## The cyst
# Osmotic material accumulates in the lumen through its lining at the rate $\beta$ per
# unit area, the osmotic excess pressure $f = P_h^+ - P_h^- = R_gT\,(C^+ - C^-)$ of the
# lumen pushes the wall out, and the tissue around it yields as a Maxwell body
# ($\tau\dot f + f = \nu\dot\varepsilon$, $\tau = \nu/E$, log strain
# $d\varepsilon = dR/R$).  For a sphere of radius $R$ this closes to
#
# $$\dot R = \frac{R f + 3\tau\alpha\beta}{\nu + 3\tau(\alpha C^- + f)}, \qquad
# \dot f = \frac{3}{R}\Big[\alpha\beta - (\alpha C^- + f)\,\dot R\Big], \qquad \alpha = R_gT,$$
#
# integrated with an implicit Radau method in monthly steps; at long times
# $\dot R \to \beta/C^-$.  Here $\beta = 3.2\cdot10^{-11}$ mol m⁻² s⁻¹, $C^- = 1$ mol/m³
# (about 1 mm of radius per year, a radicular cyst, as `data/scenes/jaw_cyst3d.toml`),
# $T = 310$ K, $\nu = 10^9$ Pa s, $E = 1$ MPa (the defaults).  The
# excess pressure $f$ (growth.csv `pressure`, Pa) loads the cavity wall in each analysis
# (docs/theory/growth.md).
#
# ## Mechanics
# Each analysis solves, on the mesh rebuilt around the cyst, from an unstressed state,
#
# $$-\nabla\cdot\mathbb C\,e(u) = 0 \ \text{in the bone}, \qquad u = 0 \ \text{on the condyles}, \qquad
# \sigma n = t_\text{bite} \ \text{on the teeth}, \qquad \sigma n = -p\,n \ \text{on the cyst wall},$$
#
# with isotropic cortical bone ($E = 15$ GPa, $\nu = 0.3$, between the transverse and
# longitudinal moduli of cortical bone) and cancellous bone ($E = 1$ GPa, $\nu = 0.3$),
# and the rest of the surface free.  The bite traction is uniform and vertical,
# $t_\text{bite} = (0, -F/A, 0)$ with $F = 300$ N (a firm chewing force; the largest
# molar bite forces are 500–800 N) and $A$ the area of the loaded teeth facets.  Holding
# both condyles fixed is a simplification: the real jaw hangs in the muscles of
# mastication and presses its condyles into the skull.
#
# A fracture check (`[fracture]`, the initiation risk after every analysis) is not part
# of this demo: this version evaluates it in 2D scenes only (`demos/vertebra_tumour.py`
# shows it in a coupled 2D scene).

# %%
import sys
import time
import warnings
from pathlib import Path

from mpi4py import MPI  # before dolfinx

import numpy as np

import bonecontact.plot as bp
from bonecontact.meshing import SurfaceRegion, anatomy_surface, bone_from_surface
from bonecontact.neoplasm.host3d import (
    build_host_mesh3d,
    read_host_geometry3d,
    sphere_surface,
)
from bonecontact.runners import run_scene
from bonecontact.scene import load_scene

# pyvista's import chain (pooch -> tqdm.auto) warns in a kernel without ipywidgets; the
# surface meshing imports it first
warnings.filterwarnings("ignore", message="IProgress not found")
comm = MPI.COMM_WORLD
here = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
args = [a for a in sys.argv[1:] if not a.startswith("-")] if "__file__" in globals() else []
# results: the first argument, else $BONECONTACT_OUTPUT/jaw3d, else demos/results/jaw3d
output = bp.output_dir("jaw3d", here, args)
quick = bp.quick_mode()

MM = 1e-3
YEAR = 3.15576e7  # s (Julian year)
F_BITE = 300.0  # N
CYST = np.array([45.0, -13.0, 30.0]) * MM  # centre: cancellous core of the body, z > 0
R0 = 2.0 * MM  # initial cyst radius
H_BONE, CORTEX = 8 * MM, 2 * MM  # largest tetrahedron, cortical thickness
years, per_year = (1.0, 2) if quick else (2.0, 2)  # growth time, analyses per year
t0 = time.perf_counter()
if comm.rank == 0:
    output.mkdir(parents=True, exist_ok=True)
comm.barrier()

# %% [markdown]
# ## The jaw mesh
# Axes of the surface: $x$ forward (the chin at $x \approx 82$ mm), $y$ up (the condyles
# at the top, $y \approx 30$–43 mm), $z$ across (the jaw is symmetric about $z = 0$).  Facet groups
# chosen on the surface: `condyles` (triangles with their centroid in the box
# $0 \le x \le 50$ mm, $y \ge 25$ mm: the condylar and coronoid processes, both sides)
# and `teeth` (centroid in $30 \le x \le 90$ mm, $-10 \le y \le 10$ mm, outward normal
# within 45° of $+y$: the upper face of the alveolar part, where the teeth stand; the
# surface has no single teeth).  `bone_from_surface` meshes the closed surface with its own
# 4 mm triangles (remeshing this thin bone is refused), and a shell of 2 mm inside it
# gives the cell groups `mandible_cortical` and `mandible_cancellous`.
#
# The cyst's cell group `cyst` (a ball of radius $R_0$ at the chosen centre) is put into
# the cancellous core by the same gmsh rebuild the growth uses
# (`bonecontact.neoplasm.host3d.build_host_mesh3d`): the ball's surface is a geodesic
# sphere, the tetrahedra inside it become `cyst`, the cancellous core is meshed around
# it.

# %%
REGIONS = [
    SurfaceRegion("condyles", box=((0.0, 0.025, -0.06), (0.05, 0.05, 0.06))),
    SurfaceRegion(
        "teeth", cone=((0.0, 1.0, 0.0), 45.0), box=((0.03, -0.01, -0.05), (0.09, 0.01, 0.05))
    ),
]
bone_msh, jaw_msh = output / "mandible_bone.msh", output / "mandible.msh"
bone_from_surface(
    anatomy_surface("mandible"),
    h=H_BONE,
    cortical_thickness=CORTEX,
    name="mandible",
    regions=REGIONS,
    remesh=False,
    path=bone_msh,
    comm=comm,
)
# the cyst region: one tetrahedron at the centre marks it, the rebuild puts the ball there
geo = read_host_geometry3d(bone_msh) if comm.rank == 0 else None
if comm.rank == 0:
    tag, tets = geo.cells["mandible_cancellous"]
    centre_cell = int(np.argmin(np.linalg.norm(geo.x[tets].mean(axis=1) - CYST, axis=1)))
    geo.cells["mandible_cancellous"] = (tag, np.delete(tets, centre_cell, axis=0))
    geo.cells["cyst"] = (1 + max(t for t, _ in geo.cells.values()), tets[[centre_cell]])
ball = sphere_surface(CYST, R0, R0 / 8)
jaw = build_host_mesh3d(
    geo,
    "cyst",
    ("mandible_cancellous",),
    *ball,
    cavity=False,
    h_neo=R0 / 8,
    path=jaw_msh,
    comm=comm,
)
if comm.rank == 0:
    print(f"jaw mesh: {jaw.cells} tetrahedra, cyst volume {jaw.neoplasm_area * 1e9:.2f} mm³")

# %% [markdown]
# ## The coupled scene
# `[neoplasm]` grows the cyst in monthly steps and, twice a year, runs `[analysis]` on the
# rebuilt jaw.  The bite traction
# is $F/A$ with $A$ the teeth area of the mesh.

# %%
if comm.rank == 0:
    g = read_host_geometry3d(jaw_msh)
    tri = g.x[g.facets["teeth"][1]]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    teeth_area = float(area.sum())
else:
    teeth_area = None
teeth_area = comm.bcast(teeth_area, root=0)
t_bite = F_BITE / teeth_area  # Pa, downwards
SCENE = f"""format = 1
[scene]
name = "jaw3d"
mesh = "{jaw_msh}"
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
t_end = {years * YEAR:.9e}
dt = {YEAR / 12:.9e}
mechanics_every = {12 // per_year}

[neoplasm.cyst]
model = "sphere"
beta = 3.2e-11
C_minus = 1.0

[output]
directory = "results"
fields_every = 1
"""
if comm.rank == 0:
    (output / "jaw3d.toml").write_text(SCENE)
comm.barrier()
res = run_scene(load_scene(output / "jaw3d.toml"), comm, output=output, progress=False)
if res.status != "converged":
    raise SystemExit(f"the coupled run failed: {res.summary.get('message')}")
analyses = res.summary["coupling"]["analyses"]
if comm.rank == 0:
    print(f"bite traction {t_bite / 1e6:.3f} MPa on {teeth_area * 1e6:.0f} mm² of teeth")
    for a in analyses:
        print(
            f"t = {a['time'] / YEAR:.2f} years: R = {a['equivalent_radius'] / MM:.2f} mm, "
            f"cavity {a['neoplasm_volume_in_bone'] * 1e9:.1f} mm³, {a['cells']} tetrahedra, "
            f"p = {a['cavity_pressure_Pa'] / 1e3:.2f} kPa"
        )

# %% [markdown]
# ## The stress next to the cyst
# From each analysis's fields: the largest von Mises stress of the cells within 1 mm of
# the cyst wall (cell centroids with $|x - x_c| \le R + 1$ mm: the cancellous bone
# lining the cyst), against the growth time, beside the cyst's radius.  What to expect:
# the lumen's osmotic excess pressure is tens of pascals, so the stress next to the cyst
# is the bite's, concentrated at the rim of a hole in the soft cancellous core; it
# changes little while the cyst stays inside the core (full run: 0.40, 0.39, 0.40 and
# 0.41 MPa at R = 2.5, 3.0, 3.5 and 4.0 mm), an order of magnitude below the stress in
# the cortical shell over the cyst (3.9 and 4.6 MPa within 3 mm of the wall at R = 3.5
# and 4.0 mm).

# %%
NEAR = 1 * MM


def near_cyst_stress(directory: Path, radius: float) -> float:
    """Largest von Mises stress (Pa) of the cells within NEAR of the cyst wall."""
    grid = bp.read_fields(sorted(Path(directory).glob("fields*.pvd"))[-1])
    centres = np.asarray(grid.cell_centers().points)
    near = np.linalg.norm(centres - CYST, axis=1) <= radius + NEAR
    return float(np.asarray(grid.cell_data["von_mises"])[near].max())


if comm.rank == 0:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    growth = np.genfromtxt(output / "growth.csv", delimiter=",", names=True)
    near = [near_cyst_stress(a["directory"], a["equivalent_radius"]) for a in analyses]
    with open(output / "near_cyst.csv", "w") as f:
        f.write("time,equivalent_radius,cavity_volume,max_von_mises_near_cyst\n")
        for a, s in zip(analyses, near):
            f.write(
                f"{a['time']:.9g},{a['equivalent_radius']:.9g},"
                f"{a['neoplasm_volume_in_bone']:.9g},{s:.9g}\n"
            )
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    a1.plot(growth["time"] / YEAR, growth["equivalent_radius"] / MM, "-", label="growth.csv")
    a1.plot(
        [a["time"] / YEAR for a in analyses],
        [a["equivalent_radius"] / MM for a in analyses],
        "o",
        label="analyses",
    )
    a1.legend()
    bp.line_axes(a1, ("growth time", "years"), ("cyst radius", "mm"), zero=True)
    a2.plot([a["time"] / YEAR for a in analyses], np.array(near) / 1e6, "s-")
    bp.line_axes(
        a2, ("growth time", "years"), ("max von Mises, ≤ 1 mm from the cyst", "MPa"), zero=True
    )
    fig.suptitle(f"jaw3d: cyst growth and the stress next to it (bite force {F_BITE:.0f} N)")
    fig.tight_layout()
    bp.show(fig, output / "jaw3d_growth.png", dpi=120)

# %% [markdown]
# ## The jaw around the cyst: von Mises stress
# The part of the jaw up to the plane $z = z_c$ through the cyst's centre, seen face-on
# (the cut face shows the cavity and the bone around it) on its undeformed coordinates,
# the dashed line the outline of the deformed cut with the displacement magnified by the
# stated factor, at the first and the last analysis; then the same cut cropped to a 16 mm
# square about the cyst.  The cell stresses are projected to the vertices within each
# region (cortex, cancellous bone), and each colour range stops at a round number that
# leaves at most 1 % of the cut's area above it (the clip stated in the colour-bar label).


# %%
def cell_regions(grid, directory: Path) -> np.ndarray:
    """A label per cell of ``grid``: its region in the rebuilt mesh (matched by centroid)."""
    from scipy.spatial import cKDTree

    g = read_host_geometry3d(Path(directory) / "host_mesh.msh")
    names = sorted(g.cells)
    centres = np.vstack([g.x[g.cells[k][1]].mean(axis=1) for k in names])
    labels = np.concatenate([np.full(len(g.cells[k][1]), i) for i, k in enumerate(names)])
    _, idx = cKDTree(centres).query(np.asarray(grid.cell_centers().points))
    return labels[idx]


def stress_pictures(a: dict, label: str) -> list[Path]:
    """The cut jaw and the cut square about the cyst of analysis ``a``: two PNGs."""
    grid = bp.read_fields(sorted(Path(a["directory"]).glob("fields*.pvd"))[-1])
    grid.cell_data["region"] = cell_regions(grid, Path(a["directory"]))  # kept by the clips
    cut = grid.clip(normal=(0.0, 0.0, 1.0), origin=CYST, invert=True)
    u = np.asarray(grid.point_data["displacement"])
    warp = float(2 * MM / max(np.abs(u).max(), 1e-30))  # rounded down by field_view
    title = (
        f"jaw3d: von Mises stress after {a['time'] / YEAR:.1f} years, "
        f"cyst R = {a['equivalent_radius'] / MM:.1f} mm, bite {F_BITE:.0f} N"
    )
    lo, hi = CYST - 8 * MM, CYST + 8 * MM
    crop = cut.clip_box([lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]], invert=False)
    pngs = []
    for g, name, what in (
        (cut, f"jaw3d_von_mises_{label}.png", ", cut at the cyst's centre"),
        (crop, f"jaw3d_von_mises_cyst_{label}.png", ", 16 mm about the cyst"),
    ):
        pngs.append(
            bp.field_view(
                g,
                "von_mises",
                output / name,
                quantity="von Mises stress",
                unit="MPa",
                displacement="displacement",
                warp=warp,
                title=title + what,
                cmap="inferno",
                regions=g.cell_data["region"],
                view="xy",
                axis_titles={"x": "x, forward", "y": "y, up"},
                directions={"anterior": (1.0, 0.0, 0.0), "superior": (0.0, 1.0, 0.0)},
                markers=[bp.Marker([CYST], "cyst centre", "tab:blue", "+", 12)],
            )
        )
    return pngs


if comm.rank == 0:
    for a, label in ((analyses[0], "first"), (analyses[-1], "last")):
        for png in stress_pictures(a, label):
            bp.show(png, png)
    print(f"pictures in {output}")
    print(f"wall time {time.perf_counter() - t0:.0f} s on {comm.size} rank(s)")
comm.barrier()
