"""Render the pictures of docs/meshing.md "From a surface scan" and "From CT" (off-screen).

.venv/bin/python docs/img/make_real_data_images.py
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import matplotlib
import meshio
import numpy as np

import bonecontact.plot  # noqa: F401  (sets up off-screen rendering before pyvista)
from bonecontact.meshing import SurfaceRegion, anatomy_surface, bone_from_surface
from bonecontact.meshing.ct import bone_regions, ct_slice_mesh, read_ct_slice

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import pyvista as pv

HERE = Path(__file__).resolve().parent


def vertebra(out: Path) -> None:
    """L4 from its shipped surface: facet groups (left), a cut through the tetrahedra (right)."""
    endplate = SurfaceRegion(
        "L4_endplate", cone=((0, 1, 0), 35), box=((-0.02, 0.02, -0.03), (0.02, 0.04, 0.03))
    )
    with tempfile.TemporaryDirectory() as tmp:
        msh = Path(tmp) / "L4.msh"
        bone_from_surface(
            anatomy_surface("L4"), 3e-3, 1.5e-3, name="L4", regions=[endplate], path=msh
        )
        m = meshio.read(msh)
    names = {int(t): n for n, (t, d) in m.field_data.items()}
    tets = np.vstack([c.data for c in m.cells if c.type == "tetra"])
    tet_tags = np.concatenate(
        [p for c, p in zip(m.cells, m.cell_data["gmsh:physical"]) if c.type == "tetra"]
    )
    tris = np.vstack([c.data for c in m.cells if c.type == "triangle"])
    tri_tags = np.concatenate(
        [p for c, p in zip(m.cells, m.cell_data["gmsh:physical"]) if c.type == "triangle"]
    )
    grid = pv.UnstructuredGrid({pv.CellType.TETRA: tets}, m.points)
    grid.cell_data["group"] = tet_tags
    surf = pv.PolyData(m.points, np.hstack([np.full((len(tris), 1), 3), tris]).ravel())
    surf.cell_data["group"] = tri_tags
    p = pv.Plotter(off_screen=True, shape=(1, 2), window_size=(1400, 650))
    p.subplot(0, 0)
    colours = {"L4_endplate": "#d62728", "L4_surface": "#d9d2c5"}
    for tag, name in names.items():
        if name in colours:
            part = surf.extract_cells(tri_tags == tag)
            p.add_mesh(part, color=colours[name], show_edges=True, edge_color="#555555")
    p.add_text("facet groups: L4_endplate (red), L4_surface (grey)", font_size=11)
    p.camera_position = [(0.07, 0.12, 0.13), (-0.01, 0.017, 0.0), (0, 1, 0)]
    p.subplot(0, 1)
    cut = grid.clip(normal=(0, 0, 1), origin=(0, 0, 0), crinkle=True)
    colours = {"L4_cortical": "#c9b27c", "L4_cancellous": "#8c5a3c"}
    for tag, name in names.items():
        if name in colours:
            part = cut.extract_cells(cut.cell_data["group"] == tag)
            p.add_mesh(part, color=colours[name], show_edges=True, edge_color="#333333")
    p.add_text("cut at z = 0: L4_cortical (light), L4_cancellous (dark)", font_size=11)
    p.camera_position = [(-0.02, 0.017, 0.15), (-0.02, 0.017, 0.0), (0, 1, 0)]
    p.screenshot(out)
    p.close()


def ct(out: Path) -> None:
    """pydicom's CT_small.dcm: the image, the contours at 300 HU, the triangle mesh."""
    from pydicom.data import get_testdata_file

    path = get_testdata_file("CT_small.dcm")
    image = read_ct_slice(path)
    with tempfile.TemporaryDirectory() as tmp:
        msh = ct_slice_mesh(image, 300.0, name="vertebra", path=Path(tmp) / "ct.msh")
        m = meshio.read(msh)
    dr, dc = image.spacing
    ox, oy = image.origin[:2]
    n_r, n_c = image.hu.shape
    extent = [ox - dc / 2, ox + (n_c - 0.5) * dc, -(oy + (n_r - 0.5) * dr), -(oy - dr / 2)]
    fig, ax = plt.subplots(1, 2, figsize=(11, 5.2))
    for a in ax:
        a.imshow(image.hu, cmap="gray", extent=extent, vmin=-400, vmax=1200)
        a.set_aspect("equal")
        a.set_xlabel("x (m)")
    ax[0].set_ylabel("y (m)")
    for outer, holes in bone_regions(image, 300.0):
        for loop in [outer, *holes]:
            closed = np.vstack([loop, loop[:1]])
            ax[0].plot(closed[:, 0], closed[:, 1], "r-", lw=1)
    ax[0].set_title("CT_small.dcm, contours at 300 HU")
    tri = m.cells_dict["triangle"]
    ax[1].triplot(m.points[:, 0], m.points[:, 1], tri, color="#ffcc00", lw=0.4)
    ax[1].set_title(f"mesh of the bone region: {len(tri)} triangles")
    lo, hi = m.points.min(axis=0), m.points.max(axis=0)
    for a in ax:
        a.set_xlim(lo[0] - 0.005, hi[0] + 0.005)
        a.set_ylim(lo[1] - 0.005, hi[1] + 0.005)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    vertebra(HERE / "meshing_stl_vertebra.png")
    ct(HERE / "meshing_ct.png")
