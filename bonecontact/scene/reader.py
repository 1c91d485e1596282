"""Reading scene files (format 1): :func:`load_scene` and the readers of its tables.

:func:`load_scene` reads the TOML file and checks everything that does not need the
mesh (keys, types, ranges, material constants, schedules, ...).  The keys of every table,
their types, defaults, units and allowed values are declared once in
:mod:`bonecontact.scene.spec` (:class:`~bonecontact.scene.keys.Table`); the readers here
take their checks and messages from those declarations
(:class:`~bonecontact.scene.tables.TableReader`).  ``[neoplasm]`` is read by
:mod:`bonecontact.scene.neoplasm_tables`, ``[fracture]`` and ``[[crack]]`` by
:mod:`bonecontact.scene.fracture_tables`.  Errors are a
:class:`~bonecontact.scene.errors.SceneError` naming the file, the table and the key; an
old spelling of a renamed key is read with a
:class:`~bonecontact.scene.keys.SceneDeprecationWarning` naming the file, the table and
the new key.  The checks against the mesh are in :mod:`bonecontact.scene.checks`.  Units
are SI (m, Pa, kg, s).
"""

from __future__ import annotations

import math
import tomllib
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from bonecontact.common.errors import ParameterError
from bonecontact.materials.laws import Isotropic, Orthotropic, TransverselyIsotropic
from bonecontact.scene.errors import SceneError, describe_value, table_label
from bonecontact.scene.fracture_tables import read_fracture
from bonecontact.scene.keys import SceneDeprecationWarning
from bonecontact.scene.neoplasm_tables import read_neoplasm
from bonecontact.scene.spec import (
    ANALYSIS_TABLE,
    CONTACT_TABLE,
    DIRICHLET_TABLE,
    INITIAL_VELOCITY_TABLE,
    LOAD_TABLES,
    MATERIAL_STRENGTH_KEYS,
    MATERIAL_TABLE,
    MODEL_CONSTANTS,
    OUTPUT_TABLE,
    SCENE_TABLE,
    SOLVER_TABLE,
    TOP_LEVEL,
    Analysis,
    ContactSpec,
    DirichletSpec,
    InitialVelocitySpec,
    LoadSpec,
    MaterialSpec,
    OutputSpec,
    Scene,
    Schedule,
    SolverOptions,
    default_solver_options,
)
from bonecontact.scene.tables import (
    MISSING,
    TableReader,
    array_of_tables,
    collect_deprecations,
    table_of,
)

__all__ = ["FORMAT_VERSION", "load_scene"]

#: The only scene format version this package reads.
FORMAT_VERSION = 1

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
# the tables of a mechanics scene
# --------------------------------------------------------------------------------------
def _read_analysis(doc: Mapping[str, Any]) -> Analysis:
    """``[analysis]`` (required in a mechanics scene)."""
    tab = table_of(doc, "analysis", required=True)
    assert tab is not None
    tab.check_keys(ANALYSIS_TABLE)
    kind = tab.get(ANALYSIS_TABLE["kind"])
    timed = kind in ("quasistatic", "dynamic")
    why = f' (required when kind = "{kind}")'
    t_end = tab.get(ANALYSIS_TABLE["t_end"], required=timed, why=why)
    dt = tab.get(ANALYSIS_TABLE["dt"], required=timed, why=why)
    if timed and dt is not None and t_end is not None and dt > t_end * (1.0 + 1e-12):
        raise tab.error("dt", f"must be <= t_end = {t_end!r}, got {dt!r}")
    others = ("load_steps", "unheld_motion", "scheme", "allow_large_strain")
    return Analysis(
        kind=kind, t_end=t_end, dt=dt, **{k: tab.get(ANALYSIS_TABLE[k]) for k in others}
    )


def _read_solver(doc: Mapping[str, Any]) -> SolverOptions:
    """``[solver]``, the defaults when absent."""
    defaults = default_solver_options()
    tab = table_of(doc, "solver", required=False)
    if tab is None:
        return defaults
    tab.check_keys(SOLVER_TABLE)
    return SolverOptions(**{k: tab.get(SOLVER_TABLE[k]) for k in SOLVER_TABLE.names})


#: The material law of each model.
_MATERIAL_LAWS = {
    "isotropic": Isotropic,
    "transversely_isotropic": TransverselyIsotropic,
    "orthotropic": Orthotropic,
}


def _material_axes(tab: TableReader, key: str, dim: int) -> tuple[tuple[float, ...], ...]:
    """``axes``: ``dim`` rows of ``dim`` numbers."""
    rows = tab.raw(key, True)
    if not isinstance(rows, list) or len(rows) != dim:
        raise tab.error(
            key,
            f"must be {dim} material axes (dimension = {dim}), one row of {dim} "
            f"numbers each, got {describe_value(rows)}",
        )
    return tuple(tab.vector(key, dim, value=r, what=f"row {k + 1} ") for k, r in enumerate(rows))


