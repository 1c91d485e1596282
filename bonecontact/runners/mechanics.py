"""Mechanics runs: mesh → model → integrator → results (docs/scene_format.md).

A scene with ``[analysis]`` and no ``[neoplasm]`` runs here (:func:`run_mechanics`,
chosen by :func:`bonecontact.runners.dispatch.run_scene`); coupled runs
(:mod:`bonecontact.runners.coupled`) build each analysis's model on their host mesh in
memory (``build_model(..., mesh=..., issues=...)``) and run it with :func:`run_model`.

Everything that can be wrong with the input is checked before any result file is
written; :class:`~bonecontact.scene.errors.SceneError` is raised on *every* rank (all
checks are collective), so a CLI can exit with status 2 on all ranks at once.
"""

from __future__ import annotations

import gc
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
from dolfinx import fem

from bonecontact.common.profiling import PhaseTimer
from bonecontact.contact.interface import ContactInputError, build_interface
from bonecontact.contact.krylov import krylov_rtol
from bonecontact.contact.options import LinearOptions, PDASOptions
from bonecontact.contact.pdas import ContactSolver, PDASResult
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics
from bonecontact.mechanics.newmark import make_integrator
from bonecontact.mechanics.reactions import ForceMoment, SupportReactions, moment_components
from bonecontact.meshing.io import read_gmsh_mesh
from bonecontact.runners.checkpoint import Checkpointer, MechanicsState, RunCounters
from bonecontact.runners.fracture_check import FractureMonitor, fracture_history_columns
from bonecontact.runners.loop import StepHooks, progress_bar, run_steps
from bonecontact.runners.results import (
    ENERGY_COLUMNS,
    ProbeError,
    Probes,
    ResultsWriter,
    RunResult,
    StressFields,
)
from bonecontact.scene import Scene, SceneError, check_against_mesh
from bonecontact.scene.checks import (
    PlausibilityIssue,
    PlausibilityWarning,
    check_cracks_in_mesh,
    emit,
)
from bonecontact.scene.mesh_checks import check_mesh, scene_issues
from bonecontact.scene.rigid_motions import check_rigid_motions, singular_diagnosis
from bonecontact.scene.spec import LoadSpec
from bonecontact.scene.validity import (
    SMALL_STRAIN_LIMIT,
    StrainMonitor,
    judge_run,
    material_cells,
)

__all__ = [
    "SceneModel",
    "book_step",
    "build_model",
    "check_mesh_groups",
    "check_scene_mesh",
    "finish_run",
    "force_summary_lines",
    "read_mesh",
    "run_mechanics",
    "run_model",
    "summary_header",
]


@dataclass
class SceneModel:
    """What a scene builds before it runs."""

    scene: Scene
    mesh_data: object
    groups: dict[str, tuple[int, int]]
    model: Mechanics
    v0: fem.Function | None
    probes: Probes
    interfaces: list = None  # mortar.ContactInterface per [[contact]] pair
    issues: list = None  # PlausibilityIssue per implausible value (emitted as warnings)
    supports: list = None  # (group, local facets, fixed components) per [[dirichlet]]
    unheld: list = None  # rigid motions nothing holds (scene.rigid_motions; warned about)


# ----------------------------------------------------------------------------- set-up
def read_mesh(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD):
    """Read the scene's gmsh file; check dimension, physical groups and the mesh itself
    (:func:`bonecontact.scene.mesh_checks.check_mesh`; collective).

    Returns
    -------
    (MeshData, groups)
        ``groups`` maps physical-group name → (dim, tag).
    """
    path = scene.mesh_path
    file = str(scene.path)
    if not path.is_file():
        raise SceneError(file, "[scene]", "mesh", f"mesh file {str(path)!r} does not exist")
    try:
        tdim, md = read_gmsh_mesh(path, comm, scene.dimension)
    except ValueError as exc:
        raise SceneError(
            file, "[scene]", "mesh", f"cannot read gmsh file {str(path)!r}: {exc}"
        ) from None
    if tdim != scene.dimension:
        raise SceneError(
            file,
            "[scene]",
            "dimension",
            f"is {scene.dimension} but the mesh {path.name} has dimension {tdim}",
        )
    groups = {name: (int(pg.dim), int(pg.tag)) for name, pg in md.physical_groups.items()}
    check_mesh_groups(scene, md, groups, comm)
    return md, groups


