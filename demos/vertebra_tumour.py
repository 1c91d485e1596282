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
# # A vertebral body with a tumour: growth, fracture risk, a crack to the endplate
#
# A 2D (plane-strain) sagittal section of a lumbar vertebral body, 30 mm deep
# (anterior–posterior) and 24 mm high: a cortical shell (1 mm anterior and posterior
# walls, 1 mm endplates) around a cancellous core, between two intervertebral discs
# (8 mm soft layers, bonded to the endplates).  The spine's compressive load enters
# through the upper disc; the lower disc rests on the vertebra below (fixed).  A tumour
# starts as a 3 mm disc of soft tissue in the centre of the cancellous core and grows.
#
# The storyline:
#
# 1. **growth and risk** — the tumour grows (the free-boundary model of
#    `demos/knee_tumour.py`), the host mesh is rebuilt around it by gmsh every few days
#    and loaded by the standing load; the coupled scene's `[fracture]` table evaluates
#    the initiation risk $\max_\text{cells} \sigma_1/\sigma_t$ of the bone on every
#    rebuilt mesh;
# 2. **crack** — at the first state where the risk reaches 1, a flaw is put on the line
#    through the location of the largest risk, normal to the largest principal stress, and
#    grown by the crack scenes of `bonecontact` (`[[crack]]`, `[fracture] propagate = true`)
#    as the load ramps up to a lifting load, until it reaches a free surface: the
#    vertebral body has fractured;
# 3. **fragments** — the crack faces are a Coulomb contact pair all along.  While the
#    crack runs they open (it runs along the compression, pulled open by the hoop tension
#    at the lesion's pole); after the fracture the fractured body is loaded as in a
#    forward bend, held sideways by the shell: the faces close, and the fragments press
#    and rub on each other through the Coulomb pair.
#
# `python demos/vertebra_tumour.py [OUTPUT_DIR]`, `mpiexec -n 2 python
# demos/vertebra_tumour.py`, or as a notebook.  `BONECONTACT_DEMO_QUICK=1` takes coarser
# meshes, an analysis every 6 days instead of 4 and a longer crack increment (what the
# test suite runs).
# Units: SI, 2D forces per metre of thickness.
#
# ## The load
# The compressive force on a lumbar vertebra is about 0.5 kN standing and 2–3.5 kN when a
# load is lifted with a bent back (intradiscal-pressure and telemetry measurements,
# e.g. Wilke et al. 1999, Spine 24:755).  A section per metre of a vertebral body about
# 45 mm wide (left–right) and 30 mm deep carries $F/(0.045\,\text{m})$; the growth
# analyses take the *standing* load $F = 0.675$ kN as a uniform traction
# $p = F/(0.045 \cdot 0.030)\ \text{m}^2 = 0.5$ MPa on the top of the upper disc; the
# crack analysis ramps it in four steps up to the *lifting* load, four times as much
# ($F = 2.7$ kN, $p = 2$ MPa: the activity factor 4).  The risk is linear in the load.
#
# ## Mechanics
# Each analysis solves, from an unstressed state on the rebuilt mesh,
#
# $$-\nabla\cdot\mathbb C\,e(u) = 0, \qquad u = 0 \ \text{under the lower disc}, \qquad
# \sigma n = (0, -p) \ \text{on the upper disc},$$
#
# with isotropic layers: cortical shell $E = 17$ GPa, $\nu = 0.3$ (`[material.cortical_bone]`,
# along the osteons: the direction of the load); cancellous core $E = 326$ MPa, $\nu = 0.25$
# (`[material.cancellous_bone_vertebral_018]`); disc 10 MPa, 0.45 (a homogenised annulus
# and nucleus); tumour 50 kPa, $\nu = 0.49$ (near-fluid, average nodal pressure against
# locking).
#
# ## Initiation risk
# Per cell, from the principal stresses $\sigma_1 \ge \sigma_2$ of the P1 solution,
#
# $$ r = \frac{\sigma_1}{\sigma_t}, $$
#
# the tension criterion: a crack opens where the largest principal stress reaches the
# tensile strength, normal to its direction.  Each bone's modulus and strength are those of
# one bone (`data/materials.toml`; tests/unit/materials/test_strength_pairs.py checks the
# pairs).  Cancellous bone: $\sigma_t = 1.75$ MPa, the mean tensile yield stress of
# vertebral trabecular bone of apparent density 0.18 g/cm³ (Kopperdahl & Keaveny 1998,
# `[strength.cancellous_bone_vertebral_018]`), with the modulus of that density,
# $E = 4730\,\rho^{1.56}$ MPa = 326 MPa (Morgan, Bayraktar & Keaveny 2003): yield strain
# $\sigma_t/E + 0.2\,\% = 0.74\,\%$ against the measured $0.78 \pm 0.04\,\%$.  Cortical shell:
# $\sigma_t = 133$ MPa and $E = 17$ GPa, both along the osteons (Reilly & Burstein 1975).
# Until 2026-12-03 the core was 1 GPa and the shell 12 GPa (a transverse modulus) with the
# same strengths: yield strains 0.38 % and 1.31 %, a modulus of one bone with the strength
# of another; the stiffer core carried more of the load (the risk reached 1 at day 18 of
# the quick run, now at day 24; day 20 of the full run).  The discs are given an annulus
# tensile strength of 10 MPa and the tumour an arbitrary 1 MPa (both stay far below 1:
# they are not what fractures; the scene marks them `strength_pair_exception`).  Crushing
# of the cancellous bone in compression (σ_c ≈ 1.9 MPa) is a different failure — a
# compression fracture — that this demo does not follow.

