"""Dual-mortar contact: mortar geometry (dual basis, surface frames, candidate search,
clipping, assembly of D, M and the weighted gap), distributed contact interfaces, friction
laws, and the primal–dual active set (semi-smooth Newton) contact solver with low-rank
updates, plus a PETSc SNES VI reference solver.  The solver's parts: docs/theory/pdas.md,
"Structure of the solver"."""

from bonecontact.contact.friction import FrictionLaw
from bonecontact.contact.interface import (
    ContactInputError,
    ContactInterface,
    RigidPlane,
    basis_transform,
    build_interface,
    rotation_matrix,
)
from bonecontact.contact.lowrank import LowRankActiveSetSolver, SingularActiveSetError
from bonecontact.contact.mortar_assembly import MortarContributions, assemble_mortar
from bonecontact.contact.options import (
    ActiveSetOptions,
    LinearOptions,
    PDASOptions,
    SlipOptions,
)
from bonecontact.contact.pdas import ContactConvergenceError, ContactSolver, PDASResult
from bonecontact.contact.snes_vi import snes_vi_solve

__all__ = [
    "ActiveSetOptions",
    "ContactConvergenceError",
    "ContactInputError",
    "ContactInterface",
    "ContactSolver",
    "FrictionLaw",
    "LinearOptions",
    "LowRankActiveSetSolver",
    "MortarContributions",
    "PDASOptions",
    "PDASResult",
    "RigidPlane",
    "SingularActiveSetError",
    "SlipOptions",
    "assemble_mortar",
    "basis_transform",
    "build_interface",
    "rotation_matrix",
    "snes_vi_solve",
]
