"""Rigid motions that no support and no contact holds (bonecontact.scene.rigid_motions).

A family of scenes on four meshes, each against the motions that mechanics says are left
free (docs/theory/rigid_motions.md):

* a hemisphere (R = 10 mm, centre (0, R, 0)) on a clamped block: with x and z fixed on
  its flat loaded face, the rotations about the axes through the centre of curvature
  along x and z are free (frictionless contact changes no gap); contact alone leaves the
  three rotations about the centre; no contact and no support leaves all six motions,
  the rotations about the axes through the centroid (0, 5R/8, 0); a clamped face, the
  internal lateral supports or Coulomb friction hold everything;
* its plane-strain twin, the half disc: x fixed on the loaded edge leaves the rotation
  about the centre (0, R) (the configuration of issue #23 item 1);
* a box on a box (flat on flat, frictionless): the normal contact holds the tilts and the
  vertical translation; the in-plane translations and the rotation about the vertical
  axis are free unless fixed;
* three stacked blocks (a chain of contacts) with the bottom one clamped: the middle
  block is held through the contacts when its neighbours are, and its sliding is free
  when nothing fixes it.

The motions are compared as data (kind, direction, axis point against the independent
geometric value) and one report as text.  Every case runs on 1, 2 and 3 ranks (the MPI
sessions) with the same expected report, and each shipped scene passes ``check``
(tests/unit/runners/test_cli.py runs ``bonecontact check`` on them).
"""

from __future__ import annotations

import shutil
import tempfile
import warnings
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

from bonecontact.meshing import shapes
from bonecontact.runners.cli import main as cli_main
from bonecontact.runners.dispatch import run_scene
from bonecontact.runners.mechanics import build_model, read_mesh
from bonecontact.scene import SceneError, load_scene
from bonecontact.scene.rigid_motions import (
    UnheldMotion,
    UnheldMotionWarning,
    check_rigid_motions,
    singular_diagnosis,
    unheld_motions,
)

R = 0.01  # radius of the hemisphere and the half disc (m)

HEAD = """format = 1
[scene]
name = "{name}"
mesh = "{mesh}"
dimension = {dim}
[analysis]
kind = "{kind}"
{extra}
"""
MATERIAL = """[[material]]
name = "m{i}"
regions = ["{region}"]
model = "isotropic"
E = 1.0e9
nu = 0.3
rho = 1900.0
"""
CONTACT = """[[contact]]
name = "c{i}"
slave = "{slave}"
master = "{master}"
friction = "{friction}"
{coefficient}
"""
DIRICHLET = """[[dirichlet]]
boundary = "{boundary}"
value = [{value}]
"""


def _value(components: str, dim: int) -> str:
    """``"xz"`` → ``0.0, "free", 0.0``: the fixed components of a [[dirichlet]]."""
    return ", ".join("0.0" if c in components else '"free"' for c in "xyz"[:dim])


def _scene_text(
    mesh: Path,
    dim: int,
    regions: list[str],
    supports: dict[str, str],
    contacts: list[tuple[str, str, str]],
    kind: str = "static",
    extra: str = "",
) -> str:
    text = HEAD.format(name=mesh.stem, mesh=mesh, dim=dim, kind=kind, extra=extra)
    if kind != "static":
        text = text.replace(f'kind = "{kind}"', f'kind = "{kind}"\nt_end = 1.0\ndt = 1.0')
    for i, r in enumerate(regions):
        text += MATERIAL.format(i=i, region=r)
    for i, (s, m, fr) in enumerate(contacts):
        coef = "coefficient = 0.3" if fr == "coulomb" else ""
        text += CONTACT.format(i=i, slave=s, master=m, friction=fr, coefficient=coef)
    for b, comps in supports.items():
        text += DIRICHLET.format(boundary=b, value=_value(comps, dim))
    return text


@pytest.fixture(scope="module")
def meshes():
    """The four meshes, written once (rank 0) into a directory shared by the ranks."""
    comm = MPI.COMM_WORLD
    folder = Path(comm.bcast(tempfile.mkdtemp(prefix="rigid-") if comm.rank == 0 else None))
    out = {
        "hemisphere": shapes.hertz_3d(
            comm,
            folder / "hemisphere.msh",
            radius=R,
            h_contact=1.5e-3,
            h_far=3e-3,
            zone=2e-3,
            dist_max_factor=2.0,
            lateral_support=True,
        ),
        "half_disc": shapes.hertz_2d(
            comm,
            folder / "half_disc.msh",
            radius=R,
            h_contact=5e-4,
            h_far=2e-3,
            zone=2e-3,
            lateral_support=True,
        ),
        "boxes": shapes.two_boxes_3d(
            comm,
            folder / "boxes.msh",
            upper_width=0.012,
            upper_depth=0.01,
            upper_offset=(0.004, 0.005),
        ),
        "stack": shapes.stacked_blocks_2d(comm, folder / "stack.msh"),
    }
    comm.barrier()
    yield {k: Path(v) for k, v in out.items()}
    comm.barrier()
    if comm.rank == 0:
        shutil.rmtree(folder, ignore_errors=True)


