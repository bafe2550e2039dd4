"""Transition points: merging nearby candidates, the knee rule, selection and refinement."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numba
import numpy as np

from mocapkit.graph.distance import CostDatabase, MinimaResult, pair_costs

__all__ = [
    "DUPLICATE_TOLERANCE",
    "Candidates",
    "Overlap",
    "Selection",
    "blend_slide",
    "character_height",
    "drop_trivial",
    "end_masks",
    "find_overlaps",
    "fits_blend",
    "frame_components",
    "knee_rank",
    "merge_nearby",
    "on_overlaps",
    "refine",
    "select_connected",
    "select_transitions",
    "window_weight",
]


@dataclass(frozen=True, eq=False)
class Candidates:
    """Directed transition candidates ``src -> dst`` (global frames), sorted by cost."""

    src: np.ndarray
    dst: np.ndarray
    cost: np.ndarray

    def __len__(self) -> int:
        return len(self.cost)

    def take(self, idx: np.ndarray | slice) -> Candidates:
        return Candidates(self.src[idx], self.dst[idx], self.cost[idx])

    @classmethod
    def from_minima(cls, res: MinimaResult) -> Candidates:
        """Both directions of each (symmetric) minimum, sorted by cost (stable)."""
        src = np.concatenate([res.i, res.j])
        dst = np.concatenate([res.j, res.i])
        cost = np.concatenate([res.cost, res.cost])
        order = np.argsort(cost, kind="stable")
        return cls(src[order], dst[order], cost[order])


@numba.njit(cache=True, nogil=True)
def _moves(coords, lo, hi, thr):  # pragma: no cover - compiled
    """For each (lo, hi): does some frame in (lo, hi] differ from frame lo by a mean point
    distance above thr? (stops at the first such frame)"""
    P = coords.shape[1]
    out = np.zeros(lo.shape[0], dtype=np.bool_)
    for n in range(lo.shape[0]):
        a = lo[n]
        for f in range(a + 1, hi[n] + 1):
            d = 0.0
            for p in range(P):
                dx = coords[f, p, 0] - coords[a, p, 0]
                dy = coords[f, p, 1] - coords[a, p, 1]
                dz = coords[f, p, 2] - coords[a, p, 2]
                d += np.sqrt(dx * dx + dy * dy + dz * dz)
            if d / P > thr:
                out[n] = True
                break
    return out


def drop_trivial(db: CostDatabase, cand: Candidates, fraction: float = 0.05) -> Candidates:
    """Drop transitions within one clip that skip or repeat no motion: those where no frame
    between source and destination differs from the source by more than ``fraction`` of the
    character's height (mean displacement of the representative points, no alignment). They
    are the near-zero-cost loops inside a clip's still parts (standing before a kick), which
    would otherwise crowd the top of the ranking without adding anything to the graph."""
    return cand.take(_nontrivial(db, cand, fraction))


def _nontrivial(db: CostDatabase, cand: Candidates, fraction: float) -> np.ndarray:
    """Indices of the candidates :func:`drop_trivial` keeps (in order)."""
    if len(cand) == 0 or fraction <= 0:
        return np.arange(len(cand))
    height = character_height(db)
    same = db.clip_of(cand.src) == db.clip_of(cand.dst)
    keep = np.ones(len(cand), dtype=bool)
    idx = np.flatnonzero(same)
    lo = np.minimum(cand.src[idx], cand.dst[idx])
    hi = np.maximum(cand.src[idx], cand.dst[idx])
    keep[idx] = _moves(db.coords, lo, hi, fraction * height)
    return np.flatnonzero(keep)


def character_height(db: CostDatabase) -> float:
    """The character's height (file units): median over frames of the vertical extent of the
    representative points."""
    y = db.coords[:, :, 1]
    return float(np.median(y.max(axis=1) - y.min(axis=1))) if len(y) else 0.0


def merge_nearby(db: CostDatabase, cand: Candidates, radius: int) -> Candidates:
    """Keep the cheapest of candidates that connect the same pair of clips within ``radius``
    frames at both ends (greedy in cost order, as the paper does with a quarter second)."""
    return cand.take(_merge_index(db, cand, radius))


def _merge_index(db: CostDatabase, cand: Candidates, radius: int) -> np.ndarray:
    """Indices of the candidates :func:`merge_nearby` keeps, in cost order."""
    order = np.argsort(cand.cost, kind="stable")
    src, dst = cand.src[order], cand.dst[order]
    key = db.clip_of(src).astype(np.int64) * db.num_clips + db.clip_of(dst)
    # each clip pair on its own, in cost order (a stable sort keeps the cost order inside)
    by = np.argsort(key, kind="stable")
    k = key[by]
    bounds = np.flatnonzero(np.r_[True, k[1:] != k[:-1], True])
    keep = np.zeros(len(src), dtype=np.bool_)
    _merge_kernel(src[by], dst[by], bounds, max(int(radius), 0), keep)
    kept = np.sort(by[keep])  # positions in cost order
    return order[kept]


@numba.njit(cache=True, nogil=True)
def _merge_kernel(src, dst, bounds, r, keep):  # pragma: no cover - compiled
    """Greedy suppression inside each group [bounds[g], bounds[g + 1]) (in cost order): keep a
    candidate unless a kept one lies within r frames at both ends. Kept ones are bucketed on
    a grid of cell r + 1 (a hash of the cell), so each check looks at nine cells."""
    cell = r + 1
    for g in range(bounds.shape[0] - 1):
        lo, hi = bounds[g], bounds[g + 1]
        n = hi - lo
        if n == 1:
            keep[lo] = True
            continue
        size = 1
        while size < 4 * n:
            size *= 2
        head = np.full(size, -1, dtype=np.int64)
        nxt = np.full(n, -1, dtype=np.int64)
        for q in range(lo, hi):
            a, b = src[q], dst[q]
            ca, cb = a // cell, b // cell
            clash = False
            for da in range(-1, 2):
                for dbb in range(-1, 2):
                    h = ((ca + da) * 1000003 + (cb + dbb)) & (size - 1)
                    m = head[h]
                    while m >= 0:
                        if abs(src[lo + m] - a) <= r and abs(dst[lo + m] - b) <= r:
                            clash = True
                            break
                        m = nxt[m]
                    if clash:
                        break
                if clash:
                    break
            if not clash:
                keep[q] = True
                h = (ca * 1000003 + cb) & (size - 1)
                nxt[q - lo] = head[h]
                head[h] = q - lo


def knee_rank(
    costs: np.ndarray,
    frames: int | None = None,
    ramp: float = 0.05,
    fraction: float = 0.1,
    max_points: int = 20000,
) -> int:
    """The paper's rule for T: the rank where the slope of the rank-ordered cost curve changes
    after the initial ramp.

    The sorted costs (normalised to [0, 1] on both axes) are fitted by two straight segments
    joined at a break; the best break (least squares) after the first ``ramp`` fraction of ranks
    is T. The curve is examined on its first ``fraction`` x ``frames`` ranks (``frames``: the
    database's size; default: the number of candidates), at most ``max_points``: the tail of a
    rank-ordered cost curve always steepens (the worst candidates), and the knee sought lies
    among the best transitions (the paper's: rank 67 for ~4,100 frames). Returns at least 1
    when there is a candidate.
    """
    c = np.sort(np.asarray(costs, dtype=np.float64))
    c = c[np.isfinite(c)]
    base = len(c) if frames is None else int(frames)
    c = c[: min(max_points, max(20, round(fraction * base)))]
    n = len(c)
    if n <= 3:
        return max(n, 1) if n else 0
    y = (c - c[0]) / max(c[-1] - c[0], 1e-300)
    x = np.arange(n) / (n - 1)
    lo = max(2, int(ramp * n))
    best, best_k = np.inf, n
    # prefix sums for O(1) line fits of both segments
    S = {
        k: np.concatenate([[0.0], np.cumsum(v)])
        for k, v in {"x": x, "y": y, "xx": x * x, "xy": x * y, "yy": y * y}.items()
    }

    def sse(a: int, b: int) -> float:
        m = b - a
        sx, sy = S["x"][b] - S["x"][a], S["y"][b] - S["y"][a]
        sxx, sxy, syy = S["xx"][b] - S["xx"][a], S["xy"][b] - S["xy"][a], S["yy"][b] - S["yy"][a]
        vx = sxx - sx * sx / m
        vy = syy - sy * sy / m
        cxy = sxy - sx * sy / m
        return vy - (cxy * cxy / vx if vx > 1e-300 else 0.0)

    for k in range(lo, n - 2):
        e = sse(0, k) + sse(k, n)
        if e < best:
            best, best_k = e, k
    return int(best_k)


def refine(db: CostDatabase, cand: Candidates, radius: int, max_steps: int = 50) -> Candidates:
    """Move each candidate to the full-resolution local minimum: first the best cell within
    ``radius`` frames at both ends, then steepest descent over the 8 neighbours. Exact float64
    costs (:func:`mocapkit.graph.distance.pair_costs`); pairs stay inside their clips."""
    if len(cand) == 0:
        return cand
    ok = db.valid_centres()
    clip = db.clip_of
    src, dst = cand.src.copy(), cand.dst.copy()
    cs, cd = clip(src), clip(dst)
    gap = 2 * db.half + 1

    def best_in(offsets: np.ndarray, sel: np.ndarray):
        """Best cell of ``(src, dst)[sel] + offsets`` (same clips, valid, off the diagonal)."""
        cs_, cd_ = cs[sel], cd[sel]
        a = src[sel, None] + offsets[None, :, 0]
        b = dst[sel, None] + offsets[None, :, 1]
        ac = np.clip(a, 0, db.num_frames - 1)
        bc = np.clip(b, 0, db.num_frames - 1)
        valid = (a == ac) & (b == bc) & ok[ac] & ok[bc]
        valid &= (clip(ac) == cs_[:, None]) & (clip(bc) == cd_[:, None])
        valid &= ~((cs_ == cd_)[:, None] & (np.abs(ac - bc) < gap))
        cost = np.full(a.shape, np.inf)
        cost[valid] = pair_costs(db, ac[valid], bc[valid])
        k = np.argmin(cost, axis=1)
        rows = np.arange(len(sel))
        return ac[rows, k], bc[rows, k], cost[rows, k]

    r = np.arange(-radius, radius + 1)
    offs = np.stack(np.meshgrid(r, r, indexing="ij"), -1).reshape(-1, 2)
    src, dst, cost = best_in(offs, np.arange(len(src)))
    nb = np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1], indexing="ij"), -1).reshape(-1, 2)
    active = np.isfinite(cost)
    for _ in range(max_steps):
        if not active.any():
            break
        idx = np.flatnonzero(active)
        s2, d2, c2 = best_in(nb, idx)
        moved = c2 < cost[idx]
        src[idx[moved]], dst[idx[moved]], cost[idx[moved]] = s2[moved], d2[moved], c2[moved]
        active[:] = False
        active[idx[moved]] = True
    order = np.argsort(cost, kind="stable")
    fin = np.isfinite(cost[order])
    order = order[fin]
    return Candidates(src[order], dst[order], cost[order])


def select_transitions(
    db: CostDatabase,
    minima: MinimaResult,
    transitions: int | None = None,
    threshold: float | None = None,
    merge_seconds: float = 0.25,
    trivial: float = 0.05,
) -> tuple[Candidates, Candidates, int]:
    """Choose the transitions from the tiled local minima.

    Directed candidates (both directions of each symmetric minimum) are merged within
    ``merge_seconds`` (:func:`merge_nearby`) after their costs are recomputed exactly in float64
    and trivial ones dropped (:func:`drop_trivial`, ``trivial`` = fraction of the height; 0
    keeps all) and the zero-cost matches of duplicate or overlapping takes left out
    (:func:`find_overlaps`), ranked by cost, and cut at ``transitions`` (T), or at
    ``threshold`` (cost), or by :func:`knee_rank` alone (the default build also connects every
    clip: :func:`select_connected`). The chosen ones are refined to full-resolution float64
    local minima (:func:`refine`; within the stride when the minima came from a stride grid)
    and merged again.

    Returns:
        (chosen transitions, all merged candidates (the rank-ordered curve), T).
    """
    if transitions is not None and threshold is not None:
        raise ValueError("give either transitions (T) or threshold, not both")
    if transitions is not None and transitions < 0:
        raise ValueError(f"transitions must be >= 0, got {transitions}")
    merged, overlaps, radius = _prepare(db, minima, merge_seconds, trivial)
    if transitions is not None:
        T = min(int(transitions), len(merged))
    elif threshold is not None:
        T = int(np.searchsorted(merged.cost, float(threshold), side="right"))
    else:
        T = knee_rank(merged.cost, db.num_frames)
    chosen = merged.take(slice(0, T))
    if len(chosen):
        chosen = refine(db, chosen, minima.stride if minima.stride > 1 else 0)
        chosen = drop_trivial(db, chosen, trivial)
        chosen = chosen.take(np.flatnonzero(~on_overlaps(db, chosen.src, chosen.dst, overlaps)))
        chosen = merge_nearby(db, chosen, radius)
    return chosen, merged, T


# ============================================================================================
# duplicate and overlapping takes


#: Matches closer than this fraction of the character's height (root mean square over the
#: window, after alignment) are the same recording, not two performances: real takes never
#: come closer than ~3e-4 (a person standing still; capture noise), copies match to ~0.
DUPLICATE_TOLERANCE = 1e-4


@dataclass(frozen=True)
class Overlap:
    """Two takes that hold the same frames: ``clip_a`` frames ``[a_start, a_stop)`` equal
    ``clip_b`` frames ``[b_start, b_stop)`` (0-based, clip frames) up to ``rms`` (file units,
    the largest root-mean-square point distance of the matched windows after alignment);
    ``offset`` = b frame - a frame."""

    clip_a: int
    clip_b: int
    a_start: int
    a_stop: int
    b_start: int
    b_stop: int
    offset: int
    rms: float

    @property
    def frames(self) -> int:
        return self.a_stop - self.a_start

    def to_json(self, paths: Sequence[str] | None = None) -> dict:
        out: dict = {
            "clip_a": self.clip_a,
            "clip_b": self.clip_b,
            "a_frames": [self.a_start, self.a_stop],
            "b_frames": [self.b_start, self.b_stop],
            "frames": self.frames,
            "offset": self.offset,
            "rms": self.rms,
        }
        if paths is not None:
            out["path_a"], out["path_b"] = str(paths[self.clip_a]), str(paths[self.clip_b])
        return out


def window_weight(db: CostDatabase, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """The total weight ``W = sum_k sum_p w_kp(i, j)`` of the window pairs (so that
    ``sqrt(cost / W)`` is the root-mean-square point distance after alignment)."""
    per = db.point_frame.sum(axis=1)
    k = np.arange(-db.half, db.half + 1)
    i = np.asarray(i, dtype=np.int64)
    j = np.asarray(j, dtype=np.int64)
    S = float(db.point_static.sum())
    fi = (per[i[:, None] + k] * db.window).sum(axis=1)
    fj = (per[j[:, None] + k] * db.window).sum(axis=1)
    return S + fi + fj


def find_overlaps(
    db: CostDatabase,
    i: np.ndarray,
    j: np.ndarray,
    cost: np.ndarray,
    stride: int = 1,
    tolerance: float = DUPLICATE_TOLERANCE,
) -> tuple[list[Overlap], np.ndarray]:
    """Duplicate or overlapping takes among the minima ``(i, j, cost)`` (exact costs).

    A minimum whose window matches to within ``tolerance`` x the character's height (RMS after
    alignment) is the same recording; on a stride grid a copy at an odd offset falls between
    grid cells, so the cheap minima are re-checked at the offsets the grid skipped. The matches
    are grouped by clip pair and frame offset into :class:`Overlap` ranges.

    Returns:
        (overlaps, mask): the overlaps (longest first) and, per minimum, whether it lies on one
        (those are no transitions: they jump between two copies of one motion at zero cost, and
        must not set the threshold).
    """
    i = np.asarray(i, dtype=np.int64)
    j = np.asarray(j, dtype=np.int64)
    cost = np.asarray(cost, dtype=np.float64)
    mask = np.zeros(len(cost), dtype=bool)
    if len(cost) == 0:
        return [], mask
    tol = tolerance * character_height(db)
    W = window_weight(db, i, j)
    # candidates within 5 % of the height: a grid neighbour of a copy (up to stride - 1 frames
    # off) is that close even in a run
    near = np.flatnonzero(cost <= (5e-2 * character_height(db)) ** 2 * W)
    best_c = pair_costs(db, i[near], j[near])  # exact (the tiles may be float32)
    best_j = j[near].copy()
    ok = db.valid_centres()
    ci = db.clip_of(i[near])
    for d in range(-(stride - 1), stride):
        if d == 0 or len(near) == 0:
            continue
        jj = j[near] + d
        v = (jj >= 0) & (jj < db.num_frames)
        v[v] &= ok[jj[v]] & (db.clip_of(jj[v]) == db.clip_of(j[near][v]))
        v[v] &= ~((ci[v] == db.clip_of(jj[v])) & (np.abs(jj[v] - i[near][v]) <= 2 * db.half))
        c = np.full(len(near), np.inf)
        c[v] = pair_costs(db, i[near][v], jj[v])
        better = c < best_c
        best_c[better], best_j[better] = c[better], jj[better]
    rms = np.sqrt(np.maximum(best_c, 0.0) / window_weight(db, i[near], best_j))
    hit = rms <= tol
    if not hit.any():
        return [], mask
    a, b = i[near][hit], best_j[hit]
    ca, cb = db.clip_of(a), db.clip_of(b)
    fa, fb = a - db.starts[ca], b - db.starts[cb]
    off = fb - fa
    groups: dict[tuple[int, int, int], list[int]] = {}
    for n in range(len(a)):
        groups.setdefault((int(ca[n]), int(cb[n]), int(off[n])), []).append(n)
    overlaps = []
    h = db.half
    for (x, y, o), members in groups.items():
        m = np.array(members)
        lo, hi, worst = _extend_overlap(db, x, y, o, int(fa[m].min()), int(fa[m].max()), tol)
        worst = max(worst, float(rms[hit][m].max()))
        overlaps.append(Overlap(x, y, lo - h, hi + h + 1, lo - h + o, hi + h + 1 + o, o, worst))
    overlaps.sort(key=lambda v: (-v.frames, v.clip_a, v.clip_b))
    mask = on_overlaps(db, i, j, overlaps, stride)
    return overlaps, mask


def _extend_overlap(
    db: CostDatabase, a: int, b: int, offset: int, lo: int, hi: int, tol: float
) -> tuple[int, int, float]:
    """Grow the matched centre frames [lo, hi] of clip a (b = a + offset) along the diagonal
    while the windows still match within ``tol`` (the grid may have caught only a few)."""
    ok = db.valid_centres()
    sa, sb = int(db.starts[a]), int(db.starts[b])
    Fa, Fb = int(db.starts[a + 1] - sa), int(db.starts[b + 1] - sb)
    f = np.arange(Fa)
    valid = (f + offset >= 0) & (f + offset < Fb)
    f = f[valid]
    f = f[ok[sa + f] & ok[sb + f + offset]]
    if len(f) == 0 or (a == b and abs(offset) <= 2 * db.half):
        return lo, hi, 0.0
    i, j = sa + f, sb + f + offset
    c = pair_costs(db, i, j)
    rms = np.sqrt(np.maximum(c, 0.0) / window_weight(db, i, j))
    good = rms <= tol
    # the run of good frames around [lo, hi]
    pos = np.searchsorted(f, [lo, hi])
    start, stop = int(pos[0]), int(min(pos[1], len(f) - 1))
    while start > 0 and good[start - 1] and f[start - 1] == f[start] - 1:
        start -= 1
    while stop + 1 < len(f) and good[stop + 1] and f[stop + 1] == f[stop] + 1:
        stop += 1
    worst = float(rms[start : stop + 1][good[start : stop + 1]].max(initial=0.0))
    return int(f[start]), int(f[stop]), worst


def on_overlaps(
    db: CostDatabase, src: np.ndarray, dst: np.ndarray, overlaps: Sequence[Overlap], slack: int = 1
) -> np.ndarray:
    """(n,) bool: the pair (src, dst) (either order) joins two copies of the same frames of an
    overlap (within ``slack`` frames of its offset)."""
    src = np.asarray(src, dtype=np.int64)
    dst = np.asarray(dst, dtype=np.int64)
    out = np.zeros(len(src), dtype=bool)
    if not overlaps or len(src) == 0:
        return out
    cs, cd = db.clip_of(src), db.clip_of(dst)
    fs, fd = src - db.starts[cs], dst - db.starts[cd]
    for ov in overlaps:
        for x, y, a, b in ((cs, cd, fs, fd), (cd, cs, fd, fs)):
            m = (x == ov.clip_a) & (y == ov.clip_b)
            m &= (a >= ov.a_start - slack) & (a < ov.a_stop + slack)
            m &= np.abs(b - a - ov.offset) <= slack
            out |= m
    return out


# ============================================================================================
# foot slide of a blend (the quantity mocapkit.graph.skate measures, from the point clouds)


@numba.njit(cache=True, nogil=True)
def _slide_kernel(coords, joints, feet, contacts, src, dst, w, out):  # pragma: no cover
    n_j = joints.shape[0]
    K = w.shape[0]
    last = coords.shape[0] - 1
    for n in range(src.shape[0]):
        s0 = src[n]
        d0 = dst[n]
        # centroids of the joints over the blend (ground plane: x, z)
        ax = az = bx = bz = 0.0
        for k in range(K):
            fa = min(s0 + k, last)
            fb = min(d0 + k, last)
            for q in range(n_j):
                p = joints[q]
                ax += coords[fa, p, 0]
                az += coords[fa, p, 2]
                bx += coords[fb, p, 0]
                bz += coords[fb, p, 2]
        m = K * n_j
        ax /= m
        az /= m
        bx /= m
        bz /= m
        num = den = 0.0
        for k in range(K):
            fa = min(s0 + k, last)
            fb = min(d0 + k, last)
            for q in range(n_j):
                p = joints[q]
                xa = coords[fa, p, 0] - ax
                za = coords[fa, p, 2] - az
                xb = coords[fb, p, 0] - bx
                zb = coords[fb, p, 2] - bz
                num += xa * zb - za * xb
                den += xa * xb + za * zb
        th = np.arctan2(num, den)
        c = np.cos(th)
        sn = np.sin(th)
        any_both = False
        for f in range(feet.shape[0]):
            if contacts[s0, f] and contacts[d0, f]:
                any_both = True
        # feet planted at both ends anchor the translation (as synthesis does): B's planted
        # feet are moved onto A's, on average over the blend
        ox = oz = 0.0
        if any_both:
            cnt = 0
            for f in range(feet.shape[0]):
                if not (contacts[s0, f] and contacts[d0, f]):
                    continue
                p = feet[f]
                for k in range(K):
                    fa = min(s0 + k, last)
                    fb = min(d0 + k, last)
                    x = coords[fb, p, 0] - bx
                    z = coords[fb, p, 2] - bz
                    ox += coords[fa, p, 0] - (x * c + z * sn + ax)
                    oz += coords[fa, p, 2] - (-x * sn + z * c + az)
                    cnt += 1
            ox /= cnt
            oz /= cnt
        best = -1.0
        for f in range(feet.shape[0]):
            ka = contacts[s0, f]
            kb = contacts[d0, f]
            if not ((ka and kb) or (not any_both and (ka or kb))):
                continue
            p = feet[f]
            px = pz = qx = qz = 0.0
            for e in range(2):
                k = 0 if e == 0 else K - 1
                fa = min(s0 + k, last)
                fb = min(d0 + k, last)
                x = coords[fb, p, 0] - bx
                z = coords[fb, p, 2] - bz
                ux = x * c + z * sn + ax + ox
                uz = -x * sn + z * c + az + oz
                vx = (1.0 - w[k]) * coords[fa, p, 0] + w[k] * ux
                vz = (1.0 - w[k]) * coords[fa, p, 2] + w[k] * uz
                if e == 0:
                    px = vx
                    pz = vz
                else:
                    qx = vx
                    qz = vz
            d = np.sqrt((qx - px) ** 2 + (qz - pz) ** 2)
            if d > best:
                best = d
        out[n] = best if best >= 0.0 else np.nan


def blend_slide(db: CostDatabase, src: np.ndarray, dst: np.ndarray, blend: int) -> np.ndarray:
    """How far the supporting ankle travels on the ground over each transition's blend (file
    units; NaN where no foot is planted at either end).

    The same quantity as :func:`mocapkit.graph.skate.transition_skate` measures by rendering
    (start-to-end, the larger over the feet planted at both ``src`` and ``dst``, else at
    either), predicted from the point clouds: window B is aligned onto window A by the
    unweighted ground-plane fit of the body's joints over the blend, its translation moved so
    that the feet planted at both ends coincide on average (as synthesis does), and the
    ankles are blended linearly with synthesis' ease-in/ease-out weights. It agrees with the
    rendered measure to a few per cent and costs about a microsecond per transition.
    """
    src = np.ascontiguousarray(src, dtype=np.int64)
    dst = np.ascontiguousarray(dst, dtype=np.int64)
    out = np.full(len(src), np.nan)
    if len(db.foot_points) == 0 or len(src) == 0:
        return out
    joints = np.flatnonzero(db.parts.point_source >= 0).astype(np.int64)
    a = (np.arange(blend) + 1) / (blend + 1)
    w = 3 * a * a - 2 * a * a * a
    _slide_kernel(
        db.coords, joints, np.asarray(db.foot_points, dtype=np.int64),
        np.ascontiguousarray(db.foot_contacts), src, dst, w, out,
    )  # fmt: skip
    return out


# ============================================================================================
# strongly connected components on the frames


def frame_components(db: CostDatabase, src: np.ndarray, dst: np.ndarray, blend: int) -> np.ndarray:
    """(N,) the strongly connected component of each library frame in the graph of the
    transitions ``src -> dst`` (global frames; a transition lands at ``dst + blend``), -1 for a
    frame no component's continuation passes (before a clip's first way in, after its last
    way out). Nodes and edges as :class:`mocapkit.graph.graph.MotionGraph` makes them."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    src = np.asarray(src, dtype=np.int64)
    land = np.asarray(dst, dtype=np.int64) + blend
    ends = np.concatenate([db.starts[:-1], db.starts[1:] - 1])
    nodes = np.unique(np.concatenate([ends, src, land]))
    n = len(nodes)
    clip = db.clip_of(nodes)
    cont = np.flatnonzero(clip[1:] == clip[:-1])
    u = np.concatenate([cont, np.searchsorted(nodes, src)])
    v = np.concatenate([cont + 1, np.searchsorted(nodes, land)])
    adj = coo_matrix((np.ones(len(u)), (u, v)), shape=(n, n)).tocsr()
    _, lab = connected_components(adj, directed=True, connection="strong")
    sizes = np.bincount(lab)
    out = np.full(db.num_frames, -1, dtype=np.int64)
    same = lab[cont] == lab[cont + 1]
    same &= sizes[lab[cont]] > 1
    for e in cont[same]:
        out[nodes[e] : nodes[e + 1] + 1] = lab[e]
    return out


