"""The distribution holds every package and every data file the code reads (no wheel built).

setup.py is run by setuptools up to its configuration (``run_setup(stop_after="config")``,
which also reads pyproject.toml), and what it declares is compared with the source tree:

* every folder with an ``__init__.py`` under ``bonecontact/``, ``forms/`` and ``data/`` is a
  package of the distribution, under its installed name, and nothing else is;
* ``forms/`` and ``data/`` are installed as ``bonecontact.forms`` and ``bonecontact.data``;
* every data file the code or the demos read (the material library, the plausibility
  ranges, the neoplasm sets, the bone surfaces and their licence, the shipped scenes and
  the meshes they name) matches a package-data pattern and is found through
  :mod:`importlib.resources`;
* no module of the package finds files through its own location (``__file__``).

The full check (build the wheel, install it into a fresh venv, run scenes and a demo from
outside the checkout) is ``make wheel-check`` (.ci/wheel_check.sh), which CI runs.
"""

from __future__ import annotations

import ast
import glob
import os
import tomllib
from importlib import resources
from pathlib import Path

import pytest

from bonecontact.common.resources import DATA_PACKAGE, data_file
from bonecontact.materials.library import MATERIALS_FILE
from bonecontact.meshing.anatomy_data import ANATOMY_SURFACES
from bonecontact.scene.checks import PLAUSIBILITY_FILE

#: source analysis and configuration: nothing collective, so it runs in the serial session only
pytestmark = pytest.mark.serial

ROOT = Path(__file__).resolve().parents[2]
#: top-level folder -> the package name it is installed as
FOLDERS = {"bonecontact": "bonecontact", "forms": "bonecontact.forms", "data": "bonecontact.data"}


@pytest.fixture(scope="module")
def dist():
    """The distribution as setuptools configures it from setup.py and pyproject.toml."""
    import importlib

    import setuptools  # noqa: F401  (provides distutils, gone from the standard library)

    run_setup = importlib.import_module("distutils.core").run_setup
    cwd = os.getcwd()
    os.chdir(ROOT)  # setup.py's discovery is relative to the repository, as for pip
    try:
        return run_setup("setup.py", script_args=["--name"], stop_after="config")
    finally:
        os.chdir(cwd)


def _source_packages() -> dict[str, str]:
    """Installed package name -> its folder (relative), for every folder with __init__.py."""
    found = {}
    for folder, name in FOLDERS.items():
        for init in sorted((ROOT / folder).rglob("__init__.py")):
            rel = init.parent.relative_to(ROOT / folder)
            if "__pycache__" in rel.parts:
                continue
            found[".".join([name, *rel.parts])] = init.parent.relative_to(ROOT).as_posix()
    return found


SOURCE_PACKAGES = _source_packages()


def test_the_source_tree_has_the_expected_packages() -> None:
    """The walk below sees the packages the import structure relies on (guards the walk)."""
    for name in ("bonecontact", "bonecontact.fracture", "bonecontact.forms", "bonecontact.data"):
        assert name in SOURCE_PACKAGES


@pytest.mark.parametrize("name", sorted(SOURCE_PACKAGES))
def test_every_package_folder_is_in_the_distribution(dist, name: str) -> None:
    assert name in dist.packages, (
        f"{SOURCE_PACKAGES[name]}/ has an __init__.py but setup.py does not ship {name}"
    )


def test_the_distribution_has_no_other_package(dist) -> None:
    assert sorted(dist.packages) == sorted(SOURCE_PACKAGES)


@pytest.mark.parametrize("name, folder", [(n, f) for f, n in FOLDERS.items()])
def test_top_level_folders_are_installed_under_their_package_name(
    dist, name: str, folder: str
) -> None:
    assert dist.package_dir[name] == folder


def _shipped_scenes() -> list[str]:
    return sorted(p.name for p in (ROOT / "data" / "scenes").glob("*.toml"))


def _files_read() -> list[str]:
    """Every file of data/ the package, its checks or the demos open (relative paths)."""
    files = ["materials.toml", "plausibility.toml", "neoplasms.toml"]
    files += [f"anatomy/{f}" for f, _ in ANATOMY_SURFACES.values()]
    files += ["anatomy/NOTICE", "anatomy/LICENSE-Apache-2.0.txt"]
    for name in _shipped_scenes():
        files.append(f"scenes/{name}")
        mesh = tomllib.loads((ROOT / "data" / "scenes" / name).read_text())["scene"].get("mesh")
        if mesh:
            files.append(f"scenes/{mesh}")
    return sorted(set(files))


FILES_READ = _files_read()


def test_the_shipped_scenes_are_found() -> None:
    """Guards the list above: the scenes and their meshes are in it."""
    assert "scenes/knee2d.toml" in FILES_READ and "scenes/knee2d.msh" in FILES_READ
    assert len(_shipped_scenes()) >= 5


def _declared(dist, package: str) -> set[str]:
    """The files of a package's folder matched by its package-data patterns (as setuptools:
    glob relative to the package folder)."""
    folder = dist.package_dir[package]
    matched: set[str] = set()
    for pattern in dist.package_data.get(package, []):
        for path in glob.glob(os.path.join(ROOT, folder, pattern)):
            matched.add(Path(path).relative_to(ROOT / folder).as_posix())
    return matched


@pytest.mark.parametrize("rel", FILES_READ)
def test_every_data_file_read_is_package_data(dist, rel: str) -> None:
    assert rel in _declared(dist, DATA_PACKAGE), (
        f"data/{rel} is read by the code but no pattern of pyproject.toml's "
        f"[tool.setuptools.package-data] {DATA_PACKAGE!r} ships it"
    )
    assert resources.files(DATA_PACKAGE).joinpath(rel).is_file()


def test_no_script_or_build_file_is_package_data(dist) -> None:
    """The scripts that made the data stay in the repository (they are not package data)."""
    assert not {f for f in _declared(dist, DATA_PACKAGE) if f.endswith(".py")}


@pytest.mark.parametrize(
    "item, rel", [(MATERIALS_FILE, "materials.toml"), (PLAUSIBILITY_FILE, "plausibility.toml")]
)
def test_the_code_reads_the_package_data(item, rel: str) -> None:
    """The library and the plausibility ranges are the files of bonecontact.data."""
    assert Path(str(item)) == Path(str(resources.files(DATA_PACKAGE).joinpath(rel)))


def test_a_missing_data_file_is_a_clear_error() -> None:
    with pytest.raises(FileNotFoundError, match=r"anatomy/nope\.stl.*bonecontact\.data"):
        data_file("anatomy", "nope.stl")


def _uses_file_location(path: Path) -> bool:
    """Whether the module's code names ``__file__`` (in its code, not in text)."""
    text = path.read_text()
    return "__file__" in text and any(
        isinstance(node, ast.Name) and node.id == "__file__"
        for node in ast.walk(ast.parse(text, filename=str(path)))
    )


@pytest.mark.parametrize("folder", ["bonecontact", "forms"])
def test_no_module_finds_files_through_its_own_location(folder: str) -> None:
    """``Path(__file__).parents[2] / "data"`` works only in a checkout: data are read
    through importlib.resources (bonecontact.common.resources)."""
    offenders = [
        p.relative_to(ROOT).as_posix()
        for p in sorted((ROOT / folder).rglob("*.py"))
        if _uses_file_location(p)
    ]
    assert not offenders, f"modules using __file__ to find files: {offenders}"
