"""Shared pytest set-up for serial and MPI runs.

The suite runs once serially (``pytest``) and again under ``mpiexec -n 2`` and ``-n 3``
(``python -m mpi4py -m pytest -m "not serial"``).  Every test is therefore collective:
all ranks run the same tests in the same order.  Tests marked ``serial`` spawn their own
``mpiexec`` or subprocesses and are skipped when more than one rank is running.
"""

import dolfinx_solver  # noqa: F401  (loads MPI; must precede dolfinx / petsc4py)

import gc
import os
import shutil
import sys
import tempfile
from pathlib import Path

from mpi4py import MPI

import dolfinx.mesh
import pytest

from bonecontact.common.linalg import release_petsc_garbage
from bonecontact.contact import pdas


def pytest_collection_modifyitems(config, items):
    if MPI.COMM_WORLD.size == 1:
        return
    skip = pytest.mark.skip(reason="serial test: runs only in the serial (1-rank) session")
    for item in items:
        if "serial" in item.keywords:
            item.add_marker(skip)


#: Whether this rank's session failed (set at its end; read when pytest unconfigures).
_SESSION_FAILED = False


#: Seconds per test (setup + call + teardown), kept where the session reports.
_TIMES: dict[str, float] = {}


def pytest_runtest_logreport(report):
    _TIMES[report.nodeid] = _TIMES.get(report.nodeid, 0.0) + report.duration


def _write_times(config) -> None:
    """With ``BONECONTACT_TEST_TIMES=<file>`` (the Makefile sets it per session), the
    session's reporting process (rank 0; the xdist controller) writes every test's
    seconds and each file's sum, slowest first: what to trim when the suite is slow."""
    path = os.environ.get("BONECONTACT_TEST_TIMES")
    if not path or MPI.COMM_WORLD.rank != 0 or hasattr(config, "workerinput"):
        return
    files: dict[str, float] = {}
    for nodeid, t in _TIMES.items():
        key = nodeid.split("::")[0]
        files[key] = files.get(key, 0.0) + t
    with open(path, "w") as out:
        out.write("seconds,test\n")
        for key, t in sorted(files.items(), key=lambda kv: -kv[1]):
            out.write(f"{t:.2f},{key}\n")
        for key, t in sorted(_TIMES.items(), key=lambda kv: -kv[1]):
            out.write(f"{t:.2f},{key}\n")


def pytest_sessionfinish(session, exitstatus):
    global _SESSION_FAILED
    _SESSION_FAILED = exitstatus not in (0, 5)  # 5: nothing collected
    _write_times(session.config)


def pytest_unconfigure(config):
    """Under MPI, a rank whose session failed (``-x`` stops it at its first failure) aborts
    the job once it has printed its report: the other ranks would otherwise wait in the next
    test's collective until the suite's time-out."""
    if _SESSION_FAILED and MPI.COMM_WORLD.size > 1:
        sys.stdout.flush()
        sys.stderr.flush()
        MPI.COMM_WORLD.Abort(1)


def pytest_collection_finish(session):
    """Move everything alive after collection (modules, compiled forms, parameter sets) to
    the collector's permanent generation: the ``gc.collect()`` after each test then scans
    only what the test made (0.2 s → a few ms a test; about 5 min of a full run)."""
    gc.collect()
    gc.freeze()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_teardown(item, nextitem):
    """After a module's last test (its module fixtures finalised): one full collection,
    then everything still alive (caches, the session's reports, compiled forms) moved to
    the permanent generation too.  Without it the heap the session grows was scanned
    twice after every test: 0.4 s a test late in a 2-rank session (test_spec's 171 tests
    took 68 s, 0.02 s each when run alone).  A cycle that dies after being frozen is
    collected at the next module's end."""
    yield
    if nextitem is None or getattr(nextitem, "module", None) is not getattr(item, "module", None):
        gc.unfreeze()
        gc.collect()
        gc.freeze()


#: The C++ meshes made on more than one rank since the last test ended (kept alive until
#: the PETSc objects made on their communicators are destroyed).
_PARALLEL_MESHES: list = []


def _tracking_mesh_init(init):
    """``dolfinx.mesh.Mesh.__init__`` that also records a parallel mesh's C++ object."""

    def __init__(self, msh, domain):
        init(self, msh, domain)
        if msh.comm.size > 1:
            _PARALLEL_MESHES.append(msh)

    return __init__


dolfinx.mesh.Mesh.__init__ = _tracking_mesh_init(dolfinx.mesh.Mesh.__init__)


@pytest.fixture(autouse=True)
def _collective_teardown():
    """Free PETSc/DOLFINx objects collectively and keep the ranks in step after each test.

    In parallel petsc4py parks the PETSc objects Python frees until a collective clean-up
    on their communicator, and DOLFINx gives every mesh a communicator of its own: without
    a clean-up on each test's meshes every MUMPS factor of the session kept its MPI
    communicators and MPICH ran out of them after about 400 factorisations (MUMPS
    INFOG(1) = -3 in whichever test came next).  The meshes are recorded when made (in the
    same order on every rank) and their communicators cleaned before they are released.
    """
    yield
    gc.collect()
    for msh in _PARALLEL_MESHES:
        release_petsc_garbage(msh.comm, collect=False)
    _PARALLEL_MESHES.clear()
    gc.collect()
    release_petsc_garbage(MPI.COMM_WORLD, collect=False)
    MPI.COMM_WORLD.barrier()


@pytest.fixture
def tmp_shared_path():
    """A fresh temporary directory with the same path on every rank (removed afterwards)."""
    comm = MPI.COMM_WORLD
    path = tempfile.mkdtemp(prefix="bonecontact-") if comm.rank == 0 else None
    path = Path(comm.bcast(path, root=0))
    yield path
    comm.barrier()
    if comm.rank == 0:
        shutil.rmtree(path, ignore_errors=True)


@pytest.fixture(scope="session")
def venv_bin():
    """Directory of the running interpreter (the venv's ``bin``, holding ``mpiexec``)."""
    return Path(sys.executable).parent


@pytest.fixture
def closed_gap_start(monkeypatch):
    """A function that makes every contact pair, a crack's faces too, start from its
    closed-gap nodes for the rest of the test (the rule of the pairs that do not start
    open, forced on the crack faces to compare their open start with the other rule)."""

    def force() -> None:
        original = pdas.ContactSolver.__init__

        def init(self, V, interfaces, options=None):
            for itf in interfaces:
                itf.start_open = False
            original(self, V, interfaces, options)

        monkeypatch.setattr(pdas.ContactSolver, "__init__", init)

    return force
