"""Text of numbers in the result tables (CSV): exact, round-trippable.

Two behaviours, kept apart by name:

* :func:`format_float` - every value as a float, ``repr(float(x))`` (``3`` -> ``"3.0"``):
  the growth tables and point lists;
* :func:`format_cell` - a table cell of any type: integers stay integers (``3`` ->
  ``"3"``), strings are written as they are, anything else as :func:`format_float`:
  history, probe and contact tables.
"""

from __future__ import annotations

import numpy as np

__all__ = ["format_cell", "format_float"]


def format_float(x: float) -> str:
    """Shortest text that reads back to the same float, ``repr(float(x))``.

    Parameters
    ----------
    x
        Any number (converted to float first: ``3`` gives ``"3.0"``).

    Returns
    -------
    str
        E.g. ``"0.1"``, ``"1e-09"``, ``"nan"``, ``"inf"``.
    """
    return repr(float(x))


def format_cell(x: int | float | str) -> str:
    """Text of one table cell: integers as integers, strings unchanged, else :func:`format_float`.

    Parameters
    ----------
    x
        A Python or NumPy integer, a string, or a number.

    Returns
    -------
    str
        ``str(int(x))`` for integers, ``x`` for strings, ``format_float(x)`` otherwise.
    """
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    if isinstance(x, str):
        return x
    return format_float(x)
