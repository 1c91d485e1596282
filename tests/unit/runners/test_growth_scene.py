"""Growth-only neoplasm scenes: ``[neoplasm]`` validation through the
``bonecontact`` command, ``growth.csv`` against independent references, and the same
``growth.csv`` on 1 and 2 ranks.

Most tests call the command's entry point in-process (``bonecontact.runners.cli.main``), so they
are collective and run in the serial and the MPI sessions; the ones marked ``serial``
spawn ``bonecontact`` / ``mpiexec`` themselves.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from cli_support import ENV as BASE_ENV
from cli_support import run_scene
from scipy.integrate import solve_ivp
from scipy.special import iv

from bonecontact.common.constants import R_GAS, SECONDS_PER_YEAR
from bonecontact.runners.cli import main
from bonecontact.scene.expressions import ExpressionError, parse_rate

#: growth tests: the 2-rank session and the serial one run them; the 3-rank session
#: leaves them to the tests that spawn 3 ranks (make test-all runs them on 3 ranks too)
pytestmark = pytest.mark.growth

ROOT = Path(__file__).resolve().parents[3]
ENV = {**BASE_ENV, "PYTHONWARNINGS": "ignore"}
YEAR = SECONDS_PER_YEAR

# a meshless 2D tumour (Byrne-Chaplain reduction, lengths in units of sqrt(D_c/lambda) = 1)
TUMOUR = """format = 1
[scene]
name = "tumour"
dimension = 2

[neoplasm]
kind = "tumour"
radius = 1.0
h = 0.25
t_end = 3.0
dt = 0.2

[neoplasm.tumour]
D_c = 1.0
lambda = 1.0
eps0 = 0.0
u_c1 = 1.0
K_B = "1.0*(u_c - 0.5)"
K_Q = 0.0
K_R = 0.0
gamma = 0.0
u_p0 = 1.0
u_q0 = 0.0

[output]
directory = "{out}"
"""

CYST = """format = 1
[scene]
name = "cyst"
dimension = {dim}

[neoplasm]
kind = "cyst"
radius = 2.0e-3
t_end = {t_end}
dt = {dt}

[neoplasm.cyst]
model = "sphere"
strain = "log"
beta = {beta}
C_minus = 1.0
temperature = 310.0
E = 1.0e6
viscosity = {viscosity}
f0 = {f0}

[output]
directory = "{out}"
"""

# the tumour starts as the cell group "tumour" (a disc of radius 1) of a 4 x 4 square mesh
REGION = """format = 1
[scene]
name = "region"
mesh = "{mesh}"
dimension = 2

[neoplasm]
kind = "tumour"
region = "tumour"
host = ["bone"]
t_end = 1.0
dt = 0.25

[neoplasm.tumour]
K_B = "1.0*(u_c - 0.5)"
K_Q = 0.2
K_R = 0.1
u_p0 = 0.9

