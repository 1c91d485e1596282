"""Mechanics scenes with a ``[[crack]]`` or ``[fracture] initiate = true``
(docs/scene_format.md#fracture, docs/theory/fracture.md).

With ``initiate = true`` and no ``[[crack]]`` the scene runs on its own mesh with the
initiation check; at the first step whose largest risk reaches 1 a short crack is
inserted there (:mod:`bonecontact.fracture.initiation`), the same step is solved again on
the cracked body and the run goes on as a crack scene.

The cracks (one or several ``[[crack]]``) are cut into the scene's body
(:mod:`bonecontact.fracture.body`: re-meshed by gmsh, graded towards the tips), each
crack's faces a contact pair of its own (``crack_plus`` / ``crack_minus``, frictionless or
Coulomb) solved with the other pairs by the mortar PDAS, and after every step K_I, K_II, J
and G of every tip (interaction integral, the contact tractions as face term; displacement
correlation as a cross-check) go to ``fracture.csv`` (column ``crack``).  With
``propagate = true`` every tip whose own MTS equivalent K reaches K_Ic grows by Δa and the
same step is solved again on the re-meshed body, until no tip grows, a tip comes within Δa
of the surface (*fractured*) or of another crack (*joined*; facing tips merge the two cracks
into one that grows on, :mod:`~.crack_join`) or ``max_increments`` are made; with
``[fracture.fatigue]`` the crack grows by blocks of cycles at the last step's load
(:mod:`bonecontact.runners.crack_fatigue`).  Static analyses only for growth: nothing is
transferred to the new mesh.  Checkpoints hold the crack with the mechanics state
(:class:`bonecontact.runners.checkpoint.CrackState`), between steps and between blocks.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from mpi4py import MPI

import numpy as np
from tqdm import tqdm

from bonecontact.common.errors import ParameterError, RunError
from bonecontact.common.profiling import PhaseTimer
from bonecontact.contact.interface import ContactInputError
from bonecontact.fracture.body import BodyOutline, body_outline, mesh_body_with_cracks
from bonecontact.fracture.coalescence import MERGE_ANGLE_DEG
from bonecontact.fracture.crack import Crack2D
from bonecontact.fracture.criteria import (
    cell_stresses,
    mts_angle,
    mts_equivalent_k,
    principal_direction_average,
)
from bonecontact.fracture.faces import face_interface, face_traction
from bonecontact.fracture.initiation import (
    Initiation,
    cell_size_at,
    default_length,
    initiation_crack,
    initiation_time,
    risk_peak,
)
from bonecontact.fracture.meshing import CrackedMesh, TipMesh
from bonecontact.fracture.propagation import FRACTURE_COLUMNS, IncrementRecord
from bonecontact.fracture.sif import displacement_correlation, interaction_integral
from bonecontact.materials.laws import Isotropic
from bonecontact.meshing.builder import MeshingError
from bonecontact.runners.checkpoint import Checkpointer, CrackState, RunCounters
from bonecontact.runners.crack_fatigue import (
    FATIGUE_COLUMNS,
    WAIT_FRACTION,
    FatigueProgress,
    FatigueRecord,
    block_end,
    block_shares,
    bound_to_separation,
    paris_law,
    plain_rows,
    self_similar_slope,
    size_from_tip,
    tip_key,
)
from bonecontact.runners.crack_join import join_cracks
from bonecontact.runners.cracks3d import check_cracked3d, run_cracked3d
from bonecontact.runners.loop import RunStopped, Verdict, progress_bar, run_steps
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

__all__ = ["CrackRun", "check_cracked", "is_crack_scene", "run_cracked", "write_crack_path"]


@dataclasses.dataclass
class CrackRun:
    """What a crack scene needs besides the scene model."""

    scene: Scene  # the scene with the cracks' face pairs added to its contacts (last)
    specs: tuple[CrackSpec, ...]  # (): no crack yet, one is initiated where the risk is 1
    fracture: FractureSpec
    body: BodyOutline
    material: Isotropic
    K_Ic: float | None
    tip_mesh: TipMesh | None
    groups: dict[str, tuple[int, int]]
    mesh: Any = None  # the scene's mesh data as read (the uncracked body)
    initiated: bool = False  # the crack was inserted by the run

    @property
    def spec(self) -> CrackSpec | None:
        """The first crack (``None``: none yet)."""
        return self.specs[0] if self.specs else None

    def pair(self, i: int) -> str:
        """The contact pair name of crack ``i``."""
        return _pair_name(self.specs[i].name)


def is_crack_scene(scene: Scene) -> bool:
    """Whether a mechanics scene runs here: it has a ``[[crack]]`` or ``[fracture]
    initiate = true``."""
    return bool(scene.cracks) or (scene.fracture is not None and scene.fracture.initiate)


def _pair_name(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name)


def _scene_error(
    scene: Scene, i: int, spec: CrackSpec | None, exc: Exception, key: str, initiated: bool = False
) -> SceneError:
    """The error of a crack's geometry or mesh, naming the ``[[crack]]`` table and key (an
    initiated crack: ``[fracture]`` and ``initiation_length``)."""
    k = getattr(exc, "key", key)
    text = str(exc)
    text = text[len(k) + 2 :] if text.startswith(f"{k}: ") else text
    if spec is None or initiated:
        return SceneError(str(scene.path), "[fracture]", "initiation_length", text)
    return SceneError(str(scene.path), table_label("crack", i, spec.name), k, text)


def _only_region(scene: Scene, groups: dict[str, tuple[int, int]]) -> str:
    """The one cell group of the mesh of a scene that initiates a crack."""
    regions = sorted(n for n, (d, _) in groups.items() if d == scene.dimension)
    if len(regions) != 1:
        raise SceneError(
            str(scene.path),
            "[fracture]",
            "initiate",
            "initiation inserts the crack into a mesh of one cell group; this mesh has "
            f"{len(regions)}: {', '.join(regions)}",
        )
    return regions[0]


def _check_initiation(scene: Scene, fr: FractureSpec, body: BodyOutline) -> None:
    """What an initiating scene must satisfy before it runs (exit 2 naming the key)."""
    if scene.analysis.kind != "static":
        raise SceneError(
            str(scene.path),
            "[fracture]",
            "initiate",
            f"crack initiation runs static analyses in this version, not {scene.analysis.kind!r}",
        )
    extent = float(np.ptp(body.outer, axis=0).min())
    if fr.initiation_length is not None and fr.initiation_length >= 0.5 * extent:
        raise SceneError(
            str(scene.path),
            "[fracture]",
            "initiation_length",
            f"{fr.initiation_length} m is not smaller than half the body's width "
            f"({extent:.6g} m across)",
        )


def prepare(scene: Scene, comm: MPI.Comm) -> CrackRun:
    """Read the scene mesh, check the crack against it and take the body's outline
    (collective; every input problem is a :class:`SceneError` on every rank).  A scene
    with ``[fracture] initiate = true`` has no crack yet (``spec`` is ``None``)."""
    fr = scene.fracture if scene.fracture is not None else FractureSpec()
    if fr.initiate and scene.cracks:
        raise SceneError(
            str(scene.path),
            "[fracture]",
            "initiate",
            "a scene either gives its [[crack]] or initiates one, not both",
        )
    spec = scene.cracks[0] if scene.cracks else None
    md0, groups = read_mesh(scene, comm)
    check_cracks_in_mesh(scene, md0.mesh, md0.cell_tags, groups)
    region = spec.region if spec is not None else _only_region(scene, groups)
    try:
        body = body_outline(md0.mesh, md0.cell_tags, md0.facet_tags, groups, region)
    except (ParameterError, MeshingError) as exc:
        if spec is None:
            raise SceneError(str(scene.path), "[fracture]", "initiate", str(exc)) from None
        raise _scene_error(scene, 0, spec, exc, "region") from None
    for i, c in enumerate(scene.cracks):
        try:
            body.check_crack(c.crack)
        except ParameterError as exc:
            raise _scene_error(scene, i, c, exc, "points") from None
    mat_spec = next(m for m in scene.materials if region in m.regions)
    if not isinstance(mat_spec.material, Isotropic):
        raise SceneError(
            str(scene.path),
            table_label("material", mat_spec.index, mat_spec.name),
            "model",
            "the stress intensity factors of a crack need an isotropic material around it",
        )
    if fr.grows and scene.analysis.kind != "static":
        raise SceneError(
            str(scene.path),
            "[fracture]",
            "propagate" if fr.propagate else "fatigue",
            f"crack growth runs static analyses in this version, not {scene.analysis.kind!r}",
        )
    if spec is None:
        _check_initiation(scene, fr, body)
    run = CrackRun(
        scene, (), fr, body, mat_spec.material, mat_spec.strengths.get("K_Ic"), None, groups, md0
    )
    return run if spec is None else with_cracks(run, tuple(scene.cracks))


def with_cracks(run: CrackRun, specs: tuple[CrackSpec, ...], initiated: bool = False) -> CrackRun:
    """The run with its cracks: the tip mesh and one face pair per crack added to the
    scene's pairs (in the order of the cracks, after the scene's own).

    Tip size: ``tip_size``; default Δa/8 with propagation, Δa_max/10 with fatigue (for an
    initiated crack at most that fraction of its length), else 1/100 of the shortest tip
    segment of all the cracks."""
    fr = run.fracture
    seg = min(c.crack.tip_segment_length(e) for c in specs for e in c.crack.tip_ends)
    if fr.tip_size is not None:
        h_tip = fr.tip_size
    elif fr.grows:
        shortest = min(c.crack.length for c in specs)
        step = fr.growth_step if not initiated else min(fr.growth_step, shortest)
        h_tip = step / (8 if fr.propagate else 10)
    else:
        h_tip = seg / 100
    pairs = tuple(c.face_pair(_pair_name(c.name), "crack_plus", "crack_minus") for c in specs)
    return dataclasses.replace(
        run,
        scene=dataclasses.replace(run.scene, contacts=tuple(run.scene.contacts) + pairs),
        specs=specs,
        tip_mesh=TipMesh(h_tip, fr.tip_grading if fr.tip_grading is not None else 0.25),
        initiated=initiated,
    )


def respecified(run: CrackRun, specs: tuple[CrackSpec, ...]) -> CrackRun:
    """The run with other cracks (after a merge): the face pairs of the old ones replaced
    by those of ``specs``."""
    contacts = tuple(run.scene.contacts)
    base = dataclasses.replace(run.scene, contacts=contacts[: len(contacts) - len(run.specs)])
    return with_cracks(dataclasses.replace(run, scene=base), specs, run.initiated)


def build_cracked(
    scene: Scene,
    run: CrackRun,
    cracks: list[Crack2D],
    comm: MPI.Comm,
    timer: PhaseTimer,
    made: str | None = None,
) -> tuple[SceneModel, list[CrackedMesh]]:
    """The scene model on the body meshed around ``cracks`` (one per ``run.specs``), with
    their face pairs last (in the order of the cracks); the mesh viewed from each crack.

    A crack that cannot be cut into the body, meshed or paired is a :class:`SceneError`
    naming its table when it is the scene's (``made`` ``None``), else — a crack the run
    made (``made``: ``"inserted"``, ``"grown"``) — a :class:`RunError` naming the crack,
    its points and the reason (the run ends ``"failed"``)."""
    try:
        with timer.phase("mesh_read"):
            cms, md = mesh_body_with_cracks(run.body, cracks, run.tip_mesh, comm)
    except (ParameterError, MeshingError) as exc:
        if made is not None:
            raise _run_error(run, cracks, None, made, "cannot be meshed", exc) from None
        raise _scene_error(scene, 0, run.spec, exc, "points", run.initiated) from None
    sm = build_model(scene, comm, timer, mesh=(md, run.groups))
    for i, cm in enumerate(cms):
        try:
            with timer.phase("mortar_geometry"):
                sm.interfaces.append(face_interface(sm.model, cm, run.pair(i)))
        except ContactInputError as exc:
            if made is not None:
                raise _run_error(run, cracks, i, made, "faces cannot be paired", exc) from None
            raise _scene_error(scene, i, run.specs[i], exc, "points", run.initiated) from None
    return sm, cms


def _run_error(
    run: CrackRun, cracks: list[Crack2D], i: int | None, made: str, what: str, exc: Exception
) -> RunError:
    """The failure of a crack the run inserted or grew (:func:`build_cracked`)."""
    which = range(len(cracks)) if i is None else [i]
    names = ", ".join(
        f"{run.specs[j].name!r} (points "
        + ", ".join(f"({x:.6g}, {y:.6g})" for x, y in cracks[j].points)
        + ")"
        for j in which
    )
    return RunError(f"the {made} crack {names}: {what}: {exc}")


def check_cracked(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> SceneModel:
    """Every check of a crack scene, the first cracked mesh and the face pair included
    (nothing written); the scene model on that mesh."""
    if scene.dimension == 3:  # a planar crack in a 3D body
        return check_cracked3d(scene, comm)
    run = prepare(scene, comm)
    if run.spec is None:  # the crack is initiated by the run: the uncracked model
        return build_model(scene, comm, PhaseTimer(), mesh=(run.mesh, run.groups))
    return build_cracked(scene, run, [c.crack for c in run.specs], comm, PhaseTimer())[0]


# ------------------------------------------------------------------ tip evaluation
def _radius(crack: Crack2D, end: int, run: CrackRun, others: list[Crack2D]) -> float:
    """Integration-domain radius: within the straight tip segment and away from the
    surface and the ``others`` cracks; with propagation at most 2Δa
    (docs/theory/fracture.md#propagation)."""
    seg = crack.tip_segment_length(end)
    free = min([run.body.distance(crack.tip(end))] + [c.distance(crack.tip(end)) for c in others])
    r = min(0.4 * seg, 0.8 * free)
    if run.fracture.grows:
        r = min(0.8 * seg, 0.8 * free, 2.0 * run.fracture.growth_step)
    return r


def evaluate_tips(
    sm: SceneModel,
    cms: list[CrackedMesh],
    u: Any,
    result: Any,
    run: CrackRun,
    increment: int,
    step: int,
    t: float,
) -> list[IncrementRecord]:
    """K, J, G, displacement correlation and the kink of every tip of every crack, crack
    by crack in the order of the scene (collective)."""
    records = []
    for i, cm in enumerate(cms):
        others = [c.crack for j, c in enumerate(cms) if j != i]
        k_pair = len(sm.interfaces) - len(cms) + i
        where = (k_pair, run.specs[i].name)
        records += _crack_tips(sm, cm, where, others, u, result, run, (increment, step, t))
    return records


def _crack_tips(
    sm: SceneModel,
    cm: CrackedMesh,
    where: tuple[int, str],
    others: list[Crack2D],
    u: Any,
    result: Any,
    run: CrackRun,
    when: tuple[int, int, float],
) -> list[IncrementRecord]:
    """The records of the tips of one crack (``where``: its face pair's index and its
    name; the ``others`` cracks bound its integration domains)."""
    crack, comm = cm.crack, cm.mesh.comm
    (k_pair, name), (increment, step, t) = where, when
    face = None
    if result is not None:
        tips = [crack.tip(e) for e in crack.tip_ends]
        reach = max(_radius(crack, e, run, others) for e in crack.tip_ends)
        face = face_traction(sm.model.V, sm.interfaces[k_pair], result, k_pair, tips, reach)
    records = []
    for end in crack.tip_ends:
        r_out = _radius(crack, end, run, others)
        if r_out < 4 * run.tip_mesh.h_tip:
            raise ParameterError(
                "tip_size",
                f"the integration domain at tip {end} (r = {r_out:.3g} m) spans fewer than "
                f"4 tip elements (crack {name!r}); choose a smaller tip_size",
            )
        k = interaction_integral(u, cm, end, run.material, r_out, face_traction=face)
        try:
            dc = displacement_correlation(u, cm, end, run.material, r_out)
            kdc = (dc.K_I, dc.K_II)
        except ParameterError:
            kdc = (math.nan, math.nan)
        if run.fracture.direction == "mts":
            theta = mts_angle(k.K_I, k.K_II)
        else:
            theta = principal_direction_average(
                cell_stresses(sm.model, u),
                comm,
                crack.tip(end),
                crack.direction(end),
                24,
                2.0 * run.tip_mesh.h_tip,
            )
        k_eq = mts_equivalent_k(k.K_I, k.K_II, theta)
        load = run.K_Ic / k_eq if (run.K_Ic and k_eq > 0) else math.nan
        status = "stationary"
        if run.fracture.propagate:
            status = "grows" if (run.K_Ic and k_eq >= run.K_Ic) else "holds"
        x, y = crack.tip(end)
        records.append(
            IncrementRecord(
                increment,
                end,
                float(x),
                float(y),
                crack.length,
                k.K_I,
                k.K_II,
                k.G,
                math.degrees(theta),
                load,
                status,
                step=step,
                time=t,
                J=k.J,
                K_I_dc=kdc[0],
                K_II_dc=kdc[1],
                K_eq=k_eq,
                crack=name,
            )
        )
    return records


def _snapped(crack: Crack2D, ends: tuple[int, ...], run: CrackRun) -> Crack2D:
    """The crack with its points at ``ends`` rounded to a grid of spacing
    2^(⌊log₂ extent⌋ − 32) of the body (about 1e-11 m for a 40 mm body), as the growth
    remeshes round their boundaries (:func:`bonecontact.neoplasm.remesh.snap_to_grid`); a
    mouth is then put back on the outline (its nearest point).  A grown tip's kink angle
    and an inserted crack's place come from solves whose round-off differs with the
    number of ranks, and gmsh turns a point 1e-19 m away into another mesh (the path on 2
    ranks drifted by 7e-8 of Δa)."""
    q = 2.0 ** (math.floor(math.log2(run.body.scale)) - 32)
    pts = crack.points.copy()
    for e in ends:
        k = 0 if e == 0 else len(pts) - 1
        pts[k] = np.round(pts[k] / q) * q
        if e in crack.mouth_ends:
            pts[k] = run.body.nearest(pts[k])[0]
    return Crack2D(pts, crack.tips)


def _lead_size(cracks: list[Crack2D], rows: list[IncrementRecord], run: CrackRun) -> float:
    """The size ρ of the crack of the leading tip (the largest K_eq) of ``rows`` seen from
    that tip (:func:`size_from_tip`)."""
    lead = max(rows, key=lambda r: r.K_eq)
    return size_from_tip(cracks[[c.name for c in run.specs].index(lead.crack)], lead.tip)


def _grow(
    cracks: list[Crack2D],
    records: list[IncrementRecord],
    run: CrackRun,
    advances: dict[tuple[str, int], float] | None = None,
) -> tuple[list[Crack2D], str]:
    """The cracks grown at every tip that grows (by Δa, or by its entry of ``advances``,
    keyed by (crack name, tip end)), each tip by its own kink; the stop: ``"fractured"``
    when a grown tip is within Δa (Δa_max) of the free surface, ``"joined"`` when it is
    within Δa of another crack (the rows of those tips so marked), else ``""``."""
    da = run.fracture.growth_step
    if advances is None:
        advances = {tip_key(r): da for r in records if r.status == "grows"}
    names = [c.name for c in run.specs]
    cracks = list(cracks)
    grown = [(i, r) for i, r in enumerate(records) if tip_key(r) in advances]
    for _, r in grown:
        k = names.index(r.crack)
        longer = cracks[k].extended(r.tip, advances[tip_key(r)], math.radians(r.angle_deg))
        cracks[k] = _snapped(longer, (r.tip,), run)
    stop = ""
    for i, r in grown:
        k = names.index(r.crack)
        tip = cracks[k].tip(r.tip)
        near = min([math.inf] + [c.distance(tip) for j, c in enumerate(cracks) if j != k])
        if run.body.distance(tip) < da:
            stop, records[i] = "fractured", dataclasses.replace(r, status="fractured")
        elif near < da:
            stop = stop or "joined"
            records[i] = dataclasses.replace(r, status="joined")
    return cracks, stop


# ------------------------------------------------------------------------- run
def write_crack_path(path: Path, cracks: Crack2D | list[Crack2D]) -> None:
    """The cracks' polylines as a legacy VTK file (POLYDATA, one line per crack; z = 0), to
    be shown with the fields of the mesh they were cut into (ParaView, pyvista)."""
    cracks = [cracks] if isinstance(cracks, Crack2D) else list(cracks)
    pts = np.concatenate([c.points for c in cracks])
    lines = ["# vtk DataFile Version 3.0", f"crack path, {len(pts)} points", "ASCII"]
    lines += ["DATASET POLYDATA", f"POINTS {len(pts)} double"]
    lines += [f"{float(x)!r} {float(y)!r} 0.0" for x, y in pts]
    lines += [f"LINES {len(cracks)} {len(pts) + len(cracks)}"]
    start = 0
    for c in cracks:
        n = len(c.points)
        lines.append(" ".join(map(str, [n, *range(start, start + n)])))
        start += n
    Path(path).write_text("\n".join(lines) + "\n")


def _console(comm: MPI.Comm, progress: bool, text: str) -> None:
    if comm.rank == 0:
        tqdm.write(text) if progress else print(text, flush=True)


def _initiate(
    scene: Scene, run: CrackRun, sm: SceneModel, rec: Recorder, prev: tuple[float, float], t: float
) -> tuple[Initiation, dict[str, Any]]:
    """The crack inserted at the risk maximum of the current state, and its record for
    summary.json (collective; a crack that does not fit is a SceneError on every rank)."""
    fr, mx = run.fracture, rec.fracture.current
    h = cell_size_at(sm.model.mesh, mx.location)
    centre = mx.location
    for _ in range(2):  # about the largest cell, then about the peak's centre
        centre, direction = risk_peak(sm.model, rec.integ.u, rec.fracture.risk, centre, 20 * h)
    length = (
        fr.initiation_length
        if fr.initiation_length is not None
        else default_length(fr.growth_step, h)
    )
    try:
        ini = initiation_crack(run.body, centre, direction, length, h)
        snapped = _snapped(ini.crack, (0, -1), run)
        mouth = snapped.points[snapped.mouth_ends[0]] if snapped.mouth_ends else ini.point
        ini = dataclasses.replace(ini, crack=snapped, point=tuple(float(v) for v in mouth))
        run.body.check_crack(ini.crack)
    except ParameterError as exc:
        raise _scene_error(scene, 0, None, exc, "initiation_length") from None
    record = {
        "step": rec.integ.step_count,
        "time": t,
        "load_factor": initiation_time(prev[0], prev[1], t, mx.value),
        "risk": mx.value,
        "mode": mx.mode,
        "max_risk_location": list(mx.location),
        "location": list(ini.location),
        "point": list(ini.point),
        "on_surface": ini.on_surface,
        "direction": list(ini.direction),
        "length": ini.length,
        "cell_size": ini.cell_size,
        "points": ini.crack.points.tolist(),
        "tips": ini.crack.tips,
    }
    return ini, record


def _plain(o: object) -> Any:
    """JSON of NumPy scalars and arrays (a checkpoint's crack state)."""
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"cannot store {type(o).__name__} in a checkpoint")


