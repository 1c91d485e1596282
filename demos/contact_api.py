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
# # Contact through the Python API: a cylinder pressed onto a block (Hertz)
#
# Every other demo runs a scene file.  This one builds the same kind of problem in
# Python, step by step, with the objects a scene run uses inside: a mesh with named
# groups, a `Mechanics` model, a mortar contact interface, the PDAS `ContactSolver` and
# an `Integrator`.  It then reads the contact pressure at the slave nodes and compares
# it with Hertz's solution.
#
# Run it with `python demos/contact_api.py [OUTPUT_DIR]` or
# `mpiexec -n 2 python demos/contact_api.py`, or open it as a notebook (jupytext).
# Units: SI; in plane strain forces are per metre of thickness (N/m).
#
# ## The problem
#
# A half cylinder of radius $R$ (body 1, the slave side) rests on a block (body 2, the
# master side); the meshes do not match at the contact.  Both bodies are linear elastic,
#
# $$ -\nabla\cdot\sigma(u) = 0, \qquad \sigma(u) = \lambda_L\,\mathrm{tr}\,e(u)\,I + 2\mu_L\,e(u),
#    \qquad e(u) = \tfrac12(\nabla u + \nabla u^{\mathsf T}), $$
#
# the block's base is fixed and the cylinder's flat top is moved down by $\delta$.
# On the contact surface the Signorini conditions hold for the gap $g_n$ and the
# contact pressure $\lambda_n$:
#
# $$ g_n \ge 0, \qquad \lambda_n \ge 0, \qquad g_n\,\lambda_n = 0 . $$
#
# The dual mortar method (Wohlmuth 2000) writes them at the slave nodes $p$ with the
# weighted gap $\tilde g_p$ and the nodal multiplier $\lambda_p$, and the primal–dual
# active set method (Hintermüller, Ito & Kunisch 2002; Hüeber & Wohlmuth 2005) solves
# the nonsmooth equation
#
# $$ C_n(\lambda_p, \tilde g_p) = \lambda_p - \max\bigl(0,\ \lambda_p - c_n\,\tilde g_p\bigr) = 0 $$
#
# by a semi-smooth Newton method: a node is active when $\lambda_p - c_n\tilde g_p > 0$
# (see `docs/theory/mortar.md` and `docs/theory/pdas.md`).
#
# ## The reference
#
# For a load $P$ per unit thickness Hertz's half-space solution (Johnson 1985, §4.3) gives
#
# $$ a = \sqrt{\frac{4PR}{\pi E^*}}, \qquad p_0 = \frac{2P}{\pi a}, \qquad
#    p(x) = p_0\sqrt{1 - x^2/a^2}, \qquad
#    \frac1{E^*} = \frac{1-\nu_1^2}{E_1} + \frac{1-\nu_2^2}{E_2}. $$

# %%
import sys
from pathlib import Path

from mpi4py import MPI  # before dolfinx

import numpy as np

import bonecontact.plot as bp
from bonecontact import (
    ContactSolver,
    Integrator,
    Isotropic,
    Mechanics,
    PDASOptions,
    build_interface,
)
from bonecontact.meshing import hertz_2d
from bonecontact.verification import contact_modulus
from bonecontact.verification import hertz_2d as hertz

comm = MPI.COMM_WORLD
here = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
args = [a for a in sys.argv[1:] if not a.startswith("-")] if "__file__" in globals() else []
# results: the first argument, else $BONECONTACT_OUTPUT/contact_api, else demos/results/contact_api
output = bp.output_dir("contact_api", here, args)

# %% [markdown]
# ## 1. The mesh
# `bonecontact.meshing.hertz_2d` builds the two bodies with gmsh, refined near the
# contact point, and returns the mesh with its cell and facet groups by name.

# %%
R, E1, E2, NU = 0.01, 2.0e9, 17.0e9, 0.3  # cylinder radius (m); cartilage-like on bone (Pa)
a_target = 5.0e-4  # the half-width we aim at: a/R = 0.05, inside Hertz's assumptions
md = hertz_2d(comm, radius=R, h_contact=a_target / 10, zone=1.5 * a_target, h_far=2e-3)
tag = {name: group.tag for name, group in md.physical_groups.items()}

# %% [markdown]
# ## 2. The model
# One material per cell group; Dirichlet conditions per component.  The approach
# $\delta$ is chosen so that $a \approx$ `a_target`; the load $P$ is then measured.

