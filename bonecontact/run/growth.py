"""Growth-only scenes: a tumour or a cyst grown alone, written to ``growth.csv``.

A scene with ``[neoplasm]`` and no ``[analysis]`` (``Scene.growth_only``) runs here
(:func:`run_growth`, called by :func:`bonecontact.run.dispatch.run_scene`); the format is in
``docs/neoplasm_format.md``.

* ``kind = "tumour"``: :class:`bonecontact.neoplasm.tumour.TumourModel` (Problem P_T of SPEC §6.1
  on a moving, gmsh-remeshed tumour mesh).  The initial tumour is the cell group
  ``region`` of the scene's mesh (its boundary is extracted and re-sampled at the mesh
  size ``h``), or, in a meshless scene, a disc (2D) / ball (3D) of ``radius`` (extension).
* ``kind = "cyst"``, ``model = "sphere"``: the closed osmotic/Maxwell ODE of
  :mod:`bonecontact.neoplasm.cyst` (a sphere in 3D, a cylinder per unit length in 2D), integrated
  step by step with Radau (rtol 1e-11).  The initial radius is ``radius`` or the
  equivalent radius of ``region``.
* ``kind = "cyst"``, ``model = "shape"``: the moving-wall cyst of
  :mod:`bonecontact.neoplasm.cyst_shape` (volume and wall area from the current cyst mesh, the wall
  moved with the uniform normal velocity of the osmotic/Maxwell balance, gmsh-remeshed
  every ``remesh_every`` steps).  The initial cyst is the cell group ``region`` (its
  boundary kept as the wall: 2D re-sampled at the mean boundary edge h, 3D the surface
  triangulation kept) or, meshless, a disc (2D) / ball (3D) of ``radius`` with mesh
  size h = radius/8.  The mesh size then scales with the cyst's equivalent radius.

Results (rank 0 writes, one row per growth step, flushed as the run goes):

``growth.csv``
    ``time,volume,surface_area,equivalent_radius`` (+ ``pressure`` for cysts): time in s;
    3D volume m³, surface area m², equivalent radius (3V/4π)^(1/3) m; 2D area m² (per unit
    thickness), perimeter m, equivalent radius √(A/π) m; ``pressure`` = P_h⁺ − P_h⁻, the
    osmotic excess pressure of the cyst lumen over its surroundings, in Pa.  Row 0 is t = 0.
``boundary.csv`` (tumour, shape cyst)
    The final tumour / cyst wall vertices ``x,y[,z]`` (m); 2D in counter-clockwise order.
``summary.json``
    The usual run summary plus a ``growth`` entry (steps, remeshes, initial and final
    radius, status, units).

Every input problem - including the ones found only with the mesh (``region`` not a
cell group, a region whose boundary is not one closed curve) - is a
:class:`~bonecontact.scene.spec.SceneError` raised on every rank before anything is written.
The rows do not depend on the number of ranks (the cyst ODE is replicated; the tumour
model is partition independent to round-off).
"""

from __future__ import annotations

import csv
import json
import math
import time
from pathlib import Path
from typing import Any

import dolfinx
import numpy as np
from mpi4py import MPI
from scipy.integrate import solve_ivp
from tqdm import tqdm

from bonecontact.common.version import __version__
from bonecontact.scene.spec import Scene, SceneError

__all__ = ["GROWTH_COLUMNS", "CystShapeGrowth", "CystSphereGrowth", "TumourGrowth", "build_growth",
           "run_growth", "surface_tension_dt_limit"]

#: Columns of growth.csv (cysts add ``pressure``).
GROWTH_COLUMNS = ("time", "volume", "surface_area", "equivalent_radius")


def surface_tension_dt_limit(gamma: float, h: float) -> float:
    """Largest stable growth step with explicit surface tension, ``2 h³ / (γ π³)`` (s).

    The capillary limit dt ≲ 2 R³ / (γ l_max³) of :mod:`bonecontact.neoplasm.tumour` with the
    highest boundary mode l_max ≈ π R / h (``inf`` when ``gamma = 0``).
    """
    return math.inf if gamma <= 0 else 2.0 * h**3 / (gamma * math.pi**3)


