"""Motions and pages shared by the viewer tests."""

from __future__ import annotations

import numpy as np

from mocapkit.core.motion import Motion
from mocapkit.core.rotations import quat_normalize
from mocapkit.core.skeleton import Skeleton


def random_motion(frames: int = 120, seed: int = 0) -> Motion:
    """A 6-joint chain with smooth, non-periodic random rotations (cm units, Y up)."""
    rng = np.random.default_rng(seed)
    J = 6
    names = ["Hips", "Spine", "Neck", "Head", "LeftUpLeg", "LeftFoot"]
    parents = np.array([-1, 0, 1, 2, 0, 4])
    offsets = np.array(
        [[0, 90, 0], [0, 20, 0], [0, 30, 0], [0, 15, 0], [10, -5, 0], [0, -80, 0]], float
    )
    channels = [("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")]
    channels += [("Zrotation", "Xrotation", "Yrotation")] * (J - 1)
    sk = Skeleton(names, parents, offsets, tuple(channels))
    walk = np.cumsum(rng.normal(0, 0.05, (frames, J, 3)), axis=0)
    q = np.concatenate([np.ones((frames, J, 1)), 0.5 * np.sin(walk)], axis=2)
    root = np.stack([np.zeros(frames), np.full(frames, 90.0), np.arange(frames) * 1.0], 1)
    return Motion(sk, quat_normalize(q), root, 1 / 30)
