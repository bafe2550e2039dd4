"""Joint groups and motion-word lengths (Aristidou et al. 2018, Sec. 3.1): the low-level
vocabulary shared by the pose distance, the DTW word scans, the KNN search and the cleaner.

- A :class:`JointGroup` is a named set of joints over which motion-words are compared.
- Words are defined in frames at :data:`ANALYSIS_FPS` (24 fps): source words of
  :data:`SOURCE_LEN` frames every :data:`SOURCE_STEP` frames, target words of
  :data:`TARGET_LEN` frames at every frame; :func:`word_lengths` scales them to another rate and
  :func:`source_word_starts` places the source words on a take.

This module imports nothing from the rest of :mod:`mocapkit.clean`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ANALYSIS_FPS = 24.0
"""The rate the paper analyses at; words are defined in frames at this rate."""

SOURCE_LEN = 15
SOURCE_STEP = 5
TARGET_LEN = 20


@dataclass(frozen=True)
class JointGroup:
    """A named set of joints forming motion-words.

    Attributes:
        name: label ("body", "upper", ...).
        joints: joint indices (skeleton order, sorted, unique).
        trim: how many of the largest per-joint terms the pose distance drops (outlier tolerance):
            3 for the whole body, 1 for sub-groups in the paper.
    """

    name: str
    joints: tuple[int, ...]
    trim: int = 1

    def __post_init__(self) -> None:
        js = tuple(sorted({int(j) for j in self.joints}))
        if not js:
            raise ValueError(f"joint group {self.name!r} is empty")
        object.__setattr__(self, "joints", js)
        if not 0 <= self.trim < len(js):
            raise ValueError(
                f"joint group {self.name!r}: trim must be in [0, {len(js) - 1}], got {self.trim}"
            )


def word_lengths(fps: float = ANALYSIS_FPS) -> tuple[int, int, int]:
    """(source length, source step, target length) in frames at ``fps`` (paper: 15, 5, 20 at 24)."""
    s = fps / ANALYSIS_FPS
    return (
        max(3, round(SOURCE_LEN * s)),
        max(1, round(SOURCE_STEP * s)),
        max(4, round(TARGET_LEN * s)),
    )


def source_word_starts(num_frames: int, length: int, step: int) -> np.ndarray:
    """Start frames of the source words: every ``step`` frames, the last one flush with the end
    so that every frame is covered (one word when the take is shorter than a word)."""
    if num_frames <= length:
        return np.zeros(1, dtype=np.int64)
    starts = list(range(0, num_frames - length + 1, step))
    if starts[-1] != num_frames - length:
        starts.append(num_frames - length)
    return np.asarray(starts, dtype=np.int64)
