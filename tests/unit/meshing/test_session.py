"""The gmsh session helper (bonecontact.meshing.session): owns gmsh only if it started it.

gmsh runs on rank 0 only; the other ranks run the tests too (and check nothing), so that
every rank passes through the same collective teardown.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

from mpi4py import MPI

import gmsh
import pytest

from bonecontact.meshing.session import gmsh_session

ROOT = MPI.COMM_WORLD.rank == 0


def test_session_initialises_and_finalises():
    if not ROOT:
        return
    assert not gmsh.isInitialized()
    with gmsh_session("a"):
        assert gmsh.isInitialized()
        assert gmsh.model.getCurrent() == "a"
        assert gmsh.option.getNumber("General.Terminal") == 0
    assert not gmsh.isInitialized()


def test_sessions_nest_and_keep_an_outer_session():
    if not ROOT:
        return
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 1)
        gmsh.model.add("outer")
        with gmsh_session("inner"):
            with gmsh_session():
                assert gmsh.model.getCurrent() == "inner"
                assert gmsh.option.getNumber("General.Terminal") == 0
            assert "inner" in gmsh.model.list()
        assert gmsh.isInitialized()
        assert "inner" not in gmsh.model.list() and "outer" in gmsh.model.list()
        assert gmsh.option.getNumber("General.Terminal") == 1
    finally:
        gmsh.finalize()


def test_session_finalises_after_an_error():
    if not ROOT:
        return
    with pytest.raises(RuntimeError):
        with gmsh_session("b"):
            raise RuntimeError("boom")
    assert not gmsh.isInitialized()