def _material_constants(tab: TableReader, model: str, dim: int) -> dict[str, Any]:
    """The engineering constants of ``model`` (all required; ranges checked by the law)."""
    kwargs: dict[str, Any] = {}
    for key in MODEL_CONSTANTS[model]:
        if key.name == "axis":
            kwargs[key.name] = tab.vector(key.name, dim)
        elif key.name == "axes":
            kwargs[key.name] = _material_axes(tab, key.name, dim)
        else:
            kwargs[key.name] = tab.get(key)
    if model == "transversely_isotropic" and not (-1.0 < kwargs["nu_p"] < 1.0):
        raise tab.error("nu_p", f"must satisfy -1 < nu_p < 1, got {kwargs['nu_p']!r}")
    return kwargs


def _read_material(entry: dict[str, Any], i: int, dim: int, dynamic: bool) -> MaterialSpec:
    """One ``[[material]]`` entry (``i`` from 0): its law from the model's constants."""
    tab = TableReader(entry, table_label("material", i, entry.get("name")))
    name = tab.get(MATERIAL_TABLE["name"])
    model = tab.get(MATERIAL_TABLE["model"])
    tab.check_keys(MATERIAL_TABLE.with_keys(*MODEL_CONSTANTS[model], before="sigma_t"))
    regions = tab.names("regions")
    kwargs = _material_constants(tab, model, dim)
    rho = tab.get(
        MATERIAL_TABLE["rho"],
        required=dynamic,
        why=' (density in kg/m³, required when [analysis] kind = "dynamic")',
    )
    tau_v = tab.get(MATERIAL_TABLE["tau_v"])
    formulation = tab.get(MATERIAL_TABLE["formulation"])
    try:
        material = _MATERIAL_LAWS[model](rho=rho, tau_v=tau_v, formulation=formulation, **kwargs)
    except ParameterError as exc:
        raise tab.error(exc.key, exc.message) from None
    except (ArithmeticError, np.linalg.LinAlgError) as exc:
        key = {"isotropic": "nu", "transversely_isotropic": "nu_pa", "orthotropic": "nu12"}[model]
        raise tab.error(key, f"engineering constants give a singular compliance ({exc})") from None
    strengths = {k: tab.get(MATERIAL_TABLE[k]) for k in MATERIAL_STRENGTH_KEYS if tab.has(k)}
    return MaterialSpec(name=name, regions=regions, material=material, index=i, strengths=strengths)


def _read_materials(doc: Mapping[str, Any], dim: int, dynamic: bool) -> tuple[MaterialSpec, ...]:
    """The ``[[material]]`` entries: unique names, each region in one material."""
    entries = array_of_tables(doc, "material")
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


def _contact_name(tab: TableReader, names: dict[str, int], i: int) -> str:
    """A pair's ``name``: unique, and usable in a file name."""
    name = tab.get(CONTACT_TABLE["name"])
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
    return name


def _check_friction_keys(tab: TableReader, spec: ContactSpec, allow_friction: bool) -> None:
    """A friction law that is not supported, or a key of another law than the pair's."""
    friction = spec.friction
    if friction != "none" and not allow_friction:
        raise tab.error(
            "friction",
            f'"{friction}" friction is not supported yet by this version of '
            'bonecontact; allowed for now: "none"',
        )
    # a non-default value of another friction law's key is an error, not silently ignored
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


def _read_contacts(
    doc: Mapping[str, Any], allow_contact: bool, allow_friction: bool = False
) -> tuple[ContactSpec, ...]:
    """The ``[[contact]]`` pairs (``allow_contact``, ``allow_friction``: see load_scene)."""
    entries = array_of_tables(doc, "contact")
    if entries and not allow_contact:
        raise SceneError(None, "[[contact]]", None, "contact is not supported yet")
    specs: list[ContactSpec] = []
    names: dict[str, int] = {}
    for i, entry in enumerate(entries):
        tab = TableReader(entry, table_label("contact", i, entry.get("name")))
        tab.check_keys(CONTACT_TABLE)
        name = _contact_name(tab, names, i)
        slave = tab.get(CONTACT_TABLE["slave"])
        master = tab.get(CONTACT_TABLE["master"])
        if slave == master:
            raise tab.error("master", f'must differ from slave, both are "{slave}"')
        others = ("friction", "coefficient", "bound", "coulomb_update", "search_distance")
        spec = ContactSpec(name, slave, master, **{k: tab.get(CONTACT_TABLE[k]) for k in others})
        _check_friction_keys(tab, spec, allow_friction)
        specs.append(spec)
    return tuple(specs)


