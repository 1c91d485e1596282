"""Pictures of a field for a paper: :func:`field_view`.

A flat grid, or the cut face of a 3D grid seen along an axis (``view``), is drawn by
matplotlib on its undeformed coordinates (axes in mm, nice ticks), the field continuous
(the lumped L² projection of a cell field, per region when regions are given), the
deformed outline drawn with its scale factor.  Any other 3D view is rendered by pyvista
(parallel projection, no text) and framed by matplotlib: a scale bar of undeformed
length, the anatomical directions, the colour bar and the legend.  The colour range
comes from :func:`bonecontact.plot.scales.auto_range` (≤ 2 % of the area saturated, the
clip stated in the colour-bar label), and the figure's record (texts, legend, saturation)
is written beside the PNG (:mod:`bonecontact.plot.record`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from bonecontact.plot.frame import (
    Marker,
    colorbar,
    draw_directions,
    field_array,
    legend,
    points3,
    proxy,
    smooth_cell_data,
    wrap,
)
from bonecontact.plot.record import register_field, write_record
from bonecontact.plot.render3d import render_picture
from bonecontact.plot.scales import ColorRange, auto_range, nice_factor

#: Display units: (name, factor applied to SI values).
LENGTH_UNITS = {"m": 1.0, "mm": 1e3, "µm": 1e6}
STRESS_UNITS = {"Pa": 1.0, "kPa": 1e-3, "MPa": 1e-6, "GPa": 1e-9}
#: Factor from SI to each display unit of a field (stresses from Pa, lengths from m).
UNIT_FACTORS = {**STRESS_UNITS, **LENGTH_UNITS}
#: Plane of a ``view`` → (horizontal, vertical, depth) coordinate indices.
PLANES = {"xy": (0, 1, 2), "xz": (0, 2, 1), "yz": (1, 2, 0)}
#: VTK cell types drawn as triangles (linear and Lagrange) and as quadrilaterals.
TRIANGLES, QUADS = (5, 69), (9, 70)


def _triangles(grid: Any) -> tuple[np.ndarray, np.ndarray]:
    """The cells of ``grid`` as triangles (quadrilaterals split) and the cell of each."""
    tris, owner, start = [], [], 0
    for ctype, cells in grid.cells_dict.items():
        n = len(cells)
        ids = np.arange(start, start + n)
        if int(ctype) in TRIANGLES:
            tris.append(cells[:, :3])
            owner.append(ids)
        elif int(ctype) in QUADS:
            tris += [cells[:, [0, 1, 2]], cells[:, [0, 2, 3]]]
            owner += [ids, ids]
        start += n
    if not tris:
        raise ValueError("field_view: a plane picture needs triangle or quadrilateral cells")
    return np.vstack(tris), np.concatenate(owner)


def _areas(xy: np.ndarray, tris: np.ndarray) -> np.ndarray:
    a, b, c = xy[tris[:, 0]], xy[tris[:, 1]], xy[tris[:, 2]]
    return 0.5 * np.abs(
        (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    )


def lumped_projection(
    tris: np.ndarray, cell_values: np.ndarray, areas: np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """The lumped L² projection of a piecewise-constant field on triangles onto P1: at each
    vertex the area-weighted mean of its triangles' values; and each vertex's lumped area."""
    num, den = np.zeros(n), np.zeros(n)
    for k in range(3):
        np.add.at(num, tris[:, k], areas * cell_values)
        np.add.at(den, tris[:, k], areas)
    return num / np.where(den > 0, den, 1.0), den / 3.0


def split_regions(tris: np.ndarray, regions: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Triangles renumbered so that no vertex is shared between regions (a field projected
    on the result is continuous inside each region, discontinuous across), and the
    original vertex of each new vertex."""
    if regions is None:
        return tris, np.arange(tris.max() + 1)
    out, origin = np.empty_like(tris), []
    offset = 0
    for r in np.unique(regions):
        sel = regions == r
        used, local = np.unique(tris[sel], return_inverse=True)
        out[sel] = local.reshape(-1, 3) + offset
        origin.append(used)
        offset += len(used)
    return out, np.concatenate(origin)


def _is_surface(grid: Any) -> bool:
    """Whether ``grid`` has only triangles and quadrilaterals (a surface in 3D: a plane
    picture projects it on the plane of the view)."""
    return all(int(t) in TRIANGLES + QUADS for t in grid.cells_dict)


