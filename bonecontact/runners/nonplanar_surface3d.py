"""3D scenes whose surface crack grows out of its plane (``[fracture] surface_growth =
"nonplanar"``; docs/theory/fracture.md#non-planar-growth-of-a-surface-crack-in-a-scene).

The scene's semi-elliptical or corner (quarter-elliptical) crack starts as one convex
planar patch: points at equal arc length on its ellipse, the first and the last outside
the body by a front element, closed by the chord outside it (a corner crack's around the
corner, through its edge's point moved out of both faces: :func:`start_crack`); its open
front the arc's vertices (:class:`~bonecontact.fracture.open_front3d.OpenTriangulatedCrack`),
the end edges crossing the surface (a corner crack's on its two faces).  Each increment
meshes the body with the crack (:mod:`~bonecontact.fracture.nonplanar_surface_body3d`),
solves the analysis with the faces a contact pair, takes K_I, K_II, K_III at the middle of
every front edge of the cut (an end edge's inwards when its domain reaches an oblique
surface), advances every vertex by the σ₁′ criterion (weights (K_V/K_V,max)² at K_V ≥ K_Ic
under ``propagate``, the Paris rates of ΔK = (1 − R) K_V under ``[fracture.fatigue]``, the
block cycles by ``FatigueProgress``), puts an end vertex that falls inside the body (or
within a front element of its surface) out along its edge, a front element beyond the
surface (farther until the end strip's outer edge clears the surface:
:func:`end_beyond_surface`), and adds the strips (:mod:`~bonecontact.fracture.open_front3d`).
Stops: ``arrested``, ``max_increments``/``max_blocks``, ``fractured`` (fatigue, K_V ≥
K_Ic), ``through`` (an inner front vertex would leave the body, come within two front
elements of its surface or six ahead of it), ``failed`` (a crack that cannot be cut,
meshed or evaluated).  ``fracture.csv`` a row per increment and front edge,
``crack_surface_<k>.vtk``, ``crack_front_<k>.vtk`` (K), ``increment<k>/`` each solve;
checkpoints and ``restart`` as :mod:`~bonecontact.runners.growth_state3d`'s.
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mpi4py import MPI

import numpy as np

from bonecontact.common.errors import ParameterError, RunError
from bonecontact.common.geometry import line_triangle_hits, nearest_triangle_distance
from bonecontact.common.profiling import PhaseTimer
from bonecontact.fracture.advance3d import equivalent_k, sigma1_kink
from bonecontact.fracture.body3d import BodySurface
from bonecontact.fracture.front3d import FrontSIF, OpenPolylineFront, front_interaction_integral
from bonecontact.fracture.nonplanar_surface_body3d import (
    NonplanarSurfaceCrack,
    mesh_body_with_nonplanar_surface_crack,
)
from bonecontact.fracture.open_front3d import (
    OpenTriangulatedCrack,
    advance_open_front,
    cut_block,
    cut_front,
    extend_open_surface,
    vertex_k,
)
from bonecontact.fracture.surface3d import MIN_DOMAIN_ELEMENTS
from bonecontact.fracture.surface_body3d import (
    CORNER,
    CutBody,
    corner_point,
    cut_mouth,
    inside_body,
)
from bonecontact.meshing.builder import MeshingError
from bonecontact.runners.crack_fatigue import (
    FatigueProgress,
    final_block,
    final_block_note,
    growth_stop,
    growth_weights,
)
from bonecontact.runners.front_growth3d import write_crack_surface
from bonecontact.runners.growth_state3d import find_growth_state, save_growth_state
from bonecontact.runners.mechanics import SceneModel
from bonecontact.runners.results import RecordTable, RunResult, run_summary, write_summary
from bonecontact.runners.surface_crack3d import (
    SHORTEN,
    SurfaceRun,
    crack_tractions,
    cracked_model,
    patch_triangles,
    prepare_surface,
    solve_cracked,
    surface_fragments,
)
from bonecontact.scene import Scene, SceneError
from bonecontact.scene.errors import table_label

if TYPE_CHECKING:
    from bonecontact.fracture.crack3d import SurfaceBreakingCrack

__all__ = [
    "NONPLANAR_COLUMNS",
    "check_nonplanar_surface",
    "end_beyond_surface",
    "grows_nonplanar",
    "run_nonplanar_surface",
    "start_crack",
]

#: Columns of ``fracture.csv`` (a row per increment and front edge, K at its middle).
NONPLANAR_COLUMNS = (
    "increment",
    "cycles",
    "point",
    "x",
    "y",
    "z",
    "K_I",
    "K_II",
    "K_III",
    "K_V",
    "kink_deg",
    "da",
    "status",
)
#: The least number of front edges of the start crack.
MIN_EDGES = 5
#: The least length of a start front edge, in front elements (the mid-edge integral's
#: domain needs half an edge less a front element ≥ 2 elements, with room).
EDGE_ELEMENTS = 8.0
#: The ligament (front elements) an inner front vertex keeps to the body's surface.
LIGAMENT_ELEMENTS = 2.0
#: The room an inner front vertex needs ahead of it (front elements: the integration
#: ring's 4 and 2 more, as the planar runner's r_out + 2h).
AHEAD_ELEMENTS = 6.0
#: The least radius of the integration domain (front elements) where it would reach the
#: body's surface (the ring's default 4).
MIN_RING_ELEMENTS = 2.5
#: Where an end edge's K is taken when its middle's domain reaches the surface: the
#: fractions of the edge from its surface end.
INWARD = (0.6, 0.7)
#: The clearance (front elements) of an end strip's outer edge (old end → new end) from
#: the body's surface: the mesher's least distance of a crack point
#: (``nonplanar_surface_body3d.NEAR_SURFACE``).
OUTER_CLEARANCE = 0.25
#: The farthest an end vertex is put beyond the surface (front elements) to clear it.
MAX_BEYOND = 64.0
#: The stops that break the body (fragments reported).
_BROKEN = ("fractured", "through")


@dataclasses.dataclass(frozen=True)
class EdgeRow:
    """One row of ``fracture.csv`` (:data:`NONPLANAR_COLUMNS`)."""

    increment: int
    cycles: float
    point: int
    x: float
    y: float
    z: float
    K_I: float
    K_II: float
    K_III: float
    K_V: float
    kink_deg: float
    da: float = 0.0  # the mean advance of the edge's two vertices after this solve
    status: str = "grows"

    def row(self) -> list[Any]:
        return [getattr(self, c) for c in NONPLANAR_COLUMNS]


@dataclasses.dataclass
class Growth:
    """The state of the growing crack between solves."""

    crack: OpenTriangulatedCrack
    increments: int = 0
    cycles: float = 0.0
    status: str | None = None
    fatigue: FatigueProgress = dataclasses.field(default_factory=FatigueProgress)
    history: list[dict[str, float]] = dataclasses.field(default_factory=list)
    rows: int = 0  # fracture.csv rows written
    final_block: dict[str, float] | None = None  # the block that carried it through
    shortfall: float = 0.0  # Σ (da_max − the halved blocks' da) (end_halvings)
    halved: int = 0  # blocks shorter than da_max solved before the final one

    def state(self, initial: SurfaceBreakingCrack) -> dict[str, Any]:
        """What a checkpoint stores (JSON; the scene's crack ``initial`` to check a
        restart against)."""
        return {
            "kind": CHECKPOINT_KIND,
            "initial": dataclasses.asdict(initial),
            "crack": dataclasses.asdict(self.crack),
            "cycles": self.cycles,
            "fatigue": self.fatigue.state(),
            "history": self.history,
            "rows": self.rows,
            "shortfall": self.shortfall,
            "halved": self.halved,
        }

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> Growth:
        """The growth a checkpoint stored (its ``increment`` the next to solve)."""
        c = state["crack"]
        crack = OpenTriangulatedCrack(
            tuple(tuple(float(x) for x in p) for p in c["points"]),
            tuple(tuple(int(i) for i in patch) for patch in c["patches"]),
            tuple(int(i) for i in c["front_ids"]),
            tuple(tuple(float(x) for x in n) for n in c["normals2"]),
            None if c["cuts"] is None else tuple(tuple(map(float, k)) for k in c["cuts"]),
            tuple(float(x) for x in c["normal"]),
        )
        return cls(
            crack,
            int(state["increment"]),
            float(state["cycles"]),
            fatigue=FatigueProgress.from_state(state["fatigue"]),
            history=[{k: float(v) for k, v in h.items()} for h in state["history"]],
            rows=int(state["rows"]),
            shortfall=float(state.get("shortfall", 0.0)),
            halved=int(state.get("halved", 0)),
        )


#: ``kind`` of this path's checkpoints.
CHECKPOINT_KIND = "nonplanar_surface_crack"


def _start(run: SurfaceRun, crack: OpenTriangulatedCrack, comm, outdir: Path, restart) -> Growth:
    """A fresh growth from the scene's ``crack``, or the one of the checkpoint ``restart``
    (``True``: the newest under ``outdir``; fracture.csv cut to its rows)."""
    if not restart:
        return Growth(crack)
    initial = dataclasses.asdict(run.crack)
    state = find_growth_state(
        comm, outdir, restart, CHECKPOINT_KIND, initial, run.crack.half_length
    )
    return Growth.from_state(state)


def _error(scene: Scene, key: str | None, text: str) -> SceneError:
    return SceneError(str(scene.path), table_label("crack", 0, scene.cracks[0].name), key, text)


def _pair_name(name: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "_.-" else "_" for ch in name)


def grows_nonplanar(scene: Scene) -> bool:
    """Whether the scene's surface crack grows out of its plane (this module runs it)."""
    fr = scene.fracture
    return fr is not None and fr.surface_growth == "nonplanar"


