"""The paper's baselines (Table 1, bottom): (a) joint-rotation limits learned from clean data,
(b) a rotation-change-rate threshold, (c) both (a cell is flagged when either flags it).

Both are fitted on clean takes of the same skeleton and return (F, J) bool masks on a take's own
frames, like :meth:`SelfSimilarityCleaner.mask`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion

BASELINES = ("a", "b", "c")


class RotationBaseline:
    """Fit limits on clean takes, then flag cells of a take.

    (a) Limits: per joint, the rotation relative to the joint's mean rotation over the clean data
    is expressed as a rotation vector; its three components must lie within the clean data's
    [min, max] widened by ``margin`` (a fraction of the range).
    (b) Rate: per joint, the angle between consecutive frames times the frame rate (rad/s) must
    not exceed the clean data's maximum times ``1 + margin``; both frames of a violating step are
    flagged.

    Args:
        kind: "a", "b" or "c".
        margin: widening of the learned limits (fraction).
    """

    def __init__(self, kind: str = "c", margin: float = 0.05) -> None:
        if kind not in BASELINES:
            raise ValueError(f"baseline must be one of {', '.join(BASELINES)}, got {kind!r}")
        self.kind = kind
        self.margin = float(margin)

    def fit(self, clean: Sequence[Motion]) -> RotationBaseline:
        if not clean:
            raise ValueError("the baselines need at least one clean take")
        J = clean[0].num_joints
        for m in clean:
            if m.num_joints != J:
                raise ValueError("clean takes must share the skeleton")
        allq = np.concatenate([rot.quat_unroll(m.rotations, axis=0) for m in clean])
        # mean rotation per joint (sign-aligned average)
        ref = allq[0]
        aligned = np.where(np.sum(allq * ref, axis=-1, keepdims=True) < 0, -allq, allq)
        mean = aligned.sum(axis=0)
        mean /= np.linalg.norm(mean, axis=-1, keepdims=True)
        self.mean_ = mean
        rv = rot.quat_to_rotvec(rot.quat_mul(rot.quat_inv(mean), allq))
        lo, hi = rv.min(axis=0), rv.max(axis=0)
        pad = self.margin * (hi - lo)
        self.lo_, self.hi_ = lo - pad, hi + pad
        rates = [
            rot.quat_angle(m.rotations[1:], m.rotations[:-1]) * m.fps
            for m in clean
            if m.num_frames > 1
        ]
        vmax = np.max(np.concatenate(rates), axis=0) if rates else np.full(J, np.inf)
        self.rate_max_ = vmax * (1.0 + self.margin)
        return self

    def mask(self, motion: Motion) -> np.ndarray:
        """(F, J) bool cells flagged by this baseline."""
        if not hasattr(self, "mean_"):
            raise RuntimeError("call fit() first")
        F, J = motion.num_frames, motion.num_joints
        if self.mean_.shape[0] != J:
            raise ValueError("the take's skeleton differs from the clean data's")
        out = np.zeros((F, J), dtype=bool)
        if self.kind in ("a", "c"):
            rv = rot.quat_to_rotvec(rot.quat_mul(rot.quat_inv(self.mean_), motion.rotations))
            out |= ((rv < self.lo_ - 1e-9) | (rv > self.hi_ + 1e-9)).any(axis=-1)
        if self.kind in ("b", "c") and F > 1:
            rate = rot.quat_angle(motion.rotations[1:], motion.rotations[:-1]) * motion.fps
            bad = rate > self.rate_max_ + 1e-9
            out[1:] |= bad
            out[:-1] |= bad
        return out
