"""Growth of interior planar cracks in a 3D scene (``[fracture] propagate = true`` or
``[fracture.fatigue]``; docs/scene_format.md#growing-an-interior-3d-crack).

Every ``[[crack]]`` (disc, ellipse or convex polygon) becomes a polygon with every front
edge longer than its integration domain (an ellipse's edges equally long), a
:class:`~bonecontact.fracture.crack3d.TriangulatedCrack`.  Every increment cuts the cracks
into the body (two faces and a contact pair each), solves, takes K_I, K_II, K_III at the
middle of every front edge (:func:`~bonecontact.fracture.advance3d.mid_edge_modes`) and
advances the vertices by the σ₁′ criterion, Δa_i = Δa (K_V,i/K_V,max)² one load, or by
the Paris rates under fatigue (:func:`~bonecontact.runners.crack_fatigue.growth_weights`),
the cycles by ``FatigueProgress`` (docs/theory/fracture.md#fatigue-of-interior-3d-cracks).
A vertex of weight 0 (below K_Ic; ΔK at or below ΔK_th) holds its point
(:func:`~bonecontact.fracture.advance3d.extend_surface`).
Stops: ``arrested``, ``max_increments`` / ``max_blocks``, ``fractured`` (a front reaches
the body's surface under one load; K_V reaches K_Ic under fatigue), ``through`` (fatigue:
near the surface), ``joined`` (near another crack, unless both are coplanar: then, with
``[fracture] joined = "merge"``, they become their convex hull and grow on,
:func:`_merge`), ``not_convex`` (an advanced front that is not a convex polygon).
``fracture.csv``: a row per increment, crack and mid-edge (with the cycles, the advance
``da`` of the edge's first vertex, ``holds`` for an edge that does not move, ``merged``
for the edges of cracks that merged after the solve);
``crack_surface_<k>.vtk``, ``crack_front_<k>.vtk`` and ``increment<k>/`` per increment;
with ``checkpoint_every`` the growth state (:mod:`~bonecontact.runners.growth_state3d`)
to restart from on any number of ranks.
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np

from bonecontact.common.errors import ParameterError
from bonecontact.common.profiling import PhaseTimer
from bonecontact.fracture.advance3d import (
    advance_mixed_front,
    equivalent_k,
    extend_surface,
    front_defects,
    mid_edge_modes,
    sigma1_kink,
    vertex_directions,
)
from bonecontact.fracture.body3d import (
    BodySurface,
    CrackedBody3D,
    mesh_body_with_planar_crack,
    mesh_body_with_planar_cracks,
)
from bonecontact.fracture.coalescence import coplanar, hull_polygon
from bonecontact.fracture.crack3d import (
    PlanarCrack,
    TriangulatedCrack,
    planar_crack_from_table,
    triangulated_from_polygon,
)
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.surface_body3d import inside_body
from bonecontact.meshing.builder import MeshingError
from bonecontact.runners.crack_fatigue import (
    FatigueProgress,
    final_block,
    final_block_note,
    growth_stop,
    growth_weights,
    self_similar_slope,
    size_from_vertex,
)
from bonecontact.runners.cracks3d import write_front
from bonecontact.runners.growth_state3d import find_growth_state, save_growth_state
from bonecontact.runners.mechanics import SceneModel
from bonecontact.runners.results import RecordTable, RunResult, run_summary, write_summary
from bonecontact.runners.surface_crack3d import (
    body_and_material,
    crack_tractions,
    cracked_model,
    patch_triangles,
    solve_cracked,
    surface_fragments,
)
from bonecontact.scene import Scene, SceneError
from bonecontact.scene.errors import table_label
from bonecontact.scene.spec import FractureSpec

__all__ = [
    "GROWTH3D_COLUMNS",
    "check_interior_growth",
    "equal_chords",
    "grows_interior_crack",
    "run_interior_growth",
]

#: Columns of ``fracture.csv`` of a growing interior crack (a row per increment and edge).
GROWTH3D_COLUMNS = (
    "increment",
    "cycles",
    "crack",
    "point",
    "s",
    "x",
    "y",
    "z",
    "K_I",
    "K_II",
    "K_III",
    "G",
    "K_V",
    "kink_deg",
    "status",
    "da",
)


@dataclasses.dataclass(frozen=True)
class EdgeRecord:
    """One row of ``fracture.csv`` (:data:`GROWTH3D_COLUMNS`): K at the middle of a front
    edge."""

    increment: int
    crack: str
    point: int
    s: float
    x: float
    y: float
    z: float
    K_I: float
    K_II: float
    K_III: float
    G: float
    K_V: float
    kink_deg: float
    status: str = "grows"
    cycles: float = 0.0  # the cumulative cycles N at this block end (fatigue; else 0)
    da: float = 0.0  # the advance of vertex `point` (the edge's first) after this solve

    def row(self) -> list[Any]:
        return [getattr(self, c) for c in GROWTH3D_COLUMNS]


@dataclasses.dataclass(frozen=True)
class InteriorRun:
    """What growing interior cracks need besides the scene model."""

    scene: Scene  # with the cracks' face pairs added last, in the scene's order
    names: tuple[str, ...]
    body: BodySurface
    material: Any
    size: TipMesh
    groups: dict[str, tuple[int, int]]
    fracture: FractureSpec
    K_Ic: float | None  # optional under fatigue

    @property
    def ligament(self) -> float:
        """The least distance ahead of the front to the surface (m): the integration
        domain (4 front elements) and two more."""
        return 6.0 * self.size.h_tip


@dataclasses.dataclass
class Growth:
    """The state of the growing cracks between solves."""

    cracks: list[TriangulatedCrack]
    increments: int = 0
    status: str | None = None
    history: list[dict[str, float]] = dataclasses.field(default_factory=list)
    rows: int = 0  # fracture.csv rows written
    at: int = 0  # the crack that stopped the growth (fractured, through, joined)
    cycles: float = 0.0
    fatigue: FatigueProgress = dataclasses.field(default_factory=FatigueProgress)
    defect: str | None = None  # why an advanced front was refused (stop not_convex)
    names: list[str] | None = None  # the cracks' names after merges (None: the scene's)
    coefficients: list[float] | None = None  # their face pairs' friction (idem)
    merges: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    joined: str = ""  # why cracks that met were not merged (stop joined)
    final_block: dict[str, float] | None = None  # the block that carried a crack through
    shortfall: float = 0.0  # Σ (da_max − the halved blocks' da) (end_halvings)
    halved: int = 0  # blocks shorter than da_max solved before the final one

    def state(self, initial: list[TriangulatedCrack]) -> dict[str, Any]:
        """What a checkpoint stores (JSON; :mod:`~bonecontact.runners.growth_state3d`)."""
        return {
            "kind": "interior_crack",
            "initial": _geometry(initial),
            "cracks": [dataclasses.asdict(c) for c in self.cracks],
            "history": self.history,
            "rows": self.rows,
            "cycles": self.cycles,
            "fatigue": self.fatigue.state(),
            "names": self.names,
            "coefficients": self.coefficients,
            "merges": self.merges,
            "shortfall": self.shortfall,
            "halved": self.halved,
        }

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> Growth:
        """The growth a checkpoint stored (its ``increment`` the next to solve)."""
        cracks = [_crack_from_state(c) for c in state["cracks"]]
        hist = list(state["history"])
        return cls(
            cracks,
            int(state["increment"]),
            None,
            hist,
            int(state["rows"]),
            cycles=float(state.get("cycles", 0.0)),
            fatigue=FatigueProgress.from_state(state.get("fatigue")),
            names=state.get("names"),
            coefficients=state.get("coefficients"),
            merges=list(state.get("merges", [])),
            shortfall=float(state.get("shortfall", 0.0)),
            halved=int(state.get("halved", 0)),
        )


def _crack_from_state(c: dict[str, Any]) -> TriangulatedCrack:
    return TriangulatedCrack(
        tuple(tuple(map(float, p)) for p in c["points"]),
        tuple(tuple(map(int, q)) for q in c["patches"]),
        tuple(map(int, c["front_ids"])),
        tuple(tuple(map(float, n)) for n in c["normals2"]),
        None if c["cuts"] is None else tuple(tuple(map(float, k)) for k in c["cuts"]),
        tuple(map(float, c["normal"])),
    )


def _geometry(cracks: list[TriangulatedCrack]) -> dict[str, Any]:
    """The initial polygons as a checkpoint compares them with the scene's."""
    return {
        "vertices": [c.vertices.tolist() for c in cracks],
        "normal": [list(c.normal) for c in cracks],
    }


