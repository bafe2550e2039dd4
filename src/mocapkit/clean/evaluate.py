"""Detection and repair scores against injected ground truth.

Units: (joint, source word) with source words laid on the take's own frames (15 frames every 5
at 24 fps, scaled to the take's rate). A unit is *truly erroneous* when any of its frames was
corrupted on that joint, *flagged* when the mask (MDM > threshold) holds on any of its frames
for that joint. Only the joints analysed (``joints``) count.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mocapkit.clean.inject import ERROR_KINDS, Injected, hinge_joints, inject
from mocapkit.clean.words import ANALYSIS_FPS, source_word_starts, word_lengths
from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion


def unit_words(num_frames: int, fps: float) -> tuple[np.ndarray, int]:
    """(starts, length) of the evaluation words on a take's frames."""
    n, step, _ = word_lengths(ANALYSIS_FPS)
    length = max(1, round(n * fps / ANALYSIS_FPS))
    step = max(1, round(step * fps / ANALYSIS_FPS))
    return source_word_starts(num_frames, min(length, num_frames), step), min(length, num_frames)


def unit_matrix(cells: np.ndarray, fps: float) -> np.ndarray:
    """(W, J) bool: any cell of the word on that joint."""
    starts, n = unit_words(cells.shape[0], fps)
    c = np.concatenate([np.zeros((1, cells.shape[1]), np.int64), np.cumsum(cells, axis=0)])
    return (c[starts + n] - c[starts]) > 0


@dataclass
class Counts:
    """True positives, false positives, false negatives (units)."""

    tp: int = 0
    fp: int = 0
    fn: int = 0

    def add(self, truth: np.ndarray, flagged: np.ndarray) -> None:
        self.tp += int(np.sum(truth & flagged))
        self.fp += int(np.sum(~truth & flagged))
        self.fn += int(np.sum(truth & ~flagged))

    @property
    def recall(self) -> float:
        return self.tp / (self.tp + self.fn) if self.tp + self.fn else float("nan")

    @property
    def precision(self) -> float:
        return self.tp / (self.tp + self.fp) if self.tp + self.fp else float("nan")


@dataclass
class Corrupted:
    """A take with several single-joint errors: the corrupted motion, the (F, J) truth cells and
    the list of injected errors (kind, joint, frames)."""

    motion: Motion
    truth: np.ndarray
    errors: list[Injected] = field(default_factory=list)

    @property
    def rewritten(self) -> np.ndarray:
        """(F, J) bool: every cell an error rewrote, the truth cells and those it changed by
        less than ``MIN_CHANGE_DEG`` (a frozen hold where the live joint barely moved): a flag
        there is no false alarm, a miss there no miss (score them as excused)."""
        out = self.truth.copy()
        for e in self.errors:
            if e.window is not None:
                out[e.window, e.joint] = True
        return out

    @property
    def frames(self) -> np.ndarray:
        """(F,) bool: frames where any joint was corrupted."""
        return self.truth.any(axis=1)

    def spans(self) -> list[tuple[str, str, int, int]]:
        """``(kind, joint name, first frame, last frame)`` of each error that changed a frame."""
        names = self.motion.skeleton.names
        out = []
        for e in self.errors:
            fr = np.flatnonzero(e.frames)
            if len(fr):
                out.append((e.kind, names[e.joint], int(fr[0]), int(fr[-1])))
        return out


