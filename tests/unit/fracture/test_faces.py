"""Crack faces as a contact pair (bonecontact.fracture.faces): the pair's facets, and the
face traction of a frictionless closed crack under uniform compression against the
closed-form normal stress on the crack plane.

Runs serially and under ``mpiexec -n 2/3``.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from dolfinx import fem

from bonecontact.fracture.faces import MASTER_TAG, SLAVE_TAG, contact_tags
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.plates import centre_crack, mesh_plate, solve_plate
from bonecontact.materials.laws import Isotropic

COMM = MPI.COMM_WORLD
MAT = Isotropic(E=10.0e9, nu=0.3)
A, H_TIP = 0.1, 0.005


def total(form) -> float:
    return COMM.allreduce(fem.assemble_scalar(fem.form(form)), op=MPI.SUM)


@pytest.fixture(scope="module")
def closed():
    cm = mesh_plate(1.0, 1.0, centre_crack(A, 30.0), TipMesh(H_TIP, 0.3, 0.2), COMM)
    return solve_plate(cm, MAT, {"edge2": (0.0, -1e6), "edge0": (0.0, 1e6)}, face_contact=True)


def test_pair_holds_the_whole_faces(closed):
    """Both faces are in the pair up to the tips; the tip node (shared by the faces)
    carries no multiplier, every other slave node does."""
    cm = closed.cm
    tags = contact_tags(cm)
    ds = ufl.Measure("ds", domain=cm.mesh, subdomain_data=tags)
    slave, master = total(1.0 * ds(SLAVE_TAG)), total(1.0 * ds(MASTER_TAG))
    assert master == pytest.approx(2 * A, rel=1e-12)
    assert slave == pytest.approx(2 * A, rel=1e-12)
    itf = closed.contact_interface
    tips = [cm.crack.tip(e) for e in cm.crack.tip_ends]
    at_tip = [np.linalg.norm(itf.coords[:, :2] - t, axis=1).min(initial=1.0) for t in tips]
    assert COMM.allreduce(min(at_tip), op=MPI.MIN) > 0.5 * H_TIP  # no multiplier at a tip
    plus = cm.facet_tags.find(cm.face_tags[0])
    n_plus_nodes = COMM.allreduce(int(plus[plus < cm.mesh.topology.index_map(1).size_local].size))
    assert COMM.allreduce(itf.num_owned) == n_plus_nodes - 1  # n facets: n + 1 nodes, 2 tips


def test_face_traction_is_the_normal_stress_on_the_crack_plane(closed):
    """Frictionless: t = -sigma_n n on both faces, sigma_n = |sigma| cos^2(30 deg), up
    to the tips."""
    cm, t = closed.cm, closed.face_traction
    ds = ufl.Measure("ds", domain=cm.mesh, subdomain_data=cm.facet_tags)
    n = ufl.FacetNormal(cm.mesh)
    e1 = ufl.as_vector([math.cos(math.pi / 6), math.sin(math.pi / 6)])
    sn = 1e6 * math.cos(math.pi / 6) ** 2
    for tag, tf in zip(cm.face_tags, t, strict=True):
        length = total(1.0 * ds(tag))
        assert total(ufl.dot(tf, n) * ds(tag)) / length == pytest.approx(-sn, rel=1e-2)
        assert abs(total(ufl.dot(tf, e1) * ds(tag))) / length < 1e-9 * sn
    # action and reaction: coincident face nodes carry opposite tractions, the tips too
    x = t.plus.function_space.tabulate_dof_coordinates()[:, :2]
    vp, vm = t.plus.x.array.reshape(-1, 2), t.minus.x.array.reshape(-1, 2)
    pts = {}
    for vals in (vp, vm):
        loaded = np.linalg.norm(vals, axis=1) > 0
        keys = map(tuple, np.round(x[loaded] / 1e-12).astype(np.int64))
        for p, v in zip(keys, vals[loaded], strict=True):
            pts.setdefault(p, []).append(v)
    pairs = [v for v in pts.values() if len(v) == 2]
    assert COMM.allreduce(len(pairs), op=MPI.SUM) > 0
    for tip in (cm.crack.tip(e) for e in cm.crack.tip_ends):  # its traction on each face
        at_tip = np.flatnonzero(np.linalg.norm(x - tip, axis=1) < 1e-12)
        for b in at_tip:
            assert np.dot(vp[b], -vm[b]) > 0.75 * sn**2  # the neighbour: 0.87 sn
    for a, b in pairs:
        np.testing.assert_allclose(a, -b, rtol=1e-12, atol=1e-9)


def test_shared_tip_is_refused_unless_asked(closed):
    """Two surfaces with a common node are refused by default (separate bodies must not
    share nodes); the crack faces ask for ``shared_nodes="no_multiplier"``."""
    from bonecontact.contact.interface import ContactInputError, build_interface

    cm = closed.cm
    with pytest.raises(ContactInputError, match="share nodes"):
        build_interface(closed.model.V, contact_tags(cm), SLAVE_TAG, MASTER_TAG)
    with pytest.raises(ValueError, match="shared_nodes"):
        build_interface(closed.model.V, contact_tags(cm), SLAVE_TAG, MASTER_TAG, shared_nodes="yes")


# ------------------------------------------------------------- the faces start open
#: the family of the open start: crack angle β (degrees from x; the load is along y),
#: load sign (+1 tension: the crack opens; −1 compression: it closes), Coulomb μ or None
START = [(b, s, mu) for b in (0.0, 30.0, 60.0) for s in (1.0, -1.0) for mu in (None, 0.3)]
_PLATES: dict[float, object] = {}


def _plate(beta: float):
    """The plate with a centre crack at β (coarser than ``closed``'s), made once."""
    if beta not in _PLATES:
        _PLATES[beta] = mesh_plate(1.0, 1.0, centre_crack(A, beta), TipMesh(0.01, 0.3, 0.2), COMM)
    return _PLATES[beta]


def _solve(cm, sign: float, **kw):
    return solve_plate(cm, MAT, {"edge2": (0.0, sign * 1e6), "edge0": (0.0, -sign * 1e6)}, **kw)


def _relative(u, v) -> float:
    d = u.x.petsc_vec.copy()
    d.axpy(-1.0, v.x.petsc_vec)
    return d.norm() / v.x.petsc_vec.norm()


@pytest.mark.parametrize("beta, sign, mu", START)
def test_faces_start_open(beta: float, sign: float, mu: float | None, closed_gap_start) -> None:
    """The crack's faces start open (every gap is 0, a closed-gap start would glue them).
    In tension the solve is the open crack's linear solve (reference: the same plate
    without the contact pair) in one PDAS iteration (two with the Coulomb fixed point);
    in compression the faces close with no interpenetration, a frictionless crack carries
    σ cos²β over its length 2a (the uncracked plate), and the answer is the one started
    from the closed-gap set (the second method)."""
    cm = _plate(beta)
    sol = _solve(cm, sign, face_contact=True, friction=mu)
    res = sol.contact
    assert COMM.allreduce(max([g.min(initial=np.inf) for g in res.gap]), op=MPI.MIN) >= -1e-12 * A
    if sign > 0:
        assert res.n_active == [0]
        assert res.iterations == (1 if mu is None else 2)
        assert _relative(sol.u, _solve(cm, sign).u) < 1e-10
        return
    n_nodes = COMM.allreduce(sol.contact_interface.num_owned)
    assert res.n_active == [n_nodes]
    if mu is None:
        sn = 1e6 * math.cos(math.radians(beta)) ** 2
        # (measured −0.4 … +2.0 %: the faces' tip nodes carry no multiplier, h = a/10)
        assert res.normal_force[0] == pytest.approx(sn * 2 * A, rel=3e-2)
    closed_gap_start()
    glued = _solve(cm, sign, face_contact=True, friction=mu)
    assert glued.contact.iterations <= res.iterations
    assert _relative(sol.u, glued.u) < 1e-8


# ----------------------------------------------------------- recovered tractions at a tip
def _face(dim: int, n: int, rng: np.random.Generator):
    """Face nodes behind a tip at the origin (2D: on the negative x axis, graded towards
    the tip; 3D: on the half plane x < 0 of z = 0), weights and a linear traction."""
    if dim == 2:
        s = -0.1 * np.linspace(0.0, 1.0, n + 1)[1:] ** 1.5
        x = np.column_stack([s, np.zeros(n)])
    else:
        x = np.column_stack([-0.1 * rng.random(n), 0.2 * rng.random(n) - 0.1, np.zeros(n)])
    g = np.array([0.3, -0.7, 0.2])[:dim]
    t = np.outer(1.0 + 4.0 * x[:, 0] + 2.0 * x[:, 1], np.ones(dim)) * g
    return x, t, 0.5 + rng.random(n)


@pytest.mark.parametrize("dim", [2, 3])
def test_recovered_traction_keeps_a_linear_traction(dim):
    """A traction linear in x is its own fit: the nodes and the tip get it exactly."""
    from bonecontact.fracture.faces import recovered_traction

    rng = np.random.default_rng(dim)
    x, t, w = _face(dim, 40 if dim == 2 else 300, rng)
    tips = np.zeros((1, dim))
    t_new, t_tip = recovered_traction(x, t, w, np.ones(len(x), bool), tips, 0.03)
    np.testing.assert_allclose(t_new, t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(t_tip[0], t[0] / (1.0 + 4.0 * x[0, 0] + 2.0 * x[0, 1]), atol=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
def test_recovered_traction_removes_the_scatter_next_to_the_tip(dim):
    """±30 % scatter on the nodes within 0.02 of the tip (as the multipliers of a closed
    tip): within the recovery zone the error drops at least threefold; with one open node
    in the fits' reach every node keeps its multiplier."""
    from bonecontact.fracture.faces import recovered_traction

    rng = np.random.default_rng(10 + dim)
    x, t, w = _face(dim, 40 if dim == 2 else 300, rng)
    near = np.linalg.norm(x, axis=1) < 0.02
    noisy = t * (1.0 + 0.3 * np.where(near, rng.uniform(-1, 1, len(x)), 0.0))[:, None]
    tips = np.zeros((1, dim))
    closed = np.ones(len(x), bool)
    t_new, _ = recovered_traction(x, noisy, w, closed, tips, 0.03)
    zone = np.linalg.norm(x, axis=1) <= 0.03
    raw_err = np.abs(noisy - t)[zone].max()
    assert np.abs(t_new - t)[zone].max() < raw_err / 3
    np.testing.assert_array_equal(t_new[~zone], noisy[~zone])  # beyond the zone: untouched
    closed[np.argmin(np.linalg.norm(x, axis=1))] = False  # the node next to the tip opens
    t_open, _ = recovered_traction(x, noisy, w, closed, tips, 0.03)
    np.testing.assert_array_equal(t_open[zone], noisy[zone])


# ------------------------------------------- faces of inserted and grown (kinked) cracks
# A vertebral body's section (mm): the 30 x 24 mm outline with a tumour cavity (a
# 48-gon of radius 8.7 mm about (0, 12) mm, a vertex at its top), as
# demos/vertebra_tumour.py; the cracks are the kind the runs insert and grow: Δa =
# 0.5 mm increments, each turned by its own kink (up to ±90 degrees, as a closed crack's
# MTS kinks of ±70-82 degrees did in the vertebra run that failed with a nodal gap of
# -2.7 mm between its coincident faces).
MM = 1e-3
DA = 0.5 * MM
HOLE_C, HOLE_R, HOLE_N = (0.0, 12.0 * MM), 8.7 * MM, 48


def _cavity_body():
    from bonecontact.fracture.body import BodyOutline

    outer = np.array([[-15.0, 0.0], [15.0, 0.0], [15.0, 24.0], [-15.0, 24.0]]) * MM
    phi = 2 * np.pi * np.arange(HOLE_N) / HOLE_N
    hole = np.column_stack([HOLE_C[0] + HOLE_R * np.cos(phi), HOLE_C[1] + HOLE_R * np.sin(phi)])
    names = {1: "lower_endplate", 2: "walls", 3: "upper_endplate", 4: "lesion"}
    tags = (np.array([1, 2, 3, 2], np.int32), np.full(HOLE_N, 4, np.int32))
    return BodyOutline((outer, hole), tags, names, ("vertebral_body", 10), 2.0 * MM)


def _path(start, headings_deg, tips):
    """A crack from ``start`` (m) in Δa segments of the given headings (degrees)."""
    from bonecontact.fracture.crack import Crack2D

    pts = [np.asarray(start, dtype=float)]
    for h in headings_deg:
        pts.append(pts[-1] + DA * np.array([math.cos(math.radians(h)), math.sin(math.radians(h))]))
    return Crack2D(np.array(pts), tips)


HOLE_TOP = (HOLE_C[0], HOLE_C[1] + HOLE_R)  # a vertex of the cavity's polygon
CRACKS = {
    # from the cavity's top, grown up to the endplate and then turned by 70-90 degrees
    # each increment (the path of the failed vertebra run)
    "cavity_kinked": (HOLE_TOP, [90, 90, 88, 85, 3, 0, -70, 5, -80, 10, -85], "end"),
    "cavity_straight": (HOLE_TOP, [90, 90], "end"),  # as inserted, one increment grown
    # from the free wall, zig-zagging by ±80 degrees
    "surface_kinked": ((-15.0 * MM, 18.0 * MM), [0, 80, 0, -80, 0, 80, 10], "end"),
    # inside the body (two tips), turned by 90 degrees at every vertex
    "interior_kinked": ((9.6 * MM, 1.5 * MM), [0, 90, 0, 90, 180, 90, 0], "both"),
    "interior_straight": ((10.0 * MM, 2.0 * MM), [30, 30], "both"),
}
MESHES = {"coarse": TipMesh(DA / 2, 0.5), "fine": TipMesh(DA / 16, 0.25)}


def _cracked_model(case: str, size: str):
    from bonecontact.fracture.body import mesh_body_with_cracks
    from bonecontact.mechanics.model import Mechanics

    start, headings, tips = CRACKS[case]
    crack = _path(start, headings, tips)
    (cm,), md = mesh_body_with_cracks(_cavity_body(), [crack], MESHES[size], COMM)
    return cm, Mechanics(md.mesh, MAT, md.cell_tags, md.facet_tags)


def _gather_max(values) -> float:
    return COMM.allreduce(float(np.max(np.abs(values), initial=0.0)), op=MPI.MAX)


@pytest.mark.parametrize("size", list(MESHES))
@pytest.mark.parametrize("case", list(CRACKS))
def test_faces_of_inserted_and_grown_cracks_lie_on_each_other(case: str, size: str) -> None:
    """Every crack face pair as the runs build it (edge cracks from the cavity and from the
    free wall, interior cracks; straight and turned by 70-90 degrees at every increment;
    coarse and fine tips): the nodal gaps are zero to round-off (1e-12 of the 30 mm body),
    the opposite face covers the slave face once (measure ratio 1 to 1e-12), and every
    slave node but the tips carries a multiplier."""
    from bonecontact.fracture.faces import face_interface

    cm, m = _cracked_model(case, size)
    itf = face_interface(m, cm)
    assert _gather_max(itf.gap) <= 1e-12 * 30 * MM
    assert itf.covered_area / itf.slave_area == pytest.approx(1.0, abs=1e-12)
    assert itf.slave_area == pytest.approx(cm.crack.length, rel=1e-12)
    plus = cm.facet_tags.find(cm.face_tags[0])
    owned = plus[plus < cm.mesh.topology.index_map(1).size_local]
    n_facets = COMM.allreduce(int(owned.size))
    n_tips = len(cm.crack.tip_ends)
    # an open polyline of n facets has n + 1 nodes; the tips carry no multiplier
    assert COMM.allreduce(itf.num_owned) == n_facets + 1 - n_tips


@pytest.mark.parametrize("case", ["cavity_kinked", "surface_kinked", "interior_kinked"])
def test_default_pairing_of_a_kinked_crack_misses_its_opposite_face(case: str) -> None:
    """What the faces had before 2026-12-03: paired with every master facet whose
    projection along the averaged nodal normals overlaps (three facet sizes' search), a
    facet at a sharp kink also took the adjacent facet of the other leg or the opposite
    face of a leg a few facets away: nonzero gaps between coincident faces (or the
    interpenetration refused), while the pairing of the runs has none."""
    from bonecontact.contact.interface import ContactInputError, build_interface

    cm, m = _cracked_model(case, "coarse")
    try:
        itf = build_interface(
            m.V, contact_tags(cm), SLAVE_TAG, MASTER_TAG, shared_nodes="no_multiplier"
        )
    except ContactInputError as exc:
        assert "interpenetrate initially" in str(exc)
        return
    wrong = _gather_max(itf.gap) > 1e-3 * DA
    over = abs(itf.covered_area / itf.slave_area - 1.0) > 1e-6
    assert wrong or over
