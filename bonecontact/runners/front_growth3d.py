"""Growth of an interior planar crack in a 3D scene (``[fracture] propagate = true``;
docs/scene_format.md#fracture, docs/theory/fracture.md#front-growth-in-3d-scenes).

The ``[[crack]]`` (disc, ellipse or convex polygon) becomes a polygon (a disc or an
ellipse: the polygon of N = max(6, ⌊P/(6 h_f)⌋) vertices on its front, P the perimeter,
so that every edge holds the integration domain) and then a
:class:`~bonecontact.fracture.crack3d.TriangulatedCrack`.  Every increment cuts the
crack into the scene's body (:func:`~bonecontact.fracture.body3d.mesh_body_with_planar_crack`:
two faces, a contact pair), solves the scene's analysis, takes K_I, K_II, K_III at the
middle of every front edge (:func:`~bonecontact.fracture.advance3d.mid_edge_modes`) and
advances the vertices by the σ₁′ criterion with Δa_i = Δa (K_V,i/K_V,max)² once a vertex
reaches K_Ic (:func:`~bonecontact.fracture.advance3d.advance_mixed_front`: every vertex
moves, those below K_Ic by their smaller rate; a vertex that held would leave a
degenerate strip); the crack surface is extended by the strip between the two fronts.
It stops when no vertex reaches K_Ic
(``arrested``), after ``max_increments`` advances (``max_increments``), or when the grown
front would come within the integration domain and two front elements of the body's
surface (``fractured``: under load control K grows with the crack, so it runs through;
the fragments are the body on either side of the crack plane).  ``fracture.csv`` has a
row per increment and front point, ``crack_surface_<k>.vtk`` the crack surface and
``crack_front_<k>.vtk`` the front with its K of increment k, ``increment<k>/`` the fields
and tables of each solve; with ``checkpoint_every`` the growth state after every n-th
increment (:mod:`~bonecontact.runners.growth_state3d`), from which a restart continues on
any number of ranks.  One crack per scene (several: not yet).
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
    mid_edge_modes,
    sigma1_kink,
    vertex_directions,
)
from bonecontact.fracture.body3d import BodySurface, CrackedBody3D, mesh_body_with_planar_crack
from bonecontact.fracture.crack3d import (
    PlanarCrack,
    TriangulatedCrack,
    planar_crack_from_table,
    triangulated_from_polygon,
)
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.surface_body3d import inside_body
from bonecontact.meshing.builder import MeshingError
from bonecontact.runners.cracks3d import write_front
from bonecontact.runners.growth_state3d import find_growth_state, save_growth_state
from bonecontact.runners.mechanics import SceneModel
from bonecontact.runners.results import RecordTable, RunResult, run_summary, write_summary
from bonecontact.runners.surface_crack3d import (
    body_and_material,
    crack_tractions,
    cracked_model,
    fragments,
    solve_cracked,
)
from bonecontact.scene import Scene, SceneError
from bonecontact.scene.errors import table_label
from bonecontact.scene.spec import FractureSpec

__all__ = [
    "GROWTH3D_COLUMNS",
    "check_interior_growth",
    "grows_interior_crack",
    "run_interior_growth",
]

#: Columns of ``fracture.csv`` of a growing interior crack (a row per increment and edge).
GROWTH3D_COLUMNS = (
    "increment",
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
)


@dataclasses.dataclass(frozen=True)
class EdgeRecord:
    """One row of ``fracture.csv`` (:data:`GROWTH3D_COLUMNS`): K at the middle of a front
    edge."""

    increment: int
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

    def row(self) -> list[Any]:
        return [getattr(self, c) for c in GROWTH3D_COLUMNS]


@dataclasses.dataclass(frozen=True)
class InteriorRun:
    """What a growing interior crack needs besides the scene model."""

    scene: Scene  # with the crack's face pair added
    name: str
    body: BodySurface
    material: Any
    size: TipMesh
    groups: dict[str, tuple[int, int]]
    fracture: FractureSpec
    K_Ic: float

    @property
    def ligament(self) -> float:
        """The least distance ahead of the front to the surface (m): the integration
        domain (4 front elements) and two more."""
        return 6.0 * self.size.h_tip


@dataclasses.dataclass
class Growth:
    """The state of the growing crack between solves."""

    crack: TriangulatedCrack
    increments: int = 0
    status: str | None = None
    history: list[dict[str, float]] = dataclasses.field(default_factory=list)
    rows: int = 0  # fracture.csv rows written

    def state(self, initial: TriangulatedCrack) -> dict[str, Any]:
        """What a checkpoint stores (JSON; :mod:`~bonecontact.runners.growth_state3d`)."""
        return {
            "kind": "interior_crack",
            "initial": _geometry(initial),
            "crack": dataclasses.asdict(self.crack),
            "history": self.history,
            "rows": self.rows,
        }

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> Growth:
        """The growth a checkpoint stored (its ``increment`` the next to solve)."""
        c = state["crack"]
        crack = TriangulatedCrack(
            tuple(tuple(map(float, p)) for p in c["points"]),
            tuple(tuple(map(int, q)) for q in c["patches"]),
            tuple(map(int, c["front_ids"])),
            tuple(tuple(map(float, n)) for n in c["normals2"]),
            None if c["cuts"] is None else tuple(tuple(map(float, k)) for k in c["cuts"]),
            tuple(map(float, c["normal"])),
        )
        hist = list(state["history"])
        return cls(crack, int(state["increment"]), None, hist, int(state["rows"]))


def _geometry(crack: TriangulatedCrack) -> dict[str, Any]:
    """The initial polygon as a checkpoint compares it with the scene's."""
    return {"vertices": crack.vertices.tolist(), "normal": list(crack.normal)}


