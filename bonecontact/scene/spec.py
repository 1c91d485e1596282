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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from bonecontact.fracture.scene_tables import CrackSpec, FractureSpec
from bonecontact.materials.laws import Material
from bonecontact.neoplasm.cyst import CystParameters
from bonecontact.neoplasm.tumour import TumourParameters

__all__ = [
    "Analysis",
    "ContactSpec",
    "CystSpec",
    "DirichletSpec",
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
FRICTION_LAWS = ("none", "tresca", "coulomb")
COULOMB_UPDATES = ("previous_step", "fixed_point")
LOAD_KINDS = ("traction", "pressure", "body_force", "force")
NEOPLASM_KINDS = ("tumour", "cyst")
CYST_MODELS = ("sphere", "shape")


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
    strengths
        ``sigma_t``, ``sigma_c``, ``K_Ic`` (Pa, Pa·√m) given in the entry, for the fracture
        check (docs/theory/fracture.md#material-strength).
    """

    name: str
    regions: tuple[str, ...]
    material: Material
    index: int
    strengths: dict[str, float] = field(default_factory=dict, compare=False)


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
