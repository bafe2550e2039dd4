"""Motion features shared by stitching, motion graphs and cleaning.

Plain functions on :class:`~mocapkit.core.motion.Motion` objects and numpy arrays: resampling,
up-axis and unit detection, facing / heading, ground-plane alignment (including Kovar & Gleicher's
closed-form 2-D point-cloud alignment), body-local joint positions, root trajectories and foot
contacts.

Conventions (stated once, used by every function here):

* Quaternions are w, x, y, z (see :mod:`mocapkit.core.rotations`); angles are **radians**;
  durations and rates in the API are **seconds** and **frames per second**; lengths are in the
  motion's **file units** unless a parameter says metres (those are converted with
  :func:`detect_units` or the ``units=`` override).
* ``up`` is a signed axis name: ``"Y"``, ``"Z"``, ``"X"``, ``"-Y"``, ... (case-insensitive, a
  leading ``+`` is accepted). Every function taking ``up=None`` detects it with
  :func:`detect_up_axis`; pass it explicitly to skip detection (and for robustness).
* The ground frame of an up axis is the right-handed triple ``(side, up, forward)`` given by
  :func:`ground_plane_axes` (indices) and :func:`ground_frame` (signed unit vectors):
  ``Y`` -> (X, Y, Z), ``Z`` -> (Y, Z, X), ``X`` -> (Z, X, Y), with ``side x up = forward``. For a
  negative up axis the side vector is negated, so the triple stays right-handed. ``side`` is the
  character's *left* when it faces ``forward``.
* Ground-plane 2-D coordinates are ``(p . side, p . forward)``: ``(x, z)`` for Y-up, ``(y, x)`` for
  Z-up. A heading angle ``theta`` is the right-handed rotation about ``up`` that takes ``forward``
  to the facing direction: ``facing = cos(theta) forward + sin(theta) side``, so for Y-up
  ``theta = atan2(f_x, f_z)``.
* The "root" of the body (for trajectories, alignment and local positions) is the **pelvis**:
  the lowest common ancestor of the left and right hip joints when they can be found by name
  (``Hips`` in Bandai-Namco files, whose joint 0 ``joint_Root`` is a static ground projection),
  else a joint named like ``hips``/``pelvis``, else joint 0. Transforms are always applied to
  joint 0, which moves the whole body.
* Joints are recognised by name with generous patterns (namespaces such as ``mixamorig:``
  stripped; side markers ``Left``/``Right``/``L``/``R`` as prefix, suffix, separate token or glued
  like ``lfemur``). Where names fail, geometric fallbacks are used and documented per function.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mocapkit import body as body_model
from mocapkit.body import UNITS, body_of
from mocapkit.core import rotations as rot
from mocapkit.core.kinematics import forward_kinematics
from mocapkit.core.motion import Motion
from mocapkit.core.runs import true_runs
from mocapkit.core.skeleton import Skeleton

__all__ = [
    "UNITS",
    "FootContacts",
    "GroundTransform",
    "align_point_clouds_2d",
    "apply_ground_transform",
    "character_height",
    "detect_units",
    "detect_up_axis",
    "facing_directions",
    "find_feet",
    "foot_contacts",
    "ground_alignment",
    "ground_coordinates",
    "ground_frame",
    "ground_plane_axes",
    "ground_root_on_path",
    "heading_angles",
    "limb_hinges",
    "local_positions",
    "pelvis_index",
    "resample",
    "root_trajectory",
    "up_disagreement",
]

_AXES = "XYZ"


# =============================================================================================
# axes


def _parse_up(up: str) -> tuple[int, float]:
    """``"Y"``/``"-z"``/``"+X"`` -> (axis index, sign)."""
    if not isinstance(up, str):
        raise TypeError(f"up must be an axis name like 'Y' or '-Z', got {up!r}")
    s = up.strip().upper()
    sign = -1.0 if s.startswith("-") else 1.0
    s = s.lstrip("+-")
    if s not in ("X", "Y", "Z"):
        raise ValueError(f"up must be one of X, Y, Z with an optional sign, got {up!r}")
    return _AXES.index(s), sign


def _norm_up(up: str) -> str:
    a, s = _parse_up(up)
    return ("-" if s < 0 else "") + _AXES[a]


def ground_plane_axes(up: str = "Y") -> tuple[int, int, int]:
    """Axis indices ``(side, up, forward)`` of the ground frame of ``up`` (sign ignored).

    ``Y`` -> (0, 1, 2), ``Z`` -> (1, 2, 0), ``X`` -> (2, 0, 1): a cyclic, right-handed triple
    (``e_side x e_up = e_forward``). ``side`` is the character's left when it faces ``forward``.
    """
    u, _ = _parse_up(up)
    return (u + 2) % 3, u, (u + 1) % 3


def ground_frame(up: str = "Y") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signed unit vectors ``(side, up, forward)``, each (3,), with ``side x up = forward``."""
    s_i, u_i, f_i = ground_plane_axes(up)
    _, sign = _parse_up(up)
    e = np.eye(3)
    return sign * e[s_i], sign * e[u_i], e[f_i].copy()


