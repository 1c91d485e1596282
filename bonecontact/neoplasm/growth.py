"""Growth drivers: a tumour or a cyst advanced step by step, one table row per step.

The drivers behind growth-only and coupled runs (:mod:`bonecontact.runners.growth`,
:mod:`bonecontact.runners.coupled`; format in ``docs/neoplasm_format.md``):

* :class:`TumourGrowth`: a :class:`bonecontact.neoplasm.tumour.TumourModel` (Problem P_T of
  docs/theory/growth.md#tumour-model on a moving, gmsh-remeshed tumour mesh);
* :class:`CystSphereGrowth`: the closed osmotic/Maxwell ODE of :mod:`bonecontact.neoplasm.cyst`
  (a sphere in 3D, a cylinder per unit length in 2D), integrated step by step with Radau
  (rtol 1e-11);
* :class:`CystShapeGrowth`: the moving-wall cyst of :mod:`bonecontact.neoplasm.cyst_shape`.

Each has ``columns``, ``step(dt)``, ``row()`` (``volume, surface_area,
equivalent_radius[, pressure]``: 3D volume m³, surface area m², equivalent radius
(3V/4π)^(1/3) m; 2D area m², perimeter m, equivalent radius √(A/π) m; pressure Pa) and
``info()`` (summary entries).  The builders below make a driver from a radius (a disc or
ball) or from the boundary of a region of a mesh; they know nothing of scenes.
"""

from __future__ import annotations

import math
from typing import Any

from mpi4py import MPI

import numpy as np
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from scipy.integrate import solve_ivp

from bonecontact.neoplasm import remesh
from bonecontact.neoplasm.cyst import radius_rate
from bonecontact.neoplasm.cyst_shape import CystShapeModel
from bonecontact.neoplasm.tumour import TumourModel

__all__ = [
    "GROWTH_COLUMNS",
    "CystShapeGrowth",
    "CystSphereGrowth",
    "TumourGrowth",
    "cyst_shape_growth",
    "equivalent_radius",
    "mesh_measure",
    "region_boundary",
    "region_submesh",
    "surface_tension_dt_limit",
    "tumour_growth",
]

#: Columns of growth.csv (cysts add ``pressure``).
GROWTH_COLUMNS = ("time", "volume", "surface_area", "equivalent_radius")


def surface_tension_dt_limit(gamma: float, h: float) -> float:
    """Largest stable growth step with explicit surface tension, ``2 h³ / (γ π³)`` (s).

    The capillary limit dt ≲ 2 R³ / (γ l_max³) of :mod:`bonecontact.neoplasm.tumour` with the
    highest boundary mode l_max ≈ π R / h (``inf`` when ``gamma = 0``).
    """
    return math.inf if gamma <= 0 else 2.0 * h**3 / (gamma * math.pi**3)


class CystSphereGrowth:
    """The closed cyst ODE (docs/theory/growth.md#cyst-model) advanced step by step.

    Parameters
    ----------
    params
        :class:`bonecontact.neoplasm.cyst.CystParameters`.
    R0
        Initial (and, for engineering strain, reference) radius (m).
    dim
        3 (sphere) or 2 (cylinder per unit length).
    """

    columns = GROWTH_COLUMNS + ("pressure",)

    def __init__(self, params: Any, R0: float, dim: int):
        self.params = params
        self.R0 = float(R0)
        self.dim = dim
        self.R = float(R0)
        self.f = float(params.f0)
        self.t = 0.0
        self.steps = 0
        self.remeshes = 0
        self._rhs = radius_rate(params, self.R0, dim)
        self._atol = [
            1e-14 * self.R0,
            1e-12 * max(params.alpha * params.C_minus, abs(params.f0), 1.0),
        ]

    def step(self, dt: float) -> None:
        """Advance by ``dt`` (s) with Radau, rtol 1e-11 (raises RuntimeError on failure)."""
        sol = solve_ivp(
            self._rhs,
            (self.t, self.t + dt),
            [self.R, self.f],
            method="Radau",
            rtol=1e-11,
            atol=self._atol,
        )
        if not sol.success:
            raise RuntimeError(f"cyst ODE integration failed: {sol.message}")
        self.R, self.f = float(sol.y[0, -1]), float(sol.y[1, -1])
        self.t += dt
        self.steps += 1

    def row(self) -> list[float]:
        """``volume, surface_area, equivalent_radius, pressure`` now."""
        R = self.R
        if self.dim == 3:
            return [4.0 / 3.0 * math.pi * R**3, 4.0 * math.pi * R**2, R, self.f]
        return [math.pi * R**2, 2.0 * math.pi * R, R, self.f]

    def checkpoint_state(self) -> dict[str, Any]:
        """What a restart needs besides the mesh and fields (here everything: R, f, t, steps)."""
        return {"R": self.R, "f": self.f, "t": self.t, "steps": self.steps}

    def restore_checkpoint_state(self, state: dict[str, Any]) -> None:
        """Continue from :meth:`checkpoint_state` (a restart)."""
        self.R, self.f = float(state["R"]), float(state["f"])
        self.t, self.steps = float(state["t"]), int(state["steps"])

    def info(self) -> dict[str, Any]:
        return {
            "model": "cyst sphere ODE (osmotic/Maxwell)"
            if self.dim == 3
            else "cyst cylinder ODE per unit length (osmotic/Maxwell)",
            "strain": self.params.strain,
            "final_pressure_Pa": self.f,
        }