[output]
directory = "{out}"
"""


def _disc_in_square(path: Path, R: float = 1.0, L: float = 4.0, h: float = 0.25) -> None:
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("disc_in_square")
        occ = gmsh.model.occ
        square = occ.addRectangle(-L / 2, -L / 2, 0, L, L)
        disc = occ.addDisk(0, 0, 0, R, R)
        out, mapping = occ.fragment([(2, square)], [(2, disc)])
        occ.synchronize()
        tumour = [t for _, t in mapping[1]]
        gmsh.model.addPhysicalGroup(2, tumour, 1, name="tumour")
        gmsh.model.addPhysicalGroup(2, [t for _, t in out if t not in tumour], 2, name="bone")
        edges = gmsh.model.getBoundary([(2, t) for t in tumour], oriented=False)
        gmsh.model.addPhysicalGroup(1, [abs(t) for _, t in edges], 3, name="rim")
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


@pytest.fixture(scope="module")
def shared_dir():
    """A directory with the same path on every rank, holding the disc-in-square mesh."""
    import shutil
    import tempfile

    comm = MPI.COMM_WORLD
    path = Path(
        comm.bcast(tempfile.mkdtemp(prefix="bc-growth-") if comm.rank == 0 else None, root=0)
    )
    if comm.rank == 0:
        _disc_in_square(path / "disc.msh")
    comm.barrier()
    yield path
    comm.barrier()
    if comm.rank == 0:
        shutil.rmtree(path, ignore_errors=True)


def _write(directory: Path, name: str, text: str) -> Path:
    comm = MPI.COMM_WORLD
    path = directory / name
    if comm.rank == 0:
        path.write_text(text)
    comm.barrier()
    return path


def _read_growth(path: Path) -> tuple[list[str], np.ndarray]:
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], np.array(rows[1:], dtype=float)


def _sub(old: str, new: str):
    def edit(src: str) -> str:
        assert old in src, f"test set-up: {old!r} not in the scene"
        return src.replace(old, new, 1)

    return edit


# --------------------------------------------------------------------------------------
# validation: exit status 2, one message naming the file, table and key
# --------------------------------------------------------------------------------------
# (id, base scene, edit, key, words the message must contain)
T, C, M = "tumour", "cyst", "region"
INVALID = [
    # [neoplasm]
    ("kind-value", T, _sub('kind = "tumour"', 'kind = "sarcoma"'), "kind", ['"tumour", "cyst"']),
    ("kind-missing", T, _sub('kind = "tumour"\n', ""), "kind", ["missing"]),
    (
        "unknown-key",
        T,
        _sub("dt = 0.2", "dt = 0.2\nspeed = 2.0"),
        "speed",
        ["allowed: kind, region"],
    ),
    ("t_end-positive", T, _sub("t_end = 3.0", "t_end = 0.0"), "t_end", ["> 0"]),
    ("dt-le-t_end", T, _sub("dt = 0.2", "dt = 5.0"), "dt", ["<= t_end"]),
    ("dt-string", T, _sub("dt = 0.2", 'dt = "0.2 s"'), "dt", ["number"]),
    (
        "remesh_every-float",
        T,
        _sub("dt = 0.2", "dt = 0.2\nremesh_every = 1.0"),
        "remesh_every",
        ["integer"],
    ),
    (
        "remesh_every-negative",
        T,
        _sub("dt = 0.2", "dt = 0.2\nremesh_every = -1"),
        "remesh_every",
        [">= 0"],
    ),
    (
        "mechanics_every-no-analysis",
        T,
        _sub("dt = 0.2", "dt = 0.2\nmechanics_every = 2"),
        "mechanics_every",
        ["[analysis]"],
    ),
    ("radius-missing", T, _sub("radius = 1.0\n", ""), "radius", ["missing", "without a mesh"]),
    ("radius-negative", T, _sub("radius = 1.0", "radius = -1.0"), "radius", ["> 0"]),
    ("h-negative", T, _sub("h = 0.25", "h = 0.0"), "h", ["> 0"]),
    ("region-without-mesh", T, _sub("radius = 1.0", 'region = "tumour"'), "region", ["no mesh"]),
    ("host-without-mesh", T, _sub("h = 0.25", 'h = 0.25\nhost = ["bone"]'), "host", ["no mesh"]),
    ("host-not-array", T, _sub("h = 0.25", 'h = 0.25\nhost = "bone"'), "host", ['host = ["bone"]']),
    ("h-for-cyst", C, _sub("radius = 2.0e-3", "radius = 2.0e-3\nh = 1e-4"), "h", ["cyst"]),
    (
        "wrong-subtable",
        T,
        _sub("[output]", "[neoplasm.cyst]\nbeta = 1e-11\nC_minus = 1.0\n\n[output]"),
        "cyst",
        ['kind = "tumour"'],
    ),
    ("gamma-dt-limit", T, _sub("gamma = 0.0", "gamma = 0.1"), "dt", ["surface-tension limit"]),
    # [neoplasm.tumour]
    ("tumour-unknown-key", T, _sub("K_Q = 0.0", "K_X = 0.0"), "K_X", ["allowed: D_c, lambda"]),
    ("tumour-D_c-positive", T, _sub("D_c = 1.0", "D_c = 0.0"), "D_c", ["> 0"]),
    ("tumour-lambda-type", T, _sub("lambda = 1.0", "lambda = true"), "lambda", ["boolean"]),
    ("tumour-gamma-negative", T, _sub("gamma = 0.0", "gamma = -0.1"), "gamma", [">= 0"]),
    ("tumour-fractions", T, _sub("u_q0 = 0.0", "u_q0 = 0.5"), "u_q0", ["u_p0 + u_q0 <= 1"]),
    ("tumour-K_R-expression", T, _sub("K_R = 0.0", 'K_R = "u_c"'), "K_R", ["number"]),
    ("tumour-rate-bool", T, _sub("K_Q = 0.0", "K_Q = false"), "K_Q", ["expression string of u_c"]),
    (
        "rate-injection",
        T,
        _sub('K_B = "1.0*(u_c - 0.5)"', "K_B = \"__import__('os').system('true')\""),
        "K_B",
        ["__import__", "not allowed"],
    ),
    (
        "rate-attribute",
        T,
        _sub('K_B = "1.0*(u_c - 0.5)"', 'K_B = "u_c.__class__"'),
        "K_B",
        ["not allowed"],
    ),
    ("rate-caret", T, _sub('K_B = "1.0*(u_c - 0.5)"', 'K_B = "u_c^2"'), "K_B", ["**"]),
    ("rate-unknown-name", T, _sub('K_B = "1.0*(u_c - 0.5)"', 'K_B = "2*c"'), "K_B", ['"c"', "u_c"]),
    ("rate-syntax", T, _sub('K_B = "1.0*(u_c - 0.5)"', 'K_B = "2*(u_c"'), "K_B", ["cannot parse"]),
    ("rate-arity", T, _sub('K_B = "1.0*(u_c - 0.5)"', 'K_B = "max(u_c)"'), "K_B", ["2 arguments"]),
    ("rate-domain", T, _sub('K_B = "1.0*(u_c - 0.5)"', 'K_B = "log(u_c - 1)"'), "K_B", ["u_c1"]),
    # [neoplasm.cyst]
    (
        "cyst-model-value",
        C,
        _sub('model = "sphere"', 'model = "ellipsoid"'),
        "model",
        ['"sphere", "shape"'],
    ),
    (
        "cyst-strain-value",
        C,
        _sub('strain = "log"', 'strain = "green"'),
        "strain",
        ['"log", "engineering"'],
    ),
    ("cyst-beta-negative", C, _sub("beta = {beta}", "beta = -1e-11"), "beta", [">= 0"]),
    ("cyst-beta-missing", C, _sub("beta = {beta}\n", ""), "beta", ["missing"]),
    ("cyst-C_minus-zero", C, _sub("C_minus = 1.0", "C_minus = 0.0"), "C_minus", ["> 0"]),
    (
        "cyst-viscosity-string",
        C,
        _sub("viscosity = {viscosity}", 'viscosity = "high"'),
        "viscosity",
        ["number"],
    ),
    ("cyst-f0-too-negative", C, _sub("f0 = {f0}", "f0 = -1.0e4"), "f0", ["osmolarity"]),
    (
        "cyst-unknown-key",
        C,
        _sub("f0 = {f0}", "f0 = {f0}\nalpha = 3.0"),
        "alpha",
        ["allowed: model, strain"],
    ),
    # growth-only scenes have no mechanics
    (
        "growth-only-material",
        T,
        _sub(
            "[output]",
            '[[material]]\nname = "m"\nregions = ["b"]\nmodel = "isotropic"\n'
            "E = 1e9\nnu = 0.3\n\n[output]",
        ),
        None,
        ["[[material]]", "growth-only"],
    ),
    (
        "growth-only-probes",
        T,
        _sub('directory = "{out}"', 'directory = "{out}"\nprobes = [[0.0, 0.0]]'),
        "probes",
        ["growth.csv"],
    ),
    # coupled scenes (bonecontact.runners.coupled): the tumour region needs its (near-fluid)
    # material
    (
        "coupled-tumour-no-material",
        M,
        _sub(
            "[neoplasm]",
            '[analysis]\nkind = "static"\n\n[[material]]\nname = "m"\n'
            'regions = ["bone"]\nmodel = "isotropic"\nE = 1e9\nnu = 0.3\n'
            "\n[neoplasm]",
        ),
        "regions",
        ['"tumour"', "no material"],
    ),
    # checks against the mesh
    (
        "region-unknown",
        M,
        _sub('region = "tumour"', 'region = "marrow"'),
        "region",
        ['"marrow"', '"tumour"'],
    ),
    (
        "region-facet-group",
        M,
        _sub('region = "tumour"', 'region = "rim"'),
        "region",
        ["facet group"],
    ),
    (
        "host-is-region",
        M,
        _sub('host = ["bone"]', 'host = ["bone", "tumour"]'),
        "host",
        ["neoplasm region"],
    ),
    ("radius-with-mesh", M, _sub("dt = 0.25", "dt = 0.25\nradius = 1.0"), "radius", ['"region"']),
]

BASES = {T: TUMOUR, C: CYST, M: REGION}
CYST_DEFAULTS = {
    "dim": 3,
    "t_end": YEAR,
    "dt": YEAR / 12,
    "beta": 3.2e-11,
    "f0": 0.0,
    "viscosity": 1.0e9,
}


def _scene_text(base: str, edit, out: Path, mesh: Path) -> str:
    src = edit(BASES[base]) if edit is not None else BASES[base]
    return src.format(out=out, mesh=mesh, **CYST_DEFAULTS)


@pytest.mark.parametrize("case", INVALID, ids=lambda c: c[0])
def test_invalid_neoplasm_input_exit_2(case, shared_dir, capsys):
    name, base, edit, key, words = case
    out = shared_dir / f"out-{name}"
    scene = _write(shared_dir, "scene.toml", _scene_text(base, edit, out, shared_dir / "disc.msh"))
    assert main(["run", str(scene), "-q"]) == 2
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        assert err.count("error:") == 1 and "scene.toml" in err, err
        if key is not None:
            assert f'key "{key}"' in err, err
        for w in words:
            assert w in err, f"{w!r} not in: {err}"
        assert "Traceback" not in err
    assert not out.exists()


def test_example_scenes_check(capsys):
    """The shipped example scenes are valid (``bonecontact check``)."""
    for name in ("tumour_growth_2d.toml", "cyst_radicular.toml"):
        assert main(["check", str(ROOT / "data" / "scenes" / name)]) == 0
    if MPI.COMM_WORLD.rank == 0:
        assert capsys.readouterr().out.count(": ok (") == 2


@pytest.mark.serial
@pytest.mark.parametrize("nproc", [1, 2])
def test_invalid_input_real_command(tmp_path, nproc):
    """The installed command (also under mpiexec -n 2): exit 2 on a bad cyst strain and a bad
    rate."""
    for base, edit, words in [
        (C, _sub('strain = "log"', 'strain = "green"'), ['key "strain"', '"engineering"']),
        (T, _sub('K_B = "1.0*(u_c - 0.5)"', 'K_B = "exp(u_c"'), ['key "K_B"']),
    ]:
        out = tmp_path / "out"
        scene = tmp_path / "scene.toml"
        scene.write_text(_scene_text(base, edit, out, tmp_path / "none.msh"))
        res = run_scene(scene, None, nproc, timeout=120, env=ENV)
        assert res.returncode == 2, res.stdout + res.stderr
        assert res.stderr.count("error:") == 1 and "[neoplasm." in res.stderr, res.stderr
        for w in words:
            assert w in res.stderr, res.stderr
        assert not out.exists()


# --------------------------------------------------------------------------------------
# rate expressions
# --------------------------------------------------------------------------------------
def test_rate_expressions_numbers():
    assert parse_rate("2.0*(u_c - 0.7)")(1.0) == pytest.approx(0.6, rel=1e-15)
    assert parse_rate("0.5*pos(0.4 - u_c)")(0.2) == pytest.approx(0.1, rel=1e-15)
    assert parse_rate("0.5*pos(0.4 - u_c)")(0.6) == 0.0
    assert parse_rate("exp(-u_c**2) + max(u_c, 0.3) - min(u_c, 0.3) + abs(-u_c)")(
        0.5
    ) == pytest.approx(math.exp(-0.25) + 0.5 - 0.3 + 0.5, rel=1e-15)
    assert parse_rate("sqrt(u_c)*log(e) + 0*pi")(0.25) == pytest.approx(0.5, rel=1e-15)
    assert not parse_rate("3").depends_on_u_c
    for bad in [
        "u_c if u_c else 1",
        "open('x')",
        "[u_c]",
        "u_c < 1",
        "'1'",
        "True",
        "lambda: 1",
        "u_c; 1",
    ]:
        with pytest.raises(ExpressionError):
            parse_rate(bad)


# --------------------------------------------------------------------------------------
# cyst: growth.csv against the closed-form limits of docs/theory/growth.md#cyst-model
# --------------------------------------------------------------------------------------
def _run_cyst(directory: Path, name: str, **kw) -> tuple[list[str], np.ndarray, dict]:
    import json

    out = directory / f"out-{name}"
    scene = _write(directory, f"{name}.toml", CYST.format(out=out, **{**CYST_DEFAULTS, **kw}))
    assert main(["run", str(scene), "-q"]) == 0
    return (*_read_growth(out / "growth.csv"), json.loads((out / "summary.json").read_text()))


def test_cyst_beta_zero_limit(shared_dir):
    """β = 0: the osmotic excess is spent, R → R0 (1 + f0/(R_g T C⁻))^(1/3), to 1e-6."""
    f0, R0, T_ = 500.0, 2.0e-3, 310.0
    header, g, summary = _run_cyst(
        shared_dir, "beta0", beta=0.0, f0=f0, t_end=200 * YEAR, dt=10 * YEAR
    )
    assert header == ["time", "volume", "surface_area", "equivalent_radius", "pressure"]
    assert len(g) == 21 and g[0, 0] == 0.0 and g[-1, 0] == pytest.approx(200 * YEAR, rel=1e-15)
    R_inf = R0 * (1.0 + f0 / (R_GAS * T_ * 1.0)) ** (1.0 / 3.0)
    assert g[-1, 3] == pytest.approx(R_inf, rel=1e-6, abs=0)
    assert abs(g[-1, 4]) < 1e-6 * f0 and g[0, 4] == f0
    assert g[-1, 3] > 1.05 * R0  # it did grow
    np.testing.assert_allclose(g[:, 1], 4 / 3 * np.pi * g[:, 3] ** 3, rtol=1e-14)
    np.testing.assert_allclose(g[:, 2], 4 * np.pi * g[:, 3] ** 2, rtol=1e-14)
    gr = summary["growth"]
    assert summary["status"] == "converged" and gr["steps"] == 20 and gr["final_radius"] == g[-1, 3]


@pytest.mark.parametrize("dim", [2, 3])
def test_cyst_long_time_rate(shared_dir, dim):
    """Log strain: dR/dt → β/C⁻ (linear growth), to 1e-6 relative; in 2D the columns are
    area, perimeter and sqrt(A/π).

    The rate approaches β/C⁻ algebraically, with a relative deviation of about
    f/(R_g T C⁻) ≈ βν/(R_g T C⁻² R) (see the next test), so a soft surrounding
    (ν = 1e5 Pa s) is used to reach 1e-6 within 20 years.
    """
    beta = 3.2e-11
    _, g, _ = _run_cyst(
        shared_dir, f"rate{dim}", dim=dim, beta=beta, viscosity=1.0e5, t_end=20 * YEAR, dt=YEAR
    )
    rate = (g[-1, 3] - g[-2, 3]) / (g[-1, 0] - g[-2, 0])
    assert rate == pytest.approx(beta / 1.0, rel=1e-6, abs=0)
    if dim == 2:
        np.testing.assert_allclose(g[:, 1], np.pi * g[:, 3] ** 2, rtol=1e-14)
        np.testing.assert_allclose(g[:, 2], 2 * np.pi * g[:, 3], rtol=1e-14)


def test_cyst_radicular_approach(shared_dir):
    """Radicular parameters (ν = 1e9 Pa s), 200 years: the excess pressure decays like
    f = βν/(C⁻R − 3τβ) (τ = ν/E), and the rate is β/C⁻ (≈ 1 mm/year) up to the
    predicted relative deficit ≈ f/(R_g T C⁻)."""
    beta, nu, E, C = 3.2e-11, 1.0e9, 1.0e6, 1.0
    _, g, _ = _run_cyst(shared_dir, "radicular", beta=beta, t_end=200 * YEAR, dt=YEAR)
    R, f = g[-1, 3], g[-1, 4]
    assert f == pytest.approx(beta * nu / (C * R - 3 * (nu / E) * beta), rel=1e-4, abs=0)
    rate = (g[-1, 3] - g[-2, 3]) / (g[-1, 0] - g[-2, 0])
    deficit = 1.0 - rate / (beta / C)
    assert 0.0 < deficit < 2.0 * f / (R_GAS * 310.0 * C)
    assert rate * 1e3 * YEAR == pytest.approx(1.01, abs=0.01)  # mm per year


# --------------------------------------------------------------------------------------
# tumour: R(t) of growth.csv against the radius ODE (docs/theory/growth.md#tumour-model)
# --------------------------------------------------------------------------------------
#: The phases of a tumour growth step in summary.json (TumourModel.timer).
TUMOUR_STEP_PHASES = (
    "nutrient",
    "curvature",
    "pressure",
    "velocity",
    "extension",
    "transport",
    "move",
    "reaction",
    "gmsh",
    "setup",
    "transfer",
)


@pytest.mark.serial
def test_tumour_growth_matches_radius_ode(shared_dir):
    """Quasi-steady, u_p = 1, K_B = μ(u_c − ũ): dR/dt = μ[I1(R)/I0(R) − ũR/2] within 1 %.

    Serial session only (a long verification case): the growth run on 2 ranks is
    test_growth_csv_same_on_1_and_2_ranks."""
    import json

    out = shared_dir / "out-tumour"
    scene = _write(shared_dir, "tumour.toml", TUMOUR.format(out=out))
    assert main(["run", str(scene), "-q"]) == 0
    header, g = _read_growth(out / "growth.csv")
    assert header == ["time", "volume", "surface_area", "equivalent_radius"]
    t, R = g[:, 0], g[:, 3]
    assert len(t) == 16 and t[-1] == pytest.approx(3.0, rel=1e-14)
    mu, ut = 1.0, 0.5
    ode = solve_ivp(
        lambda _, r: mu * (iv(1, r) / iv(0, r) - ut * r / 2),
        (0, t[-1]),
        [R[0]],
        t_eval=t,
        rtol=1e-11,
        atol=1e-12,
    )
    err = np.max(np.abs(R / ode.y[0] - 1))
    assert err < 0.01, err
    assert R[-1] > 1.4 * R[0]
    np.testing.assert_allclose(R, np.sqrt(g[:, 1] / np.pi), rtol=1e-14)
    np.testing.assert_allclose(g[:, 2], 2 * np.pi * R, rtol=0.01)  # still a circle (perimeter)
    s = json.loads((out / "summary.json").read_text())
    assert s["growth"]["steps"] == 15 and s["growth"]["remeshes"] == 15
    assert s["growth"]["final_radius"] == R[-1]
    b = np.loadtxt(out / "boundary.csv", delimiter=",", skiprows=1)
    assert np.max(np.abs(np.linalg.norm(b, axis=1) / R[-1] - 1)) < 0.01
    # where the run spent its time: the run's phases (timed one after the other) fit in
    # the wall time, and the tumour's step phases (15 steps, each remeshed) split the steps.
    # Each entry is the slowest rank's: one phase never exceeds the whole it is part of; the
    # sums are exact on one rank only (on several, rank 1 waits in "setup" while rank 0
    # runs gmsh, so the waiting counts in two phases' maxima)
    phases = s["phases_s"]
    run, steps = {"model", "growth_steps", "output"}, set(TUMOUR_STEP_PHASES)
    assert set(phases) == run | steps and all(phases[k] > 0.0 for k in run)
    assert all(phases[k] <= s["wall_time_s"] for k in run)
    assert all(phases[k] <= phases["growth_steps"] for k in steps)
    if MPI.COMM_WORLD.size == 1:
        assert sum(phases[k] for k in run) <= s["wall_time_s"]
        assert sum(phases[k] for k in steps) <= phases["growth_steps"]


@pytest.mark.serial
def test_growth_csv_same_on_1_and_2_ranks(tmp_path):
    """A tumour started from the mesh region "tumour" (non-trivial rates, quiescent cells),
    12 steps, each with a remesh: growth.csv on 2 ranks equals the serial file to
    round-off (measured 1.2e-15 relative, asserted 1e-12).  Without the snapped, canonical
    remesh input the files were 1.2e-12 apart from the tenth remesh on: gmsh meshed the
    boundaries, round-off apart, differently."""
    _disc_in_square(tmp_path / "disc.msh")
    outs = {}
    for n in (1, 2):
        out = tmp_path / f"out{n}"
        scene = tmp_path / f"region{n}.toml"
        text = _sub("t_end = 1.0", "t_end = 3.0")(REGION)
        scene.write_text(text.format(mesh=tmp_path / "disc.msh", out=out))
        res = run_scene(scene, None, n, timeout=300, env=ENV)
        assert res.returncode == 0, res.stderr
        outs[n] = _read_growth(out / "growth.csv")
    (h1, g1), (h2, g2) = outs[1], outs[2]
    assert h1 == h2 and g1.shape == g2.shape == (13, 4)
    np.testing.assert_allclose(g2, g1, rtol=1e-12, atol=0)
    # the region's disc (radius 1, h = 0.25) is the initial tumour, and it grows
    assert g1[0, 3] == pytest.approx(1.0, rel=0.01) and g1[-1, 3] > 1.05 * g1[0, 3]


TUMOUR3D = """format = 1
[scene]
name = "tumour3d"
dimension = 3

