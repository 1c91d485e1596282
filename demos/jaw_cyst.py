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
# # Odontogenic cysts in a jaw-bone section, then a bite
#
# A 2D (plane-strain) section along the body of a mandible, 60 mm × 24 mm: a cortical
# shell 2.5 mm thick around a cancellous core.  A cyst starts as a 1.5 mm disc in the
# cancellous bone below a tooth and grows over years by the osmotic/Maxwell model of
# Ward et al. 2004 as used by Nedoma 2015 (`bonecontact.neoplasm.cyst`, the cylinder ODE
# per unit length; equations below) with the two parameter
# sets of `data/neoplasms.toml`:
#
# * a **radicular cyst** (≈ 1 mm of radius per year), grown for 3 years;
# * a **keratocyst** (β four times larger, ≈ 4 mm per year), grown for 27 months, with the
#   bone analysed every 9 months on the way (`mechanics_every`).
#
# After (and during) the growth the host mesh is rebuilt by gmsh around the cyst
# (`bonecontact.runners.coupled`): bone that the cyst has taken — cancellous and, as it thins the
# shell, cortical — becomes a cavity whose wall carries the cyst pressure P_h⁺ − P_h⁻ (a few
# tens of Pa: the osmotic excess, small beside a bite).  The section is then loaded by a
# bite-force-like traction, 3 MPa on a 10 mm occlusal patch above the cyst (≈ 300 N on a
# 10 mm × 10 mm tooth), clamped at both ends.  Static, SI units (2D forces per metre).
#
# `python demos/jaw_cyst.py [OUTPUT_DIR]`, `mpiexec -n 2 python demos/jaw_cyst.py`, or as a
# notebook.  `BONECONTACT_DEMO_QUICK=1` takes a coarser mesh and 3-month growth steps
# (what the test suite runs).  The keratocyst's results are written into OUTPUT_DIR itself
# (`growth.csv`, `history.csv`, `summary.json`, fields, `mechanics_<step>/` for the
# intermediate analyses), the radicular cyst's into `OUTPUT_DIR/radicular/`.  The fracture check
# at the end writes `fracture_bite.csv` (the bite force that fractures the thinned bone, per
# cyst size) and its plot into OUTPUT_DIR.
#
# ## The cyst growth ODE
# Osmotic material $s$ (mol per metre of thickness) enters the lumen through the lining
# at the rate $\beta$ (mol m⁻² s⁻¹); the lumen's osmotic excess pressure $f$ (Pa) over the
# surrounding tissue pushes the wall out, and the tissue responds as a Maxwell body
# (modulus $E$, viscosity $\nu$, relaxation time $\tau = \nu/E$):
#
# $$\frac{ds}{dt} = \beta\,S_c, \qquad C^+ = \frac{s}{v_c}, \qquad
# f = P_h^+ - P_h^- = \alpha\,(C^+ - C^-), \quad \alpha = R_g T, \qquad
# \tau\,\frac{df}{dt} + f = \nu\,\frac{d\varepsilon}{dt},$$
#
# van 't Hoff's law with the gas constant $R_g$ and the body temperature $T = 310$ K.  In 2D
# the cyst is a cylinder per unit length, $v_c = \pi R^2$, $S_c = 2\pi R$, and with the
# logarithmic strain $d\varepsilon = dR/R$ this closes to the ODE in $(R, f)$ that the
# code integrates (Radau, relative tolerance $10^{-11}$), step by step:
#
# $$\frac{dR}{dt} = \frac{R f + 2\tau\alpha\beta}{\nu + 2\tau(\alpha C^- + f)}, \qquad
# \frac{df}{dt} = \frac{2}{R}\Big[\alpha\beta - (\alpha C^- + f)\,\frac{dR}{dt}\Big],
# \qquad R(0) = R_0, \quad f(0) = f_0 = 0,$$
#
# $R_0 \approx 1.5$ mm the equivalent radius $\sqrt{A/\pi}$ of the meshed `cyst` group.
#
# Both parameter sets have $C^- = 1$ mol/m³, $E = 1$ MPa, $\nu = 10^9$ Pa s ($\tau = 1000$ s)
# and $\beta = 3.2\cdot 10^{-11}$ (radicular) or $1.28\cdot 10^{-10}$ mol m⁻² s⁻¹
# (keratocyst).  For long times $dR/dt \to \beta/C^-$ (1 and 4 mm per year) and
# $f \approx \beta\nu/(C^- R)$: tens of pascals.  See [the growth notes](../docs/theory/growth.md).
#
# ## The coupling
# One-way: the ODE has its own Maxwell surrounding and does not feel the bone.  At each
# analysis the jaw mesh is rebuilt with the circle of radius $R(t)$ about the cyst
# centre embedded; the bone inside it is removed and the static plane-strain problem is
# solved on what is left, $\Omega(t)$, from an unstressed state:
#
# $$-\nabla\cdot\mathbb C\,e(u) = 0 \ \text{in } \Omega(t), \qquad u = 0 \ \text{at both ends}, \qquad
# \sigma n = (0, -3\ \text{MPa}) \ \text{on the occlusal patch}, \qquad
# \sigma n = -f(t)\,n \ \text{on the cyst wall},$$
#
# $n$ the outer normal of the bone, $\mathbb C$ isotropic (cortical bone 17 GPa, 0.3;
# cancellous bone 1 GPa, 0.25; Reilly & Burstein 1975), other boundaries traction-free.

