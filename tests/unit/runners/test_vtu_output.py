"""The binary field files (``fields.pvd``, :mod:`bonecontact.runners.vtu`) read back the way
users read them (``bonecontact.plot.read_fields``) equal the fields written.

Reference: degree-1 Lagrange interpolants of linear functions are exact at the vertices
and cell-wise constant fields set from the cell midpoints are exact at the cell centres, so
the values read back are compared with the functions themselves evaluated at the read
coordinates (to 1e-12), on every cell type, in 2D and 3D, at two saved times, on any number
of ranks.  Each rank writes only its owned cells (nothing is gathered): the pieces' cells
add up to the mesh's.  The cell invariants of :class:`StressFields` (chunked) against a
stress with known principal values.
"""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import fem, mesh

from bonecontact.plot import read_fields
from bonecontact.runners.results import ResultsWriter, StressFields

COMM = MPI.COMM_WORLD
CELLS = {
    "triangle": (2, mesh.CellType.triangle),
    "quadrilateral": (2, mesh.CellType.quadrilateral),
    "tetrahedron": (3, mesh.CellType.tetrahedron),
    "hexahedron": (3, mesh.CellType.hexahedron),
}


def _u(x: np.ndarray, t: float, g: int) -> np.ndarray:
    """A linear vector field (exact in P1), changing with t."""
    rows = [x[0] + 2.0 * x[1] + t, 3.0 * x[1] - 0.5 * x[0], (x[2] - x[0]) * (1.0 + t)]
    return np.array(rows[:g])


def _s(x: np.ndarray, t: float, n: int) -> np.ndarray:
    """A cell field of n components, each a different linear function of the midpoint."""
    return np.array([(k + 1.0) * x[0] - x[1] + 0.25 * k * x[2] + t for k in range(n)])


def _mesh(cell: str) -> mesh.Mesh:
    g, ct = CELLS[cell]
    if g == 2:
        return mesh.create_rectangle(COMM, [[0.0, 0.0], [2.0, 1.0]], [7, 5], ct)
    return mesh.create_box(COMM, [[0.0, 0.0, 0.0], [2.0, 1.0, 1.5]], [4, 3, 3], ct)


def _fields(msh: mesh.Mesh, t: float) -> list[fem.Function]:
    g = msh.geometry.dim
    u = fem.Function(fem.functionspace(msh, ("Lagrange", 1, (g,))), name="displacement")
    u.interpolate(lambda x: _u(x, t, g))
    out = [u]
    for name, shape in (("stress", (3, 3)), ("von_mises", ()), ("principal_stress", (3,))):
        f = fem.Function(fem.functionspace(msh, ("DG", 0, shape)), name=name)
        n = int(np.prod(shape)) if shape else 1
        f.interpolate(lambda x, n=n: _s(x, t, n) if n > 1 else _s(x, t, 1)[0])
        out.append(f)
    return out


@pytest.mark.parametrize("cell", list(CELLS))
def test_fields_read_back_equal_the_written_ones(tmp_shared_path, cell):
    msh = _mesh(cell)
    g = msh.geometry.dim
    writer = ResultsWriter(COMM, tmp_shared_path, "vtu")
    times = (0.0, 1.5)
    for t in times:
        writer.fields(t, _fields(msh, t))
    writer.close()
    imap = msh.topology.index_map(msh.topology.dim)
    owned = COMM.allgather(imap.size_local)
    if COMM.rank != 0:
        COMM.barrier()
        return
    try:
        _check_files(tmp_shared_path, g, times, owned)
    finally:
        COMM.barrier()


def _check_files(directory: Path, g: int, times: tuple[float, ...], owned: list[int]) -> None:
    import pyvista

    reader = pyvista.get_reader(str(directory / "fields.pvd"))
    assert list(reader.time_values) == list(times)
    for k, t in enumerate(times):
        grid = read_fields(directory / "fields.pvd", k)
        assert grid.n_cells == sum(owned)
        x = np.asarray(grid.points).T
        u = np.asarray(grid.point_data["displacement"])
        assert u.shape == (x.shape[1], 3)  # (2D vectors padded with a zero component)
        exact = np.zeros_like(u)
        exact[:, :g] = _u(x, t, g).T
        assert np.abs(u - exact).max() <= 1e-12 * np.abs(exact).max()
        c = np.asarray(grid.cell_centers().points).T
        for name, n in (("stress", 9), ("von_mises", 1), ("principal_stress", 3)):
            got = np.asarray(grid.cell_data[name]).reshape(grid.n_cells, n)
            ref = _s(c, t, n).T
            assert np.abs(got - ref).max() <= 1e-12 * np.abs(ref).max(), name
    # one piece per rank and saved time, each with only its rank's owned cells
    for r, n in enumerate(owned):
        name = f"fields_p{r}_{len(times) - 1:06d}.vtu"
        assert pyvista.read(str(directory / name)).n_cells == n


@pytest.mark.parametrize("chunk", [7, 16384])
@pytest.mark.parametrize("cell", ["triangle", "tetrahedron"])
def test_stress_invariants_of_a_known_stress(monkeypatch, cell, chunk):
    """σ = R diag(3, 1, −2) Rᵀ (MPa) for a rotation R: principal stresses 3, 1, −2 and
    von Mises √19 MPa in every cell, evaluated in chunks of ``chunk`` cells."""
    monkeypatch.setattr(StressFields, "CHUNK", chunk)
    msh = _mesh(cell)
    a, b = 0.3, -1.1
    Rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    R = Rz @ Rx
    sigma = 1e6 * R @ np.diag([3.0, 1.0, -2.0]) @ R.T
    given = fem.Function(fem.functionspace(msh, ("DG", 0, (3, 3))))
    given.x.array[:] = np.tile(sigma.ravel(), given.x.array.size // 9)
    fields = StressFields(msh, given)
    fields.update()
    p = fields.principal.x.array.reshape(-1, 3)
    assert np.abs(p - 1e6 * np.array([3.0, 1.0, -2.0])).max() < 1e-9 * 1e6
    assert np.abs(fields.von_mises.x.array - 1e6 * np.sqrt(19.0)).max() < 1e-9 * 1e6
    s = fields.stress.x.array.reshape(-1, 3, 3)
    assert np.abs(s - sigma).max() < 1e-9 * 1e6


@pytest.mark.parametrize("cell", ["triangle", "tetrahedron"])
def test_released_stress_fields_are_made_again_the_same(cell):
    """A released StressFields (its arrays freed between records) gives, at its next
    update, the values of one never released (bit for bit)."""
    msh = _mesh(cell)
    given = fem.Function(fem.functionspace(msh, ("DG", 0, (3, 3))))
    rng = np.random.default_rng(3)
    given.x.array[:] = rng.standard_normal(given.x.array.size)
    kept, freed = StressFields(msh, given), StressFields(msh, given)
    kept.update()
    freed.update()
    freed.release()
    assert freed.stress is None and freed.von_mises is None and freed.principal is None
    freed.update()
    for name in ("stress", "von_mises", "principal"):
        assert np.array_equal(getattr(freed, name).x.array, getattr(kept, name).x.array), name
