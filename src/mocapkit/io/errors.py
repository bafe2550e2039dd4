"""Errors and warnings raised by mocapkit's file readers."""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from pathlib import Path

#: Offending text is quoted up to this many characters in messages (a 50 MB line or 16 KB of NUL
#: padding would otherwise become the message).
QUOTE_LIMIT = 80


def quote(text: object, limit: int = QUOTE_LIMIT) -> str:
    """``repr`` of ``text`` cut to about ``limit`` characters, its closing quote kept."""
    r = repr(str(text))
    if len(r) <= limit:
        return r
    return r[: limit - 2] + "…" + r[0]


class DecodingWarning(UserWarning):
    """A file was not UTF-8: its text was decoded with a stated fallback encoding."""


def decode_text(data: bytes, source: str) -> str:
    """Text of a file's bytes: UTF-8; else Shift-JIS (cp932, as Japanese exporters write) when
    that decoding holds kana or kanji; else latin-1 (which decodes any byte). A fallback is
    announced with a :class:`DecodingWarning` naming the encoding, never silently replaced by
    U+FFFD. (Latin-1 accents also decode as cp932, but as half-width katakana: that alone does
    not make a file Japanese.)"""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        first_bad = e.start
    enc = "latin-1"
    try:
        sjis = data.decode("cp932")
    except UnicodeDecodeError:
        pass
    else:
        if any("\u3040" <= c <= "\u9fff" for c in sjis):
            enc = "cp932"
    warnings.warn(
        f"{source}: not UTF-8 (byte {first_bad}); decoded as {enc}", DecodingWarning, stacklevel=3
    )
    return sjis if enc == "cp932" else data.decode("latin-1")


class MocapFileError(ValueError):
    """A file could not be read: names the file, the 1-based line (when known) and the problem."""

    def __init__(self, source: str | Path, line: int | None, message: str) -> None:
        self.source = str(source)
        self.line = line
        if len(message) > 4 * QUOTE_LIMIT:  # a safety net; messages quote with quote()
            message = message[: 4 * QUOTE_LIMIT] + "…"
        self.message = message
        where = f"{self.source}:{line}" if line is not None else self.source
        super().__init__(f"{where}: {message}")


class BVHError(MocapFileError):
    """Malformed BVH input."""


class NonFiniteError(BVHError):
    """A BVH value is NaN or infinite (a solver's dropout): lenient reading fills such frames
    (:class:`FilledFramesWarning`); a caller about to replace those frames may read it so."""


class ASFAMCError(MocapFileError):
    """Malformed ASF or AMC input."""


class RepairWarning(UserWarning):
    """A lenient reader repaired something in the input; the message says what."""


class FilledFramesWarning(RepairWarning):
    """A lenient reader filled frames holding NaN or infinite values from their neighbours:
    ``frames``, the ``(start, stop)`` spans (0-based, stop excluded) of the frames filled."""

    def __init__(self, message: str, frames: list[tuple[int, int]]) -> None:
        super().__init__(message)
        self.frames = frames


NUMPY_NOISE = ("overflow encountered", "invalid value encountered", "divide by zero")
"""numpy RuntimeWarnings about intermediate values: not shown (what they cause is reported
where it matters, e.g. non-finite JSON values become null with a warning)."""


def warning_lines(caught: Iterable[warnings.WarningMessage]) -> list[str]:
    """The warnings ``caught`` (``warnings.catch_warnings(record=True)``) as a user reads them,
    each once, in order: ``repaired: ...`` (:class:`RepairWarning`) or ``warning: ...``, on one
    line; numpy's intermediate-value noise and deprecations left out. What the CLI prints
    (after ``mocapkit: ``) and what a JSON result or report carries as ``warnings``."""
    lines: list[str] = []
    for w in caught:
        text = " ".join(str(w.message).split())
        if issubclass(w.category, RuntimeWarning) and text.startswith(NUMPY_NOISE):
            continue
        if issubclass(w.category, (DeprecationWarning, PendingDeprecationWarning)):
            continue
        kind = "repaired" if issubclass(w.category, RepairWarning) else "warning"
        line = f"{kind}: {text}"
        if line not in lines:
            lines.append(line)
    return lines