def check_mesh_groups(
    scene: Scene, md: Any, groups: dict[str, tuple[int, int]], comm: MPI.Comm
) -> None:
    """The checks of a new mesh (collective): the scene's group names against its groups
    (:func:`bonecontact.scene.check_against_mesh`), then bad elements, duplicated nodes
    and detached pieces (:func:`bonecontact.scene.mesh_checks.check_mesh`)."""
    check_against_mesh(scene, groups, md.mesh.topology.dim, md.mesh.geometry.dim)
    check_mesh(scene, md, groups, comm)


def build_model(
    scene: Scene,
    comm: MPI.Comm = MPI.COMM_WORLD,
    timer: PhaseTimer | None = None,
    mesh: tuple[Any, dict[str, tuple[int, int]]] | None = None,
    issues: list[PlausibilityIssue] | None = None,
) -> SceneModel:
    """Build the mechanics model of a scene (no output written).

    ``timer`` (optional) records the phases ``mesh_read``, ``model`` (spaces, materials,
    boundary conditions, loads, probes) and ``mortar_geometry`` (the contact interfaces).
    Implausible values (unit slips, :func:`bonecontact.scene.mesh_checks.scene_issues`)
    are emitted as one :class:`~bonecontact.scene.checks.PlausibilityWarning` on every rank
    and kept in ``SceneModel.issues``; a unit slip beyond doubt is a SceneError unless
    allowed (:func:`bonecontact.scene.checks.implausible_allowed`).

    ``mesh`` (``(mesh_data, groups)``): a mesh already read and checked, instead of the
    scene's file (a scene with a crack: the body re-meshed around it,
    :mod:`bonecontact.runners.cracks`; a coupled analysis: the rebuilt host mesh).
    ``issues``: the plausibility findings already reported for this scene (a coupled
    run's analyses): kept in ``SceneModel.issues``, not measured or emitted again.

    Raises
    ------
    SceneError
        For every input problem that needs the mesh (collective).
    """
    timer = timer if timer is not None else PhaseTimer()
    with timer.phase("mesh_read"):
        if mesh is None:
            md, groups = read_mesh(scene, comm)
            check_scene_mesh(scene, md, groups)
        else:
            md, groups = mesh
        if issues is None:
            issues = scene_issues(scene, md, groups, comm)
            emit(issues, scene.path)
    unheld = check_rigid_motions(scene, md, groups, comm)  # docs/theory/rigid_motions.md
    tag = {name: t for name, (d, t) in groups.items()}
    with timer.phase("model"):
        model = _mechanics(scene, md, tag)
        supports = _add_dirichlet(scene, model, tag)
        _add_loads(scene, model, tag)
        v0 = _initial_velocity(scene, model, tag)
        try:
            probes = Probes(md.mesh, scene.output.probes)
        except ProbeError as exc:
            raise SceneError(str(scene.path), "[output]", "probes", str(exc)) from None
    with timer.phase("mortar_geometry"):
        interfaces = _contact_interfaces(scene, model, md, tag)
    return SceneModel(scene, md, groups, model, v0, probes, interfaces, issues, supports, unheld)


def check_scene_mesh(scene: Scene, md: Any, groups: dict[str, tuple[int, int]]) -> None:
    """The checks of a scene on its own mesh beyond the mesh's (run once per scene): every
    ``[[crack]]`` inside the body, and no ``[fracture] propagate`` without a crack."""
    check_cracks_in_mesh(scene, md.mesh, md.cell_tags, groups)
    _refuse_fracture_not_run(scene)


def _refuse_fracture_not_run(scene: Scene) -> None:
    """A scene without ``[[crack]]`` (those run in :mod:`bonecontact.runners.cracks`) has
    nothing to propagate."""
    if scene.fracture is not None and scene.fracture.propagate and not scene.cracks:
        raise SceneError(
            str(scene.path),
            "[fracture]",
            "propagate",
            "propagation grows a given crack: add a [[crack]] (initiation alone is the "
            "[fracture] check without propagate)",
        )


