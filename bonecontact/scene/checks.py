"""Checks of a scene against its mesh (physical-group names, dimensions, overlaps) and
plausibility checks of its numbers (unit slips).

:func:`check_against_mesh` runs, once the mesh has been read, every check that needs the
mesh's physical groups; each problem is a :class:`~bonecontact.scene.errors.SceneError`
naming the file, the table and the key, and listing the available names of the right
dimension.

:func:`check_plausibility` compares the numbers of a valid scene with what a bone model can
mean: each material's moduli, density and strengths against the ranges of biological and
implant materials (``data/plausibility.toml``, with their sources), the mesh's size against
the size of a bone, and an elastic estimate of the strain each load causes.  Each finding is a
:class:`PlausibilityIssue` naming the table, the key, the value and the likely unit slip ("E =
17 Pa: did you mean 17 GPa?"); the runners emit them as :class:`PlausibilityWarning`.
"""

from __future__ import annotations

import math
import tomllib
import warnings
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bonecontact.common.errors import ParameterError
from bonecontact.common.resources import data_dir
from bonecontact.materials.laws import Isotropic, Material, Orthotropic, TransverselyIsotropic
from bonecontact.scene.crack_region import check_crack_region
from bonecontact.scene.errors import SceneError, table_label
from bonecontact.scene.spec import LOAD_KINDS, MaterialSpec, Scene

__all__ = [
    "LOAD_STRAIN_LIMIT",
    "MESH_SIZE_RANGE",
    "MODULUS_FLOOR",
    "PLAUSIBILITY_FILE",
    "SMALL_STRAIN_LIMIT",
    "MeshGroups",
    "PlausibilityIssue",
    "PlausibilityWarning",
    "RangeClass",
    "check_against_mesh",
    "check_crack_groups",
    "check_cracks_in_mesh",
    "check_load_strains",
    "check_material_ranges",
    "check_mesh_scale",
    "check_plausibility",
    "emit",
    "implausible_allowed",
    "load_plausibility_ranges",
    "material_class",
    "unit_slip_hint",
]


class MeshGroups:
    """The physical groups of a mesh, looked up on behalf of a scene file.

    Parameters
    ----------
    file
        The scene file (for messages).
    groups
        Physical-group name → ``(dim, tag)``.
    tdim
        Topological dimension of the mesh (cells); facets have ``tdim - 1``.
    """

    def __init__(self, file: str, groups: Mapping[str, tuple[int, int]], tdim: int):
        self.file = file
        self.groups = groups
        self.tdim = tdim
        self.fdim = tdim - 1

    def available(self, dim: int) -> str:
        """The names of the groups of dimension ``dim``, quoted, for messages."""
        names = sorted(n for n, (d, _) in self.groups.items() if d == dim)
        return ", ".join(f'"{n}"' for n in names) if names else "(none)"

    def require(self, name: str, dim: int, table: str, key: str) -> int:
        """The tag of group ``name``, which must exist and have dimension ``dim``."""
        kind = "cell" if dim == self.tdim else "facet"
        if name not in self.groups:
            raise SceneError(
                self.file,
                table,
                key,
                f'the mesh has no physical group "{name}"; '
                f"its {kind} groups are: {self.available(dim)}",
            )
        d, tag = self.groups[name]
        if d != dim:
            other = {self.tdim: "cell", self.fdim: "facet"}.get(d, f"dimension-{d}")
            raise SceneError(
                self.file,
                table,
                key,
                f'"{name}" is a {other} group (dim {d}), a {kind} group '
                f"(dim {dim}) is needed; {kind} groups: {self.available(dim)}",
            )
        return tag

    def cell(self, name: str, table: str, key: str) -> int:
        """The tag of the cell group ``name``."""
        return self.require(name, self.tdim, table, key)

    def facet(self, name: str, table: str, key: str) -> int:
        """The tag of the facet group ``name``."""
        return self.require(name, self.fdim, table, key)


