"""The exception bases of bonecontact and the one table of exit statuses (docs/cli.md).

Every exception type of the package derives from one of three bases, and its exit status
is the base's :attr:`BonecontactError.exit_code`:

* :class:`InputError` (also a ``ValueError``): input the package refuses — a scene key, a
  mesh or surface file, an expression; :class:`ParameterError`, one named parameter (a
  material constant, a neoplasm or crack parameter); exit status :attr:`ExitCode.BAD_INPUT`;
* :class:`RunError` (also a ``RuntimeError``): a computation that cannot go on — a solver
  that does not converge, gmsh that cannot mesh, a field transfer that misses the mesh;
  a run reports it as ``"status": "failed"``, exit status :attr:`ExitCode.FAILED`;
* :class:`CheckpointError`: a checkpoint that cannot be found, read or written; refusing
  a restart is :attr:`ExitCode.BAD_INPUT` (nothing is changed), a failed write ends the
  run as ``"failed"`` (:attr:`ExitCode.FAILED`).

This module sits at the bottom of the layers so that every subpackage can use the bases;
:mod:`bonecontact.scene.errors` re-exports it with :class:`~bonecontact.scene.errors.SceneError`.
"""

from __future__ import annotations

import signal
from enum import IntEnum
from typing import ClassVar

__all__ = [
    "EXIT_CODES",
    "BonecontactError",
    "CheckpointError",
    "ExitCode",
    "InputError",
    "ParameterError",
    "RunError",
    "exit_code",
    "exit_code_for_status",
]


class ExitCode(IntEnum):
    """The exit statuses of the ``bonecontact`` command (the table :data:`EXIT_CODES`)."""

    CONVERGED = 0
    FAILED = 1
    BAD_INPUT = 2
    INVALID = 3
    SIGNAL = 128


#: Exit status → meaning: the one table (docs/cli.md shows it).
EXIT_CODES: dict[int, str] = {
    ExitCode.CONVERGED: 'the run converged ("status": "converged"); check found no error',
    ExitCode.FAILED: (
        'the run failed ("status": "failed": a solver did not converge, a step, a remesh '
        "or a checkpoint write failed) or an internal error (every rank stopped)"
    ),
    ExitCode.BAD_INPUT: (
        "invalid input, reported on every rank before anything is written: the scene, "
        "its mesh, materials or tables; an implausible value under --strict; a unit slip "
        "beyond doubt (mesh > 2 m or < 0.1 mm across, modulus < 1 kPa) unless "
        "--allow-implausible; a restart refused (no intact checkpoint, or one of another scene)"
    ),
    ExitCode.INVALID: (
        'the run finished but its result is outside the model\'s validity ("status": '
        '"invalid", results written)'
    ),
    ExitCode.SIGNAL: (
        "128 + N: stopped by signal N after writing a checkpoint (130 SIGINT, 143 SIGTERM)"
    ),
}

#: ``RunResult.status`` → exit status ("interrupted": :func:`exit_code_for_status`).
_STATUS_CODES = {
    "converged": ExitCode.CONVERGED,
    "failed": ExitCode.FAILED,
    "invalid": ExitCode.INVALID,
}


class BonecontactError(Exception):
    """Base of every exception type of bonecontact; :attr:`exit_code` is its exit status."""

    exit_code: ClassVar[int] = ExitCode.FAILED


class InputError(BonecontactError, ValueError):
    """Input that is refused (exit status 2): the message names the item and what is allowed."""

    exit_code: ClassVar[int] = ExitCode.BAD_INPUT


class ParameterError(InputError):
    """A named parameter outside its allowed range (exit status 2): a material constant, a
    fracture input, a tumour or cyst parameter.

    ``str(error)`` is ``where + message``.  The former ``MaterialError``,
    ``FractureError``, ``TumourParameterError`` and ``CystParameterError`` are deprecated
    aliases of this one class.

    Parameters
    ----------
    key
        The offending parameter or key, as named in the scene file or the function call.
    message
        What is wrong and what is allowed, e.g. ``"must be > 0, got 0.0"``.
    where
        The text put before ``message`` in ``str(error)``; ``None``: ``f"{key}: "``.

    Examples
    --------
    >>> str(ParameterError("a", "must be > 0, got 0.0"))
    'a: must be > 0, got 0.0'
    >>> str(ParameterError("E", "must be a positive number, got 0.0", where=""))
    'must be a positive number, got 0.0'
    """

    def __init__(self, key: str, message: str, where: str | None = None):
        self.key = key
        self.message = message
        self.where = f"{key}: " if where is None else where
        super().__init__(f"{self.where}{message}")


class RunError(BonecontactError, RuntimeError):
    """A computation that cannot go on (exit status 1; the run's status ``"failed"``)."""

    exit_code: ClassVar[int] = ExitCode.FAILED


class CheckpointError(BonecontactError):
    """A checkpoint cannot be written, found or read (the message says which and why).

    Raised on every rank.  Refusing a restart is exit status 2; a failed write during a
    run ends it as ``"failed"`` (exit status 1) before it reaches the command.
    """

    exit_code: ClassVar[int] = ExitCode.BAD_INPUT


def exit_code(exc: BaseException) -> int:
    """The exit status of an exception that ends the command.

    :class:`BonecontactError`: its :attr:`~BonecontactError.exit_code`; a warning raised
    as an error (``--strict``): 2; ``KeyboardInterrupt``: 130; anything else (an internal
    error): 1.
    """
    if isinstance(exc, BonecontactError):
        return int(exc.exit_code)
    if isinstance(exc, Warning):
        return int(ExitCode.BAD_INPUT)
    if isinstance(exc, KeyboardInterrupt):
        return int(ExitCode.SIGNAL) + int(signal.SIGINT)
    return int(ExitCode.FAILED)


def exit_code_for_status(status: str, signal_name: str | None = None) -> int:
    """The exit status of a finished run from its ``status`` (summary.json).

    ``"interrupted"``: 128 + the number of ``signal_name`` (``"SIGTERM"``: 143; unknown or
    ``None``: SIGINT, 130).  An unknown status is a failure (1).
    """
    if status == "interrupted":
        number = getattr(signal.Signals, signal_name or "", signal.SIGINT)
        return int(ExitCode.SIGNAL) + int(number)
    return int(_STATUS_CODES.get(status, ExitCode.FAILED))
