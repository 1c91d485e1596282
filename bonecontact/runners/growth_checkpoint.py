"""Restart checkpoints of growth-only and coupled runs (docs/checkpoint.md).

The same directories, atomic writing, format number and HDF5 writer as the mechanics
checkpoints of :mod:`bonecontact.runners.checkpoint` (whose code this reuses): a
checkpoint ``<output>/checkpoints/step_<k>`` after growth step k holds

* ``state.h5`` (PETSc's HDF5 viewer, collective), for a growth model with a mesh (tumour,
  moving-wall cyst):

  - ``coordinates``: the current node coordinates (the mesh moves every step), in the
    order of the nodes of the mesh as gmsh made it at the last remesh
    (``input_global_indices``);
  - ``cells``: the nodes of every cell (those node numbers), in gmsh's cell order
    (``original_cell_index``);
  - the model's fields (tumour: ``u_p``, ``u_q`` per cell; ``u_c``, ``w`` per node);

  for the cyst ODE (no mesh) the dataset ``ode`` = (R, f);
* ``mesh.vtkhdf`` (models with a mesh): the current mesh, for viewing;
* ``meta.json``: format, step, time, the model's scalars (time, step and remesh counters,
  cyst pressure...), the first and last growth.csv rows and, for a coupled run, its
  analysis records; the size and SHA-256 of ``state.h5``.

A restart rebuilds the mesh from ``cells`` and ``coordinates`` with the partitioner of
every remesh (:func:`bonecontact.neoplasm.remesh.mesh_from_cells`): on the same number of
ranks it is the mesh of the interrupted run (same partition and numbering), so the run
continues as if it had not stopped; on another number of ranks it is partitioned anew
(the growth model is partition independent to round-off).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
from dolfinx import fem
from dolfinx import mesh as dmesh
from dolfinx.io import vtkhdf

from bonecontact.common.version import __version__
from bonecontact.neoplasm.growth import CystShapeGrowth, CystSphereGrowth, TumourGrowth
from bonecontact.neoplasm.remesh import mesh_from_cells
from bonecontact.runners.checkpoint import (
    FORMAT_VERSION,
    CheckpointError,
    CheckpointSchedule,
    InputOrder,
    StopRequest,
    checkpoint_summary,
    find_checkpoint,
    save_checkpoint,
    trim_rows,
)

__all__ = ["GrowthCheckpointer", "read_growth_state", "write_growth_checkpoint"]

Driver = CystSphereGrowth | CystShapeGrowth | TumourGrowth

#: The ``kind`` of a growth checkpoint's meta.json.
KIND = "bonecontact growth checkpoint"


def _model_kind(driver: Driver) -> str:
    if isinstance(driver, TumourGrowth):
        return "tumour"
    if isinstance(driver, CystShapeGrowth):
        return "cyst_shape"
    return "cyst_sphere"


def _jsonable(o: object) -> Any:
    """meta.json of NumPy scalars and arrays (coupling records)."""
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"cannot store {type(o).__name__} in a checkpoint")


# ----------------------------------------------------------------------------- orders
def _cells_order(msh: dmesh.Mesh) -> tuple[InputOrder, npt.NDArray[np.int32]]:
    """The order of gmsh's cells over the owned cells, and the owned cells."""
    tdim = msh.topology.dim
    n = msh.topology.index_map(tdim).size_local
    keys = np.asarray(msh.topology.original_cell_index, dtype=np.int64)[:n]
    return InputOrder.of_keys(msh.comm, keys), np.arange(n, dtype=np.int32)


def _cell_nodes(msh: dmesh.Mesh, cells: npt.NDArray[np.int32]) -> npt.NDArray[np.float64]:
    """The input (gmsh) node numbers of ``cells``, as floats (exact below 2⁵³)."""
    inp = np.asarray(msh.geometry.input_global_indices, dtype=np.int64)
    return inp[msh.geometry.dofmaps[0][cells]].astype(np.float64)


def _node_coordinates(V: fem.FunctionSpace) -> npt.NDArray[np.float64]:
    """Coordinates of the owned dof blocks of the P1 space ``V``, ``(n_owned, gdim)``."""
    msh = V.mesh
    gdim = msh.geometry.dim
    n = V.dofmap.index_map.size_local
    xy = np.zeros((n + V.dofmap.index_map.num_ghosts, gdim))
    xy[V.dofmap.list.ravel()] = msh.geometry.x[msh.geometry.dofmaps[0].ravel(), :gdim]
    return xy[:n]


def _dg0_dofs(u: fem.Function, cells: npt.NDArray[np.int32]) -> npt.NDArray[np.int32]:
    return u.function_space.dofmap.list[cells, 0]


