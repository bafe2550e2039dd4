"""The one range syntax (mocapkit.core.ranges): A:B frames, 1.5s:4.0s seconds, single frames."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mocapkit.core.ranges import RangeError, RangeSpec, parse_frame, parse_range


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("10:20", (10, 20)),
        (" 10 : 20 ", (10, 20)),
        ("10:", (10, 300)),
        (":20", (0, 20)),
        (":", (0, 300)),
        ("1.5s:4.0s", (45, 120)),
        ("1.5S:4s", (45, 120)),
        (".5s:1s", (15, 30)),
        ("30:2.5s", (30, 75)),
        ("0s:", (0, 300)),
        ("0:300", (0, 300)),
    ],
)
def test_parse_range_reads_frames_and_seconds(text: str, expected: tuple[int, int]) -> None:
    assert parse_range(text, 30.0, 300) == expected


def test_single_positions_are_one_frame_ranges() -> None:
    assert parse_range("60", 30.0, 300, single=True) == (60, 61)
    assert parse_range("2.0s", 30.0, 300, single=True) == (60, 61)
    assert parse_frame("2s", 30.0, 300) == 60
    assert parse_frame("7", 30.0, None) == 7
    # a time that should sit on a frame at a non-integer rate still lands on it
    assert parse_frame("1.001s", 1 / 0.0333667, None) == 30
    # a time within the last frame's span (the take lasts 10 s) is the last frame, not past it
    # (newcomer report: --trim 6.49s: on a 6.5 s take said "frames 195:195 past the end")
    assert parse_range("9.99s:", 30.0, 300) == (299, 300)
    assert parse_frame("9.99s", 30.0, 300) == 299
    with pytest.raises(RangeError, match="past the end"):
        parse_frame("10s", 30.0, 300)
    with pytest.raises(RangeError, match=r"past the end|empty"):  # stays empty (review)
        parse_range("9.99s:9.99s", 30.0, 300)


@pytest.mark.parametrize(
    ("text", "single", "words"),
    [
        ("abc", False, "expected A:B"),
        ("1:2:3", False, "expected A:B"),
        ("-5:10", False, "expected A:B"),
        ("-20:", False, "not back from its end"),  # newcomer report: said only "expected"
        ("10:-2s", False, "not back from its end"),
        ("-20", True, "not back from its end"),
        ("1.5:3", False, "'1.5' is no frame number (frames are whole numbers; a time ends "
         "in s: 1.5s)"),  # seconds need their s
        ("2.0s:3.0", False, "'3.0' is no frame number"),  # newcomer: the end lacking its s
        ("60", False, "expected A:B"),  # a lone frame is not a range here
        ("20:10", False, "reversed"),
        ("2s:3", False, "different units: 3 is a frame number"),  # meant 2s:3s
        ("90:2s", False, "different units: 2s is a time"),
        ("10:10", False, "empty"),
        ("1s:1s", False, "empty"),
        ("0:301", False, "past the end"),
        ("300:", False, "past the end"),
        ("11s:", False, "past the end"),
        ("300", True, "past the end"),
        ("x", True, "a frame (60) or a time (2.0s)"),
    ],
)
def test_bad_ranges_are_one_line_naming_the_option(text: str, single: bool, words: str) -> None:
    with pytest.raises(RangeError) as e:
        parse_range(text, 30.0, 300, option="--trim", single=single)
    msg = str(e.value)
    assert msg.startswith("--trim") and words in msg and "\n" not in msg


def test_parse_frame_refuses_ranges_and_spec_reports_units() -> None:
    with pytest.raises(RangeError, match="--landing: expected a frame"):
        parse_frame("1:5", 30.0, 300, option="--landing")
    # a position inside a longer argument: its messages name the whole argument, once
    with pytest.raises(RangeError, match=r"^--explain 'Head:400': frame 400 past the end"):
        parse_frame("400", 30.0, 300, "--explain", shown="Head:400")
    with pytest.raises(RangeError, match=r"^--explain 'Head:x': expected a frame"):
        parse_frame("x", 30.0, 300, "--explain", shown="Head:x")
    assert RangeSpec.parse("1s:2s").in_seconds and not RangeSpec.parse("1:2").in_seconds
    with pytest.raises(RangeError, match="open end"):
        RangeSpec.parse("5:").frames(30.0, None)


@settings(max_examples=60, derandomize=True, deadline=None)
@given(
    fps=st.sampled_from([24.0, 25.0, 30.0, 1 / 0.0333333, 60.0, 120.0, 1 / 0.0417083750417]),
    a=st.integers(0, 500),
    n=st.integers(1, 500),
)
def test_seconds_and_frames_agree(fps: float, a: int, n: int) -> None:
    """``A:B`` and the same frames written as their times give the same range."""
    b = a + n
    total = b + 10
    frames = parse_range(f"{a}:{b}", fps, total)
    secs = parse_range(f"{a / fps!r}s:{b / fps!r}s", fps, total)
    assert frames == secs == (a, b)