def _motions(meshes, folder: Path, name: str, text: str) -> list[UnheldMotion]:
    comm = MPI.COMM_WORLD
    path = folder / f"{name}.toml"
    if comm.rank == 0:
        path.write_text(text)
    comm.barrier()
    scene = load_scene(path)
    md, groups = read_mesh(scene, comm)
    return unheld_motions(scene, md, groups, comm)


def _key(m: tuple) -> tuple:
    return (m[0], m[1], tuple(round(float(v), 6) + 0.0 for v in m[2]))


def _assert_motions(got: list[UnheldMotion], want: list[tuple], atol: float = 1e-9) -> None:
    """``got`` is ``want`` — (body, kind, direction, axis point or None) — in any order,
    each expected point within ``atol`` (m) of the reported axis (2D: centre)."""
    rows = sorted(((m.body, m.kind, m.direction, m.point) for m in got), key=_key)
    want = sorted(want, key=_key)
    assert [_key(r) for r in rows] == [_key(w) for w in want], rows
    for r, w in zip(rows, want, strict=True):
        assert (r[3] is None) == (w[3] is None), (r, w)
        if w[3] is not None:  # the same axis: the expected point lies on the reported one
            off = np.subtract(w[3], r[3])
            if len(off) == 3:
                off -= (off @ np.asarray(r[2])) * np.asarray(r[2])
            assert np.linalg.norm(off) <= atol, (r, w)


X, Y, Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
CENTRE3 = (0.0, R, 0.0)
HEMI = ["sphere", "block"]
HEMI_CONTACT = [("sphere_contact", "block_contact", "none")]
CLAMP3 = {"block_bottom": "xyz"}

#: case → (supports, contacts, expected motions of the hemisphere)
HEMISPHERE_CASES = {
    "loaded face x,z fixed": (
        {**CLAMP3, "sphere_top": "xz"},
        HEMI_CONTACT,
        [("rotation", X, CENTRE3), ("rotation", Z, CENTRE3)],
    ),
    "loaded face clamped": ({**CLAMP3, "sphere_top": "xyz"}, HEMI_CONTACT, []),
    "lateral supports": (
        {**CLAMP3, "sphere_support_x": "x", "sphere_support_z": "z"},
        HEMI_CONTACT,
        [],
    ),
    "x,z fixed, Coulomb friction": (
        {**CLAMP3, "sphere_top": "xz"},
        [("sphere_contact", "block_contact", "coulomb")],
        [],
    ),
    "contact only": (
        CLAMP3,
        HEMI_CONTACT,
        [("rotation", X, CENTRE3), ("rotation", Y, CENTRE3), ("rotation", Z, CENTRE3)],
    ),
}


@pytest.mark.parametrize("case", sorted(HEMISPHERE_CASES))
def test_hemisphere_on_block(meshes, case):
    supports, contacts, expected = HEMISPHERE_CASES[case]
    text = _scene_text(meshes["hemisphere"], 3, HEMI, supports, contacts)
    got = _motions(meshes, meshes["hemisphere"].parent, "hemi", text)
    # three free rotations: their axes are fitted to the faceted surface alone (facets of
    # up to 0.3 R far from the contact), to 0.5 % of R
    atol = 5e-3 * R if case == "contact only" else 1e-9
    _assert_motions(got, [("sphere", kind, d, p) for kind, d, p in expected], atol)


def test_hemisphere_without_support_or_contact_names_all_six(meshes):
    """Nothing but the block's clamp: three translations and three rotations about the
    axes through the hemisphere's centroid, 3R/8 below its flat face."""
    text = _scene_text(meshes["hemisphere"], 3, HEMI, CLAMP3, [])
    got = _motions(meshes, meshes["hemisphere"].parent, "free", text)
    assert [m.body for m in got] == ["sphere"] * 6
    assert sorted((m.kind, m.direction) for m in got) == sorted(
        [("translation", d) for d in (X, Y, Z)] + [("rotation", d) for d in (X, Y, Z)]
    )
    for m in got:
        if m.kind == "rotation":  # the faceted hemisphere's centroid: within 0.5 %
            assert np.allclose(m.point, (0.0, 5 * R / 8, 0.0), atol=5e-3 * 5 * R / 8)


