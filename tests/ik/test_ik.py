"""The IK module: the fast solver against the readable reference, and foot locking."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from testsupport import load_sibling

from mocapkit.body import body_of
from mocapkit.core.kinematics import forward_kinematics
from mocapkit.datasets import procedural_motion
from mocapkit.ik import (
    FootLockConfig,
    IKConfig,
    _hinge_flex,
    _prepare,
    _solve_frames,
    flexion_angles,
    leg_chains,
    lock_feet,
    lock_targets,
    solve,
)

naive = load_sibling(__file__, "naive")


@pytest.fixture(scope="module")
def walk():
    return procedural_motion("walk", seconds=2.0, fps=30.0, seed=1).motion


def _run_both(m, chains, targets, iters=6):
    sk = m.skeleton
    lt = m.local_translations()
    plan = _prepare(chains, sk.parents)
    pos, grot = forward_kinematics(m)
    minf = []
    for c in chains:
        for h, ax in zip(c.hinges, c.hinge_axes, strict=True):
            k = c.joints.index(h)
            child = c.joints[k + 1]
            minf.append(np.minimum(flexion_angles(pos, grot, c.joints[k - 1], h, child, ax), 0))
    fast, res, _ = _solve_frames(
        sk.parents, m.rotations, lt, plan, targets, minf, 0.01, 1e-6, 20.0, iters
    )
    ref = [
        naive.solve_frame(
            sk.parents,
            m.rotations[f],
            lt[f],
            [
                (c.joints, c.effectors, dict(zip(c.hinges, c.hinge_axes, strict=True)))
                for c in chains
            ],
            targets[f],
            [mf[f] for mf in minf],
            0.01,
            1e-6,
            20.0,
            iters,
        )
        for f in range(m.num_frames)
    ]
    return fast, res, np.stack([r[0] for r in ref]), np.stack([r[1] for r in ref])


@settings(max_examples=15, deadline=None)
@given(shift=st.tuples(*[st.floats(-0.15, 0.15)] * 3), seed=st.integers(0, 3))
def test_fast_solver_matches_naive(walk, shift, seed):
    m = walk[seed * 10 : seed * 10 + 8]
    chains = leg_chains(m)
    pos, _ = forward_kinematics(m)
    effs = [e for c in chains for e in c.effectors]
    targets = pos[:, effs] + np.asarray(shift)
    fast, res, ref, ref_res = _run_both(m, chains, targets)
    # same rotations up to sign
    d = np.abs(np.einsum("fjk,fjk->fj", fast, ref))
    assert np.allclose(d, 1.0, atol=1e-9)
    assert np.allclose(res, ref_res, atol=1e-9)


@settings(max_examples=15, deadline=None)
@given(pull=st.floats(0.1, 0.6), seed=st.integers(0, 3))
def test_targets_no_foot_can_meet_give_a_steady_leg(walk, pull, seed):
    """The ankle held where it is and the toe pulled ``pull`` metres forward: no rigid foot
    meets both. The solver returns no pose farther from the targets than the input's (it keeps
    its best pose), and the compromise is the same from frame to frame: the knee moves no more
    between two frames than it does in the input plus the toe's own pull changes (none)."""
    m = walk[seed * 10 : seed * 10 + 12]
    chains = leg_chains(m)
    pos, _ = forward_kinematics(m)
    effs = [e for c in chains for e in c.effectors]
    targets = pos[:, effs].copy()
    targets[:, 1::2, 2] += pull  # every chain's second effector (the toe)
    r = solve(m, chains, targets)
    before = np.linalg.norm(targets - pos[:, effs], axis=-1).max(axis=1)
    assert np.all(r.residual.max(axis=1) <= before + 1e-9)
    p2, _ = forward_kinematics(r.motion)
    knees = [c.hinges[0] for c in chains]
    moved = np.linalg.norm(np.diff(p2[:, knees], axis=0), axis=-1)
    own = np.linalg.norm(np.diff(pos[:, knees], axis=0), axis=-1)
    assert moved.max() < own.max() + 0.02  # metres


