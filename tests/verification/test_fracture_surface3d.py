"""Surface-breaking cracks in 3D against Newman–Raju and a 2D section
(docs/theory/fracture.md#surface-breaking-cracks-in-3d).

A plate [−b, b] × [−h, h] × [−t, 0] (b = h = 2, t = 1) under self-equilibrated tension
S = 1 on y = ±h, E = 1, ν = 0.3, with a crack in y = 0 cut into it
(:func:`~bonecontact.fracture.surface3d.mesh_plate_with_crack`: both faces meshed, the
mouth split too).  K by the domain interaction integral, its domain shortened along the
front near the free surface (q = 0 there); points closer to the surface than two front
elements are refused.

* Family (default suite, serial; reduced mesh: front a/10, grading 0.15, largest element
  0.4, 7.5k–16k dofs): semi-elliptical and corner cracks, a/c = 0.5 and 1, a/t = 0.2,
  against Newman and Raju's equations from φ = 20° (the deepest point included): every
  point within 6 %.  K_II and K_III vanish by symmetry (≤ 5 % of K_I).  The mouth is open:
  the two faces separate on the free surface; the front nodes are the faces' shared
  vertices.
* The faces are a contact pair: closed by compression, K = 0 (≤ 1 %), pressure |S|.
* The through crack (an edge crack of length 0.4 through the thickness): K_I at mid-thickness
  against the plane-strain K of the plate's 2D section (our 2D solver), and symmetric about
  the mid-plane.
* Ranks: on 2 and 3 ranks the distributed K (K_I, K_II, K_III) equals the serial K of the
  same gmsh mesh (built on COMM_SELF) to 1e-8: both crack shapes, a/c = 0.5 and 1, a point
  near the surface and the deepest point, and the through crack's straight front.
* Slow: front a/16 (the benchmark's mesh, 19k–38k dofs): within 3 % at the deepest point
  and within 5 % at every point from 10° off the surface on (docs/theory/fracture.md).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import fem

from bonecontact.fracture.crack import FractureError
from bonecontact.fracture.surface3d import (
    EllipticalArcFront,
    StraightFront,
    SurfaceCrack,
    domain_length,
    front_nodes,
)
from bonecontact.verification.surface_crack import (
    PlateProblem,
    corner_crack_k,
    plane_strain_edge_k,
    shape_factor,
    solve_plate,
    surface_crack_k,
)

A = 0.2  # crack depth (a/t = 0.2)
REDUCED = {"h_front": A / 10, "grading": 0.15, "h_max": 0.4, "r_out": 0.3 * A}
#: Tolerance of the reduced mesh (7.5k–16k dofs) against Newman–Raju at every point
#: (measured 2026-12-02 at 12° … 165°, the auxiliary field in the ellipse's coordinates:
#: semi-elliptical a/c = 0.5 −4.9 … −1.8 %, a/c = 1 −2.6 … +2.5 %, corner a/c = 0.5
#: −5.0 … −2.4 % (15°–80°), a/c = 1 −2.1 … −0.3 %; with the osculating-circle field and the
#: same domain a/c = 0.5 was −7.9 % at 20°).
REDUCED_TOL = 0.06


def problem(kind: str, a_c: float, **sizes) -> PlateProblem:
    sizes = {**REDUCED, **sizes}
    return PlateProblem(SurfaceCrack(kind, A, A / a_c), b=2.0, h=2.0, t=1.0, **sizes)


_CACHE: dict = {}


def solved(kind: str, a_c: float, comm=None, **sizes):
    key = (kind, a_c, comm is MPI.COMM_SELF, tuple(sorted(sizes.items())))
    if key not in _CACHE:
        _CACHE[key] = solve_plate(problem(kind, a_c, **sizes), comm)
    return _CACHE[key]


# ------------------------------------------------------------------ closed forms
def test_newman_raju_limits():
    """The equations reduce to known values: Q(1) = 2.464; a shallow semicircular crack
    (a/t → 0, c/b → 0) at the deepest point F = M₁ = 1.04, at the surface F = 1.04·1.1;
    the corner crack's M₁ = 1.05 and g₁ = g₂ at 45°, symmetric in φ ↔ π/2 − φ for a/c = 1
    up to the (a/t)² terms; the surface crack is symmetric about φ = π/2."""
    assert shape_factor(1.0) == pytest.approx(2.464, rel=1e-12)
    a = 1e-6
    k0 = math.sqrt(math.pi * a / 2.464)
    assert surface_crack_k(1.0, a, a, 1.0, 1e3, math.pi / 2) == pytest.approx(1.04 * k0, rel=1e-5)
    assert surface_crack_k(1.0, a, a, 1.0, 1e3, 0.0) == pytest.approx(1.04 * 1.1 * k0, rel=1e-5)
    phis = np.radians([10.0, 30.0, 60.0])
    np.testing.assert_allclose(
        surface_crack_k(1.0, 0.2, 0.4, 1.0, 2.0, phis),
        surface_crack_k(1.0, 0.2, 0.4, 1.0, 2.0, math.pi - phis),
        rtol=1e-14,
    )
    kc = corner_crack_k(1.0, a, a, 1.0, 1e3, np.array([0.3, math.pi / 2 - 0.3]))
    assert kc[0] == pytest.approx(kc[1], rel=1e-5)
    with pytest.raises(FractureError, match="a/c"):
        shape_factor(1.5)


def test_open_fronts_geometry():
    """The arc front clips nearest points to its ends, measures arc length without wrap
    and gives the distance to the free surface; the straight front likewise."""
    f = EllipticalArcFront(0.4, 0.2, (0.0, 0.0, 0.0), ((1, 0, 0), (0, 0, -1), (0, 1, 0)))
    assert not f.closed
    quarter = float(f.arc_length(math.pi / 2) - f.arc_length(0.0))
    assert f.perimeter == pytest.approx(2 * quarter, rel=1e-12)
    assert f.corner_distance(math.pi / 2) == pytest.approx(quarter, rel=1e-12)
    beyond = np.array([[0.6, 0.0, 0.05], [-0.6, 0.0, 0.05]])  # outside the plate, past each end
    np.testing.assert_allclose(f.nearest(beyond), [0.0, math.pi], atol=1e-12)
    s = StraightFront((0.0, 0, 0), (0.0, 0, -1.0), (0, 1.0, 0), (1.0, 0, 0))
    assert s.corner_distance(0.25) == pytest.approx(0.25)
    np.testing.assert_allclose(s.nearest([[0.1, 0.0, 0.5], [0.0, 0.0, -0.4]]), [0.0, 0.4])
    assert domain_length(s, 0.5, 0.3, 0.05) == pytest.approx(0.3)
    assert domain_length(s, 0.1, 0.3, 0.04) == pytest.approx(0.1, rel=1e-5)
    with pytest.raises(FractureError, match="free surface"):
        domain_length(s, 0.05, 0.3, 0.05)


def test_domain_length_is_the_ring_radius_off_the_surface():
    """The domain's half-length along the front is r_out wherever the point is farther
    than r_out from the free surface — also where an a/c = 0.5 front's curvature changes
    fastest (20°: its curvature length κ/|dκ/ds| = D^{3/2}/(3|c² − a²| sin φ cos φ) is
    0.55a, a quarter of it 0.14a, the limit the osculating-circle auxiliary field needed)
    — and the distance to the surface where that is shorter."""
    a, c = 0.2, 0.4
    front = SurfaceCrack("semi_elliptical", a, c).front(2.0, 1.0)
    phi = math.radians(20.0)
    d = (c * math.sin(phi)) ** 2 + (a * math.cos(phi)) ** 2
    ell = d**1.5 / (3 * (c * c - a * a) * math.sin(phi) * math.cos(phi))
    assert 0.25 * ell < 0.15 * a < 0.3 * a < front.corner_distance(phi)
    assert domain_length(front, phi, 0.3 * a, a / 20) == pytest.approx(0.3 * a)
    circle = SurfaceCrack("semi_elliptical", a, a).front(2.0, 1.0)
    assert domain_length(circle, 0.8, 0.3 * a, a / 20) == pytest.approx(0.3 * a)
    assert domain_length(front, math.pi / 2, 0.3 * a, a / 20) == pytest.approx(0.3 * a)
    assert domain_length(front, math.radians(10.0), 0.3 * a, a / 20) == pytest.approx(
        front.corner_distance(math.radians(10.0)), rel=1e-5
    )


# ------------------------------------------------------------ the reduced family
FAMILY = [("semi_elliptical", 0.5), ("semi_elliptical", 1.0), ("corner", 0.5), ("corner", 1.0)]


def _angles(kind: str) -> np.ndarray:
    """Parametric angles from 20° off the surface (the reduced mesh's domain there spans
    more than two front elements) — the deepest point included."""
    if kind == "corner":
        return np.radians([20.0, 30.0, 45.0, 60.0, 75.0])
    return np.radians([20.0, 45.0, 90.0, 135.0, 160.0])


@pytest.mark.serial
@pytest.mark.parametrize(("kind", "a_c"), FAMILY)
def test_newman_raju_reduced_mesh(kind, a_c):
    """K_I within 6 % of Newman–Raju at every point (reduced mesh, see
    ``REDUCED_TOL``); K_II, K_III below 5 % of K_I (zero by symmetry; measured ≤ 1.7 %).
    The parallel counterpart is :func:`test_same_on_every_partition`."""
    sol = solved(kind, a_c)
    p = sol.problem
    phis = _angles(kind)
    ks = [sol.k(phi) for phi in phis]
    k_I = np.array([k.K_I for k in ks])
    err = k_I / p.reference(phis) - 1.0
    assert np.all(np.abs(err) < REDUCED_TOL), err
    for k in ks:  # a symmetric mode-I problem
        assert abs(k.K_II) < 0.05 * k.K_I and abs(k.K_III) < 0.05 * k.K_I


@pytest.mark.parametrize(("kind", "a_c"), [("semi_elliptical", 1.0), ("corner", 1.0)])
def test_mouth_is_open_and_near_surface_points_refused(kind, a_c):
    """The two faces separate on the free surface z = 0 (the mouth's nodes were split):
    the opening of coincident upper/lower nodes there is positive; a point within two
    front elements of the surface is refused."""
    sol = solved(kind, a_c)
    blk, u = sol.block, sol.u
    V = u.function_space
    values = []
    for name in ("crack_upper", "crack_lower"):
        dofs = fem.locate_dofs_topological(V, 2, blk.facet_tags.find(blk.groups[name]))
        dofs = dofs[dofs < V.dofmap.index_map.size_local]
        x = V.tabulate_dof_coordinates()[dofs]
        uy = u.x.array.reshape(-1, 3)[dofs, 1]
        on = np.abs(x[:, 2]) < 1e-9
        keys = np.round(x[on] / 1e-9).astype(np.int64)
        values.append(dict(zip(map(tuple, keys), uy[on], strict=True)))
    comm = blk.mesh.comm
    upper = {k: v for d in comm.allgather(values[0]) for k, v in d.items()}
    lower = {k: v for d in comm.allgather(values[1]) for k, v in d.items()}
    common = set(upper) & set(lower)
    assert len(common) >= 3  # the mouth's nodes exist on both faces
    opening = np.array([upper[k] - lower[k] for k in common])
    assert np.count_nonzero(opening > 1e-3 * np.max(opening)) >= len(common) - 2  # ends shared
    with pytest.raises(FractureError, match="free surface"):
        sol.k(math.radians(2.0))
    # the front nodes are the vertices of both faces (the split mouth and face nodes are
    # not): on the front, about one per front element
    nodes = front_nodes(blk)
    front = blk.front
    assert np.max(np.linalg.norm(nodes - front.point(front.nearest(nodes)), axis=1)) < 1e-9 * A
    assert abs(len(nodes) - (front.perimeter / sol.problem.h_front + 1)) <= 0.1 * len(nodes)


#: The through crack: an edge crack of length 0.4 through the thickness, front 0.05.
THROUGH = PlateProblem(
    SurfaceCrack("through", 0.4),
    b=2.0,
    h=2.0,
    t=1.0,
    h_front=0.05,
    grading=0.15,
    h_max=0.4,
    r_out=0.15,
)


@pytest.mark.serial
def test_through_crack_against_plane_strain():
    """Edge crack of length 0.4 through the thickness (front 0.05, 20 elements through the
    thickness): K_I at mid-thickness within 5 % of the plane-strain K of the 2D section
    (the 3D mid-plane sits a few per cent above it), the quarter points (z = −t/4, −3t/4)
    alike within 4 % (symmetry about the mid-plane; measured 2.2 %, mesh scatter)."""
    p = THROUGH
    sol = solve_plate(p)
    mid = sol.k(0.5).K_I
    ref = plane_strain_edge_k(p)
    assert mid == pytest.approx(ref, rel=0.05)
    quarter = (sol.k(0.25).K_I, sol.k(0.75).K_I)
    assert quarter[0] == pytest.approx(quarter[1], rel=0.04)


@pytest.mark.parametrize("kind", ["semi_elliptical", "corner"])
def test_closed_crack_contact_pair(kind):
    """The faces are a frictionless contact pair: under compression S = −1 the crack
    closes — every slave node active, contact pressure |S| within 2 % (measured
    +1.1 … +1.2 % semi-elliptical, −1.7 … −1.2 % corner: the nodal multipliers of the
    graded mesh) — and K (with the contact
    tractions as face term) vanishes: |K_I|, |K_II|, |K_III| ≤ 1 % of |S|√(πa)
    (measured ≤ 0.32 %)."""
    p = problem(kind, 1.0)
    p = PlateProblem(
        p.crack, p.b, p.h, p.t, p.h_front, p.grading, p.h_max, p.r_out, -1.0, contact=True
    )
    sol = solve_plate(p)
    res = sol.contact
    comm = MPI.COMM_WORLD
    active = comm.allgather(np.asarray(res.active[0], dtype=bool))
    pressure = np.concatenate(comm.allgather(np.asarray(res.pressure[0])))
    assert all(a.all() for a in active)
    np.testing.assert_allclose(pressure, 1.0, rtol=0.02)
    assert sol.face_traction is not None
    ref = math.sqrt(math.pi * A)
    for phi in np.radians([30.0, 60.0] if kind == "corner" else [30.0, 90.0]):
        k = sol.k(phi)
        assert max(abs(k.K_I), abs(k.K_II), abs(k.K_III)) < 0.01 * ref


#: (kind, a/c, φ in degrees) of the partition family: near the surface (the domain cut
#: to its distance from the surface; the ellipse's coordinates where its curvature changes
#: fastest), the deepest point, and the corner cracks.
PARTITION_CASES = [
    ("semi_elliptical", 0.5, 15.0),
    ("semi_elliptical", 1.0, 90.0),
    ("corner", 1.0, 40.0),
    ("corner", 0.5, 45.0),
]


def _on_rank_0(serial):
    """``serial()`` on rank 0 alone (a COMM_SELF model), its result on every rank: the
    other ranks do not compile the same forms at the same time (under load one of them
    waited past the JIT cache's lock timeout)."""
    comm = MPI.COMM_WORLD
    return comm.bcast(serial() if comm.rank == 0 else None, root=0)


def _same_k(k, k1) -> None:
    for a, b in ((k.K_I, k1.K_I), (k.K_II, k1.K_II), (k.K_III, k1.K_III)):
        assert a == pytest.approx(b, rel=1e-8, abs=1e-8 * abs(k1.K_I))


@pytest.mark.parametrize(("kind", "a_c", "deg"), PARTITION_CASES)
def test_same_on_every_partition(kind, a_c, deg):
    """The distributed K (K_I, K_II, K_III) equals the serial K of the same mesh (built on
    COMM_SELF) to 1e-8 — the parallel counterpart of the serial Newman–Raju family."""
    if MPI.COMM_WORLD.size == 1:
        pytest.skip("needs several ranks")
    phi = math.radians(deg)
    k = solved(kind, a_c).k(phi)
    _same_k(k, _on_rank_0(lambda: solved(kind, a_c, MPI.COMM_SELF).k(phi)))


@pytest.mark.parametrize("z", [0.25, 0.5])
def test_through_crack_same_on_every_partition(z):
    """The straight front of the through crack (Gauss–Jacobi rules, the tangent-line
    auxiliary field) on several ranks equals its serial K — the parallel counterpart of
    :func:`test_through_crack_against_plane_strain`."""
    if MPI.COMM_WORLD.size == 1:
        pytest.skip("needs several ranks")
    if "through" not in _CACHE:
        _CACHE["through"] = solve_plate(THROUGH)
    k = _CACHE["through"].k(z)
    _same_k(k, _on_rank_0(lambda: solved_through_serial().k(z)))


def solved_through_serial():
    """The through crack on COMM_SELF (rank 0 only), cached."""
    if "through-self" not in _CACHE:
        _CACHE["through-self"] = solve_plate(THROUGH, MPI.COMM_SELF)
    return _CACHE["through-self"]


# ---------------------------------------------------------------- full size (slow)
FINE = {"h_front": A / 16, "grading": 0.12, "h_max": 0.2, "r_out": 0.3 * A}


#: Per-point tolerance of the fine mesh against Newman–Raju from 10° off the surface on:
#: their equations' own ±5 % (measured 2026-12-02: semi-elliptical a/c = 0.5 −4.0 … −2.3 %,
#: deepest −2.6 %; a/c = 1 −1.6 … +1.3 %; corner a/c = 0.5 −3.3 … −0.1 %, a/c = 1
#: −0.1 … +2.2 %; before the auxiliary field followed the ellipse, a/c = 0.5 was −5.6 % at
#: 15° — docs/theory/fracture.md#surface-breaking-cracks-in-3d).
FINE_TOL = 0.05


@pytest.mark.slow
@pytest.mark.parametrize(("kind", "a_c"), FAMILY)
def test_newman_raju_fine_mesh(kind, a_c):
    """Front a/16 (the benchmark's mesh, 19k–38k dofs): K_I within 3 % of Newman–Raju at
    the deepest point and within ``FINE_TOL`` (5 %) at every point from 10° off the
    surface on — every point, no mean; K_II, K_III below 1.5 % of K_I (zero by symmetry)."""
    sol = solved(kind, a_c, **FINE)
    p = sol.problem
    if kind == "corner":
        phis = np.radians([10.0, 15.0, 20.0, 30.0, 45.0, 60.0, 70.0, 80.0])
    else:
        phis = np.radians(
            [10.0, 15.0, 20.0, 30.0, 45.0, 60.0, 75.0, 90.0, 120.0, 150.0, 165.0, 170.0]
        )
    ks = [sol.k(phi) for phi in phis]
    err = np.array([k.K_I for k in ks]) / p.reference(phis) - 1.0
    if kind != "corner":
        assert abs(err[np.argmin(np.abs(phis - math.pi / 2))]) < 0.03, err
    assert np.all(np.abs(err) < FINE_TOL), err
    for k in ks:
        assert max(abs(k.K_II), abs(k.K_III)) < 0.015 * k.K_I  # measured ≤ 1.1 %
