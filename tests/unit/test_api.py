"""The public API of ``import bonecontact``: the names a notebook needs, one version string."""

from __future__ import annotations

import importlib.metadata
import tomllib
from pathlib import Path

import bonecontact

ROOT = Path(__file__).resolve().parents[2]


def test_version_comes_from_the_package_metadata():
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert bonecontact.__version__ == importlib.metadata.version("bonecontact")
    assert bonecontact.__version__ == pyproject["project"]["version"]


def test_every_exported_name_exists_and_is_what_it_says():
    assert set(bonecontact.__all__) >= {
        "load_scene",
        "run",
        "check",
        "Scene",
        "SceneError",
        "Mechanics",
        "Integrator",
        "ContactSolver",
        "PDASOptions",
        "build_interface",
    }
    for name in bonecontact.__all__:
        assert hasattr(bonecontact, name), name
    from bonecontact.contact.pdas import ContactSolver
    from bonecontact.runners.dispatch import run_scene
    from bonecontact.scene.reader import load_scene

    assert bonecontact.run is run_scene
    assert bonecontact.load_scene is load_scene
    assert bonecontact.ContactSolver is ContactSolver


def test_the_subpackages_stay_importable_by_their_dotted_names():
    import bonecontact.runners.cli as cli

    assert callable(cli.main)
    assert bonecontact.runners.__name__ == "bonecontact.runners"


def test_pdas_options_validate_on_construction():
    opts = bonecontact.PDASOptions(max_iterations=7)
    assert opts.max_iterations == 7
    for bad in ({"max_iterations": 0}, {"strategy": "fastest"}, {"cold_start_fraction": 1.5}):
        try:
            bonecontact.PDASOptions(**bad)
        except ValueError as err:
            assert next(iter(bad)) in str(err)
        else:
            raise AssertionError(f"PDASOptions({bad}) was accepted")
