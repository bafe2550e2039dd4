"""Forward kinematics, vectorised over frames.

Conventions: quaternions (..., 4) are w,x,y,z; positions are in file units; a joint's global
rotation is ``G[j] = G[parent] * L[j]`` and its global position is
``P[j] = P[parent] + G[parent] (t[j])`` where ``t[j]`` is its local translation (the OFFSET, or the
animated translation for joints with position channels, or the root translation for the root).
Because parents come before children, one pass over joints suffices; each step is a batched
operation over all frames, so the Python loop runs J times, not F*J times.
"""

from __future__ import annotations

import numpy as np

from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton


def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of (N, 4) arrays (inlined here because it is the FK hot loop)."""
    aw, ax, ay, az = a[:, 0], a[:, 1], a[:, 2], a[:, 3]
    bw, bx, by, bz = b[:, 0], b[:, 1], b[:, 2], b[:, 3]
    out = np.empty_like(a)
    out[:, 0] = aw * bw - ax * bx - ay * by - az * bz
    out[:, 1] = aw * bx + ax * bw + ay * bz - az * by
    out[:, 2] = aw * by - ax * bz + ay * bw + az * bx
    out[:, 3] = aw * bz + ax * by - ay * bx + az * bw
    return out


def _qrot(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate (N, 3) vectors by (N, 4) unit quaternions: v + 2w(u x v) + 2u x (u x v)."""
    u = q[:, 1:]
    t = 2.0 * np.cross(u, v)
    return v + q[:, :1] * t + np.cross(u, t)


def fk_arrays(
    parents: np.ndarray, rotations: np.ndarray, translations: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Global positions and rotations from local ones.

    Args:
        parents: (J,) parent indices, -1 for the root, parents before children.
        rotations: (F, J, 4) local unit quaternions w,x,y,z.
        translations: (F, J, 3) or (J, 3) local translations (root: its global position).

    Returns:
        positions (F, J, 3) and rotations (F, J, 4), both global.
    """
    rotations = np.asarray(rotations, dtype=np.float64)
    F, J = rotations.shape[:2]
    translations = np.broadcast_to(np.asarray(translations, dtype=np.float64), (F, J, 3))
    # Work joint-major so that each joint's frames are contiguous for the batched ops.
    lr = np.ascontiguousarray(rotations.transpose(1, 0, 2))
    lt = np.ascontiguousarray(translations.transpose(1, 0, 2))
    gr = np.empty_like(lr)
    gp = np.empty_like(lt)
    for j in range(J):
        p = parents[j]
        if p < 0:
            gr[j] = lr[j]
            gp[j] = lt[j]
        else:
            gr[j] = _qmul(gr[p], lr[j])
            gp[j] = gp[p] + _qrot(gr[p], lt[j])
    return gp.transpose(1, 0, 2), gr.transpose(1, 0, 2)


def forward_kinematics(motion: Motion) -> tuple[np.ndarray, np.ndarray]:
    """Global joint positions (F, J, 3) and rotations (F, J, 4) of a motion."""
    sk = motion.skeleton
    if motion.translations is not None:
        t = motion.local_translations()
    else:
        t = np.broadcast_to(sk.offsets, (motion.num_frames, sk.num_joints, 3)).copy()
        t[:, 0] = motion.root_positions
    return fk_arrays(sk.parents, motion.rotations, t)


def end_site_positions(
    skeleton: Skeleton, global_positions: np.ndarray, global_rotations: np.ndarray
) -> np.ndarray:
    """Global End Site positions (F, E, 3) from the FK result of their parents."""
    ep = skeleton.end_site_parents
    F = global_positions.shape[0]
    if len(ep) == 0:
        return np.zeros((F, 0, 3))
    q = global_rotations[:, ep].reshape(-1, 4)
    off = np.broadcast_to(skeleton.end_site_offsets, (F, len(ep), 3)).reshape(-1, 3)
    return global_positions[:, ep] + _qrot(q, off).reshape(F, len(ep), 3)


def rest_positions(skeleton: Skeleton) -> np.ndarray:
    """(J, 3) joint positions in the rest pose (all rotations identity, root at its offset)."""
    pos = np.zeros((skeleton.num_joints, 3))
    for j, p in enumerate(skeleton.parents):
        pos[j] = skeleton.offsets[j] + (pos[p] if p >= 0 else 0.0)
    return pos
