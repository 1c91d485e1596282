"""Collective helpers of the PDAS set logic: scalar reductions over the slave nodes of all
ranks, a distributed order statistic and the exchange of surface points between
neighbouring ranks (docs/theory/pdas.md#distributed-set-logic).

The set decisions of the PDAS are taken node by node on the rank that owns the slave
node; what they need of the other ranks is a few numbers (counts, maxima, norms) or, for
the cold start, the points of neighbouring ranks near this rank's surface.  Nothing here
holds an array whose length is the global number of slave nodes.  ``comm = None`` means
serial (no communication).
"""

from __future__ import annotations

import hashlib
import pickle
from collections.abc import Callable
from dataclasses import dataclass, field

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

__all__ = [
    "TRAFFIC",
    "Traffic",
    "gather_rows",
    "global_any",
    "global_count",
    "global_dot",
    "global_first",
    "global_kth",
    "global_max",
    "global_min",
    "global_sum",
    "global_vsum",
    "neighbour_points",
    "set_signature",
]

#: Below this many candidates a selection gathers them (its size then does not depend on
#: the number of slave nodes).
GATHER_BELOW = 64


@dataclass
class Traffic:
    """What this rank exchanged through these helpers (bytes of the payload: what it
    contributes, and what it receives; reset it before a measurement).  ``largest``
    holds the largest message received per kind: ``"reduce"`` (reductions and
    one-value-per-rank gathers), ``"rows"`` (:func:`gather_rows`), ``"neighbour"``
    (:func:`neighbour_points`)."""

    calls: int = 0
    sent: int = 0
    received: int = 0
    largest: dict = field(default_factory=dict)

    def add(self, sent: int, received: int, kind: str = "reduce") -> None:
        """Count one exchange."""
        self.calls += 1
        self.sent += int(sent)
        self.received += int(received)
        self.largest[kind] = max(self.largest.get(kind, 0), int(received))

    def reset(self) -> None:
        """Forget everything counted."""
        self.calls = self.sent = self.received = 0
        self.largest = {}


#: The traffic of this process (benchmarks/bench_set_comm.py reads it).
TRAFFIC = Traffic()


def _nbytes(obj: object) -> int:
    """Payload of a message: the bytes of the arrays, else of the pickled object."""
    if isinstance(obj, np.ndarray):
        return obj.nbytes
    if isinstance(obj, (tuple, list)):
        return sum(_nbytes(o) for o in obj)
    return len(pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL))


def _allreduce(comm: MPI.Comm, x: object, op: MPI.Op) -> object:
    out = comm.allreduce(x, op=op)
    TRAFFIC.add(_nbytes(x), _nbytes(out))
    return out


def _allgather(comm: MPI.Comm, x: object, kind: str = "reduce") -> list:
    out = comm.allgather(x)
    TRAFFIC.add(_nbytes(x), sum(_nbytes(o) for o in out), kind)
    return out


def global_sum(comm: MPI.Comm | None, x: float) -> float:
    """Sum of ``x`` over the ranks."""
    return x if comm is None or comm.size == 1 else _allreduce(comm, x, MPI.SUM)


def global_vsum(comm: MPI.Comm | None, v: npt.NDArray) -> npt.NDArray:
    """Entry-wise sum of the (same-shape) arrays ``v`` over the ranks."""
    return v if comm is None or comm.size == 1 else _allreduce(comm, v, MPI.SUM)


def global_op(comm: MPI.Comm | None, x: object, op: MPI.Op) -> object:
    """``x`` reduced by ``op`` over the ranks (e.g. a timing, ``MPI.MAX``)."""
    return x if comm is None or comm.size == 1 else _allreduce(comm, x, op)


def gather_rows(comm: MPI.Comm | None, *arrays: npt.NDArray) -> list[npt.NDArray]:
    """Each array's rows of all ranks, rank after rank: for exchanges whose size is what
    the ranks hold (e.g. the rows of a low-rank update), never the slave count."""
    if comm is None or comm.size == 1:
        return list(arrays)
    parts = _allgather(comm, arrays, "rows")
    return [np.concatenate([p[i] for p in parts], axis=0) for i in range(len(arrays))]


def global_count(comm: MPI.Comm | None, mask: npt.NDArray[np.bool_]) -> int:
    """Number of ``True`` entries of ``mask`` over the ranks."""
    return int(global_sum(comm, int(np.count_nonzero(mask))))


def global_any(comm: MPI.Comm | None, mask: npt.NDArray[np.bool_] | bool) -> bool:
    """Whether any rank has a ``True`` entry in ``mask``."""
    local = bool(np.any(mask))
    return local if comm is None or comm.size == 1 else bool(_allreduce(comm, local, MPI.LOR))


def global_max(comm: MPI.Comm | None, x: npt.NDArray, default: float = -np.inf) -> float:
    """Largest entry of ``x`` over the ranks (``default`` where a rank has none)."""
    local = float(x.max()) if x.size else default
    return local if comm is None or comm.size == 1 else _allreduce(comm, local, MPI.MAX)


def global_min(comm: MPI.Comm | None, x: npt.NDArray, default: float = np.inf) -> float:
    """Smallest entry of ``x`` over the ranks (``default`` where a rank has none)."""
    local = float(x.min()) if x.size else default
    return local if comm is None or comm.size == 1 else _allreduce(comm, local, MPI.MIN)


