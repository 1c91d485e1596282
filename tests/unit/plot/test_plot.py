"""bonecontact.plot: colour ranges, the display projection, pictures written off-screen.

References: percentiles and area fractions counted by hand; the lumped L² projection of
a piecewise-constant field on two triangles computed by hand (and exact for a constant);
the PNG's pixel size equals the requested window.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import bonecontact.plot as bp

pv = pytest.importorskip("pyvista")


def _two_triangles(a: float = 1.0) -> pv.UnstructuredGrid:
    """Triangles (0,0)-(1,0)-(1,1) (area 1/2) and (0,0)-(1,1)-(-a,1) (area (1+a)/2)."""
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [-a, 1, 0]], dtype=float)
    cells = np.array([3, 0, 1, 2, 3, 0, 2, 3])
    types = np.array([pv.CellType.TRIANGLE] * 2, dtype=np.uint8)
    return pv.UnstructuredGrid(cells, types, pts)


def test_color_range_percentile_and_clipping():
    v = np.arange(1.0, 101.0)
    cr = bp.color_range(v, upper=99.0)
    assert (cr.vmin, cr.vmax, cr.data_max) == (1.0, 99.0, 100.0)
    assert cr.clipped_fraction == pytest.approx(0.01)
    assert cr.clipped
    assert "clipped at 99 MPa (max 100 MPa, 1 % of the area above)" in cr.note("MPa")
    assert "clipped at 99 (max 100, 1 %" in cr.note("")  # a dimensionless quantity
    assert bp.color_range(v, upper=100.0).note("MPa") == ""
    assert bp.color_range(v, lower=None).vmin == 0.0


def test_color_range_area_weighted():
    """A thin layer (many small cells) of high values: by area it is 2 % of the picture."""
    v = np.r_[np.full(98, 10.0), np.full(200, 1000.0)]
    w = np.r_[np.full(98, 1.0), np.full(200, 0.01)]  # 98 + 2 area units
    cr = bp.color_range(v, upper=95.0, weights=w)
    assert cr.vmax == 10.0
    assert cr.clipped_fraction == pytest.approx(2.0 / 100.0)
    assert bp.color_range(v, upper=95.0).vmax == 1000.0  # unweighted: the layer dominates


@pytest.mark.parametrize("a", [1.0, 3.0])
def test_smooth_cell_data_is_the_lumped_projection(a):
    g = _two_triangles(a)
    g.cell_data["s"] = np.array([1.0, 3.0])
    p = bp.smooth_cell_data(g, "s")
    w1, w2 = 0.5, 0.5 * (1.0 + a)
    shared = (w1 * 1.0 + w2 * 3.0) / (w1 + w2)
    np.testing.assert_allclose(p, [shared, 1.0, shared, 3.0], rtol=1e-14)
    g.cell_data["c"] = np.array([[2.0, -1.0], [2.0, -1.0]])
    np.testing.assert_allclose(bp.smooth_cell_data(g, "c"), np.tile([2.0, -1.0], (4, 1)))


def test_output_dir(tmp_path, monkeypatch):
    monkeypatch.delenv("BONECONTACT_OUTPUT", raising=False)
    assert bp.output_dir("knee2d", tmp_path) == tmp_path / "results" / "knee2d"
    monkeypatch.setenv("BONECONTACT_OUTPUT", str(tmp_path / "env"))
    assert bp.output_dir("knee2d", tmp_path) == tmp_path / "env" / "knee2d"
    assert bp.output_dir("knee2d", tmp_path, ["-q", str(tmp_path / "a")]) == tmp_path / "a"


@pytest.mark.parametrize(
    ("value", "quick"), [(None, False), ("", False), ("0", False), ("1", True)]
)
def test_quick_mode(monkeypatch, value, quick):
    if value is None:
        monkeypatch.delenv("BONECONTACT_DEMO_QUICK", raising=False)
    else:
        monkeypatch.setenv("BONECONTACT_DEMO_QUICK", value)
    assert bp.quick_mode() is quick


def test_show_saves_a_matplotlib_figure(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 2])
    bp.line_axes(ax, ("x along the plateau", "mm"), ("contact pressure", "MPa"))
    assert ax.get_xlabel() == "x along the plateau (mm)"
    assert ax.get_ylabel() == "contact pressure (MPa)"
    bp.caption(fig, "a caption")
    out = bp.show(fig, tmp_path / "sub" / "line.png")
    assert out.is_file() and out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not plt.get_fignums()  # closed
    assert not bp.in_notebook()


SCRIPT = """
import numpy as np, pyvista as pv, bonecontact.plot as bp
g = pv.ImageData(dimensions=(5, 4, 3), spacing=(0.005, 0.005, 0.005)).cast_to_unstructured_grid()
g = g.triangulate()
g.cell_data["von_mises"] = 1e6 * (1 + np.asarray(g.cell_centers().points)[:, 0] / 0.02)
g.point_data["displacement"] = np.tile([0.0, -1e-5, 0.0], (g.n_points, 1))
bp.field_view(g, "von_mises", r"{out}", quantity="von Mises stress", unit="MPa",
              displacement="displacement", warp=10.0, contact_points=[[0.0, 0.005, 0.0]],
              window_size=(640, 480), title="test")
