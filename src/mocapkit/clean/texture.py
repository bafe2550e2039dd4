"""Motion-texture, joint groups and motion-words (Aristidou et al. 2018, Sec. 3.1).

Conventions (used by the whole :mod:`mocapkit.clean` package):

- A *texture* is a ``(F, J, 4)`` array of unit quaternions ``w, x, y, z``: the local rotation of
  every joint of the skeleton (all ``J`` joints, in skeleton order) at every analysis frame, after
  discarding the root translation and turning the body so that it always faces the ground frame's
  forward axis (heading removed from the pelvis). The paper's "rows = joints, columns = frames" is
  its transpose.
- Analysis runs at :data:`ANALYSIS_FPS` (24 fps): a take is resampled (slerp) first, and results
  are mapped back to the file's own frames.
- Word lengths are given at 24 fps (source 15 frames every 5, target 20 frames at every frame)
  and scale with the analysis rate: :func:`word_lengths`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mocapkit import features
from mocapkit.body import body_of
from mocapkit.clean.words import ANALYSIS_FPS, JointGroup
from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton

# ---------------------------------------------------------------------------------- groups


def rotating_joints(motion: Motion, tol: float = 1e-6) -> np.ndarray:
    """(J,) bool: joints whose local rotation changes during the take (beyond ``tol`` radians)."""
    q = motion.rotations
    if q.shape[0] == 0:
        return np.zeros(motion.num_joints, dtype=bool)
    ang = rot.quat_angle(q, q[:1])
    return ang.max(axis=0) > tol


def default_groups(skeleton: Skeleton, include: Sequence[int] | None = None) -> list[JointGroup]:
    """The paper's groups: whole body (trim 3), upper and lower half, left and right half (trim 1).

    From the body model (:func:`mocapkit.body.body_of`): the lower half is the pelvis and its
    leg branches (the subtrees that hold a hip), the upper half everything else with the
    pelvis; a joint is left or right when it lies on a limb of that side, and the centre
    (pelvis, spine, neck and head; limbs of unknown side) belongs to both halves. ``include``
    restricts every group to those joints (for instance the joints that rotate); groups left
    with fewer than two joints are dropped.
    """
    J = skeleton.num_joints
    keep = np.ones(J, dtype=bool) if include is None else np.isin(np.arange(J), include)
    body = body_of(skeleton)
    pelvis = body.pelvis
    lower: set[int] = {pelvis}
    for c in skeleton.children(pelvis):
        sub = skeleton.subtree(c)
        if len(sub) > 1 and any(j in sub for j in body.both("hip")):
            lower.update(sub)
    upper = set(range(J)) - lower | {pelvis}
    side = [body.side_of(j) for j in range(J)]
    left = {j for j in range(J) if side[j] != "right"}
    right = {j for j in range(J) if side[j] != "left"}
    groups = []
    for name, js, trim in (
        ("body", set(range(J)), 3),
        ("upper", upper, 1),
        ("lower", lower, 1),
        ("left", left, 1),
        ("right", right, 1),
    ):
        sel = [j for j in sorted(js) if keep[j]]
        if len(sel) < 2:
            continue
        groups.append(JointGroup(name, tuple(sel), min(trim, len(sel) - 1)))
    return groups


# ---------------------------------------------------------------------------------- texture


def _ancestor_rotations(motion: Motion, j: int) -> np.ndarray:
    """(F, 4) global rotation of joint ``j``'s parent."""
    q = rot.quat_identity((motion.num_frames,))
    for a in reversed(motion.skeleton.ancestors(j)):
        q = rot.quat_mul(q, motion.rotations[:, a])
    return q