def grows_interior_crack(scene: Scene) -> bool:
    """Whether this module runs the scene: 3D, ``propagate``, planar interior cracks."""
    fr = scene.fracture
    return (
        scene.dimension == 3
        and fr is not None
        and fr.propagate
        and bool(scene.cracks)
        and all(isinstance(c.crack, PlanarCrack) for c in scene.cracks)
    )


def _error(scene: Scene, index: int, key: str | None, text: str) -> SceneError:
    return SceneError(
        str(scene.path), table_label("crack", index, scene.cracks[index].name), key, text
    )


def _refuse(scene: Scene) -> None:
    if len(scene.cracks) > 1:
        raise _error(scene, 1, "name", "3D growth of several cracks is not yet supported")
    if scene.analysis.kind != "static":
        raise SceneError(
            str(scene.path),
            "[analysis]",
            "kind",
            f"a growing 3D crack runs static analyses, not {scene.analysis.kind!r}",
        )


def as_polygon(crack: PlanarCrack, h_front: float) -> TriangulatedCrack:
    """The crack as a one-patch triangulated polygon: a polygon as it is, a disc or an
    ellipse the polygon of N = max(6, ⌊P/(6 h_f)⌋) vertices on its front at the parameters
    2π(k + ½)/N (counter-clockwise about the normal)."""
    if crack.vertices is None:
        front = crack.front()
        phi = np.linspace(0.0, 2 * math.pi, 721)
        pts = front.point(phi)
        perimeter = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
        n = max(6, int(perimeter / (6.0 * h_front)))
        V = front.point(2 * math.pi * (np.arange(n) + 0.5) / n)
        table = {"shape": "polygon", "vertices": V.tolist(), "normal": list(crack.normal)}
        crack = planar_crack_from_table(table)
    return triangulated_from_polygon(crack)


def _probes(V: np.ndarray, directions: np.ndarray, reach: float) -> np.ndarray:
    """Points ``reach`` ahead of the vertices and of the middles of the edges."""
    mid = 0.5 * (V + np.roll(V, -1, axis=0))
    d_mid = directions + np.roll(directions, -1, axis=0)
    d_mid /= np.linalg.norm(d_mid, axis=1)[:, None]
    return np.concatenate([V + reach * directions, mid + reach * d_mid])


def _reaches_surface(run: InteriorRun, V: np.ndarray, directions: np.ndarray) -> bool:
    return not bool(np.all(inside_body(run.body, _probes(V, directions, run.ligament))))