def _cut_face(grid: Any, view: str) -> Any:
    """The surface cells of a 3D ``grid`` in the plane of ``view`` at its largest depth
    coordinate (the face a clip leaves, seen from outside), with the point and cell data."""
    surf = grid.extract_surface(algorithm=None).triangulate()
    depth = PLANES[view][2]
    z = np.asarray(surf.points)[:, depth]
    tol = 1e-6 * max(np.ptp(np.asarray(surf.points), axis=0).max(), 1e-300)
    tri = surf.faces.reshape(-1, 4)[:, 1:]
    keep = np.all(z[tri] >= z.max() - tol, axis=1)
    if not keep.any():
        raise ValueError(f"field_view: no face of the grid lies in the {view} plane")
    return surf.extract_cells(np.flatnonzero(keep))


def _markers(
    contact: tuple[npt.ArrayLike | None, str],
    outline: tuple[npt.ArrayLike | None, str],
    markers: Sequence[Marker],
) -> list[Marker]:
    """The markers of :func:`field_view`: the contact points, the outline, the others."""
    out = []
    if contact[0] is not None and len(np.asarray(contact[0])):
        out.append(Marker(contact[0], contact[1]))
    if outline[0] is not None and len(np.asarray(outline[0])):
        out.append(Marker(outline[0], outline[1] or "outline", "cyan", "-"))
    return out + [m for m in markers if len(np.asarray(m.points))]


def field_view(
    grid: Any,
    name: str,
    path: str | Path,
    *,
    quantity: str,
    unit: str = "MPa",
    length_unit: str = "mm",
    clim: tuple[float | None, float | None] | None = None,
    saturated: float = 0.01,
    log: bool = False,
    smooth: bool = True,
    regions: npt.ArrayLike | None = None,
    displacement: str | None = None,
    warp: float = 0.0,
    contact_points: npt.ArrayLike | None = None,
    contact_label: str = "in contact",
    outline: npt.ArrayLike | None = None,
    outline_label: str = "",
    markers: Sequence[Marker] = (),
    title: str = "",
    cmap: str = "viridis",
    window_size: tuple[int, int] = (1200, 900),
    zoom: float = 1.0,
    up: str = "y",
    view: str | None = None,
    axis_titles: Mapping[str, str] | None = None,
    directions: Mapping[str, npt.ArrayLike] | None = None,
    upper_percentile: float | None = None,
) -> Path:
    """A picture of a field, fit for a paper, written to ``path`` (PNG) with its record.

    Parameters
    ----------
    grid
        A pyvista grid (:func:`bonecontact.plot.read_fields`), coordinates in metres.
    name
        The field (cell or point data; a vector field is shown by its magnitude).
    path
        The PNG to write (``window_size`` pixels); the record goes to ``.json`` beside it.
    quantity, unit
        Colour-bar label ``"<quantity> (<unit>)"`` (mathtext allowed, e.g.
        ``r"$\\sigma_1/\\sigma_t$"``; ``unit = ""``: dimensionless); a ``unit`` of
        :data:`UNIT_FACTORS` converts the SI field (Pa, m).
    length_unit
        Unit of the axes and the scale bar (``"mm"``, ``"m"``, ``"µm"``).
    clim
        A fixed bottom and/or top of the colour range (in ``unit``; ``None`` entries chosen).
    saturated, log
        Share of the area the chosen range may leave outside (the clip is stated); a
        logarithmic colour scale (:func:`bonecontact.plot.scales.auto_range`).
    smooth, regions
        Project a cell field to the vertices (continuous), within each region of the cell
        labels ``regions`` (one per cell of ``grid``) if given.
    displacement, warp
        Point vector field and its magnification: in a plane picture the deformed outline
        is drawn over the undeformed field; a 3D picture shows the deformed shape.  The
        factor is rounded down to 1, 2 or 5 × 10^k and stated once.
    contact_points, contact_label, outline, outline_label, markers, title, cmap
        Points (m) to mark, a closed polyline, further :class:`Marker` s (each with a
        legend entry); the title (wrapped to fit) and the colour map.
    window_size, zoom, up
        Picture size in pixels; camera zoom of a 3D picture; the up axis.
    view
        The up axis; ``view`` ``"xy"``, ``"xz"``, ``"yz"``: the plane seen face-on (a
        3D grid shows its face at the largest third coordinate, e.g. the face a clip
        leaves; a surface is projected on the plane), ``None``: the plane of a flat
        grid, else an isometric 3D picture.
    axis_titles
        Axis titles instead of the coordinate names, e.g. ``{"x": "x, back to front"}``.
    directions
        Anatomical directions to draw as arrows, e.g. ``{"superior": (0, 1, 0)}``.

    Returns ``path`` (``upper_percentile`` is deprecated and ignored).
    """
    del upper_percentile
    if view not in (None, "xy", "xz", "yz"):
        raise ValueError(f"field_view: view must be None, 'xy', 'xz' or 'yz', not {view!r}")
    if length_unit not in LENGTH_UNITS:
        raise ValueError(f"field_view: length_unit must be one of {sorted(LENGTH_UNITS)}")
    style = Style(quantity, unit, length_unit, cmap, title, saturated, clim, log)
    marks = _markers((contact_points, contact_label), (outline, outline_label), markers)
    factor = nice_factor(warp) if displacement is not None and warp > 0 else 0.0
    deform = (displacement, factor) if factor else None
    flat = np.ptp(np.asarray(grid.points)[:, 2]) <= 1e-12 * max(
        np.ptp(grid.points, axis=0).max(), 1.0
    )
    fig = _figure(window_size)
    if flat or view is not None:
        source = _with_regions(grid, regions)
        face = source if flat or _is_surface(source) else _cut_face(source, view)
        reg = face.cell_data[REGION_KEY] if regions is not None else None
        plane = _plane_axes(view or "xy", up)
        _plane_picture(fig, face, name, plane, style, (smooth, reg), deform, marks,
                       axis_titles or {}, directions or {})  # fmt: skip
    else:
        render_picture(fig, _with_nodal(grid, name, smooth), name, style, deform, marks,
                       (up, zoom), directions or {})  # fmt: skip
    return _save(fig, path)


