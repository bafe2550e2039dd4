"""rename_joints and drop_joints: FK of the kept joints is unchanged (hypothesis, random trees)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from testsupport import load_sibling

from mocapkit import datasets
from mocapkit.core import rotations as rot
from mocapkit.core.kinematics import end_site_positions, forward_kinematics
from mocapkit.core.motion import Motion
from mocapkit.edit import drop_joints, rename_joints
from mocapkit.io import read_motion, write_motion

rigs = load_sibling(__file__, "rigs")


def assert_kept_fk_equal(m: Motion, out: Motion, kept: list[int]) -> None:
    pos, grot = forward_kinematics(m)
    pos2, grot2 = forward_kinematics(out)
    np.testing.assert_allclose(pos2, pos[:, kept], atol=1e-9 * max(1.0, np.abs(pos).max()))
    assert np.all(rot.quat_angle(grot2, grot[:, kept]) < 1e-9)


@settings(max_examples=60, derandomize=True, deadline=None)
@given(
    J=st.integers(2, 14),
    F=st.integers(1, 5),
    seed=st.integers(0, 2**31),
    six=st.sampled_from([0.0, 0.3]),
    still=st.booleans(),
)
def test_drop_joints_keeps_fk_of_kept_joints(
    J: int, F: int, seed: int, six: float, still: bool
) -> None:
    rng = np.random.default_rng(seed)
    m = rigs.random_motion(rng, J, F, six_every=six)
    drop = [j for j in range(1, J) if rng.random() < 0.4] or [J - 1]
    if still:  # dropped joints that never rotate: the chain folds into constant offsets
        m.rotations[:, drop] = rot.quat_identity()
    out = drop_joints(m, drop)
    kept = [j for j in range(J) if j not in drop]
    assert out.skeleton.names == tuple(m.skeleton.names[j] for j in kept)
    assert_kept_fk_equal(m, out, kept)
    if still and six == 0.0:
        assert out.translations is None  # nothing needed position channels
    # End Sites of kept joints stay where they were
    es_keep = [e for e, p in enumerate(m.skeleton.end_site_parents) if p in kept]
    pos, grot = forward_kinematics(m)
    pos2, grot2 = forward_kinematics(out)
    np.testing.assert_allclose(
        end_site_positions(out.skeleton, pos2, grot2),
        end_site_positions(m.skeleton, pos, grot)[:, es_keep],
        atol=1e-9 * max(1.0, np.abs(pos).max()),
    )


def test_drop_by_regex_survives_bvh_and_refuses_the_root(tmp_path) -> None:
    m = datasets.procedural_motion("walk", 1.0, seed=0).motion
    names = m.skeleton.names
    spine = [n for n in names if "Spine" in n]
    assert spine
    out = drop_joints(m, ".*Spine.*")
    kept = [j for j, n in enumerate(names) if n not in spine]
    assert_kept_fk_equal(m, out, kept)
    back = read_motion(write_motion(out, tmp_path / "d.bvh"))
    pos, _ = forward_kinematics(m)
    np.testing.assert_allclose(forward_kinematics(back)[0], pos[:, kept], atol=1e-4)
    with pytest.raises(ValueError, match="cannot drop the root"):
        drop_joints(m, ".*")
    with pytest.raises(ValueError, match="no joint matches"):
        drop_joints(m, "Nothing")
    with pytest.raises(ValueError, match="bad regular expression"):
        drop_joints(m, "(")


def test_rename_joints() -> None:
    m = datasets.procedural_motion("idle", 0.5, seed=0).motion
    first, second = m.skeleton.names[:2]
    out = rename_joints(m, {first: "root_renamed"})
    assert out.skeleton.names[0] == "root_renamed" and out.skeleton.names[1] == second
    assert np.array_equal(out.rotations, m.rotations)
    with pytest.raises(KeyError, match="no joint named 'Nope'"):
        rename_joints(m, {"Nope": "x"})
    with pytest.raises(ValueError, match="two joints would be called"):
        rename_joints(m, {first: second})
    with pytest.raises(ValueError, match="no blanks"):
        rename_joints(m, {first: "a b"})
