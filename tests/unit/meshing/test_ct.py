"""CT import (bonecontact.meshing.ct): a synthetic DICOM phantom made here with pydicom
(discs of known Hounsfield units and radii) and pydicom's own test image CT_small.dcm.

References: the exact disc areas (segmented areas within half a pixel times the contour
length), the segmented polygon area for the mesh, a sphere's volume for a series.
Runs serially and under ``mpiexec -n 2`` (meshes built on rank 0 and distributed).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import math

from mpi4py import MPI

import numpy as np
import pydicom
import pytest
from mesh_measures import measure
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.uid import CTImageStorage, ExplicitVRLittleEndian, generate_uid

from bonecontact.meshing import MeshInputError, bone_from_surface
from bonecontact.meshing.ct import (
    bone_regions,
    ct_bone_surface,
    ct_slice_mesh,
    polygon_area,
    read_ct_series,
    read_ct_slice,
)

COMM = MPI.COMM_WORLD
PIXEL = 0.5e-3  # m
SLOPE, INTERCEPT = 0.5, -1024.0  # stored = (HU - intercept) / slope
#: (row, column) centre in pixels, radius in pixels, HU
DISCS = [((40.3, 42.7), 15.2, 1200.0), ((85.6, 84.1), 20.4, 400.0)]


def phantom(n=128, discs=DISCS, supersample=8):
    """Water (0 HU) with discs, partial-volume averaged over each pixel."""
    sub = (np.arange(n * supersample) + 0.5) / supersample - 0.5
    r, c = np.meshgrid(sub, sub, indexing="ij")
    hu = np.zeros_like(r)
    for (r0, c0), rad, value in discs:
        hu[(r - r0) ** 2 + (c - c0) ** 2 <= rad**2] = value
    return hu.reshape(n, supersample, n, supersample).mean(axis=(1, 3))


def write_dicom(path, hu, position=(0.0, 0.0, 0.0)):
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = CTImageStorage
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = Dataset()
    ds.file_meta = meta
    ds.SOPClassUID, ds.SOPInstanceUID = CTImageStorage, meta.MediaStorageSOPInstanceUID
    ds.Modality = "CT"
    ds.Rows, ds.Columns = hu.shape
    ds.PixelSpacing = [PIXEL * 1e3, PIXEL * 1e3]  # mm
    ds.ImagePositionPatient = list(position)
    ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
    ds.RescaleSlope, ds.RescaleIntercept = SLOPE, INTERCEPT
    ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
    ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 0
    ds.PixelData = np.round((hu - INTERCEPT) / SLOPE).astype(np.uint16).tobytes()
    ds.save_as(path, enforce_file_format=True)
    return path


def disc_area(k):
    return math.pi * (DISCS[k][1] * PIXEL) ** 2


def test_rescale_and_spacing(tmp_path):
    hu = phantom()
    image = read_ct_slice(write_dicom(tmp_path / "p.dcm", hu))
    assert image.spacing == pytest.approx((PIXEL, PIXEL))
    np.testing.assert_allclose(image.hu, hu, atol=SLOPE / 2)  # stored values are rounded


@pytest.mark.parametrize(
    ("threshold", "found"),
    [(600.0, [0]), (200.0, [0, 1])],  # half of each disc's HU: the dense disc alone, both
)
def test_phantom_areas(tmp_path, threshold, found):
    image = read_ct_slice(write_dicom(tmp_path / "p.dcm", phantom()))
    regions = bone_regions(image, threshold)
    assert len(regions) == len(found)
    areas = sorted(polygon_area(outer) for outer, holes in regions)
    exact = sorted(disc_area(k) for k in found)
    for (outer, holes), a, ref in zip(regions, areas, exact):
        assert holes == []
        length = np.linalg.norm(np.diff(np.vstack([outer, outer[:1]]), axis=0), axis=1).sum()
        assert abs(a - ref) <= 0.5 * PIXEL * length  # half a pixel along the contour


def test_ring_has_a_hole_and_meshes(tmp_path):
    ring = phantom(discs=[((64.0, 64.0), 30.0, 1000.0), ((64.0, 64.0), 18.0, 0.0)])
    path = COMM.bcast(str(write_dicom(tmp_path / "ring.dcm", ring)), root=0)
    image = read_ct_slice(path)
    ((outer, holes),) = bone_regions(image, 500.0)
    assert len(holes) == 1
    exact = math.pi * (30.0**2 - 18.0**2) * PIXEL**2
    length = sum(
        np.linalg.norm(np.diff(np.vstack([p, p[:1]]), axis=0), axis=1).sum()
        for p in [outer, *holes]
    )
    segmented = polygon_area(outer) + polygon_area(holes[0])  # the hole is clockwise
    assert abs(segmented - exact) <= 0.5 * PIXEL * length
    md = ct_slice_mesh(path, 500.0, h=2 * PIXEL, name="ring", comm=COMM)
    assert set(md.physical_groups) == {"ring", "ring_outer", "ring_inner"}
    # the mesh's boundary is the contours resampled at h: area within 0.5 % of the polygons
    assert measure(md, "ring") == pytest.approx(segmented, rel=5e-3)
    assert measure(md, "ring_outer") == pytest.approx(2 * math.pi * 30 * PIXEL, rel=0.02)
    assert measure(md, "ring_inner") == pytest.approx(2 * math.pi * 18 * PIXEL, rel=0.02)


def test_pydicom_ct_small_bone_is_found_and_meshed():
    from pydicom.data import get_testdata_file

    path = get_testdata_file("CT_small.dcm")  # ships inside the pydicom wheel (offline)
    assert path is not None
    image = read_ct_slice(path)
    ds = pydicom.dcmread(path)
    ref = ds.pixel_array * float(ds.RescaleSlope) + float(ds.RescaleIntercept)
    np.testing.assert_array_equal(image.hu, ref)
    regions = bone_regions(image, 300.0)
    area = sum(polygon_area(o) + sum(polygon_area(x) for x in holes) for o, holes in regions)
    pixels = np.count_nonzero(image.hu > 300.0) * image.spacing[0] * image.spacing[1]
    assert area == pytest.approx(pixels, rel=0.1)  # the contours enclose the bone pixels
    md = ct_slice_mesh(path, 300.0, name="vertebra", comm=COMM)
    assert {"vertebra", "vertebra_outer"} <= set(md.physical_groups)
    assert measure(md, "vertebra") == pytest.approx(area, rel=0.05)


def test_no_bone_is_refused(tmp_path):
    path = COMM.bcast(str(write_dicom(tmp_path / "water.dcm", np.zeros((32, 32)))), root=0)
    with pytest.raises(MeshInputError, match=r"water\.dcm: no region above 300 HU"):
        ct_slice_mesh(path, 300.0, comm=COMM)
    not_dicom = tmp_path / "x.dcm"
    not_dicom.write_text("hello")
    with pytest.raises(MeshInputError, match="not a DICOM file"):
        read_ct_slice(not_dicom)


def test_series_of_a_sphere_to_surface_and_volume(tmp_path):
    radius, n = 12.0, 40  # pixels (slices spaced like the pixels)
    z = np.arange(n) - n / 2 + 0.5
    for k, zk in enumerate(z):
        rk = math.sqrt(max(radius**2 - zk**2, 0.0))
        hu = phantom(n=n, discs=[((n / 2, n / 2), rk, 1000.0)], supersample=4)
        write_dicom(tmp_path / f"s{k:03d}.dcm", hu, position=(0.0, 0.0, zk * PIXEL * 1e3))
    image = read_ct_series(tmp_path)
    assert image.hu.shape == (n, n, n)
    surface = ct_bone_surface(image, 500.0)
    exact = 4 / 3 * math.pi * (radius * PIXEL) ** 3
    assert surface.volume == pytest.approx(exact, rel=0.05)
    md = bone_from_surface(surface, 2 * PIXEL, name="ball", comm=COMM)  # remeshed: R/h = 6
    assert measure(md, "ball") == pytest.approx(surface.volume, rel=0.02)
