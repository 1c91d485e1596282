"""Running scenes: the ``bonecontact`` command, the table of run kinds, the step loop and one
module per run kind (docs/run_loop.md).

:mod:`~bonecontact.runners.cli` (the command) calls :mod:`~bonecontact.runners.dispatch`, which
takes the scene's row of :data:`bonecontact.runners.kinds.KINDS`:
:mod:`~bonecontact.runners.mechanics` (an analysis), :mod:`~bonecontact.runners.cracks` (an
analysis with a crack), :mod:`~bonecontact.runners.growth` (a neoplasm grown alone) or
:mod:`~bonecontact.runners.coupled` (growth with the analysis on a rebuilt host mesh).  Every
kind builds its model and runs it through :func:`bonecontact.runners.loop.run_steps` with its
own hooks, and writes its files through :mod:`~bonecontact.runners.results`.
"""

from bonecontact.runners.cli import main
from bonecontact.runners.coupled import check_coupled, mechanics_scene, run_coupled
from bonecontact.runners.dispatch import check, run, run_kind, run_scene
from bonecontact.runners.growth import build_growth, growth_times, run_growth
from bonecontact.runners.mechanics import SceneModel, build_model, read_mesh, run_mechanics
from bonecontact.runners.results import (
    ENERGY_COLUMNS,
    GROWTH_UNITS,
    HISTORY_COLUMNS,
    MECHANICS_UNITS,
    SUMMARY_FORMAT,
    GrowthTable,
    ProbeError,
    Probes,
    ResultsWriter,
    RunResult,
    StressFields,
    run_summary,
    write_points,
    write_summary,
)

__all__ = [
    "ENERGY_COLUMNS",
    "GROWTH_UNITS",
    "HISTORY_COLUMNS",
    "MECHANICS_UNITS",
    "SUMMARY_FORMAT",
    "GrowthTable",
    "ProbeError",
    "Probes",
    "ResultsWriter",
    "RunResult",
    "SceneModel",
    "StressFields",
    "build_growth",
    "build_model",
    "check",
    "check_coupled",
    "growth_times",
    "main",
    "mechanics_scene",
    "read_mesh",
    "run",
    "run_coupled",
    "run_growth",
    "run_kind",
    "run_mechanics",
    "run_scene",
    "run_summary",
    "write_points",
    "write_summary",
]
