"""The two faces of a crack as a contact pair (docs/theory/fracture.md#crack-faces-in-contact).

The faces of a :class:`~bonecontact.fracture.meshing.CrackedMesh` are duplicated node by
node, so they match; ``crack_plus`` is the slave (it carries the multipliers) and
``crack_minus`` the master of a dual-mortar interface solved by the PDAS
:class:`~bonecontact.contact.pdas.ContactSolver` (non-penetration, frictionless or
Coulomb).  The whole faces form the pair.  The tip node belongs to both faces; it
carries no multiplier (``shared_nodes="no_multiplier"`` of
:func:`~bonecontact.contact.interface.build_interface`: the dual basis is modified there
as at a Dirichlet node, so the multiplier of the tip's neighbour covers the whole tip
facet) and is a master node only — the jump of the displacement across the faces
vanishes at the tip by construction.

:func:`face_traction` turns the multipliers of a solve into P1 traction fields on the two
faces, the input of the face term of
:func:`~bonecontact.fracture.sif.interaction_integral`; near a closed tip it replaces the
multipliers, which scatter there, by a linear least-squares fit
(:func:`recovered_traction`).
"""

from __future__ import annotations

from typing import NamedTuple

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
from dolfinx import fem, mesh

from bonecontact.contact.friction import FrictionLaw
from bonecontact.contact.interface import ContactInputError, ContactInterface, build_interface
from bonecontact.contact.options import PDASOptions
from bonecontact.contact.pdas import ContactSolver, PDASResult
from bonecontact.fracture.meshing import CrackedMesh
from bonecontact.mechanics.model import Mechanics

__all__ = [
    "FACE_TOLERANCE",
    "MASTER_TAG",
    "SLAVE_TAG",
    "FaceData",
    "FaceTraction",
    "check_faces_coincide",
    "contact_tags",
    "crack_face_solver",
    "face_data",
    "face_friction_law",
    "face_interface",
    "face_traction",
    "recovered_traction",
]

#: Facet tags of the contact pair (in the interface's own facet markers).
SLAVE_TAG, MASTER_TAG = 1, 2

#: The two faces of a crack lie on each other (duplicated nodes): the master facets are
#: searched within this fraction of the model's extent (m) along the slave normals, and a
#: face whose nodal gap exceeds it (or whose covered measure differs from its measure by
#: a thousand times it) is refused (:func:`check_faces_coincide`).
FACE_TOLERANCE = 1e-8


def contact_tags(cm: CrackedMesh) -> mesh.MeshTags:
    """Facet markers of the pair: slave = ``crack_plus``, master = ``crack_minus`` (whole
    faces; the shared tip node carries no multiplier, see the module docstring).  A 3D
    :class:`~bonecontact.fracture.body3d.CrackedBody3D` works the same way (its
    ``face_tags``: ``crack_upper`` slave, ``crack_lower`` master; the front nodes shared)."""
    msh = cm.mesh
    plus, minus = (cm.facet_tags.find(t) for t in cm.face_tags)
    ent = np.concatenate([plus, minus]).astype(np.int32)
    val = np.concatenate(
        [np.full(plus.size, SLAVE_TAG, np.int32), np.full(minus.size, MASTER_TAG, np.int32)]
    )
    order = np.argsort(ent)
    return mesh.meshtags(msh, msh.topology.dim - 1, ent[order], val[order])


def face_interface(model: Mechanics, cm: CrackedMesh, name: str = "crack") -> ContactInterface:
    """The dual-mortar interface of the crack faces (collective; after the model's
    Dirichlet conditions are added).

    The faces lie on each other node by node, so every slave facet is paired only with
    the master facet on it (``coincident`` of
    :func:`~bonecontact.contact.interface.build_interface`, to :data:`FACE_TOLERANCE` of
    the model's extent, which is also the search distance): with every master facet
    whose projection along the averaged nodal normals overlaps it (the default), a
    facet next to a sharp kink of a grown crack (70-80 degrees) was also paired with the
    adjacent facet of the other leg, or with the opposite face of a leg a few facets
    away — a nodal gap of -2.7 mm between faces that coincide, and before that step
    wrong contact matrices.  The interface is then checked to have zero gaps and a
    singly covered slave face (:func:`check_faces_coincide`).  The pair starts open
    (:attr:`~bonecontact.contact.interface.ContactInterface.start_open`): a cold start
    that held every closed gap would glue the crack, and an open crack would then release
    every face node.

    Raises
    ------
    ContactInputError
        The faces cannot form the pair, or do not lie on each other (the message names
        the crack and the node).
    """
    if cm.crack is None:
        raise ValueError("the mesh has no crack")
    tol = FACE_TOLERANCE * _extent(model.mesh)
    try:
        itf = build_interface(
            model.V,
            contact_tags(cm),
            SLAVE_TAG,
            MASTER_TAG,
            dirichlet_dofs=model.bc_dofs(),
            name=name,
            search_radius=tol,
            shared_nodes="no_multiplier",
            coincident=tol,
        )
    except ContactInputError as exc:
        raise ContactInputError(
            f"crack {name!r}: its two faces do not form a contact pair: {exc}"
        ) from None
    check_faces_coincide(itf, model.mesh.comm, tol)
    itf.start_open = True  # every gap is 0: a closed-gap start would glue the crack
    return itf


