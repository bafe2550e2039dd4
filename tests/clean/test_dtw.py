"""Constrained DTW and pose distances: fast kernels against the readable references."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mocapkit.clean import dtw
from mocapkit.clean.words import JointGroup
from mocapkit.core import rotations as rot

from . import naive


def _unit_quats(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    q = rng.normal(size=(*shape, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(1, 5),
    m=st.integers(1, 6),
    max_run=st.integers(0, 3),
    seed=st.integers(0, 10_000),
)
def test_dtw_matches_brute_force(n: int, m: int, max_run: int, seed: int) -> None:
    D = np.random.default_rng(seed).random((n, m))
    ref, _ = naive.constrained_dtw(D, max_run)
    mean, path = dtw.constrained_dtw(D, max_run)
    assert mean == pytest.approx(ref, rel=1e-12, abs=1e-12)
    assert dtw.dtw_mean_cost(D, max_run) == pytest.approx(ref, rel=1e-12, abs=1e-12)
    assert naive.dtw_dp(D, max_run) == pytest.approx(ref, rel=1e-12, abs=1e-12)
    # the path is valid and its mean is the reported cost
    assert tuple(path[0]) == (0, 0)
    assert path[-1, 0] == n - 1 or path[-1, 1] == m - 1
    steps = np.diff(path, axis=0)
    assert all(tuple(s) in {(1, 0), (0, 1), (1, 1)} for s in steps)
    assert D[path[:, 0], path[:, 1]].mean() == pytest.approx(mean)


def test_slope_constraint_limits_runs() -> None:
    rng = np.random.default_rng(1)
    for _ in range(50):
        D = rng.random((8, 11))
        _, path = dtw.constrained_dtw(D, 2)
        steps = [tuple(s) for s in np.diff(path, axis=0)]
        run = 0
        prev = None
        for s in steps:
            run = run + 1 if (s == prev and s != (1, 1)) else 1
            assert s == (1, 1) or run <= 2
            prev = s
        # only the last cell lies on the last row/column
        assert not np.any((path[:-1, 0] == 7) | (path[:-1, 1] == 10))


def test_scan_words_equals_per_block_dtw() -> None:
    rng = np.random.default_rng(2)
    D = rng.random((40, 90)).astype(np.float32)
    starts = np.array([0, 5, 10, 25])
    tst = np.arange(0, 70, 3)
    for max_run in (0, 1, 2, 3):
        out = dtw.scan_words(D, starts, 15, tst, 20, max_run)
        for w, a in enumerate(starts):
            for c, t in enumerate(tst):
                ref = dtw.dtw_mean_cost(D[a : a + 15, t : t + 20].astype(np.float64), max_run)
                assert out[w, c] == pytest.approx(ref, rel=1e-9)


def test_specialised_kernel_equals_generic() -> None:
    rng = np.random.default_rng(3)
    D = rng.random((30, 80)).astype(np.float32)
    for n, m in ((15, 20), (3, 5), (2, 2), (1, 4), (5, 1), (12, 12)):
        starts = np.arange(0, 30 - n + 1, 4)
        tst = np.arange(0, 80 - m + 1)
        fast = dtw.scan_words(D, starts, n, tst, m, 2)
        gen = np.empty_like(fast)
        dtw._scan_kernel(D, starts, n, tst, m, 2, gen)
        np.testing.assert_array_equal(fast, gen)


def test_unconstrained_dtw_against_dtaidistance() -> None:
    """With no slope constraint and a sentinel frame closing both series, the open-end DTW must
    end at the sentinel, so its cost is the classic DTW cost (dtaidistance: sqrt of the summed
    squared differences)."""
    dtaw = pytest.importorskip("dtaidistance.dtw")
    rng = np.random.default_rng(4)
    for _ in range(20):
        a = rng.normal(size=rng.integers(3, 15))
        b = rng.normal(size=rng.integers(3, 15))
        big = 1e3
        a2 = np.concatenate([a, [big]])
        b2 = np.concatenate([b, [big]])
        D = (a2[:, None] - b2[None, :]) ** 2
        mean, path = dtw.constrained_dtw(D, 0)
        assert tuple(path[-1]) == (len(a), len(b))
        ref = dtaw.distance(a, b, use_c=False)
        assert np.sqrt(mean * len(path)) == pytest.approx(ref, rel=1e-9)


def test_pose_distance_matrices_match_log_map_reference() -> None:
    rng = np.random.default_rng(5)
    src = _unit_quats(rng, (6, 7))
    ctx = _unit_quats(rng, (9, 7))
    groups = [
        JointGroup("all", tuple(range(7)), 3),
        JointGroup("sub", (1, 2, 4), 1),
        JointGroup("plain", (0, 5), 0),
    ]
    out = dtw.pose_distance_matrices(src, ctx, groups)
    assert out.shape == (3, 6, 9) and out.dtype == np.float32
    for g, grp in enumerate(groups):
        js = list(grp.joints)
        for a in range(6):
            for b in range(9):
                ref = naive.pose_distance(src[a, js], ctx[b, js], grp.trim)
                assert out[g, a, b] == pytest.approx(ref, rel=1e-5, abs=1e-6)
    # sign of the quaternion does not matter, identical poses are at distance 0
    same = dtw.pose_distance_matrices(src, -src, groups[:1])[0]
    assert np.allclose(np.diag(same), 0.0, atol=1e-6)


def test_pose_distance_numpy_helper_agrees() -> None:
    rng = np.random.default_rng(6)
    a = _unit_quats(rng, (5,))
    b = rot.quat_mul(a, rot.rotvec_to_quat(rng.normal(scale=0.3, size=(5, 3))))
    assert dtw.pose_distance(a, b, 1) == pytest.approx(naive.pose_distance(a, b, 1))


def test_validation() -> None:
    with pytest.raises(ValueError):
        dtw.constrained_dtw(np.zeros((0, 3)))
    with pytest.raises(ValueError):
        dtw.constrained_dtw(np.array([[np.nan]]))
    with pytest.raises(ValueError):
        dtw.constrained_dtw(np.ones((2, 2)), -1)
    with pytest.raises(ValueError):
        dtw.scan_words(np.ones((10, 10)), np.array([0]), 15, np.array([0]), 5)
    with pytest.raises(ValueError):
        dtw.pose_distance_matrices(
            np.ones((2, 3, 4)), np.ones((2, 4, 4)), [JointGroup("a", (0, 1))]
        )
    with pytest.raises(ValueError):
        JointGroup("a", (0, 1), trim=2)