# %%
import sys
from pathlib import Path

from mpi4py import MPI  # before dolfinx

import numpy as np

import bonecontact.plot as bp
from bonecontact.common.constants import SECONDS_PER_DAY
from bonecontact.materials.library import stiffness_and_strength
from bonecontact.runners import run_scene
from bonecontact.scene import load_scene

comm = MPI.COMM_WORLD
here = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
args = [a for a in sys.argv[1:] if not a.startswith("-")] if "__file__" in globals() else []
# results: the first argument, else $BONECONTACT_OUTPUT/vertebra_tumour, else demos/results/...
output = bp.output_dir("vertebra_tumour", here, args)
quick = bp.quick_mode()

MM = 1e-3
W, H, T, D = 30 * MM, 24 * MM, 1.0 * MM, 8 * MM  # body depth, height, shell, disc height
TUMOUR = (0.0, H / 2, 3 * MM)  # centre and initial radius
P = 0.5e6  # Pa: the standing load on the upper disc (see above)
LIFT = 4.0  # activity factor of lifting
h = (1.2 if quick else 0.7) * MM  # mesh size (half of it around the tumour)
days, every = 24, (6 if quick else 4)  # growth time, days between analyses
#: bone: the stiffness and the strength of one bone each (data/materials.toml): the
#: cancellous core at the apparent density of its measured strength, the cortical shell
#: along the osteons (both from Reilly & Burstein)
CORE, SHELL = "cancellous_bone_vertebral_018", "cortical_bone"
E_CANC, NU_CANC, SIGMA_T_CANC = stiffness_and_strength(CORE)
E_CORT, NU_CORT, SIGMA_T_CORT = stiffness_and_strength(SHELL)
if comm.rank == 0:
    output.mkdir(parents=True, exist_ok=True)
comm.barrier()

# %% [markdown]
# ## The section (gmsh)
# Cell groups `disc_upper`, `disc_lower`, `cortical`, `cancellous`, `tumour`; facet groups
# `disc_top` (loaded) and `disc_bottom` (fixed).  The vertebra spans $0 \le y \le H$.


# %%
def vertebra_mesh(path: Path) -> None:
    if comm.rank == 0:
        import gmsh

        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        x0 = -W / 2
        parts = [
            occ.addRectangle(x0, H, 0, W, D),  # upper disc
            occ.addRectangle(x0, -D, 0, W, D),  # lower disc
            occ.addRectangle(x0, 0, 0, W, H),  # vertebral body
            occ.addRectangle(x0 + T, T, 0, W - 2 * T, H - 2 * T),  # cancellous core
            occ.addDisk(*TUMOUR[:2], 0, TUMOUR[2], TUMOUR[2]),
        ]
        _, m = occ.fragment([(2, p) for p in parts], [])
        occ.synchronize()
        tum = [t for d, t in m[4] if d == 2]
        canc = [t for d, t in m[3] if d == 2 and t not in tum]
        cort = [t for d, t in m[2] if d == 2 and t not in tum + canc]
        groups = {
            "disc_upper": [t for d, t in m[0] if d == 2],
            "disc_lower": [t for d, t in m[1] if d == 2],
            "cortical": cort,
            "cancellous": canc,
            "tumour": tum,
        }
        for k, (name, ss) in enumerate(groups.items()):
            gmsh.model.addPhysicalGroup(2, ss, 1 + k, name=name)
        rim = [
            abs(t)
            for _, t in gmsh.model.getBoundary(
                [(2, s) for s in sum(groups.values(), [])], combined=True
            )
        ]
        com = {c: occ.getCenterOfMass(1, c) for c in rim}
        top = [c for c in rim if abs(com[c][1] - (H + D)) < 1e-9]
        bottom = [c for c in rim if abs(com[c][1] + D) < 1e-9]
        gmsh.model.addPhysicalGroup(1, top, 10, name="disc_top")
        gmsh.model.addPhysicalGroup(1, bottom, 11, name="disc_bottom")
        f = gmsh.model.mesh.field
        d = f.add("Distance")
        f.setNumbers(d, "PointsList", [occ.addPoint(*TUMOUR[:2], 0)])
        occ.synchronize()
        th = f.add("Threshold")
        f.setNumber(th, "InField", d)
        f.setNumber(th, "SizeMin", h / 2)
        f.setNumber(th, "SizeMax", h)
        f.setNumber(th, "DistMin", 3 * TUMOUR[2])
        f.setNumber(th, "DistMax", 4 * TUMOUR[2])
        f.setAsBackgroundMesh(th)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
        gmsh.finalize()
    comm.barrier()