def _mechanics(scene: Scene, md: Any, tag: dict[str, int]) -> Mechanics:
    """The model with each region's material."""
    materials = {}
    for spec in scene.materials:
        for region in spec.regions:
            materials[tag[region]] = spec.material
    return Mechanics(md.mesh, materials, md.cell_tags, md.facet_tags)


def _add_dirichlet(
    scene: Scene, model: Mechanics, tag: dict[str, int]
) -> list[tuple[str, np.ndarray, tuple[int, ...]]]:
    """The scene's supports; returns (group, local facets, fixed components) of each."""
    supports = []
    for d in scene.dirichlet:
        facets = model.facets(tag[d.boundary])
        for comp, val in enumerate(d.value):
            if val is not None:
                model.add_dirichlet(facets, comp, float(val), d.schedule)
        supports.append((d.boundary, facets, d.components))
    return supports


def _add_loads(scene: Scene, model: Mechanics, tag: dict[str, int]) -> None:
    counters: dict[str, int] = {}
    for ld in scene.loads:
        tags = [tag[n] for n in ld.target]
        counters[ld.kind] = counters.get(ld.kind, 0) + 1
        if ld.kind == "traction":
            model.add_traction(tags, ld.value, ld.schedule)
        elif ld.kind == "force":
            _add_force(scene, model, tags, ld, counters[ld.kind])
        elif ld.kind == "pressure":
            model.add_pressure(tags, float(ld.value), ld.schedule)
        else:
            model.add_body_force(ld.value, tags, ld.schedule)


def _add_force(scene: Scene, model: Mechanics, tags: list[int], ld: LoadSpec, number: int) -> None:
    """One ``[[force]]`` (collective); a group that cannot carry it is a SceneError."""
    try:
        model.add_force(tags, ld.value, ld.schedule, ld.moment, ld.point)
    except ValueError as exc:
        key = "moment" if ld.moment is not None and "line" in str(exc) else "boundary"
        raise SceneError(
            str(scene.path), f"[[force]] #{number}", key, f'group "{ld.target[0]}": {exc}'
        ) from None


def _vector_text(v: Any) -> str:
    return "(" + ", ".join(f"{x:.6g}" for x in np.atleast_1d(v)) + ")"


def force_summary_lines(scene: Scene, sm: SceneModel) -> list[tuple[str, str]]:
    """(label, text) rows for ``bonecontact check``: the reference area (2D: length) of
    every supported and loaded facet group (volume or area of body-force regions) and
    the total force each load applies at schedule factor 1 (collective)."""
    model, tag = sm.model, {name: t for name, (d, t) in sm.groups.items()}
    two_d = scene.dimension == 2
    size, unit = ("length", "m") if two_d else ("area", "m²")
    rows: list[tuple[str, str]] = []
    for name in dict.fromkeys(d.boundary for d in scene.dirichlet):
        fixed = sorted({c for d in scene.dirichlet if d.boundary == name for c in d.components})
        area = model.group_measures(tag[name]).area
        comps = ", ".join("xyz"[c] for c in fixed)
        rows.append(("supports", f"{name}: {size} {area:.6g} {unit}, fixes {comps}"))
    resultants = model.load_resultants()
    counters: dict[str, int] = {}
    force_unit = "N/m" if two_d else "N"
    for ld, total in zip(scene.loads, resultants, strict=True):
        counters[ld.kind] = counters.get(ld.kind, 0) + 1
        where = f"[[{ld.kind}]] #{counters[ld.kind]} on {', '.join(ld.target)}"
        if ld.kind == "body_force":
            vol = model.cell_measure([tag[r] for r in ld.target])
            measure = f"{'area' if two_d else 'volume'} {vol:.6g} {'m²' if two_d else 'm³'}"
        else:
            measure = f"{size} {model.group_measures(tag[ld.target[0]]).area:.6g} {unit}"
        peak = max(abs(f) for f in ld.schedule.factors)
        rows.append(
            (
                "loads",
                f"{where} ({measure}): total force {_vector_text(total)} {force_unit} "
                f"at factor 1 (schedule peak {peak:.4g})",
            )
        )
    if rows and two_d:
        rows.append(("", "2D plane strain: forces are per metre of thickness (N/m)"))
    return rows


