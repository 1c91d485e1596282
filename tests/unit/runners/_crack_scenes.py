"""What the crack-scene tests share: the folder of one run, a scene written and run
in-process (on ``MPI.COMM_WORLD`` or on rank 0 alone for a serial reference), the 2D
plate held at its bottom-left corner with the head of its scenes, the plate of the 3D
surface-crack scenes with its scene text, and a growth run's serial reference with its
copies continued from a checkpoint (the restart tests).

Not a test module (no ``test_`` prefix); the runner tests import it by name (pytest puts
this folder on ``sys.path``).
"""

from __future__ import annotations

import json
import math
import shutil
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
import serial_store
from coupled_support import gmsh_on_rank0

from bonecontact.runners import RunResult, run_scene
from bonecontact.scene import load_scene
from bonecontact.verification.problems import crack_block_model

L = 1e-3  # the surface-crack plate in millimetres
PLATE_B = PLATE_H = 2.5 * L


def run_dir(base: Path, name: str) -> Path:
    """``base/name``, made on rank 0 (every rank waits for it)."""
    d = base / name
    if MPI.COMM_WORLD.rank == 0:
        d.mkdir(parents=True, exist_ok=True)
    MPI.COMM_WORLD.barrier()
    return d


def write_scene(path: Path, text: str) -> Path:
    """``text`` written to ``path`` on rank 0 (every rank waits for it)."""
    if MPI.COMM_WORLD.rank == 0:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    MPI.COMM_WORLD.barrier()
    return path


def run_serial_on_rank0(scene: Path, out: Path, **kw) -> RunResult | None:
    """The scene run on rank 0 alone (``MPI.COMM_SELF``): the serial reference of a
    distributed run in the same session (the other ranks get ``None`` and sleep; they do
    not compile the same forms at the same time).  A run of the same scene with the same
    code kept by an earlier session of ``make test`` is copied instead
    (:mod:`serial_store`)."""
    res = None
    if MPI.COMM_WORLD.rank == 0:
        res = serial_store.fetch(scene, out, **kw)  # kept by an earlier session of make test
        if res is None:
            res = run_scene(load_scene(scene), MPI.COMM_SELF, output=out, progress=False, **kw)
            serial_store.keep(scene, out, **kw)
    idle_barrier(MPI.COMM_WORLD)
    return res


def block_mesh(tmp_path_factory, name: str, half_width: float) -> Path:
    """A fresh folder (the same on every rank) holding ``block.msh``, the block
    [−W, W]³ of the interior-crack scenes (``crack_block_model``, W = ``half_width``)."""
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp(name)) if comm.rank == 0 else None))
    gmsh_on_rank0(lambda gmsh: crack_block_model(half_width), d / "block.msh", 3)
    return d


def run_in(base: Path, name: str, text: str) -> tuple[RunResult, Path]:
    """The scene ``text`` written to ``base/name/scene.toml`` and run on every rank into
    ``base/name/out`` (on one rank, kept as a serial reference: :mod:`serial_store`)."""
    d = run_dir(base, name)
    scene = write_scene(d / "scene.toml", text)
    res = run_scene(load_scene(scene), MPI.COMM_WORLD, output=d / "out", progress=False)
    if MPI.COMM_WORLD.size == 1:
        serial_store.keep(scene, d / "out")  # the serial reference of the MPI sessions
    return res, d


def run_compared(base: Path, name: str, text: str) -> tuple[dict, Path]:
    """:func:`run_in` (converged), and on several ranks the distributed run compared with
    the serial one (fracture.csv to 1e-9, the growth's stop and increments); returns the
    summary's ``fracture`` and the output folder."""
    res, d = run_in(base, name, text)
    assert res.status == "converged", res.summary.get("message")
    ser = serial_reference(d)
    idle_barrier(MPI.COMM_WORLD)
    out = d / "out"
    fracture = res.summary["fracture"]
    if MPI.COMM_WORLD.size > 1:
        same_tables(out / "fracture.csv", ser / "fracture.csv", rtol=1e-9)
        want = json.loads((ser / "summary.json").read_text())["fracture"]["growth"]
        assert fracture["growth"]["status"] == want["status"]
        assert fracture["growth"]["increments"] == want["increments"]
    return fracture, out


def serial_reference(d: Path) -> Path:
    """The serial run of ``d/scene.toml`` whose distributed run wrote ``d/out``: on one
    rank that run itself, else the scene run on rank 0 alone into ``d/ser``."""
    if MPI.COMM_WORLD.size == 1:
        return d / "out"
    ser = run_serial_on_rank0(d / "scene.toml", d / "ser")
    if ser is not None:
        assert ser.status == "converged", ser.summary.get("message")
    return d / "ser"


