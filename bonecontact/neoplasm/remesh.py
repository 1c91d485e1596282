"""Moving boundaries, remeshing and field transfer for growing neoplasms.

Meshes made by gmsh on rank 0 (inside a polygon or a closed surface, a moved boundary
with retries, a ball), the boundary gathered on every rank and keyed by input node, the
harmonic mesh motion with one factorised Laplacian, and the non-matching transfer of
fields with a coverage check.  Methods: docs/theory/remeshing.md.  A 2D boundary is one
closed counter-clockwise curve; curvature is div n, positive for a convex region.
"""

from __future__ import annotations

import gc
from collections.abc import Callable, Sequence
from contextlib import nullcontext
from dataclasses import dataclass

from mpi4py import MPI
from petsc4py import PETSc

import gmsh
import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem, geometry
from dolfinx import mesh as dmesh
from dolfinx.fem import petsc as fem_petsc
from dolfinx.io import gmsh as gmsh_io

from bonecontact.common.errors import RunError
from bonecontact.common.geometry import signed_polygon_area
from bonecontact.meshing.builder import MeshingError
from bonecontact.meshing.session import gmsh_session

__all__ = [
    "REMESH_RETRIES",
    "Boundary",
    "CoverageError",
    "DirichletLaplacian",
    "MeshMotion",
    "RemeshError",
    "gather_boundary",
    "mesh_from_cells",
    "moved_curve_mesh",
    "moved_surface_mesh",
    "polygon_mesh",
    "release_replaced_meshes",
    "resample_closed_curve",
    "smooth_curve",
    "smooth_surface",
    "snap_to_grid",
    "sphere_mesh",
    "surface_mesh",
    "transfer",
    "transfer_fields",
    "vertex_to_geometry",
]


def release_replaced_meshes(*holders: DirichletLaplacian | MeshMotion | None) -> None:
    """Free what a remesh has replaced: ``destroy()`` the PETSc objects of ``holders`` (the
    old mesh's Laplacian and mesh motion), then collect the old mesh's Python objects.
    Collective: call it on every rank at the same point, after the new mesh is set up.

    In parallel, petsc4py does not destroy a PETSc object that Python's garbage collector
    frees: it parks it until a collective clean-up on its communicator, which for a
    replaced mesh never comes.  Each parked solver keeps the old mesh's duplicated MPI
    communicators alive, so a growth run that remeshes every step exhausted MPICH's 2048
    communicators per process ("Too many communicators") after about 200 remeshes on 2
    ranks.  Hence the explicit ``destroy()``.
    """
    for holder in holders:
        if holder is not None:
            holder.destroy()
    gc.collect()


#: gmsh failed to mesh a moved boundary, or the boundary is not a simple closed curve: the
#: one meshing failure type of the package (the former name, kept for its users).
RemeshError = MeshingError


#: Deprecated alias of :class:`~bonecontact.common.errors.RunError`, raised when target
#: points of a transfer lie outside the source mesh (beyond the extrapolation band);
#: ``except CoverageError`` catches every ``RunError``.
CoverageError = RunError


# ----------------------------------------------------------------------------- gmsh
SNAP_BITS = 32


def snap_to_grid(points: npt.ArrayLike, bits: int = SNAP_BITS) -> npt.NDArray[np.float64]:
    """Round coordinates to a grid of spacing ``2**(floor(log2(extent)) - bits)``.

    ``extent`` is the largest side of the bounding box, so the spacing is a power of two
    between ``2**-bits`` and ``2**(1-bits)`` of it (``bits = 32``: 2.3e-10 to 4.7e-10)
    and the rounding is exact arithmetic.  What gmsh meshes is snapped: a boundary that
    differs only by round-off (a solve on another number of ranks) then gives the same
    gmsh input, hence the same mesh, unless a coordinate straddles a half-grid point
    (probability about round-off / spacing, 1e-6 per coordinate).
    """
    p = np.array(points, dtype=np.float64)
    extent = float(np.max(np.ptp(p, axis=0))) if p.size else 0.0
    if not extent > 0.0 or not np.isfinite(extent):
        return p
    q = 2.0 ** (np.floor(np.log2(extent)) - bits)
    return np.round(p / q) * q


def _run_gmsh(name: str, dim: int, build, comm: MPI.Comm) -> dmesh.Mesh:
    """Build and mesh a gmsh model on rank 0, then distribute it over ``comm``.

    Only the cells are a physical group and the mesh is made without tags (the boundary
    is found from the topology): tags would cost a distributed tag construction per
    remesh."""
    error = None
    with gmsh_session(name) if comm.rank == 0 else nullcontext():
        if comm.rank == 0:
            try:
                gmsh.option.setNumber("General.NumThreads", 1)  # reproducible meshes
                build()
                gmsh.model.mesh.generate(dim)
            except Exception as exc:  # reported collectively below
                error = f"{type(exc).__name__}: {exc}"
        error = comm.bcast(error, root=0)
        if error is not None:
            raise RemeshError(f"{name}: {error}")
        return _distribute_cells(comm, dim)


