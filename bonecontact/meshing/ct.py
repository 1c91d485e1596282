"""Bone from CT: DICOM images, a threshold in Hounsfield units, contours, a gmsh mesh.

:func:`read_ct_slice` reads one DICOM image into Hounsfield units (the stored values times
``RescaleSlope`` plus ``RescaleIntercept``) with its pixel spacing in metres;
:func:`bone_regions` thresholds it and finds the boundary contours at sub-pixel accuracy
(:func:`skimage.measure.find_contours`, linear interpolation between pixel centres), sorts
them into outer boundaries and holes by nesting, and drops pieces smaller than a minimum
area; :func:`ct_slice_mesh` meshes the bone region with gmsh (triangles, groups ``<name>``,
``<name>_outer`` for the outer boundaries and ``<name>_inner`` for the holes).

A series (:func:`read_ct_series`, one folder of slices) gives a volume of Hounsfield
units; :func:`ct_bone_surface` extracts the bone surface by marching cubes as a
:class:`~bonecontact.meshing.surface_repair.Surface` in metres, which
:func:`~bonecontact.meshing.stl.bone_from_surface` turns into a tetrahedral bone.

Coordinates: x along the image columns, y = minus the image rows (the image as displayed,
top up), origin at the centre of the first pixel plus ``ImagePositionPatient``; metres.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

import gmsh
import numpy as np
from dolfinx.io.gmsh import MeshData

from bonecontact.meshing.builder import PhysicalGroups, check_positive, generate
from bonecontact.meshing.report import MeshReport, msh_report, run_report_command
from bonecontact.meshing.surface_repair import MeshInputError, Surface, split_components

__all__ = [
    "CTImage",
    "bone_regions",
    "ct_bone_surface",
    "ct_slice_mesh",
    "main",
    "mesh_ct",
    "polygon_area",
    "read_ct_series",
    "read_ct_slice",
    "region_area",
    "select_bodies",
]

#: air, outside every image (HU)
AIR = -1000.0


@dataclass(frozen=True)
class CTImage:
    """Hounsfield units on a pixel (2D) or voxel (3D) grid.

    ``hu`` is (rows, columns) or (slices, rows, columns); ``spacing`` the matching pixel
    sizes in m; ``origin`` the position of the first pixel's centre (m, patient frame);
    ``source`` the file or folder.
    """

    hu: np.ndarray
    spacing: tuple[float, ...]
    origin: tuple[float, float, float]
    source: str


def _hounsfield(ds, path: Path) -> np.ndarray:
    """Stored pixel values → HU (RescaleSlope, RescaleIntercept; 1 and 0 if absent)."""
    try:
        raw = ds.pixel_array
    except Exception as exc:  # pydicom raises several kinds for missing/undecodable pixels
        raise MeshInputError(f"{path}: no readable pixel data ({exc})") from exc
    slope = float(getattr(ds, "RescaleSlope", 1.0))
    intercept = float(getattr(ds, "RescaleIntercept", 0.0))
    return raw.astype(np.float64) * slope + intercept


def _read(path: Path):
    import pydicom

    if not path.is_file():
        raise MeshInputError(f"{path}: no such file")
    try:
        return pydicom.dcmread(path)
    except Exception as exc:
        raise MeshInputError(f"{path}: not a DICOM file ({exc})") from exc


def _spacing(ds, path: Path) -> tuple[float, float]:
    if "PixelSpacing" not in ds:
        raise MeshInputError(f"{path}: no PixelSpacing: the pixel size is unknown")
    row, col = (float(v) * 1e-3 for v in ds.PixelSpacing)  # mm -> m
    return row, col


def read_ct_slice(path: str | Path) -> CTImage:
    """One DICOM image in Hounsfield units, spacing in m (``PixelSpacing`` is in mm).

    Raises
    ------
    MeshInputError
        If the file is missing, not DICOM, has no pixel data or no ``PixelSpacing``.
    """
    path = Path(path)
    ds = _read(path)
    hu = _hounsfield(ds, path)
    if hu.ndim != 2:
        raise MeshInputError(f"{path}: expected one 2D image, got pixel data of shape {hu.shape}")
    origin = tuple(float(v) * 1e-3 for v in getattr(ds, "ImagePositionPatient", (0, 0, 0)))
    return CTImage(hu, _spacing(ds, path), origin, str(path))


def read_ct_series(folder: str | Path, pattern: str = "*") -> CTImage:
    """The DICOM images of a folder stacked in order of their position along the slice
    normal (``ImagePositionPatient`` · normal of ``ImageOrientationPatient``).

    Raises
    ------
    MeshInputError
        If the folder holds no DICOM image, or the images differ in size or spacing.
    """
    folder = Path(folder)
    files = sorted(p for p in folder.glob(pattern) if p.is_file())
    slices = []
    for f in files:
        try:
            ds = _read(f)
        except MeshInputError:
            continue  # not every file of a folder is an image
        if "PixelData" in ds:
            slices.append((f, ds))
    if not slices:
        raise MeshInputError(f"{folder}: no DICOM image found")
    cosines = np.asarray(getattr(slices[0][1], "ImageOrientationPatient", (1, 0, 0, 0, 1, 0)))
    normal = np.cross(cosines[:3].astype(float), cosines[3:].astype(float))
    pos = [
        np.asarray(getattr(ds, "ImagePositionPatient", (0, 0, k)), float)
        for k, (_, ds) in enumerate(slices)
    ]
    order = np.argsort([p @ normal for p in pos])
    images = [_hounsfield(slices[k][1], slices[k][0]) for k in order]
    spacings = {_spacing(slices[k][1], slices[k][0]) for k in order}
    if len({im.shape for im in images}) > 1 or len(spacings) > 1:
        raise MeshInputError(f"{folder}: the images differ in size or pixel spacing")
    z = np.array([pos[k] @ normal for k in order]) * 1e-3
    dz = float(np.median(np.diff(z))) if len(z) > 1 else 1e-3
    if len(z) > 1 and not np.allclose(np.diff(z), dz, rtol=1e-3):
        raise MeshInputError(f"{folder}: the slices are not equally spaced")
    row, col = spacings.pop()
    origin = tuple(float(v) * 1e-3 for v in pos[order[0]])
    return CTImage(np.stack(images), (dz, row, col), origin, str(folder))


# ------------------------------------------------------------------------ segmentation
def polygon_area(xy: np.ndarray) -> float:
    """Signed area of a closed polygon (shoelace; positive counter-clockwise)."""
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _inside(point: np.ndarray, polygon: np.ndarray) -> bool:
    """Even-odd test of a point against a closed polygon."""
    x, y = point
    xs, ys = polygon[:, 0], polygon[:, 1]
    xn, yn = np.roll(xs, -1), np.roll(ys, -1)
    crosses = (ys > y) != (yn > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = xs + (y - ys) * (xn - xs) / (yn - ys)
    return bool(np.count_nonzero(crosses & (x < xc)) % 2)


def bone_regions(
    image: CTImage, threshold: float = 300.0, min_area: float | None = None
) -> list[tuple[np.ndarray, list[np.ndarray]]]:
    """The regions of a slice above ``threshold`` HU as polygons in m.

    Parameters
    ----------
    image
        A 2D :class:`CTImage`.
    threshold
        Hounsfield units (300: bone; cancellous bone starts near 200, cortical bone is
        above 700).
    min_area
        Pieces and holes smaller than this (m²) are dropped (holes filled); default
        four pixels.

    Returns
    -------
    list of (outer, holes)
        Each region's outer boundary (counter-clockwise, (n, 2) in m) and its holes
        (clockwise).

    Raises
    ------
    MeshInputError
        If no region is left (naming the image's range of HU).
    """
    from skimage.measure import find_contours

    hu = image.hu
    dr, dc = image.spacing[-2:]
    if min_area is None:
        min_area = 4 * dr * dc
    padded = np.pad(hu, 1, constant_values=min(AIR, float(hu.min())))  # closes every contour
    loops = []
    for c in find_contours(padded, threshold):
        rc = c - 1.0
        xy = np.column_stack([image.origin[0] + rc[:, 1] * dc, -(image.origin[1] + rc[:, 0] * dr)])
        if np.allclose(xy[0], xy[-1]):
            xy = xy[:-1]
        if len(xy) >= 3 and abs(polygon_area(xy)) >= min_area:
            loops.append(xy)
    # nesting depth: even = outer boundary of bone, odd = hole
    depth = [sum(_inside(a[0], b) for b in loops if b is not a) for a in loops]
    regions = []
    for a, da in zip(loops, depth):
        if da % 2:
            continue
        outer = a if polygon_area(a) > 0 else a[::-1]
        holes = [
            b if polygon_area(b) < 0 else b[::-1]
            for b, db in zip(loops, depth)
            if db == da + 1 and _inside(b[0], a)
        ]
        regions.append((outer, holes))
    if not regions:
        raise MeshInputError(
            f"{image.source}: no region above {threshold:g} HU larger than {min_area:.3g} m² "
            f"(the image ranges from {hu.min():.0f} to {hu.max():.0f} HU)"
        )
    return regions


def _resample(xy: np.ndarray, h: float) -> np.ndarray:
    """A closed polygon resampled at equal arc-length steps of about ``h`` (at least 6)."""
    closed = np.vstack([xy, xy[:1]])
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    n = max(int(math.ceil(s[-1] / h)), 6)
    t = np.linspace(0.0, s[-1], n, endpoint=False)
    return np.column_stack([np.interp(t, s, closed[:, 0]), np.interp(t, s, closed[:, 1])])


#: the kinds of ``bodies`` of :func:`ct_slice_mesh`
BODIES = ("all", "largest", "each")
#: names of the low and high end along x and y (as :func:`~.builder.block_groups`)
END_NAMES = (("left", "right"), ("bottom", "top"))


def region_area(region: tuple[np.ndarray, list[np.ndarray]]) -> float:
    """Area of a region (outer boundary minus its holes), m²."""
    outer, holes = region
    return abs(polygon_area(outer)) - sum(abs(polygon_area(x)) for x in holes)


def select_bodies(regions: list, bodies: str) -> list:
    """The regions sorted by area (largest first): all of them, or only the largest.

    Raises
    ------
    ValueError
        For a ``bodies`` not in :data:`BODIES`.
    """
    if bodies not in BODIES:
        raise ValueError(f"bodies must be one of {', '.join(BODIES)}; got {bodies!r}")
    ranked = sorted(regions, key=region_area, reverse=True)
    return ranked[:1] if bodies == "largest" else ranked


def _segment_on_root(source, threshold, h, min_area, bodies, comm):
    """Rank 0: the image's regions (resampled at ``h``), all found and the kept ones;
    an error is raised on every rank."""
    out, error = None, None
    if comm.rank == 0:
        try:
            image = source if isinstance(source, CTImage) else read_ct_slice(source)
            h = 2 * max(image.spacing[-2:]) if h is None else h
            check_positive(h=h)
            found = bone_regions(image, threshold, min_area)
            kept = select_bodies(found, bodies)
            resampled = [(_resample(o, h), [_resample(x, h) for x in holes]) for o, holes in kept]
            out = (found, kept, resampled, h)
        except (MeshInputError, ValueError) as exc:
            error = exc
    error = comm.bcast(error, root=0)
    if error is not None:
        raise error
    return out if out is not None else (None, None, None, None)


def _end_of(midpoints: np.ndarray, lo: float, hi: float, fraction: float) -> np.ndarray:
    """0 for a midpoint within ``fraction`` of the extent of the low end, 1 of the high
    end, -1 elsewhere."""
    band = fraction * (hi - lo)
    return np.where(midpoints <= lo + band, 0, np.where(midpoints >= hi - band, 1, -1))


def _add_slice_geometry(regions, h, name, bodies, ends):
    """gmsh geometry and physical groups of the (resampled) regions."""
    geo = gmsh.model.geo
    curves: dict[str, list[int]] = {}
    surfaces = []
    if ends is not None:
        axis, fraction = ends
        coords = np.concatenate([o[:, axis] for o, _ in regions])
        lo, hi = float(coords.min()), float(coords.max())

    def loop(xy: np.ndarray, outer: bool) -> int:
        pts = [geo.addPoint(x, y, 0.0, h) for x, y in xy]
        lines = [geo.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
        kind = np.full(len(lines), -1)
        if outer and ends is not None:
            kind = _end_of(0.5 * (xy[:, axis] + np.roll(xy, -1, axis=0)[:, axis]), lo, hi, fraction)
        for line, k in zip(lines, kind):
            group = "inner" if not outer else ("outer" if k < 0 else END_NAMES[axis][k])
            curves.setdefault(f"{name}_{group}", []).append(line)
        return geo.addCurveLoop(lines)

    for outer, holes in regions:
        loops = [loop(outer, True)] + [loop(x, False) for x in holes]
        surfaces.append(geo.addPlaneSurface(loops))
    geo.synchronize()
    groups = PhysicalGroups()
    if bodies == "each":
        for k, surface in enumerate(surfaces, start=1):
            groups(2, [surface], f"{name}_{k}")
    else:
        groups(2, surfaces, name)
    for group, lines in curves.items():
        groups(1, lines, group)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)


def ct_slice_mesh(
    source: str | Path | CTImage,
    threshold: float = 300.0,
    h: float | None = None,
    *,
    name: str = "bone",
    min_area: float | None = None,
    bodies: str = "all",
    ends: tuple[int, float] | None = None,
    comm: MPI.Comm | None = None,
    path: str | Path | None = None,
) -> MeshData | Path:
    """Triangle mesh of the bone in a CT slice.

    Parameters
    ----------
    source
        A DICOM file or a 2D :class:`CTImage`.
    threshold
        Hounsfield units above which a pixel is bone.
    h
        Element size (m; default two pixels); the contours are resampled at this step.
    name
        Cell group; facet groups ``<name>_outer`` (outer boundaries) and ``<name>_inner``
        (holes; only if there are any).
    min_area
        Smaller pieces and holes are dropped (m²; default four pixels).
    bodies
        ``"all"``: every connected piece, one cell group ``<name>``; ``"largest"``: the
        piece of largest area alone (group ``<name>``); ``"each"``: every piece, largest
        first, as cell groups ``<name>_1``, ``<name>_2``, ….
    ends
        ``(axis, fraction)`` (axis 0: x, 1: y): the outer boundary's segments whose
        midpoint lies within ``fraction`` of the kept bodies' extent along the axis from
        its low or high end form the facet groups ``<name>_bottom``/``<name>_top`` (y) or
        ``<name>_left``/``<name>_right`` (x), for supports and loads; the rest of the outer
        boundary stays ``<name>_outer``.
    comm, path
        As for every builder: distribute to ``comm`` or write a gmsh file at ``path``.

    Raises
    ------
    MeshInputError
        On every rank, for an unreadable image or no bone above the threshold.
    ValueError
        On every rank, for a bad ``h``, ``bodies`` or ``ends``.
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    _check_ends(ends)
    _, _, regions, h = _segment_on_root(source, threshold, h, min_area, bodies, comm)

    def build() -> None:
        _add_slice_geometry(regions, h, name, bodies, ends)

    return generate(name, 2, build, comm, path)


def _check_ends(ends: tuple[int, float] | None) -> None:
    if ends is None:
        return
    axis, fraction = ends
    if axis not in (0, 1) or not (0 < fraction < 0.5):
        raise ValueError(f"ends must be (axis 0 or 1, fraction in (0, 0.5)); got {ends!r}")


def ct_bone_surface(image: CTImage, threshold: float = 300.0) -> Surface:
    """The bone surface of a CT volume (:func:`read_ct_series`) by marching cubes at
    ``threshold`` HU, in m, outward-oriented, the largest closed piece.

    Axes: x along the columns, y = minus the rows, z along the slices (the series' order).
    """
    from skimage.measure import marching_cubes

    hu = image.hu
    if hu.ndim != 3:
        raise MeshInputError(f"{image.source}: a volume (a series of slices) is needed")
    if hu.max() <= threshold:
        raise MeshInputError(
            f"{image.source}: no voxel above {threshold:g} HU "
            f"(the volume ranges from {hu.min():.0f} to {hu.max():.0f} HU)"
        )
    padded = np.pad(hu, 1, constant_values=min(AIR, float(hu.min())))
    with warnings.catch_warnings():  # scikit-image 0.26 sets an array's shape (NumPy 2.5)
        warnings.simplefilter("ignore", DeprecationWarning)
        verts, faces, _, _ = marching_cubes(padded, level=threshold, spacing=image.spacing)
    dz, dr, dc = image.spacing
    k, r, c = (verts - [dz, dr, dc]).T  # undo the padding
    ox, oy, oz = image.origin
    pts = np.column_stack([ox + c, -(oy + r), oz + k])
    s = split_components(Surface(pts, faces.astype(np.int64), image.source))[0]
    return s if s.volume > 0 else Surface(s.points, s.triangles[:, ::-1], image.source)


# ------------------------------------------------------------------------- command line
def _bodies_note(found: list, kept: list, bodies: str, threshold: float, name: str) -> str:
    areas = sorted((region_area(r) for r in found), reverse=True)
    shown = ", ".join(f"{a:.4g}" for a in areas[:5]) + (", …" if len(areas) > 5 else "")
    what = {
        "largest": f"kept the largest (group {name})",
        "each": f"kept every one (groups {name}_1, … largest first)",
        "all": f"kept every one (one group {name})",
    }[bodies]
    dropped = sum(areas) - sum(region_area(r) for r in kept)
    return f"{len(found)} connected bodies above {threshold:g} HU (areas {shown} m²); {what}" + (
        f"; dropped {len(found) - len(kept)} of {dropped:.4g} m²" if dropped > 0 else ""
    )


def mesh_ct(
    source: str | Path | CTImage,
    path: str | Path,
    threshold: float = 300.0,
    h: float | None = None,
    *,
    name: str = "bone",
    min_area: float | None = None,
    bodies: str = "largest",
    ends: tuple[int, float] | None = (1, 0.1),
    comm: MPI.Comm | None = None,
) -> MeshReport | None:
    """:func:`ct_slice_mesh` written to ``path`` (the largest body, bottom/top groups by
    default), with its report on rank 0 (``None`` elsewhere).

    The report's input area is that of the segmented polygons of the kept bodies (before
    resampling at ``h``); its notes say how many bodies were found and which were kept.
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    _check_ends(ends)
    found, kept, regions, h = _segment_on_root(source, threshold, h, min_area, bodies, comm)
    generate(name, 2, lambda: _add_slice_geometry(regions, h, name, bodies, ends), comm, path)
    if comm.rank != 0:
        return None
    notes = (_bodies_note(found, kept, bodies, threshold, name),)
    if ends is not None:
        low, high = END_NAMES[ends[0]]
        notes += (
            f"groups {name}_{low}/{name}_{high}: the outer boundary within {ends[1]:g} of the "
            f"extent along {'xy'[ends[0]]} from each end; {name}_outer the rest",
        )
    area = sum(region_area(r) for r in kept)
    return msh_report(path, input_measure=area, notes=notes)


def ct_parser(prog: str = "bonecontact mesh-ct"):
    """The arguments of ``bonecontact mesh-ct``."""
    import argparse

    p = argparse.ArgumentParser(
        prog=prog,
        description="Triangle mesh (gmsh .msh) of the bone in one CT slice (DICOM): "
        "threshold in HU, the largest connected body (or all, each its own cell group), "
        "facet groups at the two ends along an axis for supports and loads. Exit status 2 "
        "for a bad file or no bone above the threshold.",
    )
    p.add_argument("image", type=Path, help="DICOM file of one CT slice")
    p.add_argument("output", type=Path, help="gmsh file to write (.msh)")
    p.add_argument("--threshold", type=float, default=300.0, help="bone above this HU (300)")
    p.add_argument("--size", type=float, default=None, help="element size (m; two pixels)")
    p.add_argument("--name", default="bone", help="prefix of the group names")
    p.add_argument("--min-area", type=float, default=None, help="drop smaller pieces (m²)")
    p.add_argument(
        "--all-bodies",
        action="store_true",
        help="keep every body, each its own cell group <name>_1, <name>_2, … (largest first)",
    )
    p.add_argument(
        "--ends-axis",
        choices=("x", "y", "none"),
        default="y",
        help="axis of the end groups: y gives <name>_bottom/<name>_top, x <name>_left/"
        "<name>_right, none only <name>_outer (default y)",
    )
    p.add_argument(
        "--end-fraction",
        type=float,
        default=0.1,
        help="depth of each end group as a fraction of the extent along the axis (0.1)",
    )
    return p


def main(argv: list[str] | None = None) -> int:
    """``bonecontact mesh-ct``; prints the report on rank 0; exit status 2 for bad input,
    1 if gmsh failed."""
    args = ct_parser().parse_args(argv)
    comm = MPI.COMM_WORLD
    ends = None if args.ends_axis == "none" else ("xy".index(args.ends_axis), args.end_fraction)
    return run_report_command(
        lambda: mesh_ct(
            args.image,
            args.output,
            args.threshold,
            args.size,
            name=args.name,
            min_area=args.min_area,
            bodies="each" if args.all_bodies else "largest",
            ends=ends,
            comm=comm,
        ),
        comm,
    )
