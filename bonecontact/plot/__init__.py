"""Pictures of results for notebooks, scripts and papers (matplotlib, pyvista for 3D).

* :func:`field_view` — a field on a plane (matplotlib, undeformed axes in mm) or in 3D
  (pyvista, framed with a scale bar and anatomical directions): continuous, a colour
  range saturating ≤ 2 % of the area with the clip stated, every marker in the legend;
* :func:`auto_range`, :func:`color_range`, :func:`nice_ceil`, :func:`nice_factor` — colour
  ranges and nice numbers (:mod:`bonecontact.plot.scales`);
* :func:`show` — saves a figure with its record (texts, legend, saturation: JSON beside the
  PNG, :mod:`bonecontact.plot.record`) and shows it inline in Jupyter; :func:`check_png`
  lists what a journal would reject;
* :func:`line_axes`, :func:`caption`, :func:`read_fields`, :func:`output_dir`,
  :func:`progress_file` (one updating progress bar in a notebook).

Everything runs without an X server: pyvista renders off-screen (EGL when ``DISPLAY`` is
unset).  Units SI in, display units (mm, MPa) out, always stated on the picture.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

if not os.environ.get("DISPLAY"):  # off-screen rendering without an X server
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

from bonecontact.plot.env import in_notebook, output_dir, quick_mode
from bonecontact.plot.fields import (
    LENGTH_UNITS,
    STRESS_UNITS,
    UNIT_FACTORS,
    field_view,
    lumped_projection,
)
from bonecontact.plot.frame import Marker, draw_directions, pyvista_module, smooth_cell_data
from bonecontact.plot.progress import progress_file
from bonecontact.plot.record import (
    check_png,
    check_record,
    figure_record,
    register_field,
    write_record,
)
from bonecontact.plot.scales import (
    MAX_SATURATED,
    ColorRange,
    auto_range,
    color_range,
    nice_ceil,
    nice_factor,
    nice_floor,
)

__all__ = [
    "LENGTH_UNITS",
    "MAX_SATURATED",
    "STRESS_UNITS",
    "UNIT_FACTORS",
    "ColorRange",
    "Marker",
    "auto_range",
    "caption",
    "check_png",
    "check_record",
    "color_range",
    "draw_directions",
    "field_view",
    "figure_record",
    "in_notebook",
    "line_axes",
    "lumped_projection",
    "nice_ceil",
    "nice_factor",
    "nice_floor",
    "output_dir",
    "progress_file",
    "pyvista_module",
    "quick_mode",
    "read_fields",
    "register_field",
    "show",
    "smooth_cell_data",
    "write_record",
]


def show(figure: Any, path: str | Path, dpi: int = 150) -> Path:
    """Save a figure to ``path`` with its record (``.json`` beside it) and show it inline
    when running in Jupyter.

    Parameters
    ----------
    figure
        A matplotlib figure (saved cropped to its content, its record written, then
        closed), or the path of a PNG already written (a :func:`field_view` picture;
        copied with its record when ``path`` is elsewhere).
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
        src = Path(figure)
        if src.resolve() != path.resolve():
            path.write_bytes(src.read_bytes())
            if src.with_suffix(".json").is_file():
                path.with_suffix(".json").write_bytes(src.with_suffix(".json").read_bytes())
    else:
        _save_tight(figure, path, dpi)
    if in_notebook():
        from IPython.display import Image, display

        display(Image(filename=str(path)))
    return path


def _save_tight(fig: Any, path: Path, dpi: int) -> None:
    """Save ``fig`` cropped to its content (0.1 inch of margin) with its record, in the
    saved picture's pixels; then close it."""
    import matplotlib.pyplot as plt

    fig.set_dpi(dpi)
    fig.canvas.draw()
    box = fig.get_tightbbox(fig.canvas.get_renderer()).padded(0.1)
    fig.savefig(path, dpi=dpi, bbox_inches=box)
    write_record(fig, path, [box.x0 * dpi, box.y0 * dpi, box.x1 * dpi, box.y1 * dpi])
    plt.close(fig)


# ----------------------------------------------------------------------------- results
def read_fields(path: str | Path, time_index: int = -1) -> Any:
    """The grid of one saved time of a run's ``fields.pvd`` (default: the last)."""
    pv = pyvista_module()

    reader = pv.get_reader(str(path))
    n = len(reader.time_values)
    reader.set_active_time_point(time_index % n if n else 0)
    return reader.read().combine()


# ----------------------------------------------------------------------------- matplotlib
def line_axes(
    ax: Any,
    x: tuple[str, str],
    y: tuple[str, str],
    title: str = "",
    grid: bool = True,
    zero: bool = False,
) -> Any:
    """Label matplotlib axes with quantity and unit: ``x = ("x along the plateau", "mm")``.

    ``zero``: the y axis starts (or, for negative data, ends) at 0, so that a change of a
    few per cent is not magnified into a slope across the panel (call after plotting)."""
    ax.set_xlabel(f"{x[0]} ({x[1]})" if x[1] else x[0])
    ax.set_ylabel(f"{y[0]} ({y[1]})" if y[1] else y[0])
    if title:
        ax.set_title(title)
    if grid:
        ax.grid(alpha=0.3)
    if zero:
        lo, hi = ax.dataLim.intervaly
        if lo >= 0:
            ax.set_ylim(0.0, 1.1 * hi if hi > 0 else 1.0)
        elif hi <= 0:
            ax.set_ylim(1.1 * lo, 0.0)
    return ax


def caption(fig: Any, text: str, width: int = 100) -> None:
    """A caption under a matplotlib figure (wrapped to ``width`` characters, never inside
    a ``$…$`` formula): what the curves are and why a reference differs."""
    import re
    import textwrap

    fig.tight_layout()  # the axes' labels inside the figure, the caption below them
    glued = re.sub(r"\$[^$]*\$", lambda m: m.group(0).replace(" ", "\x00"), text)
    wrapped = "\n".join(textwrap.wrap(glued, width)).replace("\x00", " ")
    fig.text(0.01, -0.01, wrapped, ha="left", va="top", fontsize=9)