class CystSphereGrowth:
    """The closed cyst ODE (SPEC §6.2) advanced step by step.

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
        from bonecontact.neoplasm.cyst import _rhs

        self.params = params
        self.R0 = float(R0)
        self.dim = dim
        self.R = float(R0)
        self.f = float(params.f0)
        self.t = 0.0
        self.steps = 0
        self.remeshes = 0
        self._rhs = _rhs(params, self.R0, dim)
        self._atol = [1e-14 * self.R0, 1e-12 * max(params.alpha * params.C_minus, abs(params.f0), 1.0)]

    def step(self, dt: float) -> None:
        """Advance by ``dt`` (s) with Radau, rtol 1e-11 (raises RuntimeError on failure)."""
        sol = solve_ivp(self._rhs, (self.t, self.t + dt), [self.R, self.f], method="Radau", rtol=1e-11,
                        atol=self._atol)
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

    def info(self) -> dict[str, Any]:
        return {"model": "cyst sphere ODE (osmotic/Maxwell, SPEC 6.2)" if self.dim == 3
                else "cyst cylinder ODE per unit length (osmotic/Maxwell, SPEC 6.2)",
                "strain": self.params.strain, "final_pressure_Pa": self.f}


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

    def row(self) -> list[float]:
        """``volume, surface_area, equivalent_radius, pressure`` of the current cyst mesh."""
        m = self.model
        v, S = m.volume(), m.surface_area()
        R = math.sqrt(v / math.pi) if self.dim == 2 else (3.0 * v / (4.0 * math.pi)) ** (1.0 / 3.0)
        return [v, S, R, m.f]

    def info(self) -> dict[str, Any]:
        m = self.model
        im = m.mesh.topology.index_map(self.dim)
        return {"model": f"cyst moving wall (osmotic/Maxwell, SPEC 6.2), {self.dim}D, remeshed by gmsh",
                "strain": m.params.strain, "final_pressure_Pa": m.f, "h_m": m.h0,
                "final_h_m": m.mesh_size(), "final_cells": int(im.size_global)}


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

    def row(self) -> list[float]:
        m = self.model
        return [m.volume(), m.surface_area(), m.equivalent_radius()]

    def info(self) -> dict[str, Any]:
        im = self.model.mesh.topology.index_map(self.dim)
        return {"model": f"tumour P_T (SPEC 6.1), {self.dim}D, remeshed by gmsh", "h_m": self.model.h,
                "final_cells": int(im.size_global)}


# ----------------------------------------------------------------------------- set-up
def _region_mesh(scene: Scene, comm: MPI.Comm):
    """The submesh of the ``[neoplasm] region`` cells (after all mesh checks)."""
    from dolfinx import mesh as dmesh

    from bonecontact.run.dispatch import read_mesh

    md, groups = read_mesh(scene, comm)
    neo = scene.neoplasm
    assert neo is not None and neo.region is not None
    tag = groups[neo.region][1]
    cells = md.cell_tags.find(tag)
    if comm.allreduce(len(cells), op=MPI.SUM) == 0:
        raise SceneError(str(scene.path), "[neoplasm]", "region", f'cell group "{neo.region}" has no cells')
    msh = md.mesh
    return dmesh.create_submesh(msh, msh.topology.dim, cells)[0]


def _measure(msh) -> float:
    import ufl
    from dolfinx import fem

    one = fem.form(fem.Constant(msh, 1.0) * ufl.dx(domain=msh))
    return msh.comm.allreduce(fem.assemble_scalar(one), op=MPI.SUM)


def build_growth(scene: Scene,
                 comm: MPI.Comm = MPI.COMM_WORLD) -> CystSphereGrowth | CystShapeGrowth | TumourGrowth:
    """Check a neoplasm scene against its mesh and build the growth model (collective).

    Growth-only and coupled scenes (:mod:`bonecontact.run.coupled`, which adds the
    mechanics) alike.  Nothing is written.

    Raises
    ------
    SceneError
        Every input problem (on every rank).
    """
    neo = scene.neoplasm
    file = str(scene.path)
    if neo is None:  # growth-only or coupled (bonecontact.run.coupled) scenes
        raise SceneError(file, "[neoplasm]", None, "build_growth needs a scene with [neoplasm]")
    dim = scene.dimension
    if neo.kind == "cyst":
        from bonecontact.neoplasm.cyst import CystParameters

        spec = neo.cyst
        assert spec is not None
        try:
            params = CystParameters(**spec.parameters())
        except ValueError as exc:  # the scene reader checks the same ranges
            raise SceneError(file, "[neoplasm.cyst]", None, str(exc)) from None
        if spec.model == "shape":
            return _build_cyst_shape(scene, params, comm)
        if neo.region is not None:
            sub = _region_mesh(scene, comm)
            v = _measure(sub)
            R0 = math.sqrt(v / math.pi) if dim == 2 else (3.0 * v / (4.0 * math.pi)) ** (1.0 / 3.0)
        else:
            R0 = float(neo.radius)  # type: ignore[arg-type]
        return CystSphereGrowth(params, R0, dim)

    from bonecontact.neoplasm import remesh
    from bonecontact.neoplasm.tumour import TumourError, TumourModel, TumourParameters

    spec_t = neo.tumour
    assert spec_t is not None
    try:
        params = TumourParameters.from_dict(spec_t.as_table())
    except TumourError as exc:
        raise SceneError(file, "[neoplasm.tumour]", None, str(exc)) from None
    kwargs = {"remesh_every": neo.remesh_every}
    if neo.region is None:
        R = float(neo.radius)  # type: ignore[arg-type]
        h = neo.h if neo.h is not None else R / 8.0
        _check_dt(scene, params.gamma, h)
        try:
            model = (TumourModel.disc if dim == 2 else TumourModel.ball)(comm, R, params, h, **kwargs)
        except remesh.RemeshError as exc:
            raise SceneError(file, "[neoplasm]", "h", f"gmsh cannot mesh the initial tumour: {exc}") from None
        return TumourGrowth(model, neo.remesh_every)
    b, mean_edge = _region_boundary(scene, comm)
    h = neo.h if neo.h is not None else mean_edge
    _check_dt(scene, params.gamma, h)
    try:
        if dim == 2:
            model = TumourModel(comm, remesh.resample_closed_curve(b.points, h), params, h, **kwargs)
        else:
            model = TumourModel(comm, remesh.surface_mesh(b.points, b.facets, h, comm), params, h, **kwargs)
    except remesh.RemeshError as exc:
        raise SceneError(file, "[neoplasm]", "region",
                         f'gmsh cannot mesh the tumour region "{neo.region}": {exc}') from None
    return TumourGrowth(model, neo.remesh_every)


def _region_boundary(scene: Scene, comm: MPI.Comm):
    """The boundary of the ``region`` cells and its mean edge length (errors on ``region``)."""
    from bonecontact.neoplasm import remesh

    neo = scene.neoplasm
    assert neo is not None
    dim = scene.dimension
    sub = _region_mesh(scene, comm)
    try:
        b = remesh.gather_boundary(sub)
    except remesh.RemeshError as exc:
        raise SceneError(str(scene.path), "[neoplasm]", "region",
                         f'the boundary of "{neo.region}" must be one closed {"curve" if dim == 2 else "surface"} '
                         f"(a simply connected region): {exc}") from None
    edges = b.points[b.facets[:, 1]] - b.points[b.facets[:, 0]] if dim == 2 else \
        b.points[b.facets[:, [1, 2, 0]]] - b.points[b.facets]
    return b, float(np.mean(np.linalg.norm(edges.reshape(-1, dim), axis=1)))


def _build_cyst_shape(scene: Scene, params: Any, comm: MPI.Comm) -> CystShapeGrowth:
    """The moving-wall cyst from ``region`` or a meshless disc/ball (collective)."""
    from bonecontact.neoplasm import remesh
    from bonecontact.neoplasm.cyst_shape import CystShapeModel

    neo = scene.neoplasm
    assert neo is not None
    file, dim = str(scene.path), scene.dimension
    kwargs = {"remesh_every": neo.remesh_every}
    if neo.region is None:
        R = float(neo.radius)  # type: ignore[arg-type]
        try:
            model = (CystShapeModel.disc if dim == 2 else CystShapeModel.ball)(comm, R, params, R / 8.0, **kwargs)
        except remesh.RemeshError as exc:
            raise SceneError(file, "[neoplasm]", "radius", f"gmsh cannot mesh the initial cyst: {exc}") from None
        return CystShapeGrowth(model)
    b, h = _region_boundary(scene, comm)
    try:
        if dim == 2:
            model = CystShapeModel(comm, remesh.resample_closed_curve(b.points, h), params, h, **kwargs)
        else:
            model = CystShapeModel(comm, remesh.surface_mesh(b.points, b.facets, h, comm), params, h, **kwargs)
    except remesh.RemeshError as exc:
        raise SceneError(file, "[neoplasm]", "region",
                         f'gmsh cannot mesh the cyst region "{neo.region}": {exc}') from None
    return CystShapeGrowth(model)


def _check_dt(scene: Scene, gamma: float, h: float) -> None:
    neo = scene.neoplasm
    assert neo is not None
    limit = surface_tension_dt_limit(gamma, h)
    if neo.dt > limit:
        raise SceneError(str(scene.path), "[neoplasm]", "dt",
                         f"{neo.dt!r} s exceeds the explicit surface-tension limit 2 h^3 / (gamma pi^3) = "
                         f"{limit:.4g} s (gamma = {gamma!r}, h = {h:.4g} m); take a smaller dt or a larger h")


# ----------------------------------------------------------------------------- run
def _fmt(x: float) -> str:
    return repr(float(x))


def run_growth(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD, output: Path | None = None,
               progress: bool = True):
    """Run a growth-only scene: growth.csv, boundary.csv (tumour, shape cyst) and summary.json.

    Returns
    -------
    bonecontact.run.dispatch.RunResult
        ``status`` ``"converged"`` or ``"failed"`` (a growth step raised: the message is
        in the summary, the rows of the steps done are in growth.csv).
    """
    from bonecontact.run.dispatch import RunResult

    t_start = time.perf_counter()
    driver = build_growth(scene, comm)   # SceneError before anything is written
    neo = scene.neoplasm
    assert neo is not None
    outdir = Path(output) if output is not None else scene.output.directory
    times = np.concatenate([[0.0], neo.times()])
    columns = driver.columns
    fh = writer = None
    if comm.rank == 0:
        outdir.mkdir(parents=True, exist_ok=True)
        fh = open(outdir / "growth.csv", "w", newline="")
        writer = csv.writer(fh)
        writer.writerow(columns)
    comm.barrier()

    def record(t: float) -> list[float]:
        vals = driver.row()  # collective (tumour, shape cyst)
        if writer is not None:
            writer.writerow([f"{t:.15g}"] + [_fmt(v) for v in vals])  # k*dt printed as written
            fh.flush()
        return vals

    status, message = "converged", None
    first = record(0.0)
    last, t_done = first, 0.0
    bar = tqdm(total=len(times) - 1, desc=scene.name, unit="step", disable=(comm.rank != 0) or not progress,
               dynamic_ncols=True)
    try:
        for k in range(1, len(times)):
            driver.step(float(times[k] - times[k - 1]))
            last, t_done = record(float(times[k])), float(times[k])
            bar.update(1)
    except RuntimeError as exc:  # TumourError, RemeshError, CoverageError, PETSc errors, ODE failure
        status = "failed"
        message = f"growth step {driver.steps + 1} (t = {times[driver.steps + 1]:.6g} s): {exc}"
    finally:
        bar.close()
        if fh is not None:
            fh.close()
    b = None
    if isinstance(driver, (TumourGrowth, CystShapeGrowth)):
        try:
            b = driver.model.boundary()   # collective; replicated
        except RuntimeError:  # a failed remesh may leave no usable boundary: skip the file
            b = None
        if b is not None and comm.rank == 0:
            with open(outdir / "boundary.csv", "w", newline="") as f:
                w = csv.writer(f)
                w.writerow(list("xyz"[:driver.dim]))
                for p in b.points:
                    w.writerow([_fmt(x) for x in p])
    length = "m" if driver.dim == 3 else "m (per unit thickness in 2D)"
    growth = {
        "kind": neo.kind, "dimension": driver.dim, "status": status, "steps": driver.steps,
        "steps_planned": len(times) - 1, "remeshes": driver.remeshes, "t_end": neo.t_end, "dt": neo.dt,
        "final_time": t_done, "initial_radius": first[2], "final_radius": last[2],
        "initial_volume": first[0], "final_volume": last[0], "final_surface_area": last[1],
        "geometry": (f'cell group "{neo.region}" of {scene.mesh_path.name}' if neo.region is not None
                     and scene.mesh_path is not None else f"radius = {neo.radius!r} m (meshless)"),
        "units": {"time": "s", "radius": "m",
                  "volume": "m^3" if driver.dim == 3 else "m^2 (area)",
                  "surface_area": "m^2" if driver.dim == 3 else "m (perimeter)", "pressure": "Pa",
                  "lengths": length},
        **driver.info(),
    }
    summary: dict[str, Any] = {
        "scene": scene.name, "format": 1, "status": status, "ranks": comm.size,
        "wall_time_s": time.perf_counter() - t_start,
        "units": "SI (m, kg, s, Pa, N; 2D: per unit thickness)",
        "bonecontact_version": __version__, "dolfinx_version": dolfinx.__version__,
        "steps": driver.steps, "growth": growth,
    }
    if message is not None:
        summary["message"] = message
    if comm.rank == 0:
        with open(outdir / "summary.json", "w") as f:
            json.dump(summary, f, indent=2)
    comm.barrier()
    return RunResult(status, summary, None, outdir)
