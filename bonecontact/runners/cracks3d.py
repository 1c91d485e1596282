"""3D mechanics scenes with a planar ``[[crack]]`` (docs/scene_format.md#fracture,
docs/theory/fracture.md#3d-crack-fronts).

The crack (a disc, an ellipse or a convex polygon,
:class:`~bonecontact.fracture.crack3d.PlanarCrack`) is cut into the scene's body
(:mod:`bonecontact.fracture.body3d`: the body's boundary triangulation kept, the volume
re-meshed by gmsh with the crack surface embedded, graded towards the front, the crack nodes
split into the faces ``crack_upper`` and ``crack_lower``).  The faces become a dual-mortar
contact pair (``crack_upper`` slave; frictionless, or Coulomb with the crack's ``friction``
and the fixed-point bound) solved with the scene's other pairs by the PDAS, so an open crack
is traction-free and a closed one carries compression and friction.  After every step K_I,
K_II, K_III and G at ``front_points`` points along the front (a polygon: on every edge, at
least 15 % of the edge and two front elements from its ends) come from the 3D domain
interaction integral of :mod:`bonecontact.fracture.front3d` (traction-free faces: no face
term), with displacement correlation as the cross-check; rows go to ``fracture.csv`` as the
run goes, the largest K_I and G and their place to ``summary.json``, and the front with its
K to ``fields_crack_front.vtk``.

Several planar cracks per scene (each embedded, split into its own faces, its own pair,
its rows in fracture.csv under its name), one cell group, an isotropic material around
the fronts; static and quasi-static analyses; checkpoints and restarts as a mechanics
run's, the cracks' geometry stored with them; no propagation in 3D (exit 2).
"""

from __future__ import annotations

import dataclasses
import math
import re
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from bonecontact.common.errors import CheckpointError, ParameterError
from bonecontact.common.profiling import PhaseTimer
from bonecontact.contact.interface import ContactInputError
from bonecontact.fracture.body3d import (
    BodySurface,
    CrackedBody3D,
    body_surface,
    front_vertices,
    mesh_body_with_planar_crack,
    mesh_body_with_planar_cracks,
)
from bonecontact.fracture.crack import points_in_polygon
from bonecontact.fracture.crack3d import PlanarCrack
from bonecontact.fracture.faces import face_interface, face_traction
from bonecontact.fracture.front3d import (
    front_displacement_correlation,
    front_interaction_integral,
)
from bonecontact.fracture.meshing import TipMesh
from bonecontact.materials.laws import Isotropic
from bonecontact.meshing.builder import MeshingError
from bonecontact.runners.checkpoint import Checkpointer, CrackState
from bonecontact.runners.loop import Verdict, progress_bar, run_steps
from bonecontact.runners.mechanics import (
    MechanicsSteps,
    Recorder,
    SceneModel,
    analysis_steps,
    build_model,
    finish_run,
    read_mesh,
    run_info,
    scene_integrator,
    summary_header,
)
from bonecontact.runners.results import RecordTable, RunResult
from bonecontact.scene import Scene, SceneError
from bonecontact.scene.checks import check_cracks_in_mesh
from bonecontact.scene.errors import table_label
from bonecontact.scene.spec import CrackSpec, FractureSpec

__all__ = [
    "FRONT_COLUMNS",
    "Crack3DRun",
    "FrontRecord",
    "check_cracked3d",
    "run_cracked3d",
    "write_front",
]

#: Columns of ``fracture.csv`` of a 3D crack (one row per front point and step).
FRONT_COLUMNS = (
    "step",
    "time",
    "crack",
    "point",
    "phi_deg",
    "s",
    "x",
    "y",
    "z",
    "K_I",
    "K_II",
    "K_III",
    "G",
    "K_I_dc",
    "K_II_dc",
    "K_III_dc",
    "status",
)


