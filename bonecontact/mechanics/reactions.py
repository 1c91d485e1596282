"""Support reactions from the assembled residual (docs/theory/mechanics.md#forces-and-reactions).

After a step the integrator holds the force residual

    r = M a + K u + Kv v − F        (a, v: the scheme's acceleration and velocity),

which vanishes at every free dof (to solver tolerance) and equals the force that the
supports exert at the constrained dofs (and the contact forces at the contact nodes).
The reaction of a ``[[dirichlet]]`` group is the sum of ``r`` over the group's
constrained dofs, per component (with contact, the runner passes ``r`` less the contact
forces: a node on both a support and a slave surface carries a share of the contact
force that is not the support's reaction), and its moment about the origin
``Σ xᵢ × rᵢ`` (reference coordinates).  A dof constrained by several groups (a node
where two supported boundaries meet) counts for the first of them in file order, so the
reactions of all groups add up to the total support force.  Nothing is taken from the
stresses at the boundary.

Balance: since ``K`` and ``Kv`` annihilate rigid translations,
``Σ_groups R + F_total − I_total = −(sum of the contact forces)``, which is zero when the
contact forces are internal between bodies (``I``: total inertial force, dynamic runs).
All sums are over owned dofs, then over the ranks (one reduction per step).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
from dolfinx import fem, la

from bonecontact.mechanics.model import Mechanics

__all__ = ["ForceMoment", "ReactionRecord", "SupportReactions", "moment_components"]


def moment_components(gdim: int) -> tuple[str, ...]:
    """Names of the moment components: ``("mz",)`` in 2D, ``("mx", "my", "mz")`` in 3D."""
    return ("mz",) if gdim == 2 else ("mx", "my", "mz")


@dataclass(frozen=True)
class ForceMoment:
    """A resultant: ``force`` (gdim components; N, N/m in 2D) and ``moment`` about the
    origin (1 component in 2D, N·m/m; 3 in 3D, N·m)."""

    force: npt.NDArray[np.float64]
    moment: npt.NDArray[np.float64]

    def values(self) -> list[float]:
        """Force components, then moment components."""
        return [float(v) for v in np.concatenate([self.force, self.moment])]


@dataclass(frozen=True)
class ReactionRecord:
    """Reactions of one step.

    Attributes
    ----------
    groups
        Reaction of each supported group (file order of first appearance).
    load
        Resultant of the applied loads at the step.
    inertia
        Total inertial force ``Σ M a`` (and its moment); ``None`` outside dynamic runs.
    load_gross
        ``Σ_nodes |F_node|``, the size of the applied loads however they cancel (a
        pressure in a closed cavity has resultant 0): a scale of :meth:`defect`.
    """

    groups: dict[str, ForceMoment]
    load: ForceMoment
    inertia: ForceMoment | None
    load_gross: float = 0.0

    def defect(self) -> float:
        """``|Σ R + F − I|`` relative to the largest of ``|F|``, each ``|R|``, ``|I|`` and
        ``load_gross``: the force balance (zero up to solver tolerance without contact;
        with contact the mismatch of the contact forces between bodies)."""
        total = self.load.force.copy()
        scale = max(float(np.linalg.norm(self.load.force)), self.load_gross)
        for r in self.groups.values():
            total += r.force
            scale = max(scale, float(np.linalg.norm(r.force)))
        if self.inertia is not None:
            total -= self.inertia.force
            scale = max(scale, float(np.linalg.norm(self.inertia.force)))
        return float(np.linalg.norm(total)) / scale if scale > 0.0 else 0.0


def _moment_parts(x: npt.NDArray[np.float64], f: npt.NDArray[np.float64]) -> npt.NDArray:
    """``Σ x × f`` of nodal positions and forces (n, gdim): (1,) in 2D, (3,) in 3D."""
    if x.shape[1] == 2:
        return np.array([np.sum(x[:, 0] * f[:, 1] - x[:, 1] * f[:, 0])])
    return np.cross(x, f).sum(axis=0) if x.size else np.zeros(3)


class SupportReactions:
    """Reaction force and moment of each supported group, per step (collective).

    Parameters
    ----------
    model
        The mechanics model.
    groups
        ``(name, facets, components)`` per supported group, in file order: the local
        facets of the group and the displacement components it fixes.  Entries with the
        same name are merged.
    """

    def __init__(
        self, model: Mechanics, groups: Sequence[tuple[str, npt.NDArray[np.int32], Sequence[int]]]
    ):
        self.model = model
        self.comm = model.mesh.comm
        V = model.V
        self.gdim = model.dim
        self.bs = V.dofmap.index_map_bs
        n_owned = model.num_owned
        self.x = V.tabulate_dof_coordinates()[: n_owned // self.bs, : self.gdim]
        self.names: list[str] = []
        masks: dict[str, npt.NDArray[np.bool_]] = {}
        claimed = np.zeros(n_owned, dtype=bool)
        for name, facets, comps in groups:
            mark = self._owned_mark(facets, comps)
            if name not in masks:
                self.names.append(name)
                masks[name] = np.zeros(n_owned, dtype=bool)
            mine = mark & ~claimed
            masks[name] |= mine
            claimed |= mine
        self.masks = masks

    def _owned_mark(self, facets: npt.NDArray[np.int32], comps: Sequence[int]) -> npt.NDArray:
        """Owned dofs of the components ``comps`` of the nodes of ``facets``, marked on the
        rank that owns them (ghost marks summed onto their owners)."""
        V = self.model.V
        fdim = self.model.mesh.topology.dim - 1
        blocks = fem.locate_dofs_topological(V, fdim, facets)
        mark = fem.Function(V)
        for c in comps:
            mark.x.array[self.bs * blocks + c] = 1.0
        mark.x.scatter_reverse(la.InsertMode.add)
        return mark.x.array[: self.model.num_owned] > 0.0

    def _resultant(self, values: npt.NDArray[np.float64], mask: npt.NDArray | None) -> npt.NDArray:
        """Local ``[force..., moment...]`` of the owned entries ``values`` (where ``mask``)."""
        f = values.reshape(-1, self.bs)[:, : self.gdim].copy()
        if mask is not None:
            f[~mask.reshape(-1, self.bs)[:, : self.gdim]] = 0.0
        return np.concatenate([f.sum(axis=0), _moment_parts(self.x, f)])

    def record(
        self, residual: PETSc.Vec, load: PETSc.Vec, inertia: PETSc.Vec | None = None
    ) -> ReactionRecord:
        """The reactions of the residual ``residual`` (owned entries), with the resultant
        of ``load`` and of ``inertia`` (collective: one reduction)."""
        r = residual.array_r
        parts = [self._resultant(r, self.masks[n]) for n in self.names]
        parts.append(self._resultant(load.array_r, None))
        if inertia is not None:
            parts.append(self._resultant(inertia.array_r, None))
        gross = np.zeros_like(parts[-1])
        gross[0] = np.linalg.norm(load.array_r.reshape(-1, self.bs)[:, : self.gdim], axis=1).sum()
        parts.append(gross)
        total = self.comm.allreduce(np.array(parts), op=MPI.SUM)
        g = self.gdim

        def fm(row: npt.NDArray[np.float64]) -> ForceMoment:
            return ForceMoment(row[:g].copy(), row[g:].copy())

        groups = {n: fm(total[k]) for k, n in enumerate(self.names)}
        k = len(self.names)
        inert = fm(total[k + 1]) if inertia is not None else None
        return ReactionRecord(groups, fm(total[k]), inert, float(total[-1][0]))

    def columns(self, dynamic: bool) -> list[str]:
        """history.csv columns: ``reaction_<group>_<c>`` per group, then ``load_<c>`` (and
        ``inertia_<c>`` in dynamic runs); ``c`` runs over x, y(, z) and the moments."""
        comps = list("xyz"[: self.gdim]) + list(moment_components(self.gdim))
        cols = [f"reaction_{n}_{c}" for n in self.names for c in comps]
        cols += [f"load_{c}" for c in comps]
        if dynamic:
            cols += [f"inertia_{c}" for c in comps]
        return cols

    def zero_record(self, dynamic: bool) -> ReactionRecord:
        """All zero (the initial state: no step solved yet)."""
        g, m = self.gdim, len(moment_components(self.gdim))
        z = ForceMoment(np.zeros(g), np.zeros(m))
        return ReactionRecord({n: z for n in self.names}, z, z if dynamic else None)
