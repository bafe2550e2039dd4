"""Detection rules on top of the MDM: hysteresis seeds, jumps, frozen joints, dominance."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mocapkit import datasets
from mocapkit.clean import SelfSimilarityCleaner, inject
from mocapkit.clean import mdm as mdm_mod
from mocapkit.clean.detect import DetectConfig
from mocapkit.clean.inject import hinge_joints
from mocapkit.core import rotations as rot


def test_hysteresis_keeps_only_seeded_runs() -> None:
    weak = np.zeros((12, 2), dtype=bool)
    weak[2:6, 0] = True
    weak[8:11, 0] = True
    weak[1:4, 1] = True
    strong = np.zeros_like(weak)
    strong[4, 0] = True
    out = mdm_mod.hysteresis(weak, strong)
    assert out[2:6, 0].all() and not out[8:11, 0].any() and not out[:, 1].any()


def test_angular_acceleration_sees_a_kink_not_a_steady_turn() -> None:
    t = np.arange(20)
    q = rot.rotvec_to_quat(np.stack([0.05 * t, 0 * t, 0 * t], axis=1))[:, None]
    a = mdm_mod.angular_acceleration(q)
    assert a.shape == (20, 1) and np.allclose(a, 0.0, atol=1e-9)
    q2 = q.copy()
    q2[10, 0] = rot.quat_mul(q[10, 0], rot.rotvec_to_quat(np.array([0.0, 0.5, 0.0])))
    a2 = mdm_mod.angular_acceleration(q2)
    assert a2[9:12, 0].min() > 0.4 and np.allclose(a2[:8, 0], 0.0, atol=1e-9)


def test_frozen_cells_need_a_moving_context_and_a_value_that_does_not_recur() -> None:
    F = 60
    t = np.linspace(0, 4 * np.pi, F)
    q = rot.rotvec_to_quat(np.stack([0.6 * np.sin(t), 0 * t, 0 * t], axis=1))[:, None]
    frozen = q.copy()
    frozen[20:35, 0] = q[20, 0]
    dig = rot.quat_angle(frozen, q)
    out = mdm_mod.frozen_cells(frozen, dig, min_frames=10)
    # the held frames, not the first: that one is the last value captured, genuine
    assert np.array_equal(np.flatnonzero(out[:, 0]), np.arange(21, 35))
    # no digression there: the KNN words hold still too; a pause, unless held bit for bit (a
    # natural pause is never exact: a dropout is frozen whatever its neighbours do)
    paused = frozen.copy()
    paused[20:35:2, 0] = rot.quat_mul(frozen[20, 0], rot.rotvec_to_quat(np.array([1e-5, 0, 0])))
    assert not mdm_mod.frozen_cells(paused, np.zeros_like(dig), min_frames=10).any()
    assert mdm_mod.frozen_cells(frozen, np.zeros_like(dig), min_frames=10)[22:35, 0].all()
    # a joint parked at a limit it keeps returning to is not frozen
    limit = np.clip(np.sin(t), -0.3, None)
    ql = rot.rotvec_to_quat(np.stack([limit, 0 * t, 0 * t], axis=1))[:, None]
    assert not mdm_mod.frozen_cells(ql, np.full((F, 1), 1.0), min_frames=5).any()
    # a value the joint only passes through (every 10 frames, exactly) is no limit
    tp = np.arange(F)
    qp = rot.rotvec_to_quat(np.stack([0.6 * np.sin(2 * np.pi * tp / 10), 0 * tp, 0 * tp], 1))
    fp = qp[:, None].copy()
    fp[20:35, 0] = qp[20]
    assert (rot.quat_angle(qp, qp[20][None]) < 1e-9).sum() >= 5
    dp = rot.quat_angle(fp, qp[:, None])
    assert mdm_mod.frozen_cells(fp, dp, min_frames=10)[21:35, 0].all()


def test_an_exact_hold_at_a_value_the_joint_rests_near_is_frozen_unless_it_recurs_exactly() -> None:
    """A toe resting flat (within a tremble of 0.05 deg of one value) between steps, then a
    dropout holding the flat value bit for bit through a step: the natural rests near it do not
    make the hold a park (they are never exact); the same hold at a value the joint parks at
    exactly, again and again (a solver clamping it at its limit), is a park."""
    F = 150
    rng = np.random.default_rng(0)
    t = np.arange(F)
    swing = 0.5 * np.clip(np.sin(2 * np.pi * t / 30), 0, None)  # rests at 0 half of each cycle
    tremble = np.radians(0.05) * rng.standard_normal(F)
    live = rot.rotvec_to_quat(np.stack([swing + tremble, 0 * t, 0 * t], axis=1))[:, None]
    held = live.copy()
    held[60:90, 0] = live[60, 0]  # held through the step of frames 60-75
    dig = rot.quat_angle(held, live)
    out = mdm_mod.frozen_cells(held, dig, min_frames=10, speed=np.radians(0.2))
    assert out[62:90, 0].all() and not out[:55, 0].any() and not out[95:, 0].any()
    # a clamp: the joint parks at exactly 0 between steps, and the hold is at exactly 0 too
    clamp = rot.rotvec_to_quat(np.stack([swing, 0 * t, 0 * t], axis=1))[:, None]
    hc = clamp.copy()
    hc[60:90, 0] = clamp[60, 0]
    assert not mdm_mod.frozen_cells(hc, rot.quat_angle(hc, clamp), min_frames=10).any()


def test_held_runs_split_an_exact_hold_from_the_slow_frames_beside_it() -> None:
    F = 40
    a = np.radians(0.001) * np.arange(F)  # turning slowly, never twice the same value
    a[15:30] = a[15]  # frames 15-29 the same value bit for bit: steps 15-28
    q = rot.rotvec_to_quat(np.stack([a, 0 * a, 0 * a], axis=1))
    still = np.ones(F - 1, bool)
    assert mdm_mod.held_runs(q, still, 10) == [(0, 14), (15, 28), (29, 38)]
    assert mdm_mod.held_runs(q, still, 20) == [(0, 38)]  # shorter than 20 steps: not split


def test_dominated_runs() -> None:
    mask = np.zeros((10, 3), dtype=bool)
    mask[3:6, 0] = True
    mask[3:6, 1] = True
    z = np.zeros((10, 3))
    z[3:6, 0] = 1.5
    z[3:6, 1] = 10.0
    keep = np.zeros_like(mask)
    out = mdm_mod.dominated_runs(mask, z, keep, 0.5, 2)
    assert out[3:6, 0].all() and not out[:, 1].any()
    keep[4, 0] = True
    assert not mdm_mod.dominated_runs(mask, z, keep, 0.5, 2).any()
    assert not mdm_mod.dominated_runs(mask, z, np.zeros_like(mask), 0.0, 2).any()


@pytest.fixture(scope="module")
def frozen_take():
    walk = datasets.procedural_motion("walk", seconds=6.0, seed=5).motion
    ctx = datasets.procedural_motion("walk", seconds=6.0, seed=6).motion
    names = list(walk.skeleton.names)
    inj = inject(walk, "frozen", names.index("LeftForeArm"), np.random.default_rng(3), start=60)
    return inj, ctx


def test_frozen_joint_is_flagged_and_paper_mode_is_a_plain_threshold(frozen_take) -> None:
    inj, ctx = frozen_take
    cl = SelfSimilarityCleaner().fit(inj.motion, [ctx])
    m = cl.mask()
    assert m[inj.frames, inj.joint].mean() > 0.8
    plain = SelfSimilarityCleaner(detect="threshold").fit(inj.motion, [ctx])
    assert np.array_equal(plain.mask(), plain.scores() > 0.5)
    assert np.array_equal(plain.mask(0.7), plain.scores() > 0.7)
    with pytest.raises(ValueError):
        SelfSimilarityCleaner(detect="nope")


def _turning(F: int, J: int = 2, seed: int = 0) -> np.ndarray:
    """(F, J, 4) smooth, fast-turning tracks (a natural motion's steps change gradually)."""
    t = np.linspace(0, 3 * np.pi, F)[:, None]
    rng = np.random.default_rng(seed)
    ph = rng.uniform(0, np.pi, size=(1, J))
    rv = np.stack([0.9 * np.sin(t + ph), 0.5 * np.cos(0.7 * t + ph), 0.2 * t + 0 * ph], axis=-1)
    return rot.rotvec_to_quat(rv)


def test_step_size_matches_the_reference_and_sees_a_jump_not_a_fast_turn() -> None:
    from clean.naive import step_size as naive_step_size

    q = _turning(40)
    s = mdm_mod.step_size(q)
    assert np.allclose(s, naive_step_size(q), atol=1e-9)
    assert s.max() < np.radians(2.0)  # fast but smooth: no step
    jumped = q.copy()
    d = rot.rotvec_to_quat(np.array([0.0, 0.0, np.radians(30.0)]))
    jumped[20:, 0] = rot.quat_mul(q[20:, 0], d)  # a 30 deg offset from frame 20 on
    s2 = mdm_mod.step_size(jumped)
    assert np.allclose(s2, naive_step_size(jumped), atol=1e-9)
    assert int(np.argmax(s2[:, 0])) == 20 and abs(np.degrees(s2[20, 0]) - 30.0) < 3.0
    assert np.allclose(s2[:, 1], s[:, 1])
    assert mdm_mod.step_size(q[:3]).shape == (3, 2) and not mdm_mod.step_size(q[:3]).any()


def test_steps_pair_into_the_whole_error_on_the_digressing_side() -> None:
    F = 400  # the peaks are judged against the joint's 99th percentile: a few seconds of data
    q = _turning(F, J=2, seed=1)
    bad = q.copy()
    d = rot.rotvec_to_quat(np.array([np.radians(40.0), 0.0, 0.0]))
    bad[30:50, 1] = rot.quat_mul(q[30:50, 1], d)  # error on frames 30..49 of joint 1
    steps = mdm_mod.step_size(bad)
    peaks = mdm_mod.step_peaks(steps, 1.5, np.radians(8.0))
    assert sorted(np.flatnonzero(peaks[:, 1])) == [30, 50] and not peaks[:, 0].any()
    z = rot.quat_angle(bad, q) / np.radians(20.0)  # digression: high inside the error only
    sides = mdm_mod.step_sides(peaks, z, 3)
    assert sides[30, 1] == 1 and sides[50, 1] == -1
    cells = mdm_mod.step_cells(peaks, sides)
    assert sorted(np.flatnonzero(cells[:, 1])) == [30, 49]  # both on the corrupted frames


def test_cancelling_steps_flag_a_constant_turn_and_not_a_turn_that_stays() -> None:
    F = 400
    q = _turning(F, J=3, seed=1)
    bad = q.copy()
    d = rot.rotvec_to_quat(np.array([np.radians(40.0), np.radians(10.0), 0.0]))
    bad[30:50, 1] = rot.quat_mul(q[30:50, 1], d)  # body side: q d on frames 30..49
    bad[100:104, 1] = rot.quat_mul(d, q[100:104, 1])  # parent side: d q, a 4-frame spike
    e = rot.rotvec_to_quat(np.array([0.0, np.radians(35.0), 0.0]))
    bad[60:, 2] = rot.quat_mul(q[60:, 2], e)  # joint 2 jumps at 60 and stays there
    bad[90:, 2] = rot.quat_mul(bad[90:, 2], e)  # ... and jumps on by the same turn at 90
    steps = mdm_mod.step_size(bad)
    peaks = mdm_mod.step_peaks(steps, 1.5, np.radians(8.0))
    devs = [mdm_mod.step_deviations(bad, f) for f in ("body", "parent")]
    assert np.allclose(np.linalg.norm(devs[0], axis=-1), steps)
    flagged = mdm_mod.cancelling_steps(peaks, devs, 45, 0.35)
    assert np.array_equal(np.flatnonzero(flagged[:, 1]), np.r_[30:50, 100:104])
    assert not flagged[:, 0].any() and not flagged[:, 2].any()
    assert not mdm_mod.cancelling_steps(peaks, devs, 3, 0.35)[30:50, 1].any()  # too far apart
    # a joint spinning 6 deg per frame about z, turned 40 deg about x on the parent side for 30
    # frames: seen from the joint, the axis of the entry step has turned by 180 deg at the exit
    spin = rot.rotvec_to_quat(np.radians(6.0) * np.arange(F)[:, None] * np.array([[0, 0, 1.0]]))
    spun = spin.copy()
    spun[200:230] = rot.quat_mul(d, spin[200:230])
    spun = spun[:, None]
    pk = mdm_mod.step_peaks(mdm_mod.step_size(spun), 1.5, np.radians(8.0))
    both = [mdm_mod.step_deviations(spun, f) for f in ("body", "parent")]
    assert mdm_mod.cancelling_steps(pk, both, 45, 0.35)[200:230, 0].all()
    assert not mdm_mod.cancelling_steps(pk, both[:1], 45, 0.35).any()
    with pytest.raises(ValueError, match="frame"):
        mdm_mod.step_deviations(bad, "world")


def test_cancelling_steps_pair_two_close_errors_without_bridging_the_gap() -> None:
    q = _turning(80, J=1, seed=3)
    bad = q.copy()
    # error A grows from 0.5 to 0.8 rad (its entry and exit do not cancel); error B holds
    # 0.7 rad, so A's exit (-0.8) and B's entry (+0.7) cancel too, across the clean gap
    grow = np.linspace(0.5, 0.8, 10)[:, None] * np.array([[1.0, 0.0, 0.0]])
    bad[10:20, 0] = rot.quat_mul(q[10:20, 0], rot.rotvec_to_quat(grow))
    bad[30:40, 0] = rot.quat_mul(q[30:40, 0], rot.rotvec_to_quat(np.array([0.7, 0.0, 0.0])))
    peaks = np.zeros((80, 1), dtype=bool)
    peaks[[10, 20, 30, 40], 0] = True
    devs = [mdm_mod.step_deviations(bad, "body")]
    flagged = mdm_mod.cancelling_steps(peaks, devs, 45, 0.35)
    assert np.array_equal(np.flatnonzero(flagged[:, 0]), np.r_[30:40])


def test_cancelling_steps_pair_a_turn_about_one_axis_that_changes_size() -> None:
    """A wrong-way bend turns its stretch about one axis by an angle that grows and shrinks
    with the joint's own flexion: entry and exit point opposite ways but differ in size, so
    they do not cancel. With ``axis_cos`` they pair, where both peaks are large enough
    (``axis_peaks``); two opposite-sized jumps about different axes never do."""
    q = _turning(120, J=2, seed=5)
    bad = q.copy()
    grow = np.linspace(0.3, 0.9, 20)[:, None] * np.array([[1.0, 0.0, 0.0]])
    bad[40:60, 0] = rot.quat_mul(q[40:60, 0], rot.rotvec_to_quat(grow))  # in 0.3, out 0.9 rad
    bad[40:50, 1] = rot.quat_mul(q[40:50, 1], rot.rotvec_to_quat(np.array([0.5, 0.0, 0.0])))
    # ... left about an axis 60 deg away (opposite ways to a cosine of 0.5 only)
    tilted = 0.5 * np.array([0.5, 0.0, np.sqrt(0.75)])
    bad[50:60, 1] = rot.quat_mul(q[50:60, 1], rot.rotvec_to_quat(tilted))
    peaks = np.zeros((120, 2), dtype=bool)
    peaks[[40, 60], :] = True
    devs = [mdm_mod.step_deviations(bad, "body")]
    assert not mdm_mod.cancelling_steps(peaks, devs, 45, 0.45).any()
    flagged = mdm_mod.cancelling_steps(peaks, devs, 45, 0.45, axis_cos=0.9, axis_peaks=peaks)
    assert np.array_equal(np.flatnonzero(flagged[:, 0]), np.r_[40:60])
    assert not flagged[:, 1].any()  # entered about x, left 60 deg off it (a bump at 50 between)
    small = peaks.copy()
    small[60, 0] = False  # the exit under the bar
    assert not mdm_mod.cancelling_steps(peaks, devs, 45, 0.45, axis_cos=0.9, axis_peaks=small).any()


def test_cancelling_steps_pair_a_turn_that_passes_half_a_turn() -> None:
    """A wrong-way bend of a well-bent elbow turns its stretch past 180 deg: entered by 40 deg
    about x, it is left from 229 deg, which reads as 131 deg the other way, so the exit's
    deviation points the way the entry's does. Read the other way round (its turn over 90
    deg), the exit opposes the entry and the pair is found where the sides read an entry and
    an exit next to each other; not where they read two entries, nor without sides."""
    q = _turning(120, J=1, seed=6)
    bad = q.copy()
    grow = np.radians(np.linspace(40.0, 229.0, 20))[:, None] * np.array([[1.0, 0.0, 0.0]])
    bad[40:60, 0] = rot.quat_mul(q[40:60, 0], rot.rotvec_to_quat(grow))
    peaks = np.zeros((120, 1), dtype=bool)
    peaks[[40, 60], 0] = True
    devs = [mdm_mod.step_deviations(bad, "body")]
    v = devs[0][:, 0]
    assert v[40] @ v[60] > 0.9 * np.linalg.norm(v[40]) * np.linalg.norm(v[60])  # alike
    assert mdm_mod._opposed(devs, 40, 60, 0) < -0.9
    assert mdm_mod._opposed(devs, 40, 60, 0, flip=True) > 0.9
    kw = {"axis_cos": 0.9, "axis_peaks": peaks}
    assert not mdm_mod.cancelling_steps(peaks, devs, 45, 0.45, **kw).any()  # no sides: no flip
    sides = np.zeros((120, 1), dtype=np.int8)
    sides[[40, 60], 0] = (1, -1)
    kw.update(sides=sides, sided_frames=19)
    flagged = mdm_mod.cancelling_steps(peaks, devs, 45, 0.45, **kw)
    assert np.array_equal(np.flatnonzero(flagged[:, 0]), np.r_[40:60])
    sides[60, 0] = 1  # two entries: the flip is not tried, however close
    assert not mdm_mod.cancelling_steps(peaks, devs, 45, 0.45, **kw).any()
    kw["sided_frames"] = 21
    assert not mdm_mod.cancelling_steps(peaks, devs, 45, 0.45, **kw).any()
    # two such bends close together (reviewer): every two of their four jumps oppose once read
    # the other way round; only an entry and the exit next to it are, so each pairs with its own
    two = q.copy()
    for lo in (40, 55):
        two[lo : lo + 10, 0] = rot.quat_mul(q[lo : lo + 10, 0], rot.rotvec_to_quat(grow[::2]))
    peaks = np.zeros((120, 1), dtype=bool)
    peaks[[40, 50, 55, 65], 0] = True
    sides = np.zeros((120, 1), dtype=np.int8)
    sides[[40, 50, 55, 65], 0] = (1, -1, 1, -1)
    devs = [mdm_mod.step_deviations(two, "body")]
    for sided in (19, 3):
        kw = {"axis_cos": 0.9, "axis_peaks": peaks, "sides": sides, "sided_frames": sided}
        got = mdm_mod.cancelling_steps(peaks, devs, 45, 0.45, **kw)
        assert np.array_equal(np.flatnonzero(got[:, 0]), np.r_[40:50, 55:65]), sided
    small = np.radians(np.linspace(40.0, 60.0, 20))[:, None] * np.array([[1.0, 0.0, 0.0]])
    same = q.copy()  # left by a 60-deg jump pointing the entry's way: a turn under 90 deg
    same[40:60, 0] = rot.quat_mul(q[40:60, 0], rot.rotvec_to_quat(small))
    same[50:60, 0] = rot.quat_mul(same[50:60, 0], rot.rotvec_to_quat(np.radians([-120, 0, 0])))
    devs = [mdm_mod.step_deviations(same, "body")]
    assert mdm_mod._opposed(devs, 40, 60, 0, flip=True) < 0.9


def test_cancelling_steps_never_pair_an_exit_with_a_later_entry() -> None:
    """Two wrong-way bends are not constant turns: each one's own ends cancel poorly, and the
    exit of the first (+0.9 rad) cancels the entry of the second (-0.9 rad) across the clean
    frames between them. Told which side of each jump digresses, the pair is refused there,
    and only there: jumps closer than ``sided_frames`` pair whatever their sides say."""
    q = _turning(120, J=1, seed=4)
    bad = q.copy()
    ax = np.array([1.0, 0.0, 0.0])
    bad[10:30, 0] = rot.quat_mul(
        q[10:30, 0], rot.rotvec_to_quat(np.linspace(0.4, 0.9, 20)[:, None] * ax)
    )
    bad[60:80, 0] = rot.quat_mul(
        q[60:80, 0], rot.rotvec_to_quat(np.linspace(0.9, 0.3, 20)[:, None] * ax)
    )
    peaks = np.zeros((120, 1), dtype=bool)
    peaks[[10, 30, 60, 80], 0] = True
    devs = [mdm_mod.step_deviations(bad, "body")]
    across = mdm_mod.cancelling_steps(peaks, devs, 45, 0.35)
    assert across[30:60, 0].all()  # the clean frames between the two errors
    sides = np.zeros((120, 1), dtype=np.int8)
    sides[[10, 60], 0], sides[[30, 80], 0] = 1, -1  # entries, exits
    assert not mdm_mod.cancelling_steps(peaks, devs, 45, 0.35, sides, 15).any()
    assert mdm_mod.cancelling_steps(peaks, devs, 45, 0.35, sides, 31)[30:60, 0].all()


def test_cancelling_steps_leave_one_frame_pops_to_the_spike_rule() -> None:
    """A toe that pops for one frame at each foot strike (Bandai-1 walk-back_angry): the exit of
    one pop and the entry of the next cancel across the stance between them, but each pop's
    two sides are each other's partners. Only the larger side is a peak of the jump size, so
    the pairing must know the frame beside it. A two-frame error still pairs its own ends."""
    F = 200
    q = _turning(F, J=1, seed=6)
    bad = q.copy()
    pop = rot.rotvec_to_quat(np.array([np.radians(11.0), 0.0, 0.0]))
    for f in (57, 88, 190):  # the last pop is near the take's end
        bad[f, 0] = rot.quat_mul(q[f, 0], pop)
    devs = [mdm_mod.step_deviations(bad, f) for f in ("body", "parent")]
    peaks = mdm_mod.step_peaks(mdm_mod.jump_size(bad), 1.45, np.radians(3.0), 97.0)
    assert set(np.flatnonzero(peaks[:, 0])) <= {57, 58, 88, 89, 190, 191}
    assert peaks[57:59, 0].any() and peaks[88:90, 0].any()
    spikes = mdm_mod.one_frame_spikes(peaks, devs, 0.3)
    assert np.array_equal(spikes, peaks)
    used = np.zeros(peaks.shape, dtype=bool)
    assert not mdm_mod.cancelling_steps(peaks, devs, 45, 0.45, used_out=used, pops=spikes).any()
    assert np.array_equal(used, peaks)  # paired with the frame beside them: no cut-off either
    # without the pops (pop_tol 0) the exit of one pop pairs with the entry of the next
    assert mdm_mod.cancelling_steps(peaks, devs, 45, 0.45)[60:85, 0].all()
    with pytest.raises(ValueError, match="pop_tol"):
        DetectConfig(pop_tol=-0.1)
    sides = np.where(peaks, 1, 0).astype(np.int8)
    assert not mdm_mod.cut_off_steps(peaks, used, sides, 45).any()
    two = q.copy()
    two[57:59, 0] = rot.quat_mul(q[57:59, 0], pop)  # two frames turned: ends two frames apart
    devs2 = [mdm_mod.step_deviations(two, f) for f in ("body", "parent")]
    peaks2 = np.zeros_like(peaks)
    peaks2[[57, 59], 0] = True
    assert not mdm_mod.one_frame_spikes(peaks2, devs2, 0.3).any()
    assert np.array_equal(
        np.flatnonzero(mdm_mod.cancelling_steps(peaks2, devs2, 45, 0.45)[:, 0]), [57, 58]
    )


def test_cancelling_steps_pair_a_misread_error_that_nothing_flanks() -> None:
    """Where the words match the turned stretch, the digression is lower inside an error than
    around it and the sides read its entry as an exit (and its exit as an entry). Two wrong-way
    bends are flanked by their own outer ends (an entry before, an exit after); a lone error
    is not, and pairs whatever its sides say."""
    q = _turning(120, J=1, seed=5)
    bad = q.copy()
    bad[40:70, 0] = rot.quat_mul(q[40:70, 0], rot.rotvec_to_quat(np.array([0.6, 0.2, 0.0])))
    peaks = np.zeros((120, 1), dtype=bool)
    peaks[[40, 70], 0] = True
    devs = [mdm_mod.step_deviations(bad, "body")]
    sides = np.zeros((120, 1), dtype=np.int8)
    sides[40, 0], sides[70, 0] = -1, 1  # misread
    lone = mdm_mod.cancelling_steps(peaks, devs, 45, 0.35, sides, 15)
    assert np.array_equal(np.flatnonzero(lone[:, 0]), np.r_[40:70])
    # one flank only (an entry 10 frames before): still paired
    peaks[30, 0], sides[30, 0] = True, 1
    assert mdm_mod.cancelling_steps(peaks, devs, 45, 0.35, sides, 15)[40:70, 0].all()
    # flanked on both sides (an exit 10 frames after too): refused
    peaks[80, 0], sides[80, 0] = True, -1
    assert not mdm_mod.cancelling_steps(peaks, devs, 45, 0.35, sides, 15)[40:70, 0].any()
    # an exit after it only (and the take's start more than max_frames before): paired
    peaks[30, 0], sides[30, 0] = False, 0
    assert mdm_mod.cancelling_steps(peaks, devs, 35, 0.35, sides, 15)[40:70, 0].all()
    # the flanks count within max_frames (here 30) of the pair, not one frame further
    for entry, exit_, paired in ((10, 100, False), (9, 100, True), (10, 101, True)):
        pk, sd = peaks.copy(), sides.copy()
        pk[80, 0], sd[80, 0] = False, 0
        pk[[entry, exit_], 0], sd[entry, 0], sd[exit_, 0] = True, 1, -1
        got = mdm_mod.cancelling_steps(pk, devs, 30, 0.35, sd, 15)[40:70, 0]
        assert got.all() if paired else not got.any(), (entry, exit_)


def test_cancelling_steps_take_the_takes_start_for_a_flank() -> None:
    """An error cut off by the take's start has an exit and no entry: its exit and the entry
    of a later error are not paired across the clean frames between them."""
    q = _turning(80, J=1, seed=7)
    bad = q.copy()
    d = rot.rotvec_to_quat(np.array([0.7, 0.0, 0.0]))
    bad[:12, 0] = rot.quat_mul(q[:12, 0], d)
    bad[40:, 0] = rot.quat_mul(q[40:, 0], d)
    peaks = np.zeros((80, 1), dtype=bool)
    peaks[[12, 40], 0] = True
    sides = np.zeros((80, 1), dtype=np.int8)
    sides[12, 0], sides[40, 0] = -1, 1
    devs = [mdm_mod.step_deviations(bad, "body")]
    assert not mdm_mod.cancelling_steps(peaks, devs, 45, 0.45, sides, 15).any()


def test_cut_off_steps_reach_the_takes_end_from_an_unpaired_jump() -> None:
    """An offset running off the take's end (or in from its start) has one jump: unpaired, it
    marks the frames to that end, but not past a later jump that leaves an error, not from a
    jump that paired, and not further than max_frames."""
    q = _turning(120, J=1, seed=4)
    bad = q.copy()
    d = rot.rotvec_to_quat(np.array([0.7, 0.0, 0.0]))
    bad[95:, 0] = rot.quat_mul(q[95:, 0], d)  # to the end
    bad[:12, 0] = rot.quat_mul(q[:12, 0], d)  # from the start
    peaks = np.zeros((120, 1), dtype=bool)
    peaks[[12, 95], 0] = True
    sides = np.zeros((120, 1), dtype=np.int8)
    sides[12, 0], sides[95, 0] = -1, 1  # an exit, an entry
    devs = [mdm_mod.step_deviations(bad, "body")]
    used = np.zeros((120, 1), dtype=bool)
    assert not mdm_mod.cancelling_steps(peaks, devs, 45, 0.35, sides, 15, used).any()
    assert not used.any()  # neither jump pairs
    out = mdm_mod.cut_off_steps(peaks, used, sides, 45)
    assert np.array_equal(np.flatnonzero(out[:, 0]), np.r_[0:12, 95:120])
    assert not mdm_mod.cut_off_steps(peaks, used, sides, 20)[95:].any()  # 25 frames to the end
    assert mdm_mod.cut_off_steps(peaks, used, sides, 20)[:12].all()  # 12 from the start
    # a later jump that leaves an error (it did not pair): the entry's error ends there
    later = peaks.copy()
    later[110, 0] = True
    sides2 = sides.copy()
    sides2[110, 0] = -1
    assert not mdm_mod.cut_off_steps(later, used, sides2, 45)[95:, 0].any()
    # a jump that paired is no cut-off
    paired = used.copy()
    paired[95, 0] = True
    assert not mdm_mod.cut_off_steps(peaks, paired, sides, 45)[95:, 0].any()


def test_extend_to_steps_reaches_the_error_edges() -> None:
    F = 120
    q = _turning(F, J=2, seed=6)
    bad = q.copy()
    d = rot.rotvec_to_quat(np.array([0.0, 0.0, np.radians(30.0)]))
    bad[40:60, 0] = rot.quat_mul(q[40:60, 0], d)
    steps = mdm_mod.step_size(bad)
    part = np.zeros((F, 2), dtype=bool)
    part[43:57, 0] = True  # the edges digress too little
    out = mdm_mod.extend_to_steps(part, steps, np.radians(8.0), 4)
    assert np.array_equal(np.flatnonzero(out[:, 0]), np.arange(40, 60))
    # steps farther than the width are not reached
    assert np.array_equal(mdm_mod.extend_to_steps(part, steps, np.radians(8.0), 2), part)
    assert not mdm_mod.extend_to_steps(part, steps, np.radians(8.0), 4)[:, 1].any()


def test_partly_flagged_offset_is_flagged_whole_end_to_end() -> None:
    walk = datasets.procedural_motion("walk", seconds=6.0, seed=5).motion
    names = list(walk.skeleton.names)
    j = names.index("LeftUpLeg")
    q = walk.rotations.copy()
    d = rot.rotvec_to_quat(np.array([0.0, np.radians(35.0), 0.0]))
    q[70:100, j] = rot.quat_mul(q[70:100, j], d)
    bad = type(walk)(walk.skeleton, q, walk.root_positions, walk.frame_time)
    cl = SelfSimilarityCleaner().fit(bad)
    m = cl.mask()
    assert m[70:100, j].all()
    assert not m[:66, j].any() and not m[104:, j].any()
    off = SelfSimilarityCleaner(pair_seconds=0.0).fit(bad)
    assert off.mask()[70:100, j].sum() <= m[70:100, j].sum()


@pytest.mark.parametrize(
    "kwargs",
    [{"step_ratio": 0.0}, {"step_min_deg": -1.0}, {"step_min_mdm": 1.5}, {"pair_seconds": -0.1}],
)
def test_step_parameters_are_checked(kwargs) -> None:
    with pytest.raises(ValueError, match=r"step_|pair_seconds"):
        SelfSimilarityCleaner(**kwargs)


def test_smooth_runs_drop_a_digression_without_a_step() -> None:
    q = _turning(60, J=2, seed=2)
    bad = q.copy()
    d = rot.rotvec_to_quat(np.array([0.0, np.radians(30.0), 0.0]))
    bad[20:30, 1] = rot.quat_mul(q[20:30, 1], d)  # abrupt: steps at 20 and 30
    steps = mdm_mod.step_size(bad)
    mask = np.zeros((60, 2), dtype=bool)
    mask[23:27] = True  # the same stretch flagged on the smooth joint 0 and the stepped joint 1
    keep = np.zeros_like(mask)
    smooth = mdm_mod.smooth_runs(mask, steps, keep, np.radians(10.0), pad=6)
    assert smooth[23:27, 0].all() and not smooth[:, 1].any()
    # a narrow pad does not reach the steps; a keep cell (a frozen joint) protects the run
    assert mdm_mod.smooth_runs(mask, steps, keep, np.radians(10.0), pad=1)[23:27, 1].all()
    keep[25, 0] = True
    assert not mdm_mod.smooth_runs(mask, steps, keep, np.radians(10.0), pad=6)[:, 0].any()


def test_excursion_match_matches_the_reference() -> None:
    from clean.naive import excursion_match as naive_excursion_match

    q = _turning(50, J=1, seed=3)[:, 0]
    other = _turning(30, J=1, seed=4)[:, 0]
    for start, stop, flex in ((1, 5, 1), (10, 17, 2), (44, 49, 1), (20, 21, 0)):
        fast = mdm_mod.excursion_match(q, start, stop, [other], flex)
        assert abs(fast - naive_excursion_match(q, start, stop, [other], flex)) < 1e-6
    assert mdm_mod.excursion_match(q, 0, 5) == np.inf  # no entry pose before the run


def test_recurring_runs_spare_a_random_error_and_drop_a_repeated_motif() -> None:
    F = 200
    q = np.tile(rot.quat_identity((1, 2)), (F, 1, 1))  # a joint at rest, like flat toes
    pops = {40: (8.0, 12.0, 26.0), 90: (25.0, 18.0), 150: (10.0, 27.0)}  # toe pops, varied
    for f, degs in pops.items():
        for i, deg in enumerate(degs):
            q[f + i, 0] = rot.rotvec_to_quat(np.array([np.radians(deg), 0.0, 0.0]))
    err = rot.rotvec_to_quat(np.array([0.0, np.radians(20.0), np.radians(15.0)]))
    q[120:122, 1] = err  # one random spike
    dig = np.full((F, 2), np.radians(25.0))
    mask = np.zeros((F, 2), dtype=bool)
    mask[90:92, 0] = True
    mask[120:122, 1] = True
    args = (6, np.radians(8.0), 0.5)
    drop = mdm_mod.recurring_runs(mask, q, dig, *args)
    assert drop[90:92, 0].all() and not drop[:, 1].any()
    # once alone in the take, the pop stays flagged unless a context take repeats it
    alone = q.copy()
    alone[40:43, 0] = alone[150:152, 0] = rot.quat_identity()
    assert not mdm_mod.recurring_runs(mask, alone, dig, *args).any()
    assert mdm_mod.recurring_runs(mask, alone, dig, *args, others=[q])[90:92, 0].all()
    # without lag flexibility the pop at 150, a frame slower to peak, does not match
    assert not mdm_mod.recurring_runs(mask, q, dig, *args, flex=0)[:, 0].any()
    # a match (2 deg off) that explains less than half of the digression does not veto
    assert not mdm_mod.recurring_runs(mask, q, dig * 0.1, *args).any()
    # long runs are never vetoed
    assert not mdm_mod.recurring_runs(mask, q, dig, 1, np.radians(8.0), 0.5).any()


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"abrupt_deg": -1.0}, "abrupt_deg and recur_deg"),
        ({"recur_deg": -0.5}, "abrupt_deg and recur_deg"),
        ({"limit_holds": -1}, "limit_holds must be 0"),
        ({"limit_holds": 1}, "limit_holds must be 0"),
        ({"limit_move_deg": -1.0}, "limit_move_deg must be >= 0"),
    ],
)
def test_veto_parameters_are_checked(kwargs, message) -> None:
    with pytest.raises(ValueError, match=message):
        SelfSimilarityCleaner(**kwargs)


