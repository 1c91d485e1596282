"""Linear (visco)elastic mechanics: the finite-element model (operators, loads, Dirichlet
conditions) and the static, quasi-static and dynamic integrators with their energy
balance; the step-solver protocol through which an integrator is handed a contact solver."""

from bonecontact.mechanics.integrator import (
    Energy,
    EnergyBalance,
    Integrator,
    StepInfo,
    redistributed_mass,
)
from bonecontact.mechanics.model import Mechanics, Schedule, constant_schedule
from bonecontact.mechanics.step_solver import StepResult, StepSolver

__all__ = [
    "Energy",
    "EnergyBalance",
    "Integrator",
    "Mechanics",
    "Schedule",
    "StepInfo",
    "StepResult",
    "StepSolver",
    "constant_schedule",
    "redistributed_mass",
]
