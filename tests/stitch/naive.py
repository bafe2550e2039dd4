"""Independent test references for mocapkit.stitch (never imported by the library).

``rts_smooth_reference`` is the textbook smoother, one series at a time: an explicit forward
Kalman filter and backward Rauch-Tung-Striebel pass. ``lscore_reference``,
``elastic_lscores_reference`` and ``elastic_lscore_reference`` are the readable L, L_k and L*:
for each window, k and dimension, insert k unobserved steps, smooth with
``rts_smooth_reference`` and sum |(p̂_{n+1} - p̂_n) â_n| over all steps.

``smooth_information_form`` computes the smoothed means without any Kalman recursion: for a
linear-Gaussian state-space model the posterior mean E[z | y] is the minimiser of the quadratic

    (z_1 - μ0)ᵀ P0⁻¹ (z_1 - μ0) + Σ_t (z_{t+1} - A z_t)ᵀ Q⁻¹ (z_{t+1} - A z_t)
        + Σ_{observed t} (y_t - C z_t)² / σ,

so it is the solution of one dense (3T × 3T) linear system. ``lk_direct`` spells out Eq. 3 of the
paper term by term from those means.
"""

from __future__ import annotations

import numpy as np

from mocapkit.stitch.kalman import DEFAULT_MODEL
from mocapkit.stitch.lscore import DEFAULT_K_MAX, ElasticResult


def smooth_information_form(y, mask, model) -> np.ndarray:
    """Smoothed means (T, 3) of one series by solving the normal equations of the posterior."""
    y = np.asarray(y, float)
    T = y.shape[0]
    A, C = model.A, model.C
    Qi, P0i = np.linalg.inv(model.Q), np.linalg.inv(model.P0)
    mu0 = model.mu0_matrix @ y[:3]
    H = np.zeros((3 * T, 3 * T))
    g = np.zeros(3 * T)
    H[:3, :3] += P0i
    g[:3] += P0i @ mu0
    for t in range(T - 1):
        i, j = slice(3 * t, 3 * t + 3), slice(3 * t + 3, 3 * t + 6)
        H[i, i] += A.T @ Qi @ A
        H[j, j] += Qi
        H[i, j] -= A.T @ Qi
        H[j, i] -= Qi @ A
    for t in range(T):
        if mask[t]:
            i = slice(3 * t, 3 * t + 3)
            H[i, i] += C.T @ C / model.sigma
            g[i] += C[0] * y[t] / model.sigma
    return np.linalg.solve(H, g).reshape(T, 3)


def lk_direct(window, model, w: int, k: int) -> float:
    """L_k of one window (2w, m), written as the paper's Eq. 3 with its five sums."""
    total = 0.0
    mask = np.r_[np.ones(w, bool), np.zeros(k, bool), np.ones(w, bool)]
    for d in range(window.shape[1]):
        y = np.r_[window[:w, d], np.zeros(k), window[w:, d]]
        z = smooth_information_form(y, mask, model)
        p, a = z[:w, 0], z[:w, 2]  # take-off side p̂_1..p̂_w
        pi, ai = z[w : w + k, 0], z[w : w + k, 2]  # injected p̂'_1..p̂'_k
        pl, al = z[w + k :, 0], z[w + k :, 2]  # landing side p̂_{w+1}..p̂_{2w}
        total += sum(abs((p[n + 1] - p[n]) * a[n]) for n in range(w - 1))
        if k == 0:
            total += abs((pl[0] - p[-1]) * a[-1])
        else:
            total += abs((pi[0] - p[-1]) * a[-1])
            total += sum(abs((pi[i + 1] - pi[i]) * ai[i]) for i in range(k - 1))
            total += abs((pl[0] - pi[-1]) * ai[-1])
        total += sum(abs((pl[n + 1] - pl[n]) * al[n]) for n in range(w - 1))
    return total


# --------------------------------------------------------------------------- RTS smoother


def rts_smooth_reference(y, mask=None, model=DEFAULT_MODEL, *, return_cov: bool = False):
    """Smooth one series ``y`` (T,) with the forward Kalman filter and the backward RTS pass.

    Steps with ``mask[t] == False`` get no measurement update (their ``y`` is ignored). Returns the
    smoothed means (T, 3) ``[p̂, v̂, â]``, and the smoothed covariances (T, 3, 3) if ``return_cov``.
    """
    y = np.asarray(y, dtype=float)
    T = y.shape[0]
    mask = np.ones(T, bool) if mask is None else np.asarray(mask, dtype=bool)
    assert mask.shape == (T,) and T >= 3 and mask[:3].all(), "μ0 needs y1, y2, y3 observed"
    A, Q, sigma = model.A, model.Q, model.sigma
    m_pred, P_pred = np.zeros((T, 3)), np.zeros((T, 3, 3))
    m_filt, P_filt = np.zeros((T, 3)), np.zeros((T, 3, 3))
    for t in range(T):
        if t == 0:
            m, P = model.mu0_matrix @ y[:3], model.P0
        else:
            m, P = A @ m_filt[t - 1], A @ P_filt[t - 1] @ A.T + Q
        m_pred[t], P_pred[t] = m, P
        if mask[t]:  # measurement update with C = (1 0 0)
            gain = P[:, 0] / (P[0, 0] + sigma)
            m = m + gain * (y[t] - m[0])
            P = P - np.outer(gain, P[0, :])
        m_filt[t], P_filt[t] = m, P
    m_s, P_s = m_filt.copy(), P_filt.copy()
    for t in range(T - 2, -1, -1):
        J = np.linalg.solve(P_pred[t + 1], A @ P_filt[t]).T  # P_filt A^T P_pred^{-1}
        m_s[t] = m_filt[t] + J @ (m_s[t + 1] - m_pred[t + 1])
        P_s[t] = P_filt[t] + J @ (P_s[t + 1] - P_pred[t + 1]) @ J.T
    return (m_s, P_s) if return_cov else m_s


