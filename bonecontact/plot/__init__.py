"""Pictures of results for notebooks, scripts and papers (pyvista and matplotlib).

* :func:`read_fields` — the last (or a chosen) time of a run's ``fields.pvd``;
* :func:`field_view` — a pyvista picture of a cell or point field: y up, lengths in mm with
  axes, the deformed shape with its scale factor stated, a colour bar titled with the
  quantity and its unit, a colour range from percentiles with the clipped maximum stated,
  stress smoothed to a continuous field, contact nodes marked with a legend;
* :func:`smooth_cell_data` — a cell (DG0) field projected to the vertices (lumped L² projection,
  for display only: the computed field is cell-wise);
* :func:`color_range` — a colour range from percentiles and what it clips;
* :func:`line_axes` and :func:`caption` — matplotlib axes labelled with units, a caption
  below the figure;
* :func:`show` — saves a figure (matplotlib figure or a PNG written by :func:`field_view`)
  and, in Jupyter, shows it inline; :func:`output_dir` — where a demo writes its results.

Everything runs without an X server: pyvista renders off-screen (EGL when ``DISPLAY`` is
unset).  Units SI in, display units (mm, MPa) out, always stated on the picture.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

if not os.environ.get("DISPLAY"):  # off-screen rendering without an X server
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

__all__ = [
    "ColorRange",
    "caption",
    "color_range",
    "field_view",
    "in_notebook",
    "line_axes",
    "output_dir",
    "quick_mode",
    "read_fields",
    "show",
    "smooth_cell_data",
]

#: Display units: (name, factor applied to SI values).
LENGTH_UNITS = {"m": 1.0, "mm": 1e3, "µm": 1e6}
STRESS_UNITS = {"Pa": 1.0, "kPa": 1e-3, "MPa": 1e-6, "GPa": 1e-9}
#: Factor from SI to each display unit of a field (stresses from Pa, lengths from m).
UNIT_FACTORS = {**STRESS_UNITS, **LENGTH_UNITS}


# ----------------------------------------------------------------------------- environment
def in_notebook() -> bool:
    """Whether the code runs in a Jupyter kernel (a figure can be shown inline)."""
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython comes with the test extras
        return False
    shell = get_ipython()
    return shell is not None and shell.__class__.__name__ == "ZMQInteractiveShell"


def output_dir(name: str, demo_dir: str | Path, argv: Sequence[str] = ()) -> Path:
    """Where a demo writes: the first non-option argument, else ``$BONECONTACT_OUTPUT/<name>``,
    else ``<demo_dir>/results/<name>`` — never relative to the working directory."""
    args = [a for a in argv if not a.startswith("-")]
    if args:
        return Path(args[0]).resolve()
    env = os.environ.get("BONECONTACT_OUTPUT")
    base = Path(env) if env else Path(demo_dir) / "results"
    return (base / name).resolve()


def quick_mode() -> bool:
    """Whether a demo should run at its reduced size: ``$BONECONTACT_DEMO_QUICK`` set and not
    ``0`` (the test suite sets it)."""
    return os.environ.get("BONECONTACT_DEMO_QUICK", "0") not in ("", "0")


def show(figure: Any, path: str | Path, dpi: int = 150) -> Path:
    """Save a figure to ``path`` and show it inline when running in Jupyter.

    Parameters
    ----------
    figure
        A matplotlib figure (saved, then closed), or the path of a PNG already written
        (a :func:`field_view` picture).
    path
        The PNG to write.
    dpi
        Resolution of a matplotlib figure.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(figure, (str, Path)):
        if Path(figure).resolve() != path.resolve():
            path.write_bytes(Path(figure).read_bytes())
    else:
        import matplotlib.pyplot as plt

        figure.savefig(path, dpi=dpi, bbox_inches="tight")
        plt.close(figure)
    if in_notebook():
        from IPython.display import Image, display

        display(Image(filename=str(path)))
    return path


