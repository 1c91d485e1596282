"""The material library shipped with the package (``data/materials.toml``).

``materials.toml`` holds starting material constants and strengths
(docs/theory/mechanics.md#material-data), each with the published ``source`` it comes
from.  It is package data of ``bonecontact.data`` (the repository's ``data/`` folder),
read through :mod:`importlib.resources` (:mod:`bonecontact.common.resources`).
"""

from __future__ import annotations

import tomllib
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any, NamedTuple

from bonecontact.common.resources import data_dir

__all__ = [
    "DATA_DIR",
    "MATERIALS_FILE",
    "METADATA_KEYS",
    "STRENGTH_KEYS",
    "BoneProperties",
    "load_material_library",
    "load_reference_values",
    "load_strengths",
    "material_strength",
    "stiffness_and_strength",
]

#: the folder of the shipped data (package ``bonecontact.data``; a Path on disk)
DATA_DIR: Traversable = data_dir()
#: the shipped material library
MATERIALS_FILE: Traversable = DATA_DIR / "materials.toml"

#: Keys of a library entry that are documentation, not scene-file material keys.
METADATA_KEYS = ("source", "notes")

#: Strength and toughness keys of a ``[strength.<material>]`` table (Pa, Pa·√m).
STRENGTH_KEYS = ("sigma_t", "sigma_c", "K_Ic")


def _load(path: str | Path | None, section: str) -> dict[str, dict[str, Any]]:
    path = MATERIALS_FILE if path is None else Path(path)
    with path.open("rb") as f:
        doc = tomllib.load(f)
    entries = doc.get(section, {})
    for name, entry in entries.items():
        if not isinstance(entry, dict) or not str(entry.get("source", "")).strip():
            raise ValueError(f"{path}: [{section}.{name}] needs a non-empty 'source' string")
    return entries


def load_material_library(
    path: str | Path | None = None, *, metadata: bool = True
) -> dict[str, dict[str, Any]]:
    """Material entries of the library, by name.

    Parameters
    ----------
    path
        TOML file to read (default: the shipped ``materials.toml``).
    metadata
        Keep the ``source`` and ``notes`` keys.  With ``False`` each entry holds only
        scene-file material keys (``model``, moduli, ``rho``, ``tau_v``), ready to be
        completed with ``name`` and ``regions`` in a scene's ``[[material]]`` table.

    Returns
    -------
    dict
        ``{name: {"model": ..., "E": ..., ..., "source": ...}}``, SI units.

    Raises
    ------
    ValueError
        If an entry has no ``source``.
    """
    entries = _load(path, "material")
    if not metadata:
        entries = {
            name: {k: v for k, v in e.items() if k not in METADATA_KEYS}
            for name, e in entries.items()
        }
    return entries


def load_reference_values(path: str | Path | None = None) -> dict[str, dict[str, Any]]:
    """Other published values of the library (strengths, toughness, friction, pressures), by name.

    Parameters
    ----------
    path
        TOML file to read (default: the shipped ``materials.toml``).

    Returns
    -------
    dict
        ``{name: {quantity: value, ..., "source": ..., "notes": ...}}``, SI units.
    """
    return _load(path, "reference")


def load_strengths(path: str | Path | None = None) -> dict[str, dict[str, Any]]:
    """Strength and toughness tables of the library, by material name.

    Returns
    -------
    dict
        ``{material: {"sigma_t": ..., "sigma_c": ..., "K_Ic": ..., "source": ...}}`` (Pa,
        Pa·√m); a table may lack keys.
    """
    return _load(path, "strength")


def material_strength(
    name: str, keys: tuple[str, ...] = STRENGTH_KEYS, path: str | Path | None = None
) -> dict[str, float]:
    """The strengths of material ``name`` that a fracture check needs.

    Parameters
    ----------
    name
        Material name (a ``[strength.<name>]`` table).
    keys
        The keys the check needs (a subset of :data:`STRENGTH_KEYS`).
    path
        TOML file to read (default: the shipped ``materials.toml``).

    Raises
    ------
    KeyError
        Naming the file, the material and the first missing key, when the table or a
        needed value is missing or not a positive number.
    """
    table = load_strengths(path).get(name, {})
    return {key: _positive(table, key, f"strength.{name}", path) for key in keys}


def _positive(table: dict[str, Any], key: str, where: str, path: str | Path | None) -> float:
    """``table[key]`` as a float, or a KeyError naming the file and ``where.key``."""
    v = table.get(key)
    if not isinstance(v, (int, float)) or not v > 0:
        file = MATERIALS_FILE if path is None else Path(path)
        raise KeyError(f"{file}: {where}.{key}: missing (a positive number is needed)")
    return float(v)


class BoneProperties(NamedTuple):
    """The modulus, Poisson's ratio and tensile strength of one bone (Pa, –, Pa)."""

    E: float
    nu: float
    sigma_t: float


def stiffness_and_strength(name: str, path: str | Path | None = None) -> BoneProperties:
    """E and ν of ``[material.<name>]`` with σ_t of ``[strength.<name>]``: one bone's pair.

    A fracture risk R = σ₁/σ_t is a strain criterion (σ_t/E is the strain at which the
    tissue yields), so the modulus and the strength must come from the same bone; this
    reads both from the same library entry name.

    Parameters
    ----------
    name
        Library name with both a ``[material.<name>]`` and a ``[strength.<name>]`` table.
    path
        TOML file to read (default: the shipped ``materials.toml``).

    Raises
    ------
    KeyError
        Naming the file, the table and the missing key (or the names that have both).
    """
    material, strength = load_material_library(path), load_strengths(path)
    if name not in material or name not in strength:
        where = MATERIALS_FILE if path is None else Path(path)
        both = sorted(set(material) & set(strength))
        raise KeyError(
            f"{where}: no [material.{name}] with [strength.{name}]; names with both: {both}"
        )
    E, nu = (_positive(material[name], k, f"material.{name}", path) for k in ("E", "nu"))
    return BoneProperties(E, nu, _positive(strength[name], "sigma_t", f"strength.{name}", path))
