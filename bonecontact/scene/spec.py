"""The parsed scene: dataclasses of a validated scene file (format 1).

A *scene* is one TOML file describing a loaded part of the skeleton: the mesh,
the analysis (static, quasi-static or dynamic), the materials of the cell
regions, contact pairs, boundary conditions, loads and output.
``docs/scene_format.md`` documents the format.

The scene is read in two steps: :func:`bonecontact.scene.reader.load_scene` reads the
file and checks everything that does not need the mesh and builds the dataclasses of
this module; :func:`bonecontact.scene.checks.check_against_mesh` checks the names of
physical groups against the groups actually present in the mesh.  Units are SI
(m, Pa, kg, s).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from bonecontact.contact.friction import FrictionLaw
from bonecontact.fracture.crack import Crack2D
from bonecontact.fracture.crack3d import CRACK3D_SHAPES, PlanarCrack
from bonecontact.fracture.criteria import RISK_CRITERIA
from bonecontact.materials.laws import FORMULATIONS, Material
from bonecontact.neoplasm.cyst import CystParameters
from bonecontact.neoplasm.tumour import TumourParameters
from bonecontact.scene.keys import REQUIRED, Key, Table

__all__ = [
    "TABLES",
    "Analysis",
    "ContactSpec",
    "CrackSpec",
    "CystSpec",
    "DirichletSpec",
    "FatigueSpec",
    "FractureSpec",
    "InitialVelocitySpec",
    "LoadSpec",
    "MaterialSpec",
    "NeoplasmSpec",
    "OutputSpec",
    "Scene",
    "Schedule",
    "SolverOptions",
    "default_solver_options",
]

ANALYSIS_KINDS = ("static", "quasistatic", "dynamic")
UNHELD_MOTION_CHOICES = ("error", "warn")
#: ``[analysis] scheme``: the time scheme of a dynamic analysis (bonecontact.mechanics.newmark)
SCHEME_CHOICES = ("backward-difference", "stabilized-newmark")
LINEAR_SOLVERS = ("direct", "iterative")
#: ``[solver] multigrid``: the preconditioner of the iterative contact solve
#: (:class:`bonecontact.contact.options.LinearOptions`).
MULTIGRIDS = ("gamg", "compressed")
FRICTION_LAWS = ("none", "tresca", "coulomb")
COULOMB_UPDATES = ("previous_step", "fixed_point")
LOAD_KINDS = ("traction", "pressure", "body_force", "force")
NEOPLASM_KINDS = ("tumour", "cyst")
CYST_MODELS = ("sphere", "shape")
MATERIAL_MODELS = ("isotropic", "transversely_isotropic", "orthotropic")
CRACK_DIRECTIONS = ("mts", "principal")
CRACK_TIPS = ("both", "start", "end")

#: A ``ramp`` or ``schedule`` of a load or prescribed displacement (docs: *Schedules*).
SCHEDULE_KEYS = (
    Key("ramp", "number", unit="s", minimum=0, doc_default="none (static: `1.0`)"),
    Key("schedule", "schedule", doc_default="none (static: `ramp = 1`)"),
)


# --------------------------------------------------------------------------------------
# schedules
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Schedule:
    """Piecewise-linear time factor of a load or prescribed displacement.

    The factor is interpolated linearly between the ``(times[i], factors[i])``
    pairs and held constant before the first and after the last time.  The
    default is the constant factor 1.

    Parameters
    ----------
    times
        Strictly increasing times (s); at least one.
    factors
        Factor at each time (dimensionless), as many as ``times``.

    Examples
    --------
    >>> s = Schedule.from_ramp(2.0)
    >>> s(0.5), s(3.0)
    (0.25, 1.0)
    >>> Schedule.from_pairs([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]])(1.5)
    0.5
    """

    times: tuple[float, ...] = (0.0,)
    factors: tuple[float, ...] = (1.0,)

    def __post_init__(self) -> None:
        t = tuple(float(x) for x in self.times)
        f = tuple(float(x) for x in self.factors)
        if len(t) == 0 or len(t) != len(f):
            raise ValueError(
                "a schedule needs at least one (time, factor) pair and as many factors as times"
            )
        if not all(math.isfinite(x) for x in t + f):
            raise ValueError("schedule times and factors must be finite numbers")
        if any(b <= a for a, b in zip(t, t[1:])):
            raise ValueError(f"schedule times must be strictly increasing, got {list(t)}")
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "factors", f)

    @classmethod
    def constant(cls, factor: float = 1.0) -> Schedule:
        """The constant factor ``factor``."""
        return cls((0.0,), (float(factor),))

    @classmethod
    def from_ramp(cls, ramp: float) -> Schedule:
        """``min(t / ramp, 1)`` for ``ramp > 0`` (0 before ``t = 0``); constant 1 for ``ramp ==
        0``."""
        if not math.isfinite(ramp) or ramp < 0.0:
            raise ValueError(f"ramp must be >= 0, got {ramp!r}")
        if ramp == 0.0:
            return cls.constant(1.0)
        return cls((0.0, float(ramp)), (0.0, 1.0))

    @classmethod
    def from_pairs(cls, pairs: Sequence[Sequence[float]]) -> Schedule:
        """From ``[[t, factor], ...]`` pairs (times strictly increasing)."""
        pts = [tuple(p) for p in pairs]
        if not pts or any(len(p) != 2 for p in pts):
            raise ValueError("a schedule is a non-empty list of [time, factor] pairs")
        return cls(tuple(p[0] for p in pts), tuple(p[1] for p in pts))

    @property
    def is_constant(self) -> bool:
        """Whether the factor does not depend on time."""
        return len(set(self.factors)) == 1

    def __call__(self, t: float) -> float:
        """The factor at time ``t``."""
        return float(np.interp(float(t), self.times, self.factors))

    def values(self, ts: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """The factor at each time of ``ts`` (any shape)."""
        return np.interp(np.asarray(ts, dtype=np.float64), self.times, self.factors)


# --------------------------------------------------------------------------------------
# scene objects
# --------------------------------------------------------------------------------------
#: The top level of a scene file: ``format`` and the tables (docs: *Top level*).
TOP_LEVEL = Table(
    "",
    (
        Key("format", "integer", REQUIRED),
        *(
            Key(name, "table")
            for name in (
                "scene",
                "analysis",
                "solver",
                "material",
                "contact",
                "dirichlet",
                "traction",
                "pressure",
                "body_force",
                "force",
                "initial_velocity",
                "output",
                "neoplasm",
                "fracture",
                "crack",
            )
        ),
    ),
)

#: ``[scene]``.
SCENE_TABLE = Table(
    "scene",
    (
        Key("name", "string", doc_default="file name without suffix"),
        Key("mesh", "string", REQUIRED),
        Key("dimension", "integer", REQUIRED),
    ),
)


@dataclass(frozen=True)
class Analysis:
    """``[analysis]``: what kind of problem is solved over which (pseudo-)time.

    Parameters
    ----------
    kind
        ``"static"`` (no inertia, no viscosity), ``"quasistatic"`` (no inertia,
        viscous term with the step as rate) or ``"dynamic"``.
    t_end
        End time (s); required for quasistatic and dynamic analyses.  A static
        analysis ignores it (its pseudo-time runs from 0 to 1); ``None`` if absent.
    dt
        Time step (s), ``0 < dt <= t_end``; same rules as ``t_end``.
    load_steps
        Number of load increments of a static analysis (>= 1).
    unheld_motion
        What a rigid motion of a body that no support and no contact holds is
        (docs/theory/rigid_motions.md): ``"error"`` (default: the scene is refused) or
        ``"warn"``.
    scheme
        Time scheme of a dynamic analysis: ``"backward-difference"`` (default) or
        ``"stabilized-newmark"`` (docs/theory/mechanics.md#contact-stabilised-newmark).
    allow_large_strain
        Accept a run whose strain exceeds the small-strain range (default ``False``: such
        a run ends with status ``"invalid"``; :mod:`bonecontact.scene.validity`).
    """

    kind: Literal["static", "quasistatic", "dynamic"] = "static"
    t_end: float | None = None
    dt: float | None = None
    load_steps: int = 1
    unheld_motion: Literal["error", "warn"] = "error"
    scheme: Literal["backward-difference", "stabilized-newmark"] = "backward-difference"
    allow_large_strain: bool = False

    @property
    def n_steps(self) -> int:
        """Number of steps: ``load_steps`` (static) or ``ceil(t_end / dt)``."""
        if self.kind == "static" or self.t_end is None or self.dt is None:
            return self.load_steps
        return max(1, math.ceil(self.t_end / self.dt * (1.0 - 1e-12)))

    def times(self) -> npt.NDArray[np.float64]:
        """The (pseudo-)times at the end of each step.

        Static: ``k / load_steps`` for ``k = 1..load_steps``.  Otherwise
        ``k * dt``; when ``dt`` does not divide ``t_end`` the last step is
        shortened so that the last time is exactly ``t_end``.
        """
        n = self.n_steps
        if self.kind == "static" or self.t_end is None or self.dt is None:
            return np.arange(1, n + 1, dtype=np.float64) / n
        t = np.arange(1, n + 1, dtype=np.float64) * self.dt
        t[-1] = self.t_end
        return t


#: ``[analysis]``.
ANALYSIS_TABLE = Table(
    "analysis",
    (
        Key("kind", "string", REQUIRED, choices=ANALYSIS_KINDS),
        Key(
            "t_end",
            "number",
            unit="s",
            minimum=0,
            exclusive=True,
            doc_default="required for quasistatic/dynamic",
        ),
        Key(
            "dt",
            "number",
            unit="s",
            minimum=0,
            exclusive=True,
            doc_default="required for quasistatic/dynamic",
        ),
        Key("load_steps", "integer", 1, minimum=1),
        Key("unheld_motion", "string", "error", choices=UNHELD_MOTION_CHOICES),
        Key("scheme", "string", "backward-difference", choices=SCHEME_CHOICES),
        Key("allow_large_strain", "boolean", False),
    ),
)


@dataclass(frozen=True)
class SolverOptions:
    """``[solver]``.

    Parameters
    ----------
    linear
        ``"direct"`` (MUMPS LU) or ``"iterative"`` (Krylov + GAMG).
    tolerance
        Stopping tolerance of the PDAS / nonlinear iterations (> 0); it also sets the
        contact solve's Krylov relative tolerance, ``min(1e-2 * tolerance, 1e-8)``
        (:func:`bonecontact.contact.krylov.krylov_rtol`).
    max_iterations
        Maximum number of PDAS / nonlinear iterations per step (>= 1).
    multigrid
        The multigrid preconditioner of the iterative contact solve: ``"compressed"``
        (:mod:`bonecontact.contact.compressed_mg`, the default) or ``"gamg"`` (PETSc's);
        ignored by ``"direct"`` and by solves without contact.
    """

    linear: Literal["direct", "iterative"] = "direct"
    tolerance: float = 1e-10
    max_iterations: int = 50
    multigrid: Literal["gamg", "compressed"] = "compressed"


#: ``[solver]``.
SOLVER_TABLE = Table(
    "solver",
    (
        Key("linear", "string", "direct", choices=LINEAR_SOLVERS),
        Key("tolerance", "number", 1e-10, minimum=0, exclusive=True),
        Key("max_iterations", "integer", 50, minimum=1),
        Key("multigrid", "string", "compressed", choices=MULTIGRIDS),
    ),
)


def default_solver_options() -> SolverOptions:
    """The solver options used when ``[solver]`` (or one of its keys) is absent."""
    return SolverOptions()


@dataclass(frozen=True)
class MaterialSpec:
    """One ``[[material]]`` entry.

    Parameters
    ----------
    name
        Unique name of the material.
    regions
        Cell physical groups made of this material.
    material
        The validated material law.
    index
        Position of the entry in the file, counting from 0.
    strengths
        ``sigma_t``, ``sigma_c``, ``K_Ic`` (Pa, Pa·√m) given in the entry, for the fracture
        check (docs/theory/fracture.md#material-strength).
    """

    name: str
    regions: tuple[str, ...]
    material: Material
    index: int
    strengths: dict[str, float] = field(default_factory=dict, compare=False)


#: ``[[material]]``: the keys of every material (the constants of its model:
#: :data:`MODEL_CONSTANTS`).
MATERIAL_TABLE = Table(
    "material",
    (
        Key("name", "string", REQUIRED),
        Key("regions", "names", REQUIRED),
        Key("model", "string", REQUIRED, choices=MATERIAL_MODELS),
        Key("rho", "number", unit="kg/m³", minimum=0, exclusive=True),
        Key("tau_v", "number", 0.0, unit="s", minimum=0),
        Key("formulation", "string", "displacement", choices=FORMULATIONS),
        Key("sigma_t", "number", unit="Pa", minimum=0, exclusive=True),
        Key("sigma_c", "number", unit="Pa", minimum=0, exclusive=True),
        Key("K_Ic", "number", unit="Pa·√m", minimum=0, exclusive=True),
    ),
    array=True,
)
#: The strength keys of a ``[[material]]`` (needed by a ``[fracture]`` check).
MATERIAL_STRENGTH_KEYS = ("sigma_t", "sigma_c", "K_Ic")


def _moduli(*names: str) -> tuple[Key, ...]:
    return tuple(Key(n, "number", REQUIRED, unit="Pa") for n in names)


def _ratios(*names: str) -> tuple[Key, ...]:
    return tuple(Key(n, "number", REQUIRED) for n in names)


#: The engineering constants of each material model (all required).
MODEL_CONSTANTS: dict[str, tuple[Key, ...]] = {
    "isotropic": (*_moduli("E"), *_ratios("nu")),
    "transversely_isotropic": (
        *_moduli("E_p", "E_a"),
        *_ratios("nu_p", "nu_pa"),
        *_moduli("G_pa"),
        Key("axis", "vector", REQUIRED),
    ),
    "orthotropic": (
        *_moduli("E1", "E2", "E3"),
        *_ratios("nu12", "nu13", "nu23"),
        *_moduli("G12", "G13", "G23"),
        Key("axes", "array", REQUIRED),
    ),
}


@dataclass(frozen=True)
class ContactSpec:
    """One ``[[contact]]`` pair.

    Parameters
    ----------
    name
        Unique name of the pair (used in output file names).
    slave, master
        Facet physical groups of the slave and master surfaces.
    friction
        ``"none"``, ``"tresca"`` or ``"coulomb"``.
    coefficient
        Coulomb friction coefficient (>= 0).
    bound
        Tresca friction bound in Pa (>= 0).
    coulomb_update
        ``"previous_step"`` (semi-implicit: bound from the previous step's normal
        pressure) or ``"fixed_point"`` (iterated within the step).
    search_distance
        How far (m) along its normal each slave facet looks for master facets; ``None``:
        three times the slave facet's own size.
    """

    name: str
    slave: str
    master: str
    friction: Literal["none", "tresca", "coulomb"] = "none"
    coefficient: float = 0.0
    bound: float = 0.0
    coulomb_update: Literal["previous_step", "fixed_point"] = "previous_step"
    search_distance: float | None = None

    def friction_law(self) -> FrictionLaw:
        """The :class:`~bonecontact.contact.friction.FrictionLaw` of this pair (the one
        place a scene's friction becomes the solver's)."""
        return FrictionLaw(self.friction, self.coefficient, self.bound, self.coulomb_update)


#: ``[[contact]]``.
CONTACT_TABLE = Table(
    "contact",
    (
        Key("name", "string", REQUIRED),
        Key("slave", "string", REQUIRED),
        Key("master", "string", REQUIRED),
        Key("friction", "string", "none", choices=FRICTION_LAWS),
        Key("coefficient", "number", 0.0, minimum=0),
        Key("bound", "number", 0.0, unit="Pa", minimum=0),
        Key("coulomb_update", "string", "previous_step", choices=COULOMB_UPDATES),
        Key(
            "search_distance",
            "number",
            unit="m",
            minimum=0,
            exclusive=True,
            doc_default="3 × each slave facet's size beyond the closest distance of the two "
            "surfaces",
        ),
    ),
    array=True,
)


@dataclass(frozen=True)
class DirichletSpec:
    """One ``[[dirichlet]]`` entry: prescribed displacement components on a boundary.

    Parameters
    ----------
    boundary
        Facet physical group.
    value
        Displacement (m) per component; ``None`` leaves the component free.
    schedule
        Time factor of ``value``.
    """

    boundary: str
    value: tuple[float | None, ...]
    schedule: Schedule = field(default_factory=Schedule)

    @property
    def components(self) -> tuple[int, ...]:
        """Indices of the fixed components."""
        return tuple(i for i, v in enumerate(self.value) if v is not None)


#: ``[[dirichlet]]``.
DIRICHLET_TABLE = Table(
    "dirichlet",
    (Key("boundary", "string", REQUIRED), Key("value", "array", REQUIRED, unit="m"))
    + SCHEDULE_KEYS,
    array=True,
)


@dataclass(frozen=True)
class LoadSpec:
    """One ``[[traction]]``, ``[[pressure]]``, ``[[body_force]]`` or ``[[force]]`` entry.

    Parameters
    ----------
    kind
        ``"traction"``, ``"pressure"``, ``"body_force"`` or ``"force"``.
    target
        ``(boundary,)`` for traction, pressure and force (a facet group), the cell
        regions for a body force.
    value
        Traction vector (Pa), scalar pressure (Pa, positive pushes into the
        body), body-force vector (N/m³) or total force vector (N; N/m in 2D plane
        strain), spread uniformly over the boundary's reference area.
    schedule
        Time factor of ``value`` (and of ``moment``).
    moment
        ``[[force]]`` only: total moment of the load about ``point`` (N·m; 2D: the
        z-component, a number, in N·m/m), given by a linearly varying traction added to
        the uniform one (docs/scene_format.md#force); ``None``: no moment prescribed.
    point
        ``[[force]]`` only: the point ``moment`` is taken about (m); ``None``: the
        centroid of the boundary.
    """

    kind: Literal["traction", "pressure", "body_force", "force"]
    target: tuple[str, ...]
    value: tuple[float, ...] | float
    schedule: Schedule = field(default_factory=Schedule)
    moment: tuple[float, ...] | float | None = None
    point: tuple[float, ...] | None = None


#: ``[[traction]]``, ``[[pressure]]``, ``[[body_force]]`` and ``[[force]]``.
LOAD_TABLES = {
    "traction": Table(
        "traction",
        (Key("boundary", "string", REQUIRED), Key("value", "vector", REQUIRED, unit="Pa"))
        + SCHEDULE_KEYS,
        array=True,
    ),
    "pressure": Table(
        "pressure",
        (Key("boundary", "string", REQUIRED), Key("value", "number", REQUIRED, unit="Pa"))
        + SCHEDULE_KEYS,
        array=True,
    ),
    "body_force": Table(
        "body_force",
        (Key("regions", "names", REQUIRED), Key("value", "vector", REQUIRED, unit="N/m³"))
        + SCHEDULE_KEYS,
        array=True,
    ),
    "force": Table(
        "force",
        (
            Key("boundary", "string", REQUIRED),
            Key("value", "vector", REQUIRED, unit="N"),
            Key("moment", "number or array", unit="N·m"),
            Key("point", "vector", unit="m", doc_default="centroid of the group"),
        )
        + SCHEDULE_KEYS,
        array=True,
    ),
}


@dataclass(frozen=True)
class InitialVelocitySpec:
    """One ``[[initial_velocity]]`` entry (used by dynamic analyses).

    Parameters
    ----------
    regions
        Cell physical groups.
    value
        Velocity vector (m/s).
    """

    regions: tuple[str, ...]
    value: tuple[float, ...]


#: ``[[initial_velocity]]``.
INITIAL_VELOCITY_TABLE = Table(
    "initial_velocity",
    (Key("regions", "names", REQUIRED), Key("value", "vector", REQUIRED, unit="m/s")),
    array=True,
)


@dataclass(frozen=True)
class OutputSpec:
    """``[output]``.

    Parameters
    ----------
    directory
        Absolute results directory (a relative directory in the file is taken
        relative to the current working directory at load time).
    fields_every
        Write fields every this many steps; 0 writes the last step only.
    probes
        Points (reference configuration) sampled every step.
    checkpoint_every
        Write a restart checkpoint every this many steps (docs/checkpoint.md); 0: none
        (an interrupted run still writes one).
    checkpoint_time
        Also write one after the first step that reaches each multiple of this much
        simulated time (s); 0: none.
    """

    directory: Path = field(default_factory=lambda: Path.cwd() / "results")
    fields_every: int = 1
    probes: tuple[tuple[float, ...], ...] = ()
    checkpoint_every: int = 0
    checkpoint_time: float = 0.0

    @property
    def checkpoints(self) -> bool:
        """Whether periodic checkpoints are asked for (``checkpoint_every`` or
        ``checkpoint_time``)."""
        return self.checkpoint_every > 0 or self.checkpoint_time > 0


#: ``[output]``.
OUTPUT_TABLE = Table(
    "output",
    (
        Key("directory", "string", "results"),
        Key("fields_every", "integer", 1, minimum=0),
        Key("probes", "points", [], unit="m"),
        Key("checkpoint_every", "integer", 0, minimum=0),
        Key("checkpoint_time", "number", 0.0, unit="s", minimum=0),
    ),
)


@dataclass(frozen=True)
class CystSpec:
    """``[neoplasm.cyst]``: the osmotic/Maxwell cyst model (docs/theory/growth.md#cyst-model).

    Parameters
    ----------
    model
        ``"sphere"`` (closed ODE; a cylinder per unit length in 2D) or ``"shape"``
        (moving wall).
    parameters
        The validated model parameters (all other keys of the table).
    """

    model: Literal["sphere", "shape"]
    parameters: CystParameters


@dataclass(frozen=True)
class NeoplasmSpec:
    """``[neoplasm]``: a growing tumour or cyst.

    Parameters
    ----------
    kind
        ``"tumour"`` or ``"cyst"``.
    region
        Cell physical group holding the neoplasm at t = 0 (scenes with a mesh), else ``None``.
    host
        Cell groups it may grow into (may be empty; checked against the mesh).
    t_end, dt
        Growth time and step (s); the last step is shortened to end at ``t_end``.
    remesh_every
        Growth steps between remeshes (tumour), >= 0; 0 = never.
    mechanics_every
        Run the scene's ``[analysis]`` every N growth steps; 0 = only after growth.
    radius
        Extension: initial radius (m) of a meshless scene (disc in 2D, ball in 3D).
    h
        Extension: tumour mesh size (m); default ``radius / 8`` (meshless) or the mean
        boundary edge of ``region``.
    tumour
        ``[neoplasm.tumour]``: the validated tumour parameters when ``kind = "tumour"``,
        else ``None``.
    cyst
        ``[neoplasm.cyst]`` when ``kind = "cyst"``, else ``None``.
    """

    kind: Literal["tumour", "cyst"]
    t_end: float
    dt: float
    region: str | None = None
    host: tuple[str, ...] = ()
    remesh_every: int = 1
    mechanics_every: int = 0
    radius: float | None = None
    h: float | None = None
    tumour: TumourParameters | None = None
    cyst: CystSpec | None = None

    @property
    def n_steps(self) -> int:
        """Number of growth steps, ``ceil(t_end / dt)``."""
        return max(1, math.ceil(self.t_end / self.dt * (1.0 - 1e-12)))

    def times(self) -> npt.NDArray[np.float64]:
        """Times at the end of each growth step (``k dt``, the last one exactly ``t_end``)."""
        t = np.arange(1, self.n_steps + 1, dtype=np.float64) * self.dt
        t[-1] = self.t_end
        return t


#: ``[neoplasm]`` (docs/neoplasm_format.md); ``radius`` and ``h`` are an extension.
NEOPLASM_TABLE = Table(
    "neoplasm",
    (
        Key("kind", "string", REQUIRED, choices=NEOPLASM_KINDS),
        Key("region", "string", doc_default="required with a mesh; not allowed without"),
        Key("host", "names", []),
        Key("t_end", "number", REQUIRED, unit="s", minimum=0, exclusive=True),
        Key("dt", "number", REQUIRED, unit="s", minimum=0, exclusive=True),
        Key("remesh_every", "integer", 1, minimum=0),
        Key("mechanics_every", "integer", 0, minimum=0),
        Key(
            "radius",
            "number",
            unit="m",
            minimum=0,
            exclusive=True,
            doc_default="required without a mesh; not allowed with one",
        ),
        Key("h", "number", unit="m", minimum=0, exclusive=True, doc_default="tumour only"),
        Key("tumour", "table"),
        Key("cyst", "table"),
    ),
)

_TUMOUR_UNITS = {
    "D_c": "m²/s",
    "lambda": "1/s",
    "K_R": "1/s",
    "gamma": "m³/s",
    **{k: "1/s" for k in TumourParameters.RATES},
}

#: ``[neoplasm.tumour]``: the fields of TumourParameters (``lambda`` for ``lambda_``); the
#: rates ``K_B`` ... ``K_D`` are a number or an expression of ``u_c``.
TUMOUR_TABLE = Table(
    "neoplasm.tumour",
    tuple(
        Key(
            key,
            "number or expression" if name in TumourParameters.RATES else "number",
            getattr(TumourParameters(), name),
            unit=_TUMOUR_UNITS.get(key, ""),
        )
        for name, key in zip(
            (f.name for f in fields(TumourParameters)), TumourParameters.keys(), strict=True
        )
    ),
)

#: ``[neoplasm.cyst]``: the scene's ``model``, then the fields of CystParameters.
CYST_TABLE = Table(
    "neoplasm.cyst",
    (
        Key("model", "string", "sphere", choices=CYST_MODELS),
        Key("strain", "string", "log", choices=CystParameters.STRAINS),
        Key("beta", "number", REQUIRED, unit="mol m⁻² s⁻¹"),
        Key("C_minus", "number", REQUIRED, unit="mol/m³"),
        Key("temperature", "number", CystParameters.temperature, unit="K"),
        Key("E", "number", CystParameters.E, unit="Pa"),
        Key("viscosity", "number", CystParameters.viscosity, unit="Pa s"),
        Key("f0", "number", CystParameters.f0, unit="Pa"),
    ),
)


@dataclass(frozen=True)
class FractureSpec:
    """``[fracture]``: the initiation check, the direction method, propagation, and the
    automatic insertion of a crack where the risk reaches 1 (docs/theory/fracture.md).

    Parameters
    ----------
    criterion
        Initiation risk: ``"tension"`` or ``"tension_compression"``.
    direction
        Crack direction: ``"mts"`` or ``"principal"``.
    propagate
        Grow the cracks (2D).
    increment
        Δa (m), required with ``propagate``.
    max_increments
        Upper bound on the increments.
    tip_size, tip_grading
        Element size at the tips (m) and its growth per unit distance; ``None``: the
        defaults of the run (``tip_grading`` 0.25 at a 2D tip, 0.12 along a 3D front).
    initiate
        Insert a crack where the risk first reaches 1.
    initiation_length
        Length of the inserted crack (m); ``None``: the default of
        :func:`bonecontact.fracture.initiation.default_length`.
    coefficient
        Coulomb coefficient of the inserted crack's face pair (0: frictionless).
    joined
        What two 2D cracks do when a grown tip comes within the increment of another
        crack: ``"merge"`` (facing, nearly collinear tips: the cracks become one and grow
        on; :mod:`bonecontact.runners.crack_join`) or ``"stop"`` (the run stops
        ``joined``).
    breakthrough
        What a growing interior 3D crack does when its front reaches the body's surface:
        ``"stop"`` (``fractured``/``through``) or ``"surface_crack"`` (re-characterised
        as a semi-elliptical surface crack that keeps growing;
        :mod:`bonecontact.runners.breakthrough3d`).
    max_kink_deg
        The validity limit of a crack grown in its plane (a 3D surface crack): the
        largest |σ₁′ kink angle| (degrees, 0 < value ≤ 90) of a growing front point for
        which the planar model is taken as valid (:data:`DEFAULT_MAX_KINK_DEG`).
    stop_out_of_plane
        Stop the planar growth (status ``out_of_plane``) at the first increment where a
        growing point's |kink| exceeds ``max_kink_deg`` (else it is recorded and the run
        goes on).
    surface_growth
        How a growing 3D surface crack grows: ``"planar"`` (a semi-ellipse in its plane,
        three growth points; :mod:`bonecontact.runners.surface_crack3d`) or
        ``"nonplanar"`` (planar patches along its σ₁′ kink, an open front;
        :mod:`bonecontact.runners.nonplanar_surface3d`).
    """

    criterion: str = "tension"
    direction: str = "mts"
    propagate: bool = False
    increment: float | None = None
    max_increments: int = 10
    tip_size: float | None = None
    tip_grading: float | None = None
    initiate: bool = False
    initiation_length: float | None = None
    coefficient: float = 0.0
    fatigue: FatigueSpec | None = None
    joined: str = "merge"
    breakthrough: str = "stop"
    max_kink_deg: float = 15.0
    stop_out_of_plane: bool = False
    surface_growth: str = "planar"

    @property
    def grows(self) -> bool:
        """The crack grows: by K_Ic (``propagate``) or by cycles (``fatigue``)."""
        return self.propagate or self.fatigue is not None

    @property
    def growth_step(self) -> float | None:
        """Δa of propagation, Δa_max of fatigue (m); ``None`` without growth."""
        if self.fatigue is not None:
            return self.fatigue.da_max
        return self.increment if self.propagate else None


@dataclass(frozen=True)
class FatigueSpec:
    """``[fracture.fatigue]``: growth by blocks of load cycles under the Paris law
    da/dN = C ΔK^m (docs/theory/fracture.md#fatigue; the law:
    :func:`bonecontact.runners.crack_fatigue.paris_law`).

    Parameters
    ----------
    C, m
        Paris coefficient ((m/cycle)/(Pa·√m)^m) and exponent.
    da_max
        Growth of the fastest tip per block (m).
    delta_K_th
        Threshold ΔK (Pa·√m): no growth at or below it.
    R
        Load ratio K_min/K_max of the cycle (< 1).
    max_blocks
        Upper bound on the blocks.
    end_halvings
        A 3D surface crack on the planar path: when a block of ``da_max`` would carry the
        crack through, blocks of ``da_max``/2 … ``da_max``/2^n (n = ``end_halvings``), the
        longest that still fits, are solved first, so that the final, extrapolated block
        is at most ``da_max``/2^n (0: the final block is ``da_max``).
    """

    C: float
    m: float
    da_max: float
    delta_K_th: float = 0.0
    R: float = 0.0
    max_blocks: int = 100
    end_halvings: int = 0


@dataclass(frozen=True)
class CrackSpec:
    """One ``[[crack]]``: the crack, the cell group it lies in, the Coulomb coefficient of
    its face pair (0: frictionless) and, in 3D, the number of front points at which K is
    evaluated."""

    name: str
    crack: Crack2D | PlanarCrack
    region: str
    coefficient: float = 0.0
    front_points: int = 8

    def face_pair(self, name: str, slave: str, master: str) -> ContactSpec:
        """The contact pair of the crack's faces: frictionless, or Coulomb with
        :attr:`coefficient` and the fixed-point bound (so that a single static step is
        frictional; docs/theory/fracture.md)."""
        mu = float(self.coefficient)
        if mu > 0:
            return ContactSpec(name, slave, master, "coulomb", mu, 0.0, "fixed_point")
        return ContactSpec(name, slave, master, "none", mu, 0.0, "previous_step")


_COEFFICIENT = Key("coefficient", "number", 0.0, minimum=0)
#: The old name of the Coulomb coefficient in ``[fracture]`` and ``[[crack]]``.
_OLD_COEFFICIENT = {"friction": "coefficient"}

#: What a growing interior 3D crack does at the body's surface (``[fracture] breakthrough``).
BREAKTHROUGH_RULES = ("stop", "surface_crack")

#: The default ``[fracture] max_kink_deg`` (degrees): below it each advance of the planar
#: front misses the kinked branch's reach by under 1 − cos 15° = 3.4 %, within the front K's
#: accuracy (docs/theory/fracture.md#surface-cracks-in-a-scenes-body, "Validity of the
#: planar model").
DEFAULT_MAX_KINK_DEG = 15.0
#: The largest ``[fracture] max_kink_deg`` allowed (degrees).
MAX_KINK_LIMIT_DEG = 90.0

#: How a growing 3D surface crack grows (``[fracture] surface_growth``).
SURFACE_GROWTH_MODELS = ("planar", "nonplanar")

#: What two 2D cracks that meet do (``[fracture] joined``).
JOIN_RULES = ("merge", "stop")

#: ``[fracture]``.
FRACTURE_TABLE = Table(
    "fracture",
    (
        Key("criterion", "string", "tension", choices=RISK_CRITERIA),
        Key("direction", "string", "mts", choices=CRACK_DIRECTIONS),
        Key("propagate", "boolean", False),
        Key("increment", "number", unit="m", minimum=0, exclusive=True),
        Key("max_increments", "integer", 10, minimum=1),
        Key(
            "tip_size",
            "number",
            unit="m",
            minimum=0,
            exclusive=True,
            doc_default=(
                "Δa/8 with `propagate`, `da_max`/10 with fatigue, else 1/100 of the "
                "shortest tip segment (3D: b/10)"
            ),
        ),
        Key(
            "tip_grading",
            "number",
            minimum=0,
            exclusive=True,
            doc_default="`0.25` (3D: `0.12`)",
        ),
        Key("initiate", "boolean", False),
        Key(
            "initiation_length",
            "number",
            unit="m",
            minimum=0,
            exclusive=True,
            doc_default=(
                "Δa with `propagate` (`da_max` with fatigue), else four cells of the mesh "
                "at the risk maximum"
            ),
        ),
        _COEFFICIENT,
        Key("fatigue", "table"),
        Key("joined", "string", "merge", choices=JOIN_RULES),
        Key("breakthrough", "string", "stop", choices=BREAKTHROUGH_RULES),
        Key("max_kink_deg", "number", DEFAULT_MAX_KINK_DEG, unit="°", minimum=0, exclusive=True),
        Key("stop_out_of_plane", "boolean", False),
        Key("surface_growth", "string", "planar", choices=SURFACE_GROWTH_MODELS),
    ),
    renamed=_OLD_COEFFICIENT,
)

#: The most halvings of the block before a surface crack runs through (``end_halvings``).
MAX_END_HALVINGS = 8

#: ``[fracture.fatigue]``: the Paris law and the blocks of cycles.
FATIGUE_TABLE = Table(
    "fracture.fatigue",
    (
        Key("C", "number", REQUIRED, unit="(m/cycle)/(Pa·√m)^m", minimum=0, exclusive=True),
        Key("m", "number", REQUIRED, minimum=0, exclusive=True),
        Key("delta_K_th", "number", 0.0, unit="Pa·√m", minimum=0),
        Key("R", "number", 0.0),
        Key("da_max", "number", REQUIRED, unit="m", minimum=0, exclusive=True),
        Key("max_blocks", "integer", 100, minimum=1),
        Key("end_halvings", "integer", 0, minimum=0),
    ),
)

_CRACK_NAME = Key("name", "string", doc_default='`"crack<n>"`')

#: ``[[crack]]`` in a 2D scene: a polyline.
CRACK_TABLE = Table(
    "crack",
    (
        _CRACK_NAME,
        Key("points", "array", REQUIRED, unit="m"),
        Key("tips", "string", "both", choices=CRACK_TIPS),
        Key("region", "string", REQUIRED),
        _COEFFICIENT,
    ),
    array=True,
    renamed=_OLD_COEFFICIENT,
)

#: ``[[crack]]`` in a 3D scene: a planar disc, ellipse or convex polygon.
CRACK3D_TABLE = Table(
    "crack",
    (
        _CRACK_NAME,
        Key("shape", "string", "disc", choices=CRACK3D_SHAPES),
        Key("centre", "vector", unit="m", doc_default="required (not for a polygon)"),
        Key("normal", "vector", doc_default="required (polygon: optional)"),
        Key("radius", "number", unit="m", doc_default="required for a disc"),
        Key("semi_axes", "array", unit="m", doc_default="required for an ellipse"),
        Key(
            "axis",
            "vector",
            doc_default="required for an ellipse and a quarter_elliptical crack",
        ),
        Key("region", "string", REQUIRED),
        _COEFFICIENT,
        Key("front_points", "integer", 8, minimum=1, doc_default="`8` (polygon: `1`)"),
        Key("vertices", "points", unit="m", doc_default="required for a polygon"),
        Key(
            "depth",
            "number",
            unit="m",
            doc_default="required for a semi_elliptical and a quarter_elliptical crack",
        ),
        Key("half_length", "number", unit="m", doc_default="required for a semi_elliptical crack"),
        Key(
            "length",
            "number",
            unit="m",
            doc_default="required for a quarter_elliptical crack",
        ),
    ),
    array=True,
    renamed=_OLD_COEFFICIENT,
)


@dataclass(frozen=True)
class Scene:
    """A validated scene.

    Parameters
    ----------
    path
        Absolute path of the scene file.
    name
        Scene name (``[scene].name``, defaults to the file name without suffix).
    mesh_path
        Absolute path of the mesh (given relative to the scene file); ``None`` only in a
        meshless growth-only scene.
    dimension
        2 (plane strain) or 3.
    analysis, solver
        ``[analysis]`` (``None`` in a growth-only scene) and ``[solver]``.
    materials, contacts, dirichlet, initial_velocities
        The entries of the arrays of tables, in file order.
    loads
        Tractions, then pressures, then body forces, then forces, each in file order.
    output
        ``[output]``.
    raw
        The parsed TOML document, untouched.
    neoplasm
        ``[neoplasm]``, or ``None``.  A scene with ``[neoplasm]`` and no ``[analysis]``
        is a *growth-only* scene; with both it is a *coupled* scene (2D and 3D, run by
        :mod:`bonecontact.runners.coupled`).
    fracture, cracks
        ``[fracture]`` (``None``: no fracture check) and the ``[[crack]]`` entries
        (docs/theory/fracture.md#scene-tables).
    """

    path: Path
    name: str
    mesh_path: Path | None
    dimension: int
    analysis: Analysis | None
    solver: SolverOptions
    materials: tuple[MaterialSpec, ...]
    contacts: tuple[ContactSpec, ...]
    dirichlet: tuple[DirichletSpec, ...]
    loads: tuple[LoadSpec, ...]
    initial_velocities: tuple[InitialVelocitySpec, ...]
    output: OutputSpec
    raw: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)
    neoplasm: NeoplasmSpec | None = None
    fracture: FractureSpec | None = None
    cracks: tuple[CrackSpec, ...] = ()

    @property
    def growth_only(self) -> bool:
        """``[neoplasm]`` without ``[analysis]``: the growth runs alone (``growth.csv``)."""
        return self.neoplasm is not None and self.analysis is None

    @property
    def cell_regions(self) -> tuple[str, ...]:
        """All regions that have a material, in material order."""
        return tuple(r for m in self.materials for r in m.regions)

    def material_of(self, region: str) -> MaterialSpec:
        """The material of a cell region (``KeyError`` if none)."""
        for m in self.materials:
            if region in m.regions:
                return m
        raise KeyError(region)


#: Every table declaration, by the name the docs' tests and messages use.
TABLES: dict[str, Table] = {
    "top level": TOP_LEVEL,
    "scene": SCENE_TABLE,
    "analysis": ANALYSIS_TABLE,
    "solver": SOLVER_TABLE,
    "material": MATERIAL_TABLE,
    "contact": CONTACT_TABLE,
    "dirichlet": DIRICHLET_TABLE,
    **LOAD_TABLES,
    "initial_velocity": INITIAL_VELOCITY_TABLE,
    "output": OUTPUT_TABLE,
    "fracture": FRACTURE_TABLE,
    "fracture.fatigue": FATIGUE_TABLE,
    "crack": CRACK_TABLE,
    "crack (3D)": CRACK3D_TABLE,
    "neoplasm": NEOPLASM_TABLE,
    "neoplasm.tumour": TUMOUR_TABLE,
    "neoplasm.cyst": CYST_TABLE,
}
