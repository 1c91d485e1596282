"""Forces in and out: ``[[force]]``, the support reactions and ``bonecontact check``'s areas.

* Reactions balance the loads (Σ R + F − I = 0, I the inertial force of a dynamic run) in
  every step of a family of scenes: 2D and 3D, with and without contact, static,
  quasi-static and dynamic; their moments too without contact.  In-process, so the MPI
  sessions run them on 2 and 3 ranks.
* The inertial force of the reactions' balance is the change of momentum ∫ρv dx per step.
* ``[[force]]`` gives the solution of the equivalent ``[[traction]]`` (value F/A).
* ``moment`` against the closed-form linear traction of a rectangular face (beam theory:
  bending σ = F/A + M_y z/I_y − M_z y/I_z, torsion τ = T r/I_p), and the reaction moment
  of a clamped plate under a pure couple.
* Bad ``[[force]]`` input: one error naming the file, the table, the key and what is allowed.
* ``bonecontact check`` prints the length/area of every supported and loaded group and the
  total force of each load (against the exact values of a rectangle).
* The femur of ``data/anatomy``, fixed distally, loaded by 2 kN on its head: a reaction of
  2000 N within 0.1 % (a coarse mesh here; the 6 mm mesh with its cortex is ``slow``).
"""

from __future__ import annotations

import csv
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from cli_support import reaction_balance, run_in_process

from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics import Integrator, Mechanics
from bonecontact.mechanics.reactions import SupportReactions
from bonecontact.meshing import shapes
from bonecontact.runners.dispatch import run_scene
from bonecontact.scene import SceneError, load_scene

COMM = MPI.COMM_WORLD
E, NU = 1.0e9, 0.3
ROOT = Path(__file__).resolve().parents[3]


# ----------------------------------------------------------------------------- scenes
def _material(regions: str, rho: bool = False, tau: float = 0.0) -> str:
    text = f'[[material]]\nname = "m_{regions}"\nregions = ["{regions}"]\nmodel = "isotropic"\n'
    text += f"E = {E}\nnu = {NU}\n"
    return text + (f"rho = 1500.0\ntau_v = {tau}\n" if rho or tau else "")


def _head(mesh: Path, dim: int, analysis: str) -> str:
    return f'format = 1\n[scene]\nname = "s"\nmesh = "{mesh}"\ndimension = {dim}\n{analysis}\n'


STATIC = '[analysis]\nkind = "static"\nload_steps = 2'
QUASI = '[analysis]\nkind = "quasistatic"\nt_end = 0.3\ndt = 0.1'
DYNAMIC = '[analysis]\nkind = "dynamic"\nt_end = 4.0e-5\ndt = 1.0e-5'


def _timed(analysis: str) -> bool:
    return "static" not in analysis.split("\n")[1]


def _plate(path: Path, analysis: str) -> str:
    """A 2D plate, guided on its left and bottom, loaded on top and right."""
    mesh = shapes.rectangle(0.04, 0.02, 8, 4, COMM, path=path / "plate.msh")
    timed = _timed(analysis)
    text = _head(mesh, 2, analysis) + _material("body", rho=timed, tau=1e-3 if timed else 0.0)
    text += '[[dirichlet]]\nboundary = "left"\nvalue = [0.0, "free"]\n'
    text += '[[dirichlet]]\nboundary = "bottom"\nvalue = ["free", 0.0]\n'
    text += '[[traction]]\nboundary = "top"\nvalue = [2.0e5, -1.0e6]\n'
    text += '[[force]]\nboundary = "right"\nvalue = [3.0e3, 1.0e3]\nmoment = 20.0\n'
    text += '[[body_force]]\nregions = ["body"]\nvalue = [0.0, -2.0e5]\n'
    return text


def _box(path: Path, analysis: str) -> str:
    """A 3D box clamped at its bottom, a force with a moment on top, a pressure on a side."""
    mesh = shapes.box(0.02, 0.03, 0.02, 0.01, COMM, path=path / "box.msh")
    text = _head(mesh, 3, analysis) + _material("body", rho=_timed(analysis))
    text += '[[dirichlet]]\nboundary = "bottom"\nvalue = [0.0, 0.0, 0.0]\n'
    text += '[[force]]\nboundary = "top"\nvalue = [50.0, -400.0, 20.0]\n'
    text += "moment = [1.0, 2.0, -0.5]\npoint = [0.0, 0.03, 0.0]\n"
    text += '[[pressure]]\nboundary = "left"\nvalue = 1.0e5\n'
    return text


