"""The one step loop of every run kind, with hooks for what a scene adds (docs/run_loop.md).

A run is built from a model (the mechanics model of a scene, the growth driver, the body
meshed around a crack) and handed to :func:`run_steps` as a :class:`StepHooks` object;
the loop itself knows nothing of scenes::

    start()                        the initial state recorded (a fresh run only)
    for k = first .. n:
        advance(k)                 one step: a load/time step solved, a growth step made
        verdict = after(k)         what the scene adds between the solve and the record:
                                   fracture checks, crack insertion and propagation,
                                   the analyses of a coupled run
            AGAIN: the same step once more (on the model the hook rebuilt)
            LAST:  record this step and end the run (a crack cut through)
        record(k, last)            history rows, fields, growth rows (output)
        checkpoint(k, last)        written when due; True: a signal stops the run
            interrupted(k)         the fields of the last state, then "interrupted"

A hook ends the run early by raising :class:`RunStopped` (status and message); a
:class:`~bonecontact.runners.checkpoint.CheckpointError` (a checkpoint cannot be written)
and the hook's own ``errors`` (a solver that does not converge, a crack whose K cannot be
had) end it ``"failed"`` with the message of :meth:`StepHooks.failure`.  Every other
exception propagates (an input error found on a rebuilt mesh).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from mpi4py import MPI

from tqdm import tqdm

from bonecontact.plot.progress import progress_file
from bonecontact.runners.checkpoint import CheckpointError

__all__ = ["LoopResult", "RunStopped", "StepHooks", "Verdict", "run_steps"]


class Verdict(enum.Enum):
    """What :meth:`StepHooks.after` asks of the loop."""

    NEXT = "next"  # record the step, checkpoint, go on
    AGAIN = "again"  # solve the same step again (the hook rebuilt the model)
    LAST = "last"  # record the step as the last one and end the run


class RunStopped(Exception):
    """Raised by a hook to end the run with ``status`` and ``message``."""

    def __init__(self, status: str, message: str):
        super().__init__(message)
        self.status, self.message = status, message


@dataclass
class LoopResult:
    """How the loop ended: ``status`` (``"converged"``, ``"failed"``, ``"interrupted"``),
    the message (``None`` when converged) and the step it ended at."""

    status: str
    message: str | None
    step: int


class StepHooks:
    """The hooks of one run kind; every hook but :meth:`advance` does nothing by default.

    ``noun`` names a step in messages (``"step"``, ``"growth step"``); ``errors`` are the
    exceptions that fail the run with :meth:`failure`'s message.
    """

    noun = "step"
    errors: tuple[type[BaseException], ...] = (RuntimeError,)

    def start(self) -> None:
        """Record the initial state (a fresh run only)."""

    def advance(self, k: int) -> None:
        """Make step ``k``."""
        raise NotImplementedError

    def after(self, k: int) -> Verdict:
        """What the scene adds after step ``k`` is made (fracture checks, crack insertion
        and growth, analyses)."""
        return Verdict.NEXT

    def record(self, k: int, last: bool) -> None:
        """Write the results of step ``k`` (``last``: the run's last step)."""

    def checkpoint(self, k: int, last: bool) -> bool:
        """A checkpoint after step ``k`` when due; whether a signal asks the run to stop."""
        return False

    def interrupted(self, k: int) -> None:
        """The run stops after step ``k`` by a signal (its checkpoint is written)."""

    def failure(self, k: int, exc: BaseException) -> str:
        """The message of a run failed at step ``k`` by ``exc`` (one of ``errors``)."""
        return f"{self.noun} {k}: {exc}"


def progress_bar(comm: MPI.Comm, name: str, total: int, done: int, progress: bool) -> tqdm:
    """The run's progress bar (rank 0 only, and only with ``progress``; in a notebook one
    display updated in place, :func:`bonecontact.plot.progress_file`)."""
    disable = (comm.rank != 0) or not progress
    return tqdm(
        total=total,
        initial=done,
        desc=name,
        unit="step",
        disable=disable,
        dynamic_ncols=True,
        file=None if disable else progress_file(),
    )


def run_steps(
    hooks: StepHooks, first: int, nsteps: int, bar: tqdm, fresh: bool | None = None
) -> LoopResult:
    """Make steps ``first`` .. ``nsteps`` through ``hooks`` (module docstring; collective).

    A ``fresh`` run (default: ``first == 1``) records the initial state first; a restarted
    run starts after its checkpoint's step.  Returns how the loop ended.
    """
    k = first
    try:
        if first == 1 if fresh is None else fresh:
            hooks.start()
        while k <= nsteps:
            if not _one_step(hooks, k, nsteps, bar):
                return LoopResult("converged", None, k)
            if hooks.checkpoint(k, k == nsteps) and k < nsteps:
                hooks.interrupted(k)
                return LoopResult("interrupted", f"stopped after {hooks.noun} {k} by a signal", k)
            k += 1
    except RunStopped as stop:
        return LoopResult(stop.status, stop.message, k)
    except CheckpointError as exc:
        return LoopResult("failed", str(exc), k)
    except hooks.errors as exc:
        return LoopResult("failed", hooks.failure(k, exc), k)
    finally:
        bar.close()
    return LoopResult("converged", None, nsteps)


def _one_step(hooks: StepHooks, k: int, nsteps: int, bar: tqdm) -> bool:
    """Make and record step ``k`` (again while the hooks ask); ``False``: the run ends here."""
    while True:
        hooks.advance(k)
        verdict = hooks.after(k)
        if verdict is not Verdict.AGAIN:
            break
    last = verdict is Verdict.LAST
    hooks.record(k, k == nsteps or last)
    bar.update(1)
    return not last
