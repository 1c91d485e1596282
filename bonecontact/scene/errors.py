"""Errors of scene files: :class:`SceneError` and the helpers that word its messages.

Every problem of a scene is reported as one :class:`SceneError` naming the file, the
table, the key and what is allowed.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from bonecontact.materials.laws import MaterialError

__all__ = ["SceneError", "describe_value", "format_choices", "format_error", "table_label"]


class SceneError(Exception):
    """An invalid scene: one clear message naming the file, the table and the key.

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


def format_error(exc: BaseException) -> str:
    """One-line, user-facing description of an input error.

    Parameters
    ----------
    exc
        Typically a :class:`SceneError`; :class:`~bonecontact.materials.laws.MaterialError`
        and any other exception are formatted too.

    Returns
    -------
    str
        The message, prefixed with ``error: ``.
    """
    if isinstance(exc, SceneError):
        text = str(exc)
    elif isinstance(exc, MaterialError):
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
