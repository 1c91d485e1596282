"""Reading scene files (format 1): :func:`load_scene` and the readers of its tables.

:func:`load_scene` reads the TOML file and checks everything that does not need the
mesh (keys, types, ranges, material constants, schedules, ...); the parameters of a
neoplasm are validated by their physics dataclasses
(:class:`~bonecontact.neoplasm.tumour.TumourParameters`,
:class:`~bonecontact.neoplasm.cyst.CystParameters`), whose errors are reported as a
:class:`~bonecontact.scene.errors.SceneError` naming the file, the table and the key.
The checks against the mesh are in :mod:`bonecontact.scene.checks`.  Units are SI
(m, Pa, kg, s).
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from bonecontact.fracture.crack import FractureError
from bonecontact.fracture.scene_tables import (
    CrackSpec,
    FractureSpec,
    check_strengths,
    crack_from_table,
    fracture_from_table,
)
from bonecontact.materials.laws import (
    FORMULATIONS,
    Isotropic,
    MaterialError,
    Orthotropic,
    TransverselyIsotropic,
)
from bonecontact.neoplasm.cyst import CystParameterError, CystParameters
from bonecontact.neoplasm.tumour import TumourParameterError, TumourParameters
from bonecontact.scene.errors import SceneError, describe_value, format_choices, table_label
from bonecontact.scene.expressions import ExpressionError, RateExpression, parse_rate
from bonecontact.scene.spec import (
    ANALYSIS_KINDS,
    COULOMB_UPDATES,
    CYST_MODELS,
    FRICTION_LAWS,
    LINEAR_SOLVERS,
    NEOPLASM_KINDS,
    SCHEME_CHOICES,
    UNHELD_MOTION_CHOICES,
    Analysis,
    ContactSpec,
    CystSpec,
    DirichletSpec,
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

__all__ = ["FORMAT_VERSION", "load_scene"]

#: The only scene format version this package reads.
FORMAT_VERSION = 1

#: Engineering constants of each material model (all required).
MODEL_KEYS: dict[str, tuple[str, ...]] = {
    "isotropic": ("E", "nu"),
    "transversely_isotropic": ("E_p", "E_a", "nu_p", "nu_pa", "G_pa", "axis"),
    "orthotropic": ("E1", "E2", "E3", "nu12", "nu13", "nu23", "G12", "G13", "G23", "axes"),
}
#: Keys every ``[[material]]`` may carry besides the constants of its model.
MATERIAL_COMMON_KEYS = ("name", "regions", "model", "rho", "tau_v", "formulation")
#: Strength keys a ``[[material]]`` may carry (Pa, Pa·√m), needed by a fracture check.
MATERIAL_STRENGTH_KEYS = ("sigma_t", "sigma_c", "K_Ic")

TOP_LEVEL_KEYS = (
    "format",
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
SCENE_KEYS = ("name", "mesh", "dimension")
ANALYSIS_KEYS = (
    "kind",
    "t_end",
    "dt",
    "load_steps",
    "unheld_motion",
    "scheme",
    "allow_large_strain",
)
SOLVER_KEYS = ("linear", "tolerance", "max_iterations")
CONTACT_KEYS = (
    "name",
    "slave",
    "master",
    "friction",
    "coefficient",
    "bound",
    "coulomb_update",
    "search_distance",
)
SCHEDULE_KEYS = ("ramp", "schedule")
DIRICHLET_KEYS = ("boundary", "value") + SCHEDULE_KEYS
TRACTION_KEYS = ("boundary", "value") + SCHEDULE_KEYS
PRESSURE_KEYS = ("boundary", "value") + SCHEDULE_KEYS
BODY_FORCE_KEYS = ("regions", "value") + SCHEDULE_KEYS
FORCE_KEYS = ("boundary", "value", "moment", "point") + SCHEDULE_KEYS
INITIAL_VELOCITY_KEYS = ("regions", "value")
OUTPUT_KEYS = ("directory", "fields_every", "probes", "checkpoint_every", "checkpoint_time")

#: Tables that later capabilities will add (rejected with a clearer message until then).
FUTURE_TABLES: tuple[str, ...] = ()

#: ``[neoplasm]`` keys; ``radius`` and ``h`` are an extension (initial geometry of meshless scenes).
NEOPLASM_KEYS = (
    "kind",
    "region",
    "host",
    "t_end",
    "dt",
    "remesh_every",
    "mechanics_every",
    "radius",
    "h",
    "tumour",
    "cyst",
)
#: ``[neoplasm.tumour]`` keys: the fields of TumourParameters (``lambda`` for ``lambda_``).
TUMOUR_KEYS = TumourParameters.keys()
#: ``[neoplasm.cyst]`` keys: the scene-only ``model``, then the fields of CystParameters.
CYST_KEYS = ("model", "strain") + tuple(
    f.name for f in dataclasses.fields(CystParameters) if f.name != "strain"
)
#: Tables of a mechanics analysis: not allowed in a growth-only scene.
MECHANICS_TABLES = (
    "solver",
    "material",
    "contact",
    "dirichlet",
    "traction",
    "pressure",
    "body_force",
    "force",
    "initial_velocity",
    "fracture",
    "crack",
)


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
                raise self.error(
                    key, f"[{key}] is not supported yet by this version of bonecontact"
                )
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
            raise self.error(key, f"{what}must be a number, got {describe_value(value)}")
        x = float(value)
        if not math.isfinite(x):
            raise self.error(key, f"{what}must be a finite number, got {value!r}")
        return x

    def number(
        self,
        key: str,
        *,
        required: bool = False,
        default: float | None = None,
        positive: bool = False,
        nonnegative: bool = False,
        why: str = "",
    ) -> float | None:
        value = self.raw(key, required, why)
        if value is _MISSING:
            return default
        x = self._as_number(key, value)
        if positive and x <= 0.0:
            raise self.error(key, f"must be > 0, got {value!r}")
        if nonnegative and x < 0.0:
            raise self.error(key, f"must be >= 0, got {value!r}")
        return x

    def integer(
        self,
        key: str,
        *,
        required: bool = False,
        default: int | None = None,
        minimum: int | None = None,
        why: str = "",
    ) -> int | None:
        value = self.raw(key, required, why)
        if value is _MISSING:
            return default
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(key, f"must be an integer, got {describe_value(value)}")
        if minimum is not None and value < minimum:
            raise self.error(key, f"must be an integer >= {minimum}, got {value}")
        return value

    def string(
        self,
        key: str,
        *,
        required: bool = False,
        default: str | None = None,
        choices: Sequence[str] | None = None,
    ) -> str | None:
        value = self.raw(
            key, required, f"; allowed values: {format_choices(choices)}" if choices else ""
        )
        if value is _MISSING:
            return default
        if not isinstance(value, str):
            allowed = f" (one of {format_choices(choices)})" if choices else ""
            raise self.error(key, f"must be a string{allowed}, got {describe_value(value)}")
        if choices is not None and value not in choices:
            raise self.error(key, f'must be one of {format_choices(choices)}, got "{value}"')
        if choices is None and not value.strip():
            raise self.error(key, "must be a non-empty string")
        return value

    def boolean(self, key: str, *, default: bool = False) -> bool:
        value = self.raw(key, False)
        if value is _MISSING:
            return default
        if not isinstance(value, bool):
            raise self.error(key, f"must be true or false, got {describe_value(value)}")
        return value

    def names(self, key: str, *, required: bool = True) -> tuple[str, ...]:
        """A non-empty array of distinct physical-group names."""
        value = self.raw(key, required)
        if value is _MISSING:
            return ()
        if not isinstance(value, list):
            hint = f' (write {key} = ["{value}"])' if isinstance(value, str) else ""
            raise self.error(
                key, f"must be an array of physical-group names{hint}, got {describe_value(value)}"
            )
        if not value:
            raise self.error(key, "must name at least one physical group")
        for v in value:
            if not isinstance(v, str) or not v.strip():
                raise self.error(
                    key,
                    "must contain physical-group names (non-empty strings), "
                    f"got {describe_value(v)}",
                )
        seen: set[str] = set()
        for v in value:
            if v in seen:
                raise self.error(key, f'physical group "{v}" is listed twice')
            seen.add(v)
        return tuple(value)

    def vector(
        self, key: str, dim: int, *, required: bool = True, value: Any = _MISSING, what: str = ""
    ) -> tuple[float, ...]:
        if value is _MISSING:
            value = self.raw(key, required)
        if not isinstance(value, list):
            raise self.error(
                key,
                f"{what}must be an array of {dim} numbers (one per component), "
                f"got {describe_value(value)}",
            )
        if len(value) != dim:
            raise self.error(
                key, f"{what}must have {dim} components (dimension = {dim}), got {len(value)}"
            )
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
            raise self.error(
                "schedule",
                f"must be a non-empty array of [time, factor] pairs ({example}), "
                f"got {describe_value(pairs)}",
            )
        times: list[float] = []
        factors: list[float] = []
        for i, p in enumerate(pairs, start=1):
            if not isinstance(p, list) or len(p) != 2:
                raise self.error(
                    "schedule",
                    f"entry {i} must be a [time, factor] pair ({example}), got {describe_value(p)}",
                )
            times.append(self._as_number("schedule", p[0], f"entry {i}: time "))
            factors.append(self._as_number("schedule", p[1], f"entry {i}: factor "))
        for i in range(1, len(times)):
            if times[i] <= times[i - 1]:
                raise self.error(
                    "schedule",
                    f"times must be strictly increasing, but entry {i + 1} "
                    f"has time {times[i]!r} after {times[i - 1]!r}",
                )
        return Schedule(tuple(times), tuple(factors))


def _table(doc: Mapping[str, Any], name: str, required: bool) -> _Table | None:
    label = f"[{name}]"
    if name not in doc:
        if required:
            raise SceneError(None, label, None, "missing required table")
        return None
    value = doc[name]
    if not isinstance(value, dict):
        raise SceneError(None, None, name, f"must be a table [{name}], got {describe_value(value)}")
    return _Table(value, label)


def _array_of_tables(doc: Mapping[str, Any], name: str) -> list[dict[str, Any]]:
    if name not in doc:
        return []
    value = doc[name]
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise SceneError(
            None,
            None,
            name,
            f"must be an array of tables (write each entry under [[{name}]]), "
            f"got {describe_value(value)}",
        )
    return value


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
    unheld = tab.string("unheld_motion", default="error", choices=UNHELD_MOTION_CHOICES)
    scheme = tab.string("scheme", default="backward-difference", choices=SCHEME_CHOICES)
    allow_large_strain = tab.boolean("allow_large_strain", default=False)
    return Analysis(
        kind=kind,  # type: ignore[arg-type]
        t_end=t_end,
        dt=dt,
        load_steps=load_steps,
        unheld_motion=unheld,  # type: ignore[arg-type]
        scheme=scheme,  # type: ignore[arg-type]
        allow_large_strain=allow_large_strain,
    )


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
    tab = _Table(entry, table_label("material", i, entry.get("name")))
    name = tab.string("name", required=True)
    assert name is not None
    model = tab.string("model", required=True, choices=tuple(MODEL_KEYS))
    assert model is not None
    constants = MODEL_KEYS[model]
    tab.check_keys(MATERIAL_COMMON_KEYS + constants + MATERIAL_STRENGTH_KEYS)
    regions = tab.names("regions")

    kwargs: dict[str, Any] = {}
    for key in constants:
        if key == "axis":
            kwargs[key] = tab.vector(key, dim)
        elif key == "axes":
            rows = tab.raw(key, True)
            if not isinstance(rows, list) or len(rows) != dim:
                raise tab.error(
                    key,
                    f"must be {dim} material axes (dimension = {dim}), one row of {dim} "
                    f"numbers each, got {describe_value(rows)}",
                )
            kwargs[key] = tuple(
                tab.vector(key, dim, value=r, what=f"row {k + 1} ") for k, r in enumerate(rows)
            )
        else:
            kwargs[key] = tab.number(key, required=True)
    if model == "transversely_isotropic" and not (-1.0 < kwargs["nu_p"] < 1.0):
        raise tab.error("nu_p", f"must satisfy -1 < nu_p < 1, got {kwargs['nu_p']!r}")

    rho = tab.number(
        "rho",
        required=dynamic,
        why=' (density in kg/m³, required when [analysis] kind = "dynamic")',
    )
    tau_v = tab.number("tau_v", default=0.0)
    formulation = tab.string("formulation", default="displacement", choices=FORMULATIONS)
    cls = {
        "isotropic": Isotropic,
        "transversely_isotropic": TransverselyIsotropic,
        "orthotropic": Orthotropic,
    }[model]
    try:
        material = cls(rho=rho, tau_v=tau_v, formulation=formulation, **kwargs)
    except MaterialError as exc:
        raise tab.error(exc.key, exc.message) from None
    except (ArithmeticError, np.linalg.LinAlgError) as exc:
        key = {"isotropic": "nu", "transversely_isotropic": "nu_pa", "orthotropic": "nu12"}[model]
        raise tab.error(key, f"engineering constants give a singular compliance ({exc})") from None
    strengths = {k: tab.number(k, positive=True) for k in MATERIAL_STRENGTH_KEYS if tab.has(k)}
    return MaterialSpec(name=name, regions=regions, material=material, index=i, strengths=strengths)


def _read_materials(doc: Mapping[str, Any], dim: int, dynamic: bool) -> tuple[MaterialSpec, ...]:
    entries = _array_of_tables(doc, "material")
    if not entries:
        raise SceneError(None, "[[material]]", None, "at least one material is required")
    specs: list[MaterialSpec] = []
    names: dict[str, int] = {}
    owner: dict[str, str] = {}
    for i, entry in enumerate(entries):
        spec = _read_material(entry, i, dim, dynamic)
        label = table_label("material", i, spec.name)
        if spec.name in names:
            raise SceneError(
                None,
                label,
                "name",
                f'material name "{spec.name}" is already used by '
                f"[[material]] #{names[spec.name] + 1}",
            )
        names[spec.name] = i
        for region in spec.regions:
            if region in owner:
                raise SceneError(
                    None,
                    label,
                    "regions",
                    f'region "{region}" is already claimed by material "{owner[region]}"; '
                    "a region has exactly one material",
                )
            owner[region] = spec.name
        specs.append(spec)
    return tuple(specs)


def _read_contacts(
    doc: Mapping[str, Any], allow_contact: bool, allow_friction: bool = False
) -> tuple[ContactSpec, ...]:
    entries = _array_of_tables(doc, "contact")
    if entries and not allow_contact:
        raise SceneError(None, "[[contact]]", None, "contact is not supported yet")
    specs: list[ContactSpec] = []
    names: dict[str, int] = {}
    for i, entry in enumerate(entries):
        tab = _Table(entry, table_label("contact", i, entry.get("name")))
        tab.check_keys(CONTACT_KEYS)
        name = tab.string("name", required=True)
        assert name is not None
        if not all(c.isalnum() or c in "_-." for c in name):
            raise tab.error(
                "name",
                f'must contain only letters, digits, "_", "-" and "." '
                f'(it names output files), got "{name}"',
            )
        if name in names:
            raise tab.error(
                "name", f'contact name "{name}" is already used by [[contact]] #{names[name] + 1}'
            )
        names[name] = i
        slave = tab.string("slave", required=True)
        master = tab.string("master", required=True)
        if slave == master:
            raise tab.error("master", f'must differ from slave, both are "{slave}"')
        friction = tab.string("friction", default="none", choices=FRICTION_LAWS)
        specs.append(
            ContactSpec(
                name=name,
                slave=slave,
                master=master,  # type: ignore[arg-type]
                friction=friction,  # type: ignore[arg-type]
                coefficient=tab.number("coefficient", default=0.0, nonnegative=True),  # type: ignore[arg-type]
                bound=tab.number("bound", default=0.0, nonnegative=True),  # type: ignore[arg-type]
                coulomb_update=tab.string(
                    "coulomb_update",
                    default="previous_step",  # type: ignore[arg-type]
                    choices=COULOMB_UPDATES,
                ),
                search_distance=tab.number("search_distance", default=None, positive=True),
            )
        )
        if friction != "none" and not allow_friction:
            raise tab.error(
                "friction",
                f'"{friction}" friction is not supported yet by this version of '
                'bonecontact; allowed for now: "none"',
            )
        # a non-default value of another friction law's key is an error, not silently ignored
        spec = specs[-1]
        if spec.coefficient > 0 and friction != "coulomb":
            raise tab.error(
                "coefficient",
                f'is the Coulomb coefficient, but this pair has friction = "{friction}" '
                '(use friction = "coulomb", or "bound" for Tresca)',
            )
        if spec.bound > 0 and friction != "tresca":
            raise tab.error(
                "bound",
                f'is the Tresca bound (Pa), but this pair has friction = "{friction}" '
                '(use friction = "tresca", or "coefficient" for Coulomb)',
            )
        if spec.coulomb_update != "previous_step" and friction != "coulomb":
            raise tab.error(
                "coulomb_update",
                f'applies to Coulomb friction only, but this pair has friction = "{friction}"',
            )
    return tuple(specs)


def _default_schedule(static: bool) -> Schedule:
    # static: loads grow linearly with the pseudo-time over the load steps
    return Schedule.from_ramp(1.0) if static else Schedule()


def _read_dirichlet(doc: Mapping[str, Any], dim: int, static: bool) -> tuple[DirichletSpec, ...]:
    specs: list[DirichletSpec] = []
    for i, entry in enumerate(_array_of_tables(doc, "dirichlet")):
        tab = _Table(entry, table_label("dirichlet", i))
        tab.check_keys(DIRICHLET_KEYS)
        boundary = tab.string("boundary", required=True)
        assert boundary is not None
        raw = tab.raw("value", True)
        if not isinstance(raw, list) or len(raw) != dim:
            got = f"{len(raw)} entries" if isinstance(raw, list) else describe_value(raw)
            raise tab.error(
                "value",
                f"must be an array of {dim} entries (dimension = {dim}), each a number or "
                f'"free", got {got}',
            )
        value: list[float | None] = []
        for k, v in enumerate(raw, start=1):
            if isinstance(v, str):
                if v != "free":
                    raise tab.error(
                        "value", f'component {k}: the only string allowed is "free", got "{v}"'
                    )
                value.append(None)
            elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise tab.error(
                    "value",
                    f'component {k} must be a finite number or "free", got {describe_value(v)}',
                )
            else:
                value.append(float(v))
        if all(v is None for v in value):
            raise tab.error("value", 'all components are "free"; fix at least one component')
        sched = tab.schedule() or _default_schedule(static)
        specs.append(DirichletSpec(boundary=boundary, value=tuple(value), schedule=sched))
    return tuple(specs)


def _read_moment(tab: _Table, dim: int) -> tuple[tuple[float, ...] | float | None, Any]:
    """``[[force]]`` ``moment`` and ``point``: ``(moment, point)``, ``(None, None)`` without."""
    if not tab.has("moment"):
        if tab.has("point"):
            raise tab.error(
                "point",
                "is the point the moment is taken about, but no moment is given "
                "(add moment = ..., or remove point)",
            )
        return None, None
    moment: tuple[float, ...] | float
    if dim == 2:
        raw = tab.raw("moment", True)
        if isinstance(raw, list):
            raise tab.error(
                "moment",
                "must be a single number in 2D (the moment about the z axis, N·m per m of "
                f"thickness), got an array of {len(raw)}",
            )
        moment = tab._as_number("moment", raw)
    else:
        moment = tab.vector("moment", 3)
    point = tab.vector("point", dim) if tab.has("point") else None
    return moment, point


def _read_loads(doc: Mapping[str, Any], dim: int, static: bool) -> tuple[LoadSpec, ...]:
    specs: list[LoadSpec] = []
    for kind, keys in (
        ("traction", TRACTION_KEYS),
        ("pressure", PRESSURE_KEYS),
        ("body_force", BODY_FORCE_KEYS),
        ("force", FORCE_KEYS),
    ):
        for i, entry in enumerate(_array_of_tables(doc, kind)):
            tab = _Table(entry, table_label(kind, i))
            tab.check_keys(keys)
            moment, point = _read_moment(tab, dim) if kind == "force" else (None, None)
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
                        raise tab.error(
                            "value", "must be a single number (normal pressure in Pa), got an array"
                        )
                    value = tab._as_number("value", raw)
                else:
                    value = tab.vector("value", dim)
            sched = tab.schedule() or _default_schedule(static)
            specs.append(
                LoadSpec(
                    kind=kind,  # type: ignore[arg-type]
                    target=target,
                    value=value,
                    schedule=sched,
                    moment=moment,
                    point=point,
                )
            )
    return tuple(specs)


def _read_initial_velocities(doc: Mapping[str, Any], dim: int) -> tuple[InitialVelocitySpec, ...]:
    specs: list[InitialVelocitySpec] = []
    owner: dict[str, int] = {}
    for i, entry in enumerate(_array_of_tables(doc, "initial_velocity")):
        tab = _Table(entry, table_label("initial_velocity", i))
        tab.check_keys(INITIAL_VELOCITY_KEYS)
        regions = tab.names("regions")
        for r in regions:
            if r in owner:
                raise tab.error(
                    "regions",
                    f'region "{r}" already has an initial velocity '
                    f"([[initial_velocity]] #{owner[r] + 1})",
                )
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
    checkpoint_every = tab.integer("checkpoint_every", default=0, minimum=0)
    checkpoint_time = tab.number("checkpoint_time", default=0.0, nonnegative=True)
    raw = tab.raw("probes", False)
    probes: tuple[tuple[float, ...], ...] = ()
    if raw is not _MISSING:
        example = "[[x, y]]" if dim == 2 else "[[x, y, z]]"
        if not isinstance(raw, list) or any(not isinstance(p, list) for p in raw):
            raise tab.error(
                "probes", f"must be an array of points, e.g. {example}, got {describe_value(raw)}"
            )
        probes = tuple(
            tab.vector("probes", dim, value=p, what=f"point {k + 1} ") for k, p in enumerate(raw)
        )
    return OutputSpec(
        directory=directory,
        fields_every=fields_every,
        probes=probes,  # type: ignore[arg-type]
        checkpoint_every=checkpoint_every,  # type: ignore[arg-type]
        checkpoint_time=checkpoint_time,  # type: ignore[arg-type]
    )


def _sub_table(tab: _Table, key: str) -> _Table | None:
    """``[neoplasm.<key>]`` as a table, or ``None`` when absent."""
    if not tab.has(key):
        return None
    value = tab.data[key]
    if not isinstance(value, dict):
        raise tab.error(key, f"must be a table [neoplasm.{key}], got {describe_value(value)}")
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
            raise tab.error(
                key, f'expression "{value}" cannot be evaluated at u_c = u_c1 = {u_c1!r} ({exc})'
            ) from None
        if not math.isfinite(probe):
            raise tab.error(key, f'expression "{value}" is not finite at u_c = u_c1 = {u_c1!r}')
        return expr
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise tab.error(
            key,
            f"must be a number (1/s) or an expression string of u_c such as "
            f'"2.0*(u_c - 0.7)", got {describe_value(value)}',
        )
    return tab._as_number(key, value)


def _tumour_parameters(tab: _Table, values: dict[str, Any]) -> TumourParameters:
    """``TumourParameters(**values)``, its range errors reported on ``tab``."""
    params = TumourParameters(**values)
    try:
        params.validate()
    except TumourParameterError as exc:
        raise tab.error(exc.key, exc.message) from None
    return params


def _read_tumour(tab: _Table) -> TumourParameters:
    """``[neoplasm.tumour]``: numbers (ranges checked by TumourParameters), then the rates."""
    tab.check_keys(TUMOUR_KEYS)
    d = TumourParameters()
    fields = (f.name for f in dataclasses.fields(TumourParameters))
    numbers = {
        name: tab.number(key, default=getattr(d, name))
        for name, key in zip(fields, TUMOUR_KEYS)
        if name in TumourParameters.NUMBERS
    }
    _tumour_parameters(tab, numbers)  # ranges first: the rates are probed at u_c1
    rates = {k: _read_rate(tab, k, getattr(d, k), numbers["u_c1"]) for k in TumourParameters.RATES}
    return _tumour_parameters(tab, {**numbers, **rates})


def _read_cyst(tab: _Table) -> CystSpec:
    """``[neoplasm.cyst]``: the scene's ``model`` and the CystParameters (ranges checked there)."""
    tab.check_keys(CYST_KEYS)
    model = tab.string("model", default="sphere", choices=CYST_MODELS)
    strain = tab.string("strain", default="log", choices=CystParameters.STRAINS)
    beta = tab.number("beta", required=True, why=" (osmotic supply rate, mol m-2 s-1)")
    C_minus = tab.number("C_minus", required=True, why=" (outside osmolarity, mol/m3)")
    others = {
        k: tab.number(k, default=getattr(CystParameters, k))
        for k in ("temperature", "E", "viscosity", "f0")
    }
    try:
        params = CystParameters(beta=beta, C_minus=C_minus, strain=strain, **others)  # type: ignore[arg-type]
    except CystParameterError as exc:
        raise tab.error(exc.key, exc.message) from None
    return CystSpec(model=model, parameters=params)  # type: ignore[arg-type]


