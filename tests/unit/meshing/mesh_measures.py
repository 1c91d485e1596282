"""Measures of the named groups of a mesh, summed over the ranks (helpers of the meshing tests)."""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

from mpi4py import MPI

import numpy as np
import ufl
from dolfinx import default_scalar_type, fem
from dolfinx.mesh import (
    compute_incident_entities,
    entities_to_geometry,
    exterior_facet_indices,
    meshtags,
)


def measure(md, name=None):
    """Area/volume of a cell group, length/area of a facet group (whole boundary if None).

    The group is re-tagged with id 1, so that one compiled form per cell type serves all
    groups (the JIT cache is keyed on the form, which includes the subdomain ids).
    """
    msh = md.mesh
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    if name is None:
        dim = tdim - 1
        entities = exterior_facet_indices(msh.topology)
    else:
        dim = md.physical_groups[name].dim
        tags = md.cell_tags if dim == tdim else md.facet_tags
        entities = tags.find(md.physical_groups[name].tag)
    assert dim in (tdim, tdim - 1)
    marker = meshtags(
        msh, dim, np.sort(entities).astype(np.int32), np.ones(len(entities), np.int32)
    )
    kind = "dx" if dim == tdim else "ds"
    one = fem.Constant(msh, default_scalar_type(1.0))
    form = fem.form(one * ufl.Measure(kind, domain=msh, subdomain_data=marker)(1))
    return msh.comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)


def count_owned(md, name):
    """Global number of cells/facets in a physical group."""
    group = md.physical_groups[name]
    tags = md.cell_tags if group.dim == md.mesh.topology.dim else md.facet_tags
    n_owned = md.mesh.topology.index_map(group.dim).size_local
    local = np.count_nonzero(tags.find(group.tag) < n_owned)
    return md.mesh.comm.allreduce(int(local), op=MPI.SUM)


def group_vertices(md, name):
    """Global vertex indices and coordinates of the vertices of a group (on every rank)."""
    msh = md.mesh
    group = md.physical_groups[name]
    tags = md.cell_tags if group.dim == msh.topology.dim else md.facet_tags
    msh.topology.create_connectivity(group.dim, 0)
    msh.topology.create_connectivity(0, msh.topology.dim)
    local = compute_incident_entities(msh.topology, tags.find(group.tag), group.dim, 0)
    glob = msh.topology.index_map(0).local_to_global(local)
    xyz = msh.geometry.x[entities_to_geometry(msh, 0, local).reshape(-1)]
    glob = np.concatenate(msh.comm.allgather(glob))
    xyz = np.concatenate(msh.comm.allgather(xyz))
    glob, first = np.unique(glob, return_index=True)
    return glob, xyz[first]
