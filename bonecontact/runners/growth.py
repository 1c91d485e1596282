"""Growth-only scenes: a tumour or a cyst grown alone, written to ``growth.csv``.

A scene with ``[neoplasm]`` and no ``[analysis]`` (the ``growth`` run kind) runs here
(:func:`run_growth`); coupled runs (:mod:`bonecontact.runners.coupled`) grow with the same
driver (:func:`build_growth`) and hooks (:class:`GrowthSteps`).  The drivers are in
:mod:`bonecontact.neoplasm.growth`:

* ``kind = "tumour"``: :class:`bonecontact.neoplasm.tumour.TumourModel` (Problem P_T on a
  moving, gmsh-remeshed tumour mesh, remeshed in memory);
* ``kind = "cyst"``, ``model = "sphere"``: the osmotic/Maxwell ODE of
  :mod:`bonecontact.neoplasm.cyst`;
* ``kind = "cyst"``, ``model = "shape"``: the moving-wall cyst of
  :mod:`bonecontact.neoplasm.cyst_shape`.

Results: ``growth.csv`` (one row per growth step, rank 0, flushed as the run goes),
``boundary.csv`` (tumour, shape cyst) and ``summary.json`` with ``growth`` and
``phases_s``.  Every input problem is a :class:`~bonecontact.scene.errors.SceneError` on
every rank before anything is written; the rows do not depend on the number of ranks.
The initial neoplasm, the columns and the phases: docs/run_loop.md (*Growth-only runs*)
and docs/neoplasm_format.md; the models: docs/theory/growth.md.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np

from bonecontact.common.profiling import PhaseTimer
from bonecontact.neoplasm.growth import (
    CystShapeGrowth,
    CystSphereGrowth,
    TumourGrowth,
    cyst_shape_growth,
    equivalent_radius,
    mesh_measure,
    region_boundary,
    region_submesh,
    surface_tension_dt_limit,
    tumour_growth,
)
from bonecontact.neoplasm.remesh import Boundary, RemeshError
from bonecontact.runners.checkpoint import Checkpointer, GrowthState
from bonecontact.runners.loop import StepHooks, progress_bar, run_steps
from bonecontact.runners.mechanics import read_mesh
from bonecontact.runners.results import (
    GROWTH_UNITS,
    GrowthTable,
    RunResult,
    run_summary,
    write_points,
    write_summary,
)
from bonecontact.scene import Scene, SceneError

__all__ = ["GrowthSteps", "build_growth", "growth_checkpointer", "growth_times", "run_growth"]

Driver = CystSphereGrowth | CystShapeGrowth | TumourGrowth


# ----------------------------------------------------------------------------- set-up
def _region_mesh(scene: Scene, comm: MPI.Comm):
    """The submesh of the ``[neoplasm] region`` cells (after all mesh checks)."""
    md, groups = read_mesh(scene, comm)
    neo = scene.neoplasm
    assert neo is not None and neo.region is not None
    sub = region_submesh(md, groups[neo.region][1], comm)
    if sub is None:
        raise SceneError(
            str(scene.path), "[neoplasm]", "region", f'cell group "{neo.region}" has no cells'
        )
    return sub


def build_growth(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> Driver:
    """Check a neoplasm scene against its mesh and build the growth model (collective).

    Growth-only and coupled scenes (:mod:`bonecontact.runners.coupled`, which adds the
    mechanics) alike.  Nothing is written.

    Raises
    ------
    SceneError
        Every input problem (on every rank).
    """
    neo = scene.neoplasm
    file = str(scene.path)
    if neo is None:  # growth-only or coupled (bonecontact.runners.coupled) scenes
        raise SceneError(file, "[neoplasm]", None, "build_growth needs a scene with [neoplasm]")
    dim = scene.dimension
    if neo.kind == "cyst":
        spec = neo.cyst
        assert spec is not None
        params = spec.parameters  # validated by the scene reader
        if spec.model == "shape":
            return _build_cyst_shape(scene, params, comm)
        if neo.region is not None:
            R0 = equivalent_radius(mesh_measure(_region_mesh(scene, comm)), dim)
        else:
            R0 = float(neo.radius)  # type: ignore[arg-type]
        return CystSphereGrowth(params, R0, dim)

    params = neo.tumour  # TumourParameters, validated by the scene reader
    assert params is not None
    if neo.region is None:
        R = float(neo.radius)  # type: ignore[arg-type]
        h = neo.h if neo.h is not None else R / 8.0
        _check_dt(scene, params.gamma, h)
        try:
            return tumour_growth(comm, params, dim, h, neo.remesh_every, radius=R)
        except RemeshError as exc:
            raise SceneError(
                file, "[neoplasm]", "h", f"gmsh cannot mesh the initial tumour: {exc}"
            ) from None
    b, mean_edge = _region_boundary(scene, comm)
    h = neo.h if neo.h is not None else mean_edge
    _check_dt(scene, params.gamma, h)
    try:
        return tumour_growth(comm, params, dim, h, neo.remesh_every, boundary=b)
    except RemeshError as exc:
        raise SceneError(
            file,
            "[neoplasm]",
            "region",
            f'gmsh cannot mesh the tumour region "{neo.region}": {exc}',
        ) from None


def _region_boundary(scene: Scene, comm: MPI.Comm) -> tuple[Boundary, float]:
    """The boundary of the ``region`` cells and its mean edge length (errors on ``region``)."""
    neo = scene.neoplasm
    assert neo is not None
    dim = scene.dimension
    sub = _region_mesh(scene, comm)
    try:
        return region_boundary(sub, dim)
    except RemeshError as exc:
        raise SceneError(
            str(scene.path),
            "[neoplasm]",
            "region",
            f'the boundary of "{neo.region}" must be one closed '
            f"{'curve' if dim == 2 else 'surface'} "
            f"(a simply connected region): {exc}",
        ) from None


def _build_cyst_shape(scene: Scene, params: Any, comm: MPI.Comm) -> CystShapeGrowth:
    """The moving-wall cyst from ``region`` or a meshless disc/ball (collective)."""
    neo = scene.neoplasm
    assert neo is not None
    file, dim = str(scene.path), scene.dimension
    if neo.region is None:
        R = float(neo.radius)  # type: ignore[arg-type]
        try:
            return cyst_shape_growth(comm, params, dim, R / 8.0, neo.remesh_every, radius=R)
        except RemeshError as exc:
            raise SceneError(
                file, "[neoplasm]", "radius", f"gmsh cannot mesh the initial cyst: {exc}"
            ) from None
    b, h = _region_boundary(scene, comm)
    try:
        return cyst_shape_growth(comm, params, dim, h, neo.remesh_every, boundary=b)
    except RemeshError as exc:
        raise SceneError(
            file, "[neoplasm]", "region", f'gmsh cannot mesh the cyst region "{neo.region}": {exc}'
        ) from None


def _check_dt(scene: Scene, gamma: float, h: float) -> None:
    neo = scene.neoplasm
    assert neo is not None
    limit = surface_tension_dt_limit(gamma, h)
    if neo.dt > limit:
        raise SceneError(
            str(scene.path),
            "[neoplasm]",
            "dt",
            f"{neo.dt!r} s exceeds the explicit surface-tension limit 2 h^3 / (gamma pi^3) = "
            f"{limit:.4g} s (gamma = {gamma!r}, h = {h:.4g} m); take a smaller dt or a larger h",
        )


# ----------------------------------------------------------------------------- run
def growth_times(scene: Scene) -> np.ndarray:
    """The times of the growth rows: 0 and every step's end (s)."""
    assert scene.neoplasm is not None
    return np.concatenate([[0.0], scene.neoplasm.times()])