def test_solve_reaches_targets_and_keeps_knees(walk):
    m = walk
    body = body_of(m)
    chains = leg_chains(m, body)
    pos, _ = forward_kinematics(m)
    effs = [e for c in chains for e in c.effectors]
    # ankles and toes pulled 3 cm back and 2 cm up: reachable
    targets = pos[:, effs] + np.array([0.0, 0.02, -0.03])
    r = solve(m, chains, targets, config=IKConfig())
    assert r.residual.max() < 2e-3  # metres (procedural rig is in metres)
    p2, g2 = forward_kinematics(r.motion)
    for c in chains:
        f = flexion_angles(p2, g2, *c.joints, c.hinge_axes[0])
        assert f.min() > -math.radians(1.0)
    # only the chain joints changed
    others = sorted(set(range(m.num_joints)) - {j for c in chains for j in c.joints})
    assert np.array_equal(r.motion.rotations[:, others], m.rotations[:, others])


def test_zero_weights_change_nothing(walk):
    chains = leg_chains(walk)
    pos, _ = forward_kinematics(walk)
    effs = [e for c in chains for e in c.effectors]
    w = np.zeros((walk.num_frames, len(effs)))
    w[10:15, 0] = 1.0
    r = solve(walk, chains, pos[:, effs] + 0.05, w)
    keep = np.ones(walk.num_frames, dtype=bool)
    keep[10:15] = False
    assert np.array_equal(r.motion.rotations[keep], walk.rotations[keep])
    assert not np.array_equal(r.motion.rotations[10:15], walk.rotations[10:15])
    # the other leg, with no weight on those frames, is left bit for bit (it moved by 1e-6 deg
    # of rounding, and the clean repair counted it as written: newcomer report)
    other = list(chains[1].joints)
    assert np.array_equal(r.motion.rotations[:, other], walk.rotations[:, other])


def test_lock_targets_blend_is_smooth():
    F = 40
    pos = np.zeros((F, 1, 3))
    pos[:, 0, 0] = np.linspace(0, 1, F)
    flags = np.zeros((F, 1), dtype=bool)
    flags[15:25] = True
    t, w = lock_targets(pos, flags, 4, "mean")
    assert np.all(w[15:25] == 1) and np.all(w[:11] == 0) and np.all(w[30:] == 0)
    assert np.all(np.diff(w[10:16, 0]) > 0) and np.all(np.diff(w[24:30, 0]) < 0)
    assert np.allclose(t[15:25, 0], pos[15:25, 0].mean(axis=0))


@pytest.mark.parametrize("anchor", ["first", "mean"])
def test_lock_targets_with_drift_move_the_hold_as_meant(anchor):
    """drift: a foot that moves within its contact exactly as meant is held where it is; one
    that slides more is held to the meant path; pinned frames are met exactly either way."""
    F = 40
    rng = np.random.default_rng(0)
    pos = np.cumsum(rng.normal(0, 0.01, size=(F, 1, 3)), axis=0)
    flags = np.zeros((F, 1), dtype=bool)
    flags[10:30] = True
    meant = np.zeros_like(pos)
    meant[1:] = np.diff(pos, axis=0)
    t, w = lock_targets(pos, flags, 4, anchor, drift=meant)
    assert np.allclose(t[10:30], pos[10:30]) and np.all(w[10:30] == 1)
    slid = pos.copy()
    slid[20:] += np.linspace(0, 0.05, F - 20)[:, None, None]  # 5 cm more than meant
    t, _ = lock_targets(slid, flags, 4, "first", drift=meant)
    assert np.allclose(t[10:30], pos[10:30])  # back on the meant path
    pins = np.zeros((F, 1), dtype=bool)
    pins[:12] = True
    t, _ = lock_targets(slid, flags, 4, anchor, pins=pins, drift=meant)
    assert np.allclose(t[10:12], slid[10:12]) and np.allclose(t[12:30], pos[12:30])