def _read_neoplasm(
    doc: Mapping[str, Any], has_mesh: bool, has_analysis: bool
) -> NeoplasmSpec | None:
    """``[neoplasm]`` and its sub-table (the neoplasm tables of docs/neoplasm_format.md)."""
    tab = _table(doc, "neoplasm", required=False)
    if tab is None:
        return None
    tab.check_keys(NEOPLASM_KEYS)
    kind = tab.string("kind", required=True, choices=NEOPLASM_KINDS)
    assert kind is not None
    # initial geometry: a cell group of the mesh, or (extension) radius + h without a mesh
    if has_mesh:
        if not tab.has("region"):
            raise tab.error(
                "region",
                "missing required key (the cell group of the mesh holding the neoplasm at t = 0)",
            )
        region = tab.string("region", required=True)
        if tab.has("radius"):
            raise tab.error(
                "radius",
                "is only for scenes without a mesh; with a mesh the initial "
                'neoplasm is the cell group named by "region"',
            )
    else:
        if tab.has("region"):
            raise tab.error(
                "region",
                "names a cell group of the mesh, but [scene] has no mesh; "
                "give the initial size with radius = ... (m) instead",
            )
        region = None
    radius = tab.number(
        "radius",
        required=not has_mesh,
        positive=True,
        why=" (initial radius in m of a scene without a mesh: a disc in 2D, a ball in 3D)",
    )
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
            raise tab.error(
                "host",
                "names cell groups of the mesh, but [scene] has no mesh; "
                "write host = [] or leave it out",
            )
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
        raise tab.error(
            "mechanics_every",
            f"is {mechanics_every} but the scene has no [analysis] to run; "
            "a growth-only scene needs mechanics_every = 0",
        )
    tumour_tab, cyst_tab = _sub_table(tab, "tumour"), _sub_table(tab, "cyst")
    other = cyst_tab if kind == "tumour" else tumour_tab
    if other is not None:
        raise tab.error(
            "tumour" if kind == "cyst" else "cyst",
            f'[neoplasm.{"tumour" if kind == "cyst" else "cyst"}] is given but kind = "{kind}"; '
            f"write the parameters under [neoplasm.{kind}]",
        )
    tumour = cyst = None
    if kind == "tumour":
        tumour = _read_tumour(tumour_tab or _Table({}, "[neoplasm.tumour]"))
    else:
        if cyst_tab is None:
            raise SceneError(
                None,
                "[neoplasm.cyst]",
                None,
                'missing required table (kind = "cyst" needs at least beta and C_minus)',
            )
        cyst = _read_cyst(cyst_tab)
    return NeoplasmSpec(
        kind=kind,
        t_end=t_end,
        dt=dt,
        region=region,
        host=host,  # type: ignore[arg-type]
        remesh_every=remesh_every,
        mechanics_every=mechanics_every,  # type: ignore[arg-type]
        radius=radius,
        h=h,
        tumour=tumour,
        cyst=cyst,
    )


