"""3D scenes with a semi-elliptical surface crack (``shape = "semi_elliptical"``;
docs/scene_format.md#fracture, docs/theory/fracture.md#surface-cracks-in-a-scenes-body).

The crack is cut into the scene's body (:mod:`bonecontact.fracture.surface_body3d`), its
faces a contact pair, and after the analysis's last step K_I, K_II, K_III, G, the σ₁′
equivalent K_V and kink angle (:mod:`bonecontact.fracture.advance3d`) come from the
interaction integral at ``front_points`` points between φ_s = 20° (or two front elements)
from either end of the front and at the deepest point.  Without growth that is the run;
several surface cracks are solved and grown together (:func:`run_several_surface`).

Growth keeps the crack planar and semi-elliptical and moves three points — the deepest and the
two at φ_s from the surface — as Newman and Raju's own growth computations do: ``[fracture]
propagate`` grows the points with K_V ≥ K_Ic by Δa (K_V/K_V,max)² under the one load;
``[fracture.fatigue]`` by the Paris rates of ΔK = (1 − R)K_V per block of cycles (the fastest
point Δa_max; :func:`~bonecontact.fracture.fatigue.block_cycles`).  Each increment re-meshes
the body and solves the analysis again.  It stops at arrest, at the increment or block limit,
when K_V reaches K_Ic under fatigue (``fractured``: the crack runs unstably) or when the grown
front would leave the body (``through``: it reaches the far surface); the two last report the
fragments, the body on either side of the crack plane; ``out_of_plane`` (with
``stop_out_of_plane``) when a growing point's σ₁′ kink exceeds ``max_kink_deg``
(:func:`check_kink`: recorded always).  A crack that cannot be cut while its front stays
inside, or meshed, or K that cannot be evaluated, ends the run ``failed``.  ``fracture.csv``
has a row per increment and front point, ``crack_surface_<k>.vtk`` and ``crack_front_<k>.vtk``
the crack and its front with K, ``increment<k>/`` each solve.
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np
import ufl
from dolfinx import fem, mesh

from bonecontact.common.errors import ParameterError, RunError
from bonecontact.common.geometry import nearest_triangle, on_advance_grid
from bonecontact.common.profiling import PhaseTimer
from bonecontact.contact.interface import ContactInputError
from bonecontact.fracture.advance3d import equivalent_k, sigma1_kink
from bonecontact.fracture.body3d import BodySurface, CrackedBody3D, body_surface
from bonecontact.fracture.crack3d import SurfaceBreakingCrack
from bonecontact.fracture.faces import face_interface, face_traction
from bonecontact.fracture.front3d import front_interaction_integral
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.surface3d import MIN_DOMAIN_ELEMENTS, domain_length
from bonecontact.fracture.surface_body3d import (
    CORNER,
    CutBody,
    corner_angle,
    corner_parameter,
    cut_mouth,
    cut_mouths,
    inside_body,
    mesh_body_with_surface_crack,
    mesh_body_with_surface_cracks,
)
from bonecontact.materials.laws import Isotropic
from bonecontact.meshing.builder import MeshingError
from bonecontact.runners.checkpoint import RunCounters
from bonecontact.runners.crack_fatigue import (
    FatigueProgress,
    final_block,
    final_block_note,
    growth_stop,
    growth_weights,
)
from bonecontact.runners.cracks3d import front_nodes, write_front
from bonecontact.runners.growth_state3d import find_growth_state, save_growth_state
from bonecontact.runners.loop import progress_bar, run_steps
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
from bonecontact.runners.results import RecordTable, RunResult, run_summary, write_summary
from bonecontact.scene import Scene, SceneError
from bonecontact.scene.errors import table_label
from bonecontact.scene.fracture_tables import surface_cracks_meet
from bonecontact.scene.spec import FractureSpec

__all__ = [
    "SEVERAL_COLUMNS",
    "SURFACE_COLUMNS",
    "NamedRecord",
    "PlanarModelWarning",
    "SurfaceRecord",
    "SurfaceStart",
    "check_surface_crack",
    "has_surface_crack",
    "prepare_several",
    "run_several_surface",
    "run_surface_crack",
]

#: Columns of ``fracture.csv`` of a surface crack (one row per increment and front point).
SURFACE_COLUMNS = (
    "increment",
    "cycles",
    "depth",
    "half_length",
    "point",
    "phi_deg",
    "psi_deg",
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
#: Parametric angle of the two growth points from the ends of the front.
PHI_SURFACE = math.radians(20.0)
#: The least parametric angle of a corner crack's K points from the ends of its front (a
#: quarter of the semi-elliptical front's 90° half; two and a half front elements if more).
PHI_CORNER = math.radians(10.0)


@dataclasses.dataclass(frozen=True)
class SurfaceRecord:
    """One row of ``fracture.csv`` (:data:`SURFACE_COLUMNS`)."""

    increment: int
    cycles: float
    depth: float
    half_length: float
    point: int
    phi_deg: float
    psi_deg: float
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
    status: str = "stationary"

    def row(self) -> list[Any]:
        return [getattr(self, c) for c in SURFACE_COLUMNS]


@dataclasses.dataclass
class SurfaceRun:
    """What a surface-crack scene needs besides the scene model."""

    scene: Scene  # with the crack's face pair added
    original: Scene  # as given (the model is built from it, the pair added after)
    name: str
    crack: SurfaceBreakingCrack  # its axis and centre set on the body's surface
    body: BodySurface
    material: Isotropic
    size: TipMesh
    groups: dict[str, tuple[int, int]]
    fracture: FractureSpec
    points: int
    K_Ic: float | None
    r_out: float = 0.0  # the integration domain's radius (m), fixed as the crack grows

    @property
    def ligament(self) -> float:
        """The least distance ahead of the front to the surface (m): r_out and two front
        elements (the domain must not reach the surface)."""
        return self.r_out + 2.0 * self.size.h_tip


def has_surface_crack(scene: Scene) -> bool:
    """Whether the scene's ``[[crack]]`` is a surface crack (this module runs it)."""
    return any(isinstance(c.crack, SurfaceBreakingCrack) for c in scene.cracks)


def _error(scene: Scene, key: str | None, text: str, i: int = 0) -> SceneError:
    return SceneError(str(scene.path), table_label("crack", i, scene.cracks[i].name), key, text)


def _refuse(scene: Scene) -> None:
    if len(scene.cracks) > 1:
        _refuse_several(scene)
    if scene.analysis.kind not in ("static", "quasistatic"):
        raise SceneError(
            str(scene.path),
            "[analysis]",
            "kind",
            f"a surface crack runs static or quasi-static analyses, not {scene.analysis.kind!r}",
        )
    fr = scene.fracture
    if fr is not None and fr.initiate:
        raise SceneError(str(scene.path), "[fracture]", "initiate", "runs in 2D scenes only")


def _refuse_several(scene: Scene) -> None:
    """What a scene with several surface cracks does not run: another kind of crack
    beside them, cracks in different regions."""
    for i, c in enumerate(scene.cracks):
        if not isinstance(c.crack, SurfaceBreakingCrack):
            raise _error(
                scene,
                "shape",
                "a surface-breaking crack shares its scene only with other surface-breaking "
                "cracks (semi_elliptical, quarter_elliptical); an interior crack beside a "
                "surface crack is not supported",
                i,
            )
        if c.region != scene.cracks[0].region:
            raise _error(scene, "region", "the cracks of a 3D scene lie in one body", i)


def _material(scene: Scene, region: str) -> tuple[Isotropic, float | None]:
    spec = next(m for m in scene.materials if region in m.regions)
    if not isinstance(spec.material, Isotropic):
        raise SceneError(
            str(scene.path),
            table_label("material", spec.index, spec.name),
            "model",
            "the stress intensity factors of a crack need an isotropic material around it",
        )
    k_ic = spec.strengths.get("K_Ic")
    return spec.material, (float(k_ic) if k_ic else None)


