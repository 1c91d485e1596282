"""K along the front of a surface crack on a curved body: a round bar in tension
(docs/theory/fracture.md#k-on-a-curved-body-a-surface-crack-in-a-round-bar).

A solid round bar, diameter D = 10 mm, length 4D along z (ends z = ±2D), E = 17 GPa,
ν = 0.3, uniform traction S = 1 MPa on the top end; the bottom end slides on u_z = 0, with
u_x = u_y = 0 on a disc of radius D/20 at its centre (no work, no moment: the top end is
free to rotate, the load line is the bar's axis — the *end-free* tension of Shin & Cai
2004).  The crack plane z = 0, the crack centred on the surface point (R, 0, 0), depth a
along −x, half-length c along y (``[[crack]] shape = "semi_elliptical"``): the ellipse is
centred on the bar's surface and its arc inside the bar is the front, as in Carpinteri
(1992) and Shin & Cai (2004).  The scene runs through the package's runner (the scene
TOML in tmp_path; gmsh bar: boundary facets D/5, min(a, c)/5 within 3·max(a, c) of the
crack's centre, so that the mouth lies on the cylinder, not on one flat facet); tip size
min(a, c)/16, K at 13 points from 15° off the front's ends (the runner's 20° patched: at
10° the integration domain leaves the bar near the oblique mouth).

**No published closed form could be read** (2026-12-04): for the fits of Shin & Cai 2004
(Int J Fract 129:239–264), Carpinteri 1992, Raju & Newman 1986 (ASTM STP 905) only
abstracts were found.  Two deepest-point fits were read as transcribed in an open-source
crack-growth program, not in their papers: Murakami & Tsuru 1986 (Murakami's handbook
1987, p. 657), F = (1.122 − 0.230α − 0.901α² + 0.949α³ − 0.280α⁴)(1 + 0.157λ − 0.634λ²
+ 4.590λ³ − 6.628λ⁴), α = a/c, whose λ is a/D in one transcription and a/R (2a/D) in
another; Forman & Shivakumar 1986 (ASTM STP 905), a/c = 1: F = g[0.752 + 2.02 a/D +
0.37(1 − sin β)³], g = 0.92 (2/π) sec β √(tan β/β), β = πa/(2D).  They disagree with each
other by up to 25 % and are not asserted; the package's deepest point (K = F S √(πa)) and
its difference from them:

=========  ======  ======================  ======================  ==================
a/c, a/D   F       M–T, λ = a/D            M–T, λ = a/R            F–S
=========  ======  ======================  ======================  ==================
1, 0.1     0.648   0.669 (−3.1 %)          0.681 (−4.9 %)          0.700 (−7.5 %)
1, 0.2     0.682   0.681 (+0.1 %)          0.716 (−4.8 %)          0.800 (−14.8 %)
1, 0.25    0.723   0.690 (+4.8 %)          0.713 (+1.5 %)          0.875 (−17.4 %)
0.6, 0.2   0.903   0.855 (+5.6 %)          0.899 (+0.4 %)          —
=========  ======  ======================  ======================  ==================

(a/c = 1, a/D = 0.2 on fronts of min(a, c)/24: 0.689.)  The energy check below rules out
the Forman–Shivakumar values for this crack shape: a K 15 % higher everywhere would make
the ratio below about 0.69.

The asserted check is an independent second method that needs no published number, the
**energy release rate**.  At fixed load the strain energy U of the bar grows with the
crack by G per unit of new crack area (Clapeyron: the potential is −U; the support does no
work).  Changing the depth a alone (c fixed) moves the front point P(φ) = C + c cos φ ŷ −
a sin φ x̂ normally by δn with δn ds = c δa sin²φ dφ, so

    dU/da = ∫ G(φ) c sin²φ dφ   over the front's arc φ₀ … π − φ₀ (where P meets the bar),
    G = (1 − ν²)(K_I² + K_II²)/E + (1 + ν) K_III²/E,

with K from the interaction integral at the points, G piecewise linear between them and
held at its end values over the last 15° of the arc (where the sin² weight is small: 2–12
% of the integral; taking G → 0 at the ends instead raises the ratio by 0.7 % (a/D = 0.1)
… 5 % (a/c = 0.6)).  dU/da comes from the strain energy (increment0/history.csv) of
solves at 7 depths a(1 + ε), ε = −15 % … 15 % (a/D = 0.1: 9 depths, ±25 %), c fixed, on
the same bar mesh, by a least-squares quadratic: its residual is the mesh noise, the
jitter of the energy as the crack's mesh changes (for a cubic U(a) the quadratic's slope
is 0.6 % high, ±25 %: 1.7 %).  **This checks a weighted integral of K² along the front, not
K pointwise**: an error of K of one sign along the front shows (twice, in G), one confined
to a few points is diluted.  Linear tetrahedra are stiff: their energy, hence dU/da, comes
out low by a few per cent that shrink with the front's mesh — on a flat block (x ∈ [−D, 0],
|y| ≤ D/2, the same length, ends and crack a = c = 0.2D on its face x = 0), where K_I is
within 1.3 % of Newman–Raju at every point, the ratio is 0.83, 0.915, 0.943 at tip sizes
a/10 (K from 20°), a/16, a/24; the bar's (a/D = 0.2) 0.94, 0.936, 0.942.

Measured (serial, 2026-12-04, tip min(a, c)/16; ratio = (dU/da)/∫G c sin²φ dφ; noise = the
quadratic's rms residual / the energy change over the sweep):

=================  ======  ======  =====  ==========================================
case               dofs    ratio   noise  K symmetry about 90°, |K_II|, |K_III| / K_I
=================  ======  ======  =====  ==========================================
bar 1, 0.1         24126   0.876   1.5 %  ≤ 0.8 %, ≤ 0.5 %
bar 1, 0.2         18867   0.936   0.3 %  ≤ 1.2 %, ≤ 0.6 %
bar 1, 0.25        17628   0.922   0.5 %  ≤ 1.4 %, ≤ 0.7 %
bar 0.6, 0.2       29982   0.898   0.3 %  ≤ 0.9 %, ≤ 0.6 %
block 1, 0.2       22581   0.915   0.8 %  ≤ 0.7 %, ≤ 0.7 %; K_I vs Newman–Raju ≤ 1.3 %
=================  ======  ======  =====  ==========================================

Asserted: the ratio within 0.84 … 1.03 (a uniform K error of +5 % or −6 % would leave it),
the noise below 2 %, K_I symmetric about the deepest point within 2 %, K_II and K_III below
2 % of K_I, F at the deepest point above 0.62 (the half-space's 0.66 less 6 %); the block's
K_I within 3 % of Newman–Raju.  Slow: fronts of min(a, c)/24 (28k–33k dofs), the bar's and
the block's ratios equal within 2.5 % (measured 0.942 and 0.943; serial 102 s) and within
0.92 … 1.0.  The default suite runs one case, the bar a/c = 1, a/D = 0.25 on a sweep of
5 depths (ratio 0.925, noise 0.3 %; serial 19 s, 2 ranks the same to 1e-11); the table's
cases (7–9 solves each, 17k–30k dofs; serial 258 s, 2 ranks 242 s, 3 ranks 300 s on a
loaded 2-core machine, 2026-12-04, all passing) are ``slow``: the suite's time budget.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

from bonecontact.runners import surface_crack3d

sys.path.insert(0, str(Path(__file__).parents[1] / "unit" / "runners"))
from coupled_support import gmsh_on_rank0, read_csv, run_text

D = 10e-3  # bar diameter (m)
R = 0.5 * D
LENGTH = 4.0 * D
PIN = 0.05 * D  # radius of the disc holding u_x = u_y = 0 on the bottom end
E, NU, S = 17.0e9, 0.3, 1.0e6
SPAN, N_DEPTHS = 0.15, 7  # depths a(1 + ε), ε ∈ [−SPAN, SPAN]
POINTS = 13  # K points along the front
PHI_S_DEG = 15.0  # the K points from this far (in φ) off the front's ends (the runner: 20°)

SCENE = """format = 1
[scene]
name = "round_bar"
mesh = "{mesh}"
dimension = 3
[analysis]
kind = "static"
load_steps = 1
[[material]]
name = "bone"
regions = ["bar"]
model = "isotropic"
E = {E}
nu = {nu}
sigma_t = 133e6
[[dirichlet]]
boundary = "bottom"
value = ["free", "free", 0.0]
[[dirichlet]]
boundary = "pin"
value = [0.0, 0.0, 0.0]
[[traction]]
boundary = "top"
value = [0.0, 0.0, {S}]
[fracture]
tip_size = {h}
tip_grading = 0.12
[[crack]]
name = "mouth"
shape = "semi_elliptical"
centre = {centre}
normal = [0.0, 0.0, 1.0]
depth = {a}
half_length = {c}
region = "bar"
front_points = {points}
[output]
fields_every = 0
"""


@dataclass(frozen=True)
class Case:
    """A crack (depth a, half-length c) on the bar (``body = "bar"``) or on the flat face
    x = 0 of a block of the same length (``"block"``: the control)."""

    body: str
    a_c: float
    a_D: float
    tip: float = 16.0  # tip size min(a, c)/tip
    span: float = SPAN  # the sweep's depths a(1 + ε), ε ∈ [−span, span] ...
    depths: int = N_DEPTHS  # ... this many

    @property
    def a(self) -> float:
        return self.a_D * D

    @property
    def c(self) -> float:
        return self.a / self.a_c

    @property
    def centre(self) -> tuple[float, float, float]:
        return (R, 0.0, 0.0) if self.body == "bar" else (0.0, 0.0, 0.0)

    def arc(self, a: float) -> tuple[float, float]:
        """The front's parameter range for depth ``a``: where the ellipse centred on the
        surface, P(φ) = C + c cos φ ŷ − a sin φ x̂, meets the bar's circle (on the flat
        block 0 … π)."""
        if self.body != "bar":
            return 0.0, math.pi
        c = self.c
        g = lambda f: (R - a * math.sin(f)) ** 2 + (c * math.cos(f)) ** 2 - R * R  # noqa: E731
        lo, hi = 1e-12, 0.5 * math.pi  # g(lo) > 0 > g(hi) (R > a)
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if g(mid) > 0 else (lo, mid)
        return lo, math.pi - lo


def _groups(gmsh, z_bottom: float, z_top: float, pin_area: float) -> None:
    occ = gmsh.model.occ
    gmsh.model.addPhysicalGroup(3, [t for _, t in gmsh.model.getEntities(3)], 1, name="bar")
    groups: dict[str, list[int]] = {}
    for _, s in gmsh.model.getEntities(2):
        z = occ.getCenterOfMass(2, s)[2]
        if abs(z - z_bottom) < 1e-9 * D:
            name = "pin" if occ.getMass(2, s) < 1.01 * pin_area else "bottom"
        elif abs(z - z_top) < 1e-9 * D:
            name = "top"
        else:
            name = "side"
        groups.setdefault(name, []).append(s)
    for k, (name, tags) in enumerate(sorted(groups.items()), start=2):
        gmsh.model.addPhysicalGroup(2, tags, k, name=name)


def body_mesh(case: Case):
    """gmsh builder of the bar (or block): groups bar, top, bottom, pin, side; facets D/5,
    min(a, c)/5 within 3·max(a, c) of the crack's centre."""

    def build(gmsh) -> None:
        occ = gmsh.model.occ
        z0 = -0.5 * LENGTH
        if case.body == "bar":
            body = occ.addCylinder(0, 0, z0, 0, 0, LENGTH, R)
            pin = occ.addDisk(0, 0, z0, PIN, PIN)
        else:  # a block D deep (x ∈ [−D, 0]) and D wide, the crack on its face x = 0
            body = occ.addBox(-D, -0.5 * D, z0, D, D, LENGTH)
            pin = occ.addDisk(-0.5 * D, 0, z0, PIN, PIN)
        occ.fragment([(3, body)], [(2, pin)])
        occ.synchronize()
        _groups(gmsh, z0, -z0, math.pi * PIN**2)
        field = gmsh.model.mesh.field
        ball = field.add("Ball")
        for key, value in zip(("XCenter", "YCenter", "ZCenter"), case.centre, strict=True):
            field.setNumber(ball, key, value)
        rad = 3.0 * max(case.a, case.c)
        field.setNumber(ball, "Radius", rad)
        field.setNumber(ball, "Thickness", rad)
        field.setNumber(ball, "VIn", min(case.a, case.c) / 5)
        field.setNumber(ball, "VOut", D / 5)
        field.setAsBackgroundMesh(ball)
        for opt in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints", "MeshSizeFromCurvature"):
            gmsh.option.setNumber(f"Mesh.{opt}", 0)
        gmsh.option.setNumber("Mesh.MeshSizeMax", D / 5)

    return build


