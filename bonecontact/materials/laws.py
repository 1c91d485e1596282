"""Material laws: elastic and Kelvin–Voigt viscous stiffness tensors.

Every material delivers its elastic stiffness as a 6×6 matrix in Voigt notation
in the *global* axes, ordering ``[xx, yy, zz, yz, xz, xy]`` with engineering shear
strains (γ = 2ε).  Plane strain (2D) uses the sub-block ``[xx, yy, xy]``; the
out-of-plane stress ``σ_zz`` follows from row ``zz``.  The viscous tensor of
docs/theory/mechanics.md#kelvin-voigt-model is ``c⁽¹⁾ = τ_v c⁽⁰⁾`` (Kelvin–Voigt relaxation time
``tau_v``).

Units are SI: moduli in Pa, density in kg/m³, ``tau_v`` in s.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

from bonecontact.common.errors import ParameterError

__all__ = [
    "FORMULATIONS",
    "Isotropic",
    "Material",
    "MaterialError",
    "Orthotropic",
    "TransverselyIsotropic",
    "plane_strain_block",
    "voigt_rotation",
]

#: Volumetric formulations a material may select.  ``"displacement"`` is the plain
#: P1 displacement formulation; ``"nodal_pressure"`` averages the volumetric strain
#: at the vertices (Bonet–Burton average nodal pressure), which does not lock for
#: nearly incompressible materials (isotropic materials only).
FORMULATIONS = ("displacement", "nodal_pressure")

#: Voigt index pairs, ordering [xx, yy, zz, yz, xz, xy].
VOIGT_PAIRS = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))


#: Deprecated alias of :class:`~bonecontact.common.errors.ParameterError` (the one type of
#: a parameter out of range); a material's ``str(error)`` is the bare message.
MaterialError = ParameterError


def _material_error(key: str, message: str) -> ParameterError:
    """Invalid material constant ``key`` (``message``: what is wrong and what is allowed)."""
    return ParameterError(key, message, where="")


def _positive(name: str, value: float) -> None:
    if not np.isfinite(value) or value <= 0.0:
        raise _material_error(name, f"must be a positive number, got {value!r}")


def _common_checks(rho: float | None, tau_v: float) -> None:
    if rho is not None:
        _positive("rho", rho)
    if not np.isfinite(tau_v) or tau_v < 0.0:
        raise _material_error("tau_v", f"must be >= 0, got {tau_v!r}")


def _check_spd(C: npt.NDArray[np.float64], key: str) -> None:
    w = np.linalg.eigvalsh(0.5 * (C + C.T))
    if not np.all(np.isfinite(w)) or w.min() <= 1e-12 * abs(w).max():
        raise _material_error(
            key,
            "engineering constants do not give a positive definite stiffness "
            f"(eigenvalues of the Voigt stiffness: {np.array2string(w, precision=3)})",
        )


def voigt_rotation(R: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Voigt (engineering strain) transformation for a rotation.

    Parameters
    ----------
    R
        3×3 orthogonal matrix whose *rows* are the material axes written in
        global coordinates.

    Returns
    -------
    T
        6×6 matrix with ``C_global = T.T @ C_material @ T`` where ``T`` maps
        global engineering strains to material engineering strains.
    """
    R = np.asarray(R, dtype=np.float64)
    T = np.zeros((6, 6))
    for a, (i, j) in enumerate(VOIGT_PAIRS):
        fa = 1.0 if i == j else 2.0  # engineering shear strain of the result
        for b, (k, l) in enumerate(VOIGT_PAIRS):
            # material strain e'_ij = R_ik R_jl e_kl; e_kl = γ_kl/2 for k != l
            if k == l:
                T[a, b] = fa * R[i, k] * R[j, l]
            else:
                T[a, b] = fa * 0.5 * (R[i, k] * R[j, l] + R[i, l] * R[j, k])
    return T


