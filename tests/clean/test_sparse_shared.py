"""Sparse reconstruction, and detection on the shared Bandai captures (skipped without them)."""

from __future__ import annotations

import numpy as np
import pytest

from mocapkit import datasets
from mocapkit.clean import SelfSimilarityCleaner, reconstruct
from mocapkit.clean.evaluate import corrupt, unit_matrix
from mocapkit.clean.texture import rotating_joints
from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion

KEEP = ["Neck", "LeftArm", "RightArm", "LeftForeArm", "RightForeArm", "LeftUpLeg", "RightUpLeg",
        "LeftLeg", "RightLeg"]  # fmt: skip


def test_reconstruct_from_sparse_joints() -> None:
    take = datasets.procedural_motion("walk", seconds=4.0, seed=11).motion
    db = [datasets.procedural_motion("walk", seconds=5.0, seed=s).motion for s in (12, 13)]
    names = list(take.skeleton.names)
    rec = reconstruct(take, db, KEEP)
    assert rec.num_joints == take.num_joints and rec.num_frames == take.num_frames
    kidx = [names.index(n) for n in KEEP]
    assert np.array_equal(rec.rotations[:, kidx], take.rotations[:, kidx])
    unknown = [j for j in range(take.num_joints) if j not in kidx and j != 0]
    err = np.degrees(rot.quat_angle(rec.rotations[:, unknown], take.rotations[:, unknown]))
    naive = np.degrees(rot.quat_angle(np.array([1.0, 0, 0, 0]), take.rotations[:, unknown]))
    assert err.mean() < 0.5 * naive.mean()
    # a reduced skeleton (joint subset by name) works too
    sub = Motion(take.skeleton, take.rotations, take.root_positions, take.frame_time)
    assert reconstruct(sub, db, KEEP[:4]).num_joints == take.num_joints
    with pytest.raises(ValueError):
        reconstruct(take, db, ["Nope"])
    with pytest.raises(ValueError):
        reconstruct(take, [], KEEP)


@pytest.mark.shared
def test_detection_on_bandai_walks(shared_path) -> None:
    from mocapkit.io import read_motion

    d = shared_path("bandai1/data")
    files = sorted(d.glob("dataset-1_walk_*_001.bvh"))[:4]
    take, ctx = read_motion(files[0]), [read_motion(f) for f in files[1:]]
    act = np.flatnonzero(rotating_joints(take))
    cor = corrupt(take, np.random.default_rng(0), kinds=["spike", "offset", "flip"], joints=act)
    cl = SelfSimilarityCleaner().fit(cor.motion, ctx)
    t = unit_matrix(cor.truth, take.fps)[:, act]
    f = unit_matrix(cl.mask(), take.fps)[:, act]
    assert (t & f).sum() / t.sum() >= 0.9
    res = cl.repair()
    assert np.array_equal(res.motion.rotations[~res.written], cor.motion.rotations[~res.written])


@pytest.mark.shared
def test_reconstructed_bandai_take_walks_with_its_ground_root_under_it(shared_path) -> None:
    """A Bandai body travels through its Hips' position channels (joint_Root stays at the
    origin in the files): the reconstruction keeps that travel, and its ground root follows
    the body's ground path with steps no larger than the body's (issue: root motion)."""
    from mocapkit.body import body_of
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.edit.joints import drop_joints
    from mocapkit.io import read_motion

    d = shared_path("bandai2/data")
    take = read_motion(d / "dataset-2_walk_normal_013.bvh")
    db = [read_motion(d / f"dataset-2_walk_normal_{n:03d}.bvh") for n in (1, 5, 9)]
    sparse = drop_joints(take, r".*(Lower|Hand|Foot|Toe).*")
    full = reconstruct(sparse, db)
    b = body_of(full)
    p, _ = forward_kinematics(full)
    q, _ = forward_kinematics(take)
    ground = [0, 2]  # Y up
    pel = p[:, b.pelvis][:, ground]
    np.testing.assert_allclose(pel, q[:, b.pelvis][:, ground], atol=1e-6)  # the same travel
    assert np.linalg.norm(pel[-1] - pel[0]) > 100.0  # cm: it walks
    root = p[:, b.ground_root][:, ground]
    step = np.linalg.norm(np.diff(root, axis=0), axis=1).max()
    body = np.linalg.norm(np.diff(pel, axis=0), axis=1).max()
    assert step <= 2.0 * body
    assert np.linalg.norm(root - pel, axis=1).max() < 1.0  # under the body, not at the origin
