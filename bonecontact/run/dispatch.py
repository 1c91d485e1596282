"""Run a scene: mesh → model → integrator → results (SCENE_FORMAT.md).

Everything that can be wrong with the input is checked before any result file is
written; :class:`~bonecontact.scene.spec.SceneError` is raised on *every* rank (all
checks are collective), so a CLI can exit with status 2 on all ranks at once.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from dolfinx import fem
from dolfinx.io import gmsh as gmshio
from mpi4py import MPI
from tqdm import tqdm

from bonecontact.run.results import ENERGY_COLUMNS, ProbeError, Probes, ResultsWriter, StressFields
from bonecontact.mechanics.model import Mechanics
from bonecontact.contact.pdas import FrictionLaw
from bonecontact.scene.spec import Scene, SceneError, check_against_mesh
from bonecontact.mechanics.integrator import Integrator

__all__ = ["SceneModel", "build_model", "run_scene", "RunResult", "read_mesh"]


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


@dataclass
class RunResult:
    """Outcome of :func:`run_scene`."""

    status: str
    summary: dict
    integrator: Integrator | None
    output: Path


def _open_gmsh(path: Path, comm: MPI.Comm, gdim: int):
    """Open a gmsh file on rank 0 only (quietly) and build the distributed mesh.

    Returns ``(tdim, mesh_data)``; ``mesh_data`` is None when the dimension is wrong.
    Raises ValueError (on every rank) when gmsh cannot read the file.
    """
    import gmsh

    dim, err = -1, None
    init = False
    if comm.rank == 0:
        init = not gmsh.isInitialized()
        if init:
            gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        try:
            gmsh.clear()
            gmsh.open(str(path))
            dim = gmsh.model.getDimension()
        except Exception as exc:  # gmsh raises plain Exceptions
            err = str(exc)
    dim, err = comm.bcast((dim, err), root=0)
    md = None
    try:
        if err is None and dim == gdim:
            md = gmshio.model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=gdim)
    finally:
        if comm.rank == 0:
            gmsh.clear()
            if init:
                gmsh.finalize()
    if err is not None or dim < 1:
        raise ValueError(err or "no elements")
    return dim, md


def read_mesh(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD):
    """Read the scene's gmsh file; check dimension and physical groups (collective).

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
        tdim, md = _open_gmsh(path, comm, scene.dimension)
    except ValueError as exc:
        raise SceneError(file, "[scene]", "mesh", f"cannot read gmsh file {str(path)!r}: {exc}") from None
    if tdim != scene.dimension:
        raise SceneError(file, "[scene]", "dimension",
                         f"is {scene.dimension} but the mesh {path.name} has dimension {tdim}")
    groups = {name: (int(pg.dim), int(pg.tag)) for name, pg in md.physical_groups.items()}
    check_against_mesh(scene, groups, md.mesh.topology.dim, md.mesh.geometry.dim)
    return md, groups