# %%
import json
import os
import sys
import tomllib
from pathlib import Path

from mpi4py import MPI  # before dolfinx

import numpy as np

import bonecontact.plot as bp
from bonecontact.common.constants import SECONDS_PER_YEAR
from bonecontact.common.resources import data_file
from bonecontact.fracture import cell_stresses, risk_field
from bonecontact.materials.laws import Isotropic
from bonecontact.materials.library import load_material_library, load_strengths
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics
from bonecontact.meshing.io import read_gmsh_mesh
from bonecontact.runners import run_scene
from bonecontact.scene import load_scene

comm = MPI.COMM_WORLD
here = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
args = [a for a in sys.argv[1:] if not a.startswith("-")] if "__file__" in globals() else []
# results: the first argument, else $BONECONTACT_OUTPUT/jaw_cyst, else demos/results/jaw_cyst
output = bp.output_dir("jaw_cyst", here, args)
quick = bp.quick_mode()

MM, MONTH = 1e-3, SECONDS_PER_YEAR / 12
L, H, T = 60 * MM, 24 * MM, 2.5 * MM  # section length, height, cortical thickness
XC, YC, R0 = 30 * MM, 12.5 * MM, 1.5 * MM  # cyst centre and initial radius
PATCH = (25 * MM, 35 * MM)  # occlusal patch under the bite
h = (1.0 if quick else 0.6) * MM  # mesh size (finer near the cyst)
dt_months = 3 if quick else 1
cysts = tomllib.loads(data_file("neoplasms.toml").read_text())["cyst"]
if comm.rank == 0:
    output.mkdir(parents=True, exist_ok=True)
comm.barrier()

# %% [markdown]
# ## The jaw section (gmsh)
# Cell groups `cortical`, `cancellous`, `cyst`; facet groups `symphysis` (x = 0), `ramus`
# (x = L), `occlusal` (the loaded patch).


# %%
def jaw_mesh(path: Path) -> None:
    if comm.rank == 0:
        import gmsh

        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        outer = occ.addRectangle(0, 0, 0, L, H, roundedRadius=4 * MM)
        inner = occ.addRectangle(T, T, 0, L - 2 * T, H - 2 * T, roundedRadius=2 * MM)
        cyst = occ.addDisk(XC, YC, 0, R0, R0)
        pts = [occ.addPoint(x, H, 0) for x in PATCH]
        _, m = occ.fragment([(2, outer), (2, inner), (2, cyst)], [(0, p) for p in pts])
        occ.synchronize()
        cyst_s = [t for d, t in m[2] if d == 2]
        canc_s = [t for d, t in m[1] if d == 2 and t not in cyst_s]
        cort_s = [t for d, t in m[0] if d == 2 and t not in cyst_s + canc_s]
        gmsh.model.addPhysicalGroup(2, cort_s, 1, name="cortical")
        gmsh.model.addPhysicalGroup(2, canc_s, 2, name="cancellous")
        gmsh.model.addPhysicalGroup(2, cyst_s, 3, name="cyst")
        rim = [
            abs(t)
            for _, t in gmsh.model.getBoundary(
                [(2, s) for s in cort_s + canc_s + cyst_s], combined=True
            )
        ]
        com = {c: occ.getCenterOfMass(1, c) for c in rim}
        pick = {
            "symphysis": [c for c in rim if abs(com[c][0]) < 1e-9],
            "ramus": [c for c in rim if abs(com[c][0] - L) < 1e-9],
            "occlusal": [
                c for c in rim if abs(com[c][1] - H) < 1e-9 and PATCH[0] < com[c][0] < PATCH[1]
            ],
        }
        for k, (name, cs) in enumerate(pick.items()):
            gmsh.model.addPhysicalGroup(1, cs, 4 + k, name=name)
        f = gmsh.model.mesh.field
        d = f.add("Distance")
        f.setNumbers(d, "PointsList", [occ.addPoint(XC, YC, 0)])
        occ.synchronize()
        th = f.add("Threshold")
        f.setNumber(th, "InField", d)
        f.setNumber(th, "SizeMin", h / 2)
        f.setNumber(th, "SizeMax", h)
        f.setNumber(th, "DistMin", 3 * R0)
        f.setNumber(th, "DistMax", 6 * R0)
        f.setAsBackgroundMesh(th)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
        gmsh.finalize()
    comm.barrier()