def _distribute_cells(comm: MPI.Comm, dim: int) -> dmesh.Mesh:
    """The cells of dimension ``dim`` of the physical groups of rank 0's gmsh model as a
    distributed mesh, without tags (the cells, nodes and partitioner of
    :func:`dolfinx.io.gmsh.model_to_mesh`, so the same mesh)."""
    types, cells, x = None, None, np.empty((0, dim))
    if comm.rank == 0:
        x = gmsh_io.extract_geometry(gmsh.model)[:, :dim]
        topologies, _ = gmsh_io.extract_topology_and_markers(gmsh.model)
        types = [t for t in topologies if gmsh.model.mesh.getElementProperties(t)[1] == dim]
        if len(types) == 1:
            cells = np.asarray(topologies[types[0]]["topology"], dtype=np.int64)
    types = comm.bcast([int(t) for t in types] if types is not None else None, root=0)
    if len(types) != 1:  # collectively
        raise RemeshError(f"expected one cell type of dimension {dim}, got {types}")
    etype = types[0]
    domain = gmsh_io.ufl_mesh(etype, dim, dtype=np.float64)
    nodes = domain.ufl_coordinate_element().basix_element.dim
    if cells is None:
        cells = np.empty((0, nodes), dtype=np.int64)
    perm = gmsh_io.cell_perm_array(dmesh.to_type(str(domain.ufl_cell())), nodes)
    return mesh_from_cells(comm, cells[:, perm].copy(), x, dim)


#: gmsh element type of the cells of a remeshed 2D / 3D neoplasm (P1 triangles / tetrahedra)
_GMSH_SIMPLEX = {2: 2, 3: 4}


def mesh_from_cells(
    comm: MPI.Comm, cells: npt.NDArray[np.int64], x: npt.NDArray[np.float64], dim: int
) -> dmesh.Mesh:
    """The distributed P1 simplex mesh of ``cells`` (DOLFINx node order, rows of ``x``)
    and ``x``, given on rank 0 (empty elsewhere), with the partitioner every remesh uses.

    The same arrays give the same mesh (partition, numbering, ``input_global_indices`` =
    rows of ``x``, ``original_cell_index`` = rows of ``cells``) on the same number of ranks:
    a restart rebuilds the mesh of a checkpoint with it (collective)."""
    domain = gmsh_io.ufl_mesh(_GMSH_SIMPLEX[dim], dim, dtype=np.float64)
    partitioner = dmesh.create_cell_partitioner(dmesh.GhostMode.shared_facet, 2)
    return dmesh.create_mesh(comm, cells, domain, x, partitioner)


def polygon_mesh(points: npt.ArrayLike, h: float, comm: MPI.Comm) -> dmesh.Mesh:
    """Triangulate the inside of a closed polygon.

    Parameters
    ----------
    points
        ``(N, 2)`` polygon nodes, in order (either orientation), the last not repeating the
        first.  Only rank 0's array is used.
    h
        Target interior mesh size.
    comm
        Communicator of the resulting mesh.

    Returns
    -------
    The distributed mesh; its boundary vertices are exactly ``points`` snapped to a grid
    (:func:`snap_to_grid`: about 3e-10 of the extent).
    """
    pts = snap_to_grid(points) if comm.rank == 0 else None

    def build() -> None:
        if pts.ndim != 2 or pts.shape[1] != 2 or pts.shape[0] < 3:
            raise ValueError(f"points must have shape (N >= 3, 2), got {pts.shape}")
        geo = gmsh.model.geo
        tags = [geo.addPoint(x, y, 0.0, h) for x, y in pts]
        n = len(tags)
        lines = [geo.addLine(tags[i], tags[(i + 1) % n]) for i in range(n)]
        loop = geo.addCurveLoop(lines)
        surf = geo.addPlaneSurface([loop])
        geo.synchronize()
        for line in lines:
            gmsh.model.mesh.setTransfiniteCurve(line, 2)
        gmsh.model.addPhysicalGroup(2, [surf], 1, name="tumour")
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.Algorithm", 6)

    return _run_gmsh("polygon", 2, build, comm)


def surface_mesh(
    points: npt.ArrayLike, triangles: npt.ArrayLike, h: float, comm: MPI.Comm
) -> dmesh.Mesh:
    """Tetrahedralise the inside of a closed triangulated surface; the surface is kept.

    ``points`` ``(N, 3)`` and ``triangles`` ``(M, 3)`` (indices into ``points``) are read
    on rank 0.  The boundary vertices of the result are exactly ``points`` snapped to a
    grid (:func:`snap_to_grid`: about 3e-10 of the extent).  gmsh's
    Delaunay algorithm: its HXT algorithm is about twice as fast from 10⁴ cells on, but
    its mesh changes with round-off differences of the surface, so a growing tumour would
    no longer be the same on any number of ranks (radius 2e-7 apart after two remeshes).
    """
    pts = snap_to_grid(points) if comm.rank == 0 else None
    tri = np.asarray(triangles, dtype=np.int64) if comm.rank == 0 else None

    def build() -> None:
        s = gmsh.model.addDiscreteEntity(2)
        gmsh.model.mesh.addNodes(2, s, np.arange(1, len(pts) + 1), pts.ravel())
        gmsh.model.mesh.addElementsByType(s, 2, [], (tri + 1).ravel())
        sl = gmsh.model.geo.addSurfaceLoop([s])
        vol = gmsh.model.geo.addVolume([sl])
        gmsh.model.geo.synchronize()
        gmsh.model.addPhysicalGroup(3, [vol], 1, name="tumour")
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)

    return _run_gmsh("surface", 3, build, comm)


