"""The Kelvin–Voigt mechanics model of one scene: space, materials, loads, BCs.

:class:`Mechanics` collects what a scene defines (materials per cell tag, Dirichlet
conditions per component with a time factor, traction / pressure / body-force
loads) and assembles, once, the PETSc matrices the time integrators need:

* ``M``  — mass (ρu, v),
* ``K``  — elastic a⁽⁰⁾ (with the nodal-pressure volumetric part where selected),
* ``Kv`` — viscous a⁽¹⁾ (Kelvin–Voigt, c⁽¹⁾ = τ_v c⁽⁰⁾),

and load vectors: a load whose value does not depend on time (only scaled by its
schedule) is assembled once; a load form depending on the model's time constant
``t`` is assembled when evaluated.  Units: SI.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import default_scalar_type, fem, mesh
from dolfinx.fem import petsc as fem_petsc

from bonecontact.forms.elastic import elastic_form, nodal_weight, volumetric_coupling
from bonecontact.forms.kinematics import strain, tensor_from_voigt, voigt_strain
from bonecontact.forms.loads import body_force_form, pressure_form, traction_form
from bonecontact.forms.mass import mass_form
from bonecontact.forms.viscous import viscous_form
from bonecontact.materials.constitutive import MaterialFields, material_fields
from bonecontact.materials.laws import Material
from bonecontact.mechanics.forces import FacetMeasures, facet_measures, force_traction

#: Cells per form of :meth:`Mechanics.operator_action` (its coefficients are packed per
#: form: ~0.5 kB per cell in 3D)
ACTION_CHUNK = 16384

__all__ = ["Mechanics", "Schedule", "constant_schedule"]

Schedule = Callable[[float], float]


def constant_schedule(t: float) -> float:
    """Factor 1 at all times."""
    return 1.0


@dataclass
class _Load:
    form: fem.Form
    schedule: Schedule
    time_dependent: bool
    vector: PETSc.Vec | None = None


@dataclass
class _Dirichlet:
    dofs: npt.NDArray[np.int32]  # unrolled local dof indices (owned and ghost)
    values: npt.NDArray[np.float64]
    schedule: Schedule


@dataclass
class _Matrices:
    M: PETSc.Mat | None = None
    K: PETSc.Mat | None = None
    Kv: PETSc.Mat | None = None
    extra: dict = field(default_factory=dict)


class Mechanics:
    """Kelvin–Voigt solid on a mesh that may hold several bodies.

    Parameters
    ----------
    msh
        Mesh; ``gdim`` 2 means plane strain (forces per unit thickness, N/m).
    materials
        Cell tag → :class:`~bonecontact.materials.laws.Material`, or one material.
    cell_tags, facet_tags
        Mesh markers (facet tags are needed for boundary loads and conditions).
    """

    def __init__(
        self,
        msh: mesh.Mesh,
        materials: Mapping[int, Material] | Material,
        cell_tags: mesh.MeshTags | None = None,
        facet_tags: mesh.MeshTags | None = None,
    ):
        self.mesh = msh
        self.dim = msh.geometry.dim
        if msh.topology.dim != self.dim:
            raise ValueError(
                "manifold meshes are not supported: topological and geometric dimensions differ"
            )
        self.cell_tags = cell_tags
        self.facet_tags = facet_tags
        tdim = msh.topology.dim
        msh.topology.create_connectivity(tdim - 1, tdim)
        self.V = fem.functionspace(msh, ("Lagrange", 1, (self.dim,)))
        self.materials = materials
        self.fields: MaterialFields = material_fields(msh, cell_tags, materials)
        self.t = fem.Constant(msh, default_scalar_type(0.0))
        self.dx = ufl.Measure("dx", domain=msh, subdomain_data=cell_tags)
        self.ds = ufl.Measure("ds", domain=msh, subdomain_data=facet_tags)
        self.n = ufl.FacetNormal(msh)
        self._u = ufl.TrialFunction(self.V)
        self._v = ufl.TestFunction(self.V)
        self.loads: list[_Load] = []
        self.dirichlet: list[_Dirichlet] = []
        self._mats = _Matrices()
        self._anp: dict | None = None
        self._actions: dict[tuple[float, float, float], tuple] = {}  # (operator_action)

    # ------------------------------------------------------------------ sizes
    @property
    def num_dofs(self) -> int:
        """Global number of displacement dofs."""
        im = self.V.dofmap.index_map
        return im.size_global * self.V.dofmap.index_map_bs

    @property
    def num_owned(self) -> int:
        """Number of owned (unrolled) dofs on this rank."""
        return self.V.dofmap.index_map.size_local * self.V.dofmap.index_map_bs

    # ------------------------------------------------------------- boundaries
    def facets(self, tag: int | Sequence[int]) -> npt.NDArray[np.int32]:
        """Local facet indices with the given tag(s)."""
        if self.facet_tags is None:
            raise ValueError("the mesh has no facet tags")
        tags = [tag] if np.isscalar(tag) else list(tag)
        return np.unique(np.concatenate([self.facet_tags.find(int(t)) for t in tags])).astype(
            np.int32
        )

    def cells(self, tag: int | Sequence[int] | None) -> npt.NDArray[np.int32]:
        """Local cell indices (owned and ghost) with the given tag(s); all cells for ``None``."""
        tdim = self.mesh.topology.dim
        if tag is None:
            im = self.mesh.topology.index_map(tdim)
            return np.arange(im.size_local + im.num_ghosts, dtype=np.int32)
        tags = [tag] if np.isscalar(tag) else list(tag)
        return np.unique(np.concatenate([self.cell_tags.find(int(t)) for t in tags])).astype(
            np.int32
        )

    def add_dirichlet(
        self,
        facets: npt.NDArray[np.int32],
        component: int,
        value: float | Callable[[npt.NDArray[np.float64]], npt.NDArray[np.float64]] = 0.0,
        schedule: Schedule = constant_schedule,
    ) -> None:
        """Prescribe one displacement component on a set of facets.

        The imposed value is ``schedule(t) * value`` where ``value`` is a number or a
        callable of the coordinates ``x`` (shape (3, n)) returning (n,) values.
        """
        if not 0 <= component < self.dim:
            raise ValueError(f"component must be in [0, {self.dim}), got {component}")
        fdim = self.mesh.topology.dim - 1
        blocks = fem.locate_dofs_topological(self.V, fdim, facets)
        bs = self.V.dofmap.index_map_bs
        dofs = (bs * blocks + component).astype(np.int32)
        if callable(value):
            x = self.V.tabulate_dof_coordinates()[blocks].T
            vals = np.asarray(value(x), dtype=np.float64).reshape(-1)
        else:
            vals = np.full(dofs.size, float(value))
        self.dirichlet.append(_Dirichlet(dofs, vals, schedule))

    def bc_dofs(self) -> npt.NDArray[np.int32]:
        """All constrained unrolled local dofs (owned and ghost)."""
        if not self.dirichlet:
            return np.zeros(0, dtype=np.int32)
        return np.unique(np.concatenate([d.dofs for d in self.dirichlet])).astype(np.int32)

    def dirichlet_values(self, t: float, g: fem.Function) -> None:
        """Fill ``g`` with the prescribed values at time ``t`` (0 elsewhere)."""
        g.x.array[:] = 0.0
        for d in self.dirichlet:
            g.x.array[d.dofs] = d.schedule(t) * d.values

    # ------------------------------------------------------------------ loads
    def add_load(self, form: ufl.Form, schedule: Schedule = constant_schedule) -> None:
        """Add a linear form in the test function ``self.test`` scaled by ``schedule(t)``.

        A form that contains the time constant ``self.t`` is re-assembled at every
        evaluation; otherwise it is assembled once.
        """
        time_dep = any(c is self.t for c in ufl.algorithms.analysis.extract_constants(form))
        self.loads.append(_Load(fem.form(form), schedule, time_dep))

    @property
    def test(self) -> ufl.Argument:
        return self._v

    def _measure(self, kind: str, tags: int | Sequence[int] | None) -> ufl.Measure:
        m = self.ds if kind == "ds" else self.dx
        if tags is None:
            return m
        tags = (tags,) if np.isscalar(tags) else tuple(int(t) for t in tags)
        return m(tags)

    def _vector(self, value) -> ufl.core.expr.Expr:
        if isinstance(value, ufl.core.expr.Expr):
            return value
        return fem.Constant(self.mesh, np.asarray(value, dtype=default_scalar_type))

    def add_traction(
        self, tags: int | Sequence[int], value, schedule: Schedule = constant_schedule
    ) -> None:
        """Traction vector (Pa) on the facets with ``tags``."""
        self.add_load(
            traction_form(self._vector(value), self._v, self._measure("ds", tags)), schedule
        )

    def group_measures(self, tags: int | Sequence[int]) -> FacetMeasures:
        """Reference area (2D: length), centroid and second moments of the facets with
        ``tags`` (collective; :func:`~bonecontact.mechanics.forces.facet_measures`)."""
        return facet_measures(self.mesh, self._measure("ds", tags))

    def add_force(
        self,
        tags: int | Sequence[int],
        force: Sequence[float],
        schedule: Schedule = constant_schedule,
        moment: Sequence[float] | float | None = None,
        point: Sequence[float] | None = None,
    ) -> FacetMeasures:
        """Total force (N; N/m in 2D) on the facets with ``tags``, spread as a uniform
        traction over their reference area; with ``moment`` (N·m; 2D: a number, N·m/m)
        a linearly varying traction is added so that the load's moment about ``point``
        (default: the centroid) is ``moment`` (:mod:`bonecontact.mechanics.forces`).

        Collective (the area is assembled).  Returns the group's measures; raises
        ``ValueError`` for a group of zero area (on every rank).
        """
        measures = self.group_measures(tags)
        traction = force_traction(self.mesh, measures, force, moment, point)
        self.add_load(traction_form(traction, self._v, self._measure("ds", tags)), schedule)
        return measures

    def add_pressure(
        self, tags: int | Sequence[int], value, schedule: Schedule = constant_schedule
    ) -> None:
        """Normal pressure (Pa), positive pushing into the body."""
        p = (
            value
            if isinstance(value, ufl.core.expr.Expr)
            else fem.Constant(self.mesh, default_scalar_type(value))
        )
        self.add_load(pressure_form(p, self._v, self.n, self._measure("ds", tags)), schedule)

    def add_body_force(
        self, value, tags: int | Sequence[int] | None = None, schedule: Schedule = constant_schedule
    ) -> None:
        """Body force (N/m³) on the cells with ``tags`` (all cells for ``None``)."""
        self.add_load(
            body_force_form(self._vector(value), self._v, self._measure("dx", tags)), schedule
        )

    def load_resultants(self, t: float = 0.0) -> list[npt.NDArray[np.float64]]:
        """Total force (N; N/m in 2D) of each load without its schedule factor: the
        component sums of its assembled vector (the model's time constant set to ``t``
        for time-dependent forms).  Collective (one reduction)."""
        self.t.value = t
        bs = self.V.dofmap.index_map_bs
        parts = np.zeros((len(self.loads), self.dim))
        for k, ld in enumerate(self.loads):
            vec = fem_petsc.assemble_vector(ld.form)
            vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            parts[k] = vec.array_r.reshape(-1, bs)[:, : self.dim].sum(axis=0)
            vec.destroy()
        total = self.mesh.comm.allreduce(parts, op=MPI.SUM)
        return [row for row in total]

    def cell_measure(self, tags: int | Sequence[int] | None) -> float:
        """Volume (2D: area) of the cells with ``tags`` (all for ``None``; collective)."""
        one = fem.Constant(self.mesh, default_scalar_type(1.0))
        local = fem.assemble_scalar(fem.form(one * self._measure("dx", tags)))
        return float(self.mesh.comm.allreduce(local, op=MPI.SUM))

    def load_vector(self, t: float, b: PETSc.Vec) -> PETSc.Vec:
        """Assemble F(t) = Σ schedule_k(t) F_k into ``b`` (owned entries, ghosts accumulated)."""
        b.zeroEntries()
        self.t.value = t
        for ld in self.loads:
            s = ld.schedule(t)
            if ld.time_dependent:
                vec = fem_petsc.assemble_vector(ld.form)
                vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
                b.axpy(s, vec)
                vec.destroy()
            else:
                if ld.vector is None:
                    ld.vector = fem_petsc.assemble_vector(ld.form)
                    ld.vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
                if s != 0.0:
                    b.axpy(s, ld.vector)
        return b

    # --------------------------------------------------------------- matrices
    def _assemble(self, a: ufl.Form) -> PETSc.Mat:
        A = fem_petsc.assemble_matrix(fem.form(a))
        A.assemble()
        return A

    def _anp_setup(self) -> dict:
        """Nodal-pressure pieces: B (Q×V), weights k/m² and k_v/m² on Q."""
        if self._anp is None:
            f = self.fields
            Q = fem.functionspace(self.mesh, ("Lagrange", 1))
            q = ufl.TestFunction(Q)
            B = fem_petsc.assemble_matrix(fem.form(volumetric_coupling(self._u, q, f.chi)))
            B.assemble()

            def nodal(w):
                vec = fem_petsc.assemble_vector(fem.form(nodal_weight(q, w)))
                vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
                return vec

            m, k, kv = nodal(f.chi), nodal(f.kappa), nodal(f.kappa_v)
            ma = m.array_r
            inv_m = np.where(ma > 0, 1.0 / np.where(ma > 0, ma, 1.0), 0.0)
            w0, wv = k.copy(), kv.copy()
            w0.array[:] = k.array_r * inv_m**2
            wv.array[:] = kv.array_r * inv_m**2
            theta = fem.Function(Q, name="theta_bar")
            theta_v = fem.Function(Q, name="theta_bar_rate")
            self._anp = {
                "Q": Q,
                "B": B,
                "w0": w0,
                "wv": wv,
                "inv_m": inv_m,
                "theta": theta,
                "theta_v": theta_v,
            }
        return self._anp

    def _anp_matrix(self, c0: float, cv: float) -> PETSc.Mat:
        """Bᵀ diag(c0 k/m² + cv k_v/m²) B, from the rows of B of the nodes of nodal-pressure
        cells only (B is assembled over the whole mesh: its other rows hold structural zeros
        that would couple every node to its second neighbours)."""
        d = self._anp_setup()
        w = d["w0"].copy()
        w.scale(c0)
        w.axpy(cv, d["wv"])
        B = d["B"]
        keep = np.flatnonzero(w.array_r != 0.0)
        comm = B.getComm()
        rows = PETSc.IS().createGeneral(
            (keep + w.getOwnershipRange()[0]).astype(PETSc.IntType), comm=comm
        )
        c0_, c1_ = B.getOwnershipRangeColumn()
        cols = PETSc.IS().createStride(c1_ - c0_, first=c0_, step=1, comm=comm)
        Bs = B.createSubMatrix(rows, cols)
        ws = Bs.createVecLeft()
        ws.array[:] = w.array_r[keep]
        DB = Bs.copy()
        DB.diagonalScale(L=ws)
        return Bs.transposeMatMult(DB)

    def _operator_form(self, c_mass: float, c_elastic: float, c_viscous: float) -> ufl.Form:
        """The bilinear form c_M m + c_K a⁽⁰⁾ + c_V a⁽¹⁾ (without the nodal-pressure terms)."""
        f = self.fields
        u, v = self._u, self._v
        a = 0
        if c_mass:
            a = a + c_mass * mass_form(u, v, f.rho, ufl.dx)
        a = a + c_elastic * elastic_form(u, v, f.C, self.dim, ufl.dx)
        if c_viscous and f.has_viscosity:
            a = a + c_viscous * viscous_form(u, v, f.C_v, self.dim, ufl.dx)
        return a

    def combined_operator(self, c_mass: float, c_elastic: float, c_viscous: float) -> PETSc.Mat:
        """c_M M + c_K K + c_V Kv assembled in one pass (nodal-pressure terms included)."""
        f = self.fields
        A = self._assemble(self._operator_form(c_mass, c_elastic, c_viscous))
        if f.has_nodal_pressure:
            A.axpy(
                1.0,
                self._anp_matrix(c_elastic, c_viscous if f.has_viscosity else 0.0),
                structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN,
            )
        return A

    def operator_action(
        self, coeffs: tuple[float, float, float], x: PETSc.Vec, out: PETSc.Vec
    ) -> None:
        """``out = (c_M M + c_K K + c_V Kv) x`` without the matrix (collective): the
        action of the forms of :meth:`combined_operator` assembled as a vector, the
        nodal-pressure terms as ``Bᵀ diag(c_K k/m² + c_V k_v/m²) B x``; the matrix
        product's value up to round-off.  ``x`` and ``out``: owned entries in the layout
        of the operator.  The compiled form is kept per ``coeffs`` (issue 28: a static
        contact run releases its step operator and takes its products from here)."""
        c_mass, c_elastic, c_viscous = (float(c) for c in coeffs)
        w, forms, vec = self._action_forms((c_mass, c_elastic, c_viscous))
        w.x.petsc_vec.array[:] = x.array_r
        w.x.scatter_forward()
        with vec.localForm() as loc:
            loc.set(0.0)
        for form in forms:
            fem_petsc.assemble_vector(vec, form)
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        out.array[:] = vec.array_r
        if self.fields.has_nodal_pressure:
            cv = c_viscous if self.fields.has_viscosity else 0.0
            d = self._anp_setup()
            y = d["B"].createVecLeft()
            d["B"].mult(x, y)
            y.array[:] *= c_elastic * d["w0"].array_r + cv * d["wv"].array_r
            d["B"].multTransposeAdd(y, out, out)
            y.destroy()

    def _action_forms(self, coeffs: tuple[float, float, float]) -> tuple:
        """``(w, forms, vector)``: the compiled action of :meth:`_operator_form` on the
        function ``w``, one form per chunk of :data:`ACTION_CHUNK` owned cells (DOLFINx
        packs the coefficients of all cells of a form at once: the Voigt stiffness
        alone is 36 values per cell), and a vector to assemble it into (made once per
        ``coeffs``; collective)."""
        if coeffs not in self._actions:
            w = fem.Function(self.V)
            integrals = ufl.action(self._operator_form(*coeffs), w).integrals()
            n = self.mesh.topology.index_map(self.mesh.topology.dim).size_local
            count = self.mesh.comm.allreduce(-(-n // ACTION_CHUNK), op=MPI.MAX)  # (fem.form
            forms = []  # is collective: the same number of forms on every rank)
            for k in range(count):
                cells = np.arange(k * ACTION_CHUNK, min((k + 1) * ACTION_CHUNK, n), dtype=np.int32)
                data = [(1, cells)]  # (one object for all integrals: DOLFINx asks for it)
                part = [i.reconstruct(subdomain_id=1, subdomain_data=data) for i in integrals]
                forms.append(fem.form(ufl.Form(part)))
            self._actions[coeffs] = (w, forms, fem_petsc.create_vector(self.V))
        return self._actions[coeffs]

    @property
    def M(self) -> PETSc.Mat:
        """Consistent mass matrix."""
        if self._mats.M is None:
            if not self.fields.has_density:
                raise ValueError(
                    "a density (rho) is required for every material in a dynamic analysis"
                )
            self._mats.M = self._assemble(mass_form(self._u, self._v, self.fields.rho, ufl.dx))
        return self._mats.M

    @property
    def K(self) -> PETSc.Mat:
        """Elastic stiffness a⁽⁰⁾."""
        if self._mats.K is None:
            self._mats.K = self.combined_operator(0.0, 1.0, 0.0)
        return self._mats.K

    @property
    def Kv(self) -> PETSc.Mat | None:
        """Viscous matrix a⁽¹⁾ (``None`` without viscosity)."""
        if not self.fields.has_viscosity:
            return None
        if self._mats.Kv is None:
            f = self.fields
            A = self._assemble(viscous_form(self._u, self._v, f.C_v, self.dim, ufl.dx))
            if f.has_nodal_pressure:
                A.axpy(
                    1.0,
                    self._anp_matrix(0.0, 1.0),
                    structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN,
                )
            self._mats.Kv = A
        return self._mats.Kv

    # ----------------------------------------------------------------- stress
    def update_nodal_volumetric(self, u: fem.Function, w: fem.Function | None = None) -> None:
        """θ̄ = B u / m (and its rate from ``w``) for the nodal-pressure stress."""
        if not self.fields.has_nodal_pressure:
            return
        d = self._anp_setup()
        for src, dst in ((u, d["theta"]), (w, d["theta_v"])):
            if src is None:
                dst.x.array[:] = 0.0
                continue
            d["B"].mult(src.x.petsc_vec, dst.x.petsc_vec)
            dst.x.petsc_vec.array[:] *= d["inv_m"]
            dst.x.scatter_forward()

    def stress_expression(
        self, u: fem.Function, w: fem.Function | None = None
    ) -> ufl.core.expr.Expr:
        """Kelvin–Voigt stress τ = c⁽⁰⁾e(u) + c⁽¹⁾e(w) as a 3×3 UFL tensor.

        In 2D (plane strain) the zz entry is σ_zz.  In nodal-pressure cells the
        volumetric part uses the averaged nodal strain θ̄ (call
        :meth:`update_nodal_volumetric` first).
        """
        f, dim = self.fields, self.dim
        ev = voigt_strain(strain(u), dim)
        sv = ufl.dot(f.C, ev)
        ew = None
        if w is not None and f.has_viscosity:
            ew = voigt_strain(strain(w), dim)
            sv = sv + ufl.dot(f.C_v, ew)
        vol = 0
        if f.has_nodal_pressure:
            d = self._anp_setup()
            vol = f.kappa * d["theta"]
            if ew is not None:
                vol = vol + f.kappa_v * d["theta_v"]
        if dim == 2:
            s2 = tensor_from_voigt(sv, 2) + vol * ufl.Identity(2)
            szz = ufl.dot(ufl.as_vector([f.C_zz[0, i] for i in range(3)]), ev) + vol
            if ew is not None:
                szz = szz + ufl.dot(ufl.as_vector([f.C_zz[1, i] for i in range(3)]), ew)
            return ufl.as_matrix([[s2[0, 0], s2[0, 1], 0], [s2[1, 0], s2[1, 1], 0], [0, 0, szz]])
        return tensor_from_voigt(sv, 3) + vol * ufl.Identity(3)
