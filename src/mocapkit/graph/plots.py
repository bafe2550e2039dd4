"""Figures for motion graphs (matplotlib, imported lazily): the normalised cost matrices of two
metrics and their difference with the chosen transitions marked (the paper's Figure 3), and the
rank-ordered cost curves with the chosen T (Figure 4)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from mocapkit.graph.distance import CostDatabase, cost_tile
from mocapkit.graph.graph import MotionGraph

__all__ = ["plot_cost_comparison", "sampled_cost_matrix"]


def sampled_cost_matrix(db: CostDatabase, max_size: int = 1200) -> tuple[np.ndarray, np.ndarray]:
    """The cost matrix on every k-th frame (k chosen so that it is at most ``max_size``
    square), divided by its 95th percentile and clipped to [0, 1]; and the sampled frames."""
    N = db.num_frames
    k = max(1, -(-N // max_size))
    frames = np.arange(0, N, k)
    m = np.full((len(frames), len(frames)), np.nan)
    ok = db.valid_centres()[frames]
    f = frames[ok]
    if len(f):
        t = cost_tile(db, f, f)
        m[np.ix_(ok, ok)] = t
    fin = np.isfinite(m)
    if fin.any():
        # robust normalisation: a few extreme frames (a T-pose, a fall) would darken the rest
        scale = max(float(np.percentile(m[fin], 95.0)), 1e-300)
        m[fin] = np.minimum(m[fin] / scale, 1.0)
    return m, frames


def plot_cost_comparison(
    path: str | Path,
    dbs: Mapping[str, CostDatabase],
    graphs: Mapping[str, MotionGraph],
    max_size: int = 1200,
) -> Path:
    """Write a figure: the normalised cost matrices of two metrics, their difference with each
    metric's transitions marked (green: first only, magenta: second only, white: both within a
    quarter second), and the rank-ordered cost curves with T."""
    from mocapkit._optional import pyplot

    plt = pyplot()

    names = list(dbs)[:2]
    mats = {}

    for n in names:
        mats[n], _ = sampled_cost_matrix(dbs[n], max_size)
    first = dbs[names[0]]
    extent = (0, first.num_frames, first.num_frames, 0)  # axes in frames of the whole library
    fig, axes = plt.subplots(
        1, 4 if len(names) == 2 else 2, figsize=(22 if len(names) == 2 else 11, 5.2)
    )
    for ax, n in zip(axes, names, strict=False):
        im = ax.imshow(mats[n], cmap="viridis", interpolation="nearest", extent=extent)
        ax.set_title(f"normalised cost: {n}")
        fig.colorbar(im, ax=ax, fraction=0.046)
    if len(names) == 2:
        ax = axes[2]
        diff = mats[names[0]] - mats[names[1]]
        lim = np.nanmax(np.abs(diff)) if np.isfinite(diff).any() else 1.0
        im = ax.imshow(
            diff, cmap="RdBu_r", vmin=-lim, vmax=lim, interpolation="nearest", extent=extent
        )
        ax.set_title(f"difference ({names[0]} - {names[1]})")
        fig.colorbar(im, ax=ax, fraction=0.046)
        pts = {}
        for n in names:
            g = graphs[n]
            pts[n] = np.stack(
                [first.starts[g.src_clip] + g.src_frame, first.starts[g.dst_clip] + g.dst_frame], 1
            )
        q = max(1, round(0.25 * first.fps))

        def near(p, others):
            if len(others) == 0:
                return np.zeros(len(p), dtype=bool)
            d = np.abs(p[:, None, :] - others[None, :, :]).max(-1)
            return (d <= q).any(1)

        a, b = pts[names[0]], pts[names[1]]
        both = near(a, b)
        for arr, mask, col, lab in (
            (a, ~both, "lime", f"{names[0]} only"),
            (b, ~near(b, a), "magenta", f"{names[1]} only"),
            (a, both, "white", "both"),
        ):
            sel = arr[mask]
            ax.scatter(
                sel[:, 1],
                sel[:, 0],
                s=14,
                c=col,
                edgecolors="k",
                linewidths=0.4,
                label=lab,
            )
        ax.legend(loc="lower left", fontsize=7, framealpha=0.6)
    ax = axes[-1]
    for n in graphs:
        g = graphs[n]
        c = g.ranked_costs
        if len(c):
            shown = c[: max(4 * max(g.T, 1), 50)]
            ax.plot(np.arange(1, len(shown) + 1), shown / max(shown.max(), 1e-300), label=n)
    Ts = {graphs[n].T for n in graphs}
    for T in Ts:
        ax.axvline(T, color="r", lw=1)
    ax.set_xlabel("rank")
    ax.set_ylabel("normalised cost")
    ax.set_title(f"rank-ordered costs, T = {', '.join(str(t) for t in sorted(Ts))}")
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
