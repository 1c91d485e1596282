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
# # A tumour growing in the proximal tibia of the loaded 2D knee
#
# The knee of `demos/knee2d.py` with a 5 mm disc of tumour tissue in the tibial
# cancellous bone, 20 mm below the plateau.  The tumour grows for 20 days by a
# free-boundary model of avascular growth (quasi-steady nutrient $u_c$, proliferation
# rate $\mu(u_c - 0.5)$, velocity potential $\sigma$ with $V_n = -\partial\sigma/\partial n$,
# gmsh remeshing at every step; equations below).  Every
# 4 days gmsh rebuilds the knee mesh with the tumour boundary embedded; the
# tumour cells become near-fluid soft tissue (E = 50 kPa, ν = 0.49, non-locking
# `nodal_pressure`) and the body-weight contact analysis of the healthy knee runs on
# the new mesh.  We follow the tumour's size and how far the subchondral plate above it
# sinks under body weight as the soft tumour replaces cancellous bone.
#
# The knee is the one of `demos/knee2d.py` with its concave tibial seat (issue 27): on the
# earlier flat plateau every contact analysis strained the cartilage to a strain measure of
# 11.6 % (beyond the small-strain model's 10 %) and the scene needed `allow_large_strain`;
# in the conforming seat each analysis reports 7.0 % (`small_strain_valid: true`; the
# tumour, 20 mm below the plateau, does not change the cartilage strain in the first digit).
#
# Run with `python demos/knee_tumour.py [OUTPUT_DIR]` or
# `mpiexec -n 2 python demos/knee_tumour.py`, or open as a notebook.  The scene is
# `data/scenes/knee2d_tumour.toml`.  `BONECONTACT_DEMO_QUICK=1` runs the contact analysis
# every 10 days (two analyses) instead of every 4 (five); the growth is the same.
# Units: SI (2D forces per metre of thickness).
#
# ## The growth problem
# The tumour $\omega(t)$ holds volume fractions of proliferating ($u_p$) and quiescent
# ($u_q$) cells, the rest dead, moving with the velocity $v = -\nabla\sigma$; $u_c$ is the
# nutrient (relative to its value $u_{c1}$ outside).  The code solves
#
# $$\varepsilon_0\,\partial_t u_c - D_c\,\Delta u_c + \lambda\,u_c = 0 \ \text{in } \omega(t), \qquad u_c = u_{c1} \ \text{on } \partial\omega(t),$$
#
# $$-\Delta\sigma = h \ \text{in } \omega(t), \qquad \sigma = \gamma\kappa \ \text{on } \partial\omega(t), \qquad
# h = \nabla\cdot v = (K_B + K_R)\,u_p + K_R\,u_q - K_R,$$
#
# $$\partial_t u_p + v\cdot\nabla u_p = (K_B - K_Q - K_A)\,u_p + K_P\,u_q - h\,u_p, \qquad
# \partial_t u_q + v\cdot\nabla u_q = K_Q\,u_p - (K_P + K_D)\,u_q - h\,u_q,$$
#
# $$V_n = -\frac{\partial\sigma}{\partial n} \ \text{on } \partial\omega(t),$$
#
# with the rates $K_\bullet(u_c)$ in 1/s (birth, proliferating → quiescent, apoptosis,
# quiescent → proliferating, death, removal of the dead), $\kappa = \nabla\cdot n$ the
# curvature and $\gamma$ the surface tension (m³/s; $\sigma$ is in m²/s).  This scene
# takes $\varepsilon_0 = 0$ (quasi-steady nutrient), $D_c = 10^{-9}$ m²/s,
# $\lambda = 10^{-5}$ 1/s (nutrient length $L = \sqrt{D_c/\lambda} = 10$ mm), $u_{c1} = 1$,
# $K_B = \mu\,(u_c - \tfrac12)$ with $\mu = 1/(10\ \text{days})$, all other rates and
# $\gamma$ zero and $u_p = 1$, $u_q = 0$ at $t = 0$.  Then $u_p \equiv 1$, $u_q \equiv 0$
# and the model is the non-necrotic tumour of Byrne & Chaplain 1995:
#
# $$-D_c\Delta u_c + \lambda u_c = 0, \quad -\Delta\sigma = \mu\big(u_c - \tfrac12\big) \ \text{in } \omega(t), \qquad
# u_c = 1, \quad \sigma = 0, \quad V_n = -\partial_n\sigma \ \text{on } \partial\omega(t);$$
#
# for a disc of radius $R$ it reduces to
# $\dot R = \mu L\big[I_1(R/L)/I_0(R/L) - R/(4L)\big]$.  Each 2-day step solves
# $u_c$ and $\sigma$ (P1, LU), recovers $V_n$ as the boundary flux of $\sigma$, moves the
# boundary along its normals by $\Delta t\,V_n$ (explicit Euler; mesh moved by a harmonic
# extension), transports $u_p, u_q$ by upwind finite volumes, integrates the reaction
# terms cell by cell (RK4) and remeshes the tumour with gmsh.  See
# [the growth notes](../docs/theory/growth.md) and [the remeshing notes](../docs/theory/remeshing.md).
#
# ## The coupling
# One-way: the growth does not feel the mechanics.  Every 4 days (and at the end) the
# knee mesh is rebuilt with the current $\partial\omega$ embedded; cells inside $\omega$
# become tumour tissue and the static, frictionless contact problem of `demos/knee2d.py`
# (Signorini conditions, dual mortar, PDAS; body weight in 4 load steps) is solved from
# an unstressed state,
#
# $$-\nabla\cdot\mathbb C^{(0)} e(u) = 0, \qquad \tilde g_p \ge 0, \ \lambda_{n,p} \ge 0, \ \tilde g_p\lambda_{n,p} = 0,$$
#
# with the tumour isotropic and nearly incompressible, $E = 50$ kPa, $\nu = 0.49$
# (bulk modulus $\kappa_b = E/(3(1-2\nu)) \approx 0.83$ MPa, shear modulus $\approx 17$ kPa),
# its volumetric strain $\operatorname{tr} e(u)$ averaged at the vertices (average nodal
# pressure, Bonet & Burton 1998) so that the P1 elements do not lock.

