"""Stress intensity factors of a 2D crack tip (docs/theory/fracture.md#stress-intensity-factors).

* :func:`interaction_integral` — the domain form of the interaction integral with
  Williams' auxiliary fields (:mod:`bonecontact.fracture.williams`) and a plateau
  q-function over a ring around the tip; gives K_I, K_II and the domain J.  It is a sum
  over cells, assembled by DOLFINx (parallel as the assembly is).
* :func:`displacement_correlation` — K from the opening and sliding of the crack faces
  behind the tip, extrapolated to the tip: the cheap cross-check.
* :func:`energy_release_rate` — G = (K_I² + K_II²)/E′.

Limits (stated, checked where they can be): the material inside the domain must be one
homogeneous isotropic material (a domain crossing a material interface, or an anisotropic
material, is refused with :class:`~bonecontact.common.errors.ParameterError`); the crack
faces inside the domain are straight and traction-free (no crack-face contact term); the
domain must not reach another boundary.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import default_scalar_type, fem, mesh

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.meshing import CrackedMesh
from bonecontact.fracture.williams import PlaneState, elastic_constants, williams_displacement_ufl
from bonecontact.materials.laws import Isotropic, Material

__all__ = [
    "SIFResult",
    "displacement_correlation",
    "energy_release_rate",
    "interaction_integral",
    "plane_stress_equivalent",
]


@dataclass(frozen=True)
class SIFResult:
    """Stress intensity factors at one tip.

    Attributes
    ----------
    K_I, K_II
        Mode I and II stress intensity factors (Pa·√m).
    G
        Energy release rate from K: (K_I² + K_II²)/E′ (J/m²).
    J
        Domain J-integral (J/m²); ``nan`` for displacement correlation.
    tip, direction
        Tip position and crack direction (unit vector ahead of the tip).
    method
        ``"interaction"`` or ``"displacement"``.
    """

    K_I: float
    K_II: float
    G: float
    J: float
    tip: tuple[float, float]
    direction: tuple[float, float]
    method: str


def energy_release_rate(K_I: float, K_II: float, E: float, nu: float, plane: PlaneState) -> float:
    """G = (K_I² + K_II²)/E′ with E′ = E/(1 − ν²) (plane strain) or E (plane stress)."""
    return (K_I**2 + K_II**2) / elastic_constants(E, nu, plane)["E_prime"]


def plane_stress_equivalent(material: Isotropic) -> Isotropic:
    """The plane-strain material whose in-plane response is plane stress with ``material``.

    E* = E(1 + 2ν)/(1 + ν)², ν* = ν/(1 + ν): solving the (plane-strain) mechanics model with
    it gives the plane-stress displacement field of ``material``.
    """
    E, nu = material.E, material.nu
    return Isotropic(E=E * (1 + 2 * nu) / (1 + nu) ** 2, nu=nu / (1 + nu))


# ----------------------------------------------------------------------- the domain
def _q_nodal(V1: fem.FunctionSpace, tip: np.ndarray, r_in: float, r_out: float) -> fem.Function:
    """Plateau q: 1 for r ≤ r_in, linear to 0 at r_out (P1)."""
    q = fem.Function(V1)
    q.interpolate(lambda x: _plateau(x.T, tip, r_in, r_out))
    return q


def _cell_q_range(msh: mesh.Mesh, q: fem.Function) -> tuple[np.ndarray, np.ndarray]:
    """Minimum and maximum nodal q of every local cell (owned and ghost)."""
    tdim = msh.topology.dim
    dofs = q.function_space.dofmap.list
    vals = q.x.array[dofs]
    n = msh.topology.index_map(tdim).size_local + msh.topology.index_map(tdim).num_ghosts
    return vals[:n].min(axis=1), vals[:n].max(axis=1)


def _domain_material(
    cm: CrackedMesh,
    material: Isotropic | Mapping[int, Material],
    support: npt.NDArray[np.int32],
) -> Isotropic:
    """The one isotropic material of the cells in ``support``; refuse an interface."""
    comm = cm.mesh.comm
    if isinstance(material, Mapping):
        tags = np.unique(cm.cell_tags.values[np.isin(cm.cell_tags.indices, support)])
        all_tags = sorted(set().union(*comm.allgather(set(int(t) for t in tags))))
        mats = [material.get(t) for t in all_tags]
        if any(m is None for m in mats):
            raise ParameterError("materials", f"no material for cell tags {all_tags}")
        if any(m != mats[0] for m in mats[1:]):
            raise ParameterError(
                "r_out",
                f"the integration domain crosses a material interface (cell tags {all_tags}); "
                "choose a domain inside one material",
            )
        material = mats[0]
    if not isinstance(material, Isotropic):
        raise ParameterError(
            "material",
            f"the interaction integral needs a homogeneous isotropic material near the tip, "
            f"got {type(material).__name__}",
        )
    return material


def _plateau(x: np.ndarray, tip: np.ndarray, r_in: float, r_out: float) -> np.ndarray:
    """The q-function at points ``x`` (shape (n, ≥2))."""
    r = np.hypot(x[:, 0] - tip[0], x[:, 1] - tip[1])
    return np.clip((r_out - r) / (r_out - r_in), 0.0, 1.0)


def _check_boundary(cm: CrackedMesh, tip: np.ndarray, r_in: float, r_out: float) -> None:
    """Refuse a domain (q > 0) that touches a boundary other than the crack faces."""
    msh = cm.mesh
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    ext = mesh.exterior_facet_indices(msh.topology)
    faces = np.concatenate([cm.facet_tags.find(t) for t in cm.face_tags])
    ext = np.setdiff1d(ext, faces)
    touches = 0
    if ext.size:
        verts = mesh.entities_to_geometry(msh, tdim - 1, ext)
        touches = int(np.any(_plateau(msh.geometry.x[verts.ravel()], tip, r_in, r_out) > 0))
    if msh.comm.allreduce(touches, op=MPI.MAX):
        raise ParameterError(
            "r_out", "the integration domain reaches the body's boundary; take a smaller r_out"
        )


@dataclass
class _Domain:
    q: fem.Function
    dx: ufl.Measure
    material: Isotropic


def _domain(
    cm: CrackedMesh,
    end: int,
    material: Isotropic | Mapping[int, Material],
    r_in: float,
    r_out: float,
    quadrature_degree: int,
) -> _Domain:
    crack, msh = cm.crack, cm.mesh
    if crack is None:
        raise ParameterError("crack", "the mesh has no crack")
    if not (0 <= r_in < r_out):
        raise ParameterError("r_out", f"need 0 <= r_in < r_out, got r_in={r_in}, r_out={r_out}")
    if r_out >= crack.tip_segment_length(end):
        raise ParameterError(
            "r_out",
            f"the domain (r_out={r_out:g}) must lie within the straight tip segment "
            f"(length {crack.tip_segment_length(end):g})",
        )
    tip = crack.tip(end)
    V1 = fem.functionspace(msh, ("Lagrange", 1))
    q = _q_nodal(V1, tip, r_in, r_out)
    qmin, qmax = _cell_q_range(msh, q)
    support = np.flatnonzero(qmax > 0).astype(np.int32)
    mat = _domain_material(cm, material, support)
    _check_boundary(cm, tip, r_in, r_out)
    n_owned = msh.topology.index_map(msh.topology.dim).size_local
    ring = np.flatnonzero(qmax[:n_owned] > qmin[:n_owned]).astype(np.int32)
    tags = mesh.meshtags(msh, msh.topology.dim, ring, np.ones(ring.size, dtype=np.int32))
    dx = ufl.Measure(
        "dx", domain=msh, subdomain_data=tags, metadata={"quadrature_degree": quadrature_degree}
    )
    return _Domain(q, dx(1), mat)


#: Quadrature of the crack-face term: its integrand has a 1/√r singularity at the tip, which
#: low-order Gauss rules underestimate on the tip facet (degree 4: K −1.4 % for a
#: pressurised crack; degree 20: see the tests).
FACE_QUADRATURE_DEGREE = 20


def _with_face_terms(cm, end, d, const, t, du1, quadrature_degree, integrand, J_integrand):
    """Add −∫ t·∂u^a/∂x₁ q ds (and −∫ t·∂u/∂x₁ q ds for J) over both crack faces.

    On the faces the auxiliary field is evaluated with its face values (θ = ±π, where
    atan2 cannot tell the sides apart): u^a = ±(κ+1)/(2μ)·√(r/2π)·(K_I e₂ + K_II e₁), so
    ∂u^a/∂x₁ = −d/dr of it = ∓(κ+1)/(4μ√(2πr))·(K_I e₂ + K_II e₁); + on the e₂ side.
    """
    msh = cm.mesh
    ds = ufl.Measure(
        "ds",
        domain=msh,
        subdomain_data=cm.facet_tags,
        metadata={"quadrature_degree": max(quadrature_degree, FACE_QUADRATURE_DEGREE)},
    )
    x = ufl.SpatialCoordinate(msh)
    e1 = const["e1"]
    e2 = ufl.as_vector([-e1[1], e1[0]])
    r = ufl.sqrt(ufl.dot(x - const["tip"], x - const["tip"]))
    g = (const["kappa"] + 1) / (4 * const["mu"] * ufl.sqrt(2 * np.pi * r))
    dua1 = -g * (const["k1"] * e2 + const["k2"] * e1)  # on the e2 side; opposite on the other
    e2_side, other = cm.face_tags if end == -1 else cm.face_tags[::-1]
    if isinstance(t, tuple):  # one traction field per face (FaceTraction: plus, minus)
        t_e2, t_other = t if end == -1 else t[::-1]
    else:
        t_e2 = t_other = t
    face_term = ufl.dot(t_e2, dua1) * d.q * ds(e2_side) - ufl.dot(t_other, dua1) * d.q * ds(other)
    J_face = ufl.dot(t_e2, du1) * d.q * ds(e2_side) + ufl.dot(t_other, du1) * d.q * ds(other)
    return integrand * d.dx - face_term, J_integrand - J_face


def _total_compiled(form: fem.Form, comm: MPI.Comm) -> float:
    return comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)


def interaction_integral(
    u: fem.Function,
    cm: CrackedMesh,
    end: int,
    material: Isotropic | Mapping[int, Material],
    r_out: float,
    r_in: float | None = None,
    plane: PlaneState = "strain",
    quadrature_degree: int = 4,
    face_traction: ufl.core.expr.Expr | tuple | None = None,
) -> SIFResult:
    """K_I, K_II and J at a tip by the domain interaction integral.

    Parameters
    ----------
    u
        Displacement (vector P1 on ``cm.mesh``).
    cm
        The cracked mesh.
    end
        The tip: polyline end 0 or -1.
    material
        The material (one :class:`~bonecontact.materials.laws.Isotropic`), or the cell
        tag → material map of the model; for plane stress the real (E, ν), not the
        plane-strain equivalent used to solve.
    r_out, r_in
        The q-function is 1 within ``r_in`` of the tip and falls linearly to 0 at
        ``r_out`` (m); the integral runs over the elements of that ring.  ``r_in``
        defaults to ``r_out/2``: keeping the tip elements (``r_in = 0``) adds an error of
        order h_tip/r_out from the poorly resolved singular field there.
    plane
        ``"strain"`` or ``"stress"``.
    quadrature_degree
        Quadrature of the ring cells (the auxiliary fields are not polynomials).
    face_traction
        The traction t (Pa): a UFL vector on the crack faces (e.g. ``-p * FacetNormal``),
        or the contact tractions of the two faces
        (:class:`~bonecontact.fracture.faces.FaceTraction`, one P1 field per face, so
        that the shared tip node has the value of each face): adds the face term
        −∫ t·∂u^a/∂x₁ q ds.  ``None``: traction-free faces.  (σ(u)n of the cells along
        the faces is no substitute: P1 stresses next to the tip are far off.)

    Returns
    -------
    SIFResult

    Raises
    ------
    ParameterError
        The domain crosses a material interface, reaches the boundary or leaves the
        straight tip segment, or the material is not isotropic (on every rank).
    """
    r_in = 0.5 * r_out if r_in is None else r_in
    d = _domain(cm, end, material, r_in, r_out, quadrature_degree)
    c = elastic_constants(d.material.E, d.material.nu, plane)
    tip, e1 = cm.crack.tip(end), cm.crack.direction(end)
    form, J_form, const = _interaction_forms(u, cm, end, d, c, face_traction, quadrature_degree)
    values = {}
    for mode, (k1, k2) in (("I", (1.0, 0.0)), ("II", (0.0, 1.0))):
        const["k1"].value, const["k2"].value = k1, k2
        values[mode] = 0.5 * c["E_prime"] * _total_compiled(form, cm.mesh.comm)
    J = _total_compiled(J_form, cm.mesh.comm)
    K_I, K_II = values["I"], values["II"]
    return SIFResult(
        K_I,
        K_II,
        (K_I**2 + K_II**2) / c["E_prime"],
        J,
        (float(tip[0]), float(tip[1])),
        (float(e1[0]), float(e1[1])),
        "interaction",
    )


def _interaction_forms(
    u: fem.Function,
    cm: CrackedMesh,
    end: int,
    d: _Domain,
    c: dict,
    face_traction: ufl.core.expr.Expr | tuple | None,
    quadrature_degree: int,
) -> tuple[fem.Form, fem.Form, dict]:
    """The compiled interaction integral (its auxiliary mode set by the constants
    ``k1``, ``k2``), the compiled J-integral and the constants, on the domain ``d`` of
    the tip ``end`` (with the face terms of loaded faces)."""
    crack, msh = cm.crack, cm.mesh
    tip, e1 = crack.tip(end), crack.direction(end)
    # constants, not numbers: one compiled form for every tip, mesh size and material
    const = {
        k: fem.Constant(msh, np.asarray(v, dtype=default_scalar_type))
        for k, v in (
            ("tip", tip),
            ("e1", e1),
            ("lmbda", c["lmbda"]),
            ("mu", c["mu"]),
            ("kappa", c["kappa"]),
            ("k1", 1.0),
            ("k2", 0.0),
        )
    }
    e1c = const["e1"]

    def sigma(v):
        eps = ufl.sym(ufl.grad(v))
        return const["lmbda"] * ufl.tr(eps) * ufl.Identity(2) + 2 * const["mu"] * eps

    x = ufl.SpatialCoordinate(msh)
    grad_q = ufl.grad(d.q)
    s, eps_u = sigma(u), ufl.sym(ufl.grad(u))
    du1 = ufl.dot(ufl.grad(u), e1c)
    ua = williams_displacement_ufl(
        x, const["tip"], e1c, const["mu"], const["kappa"], const["k1"], const["k2"]
    )
    sa = sigma(ua)
    dua1 = ufl.dot(ufl.grad(ua), e1c)
    integrand = ufl.dot(ufl.dot(s, dua1) + ufl.dot(sa, du1) - ufl.inner(sa, eps_u) * e1c, grad_q)
    J_integrand = ufl.dot(ufl.dot(s, du1) - 0.5 * ufl.inner(s, eps_u) * e1c, grad_q) * d.dx
    if face_traction is not None:
        integrand, J_integrand = _with_face_terms(
            cm, end, d, const, face_traction, du1, quadrature_degree, integrand, J_integrand
        )
    else:
        integrand = integrand * d.dx
    return fem.form(integrand), fem.form(J_integrand), const


# ------------------------------------------------------------ displacement correlation
def _face_nodes(
    u: fem.Function, cm: CrackedMesh, tag: int, tip: np.ndarray, e1: np.ndarray, r_max: float
) -> tuple[np.ndarray, np.ndarray]:
    """Owned nodes of a face group within ``r_max`` behind the tip: (coordinates, u), all ranks."""
    msh, V = cm.mesh, u.function_space
    blocks = fem.locate_dofs_topological(V, msh.topology.dim - 1, cm.facet_tags.find(tag))
    blocks = blocks[blocks < V.dofmap.index_map.size_local]
    x = V.tabulate_dof_coordinates()[blocks, :2]
    d = x - tip
    behind = (d @ e1 < 0) & (np.linalg.norm(d, axis=1) <= r_max * (1 + 1e-9))
    bs = V.dofmap.index_map_bs
    vals = u.x.array.reshape(-1, bs)[blocks[behind], :2]
    xs = msh.comm.allgather(x[behind])
    vs = msh.comm.allgather(vals)
    return np.concatenate(xs), np.concatenate(vs)


def displacement_correlation(
    u: fem.Function,
    cm: CrackedMesh,
    end: int,
    material: Isotropic,
    r_max: float,
    plane: PlaneState = "strain",
    skip: int = 1,
) -> SIFResult:
    """K_I, K_II from the crack-face displacement jump behind the tip.

    At each pair of coincident face nodes at distance r ≤ ``r_max`` behind the tip (but
    the ``skip`` pairs nearest the tip, whose opening linear elements get worst),
    K(r) = μ/(κ + 1) √(2π/r) [u]·e, with [u] = u(plus side) − u(minus side), e = e₂
    (mode I, opening) or e₁ (mode II, sliding); K(r) is fitted linearly in r and taken at
    r = 0.  ``material`` is the real one (also in plane stress).
    """
    crack = cm.crack
    if crack is None:
        raise ParameterError("crack", "the mesh has no crack")
    c = elastic_constants(material.E, material.nu, plane)
    tip, e1 = crack.tip(end), crack.direction(end)
    if r_max >= crack.tip_segment_length(end):
        raise ParameterError("r_max", "must be shorter than the straight tip segment")
    e2 = np.array([-e1[1], e1[0]])
    # crack_plus lies left of the polyline; seen from tip 0 the polyline runs backwards
    plus, minus = cm.face_tags if end == -1 else cm.face_tags[::-1]
    xp, up = _face_nodes(u, cm, plus, tip, e1, r_max)
    xm, um = _face_nodes(u, cm, minus, tip, e1, r_max)
    rp, rm = np.linalg.norm(xp - tip, axis=1), np.linalg.norm(xm - tip, axis=1)
    scale = max(r_max, 1e-300)
    keep_p, keep_m = rp > 1e-9 * scale, rm > 1e-9 * scale
    xp, up, rp, xm, um, rm = xp[keep_p], up[keep_p], rp[keep_p], xm[keep_m], um[keep_m], rm[keep_m]
    ip, im = np.argsort(rp), np.argsort(rm)
    if len(ip) != len(im) or len(ip) < 2 or not np.allclose(xp[ip], xm[im], atol=1e-9 * scale):
        raise ParameterError(
            "r_max", "needs at least two pairs of matching face nodes behind the tip"
        )
    r, jump = rp[ip][skip:], (up[ip] - um[im])[skip:]
    if len(r) < 2:
        raise ParameterError(
            "r_max", "needs at least two pairs of face nodes after the skipped ones"
        )
    f = c["mu"] / (c["kappa"] + 1) * np.sqrt(2 * np.pi / r)
    k1, k2 = f * (jump @ e2), f * (jump @ e1)
    A = np.vstack([np.ones_like(r), r]).T
    K_I = float(np.linalg.lstsq(A, k1, rcond=None)[0][0])
    K_II = float(np.linalg.lstsq(A, k2, rcond=None)[0][0])
    return SIFResult(
        K_I,
        K_II,
        (K_I**2 + K_II**2) / c["E_prime"],
        float("nan"),
        (float(tip[0]), float(tip[1])),
        (float(e1[0]), float(e1[1])),
        "displacement",
    )
