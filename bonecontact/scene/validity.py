"""Validity of a computed result: the strain measure of a run against the small-strain limit.

The model is linear-elastic with the linear (small) strain ``ε = sym ∇u``.  Its error
against a finite-strain measure is the neglected quadratic term ``½ ∇uᵀ∇u``: for a stretch
``ε`` the Green-Lagrange strain is ``ε + ε²/2``, a relative error of ``ε/2``.  At
:data:`~bonecontact.scene.checks.SMALL_STRAIN_LIMIT` (10 %) that error is 5 %, below the
scatter of the moduli of bone and cartilage the model is fed with; beyond it the error grows
with the strain and a result is no longer an answer of the model (docs/scene_format.md,
"Validity of the model").

The **strain measure** of a run (:class:`StrainMonitor`) is, at each recorded state, the
largest absolute principal strain exceeded in :data:`VOLUME_FRACTION` (1 %) of the volume of
each material, maximised over the materials and the states.  A cell maximum is not used: at a
re-entrant corner or at the edge of a contact patch the elastic strain is singular, so the
largest cell value grows without bound as the mesh is refined, and a few contact nodes
decide it; a fixed volume fraction of each material converges with the mesh, and taking it
per material keeps a thin layer (cartilage) from being averaged away by the bone next to it.
The cell maximum is still reported (``max_strain``).

:func:`judge_run` turns a converged run whose measure exceeds the limit into status
``"invalid"`` unless the scene sets ``[analysis] allow_large_strain = true``.

Everything here is collective on the mesh's communicator and gives the same answer on every
rank.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem

from bonecontact.scene.checks import SMALL_STRAIN_LIMIT
from bonecontact.scene.spec import Scene

__all__ = [
    "SMALL_STRAIN_LIMIT",
    "VOLUME_FRACTION",
    "StrainMonitor",
    "judge_run",
    "large_strain_allowed",
    "material_cells",
    "principal_strains",
    "volume_quantile",
]

#: The measure ignores the most strained 1 % of each material's volume.
VOLUME_FRACTION = 0.01
#: cells whose strains are evaluated at once (bounds the packed coefficients and copies)
CHUNK_CELLS = 16384
#: Relative precision of the quantile's bisection.
_BISECTION_RTOL = 1e-12


def volume_quantile(
    values: npt.ArrayLike, volumes: npt.ArrayLike, fraction: float, comm: MPI.Comm
) -> float:
    """The smallest ``s`` such that the cells with a value above ``s`` hold at most
    ``fraction`` of the total volume (collective; each rank passes its owned cells).

    A bisection on ``s`` whose every step sums the volume above ``s`` over all ranks, so no
    rank gathers the cells of another.  ``0`` for an empty set or when at most ``fraction``
    of the volume has a positive value.

    Parameters
    ----------
    values
        Non-negative cell values (owned cells of this rank).
    volumes
        The cells' volumes (areas in 2D).
    fraction
        The volume fraction allowed above the result, in ``[0, 1)``.
    comm
        The communicator over which the cells are distributed.
    """
    v = np.asarray(values, dtype=np.float64)
    w = np.asarray(volumes, dtype=np.float64)
    total = comm.allreduce(float(w.sum()), op=MPI.SUM)
    hi = comm.allreduce(float(v.max()) if len(v) else 0.0, op=MPI.MAX)
    allowed = fraction * total

    def above(s: float) -> float:
        return comm.allreduce(float(w[v > s].sum()), op=MPI.SUM)

    lo = 0.0
    if total <= 0.0 or hi <= 0.0 or above(lo) <= allowed:
        return 0.0
    while hi - lo > _BISECTION_RTOL * hi:  # invariant: above(lo) > allowed >= above(hi)
        mid = 0.5 * (lo + hi)
        if above(mid) > allowed:
            lo = mid
        else:
            hi = mid
    return hi


def principal_strains(eps: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The largest absolute principal value of each symmetric tensor of ``eps`` (n, d, d)."""
    if len(eps) == 0:
        return np.zeros(0)
    return np.abs(np.linalg.eigvalsh(eps)).max(axis=1)


def material_cells(scene: Scene, cell_tags: Any, groups: Mapping[str, tuple[int, int]]) -> dict:
    """Material name → local indices of its cells (owned and ghost) on this rank."""
    out = {}
    for m in scene.materials:
        tags = [groups[r][1] for r in m.regions if r in groups]
        out[m.name] = np.sort(cell_tags.indices[np.isin(cell_tags.values, tags)])
    return out


