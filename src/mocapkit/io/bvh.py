"""BVH reader and writer: lossless, fast, with clear errors.

Conventions: BVH stores Euler angles in **degrees**, in each joint's channel order, composed
intrinsically (``Zrotation Xrotation Yrotation`` means R = Rz @ Rx @ Ry). Inside mocapkit they
become unit quaternions w,x,y,z (see :mod:`mocapkit.core.motion`). ``Frame Time`` is kept as the
exact double parsed from the file and written back with the shortest text that round-trips.

Reading tolerates what real exporters write (tabs, CRLF or mixed line endings, blank lines in the
hierarchy, ``End Site`` with trailing tokens, 0/3/6 channels in any order per joint, exponents,
missing final newline). Anything that would make the result wrong raises :class:`BVHError` with the
file, the line and what was expected. ``lenient=True`` additionally repairs what is safe — a
``Frames:`` count that disagrees with the rows present, blank lines inside the motion block, a
truncated last row — and says so with a :class:`RepairWarning`.
"""

from __future__ import annotations

import collections
import functools
import math
import re
import warnings
from collections.abc import Iterator
from pathlib import Path

import numba
import numpy as np

from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion, fill_missing
from mocapkit.core.skeleton import POSITION_CHANNELS, ROTATION_CHANNELS, VALID_CHANNELS, Skeleton
from mocapkit.io import _numparse
from mocapkit.io.atomic import atomic_write_text
from mocapkit.io.errors import (
    BVHError,
    FilledFramesWarning,
    NonFiniteError,
    RepairWarning,
    decode_text,
    quote,
)

_TOKEN = re.compile(r"[{}]|[^\s{}]+")
_FRAMES = re.compile(r"frames\s*:\s*(\S*)\s*(.*)", re.IGNORECASE)
_FRAME_TIME = re.compile(r"frame\s+time\s*:\s*(\S*)\s*(.*)", re.IGNORECASE)


_MOTION_LINE = re.compile(rb"^[ \t]*MOTION[ \t\r]*$", re.IGNORECASE | re.MULTILINE)


class _Lines:
    """Tokens of the hierarchy (tokenised once), then a lazy line reader for the MOTION header,
    so the motion block itself is never split into Python lines."""

    def __init__(self, data: bytes, source: str) -> None:
        self.data = data
        self.source = source
        m = _MOTION_LINE.search(data)
        end = len(data) if m is None else m.end()
        header = decode_text(data[:end], source)
        lines = header.split("\n")
        self.header_lines = lines
        self._buf: collections.deque[tuple[str, int]] = collections.deque()
        self._iter: Iterator[re.Match[str]] | None = None
        self._iter_line = 0
        self._next_line = 0
        self.lineno = len(lines)  # line of the last hierarchy token (the MOTION line)
        self.pos = end + 1 if data[end : end + 1] == b"\n" else end

    def _fill(self) -> bool:
        """Tokenise lines lazily until a token is buffered (False at the end of the header):
        the token parser runs only on broken or unusual files, and stops at the first error,
        so a huge bad line is never split whole into Python strings."""
        while not self._buf:
            if self._iter is None:
                if self._next_line >= len(self.header_lines):
                    return False
                self._iter_line = self._next_line + 1
                self._iter = _TOKEN.finditer(self.header_lines[self._next_line])
                self._next_line += 1
            m = next(self._iter, None)
            if m is None:
                self._iter = None
                continue
            self._buf.append((m.group(), self._iter_line))
        return True

    def more_tokens(self) -> bool:
        return self._fill()

    def next_line(self) -> tuple[int, str] | None:
        if self.pos >= len(self.data):
            return None
        end = self.data.find(b"\n", self.pos)
        if end < 0:
            end = len(self.data)
        raw = self.data[self.pos : end]
        self.pos = end + 1
        self.lineno += 1
        return self.lineno, raw.decode("utf-8", errors="backslashreplace")

    def peek(self, expected: str) -> tuple[str, int]:
        if not self._fill():
            raise BVHError(self.source, self.lineno, f"unexpected end of file, expected {expected}")
        return self._buf[0]

    def take(self, expected: str) -> tuple[str, int]:
        tok = self.peek(expected)
        self._buf.popleft()
        return tok

    def rest_of_line(self, line: int, limit: int = 64) -> list[str]:
        """Remaining words on ``line`` up to a brace (consumed); more than ``limit`` words is an
        error (a name, a channel list or an offset never has that many)."""
        out = []
        while self._fill() and self._buf[0][1] == line and self._buf[0][0] not in "{}":
            out.append(self._buf.popleft()[0])
            if len(out) > limit:
                raise BVHError(
                    self.source,
                    line,
                    f"more than {limit} words on one line: {quote(' '.join(out))}",
                )
        return out

    def expect(self, word: str) -> int:
        tok, ln = self.take(f"'{word}'")
        if tok.upper() != word.upper():
            raise BVHError(self.source, ln, f"expected '{word}', found {quote(tok)}")
        return ln