def build_model(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> SceneModel:
    """Build the mechanics model of a scene (no output written).

    Raises
    ------
    SceneError
        For every input problem that needs the mesh (collective).
    """
    md, groups = read_mesh(scene, comm)
    msh = md.mesh
    tag = {name: t for name, (d, t) in groups.items()}
    materials = {}
    for spec in scene.materials:
        for region in spec.regions:
            materials[tag[region]] = spec.material
    model = Mechanics(msh, materials, md.cell_tags, md.facet_tags)
    for d in scene.dirichlet:
        facets = model.facets(tag[d.boundary])
        for comp, val in enumerate(d.value):
            if val is not None:
                model.add_dirichlet(facets, comp, float(val), d.schedule)
    for ld in scene.loads:
        tags = [tag[n] for n in ld.target]
        if ld.kind == "traction":
            model.add_traction(tags, ld.value, ld.schedule)
        elif ld.kind == "pressure":
            model.add_pressure(tags, float(ld.value), ld.schedule)
        else:
            model.add_body_force(ld.value, tags, ld.schedule)
    v0 = None
    if scene.initial_velocities:
        v0 = fem.Function(model.V, name="initial_velocity")
        bs = model.V.dofmap.index_map_bs
        for iv in scene.initial_velocities:
            cells = model.cells([tag[r] for r in iv.regions])
            blocks = np.unique(model.V.dofmap.list[cells])
            for c, val in enumerate(iv.value):
                v0.x.array[bs * blocks + c] = val
    try:
        probes = Probes(msh, scene.output.probes)
    except ProbeError as exc:
        raise SceneError(str(scene.path), "[output]", "probes", str(exc)) from None
    interfaces = []
    if scene.contacts:
        from bonecontact.contact.interface import ContactInputError, build_interface

        bc = model.bc_dofs()
        for i, c in enumerate(scene.contacts):
            try:
                interfaces.append(build_interface(model.V, md.facet_tags, tag[c.slave], tag[c.master],
                                                  dirichlet_dofs=bc, name=c.name))
            except ContactInputError as exc:
                raise SceneError(str(scene.path), f'[[contact]] #{i + 1} "{c.name}"', "slave",
                                 str(exc).replace(f"contact {c.name!r}: ", "")) from None
    return SceneModel(scene, md, groups, model, v0, probes, interfaces)


def _steps(scene: Scene) -> tuple[int, float]:
    a = scene.analysis
    if a.kind == "static":
        return a.load_steps, 1.0 / a.load_steps
    n = int(round(a.t_end / a.dt))
    if abs(n * a.dt - a.t_end) > 1e-9 * a.t_end:
        n = int(np.ceil(a.t_end / a.dt - 1e-9))
    return max(n, 1), a.dt


def run_scene(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD, output: Path | None = None,
              progress: bool = True) -> RunResult:
    """Validate, build and run a scene, writing its results incrementally.

    Returns
    -------
    RunResult
        ``status`` is ``"converged"`` or ``"failed"`` (then ``summary["message"]``
        says why; the last good state is in the output files).
    """
    if scene.growth_only:  # [neoplasm] without [analysis]: growth.csv (bonecontact.run.growth)
        from bonecontact.run.growth import run_growth

        return run_growth(scene, comm, output, progress)
    if scene.neoplasm is not None:  # [neoplasm] with [analysis]: growth + rebuilt host mesh + analysis
        from bonecontact.run.coupled import run_coupled

        return run_coupled(scene, comm, output, progress)
    t_start = time.perf_counter()
    sm = build_model(scene, comm)
    model = sm.model
    outdir = Path(output) if output is not None else scene.output.directory
    nsteps, dt = _steps(scene)
    dynamic = scene.analysis.kind == "dynamic"  # dynamic runs book the energy balance
    integ = Integrator(model, scene.analysis.kind, dt, linear=scene.solver.linear,
                       rtol=min(1e-2 * scene.solver.tolerance, 1e-12), contact=sm.interfaces or None,
                       contact_options={"max_iterations": scene.solver.max_iterations,
                                        "friction": [FrictionLaw(c.friction, c.coefficient, c.bound, c.coulomb_update)
                                                     for c in scene.contacts]},
                       energy_balance=dynamic)
    integ.set_initial(None, sm.v0)
    stress = StressFields(model.mesh, model.stress_expression(integ.u, integ.velocity))
    writer = ResultsWriter(comm, outdir, scene.name, sm.probes, ENERGY_COLUMNS if dynamic else ())
    every = scene.output.fields_every

    fields_written = [-1]
    e0 = integ.balance.total

    def record(step: int, t: float, write_fields: bool, tables: bool = True) -> None:
        model.update_nodal_volumetric(integ.u, integ.velocity)
        stress.update()
        if not tables:  # after a failure: only make sure the last good state's fields exist
            if fields_written[0] != step:
                writer.fields(t, [integ.u, integ.velocity, stress.stress, stress.von_mises, stress.principal])
            return
        e = integ.energy()
        res = integ.last_contact
        works = [getattr(integ.balance, c) for c in ENERGY_COLUMNS] if dynamic else []
        if not sm.interfaces:
            writer.history([[step, t, "", 0.0, 0.0, 0, 0, 0, 0, e.kinetic, e.strain, *works]])
        else:
            rows = []
            for k, itf in enumerate(sm.interfaces):
                if res is None:  # initial state: no contact solve yet
                    rows.append([step, t, itf.name, 0.0, 0.0, 0, 0, 0, 0, e.kinetic, e.strain, *works])
                    continue
                # frictionless pairs: active nodes slide freely ("slip"), no tangential traction
                rows.append([step, t, itf.name, res.normal_force[k], res.tangential_force[k], res.n_active[k],
                             res.n_stick[k], res.n_slip[k], res.iterations, e.kinetic, e.strain, *works])
                writer.contact_table(itf.name, itf.coords, res.gap[k], res.pressure[k],
                                     res.traction_t[k], res.slip[k], list(res.status[k]))
            writer.history(rows)
        writer.probe_rows(step, t, integ.u, integ.velocity, stress)
        if write_fields:
            writer.fields(t, [integ.u, integ.velocity, stress.stress, stress.von_mises, stress.principal])
            fields_written[0] = step

    status, message = "converged", None
    lin_its, pdas_its, bound_updates = [], [], []
    info = {"dofs": model.num_dofs, "analysis": scene.analysis.kind, "dt": dt, "setup_time_s": integ.setup_time,
            "linear_solver": scene.solver.linear}
    try:
        record(0, 0.0, every > 0)
        bar = tqdm(total=nsteps, desc=scene.name, unit="step", disable=(comm.rank != 0) or not progress,
                   dynamic_ncols=True)
        for k in range(1, nsteps + 1):
            si = integ.step()
            lin_its.append(si.linear_iterations)
            if integ.last_contact is not None:
                pdas_its.append(integ.last_contact.iterations)
                bound_updates.append(integ.last_contact.bound_updates)
            last = k == nsteps
            record(k, integ.t, (every > 0 and k % every == 0) or last)
            bar.update(1)
        bar.close()
    except RuntimeError as exc:
        status, message = "failed", f"step {integ.step_count + 1} (t = {integ.t + dt:.6g} s): {exc}"
        record(integ.step_count, integ.t, True, tables=False)  # last good state (its rows are written)
    info.update({"steps": integ.step_count, "linear_iterations": {"total": int(sum(lin_its)),
                                                                  "max": int(max(lin_its, default=0))},
                 "wall_time_s": time.perf_counter() - t_start})
    if sm.interfaces:
        info["contact"] = {"pairs": [i.name for i in sm.interfaces],
                           "pdas_iterations": {"total": int(sum(pdas_its)), "max": int(max(pdas_its, default=0))},
                           "friction": [c.friction for c in scene.contacts],
                           "bound_updates": int(sum(bound_updates)),
                           "solver": "PDAS (semi-smooth Newton), dual mortar; Tresca/Coulomb friction "
                                     "(Coulomb fixed_point: outer = bound_updates, inner = pdas_iterations)",
                           "setup_time_s": integ.contact.setup_time}
    if dynamic:
        b = integ.balance
        info["energy"] = {"initial": e0, "final": b.total, **{c: getattr(b, c) for c in ENERGY_COLUMNS},
                          "defect": b.defect}
    if message is not None:
        info["message"] = message
    summary = writer.summary(status, **info)
    writer.close()
    return RunResult(status, summary, integ, outdir)