def pelvis_alignment(motion: Motion, up: str | None = None) -> np.ndarray:
    """(F, 4) ``X`` with ``aligned_pelvis = X * pelvis`` (local rotations): ``X = A^-1 U A`` where
    ``A`` is the pelvis' parent's global rotation and ``U`` turns the heading back to zero."""
    up = up or features.detect_up_axis(motion)
    heading = features.heading_angles(motion, up)
    pelvis = body_of(motion.skeleton).pelvis
    axis = np.zeros(3)
    axis["XYZ".index(up.lstrip("+-")[-1])] = -1.0 if up.startswith("-") else 1.0
    unturn = rot.rotvec_to_quat(-heading[:, None] * axis)  # (F, 4)
    anc = _ancestor_rotations(motion, pelvis)
    return rot.quat_mul(rot.quat_inv(anc), rot.quat_mul(unturn, anc))


def texture_from_rotations(q: np.ndarray) -> np.ndarray:
    """Make each joint's quaternion track hemisphere-continuous with ``w >= 0`` at the start;
    returns a C-contiguous float64 ``(F, J, 4)`` copy."""
    q = np.asarray(q, dtype=np.float64)
    if q.shape[0] == 0:
        return q.copy()
    q = rot.quat_normalize(q)
    q = np.where(q[:1, :, :1] < 0, -q, q)
    return np.ascontiguousarray(rot.quat_unroll(q, axis=0))


@dataclass
class Texture:
    """A take prepared for analysis.

    Attributes:
        file_rotations: (F_file, J, 4) facing-aligned rotations at the file's own frames.
        rotations: (F_a, J, 4) the same resampled to ``fps`` (the analysis texture).
        fps: analysis rate.
        file_fps: the take's rate.
        name: label (file name).
        pelvis: the joint whose heading was removed.
        pelvis_align: (F_file, 4) ``X`` with ``file_rotations[:, pelvis] = X * original`` (up to
            sign): see :func:`pelvis_alignment`.
    """

    file_rotations: np.ndarray
    rotations: np.ndarray
    fps: float
    file_fps: float
    name: str = ""
    pelvis: int = 0
    pelvis_align: np.ndarray | None = None

    @property
    def num_frames(self) -> int:
        return int(self.rotations.shape[0])

    def analysis_times(self) -> np.ndarray:
        return np.arange(self.num_frames) / self.fps

    def file_times(self) -> np.ndarray:
        return np.arange(self.file_rotations.shape[0]) / self.file_fps


def make_texture(motion: Motion, fps: float = ANALYSIS_FPS, name: str = "") -> Texture:
    """The motion-texture of a take at ``fps`` (and at its own frames), see the module notes."""
    if motion.num_frames == 0:
        raise ValueError(f"{name or 'motion'}: the take has no frames")
    motion.check_finite(name or "motion")
    pelvis = body_of(motion.skeleton).pelvis
    align = pelvis_alignment(motion)
    aligned = np.array(motion.rotations, dtype=np.float64)
    aligned[:, pelvis] = rot.quat_mul(align, aligned[:, pelvis])
    file_q = texture_from_rotations(aligned)
    if abs(motion.fps - fps) < 1e-6 * fps:
        an = file_q.copy()
    else:
        tmp = Motion(motion.skeleton, file_q, np.zeros((motion.num_frames, 3)), motion.frame_time)
        an = texture_from_rotations(features.resample(tmp, fps).rotations)
    return Texture(file_q, an, float(fps), float(motion.fps), name, pelvis, align)


def interpolate_track(q: np.ndarray, src_fps: float, dst_times: np.ndarray) -> np.ndarray:
    """Slerp a ``(F, J, 4)`` quaternion track sampled at ``src_fps`` to the times ``dst_times``
    (clamped to the track's span)."""
    F = q.shape[0]
    s = np.clip(np.asarray(dst_times) * src_fps, 0.0, F - 1)
    i0 = np.floor(s).astype(np.int64)
    i1 = np.minimum(i0 + 1, F - 1)
    a = s - i0
    out = rot.quat_slerp(q[i0], q[i1], np.broadcast_to(a[:, None], (len(s), q.shape[1])))
    return np.where((a == 0.0)[:, None, None], q[i0], out)
