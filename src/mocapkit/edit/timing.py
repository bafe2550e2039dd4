"""Edits in time: trim a take to a range, change its speed.

Both keep the frame time exactly as read (never rebuilt from a rounded fps), so a trimmed or
sped-up take writes back with the same ``Frame Time:`` line as its source.
"""

from __future__ import annotations

import math

from mocapkit.core.motion import Motion
from mocapkit.core.ranges import RangeSpec
from mocapkit.features import resample, resampled_frames

__all__ = ["change_speed", "trim", "trim_frames"]


def trim_frames(motion: Motion, start: int, stop: int | None = None) -> Motion:
    """Frames ``start..stop-1`` (0-based, ``stop`` excluded; None: to the end) as a new motion.

    Refused (ValueError): negative or reversed bounds, an empty result, ends past the take.
    """
    F = motion.num_frames
    stop = F if stop is None else int(stop)
    start = int(start)
    if start < 0 or stop < 0:
        raise ValueError(f"trim: frames count from 0, got {start}:{stop}")
    if stop <= start:
        raise ValueError(f"trim: empty or reversed range {start}:{stop}; expected start < stop")
    if stop > F:
        raise ValueError(f"trim: frames {start}:{stop} past the end of the take ({F} frames)")
    return motion[start:stop]


def trim(motion: Motion, start_s: float = 0.0, stop_s: float | None = None) -> Motion:
    """The frames whose times lie in ``[start_s, stop_s)`` seconds (frame k at ``k *
    frame_time``; each bound becomes the nearest frame, and a start inside the last frame's
    span is that frame: the CLI's ``--trim 1.5s:4s``, :class:`mocapkit.core.ranges.RangeSpec`).

    Refused (ValueError): negative times, an empty or reversed range, ends past the take."""
    spec = RangeSpec.seconds(start_s, stop_s, "trim")
    return trim_frames(motion, *spec.frames(motion.fps, motion.num_frames))


MIN_SPEED = 0.01
"""Slowest :func:`change_speed` factor: 100 times slower already holds each captured frame
for a hundred frames; slower only multiplies the file's size."""


SPEED_TOLERANCE = 0.05
"""How far the speed the frames left play at may be from the factor asked for (a fraction):
the frame count is whole, so a take sped up to a handful of frames plays at another speed."""


def change_speed(motion: Motion, factor: float) -> Motion:
    """The take played ``factor`` times faster (2.0: half the duration), at its own frame rate.

    The source is read as if its frame time were ``frame_time / factor`` and resampled back to
    the original rate with :func:`mocapkit.features.resample` (rotations slerped on
    hemisphere-continuous tracks, translations linear), so the result spans the same samples,
    first to last, in ``(num_frames - 1) / factor`` frames (rounded, a tie down) and the path
    is the same, only traversed at another pace. The frame time of the result is the source's,
    bit for bit.

    Refused (ValueError): a factor that is not a positive number; one under :data:`MIN_SPEED`
    (a take a hundred times longer, gigabytes of BVH for a minute's take); a take of one frame
    (no motion to play faster or slower); and a factor the take is too short to play: the
    whole frames left would play it more than :data:`SPEED_TOLERANCE` off the factor (250x
    on 195 frames leaves 2, the first and last pose, which is 194x).
    """
    factor = float(factor)
    if not (math.isfinite(factor) and factor > 0):
        raise ValueError(f"speed factor must be a positive number, got {factor!r}")
    if factor < MIN_SPEED:
        raise ValueError(f"speed factor {factor:g} is below the slowest, {MIN_SPEED:g}")
    F = motion.num_frames
    if factor == 1.0 or F == 0:
        return motion.copy()
    if F == 1:
        raise ValueError("speed: a take of 1 frame has no motion to play faster or slower")
    n = _frames_after_speed(F, factor, motion.frame_time)
    played = (F - 1) / (n - 1) if n >= 2 else math.inf
    if abs(played / factor - 1.0) > SPEED_TOLERANCE:
        # (F - 1) / factor frames, rounded, are off by at most half a frame: well within the
        # tolerance from 0.5 / tol + 1 frames on
        fastest = (F - 1) / (0.5 / SPEED_TOLERANCE + 1.0)
        raise ValueError(
            f"speed factor {factor:g} on the take's {F} frames leaves {n} frame(s), which "
            f"play it {played:.3g}x, more than {SPEED_TOLERANCE:.0%} off: factors up to "
            f"{fastest:.3g} always play within it"
        )
    ft = motion.frame_time
    fast = Motion(
        motion.skeleton, motion.rotations, motion.root_positions, ft / factor, motion.translations
    )
    out = resample(fast, 1.0 / ft)
    # resample sets 1 / (1 / ft), which may differ from ft in the last bit: keep the source's.
    return Motion(out.skeleton, out.rotations, out.root_positions, ft, out.translations)


def _frames_after_speed(num_frames: int, factor: float, frame_time: float = 1.0) -> int:
    """How many frames :func:`change_speed` returns: the source read at ``frame_time /
    factor``, resampled back to ``1 / frame_time`` (as it does, so the same rounding)."""
    return resampled_frames(num_frames, frame_time / factor, 1.0 / frame_time)
