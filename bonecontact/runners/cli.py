"""Command line: ``bonecontact run|check|mesh-surface|mesh-ct`` (also under ``mpiexec -n K``).

``bonecontact check SCENE.toml`` validates a scene and its mesh without running it and
prints a short summary; ``bonecontact run SCENE.toml [--restart [CHECKPOINT]]`` runs (or
continues) it; ``--strict`` makes plausibility warnings errors, ``--allow-implausible``
runs a unit slip beyond doubt.  ``mesh-surface`` and ``mesh-ct`` mesh a closed surface or
one CT slice (:mod:`bonecontact.meshing.stl`, :mod:`bonecontact.meshing.ct`).  The run
kind comes from :mod:`bonecontact.runners.kinds`, as for :func:`bonecontact.run`.

Exit statuses follow one table, :data:`bonecontact.scene.errors.EXIT_CODES`
(docs/scene_format.md, *Exit status*): 0 converged, 1 failed, 2 invalid input, 3 an
invalid result, 128 + signal after a checkpoint.  Under MPI an input error is found on
every rank and an unexpected error on one rank aborts all ranks.  What each command
prints and does: docs/run_loop.md (*The command*).
"""

from __future__ import annotations

import argparse
import sys
import traceback
import warnings
from pathlib import Path

from mpi4py import MPI

from bonecontact.common.profiling import map_large_allocations
from bonecontact.common.version import __version__
from bonecontact.meshing.ct import main as mesh_ct
from bonecontact.meshing.stl import main as mesh_surface
from bonecontact.runners.checkpoint import CheckpointError
from bonecontact.runners.dispatch import check, run_kind, run_scene
from bonecontact.runners.mechanics import SceneModel, force_summary_lines
from bonecontact.scene import Scene, SceneError, format_error, load_scene
from bonecontact.scene.checks import PlausibilityWarning, implausible_allowed
from bonecontact.scene.errors import ExitCode, exit_code, exit_code_for_status
from bonecontact.scene.mesh_checks import count_bodies, mesh_extent

__all__ = ["main"]

ALLOW_HELP = (
    "run a scene with a unit slip beyond doubt (a mesh more than 2 m or less than 0.1 mm "
    "across, a modulus below 1 kPa) with a warning instead of refusing it (exit status 2)"
)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="bonecontact",
        description="Dynamic contact of visco-elastic bones with neoplasms (FEniCSx). Units: SI.",
    )
    p.add_argument("--version", action="version", version=f"bonecontact {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser(
        "run",
        help="run a scene file (TOML, format 1)",
        description="Run a scene; results go to [output].directory (or --output).",
    )
    r.add_argument("scene", type=Path, help="scene file (TOML)")
    r.add_argument(
        "-o", "--output", type=Path, default=None, help="output directory (overrides the scene)"
    )
    r.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    r.add_argument(
        "--strict",
        action="store_true",
        help="treat implausible values (likely unit slips) as errors (exit status 2)",
    )
    r.add_argument("--allow-implausible", action="store_true", help=ALLOW_HELP)
    r.add_argument(
        "--restart",
        nargs="?",
        const=True,
        default=None,
        metavar="CHECKPOINT",
        help="continue from the newest checkpoint of the output directory, or from the "
        "named checkpoint directory (docs/checkpoint.md)",
    )
    sub.add_parser(
        "mesh-surface",
        add_help=False,
        help="tetrahedral bone (.msh) from a closed surface file (STL, ...); "
        "'bonecontact mesh-surface -h' for its options",
    )
    sub.add_parser(
        "mesh-ct",
        add_help=False,
        help="triangle mesh (.msh) of the bone in one CT slice (DICOM); "
        "'bonecontact mesh-ct -h' for its options",
    )
    c = sub.add_parser("check", help="validate a scene file and its mesh without running it")
    c.add_argument("scene", type=Path, help="scene file (TOML)")
    c.add_argument(
        "--strict",
        action="store_true",
        help="treat implausible values (likely unit slips) as errors (exit status 2)",
    )
    c.add_argument("--allow-implausible", action="store_true", help=ALLOW_HELP)
    return p