def _default_schedule(static: bool) -> Schedule:
    """The schedule of an entry without ``ramp`` or ``schedule``."""
    # static: loads grow linearly with the pseudo-time over the load steps
    return Schedule.from_ramp(1.0) if static else Schedule()


def _read_dirichlet(doc: Mapping[str, Any], dim: int, static: bool) -> tuple[DirichletSpec, ...]:
    """The ``[[dirichlet]]`` entries: a number or ``"free"`` per component."""
    specs: list[DirichletSpec] = []
    for i, entry in enumerate(array_of_tables(doc, "dirichlet")):
        tab = TableReader(entry, table_label("dirichlet", i))
        tab.check_keys(DIRICHLET_TABLE)
        boundary = tab.get(DIRICHLET_TABLE["boundary"])
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


def _read_moment(tab: TableReader, dim: int) -> tuple[tuple[float, ...] | float | None, Any]:
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
        moment = tab.as_number("moment", raw)
    else:
        moment = tab.vector("moment", 3)
    point = tab.vector("point", dim) if tab.has("point") else None
    return moment, point


def _load_value(tab: TableReader, kind: str, dim: int) -> tuple[float, ...] | float:
    """``value``: a vector, or the single number of a pressure."""
    if kind != "pressure":
        return tab.vector("value", dim)
    raw = tab.raw("value", True)
    if isinstance(raw, list):
        raise tab.error("value", "must be a single number (normal pressure in Pa), got an array")
    return tab.as_number("value", raw)


def _read_load(tab: TableReader, kind: str, dim: int, static: bool) -> LoadSpec:
    """One ``[[traction]]``, ``[[pressure]]``, ``[[body_force]]`` or ``[[force]]``."""
    tab.check_keys(LOAD_TABLES[kind])
    moment, point = _read_moment(tab, dim) if kind == "force" else (None, None)
    target: tuple[str, ...]
    if kind == "body_force":
        target = tab.names("regions")
    else:
        target = (tab.get(LOAD_TABLES[kind]["boundary"]),)
    value = _load_value(tab, kind, dim)
    sched = tab.schedule() or _default_schedule(static)
    return LoadSpec(
        kind=kind,  # type: ignore[arg-type]
        target=target,
        value=value,
        schedule=sched,
        moment=moment,
        point=point,
    )


def _read_loads(doc: Mapping[str, Any], dim: int, static: bool) -> tuple[LoadSpec, ...]:
    """Tractions, pressures, body forces and forces, each kind in file order."""
    return tuple(
        _read_load(TableReader(entry, table_label(kind, i)), kind, dim, static)
        for kind in LOAD_TABLES
        for i, entry in enumerate(array_of_tables(doc, kind))
    )


def _read_initial_velocities(doc: Mapping[str, Any], dim: int) -> tuple[InitialVelocitySpec, ...]:
    """The ``[[initial_velocity]]`` entries (a region in one entry only)."""
    specs: list[InitialVelocitySpec] = []
    owner: dict[str, int] = {}
    for i, entry in enumerate(array_of_tables(doc, "initial_velocity")):
        tab = TableReader(entry, table_label("initial_velocity", i))
        tab.check_keys(INITIAL_VELOCITY_TABLE)
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
    """``[output]`` (the defaults when absent)."""
    tab = table_of(doc, "output", required=False) or TableReader({}, "[output]")
    tab.check_keys(OUTPUT_TABLE)
    directory = Path(tab.get(OUTPUT_TABLE["directory"]))
    if not directory.is_absolute():
        directory = Path.cwd() / directory
    counts = {k: tab.get(OUTPUT_TABLE[k]) for k in ("fields_every", "checkpoint_every")}
    checkpoint_time = tab.get(OUTPUT_TABLE["checkpoint_time"])
    raw = tab.raw("probes", False)
    probes: tuple[tuple[float, ...], ...] = ()
    if raw is not MISSING:
        example = "[[x, y]]" if dim == 2 else "[[x, y, z]]"
        if not isinstance(raw, list) or any(not isinstance(p, list) for p in raw):
            raise tab.error(
                "probes", f"must be an array of points, e.g. {example}, got {describe_value(raw)}"
            )
        probes = tuple(
            tab.vector("probes", dim, value=p, what=f"point {k + 1} ") for k, p in enumerate(raw)
        )
    return OutputSpec(directory=directory, probes=probes, checkpoint_time=checkpoint_time, **counts)


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


