"""Readable reference implementations the fast kernels of mocapkit.clean are tested against."""

from __future__ import annotations

import itertools

import numpy as np


def pose_distance(a: np.ndarray, b: np.ndarray, trim: int) -> float:
    """Eq. 1 with log-maps: sum_k ||log(q_bk^-1 q_ak)||^2 over joints, trim largest dropped."""
    from mocapkit.core import rotations as rot

    rel = rot.quat_mul(rot.quat_inv(b), a)
    terms = np.sum(rot.quat_log(rel) ** 2, axis=-1)
    # log of q and -q differ; take the shorter one (the geodesic on SO(3))
    terms = np.minimum(terms, np.sum(rot.quat_log(-rel) ** 2, axis=-1))
    terms = sorted(terms.tolist())
    return float(sum(terms[: len(terms) - trim]))


def _paths(N: int, M: int, max_run: int):
    """All constrained paths from (0,0) that stop when they first reach row N-1 or column M-1."""
    out = []

    def rec(path, run_dir, run_len):
        i, j = path[-1]
        if i == N - 1 or j == M - 1:
            out.append(list(path))
            return
        for di, dj in ((1, 1), (1, 0), (0, 1)):
            d = (di, dj)
            if d == (1, 1):
                nd, nl = None, 0
            else:
                nd = d
                nl = run_len + 1 if run_dir == d else 1
                if max_run and nl > max_run:
                    continue
            path.append((i + di, j + dj))
            rec(path, nd, nl)
            path.pop()

    if N == 1 or M == 1:
        return [[(0, 0)]]
    rec([(0, 0)], None, 0)
    return out


def constrained_dtw(D: np.ndarray, max_run: int) -> tuple[float, list[tuple[int, int]]]:
    """Brute force over all paths: per end cell the least-sum path (ties: shorter), then the end
    cell with the least mean. Only for tiny blocks."""
    N, M = D.shape
    best_per_end: dict[tuple[int, int], tuple[float, int, list]] = {}
    for p in _paths(N, M, max_run):
        s = float(sum(D[i, j] for i, j in p))
        key = p[-1]
        cur = best_per_end.get(key)
        if cur is None or (s, len(p)) < (cur[0], cur[1]):
            best_per_end[key] = (s, len(p), p)
    best = min(best_per_end.values(), key=lambda t: (t[0] / t[1], t[1]))
    return best[0] / best[1], best[2]


def dtw_dp(D: np.ndarray, max_run: int) -> float:
    """Readable dynamic programme over (cell, state): state ("d", 0) after a diagonal step or at
    the start, ("h", k) / ("v", k) after k consecutive (0,1) / (1,0) steps."""
    N, M = D.shape
    if N == 1 or M == 1:
        return float(D[0, 0])
    INF = float("inf")
    best: dict = {(0, 0): {("d", 0): (float(D[0, 0]), 1)}}
    for i, j in itertools.product(range(N), range(M)):
        if (i, j) == (0, 0):
            continue
        cands: dict = {}
        for (pi, pj), kind in (((i - 1, j - 1), "d"), ((i - 1, j), "v"), ((i, j - 1), "h")):
            if pi < 0 or pj < 0 or pi == N - 1 or pj == M - 1:
                continue  # outside, or an end cell (paths stop there)
            for st, (c, n) in best.get((pi, pj), {}).items():
                if kind == "d" or max_run == 0:
                    new = ("d", 0)
                else:
                    k = st[1] + 1 if st[0] == kind else 1
                    if k > max_run:
                        continue
                    new = (kind, k)
                cand = (c + float(D[i, j]), n + 1)
                if cand < cands.get(new, (INF, 0)):
                    cands[new] = cand
        best[(i, j)] = cands
    per_end = [
        min(states.values())
        for (i, j), states in best.items()
        if (i == N - 1 or j == M - 1) and states
    ]
    return min((c / n, n) for c, n in per_end)[0]


def knn_minima(dist: np.ndarray, k: int, exclude: tuple[int, int] | None) -> list[int]:
    """The k smallest strict-or-left-plateau local minima of a 1-D function, skipping indices in
    the half-open range ``exclude``."""
    n = len(dist)
    mins = []
    for c in range(n):
        if exclude is not None and exclude[0] <= c < exclude[1]:
            continue
        left = dist[c - 1] if c > 0 else np.inf
        right = dist[c + 1] if c < n - 1 else np.inf
        if dist[c] < left and dist[c] <= right:
            mins.append(c)
    mins.sort(key=lambda c: (dist[c], c))
    return mins[:k]


