"""Which packages the distribution holds; everything else is declared in pyproject.toml.

The repository keeps ``forms/`` (the UFL forms) and ``data/`` (the reference data) at its
top level beside ``bonecontact/``; the distribution installs them as the subpackages
``bonecontact.forms`` and ``bonecontact.data``.  The subpackages of all three folders are
found by setuptools' discovery (:func:`setuptools.find_packages`: every directory with an
``__init__.py``), so a new subpackage is shipped without editing a list.  pyproject.toml
cannot express discovery together with a renamed folder, hence this file.
"""

from setuptools import find_packages, setup

#: Top-level folders installed under another package name: name -> folder.
MAPPED = {"bonecontact.forms": "forms", "bonecontact.data": "data"}


def discovered_packages() -> list[str]:
    """Every package of ``bonecontact/`` and of the mapped folders, by its installed name."""
    names = find_packages(include=["bonecontact", "bonecontact.*"])
    for name, folder in MAPPED.items():
        names += [name, *(f"{name}.{sub}" for sub in find_packages(where=folder))]
    return sorted(names)


setup(packages=discovered_packages(), package_dir={"bonecontact": "bonecontact", **MAPPED})