def body_and_material(
    scene: Scene, comm: MPI.Comm
) -> tuple[BodySurface, Isotropic, float | None, dict[str, tuple[int, int]]]:
    """The scene mesh's body around the (first) crack, its isotropic material and K_Ic,
    and the mesh's groups (collective; a :class:`SceneError` on every rank)."""
    spec = scene.cracks[0]
    md0, groups = read_mesh(scene, comm)
    try:
        body = body_surface(md0.mesh, md0.cell_tags, md0.facet_tags, groups, spec.region)
    except ParameterError as exc:
        raise _error(scene, exc.key, str(exc).removeprefix(f"{exc.key}: ")) from None
    material, k_ic = _material(scene, spec.region)
    return body, material, k_ic, groups


def prepare_surface(scene: Scene, comm: MPI.Comm) -> SurfaceRun:
    """Read the mesh, take the body's surface, cut the crack's mouth into it (to check
    it: a :class:`SceneError` naming the key on every rank) and set the front mesh."""
    _refuse(scene)
    if len(scene.cracks) > 1:  # the non-planar path comes here: it takes one crack
        raise SceneError(
            str(scene.path),
            "[fracture]",
            "surface_growth",
            "several surface cracks run on the planar path; the non-planar path takes one crack",
        )
    fr = scene.fracture if scene.fracture is not None else FractureSpec()
    body, material, k_ic, groups = body_and_material(scene, comm)
    size = _tip_mesh(fr, [scene.cracks[0].crack])
    cut = _cut(scene, body, size, 0)
    return _surface_run(scene, 0, (body, material, k_ic, groups), cut, size)


def _tip_mesh(fr: FractureSpec, cracks: list[SurfaceBreakingCrack]) -> TipMesh:
    """The front mesh: ``tip_size``, else a tenth of the smallest crack's smaller axis."""
    h = fr.tip_size if fr.tip_size is not None else min(c.b for c in cracks) / 10
    return TipMesh(h, fr.tip_grading if fr.tip_grading is not None else 0.12)


def _cut(scene: Scene, body: BodySurface, size: TipMesh, i: int) -> CutBody:
    """Crack ``i``'s mouth cut into the body (a :class:`SceneError` naming it)."""
    try:
        return cut_mouth(body, scene.cracks[i].crack, size)
    except ParameterError as exc:
        raise _error(scene, exc.key, str(exc).removeprefix(f"{exc.key}: "), i) from None


def _surface_run(
    scene: Scene, i: int, around: tuple, cut: CutBody, size: TipMesh, pairs: tuple = ()
) -> SurfaceRun:
    """Crack ``i``'s run: ``around`` = (body, material, K_Ic, groups); the scene gets the
    face pairs ``pairs`` (default: the crack's own) as its last contacts."""
    body, material, k_ic, groups = around
    spec, h = scene.cracks[i], size.h_tip
    fr = scene.fracture if scene.fracture is not None else FractureSpec()
    crack = spec.crack
    r_out = min(max(0.25 * crack.b, 3.0 * h), 0.6 * crack.b**2 / crack.a)
    if r_out < 3.0 * h * (1.0 - 1e-9):
        raise SceneError(
            str(scene.path),
            "[fracture]",
            "tip_size",
            f"the integration domain (r = {r_out:.3g} m: at most 0.6 b²/a of the crack) spans "
            f"fewer than 3 front elements of {h:.3g} m; choose a smaller tip_size",
        )
    _check_inside(scene, body, cut, r_out + 2.0 * h, i)
    pairs = pairs or (spec.face_pair(_pair_name(spec.name), "crack_upper", "crack_lower"),)
    scene2 = dataclasses.replace(scene, contacts=tuple(scene.contacts) + tuple(pairs))
    return SurfaceRun(
        scene2,
        scene,
        spec.name,
        cut.crack,
        body,
        material,
        size,
        groups,
        fr,
        spec.front_points,
        k_ic,
        r_out,
    )


def prepare_several(scene: Scene, comm: MPI.Comm) -> tuple[list[SurfaceRun], list[CutBody]]:
    """The runs of a scene's several surface cracks (their scenes hold every crack's face
    pair, in the order of the cracks) and their mouths cut into one boundary (each crack
    first cut alone, to name the crack that does not fit)."""
    _refuse(scene)
    fr = scene.fracture if scene.fracture is not None else FractureSpec()
    around = body_and_material(scene, comm)
    body = around[0]
    size = _tip_mesh(fr, [c.crack for c in scene.cracks])
    alone = [_cut(scene, body, size, i) for i in range(len(scene.cracks))]
    try:
        cuts = cut_mouths(body, [c.crack for c in scene.cracks], size)
    except ParameterError as exc:
        raise _error(scene, exc.key, str(exc), len(scene.cracks) - 1) from None
    pairs = tuple(
        c.face_pair(_pair_name(c.name), "crack_upper", "crack_lower") for c in scene.cracks
    )
    runs = [_surface_run(scene, i, around, cut, size, pairs) for i, cut in enumerate(alone)]
    return runs, cuts


def _pair_name(name: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "_.-" else "_" for ch in name)


def _probe_points(cut: CutBody, h: float) -> np.ndarray:
    """Points ``h`` ahead of the inner 80 % of the front and of its deepest point."""
    p0, p1 = cut.arc.phi_range
    phi = np.linspace(p0 + 0.1 * (p1 - p0), p1 - 0.1 * (p1 - p0), 17)
    phi = np.append(phi, _deepest_parameter(cut))
    return cut.arc.point(phi) + h * cut.arc.normals(phi)


def _check_inside(
    scene: Scene, body: BodySurface, cut: CutBody, ligament: float, i: int = 0
) -> None:
    if not np.all(inside_body(body, _probe_points(cut, ligament))):
        raise _error(
            scene,
            "depth",
            f"the crack's front comes within {ligament:.3g} m of the body's surface (the "
            "integration domain and two front elements): a smaller crack or tip_size",
            i,
        )


# --------------------------------------------------------------------- one solve
def _front_parameters(cut: CutBody, n: int, h: float) -> np.ndarray:
    """The K points: ``n`` equally spaced in φ between φ_s from either end (φ_s = 20° or
    the angle of two and a half front elements, whichever is more) and the deepest."""
    arc = cut.arc
    p0, p1 = arc.phi_range
    ds = 2.5 * h
    phi = np.linspace(p0, p1, 2001)
    s = arc.arc_length(phi) - arc.arc_length(p0)
    end = PHI_CORNER if cut.crack.shape == CORNER else PHI_SURFACE
    margin = max(end, float(np.interp(ds, s, phi) - p0), p1 - float(np.interp(s[-1] - ds, s, phi)))
    deep = _deepest_parameter(cut)
    pts = np.linspace(p0 + margin, p1 - margin, max(n, 2))
    pts = pts[np.abs(pts - deep) > math.radians(0.5)]  # the deepest point once
    return np.sort(np.append(pts, deep))


def _deepest_parameter(cut: CutBody) -> float:
    """φ of the deepest front point (π/2 when c ≥ a, else 0 — the frame's depth axis); of
    a corner crack the point at Newman and Raju's ψ = 45°."""
    c = cut.crack
    if c.shape == CORNER:
        return corner_parameter(cut, 0.25 * math.pi)
    return 0.5 * math.pi if c.half_length >= c.depth else 0.0