def _check_format(doc: Mapping[str, Any]) -> None:
    """``format`` first (a different version may have different tables), then the
    top-level keys."""
    top = TableReader(doc, None)
    fmt = top.raw("format", True, f" (write format = {FORMAT_VERSION} at the top of the file)")
    if isinstance(fmt, bool) or not isinstance(fmt, int):
        raise top.error(
            "format", f"must be the integer {FORMAT_VERSION}, got {describe_value(fmt)}"
        )
    if fmt != FORMAT_VERSION:
        raise top.error(
            "format", f"unsupported scene format {fmt}; this package reads format {FORMAT_VERSION}"
        )
    top.check_keys(TOP_LEVEL, what="top-level key or table")


def _mesh_path(tab: TableReader, mesh: str, path: Path) -> Path:
    """The absolute path of ``[scene] mesh`` (relative to the scene file); it must exist."""
    mesh_path = Path(mesh)
    if not mesh_path.is_absolute():
        mesh_path = path.parent / mesh_path
    mesh_path = mesh_path.resolve()
    if not mesh_path.is_file():
        raise tab.error("mesh", f'mesh file "{mesh}" not found (looked for {mesh_path})')
    return mesh_path


def _read_scene_table(
    doc: Mapping[str, Any], path: Path, has_neoplasm: bool
) -> tuple[str, Path | None, int]:
    """``[scene]``: the name, the mesh path (``None``: a meshless growth-only scene) and
    the dimension."""
    tab = table_of(doc, "scene", required=True)
    assert tab is not None
    tab.check_keys(SCENE_TABLE)
    name = tab.get(SCENE_TABLE["name"]) or path.stem
    # a growth-only scene may be meshless ([neoplasm] radius = ...)
    mesh = tab.get(SCENE_TABLE["mesh"], required=not has_neoplasm)  # the gmsh .msh file
    dim = tab.get(SCENE_TABLE["dimension"], why=" (2 for plane strain or 3)")
    if dim not in (2, 3):
        raise tab.error("dimension", f"must be 2 (plane strain) or 3, got {dim}")
    return name, None if mesh is None else _mesh_path(tab, mesh, path), dim


def _growth_only_scene(
    doc: dict[str, Any], path: Path, name: str, mesh_path: Path | None, dim: int
) -> Scene:
    """A scene with ``[neoplasm]`` and no ``[analysis]``: the growth runs alone."""
    _reject_mechanics_tables(doc)
    neoplasm = read_neoplasm(doc, mesh_path is not None, has_analysis=False)
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
        output=_read_output(doc, dim),
        raw=doc,
        neoplasm=neoplasm,
    )


def _mechanics_scene(
    doc: dict[str, Any],
    path: Path,
    name: str,
    mesh_path: Path | None,
    dim: int,
    allow: tuple[bool, bool],
) -> Scene:
    """A scene with an ``[analysis]`` (with ``[neoplasm]``: a coupled scene, run by
    :mod:`bonecontact.runners.coupled`, 2D and 3D).  ``allow``: contact, friction."""
    analysis = _read_analysis(doc)
    if mesh_path is None:
        raise SceneError(
            None,
            "[scene]",
            "mesh",
            "missing required key (a scene with an [analysis] needs a mesh)",
        )
    static = analysis.kind == "static"
    solver = _read_solver(doc)
    materials = _read_materials(doc, dim, analysis.kind == "dynamic")
    contacts = _read_contacts(doc, *allow)
    dirichlet = _read_dirichlet(doc, dim, static)
    loads = _read_loads(doc, dim, static)
    initial_velocities = _read_initial_velocities(doc, dim)
    output = _read_output(doc, dim)
    neoplasm = read_neoplasm(doc, True, has_analysis=True)
    fracture, cracks = read_fracture(doc, dim, materials, neoplasm is not None)
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


def _read_document(
    doc: dict[str, Any], path: Path, allow_contact: bool, allow_friction: bool = False
) -> Scene:
    """The scene of a parsed TOML document (errors without the file name)."""
    _check_format(doc)
    has_neoplasm = "neoplasm" in doc
    name, mesh_path, dim = _read_scene_table(doc, path, has_neoplasm)
    if has_neoplasm and "analysis" not in doc:  # growth-only scene
        return _growth_only_scene(doc, path, name, mesh_path, dim)
    return _mechanics_scene(doc, path, name, mesh_path, dim, (allow_contact, allow_friction))


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
    with collect_deprecations() as notices:
        try:
            return _read_document(doc, p, allow_contact, allow_friction)
        except SceneError as exc:
            raise exc.with_file(shown) from None
        finally:
            for text in notices:
                warnings.warn(f"{shown}: {text}", SceneDeprecationWarning, stacklevel=2)
