"""The automatic figure check: colour ranges, nice numbers, and the record written beside
every PNG (saturated share, text boxes, legend entries), over families of synthetic
fields and figures.  The demos' own figures are checked against the same record in
tests/demos/test_demos.py (``test_demo_figures_pass_the_figure_check``).

References: the saturated share counted by hand from the values and weights; the
nice numbers listed by hand; defects built into a figure on purpose must be reported,
and a figure built without them must report none.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import bonecontact.plot as bp

pv = pytest.importorskip("pyvista")
matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

NICE = {1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0}


def _is_nice(x: float) -> bool:
    m = x / 10 ** np.floor(np.log10(x))
    return any(abs(m - n) < 1e-9 for n in NICE | {10.0})


@pytest.mark.parametrize(
    ("x", "up", "down"),
    [
        (0.349, 0.4, 0.3),
        (1.4, 1.5, 1.2),
        (5.48, 6.0, 5.0),
        (23.6036, 25.0, 20.0),
        (100.0, 100.0, 100.0),
    ],
)
def test_nice_numbers(x, up, down):
    assert bp.nice_ceil(x) == pytest.approx(up)
    assert bp.nice_floor(x) == pytest.approx(down)
    assert bp.nice_ceil(-x) == pytest.approx(-down)


@pytest.mark.parametrize(
    ("x", "f"), [(23.6036, 20.0), (30.0, 20.0), (1.0, 1.0), (0.07, 0.05), (512.0, 500.0)]
)
def test_nice_factor_rounds_a_deformation_scale_down(x, f):
    assert bp.nice_factor(x) == pytest.approx(f)


def _sample(kind: str, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Values and areas: a smooth field, a thin hot layer of small cells, a signed field,
    a heavy tail, a constant."""
    n = 4000
    if kind == "uniform":
        return rng.uniform(0, 3, n), rng.uniform(0.5, 1.5, n)
    if kind == "thin_layer":
        v = np.r_[rng.uniform(0, 1, n), rng.uniform(5, 50, 400)]
        return v, np.r_[np.ones(n), np.full(400, 0.02)]
    if kind == "signed":
        return rng.normal(0, 1, n), np.ones(n)
    if kind == "tail":
        return rng.lognormal(0, 1.2, n), rng.uniform(0.1, 1, n)
    return np.full(n, 2.5), np.ones(n)


@pytest.mark.parametrize("saturated", [0.002, 0.01, 0.05])
@pytest.mark.parametrize("kind", ["uniform", "thin_layer", "signed", "tail", "constant"])
def test_auto_range_saturates_at_most_the_share_asked(kind, saturated):
    """The share of the area outside the range, counted here, is at most ``saturated``; a
    clipped end is a nice number and is stated; an unclipped end is the data's extreme."""
    v, w = _sample(kind, np.random.default_rng(7))
    cr = bp.auto_range(v, w, saturated=saturated)
    out = w[(v > cr.vmax) | (v < cr.vmin)].sum() / w.sum()
    assert out <= saturated * (2 if kind == "signed" else 1) + 1e-12
    assert cr.clipped_fraction == pytest.approx(out)
    if cr.clipped:
        assert _is_nice(cr.vmax) and "clipped at" in cr.bar_label("q (MPa)")
    else:
        assert cr.vmax == pytest.approx(v.max())
    if cr.clipped_below:
        assert _is_nice(-cr.vmin) and "clipped at" in cr.bar_label("q (MPa)")
    if not (cr.clipped or cr.clipped_below):
        assert "clipped" not in cr.bar_label("q (MPa)") and out == 0.0
    if v.min() >= 0:
        assert cr.vmin == 0.0


