"""Where and how a new crack is inserted when the initiation risk reaches 1
(docs/theory/fracture.md#automatic-initiation).

The risk maximum (:class:`~bonecontact.fracture.criteria.RiskMaximum`) gives a cell
midpoint and the direction a crack started there takes (normal to the in-plane direction
of σ₁).  :func:`initiation_crack` turns it into a short straight crack of the body:

* the cell of the maximum touches the boundary (its midpoint lies within one cell size of
  a boundary loop — the outer surface or a hole's edge): an *edge* crack, its mouth at the
  boundary point nearest to the midpoint, running into the material along the crack
  direction (``tips = "end"``);
* otherwise an *interior* crack centred at the midpoint, with two tips.

:func:`initiation_time` is the load factor (static analysis) or time at which the risk
reached 1, interpolated linearly between the last two evaluated states (exact for a
linear elastic problem under a proportional load, where the risk is linear in the load).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from dolfinx import fem, mesh

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.body import BodyOutline
from bonecontact.fracture.crack import Crack2D
from bonecontact.fracture.criteria import cell_stresses
from bonecontact.mechanics.model import Mechanics

__all__ = [
    "EDGE_ANGLE_MIN_DEG",
    "Initiation",
    "cell_size_at",
    "default_length",
    "initiation_crack",
    "initiation_time",
    "risk_peak",
]

#: Cells whose risk lies within this fraction of the largest, near it, make up the peak.
PEAK_FRACTION = 0.99

#: An edge crack needs to leave the surface at this angle at least (degrees); a crack
#: direction closer to the surface's tangent gives an interior crack instead.
EDGE_ANGLE_MIN_DEG = 30.0


@dataclass(frozen=True)
class Initiation:
    """A crack inserted where the risk reached 1.

    Attributes
    ----------
    crack
        The new crack.
    location
        Midpoint of the cell of the largest risk (m).
    point
        Where the crack starts: its mouth on the boundary (edge crack) or its centre.
    direction
        Unit vector along the crack (normal to σ₁ there), into the material for an edge
        crack.
    on_surface
        Whether it is an edge crack from the boundary.
    length
        Its length (m).
    cell_size
        Size (longest edge) of the cell of the largest risk (m).
    """

    crack: Crack2D
    location: tuple[float, float]
    point: tuple[float, float]
    direction: tuple[float, float]
    on_surface: bool
    length: float
    cell_size: float


def cell_size_at(msh: mesh.Mesh, point: npt.ArrayLike) -> float:
    """Longest edge of the cell whose midpoint is nearest to ``point`` (collective)."""
    tdim = msh.topology.dim
    n = msh.topology.index_map(tdim).size_local
    p = np.asarray(point, dtype=float)[:2]
    best = (math.inf, 0.0)
    if n:
        cells = np.arange(n, dtype=np.int32)
        mid = mesh.compute_midpoints(msh, tdim, cells)[:, :2]
        i = int(np.argmin(np.hypot(*(mid - p).T)))
        x = msh.geometry.x[msh.geometry.dofmap[i], :2]
        h = float(max(np.linalg.norm(x[a] - x[b]) for a in range(len(x)) for b in range(a)))
        best = (float(np.hypot(*(mid[i] - p))), h)
    rows = msh.comm.allgather(best)
    return min(rows)[1]


def risk_peak(
    model: Mechanics,
    u: fem.Function,
    risk: fem.Function,
    location: npt.ArrayLike,
    radius: float,
    fraction: float = PEAK_FRACTION,
) -> tuple[tuple[float, float], tuple[float, float]]:
    """Centre and crack direction of the risk peak around its largest cell (collective).

    A P1 solution's cell risks scatter by a fraction of a per cent from cell to cell, so
    on a flat peak (a hole edge) the single largest cell can lie a few cells off its
    centre.  The peak is taken as the cells within ``radius`` of ``location`` whose risk
    is at least ``fraction`` of the largest: their risk-weighted centroid is the centre,
    and the crack direction is normal to their weighted mean σ₁ axis (axes averaged as
    doubled angles).  Rows are sorted before the sums: the same on any number of ranks.
    """
    cs = cell_stresses(model, u)
    V0 = risk.function_space
    r = risk.x.array[V0.dofmap.list[cs.cells, 0]]
    _, _, phi = cs.principal()
    x0 = np.asarray(location, dtype=float)[:2]
    near = np.hypot(*(cs.midpoints - x0).T) <= radius
    local = np.column_stack([r[near], cs.midpoints[near], phi[near]])
    rows = np.concatenate(model.mesh.comm.allgather(local))
    rows = rows[rows[:, 0] >= fraction * rows[:, 0].max()]
    rows = rows[np.lexsort((rows[:, 2], rows[:, 1]))]
    w = rows[:, 0] / rows[:, 0].sum()
    centre = (float(w @ rows[:, 1]), float(w @ rows[:, 2]))
    axis = 0.5 * math.atan2(float(w @ np.sin(2 * rows[:, 3])), float(w @ np.cos(2 * rows[:, 3])))
    normal = axis + 0.5 * math.pi
    return centre, (math.cos(normal), math.sin(normal))


def default_length(increment: float | None, cell_size: float) -> float:
    """Default crack length: one increment Δa with propagation (eight tip elements at the
    default tip size Δa/8), else four cells of the mesh at the risk maximum."""
    return float(increment) if increment is not None else 4.0 * cell_size


def _unit(v: npt.ArrayLike) -> npt.NDArray[np.float64]:
    v = np.asarray(v, dtype=float)[:2]
    norm = float(np.linalg.norm(v))
    if not norm > 0:
        raise ParameterError("direction", "the crack direction is zero")
    return v / norm


def _edge_crack(
    body: BodyOutline, foot: npt.NDArray[np.float64], d: npt.NDArray[np.float64], length: float
) -> Crack2D | None:
    """The crack from the boundary point ``foot`` into the material along ±d (the side
    that lies in the body), or ``None`` if neither fits."""
    best = None
    for s in (1.0, -1.0):
        tip = foot + s * length * d
        if not body.inside(tip):
            continue
        crack = Crack2D(np.array([foot, tip]), "end")
        try:
            body.check_crack(crack)
        except ParameterError:
            continue
        if best is None or body.distance(tip) > body.distance(best.points[-1]):
            best = crack
    return best


def initiation_crack(
    body: BodyOutline,
    location: npt.ArrayLike,
    direction: npt.ArrayLike,
    length: float,
    cell_size: float,
) -> Initiation:
    """The crack inserted at the risk maximum (module docstring).

    Parameters
    ----------
    body
        The body's outline.
    location
        Midpoint of the cell of the largest risk (m).
    direction
        The crack direction there (normal to σ₁), any sign.
    length
        Crack length (m), > 0.
    cell_size
        Size of that cell (m): the midpoint of a cell at the boundary lies within it.

    Raises
    ------
    ParameterError
        ``initiation_length``: the crack does not fit into the body (longer than the
        material ahead of the surface point, or crossing the outline).
    """
    if not (math.isfinite(length) and length > 0):
        raise ParameterError("initiation_length", f"must be a positive length, got {length!r}")
    x = np.asarray(location, dtype=float)[:2]
    d = _unit(direction)
    foot, dist = body.nearest(x)
    crack, on_surface, point = None, False, x
    if dist <= cell_size:
        normal = _unit(x - foot) if dist > 1e-12 * body.scale else None
        steep = normal is None or abs(float(d @ normal)) >= math.sin(
            math.radians(EDGE_ANGLE_MIN_DEG)
        )
        if steep:
            crack = _edge_crack(body, foot, d, length)
            if crack is None:
                raise ParameterError(
                    "initiation_length",
                    f"a crack of {length:.4g} m from the surface point {foot.tolist()} along "
                    f"{d.tolist()} leaves the body; choose a shorter initiation_length",
                )
            on_surface, point = True, foot
            d = _unit(crack.points[-1] - crack.points[0])
    if crack is None:
        crack = Crack2D(np.array([x - 0.5 * length * d, x + 0.5 * length * d]), "both")
        try:
            body.check_crack(crack)
        except ParameterError as exc:
            raise ParameterError(
                "initiation_length",
                f"a crack of {length:.4g} m centred at {x.tolist()} along {d.tolist()} does "
                f"not lie in the body ({exc}); choose a shorter initiation_length",
            ) from None
    return Initiation(
        crack,
        (float(x[0]), float(x[1])),
        (float(point[0]), float(point[1])),
        (float(d[0]), float(d[1])),
        on_surface,
        float(length),
        float(cell_size),
    )


def initiation_time(t0: float, r0: float, t1: float, r1: float) -> float:
    """Time (load factor) at which the risk reached 1 between the states ``(t0, r0)``
    (r0 < 1) and ``(t1, r1)`` (r1 ≥ 1), by linear interpolation."""
    if r1 <= r0:
        return float(t1)
    return float(t0 + (1.0 - r0) * (t1 - t0) / (r1 - r0))