# --------------------------------------------------------------------------- L-scores


def _windows(windows, w):
    Y = np.asarray(windows, dtype=float)
    if Y.ndim == 2:
        Y = Y[None]
    return Y, Y.shape[1] // 2 if w is None else int(w)


def _mask(w: int, k: int) -> np.ndarray:
    return np.r_[np.ones(w, bool), np.zeros(k, bool), np.ones(w, bool)]


def _inject(y: np.ndarray, w: int, k: int) -> np.ndarray:
    return np.r_[y[:w], np.full(k, np.nan), y[w:]]


def lscore_reference(windows, model=DEFAULT_MODEL, w=None):
    """Readable L-score of each window (N, 2w, m) → (N,)."""
    return elastic_lscores_reference(windows, model, w, 0)[:, 0]


def elastic_lscores_reference(windows, model=DEFAULT_MODEL, w=None, k_max=DEFAULT_K_MAX):
    """Readable L_k, k = 0..k_max, of each window (N, 2w, m) → (N, k_max + 1)."""
    Y, w = _windows(windows, w)
    N, _, m = Y.shape
    out = np.zeros((N, k_max + 1))
    for i in range(N):
        for k in range(k_max + 1):
            for d in range(m):
                z = rts_smooth_reference(_inject(Y[i, :, d], w, k), _mask(w, k), model)
                p, a = z[:, 0], z[:, 2]
                out[i, k] += np.abs((p[1:] - p[:-1]) * a[:-1]).sum()
    return out


def elastic_lscore_reference(window, model=DEFAULT_MODEL, w=None, k_max=DEFAULT_K_MAX):
    """Readable elastic L-score of one window (2w, m) → ``ElasticResult``."""
    Y, w = _windows(window, w)
    scores = elastic_lscores_reference(Y, model, w, k_max)[0]
    k = int(np.argmin(scores))
    traj = np.stack(
        [
            rts_smooth_reference(_inject(Y[0, :, d], w, k), _mask(w, k), model)[:, 0]
            for d in range(Y.shape[2])
        ],
        axis=1,
    )
    return ElasticResult(float(scores[k]), k, traj, scores)


def inbetween_search_reference(ctx, gap: int, library, w: int, config, metres_per_unit: float):
    """The in-betweening search by brute force: (score, clip, start time, rate) of the best
    candidate. For every warp and every frame s of it (the frame on A-1), with the windows and
    the ground path written out: L-scores by ``rts_smooth_reference`` one dimension at a time
    (past then the first wl gap frames; the last wl gap frames then the future), and the
    ground-path term from the pelvis path and heading. Candidates whose frames s-1..s+g+1 or
    windows leave their clip are skipped."""
    import math

    g = int(gap)
    wl = max(3, min(w, g))

    def lscore(Y):
        total = 0.0
        for d in range(Y.shape[1]):
            z = rts_smooth_reference(Y[:, d], None, DEFAULT_MODEL)
            p, acc = z[:, 0], z[:, 2]
            total += float(np.sum(np.abs((p[1:] - p[:-1]) * acc[:-1])))
        return total

    def turn(v, h):  # ground vector (side, forward) into the frame of heading h
        c, s = math.cos(h), math.sin(h)
        return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])

    tol = config.travel_tolerance_m / metres_per_unit
    best = None
    for W in library.warped:
        N = W.feats.shape[0]
        for s in range(1, N):
            frames = [s - 1, s + g + 1, s + wl, s + g - wl + 1]
            if min(frames) < 0 or max(frames) >= N:
                continue
            if len({int(W.clip[f]) for f in range(min(frames), max(frames) + 1)}) != 1:
                continue
            ls = lscore(np.concatenate([ctx.past, W.feats[s + 1 : s + 1 + wl]]))
            le = lscore(np.concatenate([W.feats[s + g - wl + 1 : s + g + 1], ctx.future]))
            h0 = W.heading[s]
            d = turn(W.ground[s + g + 1] - W.ground[s], h0)
            v = turn(W.ground[s] - W.ground[s - 1], h0) / W.rate
            dh = W.heading[s + g + 1] - W.heading[s]
            travel = config.travel_weight * (
                np.sum((d - ctx.travel) ** 2) / tol**2
                + np.sum((v - ctx.velocity) ** 2) * (g + 1) ** 2 / tol**2 / 4.0
                + ((dh - ctx.turn) / math.radians(config.turn_tolerance_deg)) ** 2
            )
            score = ls + le + travel
            if best is None or score < best[0]:
                best = (score, int(W.clip[s]), float(W.time[s]), W.rate)
    return best