vertebra_mesh(output / "vertebra.msh")

# %% [markdown]
# ## The coupled scene: growth, analyses, risk
# `[neoplasm]` (the tumour, free to grow into the cancellous core), `[analysis]` (the
# lifting load) and `[fracture]` (the risk after every analysis).  The tumour grows as in
# `demos/knee_tumour.py`: quasi-steady nutrient $-D_c\Delta u_c + \lambda u_c = 0$,
# $-\Delta\sigma = \mu(u_c - \tfrac12)$ in the tumour, $u_c = 1$, $\sigma = 0$ and normal
# velocity $V_n = -\partial_n\sigma$ on its boundary, with $D_c = 10^{-9}$ m²/s,
# $\lambda = 10^{-5}$ 1/s (nutrient length 10 mm) and $\mu = 1/(5\ \text{days})$ — an
# aggressive, illustrative rate, not fitted to a patient; 2-day growth steps.

# %%
SCENE = f"""format = 1
[scene]
name = "vertebra_tumour"
mesh = "{{mesh}}"
dimension = 2

[analysis]
kind = "static"
load_steps = 1

[solver]
linear = "direct"

[[material]]
name = "cortical"
regions = ["cortical"]
model = "isotropic"
E = {E_CORT!r}
nu = {NU_CORT!r}
sigma_t = {SIGMA_T_CORT!r}

[[material]]
name = "cancellous"
regions = ["cancellous"]
model = "isotropic"
E = {E_CANC!r}
nu = {NU_CANC!r}
sigma_t = {SIGMA_T_CANC!r}

[[material]]
name = "disc"
regions = ["disc_upper", "disc_lower"]
# strength_pair_exception: not bone; an annulus tensile strength that only keeps R defined
model = "isotropic"
E = 10.0e6
nu = 0.45
sigma_t = 10.0e6

[[material]]
name = "tumour"
regions = ["tumour"]
# strength_pair_exception: not bone; an arbitrary strength that only keeps R defined
model = "isotropic"
E = 5.0e4
nu = 0.49
formulation = "nodal_pressure"
sigma_t = 1.0e6

[[dirichlet]]
boundary = "disc_bottom"
value = [0.0, 0.0]

[[traction]]
boundary = "disc_top"
value = [0.0, {-P}]

[output]
directory = "results"
fields_every = 1
"""
RISK = """
[fracture]
criterion = "tension"
"""
GROWTH = f"""
[neoplasm]
kind = "tumour"
region = "tumour"
host = ["cancellous"]
t_end = {days * SECONDS_PER_DAY}
dt = {2 * SECONDS_PER_DAY}
remesh_every = 1
mechanics_every = {every // 2}

[neoplasm.tumour]
D_c = 1.0e-9
lambda = 1.0e-5
eps0 = 0.0
u_c1 = 1.0
K_B = "{1 / (5 * SECONDS_PER_DAY):.8e}*(u_c - 0.5)"
K_Q = 0.0
K_A = 0.0
K_P = 0.0
K_D = 0.0
K_R = 0.0
gamma = 0.0
u_p0 = 1.0
u_q0 = 0.0
"""


def run_text(text: str, path: Path, out: Path, what: str):
    """Write the scene ``text`` to ``path``, run it into ``out``; the run's result."""
    if comm.rank == 0:
        path.write_text(text)
    comm.barrier()
    res = run_scene(load_scene(path), comm, output=out, progress=False)
    if res.status != "converged":
        raise SystemExit(f"{what} failed: {res.summary.get('message')}")
    return res