def _figure_with(defect: str):
    fig, ax = plt.subplots(figsize=(4, 3))
    ax.plot([0, 1], [0, 1], label="computed")
    ax.plot([0, 1], [1, 0], label="reference")
    if defect != "no_legend_entry":
        ax.legend()
    if defect == "overlap":
        ax.text(0.5, 0.5, "a long note here", transform=ax.transAxes)
        ax.text(0.52, 0.5, "another note", transform=ax.transAxes)
    if defect == "saturated":
        img = ax.imshow(np.linspace(0, 1, 100).reshape(10, 10), vmin=0, vmax=0.5)
        fig.colorbar(img, ax=ax, label="q (MPa)")
    if defect == "no_ticks":
        ax.set_xticks([])
    if defect == "outside":
        fig.text(0.9, 0.5, "a text running out of the picture on the right")
    if defect == "twin":  # a twin's hidden x axis draws no tick labels over the host's
        ax.twinx().set_ylabel("second quantity (MPa)")
    return fig


@pytest.mark.parametrize(
    ("defect", "expected"),
    [
        ("none", None),
        ("twin", None),
        ("overlap", "texts overlap"),
        ("no_legend_entry", "without a legend entry"),
        ("saturated", "saturated"),
        ("no_ticks", "tick label"),
        ("outside", "outside the picture"),
    ],
)
def test_check_record_finds_each_defect(tmp_path, defect, expected):
    """A figure built with one defect reports it (and only a defect of that kind); the
    same figure without it reports nothing.  ``outside``: a fixed-size figure."""
    fig = _figure_with(defect)
    png = tmp_path / "f.png"
    if defect == "outside":
        fig.savefig(png)
        bp.write_record(fig, png)
        plt.close(fig)
    else:
        bp.show(fig, png)
    problems = bp.check_png(png)
    if expected is None:
        assert problems == []
    else:
        assert problems and all(expected in p for p in problems), problems


def test_check_png_without_record(tmp_path):
    assert "no figure record" in bp.check_png(tmp_path / "x.png")[0]


def _plane_grid(n: int = 24) -> pv.UnstructuredGrid:
    """A 40 × 20 mm plate of triangles; von Mises 1 MPa rising to 50 MPa in a thin top
    layer (y > 19 mm, 5 % of the area); region 1 the layer, 0 the rest."""
    g = pv.UnstructuredGrid(
        pv.Plane(
            center=(0.02, 0.01, 0), i_size=0.04, j_size=0.02, i_resolution=2 * n, j_resolution=n
        )
        .triangulate()
        .cast_to_unstructured_grid()
    )
    c = np.asarray(g.cell_centers().points)
    layer = c[:, 1] > 0.019
    g.cell_data["von_mises"] = 1e6 * (1 + c[:, 0] / 0.04) + 49e6 * layer
    u = np.zeros((g.n_points, 3))
    u[:, 1] = -2e-6 * np.asarray(g.points)[:, 0] / 0.04
    g.point_data["displacement"] = u
    g.cell_data["layer"] = layer.astype(int)
    return g


@pytest.mark.parametrize("smooth", [True, False])
@pytest.mark.parametrize("regions", [False, True])
def test_field_view_plane_family(tmp_path, smooth, regions):
    """A plate with a hot thin layer: the picture passes the check, at most 1 % of its area
    saturated (the clip stated), every marker in the legend, the deformation scale
    rounded (23.6 → 20) and stated once, the PNG at its window size."""
    g = _plane_grid()
    png = bp.field_view(
        g,
        "von_mises",
        tmp_path / "p.png",
        quantity="von Mises stress",
        unit="MPa",
        smooth=smooth,
        regions=g.cell_data["layer"] if regions else None,
        displacement="displacement",
        warp=23.6036,
        contact_points=[[0.01, 0.02], [0.02, 0.02]],
        outline=[[0.015, 0.005], [0.025, 0.005], [0.02, 0.012]],
        outline_label="tumour",
        markers=[bp.Marker([[0.03, 0.01]], "peak", "red", "*")],
        title="a plate under load with a title long enough to need wrapping on a small picture",
        directions={"proximal": (0, 1, 0), "medial": (1, 0, 0)},
        window_size=(800, 600),
    )
    assert bp.check_png(png) == []
    rec = json.loads(png.with_suffix(".json").read_text())
    assert rec["size"] == [800, 600]
    (field,) = rec["fields"]
    assert field["saturated_share"] <= 0.01 + 1e-12
    assert set(rec["legend"]) >= {
        "in contact",
        "tumour",
        "peak",
        "deformed outline, displacement × 20",
    }
    texts = " ".join(t["text"] for t in rec["texts"])
    assert texts.count("× 20") == 1 and "23.6" not in texts
    assert "proximal" in texts and "medial" in texts


