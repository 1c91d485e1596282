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
#
# ## The equations
# Kelvin–Voigt visco-elasticity (the bone model of Nedoma 2015) in plane strain,
# displacement $u$ in m, on $\Omega$ = cortex $\cup$ core:
#
# $$\rho\ddot u - \nabla\cdot\sigma = 0 \quad\text{in } \Omega, \qquad
# \sigma = \mathbb C^{(0)} e(u) + \mathbb C^{(1)} e(\dot u), \qquad \mathbb C^{(1)} = \tau_v\,\mathbb C^{(0)},
# \qquad e(u) = \tfrac12\big(\nabla u + \nabla u^{\mathsf T}\big),$$
#
# $$u = 0 \ \text{on } \Gamma_{\text{distal}}, \qquad
# \sigma n = \min(t/t_r, 1)\,\bar t \ \text{on } \Gamma_{\text{proximal}}, \qquad
# \bar t = (0.2, -1.6)\ \text{MPa}, \quad t_r = 5\ \text{ms}, \qquad u(0) = \dot u(0) = 0,$$
#
# with $\tau_v = 2$ ms in both tissues, $\rho = 1900$ kg/m³ (cortex) and 450 kg/m³ (core).
# The core is isotropic, $E = 1$ GPa, $\nu = 0.25$.  The cortex is transversely isotropic
# about the bone axis $a = e_y$ (Reilly & Burstein 1975): in its material axes
# $(1, 2)$ = isotropy plane, $3 = a$, the compliance in Voigt notation
# $[11, 22, 33, 23, 13, 12]$ (engineering shears) is
#
# $$\mathbb S = \begin{pmatrix}
# 1/E_p & -\nu_p/E_p & -\nu_{pa}/E_p & & & \\
# -\nu_p/E_p & 1/E_p & -\nu_{pa}/E_p & & & \\
# -\nu_{pa}/E_p & -\nu_{pa}/E_p & 1/E_a & & & \\
# & & & 1/G_{pa} & & \\
# & & & & 1/G_{pa} & \\
# & & & & & 2(1+\nu_p)/E_p
# \end{pmatrix}, \qquad \mathbb C^{(0)} = T^{\mathsf T}\,\mathbb S^{-1}\,T,$$
#
# $T$ the Voigt rotation from the global to the material axes, with $E_p = 11.5$ GPa,
# $E_a = 17$ GPa, $\nu_p = 0.58$, $\nu_{pa} = 0.311$ ($\nu_{ap} = \nu_{pa}E_a/E_p$),
# $G_{pa} = 3.3$ GPa.  Plane strain keeps the $[xx, yy, xy]$ block of $\mathbb C^{(0)}$.
# More in [the mechanics notes](../docs/theory/mechanics.md).

# %%
import sys
from pathlib import Path

from mpi4py import MPI  # before dolfinx

import numpy as np

import bonecontact.plot as bp
from bonecontact.common.resources import data_file
from bonecontact.runners import run_scene
from bonecontact.scene import load_scene

comm = MPI.COMM_WORLD
here = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
args = [a for a in sys.argv[1:] if not a.startswith("-")] if "__file__" in globals() else []
# results: the first argument, else $BONECONTACT_OUTPUT/long_bone, else demos/results/long_bone
output = bp.output_dir("long_bone", here, args)

# %% [markdown]
# ## The scene
# Materials, boundary conditions, the load ramp and the probes are all in the scene file.

# %%
scene = load_scene(data_file("scenes", "long_bone.toml"))
if comm.rank == 0:
    print(
        f"scene {scene.name}: {scene.analysis.kind}, t_end = {scene.analysis.t_end} s, "
        f"dt = {scene.analysis.dt} s, materials: {', '.join(m.name for m in scene.materials)}"
    )

