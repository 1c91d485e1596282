# bonecontact — set-up, demo and test entry points.
#
#   make install      create .venv (Python >= 3.12, found automatically) and install the
#                     package editable with its test extras; cheap when already done
#   make demo         install if needed, then run demos/knee2d.py; DEMO=demos/<name>.py runs
#                     another of the eleven demos (knee2d, long_bone, knee_tumour, jaw_cyst,
#                     vertebra_tumour, jaw3d, spine3d, knee3d, knee3d_gait, vertebra_fracture,
#                     contact_api); results in
#                     demos/results/<name>/
#   make notebooks    install if needed, then run every demo as a notebook (build/notebooks/, also as .html)
#                     and execute it headless with its figures inline (NOTEBOOKS="demos/x.py"
#                     for some); results in build/notebooks/results/<name>/
#   make test         install if needed, then lint, docs, the serial suite and the MPI suite on
#                     2 and 3 ranks, without the tests marked slow (what CI runs);
#                     make test-serial / make test-parallel  run one suite only, without lint
#                     and docs
#                     (each pytest session writes every test's and file's seconds, slowest
#                     first, to .venv/test-logs/<session>-times.csv)
#   make test-all     make test with the slow verification cases too
#   make lint         ruff check and ruff format --check over the repository (changes no file;
#                     `.venv/bin/ruff check --fix . && .venv/bin/ruff format .` applies the fixes)
#   make docs         API reference generated from the docstrings (pdoc) into docs/api/;
#                     fails on any import error or warning
#   make wheel-check  build the wheel from a clean export of HEAD, install it with its
#                     dependencies into a fresh venv in a temporary directory and run a shipped
#                     scene, a 2D crack scene and the contact_api demo from outside the
#                     checkout (.ci/wheel_check.sh; CI runs it; needs no .venv)
#   make benchmarks   install if needed, then benchmarks/run_all.sh
#   make clean        remove caches, test logs, docs/api, build/ and demos/results;  make distclean  also removes .venv
#
# Variables you may override:  PYTHON=/path/to/python3.12  MPI_SIZES="2 3"  TEST_TIMEOUT=2400
# (seconds, each pytest session)  SERIAL_WORKERS=2 (pytest-xdist processes of the serial
# session; 0: none)  MPI3_SKIP="growth or two_ranks" (markers left out on 3+ ranks by make
# test; empty: none)
# MPI3_TESTS="tests/unit/contact ..." (what make test runs on 3+ ranks; empty: everything)
# PYTEST_ARGS="-k hertz" (added to every pytest call).
# BONECONTACT_TEST_SERIAL_STORE=<dir> (where the serial session keeps its fracture runs for
# the MPI sessions' serial references; default .venv/test-logs/serial-store; empty: off).

SHELL := /bin/bash
.SHELLFLAGS := -euo pipefail -c
.DEFAULT_GOAL := help
.DELETE_ON_ERROR:

VENV         := .venv
PY           := $(VENV)/bin/python
MPIEXEC      := $(VENV)/bin/mpiexec
STAMP        := $(VENV)/.install.stamp
LOG_DIR      := $(VENV)/test-logs
DOCS_DIR     := docs/api
MPI_SIZES    ?= 2 3
SERIAL_WORKERS ?= 2
TEST_TIMEOUT ?= 2400
PYTEST_ARGS  ?=
# Serial reference runs of the fracture scenes, kept by one test session for the later ones
# (tests/unit/runners/serial_store.py: keyed by the package's files, the library versions,
# the scene text and its mesh); emptied when the serial session starts;
# BONECONTACT_TEST_SERIAL_STORE= turns it off.
export BONECONTACT_TEST_SERIAL_STORE ?= $(CURDIR)/$(LOG_DIR)/serial-store

# Keep MPI ranks from each starting a full set of BLAS/OpenMP threads.
export OMP_NUM_THREADS ?= 1
export OPENBLAS_NUM_THREADS ?= 1
# MPICH busy-polls while a rank waits; with more ranks than cores (3 ranks, and the serial
# session's 3-rank runs beside the other worker, on 2 cores) the waiting ranks take the
# cores from the working one.  Throttled polling (a 1 µs sleep after 4096 idle polls)
# made a 3-rank sample of the suite 18 % faster and left 2 ranks unchanged (2026-12-05).
export MPIR_CVAR_CH4_PROGRESS_THROTTLE ?= 1
export PIP_DISABLE_PIP_VERSION_CHECK := 1
export PIP_NO_INPUT := 1
export PYTHON