def test_report_in_words(meshes):
    """The error names the file, the body, the motion and the key that makes it a warning;
    with ``unheld_motion = "warn"`` the same report is a warning."""
    comm = MPI.COMM_WORLD
    supports, contacts, _ = HEMISPHERE_CASES["loaded face x,z fixed"]
    folder = meshes["hemisphere"].parent
    for mode in ("error", "warn"):
        text = _scene_text(
            meshes["hemisphere"], 3, HEMI, supports, contacts, extra=f'unheld_motion = "{mode}"'
        )
        path = folder / f"words_{mode}.toml"
        if comm.rank == 0:
            path.write_text(text)
        comm.barrier()
        scene = load_scene(path)
        md, groups = read_mesh(scene, comm)
        lines = (
            'body "sphere": rotation about the axis through (0, 0.01, 0) along x is not held',
            'body "sphere": rotation about the axis through (0, 0.01, 0) along z is not held',
        )
        if mode == "error":
            with pytest.raises(SceneError) as info:
                check_rigid_motions(scene, md, groups, comm)
            text = str(info.value)
            assert str(path) in text and 'unheld_motion = "warn"' in text
        else:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                check_rigid_motions(scene, md, groups, comm)
            found = [w for w in caught if issubclass(w.category, UnheldMotionWarning)]
            assert len(found) == 1
            text = str(found[0].message)
        assert all(line in text for line in lines)


@pytest.mark.parametrize("kind", ["dynamic", "quasistatic"])
def test_analysis_kinds(meshes, kind):
    """A dynamic scene holds a free body by its mass: not checked; a quasi-static one (the
    viscous term has the same rigid modes as the elastic one) is refused."""
    comm = MPI.COMM_WORLD
    text = _scene_text(meshes["half_disc"], 2, ["cylinder", "block"], CLAMP2, [], kind=kind)
    path = meshes["half_disc"].parent / f"{kind}.toml"
    if comm.rank == 0:
        path.write_text(text)
    comm.barrier()
    scene = load_scene(path)
    md, groups = read_mesh(scene, comm)
    if kind == "dynamic":
        assert check_rigid_motions(scene, md, groups, comm) == []
    else:
        with pytest.raises(SceneError, match='body "cylinder": translation along x'):
            check_rigid_motions(scene, md, groups, comm)


DISC = ["cylinder", "block"]
DISC_CONTACT = [("cyl_contact", "block_contact", "none")]
CLAMP2 = {"block_bottom": "xy"}
#: case → (supports, contacts, expected motions of the half disc)
HALF_DISC_CASES = {
    "loaded edge x fixed": (
        {**CLAMP2, "cyl_top": "x"},
        DISC_CONTACT,
        [("cylinder", "rotation", Z, (0.0, R))],
    ),
    "loaded edge clamped": ({**CLAMP2, "cyl_top": "xy"}, DISC_CONTACT, []),
    "lateral support": ({**CLAMP2, "cyl_support": "x"}, DISC_CONTACT, []),
    "loaded edge x fixed, Tresca": (
        {**CLAMP2, "cyl_top": "x"},
        [("cyl_contact", "block_contact", "tresca")],
        [],
    ),
    "no support, no contact": (
        CLAMP2,
        [],
        [
            ("cylinder", "translation", (1.0, 0.0), None),
            ("cylinder", "translation", (0.0, 1.0), None),
            # the half disc's centroid: 4R/(3π) below its flat edge
            ("cylinder", "rotation", Z, (0.0, R - 4 * R / (3 * np.pi))),
        ],
    ),
}


@pytest.mark.parametrize("case", sorted(HALF_DISC_CASES))
def test_half_disc_on_block(meshes, case):
    supports, contacts, expected = HALF_DISC_CASES[case]
    text = _scene_text(meshes["half_disc"], 2, DISC, supports, contacts)
    if "Tresca" in case:
        text = text.replace('friction = "tresca"', 'friction = "tresca"\nbound = 1.0e5')
    got = _motions(meshes, meshes["half_disc"].parent, "disc", text)
    _assert_motions(got, expected, atol=ATOL.get(case, 1e-9))


#: the half disc's centroid, of the polygon inscribed in the circle: to 0.2 % of it
ATOL = {"no support, no contact": 2e-3 * (R - 4 * R / (3 * np.pi))}

