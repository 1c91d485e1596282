"""How a scene table is declared: its keys with type, default, unit and allowed values.

Every table of a scene file is declared once, next to its dataclass in
:mod:`bonecontact.scene.spec`, as a :class:`Table` of :class:`Key` entries.  The reader
(:mod:`bonecontact.scene.reader`) takes the allowed keys, the defaults, the ranges and the
allowed values of its checks and error messages from these declarations, and
``tests/unit/scene/test_key_declarations.py`` checks the tables of
``docs/scene_format.md`` against them (every declared key documented with its type, unit
and default; no documented key undeclared).

A key that was renamed stays readable under its old name for a while: the table lists
it in ``renamed`` (old name → new name); :func:`bonecontact.scene.reader.load_scene`
reads it as the new key and warns with a :class:`SceneDeprecationWarning` naming the file,
the table and the new key.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = ["REQUIRED", "Key", "SceneDeprecationWarning", "Table"]


class _Required:
    """The default of a required key."""

    def __repr__(self) -> str:
        return "REQUIRED"


#: The ``default`` of a key that must be given.
REQUIRED: Any = _Required()

#: How the docs name each key type (the first words of the docs' "type" column).
TYPE_LABELS = {
    "string": "string",
    "number": "number",
    "integer": "integer",
    "boolean": "boolean",
    "names": "array of strings",
    "vector": "array",
    "points": "array of points",
    "schedule": "array of pairs",
    "table": "table",
    "number or string": "number or string",
    "number or expression": "number or expression",
    "number or array": "number or array",
    "array": "array",
}


class SceneDeprecationWarning(FutureWarning):
    """A scene uses an old spelling that is still read (the message names the new one)."""


@dataclass(frozen=True)
class Key:
    """One key of a scene table.

    Parameters
    ----------
    name
        The key as written in the file.
    type
        One of :data:`TYPE_LABELS`: ``"string"``, ``"number"``, ``"integer"``,
        ``"boolean"``, ``"names"`` (array of physical-group names), ``"vector"`` (one
        number per component), ``"points"``, ``"schedule"``, ``"table"``, ...
    default
        The value when the key is absent (a TOML value), :data:`REQUIRED`, or ``None``
        (absent means "not given", documented as ``none``).
    unit
        SI unit of a number (``"s"``, ``"Pa"``, ``"m"``, ...); ``""``: dimensionless or
        not a number.
    choices
        The allowed values of a string key (empty: any non-empty string).
    minimum
        The smallest allowed value of a number or integer (``None``: no bound).
    exclusive
        ``minimum`` itself is not allowed (``> minimum`` instead of ``>= minimum``).
    doc_default
        The docs' "default" text when the default is not one TOML value (a default that
        depends on other keys, "required for ...").
    """

    name: str
    type: str
    default: Any = None
    unit: str = ""
    choices: tuple[str, ...] = ()
    minimum: float | None = None
    exclusive: bool = False
    doc_default: str | None = None

    def __post_init__(self) -> None:
        if self.type not in TYPE_LABELS:
            raise ValueError(f"key {self.name!r}: unknown type {self.type!r}")
        if self.choices and self.type != "string":
            raise ValueError(f"key {self.name!r}: choices are for string keys")

    @property
    def required(self) -> bool:
        """Whether the key must be given."""
        return self.default is REQUIRED

    @property
    def positive(self) -> bool:
        """``> 0``."""
        return self.minimum == 0 and self.exclusive

    @property
    def nonnegative(self) -> bool:
        """``>= 0``."""
        return self.minimum == 0 and not self.exclusive

    def doc_type(self) -> str:
        """The docs' "type" column: the type, then the unit (``"number, s"``)."""
        label = TYPE_LABELS[self.type]
        return f"{label}, {self.unit}" if self.unit else label

    def doc_default_text(self) -> str:
        """The docs' "default" column: ``required``, ``none`` or the TOML value in
        backticks (``doc_default`` when given)."""
        if self.doc_default is not None:
            return self.doc_default
        if self.required:
            return "required"
        if self.default is None:
            return "none"
        return f"`{toml_literal(self.default)}`"


def toml_literal(value: Any) -> str:
    """A value as written in TOML (``true``, ``"none"``, ``1e-10``, ``[]``)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, float):
        if math.isfinite(value) and value != 0 and (abs(value) < 1e-3 or abs(value) >= 1e4):
            mantissa, exponent = f"{value:.6g}".split("e")
            return f"{mantissa}e{int(exponent)}"
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_literal(v) for v in value) + "]"
    return str(value)


@dataclass(frozen=True)
class Table:
    """The declaration of one scene table.

    Parameters
    ----------
    name
        The table's name (``"analysis"``, ``"contact"``, ``"neoplasm.tumour"``).
    keys
        Its keys, in the order of the error messages and the docs.
    array
        An array of tables (``[[name]]``) rather than a single table.
    renamed
        Old key → new key: old spellings still read, with a deprecation warning.
    """

    name: str
    keys: tuple[Key, ...]
    array: bool = False
    renamed: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        names = [k.name for k in self.keys]
        if len(set(names)) != len(names):
            raise ValueError(f"[{self.name}]: a key is declared twice")
        for old, new in self.renamed.items():
            if new not in names or old in names:
                raise ValueError(f"[{self.name}]: renamed {old!r} -> {new!r} is not a key")

    @property
    def names(self) -> tuple[str, ...]:
        """The allowed keys, in declaration order."""
        return tuple(k.name for k in self.keys)

    @property
    def label(self) -> str:
        """``[name]`` or ``[[name]]``."""
        return f"[[{self.name}]]" if self.array else f"[{self.name}]"

    def __getitem__(self, name: str) -> Key:
        for k in self.keys:
            if k.name == name:
                return k
        raise KeyError(f"{self.label} has no key {name!r}")

    def __contains__(self, name: object) -> bool:
        return name in self.names

    def default(self, name: str) -> Any:
        """The default of a key (``None`` for a key without one)."""
        value = self[name].default
        return None if value is REQUIRED else value

    def choices(self, name: str) -> tuple[str, ...]:
        """The allowed values of a string key."""
        return self[name].choices

    def with_keys(self, *keys: Key, before: str | None = None) -> Table:
        """This table with more keys (e.g. the constants of a material model), at the end
        or before the key ``before``."""
        at = len(self.keys) if before is None else self.names.index(before)
        return Table(
            self.name, self.keys[:at] + tuple(keys) + self.keys[at:], self.array, self.renamed
        )