def _solve(d: Path, name: str, case: Case, a: float) -> tuple[dict, float]:
    """Run the scene with depth ``a`` (collective): fracture.csv and the strain energy."""
    sub = d / name
    if MPI.COMM_WORLD.rank == 0:
        sub.mkdir(parents=True, exist_ok=True)
    MPI.COMM_WORLD.barrier()
    h = min(a, case.c) / case.tip  # the crack's mesh scales with it
    text = SCENE.format(
        mesh=d / "body.msh",
        E=E,
        nu=NU,
        S=S,
        h=h,
        centre=list(case.centre),
        a=a,
        c=case.c,
        points=POINTS,
    )
    res = run_text(text, sub, sub / "out")
    assert res.status == "converged", res.summary.get("message")
    hist = read_csv(sub / "out" / "increment0" / "history.csv")
    return read_csv(sub / "out" / "fracture.csv"), float(hist["strain_energy"][-1])


@dataclass
class Result:
    case: Case
    phi: np.ndarray
    K: np.ndarray  # (3, n): K_I, K_II, K_III
    depths: np.ndarray
    U: np.ndarray
    dofs: int

    @property
    def G(self) -> np.ndarray:
        KI, KII, KIII = self.K
        return ((1 - NU**2) * (KI**2 + KII**2) + (1 + NU) * KIII**2) / E

    def integral(self) -> float:
        """∫ G c sin²φ dφ over the arc, G piecewise linear between the points and held
        at its end values beyond them."""
        p0, p1 = self.case.arc(self.case.a)
        ff = np.linspace(p0, p1, 4001)
        g = np.interp(ff, self.phi, self.G) * self.case.c * np.sin(ff) ** 2
        return float(np.sum(0.5 * (g[1:] + g[:-1]) * np.diff(ff)))

    def slope(self) -> tuple[float, float]:
        """dU/da at a (least-squares quadratic in the depth) and the fit's residual, rms,
        relative to the energy change over the sweep."""
        x = self.depths - self.case.a
        coef = np.polyfit(x, self.U, 2)
        resid = self.U - np.polyval(coef, x)
        return float(coef[1]), float(np.sqrt(np.mean(resid**2)) / abs(self.U[-1] - self.U[0]))

    def ratio(self) -> float:
        return self.slope()[0] / self.integral()

    def F(self) -> np.ndarray:
        return self.K[0] / (S * math.sqrt(math.pi * self.case.a))


