"""Synthetic capture errors with ground truth (for evaluation, tests and the demo).

Every injector corrupts one joint of a copy of the take over a window and returns the corrupted
take and the (F,) bool mask of frames whose rotation changed by more than ``MIN_CHANGE_DEG``.
Angles in degrees, durations in frames at 30 fps (scaled with the take's rate).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mocapkit.core import rotations as rot
from mocapkit.core.checks import whole_number
from mocapkit.core.motion import Motion
from mocapkit.features import limb_hinges

ERROR_KINDS = ("spike", "offset", "noise", "bend", "flip", "frozen")
MIN_CHANGE_DEG = 1.0


@dataclass
class Injected:
    """A corrupted take: ``motion``, the ``joint`` index, the ``kind``, ``frames`` (F,) bool
    (changed by more than ``MIN_CHANGE_DEG``) and ``window`` (F,) bool (every frame the error
    rewrote; a frozen hold's frames that drift less than that from the live motion, or a noise
    draw under it, are in the window but not in ``frames``)."""

    motion: Motion
    joint: int
    kind: str
    frames: np.ndarray
    window: np.ndarray | None = None


def hinge_joints(motion: Motion) -> list[int]:
    """Knee/elbow joints (for the "bend" error): :func:`mocapkit.features.limb_hinges`."""
    return limb_hinges(motion.skeleton)


def _random_axis(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _dur(rng: np.random.Generator, lo: int, hi: int, fps: float) -> int:
    s = fps / 30.0
    return max(1, round(int(rng.integers(lo, hi + 1)) * s))


def inject(
    motion: Motion,
    kind: str,
    joint: int | str,
    rng: np.random.Generator | int,
    start: int | None = None,
) -> Injected:
    """Corrupt ``joint`` of a copy of ``motion`` with an error of ``kind`` (see ERROR_KINDS).

    - spike: 1-5 frames rotated by 20-90 deg about a random axis (constant over the spike).
    - offset: 10-40 frames rotated by 15-60 deg, abrupt edges.
    - noise: 10-30 frames of random rotations, sigma 5-15 deg per axis.
    - bend: 10-30 frames of the hinge (knee/elbow) bent the wrong way: the flexion component
      about the joint's main axis is mirrored and pushed 20-50 deg past straight.
    - flip: 3-15 frames rotated by 180 deg about a random axis.
    - frozen: a window of 15-40 frames holding the value of its first frame (that frame keeps
      its own value, so ``frames`` marks the 14-39 after it).

    ``joint``: an index or a name; ``rng``: a Generator or a seed; ``start``: the first frame
    (ValueError past the take), random when None.
    """
    if kind not in ERROR_KINDS:
        raise ValueError(f"unknown error kind {kind!r}; choose from {', '.join(ERROR_KINDS)}")
    joint = motion.skeleton.index(joint) if isinstance(joint, str) else int(joint)
    if not 0 <= joint < motion.num_joints:
        raise ValueError(f"joint {joint} out of range for {motion.num_joints} joints")
    if not isinstance(rng, np.random.Generator):
        rng = np.random.default_rng(rng)
    if start is not None:
        start = whole_number(start, "start")
    if start is not None and not 0 <= int(start) < motion.num_frames:
        raise ValueError(f"start {start} out of range for {motion.num_frames} frames")
    F = motion.num_frames
    fps = motion.fps
    lengths = {
        "spike": (1, 5),
        "offset": (10, 40),
        "noise": (10, 30),
        "bend": (10, 30),
        "flip": (3, 15),
        "frozen": (15, 40),
    }[kind]
    n = min(_dur(rng, *lengths, fps), max(1, F - 2))
    if start is None:
        start = int(rng.integers(1, max(2, F - n)))
    start = int(np.clip(start, 0, max(0, F - n)))
    sl = slice(start, start + n)
    q = motion.rotations.copy()
    orig = motion.rotations[:, joint]
    if kind == "spike":
        d = rot.rotvec_to_quat(_random_axis(rng) * np.radians(rng.uniform(20, 90)))
        q[sl, joint] = rot.quat_mul(orig[sl], d)
    elif kind == "offset":
        d = rot.rotvec_to_quat(_random_axis(rng) * np.radians(rng.uniform(15, 60)))
        q[sl, joint] = rot.quat_mul(orig[sl], d)
    elif kind == "noise":
        sigma = np.radians(rng.uniform(5, 15))
        d = rot.rotvec_to_quat(rng.normal(scale=sigma, size=(n, 3)))
        q[sl, joint] = rot.quat_mul(orig[sl], d)
    elif kind == "bend":
        rv = rot.quat_to_rotvec(orig)
        # main flexion axis: principal direction of the joint's rotation vectors
        vt = np.linalg.svd(rv, full_matrices=False)[2]
        axis = vt[0]
        if np.mean(rv @ axis) < 0:
            axis = -axis
        seg = rv[sl]
        along = seg @ axis
        extra = np.radians(rng.uniform(20, 50))
        new = seg - (along + np.maximum(along, 0.0) + extra)[:, None] * axis[None, :]
        q[sl, joint] = rot.rotvec_to_quat(new)
    elif kind == "flip":
        d = rot.rotvec_to_quat(_random_axis(rng) * np.pi)
        q[sl, joint] = rot.quat_mul(orig[sl], d)
    elif kind == "frozen":
        q[sl, joint] = orig[start]
    out = Motion(
        motion.skeleton,
        q,
        motion.root_positions.copy(),
        motion.frame_time,
        None if motion.translations is None else motion.translations.copy(),
    )
    changed = rot.quat_angle(q[:, joint], orig) > np.radians(MIN_CHANGE_DEG)
    window = np.zeros(F, dtype=bool)
    window[start + (kind == "frozen") : start + n] = True  # a hold keeps its first frame's own
    return Injected(out, joint, kind, changed, window)