def _initial_velocity(scene: Scene, model: Mechanics, tag: dict[str, int]) -> fem.Function | None:
    if not scene.initial_velocities:
        return None
    v0 = fem.Function(model.V, name="initial_velocity")
    bs = model.V.dofmap.index_map_bs
    for iv in scene.initial_velocities:
        cells = model.cells([tag[r] for r in iv.regions])
        blocks = np.unique(model.V.dofmap.list[cells])
        for c, val in enumerate(iv.value):
            v0.x.array[bs * blocks + c] = val
    return v0


def _contact_interfaces(scene: Scene, model: Mechanics, md: Any, tag: dict[str, int]) -> list:
    """One mortar interface per ``[[contact]]`` pair (input errors as SceneError)."""
    interfaces = []
    if scene.contacts:
        bc = model.bc_dofs()
        for i, c in enumerate(scene.contacts):
            try:
                interfaces.append(
                    build_interface(
                        model.V,
                        md.facet_tags,
                        tag[c.slave],
                        tag[c.master],
                        dirichlet_dofs=bc,
                        name=c.name,
                        search_radius=c.search_distance,
                        groups=(c.slave, c.master),
                        approach=scene.analysis.kind != "dynamic",
                    )
                )
            except ContactInputError as exc:
                raise SceneError(
                    str(scene.path),
                    f'[[contact]] #{i + 1} "{c.name}"',
                    "slave",
                    str(exc).replace(f"contact {c.name!r}: ", ""),
                ) from None
    return interfaces


def _support_residual(integ: Integrator) -> PETSc.Vec:
    """The step's residual less the contact forces: at a support dof of a slave node the
    residual also holds that node's share of the contact force
    (:meth:`~bonecontact.contact.pdas.ContactSolver.contact_force`), which is not the
    support's reaction (issue #23, h1-contact)."""
    out = integ.residual.copy()
    if integ.contact is not None and hasattr(integ.contact, "contact_force"):
        force = integ.residual.duplicate()
        integ.contact.contact_force(force)
        out.axpy(-1.0, force)
        force.destroy()
    return out


def analysis_steps(scene: Scene) -> tuple[int, float]:
    a = scene.analysis
    if a.kind == "static":
        return a.load_steps, 1.0 / a.load_steps
    n = int(round(a.t_end / a.dt))
    if abs(n * a.dt - a.t_end) > 1e-9 * a.t_end:
        n = int(np.ceil(a.t_end / a.dt - 1e-9))
    return max(n, 1), a.dt


def scene_integrator(scene: Scene, sm: SceneModel, dt: float, dynamic: bool) -> Integrator:
    """The time integrator of the scene's analysis (with its contact pairs)."""
    model = sm.model
    contact = None
    if sm.interfaces:
        options = PDASOptions(
            max_iterations=scene.solver.max_iterations,
            friction=[c.friction_law() for c in scene.contacts],
            linear=LinearOptions(multigrid=scene.solver.multigrid),
        )
        contact = ContactSolver(model.V, sm.interfaces, options)
        contact.on_singular = singular_diagnosis(  # which body a singular set leaves free
            scene, sm.mesh_data, sm.groups, model.V, sm.interfaces, model.mesh.comm
        )
    integ = make_integrator(
        scene.analysis.scheme,
        model,
        scene.analysis.kind,
        dt,
        linear=scene.solver.linear,
        rtol=krylov_rtol(scene.solver.tolerance),
        contact=contact,
        energy_balance=dynamic,
    )
    return integ


