"""Independent test references for mocapkit.stitch (never imported by the library).

``smooth_information_form`` computes the smoothed means without any Kalman recursion: for a
linear-Gaussian state-space model the posterior mean E[z | y] is the minimiser of the quadratic

    (z_1 - μ0)ᵀ P0⁻¹ (z_1 - μ0) + Σ_t (z_{t+1} - A z_t)ᵀ Q⁻¹ (z_{t+1} - A z_t)
        + Σ_{observed t} (y_t - C z_t)² / σ,

so it is the solution of one dense (3T × 3T) linear system. ``lk_direct`` spells out Eq. 3 of the
paper term by term from those means.
"""

from __future__ import annotations

import numpy as np


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
