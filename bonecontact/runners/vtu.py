"""Binary VTK output of a run's fields: ``<stem>.pvd``, one grid per saved time.

Each rank writes its own piece of every saved time (``<stem>_p<rank>_<k>.vtu``: its owned
cells and the vertices they use, raw little-endian binary appended to the XML header,
written straight from the functions' arrays); with several ranks rank 0 adds the
``<stem><k>.pvtu`` that lists the pieces.  Nothing is gathered.  After every saved time
rank 0 rewrites the small ``<stem>.pvd`` index, so a run that fails leaves a readable
series.  ParaView, VTK and pyvista read it (``bonecontact.plot.read_fields``).

Fields: continuous degree-1 Lagrange functions as point data (2D vectors padded to three
components), cell-wise constant (DG0) ones as cell data; tensors as 9 components.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import BinaryIO

from mpi4py import MPI

import dolfinx
import numpy as np
import numpy.typing as npt
from dolfinx import fem

__all__ = ["VtuSeries"]

#: VTK cell types of the degree-1 cells
VTK_CELL = {"triangle": 5, "quadrilateral": 9, "tetrahedron": 10, "hexahedron": 12}
#: values per chunk when an array is written through an index (bounds the copy)
CHUNK = 1 << 20
_VTK_TYPE = {np.dtype("float64"): "Float64", np.dtype("int64"): "Int64", np.dtype("uint8"): "UInt8"}


class _Piece:
    """This rank's owned cells of a mesh in VTK form: the vertices they use (renumbered),
    the connectivity in VTK's vertex order, and each used vertex's geometry node."""

    def __init__(self, msh: dolfinx.mesh.Mesh):
        cmap = msh.geometry.cmaps[0]
        name = msh.topology.cell_name()
        if cmap.degree != 1 or name not in VTK_CELL:
            raise ValueError(
                f"binary VTK output: degree-1 {', '.join(VTK_CELL)} meshes only, "
                f"got degree {cmap.degree} {name}"
            )
        self.mesh = msh
        ncells = msh.topology.index_map(msh.topology.dim).size_local
        x_dofmap = msh.geometry.dofmaps[0][:ncells]
        perm = np.asarray(dolfinx.cpp.io.perm_vtk(msh.topology.cell_type, x_dofmap.shape[1]))
        #: geometry node of every written point
        self.nodes, conn = np.unique(x_dofmap[:, perm], return_inverse=True)
        self.connectivity = conn.reshape(-1).astype(np.int64)
        self.ncells = ncells
        self.offsets = np.arange(1, ncells + 1, dtype=np.int64) * x_dofmap.shape[1]
        self.types = np.full(ncells, VTK_CELL[name], dtype=np.uint8)
        self._cells = x_dofmap  # (for the point → dof maps)
        self._dofs: dict[int, npt.NDArray[np.int32]] = {}

    def point_dofs(self, V: fem.FunctionSpace) -> npt.NDArray[np.int32]:
        """The dof (block) of every written point in the degree-1 space ``V``."""
        key = id(V.dofmap)
        if key not in self._dofs:
            node_dof = np.empty(self.mesh.geometry.x.shape[0], dtype=np.int32)
            node_dof[self._cells.ravel()] = V.dofmap.list[: self.ncells].ravel()
            self._dofs[key] = node_dof[self.nodes]
        return self._dofs[key]


def _kind(f: fem.Function) -> str:
    """``"point"`` (continuous degree 1) or ``"cell"`` (DG0) data; else an error."""
    e = f.function_space.ufl_element()
    if e.degree == 1 and not e.discontinuous:
        return "point"
    if e.degree == 0:
        return "cell"
    raise ValueError(
        f"binary VTK output: field {f.name!r} is neither continuous degree 1 nor "
        f"cell-wise constant (degree {e.degree})"
    )


class _Array:
    """One data array of a piece: its XML attributes and how to write its bytes."""

    def __init__(
        self,
        name: str,
        values: npt.NDArray,
        components: int,
        index: npt.NDArray | None = None,
        pad: int = 0,
    ):
        self.name, self.values, self.components = name, values, components
        self.index, self.pad = index, pad
        rows = values.shape[0] if index is None else index.size
        self.nbytes = rows * (components + pad) * values.dtype.itemsize

    def xml(self, offset: int) -> str:
        name = f' Name="{self.name}"' if self.name else ""
        comps = self.components + self.pad
        return (
            f'<DataArray type="{_VTK_TYPE[self.values.dtype]}"{name} '
            f'NumberOfComponents="{comps}" format="appended" offset="{offset}"/>'
        )

    def write(self, f: BinaryIO) -> None:
        """The block: its byte count (UInt64), then the values row by row."""
        f.write(np.uint64(self.nbytes).tobytes())
        v = self.values
        if self.index is None and not self.pad:
            f.write(memoryview(np.ascontiguousarray(v)).cast("B"))
            return
        rows = np.arange(v.shape[0]) if self.index is None else self.index
        step = max(CHUNK // (self.components + self.pad), 1)
        for i in range(0, rows.size, step):
            block = v[rows[i : i + step]]
            if self.pad:
                block = np.hstack([block, np.zeros((block.shape[0], self.pad), v.dtype)])
            f.write(block.tobytes())


class VtuSeries:
    """A time series of binary ``.vtu`` pieces with its ``.pvd`` index (collective).

    Parameters
    ----------
    comm
        Communicator of the run.
    path
        The ``.pvd`` file; the pieces go beside it.
    """

    def __init__(self, comm: MPI.Comm, path: Path):
        self.comm = comm
        self.path = Path(path)
        self.stem = self.path.with_suffix("").name
        self.times: list[tuple[float, str]] = []
        self._piece: _Piece | None = None

    def write(self, t: float, functions: Sequence[fem.Function]) -> None:
        """Write ``functions`` (on one mesh) at time ``t`` and update the index."""
        msh = functions[0].function_space.mesh
        if self._piece is None or self._piece.mesh is not msh:
            self._piece = _Piece(msh)
        k = len(self.times)
        piece = f"{self.stem}_p{self.comm.rank}_{k:06d}.vtu"
        point, cell = self._arrays(functions)
        _write_piece(self.path.parent / piece, self._piece, point, cell)
        self.comm.barrier()
        if self.comm.size == 1:
            self.times.append((float(t), piece))
        else:
            self.times.append((float(t), f"{self.stem}{k:06d}.pvtu"))
            if self.comm.rank == 0:
                pvtu = self.path.parent / self.times[-1][1]
                _write_pvtu(pvtu, self.stem, k, self.comm.size, point, cell)
        if self.comm.rank == 0:
            _write_pvd(self.path, self.times)
        self.comm.barrier()

    def release(self) -> None:
        """Free the mesh's VTK form (connectivity, offsets, point maps: about 42 bytes per
        cell) until the next :meth:`write` makes it again (issue 28)."""
        self._piece = None

    def _arrays(self, functions: Sequence[fem.Function]) -> tuple[list[_Array], list[_Array]]:
        """Point and cell data arrays of ``functions`` (views of their arrays)."""
        point, cell = [], []
        for f in functions:
            V = f.function_space
            bs = int(np.prod(V.value_shape)) if V.value_shape else 1
            values = f.x.array.reshape(-1, bs) if bs > 1 else f.x.array
            if _kind(f) == "point":
                pad = 3 - bs if bs == 2 else 0
                idx = self._piece.point_dofs(V)
                point.append(_Array(f.name, values, bs, idx, pad))
            else:
                dofs = V.dofmap.list[: self._piece.ncells, 0]
                if np.array_equal(dofs, np.arange(dofs.size)):
                    cell.append(_Array(f.name, values[: dofs.size], bs))
                else:
                    cell.append(_Array(f.name, values, bs, dofs))
        return point, cell


def _write_piece(path: Path, piece: _Piece, point: list[_Array], cell: list[_Array]) -> None:
    """This rank's ``.vtu``: the XML header, then the arrays' raw bytes."""
    x = piece.mesh.geometry.x
    grid = [
        _Array("", x, 3, piece.nodes),
        _Array("connectivity", piece.connectivity, 1),
        _Array("offsets", piece.offsets, 1),
        _Array("types", piece.types, 1),
    ]
    offsets, pos = [], 0
    for a in point + cell + grid:
        offsets.append(pos)
        pos += 8 + a.nbytes
    it = iter(offsets)
    head = [
        '<?xml version="1.0"?>',
        '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" '
        'header_type="UInt64">',
        "<UnstructuredGrid>",
        f'<Piece NumberOfPoints="{piece.nodes.size}" NumberOfCells="{piece.ncells}">',
        "<PointData>",
        *[a.xml(next(it)) for a in point],
        "</PointData>",
        "<CellData>",
        *[a.xml(next(it)) for a in cell],
        "</CellData>",
        f"<Points>{grid[0].xml(next(it))}</Points>",
        "<Cells>",
        *[a.xml(next(it)) for a in grid[1:]],
        "</Cells>",
        "</Piece>",
        "</UnstructuredGrid>",
        '<AppendedData encoding="raw">',
        "_",
    ]
    with open(path, "wb") as f:
        f.write("\n".join(head).encode())
        for a in point + cell + grid:
            a.write(f)
        f.write(b"\n</AppendedData>\n</VTKFile>\n")


def _pdata(tag: str, arrays: list[_Array]) -> list[str]:
    rows = [
        f'<PDataArray type="Float64" Name="{a.name}" NumberOfComponents="{a.components + a.pad}"/>'
        for a in arrays
    ]
    return [f"<{tag}>", *rows, f"</{tag}>"]


def _write_pvtu(
    path: Path, stem: str, k: int, ranks: int, point: list[_Array], cell: list[_Array]
) -> None:
    """The ``.pvtu`` of saved time ``k``: the arrays and the ranks' pieces (rank 0)."""
    lines = [
        '<?xml version="1.0"?>',
        '<VTKFile type="PUnstructuredGrid" version="1.0" byte_order="LittleEndian" '
        'header_type="UInt64">',
        '<PUnstructuredGrid GhostLevel="0">',
        *_pdata("PPointData", point),
        *_pdata("PCellData", cell),
        '<PPoints><PDataArray type="Float64" NumberOfComponents="3"/></PPoints>',
        *[f'<Piece Source="{stem}_p{r}_{k:06d}.vtu"/>' for r in range(ranks)],
        "</PUnstructuredGrid>",
        "</VTKFile>",
    ]
    path.write_text("\n".join(lines) + "\n")


def _write_pvd(path: Path, times: list[tuple[float, str]]) -> None:
    """The index of the saved times, replaced in one step (rank 0)."""
    rows = [f'<DataSet timestep="{t!r}" part="0" file="{name}"/>' for t, name in times]
    text = "\n".join(
        [
            '<?xml version="1.0"?>',
            '<VTKFile type="Collection" version="1.0" byte_order="LittleEndian">',
            "<Collection>",
            *rows,
            "</Collection>",
            "</VTKFile>",
        ]
    )
    tmp = path.with_suffix(".pvd.tmp")
    tmp.write_text(text + "\n")
    os.replace(tmp, path)