# ----------------------------------------------------------------------------- recording
class Recorder:
    """Writes the tables (history, contact, probes) and fields of a state as the run goes."""

    def __init__(
        self,
        scene: Scene,
        sm: SceneModel,
        integ: Integrator,
        comm: MPI.Comm,
        outdir: Path,
        dynamic: bool,
        ckpt: Checkpointer | None = None,
    ):
        self.sm, self.integ, self.dynamic = sm, integ, dynamic
        self.stress = StressFields(
            sm.model.mesh, sm.model.stress_expression(integ.u, integ.velocity)
        )
        self.fracture = None
        if scene.fracture is not None:
            tag = {name: t for name, (d, t) in sm.groups.items()}
            self.fracture = FractureMonitor(scene, sm.model, integ.u, tag)
            if ckpt is not None:  # the maxima so far go into the checkpoints
                ckpt.extra["fracture"] = self.fracture.checkpoint_state
                if "fracture" in ckpt.resumed:
                    self.fracture.restore(ckpt.resumed["fracture"])
        self.reactions = SupportReactions(sm.model, sm.supports or [])
        self.last_reactions = self.reactions.zero_record(dynamic)
        self.max_defect = 0.0
        self.max_gross = 0.0
        extra = (
            (tuple(ENERGY_COLUMNS) if dynamic else ())
            + (fracture_history_columns(sm.model.dim) if self.fracture is not None else ())
            + tuple(self.reactions.columns(dynamic))
        )
        self.writer = ResultsWriter(
            comm,
            outdir,
            scene.name,
            sm.probes,
            extra,
            append=ckpt is not None and ckpt.restarted_from is not None,
            fields_stem=ckpt.fields_stem if ckpt is not None else "fields",
        )
        self.fields_written = -1
        cells = material_cells(scene, sm.mesh_data.cell_tags, sm.groups)
        self.strain = StrainMonitor(integ.u, cells)

    def _write_fields(self, t: float) -> None:
        integ, stress = self.integ, self.stress
        risk = [] if self.fracture is None else [self.fracture.risk]
        # a static analysis's velocity is zero: not written (one field less to format)
        velocity = [] if integ.kind == "static" else [integ.velocity]
        self.writer.fields(
            t, [integ.u, *velocity, stress.stress, stress.von_mises, stress.principal, *risk]
        )

    def record(self, step: int, t: float, write_fields: bool, tables: bool = True) -> None:
        """Record the current state (collective); ``tables=False`` after a failure: only
        make sure the last good state's fields exist."""
        integ, sm = self.integ, self.sm
        sm.model.update_nodal_volumetric(integ.u, integ.velocity)
        if tables:  # (first: its cell strains are freed before the stress is made)
            self.strain.update()
            self._release(self.strain)
        self.stress.update()
        risk = [] if self.fracture is None else self.fracture.update(step, t)
        if not tables:
            if self.fields_written != step:
                self._write_fields(t)
            self._free_output()
            return
        forces = self._reaction_values(step)
        self.writer.history([row + risk + forces for row in self._history_rows(step, t)])
        self.writer.probe_rows(step, t, integ.u, integ.velocity, self.stress)
        if write_fields:
            self._write_fields(t)
            self.fields_written = step
        self._free_output()

    def _free_output(self) -> None:
        """After a record: the stress fields (:meth:`_release`) and, in a static run, the
        field writer's mesh in VTK form until the next record."""
        self._release(self.stress)
        if self.integ.kind == "static":
            self.writer.release_fields()

    def _release(self, fields: StressFields | StrainMonitor) -> None:
        """Free the cell fields of a record (the stress and its invariants, or the
        strains: 13 and 9 values per cell in 3D, 104 and 65 MiB per rank at 1M dofs on 2
        ranks) until the next record, when the run is static: its records are few, and
        its solves need the memory (issue 28).  A dynamic run records every step and
        keeps them."""
        if self.integ.kind != "static":
            return
        fields.release()
        gc.collect()  # (an interpolation leaves its target function in a reference cycle)

    def _reaction_values(self, step: int) -> list[float]:
        """The reactions, load (and inertia) of the state just solved as history values
        (zeros for the initial state); books the largest force-balance defect."""
        integ = self.integ
        if step == 0 or integ.step_count == 0:
            rec = self.reactions.zero_record(self.dynamic)
        else:
            support = _support_residual(integ)
            rec = self.reactions.record(support, integ.load, integ.inertia)
            support.destroy()
            self.max_defect = max(self.max_defect, rec.defect())
            self.max_gross = max(self.max_gross, rec.load_gross)
        self.last_reactions = rec
        values = [v for g in rec.groups.values() for v in g.values()] + rec.load.values()
        return values + (rec.inertia.values() if rec.inertia is not None else [])

    def reaction_summary(self) -> dict[str, Any]:
        """The ``reactions`` entry of summary.json: the last step's reaction of every
        supported group, the load (and inertia) resultants and the largest relative
        force-balance defect of the run."""
        rec = self.last_reactions
        gdim = self.sm.model.dim

        def entry(fm: ForceMoment) -> dict[str, list[float]]:
            return {"force": fm.force.tolist(), "moment": fm.moment.tolist()}

        out: dict[str, Any] = {
            "units": "N and N·m about the origin"
            + (" (2D plane strain: per metre of thickness, N/m and N·m/m)" if gdim == 2 else ""),
            "moment_components": list(moment_components(gdim)),
            "groups": {name: entry(fm) for name, fm in rec.groups.items()},
            "load": entry(rec.load),
        }
        if rec.inertia is not None:
            out["inertia"] = entry(rec.inertia)
        out["load_gross_max"] = self.max_gross
        out["balance_defect_max"] = self.max_defect
        return out

    def _history_rows(self, step: int, t: float) -> list[list]:
        """One history row per contact pair (one row without pairs); rewrites the contact tables."""
        integ, sm = self.integ, self.sm
        e = integ.energy()
        res = integ.last_contact
        works = [getattr(integ.balance, c) for c in ENERGY_COLUMNS] if self.dynamic else []
        if not sm.interfaces:
            return [[step, t, "", 0.0, 0.0, 0, 0, 0, 0, e.kinetic, e.strain, *works]]
        rows = []
        for k, itf in enumerate(sm.interfaces):
            if res is None:  # initial state: no contact solve yet
                rows.append([step, t, itf.name, 0.0, 0.0, 0, 0, 0, 0, e.kinetic, e.strain, *works])
                continue
            # frictionless pairs: active nodes slide freely ("slip"), no tangential traction
            rows.append(
                [
                    step,
                    t,
                    itf.name,
                    res.normal_force[k],
                    res.tangential_force[k],
                    res.n_active[k],
                    res.n_stick[k],
                    res.n_slip[k],
                    res.iterations,
                    e.kinetic,
                    e.strain,
                    *works,
                ]
            )
            self.writer.contact_table(
                itf.name,
                itf.coords,
                res.gap[k],
                res.pressure[k],
                res.traction_t[k],
                res.slip[k],
                list(res.status[k]),
            )
        return rows


