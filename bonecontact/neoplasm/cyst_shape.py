"""The moving-wall odontogenic cyst on a cyst mesh remeshed by gmsh.

The osmotic/Maxwell balance of :mod:`bonecontact.neoplasm.cyst` with the volume and the
lining area taken from the current mesh; the wall moves by a uniform normal offset each
step (docs/theory/growth.md#moving-wall-cyst).
"""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from scipy.integrate import solve_ivp

from bonecontact.neoplasm import remesh
from bonecontact.neoplasm.cyst import CystParameters

__all__ = ["CystShapeModel", "boundary_measures", "offset_directions"]


def _measures(
    points: npt.NDArray[np.float64], facets: npt.NDArray[np.int64]
) -> tuple[float, float]:
    """Enclosed volume (area) and surface area (perimeter) of a closed outward boundary."""
    if points.shape[1] == 2:
        q = points[facets[:, 1]]
        p = points[facets[:, 0]]
        area = 0.5 * float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))
        return area, float(np.sum(np.linalg.norm(q - p, axis=1)))
    a, b, c = points[facets[:, 0]], points[facets[:, 1]], points[facets[:, 2]]
    vol = float(np.sum(np.einsum("ij,ij->i", a, np.cross(b, c)))) / 6.0
    return vol, 0.5 * float(np.sum(np.linalg.norm(np.cross(b - a, c - a), axis=1)))


def boundary_measures(b: remesh.Boundary) -> tuple[float, float]:
    """``(volume, surface_area)`` enclosed by a gathered boundary (2D: area, perimeter).

    Equal to ∫dx and ∫ds over the mesh the boundary came from, to round-off (affine
    geometry), but independent of the partition.
    """
    return _measures(b.points, b.facets)


def offset_directions(b: remesh.Boundary) -> npt.NDArray[np.float64]:
    """Vertex displacement per unit wall offset δ, so that the wall moves by δ along its normal.

    2D: the miter vector m_i with m_i·ν = 1 for the outward unit normals ν of both edges
    at vertex i, so every edge moves parallel to itself by exactly δ (the discrete parallel
    curve: dA/dδ equals the perimeter for every δ, and a regular polygon stays regular).
    3D (a triangle can only move parallel when its vertices agree): m_i along the area-weighted
    normal N_i = ∂V/∂x_i = ⅓ Σ A_f ν_f, scaled to m_i = N_i s_i / |N_i|² with the vertex's
    share s_i = ⅓ Σ A_f of the area, so that dV/dδ = S at δ = 0.

    Raises
    ------
    RemeshError
        At a 2D corner sharper than about 100° (the miter would exceed √5 δ).
    """
    x = b.points
    if b.gdim == 2:
        e = np.roll(x, -1, axis=0) - x  # edge i: x_i -> x_{i+1} (counter-clockwise)
        nu = np.column_stack([e[:, 1], -e[:, 0]]) / np.linalg.norm(e, axis=1)[:, None]
        a, c = np.roll(nu, 1, axis=0), nu  # edges before and after vertex i
        den = 1.0 + np.einsum("ij,ij->i", a, c)
        if np.any(den < 0.2):
            raise remesh.RemeshError(
                f"cyst wall has a corner sharper than ~100 degrees "
                f"(min 1 + cos = {den.min():.3g}); refine or smooth the wall"
            )
        return (a + c) / den[:, None]
    t = b.facets
    fn = 0.5 * np.cross(x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]])  # A_f ν_f
    N = np.zeros_like(x)
    share = np.zeros(len(x))
    fa = np.linalg.norm(fn, axis=1)
    for k in range(3):
        np.add.at(N, t[:, k], fn / 3.0)
        np.add.at(share, t[:, k], fa / 3.0)
    return N * (share / np.einsum("ij,ij->i", N, N))[:, None]