# ============================================================================================
# the default rule: the knee, then every clip's ends, then bridges between components


#: Fraction of a clip (at least :data:`END_MIN_FRAMES`) that counts as its start or its end.
END_FRACTION = 0.1
END_MIN_FRAMES = 3
#: Components at least this long (seconds) are always bridged into the largest one; smaller
#: ones only when their bridges slide the foot at most BRIDGE_RATIO x their own transitions.
BRIDGE_SECONDS = 5.0
BRIDGE_RATIO = 3.0
#: Components shorter than this (seconds) are left out.
MIN_COMPONENT_SECONDS = 1.0
#: A slide below this fraction of the character's height (about 1 cm on a 1.7 m person) is
#: within marker noise and shoe compression: a bridge that slides no more is always
#: acceptable, even into a component whose own transitions do not slide at all.
UNSEEN_SLIDE = 0.006


@dataclass(frozen=True, eq=False)
class Selection:
    """What :func:`select_connected` chose and why.

    Attributes:
        chosen: the transitions, sorted by cost.
        kind: (len(chosen),) per transition "knee" (among the T cheapest of the library),
            "end" (a clip's way out of its end or into its start) or "bridge" (joins a
            component to the largest one).
        merged: all merged candidates, rank-ordered (the knee's curve; overlaps left out).
        T: the knee's rank.
        overlaps: duplicate or overlapping takes found (:func:`find_overlaps`).
        bridged: components joined to the largest; skipped: components left out (too short,
            or their bridges would slide the feet too far).
    """

    chosen: Candidates
    kind: np.ndarray
    merged: Candidates
    T: int
    overlaps: list[Overlap] = field(default_factory=list)
    bridged: int = 0
    skipped: int = 0

    def counts(self) -> dict[str, int]:
        return {k: int((self.kind == k).sum()) for k in ("knee", "end", "bridge")}


