"""A cartilage layer shaped to the facing bone (``Cartilage(..., conform_to=...)``).

Two spheres of radius R, the upper one carrying a uniform layer of thickness T on its
underside, the lower one a layer conformed to it with a clearance c and at most Tmax
thick.  References: the exact distance along each vertex normal from the lower sphere
to the upper cartilage sphere (radius R + T), less c (the faceted surfaces differ from
it by their chord error, edge²/(4R)); the two layers do not cross (VTK's collision
filter) and the meshed volumes equal the layers' closed surfaces (divergence theorem).
Built serially and under ``mpiexec -n 2`` (the mesh on rank 0, measures summed).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

from mpi4py import MPI

import numpy as np
import pytest
import pyvista as pv
from mesh_measures import measure

from bonecontact.meshing import MeshInputError, Surface, SurfaceRegion
from bonecontact.meshing.joint import Cartilage, JointBone, cartilage_layer, joint_from_surfaces

COMM = MPI.COMM_WORLD
MM = 1e-3
R, T, TMAX, TMIN = 0.02, 2 * MM, 3 * MM, 1.0 * MM


def _sphere(center, nsub: int) -> Surface:
    poly = pv.Icosphere(radius=R, center=center, nsub=nsub).triangulate().clean()
    return Surface(
        np.asarray(poly.points, float), poly.faces.reshape(-1, 4)[:, 1:].astype(np.int64)
    )


def _pair(nsub: int, clearance: float, dx: float):
    """The two spheres, the gap between the bones T + c + TMIN on the line of centres
    (tilted by the horizontal offset dx), and the two cartilages."""
    d = 2 * R + T + clearance + TMIN
    centre = np.array([dx, np.sqrt(d**2 - dx**2), 0.0])
    upper, lower = _sphere(centre, nsub), _sphere((0.0, 0.0, 0.0), nsub)
    up_c = Cartilage("up_cart", "up_contact", (SurfaceRegion("c", cone=((0, -1, 0), 35)),), T)
    lo_c = Cartilage(
        "lo_cart", "lo_contact", (SurfaceRegion("c", cone=((0, 1, 0), 40)),), TMAX,
        conform_to="upper", clearance=clearance,
    )  # fmt: skip
    return upper, lower, centre, up_c, lo_c


def _exact_thickness(p: np.ndarray, n: np.ndarray, centre: np.ndarray, c: float) -> np.ndarray:
    """Distance s along the unit n from p to the sphere |x - centre| = R + T, less c."""
    q = p - centre
    b = np.einsum("ij,ij->i", q, n)
    disc = b**2 - (np.einsum("ij,ij->i", q, q) - (R + T) ** 2)
    s = -b - np.sqrt(np.where(disc >= 0, disc, 0.0))
    return np.where((disc >= 0) & (s > 0), s - c, np.inf)  # inf: the ray misses it


@pytest.mark.parametrize(
    ("nsub", "clearance", "dx"),
    [
        (3, 0.2 * MM, 0.0),
        (3, 0.5 * MM, 6 * MM),
        pytest.param(4, 0.5 * MM, 0.0, marks=pytest.mark.slow),  # finer facets: 25-30 s
        pytest.param(4, 0.2 * MM, 6 * MM, marks=pytest.mark.slow),
    ],
)
def test_conformed_layer_follows_the_other_surface(nsub, clearance, dx):
    """Each inner vertex of the conformed layer sits at the exact normal distance to the
    upper cartilage sphere less the clearance (to the chord error), or at TMAX where
    that is farther; the patch where it conforms is not a few nodes (its vertices reach
    the analytic radius); the layer encloses a positive volume and does not cross the
    upper layer."""
    upper, lower, centre, up_c, lo_c = _pair(nsub, clearance, dx)
    top = cartilage_layer(upper, up_c.select(upper), T)
    target = Surface(top.points, np.vstack([top.top, upper.triangles[
        np.setdiff1d(np.arange(len(upper.triangles)), top.facets)]]), "upper")  # fmt: skip
    layer = cartilage_layer(lower, lo_c.select(lower), TMAX, (target, clearance))
    assert layer.volume > 0
    base, tv = layer.base.ravel(), layer.top.ravel()
    inner = base != tv
    b, t = np.unique(np.c_[base[inner], tv[inner]], axis=0).T
    n = layer.points[t] - layer.points[b]
    thick = np.linalg.norm(n, axis=1)
    n /= thick[:, None]
    exact = np.minimum(_exact_thickness(layer.points[b], n, centre, clearance), TMAX)
    edge = np.linalg.norm(lower.points[lower.triangles[:, 1]] - lower.points[lower.triangles[:, 0]],
                          axis=1).max()  # fmt: skip
    np.testing.assert_allclose(thick, exact, atol=edge**2 / (4 * R))
    conformed = thick < TMAX - 1e-9
    assert conformed.sum() >= (7 if nsub == 3 else 19)  # a patch, not a few nodes
    # the shortest gap from the conformed vertices to the upper cartilage sphere is the
    # clearance, measured along the normal: c cos(angle between normal and radius)
    q = centre - layer.points[t[conformed]]
    gap = np.linalg.norm(q, axis=1) - (R + T)
    cos = np.einsum("ij,ij->i", n[conformed], q) / np.linalg.norm(q, axis=1)
    assert cos.min() > 0.8
    np.testing.assert_allclose(gap, clearance * cos, atol=edge**2 / (4 * R))
    hit, count = target.to_pyvista().collision(
        Surface(layer.points, layer.top, "lower").to_pyvista(), contact_mode=0
    )
    assert count == 0


def test_conformed_joint_mesh_volumes():
    """The joint meshed with a conformed layer: the cartilage volumes are the layers'
    (exactly: the boundary triangles are kept), the tibial layer thicker than TMIN."""
    upper, lower, centre, up_c, lo_c = _pair(3, 0.5 * MM, 3 * MM)
    bones = [
        JointBone("upper", upper, 4 * MM, cartilage=up_c),
        JointBone("lower", lower, 4 * MM, cartilage=lo_c),
    ]
    md = joint_from_surfaces(bones, 4 * MM, remesh=False, comm=COMM)
    top = cartilage_layer(upper, up_c.select(upper), T)
    assert measure(md, "up_cart") == pytest.approx(top.volume, rel=1e-10)
    vol = measure(md, "lo_cart")
    assert vol > 0
    # the uniform layer of TMAX would be larger: the conformed one is trimmed
    assert vol < cartilage_layer(lower, lo_c.select(lower), TMAX).volume


def test_conform_to_refuses_unknown_bone_and_close_bones():
    """conform_to naming no earlier bone with cartilage, and bones closer than the
    clearance: MeshInputError naming the cause."""
    upper, lower, _, up_c, lo_c = _pair(3, 0.5 * MM, 0.0)
    bad = Cartilage("lo", "lo_c", lo_c.regions, TMAX, conform_to="femur", clearance=0.5 * MM)
    with pytest.raises(MeshInputError, match="conform_to = 'femur'"):
        joint_from_surfaces([JointBone("upper", upper, cartilage=up_c),
                             JointBone("lower", lower, cartilage=bad)], 4 * MM, remesh=False,
                            comm=COMM)  # fmt: skip
    top = cartilage_layer(upper, up_c.select(upper), T)
    target = Surface(top.points, top.top, "upper")
    with pytest.raises(MeshInputError, match="pose the bones further apart"):
        cartilage_layer(lower, lo_c.select(lower), TMAX, (target, 1.5 * MM))
    with pytest.raises(ValueError, match="clearance"):
        Cartilage("x", "y", lo_c.regions, TMAX, conform_to="upper", clearance=-1.0)