# ------------------------------------------------------------------ the start crack
def _surface_distance(run: SurfaceRun, points: np.ndarray) -> np.ndarray:
    """The distance of every point from the body's surface (m)."""
    tris = np.asarray(run.body.triangles, dtype=float)
    return nearest_triangle_distance(points, tris)


def _arc_samples(cut: CutBody) -> tuple[np.ndarray, np.ndarray]:
    """φ over the whole ellipse from the middle of the arc (±π) and its arc length s
    from φ₀ (m), 8001 samples."""
    p0, p1 = cut.arc.phi_range
    phi = 0.5 * (p0 + p1) + np.linspace(-math.pi, math.pi, 8001)
    x = np.asarray(cut.arc.point(phi), dtype=float)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(x, axis=0), axis=1))])
    return phi, s - float(np.interp(p0, phi, s))


def _beyond_ends(run: SurfaceRun, cut: CutBody, phi: np.ndarray, s: np.ndarray) -> float:
    """The least arc length δ (in half front elements) beyond both ends of the arc at
    which the ellipse lies outside the body by at least a front element."""
    h = run.size.h_tip
    s1 = float(np.interp(cut.arc.phi_range[1], phi, s))
    for k in range(1, 200):
        ext = 0.5 * k * h
        ends = cut.arc.point(np.interp([-ext, s1 + ext], s, phi))
        ends = np.asarray(ends, dtype=float)
        if not np.any(inside_body(run.body, ends)) and _surface_distance(run, ends).min() >= h:
            return ext
    raise _error(run.scene, "depth", "the crack's ellipse does not leave the body beyond its arc")


