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
# # A vertebral body weakened by a tumour breaks by fatigue (3D)
#
# An idealised lumbar vertebral body — an elliptic cylinder 44 mm wide, 34 mm deep and
# 27 mm high, one homogeneous isotropic bone (E = 17 GPa, ν = 0.3; the cancellous core
# and the cortical shell are not told apart) — holds an osteolytic tumour, a spherical
# cavity near its posterior wall that grows as the tumour of `demos/spine3d.py` does:
# from 3 mm in radius, volume ∝ e^{μt/2} with μ = 1/(5 days), i.e. r(t) = 3 mm·e^{t/(30
# days)}.  For every tumour size:
#
# 1. **Risk.** The body, held on its lower endplate, carries on its upper endplate the
#    standing load (500 N compression) and a flexion moment of 7.5 N·m (the posterior
#    half of the endplate pulled, the anterior half pushed).  The tension criterion gives
#    the fracture risk R = σ₁/σ_t of every cell; in this linear model R scales with the
#    load, so the load factor at which R reaches 1 is 1/max R (printed with the place of
#    the largest R: in the quick run 1 mm above the clamped lower endplate behind the
#    tumour for r = 5 mm — a support effect — and in the bone beside the cavity for 7 mm).
# 2. **Crack.** A semicircular surface crack (depth and half-length 0.6 mm) is cut
#    into the outer posterior wall at mid-height, where the wall over the tumour is
#    thinnest, normal to the body's axis — the direction of the flexion stress there
#    (docs/scene_format.md#3d-surface-crack).  (It is not put at the largest risk itself,
#    which may lie on the cavity's wall: a crack there is not a crack of the cortex.)
# 3. **Standing.** Under the standing load alone the crack grows only where the σ₁′
#    equivalent K reaches K_Ic = 4 MPa√m: it is arrested at once.
# 4. **Flexion, repeated.** Under repeated flexion (load ratio R = 0) the crack grows by the
#    Paris law in blocks of cycles until K reaches K_Ic at the peak (*fractured*) or the
#    front reaches the cavity (*through*: the wall is broken).  The cycle count is the
#    demo's result: **load cycles to fracture against tumour size**.
#
# **Material constants.**  K_Ic = 4 MPa√m and σ_t = 133 MPa are those of
# data/materials.toml `[strength.cortical_bone]`.  The Paris exponent m = 4.4 is the lowest
# of the range Nalla, Kruzic, Kinney & Ritchie (2005, Biomaterials 26:2183) measured in human
# cortical bone (data/materials.toml `[reference.cortical_fatigue_crack_growth]`).  The
# coefficient C is **an assumption of this demo, not a published value**: C is set so that
# da/dN = 3·10⁻¹⁰ m/cycle (the lowest rate Nalla et al. measured) at ΔK = 1 MPa√m.  The
# cycle counts below scale with 1/C, so they are a comparison between tumour sizes, not a
# prediction.  Bone remodelling (which repairs fatigue damage in vivo) is not modelled.
#
# **What it shows, and what not (2026-12-02).**  The quick run (r = 5 and 7 mm, two blocks
# of 0.4 mm) gives a largest risk of 0.009 (the load would have to be about 110 times
# larger for R to reach 1), K_V of the standing load below 0.001 MPa√m (arrested at once)
# and, under flexion, 1.2·10¹³ and 9.2·10¹² cycles for the two blocks (a 0.6 mm crack
# grown to 1.3 mm): fewer with the larger tumour, but both at the block limit, so the
# plot's values are lower bounds, and with the assumed C they are not a prediction.  This
# idealised body under these loads is far from breaking; the chain (risk → crack → growth
# under one load → fatigue blocks → the stop) is what the demo exercises.
#
# `python demos/vertebra_fracture.py [OUTPUT_DIR]`, `mpiexec -n 2 python
# demos/vertebra_fracture.py`, or as a notebook.  `BONECONTACT_DEMO_QUICK=1` runs two
# tumour sizes on a coarse mesh with at most two blocks of cycles (about 6 min per size,
# serial, on the 2-core machine at load 25).  Units: SI.

# %%
import json
import math
import shutil
import sys
from pathlib import Path

from mpi4py import MPI  # before dolfinx

import gmsh
import numpy as np

import bonecontact.plot as bp
from bonecontact.runners import run_scene
from bonecontact.scene import load_scene

comm = MPI.COMM_WORLD
here = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
args = [a for a in sys.argv[1:] if not a.startswith("-")] if "__file__" in globals() else []
output = bp.output_dir("vertebra_fracture", here, args)
QUICK = bp.quick_mode()

