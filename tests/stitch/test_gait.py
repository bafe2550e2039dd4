"""The clip's own gait carried through a gap (mocapkit.stitch.gait) and its use by inbetween."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from testsupport import load_sibling

from mocapkit import datasets
from mocapkit.core.kinematics import forward_kinematics
from mocapkit.core.motion import Motion
from mocapkit.edit.mirror import mirror
from mocapkit.features import ground_root_on_path as on_path
from mocapkit.features import heading_angles
from mocapkit.stitch.gait import (
    BodyLocal,
    _positions,
    body_local,
    gait_continued,
    half_periods,
    predicted,
    stance_kept,
    with_gait,
)
from mocapkit.stitch.inbetween import DEFAULT_CONFIG, inbetween

naive = load_sibling(__file__, "inbetween_naive")
motions = load_sibling(__file__, "motions")


def _walk(seed: int = 3, seconds: float = 3.0) -> Motion:
    return datasets.procedural_motion("walk", seconds, seed=seed).motion


def _periodic_clip(h: int, halves: int) -> Motion:
    """A clip whose body-local pose repeats mirrored every ``h`` frames exactly: a walk's ``h``
    frames, its heading taken out, then their mirror image, and so on, standing at the origin."""
    walk = _walk()
    bl = body_local(walk[30 : 30 + h], "Y")
    base = Motion(walk.skeleton, bl.rotations, bl.heights[:, None] * [0.0, 1.0, 0.0],
                  walk.frame_time)  # fmt: skip
    mir = mirror(base, "Y").motion
    mir = Motion(walk.skeleton, mir.rotations, mir.root_positions, walk.frame_time)
    parts = [base if k % 2 == 0 else mir for k in range(halves)]
    return Motion(walk.skeleton, np.concatenate([p.rotations for p in parts]),
                  np.concatenate([p.root_positions for p in parts]), walk.frame_time)  # fmt: skip


# a past holding twice the longest half period tried (its own mirror pairs read the period
# too), one longer than the half cycle, and one shorter
@pytest.mark.parametrize("a", [40, 20, 5])
def test_a_mirror_periodic_clip_is_carried_on_exactly(a):
    """Where the body-local pose half a cycle on is the mirror image of the pose now, the
    prediction finds the half period from the first future frame and gives the gap's poses
    back (joint positions, so that a bone's encoding does not matter); with fewer past frames
    than the half cycle, the frames it bridges are the guess, the others are exact."""
    h = 9
    clip = _periodic_clip(h, 8)
    b = a + 25
    cont = gait_continued(clip, a, b, "Y", (0.2, 0.5), 0.5)
    assert cont is not None
    assert cont.half_period_s == pytest.approx(h * clip.frame_time)
    got = _positions(clip, cont.poses, "Y")
    want = _positions(clip, body_local(clip[a:b], "Y"), "Y")
    err = np.linalg.norm(got - want, axis=-1).max(axis=-1)  # per frame, metres
    known = cont.known > 0.999
    if a >= h:
        assert known.all()
    else:  # 5 past frames of a 9-frame half cycle: 4 of every 9 frames bridged
        assert 0.3 < 1 - known.mean() < 0.6
    assert err[known].max() < 1e-6
    # and a bridged frame is a guess, not a copy (the test can tell them apart)
    if not known.all():
        assert err[~known].max() > 1e-3


def test_predicted_matches_its_reference():
    """The vectorised prediction against a frame-by-frame loop (tests/stitch/inbetween_naive)."""
    rng = np.random.default_rng(0)
    walk = _walk()
    for P, h in ((10, 16), (10, 8), (12, 12), (3, 20)):
        piece = walk[40 - P : 40]
        past = body_local(piece, "Y")
        mir = body_local(mirror(piece, "Y").motion, "Y")
        frames = np.arange(-1, 31)
        got, have = predicted(past, mir, h, frames)
        want, want_have = naive.gait_predicted_reference(past, mir, h, frames)
        np.testing.assert_array_equal(have, want_have)
        dot = np.abs(np.sum(got.rotations * want.rotations, -1))
        assert dot.min() > 1 - 1e-9
        np.testing.assert_allclose(got.heights, want.heights, atol=1e-9)
        np.testing.assert_allclose(got.translations, want.translations, atol=1e-9)
        assert rng is not None


@settings(max_examples=25, deadline=None)
@given(st.floats(0.01, 0.05), st.floats(0.3, 1.5))
def test_half_periods_cover_the_range(frame_time, hi):
    hs = half_periods(frame_time, (0.25, hi))
    assert hs[0] >= 2 and np.all(np.diff(hs) > 0) and len(hs) <= 32
    assert hs[0] * frame_time == pytest.approx(0.25, abs=frame_time)
    assert hs[-1] * frame_time <= hi + frame_time


@settings(max_examples=20, deadline=None)
@given(st.floats(0.0, 1.0), st.integers(0, 40))
def test_with_gait_keeps_the_fills_ground_path_and_heading(share, start):
    """Only the body-local pose moves: the fill's ground path and heading stay; share 0 is the
    fill itself, share 1 the gait's pose on the fill's path."""
    walk = on_path(motions.with_ground_root(_walk(5)), "Y")  # as inbetween hands it the fill
    other = on_path(motions.with_ground_root(_walk(8)), "Y")
    fill = walk[start : start + 20]
    gait = body_local(other[10:30], "Y")
    out = with_gait(fill, gait, share, "Y")
    P, Q = forward_kinematics(out)[0], forward_kinematics(fill)[0]
    pelvis = 1
    np.testing.assert_allclose(P[:, pelvis, [0, 2]], Q[:, pelvis, [0, 2]], atol=1e-6)
    dh = np.angle(np.exp(1j * (heading_angles(out, "Y") - heading_angles(fill, "Y"))))
    # (a blend of two poses facing forward faces forward to within its hips' and shoulders'
    # disagreement: 1e-4 rad here)
    assert np.abs(dh).max() < 1e-3
    if share == 0.0:
        np.testing.assert_allclose(P, Q, atol=1e-9)
    if share == 1.0:
        np.testing.assert_allclose(_positions(fill, body_local(out, "Y"), "Y"),
                                   _positions(fill, gait, "Y"), atol=1e-6)  # fmt: skip


def test_stance_kept_puts_a_planted_foot_back():
    """A foot the fill plants stays where the fill has it after the gait's pose is blended in
    (a planted foot blended with a swinging one slides); a swinging foot is not lowered."""
    from mocapkit import ik
    from mocapkit.features import foot_contacts

    walk = on_path(motions.with_ground_root(_walk(5)), "Y")
    other = on_path(motions.with_ground_root(_walk(8)), "Y")
    a, b = 30, 60
    fill = walk[a:b]
    mixed = with_gait(fill, body_local(other[17:47], "Y"), 0.5, "Y")
    out = stance_kept(walk, a, b, fill, mixed, "Y", (15, 15))
    effs = [e for c in ik.leg_chains(fill) for e in c.effectors]
    planted = foot_contacts(walk, feet=effs, up="Y").contacts[a:b]
    assert planted.any() and (~planted).any()
    own = forward_kinematics(fill)[0][:, effs]
    moved = np.linalg.norm(forward_kinematics(mixed)[0][:, effs] - own, axis=-1)
    kept = np.linalg.norm(forward_kinematics(out)[0][:, effs] - own, axis=-1)
    assert moved[planted].mean() > 0.01  # the blend moved the planted feet ...
    assert kept[planted].mean() < 0.2 * moved[planted].mean()  # ... and they are put back
    def lowered(m):  # how far the swinging feet went nearer the ground, mean (m)
        return np.maximum(own - forward_kinematics(m)[0][:, effs], 0.0)[..., 1][~planted].mean()

    # (not to the millimetre: the solve reaches a toe's aim only as near as the ankle allows)
    assert lowered(out) < 0.3 * lowered(mixed) and lowered(mixed) > 0.005


@pytest.fixture(scope="module")
def library():
    return [
        motions.with_ground_root(datasets.procedural_motion(k, 6.0, seed=s).motion)
        for k, s in (("walk", 1), ("walk", 2), ("run", 1), ("idle", 3))
    ]


def test_inbetween_carries_a_walks_own_gait_and_says_so(library):
    walk = motions.with_ground_root(_walk(11, 5.0))
    a, b = 60, 90
    res = inbetween(walk, (a, b), library, up="Y", method="library")
    off = inbetween(walk, (a, b), library, up="Y", method="library",
                    config=replace(DEFAULT_CONFIG, gait_share=0.0))  # fmt: skip
    assert res.gait_share == DEFAULT_CONFIG.gait_share and off.gait_share == 0.0
    assert 0.25 <= res.gait_half_period_s <= 0.8
    # the context is the clip's own, channel for channel; the fill differs from the library's
    np.testing.assert_array_equal(res.motion.rotations[:a], walk.rotations[:a])
    np.testing.assert_array_equal(res.motion.rotations[b:], walk.rotations[b:])
    assert not np.allclose(res.motion.rotations[a:b], off.motion.rotations[a:b])
    js = res.to_json()
    assert js["gait_share"] == DEFAULT_CONFIG.gait_share
    assert js["gait_half_period_s"] == pytest.approx(res.gait_half_period_s)
    params = res.provenance("x.bvh").to_json()["parameters"]
    assert params["gait_share"] == DEFAULT_CONFIG.gait_share
    assert off.to_json()["gait_half_period_s"] is None


def test_a_standing_clip_and_a_short_gap_take_nothing_from_the_gait(library):
    """A standing clip's gestures are not periodic nor symmetric (a wave with one hand
    mirrors into the other), and a gap shorter than the shortest half cycle is carried by its
    context: both are filled as with the gait share off."""
    idle = motions.with_ground_root(datasets.procedural_motion("idle", 5.0, seed=4).motion)
    walk = motions.with_ground_root(_walk(11, 5.0))
    off = replace(DEFAULT_CONFIG, gait_share=0.0)
    for clip, gap in ((idle, (60, 90)), (walk, (60, 66))):
        res = inbetween(clip, gap, library, up="Y", method="library")
        ref = inbetween(clip, gap, library, up="Y", method="library", config=off)
        assert res.gait_share == 0.0
        np.testing.assert_array_equal(res.motion.rotations, ref.motion.rotations)


def test_gait_continued_needs_both_sides():
    walk = _walk()
    assert gait_continued(walk, 0, 10, "Y", (0.25, 0.8), 0.5) is None
    assert gait_continued(walk, 80, walk.num_frames, "Y", (0.25, 0.8), 0.5) is None
    assert isinstance(gait_continued(walk, 1, 20, "Y", (0.25, 0.8), 0.5).poses, BodyLocal)


def test_a_rig_that_cannot_be_mirrored_carries_no_gait():
    """A joint on one side with no counterpart (a sword in the left hand): the mirror image is
    unknown, so nothing is carried on, and the gap is filled from the library alone."""
    from mocapkit.core.skeleton import Skeleton

    walk = _walk(11, 5.0)
    sk = walk.skeleton
    hand = sk.names.index("LeftHand")
    sword = Skeleton(
        (*sk.names, "LeftSword"), np.r_[sk.parents, hand], np.r_[sk.offsets, [[0.0, -0.3, 0.0]]],
        (*sk.channels, ("Zrotation", "Xrotation", "Yrotation")), sk.end_site_parents,
        sk.end_site_offsets, sk.end_site_names, sk.metres_per_unit,
    )  # fmt: skip
    q = np.concatenate([walk.rotations, np.tile([1.0, 0, 0, 0], (walk.num_frames, 1, 1))], 1)
    armed = Motion(sword, q, walk.root_positions, walk.frame_time)
    with pytest.raises(ValueError, match="counterpart"):
        mirror(armed, "Y")
    assert gait_continued(armed, 60, 90, "Y", (0.25, 0.8), 0.5) is None
    assert gait_continued(walk, 60, 90, "Y", (0.25, 0.8), 0.5) is not None  # unarmed
    res = inbetween(armed, (60, 90), None, up="Y", method="library")  # from its own frames
    assert res.gait_share == 0.0 and np.isfinite(res.motion.rotations).all()


def test_the_command_says_what_share_of_the_fill_is_the_clips_gait(library, tmp_path):
    import json

    from click.testing import CliRunner

    from mocapkit.cli import main
    from mocapkit.io import write_motion

    walk = motions.with_ground_root(_walk(11, 5.0))
    write_motion(walk, tmp_path / "walk.bvh")
    for i, m in enumerate(library[:3]):
        write_motion(m, tmp_path / f"l{i}.bvh")
    args = ["inbetween", tmp_path / "walk.bvh", "--gap", "60:90", "--out", tmp_path / "o.bvh",
            "--json", tmp_path / "o.json"]  # fmt: skip
    args += [x for i in range(3) for x in ("--library", tmp_path / f"l{i}.bvh")]
    res = CliRunner().invoke(main, [str(a) for a in args])
    assert res.exit_code == 0, res.output
    js = json.loads((tmp_path / "o.json").read_text())
    assert js["gait_share"] > 0
    line = next(x for x in res.stdout.splitlines() if "the clip's own gait" in x)
    pct = round(100 * js["gait_share"])
    assert (f"{pct}% of the fill's pose" in line) if pct else ("under 1%" in line)
    assert f"fitted: {js['gait_half_period_s']:.2f} s" in line and "frame 90" in line
    side = json.loads((tmp_path / "o.bvh.provenance.json").read_text())
    assert side["parameters"]["gait_share"] == js["gait_share"]


def test_the_miss_reported_is_the_predictions_at_b_alone():
    """Where the past's mirror pairs judge the half period too, the miss the share is set by
    is still the prediction's own at frame B (reviewer: the pairs' cost was returned, and the
    gait's share halved when a frame more of past switched them on)."""
    walk = _walk(5, 4.0)
    hs = half_periods(walk.frame_time, (0.25, 0.8))
    a = 2 * int(hs[-1]) + 5
    b = a + 30
    cont = gait_continued(walk, a, b, "Y", (0.25, 0.8), 0.5)
    P = 2 * int(hs[-1])
    piece = walk[a - P : a]
    past, mir = body_local(piece, "Y"), body_local(mirror(piece, "Y").motion, "Y")
    target = _positions(walk, body_local(walk[b : b + 1], "Y"), "Y")
    preds = [predicted(past, mir, int(h), np.array([b - a]))[0] for h in hs]
    cb = np.array([np.sum((_positions(walk, p, "Y") - target) ** 2) for p in preds])
    pp, pm = _positions(walk, past, "Y"), _positions(walk, mir, "Y")
    pairs = np.array([np.sum((pm[: P - h] - pp[h:]) ** 2, axis=(-1, -2)).mean() for h in hs])
    assert pairs.min() > 1e-4  # the pairs count here
    c = cb + pairs
    assert cont.miss_m2 == pytest.approx(cb[np.argmin(c)], rel=1e-9)  # at the best h
    assert cont.miss_m2 < c.min()  # not the pairs' cost


@settings(max_examples=40, deadline=None)
@given(st.lists(st.booleans(), min_size=1, max_size=30), st.integers(1, 6))
def test_spread_is_the_largest_tent_about_the_set_frames(flags, width):
    """The stance hold's fade (:func:`mocapkit.stitch.gait._spread`) against its definition."""
    from mocapkit.stitch.gait import _spread

    f = np.array(flags)[:, None]
    g = len(flags)
    tent = np.clip(1.0 - np.abs(np.arange(g)[:, None] - np.arange(g)[None]) / (width + 1.0), 0, 1)
    want = np.max(tent * f[:, 0][None], axis=1, initial=0.0)[:, None]
    np.testing.assert_allclose(_spread(f, width), want, atol=1e-12)