def growth_checkpointer(
    scene: Scene, driver: Driver, comm: MPI.Comm, outdir: Path, run: str
) -> Checkpointer:
    """The checkpoints of a growth (``run = "growth"``) or coupled run (docs/checkpoint.md)."""
    neo = scene.neoplasm
    assert neo is not None
    info = {"scene": scene.name, "run": run, "dt": neo.dt, "remesh_every": neo.remesh_every}
    out = scene.output
    state = GrowthState(driver, comm)
    return Checkpointer(outdir, state, out.checkpoint_every, info, out.checkpoint_time)


def run_growth(
    scene: Scene,
    comm: MPI.Comm = MPI.COMM_WORLD,
    output: Path | None = None,
    progress: bool = True,
    restart: str | Path | bool | None = None,
) -> RunResult:
    """Run a growth-only scene: growth.csv, boundary.csv (tumour, shape cyst) and summary.json.

    ``restart``: continue from the newest checkpoint in the output directory (``True``)
    or from the named one (a path); docs/checkpoint.md.

    Returns
    -------
    RunResult
        ``status`` ``"converged"``, ``"failed"`` (a growth step raised: the message is
        in the summary, the rows of the steps done are in growth.csv) or ``"interrupted"``
        (a signal; a checkpoint of the last step was written).

    Raises
    ------
    CheckpointError
        The checkpoint to restart from is missing, damaged or from another scene.
    """
    t_start = time.perf_counter()
    timer = PhaseTimer()
    with timer.phase("model"):
        driver = build_growth(scene, comm)  # SceneError before anything is written
    outdir = Path(output) if output is not None else scene.output.directory
    times = growth_times(scene)
    ckpt = growth_checkpointer(scene, driver, comm, outdir, "growth")
    resumed = None
    if restart:
        with timer.phase("checkpoint"):
            resumed = ckpt.resume(None if restart is True else restart)
    with timer.phase("output"):
        table = GrowthTable(comm, outdir, driver.columns, append=resumed is not None)
    hooks = GrowthSteps(driver, table, times, timer, ckpt, resumed)
    with ckpt.stop:
        bar = progress_bar(comm, scene.name, len(times) - 1, driver.steps, progress)
        try:
            end = run_steps(hooks, driver.steps + 1, len(times) - 1, bar, resumed is None)
        finally:
            table.close()
    status, message = end.status, end.message
    first, last, t_done = hooks.first, hooks.last, hooks.t_done
    with timer.phase("output"):
        _write_boundary(driver, comm, outdir)
    if ckpt.time_s:
        timer.add("checkpoint", ckpt.time_s)
    growth = _growth_entry(scene, driver, status, len(times) - 1, first, last, t_done)
    summary = run_summary(
        scene.name,
        status,
        comm,
        time.perf_counter() - t_start,
        units=GROWTH_UNITS,
        steps=driver.steps,
        growth=growth,
        **ckpt.summary(),
        phases_s=_phases(driver, timer, comm),
    )
    if message is not None:
        summary["message"] = message
    write_summary(comm, outdir, summary)
    comm.barrier()
    return RunResult(status, summary, None, outdir)


