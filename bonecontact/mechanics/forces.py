"""Total forces on facet groups: the measures of a group and the traction of a ``[[force]]``.

A ``[[force]]`` gives the total force ``F`` (N; N/m in 2D plane strain) on a facet
group and, optionally, its total moment ``M`` about a point ``p``.  It is applied as the
traction

    t(x) = F / A + Θ × (x − c),        Θ = J⁻¹ (M − (c − p) × F),

over the group's reference area ``A`` (a length in 2D), with ``c`` its centroid and
``J = ∫ (|r|² I − r rᵀ) dA`` (``r = x − c``) its second-moment tensor.  The linear part
has zero resultant (``∫ r dA = 0``) and moment ``J Θ`` about any point, so the total
moment about ``p`` is ``(c − p) × F + J Θ = M``.  In 2D, Θ × r = Θ (−r_y, r_x) and
``J = ∫ |r|² ds``.  On a flat face this is the traction of beam theory: bending about an
in-plane axis gives a normal traction linear across the face, a twist about the normal a
shear traction (the exact torsion of a circular section).  docs/theory/mechanics.md has
the derivation.  All measures are assembled (collective) and summed over the ranks.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem, mesh

__all__ = ["FacetMeasures", "facet_measures", "force_traction", "linear_traction_rate"]


@dataclass(frozen=True)
class FacetMeasures:
    """Reference measures of a facet group (summed over every rank).

    Attributes
    ----------
    area
        Area (m²; 2D: length, m).
    centroid
        ``∫ x dA / A`` (gdim components).
    inertia
        Second-moment tensor ``J = ∫ (|r|² I − r rᵀ) dA`` about the centroid, 3×3 in
        3D; in 2D the 1×1 ``[[∫ |r|² ds]]`` (m⁴; 2D: m³).
    """

    area: float
    centroid: npt.NDArray[np.float64]
    inertia: npt.NDArray[np.float64]


def _integral(expr: ufl.core.expr.Expr, ds: ufl.Measure, comm: MPI.Comm) -> float:
    """``∫ expr ds`` over the owned facets, summed over the ranks (collective)."""
    return float(comm.allreduce(fem.assemble_scalar(fem.form(expr * ds)), op=MPI.SUM))


def facet_measures(msh: mesh.Mesh, ds: ufl.Measure) -> FacetMeasures:
    """Area, centroid and second-moment tensor of the facets of the measure ``ds``
    (e.g. ``model.ds((tag,))``), in the reference configuration (collective)."""
    comm = msh.comm
    gdim = msh.geometry.dim
    x = ufl.SpatialCoordinate(msh)
    one = fem.Constant(msh, np.float64(1.0))
    area = _integral(one, ds, comm)
    if area <= 0.0:
        return FacetMeasures(0.0, np.zeros(gdim), np.zeros((1, 1) if gdim == 2 else (3, 3)))
    c = np.array([_integral(x[i], ds, comm) for i in range(gdim)]) / area
    r = [x[i] - float(c[i]) for i in range(gdim)]
    second = np.array(
        [[_integral(r[i] * r[j], ds, comm) for j in range(gdim)] for i in range(gdim)]
    )
    if gdim == 2:
        inertia = np.array([[np.trace(second)]])
    else:
        inertia = np.trace(second) * np.eye(3) - second
    return FacetMeasures(area, c, inertia)


def _cross(a: npt.ArrayLike, b: npt.ArrayLike) -> npt.NDArray[np.float64] | float:
    """``a × b`` (3D) or its z-component (2D)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.size == 2:
        return float(a[0] * b[1] - a[1] * b[0])
    return np.cross(a, b)


def linear_traction_rate(
    measures: FacetMeasures,
    force: Sequence[float],
    moment: Sequence[float] | float,
    point: Sequence[float] | None,
) -> npt.NDArray[np.float64]:
    """Θ of the module docstring: ``J⁻¹ (M − (c − p) × F)`` (1 entry in 2D, 3 in 3D).

    ``point`` ``None`` is the centroid.  Raises ``ValueError`` when ``J`` is singular (a
    group whose facets lie on one line, which cannot carry every moment).
    """
    c = measures.centroid
    p = c if point is None else np.asarray(point, dtype=np.float64)
    target = np.atleast_1d(np.asarray(moment, dtype=np.float64)) - np.atleast_1d(
        _cross(c - p, force)
    )
    J = measures.inertia
    scale = float(np.abs(J).max()) if J.size else 0.0
    if scale <= 0.0 or np.linalg.cond(J) > 1e12:
        raise ValueError(
            "the group's facets lie on a line: a linearly varying traction cannot carry "
            "every moment there"
        )
    return np.linalg.solve(J, target)


def force_traction(
    msh: mesh.Mesh,
    measures: FacetMeasures,
    force: Sequence[float],
    moment: Sequence[float] | float | None = None,
    point: Sequence[float] | None = None,
) -> ufl.core.expr.Expr:
    """The traction (Pa) ``F/A + Θ × (x − c)`` of a total force (and moment) as a UFL vector.

    Raises ``ValueError`` for a group of zero area, or a moment on a group whose facets
    lie on a line.
    """
    if measures.area <= 0.0:
        raise ValueError("the group has no facets (zero area)")
    gdim = msh.geometry.dim
    uniform = np.asarray(force, dtype=np.float64) / measures.area
    if moment is None:
        return fem.Constant(msh, uniform)
    theta = linear_traction_rate(measures, force, moment, point)
    x = ufl.SpatialCoordinate(msh)
    r = ufl.as_vector([x[i] - float(measures.centroid[i]) for i in range(gdim)])
    th = fem.Constant(msh, theta)
    lin = ufl.as_vector([-th[0] * r[1], th[0] * r[0]]) if gdim == 2 else ufl.cross(th, r)
    return fem.Constant(msh, uniform) + lin
