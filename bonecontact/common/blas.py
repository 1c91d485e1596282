"""One BLAS thread for the small dense work of the contact solver.

The wheels of NumPy and SciPy each bundle a threaded OpenBLAS.  For the small dense
systems of the low-rank contact solver (a few hundred unknowns) its threads cost more
than they save, and on a loaded machine they spin: an LU of 250 unknowns measured 61 ms
of CPU with the default threads against 1 ms with one (2-core machine, load 16;
docs/theory/pdas.md#small-system-scaling).  :func:`one_blas_thread` sets every loaded
OpenBLAS to one thread for a block of code and restores its count afterwards (found by
its exported ``*openblas_set_num_threads*`` entry points; a library without them, or a
platform without ``/proc/self/maps``, is left alone).
"""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from contextlib import contextmanager
from functools import cache

__all__ = ["one_blas_thread", "openblas_controls"]

#: (setter, getter) names exported by the OpenBLAS builds of the NumPy/SciPy wheels
#: (64-bit-integer build first) and by a plain OpenBLAS
_ENTRY_POINTS = (
    ("scipy_openblas_set_num_threads64_", "scipy_openblas_get_num_threads64_"),
    ("scipy_openblas_set_num_threads", "scipy_openblas_get_num_threads"),
    ("openblas_set_num_threads", "openblas_get_num_threads"),
)


@cache
def openblas_controls() -> tuple[tuple, ...]:
    """(set, get) of every OpenBLAS loaded in this process (cached: the BLAS libraries
    are loaded with NumPy and SciPy, before the contact solver runs)."""
    try:
        with open("/proc/self/maps") as f:
            paths = {line.split()[-1] for line in f if "openblas" in line.lower()}
    except OSError:
        return ()
    out = []
    for path in sorted(paths):
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for set_name, get_name in _ENTRY_POINTS:
            if hasattr(lib, set_name) and hasattr(lib, get_name):
                setter, getter = getattr(lib, set_name), getattr(lib, get_name)
                setter.argtypes, setter.restype = [ctypes.c_int], None
                getter.argtypes, getter.restype = [], ctypes.c_int
                out.append((setter, getter))
                break
    return tuple(out)


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the block with one thread in every loaded OpenBLAS, then restore."""
    controls = openblas_controls()
    saved = [get() for _, get in controls]
    for setter, _ in controls:
        setter(1)
    try:
        yield
    finally:
        for (setter, _), n in zip(controls, saved):
            setter(n)
