"""K-nearest-neighbour motion-words (Sec. 3.3): distance functions over a context, local minima,
time-warped neighbour words.

A *context* is a list of analysis textures (the take itself first for a "local" search, then any
related takes). Target words (``M`` frames) start at every frame of every context take where they
fit inside that take; a target word is identified by its centre ``start + M // 2``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.signal import resample_poly

from mocapkit.clean.dtw import (
    MAX_RUN,
    constrained_dtw,
    pose_distance_matrices,
    scan_words,
    scan_words_pruned,
)
from mocapkit.clean.words import JointGroup

K_NEIGHBOURS = 5


@dataclass
class Context:
    """Context takes concatenated into one frame axis.

    Attributes:
        rotations: (Fc, J, 4) all context textures end to end.
        clip: (Fc,) index of the take each frame belongs to.
        offsets: (n_takes + 1,) first frame of each take in ``rotations`` (and the total).
        names: take labels.
        self_clip: index of the analysed take inside the context, or -1.
    """

    rotations: np.ndarray
    clip: np.ndarray
    offsets: np.ndarray
    names: list[str]
    self_clip: int = -1

    @classmethod
    def build(
        cls, textures: Sequence[np.ndarray], names: Sequence[str] | None = None, self_clip: int = -1
    ) -> Context:
        if not textures:
            raise ValueError("the context needs at least one take")
        J = textures[0].shape[1]
        for t in textures:
            if t.ndim != 3 or t.shape[1:] != (J, 4):
                raise ValueError("context takes must share the skeleton (same joints)")
        lens = [t.shape[0] for t in textures]
        offsets = np.concatenate([[0], np.cumsum(lens)]).astype(np.int64)
        clip = np.repeat(np.arange(len(textures)), lens)
        names = list(names) if names is not None else [f"take{i}" for i in range(len(textures))]
        rots = np.ascontiguousarray(np.concatenate(textures, axis=0))
        return cls(rots, clip, offsets, names, self_clip)

    @property
    def num_frames(self) -> int:
        return int(self.rotations.shape[0])

    def target_starts(self, target_len: int) -> np.ndarray:
        """(C,) global start frames of every target word lying inside one take."""
        out = []
        for a, b in zip(self.offsets[:-1], self.offsets[1:], strict=True):
            if b - a >= target_len:
                out.append(np.arange(a, b - target_len + 1))
        return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


def local_minima(dist: np.ndarray, segment: np.ndarray) -> np.ndarray:
    """(W, C) bool: ``dist[w, c]`` is a local minimum of row ``w`` within its segment (strictly
    below its left neighbour, not above its right one; segment edges compare one side)."""
    d = np.asarray(dist, dtype=np.float64)
    W, C = d.shape
    left = np.full((W, C), np.inf)
    right = np.full((W, C), np.inf)
    if C > 1:
        same = segment[1:] == segment[:-1]
        left[:, 1:] = np.where(same, d[:, :-1], np.inf)
        right[:, :-1] = np.where(same, d[:, 1:], np.inf)
    return (d < left) & (d <= right) & np.isfinite(d)


def select_knn(
    dist: np.ndarray,
    segment: np.ndarray,
    centres: np.ndarray,
    k: int,
    exclude_lo: np.ndarray | None = None,
    exclude_hi: np.ndarray | None = None,
) -> np.ndarray:
    """Indices (W, k) of the k smallest local minima per row (-1 where fewer exist), sorted by
    distance (ties: lower index); candidates with ``exclude_lo[w] <= centres[c] < exclude_hi[w]``
    (global frame numbers) are skipped."""
    dist = np.asarray(dist, dtype=np.float64)
    W, C = dist.shape
    ok = local_minima(dist, segment)
    if exclude_lo is not None and exclude_hi is not None:
        ok &= ~(
            (centres[None, :] >= exclude_lo[:, None]) & (centres[None, :] < exclude_hi[:, None])
        )
    masked = np.where(ok, dist, np.inf)
    out = np.full((W, k), -1, dtype=np.int64)
    if C == 0:
        return out
    kk = min(k, C)
    part = (
        np.argpartition(masked, kk - 1, axis=1)[:, :kk] if kk < C else np.tile(np.arange(C), (W, 1))
    )
    vals = np.take_along_axis(masked, part, axis=1)
    order = np.lexsort((part, vals), axis=1)
    part = np.take_along_axis(part, order, axis=1)
    vals = np.take_along_axis(vals, order, axis=1)
    out[:, :kk] = np.where(np.isfinite(vals), part, -1)
    return out


@dataclass
class GroupNeighbours:
    """The KNN of every source word of one joint group.

    Attributes:
        group: the joint group.
        starts: (W,) source word starts (analysis frames).
        index: (W, K) global start frame of each neighbour target word in the context (-1: none).
        distance: (W, K) word distances (inf where none).
        words: (W, K, N, m, 4) neighbour words warped and resampled to the source length
            (hemisphere-aligned to the source word), for the group's joints ``group.joints``.
        usable: (W, K, N, m) bool or None: whether neighbour ``k`` may speak for frame ``n``
            of the group's joint ``jj`` (see :func:`untainted`); None: every neighbour found.
    """

    group: JointGroup
    starts: np.ndarray
    index: np.ndarray
    distance: np.ndarray
    words: np.ndarray
    usable: np.ndarray | None = None

    def usable_mask(self) -> np.ndarray:
        """(W, K, N, m) bool: the neighbours found (``index >= 0``) that may speak per frame and
        joint."""
        W, K = self.index.shape
        shape = (W, K, self.words.shape[2] if self.words.ndim == 5 else 0, len(self.group.joints))
        found = np.broadcast_to((self.index >= 0)[:, :, None, None], shape)
        return found & self.usable if self.usable is not None else found.copy()


def untainted(gn: GroupNeighbours, tainted: np.ndarray, target_len: int) -> GroupNeighbours:
    """``gn`` with the neighbour frames that lie on known-bad cells of the take barred.

    ``tainted``: (F, J) bool over the analysed take's frames, which the context holds first
    (global frames ``0 .. F - 1``). Frame ``n`` of a neighbour word (``N`` frames, warped from
    the target word of ``target_len`` frames starting at ``i < F``) is taken from about target
    frame ``i + n (target_len - 1) / (N - 1)``; where that cell is tainted on joint ``j``, the
    neighbour may not speak for ``j`` there (two errors on one joint would vouch for each
    other). A (word, frame, joint) whose neighbours are all barred keeps them all: better a
    doubtful vote than none."""
    bad = np.asarray(tainted, dtype=bool)
    F = bad.shape[0]
    js = np.asarray(gn.group.joints)
    found = gn.usable_mask()
    N = found.shape[2]
    step = (target_len - 1) / max(N - 1, 1)
    pos = gn.index[:, :, None] + np.round(np.arange(N) * step).astype(np.int64)  # (W, K, N)
    inside = (gn.index >= 0)[:, :, None] & (pos < F)
    hit = bad[np.clip(pos, 0, max(F - 1, 0))][..., js] & inside[..., None]  # (W, K, N, m)
    usable = found & ~hit
    none = ~usable.any(axis=1, keepdims=True)  # (W, 1, N, m)
    usable = np.where(none, found, usable)
    return GroupNeighbours(gn.group, gn.starts, gn.index, gn.distance, gn.words, usable)


@functools.lru_cache(maxsize=1024)
def _resample_filter(up: int, down: int, dtype: str = "<f8") -> np.ndarray:
    """The FIR filter ``resample_poly(x, up, down)`` designs by default (a Kaiser window,
    beta 5, cut-off at the lower of the two Nyquist rates) in the signal's ``dtype`` (as
    resample_poly casts it), made once per ratio: designing it cost as much as the resampling.
    Read-only; resample_poly copies it."""
    from scipy.signal import firwin

    g = math.gcd(up, down)  # resample_poly reduces the ratio first
    max_rate = max(up // g, down // g)
    h = firwin(2 * 10 * max_rate + 1, 1.0 / max_rate, window=("kaiser", 5.0))
    h = np.asarray(h, dtype=np.dtype(dtype) if np.dtype(dtype).kind == "f" else None)
    h.setflags(write=False)
    return h


def warp_word(target: np.ndarray, path: np.ndarray, n: int) -> np.ndarray:
    """A target word brought onto a source word of ``n`` frames: the frames of ``target``
    (M, m, 4) visited by the DTW path (p, 2) of (source, target) frame pairs, i.e. the target
    frames ``path[:, 1]`` (p, m, 4), resampled to ``n`` frames (polyphase, renormalised).
    Used for the KNN words of :func:`search_group` and the full-body words of
    :func:`mocapkit.clean.sparse.reconstruct`."""
    seq = target[path[:, 1]]  # (p, m, 4)
    p = seq.shape[0]
    if p == n:
        return seq.copy()
    if p == 1:
        return np.repeat(seq, n, axis=0)
    out = resample_poly(
        seq, n, p, axis=0, window=_resample_filter(n, p, seq.dtype.str), padtype="line"
    )
    if out.shape[0] != n:  # resample_poly gives ceil(p * n / p) == n; guard anyway
        out = out[:n] if out.shape[0] > n else np.concatenate([out, out[-1:]], axis=0)
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def search_group(
    source: np.ndarray,
    context: Context,
    group: JointGroup,
    starts: np.ndarray,
    source_len: int,
    target_len: int,
    k: int = K_NEIGHBOURS,
    exclude: int | None = None,
    max_run: int = MAX_RUN,
    distances: np.ndarray | None = None,
    row_offset: int = 0,
    prune: bool = True,
) -> GroupNeighbours:
    """KNN of the source words of one group.

    Args:
        source: (F, J, 4) analysis texture of the take.
        context: the context (may contain the take itself as ``context.self_clip``).
        group: joint group.
        starts: (W,) source word starts.
        source_len, target_len: N and M.
        k: neighbours per word.
        exclude: minima whose target centre lies within this many frames of the source word
            (``[start - exclude, start + N + exclude)``, in the take itself) are skipped; default
            ``N // 2`` as in the paper.
        max_run: DTW slope constraint.
        distances: optional precomputed (Fs', Fc) pose distances for this group, whose row 0 is
            source frame ``row_offset``.
        prune: use the exact lower-bound pruning of
            :func:`~mocapkit.clean.dtw.scan_words_pruned` (same neighbours, less work).
    """
    N, M = int(source_len), int(target_len)
    exclude = N // 2 if exclude is None else int(exclude)
    if distances is None:
        distances = pose_distance_matrices(source, context.rotations, [group])[0]
        row_offset = 0
    tst = context.target_starts(M)
    seg = context.clip[tst] if len(tst) else np.zeros(0, dtype=np.int64)
    centres = tst + M // 2
    lo = hi = None
    if context.self_clip >= 0:
        base = context.offsets[context.self_clip]
        lo = base + np.asarray(starts) - exclude
        hi = base + np.asarray(starts) + N + exclude
    rows = np.asarray(starts) - row_offset
    if max_run == 2 and prune:
        dist, _ = scan_words_pruned(distances, rows, N, tst, seg, M, k, lo, hi)
    else:
        dist = scan_words(distances, rows, N, tst, M, max_run)
    sel = select_knn(dist, seg, centres, k, lo, hi)
    W = len(starts)
    js = np.asarray(group.joints)
    words = np.zeros((W, k, N, len(js), 4))
    index = np.full((W, k), -1, dtype=np.int64)
    dval = np.full((W, k), np.inf)
    for w in range(W):
        a = int(starts[w])
        src_word = source[a : a + N][:, js]
        for r in range(k):
            c = sel[w, r]
            if c < 0:
                continue
            t0 = int(tst[c])
            block = distances[a - row_offset : a - row_offset + N, t0 : t0 + M]
            _, path = constrained_dtw(block, max_run)
            ww = warp_word(context.rotations[t0 : t0 + M][:, js], path, N)
            sign = np.where(np.sum(ww * src_word, axis=-1, keepdims=True) < 0, -1.0, 1.0)
            words[w, r] = ww * sign
            index[w, r] = t0
            dval[w, r] = dist[w, c]
    return GroupNeighbours(group, np.asarray(starts, dtype=np.int64), index, dval, words)