BOXES = ["lower", "upper"]
BOX_CONTACT = [("upper_contact", "lower_contact", "none")]
#: the upper box [0.004, 0.016] x [0.01, 0.02] x [0.005, 0.015]: centroid (0.01, 0.015, 0.01)
BOX_CASES = {
    "top x,z fixed": ({"bottom": "xyz", "top": "xz"}, BOX_CONTACT, []),
    "contact only": (
        {"bottom": "xyz"},
        BOX_CONTACT,
        [
            ("upper", "translation", X, None),
            ("upper", "translation", Z, None),
            ("upper", "rotation", Y, (0.01, 0.015, 0.01)),
        ],
    ),
    "top x fixed": (
        {"bottom": "xyz", "top": "x"},
        BOX_CONTACT,
        [("upper", "translation", Z, None)],
    ),
}


@pytest.mark.parametrize("case", sorted(BOX_CASES))
def test_flat_box_on_box(meshes, case):
    """Flat on flat: the normal contact holds the tilts (their normal velocity varies
    linearly over the face) and the vertical translation, never the sliding."""
    supports, contacts, expected = BOX_CASES[case]
    text = _scene_text(meshes["boxes"], 3, BOXES, supports, contacts)
    got = _motions(meshes, meshes["boxes"].parent, "boxes", text)
    _assert_motions(got, expected, atol=ATOL.get(case, 1e-9))


STACK = ["block1", "block2", "block3"]
STACK_CONTACTS = [
    ("block2_bottom", "block1_top", "none"),
    ("block3_bottom", "block2_top", "none"),
]
STACK_CASES = {
    # block 2 and 3 held in y and rotation only through the chain of contacts
    "sides x fixed": (
        {"block1_bottom": "xy", "block2_left": "x", "block3_left": "x"},
        STACK_CONTACTS,
        [],
    ),
    "middle sliding": (
        {"block1_bottom": "xy", "block3_left": "x"},
        STACK_CONTACTS,
        [("block2", "translation", (1.0, 0.0), None)],
    ),
    "middle held by friction": (
        {"block1_bottom": "xy", "block3_left": "x"},
        [("block2_bottom", "block1_top", "coulomb"), STACK_CONTACTS[1]],
        [],
    ),
    "chain without its base": (
        {"block2_left": "x", "block3_left": "x"},
        STACK_CONTACTS,
        [  # block 1 slides; the three move up and down together
            ("block1", "translation", (1.0, 0.0), None),
            ("block1", "translation", (0.0, 1.0), None),
            ("block2", "translation", (0.0, 1.0), None),
            ("block3", "translation", (0.0, 1.0), None),
        ],
    ),
}


@pytest.mark.parametrize("case", sorted(STACK_CASES))
def test_chain_of_contacts(meshes, case):
    supports, contacts, expected = STACK_CASES[case]
    text = _scene_text(meshes["stack"], 2, STACK, supports, contacts)
    got = _motions(meshes, meshes["stack"].parent, "stack", text)
    _assert_motions(got, expected, atol=ATOL.get(case, 1e-9))


def test_command_exit_status(meshes, tmp_shared_path, capsys):
    """``bonecontact check``: exit 2 with the report on an ill-posed scene, 0 with
    ``unheld_motion = "warn"`` (the report then a warning, and a ``motions`` row)."""
    comm = MPI.COMM_WORLD
    supports, contacts, _ = HALF_DISC_CASES["loaded edge x fixed"]
    line = 'body "cylinder": rotation about the point (0, 0.01) is not held'
    for mode, status in (("error", 2), ("warn", 0)):
        path = tmp_shared_path / f"{mode}.toml"
        if comm.rank == 0:
            path.write_text(
                _scene_text(
                    meshes["half_disc"],
                    2,
                    DISC,
                    supports,
                    contacts,
                    extra=f'unheld_motion = "{mode}"',
                )
            )
        comm.barrier()
        assert cli_main(["check", str(path)]) == status
        out = capsys.readouterr()
        if comm.rank == 0:
            assert line in out.err
            if mode == "error":
                assert f"error: {path}" in out.err and 'unheld_motion = "warn"' in out.err
            else:
                assert "warning:" in out.err and f"motions     {line} (warning)" in out.out


#: active set → the motions the half disc's supports and these active nodes leave free
#: (x fixed on the loaded edge; "apex": the slave nodes within 1.2 mm of the first touch)
ACTIVE_CASES = {
    "apex": ("cyl_top", "apex", False, ["rotation"]),
    "none": ("cyl_top", "none", False, ["rotation", "translation"]),
    "all, sticking": ("cyl_top", "all", True, []),
    "apex, lateral support": ("cyl_support", "apex", False, []),
}


