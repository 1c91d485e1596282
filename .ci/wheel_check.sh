#!/usr/bin/env bash
# Wheel check: the package installs like any other.  From a clean export of HEAD (git
# archive: no build products, no uncommitted files) build the wheel, install it with its
# dependencies into a fresh venv in a temporary directory, and from a directory outside the
# checkout (nothing of the repository is reachable there but copies of the inputs) run
#   * bonecontact --version (must be pyproject.toml's version);
#   * the shipped scene data/scenes/knee2d.toml (copied with its mesh), on 1 and 2 ranks;
#   * a 2D crack scene written here (a plate with a centre crack in tension; its K_I is
#     compared with Feddersen's formula, 5 %);
#   * the quickest demo, demos/contact_api.py (copied alone).
# Usage: .ci/wheel_check.sh  (make wheel-check finds the Python; or PYTHON=/path/python3.12)
# KEEP=1 keeps the temporary directory.  Any failure names the step and exits non-zero.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
step="start"
trap 'echo "WHEEL CHECK FAILED at step \"${step}\": \"${BASH_COMMAND}\" exited with status $? (line ${LINENO} of .ci/wheel_check.sh)" >&2' ERR
fail() { echo "WHEEL CHECK FAILED at step \"${step}\": $*" >&2; exit 1; }
say() { echo "== wheel check: $*"; }

step="find Python"
py=${PYTHON:-}
if [ -z "$py" ]; then
  for name in python3.13 python3.12 python3; do
    py=$(command -v "$name" 2>/dev/null) && "$py" -c 'import sys; sys.exit(sys.version_info < (3, 12))' \
      && break
    py=""
  done
fi
[ -n "$py" ] && "$py" -c 'import sys, venv, ensurepip; sys.exit(sys.version_info < (3, 12))' \
  || fail "no Python >= 3.12 with venv (pass PYTHON=/path/to/python3.12; make wheel-check finds one)"
command -v git >/dev/null || fail "git is needed to export HEAD"
git -C "$repo" rev-parse --verify -q HEAD >/dev/null || fail "$repo is not a git checkout with a commit"

work=$(mktemp -d "${TMPDIR:-/tmp}/bonecontact-wheel.XXXXXX")
cleanup() { if [ "${KEEP:-0}" = 1 ]; then echo "== wheel check: kept $work"; else rm -rf "$work"; fi; }
trap cleanup EXIT
mkdir -p "$work/src" "$work/dist" "$work/run"
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1} OPENBLAS_NUM_THREADS=${OPENBLAS_NUM_THREADS:-1}
export PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_INPUT=1
start=$SECONDS

step="export HEAD"
say "HEAD $(git -C "$repo" rev-parse --short HEAD) -> $work/src"
if [ -n "$(git -C "$repo" status --porcelain --untracked-files=no 2>/dev/null)" ]; then
  say "note: the work tree has uncommitted changes; they are not part of this check (it builds HEAD)"
fi
git -C "$repo" archive --format=tar HEAD | tar -x -C "$work/src"

step="create the venv"
say "$py -m venv $work/venv   # $("$py" --version 2>&1)"
"$py" -m venv "$work/venv"
vpy="$work/venv/bin/python"

step="build the wheel"
say "pip wheel --no-deps $work/src"
"$vpy" -m pip wheel --no-deps --progress-bar off -q -w "$work/dist" "$work/src" \
  || fail "pip wheel could not build the package from a clean export of HEAD"
wheels=("$work/dist"/bonecontact-*.whl)
[ -f "${wheels[0]}" ] || fail "no bonecontact wheel in $work/dist"
wheel=${wheels[0]}
say "built $(basename "$wheel") ($(du -k "$wheel" | cut -f1) kB)"

