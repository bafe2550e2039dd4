"""Tests for mocapkit.features: resampling, up/unit detection, facing, ground alignment, local
positions and foot contacts (synthetic skeletons, plus real data when the shared folder exists)."""

from __future__ import annotations

import itertools
import math
import warnings

import numpy as np
import pytest

from mocapkit import features as fe
from mocapkit.body import body_of, split_name
from mocapkit.core import rotations as rot
from mocapkit.core.kinematics import forward_kinematics
from mocapkit.core.motion import Motion
from mocapkit.core.runs import true_runs
from mocapkit.core.skeleton import Skeleton
from mocapkit.io.bvh import read_bvh

# --------------------------------------------------------------------------- synthetic data

SIX = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
THREE = ("Zrotation", "Xrotation", "Yrotation")

# A Y-up T-pose humanoid in metres facing +Z (so its left is +X), ~1.7 m tall.
_JOINTS = [
    ("Hips", None, (0.0, 0.95, 0.0)),
    ("Spine", "Hips", (0.0, 0.12, 0.0)),
    ("Chest", "Spine", (0.0, 0.15, 0.0)),
    ("Neck", "Chest", (0.0, 0.22, 0.0)),
    ("Head", "Neck", (0.0, 0.12, 0.0)),
    ("LeftShoulder", "Chest", (0.05, 0.18, 0.0)),
    ("LeftArm", "LeftShoulder", (0.13, 0.0, 0.0)),
    ("LeftForeArm", "LeftArm", (0.28, 0.0, 0.0)),
    ("LeftHand", "LeftForeArm", (0.25, 0.0, 0.0)),
    ("RightShoulder", "Chest", (-0.05, 0.18, 0.0)),
    ("RightArm", "RightShoulder", (-0.13, 0.0, 0.0)),
    ("RightForeArm", "RightArm", (-0.28, 0.0, 0.0)),
    ("RightHand", "RightForeArm", (-0.25, 0.0, 0.0)),
    ("LeftUpLeg", "Hips", (0.09, -0.05, 0.0)),
    ("LeftLeg", "LeftUpLeg", (0.0, -0.42, 0.0)),
    ("LeftFoot", "LeftLeg", (0.0, -0.41, 0.0)),
    ("LeftToeBase", "LeftFoot", (0.0, -0.05, 0.13)),
    ("RightUpLeg", "Hips", (-0.09, -0.05, 0.0)),
    ("RightLeg", "RightUpLeg", (0.0, -0.42, 0.0)),
    ("RightFoot", "RightLeg", (0.0, -0.41, 0.0)),
    ("RightToeBase", "RightFoot", (0.0, -0.05, 0.13)),
]

# Rotations taking the Y-up frame to other up axes (applied to offsets and root paths).
_TO_UP = {
    "Y": np.eye(3),
    "Z": np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]),  # +90 deg about X: Y -> Z
    "X": np.array([[0, 1.0, 0], [-1, 0, 0], [0, 0, 1]]),  # -90 deg about Z: Y -> X
    "-Y": np.diag([1.0, -1.0, -1.0]),  # 180 deg about X: Y -> -Y
}


def humanoid(scale: float = 1.0, up: str = "Y", names: list[str] | None = None) -> Skeleton:
    """The T-pose humanoid, offsets times ``scale``, rotated so that its up is ``up``."""
    jn = [j[0] for j in _JOINTS]
    parents = [-1 if p is None else jn.index(p) for _, p, _ in _JOINTS]
    offsets = np.array([o for _, _, o in _JOINTS]) @ _TO_UP[up].T * scale
    channels = [SIX] + [THREE] * (len(jn) - 1)
    return Skeleton(tuple(names or jn), np.array(parents), offsets, tuple(channels))