def _blocks2d(path: Path, analysis: str) -> str:
    """Two blocks in frictionless contact, the upper one held only by contact (x guided)."""
    mesh = shapes.two_blocks_2d(
        COMM, path=path / "blocks.msh", upper_width=0.012, upper_offset=0.004
    )
    timed = _timed(analysis)
    text = _head(mesh, 2, analysis) + _material("lower", rho=timed) + _material("upper", rho=timed)
    text += '[[contact]]\nname = "joint"\nslave = "upper_contact"\nmaster = "lower_contact"\n'
    text += '[[dirichlet]]\nboundary = "bottom"\nvalue = [0.0, 0.0]\n'
    text += '[[dirichlet]]\nboundary = "upper_left"\nvalue = [0.0, "free"]\n'
    text += '[[force]]\nboundary = "top"\nvalue = [0.0, -2.0e3]\n'
    return text


def _blocks2d_coulomb(path: Path, analysis: str) -> str:
    """The two blocks with Coulomb friction, the upper one pressed by a force and dragged
    sideways by its top (instead of the guide on its side)."""
    text = _blocks2d(path, analysis).replace(
        '[[dirichlet]]\nboundary = "upper_left"\nvalue = [0.0, "free"]\n',
        '[[dirichlet]]\nboundary = "top"\nvalue = [1.0e-7, "free"]\n',
    )
    return text.replace(
        'master = "lower_contact"\n',
        'master = "lower_contact"\nfriction = "coulomb"\ncoefficient = 0.5\n',
    )


def _blocks2d_guided_stick(path: Path, analysis: str) -> str:
    """The two blocks with Coulomb friction and the guide on the upper block's side, so
    the slave surface's end node carries a support; a lateral force (stick)."""
    text = _blocks2d(path, analysis).replace("value = [0.0, -2.0e3]", "value = [3.0e2, -2.0e3]")
    return text.replace(
        'master = "lower_contact"\n',
        'master = "lower_contact"\nfriction = "coulomb"\ncoefficient = 0.5\n',
    )


def _boxes3d(path: Path, analysis: str) -> str:
    """Two boxes in Coulomb contact, the upper one pressed by a force and dragged sideways by
    its top (stick, then slip)."""
    mesh = shapes.two_boxes_3d(
        COMM,
        path=path / "boxes.msh",
        upper_width=0.012,
        upper_depth=0.012,
        upper_offset=(0.004, 0.004),
        h_lower=0.02 / 4,
        h_upper=0.012 / 4,
    )
    text = _head(mesh, 3, analysis) + _material("lower") + _material("upper")
    text += '[[contact]]\nname = "joint"\nslave = "upper_contact"\nmaster = "lower_contact"\n'
    text += 'friction = "coulomb"\ncoefficient = 0.5\n'
    text += '[[dirichlet]]\nboundary = "bottom"\nvalue = [0.0, 0.0, 0.0]\n'
    text += '[[dirichlet]]\nboundary = "top"\nvalue = [1.0e-7, "free", -5.0e-8]\n'
    text += '[[force]]\nboundary = "top"\nvalue = [0.0, -500.0, 0.0]\n'
    return text


CASES = {
    "plate2d-static": (_plate, STATIC, False),
    "plate2d-quasistatic": (_plate, QUASI, False),
    "plate2d-dynamic": (_plate, DYNAMIC, False),
    "box3d-static": (_box, STATIC, False),
    "box3d-dynamic": (_box, DYNAMIC.replace("4.0e-5", "2.0e-5"), False),
    "contact2d-static": (_blocks2d, STATIC, True),
    "contact2d-dynamic": (_blocks2d, DYNAMIC, True),
    "contact2d-coulomb": (_blocks2d_coulomb, STATIC, True),
    "contact2d-coulomb-guided": (_blocks2d_guided_stick, STATIC, True),
    "contact3d-coulomb": (_boxes3d, STATIC, True),
}


def _run(tmp: Path, text: str):
    path = tmp / "scene.toml"
    if COMM.rank == 0:
        path.write_text(text)
    COMM.barrier()
    res = run_scene(load_scene(path), COMM, output=tmp / "out", progress=False)
    assert res.status == "converged", res.summary.get("message")
    return res


def _history(out: Path) -> dict[str, np.ndarray]:
    rows = list(csv.reader(open(out / "history.csv")))
    return {c: np.array([r[k] for r in rows[1:]]) for k, c in enumerate(rows[0])}


