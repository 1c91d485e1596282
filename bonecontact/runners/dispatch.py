"""Run a scene: choose the run kind, then run it or only check it (docs/scene_format.md).

* ``[analysis]`` without ``[neoplasm]``: mechanics (:mod:`bonecontact.runners.mechanics`);
* ``[neoplasm]`` without ``[analysis]``: growth only (:mod:`bonecontact.runners.growth`);
* both: growth coupled to the loaded bone (:mod:`bonecontact.runners.coupled`).

Everything that can be wrong with the input is checked before any result file is
written; :class:`~bonecontact.scene.errors.SceneError` is raised on *every* rank (all
checks are collective), so a CLI can exit with status 2 on all ranks at once.
"""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

from bonecontact.runners.coupled import check_coupled, run_coupled
from bonecontact.runners.cracks import check_cracked, is_crack_scene, run_cracked
from bonecontact.runners.growth import build_growth, run_growth
from bonecontact.runners.mechanics import build_model, run_mechanics
from bonecontact.runners.results import RunResult
from bonecontact.scene import Scene, SceneError

__all__ = ["check", "run", "run_kind", "run_scene"]


def run_kind(scene: Scene) -> str:
    """``"growth"`` (``[neoplasm]`` only), ``"coupled"`` (``[neoplasm]`` and ``[analysis]``) or
    ``"mechanics"``."""
    if scene.growth_only:
        return "growth"
    if scene.neoplasm is not None:
        return "coupled"
    return "mechanics"


def run_scene(
    scene: Scene,
    comm: MPI.Comm = MPI.COMM_WORLD,
    output: str | Path | None = None,
    progress: bool = True,
    restart: str | Path | bool | None = None,
) -> RunResult:
    """Validate, build and run a scene, writing its results incrementally.

    Parameters
    ----------
    scene
        A scene from :func:`bonecontact.scene.load_scene`.
    comm
        The communicator the run is distributed over (collective on it).
    output
        The results directory; ``None``: the scene's ``[output] directory``.
    progress
        Show a progress bar (rank 0 only).
    restart
        Continue from the newest checkpoint (``True``) or the named one
        (docs/checkpoint.md).

    Returns
    -------
    RunResult
        ``status`` is ``"converged"`` or ``"failed"`` (then ``summary["message"]``
        says why; the last good state is in the output files).
    """
    output = None if output is None else Path(output)
    kind = run_kind(scene)
    if kind == "growth":  # [neoplasm] without [analysis]: growth.csv
        return run_growth(scene, comm, output, progress, restart)
    _refuse_initiation(scene, kind)
    if kind == "coupled":  # [neoplasm] with [analysis]: growth + rebuilt host mesh + analysis
        return run_coupled(scene, comm, output, progress, restart)
    if is_crack_scene(scene):  # a given or initiated crack: re-meshed body, face pair, fracture.csv
        return run_cracked(scene, comm, output, progress, restart)
    return run_mechanics(scene, comm, output, progress, restart)


def _refuse_initiation(scene: Scene, kind: str) -> None:
    """Crack initiation runs in mechanics scenes only."""
    if kind == "coupled" and scene.fracture is not None and scene.fracture.initiate:
        raise SceneError(
            scene.path,
            "[fracture]",
            "initiate",
            "a coupled [neoplasm] scene computes the risk and the growth time of initiation; "
            "inserting the crack runs in a static mechanics scene",
        )


#: :func:`run_scene` under its short name
run = run_scene


def check(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """Every check of a scene without running it (collective; nothing written).

    Raises
    ------
    SceneError
        On every rank.
    """
    kind = run_kind(scene)
    _refuse_initiation(scene, kind)
    if kind == "growth":
        build_growth(scene, comm)
    elif kind == "coupled":  # growth model, host mesh at t = 0, mechanics
        check_coupled(scene, comm)
    elif is_crack_scene(scene):
        check_cracked(scene, comm)
    else:
        build_model(scene, comm)