def _number(tok: str, source: str, line: int, what: str) -> float:
    try:
        v = float(tok)
    except ValueError:
        raise BVHError(source, line, f"expected a number for {what}, found {quote(tok)}") from None
    if not np.isfinite(v):
        raise BVHError(source, line, f"{what} is {quote(tok)}; only finite numbers are allowed")
    return v


class _Hierarchy:
    def __init__(self) -> None:
        self.names: list[str] = []
        self.parents: list[int] = []
        self.offsets: list[list[float]] = []
        self.channels: list[tuple[str, ...]] = []
        self.lines: list[int] = []
        self.es_parents: list[int] = []
        self.es_offsets: list[list[float]] = []
        self.es_names: list[str] = []


def _parse_offset(lx: _Lines, what: str) -> list[float]:
    ln = lx.expect("OFFSET")
    vals = []
    for axis in "xyz":
        tok, tln = lx.peek(f"{axis} of the OFFSET of {what}")
        if tln != ln or tok in "{}":
            raise BVHError(lx.source, ln, f"OFFSET of {what} needs 3 numbers")
        lx.take("")
        vals.append(_number(tok, lx.source, ln, f"the OFFSET of {what}"))
    extra = lx.rest_of_line(ln)
    if extra:
        words = quote(" ".join(extra))
        raise BVHError(lx.source, ln, f"OFFSET of {what} has more than 3 numbers: {words}")
    return vals


def _open_joint(lx: _Lines, h: _Hierarchy, parent: int, name_line: int, name: str) -> int:
    """Read a joint's name, '{', OFFSET and CHANNELS; returns its index."""
    src = lx.source
    if not name:
        raise BVHError(src, name_line, "joint without a name")
    if name in h.names:
        raise BVHError(src, name_line, f"duplicate joint name {quote(name)}")
    j = len(h.names)
    h.names.append(name)
    h.parents.append(parent)
    h.lines.append(name_line)
    lx.expect("{")
    h.offsets.append(_parse_offset(lx, f"joint {quote(name)}"))
    tok, ln = lx.peek(f"CHANNELS or '}}' in joint {quote(name)}")
    channels: tuple[str, ...] = ()
    if tok.upper() == "CHANNELS":
        lx.take("")
        ntok, nln = lx.take("the channel count")
        try:
            n = int(ntok)
        except ValueError:
            raise BVHError(src, nln, f"expected the channel count, found {quote(ntok)}") from None
        names = lx.rest_of_line(ln)
        if n not in (0, 3, 6):
            raise BVHError(src, ln, f"joint {quote(name)}: CHANNELS {n}; expected 0, 3 or 6")
        if len(names) != n:
            raise BVHError(
                src, ln, f"joint {quote(name)}: CHANNELS {n} lists {len(names)} channel names"
            )
        canon = {c.lower(): c for c in VALID_CHANNELS}
        fixed = []
        for c in names:
            if c.lower() not in canon:
                raise BVHError(src, ln, f"joint {quote(name)}: unknown channel {quote(c)}")
            fixed.append(canon[c.lower()])
        channels = tuple(fixed)
        if len(set(channels)) != n:
            raise BVHError(src, ln, f"joint {quote(name)}: repeated channel in {channels}")
        nrot = sum(c in ROTATION_CHANNELS for c in channels)
        npos = sum(c in POSITION_CHANNELS for c in channels)
        if nrot not in (0, 3) or npos not in (0, 3):
            raise BVHError(
                src,
                ln,
                f"joint {quote(name)}: channels {channels} need all three rotations "
                "and/or all three positions",
            )
    h.channels.append(channels)
    return j


