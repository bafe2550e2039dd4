"""Edits of the joint set: rename joints, drop joints.

:func:`drop_joints` keeps forward kinematics of the kept joints exactly: a kept joint whose
parent is dropped hangs from its nearest kept ancestor, and the dropped joints' rotations and
translations between them are composed into it, per frame. That relies on FK being a product
of local transforms along the chain (``G[j] = G[p] L[j]``, ``P[j] = P[p] + G[p] t[j]``), so
any run of consecutive transforms can be multiplied out into one.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Iterable, Mapping

import numpy as np

from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import POSITION_CHANNELS, ROTATION_CHANNELS, Skeleton

__all__ = ["drop_joints", "joints_matching", "rename_joints"]


def rename_joints(motion: Motion, mapping: Mapping[str, str]) -> Motion:
    """The motion on a skeleton whose joints ``old`` are called ``mapping[old]``.

    Refused (KeyError / ValueError naming the joint): an ``old`` name that is not a joint, an
    empty new name, or a result with two joints of one name.
    """
    sk = motion.skeleton
    names = list(sk.names)
    for old, new in mapping.items():
        if old not in sk.names:
            raise KeyError(f"rename: no joint named {old!r}")
        new = str(new)
        if not new.strip() or any(c.isspace() for c in new):
            raise ValueError(f"rename: {old!r} -> {new!r}: a joint name needs no blanks")
        names[sk.index(old)] = new
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"rename: two joints would be called {dup[0]!r}")
    return motion.with_skeleton(dataclasses.replace(sk, names=tuple(names)))


def joints_matching(skeleton: Skeleton, pattern: str) -> list[int]:
    """Joints whose whole name matches the regular expression ``pattern`` (``re.fullmatch``),
    in joint order. A user's pattern, not a body-part rule: the body model is not consulted."""
    try:
        rx = re.compile(pattern)
    except re.error as e:
        raise ValueError(f"drop: bad regular expression {pattern!r}: {e}") from None
    return [j for j, n in enumerate(skeleton.names) if rx.fullmatch(n)]


def drop_joints(
    motion: Motion, joints: str | Iterable[int], tolerance: float | None = None
) -> Motion:
    """The motion without ``joints`` (a regular expression on whole names, or indices).

    Each kept joint whose parent is dropped is re-parented to its nearest kept ancestor; its
    local rotation becomes the product of the dropped joints' rotations and its own, and its
    local translation the dropped chain's translation carried through those rotations, per
    frame. FK of every kept joint is unchanged. Where that translation is the same in every
    frame (within ``tolerance``, default 1e-9 of the rig's size) it is the joint's new offset;
    where it moves (a dropped joint that rotates), the joint gets position channels so the file
    can store it. A kept joint that gains a rotation and had no rotation channels gets them too.
    End Sites of dropped joints go with them.

    Refused (ValueError): dropping the root, or nothing matching.
    """
    sk = motion.skeleton
    J = sk.num_joints
    drop = sorted(set(joints_matching(sk, joints) if isinstance(joints, str) else joints))
    if not drop:
        what = f"matches {joints!r}" if isinstance(joints, str) else "was given"
        raise ValueError(f"drop: no joint {what}")
    if any(not 0 <= int(j) < J for j in drop):
        raise ValueError(f"drop: joint indices must lie in 0..{J - 1}, got {drop}")
    if 0 in drop:
        raise ValueError(f"drop: cannot drop the root joint {sk.names[0]!r} (all hang from it)")
    keep = np.ones(J, dtype=bool)
    keep[drop] = False
    kept = np.flatnonzero(keep)
    new_index = np.full(J, -1, dtype=np.int64)
    new_index[kept] = np.arange(len(kept))
    tol = (1e-9 * max(sk.height(), 1.0)) if tolerance is None else float(tolerance)

    F = motion.num_frames
    lrot = motion.rotations
    ltr = motion.local_translations()
    new_rot = lrot[:, kept].copy()
    new_tr = ltr[:, kept].copy()
    parents = np.empty(len(kept), dtype=np.int64)
    offsets = sk.offsets[kept].copy()
    channels = [tuple(sk.channels[j]) for j in kept]
    for i, j in enumerate(kept):
        p = int(sk.parents[j])
        chain: list[int] = []  # dropped joints between the kept ancestor and j, top first
        while p >= 0 and not keep[p]:
            chain.append(p)
            p = int(sk.parents[p])
        parents[i] = -1 if p < 0 else new_index[p]
        if not chain:
            continue
        chain.reverse()
        # Fold the chain from the bottom: (R_d, t_d) o (R, t) = (R_d R, t_d + R_d t).
        q = lrot[:, j]
        t = ltr[:, j]
        for d in reversed(chain):
            t = ltr[:, d] + rot.quat_apply(lrot[:, d], t)
            q = rot.quat_mul(lrot[:, d], q)
        new_rot[:, i] = rot.quat_normalize(q)
        new_tr[:, i] = t
        ch = list(channels[i])
        moving = F > 0 and float(np.max(np.abs(t - t[:1]))) > tol
        # A still chain's translation is the new offset; a moving one keeps the rest pose's
        # (the dropped offsets added up), which is what a viewer draws without the channels.
        offsets[i] = t[0] if F > 0 and not moving else sk.offsets[[*chain, j]].sum(axis=0)
        if moving and not any(c in POSITION_CHANNELS for c in ch):
            ch = list(POSITION_CHANNELS) + ch
        if (
            F > 0
            and not any(c in ROTATION_CHANNELS for c in ch)
            and float(np.max(rot.quat_angle(new_rot[:, i], rot.quat_identity()))) > 1e-12
        ):
            order = next((sk.rotation_order(d) for d in chain if sk.has_rotation[d]), "ZXY")
            ch = ch + [f"{a}rotation" for a in order]
        channels[i] = tuple(ch)
    es_keep = keep[sk.end_site_parents] if len(sk.end_site_parents) else np.zeros(0, dtype=bool)
    new_sk = Skeleton(
        tuple(sk.names[j] for j in kept),
        parents,
        offsets,
        tuple(channels),
        new_index[sk.end_site_parents[es_keep]],
        sk.end_site_offsets[es_keep],
        tuple(n for n, k in zip(sk.end_site_names, es_keep, strict=True) if k),
        sk.metres_per_unit,
    )
    animated = new_sk.has_position.copy()
    animated[0] = False
    translations = None
    if animated.any():
        translations = np.broadcast_to(new_sk.offsets, new_tr.shape).copy()
        translations[:, animated] = new_tr[:, animated]
        translations[:, 0] = motion.root_positions
    return Motion(new_sk, new_rot, motion.root_positions.copy(), motion.frame_time, translations)
