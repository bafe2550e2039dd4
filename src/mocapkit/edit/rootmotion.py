"""Root motion: take the travel out of a take, or move it onto a root joint.

Both read the body's travel off the **pelvis** (the body model's, :attr:`mocapkit.body.Body.
pelvis`), not off joint 0: on a ground-root rig (Bandai's ``joint_Root`` under ``Hips``) joint 0
is a static ground projection that does not travel at all, and on others joint 0 may sit above
the pelvis (Character Creator's ``RL_BoneRoot``). The heading is the body model's facing
(:func:`mocapkit.features.heading_angles`: hips and shoulders across, crossed with up).
"""

from __future__ import annotations

import numpy as np

from mocapkit.body import body_of
from mocapkit.core import rotations as rot
from mocapkit.core.kinematics import forward_kinematics
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import POSITION_CHANNELS, ROTATION_CHANNELS, Skeleton
from mocapkit.features import ground_frame, ground_root_on_path, heading_angles

__all__ = ["extract_root_motion", "in_place"]

#: The joint :func:`extract_root_motion` adds on a rig without a ground root. Unreal and Unity
#: both look for a root bone above the pelvis; "Root" is the name their humanoid rigs use.
ROOT_NAME = "Root"


def _flat(v: np.ndarray, u: np.ndarray) -> np.ndarray:
    return v - (v @ u)[..., None] * u


def in_place(motion: Motion, up: str | None = None) -> Motion:
    """The take without its horizontal travel: the pelvis' ground position stays where it is
    in the first frame, in every frame; heights, turns and the body's own motion are kept.

    The travel is taken off joint 0's translation, which carries the whole body. On a
    ground-root rig the ground root is first put on the body's path and heading
    (:func:`mocapkit.features.ground_root_on_path`), so it too stays under the body, turning
    with it, instead of drifting away from it.
    """
    if motion.num_frames == 0:
        return motion.copy()
    body = body_of(motion)
    up = up or body.up
    _, u, _ = ground_frame(up)
    if body.ground_root is not None:
        motion = ground_root_on_path(motion, up)
    pos, grot = forward_kinematics(motion)
    path = _flat(pos[:, body.pelvis], u)
    travel = path - path[:1]
    out = motion.copy()
    sk = motion.skeleton
    if sk.has_position[0] or out.translations is None:
        out.root_positions = motion.root_positions - travel
        if out.translations is not None:
            out.translations[:, 0] = out.root_positions
        return out
    # A root without position channels (a VR recording's static origin): the travel comes off
    # the children that animate their translation, in the root's frame, so a file can store it.
    kids = sk.children(0)
    if not all(sk.has_position[c] for c in kids):
        raise ValueError(
            "in-place: the root joint has no position channels and not all of its children "
            "have them, so the travel cannot be stored"
        )
    local = rot.quat_apply(rot.quat_conj(grot[:, 0]), travel)
    for c in kids:
        out.translations[:, c] -= local
    return out


def extract_root_motion(motion: Motion, up: str | None = None, name: str = ROOT_NAME) -> Motion:
    """The same world pose with the body's ground path and heading carried by a root joint.

    On a ground-root rig that root is joint 0, moved onto the path
    (:func:`mocapkit.features.ground_root_on_path`). On any other rig a new joint 0 called
    ``name`` (``Root``, or ``Root_1``... where taken) is added above the old root, with position
    and rotation channels: in every frame it stands at the pelvis' ground projection, at the
    floor's height (the 5th percentile of the lowest foot joint's height over the take; 0 without
    feet), turned to the body's heading; the old root hangs below it with the remaining
    (body-relative) motion. This is the layout game engines read root motion from. FK of every
    original joint is unchanged.
    """
    body = body_of(motion)
    up = up or body.up
    if body.ground_root is not None:
        return ground_root_on_path(motion, up)
    sk = motion.skeleton
    _, u, _ = ground_frame(up)
    F = motion.num_frames
    pos, grot = forward_kinematics(motion)
    feet = [j for _, j in body.feet]
    floor = float(np.percentile((pos[:, feet] @ u).min(axis=1), 5)) if feet and F else 0.0
    root_pos = _flat(pos[:, body.pelvis], u) + floor * u
    theta = heading_angles(motion, up) if F else np.zeros(0)
    root_rot = np.zeros((F, 4))
    root_rot[:, 0] = np.cos(0.5 * theta)
    root_rot[:, 1:] = np.sin(0.5 * theta)[:, None] * u
    inv = rot.quat_conj(root_rot)

    taken = set(sk.names)
    new_name, k = name, 0
    while new_name in taken:
        k += 1
        new_name = f"{name}_{k}"
    old_ch = list(sk.channels[0])
    if not any(c in POSITION_CHANNELS for c in old_ch):
        old_ch = list(POSITION_CHANNELS) + old_ch
    order = sk.rotation_order(0)
    if not any(c in ROTATION_CHANNELS for c in old_ch):
        old_ch = old_ch + [f"{a}rotation" for a in order]
    root_ch = (*POSITION_CHANNELS, *(f"{a}rotation" for a in order))
    new_sk = Skeleton(
        (new_name, *sk.names),
        np.concatenate([[-1], np.where(sk.parents < 0, 0, sk.parents + 1)]),
        np.vstack([np.zeros((1, 3)), sk.offsets]),
        (root_ch, tuple(old_ch), *sk.channels[1:]),
        sk.end_site_parents + 1,
        sk.end_site_offsets,
        sk.end_site_names,
        sk.metres_per_unit,
    )
    rots = np.concatenate([root_rot[:, None], motion.rotations], axis=1)
    rots[:, 1] = rot.quat_normalize(rot.quat_mul(inv, grot[:, 0]))
    tr = np.concatenate([root_pos[:, None], motion.local_translations()], axis=1)
    tr[:, 1] = rot.quat_apply(inv, pos[:, 0] - root_pos)
    return Motion(new_sk, rots, root_pos, motion.frame_time, tr)
