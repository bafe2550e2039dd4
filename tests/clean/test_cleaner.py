"""The estimator end to end on procedural takes: detection, MDM, repair, two-stage, baselines."""

from __future__ import annotations

import numpy as np
import pytest
from testsupport import load_sibling

from mocapkit import datasets
from mocapkit.clean import (
    RotationBaseline,
    SelfSimilarityCleaner,
    inject,
    movement_digression_map,
    repair_cells,
)
from mocapkit.clean.evaluate import corrupt, repair_error, unit_matrix
from mocapkit.clean.repair import dilate
from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion
from mocapkit.core.runs import true_runs
from mocapkit.core.skeleton import Skeleton

with_ground_root = load_sibling(__file__.replace("clean", "stitch"), "motions").with_ground_root


@pytest.fixture(scope="module")
def takes() -> tuple[Motion, Motion]:
    a = datasets.procedural_motion("walk", seconds=6.0, seed=5).motion
    b = datasets.procedural_motion("walk", seconds=6.0, seed=6).motion
    return a, b


@pytest.fixture(scope="module")
def corrupted(takes):
    walk, _ = takes
    rng = np.random.default_rng(1)
    names = list(walk.skeleton.names)
    cur = walk
    truth = np.zeros((walk.num_frames, walk.num_joints), dtype=bool)
    for kind, joint, start in (("spike", "LeftForeArm", 40), ("offset", "RightUpLeg", 100)):
        inj = inject(cur, kind, names.index(joint), rng, start=start)
        cur = inj.motion
        truth[inj.frames, inj.joint] = True
    return cur, truth


@pytest.fixture(scope="module")
def fitted(takes, corrupted):
    _, ctx = takes
    cur, _ = corrupted
    return SelfSimilarityCleaner().fit(cur, [ctx])


def test_mdm_flags_the_injected_errors(fitted, corrupted, takes) -> None:
    cur, truth = corrupted
    mdm = fitted.scores()
    assert mdm.shape == (cur.num_frames, cur.num_joints)
    assert mdm.min() >= 0.0 and mdm.max() <= 1.0
    # every injected error is flagged on its joint
    for j in np.flatnonzero(truth.any(axis=0)):
        assert mdm[truth[:, j], j].max() > 0.9
    # few false alarms elsewhere
    t = unit_matrix(truth, cur.fps)
    f = unit_matrix(fitted.mask(), cur.fps)
    assert (t & f).sum() == t.sum()
    assert (f & ~t).sum() <= 0.5 * t.sum()
    segs = fitted.segments()
    assert {s.joint for s in segs} >= {"LeftForeArm", "RightUpLeg"}
    for s in segs:
        assert 0 <= s.start <= s.end < cur.num_frames and 0.5 < s.peak <= 1.0


def test_repair_touches_only_written_cells_and_fixes_errors(fitted, corrupted, takes) -> None:
    cur, truth = corrupted
    walk, _ = takes
    res = fitted.repair()
    plain = fitted.repair(foot_lock=False)
    assert np.array_equal(plain.written, dilate(plain.flagged, plain.margin))
    # the foot lock adds leg cells (hip, knee, ankle, toe) around planted feet, nothing else
    assert not (dilate(res.flagged, res.margin) & ~res.written).any()
    extra = np.flatnonzero((res.written & ~plain.written).any(axis=0))
    names = cur.skeleton.names
    assert all(any(k in names[j] for k in ("UpLeg", "Leg", "Foot", "Toe")) for j in extra)
    assert np.array_equal(res.flagged, fitted.mask())
    # bit-identical outside the written cells; root translation untouched
    assert np.array_equal(res.motion.rotations[~res.written], cur.rotations[~res.written])
    assert np.array_equal(res.motion.root_positions, cur.root_positions)
    bad = truth.any(axis=1)
    before = repair_error(walk, cur)[bad].mean()
    after = repair_error(walk, res.motion)[bad].mean()
    assert after < 0.2 * before
    assert np.allclose(np.linalg.norm(res.motion.rotations, axis=-1), 1.0)


def test_repair_margin_semantics() -> None:
    m = datasets.procedural_motion("idle", seconds=2.0, seed=0).motion
    F, J = m.num_frames, m.num_joints
    flagged = np.zeros((F, J), dtype=bool)
    flagged[20:25, 3] = True
    rep = rot.quat_mul(m.rotations, rot.rotvec_to_quat(np.array([0.0, 0.0, 0.5])))
    res = repair_cells(m, flagged, rep, margin=3)
    changed = np.any(res.motion.rotations != m.rotations, axis=-1)
    assert changed[:, 3].any()
    assert not changed[:17, 3].any() and not changed[28:, 3].any()
    assert not changed[:, [j for j in range(J) if j != 3]].any()
    assert true_runs(res.written[:, 3]) == [(17, 27)]
    # the flagged cells moved towards the replacement, the margins only partly
    ang_mid = rot.quat_angle(res.motion.rotations[22, 3], m.rotations[22, 3])
    ang_edge = rot.quat_angle(res.motion.rotations[17, 3], m.rotations[17, 3])
    assert ang_mid > 0.3 and ang_edge < ang_mid
    with pytest.raises(ValueError):
        repair_cells(m, flagged[:-1], rep)


def test_repair_keeps_an_exact_replacement_but_near_its_seams() -> None:
    """A joint swinging fast (120 fps, +-60 deg at 3 Hz), damaged over 40 frames, whose
    replacement is its motion moved as a whole (as a turn-back or a reflection rebuilds it;
    here 8 deg off the capture beside it): marked ``exact``, it is written as it is from
    ``margin`` frames inside the run on, and the 8 deg at its seams are spread over the margin;
    smoothed whole, as a median's replacement is, the 25-frame fit takes its curve off
    (reviewer: a reflected CMU elbow 0.1 deg off came out 2.7 deg off)."""
    F = 240
    t = np.arange(F) / 120.0
    q = rot.rotvec_to_quat(np.stack([np.radians(60.0) * np.sin(6 * np.pi * t),
                                     np.zeros(F), np.zeros(F)], axis=1))[:, None]  # fmt: skip
    sk = Skeleton(
        ("a",), np.array([-1]), np.zeros((1, 3)), (("Zrotation", "Xrotation", "Yrotation"),)
    )
    bad = Motion(sk, q.copy(), np.zeros((F, 3)), 1 / 120.0)
    bad.rotations[100:140, 0] = rot.quat_mul(
        rot.rotvec_to_quat(np.array([0.0, np.radians(40.0), 0.0])), q[100:140, 0]
    )
    rep = rot.quat_mul(rot.rotvec_to_quat(np.array([0.0, 0.0, np.radians(8.0)])), q)
    flagged = np.zeros((F, 1), dtype=bool)
    flagged[100:140] = True
    margin = 12
    whole = repair_cells(bad, flagged, rep, margin)
    kept = repair_cells(bad, flagged, rep, margin, exact=flagged)
    inner = slice(100 + margin, 140 - margin)

    def off(res):
        return np.degrees(rot.quat_angle(res.motion.rotations[inner, 0], rep[inner, 0])).max()

    assert off(whole) > 2.0 and off(kept) < 1e-9

    # the seams: no step much over the motion's own (9.4 deg a frame); written as they come,
    # the 8 deg across it would make 12.3 there
    def steps(r):
        return np.degrees(rot.quat_angle(r[1:, 0], r[:-1, 0]))

    assert steps(kept.motion.rotations).max() < 10.5
    seamed = np.where(flagged[..., None], rep, q)
    assert steps(seamed).max() > 12.0
    assert np.array_equal(kept.written, whole.written)