def _say(msg: str, comm: MPI.Comm) -> None:
    if comm.rank == 0:
        print(msg, file=sys.stderr, flush=True)


def _warning_printer(comm: MPI.Comm):
    """``warnings.showwarning`` of the command: ``warning: <message>`` on rank 0's stderr."""

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        _say(f"warning: {message}", comm)

    return show


def _pascals(v: float) -> str:
    """A stress or modulus with its SI prefix (``17 GPa``)."""
    for factor, unit in ((1e9, "GPa"), (1e6, "MPa"), (1e3, "kPa")):
        if abs(v) >= factor:
            return f"{v / factor:.4g} {unit}"
    return f"{v:.4g} Pa"


def _fmt_modulus(material: object) -> str:
    keys = [k for k in ("E", "E_p", "E_a", "E1", "E2", "E3") if hasattr(material, k)]
    return ", ".join(f"{k} = {_pascals(getattr(material, k))}" for k in keys)


def _summary_lines(scene: Scene, sm: SceneModel | None, comm: MPI.Comm) -> list[tuple[str, str]]:
    """(label, text) rows of ``bonecontact check``'s summary (collective: counts bodies)."""
    rows = []
    a = scene.analysis
    steps = "" if a is None else f", {a.n_steps} {'load ' if a.kind == 'static' else ''}steps"
    kind = "growth only" if a is None else f"{a.kind}{steps}"
    plane = "2D plane strain" if scene.dimension == 2 else "3D"
    rows.append(("analysis", f"{kind}; {plane}; {run_kind(scene)} run; {scene.solver.linear}"))
    if sm is not None:
        mesh = sm.mesh_data.mesh
        cells = mesh.topology.index_map(mesh.topology.dim).size_global
        bodies = count_bodies(mesh, comm)
        size = " × ".join(f"{e:.4g}" for e in mesh_extent(mesh, comm))
        rows.append(("mesh", f"{scene.mesh_path.name}: {size} m, {cells} cells, {bodies} bodies"))
    elif scene.mesh_path is not None:
        rows.append(("mesh", scene.mesh_path.name))
    for m in scene.materials:
        law = type(m.material).__name__
        regions = ", ".join(m.regions)
        rows.append(("materials", f"{m.name} ({law}, {_fmt_modulus(m.material)}) on {regions}"))
    facets = sorted(
        {d.boundary for d in scene.dirichlet}
        | {ld.target[0] for ld in scene.loads if ld.kind != "body_force"}
        | {s for c in scene.contacts for s in (c.slave, c.master)}
    )
    rows.append(("groups used", f"cells: {', '.join(scene.cell_regions) or '-'}"))
    rows.append(("", f"facets: {', '.join(facets) or '-'}"))
    if sm is not None:  # areas of the supported and loaded groups, total force of each load
        rows += force_summary_lines(scene, sm)
    for c in scene.contacts:
        fr = "frictionless" if c.friction == "none" else c.friction
        rows.append(("contact", f"{c.name}: {c.slave} (slave) on {c.master} (master), {fr}"))
    for c in scene.cracks:
        fr = f"Coulomb {c.coefficient:g}" if c.coefficient else "frictionless"
        rows.append(("contact", f"{c.name}: the crack's faces (re-meshed body), {fr}"))
    initiates = scene.fracture is not None and scene.fracture.initiate and not scene.cracks
    if initiates:
        mu = scene.fracture.coefficient
        fr = f"Coulomb {mu:g}" if mu else "frictionless"
        rows.append(("contact", f"initiated: the faces of the crack inserted at risk 1, {fr}"))
    if not scene.contacts and not scene.cracks and not initiates:
        rows.append(("contact", "none"))
    if sm is not None:
        rows.append(("dofs", f"{sm.model.num_dofs} (P1 displacement)"))
        rows += _motion_lines(scene, sm)
        rows.append(("warnings", str(len(sm.issues)) if sm.issues else "none"))
    elif scene.growth_only:
        rows.append(("dofs", "no mechanics (growth only)"))
    else:
        rows.append(("dofs", "set by the host mesh rebuilt around the neoplasm during the run"))
    return rows


