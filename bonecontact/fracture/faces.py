"""The two faces of a crack as a contact pair (docs/theory/fracture.md#crack-faces-in-contact).

The faces of a :class:`~bonecontact.fracture.meshing.CrackedMesh` are duplicated node by
node, so they match; ``crack_plus`` is the slave (it carries the multipliers) and
``crack_minus`` the master of a dual-mortar interface solved by the PDAS
:class:`~bonecontact.contact.pdas.ContactSolver` (non-penetration, frictionless or
Coulomb).  The contact interface needs slave and master surfaces without common nodes,
so the slave facets touching a tip (where both faces share the node) are left out: the
last element at each tip carries no contact constraint.

:func:`face_traction` turns the multipliers of a solve into a P1 traction field on both
faces, the input of the face term of
:func:`~bonecontact.fracture.sif.interaction_integral`.
"""

from __future__ import annotations

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
    "contact_tags",
    "crack_face_solver",
    "face_interface",
    "face_traction",
]

#: Facet tags of the contact pair (in the interface's own facet markers).
SLAVE_TAG, MASTER_TAG = 1, 2


def _tip_vertices(cm: CrackedMesh) -> npt.NDArray[np.int32]:
    tips = [cm.crack.tip(e) for e in cm.crack.tip_ends]
    tol = 1e-9 * float(np.ptp(cm.outline, axis=0).max())
    return mesh.locate_entities(
        cm.mesh,
        0,
        lambda x: np.logical_or.reduce([np.hypot(x[0] - t[0], x[1] - t[1]) <= tol for t in tips]),
    )


def contact_tags(cm: CrackedMesh) -> mesh.MeshTags:
    """Facet markers of the pair: slave = ``crack_plus`` without the tip facets, master =
    ``crack_minus``."""
    msh = cm.mesh
    msh.topology.create_connectivity(1, 0)
    f2v = msh.topology.connectivity(1, 0)
    tipv = _tip_vertices(cm)
    plus, minus = (cm.facet_tags.find(t) for t in cm.face_tags)
    keep = np.array([not np.isin(f2v.links(f), tipv).any() for f in plus], dtype=bool)
    ent = np.concatenate([plus[keep], minus]).astype(np.int32)
    val = np.concatenate(
        [np.full(int(keep.sum()), SLAVE_TAG, np.int32), np.full(minus.size, MASTER_TAG, np.int32)]
    )
    order = np.argsort(ent)
    return mesh.meshtags(msh, 1, ent[order], val[order])


def face_interface(model: Mechanics, cm: CrackedMesh, name: str = "crack") -> ContactInterface:
    """The dual-mortar interface of the crack faces (collective; after the model's
    Dirichlet conditions are added)."""
    if cm.crack is None:
        raise ValueError("the mesh has no crack")
    return build_interface(
        model.V, contact_tags(cm), SLAVE_TAG, MASTER_TAG, dirichlet_dofs=model.bc_dofs(), name=name
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


def face_traction(
    V: fem.FunctionSpace, itf: ContactInterface, result: PDASResult, k: int = 0
) -> fem.Function:
    """P1 traction on both crack faces from the multipliers of pair ``k`` (Pa).

    On a slave node the traction on the face is −(λ_n n + λ_t t) (n, t the slave normal
    and tangent; λ_n > 0 a pressure); the coincident master node carries the opposite.
    The slave data are gathered (a face is small), so every rank fills its owned and
    ghost dofs without a scatter.
    """
    comm = V.mesh.comm
    bs = V.dofmap.index_map_bs
    lam_n = result.pressure[k]
    lam_t = result.traction_t[k] if result.traction_t else np.zeros((lam_n.size, bs - 1))
    t = -(lam_n[:, None] * itf.normals + np.einsum("nk,nkd->nd", lam_t, itf.tangents))
    rows = np.column_stack([itf.global_blocks.astype(float), itf.coords[:, :bs], t])
    rows = np.concatenate(comm.allgather(rows))
    f = fem.Function(V, name="crack_face_traction")
    if rows.size == 0:
        return f
    im = V.dofmap.index_map
    n_local = im.size_local + im.num_ghosts
    gblocks = im.local_to_global(np.arange(n_local, dtype=np.int32))
    values = f.x.array.reshape(-1, bs)
    slave_g = rows[:, 0].astype(np.int64)
    is_slave = np.isin(gblocks, slave_g)
    pos = {g: i for i, g in enumerate(slave_g)}
    for b in np.flatnonzero(is_slave):
        values[b] = rows[pos[int(gblocks[b])], 1 + bs :]
    # master nodes: the other node at the same point
    x = V.tabulate_dof_coordinates()[:, :bs]
    scale = float(np.ptp(x, axis=0).max()) if x.size else 1.0
    key = lambda p: tuple(np.round(p / (1e-9 * max(scale, 1e-300))).astype(np.int64))  # noqa: E731
    at = {key(r[1 : 1 + bs]): r[1 + bs :] for r in rows}
    for b in np.flatnonzero(~is_slave):
        tr = at.get(key(x[b]))
        if tr is not None:
            values[b] = -tr
    return f