def start_crack(run: SurfaceRun, cut: CutBody) -> OpenTriangulatedCrack:
    """The scene's crack as one convex planar patch (module docstring): N + 1 points at
    equal arc length on the ellipse from δ before its arc to δ after it (the ends outside
    the body), N = ⌊length/(8 h)⌋ ≥ 5 edges, closed by the chord outside the body; a
    corner crack's chord would cross the body (through the crack): its patch closes
    around the corner instead (:func:`_around_corner`).

    Raises
    ------
    SceneError
        (``[fracture] tip_size``) fewer than 5 edges of 8 front elements fit; (``depth``)
        the closing chord (path) re-enters the body or an inner vertex lies within two
        front elements of the surface.
    """
    h = run.size.h_tip
    phi, s = _arc_samples(cut)
    ext = _beyond_ends(run, cut, phi, s)
    s1 = float(np.interp(cut.arc.phi_range[1], phi, s))
    total = s1 + 2.0 * ext
    n = int(total // (EDGE_ELEMENTS * h))
    if n < MIN_EDGES:
        raise SceneError(
            str(run.scene.path),
            "[fracture]",
            "tip_size",
            f'surface_growth = "nonplanar" needs {MIN_EDGES} front edges of at least '
            f"{EDGE_ELEMENTS:g} front elements on the crack's arc of {total:.3g} m: choose "
            f"tip_size <= {total / (MIN_EDGES * EDGE_ELEMENTS):.3g} m",
        )
    P = np.asarray(cut.arc.point(np.interp(np.linspace(-ext, s1 + ext, n + 1), s, phi)))
    closing = P[[-1, 0]] if cut.crack.shape != CORNER else _around_corner(cut, P, h)
    if _closing_enters(run, closing) or not _keeps_ligament(run, P[1:-1]):
        raise _error(
            run.scene,
            "depth",
            "the crack cannot start as one patch: its closing chord re-enters the body or a "
            f"front vertex lies within {LIGAMENT_ELEMENTS:g} front elements of the surface",
        )
    if cut.crack.shape == CORNER:
        P = np.vstack([P, closing[1:-1]])
    normal = np.cross(P, np.roll(P, -1, axis=0)).sum(axis=0)
    normal = tuple(map(float, normal / np.linalg.norm(normal)))
    return OpenTriangulatedCrack(
        tuple(map(tuple, P.tolist())),
        (tuple(range(len(P))),),
        tuple(range(n + 1)),
        (normal,) * n,
        None,
        normal,
    )


def _around_corner(cut: CutBody, P: np.ndarray, h: float) -> np.ndarray:
    """A corner crack's closing path from the last point to the first: the chord between
    them crosses the body (through the crack), so the patch closes around the corner,
    through the point of the edge at the crack's centre moved a front element out of
    either face (−h t − h d: t, d the crack's in-plane directions along the faces of c
    and a, which meet at 90 ± 20°; the patch stays one convex polygon)."""
    C = np.asarray(cut.arc.centre, dtype=float)
    c, a = cut.crack.half_length, cut.crack.depth
    t = (corner_point(cut.crack, cut.arc, 0.0) - C) / c
    d = (corner_point(cut.crack, cut.arc, 0.5 * math.pi) - C) / a
    return np.array([P[-1], C - h * (t + d), P[0]])


def _closing_enters(run: SurfaceRun, path: np.ndarray) -> bool:
    """Whether the closing path (its segments sampled 33 times each) enters the body."""
    f = np.linspace(0.0, 1.0, 33)[:, None]
    x = np.vstack([p + f * (q - p) for p, q in zip(path[:-1], path[1:], strict=True)])
    return bool(np.any(inside_body(run.body, x)))


def _keeps_ligament(run: SurfaceRun, points: np.ndarray) -> bool:
    """Whether every point lies inside the body, two front elements from its surface."""
    reach = LIGAMENT_ELEMENTS * run.size.h_tip
    inside = inside_body(run.body, points)
    return bool(np.all(inside) and _surface_distance(run, points).min() >= reach)


def prepare_nonplanar(scene: Scene, comm: MPI.Comm) -> tuple[SurfaceRun, OpenTriangulatedCrack]:
    """The checks of a surface-crack scene (:func:`prepare_surface`) and the start crack."""
    run = prepare_surface(scene, comm)
    if run.crack.shape not in ("semi_elliptical", CORNER):
        raise _error(
            scene,
            "shape",
            'surface_growth = "nonplanar" grows semi_elliptical and quarter_elliptical cracks only',
        )
    return run, start_crack(run, cut_mouth(run.body, run.crack, run.size))


# ---------------------------------------------------------------------- one solve
def _mesh(run: SurfaceRun, crack: OpenTriangulatedCrack, comm: MPI.Comm, timer: PhaseTimer):
    """The body meshed with ``crack``: (cracked body, mesh data, cut)."""
    surface = NonplanarSurfaceCrack(crack.points, crack.patches)
    with timer.phase("mesh_read"):
        return mesh_body_with_nonplanar_surface_crack(run.body, surface, run.size, comm)


def check_nonplanar_surface(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> SceneModel:
    """Every check of the scene, the start crack's mesh and face pair included."""
    run, crack = prepare_nonplanar(scene, comm)
    timer = PhaseTimer()
    try:
        cb, md, _ = _mesh(run, crack, comm, timer)
    except (MeshingError, ParameterError) as exc:
        raise _error(scene, getattr(exc, "key", "depth"), str(exc)) from None
    return cracked_model(run.scene, [(cb, _pair_name(run.name))], md, run.groups, comm, timer)


def _in_crack_order(front: OpenPolylineFront, crack: OpenTriangulatedCrack) -> bool:
    """Whether the cut's front runs as the crack's (else reversed); a
    :class:`RunError` when it does not have one segment per front edge."""
    V, W = np.asarray(front.vertices, dtype=float), crack.vertices
    if len(V) != len(W):
        raise RunError(
            f"the cut front has {len(V) - 1} segments for the crack's {len(W) - 1} front "
            "edges (its end edges must cross the body's surface, the others stay inside)"
        )
    return bool(np.linalg.norm(V[1] - W[1]) <= np.linalg.norm(V[1] - W[-2]))


def edge_modes(u: Any, cb: Any, cut: Any, run: SurfaceRun, crack, traction) -> list[FrontSIF]:
    """K at the middle of every front edge, in the crack's edge order (collective)."""
    front = cut_front(cut, crack.cuts)
    same = _in_crack_order(front, crack)
    if not same:  # the cut's front reversed: its kinks in its own order
        cuts = None if crack.cuts is None else tuple(crack.cuts[::-1])
        front = cut_front(cut, cuts)
    block = cut_block(cb, front)
    h = run.size.h_tip
    r_out = 4.0 * h
    length = min(r_out, min(front.corner_distance(float(p)) for p in front.edge_middles()) - h)
    sifs = []
    for k, p in enumerate(front.edge_middles()):
        for i, phi in enumerate(_candidates(front, k, float(p))):
            dom = (r_out, min(length, front.corner_distance(phi) - h), h)
            try:
                sifs.append(_edge_k(u, block, phi, run.material, dom, traction))
                break
            except ParameterError as exc:
                if exc.key != "r_out" or i == len(INWARD):
                    raise
    return sifs if same else sifs[::-1]


def _candidates(front: OpenPolylineFront, k: int, middle: float) -> list[float]:
    """Where edge ``k``'s K is taken: its middle; on an end edge then the points at the
    fractions :data:`INWARD` of it from the surface end (its domain, shrunk to its least
    size, may still reach an oblique surface at the middle)."""
    n = len(front.edge_lengths)
    if k not in (0, n - 1):
        return [middle]
    ends = np.concatenate([[0.0], np.cumsum(front.edge_lengths)])
    total = float(ends[-1])
    f = np.asarray(INWARD) if k == 0 else 1.0 - np.asarray(INWARD)
    s = ends[k] + f * front.edge_lengths[k]
    return [middle, *(2.0 * math.pi * s / total).tolist()]


def _edge_k(u: Any, block: Any, phi: float, material: Any, dom: tuple, traction) -> FrontSIF:
    """K at ``phi`` with the domain ``dom`` = (r_out, half-length, h_front) of
    :func:`~bonecontact.fracture.open_front3d.open_mid_edge_modes`; where the domain
    reaches the body's surface (an end edge meeting an oblique surface) its half-length
    is shortened by :data:`SHORTEN` down to ``MIN_DOMAIN_ELEMENTS`` front elements, as the
    planar runner does, then its radius down to :data:`MIN_RING_ELEMENTS` (then the error;
    collective)."""
    r_out, length, h = dom
    while True:
        try:
            return front_interaction_integral(
                u, block, phi, material, r_out, None, length, face_traction=traction
            )
        except ParameterError as exc:
            if exc.key != "r_out":
                raise
            if SHORTEN * length >= MIN_DOMAIN_ELEMENTS * h * (1 - 1e-9):
                length *= SHORTEN
            elif SHORTEN * r_out >= MIN_RING_ELEMENTS * h * (1 - 1e-9):
                r_out *= SHORTEN
            else:
                raise


def _rows(sifs: list[FrontSIF], inc: int) -> list[EdgeRow]:
    out = []
    for i, f in enumerate(sifs):
        kv = float(equivalent_k(f.K_I, f.K_II, f.K_III))
        kink = math.degrees(float(sigma1_kink(f.K_I, f.K_II, f.K_III)[0][0]))
        x, y, z = map(float, f.point)
        out.append(EdgeRow(inc, 0.0, i, x, y, z, f.K_I, f.K_II, f.K_III, kv, kink))
    return out


# ------------------------------------------------------------------------ advance
def end_beyond_surface(
    body: BodySurface, h: float, inner: np.ndarray, end: np.ndarray, old: np.ndarray
) -> np.ndarray:
    """An end vertex ``end`` of the grown front, inside the body or within ``h`` (a front
    element) of its surface, moved along the edge from ``inner`` to ``h`` beyond the
    surface; then on along it (``h`` at a time) until the strip's outer edge from the
    ``old`` end clears the surface (:func:`_clears`: on a convex surface of radius R the
    chord between two ends h out dips into the body when it is longer than about
    √(8 R h)).  Raises RunError when the edge misses the surface or no place within
    :data:`MAX_BEYOND` h clears it."""
    tris = np.asarray(body.triangles, dtype=float)
    d = (end - inner) / np.linalg.norm(end - inner)
    if inside_body(body, end[None])[0] or nearest_triangle_distance(end, tris)[0] < h:
        s = line_triangle_hits(inner, d, tris)
        s = s[np.isfinite(s) & (s > 0.0)]
        if len(s) == 0:
            raise RunError("an end of the grown front does not reach the body's surface")
        end = inner + (float(s.min()) + h) * d
    for k in range(int(MAX_BEYOND)):
        if _clears(body, tris, h, old, end + k * h * d):
            return end + k * h * d
    raise RunError(
        f"the outer edge of an end strip stays within {OUTER_CLEARANCE:g} front elements of "
        f"the body's surface (or inside it) with its new end {MAX_BEYOND:g} elements out"
    )


def _clears(body: BodySurface, tris: np.ndarray, h: float, a: np.ndarray, b: np.ndarray) -> bool:
    """Whether the segment a → b lies outside the body, at least :data:`OUTER_CLEARANCE` h
    off its surface (sampled every h/8: a crossing has a sample within h/16 of it)."""
    n = max(2, int(math.ceil(8.0 * float(np.linalg.norm(b - a)) / h)) + 1)
    x = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
    if np.any(inside_body(body, x)):
        return False
    return bool(nearest_triangle_distance(x, tris).min() >= OUTER_CLEARANCE * h)


def _in_plane(p: np.ndarray, q: np.ndarray, r: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``x`` projected on the plane through p, q, r (``x`` itself when they are on a
    line: a held inner vertex)."""
    n = np.cross(q - p, r - p)
    if np.linalg.norm(n) <= 1e-12 * np.linalg.norm(q - p) ** 2:
        return x
    n = n / np.linalg.norm(n)
    return x - float((x - p) @ n) * n


def _quad_ends(grown: OpenTriangulatedCrack, old: OpenTriangulatedCrack, held) -> Any:
    """``grown`` with the two triangles of each end edge's strip (both ends moved) made
    one quadrilateral (planar: the new end vertex lies in the plane of the other three,
    :func:`_in_plane`): its diagonal would cross the body's surface next to the old front
    end, two mouth nodes a fraction of a front element apart."""
    patches = list(grown.patches)
    o, w = old.front_ids, grown.front_ids
    last = len(o) - 1
    for k in (0, last - 1):
        if held[k] or held[k + 1]:
            continue
        a, b, b2, a2 = o[k], o[k + 1], w[k + 1], w[k]
        tris = [i for i, t in enumerate(patches) if set(t) in ({a, b, b2}, {a, b2, a2})]
        if len(tris) != 2:
            continue
        t = patches[tris[0]]
        quad = (a, b, b2, a2)
        same = any(t == tuple(quad[j] for j in idx) for idx in ((0, 1, 2), (1, 2, 0), (2, 0, 1)))
        patches[tris[0]] = quad if same else quad[::-1]
        del patches[tris[1]]
    return dataclasses.replace(grown, patches=tuple(patches))


def _record(g: Growth, run: SurfaceRun, kv: np.ndarray) -> None:
    """The increment's ``history`` entry (``depth``: the front's reach along the scene
    crack's depth direction d = n × t from its centre; :func:`advance` adds ``da``, the
    leading advance of the block after it: 0 at a stop, the final block's at ``through``)."""
    c = run.crack
    d = np.cross(np.asarray(c.normal, dtype=float), np.asarray(c.axis, dtype=float))
    depth = float(np.max((g.crack.vertices - np.asarray(c.centre, dtype=float)) @ d))
    g.history.append(
        {
            "increment": g.increments,
            "cycles": g.cycles,
            "K_V_max": float(kv.max()),
            "K_V_min": float(kv.min()),
            "depth": float(depth),
        }
    )


def _fits(run: SurfaceRun, adv: Any) -> bool:
    """Whether the advanced front keeps its ligament: every inner vertex two front
    elements inside the body and its point :data:`AHEAD_ELEMENTS` ahead inside (else the
    block carries the crack ``through``)."""
    inner = adv.vertices[1:-1]
    ahead = inner + AHEAD_ELEMENTS * run.size.h_tip * adv.directions[1:-1]
    return _keeps_ligament(run, inner) and bool(np.all(inside_body(run.body, ahead)))


def advance(run: SurfaceRun, g: Growth, K: np.ndarray) -> tuple[str | None, np.ndarray]:
    """The stop after this solve (``None``: the crack in ``g`` grown) and the advance of
    every front vertex (zeros at a stop)."""
    fat = run.fracture.fatigue
    kv_vertex = vertex_k(K)
    w = growth_weights(kv_vertex, fat, run.K_Ic)
    lead = float(w.max(initial=0.0))
    if fat is not None:
        g.cycles = g.fatigue.add_end(g.increments * fat.da_max - g.shortfall, lead)
    kv = equivalent_k(K[:, 0], K[:, 1], K[:, 2])
    _record(g, run, kv)
    most = fat.max_blocks if fat is not None else run.fracture.max_increments
    still = np.zeros(len(kv_vertex))
    stop = growth_stop(float(kv.max()), lead, fat, run.K_Ic, g.increments, most)
    g.history[-1]["da"] = 0.0  # the leading advance of the block after this solve
    if stop is not None:
        return stop, still
    step = float(fat.da_max if fat is not None else run.fracture.increment)
    crack = g.crack
    halvings = fat.end_halvings if fat is not None else 0
    for k in range(halvings + 1):  # [fracture.fatigue] end_halvings: the longest that fits
        da = step / 2.0**k
        adv = advance_open_front(crack.vertices, crack.normals2, K, da, weights=w / lead)
        if _fits(run, adv):
            break
    else:
        if fat is not None:  # the last block at the rate of its start
            g.final_block = final_block(g.cycles, da, lead, g.fatigue)
            g.cycles += g.final_block["cycles"]
            g.history[-1]["da"] = da
        return "through", still
    g.history[-1]["da"] = da
    if da < step:
        g.shortfall, g.halved = g.shortfall + (step - da), g.halved + 1
    new = adv.vertices.copy()
    V, last = crack.vertices, len(new) - 1
    for end, inner in ((0, 1), (last, last - 1)):
        if not adv.held[end]:
            w = _in_plane(V[end], V[inner], new[inner], new[end])
            new[end] = end_beyond_surface(run.body, run.size.h_tip, new[inner], w, V[end])
    g.crack = _quad_ends(extend_open_surface(crack, new, adv.held), crack, adv.held)
    g.increments += 1
    return None, adv.da


# --------------------------------------------------------------------------- loop
def _increment(run: SurfaceRun, g: Growth, comm, timer: PhaseTimer, outdir: Path, table):
    """Mesh, solve, evaluate, advance and write one increment; returns (stop, message,
    fragments) (stop ``None``: grow on)."""
    inc, crack = g.increments, g.crack
    try:
        cb, md, cut = _mesh(run, crack, comm, timer)
    except (MeshingError, ParameterError) as exc:
        if inc == 0:
            raise _error(run.scene, getattr(exc, "key", "depth"), str(exc)) from None
        return "failed", f"{_where(run, g)}: the grown crack cannot be meshed: {exc}", None
    faces = [(cb, _pair_name(run.name))]
    out = outdir / f"increment{inc}"
    sm, integ, summary = solve_cracked(run.scene, faces, md, run.groups, comm, timer, out)
    if summary["status"] != "converged":
        integ.destroy()
        return summary["status"], summary.get("message"), None
    try:
        with timer.phase("fracture"):
            traction = crack_tractions(sm, integ, cb, 4.0 * run.size.h_tip)
            sifs = edge_modes(integ.u, cb, cut, run, crack, traction)
    except (ParameterError, RunError) as exc:
        return "failed", f"{_where(run, g)}: no K at the front: {exc}", None
    finally:
        integ.destroy()
    K = np.array([(f.K_I, f.K_II, f.K_III) for f in sifs])
    message = None
    try:
        stop, da = advance(run, g, K)
    except RunError as exc:
        stop, da, message = "failed", np.zeros(len(K) + 1), f"{_where(run, g)}: {exc}"
    rows = [
        dataclasses.replace(r, cycles=g.cycles, da=float(0.5 * (da[k] + da[k + 1])))
        for k, r in enumerate(_rows(sifs, inc))
    ]
    table.rows([dataclasses.replace(r, status=_mark(stop, r.da)) for r in rows])
    g.rows += len(rows)
    if comm.rank == 0:
        write_crack_surface(outdir / f"crack_surface_{inc}.vtk", [crack])
        write_open_front(outdir / f"crack_front_{inc}.vtk", sifs)
    frags = None
    if stop in _BROKEN:
        frags = surface_fragments(cb.mesh, patch_triangles(crack.points, crack.patches))
        message = final_block_note(comm, g.final_block)
    return stop, message, frags


def _mark(stop: str | None, da: float) -> str:
    if stop is not None:
        return stop
    return "grows" if da > 0.0 else "holds"


def _where(run: SurfaceRun, g: Growth) -> str:
    return f"crack {run.name!r}, increment {g.increments}"


def write_open_front(path: Path, sifs: list[FrontSIF]) -> None:
    """The front's mid-edge points as a legacy VTK open line with K_I, K_II, K_III, G."""
    pts = np.array([f.point for f in sifs], dtype=float)
    n = len(pts)
    lines = ["# vtk DataFile Version 3.0", "crack front", "ASCII", "DATASET POLYDATA"]
    lines += [f"POINTS {n} double"] + [" ".join(repr(float(c)) for c in p) for p in pts]
    lines += [f"LINES 1 {n + 1}", " ".join(map(str, [n, *range(n)])), f"POINT_DATA {n}"]
    for name in ("K_I", "K_II", "K_III", "G"):
        lines += [f"SCALARS {name} double 1", "LOOKUP_TABLE default"]
        lines += [repr(float(getattr(f, name))) for f in sifs]
    Path(path).write_text("\n".join(lines) + "\n")


def run_nonplanar_surface(
    scene: Scene,
    comm: MPI.Comm = MPI.COMM_WORLD,
    output: Path | None = None,
    progress: bool = True,
    restart: str | Path | bool | None = None,
) -> RunResult:
    """Validate, build and run a 3D scene whose surface crack grows out of its plane
    (module docstring).  ``restart``: continue from the newest (``True``) or the named
    growth checkpoint (a directory ``checkpoints/increment_<k>`` or its ``growth.json``),
    on any number of ranks."""
    t_start = time.perf_counter()
    timer = PhaseTimer()
    run, crack = prepare_nonplanar(scene, comm)
    outdir = Path(output) if output is not None else scene.output.directory
    if comm.rank == 0:
        outdir.mkdir(parents=True, exist_ok=True)
    g = _start(run, crack, comm, outdir, restart)
    table = RecordTable(comm, outdir / "fracture.csv", NONPLANAR_COLUMNS, append=bool(restart))
    every = scene.output.checkpoint_every
    message, frags = None, None
    try:
        while g.status is None:
            g.status, message, frags = _increment(run, g, comm, timer, outdir, table)
            if g.status is None and every > 0 and g.increments % every == 0:
                with timer.phase("checkpoint"):
                    save_growth_state(comm, outdir, g.increments, g.state(run.crack))
    finally:
        table.close()
    status = "converged" if g.status in _STOPS and g.status != "failed" else "failed"
    if g.status not in _STOPS:  # the solve's status (it did not converge)
        status, g.status = g.status, "failed"
    info = _summary(run, g, frags, timer, comm, t_start, message)
    summary = run_summary(scene.name, status, comm, info["wall_time_s"], **info)
    write_summary(comm, outdir, summary)
    return RunResult(status, summary, None, outdir)


#: The stops of the growth (anything else is the solve's status).
_STOPS = ("arrested", "max_increments", "max_blocks", "fractured", "through", "failed")


def _summary(run, g: Growth, frags, timer, comm, t_start: float, message) -> dict[str, Any]:
    fat = run.fracture.fatigue is not None
    info: dict[str, Any] = {
        "wall_time_s": time.perf_counter() - t_start,
        "fracture": {
            "crack": {
                "name": run.name,
                "shape": "grown",
                "normal": list(g.crack.normal),
                "front_size": run.size.h_tip,
                "front": g.crack.vertices.tolist(),
                "front_normals": [list(n) for n in g.crack.normals2],
            },
            "growth": {
                "model": "nonplanar",
                "rule": "fatigue" if fat else "propagate",
                "criterion": "sigma1_prime",
                "status": g.status,
                "increments": g.increments,
                "cycles": g.cycles if fat else None,
                "K_Ic": run.K_Ic,
                "history": g.history,
                "fractured": g.status in _BROKEN,
                "fragments": frags,
                "final_block": g.final_block,
                "halved_blocks": g.halved,
            },
        },
        "phases_s": timer.summary(comm),
    }
    if message is not None:
        info["message"] = message
    return info
