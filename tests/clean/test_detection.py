"""Detection rules on top of the MDM: hysteresis seeds, jumps, frozen joints, dominance."""

from __future__ import annotations

import numpy as np
import pytest

from mocapkit import datasets
from mocapkit.clean import SelfSimilarityCleaner, inject
from mocapkit.clean import mdm as mdm_mod
from mocapkit.core import rotations as rot


def test_hysteresis_keeps_only_seeded_runs() -> None:
    weak = np.zeros((12, 2), dtype=bool)
    weak[2:6, 0] = True
    weak[8:11, 0] = True
    weak[1:4, 1] = True
    strong = np.zeros_like(weak)
    strong[4, 0] = True
    out = mdm_mod.hysteresis(weak, strong)
    assert out[2:6, 0].all() and not out[8:11, 0].any() and not out[:, 1].any()


def test_angular_acceleration_sees_a_kink_not_a_steady_turn() -> None:
    t = np.arange(20)
    q = rot.rotvec_to_quat(np.stack([0.05 * t, 0 * t, 0 * t], axis=1))[:, None]
    a = mdm_mod.angular_acceleration(q)
    assert a.shape == (20, 1) and np.allclose(a, 0.0, atol=1e-9)
    q2 = q.copy()
    q2[10, 0] = rot.quat_mul(q[10, 0], rot.rotvec_to_quat(np.array([0.0, 0.5, 0.0])))
    a2 = mdm_mod.angular_acceleration(q2)
    assert a2[9:12, 0].min() > 0.4 and np.allclose(a2[:8, 0], 0.0, atol=1e-9)


def test_frozen_cells_need_a_moving_context_and_a_value_that_does_not_recur() -> None:
    F = 60
    t = np.linspace(0, 4 * np.pi, F)
    q = rot.rotvec_to_quat(np.stack([0.6 * np.sin(t), 0 * t, 0 * t], axis=1))[:, None]
    frozen = q.copy()
    frozen[20:35, 0] = q[20, 0]
    dig = rot.quat_angle(frozen, q)
    out = mdm_mod.frozen_cells(frozen, dig, min_frames=10)
    assert out[22:35, 0].all() and not out[:19, 0].any() and not out[37:, 0].any()
    # no digression there: the KNN words hold still too
    assert not mdm_mod.frozen_cells(frozen, np.zeros_like(dig), min_frames=10).any()
    # a joint parked at a limit it keeps returning to is not frozen
    limit = np.clip(np.sin(t), -0.3, None)
    ql = rot.rotvec_to_quat(np.stack([limit, 0 * t, 0 * t], axis=1))[:, None]
    assert not mdm_mod.frozen_cells(ql, np.full((F, 1), 1.0), min_frames=5).any()


def test_dominated_runs() -> None:
    mask = np.zeros((10, 3), dtype=bool)
    mask[3:6, 0] = True
    mask[3:6, 1] = True
    z = np.zeros((10, 3))
    z[3:6, 0] = 1.5
    z[3:6, 1] = 10.0
    keep = np.zeros_like(mask)
    out = mdm_mod.dominated_runs(mask, z, keep, 0.5, 2)
    assert out[3:6, 0].all() and not out[:, 1].any()
    keep[4, 0] = True
    assert not mdm_mod.dominated_runs(mask, z, keep, 0.5, 2).any()
    assert not mdm_mod.dominated_runs(mask, z, np.zeros_like(mask), 0.0, 2).any()


@pytest.fixture(scope="module")
def frozen_take():
    walk = datasets.procedural_motion("walk", seconds=6.0, seed=5).motion
    ctx = datasets.procedural_motion("walk", seconds=6.0, seed=6).motion
    names = list(walk.skeleton.names)
    inj = inject(walk, "frozen", names.index("LeftForeArm"), np.random.default_rng(3), start=60)
    return inj, ctx


def test_frozen_joint_is_flagged_and_paper_mode_is_a_plain_threshold(frozen_take) -> None:
    inj, ctx = frozen_take
    cl = SelfSimilarityCleaner().fit(inj.motion, [ctx])
    m = cl.mask()
    assert m[inj.frames, inj.joint].mean() > 0.8
    plain = SelfSimilarityCleaner(detect="threshold").fit(inj.motion, [ctx])
    assert np.array_equal(plain.mask(), plain.scores() > 0.5)
    assert np.array_equal(plain.mask(0.7), plain.scores() > 0.7)
    with pytest.raises(ValueError):
        SelfSimilarityCleaner(detect="nope")