grown = run_text(
    SCENE.format(mesh=output / "vertebra.msh") + GROWTH + RISK,
    output / "vertebra_tumour.toml",
    output,
    "the growth run",
)
# every analysis ran the risk check on its rebuilt mesh: its largest risk, where, and the
# direction of a crack started there are in its record (summary.json coupling.analyses)
risk = [  # (day, R, max risk, location, crack direction, directory)
    (
        a["time"] / SECONDS_PER_DAY,
        a["equivalent_radius"],
        a["max_risk"],
        a["max_risk_location"],
        a["max_risk_crack_direction"],
        Path(a["directory"]),
    )
    for a in grown.summary["coupling"]["analyses"]
]
if comm.rank == 0:
    with open(output / "risk.csv", "w") as f:
        f.write("day,equivalent_radius,max_risk,x,y,crack_dir_x,crack_dir_y\n")
        for day, R, r, loc, cd, _ in risk:
            f.write(
                f"{day:.6g},{R:.9g},{r:.9g},{loc[0]:.9g},{loc[1]:.9g},{cd[0]:.9g},{cd[1]:.9g}\n"
            )
    for day, R, r, loc, cd, _ in risk:
        print(
            f"day {day:4.0f}: R = {1e3 * R:.2f} mm, max risk {r:.3f} at "
            f"({1e3 * loc[0]:.2f}, {1e3 * loc[1]:.2f}) mm, crack direction ({cd[0]:.2f}, {cd[1]:.2f})"
        )

# %% [markdown]
# ## Risk over the growth
# The largest risk of each analysis against the growth time.  It is linear in the load:
# the dashed line is the same risk under the lifting load (activity factor 4), which is
# what the crack analysis below ramps to.

# %%
if comm.rank == 0:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4))
    t_days = [r[0] for r in risk]
    ax.plot(t_days, [r[2] for r in risk], "o-", label=f"standing, p = {P / 1e6:.1f} MPa")
    ax.plot(
        t_days, [LIFT * r[2] for r in risk], "s--", label=f"lifting, p = {LIFT * P / 1e6:.1f} MPa"
    )
    ax.axhline(1.0, color="k", lw=0.8, label="fracture initiates (risk 1)")
    ax.set_ylim(bottom=0.0)
    for day, R, rr, *_ in risk:
        ax.annotate(
            f"R = {1e3 * R:.1f} mm",
            (day, rr),
            textcoords="offset points",
            xytext=(0, -14),
            ha="center",
            fontsize=8,
        )
    ax.legend()
    bp.line_axes(ax, ("growth time", "days"), (r"largest risk $\sigma_1/\sigma_t$ in the bone", ""))
    fig.suptitle("vertebra_tumour: initiation risk as the tumour grows")
    fig.tight_layout()
    bp.show(fig, output / "vertebra_risk.png", dpi=120)

# %% [markdown]
# ## The crack
# The first analysis whose risk reaches 1 gives the crack: it starts at the cell of the
# largest risk and runs normal to $\sigma_1$ there (for a soft inclusion under vertical
# compression $\sigma_1$ is the horizontal hoop tension at the lesion's poles, so the crack
# is vertical, towards an endplate).
#
# The crack scenes of this version cut the crack into a body of **one** cell group, so
# the crack analysis takes the vertebral body alone, homogenised to cancellous bone
# (the thin shell's share of the load is neglected: conservative), with the tumour as a
# cavity (at 50 kPa it carries next to nothing) and the disc replaced by the load it
# transmits, a uniform pressure on the upper endplate (the nucleus is nearly a fluid);
# the lower endplate is held.  The initial flaw lies on the line of largest risk,
# centred in the ligament between the lesion wall and the endplate, a quarter of the
# ligament long, with two tips: the vertebral body has fractured when the crack has cut
# through the ligament (a tip reaches the lesion or the endplate).  (A crack scene can
# also insert the crack itself, `[fracture] initiate = true`: in this body (the quick
# run's day-24 lesion) it starts at the lesion's upper pole at 0.22 of the lifting load,
# normal to the hoop tension, and runs up towards the upper endplate; a run of 2026-12-03
# stopped while it grew, with an input error of the re-meshed crack faces' contact (a face
# node 2.7 mm across the other face; not yet investigated).  With the former day-18
# lesion it started at 0.38 of the lifting load and arrested 1.3 mm below the upper
# endplate, where the endplate's compression closes its faces ($K_I < 0$).  The flaw in
# the ligament follows the storyline to a fracture.)
#
# The load ramps in four steps from the standing load to the lifting load; at every step
# the tip's $K_I$, $K_{II}$ come from the interaction integral (crack-face contact tractions
# as face term) and the tip grows by $\Delta a$ in the direction of maximum tangential
# stress, $\theta = 2\arctan\big[(K_I - \sqrt{K_I^2 + 8K_{II}^2})/(4K_{II})\big]$, while
#
# $$ K_\text{eq} = \cos\tfrac{\theta}{2}\Big[K_I\cos^2\tfrac{\theta}{2} - \tfrac32 K_{II}\sin\theta\Big] \ \ge\ K_{Ic}, $$
#
# re-meshing around the longer crack and solving the same load again, until the tip
# holds or comes within $\Delta a$ of the surface (fracture).  $K_{Ic} = 0.006$ MPa√m is
# an *assumed* toughness, far below the values reported for trabecular bone (of the order
# of 0.1 MPa√m and more): with a flaw of about a millimetre, $K_I$ at the lifting load
# is only 0.015–0.02 MPa√m here (full and quick run; 0.008 with the former day-18
# lesion), so with a realistic toughness the flaw would hold.  The
# value is chosen so that the flaw holds under the standing load and grows while lifting:
# the analysis shows the mechanism — where the crack runs and how $K$ rises as it
# grows — not a prediction of when the vertebra breaks.  (The crack and fragment runs are
# one material under given loads: their stresses and $K$ do not depend on $E$.)  The crack
# faces are a Coulomb contact pair, $\mu = 0.4$ (assumed for rough bone fracture surfaces):
# closed faces carry $\lambda_n \ge 0$ and $|\lambda_t| \le \mu\lambda_n$.