@dataclasses.dataclass(frozen=True)
class FrontRecord:
    """One row of ``fracture.csv``: K at a front point after a step (:data:`FRONT_COLUMNS`;
    ``phi_deg`` the front parameter — of a polygon 360° × s/P, s from its first vertex, P
    the perimeter —, ``s`` the arc length from φ = 0, m)."""

    step: int
    time: float
    point: int
    phi_deg: float
    s: float
    x: float
    y: float
    z: float
    K_I: float
    K_II: float
    K_III: float
    G: float
    K_I_dc: float
    K_II_dc: float
    K_III_dc: float
    status: str = "stationary"
    crack: str = ""  # the [[crack]]'s name

    def row(self) -> list[Any]:
        return [getattr(self, c) for c in FRONT_COLUMNS]


@dataclasses.dataclass
class Crack3DRun:
    """What a 3D crack scene needs besides the scene model."""

    scene: Scene  # with the crack's face pair added to its contacts
    spec: CrackSpec
    body: BodySurface
    material: Isotropic
    tip_mesh: TipMesh
    r_out: float  # radius of the interaction-integral domain (m)
    groups: dict[str, tuple[int, int]]
    length: float | None = None  # half-length along the front (m; None: r_out)
    index: int = 0  # the crack's place among the scene's [[crack]] tables (and face pairs)
    count: int = 1  # the scene's cracks: the face pairs are the last ``count`` pairs

    @property
    def pair_index(self) -> int:
        """Index of this crack's face pair counted from the end of the model's pairs."""
        return self.index - self.count


def _pair_name(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name)


def _error(scene: Scene, spec: CrackSpec, key: str, text: str) -> SceneError:
    i = next((k for k, c in enumerate(scene.cracks) if c.name == spec.name), 0)
    return SceneError(str(scene.path), table_label("crack", i, spec.name), key, text)


def _refuse(scene: Scene) -> None:
    """What a 3D crack scene does not run (exit 2 naming the table and key)."""
    if len(scene.cracks) > 1:
        for i, c in enumerate(scene.cracks):
            if not isinstance(c.crack, PlanarCrack):
                raise SceneError(
                    str(scene.path),
                    table_label("crack", i, c.name),
                    "shape",
                    "several [[crack]] tables in 3D are planar cracks with an interior front "
                    "(disc, ellipse, polygon); a surface-breaking crack runs alone",
                )
        if len({c.region for c in scene.cracks}) > 1:
            raise SceneError(
                str(scene.path),
                table_label("crack", 1, scene.cracks[1].name),
                "region",
                "the cracks of a 3D scene lie in one body (one region)",
            )
    if scene.analysis.kind not in ("static", "quasistatic"):
        raise SceneError(
            str(scene.path),
            "[analysis]",
            "kind",
            f"a 3D [[crack]] scene runs static or quasi-static analyses, not "
            f"{scene.analysis.kind!r}",
        )


def _evaluation_parameters(crack: PlanarCrack, n: int, h_tip: float) -> npt.NDArray[np.float64]:
    """Front parameters of the K points (a polygon's: two front elements or 15 % of the
    edge from its ends, whichever is more)."""
    return crack.front_parameters(n, margin=2.0 * h_tip)


def _domain_radius(
    crack: PlanarCrack, body: BodySurface, h_tip: float, others: tuple[PlanarCrack, ...] = ()
) -> float:
    """Interaction-integral domain: 0.3 of the smaller semi-axis b (a polygon: its
    inradius) or four front elements, whichever is larger, but at most 0.6 of the smallest
    radius of curvature of the front (b²/a; none on a polygon's straight edges), half
    the distance from the front to the body's surface, and the distance to the ``others``
    cracks less two front elements (the domain holds none of their faces)."""
    front = crack.front()
    pts = front.point(np.linspace(0.0, 2 * math.pi, 64, endpoint=False))
    free = body.distance(pts)
    apart = min([math.inf] + [_crack_distance(pts, c) for c in others]) - 2 * h_tip
    bend = math.inf if crack.vertices is not None else 0.6 * crack.b**2 / crack.a
    return min(max(0.3 * crack.b, 4 * h_tip), bend, 0.5 * max(free - h_tip, 0.0), apart)


