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
# # A loaded long bone under a dynamic load ramp
#
# A longitudinal (plane strain) section through the diaphysis of a long bone: a cortical
# shell — transversely isotropic, stiffest along the bone axis (Reilly & Burstein 1975) —
# around a soft cancellous core.  The distal end is fixed; the proximal end is loaded
# by an axial compression with some shear that rises over 5 ms, like the load at heel
# strike.  Both tissues are Kelvin–Voigt visco-elastic.  The whole set-up is the scene
# file `data/scenes/long_bone.toml`; this demo runs it, prints what happened and draws
# the displacement and the von Mises stress.
#
# Run it with `python demos/long_bone.py` or `mpiexec -n 2 python demos/long_bone.py`,
# or open it as a notebook (jupytext).  Results go to `results/long_bone/` (or to the
# directory given as the first argument or in `BONECONTACT_OUTPUT`).  Units: SI; 2D
# forces and energies are per metre of thickness.

# %%
import os
import sys
from pathlib import Path

from mpi4py import MPI  # before dolfinx

import numpy as np

from bonecontact.run.dispatch import run_scene
from bonecontact.scene.spec import load_scene

comm = MPI.COMM_WORLD
here = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
root = here.parent if (here.parent / "data" / "scenes").is_dir() else here
args = [a for a in sys.argv[1:] if not a.startswith("-")] if "__file__" in globals() else []
output = Path(args[0] if args else os.environ.get("BONECONTACT_OUTPUT", "results/long_bone"))

# %% [markdown]
# ## The scene
# Materials, boundary conditions, the load ramp and the probes are all in the scene file.

# %%
scene = load_scene(root / "data" / "scenes" / "long_bone.toml")
if comm.rank == 0:
    print(f"scene {scene.name}: {scene.analysis.kind}, t_end = {scene.analysis.t_end} s, "
          f"dt = {scene.analysis.dt} s, materials: {', '.join(m.name for m in scene.materials)}")

# %% [markdown]
# ## Run it
# The operator is assembled and factorised once; each step is one forward/back solve.
# `history.csv`, `probes.csv`, `summary.json` and the fields (`fields.xdmf` for
# ParaView, `fields.pvd` for pyvista) are written as the run goes.

# %%
result = run_scene(scene, comm, output=output, progress=True)
summary = result.summary
if result.status != "converged":
    raise SystemExit(f"run failed: {summary.get('message')}")

# %%
history = np.loadtxt(output / "history.csv", delimiter=",", skiprows=1, usecols=(0, 1, 9, 10)) \
    if comm.rank == 0 else None
probes = np.loadtxt(output / "probes.csv", delimiter=",", skiprows=1) if comm.rank == 0 else None
if comm.rank == 0:
    last = probes[probes[:, 0] == probes[:, 0].max()]
    print(f"{summary['dofs']} dofs on {comm.size} rank(s), {summary['steps']} steps, "
          f"wall time {summary['wall_time_s']:.2f} s (set-up {summary['setup_time_s']:.2f} s)")
    print(f"proximal end (probe 4) at t = {last[3, 1]:.4f} s: u = ({last[3, 5]:.3e}, {last[3, 6]:.3e}) m")
    print(f"mid-shaft cortex von Mises: {last[0, -1] / 1e6:.2f} MPa (x < 0), {last[1, -1] / 1e6:.2f} MPa (x > 0)")
    print(f"energy at t_end: kinetic {history[-1, 2]:.3e} J/m, strain {history[-1, 3]:.3e} J/m")

# %% [markdown]
# ## Pictures
# pyvista reads the `.pvd` series (the VTK in the PyPI wheels cannot read DOLFINx's
# XDMF).  Left: the displacement magnitude on the deformed shape (magnified); right:
# the von Mises stress.

# %%
png = output / "long_bone.png"
if comm.rank == 0:
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = True
    reader = pv.get_reader(str(output / "fields.pvd"))
    reader.set_active_time_point(len(reader.time_values) - 1)
    grid = reader.read().combine()
    disp_name = next(n for n in grid.point_data if n.startswith("displacement"))
    u = grid.point_data[disp_name]
    grid.point_data["|u| (mm)"] = 1e3 * np.linalg.norm(u, axis=1)
    vm_name = next(n for n in grid.cell_data if "von" in n.lower())
    grid.cell_data["von Mises (MPa)"] = grid.cell_data[vm_name] / 1e6
    scale = 0.1 * 0.2 / max(np.abs(u).max(), 1e-30)
    warped = grid.warp_by_vector(disp_name, factor=scale)
    plotter = pv.Plotter(shape=(1, 2), window_size=(1000, 900), off_screen=True)
    plotter.subplot(0, 0)
    plotter.add_text(f"displacement (x{scale:.0f})", font_size=10)
    warped.point_data["|u| (mm)"] = grid.point_data["|u| (mm)"]
    bar = {"fmt": "%.2f", "n_labels": 4, "position_x": 0.2, "width": 0.6}
    plotter.add_mesh(warped, scalars="|u| (mm)", cmap="viridis", show_edges=False, scalar_bar_args=bar)
    plotter.add_mesh(grid, style="wireframe", color="grey", opacity=0.15)
    plotter.view_xy()
    plotter.subplot(0, 1)
    plotter.add_text("von Mises stress", font_size=10)
    plotter.add_mesh(grid, scalars="von Mises (MPa)", cmap="inferno", show_edges=False,
                     scalar_bar_args={**bar, "fmt": "%.1f"})
    plotter.view_xy()
    plotter.screenshot(str(png))
    plotter.close()
    print(f"picture: {png}")
comm.barrier()