def _read_fracture(
    doc: Mapping[str, Any], dim: int, materials: Sequence[MaterialSpec], has_neoplasm: bool
) -> tuple[FractureSpec | None, tuple[CrackSpec, ...]]:
    """``[fracture]`` and ``[[crack]]`` (docs/theory/fracture.md#scene-tables), parsed by
    :mod:`bonecontact.fracture.scene_tables`; its errors name the key."""
    tab = _table(doc, "fracture", required=False)
    entries = _array_of_tables(doc, "crack")
    if tab is None and not entries:
        return None, ()
    if has_neoplasm and entries:
        raise SceneError(
            None,
            "[[crack]]",
            None,
            "a crack in a coupled [neoplasm] scene is not supported yet (a [fracture] "
            "initiation check is: it runs at every analysis of the growth)",
        )
    try:
        spec = fracture_from_table(tab.data if tab is not None else {})
    except FractureError as exc:
        raise SceneError(None, "[fracture]", exc.key, _fracture_message(exc)) from None
    for key in ("propagate", "initiate"):
        if dim != 2 and getattr(spec, key):
            raise SceneError(
                None,
                "[fracture]",
                key,
                "runs in 2D scenes in this version (3D: the risk, and K along the front of a "
                "given planar [[crack]]; 3D propagation is planned, docs/theory/fracture.md)",
            )
    cracks = []
    for i, entry in enumerate(entries):
        try:
            cracks.append(crack_from_table(entry, i + 1, dim))
        except FractureError as exc:
            where = table_label("crack", i, entry.get("name"))
            raise SceneError(None, where, exc.key, _fracture_message(exc)) from None
    for m in materials:
        try:
            check_strengths(spec, {m.name: m.strengths}, [m.name])
        except FractureError as exc:
            raise SceneError(
                None,
                table_label("material", m.index, m.name),
                exc.key,
                f"missing: the [fracture] check needs {exc.key} (a positive number) of every "
                "material (values with sources: data/materials.toml [strength.*])",
            ) from None
    names = [c.name for c in cracks]
    for i, c in enumerate(cracks):
        if names.index(c.name) != i:
            raise SceneError(None, table_label("crack", i, c.name), "name", "is not unique")
    return spec, tuple(cracks)


