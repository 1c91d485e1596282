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
:func:`~bonecontact.fracture.sif.interaction_integral`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from dolfinx import fem, mesh

from bonecontact.contact.friction import FrictionLaw
from bonecontact.contact.interface import ContactInterface, build_interface
from bonecontact.contact.options import PDASOptions
from bonecontact.contact.pdas import ContactSolver, PDASResult
from bonecontact.fracture.meshing import CrackedMesh
from bonecontact.mechanics.model import Mechanics

__all__ = [
    "MASTER_TAG",
    "SLAVE_TAG",
    "FaceTraction",
    "contact_tags",
    "crack_face_solver",
    "face_interface",
    "face_traction",
]

#: Facet tags of the contact pair (in the interface's own facet markers).
SLAVE_TAG, MASTER_TAG = 1, 2


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
    Dirichlet conditions are added)."""
    if cm.crack is None:
        raise ValueError("the mesh has no crack")
    return build_interface(
        model.V,
        contact_tags(cm),
        SLAVE_TAG,
        MASTER_TAG,
        dirichlet_dofs=model.bc_dofs(),
        name=name,
        shared_nodes="no_multiplier",
    )


def crack_face_solver(
    model: Mechanics,
    cm: CrackedMesh,
    friction: float | None = None,
    options: PDASOptions | None = None,
) -> ContactSolver:
    """A PDAS contact solver for the crack faces: frictionless (``friction=None``) or
    Coulomb with coefficient ``friction`` (fixed-point bound, so that a single static
    step is frictional)."""
    law = (
        FrictionLaw()
        if friction is None
        else FrictionLaw("coulomb", float(friction), update="fixed_point")
    )
    opts = options if options is not None else PDASOptions(friction=law, max_iterations=50)
    return ContactSolver(model.V, [face_interface(model, cm)], opts)


class FaceTraction(NamedTuple):
    """The traction on each crack face (Pa): P1 functions, ``plus`` on the nodes of
    ``crack_plus`` and ``minus`` on those of ``crack_minus``; both hold the shared tip node
    with the value of their own face."""

    plus: fem.Function
    minus: fem.Function


def face_traction(
    V: fem.FunctionSpace,
    itf: ContactInterface,
    result: PDASResult,
    k: int = 0,
    tips: npt.ArrayLike = (),
) -> FaceTraction:
    """P1 traction on the two crack faces from the multipliers of pair ``k`` (Pa).

    On a slave node the traction on the face is −(λ_n n + λ_t t) (n, t the slave normal
    and tangent; λ_n > 0 a pressure); the coincident master node carries the opposite.
    At a tip (``tips``: their coordinates) the node carries no multiplier; the modified
    dual basis of its neighbour is 1 on the whole tip facet, so the multiplier there is
    the neighbour's: the tip node gets the traction of the nearest slave node (in
    ``plus``) and its opposite (in ``minus``).  The slave data are gathered (a face is
    small), so every rank fills its owned and ghost dofs without a scatter.
    """
    comm = V.mesh.comm
    bs = V.dofmap.index_map_bs
    lam_n = result.pressure[k]
    lam_t = result.traction_t[k] if result.traction_t else np.zeros((lam_n.size, bs - 1))
    t = -(lam_n[:, None] * itf.normals + np.einsum("nk,nkd->nd", lam_t, itf.tangents))
    rows = np.column_stack([itf.global_blocks.astype(float), itf.coords[:, :bs], t])
    rows = np.concatenate(comm.allgather(rows))
    plus = fem.Function(V, name="crack_face_traction_plus")
    minus = fem.Function(V, name="crack_face_traction_minus")
    if rows.size == 0:
        return FaceTraction(plus, minus)
    im = V.dofmap.index_map
    n_local = im.size_local + im.num_ghosts
    gblocks = im.local_to_global(np.arange(n_local, dtype=np.int32))
    vp, vm = plus.x.array.reshape(-1, bs), minus.x.array.reshape(-1, bs)
    slave_g = rows[:, 0].astype(np.int64)
    is_slave = np.isin(gblocks, slave_g)
    pos = {g: i for i, g in enumerate(slave_g)}
    for b in np.flatnonzero(is_slave):
        vp[b] = rows[pos[int(gblocks[b])], 1 + bs :]
    # master nodes: the other node at the same point
    x = V.tabulate_dof_coordinates()[:, :bs]
    scale = float(np.ptp(rows[:, 1 : 1 + bs], axis=0).max()) or 1.0
    key = lambda p: tuple(np.round(p / (1e-9 * scale)).astype(np.int64))  # noqa: E731
    at = {key(r[1 : 1 + bs]): r[1 + bs :] for r in rows}
    for b in np.flatnonzero(~is_slave):
        tr = at.get(key(x[b]))
        if tr is not None:
            vm[b] = -tr
    for tip in np.asarray(tips, dtype=float).reshape(-1, bs):
        nearest = rows[np.argmin(np.linalg.norm(rows[:, 1 : 1 + bs] - tip, axis=1)), 1 + bs :]
        for b in np.flatnonzero(np.linalg.norm(x - tip, axis=1) <= 1e-9 * scale):
            vp[b], vm[b] = nearest, -nearest
    return FaceTraction(plus, minus)
