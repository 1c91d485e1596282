"""A 3D picture of a field: rendered by pyvista off-screen (parallel projection, no
text), framed by matplotlib with a scale bar of undeformed length, the anatomical
directions, the colour bar, the title and the legend (:func:`render_picture`, called
by :func:`bonecontact.plot.field_view`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np
import numpy.typing as npt

from bonecontact.plot.frame import (
    colorbar,
    draw_directions,
    field_array,
    legend,
    points3,
    proxy,
    pyvista_module,
    scale_bar_length,
    wrap,
)
from bonecontact.plot.record import register_field


def _surface_weights(surf: Any) -> np.ndarray:
    """The lumped area of each point of a triangulated surface (a third of its triangles')."""
    sizes = surf.compute_cell_sizes(length=False, area=True, volume=False)
    area = np.abs(np.asarray(sizes.cell_data["Area"]))
    tri = surf.faces.reshape(-1, 4)[:, 1:]
    w = np.zeros(surf.n_points)
    for k in range(3):
        np.add.at(w, tri[:, k], area / 3.0)
    return w


def _display(grid: Any, name: str, deform: tuple[str, float] | None, scale: float) -> Any:
    """The outer surface of ``grid`` (triangles), deformed, in display lengths, with the
    field as ``"shown"`` (point or cell data as ``grid`` has it)."""
    g = grid.copy()
    values, on_cells = field_array(g, name)
    (g.cell_data if on_cells else g.point_data)["shown"] = values
    if deform is not None:
        u = np.asarray(grid.point_data[deform[0]], dtype=np.float64)
        g.points = np.asarray(g.points) + deform[1] * np.pad(u, ((0, 0), (0, 3 - u.shape[1])))
    g.points = np.asarray(g.points) * scale
    surf = g.extract_surface(algorithm=None).triangulate()
    return surf


def _camera(pl: Any, up: str, zoom: float) -> None:
    view_up = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}[up]
    pl.view_isometric()
    pl.camera.up = view_up
    pl.enable_parallel_projection()
    pl.reset_camera()
    pl.camera.zoom(zoom)


def _screen_basis(pl: Any) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors of the screen's right and up directions in world coordinates."""
    cam = pl.camera
    dop = np.asarray(cam.focal_point) - np.asarray(cam.position)
    dop /= np.linalg.norm(dop)
    right = np.cross(dop, np.asarray(cam.up, dtype=float))
    right /= np.linalg.norm(right)
    return right, np.cross(right, dop)


def render_picture(
    fig: Any,
    grid: Any,
    name: str,
    style: Any,
    deform: tuple[str, float] | None,
    marks: list[Any],
    camera: tuple[str, float],
    directions: Mapping[str, npt.ArrayLike],
) -> None:
    """The 3D picture of :func:`bonecontact.plot.field_view` on ``fig``."""
    s = style.scale
    surf = _display(grid, name, deform, s)
    on_cells = "shown" in surf.cell_data
    values = (
        np.asarray(surf.cell_data["shown"] if on_cells else surf.point_data["shown"]) * style.factor
    )
    if on_cells:
        sizes = surf.compute_cell_sizes(length=False, area=True, volume=False)
        weights = np.abs(np.asarray(sizes.cell_data["Area"]))
    else:
        weights = _surface_weights(surf)
    cr = style.color_range(values, weights)
    w_px, h_px = (int(v) for v in fig.bbox.size)
    pl = pyvista_module().Plotter(off_screen=True, window_size=[int(0.8 * w_px), int(0.85 * h_px)])
    pl.set_background("white")
    surf["shown"] = values
    pl.add_mesh(surf, scalars="shown", cmap=style.cmap, clim=(cr.vmin, cr.vmax), log_scale=cr.log,
                show_scalar_bar=False, smooth_shading=not on_cells,
                ambient=0.5, diffuse=0.5, specular=0.0)  # fmt: skip
    _render_markers(pl, marks, grid, deform, s)
    _camera(pl, *camera)
    right, up = _screen_basis(pl)
    px_per_unit = pl.window_size[1] / (2.0 * pl.camera.parallel_scale)
    image = pl.screenshot(return_img=True)
    pl.close()
    ax = fig.add_subplot()
    ax.imshow(image)
    ax.set_axis_off()
    register_field(
        fig, style.label, values, weights, cr.vmin, cr.vmax, cr.clipped or cr.clipped_below
    )
    colorbar(fig, ax, style.cmap, cr, style.label)
    _scale_bar(ax, image.shape, px_per_unit, style.length_unit)
    vectors = {k: np.array([np.dot(v, right), np.dot(v, up)]) for k, v in directions.items()}
    draw_directions(ax, vectors)
    # points are rendered as spheres: their legend entries are dots of the same colour
    handles = [proxy(m if m.marker == "-" else replace(m, marker="o")) for m in marks]
    if deform is not None:
        from matplotlib.lines import Line2D

        handles.append(Line2D([], [], ls="none", label=f"shape: displacement × {deform[1]:g}"))
    legend(fig, handles)
    if style.title:
        fig.suptitle(wrap(style.title, fig.bbox.width * 0.9, 10.0), fontsize=13)


def _render_markers(
    pl: Any, marks: list[Any], grid: Any, deform: tuple[str, float] | None, s: float
) -> None:
    """The markers in the 3D scene, moved with the deformed shape."""
    for m in marks:
        p = points3(m.points)
        if deform is not None:
            u = np.asarray(grid.point_data[deform[0]], dtype=np.float64)
            u = np.pad(u, ((0, 0), (0, 3 - u.shape[1])))
            near = [grid.find_closest_point(q) for q in p]
            p = p + deform[1] * u[near]
        p = p * s
        if m.marker == "-":
            pl.add_lines(np.vstack([p, p[:1]]), color=m.color, width=3, connected=True)
        else:
            pl.add_points(p, color=m.color, point_size=2 * m.size, render_points_as_spheres=True)


def _scale_bar(ax: Any, shape: tuple[int, ...], px_per_unit: float, unit: str) -> None:
    """A scale bar (undeformed length) in the lower right corner of the rendered image."""
    h, w = shape[:2]
    length = scale_bar_length(w / px_per_unit)
    x1, y = 0.95 * w, 0.95 * h
    x0 = x1 - length * px_per_unit
    ax.plot([x0, x1], [y, y], "k-", lw=3, solid_capstyle="butt")
    ax.text(
        0.5 * (x0 + x1), y - 0.015 * h, f"{length:g} {unit}", ha="center", va="bottom", fontsize=10
    )