def test_two_stage_agrees_with_full_search(takes, corrupted) -> None:
    _, ctx = takes
    cur, truth = corrupted
    two = SelfSimilarityCleaner(two_stage=True).fit(cur, [ctx])
    assert hasattr(two, "stage1_flagged_") and two.stage1_flagged_.any()
    for j in np.flatnonzero(truth.any(axis=0)):
        assert two.scores()[truth[:, j], j].max() > 0.9


def test_local_context_and_inputs(takes) -> None:
    walk, _ = takes
    cl = SelfSimilarityCleaner().fit(walk)
    assert cl.mask().mean() < 0.02  # a clean take is (nearly) all clean
    with pytest.raises(ValueError):
        SelfSimilarityCleaner().fit(walk[:5])
    small = Motion(walk.skeleton, walk.rotations[:, :], walk.root_positions, walk.frame_time)
    assert SelfSimilarityCleaner(k=2).fit(small).mdm_.shape == walk.rotations.shape[:2]
    with pytest.raises(RuntimeError):
        SelfSimilarityCleaner().scores()
    with pytest.raises(ValueError):
        SelfSimilarityCleaner(threshold=2.0)


def test_mdm_normalisation() -> None:
    M = np.array([[0.1, 0.0], [0.3, 0.0], [2.0, 0.0]])
    paper = movement_digression_map(M, "mean", 1.0, 0.0)
    assert paper[:, 0] == pytest.approx(1 - np.exp(-((M[:, 0] / M[:, 0].mean()) ** 2)))
    assert np.all(paper[:, 1] == 0.0)
    floored = movement_digression_map(M, "mean", 1.0, 1.0)
    assert floored[2, 0] == pytest.approx(1 - np.exp(-4.0))
    with pytest.raises(ValueError):
        movement_digression_map(M, "max")


def test_baselines(takes) -> None:
    walk, ctx = takes
    rng = np.random.default_rng(3)
    cor = corrupt(walk, rng, kinds=["flip"], every_seconds=3.0)
    for kind in ("a", "b", "c"):
        b = RotationBaseline(kind).fit([ctx, walk])
        assert not b.mask(walk).any()
        m = b.mask(cor.motion)
        assert m.shape == cor.truth.shape
    c = RotationBaseline("c").fit([ctx])
    assert (c.mask(cor.motion) & cor.truth).any()
    with pytest.raises(ValueError):
        RotationBaseline("d")


def test_injectors_change_only_their_joint_and_window(takes) -> None:
    walk, _ = takes
    from mocapkit.clean.inject import ERROR_KINDS, hinge_joints

    rng = np.random.default_rng(0)
    for kind in ERROR_KINDS:
        j = hinge_joints(walk)[0] if kind == "bend" else 7
        inj = inject(walk, kind, j, rng, start=50)
        diff = rot.quat_angle(inj.motion.rotations, walk.rotations) > 1e-9
        assert not diff[:, [k for k in range(walk.num_joints) if k != j]].any()
        fr = np.flatnonzero(inj.frames)
        assert len(fr) >= 1 and fr.min() >= 50 and fr.max() < 50 + 41
        # the window holds every rewritten frame; the changed ones (over a degree) are in it
        assert np.array_equal(np.flatnonzero(diff[:, j]), np.flatnonzero(inj.window & diff[:, j]))
        assert not (inj.frames & ~inj.window).any()
    with pytest.raises(ValueError):
        inject(walk, "nope", 1, rng)


def test_a_hold_where_the_joint_barely_moved_is_rewritten_but_not_truth(takes) -> None:
    """A frozen hold's first frames, where the live joint drifted under a degree from the held
    value, are rewritten (a flag there is no false alarm) but not in the truth (no miss)."""
    from mocapkit.clean.evaluate import inject_errors

    walk, _ = takes
    q = walk.rotations.copy()
    q[50:60, 7] = q[50, 7]  # the live joint rests, then moves on
    rest = Motion(walk.skeleton, q, walk.root_positions, walk.frame_time, walk.translations)
    cor = inject_errors(rest, [("frozen", 7, 50)], rng=0)
    (err,) = cor.errors
    held = np.flatnonzero(err.window)
    assert held[0] == 51 and np.all(cor.motion.rotations[held, 7] == q[50, 7])
    assert not cor.truth[51:60, 7].any() and cor.rewritten[51:60, 7].all()
    assert cor.truth[60:, 7].any() and not (cor.truth & ~cor.rewritten).any()


@pytest.mark.parametrize("ground_root", [False, True])
def test_contact_constraint_pins_the_effector(takes, ground_root) -> None:
    """Also on a rig whose pelvis translation is animated under a static ground root (as
    Bandai's under joint_Root): the IK once aimed from the rest pose's pelvis there, and the
    pinned hand of a Bandai bow ended 6 cm from its target (0.4 cm unpinned)."""
    from mocapkit.clean import ContactConstraint
    from mocapkit.core.kinematics import forward_kinematics

    synth = datasets.procedural_motion("walk", seconds=6.0, seed=5)
    walk, (_, ctx) = synth.motion, takes
    if ground_root:
        walk, ctx = with_ground_root(walk), with_ground_root(ctx)
    names = list(walk.skeleton.names)
    toe = names.index("LeftToe")
    stance = np.flatnonzero(synth.contacts[:, 0])
    runs_ = [r for r in true_runs(synth.contacts[:, 0]) if r[1] - r[0] >= 12 and r[0] > 20]
    a, b = runs_[0]
    inj = inject(walk, "offset", names.index("LeftLeg"), np.random.default_rng(2), start=a + 2)
    pos, _ = forward_kinematics(walk)
    contact = ContactConstraint(toe, a + 2, b - 2, tuple(pos[a + 2, toe]))
    cl = SelfSimilarityCleaner().fit(inj.motion, [ctx])
    plain = cl.repair()
    pinned = cl.repair(contacts=[contact])
    target = np.asarray(contact.position)
    from mocapkit.clean.repair import effector_error

    e_plain = effector_error(plain.motion, contact, target)
    e_pin = effector_error(pinned.motion, contact, target)
    assert e_pin.mean() < e_plain.mean()
    # the result says how each contact held, and that one where nothing was repaired was not
    # pinned (it used to be ignored silently)
    (held,) = pinned.contacts
    assert held.pinned and held.max_error == pytest.approx(e_pin.max())
    assert held.joint == "LeftToe" and (held.start, held.end) == (a + 2, b - 2)
    assert held.held and "held to" in str(held) and held.as_dict()["held"]
    # JSON ranges are start:stop, stop excluded, as every range of the CLI and report
    assert held.as_dict()["frames"] == [a + 2, b - 1]
    # a point out of the leg's reach is pinned towards but not held, and says so
    away = ContactConstraint(toe, a + 2, b - 2, tuple(pos[a + 2, toe] + np.array([0, 2.0, 0])))
    (missed,) = cl.repair(contacts=[away]).contacts
    assert missed.pinned and not missed.held and "NOT held" in str(missed)
    assert missed.pinned_max_error > missed.tolerance > 0 and not missed.as_dict()["held"]
    # held where the repair wrote, off where it wrote nothing (the take's own frames): said so
    from mocapkit.clean.repair import ContactHeld

    mixed = ContactHeld("LeftToe", 10, 20, (0.0, 0.0, 0.0), 0.5, 0.2, True, 0.04, 0.01)
    assert mixed.held and "the take's own frames are up to 0.5" in str(mixed)
    far = ContactConstraint("LeftHand", 5, 8)
    (untouched,) = cl.repair(contacts=[far]).contacts
    assert not untouched.pinned and "not pinned" in str(untouched)
    w = pinned.written
    assert np.array_equal(pinned.motion.rotations[~w], inj.motion.rotations[~w])
    assert len(stance) > 0


