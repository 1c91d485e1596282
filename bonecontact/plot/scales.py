"""Numbers for pictures: nice numbers, colour ranges chosen from area-weighted quantiles
and what they saturate.

A colour range saturates the part of the picture whose value lies outside it; a figure
fit for a paper saturates at most :data:`MAX_SATURATED` of its area unless it says so.
:func:`auto_range` picks the top (and bottom) of the range at a nice number above the
area quantile that leaves ``saturated`` of the area out, and states the clip.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

#: Largest share of the area a colour range may saturate without saying so.
MAX_SATURATED = 0.05
#: Mantissas of the nice numbers (1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 8 times a power of ten).
NICE = (1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0)


def nice_ceil(x: float) -> float:
    """The smallest nice number (:data:`NICE` × 10^k) ≥ ``x`` (``x ≤ 0``: −nice_floor(−x))."""
    if x == 0 or not math.isfinite(x):
        return float(x)
    if x < 0:
        return -nice_floor(-x)
    e = math.floor(math.log10(x))
    m = x / 10**e
    return float(next(n for n in NICE if n >= m * (1 - 1e-12)) * 10**e)


def nice_floor(x: float) -> float:
    """The largest nice number ≤ ``x`` (``x ≤ 0``: −nice_ceil(−x))."""
    if x == 0 or not math.isfinite(x):
        return float(x)
    if x < 0:
        return -nice_ceil(-x)
    e = math.floor(math.log10(x))
    m = x / 10**e
    return float(max(n for n in NICE if n <= m * (1 + 1e-12)) * 10**e)


def nice_factor(x: float) -> float:
    """A deformation scale rounded down to 1, 2 or 5 × 10^k (``23.6 → 20``)."""
    if not x > 0 or not math.isfinite(x):
        raise ValueError(f"nice_factor: the factor must be positive and finite, not {x!r}")
    e = math.floor(math.log10(x))
    return float(max(n for n in (1.0, 2.0, 5.0, 10.0) if n <= x / 10**e * (1 + 1e-12)) * 10**e)


def weighted_quantile(values: npt.ArrayLike, weights: npt.ArrayLike | None, q: float) -> float:
    """The value below which the share ``q`` of the total weight lies."""
    v = np.asarray(values, dtype=np.float64).ravel()
    w = np.ones_like(v) if weights is None else np.asarray(weights, dtype=np.float64).ravel()
    order = np.argsort(v)
    cdf = np.cumsum(w[order]) / w.sum()
    return float(v[order][min(int(np.searchsorted(cdf, q)), len(v) - 1)])


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
        Share of the area (weight) outside the range.
    data_min
        The smallest value of the data (``< vmin`` when clipped below).
    """

    vmin: float
    vmax: float
    data_max: float
    clipped_fraction: float
    data_min: float = -math.inf
    log: bool = False

    def norm(self) -> Any:
        """The matplotlib norm of the range (logarithmic when ``log``)."""
        from matplotlib.colors import LogNorm, Normalize

        return (LogNorm if self.log else Normalize)(self.vmin, self.vmax)

    @property
    def clipped(self) -> bool:
        """Whether some values lie above the range."""
        return self.data_max > self.vmax

    @property
    def clipped_below(self) -> bool:
        """Whether some values lie below the range."""
        return self.data_min < self.vmin

    @property
    def extend(self) -> str:
        """matplotlib's ``extend`` of a colour bar: which ends are clipped."""
        return {(1, 1): "both", (1, 0): "max", (0, 1): "min"}.get(
            (int(self.clipped), int(self.clipped_below)), "neither"
        )

    def note(self, unit: str, fmt: str = ".3g") -> str:
        """``"colour scale clipped at 12 MPa (max 53 MPa, 0.5 % of the area above)"`` or ``""``."""
        if not self.clipped:
            return ""
        u = f" {unit}" if unit else ""  # "": a dimensionless quantity
        return (
            f"colour scale clipped at {self.vmax:{fmt}}{u} (max {self.data_max:{fmt}}{u}, "
            f"{100 * self.clipped_fraction:.2g} % of the area above)"
        )

    def bar_label(self, label: str, unit: str = "") -> str:
        """The colour-bar label: ``label``, and under it ``"clipped at 2 (max 5.48)"`` when
        the range clips (in the bar's unit, which ``label`` states)."""
        notes = []
        if self.clipped:
            notes.append(f"clipped at {self.vmax:.3g} (max {self.data_max:.3g})")
        if self.clipped_below:
            notes.append(f"clipped at {self.vmin:.3g} (min {self.data_min:.3g})")
        del unit  # the unit is in ``label``
        return "\n".join([label, *notes])


