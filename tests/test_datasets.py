"""Tests for mocapkit.datasets: Three-Circles and the procedural humanoid."""

from __future__ import annotations

import numpy as np
import pytest

from mocapkit.core import rotations as rot
from mocapkit.core.kinematics import end_site_positions, forward_kinematics
from mocapkit.datasets import (
    BACKWARD_CENTER,
    FORWARD_CENTER,
    KINDS,
    LARGE_CENTER,
    LARGE_RADIUS,
    SMALL_RADIUS,
    humanoid_skeleton,
    procedural_motion,
    procedural_sequence,
    three_circles,
    three_circles_pair,
)
from mocapkit.io.bvh import read_bvh, write_bvh

HEIGHT = 1.7

# --------------------------------------------------------------------------- Three-Circles


def _turning(points: np.ndarray, center: tuple[float, float]) -> np.ndarray:
    """z of (p - c) x v: > 0 counter-clockwise, < 0 clockwise."""
    r = points[:-1] - np.asarray(center)
    v = np.diff(points, axis=0)
    return r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0]


def test_three_circles_geometry():
    tc = three_circles()
    assert tc.frames_per_cycle == 64
    for arr in (tc.large, tc.forward, tc.backward):
        assert arr.shape == (64, 2)
    np.testing.assert_allclose(np.linalg.norm(tc.large - LARGE_CENTER, axis=1), 20.0)
    np.testing.assert_allclose(np.linalg.norm(tc.forward - FORWARD_CENTER, axis=1), 10.0)
    np.testing.assert_allclose(np.linalg.norm(tc.backward - BACKWARD_CENTER, axis=1), 10.0)
    np.testing.assert_allclose(np.linalg.norm(tc.query - LARGE_CENTER, axis=1), LARGE_RADIUS)
    assert FORWARD_CENTER == (30.0, 10.0) and BACKWARD_CENTER == (30.0, -10.0)
    assert SMALL_RADIUS == 10.0
    # uniform speed: 2 pi r / 64 per frame on every circle
    for arr, r in ((tc.large, 20.0), (tc.forward, 10.0), (tc.backward, 10.0)):
        step = np.linalg.norm(np.diff(arr, axis=0), axis=1)
        np.testing.assert_allclose(step, 2 * r * np.sin(np.pi / 64))


def test_three_circles_period():
    tc = three_circles(frames_per_cycle=64, cycles=2.0)
    assert tc.large.shape == (128, 2)
    for arr in (tc.large, tc.forward, tc.backward):
        np.testing.assert_allclose(arr[64:], arr[:64], atol=1e-12)
        assert np.linalg.norm(arr[32] - arr[0]) > 1.0  # half a cycle away
    assert three_circles(frames_per_cycle=32, cycles=1.5).forward.shape == (48, 2)