class CystShapeGrowth:
    """A :class:`bonecontact.neoplasm.cyst_shape.CystShapeModel` as a growth-scene driver."""

    columns = GROWTH_COLUMNS + ("pressure",)

    def __init__(self, model: Any):
        self.model = model
        self.dim = model.dim

    @property
    def t(self) -> float:
        return self.model.t

    @property
    def steps(self) -> int:
        return self.model.steps

    @property
    def remeshes(self) -> int:
        return self.model.remeshes

    @property
    def f(self) -> float:
        """Osmotic excess pressure P_h⁺ − P_h⁻ now (Pa)."""
        return self.model.f

    def step(self, dt: float) -> None:
        """One growth step (collective); the model remeshes every ``remesh_every`` steps."""
        self.model.step(dt)

    def checkpoint_state(self) -> dict[str, Any]:
        """The scalars a restart needs besides the mesh: time, counters, pressure, the last
        wall velocity and the references of the strain and of the mesh size."""
        m = self.model
        return {
            "t": m.t,
            "steps": m.steps,
            "remeshes": m.remeshes,
            "f": m.f,
            "vn": m.normal_velocity(),
            "R_eq0": m.R_eq0,
            "L0": m.L0,
            "h0": m.h0,
        }

    def restore_checkpoint_state(self, state: dict[str, Any]) -> None:
        """Continue from :meth:`checkpoint_state` (after :meth:`replace_mesh`)."""
        m = self.model
        m.t, m.steps, m.remeshes = float(state["t"]), int(state["steps"]), int(state["remeshes"])
        m.f = float(state["f"])
        m.restore_normal_velocity(float(state["vn"]))
        m.R_eq0, m.L0, m.h0 = float(state["R_eq0"]), float(state["L0"]), float(state["h0"])

    def fields(self) -> dict[str, fem.Function]:
        """The fields a restart needs besides the mesh (none: the wall is the mesh's boundary)."""
        return {}

    def replace_mesh(self, msh: dmesh.Mesh) -> None:
        """Continue on ``msh`` (a restart's copy of the checkpoint's mesh; collective)."""
        self.model.replace_mesh(msh)

    def row(self) -> list[float]:
        """``volume, surface_area, equivalent_radius, pressure`` of the current cyst mesh."""
        m = self.model
        v, S = m.volume(), m.surface_area()
        R = math.sqrt(v / math.pi) if self.dim == 2 else (3.0 * v / (4.0 * math.pi)) ** (1.0 / 3.0)
        return [v, S, R, m.f]

    def info(self) -> dict[str, Any]:
        m = self.model
        im = m.mesh.topology.index_map(self.dim)
        return {
            "model": f"cyst moving wall (osmotic/Maxwell), {self.dim}D, remeshed by gmsh",
            "strain": m.params.strain,
            "final_pressure_Pa": m.f,
            "h_m": m.h0,
            "final_h_m": m.mesh_size(),
            "final_cells": int(im.size_global),
        }


class TumourGrowth:
    """A :class:`bonecontact.neoplasm.tumour.TumourModel` with a remesh counter."""

    columns = GROWTH_COLUMNS

    def __init__(self, model: Any, remesh_every: int):
        self.model = model
        self.remesh_every = remesh_every
        self.dim = model.dim
        self.remeshes = 0

    @property
    def t(self) -> float:
        return self.model.t

    @property
    def steps(self) -> int:
        return self.model.steps

    def step(self, dt: float) -> None:
        """One growth step (collective); the model remeshes every ``remesh_every`` steps."""
        self.model.step(dt)
        if self.remesh_every and self.model.steps % self.remesh_every == 0:
            self.remeshes += 1

    def checkpoint_state(self) -> dict[str, Any]:
        """The scalars a restart needs besides the mesh and :meth:`fields`."""
        m = self.model
        return {
            "t": m.t,
            "steps": m.steps,
            "remeshes": self.remeshes,
            "smoothed_remeshes": m.smoothed_remeshes,
            "h": m.h,
            "degree": m.degree,
        }

    def restore_checkpoint_state(self, state: dict[str, Any]) -> None:
        """Continue from :meth:`checkpoint_state` (after :meth:`replace_mesh`)."""
        m = self.model
        m.t, m.steps = float(state["t"]), int(state["steps"])
        self.remeshes, m.smoothed_remeshes = int(state["remeshes"]), int(state["smoothed_remeshes"])

    def fields(self) -> dict[str, fem.Function]:
        """The fields a restart needs besides the mesh: the densities u_p, u_q (DG0), the
        nutrient u_c (its previous value with eps0 > 0) and the mesh displacement ``w`` of
        the last step (the ALE term of the nutrient with eps0 > 0)."""
        m = self.model
        if m.degree != 1:
            raise ValueError("checkpoints of a tumour need degree = 1")
        return {"u_p": m.u_p, "u_q": m.u_q, "u_c": m.u_c, "w": m.mesh_displacement}

    def replace_mesh(self, msh: dmesh.Mesh) -> None:
        """Continue on ``msh`` (a restart's copy of the checkpoint's mesh; collective)."""
        self.model.replace_mesh(msh)

    def row(self) -> list[float]:
        m = self.model
        return [m.volume(), m.surface_area(), m.equivalent_radius()]

    def info(self) -> dict[str, Any]:
        im = self.model.mesh.topology.index_map(self.dim)
        return {
            "model": f"tumour P_T , {self.dim}D, remeshed by gmsh",
            "h_m": self.model.h,
            "final_cells": int(im.size_global),
        }