# ----------------------------------------------------------------------------- numbers
@dataclass(frozen=True)
class ColorRange:
    """A colour range and what it leaves out.

    Parameters
    ----------
    vmin, vmax
        The range.
    data_max
        The largest value of the data (``> vmax`` when clipped).
    clipped_fraction
        Fraction of the values above ``vmax``.
    """

    vmin: float
    vmax: float
    data_max: float
    clipped_fraction: float

    @property
    def clipped(self) -> bool:
        """Whether some values lie above the range."""
        return self.data_max > self.vmax

    def note(self, unit: str, fmt: str = ".3g") -> str:
        """``"colour scale clipped at 12 MPa (max 53 MPa, 0.5 % of cells above)"`` or ``""``."""
        if not self.clipped:
            return ""
        u = f" {unit}" if unit else ""  # "": a dimensionless quantity
        return (
            f"colour scale clipped at {self.vmax:{fmt}}{u} (max {self.data_max:{fmt}}{u}, "
            f"{100 * self.clipped_fraction:.2g} % of the area above)"
        )


def color_range(
    values: npt.ArrayLike,
    upper: float = 99.0,
    lower: float | None = 0.0,
    weights: npt.ArrayLike | None = None,
) -> ColorRange:
    """A colour range from percentiles of ``values``.

    Parameters
    ----------
    values
        The data (cells or points).
    upper
        Percentile of the top of the range.
    lower
        Percentile of the bottom; ``None``: 0 (a non-negative quantity such as von Mises).
    weights
        Optional weights (cell areas: the percentile of the *area*, so that many small
        cells of a thin layer do not take the whole range).

    Returns
    -------
    ColorRange
    """
    v = np.asarray(values, dtype=np.float64).ravel()
    w = np.ones_like(v) if weights is None else np.asarray(weights, dtype=np.float64).ravel()
    order = np.argsort(v)
    cdf = np.cumsum(w[order]) / w.sum()

    def pct(q: float) -> float:
        return float(v[order][min(np.searchsorted(cdf, q / 100.0), len(v) - 1)])

    vmax = pct(upper)
    vmin = 0.0 if lower is None else pct(lower)
    above = float(w[v > vmax].sum() / w.sum())
    return ColorRange(vmin, vmax, float(v.max()), above)


def _cell_measures(grid: Any) -> npt.NDArray[np.float64]:
    sizes = grid.compute_cell_sizes(length=False, area=True, volume=True)
    area, vol = np.abs(sizes.cell_data["Area"]), np.abs(sizes.cell_data["Volume"])
    return vol if vol.max() > 0 else area


def smooth_cell_data(grid: Any, name: str) -> npt.NDArray[np.float64]:
    """A cell field projected to the vertices: the lumped-mass L² projection of a piecewise
    constant field onto continuous piecewise-linear functions.

    At each vertex, the average of the values of the cells around it weighted by their
    areas (volumes in 3D) — for linear simplices ∫φ_i over a cell is its measure/(d+1),
    so this is exactly the lumped projection.  For display: the computed stress is
    cell-wise and the projection smooths its jumps (between materials too).

    Parameters
    ----------
    grid
        A pyvista unstructured grid with cell data ``name`` (scalar or vector per cell).
    name
        The cell field.

    Returns
    -------
    ndarray
        One value (or vector) per point.
    """
    values = np.asarray(grid.cell_data[name], dtype=np.float64)
    measure = _cell_measures(grid)
    conn = grid.cells_dict
    num = np.zeros((grid.n_points,) + values.shape[1:])
    den = np.zeros(grid.n_points)
    start = 0
    for _, cells in conn.items():
        n = len(cells)
        idx = slice(start, start + n)
        w = measure[idx]
        for k in range(cells.shape[1]):
            np.add.at(den, cells[:, k], w)
            np.add.at(num, cells[:, k], (w * values[idx].T).T)
        start += n
    den[den == 0] = 1.0
    return (num.T / den).T