"""


@pytest.mark.serial  # spawns its own process
def test_field_view_writes_png_without_x_server(tmp_path):
    """A 3D picture (rendered by pyvista off-screen) in a process without DISPLAY."""
    out = tmp_path / "view.png"
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    r = subprocess.run(
        [sys.executable, "-c", SCRIPT.format(out=out)],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr
    assert "X server" not in r.stderr and "DISPLAY" not in r.stderr
    import matplotlib.image as mpimg

    img = mpimg.imread(out)
    assert img.shape[:2] == (480, 640)
    assert img[..., :3].std() > 0.05  # not a blank picture


def test_field_view_face_on_shows_the_colour_bar_colours(tmp_path):
    """A cut face seen face-on (``view``) is drawn unlit: a cell above the colour range
    has exactly the colour of the top of the colour bar (the colour map's last colour)."""
    import matplotlib

    g = pv.ImageData(dimensions=(5, 5, 3), spacing=(0.01, 0.01, 0.005)).cast_to_unstructured_grid()
    g.cell_data["von_mises"] = np.full(g.n_cells, 2e6)
    out = bp.field_view(
        g, "von_mises", tmp_path / "face.png", quantity="q", unit="MPa", clim=(0.0, 1.0),
        cmap="inferno", window_size=(400, 300), view="xy",
    )  # fmt: skip
    img = matplotlib.image.imread(out)[..., :3]
    top = np.array(matplotlib.colormaps["inferno"](1.0)[:3])
    centre = img[img.shape[0] // 2, int(img.shape[1] * 0.4)]  # left of the colour bar
    np.testing.assert_allclose(centre, top, atol=2 / 255)


def test_field_view_refuses_an_unknown_view(tmp_path):
    """``view`` names a coordinate plane (or None); anything else is refused before drawing."""
    with pytest.raises(ValueError, match="view must be"):
        bp.field_view(None, "von_mises", tmp_path / "v.png", quantity="q", view="front")
    assert not (tmp_path / "v.png").exists()


def test_plot_has_no_bonecontact_imports():
    """bonecontact.plot stands alone (any layer may use it; it reads files, not models):
    its modules import only each other from bonecontact."""
    import re

    for path in Path(bp.__file__).parent.glob("*.py"):
        for m in re.finditer(r"(?:from|import) (bonecontact[\w.]*)", path.read_text()):
            assert m.group(1).startswith("bonecontact.plot"), (path.name, m.group(1))


def test_progress_file_is_one_updating_display(monkeypatch):
    """In a notebook a progress bar writes to one display, updated in place with the last
    line written (after the last carriage return); outside a notebook: stderr (None)."""
    import IPython.display

    from bonecontact.plot.progress import DisplayFile

    assert bp.progress_file() is None
    shown = []

    class Handle:
        def update(self, data, raw):
            shown.append(("update", data["text/plain"]))

    def display(data, raw, display_id):
        shown.append(("display", data["text/plain"]))
        return Handle()

    monkeypatch.setattr(IPython.display, "display", display)
    f = DisplayFile()
    for k in range(3):
        f.write(f"\rrun: {k}/2")
    f.write("\n")
    assert shown == [("display", "run: 0/2"), ("update", "run: 1/2"), ("update", "run: 2/2")]