def _half_disc_model(meshes, group: str, name: str, comm):
    """The half disc on the block with x fixed on ``group``, built anyway (``"warn"``):
    its scene and model (the scene file ``<name>.toml`` beside the mesh)."""
    text = _scene_text(
        meshes["half_disc"],
        2,
        DISC,
        {**CLAMP2, group: "x"},
        DISC_CONTACT,
        extra='unheld_motion = "warn"',
    )
    path = meshes["half_disc"].parent / f"{name}.toml"
    if comm.rank == 0:
        path.write_text(text)
    comm.barrier()
    scene = load_scene(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return scene, build_model(scene, comm)


@pytest.mark.parametrize("case", sorted(ACTIVE_CASES))
def test_singular_active_set_names_the_free_body(meshes, case):
    """:func:`singular_diagnosis` (what a singular PDAS system reports) on given active
    sets: the rotation about the centre (0, R) is held by no set of frictionless nodes on
    the arc, the vertical translation only by active nodes, everything by sticking ones."""
    comm = MPI.COMM_WORLD
    group, nodes, stick, expected = ACTIVE_CASES[case]
    scene, sm = _half_disc_model(meshes, group, "active", comm)
    itf = sm.interfaces[0]
    x = itf.coords
    on = {
        "apex": (np.abs(x[:, 0]) < 1.2e-3) & (x[:, 1] < 1e-4),
        "none": np.zeros(len(x), dtype=bool),
        "all": np.ones(len(x), dtype=bool),
    }[nodes]
    diagnose = singular_diagnosis(scene, sm.mesh_data, sm.groups, sm.model.V, sm.interfaces, comm)
    report = diagnose([on], [on & stick])
    want = {
        "rotation": 'body "cylinder": rotation about the point (0, 0.01) is not held',
        "translation": 'body "cylinder": translation along y is not held',
    }
    assert sorted(r for r in report.split("; ") if r) == sorted(want[e] for e in expected)


def test_diagnosis_of_a_pair_the_run_made(meshes):
    """A pair whose groups are not among the scene's (a crack's faces, made by the run
    inside one body) holds nothing in the diagnosis — and does not stop it: with the
    master group left out, every active node of the disc's pair holds nothing, so the
    rotation and the translation are reported as with no active node."""
    comm = MPI.COMM_WORLD
    scene, sm = _half_disc_model(meshes, "cyl_top", "made", comm)
    groups = {k: v for k, v in sm.groups.items() if k != "block_contact"}
    diagnose = singular_diagnosis(scene, sm.mesh_data, groups, sm.model.V, sm.interfaces, comm)
    on = np.ones(len(sm.interfaces[0].coords), dtype=bool)
    report = diagnose([on], [on])
    assert sorted(r for r in report.split("; ") if r) == [
        'body "cylinder": rotation about the point (0, 0.01) is not held',
        'body "cylinder": translation along y is not held',
    ]


@pytest.mark.serial
def test_singular_run_says_which_body(meshes, tmp_shared_path):
    """The half disc with x fixed on its loaded edge, run anyway (``"warn"``): the first
    PDAS system is singular and the failure names the body and the motion.

    Serial only: on 2 ranks MUMPS finds no null pivot in the same system (the mortar's
    nodal normals hold the rotation by round-off) and the run "converges" with an
    arbitrary rotation — what the check before the solve refuses by default.  The
    diagnosis itself is tested on 1, 2 and 3 ranks above."""
    comm = MPI.COMM_WORLD
    supports, contacts, _ = HALF_DISC_CASES["loaded edge x fixed"]
    text = _scene_text(
        meshes["half_disc"], 2, DISC, supports, contacts, extra='unheld_motion = "warn"'
    )
    text += '[[traction]]\nboundary = "cyl_top"\nvalue = [0.0, -1.0e6]\n'
    path = tmp_shared_path / "singular.toml"
    if comm.rank == 0:
        path.write_text(text)
    comm.barrier()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = run_scene(load_scene(path), comm, output=tmp_shared_path / "out", progress=False)
    assert result.status == "failed"
    message = result.summary["message"]
    assert "singular" in message
    assert 'body "cylinder": rotation about the point (0, 0.01) is not held' in message


SHIPPED = sorted((Path(__file__).resolve().parents[3] / "data" / "scenes").glob("*.toml"))


@pytest.mark.serial
@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_shipped_scenes_hold_every_body(path):
    """No false alarm: every body of every scene of data/scenes is held (the dynamic and
    coupled ones too, on the scene's own mesh)."""
    scene = load_scene(path)
    if scene.analysis is None:  # growth only: no mechanics
        return
    comm = MPI.COMM_WORLD
    md, groups = read_mesh(scene, comm)
    assert unheld_motions(scene, md, groups, comm) == []