jaw_mesh(output / "jaw.msh")

# %% [markdown]
# ## The coupled scenes
# `[neoplasm]` (the cyst and where it may grow) together with `[analysis]` (the bite):
# `bonecontact run` accepts the same file.

# %%
SCENE = """format = 1
[scene]
name = "jaw_{kind}"
mesh = "{mesh}"
dimension = 2

[analysis]
kind = "static"
load_steps = 1

[[material]]
name = "cortical"
regions = ["cortical"]
model = "isotropic"
E = 17.0e9
nu = 0.3

[[material]]
name = "cancellous"
regions = ["cancellous"]
model = "isotropic"
E = 1.0e9
nu = 0.25

[[dirichlet]]
boundary = "symphysis"
value = [0.0, 0.0]

[[dirichlet]]
boundary = "ramus"
value = [0.0, 0.0]

[[traction]]
boundary = "occlusal"
value = [0.0, -3.0e6]

[neoplasm]
kind = "cyst"
region = "cyst"
host = ["cancellous", "cortical"]
t_end = {t_end}
dt = {dt}
mechanics_every = {every}

[neoplasm.cyst]
{params}

[output]
directory = "{out}"
fields_every = 0
"""


def cyst_table(name: str) -> str:
    keys = ("model", "strain", "beta", "C_minus", "temperature", "E", "viscosity", "f0")
    return "\n".join(f"{k} = {json.dumps(cysts[name][k])}" for k in keys)


runs = {"keratocyst": (output, 27, 9), "radicular": (output / "radicular", 36, 0)}
results = {}
for kind, (out, months, every) in runs.items():
    text = SCENE.format(
        kind=kind,
        mesh=output / "jaw.msh",
        t_end=months * MONTH,
        dt=dt_months * MONTH,
        every=every // dt_months if every else 0,
        params=cyst_table(kind),
        out=out,
    )
    path = output / f"jaw_{kind}.toml"
    if comm.rank == 0:
        path.write_text(text)
    comm.barrier()
    res = run_scene(load_scene(path), comm, output=out, progress=comm.rank == 0)
    if res.status != "converged":
        raise SystemExit(f"{kind}: run failed: {res.summary.get('message')}")
    results[kind] = res.summary
    if comm.rank == 0:
        g = res.summary["growth"]
        print(
            f"{kind}: R {g['initial_radius'] / MM:.2f} -> {g['final_radius'] / MM:.2f} mm in {months} months; "
            f"{len(res.summary['coupling']['analyses'])} analyses, {res.summary['dofs']} dofs at the end"
        )

# %% [markdown]
# ## Stress in the thinning bone
# von Mises stress from each analysis (pyvista reads the `.pvd` files): the peak in the bone
# within 2 mm of the cyst wall (99.5th percentile of the cells there, to stay clear of
# single-cell corner values), and the thinnest remaining bone below and above the cyst.


# %%
def bone_near_cyst(directory: Path, R: float) -> tuple[float, float]:
    grid = bp.read_fields(directory / "fields.pvd")
    vm = np.asarray(grid.cell_data[next(n for n in grid.cell_data if "von" in n.lower())])
    c = np.asarray(grid.cell_centers().points)[:, :2]
    near = np.hypot(c[:, 0] - XC, c[:, 1] - YC) < R + 2 * MM
    return float(np.percentile(vm[near], 99.5)), float(np.percentile(vm, 99.5))


