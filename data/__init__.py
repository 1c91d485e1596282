"""Reference data of bonecontact, installed as the package ``bonecontact.data``.

The repository keeps this folder at its top level; the distribution installs it as
``bonecontact.data`` (setup.py, pyproject.toml's package data), and the code reads its
files through :mod:`importlib.resources` (:mod:`bonecontact.common.resources`):

* ``materials.toml`` — material constants and strengths with their sources;
* ``plausibility.toml`` — the plausible ranges the scene checks compare against;
* ``neoplasms.toml`` — growth parameter sets of tumours and cysts;
* ``anatomy/`` — five bone surfaces (STL) with their licence;
* ``scenes/`` — the example scenes and their meshes.
"""