# %%
first = next((r for r in risk if r[2] >= 1.0), None)
if first is None:
    raise SystemExit("the risk never reached 1: grow the tumour longer")
day0, R0, r0, loc, cdir, rdir = first
lesion = np.genfromtxt(rdir / "neoplasm_boundary.csv", delimiter=",", names=True)
lesion = np.column_stack([lesion["x"], lesion["y"]])
centre = lesion.mean(axis=0)
cdir = np.asarray(cdir) / np.linalg.norm(cdir)
if np.dot(cdir, np.asarray(loc) - centre) < 0:
    cdir = -cdir  # pointing away from the lesion
da = (0.5 if quick else 0.35) * MM
# the ligament between the lesion wall (at the largest risk) and the endplate along the
# crack line; the crack is centred in it, a quarter of its length
loc = np.asarray(loc)
exits = [
    (b - loc[i]) / cdir[i]
    for i, b in ((0, -W / 2), (0, W / 2), (1, 0.0), (1, H))
    if abs(cdir[i]) > 1e-12
]
ligament = min(t for t in exits if t > 0)
mid = loc + 0.5 * ligament * cdir
crack0 = np.array([mid - ligament / 8 * cdir, mid + ligament / 8 * cdir])


def cracked_body_mesh(path: Path, split: bool = False) -> None:
    """The vertebral body with the lesion as a cavity: cell group ``vertebral_body``,
    facets ``upper_endplate``, ``lower_endplate``, ``walls``, ``lesion``; ``split``: the
    upper endplate in two halves, ``upper_anterior`` (x < 0) and ``upper_posterior``."""
    if comm.rank == 0:
        import gmsh

        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        body = occ.addRectangle(-W / 2, 0, 0, W, H)
        pts = [occ.addPoint(x, y, 0) for x, y in lesion]
        lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
        hole = occ.addPlaneSurface([occ.addCurveLoop(lines)])
        out, _ = occ.cut([(2, body)], [(2, hole)])
        if split:  # a vertex in the middle of the upper endplate
            out, _ = occ.fragment(out, [(0, occ.addPoint(0.0, H, 0))])
        occ.synchronize()
        surf = [t for d, t in out if d == 2]
        gmsh.model.addPhysicalGroup(2, surf, 1, name="vertebral_body")
        rim = [abs(t) for _, t in gmsh.model.getBoundary([(2, s) for s in surf], combined=False)]
        com = {c: occ.getCenterOfMass(1, c) for c in rim}
        pick = {
            "upper_endplate": [c for c in rim if abs(com[c][1] - H) < 1e-9],
            "lower_endplate": [c for c in rim if abs(com[c][1]) < 1e-9],
            "walls": [c for c in rim if abs(abs(com[c][0]) - W / 2) < 1e-9],
        }
        pick["lesion"] = [c for c in rim if not any(c in v for v in pick.values())]
        if split:
            upper = pick.pop("upper_endplate")
            pick["upper_anterior"] = [c for c in upper if com[c][0] < 0]
            pick["upper_posterior"] = [c for c in upper if com[c][0] > 0]
        for k, (name, cs) in enumerate(pick.items()):
            gmsh.model.addPhysicalGroup(1, cs, 10 + k, name=name)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
        gmsh.finalize()
    comm.barrier()


cracked_body_mesh(output / "vertebral_body.msh")

