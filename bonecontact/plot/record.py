"""What a figure shows, written as JSON beside its PNG, and the checks a figure must pass.

:func:`write_record` (called by :func:`bonecontact.plot.show`) writes ``<name>.json`` next
to ``<name>.png``: the figure's size, the bounding box of every text drawn (tick labels,
titles, axis and colour-bar labels, legend entries, notes), the labelled artists and the
legend entries of every axes, and every colour-mapped field with the share of its area
outside the colour range (:func:`register_field`; matplotlib artists with a colour
norm are found by themselves).  :func:`check_record` lists what a journal would reject.
"""

from __future__ import annotations

import json
import weakref
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from bonecontact.plot.scales import MAX_SATURATED

#: Fields registered on a figure (:func:`register_field`), by figure.
_FIELDS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
#: Pixels two texts may share before they count as overlapping.
OVERLAP_TOLERANCE = 1.0


def register_field(
    fig: Any,
    label: str,
    values: npt.ArrayLike,
    weights: npt.ArrayLike | None,
    vmin: float,
    vmax: float,
    stated: bool,
) -> dict[str, Any]:
    """Record a colour-mapped field of ``fig`` (e.g. a rendered 3D picture): the share of
    its area (``weights``) outside ``[vmin, vmax]`` and whether the figure states the clip."""
    v = np.asarray(values, dtype=np.float64).ravel()
    w = np.ones_like(v) if weights is None else np.asarray(weights, dtype=np.float64).ravel()
    share = float(w[(v > vmax) | (v < vmin)].sum() / w.sum()) if v.size else 0.0
    entry = {
        "label": label,
        "vmin": float(vmin),
        "vmax": float(vmax),
        "data_min": float(v.min()) if v.size else 0.0,
        "data_max": float(v.max()) if v.size else 0.0,
        "saturated_share": share,
        "stated": bool(stated),
    }
    _FIELDS.setdefault(fig, []).append(entry)
    return entry


def _text_boxes(fig: Any, renderer: Any) -> list[dict[str, Any]]:
    """Every visible, non-empty text of ``fig`` with its pixel box and its role."""
    from matplotlib.text import Text

    ticks = {id(t): r for r, t, _ in _tick_labels(fig)}
    out = []
    for t in fig.findobj(Text):
        if not t.get_visible() or not t.get_text().strip() or not _drawn(t, ticks):
            continue
        bb = t.get_window_extent(renderer)
        if bb.width <= 0 or bb.height <= 0:
            continue
        out.append(
            {
                "text": t.get_text(),
                "role": ticks.get(id(t), "text"),
                "box": [float(bb.x0), float(bb.y0), float(bb.x1), float(bb.y1)],
            }
        )
    return out


def _tick_labels(fig: Any) -> list[tuple[str, Any, Any]]:
    """(role, text, axes) of the tick labels: role ``"xtick"``/``"ytick"`` if drawn (visible,
    of a tick inside the view interval), else ``"hidden"``."""
    out = []
    for ax in fig.axes:
        if not ax.axison:
            continue
        for name, axis in (("xtick", ax.xaxis), ("ytick", ax.yaxis)):
            lo, hi = sorted(axis.get_view_interval())
            eps = 1e-9 * max(abs(hi - lo), 1e-300)
            axis.get_majorticklabels()  # brings the ticks up to date
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                inside = lo - eps <= tick.get_loc() <= hi + eps
                shown = inside and axis.get_visible()  # a twin's hidden axis draws nothing
                for lab in (tick.label1, tick.label2):
                    out.append((name if shown and lab.get_visible() else "hidden", lab, ax))
    return out


def _drawn(t: Any, ticks: dict[int, str]) -> bool:
    """Whether text ``t`` is drawn: not a hidden tick label, its axes (if any) shown."""
    if ticks.get(id(t)) == "hidden":
        return False
    ax = t.axes
    if ax is not None and not ax.get_visible():
        return False
    return True


def _legends(fig: Any) -> tuple[list[str], list[str]]:
    """The labels of the labelled artists of every axes, and every legend entry."""
    labelled, entries = [], []
    for ax in fig.axes:
        _, labels = ax.get_legend_handles_labels()
        labelled += labels
        if ax.get_legend() is not None:
            entries += [t.get_text() for t in ax.get_legend().get_texts()]
    for leg in fig.legends:
        entries += [t.get_text() for t in leg.get_texts()]
    return labelled, entries


def _mapped(fig: Any) -> list[dict[str, Any]]:
    """The matplotlib colour-mapped artists (a norm and an array) not registered by hand."""
    from matplotlib.cm import ScalarMappable

    out = []
    for art in fig.findobj(lambda a: isinstance(a, ScalarMappable)):
        arr = art.get_array() if hasattr(art, "get_array") else None
        if arr is None or getattr(art, "bonecontact_registered", False):
            continue
        if getattr(art, "colorbar", None) is None:  # a colour map without a bar: no scale
            continue
        v = np.ma.compressed(np.ma.asarray(arr, dtype=np.float64))
        norm = art.norm
        lab = art.colorbar.ax.get_ylabel() or art.colorbar.ax.get_xlabel()
        stated = "clipped" in lab
        out.append(_field_entry(lab, v, norm.vmin, norm.vmax, stated))
    return out


