"""The contact robustness matrix: contact configurations generated from a few parameters,
each built as a gmsh mesh and a scene file and run through the documented user path.

:class:`Config` is one configuration, :data:`LEVELS` the parameter values, :func:`matrix`
the covering design that is run, :func:`run_config` one run (mesh, scene, ``run_scene``)
turned into a :class:`Record` with its checks, :func:`same_answer` the comparison of two
runs.  Geometry, checks and the choice of configurations:
docs/theory/verification.md#contact-robustness-matrix.
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from types import SimpleNamespace

from mpi4py import MPI

import gmsh
import numpy as np

from bonecontact.meshing.builder import PhysicalGroups, generate
from bonecontact.meshing.io import read_gmsh_mesh
from bonecontact.meshing.session import gmsh_session
from bonecontact.runners.dispatch import run_scene
from bonecontact.scene import SceneError, load_scene
from bonecontact.scene.checks import PlausibilityWarning
from bonecontact.verification.analytic import hertz_2d, hertz_3d

__all__ = [
    "HARD_CORNERS",
    "ILL_POSED",
    "LEVELS",
    "Config",
    "Record",
    "build_mesh",
    "config_from_name",
    "contact_table",
    "matrix",
    "normalised",
    "pairwise",
    "run_config",
    "run_matrix",
    "same_answer",
    "scene_text",
    "touch_ranks",
]

#: Radius of the curved slave body (m); the master cap has radius 2R.
RADIUS = 0.01
#: Young's modulus of the slave body (Pa); the master's is ``contrast`` times larger.
E_SLAVE = 1.0e7
#: Poisson ratios of curved and of flat bodies.
NU_CURVED, NU_FLAT = 0.3, 0.0
#: Density (kg/m³) and Kelvin–Voigt time (s) of both bodies in dynamic runs.
RHO, TAU_V = 2000.0, 1.0e-5
#: Friction: Coulomb coefficient; Tresca bound as a fraction of the nominal pressure.
MU, TRESCA_FRACTION = 0.3, 0.2

#: The values of each parameter (the order of :class:`Config`'s fields).
LEVELS: dict[str, tuple] = {
    "dim": (2, 3),
    "shape": ("curved_flat", "flat_flat", "curved_curved", "wide_slave"),
    "touch": ("node", "between"),
    "gap": (0.0, 0.1, 1.0, 10.0, -0.1),
    "drive": ("load", "displacement"),
    "contrast": (1.0, 1.0e2, 1.0e4),
    "size_ratio": (0.25, 1.0, 4.0),
    "friction": ("none", "tresca", "coulomb"),
    "analysis": ("static", "dynamic"),
}


@dataclass(frozen=True)
class Config:
    """One contact configuration (docs/theory/verification.md#contact-robustness-matrix).

    Attributes
    ----------
    dim
        2 (plane strain) or 3.
    shape
        ``"curved_flat"``, ``"flat_flat"``, ``"curved_curved"`` or ``"wide_slave"`` (a
        flat slave block 1.5 times wider than the master block).
    touch
        Curved slave: ``"node"`` (a slave node at the apex) or ``"between"`` (2D: the
        apex at the midpoint of a slave facet; 3D: inside a facet).  Flat shapes touch
        along a face (the value is ignored).
    gap
        Initial gap in slave element sizes at the contact (negative: overlap).
    drive
        ``"load"`` (a traction on the slave's top face; the body held in the load
        direction only by the contact) or ``"displacement"`` (that face moved down by
        the gap plus the approach).
    contrast
        E_master / E_slave.
    size_ratio
        Slave element size over master element size at the contact.
    friction
        ``"none"``, ``"tresca"`` or ``"coulomb"``.
    analysis
        ``"static"`` or ``"dynamic"``.
    supported
        ``False``: the slave body has no tangential support (ill-posed without friction).
    fine
        Mesh refinement factor (1: the reduced meshes of the test suite).
    """

    dim: int = 2
    shape: str = "curved_flat"
    touch: str = "node"
    gap: float = 0.0
    drive: str = "load"
    contrast: float = 1.0e3
    size_ratio: float = 1.0
    friction: str = "none"
    analysis: str = "static"
    supported: bool = True
    fine: float = 1.0

    @property
    def curved(self) -> bool:
        """Whether the slave body is a curved punch."""
        return self.shape in ("curved_flat", "curved_curved")

    @property
    def name(self) -> str:
        """A short identifier, e.g. ``2d-curved_flat-node-g0-load-c1e+03-r1-none-static``."""
        parts = [
            f"{self.dim}d",
            self.shape,
            self.touch if self.curved else "face",
            f"g{self.gap:g}",
            self.drive,
            f"c{self.contrast:.0e}",
            f"r{self.size_ratio:g}",
            self.friction,
            self.analysis,
        ]
        if not self.supported:
            parts.append("unsupported")
        if self.fine != 1.0:
            parts.append(f"f{self.fine:g}")
        return "-".join(parts)

    def well_posed(self) -> tuple[bool, str]:
        """``(True, "")`` or ``(False, why)``: a frictionless slave body without
        tangential support can slide (and rotate) freely."""
        if not self.supported and self.friction == "none" and self.analysis == "static":
            return False, "the slave body's sliding and rotation are held by nothing"
        return True, ""


def normalised(cfg: Config) -> Config:
    """The same configuration with the parameters that do not apply to it set to a
    fixed value (flat slaves touch along a face: ``touch = "node"``)."""
    return cfg if cfg.curved else replace(cfg, touch="node")


# ----------------------------------------------------------------------------- covering design
def pairwise(levels: dict[str, Sequence]) -> list[dict]:
    """A greedy all-pairs covering design: rows (dicts of parameter values) such that
    every pair of values of any two parameters occurs in at least one row.

    Each new row starts from the first uncovered pair and fills the other parameters,
    one at a time, with the value that covers the most uncovered pairs with the values
    chosen so far (ties: the earlier value).  Deterministic.
    """
    keys = list(levels)
    uncovered = {
        (a, va, b, vb)
        for a, b in itertools.combinations(keys, 2)
        for va in levels[a]
        for vb in levels[b]
    }
    rows: list[dict] = []
    while uncovered:
        a, va, b, vb = min(uncovered, key=lambda t: (keys.index(t[0]), keys.index(t[2]), str(t)))
        row = {a: va, b: vb}
        for k in keys:
            if k in row:
                continue
            row[k] = max(levels[k], key=lambda v: _gain(row, k, v, uncovered, keys))
        uncovered -= {(p, row[p], q, row[q]) for p, q in itertools.combinations(keys, 2)}
        rows.append(row)
    return rows


def _gain(row: dict, k: str, v: object, uncovered: set, keys: list[str]) -> int:
    """How many uncovered pairs setting ``row[k] = v`` covers."""
    n = 0
    for p, pv in row.items():
        pair = (p, pv, k, v) if keys.index(p) < keys.index(k) else (k, v, p, pv)
        n += pair in uncovered
    return n


#: The hard corners added to the pairwise cover.
HARD_CORNERS: tuple[Config, ...] = (
    # the issue-23 half disc: no node at the apex, stiff block, load-driven
    Config(2, "curved_flat", "between", 0.0, "load", 1.0e4, 1.0, "none", "static"),
    Config(3, "curved_flat", "between", 0.0, "load", 1.0e4, 1.0, "none", "static"),
    # everything extreme at once
    Config(2, "curved_flat", "between", 10.0, "load", 1.0e4, 4.0, "coulomb", "static"),
    Config(3, "curved_curved", "between", 10.0, "displacement", 1.0e4, 0.25, "coulomb", "static"),
    Config(2, "wide_slave", "node", 1.0, "load", 1.0e4, 0.25, "tresca", "static"),
    Config(2, "flat_flat", "node", -0.1, "load", 1.0e4, 4.0, "coulomb", "dynamic"),
    Config(3, "flat_flat", "node", 10.0, "displacement", 1.0, 4.0, "tresca", "static"),
)

#: Configurations that are ill-posed by construction (recognised, not failures).
ILL_POSED: tuple[Config, ...] = (
    Config(2, "flat_flat", supported=False),
    Config(2, "curved_flat", supported=False),
    Config(3, "curved_flat", supported=False),
)


def matrix(levels: dict[str, Sequence] | None = None) -> list[Config]:
    """The robustness matrix: the pairwise cover of ``levels`` (default :data:`LEVELS`),
    the hard corners and the ill-posed configurations, normalised, without repeats."""
    rows = [Config(**r) for r in pairwise(LEVELS if levels is None else levels)]
    out: list[Config] = []
    for cfg in map(normalised, [*rows, *HARD_CORNERS, *ILL_POSED]):
        if cfg not in out:
            out.append(cfg)
    return out


# ----------------------------------------------------------------------------- sizes and loads
@dataclass(frozen=True)
class Design:
    """The numbers a configuration is built from (m, Pa, N or N/m).

    Attributes
    ----------
    h_slave, h_master
        Element sizes of the two bodies at the contact.
    h_far
        Element size far from the contact (curved bodies).
    zone
        Radius of the refined zone around the first touch.
    gap
        Initial gap (m; negative: overlap).
    a_target
        Hertz half-width/radius the load is chosen for (curved), else 0.
    r_eff
        Relative radius of curvature (curved), else ``inf``.
    pressure
        Nominal contact pressure: Hertz's p₀ (curved) or the uniform pressure (flat).
    load
        The total load the traction applies (load-driven), else 0.
    approach
        The prescribed approach beyond first touch (displacement-driven), else 0.
    """

    h_slave: float
    h_master: float
    h_far: float
    zone: float
    gap: float
    a_target: float
    r_eff: float
    pressure: float
    load: float
    approach: float


def _hertz(dim: int) -> SimpleNamespace:
    """The Hertz formulas of the dimension (plane strain or 3D)."""
    return hertz_3d if dim == 3 else hertz_2d


def design(cfg: Config) -> Design:
    """The sizes and loads of ``cfg`` (before meshing; the traction is set from the
    meshed top face's area so that it applies exactly ``load``)."""
    R, E1, E2 = RADIUS, E_SLAVE, cfg.contrast * E_SLAVE
    if cfg.curved:
        a = (0.15 if cfg.dim == 3 else 0.1) * R
        coarse = a / (2.0 if cfg.dim == 3 else 4.0) / cfg.fine
    else:
        a, coarse = 0.0, R / (3.0 if cfg.dim == 3 else 5.0) / cfg.fine
    hs, hm = (
        (coarse, coarse / cfg.size_ratio)
        if cfg.size_ratio >= 1
        else (
            coarse * cfg.size_ratio,
            coarse,
        )
    )
    if not cfg.curved:
        p = 1.0e-3 * E1
        top = _flat_top_area(cfg)
        comp = _slab_height(cfg, "slave") / E1 + _slab_height(cfg, "master") / E2
        load, approach = (p * top, 0.0) if cfg.drive == "load" else (0.0, p * comp)
        return Design(hs, hm, max(hs, hm), 0.0, cfg.gap * hs, 0.0, math.inf, p, load, approach)
    r_eff = R if cfg.shape == "curved_flat" else R * 2 * R / (R + 2 * R)
    law, nu = _hertz(cfg.dim), NU_CURVED
    P = (law.load_for_radius if cfg.dim == 3 else law.load_for_half_width)(a, r_eff, E1, nu, E2, nu)
    p0 = law.peak_pressure(P, r_eff, E1, nu, E2, nu)
    delta = a**2 / r_eff * (1.0 if cfg.dim == 3 else 1.6)
    load, approach = (P, 0.0) if cfg.drive == "load" else (0.0, delta)
    h_far = 4.0e-3 if cfg.dim == 3 else 2.0e-3
    return Design(
        hs,
        hm,
        h_far,
        (1.0 if cfg.dim == 3 else 1.5) * a,
        cfg.gap * hs,
        a,
        r_eff,
        p0,
        load,
        approach,
    )


def _slab_height(cfg: Config, body: str) -> float:
    """Height of a flat slave or master block (m)."""
    return RADIUS / 2


def _half_width(cfg: Config, body: str) -> float:
    """Half-width (x, and z in 3D) of a body (m)."""
    if body == "slave":
        return RADIUS * (1.5 if cfg.shape == "wide_slave" else 1.0)
    if cfg.shape in ("flat_flat", "wide_slave", "curved_curved"):
        return RADIUS
    return RADIUS * (1.2 if cfg.dim == 3 else 2.0)


def _flat_top_area(cfg: Config) -> float:
    """Area (length in 2D) of a flat slave block's top face."""
    w = 2 * _half_width(cfg, "slave")
    return w if cfg.dim == 2 else w * w


# ----------------------------------------------------------------------------- geometry
def _classify(dim: int, tag: int, rules: dict[str, Callable]) -> dict[str, list[int]]:
    """The boundary entities of (dim, tag) sorted into groups by the first rule
    (name -> predicate on (entity tag, centre of mass, gmsh type)) they satisfy."""
    out: dict[str, list[int]] = {k: [] for k in rules}
    for _, t in gmsh.model.getBoundary([(dim, tag)], combined=False, oriented=False):
        t = abs(t)
        com = gmsh.model.occ.getCenterOfMass(dim - 1, t)
        kind = gmsh.model.getType(dim - 1, t)
        for name, rule in rules.items():
            if rule(com, kind):
                out[name].append(t)
                break
    return out


def _slab(dim: int, hw: float, y0: float, y1: float) -> int:
    """An axis-aligned block |x| (and |z|) <= hw, y0 <= y <= y1."""
    occ = gmsh.model.occ
    if dim == 2:
        return occ.addRectangle(-hw, y0, 0, 2 * hw, y1 - y0)
    return occ.addBox(-hw, y0, -hw, 2 * hw, y1 - y0, 2 * hw)


def _punch_2d(touch: str, gap: float, h: float) -> int:
    """The 2D punch: the lower half of the disc of radius R centred at (0, R + gap) under
    the rectangle up to y = R + gap + R/2.  ``touch = "between"``: the arc is split at
    x = ±h/2 and the middle arc meshed with one element (the apex at its midpoint)."""
    occ, R = gmsh.model.occ, RADIUS
    yc, top = R + gap, R + gap + R / 2
    c = occ.addPoint(0, yc, 0)
    pl, pr = occ.addPoint(-R, yc, 0), occ.addPoint(R, yc, 0)
    if touch == "node":
        mids = [occ.addPoint(0, gap, 0)]
    else:
        s = h / 2
        y = yc - math.sqrt(R * R - s * s)
        mids = [occ.addPoint(-s, y, 0), occ.addPoint(s, y, 0)]
    chain = [pl, *mids, pr]
    arcs = [occ.addCircleArc(a, c, b) for a, b in itertools.pairwise(chain)]
    tr, tl = occ.addPoint(R, top, 0), occ.addPoint(-R, top, 0)
    lines = [occ.addLine(pr, tr), occ.addLine(tr, tl), occ.addLine(tl, pl)]
    surf = occ.addPlaneSurface([occ.addCurveLoop(arcs + lines)])
    occ.remove([(0, c)])
    occ.synchronize()
    if touch != "node":
        gmsh.model.mesh.setTransfiniteCurve(arcs[1], 2)
    return surf


def _punch_3d(touch: str, gap: float) -> int:
    """The 3D punch: the lower half of the ball of radius R centred at (0, R + gap, 0)
    under a cylinder of height R/2.  The ball's pole is at the apex for ``"node"``,
    0.35 rad away from it for ``"between"``."""
    occ, R = gmsh.model.occ, RADIUS
    yc = R + gap
    ball = occ.addSphere(0, yc, 0, R)
    occ.rotate([(3, ball)], 0, yc, 0, 1, 0, 0, math.pi / 2 + (0.0 if touch == "node" else 0.35))
    box = occ.addBox(-2 * R, gap - R, -2 * R, 4 * R, 2 * R, 4 * R)
    hemi, _ = occ.intersect([(3, ball)], [(3, box)])
    cyl = occ.addCylinder(0, yc, 0, 0, R / 2, 0, R)
    out, _ = occ.fuse(hemi, [(3, cyl)])
    occ.synchronize()
    return out[0][1]


def _cap(dim: int) -> int:
    """The curved master: the block |x|, |z| <= R, -R <= y, under the circle/sphere of
    radius 2R centred at (0, -2R): its apex at the origin."""
    occ, R = gmsh.model.occ, RADIUS
    if dim == 2:
        round_ = occ.addDisk(0, -2 * R, 0, 2 * R, 2 * R)
    else:
        round_ = occ.addSphere(0, -2 * R, 0, 2 * R)
    out, _ = occ.intersect([(dim, round_)], [(dim, _slab(dim, R, -R, R))])
    occ.synchronize()
    return out[0][1]


def _bodies(cfg: Config, d: Design) -> tuple[int, int]:
    """Build the slave and master entities of ``cfg`` (synchronised)."""
    occ, dim = gmsh.model.occ, cfg.dim
    if cfg.curved:
        slave = _punch_2d(cfg.touch, d.gap, d.h_slave) if dim == 2 else _punch_3d(cfg.touch, d.gap)
    else:
        slave = _slab(dim, _half_width(cfg, "slave"), d.gap, d.gap + _slab_height(cfg, "slave"))
    if cfg.shape == "curved_curved":
        master = _cap(dim)
    else:
        hb = RADIUS if cfg.curved else _slab_height(cfg, "master")
        master = _slab(dim, _half_width(cfg, "master"), -hb, 0.0)
    occ.synchronize()
    return slave, master


def _size_field(dim: int, ent: int, h: float, h_far: float, zone: float, y0: float) -> int:
    """A Ball field (size ``h`` within ``zone`` of (0, y0, 0), growing to ``h_far``)
    restricted to the entity and its boundary."""
    f = gmsh.model.mesh.field
    ball = f.add("Ball")
    for key, val in (
        ("VIn", h),
        ("VOut", h_far),
        ("Radius", zone),
        ("Thickness", 10 * h_far),
        ("XCenter", 0.0),
        ("YCenter", y0),
        ("ZCenter", 0.0),
    ):
        f.setNumber(ball, key, val)
    res = f.add("Restrict")
    f.setNumber(res, "InField", ball)
    bnd = gmsh.model.getBoundary([(dim, ent)], combined=False, oriented=False, recursive=False)
    lists = {1: "CurvesList", 2: "SurfacesList", 3: "VolumesList"}
    f.setNumbers(res, lists[dim], [ent])
    f.setNumbers(res, lists[dim - 1], [abs(t) for _, t in bnd])
    if dim == 3:
        edges = gmsh.model.getBoundary(bnd, combined=False, oriented=False)
        f.setNumbers(res, "CurvesList", sorted({abs(t) for _, t in edges}))
    return res


def _groups(cfg: Config, d: Design, slave: int, master: int) -> None:
    """Name the bodies and the faces the scene uses."""
    dim, R = cfg.dim, RADIUS
    tol = 1e-9 * R
    bent = ("Circle", "Ellipse", "Sphere")
    top_y = (R + d.gap + R / 2) if cfg.curved else d.gap + _slab_height(cfg, "slave")
    s = _classify(
        dim,
        slave,
        {
            "slave_contact": (lambda c, k: k in bent)
            if cfg.curved
            else (lambda c, k: abs(c[1] - d.gap) < tol),
            "slave_top": lambda c, k: abs(c[1] - top_y) < tol and k not in bent,
        },
    )
    bottom = -R if cfg.curved or cfg.shape == "curved_curved" else -_slab_height(cfg, "master")
    m = _classify(
        dim,
        master,
        {
            "master_contact": (lambda c, k: k in bent)
            if cfg.shape == "curved_curved"
            else (lambda c, k: abs(c[1]) < tol),
            "master_bottom": lambda c, k: abs(c[1] - bottom) < tol,
        },
    )
    groups = PhysicalGroups()
    groups(dim, [slave], "slave_body")
    groups(dim, [master], "master_body")
    for name, tags in {**s, **m}.items():
        groups(dim - 1, tags, name)


def build_mesh(cfg: Config, path: Path, comm: MPI.Comm) -> Design:
    """Write the gmsh mesh of ``cfg`` to ``path`` (rank 0 of ``comm``; collective).

    Cell groups ``slave_body``, ``master_body``; facet groups ``slave_contact``,
    ``slave_top``, ``master_contact``, ``master_bottom``.
    """
    d = design(cfg)

    def build() -> None:
        slave, master = _bodies(cfg, d)
        fields = [
            _size_field(cfg.dim, slave, d.h_slave, d.h_far, d.zone, d.gap),
            _size_field(cfg.dim, master, d.h_master, d.h_far, d.zone, 0.0),
        ]
        f = gmsh.model.mesh.field
        fmin = f.add("Min")
        f.setNumbers(fmin, "FieldsList", fields)
        f.setAsBackgroundMesh(fmin)
        for opt in ("MeshSizeFromPoints", "MeshSizeExtendFromBoundary", "MeshSizeFromCurvature"):
            gmsh.option.setNumber(f"Mesh.{opt}", 0)
        _groups(cfg, d, slave, master)

    generate("robustness", cfg.dim, build, comm, path)
    return d


# ----------------------------------------------------------------------------- mesh facts
@dataclass
class Surface:
    """A facet group read back from the mesh file: its nodes with their nodal weights
    ∫φ_p (a 1/2 or 1/3 share of each adjacent facet's size) and unit normals (the
    facet-size weighted mean, oriented downwards: both slave faces the scene uses face
    −y or +y wholly), and its total size."""

    coords: np.ndarray
    weights: np.ndarray
    normals: np.ndarray
    size: float


def read_surface(path: Path, group: str, dim: int) -> Surface:
    """The facet group ``group`` of the mesh file (run on one rank)."""
    with gmsh_session("read"):
        gmsh.open(str(path))
        tag = next(
            t
            for d_, t in gmsh.model.getPhysicalGroups(dim - 1)
            if gmsh.model.getPhysicalName(d_, t) == group
        )
        facets = []
        for ent in gmsh.model.getEntitiesForPhysicalGroup(dim - 1, tag):
            _, _, nodes = gmsh.model.mesh.getElements(dim - 1, ent)
            facets.append(np.asarray(nodes[0], dtype=np.int64).reshape(-1, dim))
        tags, x, _ = gmsh.model.mesh.getNodes()
    facets = np.concatenate(facets)
    pos = {int(t): i for i, t in enumerate(tags)}
    X = np.asarray(x).reshape(-1, 3)[:, :dim]
    used = np.unique(facets)
    local = {int(t): i for i, t in enumerate(used)}
    coords = np.array([X[pos[int(t)]] for t in used])
    F = np.vectorize(local.get)(facets)
    P = coords[F]
    if dim == 2:
        t = P[:, 1] - P[:, 0]
        size = np.linalg.norm(t, axis=1)
        n = np.c_[t[:, 1], -t[:, 0]] / size[:, None]
    else:
        c = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
        size = 0.5 * np.linalg.norm(c, axis=1)
        n = c / (2 * size[:, None])
    n *= np.where(n[:, 1] > 0, -1.0, 1.0)[:, None]
    w, nn = np.zeros(len(used)), np.zeros((len(used), dim))
    for k in range(dim):
        np.add.at(w, F[:, k], size / dim)
        np.add.at(nn, F[:, k], size[:, None] * n)
    nn /= np.linalg.norm(nn, axis=1)[:, None]
    return Surface(coords, w, nn, float(size.sum()))


# ----------------------------------------------------------------------------- scene
def _vector(dim: int, y: float | str, tangential: float | str = 0.0) -> str:
    comps = [tangential, y, tangential][:dim]
    return "[" + ", ".join(f'"{c}"' if isinstance(c, str) else f"{c!r}" for c in comps) + "]"


def scene_text(cfg: Config, d: Design, mesh: str) -> str:
    """The scene of ``cfg`` (docs/scene_format.md): a load-driven slave body carries a
    ``[[force]]`` (the total load, spread uniformly over its top face)."""
    nu_s = NU_CURVED if cfg.curved else NU_FLAT
    nu_m = NU_CURVED if cfg.shape != "flat_flat" and cfg.shape != "wide_slave" else NU_FLAT
    dyn = cfg.analysis == "dynamic"
    t_end = dynamic_duration(cfg, d)
    dt = t_end / 4
    lines = [
        "format = 1",
        "[scene]",
        f'name = "{cfg.name}"',
        f'mesh = "{mesh}"',
        f"dimension = {cfg.dim}",
        "[analysis]",
        f'kind = "{cfg.analysis}"',
    ]
    if dyn:
        lines += [f"t_end = {t_end!r}", f"dt = {dt!r}"]
    else:
        lines += [f"load_steps = {1 if cfg.friction == 'none' else 2}"]
    for name, E, nu in (("slave", E_SLAVE, nu_s), ("master", cfg.contrast * E_SLAVE, nu_m)):
        lines += ["[[material]]", f'name = "{name}"', f'regions = ["{name}_body"]']
        lines += ['model = "isotropic"', f"E = {E!r}", f"nu = {nu!r}"]
        if dyn:
            lines += [f"rho = {RHO!r}", f"tau_v = {TAU_V!r}"]
    lines += _contact_lines(cfg, d)
    ramp = [f"ramp = {t_end!r}"] if dyn else []
    lines += ["[[dirichlet]]", 'boundary = "master_bottom"', f"value = {_vector(cfg.dim, 0.0)}"]
    tangential = 0.0 if cfg.supported else "free"
    if cfg.drive == "displacement":
        value = _vector(cfg.dim, -(d.gap + d.approach), tangential)
        lines += ["[[dirichlet]]", 'boundary = "slave_top"', f"value = {value}", *ramp]
    else:
        if cfg.supported:
            value = _vector(cfg.dim, "free", 0.0)
            lines += ["[[dirichlet]]", 'boundary = "slave_top"', f"value = {value}"]
        value = _vector(cfg.dim, -d.load)
        lines += ["[[force]]", 'boundary = "slave_top"', f"value = {value}", *ramp]
        if dyn and d.gap > 0.0:
            # an impact: the slave closes the gap by mid-run (a force alone would not
            # move it that far in the run's time)
            velocity = _vector(cfg.dim, -2.0 * d.gap / t_end)
            lines += ["[[initial_velocity]]", 'regions = ["slave_body"]', f"value = {velocity}"]
    lines += ["[output]", "fields_every = 0"]
    return "\n".join(lines) + "\n"


#: Impact speed of a dynamic load-driven row that starts apart, at most (m/s).
IMPACT_SPEED = 1.0


def dynamic_duration(cfg: Config, d: Design) -> float:
    """Simulated time of a dynamic row (s; 4 steps): 0.4 ms, longer where the slave
    must cross a gap — it is given the speed that closes the gap at mid-run, at most
    :data:`IMPACT_SPEED`."""
    return max(4.0e-4, 2.0 * max(d.gap, 0.0) / IMPACT_SPEED)


def _contact_lines(cfg: Config, d: Design) -> list[str]:
    """The ``[[contact]]`` table: friction, and a search distance beyond the gap."""
    lines = ["[[contact]]", 'name = "pair"', 'slave = "slave_contact"', 'master = "master_contact"']
    lines += [f'friction = "{cfg.friction}"']
    if cfg.friction == "tresca":
        lines += [f"bound = {TRESCA_FRACTION * d.pressure!r}"]
    elif cfg.friction == "coulomb":
        lines += [f"coefficient = {MU!r}"]
    if cfg.gap >= 1.0:
        lines += [f"search_distance = {d.gap + 3 * max(d.h_slave, d.h_master)!r}"]
    return lines


# ----------------------------------------------------------------------------- run and record
#: Tolerances of the checks: force balance (static, relative), energy balance (dynamic,
#: relative to the largest energy), uniform pressure (flat), Hertz (curved; 2D, 3D).
BALANCE_TOL, ENERGY_TOL, UNIFORM_TOL = 1.0e-8, 1.0e-8, 1.0e-6
HERTZ_TOL = {2: 0.08, 3: 0.3}


@dataclass
class Record:
    """What one run of one configuration gave.

    Attributes
    ----------
    config
        The configuration.
    ranks
        Number of MPI ranks of the run.
    status
        ``converged``, ``failed`` (the run's message in ``message``) or ``refused``
        (the scene was refused before solving: exit status 2 of ``bonecontact run``).
    iterations
        PDAS iterations, summed over the steps.
    steps, dofs
        Steps run and degrees of freedom.
    time
        Wall time of the run (s; ``summary.json`` ``wall_time_s``).
    balance, closed_form
        The checks of docs/theory/verification.md#contact-robustness-matrix (NaN where
        none applies).
    outcome
        ``pass``, ``FAIL (...)`` naming the check that failed, ``ill-posed (refused)``
        or ``ill-posed (ran)``.
    message
        The run's message (failed or refused runs).
    touch_ranks
        :func:`touch_ranks`: on how many ranks the first-touch node lies (1 serially).
    contact_force
        The largest normal contact force over the steps (``history.csv``): a run that
        never touches tests no contact and fails.
    pressures
        The slave nodes' coordinates and pressures, rows sorted by coordinates
        (columns x, y(, z), pressure).
    """

    config: Config
    ranks: int
    status: str
    iterations: int = 0
    steps: int = 0
    dofs: int = 0
    time: float = math.nan
    balance: float = math.nan
    closed_form: float = math.nan
    outcome: str = ""
    message: str = ""
    touch_ranks: int = 1
    contact_force: float = math.nan
    pressures: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    def row(self) -> dict:
        """The record as a flat table row (configuration fields first)."""
        out = asdict(self.config)
        out |= {
            "name": self.config.name,
            "ranks": self.ranks,
            "status": self.status,
            "iterations": self.iterations,
            "steps": self.steps,
            "dofs": self.dofs,
            "time_s": round(self.time, 3),
            "balance": f"{self.balance:.2e}",
            "closed_form": f"{self.closed_form:.2e}",
            "outcome": self.outcome,
            "touch_ranks": self.touch_ranks,
            "message": self.message.replace("\n", " ")[:200],
        }
        return out


def run_config(cfg: Config, folder: str | Path, comm: MPI.Comm = MPI.COMM_WORLD) -> Record:
    """Build ``cfg`` in ``folder`` (mesh ``mesh.msh``, scene ``scene.toml``), run it with
    :func:`~bonecontact.runners.dispatch.run_scene` on ``comm`` (results in
    ``folder/results``) and check the results (collective; the same record on every
    rank).  Plausibility warnings (a stiff master reaches moduli beyond bone's) are
    silenced."""
    folder = Path(folder)
    mesh, scene, out = folder / "mesh.msh", folder / "scene.toml", folder / "results"
    d = build_mesh(cfg, mesh, comm)
    if comm.rank == 0:
        scene.write_text(scene_text(cfg, d, mesh.name))
    comm.barrier()
    status, message = "refused", ""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PlausibilityWarning)
        try:
            result = run_scene(load_scene(scene), comm, output=out, progress=False)
            status = result.status
            message = result.summary.get("message", "")
        except SceneError as exc:
            message = str(exc)
    rec = None
    if comm.rank == 0:
        rec = _record(cfg, d, mesh, out, comm.size, status, message)
    rec = comm.bcast(rec, root=0)
    rec.touch_ranks = touch_ranks(cfg, mesh, comm) if comm.size > 1 else 1
    return rec


def touch_ranks(cfg: Config, mesh: Path, comm: MPI.Comm) -> int:
    """On how many ranks the first-touch slave node (the lowest; flat slaves: any node
    of the face) lies when ``mesh`` is distributed over ``comm`` as a run distributes it
    (collective): 2 or more means a partition boundary runs through it."""
    pts = None
    if comm.rank == 0:
        X = read_surface(mesh, "slave_contact", cfg.dim).coords
        pts = X[X[:, 1] <= X[:, 1].min() + 1e-9 * RADIUS]
    pts = comm.bcast(pts, root=0)
    _, md = read_gmsh_mesh(mesh, comm, cfg.dim)
    x = md.mesh.geometry.x[:, : cfg.dim]
    here = np.array([bool((np.linalg.norm(x - p, axis=1) < 1e-12).any()) for p in pts], int)
    return int(comm.allreduce(here, op=MPI.SUM).max())


def _record(
    cfg: Config, d: Design, mesh: Path, out: Path, ranks: int, status: str, message: str
) -> Record:
    """The record of a finished run (rank 0: reads the result files)."""
    rec = Record(cfg, ranks, status, message=message)
    ok, why = cfg.well_posed()
    if status == "refused":
        rec.outcome = "ill-posed (refused)" if not ok else f"FAIL (refused: {message[:80]})"
        return rec
    summary = json.loads((out / "summary.json").read_text())
    rec.time = float(summary.get("wall_time_s", math.nan))
    rec.steps = int(summary.get("steps", 0))
    rec.dofs = int(summary.get("dofs", 0))
    rec.iterations = _pdas_iterations(out)
    if status == "converged":
        table = contact_table(out / "contact_pair.csv", cfg.dim)
        last = _csv(out / "history.csv")[-1]
        rec.pressures = table
        rec.contact_force = max(float(r["normal_force"]) for r in _csv(out / "history.csv"))
        rec.balance = _balance(cfg, d, table, summary, last)
        vertical = float(last.get("reaction_master_bottom_y", "nan"))
        if math.isnan(vertical):
            vertical = _resultant(read_surface(mesh, "slave_contact", cfg.dim), table, cfg.dim)[1]
        rec.closed_form = _closed_form(cfg, d, table, vertical)
    rec.outcome = _outcome(rec) if ok else f"ill-posed ({status})"
    return rec


def _outcome(rec: Record) -> str:
    """``pass`` or ``FAIL (<the check>)``."""
    cfg = rec.config
    if rec.status != "converged":
        return f"FAIL ({rec.status})"
    if not rec.contact_force > 0.0:
        return "FAIL (no contact)"
    tol = ENERGY_TOL if cfg.analysis == "dynamic" else BALANCE_TOL
    if not rec.balance <= tol and not math.isnan(rec.balance):
        return f"FAIL (balance {rec.balance:.1e})"
    cf_tol = HERTZ_TOL[cfg.dim] if cfg.curved else UNIFORM_TOL
    if not rec.closed_form <= cf_tol and not math.isnan(rec.closed_form):
        return f"FAIL (closed form {rec.closed_form:.1e})"
    return "pass"


def _pdas_iterations(out: Path) -> int:
    """PDAS iterations summed over the steps (``history.csv``)."""
    rows = _csv(out / "history.csv")
    return int(sum(int(r["pdas_iterations"]) for r in rows if int(r["step"]) > 0))


def _csv(path: Path) -> list[dict[str, str]]:
    """The rows of a CSV table with a header."""
    with path.open() as fh:
        return list(csv.DictReader(fh))


def contact_table(path: Path, dim: int) -> np.ndarray:
    """Coordinates and pressure of every slave node (last step), sorted by coordinates
    rounded to 1e-9 R (the written coordinates of one node may differ by round-off,
    e.g. 1e-19 m against 0, between runs on different numbers of ranks)."""
    rows = _csv(path)
    keys = ["x", "y", "z"][:dim] + ["pressure"]
    a = np.array([[float(r[k]) for k in keys] for r in rows])
    key = np.round(a[:, :dim] / RADIUS, 9)
    return a[np.lexsort(key.T[::-1])]


def _resultant(surf: Surface, table: np.ndarray, dim: int) -> np.ndarray:
    """The contact force on the slave body, Σ_p w_p λ_p (−n_p) (N or N/m)."""
    key = {tuple(np.round(x / RADIUS, 9)): i for i, x in enumerate(surf.coords)}
    idx = np.array([key[tuple(np.round(x / RADIUS, 9))] for x in table[:, :dim]])
    lam = table[:, dim]
    return -(surf.weights[idx, None] * lam[:, None] * surf.normals[idx]).sum(axis=0)


def _balance(cfg: Config, d: Design, table: np.ndarray, summary: dict, last: dict) -> float:
    """Static runs: the largest of (i) the global equilibrium |R_m + R_s + L| of the
    vertical reactions of ``master_bottom`` and ``slave_top`` and the applied load
    (``history.csv``), (ii) load-driven: |R_m − P| with P the load of the design (the
    traction times the meshed top face), (iii) flat on flat (vertical normals):
    |Σ D λ − R_m| (the pair's ``normal_force``), each over max(|R_m|, P).  Dynamic
    runs: the energy-balance defect over the largest energy.  NaN if the history has
    no reaction columns."""
    if cfg.analysis == "dynamic":
        e = summary.get("energy", {})
        scale = max(abs(float(v)) for k, v in e.items() if k != "defect")
        return abs(float(e.get("defect", math.nan))) / scale if scale > 0 else math.nan
    if "reaction_master_bottom_y" not in last:
        return math.nan
    r_m = float(last["reaction_master_bottom_y"])
    r_s = float(last.get("reaction_slave_top_y", 0.0))
    load = float(last.get("load_y", 0.0))
    scale = max(abs(r_m), d.load, 1e-300)
    errs = [abs(r_m + r_s + load)]
    if cfg.drive == "load":
        errs.append(abs(r_m - d.load))
    if not cfg.curved:
        errs.append(abs(float(last["normal_force"]) - r_m))
    return max(errs) / scale


def _closed_form(cfg: Config, d: Design, table: np.ndarray, vertical: float) -> float:
    """Uniform pressure (flat-on-flat) or Hertz (curved; for the transmitted vertical
    force ``vertical``), static runs; else NaN.  Hertz's solution is frictionless: with
    friction it holds only between bodies of the same material (no coupling of normal
    and tangential tractions); friction between dissimilar curved bodies has none
    (a Tresca bound 0.2 p₀ at contrast 1e4 moves the fitted p₀ by 9 %)."""
    if cfg.analysis != "static" or cfg.shape == "wide_slave":
        return math.nan
    if cfg.curved and cfg.friction != "none" and cfg.contrast != 1.0:
        return math.nan
    lam = table[:, cfg.dim]
    if not cfg.curved:
        p = d.pressure
        active = lam > 0
        return float(np.abs(lam[active] - p).max() / p) if active.any() else math.inf
    P = vertical
    law, nu, E1, E2 = _hertz(cfg.dim), NU_CURVED, E_SLAVE, cfg.contrast * E_SLAVE
    R = d.r_eff
    a_ref = (law.radius if cfg.dim == 3 else law.half_width)(P, R, E1, nu, E2, nu)
    p0_ref = law.peak_pressure(P, R, E1, nu, E2, nu)
    X = table[:, : cfg.dim]
    r = np.hypot(X[:, 0], X[:, 2]) if cfg.dim == 3 else np.abs(X[:, 0])
    sel = r < 0.8 * a_ref
    if sel.sum() < 3:
        return math.inf
    A = np.c_[np.ones(sel.sum()), r[sel] ** 2]
    c0, c1 = np.linalg.lstsq(A, lam[sel] ** 2, rcond=None)[0]
    if c0 <= 0 or c1 >= 0:
        return math.inf
    return float(max(abs(math.sqrt(-c0 / c1) / a_ref - 1), abs(math.sqrt(c0) / p0_ref - 1)))


def same_answer(a: Record, b: Record, tol: float = 1.0e-8) -> float:
    """The largest pressure difference of two runs of one configuration relative to the
    peak pressure (``inf`` if their slave nodes differ); the runs agree when it is at
    most ``tol`` and their PDAS iterations are equal."""
    if a.pressures.shape != b.pressures.shape or a.pressures.size == 0:
        return math.inf
    dim = a.config.dim
    if np.abs(a.pressures[:, :dim] - b.pressures[:, :dim]).max() > 1e-12:
        return math.inf
    peak = max(np.abs(a.pressures[:, dim]).max(), 1e-300)
    return float(np.abs(a.pressures[:, dim] - b.pressures[:, dim]).max() / peak)


def run_matrix(
    configs: Iterable[Config], folder: str | Path, comm: MPI.Comm = MPI.COMM_WORLD
) -> list[Record]:
    """:func:`run_config` for every configuration, each in its own sub-folder."""
    out = []
    for cfg in configs:
        sub = Path(folder) / cfg.name
        if comm.rank == 0:
            sub.mkdir(parents=True, exist_ok=True)
        comm.barrier()
        t0 = time.perf_counter()
        rec = run_config(cfg, sub, comm)
        if math.isnan(rec.time):
            rec.time = time.perf_counter() - t0
        out.append(rec)
    return out


def config_from_name(name: str) -> Config:
    """The configuration named ``name`` (the inverse of :attr:`Config.name`)."""
    p = name.split("-g")
    head, tail = p[0].split("-"), "-g".join(p[1:])
    gap, rest = _split_number(tail)
    fields = rest.split("-")
    cfg = Config(
        dim=int(head[0][0]),
        shape=head[1],
        touch=head[2] if head[2] != "face" else "node",
        gap=gap,
        drive=fields[0],
        contrast=float(fields[1][1:]),
        size_ratio=float(fields[2][1:]),
        friction=fields[3],
        analysis=fields[4],
        supported="unsupported" not in fields[5:],
        fine=next((float(f[1:]) for f in fields[5:] if f.startswith("f")), 1.0),
    )
    if cfg.name != name:
        raise ValueError(f"not a configuration name: {name!r}")
    return cfg


def _split_number(text: str) -> tuple[float, str]:
    """``"-0.1-load-..."`` → ``(-0.1, "load-...")``."""
    start = 1 if text.startswith("-") else 0
    end = text.index("-", start)
    return float(text[:end]), text[end + 1 :]


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m bonecontact.verification.robustness NAME [FOLDER] [--run]``: write the
    mesh and scene of the configuration NAME to FOLDER (default ``robustness/NAME``) and
    print the command that runs it; with ``--run``, run it and print its record."""
    import argparse

    parser = argparse.ArgumentParser(prog="python -m bonecontact.verification.robustness")
    parser.add_argument("name")
    parser.add_argument("folder", nargs="?")
    parser.add_argument("--run", action="store_true")
    args = parser.parse_args(argv)
    cfg = config_from_name(args.name)
    folder = Path(args.folder or Path("robustness") / cfg.name)
    comm = MPI.COMM_WORLD
    if comm.rank == 0:
        folder.mkdir(parents=True, exist_ok=True)
    comm.barrier()
    if args.run:
        rec = run_config(cfg, folder, comm)
        if comm.rank == 0:
            print(json.dumps(rec.row(), indent=1))
        return 0 if rec.outcome == "pass" or rec.outcome.startswith("ill-posed") else 1
    d = build_mesh(cfg, folder / "mesh.msh", comm)
    if comm.rank == 0:
        (folder / "scene.toml").write_text(scene_text(cfg, d, "mesh.msh"))
        print(f"bonecontact run {folder / 'scene.toml'}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