@dataclass(frozen=True)
class Style:
    """What :func:`field_view` was asked for, passed to the two kinds of picture."""

    quantity: str
    unit: str
    length_unit: str
    cmap: str
    title: str
    saturated: float
    clim: tuple[float | None, float | None] | None
    log: bool = False

    @property
    def label(self) -> str:
        return f"{self.quantity} ({self.unit})" if self.unit else self.quantity

    @property
    def factor(self) -> float:
        return UNIT_FACTORS.get(self.unit, 1.0)

    @property
    def scale(self) -> float:
        return LENGTH_UNITS[self.length_unit]

    def color_range(self, values: np.ndarray, weights: np.ndarray) -> ColorRange:
        return auto_range(values, weights, saturated=self.saturated, clim=self.clim, log=self.log)


def _figure(window_size: tuple[int, int]) -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    w, h = window_size
    return plt.figure(figsize=(w / 100, h / 100), dpi=100, layout="constrained")


def _save(fig: Any, path: str | Path) -> Path:
    """Write ``fig`` to ``path`` at its own size, its record beside it, and close it."""
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    write_record(fig, path)
    plt.close(fig)
    return path


def _with_nodal(grid: Any, name: str, smooth: bool) -> Any:
    """``grid`` with a cell field ``name`` also as point data (lumped projection) when
    ``smooth`` (3D grids; a plane picture projects on its own triangles)."""
    if not smooth or name not in grid.cell_data:
        return grid
    g = grid.copy()
    values = smooth_cell_data(g, name)
    del g.cell_data[name]
    g.point_data[name] = values
    return g


#: Cell data of the region labels on a picture's copy of the grid.
REGION_KEY = "bonecontact_region"


def _with_regions(grid: Any, regions: npt.ArrayLike | None) -> Any:
    """``grid``, or a copy with the cell labels ``regions`` as cell data :data:`REGION_KEY`."""
    if regions is None:
        return grid
    labels = np.asarray(regions)
    if labels.shape != (grid.n_cells,):
        raise ValueError(
            f"field_view: regions needs one label per cell ({grid.n_cells}), not {labels.shape}"
        )
    g = grid.copy()
    g.cell_data[REGION_KEY] = labels
    return g


def _plane_axes(view: str, up: str) -> tuple[int, int]:
    """(horizontal, vertical) coordinate indices of a plane, ``up`` vertical if in it."""
    h, v, _ = PLANES[view]
    u = "xyz".index(up)
    return (v, h) if u == h else (h, v)