class MechanicsSteps(StepHooks):
    """The hooks of a mechanics run (:func:`bonecontact.runners.loop.run_steps`): a load or
    time step solved (phase ``time_stepping``, its PDAS part ``contact_solve``), its rows
    and fields recorded (phase ``output``), a checkpoint when due or asked for by a signal
    (``ckpt``; ``None``: no checkpoints).  A failed step leaves the last good state's
    fields."""

    def __init__(
        self,
        integ: Integrator,
        rec: Recorder,
        timer: PhaseTimer,
        every: int,
        counters: RunCounters,
        dt: float,
        ckpt: Checkpointer | None = None,
    ):
        self.integ, self.rec, self.timer, self.every = integ, rec, timer, every
        self.counters, self.dt, self.ckpt = counters, dt, ckpt
        #: free the linear solver's preconditioner or factorisation before the last
        #: record (a run whose integrator solves nothing after its last step; issue 28)
        self.release_solver = False

    def start(self) -> None:
        with self.timer.phase("output"):
            self.rec.record(0, 0.0, self.every > 0)

    def advance(self, k: int) -> None:
        with self.timer.phase("time_stepping"):
            si = self.integ.step()
        book_step(self.counters, self.timer, si.linear_iterations, self.integ.last_contact)

    def fields_due(self, k: int) -> bool:
        """Whether ``[output] fields_every`` asks for the fields of step ``k``."""
        return self.every > 0 and k % self.every == 0

    def record(self, k: int, last: bool) -> None:
        if last and self.release_solver:
            self.integ.release_solver_work()  # (no solve follows: the output needs the room)
        with self.timer.phase("output"):
            self.rec.record(k, self.integ.t, self.fields_due(k) or last)

    def checkpoint(self, k: int, last: bool) -> bool:
        return self.ckpt is not None and bool(self.ckpt.after_step(last))

    def interrupted(self, k: int) -> None:
        with self.timer.phase("output"):  # the fields of the last state
            self.rec.record(k, self.integ.t, True, tables=False)

    def failure(self, k: int, exc: BaseException) -> str:
        integ = self.integ
        message = f"step {integ.step_count + 1} (t = {integ.t + self.dt:.6g} s): {exc}"
        integ.u.x.array[:] = integ.u_n.x.array  # the failed step may have left NaN there
        with self.timer.phase("output"):  # the last good state (its rows are written)
            self.rec.record(integ.step_count, integ.t, True, tables=False)
        return message


