"""in_place and extract_root_motion, on a plain rig and on a ground-root rig (like Bandai's)."""

from __future__ import annotations

import numpy as np
from testsupport import load_sibling

from mocapkit import datasets
from mocapkit.body import body_of
from mocapkit.core.kinematics import forward_kinematics
from mocapkit.edit import extract_root_motion, in_place
from mocapkit.features import ground_frame, heading_angles

with_ground_root = load_sibling(__file__.replace("edit", "stitch"), "motions").with_ground_root


def flat(v: np.ndarray) -> np.ndarray:
    _, u, _ = ground_frame("Y")
    return v - (v @ u)[..., None] * u


def walk():
    return datasets.procedural_motion("walk", 3.0, seed=0).motion


def test_in_place_removes_travel_and_keeps_heights_and_body() -> None:
    m = walk()
    pelvis = body_of(m).pelvis
    pos, _ = forward_kinematics(m)
    assert np.ptp(flat(pos[:, pelvis]), axis=0).max() > 10 * body_of(m).size / 100
    out = in_place(m, "Y")
    pos2, _ = forward_kinematics(out)
    np.testing.assert_allclose(flat(pos2[:, pelvis]), flat(pos[:1, pelvis]).repeat(len(m), 0),
                               atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(pos2[..., 1], pos[..., 1], atol=1e-9)  # heights
    rel, rel2 = pos - pos[:, pelvis : pelvis + 1], pos2 - pos2[:, pelvis : pelvis + 1]
    np.testing.assert_allclose(rel2, rel, atol=1e-9)  # the body's own motion


def test_ground_root_rig_in_place_keeps_the_root_under_the_body() -> None:
    m = with_ground_root(walk())
    body = body_of(m)
    assert body.ground_root == 0
    out = in_place(m, "Y")
    pos, _ = forward_kinematics(out)
    np.testing.assert_allclose(flat(pos[:, body.pelvis]), flat(pos[:, 0]), atol=1e-9)
    assert np.ptp(flat(pos[:, 0]), axis=0).max() < 1e-9  # and it does not move


def test_extract_root_motion_adds_a_ground_root_on_a_plain_rig() -> None:
    m = walk()
    out = extract_root_motion(m, "Y")
    assert out.skeleton.names[0] == "Root" and out.skeleton.names[1:] == m.skeleton.names
    pos, _ = forward_kinematics(m)
    pos2, _ = forward_kinematics(out)
    np.testing.assert_allclose(pos2[:, 1:], pos, atol=1e-9)  # FK of every joint unchanged
    pelvis = body_of(m).pelvis
    np.testing.assert_allclose(flat(pos2[:, 0]), flat(pos[:, pelvis]), atol=1e-9)
    assert body_of(out).ground_root == 0
    # the root turns with the body
    h = heading_angles(m, "Y")
    w = out.rotations[:, 0]
    np.testing.assert_allclose(np.abs(w[:, 0]), np.abs(np.cos(h / 2)), atol=1e-9)
    # and taking its travel out keeps the root still
    still = in_place(out, "Y")
    assert np.ptp(flat(forward_kinematics(still)[0][:, 0]), axis=0).max() < 1e-9


def test_extract_on_ground_root_rig_moves_that_root() -> None:
    m = with_ground_root(walk())
    out = extract_root_motion(m, "Y")
    assert out.num_joints == m.num_joints
    pos, _ = forward_kinematics(m)
    pos2, _ = forward_kinematics(out)
    np.testing.assert_allclose(pos2[:, 1:], pos[:, 1:], atol=1e-9)
    pelvis = body_of(m).pelvis
    np.testing.assert_allclose(flat(pos2[:, 0]), flat(pos[:, pelvis]), atol=1e-9)