def test_jump_size_sees_a_displaced_pose_not_a_limb_starting_at_once() -> None:
    F = 60
    t = np.arange(F)
    angle = np.zeros((F, 2))
    angle[30:, 0] = np.radians(20.0)  # joint 0: the pose jumps by 20 deg at frame 30
    angle[:, 1] = np.radians(6.0) * np.clip(t - 30, 0, None)  # joint 1: starts turning at 30
    q = rot.rotvec_to_quat(angle[..., None] * np.array([1.0, 0.0, 0.0]))
    jumps = mdm_mod.jump_size(q)
    assert int(np.argmax(jumps[:, 0])) == 30 and abs(np.degrees(jumps[30, 0]) - 20.0) < 1e-6
    assert np.degrees(jumps[:, 1]).max() < 1e-6  # a kink: the step changes on one side only
    assert np.degrees(mdm_mod.step_size(q)[:, 1]).max() > 2.9  # which step_size does see
    assert not mdm_mod.jump_size(q[:3]).any()


def test_step_deviations_and_jump_size_match_the_references() -> None:
    from clean.naive import jump_size as naive_jump_size
    from clean.naive import step_deviations as naive_step_deviations

    q = _turning(30, J=3, seed=8)
    q[12:15, 1] = rot.quat_mul(q[12:15, 1], rot.rotvec_to_quat(np.array([0.5, -0.2, 0.1])))
    for frame in ("body", "parent"):
        fast = mdm_mod.step_deviations(q, frame)
        assert np.allclose(fast, naive_step_deviations(q, frame), atol=1e-9)
    assert np.allclose(mdm_mod.jump_size(q), naive_jump_size(q), atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(
    st.integers(4, 40),
    st.integers(1, 6),
    st.floats(1.0, 8.0),
    st.integers(0, 10_000),
)
def test_still_jumps_match_the_reference(F: int, width: int, ratio: float, seed: int) -> None:
    from clean.naive import still_jumps as naive_still_jumps

    rng = np.random.default_rng(seed)
    # mostly still joints with a few turns at once, and one moving joint
    rv = np.zeros((F, 3, 3))
    for j in range(2):
        for f in rng.choice(F, size=min(3, F), replace=False):
            rv[f:, j] += rng.normal(scale=0.3, size=3)
    rv[:, 2] = np.cumsum(rng.normal(scale=0.05, size=(F, 3)), axis=0)
    q = rot.rotvec_to_quat(rv)
    fast = mdm_mod.still_jumps(q, np.radians(8.0), ratio, width)
    assert np.array_equal(fast, naive_still_jumps(q, np.radians(8.0), ratio, width))


def test_spike_size_matches_the_reference_and_sees_a_spike_not_fast_motion() -> None:
    from clean.naive import spike_size as naive_spike_size

    q = _turning(40, J=2, seed=7)
    bad = q.copy()
    d = rot.rotvec_to_quat(np.array([0.0, np.radians(30.0), np.radians(10.0)]))
    bad[20:23, 1] = rot.quat_mul(q[20:23, 1], d)  # a three-frame spike of ~32 deg
    fast = mdm_mod.spike_size(bad, 4)
    assert np.allclose(fast, naive_spike_size(bad, 4), atol=1e-9)
    assert np.degrees(fast[20:23, 1]).min() > 25.0
    assert np.degrees(fast[:, 0]).max() < 3.0  # a fast smooth turn stays on its cubic
    assert np.degrees(mdm_mod.spike_size(bad, 2)[20:23, 1]).max() < 25.0  # gap too short
    assert not mdm_mod.spike_size(bad[:4], 3).any()  # no gap with two frames either side


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compiled_spike_size_matches_the_reference_above_its_floor(seed: int) -> None:
    """The compiled kernel against the loop reference: exact where the reference is above the
    floor, at most the floor elsewhere; rough random motion with spikes of every length."""
    from clean.naive import spike_size as naive_spike_size

    rng = np.random.default_rng(seed)
    q = _turning(30, J=3, seed=seed)
    for _ in range(4):
        a, n, j = int(rng.integers(2, 24)), int(rng.integers(1, 5)), int(rng.integers(0, 3))
        q[a : a + n, j] = rot.quat_mul(q[a : a + n, j], rot.rotvec_to_quat(rng.normal(0, 0.6, 3)))
    for max_frames in (1, 3, 5):
        ref = naive_spike_size(q, max_frames)
        assert np.allclose(mdm_mod.spike_size(q, max_frames), ref, atol=1e-9)
        floor = float(np.quantile(ref, 0.7))
        fast = mdm_mod.spike_size(q, max_frames, floor)
        above = ref > floor + 1e-9
        assert np.allclose(fast[above], ref[above], atol=1e-9)
        assert (fast[~above] <= floor + 1e-9).all()
    assert np.allclose(mdm_mod.spike_size(q[:7], 50), naive_spike_size(q[:7], 3), atol=1e-9)
    zero = q.copy()
    zero[3, 0] = 0.0
    with pytest.raises(ValueError, match="unit quaternions"):
        mdm_mod.spike_size(zero, 2)


def test_a_spike_the_mdm_misses_is_flagged_end_to_end() -> None:
    walk = datasets.procedural_motion("walk", seconds=6.0, seed=5).motion
    j = list(walk.skeleton.names).index("LeftArm")
    q = walk.rotations.copy()
    d = rot.rotvec_to_quat(np.array([np.radians(50.0), 0.0, 0.0]))
    q[80:82, j] = rot.quat_mul(q[80:82, j], d)
    bad = type(walk)(walk.skeleton, q, walk.root_positions, walk.frame_time)
    from mocapkit.clean.detect import ORIGINAL_ORDER, PIPELINE, MDMHysteresis, Spikes

    # by the spike rule (its spike size alone): in a 6 s take the spike's own jumps are the
    # joint's top percent, so the cancelling jumps miss it
    for pipeline in (PIPELINE, ORIGINAL_ORDER, (MDMHysteresis, Spikes)):
        cl = SelfSimilarityCleaner(pipeline=pipeline).fit(bad)
        cl.mdm_[:, j] = 0.0  # as if the KNN words had followed the spike
        cl.forget_flags()
        m = cl.mask()
        assert m[80:82, j].all() and not m[:76, j].any() and not m[86:, j].any()


def test_cancelling_steps_pair_the_two_ends_of_a_flip() -> None:
    """A joint turning 3 deg per frame about x, flipped 180 deg about the same axis for 9
    frames: the entry step is 183 deg, which ``log`` reports as 177 deg about -x, and the exit
    step 177 deg about -x too. As rotation vectors they add up instead of cancelling; as turns
    one undoes the other, and the stretch is flagged."""
    F = 60
    r = np.radians(3.0) * np.arange(F)
    q = rot.rotvec_to_quat(r[:, None] * np.array([[1.0, 0.0, 0.0]]))[:, None]
    bad = q.copy()
    flip = rot.rotvec_to_quat(np.array([np.pi, 0.0, 0.0]))
    bad[20:29, 0] = rot.quat_mul(q[20:29, 0], flip)
    devs = [mdm_mod.step_deviations(bad, f) for f in ("body", "parent")]
    v_in, v_out = devs[0][20, 0], devs[0][29, 0]
    assert np.degrees(np.linalg.norm(v_in + v_out)) > 300  # the same way round
    peaks = np.zeros((F, 1), dtype=bool)
    peaks[[20, 29], 0] = True
    flagged = mdm_mod.cancelling_steps(peaks, devs, 45, 0.35)
    assert np.array_equal(np.flatnonzero(flagged[:, 0]), np.arange(20, 29))
    # two steps of 60 deg the same way do not cancel, whichever way round
    same = rot.rotvec_to_quat(np.array([np.radians(60.0), 0.0, 0.0]))
    stays = q.copy()
    stays[20:, 0] = rot.quat_mul(q[20:, 0], same)
    stays[29:, 0] = rot.quat_mul(stays[29:, 0], same)
    devs = [mdm_mod.step_deviations(stays, f) for f in ("body", "parent")]
    assert not mdm_mod.cancelling_steps(peaks, devs, 45, 0.35).any()


def test_burst_roughness_matches_the_reference_and_finds_a_burst_not_its_edges() -> None:
    from clean.naive import burst_roughness as naive_burst_roughness

    q = _turning(60, J=2, seed=4)
    bad = q.copy()
    rng = np.random.default_rng(2)
    noise = rot.rotvec_to_quat(rng.normal(scale=np.radians(10.0), size=(12, 3)))
    bad[20:32, 1] = rot.quat_mul(q[20:32, 1], noise)  # a 12-frame burst, sigma 10 deg
    bad[45:48, 0] = rot.quat_mul(q[45:48, 0], rot.rotvec_to_quat(np.array([0.6, 0.0, 0.0])))
    r = mdm_mod.burst_roughness(bad)
    assert np.allclose(r, naive_burst_roughness(bad), atol=1e-9)
    m = mdm_mod.noise_bursts(r, mdm_mod.turn_change(bad), np.radians(20.0), 6)
    assert not m[:, 0].any()  # a 34 deg spike raises the roughness on a few frames only
    assert not m[:18, 1].any() and not m[34:, 1].any()
    # the burst; its edge frames weigh little in the third difference and may fall short
    assert m[20:32, 1].sum() >= 8
    calm = (mdm_mod.burst_roughness(q), mdm_mod.turn_change(q))
    assert not mdm_mod.noise_bursts(*calm, np.radians(20.0), 6).any()


def test_wrong_way_bends_flag_a_knee_bent_backwards_only() -> None:
    walk = datasets.procedural_motion("walk", seconds=6.0, seed=5).motion
    ctx = datasets.procedural_motion("walk", seconds=6.0, seed=6).motion
    knees = hinge_joints(walk)
    names = walk.skeleton.names
    assert sorted(names[j] for j in knees) == sorted(
        ["LeftForeArm", "RightForeArm", "LeftLeg", "RightLeg"]
    )
    clean = mdm_mod.wrong_way_bends(walk.rotations, knees, np.radians(15.0), [ctx.rotations])
    assert not clean.any()
    j = names.index("LeftLeg")
    inj = inject(walk, "bend", j, np.random.default_rng(1), start=70)
    m = mdm_mod.wrong_way_bends(inj.motion.rotations, knees, np.radians(15.0))
    assert np.array_equal(m[:, j], inj.frames) and not np.delete(m, j, axis=1).any()
    # the cleaner flags it even where the KNN words follow it (several bends match each other)
    cl = SelfSimilarityCleaner().fit(inj.motion, [ctx])
    cl.mdm_[:, j] = 0.0
    cl.forget_flags()
    assert cl.mask()[inj.frames, j].all()


def test_limb_hinges_need_a_straight_rest_pose_for_the_bend_rule() -> None:
    from mocapkit.clean.detect import straight_hinges

    sk = datasets.humanoid_skeleton()
    assert straight_hinges(sk, np.radians(20.0)) == hinge_joints(
        datasets.procedural_motion("walk", seconds=1.0, seed=1).motion
    )
    j = sk.names.index("LeftLeg")
    offsets = sk.offsets.copy()
    child = sk.children(j)[0]
    # bend the rest shin 45 deg forward: the zero rotation is no longer a straight knee
    offsets[child] = rot.quat_apply(rot.rotvec_to_quat(np.array([0.8, 0.0, 0.0])), offsets[child])
    bent = dataclasses.replace(sk, offsets=offsets)
    assert j not in straight_hinges(bent, np.radians(20.0))


def test_neighbours_on_a_known_bad_cell_do_not_speak_for_its_joint() -> None:
    walk = datasets.procedural_motion("walk", seconds=6.0, seed=5).motion
    j = list(walk.skeleton.names).index("LeftLeg")
    inj = inject(walk, "bend", j, np.random.default_rng(1), start=70)
    cl = SelfSimilarityCleaner().fit(inj.motion)
    tex = cl.texture_
    bad_a = np.interp(tex.analysis_times(), tex.file_times(), inj.frames.astype(float)) > 0
    M = cl.word_lengths_[2]
    barred_somewhere = False
    for gn in cl.neighbours_:
        use = gn.usable_mask()
        found = np.broadcast_to((gn.index >= 0)[:, :, None, None], use.shape)
        if j not in gn.group.joints:
            assert np.array_equal(use, found)  # no bad cell on its joints
            continue
        jj = gn.group.joints.index(j)
        N = use.shape[2]
        pos = gn.index[:, :, None] + np.round(np.arange(N) * (M - 1) / (N - 1)).astype(int)
        on_bend = (gn.index >= 0)[:, :, None] & bad_a[np.clip(pos, 0, len(bad_a) - 1)]
        barred = found[..., jj] & ~use[..., jj]
        assert not (barred & ~on_bend).any()  # only frames lying on the bend are barred
        # ... all of them, unless every neighbour of that word frame lies on it
        some_clean = (found[..., jj] & ~on_bend).any(axis=1, keepdims=True)
        assert np.array_equal(barred & some_clean, found[..., jj] & on_bend & some_clean)
        barred_somewhere |= bool(barred.any())
    assert barred_somewhere


def test_noise_burst_edges_are_told_by_the_step_into_the_noise() -> None:
    """The roughness run of a burst on frames a..b spans a-1..b or a-2..b+1 (its outermost
    frames see one noisy step). Where it starts one frame before the burst, the step out of
    that frame enters the noise and differs from the step before it; two frames before, both
    steps are the clean motion's. The flags are the burst's frames, in one run, never more
    than one frame off: of 800 edges the step test misplaces a handful, where the run's
    outermost roughness against the next frame's misplaced 51 (ratio 0.5) or 42 (2/3)."""
    lost = extra = 0
    for seed in range(400):
        q = _turning(60, J=1, seed=seed)
        rng = np.random.default_rng(seed)
        a, b = 15, 15 + int(rng.integers(10, 25)) - 1
        noise = rng.normal(scale=np.radians(rng.uniform(5, 15)), size=(b - a + 1, 3))
        bad = q.copy()
        bad[a : b + 1, 0] = rot.quat_mul(q[a : b + 1, 0], rot.rotvec_to_quat(noise))
        f = np.flatnonzero(
            mdm_mod.noise_bursts(
                mdm_mod.burst_roughness(bad), mdm_mod.turn_change(bad), np.radians(5.0), 6
            )[:, 0]
        )
        assert len(f) and np.all(np.diff(f) == 1)  # one run
        assert abs(f[0] - a) <= 1 and abs(f[-1] - b) <= 1
        lost += (f[0] > a) + (f[-1] < b)
        extra += (f[0] < a) + (f[-1] > b)
    assert lost + extra <= 10


def test_noise_bursts_go_on_over_a_dip_of_the_roughness_inside_the_burst() -> None:
    """Noise that deviates little on two frames dips the roughness under the level inside a
    burst: with hysteresis the burst goes on over the dip (frames above half the level) to its
    first frames; without, the part before the dip is too short to count. Frames above half the
    level beside a burst too short to count are never flagged."""
    level = np.radians(20.0)
    r = np.zeros((80, 1))
    r[10:15] = np.radians(30.0)  # the burst's first frames: a run too short on its own
    r[15:17] = np.radians(15.0)  # the dip
    r[17:30] = np.radians(30.0)
    r[50:54] = np.radians(30.0)  # an error's edge: rough for a few frames only ...
    r[54:62] = np.radians(15.0)  # ... then fast natural motion above half the level
    change = np.zeros((80, 1))
    change[[10, 17, 30], 0] = 1.0  # the steps into and out of the noise (see the edge tests)
    held = mdm_mod.noise_bursts(r, change, level, 6, hold_ratio=0.5)[:, 0]
    cut = mdm_mod.noise_bursts(r, change, level, 6, hold_ratio=1.0)[:, 0]
    assert held[11:30].all() and not held[:10].any() and not held[31:].any()
    assert cut[18:30].all() and not cut[:17].any() and not cut[31:].any()


def test_exactness_tells_a_dropout_only_where_the_data_do_not_repeat_values_all_along() -> None:
    """A take written at twice its source's rate (each frame twice) repeats values all along:
    there an exact hold is judged like any still run (a near rest spares it); in captured data
    it is a dropout."""
    F = 150
    rng = np.random.default_rng(1)
    t = np.arange(F)
    swing = 0.5 * np.clip(np.sin(2 * np.pi * t / 30), 0, None)
    live = rot.rotvec_to_quat(
        np.stack([swing + np.radians(0.05) * rng.standard_normal(F), 0 * t, 0 * t], axis=1)
    )[:, None]
    doubled = live.copy()
    doubled[1::2] = doubled[0:-1:2]  # every value written twice
    for q, tells in ((live, True), (doubled, False)):
        held = q.copy()
        held[60:90, 0] = q[60, 0]
        assert mdm_mod.exact_holds_tell(held[:, 0], 10, 0.05) is tells
        out = mdm_mod.frozen_cells(held, rot.quat_angle(held, q), min_frames=10,
                                   speed=np.radians(0.2))  # fmt: skip
        assert bool(out[62:90, 0].all()) is tells


def test_an_exact_hold_that_does_not_come_back_is_judged_as_any_still_run() -> None:
    """A dropout comes back: a joint held bit for bit from some frame to the take's end (never
    captured after that) is a pause where its KNN words hold too, not a dropout."""
    F = 120
    t = np.linspace(0, 2 * np.pi, F)
    q = rot.rotvec_to_quat(np.stack([0.6 * np.sin(t), 0 * t, 0 * t], axis=1))[:, None]
    held = q.copy()
    held[60:, 0] = q[60, 0]  # to the last frame
    calm = np.zeros((F, 1))
    assert not mdm_mod.frozen_cells(held, calm, min_frames=10).any()
    inside = q.copy()
    inside[60:100, 0] = q[60, 0]  # comes back at frame 100
    assert mdm_mod.frozen_cells(inside, calm, min_frames=10)[62:100, 0].all()


@settings(max_examples=60, deadline=None)
@given(
    st.integers(min_value=0, max_value=2**32 - 1),
    st.sampled_from([0.3, 0.5, 1.0]),
    st.integers(min_value=2, max_value=8),
    st.sampled_from(
        [(DetectConfig().noise_edge_share, DetectConfig().noise_edge_jump), (0.5, 0.0)]
    ),
)
def test_noise_bursts_match_the_readable_reference(
    seed: int, hold: float, min_frames: int, edge: tuple[float, float]
) -> None:
    from clean.naive import noise_bursts as naive_noise_bursts

    rng = np.random.default_rng(seed)
    F, J = int(rng.integers(12, 120)), int(rng.integers(1, 4))
    r = np.abs(rng.normal(size=(F, J))) * rng.uniform(0.1, 3.0, size=J)
    r[rng.random((F, J)) < 0.3] *= 5.0  # bursty
    level = rng.uniform(0.5, 3.0, size=J)
    change = np.abs(rng.normal(size=(F, J))) * rng.uniform(0.1, 3.0, size=J)
    fast = mdm_mod.noise_bursts(r, change, level, min_frames, *edge, hold)
    assert np.array_equal(fast, naive_noise_bursts(r, change, level, min_frames, *edge, hold))


def test_turn_change_matches_the_readable_reference() -> None:
    from clean.naive import turn_change as naive_turn_change

    q = _turning(40, J=3, seed=11)
    assert np.allclose(mdm_mod.turn_change(q), naive_turn_change(q), atol=1e-9)


@pytest.mark.parametrize("small_ratio", [0.0, 0.3])
def test_cancelling_steps_drop_a_small_pair_across_a_larger_stretchs_edge(small_ratio) -> None:
    """A 40-deg turned stretch (peaks 20 and 40) and a natural pair of 1-deg step deviations at
    17 and 23 across its entry: whichever cancels the better, the small pair is dropped and the
    flag starts at the stretch's own entry (a dancer's elbow flagged 3 frames early; reviewer:
    the drop must not depend on the order the pairs are taken in)."""
    F = 60
    v = np.zeros((F, 1, 3))
    big = np.radians(40.0) * np.array([1.0, 0.0, 0.0])
    v[20, 0], v[40, 0] = big, -big + np.radians(8.0) * np.array([0.0, 1.0, 0.0])  # ratio 0.2
    small = np.radians(1.0) * np.array([0.0, 0.0, 1.0])
    v[17, 0] = small
    v[23, 0] = -small * (1.0 + small_ratio)  # cancels exactly, or at 0.3 (worse than 0.2)
    peaks = np.zeros((F, 1), dtype=bool)
    peaks[[17, 20, 23, 40], 0] = True
    used = np.zeros_like(peaks)
    out = mdm_mod.cancelling_steps(peaks, [v], 40, 0.45, used_out=used)
    assert np.flatnonzero(out[:, 0]).tolist() == list(range(20, 40))
    assert np.flatnonzero(used[:, 0]).tolist() == [20, 40]
    # the small pair alone is a pair as before
    alone = peaks.copy()
    alone[[20, 40], 0] = False
    assert np.flatnonzero(mdm_mod.cancelling_steps(alone, [v], 40, 0.45)[:, 0]).tolist() == list(
        range(17, 23)
    )
