"""The frame of a picture shared by the plane and the 3D pictures of
:func:`bonecontact.plot.field_view`: markers and their legend, the colour bar with the
clip stated, the anatomical direction arrows, the scale bar, the wrapped title.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from bonecontact.plot.scales import ColorRange, nice_factor


@dataclass(frozen=True)
class Marker:
    """Points to mark on a picture, with their legend entry.

    Parameters
    ----------
    points
        Coordinates (m), one row a point.
    label
        The legend entry.
    color, marker
        matplotlib colour and marker (``marker = "-"``: a closed polyline, e.g. an outline).
    size
        Marker size (points).
    """

    points: npt.ArrayLike
    label: str
    color: str = "deepskyblue"
    marker: str = "o"
    size: float = 6.0


def field_array(grid: Any, name: str) -> tuple[np.ndarray, bool]:
    """The field as one number per cell or point (magnitude of a vector), and whether
    it is a cell field."""
    if name in grid.cell_data:
        v, on_cells = np.asarray(grid.cell_data[name], dtype=np.float64), True
    elif name in grid.point_data:
        v, on_cells = np.asarray(grid.point_data[name], dtype=np.float64), False
    else:
        raise KeyError(f"field_view: the grid has no field {name!r}")
    if v.ndim == 2:
        v = np.linalg.norm(v, axis=1)
    return v, on_cells


def wrap(text: str, width_px: float, font_px: float = 9.0) -> str:
    """``text`` wrapped to fit ``width_px`` pixels (about ``font_px`` pixels a character)."""
    return "\n".join(textwrap.wrap(text, max(int(width_px / font_px), 20)))


def colorbar(fig: Any, ax: Any, cmap: str, cr: ColorRange, label: str) -> Any:
    """A colour bar of the range ``cr`` with nice ticks; the clip stated in its label."""
    import matplotlib as mpl

    sm = mpl.cm.ScalarMappable(norm=cr.norm(), cmap=cmap)
    sm.bonecontact_registered = True
    bar = fig.colorbar(sm, ax=ax, extend=cr.extend, shrink=0.8, pad=0.02, fraction=0.05)
    bar.set_label(cr.bar_label(label + (", log scale" if cr.log else "")))
    if not cr.log:
        bar.ax.yaxis.set_major_locator(mpl.ticker.MaxNLocator(6))
    return bar


def legend(fig: Any, handles: list[Any]) -> None:
    """The legend of the markers under the picture (outside it)."""
    if handles:
        fig.legend(
            handles=handles,
            loc="outside lower center",
            ncols=min(len(handles), 2),
            frameon=False,
            fontsize=10,
        )


def proxy(m: Marker) -> Any:
    from matplotlib.lines import Line2D

    if m.marker == "-":
        return Line2D([], [], color=m.color, lw=2, label=m.label)
    return Line2D([], [], color=m.color, marker=m.marker, ls="none", ms=m.size, label=m.label)


def points3(points: npt.ArrayLike) -> np.ndarray:
    p = np.atleast_2d(np.asarray(points, dtype=np.float64))
    return np.pad(p, ((0, 0), (0, 3 - p.shape[1])))


def draw_directions(ax: Any, vectors: Mapping[str, np.ndarray], corner: str = "lower left") -> None:
    """Arrows along the 2D ``vectors`` (screen components, y up) in a small white inset in
    a ``corner`` of ``ax``, labelled at their tips; a direction seen end-on (in-plane length
    < 0.3) is left out."""
    shown = {k: np.asarray(v, dtype=float) for k, v in vectors.items()}
    shown = {k: v / np.linalg.norm(v) for k, v in shown.items() if np.linalg.norm(v) >= 0.3}
    if not shown:
        return
    from mpl_toolkits.axes_grid1.inset_locator import inset_axes

    inset = inset_axes(ax, width=0.9, height=0.9, loc=corner, borderpad=1.0)  # inches
    inset.set_xlim(-1.6, 1.6)
    inset.set_ylim(-1.6, 1.6)
    inset.set_aspect("equal")
    inset.set_axis_off()
    inset.add_patch(_white_box(inset))
    for label, d in shown.items():
        tip = 0.9 * d
        inset.annotate("", xy=tip, xytext=(0, 0), arrowprops={"arrowstyle": "-|>", "lw": 1.2})
        ha = "left" if d[0] > 0.3 else ("right" if d[0] < -0.3 else "center")
        va = "bottom" if d[1] > 0.3 else ("top" if d[1] < -0.3 else "center")
        inset.text(1.0 * d[0], 1.0 * d[1], label, ha=ha, va=va, fontsize=8)


def _white_box(inset: Any) -> Any:
    from matplotlib.patches import Rectangle

    return Rectangle(
        (0, 0),
        1,
        1,
        transform=inset.transAxes,
        fc="white",
        ec="0.6",
        lw=0.5,
        alpha=1.0,
        clip_on=False,
    )


def scale_bar_length(width: float) -> float:
    """A length of 1, 2 or 5 × 10^k of about a fifth of ``width``."""
    return nice_factor(0.2 * width) if width > 0 else 1.0


def pyvista_module() -> Any:
    """pyvista, imported without the ipywidgets warning its import chain (pooch → tqdm.auto)
    prints in a Jupyter kernel that has no ipywidgets."""
    import warnings

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="IProgress not found")
        import pyvista

    return pyvista


def cell_measures(grid: Any) -> npt.NDArray[np.float64]:
    """The volume of each cell of a 3D grid, else its area."""
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
    measure = cell_measures(grid)
    num = np.zeros((grid.n_points,) + values.shape[1:])
    den = np.zeros(grid.n_points)
    start = 0
    for _, cells in grid.cells_dict.items():
        n = len(cells)
        idx = slice(start, start + n)
        w = measure[idx]
        for k in range(cells.shape[1]):
            np.add.at(den, cells[:, k], w)
            np.add.at(num, cells[:, k], (w * values[idx].T).T)
        start += n
    den[den == 0] = 1.0
    return (num.T / den).T