def check_against_mesh(
    scene: Scene, groups: Mapping[str, tuple[int, int]], tdim: int, gdim: int
) -> None:
    """Check the scene's physical-group names against the mesh.

    Parameters
    ----------
    scene
        A scene from :func:`~bonecontact.scene.reader.load_scene`.
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
    check_dimension(scene, tdim, gdim)
    mesh = MeshGroups(str(scene.path), groups, tdim)
    owner = check_material_regions(scene, mesh)
    check_neoplasm_groups(scene, mesh)
    cavity = check_cyst_cavity(scene, mesh, owner)
    check_cells_have_material(scene, mesh, owner, cavity)
    check_contact_surfaces(scene, mesh)
    fixed = check_dirichlet_boundaries(scene, mesh)
    check_load_targets(scene, mesh, fixed)
    check_initial_velocity_regions(scene, mesh)
    check_crack_groups(scene, mesh)


def check_dimension(scene: Scene, tdim: int, gdim: int) -> None:
    """The mesh's topological and geometric dimensions equal ``[scene].dimension``."""
    if tdim != scene.dimension or gdim != scene.dimension:
        raise SceneError(
            str(scene.path),
            "[scene]",
            "dimension",
            f"is {scene.dimension} but the mesh ({scene.mesh_path.name}) has topological "
            f"dimension {tdim} and geometric dimension {gdim}",
        )


def check_material_regions(scene: Scene, mesh: MeshGroups) -> dict[int, str]:
    """Material regions are cell groups, no two materials share a tag.

    Returns
    -------
    dict
        Cell group tag → name of its material.
    """
    owner: dict[int, str] = {}
    for m in scene.materials:
        label = table_label("material", m.index, m.name)
        for r in m.regions:
            tag = mesh.cell(r, label, "regions")
            if tag in owner and owner[tag] != m.name:
                raise SceneError(
                    mesh.file,
                    label,
                    "regions",
                    f'region "{r}" (tag {tag}) has the same cells as a region of material '
                    f'"{owner[tag]}"',
                )
            owner[tag] = m.name
    return owner


def check_neoplasm_groups(scene: Scene, mesh: MeshGroups) -> None:
    """The ``[neoplasm]`` region and hosts are cell groups; no host has the region's tag."""
    neo = scene.neoplasm
    if neo is None or neo.region is None:
        return
    rtag = mesh.cell(neo.region, "[neoplasm]", "region")
    for h in neo.host:
        if mesh.cell(h, "[neoplasm]", "host") == rtag:
            raise SceneError(
                mesh.file,
                "[neoplasm]",
                "host",
                f'"{h}" has the same cells (tag {rtag}) as the neoplasm region "{neo.region}"',
            )


def check_crack_groups(scene: Scene, mesh: MeshGroups) -> None:
    """The region of every ``[[crack]]`` is a cell group (its geometry against the cells:
    :func:`check_cracks_in_mesh`)."""
    for i, c in enumerate(scene.cracks):
        mesh.cell(c.region, table_label("crack", i, c.name), "region")


def check_cracks_in_mesh(
    scene: Scene, msh: Any, cell_tags: Any, groups: Mapping[str, tuple[int, int]]
) -> None:
    """Every ``[[crack]]`` lies in the cells of its region (collective; raised on every rank).

    :func:`bonecontact.scene.crack_region.check_crack_region` samples each segment;
    a crack leaving the mesh, leaving its region or crossing another body, and a
    ``[fracture]`` increment not smaller than the region are a :class:`SceneError`.
    """
    increment = scene.fracture.increment if scene.fracture is not None else None
    for i, c in enumerate(scene.cracks):
        try:
            check_crack_region(c, msh, cell_tags, groups[c.region][1], increment)
        except ParameterError as exc:
            table = "[fracture]" if exc.key == "increment" else table_label("crack", i, c.name)
            message = str(exc).removeprefix(f"{exc.key}: ")
            raise SceneError(str(scene.path), table, exc.key, message) from None


def check_cyst_cavity(scene: Scene, mesh: MeshGroups, owner: Mapping[int, str]) -> str | None:
    """A coupled cyst (kind = "cyst" with ``[analysis]``) is a pressurised cavity: no material.

    Returns
    -------
    str or None
        The cyst region (a cavity of the mechanics), or ``None``.
    """
    neo = scene.neoplasm
    cavity = neo.region if neo is not None and neo.kind == "cyst" else None
    if cavity is not None and not scene.growth_only and mesh.groups[cavity][1] in owner:
        raise SceneError(
            mesh.file,
            "[[material]]",
            "regions",
            f'cell group "{cavity}" is the cyst of [neoplasm]: a pressurised cavity in the '
            f"mechanics, it takes no material; remove it from the regions of "
            f'"{owner[mesh.groups[cavity][1]]}"',
        )
    return cavity