def same_growth(out: Path, ref: Path, length: float) -> tuple[dict, dict]:
    """The growth run in ``out`` equals the one in ``ref``: fracture.csv to 1e-10
    (:func:`same_tables`), the stop, the cycles (fatigue) to 1e-10 and the final front to
    1e-10 ``length``; returns both summaries' ``fracture``.  Every rank waits for rank 0
    first: it writes summary.json after the run's last collective."""
    idle_barrier(MPI.COMM_WORLD)
    same_tables(out / "fracture.csv", ref / "fracture.csv")
    got = json.loads((out / "summary.json").read_text())["fracture"]
    want = json.loads((ref / "summary.json").read_text())["fracture"]
    assert got["growth"]["status"] == want["growth"]["status"]
    assert got["growth"]["increments"] == want["growth"]["increments"]
    cycles = want["growth"].get("cycles")
    if cycles is not None:
        assert abs(got["growth"]["cycles"] - cycles) <= 1e-10 * cycles
    front = np.asarray(want["crack"]["front"])
    np.testing.assert_allclose(got["crack"]["front"], front, rtol=0, atol=1e-10 * length)
    return got, want


def uninterrupted_run(tmp_path_factory, name: str, scene_text) -> Path:
    """A fresh folder ``name`` (the same on every rank) holding ``plate.msh`` (the plate
    1 mm thick: :func:`surface_plate`), ``scene.toml`` (``scene_text(plate.msh)``) and
    ``full``: that scene's serial run (on rank 0 alone when the session has more ranks;
    on one rank the run itself, kept for them: :mod:`serial_store`), converged."""
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(str(tmp_path_factory.mktemp(name)) if comm.rank == 0 else None))
    gmsh_on_rank0(surface_plate(1.0 * L), d / "plate.msh", 3)
    scene = write_scene(d / "scene.toml", scene_text(d / "plate.msh"))
    if comm.size > 1:
        res = run_serial_on_rank0(scene, d / "full")  # kept by the serial session if it ran
    else:
        res = run_scene(load_scene(scene), comm, output=d / "full", progress=False)
        serial_store.keep(scene, d / "full")
    if res is not None:
        assert res.status == "converged", res.summary.get("message")
    comm.barrier()
    return d


def copied_run(run: Path, out: Path, surfaces: bool = True) -> Path:
    """The run folder ``run`` copied to ``out`` (replacing it) by rank 0, without its
    crack surfaces (``crack_surface_*.vtk``) unless ``surfaces``; every rank waits for
    the copy (before any reads it)."""
    if MPI.COMM_WORLD.rank == 0:
        shutil.rmtree(out, ignore_errors=True)
        shutil.copytree(run, out)
        for vtk in [] if surfaces else out.glob("crack_surface_*.vtk"):
            vtk.unlink()
    MPI.COMM_WORLD.barrier()
    return out


def continued_run(d: Path, serial: Path, k: int) -> tuple[RunResult, Path]:
    """The growth run ``serial`` copied to ``d/continued<k>`` and continued there on every
    rank from its checkpoint before increment ``k`` (``d/scene.toml``).

    The comparison with ``serial`` can fail: ``k`` > 0; the copy's crack surfaces (one
    ``crack_surface_<i>.vtk`` per solve) are removed before the restart and the continued
    run must write exactly those of increments k, k + 1, … (it resumed at k, not at 0);
    and the K columns of fracture.csv change from each increment to the next by more than
    1e-6 of the largest |K| (point by point, or each mode's largest |K| when the front's
    point count changed: the rows the restart solved again are not copies of the
    checkpoint's)."""
    assert k > 0
    out = copied_run(serial, d / f"continued{k}", surfaces=False)
    ck = out / "checkpoints" / f"increment_{k:05d}"
    res = run_scene(
        load_scene(d / "scene.toml"), MPI.COMM_WORLD, output=out, progress=False, restart=ck
    )
    assert res.status == "converged", res.summary.get("message")
    idle_barrier(MPI.COMM_WORLD)
    solved = sorted(int(p.stem.rsplit("_", 1)[1]) for p in out.glob("crack_surface_*.vtk"))
    last = json.loads((out / "summary.json").read_text())["fracture"]["growth"]["increments"]
    assert solved == list(range(k, last + 1)), (k, solved)
    t = read_table(out / "fracture.csv")
    scale = column_scale("K_I", t)
    for i in range(1, last + 1):
        before, now = t["increment"] == i - 1, t["increment"] == i
        K = [np.stack([t[c][sel] for c in ("K_I", "K_II", "K_III")]) for sel in (before, now)]
        if K[0].shape == K[1].shape:
            change = np.abs(K[1] - K[0]).max()
        else:  # the front gained or lost points: compare each mode's largest |K|
            change = np.abs(np.abs(K[1]).max(axis=1) - np.abs(K[0]).max(axis=1)).max()
        assert change > 1e-6 * scale, f"K unchanged at increment {i}"
    return res, out