def grows_interior_crack(scene: Scene) -> bool:
    """Whether this module runs the scene: 3D, ``propagate`` or ``[fracture.fatigue]``,
    planar interior cracks."""
    fr = scene.fracture
    return (
        scene.dimension == 3
        and fr is not None
        and (fr.propagate or fr.fatigue is not None)
        and bool(scene.cracks)
        and all(isinstance(c.crack, PlanarCrack) for c in scene.cracks)
    )


def _error(scene: Scene, index: int, key: str | None, text: str) -> SceneError:
    return SceneError(
        str(scene.path), table_label("crack", index, scene.cracks[index].name), key, text
    )


def _refuse(scene: Scene) -> None:
    if len({c.region for c in scene.cracks}) > 1:
        raise _error(scene, 1, "region", "the cracks of a 3D scene lie in one body (one region)")
    if scene.analysis.kind != "static":
        raise SceneError(
            str(scene.path),
            "[analysis]",
            "kind",
            f"a growing 3D crack runs static analyses, not {scene.analysis.kind!r}",
        )


def as_polygon(crack: PlanarCrack, h_front: float) -> TriangulatedCrack:
    """The crack as a one-patch triangulated polygon: a polygon as it is; a disc the
    polygon of N vertices on its circle at the parameters 2π(k + ½)/N, an ellipse the
    inscribed N-gon of equal edges (:func:`equal_chords`; N even), N the largest from
    max(6, ⌊P/(6 h_f)⌋) (P the perimeter) down to 6 whose edges hold 6 h_f
    (counter-clockwise about the normal)."""
    if crack.vertices is None:
        front = crack.front()
        phi = np.linspace(0.0, 2 * math.pi, 721)
        pts = front.point(phi)
        perimeter = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
        step = 1 if crack.a == crack.b else 2
        n = max(6, int(perimeter / (6.0 * h_front)))
        n -= n % step
        t = _vertex_parameters(crack, n)
        while n - step >= 6 and _chord(crack.a, crack.b, t) < 6.0 * h_front:
            n -= step
            t = _vertex_parameters(crack, n)
        V = front.point(t)
        table = {"shape": "polygon", "vertices": V.tolist(), "normal": list(crack.normal)}
        crack = planar_crack_from_table(table)
    return triangulated_from_polygon(crack)