def corrupt(
    motion: Motion,
    rng: np.random.Generator,
    kinds: Sequence[str] = ERROR_KINDS,
    joints: Sequence[int] | None = None,
    every_seconds: float = 2.0,
    gap_seconds: float = 0.8,
) -> Corrupted:
    """Inject one error (one joint at a time) per ``every_seconds`` of the take, cycling through
    ``kinds``, at non-overlapping times separated by ``gap_seconds``; each on a random joint of
    ``joints`` (hinge joints for "bend"). Frozen errors are placed where the joint moves (at least
    15 deg away from the held value), retrying a few times."""
    F = motion.num_frames
    J = motion.num_joints
    joints = list(range(J)) if joints is None else list(joints)
    hinges = [j for j in hinge_joints(motion) if j in joints] or joints
    n_err = max(1, int(motion.duration / every_seconds))
    slots = np.linspace(0, F, n_err + 1).astype(int)
    gap = round(gap_seconds * motion.fps / 2)
    cur = motion
    truth = np.zeros((F, J), dtype=bool)
    errors = []
    for e in range(n_err):
        kind = kinds[(e + int(rng.integers(len(kinds)))) % len(kinds)]
        lo, hi = slots[e] + gap, slots[e + 1] - gap
        best = None
        for _ in range(8):
            j = int(rng.choice(hinges if kind == "bend" else joints))
            start = int(rng.integers(lo, max(lo + 1, hi - 5)))
            inj = inject(cur, kind, j, rng, start=start)
            fr = np.flatnonzero(inj.frames)
            if len(fr) == 0 or fr.max() >= hi + gap:
                continue
            if kind == "frozen":
                dev = rot.quat_angle(inj.motion.rotations[fr, j], cur.rotations[fr, j]).max()
                if dev < np.radians(15):
                    continue
            best = inj
            break
        if best is None:
            continue
        cur = best.motion
        truth[best.frames, best.joint] = True
        errors.append(best)
    return Corrupted(cur, truth, errors)


def repair_error(clean: Motion, repaired: Motion, joints: np.ndarray | None = None) -> np.ndarray:
    """The paper's Eq. 2 per frame: sum over joints of ||log(q_clean^-1 q_repaired)||², (F,)."""
    a = clean.rotations if joints is None else clean.rotations[:, joints]
    b = repaired.rotations if joints is None else repaired.rotations[:, joints]
    half = rot.quat_angle(a, b) / 2.0
    return np.sum(half**2, axis=1)


def detection_counts(
    truth: np.ndarray, flagged: np.ndarray, fps: float, joints: np.ndarray | None = None
) -> Counts:
    """Unit counts (module docstring) of a (F, J) bool ``flagged`` mask against the (F, J)
    ``truth`` cells, on the joints ``joints`` (indices or a (J,) bool mask; default all).
    ``.recall`` and ``.precision`` give the scores."""
    t = unit_matrix(np.asarray(truth, dtype=bool), fps)
    f = unit_matrix(np.asarray(flagged, dtype=bool), fps)
    if joints is not None:
        t, f = t[:, joints], f[:, joints]
    c = Counts()
    c.add(t, f)
    return c


def inject_errors(
    motion: Motion,
    plan: Sequence[tuple[str, str | int, int]],
    rng: np.random.Generator | int = 0,
) -> Corrupted:
    """Inject the errors of ``plan``, ``(kind, joint name or index, start frame)`` each, one
    after the other (:func:`mocapkit.clean.inject`); ``rng``: a generator or a seed."""
    rng = np.random.default_rng(rng) if isinstance(rng, int) else rng
    names = list(motion.skeleton.names)
    cur = motion
    truth = np.zeros((motion.num_frames, motion.num_joints), dtype=bool)
    errors = []
    for kind, joint, start in plan:
        j = names.index(joint) if isinstance(joint, str) else int(joint)
        inj = inject(cur, kind, j, rng, start=start)
        cur = inj.motion
        truth[inj.frames, inj.joint] = True
        errors.append(inj)
    return Corrupted(cur, truth, errors)


def worst_error_deg(reference: Motion, motion: Motion, frames: np.ndarray | None = None) -> float:
    """The largest joint-rotation difference (degrees) between ``motion`` and ``reference`` on
    ``frames`` (a (F,) bool mask or indices; default all), 0 when there are none."""
    a, b = reference.rotations, motion.rotations
    if frames is not None:
        a, b = a[frames], b[frames]
    if a.size == 0:
        return 0.0
    return float(np.degrees(rot.quat_angle(a, b).max()))