def knn_search(
    source: np.ndarray,
    context: np.ndarray,
    joints: list[int],
    trim: int,
    starts: list[int],
    n: int,
    m: int,
    k: int,
    exclude: int,
    max_run: int,
) -> list[list[int]]:
    """Reference KNN: for every source word, the naive DTW (readable DP over log-map pose
    distances) against the target word starting at every context frame, then the k smallest
    local minima outside ``[start - exclude, start + n + exclude)`` (target centres; the context
    is the take itself). Returns target start frames per word."""
    out = []
    tstarts = list(range(0, context.shape[0] - m + 1))
    for a in starts:
        D_all = np.array(
            [
                [
                    pose_distance(source[a + i, joints], context[t, joints], trim)
                    for t in range(context.shape[0])
                ]
                for i in range(n)
            ]
        )
        dist = np.array([dtw_dp(D_all[:, t : t + m], max_run) for t in tstarts])
        centres = np.array(tstarts) + m // 2
        lo, hi = a - exclude, a + n + exclude
        mins = []
        for c in range(len(dist)):
            if lo <= centres[c] < hi:
                continue
            left = dist[c - 1] if c > 0 else np.inf
            right = dist[c + 1] if c < len(dist) - 1 else np.inf
            if dist[c] < left and dist[c] <= right:
                mins.append(c)
        mins.sort(key=lambda c: (dist[c], c))
        out.append([tstarts[c] for c in mins[:k]])
    return out


def _steps(q: np.ndarray, j: int, frame: str = "body") -> list[np.ndarray]:
    """Rotation vectors of joint j's steps with scipy's Rotation: q[i]^-1 q[i+1] ("body") or
    q[i+1] q[i]^-1 ("parent")."""
    from scipy.spatial.transform import Rotation

    r = Rotation.from_quat(q[:, j][:, [1, 2, 3, 0]])
    if frame == "body":
        return [(r[i].inv() * r[i + 1]).as_rotvec() for i in range(len(q) - 1)]
    return [(r[i + 1] * r[i].inv()).as_rotvec() for i in range(len(q) - 1)]


def step_deviations(q: np.ndarray, frame: str) -> np.ndarray:
    """Loop version of mdm.step_deviations: each step against the mean of its neighbours."""
    F, J = q.shape[:2]
    out = np.zeros((F, J, 3))
    for j in range(J):
        w = _steps(q, j, frame)
        for f in range(2, F - 1):
            out[f, j] = w[f - 1] - 0.5 * (w[f - 2] + w[f])
    return out


def jump_size(q: np.ndarray) -> np.ndarray:
    """Loop version of mdm.jump_size: how much each step differs from both neighbours."""
    F, J = q.shape[:2]
    out = np.zeros((F, J))
    for j in range(J):
        w = _steps(q, j)
        for f in range(2, F - 1):
            out[f, j] = min(np.linalg.norm(w[f - 1] - w[f - 2]), np.linalg.norm(w[f - 1] - w[f]))
    return out


def still_jumps(q: np.ndarray, min_step: float, ratio: float, width: int) -> np.ndarray:
    """Loop version of mdm.still_jumps: frame f is entered by a step over ``min_step`` and over
    ``ratio`` times every step within ``width`` frames before and after it, with a jump over
    ``min_step`` too."""
    F, J = q.shape[:2]
    out = np.zeros((F, J), dtype=bool)
    if F < 4 or width < 1 or ratio <= 0:
        return out
    jumps = jump_size(q)
    for j in range(J):
        s = [float(np.linalg.norm(w)) for w in _steps(q, j)]  # s[i]: frame i -> i + 1
        for f in range(2, F - 1):
            i = f - 1
            near = s[max(0, i - width) : i] + s[i + 1 : i + 1 + width]
            out[f, j] = s[i] > min_step and s[i] > ratio * max(near) and jumps[f, j] > min_step
    return out


def step_size(q: np.ndarray) -> np.ndarray:
    """Loop version of mdm.step_size: the length of the body-frame step deviation."""
    return np.linalg.norm(step_deviations(q, "body"), axis=-1)


def burst_roughness(q: np.ndarray) -> np.ndarray:
    """Loop version of mdm.burst_roughness: |w[f-1] - 2 w[f] + w[f+1]| with w the body-frame
    steps."""
    F, J = q.shape[:2]
    out = np.zeros((F, J))
    for j in range(J):
        w = _steps(q, j)
        for f in range(1, F - 2):
            out[f, j] = np.linalg.norm(w[f - 1] - 2.0 * w[f] + w[f + 1])
    return out


