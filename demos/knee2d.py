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
# # A 2D knee joint under body weight, then through a gait cycle with friction
#
# A frontal section of the knee: the femoral condyle (cartilage over a cortical shell
# and a cancellous core) rests on the tibial plateau (cartilage, subchondral plate,
# cancellous bone).  The two bones are meshed independently, so the nodes of the two
# cartilage surfaces do not match; the contact is discretised with dual mortar
# multipliers and solved by the primal–dual active set method (PDAS).  The load — body
# weight, 17.5 kN per metre of thickness — is ramped over four load steps; each step
# warm-starts the PDAS from the previous one.
#
# Part 2 runs the same knee dynamically through a one-second gait-like load cycle with
# Coulomb friction between the cartilage layers (`data/scenes/knee2d_gait.toml`).
#
# Run with `python demos/knee2d.py [OUTPUT_DIR]` or `mpiexec -n 2 python demos/knee2d.py`,
# or open as a notebook.  Everything is in `data/scenes/knee2d.toml` and
# `knee2d_gait.toml`.  Units: SI (2D forces per metre of thickness, pressures in Pa).

# %%
import os
import sys
from pathlib import Path

from mpi4py import MPI  # before dolfinx

import numpy as np

from bonecontact.verification.analytic import hertz_2d
from bonecontact.run.dispatch import run_scene
from bonecontact.scene.spec import load_scene

comm = MPI.COMM_WORLD
here = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
root = here.parent if (here.parent / "data" / "scenes").is_dir() else here
args = [a for a in sys.argv[1:] if not a.startswith("-")] if "__file__" in globals() else []
output = Path(args[0] if args else os.environ.get("BONECONTACT_OUTPUT", "results/knee2d"))

# %% [markdown]
# ## Run the scene

# %%
scene = load_scene(root / "data" / "scenes" / "knee2d.toml")
result = run_scene(scene, comm, output=output, progress=True)
if result.status != "converged":
    raise SystemExit(f"run failed: {result.summary.get('message')}")
s = result.summary
if comm.rank == 0:
    print(f"{s['dofs']} dofs on {comm.size} rank(s); {s['steps']} load steps; PDAS iterations per step: "
          f"max {s['contact']['pdas_iterations']['max']}, total {s['contact']['pdas_iterations']['total']}; "
          f"wall time {s['wall_time_s']:.2f} s")

# %% [markdown]
# ## Contact pressure along the plateau
# `contact_tibiofemoral.csv` holds, at every slave node of the femoral cartilage, its
# position, gap and pressure λ_n.  For comparison: Hertz's cylinder-on-half-space
# profile for the same load with the cartilage–cartilage contact modulus — a thin
# cartilage layer on bone is stiffer than a half-space of cartilage, so the real
# contact is narrower and the peak higher.