# --- find a Python >= 3.12 (with venv + ensurepip): $PYTHON, then PATH, then pyenv -----------
define FIND_PYTHON
usable() { "$$1" -c 'import sys, venv, ensurepip; sys.exit(sys.version_info < (3, 12))' >/dev/null 2>&1; }
if [ -n "$${PYTHON:-}" ]; then
  usable "$$PYTHON" && { echo "$$PYTHON"; exit 0; }
  echo "error: PYTHON=$$PYTHON is not a Python >= 3.12 with the venv module; install one or unset PYTHON" >&2; exit 1
fi
for name in python3.13 python3.12 python3; do
  p=$$(command -v "$$name" 2>/dev/null) || continue
  usable "$$p" && { echo "$$p"; exit 0; }
done
roots=""
if command -v pyenv >/dev/null 2>&1; then roots=$$(pyenv root 2>/dev/null || true); fi
roots="$$roots $$HOME/.pyenv"
for root in $$roots; do
  for p in "$$root"/versions/3.1[2-9]*/bin/python3.*; do
    case "$${p##*/}" in python3.[0-9]|python3.[0-9][0-9]) ;; *) continue ;; esac
    [ -x "$$p" ] && usable "$$p" && { echo "$$p"; exit 0; }
  done
done
echo "error: no Python >= 3.12 with the venv module found (looked for python3.13, python3.12, python3 on PATH and in pyenv's versions): install one, e.g. 'pyenv install 3.12' or 'apt-get install python3.12-venv', or pass PYTHON=/path/to/python3.12" >&2
exit 1
endef
export FIND_PYTHON

# --- run one pytest session and explain its exit status ------------------------------------
# usage: [SHOW="what to print"] bash -c "$$RUN_PYTEST" run-pytest LABEL COMMAND...
define RUN_PYTEST
label=$$1; shift
echo "+ $${SHOW:-$$*}"
rc=0; "$$@" || rc=$$?
case $$rc in
  0) echo "== $$label: passed"; exit 0 ;;
  5) echo "error: $$label collected no tests (pytest exit 5): a suite that runs nothing is a defect" >&2 ;;
  124|137) echo "error: $$label timed out after $(TEST_TIMEOUT) s (a rank probably hung in a collective)" >&2 ;;
  *) echo "error: $$label failed (exit $$rc)" >&2 ;;
esac
for log in "$(LOG_DIR)/$$label".rank*.log; do
  [ -s "$$log" ] || continue
  printf "\n---- last 40 lines of %s ----\n" "$$log" >&2; tail -n 40 "$$log" >&2
done
exit $$rc
endef
export RUN_PYTEST

# Under mpiexec, rank 0 prints; every other rank writes to LOG_DIR/<label>.rank<r>.log.
# (MPICH hydra sets PMI_RANK, Open MPI sets OMPI_COMM_WORLD_RANK.)
RANK_LOG := bash -c 'r=$${PMI_RANK:-$${OMPI_COMM_WORLD_RANK:-0}}; \
  if [ "$$r" != 0 ]; then exec >"$$0.rank$$r.log" 2>&1; fi; exec "$$@"'

.PHONY: help install demo notebooks lint docs test test-all test-serial test-parallel benchmarks \
	wheel-check clean distclean

help:
	@sed -n 's/^#   //p' $(firstword $(MAKEFILE_LIST))

install: $(STAMP)

$(STAMP): pyproject.toml setup.py
	@if [ -x "$(PY)" ] && ! "$(PY)" -c 'import sys; sys.exit(sys.version_info < (3, 12))' 2>/dev/null; then \
	  echo "+ rm -rf $(VENV)   # existing venv is unusable or older than Python 3.12"; rm -rf "$(VENV)"; \
	fi
	@if [ ! -x "$(PY)" ]; then \
	  py=$$(bash -c "$$FIND_PYTHON") || exit 1; \
	  echo "+ $$py -m venv $(VENV)   # $$("$$py" --version 2>&1)"; \
	  "$$py" -m venv "$(VENV)"; \
	fi
	@echo "+ $(PY) -m pip install --progress-bar off -e '.[test]'"
	@$(PY) -m pip install --progress-bar off -q -e '.[test]'
	@touch "$@"
	@echo "== installed into $(VENV) ($$($(PY) --version))"

DEMO ?= demos/knee2d.py

demo: install
	@test -f $(DEMO) || { echo "error: $(DEMO) does not exist" >&2; exit 1; }
	$(PY) $(DEMO)

# Tests marked `slow` (long verification cases) run only in make test-all.
SELECT ?= not slow