def _saved_cracks(saved: dict[str, Any]) -> list[Crack2D]:
    """The cracks of a checkpoint's ``crack_run`` entry (before several cracks: the one
    crack's ``points`` and ``tips``)."""
    entries = saved.get("cracks") or [{"points": saved["points"], "tips": saved["tips"]}]
    return [Crack2D(np.asarray(e["points"], dtype=float), e["tips"]) for e in entries]


def _saved_specs(run: CrackRun, saved: dict[str, Any], cracks: list[Crack2D]) -> CrackRun:
    """The run with the cracks of a checkpoint taken after cracks merged (their names
    differ from the scene's; a merged crack in the region of the scene's cracks)."""
    names = [e.get("name") for e in saved.get("cracks") or []]
    if not names or names == [s.name for s in run.specs]:
        return run
    specs = tuple(
        CrackSpec(e["name"], c, run.specs[0].region, float(e.get("coefficient", 0.0)))
        for e, c in zip(saved["cracks"], cracks, strict=True)
    )
    return respecified(run, specs)


def _initiated_spec(run: CrackRun, initiation: dict[str, Any]) -> CrackSpec:
    """The ``[[crack]]`` of an initiated crack, from its initiation record."""
    crack = Crack2D(np.asarray(initiation["points"], dtype=float), initiation["tips"])
    return CrackSpec("initiated", crack, run.body.region[0], run.fracture.coefficient)