def _phases(driver: Driver, timer: PhaseTimer, comm: MPI.Comm) -> dict[str, float]:
    """``phases_s`` of summary.json: the run's phases, then (tumour) the split of
    ``growth_steps`` into the phases of the tumour's steps (collective)."""
    if isinstance(driver, TumourGrowth):
        for name, seconds in driver.model.timer.times.items():
            timer.add(name, seconds)
    return timer.summary(comm)


class GrowthSteps(StepHooks):
    """The hooks of a growth run (:func:`bonecontact.runners.loop.run_steps`): a growth step
    of the driver (phase ``growth_steps``), its growth.csv row (phase ``output``), a
    checkpoint when due or asked for by a signal.  ``first`` and ``last`` are the first
    and last rows written, ``t_done`` the time of the last."""

    noun = "growth step"

    def __init__(
        self,
        driver: Driver,
        table: GrowthTable,
        times: np.ndarray,
        timer: PhaseTimer,
        ckpt: Checkpointer,
        resumed: dict[str, Any] | None,
    ):
        self.driver, self.table, self.times = driver, table, times
        self.timer, self.ckpt = timer, ckpt
        self.nsteps = len(times) - 1
        self.first: list[float] = [] if resumed is None else resumed["first_row"]
        self.last: list[float] = [] if resumed is None else resumed["last_row"]
        self.t_done = 0.0 if resumed is None else float(times[driver.steps])

    def row(self, t: float) -> list[float]:
        """The growth.csv row of the driver's state at time ``t`` (collective)."""
        with self.timer.phase("output"):
            vals = self.driver.row()  # collective (tumour, shape cyst)
            self.table.row(t, vals)
        return vals

    def start(self) -> None:
        self.first = self.last = self.row(0.0)

    def grow(self, k: int) -> None:
        """Growth step ``k`` (from ``times[k - 1]`` to ``times[k]``)."""
        with self.timer.phase("growth_steps"):
            self.driver.step(float(self.times[k] - self.times[k - 1]))

    def advance(self, k: int) -> None:
        self.grow(k)

    def record(self, k: int, last: bool) -> None:
        self.last, self.t_done = self.row(float(self.times[k])), float(self.times[k])

    def content(self) -> dict[str, Any]:
        """What a checkpoint's meta.json holds besides the driver's state."""
        return {"first_row": self.first, "last_row": self.last}

    def checkpoint(self, k: int, last: bool) -> bool:
        return bool(self.ckpt.after_step(last, self.content()))

    def failure(self, k: int, exc: BaseException) -> str:
        # RunError (a tumour step, a transfer off the mesh), MeshingError, PETSc, ODE failure
        steps = self.driver.steps
        return f"growth step {steps + 1} (t = {self.times[steps + 1]:.6g} s): {exc}"


