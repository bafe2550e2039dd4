"""Pose distance (Lee et al. 2002) and constrained DTW between motion-words.

Pose distance between frames ``a`` and ``b`` of a joint group (Eq. 1 of the paper)::

    d(a, b) = sum_k || log(q_bk^-1 q_ak) ||^2      (k over the group's joints)

``|| log q ||`` is half the rotation angle of ``q`` (:func:`mocapkit.core.rotations.quat_log`), i.e.
``acos(|<q_a, q_b>|)`` for unit quaternions, so one 4-vector dot product per joint gives it
(the kernel evaluates ``acos`` by a polynomial accurate to 2e-8 rad). Outlier tolerance: the
``trim`` largest joint terms of each frame pair are dropped.

Constrained DTW (paper's Appendix, after Mueller 2007) of a source word (``N`` frames, rows) and a
target word (``M`` frames, columns) on their frame-distance block ``D`` (N x M):

- the path starts at (0, 0) and stops as soon as it reaches the last row or the last column
  (whichever word ends first); it never runs along the last row/column;
- steps (1, 0), (0, 1), (1, 1) (monotone, continuous);
- slope constraint: at most ``max_run`` consecutive (1, 0) steps or (0, 1) steps
  (``max_run = 0``: unconstrained);
- for every end cell the path of least cumulative cost is kept (ties: fewer cells), and the word
  distance is the least *mean* cost over the end cells: ``cost / number of matched pairs``
  (ties: the shorter path). Least-sum per end cell, then least mean across end cells: comparing
  sums across end cells would favour the shortest paths.

Hot loops are private numba kernels behind validating wrappers; the readable reference they are
tested against is ``tests/clean/naive.py``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numba as nb
import numpy as np

from mocapkit.clean.words import JointGroup

MAX_RUN = 2
"""Default slope constraint: at most two consecutive non-diagonal steps in one direction."""

_INF = np.inf


# ------------------------------------------------------------------------ pose distances


@nb.njit(inline="always")
def _acos01(x):  # pragma: no cover - compiled
    """arccos on [0, 1] to 2e-8 rad (Abramowitz & Stegun 4.4.46): one sqrt, no libm call."""
    p = -0.0012624911
    p = p * x + 0.0066700901
    p = p * x - 0.0170881256
    p = p * x + 0.0308918810
    p = p * x - 0.0501743046
    p = p * x + 0.0889789874
    p = p * x - 0.2145988016
    p = p * x + 1.5707963050
    return np.sqrt(1.0 - x) * p


@nb.njit(parallel=True, fastmath=False, cache=True)
def _pose_dist_kernel(src, ctxT, members, counts, trims, out):  # pragma: no cover - compiled
    # src (Fs, J, 4); ctxT (J, 4, Fc) (structure of arrays: the loops over context frames are
    # contiguous and vectorise); members (G, Jmax), counts (G,), trims (G,); out (G, Fs, Fc)
    Fs = src.shape[0]
    J = src.shape[1]
    Fc = ctxT.shape[2]
    G = members.shape[0]
    used = np.zeros(J, dtype=np.bool_)
    for g in range(G):
        for k in range(counts[g]):
            used[members[g, k]] = True
    for a in nb.prange(Fs):
        terms = np.empty((J, Fc))
        s = np.empty(Fc)
        m1 = np.empty(Fc)
        m2 = np.empty(Fc)
        m3 = np.empty(Fc)
        for j in range(J):
            if not used[j]:
                continue
            q0 = src[a, j, 0]
            q1 = src[a, j, 1]
            q2 = src[a, j, 2]
            q3 = src[a, j, 3]
            c0 = ctxT[j, 0]
            c1 = ctxT[j, 1]
            c2 = ctxT[j, 2]
            c3 = ctxT[j, 3]
            tj = terms[j]
            for b in range(Fc):
                d = abs(q0 * c0[b] + q1 * c1[b] + q2 * c2[b] + q3 * c3[b])
                d = min(d, 1.0)
                h = _acos01(d)
                tj[b] = h * h
        for g in range(G):
            t = trims[g]
            for b in range(Fc):
                s[b] = 0.0
                m1[b] = 0.0
                m2[b] = 0.0
                m3[b] = 0.0
            for k in range(counts[g]):
                tk = terms[members[g, k]]
                for b in range(Fc):
                    v = tk[b]
                    s[b] += v
                    # keep the three largest terms (branch-free insertion)
                    hi1 = max(m1[b], v)
                    lo1 = min(m1[b], v)
                    hi2 = max(m2[b], lo1)
                    lo2 = min(m2[b], lo1)
                    m1[b] = hi1
                    m2[b] = hi2
                    m3[b] = max(m3[b], lo2)
            og = out[g, a]
            for b in range(Fc):
                v = s[b]
                if t >= 1:
                    v -= m1[b]
                if t >= 2:
                    v -= m2[b]
                if t >= 3:
                    v -= m3[b]
                og[b] = max(v, 0.0)


def _group_arrays(groups: Sequence[JointGroup], J: int) -> tuple[np.ndarray, ...]:
    G = len(groups)
    if G == 0:
        raise ValueError("at least one joint group is needed")
    jmax = max(len(g.joints) for g in groups)
    members = np.zeros((G, jmax), dtype=np.int64)
    counts = np.zeros(G, dtype=np.int64)
    trims = np.zeros(G, dtype=np.int64)
    for i, g in enumerate(groups):
        if max(g.joints) >= J:
            raise ValueError(f"joint group {g.name!r} names joint {max(g.joints)} of {J}")
        if g.trim > 3:
            raise ValueError(f"joint group {g.name!r}: trim > 3 is not supported")
        members[i, : len(g.joints)] = g.joints
        counts[i] = len(g.joints)
        trims[i] = g.trim
    return members, counts, trims


def pose_distance_matrices(
    source: np.ndarray, context: np.ndarray, groups: Sequence[JointGroup]
) -> np.ndarray:
    """Frame-to-frame pose distances, one matrix per group.

    Args:
        source: (Fs, J, 4) unit quaternions (a texture).
        context: (Fc, J, 4) unit quaternions, same joints.
        groups: joint groups (indices into J) with their trims (at most 3).

    Returns:
        (G, Fs, Fc) float32: ``out[g, a, b]`` = Eq. 1 over group ``g`` between source frame ``a``
        and context frame ``b``, the ``trim`` largest joint terms dropped.
    """
    src = np.ascontiguousarray(source, dtype=np.float64)
    ctx = np.ascontiguousarray(context, dtype=np.float64)
    if src.ndim != 3 or src.shape[2] != 4 or ctx.ndim != 3 or ctx.shape[1:] != src.shape[1:]:
        raise ValueError(f"source/context must be (F, J, 4) alike, got {src.shape}, {ctx.shape}")
    members, counts, trims = _group_arrays(groups, src.shape[1])
    out = np.empty((len(groups), src.shape[0], ctx.shape[0]), dtype=np.float32)
    if src.shape[0] and ctx.shape[0]:
        ctxT = np.ascontiguousarray(ctx.transpose(1, 2, 0))
        _pose_dist_kernel(src, ctxT, members, counts, trims, out)
    return out


def pose_distance(a: np.ndarray, b: np.ndarray, trim: int = 0) -> np.ndarray:
    """Eq. 1 between poses ``a`` and ``b`` ((..., m, 4) broadcasting), ``trim`` largest terms
    dropped: (...) float64. A plain NumPy version for small inputs."""
    d = np.clip(np.abs(np.sum(np.asarray(a) * np.asarray(b), axis=-1)), 0.0, 1.0)
    terms = np.arccos(d) ** 2
    if trim:
        terms = np.sort(terms, axis=-1)[..., : terms.shape[-1] - trim]
    return terms.sum(axis=-1)


# ------------------------------------------------------------------------ constrained DTW


@nb.njit(cache=True)
def _dtw_block(D, r0, c0, N, M, S, cost, length, ncost, nlen):  # pragma: no cover - compiled
    """Mean cost of the constrained DTW on D[r0:r0+N, c0:c0+M].

    cost/length/ncost/nlen: work buffers (nstates, M); nstates = 2*S+1 (S>0) or 1 (S=0).
    States: 0 diagonal/start, 1..S horizontal run (0,1) of that length, S+1..2S vertical run.
    Returns (best mean, path length).
    """
    ns = 2 * S + 1 if S > 0 else 1
    inf = np.inf
    best = inf
    best_len = 0
    for s in range(ns):
        for j in range(M):
            cost[s, j] = inf
            length[s, j] = 0
    # row 0: start cell then horizontal moves only
    cost[0, 0] = D[r0, c0]
    length[0, 0] = 1
    if N == 1 or M == 1:
        return cost[0, 0], 1
    for j in range(1, M):
        v = D[r0, c0 + j]
        if S == 0:
            cost[0, j] = cost[0, j - 1] + v
            length[0, j] = length[0, j - 1] + 1
        else:
            # reach (0, j) with a horizontal run of length j (only from the start)
            if j <= S and j < M:
                prev = cost[0, j - 1] if j == 1 else cost[j - 1, j - 1]
                pl = length[0, j - 1] if j == 1 else length[j - 1, j - 1]
                cost[j, j] = prev + v
                length[j, j] = pl + 1
        if j == M - 1:
            ec = inf
            el = 0
            for s in range(ns):
                if cost[s, j] < ec or (cost[s, j] == ec and length[s, j] < el):
                    ec = cost[s, j]
                    el = length[s, j]
            if ec < inf:
                mean = ec / el
                if mean < best or (mean == best and el < best_len):
                    best = mean
                    best_len = el
    for i in range(1, N):
        last_row = i == N - 1
        for s in range(ns):
            for j in range(M):
                ncost[s, j] = inf
                nlen[s, j] = 0
        for j in range(M):
            v = D[r0 + i, c0 + j]
            # predecessor cells must not be end cells: (i-1, *) is an end cell only if j-1/j is
            # the last column; (i-1, M-1) is excluded by j <= M-1 for diagonal; vertical from
            # (i-1, M-1) is excluded below; horizontal from (i, j-1) excluded on the last row.
            # diagonal from (i-1, j-1)
            if j >= 1:
                bc = inf
                bl = 0
                for s in range(ns):
                    c = cost[s, j - 1]
                    if c < bc or (c == bc and length[s, j - 1] < bl):
                        bc = c
                        bl = length[s, j - 1]
                if bc < inf:
                    ncost[0, j] = bc + v
                    nlen[0, j] = bl + 1
            # vertical from (i-1, j) (not from the last column: that is an end cell)
            if j < M - 1:
                if S == 0:
                    c = cost[0, j]
                    if c < inf:
                        c += v
                        if c < ncost[0, j] or (c == ncost[0, j] and length[0, j] + 1 < nlen[0, j]):
                            ncost[0, j] = c
                            nlen[0, j] = length[0, j] + 1
                else:
                    # run length 1: from diagonal or horizontal states
                    bc = inf
                    bl = 0
                    for s in range(0, S + 1):
                        c = cost[s, j]
                        if c < bc or (c == bc and length[s, j] < bl):
                            bc = c
                            bl = length[s, j]
                    if bc < inf:
                        ncost[S + 1, j] = bc + v
                        nlen[S + 1, j] = bl + 1
                    for k in range(2, S + 1):
                        c = cost[S + k - 1, j]
                        if c < inf:
                            ncost[S + k, j] = c + v
                            nlen[S + k, j] = length[S + k - 1, j] + 1
            # horizontal from (i, j-1) (not along the last row, and not from the last column)
            if j >= 1 and not last_row:
                if S == 0:
                    c = ncost[0, j - 1]
                    if c < inf:
                        c += v
                        if c < ncost[0, j] or (
                            c == ncost[0, j] and nlen[0, j - 1] + 1 < nlen[0, j]
                        ):
                            ncost[0, j] = c
                            nlen[0, j] = nlen[0, j - 1] + 1
                else:
                    bc = inf
                    bl = 0
                    for s in range(ns):
                        if 1 <= s <= S:
                            continue
                        c = ncost[s, j - 1]
                        if c < bc or (c == bc and nlen[s, j - 1] < bl):
                            bc = c
                            bl = nlen[s, j - 1]
                    if bc < inf:
                        ncost[1, j] = bc + v
                        nlen[1, j] = bl + 1
                    for k in range(2, S + 1):
                        c = ncost[k - 1, j - 1]
                        if c < inf:
                            ncost[k, j] = c + v
                            nlen[k, j] = nlen[k - 1, j - 1] + 1
            if last_row or j == M - 1:
                ec = inf
                el = 0
                for s in range(ns):
                    if ncost[s, j] < ec or (ncost[s, j] == ec and nlen[s, j] < el):
                        ec = ncost[s, j]
                        el = nlen[s, j]
                if ec < inf:
                    mean = ec / el
                    if mean < best or (mean == best and el < best_len):
                        best = mean
                        best_len = el
        for s in range(ns):
            for j in range(M):
                cost[s, j] = ncost[s, j]
                length[s, j] = nlen[s, j]
    return best, best_len


@nb.njit(cache=True)
def _dtw_path(D, S):  # pragma: no cover - compiled
    """Full tables with back-pointers on a whole (N, M) block: returns (mean, path (p, 2))."""
    N, M = D.shape
    ns = 2 * S + 1 if S > 0 else 1
    inf = np.inf
    cost = np.full((N, M, ns), inf)
    length = np.zeros((N, M, ns), dtype=np.int64)
    back = np.full((N, M, ns, 3), -1, dtype=np.int64)  # (pi, pj, ps)
    cost[0, 0, 0] = D[0, 0]
    length[0, 0, 0] = 1
    for i in range(N):
        for j in range(M):
            if i == 0 and j == 0:
                continue
            v = D[i, j]
            # diagonal
            if i >= 1 and j >= 1 and i - 1 < N - 1 and j - 1 < M - 1:
                for s in range(ns):
                    c = cost[i - 1, j - 1, s]
                    if c == inf:
                        continue
                    nc = c + v
                    nl = length[i - 1, j - 1, s] + 1
                    if nc < cost[i, j, 0] or (nc == cost[i, j, 0] and nl < length[i, j, 0]):
                        cost[i, j, 0] = nc
                        length[i, j, 0] = nl
                        back[i, j, 0, 0] = i - 1
                        back[i, j, 0, 1] = j - 1
                        back[i, j, 0, 2] = s
            # vertical from (i-1, j)
            if i >= 1 and j < M - 1 and i - 1 < N - 1:
                for s in range(ns):
                    c = cost[i - 1, j, s]
                    if c == inf:
                        continue
                    if S == 0:
                        t = 0
                    elif s == 0 or s <= S:
                        t = S + 1
                    elif s < 2 * S:
                        t = s + 1
                    else:
                        continue
                    nc = c + v
                    nl = length[i - 1, j, s] + 1
                    if nc < cost[i, j, t] or (nc == cost[i, j, t] and nl < length[i, j, t]):
                        cost[i, j, t] = nc
                        length[i, j, t] = nl
                        back[i, j, t, 0] = i - 1
                        back[i, j, t, 1] = j
                        back[i, j, t, 2] = s
            # horizontal from (i, j-1)
            if j >= 1 and i < N - 1 and j - 1 < M - 1:
                for s in range(ns):
                    c = cost[i, j - 1, s]
                    if c == inf:
                        continue
                    if S == 0:
                        t = 0
                    elif s == 0 or s > S:
                        t = 1
                    elif s < S:
                        t = s + 1
                    else:
                        continue
                    nc = c + v
                    nl = length[i, j - 1, s] + 1
                    if nc < cost[i, j, t] or (nc == cost[i, j, t] and nl < length[i, j, t]):
                        cost[i, j, t] = nc
                        length[i, j, t] = nl
                        back[i, j, t, 0] = i
                        back[i, j, t, 1] = j - 1
                        back[i, j, t, 2] = s
    best = inf
    bl = 0
    bi = 0
    bj = 0
    bs = 0
    if N == 1 or M == 1:
        out = np.zeros((1, 2), dtype=np.int64)
        return D[0, 0], out
    for i in range(N):
        for j in range(M):
            if i != N - 1 and j != M - 1:
                continue
            es = -1
            for s in range(ns):
                c = cost[i, j, s]
                if c == inf:
                    continue
                if (
                    es < 0
                    or c < cost[i, j, es]
                    or (c == cost[i, j, es] and length[i, j, s] < length[i, j, es])
                ):
                    es = s
            if es < 0:
                continue
            mean = cost[i, j, es] / length[i, j, es]
            if mean < best or (mean == best and length[i, j, es] < bl):
                best = mean
                bl = length[i, j, es]
                bi = i
                bj = j
                bs = es
    path = np.zeros((bl, 2), dtype=np.int64)
    k = bl - 1
    i, j, s = bi, bj, bs
    while k >= 0:
        path[k, 0] = i
        path[k, 1] = j
        pi = back[i, j, s, 0]
        pj = back[i, j, s, 1]
        ps = back[i, j, s, 2]
        i, j, s = pi, pj, ps
        k -= 1
    return best, path


def constrained_dtw(D: np.ndarray, max_run: int = MAX_RUN) -> tuple[float, np.ndarray]:
    """Constrained DTW of a source word (rows) against a target word (columns).

    Args:
        D: (N, M) frame-to-frame distances (N, M >= 1), finite and non-negative.
        max_run: slope constraint (at most this many consecutive (1,0) or (0,1) steps; 0: none).

    Returns:
        (mean matched cost, path (p, 2) of (row, column) pairs from (0, 0) to the end cell).
    """
    D = np.ascontiguousarray(D, dtype=np.float64)
    if D.ndim != 2 or min(D.shape) < 1:
        raise ValueError(f"D must be a non-empty 2-D array, got shape {D.shape}")
    if not np.all(np.isfinite(D)) or (D < 0).any():
        raise ValueError("D must be finite and non-negative")
    if max_run < 0:
        raise ValueError(f"max_run must be >= 0, got {max_run}")
    mean, path = _dtw_path(D, int(max_run))
    return float(mean), path


def dtw_mean_cost(D: np.ndarray, max_run: int = MAX_RUN) -> float:
    """Only the mean matched cost of :func:`constrained_dtw` (the fast kernel, no path)."""
    D = np.ascontiguousarray(D, dtype=np.float64)
    if D.ndim != 2 or min(D.shape) < 1:
        raise ValueError(f"D must be a non-empty 2-D array, got shape {D.shape}")
    S = int(max_run)
    if S < 0:
        raise ValueError(f"max_run must be >= 0, got {max_run}")
    ns = 2 * S + 1 if S > 0 else 1
    M = D.shape[1]
    bufs = [np.empty((ns, M)) for _ in range(2)] + [np.empty((ns, M), np.int64) for _ in range(2)]
    mean, _ = _dtw_block(D, 0, 0, D.shape[0], M, S, bufs[0], bufs[2], bufs[1], bufs[3])
    return float(mean)


# ------------------------------------------------------------------------ word scans


@nb.njit(parallel=True, cache=True)
def _scan_kernel(D, starts, N, tstarts, M, S, out):  # pragma: no cover - compiled
    # D (Fs, Fc) float32; starts (W,) source word starts; tstarts (C,) target word starts
    W = starts.shape[0]
    C = tstarts.shape[0]
    ns = 2 * S + 1 if S > 0 else 1
    for w in nb.prange(W):
        cost = np.empty((ns, M))
        length = np.empty((ns, M), dtype=np.int64)
        ncost = np.empty((ns, M))
        nlen = np.empty((ns, M), dtype=np.int64)
        r0 = starts[w]
        for c in range(C):
            m, _ = _dtw_block(D, r0, tstarts[c], N, M, S, cost, length, ncost, nlen)
            out[w, c] = m


def scan_words(
    D: np.ndarray,
    starts: np.ndarray,
    source_len: int,
    target_starts: np.ndarray,
    target_len: int,
    max_run: int = MAX_RUN,
) -> np.ndarray:
    """Word distances of every source word against every target word, on one distance matrix.

    Args:
        D: (Fs, Fc) frame distances (source frames x context frames), e.g. one group of
            :func:`pose_distance_matrices`.
        starts: (W,) first source frame of each source word (``start + source_len <= Fs``).
        source_len: N.
        target_starts: (C,) first context frame of each target word (``+ target_len <= Fc``).
        target_len: M.
        max_run: slope constraint.

    Returns:
        (W, C) float64 constrained-DTW mean costs.
    """
    D = np.ascontiguousarray(D)
    if D.dtype not in (np.float32, np.float64):
        D = D.astype(np.float64)
    starts = np.ascontiguousarray(starts, dtype=np.int64)
    tst = np.ascontiguousarray(target_starts, dtype=np.int64)
    if D.ndim != 2:
        raise ValueError("D must be 2-D")
    if source_len < 1 or target_len < 1:
        raise ValueError("word lengths must be >= 1")
    if len(starts) and (starts.min() < 0 or starts.max() + source_len > D.shape[0]):
        raise ValueError("a source word runs outside the distance matrix")
    if len(tst) and (tst.min() < 0 or tst.max() + target_len > D.shape[1]):
        raise ValueError("a target word runs outside the distance matrix")
    if max_run < 0:
        raise ValueError("max_run must be >= 0")
    out = np.empty((len(starts), len(tst)))
    if len(starts) and len(tst):
        if max_run == 2:
            _scan_kernel_s2(D, starts, int(source_len), tst, int(target_len), out)
        else:
            _scan_kernel(D, starts, int(source_len), tst, int(target_len), int(max_run), out)
    return out


@nb.njit(inline="always")
def _better(c, n, bc, bn):  # pragma: no cover - compiled
    return c < bc or (c == bc and n < bn)


@nb.njit(parallel=True, cache=True, fastmath=False)
def _scan_kernel_s2(D, starts, N, tstarts, M, out):  # pragma: no cover - compiled
    """Specialised :func:`_scan_kernel` for ``max_run == 2``: :func:`_dtw_s2_one` on every
    (source word, target word) block, with row buffers per thread. Same semantics and
    tie-breaks as :func:`_dtw_block`."""
    W = starts.shape[0]
    C = tstarts.shape[0]
    for w in nb.prange(W):
        bufs_f = np.empty((6, M))
        bufs_i = np.empty((6, M), dtype=np.int64)
        for c in range(C):
            out[w, c] = _dtw_s2_one(
                D, starts[w], tstarts[c], N, M,
                bufs_f[0], bufs_i[0], bufs_f[1], bufs_i[1], bufs_f[2], bufs_i[2],
                bufs_f[3], bufs_i[3], bufs_f[4], bufs_i[4], bufs_f[5], bufs_i[5],
            )  # fmt: skip


# ------------------------------------------------- one max_run == 2 block, and the KNN scans


@nb.njit(cache=True)
def _dtw_s2_one(
    D, r0, c0, N, M, pa_c, pa_n, pdh_c, pdh_n, pv1_c, pv1_n, ca_c, ca_n, cdh_c, cdh_n, cv1_c, cv1_n
):  # pragma: no cover - compiled
    """Constrained DTW mean cost of the block ``D[r0 : r0 + N, c0 : c0 + M]`` for
    ``max_run == 2``, with the states unrolled (the last step diagonal, one or two vertical,
    one or two horizontal) and caller row buffers (previous / current row: best over all
    states, best over diagonal and horizontal, vertical-1). Same semantics and tie-breaks as
    :func:`_dtw_block`."""
    inf = np.inf
    best = inf
    best_n = 0
    if N == 1 or M == 1:
        return np.float64(D[r0, c0])
    for j in range(M):
        pa_c[j] = inf
        pa_n[j] = 0
        pdh_c[j] = inf
        pdh_n[j] = 0
        pv1_c[j] = inf
        pv1_n[j] = 0
    acc = np.float64(D[r0, c0])
    pa_c[0] = acc
    pa_n[0] = 1
    pdh_c[0] = acc
    pdh_n[0] = 1
    for j in range(1, min(3, M)):
        acc += D[r0, c0 + j]
        pa_c[j] = acc
        pa_n[j] = j + 1
        pdh_c[j] = acc
        pdh_n[j] = j + 1
        if j == M - 1:
            mean = acc / (j + 1)
            if mean < best or (mean == best and j + 1 < best_n):
                best = mean
                best_n = j + 1
    for i in range(1, N):
        last_row = i == N - 1
        h1_c = inf
        h1_n = 0
        dv_c = inf
        dv_n = 0
        for j in range(M):
            v = np.float64(D[r0 + i, c0 + j])
            d_c = inf
            d_n = 0
            if j >= 1 and pa_c[j - 1] < inf:
                d_c = pa_c[j - 1] + v
                d_n = pa_n[j - 1] + 1
            v1_c = inf
            v1_n = 0
            v2_c = inf
            v2_n = 0
            if j < M - 1:
                if pdh_c[j] < inf:
                    v1_c = pdh_c[j] + v
                    v1_n = pdh_n[j] + 1
                if pv1_c[j] < inf:
                    v2_c = pv1_c[j] + v
                    v2_n = pv1_n[j] + 1
            nh1_c = inf
            nh1_n = 0
            nh2_c = inf
            nh2_n = 0
            if j >= 1 and not last_row:
                if dv_c < inf:
                    nh1_c = dv_c + v
                    nh1_n = dv_n + 1
                if h1_c < inf:
                    nh2_c = h1_c + v
                    nh2_n = h1_n + 1
            dvb_c = d_c
            dvb_n = d_n
            if _better(v1_c, v1_n, dvb_c, dvb_n):
                dvb_c = v1_c
                dvb_n = v1_n
            if _better(v2_c, v2_n, dvb_c, dvb_n):
                dvb_c = v2_c
                dvb_n = v2_n
            dh_c = d_c
            dh_n = d_n
            if _better(nh1_c, nh1_n, dh_c, dh_n):
                dh_c = nh1_c
                dh_n = nh1_n
            if _better(nh2_c, nh2_n, dh_c, dh_n):
                dh_c = nh2_c
                dh_n = nh2_n
            a_c = dvb_c
            a_n = dvb_n
            if _better(nh1_c, nh1_n, a_c, a_n):
                a_c = nh1_c
                a_n = nh1_n
            if _better(nh2_c, nh2_n, a_c, a_n):
                a_c = nh2_c
                a_n = nh2_n
            ca_c[j] = a_c
            ca_n[j] = a_n
            cdh_c[j] = dh_c
            cdh_n[j] = dh_n
            cv1_c[j] = v1_c
            cv1_n[j] = v1_n
            if (last_row or j == M - 1) and a_c < inf:
                mean = a_c / a_n
                if mean < best or (mean == best and a_n < best_n):
                    best = mean
                    best_n = a_n
            h1_c = nh1_c
            h1_n = nh1_n
            dv_c = dvb_c
            dv_n = dvb_n
        for j in range(M):
            pa_c[j] = ca_c[j]
            pa_n[j] = ca_n[j]
            pdh_c[j] = cdh_c[j]
            pdh_n[j] = cdh_n[j]
            pv1_c[j] = cv1_c[j]
            pv1_n[j] = cv1_n[j]
    return best


@nb.njit(parallel=True, cache=True)
def _scan_pruned_kernel(
    D, rowmin, starts, N, tstarts, seg, M, K, lo, hi, stride, out, nexact
):  # pragma: no cover - compiled
    W = starts.shape[0]
    C = tstarts.shape[0]
    Fc = D.shape[1]
    inf = np.inf
    pmax = N + M - 1
    for w in nb.prange(W):
        bufs_f = np.empty((6, M))
        bufs_i = np.empty((6, M), dtype=np.int64)
        a = starts[w]
        count = 0
        # 1. exact distances on a coarse grid of candidates
        for c in range(0, C, stride):
            out[w, c] = _dtw_s2_one(
                D, a, tstarts[c], N, M,
                bufs_f[0], bufs_i[0], bufs_f[1], bufs_i[1], bufs_f[2], bufs_i[2],
                bufs_f[3], bufs_i[3], bufs_f[4], bufs_i[4], bufs_f[5], bufs_i[5],
            )  # fmt: skip
            count += 1
        # 2. tau: K-th smallest coarse local minimum whose basin lies in one take, outside the
        # exclusion zone; the true function has a distinct local minimum <= it in each basin
        vals = np.empty(C // stride + 1)
        nv = 0
        for c in range(stride, C - stride, stride):
            cl = c - stride
            cr = c + stride
            if seg[cl] != seg[cr]:
                continue
            if not (out[w, c] < out[w, cl] and out[w, c] < out[w, cr]):
                continue
            # basin [tstarts[cl], tstarts[cr]] of target centres must avoid [lo, hi)
            outside = tstarts[cr] + M // 2 < lo[w] or tstarts[cl] + M // 2 >= hi[w]
            if lo[w] < hi[w] and not outside:
                continue
            vals[nv] = out[w, c]
            nv += 1
        tau = inf
        if nv >= K:
            tau = np.sort(vals[:nv])[K - 1]
        # 3. lower bounds: a path ending on the last row crosses every row, one ending on the
        # last column every column; a path has at most N + M - 1 cells
        lbr = np.zeros(Fc)
        for i in range(N):
            for x in range(Fc - M + 1):
                lbr[x] += rowmin[a + i, x]
        colmin = np.empty(Fc)
        for x in range(Fc):
            m = D[a, x]
            for i in range(1, N):
                if D[a + i, x] < m:
                    m = D[a + i, x]
            colmin[x] = m
        csum = np.zeros(Fc + 1)
        for x in range(Fc):
            csum[x + 1] = csum[x] + colmin[x]
        # 4. exact distances where the bound does not rule the candidate out
        for c in range(C):
            if c % stride == 0:
                continue
            t0 = tstarts[c]
            lbc = csum[t0 + M] - csum[t0]
            lb = min(lbr[t0], lbc) / pmax
            if lb >= tau:
                out[w, c] = inf
                continue
            out[w, c] = _dtw_s2_one(
                D, a, t0, N, M,
                bufs_f[0], bufs_i[0], bufs_f[1], bufs_i[1], bufs_f[2], bufs_i[2],
                bufs_f[3], bufs_i[3], bufs_f[4], bufs_i[4], bufs_f[5], bufs_i[5],
            )  # fmt: skip
            count += 1
        nexact[w] = count


@nb.njit(parallel=True, cache=True)
def _sliding_row_min(D, rows, M, out):  # pragma: no cover - compiled
    """out[r, x] = min(D[rows[r], x : x + M]) (van Herk / Gil-Werman: 3 comparisons a cell)."""
    Fc = D.shape[1]
    nwin = Fc - M + 1
    for r in nb.prange(rows.shape[0]):
        row = D[rows[r]]
        pre = np.empty(Fc)
        suf = np.empty(Fc)
        for b0 in range(0, Fc, M):
            b1 = min(b0 + M, Fc)
            pre[b0] = row[b0]
            for x in range(b0 + 1, b1):
                pre[x] = min(pre[x - 1], row[x])
            suf[b1 - 1] = row[b1 - 1]
            for x in range(b1 - 2, b0 - 1, -1):
                suf[x] = min(suf[x + 1], row[x])
        for x in range(nwin):
            out[r, x] = min(suf[x], pre[x + M - 1])


def scan_words_pruned(
    D: np.ndarray,
    starts: np.ndarray,
    source_len: int,
    target_starts: np.ndarray,
    segment: np.ndarray,
    target_len: int,
    k: int,
    exclude_lo: np.ndarray | None = None,
    exclude_hi: np.ndarray | None = None,
    stride: int = 8,
) -> tuple[np.ndarray, int]:
    """:func:`scan_words` (``max_run = 2``) computing exactly only what the KNN can need.

    Exact word distances are computed on every ``stride``-th target word; the ``k``-th smallest
    of their local minima (each bracketing a distinct true local minimum, outside the exclusion
    zone ``[exclude_lo[w], exclude_hi[w])`` of target centres) bounds the k-th nearest
    neighbour's distance from above (``tau``). Every other target word whose lower bound (row or
    column minima of its block over the longest possible path) reaches ``tau`` is not computed
    and reported as ``inf``; since all of them lie above the k smallest local minima, the
    selection of :func:`~mocapkit.clean.knn.select_knn` is the same as on the full scan (up to
    exact ties at ``tau``).

    Returns:
        ((W, C) distances with ``inf`` for the pruned words, number of exact DTW evaluations).
    """
    D = np.ascontiguousarray(D)
    if D.dtype not in (np.float32, np.float64):
        D = D.astype(np.float64)
    starts = np.ascontiguousarray(starts, dtype=np.int64)
    tst = np.ascontiguousarray(target_starts, dtype=np.int64)
    seg = np.ascontiguousarray(segment, dtype=np.int64)
    W, C = len(starts), len(tst)
    if seg.shape != (C,):
        raise ValueError("segment must have one entry per target word")
    if W and (starts.min() < 0 or starts.max() + source_len > D.shape[0]):
        raise ValueError("a source word runs outside the distance matrix")
    if C and (tst.min() < 0 or tst.max() + target_len > D.shape[1]):
        raise ValueError("a target word runs outside the distance matrix")
    if k < 1 or stride < 1:
        raise ValueError("k and stride must be >= 1")
    lo = np.zeros(W, np.int64) if exclude_lo is None else np.asarray(exclude_lo, np.int64)
    hi = np.zeros(W, np.int64) if exclude_hi is None else np.asarray(exclude_hi, np.int64)
    out = np.empty((W, C))
    nexact = np.zeros(W, np.int64)
    if W and C:
        M = int(target_len)
        rowmin = np.zeros((D.shape[0], D.shape[1]))
        used = np.unique((starts[:, None] + np.arange(source_len)[None, :]).ravel())
        tmp = np.empty((len(used), max(0, D.shape[1] - M + 1)))
        if tmp.shape[1]:
            _sliding_row_min(D, used, M, tmp)
            rowmin[used, : tmp.shape[1]] = tmp
        _scan_pruned_kernel(
            D, rowmin, starts, int(source_len), tst, seg, M, int(k), lo, hi, int(stride),
            out, nexact,
        )  # fmt: skip
    return out, int(nexact.sum())