def check_cells_have_material(
    scene: Scene, mesh: MeshGroups, owner: Mapping[int, str], cavity: str | None
) -> None:
    """Every cell group except the cyst cavity has a material (not needed without mechanics)."""
    if scene.growth_only:  # no mechanics: cell groups need no material
        return
    for name, (d, tag) in sorted(mesh.groups.items()):
        if d == mesh.tdim and tag not in owner and name != cavity:
            raise SceneError(
                mesh.file,
                "[[material]]",
                "regions",
                f'cell group "{name}" has no material; list it in the regions of a [[material]]',
            )


def check_contact_surfaces(scene: Scene, mesh: MeshGroups) -> None:
    """Contact slave and master are distinct facet groups."""
    for i, c in enumerate(scene.contacts):
        label = table_label("contact", i, c.name)
        s = mesh.facet(c.slave, label, "slave")
        if mesh.facet(c.master, label, "master") == s:
            raise SceneError(
                mesh.file, label, "master", f'"{c.master}" and "{c.slave}" are the same facet group'
            )


def check_dirichlet_boundaries(scene: Scene, mesh: MeshGroups) -> dict[tuple[int, int], int]:
    """Dirichlet boundaries are facet groups; each component of a boundary is fixed once.

    Returns
    -------
    dict
        ``(facet tag, component)`` → index of the ``[[dirichlet]]`` entry fixing it.
    """
    fixed: dict[tuple[int, int], int] = {}
    for i, bc in enumerate(scene.dirichlet):
        label = table_label("dirichlet", i)
        tag = mesh.facet(bc.boundary, label, "boundary")
        for comp in bc.components:
            if (tag, comp) in fixed:
                j = fixed[(tag, comp)]
                raise SceneError(
                    mesh.file,
                    label,
                    "value",
                    f'component {comp + 1} of boundary "{bc.boundary}" is already fixed by '
                    f'[[dirichlet]] #{j + 1} (boundary "{scene.dirichlet[j].boundary}"); '
                    "each component of a boundary may be fixed once",
                )
            fixed[(tag, comp)] = i
    return fixed


def check_load_targets(
    scene: Scene, mesh: MeshGroups, fixed: Mapping[tuple[int, int], int]
) -> None:
    """Body forces act on cell groups, tractions and pressures on facet groups; a
    traction loads only the free components of its boundary."""
    counters = {k: 0 for k in LOAD_KINDS}
    for load in scene.loads:
        label = table_label(load.kind, counters[load.kind])
        counters[load.kind] += 1
        if load.kind == "body_force":
            for r in load.target:
                mesh.cell(r, label, "regions")
            continue
        tag = mesh.facet(load.target[0], label, "boundary")
        if load.kind in ("traction", "force"):
            assert isinstance(load.value, tuple)
            for comp, v in enumerate(load.value):
                if v != 0.0 and (tag, comp) in fixed:
                    raise SceneError(
                        mesh.file,
                        label,
                        "value",
                        f'component {comp + 1} of boundary "{load.target[0]}" is fixed by '
                        f"[[dirichlet]] #{fixed[(tag, comp)] + 1}; a boundary carries loads only "
                        "in its free components",
                    )


def check_initial_velocity_regions(scene: Scene, mesh: MeshGroups) -> None:
    """Initial-velocity regions are cell groups."""
    for i, iv in enumerate(scene.initial_velocities):
        label = table_label("initial_velocity", i)
        for r in iv.regions:
            mesh.cell(r, label, "regions")


# ======================================================================================
# plausibility (unit slips): warnings, not errors
# ======================================================================================
#: The table of plausible material ranges, with their sources (package data).
PLAUSIBILITY_FILE = data_dir() / "plausibility.toml"
#: Smallest and largest extent (m) of a mesh that can be a bone or a piece of one; a mesh
#: outside is a unit slip beyond doubt (an error unless implausible values are allowed).
MESH_SIZE_RANGE = (1.0e-4, 2.0)
#: A Young's or shear modulus below this (Pa) is a unit slip beyond doubt (softer than
#: any tissue a bone model holds: bone marrow and fat are ~1-10 kPa and above).
MODULUS_FLOOR = 1.0e3
#: The small-strain model's limit on the principal strain: the error of the linear strain
#: against the Green-Lagrange strain is ε/2 relative, 5 % here (bonecontact.scene.validity;
#: docs/scene_format.md, "Validity of the model").  The same limit before the run
#: (:data:`LOAD_STRAIN_LIMIT`, an elastic estimate) and after it (the computed strain).
SMALL_STRAIN_LIMIT = 0.10
#: An elastic strain estimate above this warns before solving (the model is small-strain).
LOAD_STRAIN_LIMIT = SMALL_STRAIN_LIMIT