def _vertex_parameters(crack: PlanarCrack, n: int) -> np.ndarray:
    """The parameters of the n vertices of a disc's or an ellipse's polygon."""
    if crack.a == crack.b:
        return 2 * math.pi * (np.arange(n) + 0.5) / n
    return equal_chords(crack.a, crack.b, n)


def _chord(a: float, b: float, t: np.ndarray) -> float:
    """The shortest edge of the polygon of the ellipse points at the parameters ``t``."""
    p = np.column_stack([a * np.cos(t), b * np.sin(t)])
    return float(np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1).min())


def equal_chords(a: float, b: float, n: int, iterations: int = 60) -> np.ndarray:
    """The parameters t_k of the n-gon inscribed in the ellipse (a cos t, b sin t) whose
    edges are equally long, its edge from vertex n − 1 to vertex 0 across the end of the
    major axis (symmetric about both axes for even n).

    From equal arc lengths (vertex k at (k + ½)P/n from the end of the axis a), each
    iteration gives edge k the arc Δs_k ∝ Δs_k/c_k (c_k its chord): the chords of a
    smooth curve vary slowly with the arc, and the spread of the edges falls by about
    the square of the step's change every iteration (to round-off in a few).
    """
    t = np.linspace(0.0, 2 * math.pi, 40001)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(a * np.diff(np.cos(t)), b * np.diff(np.sin(t))))])
    total = float(s[-1])
    arcs = np.full(n, total / n)  # arc k: vertex k to k + 1
    for _ in range(iterations):
        at = np.mod(0.5 * arcs[-1] + np.concatenate([[0.0], np.cumsum(arcs[:-1])]), total)
        tk = np.interp(at, s, t)
        p = np.column_stack([a * np.cos(tk), b * np.sin(tk)])
        chords = np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)
        if np.ptp(chords) <= 1e-13 * chords.max():
            break
        arcs = arcs / chords
        arcs *= total / arcs.sum()
    return tk


def _probes(V: np.ndarray, directions: np.ndarray, reach: float) -> np.ndarray:
    """Points ``reach`` ahead of the vertices and of the middles of the edges."""
    mid = 0.5 * (V + np.roll(V, -1, axis=0))
    d_mid = directions + np.roll(directions, -1, axis=0)
    d_mid /= np.linalg.norm(d_mid, axis=1)[:, None]
    return np.concatenate([V + reach * directions, mid + reach * d_mid])


def _reaches_surface(run: InteriorRun, V: np.ndarray, directions: np.ndarray) -> bool:
    return not bool(np.all(inside_body(run.body, _probes(V, directions, run.ligament))))


