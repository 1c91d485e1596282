"""Fatigue growth of a 2D crack scene by blocks of load cycles (``[fracture.fatigue]``;
docs/scene_format.md, docs/theory/fracture.md#fatigue).

At the load of the analysis's last step (the peak of the cycle) every evaluation of the
tips is a block end: the Paris rates of the tips' MTS equivalent K, the cycles of the
block just made (:func:`bonecontact.fracture.fatigue.block_cycles` over the ends known so
far), then a stop or the advances of the next block.  The run (:mod:`~.cracks`)
re-meshes the grown crack and solves the same step again.  Nothing here touches a mesh.
The 3D runners share the block history (:class:`FatigueProgress`), the rates and stops,
and the report of a final block that carries a crack through (:func:`final_block`).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Any

import numpy as np
import numpy.typing as npt

from bonecontact.fracture.crack import Crack2D
from bonecontact.fracture.fatigue import ParisLaw, block_cycles
from bonecontact.fracture.propagation import FRACTURE_COLUMNS, IncrementRecord
from bonecontact.scene.spec import FatigueSpec

__all__ = [
    "FATIGUE_COLUMNS",
    "FINAL_BLOCK_SHARE",
    "WAIT_FRACTION",
    "FatigueProgress",
    "FatigueRecord",
    "FinalBlockWarning",
    "block_end",
    "block_shares",
    "bound_to_separation",
    "final_block",
    "final_block_note",
    "final_block_text",
    "growth_stop",
    "growth_weights",
    "paris_law",
    "plain_rows",
    "self_similar_slope",
    "size_from_tip",
    "size_from_vertex",
    "tip_key",
]

#: The columns of fracture.csv of a fatigue run: the crack's, then the cumulative cycles.
FATIGUE_COLUMNS = (*FRACTURE_COLUMNS, "cycles")

#: A tip whose share of a block is below this fraction of Δa_max keeps it for later: its
#: last segment (the integration domain's bound) stays ≥ 0.6 Δa_max.
WAIT_FRACTION = 0.6


@dataclasses.dataclass(frozen=True)
class FatigueRecord(IncrementRecord):
    """A row of fracture.csv of a fatigue run: the tip, then the cycles N to this crack."""

    cycles: float = 0.0

    def row(self) -> tuple:
        return (*super().row(), self.cycles)


@dataclasses.dataclass
class FatigueProgress:
    """The history of the blocks at the peak load (what a checkpoint stores).

    ``growth`` and ``lead_rate`` are the growth of the fastest tip summed over the blocks
    (m) and its da/dN (m/cycle) at every block end, ``cycles`` the cumulative N there,
    ``waiting`` the growth a tip keeps for later ((crack, tip end) -> m), ``status`` the stop
    (``None`` while it runs) and ``bound`` the upper bound of the cycles to separation.
    ``phases`` are the indices of the ends that start a new set of cracks (after a merge)
    and ``slope`` the self-similar d ln(da/dN)/ds of the leading tip at the last merge's
    block start (1/m; 0: unknown; :func:`self_similar_slope`, :meth:`_merging_block`).
    ``shortfall`` is what the blocks shortened before a merge fell short of Δa_max (m; the
    leading tip's growth is blocks × Δa_max less it) and ``shortened`` whether the last
    block was one (the next is then cut where facing tips meet;
    :meth:`bonecontact.runners.cracks.CrackSteps.fit_block`).
    """

    growth: list[float] = dataclasses.field(default_factory=list)
    lead_rate: list[float] = dataclasses.field(default_factory=list)
    cycles: list[float] = dataclasses.field(default_factory=list)
    waiting: dict[TipKey, float] = dataclasses.field(default_factory=dict)
    status: str | None = None
    bound: float | None = None
    phases: list[int] = dataclasses.field(default_factory=lambda: [0])
    slope: float = 0.0
    shortfall: float = 0.0
    shortened: bool = False

    @classmethod
    def from_state(cls, state: dict[str, Any] | None) -> FatigueProgress:
        """From a checkpoint's ``fatigue`` entry (``None``: a fresh history)."""
        if state is None:
            return cls()
        waiting = {_text_key(k): float(v) for k, v in state["waiting"].items()}
        return cls(
            [float(v) for v in state["growth"]],
            [float(v) for v in state["lead_rate"]],
            [float(v) for v in state["cycles"]],
            waiting,
            state["status"],
            state["bound"],
            [int(v) for v in state.get("phases", [0])],
            float(state.get("slope", 0.0)),  # older checkpoints: unknown
            float(state.get("shortfall", 0.0)),  # older checkpoints: no block shortened
            bool(state.get("shortened", False)),
        )

    def state(self) -> dict[str, Any]:
        """The checkpoint's ``fatigue`` entry (JSON)."""
        out = dataclasses.asdict(self)
        out["waiting"] = {_key_text(k): v for k, v in self.waiting.items()}
        return out

    def add_end(self, growth: float, lead_rate: float) -> float:
        """A block end (the fastest tip's summed growth and rate there): its cumulative
        cycles (the last block's by the rule of :func:`block_cycles` over the ends known so
        far, or, if the rate at its end is zero, at its start rate)."""
        self.growth.append(float(growth))
        self.lead_rate.append(float(lead_rate))
        p = self.phases[-1]
        if len(self.growth) == 1:
            block = 0.0
        elif len(self.growth) - 1 == p:  # the block that merged cracks
            block = self._merging_block()
        elif lead_rate > 0:
            block = float(block_cycles(self.growth[p:], self.lead_rate[p:])[-1])
        else:
            block = (self.growth[-1] - self.growth[-2]) / self.lead_rate[-2]
        self.cycles.append((self.cycles[-1] if self.cycles else 0.0) + block)
        return self.cycles[-1]

    def trend_block(self, da: float) -> float:
        """Cycles of a block of ``da`` (m) after the last end, ln(da/dN) continued linearly
        with the slope between the last two ends of the current set of cracks: ∫ ds / r
        = (1 − e^(−g·da)) / (g·r) for a rising rate (slope g > 0); a falling rate, or a
        single end, the last rate da/r (:func:`final_block`'s second estimate)."""
        s, r = self.growth, self.lead_rate
        g = 0.0
        if len(s) - 2 >= self.phases[-1] and r[-2] > 0 and s[-1] > s[-2]:
            g = (math.log(r[-1]) - math.log(r[-2])) / (s[-1] - s[-2])
        if g <= 1e-12 / da:
            return da / r[-1]
        return -math.expm1(-g * da) / (g * r[-1])

    def merged(self, tip_map: dict[TipKey, TipKey], slope: float = 0.0) -> None:
        """Cracks merged at the last block end: the next end starts a new set of cracks
        (:meth:`add_end`); what the far tips kept goes to the merged crack's tips
        (``tip_map``), what the merged-away tips kept is dropped.  ``slope``: the
        self-similar d ln(da/dN)/ds of the leading tip at the merging block's start
        (:func:`self_similar_slope`; 0: unknown), used when that start is the only end of
        its set of cracks (:meth:`_merging_block`)."""
        self.phases.append(len(self.growth))
        self.waiting = {tip_map[t]: v for t, v in self.waiting.items() if t in tip_map}
        self.slope = float(slope)

    def _merging_block(self) -> float:
        """Cycles of the block at whose end cracks merged: ∫ ds / r over it with ln r
        linear, its slope extrapolated from the last two ends before the merge (of one set
        of cracks), or, when the block's start is the only end known, the self-similar
        ``slope`` (:meth:`merged`).  A falling rate, or one end and no positive slope:
        the start rate, constant.  The rate after the merge is another tip's and is not
        used."""
        s, r = self.growth, self.lead_rate
        h, start = s[-1] - s[-2], (self.phases[-2] if len(self.phases) > 1 else 0)
        if r[-2] <= 0:
            return 0.0
        if len(s) - 3 < start:
            g = self.slope
        elif r[-3] > 0:
            g = (math.log(r[-2]) - math.log(r[-3])) / (s[-2] - s[-3])
        else:
            g = 0.0
        if g <= 1e-12 / h:
            return h / r[-2]
        return (1.0 - math.exp(-g * h)) / (g * r[-2])


def self_similar_slope(m: float, size: float) -> float:
    """d ln(da/dN)/ds of a tip whose crack grows self-similarly, K ∝ √ρ: da/dN ∝ ρ^(m/2)
    and ρ grows as the tip does, so (m/2)/ρ (1/m; 0 for ρ ≤ 0).  ``size`` ρ is the
    crack's size seen from the tip (:func:`size_from_tip`, :func:`size_from_vertex`)."""
    return 0.5 * float(m) / float(size) if size > 0 else 0.0


def size_from_tip(crack: Crack2D, end: int) -> float:
    """ρ of a 2D crack seen from its tip at polyline end ``end`` (0 or −1): the distance
    to the crack's other end, half of it for an interior crack (a centre crack's
    half-length, which grows as fast as each tip when both grow alike; the whole distance
    would halve the slope), all of it for an edge crack (its length from the mouth)."""
    end = int(end)
    chord = float(np.linalg.norm(crack.tip(end) - crack.points[-1 - end]))
    return 0.5 * chord if crack.tips == "both" else chord


def size_from_vertex(vertices: npt.ArrayLike, k: int) -> float:
    """ρ of a planar 3D crack seen from front vertex ``k`` of ``vertices`` (N, 3): its
    distance to the mean of the vertices, which grows as the vertex does when the front
    grows self-similarly (a penny's radius; an ellipse's b at the minor axis end, where K
    is largest, where the largest radius a would halve the slope)."""
    V = np.asarray(vertices, dtype=float)
    return float(np.linalg.norm(V[int(k)] - V.mean(axis=0)))


#: A tip of a scene's cracks: (the crack's name, the polyline end 0 or -1).
TipKey = tuple[str, int]


def tip_key(r: IncrementRecord) -> TipKey:
    """The tip of a row: its crack's name and its end."""
    return (r.crack, int(r.tip))


def _key_text(key: TipKey) -> str:
    return f"{key[1]}@{key[0]}"


def _text_key(text: str) -> TipKey:
    """A key of a checkpoint's ``waiting``: ``"<end>@<crack>"`` (older: ``"<end>"``, the
    crack unnamed)."""
    end, _, crack = str(text).partition("@")
    return (crack, int(end))


def paris_law(spec: FatigueSpec) -> ParisLaw:
    """The Paris law of ``[fracture.fatigue]``."""
    return ParisLaw(spec.C, spec.m, spec.delta_K_th, spec.R)


def growth_weights(
    k_eq: npt.ArrayLike, spec: FatigueSpec | None, K_Ic: float | None
) -> npt.NDArray[np.float64]:
    """The growth weights of the front points of a 3D crack (surface and interior runners):
    under fatigue (``spec``) the Paris rates da/dN of ΔK from the peak ``k_eq`` (zero at or
    below ΔK_th), under one load (K_eq/K_eq,max)² at the points with K_eq ≥ K_Ic, else 0.
    The advance of a point is the increment × its weight / the largest weight."""
    k = np.asarray(k_eq, dtype=float)
    if spec is not None:
        return paris_law(spec).rate(k)
    grows = k >= (K_Ic or math.inf)
    return np.where(grows, (k / k.max()) ** 2, 0.0)


def growth_stop(
    k_max: float, lead: float, spec: FatigueSpec | None, K_Ic: float | None, done: int, most: int
) -> str | None:
    """The stop of a growing 3D crack after ``done`` increments (``None``: grow on):
    ``fractured`` under fatigue when the largest K (``k_max``) reaches K_Ic (the crack runs
    unstably), ``arrested`` when the largest weight ``lead`` (:func:`growth_weights`) is 0,
    ``max_blocks`` (fatigue) or ``max_increments`` once ``done`` reaches ``most``."""
    if spec is not None and K_Ic and k_max >= K_Ic:
        return "fractured"
    if lead <= 0.0:
        return "arrested"
    if done >= most:
        return "max_blocks" if spec is not None else "max_increments"
    return None


def _stop(k_eq: np.ndarray, rates: np.ndarray, K_Ic: float | None, blocks: int, most: int) -> str:
    """The stop at this block end (``""``: make a block)."""
    if K_Ic and bool(np.any(k_eq >= K_Ic)):
        return "K_Ic"
    if float(rates.max(initial=0.0)) <= 0.0:
        return "arrested"
    if blocks >= most:
        return "max_blocks"
    return ""


def _as_fatigue(r: IncrementRecord, status: str, cycles: float) -> FatigueRecord:
    fields = {f.name: getattr(r, f.name) for f in dataclasses.fields(IncrementRecord)}
    return FatigueRecord(**(fields | {"status": status, "cycles": cycles}))


def _stopped_rows(
    records: list[IncrementRecord], k_eq: np.ndarray, K_Ic: float | None, stop: str, n: float
) -> list[FatigueRecord]:
    """The rows of a stop: the tips at K_Ic marked ``K_Ic`` (the others ``holds``), every
    tip ``arrested`` or ``max_blocks``."""
    hit = k_eq >= K_Ic if stop == "K_Ic" else np.ones(len(records), dtype=bool)
    return [_as_fatigue(r, stop if h else "holds", n) for r, h in zip(records, hit, strict=True)]


def block_end(
    records: list[IncrementRecord],
    spec: FatigueSpec,
    K_Ic: float | None,
    prog: FatigueProgress | None,
    blocks: int,
) -> tuple[list[FatigueRecord], dict[TipKey, float], str]:
    """One evaluation of the tips after ``blocks`` blocks: the rows, the advance of every
    tip that grows in the next block ((crack, tip end) -> m; the tips of all the cracks
    share one block, the fastest of them growing by Δa_max) and the stop (``""``: go on).

    ``prog`` is ``None`` before the last step (the ramp): only the K_Ic check.  Otherwise
    the rates give the cycles of the block just made (``prog`` updated), then the stop
    (``K_Ic``, ``arrested``, ``max_blocks``) or the advances: each tip's share
    rate/max rate × Δa_max added to what it kept, grown once the sum reaches
    :data:`WAIT_FRACTION` × Δa_max (the fastest tip always).
    """
    k_eq = np.array([r.K_eq for r in records], dtype=float)
    if prog is None:
        stop = "K_Ic" if K_Ic and bool(np.any(k_eq >= K_Ic)) else ""
        if stop:
            return _stopped_rows(records, k_eq, K_Ic, stop, 0.0), {}, stop
        return [_as_fatigue(r, r.status, 0.0) for r in records], {}, ""
    rates = paris_law(spec).rate(k_eq)
    lead = float(rates.max(initial=0.0))
    n = prog.add_end(blocks * spec.da_max - prog.shortfall, lead)
    stop = _stop(k_eq, rates, K_Ic, blocks, spec.max_blocks)
    if stop:
        prog.status = stop
        return _stopped_rows(records, k_eq, K_Ic, stop, n), {}, stop
    grow, prog.waiting = block_shares(records, spec, prog.waiting, spec.da_max)
    rows = [_as_fatigue(r, "grows" if tip_key(r) in grow else "holds", n) for r in records]
    return rows, grow, ""


def block_shares(
    records: list[IncrementRecord],
    spec: FatigueSpec,
    waiting: dict[TipKey, float],
    length: float,
    must: tuple[TipKey, ...] = (),
) -> tuple[dict[TipKey, float], dict[TipKey, float]]:
    """The advances of a block of ``length`` (m; Δa_max, or less before a merge) and what
    the tips keep after it: each tip's share rate/max rate × ``length`` added to what it
    kept (``waiting``), grown once the sum reaches :data:`WAIT_FRACTION` × Δa_max, or
    whatever it is for the tips of ``must``; the others keep their sum."""
    k_eq = np.array([r.K_eq for r in records], dtype=float)
    rates = paris_law(spec).rate(k_eq)
    lead = float(rates.max(initial=0.0))
    share = {
        tip_key(r): waiting.get(tip_key(r), 0.0) + length * float(rt) / lead
        for r, rt in zip(records, rates, strict=True)
    }
    least = WAIT_FRACTION * spec.da_max * (1.0 - 1e-12)
    grow = {t: s for t, s in share.items() if s >= least or (t in must and s > 0)}
    return grow, {t: s for t, s in share.items() if t not in grow and s > 0}


def plain_rows(rows: list[dict[str, Any]]) -> list[IncrementRecord]:
    """Rows of a checkpoint back as records (fatigue rows carry ``cycles``)."""
    return [FatigueRecord(**r) if "cycles" in r else IncrementRecord(**r) for r in rows]


def bound_to_separation(cycles: float, distance: float, rate: float) -> float:
    """An upper bound of the cycles to separation from the last evaluated crack: the tip's
    distance to the surface at its rate there (the rate only grows as the crack does)."""
    return cycles + distance / rate if rate > 0 else math.inf


#: The share of a run's cycles above which its final block — the one that carries the crack
#: through, counted at the rate of its start — is said to set the count (FinalBlockWarning).
FINAL_BLOCK_SHARE = 0.5


class FinalBlockWarning(UserWarning):
    """The final block of a fatigue run that ends ``through`` holds more than
    :data:`FINAL_BLOCK_SHARE` of its cycles: the count is set by that block's
    extrapolation, not by a solved K (summary.json ``fracture.growth.final_block``)."""


def final_block(
    cycles: float, da: float, rate: float, progress: FatigueProgress | None = None
) -> dict[str, float]:
    """The block that carries a crack through the body: ``da`` (m) at the leading rate
    ``rate`` (m/cycle) of its start, the last solved crack; no solve at its end, so its
    cycles da/rate are an extrapolation — too many where K would rise towards the far
    surface, too few (or the crack would arrest) where it falls, as into a compressed
    region.  ``cycles`` are those before it.  Returns its ``cycles``, ``share`` of the
    total, ``da``, ``rate`` and ``cycles_trend``: the block with ln(da/dN) continued from
    the last two solves (:meth:`FatigueProgress.trend_block` of ``progress``, whose last
    end is this start; else da/rate) — fewer cycles where the rate was rising, the same
    where it fell (summary.json ``fracture.growth.final_block``)."""
    n = da / rate
    trend = progress.trend_block(da) if progress is not None else n
    return {
        "cycles": n,
        "share": n / (cycles + n),
        "da": da,
        "rate": rate,
        "cycles_trend": trend,
    }


def final_block_text(block: dict[str, float]) -> str:
    """The FinalBlockWarning's text for ``block`` (:func:`final_block`)."""
    return (
        f"the final block, {block['da']:.3g} m at the leading rate of its start "
        f"({block['rate']:.3g} m/cycle; no solve at its end), holds {100 * block['share']:.0f} % "
        f"of the cycles ({block['cycles']:.4g}; {block['cycles_trend']:.4g} with ln(da/dN) "
        "continued from the last two solves): the count is set by that extrapolation, "
        "not by a solved K; a smaller da_max resolves it, or in 3D [fracture.fatigue] "
        "end_halvings (the blocks before it halved)"
    )


def final_block_note(comm: Any, block: dict[str, float] | None) -> str | None:
    """The run's message when its final block (:func:`final_block`) holds more than
    :data:`FINAL_BLOCK_SHARE` of the cycles, with a FinalBlockWarning on rank 0; else
    ``None``."""
    if block is None or not block["share"] > FINAL_BLOCK_SHARE:
        return None
    text = final_block_text(block)
    if comm.rank == 0:
        warnings.warn(text, FinalBlockWarning, stacklevel=2)
    return text