def smooth_motion(
    sk: Skeleton,
    frames: int = 90,
    fps: float = 30.0,
    seed: int = 0,
    amp: float = 0.3,
    freq: float = 0.5,
) -> Motion:
    """Smooth sinusoidal joint rotations and a curved root path on the ground."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames) / fps
    J = sk.num_joints
    phase = rng.uniform(0, 2 * np.pi, size=(J, 3))
    fr = freq * rng.uniform(0.5, 1.5, size=(J, 3))
    ang = amp * np.sin(2 * np.pi * fr[None] * t[:, None, None] + phase[None])  # (F, J, 3)
    q = rot.euler_to_quat(ang, "ZXY")
    up = fe.detect_up_axis(sk)
    side, u, fwd = fe.ground_frame(up)
    s = sk.height() / 1.7
    root = (
        sk.offsets[0]
        + (0.8 * s * t)[:, None] * fwd
        + (0.3 * s * np.sin(t))[:, None] * side
        + (0.02 * s * np.sin(4 * t))[:, None] * u
    )
    return Motion(sk, q, root, 1.0 / fps)


def moved(motion: Motion, angle: float, offset_2d: tuple[float, float], up: str) -> Motion:
    return fe.apply_ground_transform(motion, fe.GroundTransform.from_2d(angle, offset_2d, up))


def wrap(a: np.ndarray | float) -> np.ndarray:
    return np.angle(np.exp(1j * np.asarray(a)))


# --------------------------------------------------------------------------- shared data


@pytest.fixture
def bandai(shared_path):
    """``bandai("walk", "normal")`` reads ``dataset-1_walk_normal_001.bvh`` (skips without data)."""
    root = shared_path("bandai1/data")

    def load(content: str, style: str = "normal", take: int = 1) -> Motion:
        return read_bvh(root / f"dataset-1_{content}_{style}_{take:03d}.bvh")

    return load


@pytest.fixture
def corpus(shared_path):
    """``corpus(name)`` reads a bvh-corpus file leniently (skips without data)."""
    root = shared_path("bvh-corpus")

    def load(name: str) -> Motion:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return read_bvh(root / name, lenient=True)

    return load


# --------------------------------------------------------------------------- axes


@pytest.mark.parametrize("up", ["Y", "Z", "X", "-Y", "-Z", "+x", "y"])
def test_ground_frame_is_right_handed(up):
    side, u, fwd = fe.ground_frame(up)
    np.testing.assert_allclose(np.cross(side, u), fwd)
    s, a, f = fe.ground_plane_axes(up)
    assert sorted((s, a, f)) == [0, 1, 2]
    assert np.abs(u)[a] == 1 and np.abs(fwd)[f] == 1 and np.abs(side)[s] == 1


def test_ground_plane_axes_y_and_z():
    assert fe.ground_plane_axes("Y") == (0, 1, 2)
    assert fe.ground_plane_axes("Z") == (1, 2, 0)
    with pytest.raises(ValueError):
        fe.ground_plane_axes("W")


# --------------------------------------------------------------------------- resampling


def test_resample_round_trip_integer_ratio_is_exact():
    m = smooth_motion(humanoid(), frames=75, fps=30.0)
    up = fe.resample(m, 120.0)
    assert up.frame_time == 1.0 / 120.0
    assert up.num_frames == 4 * 75 - 3  # frame 0 to the last captured frame, none made up
    # no frame repeats its neighbour: the motion never stops, so neither may the resampled one
    assert rot.quat_angle(up.rotations[1:], up.rotations[:-1]).max(axis=1).min() > 1e-6
    np.testing.assert_array_equal(up.rotations[-1], m.rotations[-1])
    back = fe.resample(up, 30.0)
    assert back.frame_time == 1.0 / 30.0
    assert back.num_frames == m.num_frames
    assert back.allclose(m, rot_atol=1e-9, pos_atol=1e-12)


@pytest.mark.parametrize("fps", [47.0, 24.0, 59.94, 100.0])
def test_resample_round_trip_smooth_within_tolerance(fps):
    m = smooth_motion(humanoid(), frames=120, fps=30.0, freq=0.4)
    r = fe.resample(m, fps)
    assert r.frame_time == 1.0 / fps
    span, r_span = (m.num_frames - 1) * m.frame_time, (r.num_frames - 1) * r.frame_time
    assert abs(r_span - span) <= 0.5 * r.frame_time + 1e-12
    back = fe.resample(r, 30.0)
    assert back.num_frames == m.num_frames
    assert abs(back.duration - m.duration) < 1e-9
    # compare away from the clamped tail
    n = m.num_frames - 3
    err = rot.quat_angle(back.rotations[:n], m.rotations[:n]).max()
    assert err < 5e-3
    np.testing.assert_allclose(back.root_positions[:n], m.root_positions[:n], atol=2e-3)


@pytest.mark.parametrize("fps", [47.0, 24.0, 12.5, 120.0])
def test_resample_constant_speed_rotation_is_exact(fps):
    sk = humanoid()
    F, src_fps = 40, 30.0
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    omega = 2.5  # rad/s, below pi per frame
    t = np.arange(F) / src_fps
    q = np.tile(rot.quat_identity(), (F, sk.num_joints, 1))
    q[:, 3] = rot.rotvec_to_quat(axis * omega * t[:, None])
    q[::2, 3] *= -1.0  # arbitrary signs: resample must make the track continuous itself
    root = np.array([0.0, 0.9, 0.0]) + np.outer(t, [0.4, 0.0, 1.1])
    m = Motion(sk, q, root, 1.0 / src_fps)
    r = fe.resample(m, fps)
    n = r.num_frames
    assert n == math.floor((F - 1) / src_fps * fps + 0.5) + 1
    tn = np.minimum(np.arange(n) / fps, (F - 1) / src_fps)  # clamped at the last frame
    expected = rot.rotvec_to_quat(axis * omega * tn[:, None])
    assert rot.quat_angle(r.rotations[:, 3], expected).max() < 1e-9
    expected_root = np.array([0.0, 0.9, 0.0]) + np.outer(tn, [0.4, 0.0, 1.1])
    np.testing.assert_allclose(r.root_positions, expected_root, atol=1e-12)
    assert rot.quat_angle(r.rotations[:, 0], rot.quat_identity()).max() == 0.0


def test_resample_interpolates_translations_and_keeps_root_column():
    sk = humanoid()
    m = smooth_motion(sk, frames=20)
    tr = m.local_translations()
    tr[:, 5] += np.linspace(0, 1, 20)[:, None]
    m = Motion(sk, m.rotations, m.root_positions, m.frame_time, tr)
    r = fe.resample(m, 60.0)
    assert r.translations is not None
    np.testing.assert_array_equal(r.translations[:, 0], r.root_positions)
    np.testing.assert_allclose(r.translations[1, 5], 0.5 * (tr[0, 5] + tr[1, 5]))


def test_resample_edge_cases():
    m = smooth_motion(humanoid(), frames=1)
    r = fe.resample(m, 60.0)
    assert r.num_frames == 1  # one sample spans no time: nothing to make up
    np.testing.assert_array_equal(r.rotations[0], m.rotations[0])
    assert fe.resample(m[0:0], 60.0).num_frames == 0
    with pytest.raises(ValueError):
        fe.resample(m, 0.0)


# --------------------------------------------------------------------------- up axis and units


@pytest.mark.parametrize("up", ["Y", "Z", "X", "-Y"])
def test_detect_up_axis_synthetic(up):
    sk = humanoid(up=up)
    assert fe.detect_up_axis(sk) == up
    assert fe.detect_up_axis(smooth_motion(sk, frames=30)) == up


def test_detect_up_axis_without_names_uses_geometry():
    sk = humanoid(up="Z", names=[f"j{i}" for i in range(len(_JOINTS))])
    assert fe.detect_up_axis(sk) == "Z"


@pytest.mark.parametrize(
    ("factor", "unit"),
    [(1.0, "m"), (100.0, "cm"), (1000.0, "mm"), (1 / 0.0254, "inch")],
)
@pytest.mark.parametrize("body", [0.75, 1.0, 1.25])  # ~1.3 m, 1.7 m and 2.1 m tall
def test_detect_units_synthetic(factor, unit, body):
    sk = humanoid(scale=factor * body)
    name, mpu = fe.detect_units(sk)
    assert name == unit
    assert mpu == fe.UNITS[unit]
    m = smooth_motion(sk, frames=10)
    assert fe.detect_units(m)[0] == unit
    h_m = fe.character_height(sk) * mpu
    assert 0.85 * body * 1.45 < h_m < 1.15 * body * 1.45


def test_detect_units_candidates():
    sk = humanoid(scale=0.45 / 0.0254 * 0.9)  # CMU-like units (1/0.45 inch)
    assert fe.detect_units(sk, {**fe.UNITS, "cmu": 0.0254 / 0.45})[0] == "cmu"


@pytest.mark.shared
@pytest.mark.parametrize(
    ("name", "up", "unit"),
    [
        ("PeizhuoLi__ganimator__Walk-In-Circle.bvh", "Y", "cm"),  # Mixamo, Y-up cm
        ("VictorS-67__pybvh__bvh_test1.bvh", "Z", None),  # manifest: Z-up
        ("emretanirgan__BVH_Viewer__jump_from_stand_.bvh", "Z", None),  # manifest: Z-up
        ("KevinLTT__video2bvh__cxk.bvh", "Z", "mm"),  # manifest: Z-up, mm
        ("guillefix__shadermotion-bvh-utils__test.bvh", "Y", "m"),  # manifest: metres
        ("iamthephd__WHAM__sample.bvh", "Y", "m"),  # manifest: metres
        ("Zju-George__video2bvh_hmr__result.bvh", "Y", "m"),  # manifest: metres
    ],
)
def test_detect_on_corpus(corpus, name, up, unit):
    m = corpus(name)
    assert fe.detect_up_axis(m) == up
    if unit is not None:
        assert fe.detect_units(m)[0] == unit


@pytest.mark.shared
def test_detect_on_bandai(bandai):
    m = bandai("walk")
    assert fe.detect_up_axis(m) == "Y"
    assert fe.detect_units(m) == ("cm", 0.01)
    assert fe.pelvis_index(m.skeleton) == m.skeleton.index("Hips")


# --------------------------------------------------------------------------- names


@pytest.mark.parametrize(
    ("name", "side", "base"),
    [
        ("LeftUpLeg", "left", "upleg"),
        ("mixamorig:RightUpLeg", "right", "upleg"),
        ("UpperLeg_L", "left", "upperleg"),
        ("LHipJoint", "left", "hipjoint"),
        ("lfemur", "left", "femur"),
        ("rtoes", "right", "toes"),
        ("Bip01_R_Thigh", "right", "thigh"),
        ("thigh.L", "left", "thigh"),
        ("Left_ankle", "left", "ankle"),
        ("CC_Base_L_Foot", "left", "foot"),
        ("LowerLeg_R", "right", "lowerleg"),
        ("Hips", "", "hips"),
        ("root", "", "root"),
        ("LeftForeArm", "left", "forearm"),
    ],
)
def test_name_parts(name, side, base):
    assert split_name(name) == (side, base)


def test_feet_and_pairs_by_name():
    sk = humanoid()
    feet = fe.find_feet(sk)
    assert [(s, sk.names[j]) for s, j in feet] == [
        ("left", "LeftFoot"),
        ("left", "LeftToeBase"),
        ("right", "RightFoot"),
        ("right", "RightToeBase"),
    ]
    assert [sk.names[j] for j in body_of(sk).pair("shoulder")] == ["LeftArm", "RightArm"]
    assert fe.pelvis_index(sk) == 0


def test_feet_without_names_come_from_structure():
    named = humanoid()
    sk = humanoid(names=[f"j{i}" for i in range(len(_JOINTS))])
    # the body model finds ankle and toe of both legs by structure, with the same sides
    assert fe.find_feet(sk) == fe.find_feet(named)


# --------------------------------------------------------------------------- facing


@pytest.mark.parametrize("up", ["Y", "Z", "-Y"])
def test_rest_facing_is_forward_axis(up):
    m = smooth_motion(humanoid(up=up), frames=1, amp=0.0)
    m.rotations[:] = rot.quat_identity()
    f = fe.facing_directions(m, up)
    expected = _TO_UP[up] @ [0.0, 0.0, 1.0]  # the humanoid faces its (rotated) +Z
    np.testing.assert_allclose(f[0], expected, atol=1e-12)
    side, _, fwd = fe.ground_frame(up)
    h = fe.heading_angles(m, up)[0]
    np.testing.assert_allclose(math.cos(h) * fwd + math.sin(h) * side, expected, atol=1e-12)
    if up == "Y":
        assert h == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("up", ["Y", "Z"])
@pytest.mark.parametrize("angle", [0.3, -2.0, 3.0])
def test_facing_rotates_with_the_motion(up, angle):
    m = smooth_motion(humanoid(up=up), frames=40, seed=3)
    h0 = fe.heading_angles(m, up)
    h1 = fe.heading_angles(moved(m, angle, (1.5, -0.7), up), up)
    np.testing.assert_allclose(wrap(h1 - h0 - angle), 0.0, atol=1e-9)
    f0, f1 = fe.facing_directions(m, up), fe.facing_directions(moved(m, angle, (0, 0), up), up)
    np.testing.assert_allclose(np.linalg.norm(f1, axis=1), 1.0)
    np.testing.assert_allclose(f1 @ fe.ground_frame(up)[1], 0.0, atol=1e-12)
    np.testing.assert_allclose(np.einsum("fi,fi->f", f0, f1), math.cos(angle), atol=1e-9)


def test_facing_fallback_without_names_uses_root_rotation():
    names = [f"j{i}" for i in range(len(_JOINTS))]
    m = smooth_motion(humanoid(names=names), frames=30, seed=1)
    angle = 1.1
    h0 = fe.heading_angles(m, "Y")
    h1 = fe.heading_angles(moved(m, angle, (0.0, 0.0), "Y"), "Y")
    np.testing.assert_allclose(wrap(h1 - h0 - angle), 0.0, atol=1e-9)


@pytest.mark.shared
def test_facing_follows_walking_direction(bandai):
    for style in ("normal", "happy", "old"):
        m = bandai("walk", style)
        tr = fe.root_trajectory(m)
        v = np.gradient(tr, axis=0)
        moving = np.linalg.norm(v, axis=1) > 0.5  # cm per frame
        h = fe.heading_angles(m)
        d = wrap(h - np.arctan2(v[:, 0], v[:, 1]))[moving]
        assert abs(np.degrees(np.median(d))) < 10
        back = fe.heading_angles(bandai("walk-back", style))
        assert abs(np.degrees(np.median(wrap(back)))) < 20  # faces +Z while walking to -Z


# --------------------------------------------------------------------------- ground alignment


def _pelvis_ground_and_heading(m: Motion, frame: int, up: str):
    pos, _ = forward_kinematics(m)
    p = pos[frame, fe.pelvis_index(m.skeleton)]
    return fe.ground_coordinates(p, up), p @ fe.ground_frame(up)[1], fe.heading_angles(m, up)[frame]


@pytest.mark.parametrize("up", ["Y", "Z", "-Y"])
def test_ground_alignment_makes_position_and_facing_coincide(up):
    a = smooth_motion(humanoid(up=up), frames=50, seed=4)
    b = moved(smooth_motion(humanoid(up=up), frames=60, seed=5), 2.2, (3.0, -1.0), up)
    T = fe.ground_alignment(a, 30, b, 7, up)
    b2 = fe.apply_ground_transform(b, T)
    ga, _, ha = _pelvis_ground_and_heading(a, 30, up)
    _, hb_before, _ = _pelvis_ground_and_heading(b, 7, up)
    gb2, hb_after, hb2 = _pelvis_ground_and_heading(b2, 7, up)
    np.testing.assert_allclose(gb2, ga, atol=1e-12)
    assert wrap(hb2 - ha) == pytest.approx(0.0, abs=1e-12)
    assert hb_after == pytest.approx(hb_before, abs=1e-12)  # heights untouched
    np.testing.assert_allclose(T.translation @ fe.ground_frame(up)[1], 0.0, atol=0)


@pytest.mark.shared
def test_ground_alignment_on_bandai(bandai):
    a, b = bandai("walk", "happy"), bandai("run", "old")
    T = fe.ground_alignment(a, a.num_frames - 1, b, 10)
    b2 = fe.apply_ground_transform(b, T)
    ga, _, ha = _pelvis_ground_and_heading(a, a.num_frames - 1, "Y")
    _, yb, _ = _pelvis_ground_and_heading(b, 10, "Y")
    gb2, yb2, hb2 = _pelvis_ground_and_heading(b2, 10, "Y")
    np.testing.assert_allclose(gb2, ga, atol=1e-9)
    assert wrap(hb2 - ha) == pytest.approx(0.0, abs=1e-9)
    assert yb2 == pytest.approx(yb, abs=1e-9)
    # the whole clip moved rigidly: pairwise joint distances unchanged
    p, _ = forward_kinematics(b)
    p2, _ = forward_kinematics(b2)
    np.testing.assert_allclose(p2, T.apply(p), atol=1e-8)


def test_ground_transform_inverse_and_compose():
    T = fe.GroundTransform.from_2d(0.7, (1.0, 2.0), "Z")
    U = fe.GroundTransform.from_2d(-2.1, (-0.5, 0.3), "Z")
    p = np.random.default_rng(0).normal(size=(10, 3))
    np.testing.assert_allclose(T.inverse().apply(T.apply(p)), p, atol=1e-12)
    np.testing.assert_allclose(T.compose(U).apply(p), T.apply(U.apply(p)), atol=1e-12)
    np.testing.assert_allclose(T.apply(p)[:, 2], p[:, 2])  # heights untouched
    np.testing.assert_allclose(T.translation_2d, [1.0, 2.0])


def test_apply_ground_transform_to_channel_less_root():
    # A VR-style rig: root without channels, 6-channel children (as in Firepal's test.bvh).
    sk = Skeleton(
        ("root", "head", "hand_l", "hand_r"),
        np.array([-1, 0, 0, 0]),
        np.zeros((4, 3)),
        ((), SIX, SIX, SIX),
    )
    rng = np.random.default_rng(2)
    F = 5
    q = rot.quat_normalize(rng.normal(size=(F, 4, 4)))
    q[:, 0] = rot.quat_identity()
    tr = rng.normal(size=(F, 4, 3))
    tr[:, 0] = 0.0
    m = Motion(sk, q, np.zeros((F, 3)), 1 / 72, tr)
    T = fe.GroundTransform(0.9, np.array([1.0, 5.0, -2.0]), "Y")
    m2 = fe.apply_ground_transform(m, T)
    np.testing.assert_array_equal(m2.rotations[:, 0], rot.quat_identity(F))  # still identity
    p, _ = forward_kinematics(m)
    p2, _ = forward_kinematics(m2)
    np.testing.assert_allclose(p2[:, 1:], T.apply(p[:, 1:]), atol=1e-12)


# --------------------------------------------------------------------------- Kovar & Gleicher


def _cost(a, b, w, theta, x0, z0):
    ga, gb = fe.ground_coordinates(a, "Y"), fe.ground_coordinates(b, "Y")
    c, s = np.cos(theta), np.sin(theta)
    x = gb[:, 0] * c + gb[:, 1] * s + x0
    z = -gb[:, 0] * s + gb[:, 1] * c + z0
    return np.sum(w * ((ga[:, 0] - x) ** 2 + (ga[:, 1] - z) ** 2))


def _best_cost_for_theta(a, b, w, theta):
    """Exact optimum over the translation for fixed angles theta (...,): the weighted centroid
    difference. Vectorised over theta."""
    ga, gb = fe.ground_coordinates(a, "Y"), fe.ground_coordinates(b, "Y")
    c, s = np.cos(theta)[..., None], np.sin(theta)[..., None]
    rb = np.stack([gb[:, 0] * c + gb[:, 1] * s, -gb[:, 0] * s + gb[:, 1] * c], axis=-1)
    d = ga - rb  # (..., n, 2)
    t = np.einsum("n,...ni->...i", w, d) / w.sum()
    return np.einsum("n,...n->...", w, np.sum((d - t[..., None, :]) ** 2, axis=-1))


@pytest.mark.parametrize("seed", range(8))
def test_align_point_clouds_2d_matches_brute_force(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 40))
    b = rng.normal(size=(n, 3)) * [1.0, 0.5, 2.0]
    true = fe.GroundTransform.from_2d(rng.uniform(-np.pi, np.pi), rng.normal(size=2) * 3, "Y")
    a = true.apply(b) + rng.normal(size=(n, 3)) * 0.3 * (seed % 2)  # noisy on odd seeds
    a[:, 1] += rng.normal(size=n)  # heights are irrelevant
    w = rng.uniform(0.0, 2.0, size=n)
    T = fe.align_point_clouds_2d(a, b, w, up="Y")
    x0, z0 = T.translation_2d
    got = _cost(a, b, w, T.angle, x0, z0)
    thetas = np.linspace(-np.pi, np.pi, 20001)
    brute = _best_cost_for_theta(a, b, w, thetas)
    k = int(np.argmin(brute))
    assert got <= brute[k] + 1e-9
    assert abs(wrap(T.angle - thetas[k])) < 2 * (thetas[1] - thetas[0]) + 1e-6 or np.isclose(
        got, brute[k], rtol=1e-6
    )
    # translation is the optimum for that angle
    assert got == pytest.approx(
        _best_cost_for_theta(a, b, w, np.float64(T.angle)), rel=1e-9, abs=1e-12
    )
    if seed % 2 == 0:  # noise-free: the true transform comes back
        assert wrap(T.angle - true.angle) == pytest.approx(0.0, abs=1e-9)
        np.testing.assert_allclose(T.translation, true.translation, atol=1e-9)


@pytest.mark.parametrize("up", ["Z", "-Y", "X"])
def test_align_point_clouds_2d_other_up_axes(up):
    rng = np.random.default_rng(7)
    b = rng.normal(size=(12, 3))
    true = fe.GroundTransform.from_2d(-1.3, (0.4, -2.0), up)
    T = fe.align_point_clouds_2d(true.apply(b), b, None, up=up)
    np.testing.assert_allclose(T.apply(b), true.apply(b), atol=1e-9)


def test_align_point_clouds_2d_rejects_bad_weights():
    p = np.zeros((3, 3))
    with pytest.raises(ValueError):
        fe.align_point_clouds_2d(p, p, np.zeros(3))
    with pytest.raises(ValueError):
        fe.align_point_clouds_2d(p, p[:2])


# --------------------------------------------------------------------------- local positions


@pytest.mark.parametrize("up", ["Y", "Z"])
def test_local_positions_invariant_under_ground_transform(up):
    m = smooth_motion(humanoid(up=up), frames=40, seed=6)
    lp = fe.local_positions(m, up)
    for angle, off in [(0.8, (2.0, -3.0)), (-3.0, (0.0, 10.0))]:
        np.testing.assert_allclose(fe.local_positions(moved(m, angle, off, up), up), lp, atol=1e-10)
    # faces the forward axis, pelvis above the origin, heights kept
    side, u, fwd = fe.ground_frame(up)
    pel = fe.pelvis_index(m.skeleton)
    np.testing.assert_allclose(lp[:, pel] @ side, 0.0, atol=1e-12)
    np.testing.assert_allclose(lp[:, pel] @ fwd, 0.0, atol=1e-12)
    pos, _ = forward_kinematics(m)
    np.testing.assert_allclose(lp @ u, pos @ u, atol=1e-12)
    hips = body_of(m.skeleton).pair("hip")
    across = lp[:, hips[0]] - lp[:, hips[1]]
    shoulders = body_of(m.skeleton).pair("shoulder")
    across2 = lp[:, shoulders[0]] - lp[:, shoulders[1]]
    a = across / np.linalg.norm(across, axis=1, keepdims=True)
    a2 = across2 / np.linalg.norm(across2, axis=1, keepdims=True)
    np.testing.assert_allclose((a + a2) @ fwd, 0.0, atol=1e-9)  # left-right axis is lateral
    assert np.all((a + a2) @ side > 0)  # left is +side


@pytest.mark.shared
def test_local_positions_invariant_on_bandai(bandai):
    m = bandai("walk-left", "normal")
    lp = fe.local_positions(m)
    np.testing.assert_allclose(
        fe.local_positions(moved(m, -1.9, (250.0, 40.0), "Y")), lp, atol=1e-8
    )


# --------------------------------------------------------------------------- foot contacts


def test_clean_flags():
    x = np.array([1, 1, 0, 1, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 0, 0], dtype=bool)
    got = fe._clean_flags(x, max_gap=1, max_spike=1)
    want = np.array([1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 1, 1, 0, 0], dtype=bool)
    np.testing.assert_array_equal(got, want)
    edge = np.array([1, 0, 0, 0, 1], dtype=bool)  # runs at the ends are kept
    np.testing.assert_array_equal(fe._clean_flags(edge, 1, 1), edge)


def _alternates(fc: fe.FootContacts) -> bool:
    """Contact onsets alternate between the left and right feet."""
    bs = fc.by_side()
    onsets = []
    for k in range(2):
        for a, _ in true_runs(bs[:, k]):
            if a > 0:
                onsets.append((a, k))
    sides = [k for _, k in sorted(onsets)]
    return len(sides) >= 3 and all(s != t for s, t in itertools.pairwise(sides))


@pytest.mark.shared
@pytest.mark.parametrize("style", ["normal", "happy", "tired", "childish", "feminine", "proud"])
def test_foot_contacts_bandai_walk(bandai, style):
    m = bandai("walk", style)
    fc = fe.foot_contacts(m)
    assert fc.names == ("Foot_L", "Toes_L", "Foot_R", "Toes_R")
    assert fc.sides == ("left", "left", "right", "right")
    bs = fc.by_side()
    duty = fc.duty_factors()
    assert np.all((duty > 0.5) & (duty < 0.8)), duty
    assert (bs[:, 0] & bs[:, 1]).mean() > 0.03  # double support
    assert not (~bs[:, 0] & ~bs[:, 1]).any()  # never airborne
    assert _alternates(fc)


@pytest.mark.shared
@pytest.mark.parametrize("style", ["feminine", "happy", "angry", "childish", "musical", "old"])
def test_foot_contacts_bandai_run(bandai, style):
    m = bandai("run", style)
    fc = fe.foot_contacts(m)
    bs = fc.by_side()
    duty = fc.duty_factors()
    assert np.all((duty > 0.2) & (duty < 0.5)), duty
    assert (~bs[:, 0] & ~bs[:, 1]).mean() > 0.1  # flight phases
    assert (bs[:, 0] & bs[:, 1]).mean() < 0.05
    assert _alternates(fc)


@pytest.mark.shared
def test_foot_contacts_scale_and_units_invariant(bandai):
    m = bandai("walk", "tired")
    fc = fe.foot_contacts(m)
    # the same clip in metres: identical defaults (relative to the character's size) ...
    tr = None if m.translations is None else m.translations * 0.01
    m_m = Motion(m.skeleton.scaled(0.01), m.rotations, m.root_positions * 0.01, m.frame_time, tr)
    assert fe.detect_units(m_m)[0] == "m"
    np.testing.assert_array_equal(fe.foot_contacts(m_m).contacts, fc.contacts)
    # ... and identical explicit thresholds in metres / metres per second
    kw = dict(height_threshold=0.06, velocity_threshold=0.8)
    np.testing.assert_array_equal(
        fe.foot_contacts(m_m, **kw).contacts, fe.foot_contacts(m, **kw).contacts
    )
    assert fe.foot_contacts(m, units="cm", **kw).height_threshold == pytest.approx(6.0)
    # and at another frame rate the pattern is the same over time
    r = fe.resample(m, 60.0)
    bs60 = fe.foot_contacts(r).by_side()[::2][: m.num_frames]
    assert (bs60 == fc.by_side()[: len(bs60)]).mean() > 0.9


def test_foot_contacts_explicit_feet_and_errors():
    m = smooth_motion(humanoid(), frames=30)
    fc = fe.foot_contacts(m, feet=["LeftToeBase", 20])
    assert fc.names == ("LeftToeBase", "RightToeBase")
    assert fc.contacts.shape == (30, 2)
    assert fc.by_side().shape == (30, 2)


@pytest.mark.parametrize("kind", ["walk", "run"])
@pytest.mark.parametrize("fps", [30.0, 60.0])
def test_foot_contacts_procedural_humanoid(kind, fps):
    datasets = pytest.importorskip("mocapkit.datasets")
    if not hasattr(datasets, "procedural_motion"):
        pytest.skip("mocapkit.datasets has no procedural_motion")
    for seed in (0, 1):
        syn = datasets.procedural_motion(kind, seconds=5.0, fps=fps, seed=seed)
        fc = fe.foot_contacts(syn.motion)
        assert fe.detect_up_axis(syn.motion) == "Y"
        assert fe.detect_units(syn.motion)[0] == "m"
        agree = (fc.by_side() == np.asarray(syn.contacts, dtype=bool)).mean()
        assert agree >= 0.9, (kind, fps, seed, agree)


# --------------------------------------------------------------------------- trajectories


@pytest.mark.parametrize("up", ["Y", "Z"])
def test_root_trajectory_is_pelvis_ground_path(up):
    m = smooth_motion(humanoid(up=up), frames=20)
    tr = fe.root_trajectory(m, up)
    pos, _ = forward_kinematics(m)
    np.testing.assert_allclose(tr, fe.ground_coordinates(pos[:, 0], up))
    assert tr.shape == (20, 2)


# ---------------------------------------------------------------------------------------------
# limb hinges (knees and elbows)


def _renamed(sk: Skeleton, names: dict[str, str]) -> Skeleton:
    import dataclasses

    return dataclasses.replace(sk, names=tuple(names.get(n, n) for n in sk.names))


def test_limb_hinges_by_name_under_common_schemes() -> None:
    from mocapkit.datasets import humanoid_skeleton

    sk = humanoid_skeleton()  # Mixamo-like: LeftLeg is the knee, LeftArm the upper arm
    want = sorted(sk.names.index(n) for n in ("LeftForeArm", "RightForeArm", "LeftLeg", "RightLeg"))
    assert fe.limb_hinges(sk) == want
    schemes = [
        {"LeftForeArm": "LowerArm_L", "RightForeArm": "LowerArm_R", "LeftLeg": "LowerLeg_L",
         "RightLeg": "LowerLeg_R", "LeftUpLeg": "UpperLeg_L", "RightUpLeg": "UpperLeg_R"},
        {"LeftForeArm": "lradius", "RightForeArm": "rradius", "LeftLeg": "ltibia",
         "RightLeg": "rtibia", "LeftUpLeg": "lfemur", "RightUpLeg": "rfemur"},
        {"LeftForeArm": "mixamorig:LeftForeArm", "RightForeArm": "mixamorig:RightForeArm",
         "LeftLeg": "mixamorig:LeftLeg", "RightLeg": "mixamorig:RightLeg"},
    ]  # fmt: skip
    for scheme in schemes:
        assert fe.limb_hinges(_renamed(sk, scheme)) == want, scheme
    # a twist bone named like a forearm is not the elbow
    twist = _renamed(sk, {"LeftForeArm": "LeftForeArmTwist", "LeftHand": "LeftForeArm"})
    assert sk.names.index("LeftForeArm") not in fe.limb_hinges(twist)


def test_limb_hinges_by_structure_when_names_say_nothing() -> None:
    from mocapkit.datasets import humanoid_skeleton

    sk = humanoid_skeleton()
    anonymous = _renamed(sk, {n: f"j{i}" for i, n in enumerate(sk.names)})
    want = sorted(sk.names.index(n) for n in ("LeftForeArm", "RightForeArm", "LeftLeg", "RightLeg"))
    assert fe.limb_hinges(anonymous) == want  # not the spine, neck or hips


def test_up_disagreement_names_the_bodys_axis() -> None:
    from mocapkit import datasets
    from mocapkit.features import up_disagreement

    walk = datasets.procedural_motion("walk", 2.0, seed=0).motion  # Y up
    assert up_disagreement(walk, "Y") is None and up_disagreement(walk, "+y") is None
    assert up_disagreement(walk, None) is None and up_disagreement(walk[:0], "Z") is None
    assert up_disagreement(walk, "Z") == "Y"


def test_resample_to_the_rate_a_file_rounds_is_no_change():
    """``Frame Time: 0.0333333`` is 30 fps written rounded: converting it to 30 fps must not
    interpolate every frame by a hair (newcomer report: up to 0.005 deg on every channel)."""
    m = smooth_motion(humanoid(), frames=90, fps=30.0)
    rounded = Motion(m.skeleton, m.rotations, m.root_positions, 0.0333333)
    same = fe.resample(rounded, 30.0)
    assert same.frame_time == 0.0333333 and same is not rounded
    np.testing.assert_array_equal(same.rotations, rounded.rotations)
    np.testing.assert_array_equal(same.root_positions, rounded.root_positions)
    other = fe.resample(rounded, 29.9)  # a real change of rate is made
    assert other.frame_time == 1 / 29.9 and not np.array_equal(other.rotations, rounded.rotations)
