"""Motion helpers shared by the stitching tests (loaded by path, never imported by the library)."""

from __future__ import annotations

import numpy as np

from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton


def with_ground_root(motion: Motion) -> Motion:
    """The motion with an extra static root joint above its root (like Bandai's joint_Root)."""
    sk = motion.skeleton
    six = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
    new = Skeleton(
        ("ground", *sk.names),
        np.r_[-1, np.where(sk.parents < 0, 0, sk.parents + 1)],
        np.r_[np.zeros((1, 3)), sk.offsets],
        (six, six, *sk.channels[1:]),
        sk.end_site_parents + 1,
        sk.end_site_offsets,
        sk.end_site_names,
    )
    F = motion.num_frames
    rots = np.concatenate([np.tile([1.0, 0, 0, 0], (F, 1, 1)), motion.rotations], axis=1)
    tr = np.concatenate([np.zeros((F, 1, 3)), motion.local_translations()], axis=1)
    return Motion(new, rots, np.zeros((F, 3)), motion.frame_time, tr)