# %%
model = Mechanics(
    md.mesh,
    {tag["cylinder"]: Isotropic(E=E1, nu=NU), tag["block"]: Isotropic(E=E2, nu=NU)},
    md.cell_tags,
    md.facet_tags,
)
delta = (
    2.5 * hertz.load_for_half_width(a_target, R, E1, NU, E2, NU) / contact_modulus(E1, NU, E2, NU)
)
for component in (0, 1):
    model.add_dirichlet(model.facets(tag["block_bottom"]), component, 0.0)
model.add_dirichlet(model.facets(tag["cyl_top"]), 0, 0.0)
model.add_dirichlet(model.facets(tag["cyl_top"]), 1, -delta)

# %% [markdown]
# ## 3. Contact: the mortar interface and the PDAS solver
# The interface holds the mortar matrices $D$ and $M$ and the slave nodes' normals; the
# solver takes its options as one `PDASOptions` object (frictionless here).

# %%
interface = build_interface(
    model.V, md.facet_tags, tag["cyl_contact"], tag["block_contact"], dirichlet_dofs=model.bc_dofs()
)
solver = ContactSolver(model.V, [interface], PDASOptions(max_iterations=30))

# %% [markdown]
# ## 4. Solve
# A static analysis is one step of the integrator: the operator is assembled and
# factorised once, and the PDAS iterates on the active set.

# %%
integrator = Integrator(model, "static", 1.0, contact=solver)
integrator.step()
result = integrator.last_contact
if comm.rank == 0:
    print(f"PDAS: {result.iterations} iterations, {result.n_active[0]} active slave nodes")

# %% [markdown]
# ## 5. Read the contact pressure and compare with Hertz
# The result holds, per interface, the multiplier $\lambda_p$ (Pa) at this rank's slave
# nodes.  The load is the vertical resultant $P = -\sum_p w_p\,\lambda_p\,n_{p,y}$.

# %%
x = np.concatenate(comm.allgather(interface.coords[:, 0]))
pressure = np.concatenate(comm.allgather(result.pressure[0]))
P = comm.allreduce(
    float(-(interface.weight * result.pressure[0] * interface.normals[:, 1]).sum()), op=MPI.SUM
)
order = np.argsort(x)
x, pressure = x[order], pressure[order]
a_ref = hertz.half_width(P, R, E1, NU, E2, NU)
p0_ref = hertz.peak_pressure(P, R, E1, NU, E2, NU)
inner = np.abs(x) < 0.8 * a_ref
c0, c1 = np.linalg.lstsq(
    np.c_[np.ones(inner.sum()), x[inner] ** 2], pressure[inner] ** 2, rcond=None
)[0]
a_fit = np.sqrt(-c0 / c1)  # least-squares fit of λ² = p0² (1 − x²/a²)
errors = {
    "load_N_per_m": P,
    "a_error": a_fit / a_ref - 1.0,
    "p0_error": pressure.max() / p0_ref - 1.0,
    "pdas_iterations": result.iterations,
}
if comm.rank == 0:
    print(
        f"load P = {P:.4g} N/m: half-width a {a_fit * 1e3:.4f} mm (Hertz {a_ref * 1e3:.4f} mm, "
        f"{100 * errors['a_error']:+.2f} %), peak pressure {pressure.max() / 1e6:.3f} MPa "
        f"(Hertz {p0_ref / 1e6:.3f} MPa, {100 * errors['p0_error']:+.2f} %)"
    )

# %% [markdown]
# ## 6. Write and plot
# `pressure.csv` holds the slave nodes' positions and pressures; the plot lays the
# computed pressure over Hertz's profile.

# %%
if comm.rank == 0:
    import json

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    output.mkdir(parents=True, exist_ok=True)
    np.savetxt(
        output / "pressure.csv",
        np.c_[x, pressure],
        delimiter=",",
        header="x_m,pressure_Pa",
        comments="",
    )
    (output / "hertz.json").write_text(json.dumps(errors, indent=2))
    xs = np.linspace(-a_ref, a_ref, 201)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot(xs * 1e3, hertz.pressure(xs, P, R, E1, NU, E2, NU) / 1e6, "k-", label="Hertz")
    ax.plot(x * 1e3, pressure / 1e6, "o", ms=3, label="dual mortar + PDAS")
    ax.set_xlim(-1.5 * a_ref * 1e3, 1.5 * a_ref * 1e3)
    bp.line_axes(ax, ("x", "mm"), ("contact pressure", "MPa"), "half cylinder on a block")
    ax.legend(fontsize=8)
    bp.caption(
        fig, "Hertz: cylinder on a half-space (Johnson 1985, §4.3), same load per unit thickness."
    )
    bp.show(fig, output / "contact_pressure.png", dpi=100)
    print(f"results in {output}/")
integrator.destroy()