def run_info(
    scene: Scene,
    sm: SceneModel,
    integ: Integrator,
    counts: RunCounters,
    dynamic: bool,
    e0: float,
    t_start: float,
) -> dict[str, Any]:
    """Steps, iterations, contact and energy entries of the summary."""
    info: dict[str, Any] = {
        "steps": integ.step_count,
        "linear_iterations": {
            "total": int(sum(counts.linear)),
            "max": int(max(counts.linear, default=0)),
        },
        "wall_time_s": time.perf_counter() - t_start,
    }
    if sm.interfaces:
        info["contact"] = {
            "pairs": [i.name for i in sm.interfaces],
            "pdas_iterations": {
                "total": int(sum(counts.pdas)),
                "max": int(max(counts.pdas, default=0)),
            },
            "friction": [c.friction for c in scene.contacts],
            "bound_updates": int(sum(counts.bound_updates)),
            "solver": "PDAS (semi-smooth Newton), dual mortar; Tresca/Coulomb friction "
            "(Coulomb fixed_point: outer = bound_updates, inner = pdas_iterations)",
            "setup_time_s": integ.contact.setup_time,
            **integ.contact.column_report(),
        }
    if dynamic:
        b = integ.balance
        info["energy"] = {
            "initial": e0,
            "final": b.total,
            **{c: getattr(b, c) for c in ENERGY_COLUMNS},
            "defect": b.defect,
        }
    return info


def book_step(
    counts: RunCounters, timer: PhaseTimer, linear_iterations: int, res: PDASResult | None
) -> None:
    """Count a step's linear (and, with contact, PDAS) iterations and add its contact
    solve's time to the phase ``contact_solve``."""
    if res is None:
        counts.add(linear_iterations)
        return
    counts.add(linear_iterations, res.iterations, res.bound_updates)
    timer.add("contact_solve", res.wall_time)


def summary_header(scene: Scene, sm: SceneModel, integ: Integrator, dt: float) -> dict[str, Any]:
    """The first entries of summary.json: dofs, analysis, time step, set-up time, linear
    solver and the multigrid of the iterative contact solve."""
    return {
        "dofs": sm.model.num_dofs,
        "analysis": scene.analysis.kind,
        "dt": dt,
        "setup_time_s": integ.setup_time,
        "linear_solver": scene.solver.linear,
        "multigrid": scene.solver.multigrid,
    }


def finish_run(
    scene: Scene,
    sm: SceneModel,
    rec: Recorder,
    timer: PhaseTimer,
    comm: MPI.Comm,
    status: str,
    message: str | None,
    info: dict[str, Any],
) -> dict[str, Any]:
    """Complete ``info`` (the model's warnings, the phase times, the failure message),
    judge the strain (a converged run beyond small-strain validity becomes ``"invalid"``,
    :func:`bonecontact.scene.validity.judge_run`), write summary.json, close the writer and
    warn of an allowed large strain (collective).  Returns the summary (its ``"status"``
    is the run's)."""
    status, message = judge_run(scene, status, message, info)
    info["warnings"] = [str(i) for i in sm.issues]
    info.setdefault("reactions", rec.reaction_summary())
    info["phases_s"] = timer.summary(comm)
    imap = sm.model.V.dofmap.index_map
    owned = imap.size_local * sm.model.V.dofmap.index_map_bs
    info["memory_bytes_per_dof"] = timer.memory_per_dof(comm, owned)  # (issue 28)
    if message is not None:
        info["message"] = message
    summary = rec.writer.summary(status, **info)
    rec.writer.close()
    if status != "invalid":
        _warn_large_strain(scene, rec.strain.measure)
    return summary


def _checkpoint_info(scene: Scene, sm: SceneModel, dt: float) -> dict[str, Any]:
    """What a checkpoint and the run continuing it must agree on."""
    return {"scene": scene.name, "analysis": scene.analysis.kind, "dt": dt}


