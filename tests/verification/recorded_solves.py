"""Every contact solve's result of a run, kept for the law checks of the friction tests.

Not a test module (no ``test_`` prefix); the tests import it by name (pytest puts this
folder on ``sys.path``).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from bonecontact.contact.pdas import ContactSolver


@contextmanager
def recorded_solves(monkeypatch: pytest.MonkeyPatch) -> Iterator[list]:
    """Inside the block, every :meth:`ContactSolver.solve` appends its result to the list
    yielded (in call order); the method is restored on exit."""
    results: list = []
    solve = ContactSolver.solve

    def recording(self, b, u):
        res = solve(self, b, u)
        results.append(res)
        return res

    with monkeypatch.context() as m:
        m.setattr(ContactSolver, "solve", recording)
        yield results
