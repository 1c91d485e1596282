"""bonecontact: dynamic frictional contact of visco-elastic bones with growing neoplasms.

A FEniCSx (DOLFINx 0.11) package.  Units are SI throughout (m, kg, s, Pa, N; in 2D plane
strain forces are per metre of thickness).

The names a notebook needs are here:

* scenes: :func:`load_scene`, :func:`run`, :func:`check`, :class:`Scene`, :class:`SceneError`,
  :class:`RunResult`;
* the model: :class:`Mechanics`, :class:`Integrator` and the materials
  (:class:`Isotropic`, :class:`TransverselyIsotropic`, :class:`Orthotropic`);
* contact: :func:`build_interface`, :class:`ContactSolver`, :class:`PDASOptions`,
  :class:`FrictionLaw`, :class:`RigidPlane`, :class:`PDASResult`,
  :class:`ContactConvergenceError`.

Everything else lives in one subpackage per concern (``common``, ``materials``,
``mechanics``, ``contact``, ``meshing``, ``neoplasm``, ``scene``, ``verification``,
``runners``).  Import order matters: ``dolfinx_solver`` (which loads MPI) must be imported
before ``dolfinx``; importing :mod:`bonecontact` does it.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx / petsc4py)

from bonecontact.common.version import __version__
from bonecontact.contact import (
    ContactConvergenceError,
    ContactSolver,
    FrictionLaw,
    PDASOptions,
    PDASResult,
    RigidPlane,
    build_interface,
)
from bonecontact.materials import Isotropic, Orthotropic, TransverselyIsotropic
from bonecontact.mechanics import Integrator, Mechanics
from bonecontact.runners import RunResult, check, run
from bonecontact.scene import Scene, SceneError, load_scene

__all__ = [
    "ContactConvergenceError",
    "ContactSolver",
    "FrictionLaw",
    "Integrator",
    "Isotropic",
    "Mechanics",
    "Orthotropic",
    "PDASOptions",
    "PDASResult",
    "RigidPlane",
    "RunResult",
    "Scene",
    "SceneError",
    "TransverselyIsotropic",
    "__version__",
    "build_interface",
    "check",
    "load_scene",
    "run",
]