def test_robust_second_pass_and_paper_normalisation(takes, corrupted) -> None:
    _, ctx = takes
    cur, truth = corrupted
    rb = SelfSimilarityCleaner(robust=True).fit(cur, [ctx])
    paper = SelfSimilarityCleaner(scale="mean", gain=1.0, floor_deg=0.0, detect="threshold").fit(
        cur, [ctx]
    )
    for cl in (rb, paper):
        for j in np.flatnonzero(truth.any(axis=0)):
            assert cl.scores()[truth[:, j], j].max() > 0.9
    # the paper's row-mean normalisation flags far more cells than the default
    assert paper.mask().sum() > 3 * rb.mask().sum()


def test_repair_keeps_planted_feet_planted(fitted, corrupted, takes) -> None:
    from mocapkit.clean.repair import foot_slide
    from mocapkit.features import foot_contacts

    cur, truth = corrupted
    walk, _ = takes
    contacts = foot_contacts(walk)  # the clean take's contacts: where feet should stay
    near = np.convolve(truth.any(axis=1), np.ones(21), mode="same") > 0
    locked = fitted.repair()
    plain = fitted.repair(foot_lock=False)
    assert locked.held_contacts is not None and locked.held_contacts.contacts.any()
    s_locked = foot_slide(locked.motion, contacts, near)
    s_plain = foot_slide(plain.motion, contacts, near)
    s_bad = foot_slide(cur, contacts, near)
    assert s_locked < s_plain and s_locked < s_bad


def test_a_repaired_toe_alone_does_not_move_the_leg(takes) -> None:
    """A joint's own rotation does not move the joint: repairing a toe's rotation leaves the
    toe joint (and every foot contact) where it was, so the foot lock changes nothing; a
    repaired knee moves the foot below it, and the lock holds that foot with IK on the leg."""
    from mocapkit.clean.repair import lock_repaired_feet
    from mocapkit.features import foot_contacts

    walk, _ = takes
    names = list(walk.skeleton.names)
    toe = next(j for j, n in enumerate(names) if "Toe" in n and "Right" in n)
    knee = walk.skeleton.parents[walk.skeleton.parents[toe]]
    contacts = foot_contacts(walk)
    assert contacts.contacts.any()
    planted = contacts.contacts.any(axis=1)
    written = np.zeros((walk.num_frames, walk.num_joints), dtype=bool)
    written[planted, toe] = True
    res = lock_repaired_feet(walk, written)
    assert np.array_equal(res.written, written)
    assert np.array_equal(res.motion.rotations, walk.rotations)
    moved = walk.copy()
    bend = rot.rotvec_to_quat(np.array([0.15, 0.0, 0.0]))
    moved.rotations[planted, knee] = rot.quat_mul(moved.rotations[planted, knee], bend)
    written[:] = False
    written[planted, knee] = True
    res = lock_repaired_feet(moved, written)
    assert res.contacts is not None and res.contacts.contacts.any()
    assert (res.written & ~written).any()  # the IK wrote leg cells beside the knee's


def test_the_foot_lock_changes_only_frames_the_repair_touched(takes) -> None:
    """A knee repaired over a few frames in the middle of a stance: the lock holds the foot
    where the untouched frames of that stance plant it, changes no other frame, and the foot
    does not jump where the repair ends (newcomer report: a whole stance held at one point
    moved good frames by 5 cm and made the toe jump 21 cm at toe-off)."""
    from mocapkit.clean.repair import lock_repaired_feet
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.features import foot_contacts

    walk, _ = takes
    names = list(walk.skeleton.names)
    toe = next(j for j, n in enumerate(names) if "Toe" in n and "Right" in n)
    ankle = walk.skeleton.parents[toe]
    knee = walk.skeleton.parents[ankle]
    k = list(foot_contacts(walk).joints).index(toe)
    a, b = max(true_runs(foot_contacts(walk).contacts[:, k]), key=lambda r: r[1] - r[0])
    assert b - a >= 12
    span = np.arange(a + 3, b - 3)  # the repaired frames, inside the stance
    moved = walk.copy()
    bend = rot.rotvec_to_quat(np.array([0.12, 0.0, 0.0]))
    moved.rotations[span, knee] = rot.quat_mul(moved.rotations[span, knee], bend)
    written = np.zeros((walk.num_frames, walk.num_joints), dtype=bool)
    written[span, knee] = True
    res = lock_repaired_feet(moved, written)
    other = np.ones(walk.num_frames, bool)
    other[span] = False
    assert np.array_equal(res.motion.rotations[other], moved.rotations[other])
    before, _ = forward_kinematics(walk)
    bent, _ = forward_kinematics(moved)
    after, _ = forward_kinematics(res.motion)
    flat = [0, 2]  # procedural walks are Y-up
    miss = np.linalg.norm(after[span][:, toe, flat] - before[span][:, toe, flat], axis=-1)
    miss_bent = np.linalg.norm(bent[span][:, toe, flat] - before[span][:, toe, flat], axis=-1)
    assert miss.max() < 0.5 * miss_bent.max()  # before the fix: 1.6 times
    step = np.linalg.norm(np.diff(after[a - 2 : b + 3, toe, flat], axis=0), axis=-1)
    step_true = np.linalg.norm(np.diff(before[a - 2 : b + 3, toe, flat], axis=0), axis=-1)
    assert step.max() <= step_true.max() + 0.1 * miss_bent.max()


def test_the_cleaner_api_refuses_what_it_cannot_analyse_and_survives_a_failed_fit(
    takes,
) -> None:
    """Newcomer report (API): one take given as the context hung (iterating a Motion), a fit
    that failed left the cleaner broken, a take too short to find like words came back clean,
    a generator context was used up by the skeleton check, pipeline=[] ran every rule, and NaN
    or mistyped settings passed."""
    from mocapkit.clean import DetectConfig

    walk, other = takes
    single = SelfSimilarityCleaner().fit(walk, other)
    listed = SelfSimilarityCleaner().fit(walk, [other])
    np.testing.assert_array_equal(single.mdm_, listed.mdm_)
    gen = SelfSimilarityCleaner().fit(walk, (m for m in [other]))
    np.testing.assert_array_equal(gen.mdm_, listed.mdm_)
    with pytest.raises(ValueError, match="1 names for 2 context takes"):
        SelfSimilarityCleaner().fit(walk, [other, other], names=["a"])
    c = SelfSimilarityCleaner().fit(walk)
    before = c.mdm_.copy()
    with pytest.raises(ValueError, match="too short"):
        c.fit(walk[:5])
    np.testing.assert_array_equal(c.mdm_, before)  # the earlier fit is intact
    assert c.segments() == SelfSimilarityCleaner().fit(walk).segments()
    with pytest.raises(ValueError, match="found a like word away from itself"):
        SelfSimilarityCleaner().fit(walk[:30])
    SelfSimilarityCleaner().fit(walk[:30], [other])  # a context gives the words neighbours
    assert not SelfSimilarityCleaner(pipeline=[]).fit(walk).mask().any()
    with pytest.raises(TypeError, match="rule classes"):
        SelfSimilarityCleaner(pipeline=["noise"])
    for bad_setting in ({"gain": np.nan}, {"floor_deg": np.inf}, {"k": 2.5}, {"k": True},
                        {"two_stage": "no"}, {"step_quantile": 150.0}, {"max_run": -1},
                        {"stage1_threshold": 2.0}, {"analysis_fps": 1000.0}):  # fmt: skip
        with pytest.raises(ValueError, match=next(iter(bad_setting))):
            DetectConfig(**bad_setting)


