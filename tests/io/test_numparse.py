"""The numba motion-block parser against the readable reference: float() of each token."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from mocapkit.io import _numparse


def reference_parse(block: bytes, ncols: int) -> np.ndarray:
    """The straightforward version: split lines, skip blank ones, float() every token."""
    rows = [line.split() for line in block.split(b"\n")]
    rows = [r for r in rows if r]
    assert all(len(r) == ncols for r in rows)
    return np.array([[float(t) for t in r] for r in rows], dtype=np.float64).reshape(-1, ncols)


FORMATS = ["{!r}", "{:.6f}", "{:.3e}", "{:.17g}", "{:.9E}", "{:g}", "{:.0f}", "{:+.4f}"]


@settings(max_examples=200, derandomize=True, deadline=None)
@given(
    values=st.lists(
        st.floats(allow_nan=False, allow_infinity=False, min_value=-1e30, max_value=1e30)
        | st.floats(min_value=-1e-30, max_value=1e-30, allow_subnormal=False)
        | st.integers(-(10**6), 10**6).map(float),
        min_size=6,
        max_size=60,
    ),
    fmt=st.sampled_from(FORMATS),
    sep=st.sampled_from([" ", "\t", "  ", " \t"]),
    eol=st.sampled_from(["\n", "\r\n"]),
)
def test_fast_parser_equals_float_of_each_token(values, fmt, sep, eol) -> None:
    ncols = 3
    values = values[: len(values) // ncols * ncols]
    toks = [fmt.format(v) for v in values]
    lines = [sep.join(toks[i : i + ncols]) for i in range(0, len(toks), ncols)]
    block = (eol.join(lines) + eol).encode()
    res = _numparse.parse_rows(block, ncols)
    assert res.status == _numparse.OK
    np.testing.assert_array_equal(res.values, reference_parse(block, ncols))


def test_odd_literals_exact() -> None:
    toks = [
        ".0083333",
        "-0",
        "0",
        "1.",
        "-.5",
        "4.96962e-017",
        "1e-05",
        "1.2E+5",
        "+3.25",
        "0.016666666666666666",
        "123456789012345678901234",
        "0.0417083750417",
        "1.7976931348623157e308",
        "2.2250738585072014e-308",
        "00012.5000",
        "9" * 30,
    ]
    block = (" ".join(toks) + "\n").encode()
    res = _numparse.parse_rows(block, len(toks))
    assert res.status == _numparse.OK
    np.testing.assert_array_equal(res.values[0], [float(t) for t in toks])


def test_many_long_literals_use_exact_fallback() -> None:
    rng = np.random.default_rng(0)
    vals = rng.normal(size=(3000, 4))
    block = "\n".join(" ".join(f"{v:.19f}" for v in r) for r in vals).encode()
    res = _numparse.parse_rows(block, 4)
    assert res.status == _numparse.OK
    np.testing.assert_array_equal(res.values, reference_parse(block, 4))


def test_errors_report_line_and_column() -> None:
    block = b"1 2 3\n\n4 5 x6\n"
    res = _numparse.parse_rows(block, 3)
    assert (res.status, res.err_line, res.err_col) == (_numparse.BAD_NUMBER, 2, 2)
    res = _numparse.parse_rows(b"\n1 2 3\n\n4 5 6\n\n", 3)
    assert (res.status, res.first_inner_blank_line, res.values.shape) == (_numparse.OK, 0, (2, 3))
    res = _numparse.parse_rows(b"1 2 3\n4 5\n", 3)
    assert (res.status, res.err_line, res.err_count) == (_numparse.BAD_COUNT, 1, 2)
    assert res.values.shape == (1, 3)
    res = _numparse.parse_rows(b"1 NaN 3\n", 3)
    assert res.status == _numparse.NON_FINITE
    res = _numparse.parse_rows(b"1 NaN 3\n", 3, allow_nan=True)
    assert res.status == _numparse.OK and np.isnan(res.values[0, 1])
    for bad in (b"1 2 3e\n", b"1 2 -\n", b"1 2 .\n", b"1 2 3..\n", b"1 2 0x10\n", b"1 2 e5\n"):
        assert _numparse.parse_rows(bad, 3).status == _numparse.BAD_NUMBER, bad