def _motion_lines(scene: Scene, sm: SceneModel) -> list[tuple[str, str]]:
    """The ``motions`` rows: every body held, the motions left free (``unheld_motion =
    "warn"``), or not checked (dynamic: the mass holds a free body)."""
    if scene.analysis is None or scene.analysis.kind == "dynamic":
        return [("motions", "not checked (dynamic analysis: inertia holds a free body)")]
    if not sm.unheld:
        return [("motions", "every rigid motion of every body is held")]
    return [("motions", f"{m} (warning)") for m in sm.unheld]


def _check(scene: Scene, shown: Path, comm: MPI.Comm) -> int:
    """``bonecontact check``: every check, then the summary on stdout (rank 0)."""
    sm = check(scene, comm)  # mechanics, crack: the model (on the cracked body); else None
    rows = _summary_lines(scene, sm, comm)
    if comm.rank == 0:
        print(f"{scene.name}: ok ({shown})")
        previous = None
        for label, text in rows:
            print(f"  {'' if label == previous else label:<12}{text}")
            previous = label
        sys.stdout.flush()
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit status."""
    comm = MPI.COMM_WORLD
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["mesh-surface"]:  # its own parser (bonecontact.meshing.stl)
        return mesh_surface(argv[1:])
    if argv[:1] == ["mesh-ct"]:  # its own parser (bonecontact.meshing.ct)
        return mesh_ct(argv[1:])
    args = _parser().parse_args(argv)
    if args.command == "run":
        map_large_allocations()  # freed matrices leave the resident set (issue 28)
    with warnings.catch_warnings():
        warnings.simplefilter("error" if args.strict else "always", PlausibilityWarning)
        warnings.showwarning = _warning_printer(comm)
        with implausible_allowed(args.allow_implausible):
            return _command(args, comm)


def _command(args: argparse.Namespace, comm: MPI.Comm) -> int:
    """Run the parsed command; returns the exit status."""
    try:
        scene = load_scene(args.scene)
        if args.command == "check":
            return _check(scene, args.scene, comm)
        result = run_scene(
            scene, comm, output=args.output, progress=not args.quiet, restart=args.restart
        )
    except SceneError as exc:
        _say(format_error(exc), comm)
        return exit_code(exc)
    except PlausibilityWarning as exc:  # --strict: raised on every rank
        _say(f"error (--strict): {exc}", comm)
        return exit_code(exc)
    except CheckpointError as exc:  # raised on every rank
        _say(f"restart: {exc}", comm)
        return exit_code(exc)
    except KeyboardInterrupt as exc:
        _say("interrupted", comm)
        if comm.size > 1:
            comm.Abort(exit_code(exc))
        return exit_code(exc)
    except Exception:  # an internal error: say so loudly and stop every rank
        sys.stderr.write(
            f"[rank {comm.rank}] internal error in bonecontact:\n{traceback.format_exc()}"
        )
        sys.stderr.flush()
        if comm.size > 1:
            comm.Abort(int(ExitCode.FAILED))
        return int(ExitCode.FAILED)
    code = exit_code_for_status(result.status, result.summary.get("signal"))
    if result.status == "interrupted":
        _say(
            f"{scene.name}: {result.summary.get('message', 'interrupted')}; checkpoint "
            f"{result.summary['checkpoints']['last']} (continue with --restart)",
            comm,
        )
        return code
    if result.status == "invalid":  # finished, results written, outside the model's range
        _say(f"invalid result: {result.summary.get('message', '')}", comm)
        return code
    if result.status != "converged":
        _say(
            f"run failed: {result.summary.get('message', '')} "
            f"(see {result.output / 'summary.json'})",
            comm,
        )
        return code
    _say(
        f"{scene.name}: {result.status}, {result.summary['steps']} steps, "
        f"results in {result.output}",
        comm,
    )
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