def _prepare(
    db: CostDatabase, minima: MinimaResult, merge_seconds: float, trivial: float
) -> tuple[Candidates, list[Overlap], int]:
    """Exact float64 costs, overlaps out, trivial loops out, merged: the ranked candidates."""
    radius = max(1, round(merge_seconds * db.fps))
    if minima.dtype != "float64":
        # exact float64 costs (the cost is symmetric: one evaluation per unordered pair)
        exact = pair_costs(db, minima.i, minima.j)
        minima = MinimaResult(
            minima.i, minima.j, exact, minima.stride, minima.pairs, minima.flops,
            minima.seconds, "float64",
        )  # fmt: skip
    overlaps, dup = find_overlaps(db, minima.i, minima.j, minima.cost, minima.stride)
    if dup.any():
        keep = ~dup
        minima = MinimaResult(
            minima.i[keep], minima.j[keep], minima.cost[keep], minima.stride, minima.pairs,
            minima.flops, minima.seconds, "float64",
        )  # fmt: skip
    cand = drop_trivial(db, Candidates.from_minima(minima), trivial)
    return merge_nearby(db, cand, radius), overlaps, radius


def _refined(
    db: CostDatabase,
    cand: Candidates,
    stride: int,
    trivial: float,
    overlaps: Sequence[Overlap],
    blend: int,
    by_cost: bool = True,
) -> Candidates:
    """Refined to full resolution (``by_cost``: moved to the nearest local minimum of the cost;
    else kept where they are: exact frames chosen for another reason), without trivial loops,
    overlaps, or blends off the clip."""
    if len(cand) == 0:
        return cand
    out = refine(db, cand, stride if stride > 1 else 0) if by_cost else cand
    out = out.take(_nontrivial(db, out, trivial))
    keep = ~on_overlaps(db, out.src, out.dst, overlaps) & fits_blend(db, out, blend)
    return out.take(np.flatnonzero(keep))


