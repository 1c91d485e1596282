"""One progress bar that updates in place in a Jupyter notebook.

A console progress bar (tqdm) redraws itself with carriage returns; an executed
notebook keeps every redraw as an output.  :func:`progress_file` gives, in a notebook, a
file whose writes replace the text of one display (``update_display``), so that the cell
keeps a single, final bar; elsewhere ``None`` (tqdm writes to stderr as usual).
"""

from __future__ import annotations

from typing import Any

from bonecontact.plot.env import in_notebook


class DisplayFile:
    """A writable file that shows the last line written in one updating notebook display."""

    #: What tqdm reads to choose its bar characters (Unicode blocks, not ``#``).
    encoding = "utf-8"

    def __init__(self) -> None:
        self.handle: Any = None
        self.text = ""

    def write(self, s: str) -> int:
        """Keep the last non-empty line of ``s`` (after its last carriage return) and show it."""
        line = s.replace("\n", "\r").split("\r")
        last = next((p for p in reversed(line) if p.strip()), "")
        if last and last != self.text:
            self.text = last
            self._show()
        return len(s)

    def _show(self) -> None:
        from IPython.display import display

        data = {"text/plain": self.text}
        if self.handle is None:
            self.handle = display(data, raw=True, display_id=True)
        else:
            self.handle.update(data, raw=True)

    def flush(self) -> None:
        """Nothing to flush: every write is shown."""


def progress_file() -> DisplayFile | None:
    """The file a progress bar should write to: one updating display in a Jupyter
    notebook, ``None`` (stderr) elsewhere."""
    return DisplayFile() if in_notebook() else None
