"""One gmsh session helper for every gmsh user of the package (meshing, remeshing, runs).

gmsh is a process-wide singleton: a caller must not finalise a session somebody else
opened (a test, a demo, an outer builder).  :func:`gmsh_session` initialises gmsh only if
it is not yet initialised, and then finalises it again on exit; otherwise it leaves gmsh
running and only removes the model it added.  Sessions nest.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import gmsh

__all__ = ["gmsh_session"]


@contextmanager
def gmsh_session(name: str | None = None) -> Iterator[None]:
    """A quiet gmsh session, optionally with a fresh model (reentrant).

    Parameters
    ----------
    name
        If given, a new gmsh model of that name is added (and removed again on exit
        when gmsh stays initialised); ``None``: no model is added.

    Notes
    -----
    gmsh is initialised (non-interruptible) only if it is not already, and then
    finalised on exit.  Terminal output is off inside the session; an outer session's
    setting is restored on exit.
    """
    own = not gmsh.isInitialized()
    if own:
        gmsh.initialize(interruptible=False)
    terminal = gmsh.option.getNumber("General.Terminal")
    gmsh.option.setNumber("General.Terminal", 0)
    if name is not None:
        gmsh.model.add(name)
    try:
        yield
    finally:
        if own:
            gmsh.finalize()
        else:
            if name is not None:
                gmsh.model.remove()
            gmsh.option.setNumber("General.Terminal", terminal)
