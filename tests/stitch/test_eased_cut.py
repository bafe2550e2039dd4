"""A stitch with no injected frame (k = 0, which the elastic L-score often picks) is a cut: its
landing is eased in from where the query was heading, and a foot planted across it stays."""

from __future__ import annotations

import numpy as np
import pytest

from mocapkit import datasets
from mocapkit.core.kinematics import forward_kinematics
from mocapkit.edit import mirror
from mocapkit.io import read_motion
from mocapkit.stitch import stitch


def _worst_jolt(motion, own, around: slice) -> float:
    """The largest joint acceleration in ``around`` over the takes' own 99th percentile (per
    joint, joints that move only)."""
    pos, _ = forward_kinematics(motion)
    acc = np.linalg.norm(pos[2:] - 2 * pos[1:-1] + pos[:-2], axis=-1)[around]
    moves = own > 1e-6
    return float((acc[:, moves] / own[moves]).max())


def _own_p99(*takes) -> np.ndarray:
    accs = []
    for m in takes:
        pos, _ = forward_kinematics(m)
        accs.append(np.linalg.norm(pos[2:] - 2 * pos[1:-1] + pos[:-2], axis=-1))
    return np.percentile(np.concatenate(accs), 99, axis=0)


def test_a_cut_from_a_walk_into_a_run_is_eased() -> None:
    """Forced k = 0 between a walk and a run: played as a cut, a joint jolted 6.8 times the
    takes' own 99th-percentile acceleration; eased, 2.3 times."""
    walk = datasets.procedural_motion("walk", seconds=4.0, seed=1).motion
    run = datasets.procedural_motion("run", seconds=4.0, seed=2).motion
    res = stitch(walk, "40:60", [run], inject=0)
    a = res.takeoff
    own = _own_p99(walk, run)
    assert _worst_jolt(res.motion, own, slice(a - 3, a + 12)) < 3.0
    # the query's frames are the query's; the data clip plays as it is after the eased frames
    np.testing.assert_array_equal(res.motion.rotations[: a + 1], walk.rotations[: a + 1])
    assert res.motion.num_frames - res.landing_index == run.num_frames - res.landing_played


def test_a_bandai_walk_stitched_to_its_mirror_at_a_cut(shared_path) -> None:
    """Newcomer report: `stitch walk.bvh walk_mirrored.bvh --takeoff 60:150` chose k = 0 (landing
    117, take-off 133) and played it as a cut: the swinging foot moved 11.4, 2.2, then 12.0 cm
    a frame and the planted one jumped 4.9 cm (joint accelerations 3.5 times the walk's own
    99th percentile). Eased: under twice it, and the planted foot's joints move under 1.5 cm a
    frame (the toe rolls a little as the heel lifts)."""
    path = shared_path("bandai1/data/dataset-1_walk_normal_001.bvh")
    walk = read_motion(path)
    mirrored = mirror(walk).motion
    res = stitch(walk, "60:150", [mirrored])
    if res.k != 0:
        pytest.fail(f"the search chose k = {res.k}: this test needs the cut it chose before")
    a = res.takeoff
    assert _worst_jolt(res.motion, _own_p99(walk), slice(a - 3, a + 12)) < 2.0
    from mocapkit.features import foot_contacts

    pos, _ = forward_kinematics(res.motion)
    contacts = foot_contacts(res.motion)
    held = 0
    for c, j in enumerate(contacts.joints):  # a foot on the ground across the cut stays put
        run = contacts.contacts[a:, c]
        n = int(np.argmin(run)) if not run.all() else len(run)  # frames it stays planted
        if run[0] and n > 1:
            steps = np.linalg.norm(np.diff(pos[a : a + n, j], axis=0), axis=-1)
            assert steps.max() < 1.5, (walk.skeleton.names[j], steps)
            held += 1
    assert held