# %%
CRACK = f"""format = 1
[scene]
name = "vertebra_crack"
mesh = "{output / "vertebral_body.msh"}"
dimension = 2

[analysis]
kind = "static"
load_steps = 4

[solver]
linear = "direct"

[[material]]
name = "cancellous"
regions = ["vertebral_body"]
model = "isotropic"
E = {E_CANC!r}
nu = {NU_CANC!r}
sigma_t = {SIGMA_T_CANC!r}
K_Ic = 0.006e6

[[dirichlet]]
boundary = "lower_endplate"
value = [0.0, 0.0]

[[traction]]
boundary = "upper_endplate"
value = [0.0, {-LIFT * P}]

[fracture]
criterion = "tension"
direction = "mts"
propagate = true
increment = {da}
max_increments = 40

[[crack]]
name = "split"
points = {crack0.tolist()}
tips = "both"
region = "vertebral_body"
coefficient = 0.4

[output]
directory = "results"
fields_every = 1
"""
cracked = run_text(CRACK, output / "vertebra_crack.toml", output / "crack", "the crack run")
cs = cracked.summary["fracture"]["crack"]
if comm.rank == 0:
    pr = cs["propagation"]
    print(
        f"crack from day {day0:.0f} (R = {1e3 * R0:.2f} mm, risk {r0:.2f}): {pr['status']} after "
        f"{pr['increments']} increments, length {1e3 * cs['length']:.2f} mm, "
        f"end at ({1e3 * cs['points'][-1][0]:.2f}, {1e3 * cs['points'][-1][1]:.2f}) mm"
    )

# %% [markdown]
# ## The crack path over the stress field, and K against crack length
# Left: the largest principal stress $\sigma_1$ of the last cracked state (the mesh of
# the last crack increment) with the initial flaw and the path.  Right: $K_I$ of each tip
# against the crack length at the load step in which the crack ran through (the row of
# each increment at that step), with $K_{Ic}$.

# %%
if comm.rank == 0:
    import matplotlib.patches
    import matplotlib.tri as mtri

    fr = np.genfromtxt(
        output / "crack" / "fracture.csv", delimiter=",", names=True, dtype=None, encoding="utf-8"
    )
    pvds = sorted((output / "crack").glob("fields*.pvd"), key=lambda p: p.stat().st_mtime)
    grid = bp.read_fields(pvds[-1])
    cells = grid.cells.reshape(-1, 4)[:, 1:]
    xy = 1e3 * grid.points[:, :2]
    s1 = np.asarray(grid.cell_data["principal_stress"]).reshape(grid.n_cells, -1).max(axis=1) / 1e6
    path = 1e3 * np.asarray(cs["points"])
    last = fr[fr["step"] == fr["step"].max()]  # the load step the crack ran at
    p_end = LIFT * P * float(last["time"][0])  # static pseudo-time = load factor
    fig, (a1, a3, a2) = plt.subplots(
        1, 3, figsize=(16, 5), gridspec_kw={"width_ratios": [1.3, 1, 1]}
    )
    trimesh = mtri.Triangulation(xy[:, 0], xy[:, 1], cells)
    # σ₁ projected to the vertices (lumped L² projection): continuous, no cell-wise
    # checkerboard; a symmetric range leaving at most 1 % of the area outside
    e1, e2 = xy[cells[:, 1]] - xy[cells[:, 0]], xy[cells[:, 2]] - xy[cells[:, 0]]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    s1_nodal, w_nodal = bp.lumped_projection(cells, s1, area, len(xy))
    cr = bp.auto_range(np.abs(s1_nodal), w_nodal)
    cr = bp.ColorRange(-cr.vmax, cr.vmax, cr.data_max, cr.clipped_fraction, -cr.data_max)
    zoom = (path.min(axis=0) - 1.5, path.max(axis=0) + 1.5)  # mm around the crack
    for ax in (a1, a3):
        pc = ax.tripcolor(trimesh, s1_nodal, shading="gouraud", cmap="RdBu_r", vmin=cr.vmin,
                          vmax=cr.vmax)  # fmt: skip
        if ax is a3:
            ax.triplot(trimesh, color="0.6", lw=0.1)
        ax.plot(*(1e3 * np.vstack([lesion, lesion[:1]])).T, "k-", lw=1, label="lesion (tumour)")
        ax.plot(*(1e3 * crack0).T, "c-", lw=4, label="initial flaw")
        ax.plot(*path.T, "y.-", lw=1.5, ms=4, label="crack path")
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
    bar = fig.colorbar(pc, ax=a1, extend="both" if cr.clipped else "neither")
    bar.set_label(
        r"$\sigma_1$ (MPa)"
        + (f"\nclipped at ±{cr.vmax:.3g} (max |σ₁| {cr.data_max:.3g})" if cr.clipped else "")
    )
    a1.add_patch(
        matplotlib.patches.Rectangle(zoom[0], *(zoom[1] - zoom[0]), fill=False, ec="g", lw=1)
    )
    a1.legend(loc="upper right", fontsize=8)
    a1.set_title(f"largest principal stress at p = {p_end / 1e6:.1f} MPa", fontsize=9)
    a3.set_xlim(zoom[0][0], zoom[1][0])
    a3.set_ylim(zoom[0][1], zoom[1][1])
    a3.set_title("zoom (green box): the path and the tip meshes", fontsize=9)

    K_Ic = cracked.summary["fracture"]["crack"]["propagation"]["K_Ic"]
    for tip, name in ((0, "tip towards the lesion"), (-1, "tip towards the endplate")):
        rows = last[last["tip"] == tip]
        a2.plot(1e3 * rows["length"], rows["K_I"] / 1e6, "o-", label=f"$K_I$, {name}")
    a2.axhline(K_Ic / 1e6, color="k", ls="--", label=r"$K_{Ic}$ (assumed)")
    a2.legend(fontsize=8)
    bp.line_axes(a2, ("crack length", "mm"), (rf"$K_I$ at p = {p_end / 1e6:.1f} MPa", "MPa√m"))
    fig.suptitle(f"vertebra_tumour: crack from day {day0:.0f} — {cs['propagation']['status']}")
    fig.tight_layout()
    bp.show(fig, output / "vertebra_crack.png", dpi=120)