def prepare_interior(scene: Scene, comm: MPI.Comm) -> tuple[InteriorRun, TriangulatedCrack]:
    """Read the mesh and the body's surface, take the material and its K_Ic, the front
    mesh and the crack as a polygon; refuse a front within the ligament of the surface
    (a :class:`SceneError` on every rank)."""
    _refuse(scene)
    spec = scene.cracks[0]
    fr = scene.fracture if scene.fracture is not None else FractureSpec()
    body, material, k_ic, groups = body_and_material(scene, comm)
    h = fr.tip_size if fr.tip_size is not None else spec.crack.b / 10
    size = TipMesh(h, fr.tip_grading if fr.tip_grading is not None else 0.12)
    try:
        crack = as_polygon(spec.crack, h)
    except ParameterError as exc:
        raise _error(scene, 0, exc.key, str(exc)) from None
    if min(crack.front().edge_lengths) < 6.0 * h:
        raise SceneError(
            str(scene.path),
            "[fracture]",
            "tip_size",
            f"the front's edges ({min(crack.front().edge_lengths):.3g} m) must hold the "
            f"integration domain (6 front elements of {h:.3g} m): a smaller tip_size",
        )
    pair = spec.face_pair(_pair_name(spec.name), "crack_upper", "crack_lower")
    scene2 = dataclasses.replace(scene, contacts=tuple(scene.contacts) + (pair,))
    run = InteriorRun(scene2, spec.name, body, material, size, groups, fr, float(k_ic))
    V = crack.vertices
    if _reaches_surface(run, V, vertex_directions(V, crack.normal)):
        raise _error(
            scene,
            0,
            spec.crack.size_key,
            f"the crack's front comes within {run.ligament:.3g} m of the body's surface (the "
            "integration domain and two front elements): a smaller crack or tip_size",
        )
    return run, crack


def _pair_name(name: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "_.-" else "_" for ch in name)


