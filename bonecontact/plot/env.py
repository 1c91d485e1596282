"""Where a demo runs: in a Jupyter kernel or not, where it writes, at which size."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path


def in_notebook() -> bool:
    """Whether the code runs in a Jupyter kernel (a figure can be shown inline)."""
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython comes with the test extras
        return False
    shell = get_ipython()
    return shell is not None and shell.__class__.__name__ == "ZMQInteractiveShell"


def output_dir(name: str, demo_dir: str | Path, argv: Sequence[str] = ()) -> Path:
    """Where a demo writes: the first non-option argument, else ``$BONECONTACT_OUTPUT/<name>``,
    else ``<demo_dir>/results/<name>`` — never relative to the working directory."""
    args = [a for a in argv if not a.startswith("-")]
    if args:
        return Path(args[0]).resolve()
    env = os.environ.get("BONECONTACT_OUTPUT")
    base = Path(env) if env else Path(demo_dir) / "results"
    return (base / name).resolve()


def quick_mode() -> bool:
    """Whether a demo should run at its reduced size: ``$BONECONTACT_DEMO_QUICK`` set and not
    ``0`` (the test suite sets it)."""
    return os.environ.get("BONECONTACT_DEMO_QUICK", "0") not in ("", "0")
