"""Replacing erroneous joint values (Sec. 4), on the take's own frames.

Which cells change: for every joint, the frames whose MDM exceeds the threshold ("flagged
cells"), each run of them dilated by ``margin`` frames on both sides (the *blend margin*). Exactly
those (joint, frame) cells are written; every other rotation of the take, and every root
position, is copied bit for bit.

What they get: a composite track (the take's rotation outside the flagged cells, the replacement
inside, made hemisphere-continuous) smoothed by a quadratic Savitzky-Golay filter of
``2 * margin + 1`` frames, so the amended part joins the original smoothly; only the written
cells take the smoothed values.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_filter

from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion


def default_margin(fps: float) -> int:
    """Blend margin in frames: about 0.1 s, at least 2."""
    return max(2, round(0.1 * fps))


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, end) inclusive runs of True in a 1-D bool array."""
    m = np.asarray(mask, dtype=bool)
    if not m.any():
        return []
    d = np.diff(np.concatenate([[0], m.astype(np.int8), [0]]))
    starts = np.flatnonzero(d == 1)
    ends = np.flatnonzero(d == -1) - 1
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


def dilate(mask: np.ndarray, margin: int) -> np.ndarray:
    """Dilate a (F, J) bool mask by ``margin`` frames along axis 0."""
    m = np.asarray(mask, dtype=bool)
    if margin <= 0 or not m.any():
        return m.copy()
    out = m.copy()
    for s in range(1, margin + 1):
        out[s:] |= m[:-s]
        out[:-s] |= m[s:]
    return out


@dataclass
class RepairResult:
    """A repaired take and what changed.

    Attributes:
        motion: the repaired Motion.
        flagged: (F, J) bool, cells above the threshold.
        written: (F, J) bool, cells written (flagged dilated by the blend margin).
        margin: the blend margin in frames.
    """

    motion: Motion
    flagged: np.ndarray
    written: np.ndarray
    margin: int


def repair_cells(
    motion: Motion,
    flagged: np.ndarray,
    replacement: np.ndarray,
    margin: int | None = None,
    to_file: np.ndarray | None = None,
    pelvis: int | None = None,
) -> RepairResult:
    """Write ``replacement`` into the flagged cells of ``motion`` with Savitzky-Golay blending.

    Args:
        motion: the take (F frames).
        flagged: (F, J) bool.
        replacement: (F, J, 4) replacement rotations, in the same space as ``motion.rotations``
            except for joint ``pelvis`` when ``to_file`` is given.
        margin: blend margin (frames); default :func:`default_margin`.
        to_file: (F, 4) ``X``: the pelvis column of ``replacement`` (and of the composite) is in
            the facing-aligned space ``X * q``; it is mapped back with ``X^-1``.
        pelvis: the pelvis joint index for ``to_file``.
    """
    F, J = motion.num_frames, motion.num_joints
    flagged = np.asarray(flagged, dtype=bool)
    if flagged.shape != (F, J):
        raise ValueError(f"flagged must be ({F}, {J}), got {flagged.shape}")
    replacement = np.asarray(replacement, dtype=np.float64)
    if replacement.shape != (F, J, 4):
        raise ValueError(f"replacement must be ({F}, {J}, 4), got {replacement.shape}")
    margin = default_margin(motion.fps) if margin is None else int(margin)
    if margin < 0:
        raise ValueError("margin must be >= 0")
    written = dilate(flagged, margin)
    out = motion.rotations.copy()
    window = 2 * margin + 1
    for j in np.flatnonzero(flagged.any(axis=0)):
        orig = motion.rotations[:, j]
        rep = replacement[:, j]
        if to_file is not None and j == pelvis:
            rep = rot.quat_mul(rot.quat_inv(to_file), rep)
        comp = np.where(flagged[:, j, None], rep, orig)
        comp = rot.quat_unroll(rot.quat_normalize(comp), axis=0)
        w = min(window, F if F % 2 == 1 else F - 1)
        if w >= 3:
            smooth = savgol_filter(comp, w, min(2, w - 1), axis=0, mode="interp")
            smooth = rot.quat_normalize(smooth)
        else:
            smooth = comp
        cells = written[:, j]
        new = smooth[cells]
        # keep the file's sign convention (w >= 0 where the input had it) for stable output
        sign = np.where(np.sum(new * orig[cells], axis=-1, keepdims=True) < 0, -1.0, 1.0)
        out[cells, j] = new * sign
    result = Motion(
        motion.skeleton,
        out,
        motion.root_positions.copy(),
        motion.frame_time,
        None if motion.translations is None else motion.translations.copy(),
    )
    return RepairResult(result, flagged, written, margin)
