"""Errors and warnings raised by mocapkit's file readers."""

from __future__ import annotations

from pathlib import Path


class MocapFileError(ValueError):
    """A file could not be read: names the file, the 1-based line (when known) and the problem."""

    def __init__(self, source: str | Path, line: int | None, message: str) -> None:
        self.source = str(source)
        self.line = line
        self.message = message
        where = f"{self.source}:{line}" if line is not None else self.source
        super().__init__(f"{where}: {message}")


class BVHError(MocapFileError):
    """Malformed BVH input."""


class ASFAMCError(MocapFileError):
    """Malformed ASF or AMC input."""


class RepairWarning(UserWarning):
    """A lenient reader repaired something in the input; the message says what."""