def smooth_surface(
    points: npt.ArrayLike,
    triangles: npt.ArrayLike,
    passes: int = 5,
    lam: float = 0.5,
    mu: float = -0.53,
) -> npt.NDArray[np.float64]:
    """Taubin λ|μ smoothing of a closed triangulated surface (vertex positions only).

    Each pass moves every vertex by ``λ`` then by ``μ`` (< −λ) times the offset to the
    mean of its edge neighbours: the first step smooths, the second inflates back, so
    noise at the scale of the edges is removed without the shrinkage of plain Laplacian
    smoothing (Taubin 1995).  Used to repair a moved surface that gmsh can no longer
    tetrahedralise (self-intersections at the scale of the mesh).
    """
    x = np.array(points, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    n = x.shape[0]
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    e = np.unique(np.sort(e, axis=1), axis=0)
    rows = np.concatenate([e[:, 0], e[:, 1]])
    cols = np.concatenate([e[:, 1], e[:, 0]])
    deg = np.bincount(rows, minlength=n).astype(np.float64)

    def offset(y: np.ndarray) -> np.ndarray:
        s = np.zeros_like(y)
        np.add.at(s, rows, y[cols])
        return s / deg[:, None] - y

    for _ in range(passes):
        x += lam * offset(x)
        x += mu * offset(x)
    return x


#: What a remesh tries after gmsh fails on the moved boundary, in order: (smooth the
#: boundary first, mesh size as a fraction of the requested one).  The boundary as it is,
#: with the requested size, is always tried first.
REMESH_RETRIES: tuple[tuple[bool, float], ...] = ((True, 1.0), (True, 0.5))


def _with_retries(name: str, attempt: Callable[[bool, float], dmesh.Mesh]) -> tuple:
    """``attempt(smooth, factor)`` for the boundary as it is, then for every entry of
    :data:`REMESH_RETRIES` until one succeeds (collective: gmsh's errors are broadcast).

    Returns ``(mesh, smoothed)``; raises :class:`RemeshError` naming every attempt."""
    errors = []
    for smooth, factor in ((False, 1.0), *REMESH_RETRIES):
        try:
            return attempt(smooth, factor), smooth
        except RemeshError as exc:
            how = ("smoothed boundary" if smooth else "boundary as moved") + f", size × {factor:g}"
            errors.append(f"{how}: {exc}")
    raise RemeshError(f"{name}: gmsh failed {len(errors)} times (" + "; ".join(errors) + ")")


def moved_surface_mesh(
    points: npt.ArrayLike, triangles: npt.ArrayLike, h: float, comm: MPI.Comm
) -> tuple[dmesh.Mesh, bool]:
    """Tetrahedralise a moved closed surface, repairing it if gmsh cannot.

    The surface is kept as it is when possible (:func:`surface_mesh`).  A surface moved by
    a noisy nodal velocity can intersect itself at the scale of its edges ("PLC Error: a
    segment and a facet intersect"); it is then Taubin-smoothed
    (:func:`smooth_surface`, rank 0) and tetrahedralised again, then with half the mesh
    size (:data:`REMESH_RETRIES`), before the remesh fails.

    Returns
    -------
    (mesh, smoothed)
        The distributed mesh and whether the surface had to be smoothed.
    """
    smoothed = smooth_surface(points, triangles) if comm.rank == 0 else None

    def attempt(smooth: bool, factor: float) -> dmesh.Mesh:
        return surface_mesh(smoothed if smooth else points, triangles, factor * h, comm)

    return _with_retries("moved surface", attempt)


def smooth_curve(
    points: npt.ArrayLike, passes: int = 5, lam: float = 0.5, mu: float = -0.53
) -> npt.NDArray[np.float64]:
    """Taubin λ|μ smoothing of a closed polyline (the 2D counterpart of
    :func:`smooth_surface`: each node's neighbours are the previous and next node)."""
    x = np.array(points, dtype=np.float64)
    for _ in range(passes):
        for f in (lam, mu):
            x += f * (0.5 * (np.roll(x, 1, axis=0) + np.roll(x, -1, axis=0)) - x)
    return x


def moved_curve_mesh(points: npt.ArrayLike, h: float, comm: MPI.Comm) -> tuple[dmesh.Mesh, bool]:
    """Triangulate the inside of a moved closed curve, resampled uniformly at ``h``
    (:func:`resample_closed_curve`, :func:`polygon_mesh`); if gmsh fails, the curve is
    Taubin-smoothed (:func:`smooth_curve`) and meshed again, then with half the size
    (:data:`REMESH_RETRIES`), before the remesh fails.

    ``points`` are read on rank 0.  Returns ``(mesh, smoothed)``.
    """
    raw = np.asarray(points, dtype=np.float64) if comm.rank == 0 else None
    smoothed = smooth_curve(raw) if comm.rank == 0 else None

    def attempt(smooth: bool, factor: float) -> dmesh.Mesh:
        size = factor * h
        curve = None
        if comm.rank == 0:
            curve = resample_closed_curve(smoothed if smooth else raw, size)
        return polygon_mesh(curve, size, comm)

    return _with_retries("moved curve", attempt)


def sphere_mesh(
    radius: float, h: float, comm: MPI.Comm, centre: tuple[float, float, float] = (0.0, 0.0, 0.0)
) -> dmesh.Mesh:
    """A tetrahedral ball of the given radius and mesh size."""

    def build() -> None:
        ball = gmsh.model.occ.addSphere(*centre, radius)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(3, [ball], 1, name="tumour")
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.MeshSizeMin", h)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)

    return _run_gmsh("sphere", 3, build, comm)


# ----------------------------------------------------------------------------- boundary
def vertex_to_geometry(msh: dmesh.Mesh) -> npt.NDArray[np.int32]:
    """Geometry node of each local vertex (affine P1 geometry)."""
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim, 0)
    c2v = msh.topology.connectivity(tdim, 0).array.reshape(-1, tdim + 1)
    gdm = msh.geometry.dofmaps[0] if hasattr(msh.geometry, "dofmaps") else msh.geometry.dofmap
    nv = msh.topology.index_map(0).size_local + msh.topology.index_map(0).num_ghosts
    out = np.empty(nv, dtype=np.int32)
    out[c2v.ravel()] = np.asarray(gdm)[: c2v.shape[0], : tdim + 1].ravel()
    return out