class StrainMonitor:
    """The strain measure of a displacement field over a run (see the module's text).

    Parameters
    ----------
    u
        The displacement (P1 here, so the strain is constant in each cell and the cell
        value is exact).
    regions
        Material name → local cell indices (:func:`material_cells`); ``None``: the whole
        mesh as one material.
    """

    def __init__(self, u: fem.Function, regions: Mapping[str, npt.ArrayLike] | None = None):
        mesh = u.function_space.mesh
        gdim, tdim = mesh.geometry.dim, mesh.topology.dim
        self._space = fem.functionspace(mesh, ("DG", 0, (gdim, gdim)))
        self._eps: fem.Function | None = None  # the cell strains (made by update)
        self._expr = fem.Expression(ufl.sym(ufl.grad(u)), self._space.element.interpolation_points)
        n_owned = mesh.topology.index_map(tdim).size_local
        self._comm = mesh.comm
        self._gdim = gdim
        self._volume = _cell_volumes(mesh)[:n_owned]
        every = np.arange(n_owned, dtype=np.int32)
        regions = {"all": every} if regions is None else regions
        self._regions = {k: np.asarray(c)[np.asarray(c) < n_owned] for k, c in regions.items()}
        self.max_strain = 0.0
        self.measure = 0.0
        self.measure_material: str | None = None
        self.above_limit = dict.fromkeys(self._regions, 0.0)

    def update(self) -> float:
        """Evaluate the current state; return the strain measure so far (collective)."""
        if self._eps is None:
            self._eps = fem.Function(self._space)
        n = len(self._volume)
        # in chunks of cells: the expression's coefficients and LAPACK's copies of a chunk
        # at a time (at once: +220 MiB per rank at 1M dofs on 2 ranks, issue 28)
        for start in range(0, n, CHUNK_CELLS):
            cells = np.arange(start, min(start + CHUNK_CELLS, n), dtype=np.int32)
            self._eps.interpolate(self._expr, cells0=cells)
        eps = self._eps.x.array.reshape(-1, self._gdim, self._gdim)[:n]
        e = np.empty(n)
        for start in range(0, n, CHUNK_CELLS):
            e[start : start + CHUNK_CELLS] = principal_strains(eps[start : start + CHUNK_CELLS])
        local = float(e.max()) if len(e) else 0.0
        self.max_strain = max(self.max_strain, self._comm.allreduce(local, op=MPI.MAX))
        for name, cells in self._regions.items():
            q = volume_quantile(e[cells], self._volume[cells], VOLUME_FRACTION, self._comm)
            if self.measure_material is None or q > self.measure:
                self.measure, self.measure_material = q, name
            share = _volume_share(e[cells] > SMALL_STRAIN_LIMIT, self._volume[cells], self._comm)
            self.above_limit[name] = max(self.above_limit[name], share)
        return self.measure

    def release(self) -> None:
        """Free the cell strains (d² values per cell) until the next :meth:`update`."""
        self._eps = None

    def summary(self) -> dict[str, Any]:
        """The summary.json entries: ``max_strain`` (the largest cell value),
        ``strain_measure`` (the volume quantile), ``strain_measure_material``,
        ``volume_above_strain_limit`` (material → the largest share of its volume strained
        beyond the limit at one state), ``small_strain_limit`` and ``small_strain_valid``."""
        return {
            "max_strain": self.max_strain,
            "strain_measure": self.measure,
            "strain_measure_material": self.measure_material,
            "volume_above_strain_limit": dict(self.above_limit),
            "small_strain_limit": SMALL_STRAIN_LIMIT,
            "small_strain_valid": bool(self.measure <= SMALL_STRAIN_LIMIT),
        }


def _volume_share(
    mask: npt.NDArray[np.bool_], volumes: npt.NDArray[np.float64], comm: MPI.Comm
) -> float:
    """The share of the total volume of the cells where ``mask`` holds (collective)."""
    part = np.array([volumes[mask].sum(), volumes.sum()])
    total = np.zeros(2)
    comm.Allreduce(part, total, op=MPI.SUM)
    return float(total[0] / total[1]) if total[1] > 0 else 0.0


def _cell_volumes(mesh: Any) -> npt.NDArray[np.float64]:
    """The volume (area in 2D) of each local cell."""
    V0 = fem.functionspace(mesh, ("DG", 0))
    vol = fem.Function(V0)
    vol.interpolate(fem.Expression(ufl.CellVolume(mesh), V0.element.interpolation_points))
    return vol.x.array.copy()


def large_strain_allowed(scene: Scene) -> bool:
    """``[analysis] allow_large_strain`` of the scene (``False`` when absent)."""
    return bool(getattr(scene.analysis, "allow_large_strain", False))


def judge_run(
    scene: Scene, status: str, message: str | None, info: Mapping[str, Any]
) -> tuple[str, str | None]:
    """The status of a finished run given its strain entries (``info`` from
    :meth:`StrainMonitor.summary`).

    A ``"converged"`` run whose strain measure exceeds :data:`SMALL_STRAIN_LIMIT` becomes
    ``"invalid"`` with a message saying why, unless :func:`large_strain_allowed`; any other
    status is kept.  Returns ``(status, message)``.
    """
    if status != "converged" or info.get("small_strain_valid", True):
        return status, message
    if large_strain_allowed(scene):
        return status, message
    where = info.get("strain_measure_material")
    text = (
        f"the strain measure reaches {info['strain_measure']:.3g} "
        f"(principal strain exceeded in {VOLUME_FRACTION:.0%} of the volume of material "
        f'"{where}"; the largest cell value is {info["max_strain"]:.3g}), more than the '
        f"small-strain limit {SMALL_STRAIN_LIMIT:.0%}: the result is outside the validity of "
        "the linear model (check the units of the loads, the moduli and the mesh; set "
        "[analysis] allow_large_strain = true only with a stated reason)"
    )
    return "invalid", text
