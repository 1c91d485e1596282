"""Neoplasm growth coupled to the loaded bone: the ``coupled`` run kind (2D and 3D).

A *coupled* scene has ``[neoplasm]`` **and** ``[analysis]``.  :func:`run_coupled` advances
the growth model of :func:`bonecontact.runners.growth.build_growth` step by step (writing
``growth.csv``) and, every ``mechanics_every`` growth steps and after the last, runs the
scene's analysis on the host mesh rebuilt around the current neoplasm:

1. gmsh rebuilds the host mesh on rank 0 (:func:`bonecontact.neoplasm.host.build_host_mesh`,
   3D :func:`~bonecontact.neoplasm.host3d.build_host_mesh3d`) and the mesh is distributed
   from the open gmsh model (``host_mesh.msh`` is written for the user, never read back);
2. :func:`analysis_model` builds the mechanics model on that mesh from the scene checked
   once at the start (only the new mesh's own checks run again; the plausibility findings
   of the check at t = 0 are kept, not repeated);
3. :func:`bonecontact.runners.mechanics.run_model` runs it through the step loop.

A cyst is a cavity loaded by its excess pressure on ``"<region>_wall"``; a tumour keeps
the region's material.  The coupling is one-way and every rebuilt mesh is a fresh
reference configuration.  Classification of the pieces, the result files and
``summary.json``: docs/neoplasm_format.md; the hooks and where the model comes from:
docs/run_loop.md; the method: docs/theory/remeshing.md.
"""

from __future__ import annotations

import math
import signal
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from bonecontact.common.linalg import release_petsc_garbage
from bonecontact.common.profiling import PhaseTimer
from bonecontact.neoplasm.host import (
    CouplingError,
    HostMesh,
    build_host_mesh,
    neoplasm_polygon,
    read_host_geometry,
)
from bonecontact.neoplasm.host3d import build_host_mesh3d, read_host_geometry3d, sphere_surface
from bonecontact.runners.checkpoint import Checkpointer
from bonecontact.runners.growth import (
    GrowthSteps,
    build_growth,
    growth_checkpointer,
    growth_times,
)
from bonecontact.runners.loop import RunStopped, Verdict, progress_bar, run_steps
from bonecontact.runners.mechanics import (
    SceneModel,
    build_model,
    check_mesh_groups,
    check_scene_mesh,
    run_model,
)
from bonecontact.runners.results import (
    SUMMARY_FORMAT,
    GrowthTable,
    RunResult,
    write_points,
    write_summary,
)
from bonecontact.scene import LoadSpec, Scene, SceneError, Schedule
from bonecontact.scene.checks import PlausibilityIssue

__all__ = ["analysis_model", "check_coupled", "mechanics_scene", "run_coupled"]


# ----------------------------------------------------------------------------- mechanics scene
def mechanics_scene(scene: Scene, hm: HostMesh, pressure: float | None, output: Path) -> Scene:
    """The scene's mechanics on a rebuilt host mesh: no ``[neoplasm]``, the cyst pressure added.

    Materials keep only the cell groups that still exist; a cyst adds
    ``[[pressure]] boundary = "<region>_wall", value = pressure`` (ramped with the
    pseudo-time in a static analysis like the scene's own loads, else constant).  The
    mesh is ``hm``'s in memory; ``mesh_path`` names the written result file (if any) in
    messages.
    """
    assert scene.analysis is not None
    present = set(hm.cell_groups)
    materials = tuple(
        replace(m, regions=tuple(r for r in m.regions if r in present))
        for m in scene.materials
        if any(r in present for r in m.regions)
    )
    loads = scene.loads
    if pressure is not None and hm.wall is not None:
        sched = Schedule.from_ramp(1.0) if scene.analysis.kind == "static" else Schedule()
        loads = loads + (
            LoadSpec(kind="pressure", target=(hm.wall,), value=float(pressure), schedule=sched),
        )
    return replace(
        scene,
        mesh_path=hm.path if hm.path is not None else scene.mesh_path,
        neoplasm=None,
        materials=materials,
        loads=loads,
        output=replace(scene.output, directory=output, checkpoint_every=0, checkpoint_time=0.0),
    )