def test_inject_takes_a_joint_name_and_a_seed_and_refuses_what_is_off_the_take(takes) -> None:
    walk, _ = takes
    by_name = inject(walk, "spike", "LeftForeArm", 3, start=40)
    by_index = inject(
        walk, "spike", walk.skeleton.index("LeftForeArm"), np.random.default_rng(3), start=40
    )
    assert by_name.joint == by_index.joint
    np.testing.assert_array_equal(by_name.motion.rotations, by_index.motion.rotations)
    with pytest.raises(ValueError, match="out of range"):
        inject(walk, "spike", -1, 0)
    with pytest.raises(ValueError, match="start 1000 out of range"):
        inject(walk, "spike", 3, 0, start=1000)


def test_explain_and_repair_refuse_fractional_frames_and_take_a_contact_by_name(
    corrupted,
) -> None:
    from mocapkit.clean.repair import ContactConstraint

    bad, _ = corrupted
    c = SelfSimilarityCleaner().fit(bad)
    with pytest.raises(ValueError, match="frame must be a whole number"):
        c.explain("LeftForeArm", 40.5)
    with pytest.raises(ValueError, match=r"margin \(frames\) must be a whole number"):
        c.repair(margin=2.7)
    # a threshold or joint given as a string or fraction is refused, not compared or truncated
    for call in (lambda: c.mask(threshold="0.5"), lambda: c.explain("LeftForeArm", 40, "0.85"),
                 lambda: c.segments(threshold=1.5), lambda: c.explain(2.5, 40)):  # fmt: skip
        with pytest.raises(ValueError, match=r"threshold|joint must be a whole number"):
            call()
    assert c.mask(threshold=0.5).shape == bad.rotations.shape[:2]
    hand = bad.skeleton.names.index("LeftHand")
    by_name = c.repair(contacts=[ContactConstraint("LeftHand", 38, 44)])
    by_index = c.repair(contacts=[ContactConstraint(hand, 38, 44)])
    np.testing.assert_array_equal(by_name.motion.rotations, by_index.motion.rotations)
    with pytest.raises(ValueError, match="no joint named 'Nope'"):
        c.repair(contacts=[ContactConstraint("Nope", 38, 44)])


def test_a_contact_constraint_refuses_what_is_not_a_contact(corrupted) -> None:
    from mocapkit.clean.repair import ContactConstraint

    for args in (("LeftHand", 38.5, 44), ("LeftHand", 38, 44, (0.0, np.nan, 0.0)),
                 ("LeftHand", 38, 44, (0.0, 0.0)), (None, 38, 44)):  # fmt: skip
        with pytest.raises(ValueError, match="contact"):
            ContactConstraint(*args)
    bad, _ = corrupted
    with pytest.raises(ValueError, match="out of range"):
        SelfSimilarityCleaner().fit(bad).repair(contacts=[ContactConstraint(99, 38, 44)])
    with pytest.raises(ValueError, match="start must be a whole number"):
        inject(bad, "spike", 3, 0, start=40.5)


def _swing(F: int = 120) -> np.ndarray:
    """(F, 2, 4): two joints turning smoothly about tilted axes."""
    t = np.arange(F) / 30.0
    rv = np.zeros((F, 2, 3))
    rv[:, 0] = np.outer(0.6 * np.sin(2 * np.pi * t / 2.0), [1.0, 0.3, 0.0])
    rv[:, 1] = np.outer(0.4 * np.cos(2 * np.pi * t / 3.0), [0.0, 1.0, 0.5])
    return rot.rotvec_to_quat(rv)


def test_unturned_undoes_a_stretch_turned_by_one_rotation() -> None:
    from mocapkit.clean.repair import unturned

    def err(a: np.ndarray, b: np.ndarray) -> float:
        return float(np.degrees(rot.quat_angle(a, b)).max())

    q = _swing()
    d = rot.rotvec_to_quat(np.radians(35.0) * np.array([0.6, 0.0, 0.8]))

    def turned(sl: slice, side: str = "body") -> np.ndarray:
        bad = q.copy()
        bad[sl, 1] = rot.quat_mul(q[sl, 1], d) if side == "body" else rot.quat_mul(d, q[sl, 1])
        return bad

    def cells_at(sl: slice) -> np.ndarray:
        c = np.zeros(q.shape[:2], dtype=bool)
        c[sl, 1] = True
        return c

    cells = cells_at(slice(40, 70))
    for side in ("body", "parent"):
        bad = turned(slice(40, 70), side)
        back, done = unturned(bad, cells)
        assert err(back[40:70, 1], q[40:70, 1]) < 0.5, side
        assert np.array_equal(done, cells)
        assert np.array_equal(back[~cells], bad[~cells])  # every other cell as it was
        # cut off by the take's end or start: the one edge inside says the turn and its side
        # (or, where the side does not show, leaves it for the median)
        for sl in (slice(90, 120), slice(0, 30), slice(100, 120)):
            back, done = unturned(turned(sl, side), cells_at(sl))
            assert not done.any() or err(back[sl, 1], q[sl, 1]) < 0.5, (side, sl)
    # a run one frame short of the turn (the jump read a frame late): predicting across the
    # jump turns the stretch by it twice, unless the edge may move onto the jump inside the
    # flagged run around it
    bad = turned(slice(40, 70))
    late, flagged = cells_at(slice(41, 70)), cells_at(slice(38, 73))
    assert err(unturned(bad, late)[0][41:70, 1], q[41:70, 1]) > 30
    back, done = unturned(bad, late, within=flagged)
    assert err(back[40:70, 1], q[40:70, 1]) < 0.5 and done[40:70, 1].all()
    assert np.array_equal(back[70:, 1], bad[70:, 1]) and np.array_equal(back[:40], bad[:40])
    # a two-frame turn and runs from frame 1 or to the last frame: the edges stay put
    for sl in (slice(5, 7), slice(50, 52), slice(1, 41), slice(80, 119)):
        back, done = unturned(turned(sl), cells_at(sl), within=cells_at(sl))
        assert err(back[sl, 1], q[sl, 1]) < 1.0, sl
    # two edges whose turns disagree (not one rotation: a wrong pairing) are left alone
    odd = q.copy()
    odd[40:55, 1] = rot.quat_mul(q[40:55, 1], d)
    odd[55:70, 1] = rot.quat_mul(q[55:70, 1], rot.rotvec_to_quat(np.radians([0.0, 60.0, 0.0])))
    back, done = unturned(odd, cells)
    assert not done.any() and np.array_equal(back, odd)
    # a turn about one axis whose angle grows along the run (a wrong-way bend follows the
    # joint's flexion): the edges disagree in size, not in axis, and the slerp between them
    # undoes it
    axis = np.array([0.6, 0.0, 0.8])
    grow = rot.rotvec_to_quat(np.radians(np.linspace(25.0, 60.0, 30))[:, None] * axis[None])
    bent = q.copy()
    bent[40:70, 1] = rot.quat_mul(q[40:70, 1], grow)
    back, done = unturned(bent, cells)
    assert done[40:70, 1].all() and err(back[40:70, 1], q[40:70, 1]) < 1.0
    # ... but not edges 5 times apart in size, nor a turn near 180 deg (no reliable axis)
    for lo, hi in ((12.0, 60.0), (100.0, 170.0)):
        grow = rot.rotvec_to_quat(np.radians(np.linspace(lo, hi, 30))[:, None] * axis[None])
        bent[40:70, 1] = rot.quat_mul(q[40:70, 1], grow)
        assert not unturned(bent, cells)[1].any(), (lo, hi)