def run_case(d: Path, case: Case) -> Result:
    """The body meshed once; the crack at a (K) and at the sweep's depths (energies)."""
    gmsh_on_rank0(body_mesh(case), d / "body.msh", 3)
    eps = np.linspace(-case.span, case.span, case.depths)
    with pytest.MonkeyPatch.context() as mp:  # K points from 10° off the surface
        mp.setattr(surface_crack3d, "PHI_SURFACE", math.radians(PHI_S_DEG))
        tab, U0 = _solve(d, "a", case, case.a)
    U = []
    for k, e in enumerate(eps):
        U.append(U0 if abs(e) < 1e-12 else _solve(d, f"a{k}", case, case.a * (1 + e))[1])
    summary = json.loads((d / "a" / "out" / "increment0" / "summary.json").read_text())
    K = np.array([tab["K_I"], tab["K_II"], tab["K_III"]])
    phi = np.radians(tab["phi_deg"])
    return Result(case, phi, K, case.a * (1 + eps), np.array(U), int(summary["dofs"]))


_RESULTS: dict[Case, Result] = {}


def result(tmp_path_factory, case: Case) -> Result:
    if case not in _RESULTS:
        comm = MPI.COMM_WORLD
        d = tmp_path_factory.mktemp(f"{case.body}_{case.a_c}_{case.a_D}")
        d = Path(comm.bcast(str(d) if comm.rank == 0 else None))
        _RESULTS[case] = run_case(d, case)
    return _RESULTS[case]