def fits_blend(db: CostDatabase, cand: Candidates, blend: int) -> np.ndarray:
    """(n,) bool: the transition's blend and landing frame stay inside their clips."""
    cs, cd = db.clip_of(cand.src), db.clip_of(cand.dst)
    return (cand.dst + blend <= db.starts[cd + 1] - 1) & (cand.src + blend <= db.starts[cs + 1])


def _best_per_group(idx: np.ndarray, group: np.ndarray, score: np.ndarray, tie: np.ndarray):
    """The index of ``idx`` with the lowest ``score`` (then ``tie``) per value of ``group``."""
    if len(idx) == 0:
        return idx
    o = idx[np.lexsort((tie[idx], score[idx], group[idx]))]
    g = group[o]
    first = np.ones(len(o), dtype=bool)
    first[1:] = g[1:] != g[:-1]
    return o[first]


def end_masks(
    db: CostDatabase, cand: Candidates, blend: int, fraction: float = END_FRACTION
) -> tuple[np.ndarray, np.ndarray]:
    """Per candidate: (leaves a clip's end for a frame that is not another end, arrives at a
    clip's start from a frame that is not another start). A clip's end is its last
    ``fraction`` of valid source frames (at least :data:`END_MIN_FRAMES`), its start the
    first ``fraction`` of landing frames."""
    F = np.diff(db.starts)
    L = np.maximum(END_MIN_FRAMES, np.round(fraction * F)).astype(np.int64)
    cs, cd = db.clip_of(cand.src), db.clip_of(cand.dst)
    fs, fd = cand.src - db.starts[cs], cand.dst - db.starts[cd]
    h = db.half
    s_end = fs >= F[cs] - 1 - h - L[cs]
    d_end = fd >= F[cd] - 1 - h - L[cd]
    s_start = fs <= h + L[cs]
    d_start = fd <= h + L[cd]
    return s_end & ~d_end, d_start & ~s_start