def _fracture_message(exc: FractureError) -> str:
    """The message of a FractureError without its ``key:`` prefix."""
    text = str(exc)
    prefix = f"{exc.key}: "
    return text[len(prefix) :] if text.startswith(prefix) else text


def _reject_mechanics_tables(doc: Mapping[str, Any]) -> None:
    """A growth-only scene has no mechanics: its tables would be silently unused."""
    for name in MECHANICS_TABLES:
        if name in doc:
            label = f"[{name}]" if name == "solver" else f"[[{name}]]"
            raise SceneError(
                None,
                label,
                None,
                "belongs to a mechanics analysis, but this growth-only scene ([neoplasm] "
                "without [analysis]) has none; remove it",
            )
    out = doc.get("output")
    if isinstance(out, dict) and "probes" in out:
        raise SceneError(
            None,
            "[output]",
            "probes",
            "probes sample the mechanics fields; a growth-only "
            "scene writes growth.csv only, remove probes",
        )


def _read_document(
    doc: dict[str, Any], path: Path, allow_contact: bool, allow_friction: bool = False
) -> Scene:
    # format first: a different version may have different tables
    top = _Table(doc, None)
    fmt = top.raw("format", True, f" (write format = {FORMAT_VERSION} at the top of the file)")
    if isinstance(fmt, bool) or not isinstance(fmt, int):
        raise top.error(
            "format", f"must be the integer {FORMAT_VERSION}, got {describe_value(fmt)}"
        )
    if fmt != FORMAT_VERSION:
        raise top.error(
            "format", f"unsupported scene format {fmt}; this package reads format {FORMAT_VERSION}"
        )
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
        return Scene(
            path=path,
            name=name,
            mesh_path=mesh_path,
            dimension=dim,
            analysis=None,
            solver=default_solver_options(),
            materials=(),
            contacts=(),
            dirichlet=(),
            loads=(),
            initial_velocities=(),
            output=output,
            raw=doc,
            neoplasm=neoplasm,
        )
    analysis = _read_analysis(doc)
    if mesh_path is None:
        raise scene_tab.error(
            "mesh", "missing required key (a scene with an [analysis] needs a mesh)"
        )
    static = analysis.kind == "static"
    solver = _read_solver(doc)
    materials = _read_materials(doc, dim, analysis.kind == "dynamic")
    contacts = _read_contacts(doc, allow_contact, allow_friction)
    dirichlet = _read_dirichlet(doc, dim, static)
    loads = _read_loads(doc, dim, static)
    initial_velocities = _read_initial_velocities(doc, dim)
    output = _read_output(doc, dim)
    neoplasm = _read_neoplasm(doc, True, has_analysis=True)
    fracture, cracks = _read_fracture(doc, dim, materials, neoplasm is not None)
    # growth coupled to the loaded bone (bonecontact.runners.coupled, docs/neoplasm_format.md):
    # 2D and 3D (in 3D the neoplasm must stay strictly inside one region, checked with the mesh)
    return Scene(
        path=path,
        name=name,
        mesh_path=mesh_path,
        dimension=dim,
        analysis=analysis,
        solver=solver,
        materials=materials,
        contacts=contacts,
        dirichlet=dirichlet,
        loads=loads,
        initial_velocities=initial_velocities,
        output=output,
        raw=doc,
        neoplasm=neoplasm,
        fracture=fracture,
        cracks=cracks,
    )


def load_scene(
    path: str | Path, *, allow_contact: bool = True, allow_friction: bool = True
) -> Scene:
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
        with ``ramp = 0``) and without ``schedule`` gets the schedule ``ramp = 1`` (the load grows
        linearly over
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
        raise SceneError(
            shown, None, None, f"cannot read the scene file: {exc.strerror or exc}"
        ) from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(shown, None, None, f"invalid TOML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise SceneError(
            shown, None, None, f"invalid TOML: the file is not UTF-8 ({exc.reason})"
        ) from None
    try:
        return _read_document(doc, p, allow_contact, allow_friction)
    except SceneError as exc:
        raise exc.with_file(shown) from None