def _crack_distance(points: npt.NDArray[np.float64], crack: PlanarCrack) -> float:
    """Distance from ``points`` (n, 3) to the planar ``crack`` (m): to its plane where a
    point projects inside its outline, else to its front (96 points)."""
    c, R = np.asarray(crack.centre, dtype=float), crack.axes
    rel = (points - c) @ R.T
    front = crack.front().point(np.linspace(0.0, 2 * math.pi, 96, endpoint=False))
    to_front = np.linalg.norm(points[:, None, :] - front[None, :, :], axis=2).min(axis=1)
    inside = points_in_polygon(rel[:, :2], ((front - c) @ R.T)[:, :2])
    return float(np.where(inside, np.abs(rel[:, 2]), to_front).min())


def _domain_length(crack: PlanarCrack, r_out: float, h_tip: float, n: int) -> float:
    """Half-length of the domain along the front: ``r_out``; on a polygon at most the
    distance from the K points to the corners less a front element (the straight-edge
    auxiliary field holds up to the corner; the ring may be wider)."""
    if crack.vertices is None:
        return r_out
    front = crack.front()
    phis = _evaluation_parameters(crack, n, h_tip)
    return min(r_out, min(front.corner_distance(float(p)) for p in phis) - h_tip)


def prepare3d(scene: Scene, comm: MPI.Comm) -> list[Crack3DRun]:
    """Read the scene mesh, check the cracks against it, take the body's surface and set
    every crack's front mesh and integration domain (collective; every input problem is a
    :class:`SceneError` on every rank).  One run per ``[[crack]]``, in the scene's order,
    sharing the scene with all the face pairs (the cracks' pairs last, in that order)."""
    _refuse(scene)
    spec = scene.cracks[0]
    fr = scene.fracture if scene.fracture is not None else FractureSpec()
    md0, groups = read_mesh(scene, comm)
    check_cracks_in_mesh(scene, md0.mesh, md0.cell_tags, groups)
    try:
        body = body_surface(md0.mesh, md0.cell_tags, md0.facet_tags, groups, spec.region)
    except ParameterError as exc:
        raise _error(scene, spec, exc.key, str(exc).removeprefix(f"{exc.key}: ")) from None
    mat_spec = next(m for m in scene.materials if spec.region in m.regions)
    if not isinstance(mat_spec.material, Isotropic):
        raise SceneError(
            str(scene.path),
            table_label("material", mat_spec.index, mat_spec.name),
            "model",
            "the stress intensity factors of a crack need an isotropic material around it",
        )
    pairs = tuple(
        c.face_pair(_pair_name(c.name), "crack_upper", "crack_lower") for c in scene.cracks
    )
    scene2 = dataclasses.replace(scene, contacts=tuple(scene.contacts) + pairs)
    runs = []
    for i, c in enumerate(scene.cracks):
        others = tuple(o.crack for j, o in enumerate(scene.cracks) if j != i)
        r_out, length, size = _front_domain(scene, c, fr, body, others)
        runs.append(
            Crack3DRun(
                scene2, c, body, mat_spec.material, size, r_out, groups, length, i, len(pairs)
            )
        )
    return runs


