"""Scene files: reading a TOML scene (:func:`load_scene`), the dataclasses of a parsed
scene with the declaration of every table's keys (:mod:`~bonecontact.scene.spec`,
:mod:`~bonecontact.scene.keys`), its errors (:class:`SceneError`), the checks against the
mesh (:func:`check_against_mesh`) and the safe rate expressions of tumour parameters
(:mod:`~bonecontact.scene.expressions`)."""

from bonecontact.scene.checks import check_against_mesh
from bonecontact.scene.errors import SceneError, format_error
from bonecontact.scene.expressions import ExpressionError, RateExpression, parse_rate
from bonecontact.scene.keys import SceneDeprecationWarning
from bonecontact.scene.reader import FORMAT_VERSION, load_scene
from bonecontact.scene.spec import (
    Analysis,
    ContactSpec,
    CrackSpec,
    CystSpec,
    DirichletSpec,
    FractureSpec,
    InitialVelocitySpec,
    LoadSpec,
    MaterialSpec,
    NeoplasmSpec,
    OutputSpec,
    Scene,
    Schedule,
    SolverOptions,
    default_solver_options,
)

__all__ = [
    "FORMAT_VERSION",
    "Analysis",
    "ContactSpec",
    "CrackSpec",
    "CystSpec",
    "DirichletSpec",
    "ExpressionError",
    "FractureSpec",
    "InitialVelocitySpec",
    "LoadSpec",
    "MaterialSpec",
    "NeoplasmSpec",
    "OutputSpec",
    "RateExpression",
    "Scene",
    "SceneDeprecationWarning",
    "SceneError",
    "Schedule",
    "SolverOptions",
    "check_against_mesh",
    "default_solver_options",
    "format_error",
    "load_scene",
    "parse_rate",
]