def _signal_number(name: str) -> int:
    """15 for ``"SIGTERM"`` (2 for an unknown name)."""
    return int(getattr(signal.Signals, name, signal.SIGINT))


# ----------------------------------------------------------------------------- driver
class _Coupled:
    """Growth driver + host geometry + the neoplasm boundary of the current state
    (a polygon in 2D, a closed triangulated surface in 3D)."""

    def __init__(self, scene: Scene, comm: MPI.Comm):
        neo = scene.neoplasm
        assert neo is not None and neo.region is not None
        self.scene, self.comm, self.neo = scene, comm, neo
        self.dim = scene.dimension
        self.driver = build_growth(scene, comm)  # checks the scene against the mesh
        geo, info, err = None, None, None
        if comm.rank == 0:
            try:
                geo = (read_host_geometry if self.dim == 2 else read_host_geometry3d)(
                    scene.mesh_path
                )
                size = geo.node_size()
                nodes = np.unique(geo.cells[neo.region][1])
                info = (geo.centroid(neo.region), float(np.median(size[nodes])))
            except Exception as exc:
                err = f"{type(exc).__name__}: {exc}"
        info, err = comm.bcast((info, err), root=0)
        if err is not None:
            raise SceneError(
                str(scene.path), "[scene]", "mesh", f"cannot read the host geometry: {err}"
            )
        self.geo = geo
        self.center, self.h_region = info
        self.cavity = neo.kind == "cyst"

    def polygon(self) -> tuple[npt.NDArray[np.float64], float]:
        """Current neoplasm boundary (ccw) and the mesh size on it (collective)."""
        if self.cavity and hasattr(
            self.driver, "R"
        ):  # cyst ODE: a circle about the region's centroid
            R = self.driver.R
            h = min(max(self.h_region, 2 * math.pi * R / 256), 2 * math.pi * R / 32)
            return neoplasm_polygon(self.center, R, h), h
        # tumour (or a moving-wall cyst): the current boundary of the growth mesh
        m = self.driver.model
        b = m.boundary()
        h = (
            float(m.h)
            if hasattr(m, "h")
            else float(np.mean(np.linalg.norm(np.diff(b.points[:, :2], axis=0), axis=1)))
        )
        return np.asarray(b.points[:, :2]), h

    def surface(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], float]:
        """3D: the current neoplasm surface (points, triangles) and its mesh size (collective).

        Cyst ODE: a geodesic sphere of the current radius about the region's centroid, edge
        about the scene mesh's size at the region (between R/32 and R/4); tumour (or a
        moving-wall cyst): the current boundary of the growth mesh.
        """
        if self.cavity and hasattr(self.driver, "R"):
            R = self.driver.R
            h = min(max(self.h_region, R / 32), R / 4)
            p, t = sphere_surface(self.center, R, h)
            return p, t, h
        m = self.driver.model
        b = m.boundary()
        if hasattr(m, "h"):
            h = float(m.h)
        else:
            e = b.points[b.facets[:, [1, 2, 0]]] - b.points[b.facets]
            h = float(np.mean(np.linalg.norm(e, axis=2)))
        return np.asarray(b.points), np.asarray(b.facets), h

    def pressure(self) -> float | None:
        """Cyst: P_h+ - P_h- now (Pa); tumour: ``None``."""
        if not self.cavity:
            return None
        return float(self.driver.f if hasattr(self.driver, "f") else self.driver.model.f)

    def host_mesh(self, path: Path | None) -> tuple[HostMesh, npt.NDArray[np.float64]]:
        """The rebuilt host mesh (with the distributed mesh in memory; ``path``: the result
        file written for the user, or ``None``) and the neoplasm boundary points embedded
        (collective)."""
        if self.dim == 3:
            pts, tri, h = self.surface()
            return build_host_mesh3d(
                self.geo, self.neo.region, self.neo.host, pts, tri, self.cavity, h, path, self.comm
            ), pts
        poly, h = self.polygon()
        return build_host_mesh(
            self.geo, self.neo.region, self.neo.host, poly, self.cavity, h, path, self.comm
        ), poly


