"""Cracks of a 2D scene that join, merged into one (``[fracture] joined = "merge"``;
docs/scene_format.md#several-cracks, docs/theory/fracture.md#several-cracks).

After a growth whose grown tips came within the ligament of another crack (status
``joined``), every such tip that faces a tip of the other crack
(:func:`bonecontact.fracture.coalescence.facing_tips`) merges the two cracks into one
named ``"<first>+<second>"`` (the first: the crack of the grown tip), its tips the far
tips of both.  All or nothing: when one joined tip cannot be merged nothing is, and the
reason goes with the stop ``joined``.  Nothing here touches a mesh.
"""

from __future__ import annotations

import dataclasses

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.body import BodyOutline
from bonecontact.fracture.coalescence import facing_tips, far_end, merged_crack
from bonecontact.fracture.crack import Crack2D, crack_gap
from bonecontact.scene.spec import CrackSpec

__all__ = ["Join", "join_cracks"]

#: A tip: (the crack's name, the polyline end 0 or -1).
TipKey = tuple[str, int]


@dataclasses.dataclass
class Join:
    """The cracks after the merges (one spec per crack), the merges made
    (``{"cracks": [first, second], "into": name, "bridge": m}``), where the far tips went
    (old tip -> tip of the merged crack) and, when a joined tip could not be merged, why
    (then ``cracks``/``specs`` are the ones given and nothing is merged)."""

    cracks: list[Crack2D]
    specs: tuple[CrackSpec, ...]
    merges: list[dict] = dataclasses.field(default_factory=list)
    tip_map: dict[TipKey, TipKey] = dataclasses.field(default_factory=dict)
    reason: str = ""


def _why_not(
    cracks: list[Crack2D],
    specs: list[CrackSpec],
    k: int,
    j: int,
    merged: Crack2D,
    body: BodyOutline,
) -> str:
    """Why the merged crack of cracks ``k`` and ``j`` cannot replace them ("" if it can)."""
    if specs[k].coefficient != specs[j].coefficient:
        return (
            f"their faces have different friction coefficients ({specs[k].coefficient:g}, "
            f"{specs[j].coefficient:g})"
        )
    try:
        body.check_crack(merged)
    except ParameterError as exc:
        return f"the merged crack does not lie in the body: {exc}"
    for i, c in enumerate(cracks):
        if i not in (k, j) and crack_gap(merged, c) <= 0.0:
            return f"the merged crack would touch crack {specs[i].name!r}"
    return ""


def join_cracks(
    cracks: list[Crack2D],
    specs: tuple[CrackSpec, ...],
    joined: list[TipKey],
    reach: float,
    min_bridge: float,
    body: BodyOutline,
) -> Join:
    """Merge the cracks of the ``joined`` tips (grown tips within ``reach`` of another
    crack) with the cracks they met, pair by pair in the order of ``joined``; a bridge
    shorter than ``min_bridge`` is closed at its midpoint (:func:`merged_crack`)."""
    out = Join(list(cracks), tuple(specs))
    cur, names = list(cracks), [s.name for s in specs]
    sp = list(specs)
    pending = list(joined)
    while pending:
        name, end = pending.pop(0)
        if name not in names:
            continue  # a tip merged away with its crack
        k = names.index(name)
        tip = cur[k].tip(end)
        near = [(c.distance(tip), j) for j, c in enumerate(cur) if j != k]
        near = [(d, j) for d, j in near if d < reach]
        if not near:
            continue  # it met a tip that an earlier merge closed
        j = min(near)[1]
        end_b, why = facing_tips(cur[k], end, cur[j], reach, min_bridge)
        merged = None
        if not why:
            try:
                merged = merged_crack(cur[k], end, cur[j], end_b, min_bridge)
            except ParameterError as exc:
                why = str(exc).removeprefix("points: ")
        why = why or _why_not(cur, sp, k, j, merged, body)
        if why:
            out.reason = f"tip {end} of crack {name!r} met crack {names[j]!r}: {why}"
            return Join(list(cracks), tuple(specs), reason=out.reason)
        into = f"{name}+{names[j]}"
        gap = float(((cur[j].tip(end_b) - tip) ** 2).sum() ** 0.5)
        out.merges.append({"cracks": [name, names[j]], "into": into, "bridge": gap})
        moved = {(name, far_end(end)): (into, 0), (names[j], far_end(end_b)): (into, -1)}
        out.tip_map = {o: moved.get(n, n) for o, n in out.tip_map.items()} | {
            t: n for t, n in moved.items() if t not in out.tip_map.values()
        }
        pending = [moved.get(t, t) for t in pending]
        lo, hi = min(k, j), max(k, j)
        new = dataclasses.replace(sp[k], name=into, crack=merged)
        cur[lo], sp[lo], names[lo] = merged, new, into
        del cur[hi], sp[hi], names[hi]
    out.cracks, out.specs = cur, tuple(sp)
    return out