def test_three_circles_directions():
    tc = three_circles()
    assert np.all(_turning(tc.large, LARGE_CENTER) > 0)  # counter-clockwise
    assert np.all(_turning(tc.query, LARGE_CENTER) > 0)
    assert np.all(_turning(tc.forward, FORWARD_CENTER) < 0)  # clockwise
    assert np.all(_turning(tc.backward, BACKWARD_CENTER) > 0)  # counter-clockwise
    # take-off B = (20, 0), moving up; the query AB is the last quarter before it
    np.testing.assert_allclose(tc.takeoff, [20.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(tc.large[-1], tc.takeoff, atol=1e-12)
    np.testing.assert_allclose(tc.query, tc.large[-17:], atol=1e-12)
    np.testing.assert_allclose(tc.query[0], [0.0, -20.0], atol=1e-12)
    v_q = tc.query[-1] - tc.query[-2]
    assert v_q[1] > 0 and abs(v_q[0]) < 0.2
    # data start at the points nearest the large circle, mirror images, equidistant from B
    for c, arr in ((FORWARD_CENTER, tc.forward), (BACKWARD_CENTER, tc.backward)):
        d = np.linalg.norm(arr, axis=1)
        assert np.argmin(d) == 0
        np.testing.assert_allclose(d[0], np.hypot(*c) - 10.0)
    np.testing.assert_allclose(tc.forward * [1, -1], tc.backward, atol=1e-12)
    np.testing.assert_allclose(
        np.linalg.norm(tc.forward[0] - tc.takeoff), np.linalg.norm(tc.backward[0] - tc.takeoff)
    )
    # "forward" continues the query's direction of travel, "backward" goes against it
    v_f = tc.forward[1] - tc.forward[0]
    v_b = tc.backward[1] - tc.backward[0]
    cos_f = v_f @ v_q / np.linalg.norm(v_f) / np.linalg.norm(v_q)
    cos_b = v_b @ v_q / np.linalg.norm(v_b) / np.linalg.norm(v_q)
    assert cos_f > 0.9 and cos_b < -0.9
    # the forward landing point lies ahead of B along the travel, the backward one behind it
    assert (tc.forward[0] - tc.takeoff) @ v_q > 0 > (tc.backward[0] - tc.takeoff) @ v_q


def test_three_circles_pair_and_parameters():
    q, x = three_circles_pair("forward")
    tc = three_circles()
    np.testing.assert_array_equal(q, tc.query)
    np.testing.assert_array_equal(x, tc.forward)
    q, x = three_circles_pair("backward", query_frames=8)
    assert q.shape == (8, 2)
    np.testing.assert_array_equal(x, tc.backward)
    tc2 = three_circles(takeoff_angle=np.pi / 2, forward_start_angle=0.0)
    np.testing.assert_allclose(tc2.takeoff, [0.0, 20.0], atol=1e-12)
    np.testing.assert_allclose(tc2.forward[0], [40.0, 10.0], atol=1e-12)
    with pytest.raises(ValueError):
        tc.data("sideways")
    with pytest.raises(ValueError):
        three_circles(frames_per_cycle=2)


# --------------------------------------------------------------------------- skeleton


def _standing_height(sk) -> float:
    p = sk.rest_positions()
    q = rot.quat_identity((1, sk.num_joints))
    e = end_site_positions(sk, p[None], q)[0]
    allp = np.concatenate([p, e])
    return float(allp[:, 1].max() - allp[:, 1].min())


@pytest.mark.parametrize(("height", "units", "scale"), [(1.7, "m", 1.0), (1.5, "cm", 100.0)])
def test_humanoid_skeleton(height, units, scale):
    sk = humanoid_skeleton(height, units)
    assert 18 <= sk.num_joints <= 24
    assert sk.parents[0] == -1 and np.all(sk.parents[1:] < np.arange(1, sk.num_joints))
    for name in (
        "Hips",
        "Spine",
        "Chest",
        "Neck",
        "Head",
        "LeftShoulder",
        "LeftArm",
        "LeftForeArm",
        "LeftHand",
        "RightHand",
        "LeftUpLeg",
        "LeftLeg",
        "LeftFoot",
        "LeftToe",
        "RightToe",
    ):
        sk.index(name)
    assert len(sk.channels[0]) == 6 and sk.has_position[0]
    assert all(sk.rotation_order(j) == "ZXY" for j in range(sk.num_joints))
    assert all(len(c) == 3 for c in sk.channels[1:])
    assert abs(_standing_height(sk) - height * scale) < 0.05 * height * scale
    p = sk.rest_positions()
    # Y up, left side at +X, feet on the ground, toes forward (+Z)
    assert p[sk.index("Head"), 1] > p[sk.index("Hips"), 1] > p[sk.index("LeftFoot"), 1]
    assert p[sk.index("LeftHand"), 0] > 0 > p[sk.index("RightHand"), 0]
    assert p[sk.index("LeftUpLeg"), 0] > 0 > p[sk.index("RightUpLeg"), 0]
    assert abs(p[sk.index("LeftToe"), 1]) < 1e-9
    assert p[sk.index("LeftToe"), 2] > p[sk.index("LeftFoot"), 2]
    assert len(sk.end_site_parents) == 5
    assert {sk.names[j] for j in sk.end_site_parents} == {
        "Head",
        "LeftHand",
        "RightHand",
        "LeftToe",
        "RightToe",
    }


def test_humanoid_units():
    m, cm = humanoid_skeleton(1.8, "m"), humanoid_skeleton(1.8, "cm")
    np.testing.assert_allclose(cm.offsets, 100 * m.offsets)
    with pytest.raises(ValueError):
        humanoid_skeleton(1.7, "ft")


# --------------------------------------------------------------------------- procedural motion


@pytest.fixture(scope="module")
def clips():
    return {k: procedural_motion(k, seconds=4.0, fps=30.0, seed=0) for k in KINDS}


@pytest.fixture(scope="module")
def fk(clips):
    return {k: forward_kinematics(c.motion)[0] for k, c in clips.items()}


@pytest.mark.parametrize("kind", KINDS)
def test_shapes_and_unit_quaternions(clips, kind):
    sm = clips[kind]
    m = sm.motion
    F = m.num_frames
    assert F == 120 and np.isclose(m.frame_time, 1 / 30)
    assert sm.contacts.shape == (F, 2) and sm.contacts.dtype == bool
    assert sm.phase.shape == (F,) and np.all((sm.phase >= 0) & (sm.phase < 1))
    assert sm.foot_joints == (m.skeleton.index("LeftToe"), m.skeleton.index("RightToe"))
    np.testing.assert_allclose(np.linalg.norm(m.rotations, axis=-1), 1.0, atol=1e-12)
    assert set(sm.angles) == set(m.skeleton.names)
    for name, a in sm.angles.items():
        assert a.shape == (F, 3)
        q = rot.euler_to_quat(a, "ZXY")
        assert np.all(rot.quat_angle(q, m.rotations[:, m.skeleton.index(name)]) < 1e-9)
    assert np.all(sm.labels == kind)
    m.check_finite()


@pytest.mark.parametrize("kind", KINDS)
def test_determinism_and_seed(clips, kind):
    a = clips[kind]
    b = procedural_motion(kind, seed=0)
    np.testing.assert_array_equal(a.motion.rotations, b.motion.rotations)
    np.testing.assert_array_equal(a.motion.root_positions, b.motion.root_positions)
    np.testing.assert_array_equal(a.contacts, b.contacts)
    c = procedural_motion(kind, seed=1)
    assert not a.motion.allclose(c.motion, rot_atol=1e-4, pos_atol=1e-4)


@pytest.mark.parametrize("kind", KINDS)
def test_stance_feet_are_planted(clips, fk, kind):
    sm, P = clips[kind], fk[kind]
    toes = P[:, list(sm.foot_joints)]  # (F, 2, 3)
    c = sm.contacts
    both = c[1:] & c[:-1]
    assert both.any()
    slide = np.linalg.norm(np.diff(toes, axis=0), axis=-1)
    assert slide[both].max() < 0.002 * HEIGHT
    assert np.abs(toes[..., 1][c]).max() < 0.005 * HEIGHT  # on the ground
    assert toes[..., 1].min() > -0.005 * HEIGHT  # never below it
    # the whole foot stays above the ground too
    foot_j = [sm.motion.skeleton.index(n) for n in ("LeftFoot", "RightFoot")]
    assert P[:, foot_j, 1].min() > 0.02 * HEIGHT


@pytest.mark.parametrize("kind", ["walk", "run"])
def test_swing_feet_are_higher(clips, fk, kind):
    sm, P = clips[kind], fk[kind]
    h = P[:, list(sm.foot_joints), 1]
    c = sm.contacts
    one = c.sum(axis=1) == 1
    assert one.any()
    swing_h = np.where(c[one], h[one][:, ::-1], h[one]).max(axis=1)
    stance_h = np.where(c[one], h[one], h[one][:, ::-1]).max(axis=1)
    assert np.all(swing_h >= stance_h - 1e-9)
    assert swing_h.mean() > stance_h.mean() + 0.02 * HEIGHT
    assert h[~c].max() > 0.04 * HEIGHT  # clearly lifted at some point


def test_gait_phases(clips, fk):
    walk, run = clips["walk"], clips["run"]
    assert walk.contacts.all(axis=1).any()  # double support
    assert not (~walk.contacts).all(axis=1).any()  # a walk never flies
    flight = (~run.contacts).all(axis=1)
    assert flight.any() and not run.contacts.all(axis=1).any()
    h = fk["run"][:, list(run.foot_joints), 1]
    assert (h[flight].min(axis=1) > 0.0).all()
    assert (h[flight].min(axis=1) > 0.01 * HEIGHT).any()
    for kind in ("wave", "idle"):
        assert clips[kind].contacts.all()
    # each foot alternates, right half a cycle after left
    for sm in (walk, run):
        assert (np.diff(sm.contacts.astype(int), axis=0) == 1).sum() >= 4


def test_speeds(clips):
    def speed(sm):
        p = sm.motion.root_positions[:, [0, 2]]
        return np.linalg.norm(p[-1] - p[0]) / (sm.motion.duration - sm.motion.frame_time)

    v_walk, v_run = speed(clips["walk"]), speed(clips["run"])
    assert 0.8 < v_walk < 1.6 and v_run > 2.0 * v_walk
    assert speed(clips["wave"]) < 0.01 and speed(clips["idle"]) < 0.01
    fast = procedural_motion("walk", speed=1.5)
    assert abs(speed(fast) - 1.5) < 0.1
    # the walk heads along +Z by default, along (sin h, 0, cos h) otherwise
    d = clips["walk"].motion.root_positions[-1] - clips["walk"].motion.root_positions[0]
    assert d[2] > 3.0 and abs(d[0]) < 0.1
    turned = procedural_motion("walk", heading=np.pi / 2).motion.root_positions
    d = turned[-1] - turned[0]
    assert d[0] > 3.0 and abs(d[2]) < 0.1
    with pytest.raises(ValueError):
        procedural_motion("wave", speed=1.0)
    with pytest.raises(ValueError):
        procedural_motion("dance")


@pytest.mark.parametrize("kind", ["walk", "run"])
def test_arms_swing_opposite_to_legs(clips, fk, kind):
    sk, P = clips[kind].motion.skeleton, fk[kind]
    hands = P[:, sk.index("LeftHand"), 2] - P[:, sk.index("RightHand"), 2]
    feet = P[:, sk.index("LeftToe"), 2] - P[:, sk.index("RightToe"), 2]
    assert np.corrcoef(hands, feet)[0, 1] < -0.6


def test_wave_raises_one_arm(clips, fk):
    sk, P = clips["wave"].motion.skeleton, fk["wave"]
    head = P[:, sk.index("Head"), 1]
    rhand, lhand = P[:, sk.index("RightHand")], P[:, sk.index("LeftHand")]
    assert np.all(rhand[:, 1] > head) and np.all(lhand[:, 1] < head - 0.3 * HEIGHT)
    assert np.ptp(rhand[:, 0]) > 0.05 * HEIGHT  # the hand waves side to side
    idle = fk["idle"]
    assert np.all(idle[:, sk.index("RightHand"), 1] < head - 0.3 * HEIGHT)
    assert 0.0 < np.ptp(idle[:, 0, 0]) < 0.05 * HEIGHT  # a subtle sway


@pytest.mark.parametrize("kind", KINDS)
def test_bvh_round_trip(clips, kind, tmp_path):
    m = clips[kind].motion
    back = read_bvh(write_bvh(m, tmp_path / f"{kind}.bvh"))
    assert back.skeleton.allclose(m.skeleton)
    assert back.allclose(m, rot_atol=1e-6, pos_atol=1e-6)


def test_units_cm():
    m = procedural_motion("walk", seed=3).motion
    cm = procedural_motion("walk", seed=3, units="cm").motion
    np.testing.assert_allclose(cm.root_positions, 100 * m.root_positions, atol=1e-9)
    assert np.all(rot.quat_angle(cm.rotations, m.rotations) < 1e-9)


# --------------------------------------------------------------------------- sequences


def test_procedural_sequence_is_continuous():
    segs = [("walk", 3.0), ("run", 2.0), ("wave", 3.0), ("idle", 1.5), ("walk", 2.0)]
    sm = procedural_sequence(segs, seed=0)
    m = sm.motion
    assert m.num_frames == round(11.5 * 30)
    assert [s[0] for s in sm.segments] == [s[0] for s in segs]
    assert sm.segments[0][1] == 0 and sm.segments[-1][2] == m.num_frames
    assert list(sm.labels[[0, 100, 160, 250, 300]]) == ["walk", "run", "wave", "idle", "walk"]
    P = forward_kinematics(m)[0]
    step = np.linalg.norm(np.diff(P, axis=0), axis=-1).max(axis=1)  # (F-1,)
    # bound: the fastest per-frame joint displacement seen in the pure clips of those kinds
    pure = {
        k: np.linalg.norm(
            np.diff(forward_kinematics(procedural_motion(k, seed=s).motion)[0], axis=0), axis=-1
        ).max()
        for k in ("walk", "run", "wave", "idle")
        for s in (0,)
    }
    bound = 1.15 * max(pure.values())
    assert step.max() < bound
    for (k0, _, join), (k1, _, _) in zip(sm.segments[:-1], sm.segments[1:], strict=True):
        # a transition may move a limb a little faster than either clip (e.g. lowering the
        # waving arm), but nothing teleports
        win = step[join - 15 : join + 15]
        assert win.max() < 1.15 * max(pure[k0], pure[k1]) + 0.05 * HEIGHT
    acc = np.linalg.norm(np.diff(P, 2, axis=0), axis=-1).max(axis=1)
    assert acc.max() < 0.1 * HEIGHT
    # the stance feet stay planted across the transitions as well
    toes = P[:, list(sm.foot_joints)]
    both = sm.contacts[1:] & sm.contacts[:-1]
    assert np.linalg.norm(np.diff(toes, axis=0), axis=-1)[both].max() < 0.002 * HEIGHT
    assert np.abs(toes[..., 1][sm.contacts]).max() < 0.005 * HEIGHT
    # standing while waving: the last step ends within ~1 cycle of the run -> wave blend, and
    # the first step of the final walk starts at most ~1.5 cycles before the idle -> walk one
    assert sm.contacts[185:220].all()
    # deterministic
    again = procedural_sequence(segs, seed=0)
    np.testing.assert_array_equal(again.motion.rotations, m.rotations)


def test_procedural_sequence_overrides():
    sm = procedural_sequence([("walk", 2.0, {"speed": 0.8}), ("walk", 2.0, {"speed": 1.6})])
    p = sm.motion.root_positions
    v0 = np.linalg.norm(p[50, [0, 2]] - p[10, [0, 2]]) / (40 / 30)
    v1 = np.linalg.norm(p[110, [0, 2]] - p[70, [0, 2]]) / (40 / 30)
    assert abs(v0 - 0.8) < 0.1 and abs(v1 - 1.6) < 0.15
    with pytest.raises(ValueError):
        procedural_sequence([])
    with pytest.raises(ValueError):
        procedural_sequence([("walk", 1.0, {"nonsense": 1.0})])