# %%
import dataclasses
import json
import sys
from pathlib import Path

from mpi4py import MPI  # before dolfinx

import numpy as np

import bonecontact.plot as bp
from bonecontact.common.constants import SECONDS_PER_DAY
from bonecontact.common.resources import data_file
from bonecontact.runners import run_scene
from bonecontact.scene import load_scene

comm = MPI.COMM_WORLD
here = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
args = [a for a in sys.argv[1:] if not a.startswith("-")] if "__file__" in globals() else []
# results: the first argument, else $BONECONTACT_OUTPUT/knee_tumour, else demos/results/knee_tumour
output = bp.output_dir("knee_tumour", here, args)

# %% [markdown]
# ## Grow the tumour and load the knee

# %%
scene = load_scene(data_file("scenes", "knee2d_tumour.toml"))
if bp.quick_mode():  # analyses at days 10, 20
    scene = dataclasses.replace(
        scene, neoplasm=dataclasses.replace(scene.neoplasm, mechanics_every=5)
    )
result = run_scene(scene, comm, output=output, progress=True)
if result.status != "converged":
    raise SystemExit(f"run failed: {result.summary.get('message')}")
s = result.summary
if comm.rank == 0:
    g = s["growth"]
    print(
        f"tumour: R {1e3 * g['initial_radius']:.2f} -> {1e3 * g['final_radius']:.2f} mm in "
        f"{g['final_time'] / SECONDS_PER_DAY:.0f} days ({g['steps']} steps, {g['remeshes']} remeshes); "
        f"{len(s['coupling']['analyses'])} contact analyses; wall time {s['wall_time_s']:.1f} s"
    )
    for a in s["coupling"]["analyses"]:
        m = json.loads((Path(a["directory"]) / "summary.json").read_text())
        print(
            f"  day {a['time'] / SECONDS_PER_DAY:.0f}: strain measure "
            f"{100 * m['strain_measure']:.1f} % ({m['strain_measure_material']}), "
            f"small_strain_valid: {m['small_strain_valid']}"
        )

# %% [markdown]
# ## Tumour size and the subsidence of the plateau above it
# `growth.csv` holds the tumour's area and equivalent radius at every growth step; the
# second probe sits on the axis just under the subchondral plate (y = −4 mm), whose
# vertical displacement under body weight grows with the tumour.

# %%
if comm.rank == 0:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    gr = np.genfromtxt(output / "growth.csv", delimiter=",", names=True)
    rows = []
    for a in s["coupling"]["analyses"]:
        pr = np.genfromtxt(Path(a["directory"]) / "probes.csv", delimiter=",", names=True)
        last = pr[(pr["probe"] == 2) & (pr["step"] == pr["step"].max())]
        hist = np.genfromtxt(
            Path(a["directory"]) / "history.csv",
            delimiter=",",
            names=True,
            dtype=None,
            encoding="utf-8",
        )
        rows.append(
            (
                a["time"] / SECONDS_PER_DAY,
                1e3 * a["equivalent_radius"],
                -1e6 * float(last["u_y"][0]),
                float(hist["normal_force"][-1]),
            )
        )
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    a1.plot(gr["time"] / SECONDS_PER_DAY, 1e3 * gr["equivalent_radius"], "o-", ms=3)
    bp.line_axes(
        a1, ("time", "days"), (r"tumour equivalent radius $\sqrt{A/\pi}$", "mm"), zero=True
    )
    a2.plot([r[1] for r in rows], [r[2] for r in rows], "s-")
    bp.line_axes(
        a2, ("tumour radius", "mm"), ("subsidence under the plate at (0, −4) mm", "µm"), zero=True
    )
    fig.suptitle("knee2d_tumour: tumour growth and the plateau's subsidence under body weight")
    fig.tight_layout()
    bp.show(fig, output / "tumour_growth.png", dpi=120)
    for day, r, sub, fn in rows:
        print(
            f"day {day:4.0f}: R = {r:.2f} mm, subsidence under the plate {sub:.2f} µm, contact force {fn:.0f} N/m"
        )

# %% [markdown]
# ## Stress in the tibia with the tumour outlined
# von Mises stress of the last analysis (projected to the vertices for display), the
# colour range stopping at a round number that leaves at most 1 % of the area above it
# (the clip and the maximum stated in the colour-bar label); the cyan line is the tumour
# boundary.

# %%
if comm.rank == 0:
    poly = np.genfromtxt(output / "neoplasm_boundary.csv", delimiter=",", names=True)
    png = bp.field_view(
        bp.read_fields(output / "fields.pvd"),
        "von_mises",
        output / "knee_tumour_von_mises.png",
        quantity="von Mises stress",
        unit="MPa",
        outline=np.column_stack([poly["x"], poly["y"]]),
        outline_label="tumour boundary",
        title=f"knee2d_tumour: von Mises stress after {s['growth']['final_time'] / SECONDS_PER_DAY:.0f} days",
        cmap="inferno",
        axis_titles={"x": "x, across the knee", "y": "y, along the leg"},
        directions={"proximal": (0.0, 1.0, 0.0)},
    )
    bp.show(png, png)
    print(f"pictures: {output / 'tumour_growth.png'}, {png}")
comm.barrier()