step="wheel contents"
# Every package of the source tree (a folder with __init__.py under bonecontact/, forms/,
# data/) and the reference data the code reads must be in the wheel.
"$vpy" - "$wheel" "$work/src" <<'PY' || fail "the wheel is incomplete (listed above): a package or data file is not shipped (setup.py, pyproject.toml [tool.setuptools.package-data])"
import sys, zipfile
from pathlib import Path

wheel, src = sys.argv[1], Path(sys.argv[2])
names = set(zipfile.ZipFile(wheel).namelist())
want = []
for folder, target in (("bonecontact", "bonecontact"), ("forms", "bonecontact/forms"),
                       ("data", "bonecontact/data")):
    for init in (src / folder).rglob("__init__.py"):
        want.append(f"{target}/{init.relative_to(src / folder).as_posix()}")
data = src / "data"
for pattern in ("*.toml", "anatomy/*.stl", "anatomy/NOTICE", "anatomy/LICENSE-*",
                "scenes/*.toml", "scenes/*.msh"):
    want += [f"bonecontact/data/{p.relative_to(data).as_posix()}" for p in data.glob(pattern)]
missing = sorted(set(want) - names)
if missing:
    sys.exit("the wheel lacks " + ", ".join(missing))
print(f"== wheel check: the wheel holds all {len(want)} packages and data files looked for")
PY

step="install the wheel and its dependencies"
say "pip install $(basename "$wheel")   # dependencies from the pip cache or the index"
"$vpy" -m pip install --progress-bar off -q "$wheel" \
  || fail "pip could not install the wheel with its dependencies into a fresh venv"
bin="$work/venv/bin"

cd "$work/run"   # outside the checkout from here on
step="import from the installation"
"$bin/python" - "$work/venv" <<'PY' || fail "the installed package cannot be imported, or is not the one in the venv (see above)"
import dolfinx_solver  # noqa: F401  (first, as everywhere)
import sys
from pathlib import Path

import bonecontact
import bonecontact.data
import bonecontact.forms
from bonecontact.materials.library import MATERIALS_FILE, load_material_library

venv = Path(sys.argv[1]).resolve()
for mod in (bonecontact, bonecontact.forms, bonecontact.data):
    if not Path(mod.__file__).resolve().is_relative_to(venv):
        sys.exit(f"{mod.__name__} was imported from {mod.__file__}, not from the venv {venv}")
if not Path(str(MATERIALS_FILE)).resolve().is_relative_to(venv):
    sys.exit(f"the material library is read from {MATERIALS_FILE}, not from the installation")
print(f"== wheel check: imported from the venv; {len(load_material_library())} library materials")
PY

step="bonecontact --version"
want=$("$bin/python" -c 'import sys, tomllib; print(tomllib.load(open(sys.argv[1], "rb"))["project"]["version"])' \
  "$work/src/pyproject.toml")
got=$("$bin/bonecontact" --version)
[ "$got" = "bonecontact $want" ] || fail "bonecontact --version printed '$got', expected 'bonecontact $want'"
say "$got"

check_summary() {  # the run's summary.json says converged
  "$bin/python" -c 'import json, sys; s = json.load(open(sys.argv[1])); sys.exit(0 if s["status"] == "converged" else "status " + s["status"])' \
    "$1/summary.json" || fail "$1/summary.json does not report a converged run"
}

step="run a shipped scene (knee2d)"
mkdir -p scene
cp "$work/src/data/scenes/knee2d.toml" "$work/src/data/scenes/knee2d.msh" scene/
say "bonecontact run scene/knee2d.toml"
"$bin/bonecontact" run -q scene/knee2d.toml -o out_knee2d || fail "bonecontact run knee2d.toml failed"
check_summary out_knee2d
say "mpiexec -n 2 bonecontact run scene/knee2d.toml   # the venv's MPICH"
"$bin/mpiexec" -n 2 "$bin/bonecontact" run -q scene/knee2d.toml -o out_knee2d_2 \
  || fail "bonecontact run knee2d.toml on 2 ranks (the venv's mpiexec) failed"
check_summary out_knee2d_2

