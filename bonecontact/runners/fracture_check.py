"""The initiation check of a mechanics scene with ``[fracture]`` (docs/scene_format.md#fracture).

After every recorded state the risk field of :func:`bonecontact.fracture.risk_field`
(docs/theory/fracture.md#initiation-risk) is evaluated from the solved displacement with each
cell's material strengths; it is written with the fields (``fracture_risk``), its maximum
goes to ``history.csv`` and the largest over the run, with the time it was reached and the
first time the risk reached 1 (initiation), to ``summary.json``.
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

import numpy as np
from dolfinx import fem

from bonecontact.fracture import RiskMaximum, risk_field
from bonecontact.mechanics.model import Mechanics
from bonecontact.scene import Scene

__all__ = ["FRACTURE_HISTORY_COLUMNS", "FractureMonitor", "fracture_history_columns"]

#: history.csv columns of a 2D scene with ``[fracture]``: the largest risk of the state
#: and the midpoint of its cell (m); a 3D scene adds ``max_risk_z``.
FRACTURE_HISTORY_COLUMNS = ("max_risk", "max_risk_x", "max_risk_y")


def fracture_history_columns(dim: int) -> tuple[str, ...]:
    """The history.csv columns of the fracture check of a ``dim``-dimensional scene."""
    return FRACTURE_HISTORY_COLUMNS + (("max_risk_z",) if dim == 3 else ())


def _cell_strengths(scene: Scene, model: Mechanics, tag: dict[str, int], key: str) -> np.ndarray:
    """``key`` (``sigma_t`` or ``sigma_c``) of every owned cell, from its material (NaN where
    the strength is not needed and not given)."""
    n = model.mesh.topology.index_map(model.mesh.topology.dim).size_local
    out = np.full(n, np.nan)
    for spec in scene.materials:
        value = spec.strengths.get(key, np.nan)
        for region in spec.regions:
            cells = model.cells([tag[region]])
            out[cells[cells < n]] = value
    return out


class FractureMonitor:
    """Risk field and its maxima over a run (collective ``update``)."""

    def __init__(self, scene: Scene, model: Mechanics, u: fem.Function, tag: dict[str, int]):
        self.model, self.u = model, u
        self.criterion = scene.fracture.criterion
        self.sigma_t = _cell_strengths(scene, model, tag, "sigma_t")
        self.sigma_c = (
            _cell_strengths(scene, model, tag, "sigma_c")
            if self.criterion == "tension_compression"
            else None
        )
        self.risk = fem.Function(fem.functionspace(model.mesh, ("DG", 0)), name="fracture_risk")
        self.current: Any = None
        self.peak: tuple[Any, float, int] | None = None  # (RiskMaximum, time, step)
        self.initiation: tuple[float, int] | None = None

    def update(self, step: int, t: float) -> list[float]:
        """Evaluate the risk of the current state; the history.csv values."""
        f, mx = risk_field(self.model, self.u, self.sigma_t, self.sigma_c, self.criterion)
        self.risk.x.array[:] = f.x.array
        self.current = mx
        if self.peak is None or mx.value > self.peak[0].value:
            self.peak = (mx, t, step)
        if self.initiation is None and mx.value >= 1.0:
            self.initiation = (t, step)
        return [mx.value, *mx.location]

    def checkpoint_state(self) -> dict[str, Any]:
        """The maxima so far, for a restart checkpoint's meta.json: the largest risk
        (with its time and step) and the initiation (time, step)."""
        peak = None
        if self.peak is not None:
            mx, t, step = self.peak
            peak = {"risk": asdict(mx), "time": t, "step": step}
        return {"peak": peak, "initiation": self.initiation}

    def restore(self, state: dict[str, Any]) -> None:
        """Continue from :meth:`checkpoint_state` (a restarted run)."""
        peak = state.get("peak")
        if peak is not None:
            r = peak["risk"]
            direction = r["crack_direction"]
            mx = RiskMaximum(
                value=float(r["value"]),
                location=tuple(r["location"]),
                crack_direction=None if direction is None else tuple(direction),
                mode=str(r["mode"]),
                crack_normal=tuple(r["crack_normal"]),
            )
            self.peak = (mx, float(peak["time"]), int(peak["step"]))
        ini = state.get("initiation")
        self.initiation = None if ini is None else (float(ini[0]), int(ini[1]))

    def summary(self) -> dict[str, Any]:
        """The ``fracture`` entry of summary.json."""
        info: dict[str, Any] = {"criterion": self.criterion}
        if self.peak is None:
            return info
        mx, t, step = self.peak
        info.update(
            max_risk=mx.value,
            location=list(mx.location),
            time=t,
            step=step,
            mode=mx.mode,
            crack_direction=None if mx.crack_direction is None else list(mx.crack_direction),
            crack_normal=list(mx.crack_normal),
            initiated=self.initiation is not None,
            initiation_time=None if self.initiation is None else self.initiation[0],
        )
        return info
