"""A coupled run hands each analysis a model in memory (issue #25): no mesh file is read
back and the scene is checked once per run, not once per analysis.

Collective tests (serial session and ``mpiexec -n 2 / -n 3``), a family over the neoplasm
(2D cyst, 2D tumour; the 3D cyst, about 10 s of CPU, is marked ``slow``).  Each run has
two analyses; the test watches

* every gmsh file read (``gmsh.open``, ``gmsh.merge``: how a mesh file is read back) and
  every host-mesh build: no file is read once the first host mesh (the check at t = 0) has
  been built, and the builds are the check plus one per analysis;
* the scene's plausibility check (``check_plausibility``): once per run, on every rank;
  the scene has one implausible value (a cortical modulus of 1 GPa, below the class's
  3 GPa), emitted as one warning, and every analysis's ``summary.json`` still lists it;
* the model of the last analysis against the written ``host_mesh.msh`` read back after
  the run (a second method): the same global number of cells and the same areas
  (volumes) of every cell group to 1e-12, and these against the geometry — the
  square plate's area 4L² (tumour), the scene mesh's measure less the cavity recorded by
  the analysis (cysts).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from mpi4py import MPI

import gmsh
import numpy as np
import pytest
import ufl
from coupled_support import run_text
from dolfinx import fem
from test_coupled import CYST_SCENE, PLATE_SCENE, disc_with_core, plate_with_inclusion
from test_coupled3d import CYST_SCENE as CYST3D_SCENE
from test_coupled3d import ball_with_core

import bonecontact.scene.mesh_checks as mesh_checks
from bonecontact.common.constants import SECONDS_PER_YEAR
from bonecontact.meshing.io import read_gmsh_mesh
from bonecontact.runners import coupled
from bonecontact.scene.checks import PlausibilityWarning

pytestmark = pytest.mark.growth

L_PLATE, R_INCL = 0.01, 0.002
BONE = 'name = "bone"\nregions = ["{}"]\nmodel = "isotropic"\nE = 1000000000.0'
CORTICAL = 'name = "cortical"\nregions = ["{}"]\nmodel = "isotropic"\nE = 1.0e9'


def _cortical(text: str, region: str) -> str:
    """The scene with its bone material named "cortical" (1 GPa: one implausible value)."""
    assert BONE.format(region) in text
    return text.replace(BONE.format(region), CORTICAL.format(region))


def _cyst2d(d: Path) -> tuple[str, Path]:
    mesh = d / "disc.msh"
    disc_with_core(mesh, 0.04, 0.003, 4e-4, 4e-3)
    text = CYST_SCENE.format(
        mesh=mesh,
        E=1.0e9,
        nu=0.3,
        t_end=SECONDS_PER_YEAR / 6,
        dt=SECONDS_PER_YEAR / 12,
        every=1,
        out=d / "out",
    )
    return _cortical(text, "bone"), mesh


def _tumour2d(d: Path) -> tuple[str, Path]:
    mesh = d / "plate.msh"
    plate_with_inclusion(mesh, L_PLATE, R_INCL, 4e-4, 2e-3)
    text = PLATE_SCENE.format(
        mesh=mesh,
        E=1.0e9,
        nu=0.3,
        E_i=1e6,
        nu_i=0.45,
        formulation="displacement",
        sigma0=1e6,
        out=d / "out",
    )
    text = text.replace("t_end = 1.0\ndt = 1.0", "t_end = 2.0\ndt = 1.0\nmechanics_every = 1")
    return _cortical(text, "plate"), mesh


def _cyst3d(d: Path) -> tuple[str, Path]:
    mesh = d / "ball.msh"
    ball_with_core(mesh, 0.02, 0.002, 1.5e-3, 6e-3)
    text = CYST3D_SCENE.format(
        mesh=mesh,
        E=1.0e9,
        nu=0.3,
        t_end=SECONDS_PER_YEAR / 6,
        dt=SECONDS_PER_YEAR / 12,
        every=1,
        out=d / "out",
    )
    return _cortical(text, "bone"), mesh


def _group_measures(mesh, cell_tags, groups: dict[str, tuple[int, int]]) -> dict[str, float]:
    """Area (2D) or volume (3D) of every cell group of a mesh (collective)."""
    tdim = mesh.topology.dim
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags)
    comm = mesh.comm
    return {
        name: comm.allreduce(fem.assemble_scalar(fem.form(1.0 * dx(tag))), op=MPI.SUM)
        for name, (dim, tag) in groups.items()
        if dim == tdim
    }


def _num_cells(mesh) -> int:
    imap = mesh.topology.index_map(mesh.topology.dim)
    return imap.size_global


def _watch(monkeypatch) -> tuple[list[str], list[int]]:
    """Log gmsh file reads and host-mesh builds in order; count plausibility checks."""
    events: list[str] = []
    checks = [0]
    for name in ("open", "merge"):
        real = getattr(gmsh, name)

        def read(path, _real=real, _name=name):
            events.append(f"read {Path(path).name}")
            return _real(path)

        monkeypatch.setattr(gmsh, name, read)
    for name in ("build_host_mesh", "build_host_mesh3d"):
        real = getattr(coupled, name)

        def build(*args, _real=real):
            events.append("build")
            return _real(*args)

        monkeypatch.setattr(coupled, name, build)
    real_check = mesh_checks.check_plausibility

    def check(*args, **kwargs):
        checks[0] += 1
        return real_check(*args, **kwargs)

    monkeypatch.setattr(mesh_checks, "check_plausibility", check)
    return events, checks


@pytest.mark.parametrize(
    "case", ["cyst2d", "tumour2d", pytest.param("cyst3d", marks=pytest.mark.slow)]
)
def test_coupled_analyses_get_the_model_in_memory(case, tmp_shared_path, monkeypatch):
    comm = MPI.COMM_WORLD
    text, scene_mesh = {"cyst2d": _cyst2d, "tumour2d": _tumour2d, "cyst3d": _cyst3d}[case](
        tmp_shared_path
    )
    out = tmp_shared_path / "out"
    events, checks = _watch(monkeypatch)
    with pytest.warns(PlausibilityWarning) as caught:
        res = run_text(text, tmp_shared_path, out)
    monkeypatch.undo()
    assert res.status == "converged", res.summary.get("message")
    records = res.summary["coupling"]["analyses"]
    assert [r["growth_step"] for r in records] == [1, 2]

    # no file read back: every read precedes the first host-mesh build (rank 0 reads)
    assert events.count("build") == 1 + len(records)
    first = events.index("build")
    assert not [e for e in events[first:] if e.startswith("read")], events
    if comm.rank == 0:
        assert events[:first] and all(e == f"read {scene_mesh.name}" for e in events[:first])
    # the scene checked once: one plausibility check, one warning, kept in every analysis
    implausible = [w for w in caught if "implausible value" in str(w.message)]
    assert checks[0] == 1 and len(implausible) == 1
    assert '"cortical" E' in str(implausible[0].message)
    for r in records:
        kept = json.loads((Path(r["directory"]) / "summary.json").read_text())["warnings"]
        assert len(kept) == 1 and '"cortical" E' in kept[0], kept

    # the model in memory against the written result file read back (a second method)
    model = res.integrator.model
    gdim = model.mesh.geometry.dim
    _, md = read_gmsh_mesh(out / "host_mesh.msh", comm, gdim)
    groups = {n: (int(p.dim), int(p.tag)) for n, p in md.physical_groups.items()}
    read_back = _group_measures(md.mesh, md.cell_tags, groups)
    in_memory = _group_measures(model.mesh, model.cell_tags, groups)
    assert _num_cells(model.mesh) == _num_cells(md.mesh) == records[-1]["cells"]
    for name, value in read_back.items():
        assert in_memory[name] == pytest.approx(value, rel=1e-12), name
    total = sum(in_memory.values())
    if case == "tumour2d":
        assert total == pytest.approx(4 * L_PLATE**2, rel=1e-12)
        # gmsh's OCC area of the tumour pieces (measured 1e-6 apart: OCC's tolerance)
        assert in_memory["tumour"] == pytest.approx(records[-1]["neoplasm_area_in_bone"], rel=1e-5)
    else:  # the scene's body less the cavity the analysis recorded
        _, smd = read_gmsh_mesh(scene_mesh, comm, gdim)
        sgroups = {n: (int(p.dim), int(p.tag)) for n, p in smd.physical_groups.items()}
        body = sum(_group_measures(smd.mesh, smd.cell_tags, sgroups).values())
        cavity = records[-1]["neoplasm_area_in_bone" if gdim == 2 else "neoplasm_volume_in_bone"]
        assert total == pytest.approx(body - cavity, rel=1e-9)
    assert math.isfinite(total)
    assert np.all(np.isfinite(res.integrator.u.x.array))