# ----------------------------------------------------------------------------- builders
def region_submesh(mesh_data: Any, tag: int, comm: MPI.Comm) -> dmesh.Mesh | None:
    """The submesh of the cells tagged ``tag`` (collective); ``None`` when no rank has one."""
    cells = mesh_data.cell_tags.find(tag)
    if comm.allreduce(len(cells), op=MPI.SUM) == 0:
        return None
    msh = mesh_data.mesh
    return dmesh.create_submesh(msh, msh.topology.dim, cells)[0]


def mesh_measure(msh: dmesh.Mesh) -> float:
    """Area (2D) or volume (3D) of a mesh (collective)."""
    one = fem.form(fem.Constant(msh, 1.0) * ufl.dx(domain=msh))
    return msh.comm.allreduce(fem.assemble_scalar(one), op=MPI.SUM)


def equivalent_radius(measure: float, dim: int) -> float:
    """Radius of the disc (2D) or ball (3D) of the given area or volume."""
    return (
        math.sqrt(measure / math.pi)
        if dim == 2
        else (3.0 * measure / (4.0 * math.pi)) ** (1.0 / 3.0)
    )


def region_boundary(sub: dmesh.Mesh, dim: int) -> tuple[remesh.Boundary, float]:
    """The boundary of a region's submesh and its mean edge length (collective).

    Raises
    ------
    bonecontact.neoplasm.remesh.RemeshError
        The boundary is not one closed curve (2D) / surface (3D).
    """
    b = remesh.gather_boundary(sub)
    edges = (
        b.points[b.facets[:, 1]] - b.points[b.facets[:, 0]]
        if dim == 2
        else b.points[b.facets[:, [1, 2, 0]]] - b.points[b.facets]
    )
    return b, float(np.mean(np.linalg.norm(edges.reshape(-1, dim), axis=1)))


def tumour_growth(
    comm: MPI.Comm,
    params: Any,
    dim: int,
    h: float,
    remesh_every: int,
    *,
    radius: float | None = None,
    boundary: remesh.Boundary | None = None,
) -> TumourGrowth:
    """A tumour driver: a disc/ball of ``radius``, or the region bounded by ``boundary``
    (collective).

    Raises
    ------
    bonecontact.neoplasm.remesh.RemeshError
        gmsh cannot mesh the initial tumour.
    """
    kwargs = {"remesh_every": remesh_every}
    if boundary is None:
        model = (TumourModel.disc if dim == 2 else TumourModel.ball)(
            comm, radius, params, h, **kwargs
        )
    elif dim == 2:
        model = TumourModel(
            comm, remesh.resample_closed_curve(boundary.points, h), params, h, **kwargs
        )
    else:
        model = TumourModel(
            comm,
            remesh.surface_mesh(boundary.points, boundary.facets, h, comm),
            params,
            h,
            **kwargs,
        )
    return TumourGrowth(model, remesh_every)


def cyst_shape_growth(
    comm: MPI.Comm,
    params: Any,
    dim: int,
    h: float,
    remesh_every: int,
    *,
    radius: float | None = None,
    boundary: remesh.Boundary | None = None,
) -> CystShapeGrowth:
    """A moving-wall cyst driver: a disc/ball of ``radius``, or the region bounded by ``boundary``.

    Raises
    ------
    bonecontact.neoplasm.remesh.RemeshError
        gmsh cannot mesh the initial cyst.
    """
    kwargs = {"remesh_every": remesh_every}
    if boundary is None:
        model = (CystShapeModel.disc if dim == 2 else CystShapeModel.ball)(
            comm, radius, params, h, **kwargs
        )
    elif dim == 2:
        model = CystShapeModel(
            comm, remesh.resample_closed_curve(boundary.points, h), params, h, **kwargs
        )
    else:
        model = CystShapeModel(
            comm,
            remesh.surface_mesh(boundary.points, boundary.facets, h, comm),
            params,
            h,
            **kwargs,
        )
    return CystShapeGrowth(model)
