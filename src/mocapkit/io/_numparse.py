"""Fast parser for the BVH motion block: whitespace-separated decimal numbers, one row per line.

The public entry point is :func:`parse_rows`; the numba kernel ``_parse_kernel`` behind it walks the
bytes once. Numbers with at most 15 significant digits and a decimal exponent within ±22 (every
real mocap value) are converted exactly by Clinger's fast path (m * 10^e with both factors exact
doubles, so the one multiplication is correctly rounded); the rare longer ones are re-read with
Python's ``float`` so that every value is the correctly rounded double, as ``float(text)`` gives.
The readable reference it is tested against is ``numpy.array(text.split(), float)`` per line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

OK, BAD_COUNT, BAD_NUMBER, NON_FINITE, OVERFLOW = 0, 1, 2, 3, 4

_POW10 = np.array([10.0**i for i in range(23)])
_SLOW_CAPACITY = 256


@numba.njit(cache=True, nogil=True)
def _parse_kernel(buf, ncols, out, slow_pos, pow10, allow_nan):  # pragma: no cover - compiled
    """Parse rows of ``ncols`` numbers from uint8 ``buf`` into flat float64 ``out``.

    Returns (status, nrows, err_line, err_col, err_count, first_inner_blank_line,
    nslow, err_line_start). Lines are counted from 0 at the start of ``buf``; blank lines are
    skipped but the first blank line followed by more data is reported.
    """
    n = buf.shape[0]
    pos = 0
    line = 0
    row = 0
    nslow = 0
    pending_blank = -1
    first_inner_blank = -1
    while pos < n:
        line_start = pos
        col = 0
        base = row * ncols
        while True:
            # skip separators within the line
            while pos < n and (buf[pos] == 32 or buf[pos] == 9 or buf[pos] == 13):
                pos += 1
            if pos >= n or buf[pos] == 10:
                break
            tok_start = pos
            neg = False
            c = buf[pos]
            if c == 45 or c == 43:  # '-' '+'
                neg = c == 45
                pos += 1
            mant = 0
            ndig = 0
            exp10 = 0
            seen_digit = False
            slow = False
            while pos < n and buf[pos] == 48:  # leading zeros: no significant digit
                seen_digit = True
                pos += 1
            while pos < n and 48 <= buf[pos] <= 57:
                seen_digit = True
                if ndig < 18:
                    mant = mant * 10 + (buf[pos] - 48)
                    ndig += 1
                else:
                    exp10 += 1
                    slow = True
                pos += 1
            if pos < n and buf[pos] == 46:  # '.'
                pos += 1
                if mant == 0:
                    while pos < n and buf[pos] == 48:
                        seen_digit = True
                        exp10 -= 1
                        pos += 1
                while pos < n and 48 <= buf[pos] <= 57:
                    seen_digit = True
                    if ndig < 18:
                        mant = mant * 10 + (buf[pos] - 48)
                        ndig += 1
                        exp10 -= 1
                    else:
                        slow = True
                    pos += 1
            if seen_digit and pos < n and (buf[pos] == 101 or buf[pos] == 69):  # e E
                pos += 1
                eneg = False
                if pos < n and (buf[pos] == 45 or buf[pos] == 43):
                    eneg = buf[pos] == 45
                    pos += 1
                if pos >= n or not (48 <= buf[pos] <= 57):
                    seen_digit = False
                e = 0
                while pos < n and 48 <= buf[pos] <= 57:
                    if e < 100000:
                        e = e * 10 + (buf[pos] - 48)
                    pos += 1
                exp10 += -e if eneg else e
            # the token must end at a separator
            if not seen_digit or (
                pos < n
                and not (buf[pos] == 32 or buf[pos] == 9 or buf[pos] == 13 or buf[pos] == 10)
            ):
                # classify nan/inf for a clearer message
                q = tok_start
                while q < n and not (buf[q] == 32 or buf[q] == 9 or buf[q] == 13 or buf[q] == 10):
                    q += 1
                status = 2
                k = tok_start
                if k < q and (buf[k] == 45 or buf[k] == 43):
                    k += 1
                if q - k >= 3:
                    c0 = buf[k] | 32
                    c1 = buf[k + 1] | 32
                    c2 = buf[k + 2] | 32
                    if (c0 == 110 and c1 == 97 and c2 == 110) or (
                        c0 == 105 and c1 == 110 and c2 == 102
                    ):
                        status = 3
                if status == 3 and allow_nan:
                    if col < ncols:
                        out[base + col] = np.nan
                    col += 1
                    pos = q
                    continue
                return status, row, line, col, 0, first_inner_blank, nslow, line_start
            if col < ncols:
                if ndig > 15 or exp10 > 22 or exp10 < -22:
                    slow = True
                if slow:
                    if nslow < slow_pos.shape[0]:
                        slow_pos[nslow, 0] = base + col
                        slow_pos[nslow, 1] = tok_start
                        slow_pos[nslow, 2] = pos
                    nslow += 1
                    v = 0.0
                elif exp10 >= 0:
                    v = mant * pow10[exp10]
                else:
                    v = mant / pow10[-exp10]
                out[base + col] = -v if neg else v
            col += 1
        # end of line
        if col == 0:
            if pending_blank < 0:
                pending_blank = line
        else:
            if pending_blank >= 0 and first_inner_blank < 0:
                first_inner_blank = pending_blank
            pending_blank = -1
            if col != ncols:
                return 1, row, line, col, col, first_inner_blank, nslow, line_start
            row += 1
        pos += 1  # skip '\n'
        line += 1
    return 0, row, line, 0, 0, first_inner_blank, nslow, n


@numba.njit(cache=True, nogil=True)
def _count_newlines(buf):  # pragma: no cover - compiled
    # no temporary (buf == 10) array: fresh large allocations cost page faults on every file
    n = 0
    for c in buf:
        if c == 10:
            n += 1
    return n


@dataclass
class ParseResult:
    """Outcome of :func:`parse_rows`.

    ``values`` is (rows, ncols) float64 holding the rows parsed before any error. ``status`` is
    OK or the error kind; ``err_line`` (0-based, relative to the block), ``err_col`` and
    ``err_count`` describe it; ``err_offset`` is the byte offset where the bad line starts.
    """

    values: np.ndarray
    status: int
    err_line: int
    err_col: int
    err_count: int
    first_inner_blank_line: int
    err_offset: int


def parse_rows(
    block: bytes | bytearray | memoryview, ncols: int, allow_nan: bool = False
) -> ParseResult:
    """Parse a motion block of rows with ``ncols`` numbers each (validated, exact doubles).

    With ``allow_nan``, ``nan``/``inf`` tokens become NaN instead of a NON_FINITE error.
    """
    if ncols < 0:
        raise ValueError("ncols must be >= 0")
    buf = np.frombuffer(block, dtype=np.uint8)
    max_rows = _count_newlines(buf) + 1
    out = np.empty(max(max_rows * ncols, 1), dtype=np.float64)
    slow = np.empty((_SLOW_CAPACITY, 3), dtype=np.int64)
    if ncols == 0:
        # Rows of zero values are blank lines: nothing to parse, but garbage is still an error.
        stripped = bytes(block).strip()
        if stripped:
            first = bytes(block).lstrip()
            line = bytes(block)[: len(bytes(block)) - len(first)].count(b"\n")
            return ParseResult(np.zeros((0, 0)), BAD_COUNT, line, 0, len(stripped.split()), -1, 0)
        return ParseResult(np.zeros((0, 0)), OK, 0, 0, 0, -1, len(buf))
    status, rows, eline, ecol, ecount, blank, nslow, eoff = _parse_kernel(
        buf, ncols, out, slow, _POW10, allow_nan
    )
    values = out[: rows * ncols]
    if nslow:
        raw = bytes(block)
        if nslow <= _SLOW_CAPACITY:
            for flat, a, b in slow[:nslow]:
                if flat < len(values):
                    values[flat] = float(raw[a:b])
                    if not math.isfinite(values[flat]) and not allow_nan:
                        # a literal beyond the double range (1e309, 400 digits): float() gives
                        # inf without a word, which must not pass for data
                        r, c = divmod(int(flat), ncols)
                        line = raw[:a].count(b"\n")
                        return ParseResult(values[: r * ncols].reshape(r, ncols), OVERFLOW,
                                           line, c, 0, int(blank), int(a))  # fmt: skip
        else:  # many long literals: let numpy convert the whole (validated) prefix exactly
            prefix = raw[: eoff if status != OK else len(buf)]
            values = np.array(prefix.split(), dtype=np.float64)[: rows * ncols]
            bad = np.flatnonzero(~np.isfinite(values))
            if len(bad) and not allow_nan:
                r, c = divmod(int(bad[0]), ncols)
                return ParseResult(values[: r * ncols].reshape(r, ncols), OVERFLOW, r, c, 0,
                                   int(blank), 0)  # fmt: skip
        if allow_nan:
            values[~np.isfinite(values)] = np.nan
    return ParseResult(
        # a view: the buffer holds at most a row or two more than needed
        values.reshape(rows, ncols) if rows * ncols else np.zeros((rows, ncols)),
        int(status),
        int(eline),
        int(ecol),
        int(ecount),
        int(blank),
        int(eoff),
    )