def _parse_joints(lx: _Lines, h: _Hierarchy, name_line: int, name: str) -> None:
    """The root joint and everything below it, with a stack of open joints (no recursion:
    rigs nest thousands of joints)."""
    src = lx.source
    stack = [_open_joint(lx, h, -1, name_line, name)]
    while stack:
        j = stack[-1]
        name = h.names[j]
        tok, ln = lx.take(f"JOINT, End Site or '}}' closing joint {quote(name)}")
        key = tok.upper()
        if key == "}":
            stack.pop()
        elif key == "JOINT":
            child = " ".join(lx.rest_of_line(ln))
            stack.append(_open_joint(lx, h, j, ln, child))
        elif key == "END":
            site = lx.rest_of_line(ln)
            if not site or not site[0].upper().startswith("SITE"):
                raise BVHError(
                    src, ln, f"expected 'End Site', found {quote('End ' + ' '.join(site))}"
                )
            label = " ".join(site[1:])
            lx.expect("{")
            off = _parse_offset(lx, f"the End Site of {quote(name)}")
            lx.expect("}")
            h.es_parents.append(j)
            h.es_offsets.append(off)
            h.es_names.append(label)
        else:
            raise BVHError(
                src,
                ln,
                f"expected JOINT, End Site or '}}' in joint {quote(name)}, found {quote(tok)}",
            )


_FAST_LINE_LIMIT = 10_000
_CANON = {c.lower(): c for c in VALID_CHANNELS}


@functools.lru_cache(maxsize=256)
def _channel_layout(tokens: tuple[str, ...]) -> tuple[str, ...] | None:
    """("6", "Xposition", ...) -> canonical channel names, or None if not a valid layout.
    Cached: a file repeats the same few CHANNELS lines for every joint."""
    if not tokens:
        return None
    try:
        chans = tuple(_CANON[c.lower()] for c in tokens[1:])
    except KeyError:
        return None
    n = len(chans)
    nrot = sum(c in ROTATION_CHANNELS for c in chans)
    if tokens[0] != str(n) or len(set(chans)) != n or nrot not in (0, 3) or n - nrot not in (0, 3):
        return None
    return chans


def _fast_hierarchy(lines: list[str]) -> _Hierarchy | None:
    """Line-based parse of a well-formed hierarchy (the common case), or None.

    One keyword per line, braces alone on their lines. Anything unusual — or anything wrong —
    returns None and the token parser (:func:`_parse_joint`, the reference) takes over; it
    gives the same result on good input and the precise error on bad input.
    """
    h = _Hierarchy()
    stack: list[int] = []  # open joints; -2 marks an open End Site
    opening: tuple[str, str] | None = None  # ("joint", name) or ("site", label) awaiting "{"
    seen_root = closed = motion_seen = False
    names: set[str] = set()
    has_channels: set[int] = set()
    for line in lines:
        if len(line) > _FAST_LINE_LIMIT:
            return None  # no well-formed hierarchy line is this long: let the token parser say why
        parts = line.split()
        if not parts:
            continue
        if (closed and not motion_seen and parts[0].upper() != "MOTION") or motion_seen:
            return None  # text after the root closed (a second ROOT?) or after MOTION
        key = parts[0].upper()
        if opening is not None:
            if parts != ["{"]:
                return None
            kind, label = opening
            opening = None
            if kind == "site":
                stack.append(-2)
            else:
                if label in names or not label or "{" in label or "}" in label:
                    return None
                names.add(label)
                h.parents.append(stack[-1] if stack else -1)
                h.names.append(label)
                h.channels.append(())
                h.offsets.append([])
                stack.append(len(h.names) - 1)
            continue
        if key == "HIERARCHY" and len(parts) == 1 and not h.names and not seen_root:
            continue
        if key == "ROOT" or key == "JOINT":
            if (key == "ROOT") == (seen_root or bool(stack)) or (stack and stack[-1] < 0):
                return None
            seen_root = True
            opening = ("joint", " ".join(parts[1:]))
        elif key == "END":
            if len(parts) < 2 or not parts[1].upper().startswith("SITE") or not stack:
                return None
            if stack[-1] < 0 or "{" in line or "}" in line:
                return None
            h.es_parents.append(stack[-1])
            h.es_names.append(" ".join(parts[2:]))
            h.es_offsets.append([])
            opening = ("site", "")
        elif key == "OFFSET":
            if len(parts) != 4 or not stack:
                return None
            try:
                off = [float(parts[1]), float(parts[2]), float(parts[3])]
            except ValueError:
                return None
            if not all(map(math.isfinite, off)):
                return None
            target = h.es_offsets[-1] if stack[-1] < 0 else h.offsets[stack[-1]]
            if target:
                return None
            target.extend(off)
        elif key == "CHANNELS":
            if not stack or stack[-1] < 0 or stack[-1] in has_channels or not h.offsets[stack[-1]]:
                return None
            has_channels.add(stack[-1])
            chans = _channel_layout(tuple(parts[1:]))
            if chans is None:
                return None
            h.channels[stack[-1]] = chans
        elif key == "}":
            if len(parts) != 1 or not stack:
                return None
            top = stack.pop()
            if (h.es_offsets[-1] if top < 0 else h.offsets[top]) == []:
                return None
            if not stack:
                closed = True
        elif key == "MOTION" and closed and len(parts) == 1:
            motion_seen = True
        else:
            return None
    return h if closed and motion_seen else None