# %% [markdown]
# ## Run it
# With P1 elements, the mass, stiffness and viscous matrices
# $M = (\rho u, v)$, $K = (\mathbb C^{(0)} e(u), e(v))$, $K_v = (\mathbb C^{(1)} e(u), e(v))$
# and the load vector $F(t)$, the semi-implicit scheme (second difference for the
# inertia, backward difference for the velocity, stiffness at the new time) is
#
# $$M\,\frac{u^{n+1} - 2u^n + u^{n-1}}{\Delta t^2} + K_v\,\frac{u^{n+1} - u^n}{\Delta t} + K u^{n+1} = F(t^{n+1}),
# \qquad v^{n+1} = \frac{u^{n+1} - u^n}{\Delta t},$$
#
# that is $(M + \Delta t^2 K + \Delta t K_v)\,u^{n+1} = \Delta t^2 F(t^{n+1}) + M(2u^n - u^{n-1}) + \Delta t K_v u^n$,
# with $\Delta t = 0.25$ ms up to $t = 10$ ms and $u^{-1} = u^0 - \Delta t\,v^0$.  It is
# first-order accurate and unconditionally stable: the energy
# $E = \tfrac12 v^{\mathsf T} M v + \tfrac12 u^{\mathsf T} K u$ obeys
# $E^{n+1} - E^n = F^{n+1}\cdot(u^{n+1} - u^n) - \Delta t\,|v^{n+1}|^2_{K_v}
# - \tfrac12|v^{n+1} - v^n|^2_M - \tfrac12|u^{n+1} - u^n|^2_K$ (work of the supports aside).
# The operator is assembled and factorised once; each step is one forward/back solve.
# `history.csv`, `probes.csv`, `summary.json` and the fields (`fields.xdmf` for
# ParaView, `fields.pvd` for pyvista) are written as the run goes.

# %%
result = run_scene(scene, comm, output=output, progress=True)
summary = result.summary
if result.status != "converged":
    raise SystemExit(f"run failed: {summary.get('message')}")

# %%
history = (
    np.loadtxt(output / "history.csv", delimiter=",", skiprows=1, usecols=(0, 1, 9, 10))
    if comm.rank == 0
    else None
)
probes = np.loadtxt(output / "probes.csv", delimiter=",", skiprows=1) if comm.rank == 0 else None
if comm.rank == 0:
    last = probes[probes[:, 0] == probes[:, 0].max()]
    print(
        f"{summary['dofs']} dofs on {comm.size} rank(s), {summary['steps']} steps, "
        f"wall time {summary['wall_time_s']:.2f} s (set-up {summary['setup_time_s']:.2f} s)"
    )
    print(
        f"proximal end (probe 4) at t = {last[3, 1]:.4f} s: u = ({last[3, 5]:.3e}, {last[3, 6]:.3e}) m"
    )
    print(
        f"mid-shaft cortex von Mises: {last[0, -1] / 1e6:.2f} MPa (x < 0), {last[1, -1] / 1e6:.2f} MPa (x > 0)"
    )
    print(f"energy at t_end: kinetic {history[-1, 2]:.3e} J/m, strain {history[-1, 3]:.3e} J/m")

# %% [markdown]
# ## Pictures
# pyvista reads the `.pvd` series (the VTK in the PyPI wheels cannot read DOLFINx's
# XDMF).  The displacement magnitude and the von Mises stress (projected to the vertices
# for display) on the undeformed bone, lengths in mm, proximal up; the dashed line is the
# outline of the deformed bone with the displacement magnified by the stated factor.

# %%
png = output / "long_bone.png"
if comm.rank == 0:
    grid = bp.read_fields(output / "fields.pvd")
    u = np.asarray(grid.point_data["displacement"])
    warp = float(f"{0.1 * 0.2 / max(np.abs(u).max(), 1e-30):.1g}")  # 10 % of the length
    common = dict(
        displacement="displacement",
        warp=warp,
        window_size=(700, 1000),
        directions={"proximal": (0.0, 1.0, 0.0)},
    )
    disp = bp.field_view(
        grid,
        "displacement",
        output / "long_bone_displacement.png",
        quantity=r"displacement $|\mathbf{u}|$",
        unit="µm",
        clim=None,
        title=f"long bone: displacement at t = {summary['steps'] * scene.analysis.dt * 1e3:.0f} ms",
        **common,
    )
    bp.show(disp, disp)
    vm = bp.field_view(
        grid, "von_mises", png, quantity="von Mises stress", unit="MPa", cmap="inferno",
        title="long bone: von Mises stress", **common,
    )  # fmt: skip
    bp.show(vm, vm)
    print(f"pictures: {disp}, {vm}")
comm.barrier()