def crack_tractions(
    sm: SceneModel, integ: Any, cb: CrackedBody3D, reach: float, back: int = -1
) -> tuple | None:
    """The contact tractions on the faces of the crack (the model's pair ``back`` from
    the end; −1 the last) when it has active nodes, else ``None`` (open: traction-free)."""
    k = len(sm.interfaces) + back
    result = integ.last_contact
    if result is None or int(result.n_active[k]) == 0:
        return None
    ft = face_traction(sm.model.V, sm.interfaces[k], result, k, front_nodes(cb), reach, 6.0)
    return ft.plus, ft.minus


#: the factor the domain's half-length along the front is shortened by while it reaches
#: the surface (down to MIN_DOMAIN_ELEMENTS front elements)
SHORTEN = 0.8


def _front_k(u: Any, block: Any, phi: float, material: Isotropic, dom: tuple, traction):
    """K at ``phi`` with the domain ``dom`` = (r_out, half-length, h_front); where the domain
    reaches the body's surface (a front point near the mouth on a surface oblique to the
    front's end: the tube's end, cut by the plane normal to the front, leans out of the
    body) its half-length is shortened by :data:`SHORTEN` until it does not, down to
    MIN_DOMAIN_ELEMENTS front elements (then the error; collective)."""
    r_out, length, h = dom
    while True:
        try:
            return front_interaction_integral(
                u, block, phi, material, r_out, None, length, face_traction=traction
            )
        except ParameterError as exc:
            if exc.key != "r_out" or SHORTEN * length < MIN_DOMAIN_ELEMENTS * h * (1 - 1e-9):
                raise
            length *= SHORTEN


def evaluate(u: Any, cb: CrackedBody3D, run: SurfaceRun, inc: int, cycles: float, traction):
    """K at the front points (collective)."""
    cut: CutBody = cb.crack
    block = cb.block()
    h, r_out = run.size.h_tip, run.r_out
    records = []
    p0 = cut.arc.phi_range[0]
    for i, phi in enumerate(_front_parameters(cut, run.points, h)):
        length = domain_length(block.front, float(phi), r_out, h)
        k = _front_k(u, block, float(phi), run.material, (r_out, length, h), traction)
        kv = float(equivalent_k(k.K_I, k.K_II, k.K_III))
        kink = float(sigma1_kink(k.K_I, k.K_II, k.K_III)[0][0])
        x, y, z = k.point
        s = float(block.front.arc_length(phi) - block.front.arc_length(p0))
        psi = float(corner_angle(cut, [k.point])[0])  # Newman and Raju's angle
        records.append(
            SurfaceRecord(
                inc,
                cycles,
                cut.crack.depth,
                cut.crack.half_length,
                i,
                math.degrees(phi),
                math.degrees(psi),
                s,
                x,
                y,
                z,
                k.K_I,
                k.K_II,
                k.K_III,
                k.G,
                kv,
                math.degrees(kink),
            )
        )
    return records


def _build(run: SurfaceRun, crack: SurfaceBreakingCrack, comm: MPI.Comm, timer: PhaseTimer):
    """The body meshed with ``crack`` (and its mesh data)."""
    try:
        with timer.phase("mesh_read"):
            cb, md, _ = mesh_body_with_surface_crack(run.body, crack, run.size, comm)
    except (MeshingError, ParameterError) as exc:
        raise _error(run.scene, getattr(exc, "key", "depth"), str(exc)) from None
    return cb, md


def cracked_model(
    scene: Scene,
    faces: list[tuple[CrackedBody3D, str]],
    md: Any,
    groups: dict,
    comm,
    timer: PhaseTimer,
    key: str | None = "depth",
) -> SceneModel:
    """The scene model on the cracked mesh with the cracks' face pairs last (``faces``:
    each crack's view of the mesh and its pair's name; ``scene`` holds those pairs as its
    last contacts: the model is built without them, then the pairs of the faces are
    added); a pair that cannot be built is a :class:`SceneError` on the crack's ``key``."""
    original = dataclasses.replace(scene, contacts=tuple(scene.contacts)[: -len(faces)])
    sm = build_model(original, comm, timer, mesh=(md, groups))
    try:
        with timer.phase("mortar_geometry"):
            for cb, pair in faces:
                sm.interfaces.append(face_interface(sm.model, cb, pair))
    except ContactInputError as exc:
        raise _error(scene, key, str(exc)) from None
    return sm