def _extent(msh: mesh.Mesh) -> float:
    """Largest extent of the mesh's bounding box (m; collective)."""
    x = msh.geometry.x[:, : msh.geometry.dim]
    lo = np.min(x, axis=0, initial=np.inf)
    hi = np.max(x, axis=0, initial=-np.inf)
    msh.comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)
    msh.comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
    return float(np.max(hi - lo))


def check_faces_coincide(itf: ContactInterface, comm: MPI.Comm, tol: float) -> None:
    """Raise :class:`ContactInputError` unless the two crack faces of ``itf`` lie on each
    other: every nodal gap within ``tol`` (m) of zero and the slave face covered once,
    its covered measure its measure to 1000 :data:`FACE_TOLERANCE` (collective)."""
    gap = itf.gap
    i = int(np.argmax(np.abs(gap))) if gap.size else -1
    local = (float(abs(gap[i])), gap[i], itf.coords[i].tolist()) if gap.size else (0.0, 0.0, [])
    worst = max(comm.allgather(local), key=lambda r: (r[0], r[2]))
    if worst[0] > tol:
        where = ", ".join(f"{c:.6g}" for c in worst[2])
        raise ContactInputError(
            f"crack {itf.name!r}: its two faces do not lie on each other: nodal gap "
            f"{worst[1]:.3e} m at the face node ({where}), more than {tol:.1e} m"
        )
    ratio = itf.covered_area / itf.slave_area if itf.slave_area > 0 else 0.0
    if abs(ratio - 1.0) > FACE_TOLERANCE * 1e3:
        raise ContactInputError(
            f"crack {itf.name!r}: its two faces do not lie on each other: the opposite "
            f"face covers {ratio:.9g} times the face's {itf.slave_area:.6g} m^{itf.gdim - 1} "
            "(1 expected)"
        )


def face_friction_law(coefficient: float | None) -> FrictionLaw:
    """The friction of a crack's faces: frictionless (``None``) or Coulomb with the
    coefficient and the fixed-point bound (so that a single static step is frictional)."""
    if coefficient is None:
        return FrictionLaw()
    return FrictionLaw("coulomb", float(coefficient), update="fixed_point")


def crack_face_solver(
    model: Mechanics,
    cm: CrackedMesh,
    friction: float | None = None,
    options: PDASOptions | None = None,
) -> ContactSolver:
    """A PDAS contact solver for the crack faces: frictionless (``friction=None``) or
    Coulomb with coefficient ``friction`` (fixed-point bound, so that a single static
    step is frictional)."""
    law = face_friction_law(friction)
    opts = options if options is not None else PDASOptions(friction=law, max_iterations=50)
    return ContactSolver(model.V, [face_interface(model, cm)], opts)


class FaceTraction(NamedTuple):
    """The traction on each crack face (Pa): P1 functions, ``plus`` on the nodes of
    ``crack_plus`` and ``minus`` on those of ``crack_minus``; both hold the shared tip node
    with the value of their own face."""

    plus: fem.Function
    minus: fem.Function


