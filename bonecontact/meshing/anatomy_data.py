"""The human bone surfaces shipped in ``data/anatomy/`` (low-resolution, in metres).

Five closed surfaces from the MyoSuite musculoskeletal model (the ``myo-sim`` package,
version 0.2.3, Apache-2.0; ``data/anatomy/NOTICE`` and ``README.md``): the lumbar vertebrae
L3 and L4 (placed as a pair, L3 on L4), a right femur, a right tibia and a mandible.  They
are visualisation meshes of a few hundred to a few thousand triangles: good for meshing
tests, demonstrations and coarse 3D scenes, not for patient-specific stresses.

They are package data of ``bonecontact.data`` (the repository's ``data/`` folder), read
through :mod:`importlib.resources` (:mod:`bonecontact.common.resources`).
"""

from __future__ import annotations

from importlib.resources.abc import Traversable

from bonecontact.common.resources import data_dir, data_path
from bonecontact.meshing.surface_repair import MeshInputError, Surface, prepare_surface

__all__ = ["ANATOMY_DIR", "ANATOMY_SURFACES", "anatomy_surface"]

#: the folder of the shipped surfaces
ANATOMY_DIR: Traversable = data_dir() / "anatomy"

#: name -> (file, what it is)
ANATOMY_SURFACES = {
    "L3": ("L3.stl", "third lumbar vertebra, in L4's frame (rests on L4)"),
    "L4": ("L4.stl", "fourth lumbar vertebra"),
    "femur": ("femur.stl", "right femur, knee end at y = -0.43 m"),
    "tibia": ("tibia.stl", "right tibia, plateau near y = 0"),
    "mandible": ("mandible.stl", "mandible (lower jaw)"),
}

_ALIASES = {"jaw": "mandible", "l3": "L3", "l4": "L4"}


def anatomy_surface(name: str, size: float | None = None) -> Surface:
    """A shipped bone surface in SI units (m), checked closed, manifold and outward.

    Parameters
    ----------
    name
        ``"L3"``, ``"L4"``, ``"femur"``, ``"tibia"`` or ``"mandible"`` (``"jaw"``).
    size
        If given, remesh to triangles of this edge length (m; pyacvd).

    Raises
    ------
    MeshInputError
        For an unknown name (listing the available ones).
    """
    key = _ALIASES.get(name, name)
    if key not in ANATOMY_SURFACES:
        raise MeshInputError(
            f"no shipped anatomy surface {name!r}; available: {', '.join(ANATOMY_SURFACES)}"
        )
    with data_path("anatomy", ANATOMY_SURFACES[key][0]) as path:
        return prepare_surface(path, size=size)