# %% [markdown]
# ## The crack faces: a Coulomb contact pair
# `contact_split.csv` holds the state of every crack-face node of the last solve: gap,
# contact pressure, tangential traction, slip and status (open, stick, slip).  Under
# vertical compression the crack across the lesion's pole opens (the hoop tension pulls
# its faces apart); faces that close would press and rub with $|\lambda_t| \le \mu\lambda_n$.

# %%
if comm.rank == 0:
    faces = np.genfromtxt(
        output / "crack" / "contact_split.csv",
        delimiter=",",
        names=True,
        dtype=None,
        encoding="utf-8",
    )
    states = {k: int((faces["status"] == k).sum()) for k in ("open", "stick", "slip")}
    closed = faces["status"] != "open"
    bound = np.all(
        np.abs(faces["traction_t"][closed]) <= 0.4 * faces["pressure"][closed] * (1 + 1e-6) + 1e-9
    )
    print(
        f"crack-face nodes: {states}; largest opening {1e6 * faces['gap'].max():.2f} µm; "
        f"|traction_t| <= mu pressure on closed nodes: {bool(bound)}"
    )
    print(f"pictures: {output / 'vertebra_risk.png'}, {output / 'vertebra_crack.png'}")
comm.barrier()

# %% [markdown]
# ## After the fracture: the fragments in frictional contact
# The crack has cut the ligament between the lesion and the endplate (to within one
# increment).  Is the fractured vertebral body still a load-bearing structure?  The
# fragments are held together only where the faces press on each other, and they can
# slide along each other where $|\lambda_t|$ would exceed $\mu\lambda_n$.
#
# One more static analysis of the fractured body (the final crack, not growing):
#
# * a forward bend while lifting: the upper endplate carries the lifting force, 90 % of
#   it on its anterior half ($x < 0$: 1.8 times the lifting pressure) and 10 % on the
#   posterior half (0.2 times): the same force as the uniform lifting load, its resultant
#   6 mm anterior of the centre;
# * the cortical shell, which the crack analysis left out, holds the body sideways: the
#   anterior and posterior walls do not move horizontally ($u_x = 0$, $u_y$ free);
# * the crack faces are the Coulomb pair of the crack run ($\mu = 0.4$).
#
# The shell's confinement closes the faces (in a body that cannot expand sideways the
# vertical compression $p$ brings a horizontal one, $\nu p/(1-\nu) = p/3$ far from the
# lesion), and the uneven load pushes the anterior fragment down along the posterior one:
# the faces carry compression and friction; where the friction needed exceeds
# $\mu\lambda_n$ the faces slip.  The totals are the pair's `normal_force`
# and `tangential_force` in `history.csv` (N per metre of thickness); every closed node
# satisfies Coulomb's law $|\lambda_t| \le \mu\lambda_n$ (`contact_split.csv`).