def test_lock_targets_offset_ramp_keeps_the_swing():
    """ramp="offset": over the blends the target moves with the joint (a constant correction
    per side, weighted down), inside the run it is the anchor, continuous at the run's ends."""
    F = 40
    pos = np.zeros((F, 1, 3))
    pos[:, 0, 0] = np.linspace(0, 1, F) ** 2
    flags = np.zeros((F, 1), dtype=bool)
    flags[15:25] = True
    t, w = lock_targets(pos, flags, 4, "mean", ramp="offset")
    _, w0 = lock_targets(pos, flags, 4, "mean")
    assert np.array_equal(w, w0)
    anchor = pos[15:25, 0].mean(axis=0)
    assert np.allclose(t[15:25, 0], anchor)
    # the blend frames keep the joint's own motion (same velocity as the input)
    assert np.allclose(np.diff(t[11:16, 0], axis=0)[:-1], np.diff(pos[11:16, 0], axis=0)[:-1])
    assert np.allclose(t[11:15, 0] - pos[11:15, 0], anchor - pos[15, 0])
    assert np.allclose(t[25:29, 0] - pos[25:29, 0], anchor - pos[24, 0])
    # with up: only the ground-plane correction, the joint's own height
    pos[:, 0, 1] = np.linspace(0, 0.3, F)
    t, _ = lock_targets(pos, flags, 4, "mean", up=np.array([0.0, 1.0, 0.0]), ramp="offset")
    assert np.allclose(t[:, 0, 1], pos[:, 0, 1])
    with pytest.raises(ValueError, match="ramp"):
        FootLockConfig(ramp="pull")


@pytest.mark.parametrize("ramp", ["target", "offset"])
def test_lock_targets_pinned_frames_anchor_their_run(ramp):
    """A run holding pinned frames (a filled gap's fixed context) is held where those frames put
    the joint: at the pinned frames exactly, between two of them interpolated, past the last
    one that one's; a run without pinned frames keeps its own anchor."""
    F = 40
    pos = np.zeros((F, 1, 3))
    pos[:, 0, 0] = np.linspace(0, 1, F)  # a sliding joint
    flags = np.zeros((F, 1), dtype=bool)
    flags[5:12] = flags[20:35] = True
    pins = np.zeros((F, 1), dtype=bool)
    pins[30:] = True  # the run 20..34 reaches the fixed frames from 30 on
    up = np.array([0.0, 1.0, 0.0])
    t, w = lock_targets(pos, flags, 3, "first", up, ramp, pins)
    assert np.allclose(t[20:31, 0], pos[30, 0])  # held where the fixed frame 30 plants it
    assert np.allclose(t[30:35, 0], pos[30:35, 0])  # the fixed frames themselves untouched
    assert np.allclose(t[5:12, 0], pos[5, 0])  # no pinned frame: its first position
    _, w_free = lock_targets(pos, flags, 3, "first", up, ramp)
    assert np.array_equal(w, w_free)
    pins[:] = False
    pins[22] = pins[28] = True  # two pinned frames: interpolated between, held beyond
    t, _ = lock_targets(pos, flags, 3, "first", up, ramp, pins)
    assert np.allclose(t[20:23, 0], pos[22, 0]) and np.allclose(t[28:35, 0], pos[28, 0])
    assert np.allclose(t[22:29, 0], pos[22:29, 0])


