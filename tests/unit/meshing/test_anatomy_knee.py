"""The 2D knee builder (bonecontact.meshing.anatomy.knee_2d), flat and concave plateau:
measures of the named groups against the exact geometry.

Family over the plateau (flat; concave of radius 40 mm as shipped, 50 mm) on a coarse
mesh, and the shipped meshes.  The tibial cartilage of a concave plateau of radius R_t
and half width w is the part |x| ≤ w of the ring R_t ≤ r ≤ R_t + h below the centre
(0, R_t): area F(R_t + h) - F(R_t), F(r) = w √(r² - w²) + r² asin(w/r) (the area under
the lower arc of radius r over [-w, w] is measured from the centre's height); its surface
is the arc of length 2 R_t asin(w/R_t).  Chords make the discrete area and length differ
by O((h_c/R)²): tolerance 2e-3.  Runs serially and under ``mpiexec -n 2/3``.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx.io.gmsh import read_from_msh
from mesh_measures import group_vertices, measure

from bonecontact.meshing import anatomy

COMM = MPI.COMM_WORLD
SCENES = Path(__file__).resolve().parents[3] / "data" / "scenes"
R_F, CART, CORT = 0.03, 3e-3, 2e-3  # the builder's defaults (m)


def _segment(r: float, w: float) -> float:
    """Area between the horizontal through the centre and the lower arc of radius r, |x| ≤ w."""
    return w * math.sqrt(r * r - w * w) + r * r * math.asin(w / r)


def check_knee(md, plateau_radius: float | None, w: float) -> None:
    """Every tibial layer and both contact surfaces against the exact geometry."""
    if plateau_radius is None:
        cart, cort, contact = 2 * w * CART, 2 * w * CORT, 2 * w
    else:
        rt, rc = plateau_radius, plateau_radius + CART
        cart = _segment(rc, w) - _segment(rt, w)
        cort = _segment(rc + CORT, w) - _segment(rc, w)
        contact = 2 * rt * math.asin(w / rt)
    assert measure(md, "tibia_cartilage") == pytest.approx(cart, rel=2e-3)
    assert measure(md, "tibia_cortical") == pytest.approx(cort, rel=2e-3)
    assert measure(md, "tibia_contact") == pytest.approx(contact, rel=2e-3)
    assert measure(md, "femur_contact") == pytest.approx(math.pi * R_F, rel=2e-3)
    _, xt = group_vertices(md, "tibia_contact")
    if plateau_radius is None:
        assert np.allclose(xt[:, 1], 0.0, atol=1e-12)
    else:
        r = np.hypot(xt[:, 0], xt[:, 1] - plateau_radius)
        assert np.allclose(r, plateau_radius, rtol=1e-9)
    _, xf = group_vertices(md, "femur_contact")
    assert np.allclose(np.hypot(xf[:, 0], xf[:, 1] - R_F), R_F, rtol=1e-9)
    # the joint opens away from the origin: no tibial contact vertex above the condyle
    inside = np.abs(xt[:, 0]) < R_F
    assert (xt[inside, 1] <= R_F - np.sqrt(R_F**2 - xt[inside, 0] ** 2) + 1e-12).all()


@pytest.mark.parametrize(
    ("plateau_radius", "w"), [(None, 0.045), (0.04, 0.034), (0.05, 0.04)], ids=str
)
def test_knee_2d_plateau(plateau_radius, w):
    md = anatomy.knee_2d(
        COMM, plateau_radius=plateau_radius, plateau_half_width=w, h_contact=1.5e-3, h_far=6e-3
    )
    assert {"tibia_contact", "femur_contact", "tibia_bottom", "femur_sides"} <= set(
        md.physical_groups
    )
    check_knee(md, plateau_radius, w)


@pytest.mark.parametrize("name", ["knee2d", "knee2d_tumour"])
def test_shipped_knee_meshes(name):
    """The shipped meshes: the concave seat of data/scenes/make_meshes.py, ≤ 1 MB."""
    path = SCENES / f"{name}.msh"
    assert path.stat().st_size < 1_000_000
    check_knee(read_from_msh(path, COMM, 0, gdim=2), 0.04, 0.034)


@pytest.mark.parametrize(("plateau_radius", "w"), [(0.03, 0.02), (0.035, 0.04)])
def test_plateau_not_wider_than_condyle_or_seat_is_rejected(plateau_radius, w):
    with pytest.raises(ValueError, match="plateau_radius must exceed"):
        anatomy.knee_2d(COMM, plateau_radius=plateau_radius, plateau_half_width=w)