def _write_boundary(driver: Driver, comm: MPI.Comm, outdir: Path) -> None:
    """boundary.csv: the final tumour / cyst wall (tumour, shape cyst; collective)."""
    if not isinstance(driver, (TumourGrowth, CystShapeGrowth)):
        return
    try:
        b = driver.model.boundary()  # collective; replicated
    except RuntimeError:  # a failed remesh may leave no usable boundary: skip the file
        b = None
    if b is not None and comm.rank == 0:
        write_points(outdir / "boundary.csv", list("xyz"[: driver.dim]), b.points)


def _growth_entry(
    scene: Scene,
    driver: Driver,
    status: str,
    steps_planned: int,
    first: list[float],
    last: list[float],
    t_done: float,
) -> dict[str, Any]:
    """The ``growth`` entry of summary.json."""
    neo = scene.neoplasm
    assert neo is not None
    length = "m" if driver.dim == 3 else "m (per unit thickness in 2D)"
    return {
        "kind": neo.kind,
        "dimension": driver.dim,
        "status": status,
        "steps": driver.steps,
        "steps_planned": steps_planned,
        "remeshes": driver.remeshes,
        "t_end": neo.t_end,
        "dt": neo.dt,
        "final_time": t_done,
        "initial_radius": first[2],
        "final_radius": last[2],
        "initial_volume": first[0],
        "final_volume": last[0],
        "final_surface_area": last[1],
        "geometry": (
            f'cell group "{neo.region}" of {scene.mesh_path.name}'
            if neo.region is not None and scene.mesh_path is not None
            else f"radius = {neo.radius!r} m (meshless)"
        ),
        "units": {
            "time": "s",
            "radius": "m",
            "volume": "m^3" if driver.dim == 3 else "m^2 (area)",
            "surface_area": "m^2" if driver.dim == 3 else "m (perimeter)",
            "pressure": "Pa",
            "lengths": length,
        },
        **driver.info(),
    }
