"""Anisotropic materials: homogeneous states that P1 represents exactly.

The references are built here from the engineering constants alone: a fourth-order
compliance tensor S_ijkl in the material frame (ε = S : σ), rotated to the global
frame with the rotation matrix by ``np.einsum``, independently of the package's
Voigt rotation.  Constants: Ashman et al. 1984 (orthotropic cortical bone) and
Reilly & Burstein 1975 (transversely isotropic), docs/theory/mechanics.md#material-data.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh

from bonecontact.materials.laws import Isotropic, MaterialError, Orthotropic, TransverselyIsotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics

COMM = MPI.COMM_WORLD
GPa = 1.0e9
SIGMA = 1.0e6  # applied stress (Pa)
LX, LY, LZ = 2.0, 1.5, 1.0  # box edges (m), deliberately unequal
ASHMAN = dict(
    E1=12.0 * GPa,
    E2=13.4 * GPa,
    E3=20.0 * GPa,
    nu12=0.376,
    nu13=0.222,
    nu23=0.235,
    G12=4.53 * GPa,
    G13=5.61 * GPa,
    G23=6.23 * GPa,
)
# Reilly–Burstein: E1 = E2 = 11.5, E3 = 17.0 GPa, ν12 = 0.58, ν31 = 0.46, G13 = G23 = 3.3 GPa
RB = dict(E_p=11.5 * GPa, E_a=17.0 * GPa, nu_p=0.58, nu_ap=0.46, G_pa=3.3 * GPa)


def compliance_tensor(E, nu, G) -> np.ndarray:
    """S_ijkl in the material frame; ``nu[i][j]`` = ν_ij (load along i), ``G[i][j]`` = G_ij."""
    S = np.zeros((3, 3, 3, 3))
    for i in range(3):
        S[i, i, i, i] = 1.0 / E[i]
        for j in range(3):
            if i != j:
                S[i, i, j, j] = -nu[i][j] / E[i]
                for a, b in ((i, j), (j, i)):
                    for c, d in ((i, j), (j, i)):
                        S[a, b, c, d] = 1.0 / (4.0 * G[i][j])
    return S


def orthotropic_compliance(E1, E2, E3, nu12, nu13, nu23, G12, G13, G23) -> np.ndarray:
    E = (E1, E2, E3)
    nu = [[0.0, nu12, nu13], [nu12 * E2 / E1, 0.0, nu23], [nu13 * E3 / E1, nu23 * E3 / E2, 0.0]]
    G = [[0.0, G12, G13], [G12, 0.0, G23], [G13, G23, 0.0]]
    return compliance_tensor(E, nu, G)


def rotate(S: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """Global components of a material-frame tensor; ``axes`` rows = material axes."""
    Q = np.asarray(axes).T  # Q[i, a]: global component i of material axis a
    return np.einsum("ia,jb,kc,ld,abcd->ijkl", Q, Q, Q, Q, S)


def rotation_z(theta_deg: float) -> np.ndarray:
    """Material axes (rows) of a frame turned by ``theta_deg`` about z."""
    c, s = np.cos(np.deg2rad(theta_deg)), np.sin(np.deg2rad(theta_deg))
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation_x(theta_deg: float) -> np.ndarray:
    """Material axes (rows) of a frame turned by ``theta_deg`` about x."""
    c, s = np.cos(np.deg2rad(theta_deg)), np.sin(np.deg2rad(theta_deg))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])


def total(form) -> float:
    return COMM.allreduce(fem.assemble_scalar(fem.form(form)), op=MPI.SUM)


def _box():
    msh = mesh.create_box(
        COMM, [[0.0, 0.0, 0.0], [LX, LY, LZ]], [3, 2, 2], mesh.CellType.tetrahedron
    )
    lengths = (LX, LY, LZ)
    facets, values = [], []
    for axis in range(3):
        for side, value in ((0, 0.0), (1, lengths[axis])):
            f = mesh.locate_entities_boundary(
                msh, 2, lambda X, a=axis, v=value: np.isclose(X[a], v)
            )
            facets.append(f)
            values.append(np.full(f.size, 10 * axis + side + 1, dtype=np.int32))
    facets, values = np.concatenate(facets), np.concatenate(values)
    order = np.argsort(facets)
    return msh, mesh.meshtags(msh, 2, facets[order], values[order])


def _tag(axis: int, side: int) -> int:
    return 10 * axis + side + 1


def _mean_strain(msh, u) -> tuple[np.ndarray, float]:
    """Volume average of e(u) and the relative L² deviation from it (homogeneity)."""
    vol = LX * LY * LZ
    e = ufl.sym(ufl.grad(u))
    mean = np.array(
        [[total(e[i, j] * ufl.dx(domain=msh)) / vol for j in range(3)] for i in range(3)]
    )
    dev = e - fem.Constant(msh, mean)  # a Constant: no new form (JIT) per value
    inhom = np.sqrt(total(ufl.inner(dev, dev) * ufl.dx(domain=msh)) / vol) / np.linalg.norm(mean)
    return mean, inhom


def uniaxial_rollers(mat, axis: int) -> np.ndarray:
    """Traction σ on the face x_axis = L, rollers (u_i = 0 on x_i = 0) on three faces."""
    msh, ft = _box()
    m = Mechanics(msh, mat, None, ft)
    for i in range(3):
        m.add_dirichlet(m.facets(_tag(i, 0)), i, 0.0)
    t = np.zeros(3)
    t[axis] = SIGMA
    m.add_traction(_tag(axis, 1), t)
    integ = Integrator(m, "static", 1.0)
    integ.step()
    eps, inhom = _mean_strain(msh, integ.u)
    integ.destroy()
    assert inhom < 1e-10
    return eps


def general_stress(mat, sigma: np.ndarray, eps_ref: np.ndarray) -> np.ndarray:
    """Homogeneous stress ``sigma`` with tractions σn on five faces; the face x = 0 is
    held at the affine displacement eps_ref·x of the expected strain (no rotation).

    If the assembled stiffness does not map eps_ref to sigma, the affine field violates
    the traction conditions and the FE solution is not homogeneous (checked).
    """
    msh, ft = _box()
    m = Mechanics(msh, mat, None, ft)
    for c in range(3):
        m.add_dirichlet(m.facets(_tag(0, 0)), c, lambda X, c=c: (eps_ref @ X)[c])
    for axis in range(3):
        for side in (0, 1):
            if axis == 0 and side == 0:
                continue
            n = np.zeros(3)
            n[axis] = 1.0 if side else -1.0
            t = sigma @ n
            if np.any(t != 0.0):
                m.add_traction(_tag(axis, side), t)
    integ = Integrator(m, "static", 1.0)
    integ.step()
    eps, inhom = _mean_strain(msh, integ.u)
    integ.destroy()
    assert inhom < 1e-9
    return eps


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_orthotropic_engineering_constants(axis):
    """Ashman orthotropic bone, material axes = global axes, uniaxial stress along each axis.

    E_i = σ/ε_ii and ν_ij = −ε_jj/ε_ii from the FE mean strain; tolerance 1e-8 relative;
    shear strains vanish (|ε_ij| < 1e-12 |ε_ii|); homogeneity < 1e-10 (relative L²).
    """
    mat = Orthotropic(**ASHMAN)
    eps = uniaxial_rollers(mat, axis)
    E = (ASHMAN["E1"], ASHMAN["E2"], ASHMAN["E3"])
    nu = {(0, 1): ASHMAN["nu12"], (0, 2): ASHMAN["nu13"], (1, 2): ASHMAN["nu23"]}
    assert SIGMA / eps[axis, axis] == pytest.approx(E[axis], rel=1e-8)
    for j in range(3):
        if j == axis:
            continue
        ref = (
            nu[(axis, j)] if (axis, j) in nu else nu[(j, axis)] * E[axis] / E[j]
        )  # ν_ji = ν_ij E_j/E_i
        assert -eps[j, j] / eps[axis, axis] == pytest.approx(ref, rel=1e-8)
    off = eps - np.diag(np.diag(eps))
    assert np.abs(off).max() < 1e-12 * abs(eps[axis, axis])


def test_rotated_orthotropic_response():
    """Ashman bone with material axes turned by 40° about x, then 30° about z.

    (1) Uniaxial σ_xx in the global frame: the FE mean strain equals S_rot : σ with S_rot
    the analytically rotated compliance tensor (all six components, 1e-8 relative to
    |ε|), and it has shear strains that the unrotated material does not have.
    (2) Uniaxial stress along the rotated material axis 1: E1 = σ/ε₁₁ and ν12, ν13 in
    the material frame to 1e-8.  (3) A 90° rotation exchanges E1 and E2 (rollers, 1e-8).
    """
    R = rotation_x(40.0) @ rotation_z(30.0)  # rows: the material axes in global coordinates
    assert np.allclose(R @ R.T, np.eye(3))
    mat = Orthotropic(**ASHMAN, axes=tuple(map(tuple, R)))
    S = rotate(orthotropic_compliance(**ASHMAN), R)

    sigma = np.zeros((3, 3))
    sigma[0, 0] = SIGMA
    eps_ref = np.einsum("ijkl,kl->ij", S, sigma)
    eps = general_stress(mat, sigma, eps_ref)
    assert np.abs(eps - eps_ref).max() < 1e-8 * np.abs(eps_ref).max()
    off = eps_ref - np.diag(np.diag(eps_ref))
    assert np.abs(off).max() > 0.05 * abs(eps_ref[0, 0])  # the rotation really matters

    d1, d2, d3 = R
    sigma = SIGMA * np.outer(d1, d1)
    eps = general_stress(mat, sigma, np.einsum("ijkl,kl->ij", S, sigma))
    e11 = d1 @ eps @ d1
    assert SIGMA / e11 == pytest.approx(ASHMAN["E1"], rel=1e-8)
    assert -(d2 @ eps @ d2) / e11 == pytest.approx(ASHMAN["nu12"], rel=1e-8)
    assert -(d3 @ eps @ d3) / e11 == pytest.approx(ASHMAN["nu13"], rel=1e-8)
    assert abs(d1 @ eps @ d2) < 1e-12 * abs(e11)

    swapped = Orthotropic(**ASHMAN, axes=tuple(map(tuple, rotation_z(90.0))))
    eps = uniaxial_rollers(swapped, 0)
    assert SIGMA / eps[0, 0] == pytest.approx(ASHMAN["E2"], rel=1e-8)
    eps = uniaxial_rollers(swapped, 1)
    assert SIGMA / eps[1, 1] == pytest.approx(ASHMAN["E1"], rel=1e-8)


@pytest.mark.parametrize("axis", [2, 0])
def test_transversely_isotropic_reilly_burstein(axis):
    """Reilly–Burstein bone with its axis along z, then along x.

    Load along the axis: E_a = 17 GPa and ν_ap = 0.46; load in the isotropy plane:
    E_p = 11.5 GPa and ν_p = 0.58.  Tolerance 1e-8 relative.
    """
    nu_pa = RB["nu_ap"] * RB["E_p"] / RB["E_a"]  # ν_pa / E_p = ν_ap / E_a
    direction = np.zeros(3)
    direction[axis] = 1.0
    mat = TransverselyIsotropic(
        E_p=RB["E_p"],
        E_a=RB["E_a"],
        nu_p=RB["nu_p"],
        nu_pa=nu_pa,
        G_pa=RB["G_pa"],
        axis=tuple(direction),
    )
    p1, p2 = [i for i in range(3) if i != axis]

    eps = uniaxial_rollers(mat, axis)
    assert SIGMA / eps[axis, axis] == pytest.approx(RB["E_a"], rel=1e-8)
    assert -eps[p1, p1] / eps[axis, axis] == pytest.approx(RB["nu_ap"], rel=1e-8)
    assert -eps[p2, p2] / eps[axis, axis] == pytest.approx(RB["nu_ap"], rel=1e-8)

    eps = uniaxial_rollers(mat, p1)
    assert SIGMA / eps[p1, p1] == pytest.approx(RB["E_p"], rel=1e-8)
    assert -eps[p2, p2] / eps[p1, p1] == pytest.approx(RB["nu_p"], rel=1e-8)
    assert -eps[axis, axis] / eps[p1, p1] == pytest.approx(nu_pa, rel=1e-8)


def test_plane_strain_out_of_plane_stress():
    """2D plane strain, isotropic (E = 10 GPa, ν = 0.3): σ_zz = ν(σ_xx + σ_yy) pointwise.

    Inhomogeneous state: unit square clamped at y = 0, shear and normal traction on
    y = 1.  Tolerance: ‖σ_zz − ν(σ_xx + σ_yy)‖_L² ≤ 1e-12 ‖σ‖_L², and σ_zz ≠ 0.
    """
    nu = 0.3
    mat = Isotropic(E=10.0 * GPa, nu=nu)
    msh = mesh.create_unit_square(COMM, 8, 8)
    bottom = mesh.locate_entities_boundary(msh, 1, lambda X: np.isclose(X[1], 0.0))
    top = mesh.locate_entities_boundary(msh, 1, lambda X: np.isclose(X[1], 1.0))
    ft = mesh.meshtags(msh, 1, top, np.full(top.size, 1, dtype=np.int32))
    m = Mechanics(msh, mat, None, ft)
    for c in range(2):
        m.add_dirichlet(bottom, c, 0.0)
    x = ufl.SpatialCoordinate(msh)
    m.add_traction(1, ufl.as_vector([SIGMA * x[0], -SIGMA * (1.0 + x[0] ** 2)]))
    integ = Integrator(m, "static", 1.0)
    integ.step()
    s = m.stress_expression(integ.u)
    diff = s[2, 2] - nu * (s[0, 0] + s[1, 1])
    dx = ufl.dx(domain=msh)
    norm_s = np.sqrt(total(ufl.inner(s, s) * dx))
    assert np.sqrt(total(diff**2 * dx)) <= 1e-12 * norm_s
    assert np.sqrt(total(s[2, 2] ** 2 * dx)) > 0.1 * norm_s
    integ.destroy()


def _is_positive_definite_compliance(**c) -> bool:
    S = orthotropic_compliance(**c)
    # 6×6 Voigt compliance with engineering shears (symmetric)
    pairs = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
    f = [1.0 if i == j else 2.0 for i, j in pairs]
    S6 = np.array(
        [
            [f[a] * f[b] * S[i, j, k, l] for b, (k, l) in enumerate(pairs)]
            for a, (i, j) in enumerate(pairs)
        ]
    )
    return bool(np.linalg.eigvalsh(S6).min() > 0)


@pytest.mark.parametrize(
    "bad",
    [
        dict(nu12=1.1),  # |ν12| ≥ √(E1/E2)
        dict(nu12=0.7, nu13=0.7, nu23=0.7),  # 1 − ν12ν21 − ν23ν32 − ν13ν31 − 2ν21ν32ν13 < 0
        dict(nu23=-1.4),
    ],
)
def test_not_positive_definite_orthotropic_raises(bad):
    """Engineering constants whose compliance (checked independently here) is not positive
    definite raise MaterialError; the Ashman constants themselves are accepted."""
    base = dict(E1=1.0, E2=1.0, E3=1.0, nu12=0.3, nu13=0.3, nu23=0.3, G12=0.4, G13=0.4, G23=0.4)
    assert _is_positive_definite_compliance(**base)
    constants = {**base, **bad}
    assert not _is_positive_definite_compliance(**constants)
    with pytest.raises(MaterialError):
        Orthotropic(**constants)
    assert _is_positive_definite_compliance(**ASHMAN)
    Orthotropic(**ASHMAN)


def test_not_positive_definite_other_materials_raise():
    """Transversely isotropic with ν_p ≥ 1 or with 1 − ν_p − 2ν_pa ν_ap ≤ 0, and isotropic
    ν ∉ (−1, ½) or E ≤ 0, raise MaterialError."""
    ok = dict(E_p=RB["E_p"], E_a=RB["E_a"], nu_p=RB["nu_p"], nu_pa=0.3, G_pa=RB["G_pa"])
    TransverselyIsotropic(**ok)
    for bad in (dict(nu_p=1.05), dict(nu_pa=0.9), dict(G_pa=-1.0)):
        with pytest.raises(MaterialError):
            TransverselyIsotropic(**{**ok, **bad})
    for bad in (dict(E=1.0, nu=0.5), dict(E=1.0, nu=-1.0), dict(E=-1.0, nu=0.3)):
        with pytest.raises(MaterialError):
            Isotropic(**bad)
