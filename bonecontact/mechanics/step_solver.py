"""The solver an :class:`~bonecontact.mechanics.integrator.Integrator` is handed for its steps.

Without one, the integrator solves every step with one linear solve.  With one (the
contact solver :class:`bonecontact.contact.pdas.ContactSolver`), the integrator sets it
up with its operator and solves every step through it; the solver also provides what
the energy balance needs from the contact side.  mechanics knows the solver only
through this protocol.
"""

from __future__ import annotations

from typing import Protocol

from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
from dolfinx import fem

__all__ = ["StepResult", "StepSolver"]


class StepResult(Protocol):
    """What the integrator reads from the result of a step solve."""

    #: Linear (Krylov) iterations of the step.
    linear_iterations: int


class StepSolver(Protocol):
    """A solver of the steps of an :class:`~bonecontact.mechanics.integrator.Integrator`."""

    @property
    def slave_blocks(self) -> list[npt.NDArray[np.int32]]:
        """Local dof blocks of the contact (slave) nodes, per pair: the nodes without
        inertia under ``mass_redistribution``."""
        ...

    def setup(
        self,
        A: PETSc.Mat,
        bc_rows: npt.ArrayLike | None = None,
        *,
        force_scale: float = 1.0,
        linear: str = "direct",
        rtol: float = 1e-12,
        release_operator: bool = False,
    ) -> None:
        """Take the step operator ``A`` (Dirichlet rows and columns eliminated), its owned
        global Dirichlet rows, the factor turning its forces into physical ones, the
        linear solver (``"direct"`` / ``"iterative"``) and its Krylov tolerance;
        ``release_operator``: the caller needs ``A`` no more (the solver may destroy it
        once it has built what it needs from it)."""
        ...

    def solve(self, b: PETSc.Vec, u: fem.Function) -> StepResult:
        """Solve the step with right-hand side ``b`` (Dirichlet lifting applied) into ``u``."""
        ...

    def contact_gaps(self, u: fem.Function) -> list[npt.NDArray[np.float64]]:
        """Nodal normal gaps of every contact pair for the displacement ``u``."""
        ...

    def start_contact_work(self, u: fem.Function) -> None:
        """Record the gaps of the initial state ``u`` (start of an energy balance)."""
        ...

    def contact_work(self, u: fem.Function) -> float:
        """This rank's part of the work of the contact forces in the step just solved
        (``u``: its solution); collective reduction by the caller."""
        ...

    def destroy(self) -> None:
        """Free the solver's PETSc objects."""
        ...