def _newman_raju(case: Case, phi: np.ndarray) -> np.ndarray:
    from bonecontact.verification.surface_crack import surface_crack_k

    return surface_crack_k(S, case.a, case.c, D, 0.5 * D, phi)


def _id(case: Case) -> str:
    return f"{case.body}-ac{case.a_c:g}-aD{case.a_D:g}-tip{case.tip:g}"


#: The bar's cases and the flat block's control, tip size min(a, c)/16.  The default
#: suite runs one bar case on a sweep of 5 depths (6 solves, about 40 s serially); the
#: others, 7–9 depths each, are ``slow`` (the suite's time budget).
CASES = [
    pytest.param(Case("bar", 1.0, 0.25, 16.0, SPAN, 5), id="bar-ac1-aD0.25-tip16-5depths"),
    *(
        pytest.param(c, id=_id(c), marks=pytest.mark.slow)
        for c in (
            Case("bar", 1.0, 0.1, 16.0, 0.25, 9),  # the smallest crack's energy jitters most
            Case("bar", 1.0, 0.25, 16.0),
            Case("bar", 0.6, 0.2, 16.0),
            Case("block", 1.0, 0.2, 16.0),
        )
    ),
]
#: (dU/da)/∫G c sin²φ dφ on the reduced meshes (measured 0.876 … 0.936: the energy of
#: linear tetrahedra is low; an error of K of one sign along the front shows twice in G)
RATIO = (0.84, 1.03)
#: the energy's jitter between the sweep's meshes: the quadratic's residual, rms, relative
#: to the energy change over the sweep (measured 0.3 … 1.5 %)
NOISE = 0.02