def recovered_traction(
    x: npt.NDArray[np.float64],
    t: npt.NDArray[np.float64],
    weight: npt.NDArray[np.float64],
    closed: npt.NDArray[np.bool_],
    tips: npt.NDArray[np.float64],
    radius: float,
    reach: float = 2.0,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Face tractions near the tips recovered by weighted linear least squares.

    Every face node within ``radius`` of a tip (and every tip) takes the value at its own
    position of the linear fit ``t ≈ a + B (x − x_i)`` to the nodes within
    ``reach·radius`` of it, weighted by ``weight`` (∫ψ_p), when all those nodes are closed
    and they are at least ``2·gdim``; otherwise it keeps its multiplier (a tip: the
    nearest node's).  The fit reaches beyond the zone it replaces, so that the scattered
    nodes next to the tip cannot tilt it (2D, reach 1: |K_I| up to 0.8 %, reach 2:
    0.35 %; 3D, where the multipliers scatter more, reach 2: 1.5 %, 4: 1.0 %, 6: 0.8 %
    of |σ|√(πa) for a penny at 30°; a weighted mean instead of the linear fit would be
    biased by the gradient of the traction at a one-sided tip).

    Why: the nodal multipliers next to a tip scatter by ±20 % about the smooth traction
    of a closed crack (the P1 field cannot follow the sliding singularity on an
    unstructured mesh), and the face term weighs them by 1/√r: |K_I| reached 1.5–3 % of
    |σ|√(πa) at one tip of a closed 45° crack.  A closed crack's face traction is
    bounded and smooth up to the tip, so the fit loses nothing there; an open node in
    the fit's reach keeps the raw values (the traction jumps to zero at the open part).

    Parameters
    ----------
    x, t, weight, closed
        Face nodes: coordinates (n, gdim), tractions (n, gdim), weights (n,), closed (n,).
    tips
        Tip (2D) or front (3D) node coordinates (m, gdim): no multiplier there.
    radius
        Reach of the recovery around the tips (m): the integration domain's radius.
    reach
        Reach of each fit, in units of ``radius``.

    Returns
    -------
    (t_nodes, t_tips)
        The tractions of the nodes and of the tips.
    """
    from scipy.spatial import cKDTree

    gdim = x.shape[1]
    t_new = t.copy()
    if len(x) == 0:
        return t_new, np.zeros((len(tips), gdim))
    tree = cKDTree(x)
    tip_t = t[tree.query(tips)[1]] if len(tips) else np.zeros((0, gdim))
    near_tip = (
        np.unique(np.concatenate(tree.query_ball_point(tips, radius)).astype(np.int64))
        if len(tips)
        else np.zeros(0, np.int64)
    )

    def fit(p: npt.NDArray[np.float64]) -> npt.NDArray[np.float64] | None:
        nb = np.sort(np.asarray(tree.query_ball_point(p, reach * radius), dtype=np.int64))
        if len(nb) < 2 * gdim or not closed[nb].all():
            return None
        X = np.column_stack([np.ones(len(nb)), (x[nb] - p) / (reach * radius)])
        sw = np.sqrt(weight[nb])[:, None]
        coef = np.linalg.lstsq(sw * X, sw * t[nb], rcond=1e-8)[0]
        return coef[0]

    for i in near_tip:
        v = fit(x[i])
        if v is not None:
            t_new[i] = v
    for j, p in enumerate(tips):
        v = fit(p)
        if v is not None:
            tip_t[j] = v
    return t_new, tip_t


def face_traction(
    V: fem.FunctionSpace,
    itf: ContactInterface,
    result: PDASResult,
    k: int = 0,
    tips: npt.ArrayLike = (),
    radius: float | None = None,
    reach: float = 2.0,
) -> FaceTraction:
    """P1 traction on the two crack faces from the multipliers of pair ``k`` (Pa).

    On a slave node the traction on the face is −(λ_n n + λ_t t) (n, t the slave normal
    and tangent; λ_n > 0 a pressure); the coincident master node carries the opposite.
    At a tip (``tips``: their coordinates) the node carries no multiplier; the modified
    dual basis of its neighbour is 1 on the whole tip facet, so the multiplier there is
    the neighbour's: the tip node gets the traction of the nearest slave node (in
    ``plus``) and its opposite (in ``minus``).  With ``radius``, the tractions within it
    of a tip, and the tips', are recovered by :func:`recovered_traction` with fits of
    ``reach`` (the scatter of the multipliers next to a closed tip would show as K_I).
    The slave data are gathered (a face is small) and sorted by coordinates, so every
    rank fills its owned and ghost dofs without a scatter, the same on any number of
    ranks (:func:`_fill_faces`: only the pair's nodes are visited).
    """
    plus = fem.Function(V, name="crack_face_traction_plus")
    minus = fem.Function(V, name="crack_face_traction_minus")
    masters = _master_blocks(V, itf)  # collective
    face = face_data(V, itf, result, k, tips, radius, reach)
    if face.slave_g.size:
        _fill_faces(V, masters, face, (plus, minus))
    return FaceTraction(plus, minus)


class FaceData(NamedTuple):
    """The slave nodes of a pair on every rank, sorted by coordinates: global blocks
    ``slave_g``, coordinates ``x``, tractions ``t`` (recovered near the tips when asked);
    the tips' coordinates and tractions."""

    slave_g: npt.NDArray[np.int64]
    x: npt.NDArray[np.float64]
    t: npt.NDArray[np.float64]
    tips: npt.NDArray[np.float64]
    tip_t: npt.NDArray[np.float64]


def face_data(
    V: fem.FunctionSpace,
    itf: ContactInterface,
    result: PDASResult,
    k: int = 0,
    tips: npt.ArrayLike = (),
    radius: float | None = None,
    reach: float = 2.0,
) -> FaceData:
    """The face tractions of pair ``k`` gathered from every rank (collective; the
    arguments as :func:`face_traction`'s)."""
    comm = V.mesh.comm
    bs = V.dofmap.index_map_bs
    lam_n = result.pressure[k]
    lam_t = result.traction_t[k] if result.traction_t else np.zeros((lam_n.size, bs - 1))
    t = -(lam_n[:, None] * itf.normals + np.einsum("nk,nkd->nd", lam_t, itf.tangents))
    closed = (np.asarray(result.active[k], dtype=bool) & (lam_n > 0)).astype(float)
    rows = np.column_stack(
        [itf.global_blocks.astype(float), itf.coords[:, :bs], t, itf.weight, closed]
    )
    rows = np.concatenate(comm.allgather(rows)).reshape(-1, 3 + 2 * bs)
    rows = rows[np.lexsort(rows[:, 1 : 1 + bs].T[::-1])]
    tips = np.asarray(tips, dtype=float).reshape(-1, bs)
    xs, ts = rows[:, 1 : 1 + bs], rows[:, 1 + bs : 1 + 2 * bs]
    if rows.size == 0:
        tip_t = np.zeros((len(tips), bs))
    elif radius is not None:
        closed = rows[:, -1] > 0
        ts, tip_t = recovered_traction(xs, ts, rows[:, -2], closed, tips, radius, reach)
    else:
        tip_t = ts[[int(np.argmin(np.linalg.norm(xs - p, axis=1))) for p in tips]]
    return FaceData(rows[:, 0].astype(np.int64), xs, ts, tips, tip_t.reshape(-1, bs))


def _master_blocks(V: fem.FunctionSpace, itf: ContactInterface) -> npt.NDArray[np.int32]:
    """Local blocks (owned and ghost) of the pair's master nodes: the columns of every
    rank's rows of ``M̂`` (a master node that meets no slave facet has no traction to
    take; collective)."""
    bs = V.dofmap.index_map_bs
    mine = np.unique(np.asarray(itf.qt_cols, dtype=np.int64) // bs)
    every = np.unique(np.concatenate(V.mesh.comm.allgather(mine)))
    loc = V.dofmap.index_map.global_to_local(every)
    return loc[loc >= 0].astype(np.int32)


def _fill_faces(
    V: fem.FunctionSpace,
    masters: npt.NDArray[np.int32],
    face: FaceData,
    fields: tuple[fem.Function, fem.Function],
) -> None:
    """The gathered slave tractions into ``plus`` on the local slave nodes and, negated,
    into ``minus`` on the master nodes (``masters``) at the same point; the tips'
    tractions (and their opposites) on the master nodes at the tips."""
    from scipy.spatial import cKDTree

    slave_g, xs, ts, tips, tip_t = face
    bs = V.dofmap.index_map_bs
    vp, vm = fields[0].x.array.reshape(-1, bs), fields[1].x.array.reshape(-1, bs)
    loc = V.dofmap.index_map.global_to_local(slave_g)
    vp[loc[loc >= 0]] = ts[loc >= 0]
    masters = np.setdiff1d(masters, loc[loc >= 0])
    if masters.size == 0:  # no master node on this rank
        return
    x = V.tabulate_dof_coordinates()[masters, :bs]
    tol = 1e-9 * (float(np.ptp(xs, axis=0).max()) or 1.0)
    dist, j = cKDTree(xs).query(x, distance_upper_bound=tol)
    hit = dist <= tol
    vm[masters[hit]] = -ts[j[hit]]
    if len(tips):
        dist, j = cKDTree(tips).query(x, distance_upper_bound=tol)
        hit = dist <= tol
        vp[masters[hit]], vm[masters[hit]] = tip_t[j[hit]], -tip_t[j[hit]]
