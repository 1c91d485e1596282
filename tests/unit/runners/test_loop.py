"""The one step loop (``bonecontact.runners.loop.run_steps``) against a toy run kind whose
hooks log every call: a family over the number of steps, the first step (a restart), a step
solved again (a crack grown), a last step (a crack cut through), a signal, a failing step
and a hook that stops the run.  What each configuration must give is counted from the
configuration itself (steps first..end recorded once each, in order; one extra solve per
repeat; a checkpoint after every recorded step but the last one of a cut-through run).
Nothing is solved; no MPI communication (runs on every rank alike).
"""

from __future__ import annotations

import itertools

import pytest

from bonecontact.runners.checkpoint import CheckpointError
from bonecontact.runners.loop import RunStopped, StepHooks, Verdict, run_steps


class Toy(StepHooks):
    """Hooks that log their calls; ``again``: steps solved twice; ``last``: the step that
    ends the run; ``signal``: the step after which a signal arrives; ``fail``: the step
    whose solve raises ``error``."""

    noun = "toy step"

    def __init__(self, again=(), last=None, signal=None, fail=None, error=RuntimeError):
        self.again, self.last_at, self.signal = set(again), last, signal
        self.fail, self.error = fail, error
        self.log: list[tuple[str, int]] = []
        self.repeated: set[int] = set()

    def start(self) -> None:
        self.log.append(("start", 0))

    def advance(self, k: int) -> None:
        self.log.append(("advance", k))
        if k == self.fail:
            raise self.error("no convergence")

    def after(self, k: int) -> Verdict:
        if k in self.again and k not in self.repeated:
            self.repeated.add(k)
            return Verdict.AGAIN
        return Verdict.LAST if k == self.last_at else Verdict.NEXT

    def record(self, k: int, last: bool) -> None:
        self.log.append(("record", k))
        self.log.append(("last", int(last)))

    def checkpoint(self, k: int, last: bool) -> bool:
        self.log.append(("checkpoint", k))
        return k == self.signal

    def interrupted(self, k: int) -> None:
        self.log.append(("interrupted", k))

    def failure(self, k: int, exc: BaseException) -> str:
        return f"toy step {k}: {exc}"


class Bar:
    """A progress bar that counts its updates and knows whether it was closed."""

    def __init__(self):
        self.n, self.closed = 0, False

    def update(self, k: int) -> None:
        self.n += k

    def close(self) -> None:
        self.closed = True


def _calls(log, name):
    return [k for n, k in log if n == name]


CASES = list(
    itertools.product(
        (1, 4),  # nsteps
        (1, 2),  # first (2: a restart after step 1)
        ((), (2,)),  # steps solved again
        (None, 3),  # a last step
        (None, 1, 3),  # a signal after this step
    )
)


@pytest.mark.parametrize("n, first, again, last, signal", CASES)
def test_steps_records_and_checkpoints(n, first, again, last, signal):
    hooks = Toy(again, last, signal)
    bar = Bar()
    end = run_steps(hooks, first, n, bar)
    # where the run ends: the last step, a cut-through, or a signal before the last step
    stops = [n]
    if last is not None and first <= last <= n:
        stops.append(last)
    if signal is not None and first <= signal < n:
        stops.append(signal)
    stop = min(stops) if first <= n else first - 1
    steps = list(range(first, stop + 1))
    assert _calls(hooks.log, "start") == ([0] if first == 1 else [])
    assert _calls(hooks.log, "record") == steps
    assert bar.n == len(steps) and bar.closed
    repeats = [k for k in steps if k in again]
    assert len(_calls(hooks.log, "advance")) == len(steps) + len(repeats)
    cut = last in stops and stop == last  # cut through: no checkpoint, no interrupt
    assert _calls(hooks.log, "checkpoint") == (steps[:-1] if cut else steps)
    flags = _calls(hooks.log, "last")  # only the run's last recorded step is marked last
    assert flags == [0] * (len(steps) - 1) + [int(stop == n or cut)] if steps else flags == []
    interrupted = signal is not None and stop == signal and signal < n and not cut
    assert _calls(hooks.log, "interrupted") == ([signal] if interrupted else [])
    if interrupted:
        assert end.status == "interrupted"
        assert end.message == f"stopped after toy step {signal} by a signal"
    else:
        assert (end.status, end.message) == ("converged", None)


@pytest.mark.parametrize("fail", (1, 3))
@pytest.mark.parametrize(
    "error, status, message",
    (
        (RuntimeError, "failed", "toy step {k}: no convergence"),
        (CheckpointError, "failed", "no convergence"),
        (lambda m: RunStopped("invalid", f"stopped: {m}"), "invalid", "stopped: no convergence"),
    ),
)
def test_a_failing_step_ends_the_run_with_its_message(fail, error, status, message):
    hooks = Toy(fail=fail, error=error)
    bar = Bar()
    end = run_steps(hooks, 1, 4, bar)
    assert (end.status, end.message, end.step) == (status, message.format(k=fail), fail)
    assert _calls(hooks.log, "record") == list(range(1, fail))
    assert bar.closed and bar.n == fail - 1


def test_other_errors_are_raised():
    hooks = Toy(fail=2, error=ValueError)
    with pytest.raises(ValueError, match="no convergence"):
        run_steps(hooks, 1, 3, bar := Bar())
    assert _calls(hooks.log, "record") == [1] and bar.closed