def global_dot(comm: MPI.Comm | None, a: npt.NDArray, b: npt.NDArray) -> float:
    """``a · b`` over the ranks (the local product as NumPy forms it)."""
    return global_sum(comm, float(a @ b))


def _pivot(comm: MPI.Comm, cand: npt.NDArray[np.float64]) -> float:
    """A candidate value near the global median: the count-weighted median of the ranks'
    local medians (one value and one count per rank)."""
    med = float(cand[(cand.size - 1) // 2]) if cand.size else 0.0
    pairs = np.array(_allgather(comm, (med, cand.size)), dtype=float)
    pairs = pairs[pairs[:, 1] > 0]
    order = np.argsort(pairs[:, 0], kind="stable")
    cum = np.cumsum(pairs[order, 1])
    return float(pairs[order, 0][np.searchsorted(cum, 0.5 * cum[-1])])


def global_kth(comm: MPI.Comm | None, values: npt.NDArray, k: int) -> float:
    """The ``k``-th smallest (0-based) of the values of all ranks, exactly.

    Bisection on candidate values (``O(log n)`` rounds of one value per rank), the last
    few candidates gathered (:data:`GATHER_BELOW`).
    """
    v = np.sort(np.asarray(values, dtype=float))
    if comm is None or comm.size == 1:
        return float(v[k])
    lo, hi = -np.inf, np.inf
    while True:
        cand = v[(v > lo) & (v < hi)]
        n = _allreduce(comm, cand.size, MPI.SUM)
        if n <= GATHER_BELOW:
            allc = np.sort(np.concatenate(_allgather(comm, cand)))
            return float(allc[k])
        p = _pivot(comm, cand)
        counts = np.array([(cand < p).sum(), (cand == p).sum()], dtype=np.int64)
        less, eq = (int(c) for c in _allreduce(comm, counts, MPI.SUM))
        if k < less:
            hi = p
        elif k < less + eq:
            return p
        else:
            k -= less + eq
            lo = p


def global_first(
    comm: MPI.Comm | None, values: npt.NDArray, holds: Callable[[float], bool]
) -> float | None:
    """The smallest of the values of all ranks at which the monotone test ``holds``
    (collective: called with the same value on every rank) is true; ``None`` if none."""
    v = np.unique(np.asarray(values, dtype=float))
    if comm is None or comm.size == 1:
        lo_i, hi_i = -1, v.size  # holds(v[hi_i]) (hi_i = size: none known)
        while hi_i - lo_i > 1:
            mid = (lo_i + hi_i) // 2
            if holds(float(v[mid])):
                hi_i = mid
            else:
                lo_i = mid
        return float(v[hi_i]) if hi_i < v.size else None
    lo, hi, found = -np.inf, np.inf, None
    while True:
        cand = v[(v > lo) & (v < hi)]
        if _allreduce(comm, cand.size, MPI.SUM) == 0:
            return found
        p = _pivot(comm, cand)
        if holds(p):
            hi, found = p, p
        else:
            lo = p


def set_signature(comm: MPI.Comm | None, parts: tuple[bytes, ...]) -> bytes:
    """A fingerprint of sets held in parts on every rank: the SHA-256 of this rank's
    ``parts`` (and its rank), combined over the ranks by exclusive or (four words)."""
    h = hashlib.sha256()
    h.update(int(comm.rank if comm is not None else 0).to_bytes(4, "little"))
    for p in parts:
        h.update(len(p).to_bytes(8, "little"))
        h.update(p)
    words = np.frombuffer(h.digest(), dtype=np.uint64).copy()
    if comm is not None and comm.size > 1:
        out = np.zeros_like(words)
        comm.Allreduce(words, out, op=MPI.BXOR)
        TRAFFIC.add(words.nbytes, out.nbytes)
        words = out
    return words.tobytes()


def neighbour_points(
    comm: MPI.Comm | None,
    points: npt.NDArray[np.float64],
    data: npt.NDArray[np.float64],
    reach: float,
    targets: npt.NDArray[np.float64],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The ``points`` (with one value of ``data`` each) of every rank that lie within
    ``reach`` of the bounding box of some rank's ``targets``, delivered to that rank
    (this rank's own points included).

    Each rank sends its boxes' corners to all (two points per rank), then its points
    only to the ranks whose box, widened by ``reach``, holds them: the exchange is
    between neighbours on the surface.
    """
    if comm is None or comm.size == 1:
        return points, data
    gdim = points.shape[1] if points.ndim == 2 else targets.shape[1]
    box = (
        np.concatenate([targets.min(axis=0), targets.max(axis=0)])
        if targets.size
        else np.concatenate([np.full(gdim, np.inf), np.full(gdim, -np.inf)])
    )
    boxes = np.array(_allgather(comm, box)).reshape(comm.size, 2, gdim)
    send = []
    for r in range(comm.size):
        lo, hi = boxes[r, 0] - reach, boxes[r, 1] + reach
        near = np.all((points >= lo) & (points <= hi), axis=1) if points.size else np.zeros(0, bool)
        send.append((points[near], data[near]))
    got = comm.alltoall(send)
    TRAFFIC.add(sum(_nbytes(x) for x in send), sum(_nbytes(x) for x in got), "neighbour")
    pts = np.concatenate([g[0].reshape(-1, gdim) for g in got], axis=0)
    dat = np.concatenate([g[1] for g in got], axis=0)
    return pts, dat
