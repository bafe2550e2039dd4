"""One syntax for frame ranges and frame positions, shared by every ``mocapkit`` option.

* ``A:B`` -- 0-based frames A..B-1 (B excluded, like a Python slice); ``A:`` runs to the end,
  ``:B`` from the start, ``:`` is the whole take.
* ``1.5s:4.0s`` -- the same in seconds; each end becomes the frame nearest to ``t * fps``
  (frame k lies at ``k * frame_time``), so ``0s:2s`` at 30 fps is ``0:60``. Ends may mix units
  (``30:2.5s``).
* A single position, where an option takes one (``--takeoff 60``, ``--takeoff 2.0s``), is the
  one-frame range ``A:A+1``.

Negative frames are refused rather than read Python-style from the end: a take's length is not
always known to the person typing, and a silent wrap would cut the wrong frames.

Errors are :class:`RangeError` (a ValueError) with a one-line message that names the option and
what was expected, so the CLI prints it as is.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

__all__ = ["RangeError", "RangeSpec", "parse_frame", "parse_range"]

_END = re.compile(r"^\s*(?:(?P<frame>\d+)|(?P<sec>\d+(?:\.\d*)?|\.\d+)\s*s)\s*$", re.IGNORECASE)
_SYNTAX = "A:B (0-based frames, B excluded), A:, :B, or seconds such as 1.5s:4.0s"
_SYNTAX_CLOSED = "A:B (0-based frames, B excluded) or seconds such as 1.5s:4.0s"
_SYNTAX_ONE = "a frame (60) or a time (2.0s)"
_NOT_FROM_END = (
    "frames count from the take's start, not back from its end (its length: mocapkit info FILE)"
)


class RangeError(ValueError):
    """A range or frame that cannot be read or does not fit the take (one line)."""


@dataclass(frozen=True)
class _End:
    value: float
    seconds: bool

    def frame(self, fps: float) -> int:
        if not self.seconds:
            return int(self.value)
        x = self.value * fps
        # A time meant to sit on a frame (2.0 s at 29.97 fps) may miss it by rounding: snap.
        return math.floor(x + 0.5 + 1e-9)

    def __str__(self) -> str:
        return f"{self.value:g}s" if self.seconds else str(int(self.value))


def _parse_end(text: str) -> _End | None:
    m = _END.match(text)
    if m is None:
        return None
    if m.group("frame") is not None:
        return _End(float(int(m.group("frame"))), False)
    return _End(float(m.group("sec")), True)


@dataclass(frozen=True)
class RangeSpec:
    """A parsed range, not yet tied to a take: ``start``/``stop`` None for an open end.

    Build it with :meth:`parse` (syntax only, e.g. before any file is read), then turn it into
    frames with :meth:`frames` once the take's frame rate and length are known.
    """

    text: str
    start: _End | None
    stop: _End | None
    single: bool
    option: str

    @classmethod
    def parse(
        cls, text: str, option: str = "range", single: bool = False, closed: bool = False
    ) -> RangeSpec:
        """Read ``text``; with ``single=True`` a lone position (``60``, ``2.0s``) is accepted too
        and means that one frame; with ``closed=True`` both ends must be given (``A:``, ``:B``
        and ``:`` refused, and not offered in the messages). ``option`` names the option in
        error messages."""
        syntax = _SYNTAX_CLOSED if closed else _SYNTAX
        if not isinstance(text, str):
            raise RangeError(f"{option}: expected {syntax}, got {text!r}")
        s = text.strip()
        want = f"{_SYNTAX_ONE} or a range {syntax}" if single else syntax
        back = _NOT_FROM_END
        if ":" not in s:
            end = _parse_end(s) if single else None
            if end is None:
                if single and s.startswith("-") and _parse_end(s[1:]):
                    raise RangeError(f"{option}: expected {want}, got {text!r}: {back}")
                raise RangeError(f"{option}: expected {want}, got {text!r}")
            return cls(text, end, None, True, option)
        if s.count(":") != 1:
            raise RangeError(f"{option}: expected {want}, got {text!r}")
        lo_t, hi_t = s.split(":")
        lo = _parse_end(lo_t) if lo_t.strip() else None
        hi = _parse_end(hi_t) if hi_t.strip() else None
        if (lo_t.strip() and lo is None) or (hi_t.strip() and hi is None):
            if any(t.strip().startswith("-") and _parse_end(t.strip()[1:]) for t in (lo_t, hi_t)):
                raise RangeError(f"{option}: expected {want}, got {text!r}: {back}")
            for t in (lo_t.strip(), hi_t.strip()):  # a time without its s (newcomer: 2.0s:3.0)
                if t and _parse_end(t) is None and _parse_end(t + "s") is not None:
                    raise RangeError(
                        f"{option}: expected {want}, got {text!r}: {t!r} is no frame number "
                        f"(frames are whole numbers; a time ends in s: {t}s)"
                    )
            raise RangeError(f"{option}: expected {want}, got {text!r}")
        if closed and (lo is None or hi is None):
            raise RangeError(f"{option}: expected {want} with both ends given, got {text!r}")
        return cls(text, lo, hi, False, option)

    @classmethod
    def seconds(cls, start: float, stop: float | None = None, option: str = "range") -> RangeSpec:
        """The range ``start``-``stop`` seconds (None: to the end), as ``1.5s:4s`` reads (for
        the API, which takes numbers)."""
        if not all(math.isfinite(t) and t >= 0 for t in (start, 0.0 if stop is None else stop)):
            raise RangeError(f"{option}: expected times from 0 s on, got {start:g}:{stop}")
        text = f"{start:g}s:" + ("" if stop is None else f"{stop:g}s")
        end = None if stop is None else _End(float(stop), True)
        return cls(text, _End(float(start), True), end, False, option)

    def frames(self, fps: float, num_frames: int | None = None) -> tuple[int, int]:
        """``(start, stop)`` frames, stop excluded, for a take at ``fps`` of ``num_frames``
        frames (None: no upper bound is checked, for options whose takes are checked later).

        Refused: a reversed or empty range, and ends past the take."""
        lo = 0 if self.start is None else self.start.frame(fps)
        if (
            num_frames is not None
            and self.start is not None
            and self.start.seconds
            and lo == num_frames
            and self.start.value * fps < num_frames
            and (
                self.single
                or self.stop is None
                or (
                    self.stop.frame(fps) >= lo
                    and self.stop.value * (fps if self.stop.seconds else 1.0)
                    > self.start.value * fps
                )
            )
        ):  # a time in the last frame's span (6.49 s of a 6.5 s take) rounds past it
            lo = num_frames - 1
        if self.single:
            hi = lo + 1
        elif self.stop is None:
            if num_frames is None:
                raise RangeError(
                    f"{self.option} {self.text!r}: an open end needs the take's length"
                )
            hi = num_frames
        else:
            hi = self.stop.frame(fps)
        where = f"{self.option} {self.text.strip()!r}"
        # a start past the end says more than "reversed" (300: on a 300-frame take)
        if num_frames is not None and (lo >= num_frames or (lo < hi and hi > num_frames)):
            what = f"frame {lo}" if self.single else f"frames {lo}:{hi}"
            raise RangeError(
                f"{where}: {what} past the end of the take ({num_frames} frames, "
                f"{num_frames / fps:.4g} s at {fps:.4g} fps; expected within 0:{num_frames})"
            )
        if hi < lo:
            mixed = (
                self.start is not None
                and self.stop is not None
                and self.start.seconds != self.stop.seconds
            )
            hint = (
                f" ({self.start} and {self.stop} are in different units: {self.stop} is "
                f"{'a time' if self.stop.seconds else 'a frame number'})"
                if mixed
                else ""
            )
            raise RangeError(
                f"{where}: reversed range (frames {lo}:{hi}){hint}; expected A:B with A < B"
            )
        if hi == lo:
            raise RangeError(f"{where}: empty range (frames {lo}:{hi}); expected A:B with A < B")
        return lo, hi

    @property
    def in_seconds(self) -> bool:
        """Whether an end is given in seconds."""
        return any(e is not None and e.seconds for e in (self.start, self.stop))


def parse_range(
    text: str,
    fps: float,
    num_frames: int | None,
    option: str = "range",
    single: bool = False,
) -> tuple[int, int]:
    """``parse_range("1.5s:4.0s", 30, 300) == (45, 120)``: frames ``start..stop-1`` of a take
    at ``fps`` with ``num_frames`` frames (see the module notes; :class:`RangeError` otherwise)."""
    return RangeSpec.parse(text, option, single).frames(fps, num_frames)


def parse_frame(
    text: str, fps: float, num_frames: int | None, option: str = "frame", shown: str | None = None
) -> int:
    """One frame from ``60`` or ``2.0s`` (:class:`RangeError` for anything else). ``shown``:
    the whole argument the position is part of, named in messages (``--explain 'Head:99'``)."""
    end = _parse_end(text) if isinstance(text, str) else None
    where = option if shown is None else f"{option} {shown!r}"
    if end is None:  # a range or anything else: the message offers only what is taken here
        raise RangeError(f"{where}: expected {_SYNTAX_ONE}, got {text!r}")
    return RangeSpec(shown or text, end, None, True, option).frames(fps, num_frames)[0]