def _field_entry(label: str, v: np.ndarray, vmin: float, vmax: float, stated: bool) -> dict:
    share = float(np.mean((v > vmax) | (v < vmin))) if v.size else 0.0
    return {
        "label": label,
        "vmin": float(vmin),
        "vmax": float(vmax),
        "data_min": float(v.min()) if v.size else 0.0,
        "data_max": float(v.max()) if v.size else 0.0,
        "saturated_share": share,
        "stated": bool(stated),
    }


def _axes_ticks(fig: Any, texts: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per shown data axes (not a colour bar): the number of tick labels drawn on x and y."""
    out, ticks = [], _tick_labels(fig)
    for k, ax in enumerate(fig.axes):
        if not ax.axison or ax.get_label() == "<colorbar>":
            continue
        counts = {}
        for name, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            labs = [lab for r, lab, a in ticks if r == f"{name}tick" and a is ax]
            counts[name] = sum(bool(lab.get_text().strip()) for lab in labs)
            counts[f"{name}_shown"] = axis.get_visible()
        out.append({"axes": k, **counts})
    del texts
    return out


def figure_record(fig: Any) -> dict[str, Any]:
    """The record of a matplotlib figure (drawn here): size, texts, legends, fields."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    texts = _text_boxes(fig, renderer)
    labelled, entries = _legends(fig)
    w, h = fig.canvas.get_width_height()
    return {
        "size": [int(w), int(h)],
        "texts": texts,
        "labelled": labelled,
        "legend": entries,
        "fields": list(_FIELDS.get(fig, [])) + _mapped(fig),
        "axes": _axes_ticks(fig, texts),
    }


def write_record(fig: Any, png: str | Path, bbox: Any = None) -> Path:
    """Write :func:`figure_record` of ``fig`` as ``png`` with the suffix ``.json``.

    ``bbox`` (a pixel box, the saved part of a figure saved with a tight box) moves the
    text boxes into the saved picture's pixels."""
    rec = figure_record(fig)
    if bbox is not None:
        x0, y0 = float(bbox[0]), float(bbox[1])
        for t in rec["texts"]:
            b = t["box"]
            t["box"] = [b[0] - x0, b[1] - y0, b[2] - x0, b[3] - y0]
        rec["size"] = [int(round(bbox[2] - bbox[0])), int(round(bbox[3] - bbox[1]))]
    path = Path(png).with_suffix(".json")
    path.write_text(json.dumps(rec, indent=1, ensure_ascii=False))
    return path


def _overlap(a: list[float], b: list[float], tol: float) -> bool:
    return min(a[2], b[2]) - max(a[0], b[0]) > tol and min(a[3], b[3]) - max(a[1], b[1]) > tol


def check_record(rec: dict[str, Any], max_saturated: float = MAX_SATURATED) -> list[str]:
    """What is wrong with a figure (its :func:`figure_record`): a field saturated over more
    than ``max_saturated`` of its area without saying so, overlapping texts, a text outside
    the picture, a labelled artist without a legend entry, a shown axis without tick
    labels.  An empty list: nothing."""
    bad = []
    for f in rec["fields"]:
        if f["saturated_share"] > max_saturated and not f["stated"]:
            bad.append(f"{f['label']!r}: {100 * f['saturated_share']:.1f} % saturated, unstated")
    texts = rec["texts"]
    for i, a in enumerate(texts):
        for b in texts[i + 1 :]:
            if _overlap(a["box"], b["box"], OVERLAP_TOLERANCE):
                bad.append(f"texts overlap: {a['text']!r} ({a['role']}) and {b['text']!r}")
    w, h = rec["size"]
    for t in texts:
        x0, y0, x1, y1 = t["box"]
        if x0 < 0 or y0 < 0 or x1 > w or y1 > h:
            bad.append(f"text outside the picture: {t['text']!r}")
    missing = sorted(set(rec["labelled"]) - set(rec["legend"]))
    bad += [f"labelled without a legend entry: {m!r}" for m in missing]
    for a in rec["axes"]:
        for name in ("x", "y"):
            if a[f"{name}_shown"] and a[name] < 2:
                bad.append(f"axes {a['axes']}: {a[name]} tick label(s) on {name}")
    return bad


def check_png(png: str | Path, max_saturated: float = MAX_SATURATED) -> list[str]:
    """:func:`check_record` of the record written beside ``png`` (missing: one defect)."""
    path = Path(png).with_suffix(".json")
    if not path.is_file():
        return [f"{Path(png).name}: no figure record {path.name}"]
    return check_record(json.loads(path.read_text()), max_saturated)
