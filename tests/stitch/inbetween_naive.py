"""Brute-force reference of the in-betweening search score (never imported by the library).

``inbetween_scores_reference`` writes every candidate out one at a time: for every warp and
every frame s of it (the frame on A-1) whose frames s-1 .. s+g+1 and L-score windows stay in
one clip, the score

    lscore_weight (L_start + L_end)  +  travel  +  pose

with the L-scores by the textbook RTS smoother of naive.py (one dimension at a time), the
ground-path term from the pelvis path and heading (divided by the square of the gap's length
A-1 to B over travel_seconds where that is longer and the context has a frame time), and the
pose term as the squared distances
of frames s-1, s and s+g+1 to the context's last two past frames and its first future frame,
divided by (joints x tolerance²), times pose_weight; with pelvis heights in the library and
the context (three past frames or more, a frame time), plus the bob term: bob_weight times
the squared differences of the pelvis' vertical acceleration and speed, over the frames
end-2k_s, end-k_s, end of the candidate (end = s, or s+1 on its clip's second frame) and
A-1-2k_s, A-1-k_s, A-1 of the context, over their tolerances (metres), where k_s is half
bob_span_seconds in frames, or less where the candidate's clip or the context has fewer
frames before. Returns every candidate, best first.

A context with no future frames (a gap at the clip's end) has no L_end, no displacement or
turn in the ground-path term (its velocity is the warped segment's, not the library's own),
and no frame s+g+1: its pose term is frames s-1 and s, times 3/2 (per frame matched, as with
three), and a candidate needs frames up to s+g only.
"""

from __future__ import annotations

import math

import numpy as np
from testsupport import load_sibling

naive = load_sibling(__file__, "naive")


def _lscore(Y) -> float:
    total = 0.0
    for d in range(Y.shape[1]):
        z = naive.rts_smooth_reference(Y[:, d], None, naive.DEFAULT_MODEL)
        p, acc = z[:, 0], z[:, 2]
        total += float(np.sum(np.abs((p[1:] - p[:-1]) * acc[:-1])))
    return total


