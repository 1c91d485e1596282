"""What the 2D and 3D coupled-scene tests share: gmsh meshes made on rank 0, a size field
graded away from the neoplasm, scenes run in-process, and the CSV tables read back.

Not a test module (no ``test_`` prefix); the coupled tests import it by name.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable
from pathlib import Path

from mpi4py import MPI

import numpy as np
import serial_store
from cli_support import check_reaction_balance

from bonecontact.runners import RunResult, run_scene
from bonecontact.scene import load_scene


def gmsh_on_rank0(build: Callable, path: Path, dim: int) -> None:
    """``build(gmsh)`` (geometry, groups, sizes) on rank 0, mesh in ``dim`` D, write
    ``path``; every rank waits for the file."""
    comm = MPI.COMM_WORLD
    if comm.rank == 0:
        import gmsh

        own = not gmsh.isInitialized()
        if own:
            gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("test")
        try:
            build(gmsh)
            gmsh.model.mesh.generate(dim)
            gmsh.write(str(path))
        finally:
            if own:
                gmsh.finalize()
            else:
                gmsh.model.remove()
    comm.barrier()


def refine_near(gmsh, entities: list[int], h_in: float, h_out: float, dist: float) -> None:
    """Element size ``h_in`` at the curves (2D model) or surfaces (3D model) ``entities``,
    growing linearly to ``h_out`` at distance ``dist``; the only size source."""
    f = gmsh.model.mesh.field
    d = f.add("Distance")
    kind = "SurfacesList" if gmsh.model.getDimension() == 3 else "CurvesList"
    f.setNumbers(d, kind, entities)
    th = f.add("Threshold")
    f.setNumber(th, "InField", d)
    f.setNumber(th, "SizeMin", h_in)
    f.setNumber(th, "SizeMax", h_out)
    f.setNumber(th, "DistMin", 0.0)
    f.setNumber(th, "DistMax", dist)
    f.setAsBackgroundMesh(th)
    for key in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints", "MeshSizeFromCurvature"):
        gmsh.option.setNumber(f"Mesh.{key}", 0)


def plate_with_disc(gmsh, L: float, R: float) -> list[int]:
    """Square [0, 2L]² ("plate", facet groups "left", "bottom", "right", "top") with a disc
    of radius R at (L, L) ("tumour") in the current gmsh model; the disc's surface tags
    (sizes are the caller's)."""
    occ = gmsh.model.occ
    s, c = occ.addRectangle(0, 0, 0, 2 * L, 2 * L), occ.addDisk(L, L, 0, R, R)
    _, m = occ.fragment([(2, s)], [(2, c)])
    occ.synchronize()
    inner = [t for _, t in m[1]]
    outer = [t for _, t in m[0] if t not in inner]
    gmsh.model.addPhysicalGroup(2, outer, 1, name="plate")
    gmsh.model.addPhysicalGroup(2, inner, 2, name="tumour")
    edges = [
        abs(t) for _, t in gmsh.model.getBoundary([(2, t) for t in outer + inner], combined=True)
    ]
    for k, (name, axis, val) in enumerate(
        [("left", 0, 0.0), ("bottom", 1, 0.0), ("right", 0, 2 * L), ("top", 1, 2 * L)]
    ):
        pick = [e for e in edges if abs(occ.getCenterOfMass(1, e)[axis] - val) < 1e-9 * L]
        gmsh.model.addPhysicalGroup(1, pick, 3 + k, name=name)
    return inner


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """A results table as column name → values (non-numbers, e.g. names, as NaN)."""
    with open(path) as f:
        rows = list(csv.reader(f))

    def num(v: str) -> float:
        try:
            return float(v) if v else math.nan
        except ValueError:  # a name column (e.g. the empty contact pair)
            return math.nan

    return {k: np.array([num(r[i]) for r in rows[1:]]) for i, k in enumerate(rows[0])}


def run_text(text: str, path: Path, out: Path) -> RunResult:
    """Write the scene ``text`` to ``path/scene.toml`` (rank 0) and run it into ``out``
    (collective, in-process); a converged run's analyses must show reactions that
    balance their loads (``cli_support.check_reaction_balance``); on one rank a crack run
    is kept as the serial reference of the MPI sessions (:mod:`serial_store`)."""
    scene_file = path / "scene.toml"
    if MPI.COMM_WORLD.rank == 0:
        scene_file.write_text(text)
    MPI.COMM_WORLD.barrier()
    res = run_scene(load_scene(scene_file), MPI.COMM_WORLD, output=out, progress=False)
    if res.status == "converged":
        for table in (out, *sorted(Path(out).glob("mechanics_*"))):
            check_reaction_balance(table)
    if MPI.COMM_WORLD.size == 1:
        serial_store.keep(scene_file, Path(out))  # a crack run: the MPI sessions' reference
    return res
