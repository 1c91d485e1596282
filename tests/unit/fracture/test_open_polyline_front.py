"""The open polyline front of a grown surface-breaking crack
(bonecontact.fracture.front3d.OpenPolylineFront).

* Geometry against hand-computed values on a front with a kink in its plane and one out
  of it (a family of three fronts): points, the parameter of nearest points (clipped at
  both ends, not wrapped), arc length, the distance to the nearer end of the edge (a
  corner or the free surface), the frame of every edge (orthonormal, e₁ = t × e₂, e₂ the
  edge's normal), the edges' midpoints; bad input is refused with the key named.
* K by the interaction integral on the through crack of a plate
  (bonecontact.verification.surface_crack, an edge crack through the thickness, coarse):
  the front given as an open polyline of one edge, two and three collinear edges, gives
  the straight front's K_I, K_II, K_III at the same points and domains (1e-9 of K_I: the
  same q-function and auxiliary field, a second description of the same front), and K_I
  at mid-thickness within 6 % of the plane-strain K of the 2D section.  Serially and on
  the session's ranks.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import dataclasses
import math

import numpy as np
import pytest

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.front3d import OpenPolylineFront, front_interaction_integral
from bonecontact.fracture.surface3d import SurfaceCrack, domain_length
from bonecontact.verification.surface_crack import (
    PlateProblem,
    plane_strain_edge_k,
    solve_plate,
)

Z = (0.0, 0.0, 1.0)


def _front(turn: float) -> OpenPolylineFront:
    """Three edges: (0,0,0) → (1,0,0) → (1 + cos τ, sin τ, 0) → … + (0, 0, −1)·0.5, the
    crack surface on the side −y of the first edge (e₂ = +z on the first two edges, the
    third edge's normal turned about it)."""
    c, s = math.cos(turn), math.sin(turn)
    V = np.array([[0, 0, 0], [1, 0, 0], [1 + c, s, 0], [1 + c, s, -0.5]], dtype=float)
    n3 = np.array([-s, c, 0.0])  # normal to the third edge (along −z)
    return OpenPolylineFront(tuple(map(tuple, V)), (Z, Z, tuple(n3)), None, Z)


@pytest.mark.parametrize("turn_deg", [0.0, 30.0, 75.0])
def test_geometry(turn_deg: float) -> None:
    f = _front(math.radians(turn_deg))
    V = np.asarray(f.vertices)
    L = np.array([1.0, 1.0, 0.5])
    assert f.perimeter == pytest.approx(2.5, rel=1e-14)
    np.testing.assert_allclose(f.edge_lengths, L, rtol=1e-14)
    assert not f.closed
    # the parameter: φ = 2π s / L_total, the ends 0 and 2π (not wrapped)
    phi = 2 * math.pi * np.array([0.0, 0.5, 1.0, 1.5, 2.25, 2.5]) / 2.5
    expect = np.array([V[0], [0.5, 0, 0], V[1], 0.5 * (V[1] + V[2]), V[2] + [0, 0, -0.25], V[3]])
    np.testing.assert_allclose(f.point(phi), expect, atol=1e-14)
    np.testing.assert_allclose(f.arc_length(phi), [0, 0.5, 1, 1.5, 2.25, 2.5], atol=1e-14)
    np.testing.assert_allclose(f.edge_middles(), 2 * math.pi * np.array([0.5, 1.5, 2.25]) / 2.5)
    # nearest: points off the front, and beyond either end clipped to that end
    x = np.array([[0.5, -0.3, 0.2], [-0.4, 0.1, 0.0], [V[3, 0], V[3, 1], -3.0]])
    np.testing.assert_allclose(
        f.nearest(x), [2 * math.pi * 0.5 / 2.5, 0.0, 2 * math.pi], atol=1e-14
    )
    # distance to the nearer end of the edge (a corner or the free surface)
    assert f.corner_distance(2 * math.pi * 0.3 / 2.5) == pytest.approx(0.3, abs=1e-14)
    assert f.corner_distance(2 * math.pi * 1.8 / 2.5) == pytest.approx(0.2, abs=1e-14)
    assert f.corner_distance(2 * math.pi * 2.4 / 2.5) == pytest.approx(0.1, abs=1e-14)
    # the frame of every edge: e₁ = t × e₂ ahead, e₂ the edge's normal, e₃ = e₁ × e₂ = −t
    for k, p in enumerate(f.edge_middles()):
        t = (V[k + 1] - V[k]) / L[k]
        e1, e2, e3 = f.frame(float(p))
        np.testing.assert_allclose(e2, f.normals2[k], atol=1e-14)
        np.testing.assert_allclose(e1, np.cross(t, e2), atol=1e-14)
        np.testing.assert_allclose(e3, -t, atol=1e-14)
        np.testing.assert_allclose(
            np.array([e1, e2, e3]) @ np.array([e1, e2, e3]).T, np.eye(3), atol=1e-14
        )
        np.testing.assert_allclose(f.normals(p)[0], e1, atol=1e-14)
    assert f.radius_of_curvature(1.0) == math.inf


def test_bad_input_is_refused() -> None:
    V = ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (2.0, 0.0, 0.0))
    with pytest.raises(ParameterError, match="normals2"):
        OpenPolylineFront(V, (Z,), None, Z)
    with pytest.raises(ParameterError, match="cuts"):
        OpenPolylineFront(V, (Z, Z), ((1.0, 0.0),), Z)
    with pytest.raises(ParameterError, match="vertices"):
        OpenPolylineFront((V[0], V[0], V[1]), (Z, Z), None, Z)