def _turn(v, h):  # ground vector (side, forward) into the frame of heading h
    c, s = math.cos(h), math.sin(h)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def inbetween_scores_reference(ctx, gap: int, library, w: int, config, metres_per_unit: float):
    """[(score, clip, start time, rate), ...] of every valid candidate, lowest score first."""
    g = int(gap)
    wl = max(3, min(w, g))
    tol = config.travel_tolerance_m / metres_per_unit
    ptol = config.pose_tolerance_m / metres_per_unit
    one_sided = len(ctx.future) == 0
    refs = [(np.asarray(ctx.past[-2]), -1), (np.asarray(ctx.past[-1]), 0)]
    if not one_sided:
        refs.append((np.asarray(ctx.future[0]), g + 1))
    last = g if one_sided else g + 1
    bob = config.bob_weight > 0 and ctx.pelvis is not None and ctx.frame_time is not None
    if bob:
        hc = np.asarray(ctx.pelvis, float)
        bob = len(hc) >= 3
        k = min(max(1, round(config.bob_span_seconds / 2 / ctx.frame_time)), (len(hc) - 1) // 2)
    out = []
    for W in library.warped:
        N, m = W.feats.shape
        with_bob = bob and W.pelvis is not None
        for s in range(1, N):
            frames = [s - 1, s + last, s + wl, s + g - wl + 1]
            if min(frames) < 0 or max(frames) >= N:
                continue
            if len({int(W.clip[f]) for f in range(min(frames), max(frames) + 1)}) != 1:
                continue
            score = 0.0
            if config.lscore_weight > 0:
                ls = _lscore(np.concatenate([ctx.past, W.feats[s + 1 : s + 1 + wl]]))
                le = 0.0
                if not one_sided:
                    le = _lscore(np.concatenate([W.feats[s + g - wl + 1 : s + g + 1], ctx.future]))
                score += config.lscore_weight * (ls + le)
            h0 = W.heading[s]
            # the library's own speed, or at the clip's end the speed as the segment plays it
            v = _turn(W.ground[s] - W.ground[s - 1], h0) / (1.0 if one_sided else W.rate)
            travel = np.sum((v - ctx.velocity) ** 2) * (g + 1) ** 2 / tol**2 / 4.0
            if not one_sided:
                d = _turn(W.ground[s + g + 1] - W.ground[s], h0)
                dh = W.heading[s + g + 1] - W.heading[s]
                travel += np.sum((d - ctx.travel) ** 2) / tol**2
                travel += ((dh - ctx.turn) / math.radians(config.turn_tolerance_deg)) ** 2
                if ctx.frame_time is not None and config.travel_seconds > 0:
                    # past travel_seconds, the differences as rates over the gap's length
                    span = (g + 1) * ctx.frame_time
                    if span > config.travel_seconds:
                        travel *= (config.travel_seconds / span) ** 2
            score += config.travel_weight * travel
            pose = sum(float(np.sum((W.feats[s + k].astype(float) - c) ** 2)) for c, k in refs)
            score += config.pose_weight * (3 / len(refs)) * pose / ((m / 3) * ptol**2)
            if with_bob:  # the pelvis' vertical motion ending on A-1, the context's and s's
                h, dt = W.pelvis, ctx.frame_time
                lo = min(i for i in range(N) if W.clip[i] == W.clip[s])  # s's clip starts here
                ks = min(k, max(1, (s - lo) // 2))  # as long a span as its clip has
                end = s if s - lo >= 2 else s + 1  # on the clip's second frame: a frame later
                seg_acc = (h[end] - 2 * h[end - ks] + h[end - 2 * ks]) / (ks * dt) ** 2
                seg_vel = (h[end] - h[end - 2 * ks]) / (2 * ks * dt)
                ctx_acc = (hc[-1] - 2 * hc[-1 - ks] + hc[-1 - 2 * ks]) / (ks * dt) ** 2
                ctx_vel = (hc[-1] - hc[-1 - 2 * ks]) / (2 * ks * dt)
                cost = ((seg_acc - ctx_acc) * metres_per_unit / config.bob_tolerance_m_s2) ** 2
                if config.bob_speed_tolerance_m_s > 0:
                    cost += (
                        (seg_vel - ctx_vel) * metres_per_unit / config.bob_speed_tolerance_m_s
                    ) ** 2
                score += config.bob_weight * cost
            out.append((float(score), int(W.clip[s]), float(W.time[s]), float(W.rate)))
    out.sort(key=lambda x: x[0])
    return out


def local_linear_reference(Y, X, w, rank: int, ridge: float):
    """The local linear estimate at X = 0 of fills ``Y`` (k, n) from mismatches ``X`` (k, d),
    written out: weights ``w`` normalised; the mismatches' ``rank`` main directions from the
    eigenvectors of their weighted covariance; then weighted least squares of Y on an
    intercept and the mismatches along those directions, measured from the context (so the
    intercept is the estimate there), with ``ridge**2`` added to the slopes only."""
    Y, X, w = (np.asarray(v, float) for v in (Y, X, w))
    w = w / w.sum()
    mean = np.sum(w[:, None] * X, axis=0)
    cov = sum(wi * np.outer(x - mean, x - mean) for wi, x in zip(w, X, strict=True))
    vals, vecs = np.linalg.eigh(cov)
    P = vecs[:, np.argsort(vals)[::-1][:rank]]
    D = np.hstack([np.ones((len(X), 1)), X @ P])  # the context is at X = 0
    pen = np.diag([0.0] + [ridge**2] * rank)
    beta = np.linalg.solve(D.T @ (w[:, None] * D) + pen, D.T @ (w[:, None] * Y))
    return beta[0]


def gait_predicted_reference(past, mirrored, h: int, frames):
    """mocapkit.stitch.gait.predicted one frame at a time: frame t (0 = the gap's first) takes
    the past frame t - m h for the least m >= 1 that reaches the last h past frames, mirrored
    where m is odd; a past frame the clip lacks (more than P back) is the normalised lerp
    between the mirror of the last past frame (h + 1 back) and the first past frame (P back).
    Returns (poses with the fields of past, have)."""
    from mocapkit.stitch.gait import BodyLocal

    P = past.heights.shape[0]

    def pose(src, k):
        return src.rotations[k], src.heights[k], src.translations[k]

    def nlerp(x, y, f):
        qy = np.where(np.sum(x[0] * y[0], -1, keepdims=True) < 0, -y[0], y[0])
        q = (1 - f) * x[0] + f * qy
        return q / np.linalg.norm(q, axis=-1, keepdims=True), (1 - f) * x[1] + f * y[1], (
            (1 - f) * x[2] + f * y[2])

    rots, hts, trs, have = [], [], [], []
    for t in frames:
        m = 1
        while t - m * h > -1:
            m += 1
        u = t - m * h  # frames back from the gap: -h .. -1 (or -1-h for t = -1)
        odd = m % 2 == 1
        plain, mir = (mirrored, past) if odd else (past, mirrored)
        k = u + P
        if k >= 0:
            r = pose(plain, k)
            have.append(True)
        else:
            f = min(max((u + 1 + h) / max(h + 1 - P, 1), 0.0), 1.0)
            r = nlerp(pose(mir, P - 1), pose(plain, 0), f)
            have.append(False)
        rots.append(r[0])
        hts.append(r[1])
        trs.append(r[2])
    return BodyLocal(np.array(rots), np.array(hts), np.array(trs)), np.array(have)