def prepare_interior(scene: Scene, comm: MPI.Comm) -> tuple[InteriorRun, list[TriangulatedCrack]]:
    """Read the mesh and the body's surface, take the material and its K_Ic, the front
    mesh and the cracks as polygons; refuse a front within the ligament of the surface or
    of another crack (a :class:`SceneError` on every rank)."""
    _refuse(scene)
    fr = scene.fracture if scene.fracture is not None else FractureSpec()
    body, material, k_ic, groups = body_and_material(scene, comm)
    h = fr.tip_size if fr.tip_size is not None else min(c.crack.b for c in scene.cracks) / 10
    size = TipMesh(h, fr.tip_grading if fr.tip_grading is not None else 0.12)
    cracks = [_polygon(scene, i, h) for i in range(len(scene.cracks))]
    pairs = tuple(
        c.face_pair(_pair_name(c.name), "crack_upper", "crack_lower") for c in scene.cracks
    )
    scene2 = dataclasses.replace(scene, contacts=tuple(scene.contacts) + pairs)
    names = tuple(c.name for c in scene.cracks)
    k_ic = float(k_ic) if k_ic else None
    run = InteriorRun(scene2, names, body, material, size, groups, fr, k_ic)
    for i, crack in enumerate(cracks):
        V = crack.vertices
        stop = _meets(run, cracks, i, V, vertex_directions(V, crack.normal))
        if stop is not None:
            where = "the body's surface" if stop == "fractured" else "another crack"
            raise _error(
                scene,
                i,
                scene.cracks[i].crack.size_key,
                f"the crack's front comes within {run.ligament:.3g} m of {where} (the "
                "integration domain and two front elements): a smaller crack or tip_size",
            )
    return run, cracks


def _polygon(scene: Scene, index: int, h: float) -> TriangulatedCrack:
    """The ``index``-th crack as a polygon whose edges hold the integration domain."""
    try:
        crack = as_polygon(scene.cracks[index].crack, h)
    except ParameterError as exc:
        raise _error(scene, index, exc.key, str(exc)) from None
    if min(crack.front().edge_lengths) < 6.0 * h:
        raise SceneError(
            str(scene.path),
            "[fracture]",
            "tip_size",
            f"the front's edges ({min(crack.front().edge_lengths):.3g} m) must hold the "
            f"integration domain (6 front elements of {h:.3g} m): a smaller tip_size",
        )
    return crack


def _meets(run: InteriorRun, cracks: list, i: int, V: np.ndarray, d: np.ndarray) -> str | None:
    """``fractured`` when the front ``V`` of crack ``i`` (advancing along ``d``) comes
    within the ligament of the body's surface, ``joined`` when within it of another
    crack's surface, else ``None``."""
    if _reaches_surface(run, V, d):
        return "fractured"
    return "joined" if _met(run, cracks, i, V, d) is not None else None


def _met(run: InteriorRun, cracks: list, i: int, V: np.ndarray, d: np.ndarray) -> int | None:
    """The first crack other than ``i`` within the ligament of the front ``V`` (advancing
    along ``d``), or ``None``."""
    probes = np.concatenate([V, _probes(V, d, run.ligament)])
    for j, other in enumerate(cracks):
        if j != i and _surface_distance(probes, other) < run.ligament:
            return j
    return None