def test_repair_turns_an_offset_back_and_keeps_the_captured_frames_around_it(takes) -> None:
    """An offset on a joint the take holds still (a resting hand): the neighbours' median is
    another moment's pose; the repair undoes the offset's rotation instead, and the frames the
    MDM flags past its jumps keep their captured rotations."""
    walk, ctx = takes
    names = list(walk.skeleton.names)
    j = names.index("LeftHand")
    bad = walk.copy()
    d = rot.rotvec_to_quat(np.radians(30.0) * np.array([1.0, 0.0, 0.0]))
    bad.rotations[60:85, j] = rot.quat_mul(walk.rotations[60:85, j], d)
    cl = SelfSimilarityCleaner().fit(bad, [ctx])
    flags = cl.flags()
    assert flags.live("cancelling-jumps")[60:85, j].all()
    fixed = cl.repair().motion
    err = np.degrees(rot.quat_angle(fixed.rotations[:, j], walk.rotations[:, j]))
    assert err[60:85].max() < 1.0
    # the median words instead (a baseline mask takes the plain path)
    plain = cl.repair(mask=cl.mask()).motion
    assert (
        np.degrees(rot.quat_angle(plain.rotations[60:85, j], walk.rotations[60:85, j])).mean()
        > err[60:85].mean()
    )


def test_repair_turns_a_pelvis_offset_back_in_the_files_space(takes) -> None:
    """The pelvis column of the replacement lives in the facing-aligned space: the turned-back
    pelvis must be mapped there, or the repair lands off by the body's facing."""
    walk, ctx = takes
    p = walk.skeleton.names.index("Hips")
    # facing 120 deg away from the context's: the facing-aligned space is far from the file's
    yaw = rot.rotvec_to_quat(np.radians(120.0) * np.array([0.0, 1.0, 0.0]))
    walk = walk.copy()
    walk.rotations[:, p] = rot.quat_mul(yaw, walk.rotations[:, p])
    bad = walk.copy()
    d = rot.rotvec_to_quat(np.radians(30.0) * np.array([1.0, 0.0, 0.0]))
    bad.rotations[60:85, p] = rot.quat_mul(walk.rotations[60:85, p], d)
    cl = SelfSimilarityCleaner().fit(bad, [ctx])
    assert cl.flags().live("cancelling-jumps")[60:85, p].all()
    fixed = cl.repair().motion
    assert (
        np.degrees(rot.quat_angle(fixed.rotations[60:85, p], walk.rotations[60:85, p])).max() < 2.0
    )


def test_repair_keeps_the_captured_frames_the_words_flag_past_a_turned_stretch(shared_path) -> None:
    """A Bandai forearm twisted 40 deg about its own bone for 0.5 s (newcomer): the jumps bound
    the stretch, which is turned back; the words' digression flags frames past it (up to a
    source word), which hold the captured motion and must keep it. With only 0.1 s of them
    kept, the median replaced frames 4-7 past the stretch, 18 deg off the capture."""
    from mocapkit.io import read_motion

    take = read_motion(shared_path("bandai1") / "data" / "dataset-1_guide_masculinity_001.bvh")
    j = take.skeleton.index("LowerArm_R")
    bone = take.skeleton.offsets[take.skeleton.children(j)[0]]
    bad = take.copy()
    d = rot.rotvec_to_quat(np.radians(40.0) * bone / np.linalg.norm(bone))
    bad.rotations[60:75, j] = rot.quat_mul(take.rotations[60:75, j], d)
    cl = SelfSimilarityCleaner().fit(bad)
    seg = [s for s in cl.segments() if s.joint == "LowerArm_R"]
    assert seg and seg[0].start <= 60 and seg[0].end >= 78  # the words' spill past the twist
    fixed = cl.repair().motion
    err = np.degrees(rot.quat_angle(fixed.rotations[:, j], take.rotations[:, j]))
    assert err[60:75].max() < 1.0 and err[75:90].max() < 1.0


def test_repair_turns_back_a_flipped_elbow_but_not_a_wrong_way_bend_of_a_flexing_one(
    takes,
) -> None:
    """Both errors bend the elbow the wrong way (the wrong-way-hinge rule flags them), and both
    stretches are entered and left by opposite jumps. A flip is one half turn: turning it back
    restores the capture, where the median is another moment's pose. A wrong-way bend mirrors
    the flexion, which changes along the run on an arm swinging in a walk: the turn read at
    its edges leaves the middle off (12-20 deg here), and the median, another swing of the
    same arm, is near (under 3 deg)."""
    walk, ctx = takes
    j = walk.skeleton.index("LeftForeArm")

    def off(m: Motion, sl: slice) -> float:
        return float(np.degrees(rot.quat_angle(m.rotations[sl, j], walk.rotations[sl, j])).mean())

    for kind, seed, start in (("flip", 0, 60), ("flip", 2, 100), ("bend", 0, 60), ("bend", 3, 120)):
        inj = inject(walk, kind, j, seed, start=start)
        frames = np.flatnonzero(inj.frames)
        sl = slice(int(frames[0]), int(frames[-1]) + 1)
        cl = SelfSimilarityCleaner().fit(inj.motion, [ctx])
        flags = cl.flags()
        assert flags.live("wrong-way-hinge")[sl, j].any(), (kind, seed)
        assert flags.live("cancelling-jumps")[sl, j].any(), (kind, seed)
        fixed = off(cl.repair().motion, sl)
        median = off(cl.repair(mask=cl.mask()).motion, sl)
        if kind == "flip":
            assert fixed < 0.5 and median > 2.0, (seed, fixed, median)
        else:
            assert fixed < 3.0 and fixed <= median + 0.1, (seed, fixed, median)