# ----------------------------------------------------------------------------- balance
@pytest.mark.parametrize("case", list(CASES))
def test_reactions_balance_the_loads(tmp_shared_path, case):
    builder, analysis, contact = CASES[case]
    res = _run(tmp_shared_path, builder(tmp_shared_path, analysis))
    out = tmp_shared_path / "out"
    hist = _history(out)
    dim = 3 if "3d" in case else 2
    force_defect, moment_defect = reaction_balance(hist, dim)
    # contact forces are internal between the bodies: the dual mortar conserves momentum
    assert force_defect.max() < 1e-8, force_defect
    if not contact:  # moments too (Σ x × r of the rigid rotations of K vanishes)
        assert moment_defect.max() < 1e-8, moment_defect
    # the reactions carry the load: some support takes a force of the order of the load
    groups = res.summary["reactions"]["groups"]
    biggest = max(np.linalg.norm(g["force"]) for g in groups.values())
    assert biggest > 0.1 * np.linalg.norm(res.summary["reactions"]["load"]["force"])
    assert res.summary["reactions"]["balance_defect_max"] < 1e-8
    # the summary holds the last row of the history
    last = {c: float(v[-1]) for c, v in hist.items() if c.startswith("reaction_")}
    for name, g in groups.items():
        for c, v in zip("xyz", g["force"], strict=False):
            assert last[f"reaction_{name}_{c}"] == pytest.approx(v, rel=1e-12, abs=1e-300)


def test_inertia_is_the_change_of_momentum():
    """Dynamic plate: Σ M a of the reactions' balance equals (∫ρvⁿ⁺¹ − ∫ρvⁿ)/Δt, the
    momentum assembled from the velocity field; and Σ R + F − I = 0."""
    import ufl
    from dolfinx import fem

    md = shapes.rectangle(0.04, 0.02, 8, 4, COMM)
    tag = {n: pg.tag for n, pg in md.physical_groups.items()}
    rho, dt = 1500.0, 1.0e-5
    model = Mechanics(md.mesh, Isotropic(E=E, nu=NU, rho=rho), md.cell_tags, md.facet_tags)
    left, bottom = model.facets(tag["left"]), model.facets(tag["bottom"])
    model.add_dirichlet(left, 0)
    model.add_dirichlet(bottom, 1)
    model.add_force(tag["right"], [3.0e3, 1.0e3], lambda t: min(t / 3e-5, 1.0))
    integ = Integrator(model, "dynamic", dt)
    integ.set_initial()
    supports = SupportReactions(model, [("left", left, (0,)), ("bottom", bottom, (1,))])
    momentum = [fem.form(rho * integ.velocity[i] * ufl.dx) for i in range(2)]

    def p() -> np.ndarray:
        return np.array([COMM.allreduce(fem.assemble_scalar(f)) for f in momentum])

    for _ in range(4):
        before = p()
        integ.step()
        rec = supports.record(integ.residual, integ.load, integ.inertia)
        change = (p() - before) / dt
        assert rec.inertia.force == pytest.approx(change, rel=1e-9, abs=1e-9 * np.abs(change).max())
        assert rec.defect() < 1e-9
        total = sum(g.force for g in rec.groups.values()) + rec.load.force - rec.inertia.force
        assert np.abs(total).max() < 1e-9 * np.abs(rec.load.force).max()
    integ.destroy()


# ----------------------------------------------------------------------------- [[force]]
@pytest.mark.parametrize(
    "dim, analysis, schedule",
    [
        (2, STATIC, ""),
        (2, DYNAMIC, "ramp = 2.0e-5\n"),
        (3, STATIC, "schedule = [[0.0, 0.0], [0.5, 1.0], [1.0, 0.25]]\n"),
    ],
    ids=["2d-static", "2d-dynamic-ramp", "3d-static-schedule"],
)
def test_force_equals_traction(tmp_shared_path, dim, analysis, schedule):
    """[[force]] value = t·A gives the solution of [[traction]] value = t (A exact)."""
    if dim == 2:
        mesh = shapes.rectangle(0.04, 0.02, 8, 4, COMM, path=tmp_shared_path / "m.msh")
        t, area, fixed = [2.0e5, -1.0e6], 0.04, "[0.0, 0.0]"
    else:
        mesh = shapes.box(0.02, 0.03, 0.015, 0.0075, COMM, path=tmp_shared_path / "m.msh")
        t, area, fixed = [2.0e5, -1.0e6, 5.0e4], 0.02 * 0.015, "[0.0, 0.0, 0.0]"
    timed = "dynamic" in analysis
    base = _head(mesh, dim, analysis) + _material("body", rho=timed)
    base += f'[[dirichlet]]\nboundary = "bottom"\nvalue = {fixed}\n'
    fields = {}
    for table, value in (("traction", t), ("force", [v * area for v in t])):
        text = base + f'[[{table}]]\nboundary = "top"\nvalue = {value}\n{schedule}'
        sub = tmp_shared_path / table
        if COMM.rank == 0:
            sub.mkdir()
        COMM.barrier()
        res = _run(sub, text)
        fields[table] = res.integrator.u.x.array.copy()
        res.integrator.destroy()
    scale = np.abs(fields["traction"]).max()
    assert scale > 0
    assert np.abs(fields["force"] - fields["traction"]).max() < 1e-12 * scale


