"""A front point whose interaction-integral domain is empty or misses the front
(fracture.front3d; issue #26: a ZeroDivisionError in the normalisation on a finer
vertebra mesh).

K = I / ∫ q_h (e₁·e₁(s)) ds: the front integral of q is about 1.5 times the domain's
half-length along the front for a whole domain and 0.73 times for one halved by a
symmetry plane through the point (measured 1.43–1.53 and 0.735 on the penny octant and
the Newman–Raju plates).  The octant of a penny crack (radius 1, front 1/12, block 4;
E = 1, ν = 0.3, σ = 1 on top; the closed form K_I = 2σ√(a/π)):

* points of the circle outside the octant (φ = −45°, 180°, 270°): their domain holds no
  cell — a ParameterError naming ``phi``, the point and why, on every rank (before:
  ZeroDivisionError);
* the front moved 0.05 below the crack plane (outside the model): the domain holds the
  cells around the meshed front but q_h on the moved front is 0 — refused by the floor
  of the front integral (0.5 times the length), naming the point;
* the points inside (0°, 45°, 90°: two of them on a symmetry plane, front integral 0.73
  times the length) still give K_I within 2.5 % of the closed form (measured +0.1, +1.4,
  −0.03 %).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import dataclasses
import math

from mpi4py import MPI

import pytest

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.front3d import (
    NORM_FLOOR,
    EllipticalFront,
    front_interaction_integral,
    mesh_crack_octant,
    penny_k,
)
from bonecontact.materials.laws import Isotropic
from bonecontact.verification.crack_octant import solve_crack_octant

MAT = Isotropic(E=1.0, nu=0.3)
R_OUT = 0.3


@pytest.fixture(scope="module")
def penny():
    front = EllipticalFront(1.0, 1.0)
    blk = mesh_crack_octant(front, 4.0, 1.0 / 12, 0.12, 1.0, MPI.COMM_WORLD)
    return blk, solve_crack_octant(blk, MAT, 1.0)


def _fails_on_every_rank(call) -> str:
    """The message of the ParameterError ``call`` raises (asserted on every rank)."""
    try:
        call()
    except ParameterError as exc:
        text = str(exc)
    else:
        text = ""
    assert all(MPI.COMM_WORLD.allgather(bool(text))), "not refused on every rank"
    return text


@pytest.mark.parametrize("deg", [-45.0, 180.0, 270.0])
def test_point_outside_the_model_is_refused(penny, deg: float) -> None:
    blk, u = penny
    phi = math.radians(deg)
    text = _fails_on_every_rank(lambda: front_interaction_integral(u, blk, phi, MAT, R_OUT))
    assert text.startswith("phi: ") and "holds no cell" in text and "no K there" in text, text
    x, y = math.cos(phi), math.sin(phi)
    assert f"phi = {phi:.6g} at ({x:.6g}, {y:.6g}, 0)" in text, text


def test_front_off_its_mesh_is_refused(penny) -> None:
    """The front 0.05 below the model: the domain has cells (around the real front) but
    q_h on the given front is 0, below the floor."""
    blk, u = penny
    moved = dataclasses.replace(blk, front=EllipticalFront(1.0, 1.0, (0.0, 0.0, -0.05)))
    phi = math.pi / 4

    text = _fails_on_every_rank(lambda: front_interaction_integral(u, moved, phi, MAT, R_OUT))
    assert text.startswith("phi: ") and "front integral of q" in text, text
    assert f"less than {NORM_FLOOR:g} times the length" in text and "is 0 m" in text, text


@pytest.mark.parametrize("deg", [0.0, 45.0, 90.0])
def test_points_inside_still_give_k(penny, deg: float) -> None:
    blk, u = penny
    k = front_interaction_integral(u, blk, math.radians(deg), MAT, R_OUT)
    assert k.K_I == pytest.approx(penny_k(1.0, 1.0), rel=0.025)