def turn_change(q: np.ndarray) -> np.ndarray:
    """Loop version of mdm.turn_change."""
    F, J = q.shape[:2]
    out = np.zeros((F, J))
    for j in range(J):
        w = _steps(q, j)
        for f in range(1, F - 1):
            out[f, j] = np.linalg.norm(w[f] - w[f - 1])
    return out


def noise_bursts(
    r: np.ndarray,
    change: np.ndarray,
    level: np.ndarray,
    min_frames: int,
    edge_share: float,
    edge_jump: float,
    hold_ratio: float,
) -> np.ndarray:
    """Frame-by-frame version of mdm.noise_bursts, per joint: a frame is rough when above the
    level (weakly rough above ``hold_ratio`` times it), or when its two neighbours are; a
    burst is a stretch of weakly rough frames holding a stretch of more than ``min_frames``
    rough ones; each end is moved in by one frame where the step change there carries noise
    (``edge_share``, ``edge_jump``), by two where it does not."""
    F, J = r.shape
    out = np.zeros((F, J), dtype=bool)

    def above(c: np.ndarray, f: int, x: float) -> bool:
        return bool(c[f] > x or (0 < f < F - 1 and c[f - 1] > x and c[f + 1] > x))

    for j in range(J):
        lv = float(np.broadcast_to(level, (J,))[j])
        strong = [above(r[:, j], f, lv) for f in range(F)]
        weak = [above(r[:, j], f, hold_ratio * lv) or strong[f] for f in range(F)]
        f = 0
        while f < F:
            if not weak[f]:
                f += 1
                continue
            a = f
            while f < F and weak[f]:
                f += 1
            b = f - 1
            longest, cur = 0, 0  # the longest stretch of rough frames in a .. b
            for g in range(a, b + 1):
                cur = cur + 1 if strong[g] else 0
                longest = max(longest, cur)
            if longest - 1 >= min_frames:
                col = change[:, j]

                def ch(g: int, col: np.ndarray = col) -> float:
                    return float(col[g]) if 0 <= g < F else 0.0

                noisy_in = ch(a) > edge_share * r[a, j] and ch(a) > edge_jump * ch(a - 1)
                noisy_out = ch(b + 1) > edge_share * r[b, j] and ch(b + 1) > edge_jump * ch(b + 2)
                first = a + 1 if noisy_in else a + 2
                last = b if noisy_out else b - 1
                out[first : last + 1, j] = True
    return out


def excursion_match(track: np.ndarray, start: int, stop: int, others=(), flex: int = 1) -> float:
    """Loop version of mdm.excursion_match: every place and lag, scipy's Rotation for angles."""
    from scipy.spatial.transform import Rotation

    def rots(t):
        return Rotation.from_quat(np.asarray(t)[:, [1, 2, 3, 0]])

    q = rots(track)
    e, x = start - 1, stop
    if e < 0 or x >= len(track):
        return float("inf")
    p = max(range(start, stop), key=lambda f: (q[e].inv() * q[f]).magnitude())
    k, m = p - e, x - e
    best = float("inf")
    for idx, src in enumerate([track, *others]):
        t = rots(src)
        for g in range(len(src)):
            for kk in range(max(1, k - flex), k + flex + 1):
                for mm in range(max(kk + 1, m - flex), m + flex + 1):
                    if g + mm >= len(src) or (idx == 0 and g <= x and g + mm >= e):
                        continue
                    pairs = ((q[e], t[g]), (q[p], t[g + kk]), (q[x], t[g + mm]))
                    cost = max((a.inv() * b).magnitude() for a, b in pairs)
                    best = min(best, float(cost))
    return best


def spike_size(q: np.ndarray, max_frames: int) -> np.ndarray:
    """Loop version of mdm.spike_size: per joint and gap, numpy's polyfit through the rotation
    vectors (scipy's Rotation) of the two frames either side, relative to the frame before."""
    from scipy.spatial.transform import Rotation

    F, J = q.shape[:2]
    out = np.zeros((F, J))
    for j in range(J):
        r = Rotation.from_quat(q[:, j][:, [1, 2, 3, 0]])
        for n in range(1, max_frames + 1):
            for a in range(2, F - n - 1):
                ref = r[a - 1]
                knots = [-2, -1, n, n + 1]
                x = np.array([(ref.inv() * r[a + t]).as_rotvec() for t in knots])
                coef = [np.polyfit(knots, x[:, k], 3) for k in range(3)]
                score = min(
                    (
                        (ref * Rotation.from_rotvec([np.polyval(c, g) for c in coef])).inv()
                        * r[a + g]
                    ).magnitude()
                    for g in range(n)
                )
                for g in range(n):
                    out[a + g, j] = max(out[a + g, j], score)
    return out