def _face_traction(model, tag, c, F, M, point, dim):
    """The closed-form traction on the right face (x = const) of a rectangle/box: uniform
    F/A plus beam theory's bending (and in 3D torsion) for the moment about the centroid."""
    import ufl

    x = ufl.SpatialCoordinate(model.mesh)
    F, c, p = np.asarray(F, float), np.asarray(c, float), np.asarray(point, float)
    if dim == 2:
        H = 0.02
        A, I = H, H**3 / 12
        Mc = M - ((c - p)[0] * F[1] - (c - p)[1] * F[0])
        return ufl.as_vector([F[0] / A - Mc * (x[1] - c[1]) / I, F[1] / A])
    H, W = 0.03, 0.015  # y and z sides of the face x = const
    A, Iy, Iz = H * W, H * W**3 / 12, W * H**3 / 12  # Iy = ∫ z², Iz = ∫ y²
    Mc = np.asarray(M, float) - np.cross(c - p, F)
    ry, rz = x[1] - c[1], x[2] - c[2]
    T = Mc[0] / (Iy + Iz)
    return ufl.as_vector(
        [
            F[0] / A + Mc[1] * rz / Iy - Mc[2] * ry / Iz,
            F[1] / A - T * rz,
            F[2] / A + T * ry,
        ]
    )


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("point", ["centroid", "offset"])
def test_moment_is_beam_theory_traction(dim, point):
    """The load vector of [[force]] with a moment equals that of the closed-form traction,
    and its resultant is F with moment M about the point."""
    from dolfinx import fem

    if dim == 2:
        md = shapes.rectangle(0.04, 0.02, 8, 6, COMM)
        F, M, c = [300.0, -1.0e3], 7.5, np.array([0.04, 0.01])
    else:
        md = shapes.box(0.02, 0.03, 0.015, 0.005, COMM)
        F, M, c = [300.0, -1.0e3, 200.0], [2.0, -3.0, 1.5], np.array([0.02, 0.015, 0.0075])
    p = c if point == "centroid" else c + np.array([0.01, -0.02, 0.005][:dim])
    tag = {n: pg.tag for n, pg in md.physical_groups.items()}["right"]
    material = Isotropic(E=E, nu=NU)
    a = Mechanics(md.mesh, material, md.cell_tags, md.facet_tags)
    measures = a.add_force(tag, F, moment=M, point=None if point == "centroid" else p)
    assert measures.area == pytest.approx(0.02 if dim == 2 else 0.03 * 0.015, rel=1e-12)
    assert measures.centroid == pytest.approx(c, rel=1e-12)
    b = Mechanics(md.mesh, material, md.cell_tags, md.facet_tags)
    b.add_traction(tag, _face_traction(b, tag, c, F, M, p, dim))
    fa, fb = fem.Function(a.V), fem.Function(b.V)
    va, vb = a.load_vector(0.0, fa.x.petsc_vec), b.load_vector(0.0, fb.x.petsc_vec)
    diff = va.copy()
    diff.axpy(-1.0, vb)
    assert diff.norm() < 1e-12 * vb.norm()
    # resultant force and moment about p, from the nodal forces
    x = a.V.tabulate_dof_coordinates()[: a.num_owned // dim, :dim]
    f = va.array_r.reshape(-1, dim)
    total = COMM.allreduce(f.sum(axis=0))
    r = x - p
    mom = r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0] if dim == 2 else np.cross(r, f).sum(axis=0)
    mom = COMM.allreduce(np.sum(mom) if dim == 2 else mom)
    assert total == pytest.approx(F, rel=1e-12)
    assert mom == pytest.approx(M, rel=1e-10, abs=1e-10 * np.abs(M).max())
    diff.destroy()