def _channel_columns(
    sk: Skeleton,
) -> tuple[list[tuple[int, list[int]]], list[tuple[int, list[int]]]]:
    """Per joint: column indices of its rotation channels (file order) and of X,Y,Z position."""
    rot_cols, pos_cols = [], []
    c = 0
    for j, ch in enumerate(sk.channels):
        cols = {name: c + i for i, name in enumerate(ch)}
        c += len(ch)
        r = [cols[n] for n in ch if n in ROTATION_CHANNELS]
        if r:
            rot_cols.append((j, r))
        if "Xposition" in cols:
            pos_cols.append((j, [cols["Xposition"], cols["Yposition"], cols["Zposition"]]))
    return rot_cols, pos_cols


@numba.njit(cache=True, nogil=True)
def _channels_kernel(  # pragma: no cover - compiled
    values, rot_cols, rot_axes, pos_cols, offsets, rotations, translations
):
    """Fill local rotations (F, J, 4) and translations (F, Jt, 3) from BVH channel values.

    Joint j rotates by q_ax0(v0) q_ax1(v1) q_ax2(v2) (degrees, intrinsic, w,x,y,z) with
    rot_cols[j] < 0 meaning "no rotation channels" (identity); its translation comes from the
    position columns pos_cols[j] (< 0: its OFFSET). Only the first Jt joints get translations
    (Jt = 1 when only the root may move). The fast twin of ``rotations.euler_to_quat``.
    """
    half = np.pi / 360.0
    F, J = rotations.shape[0], rotations.shape[1]
    Jt = translations.shape[1]
    for f in range(F):
        for j in range(J):
            w, x, y, z = 1.0, 0.0, 0.0, 0.0
            if rot_cols[j, 0] >= 0:
                for i in range(3):
                    a = values[f, rot_cols[j, i]] * half
                    c, s = np.cos(a), np.sin(a)
                    ax = rot_axes[j, i]
                    # (w,x,y,z) * (c, s*e_ax)
                    if ax == 0:
                        w, x, y, z = w * c - x * s, x * c + w * s, y * c + z * s, z * c - y * s
                    elif ax == 1:
                        w, x, y, z = w * c - y * s, x * c - z * s, y * c + w * s, z * c + x * s
                    else:
                        w, x, y, z = w * c - z * s, x * c + y * s, y * c - x * s, z * c + w * s
            rotations[f, j, 0] = w
            rotations[f, j, 1] = x
            rotations[f, j, 2] = y
            rotations[f, j, 3] = z
        for j in range(Jt):
            for i in range(3):
                c = pos_cols[j, i]
                translations[f, j, i] = values[f, c] if c >= 0 else offsets[j, i]