_PREFIXES = {1e3: "k", 1e6: "M", 1e9: "G"}
#: Strength keys of a material table (Pa), as in data/materials.toml [strength.*].
STRENGTH_KEYS = ("sigma_t", "sigma_c")


class PlausibilityWarning(UserWarning):
    """A scene value is valid but implausible for a bone model (a likely unit slip)."""


@dataclass(frozen=True)
class PlausibilityIssue:
    """One implausible value of a scene.

    Parameters
    ----------
    table
        The table it is in (``[[material]] #1 "bone"``, ``[scene]``, ``[[traction]] #1``).
    key
        The key, or ``None``.
    message
        What is implausible and the likely slip.
    certain
        A unit slip beyond doubt (:data:`MESH_SIZE_RANGE`, :data:`MODULUS_FLOOR`): an error
        (:func:`emit`) unless implausible values are allowed (:func:`implausible_allowed`).
    """

    table: str
    key: str | None
    message: str
    certain: bool = False  # a unit slip beyond doubt: an error unless allowed

    def __str__(self) -> str:
        where = self.table if self.key is None else f"{self.table} {self.key}"
        return f"{where}: {self.message}"


@dataclass(frozen=True)
class RangeClass:
    """Plausible ranges of one class of materials (a table of ``data/plausibility.toml``).

    Parameters
    ----------
    name
        Class name (``cortical_bone``, ``titanium``...; ``any`` for the envelope).
    keywords
        Lower-case words that put a material into the class by its name or regions.
    modulus, rho, strength
        ``(low, high)`` in Pa, kg/m³ and Pa.
    source
        Where the ranges come from.
    """

    name: str
    keywords: tuple[str, ...]
    modulus: tuple[float, float]
    rho: tuple[float, float]
    strength: tuple[float, float]
    source: str

    @classmethod
    def from_table(cls, name: str, table: Mapping) -> RangeClass:
        """From a TOML table with ``keywords``, ``modulus``, ``rho``, ``strength``, ``source``."""
        pair = lambda k: (float(table[k][0]), float(table[k][1]))  # noqa: E731
        words = tuple(str(w).lower() for w in table.get("keywords", ()))
        return cls(name, words, pair("modulus"), pair("rho"), pair("strength"), table["source"])


def load_plausibility_ranges(
    path: str | Path | None = None,
) -> tuple[tuple[RangeClass, ...], RangeClass]:
    """The material classes of ``data/plausibility.toml`` (file order) and the envelope."""
    source = PLAUSIBILITY_FILE if path is None else Path(path)
    with source.open("rb") as f:
        doc = tomllib.load(f)
    classes = tuple(RangeClass.from_table(n, t) for n, t in doc["class"].items())
    return classes, RangeClass.from_table("any", doc["any"])


def material_class(
    spec: MaterialSpec, classes: Sequence[RangeClass], default: RangeClass
) -> RangeClass:
    """The class of a material: the first whose keyword is in its name, else in a region."""
    for names in ((spec.name,), spec.regions):
        for c in classes:
            if any(w in n.lower() for n in names for w in c.keywords):
                return c
    return default


def _moduli(material: Material) -> dict[str, float]:
    """The Young's and shear moduli of a material law, by scene key."""
    if isinstance(material, Isotropic):
        keys: tuple[str, ...] = ("E",)
    elif isinstance(material, TransverselyIsotropic):
        keys = ("E_p", "E_a", "G_pa")
    elif isinstance(material, Orthotropic):
        keys = ("E1", "E2", "E3", "G12", "G13", "G23")
    else:  # pragma: no cover - every law of the scene format is listed above
        keys = ()
    return {k: float(getattr(material, k)) for k in keys}


def young_modulus(material: Material) -> float:
    """The smallest Young's modulus of a material law (Pa): the softest direction."""
    return min(v for k, v in _moduli(material).items() if not k.startswith("G"))