[neoplasm]
kind = "tumour"
radius = 1.0
h = 0.45
t_end = 0.6
dt = 0.2
remesh_every = 1

[neoplasm.tumour]
K_B = "1.0*(u_c - 0.5)"
K_Q = 0.2
K_R = 0.1
u_p0 = 0.9

[output]
directory = "{out}"
"""


def _read_points(path: Path) -> np.ndarray:
    return np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def _tumour3d(folder: Path, n: int) -> Path:
    out = folder / f"out{n}"
    scene = folder / f"tumour3d_{n}.toml"
    scene.write_text(TUMOUR3D.format(out=out))
    res = run_scene(scene, None, n, timeout=600, env=ENV)
    assert res.returncode == 0, res.stderr
    return out


@pytest.fixture(scope="module")
def tumour3d_serial(tmp_path_factory) -> Path:
    return _tumour3d(tmp_path_factory.mktemp("tumour3d"), 1)


@pytest.mark.serial
@pytest.mark.parametrize("n", [2, pytest.param(3, marks=pytest.mark.slow)])
def test_growth_3d_same_on_ranks(tumour3d_serial, tmp_path, n):
    """A 3D tumour (non-trivial rates), 3 steps, each remeshed by gmsh from the moved
    surface: growth.csv and the final surface on 2 and 3 ranks equal the serial ones to
    1e-10 (the surface reaches gmsh keyed by input node numbers, in a canonical order and
    snapped to a grid: the same mesh; measured 7e-16)."""
    outs = {1: tumour3d_serial, n: _tumour3d(tmp_path, n)}
    (h1, g1), (hn, gn) = (_read_growth(outs[k] / "growth.csv") for k in (1, n))
    assert h1 == hn and g1.shape == gn.shape == (4, 4)
    np.testing.assert_allclose(gn, g1, rtol=1e-10, atol=0)
    b1, bn = (_read_points(outs[k] / "boundary.csv") for k in (1, n))
    assert b1.shape == bn.shape and b1.shape[1] == 3
    np.testing.assert_allclose(bn, b1, rtol=0, atol=1e-10 * np.abs(b1).max())
    assert g1[-1, 3] != g1[0, 3]  # it grows (or shrinks): the comparison is not trivial


def test_failed_growth_step_exit_1_rows_kept(shared_dir, monkeypatch):
    """A growth step that raises (e.g. gmsh cannot remesh): exit 1, status "failed" with the
    step in the message, and the rows of the steps done are in growth.csv."""
    import json

    from bonecontact.neoplasm import growth

    step = growth.TumourGrowth.step

    def failing(self, dt):
        if self.steps == 2:
            raise RuntimeError("simulated remesh failure")
        step(self, dt)

    monkeypatch.setattr(growth.TumourGrowth, "step", failing)
    out = shared_dir / "out-fail"
    scene = _write(shared_dir, "fail.toml", TUMOUR.format(out=out))
    assert main(["run", str(scene), "-q"]) == 1
    _, g = _read_growth(out / "growth.csv")
    np.testing.assert_allclose(g[:, 0], [0.0, 0.2, 0.4], rtol=1e-14)
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "failed" and s["growth"]["steps"] == 2
    assert "growth step 3" in s["message"] and "simulated remesh failure" in s["message"]
    assert s["growth"]["final_radius"] == g[-1, 3]


def test_remesh_failure_after_retries_keeps_the_last_checkpoint(shared_dir, monkeypatch):
    """gmsh fails on every remesh from growth step 3 on (injected: every call of
    ``remesh.polygon_mesh`` raises RemeshError on every rank, as a gmsh error broadcast
    from rank 0 does): the remesh is tried with the moved boundary, the smoothed one and
    the smoothed one at half the size, then the run stops: exit 1, status "failed", the
    message names the step and the three attempts; growth.csv holds the rows of steps
    0-2, the checkpoint of step 2 is intact and continues, without the fault, to the rows
    of an uninterrupted run (to 1e-10)."""
    import json

    from bonecontact.neoplasm import growth, remesh

    text = TUMOUR.replace("t_end = 3.0", "t_end = 1.0").replace(
        'directory = "{out}"', 'directory = "{out}"\ncheckpoint_every = 1'
    )
    ref = shared_dir / "out-remesh-ref"
    assert main(["run", str(_write(shared_dir, "ref.toml", text.format(out=ref))), "-q"]) == 0
    out = shared_dir / "out-remesh-fail"
    scene = _write(shared_dir, "remesh_fail.toml", text.format(out=out))

    attempts = []
    real_polygon, real_step = remesh.polygon_mesh, growth.TumourGrowth.step

    def polygon_mesh(points, h, comm):
        if armed:
            attempts.append(h)
            raise remesh.RemeshError("injected: gmsh could not mesh the curve")
        return real_polygon(points, h, comm)

    def step(self, dt):
        nonlocal armed
        armed = self.steps == 2
        real_step(self, dt)

    armed = False
    monkeypatch.setattr(remesh, "polygon_mesh", polygon_mesh)
    monkeypatch.setattr(growth.TumourGrowth, "step", step)
    assert main(["run", str(scene), "-q"]) == 1
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "failed" and s["growth"]["steps"] == 2
    assert "growth step 3" in s["message"] and "gmsh failed 3 times" in s["message"]
    assert "smoothed boundary, size × 0.5" in s["message"]
    assert attempts == [0.25, 0.25, 0.125]  # the size of each attempt (h = 0.25)
    _, g = _read_growth(out / "growth.csv")
    np.testing.assert_allclose(g[:, 0], [0.0, 0.2, 0.4], rtol=1e-14)
    ckpts = sorted(p.name for p in (out / "checkpoints").iterdir())
    assert ckpts == ["step_00000001", "step_00000002"]

    monkeypatch.undo()
    assert main(["run", str(scene), "-q", "--restart"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "converged" and s["restarted_from"]["step"] == 2
    (_, g), (_, gr) = _read_growth(out / "growth.csv"), _read_growth(ref / "growth.csv")
    assert g.shape == gr.shape == (6, 4)
    np.testing.assert_allclose(g, gr, rtol=1e-10, atol=0)


CYST_RESTART = """format = 1
[scene]
name = "cyst_restart"
dimension = 2