def test_pure_couple_reaction(tmp_shared_path):
    """A plate clamped on its left, a pure couple M on its right edge: the left support's
    reaction is zero force and moment −M (statics), the history's load moment M."""
    M = 12.5
    mesh = shapes.rectangle(0.04, 0.02, 8, 4, COMM, path=tmp_shared_path / "m.msh")
    text = _head(mesh, 2, STATIC) + _material("body")
    text += '[[dirichlet]]\nboundary = "left"\nvalue = [0.0, 0.0]\n'
    text += (
        f'[[force]]\nboundary = "right"\nvalue = [0.0, 0.0]\nmoment = {M}\npoint = [5.0, -3.0]\n'
    )
    res = _run(tmp_shared_path, text)
    left = res.summary["reactions"]["groups"]["left"]
    assert np.abs(left["force"]).max() < 1e-9 * M
    assert left["moment"][0] == pytest.approx(-M, rel=1e-9)
    assert res.summary["reactions"]["load"]["moment"][0] == pytest.approx(M, rel=1e-12)
    res.integrator.destroy()


# ----------------------------------------------------------------------------- bad input
GOOD = '[[force]]\nboundary = "top"\nvalue = [0.0, -1.0]\n'
BAD_FORCE = {
    "unknown key": (
        '[[force]]\nboundary = "top"\nvalue = [0.0, -1.0]\nmagnitude = 2.0\n',
        "magnitude",
        "allowed: boundary, value, moment, point, ramp, schedule",
    ),
    "value length": (
        '[[force]]\nboundary = "top"\nvalue = [0.0, -1.0, 3.0]\n',
        "value",
        "must have 2 components",
    ),
    "value text": (
        '[[force]]\nboundary = "top"\nvalue = "2 kN"\n',
        "value",
        "must be an array of 2 numbers",
    ),
    "no boundary": ("[[force]]\nvalue = [0.0, -1.0]\n", "boundary", "missing required key"),
    "2D moment array": (GOOD + "moment = [0.0, 0.0, 1.0]\n", "moment", "must be a single number"),
    "point without moment": (GOOD + "point = [0.0, 0.0]\n", "point", "no moment is given"),
    "point length": (GOOD + "moment = 1.0\npoint = [0.0]\n", "point", "must have 2 components"),
    "ramp and schedule": (
        GOOD + "ramp = 1.0\nschedule = [[0.0, 1.0]]\n",
        "schedule",
        "either ramp > 0 or schedule",
    ),
}


@pytest.mark.parametrize("case", list(BAD_FORCE))
def test_bad_force_input(tmp_shared_path, case):
    text, key, fragment = BAD_FORCE[case]
    mesh = tmp_shared_path / "m.msh"
    if COMM.rank == 0:
        mesh.write_text("")  # the reader only checks that the file exists
    path = tmp_shared_path / "bad.toml"
    if COMM.rank == 0:
        path.write_text(_head(mesh, 2, STATIC) + _material("body") + text)
    COMM.barrier()
    with pytest.raises(SceneError) as err:
        load_scene(path)
    msg = str(err.value)
    assert "bad.toml" in msg and "[[force]] #1" in msg and key in msg and fragment in msg, msg


@pytest.mark.parametrize(
    "entry, key, fragment",
    [
        ('boundary = "nowhere"\nvalue = [0.0, -1.0]\n', "boundary", "nowhere"),
        ('boundary = "left"\nvalue = [1.0, 0.0]\n', "value", "is fixed by [[dirichlet]] #1"),
    ],
)
def test_bad_force_against_the_mesh(tmp_shared_path, entry, key, fragment):
    """Errors that need the mesh: exit 2 from ``bonecontact check`` with file, table, key."""
    mesh = shapes.rectangle(0.04, 0.02, 4, 2, COMM, path=tmp_shared_path / "m.msh")
    path = tmp_shared_path / "bad.toml"
    text = _head(mesh, 2, STATIC) + _material("body")
    text += '[[dirichlet]]\nboundary = "left"\nvalue = [0.0, 0.0]\n[[force]]\n' + entry
    if COMM.rank == 0:
        path.write_text(text)
    COMM.barrier()
    res = run_in_process(["check", str(path)])
    assert res.returncode == 2
    if COMM.rank == 0:
        assert "bad.toml" in res.stderr + res.stdout
        msg = res.stderr + res.stdout
        assert "[[force]] #1" in msg and key in msg and fragment in msg, msg


