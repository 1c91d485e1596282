"""Reading one TOML table of a scene: :class:`TableReader`.

A :class:`TableReader` holds one table (or the top level) of the file with the label used
in messages, and reads its values with the checks of their declaration
(:class:`~bonecontact.scene.keys.Key`): types, ranges, allowed values, required keys,
schedules.  Its errors are :class:`~bonecontact.scene.errors.SceneError` naming the table
and the key; :func:`bonecontact.scene.reader.load_scene` adds the file.  Old spellings of
renamed keys are read as their new names with a notice (:func:`deprecation`), which
``load_scene`` issues as a :class:`~bonecontact.scene.keys.SceneDeprecationWarning`
naming the file.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

from bonecontact.scene.errors import SceneError, describe_value, format_choices
from bonecontact.scene.keys import Key, SceneDeprecationWarning, Table
from bonecontact.scene.spec import SCHEDULE_KEYS, Schedule

__all__ = [
    "MISSING",
    "TableReader",
    "array_of_tables",
    "collect_deprecations",
    "deprecation",
    "table_of",
]

#: The deprecation notices of the scene being read (``None``: warn at once).
_NOTICES: ContextVar[list[str] | None] = ContextVar("scene_deprecations", default=None)


def deprecation(label: str | None, key: str, message: str) -> None:
    """A deprecated spelling in table ``label``: collected for :func:`collect_deprecations`
    (``load_scene`` names the file), or a warning at once outside it."""
    where = ", ".join(p for p in (label, f'key "{key}"') if p)
    text = f"{where}: {message} (the old spelling is still read, but will be removed)"
    notices = _NOTICES.get()
    if notices is None:
        warnings.warn(text, SceneDeprecationWarning, stacklevel=3)
    else:
        notices.append(text)


@contextmanager
def collect_deprecations() -> Iterator[list[str]]:
    """Collect the deprecation notices of the tables read in this block."""
    notices: list[str] = []
    token = _NOTICES.set(notices)
    try:
        yield notices
    finally:
        _NOTICES.reset(token)


#: The value of an absent key that is not required.
MISSING: Any = object()


class TableReader:
    """A TOML table being validated, with the label used in messages.

    Parameters
    ----------
    data
        The table as read from TOML.
    label
        Where it is, for messages (``'[analysis]'``, ``'[[contact]] #2 "knee"'``); ``None``
        for the top level of the file.
    """

    def __init__(self, data: Mapping[str, Any], label: str | None):
        self.data = data
        self.label = label
        #: new key -> the old spelling the file used for it (see :meth:`upgrade`)
        self.old_names: dict[str, str] = {}

    def error(self, key: str | None, message: str) -> SceneError:
        """A SceneError on ``key`` of this table (named as the file spells it)."""
        if key in self.old_names:
            old = self.old_names[key]
            return SceneError(
                None, self.label, old, f'{message} ("{old}" is the old name of "{key}")'
            )
        return SceneError(None, self.label, key, message)

    def check_keys(self, table: Table | Sequence[str], what: str = "key") -> None:
        """Every key is one of the declared ``table`` (old spellings read as their new
        names first, :meth:`upgrade`); the message of an unknown key lists the allowed
        ones."""
        if isinstance(table, Table):
            self.upgrade(table)
            allowed: Sequence[str] = table.names
        else:
            allowed = table
        for key in self.data:
            if key not in allowed:
                raise self.error(key, f"unknown {what}; allowed: {', '.join(allowed)}")

    def upgrade(self, table: Table) -> None:
        """Read the old spelling of a renamed key as its new name, with a deprecation
        notice naming the table and the new key (both given: an error)."""
        old_keys = [old for old in table.renamed if old in self.data]
        if not old_keys:
            return
        data = dict(self.data)
        for old in old_keys:
            new = table.renamed[old]
            if new in data:
                raise SceneError(
                    None,
                    self.label,
                    old,
                    f'is the old name of "{new}"; give {new} only (both are given)',
                )
            data[new] = data.pop(old)
            self.old_names[new] = old
            deprecation(self.label, old, f'is the old name of "{new}": write {new} = {data[new]!r}')
        self.data = data

    def has(self, key: str) -> bool:
        """Whether the table gives ``key``."""
        return key in self.data

    def raw(self, key: str, required: bool, why: str = "") -> Any:
        """The value of ``key`` as read (:data:`MISSING` when absent and not required)."""
        if key in self.data:
            return self.data[key]
        if required:
            raise self.error(key, f"missing required key{why}")
        return MISSING

    # scalars -----------------------------------------------------------------------
    def get(self, key: Key, *, required: bool | None = None, why: str = "") -> Any:
        """The value of a declared key, with the checks of its declaration (type, range,
        allowed values) and its default; ``required`` overrides the declaration's."""
        req = key.required if required is None else required
        default = None if key.required else key.default
        if key.type == "string":
            return self.string(key.name, required=req, default=default, choices=key.choices or None)
        if key.type == "boolean":
            return self.boolean(key.name, default=bool(default))
        if key.type == "integer":
            minimum = None if key.minimum is None else int(key.minimum) + int(key.exclusive)
            return self.integer(key.name, required=req, default=default, minimum=minimum, why=why)
        if key.type == "number":
            return self.number(
                key.name,
                required=req,
                default=default,
                positive=key.positive,
                nonnegative=key.nonnegative,
                why=why,
            )
        raise TypeError(f"key {key.name!r} of type {key.type!r} is read by its own reader")

    def as_number(self, key: str, value: Any, what: str = "") -> float:
        """``value`` (of ``key``) as a finite float; ``what`` prefixes the message."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(key, f"{what}must be a number, got {describe_value(value)}")
        x = float(value)
        if not math.isfinite(x):
            raise self.error(key, f"{what}must be a finite number, got {value!r}")
        return x

    def number(
        self,
        key: str,
        *,
        required: bool = False,
        default: float | None = None,
        positive: bool = False,
        nonnegative: bool = False,
        why: str = "",
    ) -> float | None:
        """A finite number (an integer is accepted), with the range asked for."""
        value = self.raw(key, required, why)
        if value is MISSING:
            return default
        x = self.as_number(key, value)
        if positive and x <= 0.0:
            raise self.error(key, f"must be a positive number (> 0), got {value!r}")
        if nonnegative and x < 0.0:
            raise self.error(key, f"must be >= 0, got {value!r}")
        return x

    def integer(
        self,
        key: str,
        *,
        required: bool = False,
        default: int | None = None,
        minimum: int | None = None,
        why: str = "",
    ) -> int | None:
        """An integer (``2.0`` and booleans are refused), at least ``minimum``."""
        value = self.raw(key, required, why)
        if value is MISSING:
            return default
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(key, f"must be an integer, got {describe_value(value)}")
        if minimum is not None and value < minimum:
            what = "a positive integer (>= 1)" if minimum == 1 else f"an integer >= {minimum}"
            raise self.error(key, f"must be {what}, got {value}")
        return value

    def string(
        self,
        key: str,
        *,
        required: bool = False,
        default: str | None = None,
        choices: Sequence[str] | None = None,
    ) -> str | None:
        """A non-empty string, one of ``choices`` when given."""
        value = self.raw(
            key, required, f"; allowed values: {format_choices(choices)}" if choices else ""
        )
        if value is MISSING:
            return default
        if not isinstance(value, str):
            allowed = f" (one of {format_choices(choices)})" if choices else ""
            raise self.error(key, f"must be a string{allowed}, got {describe_value(value)}")
        if choices is not None and value not in choices:
            raise self.error(key, f'must be one of {format_choices(choices)}, got "{value}"')
        if choices is None and not value.strip():
            raise self.error(key, "must be a non-empty string")
        return value

    def boolean(self, key: str, *, default: bool = False) -> bool:
        """``true`` or ``false``."""
        value = self.raw(key, False)
        if value is MISSING:
            return default
        if not isinstance(value, bool):
            raise self.error(key, f"must be true or false, got {describe_value(value)}")
        return value

    def names(self, key: str, *, required: bool = True) -> tuple[str, ...]:
        """A non-empty array of distinct physical-group names."""
        value = self.raw(key, required)
        if value is MISSING:
            return ()
        if not isinstance(value, list):
            hint = f' (write {key} = ["{value}"])' if isinstance(value, str) else ""
            raise self.error(
                key, f"must be an array of physical-group names{hint}, got {describe_value(value)}"
            )
        if not value:
            raise self.error(key, "must name at least one physical group")
        for v in value:
            if not isinstance(v, str) or not v.strip():
                raise self.error(
                    key,
                    "must contain physical-group names (non-empty strings), "
                    f"got {describe_value(v)}",
                )
        seen: set[str] = set()
        for v in value:
            if v in seen:
                raise self.error(key, f'physical group "{v}" is listed twice')
            seen.add(v)
        return tuple(value)

    def vector(
        self, key: str, dim: int, *, required: bool = True, value: Any = MISSING, what: str = ""
    ) -> tuple[float, ...]:
        """``dim`` finite numbers (``value`` instead of the table's value when given)."""
        if value is MISSING:
            value = self.raw(key, required)
        if not isinstance(value, list):
            raise self.error(
                key,
                f"{what}must be an array of {dim} numbers (one per component), "
                f"got {describe_value(value)}",
            )
        if len(value) != dim:
            raise self.error(
                key, f"{what}must have {dim} components (dimension = {dim}), got {len(value)}"
            )
        return tuple(self.as_number(key, v, what) for v in value)

    def schedule(self) -> Schedule | None:
        """The ``ramp`` / ``schedule`` keys; ``None`` when neither is given (or ``ramp = 0``)."""
        ramp = self.get(SCHEDULE_KEYS[0])  # the declared "ramp": a number >= 0 (s)
        pairs = self.raw("schedule", False)
        if pairs is MISSING:
            # ramp = 0 is the documented default: the same as no ramp at all
            return None if not ramp else Schedule.from_ramp(ramp)
        if ramp is not None and ramp > 0.0:
            raise self.error("schedule", "give either ramp > 0 or schedule, not both")
        example = "e.g. [[0.0, 0.0], [1.0, 1.0]]"
        if not isinstance(pairs, list) or not pairs:
            raise self.error(
                "schedule",
                f"must be a non-empty array of [time, factor] pairs ({example}), "
                f"got {describe_value(pairs)}",
            )
        times: list[float] = []
        factors: list[float] = []
        for i, p in enumerate(pairs, start=1):
            if not isinstance(p, list) or len(p) != 2:
                raise self.error(
                    "schedule",
                    f"entry {i} must be a [time, factor] pair ({example}), got {describe_value(p)}",
                )
            times.append(self.as_number("schedule", p[0], f"entry {i}: time "))
            factors.append(self.as_number("schedule", p[1], f"entry {i}: factor "))
        for i in range(1, len(times)):
            if times[i] <= times[i - 1]:
                raise self.error(
                    "schedule",
                    f"times must be strictly increasing, but entry {i + 1} "
                    f"has time {times[i]!r} after {times[i - 1]!r}",
                )
        return Schedule(tuple(times), tuple(factors))


def table_of(doc: Mapping[str, Any], name: str, required: bool) -> TableReader | None:
    """The table ``[name]`` of the document (``None`` when absent and not required)."""
    label = f"[{name}]"
    if name not in doc:
        if required:
            raise SceneError(None, label, None, "missing required table")
        return None
    value = doc[name]
    if not isinstance(value, dict):
        raise SceneError(None, None, name, f"must be a table [{name}], got {describe_value(value)}")
    return TableReader(value, label)


def array_of_tables(doc: Mapping[str, Any], name: str) -> list[dict[str, Any]]:
    """The entries of the array of tables ``[[name]]`` (empty when absent)."""
    if name not in doc:
        return []
    value = doc[name]
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise SceneError(
            None,
            None,
            name,
            f"must be an array of tables (write each entry under [[{name}]]), "
            f"got {describe_value(value)}",
        )
    return value
