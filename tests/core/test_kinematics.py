"""Forward kinematics: the numba kernel against the readable reference (tests/core/naive.py)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from testsupport import load_sibling

from mocapkit.core import rotations as rot
from mocapkit.core.kinematics import end_site_positions, fk_arrays, forward_kinematics
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton

naive = load_sibling(__file__, "naive")


def random_tree(rng, J):
    parents = np.array([-1] + [int(rng.integers(0, j)) for j in range(1, J)])
    return parents


@settings(max_examples=40, derandomize=True, deadline=None)
@given(J=st.integers(1, 12), F=st.integers(0, 6), seed=st.integers(0, 2**31))
def test_fast_fk_matches_reference(J: int, F: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    parents = random_tree(rng, J)
    q = rot.quat_normalize(rng.normal(size=(F, J, 4)))
    t = rng.normal(size=(F, J, 3)) * 10
    pos, grot = fk_arrays(parents, q, t)
    ref_pos, ref_mats = naive.fk_reference(parents, q, t)
    np.testing.assert_allclose(pos, ref_pos, atol=1e-9)
    np.testing.assert_allclose(rot.quat_to_matrix(grot), ref_mats, atol=1e-12)


def test_fk_of_motion_uses_offsets_root_and_animated_translations() -> None:
    sk = Skeleton(
        ("r", "a", "b"),
        [-1, 0, 1],
        [[0, 1, 0], [0, 2, 0], [1, 0, 0]],
        (
            ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),
            ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),
            ("Zrotation", "Xrotation", "Yrotation"),
        ),
        end_site_parents=[2],
        end_site_offsets=[[0, 0, 3]],
    )
    q = np.tile(rot.quat_identity(), (2, 3, 1))
    q[1, 0] = rot.euler_to_quat(np.array([np.pi / 2, 0, 0]), "ZXY")  # 90 deg about Z
    trans = np.broadcast_to(sk.offsets, (2, 3, 3)).copy()
    trans[:, 1] = [[0, 5, 0], [0, 5, 0]]
    m = Motion(sk, q, [[1, 1, 1], [1, 1, 1]], 0.1, translations=trans)
    pos, grot = forward_kinematics(m)
    np.testing.assert_allclose(pos[0], [[1, 1, 1], [1, 6, 1], [2, 6, 1]], atol=1e-12)
    # frame 1: root turned +90 deg about Z: (0,5,0) -> (-5,0,0), (1,0,0) -> (0,1,0)
    np.testing.assert_allclose(pos[1], [[1, 1, 1], [-4, 1, 1], [-4, 2, 1]], atol=1e-12)
    es = end_site_positions(sk, pos, grot)
    np.testing.assert_allclose(es[:, 0], [[2, 6, 4], [-4, 2, 4]], atol=1e-12)


def test_fk_validates_input() -> None:
    with pytest.raises(ValueError, match="parents"):
        fk_arrays(np.array([-1, 1]), np.zeros((1, 2, 4)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="rotations"):
        fk_arrays(np.array([-1]), np.zeros((1, 1, 3)), np.zeros((1, 3)))