@dataclasses.dataclass
class CrackProgress:
    """Where a crack run stands: what its checkpoints store and its summary reports."""

    increment: int = 0  # crack increments made
    status: str | None = None  # grows, arrested, max_increments, fractured, joined
    fractured_at: tuple[float, int] | None = None  # (time, step) the crack cut through
    tips_last: list[IncrementRecord] = dataclasses.field(default_factory=list)
    initiation: dict[str, Any] | None = None  # the record of an initiated crack
    risk_before: dict[str, Any] | None = None  # the initiation check on the uncracked body
    prev: tuple[float, float] = (0.0, 0.0)  # (time, largest risk) of the last step recorded
    merges: list[dict[str, Any]] = dataclasses.field(default_factory=list)  # cracks merged
    joined: str = ""  # why cracks that met were not merged (the stop joined)


class CrackSteps(MechanicsSteps):
    """The hooks of a 2D crack run (:func:`bonecontact.runners.loop.run_steps`).

    After a step solved on the uncracked body: the initiation check, and the crack
    inserted where the risk reaches 1 (the same step again on the cracked body).  After a
    step on the cracked body: K at every tip (fracture.csv), the crack grown where K
    reaches K_Ic (the same step again on the longer crack) until it arrests or cuts
    through (the last step).  Checkpoints hold the crack with the mechanics state
    (:class:`bonecontact.runners.checkpoint.CrackState`).
    """

    errors = (RuntimeError, ParameterError)  # a solver failure; a tip K cannot be had

    def __init__(
        self,
        scene: Scene,
        run: CrackRun,
        comm: MPI.Comm,
        outdir: Path,
        timer: PhaseTimer,
        ck: Checkpointer,
        resume: tuple[Path, dict[str, Any]] | None,
        progress: bool,
    ):
        self.scene, self.comm, self.outdir, self.ck, self.resume = scene, comm, outdir, ck, resume
        self.progress, self.table = progress, None
        self.saved = resume[1]["crack_run"] if resume is not None else None
        self.nsteps, dt = analysis_steps(scene)
        super().__init__(None, None, timer, scene.output.fields_every, RunCounters(), dt)
        self.state = CrackProgress()
        self.fatigue = FatigueProgress()  # the blocks of a [fracture.fatigue] run
        self.run = run
        self.cracks: list[Crack2D] | None = None  # as they have grown, one per run.specs
        self.cms: list[CrackedMesh] | None = None  # the mesh viewed from each crack

    # ------------------------------------------------------------- models
    def build_first(self, scene: Scene) -> int:
        """The model the run starts on (the uncracked body, the crack of the scene or the
        crack of the checkpoint) with its integrator and recorder; returns the first step."""
        run, saved, resume = self.run, self.saved, self.resume
        if saved is not None and saved["initiated"]:
            initiated = (_initiated_spec(run, saved["initiation"]),)
            self.run = run = with_cracks(run, initiated, True)
        if run.spec is None:  # no crack yet: the scene's own mesh until the risk reaches 1
            self.sm = build_model(scene, self.comm, self.timer, mesh=(run.mesh, run.groups))
        else:
            self.cracks = [c.crack for c in run.specs]
            if saved is not None:  # the cracks as they had grown (and merged)
                self.cracks = _saved_cracks(saved)
                self.run = run = _saved_specs(run, saved, self.cracks)
            self.sm, self.cms = build_cracked(scene, run, self.cracks, self.comm, self.timer)
        if resume is None:
            self.start_model(0, "fields")
            return 1
        segment = int(resume[1]["counters"]["segment"]) + 1
        self.start_model(int(resume[1]["step"]), f"fields_restart{segment}")
        self.restore(saved)
        return int(resume[1]["step"]) + 1

    def restore(self, saved: dict[str, Any]) -> None:
        """The crack run's progress from a checkpoint's ``crack_run`` entry."""
        self.state = CrackProgress(
            int(saved["increment"]),
            saved["propagation"],
            None,
            plain_rows(saved["tips_last"]),
            saved["initiation"],
            saved["risk_before"],
            tuple(saved["prev"]),
            list(saved.get("merges", [])),
        )
        self.fatigue = FatigueProgress.from_state(saved.get("fatigue"))

    def start_model(self, step: int, stem: str) -> None:
        """The integrator (at ``step``) and recorder of the current model; after a
        re-meshing or a restart history.csv continues and the fields go to new files."""
        with self.timer.phase("solver_setup"):
            integ = scene_integrator(self.run.scene, self.sm, self.dt, False)
            integ.set_initial(None, self.sm.v0)
            integ.step_count, integ.t = step, step * self.dt
        resumed = {}
        if stem.startswith("fields_restart"):  # the state and counters of the checkpoint
            with self.timer.phase("checkpoint"):
                self.ck.state.integ = integ
                self.ck.continue_from(*self.resume)  # the state, a new segment; tables cut
                self.counters = self.ck.state.counters
            if self.saved["monitor"] is not None:
                resumed["fracture"] = self.saved["monitor"]
        files = SimpleNamespace(
            restarted_from="increment" if stem != "fields" else None,
            fields_stem=stem,
            extra={},
            resumed=resumed,
        )
        with self.timer.phase("output"):
            self.rec = Recorder(
                self.run.scene, self.sm, integ, self.comm, self.outdir, False, files
            )
            if self.cracks is not None and self.comm.rank == 0:
                write_crack_path(self.outdir / f"{stem}_crack.vtk", self.cracks)
        self.integ = integ

    def remesh(self, k: int, stem: str) -> Verdict:
        """The body meshed around the current crack, the model rebuilt on it at the state
        before step ``k``: the same step again.  A crack that cannot be meshed or paired
        ends the run ``"failed"`` (:class:`RunError`), the last model's state kept."""
        made = "inserted" if stem == "fields_initiated" else "grown"
        try:
            built = build_cracked(self.scene, self.run, self.cracks, self.comm, self.timer, made)
        except RunError:
            self.state.status = "failed"
            raise
        self.integ.destroy()
        self.rec.writer.close()
        self.sm, self.cms = built
        self.start_model(k - 1, stem)
        return Verdict.AGAIN

    # ------------------------------------------------------------- hooks
    def start(self) -> None:
        super().start()
        fracture = self.rec.fracture
        self.state.prev = (0.0, fracture.current.value if fracture is not None else 0.0)

    def after(self, k: int) -> Verdict:
        if self.cms is None:
            return self.check_initiation(k)
        return self.evaluate_and_grow(k)

    def check_initiation(self, k: int) -> Verdict:
        """No crack yet: the initiation check of step ``k``; at risk 1 the crack inserted."""
        integ, rec = self.integ, self.rec
        with self.timer.phase("fracture"):
            self.sm.model.update_nodal_volumetric(integ.u, integ.velocity)  # as record does
            rec.fracture.update(k, integ.t)
        if rec.fracture.current.value < 1.0:
            return Verdict.NEXT
        with self.timer.phase("fracture"):
            ini, initiation = _initiate(
                self.scene, self.run, self.sm, rec, self.state.prev, integ.t
            )
        self.state.initiation, self.state.risk_before = initiation, rec.fracture.summary()
        self.run = with_cracks(self.run, (_initiated_spec(self.run, initiation),), True)
        self.cracks = [self.run.spec.crack]
        where = "at the surface point" if ini.on_surface else "centred at"
        self.say(
            f"{self.scene.name}: risk {rec.fracture.current.value:.4g} >= 1 at t = "
            f"{integ.t:.6g} (step {k}; 1 reached at {initiation['load_factor']:.6g}): crack of "
            f"{ini.length:.4g} m inserted {where} ({ini.point[0]:.6g}, {ini.point[1]:.6g}) "
            f"along ({ini.direction[0]:.4f}, {ini.direction[1]:.4f})"
        )
        return self.remesh(k, "fields_initiated")  # the same load on the cracked body

    def evaluate_and_grow(self, k: int) -> Verdict:
        """K at every tip of every crack after step ``k``; each tip grown where its own
        K_eq reaches K_Ic, all in one increment (with ``[fracture.fatigue]``:
        :meth:`fatigue_block`)."""
        if self.run.fracture.fatigue is not None:
            return self.fatigue_block(k)
        integ, st = self.integ, self.state
        with self.timer.phase("fracture"):
            records = evaluate_tips(
                self.sm, self.cms, integ.u, integ.last_contact, self.run, st.increment, k, integ.t
            )
        grows = any(r.status == "grows" for r in records)
        if grows and st.increment >= self.run.fracture.max_increments:
            records = [_spent(r) for r in records]
            grows, st.status = False, "max_increments"
        stop = ""
        if grows:
            self.cracks, stop = _grow(self.cracks, records, self.run)
            stop = self.merge_joined(k, records, stop)
        self.table.rows(records)
        st.tips_last = records
        if stop:
            st.increment, st.status = st.increment + 1, stop
            st.fractured_at = (integ.t, k) if stop == "fractured" else None
            what = "fractured" if stop == "fractured" else f"cracks joined ({st.joined})"
            self.say(
                f"{self.scene.name}: {what} at t = {integ.t:.6g} "
                f"(step {k}, after {st.increment} crack increments)"
            )
            return Verdict.LAST
        if grows:
            st.increment, st.status = st.increment + 1, "grows"
            return self.remesh(k, f"fields_increment{st.increment}")  # the longer crack
        if st.status == "grows":
            st.status = "arrested"
        return Verdict.NEXT

    def fatigue_block(self, k: int) -> Verdict:
        """K at every tip after step ``k`` of a fatigue run; at the last step (the peak of
        the cycle) a block end: its cycles, then a stop or the next block (the crack grown,
        the same step again on the re-meshed body)."""
        integ, st, fr = self.integ, self.state, self.run.fracture
        with self.timer.phase("fracture"):
            records = evaluate_tips(
                self.sm, self.cms, integ.u, integ.last_contact, self.run, st.increment, k, integ.t
            )
        prog = self.fatigue if k == self.nsteps else None
        waiting = dict(self.fatigue.waiting)  # what the tips kept before this block end
        rows, grow, stop = block_end(records, fr.fatigue, self.run.K_Ic, prog, st.increment)
        met = ""
        if grow:
            slope = self_similar_slope(fr.fatigue.m, _lead_size(self.cracks, rows, self.run))
            grow = self.fit_block(rows, grow, waiting)
            self.cracks, met = _grow(self.cracks, rows, self.run, grow)
            met = self.merge_joined(k, rows, met, slope)
        self.table.rows(rows)
        st.tips_last = rows
        if stop or met:
            self.fatigue_stop(k, stop or met, rows)
            return Verdict.LAST
        if prog is None:
            return Verdict.NEXT
        st.increment, st.status = st.increment + 1, "grows"
        verdict = self.remesh(k, f"fields_block{st.increment}")  # the longer crack
        self.block_checkpoint(k)
        return verdict

    def fit_block(
        self,
        rows: list[IncrementRecord],
        grow: dict[tuple[str, int], float],
        waiting: dict[tuple[str, int], float],
    ) -> dict[tuple[str, int], float]:
        """The advances of the next fatigue block (``grow``: those of a full block of
        Δa_max; ``waiting``: what the tips kept before it), shortened before a merge
        (docs/theory/fracture.md#coalescence).

        When the block is the first of its set of cracks (its start the only end known)
        and its facing tips would meet and merge, it is shortened to a block of length L
        (:func:`block_shares`) midway between the floor 0.6 Δa_max (the tip segment that
        bounds the integration domain) and the length at which the gap would reach the
        merge distance Δa, the gap closing in proportion to L; only when that length
        exceeds the floor and the shortened block merges nothing.  The block after it,
        when its facing tips would cross, is cut where they meet (its tips that meet
        grow whatever their share).  Any other block is left as it is."""
        prog, fr = self.fatigue, self.run.fracture
        after_short, prog.shortened = prog.shortened, False
        first = len(prog.growth) - 1 == prog.phases[-1]
        if fr.joined != "merge" or not (first or after_short):
            return grow
        da = fr.growth_step
        merges, pairs = self._meeting(rows, grow)
        if after_short:
            cross = [(g0, g1, tips) for g0, g1, tips in pairs if g1 < 0.0 < g0]
            if not cross:
                return grow
            length = min(da * g0 / (g0 - g1) for g0, g1, _ in cross)
            must = tuple(t for _, _, tips in cross for t in tips if t in grow)
            new, kept = block_shares(rows, fr.fatigue, waiting, length, must)
            what = "cut where the facing tips meet"
        else:
            floor = WAIT_FRACTION * da
            reach = [da * (g0 - da) / (g0 - g1) for g0, g1, _ in pairs if g0 > g1]
            if not (merges and reach) or min(reach) <= floor:
                return grow
            length = 0.5 * (floor + min(reach))
            new, kept = block_shares(rows, fr.fatigue, waiting, length)
            if _grow(self.cracks, list(rows), self.run, new)[1]:
                return grow  # the shortened block would still meet (or cut through)
            prog.shortened = True
            what = "shortened before the facing tips meet"
        prog.waiting = kept
        prog.shortfall += da - length
        for i, r in enumerate(rows):  # the rows say which tips grow in this block
            if r.status in ("grows", "holds"):
                rows[i] = dataclasses.replace(r, status="grows" if tip_key(r) in new else "holds")
        self.say(
            f"{self.scene.name}: block {self.state.increment + 1} {what}: the leading tip "
            f"grows {length:.4g} m (of {da:.4g} m)"
        )
        return new

    def _meeting(
        self, rows: list[IncrementRecord], grow: dict[tuple[str, int], float]
    ) -> tuple[bool, list[tuple[float, float, tuple]]]:
        """A trial of the block ``grow``: whether its tips meet and would merge, and for each
        tip that meets another crack's facing tip (directions opposite within
        MERGE_ANGLE_DEG) the gap between them along the line from one to the other before
        (> 0) and after the block (< 0: crossed), with the two tips."""
        trial = list(rows)
        after, stop = _grow(self.cracks, trial, self.run, grow)
        if stop != "joined":
            return False, []
        fr, names = self.run.fracture, [sp.name for sp in self.run.specs]
        joined = [tip_key(r) for r in trial if r.status == "joined"]
        res = join_cracks(
            after, self.run.specs, joined, fr.growth_step, self.run.tip_mesh.h_tip, self.run.body
        )
        pairs, cos_max = [], math.cos(math.radians(MERGE_ANGLE_DEG))
        for name, end in joined:
            a = names.index(name)
            p0, p1 = self.cracks[a].tip(end), after[a].tip(end)
            b = min((c.distance(p1), j) for j, c in enumerate(after) if j != a)[1]
            if not self.cracks[b].tip_ends:
                continue
            e = min(
                self.cracks[b].tip_ends, key=lambda t: np.linalg.norm(self.cracks[b].tip(t) - p0)
            )
            q0, q1 = self.cracks[b].tip(e), after[b].tip(e)
            d_a, d_b = self.cracks[a].direction(end), self.cracks[b].direction(e)
            g0 = float(np.linalg.norm(q0 - p0))
            if -float(np.dot(d_a, d_b)) < cos_max or g0 <= 0.0:
                continue
            g1 = float(np.dot(q1 - p1, (q0 - p0) / g0))
            pairs.append((g0, g1, ((name, end), (names[b], e))))
        return not res.reason, pairs

    def merge_joined(
        self, k: int, rows: list[IncrementRecord], stop: str, slope: float = 0.0
    ) -> str:
        """After a growth that stopped ``joined``, with ``[fracture] joined = "merge"``: the
        cracks whose facing tips met merged (:func:`join_cracks`; their rows marked
        ``merged``, the run's cracks and face pairs replaced, a fatigue run's kept growth
        moved to the merged tips and its leading tip's self-similar ``slope`` kept for
        the merging block) and ``""`` returned; else the stop, with the reason why nothing
        was merged kept for the message."""
        if stop != "joined":
            return stop
        st = self.state
        if self.run.fracture.joined != "merge":
            st.joined = '[fracture] joined = "stop"'
            return stop
        tips = [tip_key(r) for r in rows if r.status == "joined"]
        fr, h_tip = self.run.fracture, self.run.tip_mesh.h_tip
        res = join_cracks(self.cracks, self.run.specs, tips, fr.growth_step, h_tip, self.run.body)
        if res.reason:
            st.joined = f"not merged: {res.reason}"
            return stop
        for i, r in enumerate(rows):
            if r.status == "joined":
                rows[i] = dataclasses.replace(r, status="merged")
        self.run, self.cracks = respecified(self.run, res.specs), res.cracks
        st.merges += [m | {"increment": st.increment, "step": k} for m in res.merges]
        if fr.fatigue is not None:
            self.fatigue.merged(res.tip_map, slope)
        for m in res.merges:
            self.say(
                f"{self.scene.name}: cracks {m['cracks'][0]!r} and {m['cracks'][1]!r} met "
                f"(bridge {m['bridge']:.3g} m) at step {k}, increment {st.increment}: "
                f"merged into {m['into']!r}"
            )
        return ""

    def fatigue_stop(self, k: int, status: str, rows: list[FatigueRecord]) -> None:
        """The end of the blocks: the status, after a fracture the bound of the cycles to
        separation, and the line on the console."""
        st, prog, t = self.state, self.fatigue, self.integ.t
        st.status = prog.status = status
        cycles = prog.cycles[-1] if prog.cycles else 0.0
        if status == "fractured":
            st.increment, st.fractured_at = st.increment + 1, (t, k)
            law = paris_law(self.run.fracture.fatigue)
            prog.bound = min(
                bound_to_separation(cycles, self.run.body.distance((r.x, r.y)), law.rate(r.K_eq))
                for r in rows
                if r.status == "fractured"
            )
        why = f" ({st.joined})" if status == "joined" else ""
        self.say(
            f"{self.scene.name}: fatigue {status}{why} at step {k} after {len(prog.cycles) - 1} "
            f"blocks, N = {cycles:.6g} cycles (crack length "
            f"{', '.join(f'{c.length:.6g}' for c in self.cracks)} m)"
        )

    def block_checkpoint(self, k: int) -> None:
        """After a block (the model rebuilt at step ``k`` − 1): a checkpoint every
        ``checkpoint_every`` blocks and on a signal, which then stops the run."""
        every, signum = self.scene.output.checkpoint_every, self.ck.stop.agreed(self.comm)
        if signum or (every > 0 and self.state.increment % every == 0):
            with self.timer.phase("checkpoint"):
                self.ck.state.integ, self.ck.state.counters = self.integ, self.counters
                self.ck.write({"crack_run": self.crack_state()})
        if signum:
            self.ck.signum = signum
            raise RunStopped(
                "interrupted", f"stopped after block {self.state.increment} of step {k} by a signal"
            )

    def record(self, k: int, last: bool) -> None:
        super().record(k, last)
        if self.cms is None:
            self.state.prev = (self.integ.t, self.rec.fracture.current.value)

    def checkpoint(self, k: int, last: bool) -> bool:
        with self.timer.phase("checkpoint"):
            self.ck.state.integ, self.ck.state.counters = self.integ, self.counters
            signum = self.ck.after_step(last, {"crack_run": self.crack_state()})
        return bool(signum)

    def failure(self, k: int, exc: BaseException) -> str:
        return f"step {k} (t = {k * self.dt:.6g}): {exc}"

    # ------------------------------------------------------------- reports
    def say(self, text: str) -> None:
        """A line on the console (rank 0)."""
        _console(self.comm, self.progress, text)

    def crack_state(self) -> dict[str, Any]:
        """The ``crack_run`` entry of a checkpoint's meta.json."""
        st, cracks, fracture = self.state, self.cracks, self.rec.fracture
        crack = None if cracks is None else cracks[0]
        state = {
            "initiated": self.run.initiated,
            "points": None if crack is None else crack.points,  # the first crack's
            "tips": None if crack is None else crack.tips,
            "cracks": None
            if cracks is None
            else [
                {"name": sp.name, "points": c.points, "tips": c.tips, "coefficient": sp.coefficient}
                for sp, c in zip(self.run.specs, cracks, strict=True)
            ],
            "increment": st.increment,
            "propagation": st.status,
            "merges": st.merges,
            "tips_last": [dataclasses.asdict(r) for r in st.tips_last],
            "initiation": st.initiation,
            "risk_before": st.risk_before,
            "prev": list(st.prev),
            "monitor": fracture.checkpoint_state() if fracture is not None else None,
            "fatigue": self.fatigue.state() if self.run.fracture.fatigue is not None else None,
        }
        return json.loads(json.dumps(state, default=_plain))

    def fracture_summary(self) -> dict[str, Any]:
        """The ``fracture`` entry of summary.json."""
        st, run, fracture = self.state, self.run, self.rec.fracture
        frac = st.risk_before or (fracture.summary() if fracture is not None else {})
        if run.fracture.initiate:
            frac["initiation"] = st.initiation
        frac["cracks"] = [
            _crack_summary(run, i, c, st.tips_last, st.increment, st.status, st.fractured_at)
            for i, c in enumerate(self.cracks or [])
        ]
        if frac["cracks"] and run.fracture.fatigue is not None:
            for entry in frac["cracks"]:
                entry["fatigue"] = self.fatigue_summary()
        frac["crack"] = frac["cracks"][0] if frac["cracks"] else None  # the first crack
        frac["merges"] = st.merges
        if st.status == "joined":
            frac["joined"] = st.joined
        return frac

    def fatigue_summary(self) -> dict[str, Any]:
        """The ``fracture.crack.fatigue`` entry of summary.json."""
        prog, f, at = self.fatigue, self.run.fracture.fatigue, self.state.fractured_at
        return {
            "status": prog.status,
            "blocks": max(len(prog.cycles) - 1, 0),
            "cycles": prog.cycles[-1] if prog.cycles else 0.0,
            "cycles_bound": prog.bound,
            "length": sum(c.length for c in self.cracks),  # of all the cracks
            "lengths": {sp.name: c.length for sp, c in zip(self.run.specs, self.cracks)},
            "fractured": at is not None,
            "fracture_time": None if at is None else at[0],
            "fracture_step": None if at is None else at[1],
            **dataclasses.asdict(f),
            "K_Ic": self.run.K_Ic,
        }