def test_flexion_of_reads_a_hinge_as_its_own_flexion_does(takes) -> None:
    from mocapkit.clean.detect import DetectConfig, Evidence

    walk, _ = takes
    ev = Evidence.for_motion(walk, DetectConfig())
    assert ev.hinge_axes  # the procedural walk's knees and elbows
    for j, axis in ev.hinge_axes.items():
        assert abs(np.linalg.norm(axis) - 1.0) < 1e-9
        np.testing.assert_allclose(ev.flexion_of(j, walk.rotations[:, j]), ev.hinge_flexion[:, j])
        # flexion is signed so that the hinge spends most of its time bent its own way
        assert np.median(ev.hinge_flexion[:, j]) > 0
    other = next(j for j in range(walk.num_joints) if j not in ev.hinge_axes)
    assert np.isnan(ev.flexion_of(other, walk.rotations[:, other])).all()


def test_bent_right_sends_a_turn_back_that_leaves_a_hinge_wrong_or_has_no_line_to_the_median(
    takes,
) -> None:
    from mocapkit.clean.cleaner import _bent_right
    from mocapkit.clean.detect import DetectConfig, Evidence

    walk, _ = takes
    ev = Evidence.for_motion(walk, DetectConfig())
    j = walk.skeleton.index("LeftForeArm")
    assert j in ev.hinge_axes
    F = walk.num_frames
    q = walk.rotations
    done = np.zeros((F, walk.num_joints), dtype=bool)
    done[60:70, j] = done[0:10, j] = True
    none = np.zeros_like(done)
    # the captured elbow itself: bent its own way, so every run stays turned back where the
    # hinge rule did not flag it
    assert np.array_equal(_bent_right(ev, q, done, none), done)
    # a turn-back that folds the elbow the wrong way is no repair, flagged by the rule or not
    axis = ev.hinge_axes[j]
    flex = ev.hinge_flexion[:, j]
    wrong = q.copy()
    wrong[60:70, j] = rot.rotvec_to_quat(-(flex[60:70, None] + np.radians(40.0)) * axis)
    kept = _bent_right(ev, wrong, done, none)
    assert not kept[60:70, j].any() and kept[0:10, j].all()
    # a hinge-flagged run reaching the take's first frame has one edge: no line to follow,
    # even where the elbow holds still there (its flexion on a line)
    held = walk.copy()
    held.rotations[0:12, j] = held.rotations[12, j]
    ev = Evidence.for_motion(held, DetectConfig())
    hinge = np.zeros_like(done)
    hinge[0:10, j] = hinge[60:62, j] = True
    short = np.zeros_like(done)
    short[0:10, j] = short[60:62, j] = True
    kept = _bent_right(ev, held.rotations, short, hinge)
    assert not kept[0:10, j].any()
    assert kept[60:62, j].all()  # two frames: on the line between themselves


def test_a_flip_left_at_the_takes_next_to_last_frame_is_flagged_and_turned_back(takes) -> None:
    """The flip's exit jump falls on the take's last frames, where jumps are not measured: it
    reads as cut off by the end, and the last frame, clean, is left out only where the step
    into it cancels the flip's entry; both are half turns, which may come out the same way
    round. Then the run's one full edge gives the turn for both, on the side the two edges,
    as read, agree on (a tie chose the wrong side: 42 deg off mid-run)."""
    walk, ctx = takes
    F = walk.num_frames
    for name in ("LeftForeArm", "LeftArm"):
        j = walk.skeleton.index(name)
        inj = inject(walk, "flip", j, 1, start=F - 10)
        assert np.flatnonzero(inj.frames)[-1] == F - 2
        cl = SelfSimilarityCleaner().fit(inj.motion, [ctx])
        flagged = np.flatnonzero(cl.mask()[:, j])
        assert flagged.min() == F - 10 and flagged.max() == F - 2, name
        fixed = cl.repair().motion
        err = np.degrees(rot.quat_angle(fixed.rotations[F - 12 :, j], walk.rotations[F - 12 :, j]))
        assert err.max() < 2.0, (name, err.round(1))
        # --explain on the last frame says it was left out as clean, not a rejection (reviewer)
        text = str(cl.explain(name, F - 1))
        assert "left out of the stretch cut off there" in text, text
        assert "may bound an error" not in text


def test_unturned_reads_an_edge_both_ways_on_a_joint_that_accelerates() -> None:
    """A forearm whipping back and forth (1.6 rad swings, 0.9 s period) under a 30 deg offset:
    a prediction from outside alone misses the edge frame by the joint's acceleration (up to
    5 deg off after the turn-back); read from inside too, the two errors cancel."""
    from mocapkit.clean.repair import unturned

    F = 100
    t = np.arange(F) / 30.0
    ang = 1.6 * np.sin(2 * np.pi * t / 0.9)
    ax = np.stack([np.ones(F), 0.4 * np.sin(2 * np.pi * t / 1.7), 0.2 * np.ones(F)], 1)
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    q = rot.rotvec_to_quat(ang[:, None] * ax)[:, None]
    d = rot.rotvec_to_quat(np.radians(30.0) * np.array([0.0, 0.0, 1.0]))
    for start in range(30, 60, 3):
        sl = slice(start, start + 15)
        bad = q.copy()
        bad[sl, 0] = rot.quat_mul(q[sl, 0], d)
        cells = np.zeros((F, 1), dtype=bool)
        cells[sl, 0] = True
        back, done = unturned(bad, cells)
        assert done[sl, 0].all(), start
        assert np.degrees(rot.quat_angle(back[sl, 0], q[sl, 0])).max() < 1.0, start


def test_unturned_reads_an_edge_from_outside_where_the_glitchs_frames_jitter() -> None:
    """Inside a real glitch the frames need not move as the capture does (here 6 deg of jitter
    on top of a 40 deg turn): the reading from inside then errs, and the outside reading, whose
    two edges agree the better, is kept (always averaged, the edges were 3-9 deg off)."""
    from mocapkit.clean.repair import unturned

    q = _swing()[:, :1]
    F = q.shape[0]
    d = rot.rotvec_to_quat(np.radians(40.0) * np.array([0.0, 0.6, 0.8]))
    rng = np.random.default_rng(0)
    sl = slice(40, 56)
    cells = np.zeros((F, 1), dtype=bool)
    cells[sl, 0] = True
    for _ in range(10):
        noise = rot.rotvec_to_quat(rng.normal(scale=np.radians(6.0), size=(16, 3)))
        noise[0] = noise[-1] = (1.0, 0.0, 0.0, 0.0)  # the edge frames: the glitch's turn alone
        bad = q.copy()
        bad[sl, 0] = rot.quat_mul(rot.quat_mul(q[sl, 0], d), noise)
        back, done = unturned(bad, cells)
        assert done[sl, 0].all()
        assert np.degrees(rot.quat_angle(back[[40, 55], 0], q[[40, 55], 0])).max() < 1.0