def _is_cellwise(u: fem.Function) -> bool:
    return u.function_space.dofmap.list.shape[1] == 1


# ----------------------------------------------------------------------------- writing
def _write_state(path: Path, driver: Driver, comm: MPI.Comm) -> None:
    """state.h5 of a growth model (collective)."""
    viewer = PETSc.Viewer().createHDF5(str(path), "w", comm=comm)
    orders: list[InputOrder] = []
    try:

        def put(order: InputOrder, name: str, ncomp: int, values: npt.ArrayLike) -> None:
            vec = order.to_input(values, ncomp, name)
            vec.view(viewer)
            vec.destroy()

        if isinstance(driver, CystSphereGrowth):
            order = InputOrder.of_keys(comm, [0, 1] if comm.rank == 0 else [])
            orders.append(order)
            put(order, "ode", 1, [driver.R, driver.f] if comm.rank == 0 else [])
            return
        model = driver.model
        msh = model.mesh
        Vx = model.motion.V
        nodes = InputOrder(Vx)
        cells_order, cells = _cells_order(msh)
        orders += [nodes, cells_order]
        put(nodes, "coordinates", msh.geometry.dim, _node_coordinates(Vx))
        put(cells_order, "cells", msh.topology.dim + 1, _cell_nodes(msh, cells))
        for name, u in driver.fields().items():
            if _is_cellwise(u):
                put(cells_order, name, 1, u.x.array[_dg0_dofs(u, cells)])
            else:
                order = InputOrder(u.function_space)
                orders.append(order)
                bs = u.function_space.dofmap.index_map_bs
                n = u.function_space.dofmap.index_map.size_local
                put(order, name, bs, u.x.array[: n * bs])
    finally:
        viewer.destroy()
        for order in orders:
            order.destroy()


def write_growth_checkpoint(
    output: Path, driver: Driver, comm: MPI.Comm, info: dict[str, Any], content: dict[str, Any]
) -> Path:
    """Write the state after growth step ``driver.steps`` atomically (collective).

    ``info``: the entries a restart must agree on (scene, run kind, dt...); ``content``:
    the run's further state (rows, coupling records), stored in meta.json.
    """

    def files(tmp: Path) -> None:
        _write_state(tmp / "state.h5", driver, comm)
        if not isinstance(driver, CystSphereGrowth):
            vtkhdf.write_mesh(str(tmp / "mesh.vtkhdf"), driver.model.mesh)

    meta = {
        "format": FORMAT_VERSION,
        "kind": KIND,
        "bonecontact_version": __version__,
        "step": driver.steps,
        "time": driver.t,
        "ranks": comm.size,
        "model": _model_kind(driver),
        "model_state": driver.checkpoint_state(),
        **json.loads(json.dumps(content, default=_jsonable)),
        **info,
    }
    return save_checkpoint(output, driver.steps, comm, files, meta)


# ----------------------------------------------------------------------------- reading
def _load_whole(path: Path, names: list[str]) -> dict[str, npt.NDArray[np.float64]]:
    """Whole datasets of ``path`` (rank 0 only, sequential)."""
    viewer = PETSc.Viewer().createHDF5(str(path), "r", comm=MPI.COMM_SELF)
    out = {}
    try:
        for name in names:
            vec = PETSc.Vec().create(comm=MPI.COMM_SELF)
            vec.setType("seq")
            vec.setName(name)
            vec.load(viewer)
            out[name] = vec.array.copy()
            vec.destroy()
    finally:
        viewer.destroy()
    return out


def _rebuild_mesh(path: Path, dim: int, comm: MPI.Comm) -> dmesh.Mesh:
    """The checkpoint's mesh, rebuilt as a remesh builds one (collective)."""
    cells = np.empty((0, dim + 1), dtype=np.int64)
    x = np.empty((0, dim))
    error = None
    if comm.rank == 0:
        try:
            data = _load_whole(path / "state.h5", ["cells", "coordinates"])
            cells = np.rint(data["cells"]).astype(np.int64).reshape(-1, dim + 1)
            x = data["coordinates"].reshape(-1, dim)
        except Exception as exc:  # reported collectively below
            error = f"{type(exc).__name__}: {exc}"
    error = comm.bcast(error, root=0)
    if error is not None:
        raise CheckpointError(f"checkpoint {path}: cannot read the mesh ({error})")
    return mesh_from_cells(comm, cells, x, dim)


