"""Load-driven Hertz problems: a curved body held in the load direction only by the contact.

:func:`sphere_on_block_3d` (a hemisphere on a block a thousand times stiffer), its
plane-strain twin :func:`half_disc_on_block_2d`, and the half disc that starts apart.
The builders return a :class:`LoadDrivenHertz` with its pieces and the wall time of each
set-up phase; :func:`hertz_errors` compares a solve with Hertz's solution.  Set-up (load,
the rigid modes fixed and why): docs/theory/verification.md#load-driven-hertz-problems;
reference: docs/theory/verification.md#hertz-contact.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

from mpi4py import MPI

import gmsh
import numpy as np
from dolfinx import fem
from dolfinx.io.gmsh import MeshData

from bonecontact.contact.interface import ContactInterface, build_interface
from bonecontact.contact.options import PDASOptions
from bonecontact.contact.pdas import ContactSolver, PDASResult
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics
from bonecontact.meshing import shapes
from bonecontact.meshing.builder import PhysicalGroups, generate
from bonecontact.meshing.io import read_gmsh_mesh
from bonecontact.verification.analytic import hertz_2d, hertz_3d

__all__ = [
    "LOAD_DRIVEN_E",
    "LOAD_DRIVEN_NU",
    "LOAD_DRIVEN_RADIUS",
    "LOAD_DRIVEN_STIFFNESS_RATIO",
    "LoadDrivenHertz",
    "half_disc_apart_2d",
    "half_disc_apart_mesh",
    "half_disc_on_block_2d",
    "hertz_errors",
    "sphere_on_block_3d",
]

#: Radius (m), Young's modulus (Pa) and Poisson ratio of the curved body, and the
#: block's stiffness relative to it.
LOAD_DRIVEN_RADIUS, LOAD_DRIVEN_E, LOAD_DRIVEN_NU = 0.01, 2.0e9, 0.3
LOAD_DRIVEN_STIFFNESS_RATIO = 1000.0


@dataclass
class LoadDrivenHertz:
    """A built load-driven Hertz problem (docs/theory/verification.md#load-driven-hertz-problems).

    Attributes
    ----------
    mesh_data
        The mesh with its cell and facet tags and ``physical_groups``.
    model
        Materials, the traction load and the Dirichlet conditions.
    interface
        The contact pair (slave: the curved surface; master: the block's top).
    integrator
        A static integrator (one step, pseudo-time 0 → 1) with the
        :class:`~bonecontact.contact.pdas.ContactSolver` of the pair.
    load
        The applied load P as assembled (N in 3D, N/m in 2D): minus the sum of the
        load-direction (y) entries of the load vector.
    radius, E1, E2, nu
        Geometry and materials (curved body E1, block E2, both ν).
    a_target
        The Hertz contact radius (half-width) P was chosen for (m).
    timings
        Wall times (s, max over ranks) of the set-up phases: ``mesh`` (generation or
        read, distribution), ``assembly`` (model, operator, Dirichlet elimination,
        load vector), ``mortar`` (:func:`build_interface`), ``setup`` (the contact
        solver's set-up: transformation, rotation, factorisation or preconditioner
        objects); :meth:`solve` adds ``contact_solve``.
    """

    mesh_data: MeshData
    model: Mechanics
    interface: ContactInterface
    integrator: Integrator
    load: float
    radius: float
    E1: float
    E2: float
    nu: float
    a_target: float
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def dim(self) -> int:
        """Geometric dimension (2 or 3)."""
        return self.model.dim

    @property
    def comm(self) -> MPI.Comm:
        return self.model.mesh.comm

    def solve(self) -> PDASResult:
        """One static step: the contact solve (collective).  Its wall time goes into
        ``timings["contact_solve"]``; raises
        :class:`~bonecontact.contact.pdas.ContactConvergenceError` if the PDAS fails."""
        with _timed(self.comm, self.timings, "contact_solve"):
            self.integrator.step()
        return self.integrator.last_contact

    def destroy(self) -> None:
        """Free the PETSc objects of the integrator and its contact solver."""
        self.integrator.destroy()


class _timed:
    """Context manager: wall time of a collective phase (barriers around it) into
    ``timings[name]``."""

    def __init__(self, comm: MPI.Comm, timings: dict[str, float], name: str):
        self.comm, self.timings, self.name = comm, timings, name

    def __enter__(self) -> None:
        self.comm.barrier()
        self.t0 = time.perf_counter()

    def __exit__(self, *exc) -> None:
        if exc[0] is None:
            self.comm.barrier()
        self.timings[self.name] = time.perf_counter() - self.t0


# ----------------------------------------------------------------------------- builders
def sphere_on_block_3d(
    comm: MPI.Comm,
    h_contact: float,
    *,
    h_far: float = 3.0e-3,
    zone: float = 1.5e-3,
    dist_max_factor: float = 4.0,
    a_over_R: float = 0.1,
    linear: str = "direct",
    rtol: float = 1e-12,
    options: PDASOptions | None = None,
    mesh_file: str | Path | None = None,
    algorithm_3d: str = "delaunay",
    lift: float = 0.0,
) -> LoadDrivenHertz:
    """The 3D load-driven Hertz problem: a hemisphere on a block, held only by contact.

    Hemisphere: the lower half of the ball of radius R = 10 mm centred at (0, R, 0),
    E = 2 GPa, ν = 0.3; block ``[-20, 20] x [-20, 0] x [-20, 20]`` mm, E = 2 TPa,
    ν = 0.3, fixed at its bottom.  The flat face y = R carries the uniform traction
    ``(0, -P/(πR²), 0)`` with ``P = hertz_3d.load_for_radius(a_over_R R, ...)``; the
    hemisphere's lateral rigid modes are fixed as
    docs/theory/verification.md#load-driven-hertz-problems says.

    Parameters
    ----------
    comm
        Communicator.
    h_contact
        Element size of the hemisphere within ``zone`` of the contact point (m); the
        block's is 1.5 times larger.
    h_far
        Element size far from the contact (m).
    zone
        Radius of the refined zone (m).
    dist_max_factor
        The size reaches ``h_far`` at the distance ``zone + dist_max_factor * h_far``.
    a_over_R
        Target Hertz contact radius over R (sets P).
    linear
        ``"direct"`` (MUMPS; low-rank PDAS) or ``"iterative"`` (CG + GAMG).
    rtol
        Krylov tolerance (iterative).
    options
        PDAS options (default: all defaults).
    mesh_file
        If given: a gmsh ``.msh`` file that is written there (rank 0) when it does not
        exist yet and then read, as a scene's mesh is
        (:func:`bonecontact.meshing.io.read_gmsh_mesh`); the ``mesh`` timing is then the
        read (``mesh_generate`` the writing, when it happened).  Default: generate the
        mesh in memory.
    algorithm_3d
        gmsh's volume mesher, ``"delaunay"`` or ``"hxt"`` (fast; large meshes), see
        :func:`bonecontact.meshing.shapes.hertz_3d`.
    lift
        The hemisphere's mesh moved up by ``lift`` (m) before anything is built: it
        starts apart from the block, and the interface is built after the rigid approach
        (docs/theory/pdas.md#bodies-that-start-apart).

    Returns
    -------
    LoadDrivenHertz
    """
    timings: dict[str, float] = {}
    sizes = dict(h_contact=h_contact, h_far=h_far, zone=zone, dist_max_factor=dist_max_factor)
    md = _hemisphere_mesh(comm, mesh_file, timings, lift, algorithm_3d, sizes)
    params, traction = _sphere_load(a_over_R)
    names = ("sphere", "block", "sphere_top", "sphere_contact", "block_contact")
    supports = (("sphere_support_x", 0), ("sphere_support_z", 2))
    return _assemble_problem(
        md, names, supports, traction, params, linear, rtol, options, timings, approach=bool(lift)
    )


def _hemisphere_mesh(
    comm: MPI.Comm,
    mesh_file: str | Path | None,
    timings: dict[str, float],
    lift: float,
    algorithm_3d: str,
    sizes: dict[str, float],
) -> MeshData:
    """The mesh of :func:`sphere_on_block_3d` (:func:`bonecontact.meshing.shapes.hertz_3d`
    with the lateral supports), its hemisphere moved up by ``lift``."""
    build = partial(
        shapes.hertz_3d,
        comm,
        radius=LOAD_DRIVEN_RADIUS,
        lateral_support=True,
        algorithm_3d=algorithm_3d,
        **sizes,
    )
    md = _mesh(comm, build, mesh_file, 3, timings)
    if lift:
        _lift_body(md, "sphere", lift)
    return md


def _sphere_load(a_over_R: float) -> tuple[tuple[float, ...], tuple[float, float, float]]:
    """``(R, E1, E2, nu, a_target)`` and the traction on the hemisphere's flat face whose
    resultant gives the Hertz contact radius ``a_over_R * R``."""
    R, E1, E2, nu, a_t = params = _load_driven_parameters(a_over_R)
    P = hertz_3d.load_for_radius(a_t, R, E1, nu, E2, nu)
    return params, (0.0, -P / (np.pi * R**2), 0.0)


def _load_driven_parameters(a_over_R: float) -> tuple[float, float, float, float, float]:
    """``(R, E1, E2, nu, a_target)`` of the load-driven problems for ``a_over_R``."""
    E2 = LOAD_DRIVEN_STIFFNESS_RATIO * LOAD_DRIVEN_E
    return LOAD_DRIVEN_RADIUS, LOAD_DRIVEN_E, E2, LOAD_DRIVEN_NU, a_over_R * LOAD_DRIVEN_RADIUS


def _lift_body(md: MeshData, body: str, lift: float) -> None:
    """Move the geometry nodes of the cells of ``body`` (a cell group) up by ``lift``;
    the other bodies share no nodes with it (non-matching meshes)."""
    cells = md.cell_tags.find(md.physical_groups[body].tag)
    nodes = np.unique(md.mesh.geometry.dofmaps[0][cells])
    md.mesh.geometry.x[nodes, 1] += lift


def half_disc_on_block_2d(
    comm: MPI.Comm,
    h_contact: float,
    *,
    h_far: float = 2.0e-3,
    zone: float | None = None,
    a_over_R: float = 0.1,
    linear: str = "direct",
    rtol: float = 1e-12,
    options: PDASOptions | None = None,
    mesh_file: str | Path | None = None,
) -> LoadDrivenHertz:
    """The plane-strain twin of :func:`sphere_on_block_3d`: a half disc on a block.

    Half disc: the lower half of the disc of radius R = 10 mm centred at (0, R), on
    the block ``[-50, 50] x [-50, 0]`` mm (materials as in 3D).  The flat face y = R
    carries ``(0, -P/(2R))`` with ``P = hertz_2d.load_for_half_width(a_over_R R, ...)``
    (N/m); ``u_x = 0`` on the axis segment ``cyl_support``.  The disc touches the block
    at exactly one node (the origin).  Parameters as in :func:`sphere_on_block_3d`
    (``zone`` defaults to 1.5 a).
    """
    timings: dict[str, float] = {}
    R, E1, nu = LOAD_DRIVEN_RADIUS, LOAD_DRIVEN_E, LOAD_DRIVEN_NU
    E2 = LOAD_DRIVEN_STIFFNESS_RATIO * E1
    a_t = a_over_R * R
    zone = 1.5 * a_t if zone is None else zone

    def build(path: Path | None):
        return shapes.hertz_2d(
            comm,
            path,
            radius=R,
            h_contact=h_contact,
            h_far=h_far,
            zone=zone,
            lateral_support=True,
        )

    md = _mesh(comm, build, mesh_file, 2, timings)
    P = hertz_2d.load_for_half_width(a_t, R, E1, nu, E2, nu)
    return _assemble_problem(
        md,
        ("cylinder", "block", "cyl_top", "cyl_contact", "block_contact"),
        (("cyl_support", 0),),
        (0.0, -P / (2.0 * R)),
        (R, E1, E2, nu, a_t),
        linear,
        rtol,
        options,
        timings,
    )


def half_disc_apart_2d(
    comm: MPI.Comm,
    *,
    offset: float = 0.5,
    gap: float = 0.0,
    contrast: float = LOAD_DRIVEN_STIFFNESS_RATIO,
    a_over_h: float = 5.0,
    a_over_R: float = 0.02,
    radius: float = 0.05,
    options: PDASOptions | None = None,
    approach: bool = True,
) -> LoadDrivenHertz:
    """A half disc pressed by a traction onto a stiffer block, held only by contact,
    its apex anywhere relative to the nodes and its surface apart from the block
    (issue #23's configurations; docs/theory/pdas.md#bodies-that-start-apart).

    Half disc: radius ``radius`` (default 50 mm), E = 2 GPa, ν = 0.3, centred at
    ``(0, radius + gap)``; block ``[-2R, 2R] x [-R, 0]``, E = ``contrast`` × 2 GPa, fixed
    at its bottom.  Around the apex the arc is meshed uniformly with ``h = a/a_over_h``
    (``a = a_over_R R``, the Hertz half-width the load is chosen for) so that the
    nearest node lies ``offset h`` from the apex (0: a node at the apex, 0.5: two nodes
    with equal gaps ``≈ h²/(8R)``, as in the issue).  ``u_x = 0`` on the axis segment
    ``support`` inside the disc removes the horizontal translation and the rotation
    about the centre, which the frictionless contact cannot; nothing holds the disc
    vertically but the contact.  ``approach``: build the interface after the rigid
    approach (:func:`bonecontact.contact.interface.build_interface`).
    """
    timings: dict[str, float] = {}
    R, E1, nu = radius, LOAD_DRIVEN_E, LOAD_DRIVEN_NU
    E2 = contrast * E1
    a_t = a_over_R * R
    h = a_t / a_over_h

    def build(path: Path | None):
        return half_disc_apart_mesh(comm, path, radius=R, gap=gap, h=h, offset=offset)

    md = _mesh(comm, build, None, 2, timings)
    P = hertz_2d.load_for_half_width(a_t, R, E1, nu, E2, nu)
    return _assemble_problem(
        md,
        ("disc", "block", "disc_top", "disc_contact", "block_contact"),
        (("support", 0),),
        (0.0, -P / (2.0 * R)),
        (R, E1, E2, nu, a_t),
        "direct",
        1e-12,
        options,
        timings,
        approach=approach,
    )


def half_disc_apart_mesh(
    comm: MPI.Comm | None = None,
    path: str | Path | None = None,
    *,
    radius: float = 0.05,
    gap: float = 0.0,
    h: float = 2.0e-4,
    offset: float = 0.5,
) -> MeshData | Path:
    """The mesh of :func:`half_disc_apart_2d` (written to ``path`` if given).

    Cell groups ``disc``, ``block``; facet groups ``disc_contact`` (the arc, slave),
    ``disc_top`` (the flat face), ``support`` (the axis segment inside the disc),
    ``block_contact`` (master), ``block_bottom``.  ``h``: element size at the apex (m);
    ``offset``: distance of the nearest node from the apex in elements; ``gap``: lift
    of the disc above the block (m; negative: overlap).
    """
    return generate(
        "half_disc_apart",
        2,
        lambda: _half_disc_apart_geometry(radius, gap, h, offset),
        comm,
        path,
    )


def _half_disc_apart_geometry(R: float, gap: float, h: float, offset: float) -> None:
    """gmsh geometry, sizes and groups of :func:`half_disc_apart_2d` (current model)."""
    geo = gmsh.model.geo
    yc = R + gap
    dth = h / R
    k = 12  # uniform elements on each side of the apex
    th0, th1 = -(k + offset) * dth, (k + 1 - offset) * dth  # from the apex direction
    c = geo.addPoint(0, yc, 0)
    pl, pr = geo.addPoint(-R, yc, 0), geo.addPoint(R, yc, 0)
    q0 = geo.addPoint(R * np.sin(th0), yc - R * np.cos(th0), 0)
    q1 = geo.addPoint(R * np.sin(th1), yc - R * np.cos(th1), 0)
    left, mid, right = (
        geo.addCircleArc(pl, c, q0),
        geo.addCircleArc(q0, c, q1),
        geo.addCircleArc(q1, c, pr),
    )
    top = geo.addLine(pr, pl)
    disc = geo.addPlaneSurface([geo.addCurveLoop([left, mid, right, top])])
    s0, s1 = geo.addPoint(0, yc - 0.6 * R, 0), geo.addPoint(0, yc - 0.1 * R, 0)
    support = geo.addLine(s0, s1)
    b = [geo.addPoint(x, y, 0) for x, y in ((-2 * R, -R), (2 * R, -R), (2 * R, 0), (-2 * R, 0))]
    bottom, side_r = geo.addLine(b[0], b[1]), geo.addLine(b[1], b[2])
    btop, side_l = geo.addLine(b[2], b[3]), geo.addLine(b[3], b[0])
    block = geo.addPlaneSurface([geo.addCurveLoop([bottom, side_r, btop, side_l])])
    geo.synchronize()
    gmsh.model.mesh.embed(1, [support], 2, disc)
    gmsh.model.mesh.setTransfiniteCurve(mid, 2 * k + 2)
    h_far = 0.1 * R
    fld = gmsh.model.mesh.field
    dist = fld.add("MathEval")
    fld.setString(
        dist,
        "F",
        f"{h} + 0.3 * Max(0, Sqrt(x*x + Min((y-({gap}))*(y-({gap})), y*y)) - {(k + 1) * h})",
    )
    cap = fld.add("MathEval")
    fld.setString(cap, "F", f"{h_far}")
    fmin = fld.add("Min")
    fld.setNumbers(fmin, "FieldsList", [dist, cap])
    fld.setAsBackgroundMesh(fmin)
    for option in ("MeshSizeFromPoints", "MeshSizeExtendFromBoundary", "MeshSizeFromCurvature"):
        gmsh.option.setNumber(f"Mesh.{option}", 0)
    groups = PhysicalGroups()
    groups(2, [disc], "disc")
    groups(2, [block], "block")
    groups(1, [left, mid, right], "disc_contact")
    groups(1, [top], "disc_top")
    groups(1, [support], "support")
    groups(1, [btop], "block_contact")
    groups(1, [bottom], "block_bottom")


def _mesh(
    comm: MPI.Comm,
    build: Callable[[Path | None], MeshData | Path],
    mesh_file: str | Path | None,
    gdim: int,
    timings: dict[str, float],
) -> MeshData:
    """Generate the mesh in memory, or write it to ``mesh_file`` (if missing) and read it."""
    if mesh_file is None:
        with _timed(comm, timings, "mesh"):
            md = build(None)
        return md
    mesh_file = Path(mesh_file)
    if not comm.allreduce(mesh_file.exists() if comm.rank == 0 else True, op=MPI.LAND):
        with _timed(comm, timings, "mesh_generate"):
            build(mesh_file)
    with _timed(comm, timings, "mesh"):
        _, md = read_gmsh_mesh(mesh_file, comm, gdim)
    return md


def _assemble_problem(
    md: MeshData,
    names: tuple[str, str, str, str, str],
    supports: tuple[tuple[str, int], ...],
    traction: tuple[float, ...],
    params: tuple[float, float, float, float, float],
    linear: str,
    rtol: float,
    options: PDASOptions | None,
    timings: dict[str, float],
    approach: bool = False,
) -> LoadDrivenHertz:
    """Model, interface and integrator of a load-driven problem, timed phase by phase."""
    body, block, top, slave, master = names
    R, E1, E2, nu, a_t = params
    comm = md.mesh.comm
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    with _timed(comm, timings, "assembly"):
        m = Mechanics(
            md.mesh,
            {pg[body]: Isotropic(E=E1, nu=nu), pg[block]: Isotropic(E=E2, nu=nu)},
            md.cell_tags,
            md.facet_tags,
        )
        for c in range(m.dim):
            m.add_dirichlet(m.facets(pg["block_bottom"]), c, 0.0)
        for name, component in supports:
            m.add_dirichlet(m.facets(pg[name]), component, 0.0)
        m.add_traction(pg[top], traction)
        f = fem.Function(m.V)  # (kept alive: its PETSc vector wraps its array)
        F = m.load_vector(1.0, f.x.petsc_vec)
        P = -comm.allreduce(float(F.array_r[1 :: m.dim].sum()), op=MPI.SUM)
    with _timed(comm, timings, "mortar"):
        itf = build_interface(
            m.V,
            md.facet_tags,
            pg[slave],
            pg[master],
            dirichlet_dofs=m.bc_dofs(),
            groups=(slave, master),
            approach=approach,
        )
    comm.barrier()
    t0 = time.perf_counter()
    solver = ContactSolver(m.V, [itf], options)
    integ = Integrator(m, "static", 1.0, linear=linear, rtol=rtol, contact=solver)
    comm.barrier()
    t_total = time.perf_counter() - t0
    t_setup = comm.allreduce(solver.setup_time, op=MPI.MAX)
    timings["assembly"] += t_total - t_setup  # the operator and its Dirichlet elimination
    timings["setup"] = t_setup
    return LoadDrivenHertz(md, m, itf, integ, P, R, E1, E2, nu, a_t, timings)


# ----------------------------------------------------------------------------- errors
def hertz_errors(problem: LoadDrivenHertz, result: PDASResult | None = None) -> dict:
    """Compare the solved problem with Hertz's solution (collective).

    The contact resultant ``P = Σ_p w_p λ_p (−n_p,y)`` (``w_p = ∫ψ_p``) gives the Hertz
    references a(P), p₀(P); a and p₀ are fitted as λ² = p₀²(1 − r²/a²) over the nodes
    with r < 0.8 a(P) (r = |x| in 2D, √(x² + z²) in 3D), as in
    :func:`bonecontact.verification.problems.solve_hertz_3d`.

    Returns
    -------
    dict
        ``a``, ``p0`` (relative errors of the fitted values), ``P_contact`` (the
        resultant), ``P_applied`` (``problem.load``), ``equilibrium``
        (``|P_contact − P_applied| / P_applied``), ``a_over_R`` (Hertz, from the
        resultant), ``active`` (nodes in contact) and the PDAS ``iterations``.
    """
    r = problem.integrator.last_contact if result is None else result
    itf, comm, dim = problem.interface, problem.comm, problem.dim
    R, E1, E2, nu = problem.radius, problem.E1, problem.E2, problem.nu
    lam_local = r.pressure[0]
    P = comm.allreduce(float(-(itf.weight * lam_local * itf.normals[:, 1]).sum()), op=MPI.SUM)
    X = np.concatenate(comm.allgather(itf.coords))
    lam = np.concatenate(comm.allgather(lam_local))
    law = hertz_3d if dim == 3 else hertz_2d
    a_ref = law.radius(P, R, E1, nu, E2, nu) if dim == 3 else law.half_width(P, R, E1, nu, E2, nu)
    p0_ref = law.peak_pressure(P, R, E1, nu, E2, nu)
    rr = np.hypot(X[:, 0], X[:, 2]) if dim == 3 else np.abs(X[:, 0])
    sel = rr < 0.8 * a_ref
    c0, c1 = np.linalg.lstsq(np.c_[np.ones(sel.sum()), rr[sel] ** 2], lam[sel] ** 2, rcond=None)[0]
    return {
        "a": float(np.sqrt(-c0 / c1) / a_ref - 1.0),
        "p0": float(np.sqrt(c0) / p0_ref - 1.0),
        "P_contact": P,
        "P_applied": problem.load,
        "equilibrium": abs(P - problem.load) / problem.load,
        "a_over_R": a_ref / R,
        "active": int(sum(r.n_active)),
        "iterations": r.iterations,
    }
