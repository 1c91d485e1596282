"""Quasi-static crack propagation in 2D by remeshing (docs/theory/fracture.md#propagation).

Each increment: mesh the body around the current crack (graded towards the tips), solve
the mechanics problem, evaluate K_I and K_II at every tip by the interaction integral,
choose the kink angle (maximum tangential stress or the principal-direction average),
and grow each tip that propagates by a straight segment Δa in that direction.  A tip
propagates while its equivalent K (:func:`~bonecontact.fracture.criteria.mts_equivalent_k`)
reaches K_Ic — or, with no K_Ic, for a fixed number of increments under the prescribed
load.  The run stops when a tip gets within one increment of the free surface (the body
is fractured), when every tip arrests, or after ``max_increments``.

The mechanics problem is the caller's: a function that takes the
:class:`~bonecontact.fracture.meshing.CrackedMesh` and returns the model and its
displacement.  Everything is recomputed on the new mesh at every increment (linear
elastic, load-controlled: nothing to transfer).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
from dolfinx import fem

from bonecontact.common.errors import ParameterError
from bonecontact.common.formatting import format_cell
from bonecontact.fracture.crack import Crack2D, point_segment_distance
from bonecontact.fracture.criteria import (
    cell_stresses,
    mts_angle,
    mts_equivalent_k,
    principal_direction_average,
)
from bonecontact.fracture.meshing import CrackedMesh, Hole, TipMesh, mesh_cracked_body
from bonecontact.fracture.sif import interaction_integral
from bonecontact.fracture.williams import PlaneState
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.model import Mechanics

__all__ = [
    "FRACTURE_COLUMNS",
    "IncrementRecord",
    "PropagationOptions",
    "PropagationResult",
    "domain_radius",
    "propagate",
    "write_fracture_table",
]

#: Columns of a fracture table (``fracture.csv``), one row per tip and evaluated state:
#: ``increment`` (crack increments so far), ``step`` and ``time`` of the analysis (a
#: Python :func:`propagate` run: 0 and nan), ``crack`` (the ``[[crack]]``'s name in a scene;
#: empty in a Python run), ``tip`` (the polyline end, 0 or -1), ``x``,
#: ``y`` (the tip, m), ``length`` (of the crack, m), ``K_I``, ``K_II`` (Pa·√m, interaction
#: integral), ``J`` (domain J-integral, J/m²), ``G`` ((K_I² + K_II²)/E′, J/m²),
#: ``K_I_dc``, ``K_II_dc`` (displacement correlation, the cross-check; nan when not
#: evaluated), ``angle_deg`` (kink angle of the direction criterion, counter-clockwise from
#: the crack direction), ``K_eq`` (MTS equivalent K), ``load_factor`` (K_Ic/K_eq: the load
#: at which the tip would advance, relative to the current one; nan without K_Ic) and
#: ``status``.
FRACTURE_COLUMNS = (
    "increment",
    "step",
    "time",
    "crack",
    "tip",
    "x",
    "y",
    "length",
    "K_I",
    "K_II",
    "J",
    "G",
    "K_I_dc",
    "K_II_dc",
    "angle_deg",
    "K_eq",
    "load_factor",
    "status",
)

#: ``solve(cracked_mesh)`` returns ``(model, u)`` or ``(model, u, face_traction)`` (the
#: traction on loaded or contacting crack faces, for the interaction integral).
Solver = Callable[[CrackedMesh], tuple]


@dataclass(frozen=True)
class PropagationOptions:
    """How a crack is grown.

    Parameters
    ----------
    increment
        Crack growth per increment Δa (m).
    tip_mesh
        Tip element size and grading; ``h_tip`` should be ≤ Δa/8 so that the integration
        domain (within the last segment) spans several elements.
    direction
        ``"mts"`` (maximum tangential stress) or ``"principal"`` (average principal
        direction of the cells nearest the tip).
    K_Ic
        Fracture toughness (Pa·√m): a tip grows while K_eq ≥ K_Ic.  ``None``: every tip
        grows at every increment (a fixed number under the prescribed load).
    max_increments
        Upper bound on the number of increments.
    plane
        ``"strain"`` or ``"stress"`` (for K; the solver decides the model).
    r_out_max
        Largest integration-domain radius (m); default 2Δa.
    """

    increment: float
    tip_mesh: TipMesh
    direction: Literal["mts", "principal"] = "mts"
    K_Ic: float | None = None
    max_increments: int = 10
    plane: PlaneState = "strain"
    r_out_max: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.increment) and self.increment > 0):
            raise ParameterError("increment", f"must be a positive length, got {self.increment!r}")
        if self.direction not in ("mts", "principal"):
            raise ParameterError(
                "direction", f"must be 'mts' or 'principal', got {self.direction!r}"
            )
        if self.K_Ic is not None and not (math.isfinite(self.K_Ic) and self.K_Ic > 0):
            raise ParameterError("K_Ic", f"must be a positive number, got {self.K_Ic!r}")
        if int(self.max_increments) != self.max_increments or self.max_increments < 1:
            raise ParameterError("max_increments", "must be a positive integer")


@dataclass(frozen=True)
class IncrementRecord:
    """One tip at one increment (the row of a fracture table)."""

    increment: int
    tip: int
    x: float
    y: float
    length: float
    K_I: float
    K_II: float
    G: float
    angle_deg: float
    load_factor: float
    status: str
    step: int = 0
    time: float = math.nan
    J: float = math.nan
    K_I_dc: float = math.nan
    K_II_dc: float = math.nan
    K_eq: float = math.nan
    crack: str = ""

    def row(self) -> tuple:
        return tuple(getattr(self, c) for c in FRACTURE_COLUMNS)


@dataclass
class PropagationResult:
    """The crack path and the per-increment records.

    ``status`` is ``"fractured"`` (a tip reached the free surface), ``"arrested"`` (no
    tip can grow) or ``"max_increments"``.
    """

    crack: Crack2D
    records: list[IncrementRecord] = field(default_factory=list)
    status: str = "max_increments"
    paths: list[npt.NDArray[np.float64]] = field(default_factory=list)


def _distance_to_outline(p: np.ndarray, outline: np.ndarray, holes: Sequence[Hole]) -> float:
    n = len(outline)
    d = min(point_segment_distance(p, outline[i], outline[(i + 1) % n]) for i in range(n))
    for h in holes:
        d = min(d, abs(float(np.hypot(*(p - np.asarray(h.centre)))) - h.radius))
    return d


def domain_radius(
    crack: Crack2D, end: int, outline: np.ndarray, holes: Sequence[Hole], opts: PropagationOptions
) -> float:
    """Outer radius of the interaction-integral domain at tip ``end``: ``opts.r_out_max``
    (default 2Δa), at most 0.8 × the last crack segment and 0.8 × the distance to the free
    surface; a :class:`ParameterError` if it spans fewer than 4 tip elements."""
    r_max = opts.r_out_max if opts.r_out_max is not None else 2.0 * opts.increment
    free = _distance_to_outline(crack.tip(end), outline, holes)
    r = min(r_max, 0.8 * crack.tip_segment_length(end), 0.8 * free)
    if r < 4.0 * opts.tip_mesh.h_tip:
        raise ParameterError(
            "tip_mesh.h_tip",
            f"the integration domain (r_out = {r:.3g} m) spans fewer than 4 tip elements; "
            "refine the tip mesh or increase the increment",
        )
    return r


def _kink(
    opts: PropagationOptions,
    model: Mechanics,
    u: fem.Function,
    crack: Crack2D,
    end: int,
    K_I: float,
    K_II: float,
    comm: MPI.Comm,
) -> float:
    if opts.direction == "mts":
        return mts_angle(K_I, K_II)
    cs = cell_stresses(model, u)
    return principal_direction_average(
        cs, comm, crack.tip(end), crack.direction(end), 24, 2.0 * opts.tip_mesh.h_tip
    )


def propagate(
    outline: Sequence[Sequence[float]],
    crack: Crack2D,
    solve: Solver,
    material: Isotropic,
    options: PropagationOptions,
    comm: MPI.Comm | None = None,
    holes: Sequence[Hole] = (),
) -> PropagationResult:
    """Grow ``crack`` in the body ``outline`` increment by increment.

    Parameters
    ----------
    outline, holes
        The body (as for :func:`~bonecontact.fracture.meshing.mesh_cracked_body`).
    crack
        The initial crack.
    solve
        ``solve(cracked_mesh) -> (model, u)``: the mechanics problem on a new mesh.
    material
        The (homogeneous, isotropic) material around the tips.
    options
        :class:`PropagationOptions`.
    comm
        Communicator (``None``: ``MPI.COMM_WORLD``).

    Returns
    -------
    PropagationResult
        Identical on every rank.
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    poly = np.asarray(outline, dtype=float)
    result = PropagationResult(crack)
    for step in range(options.max_increments):
        cm = mesh_cracked_body(poly, crack, options.tip_mesh, comm, holes)
        model, u, *face = solve(cm)
        face_t = face[0] if face else None
        grown, status = crack, "arrested"
        for end in crack.tip_ends:
            r_out = domain_radius(crack, end, poly, holes, options)
            k = interaction_integral(
                u, cm, end, material, r_out, plane=options.plane, face_traction=face_t
            )
            theta = _kink(options, model, u, crack, end, k.K_I, k.K_II, comm)
            k_eq = mts_equivalent_k(k.K_I, k.K_II, theta)
            load = options.K_Ic / k_eq if (options.K_Ic and k_eq > 0) else math.nan
            grows = options.K_Ic is None or k_eq >= options.K_Ic
            tip_status = "grows" if grows else "arrested"
            if grows:
                grown = grown.extended(end, options.increment, theta)
                status = "grows"
                free = _distance_to_outline(grown.tip(end), poly, holes)
                if free < options.increment:
                    tip_status = status = "fractured"
            x, y = crack.tip(end)
            result.records.append(
                IncrementRecord(
                    step,
                    end,
                    float(x),
                    float(y),
                    crack.length,
                    k.K_I,
                    k.K_II,
                    k.G,
                    math.degrees(theta),
                    load,
                    tip_status,
                    J=k.J,
                    K_eq=k_eq,
                )
            )
        result.paths.append(crack.points.copy())
        crack = grown
        result.crack = crack
        if status in ("fractured", "arrested"):
            result.status = status
            break
    result.paths.append(crack.points.copy())
    return result


def write_fracture_table(
    records: Sequence[IncrementRecord], path: str | Path, comm: MPI.Comm | None = None
) -> None:
    """Write the records as a CSV table with :data:`FRACTURE_COLUMNS` (rank 0 writes;
    numbers round-trip exactly, see :mod:`bonecontact.common.formatting`)."""
    comm = MPI.COMM_WORLD if comm is None else comm
    if comm.rank == 0:
        lines = [",".join(FRACTURE_COLUMNS)]
        lines += [",".join(format_cell(v) for v in r.row()) for r in records]
        Path(path).write_text("\n".join(lines) + "\n")
    comm.barrier()
