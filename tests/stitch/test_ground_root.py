"""Root motion that survives a stitch on a ground-root rig (Bandai's joint_Root)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from mocapkit import features
from mocapkit.body import body_of
from mocapkit.core.kinematics import forward_kinematics
from mocapkit.io import read_motion
from mocapkit.stitch import METHODS, stitch


def _read(p):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_motion(p)


def _steps(m):
    pos, _ = forward_kinematics(m)
    body = body_of(m)
    up = features.detect_up_axis(m)
    root = features.ground_coordinates(m.root_positions, up)
    path = features.ground_coordinates(pos[:, body.pelvis], up)
    return (
        np.linalg.norm(np.diff(root, axis=0), axis=1).max(),
        np.linalg.norm(np.diff(path, axis=0), axis=1).max(),
    )


@pytest.mark.shared
def test_ground_root_on_path_keeps_the_body_and_follows_it(shared_path) -> None:
    m = _read(shared_path("bandai1/data") / "dataset-1_walk_normal_001.bvh")
    out = features.ground_root_on_path(m)
    p0, _ = forward_kinematics(m)
    p1, _ = forward_kinematics(out)
    np.testing.assert_allclose(p1[:, 1:], p0[:, 1:], atol=1e-9)  # the body does not move
    root_step, path_step = _steps(out)
    assert root_step <= path_step + 1e-9
    # the root faces where the body faces
    h = features.heading_angles(out)
    q = out.rotations[:, 0]
    yaw = 2 * np.arctan2(q[:, 2], q[:, 0])  # rotation about +Y
    assert np.degrees(np.abs(np.angle(np.exp(1j * (yaw - h))))).max() < 1e-6


@pytest.mark.shared
@pytest.mark.parametrize("method", METHODS)
def test_stitched_bandai_root_is_continuous_and_heading_carried(method, shared_path) -> None:
    folder = shared_path("bandai1/data")
    query = _read(folder / "dataset-1_walk_normal_001.bvh")
    data = [
        _read(folder / n) for n in ("dataset-1_walk_happy_001.bvh", "dataset-1_run_normal_001.bvh")
    ]
    res = stitch(query, "40:80", data, method=method)
    root_step, path_step = _steps(res.motion)
    assert root_step <= 2.0 * path_step, (root_step, path_step)
    h = np.unwrap(features.heading_angles(res.motion))
    a, land = res.transition.takeoff, res.landing_index
    turn = np.degrees(abs(h[land] - h[a]))
    assert turn < 20.0, turn  # straight walks: the data continues the query's heading