# Every demo as a notebook: jupytext converts, nbconvert executes in a python3 kernel
# started in build/notebooks/ (the demos find the repository from there).
NOTEBOOKS ?= $(sort $(wildcard demos/*.py))
NB_DIR    := build/notebooks

notebooks: install
	@mkdir -p "$(NB_DIR)"
	@for d in $(NOTEBOOKS); do \
	  nb="$(NB_DIR)/$$(basename "$$d" .py).ipynb"; \
	  echo "+ jupytext --to ipynb $$d -o $$nb && jupyter nbconvert --execute --inplace $$nb"; \
	  $(VENV)/bin/jupytext --quiet --to ipynb "$$d" -o "$$nb"; \
	  BONECONTACT_OUTPUT="$(CURDIR)/$(NB_DIR)/results" $(VENV)/bin/jupyter nbconvert --to notebook \
	    --execute --inplace --ExecutePreprocessor.timeout=1800 "$$nb"; \
	  $(VENV)/bin/jupyter nbconvert --log-level=WARN --to html "$$nb"; \
	done
	@echo "== notebooks: executed in $(NB_DIR)/*.ipynb, each also as $(NB_DIR)/<name>.html"
	@echo "   (open the .html in any web browser; the .ipynb in Jupyter or VS Code, which this"
	@echo "   venv does not install: e.g. '$(VENV)/bin/pip install jupyterlab', then"
	@echo "   '$(VENV)/bin/jupyter lab $(NB_DIR)'); results in $(NB_DIR)/results/"

# Serial suite: every selected test, including tests marked `serial` that spawn their own mpiexec.
# pytest-xdist spreads it over SERIAL_WORKERS processes, a test module to a worker (--dist
# loadscope: module-scoped fixtures such as the demo runs and restart references are made
# once); SERIAL_WORKERS=0 runs it in this process.
define run_serial
@mkdir -p "$(LOG_DIR)"
@if [ -n "$(BONECONTACT_TEST_SERIAL_STORE)" ]; then rm -rf "$(BONECONTACT_TEST_SERIAL_STORE)"; fi
@SHOW="timeout $(TEST_TIMEOUT) $(PY) -m pytest -x -q -n $(SERIAL_WORKERS) --dist loadscope --durations=15 -m '$(SELECT)' $(PYTEST_ARGS)" \
  bash -c "$$RUN_PYTEST" run-pytest serial \
  env BONECONTACT_TEST_TIMES="$(CURDIR)/$(LOG_DIR)/serial-times.csv" timeout --kill-after=30 $(TEST_TIMEOUT) \
  $(PY) -m pytest -x -q -n $(SERIAL_WORKERS) --dist loadscope --durations=15 -m "$(SELECT)" $(PYTEST_ARGS)
endef

MPI_SELECT = not serial$(if $(strip $(SELECT)), and $(SELECT))
# On 3 or more ranks (2 cores oversubscribed) make test runs the tests of the code whose
# results depend on the partition — contact, fracture, the 3D crack scenes, restarts on
# another rank count, field output pieces and reactions, the remesh input, the rigid-motion check (bodies joined across
# ranks), the contact robustness sample, the load-driven contact problems (bodies held
# only by contact, the first touching node on a partition boundary) and the fracture
# verification problems — and leaves out the tests marked growth (their 3-rank runs are
# serial-session tests that spawn 3 ranks) or two_ranks (refinements of a case that
# runs here).  The planar 3D crack scenes (interior, several, closed, surface, their
# checkpoints) run here as test_crack3d_ranks' family of reduced scenes, each against
# the same scene on one rank; their own files (test_crack_scene3d, _several,
# test_crack_restart3d, test_surface_crack_scene3d) run on 1 and 2 ranks.  Input parsing, materials, meshing, plotting, the mechanics-only
# verifications, Hertz, friction and dynamic contact (the contact code they use is in
# the 3-rank set; the Coulomb scene and the dynamic scene are also compared on 1 and 3
# ranks by serial-session tests), the crack-path verification and the other run-layer
# tests (command line, 2D crack and growth scenes, coupled runs, result tables: their
# parallel parts are those above) run on 1 and 2 ranks.  make test-all runs everything on
# 3 ranks too.
MPI3_SKIP  ?= growth or two_ranks
MPI3_RUNNERS = test_crack3d_ranks test_fracture_scene3d test_restart \
  test_vtu_output test_forces test_crack_growth_scene3d test_surface_crack_restart3d \
  test_crack_merge3d test_breakthrough_rule test_breakthrough_scene3d test_breakthrough_curved3d \
  test_scanned_vertebra_crack test_out_of_plane3d test_out_of_plane_restart3d \
  test_corner_crack_scene3d test_breakthrough_corner_rule test_breakthrough_corner_scene3d \
  test_crack_faces_start3d test_nonplanar_surface_scene3d test_nonplanar_surface_restart3d \
  test_surface_fragments
MPI3_TESTS ?= tests/unit/contact tests/unit/fracture \
  $(patsubst %,tests/unit/runners/%.py,$(MPI3_RUNNERS)) \
  tests/unit/neoplasm/test_remesh.py tests/unit/neoplasm/test_remesh_determinism.py \
  tests/unit/scene/test_rigid_motions.py tests/verification/test_robustness.py \
  tests/verification/test_load_driven.py tests/verification/test_load_driven_builder.py \
  $(filter-out %/test_fracture_propagation.py,$(wildcard tests/verification/test_fracture_*.py))

# MPI suites: each size runs under `timeout`; `python -m mpi4py` turns an exception or a
# non-zero pytest exit on any rank into MPI_Abort, so one rank's failure stops all ranks
# (and mpiexec returns that exit status) instead of leaving the others hanging.
define run_parallel
@mkdir -p "$(LOG_DIR)"
@for n in $(MPI_SIZES); do \
  sel="$(MPI_SELECT)"; paths=""; \
  if [ "$$n" -ge 3 ] && [ -n "$(strip $(MPI3_SKIP))" ]; then sel="$$sel and not ($(MPI3_SKIP))"; fi; \
  if [ "$$n" -ge 3 ]; then paths="$(strip $(MPI3_TESTS))"; fi; \
  rm -f "$(LOG_DIR)/mpi-$$n".rank*.log; \
  SHOW="timeout $(TEST_TIMEOUT) $(MPIEXEC) -n $$n $(PY) -m mpi4py -m pytest -x -q --durations=15 -m '$$sel' \
    -p no:cacheprovider $(PYTEST_ARGS) $$paths   # ranks > 0 write to $(LOG_DIR)/mpi-$$n.rank<r>.log" \
  bash -c "$$RUN_PYTEST" run-pytest "mpi-$$n" \
    env BONECONTACT_TEST_TIMES="$(CURDIR)/$(LOG_DIR)/mpi-$$n-times.csv" \
    timeout --kill-after=30 $(TEST_TIMEOUT) $(MPIEXEC) -n $$n \
    $(RANK_LOG) "$(LOG_DIR)/mpi-$$n" \
    $(PY) -m mpi4py -m pytest -x -q --durations=15 -m "$$sel" -p no:cacheprovider $(PYTEST_ARGS) $$paths; \
done
endef

# Lint: both checks always run, so one pass reports everything; either failing fails the target.
lint: install
	@rc=0; \
	echo "+ $(PY) -m ruff check ."; $(PY) -m ruff check . || rc=1; \
	echo "+ $(PY) -m ruff format --check ."; $(PY) -m ruff format --check . || rc=1; \
	if [ $$rc != 0 ]; then echo "error: lint failed (see above)" >&2; exit 1; fi; \
	echo "== lint: passed"

# API reference: pdoc imports every module (bonecontact/__init__.py imports dolfinx_solver
# first) and renders the NumPy-style docstrings. `-W error` turns every warning (an unresolvable
# annotation, a docstring pdoc cannot parse, a deprecation at import) into a failure; a module
# that fails to import already stops pdoc. A failed run leaves no half-written docs/api.
docs: install
	@rm -rf "$(DOCS_DIR)"
	@echo "+ $(PY) -W error -m pdoc -d numpy bonecontact bonecontact.forms -o $(DOCS_DIR)"
	@$(PY) -W error -m pdoc -d numpy bonecontact bonecontact.forms -o "$(DOCS_DIR)" \
	  || { rm -rf "$(DOCS_DIR)"; echo "error: API reference generation failed (see above)" >&2; exit 1; }
	@echo "== docs: $(DOCS_DIR)/index.html"

test: install lint docs
	$(run_serial)
	$(run_parallel)

test-all: SELECT :=
test-all: MPI3_SKIP :=
test-all: MPI3_TESTS :=
test-all: test

test-serial: install
	$(run_serial)

test-parallel: install
	$(run_parallel)

# The package as a user gets it: a wheel built from HEAD (uncommitted changes are not in it),
# installed outside the checkout (.ci/wheel_check.sh; KEEP=1 keeps its temporary directory).
wheel-check:
	@py=$$(bash -c "$$FIND_PYTHON") || exit 1; \
	echo "+ PYTHON=$$py bash .ci/wheel_check.sh"; \
	PYTHON="$$py" bash .ci/wheel_check.sh

benchmarks: install
	@test -f benchmarks/run_all.sh || { echo "error: benchmarks/run_all.sh does not exist yet" >&2; exit 1; }
	PATH="$(CURDIR)/$(VENV)/bin:$$PATH" bash benchmarks/run_all.sh

clean:
	rm -rf .pytest_cache "$(LOG_DIR)" build dist *.egg-info "$(DOCS_DIR)" demos/results
	find . -path ./$(VENV) -prune -o -type d -name __pycache__ -print0 | xargs -0 rm -rf

distclean: clean
	rm -rf "$(VENV)"