def _strengths(scene: Scene, spec: MaterialSpec) -> dict[str, float]:
    """Strengths of the material's table (``sigma_t``, ``sigma_c`` and any key whose name
    contains "strength") that are numbers."""
    entries = scene.raw.get("material", [])
    entry = entries[spec.index] if spec.index < len(entries) else {}
    return {
        k: float(v)
        for k, v in entry.items()
        if (k in STRENGTH_KEYS or "strength" in k)
        and isinstance(v, (int, float))
        and not isinstance(v, bool)
    }


def _fmt(v: float) -> str:
    return f"{v:.4g}"


def unit_slip_hint(value: float, low: float, high: float, unit: str) -> str:
    """The likely unit slip of ``value`` (``unit`` is SI) given its plausible range.

    Too small: the SI prefixes (k, M, G) that would bring it into the range, or for a density
    the g/cm³ reading.  Too large: the powers of 10³ that would bring it back.
    """
    if unit == "kg/m³":
        if value < low and low <= value * 1e3 <= high:
            return f"did you mean {_fmt(value)} g/cm³ ({_fmt(value * 1e3)} kg/m³)?"
        if value > high and low <= value * 1e-3 <= high:
            return f"did you mean {_fmt(value * 1e-3)} kg/m³ (the value looks like g/m³)?"
        return ""
    if value < low:
        fits = [p for f, p in _PREFIXES.items() if low <= value * f <= high]
        if fits:
            return "did you mean " + " or ".join(f"{_fmt(value)} {p}{unit}" for p in fits) + "?"
        return ""
    fits = [f for f in _PREFIXES if low <= value / f <= high]
    if fits:
        alts = " or ".join(f"{_fmt(value / f)} {unit}" for f in fits)
        return f"did you mean {alts} (the value looks {_PREFIXES[fits[0]]}-times too large)?"
    return ""


def _range_issue(
    label: str,
    key: str,
    value: float,
    bounds: tuple[float, float],
    unit: str,
    cls: RangeClass,
    certain: bool = False,
) -> PlausibilityIssue | None:
    """The finding of ``value`` outside ``bounds`` (``certain``: a modulus below the floor,
    reported even inside the class's range)."""
    low, high = bounds
    if low <= value <= high:
        return _floor_issue(label, key, value) if certain else None
    kind = "materials" if cls.name == "any" else cls.name.replace("_", " ")
    hint = unit_slip_hint(value, low, high, unit)
    msg = (
        f"{key} = {_fmt(value)} {unit}{': ' + hint if hint else ' is implausible'} "
        f"(plausible for {kind}: "
        f"{_fmt(low)}-{_fmt(high)} {unit}; data/plausibility.toml [{cls.name}], "
        f"{cls.source.split(';')[0]})"
    )
    return PlausibilityIssue(label, key, msg, certain)


def _floor_issue(label: str, key: str, value: float) -> PlausibilityIssue:
    """A modulus below :data:`MODULUS_FLOOR` that its class's range lets through."""
    msg = (
        f"{key} = {_fmt(value)} Pa is below {_fmt(MODULUS_FLOOR / 1e3)} kPa, softer than any "
        f"tissue of a bone model: is it in the unit you meant? The scene is in SI units (Pa)"
    )
    return PlausibilityIssue(label, key, msg, True)


def check_material_ranges(
    scene: Scene, ranges: tuple[Sequence[RangeClass], RangeClass] | None = None
) -> list[PlausibilityIssue]:
    """Each material's moduli, density and strengths against the range of its class.

    Parameters
    ----------
    scene
        A scene from :func:`~bonecontact.scene.reader.load_scene`.
    ranges
        Classes and envelope (default :func:`load_plausibility_ranges`).

    Returns
    -------
    list of PlausibilityIssue
        One per value outside its class's range, with the likely unit slip.
    """
    classes, default = load_plausibility_ranges() if ranges is None else ranges
    issues: list[PlausibilityIssue] = []
    for spec in scene.materials:
        cls = material_class(spec, classes, default)
        label = table_label("material", spec.index, spec.name)
        values = [(k, v, cls.modulus, "Pa") for k, v in _moduli(spec.material).items()]
        if spec.material.rho is not None:
            values.append(("rho", float(spec.material.rho), cls.rho, "kg/m³"))
        values += [(k, v, cls.strength, "Pa") for k, v in _strengths(scene, spec).items()]
        moduli = _moduli(spec.material)
        for key, value, bounds, unit in values:
            floor = key in moduli and value < MODULUS_FLOOR  # a slip beyond doubt
            issue = _range_issue(label, key, value, bounds, unit, cls, floor)
            if issue is not None:
                issues.append(issue)
    return issues