@pytest.mark.parametrize("case", CASES)
def test_energy_release_matches_the_front_k(tmp_path_factory, case: Case) -> None:
    """dU/da of the FE strain energy against ∫ G c sin²φ dφ from the front's K, the K
    symmetric about the deepest point, K_II and K_III round-off; on the flat block K_I
    against Newman–Raju too (the control: there the interaction integral is verified)."""
    r = result(tmp_path_factory, case)
    slope, noise = r.slope()
    assert slope > 0.0
    assert noise < NOISE, noise
    assert RATIO[0] < r.ratio() < RATIO[1], r.ratio()
    KI = r.K[0]
    np.testing.assert_allclose(KI, KI[::-1], rtol=0.02)  # the points are symmetric about 90°
    assert np.max(np.abs(r.K[1:])) < 0.02 * np.max(KI)
    deep = int(np.argmin(np.abs(r.phi - 0.5 * math.pi)))
    assert r.phi[deep] == pytest.approx(0.5 * math.pi, abs=1e-9)
    if case.body == "block":
        np.testing.assert_allclose(KI, _newman_raju(case, r.phi), rtol=0.03)
    else:  # deeper in the bar: F = K/(S√(πa)) at the deepest point above the half-space's
        assert r.F()[deep] > 0.62


#: The same check on finer fronts (tip size min(a, c)/24): bar and block alike.
FINE = [Case("bar", 1.0, 0.2, 24.0), Case("block", 1.0, 0.2, 24.0)]


@pytest.mark.slow  # two cases of 7 solves, 28k–33k dofs: about 60 s each serially
def test_bar_and_block_agree_on_finer_fronts(tmp_path_factory) -> None:
    """On fronts of min(a, c)/24 the bar's ratio equals the block's within 1.5 % and both
    lie within 0.92 … 1.0: the bar's K along its curved front is as consistent with its
    energy as the flat block's, whose K_I is within 3 % of Newman–Raju."""
    bar, block = (result(tmp_path_factory, c) for c in FINE)
    assert bar.ratio() == pytest.approx(block.ratio(), rel=0.025)
    for r in (bar, block):
        assert 0.92 < r.ratio() < 1.0, r.ratio()
        assert r.slope()[1] < NOISE
    np.testing.assert_allclose(block.K[0], _newman_raju(FINE[1], block.phi), rtol=0.03)
