"""bonecontact: dynamic frictional contact of visco-elastic bones with growing neoplasms.

FEniCSx (DOLFINx 0.11) package.  Import order matters: ``dolfinx_solver`` (which
loads MPI) must be imported before ``dolfinx``; importing :mod:`bonecontact` does it.
Units are SI throughout (m, kg, s, Pa, N).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx / petsc4py)

from bonecontact.common.version import __version__