def ground_coordinates(points: np.ndarray, up: str = "Y") -> np.ndarray:
    """Ground-plane coordinates ``(..., 2)`` = ``(p . side, p . forward)`` of points (..., 3)."""
    side, _, fwd = ground_frame(up)
    p = np.asarray(points, dtype=np.float64)
    return np.stack([p @ side, p @ fwd], axis=-1)


def _up_quat(angle: np.ndarray | float, up: str) -> np.ndarray:
    """Quaternions (..., 4) rotating by ``angle`` (radians, right-handed) about the up vector."""
    _, u, _ = ground_frame(up)
    a = np.asarray(angle, dtype=np.float64)
    q = np.zeros((*a.shape, 4))
    q[..., 0] = np.cos(0.5 * a)
    q[..., 1:] = np.sin(0.5 * a)[..., None] * u
    return q


def _flatten(v: np.ndarray, up: str) -> np.ndarray:
    """Remove the up component of vectors (..., 3)."""
    _, u, _ = ground_frame(up)
    return v - (v @ u)[..., None] * u


# =============================================================================================
# small helpers


def _fk(motion: Motion, max_frames: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """FK of (an evenly spaced subset of at most ``max_frames``) frames."""
    if max_frames is not None and motion.num_frames > max_frames:
        idx = np.unique(np.linspace(0, motion.num_frames - 1, max_frames).round().astype(int))
        motion = motion[idx]
    return forward_kinematics(motion)


def _skeleton_of(obj: Motion | Skeleton) -> Skeleton:
    if isinstance(obj, Motion):
        return obj.skeleton
    if isinstance(obj, Skeleton):
        return obj
    raise TypeError(f"expected a Motion or a Skeleton, got {type(obj).__name__}")


def pelvis_index(skeleton: Skeleton) -> int:
    """The body's root joint (pelvis) of the body model (:attr:`mocapkit.body.Body.pelvis`)."""
    return body_of(skeleton).pelvis


def _fill_invalid(v: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Replace rows of ``v`` (F, ...) where ``valid`` is False by the nearest valid row."""
    if valid.all() or not valid.any():
        return v
    good = np.flatnonzero(valid)
    idx = np.arange(len(valid))
    pos = np.clip(np.searchsorted(good, idx), 0, len(good) - 1)
    prev = np.clip(pos - 1, 0, len(good) - 1)
    nearest = np.where(np.abs(good[prev] - idx) <= np.abs(good[pos] - idx), good[prev], good[pos])
    return v[nearest]


def _unit(v: np.ndarray, eps: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    n = np.linalg.norm(v, axis=-1)
    ok = n > eps
    return v / np.where(ok, n, 1.0)[..., None], ok


# =============================================================================================
# resampling


SAME_RATE_TOLERANCE = 1e-5
""":func:`resample` leaves a motion as it is when its rate is the one asked for within this
fraction: BVH files write 30 fps as ``Frame Time: 0.0333333`` (30.00003 fps), and resampling
that to 30 fps would only interpolate every frame by a hair."""


def resampled_frames(num_frames: int, frame_time: float, fps: float) -> int:
    """How many frames :func:`resample` makes of ``num_frames`` at ``frame_time`` at ``fps``:
    the source's span in new frames, rounded with a tie down (a frame is never made up half a
    frame past the capture: 30 frames at twice the rate's span are frames 0, 2, .., 28), plus
    one; 0 for none."""
    if num_frames <= 0:
        return 0
    return math.ceil((num_frames - 1) * frame_time * fps - 0.5 - 1e-9) + 1


def resample(motion: Motion, fps: float) -> Motion:
    """The motion at another frame rate.

    The new ``frame_time`` is exactly ``1 / fps`` (a motion already at ``fps`` within
    :data:`SAME_RATE_TOLERANCE` is returned as a copy, its frame time kept). New frame ``i``
    samples the source at time ``t_i = i / fps`` (source frame ``k`` lies at ``k *
    frame_time``). The new frames span the source's samples, first to last: ``n - 1`` is
    ``(num_frames - 1) * frame_time * fps`` rounded (a tie down), so the last new frame lies
    within half a new frame of the last source frame (a time just past it is clamped to it),
    no frame is made up past the capture (30 fps to 60 fps gives ``2 num_frames - 1`` frames,
    not a last frame repeated) and an up-then-down round trip gives back the original count.

    Rotations: every joint's quaternion track is made hemisphere-continuous
    (:func:`~mocapkit.core.rotations.quat_unroll`) and then slerped between the two neighbouring
    source frames (shorter arc). Root positions and animated joint translations are
    interpolated linearly. A sample that falls exactly (within 1e-9 frame) on a source frame
    copies that frame.

    Args:
        motion: the source, (F, J, 4) rotations.
        fps: target frames per second (> 0).

    Returns:
        A new Motion with ``n`` frames (see above) on the same skeleton.
    """
    fps = float(fps)
    if not math.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps must be a positive number, got {fps!r}")
    if abs(motion.frame_time * fps - 1.0) <= SAME_RATE_TOLERANCE:
        return motion.copy()  # the same rate, its frame time written rounded: nothing to do
    new_ft = 1.0 / fps
    F = motion.num_frames
    sk = motion.skeleton
    if F == 0:
        tr = None if motion.translations is None else motion.translations.copy()
        return Motion(sk, motion.rotations.copy(), motion.root_positions.copy(), new_ft, tr)
    n = resampled_frames(F, motion.frame_time, fps)
    s = (np.arange(n) * new_ft) / motion.frame_time
    snap = np.rint(s)
    s = np.where(np.abs(s - snap) < 1e-9, snap, s)
    s = np.clip(s, 0.0, F - 1)
    i0 = np.floor(s).astype(np.int64)
    i1 = np.minimum(i0 + 1, F - 1)
    a = s - i0
    exact = a == 0.0
    q = rot.quat_unroll(motion.rotations, axis=0)
    rots = rot.quat_slerp(q[i0], q[i1], np.broadcast_to(a[:, None], (n, sk.num_joints)))
    rots = np.where(exact[:, None, None], q[i0], rots)

    def lerp(x: np.ndarray) -> np.ndarray:
        w = a.reshape((n,) + (1,) * (x.ndim - 1))
        out = (1.0 - w) * x[i0] + w * x[i1]
        return np.where(w == 0.0, x[i0], out)

    root = lerp(motion.root_positions)
    tr = None if motion.translations is None else lerp(motion.translations)
    if tr is not None:
        tr[:, 0] = root
    return Motion(sk, rots, root, new_ft, tr)


# =============================================================================================
# up axis, height, units


def _up_from_positions(sk: Skeleton, pos: np.ndarray) -> str:
    """Up axis from joint positions (F, J, 3) (see :func:`detect_up_axis`)."""
    body = body_of(sk)
    return body_model.up_from_poses(pos, body.head, body.pelvis, body.both("ankle"))


def detect_up_axis(obj: Motion | Skeleton, max_frames: int = 200) -> str:
    """The vertical axis of a motion (or, less reliably, of a skeleton's rest pose).

    With a Motion, joint positions are computed by FK on at most ``max_frames`` evenly spaced
    frames; with a Skeleton, the rest pose (all rotations identity) is used. The up direction is
    the sum of the mean unit vectors from the feet (mid-point of the ankle-like joints found by
    name) to the head and to the pelvis, reduced to its dominant signed axis (the pelvis term
    keeps quadrupeds, whose head is far forward, right).

    Fallback when names fail: the axis of largest median per-frame joint extent, signed so that
    more joints lie above the pelvis than below it.

    Limits: a skeleton whose rest pose is not a standing pose (e.g. the Bandai-Namco rest pose,
    with bones along local X) needs a Motion; a clip spent lying down or upside down is
    misread. Pass ``up=`` explicitly to callers when in doubt.

    Returns:
        ``"Y"``, ``"Z"``, ``"X"`` or their negations ``"-Y"``, ...
    """
    if isinstance(obj, Motion):
        if obj.num_frames == 0:
            return detect_up_axis(obj.skeleton)
        pos, _ = _fk(obj, max_frames)
        return _up_from_positions(obj.skeleton, pos)
    sk = _skeleton_of(obj)
    return _up_from_positions(sk, sk.rest_positions()[None])


def up_disagreement(motion: Motion, up: str | None) -> str | None:
    """The axis ``motion``'s body stands along (:func:`detect_up_axis`) when ``up`` names
    another one, else None (also when ``up`` is None, the take is empty or has no body to
    judge by). Callers warn rather than refuse: a take spent lying down or upside down fools
    the detection, and the user may know better."""
    if not up or motion.num_frames == 0:
        return None
    try:
        found = detect_up_axis(motion)
    except (ValueError, IndexError):
        return None
    return None if found.lstrip("+") == up.upper().lstrip("+") else found


def character_height(obj: Motion | Skeleton, up: str | None = None) -> float:
    """Size of the character in file units (pose independent where the body model allows).

    * With a head and ankles (:mod:`mocapkit.body`): the mean, over the two legs, of the
      head-to-ankle chain length (sum of bone lengths along the hierarchy; animated bone
      lengths use their median). This is about 0.85 x stature for a human.
    * Else, with a Motion: the 90th percentile over frames of the vertical extent of the joint
      positions (``up`` detected when None).
    * Else: the rest-pose extent (:meth:`Skeleton.height`).
    """
    sk = _skeleton_of(obj)
    h = body_model.chain_size(obj, body_of(sk))
    if h > 0:
        return h
    if isinstance(obj, Motion) and obj.num_frames:
        up = up or detect_up_axis(obj)
        _, u, _ = ground_frame(up)
        pos, _ = _fk(obj, 200)
        hgt = pos @ u
        h = float(np.percentile(hgt.max(axis=1) - hgt.min(axis=1), 90))
        if h > 0:
            return h
    return sk.height()


def limb_hinges(skeleton: Skeleton) -> list[int]:
    """Knees and elbows (joint indices, in joint order) of the body model
    (:attr:`mocapkit.body.Body.hinges`: by name, else by structure)."""
    return body_of(skeleton).hinges


def detect_units(
    obj: Motion | Skeleton, candidates: dict[str, float] | None = None
) -> tuple[str, float]:
    """Length unit of a humanoid's file: ``(name, metres_per_unit)``.

    Where the file states its unit (ASF ``:units``, kept on the skeleton) that unit is
    returned, named ``"file"`` unless it is one of :data:`UNITS`; otherwise the guess of
    :func:`mocapkit.body.guess_units` on :func:`character_height` among :data:`UNITS` (or
    ``candidates``). Limits of the guess: see there; non-human skeletons have no meaningful
    height, and the answer is then a guess.
    """
    sk = _skeleton_of(obj)
    if sk.metres_per_unit is not None and candidates is None:
        mpu = sk.metres_per_unit
        name = next((k for k, v in UNITS.items() if math.isclose(v, mpu, rel_tol=1e-9)), "file")
        return name, mpu
    return body_model.guess_units(character_height(obj), candidates)


def metres_per_unit(obj: Motion | Skeleton, units: str | float | None) -> float:
    """Metres per file unit: from ``units`` ("m", "cm", "mm", "inch" or a number), else guessed
    with :func:`detect_units`."""
    if units is None:
        return detect_units(obj)[1]
    if isinstance(units, str):
        key = units.strip().lower()
        key = {
            "in": "inch",
            "inches": "inch",
            "meter": "m",
            "metre": "m",
            "meters": "m",
            "metres": "m",
            "centimeters": "cm",
            "millimeters": "mm",
        }.get(key, key)
        if key not in UNITS:
            raise ValueError(f"unknown unit {units!r}; expected one of {sorted(UNITS)}")
        return UNITS[key]
    mpu = float(units)
    if not (mpu > 0 and math.isfinite(mpu)):
        raise ValueError(f"metres per unit must be positive, got {units!r}")
    return mpu


# =============================================================================================
# facing and heading


def _rest_forward(sk: Skeleton, up: str) -> np.ndarray:
    """Forward direction of the rest pose (3,): mean ground-projected ankle->toe direction, or
    the ground frame's forward axis."""
    feet = body_of(sk).feet
    rest = sk.rest_positions()
    vecs = []
    for side in ("left", "right"):
        js = [j for s, j in feet if s == side]
        if len(js) == 2:
            vecs.append(rest[js[1]] - rest[js[0]])
    if vecs:
        v = _flatten(np.mean([_unit(x)[0] for x in vecs], axis=0), up)
        v, ok = _unit(v, 1e-6)
        if ok:
            return v
    return ground_frame(up)[2]


def _facing_from_fk(sk: Skeleton, pos: np.ndarray, grot: np.ndarray, up: str) -> np.ndarray:
    _, u, _ = ground_frame(up)
    F = pos.shape[0]
    across = np.zeros((F, 3))
    body = body_of(sk)
    for pair in (body.pair("hip"), body.pair("shoulder")):
        if pair is not None:
            d, ok = _unit(pos[:, pair[0]] - pos[:, pair[1]])
            across += np.where(ok[:, None], d, 0.0)
    fwd, ok = _unit(np.cross(_flatten(across, up), u), 1e-6)
    if ok.any():
        return _fill_invalid(fwd, ok)
    # Fallback: the pelvis' global rotation applied to the rest pose's forward direction.
    pelvis = pelvis_index(sk)
    f0 = _rest_forward(sk, up)
    fwd, ok = _unit(_flatten(rot.quat_apply(grot[:, pelvis], f0), up), 1e-6)
    if ok.any():
        return _fill_invalid(fwd, ok)
    return np.broadcast_to(ground_frame(up)[2], (F, 3)).copy()


def facing_directions(motion: Motion, up: str | None = None) -> np.ndarray:
    """Unit ground-plane forward vectors of the character, (F, 3).

    From the left-right vectors of the hips and (when found) the shoulders, each normalised and
    summed, projected on the ground plane and crossed with up (``forward = across x up`` where
    ``across = left - right``). Frames where that vector vanishes (lying on the side) take the
    nearest valid frame's value. Without left/right joint names: the pelvis' global rotation
    applied to the rest pose's forward direction (ankle->toe, else the ground frame's forward).
    """
    up = _norm_up(up) if up else detect_up_axis(motion)
    if motion.num_frames == 0:
        return np.zeros((0, 3))
    pos, grot = forward_kinematics(motion)
    return _facing_from_fk(motion.skeleton, pos, grot, up)


def _heading_of(fwd: np.ndarray, up: str) -> np.ndarray:
    side, _, f = ground_frame(up)
    return np.arctan2(fwd @ side, fwd @ f)


def heading_angles(motion: Motion, up: str | None = None, unwrap: bool = False) -> np.ndarray:
    """Heading (F,) in radians: the rotation about up taking the ground frame's forward axis to
    :func:`facing_directions` (``atan2(f . side, f . forward)``; ``atan2(f_x, f_z)`` for Y-up).

    In (-pi, pi], or continuous across frames with ``unwrap=True``.
    """
    up = _norm_up(up) if up else detect_up_axis(motion)
    h = _heading_of(facing_directions(motion, up), up)
    return np.unwrap(h) if unwrap else h


# =============================================================================================
# ground-plane transforms


@dataclass(frozen=True, eq=False)
class GroundTransform:
    """A rigid motion of the ground plane: rotation by ``angle`` (radians, right-handed about the
    up axis, through the origin) followed by ``translation`` (3,), which has no up component.

    ``p' = R_up(angle) p + translation``; heights are unchanged. An up component given in
    ``translation`` is dropped. ``up`` is the axis the transform was made for (any sign).
    """

    angle: float
    translation: np.ndarray
    up: str = "Y"

    def __post_init__(self) -> None:
        up = _norm_up(self.up)
        t = _flatten(np.asarray(self.translation, dtype=np.float64).reshape(3), up)
        t.setflags(write=False)
        object.__setattr__(self, "up", up)
        object.__setattr__(self, "angle", float(self.angle))
        object.__setattr__(self, "translation", t)

    @classmethod
    def from_2d(cls, angle: float, offset_2d: Sequence[float], up: str = "Y") -> GroundTransform:
        """From a ground-plane offset ``(along side, along forward)`` (see module conventions)."""
        side, _, fwd = ground_frame(up)
        return cls(angle, offset_2d[0] * side + offset_2d[1] * fwd, up)

    @property
    def translation_2d(self) -> np.ndarray:
        """The translation as ground coordinates (2,)."""
        return ground_coordinates(self.translation, self.up)

    @property
    def quaternion(self) -> np.ndarray:
        """The rotation as a quaternion (4,)."""
        return _up_quat(self.angle, self.up)

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Transformed points (..., 3)."""
        p = np.asarray(points, dtype=np.float64)
        return rot.quat_apply(self.quaternion, p) + self.translation

    def apply_directions(self, vectors: np.ndarray) -> np.ndarray:
        """Rotated vectors (..., 3) (no translation)."""
        return rot.quat_apply(self.quaternion, np.asarray(vectors, dtype=np.float64))

    def inverse(self) -> GroundTransform:
        inv = GroundTransform(-self.angle, np.zeros(3), self.up)
        return GroundTransform(-self.angle, -inv.apply_directions(self.translation), self.up)

    def compose(self, other: GroundTransform) -> GroundTransform:
        """``self`` after ``other``: ``p -> self(other(p))``."""
        if _parse_up(other.up)[0] != _parse_up(self.up)[0]:
            raise ValueError("cannot compose ground transforms about different up axes")
        sign = _parse_up(self.up)[1] * _parse_up(other.up)[1]
        return GroundTransform(
            self.angle + sign * other.angle,
            self.apply_directions(other.translation) + self.translation,
            self.up,
        )


def _pelvis_ground_and_heading(motion: Motion, frame: int, up: str) -> tuple[np.ndarray, float]:
    if not -motion.num_frames <= frame < motion.num_frames:
        raise IndexError(f"frame {frame} out of range for a motion of {motion.num_frames} frames")
    one = motion[frame]
    pos, grot = forward_kinematics(one)
    fwd = _facing_from_fk(motion.skeleton, pos, grot, up)[0]
    p = _flatten(pos[0, pelvis_index(motion.skeleton)], up)
    return p, float(_heading_of(fwd, up))


def ground_alignment(
    motion_a: Motion, frame_a: int, motion_b: Motion, frame_b: int, up: str | None = None
) -> GroundTransform:
    """The ground transform that moves ``motion_b`` so that at ``frame_b`` its pelvis ground
    position and facing (:func:`facing_directions`) equal ``motion_a``'s at ``frame_a``.

    ``up`` is detected on ``motion_a`` when None and assumed shared by both motions.
    Apply it with :func:`apply_ground_transform`.
    """
    up = _norm_up(up) if up else detect_up_axis(motion_a)
    pa, ha = _pelvis_ground_and_heading(motion_a, frame_a, up)
    pb, hb = _pelvis_ground_and_heading(motion_b, frame_b, up)
    angle = math.remainder(ha - hb, 2.0 * math.pi)
    r = GroundTransform(angle, np.zeros(3), up)
    return GroundTransform(angle, pa - r.apply(pb), up)


def apply_ground_transform(motion: Motion, transform: GroundTransform) -> Motion:
    """The motion moved rigidly over the ground: root (joint 0) rotations are pre-multiplied by
    the rotation about up and root positions rotated and translated; heights are untouched.

    When joint 0 has no rotation channels (e.g. a channel-less root with 6-channel children), the
    rotation goes to its children instead (their local rotations and translations), so that the
    result survives writing to BVH. If that is impossible too (a child without position channels
    and with a non-zero offset), joint 0's rotation is set anyway: the Motion is right, but a
    writer that follows the channel layout cannot store it.
    """
    q = transform.quaternion
    out = motion.copy()
    sk = motion.skeleton
    out.root_positions = transform.apply(motion.root_positions)
    children = sk.children(0)
    push_down = (
        not sk.has_rotation[0]
        and children
        and all(sk.has_rotation[c] for c in children)
        and all(sk.has_position[c] or np.allclose(sk.offsets[c], 0.0) for c in children)
    )
    if push_down:
        tr = out.local_translations()
        for c in children:
            out.rotations[:, c] = rot.quat_mul(q, motion.rotations[:, c])
            tr[:, c] = transform.apply_directions(tr[:, c])
        tr[:, 0] = out.root_positions
        out.translations = tr
    else:
        out.rotations[:, 0] = rot.quat_mul(q, motion.rotations[:, 0])
        if out.translations is not None:
            out.translations[:, 0] = out.root_positions
    return out


def ground_root_on_path(motion: Motion, up: str | None = None) -> Motion:
    """On a ground-root rig (:attr:`mocapkit.body.Body.ground_root`, Bandai's ``joint_Root``),
    the same world pose with the ground root moved onto the body's ground path: at every frame
    it stands at the pelvis' ground projection (at its own height) and turns to the body's
    heading (:func:`heading_angles`), and the joint below it is re-expressed relative to it.

    This is the root motion a game engine reads: it is continuous wherever the body's path and
    facing are, whatever the source did with the root (Bandai's sits at the origin, so a stitch
    or a graph walk that moves the clips moves it in jumps). Rigs without a ground root, and
    rigs whose joint below the root cannot store a translation, are returned unchanged.
    """
    body = body_of(motion)
    sk = motion.skeleton
    if body.ground_root is None or motion.num_frames == 0:
        return motion
    kids = sk.children(0)
    if len(kids) != 1 or not sk.has_position[kids[0]] or not sk.has_rotation[0]:
        return motion
    c = kids[0]
    up = _norm_up(up) if up else detect_up_axis(motion)
    _, u, _ = ground_frame(up)
    pos, grot = forward_kinematics(motion)
    pelvis = pos[:, body.pelvis]
    root_h = (pos[:, 0] @ u)[:, None] * u
    new_root = _flatten(pelvis, up) + root_h
    new_rot = _up_quat(_heading_of(_facing_from_fk(sk, pos, grot, up), up), up)
    inv = rot.quat_inv(new_rot)
    out = motion.copy()
    tr = out.local_translations()
    out.root_positions = new_root
    out.rotations[:, 0] = new_rot
    out.rotations[:, c] = rot.quat_normalize(rot.quat_mul(inv, grot[:, c]))
    tr[:, 0] = new_root
    tr[:, c] = rot.quat_apply(inv, pos[:, c] - new_root)
    out.translations = tr
    return out


def align_point_clouds_2d(
    points_a: np.ndarray,
    points_b: np.ndarray,
    weights: np.ndarray | None = None,
    up: str = "Y",
) -> GroundTransform:
    """Best rigid ground-plane transform taking ``points_b`` onto ``points_a`` (weighted least
    squares), in closed form (Kovar, Gleicher & Pighin 2002, "Motion Graphs")::

        theta = atan2(sum w (x z' - x' z) - (xbar zbar' - xbar' zbar) / W,
                      sum w (x x' + z z') - (xbar xbar' + zbar zbar') / W)
        x0 = (xbar - xbar' cos(theta) - zbar' sin(theta)) / W
        z0 = (zbar + xbar' sin(theta) - zbar' cos(theta)) / W

    with ``(x, z)`` the ground coordinates of ``points_a`` (``(x', z')`` of ``points_b``),
    ``xbar = sum w x`` and ``W = sum w``. ``atan2`` picks the minimising branch (the paper's
    ``atan`` leaves a pi ambiguity). Heights are ignored.

    Args:
        points_a, points_b: (N, 3) corresponding points (e.g. joint positions over a window).
        weights: (N,) non-negative, not all zero; None means all ones.
        up: the up axis (no detection here: there is no skeleton).

    Returns:
        T minimising ``sum w |ground(a) - ground(T(b))|^2``.
    """
    a = np.asarray(points_a, dtype=np.float64).reshape(-1, 3)
    b = np.asarray(points_b, dtype=np.float64).reshape(-1, 3)
    if a.shape != b.shape:
        raise ValueError(f"points_a {a.shape} and points_b {b.shape} differ in shape")
    w = np.ones(len(a)) if weights is None else np.asarray(weights, dtype=np.float64).reshape(-1)
    if w.shape != (len(a),):
        raise ValueError(f"weights must be ({len(a)},), got {w.shape}")
    W = float(w.sum())
    if not W > 0 or np.any(w < 0):
        raise ValueError("weights must be non-negative with a positive sum")
    ga = ground_coordinates(a, up)
    gb = ground_coordinates(b, up)
    x, z = ga[:, 0], ga[:, 1]
    xp, zp = gb[:, 0], gb[:, 1]
    xb, zb, xpb, zpb = (float(np.dot(w, v)) for v in (x, z, xp, zp))
    num = float(np.dot(w, x * zp - xp * z)) - (xb * zpb - xpb * zb) / W
    den = float(np.dot(w, x * xp + z * zp)) - (xb * xpb + zb * zpb) / W
    theta = math.atan2(num, den)
    c, s = math.cos(theta), math.sin(theta)
    x0 = (xb - xpb * c - zpb * s) / W
    z0 = (zb + xpb * s - zpb * c) / W
    return GroundTransform.from_2d(theta, (x0, z0), up)


# =============================================================================================
# trajectories and local positions


def root_trajectory(motion: Motion, up: str | None = None, joint: int | None = None) -> np.ndarray:
    """Ground-plane path (F, 2) of the pelvis (or of ``joint``), in ground coordinates
    ``(p . side, p . forward)``: ``(x, z)`` for Y-up."""
    up = _norm_up(up) if up else detect_up_axis(motion)
    j = pelvis_index(motion.skeleton) if joint is None else int(joint)
    if motion.num_frames == 0:
        return np.zeros((0, 2))
    pos, _ = forward_kinematics(motion)
    return ground_coordinates(pos[:, j], up)


def local_positions(motion: Motion, up: str | None = None) -> np.ndarray:
    """Joint positions (F, J, 3) in the body-local frame of each frame.

    The pelvis' ground-plane position is subtracted (heights kept) and the result rotated about
    up by minus the heading, so the character always faces the ground frame's forward axis
    (+Z for Y-up, +X for Z-up). Invariant under any ground transform of the motion.
    """
    up = _norm_up(up) if up else detect_up_axis(motion)
    if motion.num_frames == 0:
        return np.zeros((0, motion.num_joints, 3))
    pos, grot = forward_kinematics(motion)
    fwd = _facing_from_fk(motion.skeleton, pos, grot, up)
    heading = _heading_of(fwd, up)
    origin = _flatten(pos[:, pelvis_index(motion.skeleton)], up)
    q = _up_quat(-heading, up)
    return rot.quat_apply(q[:, None, :], pos - origin[:, None, :])


# =============================================================================================
# foot contacts


@dataclass(frozen=True, eq=False)
class FootContacts:
    """Per-frame foot contact flags.

    Attributes:
        joints: (n,) indices of the foot joints examined.
        names: their names.
        sides: "left", "right" or "" (unknown) per joint.
        contacts: (F, n) bool, True where the joint is planted.
        height_threshold: the height threshold used (file units, above the clip's ground level).
        velocity_threshold: the speed threshold used (file units per second).
        ground: (n,) the ground reference height of each joint (file units, along up).
    """

    joints: tuple[int, ...]
    names: tuple[str, ...]
    sides: tuple[str, ...]
    contacts: np.ndarray
    height_threshold: float
    velocity_threshold: float
    ground: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def by_side(self) -> np.ndarray:
        """(F, 2) bool ``[left, right]``: any joint of that side planted. Joints of unknown side
        are assigned by position in the list (first half left)."""
        F = self.contacts.shape[0]
        out = np.zeros((F, 2), dtype=bool)
        n = len(self.joints)
        for k in range(n):
            s = self.sides[k] or ("left" if k < n / 2 else "right")
            out[:, 0 if s == "left" else 1] |= self.contacts[:, k]
        return out

    def duty_factors(self) -> np.ndarray:
        """(2,) fraction of frames in contact for the left and right feet."""
        bs = self.by_side()
        return bs.mean(axis=0) if len(bs) else np.zeros(2)


def _clean_flags(x: np.ndarray, max_gap: int, max_spike: int) -> np.ndarray:
    """Close interior False gaps of at most ``max_gap`` frames, then drop interior True runs of
    at most ``max_spike`` frames (runs touching the clip's ends are kept)."""
    x = x.copy()
    n = len(x)
    for a, b in true_runs(~x):
        if a > 0 and b < n - 1 and b - a + 1 <= max_gap:
            x[a : b + 1] = True
    for a, b in true_runs(x):
        if b - a + 1 <= max_spike and a > 0 and b < n - 1:
            x[a : b + 1] = False
    return x


def find_feet(
    skeleton: Skeleton, motion: Motion | None = None, up: str | None = None
) -> list[tuple[str, int]]:
    """Foot joints ``[(side, index)]``: per side the ankle-like joint (Foot/Ankle...) and a toe
    joint below it (Toe/ToeBase/toes/Ball...) when present, found by name.

    Without names: the two leaf joints that are lowest on average (over ``motion``'s frames, or
    in the rest pose) among the leaves of different subtrees of the pelvis, sides unknown ("").
    """
    feet = body_of(skeleton).feet
    if feet:
        return feet
    leaves = skeleton.leaves()
    if motion is not None and motion.num_frames:
        up = _norm_up(up) if up else detect_up_axis(motion)
        pos, _ = _fk(motion, 200)
    else:
        up = _norm_up(up) if up else detect_up_axis(skeleton)
        pos = skeleton.rest_positions()[None]
    _, u, _ = ground_frame(up)
    mean_h = (pos @ u).mean(axis=0)
    pelvis = pelvis_index(skeleton)
    chosen: list[int] = []
    branches: set[int] = set()
    for j in sorted(leaves, key=lambda k: mean_h[k]):
        anc = [j, *skeleton.ancestors(j)]
        if pelvis not in anc or j == pelvis:
            continue
        branch = anc[anc.index(pelvis) - 1]
        if branch in branches:
            continue
        branches.add(branch)
        chosen.append(j)
        if len(chosen) == 2:
            break
    return [("", j) for j in chosen]


def foot_contacts(
    motion: Motion,
    feet: Sequence[int | str] | None = None,
    height_threshold: float | None = None,
    velocity_threshold: float | None = None,
    up: str | None = None,
    units: str | float | None = None,
    *,
    height_fraction: float = 0.03,
    speed_fraction: float = 0.6,
    max_gap: float = 0.07,
    max_spike: float = 0.07,
    ground_percentile: float = 5.0,
) -> FootContacts:
    """Foot contacts: a foot joint is planted when it is near the ground AND slow.

    * Feet: ``feet`` (joint indices or names) or :func:`find_feet` (ankle + toe per side).
    * Ground: each joint's ``ground_percentile`` percentile height over the clip, capped at the
      clip's lowest such value plus 0.1 x character height (so that a foot held up all clip long
      is not taken as its own ground). Limits: flat ground assumed (no stairs or slopes).
    * Near: height above its ground < ``height_threshold``.
    * Slow: speed (central differences, per second) < ``velocity_threshold``.
    * Then gaps of at most ``max_gap`` seconds between two contacts are closed and contacts of
      at most ``max_spike`` seconds removed (a morphological closing, then an opening), each
      measured as ``floor(seconds * fps)`` frames: 2 frames at 30 fps, 8 at 120 fps. Runs
      touching the clip's first or last frame are never removed (they may be cut short).

    Thresholds are physical: ``height_threshold`` in metres and ``velocity_threshold`` in metres
    per second, converted to file units with ``units`` (a name of :data:`UNITS` or metres per
    unit; detected when None). Their defaults scale with the character instead:
    ``height_fraction`` x :func:`character_height` and ``speed_fraction`` x character height per
    second (for a 1.7 m human, chain ~1.45 m: ~4.4 cm and ~0.87 m/s), so that they do not depend
    on the file's unit. Speed is the discriminating test; the height test mainly rejects a foot
    hovering still above the ground. Checked on the Bandai-Namco clips (median duty factor 0.58
    for walks, with double support; 0.33 for runs, with flight phases) and on
    :func:`mocapkit.datasets.procedural_motion` (>= 92% of frames agree with its exact
    toe-planted labels for walks, >= 98% for runs). A lower ``speed_fraction`` (0.4) tracks
    "toe exactly still" more tightly but shortens contacts on captured data.

    Returns:
        :class:`FootContacts` with (F, n) flags for the n foot joints.
    """
    sk = motion.skeleton
    up = _norm_up(up) if up else detect_up_axis(motion)
    if feet is None:
        found = find_feet(sk, motion, up)
        joints = [j for _, j in found]
        sides = [s for s, _ in found]
    else:
        joints = [sk.index(f) if isinstance(f, str) else int(f) for f in feet]
        body = body_of(sk)
        sides = [s if s in ("left", "right") else "" for s in map(body.side_of, joints)]
    if not joints:
        raise ValueError("no foot joints found; pass feet= explicitly")
    H = character_height(motion, up)
    mpu = 1.0
    if height_threshold is not None or velocity_threshold is not None:
        mpu = metres_per_unit(motion, units)
    h_thr = height_fraction * H if height_threshold is None else height_threshold / mpu
    v_thr = speed_fraction * H if velocity_threshold is None else velocity_threshold / mpu
    F = motion.num_frames
    n = len(joints)
    if F == 0:
        return FootContacts(
            tuple(joints),
            tuple(sk.names[j] for j in joints),
            tuple(sides),
            np.zeros((0, n), dtype=bool),
            h_thr,
            v_thr,
            np.zeros(n),
        )
    _, u, _ = ground_frame(up)
    pos, _ = forward_kinematics(motion)
    fp = pos[:, joints]  # (F, n, 3)
    height = fp @ u  # (F, n)
    base = np.percentile(height, ground_percentile, axis=0)
    base = np.minimum(base, base.min() + 0.1 * H)
    if F > 1:
        vel = np.gradient(fp, motion.frame_time, axis=0)
        speed = np.linalg.norm(vel, axis=-1)
    else:
        speed = np.zeros((F, n))
    raw = (height - base < h_thr) & (speed < v_thr)
    gap = max(0, math.floor(max_gap / motion.frame_time + 1e-6))
    spike = max(0, math.floor(max_spike / motion.frame_time + 1e-6))
    flags = np.stack([_clean_flags(raw[:, k], gap, spike) for k in range(n)], axis=1)
    return FootContacts(
        tuple(joints),
        tuple(sk.names[j] for j in joints),
        tuple(sides),
        flags,
        float(h_thr),
        float(v_thr),
        base,
    )