def _front_domain(
    scene: Scene,
    spec: CrackSpec,
    fr: FractureSpec,
    body: BodySurface,
    others: tuple[PlanarCrack, ...],
) -> tuple[float, float, TipMesh]:
    """A crack's integration domain (radius, half-length along the front) and front mesh;
    refused (exit 2, ``tip_size``) when the domain spans too few front elements."""
    crack = spec.crack
    h_tip = fr.tip_size if fr.tip_size is not None else crack.b / 10
    r_out = _domain_radius(crack, body, h_tip, others)
    length = _domain_length(crack, r_out, h_tip, spec.front_points)
    if length < 2 * h_tip:
        raise SceneError(
            str(scene.path),
            "[fracture]",
            "tip_size",
            f"the integration domain along a polygon edge ({length:.3g} m: the distance from "
            f"the K points to the corners less {h_tip:.3g} m) spans fewer than 2 front "
            f"elements of {h_tip:.3g} m; choose a smaller tip_size (or fewer front_points)",
        )
    if r_out < 3 * h_tip:
        raise SceneError(
            str(scene.path),
            "[fracture]",
            "tip_size",
            f"the integration domain around the front of {spec.name!r} (r = {r_out:.3g} m: "
            f"at most 0.6 b²/a, half the distance to the surface, the distance to the other "
            "cracks less two elements) "
            f"spans fewer than 3 front elements of {h_tip:.3g} m; choose a smaller tip_size "
            "(or cracks farther from the surface and from each other)",
        )
    # the far field needs a finer grading in 3D: 0.3 left K_I 2 % low at every front size
    size = TipMesh(h_tip, fr.tip_grading if fr.tip_grading is not None else 0.12)
    return r_out, length, size


def build_cracked3d(
    scene: Scene, runs: list[Crack3DRun], comm: MPI.Comm, timer: PhaseTimer
) -> tuple[SceneModel, list[CrackedBody3D]]:
    """The scene model on the body meshed around the cracks, with their face pairs last
    (in the order of ``runs``); the mesh seen from each crack."""
    run = runs[0]
    try:
        with timer.phase("mesh_read"):
            if len(runs) == 1:
                cb, md = mesh_body_with_planar_crack(run.body, run.spec.crack, run.tip_mesh, comm)
                cbs = [cb]
            else:
                size = min((r.tip_mesh for r in runs), key=lambda t: t.h_tip)
                cbs, md = mesh_body_with_planar_cracks(
                    run.body, [r.spec.crack for r in runs], size, comm
                )
    except MeshingError as exc:
        raise _error(scene, run.spec, run.spec.crack.size_key, str(exc)) from None
    sm = build_model(scene, comm, timer, mesh=(md, run.groups))
    for r, cb in zip(runs, cbs, strict=True):
        try:
            with timer.phase("mortar_geometry"):
                sm.interfaces.append(face_interface(sm.model, cb, _pair_name(r.spec.name)))
        except ContactInputError as exc:
            raise _error(scene, r.spec, r.spec.crack.size_key, str(exc)) from None
    return sm, cbs


