"""Options of the PDAS contact solver (:class:`bonecontact.contact.pdas.ContactSolver`),
grouped by the part of the solver they steer.

``PDASOptions(friction=..., max_iterations=..., linear=LinearOptions(...),
active_set=ActiveSetOptions(...), slip=SlipOptions(...))``.  The former flat keywords
(``PDASOptions(strategy="refactor", slip_3d="fixed_point")``) are still accepted, with a
:class:`DeprecationWarning` naming the group, and reading ``options.strategy`` still
works (it reads the group's field); ``PDASOptions.from_fields(strategy=..., slip_3d=...)``
groups fields given by name without a warning (parameter sweeps).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, fields, replace

from bonecontact.contact.friction import FrictionLaw

__all__ = ["ActiveSetOptions", "LinearOptions", "PDASOptions", "SlipOptions"]


@dataclass(frozen=True)
class LinearOptions:
    """The linear strategy (:mod:`bonecontact.contact.linear_strategy`).

    The linear solver (``"direct"`` / ``"iterative"``), its Krylov tolerance and the
    force scale of the operator are not options: they come from the integrator that
    sets the solver up (:meth:`bonecontact.contact.pdas.ContactSolver.setup`).
    """

    #: ``"lowrank"`` (one factorisation reused through low-rank updates; direct solver
    #: only), ``"refactor"`` (factorise / precondition every iteration) or ``"auto"``
    #: (``"lowrank"`` with the direct solver, else ``"refactor"``).
    strategy: str = "auto"
    #: PETSc options prefix of the contact linear solver.
    prefix: str = "bc_contact_"
    #: Low-rank strategy: cache limit (columns) of
    #: :class:`bonecontact.contact.lowrank.LowRankActiveSetSolver`.
    max_columns: int = 2000
    #: Low-rank strategy: the cost ratio (columns against one factorisation) beyond
    #: which the current set is refactorised instead (with the split basis: the set
    #: added to the contact basis and refactorised, costs counted in operations; 0
    #: re-splits whenever columns are missing, a huge value never).
    rebase_ratio: float = 1.0
    #: Low-rank strategy: the memory of a block of columns, and of the column cache, each
    #: at most this fraction of the memory of the LU factors (blocks are computed in
    #: chunks; a cache that would outgrow it rebases), so a contact solve needs at most
    #: about ``1 + memory_ratio`` linear solves of memory (0.05: the 65k 3D Hertz
    #: run's peak 1.64 -> 1.37 MUMPS solves, same sets and time; issue 28).
    memory_ratio: float = 0.05
    #: Low-rank strategy: the full solution columns kept across contact solves (time and
    #: load steps: the final field without a second solve) are as many as the expected
    #: contact zone needs (the columns the sets needed so far plus the new ones: the
    #: last steps' zone and the rows about to close), at least ``memory_ratio`` and at
    #: most this fraction of the LU factors' memory; the peak is reported (summary.json
    #: ``contact.full_columns_peak_mb``; docs/theory/pdas.md#full-columns-across-steps).
    full_ratio: float = 0.25
    #: Low-rank strategy: factorise the operator with only the cold start's support patch
    #: in the contact basis and reach every other set by force columns
    #: (:class:`bonecontact.contact.lowrank.SplitBasis`; the full contact basis couples
    #: every slave node in reach of the master side and roughly doubles the LU factors
    #: in 3D).  The base is then never refactorised.
    split_basis: bool = True
    #: Iterative solver: the GAMG preconditioner of an earlier set is kept (across PDAS
    #: iterations and time steps) while the current set differs from it in at most this
    #: fraction of the contact rows fixed or replaced in it (at least one row) ...
    #: (docs/theory/pdas.md#preconditioner-reuse); 0 rebuilds it at every solve; ``None``:
    #: 0.25 with GAMG, 0 with the compressed hierarchy (``multigrid``; its kept
    #: preconditioner cost more iterations than its set-up saves: 200k dofs 79 → 50 CG
    #: iterations, 20.2 → 18.3 Gflop).
    pc_reuse_rows: float | None = None
    #: ... and the last solve with it took at most this many times the Krylov iterations
    #: per decade of residual reduction of the first solve after it was built; otherwise
    #: it is rebuilt.
    pc_reuse_growth: float = 1.5
    #: Iterative solver, frictionless pairs: inexact PDAS — while the active set still
    #: changes, each Krylov solve stops at this relative tolerance; once a loose solve
    #: leaves the set unchanged, the same set is solved again to the tight tolerance
    #: (warm-started from the loose iterate) and the convergence test is taken on that
    #: solve (docs/theory/pdas.md#inexact-solves).  0 (or a value not above the tight
    #: tolerance): every solve to the tight tolerance.
    loose_rtol: float = 1e-4
    #: Iterative solver: the multigrid preconditioner — ``"gamg"`` (PETSc's, twelve coarse
    #: unknowns per aggregate in 3D) or ``"compressed"`` (each aggregate's columns
    #: compressed to the rank of the rigid modes there: six inside a body, up to twelve
    #: at the interface; :mod:`bonecontact.contact.compressed_mg`,
    #: docs/theory/pdas.md#compressed-coarse-grid; the default: fewer iterations,
    #: operations and memory than GAMG at 65k–1M dofs).
    multigrid: str = "compressed"
    #: Iterative solver: multigrid cycle, ``"w"`` or ``"v"``.
    multigrid_cycle: str = "w"

    def __post_init__(self) -> None:
        if self.strategy not in ("auto", "lowrank", "refactor"):
            raise ValueError(
                f"contact strategy must be 'auto', 'lowrank' or 'refactor', got {self.strategy!r}"
            )
        if not self.memory_ratio > 0.0:
            raise ValueError(f"memory_ratio must be positive, got {self.memory_ratio}")
        if not self.full_ratio >= 0.0:
            raise ValueError(f"full_ratio must be >= 0, got {self.full_ratio}")
        rows = 0.0 if self.pc_reuse_rows is None else self.pc_reuse_rows
        if rows < 0.0 or not self.pc_reuse_growth >= 1.0:
            raise ValueError(
                f"pc_reuse_rows must be >= 0 and pc_reuse_growth >= 1, got "
                f"{self.pc_reuse_rows} and {self.pc_reuse_growth}"
            )
        if self.multigrid not in ("gamg", "compressed"):
            raise ValueError(f"multigrid must be 'gamg' or 'compressed', got {self.multigrid!r}")
        if self.multigrid_cycle not in ("w", "v"):
            raise ValueError(f"multigrid_cycle must be 'w' or 'v', got {self.multigrid_cycle!r}")
        if not 0.0 <= self.loose_rtol < 1.0:
            raise ValueError(f"loose_rtol must be in [0, 1), got {self.loose_rtol}")


@dataclass(frozen=True)
class ActiveSetOptions:
    """The normal set update and the cold start (:mod:`bonecontact.contact.set_update`,
    :mod:`bonecontact.contact.cold_start`)."""

    #: Normal complementarity parameter (Pa/m); ``None``: the mean ratio of the normal
    #: rows' diagonal to ``D_pp`` (≈ E/h).
    c_n: float | None = None
    #: Tangential complementarity parameter (Pa/m); ``None``: equal to ``c_n``.
    c_t: float | None = None
    #: Gaps below this (m) count as closed for the cold start; ``None``: 1e-9 × the
    #: slave surface size.
    gap_tol: float | None = None
    #: Cold start only: the first set update activates, of the nodes that penetrate
    #: after the first solve, only those whose penetration exceeds this fraction of the
    #: deepest (0 = all), in [0, 1).  Only the path changes, not the solution.
    cold_start_fraction: float = 0.7
    #: Cold start in 3D: ``"compliance"`` — the first set update takes the contact zone
    #: predicted from the force, approach and stiffness of the support patch's first
    #: solve (one extra solve; docs/theory/pdas.md#cold-start); ``"damped"`` — the 2D
    #: rule (``cold_start_fraction``).  Only the path changes, not the solution.
    cold_start_3d: str = "compliance"

    def __post_init__(self) -> None:
        if not 0.0 <= self.cold_start_fraction < 1.0:
            raise ValueError(
                f"cold_start_fraction must be in [0, 1), got {self.cold_start_fraction}"
            )
        if self.cold_start_3d not in ("compliance", "damped"):
            raise ValueError(
                f"cold_start_3d must be 'compliance' or 'damped', got {self.cold_start_3d!r}"
            )


@dataclass(frozen=True)
class SlipOptions:
    """How the friction sets and bounds are iterated (:mod:`bonecontact.contact.set_update`)."""

    #: Coulomb ``fixed_point``: update the bounds every ``fp_every`` iterations (and
    #: whenever the sets have settled); values below 1 count as 1.
    fp_every: int = 1
    #: Coulomb ``fixed_point``: converged when the relative change of the bounds is
    #: below this.
    fp_tol: float = 1e-8
    #: 3D friction: slip directions must change by less than this between iterations
    #: (and, with ``slip_3d="newton"``, the slip traction must equal the bound times
    #: the direction to this relative accuracy).
    direction_tol: float = 1e-6
    #: 3D slip nodes: ``"newton"`` — the damped semi-smooth Newton linearisation of
    #: C_t (Hüeber–Stadler–Wohlmuth), nonsymmetric rows; ``"fixed_point"`` — the
    #: traction is prescribed along the previous slip direction and the direction
    #: iterated (Aitken-accelerated) to a fixed point.
    slip_3d: str = "newton"
    #: Time and load steps: a friction node that slipped at the end of the last contact
    #: solve starts the next one slipping along its last direction (3D Newton rows
    #: linearised at its last traction and ξ) instead of sticking (the elastic trial
    #: state).  Same solution; off by default: where the slip direction turns between
    #: steps (the knee gait, a turning drag) the trial state's direction is the better
    #: start (docs/theory/pdas.md#warm-started-friction).
    warm_slip: bool = False

    def __post_init__(self) -> None:
        if self.slip_3d not in ("newton", "fixed_point"):
            raise ValueError(f"slip_3d must be 'newton' or 'fixed_point', got {self.slip_3d!r}")


#: The option groups of :class:`PDASOptions` and their classes.
GROUPS: dict[str, type] = {
    "linear": LinearOptions,
    "active_set": ActiveSetOptions,
    "slip": SlipOptions,
}
#: Former flat keyword → its group.
FLAT_NAMES: dict[str, str] = {f.name: group for group, cls in GROUPS.items() for f in fields(cls)}


@dataclass(frozen=True, init=False)
class PDASOptions:
    """Options of the primal–dual active set contact solver, validated on construction.

    Parameters
    ----------
    friction
        One :class:`~bonecontact.contact.friction.FrictionLaw` for every pair, or a list
        (or tuple) with one per pair; ``None``: frictionless.
    max_iterations
        PDAS iteration limit (all iterations of a solve, bound updates included).
    linear, active_set, slip
        The option groups (:class:`LinearOptions`, :class:`ActiveSetOptions`,
        :class:`SlipOptions`); ``None``: their defaults.
    **flat
        Deprecated: a field of one of the groups by its name (``strategy="refactor"``).
    """

    friction: FrictionLaw | list[FrictionLaw] | tuple[FrictionLaw, ...] | None = None
    max_iterations: int = 50
    linear: LinearOptions = field(default_factory=LinearOptions)
    active_set: ActiveSetOptions = field(default_factory=ActiveSetOptions)
    slip: SlipOptions = field(default_factory=SlipOptions)

    def __init__(
        self,
        friction: FrictionLaw | list[FrictionLaw] | tuple[FrictionLaw, ...] | None = None,
        max_iterations: int = 50,
        linear: LinearOptions | None = None,
        active_set: ActiveSetOptions | None = None,
        slip: SlipOptions | None = None,
        **flat: object,
    ):
        groups = {
            "linear": linear if linear is not None else LinearOptions(),
            "active_set": active_set if active_set is not None else ActiveSetOptions(),
            "slip": slip if slip is not None else SlipOptions(),
        }
        for name, value in flat.items():
            if name not in FLAT_NAMES:
                raise TypeError(f"PDASOptions got an unexpected keyword argument {name!r}")
            group = FLAT_NAMES[name]
            warnings.warn(
                f"PDASOptions({name}=...) is deprecated: use "
                f"PDASOptions({group}={GROUPS[group].__name__}({name}=...))",
                DeprecationWarning,
                stacklevel=2,
            )
            groups[group] = replace(groups[group], **{name: value})
        object.__setattr__(self, "friction", friction)
        object.__setattr__(self, "max_iterations", max_iterations)
        for group, value in groups.items():
            if not isinstance(value, GROUPS[group]):
                raise TypeError(
                    f"PDASOptions {group} must be a {GROUPS[group].__name__}, got {value!r}"
                )
            object.__setattr__(self, group, value)
        if int(self.max_iterations) < 1:
            raise ValueError(f"max_iterations must be >= 1, got {self.max_iterations}")

    @classmethod
    def from_fields(
        cls,
        friction: FrictionLaw | list[FrictionLaw] | tuple[FrictionLaw, ...] | None = None,
        max_iterations: int = 50,
        **fields_: object,
    ) -> PDASOptions:
        """The options with the groups' fields given by name, each put in its group
        (``from_fields(strategy="refactor", slip_3d="fixed_point")``): for parameter
        sweeps that vary fields of several groups.  An unknown name is a ``TypeError``."""
        groups: dict[str, dict[str, object]] = {g: {} for g in GROUPS}
        for name, value in fields_.items():
            if name not in FLAT_NAMES:
                raise TypeError(f"PDASOptions has no option {name!r}")
            groups[FLAT_NAMES[name]][name] = value
        built = {g: GROUPS[g](**kw) for g, kw in groups.items()}
        return cls(friction, max_iterations, **built)

    def __getattr__(self, name: str) -> object:
        """A group's field by its former flat name (``options.strategy``)."""
        group = FLAT_NAMES.get(name)
        if group is None:
            raise AttributeError(f"'PDASOptions' object has no attribute {name!r}")
        return getattr(object.__getattribute__(self, group), name)

    def frictions(self, n_pairs: int) -> list[FrictionLaw]:
        """One friction law per contact pair."""
        friction = FrictionLaw() if self.friction is None else self.friction
        laws = list(friction) if isinstance(friction, (list, tuple)) else [friction] * n_pairs
        if len(laws) != n_pairs:
            raise ValueError(f"{len(laws)} friction laws for {n_pairs} contact pairs")
        return laws