step="run a 2D crack scene"
mkdir -p crack
"$bin/python" - crack/plate.msh <<'PY' || fail "gmsh could not write the crack scene's mesh"
# A plate [-W, W] x [-H, H] with its edge groups; rigid-body motion removed on two short
# edge pieces at the bottom-left corner (as tests/unit/runners/test_crack_scene.py).
import sys

import gmsh

W, H, PIN, h = 0.02, 0.04, 0.002, 0.002
gmsh.initialize(interruptible=False)
gmsh.option.setNumber("General.Terminal", 0)
geo = gmsh.model.geo
corners = [(-W, -H), (-W + PIN, -H), (W, -H), (W, H), (-W, H), (-W, -H + PIN)]
p = [geo.addPoint(x, y, 0, h) for x, y in corners]
lines = [geo.addLine(p[i], p[(i + 1) % 6]) for i in range(6)]
geo.addPlaneSurface([geo.addCurveLoop(lines)])
geo.synchronize()
gmsh.model.addPhysicalGroup(2, [1], 1, name="plate")
for k, name in enumerate(("pin_y", "bottom", "right", "top", "left", "pin_x")):
    gmsh.model.addPhysicalGroup(1, [lines[k]], 2 + k, name=name)
gmsh.model.mesh.generate(2)
gmsh.write(sys.argv[1])
gmsh.finalize()
PY
cat > crack/plate_crack.toml <<'TOML'
format = 1
[scene]
name = "plate_crack"
mesh = "plate.msh"
dimension = 2
[analysis]
kind = "static"
load_steps = 1
[[material]]
name = "cortical"
regions = ["plate"]
model = "isotropic"
E = 17.0e9
nu = 0.3
sigma_t = 133e6
K_Ic = 2.0e6
[[dirichlet]]
boundary = "pin_x"
value = [0.0, "free"]
[[dirichlet]]
boundary = "pin_y"
value = ["free", 0.0]
[[traction]]
boundary = "top"
value = [0.0, 1.0e6]
[[traction]]
boundary = "bottom"
value = [0.0, -1.0e6]
[[crack]]
name = "c"
points = [[-0.006, 0.0], [0.006, 0.0]]
region = "plate"
[output]
fields_every = 0
TOML
say "bonecontact run crack/plate_crack.toml"
"$bin/bonecontact" run -q crack/plate_crack.toml -o out_crack || fail "bonecontact run of the crack scene failed"
check_summary out_crack
"$bin/python" - out_crack/fracture.csv <<'PY' || fail "the crack scene's K_I is not Feddersen's value"
# Centre crack 2a = 12 mm in a plate of width 2W = 40 mm under sigma = 1 MPa:
# K_I = sigma sqrt(pi a / cos(pi a / 2W)) (Feddersen), both tips.
import csv, math, sys

rows = list(csv.DictReader(open(sys.argv[1])))
a, W, sigma = 0.006, 0.02, 1.0e6
ref = sigma * math.sqrt(math.pi * a / math.cos(math.pi * a / (2 * W)))
k = [float(r["K_I"]) for r in rows]
print(f"== wheel check: crack K_I at the tips {', '.join(f'{x:.4g}' for x in k)} Pa√m, Feddersen {ref:.4g}")
if len(k) != 2 or any(abs(x / ref - 1) > 0.05 for x in k):
    sys.exit("K_I differs from Feddersen's formula by more than 5 %")
PY

step="run the quickest demo (contact_api)"
mkdir -p demo
cp "$work/src/demos/contact_api.py" demo/
say "python demo/contact_api.py"
(cd demo && MPLBACKEND=Agg "$bin/python" contact_api.py "$work/run/out_demo") \
  || fail "demos/contact_api.py failed when run outside the checkout against the installed wheel"
[ -n "$(ls -A "$work/run/out_demo" 2>/dev/null)" ] || fail "the demo wrote nothing to $work/run/out_demo"

say "passed in $((SECONDS - start)) s"