if comm.rank == 0:
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = []
    for kind, s in results.items():
        for a in s["coupling"]["analyses"]:
            R = a["equivalent_radius"]
            near, whole = bone_near_cyst(Path(a["directory"]), R)
            rows.append(
                (
                    kind,
                    a["time"] / (12 * MONTH),
                    R,
                    min(YC - R, H - YC - R),
                    near,
                    whole,
                    a["cavity_pressure_Pa"],
                )
            )
            print(
                f"{kind:10s} t = {rows[-1][1]:4.2f} y: R = {R / MM:5.2f} mm, thinnest bone "
                f"{rows[-1][3] / MM:5.2f} mm, von Mises near the cyst {near / 1e6:6.2f} MPa "
                f"(whole section {whole / 1e6:6.2f} MPa), cyst pressure {a['cavity_pressure_Pa']:.1f} Pa"
            )
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
    for kind in results:
        out = runs[kind][0]
        g = np.genfromtxt(out / "growth.csv", delimiter=",", names=True)
        ax1.plot(g["time"] / (12 * MONTH), g["equivalent_radius"] / MM, label=kind)
        rk = [r for r in rows if r[0] == kind]
        ax2.plot([r[3] / MM for r in rk], [r[4] / 1e6 for r in rk], "o-", label=kind)
    ax1.axhline((H - T - YC) / MM, color="grey", ls=":", label="cyst reaches the cortex (above it)")
    bp.line_axes(ax1, ("time", "years"), ("cyst radius", "mm"), "cyst growth (osmotic/Maxwell ODE)")
    ax1.legend(fontsize=8)
    bp.line_axes(
        ax2,
        ("thinnest bone between cyst and surface", "mm"),
        ("von Mises near the cyst, 99.5 %", "MPa"),
        "bite of 3 MPa on the occlusal patch",
    )
    ax2.invert_xaxis()
    ax2.legend(fontsize=8)
    fig.tight_layout()
    bp.show(fig, output / "jaw_cyst_growth.png", dpi=120)

    # one picture per cyst; each colour range stops at a round number leaving at most 1 %
    # of the area above it, the clip and the maximum (the peak at the thin bone next to
    # the cyst) stated in the colour-bar label
    views = [("keratocyst", output, "jaw_cyst_von_mises.png"),
             ("radicular", output / "radicular", "jaw_cyst_radicular_von_mises.png")]  # fmt: skip
    for kind, out, name in views:
        png = bp.field_view(
            bp.read_fields(out / "fields.pvd"),
            "von_mises",
            output / name,
            quantity="von Mises stress",
            unit="MPa",
            title=f"jaw_cyst: von Mises stress, {kind} after {runs[kind][1]} months, bite of 3 MPa",
            cmap="inferno",
            window_size=(1200, 700),
        )
        bp.show(png, png)
    print(f"pictures: {output / 'jaw_cyst_growth.png'}, {', '.join(v[2] for v in views)}")
comm.barrier()

# %% [markdown]
# ## The bite force that fractures the thinned mandible
# The fracture check of `bonecontact.fracture` ([the fracture notes](../docs/theory/fracture.md#initiation-risk))
# on each analysed state: the bone with the cavity of that cyst size is loaded by the bite
# alone (the cyst's osmotic pressure, tens of pascals, is left out, so that the problem is
# linear in the bite), and every cell gets the risk
#
# $$R = \max\Bigl(\frac{\sigma_1}{\sigma_t},\ -\frac{\sigma_3}{\sigma_c},\ 0\Bigr)$$
#
# from its principal stresses (σ_zz of plane strain included) and the strengths of
# `data/materials.toml`: `[strength.cortical_bone]` (σ_t = 133 MPa, σ_c = 193 MPa, along the
# osteons).  The mandible fractures when its cortical shell does, so $R$ is taken over the
# cortical bone; cells within 5 mm of the clamped ends are left out (the clamp is an
# idealisation whose corners carry a singular stress).  The problem is linear elastic and
# $R$ is homogeneous of degree one in the load, so the bite force at which $R$ reaches 1 is
#
# $$F_\text{fracture} = \frac{F_\text{applied}}{\max R},$$
#
# with $F_\text{applied}$ = 3 MPa on the 10 mm patch, i.e. 300 N on a 10 mm wide tooth.  As a
# check each state is also solved at twice the bite: its risk must be twice as large.

# %%
BITE, TOOTH = 3.0e6, 10 * MM  # the occlusal traction (Pa) and the tooth width (m)
F_APPLIED = BITE * (PATCH[1] - PATCH[0]) * TOOTH  # N
CLAMP_ZONE = 5 * MM
cortical_strength = load_strengths()["cortical_bone"]
E_CORTICAL = load_material_library()["cortical_bone"]["E"]  # the same bone as the strength
#: the (E, sigma_t) pair of the risk (tests/unit/materials/test_strength_pairs.py)
RISK_PAIRS = {"cortical": (E_CORTICAL, cortical_strength["sigma_t"])}


