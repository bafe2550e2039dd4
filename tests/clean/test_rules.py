"""Each detection rule on a hand-made case where it must fire and one where it must not."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mocapkit.clean import SelfSimilarityCleaner
from mocapkit.clean import mdm as mdm_mod
from mocapkit.clean.detect import (
    ADDED,
    ORIGINAL_ORDER,
    PIPELINE,
    RETIRED,
    BridgeHoles,
    CancellingJumps,
    DetectConfig,
    DominanceVeto,
    Evidence,
    ExtendToSteps,
    Flags,
    FrozenJoints,
    LimitReleaseVeto,
    MDMHysteresis,
    NoiseBursts,
    OnceAtTheEnds,
    PaperThreshold,
    RecurringVeto,
    SmoothVeto,
    Spikes,
    WrongWayHinges,
    run_pipeline,
)
from mocapkit.core import rotations as rot

FPS = 30.0


def smooth(F: int = 90, J: int = 2, amp: float = 0.5) -> np.ndarray:
    """(F, J, 4) joints swinging slowly about x (one cycle per 3 s)."""
    t = np.arange(F) / FPS
    ang = amp * np.sin(2 * np.pi * t / 3.0)
    rv = np.zeros((F, J, 3))
    rv[..., 0] = ang[:, None] * (1 + 0.2 * np.arange(J))[None]
    return rot.rotvec_to_quat(rv)


def turn(q: np.ndarray, frames: slice, joint: int, deg: float, axis=(0.0, 1.0, 0.0)) -> np.ndarray:
    out = q.copy()
    d = rot.rotvec_to_quat(np.radians(deg) * np.asarray(axis))
    out[frames, joint] = rot.quat_mul(q[frames, joint], d)
    return out


def evidence(q, mdm=None, z=None, dig=None, **kw) -> Evidence:
    ev = Evidence(q, FPS, **kw)
    shape = q.shape[:2]
    mdm = np.zeros(shape) if mdm is None else mdm
    z = np.sqrt(-np.log(np.clip(1 - mdm, 1e-12, 1))) if z is None else z
    dig = np.zeros(shape) if dig is None else dig
    return ev.set_maps(mdm, z, dig)


def flagged(F: int, J: int, cells) -> Flags:
    fl = Flags((F, J))
    m = np.zeros((F, J), dtype=bool)
    for a, b, j in cells:
        m[a:b, j] = True
    fl.flag("test", m)
    return fl


def test_pipeline_is_data_and_config_has_no_frames() -> None:
    names = [r.name for r in ORIGINAL_ORDER]
    assert names[0] == "mdm" and names[-1] == "bridge" and len(set(names)) == len(names)
    assert (set(ORIGINAL_ORDER) - set(RETIRED)) | set(ADDED) == set(PIPELINE)
    assert len(PIPELINE) == len(set(PIPELINE))
    # the spike rule runs after every other flagging rule: a spike beside a run they flag is
    # left to that run
    flaggers = [r for r in PIPELINE if not r.veto and r.name not in ("spike", "bridge")]
    assert all(PIPELINE.index(r) < PIPELINE.index(Spikes) for r in flaggers)
    for r in (*ORIGINAL_ORDER, *ADDED):
        assert r.__doc__ and "Relies on" in r.__doc__, r.__name__
        assert dataclasses.is_dataclass(r) and r.__dataclass_params__.frozen
    for f in dataclasses.fields(DetectConfig):
        assert "frame" not in f.name, f.name
    with pytest.raises(TypeError, match="unknown DetectConfig"):
        DetectConfig().replace(jump_frames=3)
    with pytest.raises(TypeError, match="unknown DetectConfig"):
        SelfSimilarityCleaner(nope=1)
    with pytest.raises(ValueError, match="spike_deg"):
        DetectConfig(spike_deg=-1.0)
    with pytest.raises(ValueError, match="still_jump_ratio"):
        DetectConfig(still_jump_ratio=-1.0)
    with pytest.raises(ValueError, match="still_jump_seconds"):
        DetectConfig(still_jump_seconds=-0.1)
    for bad in ({"pair_axis_cos": -0.5}, {"pair_axis_cos": 1.5}, {"pair_axis_ratio": -1.0}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            DetectConfig(**bad)


def test_mdm_threshold_and_hysteresis() -> None:
    q = smooth()
    mdm = np.zeros((90, 2))
    mdm[20:30, 0] = 0.6
    mdm[25, 0] = 1.0  # a near-certain seed
    mdm[50:60, 1] = 0.7  # above threshold, no seed, smooth track
    ev = evidence(q, mdm)
    fl = Flags((90, 2))
    MDMHysteresis().apply(ev, fl)
    assert fl.mask[20:30, 0].all() and not fl.mask[:, 1].any()
    fl = Flags((90, 2))
    PaperThreshold().apply(ev, fl)
    assert fl.mask[50:60, 1].all() and fl.mask.sum() == 20


def test_dominance_veto() -> None:
    q = smooth()
    z = np.zeros((90, 2))
    z[30:35, 0] = 1.5
    z[30:35, 1] = 10.0
    ev = evidence(q, z=z)
    fl = flagged(90, 2, [(30, 35, 0), (30, 35, 1)])
    DominanceVeto().apply(ev, fl)
    assert not fl.mask[:, 0].any() and fl.mask[30:35, 1].all()
    z[30:35, 1] = 2.0  # comparable digressions: both stay
    fl = flagged(90, 2, [(30, 35, 0), (30, 35, 1)])
    DominanceVeto().apply(evidence(q, z=z), fl)
    assert fl.mask[30:35].all()


def test_cancelling_jumps() -> None:
    # the jumps are judged against the joint's own (97th percentile): a take of 10 s
    bad = turn(smooth(300), slice(40, 52), 1, 40.0)
    fl = Flags((300, 2))
    CancellingJumps().apply(evidence(bad), fl)
    assert fl.mask[40:52, 1].all() and fl.mask.sum() == 12
    fl = Flags((300, 2))
    CancellingJumps().apply(evidence(smooth(300)), fl)
    assert not fl.mask.any()
    # one jump that stays (a turn that does not come back) pairs with nothing
    fl = Flags((300, 2))
    CancellingJumps().apply(evidence(turn(smooth(300), slice(40, 300), 1, 40.0)), fl)
    assert not fl.mask[:, 1].any()
    # ... unless the take ends within pair_seconds of it and the frames after it digress: an
    # error cut off by the take's end
    cut = turn(smooth(300), slice(270, 300), 1, 40.0)
    mdm = np.zeros((300, 2))
    mdm[275:, 1] = 0.9
    fl = Flags((300, 2))
    CancellingJumps().apply(evidence(cut, mdm=mdm), fl)
    assert fl.mask[270:, 1].all() and not fl.mask[:270].any()
    text = CancellingJumps().describe(evidence(cut, mdm=mdm), 280, 1)
    assert "jump at frame 270" in text and "cut off by its end" in text
    # frames that do not digress are flagged where the jump is far above the joint's own
    # (a slow joint's error need not digress), not where it is of the joint's usual size
    fl = Flags((300, 2))
    CancellingJumps().apply(evidence(cut), fl)
    assert fl.mask[270:, 1].all() and not fl.mask[:270].any()
    assert "times the joint's ordinary one" in CancellingJumps().describe(evidence(cut), 280, 1)
    # a one- or two-frame spike near the end (its tied jumps leave one unpaired, read as an
    # error running to the end) jumps back: the frames after it are not flagged
    # (a one-frame spike's jump is one side of a pop, paired with the frame beside it: not
    # even a candidate)
    for spike in (slice(285, 286), slice(285, 287)):
        ev = evidence(turn(smooth(300), spike, 1, 40.0))
        one = spike.stop - spike.start == 1
        assert ev.pops[:, 1].any() == one
        if one:
            assert not ev.cut_off[:, 1].any()
            peak = int(np.flatnonzero(ev.pops[:, 1])[0])
            text = CancellingJumps().describe(ev, peak, 1)
            assert f"one side of a one-frame pop with frame {2 * 285 + 1 - peak}" in text
        else:
            assert ev.cut_off[spike.stop :, 1].all()  # the candidate the rule must refuse
        assert not CancellingJumps().cells(ev)[spike.stop :, 1].any()
    # nor after an error whose jumps do not cancel (a wrong-way bend's exit, read as an entry)
    # (its two jumps, 60 deg in and 30 deg back about the same axis, pair as a turn about one
    # axis when they may: then the exit is no candidate at all)
    bent = turn(turn(smooth(300), slice(250, 300), 1, 60.0), slice(275, 300), 1, -30.0)
    ev = evidence(bent, config=DetectConfig(pair_axis_cos=0.0))
    assert ev.cut_off[275:, 1].all() and not CancellingJumps().cells(ev)[275:, 1].any()
    ev = evidence(bent)
    assert not ev.cut_off[275:, 1].any() and not CancellingJumps().cells(ev)[275:, 1].any()
    for ev in (
        evidence(cut, config=DetectConfig(pair_cut_jump_ratio=1e6)),
        evidence(cut, config=DetectConfig(pair_cut_jump_ratio=0)),
        evidence(cut, mdm=mdm, config=DetectConfig(pair_cut_off=False)),
    ):
        fl = Flags((300, 2))
        CancellingJumps().from_config(ev.config).apply(ev, fl)
        assert not fl.mask.any()
    # the MDM condition reads the pipeline's threshold, an override included
    assert run_pipeline(evidence(cut, mdm=mdm)).added["cancelling-jumps"][270:, 1].all()
    strict = DetectConfig(pair_cut_jump_ratio=0)
    over = run_pipeline(evidence(cut, mdm=mdm, config=strict), threshold=0.95)
    over = over.added["cancelling-jumps"]
    assert not over[:, 1].any()
    # the same in from the take's start: the jump at frame 30 leaves the error
    start = turn(smooth(300), slice(0, 30), 1, 40.0)
    mdm0 = np.zeros((300, 2))
    mdm0[:30, 1] = 0.9
    fl = Flags((300, 2))
    CancellingJumps().apply(evidence(start, mdm=mdm0), fl)
    assert fl.mask[:30, 1].all() and not fl.mask[30:].any()
    assert "cut off by its start" in CancellingJumps().describe(evidence(start, mdm=mdm0), 5, 1)
    # not flagged: --explain says what the cut-off reading lacked (newcomer: a CMU knee's
    # dropout at the start went unflagged once a damage 1.47 s later jumped as much)
    mild0 = 0.3 * (mdm0 > 0)
    text = CancellingJumps(cut_jump_ratio=1e6).describe(evidence(start, mdm=mild0), 5, 1)
    assert "may bound an error cut off by the take's start (0:30)" in text
    assert "0% of those frames have MDM above 0.5" in text and "not over 1e+06" in text
    again = turn(start, slice(60, 70), 1, 40.0)
    text = CancellingJumps().describe(evidence(again, mdm=mild0), 5, 1)
    assert "but so is another within 1.5 s (frame" in text, text
    # ... and there too by its one jump where the frames digress too little for the MDM rule
    mild = np.zeros((300, 2))
    mild[:30, 1] = 0.3
    fl = Flags((300, 2))
    CancellingJumps().apply(evidence(start, mdm=mild), fl)
    assert fl.mask[:30, 1].all() and not fl.mask[30:].any()
    fl = Flags((300, 2))
    CancellingJumps(cut_jump_ratio=0).apply(evidence(start, mdm=mild), fl)
    assert not fl.mask.any()


def popping_toe(F: int = 300) -> np.ndarray:
    """(F, 2, 4): joint 1 held still but for a one-frame pop of 12 deg every second (a toe at
    each foot strike), so that its ordinary jump (97th percentile) is about 12 deg."""
    rv = np.zeros((F, 2, 3))
    rv[15::30, 1, 0] = np.radians(12.0)
    return rot.rotvec_to_quat(rv)


def test_still_jumps() -> None:
    still = np.radians(8.0)
    # a still joint turned 15 deg at once from frame 200 on: a still jump at 200 ...
    q = turn(popping_toe(), slice(200, 300), 1, 15.0)
    s = mdm_mod.still_jumps(q, still, 5.0, 3)
    assert s[200, 1] and s.sum() == 1
    # ... far under the joint's own bar (1.45 times its 12 deg pops): no jump peak without it
    assert not evidence(q, config=DetectConfig(still_jump_ratio=0)).jump_peaks[200, 1]
    assert evidence(q).jump_peaks[200, 1]
    # a still joint's one-frame pop (two big steps in a row), a moving joint stopping dead (a
    # foot strike) and a turn amid fast motion are no still jumps
    assert not mdm_mod.still_jumps(popping_toe(), still, 5.0, 3).any()
    rv = np.zeros((300, 2, 3))
    rv[:100, 1, 0] = np.radians(np.arange(100) * 3.0)
    rv[100:, 1, 0] = rv[99, 1, 0]
    assert not mdm_mod.still_jumps(rot.rotvec_to_quat(rv), still, 5.0, 3).any()
    fast = turn(smooth(300, amp=1.5), slice(225, 300), 1, 15.0)  # at its fastest
    assert not mdm_mod.still_jumps(fast, still, 5.0, 3)[225, 1]
    # one two frames before the take's end is found; none on the last frame (no step after it)
    end = turn(popping_toe(), slice(298, 300), 1, 15.0)
    assert np.flatnonzero(mdm_mod.still_jumps(end, still, 5.0, 3)[:, 1]).tolist() == [298]
    assert not mdm_mod.still_jumps(
        turn(popping_toe(), slice(299, 300), 1, 15.0), still, 5.0, 3
    ).any()
    # the ratio: neighbouring steps of 1/7 of the jump are still at ratio 5, not at 10
    rv = np.zeros((300, 2, 3))
    rv[:, 1, 0] = np.radians(np.arange(300) * 15.0 / 7.0 * (np.arange(300) < 200))
    rv[200:, 1, 0] = rv[199, 1, 0] + np.radians(15.0) + np.radians(np.arange(100) * 15.0 / 7.0)
    q7 = rot.rotvec_to_quat(rv)
    assert mdm_mod.still_jumps(q7, still, 5.0, 3)[200, 1]
    assert not mdm_mod.still_jumps(q7, still, 10.0, 3)[200, 1]
    # Evidence passes the config's step_min_deg and turns still_jump_seconds into the take's
    # frames: at 120 fps a joint moving until 6 frames (0.05 s) before is not still for 0.1 s
    assert not evidence(q, config=DetectConfig(step_min_deg=20.0)).still_jumps.any()
    rv = np.zeros((300, 2, 3))
    rv[:194, 1, 0] = np.radians(np.arange(194) * 4.0)
    rv[194:, 1, 0] = rv[193, 1, 0]
    fast = turn(rot.rotvec_to_quat(rv), slice(200, 300), 1, 15.0)
    assert Evidence(fast, 30.0).still_jumps[200, 1]  # 0.1 s: three frames, all still
    assert not Evidence(fast, 120.0).still_jumps[200, 1]  # twelve frames: it was moving
    # nor a jump under step_min_deg, however still the joint
    assert not mdm_mod.still_jumps(
        turn(popping_toe(), slice(200, 300), 1, 6.0), still, 5.0, 3
    ).any()


def test_cancelling_jumps_pair_a_turn_about_one_axis_whose_size_follows_the_joint() -> None:
    """A wrong-way bend mirrors the flexion: its stretch is turned about one axis by an angle
    that changes with the joint's own swing, so entry and exit jumps differ in size (here 20
    and 60 deg) and do not cancel. Both far above the joint's ordinary jump and pointing
    opposite ways, they pair; with ``pair_axis_cos`` 0 (off), or one jump of the joint's
    usual size, they do not."""
    q = smooth(300)
    grow = np.radians(np.linspace(20.0, 60.0, 15))[:, None] * np.array([[1.0, 0.0, 0.0]])
    bad = q.copy()
    bad[40:55, 1] = rot.quat_mul(q[40:55, 1], rot.rotvec_to_quat(grow))
    fl = Flags((300, 2))
    CancellingJumps().apply(evidence(bad), fl)
    assert fl.mask[40:55, 1].all() and fl.mask.sum() == 15
    assert "turn there and back about one axis" in CancellingJumps().describe(evidence(bad), 45, 1)
    fl = Flags((300, 2))
    ev = evidence(bad, config=DetectConfig(pair_axis_cos=0.0))
    CancellingJumps().apply(ev, fl)
    assert not fl.mask.any()
    fl = Flags((300, 2))  # the jumps must both be over pair_axis_ratio times the joint's own
    CancellingJumps().apply(evidence(bad, config=DetectConfig(pair_axis_ratio=1e4)), fl)
    assert not fl.mask.any()


def test_cancelling_jumps_flag_a_still_joints_error_cut_off_by_the_take() -> None:
    """A toe held still turned 15 deg from frame 280 to the take's end (its pops make its
    ordinary jump 12 deg): the cut-off error's one jump counts because the toe is still around
    it; without the still jumps nothing is flagged."""
    cut = turn(popping_toe(), slice(280, 300), 1, 15.0)
    mdm = np.zeros((300, 2))
    mdm[280:, 1] = 0.7
    fl = Flags((300, 2))
    CancellingJumps().apply(evidence(cut, mdm=mdm), fl)
    assert fl.mask[280:, 1].all() and not fl.mask[:280].any()
    text = CancellingJumps().describe(evidence(cut, mdm=mdm), 290, 1)
    assert "frame 280 (15.0 deg, a step over 5 times every step within 0.1 s before" in text
    assert "cut off" in text
    off = DetectConfig(still_jump_ratio=0)
    fl = Flags((300, 2))
    CancellingJumps().from_config(off).apply(evidence(cut, mdm=mdm, config=off), fl)
    assert not fl.mask.any()


def test_cancelling_jumps_leave_a_clean_end_frame_out_of_a_cut_off_error() -> None:
    """An error entered at frame 1 (left at the next-to-last frame) has its entry where jumps
    are not measured, so it looks cut off by the take: the step out of frame 0 (into the last
    frame) cancels its one jump, so that end frame is clean; where that step is the joint's
    own (the error does run from frame 0), the end frame stays flagged."""
    F = 300
    for stretch, clean in ((slice(1, 2), 0), (slice(1, 4), 0), (slice(F - 2, F - 1), F - 1),
                           (slice(F - 4, F - 1), F - 1)):  # fmt: skip
        q = turn(smooth(F), stretch, 1, 60.0, axis=(0.6, 0.0, 0.8))
        mdm = np.zeros((F, 2))
        mdm[stretch, 1] = 0.9  # the error's frames digress: the jump's side is read
        ev = evidence(q, mdm=mdm)
        assert ev.cut_off[clean, 1]  # read as cut off by the take: the candidate to trim
        cells = CancellingJumps().cells(ev)
        assert cells[stretch, 1].all() and not cells[clean, 1]
        assert cells[:, 1].sum() == stretch.stop - stretch.start
        text = CancellingJumps().describe(ev, stretch.start, 1)
        assert ("frame 0 is clean" if clean == 0 else "the last frame is clean") in text
    # ... also where the joint turns fast on its own (10 deg a frame: the raw steps of a 30
    # deg pop do not cancel, their parts beyond the joint's own turn do)
    t = np.arange(F)
    rv = np.zeros((F, 2, 3))
    rv[:, 1, 1] = np.radians(10.0) * t  # a steady spin about y
    spin = rot.rotvec_to_quat(rv)
    for stretch, clean in ((slice(1, 2), 0), (slice(F - 2, F - 1), F - 1)):
        mdm = np.zeros((F, 2))
        mdm[stretch, 1] = 0.9
        ev = evidence(turn(spin, stretch, 1, 30.0), mdm=mdm)
        cells = CancellingJumps().cells(ev)
        assert ev.cut_off[clean, 1] and cells[stretch, 1].all() and not cells[clean, 1]
    # the same errors running from the take's first frame (to its last) keep that frame
    for stretch in (slice(0, 4), slice(F - 4, F)):
        mdm = np.zeros((F, 2))
        mdm[stretch, 1] = 0.9
        cells = CancellingJumps().cells(evidence(turn(smooth(F), stretch, 1, 60.0), mdm=mdm))
        assert cells[stretch, 1].all() and cells[:, 1].sum() == 4


def test_cancelling_jumps_three_errors_on_one_joint_do_not_hide_each_other() -> None:
    """Three offsets of 20-30 deg on one joint of a 10 s take make 6 jumps, the top 2% of its
    frames: measured against its 99th percentile (one of the errors' own jumps) two of them
    would pass unseen; the 97th percentile is still the joint's own motion."""
    bad = smooth(300)
    for (a, b), deg in zip(((40, 52), (120, 140), (200, 215)), (20.0, 25.0, 30.0), strict=True):
        bad = turn(bad, slice(a, b), 1, deg)
    fl = Flags((300, 2))
    CancellingJumps().apply(evidence(bad), fl)
    assert np.array_equal(np.flatnonzero(fl.mask[:, 1]), np.r_[40:52, 120:140, 200:215])
    old = DetectConfig(pair_quantile=99.0, pair_ratio=1.2, still_jump_ratio=0)
    fl = Flags((300, 2))
    CancellingJumps().apply(evidence(bad, config=old), fl)
    assert fl.mask[:, 1].sum() < 47


def test_spikes() -> None:
    bad = turn(smooth(), slice(40, 42), 0, 50.0)
    fl = Flags((90, 2))
    Spikes().apply(evidence(bad), fl)
    assert fl.mask[40:42, 0].all() and fl.mask.sum() == 2
    fl = Flags((90, 2))
    Spikes().apply(evidence(smooth(amp=1.5)), fl)
    assert not fl.mask.any()
    fl = Flags((90, 2))  # longer than spike_seconds (two frames at 30 fps): not this rule's
    Spikes().apply(evidence(turn(smooth(), slice(40, 43), 0, 50.0)), fl)
    assert not fl.mask.any()
    # under 40 deg: a spike where the joint's own jumps are small ...
    fl = Flags((90, 2))
    Spikes().apply(evidence(turn(smooth(), slice(40, 41), 0, 25.0)), fl)
    assert np.flatnonzero(fl.mask[:, 0]).tolist() == [40] and not fl.mask[:, 1].any()
    fl = Flags((90, 2))  # ... never under the floor (20 deg)
    Spikes().apply(evidence(turn(smooth(), slice(40, 41), 0, 15.0)), fl)
    assert not fl.mask.any()
    # ... and a wobble where they are large: a joint whipping to and fro at 2.5 Hz (its jumps
    # some 15 deg) wobbling 30 deg off its path for a frame is not flagged, 45 deg is
    t = np.arange(90) / FPS
    rv = np.zeros((90, 2, 3))
    rv[:, 0, 0] = 1.0 * np.sin(2 * np.pi * 2.5 * t)
    rv[:, 1, 0] = 0.3 * np.sin(2 * np.pi * t / 3.0)
    whip = rot.rotvec_to_quat(rv)
    ev = evidence(turn(whip, slice(40, 41), 0, 30.0))
    assert np.degrees(Spikes().bar(ev)[0]) > 30.0 > np.degrees(Spikes().bar(ev)[1])
    fl = Flags((90, 2))
    Spikes().apply(ev, fl)
    assert not fl.mask.any()
    fl = Flags((90, 2))
    Spikes().apply(evidence(turn(whip, slice(40, 41), 0, 45.0)), fl)
    assert np.flatnonzero(fl.mask[:, 0]).tolist() == [40]
    # beside the jump into a longer error the frames lie off the cubic by half that jump: 30
    # deg off for a 60 deg offset, over the bar, yet not a spike
    long = evidence(turn(smooth(), slice(40, 50), 0, 60.0))
    fl = Flags((90, 2))
    Spikes().apply(long, fl)
    assert np.degrees(long.spike_size[39, 0]) > 25.0 and not fl.mask.any()
    assert "beside the jump into a longer stretch" in Spikes().describe(long, 39, 0)
    assert "this joint's bar 20.0 deg" in Spikes().describe(long, 20, 0)
    for big in (100.0, 150.0):  # the frames whose cubic runs through a big spike's frame
        fl = Flags((90, 2))
        Spikes().apply(evidence(turn(smooth(), slice(40, 41), 0, big)), fl)
        assert np.flatnonzero(fl.mask[:, 0]).tolist() == [40]
    fl = Flags((90, 2))  # with the floor at 40 deg the bar is 40 deg for every joint
    Spikes(floor_deg=40.0).apply(evidence(turn(smooth(), slice(40, 41), 0, 30.0)), fl)
    assert not fl.mask.any()
    fl = flagged(90, 2, [(43, 46, 0)])  # already flagged next to it: left to that run
    Spikes().apply(evidence(bad), fl)
    assert not fl.added["spike"].any()


def test_spikes_on_a_takes_first_and_last_frames() -> None:
    """A take's end frame has no two frames on its far side for the cubic: it is judged off the
    constant turn of the two frames beside it. A 25 deg pop there is flagged (the same bar as
    anywhere), the natural end of a swing (even a fast one) is not."""
    for end in (0, 89):
        fl = Flags((90, 2))
        Spikes().apply(evidence(turn(smooth(), slice(end, end + 1), 0, 25.0)), fl)
        assert np.argwhere(fl.mask).tolist() == [[end, 0]]
        assert "off its smooth path by 25" in Spikes().describe(
            evidence(turn(smooth(), slice(end, end + 1), 0, 25.0)), end, 0
        )
    for amp in (0.5, 1.5):
        fl = Flags((90, 2))
        Spikes().apply(evidence(smooth(amp=amp)), fl)
        assert not fl.mask.any()
    # the extrapolation itself: a constant turn continues exactly; a pop reads as its angle
    steady = rot.rotvec_to_quat(np.linspace(0, 1.2, 10)[:, None, None] * np.array([[[0, 0, 1.0]]]))
    assert np.allclose(mdm_mod.end_spike_size(steady), 0.0, atol=1e-9)
    popped = turn(steady, slice(9, 10), 0, 30.0, axis=(1.0, 0.0, 0.0))
    size = np.degrees(mdm_mod.end_spike_size(popped))
    assert np.isclose(size[9, 0], 30.0) and np.allclose(size[:9], 0.0)
    assert not mdm_mod.end_spike_size(steady[:4]).any()  # too short to read a turn apart
    # a pop on a frame beside the end (or on two) is not blamed on the clean end frame
    for frames in (slice(1, 2), slice(2, 3), slice(1, 3), slice(7, 8), slice(8, 9)):
        end = 0 if frames.start < 5 else 9
        popped = turn(steady, frames, 0, 30.0, axis=(1.0, 0.0, 0.0))
        assert np.degrees(mdm_mod.end_spike_size(popped)[end, 0]) < 1.0


def test_frozen_joints() -> None:
    q = smooth()
    bad = q.copy()
    bad[30:50, 0] = q[30, 0]
    dig = rot.quat_angle(bad, q)
    fl = Flags((90, 2))
    FrozenJoints().apply(evidence(bad, dig=dig), fl)
    assert fl.mask[31:50, 0].all() and not fl.mask[:, 1].any()
    # frame 30 is the last value captured: the frames after it repeat it
    assert not fl.mask[30, 0] and not fl.mask[50:, 0].any()
    held = q.copy()  # a take that opens with a hold: no capture before it, frame 0 too
    held[:20, 0] = q[0, 0]
    fl = Flags((90, 2))
    FrozenJoints().apply(evidence(held, dig=rot.quat_angle(held, q)), fl)
    assert np.array_equal(np.flatnonzero(fl.mask[:, 0]), np.arange(20))
    # the KNN words hold still too: a pause, not a freeze, if the joint still trembles
    paused = bad.copy()
    paused[30:50:2, 0] = rot.quat_mul(q[30, 0], rot.rotvec_to_quat(np.array([1e-5, 0.0, 0.0])))
    fl = Flags((90, 2))
    FrozenJoints().apply(evidence(paused), fl)
    assert not fl.mask.any()
    fl = Flags((90, 2))  # held bit for bit: no data, whatever the KNN words do
    FrozenJoints().apply(evidence(bad), fl)
    assert fl.mask[32:50, 0].all()
    # held through the whole take, while the KNN words (a context that moves it) move away:
    # a joint this take does not animate, not a dropout
    whole = q.copy()
    whole[:, 0] = q[0, 0]
    ev = evidence(whole, dig=rot.quat_angle(whole, q))
    fl = Flags((90, 2))
    FrozenJoints().apply(ev, fl)
    assert not fl.mask.any()
    assert "the whole take, a joint this take does not animate" in FrozenJoints().describe(
        ev, 40, 0
    )
    whole[89, 0] = q[89, 0]  # moved on its last frame: held 0:89 inside a take that moves it
    fl = Flags((90, 2))
    FrozenJoints().apply(evidence(whole, dig=rot.quat_angle(whole, q)), fl)
    assert fl.mask[:89, 0].all()


def test_frozen_joints_say_why_a_held_joint_is_not_frozen() -> None:
    """--explain's frozen line names the criterion that decided: frozen, moving, too short,
    KNN words holding too, or a value the joint rests at elsewhere (parked)."""
    q = smooth(180)
    bad = q.copy()
    bad[30:50, 0] = q[30, 0]  # frozen 20 frames
    bad[100:105, 0] = q[100, 0]  # held 5 frames only
    dig = rot.quat_angle(bad, q)
    ev = evidence(bad, dig=dig)
    rule = FrozenJoints()
    assert rule.describe(ev, 40, 0).startswith("held bit for bit (one value repeated) frames 3")
    first = rule.describe(ev, 30, 0)  # not flagged: the value captured before the hold
    assert "last value captured before the hold" in first and "parked" not in first
    # the same held frames as a flagged frame of the run names
    assert first.split(" (")[0] == rule.describe(ev, 40, 0).split(" (")[0]
    assert "moving here" in rule.describe(ev, 70, 0)
    assert "shorter than 0.33 s" in rule.describe(ev, 102, 0)
    paused = bad.copy()
    paused[30:50:2, 0] = rot.quat_mul(q[30, 0], rot.rotvec_to_quat(np.array([1e-5, 0.0, 0.0])))
    assert "KNN words stay within" in rule.describe(evidence(paused), 40, 0)
    clamped = bad.copy()
    clamped[130:150, 0] = q[30, 0]  # it holds the same value, bit for bit, again later
    why = rule.describe(evidence(clamped, dig=rot.quat_angle(clamped, q)), 40, 0)
    assert "parks at exactly elsewhere" in why and "clamped" in why
    # held still but not exactly (a tremble under 0.3 deg/s), resting near that value later
    tremble = rot.rotvec_to_quat(np.array([np.radians(0.001), 0.0, 0.0]))
    parked = clamped.copy()
    parked[30:50:2, 0] = rot.quat_mul(q[30, 0], tremble)
    parked[130:150:2, 0] = rot.quat_mul(q[30, 0], tremble)
    why = rule.describe(evidence(parked, dig=rot.quat_angle(parked, q)), 40, 0)
    assert why.startswith("held still frames 3")
    assert "rests at elsewhere" in why and "parked" in why


def test_bridge_holes() -> None:
    """Holes of up to 0.05 s (2 frames at 30 fps) between two flagged runs of a joint are
    closed; a longer hole, a hole at the take's edge and other joints are not."""
    ev = evidence(smooth())
    fl = flagged(90, 2, [(10, 20, 0), (22, 30, 0), (40, 45, 0), (48, 50, 0), (0, 5, 1)])
    BridgeHoles().apply(ev, fl)
    assert fl.added["bridge"][20:22, 0].all() and fl.added["bridge"].sum() == 2
    assert fl.mask[10:30, 0].all() and not fl.mask[45:48, 0].any()
    fl = flagged(90, 2, [(10, 20, 0), (21, 30, 0)])
    BridgeHoles(max_seconds=0.0).apply(ev, fl)  # off
    assert not fl.added["bridge"].any()
    assert "between two flagged runs" in BridgeHoles().describe(ev, 20, 0)


def test_smooth_veto() -> None:
    fl = flagged(90, 2, [(30, 40, 0)])
    SmoothVeto().apply(evidence(smooth()), fl)
    assert not fl.mask.any() and fl.removed["smooth"][30:40, 0].all()
    fl = flagged(90, 2, [(30, 40, 0)])
    SmoothVeto().apply(evidence(turn(smooth(), slice(30, 40), 0, 30.0)), fl)
    assert fl.mask[30:40, 0].all()


def test_once_at_the_ends_veto() -> None:
    """A run reaching the take's start (end) whose edge inside the take does not jump is a
    movement performed once there (the arm raised into a wave), cleared; one whose edge jumps
    is an error cut off by the take, kept; as is a run in the middle of the take."""
    F = 300
    # the joint speeds up at frame 40 (the wave starts): a change of speed, no jump
    rv = np.zeros((F, 2, 3))
    t = np.arange(F, dtype=float)
    rv[:, 1, 0] = np.radians(np.where(t < 40, 0.5 * t, 20.0 + 6.0 * (t - 40)))
    wave = rot.rotvec_to_quat(rv)
    for cells, cleared in (
        ([(0, 40, 1)], True),  # the take's first movement
        ([(4, 40, 1)], True),  # within 0.2 s of the take's start
        ([(10, 40, 1)], False),  # 0.33 s in: the smooth veto's, not this one's
        ([(100, 150, 1)], False),  # the middle of the take
    ):
        fl = flagged(F, 2, cells)
        OnceAtTheEnds().apply(evidence(wave), fl)
        a, b, j = cells[0]
        assert (not fl.mask[a:b, j].any()) == cleared, cells
    # at the take's end the same, mirrored; an offset cut off there enters with a jump
    back = wave[::-1].copy()
    fl = flagged(F, 2, [(260, 300, 1)])
    OnceAtTheEnds().apply(evidence(back), fl)
    assert not fl.mask.any()
    fl = flagged(F, 2, [(260, 300, 1)])
    OnceAtTheEnds().apply(evidence(turn(back, slice(260, 300), 1, 30.0)), fl)
    assert fl.mask[260:300, 1].all()
    # an offset cut off by the take's start leaves with a jump at its edge: kept
    cut = turn(wave, slice(0, 40), 1, 30.0)
    ev = evidence(cut)
    assert ev.jump_peaks[40, 1]
    fl = flagged(F, 2, [(0, 40, 1)])
    OnceAtTheEnds().apply(ev, fl)
    assert fl.mask[0:40, 1].all()
    text = OnceAtTheEnds().describe(ev, 10, 1, fl)
    assert "an error cut off by the take" in text
    # frozen and cancelling-jumps cells are spared; the veto can be turned off
    fl = Flags((F, 2))
    m = np.zeros((F, 2), dtype=bool)
    m[0:40, 1] = True
    fl.flag("frozen", m)
    OnceAtTheEnds().apply(evidence(wave), fl)
    assert fl.mask[0:40, 1].all()
    fl = flagged(F, 2, [(0, 40, 1)])
    off = DetectConfig(once_end_seconds=0)
    OnceAtTheEnds.from_config(off).apply(evidence(wave, config=off), fl)
    assert fl.mask[0:40, 1].all()
    fl = flagged(F, 2, [(0, 40, 1)])
    OnceAtTheEnds().apply(evidence(wave), fl)
    text = OnceAtTheEnds().describe(evidence(wave), 10, 1, fl)
    assert "performed once at the take's start" in text


def test_recurring_veto() -> None:
    F = 120
    t = np.arange(F)
    bump = np.zeros(F)
    for c in (20, 60, 100):
        bump += np.radians(30.0) * np.exp(-0.5 * ((t - c) / 1.0) ** 2)
    rv = np.zeros((F, 1, 3))
    rv[:, 0, 0] = bump
    q = rot.rotvec_to_quat(rv)
    dig = np.zeros((F, 1))
    dig[59:62, 0] = np.radians(30.0)
    fl = flagged(F, 1, [(59, 62, 0)])
    RecurringVeto().apply(evidence(q, dig=dig), fl)
    assert not fl.mask.any()  # the performer's motif: the same pop three times
    rv[:, 0, 0] = np.radians(30.0) * np.exp(-0.5 * ((t - 60) / 1.0) ** 2)
    fl = flagged(F, 1, [(59, 62, 0)])
    RecurringVeto().apply(evidence(rot.rotvec_to_quat(rv), dig=dig), fl)
    assert fl.mask[59:62, 0].all()  # once only: an error


def parked_toe() -> np.ndarray:
    """(600, 1, 4) a toe clamped flat at a limit (-16.6 deg about z) in six rests (trembling
    in the file's last digit), leaving it between them: by a jump (frames 40-99: the clamp
    lets go with a 20 deg jump, the toe drifts back to 8 deg off, the clamp catches it in one
    step) or smoothly."""
    F = 600
    rv = np.zeros((F, 1, 3))
    rv[:, 0, 2] = np.radians(-16.6)
    t = np.arange(F)
    for a, b in ((140, 200), (240, 300), (340, 400), (440, 500)):  # smooth, as a live toe
        rv[a:b, 0, 2] += np.radians(25.0) * np.sin(np.pi * (t[a:b] - a) / (b - a)) ** 2
    rv[40:100, 0, 0] = np.radians(np.linspace(20.0, 8.0, 60))
    # the solver's last digit trembles (0.002 deg: still, at the limit within its tolerance)
    rv += np.radians(0.002) * np.random.default_rng(0).standard_normal(rv.shape)
    return rot.rotvec_to_quat(rv)


def test_limit_release_veto() -> None:
    q = parked_toe()
    ev = evidence(q)
    assert (40, 99) in ev.limit_excursions[0]
    fl = flagged(600, 1, [(40, 60, 0), (75, 100, 0)])
    LimitReleaseVeto().apply(ev, fl)
    assert not fl.mask.any()  # the clamp let go: measured motion, abrupt at the limit only
    fl = flagged(600, 1, [(40, 100, 0)])
    LimitReleaseVeto().apply(ev, fl)
    assert not fl.mask.any()  # the whole excursion, both of its jumps the clamp's
    # a run two cancelling jumps flagged was turned by one rotation: spared
    fl = Flags((600, 1))
    fl.flag("cancelling-jumps", np.arange(600)[:, None] // 20 == 2)
    LimitReleaseVeto().apply(ev, fl)
    assert fl.mask[40:60, 0].all()
    assert "off a limit" in LimitReleaseVeto().describe(ev, 50, 0)

    # an error on the parked frames holds its turned value: no release
    bad = turn(q, slice(210, 226), 0, 30.0, axis=(1.0, 0.0, 0.0))
    fl = flagged(600, 1, [(210, 226, 0)])
    LimitReleaseVeto().apply(evidence(bad), fl)
    assert fl.mask[210:226, 0].all()
    # an offset inside a smooth excursion enters and leaves with its own jumps
    bad = turn(q, slice(160, 176), 0, 30.0, axis=(1.0, 0.0, 0.0))
    fl = flagged(600, 1, [(160, 176, 0)])
    LimitReleaseVeto().apply(evidence(bad), fl)
    assert fl.mask[160:176, 0].all()
    # a foreign jump on one side only: the run is still reached from the other by motion
    one = turn(q, slice(85, 100), 0, 15.0, axis=(0.0, 1.0, 0.0))  # jumps at 85 (and 100)
    ev1 = evidence(one)
    assert ev1.jump_peaks[85, 0]
    fl = flagged(600, 1, [(45, 70, 0)])
    LimitReleaseVeto().apply(ev1, fl)
    assert not fl.mask.any()  # from the release at 40, no jump between
    assert "reached from the release" in LimitReleaseVeto().describe(ev1, 50, 0)
    # the same run with a foreign jump on each side (at 43 and at 85): kept
    two = turn(one, slice(43, 100), 0, 15.0, axis=(0.0, 0.0, 1.0))
    fl = flagged(600, 1, [(45, 70, 0)])
    LimitReleaseVeto().apply(evidence(two), fl)
    assert fl.mask[45:70, 0].all()
    assert "neither" in LimitReleaseVeto().describe(evidence(two), 50, 0)
    # a run holding a frozen cell is a hold, not motion: spared
    fl = Flags((600, 1))
    held = np.zeros((600, 1), dtype=bool)
    held[50:70] = True
    fl.flag("frozen", held)
    LimitReleaseVeto().apply(ev, fl)
    assert fl.mask[50:70, 0].all()
    # an excursion reaching the take's first or last frame has no release or catch in the take
    starts_off = evidence(q[50:]).limit_excursions[0]  # the take opens inside one
    ends_off = evidence(q[:250]).limit_excursions[0]  # and ends inside one
    assert starts_off[0][0] > 0 and (40, 99) in ends_off and ends_off[-1][1] < 240
    # a joint that never rests at one value twice has no limit
    live = smooth(600, 1)
    live[40:100, 0] = rot.quat_mul(live[40:100, 0], q[40:100, 0])
    fl = flagged(600, 1, [(40, 60, 0)])
    LimitReleaseVeto().apply(evidence(live), fl)
    assert fl.mask[40:60, 0].all()
    assert evidence(live).limit_excursions[0] == []
    # off: limit_holds=0
    fl = flagged(600, 1, [(40, 60, 0)])
    LimitReleaseVeto.from_config(DetectConfig(limit_holds=0)).apply(ev, fl)
    assert fl.mask[40:60, 0].all()


def test_noise_bursts() -> None:
    q = smooth()
    rng = np.random.default_rng(0)
    bad = q.copy()
    bad[30:45, 1] = rot.quat_mul(
        q[30:45, 1], rot.rotvec_to_quat(rng.normal(scale=np.radians(10), size=(15, 3)))
    )
    fl = Flags((90, 2))
    NoiseBursts().apply(evidence(bad), fl)
    assert fl.mask[:, 1].sum() >= 8 and not fl.mask[:28, 1].any() and not fl.mask[:, 0].any()
    fl = Flags((90, 2))
    NoiseBursts().apply(evidence(smooth(amp=1.5)), fl)
    assert not fl.mask.any()
    # --explain names the burst a flagged cell is in, whatever the cell's own roughness
    ev = evidence(bad)
    f = int(np.flatnonzero(ev.noise_bursts[:, 1])[0])
    assert NoiseBursts().describe(ev, f, 1).startswith(f"in a burst on frames {f}:")
    assert NoiseBursts().describe(ev, 70, 1).startswith("roughness ")
    # what a burst needs, as the rule counts it: roughness over one frame more than
    # noise_seconds rounds to (a run of N - 1 such frames is not a burst, one of N is)
    n = ev.frames(0.2, 2) + 1
    r, c = np.zeros((80, 1)), np.zeros((80, 1))
    r[10 : 10 + n - 1, 0] = r[40 : 40 + n, 0] = 1.0
    found = mdm_mod.noise_bursts(r, c, 0.5, ev.frames(0.2, 2))[:, 0]
    assert not found[:35].any() and found[40 : 40 + n].any()
    need = f"for {ev.frames(0.2, 2) + 1} frames or more ({(ev.frames(0.2, 2) + 1) / ev.fps:.2f} s)"
    assert need in NoiseBursts().describe(ev, 70, 1)
    # the frame before a burst is rough from the burst's first step, but not noisy itself
    assert f"beside the burst on frames {f}:" in NoiseBursts().describe(ev, f - 1, 1)
    assert "beside" not in NoiseBursts().describe(ev, f - 3, 1)


def test_noise_bursts_leave_a_fast_wave_about_one_axis() -> None:
    """An angry wave (a forearm swinging 60 deg at 5 Hz, 6 frames a cycle at 30 fps) is as
    rough as noise, but its jerk lies along one axis; noise turns the joint every way."""
    q = smooth()
    t = np.arange(30, 60)
    rv = np.zeros((30, 3))
    rv[:, 0] = np.radians(30.0) * np.sin(2 * np.pi * 5.0 * t / FPS)
    rv[:, 1] = np.radians(4.0) * np.sin(2 * np.pi * 5.0 * t / FPS + 0.5)  # not quite planar
    wave = q.copy()
    wave[30:60, 1] = rot.quat_mul(q[30:60, 1], rot.rotvec_to_quat(rv))
    assert mdm_mod.axis_share(wave[:, 1], 31, 58) > 0.95
    fl = Flags((90, 2))
    NoiseBursts().apply(evidence(wave), fl)
    assert not fl.mask.any()
    assert "fast wave or shake, not noise" in NoiseBursts().describe(evidence(wave), 45, 1)
    # without the axis test the wave is a burst
    off = evidence(wave, config=DetectConfig(noise_axis_share=0.0))
    assert off.noise_bursts[35:55, 1].any()
    # noise of the same size in every direction is kept (its share near 1/3 to 0.6)
    rng = np.random.default_rng(1)
    bad = q.copy()
    bad[30:60, 1] = rot.quat_mul(
        q[30:60, 1], rot.rotvec_to_quat(rng.normal(scale=np.radians(10), size=(30, 3)))
    )
    assert mdm_mod.axis_share(bad[:, 1], 31, 58) < 0.7
    fl = Flags((90, 2))
    NoiseBursts().apply(evidence(bad), fl)
    assert fl.mask[32:58, 1].all()


def test_wrong_way_hinges() -> None:
    F = 90
    flex = np.radians(40.0) * (1 + np.sin(np.arange(F) / 8.0)) / 2 + np.radians(5)
    flex[40:50] = np.radians(-40.0)
    rv = np.zeros((F, 1, 3))
    rv[:, 0, 0] = flex
    fl = Flags((F, 1))
    WrongWayHinges().apply(evidence(rot.rotvec_to_quat(rv), hinges=[0]), fl)
    assert fl.mask[40:50, 0].all() and fl.mask.sum() == 10
    fl = Flags((F, 1))  # not a hinge: never judged
    WrongWayHinges().apply(evidence(rot.rotvec_to_quat(rv)), fl)
    assert not fl.mask.any()
    rv[40:50, 0, 0] = np.radians(-5.0)  # a little past straight: within tolerance
    fl = Flags((F, 1))
    WrongWayHinges().apply(evidence(rot.rotvec_to_quat(rv), hinges=[0]), fl)
    assert not fl.mask.any()


def test_wrong_way_hinge_run_reaches_back_to_the_jump_that_entered_it() -> None:
    """An elbow bent 43 deg jumps to 10 deg past straight (a wrong-way bend of a well-bent
    limb) and goes on past -15 deg a frame later; it comes back within 15 deg of straight two
    frames before it jumps back to its own bend. The frames from the entry's jump on are
    flagged, and on to the frame before the exit's jump. Reached at the joint's own speed, the
    run is what it is; so it is with ``hinge_reach_seconds`` 0."""
    F = 90
    base = np.radians(40.0) * (1 + np.sin(np.arange(F) / 8.0)) / 2 + np.radians(5)
    flex = base.copy()
    flex[10:16] = np.radians(np.linspace(-10.0, -40.0, 6))
    flex[16:18] = np.radians(-40.0)
    flex[18:22] = np.radians(np.linspace(-30.0, -5.0, 4))
    rv = np.zeros((F, 1, 3))
    rv[:, 0, 0] = flex
    ev = evidence(rot.rotvec_to_quat(rv), hinges=[0])
    assert np.array_equal(np.flatnonzero(ev.wrong_way[:, 0]), np.r_[11:20])
    assert np.array_equal(np.flatnonzero(ev.big_jumps[:, 0]), [10, 22])
    rule = WrongWayHinges.from_config(ev.config)
    fl = Flags((F, 1))
    rule.apply(ev, fl)
    assert np.array_equal(np.flatnonzero(fl.mask[:, 0]), np.r_[10:22])
    assert "between a wrong-way or out-of-plane bend" in rule.describe(ev, 21, 0)
    assert "jump far above the joint's own" in rule.describe(ev, 10, 0)
    off = evidence(rot.rotvec_to_quat(rv), hinges=[0], config=DetectConfig(hinge_reach_seconds=0))
    fl = Flags((F, 1))
    WrongWayHinges.from_config(off.config).apply(off, fl)
    assert np.array_equal(np.flatnonzero(fl.mask[:, 0]), np.r_[11:20])
    flex = base.copy()  # the same bend reached smoothly: no jump to reach back to
    flex[4:16] = np.radians(np.linspace(np.degrees(base[4]), -40.0, 12))
    flex[16:20] = np.radians(-40.0)
    rv[:, 0, 0] = flex
    ev = evidence(rot.rotvec_to_quat(rv), hinges=[0])
    fl = Flags((F, 1))
    WrongWayHinges.from_config(ev.config).apply(ev, fl)
    assert np.array_equal(np.flatnonzero(fl.mask[:, 0]), np.flatnonzero(ev.wrong_way[:, 0]))
    assert fl.mask[12:20, 0].all() and not ev.big_jumps[:12, 0].any()


def test_reach_jumps_edges() -> None:
    """The latest jump within the width before a run, the earliest within it after; none
    farther; not the jump that leaves the run before, nor the one entering the run after
    (reviewer: a run reached back over the exit of the run before it)."""
    from mocapkit.clean.detect.hinges import reach_jumps

    runs = np.zeros((30, 1), dtype=bool)
    runs[10:13, 0] = True
    jumps = np.zeros((30, 1), dtype=bool)
    jumps[[5, 7, 8, 16, 17], 0] = True
    got = reach_jumps(runs, jumps, 3)[:, 0]
    assert np.array_equal(np.flatnonzero(got), np.r_[8:16])  # 8 (latest), 16 (earliest) - 1
    assert np.array_equal(np.flatnonzero(reach_jumps(runs, jumps, 1)[:, 0]), np.r_[10:13])
    assert np.array_equal(np.flatnonzero(reach_jumps(runs, jumps, 0)[:, 0]), np.r_[10:13])
    two = np.zeros((30, 1), dtype=bool)
    two[[2, 3, 4, 8, 9, 10], 0] = True  # runs 2..4 and 8..10, one jump at 5: the first's exit
    jumps = np.zeros((30, 1), dtype=bool)
    jumps[5, 0] = True
    assert np.array_equal(np.flatnonzero(reach_jumps(two, jumps, 4)[:, 0]), [2, 3, 4, 8, 9, 10])
    jumps[[5, 8], 0] = [False, True]  # the second's entry: the first does not reach on to it
    assert np.array_equal(np.flatnonzero(reach_jumps(two, jumps, 4)[:, 0]), [2, 3, 4, 8, 9, 10])
    runs[:] = False
    runs[0:2, 0] = True  # a run at the take's start, a jump at the end's reach
    jumps[:] = False
    jumps[[4, 29], 0] = True
    assert np.array_equal(np.flatnonzero(reach_jumps(runs, jumps, 2)[:, 0]), np.r_[0:4])


def test_extend_to_steps() -> None:
    bad = turn(smooth(), slice(40, 52), 1, 40.0)
    fl = flagged(90, 2, [(42, 50, 1)])
    ExtendToSteps().apply(evidence(bad), fl)
    assert fl.mask[40:52, 1].all() and fl.mask.sum() == 12
    assert fl.added["extend"].sum() == 4
    fl = flagged(90, 2, [(42, 50, 1)])
    ExtendToSteps().apply(evidence(smooth()), fl)
    assert fl.mask.sum() == 8 and not fl.added["extend"].any()


def test_run_pipeline_records_reasons_and_never_flags_unanalysed_joints() -> None:
    bad = turn(smooth(), slice(40, 42), 0, 50.0)
    ev = evidence(bad)
    fl = run_pipeline(ev, pipeline=ORIGINAL_ORDER)
    assert fl.mask[40:42, 0].all()
    assert fl.reasons_at(slice(40, 42), 0) == ["spike"]
    ev.analysed = np.array([False, True])
    assert not run_pipeline(ev, pipeline=ORIGINAL_ORDER).mask[:, 0].any()
    # --explain does not list verdicts that cannot apply (newcomer report); the JSON keeps them
    from mocapkit.clean.detect.pipeline import explain

    why = explain(ev, run_pipeline(ev), 0, 40)
    assert (
        str(why).splitlines()[1].startswith("  the joint was not analysed")
        and len(str(why).splitlines()) == 2
    )
    assert len(why.to_json()["rules"]) == len(why.lines) > 0


def test_noise_bursts_judge_each_joint_against_its_own_roughness() -> None:
    # a joint rough all along the take (a hand waved fast at 30 fps) is not a burst; a burst
    # far above its own roughness is
    q = smooth(F=150)
    rng = np.random.default_rng(1)
    rough = q.copy()
    rough[:, 1] = rot.quat_mul(
        q[:, 1], rot.rotvec_to_quat(rng.normal(scale=np.radians(6), size=(150, 3)))
    )
    ev = evidence(rough)
    assert np.degrees(np.median(ev.roughness[2:-2, 1])) > 1.5 * DetectConfig().noise_deg
    fl = Flags((150, 2))
    NoiseBursts.from_config(ev.config).apply(ev, fl)
    assert not fl.mask.any()
    fl = Flags((150, 2))  # the fixed level alone flags it all along
    NoiseBursts.from_config(DetectConfig(noise_ratio=0.0)).apply(
        evidence(rough, config=DetectConfig(noise_ratio=0.0)), fl
    )
    assert fl.mask[:, 1].mean() > 0.5
    burst = rough.copy()
    burst[60:80, 1] = rot.quat_mul(
        rough[60:80, 1], rot.rotvec_to_quat(rng.normal(scale=np.radians(40), size=(20, 3)))
    )
    fl = Flags((150, 2))
    NoiseBursts().apply(evidence(burst), fl)
    assert fl.mask[60:80, 1].sum() >= 8 and not fl.mask[:55, 1].any()


def test_smooth_veto_a_step_vouches_for_the_nearest_run_only() -> None:
    bad = turn(smooth(), slice(30, 40), 0, 30.0)  # an offset: steps at its two ends
    # an error's run and, just after its exit step, a run of natural motion: the exit step is
    # the error's, not the neighbour's
    fl = flagged(90, 2, [(30, 41, 0), (43, 60, 0)])
    SmoothVeto().apply(evidence(bad), fl)
    assert fl.mask[30:40, 0].all() and not fl.mask[43:60, 0].any()
    fl = flagged(90, 2, [(30, 41, 0), (43, 60, 0)])
    SmoothVeto(nearest=False).apply(evidence(bad), fl)  # any step near: both kept
    assert fl.mask[43:60, 0].all()
    # one run holding the error and natural motion after it: cut past the last step + pad
    fl = flagged(90, 2, [(30, 70, 0)])
    SmoothVeto().apply(evidence(bad), fl)
    pad = round(DetectConfig().abrupt_seconds * FPS)
    assert fl.mask[30:40, 0].all() and not fl.mask[42 + pad : 70, 0].any()
    fl = flagged(90, 2, [(30, 70, 0)])
    SmoothVeto(trim=False).apply(evidence(bad), fl)
    assert fl.mask[30:70, 0].all()
    # an error cut off by the take's end has no exit step: not trimmed there
    end = turn(smooth(), slice(70, 90), 0, 30.0)
    fl = flagged(90, 2, [(70, 90, 0)])
    SmoothVeto().apply(evidence(end), fl)
    assert fl.mask[70:90, 0].all()
    # ... but an error entered and left before the take's end holds the run between its steps:
    # the natural motion after its exit, run on to the last frame, is not vouched for
    flip = turn(smooth(), slice(50, 60), 0, 30.0)
    mdm = np.zeros((90, 2))
    mdm[50:60, 0], mdm[60:, 0] = 0.95, 0.7  # the error, then motion the take matches poorly
    fl = flagged(90, 2, [(50, 90, 0)])
    SmoothVeto().apply(evidence(flip, mdm=mdm), fl)
    assert fl.mask[50:60, 0].all() and not fl.mask[61 + pad + 1 :, 0].any()
    mdm[60:, 0] = 0.99  # the digression rises past the second step: the error goes on
    fl = flagged(90, 2, [(50, 90, 0)])
    SmoothVeto().apply(evidence(flip, mdm=mdm), fl)
    assert fl.mask[50:90, 0].all()


def test_explain_says_the_smooth_veto_spares_a_frozen_run() -> None:
    """A held joint enters its hold smoothly, so the smooth veto keeps frozen cells; --explain
    said only "not applied" there and "cleared it" on a moving cell with the same step size
    (newcomer report)."""
    from mocapkit.clean.detect.pipeline import explain

    q = smooth()
    bad = q.copy()
    bad[30:50, 0] = q[30, 0]
    ev = evidence(bad, dig=rot.quat_angle(bad, q))
    fl = run_pipeline(ev, pipeline=(FrozenJoints, SmoothVeto))
    assert fl.mask[40, 0]
    line = {
        name: verdict
        for name, verdict, _ in explain(ev, fl, 0, 40, (FrozenJoints, SmoothVeto)).lines
    }
    assert line["smooth"] == "veto: not applied (it spares frozen cells)"


def test_smooth_veto_gives_a_holds_exit_step_to_the_hold() -> None:
    """A dropout ends with a snap back to the live motion. The words overlapping the hold
    digress a word's length past it, so the MDM flags the frames after the snap, where the
    snap's step (and its half-size echo a frame on) vouched for them: that step is the hold's
    exit, and the run beyond it is cleared. A step one frame further on is not the hold's."""
    q = smooth()
    bad = q.copy()
    bad[30:50, 0] = q[29, 0]  # frames 30..49 repeat frame 29: a hold, the snap into 50
    mdm = np.zeros((90, 2))
    mdm[30:70, 0] = 0.9
    ev = evidence(bad, mdm=mdm, dig=rot.quat_angle(bad, q))
    fl = Flags((90, 2))
    FrozenJoints.from_config(ev.config).apply(ev, fl)
    assert fl.mask[30:50, 0].all() and not fl.mask[50:, 0].any()
    after = np.zeros((90, 2), dtype=bool)
    after[50:70, 0] = True
    fl.flag("mdm", after)
    SmoothVeto().apply(ev, fl)
    assert fl.mask[30:50, 0].all() and not fl.mask[50:, 0].any()
    # an offset entered three frames after the hold ends owns its own step: kept
    bad2 = turn(bad, slice(53, 70), 0, 30.0)
    ev2 = evidence(bad2, mdm=mdm, dig=rot.quat_angle(bad2, q))
    fl = Flags((90, 2))
    FrozenJoints.from_config(ev2.config).apply(ev2, fl)
    late = np.zeros((90, 2), dtype=bool)
    late[53:70, 0] = True
    fl.flag("mdm", late)
    SmoothVeto().apply(ev2, fl)
    assert fl.mask[53:68, 0].all()
    # nor is a step three frames after it: a run entered there keeps it
    bad3 = turn(bad, slice(52, 70), 0, 30.0)
    ev3 = evidence(bad3, mdm=mdm, dig=rot.quat_angle(bad3, q))
    fl = Flags((90, 2))
    FrozenJoints.from_config(ev3.config).apply(ev3, fl)
    late[52, 0] = True
    fl.flag("mdm", late)
    SmoothVeto().apply(ev3, fl)
    assert fl.mask[52:68, 0].all()


def test_smooth_veto_gives_a_turned_stretchs_exit_jump_to_it() -> None:
    """A knee flipped for a few frames (a stretch the cancelling-jumps rule flags) leaves the
    words digressing past its exit: the MDM flags the frames after it, next to the exit jump's
    echo. That jump is the flipped stretch's own, as a hold's snap is the hold's: the run
    after it owns no step and is cleared; flagged by the MDM only, it would keep the echo."""
    q = smooth()
    bad = turn(q, slice(30, 37), 0, 150.0)
    mdm = np.zeros((90, 2))
    mdm[30:37, 0] = 0.9
    mdm[38:60, 0] = 1.0
    ev = evidence(bad, mdm=mdm, dig=rot.quat_angle(bad, q))
    spill = np.zeros((90, 2), dtype=bool)
    spill[38:60, 0] = True
    for first, expect in (("cancelling-jumps", False), ("mdm", True)):
        fl = Flags((90, 2))
        flip = np.zeros((90, 2), dtype=bool)
        flip[30:37, 0] = True
        fl.flag(first, flip)
        fl.flag("mdm", spill)
        SmoothVeto().apply(ev, fl)
        assert fl.mask[30:37, 0].all()
        assert fl.mask[39:60, 0].any() == expect, first


def test_wrong_way_hinge_axis_is_the_takes_own() -> None:
    F = 90
    rv = np.zeros((F, 1, 3))
    rv[:, 0, 0] = np.radians(30.0) * (1 + np.sin(np.arange(F) / 8.0)) / 2 + np.radians(20)
    other = np.zeros((3 * F, 1, 3))  # another style's elbow bends far about -x
    other[:, 0, 0] = -np.radians(60.0) * (1 + np.sin(np.arange(3 * F) / 8.0)) / 2
    ctx = [rot.rotvec_to_quat(other)]
    q = rot.rotvec_to_quat(rv)
    fl = Flags((F, 1))
    WrongWayHinges().apply(evidence(q, hinges=[0], context_rotations=ctx), fl)
    assert not fl.mask.any()
    cfg = DetectConfig(hinge_context=True)  # the pooled axis turned the take's flexion over
    fl = Flags((F, 1))
    WrongWayHinges().apply(evidence(q, hinges=[0], context_rotations=ctx, config=cfg), fl)
    assert fl.mask.all()


def test_frozen_straight_hinge_is_parked() -> None:
    q = smooth()
    held = q.copy()
    held[10:80, 0] = np.array([1.0, 0.0, 0.0, 0.0])  # a knee locked straight, exactly
    dig = np.full((90, 2), np.radians(10.0))
    fl = Flags((90, 2))
    FrozenJoints().apply(evidence(held, dig=dig, hinges=[0]), fl)
    assert not fl.mask.any()
    fl = Flags((90, 2))  # not a hinge, or held bent: frozen
    FrozenJoints().apply(evidence(held, dig=dig), fl)
    assert fl.mask[12:78, 0].all()
    bent = turn(held, slice(10, 80), 0, 30.0, axis=(1.0, 0.0, 0.0))
    fl = Flags((90, 2))
    FrozenJoints().apply(evidence(bent, dig=dig, hinges=[0]), fl)
    assert fl.mask[12:78, 0].all()
    # the limb above held bit for bit too (joint 1 is the hinge's parent): one dropout of
    # both, the straight hinge included (CMU 03_02's opening); its parent moving: parked
    both = held.copy()
    both[10:80, 1] = both[10, 1]
    for parents, hinge_flagged in (([1, -1], True), ([-1, 0], False)):
        fl = Flags((90, 2))
        FrozenJoints().apply(evidence(both, dig=dig, hinges=[0], parents=parents), fl)
        assert fl.mask[12:78, 0].all() == hinge_flagged, parents
        assert fl.mask[12:78, 1].all()


def twisting_elbow(
    F: int = 300, bend_deg: float = 10.0, swing_deg: float = 2.0, twist_deg: float = 40.0
) -> np.ndarray:
    """(F, 1, 4) an elbow (the limb below along +y) bent ``bend_deg`` +- ``swing_deg`` about x
    while the forearm twists +-``twist_deg`` about its own bone (a wave by twisting the
    forearm)."""
    t = np.arange(F) / FPS
    zero = np.zeros(F)
    flex = np.radians(bend_deg + swing_deg * np.sin(t))
    bend = rot.rotvec_to_quat(np.stack([flex, zero, zero], axis=1))
    tw = np.radians(twist_deg) * np.sin(2 * np.pi * t / 1.5)
    twist = rot.rotvec_to_quat(np.stack([zero, tw, zero], axis=1))
    return rot.quat_mul(bend, twist)[:, None]


def wrong_bend(q: np.ndarray, frames: slice, deg: float = 40.0) -> np.ndarray:
    """``q`` with the limb below swung ``deg`` back about -x over ``frames``."""
    out = q.copy()
    back = rot.rotvec_to_quat(np.array([-np.radians(deg), 0.0, 0.0]))
    out[frames, 0] = rot.quat_mul(back, q[frames, 0])
    return out


BONE = np.array([[0.0, 1.0, 0.0]])


def hinge_flags(q: np.ndarray, **kw) -> np.ndarray:
    fl = Flags(q.shape[:2])
    WrongWayHinges().apply(evidence(q, hinges=[0], hinge_bones=BONE, **kw), fl)
    return fl.mask


def full_fit_flexion(q: np.ndarray) -> np.ndarray:
    """Degrees of flexion about the main axis of a hinge's *full* rotation vectors (twist
    included): the fit the rule no longer makes, to show what it would flag."""
    rv = rot.quat_to_rotvec(q[:, 0])
    axis = np.linalg.svd(rv, full_matrices=False)[2][0]
    return np.degrees(rv @ (axis if np.median(rv @ axis) > 0 else -axis))


def test_wrong_way_hinge_held_elbow_is_judged_on_its_bend_not_its_twist() -> None:
    q = twisting_elbow()  # bends 8-12 deg only: below hinge_bend_deg (20)
    assert not hinge_flags(q).any()  # must not fire: a twist is no bend
    assert (full_fit_flexion(q) < -15.0).sum() > 20  # a fit on the twist would have fired
    # must fire: bent 40 deg back while still twisting, flagged there and only there
    m = hinge_flags(wrong_bend(q, slice(60, 72)))
    assert m[60:72, 0].all() and m.sum() == 12


def test_wrong_way_hinge_bending_elbow_is_judged_on_its_bend_not_its_twist() -> None:
    # bends 10-40 deg while the forearm twists +-70 deg (a wave): the full rotations' main axis
    # leans to the twist, and twisting back read as a wrong-way bend
    q = twisting_elbow(bend_deg=25.0, swing_deg=15.0, twist_deg=70.0)
    assert (full_fit_flexion(q) < -15.0).sum() > 100
    assert not hinge_flags(q).any()  # must not fire
    m = hinge_flags(wrong_bend(q, slice(60, 72), 70.0))  # must fire: 30-60 deg past straight
    assert m[60:72, 0].all() and m.sum() == 12


def test_wrong_way_hinge_bending_elbow_fits_its_own_bend() -> None:
    # bends 10-70 deg: its own bend shows the axis, no context needed
    q = twisting_elbow(bend_deg=40.0, swing_deg=30.0)
    assert not hinge_flags(q).any()  # must not fire
    m = hinge_flags(wrong_bend(q, slice(60, 72), 90.0))  # must fire: 20-50 deg past straight
    assert m[60:72, 0].all() and m.sum() == 12
    ev = evidence(q, hinges=[0], hinge_bones=BONE)
    assert ev._bends(q[:, 0], BONE[0]) and not ev._bends(twisting_elbow()[:, 0], BONE[0])


def test_wrong_way_hinge_held_elbow_takes_the_contexts_axis() -> None:
    # a held elbow's bend axis is pooled with the context's: there it bends 10-70 deg about x
    q = twisting_elbow(bend_deg=4.0, swing_deg=1.0)
    ctx = [twisting_elbow(F=300, bend_deg=40.0, swing_deg=30.0)]
    m = hinge_flags(wrong_bend(q, slice(60, 72), 30.0), context_rotations=ctx)
    assert m[60:72, 0].all() and m.sum() == 12  # must fire
    assert not hinge_flags(q, context_rotations=ctx).any()  # must not fire


def out_of_plane(q: np.ndarray, frames: slice, deg: float) -> np.ndarray:
    """``q`` with the limb below (+y at rest) swung ``deg`` out of its bending plane (the plane
    across x) over ``frames``: turned towards +x about the axis across the limb and x."""
    out = q.copy()
    now = rot.quat_apply(q[frames, 0], np.broadcast_to(BONE[0], (len(q[frames]), 3)))
    across = np.cross(now, [1.0, 0.0, 0.0])
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    out[frames, 0] = rot.quat_mul(rot.rotvec_to_quat(np.radians(deg) * across), q[frames, 0])
    return out


def test_hinge_swung_out_of_its_plane_is_flagged() -> None:
    # a waving elbow (bends 10-70 deg, forearm twisting +-70 deg) keeps to its plane: no flag
    q = twisting_elbow(bend_deg=40.0, swing_deg=30.0, twist_deg=70.0)
    ev = evidence(q, hinges=[0], hinge_bones=BONE)
    assert np.nanmax(ev.hinge_off_plane[:, 0]) < 1e-9 and ev.planar_hinges[0]
    assert not hinge_flags(q).any()  # must not fire
    # must fire: swung 25 deg out of its plane for 12 frames, flexion still the right way
    bad = out_of_plane(q, slice(60, 72), 25.0)
    ev = evidence(bad, hinges=[0], hinge_bones=BONE)
    assert np.allclose(np.degrees(ev.hinge_off_plane[60:72, 0]), 25.0, atol=1e-6)
    assert (ev.hinge_flexion[60:72, 0] > 0).all() and ev.planar_hinges[0]
    m = hinge_flags(bad)
    assert m[60:72, 0].all() and m.sum() == 12
    assert "out of its plane, as no hinge bends" in WrongWayHinges().describe(ev, 65, 0)
    assert "out of its bending plane (flagged over 10)" in WrongWayHinges().describe(ev, 30, 0)
    # must not fire: 8 deg out of the plane is under hinge_plane_deg; and the switch turns it off
    assert not hinge_flags(out_of_plane(q, slice(60, 72), 8.0)).any()
    assert not hinge_flags(bad, config=DetectConfig(hinge_plane_deg=0)).any()
    # an error on a tenth of the take (30 frames, 20 deg off) does not switch the judging off
    # (reviewer: the least-squares axis leaned to it, and the take read off its plane)
    long = out_of_plane(q, slice(150, 180), 20.0)
    ev = evidence(long, hinges=[0], hinge_bones=BONE)
    assert ev.planar_hinges[0] and hinge_flags(long)[150:180, 0].all()


def test_hinge_plane_is_not_judged_on_a_ball_jointed_rig() -> None:
    """A rig whose elbow bends in planes tilted +-15 deg from one another over the take (a
    video-to-BVH or SMPL solve) is not judged by its plane: its own bends would read up to 15
    deg off it, and do fire once the gate is forced open (a hinge_planar_deg of 90); a 25-deg
    swing is not flagged either, and --explain says why. Its wrong-way bends still are."""
    t = np.arange(300) / FPS
    q = twisting_elbow(bend_deg=40.0, swing_deg=30.0)
    tilt = rot.rotvec_to_quat(
        np.stack([np.zeros(300), np.radians(15.0) * np.sin(2.3 * t), np.zeros(300)], axis=1)
    )
    loose = q.copy()
    loose[:, 0] = rot.quat_mul(tilt, q[:, 0])  # the bend axis turned about the limb's rest line
    ev = evidence(loose, hinges=[0], hinge_bones=BONE)
    assert not ev.planar_hinges[0]
    assert not hinge_flags(loose).any()  # must not fire
    assert hinge_flags(loose, config=DetectConfig(hinge_planar_deg=90.0)).any()  # gate open
    bad = out_of_plane(loose, slice(60, 72), 25.0)
    assert not hinge_flags(bad).any()
    ev = evidence(bad, hinges=[0], hinge_bones=BONE)
    assert "not judged" in WrongWayHinges().describe(ev, 65, 0)
    # must fire: the same rig's elbow bent the wrong way is still flagged
    m = hinge_flags(wrong_bend(loose, slice(150, 162), 110.0))
    assert m[150:162, 0].all()


def test_hinge_axis_is_fitted_on_the_frames_that_keep_to_its_plane() -> None:
    """An error's frames off the hinge's plane (a forearm swung 60 deg out of it for 40 of
    300 frames) tilt a least-squares axis, and the take's own frames then read off their plane
    (a flip on a Bandai-1 elbow: 9 deg, tuning half, byebye_happy); the axis is fitted again on
    the frames near the last fit's plane, and the clean frames read within a degree of it."""
    from mocapkit.clean.detect.evidence import _main_axis, bend_rotvecs

    q = twisting_elbow(bend_deg=75.0, swing_deg=45.0, twist_deg=40.0)
    bad = out_of_plane(q, slice(200, 240), 60.0)
    ev = evidence(bad, hinges=[0], hinge_bones=BONE)
    clean = np.r_[0:200, 240:300]
    assert np.degrees(ev.hinge_off_plane[clean, 0]).max() < 1.0
    assert ev.off_plane[200:240, 0].all() and not ev.off_plane[clean, 0].any()
    bends = bend_rotvecs(bad[:, 0], BONE[0])
    plain = _main_axis(bends, BONE[0], 0.0)
    assert np.degrees(np.arccos(abs(float(plain @ [1.0, 0.0, 0.0])))) > 2.5  # leans to them
    robust = _main_axis(bends, BONE[0], np.radians(10.0))
    assert abs(float(robust @ [1.0, 0.0, 0.0])) > np.cos(np.radians(0.5))


def test_bends_as_hinge_holds_a_repair_to_the_plane() -> None:
    q = twisting_elbow(bend_deg=40.0, swing_deg=30.0)
    ev = evidence(out_of_plane(q, slice(60, 72), 25.0), hinges=[0], hinge_bones=BONE)
    assert ev.bends_as_hinge(0, q[:, 0])
    assert not ev.bends_as_hinge(0, ev.rotations[60:72, 0])  # off the plane
    assert not ev.bends_as_hinge(0, wrong_bend(q, slice(0, 300), 90.0)[:, 0])  # wrong way


def test_bend_rotvecs_leave_the_twist_out() -> None:
    from mocapkit.clean.detect.evidence import bend_rotvecs

    q = twisting_elbow()
    b = bend_rotvecs(q[:, 0], BONE[0])
    assert np.allclose(b[:, 1], 0.0, atol=1e-12)  # nothing about the bone itself
    ang = np.degrees(np.linalg.norm(b, axis=1))
    assert ang.min() > 7.9 and ang.max() < 12.1  # the angle between the two bones
    full = bend_rotvecs(q[:, 0], None)
    assert np.degrees(np.linalg.norm(full, axis=1)).max() > 35.0


def test_wrong_way_hinge_limb_folded_past_reach_is_flagged() -> None:
    # an elbow bending 10-140 deg (a deep, natural bend): nothing is wrong
    t = np.arange(300) / FPS
    flex = np.radians(75.0 + 65.0 * np.sin(2 * np.pi * t / 2.0))
    rv = np.stack([flex, np.zeros(300), np.zeros(300)], axis=1)
    q = rot.rotvec_to_quat(rv)[:, None]
    assert not hinge_flags(q).any()  # must not fire
    # must fire: the forearm folded back onto the upper arm (178 deg, past any elbow's reach,
    # where the rotation vector wraps) for 10 frames; the rest of the take is still judged
    bad = q.copy()
    bad[100:110, 0] = rot.rotvec_to_quat(np.array([-np.radians(178.0), 0.0, 0.0]))
    m = hinge_flags(bad)
    assert m[100:110, 0].all() and m.sum() == 10
    ev = evidence(bad, hinges=[0], hinge_bones=BONE)
    assert "folded back 178" in WrongWayHinges().describe(ev, 105, 0)
    assert "flexion" in WrongWayHinges().describe(ev, 50, 0)
    m = hinge_flags(wrong_bend(bad, slice(200, 212), 170.0))  # and a wrong bend elsewhere
    assert m[100:110, 0].all() and m[200:212, 0].all() and m.sum() == 22


def test_context_of_another_rig_is_named_with_the_difference() -> None:
    from mocapkit import datasets

    walk = datasets.procedural_motion("walk", 2.0, seed=1).motion
    other = walk.copy()
    names = list(other.skeleton.names)
    names[5] = "Noggin"
    other.skeleton = dataclasses.replace(other.skeleton, names=tuple(names))
    with pytest.raises(ValueError, match=r"ctx\.bvh: a different skeleton .*missing joints"):
        SelfSimilarityCleaner().fit(walk, [other], names=["ctx.bvh"])


class _FlagCell:
    """Test rules: flag (or, as a veto, clear) cell (5, 0)."""

    veto = False
    signal = False

    @classmethod
    def from_config(cls, config):
        return cls()

    def apply(self, ev, flags):
        cells = np.zeros(ev.shape, dtype=bool)
        cells[5, 0] = True
        (flags.veto if self.veto else flags.flag)(self.name, cells)

    def describe(self, ev, frame, joint, flags=None):
        return "test"


class _First(_FlagCell):
    name = "first"


class _Clear(_FlagCell):
    name = "clear"
    veto = True


class _Again(_FlagCell):
    name = "again"


def test_a_cell_cleared_and_flagged_again_is_the_later_rules() -> None:
    """A veto clears a cell an earlier rule flagged, a later rule flags it again: the cell's
    reasons (report, heat map, --explain) are the later rule's alone, and --explain says a
    veto cleared the earlier flag, not that the flagged cell was cleared."""
    from mocapkit.clean.detect import explain

    ev = evidence(smooth(20))
    fl = run_pipeline(ev, pipeline=(_First, _Clear, _Again))
    assert fl.mask[5, 0] and fl.reasons_at(slice(5, 6), 0) == ["again"]
    assert fl.primary(["first", "again"])[5, 0] == 1
    assert fl.judged["clear"][5, 0]  # the decision the veto judged
    ex = explain(ev, fl, 0, 5, pipeline=(_First, _Clear, _Again))
    assert ex.flagged and ex.reasons == ["again"] and ex.cleared_by == ["clear"]
    assert "FLAGGED by again (after clear cleared the earlier rules' flags)" in str(ex)
    # the flagged segment holding the cell, as the report gives it (frames 5 to 5)
    assert ex.segment == (5, 6) and "; segment 5:6" in str(ex)
    assert ex.to_json()["segment"] == [5, 6]
    assert explain(ev, fl, 0, 9, pipeline=(_First, _Clear, _Again)).segment is None
    # a rule that flags again after the veto (two rules of one name), a veto that runs twice
    again = Flags((20, 2))
    cell = np.zeros((20, 2), dtype=bool)
    cell[5, 0] = True
    again.flag("a", cell)
    again.veto("v", cell)
    again.flag("a", cell)
    assert again.mask[5, 0] and again.reasons_at(slice(5, 6), 0) == ["a"]
    twice = Flags((20, 2))
    twice.flag("a", cell)
    twice.veto("v", cell)
    twice.flag("b", cell)
    twice.veto("v", cell)
    assert not twice.mask[5, 0] and not twice.live("b").any() and not twice.live("a").any()
    twice.flag("c", cell)
    assert twice.reasons_at(slice(5, 6), 0) == ["c"]
    # without the later rule the veto's clearing stands
    fl = run_pipeline(ev, pipeline=(_First, _Clear))
    ex = explain(ev, fl, 0, 5, pipeline=(_First, _Clear))
    assert not ex.flagged and "not flagged (cleared by clear)" in str(ex)


def test_explain_names_the_run_a_veto_judged_and_a_spike_left_to_another_rule() -> None:
    """The recurring veto's line names the flagged run it looked at (not the digressing run,
    which a spike's frames need not be); a spike over its bar next to a run another rule
    flagged first says why the spike rule left it."""
    q = turn(smooth(90), slice(40, 41), 0, 50.0)
    ev = evidence(q)
    fl = Flags((90, 2))
    fl.flag("other", np.zeros((90, 2), dtype=bool))
    cells = np.zeros((90, 2), dtype=bool)
    cells[40, 0] = True
    fl.flag("spike-ish", cells)
    RecurringVeto().apply(ev, fl)
    text = RecurringVeto().describe(ev, 40, 0, fl)
    assert "closest repeat of run 40:41" in text
    assert "nothing to match" in RecurringVeto().describe(ev, 10, 0, fl)
    # a spike beside a run flagged before the spike rule ran
    near = Flags((90, 2))
    run = np.zeros((90, 2), dtype=bool)
    run[41:45, 0] = True
    near.flag("mdm", run)
    Spikes().apply(ev, near)
    assert not near.added["spike"][40, 0]
    assert "left to that rule" in Spikes().describe(ev, 40, 0, near)
    alone = run_pipeline(ev, pipeline=(Spikes,))
    assert alone.added["spike"][40, 0]
    assert "left to that rule" not in Spikes().describe(ev, 40, 0, alone)
