"""Synthetic data that ships with the code: the Three-Circles set and a procedural humanoid.

Conventions (for everything in this module):

- **Three-Circles** lives in the plane, ``(x, y)`` with x to the right and y up; "clockwise" and
  "counter-clockwise" are as seen in that picture. Lengths are the paper's abstract units.
- **Humanoid**: Y is up, the character faces **+Z** in the rest pose and its left side is at
  **+X** (a right-handed frame). The rest pose is a T-pose standing on the ground plane ``y = 0``
  (the balls of the feet, the ``*Toe`` joints, lie on it). Lengths are in the skeleton's units
  (metres for ``units="m"``, centimetres for ``units="cm"``); ``height`` arguments are always
  in metres; speeds are in metres per second and frequencies in Hz (cycles per second).
- Angles are in **radians**. Every joint rotates in the intrinsic Euler order **ZXY**
  (``R = Rz @ Rx @ Ry``, BVH channels ``Zrotation Xrotation Yrotation``); Euler triples are stored
  in that order, ``angles[..., 0]`` about Z, ``[..., 1]`` about X, ``[..., 2]`` about Y.
- A ``heading`` of ``h`` radians is a rotation about +Y: the character then faces
  ``(sin h, 0, cos h)``.
- The gait phase is in cycles, ``[0, 1)``; one cycle is two steps. Phase 0 is the touch-down of
  the left foot, the right foot touches down at phase 0.5.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from scipy.ndimage import gaussian_filter1d

from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton

__all__ = [
    "BACKWARD_CENTER",
    "FORWARD_CENTER",
    "KINDS",
    "LARGE_CENTER",
    "LARGE_RADIUS",
    "SMALL_RADIUS",
    "SyntheticMotion",
    "ThreeCircles",
    "humanoid_skeleton",
    "procedural_motion",
    "procedural_sequence",
    "three_circles",
    "three_circles_pair",
]

# =============================================================================================
# Three-Circles (Li, McCann, Faloutsos & Pollard, "Laziness is a virtue", Sec. 3, Fig. 1 and 4)

LARGE_CENTER = (0.0, 0.0)
LARGE_RADIUS = 20.0
FORWARD_CENTER = (30.0, 10.0)
BACKWARD_CENTER = (30.0, -10.0)
SMALL_RADIUS = 10.0


def _nearest_angle(center: tuple[float, float]) -> float:
    """Angle (about ``center``) of the point of that small circle nearest the large circle."""
    return float(np.arctan2(LARGE_CENTER[1] - center[1], LARGE_CENTER[0] - center[0]))


def _circle(center: Sequence[float], radius: float, angles: np.ndarray) -> np.ndarray:
    return np.stack(
        [center[0] + radius * np.cos(angles), center[1] + radius * np.sin(angles)], axis=-1
    )


@dataclass(frozen=True, eq=False)
class ThreeCircles:
    """The Three-Circles trajectories, all sampled at ``frames_per_cycle`` frames per revolution.

    Attributes:
        large: (F, 2) the large circle (radius 20, centre (0, 0)) travelled **counter-clockwise**
            and ending at the take-off point B (the query motion Q).
        forward: (F, 2) the circle of radius 10 centred at (30, +10) travelled **clockwise**,
            starting at its point nearest the large circle (the "CD" data of the paper).
        backward: (F, 2) the circle of radius 10 centred at (30, -10) travelled
            **counter-clockwise**, starting at its point nearest the large circle ("EF").
        query: (N, 2) the query arc "AB": the last ``N`` frames of a counter-clockwise run on
            the large circle, ``query[-1]`` being the take-off point B.
        frames_per_cycle: frames per full revolution (the same for all three circles).

    Direction convention: with the defaults B = (20, 0), where the query moves straight up
    (+y), towards the (30, +10) circle. That circle, travelled clockwise, moves up (and a
    little left) at its nearest point (20.51, 6.84): it *continues* the query's direction of
    travel, as in a figure of eight, so stitching AB -> forward is natural. The (30, -10) circle
    is the mirror image across the x-axis (counter-clockwise): at its nearest point
    (20.51, -6.84) it moves *down*, against the query, and it lies behind B, so stitching
    AB -> backward needs a turn-around. The two landing points are mirror images, equally far
    (6.86) from B, so a plain Euclidean distance cannot tell the two stitches apart (Fig. 1),
    while the elastic L-score prefers "forward", with fewer injected frames (paper: k = 3 vs 6).
    """

    large: np.ndarray
    forward: np.ndarray
    backward: np.ndarray
    query: np.ndarray
    frames_per_cycle: int

    @property
    def takeoff(self) -> np.ndarray:
        """(2,) the take-off point B (last point of the query arc)."""
        return self.query[-1].copy()

    def data(self, which: str) -> np.ndarray:
        """The data trajectory ``"forward"`` or ``"backward"`` ((F, 2), a copy)."""
        if which == "forward":
            return self.forward.copy()
        if which == "backward":
            return self.backward.copy()
        raise ValueError(f"which must be 'forward' or 'backward', got {which!r}")

    def pair(self, which: str) -> tuple[np.ndarray, np.ndarray]:
        """``(query, data)`` for the stitching experiment: query AB (N, 2), data (F, 2)."""
        return self.query.copy(), self.data(which)


def three_circles(
    frames_per_cycle: int = 64,
    cycles: float = 1.0,
    *,
    takeoff_angle: float = 0.0,
    query_frames: int = 17,
    forward_start_angle: float | None = None,
    backward_start_angle: float | None = None,
) -> ThreeCircles:
    """The Three-Circles data set (2-D), as in Fig. 1 of Li et al.

    Args:
        frames_per_cycle: samples per revolution (paper: 64), for every circle.
        cycles: length of ``large``, ``forward`` and ``backward`` in revolutions;
            ``F = round(frames_per_cycle * cycles)`` frames each.
        takeoff_angle: polar angle (radians, about (0, 0)) of the take-off point B on the large
            circle, which is where ``large`` and ``query`` end. Default 0: B = (20, 0), the point
            of the large circle facing the two small ones, equidistant from both.
        query_frames: number of points N of the query arc AB (default 17: a quarter circle,
            16 steps from A = (0, -20) to B = (20, 0), both included).
        forward_start_angle, backward_start_angle: polar angles (radians, about each small
            circle's centre) where ``forward`` / ``backward`` start. Default: the point of each
            small circle nearest the large circle (polar angle pi + atan(1/3) for the upper one,
            pi - atan(1/3) for the lower one), i.e. the points labelled C and E in Fig. 1.
    """
    n = int(frames_per_cycle)
    if n < 3:
        raise ValueError(f"frames_per_cycle must be at least 3, got {frames_per_cycle}")
    F = round(n * float(cycles))
    if F < 1:
        raise ValueError(f"cycles={cycles} gives no frames")
    if query_frames < 1:
        raise ValueError(f"query_frames must be positive, got {query_frames}")
    step = 2.0 * np.pi / n
    fa = _nearest_angle(FORWARD_CENTER) if forward_start_angle is None else forward_start_angle
    ba = _nearest_angle(BACKWARD_CENTER) if backward_start_angle is None else backward_start_angle
    i = np.arange(F)
    large = _circle(LARGE_CENTER, LARGE_RADIUS, takeoff_angle - step * (F - 1 - i))
    qi = np.arange(query_frames)
    query = _circle(LARGE_CENTER, LARGE_RADIUS, takeoff_angle - step * (query_frames - 1 - qi))
    forward = _circle(FORWARD_CENTER, SMALL_RADIUS, fa - step * i)  # clockwise
    backward = _circle(BACKWARD_CENTER, SMALL_RADIUS, ba + step * i)  # counter-clockwise
    return ThreeCircles(large, forward, backward, query, n)


def three_circles_pair(
    which: str = "forward", frames_per_cycle: int = 64, cycles: float = 1.0, **kwargs: Any
) -> tuple[np.ndarray, np.ndarray]:
    """``(query AB (N, 2), data (F, 2))`` for the "forward" or "backward" stitching experiment.

    Extra keyword arguments go to :func:`three_circles`.
    """
    return three_circles(frames_per_cycle, cycles, **kwargs).pair(which)


# =============================================================================================
# Procedural humanoid

_REF_HEIGHT = 1.7  # metres: the height the gait tables below were tuned for
_UNITS = {"m": 1.0, "cm": 100.0}
ORDER = "ZXY"
_ROT = ("Zrotation", "Xrotation", "Yrotation")
_ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", *_ROT)

# name, parent, offset in units of the body height (rest T-pose, Y up, facing +Z, left = +X)
_JOINTS: tuple[tuple[str, str | None, tuple[float, float, float]], ...] = (
    ("Hips", None, (0.0, 0.53, 0.0)),
    ("Spine", "Hips", (0.0, 0.06, 0.0)),
    ("Chest", "Spine", (0.0, 0.12, 0.0)),
    ("Neck", "Chest", (0.0, 0.115, 0.0)),
    ("Head", "Neck", (0.0, 0.055, 0.0)),
    ("LeftShoulder", "Chest", (0.02, 0.09, 0.0)),
    ("LeftArm", "LeftShoulder", (0.095, 0.01, 0.0)),
    ("LeftForeArm", "LeftArm", (0.17, 0.0, 0.0)),
    ("LeftHand", "LeftForeArm", (0.15, 0.0, 0.0)),
    ("RightShoulder", "Chest", (-0.02, 0.09, 0.0)),
    ("RightArm", "RightShoulder", (-0.095, 0.01, 0.0)),
    ("RightForeArm", "RightArm", (-0.17, 0.0, 0.0)),
    ("RightHand", "RightForeArm", (-0.15, 0.0, 0.0)),
    ("LeftUpLeg", "Hips", (0.055, -0.05, 0.0)),
    ("LeftLeg", "LeftUpLeg", (0.0, -0.22, 0.0)),
    ("LeftFoot", "LeftLeg", (0.0, -0.215, 0.0)),
    ("LeftToe", "LeftFoot", (0.0, -0.045, 0.08)),
    ("RightUpLeg", "Hips", (-0.055, -0.05, 0.0)),
    ("RightLeg", "RightUpLeg", (0.0, -0.22, 0.0)),
    ("RightFoot", "RightLeg", (0.0, -0.215, 0.0)),
    ("RightToe", "RightFoot", (0.0, -0.045, 0.08)),
)
_END_SITES: tuple[tuple[str, tuple[float, float, float]], ...] = (
    ("Head", (0.0, 0.12, 0.0)),  # top of the head: exactly 1.0 * height above the ground
    ("LeftHand", (0.09, 0.0, 0.0)),
    ("RightHand", (-0.09, 0.0, 0.0)),
    ("LeftToe", (0.0, 0.0, 0.04)),
    ("RightToe", (0.0, 0.0, 0.04)),
)


def _unit_scale(units: str) -> float:
    try:
        return _UNITS[units]
    except KeyError:
        raise ValueError(f"units must be 'm' or 'cm', got {units!r}") from None


def humanoid_skeleton(height: float = 1.7, units: str = "m") -> Skeleton:
    """A 21-joint humanoid in a T-pose: Y up, facing +Z, left side at +X, feet on ``y = 0``.

    Joints (parents before children): Hips (root, 6 channels); Spine, Chest, Neck, Head;
    Left/Right Shoulder, Arm, ForeArm, Hand; Left/Right UpLeg, Leg, Foot, Toe. End Sites at the
    top of the head, the hands and the toes. Every joint rotates in ZXY.

    Args:
        height: standing height in **metres** (ground to the top of the head End Site).
        units: length unit of the offsets, "m" or "cm" (``height=1.7, units="cm"`` is 170 cm).
    """
    if not np.isfinite(height) or height <= 0:
        raise ValueError(f"height must be a positive number of metres, got {height!r}")
    H = float(height) * _unit_scale(units)
    names = tuple(n for n, _, _ in _JOINTS)
    parents = [-1 if p is None else names.index(p) for _, p, _ in _JOINTS]
    offsets = np.array([o for _, _, o in _JOINTS]) * H
    channels = tuple(_ROOT_CHANNELS if p is None else _ROT for _, p, _ in _JOINTS)
    ep = [names.index(n) for n, _ in _END_SITES]
    eo = np.array([o for _, o in _END_SITES]) * H
    return Skeleton(names, parents, offsets, channels, ep, eo, ("",) * len(ep))


# ---- gait parameter tables ------------------------------------------------------------------
# Lengths in units of the body height H, angles in degrees, speeds (m/s) and frequencies (Hz)
# for a 1.7 m body; other heights use Froude scaling (speed ~ sqrt(H), frequency ~ 1/sqrt(H)),
# so every pose is the same relative to the body. Keys:
#   speed        forward speed            freq       gait cycles per second (2 steps a cycle)
#   duty         stance fraction of a cycle per foot (> 0.5: double support; < 0.5: flight)
#   clearance    highest toe lift in swing             heel     heel rise at toe-off
#   crouch       pelvis lowering from the rest height  bob      pelvis bob (+: high at mid-stance)
#   sway         pelvis shift towards the stance foot  step_width  lateral foot offset
#   foot_offset  foothold ahead of the mid-stance pelvis
#   pelvis_yaw, pelvis_roll, lean (forward), thorax_yaw (counter-rotation of the chest)
#   arm_abd_l/r  arm abduction from hanging (90 = T-pose, > 90 raised)
#   arm_swing    fore-aft arm swing        arm_fwd_r  constant forward raise of the right arm
#   elbow_l/r    elbow flexion             elbow_swing  extra flexion while the arm is forward
#   fore_raise_r right forearm raised in the arm's plane (waving), wave_amp/wave_freq its
#                oscillation; idle_sway/idle_freq a slow lateral weight shift
# fmt: off
_PARAMS: dict[str, dict[str, float]] = {
    "walk": dict(
        speed=1.1, freq=0.95, duty=0.62, clearance=0.05, heel=30.0, crouch=0.01, bob=0.004,
        sway=0.012, step_width=0.055, foot_offset=-0.03, pelvis_yaw=5.0, pelvis_roll=3.0,
        lean=3.0, thorax_yaw=7.0, arm_abd_l=8.0, arm_abd_r=8.0, arm_swing=18.0, arm_fwd_r=0.0,
        elbow_l=15.0, elbow_r=15.0, elbow_swing=12.0, fore_raise_r=0.0, wave_amp=0.0,
        wave_freq=2.0, idle_sway=0.0, idle_freq=0.25,
    ),
    "run": dict(
        speed=3.0, freq=1.4, duty=0.36, clearance=0.13, heel=25.0, crouch=0.01, bob=-0.015,
        sway=0.006, step_width=0.035, foot_offset=-0.02, pelvis_yaw=8.0, pelvis_roll=2.0,
        lean=8.0, thorax_yaw=10.0, arm_abd_l=12.0, arm_abd_r=12.0, arm_swing=35.0,
        arm_fwd_r=0.0, elbow_l=80.0, elbow_r=80.0, elbow_swing=15.0, fore_raise_r=0.0,
        wave_amp=0.0, wave_freq=2.0, idle_sway=0.0, idle_freq=0.25,
    ),
    "wave": dict(
        speed=0.0, freq=0.92, duty=1.0, clearance=0.0, heel=0.0, crouch=0.0, bob=0.0, sway=0.0,
        step_width=0.06, foot_offset=-0.03, pelvis_yaw=0.0, pelvis_roll=0.0, lean=1.0,
        thorax_yaw=0.0, arm_abd_l=8.0, arm_abd_r=110.0, arm_swing=0.0, arm_fwd_r=25.0,
        elbow_l=12.0, elbow_r=10.0, elbow_swing=0.0, fore_raise_r=70.0, wave_amp=25.0,
        wave_freq=2.0, idle_sway=0.006, idle_freq=0.25,
    ),
    "idle": dict(
        speed=0.0, freq=0.92, duty=1.0, clearance=0.0, heel=0.0, crouch=0.0, bob=0.0, sway=0.0,
        step_width=0.06, foot_offset=-0.03, pelvis_yaw=0.0, pelvis_roll=0.0, lean=1.0,
        thorax_yaw=0.0, arm_abd_l=8.0, arm_abd_r=8.0, arm_swing=0.0, arm_fwd_r=0.0,
        elbow_l=12.0, elbow_r=12.0, elbow_swing=0.0, fore_raise_r=0.0, wave_amp=0.0,
        wave_freq=2.0, idle_sway=0.012, idle_freq=0.25,
    ),
}
KINDS = tuple(_PARAMS)
_KEYS = tuple(_PARAMS["walk"])
# Multiplied by a seeded factor around 1 (the rest is left alone, so that standing kinds keep
# identical footholds and blends between them cannot move a planted foot).
_AMPLITUDES = (
    "clearance", "heel", "bob", "sway", "pelvis_yaw", "pelvis_roll", "lean", "thorax_yaw",
    "arm_swing", "elbow_swing", "wave_amp", "idle_sway",
)
_RATES = ("freq", "wave_freq", "idle_freq")
_UPPER_BODY = (
    "Spine", "Chest", "Neck", "Head", "LeftShoulder", "RightShoulder", "LeftArm", "RightArm",
    "LeftForeArm", "RightForeArm", "LeftHand", "RightHand",
)
# fmt: on


@dataclass(eq=False)
class SyntheticMotion:
    """A generated motion with its ground truth.

    Attributes:
        motion: the Motion (skeleton from :func:`humanoid_skeleton`).
        contacts: (F, 2) bool, [left foot, right foot] in contact with the ground (exact: from
            the gait phase; the ``*Toe`` joint is then fixed in the world at height 0).
        foot_joints: indices of (LeftToe, RightToe), the joints that ``contacts`` refer to.
        phase: (F,) gait phase in [0, 1): 0 = left touch-down, 0.5 = right touch-down.
        angles: joint name -> (F, 3) ZXY Euler angles in radians (Z, X, Y) that generated the
            rotations: ``motion.rotations[:, j] == euler_to_quat(angles[name], "ZXY")`` up to
            the sign of the quaternion.
        labels: (F,) the kind ("walk", "run", ...) of the segment each frame belongs to.
        segments: (kind, first frame, end frame) per segment, end exclusive.
    """

    motion: Motion
    contacts: np.ndarray
    foot_joints: tuple[int, int]
    phase: np.ndarray
    angles: dict[str, np.ndarray]
    labels: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=object))
    segments: tuple[tuple[str, int, int], ...] = ()


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _smootherstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * x * (x * (6.0 * x - 15.0) + 10.0)


def _axis_rot(axis: int, angle: np.ndarray) -> np.ndarray:
    e = np.zeros((*np.shape(angle), 3))
    e[..., "ZXY".index("XYZ"[axis])] = angle
    return rot.euler_to_matrix(e, ORDER)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


_MAX_HALF_STANCE = 0.23  # body heights the pelvis may travel either side of a planted foot


def _kind_params(
    kind: str,
    rng: np.random.Generator,
    overrides: Mapping[str, float] | None,
    froude: float = 1.0,
) -> dict[str, float]:
    """Gait table of ``kind`` with the seeded variations and ``overrides`` applied.

    An override ``speed`` is in m/s for the actual body (``froude = sqrt(height / 1.7)``);
    other overrides are table values. A new speed also sets the stride frequency
    (~ speed ** 0.5, and fast enough that the pelvis never travels more than
    ``_MAX_HALF_STANCE`` body heights past a planted foot) and the stance fraction.
    """
    if kind not in _PARAMS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    p = dict(_PARAMS[kind])
    # Always draw the same numbers in the same order, whatever the kind (determinism).
    amp = np.clip(1.0 + 0.08 * rng.standard_normal(len(_AMPLITUDES)), 0.8, 1.2)
    rate = np.clip(1.0 + 0.04 * rng.standard_normal(len(_RATES)), 0.9, 1.1)
    spd = float(np.clip(1.0 + 0.04 * rng.standard_normal(), 0.9, 1.1))
    for k, a in zip(_AMPLITUDES, amp, strict=True):
        p[k] *= float(a)
    for k, r in zip(_RATES, rate, strict=True):
        p[k] *= float(r)
    overrides = dict(overrides or {})
    unknown = set(overrides) - set(_KEYS)
    if unknown:
        raise ValueError(f"unknown gait parameters {sorted(unknown)}; known: {_KEYS}")
    speed = overrides.pop("speed", None)
    standing = p["duty"] >= 1.0
    if standing:
        if speed is not None and float(speed) != 0.0:
            raise ValueError(f"{kind!r} is a standing motion; speed must be None or 0")
    else:
        base = p["speed"]
        v = base * spd if speed is None else float(speed) / froude
        if not v > 0 or not np.isfinite(v):
            raise ValueError(f"speed must be a positive number for {kind!r}, got {speed}")
        ratio = v / base
        if kind == "run":
            p["duty"] = float(np.clip(p["duty"] * ratio**-0.5, 0.2, 0.45))
        else:
            p["duty"] = float(np.clip(p["duty"] - 0.05 * (ratio - 1.0), 0.53, 0.7))
        p["freq"] = max(
            p["freq"] * ratio**0.5,
            v * p["duty"] / (2.0 * _MAX_HALF_STANCE * _REF_HEIGHT),
        )
        p["speed"] = v
    p.update({k: float(x) for k, x in overrides.items()})
    if not p["freq"] > 0:
        raise ValueError("freq must be positive")
    if not 0.05 <= p["duty"] <= 1.0:
        raise ValueError("duty must be in [0.05, 1]")
    return p


def _blend_params(
    params: list[dict[str, float]], bounds: np.ndarray, t: np.ndarray, blend: float
) -> dict[str, np.ndarray]:
    """Per-frame parameters: piecewise constant per segment, smoothstep blends at the joins."""
    out = {}
    ws = [_smoothstep((t - b) / blend + 0.5) for b in bounds[1:-1]]
    for k in _KEYS:
        v = np.full(t.shape, params[0][k])
        for i, w in enumerate(ws):
            v = v + (params[i + 1][k] - params[i][k]) * w
        out[k] = v
    return out


def _smooth_noise(rng: np.random.Generator, n: int, sigma_frames: float) -> np.ndarray:
    """(n, 3) smooth noise with unit standard deviation per column."""
    white = rng.standard_normal((n, 3))
    if n < 2:
        return np.zeros((n, 3))
    sm = gaussian_filter1d(white, sigma_frames, axis=0, mode="reflect")
    sd = sm.std(axis=0)
    return sm / np.where(sd > 0, sd, 1.0)


def _two_bone_ik(
    hip: np.ndarray, ankle: np.ndarray, pole: np.ndarray, l1: float, l2: float
) -> tuple[np.ndarray, np.ndarray]:
    """Global (F, 3, 3) rotations of thigh and shin putting the ankle at ``ankle``.

    Rest bones point along -Y with the knee hinge about +X (flexing forward, towards ``pole``).
    Targets out of reach are clamped onto the reachable sphere (the leg then points at them).
    """
    d = ankle - hip
    dist = np.linalg.norm(d, axis=-1, keepdims=True)
    u = d / np.maximum(dist, 1e-12)
    dc = np.clip(dist, abs(l1 - l2) + 1e-9, (l1 + l2) * (1.0 - 1e-9))
    cos_a = np.clip((l1 * l1 + dc * dc - l2 * l2) / (2.0 * l1 * dc), -1.0, 1.0)
    w = _unit(pole - np.sum(pole * u, axis=-1, keepdims=True) * u)
    knee = hip + l1 * (cos_a * u + np.sqrt(1.0 - cos_a * cos_a) * w)
    x = np.cross(w, u)  # the knee hinge, lateral (+X at rest)
    y1 = (hip - knee) / l1
    y2 = (knee - (hip + u * dc)) / l2
    g1 = np.stack([x, y1, np.cross(x, y1)], axis=-1)
    g2 = np.stack([x, y2, np.cross(x, y2)], axis=-1)
    return g1, g2


def _foot_plan(
    side: float,
    H: float,
    toe_fwd: float,
    phi_grid: np.ndarray,
    grid: dict[str, np.ndarray],
    phi: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Toe trajectory of one foot in path coordinates.

    Returns contact (n,), forward (n,), lateral (n,), height (n,) and foot pitch (n,) (heel
    rise, radians) for the phases ``phi`` of that foot (0 = its touch-down).
    """

    def at(key: str, ph: np.ndarray) -> np.ndarray:
        return np.interp(ph, phi_grid, grid[key])

    n_i = np.floor(phi).astype(np.int64)
    u = phi - n_i
    cyc = np.arange(n_i.min(), n_i.max() + 2)
    # A cycle's stance fraction is the smallest one from its start to the next mid-stance, so
    # that wherever the body moves between two footholds there is a swing to move the foot in
    # (duty and speed are blended together: duty < 1 exactly where speed > 0); the swing then
    # lifts the foot by the largest clearance of that window, so a foot out of contact is off
    # the ground.
    span = 1.0 + 0.5 * at("duty", cyc + 1.0)
    window = cyc + span * np.linspace(0.0, 1.0, 16)[:, None]
    duty = at("duty", window).min(axis=0)
    clear = at("clearance", window).max(axis=0) * H
    mid = cyc + 0.5 * duty
    fwd = at("s", mid) + at("foot_offset", mid) * H + toe_fwd
    lat = side * at("step_width", mid) * H
    heel = np.deg2rad(at("heel", cyc + duty))
    k = n_i - cyc[0]
    b = duty[k]
    contact = u < b
    sigma = np.where(contact, 0.0, (u - b) / np.maximum(1.0 - b, 1e-9))
    m = _smootherstep(sigma)
    f = np.where(contact, fwd[k], fwd[k] + (fwd[k + 1] - fwd[k]) * m)
    la = np.where(contact, lat[k], lat[k] + (lat[k + 1] - lat[k]) * m)
    h = np.where(contact, 0.0, clear[k] * np.sin(np.pi * sigma))
    rise = _smoothstep((u / np.maximum(b, 1e-9) - 0.5) / 0.5)
    pitch = heel[k] * np.where(contact, rise, 1.0 - _smoothstep(sigma / 0.6))
    return contact, f, la, h, pitch


class _Gait(NamedTuple):
    """Blended gait parameters and phases on the padded frame grid (frames ``-pad .. F+pad-1``)."""

    params: dict[str, np.ndarray]  # per-frame gait table, plus "s": distance travelled (units)
    phase: np.ndarray  # gait phase in cycles (0 = left touch-down)
    sway: np.ndarray  # cos 2π(phase - duty / 2): the side-to-side cycle of pelvis and chest
    wave_phase: np.ndarray  # cycles of the waving forearm
    idle_phase: np.ndarray  # cycles of the idle weight shift
    pad: int  # frames before frame 0 (and after the last frame)


class _Path(NamedTuple):
    """The world frame of the straight path: unit forward, left and up vectors, and the
    heading rotation (3, 3)."""

    fwd: np.ndarray
    left: np.ndarray
    up: np.ndarray
    R_head: np.ndarray


def _segment_params(
    segments: Sequence[tuple[str, float] | tuple[str, float, Mapping[str, float]]],
    rng: np.random.Generator,
    froude: float,
) -> tuple[list[str], list[float], list[dict[str, float]]]:
    """Kinds, durations (seconds) and seeded gait tables of the segments, in segment order."""
    kinds: list[str] = []
    durations: list[float] = []
    params: list[dict[str, float]] = []
    for seg in segments:
        kind, seconds = seg[0], float(seg[1])
        if not seconds > 0:
            raise ValueError(f"segment {kind!r}: seconds must be positive, got {seconds}")
        ov = seg[2] if len(seg) > 2 else None  # type: ignore[misc]
        kinds.append(kind)
        durations.append(seconds)
        params.append(_kind_params(kind, rng, ov, froude))  # type: ignore[arg-type]
    return kinds, durations, params


def _gait_timeline(
    params: list[dict[str, float]],
    bounds: np.ndarray,
    F: int,
    fps: float,
    blend: float,
    froude: float,
    units: str,
    phase0: float,
    idle0: float,
) -> _Gait:
    """Per-frame blended parameters and the integrated phases and distance, on a frame grid
    padded so that footholds one and a half cycles ahead/behind are defined."""
    min_freq = min(p["freq"] for p in params) / froude
    P = int(np.ceil(2.5 * fps / min_freq)) + 2
    idx = np.arange(-P, F + P)
    t = idx / fps
    g = _blend_params(params, bounds, t, blend)
    dt = 1.0 / fps
    speed = g["speed"] * froude * _unit_scale(units)
    freq = g["freq"] / froude

    def integral(rate: np.ndarray) -> np.ndarray:
        c = np.concatenate([[0.0], np.cumsum(rate[:-1] * dt)])
        return c - c[P]

    phi = phase0 + integral(freq)
    g["s"] = integral(speed)
    wave_ph = integral(g["wave_freq"] / froude)
    idle_ph = idle0 + integral(g["idle_freq"] / froude)
    sway = np.cos(2.0 * np.pi * (phi - g["duty"] / 2.0))
    return _Gait(g, phi, sway, wave_ph, idle_ph, P)


def _path_frame(heading: float) -> _Path:
    ch, sh = np.cos(heading), np.sin(heading)
    return _Path(
        fwd=np.array([sh, 0.0, ch]),
        left=np.array([ch, 0.0, -sh]),
        up=np.array([0.0, 1.0, 0.0]),
        R_head=rot.euler_to_matrix(np.array([0.0, 0.0, heading]), ORDER),
    )


def _plan_feet(
    gait: _Gait, path: _Path, H: float, d_toe: np.ndarray
) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """Per foot ("Left", "Right"): contact (n,), world toe and ankle positions (n, 3) and the
    global foot rotation (n, 3, 3) on the padded grid; ``d_toe`` is the ankle -> toe offset."""
    feet = {}
    for side, name, shift in ((1.0, "Left", 0.0), (-1.0, "Right", 0.5)):
        ph = gait.phase - shift
        contact, f, la, h, pitch = _foot_plan(side, H, d_toe[2], ph, gait.params, ph)
        toe = f[:, None] * path.fwd + la[:, None] * path.left + h[:, None] * path.up
        g_foot = path.R_head @ _axis_rot(0, pitch)
        ankle = toe - g_foot @ d_toe
        feet[name] = (contact, toe, ankle, g_foot)
    return feet


def _pelvis(
    gait: _Gait,
    path: _Path,
    H: float,
    skel: Skeleton,
    feet: Mapping[str, tuple[np.ndarray, ...]],
    reach: float,
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Global pelvis rotation (n, 3, 3), root position (n, 3) and hip positions (n, 3) per side
    on the padded grid. The pelvis height is a smooth minimum of its nominal height and the
    heights at which each hip is ``reach`` from its ankle."""
    g, phi, up = gait.params, gait.phase, path.up
    off = skel.offsets
    d2 = g["duty"] / 2.0
    c1 = gait.sway
    lat = g["sway"] * H * c1 + g["idle_sway"] * H * np.sin(2.0 * np.pi * gait.idle_phase)
    y_nom = off[0, 1] - g["crouch"] * H + g["bob"] * H * np.cos(4.0 * np.pi * (phi - d2))
    cos_c = np.cos(2.0 * np.pi * phi)
    root_e = np.stack(
        [
            np.deg2rad(g["pelvis_roll"]) * c1,
            np.deg2rad(g["lean"]),
            -np.deg2rad(g["pelvis_yaw"]) * cos_c,
        ],
        axis=-1,
    )
    R0 = path.R_head @ rot.euler_to_matrix(root_e, ORDER)
    p_xz = g["s"][:, None] * path.fwd + lat[:, None] * path.left
    limits = [y_nom]
    hips0 = {}
    for name in ("Left", "Right"):
        hip0 = p_xz + R0 @ off[skel.index(f"{name}UpLeg")]
        hips0[name] = hip0
        ankle = feet[name][2]
        horiz = np.hypot(*(hip0 - ankle)[:, [0, 2]].T)
        limits.append(ankle[:, 1] - hip0[:, 1] + np.sqrt(np.maximum(reach**2 - horiz**2, 0.0)))
    k_soft = 0.002 * H
    lim = np.stack(limits)
    lo = lim.min(axis=0)
    y = lo - k_soft * np.log(np.exp(-(lim - lo) / k_soft).sum(axis=0))  # smooth min, <= min
    root_pos = p_xz + y[:, None] * up
    hips = {name: hip0 + y[:, None] * up for name, hip0 in hips0.items()}
    return R0, root_pos, hips


def _leg_rotations(
    R0: np.ndarray,
    hips: Mapping[str, np.ndarray],
    feet: Mapping[str, tuple[np.ndarray, ...]],
    path: _Path,
    l1: float,
    l2: float,
) -> dict[str, np.ndarray]:
    """Local rotation matrices (n, 3, 3) of the pelvis and both legs: two-bone IK from each
    hip to its ankle (knees forward), feet from the foot plan, toes flat."""
    local: dict[str, np.ndarray] = {"Hips": R0}
    for name in ("Left", "Right"):
        _, _, ankle, g_foot = feet[name]
        hip = hips[name]
        g1, g2 = _two_bone_ik(hip, ankle, np.broadcast_to(path.fwd, hip.shape), l1, l2)
        local[f"{name}UpLeg"] = np.swapaxes(R0, -1, -2) @ g1
        local[f"{name}Leg"] = np.swapaxes(g1, -1, -2) @ g2
        local[f"{name}Foot"] = np.swapaxes(g2, -1, -2) @ g_foot
        local[f"{name}Toe"] = np.swapaxes(g_foot, -1, -2) @ path.R_head  # toes stay flat
    return local


def _upper_body_angles(
    gait: _Gait, F: int, fps: float, noise: float, rng: np.random.Generator
) -> dict[str, np.ndarray]:
    """ZXY Euler angles (F, 3) of the spine, neck, head, shoulders and arms on the output
    frames: counter-rotation, arm swing opposite to the legs, waving, breathing, plus smooth
    seeded noise of ``noise`` radians."""
    sl = slice(gait.pad, gait.pad + F)
    gg = {k: v[sl] for k, v in gait.params.items()}
    cos_p = np.cos(2.0 * np.pi * gait.phase[sl])
    c1s = gait.sway[sl]
    rad = np.deg2rad
    twist = rad(gg["pelvis_yaw"] + gg["thorax_yaw"]) * cos_p  # chest yaw relative to pelvis
    zeros = np.zeros(F)

    def e(z: np.ndarray, x: np.ndarray, yy: np.ndarray) -> np.ndarray:
        return np.stack(np.broadcast_arrays(z, x, yy), axis=-1).astype(np.float64)

    lean = rad(gg["lean"])
    roll = rad(gg["pelvis_roll"]) * c1s
    breath = rad(1.0) * np.sin(2.0 * np.pi * 0.3 * np.arange(F) / fps)
    upper = {
        "Spine": e(-0.5 * roll, -0.2 * lean, 0.5 * twist),
        "Chest": e(-0.3 * roll, breath, 0.5 * twist),
        "Neck": e(0.3 * roll, -0.3 * lean, -0.4 * rad(gg["thorax_yaw"]) * cos_p),
        "Head": e(0.2 * roll, -0.3 * lean, -0.4 * rad(gg["thorax_yaw"]) * cos_p),
        "LeftShoulder": e(zeros, zeros, zeros),
        "RightShoulder": e(-0.3 * rad(np.maximum(gg["arm_abd_r"] - 90.0, 0.0)), zeros, zeros),
        "LeftHand": e(zeros, zeros, zeros),
        "RightHand": e(zeros, zeros, zeros),
    }
    # Arms swing opposite to the legs: the left leg is forward at phase 0, the left arm back.
    swing = rad(gg["arm_swing"])
    fwd_l = -swing * cos_p
    fwd_r = swing * cos_p + rad(gg["arm_fwd_r"])
    flex_l = rad(gg["elbow_l"]) - rad(gg["elbow_swing"]) * cos_p
    flex_r = rad(gg["elbow_r"]) + rad(gg["elbow_swing"]) * cos_p
    raise_r = rad(gg["fore_raise_r"]) + rad(gg["wave_amp"]) * np.sin(
        2.0 * np.pi * gait.wave_phase[sl]
    )
    # T-pose arms along +-X: Z lowers/raises the arm, Y swings it fore-aft (for the left arm
    # a negative Y angle is forward, for the right arm a positive one); the forearm flexes
    # forward about Y and rises in the arm's plane about Z.
    upper["LeftArm"] = e(-(np.pi / 2 - rad(gg["arm_abd_l"])), zeros, -fwd_l)
    upper["RightArm"] = e(np.pi / 2 - rad(gg["arm_abd_r"]), zeros, fwd_r)
    upper["LeftForeArm"] = e(zeros, zeros, -flex_l)
    upper["RightForeArm"] = e(-raise_r, zeros, flex_r)
    if noise > 0:
        sig = 0.15 * fps
        for n in _UPPER_BODY:
            upper[n] = upper[n] + noise * _smooth_noise(rng, F, sig)
    return upper


def _segment_labels(
    kinds: Sequence[str], bounds: np.ndarray, F: int, fps: float
) -> tuple[np.ndarray, tuple[tuple[str, int, int], ...]]:
    """(F,) kind of each frame and the (kind, first frame, end frame) of each segment."""
    tf = np.arange(F) / fps
    seg_of = np.clip(np.searchsorted(bounds, tf, side="right") - 1, 0, len(kinds) - 1)
    labels = np.array(kinds, dtype=object)[seg_of]
    starts = np.searchsorted(seg_of, np.arange(len(kinds)), side="left")
    ends = np.searchsorted(seg_of, np.arange(len(kinds)), side="right")
    segs = tuple((k, int(a), int(b)) for k, a, b in zip(kinds, starts, ends, strict=True))
    return labels, segs


def procedural_sequence(
    segments: Sequence[tuple[str, float] | tuple[str, float, Mapping[str, float]]],
    seed: int = 0,
    *,
    fps: float = 30.0,
    heading: float = 0.0,
    height: float = 1.7,
    units: str = "m",
    noise: float = 0.01,
    blend: float = 0.6,
) -> SyntheticMotion:
    """One continuous motion made of ``(kind, seconds)`` segments, e.g.
    ``[("walk", 3.0), ("run", 2.0), ("wave", 2.0)]``, with smooth transitions.

    The gait parameters (speed, stride frequency, stance fraction, arm pose, ...) are blended
    with a smoothstep over ``blend`` seconds centred on each join; the phase and the distance
    travelled are integrals of the blended rates, so nothing jumps. A segment may carry a third
    element, a dict overriding gait parameters (e.g. ``{"speed": 1.5}``, see ``_PARAMS``).

    How it is built (vectorised over frames): the pelvis follows a straight path at the
    blended speed; each foot's toe (ball of the foot) is planned in the world, fixed on the
    ground during its stance and moved along a lifted, smooth arc during swing; the heel rises
    in late stance by rotating the foot about the planted toe; the pelvis height is the lower
    of its nominal height and the height at which both legs can reach their feet; the legs are
    then solved by analytic two-bone IK (knees forward). So the stance foot never slides, and
    the root translation is exactly what the footholds imply. The upper body (spine counter-
    rotation, arm swing opposite to the legs, waving) is driven by Euler angles, plus smooth
    seeded noise of ``noise`` radians (standard deviation) that never touches the legs.

    Args:
        segments: (kind, seconds[, overrides]) with kind in ``KINDS``.
        seed: varies amplitudes, stride frequency, speed (a few percent), the initial phase and
            the upper-body noise; the same seed gives the same motion.
        fps: frames per second (frame time ``1 / fps``).
        heading: facing direction, radians about +Y (0 faces +Z).
        height, units: body height in metres and the length unit, as in
            :func:`humanoid_skeleton`.
        noise: standard deviation (radians) of the smooth upper-body noise; 0 disables it.
        blend: transition length in seconds (clipped to the shortest segment).
    """
    if not segments:
        raise ValueError("procedural_sequence needs at least one segment")
    if not fps > 0:
        raise ValueError(f"fps must be positive, got {fps}")
    if noise < 0:
        raise ValueError(f"noise must be >= 0, got {noise}")
    skel = humanoid_skeleton(height, units)
    H = float(height) * _unit_scale(units)
    froude = np.sqrt(float(height) / _REF_HEIGHT)
    rng = np.random.default_rng(seed)
    phase0 = float(rng.uniform())
    idle0 = float(rng.uniform())
    kinds, durations, params = _segment_params(segments, rng, froude)
    bounds = np.concatenate([[0.0], np.cumsum(durations)])
    F = max(1, round(bounds[-1] * fps))
    blend = float(min(blend, min(durations))) if len(segments) > 1 else 1.0
    blend = max(blend, 1e-6)
    gait = _gait_timeline(params, bounds, F, fps, blend, froude, units, phase0, idle0)
    path = _path_frame(heading)
    sl = slice(gait.pad, gait.pad + F)

    off = skel.offsets
    l1 = float(np.linalg.norm(off[skel.index("LeftLeg")]))
    l2 = float(np.linalg.norm(off[skel.index("LeftFoot")]))
    feet = _plan_feet(gait, path, H, off[skel.index("LeftToe")])
    R0, root_pos, hips = _pelvis(gait, path, H, skel, feet, 0.999 * (l1 + l2))
    local = _leg_rotations(R0, hips, feet, path, l1, l2)
    angles = {n: rot.matrix_to_euler(m[sl], ORDER) for n, m in local.items()}
    angles.update(_upper_body_angles(gait, F, fps, noise, rng))

    J = {n: i for i, n in enumerate(skel.names)}
    rotations = np.empty((F, skel.num_joints, 4))
    for n, a in angles.items():
        rotations[:, J[n]] = rot.euler_to_quat(a, ORDER)
    rotations = rot.quat_unroll(rotations, axis=0)
    motion = Motion(skel, rotations, root_pos[sl], 1.0 / fps)
    contacts = np.stack([feet["Left"][0][sl], feet["Right"][0][sl]], axis=-1)
    labels, segs = _segment_labels(kinds, bounds, F, fps)
    return SyntheticMotion(
        motion=motion,
        contacts=contacts,
        foot_joints=(J["LeftToe"], J["RightToe"]),
        phase=np.mod(gait.phase[sl], 1.0),
        angles={n: angles[n] for n in skel.names},
        labels=labels,
        segments=segs,
    )


def procedural_motion(
    kind: str,
    seconds: float = 4.0,
    fps: float = 30.0,
    seed: int = 0,
    speed: float | None = None,
    heading: float = 0.0,
    *,
    height: float = 1.7,
    units: str = "m",
    noise: float = 0.01,
    params: Mapping[str, float] | None = None,
) -> SyntheticMotion:
    """A procedural ``"walk"``, ``"run"``, ``"wave"`` or ``"idle"`` clip with ground truth.

    - walk: ~1.1 m/s (1.7 m body), stance 62 % of the cycle (double support), heel-toe roll,
      pelvis sway and counter-rotating chest, arms swinging opposite to the legs.
    - run: ~3 m/s, stance 36 % (two flight phases per cycle), forward lean, bent elbows.
    - wave: standing (both feet planted), right arm raised, forearm oscillating at ~2 Hz.
    - idle: standing, slow lateral weight shift and breathing.

    ``speed`` (m/s, walk and run only) changes the speed; the stride frequency follows
    ``speed ** 0.5``. ``params`` overrides entries of the gait table (see ``_PARAMS``). See
    :func:`procedural_sequence` for the construction and the other arguments.
    """
    ov = dict(params or {})
    if speed is not None:
        ov["speed"] = speed
    return procedural_sequence(
        [(kind, seconds, ov)],
        seed,
        fps=fps,
        heading=heading,
        height=height,
        units=units,
        noise=noise,
    )
