"""Render the pictures of docs/meshing.md: every helper of bonecontact.meshing, its cell groups
coloured and its facet groups drawn as coloured lines, with a legend (off-screen, no X server).

    .venv/bin/python docs/img/make_meshing_images.py [NAME ...]
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import meshio
import numpy as np

import bonecontact.plot  # noqa: F401  (sets up off-screen rendering before pyvista)
from bonecontact import meshing

HERE = Path(__file__).resolve().parent
COLOURS = [
    "#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860", "#da8bc3", "#8c8c8c",
    "#ccb974", "#64b5cd",
]  # fmt: skip
LINES = ["#d62728", "#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd", "#17becf", "#e377c2", "#000000"]

#: name -> (builder of the .msh file, dimension, caption)
CASES = {
    "rectangle": (lambda p: meshing.rectangle(0.02, 0.01, 8, 4, None, path=p), 2),
    "quarter_tube": (lambda p: meshing.quarter_tube(0.01, 0.02, 0.002, None, path=p), 2),
    "two_blocks_2d": (lambda p: meshing.two_blocks_2d(None, p, upper_width=0.012), 2),
    "stacked_blocks_2d": (lambda p: meshing.stacked_blocks_2d(None, p), 2),
    "hertz_2d": (lambda p: meshing.hertz_2d(None, p, h_contact=4e-4, h_far=4e-3), 2),
    "knee_2d": (lambda p: meshing.knee_2d(None, p, h_contact=8e-4, h_far=5e-3), 2),
    "long_bone_2d": (lambda p: meshing.long_bone_2d(p, 0.004), 2),
    "box": (lambda p: meshing.box(0.02, 0.01, 0.01, 0.004, None, path=p), 3),
    "cantilever": (lambda p: meshing.cantilever(0.1, 0.01, 0.01, 0.004, None, path=p), 3),
    "two_boxes_3d": (lambda p: meshing.two_boxes_3d(None, p, upper_width=0.012), 3),
    "hertz_3d": (lambda p: meshing.hertz_3d(None, p, h_contact=8e-4, h_far=6e-3), 3),
}


def groups(m: meshio.Mesh, dim: int) -> dict[str, tuple[int, int]]:
    """name -> (tag, dim) of the physical groups of dimension ``dim``."""
    return {n: (int(t), int(d)) for n, (t, d) in m.field_data.items() if int(d) == dim}


def cells_of(m: meshio.Mesh, types: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Connectivity and physical tags of the cells of the given types."""
    conn, tags = [], []
    for block, phys in zip(m.cells, m.cell_data["gmsh:physical"]):
        if block.type in types:
            conn.append(block.data)
            tags.append(phys)
    if not conn:
        return np.zeros((0, 0), dtype=int), np.zeros(0, dtype=int)
    return np.vstack(conn), np.concatenate(tags)


def render_2d(name: str, msh: Path, out: Path) -> None:
    """A 2D mesh with matplotlib: cell groups filled, facet groups as thick lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection, PolyCollection

    m = meshio.read(msh)
    pts = m.points[:, :2] * 1e3  # mm
    conn, tags = cells_of(m, ("triangle",))
    fconn, ftags = cells_of(m, ("line",))
    fig, ax = plt.subplots(figsize=(9, 6))
    for k, (gname, (tag, _)) in enumerate(sorted(groups(m, 2).items())):
        tri = pts[conn[tags == tag]]
        ax.add_collection(
            PolyCollection(
                tri, facecolor=COLOURS[k % len(COLOURS)], edgecolor="#222222",
                linewidth=0.15, label=f"{gname} (cells)",
            )
        )  # fmt: skip
    for k, (gname, (tag, _)) in enumerate(sorted(groups(m, 1).items())):
        seg = pts[fconn[ftags == tag]]
        ax.add_collection(
            LineCollection(seg, colors=LINES[k % len(LINES)], linewidths=3.0,
                           label=f"{gname} (facets)")
        )  # fmt: skip
    ax.autoscale()
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"bonecontact.meshing.{name}: {len(conn)} triangles")
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=9, frameon=False)
    fig.savefig(out, dpi=110, bbox_inches="tight")
    plt.close(fig)


def render(name: str, msh: Path, dim: int, out: Path) -> None:
    if dim == 2:
        render_2d(name, msh, out)
        return
    import pyvista as pv

    m = meshio.read(msh)
    pts = m.points * 1e3  # mm
    if dim == 2:
        pts[:, 2] = 0.0
    ctypes = ("triangle",) if dim == 2 else ("tetra",)
    ftypes = ("line",) if dim == 2 else ("triangle",)
    conn, tags = cells_of(m, ctypes)
    vtk_type = pv.CellType.TRIANGLE if dim == 2 else pv.CellType.TETRA
    cells = np.hstack([np.full((len(conn), 1), conn.shape[1]), conn]).ravel()
    grid = pv.UnstructuredGrid(cells, np.full(len(conn), vtk_type, dtype=np.uint8), pts)
    pl = pv.Plotter(off_screen=True, window_size=(1300, 750), shape=(1, 2), col_weights=[2, 1])
    pl.set_background("white")
    pl.subplot(0, 0)
    legend = []
    for k, (gname, (tag, _)) in enumerate(sorted(groups(m, dim).items())):
        sub = grid.extract_cells(np.flatnonzero(tags == tag))
        colour = COLOURS[k % len(COLOURS)]
        if dim == 3:
            sub = sub.extract_surface(algorithm="dataset_surface")
        pl.add_mesh(sub, color=colour, show_edges=True, edge_color="#333333", line_width=0.5)
        legend.append([f"{gname} (cells)", colour])
    fconn, ftags = cells_of(m, ftypes)
    for k, (gname, (tag, _)) in enumerate(sorted(groups(m, dim - 1).items())):
        colour = LINES[k % len(LINES)]
        sel = fconn[ftags == tag]
        if dim == 2:
            lines = np.hstack([np.full((len(sel), 1), 2), sel]).ravel()
            poly = pv.PolyData(pts, lines=lines)
            pl.add_mesh(poly, color=colour, line_width=5)
        else:
            faces = np.hstack([np.full((len(sel), 1), 3), sel]).ravel()
            poly = pv.PolyData(pts, faces=faces)
            pl.add_mesh(poly.extract_feature_edges(90), color=colour, line_width=4)
        legend.append([f"{gname} (facets)", colour])
    pl.show_bounds(
        xtitle="x (mm)", ytitle="y (mm)", ztitle="z (mm)", color="black", font_size=11,
        location="outer", grid=False, ticks="outside", show_zaxis=dim == 3,
        show_zlabels=dim == 3,
    )  # fmt: skip
    if dim == 2:
        pl.view_xy()
    else:
        pl.view_vector((1.0, 0.8, 1.6), viewup=(0, 1, 0))
    pl.camera.up = (0, 1, 0)
    pl.reset_camera()
    pl.camera.zoom(0.85)
    pl.add_text(f"bonecontact.meshing.{name}", position="upper_left", font_size=12, color="k")
    pl.subplot(0, 1)
    pl.add_legend(legend, bcolor="white", loc="center left", size=(0.9, 0.06 * len(legend)))
    pl.screenshot(str(out))
    pl.close()


def main(names: list[str]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        for name in names or list(CASES):
            build, dim = CASES[name]
            msh = Path(tmp) / f"{name}.msh"
            build(msh)
            out = HERE / f"meshing_{name}.png"
            render(name, msh, dim, out)
            print(out)


if __name__ == "__main__":
    main(sys.argv[1:])
