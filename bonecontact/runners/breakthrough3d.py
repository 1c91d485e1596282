"""An interior 3D crack that reaches the body's surface becomes a surface crack
(``[fracture] breakthrough = "surface_crack"``; docs/scene_format.md, docs/theory/
fracture.md#an-interior-crack-that-reaches-the-surface).

The run chains the two growth runners.  The interior crack grows
(:func:`~bonecontact.runners.front_growth3d.run_interior_growth`); when it stops
``through`` (fatigue) or ``fractured`` (one load) because its front would come within
the ligament of the surface, its last solved front is re-characterised as a
semi-elliptical surface crack (:func:`surface_flaw`: in the crack's plane, centred where
the depth line through the middle of the flaw's length meets the surface, depth =
ligament + the flaw's height, half-length = half its length; at an edge a corner crack,
:func:`corner_flaw`), cut into the body and grown by
:func:`~bonecontact.runners.surface_crack3d.run_surface_crack` from the next increment
number and the cycles of the last interior solve.  The surface phase's front
size is the interior one's, or less where the deeper ellipse needs it (three elements
within 0.6 b²/a).  ``fracture.csv`` is one table of both phases (``phase`` interior or
surface; the last interior rows marked ``breaks_surface`` with the cycles of their
solve), ``summary.json`` the surface run's with the interior growth and the
re-characterisation under ``fracture.breakthrough``.  A re-characterised crack that
cannot be cut into the body with its ligament (it reaches another surface) keeps the
interior stop.  A restart continues from an interior checkpoint (the surface phase
writes none): fracture.csv goes back to the interior table, the interior run restarts,
the chain follows.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np

from bonecontact.common.errors import ParameterError
from bonecontact.common.geometry import (
    first_ray_hits,
    nearest_triangle_distance,
    point_triangle_distance,
)
from bonecontact.fracture.body3d import BodySurface
from bonecontact.fracture.crack3d import SurfaceBreakingCrack
from bonecontact.fracture.surface_body3d import CORNER, CORNER_ANGLE_TOL
from bonecontact.runners.front_growth3d import (
    GROWTH3D_COLUMNS,
    check_interior_growth,
    run_interior_growth,
)
from bonecontact.runners.results import RunResult, write_summary
from bonecontact.runners.surface_crack3d import (
    SurfaceStart,
    body_and_material,
    prepare_surface,
    run_surface_crack,
)
from bonecontact.scene import Scene, SceneError

__all__ = [
    "BREAKTHROUGH_COLUMNS",
    "EDGE_LIGAMENT_RATIO",
    "EDGE_ON_SURFACE",
    "SurfaceFlaw",
    "breaks_to_surface",
    "check_breakthrough",
    "corner_flaw",
    "interior_table_back",
    "run_breakthrough",
    "surface_flaw",
]

#: Columns of ``fracture.csv`` of a run with both phases (a row per increment and point;
#: the columns a phase does not have are empty).
BREAKTHROUGH_COLUMNS = ("phase",) + tuple(
    dict.fromkeys(
        [*GROWTH3D_COLUMNS[:4], "depth", "half_length", "phi_deg", "psi_deg", *GROWTH3D_COLUMNS[4:]]
    )
)


@dataclasses.dataclass(frozen=True)
class SurfaceFlaw:
    """An interior flaw re-characterised as a surface flaw (:func:`surface_flaw`): a
    semi-elliptical crack, or at an edge a quarter-elliptical corner crack."""

    crack: SurfaceBreakingCrack
    ligament: float  # the flaw's least distance to the surface along the depth line (m)
    height: float  # its extent along the depth direction (m)
    length: float  # its extent along the surface (m)
    ligament2: float | None = None  # a corner flaw's least distance to the second face (m)

    def summary(self) -> dict[str, Any]:
        """The entry ``fracture.breakthrough.crack`` of summary.json (a corner crack's
        with its ``shape`` and ``ligament2``)."""
        c = self.crack
        corner = {} if self.ligament2 is None else {"shape": c.shape, "ligament2": self.ligament2}
        return {
            **corner,
            "centre": list(c.centre),
            "normal": list(c.normal),
            "axis": list(c.axis),
            "depth": c.depth,
            "half_length": c.half_length,
            "ligament": self.ligament,
            "height": self.height,
            "length": self.length,
        }


def breaks_to_surface(scene: Scene) -> bool:
    """Whether the scene asks its growing interior crack to become a surface crack."""
    fr = scene.fracture
    return fr is not None and fr.breakthrough == "surface_crack"


def _edge_samples(V: np.ndarray, per_edge: int = 16) -> np.ndarray:
    s = np.arange(per_edge)[:, None, None] / per_edge
    return (V[None] + s * (np.roll(V, -1, axis=0) - V)[None]).reshape(-1, 3)


def _ray_exit(T: np.ndarray, p: np.ndarray, d: np.ndarray) -> float:
    """The least s > 0 where p + s d meets a boundary triangle of ``T``."""
    s, _ = first_ray_hits(p, d, T)
    if not np.isfinite(s[0]):
        raise ParameterError("breakthrough", "the depth line does not meet the body's surface")
    return float(s[0])


def _stable_unit(v: np.ndarray) -> np.ndarray:
    """``v`` normalised until normalising it again leaves it unchanged (a scene given this
    vector reads exactly it: the parser divides by the length once more)."""
    for _ in range(8):
        w = v / np.linalg.norm(v)
        if np.array_equal(w, v):
            break
        v = w
    return v


def _outward_normal(T: np.ndarray, p: np.ndarray, d: float) -> np.ndarray:
    """The outward normal of the boundary triangles ``T`` below the inside point ``p``
    (``d`` its distance to them): the area-weighted mean normal of the nearest triangle
    and those with a corner within d of the foot of p on it (on a faceted curved surface
    the patch's mean, not one facet's turned normal)."""
    i = int(np.argmin(point_triangle_distance(p, T)))
    m = np.cross(T[i, 1] - T[i, 0], T[i, 2] - T[i, 0])
    m /= np.linalg.norm(m)
    m = -m if float(m @ (p - T[i, 0])) > 0 else m  # outward at p
    near = np.min(np.linalg.norm(T - (p + d * m), axis=2), axis=1) < d
    near[i] = True
    tri = T[near]
    mean = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]).sum(axis=0)
    mean /= np.linalg.norm(mean)
    return mean if float(mean @ m) > 0 else -mean


def surface_flaw(body: BodySurface, front: Any, normal: Any) -> SurfaceFlaw:
    """The planar interior flaw of polygonal ``front`` (its vertices, m) and unit
    ``normal`` re-characterised as a semi-elliptical surface flaw.

    The front point nearest the body's surface (16 points per edge) and the outward
    normal there (the area-weighted mean of the nearest boundary triangle and those with
    a corner within the point's distance of its foot), projected on the crack plane,
    give the outward depth direction e; the axis t = n × e.  The flaw's length is the extent of
    the vertices along t, its height their extent along e.  The depth line is the line
    along e through the middle of the length at the nearest point's level; it meets the
    surface at the centre C.  The ligament is the distance from the flaw's highest
    vertex level to C along e, the depth = ligament + height, the half-length = half
    the length (the rule of docs/theory/fracture.md).  When the front also comes within
    :data:`EDGE_LIGAMENT_RATIO` times its least distance of a second face at about 90° to
    the first (:func:`_second_face`) and the two faces' planes meet the crack plane on
    the body's surface (within :data:`EDGE_ON_SURFACE` of the smaller semi-axis: an edge,
    not two tangent planes of a curved surface) the flaw is at an edge: a corner crack
    (:func:`corner_flaw`).

    Raises
    ------
    ParameterError
        (key ``breakthrough``) the crack plane is (nearly) parallel to the surface there,
        or the depth line does not meet it.
    """
    n = _stable_unit(np.asarray(normal, dtype=float))
    V = np.asarray(front, dtype=float)
    V = V - np.outer((V - V.mean(axis=0)) @ n, n)  # onto the mean plane
    X = _edge_samples(V)
    T = np.asarray(body.triangles, dtype=float)
    dist = nearest_triangle_distance(X, T)
    p = X[int(np.argmin(dist))]
    m = _outward_normal(T, p, float(dist.min()))
    e = m - (m @ n) * n
    if np.linalg.norm(e) < 0.2:
        raise ParameterError(
            "breakthrough", "the crack plane is (nearly) parallel to the body's surface"
        )
    e /= np.linalg.norm(e)
    edge = _second_face(T, X, m, float(dist.min()))
    if edge is not None:
        nearest = T[int(np.argmin(point_triangle_distance(p, T)))]
        corner = corner_flaw(V, n, (nearest[0], m), edge)
        if _on_an_edge(T, corner.crack):
            return corner
    t = _stable_unit(np.cross(n, e))
    along, up = V @ t, V @ e
    mid = 0.5 * (along.max() + along.min())
    p0 = p + (mid - p @ t) * t + (up.max() - p @ e) * e  # the depth line at the top level
    ligament = _ray_exit(T, p0, e)
    C = p0 + ligament * e
    height = float(np.ptp(up))
    length = float(np.ptp(along))
    crack = SurfaceBreakingCrack(
        tuple(map(float, C)),
        tuple(map(float, n)),
        ligament + height,
        0.5 * length,
        tuple(map(float, t)),
    )
    return SurfaceFlaw(crack, ligament, height, length)


#: A flaw is at an edge when a second face (its normal 90 ± CORNER_ANGLE_TOL° from the
#: first's) is at most this many times the first face's ligament from its front.
EDGE_LIGAMENT_RATIO = 2.0


def _second_face(
    T: np.ndarray, X: np.ndarray, m: np.ndarray, ligament: float
) -> tuple[np.ndarray, np.ndarray] | None:
    """The face at an edge the flaw also reaches: among the boundary triangles whose
    outward normal lies 90 ± :data:`~bonecontact.fracture.surface_body3d.CORNER_ANGLE_TOL`°
    from ``m`` the nearest to the front samples ``X``, if within
    :data:`EDGE_LIGAMENT_RATIO` × ``ligament`` of them: (a vertex of it, its unit outward
    normal); else ``None``."""
    normals = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    side = np.flatnonzero(np.abs(normals @ m) <= math.sin(math.radians(CORNER_ANGLE_TOL)))
    if len(side) == 0:
        return None
    d = np.array([point_triangle_distance(x, T[side]) for x in X])
    k = int(np.unravel_index(np.argmin(d), d.shape)[1])
    if d.min() > EDGE_LIGAMENT_RATIO * ligament:
        return None
    return T[side[k], 0], normals[side[k]]


#: A corner flaw's centre (where the crack plane meets the two faces' planes) must lie
#: within this fraction of its smaller semi-axis of the body's surface: on an edge, not
#: outside a curved surface where two tangent planes meet.
EDGE_ON_SURFACE = 0.1


def _on_an_edge(T: np.ndarray, crack: SurfaceBreakingCrack) -> bool:
    """Whether the corner crack's centre lies on the body's surface
    (:data:`EDGE_ON_SURFACE`)."""
    gap = float(point_triangle_distance(np.asarray(crack.centre), T).min())
    return gap <= EDGE_ON_SURFACE * min(crack.depth, crack.half_length)


def corner_flaw(
    V: np.ndarray,
    normal: np.ndarray,
    face1: tuple[np.ndarray, np.ndarray],
    face2: tuple[np.ndarray, np.ndarray],
) -> SurfaceFlaw:
    """The planar flaw of front vertices ``V`` (in the plane of ``normal``) next to the
    edge where ``face1`` (the nearer face) and ``face2`` meet — each (a point, its unit
    outward normal) — re-characterised as a quarter-elliptical corner crack: centred where
    the crack plane meets the edge, c along face 1 = the flaw's farthest in-plane distance
    from face 2, a along face 2 = its farthest from face 1 (ligament + height, the
    semi-elliptical rule's depth), ``axis`` the plane's line in face 1, from the edge into
    it."""
    n = np.asarray(normal, dtype=float)
    (q1, m1), (q2, m2) = face1, face2
    M = np.array([n, m1, m2])
    C = np.linalg.solve(M, [n @ V.mean(axis=0), m1 @ q1, m2 @ q2])
    h1 = _in_plane_distance(V, q1, m1, n)
    h2 = _in_plane_distance(V, q2, m2, n)
    t = np.cross(n, m1)
    t = _stable_unit(t if t @ m2 < 0 else -t)
    crack = SurfaceBreakingCrack(
        tuple(map(float, C)),
        tuple(map(float, n)),
        float(h1.max()),
        float(h2.max()),
        tuple(map(float, t)),
        CORNER,
    )
    return SurfaceFlaw(
        crack, float(h1.min()), float(np.ptp(h1)), float(np.ptp(h2)), float(h2.min())
    )


def _in_plane_distance(V: np.ndarray, q: np.ndarray, m: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The distances from the points ``V`` of the crack plane (normal ``n``) to the face
    plane through ``q`` with outward normal ``m``, measured in the crack plane."""
    e = m - (m @ n) * n
    return (q - V) @ m / np.linalg.norm(e)


def _refuse(scene: Scene) -> None:
    """One planar crack (a SceneError on every rank)."""
    if len(scene.cracks) != 1:
        raise SceneError(
            str(scene.path),
            "[fracture]",
            "breakthrough",
            f'"surface_crack" re-characterises a single crack; the scene has {len(scene.cracks)}'
            ' (allowed values: "stop", "surface_crack")',
        )


def interior_table_back(outdir: Path) -> None:
    """Before a restart (rank 0): fracture.csv as the interior run wrote it — a surface
    phase cut short leaves the interior table aside (put back), a finished run the table
    of both phases (its interior rows kept, in the interior columns)."""
    table, part = outdir / "fracture.csv", outdir / "fracture_interior.csv"
    if part.exists():
        part.replace(table)
        return
    if not table.exists():
        return
    with open(table, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows or "phase" not in rows[0]:
        return
    with open(table, "w", newline="") as f:
        w = csv.DictWriter(f, GROWTH3D_COLUMNS, extrasaction="ignore")
        w.writeheader()
        w.writerows(r for r in rows if r["phase"] == "interior")


def check_breakthrough(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> Any:
    """Every check of the interior phase (the surface phase's crack is known only when
    the interior one reaches the surface); the scene model on its first cracked mesh."""
    _refuse(scene)
    return check_interior_growth(scene, comm)


def surface_scene(scene: Scene, flaw: SurfaceFlaw, h_interior: float) -> Scene:
    """The scene whose ``[[crack]]`` is the re-characterised surface crack: its front
    size the interior one's, or 0.2 b²/a when smaller (the integration domain of three
    elements within 0.6 b²/a of a surface crack)."""
    c = flaw.crack
    h = min(h_interior, 0.2 * c.b**2 / c.a)
    spec = dataclasses.replace(scene.cracks[0], crack=c)
    fr = dataclasses.replace(scene.fracture, tip_size=h, breakthrough="stop")
    return dataclasses.replace(scene, cracks=(spec,), fracture=fr)


def _at_surface(scene: Scene) -> str:
    """The interior stop at the surface: ``through`` (fatigue), ``fractured`` (one load;
    under fatigue ``fractured`` is K_V at K_Ic, not the surface)."""
    return "through" if scene.fracture.fatigue is not None else "fractured"


def _interior_table(comm: MPI.Comm, outdir: Path) -> Path:
    """The interior phase's fracture.csv moved aside (rank 0; every rank waits)."""
    part = outdir / "fracture_interior.csv"
    if comm.rank == 0:
        (outdir / "fracture.csv").replace(part)
    comm.barrier()
    return part


def merge_tables(
    outdir: Path, interior: Path, last: int | None, cycles: float | None, name: str
) -> None:
    """fracture.csv of both phases (:data:`BREAKTHROUGH_COLUMNS`, rank 0): the interior
    rows (those of increment ``last``, the re-characterised front, marked
    ``breaks_surface`` with ``cycles``; ``last`` None: no transition), then the surface
    phase's rows of ``outdir/fracture.csv`` when there are any."""
    rows = []
    with open(interior, newline="") as f:
        for r in csv.DictReader(f):
            if last is not None and int(r["increment"]) == last:
                r["status"] = "breaks_surface"
                r["cycles"] = repr(float(cycles))
            rows.append({"phase": "interior", **r})
    table = outdir / "fracture.csv"
    if last is not None and table.exists():
        with open(table, newline="") as f:
            rows += [{"phase": "surface", "crack": name, **r} for r in csv.DictReader(f)]
    with open(table, "w", newline="") as f:
        w = csv.DictWriter(f, BREAKTHROUGH_COLUMNS, restval="")
        w.writeheader()
        w.writerows(rows)
    interior.unlink()


def run_breakthrough(
    scene: Scene,
    comm: MPI.Comm = MPI.COMM_WORLD,
    output: Path | None = None,
    progress: bool = True,
    restart: str | Path | bool | None = None,
) -> RunResult:
    """Grow the scene's interior crack; when it reaches the surface, grow it on as the
    re-characterised surface crack (module docstring); ``restart``: continue from the
    newest (``True``) or the named checkpoint of the interior phase."""
    t0 = time.perf_counter()
    _refuse(scene)
    outdir = Path(output) if output is not None else scene.output.directory
    if restart and comm.rank == 0:
        interior_table_back(outdir)
    comm.barrier()
    interior = run_interior_growth(scene, comm, outdir, progress, restart)
    fr = interior.summary["fracture"]
    g = fr["growth"]
    part = _interior_table(comm, outdir)
    if interior.status != "converged" or g["status"] != _at_surface(scene):
        return _finish(comm, outdir, part, interior, None, fr, t0)
    body = body_and_material(scene, comm)[0]
    cycles = g["history"][-1]["cycles"] if scene.fracture.fatigue is not None else 0.0
    start = SurfaceStart(g["increments"] + 1, float(cycles))
    try:
        flaw = surface_flaw(body, fr["crack"]["front"], fr["crack"]["normal"])
        scene2 = surface_scene(scene, flaw, fr["crack"]["front_size"])
        prepare_surface(scene2, comm)
    except (ParameterError, SceneError) as exc:  # it reaches another surface: the stop
        note = {"refused": str(exc), "increment": start.increment, "cycles": start.cycles}
        return _finish(comm, outdir, part, interior, note, fr, t0)
    try:
        surface = run_surface_crack(scene2, comm, outdir, progress, None, start)
    except SceneError as exc:  # its first mesh
        interior.summary.update(status="failed", message=f"the surface crack: {exc}")
        note = {"refused": str(exc), "increment": start.increment, "cycles": start.cycles}
        return _finish(comm, outdir, part, interior, note, fr, t0)
    note = {
        "increment": start.increment,
        "cycles": start.cycles,
        "interior_status": g["status"],
        "crack": flaw.summary(),
        "front_size": scene2.fracture.tip_size,
    }
    return _finish(comm, outdir, part, surface, note, fr, t0, g["increments"])


def _finish(comm, outdir, part, result, note, interior, t0, last=None) -> RunResult:
    """Merge the tables, write summary.json: the final run's with ``fracture.interior``
    (the interior phase's) and ``fracture.breakthrough`` (``note``)."""
    cycles = None if note is None else note["cycles"]
    if comm.rank == 0:
        merge_tables(outdir, part, last, cycles, interior["crack"]["name"])
    summary = dict(result.summary)
    summary["fracture"] = dict(summary["fracture"], interior=interior, breakthrough=note)
    summary["wall_time_s"] = time.perf_counter() - t0
    write_summary(comm, outdir, summary)
    comm.barrier()
    return RunResult(summary["status"], summary, None, outdir)
