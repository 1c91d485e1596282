"""Infrastructure shared by every layer: linear algebra, constants, formatting, geometry.

``linalg``: PETSc linear solvers (MUMPS, CG/GMRES + GAMG), rigid-body near-nullspaces and
body labels; ``constants``: physical constants and time units (SI); ``formatting``: the
text of numbers in result tables; ``geometry``: small 2D geometry helpers; ``profiling``:
wall time per phase and peak memory (summary.json); ``version``: the package version from
its metadata; ``resources``: the shipped data files (package ``bonecontact.data``) through
importlib.resources.
"""

from bonecontact.common.constants import R_GAS, SECONDS_PER_DAY, SECONDS_PER_YEAR
from bonecontact.common.formatting import format_cell, format_float
from bonecontact.common.geometry import cross2, polygon_area, signed_polygon_area
from bonecontact.common.linalg import (
    LinearSolverInfo,
    body_labels,
    configure_ksp,
    create_solver,
    owned_global_rows,
    release_petsc_garbage,
    rigid_body_modes,
)
from bonecontact.common.profiling import PhaseTimer, peak_memory_mb
from bonecontact.common.version import __version__

__all__ = [
    "R_GAS",
    "SECONDS_PER_DAY",
    "SECONDS_PER_YEAR",
    "LinearSolverInfo",
    "PhaseTimer",
    "__version__",
    "body_labels",
    "configure_ksp",
    "create_solver",
    "cross2",
    "format_cell",
    "format_float",
    "owned_global_rows",
    "peak_memory_mb",
    "polygon_area",
    "release_petsc_garbage",
    "rigid_body_modes",
    "signed_polygon_area",
]
