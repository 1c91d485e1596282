"""The table of run kinds: what a scene runs as, chosen in one place (docs/run_loop.md).

Every entry names the kind, says what it runs, and gives the two callables a scene of that
kind needs: ``check`` (every check of the scene, nothing written; returns the mechanics
model when the kind has one on the scene's own mesh, else ``None``) and ``run`` (validate,
build and run, writing results).  :func:`choose_kind` is the only place that looks at a
scene to choose its kind; :func:`bonecontact.runners.dispatch.run_scene`,
:func:`bonecontact.runners.dispatch.check` and ``bonecontact check`` all go through it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

from bonecontact.runners.breakthrough3d import (
    breaks_to_surface,
    check_breakthrough,
    run_breakthrough,
)
from bonecontact.runners.coupled import check_coupled, run_coupled
from bonecontact.runners.cracks import check_cracked, is_crack_scene, run_cracked
from bonecontact.runners.front_growth3d import (
    check_interior_growth,
    grows_interior_crack,
    run_interior_growth,
)
from bonecontact.runners.growth import build_growth, run_growth
from bonecontact.runners.mechanics import SceneModel, build_model, run_mechanics
from bonecontact.runners.nonplanar_surface3d import (
    check_nonplanar_surface,
    grows_nonplanar,
    run_nonplanar_surface,
)
from bonecontact.runners.results import RunResult
from bonecontact.runners.surface_crack3d import (
    check_surface_crack,
    has_surface_crack,
    run_surface_crack,
)
from bonecontact.scene import Scene, SceneError

__all__ = ["KINDS", "RunKind", "choose_kind"]

Restart = str | Path | bool | None
CheckFn = Callable[[Scene, MPI.Comm], SceneModel | None]
RunFn = Callable[[Scene, MPI.Comm, Path | None, bool, Restart], RunResult]


@dataclass(frozen=True)
class RunKind:
    """One row of the run-kind table."""

    name: str
    what: str  # one line: what the scene has and what the run does
    check: CheckFn
    run: RunFn


def _check_growth(scene: Scene, comm: MPI.Comm) -> None:
    """A growth-only scene: the growth model built against its mesh (no mechanics model)."""
    build_growth(scene, comm)
    return None


def _refuse_initiation(scene: Scene) -> None:
    """Crack initiation runs in mechanics scenes only."""
    if scene.fracture is not None and scene.fracture.initiate:
        raise SceneError(
            scene.path,
            "[fracture]",
            "initiate",
            "a coupled [neoplasm] scene computes the risk and the growth time of initiation; "
            "inserting the crack runs in a static mechanics scene",
        )


def _check_coupled(scene: Scene, comm: MPI.Comm) -> None:
    """A coupled scene: the growth model, the host mesh at t = 0 and the mechanics on it."""
    _refuse_initiation(scene)
    check_coupled(scene, comm)
    return None


def _run_coupled(
    scene: Scene, comm: MPI.Comm, output: Path | None, progress: bool, restart: Restart
) -> RunResult:
    _refuse_initiation(scene)
    return run_coupled(scene, comm, output, progress, restart)


def _check_crack(scene: Scene, comm: MPI.Comm) -> SceneModel | None:
    """A crack scene: a 3D surface crack (:mod:`~bonecontact.runners.surface_crack3d`) or
    any other crack (:mod:`~bonecontact.runners.cracks`)."""
    if scene.dimension == 3 and has_surface_crack(scene):
        if grows_nonplanar(scene):
            return check_nonplanar_surface(scene, comm)
        return check_surface_crack(scene, comm)
    if grows_interior_crack(scene):
        if breaks_to_surface(scene):
            return check_breakthrough(scene, comm)
        return check_interior_growth(scene, comm)
    return check_cracked(scene, comm)


def _run_crack(
    scene: Scene, comm: MPI.Comm, output: Path | None, progress: bool, restart: Restart
) -> RunResult:
    if scene.dimension == 3 and has_surface_crack(scene):
        if grows_nonplanar(scene):
            return run_nonplanar_surface(scene, comm, output, progress, restart)
        return run_surface_crack(scene, comm, output, progress, restart)
    if grows_interior_crack(scene):
        if breaks_to_surface(scene):
            return run_breakthrough(scene, comm, output, progress, restart)
        return run_interior_growth(scene, comm, output, progress, restart)
    return run_cracked(scene, comm, output, progress, restart)


#: The run kinds, in the order :func:`choose_kind` tries them.
KINDS: dict[str, RunKind] = {
    "growth": RunKind(
        "growth",
        "[neoplasm] without [analysis]: the neoplasm grows alone (growth.csv)",
        _check_growth,
        run_growth,
    ),
    "coupled": RunKind(
        "coupled",
        "[neoplasm] and [analysis]: growth, the host mesh rebuilt, the analysis run on it",
        _check_coupled,
        _run_coupled,
    ),
    "crack": RunKind(
        "crack",
        "[analysis] with a [[crack]] or [fracture] initiate: the body meshed around the crack",
        _check_crack,
        _run_crack,
    ),
    "mechanics": RunKind(
        "mechanics",
        "[analysis] without [neoplasm] or crack: the scene's mesh, steps, results",
        build_model,
        run_mechanics,
    ),
}


def kind_name(scene: Scene) -> str:
    """The name of the scene's run kind (a key of :data:`KINDS`)."""
    if scene.growth_only:
        return "growth"
    if scene.neoplasm is not None:
        return "coupled"
    if is_crack_scene(scene):
        return "crack"
    return "mechanics"


def choose_kind(scene: Scene) -> RunKind:
    """The row of :data:`KINDS` the scene runs as (the only place a kind is chosen)."""
    return KINDS[kind_name(scene)]