def idle_barrier(comm: MPI.Comm, pause: float = 0.02) -> None:
    """A barrier whose waiting ranks sleep (a blocking MPI barrier polls, taking a core
    from the rank they wait for when the ranks outnumber the cores)."""
    req = comm.Ibarrier()
    while not req.Test():
        time.sleep(pause)


def pinned_plate(x0: float, x1: float, half_height: float, pin: float, h: float):
    """The gmsh builder (geo kernel, element size ``h``) of the 2D plate
    [x0, x1] × [−H, H] of the crack scenes: cell group "plate" and the edge groups pin_y
    (the first ``pin`` of the bottom edge), bottom, right, top, left and pin_x (the
    lowest ``pin`` of the left edge), which hold the rigid motions at the bottom-left
    corner (a uniform stress state satisfies them exactly)."""
    H = half_height

    def build(gmsh) -> None:
        geo = gmsh.model.geo
        corners = [(x0, -H), (x0 + pin, -H), (x1, -H), (x1, H), (x0, H), (x0, -H + pin)]
        p = [geo.addPoint(x, y, 0, h) for x, y in corners]
        lines = [geo.addLine(p[i], p[(i + 1) % 6]) for i in range(6)]
        geo.addPlaneSurface([geo.addCurveLoop(lines)])
        geo.synchronize()
        gmsh.model.addPhysicalGroup(2, [1], 1, name="plate")
        names = ("pin_y", "bottom", "right", "top", "left", "pin_x")
        for k, (name, line) in enumerate(zip(names, lines, strict=True)):
            gmsh.model.addPhysicalGroup(1, [line], 2 + k, name=name)

    return build


#: The head of a scene of the :func:`pinned_plate` (a template): cortical bone
#: ("material": more material keys, e.g. ``K_Ic = …``, or empty), held on pin_x and
#: pin_y, traction σ on top and −σ (``minus_sigma``) on bottom; a module appends its
#: crack, fracture and output tables.
PINNED_PLATE_HEAD = """format = 1
[scene]
name = "{name}"
mesh = "{mesh}"
dimension = 2
[analysis]
kind = "static"
load_steps = {steps}
[[material]]
name = "cortical"
regions = ["plate"]
model = "isotropic"
E = {E}
nu = {nu}
sigma_t = 133e6
{material}
[[dirichlet]]
boundary = "pin_x"
value = [0.0, "free"]
[[dirichlet]]
boundary = "pin_y"
value = ["free", 0.0]
[[traction]]
boundary = "top"
value = [0.0, {sigma}]
[[traction]]
boundary = "bottom"
value = [0.0, {minus_sigma}]
"""


def surface_plate(t: float, size: float = 0.4 * L):
    """The gmsh builder of the plate [−b, b] × [−h, h] × [−t, 0] (b = h = 2.5 mm) of the
    surface-crack scenes: cell group "plate", facet groups top, bottom, left, right, back,
    front and a 0.5 × 0.5 mm patch "pin" in the middle of the bottom face; boundary
    facets ``size``."""

    def build(gmsh) -> None:
        occ = gmsh.model.occ
        box = occ.addBox(-PLATE_B, -PLATE_H, -t, 2 * PLATE_B, 2 * PLATE_H, t)
        w = min(0.5 * L, 0.6 * t)
        pin = occ.addRectangle(-0.25 * L, -0.5 * (t + w), 0.0, 0.5 * L, w)
        occ.rotate([(2, pin)], 0, 0, 0, 1, 0, 0, 0.5 * math.pi)  # into the plane y = 0
        occ.translate([(2, pin)], 0.0, -PLATE_H, 0.0)
        occ.fragment([(3, box)], [(2, pin)])
        occ.synchronize()
        gmsh.model.addPhysicalGroup(3, [t_ for _, t_ in gmsh.model.getEntities(3)], 1, name="plate")
        groups: dict[str, list[int]] = {}
        for _, s in gmsh.model.getEntities(2):
            x, y, z = occ.getCenterOfMass(2, s)
            area = occ.getMass(2, s)
            if abs(y + PLATE_H) < 1e-9 * L and area < 0.26 * L**2:
                name = "pin"
            else:
                hits = {
                    "bottom": abs(y + PLATE_H),
                    "top": abs(y - PLATE_H),
                    "left": abs(x + PLATE_B),
                    "right": abs(x - PLATE_B),
                    "back": abs(z + t),
                    "front": abs(z),
                }
                name = min(hits, key=hits.get)
            groups.setdefault(name, []).append(s)
        for k, (name, tags) in enumerate(sorted(groups.items()), start=2):
            gmsh.model.addPhysicalGroup(2, tags, k, name=name)
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)

    return build