# ----------------------------------------------------------------------------- pyvista
def _pyvista() -> Any:
    """pyvista, imported without the ipywidgets warning its import chain (pooch → tqdm.auto)
    prints in a Jupyter kernel that has no ipywidgets."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="IProgress not found")
        import pyvista

    return pyvista


def read_fields(path: str | Path, time_index: int = -1) -> Any:
    """The grid of one saved time of a run's ``fields.pvd`` (default: the last)."""
    pv = _pyvista()

    reader = pv.get_reader(str(path))
    n = len(reader.time_values)
    reader.set_active_time_point(time_index % n if n else 0)
    return reader.read().combine()


def _scalar_bar_args(title: str) -> dict[str, Any]:
    return {
        "title": title,
        "vertical": True,
        "position_x": 0.83,
        "position_y": 0.2,
        "height": 0.6,
        "width": 0.06,
        "title_font_size": 18,
        "label_font_size": 16,
        "n_labels": 5,
        "fmt": "%.3g",
        "color": "black",
    }


def field_view(
    grid: Any,
    name: str,
    path: str | Path,
    *,
    quantity: str,
    unit: str = "MPa",
    length_unit: str = "mm",
    upper_percentile: float = 99.0,
    clim: tuple[float, float] | None = None,
    smooth: bool = True,
    displacement: str | None = None,
    warp: float = 0.0,
    contact_points: npt.ArrayLike | None = None,
    contact_label: str = "in contact",
    outline: npt.ArrayLike | None = None,
    outline_label: str = "",
    title: str = "",
    cmap: str = "viridis",
    window_size: tuple[int, int] = (1200, 900),
    zoom: float = 1.0,
    up: str = "y",
    view: str | None = None,
    axis_titles: Mapping[str, str] | None = None,
) -> Path:
    """A pyvista picture of a field, fit for a paper, written to ``path`` (PNG).

    Parameters
    ----------
    grid
        A pyvista grid (:func:`read_fields`), coordinates in metres.
    name
        The field (cell or point data; a vector field is shown by its magnitude).
    path
        The PNG to write.
    quantity, unit
        Colour-bar title ``"<quantity> (<unit>)"`` (``unit = ""``: a dimensionless
        quantity, the title alone); a ``unit`` of :data:`UNIT_FACTORS` converts the SI
        field (Pa, m), any other shows the field as it is.
    length_unit
        Unit of the axes (``"mm"``, ``"m"``, ``"µm"``).
    upper_percentile
        Top of the colour range, as a percentile of the cell areas (:func:`color_range`);
        when it clips, the clipped maximum is stated under the picture.
    clim
        An explicit colour range (in ``unit``) instead.
    smooth
        Project a cell field to the vertices for display (:func:`smooth_cell_data`).
    displacement, warp
        Point vector field and the factor of the deformed shape; the factor is stated.
    contact_points, contact_label
        Points (m) to mark (e.g. the slave nodes in contact) and their legend label.
    outline, outline_label
        Points (m) of a polyline to draw (e.g. a tumour boundary), with its legend label.
    title, cmap
        Text at the top, and the colour map.
    window_size, zoom
        Picture size in pixels and camera zoom.
    up
        The up axis of the view (``"y"``: the convention of the meshes).
    view
        ``None``: isometric (3D) or the plane of a flat grid; ``"xy"``, ``"xz"`` or
        ``"yz"``: looking at that plane along the third axis (a cut face of a 3D grid),
        unlit (the colours are the colour bar's), in parallel projection and without the
        third axis.
    axis_titles
        Axis titles instead of the coordinate names, the unit appended, e.g.
        ``{"x": "x, back to front"}`` gives ``"x, back to front (mm)"``.

    Returns
    -------
    Path
        ``path``.
    """
    if view not in (None, "xy", "xz", "yz"):
        raise ValueError(f"field_view: view must be None, 'xy', 'xz' or 'yz', not {view!r}")
    scale = LENGTH_UNITS[length_unit]
    factor = UNIT_FACTORS.get(unit, 1.0)
    moved = (grid, displacement, warp) if displacement is not None and warp else None
    g = _display_grid(grid, name, smooth, moved, scale, factor)
    cr = _clipped_range(grid, name, factor, upper_percentile, clim)
    pl = _pyvista().Plotter(off_screen=True, window_size=list(window_size))
    label = f"{quantity} ({unit})" if unit else quantity
    _add_field(pl, g, cmap, cr, label, lit=view is None)  # a plane seen face-on: unlit
    _add_markers(pl, moved, scale, (contact_points, contact_label), (outline, outline_label))
    _axes(pl, g, length_unit, up, view, axis_titles or {})
    foot = [f"deformed shape, displacement × {warp:g}"] if moved is not None else []
    _add_notes(pl, title, foot + ([cr.note(unit)] if cr.clipped else []))
    pl.camera.zoom(zoom)
    return _screenshot(pl, path)


