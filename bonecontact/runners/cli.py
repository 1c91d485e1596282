"""Command line: ``bonecontact run SCENE.toml`` (also under ``mpiexec -n K``).

Exit status: 0 converged; 1 the run failed (solver did not converge — see
``summary.json``) or an internal error; 2 invalid input (message names the file,
table and key; nothing is written).  Under MPI an input error is detected on every
rank (collective checks) and an unexpected error on one rank aborts all ranks.
"""

from __future__ import annotations

import argparse
import signal
import sys
import traceback
from pathlib import Path

from mpi4py import MPI

from bonecontact.runners.checkpoint import CheckpointError
from bonecontact.runners.dispatch import check, run_scene
from bonecontact.scene import SceneError, format_error, load_scene

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="bonecontact",
        description="Dynamic contact of visco-elastic bones with neoplasms (FEniCSx). Units: SI.",
    )
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
        "--restart",
        nargs="?",
        const=True,
        default=None,
        metavar="CHECKPOINT",
        help="continue from the newest checkpoint of the output directory, or from the "
        "named checkpoint directory (docs/checkpoint.md)",
    )
    c = sub.add_parser("check", help="validate a scene file and its mesh without running it")
    c.add_argument("scene", type=Path, help="scene file (TOML)")
    return p


def _say(msg: str, comm: MPI.Comm) -> None:
    if comm.rank == 0:
        print(msg, file=sys.stderr, flush=True)


def _signal_number(name: str) -> int:
    """15 for ``"SIGTERM"`` (2 for an unknown name)."""
    return int(getattr(signal.Signals, name, signal.SIGINT))


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit status."""
    comm = MPI.COMM_WORLD
    args = _parser().parse_args(argv)
    try:
        scene = load_scene(args.scene)
        if args.command == "check":
            check(scene, comm)
            _say(f"{args.scene}: ok", comm)
            return 0
        result = run_scene(
            scene, comm, output=args.output, progress=not args.quiet, restart=args.restart
        )
    except SceneError as exc:
        _say(format_error(exc), comm)
        return 2
    except CheckpointError as exc:  # raised on every rank
        _say(f"restart: {exc}", comm)
        return 2
    except KeyboardInterrupt:
        _say("interrupted", comm)
        if comm.size > 1:
            comm.Abort(130)
        return 130
    except Exception:  # an internal error: say so loudly and stop every rank
        sys.stderr.write(
            f"[rank {comm.rank}] internal error in bonecontact:\n{traceback.format_exc()}"
        )
        sys.stderr.flush()
        if comm.size > 1:
            comm.Abort(1)
        return 1
    if result.status == "interrupted":
        _say(
            f"{scene.name}: {result.summary.get('message', 'interrupted')}; checkpoint "
            f"{result.summary['checkpoints']['last']} (continue with --restart)",
            comm,
        )
        return 128 + _signal_number(result.summary.get("signal", "SIGINT"))
    if result.status != "converged":
        _say(
            f"run failed: {result.summary.get('message', '')} "
            f"(see {result.output / 'summary.json'})",
            comm,
        )
        return 1
    _say(
        f"{scene.name}: {result.status}, {result.summary['steps']} steps, "
        f"results in {result.output}",
        comm,
    )
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