def test_short_of_jumps_keeps_the_capture_beside_a_turned_stretch_only_up_to_a_jump() -> None:
    from mocapkit.clean.cleaner import _short_of_jumps

    F = 40
    done = np.zeros((F, 1), dtype=bool)
    done[10:20, 0] = True
    keep = np.zeros_like(done)
    keep[20:30, 0] = keep[4:10, 0] = True
    jumps = np.zeros_like(done)
    jumps[20, 0] = True  # the stretch's own exit: the first kept frame is clean
    jumps[25, 0] = True  # a jump farther on: the capture is not clean from there
    jumps[7, 0] = True  # before the stretch, across a jump from it
    out = _short_of_jumps(keep, done, jumps)
    assert np.flatnonzero(out[:, 0]).tolist() == [7, 8, 9, *range(20, 25)]
    # no jump beside the stretch: everything kept
    assert np.array_equal(_short_of_jumps(keep, done, np.zeros_like(done)), keep)
    # between two stretches (10:20 and 26:36) with a jump entering 23: the cells on each side
    # of it stay with their own stretch (reviewer: cut from one side only, 23-25 went to the
    # median); with two jumps, the cells between them go
    two = np.zeros_like(done)
    two[10:20, 0] = two[26:36, 0] = True
    mid = np.zeros_like(done)
    mid[20:26, 0] = True
    both = np.zeros_like(done)
    both[[22, 24], 0] = True
    assert np.flatnonzero(_short_of_jumps(mid, two, both)[:, 0]).tolist() == [20, 21, 24, 25]
    at23 = np.zeros_like(done)
    at23[23, 0] = True
    assert np.array_equal(_short_of_jumps(mid, two, at23), mid)


def test_repair_of_a_raw_cmu_thumb_glitch_leaves_no_jump(shared_path) -> None:
    """CMU 01_13's thumb pops 169 deg at frame 1601, back at 1609 (a pair the cancelling-jumps
    rule turns back), then thrashes on to 1614 (steps of 40-160 deg). The frames after the
    turned stretch that only the MDM flags keep the capture only up to the next jump: kept
    through 1621, the raw thrashing left a 23-deg jump in the repair."""
    from mocapkit.clean.mdm import jump_size
    from mocapkit.io import read_motion

    take = read_motion(shared_path("cmu-asfamc") / "01" / "01_13.amc")
    j = take.skeleton.index("rthumb")
    fixed = SelfSimilarityCleaner().fit(take).repair().motion
    jumps = np.degrees(jump_size(fixed.rotations[1592:1630, j : j + 1])[:, 0])
    assert jumps.max() < 5.0, jumps.round(1)


def test_reflected_puts_a_mirrored_bend_back_on_its_side(takes) -> None:
    """A forearm's bend mirrored across straight (its flexion negated, the twist about the
    limb kept), or mirrored and pushed 25 deg further: reflected back and bridged to the
    frames beside the run, it is the capture again. Not done at the take's edge (no two
    frames beside it), nor where the reflection would still bend the wrong way."""
    from mocapkit.clean.cleaner import _reflected
    from mocapkit.clean.detect import DetectConfig, Evidence
    from mocapkit.clean.detect.evidence import bend_and_twist

    walk, _ = takes
    j = walk.skeleton.index("LeftForeArm")
    ev0 = Evidence.for_motion(walk, DetectConfig())
    axis = ev0.hinge_axes[j]
    rest = ev0.hinge_bones[ev0.hinges.index(j)]

    def mirrored(q: np.ndarray, push_deg: float) -> np.ndarray:
        bend, twist = bend_and_twist(q, rest)
        f = bend @ axis
        new = bend - (2 * f + np.radians(push_deg))[:, None] * axis[None]
        return rot.quat_mul(rot.rotvec_to_quat(new), twist)

    F = walk.num_frames
    for push in (0.0, 25.0):
        bad = walk.copy()
        bad.rotations[60:75, j] = mirrored(walk.rotations[60:75, j], push)
        ev = Evidence.for_motion(bad, DetectConfig())
        assert (ev.hinge_flexion[60:75, j] < 0).all()
        cells = np.zeros((F, walk.num_joints), dtype=bool)
        cells[60:75, j] = True
        out, done = _reflected(ev, cells)
        assert done[60:75, j].all() and done.sum() == 15
        err = np.degrees(rot.quat_angle(out[60:75, j], walk.rotations[60:75, j]))
        assert err.max() < 3.0, (push, err.round(1))
        assert np.array_equal(out[~done], np.asarray(bad.rotations)[~done])
        edge = np.zeros_like(cells)  # the take's first frames: no frames before to meet
        edge[0:10, j] = True
        assert not _reflected(ev, edge)[1].any()
        edge[:] = False  # a run from frame 1, one of a single frame: skipped, no exception
        edge[1:10, j] = edge[40, j] = True
        assert not _reflected(ev, edge)[1].any()
        # the neighbours' median meeting the edges better (here: the capture itself, against
        # a reflection that needs a 25-deg offset) wins
        if push:
            assert not _reflected(ev, cells, np.asarray(walk.rotations))[1].any()
        folded = np.asarray(bad.rotations).copy()  # a median far off at the edges loses
        folded[:, j] = rot.rotvec_to_quat(np.radians(130.0) * axis)
        assert _reflected(ev, cells, folded)[1][60:75, j].all()
        # the twist about the limb turned too (not the bend alone mirrored): not reflected
        turned = bad.copy()
        spin = rot.rotvec_to_quat(np.radians(30.0) * rest / np.linalg.norm(rest))
        turned.rotations[60:75, j] = rot.quat_mul(bad.rotations[60:75, j], spin)
        tev = Evidence.for_motion(turned, DetectConfig())
        assert not _reflected(tev, cells)[1].any()
    # a right-way bend rising 60 deg over the run from 5 deg at its edges: reflected and
    # bridged, its middle still bends the wrong way (-50 deg): left to the median
    bend, twist = bend_and_twist(walk.rotations[60:75, j], rest)
    hump = np.radians(5.0 + 60.0 * np.sin(np.linspace(0.0, np.pi, 15)))
    bad = walk.copy()
    new = bend + (hump - bend @ axis)[:, None] * axis[None]
    bad.rotations[60:75, j] = rot.quat_mul(rot.rotvec_to_quat(new), twist)
    bad.rotations[55:60, j] = bad.rotations[60, j]  # the edges held at 5 deg
    bad.rotations[75:80, j] = bad.rotations[74, j]
    ev = Evidence.for_motion(bad, DetectConfig())
    cells = np.zeros((F, walk.num_joints), dtype=bool)
    cells[60:75, j] = True
    assert not _reflected(ev, cells)[1].any()


def mirrored_bend(take: Motion, j: int, frames: slice) -> Motion:
    """``take`` with hinge ``j``'s bend mirrored across straight over ``frames`` (its flexion
    negated, the twist about the limb kept): a solver's mirror solution of the limb."""
    from mocapkit.clean.detect import DetectConfig, Evidence
    from mocapkit.clean.detect.evidence import bend_and_twist

    ev = Evidence.for_motion(take, DetectConfig())
    axis, rest = ev.hinge_axes[j], ev.hinge_bones[ev.hinges.index(j)]
    bend, twist = bend_and_twist(take.rotations[frames, j], rest)
    bad = take.copy()
    new = bend - 2 * (bend @ axis)[:, None] * axis[None]
    bad.rotations[frames, j] = rot.quat_mul(rot.rotvec_to_quat(new), twist)
    return bad