def check_cracked3d(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> SceneModel:
    """Every check of a 3D crack scene, the cracked mesh and the face pair included
    (nothing written); the scene model on that mesh."""
    runs = prepare3d(scene, comm)
    return build_cracked3d(scene, runs, comm, PhaseTimer())[0]


def front_nodes(cb: CrackedBody3D) -> npt.NDArray[np.float64]:
    """Coordinates of the front nodes (the vertices of both faces), on every rank, sorted
    by coordinates (collective; :func:`~bonecontact.fracture.body3d.front_vertices`)."""
    return front_vertices(cb.mesh, cb.facet_tags, cb.face_tags)


def evaluate_front(
    u: Any,
    cb: CrackedBody3D,
    run: Crack3DRun,
    step: int,
    t: float,
    traction: tuple | None = None,
) -> list[FrontRecord]:
    """K_I, K_II, K_III and G at the front points by the interaction integral (with the
    face term of the contact tractions ``traction`` (upper, lower) of a closed crack),
    and the displacement-correlation cross-check (collective)."""
    crack, block = run.spec.crack, cb.block()
    front = block.front
    phis = _evaluation_parameters(crack, run.spec.front_points, run.tip_mesh.h_tip)
    s0 = front.arc_length(0.0)
    records = []
    for i, phi in enumerate(phis):
        k = front_interaction_integral(
            u,
            block,
            float(phi),
            run.material,
            run.r_out,
            length=run.length,
            face_traction=traction,
        )
        try:
            dc = front_displacement_correlation(
                u,
                block,
                float(phi),
                run.material,
                min(1.5 * run.r_out, 0.5 * crack.b),
                0.5 * (run.length or run.r_out),
                skip=1.5 * run.tip_mesh.h_tip,  # the front and its first ring: P1 opens least
            )
            kdc = (dc.K_I, dc.K_II, dc.K_III)
        except ParameterError:
            kdc = (math.nan, math.nan, math.nan)
        x, y, z = k.point
        s = float(front.arc_length(phi) - s0)
        records.append(
            FrontRecord(
                step,
                t,
                i,
                math.degrees(phi),
                s,
                x,
                y,
                z,
                k.K_I,
                k.K_II,
                k.K_III,
                k.G,
                *kdc,
                crack=run.spec.name,
            )
        )
    return records


def _face_tractions(
    sm: SceneModel, result: Any, tips: np.ndarray, reach: float | None = None, back: int = -1
) -> tuple | None:
    """The contact tractions on (crack_upper, crack_lower) when the pair (``back``: its
    index from the end of the model's pairs; −1 the last) has active nodes, else ``None``
    (open: traction-free); within ``reach`` of the front recovered by linear fits over
    6·``reach`` (the planar face's multipliers scatter more than a 2D crack's, and the
    face is flat: a fit over most of it loses nothing;
    :func:`~bonecontact.fracture.faces.recovered_traction`)."""
    k = len(sm.interfaces) + back
    if result is None or int(result.n_active[k]) == 0:
        return None
    ft = face_traction(sm.model.V, sm.interfaces[k], result, k, tips, reach, 6.0)
    return ft.plus, ft.minus


def write_front(path: Path, records: list[FrontRecord]) -> None:
    """The front as a legacy VTK file: POLYDATA, a closed line through the evaluation
    points, with K_I, K_II, K_III and G as point data (to show over the fields)."""
    pts = np.array([[r.x, r.y, r.z] for r in records])
    n = len(pts)
    lines = ["# vtk DataFile Version 3.0", "crack front", "ASCII", "DATASET POLYDATA"]
    lines += [f"POINTS {n} double"] + [" ".join(repr(float(c)) for c in p) for p in pts]
    lines += [f"LINES 1 {n + 2}", " ".join(map(str, [n + 1, *range(n), 0]))]
    lines += [f"POINT_DATA {n}"]
    for name in ("K_I", "K_II", "K_III", "G"):
        lines += [f"SCALARS {name} double 1", "LOOKUP_TABLE default"]
        lines += [repr(float(getattr(r, name))) for r in records]
    Path(path).write_text("\n".join(lines) + "\n")


def _front_summary(run: Crack3DRun, records: list[FrontRecord]) -> dict[str, Any]:
    """The ``fracture.crack`` entry of summary.json."""
    c = run.spec.crack
    out: dict[str, Any] = {
        "name": run.spec.name,
        "pair": _pair_name(run.spec.name),
        "friction": run.spec.coefficient,
        "shape": c.shape,
        "centre": list(c.centre),
        "normal": list(c.normal),
        "semi_axes": [c.a, c.b],
        "axis": list(c.axis),
        "vertices": None if c.vertices is None else [list(v) for v in c.vertices],
        "front_size": run.tip_mesh.h_tip,
        "r_out": run.r_out,
        "length": run.length,
        "front": [dataclasses.asdict(r) for r in records],
    }
    for name in ("K_I", "G"):
        vals = [getattr(r, name) for r in records]
        best = records[int(np.nanargmax(np.abs(vals)))] if records else None
        out[f"max_{name}"] = None if best is None else getattr(best, name)
        out[f"max_{name}_location"] = None if best is None else [best.x, best.y, best.z]
        out[f"max_{name}_phi_deg"] = None if best is None else best.phi_deg
    return out


def crack_geometry(crack: PlanarCrack) -> dict[str, Any]:
    """The crack as a checkpoint stores it (the ``crack`` of meta.json's ``crack_run``)."""
    return {
        "shape": crack.shape,
        "centre": list(map(float, crack.centre)),
        "normal": list(map(float, crack.normal)),
        "semi_axes": [float(crack.a), float(crack.b)],
        "axis": list(map(float, crack.axis)),
        "vertices": None
        if crack.vertices is None
        else [list(map(float, v)) for v in crack.vertices],
    }


def check_saved_crack(path: Path, meta: dict[str, Any], crack: PlanarCrack, index: int = 0) -> None:
    """Refuse a checkpoint written for another crack (its stored geometry differs from the
    scene's beyond 10⁻¹² of the crack's size); ``index``: the crack's place among the
    scene's (a checkpoint of several cracks stores them all in ``crack_run.cracks``)."""
    entry = meta.get("crack_run") or {}
    stored = entry.get("cracks") or [entry.get("crack")]
    saved = stored[index] if index < len(stored) else None
    here = crack_geometry(crack)
    if saved is None or saved["shape"] != here["shape"]:
        raise CheckpointError(f"checkpoint {path} was not written for this 3D crack")
    for key in ("centre", "normal", "semi_axes", "axis", "vertices"):
        a, b = saved[key], here[key]
        if (a is None) != (b is None) or (
            a is not None
            and (np.shape(a) != np.shape(b) or not np.allclose(a, b, rtol=0, atol=1e-12 * crack.a))
        ):
            raise CheckpointError(
                f"checkpoint {path} has the crack's {key} = {a}, the scene {b}: a restart "
                "continues the same crack"
            )


class FrontSteps(MechanicsSteps):
    """The hooks of a 3D crack run: after every step K along the front (phase
    ``fracture``; fracture.csv rows), the front with its K written with the fields; a
    checkpoint (:class:`~bonecontact.runners.checkpoint.CrackState`, the crack's geometry
    in ``crack_run``) when due or asked for by a signal."""

    errors = (RuntimeError, ParameterError)  # a solver failure; K cannot be had

    def __init__(
        self,
        base: MechanicsSteps,
        sm: SceneModel,
        cbs: list[CrackedBody3D],
        runs: list[Crack3DRun],
        table: RecordTable,
        outdir: Path,
    ):
        super().__init__(
            base.integ, base.rec, base.timer, base.every, base.counters, base.dt, base.ckpt
        )
        self.sm, self.cbs, self.runs, self.table, self.outdir = sm, cbs, runs, table, outdir
        self.tips = [front_nodes(cb) for cb in cbs]
        self.last: list[FrontRecord] = []

    def after(self, k: int) -> Verdict:
        integ, self.last = self.integ, []
        with self.timer.phase("fracture"):
            for cb, run, tips in zip(self.cbs, self.runs, self.tips, strict=True):
                result = integ.last_contact
                traction = _face_tractions(self.sm, result, tips, run.r_out, run.pair_index)
                self.last += evaluate_front(integ.u, cb, run, k, integ.t, traction)
        self.table.rows(self.last)
        return Verdict.NEXT

    def record(self, k: int, last: bool) -> None:
        with self.timer.phase("output"):
            self.rec.record(k, self.integ.t, self.fields_due(k) or last)
            if self.sm.model.mesh.comm.rank == 0:
                for run in self.runs:  # one crack: fields_crack_front.vtk
                    rows = [r for r in self.last if r.crack == run.spec.name]
                    write_front(self.outdir / front_file(run), rows)

    def failure(self, k: int, exc: BaseException) -> str:
        return f"step {k} (t = {k * self.dt:.6g}): {exc}"

    def checkpoint(self, k: int, last: bool) -> bool:
        if self.ckpt is None:
            return False
        crack_run = {
            "crack": crack_geometry(self.runs[0].spec.crack),
            "cracks": [crack_geometry(r.spec.crack) for r in self.runs],
            "increment": 0,
        }
        with self.timer.phase("checkpoint"):
            return bool(self.ckpt.after_step(last, {"crack_run": crack_run}))


def front_file(run: Crack3DRun) -> str:
    """The VTK file of a crack's front: ``fields_crack_front.vtk`` (one crack), else
    ``fields_crack_front_<pair>.vtk``."""
    return (
        "fields_crack_front.vtk"
        if run.count == 1
        else f"fields_crack_front_{_pair_name(run.spec.name)}.vtk"
    )


def _checkpointer(scene: Scene, outdir: Path, comm: MPI.Comm, dt: float) -> Checkpointer:
    out = scene.output
    info = {"scene": scene.name, "analysis": scene.analysis.kind, "dt": dt}
    return Checkpointer(
        outdir, CrackState(comm, FRONT_COLUMNS), out.checkpoint_every, info, out.checkpoint_time
    )


def run_cracked3d(
    scene: Scene,
    comm: MPI.Comm = MPI.COMM_WORLD,
    output: Path | None = None,
    progress: bool = True,
    restart: str | Path | bool | None = None,
) -> RunResult:
    """Validate, build and run a 3D scene with a planar ``[[crack]]`` (module docstring),
    writing history.csv, the contact tables (the crack pair included), fields, the front
    (``fields_crack_front.vtk``), fracture.csv and summary.json.  ``restart``: continue
    from the newest (``True``) or the named checkpoint (docs/checkpoint.md): the body is
    meshed around the crack again (the checkpoint's crack must be the scene's; the node
    coordinates are checked against the checkpoint's), the tables are cut after its step
    and the run goes on from there."""
    t_start = time.perf_counter()
    timer = PhaseTimer()
    runs = prepare3d(scene, comm)
    run = runs[0]
    outdir = Path(output) if output is not None else scene.output.directory
    nsteps, dt = analysis_steps(scene)
    ck = _checkpointer(scene, outdir, comm, dt)
    resume = ck.find(None if restart is True else restart) if restart else None
    if resume is not None:
        for i, r in enumerate(runs):
            check_saved_crack(resume[0], resume[1], r.spec.crack, i)
    sm, cbs = build_cracked3d(scene, runs, comm, timer)
    with timer.phase("solver_setup"):
        integ = scene_integrator(run.scene, sm, dt, False)
        integ.set_initial(None, sm.v0)
    ck.state.integ = integ
    if resume is not None:
        with timer.phase("checkpoint"):
            ck.continue_from(*resume)
    with timer.phase("output"):
        rec = Recorder(run.scene, sm, integ, comm, outdir, False, ck)
    table = RecordTable(
        comm, Path(outdir) / "fracture.csv", FRONT_COLUMNS, append=resume is not None
    )
    base = MechanicsSteps(integ, rec, timer, scene.output.fields_every, ck.counters, dt, ck)
    hooks = FrontSteps(base, sm, cbs, runs, table, outdir)
    first = integ.step_count + 1
    try:
        with ck.stop:
            bar = progress_bar(comm, scene.name, nsteps, first - 1, progress)
            end = run_steps(hooks, first, nsteps, bar)
    finally:
        table.close()
    info = summary_header(scene, sm, integ, dt)
    info.update(run_info(run.scene, sm, integ, ck.counters, False, 0.0, t_start))
    info.update(ck.summary())
    info.update(rec.strain.summary())
    frac = rec.fracture.summary() if rec.fracture is not None else {}
    frac["cracks"] = [
        _front_summary(r, [x for x in hooks.last if x.crack == r.spec.name]) for r in runs
    ]
    frac["crack"] = frac["cracks"][0]  # the first crack
    info["fracture"] = frac
    summary = finish_run(scene, sm, rec, timer, comm, end.status, end.message, info)
    return RunResult(summary["status"], summary, integ, outdir)
