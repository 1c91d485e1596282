"""Reading gmsh mesh files into distributed DOLFINx meshes."""

from __future__ import annotations

from contextlib import nullcontext
from pathlib import Path

from mpi4py import MPI

import gmsh
from dolfinx.io.gmsh import MeshData, model_to_mesh

from bonecontact.meshing.session import gmsh_session

__all__ = ["read_gmsh_mesh"]


def read_gmsh_mesh(path: str | Path, comm: MPI.Comm, gdim: int) -> tuple[int, MeshData | None]:
    """Open a gmsh file on rank 0 only (quietly) and build the distributed mesh (collective).

    Parameters
    ----------
    path
        gmsh ``.msh`` file.
    comm
        Communicator of the mesh.
    gdim
        Geometric dimension expected (2 or 3).

    Returns
    -------
    (int, dolfinx.io.gmsh.MeshData or None)
        The dimension of the file's mesh and its mesh data; the mesh data is ``None``
        when the dimension is not ``gdim``.

    Raises
    ------
    ValueError
        On every rank, when gmsh cannot read the file or it holds no elements.
    """
    dim, err = -1, None
    with gmsh_session() if comm.rank == 0 else nullcontext():
        if comm.rank == 0:
            try:
                gmsh.clear()
                gmsh.open(str(path))
                dim = gmsh.model.getDimension()
            except Exception as exc:  # gmsh raises plain Exceptions
                err = str(exc)
        dim, err = comm.bcast((dim, err), root=0)
        md = None
        try:
            if err is None and dim == gdim:
                md = model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=gdim)
        finally:
            if comm.rank == 0:
                gmsh.clear()
    if err is not None or dim < 1:
        raise ValueError(err or "no elements")
    return dim, md