A_VB, B_VB, H_VB = 22e-3, 17e-3, 27e-3  # semi-axes (lateral, antero-posterior), height
Y_TUMOUR = -8e-3  # the tumour's centre: 8 mm behind the body's axis, mid-height
R0, DAYS = 3e-3, 30.0  # r(t) = R0 exp(t / DAYS)
RADII = [5e-3, 7e-3] if QUICK else [4e-3, 5e-3, 6e-3, 7e-3]
H_MAX = 6e-3 if QUICK else 3e-3
TIP = 0.06e-3 if QUICK else 0.04e-3  # element size at the crack front
FORCE, MOMENT = 500.0, 7.5  # N, N m
M_PARIS = 4.4
C_PARIS = 3e-10 / (1e6**M_PARIS)  # ASSUMED: 3e-10 m/cycle at Delta K = 1 MPa m^0.5
A0, C0 = 0.6e-3, 0.6e-3
DA_MAX = 0.4e-3 if QUICK else 0.25e-3
BLOCKS = 2 if QUICK else 12


def build_mesh(radius: float, path: Path) -> None:
    """The vertebral body with the tumour cavity (rank 0): facet groups ``lower`` (z = 0),
    ``upper_front`` / ``upper_back`` (z = H, y > 0 / y < 0), ``wall``, ``cavity``."""
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    occ = gmsh.model.occ
    disk = occ.addDisk(0, 0, 0, A_VB, B_VB)
    body = occ.extrude([(2, disk)], 0, 0, H_VB)
    vol = [t for d, t in body if d == 3][0]
    ball = occ.addSphere(0, Y_TUMOUR, 0.5 * H_VB, radius)
    cut, _ = occ.cut([(3, vol)], [(3, ball)])
    cutter = occ.addRectangle(-2 * A_VB, -H_VB, 0.0, 4 * A_VB, 3 * H_VB)
    occ.rotate([(2, cutter)], 0, 0, 0, 1, 0, 0, 0.5 * math.pi)  # the plane y = 0
    occ.fragment(cut, [(2, cutter)])
    occ.synchronize()
    inside = [t for _, t in gmsh.model.getEntities(3)]
    loose = [
        (2, t) for _, t in gmsh.model.getEntities(2) if not gmsh.model.getAdjacencies(2, t)[0].size
    ]
    occ.remove(loose, recursive=True)
    occ.synchronize()
    gmsh.model.addPhysicalGroup(3, inside, 1, name="vertebra")
    groups: dict[str, list[int]] = {}
    for _, s in gmsh.model.getBoundary([(3, t) for t in inside], combined=True, oriented=False):
        x, y, z = occ.getCenterOfMass(2, s)
        if abs(z) < 1e-9:
            name = "lower"
        elif abs(z - H_VB) < 1e-9:
            name = "upper_front" if y > 0 else "upper_back"
        elif gmsh.model.getBoundingBox(2, s)[3] < 1.01 * radius:  # within the sphere's box
            name = "cavity"
        else:
            name = "wall"
        groups.setdefault(name, []).append(s)
    for k, name in enumerate(("lower", "upper_front", "upper_back", "wall", "cavity"), start=2):
        gmsh.model.addPhysicalGroup(2, groups[name], k, name=name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", H_MAX)
    gmsh.model.mesh.generate(3)
    gmsh.write(str(path))
    gmsh.finalize()


# %% [markdown]
# ## The loads
# The standing load is a uniform pressure p₀ = F/(πab) on the upper endplate.  The
# flexion moment M adds ±q on its anterior and posterior halves: a half ellipse of
# area πab/2 has its centroid 4b/(3π) from the axis, so M = q·4ab²/3, q = 3M/(4ab²).

# %%
P0 = FORCE / (math.pi * A_VB * B_VB)
Q = 3 * MOMENT / (4 * A_VB * B_VB**2)
if comm.rank == 0:
    print(f"standing pressure {P0 / 1e6:.3f} MPa, flexion +/- {Q / 1e6:.3f} MPa")

SCENE = """format = 1
[scene]
name = "{name}"
mesh = "{mesh}"
dimension = 3
[analysis]
kind = "static"
load_steps = 1
[[material]]
name = "bone"
regions = ["vertebra"]
model = "isotropic"
E = 17.0e9
nu = 0.3
sigma_t = 133.0e6
K_Ic = 4.0e6
[[dirichlet]]
boundary = "lower"
value = [0.0, 0.0, 0.0]
[[traction]]
boundary = "upper_front"
value = [0.0, 0.0, {front}]
[[traction]]
boundary = "upper_back"
value = [0.0, 0.0, {back}]
{fracture}
[output]
fields_every = 0
"""


def crack_table(centre, normal) -> str:
    c = ", ".join(f"{v:.9e}" for v in centre)
    n = ", ".join(f"{v:.12f}" for v in normal)
    return (
        f'[[crack]]\nname = "wall"\nshape = "semi_elliptical"\ncentre = [{c}]\n'
        f'normal = [{n}]\ndepth = {A0}\nhalf_length = {C0}\nregion = "vertebra"\n'
        "front_points = 3\n"
    )


def run(name: str, mesh: Path, front: float, back: float, fracture: str):
    d = output / name
    if comm.rank == 0:
        d.mkdir(parents=True, exist_ok=True)
        text = SCENE.format(name=name, mesh=mesh, front=front, back=back, fracture=fracture)
        (d / "scene.toml").write_text(text)
    comm.barrier()
    res = run_scene(load_scene(d / "scene.toml"), comm, output=d / "out", progress=False)
    if res.status != "converged":
        raise SystemExit(f"{name}: {res.summary.get('message')}")
    return res.summary


# %% [markdown]
# ## Risk, crack, standing, flexion — for every tumour size
# One function does the four runs of a tumour size; the cells below call it, one size per
# cell.


# %%
def analyse(r: float) -> dict:
    tag = f"r{r * 1e3:.0f}mm"
    mesh = output / f"vertebra_{tag}.msh"
    if comm.rank == 0:
        mesh.parent.mkdir(parents=True, exist_ok=True)
        build_mesh(r, mesh)
    comm.barrier()
    risk = run(f"risk_{tag}", mesh, -P0 - Q, -P0 + Q, '[fracture]\ncriterion = "tension"')
    centre = np.array([0.0, -B_VB, 0.5 * H_VB])  # the wall over the tumour, mid-height
    crack = crack_table(centre, np.array([0.0, 0.0, 1.0]))
    head = f'[fracture]\ncriterion = "tension"\ntip_size = {TIP}\n'
    stand = run(
        f"standing_{tag}",
        mesh,
        -P0,
        -P0,
        head + f"propagate = true\nincrement = {DA_MAX}\n" + crack,
    )
    fatigue = (
        f"[fracture.fatigue]\nC = {C_PARIS!r}\nm = {M_PARIS}\nda_max = {DA_MAX}\n"
        f"max_blocks = {BLOCKS}\n"
    )
    flex = run(f"flexion_{tag}", mesh, -P0 - Q, -P0 + Q, head + fatigue + crack)
    g, sg = flex["fracture"]["growth"], stand["fracture"]["growth"]
    w = dict(
        radius=r,
        day=DAYS * math.log(r / R0),
        wall=B_VB + Y_TUMOUR - r,
        max_risk=risk["fracture"]["max_risk"],
        risk_at=risk["fracture"]["location"],
        standing=sg["status"],
        K_standing=sg["history"][0]["K_V_deepest"],
        status=g["status"],
        cycles=g["cycles"],
        depth=g["history"][-1]["depth"],
        risk_history=output / f"risk_{tag}" / "out" / "history.csv",
    )
    if comm.rank == 0:
        print(
            f"r = {r * 1e3:.0f} mm (day {w['day']:.0f}), posterior wall {w['wall'] * 1e3:.1f} mm: "
            f"max risk {w['max_risk']:.3f} at {np.round(np.array(w['risk_at']) * 1e3, 1)} mm "
            f"(load factor to R = 1: {1 / w['max_risk']:.0f}); "
            f"standing: {w['standing']} (K_V {w['K_standing'] / 1e6:.4f} MPa m^0.5); "
            f"flexion: {w['status']} after {w['cycles']:.3g} cycles, depth {w['depth'] * 1e3:.2f} mm"
        )
    return w


rows = []

# %%
rows.append(analyse(RADII[0]))

# %%
rows.append(analyse(RADII[1]))

# %%
for r in RADII[2:]:  # the full run's further sizes
    rows.append(analyse(r))

# %% [markdown]
# ## Load cycles to fracture against tumour size
# Filled markers: the crack broke the wall or reached K_Ic; open markers: the block limit
# was reached first (the count is then a lower bound).

# %%
if comm.rank == 0:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    r_mm = np.array([w["radius"] * 1e3 for w in rows])
    n = np.array([w["cycles"] for w in rows])
    done = np.array([w["status"] in ("fractured", "through") for w in rows])
    ax.semilogy(r_mm, n, "-", color="0.6")
    ax.semilogy(r_mm[done], n[done], "o", color="C3", label="fractured / through the wall")
    ax.semilogy(
        r_mm[~done], n[~done], "o", mfc="none", color="C0", label="block limit (lower bound)"
    )
    bp.line_axes(ax, ("tumour radius", "mm"), ("load cycles of flexion", ""))
    ax.set_title("Cycles to fracture of the posterior wall (C assumed: relative values)")
    ax.legend()
    fig.tight_layout()
    bp.show(fig, output / "cycles_to_fracture.png", dpi=120)
    # the demo's record: the rows above; history.csv of the largest tumour's risk run
    record = [{k: (str(v) if isinstance(v, Path) else v) for k, v in w.items()} for w in rows]
    text = json.dumps({"status": "converged", "rows": record}, indent=2)
    (output / "summary.json").write_text(text)
    shutil.copy(rows[-1]["risk_history"], output / "history.csv")