#: Name of the display copy of the field on the grid of :func:`field_view`.
_DISPLAY_KEY = "_display"


def _display_grid(
    grid: Any, name: str, smooth: bool, moved: tuple | None, scale: float, factor: float
) -> Any:
    """A copy of ``grid`` for display: deformed (``moved``), in display lengths (``scale``),
    with the field in display units (``factor``) as :data:`_DISPLAY_KEY`."""
    g = grid.copy()
    values = _field_values(g, name, smooth)
    if moved is not None:
        _, displacement, warp = moved
        u = np.asarray(grid.point_data[displacement])
        g.points = g.points + warp * np.pad(u, ((0, 0), (0, 3 - u.shape[1])))
    g.points = g.points * scale
    if len(values) == g.n_points:
        g.point_data[_DISPLAY_KEY] = values * factor
    else:
        g.cell_data[_DISPLAY_KEY] = values * factor
    return g


def _add_field(pl: Any, g: Any, cmap: str, cr: ColorRange, label: str, lit: bool) -> None:
    """The display field of ``g`` on a white background, with its colour bar titled
    ``label`` (``lit = False``: unlit, so that its colours are the colour bar's)."""
    pl.set_background("white")
    pl.add_mesh(
        g,
        scalars=_DISPLAY_KEY,
        cmap=cmap,
        clim=(cr.vmin, cr.vmax),
        scalar_bar_args=_scalar_bar_args(label),
        lighting=lit,
    )


def _clipped_range(
    grid: Any,
    name: str,
    factor: float,
    upper_percentile: float,
    clim: tuple[float, float] | None,
) -> ColorRange:
    """The colour range of :func:`field_view` (``clim``, else the area percentile of the
    unsmoothed field) and the share of the area above it."""
    cell_vals = _field_values(grid, name, False) * factor
    is_cell = len(cell_vals) == grid.n_cells
    measure = _cell_measures(grid) if is_cell else np.ones(len(cell_vals))  # points: by count
    cr = color_range(cell_vals, upper_percentile, None, measure)
    if clim is None:
        clim = (cr.vmin, cr.vmax)
    above = float(measure[cell_vals > clim[1]].sum() / measure.sum())
    return ColorRange(clim[0], clim[1], float(cell_vals.max()), above)


def _add_markers(
    pl: Any,
    moved: tuple | None,
    scale: float,
    contact: tuple[npt.ArrayLike | None, str],
    outline: tuple[npt.ArrayLike | None, str],
) -> None:
    """The contact points and the outline polyline of :func:`field_view`, with a legend."""
    legend = []
    points, label = contact
    if points is not None and len(np.asarray(points)):
        pts = _moved(_points3(points), moved) * scale
        pl.add_points(pts, color="deepskyblue", point_size=10, render_points_as_spheres=True)
        legend.append([label, "deepskyblue"])
    points, label = outline
    if points is not None and len(np.asarray(points)):
        pts = _moved(_points3(points), moved) * scale
        pl.add_lines(np.vstack([pts, pts[:1]]), color="cyan", width=3, connected=True)
        legend.append([label or "outline", "cyan"])
    if legend:
        pl.add_legend(
            legend, bcolor="white", border=True, loc="upper left", size=(0.28, 0.04 * len(legend))
        )


def _add_notes(pl: Any, title: str, foot: list[str]) -> None:
    """The title at the top and the notes (deformation scale, clipping) at the bottom."""
    if title:
        pl.add_text(title, position="upper_edge", font_size=12, color="black")
    if foot:
        pl.add_text("\n".join(foot), position="lower_left", font_size=10, color="black")


