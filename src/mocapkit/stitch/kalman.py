"""Constant-acceleration Kalman model and its Rauch–Tung–Striebel (RTS) smoother.

Conventions (stated once for :mod:`mocapkit.stitch`):

* One **scalar series per feature dimension**; each series is smoothed independently with the
  same model (Li et al., "Laziness is a virtue", Eq. 1).
* Time is in **frames**: a series ``y`` of shape ``(T,)`` has one sample per time step, steps are
  ``dt`` apart (default ``dt = 1``, i.e. velocities are per frame, accelerations per frame²).
* ``mask`` (``(T,)`` bool) says which steps carry an observation; ``mask[t] == False`` is a step
  with no observation (an injected frame), whose value in ``y`` is ignored (may be NaN).
* The hidden state is ``z = (p, v, a)``; smoothed means are returned as ``(T, 3)`` arrays
  ``[p̂, v̂, â]`` (batched: ``(N, T, 3)``).

Model (Eq. 1 of the paper)::

    z_1     = μ0 + ω_0,                 ω ~ N(0, Q),  Q = diag(γ1, γ2, γ3)
    z_{n+1} = A z_n + ω_n,              A = [[1, dt, dt²/2], [0, 1, dt], [0, 0, 1]]
    y_n     = C z_n + ε_n,              C = (1 0 0),  ε ~ N(0, σ)
    μ0      = (y1, (y2 - y1)/dt, (y3 + y1 - 2 y2)/dt²)

γ and σ are **variances**. Defaults are the published ones: dt = 1, γ1 = γ2 = γ3 = σ = 0.001.

Decisions on points the paper leaves open:

* **Initial covariance P0.** The paper writes ``z_1 = μ0 + ω_0`` with the same noise symbol as the
  transitions, so P0 = cov(ω_0) = diag(γ1, γ2, γ3) is the default (``p0=None``). pykalman's
  default would be the identity; ``p0=(1, 1, 1)`` selects that. With P0 = I the data-derived
  prior μ0 is nearly ignored; with P0 = diag(γ) it is as trusted as one transition step. Both
  give k_opt ≈ g on gap-filling experiments (see :mod:`mocapkit.stitch.lscore`).
* **μ0 is data-dependent** (it uses the first three observations), so the first three steps must
  be observed; every stitch window starts with ``w >= 3`` observed frames. μ0 is linear in y, so
  the smoothed means remain a *linear* (homogeneous) function of the observed values.

The smoother (:func:`smoother_matrix` / :func:`smooth`): the gains and covariances do not depend
on the data, so the smoothed mean is ``M @ y_obs`` for a fixed matrix ``M`` of shape
``(T, 3, n_obs)`` per (model, mask pattern). ``M`` is obtained by running the Kalman filter and
RTS recursion on all unit observation vectors at once (mean *coefficients* instead of means) and
is cached; :func:`smooth` applies it to a batch of series with a single matmul. It is tested
against its readable twin (``rts_smooth_reference`` in tests/stitch/naive.py, one series at a
time, explicit forward filter and backward pass) and against pykalman.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

__all__ = [
    "DEFAULT_MODEL",
    "ConstantAccelerationModel",
    "smooth",
    "smoother_matrix",
]


@dataclass(frozen=True)
class ConstantAccelerationModel:
    """Per-dimension constant-acceleration Kalman model (hashable, so usable as a cache key).

    ``dt``: time step in frames; ``gammas``: process-noise variances (γ1, γ2, γ3) of p, v, a;
    ``sigma``: observation-noise variance; ``p0``: diagonal of the initial-state covariance, or
    ``None`` for the paper's reading P0 = diag(gammas).
    """

    dt: float = 1.0
    gammas: tuple[float, float, float] = (1e-3, 1e-3, 1e-3)
    sigma: float = 1e-3
    p0: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "dt", float(self.dt))
        object.__setattr__(self, "gammas", tuple(float(g) for g in self.gammas))
        object.__setattr__(self, "sigma", float(self.sigma))
        if self.p0 is not None:
            object.__setattr__(self, "p0", tuple(float(g) for g in self.p0))
        if len(self.gammas) != 3 or (self.p0 is not None and len(self.p0) != 3):
            raise ValueError("gammas and p0 must have 3 entries (p, v, a)")
        values = (self.dt, self.sigma, *self.gammas, *(self.p0 or ()))
        if not all(np.isfinite(v) and v > 0 for v in values):
            raise ValueError(f"dt, sigma, gammas and p0 must be finite and > 0: {self}")

    @property
    def A(self) -> np.ndarray:
        """Transition matrix (3, 3)."""
        dt = self.dt
        return np.array([[1.0, dt, dt * dt / 2.0], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])

    @property
    def C(self) -> np.ndarray:
        """Observation matrix (1, 3)."""
        return np.array([[1.0, 0.0, 0.0]])

    @property
    def Q(self) -> np.ndarray:
        """Process-noise covariance diag(γ1, γ2, γ3)."""
        return np.diag(self.gammas)

    @property
    def R(self) -> np.ndarray:
        """Observation-noise covariance (1, 1) = σ."""
        return np.array([[self.sigma]])

    @property
    def P0(self) -> np.ndarray:
        """Initial-state covariance: diag(p0), or diag(gammas) when ``p0`` is None."""
        return np.diag(self.gammas if self.p0 is None else self.p0)

    @property
    def mu0_matrix(self) -> np.ndarray:
        """(3, 3) map from (y1, y2, y3) to μ0 = (y1, (y2-y1)/dt, (y3+y1-2y2)/dt²)."""
        dt = self.dt
        return np.array(
            [[1.0, 0.0, 0.0], [-1.0 / dt, 1.0 / dt, 0.0], [1.0 / dt**2, -2.0 / dt**2, 1.0 / dt**2]]
        )


DEFAULT_MODEL = ConstantAccelerationModel()


def _check_mask(mask, T: int) -> np.ndarray:
    mask = np.ones(T, bool) if mask is None else np.asarray(mask, dtype=bool)
    if mask.shape != (T,):
        raise ValueError(f"mask must have shape ({T},), got {mask.shape}")
    if T < 3 or not mask[:3].all():
        raise ValueError("the first three steps must be observed (μ0 uses y1, y2, y3)")
    return mask


@functools.lru_cache(maxsize=512)
def _smoother_matrix_cached(model: ConstantAccelerationModel, mask_bytes: bytes) -> np.ndarray:
    mask = np.frombuffer(mask_bytes, dtype=bool)
    T, n_obs = mask.shape[0], int(mask.sum())
    obs_index = np.cumsum(mask) - 1  # observation column of each observed step
    A, Q, sigma = model.A, model.Q, model.sigma
    # The Kalman filter / RTS recursion, but the "means" are (3, n_obs) coefficient matrices:
    # row i of G[t] holds the coefficients of E[z_t[i] | ...] on the observed values.
    G_pred, P_pred = np.zeros((T, 3, n_obs)), np.zeros((T, 3, 3))
    G_filt, P_filt = np.zeros((T, 3, n_obs)), np.zeros((T, 3, 3))
    for t in range(T):
        if t == 0:
            G = np.zeros((3, n_obs))
            G[:, :3] = model.mu0_matrix  # the first three steps are observations 0, 1, 2
            P = model.P0
        else:
            G, P = A @ G_filt[t - 1], A @ P_filt[t - 1] @ A.T + Q
        G_pred[t], P_pred[t] = G, P
        if mask[t]:
            gain = P[:, 0] / (P[0, 0] + sigma)
            innovation = -G[0].copy()
            innovation[obs_index[t]] += 1.0
            G = G + np.outer(gain, innovation)
            P = P - np.outer(gain, P[0, :])
        G_filt[t], P_filt[t] = G, P
    G_s = G_filt.copy()
    for t in range(T - 2, -1, -1):
        J = np.linalg.solve(P_pred[t + 1], A @ P_filt[t]).T
        G_s[t] = G_filt[t] + J @ (G_s[t + 1] - G_pred[t + 1])
    G_s.setflags(write=False)
    return G_s


def smoother_matrix(model: ConstantAccelerationModel, observed_mask) -> np.ndarray:
    """The linear map from observed values to smoothed states: array (T, 3, n_obs), read-only.

    For a series ``y`` with observation pattern ``observed_mask`` (T,),
    ``smoother_matrix(model, mask) @ y[mask]`` are the smoothed means (T, 3) ``[p̂, v̂, â]`` of
    the forward Kalman filter and backward RTS pass. μ0's dependence on y1..y3 is included.
    Cached per (model, mask pattern).
    """
    mask = np.ascontiguousarray(observed_mask, dtype=bool)
    if mask.ndim != 1:
        raise ValueError(f"observed_mask must be 1-D, got shape {mask.shape}")
    _check_mask(mask, mask.shape[0])
    return _smoother_matrix_cached(model, mask.tobytes())


def smooth(Y, mask=None, model: ConstantAccelerationModel = DEFAULT_MODEL) -> np.ndarray:
    """Smooth a batch of independent series ``Y`` (..., T) → smoothed means (..., T, 3).

    ``mask`` (T,) is shared by all series (None = all observed); unobserved entries of ``Y`` are
    ignored. One matmul with :func:`smoother_matrix`; result dtype float64.
    """
    Y = np.asarray(Y)
    T = Y.shape[-1]
    mask = _check_mask(mask, T)
    M = smoother_matrix(model, mask).reshape(T * 3, -1)
    Yo = Y[..., mask].astype(float, copy=False)
    out = Yo.reshape(-1, Yo.shape[-1]) @ M.T
    return out.reshape((*Y.shape[:-1], T, 3))