def select_connected(
    db: CostDatabase,
    minima: MinimaResult,
    blend: int,
    *,
    merge_seconds: float = 0.25,
    trivial: float = 0.05,
    end_fraction: float = END_FRACTION,
    bridge_seconds: float = BRIDGE_SECONDS,
    bridge_ratio: float = BRIDGE_RATIO,
    min_component_seconds: float = MIN_COMPONENT_SECONDS,
    max_rounds: int = 20,
) -> Selection:
    """The default transition rule: a graph a user can walk, with the knee's quality.

    1. **Overlaps out.** Duplicate or overlapping takes (:func:`find_overlaps`) are reported
       and their zero-cost matches dropped, so that they neither set the threshold nor become
       transitions.
    2. **The knee** (Kovar et al.): the T cheapest merged candidates (:func:`knee_rank`).
    3. **Every clip's ends** (per-clip thresholds): a take starts and ends where its
       performer was told to, so its last frames lead nowhere and its first are reached from
       nowhere; the library's cost scale (a standing pose is cheap, a run dear) leaves most
       ends without a knee transition to another clip. Each clip end without one gets its own:
       among the candidates leaving that end for another clip (anywhere but that clip's end),
       those the tiles kept for it (its cheapest partner clips,
       :class:`~mocapkit.graph.distance.MinimaReducer`), the one whose blend slides the
       planted foot least (:func:`blend_slide`; cost breaks ties). Likewise each clip start
       without one gets the best way in.
    4. **Bridges.** The rest may still fall into several strongly connected components (one
       per style or performer, walks apart from gestures). Each component of at least
       ``min_component_seconds`` gets the least-sliding candidate from the largest component
       into it and back; the pair is added when the component lasts ``bridge_seconds`` or its
       bridges slide at most ``bridge_ratio`` x the median slide of its own transitions, or
       no more than :data:`UNSEEN_SLIDE` of the character's height (a short piece is not
       worth a bad transition). Repeated until nothing joins.

    All chosen transitions are refined to full-resolution local minima (as
    :func:`select_transitions`) and merged.
    """
    stride = minima.stride
    merged, overlaps, radius = _prepare(db, minima, merge_seconds, trivial)
    T = knee_rank(merged.cost, db.num_frames)
    pool = merged.take(np.flatnonzero(fits_blend(db, merged, blend)))
    slide = blend_slide(db, pool.src, pool.dst, blend)
    slide0 = np.where(np.isfinite(slide), slide, 0.0)  # no planted foot: nothing can slide
    rank = np.arange(len(pool))
    knee_cut = merged.cost[T - 1] if T else -np.inf
    is_knee = pool.cost <= knee_cut
    out_end, in_start = end_masks(db, pool, blend, end_fraction)
    cs, cd = db.clip_of(pool.src), db.clip_of(pool.dst)
    chosen_idx = [np.flatnonzero(is_knee)]
    other = cs != cd  # a loop inside the clip does not connect it to the library
    for mask, group in ((out_end & other, cs), (in_start & other, cd)):
        # a clip end the knee already connects to another clip keeps what it has
        served = np.zeros(db.num_clips, dtype=bool)
        served[group[mask & is_knee]] = True
        idx = np.flatnonzero(mask & ~is_knee & ~served[group])
        chosen_idx.append(_best_per_group(idx, group, slide0, rank))
    knee = pool.take(chosen_idx[0])
    ends = pool.take(np.unique(np.concatenate(chosen_idx[1:])))
    parts = [(_refined(db, knee, stride, trivial, overlaps, blend), "knee")]
    # ends are chosen for their slide: moving them to a cheaper frame nearby could land a foot
    # in toe-off (a 30 cm swing read as skate), so they stay on the frames that were chosen
    parts.append((_refined(db, ends, stride, trivial, overlaps, blend, by_cost=False), "end"))

    def combine(parts):
        src = np.concatenate([p.src for p, _ in parts])
        dst = np.concatenate([p.dst for p, _ in parts])
        cost = np.concatenate([p.cost for p, _ in parts])
        kind = np.concatenate([np.full(len(p), k, dtype=object) for p, k in parts])
        c = Candidates(src, dst, cost)
        keep = _merge_index(db, c, radius)
        return c.take(keep), kind[keep]

    chosen, kind = combine(parts)
    bridged = skipped = 0
    unseen = UNSEEN_SLIDE * character_height(db)
    min_frames = min_component_seconds * db.fps
    for _ in range(max_rounds):
        lab = frame_components(db, chosen.src, chosen.dst, blend)
        labs, size = np.unique(lab[lab >= 0], return_counts=True)
        if len(labs) < 2:
            break
        big = labs[np.argmax(size)]
        ls = lab[pool.src]
        ld = lab[np.minimum(pool.dst + blend, db.num_frames - 1)]
        own = blend_slide(db, chosen.src, chosen.dst, blend)
        own = np.where(np.isfinite(own), own, 0.0)
        own_lab = lab[chosen.src]
        add: list[int] = []
        skipped = 0
        for comp, n in zip(labs, size, strict=True):
            if comp == big or n < min_frames:
                skipped += int(comp != big)
                continue
            pair = []
            for m in ((ls == big) & (ld == comp), (ls == comp) & (ld == big)):
                idx = np.flatnonzero(m)
                if len(idx):
                    pair.append(int(idx[np.lexsort((rank[idx], slide0[idx]))[0]]))
            if len(pair) < 2:
                skipped += 1
                continue
            typ = own[own_lab == comp]
            typical = float(np.median(typ)) if len(typ) else float(np.median(own))
            typical = max(typical, unseen)
            if n >= bridge_seconds * db.fps or max(slide0[pair]) <= bridge_ratio * typical:
                add += pair
                bridged += 1
            else:
                skipped += 1
        if not add:
            break
        parts.append((_refined(db, pool.take(np.array(add)), stride, trivial, overlaps, blend,
                               by_cost=False), "bridge"))  # fmt: skip
        chosen, kind = combine(parts)
    return Selection(chosen, kind.astype(str), merged, T, overlaps, int(bridged), int(skipped))