def channels_to_motion(sk: Skeleton, values: np.ndarray, frame_time: float) -> Motion:
    """Turn a (F, C) block of BVH channel values (degrees, file units) into a Motion."""
    F = values.shape[0]
    J = sk.num_joints
    rot_cols = np.full((J, 3), -1, dtype=np.int64)
    rot_axes = np.zeros((J, 3), dtype=np.int64)
    pos_cols = np.full((J, 3), -1, dtype=np.int64)
    c = 0
    for j, ch in enumerate(sk.channels):
        r = 0
        for name in ch:
            if name in ROTATION_CHANNELS:
                rot_cols[j, r] = c
                rot_axes[j, r] = "XYZ".index(name[0])
                r += 1
            else:
                pos_cols[j, "XYZ".index(name[0])] = c
            c += 1
    moving = [j for j in range(1, J) if pos_cols[j, 0] >= 0]
    Jt = J if moving else 1
    rotations = np.empty((F, J, 4))
    translations = np.empty((F, Jt, 3))
    _channels_kernel(
        np.ascontiguousarray(values, dtype=np.float64),
        rot_cols,
        rot_axes,
        pos_cols,
        sk.offsets,
        rotations,
        translations,
    )
    root_positions = translations[:, 0].copy()
    return Motion(sk, rotations, root_positions, frame_time, translations if moving else None)


def _parse_hierarchy(lx: _Lines, source: str) -> _Hierarchy:
    """The reference (token-based) hierarchy parser, with precise errors."""
    tok, ln = lx.take("'HIERARCHY'")
    if tok.upper() != "HIERARCHY":
        raise BVHError(
            source, ln, f"expected 'HIERARCHY' at the start of a BVH file, found {quote(tok)}"
        )
    tok, ln = lx.take("'ROOT'")
    if tok.upper() != "ROOT":
        raise BVHError(source, ln, f"expected 'ROOT', found {quote(tok)}")
    h = _Hierarchy()
    _parse_joints(lx, h, ln, " ".join(lx.rest_of_line(ln)))
    tok, ln = lx.take("'MOTION' after the hierarchy")
    if tok.upper() == "ROOT":
        raise BVHError(source, ln, "a second ROOT: files with several skeletons are not supported")
    if tok.upper() != "MOTION":
        raise BVHError(source, ln, f"expected 'MOTION' after the hierarchy, found {quote(tok)}")
    if lx.more_tokens():
        raise BVHError(source, ln, f"unexpected text after MOTION: {quote(lx.peek('')[0])}")
    return h