def bite_risk(msh_path: Path, scale: float) -> tuple[float, tuple[float, float], str]:
    """Largest cortical risk (away from the clamps) of the bone in ``msh_path`` under
    ``scale`` times the bite: value, cell midpoint, governing term."""
    _, md = read_gmsh_mesh(msh_path, comm, 2)
    tag = {name: g.tag for name, g in md.physical_groups.items()}
    mats = {
        tag["cortical"]: Isotropic(E=E_CORTICAL, nu=0.3),
        tag["cancellous"]: Isotropic(E=1.0e9, nu=0.25),
    }
    model = Mechanics(md.mesh, mats, md.cell_tags, md.facet_tags)
    for end in ("symphysis", "ramus"):
        for comp in (0, 1):
            model.add_dirichlet(model.facets(tag[end]), comp, 0.0)
    model.add_traction(tag["occlusal"], (0.0, -scale * BITE))
    integ = Integrator(model, "static", 1.0)
    integ.step()
    n = md.mesh.topology.index_map(2).size_local
    mid = cell_stresses(model, integ.u).midpoints  # owned cells, in risk_field's order
    cortical = np.zeros(n, dtype=bool)
    cells = model.cells(tag["cortical"])
    cortical[cells[cells < n]] = True
    counted = cortical & (mid[:, 0] > CLAMP_ZONE) & (mid[:, 0] < L - CLAMP_ZONE)
    # cells that do not count get an infinite strength: their risk is zero
    sigma_t = np.where(counted, cortical_strength["sigma_t"], np.inf)
    sigma_c = np.where(counted, cortical_strength["sigma_c"], np.inf)
    _, mx = risk_field(model, integ.u, sigma_t, sigma_c, "tension_compression")
    integ.destroy()
    return mx.value, mx.location, mx.mode


fracture_rows = []
for kind, s in results.items():
    for a in s["coupling"]["analyses"]:
        directory = Path(a["directory"])
        R = a["equivalent_radius"]
        risk, where, mode = bite_risk(directory / "host_mesh.msh", 1.0)
        risk2, _, _ = bite_risk(directory / "host_mesh.msh", 2.0)
        fracture_rows.append(
            {
                "cyst": kind,
                "months": round(a["time"] / MONTH),
                "radius_mm": R / MM,
                "thinnest_bone_mm": min(YC - R, H - YC - R) / MM,
                "max_risk": risk,
                "risk_ratio_2F": risk2 / risk,
                "x_mm": where[0] / MM,
                "y_mm": where[1] / MM,
                "mode": mode,
                "fracture_bite_force_N": F_APPLIED / risk,
            }
        )
fracture_rows.sort(key=lambda r: r["radius_mm"])
if comm.rank == 0:
    import csv

    with open(output / "fracture_bite.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(fracture_rows[0]))
        w.writeheader()
        w.writerows(fracture_rows)
    for r in fracture_rows:
        print(
            f"{r['cyst']:10s} {r['months']:2d} months: R = {r['radius_mm']:5.2f} mm, max risk at the "
            f"bite {r['max_risk']:.3f} ({r['mode']}, at x = {r['x_mm']:.1f}, y = {r['y_mm']:.1f} mm), "
            f"at twice the bite x{r['risk_ratio_2F']:.12f}; fracture bite force {r['fracture_bite_force_N']:.0f} N"
        )
    fig, ax = plt.subplots(figsize=(6.5, 4))
    for kind, marker in (("keratocyst", "o-"), ("radicular", "s")):
        rk = [r for r in fracture_rows if r["cyst"] == kind]
        ax.plot(
            [r["radius_mm"] for r in rk],
            [r["fracture_bite_force_N"] for r in rk],
            marker,
            label=kind,
        )
    bp.line_axes(
        ax,
        ("cyst radius", "mm"),
        ("bite force at fracture", "N"),
        "bite force at which the cortical shell fractures",
    )
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8)
    fig.text(
        0.01,
        0.01,
        "max(σ₁/σ_t, −σ₃/σ_c) = 1 in the cortical bone (σ_t = 133, σ_c = 193 MPa), 10 mm wide tooth, "
        "clamps excluded",
        fontsize=7,
    )
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    bp.show(fig, output / "jaw_cyst_fracture_force.png", dpi=120)
comm.barrier()