# ----------------------------------------------------------------------------- check
def test_check_prints_areas_and_total_forces(tmp_shared_path):
    """Rectangle 0.04 × 0.02: lengths of the groups and the loads' totals, exactly."""
    mesh = shapes.rectangle(0.04, 0.02, 8, 4, COMM, path=tmp_shared_path / "m.msh")
    text = _head(mesh, 2, STATIC) + _material("body")
    text += '[[dirichlet]]\nboundary = "bottom"\nvalue = [0.0, 0.0]\n'
    text += '[[traction]]\nboundary = "top"\nvalue = [2.0e5, -1.0e6]\n'
    text += '[[pressure]]\nboundary = "right"\nvalue = 3.0e5\n'
    text += '[[body_force]]\nregions = ["body"]\nvalue = [0.0, -1.0e4]\n'
    text += '[[force]]\nboundary = "left"\nvalue = [5.0, -7.0]\nmoment = 0.5\n'
    path = tmp_shared_path / "s.toml"
    if COMM.rank == 0:
        path.write_text(text)
    COMM.barrier()
    res = run_in_process(["check", str(path)])
    assert res.returncode == 0, res.stderr
    if COMM.rank != 0:
        return
    out = res.stdout
    assert "bottom: length 0.04 m, fixes x, y" in out
    assert "[[traction]] #1 on top (length 0.04 m): total force (8000, -40000) N/m" in out
    assert "[[pressure]] #1 on right (length 0.02 m): total force (-6000, 0) N/m" in out
    assert "[[body_force]] #1 on body (area 0.0008 m²): total force (0, -8) N/m" in out
    assert "[[force]] #1 on left (length 0.02 m): total force (5, -7) N/m" in out
    assert "per metre of thickness" in out


# ----------------------------------------------------------------------------- femur
def _femur(tmp: Path, h: float, cortex: float | None) -> str:
    from bonecontact.meshing import SurfaceRegion, anatomy_surface
    from bonecontact.meshing.joint import clip_surface
    from bonecontact.meshing.stl import bone_from_surface

    surface = clip_surface(anatomy_surface("femur"), (0, -0.30, 0), (0, -1, 0))
    regions = [
        SurfaceRegion("femur_distal", cone=((0, -1, 0), 10)),  # the flat cut of the shaft
        SurfaceRegion("femur_head", box=((-1, -0.05, 0.035), (1, 1, 1)), cone=((0, 1, 0), 70)),
    ]
    mesh = bone_from_surface(
        surface, h, cortex, name="femur", regions=regions, comm=COMM, path=tmp / "femur.msh"
    )
    cells = '["femur_cortical", "femur_cancellous"]' if cortex else '["femur"]'
    text = _head(mesh, 3, '[analysis]\nkind = "static"')
    text += f'[[material]]\nname = "bone"\nregions = {cells}\nmodel = "isotropic"\n'
    text += "E = 17.0e9\nnu = 0.3\n"
    text += '[[dirichlet]]\nboundary = "femur_distal"\nvalue = [0.0, 0.0, 0.0]\n'
    text += '[[force]]\nboundary = "femur_head"\nvalue = [0, -2000, 0]\n'
    return text


def _femur_reaction(tmp: Path, h: float, cortex: float | None) -> None:
    res = _run(tmp, _femur(tmp, h, cortex))
    reaction = res.summary["reactions"]["groups"]["femur_distal"]["force"]
    assert reaction[1] == pytest.approx(2000.0, rel=1e-3)
    assert abs(reaction[0]) < 1e-3 * 2000 and abs(reaction[2]) < 1e-3 * 2000
    hist = _history(tmp / "out")
    assert float(hist["reaction_femur_distal_y"][-1]) == pytest.approx(2000.0, rel=1e-3)
    res.integrator.destroy()


@pytest.mark.serial
def test_femur_head_force_reaction(tmp_shared_path):
    """The scanned femur (8 mm, one material), cut 0.30 m below its head and fixed there.

    Serial session only: the reactions on 2 and 3 ranks are those of the cheaper
    ``test_reactions_balance_the_loads[box3d-static]`` (same code, a 3D clamped body)."""
    _femur_reaction(tmp_shared_path, 8e-3, None)


@pytest.mark.slow
def test_femur_head_force_reaction_fine(tmp_shared_path):
    """The same at 6 mm with a 3 mm cortex (data/anatomy/README.md's femur mesh)."""
    _femur_reaction(tmp_shared_path, 6e-3, 3e-3)