#: The through crack of the surface-crack verification, coarser (front 0.1, 10 elements
#: through the thickness).
THROUGH = PlateProblem(
    SurfaceCrack("through", 0.4),
    b=2.0,
    h=2.0,
    t=1.0,
    h_front=0.1,
    grading=0.2,
    h_max=0.5,
    r_out=0.2,
)
_SOLVED: dict = {}


def _solved():
    if "through" not in _SOLVED:
        _SOLVED["through"] = solve_plate(THROUGH)
    return _SOLVED["through"]


def _as_polyline(front, cuts: tuple[float, ...]) -> OpenPolylineFront:
    """The straight front as collinear edges with vertices at the fractions ``cuts`` of
    it, e₁ = t × e₂ ahead."""
    V = front.point(np.array([0.0, *cuts, 1.0]))
    n = tuple(map(float, front.normal))
    return OpenPolylineFront(tuple(map(tuple, V)), (n,) * (len(cuts) + 1), None, n)


@pytest.mark.parametrize("cuts", [(), (0.3,), (0.3, 0.85)])
def test_k_equals_the_straight_front(cuts: tuple[float, ...]) -> None:
    sol = _solved()
    blk, p = sol.block, THROUGH
    straight = blk.front
    poly = _as_polyline(straight, cuts)
    np.testing.assert_allclose(poly.frame(1.0)[0], straight.frame(0.5)[0], atol=1e-14)
    polyblock = dataclasses.replace(blk, front=poly)
    for z in (0.5, 0.65):  # 0.2 and 0.35 from the vertex at 0.3
        phi = 2 * math.pi * z
        length = min(
            domain_length(straight, z, p.r_out, p.h_front),
            poly.corner_distance(phi) * (1 - 1e-6),
        )
        ref = front_interaction_integral(sol.u, blk, z, p.material, p.r_out, None, length)
        got = front_interaction_integral(sol.u, polyblock, phi, p.material, p.r_out, None, length)
        np.testing.assert_allclose(got.point, ref.point, atol=1e-12)
        for key in ("K_I", "K_II", "K_III"):
            assert getattr(got, key) == pytest.approx(getattr(ref, key), abs=1e-9 * ref.K_I)
        if z == 0.5 and not cuts:
            # (the coarse mesh; the fine one of the verification suite is within 5 %)
            assert got.K_I == pytest.approx(plane_strain_edge_k(p), rel=0.06)