def test_repair_turns_back_a_forearm_swung_out_of_its_plane(takes) -> None:
    """A forearm turned 30 deg out of its bending plane by one rotation for 15 frames: the
    wrong-way-hinge rule flags it (out of its plane) beside cancelling-jumps, but its flexion
    is the right way, so it is a stretch turned by one rotation and is turned back (0.03 deg
    off), not sent to the neighbours' median as a mirrored bend whose flexion curves (2.0 deg
    off; a newcomer's waving forearm: its wave flattened)."""
    from mocapkit.clean.detect import DetectConfig, Evidence

    walk, _ = takes
    j = walk.skeleton.index("LeftForeArm")
    ev = Evidence.for_motion(walk, DetectConfig())
    rest = ev.hinge_bones[ev.hinges.index(j)]
    across = np.cross(rest, ev.hinge_axes[j])
    bad = walk.copy()
    turn = rot.rotvec_to_quat(np.radians(30.0) * across / np.linalg.norm(across))
    bad.rotations[60:75, j] = rot.quat_mul(walk.rotations[60:75, j], turn)
    cl = SelfSimilarityCleaner().fit(bad)
    fl = cl.flags()
    assert fl.live("wrong-way-hinge")[60:75, j].all()
    assert fl.live("cancelling-jumps")[60:75, j].all()
    assert not cl.evidence_.wrong_way[:, j].any()
    fixed = cl.repair().motion.rotations[60:75, j]
    err = np.degrees(rot.quat_angle(fixed, walk.rotations[60:75, j]))
    assert err.max() < 0.5, err.round(2)


def test_repair_reflects_a_wave_elbow_bent_the_wrong_way(shared_path) -> None:
    """A Bandai elbow bent 101-140 deg through a wave, mirrored across straight for 18 frames
    (newcomer): the take holds no other such wave, so the neighbours' median straightened the
    arm, 125 deg off; reflected back, the repair is within a few degrees of the capture."""
    from mocapkit.io import read_motion

    take = read_motion(shared_path("bandai1") / "data" / "dataset-1_byebye_happy_001.bvh")
    j = take.skeleton.index("LowerArm_R")
    bad = mirrored_bend(take, j, slice(14, 32))
    cl = SelfSimilarityCleaner().fit(bad)
    assert cl.flags().live("wrong-way-hinge")[14:32, j].all()
    err = np.degrees(rot.quat_angle(cl.repair().motion.rotations[:, j], take.rotations[:, j]))
    assert err[14:32].mean() < 5.0 and err[14:32].max() < 8.0, err[14:32].round(1)
    median = cl.repair(mask=cl.mask()).motion.rotations[14:32, j]
    assert np.degrees(rot.quat_angle(median, take.rotations[14:32, j])).mean() > 60.0


def test_repair_reflects_a_fast_cmu_elbow_rather_than_turning_it_back(shared_path) -> None:
    """A CMU elbow (01_01's rradius, 120 fps, in a 5 s cut) mirrored across straight for 20
    frames: the cancelling-jumps rule pairs its ends as well, and turned back (a rotation
    slerped from one edge's turn to the other's) it came out 2.0 deg off on average, as the
    flexion curves over the run; reflected it is 0.05 deg off, 0.28 after a blend smoothing the
    whole run over 25 frames, and 0.17 written as it is beyond the seams."""
    from mocapkit.io import read_motion

    take = read_motion(shared_path("cmu-asfamc") / "01" / "01_01.amc")[700:1300]
    j = take.skeleton.index("rradius")
    bad = mirrored_bend(take, j, slice(300, 320))
    cl = SelfSimilarityCleaner().fit(bad)
    fl = cl.flags()
    assert fl.live("cancelling-jumps")[300:320, j].all()
    assert fl.live("wrong-way-hinge")[300:320, j].all()
    err = np.degrees(rot.quat_angle(cl.repair().motion.rotations[:, j], take.rotations[:, j]))
    assert err[300:320].mean() < 0.25 and err[300:320].max() < 0.6, err[300:320].round(2)


def test_repair_of_mirrored_cmu_elbows_leaves_no_jump(shared_path) -> None:
    """Two mirrored CMU elbow bends (01_01's rradius in a 5 s cut, 120 fps) that broke the
    reflection-first repair (reviewer): one whose flexion grazes -15 deg inside the run, so the
    wrong-way-hinge rule's run splits and each piece was reflected on its own (14 deg off, a
    22-deg step at the split); one reaching the take's last frame, whose refused turn-back was
    written as "captured" beside the reflected part (a 142-deg step). Reflected whole, or left
    to the median, neither leaves a step over the capture's own by more than 2 deg."""
    from mocapkit.io import read_motion

    take = read_motion(shared_path("cmu-asfamc") / "01" / "01_01.amc")[700:1300]
    j = take.skeleton.index("rradius")
    for (a, b), worst in (((250, 270), 1.0), ((580, 600), 10.0)):
        res = SelfSimilarityCleaner().fit(mirrored_bend(take, j, slice(a, b))).repair()
        got, true = res.motion.rotations[:, j], take.rotations[:, j]
        err = np.degrees(rot.quat_angle(got[a:b], true[a:b]))
        assert err.max() < worst, (a, err.round(1))
        steps = np.degrees(rot.quat_angle(got[1:], got[:-1]) - rot.quat_angle(true[1:], true[:-1]))
        assert steps[a - 40 :].max() < 2.0, (a, steps[a - 40 :].max())


def test_edge_offsets_take_the_smaller_reading_where_both_agree() -> None:
    """A run that meets the take (a knee slowing to straight after it: the outside frames,
    carried on, read 13 deg too little at its last frame, the inside ones 1 deg): the smaller
    reading; a run pushed 30 deg off reads about 30 both ways; readings of opposite signs: none."""
    from mocapkit.clean.cleaner import _edge_offsets

    true = np.radians(
        [26.9, 31.1, 37.7, 47.8, 57.9, 66.2, 69.9, 68.9, 64.4, 55.5, 42.6, 25.8, 7.9, 3.3]
    )
    a, b = 2, 11
    start, end = np.degrees(_edge_offsets(true, a, b, true[a : b + 1]))
    assert abs(start) < 3.0 and abs(end) < 1.5, (start, end)
    start, end = np.degrees(_edge_offsets(true, a, b, true[a : b + 1] - np.radians(30.0)))
    assert 25.0 < start < 35.0 and 15.0 < end < 35.0, (start, end)
    bent = true.copy()
    bent[a - 2 : a] = np.radians([40.0, 37.0])  # outside says +, inside says -
    run = np.radians(np.r_[30.0, 20.0, np.zeros(b - a - 1)])
    assert _edge_offsets(bent, a, b, run)[0] == 0.0


def test_bend_and_twist_rebuild_the_rotation_and_keep_the_bone(takes) -> None:
    """``q = exp(bend) * twist``, the twist turning about the limb alone (it leaves the bone
    where it was), and the bend carrying the bone where ``q`` does."""
    from mocapkit.clean.detect import DetectConfig, Evidence
    from mocapkit.clean.detect.evidence import bend_and_twist

    walk, _ = takes
    ev = Evidence.for_motion(walk, DetectConfig())
    for i, j in enumerate(ev.hinges):
        bone = ev.hinge_bones[i]
        q = np.asarray(walk.rotations[:, j])
        bend, twist = bend_and_twist(q, bone)
        back = rot.quat_mul(rot.rotvec_to_quat(bend), twist)
        assert np.allclose(np.abs(np.sum(back * q, axis=-1)), 1.0, atol=1e-12)
        b = np.broadcast_to(bone / np.linalg.norm(bone), (len(q), 3))
        assert np.allclose(rot.quat_apply(twist, b), b, atol=1e-12)
        assert np.allclose(rot.quat_apply(rot.rotvec_to_quat(bend), b), rot.quat_apply(q, b))