# %%
def boundary_distance(p: np.ndarray) -> float:
    """Distance from ``p`` to the lesion wall and the outline of the vertebral body (m)."""
    ring = np.vstack([lesion, lesion[:1]])
    box = np.array([[-W / 2, 0], [W / 2, 0], [W / 2, H], [-W / 2, H], [-W / 2, 0]])
    d = np.inf
    for poly in (ring, box):
        a, b = poly[:-1], poly[1:]
        t = np.clip(np.einsum("ij,ij->i", p - a, b - a) / np.einsum("ij,ij->i", b - a, b - a), 0, 1)
        d = min(d, float(np.linalg.norm(a + t[:, None] * (b - a) - p, axis=1).min()))
    return d


path_final = np.asarray(cs["points"])
d_tip = min(boundary_distance(path_final[0]), boundary_distance(path_final[-1]))
h_tip = min(da, 0.8 * d_tip) / 10  # four tip elements in the K domain of a tip near a surface
cracked_body_mesh(output / "vertebral_body_split.msh", split=True)
MU = 0.4
FRAGMENTS = f"""format = 1
[scene]
name = "vertebra_fragments"
mesh = "{output / "vertebral_body_split.msh"}"
dimension = 2

[analysis]
kind = "static"
load_steps = 1

[solver]
linear = "direct"

[[material]]
name = "cancellous"
regions = ["vertebral_body"]
model = "isotropic"
E = {E_CANC!r}
nu = {NU_CANC!r}
sigma_t = {SIGMA_T_CANC!r}

[[dirichlet]]
boundary = "lower_endplate"
value = [0.0, 0.0]

[[dirichlet]]
boundary = "walls"
value = [0.0, "free"]

[[traction]]
boundary = "upper_anterior"
value = [0.0, {-1.8 * LIFT * P}]

[[traction]]
boundary = "upper_posterior"
value = [0.0, {-0.2 * LIFT * P}]

[fracture]
criterion = "tension"
tip_size = {h_tip}

[[crack]]
name = "split"
points = {path_final.tolist()}
tips = "both"
region = "vertebral_body"
coefficient = {MU}

[output]
directory = "results"
fields_every = 1
"""
post = run_text(
    FRAGMENTS, output / "vertebra_fragments.toml", output / "fragments", "the fragments run"
)
if comm.rank == 0:
    hist = np.genfromtxt(
        output / "fragments" / "history.csv",
        delimiter=",",
        names=True,
        dtype=None,
        encoding="utf-8",
    )
    pair = hist[(hist["pair"] == "split") & (hist["step"] == hist["step"].max())][0]
    faces = np.genfromtxt(
        output / "fragments" / "contact_split.csv",
        delimiter=",",
        names=True,
        dtype=None,
        encoding="utf-8",
    )
    states = {k: int((faces["status"] == k).sum()) for k in ("open", "stick", "slip")}
    closed = faces["status"] != "open"
    ratio = np.abs(faces["traction_t"][closed]) / faces["pressure"][closed]
    print(
        f"after the fracture: crack faces {states}; contact force across the faces: normal "
        f"{pair['normal_force']:.4g} N/m, tangential {pair['tangential_force']:.4g} N/m "
        f"(ratio {pair['tangential_force'] / pair['normal_force']:.3f}, mu = {MU}); "
        f"largest |traction_t|/pressure of a closed node {ratio.max():.4f}; mean face "
        f"pressure {pair['normal_force'] / cs['length'] / 1e6:.3f} MPa (confined body far "
        f"from the lesion: nu p/(1 - nu) = {LIFT * P / 3 / 1e6:.3f} MPa)"
    )

# %% [markdown]
# The faces' contact pressure and friction traction along the crack (against the height
# $y$), with the bound $\mu\lambda_n$: where $|\lambda_t|$ reaches it the faces slip.

# %%
if comm.rank == 0:
    order = np.argsort(faces["y"])
    fig, ax = plt.subplots(figsize=(6.5, 4))
    y_mm = 1e3 * faces["y"][order]
    ax.plot(y_mm, faces["pressure"][order] / 1e6, "o-", ms=3, label="pressure λ_n")
    ax.plot(y_mm, np.abs(faces["traction_t"][order]) / 1e6, "s-", ms=3, label="|λ_t|")
    ax.plot(y_mm, MU * faces["pressure"][order] / 1e6, "k--", lw=0.8, label="μ λ_n")
    slip = faces["status"][order] == "slip"
    ax.plot(y_mm[slip], np.abs(faces["traction_t"][order][slip]) / 1e6, "rx", label="slip")
    ax.legend(fontsize=8)
    bp.line_axes(ax, ("height y along the crack", "mm"), ("face traction", "MPa"))
    fig.suptitle("vertebra_tumour: the fragments after the fracture (Coulomb crack faces)")
    fig.tight_layout()
    bp.show(fig, output / "vertebra_fragments.png", dpi=120)
    print(f"pictures: {output / 'vertebra_fragments.png'}")
comm.barrier()
