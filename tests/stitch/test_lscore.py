"""Tests for mocapkit.stitch.lscore: fast L / L_k against the readable references and the paper's
Eq. 3 written out (tests/stitch/naive.py), the properties that truly hold, k_opt ≈ g on curves
with g frames removed, and the landing search."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from testsupport import load_sibling

from mocapkit.stitch import (
    DEFAULT_MODEL,
    ConstantAccelerationModel,
    elastic_lscore,
    elastic_lscores,
    elastic_mask,
    elastic_operators,
    lscore,
    search_clips,
    search_landings,
    sliding_windows,
    windowed_euclidean,
)

naive = load_sibling(__file__, "naive")

SETTINGS = settings(max_examples=15, deadline=None, derandomize=True)
OTHER_MODEL = ConstantAccelerationModel(dt=0.5, gammas=(1e-2, 3e-3, 1e-4), sigma=0.05)


def random_windows(seed: int, n: int, w: int, m: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    walk = np.cumsum(rng.normal(size=(n, 2 * w, m)), axis=1)
    return walk * rng.uniform(0.1, 5) + rng.normal(size=(n, 1, m)) * 30


def smooth_curves(t: np.ndarray, m: int, rng, periods=(60, 120)) -> np.ndarray:
    """(len(t), m) sums of two sinusoids per dimension, periods in frames."""
    out = np.zeros((t.shape[0], m))
    for _ in range(2):
        per = rng.uniform(*periods, size=m)
        out += rng.uniform(1, 10, size=m) * np.sin(
            2 * np.pi * t[:, None] / per + rng.uniform(0, 7, m)
        )
    return out


def rel_close(a, b, tol):
    np.testing.assert_allclose(a, b, rtol=0, atol=tol * max(1e-12, float(np.abs(b).max())))


# --------------------------------------------------------------------------- against references


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), w=st.integers(3, 6), m=st.integers(1, 4))
def test_lscore_matches_reference(seed, w, m):
    Y = random_windows(seed, 3, w, m)
    for model in (DEFAULT_MODEL, OTHER_MODEL):
        rel_close(lscore(Y, model), naive.lscore_reference(Y, model), 1e-9)


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), w=st.integers(3, 5), m=st.integers(1, 3))
def test_elastic_lscores_match_reference(seed, w, m):
    Y = random_windows(seed, 2, w, m)
    fast = elastic_lscores(Y, DEFAULT_MODEL, w, k_max=6)
    assert fast.shape == (2, 7)
    rel_close(fast, naive.elastic_lscores_reference(Y, DEFAULT_MODEL, w, k_max=6), 1e-9)


def test_elastic_lscores_match_eq3_written_out():
    Y = random_windows(5, 1, 5, 3)
    fast = elastic_lscores(Y, OTHER_MODEL, k_max=4)[0]
    direct = [naive.lk_direct(Y[0], OTHER_MODEL, 5, k) for k in range(5)]
    rel_close(fast, np.array(direct), 1e-9)


def test_elastic_lscore_single_window_matches_reference():
    Y = random_windows(9, 1, 5, 3)[0]
    fast, ref = elastic_lscore(Y, k_max=8), naive.elastic_lscore_reference(Y, k_max=8)
    assert fast.k_opt == ref.k_opt == int(np.argmin(ref.scores))
    assert fast.lstar == pytest.approx(ref.lstar, rel=1e-9)
    assert fast.trajectory.shape == (10 + fast.k_opt, 3)
    rel_close(fast.trajectory, ref.trajectory, 1e-9)
    rel_close(fast.scores, ref.scores, 1e-9)


def test_l0_is_lscore_and_operators_have_expected_shapes():
    Y = random_windows(1, 4, 5, 6)
    np.testing.assert_allclose(elastic_lscores(Y, k_max=3)[:, 0], lscore(Y), rtol=1e-12)
    for k in (0, 1, 7):
        D, A = elastic_operators(DEFAULT_MODEL, 5, k)
        assert D.shape == A.shape == (2 * 5 + k - 1, 10)
    assert elastic_mask(3, 2).tolist() == [True] * 3 + [False] * 2 + [True] * 3


# --------------------------------------------------------------------------- properties


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), c=st.floats(-5, 5).filter(lambda c: abs(c) > 0.05))
def test_translation_invariance_and_quadratic_scaling(seed, c):
    rng = np.random.default_rng(seed)
    Y = random_windows(seed, 3, 5, 4)
    base = elastic_lscores(Y, k_max=5)
    shift = rng.normal(size=(1, 1, 4)) * 100
    rel_close(elastic_lscores(Y + shift, k_max=5), base, 1e-7)  # constant offset per dimension
    rel_close(elastic_lscores(c * Y, k_max=5), c * c * base, 1e-9)  # L(cY) = c² L(Y)


def test_sum_over_dimensions_and_permutation():
    Y = random_windows(2, 3, 5, 5)
    per_dim = sum(lscore(Y[:, :, d : d + 1]) for d in range(5))
    np.testing.assert_allclose(lscore(Y), per_dim, rtol=1e-12)
    np.testing.assert_allclose(lscore(Y[:, :, ::-1]), lscore(Y), rtol=1e-12)


def test_straight_line_with_gap_gives_zero_at_true_k():
    # a constant-velocity line is reproduced exactly, so L_g = 0 and every other k costs effort
    t = np.arange(30.0)
    line = np.c_[2.0 * t, -0.5 * t + 3.0, 0.1 * t]
    for g in (0, 1, 4, 9):
        Y = np.r_[line[:5], line[5 + g : 10 + g]]
        res = elastic_lscore(Y, k_max=12)
        assert res.k_opt == g
        assert res.lstar < 1e-9
        assert np.all(np.delete(res.scores, g) > 1e-3)
        np.testing.assert_allclose(res.trajectory, line[: 10 + g], atol=1e-9)  # gap refilled


@pytest.mark.parametrize("g", [0, 1, 2, 3, 5])
def test_kopt_recovers_gap_on_smooth_curves(g):
    # remove g frames from slow smooth curves; k_opt must be g (±1 for the longer gaps)
    rng = np.random.default_rng(100 + g)
    t = np.arange(40.0)
    errors = []
    for _ in range(8):
        curve = smooth_curves(t, 6, rng, periods=(90, 180))
        s = int(rng.integers(0, 20))
        Y = np.r_[curve[s : s + 5], curve[s + 5 + g : s + 10 + g]]
        errors.append(abs(elastic_lscore(Y, k_max=15).k_opt - g))
    assert np.median(errors) == 0
    assert max(errors) <= 1


@pytest.mark.parametrize("g, lo, hi", [(2, 2, 3), (11, 11, 18)])
def test_eq3_without_normalisation_on_a_circle(g, lo, hi):
    # the paper's blank-out experiment on a waving-like circle (radius 10, period 60 frames):
    # it reports k_opt = 2 for g = 2 and 14 for g = 11. The plain sum of Eq. 3 lands there;
    # the per-step reading L_k / (2w + k - 1) decreases all the way to k_max instead.
    th = 2 * np.pi * np.arange(60.0) / 60
    circle = np.c_[10 * np.cos(th), 10 * np.sin(th)]
    Y = np.r_[circle[:5], circle[5 + g : 10 + g]]
    scores = elastic_lscores(Y, k_max=30)[0]
    assert lo <= int(np.argmin(scores)) <= hi
    assert int(np.argmin(scores / (9 + np.arange(31)))) == 30


def test_windowed_euclidean():
    Y = random_windows(4, 3, 5, 2)
    expected = [np.sqrt(((y[:5] - y[5:]) ** 2).sum()) for y in Y]
    np.testing.assert_allclose(windowed_euclidean(Y), expected, rtol=1e-12)
    same = np.concatenate([Y[:, :5], Y[:, :5]], axis=1)
    np.testing.assert_array_equal(windowed_euclidean(same), 0.0)
    assert windowed_euclidean(Y[0]).shape == (1,)


def test_input_validation():
    Y = random_windows(0, 2, 5, 3)
    with pytest.raises(ValueError):
        lscore(Y, w=4)  # 10 frames != 2w
    with pytest.raises(ValueError):
        lscore(random_windows(0, 2, 2, 3))  # w = 2 < 3
    with pytest.raises(ValueError):
        lscore(np.zeros((2, 10, 3, 1)))
    with pytest.raises(ValueError, match="one window"):
        elastic_lscore(Y)
    with pytest.raises(ValueError):
        elastic_lscores(Y, k_max=-1)
    Q, X = Y[0], Y[1]
    for kwargs in ({"k_max": -1}, {"dtype": np.int32}, {"block": 0}, {"w": 2}):
        with pytest.raises(ValueError):
            search_landings(Q, 6, X, **kwargs)


# --------------------------------------------------------------------------- windows and search


def test_sliding_windows():
    rng = np.random.default_rng(0)
    Q, X = rng.normal(size=(30, 4)), rng.normal(size=(50, 4))
    win = sliding_windows(Q, 12, X, w=5)
    assert win.shape == (46, 10, 4)
    for b in (0, 17, 45):
        np.testing.assert_array_equal(win[b], np.r_[Q[8:13], X[b : b + 5]])
    np.testing.assert_array_equal(sliding_windows(Q, 12, X, landings=slice(10, 20)), win[10:20])
    np.testing.assert_array_equal(sliding_windows(Q, 12, X, landings=[3, 40]), win[[3, 40]])
    for bad in (3, 30):  # take-off needs w-1 earlier frames and must exist
        with pytest.raises(ValueError):
            sliding_windows(Q, bad, X)
    with pytest.raises(ValueError):
        sliding_windows(Q, 12, X[:, :3])
    with pytest.raises(ValueError):
        sliding_windows(Q, 12, X[:4])


@pytest.mark.parametrize("dtype, tol", [(np.float64, 1e-9), (np.float32, 2e-4)])
def test_search_matches_elastic_lscores(dtype, tol):
    rng = np.random.default_rng(1)
    Q = np.cumsum(rng.normal(size=(40, 6)), axis=0) + 100.0  # far from the origin: centring
    X = np.cumsum(rng.normal(size=(700, 6)), axis=0) + 100.0
    res = search_landings(Q, 25, X, w=5, k_max=12, dtype=dtype, block=64)
    expected = elastic_lscores(sliding_windows(Q, 25, X), k_max=12)
    assert res.lscore_by_k.shape == (696, 13)
    assert res.lscore_by_k.dtype == dtype
    rel_close(res.lscore_by_k, expected, tol)
    np.testing.assert_allclose(res.lscore_by_k, expected, rtol=50 * tol)  # entry-wise too
    b, k = np.unravel_index(np.argmin(expected), expected.shape)
    assert (res.best_landing, res.best_k) == (b, k)
    assert res.best_score == pytest.approx(expected[b, k], rel=tol)


@pytest.mark.parametrize("w", [3, 4, 7])  # one kernel per w: odd and even rows per k
def test_search_other_w_and_model(w):
    rng = np.random.default_rng(2)
    Q, X = rng.normal(size=(20, 3)), rng.normal(size=(60, 3))
    res = search_landings(Q, 10, X, w=w, k_max=4, model=OTHER_MODEL, dtype=np.float64, block=16)
    expected = elastic_lscores(sliding_windows(Q, 10, X, w=w), OTHER_MODEL, w, 4)
    rel_close(res.lscore_by_k, expected, 1e-9)


def test_search_finds_planted_continuation():
    # the query's own continuation is planted in a random data clip at frame b0: the search must
    # land there (k = 0), or at b0 + k with the k skipped frames re-synthesised by injection
    rng = np.random.default_rng(5)
    t = np.arange(3000.0)
    motion = smooth_curves(t[:400], 63, rng)
    a = 150
    query = motion[: a + 1]
    data = smooth_curves(t, 63, rng) + rng.normal(size=63) * 5
    b0 = 1700
    data[b0 : b0 + 60] = motion[a + 1 : a + 61]
    res = search_landings(query, a, data, w=5, k_max=30)
    assert res.best_landing - res.best_k == b0
    assert res.best_k <= 2
    L0 = res.lscore_by_k[:, 0]
    assert np.argmin(L0) == b0


def test_search_clips():
    rng = np.random.default_rng(3)
    Q = np.cumsum(rng.normal(size=(30, 3)), axis=0)
    clips = [np.cumsum(rng.normal(size=(n, 3)), axis=0) for n in (80, 3, 50)]
    res = search_clips(Q, range(10, 14), clips, k_max=5, dtype=np.float64)
    assert [L.shape for L in res.lstar] == [(4, 76), (4, 0), (4, 46)]
    best = min(
        (float(L[ti, b]), ci, ti, b)
        for ci, L in enumerate(res.lstar)
        for ti, b in np.ndindex(L.shape)
    )
    assert (res.best.clip, res.best.takeoff - 10, res.best.landing) == best[1:]
    single = search_landings(Q, res.best.takeoff, clips[res.best.clip], k_max=5, dtype=np.float64)
    assert res.best.k == single.best_k
    assert res.best.score == pytest.approx(best[0])
    np.testing.assert_array_equal(
        res.k_opt[2][1],
        np.argmin(search_landings(Q, 11, clips[2], k_max=5, dtype=np.float64).lscore_by_k, axis=1),
    )