def _spent(r: IncrementRecord) -> IncrementRecord:
    """A tip that would grow when the increments are spent."""
    return dataclasses.replace(r, status="max_increments") if r.status == "grows" else r


def run_cracked(
    scene: Scene,
    comm: MPI.Comm = MPI.COMM_WORLD,
    output: Path | None = None,
    progress: bool = True,
    restart: str | Path | bool | None = None,
) -> RunResult:
    """Validate, build and run a scene with a ``[[crack]]`` or with ``[fracture] initiate =
    true`` (module docstring), writing its results incrementally: history.csv, the contact
    tables (the crack pair included), fields (``fields.*``; after an initiation
    ``fields_initiated.*``, after the k-th re-meshing ``fields_increment<k>.*``, after the
    n-th restart ``fields_restart<n>.*``), fracture.csv and summary.json.

    ``restart``: continue from the newest checkpoint in the output directory (``True``)
    or the named one (docs/checkpoint.md); checkpoints are
    written between load steps as ``[output] checkpoint_every`` / ``checkpoint_time`` ask
    and when SIGINT/SIGTERM stops the run (``"interrupted"``).

    Raises
    ------
    CheckpointError
        The checkpoint to restart from is missing, damaged, from another scene or its
        mesh cannot be rebuilt.
    """
    if scene.dimension == 3:  # a planar crack in a 3D body: K along the front
        return run_cracked3d(scene, comm, output, progress, restart)
    t_start = time.perf_counter()
    timer = PhaseTimer()
    run = prepare(scene, comm)
    outdir = Path(output) if output is not None else scene.output.directory
    nsteps, dt = analysis_steps(scene)
    ck = Checkpointer(
        outdir,
        CrackState(comm),
        scene.output.checkpoint_every,
        {"scene": scene.name, "analysis": scene.analysis.kind, "dt": dt},
        scene.output.checkpoint_time,
    )
    resume = ck.find(restart) if restart else None
    hooks = CrackSteps(scene, run, comm, outdir, timer, ck, resume, progress)
    first = hooks.build_first(scene)
    columns = FATIGUE_COLUMNS if run.fracture.fatigue is not None else FRACTURE_COLUMNS
    fracture_csv = Path(outdir) / "fracture.csv"
    hooks.table = RecordTable(comm, fracture_csv, columns, append=resume is not None)
    try:
        with ck.stop:
            bar = progress_bar(comm, scene.name, nsteps, first - 1, progress)
            end = run_steps(hooks, first, nsteps, bar)
    finally:
        hooks.table.close()
    sm, integ, rec = hooks.sm, hooks.integ, hooks.rec
    info = summary_header(scene, sm, integ, dt)
    info.update(run_info(hooks.run.scene, sm, integ, hooks.counters, False, 0.0, t_start))
    info.update(ck.summary())
    info.update(rec.strain.summary())
    info["fracture"] = hooks.fracture_summary()
    summary = finish_run(scene, sm, rec, timer, comm, end.status, end.message, info)
    return RunResult(summary["status"], summary, integ, outdir)