def _screenshot(pl: Any, path: str | Path) -> Path:
    """Write the picture to ``path`` (PNG, its folder made) and close the plotter."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    pl.screenshot(str(path))
    pl.close()
    return path


def _field_values(grid: Any, name: str, smooth: bool) -> npt.NDArray[np.float64]:
    """The field as one number per cell or point (magnitude of a vector)."""
    if name in grid.cell_data:
        v = smooth_cell_data(grid, name) if smooth else np.asarray(grid.cell_data[name])
    else:
        v = np.asarray(grid.point_data[name])
    v = np.asarray(v, dtype=np.float64)
    return np.linalg.norm(v, axis=1) if v.ndim == 2 else v


def _moved(points: npt.NDArray[np.float64], moved: tuple | None) -> npt.NDArray[np.float64]:
    """Points moved with the deformed shape (displacement of the nearest grid point)."""
    if moved is None:
        return points
    grid, name, warp = moved
    u = np.asarray(grid.point_data[name])
    u = np.pad(u, ((0, 0), (0, 3 - u.shape[1])))
    nearest = [grid.find_closest_point(p) for p in points]
    return points + warp * u[nearest]


def _points3(points: npt.ArrayLike) -> npt.NDArray[np.float64]:
    p = np.atleast_2d(np.asarray(points, dtype=np.float64))
    return np.pad(p, ((0, 0), (0, 3 - p.shape[1])))


def _axes(
    pl: Any,
    g: Any,
    length_unit: str,
    up: str,
    view: str | None = None,
    titles: Mapping[str, str] | None = None,
) -> None:
    """Bounds with labelled axes in ``length_unit`` (``titles``: other names than x, y, z)
    and a camera with ``up`` upwards, looking along the normal of ``view`` (a plane
    ``"xy"``, ``"xz"``, ``"yz"``; parallel projection) if given."""
    titles = titles or {}
    b = g.bounds
    flat = abs(b[5] - b[4]) < 1e-12 * max(abs(b[1] - b[0]), abs(b[3] - b[2]), 1.0)
    # the axis along the line of sight would be drawn end-on (its ticks in a corner)
    hidden = {"xy": "z", "xz": "y", "yz": "x"}[view] if view else ("z" if flat else "")
    shown = {f"show_{a}{part}": a != hidden for a in "xyz" for part in ("axis", "labels")}
    pl.show_bounds(
        **{f"{a}title": f"{titles.get(a, a)} ({length_unit})" for a in "xyz"},
        color="black",
        font_size=12,
        location="outer",
        grid=False,
        ticks="outside",
        **shown,
    )
    view_up = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}[up]
    if view is not None:
        getattr(pl, f"view_{view}")()
        pl.camera.up = view_up
        pl.enable_parallel_projection()
    elif flat:
        pl.view_xy()
        pl.camera.up = view_up
    else:
        pl.view_isometric()
        pl.camera.up = view_up
    pl.reset_camera()


# ----------------------------------------------------------------------------- matplotlib
def line_axes(
    ax: Any, x: tuple[str, str], y: tuple[str, str], title: str = "", grid: bool = True
) -> Any:
    """Label matplotlib axes with quantity and unit: ``x = ("x along the plateau", "mm")``."""
    ax.set_xlabel(f"{x[0]} ({x[1]})" if x[1] else x[0])
    ax.set_ylabel(f"{y[0]} ({y[1]})" if y[1] else y[0])
    if title:
        ax.set_title(title)
    if grid:
        ax.grid(alpha=0.3)
    return ax


def caption(fig: Any, text: str, width: int = 100) -> None:
    """A caption under a matplotlib figure (wrapped to ``width`` characters): what the
    curves are and why a reference differs."""
    import textwrap

    fig.tight_layout()  # the axes' labels inside the figure, the caption below them
    wrapped = "\n".join(textwrap.wrap(text, width))
    fig.text(0.01, -0.01, wrapped, ha="left", va="top", fontsize=9)
