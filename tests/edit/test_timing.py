"""trim and change_speed: frames, durations and the exact frame time."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mocapkit import datasets
from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion
from mocapkit.edit import change_speed, trim, trim_frames
from mocapkit.edit.timing import _frames_after_speed


def walk(frame_time: float = 1 / 30, seconds: float = 2.0) -> Motion:
    m = datasets.procedural_motion("walk", seconds, seed=0).motion
    return Motion(m.skeleton, m.rotations, m.root_positions, frame_time, m.translations)


@settings(max_examples=40, derandomize=True, deadline=None)
@given(a=st.integers(0, 59), n=st.integers(1, 60))
def test_trim_frames_and_seconds(a: int, n: int) -> None:
    m = walk()
    b = min(a + n, m.num_frames)
    out = trim_frames(m, a, b)
    assert out.num_frames == b - a
    assert np.array_equal(out.rotations, m.rotations[a:b])
    assert out.frame_time == m.frame_time
    same = trim(m, a * m.frame_time, b * m.frame_time)
    assert same.allclose(out, 1e-12, 1e-12)


def test_trim_refuses_bad_ranges() -> None:
    m = walk()
    for a, b in ((5, 5), (9, 3), (-1, 4), (0, m.num_frames + 1)):
        with pytest.raises(ValueError, match="trim"):
            trim_frames(m, a, b)


@settings(max_examples=30, derandomize=True, deadline=None)
@given(
    factor=st.floats(0.3, 4.0),
    ft=st.sampled_from([1 / 30, 0.0333333, 0.0083333, 0.0417083750417, 0.04]),
)
def test_change_speed_duration_and_exact_frame_time(factor: float, ft: float) -> None:
    m = walk(ft, 2.0)  # long enough that every factor up to 4 plays within 5%
    out = change_speed(m, factor)
    assert out.frame_time == m.frame_time  # bit for bit
    assert out.num_frames == _frames_after_speed(m.num_frames, factor, m.frame_time)
    span = (m.num_frames - 1) / factor  # in frames: the same samples, first to last
    assert abs(out.num_frames - 1 - span) <= 0.5 + 1e-9
    assert out.skeleton is m.skeleton
    # the path is the same, run at another pace: first frames agree, the last is near the end
    assert rot.quat_angle(out.rotations[0], m.rotations[0]).max() < 1e-9
    np.testing.assert_allclose(out.root_positions[0], m.root_positions[0], atol=1e-9)


def test_speed_two_takes_every_other_frame_and_one_is_a_copy() -> None:
    m = walk()
    out = change_speed(m, 2.0)
    assert out.num_frames == m.num_frames // 2
    assert rot.quat_angle(out.rotations, m.rotations[::2][: out.num_frames]).max() < 1e-9
    assert change_speed(m, 1.0).allclose(m, 1e-12, 1e-12)
    with pytest.raises(ValueError, match="positive"):
        change_speed(m, 0.0)


def test_speed_refuses_a_factor_that_leaves_no_motion_or_a_runaway_file() -> None:
    m = walk()
    F = m.num_frames
    fastest = (F - 1) / 11  # always within 5%: 11 frames' span left
    assert abs((F - 1) / (change_speed(m, fastest).num_frames - 1) / fastest - 1) <= 0.05
    # 250x on 195 frames leaves the first and last pose: 194x, not 250x
    with pytest.raises(ValueError, match=f"on the take's {F} frames leaves 2 frame"):
        change_speed(m, 1.3 * (F - 1))
    with pytest.raises(ValueError, match="leaves 1 frame"):
        change_speed(m, 2.0 * (F - 1))
    with pytest.raises(ValueError, match="1 frame has no motion"):
        change_speed(m[:1], 2.0)
    with pytest.raises(ValueError, match="below the slowest"):
        change_speed(m, 0.001)
    assert change_speed(m, 0.01).num_frames == 100 * (F - 1) + 1


def test_trim_in_seconds_reads_times_as_the_cli_does() -> None:
    """A start inside the last frame's span is that frame (as ``--trim 6.49s:`` on a 6.5 s
    take), not "past the end"; bad times are refused with the option named."""
    m = walk()
    last = trim(m, m.duration - 0.4 * m.frame_time)
    assert last.num_frames == 1
    assert trim(m, m.duration - 0.4 * m.frame_time, m.duration).num_frames == 1  # to the end
    assert np.array_equal(last.rotations[0], m.rotations[-1])
    for a, b in (
        (1.0, 1.0),
        (2.0, 1.0),
        (-0.1, None),
        (float("nan"), None),
        (m.duration + 1, None),
    ):
        with pytest.raises(ValueError, match="trim"):
            trim(m, a, b)
