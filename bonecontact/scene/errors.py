"""Errors of scene files and the one exit-status table of the ``bonecontact`` command.

Every problem of a scene is reported as one :class:`SceneError` naming the file, the
table, the key and what is allowed.

:data:`EXIT_CODES` says what each exit status means (docs/scene_format.md, *Exit status*);
:data:`ERROR_EXIT_CODES` maps every exception type of the package to one of them, and
:func:`exit_code` gives the status of an exception that ends the command.  The bases
(:class:`~bonecontact.common.errors.InputError`, :class:`~bonecontact.common.errors.RunError`)
live in :mod:`bonecontact.common.errors`, below every layer; new exception types derive
from them and need no entry here.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any, ClassVar

from bonecontact.common.errors import (
    EXIT_CODES,
    BonecontactError,
    CheckpointError,
    ExitCode,
    InputError,
    ParameterError,
    RunError,
    exit_code_for_status,
)
from bonecontact.common.errors import exit_code as base_exit_code
from bonecontact.contact import ContactConvergenceError, ContactInputError, SingularActiveSetError
from bonecontact.meshing import MeshingError, MeshInputError
from bonecontact.neoplasm import CouplingError
from bonecontact.scene.expressions import ExpressionError

__all__ = [
    "ERROR_EXIT_CODES",
    "EXIT_CODES",
    "BonecontactError",
    "CheckpointError",
    "ExitCode",
    "InputError",
    "ParameterError",
    "RunError",
    "SceneError",
    "describe_value",
    "error_exit_code",
    "exit_code",
    "exit_code_for_status",
    "format_choices",
    "format_error",
    "table_label",
]


class SceneError(BonecontactError):
    """An invalid scene: one clear message naming the file, the table and the key (exit
    status 2; raised on every rank).

    Parameters
    ----------
    file
        The scene file (as given by the user), or ``None`` when unknown.
    table
        Where in the file, e.g. ``'[analysis]'`` or ``'[[material]] #2 "cortical"'``
        (``#n`` counts the entries of an array of tables from 1); ``None`` for the
        top level of the file or for errors that concern the file as a whole.
    key
        The offending key, or ``None``.
    message
        What is wrong and what is allowed.

    Examples
    --------
    >>> str(SceneError("scene.toml", '[[material]] #2 "cortical"', "nu",
    ...                "must satisfy -1 < nu < 0.5, got 0.5"))
    'scene.toml: [[material]] #2 "cortical", key "nu": must satisfy -1 < nu < 0.5, got 0.5'
    """

    exit_code: ClassVar[int] = ExitCode.BAD_INPUT

    def __init__(self, file: str | Path | None, table: str | None, key: str | None, message: str):
        file = None if file is None else str(file)
        super().__init__(file, table, key, message)
        self.file = file
        self.table = table
        self.key = key
        self.message = message

    def __str__(self) -> str:
        where = ", ".join(
            p for p in (self.table, None if self.key is None else f'key "{self.key}"') if p
        )
        text = f"{where}: {self.message}" if where else self.message
        return f"{self.file}: {text}" if self.file else text

    def with_file(self, file: str | Path) -> SceneError:
        """A copy of this error attributed to ``file``."""
        return SceneError(file, self.table, self.key, self.message)


#: Exception type -> exit status, the most specific first (:func:`exit_code` takes the
#: first type the exception is an instance of).  Input the package refuses is 2, a
#: computation that cannot go on is 1 (a run reports it as ``"status": "failed"``).
ERROR_EXIT_CODES: dict[type[BaseException], ExitCode] = {
    SceneError: ExitCode.BAD_INPUT,
    CheckpointError: ExitCode.BAD_INPUT,
    ParameterError: ExitCode.BAD_INPUT,
    ExpressionError: ExitCode.BAD_INPUT,
    ContactInputError: ExitCode.BAD_INPUT,
    MeshInputError: ExitCode.BAD_INPUT,
    InputError: ExitCode.BAD_INPUT,
    ContactConvergenceError: ExitCode.FAILED,
    SingularActiveSetError: ExitCode.FAILED,
    MeshingError: ExitCode.FAILED,
    CouplingError: ExitCode.FAILED,
    RunError: ExitCode.FAILED,
}


def error_exit_code(kind: type[BaseException]) -> int | None:
    """The exit status of the exception type ``kind``: its row of :data:`ERROR_EXIT_CODES`
    (the first row it is a subclass of), else its ``exit_code`` attribute; ``None`` for a
    type the package does not define (an internal error)."""
    for row, code in ERROR_EXIT_CODES.items():
        if issubclass(kind, row):
            return int(code)
    return getattr(kind, "exit_code", None)


def exit_code(exc: BaseException) -> int:
    """The exit status of an exception that ends the command: :func:`error_exit_code` of
    its type; else a warning raised as an error (``--strict``) 2, ``KeyboardInterrupt``
    130, anything else (an internal error) 1."""
    code = error_exit_code(type(exc))
    return base_exit_code(exc) if code is None else code


def format_error(exc: BaseException) -> str:
    """One-line, user-facing description of an input error.

    Parameters
    ----------
    exc
        Typically a :class:`SceneError`; a material's
        :class:`~bonecontact.common.errors.ParameterError` and any other exception are
        formatted too.

    Returns
    -------
    str
        The message, prefixed with ``error: ``.
    """
    if isinstance(exc, SceneError):
        text = str(exc)
    elif isinstance(exc, ParameterError) and not exc.where:  # a material constant
        text = f'key "{exc.key}": {exc.message}'
    else:
        text = f"{type(exc).__name__}: {exc}"
    return f"error: {text}"


def describe_value(value: Any) -> str:
    """How a TOML value looks to the user, for messages (e.g. ``'string "x"'``)."""
    if isinstance(value, bool):
        return f"boolean {str(value).lower()}"
    if isinstance(value, str):
        return f'string "{value}"'
    if isinstance(value, int):
        return f"integer {value}"
    if isinstance(value, float):
        return f"number {value!r}"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        n = len(value)
        return f"an array of {n} {'entry' if n == 1 else 'entries'}" if n else "an empty array"
    return f"{type(value).__name__} {value!r}"


def format_choices(options: Iterable[str]) -> str:
    """The allowed values of a key for messages: ``'"a", "b"'``."""
    return ", ".join(f'"{o}"' for o in options)


def table_label(name: str, i: int, entry_name: Any = None) -> str:
    """Label of entry ``i`` (from 0) of the array of tables ``[[name]]``: ``'[[name]] #2 "x"'``."""
    label = f"[[{name}]] #{i + 1}"
    if isinstance(entry_name, str) and entry_name:
        label += f' "{entry_name}"'
    return label