def color_range(
    values: npt.ArrayLike,
    upper: float = 99.0,
    lower: float | None = 0.0,
    weights: npt.ArrayLike | None = None,
) -> ColorRange:
    """A colour range from percentiles of ``values`` (``lower = None``: from 0).

    ``weights`` (cell areas) make the percentiles those of the area, so that many small
    cells of a thin layer do not take the whole range.  :func:`auto_range` picks the
    percentiles itself.
    """
    v = np.asarray(values, dtype=np.float64).ravel()
    w = np.ones_like(v) if weights is None else np.asarray(weights, dtype=np.float64).ravel()
    vmax = weighted_quantile(v, w, upper / 100.0)
    vmin = 0.0 if lower is None else weighted_quantile(v, w, lower / 100.0)
    above = float(w[v > vmax].sum() / w.sum())
    return ColorRange(vmin, vmax, float(v.max()), above, float(v.min()))


def auto_range(
    values: npt.ArrayLike,
    weights: npt.ArrayLike | None = None,
    *,
    saturated: float = 0.02,
    zero: bool | None = None,
    clim: tuple[float | None, float | None] | None = None,
    log: bool = False,
) -> ColorRange:
    """A colour range that saturates at most ``saturated`` of the area, at nice numbers.

    The top is the data's maximum unless that is more than 1.25 times the area quantile
    ``1 − saturated``; then it is the nice number (:func:`nice_ceil`) above that quantile
    (so the clipped share is at most ``saturated``).  The bottom likewise, or 0.

    Parameters
    ----------
    values, weights
        The displayed values and their areas (volumes, lumped nodal measures).
    saturated
        Target share of the area outside the range (≤ :data:`MAX_SATURATED`).
    zero
        Start the range at 0 (``None``: when the data are non-negative).
    clim
        A fixed bottom and/or top instead (``None`` entries chosen as above).
    log
        A logarithmic range: the bottom is the nice number below the area quantile
        ``saturated`` of the positive values, at most three decades below the top (for
        data spanning decades, e.g. the stress of cortex and cancellous bone).

    Returns
    -------
    ColorRange
        With the share of the weight outside the range.
    """
    v = np.asarray(values, dtype=np.float64).ravel()
    w = np.ones_like(v) if weights is None else np.asarray(weights, dtype=np.float64).ravel()
    lo_d, hi_d = float(v.min()), float(v.max())
    zero = lo_d >= 0 if zero is None else zero
    fixed = clim or (None, None)
    hi = fixed[1] if fixed[1] is not None else _top(v, w, saturated, hi_d, lo_d)
    if fixed[0] is not None:
        lo = fixed[0]
    elif log:
        pos = v > 0
        q = weighted_quantile(v[pos], w[pos], saturated) if pos.any() else 1.0
        lo = max(nice_floor(q), nice_floor(hi / 1e3))  # at most three decades
    elif zero:
        lo = min(0.0, lo_d)
    else:
        lo = -_top(-v, w, saturated, -lo_d, -hi_d)
    if hi <= lo:
        hi = lo + (abs(lo) or 1.0)
    out = float(w[(v > hi) | (v < lo)].sum() / w.sum())
    return ColorRange(float(lo), float(hi), hi_d, out, lo_d, log)


def _top(v: np.ndarray, w: np.ndarray, saturated: float, hi_d: float, lo_d: float) -> float:
    """The top of a range over ``v`` that leaves out at most ``saturated`` of ``w``."""
    q = weighted_quantile(v, w, 1.0 - saturated)
    span = hi_d - min(lo_d, 0.0) if hi_d > 0 else hi_d - lo_d
    if hi_d - q <= 0.25 * max(span, 1e-300) or q >= hi_d:
        return hi_d
    top = nice_ceil(q) if q > 0 else q
    return hi_d if top >= hi_d else top