def test_lock_feet_holds_planted_feet(shared_path):
    from mocapkit.io import read_motion

    m = read_motion(shared_path("bandai1/data") / "dataset-1_walk_normal_001.bvh")
    cfg = FootLockConfig(blend=0.15)
    fl = lock_feet(m, config=cfg)
    pos0, _ = forward_kinematics(m)
    pos, _ = forward_kinematics(fl.motion)
    e = list(fl.effectors)
    full = fl.weights == 1
    up = np.array([0.0, 1.0, 0.0])

    def horiz(d):
        return np.linalg.norm(d - (d @ up)[..., None] * up, axis=-1)

    before = horiz(pos0[:, e] - fl.targets)[full]
    after = horiz(pos[:, e] - fl.targets)[full]
    assert after.mean() < 0.5 * before.mean()
    assert after.mean() < 0.3  # cm (Bandai units): planted feet held
    assert after.max() < 1.5
    # nothing changes outside contacts and their blend
    outside = (fl.weights == 0).all(axis=1)
    assert np.array_equal(fl.motion.rotations[outside], m.rotations[outside])


def test_a_straight_knee_bends_to_raise_its_foot(walk):
    """A straight knee is a singular pose: bending it moves the ankle across the leg, not along
    it, at first order, so the steps alone never bend it (a fill's foot was left 6 cm under the
    floor). An ankle aimed 5 cm nearer the hip is reached, and so is the other leg's target on
    the same frames when one leg's aim is out of reach (each leg keeps its own best pose)."""
    m = walk[:6].copy()
    chains = leg_chains(m)
    for c in chains:
        m.rotations[:, c.hinges[0]] = [1.0, 0.0, 0.0, 0.0]  # the rest pose: a straight knee
    pos, grot = forward_kinematics(m)
    flex = [_hinge_flex(pos, grot, m.skeleton.parents, c.hinges[0], c.hinge_axes[0],
                        c.joints[2])[0] for c in chains]  # fmt: skip
    assert np.abs(flex).max() < 1e-9
    effs = [e for c in chains for e in c.effectors]
    targets = pos[:, effs].copy()
    targets[:, :, 1] += 0.05  # both feet 5 cm up: the legs must shorten
    r = solve(m, chains, targets)
    assert r.residual.max() < 1e-3
    far = targets.copy()
    n_left = len(chains[0].effectors)
    far[:, n_left:, 2] += 2.0  # the right foot aimed 2 m ahead: out of reach
    r2 = solve(m, chains, far)
    assert r2.residual[:, :n_left].max() < 1e-3  # the left leg is not held back by the right
    assert r2.residual[:, n_left:].min() > 1.0


def test_chains_that_move_each_other_are_judged_together(walk):
    """A spine chain aimed out of reach and an arm chain below it: the arm's pose depends on
    the spine's, so the two keep their best pose together and the residual reported is the
    returned pose's own (kept apart, the arm took another iteration's spine: 9.8 cm off)."""
    from mocapkit.ik import Chain

    sk = walk.skeleton
    m = walk[:20]
    pos, _ = forward_kinematics(m)
    i = sk.names.index
    spine = Chain((i("Spine"), i("Chest")), (i("Neck"),))
    arm = Chain((i("LeftShoulder"), i("LeftArm"), i("LeftForeArm")), (i("LeftHand"),))
    rng = np.random.default_rng(0)
    t = np.stack([pos[:, i("Neck")] + [0.8, 0.0, 0.0],
                  pos[:, i("LeftHand")] + rng.normal(0.0, 0.25, (20, 3))], 1)  # fmt: skip
    r = solve(m, (spine, arm), t)
    p2, _ = forward_kinematics(r.motion)
    actual = np.linalg.norm(p2[:, [i("Neck"), i("LeftHand")]] - t, axis=-1)
    np.testing.assert_allclose(r.residual, actual, atol=1e-9)
    # and the naive reference agrees
    fast, res, ref, ref_res = _run_both(m, [spine, arm], t)
    assert np.allclose(np.abs(np.einsum("fjk,fjk->fj", fast, ref)), 1.0, atol=1e-9)
    assert np.allclose(res, ref_res, atol=1e-9)