def _crack_summary(
    run: CrackRun,
    i: int,
    crack: Crack2D,
    tips: list[IncrementRecord],
    increments: int,
    status: str | None,
    fractured_at: tuple[float, int] | None,
) -> dict[str, Any]:
    """The entry of crack ``i`` in ``fracture.cracks`` of summary.json (the first is also
    ``fracture.crack``); the propagation and fatigue entries are the run's, in each."""
    spec = run.specs[i]
    tips = [r for r in tips if r.crack in (spec.name, "")]
    out: dict[str, Any] = {
        "name": spec.name,
        "pair": _pair_name(spec.name),
        "friction": spec.coefficient,
        "points": crack.points.tolist(),
        "length": crack.length,
        "tips": [
            {
                c: getattr(r, c)
                for c in FRACTURE_COLUMNS
                if c not in ("increment", "step", "time", "length")  # the crack's, not the tip's
            }
            for r in tips
        ],
    }
    if run.fracture.propagate:
        out["propagation"] = {
            "status": status or "no_growth",
            "increments": increments,
            "increment": run.fracture.increment,
            "direction": run.fracture.direction,
            "K_Ic": run.K_Ic,
            "fractured": fractured_at is not None,
            "fracture_time": None if fractured_at is None else fractured_at[0],
            "fracture_step": None if fractured_at is None else fractured_at[1],
        }
    return out