def parse_bvh(data: bytes | str, source: str = "<string>", lenient: bool = False) -> Motion:
    """Parse BVH text (bytes or str) into a Motion; ``source`` names it in errors."""
    if isinstance(data, str):
        data = data.encode("utf-8")
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    lx = _Lines(data, source)
    h = _fast_hierarchy(lx.header_lines)
    if h is None:
        h = _parse_hierarchy(lx, source)
    try:
        sk = Skeleton(
            h.names, h.parents, h.offsets, h.channels, h.es_parents, h.es_offsets, h.es_names
        )
    except ValueError as e:  # pragma: no cover - the parser checks these first
        raise BVHError(source, None, str(e)) from None

    def header_line(pattern: re.Pattern[str], what: str) -> tuple[int, str, str]:
        while True:
            got = lx.next_line()
            if got is None:
                raise BVHError(source, lx.lineno, f"unexpected end of file, expected '{what}'")
            n, text = got
            if text.strip():
                break
        m = pattern.fullmatch(text.strip())
        if not m or not m.group(1):
            raise BVHError(source, n, f"expected '{what} <value>', found {quote(text.strip())}")
        if m.group(2):
            raise BVHError(source, n, f"unexpected text after {what}: {quote(m.group(2))}")
        return n, m.group(1), text

    fl, ftok, _ = header_line(_FRAMES, "Frames:")
    try:
        declared = int(ftok)
        if declared < 0:
            raise ValueError
    except ValueError:
        raise BVHError(
            source, fl, f"Frames: expects a whole number >= 0, found {quote(ftok)}"
        ) from None
    tl, ttok, _ = header_line(_FRAME_TIME, "Frame Time:")
    frame_time = _number(ttok, source, tl, "Frame Time")
    if frame_time <= 0:
        raise BVHError(source, tl, f"Frame Time must be positive, found {quote(ttok)}")

    block = memoryview(data)[min(lx.pos, len(data)) :]
    first_data_line = lx.lineno + 1
    ncols = sk.num_channels
    res = _numparse.parse_rows(block, ncols, allow_nan=lenient)
    values = res.values
    if res.status != _numparse.OK:
        line = first_data_line + res.err_line
        rest = bytes(block[res.err_offset :])
        nl = rest.find(b"\n")
        is_last_row = nl < 0 or not rest[nl + 1 :].strip()
        truncated_tail = res.status == _numparse.BAD_COUNT and res.err_count < ncols and is_last_row
        if lenient and truncated_tail:
            warnings.warn(
                f"{source}:{line}: dropped the incomplete last row ({res.err_count} of {ncols} "
                "values)",
                RepairWarning,
                stacklevel=2,
            )
            res = _numparse.parse_rows(block[: res.err_offset], ncols, allow_nan=True)
            values = res.values
        elif res.status == _numparse.BAD_COUNT:
            # lenient reading drops only an incomplete last row: inside the data, which of the
            # channels is missing cannot be told, so every later value would be misread
            if lenient:
                why = (
                    " (lenient reading repairs only an incomplete last row: in a row inside the "
                    "data the missing channel cannot be told)"
                )
            elif truncated_tail:  # newcomer: the hint the blank-line error gives, here too
                why = " (lenient reading, --lenient, drops an incomplete last row)"
            else:
                why = ""
            raise BVHError(
                source,
                line,
                # frames count from 0, as every frame option and report does
                f"frame {res.values.shape[0]} has {res.err_count} values; "
                f"the hierarchy declares {ncols} channels{why}",
            )
        elif res.status == _numparse.OVERFLOW:
            raise BVHError(
                source,
                line,
                f"value {res.err_col + 1} is beyond the range of a double (about 1.8e308)",
            )
        elif res.status == _numparse.NON_FINITE:
            raise NonFiniteError(
                source,
                line,
                f"value {res.err_col + 1} is NaN or infinite (lenient reading, --lenient, "
                "fills such gaps from the neighbouring frames)",
            )
        else:
            bad = bytes(block[res.err_offset :]).split(b"\n", 1)[0].split()
            tokv = bad[res.err_col].decode("utf-8", "replace") if res.err_col < len(bad) else "?"
            raise BVHError(source, line, f"value {res.err_col + 1} is not a number: {quote(tokv)}")
    if res.first_inner_blank_line >= 0:
        line = first_data_line + res.first_inner_blank_line
        if not lenient:
            raise BVHError(
                source,
                line,
                "blank line inside the motion data (lenient reading, --lenient, skips blank lines)",
            )
        warnings.warn(
            f"{source}:{line}: skipped blank line(s) inside the motion data",
            RepairWarning,
            stacklevel=2,
        )
    rows = values.shape[0]
    if rows != declared:
        rows_follow = f"{rows} row{'s' * (rows != 1)} of motion data follow{'s' * (rows == 1)}"
        msg = f"{quote('Frames: ' + str(declared))} but {rows_follow}"
        if not lenient:
            raise BVHError(
                source, fl, msg + " (lenient reading, --lenient, reads the rows present)"
            )
        warnings.warn(
            f"{source}:{fl}: {msg}; read {rows} frame{'s' * (rows != 1)}",
            RepairWarning,
            stacklevel=2,
        )
    motion = channels_to_motion(sk, values, frame_time)
    if lenient and not np.all(np.isfinite(values)):
        bad_rows = np.flatnonzero(~np.all(np.isfinite(values), axis=1))
        motion, joints = fill_missing(motion)
        line = first_data_line + _row_line(data, min(lx.pos, len(data)), int(bad_rows[0]))
        n_bad = int(np.sum(~np.isfinite(values)))
        cut = np.flatnonzero(np.diff(bad_rows) > 1) + 1  # the runs of consecutive bad rows
        spans = [(int(r[0]), int(r[-1]) + 1) for r in np.split(bad_rows, cut)]
        warnings.warn(
            FilledFramesWarning(
                f"{source}:{line}: {n_bad} NaN/inf value{'s' * (n_bad != 1)} in {len(bad_rows)} "
                f"row{'s' * (len(bad_rows) != 1)} from here (frames "
                f"{', '.join(f'{x}:{y}' for x, y in spans)}; joints {', '.join(joints)}) filled "
                "from neighbouring frames",
                spans,
            ),
            stacklevel=2,
        )
    return motion


def _row_line(data: bytes, start: int, row: int) -> int:
    """The line (0-based, counted from offset ``start`` of ``data``, the motion data's first
    line) of its row ``row``: the parser skips blank lines, so rows and lines differ by the
    blank lines before it. Reads only up to that row, without copying the data."""
    seen, line, pos = -1, 0, start
    while pos <= len(data):
        end = data.find(b"\n", pos)
        end = len(data) if end < 0 else end
        if data[pos:end].strip():
            seen += 1
            if seen == row:
                return line
        line, pos = line + 1, end + 1
    return 0


