"""Files shipped with the package: the reference data of ``bonecontact.data``.

The repository keeps them in its top-level ``data/`` folder, which the distribution
installs as the package ``bonecontact.data`` (setup.py and the package data of
pyproject.toml), so a wheel carries them and an editable install reads them in place.
They are found through :mod:`importlib.resources`, never through the source tree.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path

__all__ = ["DATA_PACKAGE", "data_dir", "data_file", "data_path"]

#: the package that holds the shipped data (the repository's ``data/`` folder)
DATA_PACKAGE = "bonecontact.data"


def data_dir() -> Traversable:
    """The folder of the shipped data (a :class:`pathlib.Path` for an installation on disk)."""
    return resources.files(DATA_PACKAGE)


def data_file(*parts: str) -> Traversable:
    """A shipped data file, e.g. ``data_file("anatomy", "L3.stl")``.

    Raises
    ------
    FileNotFoundError
        If the installation does not hold it (naming the file and the package).
    """
    item = data_dir().joinpath(*parts)
    if not item.is_file():
        raise FileNotFoundError(
            f"{'/'.join(parts)}: not found in the package {DATA_PACKAGE} ({data_dir()}); "
            "the installation is incomplete (reinstall bonecontact)"
        )
    return item


@contextmanager
def data_path(*parts: str) -> Iterator[Path]:
    """A shipped data file as a path on disk, for readers that need one (meshio, gmsh).

    A context manager: for an installation on disk it yields the file itself; from a zip
    archive, a temporary copy removed on exit.
    """
    with resources.as_file(data_file(*parts)) as path:
        yield path