[neoplasm]
kind = "cyst"
radius = 2.0e-3
t_end = {t_end!r}
dt = {dt!r}
remesh_every = 2

[neoplasm.cyst]
model = "{model}"
strain = "log"
beta = 3.2e-11
C_minus = 1.0

[output]
directory = "{out}"
checkpoint_every = 2
"""


@pytest.mark.parametrize("model", ["sphere", "shape"])
def test_cyst_restart_equals_uninterrupted(shared_dir, model):
    """A cyst run stopped after step 5 (checkpoints of steps 4 and 5 kept) and continued
    from step 4 to step 8 gives growth.csv (pressure included) of the uninterrupted
    8-step run to 1e-10, every row once; remesh counts and final pressure equal.  The
    ODE cyst's checkpoint holds (R, f); the moving-wall cyst's the wall mesh, its last
    wall velocity and the strain and size references."""
    import json

    dt = YEAR / 12
    text = CYST_RESTART.replace("{model}", model)
    ref, out = shared_dir / f"cyst-{model}-ref", shared_dir / f"cyst-{model}-out"
    full = _write(shared_dir, f"cyst_{model}.toml", text.format(t_end=8 * dt, dt=dt, out=ref))
    assert main(["run", str(full), "-q"]) == 0
    short = _write(shared_dir, f"cyst_{model}_5.toml", text.format(t_end=5 * dt, dt=dt, out=out))
    assert main(["run", str(short), "-q"]) == 0
    names = sorted(p.name for p in (out / "checkpoints").iterdir())
    assert names == ["step_00000004", "step_00000005"]
    cont = _write(shared_dir, f"cyst_{model}_cont.toml", text.format(t_end=8 * dt, dt=dt, out=out))
    ckpt = out / "checkpoints" / "step_00000004"
    assert main(["run", str(cont), "-q", "--restart", str(ckpt)]) == 0
    (h1, g1), (h2, g2) = _read_growth(ref / "growth.csv"), _read_growth(out / "growth.csv")
    assert h1 == h2 and h1[-1] == "pressure" and g1.shape == g2.shape == (9, 5)
    np.testing.assert_allclose(g2, g1, rtol=1e-10, atol=0)
    assert g1[-1, 3] > g1[0, 3] and g1[-1, 4] != g1[1, 4]  # it grows, the pressure changes
    s1 = json.loads((ref / "summary.json").read_text())
    s2 = json.loads((out / "summary.json").read_text())
    assert s2["restarted_from"]["step"] == 4 and s2["status"] == "converged"
    for key in ("steps", "remeshes", "final_pressure_Pa"):
        assert s2["growth"].get(key) == pytest.approx(s1["growth"].get(key), rel=1e-10), key


def test_checkpoint_time_in_a_growth_run(shared_dir):
    """``[output] checkpoint_time = 0.3`` with growth steps of 0.2 over 5 steps:
    checkpoints after steps 2 (t = 0.4), 3 (0.6) and 5 (1.0: a new multiple of 0.3, and
    the last); the last two kept."""
    import json

    out = shared_dir / "out-by-time"
    text = TUMOUR.replace("t_end = 3.0", "t_end = 1.0").replace(
        'directory = "{out}"', 'directory = "{out}"\ncheckpoint_time = 0.3'
    )
    assert main(["run", str(_write(shared_dir, "by_time.toml", text.format(out=out))), "-q"]) == 0
    info = json.loads((out / "summary.json").read_text())["checkpoints"]
    assert info["written"] == 3 and info["time"] == 0.3 and info["every"] == 0
    names = sorted(p.name for p in (out / "checkpoints").iterdir())
    assert names == ["step_00000003", "step_00000005"]


def test_full_disk_during_a_growth_checkpoint(shared_dir, monkeypatch):
    """The disk fills while the checkpoint of growth step 3 is written (ENOSPC at its
    fsync): every rank stops, exit 1, status "failed" with a message naming that
    checkpoint; its temporary directory is gone, the checkpoints of steps 1 and 2 are
    intact (the newest found on restart is step 2), growth.csv has the rows up to step 3."""
    import errno
    import json
    import os

    from bonecontact.runners.checkpoint import find_checkpoint

    fsync = os.fsync

    def full(fd: int) -> None:  # (Linux: the file of a descriptor from /proc)
        if "step_00000003" in os.readlink(f"/proc/self/fd/{fd}"):
            raise OSError(errno.ENOSPC, "No space left on device")
        fsync(fd)

    out = shared_dir / "out-full-disk"
    text = TUMOUR.replace("t_end = 3.0", "t_end = 1.0").replace(
        'directory = "{out}"', 'directory = "{out}"\ncheckpoint_every = 1'
    )
    scene = _write(shared_dir, "full_disk.toml", text.format(out=out))
    monkeypatch.setattr(os, "fsync", full)
    assert main(["run", str(scene), "-q"]) == 1
    monkeypatch.setattr(os, "fsync", fsync)
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "failed" and "step_00000003" in s["message"]
    assert "No space left" in s["message"]
    names = sorted(p.name for p in (out / "checkpoints").iterdir())
    assert names == ["step_00000001", "step_00000002"]
    assert find_checkpoint(out, MPI.COMM_WORLD)[1]["step"] == 2
    _, g = _read_growth(out / "growth.csv")
    np.testing.assert_allclose(g[:, 0], [0.0, 0.2, 0.4, 0.6], rtol=1e-14)