@dataclass
class Boundary:
    """The exterior boundary of a mesh, replicated on every rank.

    Attributes
    ----------
    points
        ``(N, gdim)`` boundary vertex coordinates.  2D: in order along the closed loop,
        counter-clockwise.
    keys
        ``(N,)`` input (gmsh) node index of each point: partition independent.
    facets
        2D: ``(N, 2)`` consecutive pairs ``(i, i+1 mod N)``; 3D: ``(M, 3)`` triangles
        (indices into ``points``) oriented with the outward normal.
    """

    points: npt.NDArray[np.float64]
    keys: npt.NDArray[np.int64]
    facets: npt.NDArray[np.int64]

    @property
    def gdim(self) -> int:
        return self.points.shape[1]


def _owned_exterior_facets(msh: dmesh.Mesh) -> npt.NDArray[np.int32]:
    fdim = msh.topology.dim - 1
    msh.topology.create_connectivity(fdim, msh.topology.dim)
    facets = dmesh.exterior_facet_indices(msh.topology)
    return facets[facets < msh.topology.index_map(fdim).size_local]


def _canonical_triangles(tri: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Triangles in a partition-independent order: each rotated (orientation kept) to start
    at its smallest vertex index, then sorted lexicographically."""
    start = np.argmin(tri, axis=1)
    tri = tri[np.arange(len(tri))[:, None], (start[:, None] + np.arange(3)) % 3]
    return tri[np.lexsort(tri.T[::-1])]


def gather_boundary(msh: dmesh.Mesh) -> Boundary:
    """Gather the exterior boundary of ``msh`` to every rank (only boundary data moves).

    The result does not depend on the partition: points in the order of their input
    (gmsh) node index (2D: along the loop from the lowest index), 3D triangles in the
    order of :func:`_canonical_triangles`."""
    comm = msh.comm
    tdim = msh.topology.dim
    fdim = tdim - 1
    gdim = msh.geometry.dim
    facets = _owned_exterior_facets(msh)
    msh.topology.create_connectivity(fdim, 0)
    msh.topology.create_connectivity(fdim, tdim)
    msh.topology.create_connectivity(tdim, 0)
    f2v = msh.topology.connectivity(fdim, 0).array.reshape(-1, tdim)[facets]
    v2g = vertex_to_geometry(msh)
    keys = np.asarray(msh.geometry.input_global_indices, dtype=np.int64)[v2g[f2v]]
    xyz = msh.geometry.x[v2g[f2v], :gdim]
    # outward orientation: compare with the opposite vertex of the (unique) cell
    f2c = msh.topology.connectivity(fdim, tdim)
    c2v = msh.topology.connectivity(tdim, 0).array.reshape(-1, tdim + 1)
    cells = f2c.array[f2c.offsets[facets]]  # the first (only) cell of each facet
    centroid = msh.geometry.x[v2g[c2v[cells]], :gdim].mean(axis=1)
    if tdim == 2:
        t = xyz[:, 1] - xyz[:, 0]
        nrm = np.column_stack([t[:, 1], -t[:, 0]])  # right normal of the directed edge
    else:
        nrm = np.cross(xyz[:, 1] - xyz[:, 0], xyz[:, 2] - xyz[:, 0])
    flip = np.einsum("ij,ij->i", nrm, xyz.mean(axis=1) - centroid) < 0
    if tdim == 2:
        keys[flip] = keys[flip][:, ::-1]
        xyz[flip] = xyz[flip][:, ::-1]
    else:
        keys[flip] = keys[flip][:, [0, 2, 1]]
        xyz[flip] = xyz[flip][:, [0, 2, 1]]
    all_keys = np.concatenate(comm.allgather(keys)).reshape(-1, tdim)
    all_xyz = np.concatenate(comm.allgather(xyz)).reshape(-1, tdim, gdim)
    ukeys, first, inverse = np.unique(all_keys.ravel(), return_index=True, return_inverse=True)
    points = all_xyz.reshape(-1, gdim)[first]
    conn = inverse.reshape(-1, tdim)
    if tdim == 3:
        return Boundary(points, ukeys, _canonical_triangles(conn.astype(np.int64)))
    # 2D: the edges (a -> b) are oriented with the outward normal on the right, i.e. the
    # domain on the left for a counter-clockwise outer loop; chain them from the lowest key
    nxt = np.full(len(ukeys), -1, dtype=np.int64)
    nxt[conn[:, 0]] = conn[:, 1]
    if np.any(nxt < 0) or len(conn) != len(ukeys):
        raise RemeshError("boundary is not a closed curve")
    order = np.empty(len(ukeys), dtype=np.int64)
    i = 0
    for k in range(len(ukeys)):
        order[k] = i
        i = nxt[i]
        if i == 0 and k + 1 < len(ukeys):
            raise RemeshError("boundary has more than one closed curve (holes are not supported)")
    # right normal outward  <=>  traversal clockwise?  enforce counter-clockwise explicitly
    pts = points[order]
    if signed_polygon_area(pts) < 0:
        order = np.concatenate([order[:1], order[1:][::-1]])
        pts = points[order]
    n = len(order)
    return Boundary(pts, ukeys[order], np.column_stack([np.arange(n), (np.arange(n) + 1) % n]))


def resample_closed_curve(
    points: npt.ArrayLike, h: float | None = None, n: int | None = None
) -> npt.NDArray[np.float64]:
    """Redistribute the nodes of a closed 2D curve uniformly in arclength.

    A periodic cubic spline is passed through the nodes (parametrised by chord length,
    starting at ``points[0]``, which stays a node) and sampled at ``n`` equally spaced
    arclength values (``n = max(8, round(L / h))`` when ``n`` is not given).  The nodes
    are first snapped to a grid (:func:`snap_to_grid`), so that curves differing by
    round-off give the same result.
    """
    from scipy.interpolate import CubicSpline

    p = snap_to_grid(points)
    chord = np.linalg.norm(np.diff(np.vstack([p, p[:1]]), axis=0), axis=1)
    if np.any(chord <= 0):
        raise RemeshError("closed curve has coincident consecutive nodes")
    s = np.concatenate([[0.0], np.cumsum(chord)])
    spline = CubicSpline(s, np.vstack([p, p[:1]]), bc_type="periodic")
    # arclength of the spline itself (Gauss quadrature per interval)
    g, w = np.polynomial.legendre.leggauss(5)
    mid = 0.5 * (s[1:] + s[:-1])[:, None]
    half = 0.5 * chord[:, None]
    speed = np.linalg.norm(spline(mid + half * g[None, :], 1), axis=2)
    arc = np.concatenate([[0.0], np.cumsum((half * speed * w[None, :]).sum(axis=1))])
    length = arc[-1]
    if n is None:
        if h is None:
            raise ValueError("give h or n")
        n = max(8, int(round(length / h)))
    target = np.linspace(0.0, length, n, endpoint=False)
    # invert arclength(s) by Newton from a linear guess
    t = np.interp(target, arc, s)
    for _ in range(20):
        k = np.clip(np.searchsorted(s, t, side="right") - 1, 0, len(chord) - 1)
        # arclength from s[k] to t by quadrature
        a = s[k][:, None]
        hh = 0.5 * (t - s[k])[:, None]
        sp = np.linalg.norm(spline(a + hh + hh * g[None, :], 1), axis=2)
        f = arc[k] + (hh * sp * w[None, :]).sum(axis=1) - target
        dt = f / np.linalg.norm(spline(t, 1), axis=1)
        t = t - dt
        if np.max(np.abs(dt)) < 1e-14 * length:
            break
    return spline(t)


# ----------------------------------------------------------------------------- motion
class DirichletLaplacian:
    """``-Δu = f`` in the mesh, ``u = g`` on the exterior boundary, for a scalar Lagrange space,
    with one MUMPS LU factorisation reused for every right-hand side.

    The matrix (``∫ ∇u·∇v dx``, identity rows at the boundary dofs) depends only on the mesh,
    so the tumour's pressure and every component of a harmonic extension share it.  It is
    assembled and factorised at the first solve after construction or :meth:`invalidate`
    (call it after moving the mesh: :meth:`MeshMotion.apply` does).

    Parameters
    ----------
    V
        Scalar Lagrange space.
    boundary_dofs
        Its dofs on the exterior boundary (the Dirichlet dofs).
    """

    def __init__(self, V: fem.FunctionSpace, boundary_dofs: npt.NDArray[np.int32]):
        self.V = V
        self.boundary_dofs = boundary_dofs
        self.g = fem.Function(V)  # the boundary values of the next solve
        self.bc = fem.dirichletbc(self.g, boundary_dofs)
        u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        self.a = fem.form(ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx)
        self.A = fem_petsc.create_matrix(self.a)
        self.b = fem_petsc.create_vector(V)
        self.x = fem_petsc.create_vector(V)
        self.ksp = PETSc.KSP().create(V.mesh.comm)
        self.ksp.setType("preonly")
        self.ksp.getPC().setType("lu")
        self.ksp.getPC().setFactorSolverType("mumps")
        self.factorisations = 0
        self._current = False

    def invalidate(self) -> None:
        """The mesh has moved: assemble and factorise again at the next solve."""
        self._current = False

    def _factorise(self) -> None:
        self.A.zeroEntries()
        fem_petsc.assemble_matrix(self.A, self.a, bcs=[self.bc])
        self.A.assemble()
        self.ksp.setOperators(self.A)
        self.ksp.setUp()
        self.factorisations += 1
        self._current = True

    def solve(self, u: fem.Function, L: fem.Form | None = None) -> fem.Function:
        """Solve with the boundary values in :attr:`g` and the right-hand side ``L`` (a
        compiled linear form on ``V``; ``None``: f = 0) into ``u`` (ghosts updated)."""
        if not self._current:
            self._factorise()
        with self.b.localForm() as b_local:
            b_local.set(0.0)
        if L is not None:
            fem_petsc.assemble_vector(self.b, L)
        fem_petsc.apply_lifting(self.b, [self.a], bcs=[[self.bc]])
        self.b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self.bc.set(self.b.array_w)
        self.ksp.solve(self.b, self.x)
        if self.ksp.getConvergedReason() < 0:
            raise RuntimeError(f"Laplace solve failed (reason {self.ksp.getConvergedReason()})")
        self.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        fem_petsc.assign(self.x, u)
        return u

    def destroy(self) -> None:
        """Free the PETSc objects."""
        for obj in (self.ksp, self.A, self.b, self.x):
            obj.destroy()


class MeshMotion:
    """Harmonic extension of a boundary displacement, applied to ``mesh.geometry.x``.

    The vector Laplace problem decouples into one scalar problem per component with the
    same matrix: each component is solved with one factorisation of the scalar Laplacian
    (:class:`DirichletLaplacian`).

    Parameters
    ----------
    msh
        Mesh with affine (P1) geometry; it is moved in place, so forms built on it stay
        valid (DOLFINx reads the geometry at assembly).
    laplacian
        A :class:`DirichletLaplacian` of a scalar P1 space of ``msh`` to share (e.g. the
        tumour's pressure solver); by default one of its own.
    """

    def __init__(self, msh: dmesh.Mesh, laplacian: DirichletLaplacian | None = None):
        self.mesh = msh
        gdim = msh.geometry.dim
        tdim = msh.topology.dim
        self.V = fem.functionspace(msh, ("Lagrange", 1, (gdim,)))
        msh.topology.create_connectivity(tdim - 1, tdim)
        facets = dmesh.exterior_facet_indices(msh.topology)
        self.boundary_dofs = fem.locate_dofs_topological(self.V, tdim - 1, facets)
        self._owns_laplacian = laplacian is None
        if laplacian is None:
            Vs = fem.functionspace(msh, ("Lagrange", 1))
            laplacian = DirichletLaplacian(Vs, fem.locate_dofs_topological(Vs, tdim - 1, facets))
        self.laplacian = laplacian
        self.w = fem.Function(self.V, name="mesh_displacement")
        self._wk = fem.Function(laplacian.V)  # one component of the extension
        # scalar dof of each vector block (both P1 on the same cells, same local order)
        v2g = vertex_to_geometry(msh)
        msh.topology.create_connectivity(tdim, 0)
        c2v = msh.topology.connectivity(tdim, 0).array.reshape(-1, tdim + 1)
        dofs = np.asarray(self.V.dofmap.list)[: c2v.shape[0]]
        sdofs = np.asarray(laplacian.V.dofmap.list)[: c2v.shape[0]]
        self._scalar_of_block = np.empty(len(self.w.x.array) // gdim, dtype=np.int32)
        self._scalar_of_block[dofs.ravel()] = sdofs.ravel()
        # map geometry node -> P1 dof (same local ordering on each cell)
        self._geom = v2g[c2v.ravel()]
        self._dofs = dofs.ravel()

    def extend(self, displacement: fem.Function) -> fem.Function:
        """Harmonic extension of the boundary values of ``displacement`` (a function in
        ``self.V``)."""
        gdim = self.mesh.geometry.dim
        d = displacement.x.array.reshape(-1, gdim)
        w = self.w.x.array.reshape(-1, gdim)
        g = self.laplacian.g.x.array
        for k in range(gdim):
            g[self._scalar_of_block] = d[:, k]
            self.laplacian.solve(self._wk)
            w[:, k] = self._wk.x.array[self._scalar_of_block]
        return self.w

    def move(self, displacement: fem.Function) -> fem.Function:
        """Extend ``displacement`` from the boundary and move the mesh by it; return the
        extension."""
        w = self.extend(displacement)
        self.apply(w)
        return w

    def apply(self, w: fem.Function) -> None:
        """Move the mesh vertices by ``w`` (a function in ``self.V``, e.g. the result of
        :meth:`extend`), without solving again."""
        gdim = self.mesh.geometry.dim
        arr = w.x.array.reshape(-1, gdim)
        self.mesh.geometry.x[self._geom, :gdim] += arr[self._dofs]
        self.laplacian.invalidate()

    def destroy(self) -> None:
        """Free the PETSc objects of the Laplacian this motion created (collective; a shared
        Laplacian is its owner's to destroy)."""
        if self._owns_laplacian:
            self.laplacian.destroy()


# ----------------------------------------------------------------------------- transfer
def _all_cells(msh: dmesh.Mesh) -> npt.NDArray[np.int32]:
    im = msh.topology.index_map(msh.topology.dim)
    return np.arange(im.size_local + im.num_ghosts, dtype=np.int32)


def transfer(
    u_from: fem.Function, V_to: fem.FunctionSpace, extrapolate: float = 0.0, name: str | None = None
) -> fem.Function:
    """Interpolate ``u_from`` into ``V_to`` (another mesh) and check coverage.

    Parameters
    ----------
    u_from
        Source field.
    V_to
        Target space, on a mesh that need not match the source mesh.
    extrapolate
        Width of the band outside the source mesh in which target points are accepted:
        they take the value of the nearest source cell's polynomial (explicit
        extrapolation).  ``0`` accepts only points inside the source mesh (to round-off).
    name
        Name of the result (default: the name of ``u_from``).

    Raises
    ------
    RunError
        If any target interpolation point lies outside the source mesh by more than
        ``extrapolate`` (on any rank: raised collectively).
    """
    out = transfer_fields([u_from], V_to, extrapolate)[0]
    out.name = name or u_from.name
    return out


def transfer_fields(
    sources: Sequence[fem.Function], V_to: fem.FunctionSpace, extrapolate: float = 0.0
) -> list[fem.Function]:
    """Interpolate several fields of one source mesh into ``V_to``, with one point search.

    Same as :func:`transfer` for each field, but the target points are located once.  They
    are first searched inside the source cells (padding ``1e-10``, as a bounding-box test
    with a large padding makes every point a candidate of many cells); only the points not
    found there are searched again with the extrapolation band ``extrapolate``.

    Raises
    ------
    RunError
        As :func:`transfer`.
    """
    if not sources:
        return []
    V_from = sources[0].function_space
    outs = [fem.Function(V_to, name=u.name) for u in sources]
    ones = _ones(V_from.mesh, outs[0].ufl_shape)
    count = fem.Function(V_to)
    if _point_evaluation(V_to, V_from.mesh):
        _interpolate_inside(V_to, (ones, *sources), (count, *outs))
    else:
        cells = _all_cells(V_to.mesh)
        data = fem.create_interpolation_data(V_to, V_from, cells, padding=_INSIDE)
        for u, out in zip((ones, *sources), (count, *outs)):
            out.interpolate_nonmatching(u, cells, data)
    bs = V_to.dofmap.index_map_bs
    missing = np.flatnonzero(np.abs(count.x.array.reshape(-1, bs)[:, 0] - 1.0) > 1e-8)
    if V_to.mesh.comm.allreduce(len(missing), op=MPI.SUM) and extrapolate > _INSIDE:
        missing = _extrapolate(sources, ones, outs, count, missing, extrapolate)
    _check_coverage(sources[0].name, V_to, missing, extrapolate)
    for out in outs:
        out.x.scatter_forward()
    return outs


#: Padding of the inside search of a transfer: round-off only.
_INSIDE = 1e-10


#: A point is inside a source cell when its smallest barycentric coordinate is >= -this.
_BARYCENTRIC_TOL = 1e-12


def _point_evaluation(V_to: fem.FunctionSpace, msh_from: dmesh.Mesh) -> bool:
    """Whether the fast inside search applies: the target's degrees of freedom are point
    values (Lagrange, DG) and the source mesh is an affine simplex mesh."""
    simplex = msh_from.topology.cell_type in (dmesh.CellType.triangle, dmesh.CellType.tetrahedron)
    affine = msh_from.geometry.cmaps[0].degree == 1
    flat = msh_from.geometry.dim == msh_from.topology.dim
    return bool(V_to.element.interpolation_ident) and simplex and affine and flat


def _interpolate_inside(
    V_to: fem.FunctionSpace, sources: Sequence[fem.Function], outs: Sequence[fem.Function]
) -> None:
    """Evaluate ``sources`` (one source mesh) at the dof points of ``V_to`` that lie inside
    a source cell, into ``outs``; other points are left zero (collective).

    Each target point is sent to the ranks whose source bounding box holds it; there the
    candidate cells come from a bounding-box tree and the containing one is picked by its
    barycentric coordinates, vectorised (the point search of
    ``fem.create_interpolation_data`` computes a GJK distance to every candidate, the
    dominant cost of a transfer).  Of several ranks that hold the point the one where it is
    deepest inside wins (ties: the lowest rank).
    """
    msh = sources[0].function_space.mesh
    comm = msh.comm
    gdim = msh.geometry.dim
    X = V_to.tabulate_dof_coordinates()[:, :gdim]
    dest, order, sendcounts = _candidate_ranks(msh, X)
    recv = _exchange(comm, np.ascontiguousarray(X[order]), sendcounts, gdim)
    score, values = _evaluate_local(msh, recv, sources)
    recvcounts = np.empty_like(sendcounts)
    comm.Alltoall(sendcounts, recvcounts)
    back = _exchange(comm, np.column_stack([score, values]), recvcounts, 1 + values.shape[1])
    # best answer per target point (the rank order of `order` breaks ties)
    best = np.full(len(X), -np.inf)
    chosen = np.full(len(X), -1, dtype=np.int64)
    pts = order
    sc = back[:, 0]
    srt = np.lexsort((dest, -sc, pts))  # per point: highest score first, then lowest rank
    first = np.ones(len(srt), dtype=bool)
    first[1:] = pts[srt][1:] != pts[srt][:-1]
    win = srt[first]
    best[pts[win]] = sc[win]
    chosen[pts[win]] = win
    inside = np.flatnonzero(best >= -_BARYCENTRIC_TOL)
    vals = back[chosen[inside], 1:]
    offset = 0
    for out in outs:
        bs = out.function_space.dofmap.index_map_bs
        out.x.array.reshape(-1, bs)[inside] = vals[:, offset : offset + bs]
        offset += bs


def _candidate_ranks(
    msh: dmesh.Mesh, X: npt.NDArray[np.float64]
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """For every (target point, rank whose padded source box holds it) pair: the rank, the
    point, sorted by rank; and the number of points per rank (collective)."""
    comm = msh.comm
    gdim = msh.geometry.dim
    x = msh.geometry.x[:, :gdim]
    pad = 1e-8 * max(float(np.ptp(x, axis=0).max(initial=0.0)), 1.0)
    box = np.concatenate([x.min(axis=0, initial=np.inf), x.max(axis=0, initial=-np.inf)])
    boxes = np.array(comm.allgather(box)).reshape(comm.size, 2, gdim)
    lo, hi = boxes[:, None, 0, :] - pad, boxes[:, None, 1, :] + pad
    inside = np.all((X[None, :, :] >= lo) & (X[None, :, :] <= hi), axis=2)  # (ranks, points)
    dest, point = np.nonzero(inside)
    sendcounts = np.bincount(dest, minlength=comm.size).astype(np.int64)
    return dest.astype(np.int64), point.astype(np.int64), sendcounts


def _exchange(
    comm: MPI.Comm, data: npt.NDArray[np.float64], sendcounts: npt.NDArray[np.int64], width: int
) -> npt.NDArray[np.float64]:
    """All-to-all of rows of ``width`` floats, ``sendcounts[r]`` rows to rank ``r``."""
    recvcounts = np.empty_like(sendcounts)
    comm.Alltoall(sendcounts, recvcounts)
    out = np.empty((int(recvcounts.sum()), width), dtype=np.float64)
    send = np.ascontiguousarray(data, dtype=np.float64).reshape(-1, width)
    comm.Alltoallv(
        [send, (sendcounts * width, _displs(sendcounts) * width), MPI.DOUBLE],
        [out, (recvcounts * width, _displs(recvcounts) * width), MPI.DOUBLE],
    )
    return out


def _displs(counts: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    return np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)


def _evaluate_local(
    msh: dmesh.Mesh, points: npt.NDArray[np.float64], sources: Sequence[fem.Function]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Score (smallest barycentric coordinate in the best owned cell, ``-inf`` if none) and
    the values of ``sources`` there (stacked columns) at each of ``points``."""
    tdim = msh.topology.dim
    gdim = msh.geometry.dim
    width = sum(int(np.prod(u.ufl_shape)) for u in sources)
    score = np.full(len(points), -np.inf)
    values = np.zeros((len(points), width))
    nown = msh.topology.index_map(tdim).size_local
    if len(points) == 0 or nown == 0:
        return score, values
    p3 = np.zeros((len(points), 3))
    p3[:, :gdim] = points
    tree = geometry.bb_tree(msh, tdim, entities=np.arange(nown, dtype=np.int32), padding=1e-10)
    cand = geometry.compute_collisions_points(tree, p3)
    cells = cand.array
    if len(cells) == 0:
        return score, values
    counts = np.diff(cand.offsets)
    pts = np.repeat(np.arange(len(points)), counts)  # pairs grouped by point
    nodes = msh.geometry.x[np.asarray(msh.geometry.dofmaps[0])[cells, : tdim + 1], :gdim]
    s = _smallest_barycentric(nodes, points[pts])
    has = np.flatnonzero(counts)
    score[has] = np.maximum.reduceat(s, cand.offsets[:-1][has])
    best = np.flatnonzero(s == score[pts])  # the first best pair of each point wins
    first = np.ones(len(best), dtype=bool)
    first[1:] = pts[best][1:] != pts[best][:-1]
    win = best[first]
    win = win[s[win] >= -_BARYCENTRIC_TOL]
    ok, ok_cells = pts[win], cells[win].astype(np.int32)
    col = 0
    for u in sources:
        n = int(np.prod(u.ufl_shape))
        if len(ok) and u.function_space.element.space_dimension == n:  # DG0: the cell value
            dofs = np.asarray(u.function_space.dofmap.list)[ok_cells, 0]
            values[ok, col : col + n] = u.x.array.reshape(-1, n)[dofs]
        elif len(ok):
            values[ok, col : col + n] = u.eval(p3[ok], ok_cells).reshape(len(ok), n)
        col += n
    return score, values


def _smallest_barycentric(
    nodes: npt.NDArray[np.float64], x: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]:
    """The smallest barycentric coordinate of each point ``x[k]`` in the simplex
    ``nodes[k]`` (``(n, d + 1, d)``, d = 2 or 3): >= 0 inside, negative outside."""
    e = nodes[:, 1:, :] - nodes[:, :1, :]
    r = x - nodes[:, 0, :]
    if nodes.shape[2] == 2:
        det = e[:, 0, 0] * e[:, 1, 1] - e[:, 0, 1] * e[:, 1, 0]
        l1 = (r[:, 0] * e[:, 1, 1] - r[:, 1] * e[:, 1, 0]) / det
        l2 = (e[:, 0, 0] * r[:, 1] - e[:, 0, 1] * r[:, 0]) / det
        lam = (l1, l2)
    else:
        a, b, c = e[:, 0, :], e[:, 1, :], e[:, 2, :]
        bc, ca, ab = _cross(b, c), _cross(c, a), _cross(a, b)
        det = np.einsum("ij,ij->i", a, bc)
        lam = tuple(np.einsum("ij,ij->i", r, n) / det for n in (bc, ca, ab))
    return np.minimum.reduce((*lam, 1.0 - sum(lam)))


def _cross(a: npt.NDArray[np.float64], b: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Row-wise cross product of ``(n, 3)`` arrays (``np.cross`` is slow for short rows)."""
    return np.column_stack(
        [
            a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
            a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
            a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
        ]
    )


def _ones(msh: dmesh.Mesh, shape: tuple[int, ...]) -> fem.Function:
    """A DG0 function equal to one (every component) on ``msh``: the coverage probe."""
    W = fem.functionspace(msh, ("DG", 0, shape) if shape else ("DG", 0))
    one = fem.Function(W)
    one.x.array[:] = 1.0
    return one


def _extrapolate(
    sources: Sequence[fem.Function],
    ones: fem.Function,
    outs: list[fem.Function],
    count: fem.Function,
    missing: npt.NDArray[np.int64],
    band: float,
) -> npt.NDArray[np.int64]:
    """Search the ``missing`` target dofs (blocks) again within ``band`` of the source mesh
    and fill those found; returns the dofs still missing (collective)."""
    V_to = count.function_space
    dofs = np.asarray(V_to.dofmap.list)
    cells = _all_cells(V_to.mesh)
    flag = np.zeros(dofs.max(initial=-1) + 1, dtype=bool)
    flag[missing] = True
    cells = cells[flag[dofs[cells]].any(axis=1)] if len(missing) else cells[:0]
    data = fem.create_interpolation_data(V_to, sources[0].function_space, cells, padding=band)
    tmp = [fem.Function(V_to) for _ in range(len(sources) + 1)]
    for u, t in zip((ones, *sources), tmp):
        t.interpolate_nonmatching(u, cells, data)
    bs = V_to.dofmap.index_map_bs
    found = missing[np.abs(tmp[0].x.array.reshape(-1, bs)[missing, 0] - 1.0) <= 1e-8]
    for t, out in zip(tmp, (count, *outs)):
        t2, o2 = t.x.array.reshape(-1, bs), out.x.array.reshape(-1, bs)
        o2[found] = t2[found]
    return np.setdiff1d(missing, found)


def _check_coverage(
    name: str, V_to: fem.FunctionSpace, missing: npt.NDArray[np.int64], band: float
) -> None:
    """Raise a :class:`RunError` on every rank if any owned target dof is not covered."""
    nown = V_to.dofmap.index_map.size_local
    owned = missing[missing < nown]
    comm = V_to.mesh.comm
    nmiss = comm.allreduce(len(owned), op=MPI.SUM)
    if nmiss:
        xyz = V_to.tabulate_dof_coordinates()[owned]
        where = comm.allgather(xyz[:3].tolist())
        raise RunError(
            f"transfer of '{name}': {nmiss} target point(s) lie outside the source mesh "
            f"(extrapolation band {band:g}); e.g. {sum(where, [])[:3]}"
        )
