"""Material fields on a mesh: piecewise-constant Voigt stiffness, density, viscosity.

All material models are expressed through one cell-wise (DG0) Voigt stiffness
field, so that any number of regions, anisotropic axes, and later cells taken over
by a neoplasm are handled by the same compiled kernels: changing a material only
changes coefficient values.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from dolfinx import fem, mesh

from bonecontact.materials.laws import Material, plane_strain_block

__all__ = ["MaterialFields", "deviatoric_block", "material_fields"]


def deviatoric_block(mu: float, dim: int) -> npt.NDArray[np.float64]:
    """NumPy twin of :func:`bonecontact.forms.elastic.deviatoric_voigt`, full 6×6."""
    C = np.zeros((6, 6))
    C[:3, :3] = -2.0 * mu / 3.0
    C[np.arange(3), np.arange(3)] = 4.0 * mu / 3.0
    C[3, 3] = C[4, 4] = C[5, 5] = mu
    return C


@dataclass
class MaterialFields:
    """DG0 coefficient fields describing the materials of a mesh.

    Attributes
    ----------
    C, C_v
        Elastic and viscous Voigt stiffness (nv×nv; nv = 3 in 2D, 6 in 3D). In
        cells with the nodal-pressure formulation only the deviatoric part.  ``C_v``
        is ``None`` when no material is viscous (``has_viscosity`` false): at 36 values
        per cell it would be as large as the stiffness matrix and all zero.
    C_zz
        2D only: the row of σ_zz against [e_xx, e_yy, γ_xy] (plane-strain
        out-of-plane stress), elastic and viscous (shape (2, 3)).
    rho
        Density (0 where not given).
    kappa, kappa_v
        Bulk modulus and its viscous counterpart in nodal-pressure cells, 0 elsewhere.
    chi
        Indicator of nodal-pressure cells.
    """

    dim: int
    C: fem.Function
    C_v: fem.Function | None
    rho: fem.Function
    kappa: fem.Function
    kappa_v: fem.Function
    chi: fem.Function
    C_zz: fem.Function | None
    has_viscosity: bool
    has_nodal_pressure: bool
    has_density: bool


def _cell_dofs(space: fem.FunctionSpace, num_cells: int) -> npt.NDArray[np.int32]:
    return space.dofmap.list[:num_cells, 0]


def material_fields(
    msh: mesh.Mesh, cell_tags: mesh.MeshTags | None, materials: Mapping[int, Material] | Material
) -> MaterialFields:
    """Build the DG0 material fields from cell tags.

    Parameters
    ----------
    msh
        The mesh (``gdim`` = 2 for plane strain, or 3).
    cell_tags
        Cell markers; may be ``None`` when ``materials`` is a single material.
    materials
        Tag → material, or one material for the whole mesh.

    Returns
    -------
    MaterialFields
        Fields usable in the UFL forms of :mod:`bonecontact.forms`.

    Raises
    ------
    ValueError
        If a cell has no material (collective check).
    """
    dim = msh.geometry.dim
    imap = msh.topology.index_map(msh.topology.dim)
    ncells = imap.size_local + imap.num_ghosts
    tagged, cell_mat = _cell_materials(cell_tags, materials, ncells)
    comm = msh.comm
    has_visc = bool(comm.allreduce(any(m.tau_v > 0 for m in tagged.values()), op=_mpi_lor()))
    fields = _zero_fields(msh, dim, has_visc)
    missing = int(np.sum(cell_mat[: imap.size_local] < 0))
    missing = msh.comm.allreduce(missing)
    if missing:
        raise ValueError(
            f"{missing} cells have no material (tags with materials: {sorted(tagged)})"
        )
    has_anp = False
    has_rho = True
    for tag, mat in tagged.items():
        _set_material(fields, np.flatnonzero(cell_mat == tag), mat, ncells)
        has_anp |= mat.formulation == "nodal_pressure"
        has_rho &= mat.rho is not None
    fields.has_viscosity = has_visc
    fields.has_nodal_pressure = bool(comm.allreduce(has_anp, op=_mpi_lor()))
    fields.has_density = bool(comm.allreduce(has_rho, op=_mpi_land()))
    f = fields
    for u in (f.C, f.C_v, f.rho, f.kappa, f.kappa_v, f.chi, f.C_zz):
        if u is not None:
            u.x.scatter_forward()
    return fields


def _zero_fields(msh: mesh.Mesh, dim: int, viscous: bool) -> MaterialFields:
    """The DG0 fields of :func:`material_fields`, all zero, flags false (``C_v`` only if
    ``viscous``)."""
    nv = 3 if dim == 2 else 6
    T0 = fem.functionspace(msh, ("DG", 0, (nv, nv)))
    S0 = fem.functionspace(msh, ("DG", 0))
    C = fem.Function(T0, name="C")
    Cv = fem.Function(T0, name="C_v") if viscous else None
    rho = fem.Function(S0, name="rho")
    kap = fem.Function(S0, name="kappa")
    kapv = fem.Function(S0, name="kappa_v")
    chi = fem.Function(S0, name="chi")
    Czz = None
    if dim == 2:
        Czz = fem.Function(fem.functionspace(msh, ("DG", 0, (2, 3))), name="C_zz")
    return MaterialFields(dim, C, Cv, rho, kap, kapv, chi, Czz, False, False, False)


def _cell_materials(
    cell_tags: mesh.MeshTags | None, materials: Mapping[int, Material] | Material, ncells: int
) -> tuple[dict[int, Material], npt.NDArray[np.int64]]:
    """``(tag -> material, tag of each local cell)``; -1 for a cell without a material
    (one material: tag 0 everywhere)."""
    if not isinstance(materials, Mapping):
        return {0: materials}, np.zeros(ncells, dtype=np.int64)
    tagged = dict(materials)
    cell_mat = np.full(ncells, -1, dtype=np.int64)
    if cell_tags is not None:
        for tag in tagged:
            cell_mat[cell_tags.indices[cell_tags.values == tag]] = tag
    return tagged, cell_mat


def _set_material(
    f: MaterialFields, cells: npt.NDArray[np.int64], mat: Material, ncells: int
) -> None:
    """Write the coefficients of ``mat`` into the local ``cells`` of the fields (the
    deviatoric stiffness and the bulk moduli in nodal-pressure cells)."""
    dim = f.dim
    nv = 3 if dim == 2 else 6
    sdofs = _cell_dofs(f.rho.function_space, ncells)[cells]
    tdofs = _cell_dofs(f.C.function_space, ncells)[cells]
    Cfull = mat.voigt()
    if mat.formulation == "nodal_pressure":
        Cfull = deviatoric_block(mat.mu, dim)
        f.kappa.x.array[sdofs] = mat.kappa
        f.kappa_v.x.array[sdofs] = mat.tau_v * mat.kappa
        f.chi.x.array[sdofs] = 1.0
    Cd = plane_strain_block(Cfull) if dim == 2 else Cfull
    f.C.x.array.reshape(-1, nv * nv)[tdofs] = Cd.ravel()
    if f.C_v is not None:
        f.C_v.x.array.reshape(-1, nv * nv)[tdofs] = mat.tau_v * Cd.ravel()
    if mat.rho is not None:
        f.rho.x.array[sdofs] = mat.rho
    if f.C_zz is not None:
        row = Cfull[2, [0, 1, 5]]
        zdofs = _cell_dofs(f.C_zz.function_space, ncells)[cells]
        f.C_zz.x.array.reshape(-1, 6)[zdofs] = np.concatenate([row, mat.tau_v * row])


def _mpi_lor():
    from mpi4py import MPI

    return MPI.LOR


def _mpi_land():
    from mpi4py import MPI

    return MPI.LAND
