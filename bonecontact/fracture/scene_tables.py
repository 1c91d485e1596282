"""The fracture tables of a scene, parsed and checked (docs/theory/fracture.md#scene-tables).

``[fracture]`` chooses the criteria and the propagation; each ``[[crack]]`` is an initial
crack: a 2D polyline, or in 3D a planar disc, ellipse or convex polygon
(:class:`~bonecontact.fracture.crack3d.PlanarCrack`).  The functions here take the tables
as plain mappings (as read from TOML) and raise
:class:`~bonecontact.fracture.crack.FractureError` naming the offending key; the scene
reader turns that into its own error (exit code 2).  :func:`check_crack_region` checks a
crack against the mesh: every point of it must lie in cells of its region (a crack
outside its region or crossing another body is refused).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from mpi4py import MPI

import numpy as np
from dolfinx import geometry, mesh

from bonecontact.fracture.crack import Crack2D, FractureError
from bonecontact.fracture.crack3d import CRACK3D_KEYS, PlanarCrack, planar_crack_from_table
from bonecontact.fracture.criteria import RISK_CRITERIA

__all__ = [
    "CRACK_KEYS",
    "FRACTURE_KEYS",
    "CrackSpec",
    "FractureSpec",
    "check_crack_region",
    "check_strengths",
    "crack_from_table",
    "fracture_from_table",
]

#: Keys of the ``[fracture]`` table.
FRACTURE_KEYS = (
    "criterion",
    "direction",
    "propagate",
    "increment",
    "max_increments",
    "tip_size",
    "tip_grading",
    "initiate",
    "initiation_length",
    "friction",
)
#: Keys of a 2D ``[[crack]]`` table (3D: :data:`~bonecontact.fracture.crack3d.CRACK3D_KEYS`).
CRACK_KEYS = ("name", "points", "tips", "region", "friction")


@dataclass(frozen=True)
class FractureSpec:
    """The ``[fracture]`` table: initiation criterion, direction method, propagation, and
    the automatic insertion of a crack where the risk reaches 1 (``initiate``: its length
    ``initiation_length``, m, ``None``: the default of
    :func:`bonecontact.fracture.initiation.default_length`; ``friction``: the Coulomb
    coefficient of its face pair).  ``tip_grading`` ``None``: the default of the crack's
    dimension (0.25 at a 2D tip, 0.12 along a 3D front)."""

    criterion: str = "tension"
    direction: str = "mts"
    propagate: bool = False
    increment: float | None = None
    max_increments: int = 10
    tip_size: float | None = None
    tip_grading: float | None = None  # None: 0.25 for a 2D tip, 0.12 for a 3D front
    initiate: bool = False
    initiation_length: float | None = None
    friction: float = 0.0


@dataclass(frozen=True)
class CrackSpec:
    """A ``[[crack]]`` table: the crack, the region (cell group) it lies in, and the face
    friction coefficient of its contact pair (0: frictionless); in 3D the number of
    front points at which K is evaluated."""

    name: str
    crack: Crack2D | PlanarCrack
    region: str
    friction: float = 0.0
    front_points: int = 8


def _unknown(table: Mapping, allowed: Sequence[str]) -> None:
    for key in table:
        if key not in allowed:
            raise FractureError(key, f"unknown key; allowed: {', '.join(allowed)}")


def _positive(table: Mapping, key: str, default: float | None) -> float | None:
    v = table.get(key, default)
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise FractureError(key, f"must be a positive number (SI units), got {v!r}")
    return float(v)


def fracture_from_table(table: Mapping) -> FractureSpec:
    """Parse ``[fracture]``; ``increment`` is required when ``propagate = true``."""
    _unknown(table, FRACTURE_KEYS)
    criterion = table.get("criterion", "tension")
    if criterion not in RISK_CRITERIA:
        raise FractureError("criterion", f"must be one of {', '.join(RISK_CRITERIA)}")
    direction = table.get("direction", "mts")
    if direction not in ("mts", "principal"):
        raise FractureError("direction", "must be 'mts' or 'principal'")
    propagate = table.get("propagate", False)
    if not isinstance(propagate, bool):
        raise FractureError("propagate", "must be true or false")
    increment = _positive(table, "increment", None)
    if propagate and increment is None:
        raise FractureError("increment", "is required when propagate = true")
    n = table.get("max_increments", 10)
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise FractureError("max_increments", f"must be a positive integer, got {n!r}")
    initiate = table.get("initiate", False)
    if not isinstance(initiate, bool):
        raise FractureError("initiate", "must be true or false")
    for key in ("initiation_length", "friction"):
        if key in table and not initiate:
            raise FractureError(key, "applies to an initiated crack only: set initiate = true")
    friction = table.get("friction", 0.0)
    if isinstance(friction, bool) or not isinstance(friction, (int, float)) or friction < 0:
        raise FractureError("friction", f"must be a number >= 0, got {friction!r}")
    return FractureSpec(
        criterion,
        direction,
        propagate,
        increment,
        n,
        _positive(table, "tip_size", None),
        _positive(table, "tip_grading", None),
        initiate,
        _positive(table, "initiation_length", None),
        float(friction),
    )


def crack_from_table(table: Mapping, index: int = 1, dim: int = 2) -> CrackSpec:
    """Parse one ``[[crack]]``: in 2D a polyline ``points = [[x, y], …]``, in 3D a planar
    disc, ellipse or convex polygon
    (:func:`~bonecontact.fracture.crack3d.planar_crack_from_table`; ``front_points``: 8
    along a disc or ellipse, 1 per polygon edge by default)."""
    if dim == 3:
        for key in ("points", "tips"):
            if key in table:
                raise FractureError(
                    key,
                    "a 3D crack is a planar disc or ellipse (shape, centre, normal, radius or "
                    "semi_axes and axis) or polygon (vertices), not a polyline",
                )
    _unknown(table, CRACK3D_KEYS if dim == 3 else CRACK_KEYS)
    required = ("region",) if dim == 3 else ("points", "region")
    for key in required:
        if key not in table:
            raise FractureError(key, "is required")
    name = str(table.get("name", f"crack{index}"))
    friction = table.get("friction", 0.0)
    if isinstance(friction, bool) or not isinstance(friction, (int, float)) or friction < 0:
        raise FractureError("friction", f"must be a number >= 0, got {friction!r}")
    if dim == 3:
        n = table.get("front_points", 1 if table.get("shape") == "polygon" else 8)
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise FractureError("front_points", f"must be a positive integer, got {n!r}")
        return CrackSpec(
            name, planar_crack_from_table(table), str(table["region"]), float(friction), n
        )
    pts = table["points"]
    try:
        arr = np.asarray(pts, dtype=float)
    except (TypeError, ValueError) as exc:
        raise FractureError("points", "must be a list of [x, y] pairs") from exc
    crack = Crack2D(arr, table.get("tips", "both"))
    return CrackSpec(name, crack, str(table["region"]), float(friction))


def check_strengths(
    spec: FractureSpec, strengths: Mapping[str, Mapping[str, float]], materials: Sequence[str]
) -> None:
    """Every material of the check has the values it needs: σ_t (always), σ_c
    (``tension_compression``), K_Ic (propagation).  ``strengths``: material → values."""
    needed = ["sigma_t"]
    if spec.criterion == "tension_compression":
        needed.append("sigma_c")
    if spec.propagate:
        needed.append("K_Ic")
    for name in materials:
        values = strengths.get(name, {})
        for key in needed:
            v = values.get(key)
            if not isinstance(v, (int, float)) or not v > 0:
                raise FractureError(
                    key, f"material {name!r} has no {key} (needed by the fracture check)"
                )


def check_crack_region(
    spec: CrackSpec,
    msh: mesh.Mesh,
    cell_tags: mesh.MeshTags,
    region_tag: int,
    increment: float | None = None,
    samples_per_segment: int = 20,
) -> None:
    """Refuse a crack that leaves its region (collective).

    Points sampled along every segment (3D: over the crack, its front included) must each
    lie in a cell tagged ``region_tag``;
    a point in a cell of another tag means the crack crosses another body, a point in no
    cell that it lies outside the mesh.  An ``increment`` must be shorter than the
    region's extent.
    """
    if isinstance(spec.crack, PlanarCrack):
        samples = spec.crack.sample_points()
        x, out_key = samples, spec.crack.size_key
    else:
        pts = spec.crack.points
        t = np.linspace(0.0, 1.0, samples_per_segment + 1)[1:-1]
        samples = np.concatenate(
            [pts[i] + np.outer(t, pts[i + 1] - pts[i]) for i in range(len(pts) - 1)]
        )
        x, out_key = np.column_stack([samples, np.zeros(len(samples))]), "points"
    tdim = msh.topology.dim
    n_cells = msh.topology.index_map(tdim).size_local
    tree = geometry.bb_tree(msh, tdim, padding=0.0)
    cand = geometry.compute_collisions_points(tree, x)
    hits = geometry.compute_colliding_cells(msh, cand, x)
    tag_of = np.full(n_cells + msh.topology.index_map(tdim).num_ghosts, -1, dtype=np.int64)
    tag_of[cell_tags.indices] = cell_tags.values
    found = np.zeros(len(x), dtype=np.int32)
    inside = np.zeros(len(x), dtype=np.int32)
    for i in range(len(x)):
        cells = hits.links(i)
        cells = cells[cells < n_cells]
        found[i] = int(cells.size > 0)
        inside[i] = int(np.any(tag_of[cells] == region_tag))
    msh.comm.Allreduce(MPI.IN_PLACE, found, op=MPI.SUM)
    msh.comm.Allreduce(MPI.IN_PLACE, inside, op=MPI.SUM)
    if np.any(found == 0):
        p = samples[int(np.argmax(found == 0))]
        raise FractureError(out_key, f"crack {spec.name!r} leaves the mesh near {p.tolist()}")
    if np.any(inside == 0):
        p = samples[int(np.argmax(inside == 0))]
        raise FractureError(
            "region", f"crack {spec.name!r} is not in region {spec.region!r} near {p.tolist()}"
        )
    if increment is not None:
        cells = cell_tags.find(region_tag)
        xs = mesh.compute_midpoints(msh, tdim, cells[cells < n_cells])[:, :tdim]
        lo = xs.min(axis=0) if xs.size else np.full(tdim, np.inf)
        hi = xs.max(axis=0) if xs.size else np.full(tdim, -np.inf)
        msh.comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)  # buffers: pickled min of arrays fails
        msh.comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
        if increment >= float(np.max(hi - lo)):
            raise FractureError(
                "increment", f"{increment} m is not smaller than region {spec.region!r}"
            )