class CystShapeModel:
    """Moving-wall cyst (docs/theory/growth.md#moving-wall-cyst).

    Parameters
    ----------
    comm
        Communicator of the cyst mesh.
    geometry
        The initial cyst: a DOLFINx mesh (2D triangles / 3D tetrahedra; its exterior
        boundary is the wall, one closed curve / surface) or ``(N, 2)`` polygon nodes.
    params
        Osmotic/Maxwell parameters (:class:`bonecontact.neoplasm.cyst.CystParameters`).
    h
        Mesh size at t = 0 (m): interior size, and 2D boundary spacing after a remesh.
    remesh_every
        Growth steps between remeshes, >= 0 (0: never, the mesh only moves).
    scale_h
        Scale the mesh size with the cyst, h(t) = h R_eq(t)/R_eq(0) (default), so that
        the number of cells stays about constant; ``False`` keeps h.
    """

    def __init__(
        self,
        comm: MPI.Comm,
        geometry: dmesh.Mesh | npt.ArrayLike,
        params: CystParameters,
        h: float,
        *,
        remesh_every: int = 1,
        scale_h: bool = True,
    ):
        if not h > 0:
            raise ValueError(f"h must be > 0, got {h}")
        if remesh_every < 0:
            raise ValueError("remesh_every must be >= 0 (0 = never remesh)")
        self.comm = comm
        self.params = params
        self.h0 = float(h)
        self.remesh_every = int(remesh_every)
        self.scale_h = bool(scale_h)
        self.t = 0.0
        self.steps = 0
        self.remeshes = 0
        self.f = float(params.f0)
        self._vn = math.nan
        if isinstance(geometry, dmesh.Mesh):
            msh = geometry
        else:
            msh = remesh.polygon_mesh(np.asarray(geometry, dtype=np.float64), self.h0, comm)
        self._setup(msh)
        v, S = self._measures()
        if not v > 0:
            raise remesh.RemeshError(f"the cyst mesh encloses a non-positive volume {v}")
        self.R_eq0 = self.equivalent_radius()
        self.L0 = self.dim * v / S  # reference length of engineering strain (R0 for a sphere)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def disc(
        cls, comm: MPI.Comm, radius: float, params: CystParameters, h: float, **kwargs
    ) -> CystShapeModel:
        """A circular cyst (2D, per unit thickness): a regular polygon with spacing ~h."""
        n = max(8, int(round(2 * math.pi * radius / h)))
        th = 2 * math.pi * np.arange(n) / n
        return cls(comm, radius * np.column_stack([np.cos(th), np.sin(th)]), params, h, **kwargs)

    @classmethod
    def ball(
        cls, comm: MPI.Comm, radius: float, params: CystParameters, h: float, **kwargs
    ) -> CystShapeModel:
        """A spherical cyst (3D): a gmsh ball of size h."""
        return cls(comm, remesh.sphere_mesh(radius, h, comm), params, h, **kwargs)

    # ------------------------------------------------------------------ per mesh
    def _setup(self, msh: dmesh.Mesh) -> None:
        self.mesh = msh
        self.dim = msh.topology.dim
        if msh.geometry.dim != self.dim:
            raise ValueError("the cyst mesh must have gdim == tdim (2D or 3D)")
        self.motion = remesh.MeshMotion(msh)
        # key (gmsh input node) of each local P1 vector-block dof, to place boundary displacements
        tdim = self.dim
        c2v = msh.topology.connectivity(tdim, 0).array.reshape(-1, tdim + 1)
        v2g = remesh.vertex_to_geometry(msh)
        keys_of_vertex = np.asarray(msh.geometry.input_global_indices, dtype=np.int64)[v2g]
        dofs = np.asarray(self.motion.V.dofmap.list)[: c2v.shape[0]]
        im = self.motion.V.dofmap.index_map
        self._key_of_dof = np.full(im.size_local + im.num_ghosts, -1, dtype=np.int64)
        self._key_of_dof[dofs.ravel()] = keys_of_vertex[c2v.ravel()]
        self._one = fem.form(fem.Constant(msh, 1.0) * ufl.dx)
        self._area = fem.form(fem.Constant(msh, 1.0) * ufl.ds)

    # ------------------------------------------------------------------ geometry
    def boundary(self) -> remesh.Boundary:
        """The current cyst wall, replicated on every rank (collective)."""
        return remesh.gather_boundary(self.mesh)

    def _measures(self, b: remesh.Boundary | None = None) -> tuple[float, float]:
        return boundary_measures(self.boundary() if b is None else b)

    def volume(self) -> float:
        """Cyst volume v_c (2D: area per unit thickness), from the wall of the current mesh."""
        return self._measures()[0]

    def surface_area(self) -> float:
        """Lining area S_c (2D: perimeter), from the wall of the current mesh."""
        return self._measures()[1]

    def mesh_measures(self) -> tuple[float, float]:
        """``(∫dx, ∫ds)`` assembled over the current mesh (equal to the above to round-off)."""
        return (
            self.comm.allreduce(fem.assemble_scalar(self._one), op=MPI.SUM),
            self.comm.allreduce(fem.assemble_scalar(self._area), op=MPI.SUM),
        )

    def equivalent_radius(self) -> float:
        """sqrt(A/π) in 2D, (3V/4π)^(1/3) in 3D."""
        v = self.volume()
        return math.sqrt(v / math.pi) if self.dim == 2 else (3 * v / (4 * math.pi)) ** (1 / 3)

    def solute(self) -> float:
        """Osmotic material in the lumen, s = v_c (C⁻ + f/α) (mol; per unit thickness in 2D)."""
        p = self.params
        return self.volume() * (p.C_minus + self.f / p.alpha)

    def normal_velocity(self) -> float:
        """Mean wall normal velocity δ/Δt of the last step (m/s); ``nan`` before the first step."""
        return self._vn

    def restore_normal_velocity(self, vn: float) -> None:
        """Set the wall velocity of the last step (a restart: :meth:`normal_velocity`)."""
        self._vn = float(vn)

    def mesh_size(self) -> float:
        """The mesh size used at the next remesh (m)."""
        return self.h0 * (self.equivalent_radius() / self.R_eq0 if self.scale_h else 1.0)

    # ------------------------------------------------------------------ one step
    def _rhs(
        self,
        points: npt.NDArray[np.float64],
        normals: npt.NDArray[np.float64],
        facets: npt.NDArray[np.int64],
    ):
        """Right-hand side of (δ, f) on the parallel walls x + δ n of the current wall."""
        p = self.params
        d = self.dim
        a, C, beta, nu, tau = p.alpha, p.C_minus, p.beta, p.viscosity, p.tau
        v0, S0 = _measures(points, facets)
        L = d * v0 / S0
        # exact volume polynomial v(δ) (degree d) from d + 1 evaluations
        nodes = L * np.linspace(-0.25, 0.25, d + 1)
        vals = [_measures(points + s * normals, facets)[0] for s in nodes]
        coef = np.polyfit(nodes / L, vals, d)  # in the scaled variable δ/L
        dcoef = np.polyder(coef)

        def rhs(t: float, y: npt.NDArray[np.float64]) -> list[float]:
            delta, f = y
            v, S = _measures(points + delta * normals, facets)
            dv = np.polyval(dcoef, delta / L) / L
            visc = nu * ((d * v / S) / self.L0 if p.strain == "engineering" else 1.0)
            g = (f + tau * a * beta * S / v) / (visc / d + tau * (a * C + f))
            return [g * v / dv, a * beta * S / v - (a * C + f) * g]

        return rhs, L

    def step(self, dt: float) -> None:
        """Advance the cyst by one growth step ``dt`` (s) (collective).

        Raises
        ------
        RuntimeError
            If the ODE integration fails, or (:class:`bonecontact.neoplasm.remesh.RemeshError`)
            gmsh cannot remesh the moved wall.
        """
        if not dt > 0:
            raise ValueError(f"dt must be > 0, got {dt}")
        b = self.boundary()
        normals = offset_directions(b)
        rhs, L = self._rhs(b.points, normals, b.facets)
        p = self.params
        sol = solve_ivp(
            rhs,
            (0.0, dt),
            [0.0, self.f],
            method="Radau",
            rtol=1e-10,
            atol=[1e-13 * L, 1e-12 * max(p.alpha * p.C_minus, abs(self.f), 1.0)],
        )
        if not sol.success:
            raise RuntimeError(f"cyst wall ODE integration failed: {sol.message}")
        delta, f = float(sol.y[0, -1]), float(sol.y[1, -1])
        # place δ n on the local boundary dofs (by gmsh key) and move the mesh
        disp = fem.Function(self.motion.V)
        arr = disp.x.array.reshape(-1, self.dim)
        bd = self.motion.boundary_dofs
        order = np.argsort(b.keys)
        pos = np.searchsorted(b.keys[order], self._key_of_dof[bd])
        pos = np.clip(pos, 0, len(order) - 1)
        if np.any(b.keys[order][pos] != self._key_of_dof[bd]):
            raise RuntimeError("cyst wall vertex not found in the gathered boundary")
        arr[bd] = delta * normals[order][pos]
        disp.x.scatter_forward()
        self.motion.move(disp)
        self.f = f
        self._vn = delta / dt
        if self.remesh_every and (self.steps + 1) % self.remesh_every == 0:
            self.remesh()  # a RemeshError leaves t and steps at the last completed step
        self.t += dt
        self.steps += 1

    # ------------------------------------------------------------------ remeshing
    def remesh(self) -> None:
        """Rebuild the cyst mesh from its current wall with gmsh (collective)."""
        b = self.boundary()
        h = self.mesh_size()
        if self.dim == 2:
            msh, _ = remesh.moved_curve_mesh(b.points, h, self.comm)
        else:
            msh, _ = remesh.moved_surface_mesh(b.points, b.facets, h, self.comm)
        self.replace_mesh(msh)
        self.remeshes += 1

    def replace_mesh(self, msh: dmesh.Mesh) -> None:
        """Continue on ``msh`` (a remesh, or a restart's copy of a checkpoint's mesh;
        collective) and release the replaced mesh's solvers."""
        old_motion = self.motion
        self._setup(msh)
        remesh.release_replaced_meshes(old_motion)