#: A semi-elliptical ``[[crack]]`` "mouth" (normal y) in the plate of :func:`surface_plate`
#: under traction S on top and −S on bottom, held on "pin".
SURFACE_SCENE = """format = 1
[scene]
name = "surface_crack"
mesh = "{mesh}"
dimension = 3
[analysis]
kind = "static"
load_steps = 1
[[material]]
name = "bone"
regions = ["plate"]
model = "isotropic"
E = {E}
nu = {nu}
sigma_t = 133e6
K_Ic = {K_Ic}
[[dirichlet]]
boundary = "pin"
value = [0.0, 0.0, 0.0]
[[traction]]
boundary = "top"
value = [0.0, {S}, 0.0]
[[traction]]
boundary = "bottom"
value = [0.0, {minus_S}, 0.0]
[fracture]
tip_size = {h}
tip_grading = 0.12
{growth}
[[crack]]
name = "mouth"
shape = "semi_elliptical"
centre = {centre}
normal = [0.0, 1.0, 0.0]
depth = {a}
half_length = {c}
region = "plate"
front_points = {points}
[output]
fields_every = 0
"""


def surface_scene(mesh: Path, **kw) -> str:
    """:data:`SURFACE_SCENE` for ``mesh``: cortical bone (E = 17 GPa, ν = 0.3), S = 1 MPa,
    a = c = 0.2 mm at the middle of the front face, front a/10, 5 points, K_Ic = 1 GPa√m
    (no growth); ``kw`` replaces any of the placeholders."""
    a = 0.2 * L
    v = {
        "mesh": str(mesh),
        "E": 17.0e9,
        "nu": 0.3,
        "K_Ic": 1e9,
        "S": 1.0e6,
        "minus_S": -1.0e6,
        "h": a / 10,
        "growth": "",
        "centre": "[0.0, 0.0, 0.0]",
        "a": a,
        "c": a,
        "points": 5,
    }
    v.update(kw)
    return SURFACE_SCENE.format(**v)


def read_table(path: Path) -> dict[str, np.ndarray]:
    """The numeric columns of a CSV table (the crack-name column left out)."""
    with open(path) as f:
        names = f.readline().strip().split(",")
    raw = np.loadtxt(path, delimiter=",", dtype=str, skiprows=1, ndmin=2)
    out = {}
    for j, name in enumerate(names):
        try:
            out[name] = raw[:, j].astype(float)
        except ValueError:
            out[name] = raw[:, j]
    return out


def column_scale(key: str, table: dict[str, np.ndarray]) -> float:
    """What a column is measured against: the largest |K| of the table for every K column
    (a mode that vanishes by symmetry, or the cross-check of a closed crack, is round-off
    of the others), 360 for angles, else the column's largest magnitude."""
    if key.startswith("K_"):
        cols = [table[k] for k in table if k.startswith("K_") and table[k].dtype.kind == "f"]
        return float(np.max(np.abs(np.concatenate(cols))))
    if key.endswith("_deg"):
        return 360.0
    return float(np.max(np.abs(table[key]), initial=0.0)) or 1.0


def same_tables(got: Path, ref: Path, rtol: float = 1e-10) -> None:
    """Every column of ``got`` equals ``ref``'s: text exactly, numbers to rtol of their
    scale (:func:`column_scale`)."""
    a, b = read_table(got), read_table(ref)
    assert list(a) == list(b)
    for key, col in b.items():
        assert a[key].shape == col.shape, key
        if col.dtype.kind in "US":
            assert list(a[key]) == list(col), key
            continue
        scale = column_scale(key, b)
        np.testing.assert_allclose(a[key], col, rtol=rtol, atol=rtol * scale, err_msg=key)