def read_bvh(path: str | Path, lenient: bool = False) -> Motion:
    """Read a BVH file. Raises :class:`BVHError` (file, line, problem) on malformed input."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise BVHError(path, None, f"cannot read file: {e.strerror or e}") from None
    return parse_bvh(data, str(path), lenient=lenient)


# ---------------------------------------------------------------------------------------------
# writing


ANGLE_DECIMALS = 12
"""Decimals of degrees a written rotation channel keeps (1.7e-14 rad)."""


def format_number(x: float) -> str:
    """Shortest text that reads back as exactly ``x`` (used for Frame Time)."""
    return repr(float(x))


def motion_to_channels(motion: Motion) -> np.ndarray:
    """The (F, C) channel block (degrees, file units) for the motion's skeleton layout."""
    sk = motion.skeleton
    F = motion.num_frames
    out = np.zeros((F, sk.num_channels))
    rot_cols, pos_cols = _channel_columns(sk)
    by_order: dict[str, list[tuple[int, list[int]]]] = {}
    for j, cols in rot_cols:
        by_order.setdefault(sk.rotation_order(j), []).append((j, cols))
    for order, items in by_order.items():
        joints = [j for j, _ in items]
        cols = np.array([c for _, c in items])
        angles = np.rad2deg(rot.quat_to_euler(motion.rotations[:, joints], order))
        # to 1e-12 deg: the quaternion round trip leaves ~1e-14 deg of rounding, which printed
        # to 12 digits turned a file's -5.69484e-05 into -5.69483999995e-05 (far below any
        # capture's precision, but not the text the file had)
        out[:, cols] = np.round(angles, ANGLE_DECIMALS)
    trans = motion.local_translations()
    for j, cols in pos_cols:
        out[:, cols] = trans[:, j]
    return out


def _with_needed_channels(motion: Motion) -> Motion:
    """Add the channels the data needs but the layout lacks, so nothing is silently dropped:
    rotation channels for a joint that rotates without any, position channels for a root that
    moves away from its OFFSET (e.g. after a ground-plane alignment of a 0-channel root)."""
    sk = motion.skeleton
    if motion.num_frames == 0:
        return motion
    channels = list(sk.channels)
    ident = np.abs(motion.rotations[..., 0]) >= 1.0 - 1e-15  # (F, J): identity rotation
    for j in np.flatnonzero(~sk.has_rotation & ~ident.all(axis=0)):
        rot_first = bool(channels[j]) and channels[j][0] in ROTATION_CHANNELS
        new = tuple(f"{a}rotation" for a in "ZXY")
        channels[j] = new + tuple(channels[j]) if not rot_first else tuple(channels[j]) + new
    if not sk.has_position[0] and not np.allclose(
        motion.root_positions, sk.offsets[0], rtol=0, atol=1e-12
    ):
        channels[0] = POSITION_CHANNELS + tuple(channels[0])
    if channels == list(sk.channels):
        return motion
    return motion.with_skeleton(sk.with_channels(channels))


def _fmt_offset(v: np.ndarray, digits: int) -> str:
    return " ".join(f"{x:.{digits}g}" for x in v)


