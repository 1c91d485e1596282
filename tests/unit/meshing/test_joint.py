"""A joint from two bone surfaces (bonecontact.meshing.joint): pose, clip, cartilage, mesh.

References: the pose's gaps against an independent vertical ray cast (VTK's OBB tree,
``pyvista.PolyData.ray_trace``) and the closed-form tilt of a tilted cylinder; the clipped
volume of a box (exact); the cartilage layer on a sphere (offset vertices at R + t, the
volume of a spherical shell segment); the meshed volumes and areas against the surfaces'
own (divergence theorem: the boundary triangles are kept).  The meshing test runs
serially and under ``mpiexec -n 2`` (built on rank 0, measures summed over the ranks).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

from mpi4py import MPI

import numpy as np
import pytest
import pyvista as pv
from mesh_measures import group_vertices, measure

from bonecontact.meshing import MeshInputError, Surface, SurfaceRegion, anatomy_surface
from bonecontact.meshing.joint import (
    Cartilage,
    JointBone,
    cartilage_layer,
    clip_surface,
    joint_from_surfaces,
    pose_on,
)

COMM = MPI.COMM_WORLD
MM = 1e-3


def _surface(poly: pv.PolyData) -> Surface:
    poly = poly.triangulate().clean()
    return Surface(
        np.asarray(poly.points, float), poly.faces.reshape(-1, 4)[:, 1:].astype(np.int64)
    )


def _ray_gap(upper: Surface, lower: Surface, x: float, z: float) -> float:
    """Lowest crossing of ``upper`` minus highest of ``lower`` on the vertical line (x, z)."""
    ys = []
    for s in (upper, lower):
        pts, _ = s.to_pyvista().ray_trace((x, 10.0, z), (x, -10.0, z))
        assert len(pts), (x, z)
        ys.append(pts[:, 1])
    return float(ys[0].min() - ys[1].max())


def test_pose_levels_a_tilted_cylinder_on_a_block():
    """A horizontal cylinder (axis z) tilted by 5° in the frontal plane above a block:
    the pose turns it back by 5° and leaves the gap asked at both ends."""
    block = _surface(pv.Box((-0.03, 0.03, -0.02, 0.0, -0.05, 0.05)).triangulate())
    cyl = pv.Cylinder(center=(0, 0.02, 0), direction=(0, 0, 1), radius=0.01, height=0.08,
                      resolution=64)  # fmt: skip
    cyl = cyl.rotate_x(5.0, point=(0, 0.02, 0))
    upper = _surface(cyl)
    posed, pose = pose_on(upper, block, 2 * MM, spacing=0.25 * MM, tolerance=1e-6)
    assert abs(pose.angle) == pytest.approx(5.0, abs=0.05)
    np.testing.assert_allclose(pose.gaps, 2 * MM, atol=1e-6)
    np.testing.assert_allclose(pose.rotation @ pose.rotation.T, np.eye(3), atol=1e-12)
    # independent rays at the two contact points and along the bottom line
    for p in pose.points:
        assert _ray_gap(posed, block, p[0], p[2]) == pytest.approx(2 * MM, abs=2e-6)
    bottom = [_ray_gap(posed, block, 0.0, z) for z in np.linspace(-0.035, 0.035, 8)]
    np.testing.assert_allclose(bottom, 2 * MM, atol=0.02 * MM)  # levelled: 5° gone
    # the transform's matrix gives the posed points
    hom = np.c_[upper.points, np.ones(len(upper.points))] @ pose.matrix().T
    np.testing.assert_allclose(hom[:, :3], posed.points, atol=1e-12)


def test_pose_places_the_shipped_femur_on_the_tibia():
    """The shipped femur on the shipped tibia with a 4 mm gap (two 2 mm cartilage layers):
    both condyles 4 mm above the plateau by independent rays, nowhere closer; a rigid
    transform (volume and area kept)."""
    femur, tibia = anatomy_surface("femur"), anatomy_surface("tibia")
    posed, pose = pose_on(femur, tibia, 4 * MM)
    assert posed.volume == pytest.approx(femur.volume, rel=1e-12)
    assert posed.area == pytest.approx(femur.area, rel=1e-12)
    assert pose.points[0, 2] < pose.points[1, 2]  # one condyle on each side
    assert pose.points[1, 2] - pose.points[0, 2] > 20 * MM
    for p in pose.points:
        assert _ray_gap(posed, tibia, p[0], p[2]) == pytest.approx(4 * MM, abs=0.02 * MM)
    # no column of a 2 mm grid around the condyles is closer than the gap asked
    lo, hi = pose.points.min(axis=0) - 10 * MM, pose.points.max(axis=0) + 10 * MM
    gaps = []
    for x in np.arange(lo[0], hi[0], 2 * MM):
        for z in np.arange(lo[2], hi[2], 2 * MM):
            up, _ = posed.to_pyvista().ray_trace((x, 1.0, z), (x, -1.0, z))
            down, _ = tibia.to_pyvista().ray_trace((x, 1.0, z), (x, -1.0, z))
            if len(up) and len(down):
                gaps.append(up[:, 1].min() - down[:, 1].max())
    assert len(gaps) > 50 and min(gaps) > 4 * MM - 0.02 * MM


def test_clip_closes_the_cut():
    box = _surface(pv.Box((0.0, 0.02, 0.0, 0.05, 0.0, 0.03)))
    cut = clip_surface(box, (0.0, 0.03, 0.0), (0.0, 1.0, 0.0))
    assert cut.volume == pytest.approx(0.02 * 0.03 * 0.03, rel=1e-12)
    assert cut.points[:, 1].max() == pytest.approx(0.03, abs=1e-12)
    cap = SurfaceRegion("cap", cone=((0, 1, 0), 10)).select(cut.centroids(), cut.triangle_normals())
    assert cut.triangle_areas()[cap].sum() == pytest.approx(0.02 * 0.03, rel=1e-6)  # float32 box
    with pytest.raises(MeshInputError, match="does not cut"):
        clip_surface(box, (0.0, 0.1, 0.0), (0.0, 1.0, 0.0))


R, T = 0.02, 2 * MM


def _sphere(center=(0.0, 0.0, 0.0), nsub=3) -> Surface:
    return _surface(pv.Icosphere(radius=R, center=center, nsub=nsub))


def test_cartilage_layer_on_a_sphere():
    """A 2 mm layer on the cap of a sphere within 40° of +y: the offset vertices at R + t
    (the rim's at R: the layer tapers over the ring of facets at its rim), the volume
    between those of the spherical shell segments over the inner facets and over all."""
    s = _sphere(nsub=4)
    cap = np.flatnonzero(
        SurfaceRegion("cap", cone=((0, 1, 0), 40)).select(s.centroids(), s.triangle_normals())
    )
    layer = cartilage_layer(s, cap, T)
    t = layer.thickness()
    assert (t > 0).sum() > 20
    np.testing.assert_allclose(t[t > 0], T, rtol=1e-12)
    top = np.unique(layer.top)
    r = np.linalg.norm(layer.points[top], axis=1)
    np.testing.assert_allclose(r[r > R * (1 + 1e-3)], R + T, rtol=1e-3)
    # shell segments over the facets (area on the sphere of radius R)
    areas = s.triangle_areas()
    rim = np.isin(s.triangles[layer.facets], layer.base[np.isin(layer.base, layer.top)])
    full = areas[layer.facets].sum() / R**2 / 3 * ((R + T) ** 3 - R**3)
    inner = areas[layer.facets[~rim.any(axis=1)]].sum() / R**2 / 3 * ((R + T) ** 3 - R**3)
    assert inner < layer.volume < full


def test_joint_mesh_groups_volumes_and_thickness():
    """Two spheres 2t apart, each with a cortex and a cartilage layer of thickness t facing
    the other: the groups, the bone volumes (the surface's, exactly), the cartilage
    volumes (the layer's closed surface, exactly), the contact areas (the offset
    triangles), and the articular vertices at R + t from each centre (the thickness as
    asked, to the facets' chord error: far below one element)."""
    h = 4 * MM
    lower = _sphere()
    upper = _sphere(center=(0.0, 2 * R + 2 * T, 0.0))
    up_c = Cartilage(
        "upper_cartilage", "upper_contact", (SurfaceRegion("c", cone=((0, -1, 0), 35)),), T
    )
    lo_c = Cartilage(
        "lower_cartilage", "lower_contact", (SurfaceRegion("c", cone=((0, 1, 0), 35)),), T
    )
    bones = [
        JointBone("upper", upper, 4 * MM, cartilage=up_c),
        JointBone("lower", lower, 4 * MM, cartilage=lo_c),
    ]
    md = joint_from_surfaces(bones, h, remesh=False, comm=COMM)
    names = {"cortical", "cancellous", "cartilage", "contact", "surface"}
    assert set(md.physical_groups) == {f"{b}_{n}" for b in ("upper", "lower") for n in names}
    for name, s, cart in (("upper", upper, up_c), ("lower", lower, lo_c)):
        bone = measure(md, f"{name}_cortical") + measure(md, f"{name}_cancellous")
        assert bone == pytest.approx(s.volume, rel=1e-10)
        layer = cartilage_layer(s, cart.select(s), T)
        assert measure(md, f"{name}_cartilage") == pytest.approx(layer.volume, rel=1e-10)
        p = layer.points[layer.top]
        a = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
        assert measure(md, f"{name}_contact") == pytest.approx(a.sum(), rel=1e-10)
        # the articular vertices off the rim (where the layer tapers) at R + t
        _, x = group_vertices(md, f"{name}_contact")
        r = np.linalg.norm(x - s.points.mean(axis=0), axis=1)
        inner = r > R + 1e-3 * T
        assert inner.sum() > 10
        np.testing.assert_allclose(r[inner], R + T, rtol=2e-3)
        np.testing.assert_allclose(r[~inner], R, rtol=1e-3)
    # the two layers touch at the pole: the gap between the bones is 2t
    _, xu = group_vertices(md, "upper_contact")
    _, xl = group_vertices(md, "lower_contact")
    assert xu[:, 1].min() - xl[:, 1].max() == pytest.approx(0.0, abs=0.01 * T)
