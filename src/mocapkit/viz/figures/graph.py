"""Figures for motion graphs: the normalised cost matrices of two metrics and their difference
with the chosen transitions marked (the paper's Figure 3), and the rank-ordered cost curves with
the chosen T (Figure 4). The data is a :class:`~mocapkit.graph.graph.CostComparison`
(:func:`mocapkit.graph.graph.compare_metrics` or :func:`~mocapkit.graph.graph.cost_comparison`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mocapkit.viz.figures import figsize, pyplot, save, short_labels, thin_ticks, wrap

__all__ = ["clip_labels", "plot_cost_comparison"]

_MAX_CLIP_LABELS = 24  # per axis; more would overlap at 6 pt on a 5-inch axis


def clip_labels(names: Sequence[str], width: int = 22) -> list[str]:
    """Short labels for clips: their file stems without the prefix and suffix they all share
    (e.g. Bandai's ``dataset-1_`` and ``_001``), shortened to ``width`` characters."""
    return short_labels([Path(n).stem for n in names], width)


def _clip_axes(ax: Any, cmp: Any) -> None:
    """Clip boundaries as faint lines, clip names at their middles (thinned so that they do
    not overlap)."""
    starts = np.asarray(cmp.clip_starts)
    C = len(starts) - 1
    for b in starts[1:-1]:
        ax.axhline(b, color="w", lw=0.4, alpha=0.6)
        ax.axvline(b, color="w", lw=0.4, alpha=0.6)
    names = clip_labels(list(cmp.clip_names) + [str(c) for c in range(len(cmp.clip_names), C)])
    step = thin_ticks(C, _MAX_CLIP_LABELS)
    gap = cmp.num_frames / _MAX_CLIP_LABELS  # labels closer than this would overlap
    mids, labels, last = [], [], -np.inf
    for c in range(0, C, step):
        mid = (starts[c] + starts[c + 1]) / 2
        if mid - last >= gap:
            mids.append(mid)
            labels.append(names[c])
            last = mid
    size = 7 if len(labels) <= 8 else 6
    ax.set_xticks(mids)
    ax.set_xticklabels(labels, rotation=90, fontsize=size)
    ax.set_yticks(mids)
    ax.set_yticklabels(labels, fontsize=size)
    shown = f", {len(labels)} named" if len(labels) < C else ""
    ax.set_xlabel(f"target clip ({C} clips{shown}; {cmp.num_frames} frames at {cmp.fps:g} fps)")
    ax.set_ylabel("source clip")


def plot_cost_comparison(cmp: Any, path: str | Path, title: str | None = None) -> Path:
    """Write the comparison figure (PNG): each metric's normalised cost matrix, their difference
    with each metric's transitions marked (green: first metric only, magenta: second only,
    white: both within a quarter second), and the rank-ordered cost curves with T."""
    plt = pyplot()
    names = list(cmp.metrics)
    two = len(names) == 2
    extent = (0, cmp.num_frames, cmp.num_frames, 0)  # axes in frames of the whole library
    if two:
        fig, grid = plt.subplots(2, 2, figsize=figsize(12.5, 11.5))
        mat_axes = [grid[0, 0], grid[0, 1]]
        diff_ax, rank_ax = grid[1, 0], grid[1, 1]
    else:
        fig, grid = plt.subplots(1, 2, figsize=figsize(12.5, 6.0))
        mat_axes, diff_ax, rank_ax = [grid[0]], None, grid[1]
    for ax, n in zip(mat_axes, names, strict=False):
        im = ax.imshow(cmp.matrices[n], cmap="viridis", interpolation="nearest", extent=extent)
        ax.set_title(f"normalised cost: {n} metric", fontsize=10)
        fig.colorbar(im, ax=ax, fraction=0.046, label="cost / 95th percentile (capped at 1)")
        _clip_axes(ax, cmp)
    if two and diff_ax is not None:
        ax = diff_ax
        diff = cmp.matrices[names[0]] - cmp.matrices[names[1]]
        lim = float(np.nanmax(np.abs(diff))) if np.isfinite(diff).any() else 1.0
        im = ax.imshow(
            diff, cmap="RdBu_r", vmin=-lim, vmax=lim, interpolation="nearest", extent=extent
        )
        ax.set_title(f"difference ({names[0]} - {names[1]}) and the transitions", fontsize=10)
        fig.colorbar(im, ax=ax, fraction=0.046, label="normalised cost difference")
        a, b = cmp.transitions[names[0]], cmp.transitions[names[1]]
        for arr, mask, col, lab in (
            (a, ~cmp.shared[names[0]], "lime", f"{names[0]} only"),
            (b, ~cmp.shared[names[1]], "magenta", f"{names[1]} only"),
            (a, cmp.shared[names[0]], "white", "both"),
        ):
            sel = arr[mask]
            ax.scatter(
                sel[:, 1],
                sel[:, 0],
                s=16,
                c=col,
                edgecolors="k",
                linewidths=0.4,
                label=f"{lab} ({len(sel)})",
            )
        ax.legend(loc="lower left", fontsize=7, framealpha=0.7)
        _clip_axes(ax, cmp)
    ax = rank_ax
    for n in names:
        c = np.asarray(cmp.ranked_costs[n])
        if len(c):
            shown = c[: max(4 * max(cmp.T[n], 1), 50)]
            ax.plot(np.arange(1, len(shown) + 1), shown / max(shown.max(), 1e-300), label=n)
    Ts = sorted(set(cmp.T.values()))
    for T in Ts:
        ax.axvline(T, color="r", lw=1, label=f"T = {T}")
    ax.set_xlabel("rank of the candidate transition")
    ax.set_ylabel("cost / largest cost shown")
    ax.set_title(f"rank-ordered costs, chosen T = {', '.join(str(t) for t in Ts)}", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    if title:
        fig.suptitle(wrap(title, 110), fontsize=11)
    fig.tight_layout()
    return save(fig, path)