@pytest.mark.parametrize("view", ["xy", "3d"])
def test_field_view_3d_family(tmp_path, view):
    """A block (cut face seen face-on on a log scale, or rendered in 3D): passes the
    check, ≤ 1 % saturated; a 3D picture has a scale bar of a nice length and the
    directions."""
    g = pv.ImageData(
        dimensions=(9, 7, 5), spacing=(0.005, 0.005, 0.005)
    ).cast_to_unstructured_grid()
    g = g.triangulate()
    c = np.asarray(g.cell_centers().points)
    g.cell_data["von_mises"] = 1e6 * (1 + 10 * c[:, 1]) + 30e6 * (c[:, 1] > 0.028)
    g.point_data["displacement"] = np.tile([0.0, -1e-6, 0.0], (g.n_points, 1))
    png = bp.field_view(
        g,
        "von_mises",
        tmp_path / "b.png",
        quantity="von Mises stress",
        unit="MPa",
        view=None if view == "3d" else view,
        log=view == "xy",  # a logarithmic colour scale on the face-on picture
        displacement="displacement",
        warp=100.0,
        directions={"superior": (0, 1, 0), "anterior": (1, 0, 0), "lateral": (0, 0, 1)},
        window_size=(700, 520),
    )
    assert bp.check_png(png) == []
    rec = json.loads(png.with_suffix(".json").read_text())
    assert rec["fields"][0]["saturated_share"] <= 0.01 + 1e-12
    texts = [t["text"] for t in rec["texts"]]
    if view == "3d":
        bar = [t for t in texts if t.endswith(" mm") and t[:-3].replace(".", "").isdigit()]
        assert len(bar) == 1 and _is_nice(float(bar[0][:-3]))
        assert "superior" in texts and "anterior" in texts


@pytest.mark.parametrize("saturated", [0.005, 0.02])
@pytest.mark.parametrize("spread", [1.0, 3.0])
def test_auto_range_log(saturated, spread):
    """A logarithmic range over data spanning decades (and some zeros, e.g. a soft
    tumour): both ends nice numbers, at most three decades apart, the bottom above the
    positive area quantile ``saturated`` is not required but at most ``saturated`` of the
    positive area lies below it unless the three-decade floor cuts in; the share outside
    counted here matches the range's."""
    rng = np.random.default_rng(3)
    v = np.r_[rng.lognormal(0, spread, 5000), np.zeros(50)]
    w = rng.uniform(0.5, 1.5, len(v))
    cr = bp.auto_range(v, w, saturated=saturated, log=True)
    assert cr.log and cr.vmin > 0 and _is_nice(cr.vmin)
    assert cr.vmax / cr.vmin <= 1e3 * (1 + 1e-9)
    out = w[(v > cr.vmax) | (v < cr.vmin)].sum() / w.sum()
    assert cr.clipped_fraction == pytest.approx(out)
    pos = v > 0
    below = w[pos & (v < cr.vmin)].sum() / w[pos].sum()
    assert below <= saturated + 1e-12 or cr.vmin == pytest.approx(bp.nice_floor(cr.vmax / 1e3))
    assert "clipped at" in cr.bar_label("q (MPa)")  # the zeros are below any log range
