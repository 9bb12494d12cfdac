"""The one project exception: every bad-input problem names its file, line and what was expected."""

from __future__ import annotations

from pathlib import Path


class FlowvoError(Exception):
    """A user-facing error about an input file or argument.

    The CLI prints ``str(error)`` as one line on stderr and exits with code 2.
    """

    def __init__(self, message: str, path: str | Path | None = None, line: int | None = None) -> None:
        self.message = message
        self.path = None if path is None else str(path)
        self.line = line
        super().__init__(str(self))

    def __str__(self) -> str:
        where = ""
        if self.path is not None:
            where = self.path if self.line is None else f"{self.path}:{self.line}"
            where += ": "
        return f"{where}{self.message}"