def check_mesh_scale(scene: Scene, extent: Sequence[float]) -> list[PlausibilityIssue]:
    """The mesh's bounding box against the size of a bone (:data:`MESH_SIZE_RANGE`).

    Parameters
    ----------
    scene
        The scene (for the mesh name).
    extent
        Size of the mesh's bounding box along each axis (m).
    """
    size = max(extent)
    low, high = MESH_SIZE_RANGE
    name = scene.mesh_path.name if scene.mesh_path is not None else "mesh"
    if size > high:
        msg = (
            f"the mesh {name} is {_fmt(size)} m across (a bone is smaller than {_fmt(high)} m): "
            f"is the mesh in millimetres? The scene is in SI units (metres); scale the mesh "
            f"coordinates by 1e-3 (it would be {_fmt(size * 1e-3)} m)"
        )
    elif size < low:
        msg = (
            f"the mesh {name} is {_fmt(size)} m across (less than {_fmt(low * 1e3)} mm): "
            f"is the mesh in the unit you meant? The scene is in SI units (metres)"
        )
    else:
        return []
    return [PlausibilityIssue("[scene]", "mesh", msg, certain=True)]


def _soft(scene: Scene, names: Sequence[str]) -> tuple[float, str]:
    """The smallest Young's modulus among materials ``names`` (all when empty) and its name."""
    specs = [m for m in scene.materials if m.name in names] or list(scene.materials)
    m = min(specs, key=lambda s: young_modulus(s.material))
    return young_modulus(m.material), m.name


def _peak(schedule_factors: Sequence[float]) -> float:
    return max(abs(f) for f in schedule_factors)


def _load_strains(
    scene: Scene, size: float, adjacent: Mapping[str, Sequence[str]]
) -> list[tuple[str, str, float, str]]:
    """(table, key, strain estimate, how) of each load, prescribed displacement and velocity."""
    out = []
    counters = {k: 0 for k in LOAD_KINDS}
    for load in scene.loads:
        label = table_label(load.kind, counters[load.kind])
        counters[load.kind] += 1
        peak = _peak(load.schedule.factors)
        if load.kind == "force":  # N, not Pa: its traction needs the group's area (the model)
            continue
        if load.kind == "body_force":
            regions = [r for r in load.target if r in scene.cell_regions]
            E, name = _soft(scene, [scene.material_of(r).name for r in regions])
            mag = math.hypot(*load.value) * peak * size
            how = f"|b| L = {_fmt(mag)} Pa over a body {_fmt(size)} m long"
        else:
            E, name = _soft(scene, adjacent.get(load.target[0], ()))
            vec = load.value if isinstance(load.value, tuple) else (load.value,)
            mag = math.hypot(*vec) * peak
            how = f"|{'t' if load.kind == 'traction' else 'p'}| = {_fmt(mag)} Pa"
        out.append((label, "value", mag / E, f'{how} on E = {_fmt(E)} Pa of "{name}"'))
    for i, bc in enumerate(scene.dirichlet):
        u = math.hypot(*(v for v in bc.value if v is not None)) * _peak(bc.schedule.factors)
        how = f"|u| = {_fmt(u)} m over a mesh {_fmt(size)} m across"
        out.append((table_label("dirichlet", i), "value", u / size, how))
    for i, iv in enumerate(scene.initial_velocities):
        for s in {
            scene.material_of(r).name: scene.material_of(r)
            for r in iv.regions
            if r in scene.cell_regions
        }.values():
            if s.material.rho:
                c = math.sqrt(young_modulus(s.material) / s.material.rho)
                v = math.hypot(*iv.value)
                how = f'v/c with |v| = {_fmt(v)} m/s, wave speed c = {_fmt(c)} m/s in "{s.name}"'
                out.append((table_label("initial_velocity", i), "value", v / c, how))
    return out


