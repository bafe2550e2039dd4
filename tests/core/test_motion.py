"""Skeleton and Motion containers: validation, slicing, concatenation, copies, equality."""

from __future__ import annotations

import numpy as np
import pytest

from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion, concatenate, fill_missing
from mocapkit.core.skeleton import Skeleton

ROT = ("Zrotation", "Xrotation", "Yrotation")
ROOT = ("Xposition", "Yposition", "Zposition", *ROT)


def make_motion(F: int = 10, seed: int = 0) -> Motion:
    rng = np.random.default_rng(seed)
    sk = Skeleton(
        ("hips", "spine", "head"),
        [-1, 0, 1],
        [[0, 1, 0], [0, 0.2, 0], [0, 0.3, 0]],
        (ROOT, ROT, ROT),
        [2],
        [[0, 0.1, 0]],
    )
    q = rot.quat_normalize(rng.normal(size=(F, 3, 4)))
    return Motion(sk, q, rng.normal(size=(F, 3)), 1 / 30)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"parents": [0, 0, 1]}, "parents"),
        ({"parents": [-1, 2, 1]}, "parents"),
        ({"names": ("a", "a", "b")}, "duplicate joint names"),
        ({"channels": (ROOT, ("Zrotation", "Xrotation"), ROT)}, "rotation channels"),
        ({"channels": (ROOT, ("Wrotation", "Xrotation", "Yrotation"), ROT)}, "invalid channels"),
        ({"offsets": [[0, np.nan, 0], [0, 0, 0], [0, 0, 0]]}, "NaN"),
        ({"names": ("a", "b")}, "same length"),
    ],
)
def test_skeleton_validation(kwargs, match) -> None:
    base = {
        "names": ("a", "b", "c"),
        "parents": [-1, 0, 1],
        "offsets": np.zeros((3, 3)),
        "channels": (ROOT, ROT, ROT),
    }
    base.update(kwargs)
    with pytest.raises(ValueError, match=match):
        Skeleton(**base)


def test_skeleton_is_immutable_and_reorders_channels() -> None:
    m = make_motion()
    with pytest.raises(ValueError):
        m.skeleton.offsets[0, 0] = 5.0
    sk = m.skeleton.with_rotation_order("yxz")
    assert sk.rotation_orders == ("YXZ",) * 3
    assert sk.channels[0][:3] == ("Xposition", "Yposition", "Zposition")
    assert m.skeleton.index("spine") == 1
    with pytest.raises(KeyError, match="nope"):
        m.skeleton.index("nope")


def test_slicing_is_a_copy_and_keeps_frame_time() -> None:
    m = make_motion()
    part = m[2:5]
    assert part.num_frames == 3 and part.frame_time == m.frame_time
    part.rotations[:] = 0
    assert not np.all(m.rotations[2:5] == 0)
    np.testing.assert_array_equal(m[[0, 9]].root_positions, m.root_positions[[0, 9]])
    assert m[-1].num_frames == 1 and m[3].num_frames == 1
    assert m.slice_seconds(0.1, 0.2).num_frames == 3  # frames 3, 4, 5 at 30 fps
    assert m.seconds_to_frames(1.0) == 30


def test_concatenate_and_duration() -> None:
    m = make_motion()
    both = concatenate([m[:4], m[4:]])
    assert both.allclose(m, rot_atol=1e-12, pos_atol=0)
    assert both.duration == pytest.approx(10 / 30)
    other = Motion(m.skeleton.scaled(2.0), m.rotations, m.root_positions, m.frame_time)
    with pytest.raises(ValueError, match="different skeletons"):
        concatenate([m, other])
    with pytest.raises(ValueError, match="frame times"):
        concatenate([m, Motion(m.skeleton, m.rotations, m.root_positions, 1 / 60)])


def test_allclose_treats_q_and_minus_q_as_equal() -> None:
    m = make_motion()
    flipped = m.copy()
    flipped.rotations[::2] *= -1
    assert flipped.allclose(m)
    flipped.rotations[0, 1] = rot.quat_mul(
        flipped.rotations[0, 1], rot.rotvec_to_quat(np.array([1e-3, 0, 0]))
    )
    assert not flipped.allclose(m)
    assert flipped.allclose(m, rot_atol=2e-3)


def test_motion_validation() -> None:
    m = make_motion()
    with pytest.raises(ValueError, match="rotations must be"):
        Motion(m.skeleton, m.rotations[:, :2], m.root_positions, 0.1)
    with pytest.raises(ValueError, match="frame_time"):
        Motion(m.skeleton, m.rotations, m.root_positions, 0.0)
    bad = m.copy()
    bad.root_positions[4, 1] = np.inf
    with pytest.raises(ValueError, match="non-finite root position at frame 4"):
        bad.check_finite()


def test_fill_missing_slerps_rotations_and_interpolates_positions() -> None:
    m = make_motion(F=6)
    truth = m.copy()
    a, b = m.rotations[1, 2], m.rotations[4, 2]
    for i, t in ((2, 1 / 3), (3, 2 / 3)):
        truth.rotations[i, 2] = rot.quat_slerp(a, b, t)
    m.rotations[2:4, 2] = np.nan
    m.root_positions[0] = np.nan
    fixed, touched = fill_missing(m)
    assert touched == ["hips", "head"]
    assert np.all(rot.quat_angle(fixed.rotations, truth.rotations) < 1e-12)
    np.testing.assert_array_equal(fixed.root_positions[0], m.root_positions[1])
    assert np.isnan(m.rotations[2, 2, 0]), "input must not be modified"


def test_an_int_index_past_either_end_is_an_index_error() -> None:
    """motion[k] past the end used to give an empty Motion, so iterating a Motion (a take passed
    where a list of takes was expected) never ended."""
    from mocapkit import datasets

    m = datasets.procedural_motion("walk", 1.0).motion
    assert m[-1].allclose(m[m.num_frames - 1 :]) and m[0].num_frames == 1
    with pytest.raises(IndexError, match="out of range"):
        m[m.num_frames]
    with pytest.raises(IndexError, match="out of range"):
        m[-m.num_frames - 1]
    assert len(list(iter(m))) == m.num_frames
