"""Primal–dual active set (semi-smooth Newton) solver for mortar contact with friction.

Algorithm (docs/theory/pdas.md#primal-dual-active-set-solver), on the condensed system of
docs/theory/mortar.md#condensation-of-the-multipliers
----------------------------------------------------------
With ``Qᵀ`` from :func:`bonecontact.contact.interface.basis_transform`, the unknowns are
``Û = Q⁻ᵀ U`` (relative displacements at slave nodes), ``Â = Q A Qᵀ`` and
``F̂ = Q F``; the multipliers act only on the slave rows and the weak contact
conditions are nodal.  The rows of every slave node are rotated into its frame
``[n_p; t_p(; t2_p)]`` (matrix ``T``): one normal row and ``gdim − 1`` tangential rows,
whose unknowns are the normal approach ``u_n,p`` and the relative tangential
displacement ``u_t,p``.  The contact force on the rows is ``−w`` with
``w = T(F̂ − ÂÛ)`` and the multipliers are ``λ = w / D_pp``
(docs/theory/mortar.md#condensation-of-the-multipliers); ``λ_n > 0`` is
a pressure.  The slip of a step is ``Δu_t = u_t − u_t^{old}``.

Sets at iteration k (docs/theory/pdas.md#active-set-rule) and what each does to the rows
(docs/theory/pdas.md#linear-system-of-one-iteration):

* open (``p ∉ A_n``): all rows stay (λ = 0);
* ``p ∈ A_n``: the normal row is replaced by ``u_n,p = g_p`` (gap ``d_p / D_pp``);
* stick (``p ∈ A_n``, ``|λ_t + c_t Δu_t| ≤ ĝ_p``, or a slip node whose slip reversed
  under the prescribed traction): the tangential rows are replaced by
  ``u_t,p = u_t^{old}`` (no slip in the step);
* slip (``|λ_t + c_t Δu_t| > ĝ_p``): in 2D the tangential rows carry the traction
  ``λ_t = ĝ_p s_p`` with ``s_p = sign(λ_t + c_t Δu_t)`` of the previous iterate —
  exactly the semi-smooth Newton step of C_t (docs/theory/pdas.md#complementarity-functions).  In 3D
  (default
  ``slip_3d="newton"``) the rows are replaced by the damped semi-smooth Newton
  linearisation of ``|ξ| λ_t − ĝ ξ = 0``, ``ξ = λ_t + c_t Δu_t``
  (Hüeber–Stadler–Wohlmuth 2008; see :func:`bonecontact.contact.friction.slip_newton_rows`): a
  nonsymmetric 2×2 coupling of traction and slip per node, locally superlinear
  (4–6 iterations per Cattaneo–Mindlin increment).  ``slip_3d="fixed_point"``
  prescribes ``λ_t = ĝ_p s_p`` along the previous direction and iterates the
  direction to a fixed point (Aitken-accelerated; symmetric systems, linear
  convergence, 6–18 iterations).  In 3D the sets *and* the directions must settle
  (to ``direction_tol``), and with Newton rows ``|λ_t − ĝ s| ≤ direction_tol · max ĝ``.
* frictionless pairs: the tangential rows always stay (λ_t = 0); their active nodes
  are reported as ``slip``.
* edge (Tresca and semi-implicit Coulomb nodes that keep toggling between open and
  slip at the edge of the zone; docs/theory/pdas.md#edge-of-the-contact-zone): touching
  with zero pressure and a friction traction ``β s_p``, ``0 ≤ β ≤ ĝ_p``, from the solve
  (:func:`bonecontact.contact.friction.update_edge_sets`); reported as active ``slip``.

Friction bounds ``ĝ_p``: Tresca, the given bound; Coulomb ``previous_step`` (semi-
implicit), ``μ λ_n,p`` of the previous step — one Tresca problem per step; Coulomb
``fixed_point`` (Algorithm FP), ``μ max(0, λ_n,p)`` from the current iterate, updated
every ``fp_every`` iterations until its relative change is below ``fp_tol``.  Any
other outcome — iteration limit, a repeated set (cycling) with unchanged bounds, a
singular system — raises :class:`ContactConvergenceError` with the iteration history;
an unconverged state is never returned.  ``c_n = c_t`` default to the mean ratio of
the normal rows' diagonal to ``D_pp`` (≈ E/h), so the set updates weigh gaps, slips
and tractions on the scale of the problem.

Dirichlet rows of master dofs, mixed with slave rows by ``Q``, are reset to the
identity after the transformation, so ``U = Qᵀ Û`` meets every Dirichlet condition.

Non-singular first systems: without a warm start the active set begins with every
node whose gap is within ``gap_tol`` of the smallest gap of its pair (the closed-gap
nodes when the bodies touch, the closest ones when they start apart) and the support
patch around them (:func:`support_patch`), sticking if the pair has friction.  A body
held only by contact therefore starts supported against its rotations too, also when
it touches at a single node.  (Rigid modes that the contact cannot remove — sliding along a
frictionless contact plane — must be fixed by the scene.)  Held at those few nodes,
the first solve overestimates the contact zone (≈ √2 in radius for a Hertzian
contact; in 3D, where the patch acts as a small punch, every node within 1.5 contact
radii), so the first set update of a cold start is not the plain one: in 3D it takes
the zone predicted from the force, approach and stiffness of the patch
(:mod:`bonecontact.contact.cold_start`; 3 iterations on the 3D load-driven Hertz
benchmark at every size tried), in 2D only the newly penetrating nodes deeper than
``cold_start_fraction`` (0.7) of the deepest (Hertz 2D: 2–5 iterations instead of 4–7
for a/h = 5–40, no overshoot).  The solution is the same.

Linear solvers: ``"direct"`` — MUMPS LU.  By default (``strategy="lowrank"``) one
set is factorised and the systems of the other sets are solved exactly by low-rank
updates of it (:mod:`bonecontact.contact.lowrank`): a contact solve costs about one
factorisation plus a few multi-right-hand-side solves, and later steps of a run reuse
the factorisation.  ``strategy="refactor"`` re-factorises (numerically; the symbolic
analysis is reused) in every iteration — the reference the tests compare against.
``"iterative"`` — CG (GMRES with 3D Newton slip rows) preconditioned by GAMG with the
rigid-body modes of every body in the nodal frames, on the eliminated matrix of every
iteration (``strategy="refactor"`` only); the preconditioner is kept across iterations
and steps while the set changes little (:mod:`bonecontact.contact.krylov`).

All set decisions are taken on arrays gathered over the slave nodes of every rank
(``n_slave × gdim`` numbers), identically on every rank; the linear algebra stays
distributed.

Units: λ in Pa (N/m² — in 2D plane strain per unit thickness); forces in N (N/m in 2D);
slips in m.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt
from dolfinx import fem
from scipy.spatial import cKDTree

from bonecontact.common.linalg import configure_ksp
from bonecontact.contact import cold_start
from bonecontact.contact.friction import (
    FRICTION_KIND,
    EdgeSets,
    aitken_directions,
    coulomb_fixed_point_bounds,
    edge_groups,
    merge_groups,
    slip_directions,
    slip_newton_rows,
    slip_set,
    step_bounds,
    update_edge_sets,
    with_normal_row,
)
from bonecontact.contact.interface import (
    ContactInterface,
    basis_transform,
    rotation_matrix,
    transformed_operator,
)
from bonecontact.contact.krylov import (
    PreconditionerReuse,
    configure_condensed_ksp,
    reduction_decades,
)
from bonecontact.contact.lowrank import LowRankActiveSetSolver, SingularActiveSetError, null_pivots
from bonecontact.contact.options import PDASOptions

__all__ = ["ContactConvergenceError", "ContactSolver", "PDASResult", "support_patch"]

#: Radius of the cold-start support patch in local slave mesh sizes (``D_pp`` in 2D,
#: ``√D_pp`` in 3D): the closest nodes' immediate neighbours on every side.
SUPPORT_RADIUS = 1.6


def support_patch(
    coords: npt.NDArray[np.float64],
    D: npt.NDArray[np.float64],
    closest: npt.NDArray[np.bool_],
    gdim: int,
    radius: float = SUPPORT_RADIUS,
) -> npt.NDArray[np.bool_]:
    """The closest slave nodes and every slave node within ``radius`` local mesh sizes of
    one of them (docs/theory/pdas.md#cold-start).

    A single touching node cannot hold a body against its rotations (two in 3D, one in
    2D) about that node; its neighbours on the surface, in every direction, can.  The
    local mesh size of node ``p`` is ``D_pp`` (2D; the length it carries) or
    ``√(D_pp)`` (3D; ``D_pp ≈ 0.87 h²`` on equilateral triangles).

    Parameters
    ----------
    coords, D
        Reference coordinates ``(n, gdim)`` and ``D_pp`` of the slave nodes of a pair
        (replicated: identical on every rank).
    closest
        Mask of the closest nodes.
    gdim
        Geometric dimension.
    radius
        Patch radius in local mesh sizes.

    Returns
    -------
    numpy.ndarray
        Mask of the patch (``closest`` included).
    """
    if not closest.any():
        return closest.copy()
    h = np.abs(D[closest]) ** (1.0 / max(gdim - 1, 1))
    tree = cKDTree(coords[closest])
    dist, j = tree.query(coords, k=1)
    return closest | (dist <= radius * h[j])


class ContactConvergenceError(RuntimeError):
    """The PDAS iteration did not converge; ``history`` holds one dict per iteration."""

    def __init__(self, message: str, history: list[dict]):
        lines = [message, "  it  active  stick  slip  changed  |dU|/|U|    bound_change"]
        for h in history:
            lines.append(
                f"  {h['iteration']:2d}  {h['active']:6d}  {h.get('stick', 0):5d}  "
                f"{h.get('slip', 0):4d}  "
                f"{h['changed']:7d}  {h['update']:.3e}  {h.get('bound_change', 0.0):.3e}"
            )
        super().__init__("\n".join(lines))
        self.history = history


@dataclass
class PDASResult:
    """Outcome of one contact solve (per interface lists hold owned slave nodes).

    ``traction_t`` (Pa) and ``slip`` (the tangential slip of the step, m) have
    ``gdim − 1`` columns; ``status`` is ``"open"``, ``"stick"`` or ``"slip"`` per node.
    """

    iterations: int
    linear_iterations: int
    active: list[npt.NDArray[np.bool_]]
    pressure: list[npt.NDArray[np.float64]]
    gap: list[npt.NDArray[np.float64]]
    slip: list[npt.NDArray[np.float64]]
    normal_force: list[float]
    n_active: list[int]
    history: list[dict] = field(default_factory=list)
    wall_time: float = 0.0
    factorizations: int = 0
    columns: int = 0
    traction_t: list[npt.NDArray[np.float64]] = field(default_factory=list)
    status: list[npt.NDArray[np.str_]] = field(default_factory=list)
    tangential_force: list[float] = field(default_factory=list)
    n_stick: list[int] = field(default_factory=list)
    n_slip: list[int] = field(default_factory=list)
    bound_updates: int = 0


def _allsum(comm: MPI.Comm, x) -> float:
    return comm.allreduce(x, op=MPI.SUM)


@dataclass
class _PDASState:
    """The state of one contact solve carried from one PDAS iteration to the next
    (replicated per-node arrays)."""

    b: PETSc.Vec  # the step's right-hand side (Dirichlet values)
    an: npt.NDArray[np.bool_]  # active set A_n
    stick: npt.NDArray[np.bool_]  # stick set (active friction nodes without slip)
    dirs: npt.NDArray[np.float64]  # slip directions s_p, (NS, gdim − 1)
    g: npt.NDArray[np.float64]  # friction bounds ĝ_p (in operator units)
    xold: npt.NDArray[np.float64]  # unknowns at the start of the step
    values: npt.NDArray[np.float64]  # prescribed values of fixed rows (gap, old slip)
    x_prev: npt.NDArray[np.float64]  # unknowns of the previous iteration
    margin: npt.NDArray[np.float64] | None = None  # rows' distance to switching
    lam_t_k: npt.NDArray[np.float64] | None = None  # 3D Newton: last traction
    z_k: npt.NDArray[np.float64] | None = None  # 3D Newton: last ξ = λ_t + c_t Δu_t
    aitken: list = field(
        default_factory=lambda: [None, 1.0]
    )  # 3D slip directions: residual, relaxation
    edges: EdgeSets | None = None  # edge of the contact zone (docs/theory/pdas.md)
    history: list[dict] = field(default_factory=list)
    seen: set = field(default_factory=set)
    switches: npt.NDArray[np.int_] | None = None  # stick <-> slip switches in this solve
    lin_total: int = 0
    n_bound: int = 0
    f0: int = 0  # low-rank counters at the start of the solve
    c0: int = 0


@dataclass
class _Iterate:
    """What one PDAS iteration computed from its linear solve (replicated arrays)."""

    x: npt.NDArray[np.float64]
    lam_n: npt.NDArray[np.float64]
    lam_t: npt.NDArray[np.float64]
    un: npt.NDArray[np.float64]
    dut: npt.NDArray[np.float64]
    eps: float
    ind_n: npt.NDArray[np.float64]
    z: npt.NDArray[np.float64]
    zn: npt.NDArray[np.float64]
    new_an: npt.NDArray[np.bool_] | None = None
    new_stick: npt.NDArray[np.bool_] | None = None
    new_dirs: npt.NDArray[np.float64] | None = None
    changed_sets: int = 0
    changed_t: int = 0
    turned: int = 0
    bound_change: float = 0.0
    new_edges: EdgeSets | None = None


class ContactSolver:
    """PDAS for mortar contact with Tresca/Coulomb friction (see the module docstring).

    The solver is built in two stages: the constructor takes the space, the contact
    pairs and the options; :meth:`setup` (called by
    :class:`bonecontact.mechanics.integrator.Integrator`, which is handed the solver)
    takes the operator of the time step, its Dirichlet rows, the force scale and the
    linear solver.  The solver is the integrator's
    :class:`~bonecontact.mechanics.step_solver.StepSolver`: besides :meth:`solve` it
    provides the contact gaps and contact work of the energy balance.

    Parameters
    ----------
    V
        The P1 vector space of the model.
    interfaces
        The contact pairs (:func:`bonecontact.contact.interface.build_interface`).
    options
        :class:`~bonecontact.contact.options.PDASOptions` (default: all defaults,
        frictionless).
    """

    def __init__(
        self,
        V: fem.FunctionSpace,
        interfaces: list[ContactInterface],
        options: PDASOptions | None = None,
    ):
        self.V, self.interfaces = V, list(interfaces)
        self.options = options if options is not None else PDASOptions()
        self.frictions = self.options.frictions(len(self.interfaces))
        self.comm = V.mesh.comm
        self.bs = V.dofmap.index_map_bs
        self.last_result: PDASResult | None = None
        #: ``on_singular(active, stick)`` (per interface, over its owned slave nodes;
        #: collective) → the bodies the sets leave without support, in words, added to
        #: the message of a singular system; set by the runner
        #: (:func:`bonecontact.scene.rigid_motions.singular_diagnosis`), or ``None``.
        self.on_singular = None
        self.Qt = None
        self._gap_vecs: tuple[PETSc.Vec, PETSc.Vec] | None = None
        self._work_gaps: list[npt.NDArray[np.float64]] = []

    @property
    def slave_blocks(self) -> list[npt.NDArray[np.int32]]:
        """Local blocks of the owned slave nodes that carry a multiplier, per pair."""
        return [itf.blocks for itf in self.interfaces]

    def setup(
        self,
        A: PETSc.Mat,
        bc_rows: npt.ArrayLike | None = None,
        *,
        force_scale: float = 1.0,
        linear: str = "direct",
        rtol: float = 1e-12,
    ) -> None:
        """Transform and factorise (or precondition) the operator of the time step.

        Parameters
        ----------
        A
            The operator of one time step with Dirichlet rows and columns already
            eliminated (e.g. ``Integrator.A_bc``); it is transformed once here.
        bc_rows
            Global PETSc rows (owned) with Dirichlet conditions.
        force_scale
            Factor turning the operator's forces into physical ones (1 for static;
            1/Δt quasistatic; 1/Δt² dynamic, matching ``combined_operator``).
        linear
            ``"direct"`` or ``"iterative"``.
        rtol
            Krylov tolerance (iterative solver).
        """
        t0 = time.perf_counter()
        opts = self.options
        V, comm, bs = self.V, self.comm, self.bs
        c_n, c_t, gap_tol, strategy = opts.c_n, opts.c_t, opts.gap_tol, opts.strategy
        prefix, max_columns, rebase_ratio, slip_3d = (
            opts.prefix,
            opts.max_columns,
            opts.rebase_ratio,
            opts.slip_3d,
        )
        self.force_scale = float(force_scale)
        self.max_iterations = int(opts.max_iterations)
        self.linear = linear
        self.fp_every, self.fp_tol = max(int(opts.fp_every), 1), float(opts.fp_tol)
        self.direction_tol = float(opts.direction_tol)
        self.slip_3d = opts.slip_3d
        self.cold_start_fraction = float(opts.cold_start_fraction)
        self.Qt = basis_transform(V, self.interfaces)
        self.T = rotation_matrix(V, self.interfaces)
        self.Tt = self.T.transpose(PETSc.Mat())  # (transpose() without an argument is in place)
        self.At = transformed_operator(A, self.Qt, self.Tt)  # unknowns in the nodal frames
        start = bs * V.dofmap.index_map.local_range[0]
        self.bc_rows = np.asarray(bc_rows if bc_rows is not None else [], dtype=PETSc.IntType)
        self.bc_local = (self.bc_rows - start).astype(np.int32)
        self._start = start
        if strategy == "auto":
            strategy = "lowrank" if linear == "direct" else "refactor"
        if strategy not in ("lowrank", "refactor") or (
            strategy == "lowrank" and linear != "direct"
        ):
            raise ValueError(
                f"contact strategy must be 'lowrank' (direct solver only) or 'refactor', "
                f"got {strategy!r} with linear={linear!r}"
            )
        self.strategy = strategy
        # ---- layout: owned slave nodes (interface by interface) and their contact rows
        self.nrow_local = [bs * itf.blocks.astype(np.int64) for itf in self.interfaces]
        sizes = [itf.num_owned for itf in self.interfaces]
        self._m = int(sum(sizes))
        self._split = np.cumsum(sizes)[:-1]
        counts = comm.allgather(self._m)
        self._node_off = int(sum(counts[: comm.rank]))
        self.NS = int(sum(counts))
        nodes_local = np.concatenate(self.nrow_local + [np.zeros(0, np.int64)])
        self._L = np.concatenate([nodes_local + j for j in range(bs)]).astype(
            np.int32
        )  # component-major
        offs = np.cumsum([0] + counts[:-1])
        self._ridx = [
            np.concatenate([bs * o + j * c + np.arange(c) for o, c in zip(offs, counts)]).astype(
                np.int64
            )
            for j in range(bs)
        ]
        # ---- replicated node data
        self._D = self._gn(np.concatenate([itf.D for itf in self.interfaces] + [np.zeros(0)]))
        self._gap = self._gn(np.concatenate([itf.gap for itf in self.interfaces] + [np.zeros(0)]))
        kind = FRICTION_KIND

        def per(f):
            return self._gn(
                np.concatenate(
                    [np.full(n, f(fl), dtype=float) for n, fl in zip(sizes, self.frictions)]
                    + [np.zeros(0)]
                )
            )

        self._fkind = per(lambda fl: kind[fl.kind]).astype(int)
        self._fric = self._fkind > 0
        self._mu = per(lambda fl: fl.coefficient)
        self._bound = per(lambda fl: fl.bound) / self.force_scale
        self._fp = (self._fkind == 2) & (per(lambda fl: fl.update == "fixed_point") > 0)
        self._newton_3d = bs == 3 and slip_3d == "newton" and bool(self._fric.any())
        diag = self.At.getDiagonal()
        self._scale = np.maximum(self._gn(np.abs(diag.array[self._L])), 1e-300)
        diag.destroy()
        sn = self._scale[self._ridx[0]]
        num = float((sn / np.where(self._D > 0, self._D, 1.0)).sum())
        self.c_n = float(c_n) / self.force_scale if c_n is not None else (num / max(self.NS, 1))
        self.c_t = float(c_t) / self.force_scale if c_t is not None else self.c_n
        # value on the diagonal of eliminated rows: the mean normal-row stiffness
        self.diag_value = (num / max(self.NS, 1)) * float(np.mean(self._D)) if self.NS else 1.0
        gdim = V.mesh.geometry.dim
        size = max([itf.slave_area ** (1.0 / (gdim - 1)) for itf in self.interfaces] + [1e-300])
        self.gap_tol = float(gap_tol) if gap_tol is not None else 1e-9 * size
        self.Uh = self.At.createVecRight()
        self._r0, self._rhs, self._w = (
            self.At.createVecLeft(),
            self.At.createVecLeft(),
            self.At.createVecLeft(),
        )
        self._Fh = self.Qt.createVecRight()
        self.reset()
        self.B = self.ksp = self.lowrank = None
        if strategy == "lowrank":
            self.lowrank = LowRankActiveSetSolver(
                self.At,
                self.bc_rows,
                self._L,
                self.diag_value,
                prefix=prefix,
                max_columns=max_columns,
                rebase_ratio=rebase_ratio,
                memory_ratio=opts.memory_ratio,
                split=self._split_basis(A) if opts.split_basis else None,
            )
        else:
            self.B = self.At.duplicate(copy=True)
            self.B.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
            self.ksp = PETSc.KSP().create(comm)
            self.ksp.setOptionsPrefix(prefix)
            configure_ksp(self.ksp, linear, rtol=rtol, prefix=prefix, max_it=3000)
            if linear == "direct":
                PETSc.Options()[f"{prefix}mat_mumps_icntl_24"] = (
                    1  # detect null pivots (singular sets)
                )
            if linear == "iterative":  # (docs/theory/pdas.md#iterative-linear-solver)
                configure_condensed_ksp(
                    self.ksp, self.B, V, self.Qt, self.T, prefix=prefix, rtol=rtol,
                    nonsymmetric=self._newton_3d,
                )  # fmt: skip
            self.ksp.setFromOptions()
        self.pc_reuse = PreconditionerReuse(opts.pc_reuse_rows, opts.pc_reuse_growth)
        self.rtol = float(rtol)
        # inexact PDAS (docs/theory/pdas.md#inexact-solves): frictionless iterative only
        inexact = linear == "iterative" and not self._fric.any()
        self.loose_rtol = (
            float(opts.loose_rtol) if inexact and opts.loose_rtol > self.rtol else self.rtol
        )
        self.setup_time = time.perf_counter() - t0

    def _split_basis(self, A: PETSc.Mat) -> tuple:
        """Arguments of the low-rank solver's split basis: the operator in the original
        basis, the rows (all components) of the cold-start support patch and the rows
        fixed in its first system (the base)."""
        allowed = np.zeros(self.bs * self.NS, dtype=bool)
        for j in range(self.bs):
            allowed[self._ridx[j][self._an]] = True
        return (A, self.Qt, self.T, self.Tt, allowed, self._fixed_rows(self._an, self._an))

    # ------------------------------------------------------------------ layout helpers
    def _gn(self, local: npt.NDArray) -> npt.NDArray:
        """Local per-node (or per-row) values → the replicated array, identical on all ranks."""
        return np.concatenate(self.comm.allgather(np.ascontiguousarray(local)), axis=0)

    def _unsupported(self, st: _PDASState) -> str:
        """What :attr:`on_singular` says about the sets of ``st`` (empty without it)."""
        if self.on_singular is None:
            return ""
        text = self.on_singular(self._own(st.an), self._own(st.an & st.stick))
        return f"; with this active set: {text}" if text else ""

    def _own(self, rep: npt.NDArray) -> list[npt.NDArray]:
        """Replicated per-node array → this rank's nodes, split by interface."""
        return np.split(rep[self._node_off : self._node_off + self._m], self._split)

    def _cold_start(self) -> npt.NDArray[np.bool_]:
        """Initial active set (docs/theory/pdas.md#cold-start): per pair, the nodes whose
        gap is within ``gap_tol`` of the smallest gap of that pair (the closed-gap nodes
        when the bodies touch, the closest ones when they start apart), and the support
        patch around them (:func:`support_patch`), so that a body held only by contact
        is supported against its rigid modes from the first solve even when it touches
        at a single node."""
        out = []
        for itf in self.interfaces:
            gap = self._gn(itf.gap)
            closest = gap <= max(float(gap.min()) if gap.size else 0.0, 0.0) + self.gap_tol
            patch = support_patch(self._gn(itf.coords), self._gn(itf.D), closest, itf.gdim)
            lo = sum(self.comm.allgather(itf.num_owned)[: self.comm.rank])
            out.append(patch[lo : lo + itf.num_owned])
        return self._gn(np.concatenate(out + [np.zeros(0, bool)]))

    @property
    def active(self) -> list[npt.NDArray[np.bool_]]:
        """The current (warm-start) active set, per interface, owned nodes."""
        return [a.copy() for a in self._own(self._an)]

    def reset(self) -> None:
        """Forget the warm start (cold start from the closed-gap set next time)."""
        self._an = self._cold_start()
        self._cold = True
        self._dir = np.zeros((self.NS, self.bs - 1))
        self._lam_n_prev = np.zeros(self.NS)
        self.Uh.set(0.0)

    def state(self) -> dict:
        """The warm start carried from one step to the next (for a checkpoint).

        Per pair, on this rank's owned slave nodes (the order of ``interface.blocks``):
        ``active`` (bool), ``directions`` (slip directions, (n, gdim − 1)), ``lam_n_prev``
        (previous normal multipliers, operator units) and ``work_gaps`` (gaps before the
        next step, for the contact work); ``Uh`` the last solution in the nodal frames
        (owned rows, a copy) and ``cold`` whether no step has been solved yet.
        """
        return {
            "active": [a.copy() for a in self._own(self._an)],
            "directions": [a.copy() for a in self._own(self._dir)],
            "lam_n_prev": [a.copy() for a in self._own(self._lam_n_prev)],
            "work_gaps": [g.copy() for g in self._work_gaps],
            "Uh": self.Uh.array.copy(),
            "cold": bool(self._cold),
        }

    def restore_state(self, state: dict) -> None:
        """Take the warm start of :meth:`state` (same layout; collective)."""

        def rep(key: str, dtype: type) -> npt.NDArray:
            parts = [np.asarray(a, dtype=dtype) for a in state[key]]
            return self._gn(np.concatenate(parts) if parts else np.zeros(0, dtype))

        self._an = rep("active", bool)
        self._dir = rep("directions", float).reshape(self.NS, self.bs - 1)
        self._lam_n_prev = rep("lam_n_prev", float)
        self._work_gaps = [np.asarray(g, dtype=float).copy() for g in state["work_gaps"]]
        self.Uh.array[:] = state["Uh"]
        self._cold = bool(state["cold"])

    def _fixed_rows(self, an: npt.NDArray, stick: npt.NDArray) -> npt.NDArray[np.bool_]:
        fixed = np.zeros(self.bs * self.NS, dtype=bool)
        fixed[self._ridx[0][an]] = True
        st = an & stick & self._fric
        for j in range(1, self.bs):
            fixed[self._ridx[j][st]] = True
        return fixed

    # ------------------------------------------------------------------ linear solves
    def _solve_refactor(
        self, fixed, values, wg, b, coupled=None
    ) -> tuple[np.ndarray, np.ndarray, int]:
        """Eliminate the fixed rows (symmetric), prescribe ``w`` at force rows, replace the
        rows of ``coupled`` by their linearised slip equations, solve."""
        v = self._rhs.duplicate()
        v.set(0.0)
        if self.bc_local.size:
            v.array[self.bc_local] = b.array[self.bc_local]
        lo = self.bs * self._node_off
        own_fixed = fixed[lo : lo + self._L.size]
        v.array[self._L[own_fixed]] = values[lo : lo + self._L.size][own_fixed]
        self._r0.copy(self._rhs)
        self._rhs.array[self._L] -= wg[lo : lo + self._L.size]
        self.At.copy(self.B, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        rows = np.concatenate(
            [self.bc_rows.astype(np.int64), self._L[own_fixed].astype(np.int64) + self._start]
        ).astype(PETSc.IntType)
        self.B.zeroRowsColumns(rows, diag=self.diag_value, x=v, b=self._rhs)
        v.destroy()
        if coupled is not None:
            self._replace_rows(coupled, lo)
        self.ksp.setOperators(self.B)
        iterative = self.linear == "iterative"
        if iterative:
            replaced = fixed.copy()
            if coupled is not None:
                replaced[np.asarray(coupled[0]).ravel()] = True
            kept = self.pc_reuse.decide(self.ksp, replaced)
        try:
            self.ksp.solve(self._rhs, self.Uh)
            if iterative and kept and self.ksp.getConvergedReason() < 0:
                self.pc_reuse.forget()  # a kept preconditioner failed: rebuild, solve again
                self.pc_reuse.decide(self.ksp, replaced)
                self.ksp.solve(self._rhs, self.Uh)
        except PETSc.Error as exc:
            raise SingularActiveSetError(
                f"linear solve failed (singular system? PETSc error {exc.ierr})"
            ) from None
        if iterative:
            self.pc_reuse.record(self.ksp.getIterationNumber(), reduction_decades(self.ksp))
        if null_pivots(self.ksp):
            raise SingularActiveSetError(
                f"the system of the active set is singular ({null_pivots(self.ksp)} "
                f"null pivots: a body without support?)"
            )
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise SingularActiveSetError(f"the linear solver diverged (reason {reason})")
        self.At.mult(self.Uh, self._w)
        self._w.aypx(-1.0, self._r0)  # w = T F̂ − At Û
        return (
            self._gn(self.Uh.array[self._L]),
            self._gn(self._w.array[self._L]),
            self.ksp.getIterationNumber(),
        )

    def _replace_rows(self, coupled, lo: int) -> None:
        """Rows ``q`` of a slip node (free, no prescribed force): with ``w = rhs − B x``
        there, ``G w + H x = h`` becomes ``G B x − H x = G rhs − h`` (same pattern: the
        rows of one node share their columns)."""
        crow, Gc, Hc, hc = coupled
        hi = lo + self._L.size
        mine = np.flatnonzero((crow[:, 0] >= lo) & (crow[:, 0] < hi))
        updates = []
        for i in mine:
            grows = [int(self._L[q - lo]) + self._start for q in crow[i]]
            data = [self.B.getRow(r) for r in grows]
            cols = data[0][0]
            vals = np.array([d[1] for d in data])
            if any(not np.array_equal(d[0], cols) for d in data):
                raise RuntimeError(
                    "contact: the rows of a slave node do not share their sparsity pattern"
                )
            rhs_loc = np.array([self._rhs.array[r - self._start] for r in grows])
            new = Gc[i] @ vals
            for a in range(len(grows)):
                for b_, c in enumerate(grows):
                    new[a, int(np.flatnonzero(cols == c)[0])] -= Hc[i, a, b_]
            updates.append((grows, cols, new))
            self._rhs.array[np.array(grows) - self._start] = Gc[i] @ rhs_loc - hc[i]
        for grows, cols, new in updates:  # (no MatGetRow once values are set)
            for a, r in enumerate(grows):
                self.B.setValues([r], cols, new[a], addv=PETSc.InsertMode.INSERT_VALUES)
        self.B.assemble()

    # -------------------------------------------------------------------- solve
    def solve(self, b: PETSc.Vec, u: fem.Function) -> PDASResult:
        """Solve one contact problem ``A U = b + contact forces``; write ``U`` into ``u``.

        ``b`` is the right-hand side of the step with Dirichlet lifting applied (as
        for the plain linear solve).  Sets, slip directions and ``Û`` are warm-started
        from the previous call; the slip of this step is measured from its ``Û``.

        The algorithm, one PDAS iteration per pass of steps 3–9:

        1. right-hand side in the slave frames (:meth:`_assemble_rhs`);
        2. stick predictor from the previous step (:meth:`_predict`);
        3. solve the system of the current sets (:meth:`_solve_linear_system`);
        4. multipliers and indicators from the solution (:meth:`_update_multipliers`);
        5. new active set (:meth:`_update_active_set`);
        6. Coulomb fixed point: friction bounds (:meth:`_update_friction_bounds`);
        7. new stick/slip sets and slip directions (:meth:`_update_slip_sets`);
        8. converged when nothing changed (:meth:`_check_convergence`);
        9. accept the new sets, detect cycling (:meth:`_accept_sets`);
        10. ``U = Qᵀ Tᵀ Ũ`` and the result (:meth:`_finish`).
        """
        if self.Qt is None:
            raise RuntimeError(
                "ContactSolver.solve before setup (the Integrator sets the solver up)"
            )
        t0 = time.perf_counter()
        self._assemble_rhs(b)
        st = self._predict(b)
        loose = self.loose_rtol > self.rtol
        for k in range(1, self.max_iterations + 1):
            self._set_rtol(self.loose_rtol if loose else self.rtol)
            x, w, its, extra = self._solve_linear_system(st, k)
            it = self._update_multipliers(st, x, w)
            self._update_active_set(st, it, k)
            if loose and it.changed_sets == 0:
                # the set settled under a loose solve: the same set to the tight
                # tolerance, from the loose iterate; the tests below see only this solve
                loose = False
                self._set_rtol(self.rtol)
                x, w, its2, extra = self._solve_linear_system(st, k)
                its += its2
                it = self._update_multipliers(st, x, w)
                self._update_active_set(st, it, k)
            extra["krylov_rtol"] = self.loose_rtol if loose else self.rtol
            self._update_friction_bounds(st, it, k)
            self._update_slip_sets(st, it)
            self._update_edge_sets(st, it)
            if self._check_convergence(st, it, k, its, extra) and not loose:
                break
            try:
                self._accept_sets(st, it, k)
            except ContactConvergenceError:
                if not loose:
                    raise
                # a set repeated under loose solves: from here on every solve is tight
                loose = False
                st.seen.clear()
        else:
            raise ContactConvergenceError(
                f"contact: no convergence in {self.max_iterations} PDAS iterations", st.history
            )
        self.last_result = self._finish(st, it, u, t0)
        return self.last_result

    def _assemble_rhs(self, b: PETSc.Vec) -> None:
        """Step 1: ``T F̂ = T Q b`` (Dirichlet rows keep their prescribed values)."""
        self.Qt.multTranspose(b, self._Fh)
        self.T.mult(self._Fh, self._r0)
        if self.bc_local.size:
            self._r0.array[self.bc_local] = b.array[self.bc_local]

    def _predict(self, b: PETSc.Vec) -> _PDASState:
        """Step 2: the warm-started sets with every active friction node sticking.

        Stick predictor: every active friction node starts the step sticking (the
        elastic trial state); the first solve shows where the bound is exceeded.
        """
        R = self._ridx
        xold = self._gn(self.Uh.array[self._L])
        values = xold.copy()
        values[R[0]] = self._gap
        st = _PDASState(
            b=b,
            an=self._an.copy(),
            stick=self._an & self._fric,
            dirs=self._dir.copy(),
            g=step_bounds(self._fkind, self._bound, self._mu, self._lam_n_prev),
            xold=xold,
            values=values,
            x_prev=xold,
            edges=EdgeSets.empty(self.NS),
            switches=np.zeros(self.NS, dtype=int),
        )
        lr = self.lowrank
        if lr is not None:
            st.f0, st.c0 = lr.factorizations, lr.columns
            try:
                lr.begin(
                    self._r0, b.array[self.bc_local], values, self._fixed_rows(st.an, st.stick)
                )
            except SingularActiveSetError as exc:
                raise ContactConvergenceError(
                    f"contact: {exc} (first PDAS iteration){self._unsupported(st)}", st.history
                ) from None
        return st

    def _set_rtol(self, rtol: float) -> None:
        """The relative Krylov tolerance of the next solves (iterative solver only)."""
        if self.ksp is not None and self.linear == "iterative":
            self.ksp.setTolerances(rtol=rtol)

    def _solve_linear_system(
        self, st: _PDASState, k: int
    ) -> tuple[np.ndarray, np.ndarray, int, dict]:
        """Step 3: solve with the rows of the current sets replaced
        (docs/theory/pdas.md#linear-system-of-one-iteration).

        Active normal rows and stick rows are prescribed (``values``); 2D slip rows (and
        3D fixed-point slip rows) carry the prescribed force ``ĝ D s``; 3D Newton slip
        rows are replaced by their linearisation.  Returns the replicated unknowns and
        the forces ``w`` of the contact rows, the linear iterations and extra history.
        """
        bs, D, fric, g = self.bs, self._D, self._fric, st.g
        R = self._ridx
        fixed = self._fixed_rows(st.an, st.stick)
        slip = st.an & fric & ~st.stick
        wg = np.zeros(bs * self.NS)
        coupled = None
        if self._newton_3d:
            # (a slip node with a zero bound is a free row with zero force: no Newton row)
            if (slip & (g > 0.0)).any():
                S = np.flatnonzero(slip & (g > 0.0))
                rows = np.stack([R[j][S] for j in range(1, bs)], axis=1)
                coupled = slip_newton_rows(
                    rows, D[S], self.c_t, st.lam_t_k[S], st.z_k[S], g[S], st.xold
                )
        else:
            for j in range(1, bs):
                wg[R[j][slip]] = (g * D * st.dirs[:, j - 1])[slip]
        coupled = self._with_edge_rows(st, fixed, coupled)
        try:
            if self.lowrank is not None:
                x, w, info = self.lowrank.solve_set(fixed, self._scale, wg, st.margin, coupled)
                its = 1
                extra = {"columns": info["columns"], "refactorized": info["refactorized"]}
            else:
                x, w, its = self._solve_refactor(fixed, st.values, wg, st.b, coupled)
                extra = {}
        except SingularActiveSetError as exc:
            raise ContactConvergenceError(
                f"contact: {exc} (PDAS iteration {k}){self._unsupported(st)}", st.history
            ) from None
        st.lin_total += its
        return x, w, its, extra

    def _update_multipliers(self, st: _PDASState, x: np.ndarray, w: np.ndarray) -> _Iterate:
        """Step 4: ``λ = w / D``, the normal approach, the slip of the step, the normal
        indicator ``λ_n + c_n (u_n − g)`` and ``ξ = λ_t + c_t Δu_t``."""
        bs, R = self.bs, self._ridx
        Dsafe = np.where(self._D > 0, self._D, 1.0)
        lam_n = w[R[0]] / Dsafe
        lam_t = np.stack([w[R[j]] / Dsafe for j in range(1, bs)], axis=1)
        un = x[R[0]]
        dut = np.stack([x[R[j]] - st.xold[R[j]] for j in range(1, bs)], axis=1)
        lam_scale = float(np.abs(lam_n).max()) if self.NS else 0.0
        eps = 1e-10 * max(lam_scale, 1e-300)
        ind_n = lam_n + self.c_n * (un - self._gap)
        z = lam_t + self.c_t * dut
        return _Iterate(
            x=x,
            lam_n=lam_n,
            lam_t=lam_t,
            un=un,
            dut=dut,
            eps=eps,
            ind_n=ind_n,
            z=z,
            zn=np.linalg.norm(z, axis=1),
        )

    def _multipliers_of_field(self, st: _PDASState) -> _Iterate:
        """The multipliers of the full solution ``Ũ`` (low-rank strategy): ``w = T F̂ − At Ũ``
        at the contact rows.

        The small system of the low-rank solver gives ``w`` as a sum of column responses
        that cancel where a set differs much from the factorised one (round-off of
        1e-9 of the load measured on a 2D body held at three nodes); recomputed from the
        field, the contact resultant balances the load to the accuracy of the solve.
        """
        self.At.mult(self.Uh, self._w)
        self._w.aypx(-1.0, self._r0)
        x, w = self._gn(self.Uh.array[self._L]), self._gn(self._w.array[self._L])
        return self._update_multipliers(st, x, w)

    def _update_active_set(self, st: _PDASState, it: _Iterate, k: int) -> None:
        """Step 5: ``p ∈ A_n`` where ``λ_n + c_n (u_n − g) > 0``
        (docs/theory/pdas.md#active-set-rule).

        First update of a cold start: in 3D the set predicted from the compliance of the
        support patch (:func:`bonecontact.contact.cold_start.predicted_set`); in 2D (or
        with ``cold_start_3d="damped"``) of the newly penetrating nodes those within
        ``cold_start_fraction`` of the deepest penetration.
        """
        an = st.an
        # an indicator within ±ε of zero keeps the node's state: an active node whose
        # multiplier is zero to round-off (λ ≈ −ε, a degenerate node at the edge of the
        # zone) stays active instead of toggling (docs/theory/pdas.md#active-set-rule)
        new_an = (it.ind_n > it.eps) | (an & (it.ind_n >= -it.eps))
        if k == 1 and self._cold and self.bs == 3 and self.options.cold_start_3d == "compliance":
            new_an = cold_start.predicted_set(self, st, it)
        elif k == 1 and self._cold and self.cold_start_fraction > 0 and (new_an & ~an).any():
            pen = it.un - self._gap
            new_an &= an | (pen > self.cold_start_fraction * float(pen[new_an & ~an].max()))
        it.new_an = new_an
        it.changed_sets = int((new_an != an).sum())

    def _update_friction_bounds(self, st: _PDASState, it: _Iterate, k: int) -> None:
        """Step 6: Coulomb fixed point (Algorithm FP): bounds from the current normal
        multipliers, every ``fp_every`` iterations and whenever the sets have settled
        for the current bounds."""
        it.bound_change = 0.0
        if not self._fp.any():
            return
        fric, g, new_an = self._fric, st.g, it.new_an
        trial_stick = new_an & fric & ~slip_set(new_an, fric, it.zn, g, it.eps)
        settle = it.changed_sets == 0 and not ((trial_stick != st.stick) & new_an & fric).any()
        if k % self.fp_every == 0 or settle:
            g_new, it.bound_change = coulomb_fixed_point_bounds(g, self._fp, self._mu, it.lam_n)
            if it.bound_change > 0.0:
                st.g = g_new
                st.n_bound += 1
                st.seen.clear()

    def _update_slip_sets(self, st: _PDASState, it: _Iterate) -> None:
        """Step 7: stick/slip sets and slip directions, and how many of them changed.

        2D: a slip node changes when its direction (sign) flips.  3D Newton: directions
        settled and ``λ_t = ĝ s`` on the slip nodes (ĝ > 0).  3D fixed point: directions
        converge (linearly, Aitken-accelerated) to a fixed point.
        """
        fric, g, dirs = self._fric, st.g, st.dirs
        slip = st.an & fric & ~st.stick
        held = self._hold_reversed_releases(st, it, slip)
        new_an = it.new_an
        new_slip, new_dirs = slip_directions(
            slip_set(new_an, fric, it.zn, g, it.eps), slip, it.z, it.zn, g, dirs
        )
        new_slip &= ~held
        new_stick = new_an & fric & ~new_slip
        both = new_slip & slip
        if self.bs == 2:
            turned = 0
        elif self._newton_3d:
            bg = both & (g > 0.0)
            turned = int(
                (np.linalg.norm(new_dirs[bg] - dirs[bg], axis=1) > self.direction_tol).sum()
            )
            gs = max(float(g.max()) if self.NS else 0.0, it.eps)
            off = (
                np.linalg.norm(it.lam_t[bg] - g[bg, None] * new_dirs[bg], axis=1)
                > self.direction_tol * gs
            )
            turned += int(off.sum())
            if turned:
                self._hold_switches(st, new_an, new_stick, new_dirs)
        else:
            turned = int(
                (np.linalg.norm(new_dirs[both] - dirs[both], axis=1) > self.direction_tol).sum()
            )
            stick_changes = int(((new_stick != st.stick) & new_an & fric).sum())
            aitken_directions(both, dirs, new_dirs, it.changed_sets + stick_changes != 0, st.aitken)
        changed_t = int(((new_stick != st.stick) & new_an & fric).sum())
        if self.bs == 2:
            changed_t += int((np.sign(new_dirs[both, 0]) != np.sign(dirs[both, 0])).sum())
        st.switches += (new_stick != st.stick) & new_an & st.an & fric
        it.new_stick, it.new_dirs, it.changed_t, it.turned = new_stick, new_dirs, changed_t, turned

    def _hold_reversed_releases(
        self, st: _PDASState, it: _Iterate, slip: npt.NDArray[np.bool_]
    ) -> npt.NDArray[np.bool_]:
        """Slip nodes that the solve released (``λ_n < 0``) while they slipped against
        the direction of their traction (``Δu_t · s < 0``) stay active and stick
        (docs/theory/pdas.md#active-set-rule): their pressure was computed with a
        friction traction outside the law, so their normal indicator is not trusted.

        ``it.new_an`` and ``it.changed_sets`` are updated; returns the nodes held.
        """
        back = (it.dut * st.dirs).sum(axis=1)
        tol = 1e-12 * max(float(np.abs(it.dut).max()) if self.NS else 0.0, 1e-300)
        held = slip & ~it.new_an & (st.g > 0.0) & (back < -tol)
        if held.any():
            it.new_an = it.new_an | held
            it.changed_sets = int((it.new_an != st.an).sum())
        return held

    def _hold_switches(
        self,
        st: _PDASState,
        new_an: npt.NDArray[np.bool_],
        new_stick: npt.NDArray[np.bool_],
        new_dirs: npt.NDArray[np.float64],
    ) -> None:
        """3D Newton slip rows, while slip directions still turn: a node that already
        switched between stick and slip in this solve keeps its state (``new_stick``,
        ``new_dirs`` in place) until the directions have settled
        (docs/theory/pdas.md#active-set-rule).  Its indicator is taken on a linearisation
        point that is still moving; deciding on it toggles the node at the rim of the
        friction disc.  Once no direction turns, the plain rule decides again."""
        hold = (new_stick != st.stick) & new_an & st.an & self._fric & (st.switches >= 1)
        new_stick[hold] = st.stick[hold]
        new_dirs[hold] = st.dirs[hold]

    def _with_edge_rows(self, st: _PDASState, fixed: np.ndarray, coupled: tuple | None):
        """Step 3, edge nodes (docs/theory/pdas.md#edge-of-the-contact-zone): their normal
        and tangential rows become one coupled group (zero pressure, touching, traction
        along the slip direction); 3D Newton slip groups then take their normal row
        along (``u_n = g``) so that all groups have the same size.  ``fixed`` loses the
        normal rows moved into groups (in place)."""
        edge = st.edges.edge
        if not edge.any():
            return coupled
        R, k = self._ridx, self._scale[self._ridx[0]]
        nodes = np.flatnonzero(edge)
        groups = edge_groups(nodes, R, st.dirs, self._gap, k)
        fixed[R[0][nodes]] = False
        if coupled is not None:
            normal = R[0][np.searchsorted(R[1], coupled[0][:, 0])]
            coupled = with_normal_row(
                coupled, normal, self._gap[np.searchsorted(R[0], normal)], self._scale[normal]
            )
            fixed[normal] = False
        return merge_groups(coupled, groups)

    def _update_edge_sets(self, st: _PDASState, it: _Iterate) -> None:
        """Step 7b: the edge rule for friction nodes whose bound does not follow the current
        pressure (docs/theory/pdas.md#edge-of-the-contact-zone), and the set changes
        counted again when it moved a node."""
        rigid = self._fric & ~self._fp
        if not rigid.any():
            return
        new_an, new_stick = it.new_an.copy(), it.new_stick.copy()
        gs = max(float(st.g.max()) if self.NS else 0.0, it.eps)
        it.new_edges = update_edge_sets(
            st.an, it.new_an, st.stick, it.new_stick, it.new_dirs, st.dirs, st.edges, rigid,
            st.g, it.lam_t, it.z, it.zn, 1e-10 * gs,
        )  # fmt: skip
        old, new = st.edges.edge, it.new_edges.edge
        moved = (new_an != it.new_an).any() or (new_stick != it.new_stick).any()
        if not (moved or old.any() or new.any()):
            return
        fric = self._fric
        it.changed_sets = int((it.new_an != st.an).sum() + (new != old).sum())
        changed_t = int(((it.new_stick != st.stick) & it.new_an & fric).sum())
        both_e = new & old
        if self.bs == 2:
            slip = st.an & fric & ~st.stick
            both = it.new_an & fric & ~it.new_stick & slip
            flips = np.sign(it.new_dirs[:, 0]) != np.sign(st.dirs[:, 0])
            changed_t += int((flips & (both | both_e)).sum())
        else:
            turn = np.linalg.norm(it.new_dirs[both_e] - st.dirs[both_e], axis=1)
            it.turned += int((turn > self.direction_tol).sum())
        it.changed_t = changed_t

    def _check_convergence(
        self, st: _PDASState, it: _Iterate, k: int, its: int, extra: dict
    ) -> bool:
        """Step 8: record the iteration; converged when no set, sign or direction changed
        and the friction bounds are settled."""
        changed = it.changed_sets + it.changed_t + it.turned
        nrm = float(np.linalg.norm(it.x))
        update = float(np.linalg.norm(it.x - st.x_prev)) / nrm if nrm > 0 else 0.0
        st.x_prev = it.x
        an, fric = st.an, self._fric
        st.history.append(
            {
                "iteration": k,
                "active": int(an.sum()),
                "stick": int((an & st.stick & fric).sum()),
                "slip": int((an & fric & ~st.stick).sum()),
                "changed": changed,
                "update": update,
                "bound_change": it.bound_change,
                "edge": int(st.edges.edge.sum()),
                "linear_iterations": its,
                **extra,
            }
        )
        return changed == 0 and it.bound_change <= self.fp_tol

    def _accept_sets(self, st: _PDASState, it: _Iterate, k: int) -> None:
        """Step 9: take the new sets, with the margins of every row to switching (for the
        speculative low-rank columns); a repeated set with unchanged bounds is cycling."""
        bs, R, fric = self.bs, self._ridx, self._fric
        margin = np.full(bs * self.NS, np.inf)
        margin[R[0]] = np.abs(it.ind_n - it.eps)
        for j in range(1, bs):
            margin[R[j][it.new_an & fric]] = np.abs(it.zn - st.g)[it.new_an & fric]
        st.margin = margin
        st.an, st.stick, st.dirs = it.new_an, it.new_stick, it.new_dirs
        st.lam_t_k, st.z_k = it.lam_t, it.z
        if it.new_edges is not None:
            st.edges = it.new_edges
        if it.changed_sets + it.changed_t == 0:
            return  # only 3D slip directions still turning: not a cycle
        sig = (st.an.tobytes(), st.stick.tobytes(), np.sign(st.dirs).tobytes() if bs == 2 else b"")
        sig += (st.edges.signature(),)
        if sig in st.seen:
            raise ContactConvergenceError(
                f"contact: the active set cycles (iteration {k + 1} repeats an earlier set)",
                st.history,
            )
        st.seen.add(sig)

    def _finish(self, st: _PDASState, it: _Iterate, u: fem.Function, t0: float) -> PDASResult:
        """Step 10: keep the sets for the next warm start, write ``U = Qᵀ Tᵀ Ũ`` into ``u``."""
        lr = self.lowrank
        if lr is not None:
            lr.finish(self.Uh)
            n_fact, n_cols = lr.factorizations - st.f0, lr.columns - st.c0
            it = self._multipliers_of_field(st)
        else:
            n_fact, n_cols = (len(st.history) if self.linear == "direct" else 0), 0
        an = st.an | st.edges.edge  # edge nodes touch (with zero pressure)
        self._an, self._dir = an, st.dirs
        self._cold = False
        self._lam_n_prev = np.where(an, it.lam_n, 0.0)
        uhat = self.Tt.createVecLeft()
        self.Tt.mult(self.Uh, uhat)  # Û = Tᵀ Ũ
        self.Qt.mult(uhat, u.x.petsc_vec)  # U = Qᵀ Û
        uhat.destroy()
        u.x.scatter_forward()
        return self._result(
            an,
            st.stick,
            it.lam_n,
            it.lam_t,
            it.un,
            it.dut,
            st.history,
            st.lin_total,
            n_fact,
            n_cols,
            st.n_bound,
            t0,
        )

    def _result(
        self, an, stick, lam_n, lam_t, un, dut, history, lin_total, n_fact, n_cols, n_bound, t0
    ):
        comm, fs = self.comm, self.force_scale
        fric = self._fric
        pressure_r = np.where(an, lam_n, 0.0) * fs
        trac_r = np.where(an[:, None] & fric[:, None], lam_t, 0.0) * fs
        status_r = np.where(~an, "open", np.where(fric & stick, "stick", "slip"))
        act, pres, gaps, slips, tracs, stats = (
            self._own(an),
            self._own(pressure_r),
            self._own(self._gap - un),
            self._own(dut),
            self._own(trac_r),
            self._own(status_r),
        )
        forces, tforces, n_active, n_stick, n_slip = [], [], [], [], []
        for k, itf in enumerate(self.interfaces):
            forces.append(_allsum(comm, float((itf.weight * pres[k]).sum())))
            ft = np.zeros(itf.gdim)
            for j in range(self.bs - 1):
                if itf.num_owned:
                    ft += ((itf.weight * tracs[k][:, j])[:, None] * itf.tangents[:, j, :]).sum(
                        axis=0
                    )
            ft = comm.allreduce(ft, op=MPI.SUM)
            tforces.append(float(np.linalg.norm(ft)))
            n_active.append(_allsum(comm, int(act[k].sum())))
            n_stick.append(_allsum(comm, int((stats[k] == "stick").sum())))
            n_slip.append(_allsum(comm, int((stats[k] == "slip").sum())))
        return PDASResult(
            iterations=len(history),
            linear_iterations=lin_total,
            active=[a.copy() for a in act],
            pressure=pres,
            gap=gaps,
            slip=slips,
            normal_force=forces,
            n_active=n_active,
            history=history,
            wall_time=time.perf_counter() - t0,
            factorizations=n_fact,
            columns=n_cols,
            traction_t=tracs,
            status=stats,
            tangential_force=tforces,
            n_stick=n_stick,
            n_slip=n_slip,
            bound_updates=n_bound,
        )

    # ------------------------------------------------------------------ energy balance
    def contact_force(self, out: PETSc.Vec) -> None:
        """The contact forces of the last solve on the nodes of the original basis (N; N/m
        in 2D; collective; ``out``: a vector of the original space).

        The contact rows carry ``w = T F̂ − Ã Ũ`` (force ``−w``); a virtual displacement
        ``δU = Qᵀ Tᵀ δŨ`` gives the force ``−Q⁻¹ Tᵀ w`` in the original basis, and
        ``Q⁻¹ = 2I − Q`` (``Q − I`` maps slave rows to master nodes and to the slave nodes
        without a multiplier only, so its square vanishes).  Besides the slave and master
        nodes, a slave node without a multiplier (a Dirichlet node at the edge of the slave
        surface) receives its share ``(D_pq/D_pp) w_p`` of its neighbour's multiplier: there
        the residual of the assembled system is that share plus the support's reaction
        (docs/theory/mortar.md#boundary-modification-of-the-dual-basis).
        """
        self.At.mult(self.Uh, self._w)
        self._w.aypx(-1.0, self._r0)
        wv = self.At.createVecLeft()
        wv.set(0.0)
        wv.array[self._L] = self._w.array_r[self._L]
        tw = self.Tt.createVecLeft()
        self.Tt.mult(wv, tw)
        self.Qt.multTranspose(tw, out)
        out.aypx(-1.0, tw)  # Q⁻¹ Tᵀ w = 2 Tᵀ w − Q Tᵀ w
        out.axpy(1.0, tw)
        out.scale(-self.force_scale)
        wv.destroy()
        tw.destroy()

    def contact_gaps(self, u: fem.Function) -> list[npt.NDArray[np.float64]]:
        """Nodal normal gaps g_p = d_p/D_pp − n_p·(U_p − Σ_q M̂_pq U_q) of every pair for the
        displacement ``u``, in the order of ``interface.blocks`` (owned slave nodes)."""
        if self._gap_vecs is None:
            self._gap_vecs = (self.Qt.createVecLeft(), self.T.createVecLeft())
        tmp, r = self._gap_vecs
        U = u.x.petsc_vec
        self.Qt.mult(U, tmp)
        tmp.aypx(-1.0, U)
        tmp.axpy(1.0, U)  # Û = (2I − Qᵀ) U  (Qᵀ − I is nilpotent)
        self.T.mult(tmp, r)  # rows bs·p: n_p·Û_p
        bs = self.bs
        return [itf.gap - r.array[bs * itf.blocks] for itf in self.interfaces]

    def _snap(self, gaps: list[npt.NDArray[np.float64]]) -> list[npt.NDArray[np.float64]]:
        """Gaps with |g| below 1e-12 of the slave surface size (geometric round-off of
        touching bodies) set to 0, so that closed contact does exactly no work."""
        out = []
        for itf, g in zip(self.interfaces, gaps):
            tol = 1e-12 * itf.slave_area ** (1.0 / max(itf.gdim - 1, 1))
            out.append(np.where(np.abs(g) <= tol, 0.0, g))
        return out

    def start_contact_work(self, u: fem.Function) -> None:
        """Take the gaps of ``u`` (the initial state) as those before the next step."""
        self._work_gaps = self._snap(self.contact_gaps(u))

    def contact_work(self, u: fem.Function) -> float:
        """This rank's part of the contact work of the step just solved (``u``: its solution).

        ``W_c = Σ_p D_pp λ_p (g_pⁿ⁺¹ − g_pⁿ)`` over the owned slave nodes, minus the friction
        work ``Σ_p D_pp λ_t,p · Δu_t,p`` (≤ 0).  The gaps after the step are those the PDAS
        returned (exactly 0 at active nodes, so persistent contact does exactly no work);
        before: those of the previous step (or of :meth:`start_contact_work`).
        """
        res = self.last_result
        gaps = self._snap(res.gap if res is not None else self.contact_gaps(u))
        work = 0.0
        for k, itf in enumerate(self.interfaces):
            p = res.pressure[k] if res is not None else np.zeros(itf.num_owned)
            work += float((itf.D * p * (gaps[k] - self._work_gaps[k])).sum())
            if res is not None and res.traction_t and itf.num_owned:
                # friction: the force −D λ_t on the slip Δu_t of the step (≤ 0)
                work -= float((itf.D[:, None] * res.traction_t[k] * res.slip[k]).sum())
        self._work_gaps = gaps
        return work

    def destroy(self) -> None:
        """Free the PETSc objects."""
        if self.Qt is None:
            return
        if self.lowrank is not None:
            self.lowrank.destroy()
        for obj in (
            self.ksp,
            self.B,
            self.At,
            self.T,
            self.Tt,
            self.Qt,
            self.Uh,
            self._r0,
            self._rhs,
            self._w,
            self._Fh,
            *(self._gap_vecs or ()),
        ):
            if obj is not None:
                obj.destroy()
