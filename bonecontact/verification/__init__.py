"""Closed-form references and the shared verification problems.

``analytic``: Hertz contact of a cylinder (2D) and a sphere (3D) and the contact modulus;
``impact``: the longitudinal impact of two elastic bars (set-up and run);
``problems``: problem builders that the tests and the benchmarks share (the 3D Hertz
sphere on a block); ``load_driven``: the load-driven Hertz problems (a hemisphere or a
half disc held only by the contact) with their phase timings and Hertz errors.  The
formulas are collected in ``docs/theory/verification.md``.
"""

from bonecontact.verification.analytic import (
    contact_modulus,
    cylinder_half_width,
    cylinder_load,
    cylinder_peak_pressure,
    cylinder_pressure,
    hertz_2d,
    hertz_3d,
    sphere_load,
    sphere_peak_pressure,
    sphere_pressure,
    sphere_radius,
)
from bonecontact.verification.impact import (
    STRIKER,
    STRIKER_END,
    STRUCK,
    STRUCK_END,
    BarImpact,
    ImpactResult,
    run_bar_impact,
    two_bars_2d,
)
from bonecontact.verification.load_driven import (
    LOAD_DRIVEN_E,
    LOAD_DRIVEN_NU,
    LOAD_DRIVEN_RADIUS,
    LOAD_DRIVEN_STIFFNESS_RATIO,
    LoadDrivenHertz,
    half_disc_on_block_2d,
    hertz_errors,
    sphere_on_block_3d,
)
from bonecontact.verification.problems import HERTZ_3D_NU, HERTZ_3D_RADIUS, solve_hertz_3d

__all__ = [
    "HERTZ_3D_NU",
    "HERTZ_3D_RADIUS",
    "LOAD_DRIVEN_E",
    "LOAD_DRIVEN_NU",
    "LOAD_DRIVEN_RADIUS",
    "LOAD_DRIVEN_STIFFNESS_RATIO",
    "STRIKER",
    "STRIKER_END",
    "STRUCK",
    "STRUCK_END",
    "BarImpact",
    "ImpactResult",
    "LoadDrivenHertz",
    "contact_modulus",
    "cylinder_half_width",
    "cylinder_load",
    "cylinder_peak_pressure",
    "cylinder_pressure",
    "half_disc_on_block_2d",
    "hertz_2d",
    "hertz_3d",
    "hertz_errors",
    "run_bar_impact",
    "solve_hertz_3d",
    "sphere_load",
    "sphere_on_block_3d",
    "sphere_peak_pressure",
    "sphere_pressure",
    "sphere_radius",
    "two_bars_2d",
]