def _plane_data(
    face: Any, name: str, plane: tuple[int, int], smooth: tuple[bool, Any], factor: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
    """Points (2D, m), triangles, values (per vertex or per triangle) in display units,
    their areas, and whether they are per vertex, of a plane picture."""
    xy = np.asarray(face.points)[:, list(plane)]
    tris, owner = _triangles(face)
    values, on_cells = field_array(face, name)
    areas = _areas(xy, tris)
    do_smooth, regions = smooth
    if on_cells and not do_smooth:
        return xy, tris, values[owner] * factor, areas, False
    if on_cells:
        reg = None if regions is None else np.asarray(regions)[owner]
        tris, origin = split_regions(tris, reg)
        vals, w = lumped_projection(tris, values[owner], areas, len(origin))
        return xy[origin], tris, vals * factor, w, True
    _, w = lumped_projection(tris, np.zeros(len(tris)), areas, len(xy))
    return xy, tris, values * factor, w, True


def _plane_picture(
    fig: Any,
    face: Any,
    name: str,
    plane: tuple[int, int],
    style: Style,
    smooth: tuple[bool, Any],
    deform: tuple[str, float] | None,
    marks: list[Marker],
    titles: Mapping[str, str],
    directions: Mapping[str, npt.ArrayLike],
) -> None:
    """A plane picture on ``fig``: the field on its undeformed coordinates."""
    ax = fig.add_subplot()
    xy, tris, values, weights, nodal = _plane_data(face, name, plane, smooth, style.factor)
    cr = style.color_range(values, weights)
    s = style.scale
    kw = {"cmap": style.cmap, "norm": cr.norm(), "rasterized": True}
    if nodal:
        art = ax.tripcolor(xy[:, 0] * s, xy[:, 1] * s, tris, values, shading="gouraud", **kw)
    else:
        art = ax.tripcolor(xy[:, 0] * s, xy[:, 1] * s, tris, facecolors=values, **kw)
    art.bonecontact_registered = True
    register_field(
        fig, style.label, values, weights, cr.vmin, cr.vmax, cr.clipped or cr.clipped_below
    )
    handles = _deformed_outline(ax, face, plane, deform, s) if deform else []
    handles += _plane_markers(ax, marks, plane, s)
    ax.set_aspect("equal")
    ax.set_xlabel(f"{titles.get('xyz'[plane[0]], 'xyz'[plane[0]])} ({style.length_unit})")
    ax.set_ylabel(f"{titles.get('xyz'[plane[1]], 'xyz'[plane[1]])} ({style.length_unit})")
    colorbar(fig, ax, style.cmap, cr, style.label)
    _plane_directions(ax, directions, plane)
    legend(fig, handles)
    if style.title:
        fig.suptitle(wrap(style.title, fig.bbox.width * 0.9, 10.0), fontsize=13)


def _boundary_edges(tris: np.ndarray) -> np.ndarray:
    """The edges of a triangulation that belong to one triangle only."""
    e = np.sort(np.vstack([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(e, axis=0, return_counts=True)
    return uniq[count == 1]


def _deformed_outline(
    ax: Any, face: Any, plane: tuple[int, int], deform: tuple[str, float], s: float
) -> list[Any]:
    """The boundary of the deformed shape (displacement × factor) over the undeformed
    picture, and its legend handle."""
    from matplotlib.collections import LineCollection

    name, factor = deform
    u = np.asarray(face.point_data[name], dtype=np.float64)
    u = np.pad(u, ((0, 0), (0, 3 - u.shape[1])))
    moved = (np.asarray(face.points) + factor * u)[:, list(plane)] * s
    tris, _ = _triangles(face)
    edges = _boundary_edges(tris)
    lc = LineCollection(moved[edges], colors="0.15", linewidths=0.8, linestyles="--")
    lc.set_label(f"deformed outline, displacement × {factor:g}")
    ax.add_collection(lc)
    from matplotlib.lines import Line2D

    return [Line2D([], [], color="0.15", ls="--", lw=0.8, label=lc.get_label())]


def _plane_markers(ax: Any, marks: list[Marker], plane: tuple[int, int], s: float) -> list[Any]:
    """The markers drawn on a plane picture, and their legend handles."""
    handles = []
    for m in marks:
        p = points3(m.points)[:, list(plane)] * s
        if m.marker == "-":
            p = np.vstack([p, p[:1]])
            ax.plot(p[:, 0], p[:, 1], "-", color=m.color, lw=2)
        else:
            line_like = m.marker in ("+", "x", "|", "_", "1", "2", "3", "4")  # no face
            edge = {"mew": 2.0} if line_like else {"mec": "k", "mew": 0.5}
            ax.plot(p[:, 0], p[:, 1], m.marker, color=m.color, ms=m.size, **edge)
        handles.append(proxy(m))
    return handles


def _plane_directions(
    ax: Any, directions: Mapping[str, npt.ArrayLike], plane: tuple[int, int]
) -> None:
    """Arrows of the anatomical directions in the lower left corner of a plane picture."""
    vectors = {k: np.asarray(v, dtype=float)[list(plane)] for k, v in directions.items()}
    draw_directions(ax, vectors)
