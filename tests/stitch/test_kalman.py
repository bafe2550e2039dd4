"""Tests for mocapkit.stitch.kalman: the reference RTS smoother (tests/stitch/naive.py) against
pykalman and against an information-form solve, and the fast linear-map smoother against both."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pykalman import KalmanFilter
from testsupport import load_sibling

from mocapkit.stitch.kalman import (
    DEFAULT_MODEL,
    ConstantAccelerationModel,
    smooth,
    smoother_matrix,
)

naive = load_sibling(__file__, "naive")

MODELS = [
    DEFAULT_MODEL,
    ConstantAccelerationModel(p0=(1.0, 1.0, 1.0)),  # pykalman's default P0 = I
    ConstantAccelerationModel(dt=0.5, gammas=(1e-2, 3e-3, 1e-4), sigma=0.05),
    ConstantAccelerationModel(dt=2.0, gammas=(1e-4, 1e-3, 1e-2), sigma=1e-3, p0=(0.1, 1, 10)),
]

SETTINGS = settings(max_examples=25, deadline=None, derandomize=True)


def random_case(seed: int, T: int, p_missing: float):
    """A random-walk-ish series (T,) and a mask with the first three steps observed."""
    rng = np.random.default_rng(seed)
    y = np.cumsum(rng.normal(size=T)) * rng.uniform(0.1, 10) + rng.normal() * 50
    mask = rng.random(T) >= p_missing
    mask[:3] = True
    return y, mask


def pykalman_smooth(y, mask, model):
    kf = KalmanFilter(
        transition_matrices=model.A,
        observation_matrices=model.C,
        transition_covariance=model.Q,
        observation_covariance=model.R,
        initial_state_mean=model.mu0_matrix @ y[:3],
        initial_state_covariance=model.P0,
    )
    obs = np.ma.masked_array(y[:, None], mask=~mask[:, None])
    return kf.smooth(obs)


case = st.tuples(
    st.integers(0, 2**32 - 1),
    st.integers(3, 40),
    st.sampled_from([0.0, 0.3, 0.7]),
    st.sampled_from(range(len(MODELS))),
)


def close(a, b, tol=1e-8):
    scale = max(1.0, float(np.abs(b).max()))
    np.testing.assert_allclose(a, b, rtol=0, atol=tol * scale)


# --------------------------------------------------------------------------- model


def test_model_matrices():
    m = ConstantAccelerationModel(dt=2.0)
    np.testing.assert_array_equal(m.A, [[1, 2, 2], [0, 1, 2], [0, 0, 1]])
    np.testing.assert_array_equal(m.C, [[1, 0, 0]])
    np.testing.assert_array_equal(DEFAULT_MODEL.Q, np.eye(3) * 1e-3)
    np.testing.assert_array_equal(DEFAULT_MODEL.R, [[1e-3]])
    np.testing.assert_array_equal(DEFAULT_MODEL.P0, DEFAULT_MODEL.Q)  # paper: z_1 = μ0 + ω_0
    np.testing.assert_array_equal(ConstantAccelerationModel(p0=(1, 1, 1)).P0, np.eye(3))
    y = np.array([1.0, 3.0, 9.0])
    np.testing.assert_allclose(m.mu0_matrix @ y, [1.0, 1.0, 1.0])  # (y1, Δ/dt, Δ²/dt²)
    assert hash(ConstantAccelerationModel()) == hash(DEFAULT_MODEL)


@pytest.mark.parametrize(
    "kwargs", [{"dt": 0}, {"sigma": -1}, {"gammas": (1, 1)}, {"p0": (1, 0, 1)}, {"dt": np.nan}]
)
def test_model_rejects_bad_parameters(kwargs):
    with pytest.raises(ValueError):
        ConstantAccelerationModel(**kwargs)


# --------------------------------------------------------------------------- reference smoother


@SETTINGS
@given(case)
def test_reference_matches_pykalman(params):
    seed, T, p_missing, mi = params
    model = MODELS[mi]
    y, mask = random_case(seed, T, p_missing)
    means, covs = naive.rts_smooth_reference(y, mask, model, return_cov=True)
    pk_means, pk_covs = pykalman_smooth(y, mask, model)
    close(means, pk_means)
    close(covs, pk_covs)


@SETTINGS
@given(case)
def test_reference_matches_information_form(params):
    seed, T, p_missing, mi = params
    model = MODELS[mi]
    y, mask = random_case(seed, T, p_missing)
    close(naive.rts_smooth_reference(y, mask, model), naive.smooth_information_form(y, mask, model))


def test_unobserved_values_are_ignored():
    y, mask = random_case(3, 20, 0.5)
    y2 = y.copy()
    y2[~mask] = np.nan
    ref = naive.rts_smooth_reference
    np.testing.assert_array_equal(ref(y, mask), ref(y2, mask))
    np.testing.assert_array_equal(smooth(y, mask), smooth(y2, mask))


def test_first_three_steps_must_be_observed():
    y = np.arange(10.0)
    mask = np.ones(10, bool)
    mask[2] = False
    with pytest.raises(ValueError, match="first three"):
        smooth(y, mask)
    with pytest.raises(ValueError, match="first three"):
        smoother_matrix(DEFAULT_MODEL, mask)
    with pytest.raises(ValueError):
        smooth(np.zeros(2))
    with pytest.raises(ValueError):
        smooth(y, np.ones(9, bool))


def test_straight_line_is_reproduced_exactly():
    # A constant-velocity line is a zero-noise path of the model and μ0 is exact for it,
    # so the smoothed states are the line itself, even across a gap.
    t = np.arange(15.0)
    y = 3.0 - 0.7 * t
    mask = np.ones(15, bool)
    mask[6:11] = False
    for z in (naive.rts_smooth_reference(y, mask), smooth(y, mask)):
        np.testing.assert_allclose(z[:, 0], y, atol=1e-10)
        np.testing.assert_allclose(z[:, 1], -0.7, atol=1e-10)
        np.testing.assert_allclose(z[:, 2], 0.0, atol=1e-10)


# --------------------------------------------------------------------------- fast smoother


@SETTINGS
@given(case)
def test_smoother_matrix_matches_reference(params):
    seed, T, p_missing, mi = params
    model = MODELS[mi]
    y, mask = random_case(seed, T, p_missing)
    M = smoother_matrix(model, mask)
    assert M.shape == (T, 3, mask.sum())
    close(M @ y[mask], naive.rts_smooth_reference(y, mask, model))


def test_smoother_matrix_is_cached_and_read_only():
    mask = np.r_[np.ones(5, bool), np.zeros(3, bool), np.ones(5, bool)]
    M1 = smoother_matrix(DEFAULT_MODEL, mask)
    M2 = smoother_matrix(ConstantAccelerationModel(), list(mask))
    assert M1 is M2
    assert not M1.flags.writeable
    # position rows reproduce constants (translation equivariance), velocity/acc rows kill them
    np.testing.assert_allclose(M1.sum(axis=2), np.tile([1.0, 0.0, 0.0], (13, 1)), atol=1e-9)


@pytest.mark.parametrize("p_missing", [0.0, 0.4])
def test_smooth_batch_matches_reference(p_missing):
    rng = np.random.default_rng(7)
    T, model = 25, MODELS[2]
    _, mask = random_case(11, T, p_missing)
    Y = rng.normal(size=(4, 6, T)) * 10
    Y[..., ~mask] = np.nan  # ignored
    Z = smooth(Y, mask, model)
    assert Z.shape == (4, 6, T, 3)
    for i in range(4):
        for j in range(6):
            close(Z[i, j], naive.rts_smooth_reference(Y[i, j], mask, model))
    close(smooth(Y[0, 0], mask, model), Z[0, 0])  # a single series