def check_load_strains(
    scene: Scene,
    extent: Sequence[float],
    adjacent: Mapping[str, Sequence[str]],
    limit: float = LOAD_STRAIN_LIMIT,
) -> list[PlausibilityIssue]:
    """An elastic estimate of the strain of each load against the small-strain limit.

    The estimates: traction or pressure / the softest Young's modulus next to the loaded
    boundary; body force × mesh size / the softest modulus of its regions; prescribed
    displacement / mesh size; initial velocity / elastic wave speed.  Each at the peak of its
    schedule.

    Parameters
    ----------
    scene
        The scene.
    extent
        Size of the mesh's bounding box along each axis (m).
    adjacent
        Facet group → names of the materials of the cells next to it.
    limit
        Strain above which an estimate is reported.
    """
    size = max(extent)
    issues = []
    for label, key, strain, how in _load_strains(scene, size, adjacent):
        if strain > limit:
            msg = (
                f"an elastic estimate of the strain is {_fmt(strain)} ({how}), more than "
                f"{limit:.0%}: the model is small-strain; check the units of the load, the "
                f"moduli and the mesh"
            )
            issues.append(PlausibilityIssue(label, key, msg))
    return issues


def check_plausibility(
    scene: Scene,
    extent: Sequence[float] | None = None,
    adjacent: Mapping[str, Sequence[str]] | None = None,
) -> list[PlausibilityIssue]:
    """All plausibility checks of a scene (materials; with ``extent``, mesh size and loads).

    Parameters
    ----------
    scene
        A scene from :func:`~bonecontact.scene.reader.load_scene`.
    extent
        Size of the mesh's bounding box along each axis (m); ``None`` skips the checks that
        need the mesh.
    adjacent
        Facet group → names of the materials next to it (default: every material).

    Returns
    -------
    list of PlausibilityIssue
        Empty for a plausible scene.
    """
    issues = check_material_ranges(scene)
    if extent is not None and scene.materials:
        issues += check_mesh_scale(scene, extent)
        issues += check_load_strains(scene, extent, adjacent or {})
    return issues


#: Whether unit slips beyond doubt are allowed (:func:`implausible_allowed`).
_ALLOW_IMPLAUSIBLE: ContextVar[bool] = ContextVar("allow_implausible", default=False)


@contextmanager
def implausible_allowed(allow: bool = True) -> Iterator[None]:
    """Within this context, unit slips beyond doubt only warn (``bonecontact run
    --allow-implausible``); outside it, :func:`emit` raises them as a :class:`SceneError`.

    Examples
    --------
    >>> with implausible_allowed():  # doctest: +SKIP
    ...     run_scene(load_scene("scene_with_E_in_GPa_numbers.toml"))
    """
    token = _ALLOW_IMPLAUSIBLE.set(allow)
    try:
        yield
    finally:
        _ALLOW_IMPLAUSIBLE.reset(token)


def _refuse_certain(file: str | Path | None, certain: Sequence[PlausibilityIssue]) -> None:
    """One :class:`SceneError` for the unit slips beyond doubt."""
    advice = "a unit slip beyond doubt; --allow-implausible runs it anyway"
    if len(certain) == 1:
        c = certain[0]
        raise SceneError(file, c.table, c.key, f"{c.message} ({advice})")
    listed = "\n".join(f"  - {c}" for c in certain)
    raise SceneError(file, None, None, f"{len(certain)} implausible values ({advice}):\n{listed}")


def emit(issues: Sequence[PlausibilityIssue], file: str | Path | None = None) -> None:
    """Report a scene's findings on every rank (they are the same on every rank).

    The unit slips beyond doubt (``certain``) raise a :class:`SceneError` naming ``file``,
    unless :func:`implausible_allowed`; the other findings (and the allowed certain ones)
    make one :class:`PlausibilityWarning` listing them all (so that an ``"error"`` warnings
    filter, ``--strict``, raises on every rank at the same point).
    """
    certain = [i for i in issues if i.certain]
    if certain and not _ALLOW_IMPLAUSIBLE.get():
        _refuse_certain(file, certain)
    if not issues:
        return
    if len(issues) == 1:
        text = f"implausible value: {issues[0]}"
    else:
        text = f"{len(issues)} implausible values:\n" + "\n".join(f"  - {i}" for i in issues)
    warnings.warn(text, PlausibilityWarning, stacklevel=3)