def check_interior_growth(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> SceneModel:
    """Every check of a growing interior crack, the cracked mesh and the face pair
    included (nothing written); the scene model on that mesh."""
    run, crack = prepare_interior(scene, comm)
    timer = PhaseTimer()
    cb, md = _mesh(run, crack, comm, timer)
    key = scene.cracks[0].crack.size_key
    return cracked_model(run.scene, cb, md, run.groups, _pair_name(run.name), comm, timer, key)


def _mesh(run: InteriorRun, crack: TriangulatedCrack, comm: MPI.Comm, timer: PhaseTimer):
    try:
        with timer.phase("mesh_read"):
            return mesh_body_with_planar_crack(run.body, crack, run.size, comm)
    except MeshingError as exc:
        raise _error(run.scene, 0, "tip_size", str(exc)) from None


def evaluate(u: Any, cb: CrackedBody3D, run: InteriorRun, inc: int, traction) -> list:
    """K at the middle of every front edge, K_V and the σ₁′ kink (collective)."""
    crack: TriangulatedCrack = cb.crack
    sifs = mid_edge_modes(crack, cb.block(), u, run.material, run.size.h_tip, traction)
    front = crack.front()
    phis = crack.front_parameters(1)
    out = []
    for i, (f, phi) in enumerate(zip(sifs, phis, strict=True)):
        kv = float(equivalent_k(f.K_I, f.K_II, f.K_III))
        kink = float(sigma1_kink(f.K_I, f.K_II, f.K_III)[0][0])
        s = float(front.arc_length(float(phi)) - front.arc_length(0.0))
        x, y, z = f.point
        out.append(
            EdgeRecord(inc, i, s, x, y, z, f.K_I, f.K_II, f.K_III, f.G, kv, math.degrees(kink))
        )
    return out


def _advance(run: InteriorRun, g: Growth, records: list[EdgeRecord]) -> str | None:
    """The stop after this solve, or the next crack in ``g`` (``None``: grow)."""
    K = np.array([(r.K_I, r.K_II, r.K_III) for r in records])
    kv = np.array([r.K_V for r in records])
    g.history.append(
        {
            "increment": g.increments,
            "K_V_max": float(kv.max()),
            "K_V_min": float(kv.min()),
            "mean_radius": _mean_radius(g.crack),
        }
    )
    kv_vertex = equivalent_k(*(0.5 * (K + np.roll(K, 1, axis=0))).T)
    if float(kv_vertex.max()) < run.K_Ic or float(kv.min()) <= 0.0:
        return "arrested"
    if g.increments >= run.fracture.max_increments:
        return "max_increments"
    adv = advance_mixed_front(g.crack.vertices, g.crack.normals2, K, float(run.fracture.increment))
    if _reaches_surface(run, adv.vertices, adv.directions):
        return "fractured"
    g.crack, g.increments = extend_surface(g.crack, adv.vertices), g.increments + 1
    return None


def _mean_radius(crack: TriangulatedCrack) -> float:
    V = crack.vertices
    return float(np.mean(np.linalg.norm(V - V.mean(axis=0), axis=1)))


def write_crack_surface(path: Path, crack: TriangulatedCrack) -> None:
    """The crack surface as legacy VTK polygons (its planar patches)."""
    P, patches = crack.points, crack.patches
    lines = ["# vtk DataFile Version 3.0", "crack surface", "ASCII", "DATASET POLYDATA"]
    lines += [f"POINTS {len(P)} double"] + [" ".join(repr(float(c)) for c in p) for p in P]
    lines += [f"POLYGONS {len(patches)} {sum(len(q) + 1 for q in patches)}"]
    lines += [" ".join(map(str, [len(q), *q])) for q in patches]
    Path(path).write_text("\n".join(lines) + "\n")


def _increment(run: InteriorRun, g: Growth, comm, timer, outdir: Path, table: RecordTable):
    """Mesh, solve, evaluate, advance and write one increment; returns (stop, cb, summary)
    (``summary``: the solve's, when it did not converge)."""
    cb, md = _mesh(run, g.crack, comm, timer)
    out = outdir / f"increment{g.increments}"
    key = run.scene.cracks[0].crack.size_key
    sm, integ, summary = solve_cracked(
        run.scene, cb, md, run.groups, _pair_name(run.name), comm, timer, out, key
    )
    if summary["status"] != "converged":
        integ.destroy()
        return None, cb, summary
    with timer.phase("fracture"):
        traction = crack_tractions(sm, integ, cb, 4.0 * run.size.h_tip)
        records = evaluate(integ.u, cb, run, g.increments, traction)
    integ.destroy()
    crack, inc = g.crack, g.increments
    stop = _advance(run, g, records)
    table.rows([dataclasses.replace(r, status=stop or "grows") for r in records])
    g.rows += len(records)
    if comm.rank == 0:
        write_crack_surface(outdir / f"crack_surface_{inc}.vtk", crack)
        write_front(outdir / f"crack_front_{inc}.vtk", records)
    return stop, cb, None


def _start(run: InteriorRun, crack: TriangulatedCrack, comm, outdir: Path, restart) -> Growth:
    """A fresh growth, or the one of the checkpoint ``restart`` (fracture.csv cut to its
    rows)."""
    if not restart:
        return Growth(crack)
    state = find_growth_state(
        comm, outdir, restart, "interior_crack", _geometry(crack), crack.front().a
    )
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
    run, crack = prepare_interior(scene, comm)
    outdir = Path(output) if output is not None else scene.output.directory
    if comm.rank == 0:
        outdir.mkdir(parents=True, exist_ok=True)
    g = _start(run, crack, comm, outdir, restart)
    table = RecordTable(comm, outdir / "fracture.csv", GROWTH3D_COLUMNS, append=bool(restart))
    status, message, frags = "converged", None, None
    every = scene.output.checkpoint_every
    try:
        while g.status is None:
            stop, cb, failed = _increment(run, g, comm, timer, outdir, table)
            if failed is not None:
                status, message = failed["status"], failed.get("message")
                break
            g.status = stop
            if stop == "fractured":
                V = g.crack.vertices
                frags = fragments(cb.mesh, V.mean(axis=0), np.asarray(g.crack.normal))
            elif stop is None and every > 0 and g.increments % every == 0:
                save_growth_state(comm, outdir, g.increments, g.state(crack))
    finally:
        table.close()
    info = _summary(run, g, frags, timer, comm, t_start, message)
    summary = run_summary(scene.name, status, comm, info["wall_time_s"], **info)
    write_summary(comm, outdir, summary)
    return RunResult(status, summary, None, outdir)


def _summary(run, g: Growth, frags, timer, comm, t_start: float, message) -> dict[str, Any]:
    info: dict[str, Any] = {
        "wall_time_s": time.perf_counter() - t_start,
        "fracture": {
            "crack": {
                "name": run.name,
                "shape": "grown",
                "normal": list(g.crack.normal),
                "front_size": run.size.h_tip,
                "front": g.crack.vertices.tolist(),
            },
            "growth": {
                "rule": "propagate",
                "criterion": "sigma1_prime",
                "status": g.status,
                "increments": g.increments,
                "K_Ic": run.K_Ic,
                "history": g.history,
                "fractured": g.status == "fractured",
                "fragments": frags,
            },
        },
        "phases_s": timer.summary(comm),
    }
    if message is not None:
        info["message"] = message
    return info
