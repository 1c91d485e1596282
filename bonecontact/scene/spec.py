"""Scene files (format 1): reading and validating them.

A *scene* is one TOML file describing a loaded part of the skeleton: the mesh,
the analysis (static, quasi-static or dynamic), the materials of the cell
regions, contact pairs, boundary conditions, loads and output.  The public
contract is ``SCENE_FORMAT.md``; ``docs/scene_format.md`` documents the format as
this module implements it.

This module is pure Python (TOML, NumPy and :mod:`bonecontact.materials.laws`); it
imports neither DOLFINx nor MPI.  Reading a scene is split in two steps:

* :func:`load_scene` reads the file and checks everything that does not need
  the mesh (keys, types, ranges, material constants, schedules, ...);
* :func:`check_against_mesh` checks the names of physical groups against the
  groups actually present in the mesh, once the mesh has been read.

Every problem is reported as a :class:`SceneError` naming the file, the table,
the key and what is allowed.  Units are SI (m, Pa, kg, s).
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from bonecontact.scene.expressions import ExpressionError, RateExpression, parse_rate
from bonecontact.materials.laws import (
    FORMULATIONS,
    Isotropic,
    Material,
    MaterialError,
    Orthotropic,
    TransverselyIsotropic,
)

__all__ = [
    "FORMAT_VERSION",
    "SceneError",
    "Schedule",
    "Analysis",
    "SolverOptions",
    "MaterialSpec",
    "ContactSpec",
    "DirichletSpec",
    "LoadSpec",
    "InitialVelocitySpec",
    "OutputSpec",
    "TumourSpec",
    "CystSpec",
    "NeoplasmSpec",
    "Scene",
    "load_scene",
    "check_against_mesh",
    "default_solver_options",
    "format_error",
]

#: The only scene format version this package reads.
FORMAT_VERSION = 1

ANALYSIS_KINDS = ("static", "quasistatic", "dynamic")
LINEAR_SOLVERS = ("direct", "iterative")
FRICTION_LAWS = ("none", "tresca", "coulomb")
COULOMB_UPDATES = ("previous_step", "fixed_point")
LOAD_KINDS = ("traction", "pressure", "body_force")

#: Engineering constants of each material model (all required).
MODEL_KEYS: dict[str, tuple[str, ...]] = {
    "isotropic": ("E", "nu"),
    "transversely_isotropic": ("E_p", "E_a", "nu_p", "nu_pa", "G_pa", "axis"),
    "orthotropic": ("E1", "E2", "E3", "nu12", "nu13", "nu23", "G12", "G13", "G23", "axes"),
}
#: Keys every ``[[material]]`` may carry besides the constants of its model.
MATERIAL_COMMON_KEYS = ("name", "regions", "model", "rho", "tau_v", "formulation")

TOP_LEVEL_KEYS = (
    "format", "scene", "analysis", "solver", "material", "contact", "dirichlet",
    "traction", "pressure", "body_force", "initial_velocity", "output", "neoplasm",
)
SCENE_KEYS = ("name", "mesh", "dimension")
ANALYSIS_KEYS = ("kind", "t_end", "dt", "load_steps")
SOLVER_KEYS = ("linear", "tolerance", "max_iterations")
CONTACT_KEYS = ("name", "slave", "master", "friction", "coefficient", "bound", "coulomb_update")
SCHEDULE_KEYS = ("ramp", "schedule")
DIRICHLET_KEYS = ("boundary", "value") + SCHEDULE_KEYS
TRACTION_KEYS = ("boundary", "value") + SCHEDULE_KEYS
PRESSURE_KEYS = ("boundary", "value") + SCHEDULE_KEYS
BODY_FORCE_KEYS = ("regions", "value") + SCHEDULE_KEYS
INITIAL_VELOCITY_KEYS = ("regions", "value")
OUTPUT_KEYS = ("directory", "fields_every", "probes")

#: Tables that later capabilities will add (rejected with a clearer message until then).
FUTURE_TABLES = ("fracture",)

NEOPLASM_KINDS = ("tumour", "cyst")
#: ``[neoplasm]`` keys; ``radius`` and ``h`` are an extension (initial geometry of meshless scenes).
NEOPLASM_KEYS = ("kind", "region", "host", "t_end", "dt", "remesh_every", "mechanics_every", "radius", "h",
                 "tumour", "cyst")
TUMOUR_KEYS = ("D_c", "lambda", "eps0", "u_c1", "K_B", "K_Q", "K_A", "K_P", "K_D", "K_R", "gamma", "u_p0",
               "u_q0")
#: Tumour rates that may be expressions of ``u_c``.
TUMOUR_RATE_KEYS = ("K_B", "K_Q", "K_A", "K_P", "K_D")
CYST_KEYS = ("model", "strain", "beta", "C_minus", "temperature", "E", "viscosity", "f0")
CYST_MODELS = ("sphere", "shape")
CYST_STRAINS = ("log", "engineering")
#: Tables of a mechanics analysis: not allowed in a growth-only scene.
MECHANICS_TABLES = ("solver", "material", "contact", "dirichlet", "traction", "pressure", "body_force",
                    "initial_velocity")


# --------------------------------------------------------------------------------------
# errors
# --------------------------------------------------------------------------------------
class SceneError(Exception):
    """An invalid scene: one clear message naming the file, the table and the key.

    Parameters
    ----------
    file
        The scene file (as given by the user), or ``None`` when unknown.
    table
        Where in the file, e.g. ``'[analysis]'`` or ``'[[material]] #2 "cortical"'``
        (``#n`` counts the entries of an array of tables from 1); ``None`` for the
        top level of the file or for errors that concern the file as a whole.
    key
        The offending key, or ``None``.
    message
        What is wrong and what is allowed.

    Examples
    --------
    >>> str(SceneError("scene.toml", '[[material]] #2 "cortical"', "nu",
    ...                "must satisfy -1 < nu < 0.5, got 0.5"))
    'scene.toml: [[material]] #2 "cortical", key "nu": must satisfy -1 < nu < 0.5, got 0.5'
    """

    def __init__(self, file: str | Path | None, table: str | None, key: str | None, message: str):
        file = None if file is None else str(file)
        super().__init__(file, table, key, message)
        self.file = file
        self.table = table
        self.key = key
        self.message = message

    def __str__(self) -> str:
        where = ", ".join(p for p in (self.table, None if self.key is None else f'key "{self.key}"') if p)
        text = f"{where}: {self.message}" if where else self.message
        return f"{self.file}: {text}" if self.file else text

    def with_file(self, file: str | Path) -> SceneError:
        """A copy of this error attributed to ``file``."""
        return SceneError(file, self.table, self.key, self.message)


def format_error(exc: BaseException) -> str:
    """One-line, user-facing description of an input error.

    Parameters
    ----------
    exc
        Typically a :class:`SceneError`; :class:`~bonecontact.materials.laws.MaterialError`
        and any other exception are formatted too.

    Returns
    -------
    str
        The message, prefixed with ``error: ``.
    """
    if isinstance(exc, SceneError):
        text = str(exc)
    elif isinstance(exc, MaterialError):
        text = f'key "{exc.key}": {exc.message}'
    else:
        text = f"{type(exc).__name__}: {exc}"
    return f"error: {text}"


def _describe(value: Any) -> str:
    """How a TOML value looks to the user, for messages."""
    if isinstance(value, bool):
        return f"boolean {str(value).lower()}"
    if isinstance(value, str):
        return f'string "{value}"'
    if isinstance(value, int):
        return f"integer {value}"
    if isinstance(value, float):
        return f"number {value!r}"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        n = len(value)
        return f"an array of {n} {'entry' if n == 1 else 'entries'}" if n else "an empty array"
    return f"{type(value).__name__} {value!r}"


def _choices(options: Iterable[str]) -> str:
    return ", ".join(f'"{o}"' for o in options)


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
            raise ValueError("a schedule needs at least one (time, factor) pair and as many factors as times")
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
        """``min(t / ramp, 1)`` for ``ramp > 0`` (0 before ``t = 0``); constant 1 for ``ramp == 0``."""
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
    """

    kind: Literal["static", "quasistatic", "dynamic"] = "static"
    t_end: float | None = None
    dt: float | None = None
    load_steps: int = 1

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


@dataclass(frozen=True)
class SolverOptions:
    """``[solver]``.

    Parameters
    ----------
    linear
        ``"direct"`` (MUMPS LU) or ``"iterative"`` (Krylov + GAMG).
    tolerance
        Stopping tolerance of the PDAS / nonlinear iterations (> 0).
    max_iterations
        Maximum number of PDAS / nonlinear iterations per step (>= 1).
    """

    linear: Literal["direct", "iterative"] = "direct"
    tolerance: float = 1e-10
    max_iterations: int = 50


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
    """

    name: str
    regions: tuple[str, ...]
    material: Material
    index: int


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
    """

    name: str
    slave: str
    master: str
    friction: Literal["none", "tresca", "coulomb"] = "none"
    coefficient: float = 0.0
    bound: float = 0.0
    coulomb_update: Literal["previous_step", "fixed_point"] = "previous_step"


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


@dataclass(frozen=True)
class LoadSpec:
    """One ``[[traction]]``, ``[[pressure]]`` or ``[[body_force]]`` entry.

    Parameters
    ----------
    kind
        ``"traction"``, ``"pressure"`` or ``"body_force"``.
    target
        ``(boundary,)`` for traction and pressure (a facet group), the cell
        regions for a body force.
    value
        Traction vector (Pa), scalar pressure (Pa, positive pushes into the
        body) or body-force vector (N/m³).
    schedule
        Time factor of ``value``.
    """

    kind: Literal["traction", "pressure", "body_force"]
    target: tuple[str, ...]
    value: tuple[float, ...] | float
    schedule: Schedule = field(default_factory=Schedule)


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
    """

    directory: Path = field(default_factory=lambda: Path.cwd() / "results")
    fields_every: int = 1
    probes: tuple[tuple[float, ...], ...] = ()


@dataclass(frozen=True)
class TumourSpec:
    """``[neoplasm.tumour]``: parameters of Problem P_T (SPEC §6.1), SI units.

    Parameters
    ----------
    D_c
        Nutrient diffusivity (m²/s), > 0.
    lambda_
        Nutrient consumption rate (1/s), > 0 (key ``lambda``).
    eps0
        Nutrient time-scale ratio, >= 0; 0 = quasi-steady nutrient.
    u_c1
        Nutrient concentration on the tumour boundary (reference units), >= 0.
    K_B, K_Q, K_A, K_P, K_D
        Birth, quiescence, apoptosis, proliferation-recovery and death rates (1/s):
        numbers or :class:`~bonecontact.scene.expressions.RateExpression` of ``u_c``.
    K_R
        Removal rate (1/s), a number.
    gamma
        Surface tension (m³/s: σ is the velocity potential in m²/s, σ = γκ), >= 0.
    u_p0, u_q0
        Initial uniform proliferating / quiescent fractions, >= 0, sum <= 1.
    """

    D_c: float = 1.0
    lambda_: float = 1.0
    eps0: float = 0.0
    u_c1: float = 1.0
    K_B: float | RateExpression = 1.0
    K_Q: float | RateExpression = 0.0
    K_A: float | RateExpression = 0.0
    K_P: float | RateExpression = 0.0
    K_D: float | RateExpression = 0.0
    K_R: float = 0.0
    gamma: float = 0.0
    u_p0: float = 1.0
    u_q0: float = 0.0

    def as_table(self) -> dict[str, Any]:
        """The parameters keyed as in the scene (``lambda``), for
        :meth:`bonecontact.neoplasm.tumour.TumourParameters.from_dict`."""
        return {("lambda" if k == "lambda_" else k): getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class CystSpec:
    """``[neoplasm.cyst]``: the osmotic/Maxwell cyst model (SPEC §6.2), SI units.

    Parameters
    ----------
    model
        ``"sphere"`` (closed ODE; a cylinder per unit length in 2D) or ``"shape"``
        (moving wall; parsed, not run yet).
    strain
        ``"log"`` or ``"engineering"``.
    beta
        Supply rate of osmotic material (mol m⁻² s⁻¹), >= 0.
    C_minus
        Osmolarity outside the cyst (mol/m³), > 0.
    temperature
        Absolute temperature (K), > 0.
    E
        Modulus of the surrounding tissue (Pa), > 0.
    viscosity
        Viscosity of the surrounding tissue (Pa s), > 0.
    f0
        Initial osmotic excess pressure P_h⁺ − P_h⁻ (Pa), > −R_g T C⁻ (so that C⁺ > 0).
    """

    beta: float
    C_minus: float
    model: Literal["sphere", "shape"] = "sphere"
    strain: Literal["log", "engineering"] = "log"
    temperature: float = 310.0
    E: float = 1.0e6
    viscosity: float = 1.0e9
    f0: float = 0.0

    def parameters(self) -> dict[str, Any]:
        """Keyword arguments of :class:`bonecontact.neoplasm.cyst.CystParameters`."""
        return {k: getattr(self, k) for k in ("beta", "C_minus", "temperature", "E", "viscosity", "f0", "strain")}


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
    tumour, cyst
        The parameters of the model named by ``kind`` (the other is ``None``).
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
    tumour: TumourSpec | None = None
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
        Tractions, then pressures, then body forces, each in file order.
    output
        ``[output]``.
    raw
        The parsed TOML document, untouched.
    neoplasm
        ``[neoplasm]``, or ``None``.  A scene with ``[neoplasm]`` and no ``[analysis]``
        is a *growth-only* scene; with both it is a *coupled* scene (2D only, run by
        :mod:`bonecontact.run.coupled`).
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


# --------------------------------------------------------------------------------------
# reading tables
# --------------------------------------------------------------------------------------
_MISSING = object()


class _Table:
    """A TOML table being validated, with the label used in messages."""

    def __init__(self, data: Mapping[str, Any], label: str | None):
        self.data = data
        self.label = label

    def error(self, key: str | None, message: str) -> SceneError:
        return SceneError(None, self.label, key, message)

    def check_keys(self, allowed: Sequence[str], what: str = "key") -> None:
        for key in self.data:
            if key in FUTURE_TABLES and self.label is None:
                raise self.error(key, f"[{key}] is not supported yet by this version of bonecontact")
            if key not in allowed:
                raise self.error(key, f"unknown {what}; allowed: {', '.join(allowed)}")

    def has(self, key: str) -> bool:
        return key in self.data

    def raw(self, key: str, required: bool, why: str = "") -> Any:
        if key in self.data:
            return self.data[key]
        if required:
            raise self.error(key, f"missing required key{why}")
        return _MISSING

    # scalars -----------------------------------------------------------------------
    def _as_number(self, key: str, value: Any, what: str = "") -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(key, f"{what}must be a number, got {_describe(value)}")
        x = float(value)
        if not math.isfinite(x):
            raise self.error(key, f"{what}must be a finite number, got {value!r}")
        return x

    def number(self, key: str, *, required: bool = False, default: float | None = None,
               positive: bool = False, nonnegative: bool = False, why: str = "") -> float | None:
        value = self.raw(key, required, why)
        if value is _MISSING:
            return default
        x = self._as_number(key, value)
        if positive and x <= 0.0:
            raise self.error(key, f"must be > 0, got {value!r}")
        if nonnegative and x < 0.0:
            raise self.error(key, f"must be >= 0, got {value!r}")
        return x

    def integer(self, key: str, *, required: bool = False, default: int | None = None,
                minimum: int | None = None, why: str = "") -> int | None:
        value = self.raw(key, required, why)
        if value is _MISSING:
            return default
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(key, f"must be an integer, got {_describe(value)}")
        if minimum is not None and value < minimum:
            raise self.error(key, f"must be an integer >= {minimum}, got {value}")
        return value

    def string(self, key: str, *, required: bool = False, default: str | None = None,
               choices: Sequence[str] | None = None) -> str | None:
        value = self.raw(key, required, f"; allowed values: {_choices(choices)}" if choices else "")
        if value is _MISSING:
            return default
        if not isinstance(value, str):
            allowed = f" (one of {_choices(choices)})" if choices else ""
            raise self.error(key, f"must be a string{allowed}, got {_describe(value)}")
        if choices is not None and value not in choices:
            raise self.error(key, f"must be one of {_choices(choices)}, got \"{value}\"")
        if choices is None and not value.strip():
            raise self.error(key, "must be a non-empty string")
        return value

    def names(self, key: str, *, required: bool = True) -> tuple[str, ...]:
        """A non-empty array of distinct physical-group names."""
        value = self.raw(key, required)
        if value is _MISSING:
            return ()
        if not isinstance(value, list):
            hint = f' (write {key} = ["{value}"])' if isinstance(value, str) else ""
            raise self.error(key, f"must be an array of physical-group names{hint}, got {_describe(value)}")
        if not value:
            raise self.error(key, "must name at least one physical group")
        for v in value:
            if not isinstance(v, str) or not v.strip():
                raise self.error(key, f"must contain physical-group names (non-empty strings), got {_describe(v)}")
        seen: set[str] = set()
        for v in value:
            if v in seen:
                raise self.error(key, f'physical group "{v}" is listed twice')
            seen.add(v)
        return tuple(value)

    def vector(self, key: str, dim: int, *, required: bool = True, value: Any = _MISSING,
               what: str = "") -> tuple[float, ...]:
        if value is _MISSING:
            value = self.raw(key, required)
        if not isinstance(value, list):
            raise self.error(key, f"{what}must be an array of {dim} numbers (one per component), "
                                  f"got {_describe(value)}")
        if len(value) != dim:
            raise self.error(key, f"{what}must have {dim} components (dimension = {dim}), got {len(value)}")
        return tuple(self._as_number(key, v, what) for v in value)

    def schedule(self) -> Schedule | None:
        """The ``ramp`` / ``schedule`` keys; ``None`` when neither is given (or ``ramp = 0``)."""
        ramp = self.number("ramp", nonnegative=True)
        pairs = self.raw("schedule", False)
        if pairs is _MISSING:
            # ramp = 0 is the documented default: the same as no ramp at all
            return None if not ramp else Schedule.from_ramp(ramp)
        if ramp is not None and ramp > 0.0:
            raise self.error("schedule", "give either ramp > 0 or schedule, not both")
        example = "e.g. [[0.0, 0.0], [1.0, 1.0]]"
        if not isinstance(pairs, list) or not pairs:
            raise self.error("schedule", f"must be a non-empty array of [time, factor] pairs ({example}), "
                                         f"got {_describe(pairs)}")
        times: list[float] = []
        factors: list[float] = []
        for i, p in enumerate(pairs, start=1):
            if not isinstance(p, list) or len(p) != 2:
                raise self.error("schedule", f"entry {i} must be a [time, factor] pair ({example}), "
                                             f"got {_describe(p)}")
            times.append(self._as_number("schedule", p[0], f"entry {i}: time "))
            factors.append(self._as_number("schedule", p[1], f"entry {i}: factor "))
        for i in range(1, len(times)):
            if times[i] <= times[i - 1]:
                raise self.error("schedule", f"times must be strictly increasing, but entry {i + 1} "
                                             f"has time {times[i]!r} after {times[i - 1]!r}")
        return Schedule(tuple(times), tuple(factors))


def _table(doc: Mapping[str, Any], name: str, required: bool) -> _Table | None:
    label = f"[{name}]"
    if name not in doc:
        if required:
            raise SceneError(None, label, None, "missing required table")
        return None
    value = doc[name]
    if not isinstance(value, dict):
        raise SceneError(None, None, name, f"must be a table [{name}], got {_describe(value)}")
    return _Table(value, label)


def _array_of_tables(doc: Mapping[str, Any], name: str) -> list[dict[str, Any]]:
    if name not in doc:
        return []
    value = doc[name]
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise SceneError(None, None, name,
                         f"must be an array of tables (write each entry under [[{name}]]), got {_describe(value)}")
    return value


def _label(name: str, i: int, entry_name: Any = None) -> str:
    label = f"[[{name}]] #{i + 1}"
    if isinstance(entry_name, str) and entry_name:
        label += f' "{entry_name}"'
    return label


# --------------------------------------------------------------------------------------
# sections
# --------------------------------------------------------------------------------------
def _read_analysis(doc: Mapping[str, Any]) -> Analysis:
    tab = _table(doc, "analysis", required=True)
    assert tab is not None
    tab.check_keys(ANALYSIS_KEYS)
    kind = tab.string("kind", required=True, choices=ANALYSIS_KINDS)
    timed = kind in ("quasistatic", "dynamic")
    why = f' (required when kind = "{kind}")'
    t_end = tab.number("t_end", required=timed, positive=True, why=why)
    dt = tab.number("dt", required=timed, positive=True, why=why)
    if timed and dt is not None and t_end is not None and dt > t_end * (1.0 + 1e-12):
        raise tab.error("dt", f"must be <= t_end = {t_end!r}, got {dt!r}")
    load_steps = tab.integer("load_steps", default=1, minimum=1)
    assert load_steps is not None
    return Analysis(kind=kind, t_end=t_end, dt=dt, load_steps=load_steps)  # type: ignore[arg-type]


def _read_solver(doc: Mapping[str, Any]) -> SolverOptions:
    defaults = default_solver_options()
    tab = _table(doc, "solver", required=False)
    if tab is None:
        return defaults
    tab.check_keys(SOLVER_KEYS)
    return SolverOptions(
        linear=tab.string("linear", default=defaults.linear, choices=LINEAR_SOLVERS),  # type: ignore[arg-type]
        tolerance=tab.number("tolerance", default=defaults.tolerance, positive=True),  # type: ignore[arg-type]
        max_iterations=tab.integer("max_iterations", default=defaults.max_iterations, minimum=1),  # type: ignore[arg-type]
    )


def _read_material(entry: dict[str, Any], i: int, dim: int, dynamic: bool) -> MaterialSpec:
    tab = _Table(entry, _label("material", i, entry.get("name")))
    name = tab.string("name", required=True)
    assert name is not None
    model = tab.string("model", required=True, choices=tuple(MODEL_KEYS))
    assert model is not None
    constants = MODEL_KEYS[model]
    tab.check_keys(MATERIAL_COMMON_KEYS + constants)
    regions = tab.names("regions")

    kwargs: dict[str, Any] = {}
    for key in constants:
        if key == "axis":
            kwargs[key] = tab.vector(key, dim)
        elif key == "axes":
            rows = tab.raw(key, True)
            if not isinstance(rows, list) or len(rows) != dim:
                raise tab.error(key, f"must be {dim} material axes (dimension = {dim}), one row of {dim} "
                                     f"numbers each, got {_describe(rows)}")
            kwargs[key] = tuple(tab.vector(key, dim, value=r, what=f"row {k + 1} ")
                                for k, r in enumerate(rows))
        else:
            kwargs[key] = tab.number(key, required=True)
    if model == "transversely_isotropic" and not (-1.0 < kwargs["nu_p"] < 1.0):
        raise tab.error("nu_p", f"must satisfy -1 < nu_p < 1, got {kwargs['nu_p']!r}")

    rho = tab.number("rho", required=dynamic, why=' (density in kg/m³, required when [analysis] kind = "dynamic")')
    tau_v = tab.number("tau_v", default=0.0)
    formulation = tab.string("formulation", default="displacement", choices=FORMULATIONS)
    cls = {"isotropic": Isotropic, "transversely_isotropic": TransverselyIsotropic,
           "orthotropic": Orthotropic}[model]
    try:
        material = cls(rho=rho, tau_v=tau_v, formulation=formulation, **kwargs)
    except MaterialError as exc:
        raise tab.error(exc.key, exc.message) from None
    except (ArithmeticError, np.linalg.LinAlgError) as exc:
        key = {"isotropic": "nu", "transversely_isotropic": "nu_pa", "orthotropic": "nu12"}[model]
        raise tab.error(key, f"engineering constants give a singular compliance ({exc})") from None
    return MaterialSpec(name=name, regions=regions, material=material, index=i)


def _read_materials(doc: Mapping[str, Any], dim: int, dynamic: bool) -> tuple[MaterialSpec, ...]:
    entries = _array_of_tables(doc, "material")
    if not entries:
        raise SceneError(None, "[[material]]", None, "at least one material is required")
    specs: list[MaterialSpec] = []
    names: dict[str, int] = {}
    owner: dict[str, str] = {}
    for i, entry in enumerate(entries):
        spec = _read_material(entry, i, dim, dynamic)
        label = _label("material", i, spec.name)
        if spec.name in names:
            raise SceneError(None, label, "name",
                             f'material name "{spec.name}" is already used by [[material]] #{names[spec.name] + 1}')
        names[spec.name] = i
        for region in spec.regions:
            if region in owner:
                raise SceneError(None, label, "regions",
                                 f'region "{region}" is already claimed by material "{owner[region]}"; '
                                 "a region has exactly one material")
            owner[region] = spec.name
        specs.append(spec)
    return tuple(specs)


def _read_contacts(doc: Mapping[str, Any], allow_contact: bool,
                   allow_friction: bool = False) -> tuple[ContactSpec, ...]:
    entries = _array_of_tables(doc, "contact")
    if entries and not allow_contact:
        raise SceneError(None, "[[contact]]", None, "contact is not supported yet")
    specs: list[ContactSpec] = []
    names: dict[str, int] = {}
    for i, entry in enumerate(entries):
        tab = _Table(entry, _label("contact", i, entry.get("name")))
        tab.check_keys(CONTACT_KEYS)
        name = tab.string("name", required=True)
        assert name is not None
        if not all(c.isalnum() or c in "_-." for c in name):
            raise tab.error("name", f'must contain only letters, digits, "_", "-" and "." '
                                    f'(it names output files), got "{name}"')
        if name in names:
            raise tab.error("name", f'contact name "{name}" is already used by [[contact]] #{names[name] + 1}')
        names[name] = i
        slave = tab.string("slave", required=True)
        master = tab.string("master", required=True)
        if slave == master:
            raise tab.error("master", f'must differ from slave, both are "{slave}"')
        friction = tab.string("friction", default="none", choices=FRICTION_LAWS)
        specs.append(ContactSpec(
            name=name, slave=slave, master=master,  # type: ignore[arg-type]
            friction=friction,  # type: ignore[arg-type]
            coefficient=tab.number("coefficient", default=0.0, nonnegative=True),  # type: ignore[arg-type]
            bound=tab.number("bound", default=0.0, nonnegative=True),  # type: ignore[arg-type]
            coulomb_update=tab.string("coulomb_update", default="previous_step",  # type: ignore[arg-type]
                                      choices=COULOMB_UPDATES),
        ))
        if friction != "none" and not allow_friction:
            raise tab.error("friction", f'"{friction}" friction is not supported yet by this version of '
                                        'bonecontact; allowed for now: "none"')
        # a non-default value of another friction law's key is an error, not silently ignored
        spec = specs[-1]
        if spec.coefficient > 0 and friction != "coulomb":
            raise tab.error("coefficient", f'is the Coulomb coefficient, but this pair has friction = "{friction}" '
                                           '(use friction = "coulomb", or "bound" for Tresca)')
        if spec.bound > 0 and friction != "tresca":
            raise tab.error("bound", f'is the Tresca bound (Pa), but this pair has friction = "{friction}" '
                                     '(use friction = "tresca", or "coefficient" for Coulomb)')
        if spec.coulomb_update != "previous_step" and friction != "coulomb":
            raise tab.error("coulomb_update", f'applies to Coulomb friction only, but this pair has '
                                              f'friction = "{friction}"')
    return tuple(specs)


def _default_schedule(static: bool) -> Schedule:
    # static: loads grow linearly with the pseudo-time over the load steps
    return Schedule.from_ramp(1.0) if static else Schedule()


def _read_dirichlet(doc: Mapping[str, Any], dim: int, static: bool) -> tuple[DirichletSpec, ...]:
    specs: list[DirichletSpec] = []
    for i, entry in enumerate(_array_of_tables(doc, "dirichlet")):
        tab = _Table(entry, _label("dirichlet", i))
        tab.check_keys(DIRICHLET_KEYS)
        boundary = tab.string("boundary", required=True)
        assert boundary is not None
        raw = tab.raw("value", True)
        if not isinstance(raw, list) or len(raw) != dim:
            got = f"{len(raw)} entries" if isinstance(raw, list) else _describe(raw)
            raise tab.error("value", f'must be an array of {dim} entries (dimension = {dim}), each a number or '
                                     f'"free", got {got}')
        value: list[float | None] = []
        for k, v in enumerate(raw, start=1):
            if isinstance(v, str):
                if v != "free":
                    raise tab.error("value", f'component {k}: the only string allowed is "free", got "{v}"')
                value.append(None)
            elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise tab.error("value", f'component {k} must be a finite number or "free", got {_describe(v)}')
            else:
                value.append(float(v))
        if all(v is None for v in value):
            raise tab.error("value", 'all components are "free"; fix at least one component')
        sched = tab.schedule() or _default_schedule(static)
        specs.append(DirichletSpec(boundary=boundary, value=tuple(value), schedule=sched))
    return tuple(specs)


def _read_loads(doc: Mapping[str, Any], dim: int, static: bool) -> tuple[LoadSpec, ...]:
    specs: list[LoadSpec] = []
    for kind, keys in (("traction", TRACTION_KEYS), ("pressure", PRESSURE_KEYS),
                       ("body_force", BODY_FORCE_KEYS)):
        for i, entry in enumerate(_array_of_tables(doc, kind)):
            tab = _Table(entry, _label(kind, i))
            tab.check_keys(keys)
            target: tuple[str, ...]
            value: tuple[float, ...] | float
            if kind == "body_force":
                target = tab.names("regions")
                value = tab.vector("value", dim)
            else:
                boundary = tab.string("boundary", required=True)
                assert boundary is not None
                target = (boundary,)
                if kind == "pressure":
                    raw = tab.raw("value", True)
                    if isinstance(raw, list):
                        raise tab.error("value", "must be a single number (normal pressure in Pa), got an array")
                    value = tab._as_number("value", raw)
                else:
                    value = tab.vector("value", dim)
            sched = tab.schedule() or _default_schedule(static)
            specs.append(LoadSpec(kind=kind, target=target, value=value, schedule=sched))  # type: ignore[arg-type]
    return tuple(specs)


def _read_initial_velocities(doc: Mapping[str, Any], dim: int) -> tuple[InitialVelocitySpec, ...]:
    specs: list[InitialVelocitySpec] = []
    owner: dict[str, int] = {}
    for i, entry in enumerate(_array_of_tables(doc, "initial_velocity")):
        tab = _Table(entry, _label("initial_velocity", i))
        tab.check_keys(INITIAL_VELOCITY_KEYS)
        regions = tab.names("regions")
        for r in regions:
            if r in owner:
                raise tab.error("regions", f'region "{r}" already has an initial velocity '
                                           f"([[initial_velocity]] #{owner[r] + 1})")
            owner[r] = i
        specs.append(InitialVelocitySpec(regions=regions, value=tab.vector("value", dim)))
    return tuple(specs)


def _read_output(doc: Mapping[str, Any], dim: int) -> OutputSpec:
    tab = _table(doc, "output", required=False) or _Table({}, "[output]")
    tab.check_keys(OUTPUT_KEYS)
    directory = Path(tab.string("directory", default="results"))  # type: ignore[arg-type]
    if not directory.is_absolute():
        directory = Path.cwd() / directory
    fields_every = tab.integer("fields_every", default=1, minimum=0)
    raw = tab.raw("probes", False)
    probes: tuple[tuple[float, ...], ...] = ()
    if raw is not _MISSING:
        example = "[[x, y]]" if dim == 2 else "[[x, y, z]]"
        if not isinstance(raw, list) or any(not isinstance(p, list) for p in raw):
            raise tab.error("probes", f"must be an array of points, e.g. {example}, got {_describe(raw)}")
        probes = tuple(tab.vector("probes", dim, value=p, what=f"point {k + 1} ") for k, p in enumerate(raw))
    return OutputSpec(directory=directory, fields_every=fields_every, probes=probes)  # type: ignore[arg-type]


def _sub_table(tab: _Table, key: str) -> _Table | None:
    """``[neoplasm.<key>]`` as a table, or ``None`` when absent."""
    if not tab.has(key):
        return None
    value = tab.data[key]
    if not isinstance(value, dict):
        raise tab.error(key, f"must be a table [neoplasm.{key}], got {_describe(value)}")
    return _Table(value, f"[neoplasm.{key}]")


def _read_rate(tab: _Table, key: str, default: float, u_c1: float) -> float | RateExpression:
    """A tumour rate: a number, or an expression string of ``u_c`` (checked at ``u_c = u_c1``)."""
    value = tab.raw(key, False)
    if value is _MISSING:
        return default
    if isinstance(value, str):
        try:
            expr = parse_rate(value)
            probe = expr(u_c1)
        except ExpressionError as exc:
            raise tab.error(key, f"invalid expression of u_c: {exc}") from None
        except (ArithmeticError, ValueError) as exc:
            raise tab.error(key, f'expression "{value}" cannot be evaluated at u_c = u_c1 = {u_c1!r} '
                                 f"({exc})") from None
        if not math.isfinite(probe):
            raise tab.error(key, f'expression "{value}" is not finite at u_c = u_c1 = {u_c1!r}')
        return expr
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise tab.error(key, f'must be a number (1/s) or an expression string of u_c such as '
                             f'"2.0*(u_c - 0.7)", got {_describe(value)}')
    return tab._as_number(key, value)


def _read_tumour(tab: _Table) -> TumourSpec:
    tab.check_keys(TUMOUR_KEYS)
    d = TumourSpec()
    D_c = tab.number("D_c", default=d.D_c, positive=True)
    lam = tab.number("lambda", default=d.lambda_, positive=True)
    eps0 = tab.number("eps0", default=d.eps0, nonnegative=True)
    u_c1 = tab.number("u_c1", default=d.u_c1, nonnegative=True)
    assert u_c1 is not None
    rates = {k: _read_rate(tab, k, getattr(d, k), u_c1) for k in TUMOUR_RATE_KEYS}
    K_R = tab.number("K_R", default=d.K_R)
    gamma = tab.number("gamma", default=d.gamma, nonnegative=True)
    u_p0 = tab.number("u_p0", default=d.u_p0, nonnegative=True)
    u_q0 = tab.number("u_q0", default=d.u_q0, nonnegative=True)
    assert u_p0 is not None and u_q0 is not None
    if u_p0 > 1.0:
        raise tab.error("u_p0", f"must satisfy 0 <= u_p0 <= 1, got {u_p0!r}")
    if u_p0 + u_q0 > 1.0 + 1e-14:
        raise tab.error("u_q0", f"must satisfy u_p0 + u_q0 <= 1 (volume fractions), got "
                                f"u_p0 = {u_p0!r}, u_q0 = {u_q0!r}")
    return TumourSpec(D_c=D_c, lambda_=lam, eps0=eps0, u_c1=u_c1, K_R=K_R, gamma=gamma,  # type: ignore[arg-type]
                      u_p0=u_p0, u_q0=u_q0, **rates)


def _read_cyst(tab: _Table) -> CystSpec:
    tab.check_keys(CYST_KEYS)
    model = tab.string("model", default="sphere", choices=CYST_MODELS)
    strain = tab.string("strain", default="log", choices=CYST_STRAINS)
    beta = tab.number("beta", required=True, nonnegative=True, why=" (osmotic supply rate, mol m-2 s-1)")
    C_minus = tab.number("C_minus", required=True, positive=True, why=" (outside osmolarity, mol/m3)")
    temperature = tab.number("temperature", default=310.0, positive=True)
    E = tab.number("E", default=1.0e6, positive=True)
    viscosity = tab.number("viscosity", default=1.0e9, positive=True)
    f0 = tab.number("f0", default=0.0)
    assert temperature is not None and C_minus is not None and f0 is not None
    r_gas = 8.314462618  # J mol-1 K-1, as bonecontact.neoplasm.cyst.R_GAS
    if f0 <= -r_gas * temperature * C_minus:
        raise tab.error("f0", f"must be > -R_g T C_minus = {-r_gas * temperature * C_minus:.6g} Pa "
                              f"(the osmolarity inside the cyst must stay positive), got {f0!r}")
    return CystSpec(beta=beta, C_minus=C_minus, model=model, strain=strain,  # type: ignore[arg-type]
                    temperature=temperature, E=E, viscosity=viscosity, f0=f0)  # type: ignore[arg-type]


def _read_neoplasm(doc: Mapping[str, Any], has_mesh: bool, has_analysis: bool) -> NeoplasmSpec | None:
    """``[neoplasm]`` and its sub-table (SCENE_FORMAT additions of issue #5)."""
    tab = _table(doc, "neoplasm", required=False)
    if tab is None:
        return None
    tab.check_keys(NEOPLASM_KEYS)
    kind = tab.string("kind", required=True, choices=NEOPLASM_KINDS)
    assert kind is not None
    # initial geometry: a cell group of the mesh, or (extension) radius + h without a mesh
    if has_mesh:
        if not tab.has("region"):
            raise tab.error("region", "missing required key (the cell group of the mesh holding the "
                                      "neoplasm at t = 0)")
        region = tab.string("region", required=True)
        if tab.has("radius"):
            raise tab.error("radius", "is only for scenes without a mesh; with a mesh the initial "
                                      'neoplasm is the cell group named by "region"')
    else:
        if tab.has("region"):
            raise tab.error("region", "names a cell group of the mesh, but [scene] has no mesh; "
                                      "give the initial size with radius = ... (m) instead")
        region = None
    radius = tab.number("radius", required=not has_mesh, positive=True,
                        why=" (initial radius in m of a scene without a mesh: a disc in 2D, a ball in 3D)")
    h = tab.number("h", positive=True)
    if h is not None and kind == "cyst":
        raise tab.error("h", 'is the tumour mesh size; the cyst model "sphere" has no mesh')
    raw_host = tab.raw("host", False)
    host: tuple[str, ...] = ()
    if raw_host is not _MISSING:
        if isinstance(raw_host, list) and not raw_host:
            host = ()
        else:
            host = tab.names("host")
        if host and not has_mesh:
            raise tab.error("host", "names cell groups of the mesh, but [scene] has no mesh; "
                                    "write host = [] or leave it out")
        if region is not None and region in host:
            raise tab.error("host", f'must not contain the neoplasm region "{region}" itself')
    t_end = tab.number("t_end", required=True, positive=True, why=" (growth time, s)")
    dt = tab.number("dt", required=True, positive=True, why=" (growth step, s)")
    assert t_end is not None and dt is not None
    if dt > t_end * (1.0 + 1e-12):
        raise tab.error("dt", f"must be <= t_end = {t_end!r}, got {dt!r}")
    remesh_every = tab.integer("remesh_every", default=1, minimum=0)
    mechanics_every = tab.integer("mechanics_every", default=0, minimum=0)
    assert mechanics_every is not None
    if mechanics_every > 0 and not has_analysis:
        raise tab.error("mechanics_every", f"is {mechanics_every} but the scene has no [analysis] to run; "
                                           "a growth-only scene needs mechanics_every = 0")
    tumour_tab, cyst_tab = _sub_table(tab, "tumour"), _sub_table(tab, "cyst")
    other = cyst_tab if kind == "tumour" else tumour_tab
    if other is not None:
        raise tab.error("tumour" if kind == "cyst" else "cyst",
                        f'[neoplasm.{"tumour" if kind == "cyst" else "cyst"}] is given but kind = "{kind}"; '
                        f'write the parameters under [neoplasm.{kind}]')
    tumour = cyst = None
    if kind == "tumour":
        tumour = _read_tumour(tumour_tab or _Table({}, "[neoplasm.tumour]"))
    else:
        if cyst_tab is None:
            raise SceneError(None, "[neoplasm.cyst]", None,
                             'missing required table (kind = "cyst" needs at least beta and C_minus)')
        cyst = _read_cyst(cyst_tab)
    return NeoplasmSpec(kind=kind, t_end=t_end, dt=dt, region=region, host=host,  # type: ignore[arg-type]
                        remesh_every=remesh_every, mechanics_every=mechanics_every,  # type: ignore[arg-type]
                        radius=radius, h=h, tumour=tumour, cyst=cyst)


def _reject_mechanics_tables(doc: Mapping[str, Any]) -> None:
    """A growth-only scene has no mechanics: its tables would be silently unused."""
    for name in MECHANICS_TABLES:
        if name in doc:
            label = f"[{name}]" if name == "solver" else f"[[{name}]]"
            raise SceneError(None, label, None,
                             "belongs to a mechanics analysis, but this growth-only scene ([neoplasm] "
                             "without [analysis]) has none; remove it")
    out = doc.get("output")
    if isinstance(out, dict) and "probes" in out:
        raise SceneError(None, "[output]", "probes", "probes sample the mechanics fields; a growth-only "
                                                     "scene writes growth.csv only, remove probes")


def _read_document(doc: dict[str, Any], path: Path, allow_contact: bool, allow_friction: bool = False) -> Scene:
    # format first: a different version may have different tables
    top = _Table(doc, None)
    fmt = top.raw("format", True, f" (write format = {FORMAT_VERSION} at the top of the file)")
    if isinstance(fmt, bool) or not isinstance(fmt, int):
        raise top.error("format", f"must be the integer {FORMAT_VERSION}, got {_describe(fmt)}")
    if fmt != FORMAT_VERSION:
        raise top.error("format", f"unsupported scene format {fmt}; this package reads format {FORMAT_VERSION}")
    top.check_keys(TOP_LEVEL_KEYS, what="top-level key or table")

    has_neoplasm = "neoplasm" in doc
    scene_tab = _table(doc, "scene", required=True)
    assert scene_tab is not None
    scene_tab.check_keys(SCENE_KEYS)
    name = scene_tab.string("name", default=path.stem)
    # a growth-only scene may be meshless ([neoplasm] radius = ...)
    mesh = scene_tab.string("mesh", required=not has_neoplasm)  # path of the gmsh .msh file
    assert name is not None
    dim = scene_tab.integer("dimension", required=True, why=" (2 for plane strain or 3)")
    if dim not in (2, 3):
        raise scene_tab.error("dimension", f"must be 2 (plane strain) or 3, got {dim}")
    mesh_path: Path | None = None
    if mesh is not None:
        mesh_path = Path(mesh)
        if not mesh_path.is_absolute():
            mesh_path = path.parent / mesh_path
        mesh_path = mesh_path.resolve()
        if not mesh_path.is_file():
            raise scene_tab.error("mesh", f'mesh file "{mesh}" not found (looked for {mesh_path})')

    if has_neoplasm and "analysis" not in doc:  # growth-only scene
        _reject_mechanics_tables(doc)
        neoplasm = _read_neoplasm(doc, mesh_path is not None, has_analysis=False)
        output = _read_output(doc, dim)
        return Scene(path=path, name=name, mesh_path=mesh_path, dimension=dim, analysis=None,
                     solver=default_solver_options(), materials=(), contacts=(), dirichlet=(), loads=(),
                     initial_velocities=(), output=output, raw=doc, neoplasm=neoplasm)
    analysis = _read_analysis(doc)
    if mesh_path is None:
        raise scene_tab.error("mesh", "missing required key (a scene with an [analysis] needs a mesh)")
    static = analysis.kind == "static"
    solver = _read_solver(doc)
    materials = _read_materials(doc, dim, analysis.kind == "dynamic")
    contacts = _read_contacts(doc, allow_contact, allow_friction)
    dirichlet = _read_dirichlet(doc, dim, static)
    loads = _read_loads(doc, dim, static)
    initial_velocities = _read_initial_velocities(doc, dim)
    output = _read_output(doc, dim)
    neoplasm = _read_neoplasm(doc, True, has_analysis=True)
    # growth coupled to the loaded bone (bonecontact.run.coupled, docs/neoplasm_format.md): 2D only for now
    if neoplasm is not None and dim != 2:
        raise SceneError(None, "[neoplasm]", None,
                         "growth together with an [analysis] (the neoplasm coupled to the loaded bone) is "
                         "supported in 2D only by this version of bonecontact; in 3D run the growth alone "
                         "(a scene with [neoplasm] and without [analysis], [[material]] and loads)")
    return Scene(path=path, name=name, mesh_path=mesh_path, dimension=dim, analysis=analysis,
                 solver=solver, materials=materials, contacts=contacts, dirichlet=dirichlet,
                 loads=loads, initial_velocities=initial_velocities, output=output, raw=doc,
                 neoplasm=neoplasm)


def load_scene(path: str | Path, *, allow_contact: bool = True, allow_friction: bool = True) -> Scene:
    """Read and validate a scene file (everything that does not need the mesh).

    Parameters
    ----------
    path
        The scene file (TOML, format 1).
    allow_contact
        Accept ``[[contact]]`` tables (default); ``False`` rejects them.
    allow_friction
        Accept ``friction = "tresca"`` / ``"coulomb"``.  Until friction is implemented
        the default rejects them with "not supported yet" (frictionless contact is
        supported).

    Returns
    -------
    Scene
        The validated scene.  In a static analysis an entry without ``ramp`` (or
        with ``ramp = 0``) and without ``schedule`` gets the schedule ``ramp = 1`` (the load grows linearly over
        the load steps, whose pseudo-time runs from 0 to 1); otherwise the
        default schedule is the constant 1.

    Raises
    ------
    SceneError
        The file cannot be read, is not valid TOML, or breaks a rule of the
        format.  The error names the file, the table and the key.
    """
    shown = str(path)
    p = Path(path).absolute()
    try:
        with open(p, "rb") as fh:
            doc = tomllib.load(fh)
    except OSError as exc:
        raise SceneError(shown, None, None, f"cannot read the scene file: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(shown, None, None, f"invalid TOML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise SceneError(shown, None, None, f"invalid TOML: the file is not UTF-8 ({exc.reason})") from None
    try:
        return _read_document(doc, p, allow_contact, allow_friction)
    except SceneError as exc:
        raise exc.with_file(shown) from None


# --------------------------------------------------------------------------------------
# checks against the mesh
# --------------------------------------------------------------------------------------
def check_against_mesh(scene: Scene, groups: Mapping[str, tuple[int, int]], tdim: int, gdim: int) -> None:
    """Check the scene's physical-group names against the mesh.

    Parameters
    ----------
    scene
        A scene from :func:`load_scene`.
    groups
        Physical-group name → ``(dim, tag)`` of the mesh.
    tdim, gdim
        Topological and geometric dimension of the mesh.

    Raises
    ------
    SceneError
        The mesh dimension differs from ``[scene].dimension``; a material,
        body-force or initial-velocity region is not a cell group (dim
        ``tdim``); a Dirichlet/load boundary or a contact surface is not a facet
        group (dim ``tdim - 1``); two materials claim the same cell group tag; a
        cell group has no material; two ``[[dirichlet]]`` entries fix the same
        component of the same boundary; a traction acts on a component that a
        ``[[dirichlet]]`` entry fixes on the same boundary; the ``[neoplasm]``
        region or a host group is not a cell group, or a host has the region's tag; the
        cyst region of a coupled scene has a material (it is a cavity and takes none).
        Messages list the available names of the right dimension.  A growth-only
        scene has no materials, so its cell groups need none.
    """
    file = str(scene.path)
    if tdim != scene.dimension or gdim != scene.dimension:
        raise SceneError(file, "[scene]", "dimension",
                         f"is {scene.dimension} but the mesh ({scene.mesh_path.name}) has topological "
                         f"dimension {tdim} and geometric dimension {gdim}")
    fdim = tdim - 1

    def available(dim: int) -> str:
        names = sorted(n for n, (d, _) in groups.items() if d == dim)
        return ", ".join(f'"{n}"' for n in names) if names else "(none)"

    def require(name: str, dim: int, table: str, key: str) -> int:
        kind = "cell" if dim == tdim else "facet"
        if name not in groups:
            raise SceneError(file, table, key, f'the mesh has no physical group "{name}"; '
                                               f"its {kind} groups are: {available(dim)}")
        d, tag = groups[name]
        if d != dim:
            other = {tdim: "cell", fdim: "facet"}.get(d, f"dimension-{d}")
            raise SceneError(file, table, key, f'"{name}" is a {other} group (dim {d}), a {kind} group '
                                               f"(dim {dim}) is needed; {kind} groups: {available(dim)}")
        return tag

    # materials: every cell group has exactly one material
    owner: dict[int, str] = {}
    for m in scene.materials:
        label = _label("material", m.index, m.name)
        for r in m.regions:
            tag = require(r, tdim, label, "regions")
            if tag in owner and owner[tag] != m.name:
                raise SceneError(file, label, "regions",
                                 f'region "{r}" (tag {tag}) has the same cells as a region of material '
                                 f'"{owner[tag]}"')
            owner[tag] = m.name
    if scene.neoplasm is not None:
        neo = scene.neoplasm
        if neo.region is not None:
            rtag = require(neo.region, tdim, "[neoplasm]", "region")
            for h in neo.host:
                if require(h, tdim, "[neoplasm]", "host") == rtag:
                    raise SceneError(file, "[neoplasm]", "host",
                                     f'"{h}" has the same cells (tag {rtag}) as the neoplasm region "{neo.region}"')
    # a coupled cyst ([neoplasm] kind = "cyst" with [analysis]) is a pressurised cavity: no material
    cavity = scene.neoplasm.region if scene.neoplasm is not None and scene.neoplasm.kind == "cyst" else None
    if cavity is not None and not scene.growth_only and groups[cavity][1] in owner:
        raise SceneError(file, "[[material]]", "regions",
                         f'cell group "{cavity}" is the cyst of [neoplasm]: a pressurised cavity in the '
                         f'mechanics, it takes no material; remove it from the regions of "{owner[groups[cavity][1]]}"')
    for name, (d, tag) in sorted(groups.items()):
        if scene.growth_only:  # no mechanics: cell groups need no material
            break
        if d == tdim and tag not in owner and name != cavity:
            raise SceneError(file, "[[material]]", "regions",
                             f'cell group "{name}" has no material; list it in the regions of a [[material]]')

    for i, c in enumerate(scene.contacts):
        label = _label("contact", i, c.name)
        s = require(c.slave, fdim, label, "slave")
        if require(c.master, fdim, label, "master") == s:
            raise SceneError(file, label, "master", f'"{c.master}" and "{c.slave}" are the same facet group')

    fixed: dict[tuple[int, int], int] = {}
    for i, bc in enumerate(scene.dirichlet):
        label = _label("dirichlet", i)
        tag = require(bc.boundary, fdim, label, "boundary")
        for comp in bc.components:
            if (tag, comp) in fixed:
                j = fixed[(tag, comp)]
                raise SceneError(file, label, "value",
                                 f'component {comp + 1} of boundary "{bc.boundary}" is already fixed by '
                                 f'[[dirichlet]] #{j + 1} (boundary "{scene.dirichlet[j].boundary}"); '
                                 "each component of a boundary may be fixed once")
            fixed[(tag, comp)] = i

    counters = {k: 0 for k in LOAD_KINDS}
    for load in scene.loads:
        label = _label(load.kind, counters[load.kind])
        counters[load.kind] += 1
        if load.kind == "body_force":
            for r in load.target:
                require(r, tdim, label, "regions")
            continue
        tag = require(load.target[0], fdim, label, "boundary")
        if load.kind == "traction":
            assert isinstance(load.value, tuple)
            for comp, v in enumerate(load.value):
                if v != 0.0 and (tag, comp) in fixed:
                    raise SceneError(file, label, "value",
                                     f'component {comp + 1} of boundary "{load.target[0]}" is fixed by '
                                     f"[[dirichlet]] #{fixed[(tag, comp)] + 1}; a boundary carries loads only "
                                     "in its free components")

    for i, iv in enumerate(scene.initial_velocities):
        label = _label("initial_velocity", i)
        for r in iv.regions:
            require(r, tdim, label, "regions")
