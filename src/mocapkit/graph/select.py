"""Transition points: merging nearby candidates, the knee rule, selection and refinement."""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from mocapkit.graph.distance import CostDatabase, MinimaResult, pair_costs

__all__ = [
    "Candidates",
    "drop_trivial",
    "knee_rank",
    "merge_nearby",
    "refine",
    "select_transitions",
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
    if len(cand) == 0 or fraction <= 0:
        return cand
    y = db.coords[:, :, 1]
    height = float(np.median(y.max(axis=1) - y.min(axis=1)))
    same = db.clip_of(cand.src) == db.clip_of(cand.dst)
    keep = np.ones(len(cand), dtype=bool)
    idx = np.flatnonzero(same)
    lo = np.minimum(cand.src[idx], cand.dst[idx])
    hi = np.maximum(cand.src[idx], cand.dst[idx])
    keep[idx] = _moves(db.coords, lo, hi, fraction * height)
    return cand.take(np.flatnonzero(keep))


def merge_nearby(db: CostDatabase, cand: Candidates, radius: int) -> Candidates:
    """Keep the cheapest of candidates that connect the same pair of clips within ``radius``
    frames at both ends (greedy in cost order, as the paper does with a quarter second)."""
    order = np.argsort(cand.cost, kind="stable")
    src, dst = cand.src[order], cand.dst[order]
    cs, cd = db.clip_of(src), db.clip_of(dst)
    r = max(int(radius), 0)
    cell = r + 1
    buckets: dict[tuple[int, int, int, int], list[int]] = {}
    keep: list[int] = []
    for n in range(len(src)):
        a, b = int(src[n]), int(dst[n])
        key0 = (int(cs[n]), int(cd[n]))
        ba, bb = a // cell, b // cell
        clash = False
        for da in (-1, 0, 1):
            for dbk in (-1, 0, 1):
                for m in buckets.get((*key0, ba + da, bb + dbk), ()):
                    if abs(int(src[m]) - a) <= r and abs(int(dst[m]) - b) <= r:
                        clash = True
                        break
                if clash:
                    break
            if clash:
                break
        if not clash:
            keep.append(n)
            buckets.setdefault((*key0, ba, bb), []).append(n)
    k = order[np.array(keep, dtype=np.int64)]
    return cand.take(k)


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
    keeps all), ranked by cost, and cut at ``transitions`` (T), or at ``threshold`` (cost), or by
    :func:`knee_rank`. The chosen ones are refined to full-resolution float64 local minima
    (:func:`refine`; within the stride when the minima came from a stride grid) and merged
    again.

    Returns:
        (chosen transitions, all merged candidates (the rank-ordered curve), T).
    """
    if transitions is not None and threshold is not None:
        raise ValueError("give either transitions (T) or threshold, not both")
    if transitions is not None and transitions < 0:
        raise ValueError(f"transitions must be >= 0, got {transitions}")
    radius = max(1, round(merge_seconds * db.fps))
    if minima.dtype != "float64":
        # exact float64 costs (the cost is symmetric: one evaluation per unordered pair)
        exact = pair_costs(db, minima.i, minima.j)
        minima = MinimaResult(
            minima.i,
            minima.j,
            exact,
            minima.stride,
            minima.pairs,
            minima.flops,
            minima.seconds,
            "float64",
        )
    cand = drop_trivial(db, Candidates.from_minima(minima), trivial)
    merged = merge_nearby(db, cand, radius)
    if transitions is not None:
        T = min(int(transitions), len(merged))
    elif threshold is not None:
        T = int(np.searchsorted(merged.cost, float(threshold), side="right"))
    else:
        T = knee_rank(merged.cost, db.num_frames)
    chosen = merged.take(slice(0, T))
    if len(chosen):
        chosen = refine(db, chosen, minima.stride if minima.stride > 1 else 0)
        chosen = merge_nearby(db, drop_trivial(db, chosen, trivial), radius)
    return chosen, merged, T
