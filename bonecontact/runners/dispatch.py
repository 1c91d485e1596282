"""Run a scene: choose the run kind, then run it or only check it (docs/scene_format.md).

The kind comes from the one table :data:`bonecontact.runners.kinds.KINDS` (chosen by
:func:`bonecontact.runners.kinds.choose_kind`; docs/run_loop.md):

* ``[analysis]`` without ``[neoplasm]``: mechanics (:mod:`bonecontact.runners.mechanics`),
  or a crack run with a ``[[crack]]`` or ``[fracture] initiate``
  (:mod:`bonecontact.runners.cracks`);
* ``[neoplasm]`` without ``[analysis]``: growth only (:mod:`bonecontact.runners.growth`);
* both: growth coupled to the loaded bone (:mod:`bonecontact.runners.coupled`).

Everything that can be wrong with the input is checked before any result file is
written; :class:`~bonecontact.scene.errors.SceneError` is raised on *every* rank (all
checks are collective), so a CLI can exit with status 2 on all ranks at once.
"""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

from bonecontact.runners.kinds import choose_kind, kind_name
from bonecontact.runners.mechanics import SceneModel
from bonecontact.runners.results import RunResult
from bonecontact.scene import Scene

__all__ = ["check", "run", "run_kind", "run_scene"]


def run_kind(scene: Scene) -> str:
    """The name of the scene's run kind: ``"growth"`` (``[neoplasm]`` only), ``"coupled"``
    (``[neoplasm]`` and ``[analysis]``), ``"crack"`` (a ``[[crack]]`` or ``[fracture]
    initiate``) or ``"mechanics"`` (:data:`bonecontact.runners.kinds.KINDS`)."""
    return kind_name(scene)


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
        says why; the last good state is in the output files).  The output files
        that rank 0 writes are complete on return on every rank (a barrier).
    """
    output = None if output is None else Path(output)
    result = choose_kind(scene).run(scene, comm, output, progress, restart)
    comm.barrier()  # every rank may read summary.json and the tables on return
    return result


#: :func:`run_scene` under its short name
run = run_scene


def check(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> SceneModel | None:
    """Every check of a scene without running it (collective; nothing written).

    Returns
    -------
    SceneModel or None
        The mechanics model a mechanics or crack scene builds (on the first cracked mesh
        of a crack scene; on the uncracked mesh of one that initiates its crack); ``None``
        for growth and coupled scenes (their mechanics mesh is rebuilt during the run).

    Raises
    ------
    SceneError
        On every rank.
    """
    return choose_kind(scene).check(scene, comm)