def read_growth_state(path: Path, meta: dict[str, Any], driver: Driver, comm: MPI.Comm) -> None:
    """Put the growth model of a checkpoint into ``driver`` (built from the same scene;
    collective)."""
    kind = _model_kind(driver)
    if meta.get("model") != kind:
        raise CheckpointError(
            f"checkpoint {path} holds a {meta.get('model')!r} growth model, the scene a {kind!r}"
        )
    if isinstance(driver, CystSphereGrowth):
        driver.restore_checkpoint_state(meta["model_state"])
        return
    driver.replace_mesh(_rebuild_mesh(path, driver.dim, comm))
    msh = driver.model.mesh
    cells_order, cells = _cells_order(msh)
    orders = [cells_order]
    viewer = PETSc.Viewer().createHDF5(str(path / "state.h5"), "r", comm=comm)
    try:
        for name, u in driver.fields().items():
            if _is_cellwise(u):
                vec = cells_order.empty(1, name)
                vec.load(viewer)
                u.x.array[_dg0_dofs(u, cells)] = cells_order.from_input(vec, 1)[:, 0]
            else:
                order = InputOrder(u.function_space)
                orders.append(order)
                bs = u.function_space.dofmap.index_map_bs
                vec = order.empty(bs, name)
                vec.load(viewer)
                n = u.function_space.dofmap.index_map.size_local
                u.x.array[: n * bs] = order.from_input(vec, bs).ravel()
            vec.destroy()
            u.x.scatter_forward()
    finally:
        viewer.destroy()
        for order in orders:
            order.destroy()
    driver.restore_checkpoint_state(meta["model_state"])


# ----------------------------------------------------------------------------- the run's side
class GrowthCheckpointer:
    """A growth or coupled run's checkpoints: restart, periodic writes, the stop on a signal.

    Parameters
    ----------
    output
        The run's output directory.
    driver
        The growth model (built from the scene).
    comm
        The run's communicator.
    every
        Write a checkpoint every this many growth steps (0: only when stopped by a signal).
    info
        Entries that must agree between a checkpoint and the run continuing it.
    interval
        Also write one after the first growth step that reaches each multiple of this
        much simulated time, s (0: none).
    """

    def __init__(
        self,
        output: Path,
        driver: Driver,
        comm: MPI.Comm,
        every: int,
        info: dict[str, Any],
        interval: float = 0.0,
    ):
        self.output, self.driver, self.comm, self.every = Path(output), driver, comm, int(every)
        self.schedule = CheckpointSchedule(every, interval, driver.t)
        self.info = dict(info)
        self.stop = StopRequest()
        self.restarted_from: dict[str, Any] | None = None
        self.last: Path | None = None
        self.written = 0
        self.time_s = 0.0
        self.signum = 0

    def resume(self, named: str | Path | None) -> dict[str, Any]:
        """Continue from the newest (or the named) checkpoint: restore the growth model,
        cut growth.csv after the checkpoint's step (collective).

        Returns
        -------
        dict
            The checkpoint's meta.json (the run's further state: rows, records).

        Raises
        ------
        CheckpointError
            On every rank, before any file is changed.
        """
        path, meta = find_checkpoint(self.output, self.comm, None if not named else Path(named))
        if meta.get("kind") != KIND:
            raise CheckpointError(
                f"checkpoint {path} is a {meta.get('kind', 'mechanics checkpoint')!r}, "
                "not a growth run's"
            )
        for key, value in self.info.items():
            if meta.get(key) != value:
                raise CheckpointError(
                    f"checkpoint {path} has {key} = {meta.get(key)!r}, the scene {value!r}: "
                    "a restart continues the same scene"
                )
        read_growth_state(path, meta, self.driver, self.comm)
        self.schedule.t_last = self.driver.t
        trim_rows(self.output / "growth.csv", int(meta["step"]) + 1, self.comm)
        self.restarted_from = {
            "checkpoint": str(path),
            "step": int(meta["step"]),
            "time": float(meta["time"]),
            "ranks": int(meta["ranks"]),
        }
        self.last = path
        return meta

    def after_step(self, last: bool, content: dict[str, Any]) -> int:
        """Between growth steps (collective): write a checkpoint when one is due
        (:class:`bonecontact.runners.checkpoint.CheckpointSchedule`) or a signal came.

        Returns the signal number (0: go on)."""
        self.signum = max(self.signum, self.stop.agreed(self.comm))
        due = self.schedule.due(self.driver.steps, self.driver.t, last)
        if self.signum or due:
            self.write(content)
        return self.signum

    def write(self, content: dict[str, Any]) -> Path:
        """Write a checkpoint of the current state now (collective)."""
        t0 = time.perf_counter()
        self.last = write_growth_checkpoint(self.output, self.driver, self.comm, self.info, content)
        self.time_s += time.perf_counter() - t0
        self.written += 1
        return self.last

    def summary(self) -> dict[str, Any]:
        """The summary.json entries: ``checkpoints``, after a restart ``restarted_from``,
        after a signal ``signal``."""
        return checkpoint_summary(self)