def plane_strain_block(C: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The plane-strain 3×3 block ``[xx, yy, xy]`` of a 6×6 Voigt stiffness."""
    idx = [0, 1, 5]
    return np.ascontiguousarray(C[np.ix_(idx, idx)])


def _axes_matrix(axes: npt.ArrayLike, key: str) -> npt.NDArray[np.float64]:
    A = np.asarray(axes, dtype=np.float64)
    if A.shape == (2, 2):
        # 2D: in-plane axes; the third axis is z
        B = np.zeros((3, 3))
        B[:2, :2] = A
        B[2, 2] = 1.0
        A = B
    if A.shape != (3, 3):
        raise _material_error(key, f"must be 3 orthonormal rows (or 2 in 2D), got shape {A.shape}")
    if not np.allclose(A @ A.T, np.eye(3), atol=1e-8):
        raise _material_error(key, "rows must be orthonormal unit vectors")
    return A


def _frame_from_axis(axis: npt.ArrayLike, key: str = "axis") -> npt.NDArray[np.float64]:
    """An orthonormal frame whose *third* row is ``axis``."""
    a = np.asarray(axis, dtype=np.float64).ravel()
    if a.size == 2:
        a = np.array([a[0], a[1], 0.0])
    if a.size != 3 or not np.all(np.isfinite(a)) or np.linalg.norm(a) == 0.0:
        raise _material_error(key, f"must be a non-zero vector of 2 or 3 components, got {axis!r}")
    a = a / np.linalg.norm(a)
    # pick a helper vector not parallel to a; prefer z so that in 2D the frame
    # stays with one in-plane axis and z (plane-strain friendly)
    helper = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(helper, a)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    return np.array([e1, e2, a])


def _orthotropic_compliance(
    E: tuple[float, float, float], nu: dict[tuple[int, int], float], G: tuple[float, float, float]
) -> npt.NDArray[np.float64]:
    """Compliance in material axes; ``nu[(i,j)]`` is ν_ij (ν_ji = ν_ij E_j/E_i)."""
    S = np.zeros((6, 6))
    for i in range(3):
        S[i, i] = 1.0 / E[i]
    for (i, j), v in nu.items():
        S[i, j] = S[j, i] = -v / E[i]
    # shear order [23, 13, 12]
    S[3, 3] = 1.0 / G[0]
    S[4, 4] = 1.0 / G[1]
    S[5, 5] = 1.0 / G[2]
    return S


@dataclass(frozen=True)
class _Base:
    rho: float | None = None
    tau_v: float = 0.0
    formulation: Literal["displacement", "nodal_pressure"] = "displacement"

    def _check_formulation(self) -> None:
        if self.formulation not in FORMULATIONS:
            raise _material_error(
                "formulation", f"must be one of {list(FORMULATIONS)}, got {self.formulation!r}"
            )

    def voigt(self) -> npt.NDArray[np.float64]:  # pragma: no cover - abstract
        raise NotImplementedError

    def stiffness(self, dim: int) -> npt.NDArray[np.float64]:
        """Elastic stiffness in Voigt form for ``dim`` = 2 (plane strain) or 3."""
        C = self.voigt()
        return plane_strain_block(C) if dim == 2 else C

    @property
    def is_isotropic(self) -> bool:
        return False

    def wave_speed(self) -> float:
        """Largest longitudinal wave speed sqrt(max eig(C)/ρ) (for reporting)."""
        if self.rho is None:
            return float("nan")
        return float(np.sqrt(np.linalg.eigvalsh(self.voigt()).max() / self.rho))


@dataclass(frozen=True)
class Isotropic(_Base):
    """Isotropic Kelvin–Voigt material from Young's modulus and Poisson's ratio."""

    E: float = 1.0
    nu: float = 0.0

    def __post_init__(self) -> None:
        _positive("E", self.E)
        if not np.isfinite(self.nu) or not (-1.0 < self.nu < 0.5):
            raise _material_error("nu", f"must satisfy -1 < nu < 0.5, got {self.nu!r}")
        _common_checks(self.rho, self.tau_v)
        self._check_formulation()

    @property
    def is_isotropic(self) -> bool:
        return True

    @property
    def mu(self) -> float:
        return self.E / (2.0 * (1.0 + self.nu))

    @property
    def lmbda(self) -> float:
        return self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))

    @property
    def kappa(self) -> float:
        """Bulk modulus (3D)."""
        return self.E / (3.0 * (1.0 - 2.0 * self.nu))

    def voigt(self) -> npt.NDArray[np.float64]:
        lm, mu = self.lmbda, self.mu
        C = np.zeros((6, 6))
        C[:3, :3] = lm
        C[np.arange(3), np.arange(3)] += 2.0 * mu
        C[3, 3] = C[4, 4] = C[5, 5] = mu
        return C


@dataclass(frozen=True)
class TransverselyIsotropic(_Base):
    """Transversely isotropic material (e.g. cortical bone, Reilly–Burstein).

    ``E_p``, ``nu_p``: in the isotropy plane; ``E_a``: along ``axis``;
    ``nu_pa``: Poisson's ratio for a load in the plane and contraction along the
    axis (ν_pa / E_p = ν_ap / E_a); ``G_pa``: shear modulus of planes containing the axis.
    """

    E_p: float = 1.0
    E_a: float = 1.0
    nu_p: float = 0.0
    nu_pa: float = 0.0
    G_pa: float = 0.5
    axis: tuple[float, ...] = (0.0, 0.0, 1.0)
    _frame: npt.NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for k in ("E_p", "E_a", "G_pa"):
            _positive(k, getattr(self, k))
        for k in ("nu_p", "nu_pa"):
            v = getattr(self, k)
            if not np.isfinite(v):
                raise _material_error(k, f"must be a finite number, got {v!r}")
        _common_checks(self.rho, self.tau_v)
        self._check_formulation()
        if self.formulation != "displacement":
            raise _material_error(
                "formulation", "only isotropic materials support 'nodal_pressure'"
            )
        object.__setattr__(self, "_frame", _frame_from_axis(self.axis))
        _check_spd(self._material_voigt(), "nu_pa")

    def _material_voigt(self) -> npt.NDArray[np.float64]:
        Ep, Ea = self.E_p, self.E_a
        Gp = Ep / (2.0 * (1.0 + self.nu_p))
        S = _orthotropic_compliance(
            (Ep, Ep, Ea),
            {(0, 1): self.nu_p, (0, 2): self.nu_pa, (1, 2): self.nu_pa},
            (self.G_pa, self.G_pa, Gp),
        )
        return np.linalg.inv(S)

    def voigt(self) -> npt.NDArray[np.float64]:
        T = voigt_rotation(self._frame)
        return T.T @ self._material_voigt() @ T


@dataclass(frozen=True)
class Orthotropic(_Base):
    """Orthotropic material from engineering constants in its material axes.

    ``axes`` holds the three material axes (orthonormal rows, global coordinates);
    ``nu_ij`` is the contraction along j for a load along i (ν_ij/E_i = ν_ji/E_j).
    """

    E1: float = 1.0
    E2: float = 1.0
    E3: float = 1.0
    nu12: float = 0.0
    nu13: float = 0.0
    nu23: float = 0.0
    G12: float = 0.5
    G13: float = 0.5
    G23: float = 0.5
    axes: tuple[tuple[float, ...], ...] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    _frame: npt.NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for k in ("E1", "E2", "E3", "G12", "G13", "G23"):
            _positive(k, getattr(self, k))
        for k in ("nu12", "nu13", "nu23"):
            v = getattr(self, k)
            if not np.isfinite(v):
                raise _material_error(k, f"must be a finite number, got {v!r}")
        _common_checks(self.rho, self.tau_v)
        self._check_formulation()
        if self.formulation != "displacement":
            raise _material_error(
                "formulation", "only isotropic materials support 'nodal_pressure'"
            )
        object.__setattr__(self, "_frame", _axes_matrix(self.axes, "axes"))
        _check_spd(self._material_voigt(), "nu12")

    def _material_voigt(self) -> npt.NDArray[np.float64]:
        S = _orthotropic_compliance(
            (self.E1, self.E2, self.E3),
            {(0, 1): self.nu12, (0, 2): self.nu13, (1, 2): self.nu23},
            (self.G23, self.G13, self.G12),
        )
        return np.linalg.inv(S)

    def voigt(self) -> npt.NDArray[np.float64]:
        T = voigt_rotation(self._frame)
        return T.T @ self._material_voigt() @ T


Material = Isotropic | TransverselyIsotropic | Orthotropic