def _surface_distance(points: np.ndarray, crack: TriangulatedCrack) -> float:
    """Distance from ``points`` (n, 3) to the patches of ``crack`` (m): to a patch's plane
    where a point projects inside it, else to its edges."""
    P = np.asarray(crack.points, dtype=float)
    best = np.full(len(points), np.inf)
    for patch in crack.patches:
        Q = P[list(patch)]
        n = np.cross(Q[1] - Q[0], Q[2] - Q[0])
        n /= np.linalg.norm(n)
        h = (points - Q[0]) @ n
        foot = points - h[:, None] * n
        inside = np.ones(len(points), dtype=bool)
        for a, b in zip(Q, np.roll(Q, -1, axis=0), strict=True):
            inside &= np.cross(b - a, foot - a) @ n >= 0
            t = np.clip((points - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
            edge = np.linalg.norm(points - (a + t[:, None] * (b - a)), axis=1)
            best = np.minimum(best, edge)
        best = np.where(inside, np.minimum(best, np.abs(h)), best)
    return float(best.min())


def _pair_name(name: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "_.-" else "_" for ch in name)


def check_interior_growth(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> SceneModel:
    """Every check of growing interior cracks, the cracked mesh and the face pairs
    included (nothing written); the scene model on that mesh."""
    run, cracks = prepare_interior(scene, comm)
    timer = PhaseTimer()
    cbs, md = _mesh(run, cracks, comm, timer)
    return cracked_model(run.scene, _faces(run, cbs), md, run.groups, comm, timer, _key(run))


def _key(run: InteriorRun) -> str:
    return run.scene.cracks[0].crack.size_key


def _faces(run: InteriorRun, cbs: list[CrackedBody3D]) -> list[tuple[CrackedBody3D, str]]:
    return [(cb, _pair_name(name)) for cb, name in zip(cbs, run.names, strict=True)]


def _mesh(run: InteriorRun, cracks: list[TriangulatedCrack], comm: MPI.Comm, timer: PhaseTimer):
    try:
        with timer.phase("mesh_read"):
            if len(cracks) == 1:
                cb, md = mesh_body_with_planar_crack(run.body, cracks[0], run.size, comm)
                return [cb], md
            return mesh_body_with_planar_cracks(run.body, cracks, run.size, comm)
    except MeshingError as exc:
        raise _error(run.scene, 0, "tip_size", str(exc)) from None


def evaluate(u: Any, cb: CrackedBody3D, run: InteriorRun, name: str, inc: int, traction) -> list:
    """K at the middle of every front edge, K_V and the σ₁′ kink (collective)."""
    crack: TriangulatedCrack = cb.crack
    sifs = mid_edge_modes(crack, cb.block(), u, run.material, run.size.h_tip, traction)
    front = crack.front()
    phis = crack.front_parameters(1)
    out = []
    for i, (f, phi) in enumerate(zip(sifs, phis, strict=True)):
        kv = float(equivalent_k(f.K_I, f.K_II, f.K_III))
        kink = math.degrees(float(sigma1_kink(f.K_I, f.K_II, f.K_III)[0][0]))
        s = float(front.arc_length(float(phi)) - front.arc_length(0.0))
        x, y, z = f.point
        out.append(EdgeRecord(inc, name, i, s, x, y, z, f.K_I, f.K_II, f.K_III, f.G, kv, kink))
    return out


def _advance(
    run: InteriorRun, g: Growth, records: list[list[EdgeRecord]]
) -> tuple[str | None, list[np.ndarray]]:
    """The stop after this solve (a block end under fatigue), or the next cracks in ``g``
    (``None``: grow), and the advance of every crack's vertices (zeros at a stop): the
    vertices' growth weights (:func:`growth_weights`: the Paris rates, or (K_V/K_V,max)²
    at K_Ic), the cycles of the block just made (fatigue), the stop
    (:func:`growth_stop`), then every crack with a weight above 0 advances."""
    K = [np.array([(r.K_I, r.K_II, r.K_III) for r in rec]) for rec in records]
    kv = np.concatenate([[r.K_V for r in rec] for rec in records])
    kv_vertex = [equivalent_k(*(0.5 * (k + np.roll(k, 1, axis=0))).T) for k in K]
    fat = run.fracture.fatigue
    flat = growth_weights(np.concatenate(kv_vertex), fat, run.K_Ic)
    lead = float(flat.max(initial=0.0))
    if fat is not None:
        g.cycles = g.fatigue.add_end(g.increments * fat.da_max - g.shortfall, lead)
    g.history.append(
        {
            "increment": g.increments,
            "cycles": g.cycles,
            "K_V_max": float(kv.max()),
            "K_V_min": float(kv.min()),
            "mean_radius": _mean_radius(g.cracks[0]),
        }
    )
    most = fat.max_blocks if fat is not None else run.fracture.max_increments
    stop = growth_stop(float(kv.max()), lead, fat, run.K_Ic, g.increments, most)
    still = [np.zeros(len(v)) for v in kv_vertex]
    if stop is not None or float(kv.min()) <= 0.0:
        g.at = int(np.argmax([float(v.max()) for v in kv_vertex]))
        return stop or "arrested", still
    weights = _vertex_weights(kv_vertex, flat)
    return _grow_fronts(run, g, K, weights, still)


def _vertex_weights(kv_vertex: list[np.ndarray], flat: np.ndarray) -> list:
    """Each crack's vertex weights (:func:`growth_weights` ``flat`` of all the fronts),
    the largest of all 1, ``None`` for a crack that holds: fatigue the rates over the
    largest, one load (K_V/K_V,max)² at the vertices at K_Ic; a vertex of weight 0 (at or
    below ΔK_th; below K_Ic) holds
    (:func:`~bonecontact.fracture.advance3d.advance_mixed_front`)."""
    parts = np.split(flat, np.cumsum([len(v) for v in kv_vertex])[:-1])
    top = float(flat.max())
    return [None if float(w.max()) <= 0.0 else w / top for w in parts]


def _grow_fronts(
    run: InteriorRun, g: Growth, K: list, weights: list, still: list[np.ndarray]
) -> tuple[str | None, list[np.ndarray]]:
    """Advance every crack by the increment (fatigue: Δa_max; :func:`_grow_by`).  With
    ``[fracture.fatigue] end_halvings`` = n (not while an interior crack would become a
    surface crack), a block that would carry a crack through is made Δa_max/2, …,
    Δa_max/2ⁿ instead, the longest that does not; only Δa_max/2ⁿ is the final block."""
    fat = run.fracture.fatigue
    step = float(fat.da_max if fat is not None else run.fracture.increment)
    most = 0
    if fat is not None and run.fracture.breakthrough != "surface_crack":
        most = fat.end_halvings
    for k in range(most + 1):
        da = step / 2.0**k
        stop, advances = _grow_by(run, g, K, weights, still, da, final=k == most)
        if stop == _HALVE:
            continue
        if stop is None and k > 0:
            g.shortfall, g.halved = g.shortfall + (step - da), g.halved + 1
        return stop, advances
    raise AssertionError("unreachable: the last halving is final")


#: :func:`_grow_by`'s answer when its block would carry a crack through and a shorter one
#: may be tried.
_HALVE = "halve"


def _grow_by(
    run: InteriorRun,
    g: Growth,
    K: list,
    weights: list,
    still: list[np.ndarray],
    step: float,
    final: bool = True,
) -> tuple[str | None, list[np.ndarray]]:
    """Advance every crack with weights by ``step`` (fatigue: Δa_max or a halving) times them
    (its vertices of weight 0 hold: the strip only where the front moves,
    :func:`~bonecontact.fracture.advance3d.extend_surface`); a stop when a front would
    come near the surface (``fractured``; fatigue: ``through``, the block's cycles at its
    start rate added) or another crack (``joined``), or an advanced front that is not a
    convex polygon in the crack plane (``not_convex``, :func:`front_defects`: the
    increment, crack and vertices in ``g.defect``).  Returns the stop and the vertices'
    advances (``still``, zeros, at a stop: the cracks stay the last good ones)."""
    fat = run.fracture.fatigue
    new, advances, merging = list(g.cracks), list(still), []
    for i, crack in enumerate(g.cracks):
        if weights[i] is None:
            continue
        adv = advance_mixed_front(crack.vertices, crack.normals2, K[i], step, weights=weights[i])
        defect = front_defects(adv.vertices, crack.normal)
        if defect is not None:
            g.at = i
            g.defect = (
                f"crack {run.names[i]!r}, increment {g.increments}: the advanced front is not "
                f"a convex polygon ({defect}); the front before it kept"
            )
            return "not_convex", still
        stop = _meets(run, g.cracks, i, adv.vertices, adv.directions)
        if stop == "joined" and run.fracture.joined == "merge":
            merging.append((i, _met(run, g.cracks, i, adv.vertices, adv.directions)))
            stop = None
        elif stop == "joined":
            g.joined = '[fracture] joined = "stop"'
        if stop is not None:
            g.at = i
            if fat is not None and stop == "fractured" and not final:
                return _HALVE, still  # try the block halved
            if fat is not None and stop == "fractured":
                g.final_block = final_block(
                    g.cycles, step, float(g.fatigue.lead_rate[-1]), g.fatigue
                )
                g.cycles += g.final_block["cycles"]
                stop = "through"
            return stop, still
        new[i] = extend_surface(crack, adv.vertices, adv.held)
        advances[i] = adv.da
    slope = 0.0
    if merging and fat is not None:
        slope = self_similar_slope(fat.m, _lead_size(g.cracks, weights))
    if merging and _merge(run, g, new, merging, slope):
        return "joined", still
    g.cracks, g.increments = new, g.increments + 1
    return None, advances


def _groups(pairs: list[tuple[int, int]]) -> list[list[int]]:
    """The sets of cracks joined by ``pairs``, each sorted, in the order of their first."""
    groups: list[set[int]] = []
    for i, j in pairs:
        hit = [s for s in groups if i in s or j in s]
        merged = set().union({i, j}, *hit)
        groups = [s for s in groups if s not in hit] + [merged]
    return sorted((sorted(s) for s in groups), key=lambda s: s[0])


def _lead_size(cracks: list[TriangulatedCrack], weights: list) -> float:
    """The size ρ of the crack of the leading vertex (the largest weight,
    :func:`_vertex_weights`) seen from that vertex (:func:`size_from_vertex`)."""
    i = max((k for k, w in enumerate(weights) if w is not None), key=lambda k: weights[k].max())
    return size_from_vertex(cracks[i].vertices, int(np.argmax(weights[i])))


def _merge(
    run: InteriorRun, g: Growth, new: list, pairs: list[tuple[int, int]], slope: float = 0.0
) -> bool:
    """The advanced cracks ``new`` whose fronts met (``pairs``) merged in place into the
    convex hull of each coplanar set (:func:`hull_polygon`, edges of at least the
    ligament, as :func:`as_polygon`), named ``"<a>+<b>"``; ``True`` (nothing merged, the
    reason in ``g.joined``) when a set is not coplanar (within half a front element),
    differs in friction, or its hull would come within the ligament of the surface or
    of another crack.  Under fatigue the block history starts anew, ``slope`` (the
    leading vertex's self-similar d ln(da/dN)/ds) kept for the merging block."""
    names = list(g.names or run.names)
    coefs = list(g.coefficients or [c.coefficient for c in run.scene.cracks])
    out, merges = [], []
    done: set[int] = set()
    for group in _groups(pairs):
        label = " and ".join(repr(names[k]) for k in group)
        pts = np.concatenate([np.asarray(new[k].points, dtype=float) for k in group])
        normal = np.asarray(new[group[0]].normal, dtype=float)
        why = coplanar(pts, normal, 0.5 * run.size.h_tip)
        if len({coefs[k] for k in group}) > 1:
            why = why or "their faces have different friction coefficients"
        if not why:
            V = hull_polygon(pts, normal, run.ligament)
            table = {"shape": "polygon", "vertices": V.tolist(), "normal": normal.tolist()}
            merged = triangulated_from_polygon(planar_crack_from_table(table))
            rest = [c for k, c in enumerate(new) if k not in group]
            if _meets(run, [merged, *rest], 0, V, vertex_directions(V, normal)) is not None:
                why = "the merged crack would come within the ligament of the surface or a crack"
        if why:
            g.at, g.joined = group[0], f"not merged: cracks {label} met: {why}"
            return True
        into = "+".join(names[k] for k in group)
        merges.append({"cracks": [names[k] for k in group], "into": into})
        out.append((group[0], merged, into, coefs[group[0]]))
        done |= set(group)
    out += [(k, c, names[k], coefs[k]) for k, c in enumerate(new) if k not in done]
    out.sort(key=lambda e: e[0])
    new[:] = [e[1] for e in out]
    g.names, g.coefficients = [e[2] for e in out], [e[3] for e in out]
    g.merges += [m | {"increment": g.increments} for m in merges]
    if run.fracture.fatigue is not None:
        g.fatigue.merged({}, slope)
    return False


def _renamed(run: InteriorRun, g: Growth) -> InteriorRun:
    """The run with the cracks of ``g`` after merges: their names and face pairs."""
    if g.names is None or tuple(g.names) == run.names:
        return run
    contacts = tuple(run.scene.contacts)
    base = contacts[: len(contacts) - len(run.names)]
    spec = run.scene.cracks[0]
    pairs = tuple(
        dataclasses.replace(spec, name=n, coefficient=c).face_pair(
            _pair_name(n), "crack_upper", "crack_lower"
        )
        for n, c in zip(g.names, g.coefficients or [], strict=True)
    )
    scene = dataclasses.replace(run.scene, contacts=base + pairs)
    return dataclasses.replace(run, scene=scene, names=tuple(g.names))


def _mean_radius(crack: TriangulatedCrack) -> float:
    V = crack.vertices
    return float(np.mean(np.linalg.norm(V - V.mean(axis=0), axis=1)))


def write_crack_surface(path: Path, cracks: list[TriangulatedCrack]) -> None:
    """The crack surfaces as legacy VTK polygons (their planar patches)."""
    P, patches, base = [], [], 0
    for c in cracks:
        P += list(c.points)
        patches += [tuple(base + i for i in q) for q in c.patches]
        base += len(c.points)
    lines = ["# vtk DataFile Version 3.0", "crack surface", "ASCII", "DATASET POLYDATA"]
    lines += [f"POINTS {len(P)} double"] + [" ".join(repr(float(c)) for c in p) for p in P]
    lines += [f"POLYGONS {len(patches)} {sum(len(q) + 1 for q in patches)}"]
    lines += [" ".join(map(str, [len(q), *q])) for q in patches]
    Path(path).write_text("\n".join(lines) + "\n")


def _increment(run: InteriorRun, g: Growth, comm, timer, outdir: Path, table: RecordTable):
    """Mesh, solve, evaluate, advance and write one increment; returns (stop, the meshes
    seen from each crack, summary) (``summary``: the solve's, when it did not converge)."""
    cbs, md = _mesh(run, g.cracks, comm, timer)
    out = outdir / f"increment{g.increments}"
    faces = _faces(run, cbs)
    sm, integ, summary = solve_cracked(
        run.scene, faces, md, run.groups, comm, timer, out, _key(run)
    )
    if summary["status"] != "converged":
        integ.destroy()
        return None, cbs, summary
    records = []
    with timer.phase("fracture"):
        for i, (cb, name) in enumerate(zip(cbs, run.names, strict=True)):
            back = i - len(cbs)
            traction = crack_tractions(sm, integ, cb, 4.0 * run.size.h_tip, back)
            records.append(evaluate(integ.u, cb, run, name, g.increments, traction))
    integ.destroy()
    cracks, inc = g.cracks, g.increments
    stop, advances = _advance(run, g, records)
    merged = {n for m in g.merges if m["increment"] == inc for n in m["cracks"]}
    rows = [
        dataclasses.replace(
            r,
            status="merged" if r.crack in merged else _mark(stop, da, k),
            cycles=g.cycles,
            da=float(da[k]),
        )
        for rec, da in zip(records, advances, strict=True)
        for k, r in enumerate(rec)
    ]
    table.rows(rows)
    g.rows += len(rows)
    if comm.rank == 0:
        write_crack_surface(outdir / f"crack_surface_{inc}.vtk", cracks)
        for name, rec in zip(run.names, records, strict=True):
            tag = "" if len(cracks) == 1 else f"{_pair_name(name)}_"
            write_front(outdir / f"crack_front_{tag}{inc}.vtk", rec)
    return stop, cbs, None


def _mark(stop: str | None, da: np.ndarray, k: int) -> str:
    """The status of edge ``k`` (vertex k to k + 1): the stop, else ``holds`` when both
    its ends hold, else ``grows`` (the edges of cracks that merged after this solve are
    marked ``merged`` instead, :func:`_increment`)."""
    if stop is not None:
        return stop
    return "holds" if da[k] == 0.0 and da[(k + 1) % len(da)] == 0.0 else "grows"


def _start(run: InteriorRun, cracks: list, comm, outdir: Path, restart) -> Growth:
    """A fresh growth, or the one of the checkpoint ``restart`` (fracture.csv cut to its
    rows)."""
    if not restart:
        return Growth(list(cracks))
    size = max(c.front().a for c in cracks)
    state = find_growth_state(comm, outdir, restart, "interior_crack", _geometry(cracks), size)
    return Growth.from_state(state)


def run_interior_growth(
    scene: Scene,
    comm: MPI.Comm = MPI.COMM_WORLD,
    output: Path | None = None,
    progress: bool = True,
    restart: str | Path | bool | None = None,
) -> RunResult:
    """Validate, build and run a 3D scene whose interior crack grows (module docstring);
    ``restart``: continue from the newest (``True``) or the named growth checkpoint
    (:mod:`~bonecontact.runners.growth_state3d`)."""
    t_start = time.perf_counter()
    timer = PhaseTimer()
    run, cracks = prepare_interior(scene, comm)
    outdir = Path(output) if output is not None else scene.output.directory
    if comm.rank == 0:
        outdir.mkdir(parents=True, exist_ok=True)
    g = _start(run, cracks, comm, outdir, restart)
    run = _renamed(run, g)
    table = RecordTable(comm, outdir / "fracture.csv", GROWTH3D_COLUMNS, append=bool(restart))
    status, message, frags = "converged", None, None
    every = scene.output.checkpoint_every
    try:
        while g.status is None:
            stop, cbs, failed = _increment(run, g, comm, timer, outdir, table)
            run = _renamed(run, g)
            if failed is not None:
                status, message = failed["status"], failed.get("message")
                break
            g.status = stop
            if stop in _BROKEN and run.fracture.breakthrough != "surface_crack":
                message = final_block_note(comm, g.final_block)  # (else the surface goes on)
                c = g.cracks[g.at]
                frags = surface_fragments(cbs[0].mesh, patch_triangles(c.points, c.patches))
            elif stop is None and every > 0 and g.increments % every == 0:
                save_growth_state(comm, outdir, g.increments, g.state(cracks))
    finally:
        table.close()
    info = _summary(run, g, frags, timer, comm, t_start, message)
    summary = run_summary(scene.name, status, comm, info["wall_time_s"], **info)
    write_summary(comm, outdir, summary)
    return RunResult(status, summary, None, outdir)


#: The stops that break the body (fragments reported), and those that name a crack.
_BROKEN = ("fractured", "through")
_STOPPED_BY = ("fractured", "through", "joined", "not_convex")


def _summary(run, g: Growth, frags, timer, comm, t_start: float, message) -> dict[str, Any]:
    cracks = [
        {
            "name": name,
            "shape": "grown",
            "normal": list(c.normal),
            "front_size": run.size.h_tip,
            "front": c.vertices.tolist(),
        }
        for name, c in zip(run.names, g.cracks, strict=True)
    ]
    fatigue = run.fracture.fatigue is not None
    info: dict[str, Any] = {
        "wall_time_s": time.perf_counter() - t_start,
        "fracture": {
            "crack": cracks[0],
            "cracks": cracks,
            "growth": {
                "rule": "fatigue" if fatigue else "propagate",
                "criterion": "sigma1_prime",
                "status": g.status,
                "increments": g.increments,
                "cycles": g.cycles if fatigue else None,
                "K_Ic": run.K_Ic,
                "history": g.history,
                "fractured": g.status in _BROKEN,
                "stopped_by": run.names[g.at] if g.status in _STOPPED_BY else None,
                "front_defect": g.defect,
                "merges": g.merges,
                "joined": g.joined if g.status == "joined" else None,
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