def check_surface_crack(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> SceneModel:
    """Every check of a surface-crack scene, the cracked mesh and the face pair included
    (nothing written); the scene model on that mesh."""
    if len(scene.cracks) > 1:
        runs, cuts = prepare_several(scene, comm)
        timer = PhaseTimer()
        bodies, md = _build_several(runs, cuts, comm, timer)
        faces = [(cb, _pair_name(r.name)) for cb, r in zip(bodies, runs, strict=True)]
        return cracked_model(runs[0].scene, faces, md, runs[0].groups, comm, timer)
    run = prepare_surface(scene, comm)
    timer = PhaseTimer()
    cb, md = _build(run, run.crack, comm, timer)
    return cracked_model(run.scene, [(cb, _pair_name(run.name))], md, run.groups, comm, timer)


def solve_cracked(
    scene: Scene,
    faces: list[tuple[CrackedBody3D, str]],
    md: Any,
    groups: dict,
    comm,
    timer,
    outdir: Path,
    key: str | None = "depth",
):
    """Solve the analysis of ``scene`` (its last contacts the cracks' face pairs,
    :func:`cracked_model`) on the cracked mesh (collective); the fields and tables of the
    solve go to ``outdir``.  Returns (scene model, integrator, summary of the solve)."""
    sm = cracked_model(scene, faces, md, groups, comm, timer, key)
    nsteps, dt = analysis_steps(scene)
    integ = scene_integrator(scene, sm, dt, False)
    integ.set_initial(None, sm.v0)
    rec = Recorder(scene, sm, integ, comm, Path(outdir), False, None)
    counters = RunCounters()
    hooks = MechanicsSteps(integ, rec, timer, scene.output.fields_every, counters, dt, None)
    end = run_steps(hooks, 1, nsteps, progress_bar(comm, scene.name, nsteps, 0, False))
    info = summary_header(scene, sm, integ, dt)
    info.update(run_info(scene, sm, integ, counters, False, 0.0, time.perf_counter()))
    summary = finish_run(scene, sm, rec, timer, comm, end.status, end.message, info)
    return sm, integ, summary


def _solve(run: SurfaceRun, crack: SurfaceBreakingCrack, comm, timer, outdir: Path, inc: int):
    """Mesh the body with ``crack`` and solve the analysis (collective); the fields and
    tables of the solve go to ``outdir/increment<inc>``."""
    cb, md = _build(run, crack, comm, timer)
    out = Path(outdir) / f"increment{inc}"
    faces = [(cb, _pair_name(run.name))]
    sm, integ, summary = solve_cracked(run.scene, faces, md, run.groups, comm, timer, out)
    return cb, sm, integ, summary


# -------------------------------------------------------------------------- growth
@dataclasses.dataclass
class Growth:
    """The state of a growing crack between solves."""

    crack: SurfaceBreakingCrack
    increments: int = 0
    cycles: float = 0.0
    status: str | None = None
    fatigue: FatigueProgress = dataclasses.field(default_factory=FatigueProgress)
    history: list[dict[str, float]] = dataclasses.field(default_factory=list)
    rows: int = 0  # fracture.csv rows written
    first: int = 0  # the first increment (> 0: continues another run, SurfaceStart)
    cycles0: float = 0.0  # the cycles at the first increment
    max_kink: dict[str, Any] | None = None  # the largest |kink| of a growing point so far
    out_of_plane: dict[str, Any] | None = None  # where |kink| first exceeded the limit
    final_block: dict[str, float] | None = None  # the block that carried it through
    shortfall: float = 0.0  # Σ (da_max − the halved blocks' da) (end_halvings)
    halved: int = 0  # blocks shorter than da_max solved before the final one

    def state(self, initial: SurfaceBreakingCrack) -> dict[str, Any]:
        """What a checkpoint stores (JSON; :mod:`~bonecontact.runners.growth_state3d`)."""
        return {
            "kind": "surface_crack",
            "initial": dataclasses.asdict(initial),
            "crack": dataclasses.asdict(self.crack),
            "cycles": self.cycles,
            "fatigue": self.fatigue.state(),
            "history": self.history,
            "rows": self.rows,
            "max_kink": self.max_kink,
            "out_of_plane": self.out_of_plane,
            "shortfall": self.shortfall,
            "halved": self.halved,
        }

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> Growth:
        """The growth a checkpoint stored (its ``increment`` the next to solve)."""
        c = state["crack"]
        vec = {
            k: None if c[k] is None else tuple(map(float, c[k]))
            for k in ("centre", "normal", "axis")
        }
        crack = SurfaceBreakingCrack(
            vec["centre"],
            vec["normal"],
            float(c["depth"]),
            float(c["half_length"]),
            vec["axis"],
            c.get("shape", "semi_elliptical"),
        )
        return cls(
            crack,
            int(state["increment"]),
            float(state["cycles"]),
            None,
            FatigueProgress.from_state(state["fatigue"]),
            list(state["history"]),
            int(state["rows"]),
            max_kink=state.get("max_kink"),
            out_of_plane=state.get("out_of_plane"),
            shortfall=float(state.get("shortfall", 0.0)),
            halved=int(state.get("halved", 0)),
        )


def _growth_points(records: list[SurfaceRecord], cut: CutBody) -> list[int]:
    """The rows of the three growth points: the φ₀ end, the deepest point, the φ₁ end; of
    a corner crack the end nearer the face of c, the point at ψ = 45°, the end nearer the
    face of a."""
    deep = math.degrees(_deepest_parameter(cut))
    i = int(np.argmin([abs(r.phi_deg - deep) for r in records]))
    ends = [0, len(records) - 1]
    if cut.crack.shape == CORNER:  # by Newman and Raju's ψ: 0 on the face of c
        ends = ends if records[0].psi_deg <= records[-1].psi_deg else ends[::-1]
    return [ends[0], i, ends[1]]


def _history_k(records: list[SurfaceRecord], cut: CutBody, kv: np.ndarray) -> dict[str, float]:
    """The K_V entries of an increment's ``history`` (``kv``: :func:`_three_points`).  A
    semi-elliptical crack: ``K_V_surface`` (the larger at the two points φ_s from the
    surface) and ``K_V_deepest``.  A corner crack: ``K_V_c`` and ``K_V_a`` at the end points
    nearest the face of c and of a (they grow c and a), their Newman–Raju angles
    ``psi_c_deg`` and ``psi_a_deg``, and ``K_V_45`` at ψ = 45° (no growth weight)."""
    if cut.crack.shape != CORNER:
        return {"K_V_surface": float(max(kv[0], kv[2])), "K_V_deepest": float(kv[1])}
    i_c, _, i_a = _growth_points(records, cut)
    return {
        "K_V_c": float(kv[0]),
        "K_V_a": float(kv[2]),
        "K_V_45": float(kv[1]),
        "psi_c_deg": records[i_c].psi_deg,
        "psi_a_deg": records[i_a].psi_deg,
    }


def _three_points(records: list[SurfaceRecord], cut: CutBody) -> np.ndarray:
    """K_V at (the φ₀ end, the deepest point, the φ₁ end)."""
    return np.array([records[i].K_V for i in _growth_points(records, cut)])


class PlanarModelWarning(UserWarning):
    """A crack grown in its plane whose σ₁′ kink at a growing point exceeds ``[fracture]
    max_kink_deg``: a real crack would leave the plane there (summary.json
    ``fracture.growth.out_of_plane``)."""


def check_kink(
    run: SurfaceRun, g: Growth, records: list[SurfaceRecord], cut: CutBody, rates: np.ndarray
) -> bool:
    """Record the largest |σ₁′ kink| of the growing points of this solve — the three
    growth points whose weight (``rates``, :func:`growth_weights`) is above 0 — in
    ``g.max_kink`` and, the first time it exceeds ``[fracture] max_kink_deg``, that point
    in ``g.out_of_plane``.  Returns whether that happened at this solve.  The same on
    every rank (K are)."""
    limit = float(run.fracture.max_kink_deg)
    growing = [i for i, w in zip(_growth_points(records, cut), rates, strict=True) if w > 0.0]
    if not growing:
        return False
    top = max(growing, key=lambda i: (abs(records[i].kink_deg), -i))
    r = records[top]
    if g.max_kink is None or abs(r.kink_deg) > g.max_kink["kink_deg"]:
        g.max_kink = {
            "kink_deg": abs(r.kink_deg),
            "increment": r.increment,
            "point": r.point,
            "phi_deg": r.phi_deg,
            "psi_deg": r.psi_deg,
        }
    if g.out_of_plane is not None or not abs(r.kink_deg) > limit:
        return False
    g.out_of_plane = {
        "increment": r.increment,
        "point": r.point,
        "phi_deg": r.phi_deg,
        "psi_deg": r.psi_deg,
        "kink_deg": r.kink_deg,
        "limit_deg": limit,
    }
    return True


def out_of_plane_text(run: SurfaceRun, where: dict[str, Any]) -> str:
    """The message of ``g.out_of_plane``: the crack, the increment, the point, the angle."""
    return (
        f"crack {run.name!r}, increment {where['increment']}: the sigma1' kink angle "
        f"{where['kink_deg']:.1f} deg at growing front point {where['point']} (phi "
        f"{where['phi_deg']:.1f} deg) exceeds [fracture] max_kink_deg = "
        f"{where['limit_deg']:g} deg: a real crack would leave its plane here, the planar "
        "model is outside its validity from this increment on"
    )


def _rates(run: SurfaceRun, kv: np.ndarray) -> np.ndarray:
    """The growth weights of the three points (:func:`growth_weights`); a corner crack's
    point at ψ = 45° has none (its two semi-axes grow from the points near the faces)."""
    rates = growth_weights(kv, run.fracture.fatigue, run.K_Ic)
    if run.crack.shape == CORNER:
        rates[1] = 0.0
    return rates


def _stop(run: SurfaceRun, g: Growth, kv: np.ndarray, rates: np.ndarray) -> str | None:
    fat = run.fracture.fatigue
    most = fat.max_blocks if fat is not None else run.fracture.max_increments
    lead = float(rates.max(initial=0.0))
    return growth_stop(float(kv.max()), lead, fat, run.K_Ic, g.increments, most)


def _grown(
    crack: SurfaceBreakingCrack, step: float, rates: np.ndarray, lead: float | None = None
) -> SurfaceBreakingCrack:
    """The crack with its three points advanced: the fastest by ``step``.  The advances
    are rounded to a grid of about 1e-6 of the step
    (:func:`~bonecontact.common.geometry.on_advance_grid`): they come from K whose
    round-off differs with the number of ranks, and gmsh turns a crack 1e-19 m larger into
    another mesh.  ``lead``: the weight that advances by ``step`` (default the largest of
    ``rates``; several cracks: the largest of them all)."""
    d = on_advance_grid(step * rates / (rates.max() if lead is None else lead), step)
    if crack.shape == CORNER:  # c from the point near its face, a from the one near a's
        return crack.grown(crack.depth + d[2], crack.half_length + d[0])
    return crack.grown(
        crack.depth + d[1], crack.half_length + 0.5 * (d[0] + d[2]), 0.5 * (d[0] - d[2])
    )


def breaks_through(run: SurfaceRun, crack: SurfaceBreakingCrack) -> bool:
    """Whether the grown ``crack`` has broken through the body (``through``): a point
    :attr:`SurfaceRun.ligament` ahead of its front — the inner 80 % of the front and the
    deepest point — lies outside the body (the front leaves it, or less ligament is left
    than the integration domain and two front elements need).  The front is the arc of
    its mouth cut into the body's surface; when that cut fails, the arc of the crack's
    ellipse inside the body through the deepest point (:func:`_sampled_probes`).

    Raises
    ------
    RunError
        The mouth cannot be cut and the front stays inside the body with the ligament to
        spare: not a break-through but a geometry failure (the message names the crack,
        its depth and half-length and why the cut failed).
    """
    try:
        cut = cut_mouth(run.body, crack, run.size)
    except ParameterError as exc:
        probes = _sampled_probes(run, crack)
        if probes is None or not bool(np.all(inside_body(run.body, probes))):
            return True
        raise RunError(
            f"crack {run.name!r}: the grown crack (depth {crack.depth:.6g} m, half-length "
            f"{crack.half_length:.6g} m, centre {_xyz(crack.centre)}) cannot be cut into the "
            f"body's surface ({exc}); its front stays inside the body with the ligament of "
            f"{run.ligament:.3g} m to spare, so it has not broken through"
        ) from None
    return not bool(np.all(inside_body(run.body, _probe_points(cut, run.ligament))))


def _xyz(p: Any) -> str:
    return "(" + ", ".join(f"{float(v):.6g}" for v in p) + ")"


def _sampled_probes(run: SurfaceRun, crack: SurfaceBreakingCrack) -> np.ndarray | None:
    """Without a cut mouth: the probe points of :func:`breaks_through` on the crack's
    ellipse x(φ) = C + c cos φ t + a sin φ d (t the crack's ``axis``, d = n × t its inward
    depth direction, as :func:`~bonecontact.fracture.surface_body3d.crack_frame` sets them),
    the front being the arc through the deepest point (φ = π/2; of a corner crack its
    point at ψ = 45°, φ = π/4 with d the side of n × t into the body) inside the body,
    found on 720 points; ``None`` when that point lies outside the body."""
    n, t = np.asarray(crack.normal, dtype=float), np.asarray(crack.axis, dtype=float)
    d, C = np.cross(n, t), np.asarray(crack.centre, dtype=float)
    a, c = crack.depth, crack.half_length
    top = 0.5 * math.pi
    if crack.shape == CORNER:  # from its point at ψ = 45°, d into the body along a's face
        top = 0.25 * math.pi
        d = d if inside_body(run.body, C + 0.35 * (c * t + a * d))[0] else -d

    def ellipse(phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        cs, sn = np.cos(phi)[:, None], np.sin(phi)[:, None]
        normal = a * cs * t + c * sn * d
        return C + c * cs * t + a * sn * d, normal / np.linalg.norm(normal, axis=1)[:, None]

    N = 720
    phi = top + 2.0 * math.pi * (np.arange(N) - N // 2) / N  # φ = top at N // 2
    inside = inside_body(run.body, ellipse(phi)[0])
    if not inside[N // 2]:
        return None
    lo, hi = N // 2, N // 2
    while lo > 0 and inside[lo - 1]:
        lo -= 1
    while hi < N - 1 and inside[hi + 1]:
        hi += 1
    p0, p1 = phi[lo], phi[hi]
    probe = np.append(np.linspace(p0 + 0.1 * (p1 - p0), p1 - 0.1 * (p1 - p0), 17), top)
    x, e1 = ellipse(probe)
    return x + run.ligament * e1


def _advance(run: SurfaceRun, g: Growth, records: list[SurfaceRecord], cut: CutBody) -> str | None:
    """One block end (fatigue) or increment end (one load): the cycles, the stop, the
    next crack.  Returns the stop (``None``: grow)."""
    kv = _three_points(records, cut)
    rates = _rates(run, kv)
    fat = run.fracture.fatigue
    if fat is not None:
        growth = (g.increments - g.first) * fat.da_max - g.shortfall
        g.cycles = g.cycles0 + g.fatigue.add_end(growth, float(rates.max(initial=0.0)))
    g.history.append(
        {
            "increment": g.increments,
            "cycles": g.cycles,
            "depth": g.crack.depth,
            "half_length": g.crack.half_length,
            **_history_k(records, cut, kv),
        }
    )
    stop = _stop(run, g, kv, rates)
    flagged = check_kink(run, g, records, cut, rates)
    if stop is not None:
        return stop
    if flagged and run.fracture.stop_out_of_plane:
        return "out_of_plane"
    step = fat.da_max if fat is not None else run.fracture.increment
    nxt = _grown(g.crack, step, rates)
    if breaks_through(run, nxt):
        if fat is None:
            return "through"
        halved = halved_block(run, g.crack, step, rates, fat.end_halvings)
        if halved is None:  # the last block at the rate of its start
            da = step / 2.0**fat.end_halvings
            g.final_block = final_block(g.cycles, da, float(rates.max()), g.fatigue)
            g.cycles += g.final_block["cycles"]
            return "through"
        nxt, g.shortfall = _grown(g.crack, halved, rates), g.shortfall + (step - halved)
        g.halved += 1
    g.crack, g.increments = nxt, g.increments + 1
    return None


def halved_block(
    run: SurfaceRun, crack: SurfaceBreakingCrack, step: float, rates: np.ndarray, most: int
) -> float | None:
    """The longest of the blocks ``step``/2, …, ``step``/2^``most`` whose grown crack has
    not broken through (:func:`breaks_through`), solved before the final block
    (``[fracture.fatigue] end_halvings``); ``None`` when none fits (or ``most`` is 0): the
    final block, ``step``/2^``most``, carries the crack through."""
    for k in range(1, most + 1):
        da = step / 2.0**k
        if not breaks_through(run, _grown(crack, da, rates)):
            return da
    return None


def _fragments(cb: CrackedBody3D) -> list[dict[str, Any]]:
    return fragments(cb.mesh, cb.crack.crack.centre, cb.crack.normal)


def fragments(msh: Any, centre: Any, normal: Any) -> list[dict[str, Any]]:
    """Volumes of the body on either side of the plane through ``centre`` normal to
    ``normal`` (collective)."""
    n = np.asarray(normal, dtype=float)
    c = np.asarray(centre, dtype=float)
    return side_volumes(msh, lambda x: np.sign((x - c) @ n))


def surface_fragments(msh: Any, triangles: Any) -> list[dict[str, Any]]:
    """Volumes of the body on either side of a triangulated crack surface continued by its
    border triangles' planes (collective): a cell is on the side of the plane of the
    triangle nearest its midpoint, ``+normal`` where that triangle's corners run
    counter-clockwise.  The crack as grown, not its first plane: beyond the front — the
    ligament the crack has not yet cut — the last strip's plane."""
    T = np.asarray(triangles, dtype=float)
    n = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])

    def side(x: np.ndarray) -> np.ndarray:
        if len(x) == 0:
            return np.zeros(0)
        _, k = nearest_triangle(x, T)
        return np.sign(np.einsum("ij,ij->i", x - T[k, 0], n[k]))

    return side_volumes(msh, side)


def patch_triangles(points: Any, patches: Any) -> np.ndarray:
    """The triangles (k, 3, 3) of a grown crack's planar convex patches, fanned from each
    patch's first corner (the patches' counter-clockwise order kept)."""
    X = np.asarray(points, dtype=float)
    tris = [(p[0], p[i], p[i + 1]) for p in patches for i in range(1, len(p) - 1)]
    return X[np.asarray(tris, dtype=np.int64)]


def side_volumes(msh: Any, side: Any) -> list[dict[str, Any]]:
    """Volumes of the cells with ``side(midpoints)`` +1 (``+normal``) and −1 (``-normal``),
    summed over the ranks (collective)."""
    tdim = msh.topology.dim
    cells = np.arange(msh.topology.index_map(tdim).size_local, dtype=np.int32)
    sgn = side(mesh.compute_midpoints(msh, tdim, cells))
    V = fem.functionspace(msh, ("DG", 0))
    vol = fem.assemble_vector(fem.form(ufl_volume(V))).array[: len(cells)]
    out = []
    for name, s in (("+normal", 1.0), ("-normal", -1.0)):
        out.append({"side": name, "volume": float(msh.comm.allreduce(vol[sgn == s].sum()))})
    return out


def ufl_volume(V: Any) -> Any:
    """The form ∫ v dx of the cell volumes."""
    return ufl.TestFunction(V) * ufl.dx


def write_crack_surface(path: Path, cut: CutBody) -> None:
    """The crack surface as a legacy VTK polygon (the mouth, then the front back)."""
    p0, p1 = cut.arc.phi_range
    front = cut.arc.point(np.linspace(p1, p0, 65)[1:-1])
    pts = np.concatenate([cut.nodes[list(cut.mouth)], front])
    n = len(pts)
    lines = ["# vtk DataFile Version 3.0", "crack surface", "ASCII", "DATASET POLYDATA"]
    lines += [f"POINTS {n} double"] + [" ".join(repr(float(c)) for c in p) for p in pts]
    lines += [f"POLYGONS 1 {n + 1}", " ".join(map(str, [n, *range(n)]))]
    Path(path).write_text("\n".join(lines) + "\n")


@dataclasses.dataclass(frozen=True)
class SurfaceStart:
    """Where the growth of a surface crack that continues another run starts: its first
    increment's number and the cycles there (the crack is the scene's)."""

    increment: int
    cycles: float = 0.0


def _start(run: SurfaceRun, comm: MPI.Comm, outdir: Path, restart, start=None) -> Growth:
    """A fresh growth (from ``start``: :class:`SurfaceStart`), or the one of the
    checkpoint ``restart`` (fracture.csv cut to its rows)."""
    if start is not None:
        if restart:
            raise ValueError("a surface crack that continues another run cannot restart")
        return Growth(
            run.crack, start.increment, start.cycles, first=start.increment, cycles0=start.cycles
        )
    if not restart:
        return Growth(run.crack)
    initial = dataclasses.asdict(run.crack)
    state = find_growth_state(
        comm, outdir, restart, "surface_crack", initial, run.crack.half_length
    )
    return Growth.from_state(state)


def _grow(run: SurfaceRun, g: Growth, comm, timer, outdir: Path, table: RecordTable):
    """Solve, evaluate and advance until a stop; returns (status, message, fragments).
    A solve that does not converge, K that cannot be evaluated at a front point, a grown
    crack that cannot be cut (:func:`breaks_through`) or meshed end the run ``"failed"``
    with the message, the increments before written (growth status ``failed`` and
    fracture.csv rows marked so when the last solve's K were written)."""
    fr = run.fracture
    grows = fr.propagate or fr.fatigue is not None
    every = run.scene.output.checkpoint_every
    while True:
        try:
            cb, sm, integ, summary = _solve(run, g.crack, comm, timer, outdir, g.increments)
        except SceneError as exc:  # the given crack's is an input error, a grown one's not
            if g.increments == g.first:
                raise
            g.status = "failed"
            return "failed", f"{_where(run, g)}: the grown crack cannot be meshed: {exc}", None
        if summary["status"] != "converged":
            return summary["status"], summary.get("message"), None
        try:
            with timer.phase("fracture"):
                traction = crack_tractions(sm, integ, cb, run.r_out)
                records = evaluate(integ.u, cb, run, g.increments, g.cycles, traction)
        except (ParameterError, RunError) as exc:
            integ.destroy()
            g.status = "failed"
            return "failed", f"{_where(run, g)}: no K at the front: {exc}", None
        failure = None
        try:
            stop = _advance(run, g, records, cb.crack) if grows else "stationary"
        except RunError as exc:
            failure = f"{exc}; the run stops after increment {g.increments} (written)"
            stop = "failed"
        oop = g.out_of_plane
        if comm.rank == 0 and oop is not None and oop["increment"] == records[0].increment:
            warnings.warn(out_of_plane_text(run, oop), PlanarModelWarning, stacklevel=2)
        mark = stop or "grows"
        table.rows([dataclasses.replace(r, cycles=g.cycles, status=mark) for r in records])
        g.rows += len(records)
        if comm.rank == 0:
            write_crack_surface(outdir / f"crack_surface_{records[0].increment}.vtk", cb.crack)
            write_front(outdir / f"crack_front_{records[0].increment}.vtk", records)
        integ.destroy()
        if stop is not None:
            g.status = stop
            frags = _fragments(cb) if stop in ("fractured", "through") else None
            if failure is not None:
                return "failed", failure, None
            note = out_of_plane_text(run, g.out_of_plane) if stop == "out_of_plane" else None
            return "converged", note or final_block_note(comm, g.final_block), frags
        if every > 0 and g.first == 0 and g.increments % every == 0:
            with timer.phase("checkpoint"):
                save_growth_state(comm, outdir, g.increments, g.state(run.crack))


def _where(run: SurfaceRun, g: Growth) -> str:
    """The crack and increment a failure message names."""
    c = g.crack
    return (
        f"crack {run.name!r}, increment {g.increments} (depth {c.depth:.6g} m, half-length "
        f"{c.half_length:.6g} m)"
    )


def planar_validity(g: Growth, fr: FractureSpec) -> dict[str, Any]:
    """The entries of ``fracture.growth`` on the validity of the planar model: the
    largest |kink| of a growing point (``max_kink_deg``, ``max_kink_increment``,
    ``max_kink_point``, ``max_kink_phi_deg``, ``max_kink_psi_deg``; ``null`` when no
    point grew), the limit
    (``kink_limit_deg``) and ``out_of_plane`` (``null``, or the increment, point, φ, kink
    and limit where |kink| first exceeded it)."""
    mk = g.max_kink or {}
    return {
        "max_kink_deg": mk.get("kink_deg"),
        "max_kink_increment": mk.get("increment"),
        "max_kink_point": mk.get("point"),
        "max_kink_phi_deg": mk.get("phi_deg"),
        "max_kink_psi_deg": mk.get("psi_deg"),
        "kink_limit_deg": float(fr.max_kink_deg),
        "out_of_plane": g.out_of_plane,
    }


def run_surface_crack(
    scene: Scene,
    comm: MPI.Comm = MPI.COMM_WORLD,
    output: Path | None = None,
    progress: bool = True,
    restart: str | Path | bool | None = None,
    start: SurfaceStart | None = None,
) -> RunResult:
    """Validate, build and run a 3D scene with a surface crack (module docstring);
    ``restart``: continue from the newest (``True``) or the named growth checkpoint
    (:mod:`~bonecontact.runners.growth_state3d`); ``start``: the growth continues another
    run (its increments numbered and its cycles counted on from there; no restart)."""
    t_start = time.perf_counter()
    if len(scene.cracks) > 1:
        if restart or start is not None:
            raise ValueError("several surface cracks write no checkpoints: they cannot restart")
        return run_several_surface(scene, comm, output)
    timer = PhaseTimer()
    run = prepare_surface(scene, comm)
    outdir = Path(output) if output is not None else scene.output.directory
    if comm.rank == 0:
        outdir.mkdir(parents=True, exist_ok=True)
    fr = run.fracture
    grows = fr.propagate or fr.fatigue is not None
    g = _start(run, comm, outdir, restart, start)
    table = RecordTable(comm, outdir / "fracture.csv", SURFACE_COLUMNS, append=bool(restart))
    try:
        status, message, fragments = _grow(run, g, comm, timer, outdir, table)
    finally:
        table.close()
    info = {
        "wall_time_s": time.perf_counter() - t_start,
        "fracture": {
            "crack": {
                "name": run.name,
                "shape": run.crack.shape,
                "centre": list(run.crack.centre),
                "normal": list(run.crack.normal),
                "axis": list(run.crack.axis),
                "front_size": run.size.h_tip,
                "final": dataclasses.asdict(g.crack),
            },
            "growth": None
            if not grows
            else {
                "rule": "fatigue" if fr.fatigue is not None else "propagate",
                "status": g.status,
                "increments": g.increments,
                "cycles": g.cycles if fr.fatigue is not None else None,
                "K_Ic": run.K_Ic,
                "history": g.history,
                "fractured": g.status in ("fractured", "through"),
                "fragments": fragments,
                "final_block": g.final_block,
                "halved_blocks": g.halved,
                **planar_validity(g, fr),
            },
        },
        "phases_s": timer.summary(comm),
    }
    if message is not None:
        info["message"] = message
    summary = run_summary(scene.name, status, comm, info["wall_time_s"], **info)
    write_summary(comm, outdir, summary)
    return RunResult(status, summary, None, outdir)


# ------------------------------------------------------------ several surface cracks
#: Columns of ``fracture.csv`` of several surface cracks: :data:`SURFACE_COLUMNS` with the
#: crack's name after ``cycles``.
SEVERAL_COLUMNS = (*SURFACE_COLUMNS[:2], "crack", *SURFACE_COLUMNS[2:])


@dataclasses.dataclass(frozen=True)
class NamedRecord:
    """A row of ``fracture.csv`` of several cracks (:data:`SEVERAL_COLUMNS`)."""

    record: SurfaceRecord
    crack: str

    def row(self) -> list[Any]:
        r = self.record.row()
        return [*r[:2], self.crack, *r[2:]]


def _build_several(runs: list[SurfaceRun], cuts: list[CutBody], comm, timer: PhaseTimer):
    """The body meshed with every crack: each crack's view of the mesh, the mesh data."""
    run = runs[0]
    try:
        with timer.phase("mesh_read"):
            bodies, md, _ = mesh_body_with_surface_cracks(
                run.body, [c.crack for c in cuts], run.size, comm
            )
    except (MeshingError, ParameterError) as exc:
        raise _error(run.scene, getattr(exc, "key", "depth"), str(exc), len(runs) - 1) from None
    return bodies, md


def _crack_entry(run: SurfaceRun, records: list[SurfaceRecord], cut: CutBody) -> dict:
    """A crack's entry of ``fracture.cracks`` in summary.json: its frame and front size,
    and K at its deepest point (of a corner crack at ψ = 45°)."""
    deep = math.degrees(_deepest_parameter(cut))
    r = min(records, key=lambda q: abs(q.phi_deg - deep))
    return {
        "name": run.name,
        "shape": cut.crack.shape,
        "centre": list(cut.crack.centre),
        "normal": list(cut.crack.normal),
        "axis": list(cut.crack.axis),
        "front_size": run.size.h_tip,
        "final": dataclasses.asdict(cut.crack),
        "deepest": {"phi_deg": r.phi_deg, "K_I": r.K_I, "K_II": r.K_II, "K_III": r.K_III},
        "K_I_max": max(q.K_I for q in records),
    }


@dataclasses.dataclass
class SeveralGrowth:
    """The state of several growing surface cracks between solves."""

    cracks: list[SurfaceBreakingCrack]
    kinks: list[Growth]  # each crack's largest kink and out_of_plane (check_kink)
    increments: int = 0
    cycles: float = 0.0
    status: str | None = None
    fatigue: FatigueProgress = dataclasses.field(default_factory=FatigueProgress)
    history: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    final_block: dict[str, float] | None = None
    shortfall: float = 0.0  # Σ (da_max − the halved blocks' da) (end_halvings)
    halved: int = 0  # blocks shorter than da_max solved before the final one
    at: int = 0  # the crack that stopped the growth (through, joined: the first of the two)
    other: int | None = None  # joined: the second


def run_several_surface(
    scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD, output: Path | None = None
) -> RunResult:
    """Several surface cracks in one body: their mouths cut into its surface, meshed
    together, one solve with every crack's face pair, K along each front (``fracture.csv``
    with the crack's name, :data:`SEVERAL_COLUMNS`; summary.json ``fracture.cracks``, one
    entry per crack).  With ``propagate`` or ``[fracture.fatigue]`` every crack grows as a
    single one does, in one block: the fastest point of all the cracks advances by the
    increment (``da_max``), the others in proportion to their weights; it stops as a
    single crack does, ``through`` when any crack's grown front would leave the body and
    ``joined`` when two grown cracks would meet or come within a ligament of each other
    (:func:`_would_meet`)."""
    t_start = time.perf_counter()
    timer = PhaseTimer()
    runs, cuts = prepare_several(scene, comm)
    outdir = Path(output) if output is not None else scene.output.directory
    if comm.rank == 0:
        outdir.mkdir(parents=True, exist_ok=True)
    fr = runs[0].fracture
    grows = fr.propagate or fr.fatigue is not None
    g = SeveralGrowth([r.crack for r in runs], [Growth(r.crack) for r in runs])
    table = RecordTable(comm, outdir / "fracture.csv", SEVERAL_COLUMNS)
    try:
        status, message, entries, frags = _grow_several(runs, cuts, g, comm, timer, outdir, table)
    finally:
        table.close()
    growth = _several_growth(runs, g, frags) if grows else None
    info: dict[str, Any] = {
        "wall_time_s": time.perf_counter() - t_start,
        "fracture": {"cracks": entries, "growth": growth},
        "phases_s": timer.summary(comm),
    }
    if message is not None:
        info["message"] = message
    summary = run_summary(scene.name, status, comm, info["wall_time_s"], **info)
    write_summary(comm, outdir, summary)
    return RunResult(status, summary, None, outdir)


def _several_growth(runs: list[SurfaceRun], g: SeveralGrowth, frags) -> dict[str, Any]:
    """``fracture.growth`` of several cracks."""
    fr = runs[0].fracture
    stopped = g.status in ("through", "joined", "out_of_plane")
    return {
        "rule": "fatigue" if fr.fatigue is not None else "propagate",
        "status": g.status,
        "increments": g.increments,
        "cycles": g.cycles if fr.fatigue is not None else None,
        "K_Ic": runs[0].K_Ic,
        "history": g.history,
        "fractured": g.status in ("fractured", "through"),
        "fragments": frags,
        "final_block": g.final_block,
        "halved_blocks": g.halved,
        "crack": runs[g.at].name if stopped else None,
        "other": runs[g.other].name if g.other is not None else None,
        "planar_validity": {
            r.name: planar_validity(k, fr) for r, k in zip(runs, g.kinks, strict=True)
        },
    }


def _grow_several(runs, cuts, g: SeveralGrowth, comm, timer, outdir: Path, table: RecordTable):
    """Solve, evaluate and advance until a stop; returns (status, message, the summary's
    crack entries, fragments)."""
    fr = runs[0].fracture
    grows = fr.propagate or fr.fatigue is not None
    entries: list[dict] = []
    while True:
        try:
            if g.increments > 0:
                cuts = cut_mouths(runs[0].body, g.cracks, runs[0].size)
            bodies, md = _build_several(runs, cuts, comm, timer)
        except (ParameterError, SceneError) as exc:
            if g.increments == 0:
                raise
            g.status = "failed"
            return "failed", f"increment {g.increments}: the grown cracks: {exc}", entries, None
        faces = [(cb, _pair_name(r.name)) for cb, r in zip(bodies, runs, strict=True)]
        out = outdir / f"increment{g.increments}"
        sm, integ, solve = solve_cracked(runs[0].scene, faces, md, runs[0].groups, comm, timer, out)
        if solve["status"] != "converged":
            integ.destroy()
            return solve["status"], solve.get("message"), entries, None
        try:
            recs = _evaluate_several(runs, bodies, sm, integ, timer, g)
        except (ParameterError, RunError) as exc:
            g.status = "failed"
            return "failed", f"increment {g.increments}: no K at the front: {exc}", entries, None
        finally:
            integ.destroy()
        inc = g.increments
        cut_of = [cb.crack for cb in bodies]
        stop = _advance_several(runs, g, recs, cut_of) if grows else "stationary"
        _warn_out_of_plane(runs, g, inc, comm)
        for run, records in zip(runs, recs, strict=True):
            rows = [
                dataclasses.replace(r, cycles=g.cycles, status=stop or "grows") for r in records
            ]
            table.rows([NamedRecord(r, run.name) for r in rows])
        entries = [_crack_entry(r, q, c) for r, q, c in zip(runs, recs, cut_of, strict=True)]
        if comm.rank == 0:
            for run, records, cut in zip(runs, recs, cut_of, strict=True):
                tag = _pair_name(run.name)
                write_crack_surface(outdir / f"crack_surface_{inc}_{tag}.vtk", cut)
                write_front(outdir / f"crack_front_{inc}_{tag}.vtk", records)
        if stop is not None:
            g.status = stop
            frags = _fragments(bodies[g.at]) if stop in ("fractured", "through") else None
            return "converged", final_block_note(comm, g.final_block), entries, frags


def _warn_out_of_plane(runs, g: SeveralGrowth, inc: int, comm: MPI.Comm) -> None:
    """A :class:`PlanarModelWarning` (rank 0) for every crack whose kink first exceeded
    ``max_kink_deg`` at the increment ``inc``."""
    for run, kg in zip(runs, g.kinks, strict=True):
        oop = kg.out_of_plane
        if comm.rank == 0 and oop is not None and oop["increment"] == inc:
            warnings.warn(out_of_plane_text(run, oop), PlanarModelWarning, stacklevel=3)


def _evaluate_several(runs, bodies, sm, integ, timer, g: SeveralGrowth) -> list[list]:
    """K along every crack's front (its own face pair's tractions)."""
    out = []
    n = len(runs)
    for k, (run, cb) in enumerate(zip(runs, bodies, strict=True)):
        with timer.phase("fracture"):
            traction = crack_tractions(sm, integ, cb, run.r_out, back=k - n)
            out.append(evaluate(integ.u, cb, run, g.increments, g.cycles, traction))
    return out


def _advance_several(
    runs: list[SurfaceRun], g: SeveralGrowth, recs: list[list[SurfaceRecord]], cuts
) -> str | None:
    """One block (increment) end of every crack: the cycles, the stop, the next cracks;
    the fastest point of all the cracks sets the block.  Returns the stop (``None``:
    grow)."""
    fr = runs[0].fracture
    fat = fr.fatigue
    kv = [_three_points(r, c) for r, c in zip(recs, cuts, strict=True)]
    rates = _several_rates(runs, kv)
    lead = max(float(r.max(initial=0.0)) for r in rates)
    if fat is not None:
        g.cycles = g.fatigue.add_end(g.increments * fat.da_max - g.shortfall, lead)
    g.history.append(_several_history(runs, g, recs, cuts, kv))
    most = fat.max_blocks if fat is not None else fr.max_increments
    k_max = max(float(k.max()) for k in kv)
    stop = growth_stop(k_max, lead, fat, runs[0].K_Ic, g.increments, most)
    flagged = [
        check_kink(run, kg, r, cut, w)
        for run, kg, r, cut, w in zip(runs, g.kinks, recs, cuts, rates, strict=True)
    ]
    if stop is not None:
        return stop
    if any(flagged) and fr.stop_out_of_plane:
        g.at = flagged.index(True)
        return "out_of_plane"
    step = fat.da_max if fat is not None else fr.increment
    halvings = fat.end_halvings if fat is not None else 0
    for k in range(halvings + 1):  # end_halvings: the longest block that breaks none through
        da = step / 2.0**k
        nxt = [_grown(c, da, w, lead) for c, w in zip(g.cracks, rates, strict=True)]
        if k == halvings or not any(
            breaks_through(run, c) for run, c in zip(runs, nxt, strict=True)
        ):
            break
    stop = _several_stop(runs, g, nxt, da, lead)
    if stop is None and da < step:
        g.shortfall, g.halved = g.shortfall + (step - da), g.halved + 1
    return stop


def _several_stop(runs, g: SeveralGrowth, nxt, step: float, lead: float) -> str | None:
    """``through`` when a grown crack leaves the body (fatigue: the final block at the
    leading rate), ``joined`` when two grown cracks would meet, else the next cracks."""
    fat = runs[0].fracture.fatigue
    for k, (run, c) in enumerate(zip(runs, nxt, strict=True)):
        if breaks_through(run, c):
            g.at = k
            if fat is not None:
                g.final_block = final_block(g.cycles, step, lead, g.fatigue)
                g.cycles += g.final_block["cycles"]
            return "through"
    for i in range(len(nxt)):
        for j in range(i + 1, len(nxt)):
            if _would_meet(runs[i], runs[j], nxt[i], nxt[j]):
                g.at, g.other = i, j
                return "joined"
    g.cracks, g.increments = nxt, g.increments + 1
    return None


def _would_meet(run_i: SurfaceRun, run_j: SurfaceRun, a, b) -> bool:
    """Whether two grown cracks meet or come within a ligament (the integration domain
    and two front elements, :attr:`SurfaceRun.ligament`) of each other: their balls of
    radius max(depth, half_length) about their centres, widened by the larger ligament,
    touch (:func:`~bonecontact.scene.fracture_tables.surface_cracks_meet`: exact for
    coplanar cracks side by side along the surface with c ≥ a, conservative else)."""
    lig = max(run_i.ligament, run_j.ligament)
    return surface_cracks_meet(a, b, lig)


def _several_history(runs, g: SeveralGrowth, recs, cuts, kv) -> dict[str, Any]:
    """An entry of ``fracture.growth.history``: the increment, the cycles and every crack's
    depth, half-length and K_V at its growth points (:func:`_history_k`)."""
    cracks = {}
    for run, c, r, cut, k in zip(runs, g.cracks, recs, cuts, kv, strict=True):
        cracks[run.name] = {"depth": c.depth, "half_length": c.half_length, **_history_k(r, cut, k)}
    return {"increment": g.increments, "cycles": g.cycles, "cracks": cracks}


def _several_rates(runs: list[SurfaceRun], kv: list[np.ndarray]) -> list[np.ndarray]:
    """The growth weights of every crack's three points, taken together
    (:func:`growth_weights`: under one load normalised by the largest K_V of all the
    cracks); a corner crack's point at ψ = 45° has none."""
    w = growth_weights(np.concatenate(kv), runs[0].fracture.fatigue, runs[0].K_Ic)
    out = []
    for k, run in enumerate(runs):
        r = w[3 * k : 3 * k + 3].copy()
        if run.crack.shape == CORNER:
            r[1] = 0.0
        out.append(r)
    return out