def format_bvh(motion: Motion, order: str | None = None, digits: int = 12) -> str:
    """BVH text for a motion; ``order`` (e.g. "ZYX") rewrites every joint's rotation order.

    ``digits`` significant digits per value: 12 keeps rotations to ~1e-10 rad and positions to
    1e-6 of values up to 1e6 units, which is what a read -> write -> read round trip needs.
    """
    motion.check_finite("cannot write BVH")
    if order is not None:
        motion = motion.with_skeleton(motion.skeleton.with_rotation_order(order))
    motion = _with_needed_channels(motion)
    sk = motion.skeleton
    out: list[str] = ["HIERARCHY"]
    kids: dict[int, list[int]] = {}
    for j, p in enumerate(sk.parents):
        kids.setdefault(int(p), []).append(j)
    sites: dict[int, list[int]] = {}
    for e, p in enumerate(sk.end_site_parents):
        sites.setdefault(int(p), []).append(e)
    off_digits = max(digits, 15)

    # smallest End Site index in each joint's subtree (None if it has none); children come
    # after their parents, so one backward pass carries it up
    first_site: list[int | None] = [None] * sk.num_joints
    for e, p in enumerate(sk.end_site_parents):
        j = int(p)
        if first_site[j] is None or e < first_site[j]:
            first_site[j] = e
    for j in range(sk.num_joints - 1, 0, -1):
        p, f = int(sk.parents[j]), first_site[j]
        if f is not None and (first_site[p] is None or f < first_site[p]):
            first_site[p] = f

    def end_site(e: int, ind: str) -> None:
        label = sk.end_site_names[e]
        out.append(f"{ind}  End Site" + (f" {label}" if label else ""))
        out.append(f"{ind}  {{")
        out.append(f"{ind}    OFFSET {_fmt_offset(sk.end_site_offsets[e], off_digits)}")
        out.append(f"{ind}  }}")

    def open_joint(j: int, depth: int) -> list[tuple[str, int, int]]:
        """Write a joint's header; return what follows it, in file order."""
        ind = "  " * depth
        out.append(f"{ind}{'ROOT' if j == 0 else 'JOINT'} {sk.names[j]}")
        out.append(f"{ind}{{")
        out.append(f"{ind}  OFFSET {_fmt_offset(sk.offsets[j], off_digits)}")
        ch = sk.channels[j]
        out.append(f"{ind}  CHANNELS {len(ch)}" + "".join(f" {c}" for c in ch))
        # Merge child joints and End Sites so both keep their file order: an End Site goes
        # before a child joint whose subtree holds a later End Site (e.g. "End Site" then
        # "JOINT Toe" under an ankle, as some exporters write).
        items: list[tuple[str, int, int]] = []
        pending = list(sites.get(j, []))
        for c in kids.get(j, []):
            first = first_site[c]
            while pending and first is not None and pending[0] < first:
                items.append(("site", pending.pop(0), depth))
            items.append(("joint", c, depth + 1))
        items += [("site", e, depth) for e in pending]
        items.append(("close", j, depth))
        return items

    # an explicit stack instead of recursion: rigs nest thousands of joints
    stack = open_joint(0, 0)[::-1]
    while stack:
        kind, k, depth = stack.pop()
        if kind == "joint":
            stack += open_joint(k, depth)[::-1]
        elif kind == "site":
            end_site(k, "  " * depth)
        else:
            out.append(f"{'  ' * depth}}}")
    out.append("MOTION")
    out.append(f"Frames: {motion.num_frames}")
    out.append(f"Frame Time: {format_number(motion.frame_time)}")
    values = motion_to_channels(motion)
    values[values == 0] = 0.0  # no "-0"
    if values.shape[1]:
        row_fmt = " ".join([f"%.{digits}g"] * values.shape[1])
        out.extend(row_fmt % tuple(r) for r in values.tolist())
    else:
        out.extend("" for _ in range(values.shape[0]))
    return "\n".join(out) + "\n"


BVH_UNITS_M = (1.0, 0.01, 0.001, 0.0254)
"""The units other tools read a BVH file in (m, cm, mm, inch): a BVH file cannot state its unit."""


def write_bvh(motion: Motion, path: str | Path, order: str | None = None, digits: int = 12) -> Path:
    """Write a motion as BVH atomically (temp file + rename). Returns the path.

    Warns when the take's unit is known and is none that BVH readers assume (a CMU ASF's
    0.0564444 m): the numbers are written as they are, and the reader will guess."""
    mpu = motion.skeleton.metres_per_unit
    # within 1e-6: a --scale typed with seven digits (5.644444) does reach centimetres
    if mpu is not None and not any(abs(mpu / u - 1) < 1e-6 for u in BVH_UNITS_M):
        warnings.warn(  # naming the file: a folder job writes many, warned at its end
            f"{path}: the take's unit ({mpu:g} m, from its source) cannot be stated in a BVH file, "
            "which other tools will read as inch or cm (mocapkit guesses it back from the "
            "height); to keep it, write .npz, or convert the source to a unit BVH readers "
            "know first (`mocapkit convert SOURCE SOURCE_cm.bvh --units cm`; or m, "
            "inch) and work on that",
            UserWarning,
            stacklevel=2,
        )
    return atomic_write_text(path, format_bvh(motion, order=order, digits=digits))
