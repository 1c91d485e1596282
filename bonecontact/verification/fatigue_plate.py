"""Cracked plates grown by fatigue: the Paris-law block integration of
:mod:`bonecontact.fracture.fatigue` on a re-meshed 2D crack (docs/theory/fracture.md#fatigue).

The plates of :mod:`bonecontact.fracture.plates` (plane strain) under remote tension σ at
the peak of the cycle: [−W, W] × [−2W, 2W] with a straight centre crack of half-length a0
grown at both tips to a1 (:func:`grow_centre_crack`), and the strip [0, W] × [−2W, 2W]
with an edge crack of length a0 grown until its tip is within Δa_max of the far edge:
the strip is separated (:func:`grow_edge_crack`).  Every block end is a new mesh and
solve; the peak K is the MTS equivalent K of the interaction integral.

The K at a block end depends only on the crack's geometry and the mesh parameters, not on
the Paris constants: runs that share those (for example the same Δa_max with other m or
R) reuse the solves, kept in a per-process cache keyed by the crack's points.
"""

from __future__ import annotations

from dataclasses import dataclass

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from bonecontact.fracture.fatigue import CrackFatigueBody, FatigueResult, ParisLaw, grow_by_fatigue
from bonecontact.fracture.meshing import CrackedMesh, TipMesh
from bonecontact.fracture.plates import (
    centre_crack,
    edge_crack,
    rectangle_outline,
    solve_tension,
)
from bonecontact.materials.laws import Isotropic

__all__ = ["CentreCrackFatigue", "EdgeCrackFatigue", "grow_centre_crack", "grow_edge_crack"]

_K_CACHE: dict[tuple, tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]] = {}


@dataclass
class _CachedPlateBody(CrackFatigueBody):
    """:class:`CrackFatigueBody` whose K and kink angles are looked up by geometry."""

    key: tuple = ()

    def k_max(self) -> npt.NDArray[np.float64]:
        k = (*self.key, self.comm.size, np.round(self.crack.points, 12).tobytes())
        if k not in _K_CACHE:
            k_eq = super().k_max()
            _K_CACHE[k] = (k_eq, self.angles.copy())
        k_eq, angles = _K_CACHE[k]
        self.angles = angles.copy()
        return k_eq.copy()


@dataclass(frozen=True)
class CentreCrackFatigue:
    """The grown plate: the fatigue history and the half-length at every block end."""

    result: FatigueResult
    half_lengths: npt.NDArray[np.float64]

    @property
    def cycles(self) -> float:
        """Cycles from a0 to a1."""
        return float(self.result.cycles[-1])


def grow_centre_crack(
    law: ParisLaw,
    a0: float,
    a1: float,
    da_max: float,
    tip_mesh: TipMesh,
    half_width: float = 1.0,
    sigma: float = 1.0e6,
    material: Isotropic | None = None,
    comm: MPI.Comm | None = None,
) -> CentreCrackFatigue:
    """Grow the centre crack of the plate from half-length ``a0`` to ``a1``.

    Parameters
    ----------
    law
        :class:`~bonecontact.fracture.fatigue.ParisLaw` (its R sets ΔK from the peak σ).
    a0, a1
        Initial and final half-lengths (m), a0 < a1 < half_width.
    da_max
        Growth of each tip per block (m).
    tip_mesh
        Tip element size and grading of every re-mesh.
    half_width, sigma, material
        W (m; the plate's half-height is 2W), peak remote stress (Pa), material
        (default: E = 17 GPa, ν = 0.3).
    comm
        Communicator (default ``MPI.COMM_WORLD``).

    Returns
    -------
    CentreCrackFatigue
        The same on every rank.
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    mat = Isotropic(E=17.0e9, nu=0.3) if material is None else material
    w = float(half_width)

    def solve(cm: CrackedMesh) -> tuple:
        sol = solve_tension(cm, mat, sigma)
        return sol.model, sol.u

    body = _CachedPlateBody(
        outline=rectangle_outline(-w, -2 * w, w, 2 * w),
        crack=centre_crack(a0),
        solve=solve,
        material=mat,
        tip_mesh=tip_mesh,
        da_max=da_max,
        comm=comm,
        key=(w, float(sigma), mat.E, mat.nu, tip_mesh, float(da_max)),
    )
    halves = [a0]

    class _Recorder:
        def k_max(self) -> npt.NDArray[np.float64]:
            return body.k_max()

        def grow(self, advances: npt.NDArray[np.float64]) -> None:
            body.grow(advances)
            halves.append(0.5 * body.crack.length)

    result = grow_by_fatigue(_Recorder(), law, da_max, a1 - a0)
    return CentreCrackFatigue(result, np.array(halves))


@dataclass(frozen=True)
class EdgeCrackFatigue:
    """The grown strip: the fatigue history and the crack length at every block end."""

    result: FatigueResult
    lengths: npt.NDArray[np.float64]

    @property
    def separated(self) -> bool:
        """The tip of the last block is within one block of the far edge."""
        return self.result.status == "grown"

    @property
    def cycles(self) -> npt.NDArray[np.float64]:
        """Cycles from a0 to every block end."""
        return self.result.cycles


def grow_edge_crack(
    law: ParisLaw,
    a0: float,
    da_max: float,
    tip_mesh: TipMesh,
    width: float = 1.0,
    sigma: float = 1.0e6,
    material: Isotropic | None = None,
    comm: MPI.Comm | None = None,
) -> EdgeCrackFatigue:
    """Grow the edge crack of the strip [0, W] × [−2W, 2W] from length ``a0`` until the
    fracture of the strip: the tip within Δa_max of the far edge, a = W − Δa_max (the
    growth W − Δa_max − a0 must be a whole number of blocks, else the last is shorter).

    Parameters
    ----------
    law
        :class:`~bonecontact.fracture.fatigue.ParisLaw`.
    a0
        Initial crack length (m), 0 < a0 < W − Δa_max.
    da_max
        Growth per block (m).
    tip_mesh
        Tip element size and grading of every re-mesh (``h_tip`` ≤ Δa_max/5: the
        integration domain near the far edge is 0.8 Δa_max).
    width, sigma, material
        W (m), peak remote stress (Pa), material (default: E = 17 GPa, ν = 0.3).
    comm
        Communicator (default ``MPI.COMM_WORLD``).

    Returns
    -------
    EdgeCrackFatigue
        The same on every rank.
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    mat = Isotropic(E=17.0e9, nu=0.3) if material is None else material
    w = float(width)

    def solve(cm: CrackedMesh) -> tuple:
        sol = solve_tension(cm, mat, sigma)
        return sol.model, sol.u

    body = _CachedPlateBody(
        outline=rectangle_outline(0.0, -2 * w, w, 2 * w),
        crack=edge_crack(a0),
        solve=solve,
        material=mat,
        tip_mesh=tip_mesh,
        da_max=da_max,
        comm=comm,
        key=("edge", w, float(sigma), mat.E, mat.nu, tip_mesh, float(da_max)),
    )
    lengths = [a0]

    class _Recorder:
        def k_max(self) -> npt.NDArray[np.float64]:
            return body.k_max()

        def grow(self, advances: npt.NDArray[np.float64]) -> None:
            body.grow(advances)
            lengths.append(body.crack.length)

    result = grow_by_fatigue(_Recorder(), law, da_max, w - da_max - a0, max_blocks=10_000)
    return EdgeCrackFatigue(result, np.array(lengths))