# ----------------------------------------------------------------------------- run
def run_mechanics(
    scene: Scene,
    comm: MPI.Comm = MPI.COMM_WORLD,
    output: Path | None = None,
    progress: bool = True,
    restart: str | Path | bool | None = None,
    checkpoint_on_signal: bool = True,
) -> RunResult:
    """Validate, build and run a mechanics scene, writing its results incrementally.

    ``restart``: continue from the newest checkpoint in the output directory (``True``)
    or from the named one (a path); docs/checkpoint.md.  ``checkpoint_on_signal=False``
    (an analysis of a coupled run): a signal stops the run after the step without a
    checkpoint and is passed on to the enclosing run.

    Returns
    -------
    RunResult
        ``status`` is ``"converged"``, ``"failed"`` (then ``summary["message"]``
        says why; the last good state is in the output files) or ``"interrupted"``
        (a signal; a checkpoint of the last step was written).

    Raises
    ------
    CheckpointError
        The checkpoint to restart from is missing, damaged or from another scene.
    """
    t_start = time.perf_counter()
    timer = PhaseTimer()
    sm = build_model(scene, comm, timer)
    outdir = Path(output) if output is not None else scene.output.directory
    return run_model(sm, comm, outdir, progress, restart, checkpoint_on_signal, timer, t_start)


def run_model(
    sm: SceneModel,
    comm: MPI.Comm,
    outdir: Path,
    progress: bool = True,
    restart: str | Path | bool | None = None,
    checkpoint_on_signal: bool = True,
    timer: PhaseTimer | None = None,
    t_start: float | None = None,
) -> RunResult:
    """Run a built mechanics model (``sm.scene``'s analysis) through the step loop of
    :mod:`bonecontact.runners.loop`, writing into ``outdir`` (collective; nothing is read
    from a scene file or checked again).  The arguments as :func:`run_mechanics`'s;
    ``timer`` and ``t_start``: the phases and start time of the set-up already done."""
    t_start = time.perf_counter() if t_start is None else t_start
    timer = PhaseTimer() if timer is None else timer
    scene = sm.scene
    nsteps, dt = analysis_steps(scene)
    dynamic = scene.analysis.kind == "dynamic"  # dynamic runs book the energy balance
    with timer.phase("solver_setup"):  # assembly, factorisation or preconditioner
        integ = scene_integrator(scene, sm, dt, dynamic)
        integ.set_initial(None, sm.v0)
    out = scene.output
    info = _checkpoint_info(scene, sm, dt)
    ckpt = Checkpointer(
        outdir,
        MechanicsState(integ),
        out.checkpoint_every,
        info,
        out.checkpoint_time,
        checkpoint_on_signal,
    )
    if restart:
        with timer.phase("checkpoint"):
            ckpt.resume(None if restart is True else restart)
    with timer.phase("output"):
        rec = Recorder(scene, sm, integ, comm, outdir, dynamic, ckpt)
    e0 = ckpt.counters.e0
    info = summary_header(scene, sm, integ, dt)
    hooks = MechanicsSteps(integ, rec, timer, out.fields_every, ckpt.counters, dt, ckpt)
    hooks.release_solver = True
    first = integ.step_count + 1
    with ckpt.stop:
        bar = progress_bar(comm, scene.name, nsteps, first - 1, progress)
        end = run_steps(hooks, first, nsteps, bar)
    info.update(run_info(scene, sm, integ, ckpt.counters, dynamic, e0, t_start))
    info.update(ckpt.summary())
    if ckpt.time_s:
        timer.add("checkpoint", ckpt.time_s)
    info.update(rec.strain.summary())
    if rec.fracture is not None:
        info["fracture"] = rec.fracture.summary()
    summary = finish_run(scene, sm, rec, timer, comm, end.status, end.message, info)
    return RunResult(summary["status"], summary, integ, outdir)


def _warn_large_strain(scene: Scene, measure: float) -> None:
    """A strain beyond the small-strain model's validity that the scene accepts
    (``allow_large_strain``; after the results are written, summary.json says
    ``"small_strain_valid": false``)."""
    if measure > SMALL_STRAIN_LIMIT:
        warnings.warn(
            f"{scene.name}: the strain measure reaches {measure:.3g} (> "
            f"{SMALL_STRAIN_LIMIT:.0%}): the result is outside the validity of the small-strain "
            "model (summary.json: small_strain_valid = false), accepted by [analysis] "
            "allow_large_strain = true",
            PlausibilityWarning,
            stacklevel=3,
        )
