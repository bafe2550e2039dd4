"""Figures for stitching (matplotlib, imported lazily, Agg backend; PNG files).

* :func:`plot_stitch` — the paper's Figure 4 for a motion stitch: L_k versus k (k_opt marked),
  and the stitched trajectory of a few joints around the transition with the take-off frame
  (red triangle), the injected frames (blue triangles) and the landing frame (green circle), plus
  the L-score's own Kalman feature trajectory for the injected frames (dashed).
* :func:`plot_paths_2d` — 2-D paths (Three-Circles): query, data, generated frames.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mocapkit._optional import pyplot

__all__ = ["pick_plot_joints", "plot_paths_2d", "plot_stitch"]


def pick_plot_joints(names: Sequence[str], n: int = 3) -> list[int]:
    """Up to ``n`` joints worth plotting: a hand, the other hand, a foot (by name), else the
    last joints."""
    low = [s.lower() for s in names]
    picks: list[int] = []
    for pats in (("righthand", "hand_r", "rhand", "r_hand"), ("hand",), ("foot", "ankle")):
        for i, s in enumerate(low):
            if i not in picks and any(p in s for p in pats):
                picks.append(i)
                break
    for i in range(len(names) - 1, -1, -1):
        if len(picks) >= n:
            break
        if i not in picks:
            picks.append(i)
    return picks[:n]


def plot_stitch(
    stitched,
    path: str | Path,
    lscore_by_k=None,
    joints: Sequence[int] | None = None,
    up: str | None = None,
    margin: int = 15,
) -> Path:
    """Write the two-panel stitch figure to ``path`` (PNG). ``stitched`` is a
    :class:`~mocapkit.stitch.transition.Stitched`; ``lscore_by_k`` defaults to its transition's.
    ``joints``: joint indices of the motion (default :func:`pick_plot_joints`); the trajectory
    panel shows their body-local height and forward coordinates over the output frames
    ``takeoff - margin .. landing + margin``."""
    from mocapkit import features

    plt = pyplot()
    m = stitched.motion
    names = m.skeleton.names
    if lscore_by_k is None and stitched.transition is not None:
        lscore_by_k = stitched.transition.lscore_by_k
    joints = list(joints) if joints is not None else pick_plot_joints(names)
    up = up or features.detect_up_axis(m)
    a, land = stitched.takeoff, stitched.landing_index
    lo, hi = max(0, a - margin), min(m.num_frames, land + margin + 1)
    lp = features.local_positions(m[lo:hi], up=up)
    _, ui, fi = features.ground_plane_axes(up)
    frames = np.arange(lo, hi)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    ax = axes[0]
    if lscore_by_k is not None:
        L = np.asarray(lscore_by_k)
        ax.plot(np.arange(len(L)), L, "k.-")
        k = int(np.argmin(L))
        ax.plot([k], [L[k]], "r*", ms=14, label=f"k_opt = {k}, L* = {L[k]:.4g}")
        ax.set_xlabel("k (injected frames)")
        ax.set_ylabel("L_k")
        ax.set_title("elastic L-score vs k")
        ax.legend()
    else:
        ax.set_axis_off()
    ax = axes[1]
    gen = np.arange(stitched.generated.start, stitched.generated.stop)
    kal_idx = None
    if stitched.kalman_positions is not None:
        from mocapkit.stitch.search import body_joints

        body = body_joints(m.skeleton)
        kal_idx = {j: body.index(j) for j in joints if j in body}
    for c, (coord, label) in enumerate(((ui, "height"), (fi, "forward"))):
        for n, j in enumerate(joints):
            y = lp[:, j, coord]
            color = f"C{n + 3 * c}"
            ax.plot(frames, y, "-", color=color, lw=1.2, label=f"{names[j]} {label}")
            sel = lambda f, y=y: y[np.asarray(f) - lo]  # noqa: E731
            ax.plot([a], sel([a]), "r^", ms=8)
            if len(gen):
                ax.plot(gen, sel(gen), "b^", ms=5)
                if kal_idx and j in kal_idx and len(stitched.kalman_positions):
                    ax.plot(gen, stitched.kalman_positions[:, kal_idx[j], coord], "--", color=color)
            if land < hi:
                ax.plot([land], sel([land]), "go", ms=8, mfc="none", mew=2)
    ax.axvspan(a + 0.5, land - 0.5, color="0.9")
    ax.set_xlabel("output frame")
    ax.set_ylabel("body-local position (clip units)")
    ax.set_title(
        f"{stitched.method}: take-off ▲ {stitched.takeoff}, {stitched.k} injected ▲, landing ○"
    )
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_paths_2d(path: str | Path, curves: dict, title: str = "") -> Path:
    """2-D paths: ``curves`` maps a label to ``(points (n, 2), matplotlib format)``."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 5))
    for label, (pts, fmt) in curves.items():
        pts = np.asarray(pts)
        ax.plot(pts[:, 0], pts[:, 1], fmt, label=label, ms=4)
    ax.set_aspect("equal")
    ax.legend(fontsize=7)
    ax.set_title(title)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