# %%
if comm.rank == 0:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = np.genfromtxt(output / "contact_tibiofemoral.csv", delimiter=",", names=True, dtype=None,
                         encoding="utf-8")
    x, p = rows["x"], rows["pressure"]
    hist = np.genfromtxt(output / "history.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    load = float(hist["normal_force"][-1])
    cart = [m for m in scene.materials if m.name == "cartilage"][0].material
    R = 0.03
    xs = np.linspace(-1.5 * hertz_2d.half_width(load, R, cart.E, cart.nu, cart.E, cart.nu),
                     1.5 * hertz_2d.half_width(load, R, cart.E, cart.nu, cart.E, cart.nu), 400)
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(1e3 * x, p / 1e6, "o-", ms=3, label="bonecontact (mortar + PDAS)")
    ax.plot(1e3 * xs, hertz_2d.pressure(xs, load, R, cart.E, cart.nu, cart.E, cart.nu) / 1e6, "--",
            label="Hertz, cartilage half-spaces")
    ax.set_xlim(-15, 15)
    ax.set_xlabel("x along the plateau (mm)")
    ax.set_ylabel("contact pressure (MPa)")
    ax.set_title(f"knee2d: contact force {load / 1e3:.2f} kN/m, peak {p.max() / 1e6:.2f} MPa")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(output / "contact_pressure.png", dpi=120)
    width = x[p > 0].max() - x[p > 0].min()
    print(f"contact width {1e3 * width:.1f} mm, peak pressure {p.max() / 1e6:.2f} MPa, "
          f"total normal force {load:.0f} N/m (applied 17500 N/m)")

# %% [markdown]
# ## Stress, with the contact zone marked
# von Mises stress (pyvista reads the `.pvd` series); the white dots are the slave
# nodes in contact.

# %%
if comm.rank == 0:
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = True
    reader = pv.get_reader(str(output / "fields.pvd"))
    reader.set_active_time_point(len(reader.time_values) - 1)
    grid = reader.read().combine()
    vm = next(n for n in grid.cell_data if "von" in n.lower())
    grid.cell_data["von Mises (MPa)"] = grid.cell_data[vm] / 1e6
    active = np.column_stack([x[p > 0], rows["y"][p > 0], np.zeros((p > 0).sum())])
    plotter = pv.Plotter(window_size=(1000, 800), off_screen=True)
    plotter.add_mesh(grid, scalars="von Mises (MPa)", cmap="inferno", clim=(0, np.percentile(grid.cell_data["von Mises (MPa)"], 99.5)),
                     scalar_bar_args={"fmt": "%.2f", "n_labels": 4, "vertical": True, "position_x": 0.86,
                                      "position_y": 0.25, "height": 0.5, "title_font_size": 14})
    plotter.add_points(active, color="white", point_size=8, render_points_as_spheres=True)
    plotter.view_xy()
    plotter.camera.zoom(1.4)
    plotter.screenshot(str(output / "knee2d_von_mises.png"))
    plotter.close()
    print(f"pictures: {output / 'contact_pressure.png'}, {output / 'knee2d_von_mises.png'}")
comm.barrier()

# %% [markdown]
# ## Part 2: a gait cycle with friction
# The vertical femoral force follows a double-hump stance curve (1.2 × body weight at 15 %
# and 50 % of the cycle) and drops to 0.1 × body weight in swing; the analysis is
# dynamic (Kelvin–Voigt bone, Δt = 10 ms) and the cartilage surfaces carry Coulomb
# friction, μ = 0.02 (semi-implicit: the bound comes from the previous step's
# pressure).  Tangential tractions come from the different lateral expansion of
# cartilage and bone: parts of the contact stick, parts slip, and the pattern changes
# through the cycle.  Each step is warm-started and reuses one LU factorisation.

# %%
gait_scene = load_scene(root / "data" / "scenes" / "knee2d_gait.toml")
gait_out = output / "gait"
gait = run_scene(gait_scene, comm, output=gait_out, progress=True)
if gait.status != "converged":
    raise SystemExit(f"gait run failed: {gait.summary.get('message')}")
g = gait.summary
if comm.rank == 0:
    print(f"gait: {g['steps']} steps, PDAS iterations per step max {g['contact']['pdas_iterations']['max']}, "
          f"total {g['contact']['pdas_iterations']['total']}; wall time {g['wall_time_s']:.2f} s; "
          f"energy: external work {g['energy']['external_work']:.3f} J/m, contact+friction work "
          f"{g['energy']['contact_work']:.3f} J/m, balance defect {g['energy']['defect']:.1e} J/m")

# %%
if comm.rank == 0:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    h = np.genfromtxt(gait_out / "history.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    trac = [t for t in gait_scene.loads if t.kind == "traction"][0]
    applied = np.array([abs(trac.value[1]) * 0.06 * trac.schedule(t) for t in h["time"]])
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    a1.plot(h["time"], h["normal_force"] / 1e3, label="normal contact force")
    a1.plot(h["time"], applied / 1e3, "--", label="applied femoral load")
    a1.plot(h["time"], 50 * h["tangential_force"] / 1e3, label="tangential force × 50")
    a1.set_ylabel("force (kN/m)")
    a1.legend()
    a1.grid(alpha=0.3)
    a2.plot(h["time"], h["n_stick"], label="stick nodes")
    a2.plot(h["time"], h["n_slip"], label="slip nodes")
    a2.plot(h["time"], h["n_active"], ":", label="in contact")
    a2.set_xlabel("time (s)")
    a2.set_ylabel("slave nodes")
    a2.legend()
    a2.grid(alpha=0.3)
    fig.suptitle("knee2d gait cycle, Coulomb μ = 0.02")
    fig.tight_layout()
    fig.savefig(output / "gait_contact.png", dpi=120)
    print(f"picture: {output / 'gait_contact.png'}")
comm.barrier()
