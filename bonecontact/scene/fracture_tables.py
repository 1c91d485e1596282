"""Reading ``[fracture]`` and ``[[crack]]`` (docs/scene_format.md, *Fracture*).

The keys are declared in :mod:`bonecontact.scene.spec` (:data:`FRACTURE_TABLE`,
:data:`CRACK_TABLE`, :data:`CRACK3D_TABLE`) and read like every other table; the crack
geometry is built and checked by the fracture physics
(:class:`~bonecontact.fracture.crack.Crack2D`,
:func:`~bonecontact.fracture.crack3d.planar_crack_from_table`), whose
:class:`~bonecontact.common.errors.ParameterError` is reported as a
:class:`~bonecontact.scene.errors.SceneError` naming the table and the key.  The old
spelling ``friction = <number>`` of the Coulomb coefficient is read as ``coefficient``
with a deprecation warning.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.crack import Crack2D, crack_gap, points_in_polygon
from bonecontact.fracture.crack3d import (
    PlanarCrack,
    SurfaceBreakingCrack,
    planar_crack_from_table,
)
from bonecontact.scene.errors import SceneError, describe_value, table_label
from bonecontact.scene.spec import (
    CRACK3D_TABLE,
    CRACK_TABLE,
    FATIGUE_TABLE,
    FRACTURE_TABLE,
    MAX_END_HALVINGS,
    MAX_KINK_LIMIT_DEG,
    CrackSpec,
    FatigueSpec,
    FractureSpec,
    MaterialSpec,
)
from bonecontact.scene.tables import TableReader, array_of_tables, table_of

__all__ = [
    "crack_from_table",
    "fatigue_from_table",
    "fracture_from_table",
    "missing_strength",
    "planar_cracks_meet",
    "read_fracture",
]


def _fracture_error(tab: TableReader, exc: ParameterError) -> SceneError:
    """A ParameterError of the physics as a SceneError on ``tab`` (without its ``key:``)."""
    text = str(exc)
    prefix = f"{exc.key}: "
    return tab.error(exc.key, text[len(prefix) :] if text.startswith(prefix) else text)


def fatigue_from_table(tab: TableReader) -> FatigueSpec | None:
    """``[fracture.fatigue]`` of the ``[fracture]`` table ``tab`` (``None``: absent).

    Raises
    ------
    SceneError
        Naming ``[fracture.fatigue]`` and the key (``[fracture]`` ``fatigue`` if it is
        not a table, or given with ``propagate = true``).
    """
    if not tab.has("fatigue"):
        return None
    value = tab.data["fatigue"]
    if not isinstance(value, dict):
        raise tab.error(
            "fatigue", f"must be a table [fracture.fatigue], got {describe_value(value)}"
        )
    sub = TableReader(value, "[fracture.fatigue]")
    sub.check_keys(FATIGUE_TABLE)
    values = {k: sub.get(FATIGUE_TABLE[k]) for k in FATIGUE_TABLE.names}
    if not values["R"] < 1.0:
        raise sub.error("R", f"the load ratio K_min/K_max must be < 1, got {values['R']!r}")
    if values["end_halvings"] > MAX_END_HALVINGS:
        raise sub.error(
            "end_halvings",
            f"must be an integer 0 … {MAX_END_HALVINGS}, got {values['end_halvings']!r}",
        )
    return FatigueSpec(**values)


def fracture_from_table(table: Mapping[str, Any], label: str = "[fracture]") -> FractureSpec:
    """``[fracture]``; ``increment`` is required when ``propagate = true``,
    ``initiation_length`` and ``coefficient`` apply with ``initiate = true`` only;
    ``[fracture.fatigue]`` (:func:`fatigue_from_table`) excludes ``propagate = true``.

    Raises
    ------
    SceneError
        Naming the table and the key (the file is added by ``load_scene``).
    """
    tab = TableReader(table, label)
    tab.check_keys(FRACTURE_TABLE)
    values = {k: tab.get(FRACTURE_TABLE[k]) for k in ("criterion", "direction", "propagate")}
    values["increment"] = tab.get(FRACTURE_TABLE["increment"])
    if values["propagate"] and values["increment"] is None:
        raise tab.error("increment", "is required when propagate = true")
    values["max_increments"] = tab.get(FRACTURE_TABLE["max_increments"])
    values["initiate"] = tab.get(FRACTURE_TABLE["initiate"])
    for key in ("initiation_length", "coefficient"):
        if tab.has(key) and not values["initiate"]:
            raise tab.error(key, "applies to an initiated crack only: set initiate = true")
    for key in ("tip_size", "tip_grading", "initiation_length", "coefficient"):
        values[key] = tab.get(FRACTURE_TABLE[key])
    values["fatigue"] = fatigue_from_table(tab)
    values["joined"] = tab.get(FRACTURE_TABLE["joined"])
    values["breakthrough"] = tab.get(FRACTURE_TABLE["breakthrough"])
    if values["breakthrough"] != "stop" and not (values["propagate"] or values["fatigue"]):
        raise tab.error(
            "breakthrough",
            "applies to a growing crack: set propagate = true or add [fracture.fatigue]",
        )
    values["max_kink_deg"] = _max_kink(tab)
    values["stop_out_of_plane"] = tab.get(FRACTURE_TABLE["stop_out_of_plane"])
    values["surface_growth"] = tab.get(FRACTURE_TABLE["surface_growth"])
    if values["fatigue"] is not None and values["propagate"]:
        raise tab.error(
            "propagate",
            "[fracture.fatigue] grows the crack by cycles; propagate = true (growth when "
            "K_eq reaches K_Ic under one load) is the other rule: give one of them",
        )
    return FractureSpec(**values)


def _max_kink(tab: TableReader) -> float:
    """``max_kink_deg``: an angle in degrees, 0 < value ≤ 90."""
    key = FRACTURE_TABLE["max_kink_deg"]
    value = tab.number(key.name, default=key.default)
    if not 0.0 < value <= MAX_KINK_LIMIT_DEG:
        raise tab.error(
            key.name,
            f"the largest kink angle of the planar model must be in 0 < {key.name} <= "
            f"{MAX_KINK_LIMIT_DEG:g} (degrees), got {tab.data[key.name]!r}",
        )
    return value


#: The keys of the validity of a crack grown in its plane (a 3D surface crack).
OUT_OF_PLANE_KEYS = ("max_kink_deg", "stop_out_of_plane")


def _check_out_of_plane(
    tab: TableReader | None, spec: FractureSpec, dim: int, cracks: Sequence[CrackSpec]
) -> None:
    """``max_kink_deg`` and ``stop_out_of_plane`` apply where a crack grows in its plane:
    a growing semi-elliptical surface crack of a 3D scene, or the surface phase of
    ``breakthrough = "surface_crack"`` (a growing interior 3D crack follows its σ₁′ kink,
    a 2D crack its kink angle: nothing for them to flag)."""
    if tab is None:
        return
    surface = any(isinstance(c.crack, SurfaceBreakingCrack) for c in cracks)
    planar = dim == 3 and spec.grows and (surface or spec.breakthrough == "surface_crack")
    for key in OUT_OF_PLANE_KEYS:
        if tab.has(key) and not planar:
            raise tab.error(
                key,
                "applies to a crack grown in its plane: a growing semi-elliptical surface "
                '[[crack]] of a 3D scene (or breakthrough = "surface_crack"), with propagate '
                "= true or [fracture.fatigue]; an interior 3D crack turns by its kink and a "
                "2D crack by its direction",
            )


def _check_surface_growth(
    tab: TableReader | None, spec: FractureSpec, dim: int, cracks: Sequence[CrackSpec]
) -> None:
    """``surface_growth = "nonplanar"`` grows one semi-elliptical or quarter-elliptical
    (corner) surface crack of a 3D scene, with ``propagate = true`` or
    ``[fracture.fatigue]``."""
    if tab is None or spec.surface_growth == "planar":
        return
    surface = [
        c
        for c in cracks
        if isinstance(c.crack, SurfaceBreakingCrack)
        and c.crack.shape in ("semi_elliptical", "quarter_elliptical")
    ]
    if dim != 3 or len(cracks) != 1 or len(surface) != 1:
        raise tab.error(
            "surface_growth",
            '"nonplanar" grows one semi_elliptical or quarter_elliptical surface [[crack]] '
            "of a 3D scene (not an interior crack, a 2D crack or several cracks)",
        )
    if not spec.grows:
        raise tab.error(
            "surface_growth",
            '"nonplanar" applies to a growing crack: set propagate = true or add '
            "[fracture.fatigue]",
        )


def _check_end_halvings(tab: TableReader | None, spec: FractureSpec, dim: int) -> None:
    """``[fracture.fatigue] end_halvings`` > 0 applies to 3D cracks (interior, surface and
    non-planar surface growth), not to a 2D scene."""
    fat = spec.fatigue
    if tab is None or fat is None or fat.end_halvings == 0 or dim == 3:
        return
    raise SceneError(
        None,
        "[fracture.fatigue]",
        "end_halvings",
        "halves the blocks before a 3D crack runs through; a 2D crack stops `fractured` "
        "within da_max of the surface instead: set end_halvings = 0 (the default) here",
    )


def _crack3d(tab: TableReader, name: str) -> CrackSpec:
    """A planar 3D crack (disc, ellipse, polygon)."""
    for key in ("points", "tips"):
        if tab.has(key):
            raise tab.error(
                key,
                "a 3D crack is a planar disc or ellipse (shape, centre, normal, radius or "
                "semi_axes and axis) or polygon (vertices), not a polyline",
            )
    tab.check_keys(CRACK3D_TABLE)
    region = tab.get(CRACK3D_TABLE["region"])
    coefficient = tab.get(CRACK3D_TABLE["coefficient"])
    shape = tab.get(CRACK3D_TABLE["shape"])
    front_points = tab.get(CRACK3D_TABLE["front_points"])
    if not tab.has("front_points") and shape == "polygon":
        front_points = 1  # one K point per polygon edge
    try:
        crack = planar_crack_from_table(tab.data)
    except ParameterError as exc:
        raise _fracture_error(tab, exc) from None
    return CrackSpec(name, crack, region, coefficient, front_points)


def _crack2d(tab: TableReader, name: str) -> CrackSpec:
    """A 2D polyline crack."""
    tab.check_keys(CRACK_TABLE)
    points = tab.raw("points", True)
    region = tab.get(CRACK_TABLE["region"])
    coefficient = tab.get(CRACK_TABLE["coefficient"])
    tips = tab.get(CRACK_TABLE["tips"])
    try:
        arr = np.asarray(points, dtype=float)
    except (TypeError, ValueError):
        raise tab.error("points", "must be an array of [x, y] pairs (m)") from None
    try:
        crack = Crack2D(arr, tips)
    except ParameterError as exc:
        raise _fracture_error(tab, exc) from None
    return CrackSpec(name, crack, region, coefficient)


def crack_from_table(
    table: Mapping[str, Any], index: int = 1, dim: int = 2, label: str | None = None
) -> CrackSpec:
    """One ``[[crack]]`` (entry ``index`` counting from 1): in 2D a polyline ``points``,
    in 3D a planar disc, ellipse or convex polygon (``front_points``: 8 along a disc or
    ellipse, 1 per polygon edge by default).

    Raises
    ------
    SceneError
        Naming the table (``label``, default ``[[crack]] #index "name"``) and the key.
    """
    if label is None:
        label = table_label("crack", index - 1, table.get("name"))
    tab = TableReader(table, label)
    name = tab.get(CRACK_TABLE["name"]) or f"crack{index}"
    return _crack3d(tab, name) if dim == 3 else _crack2d(tab, name)


def missing_strength(spec: FractureSpec, strengths: Mapping[str, float]) -> str | None:
    """The first strength a material lacks for the check ``spec`` (``None``: none):
    σ_t always, σ_c with ``tension_compression``, K_Ic with propagation."""
    needed = ["sigma_t"]
    if spec.criterion == "tension_compression":
        needed.append("sigma_c")
    if spec.propagate:
        needed.append("K_Ic")
    for key in needed:
        v = strengths.get(key)
        if not isinstance(v, (int, float)) or not v > 0:
            return key
    return None


def _check_dimension(spec: FractureSpec, dim: int, cracks: Sequence[CrackSpec] = ()) -> None:
    """Automatic insertion runs in 2D only; propagation and fatigue in 2D, and in 3D with
    a ``[[crack]]`` (a semi-elliptical surface crack or planar interior cracks; issue
    26)."""
    allowed = {"propagate": bool(cracks), "fatigue": bool(cracks), "initiate": False}
    for key in ("propagate", "initiate", "fatigue"):
        if dim != 2 and getattr(spec, key) and not allowed[key]:
            raise SceneError(
                None,
                "[fracture]",
                key,
                "runs in 2D scenes, and in 3D with a [[crack]] (a semi-elliptical surface "
                "crack or planar interior cracks) in this version (3D otherwise: the "
                "risk; docs/theory/fracture.md)",
            )


def _check_breakthrough(spec: FractureSpec, dim: int, cracks: Sequence[CrackSpec]) -> None:
    """``breakthrough = "surface_crack"`` re-characterises one growing interior 3D crack."""
    if spec.breakthrough == "stop":
        return
    planar = [c for c in cracks if isinstance(c.crack, PlanarCrack)]
    if dim != 3 or len(cracks) != 1 or len(planar) != 1:
        raise SceneError(
            None,
            "[fracture]",
            "breakthrough",
            '"surface_crack" applies to a single growing interior (planar) [[crack]] of a 3D '
            'scene; use "stop" here (allowed values: "stop", "surface_crack")',
        )


def _check_materials(spec: FractureSpec, materials: Sequence[MaterialSpec]) -> None:
    """Every material has the strengths the check needs."""
    for m in materials:
        key = missing_strength(spec, m.strengths)
        if key is not None:
            raise SceneError(
                None,
                table_label("material", m.index, m.name),
                key,
                f"missing: the [fracture] check needs {key} (a positive number) of every "
                "material (values with sources: data/materials.toml [strength.*])",
            )


def read_fracture(
    doc: Mapping[str, Any], dim: int, materials: Sequence[MaterialSpec], has_neoplasm: bool
) -> tuple[FractureSpec | None, tuple[CrackSpec, ...]]:
    """``[fracture]`` (``None`` when absent and there is no crack) and the ``[[crack]]``
    entries of a mechanics scene."""
    tab = table_of(doc, "fracture", required=False)
    entries = array_of_tables(doc, "crack")
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
    spec = fracture_from_table(tab.data if tab is not None else {})
    if spec.fatigue is not None and has_neoplasm:
        raise SceneError(
            None, "[fracture]", "fatigue", "is not run in a coupled [neoplasm] scene yet"
        )
    if spec.fatigue is not None and not entries and not spec.initiate:
        raise SceneError(
            None,
            "[fracture]",
            "fatigue",
            "fatigue grows a crack: add a [[crack]] or set initiate = true",
        )
    cracks = [crack_from_table(entry, i + 1, dim) for i, entry in enumerate(entries)]
    _check_dimension(spec, dim, cracks)
    _check_breakthrough(spec, dim, cracks)
    _check_out_of_plane(tab, spec, dim, cracks)
    _check_surface_growth(tab, spec, dim, cracks)
    _check_end_halvings(tab, spec, dim)
    _check_materials(spec, materials)
    names = [c.name for c in cracks]
    for i, c in enumerate(cracks):
        if names.index(c.name) != i:
            raise SceneError(None, table_label("crack", i, c.name), "name", "is not unique")
    check_several(cracks, dim)
    return spec, tuple(cracks)


def check_several(cracks: Sequence[CrackSpec], dim: int) -> None:
    """Several ``[[crack]]`` tables: in 2D all in one region (one body) and no two that
    cross or touch; in 3D none whose surfaces cross or touch.

    Raises
    ------
    SceneError
        Naming the later table, the key (``region``; ``points`` in 2D, the size key in
        3D) and the earlier table.
    """
    for i, c in enumerate(cracks[1:], start=1):
        first = cracks[0]
        if dim == 2 and c.region != first.region:
            raise SceneError(
                None,
                table_label("crack", i, c.name),
                "region",
                f"{c.region!r}: the cracks of a 2D scene lie in one body, the region "
                f"{first.region!r} of {table_label('crack', 0, first.name)}",
            )
        for j in range(i):
            if cracks_meet(c.crack, cracks[j].crack):
                key = "points" if dim == 2 else c.crack.size_key
                raise SceneError(
                    None,
                    table_label("crack", i, c.name),
                    key,
                    f"crosses or touches {table_label('crack', j, cracks[j].name)}: "
                    "intersecting or overlapping cracks are not supported (give them apart)",
                )


def cracks_meet(a: Any, b: Any) -> bool:
    """Whether two cracks cross or touch: 2D polylines closer than 10⁻⁹ of their extent;
    3D planar cracks when one's surface reaches the other's (:func:`planar_cracks_meet`)."""
    if isinstance(a, Crack2D):
        return crack_gap(a, b) <= 0.0
    if not all(hasattr(c, "sample_points") for c in (a, b)):
        return surface_cracks_meet(a, b)
    return planar_cracks_meet(a, b) or planar_cracks_meet(b, a)


def surface_cracks_meet(a: Any, b: Any, gap: float = 0.0) -> bool:
    """Whether a surface-breaking crack may meet another crack (or come within ``gap`` of
    it, m), judged without the body (its mouth is cut by the runner): conservatively, when
    the balls of radius max(depth, half_length) about two surface cracks' centres come
    within ``gap``, or when a point covering a planar crack (``sample_points``) lies in a
    surface crack's ball widened by ``gap``."""
    surface = [c for c in (a, b) if not hasattr(c, "sample_points")]
    planar = [c for c in (a, b) if hasattr(c, "sample_points")]

    def ball(c: Any) -> tuple[np.ndarray, float]:
        return np.asarray(c.centre, dtype=float), max(float(c.depth), float(c.half_length))

    (ca, ra) = ball(surface[0])
    if len(surface) == 2:
        cb, rb = ball(surface[1])
        return bool(np.linalg.norm(ca - cb) <= (ra + rb + gap) * (1.0 + 1e-9))
    pts = planar[0].sample_points(16, 96)
    return bool(np.any(np.linalg.norm(pts - ca, axis=1) <= (ra + gap) * (1.0 + 1e-9)))


def planar_cracks_meet(a: Any, b: Any, rings: int = 16, per_ring: int = 96) -> bool:
    """Whether the planar crack ``a`` reaches the surface of the planar crack ``b``:
    points covering ``a`` (``sample_points``) that fall within ``b``'s outline when
    projected on its plane lie on both sides of it or on it (within 10⁻⁹ of the cracks'
    size).  The outline of ``b`` is its front as a polygon of ``per_ring`` points."""
    if not all(hasattr(c, "sample_points") for c in (a, b)):
        return False  # a surface-breaking crack: surface_cracks_meet
    c, R = np.asarray(b.centre, dtype=float), b.axes
    rel = (a.sample_points(rings, per_ring) - c) @ R.T  # (u, v, n) in b's frame
    front = b.front().point(np.linspace(0.0, 2 * np.pi, per_ring, endpoint=False))
    outline = (front - c) @ R.T
    inside = points_in_polygon(rel[:, :2], outline[:, :2])
    if not inside.any():
        return False
    d = rel[inside, 2]
    tol = 1e-9 * max(a.a, b.a)
    return bool(np.any(np.abs(d) <= tol) or (d.min() < 0.0 < d.max()))