def check_coupled(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """Every check of a coupled scene without running it (collective; nothing written).

    Builds the growth model, the host mesh at t = 0 (in memory) and the mechanics model
    on it.

    Raises
    ------
    SceneError
        On every rank.
    """
    _check(scene, comm, _Coupled(scene, comm))


def _check(scene: Scene, comm: MPI.Comm, cp: _Coupled) -> list[PlausibilityIssue]:
    """The host mesh at t = 0 and the mechanics model on it, with every check of the scene
    (its plausibility findings emitted once and returned for the analyses)."""
    try:
        hm, _ = cp.host_mesh(None)
    except CouplingError as exc:
        raise SceneError(str(scene.path), "[neoplasm]", "region", str(exc)) from None
    ms = mechanics_scene(scene, hm, cp.pressure(), scene.output.directory)
    check_mesh_groups(ms, hm.mesh_data, hm.groups, comm)
    check_scene_mesh(ms, hm.mesh_data, hm.groups)  # the order of read_mesh + build_model
    return build_model(ms, comm, mesh=(hm.mesh_data, hm.groups)).issues


def analysis_model(
    scene: Scene,
    hm: HostMesh,
    comm: MPI.Comm,
    timer: PhaseTimer | None = None,
    issues: list[PlausibilityIssue] | None = None,
) -> SceneModel:
    """The mechanics model of ``scene`` (a :func:`mechanics_scene`) on the host mesh in
    memory (collective; no file read).

    The new mesh's checks run (its groups against the scene's names, bad elements,
    detached pieces, unheld rigid motions); ``issues``: the plausibility findings of the
    check at t = 0, kept and not emitted again (``None``: measured and emitted).
    """
    check_mesh_groups(scene, hm.mesh_data, hm.groups, comm)
    return build_model(scene, comm, timer, mesh=(hm.mesh_data, hm.groups), issues=issues)


# ----------------------------------------------------------------------------- run
def run_coupled(
    scene: Scene,
    comm: MPI.Comm = MPI.COMM_WORLD,
    output: Path | None = None,
    progress: bool = True,
    restart: str | Path | bool | None = None,
) -> RunResult:
    """Run a coupled scene: growth, host remeshing and the scene's analysis (collective).

    ``restart``: continue from the newest checkpoint in the output directory (``True``)
    or from the named one (a path); docs/checkpoint.md.

    Returns
    -------
    RunResult
        The final analysis's result (``status`` ``"failed"`` if the growth or an analysis
        failed; ``summary`` then has the message; ``"interrupted"`` after a signal, with a
        checkpoint), with ``summary["growth"]`` and ``summary["coupling"]``.

    Raises
    ------
    CheckpointError
        The checkpoint to restart from is missing, damaged or from another scene.
    """
    t_start = time.perf_counter()
    timer = PhaseTimer()
    with timer.phase("setup"):
        cp = _Coupled(scene, comm)
    with timer.phase("check"):
        issues = _check(scene, comm, cp)  # SceneError before anything is written
    outdir = Path(output) if output is not None else scene.output.directory
    times = growth_times(scene)
    ckpt = growth_checkpointer(scene, cp.driver, comm, outdir, "coupled")
    analyses = _Analyses(scene, comm, cp, outdir, len(times) - 1, timer)
    analyses.issues = issues
    resumed = None
    if restart:
        resumed = ckpt.resume(None if restart is True else restart)
        analyses.records = list(resumed["records"])
        analyses.last_summary = resumed["last_summary"]
    table = GrowthTable(comm, outdir, cp.driver.columns, append=resumed is not None)
    hooks = CoupledSteps(cp, table, analyses, times, ckpt, resumed)
    first = cp.driver.steps if hooks.pending else cp.driver.steps + 1
    with ckpt.stop:
        bar = progress_bar(comm, scene.name, len(times) - 1, first - 1, progress)
        try:
            end = run_steps(hooks, first, len(times) - 1, bar, resumed is None)
        finally:
            table.close()
    status, message = end.status, end.message
    if status == "converged" and analyses.invalid:  # an analysis beyond small strain
        status = "invalid"
    first, last, t_done = hooks.first, hooks.last, hooks.t_done
    summary = _coupled_summary(
        scene, comm, cp, analyses, status, message, (first, last, t_done), t_start
    )
    summary["coupling"]["phases_s"] = timer.summary(comm)
    summary.update(ckpt.summary())
    write_summary(comm, outdir, summary)
    comm.barrier()
    result = analyses.result
    return RunResult(status, summary, result.integrator if result is not None else None, outdir)


class _Analyses:
    """The mechanics analyses of a coupled run: the host mesh rebuilt, the scene's analysis run."""

    def __init__(
        self,
        scene: Scene,
        comm: MPI.Comm,
        cp: _Coupled,
        outdir: Path,
        nsteps: int,
        timer: PhaseTimer,
    ):
        self.scene, self.comm, self.cp, self.outdir, self.nsteps = scene, comm, cp, outdir, nsteps
        self.timer = timer  # the phases host_rebuild and analyses of the coupled run
        self.signal = 0  # the signal that stopped an analysis
        self.records: list[dict[str, Any]] = []
        self.result: RunResult | None = None
        self.last_summary: dict[str, Any] | None = None  # the last analysis's summary
        self.invalid = False  # an analysis ended "invalid" (beyond small strain)
        self.issues: list[PlausibilityIssue] | None = None  # of the check at t = 0

    def due(self, step: int) -> bool:
        """An analysis follows the last growth step and every ``mechanics_every`` steps."""
        every = self.cp.neo.mechanics_every
        return step == self.nsteps or (every > 0 and step % every == 0)

    def run(self, step: int, t: float, row: list[float]) -> bool:
        """Rebuild the host mesh and run the analysis after growth step ``step``; ``True`` if it
        converged.  An analysis stopped by a signal leaves no record and sets ``signal``."""
        comm, cp = self.comm, self.cp
        final = step == self.nsteps
        where = self.outdir if final else self.outdir / f"mechanics_{step:05d}"
        with self.timer.phase("host_rebuild"):
            hm, poly = cp.host_mesh(where / "host_mesh.msh")
            if comm.rank == 0:
                write_points(where / "neoplasm_boundary.csv", ["x", "y", "z"][: cp.dim], poly)
        pressure = cp.pressure()
        with self.timer.phase("analyses"):
            res = self.analyse(mechanics_scene(self.scene, hm, pressure, where), hm, where)
        measure = "neoplasm_area_in_bone" if cp.dim == 2 else "neoplasm_volume_in_bone"
        rec = {
            "growth_step": step,
            "time": t,
            "equivalent_radius": row[2],
            measure: hm.neoplasm_area,
            "cells": hm.cells,
            "status": res.status,
            "directory": str(where),
            "wall_group": hm.wall,
            "cavity_pressure_Pa": pressure,
        }
        if "message" in res.summary:
            rec["message"] = res.summary["message"]
        rec.update(_analysis_risk(res.summary))
        if res.status == "interrupted":  # a signal: the analysis runs again on restart
            self.signal = _signal_number(res.summary.get("signal", "SIGINT"))
            return False
        self.records.append(rec)
        _release_analysis(self.result)  # only the last analysis's model is returned
        self.result = res
        self.last_summary = res.summary
        self.invalid = self.invalid or res.status == "invalid"  # the growth goes on
        return res.status in ("converged", "invalid")

    def analyse(self, scene: Scene, hm: HostMesh, where: Path) -> RunResult:
        """Build the model on the host mesh in memory and run it into ``where`` (a signal:
        no checkpoint of its own, it reaches the coupled run)."""
        t_start, timer = time.perf_counter(), PhaseTimer()
        sm = analysis_model(scene, hm, self.comm, timer, self.issues)
        return run_model(sm, self.comm, where, False, None, False, timer, t_start)


def _release_analysis(res: RunResult | None) -> None:
    """Destroy the PETSc objects of an analysis that is no longer needed, while its mesh is
    alive (collective).  In parallel Python's collector would only park them on the mesh's
    communicator, and a coupled run of a few hundred analyses on 2 ranks would run out of
    MPI communicators (:func:`~bonecontact.common.linalg.release_petsc_garbage`)."""
    if res is None or res.integrator is None:
        return
    msh = res.integrator.model.mesh
    res.integrator.destroy()
    release_petsc_garbage(msh.comm)


def _analysis_risk(summary: dict[str, Any]) -> dict[str, Any]:
    """The fracture-risk entries of an analysis record (none without ``[fracture]``): the
    largest risk of the analysis, its location, mode and the direction of a crack started
    there (normal to the largest principal stress)."""
    info = summary.get("fracture")
    if not info or "max_risk" not in info:
        return {}
    return {
        "max_risk": info["max_risk"],
        "max_risk_location": info["location"],
        "max_risk_mode": info["mode"],
        "max_risk_crack_direction": info["crack_direction"],
        "max_risk_crack_normal": info["crack_normal"],
    }


def _risk_over_growth(records: list[dict[str, Any]], criterion: str) -> dict[str, Any]:
    """summary.json ``fracture`` of a coupled run: the largest risk of every analysis against
    growth time, and the first growth time at which it reached 1 (initiation)."""
    rows = [r for r in records if "max_risk" in r]
    first = next((r for r in rows if r["max_risk"] >= 1.0), None)
    peak = max(rows, key=lambda r: r["max_risk"], default=None)
    return {
        "criterion": criterion,
        "growth_time": [r["time"] for r in rows],
        "max_risk": [r["max_risk"] for r in rows],
        "max_risk_overall": None if peak is None else peak["max_risk"],
        "location": None if peak is None else peak["max_risk_location"],
        "initiated": first is not None,
        "initiation_growth_time": None if first is None else first["time"],
        "initiation_growth_step": None if first is None else first["growth_step"],
        "units": {"growth_time": "s", "location": "m", "max_risk": "1 (stress / strength)"},
    }


class CoupledSteps(GrowthSteps):
    """The hooks of a coupled run: a growth step and its growth.csv row, then the analysis
    on the rebuilt host mesh when due (:class:`_Analyses`), a checkpoint after the step and
    its analysis.  A restarted run whose checkpoint has its analysis still to run
    (``analysis_pending``: a signal stopped it) runs that analysis first, without a
    growth step."""

    def __init__(
        self,
        cp: _Coupled,
        table: GrowthTable,
        analyses: _Analyses,
        times: np.ndarray,
        ckpt: Checkpointer,
        resumed: dict[str, Any] | None,
    ):
        super().__init__(cp.driver, table, times, analyses.timer, ckpt, resumed)
        self.analyses = analyses
        self.pending = resumed is not None and bool(resumed["analysis_pending"])
        self.analysing = False

    def row(self, t: float) -> list[float]:
        """The growth.csv row at time ``t`` (collective; no phase of its own: the coupled
        run's phases are set-up, check, growth steps, host rebuilds and analyses)."""
        vals = self.driver.row()
        self.table.row(t, vals)
        return vals

    def advance(self, k: int) -> None:
        if self.pending:  # the analysis of the checkpoint's step runs again
            self.pending = False
            return
        self.grow(k)
        self.last, self.t_done = self.row(float(self.times[k])), float(self.times[k])

    def record(self, k: int, last: bool) -> None:
        """The row is written right after the growth step (before its analysis)."""

    def after(self, k: int) -> Verdict:
        analyses = self.analyses
        self.analysing = analyses.due(k)
        if self.analysing and not analyses.run(k, self.t_done, self.last):
            if analyses.signal:  # stopped during the analysis: it runs again on restart
                self.ckpt.signum = analyses.signal
                self.ckpt.after_step(k == self.nsteps, self.content(True))
                raise RunStopped(
                    "interrupted", f"stopped in the analysis after growth step {k} by a signal"
                )
            raise RunStopped(
                "failed",
                f"analysis after growth step {k} (t = {self.t_done:.6g} s): "
                f"{analyses.records[-1].get('message')}",
            )
        self.analysing = False
        return Verdict.NEXT

    def content(self, pending: bool = False) -> dict[str, Any]:
        return {
            "first_row": self.first,
            "last_row": self.last,
            "records": self.analyses.records,
            "last_summary": self.analyses.last_summary,
            "analysis_pending": pending,
        }

    def failure(self, k: int, exc: BaseException) -> str:
        # a growth step, or an analysis's host mesh (CouplingError)
        if self.analysing:
            return f"analysis after growth step {k} (t = {self.t_done:.6g} s): {exc}"
        steps = self.driver.steps
        t_fail = self.times[min(steps + 1, self.nsteps)]
        return f"growth step {steps + 1} (t = {t_fail:.6g} s): {exc}"


def _coupled_summary(
    scene: Scene,
    comm: MPI.Comm,
    cp: _Coupled,
    analyses: _Analyses,
    status: str,
    message: str | None,
    rows: tuple[list[float], list[float], float],
    t_start: float,
) -> dict[str, Any]:
    """The final analysis's summary with ``growth`` and ``coupling`` (and the run's status)."""
    driver, neo = cp.driver, cp.neo
    first, last, t_done = rows
    growth = {
        "kind": neo.kind,
        "dimension": driver.dim,
        "steps": driver.steps,
        "steps_planned": analyses.nsteps,
        "remeshes": driver.remeshes,
        "t_end": neo.t_end,
        "dt": neo.dt,
        "final_time": t_done,
        "initial_radius": first[2],
        "final_radius": last[2],
        "initial_volume": first[0],
        "final_volume": last[0],
        "final_surface_area": last[1],
        "geometry": f'cell group "{neo.region}" of {scene.mesh_path.name}',
        "units": {
            "time": "s",
            "radius": "m",
            "volume": "m^2 (area)" if driver.dim == 2 else "m^3",
            "surface_area": "m (perimeter)" if driver.dim == 2 else "m^2",
            "pressure": "Pa",
        },
        **driver.info(),
    }
    last_summary = analyses.last_summary
    summary: dict[str, Any] = (
        dict(last_summary)
        if last_summary is not None
        else {"scene": scene.name, "format": SUMMARY_FORMAT, "ranks": comm.size, "steps": 0}
    )
    for key in ("restarted_from", "signal"):  # the final analysis's own, if any: not the run's
        summary.pop(key, None)
    summary["status"] = status
    summary["growth"] = growth
    summary["coupling"] = {
        "mechanics_every": neo.mechanics_every,
        "analyses": analyses.records,
        "wall_time_s": time.perf_counter() - t_start,
        "model": (
            "cyst: cavity in the rebuilt host mesh, wall pressure = P_h+ - P_h- (osmotic excess)"
            if cp.cavity
            else "tumour: region cells with the region's [[material]] in the rebuilt host mesh"
        ),
        "one_way": "the growth does not feel the mechanics",
    }
    if scene.fracture is not None:
        summary["fracture"] = _risk_over_growth(analyses.records, scene.fracture.criterion)
    if message is not None:
        summary["message"] = message
    return summary
