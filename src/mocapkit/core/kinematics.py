"""Forward kinematics, vectorised over frames.

Conventions: quaternions (..., 4) are w,x,y,z; positions are in file units; a joint's global
rotation is ``G[j] = G[parent] * L[j]`` and its global position is
``P[j] = P[parent] + G[parent] (t[j])`` where ``t[j]`` is its local translation (the OFFSET, or the
animated translation for joints with position channels, or the root translation for the root).
Because parents come before children, one pass over joints per frame suffices. The fast path is
a numba kernel; its readable reference twin is ``fk_reference`` in tests/core/naive.py.
"""

from __future__ import annotations

import numba
import numpy as np

from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton


@numba.njit(cache=True, nogil=True)
def _fk_kernel(parents, lrot, ltrans, gpos, grot):  # pragma: no cover - compiled
    """Per frame, per joint: G[j] = G[p] L[j]; P[j] = P[p] + G[p] t[j] (scalar loops)."""
    F, J = lrot.shape[0], lrot.shape[1]
    for f in range(F):
        for j in range(J):
            lw, lx, ly, lz = lrot[f, j, 0], lrot[f, j, 1], lrot[f, j, 2], lrot[f, j, 3]
            tx, ty, tz = ltrans[f, j, 0], ltrans[f, j, 1], ltrans[f, j, 2]
            p = parents[j]
            if p < 0:
                grot[f, j, 0], grot[f, j, 1], grot[f, j, 2], grot[f, j, 3] = lw, lx, ly, lz
                gpos[f, j, 0], gpos[f, j, 1], gpos[f, j, 2] = tx, ty, tz
                continue
            pw, px, py, pz = grot[f, p, 0], grot[f, p, 1], grot[f, p, 2], grot[f, p, 3]
            grot[f, j, 0] = pw * lw - px * lx - py * ly - pz * lz
            grot[f, j, 1] = pw * lx + px * lw + py * lz - pz * ly
            grot[f, j, 2] = pw * ly - px * lz + py * lw + pz * lx
            grot[f, j, 3] = pw * lz + px * ly - py * lx + pz * lw
            # v' = v + 2w (u x v) + 2 u x (u x v)
            cx = 2.0 * (py * tz - pz * ty)
            cy = 2.0 * (pz * tx - px * tz)
            cz = 2.0 * (px * ty - py * tx)
            gpos[f, j, 0] = gpos[f, p, 0] + tx + pw * cx + (py * cz - pz * cy)
            gpos[f, j, 1] = gpos[f, p, 1] + ty + pw * cy + (pz * cx - px * cz)
            gpos[f, j, 2] = gpos[f, p, 2] + tz + pw * cz + (px * cy - py * cx)


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
    parents = np.asarray(parents, dtype=np.int64)
    rotations = np.ascontiguousarray(rotations, dtype=np.float64)
    if rotations.ndim != 3 or rotations.shape[2] != 4:
        raise ValueError(f"rotations must be (F, J, 4), got {rotations.shape}")
    F, J = rotations.shape[:2]
    if parents.shape != (J,) or (J and parents[0] != -1) or np.any(parents >= np.arange(J)):
        raise ValueError("parents must be (J,) with -1 first and parents[j] < j")
    translations = np.ascontiguousarray(
        np.broadcast_to(np.asarray(translations, dtype=np.float64), (F, J, 3))
    )
    gpos = np.empty((F, J, 3))
    grot = np.empty((F, J, 4))
    _fk_kernel(parents, rotations, translations, gpos, grot)
    return gpos, grot


def forward_kinematics(motion: Motion) -> tuple[np.ndarray, np.ndarray]:
    """Global joint positions (F, J, 3) and rotations (F, J, 4) of a motion."""
    sk = motion.skeleton
    if motion.translations is not None:
        t = motion.local_translations()
    else:
        t = np.broadcast_to(sk.offsets, (motion.num_frames, sk.num_joints, 3)).copy()
        t[:, 0] = motion.root_positions
    return fk_arrays(sk.parents, motion.rotations, t)


def _qrot(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate (N, 3) vectors by (N, 4) unit quaternions: v + 2w(u x v) + 2u x (u x v)."""
    u = q[:, 1:]
    t = 2.0 * np.cross(u, v)
    return v + q[:, :1] * t + np.cross(u, t)


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
