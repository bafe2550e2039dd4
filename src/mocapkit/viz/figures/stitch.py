"""Figures for stitching.

* :func:`plot_stitch` — the paper's Figure 4 for a motion stitch: L_k versus k (k_opt marked),
  and the stitched trajectory of a few joints around the transition with the take-off frame
  (red triangle), the generated frames (blue triangles) and the landing frame (green circle),
  plus the L-score's own Kalman feature trajectory for the injected frames (dashed).
* :func:`plot_paths_2d` — 2-D paths (Three-Circles): query, data, generated frames.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mocapkit.viz.figures import figsize, pyplot, save, wrap

__all__ = ["pick_plot_joints", "plot_paths_2d", "plot_stitch"]


def pick_plot_joints(skeleton, n: int = 3) -> list[int]:
    """Up to ``n`` joints worth plotting: the right wrist, the left wrist and a foot (ankle) of
    the body model (:func:`mocapkit.body.body_of`), else the other wrists and ankles it found,
    else the last joints."""
    from mocapkit.body import body_of

    body = body_of(skeleton)
    picks: list[int] = []
    wanted = [body.joint(k) for k in ("right_wrist", "left_wrist", "left_ankle", "right_ankle")]
    for j in [*wanted, *body.both("wrist"), *body.both("ankle")]:
        if j is not None and j not in picks:
            picks.append(j)
    picks = picks[: min(n, 2)] + [j for j in picks[2:] if j in body.both("ankle")][:1]
    for i in range(skeleton.num_joints - 1, -1, -1):
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
    title: str | None = None,
) -> Path:
    """Write the two-panel stitch figure to ``path`` (PNG).

    ``stitched`` is a :class:`~mocapkit.stitch.Stitched`; ``lscore_by_k`` defaults to its
    transition's. ``joints``: joint indices of the motion (default :func:`pick_plot_joints`);
    the right panel shows their body-local height and forward coordinates (cm) over the output
    frames ``takeoff - margin .. landing + margin``. ``up`` defaults to the stitch's.
    """
    from mocapkit import features

    plt = pyplot()
    m = stitched.motion
    names = m.skeleton.names
    if lscore_by_k is None and stitched.transition is not None:
        lscore_by_k = stitched.transition.lscore_by_k
    joints = list(joints) if joints is not None else pick_plot_joints(m.skeleton)
    up = up or getattr(stitched, "up", None) or features.detect_up_axis(m)
    cm = 100.0 * features.metres_per_unit(m, None)
    fps = m.fps
    a, land = stitched.takeoff, stitched.landing_index
    # a cross-fade's window starts before its take-off: show all of it
    first = min(a, stitched.generated.start)
    lo, hi = max(0, first - margin), min(m.num_frames, max(land, a) + margin + 1)
    lp = features.local_positions(m[lo:hi], up=up) * cm
    _, ui, fi = features.ground_plane_axes(up)
    frames = np.arange(lo, hi)
    fig, axes = plt.subplots(1, 2, figsize=figsize(13, 5.2), gridspec_kw={"width_ratios": [1, 1.6]})
    ax = axes[0]
    if lscore_by_k is not None:
        L = np.asarray(lscore_by_k)
        ks = np.arange(len(L))
        ax.plot(ks, L, "k.-", ms=4)
        k_opt = int(np.argmin(L))
        k = int(stitched.k) if 0 <= int(stitched.k) < len(L) else k_opt
        label = f"k_opt = {k} ({k / fps:.2f} s), L* = {L[k]:.4g}"
        if k != k_opt:  # a forced k (--inject): mark what was used, and the optimum beside it
            label = f"k = {k} (forced), L_k = {L[k]:.4g}; k_opt = {k_opt}"
            ax.plot([k_opt], [L[k_opt]], "o", mfc="none", mec="r", ms=10)
        ax.plot([k], [L[k]], "r*", ms=14, label=label)
        ax.set_xlabel(f"k, injected frames (at {fps:g} fps)")
        ax.set_ylabel("L_k (effort; lower = smoother)")
        ax.set_title("elastic L-score vs k", fontsize=10)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
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
            ax.plot(frames, y, "-", color=color, lw=1.3, label=f"{names[j]} {label}")
            sel = lambda f, y=y: y[np.asarray(f) - lo]  # noqa: E731
            ax.plot([a], sel([a]), "r^", ms=8)
            if len(gen):
                ax.plot(gen, sel(gen), "b^", ms=4)
                if kal_idx and j in kal_idx and len(stitched.kalman_positions):
                    kal = stitched.kalman_positions[:, kal_idx[j], coord] * cm
                    ax.plot(gen, kal, "--", color=color, lw=1)
            if land < hi:
                ax.plot([land], sel([land]), "go", ms=8, mfc="none", mew=2)
    ax.axvspan(a + 0.5, land - 0.5, color="0.9", zorder=0)
    ax.set_xlabel(f"output frame (at {fps:g} fps)")
    top = ax.secondary_xaxis("top", functions=(lambda f: f / fps, lambda t: t * fps))
    top.set_xlabel("time (s)", fontsize=8)
    top.tick_params(labelsize=7)
    ax.set_ylabel("body-local position (cm)")
    n_gen = len(gen)
    from matplotlib.lines import Line2D

    handles, _ = ax.get_legend_handles_labels()
    handles += [
        Line2D([], [], ls="", marker="^", color="r", ms=8, label=f"take-off (frame {a})"),
        Line2D([], [], ls="", marker="^", color="b", ms=5, label=f"generated ({n_gen} frames)"),
        Line2D(
            [], [], ls="", marker="o", mfc="none", mec="g", mew=2, ms=8,
            label=f"landing (output frame {land})",
        ),
    ]  # fmt: skip
    if kal_idx:
        handles.append(Line2D([], [], ls="--", color="0.3", label="L-score's Kalman features"))
    ax.set_title(
        wrap(
            f"{stitched.method} transition: output frames {lo}-{hi - 1}, shaded = between "
            "take-off and landing",
            80,
        ),
        fontsize=10,
    )
    ax.legend(
        handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False
    )
    ax.grid(alpha=0.3)
    if title is None and stitched.transition is not None:
        tr = stitched.transition
        names_ = getattr(stitched, "data_names", ())
        data = names_[tr.clip] if tr.clip < len(names_) else f"data clip {tr.clip}"
        query = getattr(stitched, "query_name", "query")
        title = (
            f"{Path(str(query)).stem} → {Path(str(data)).stem} at its frame {tr.landing}: "
            f"best of {tr.candidates} candidate{'' if tr.candidates == 1 else 's'} by {tr.score}"
        )
    if title:
        fig.suptitle(wrap(title, 140), fontsize=11)
    fig.tight_layout()
    return save(fig, path)


def plot_paths_2d(path: str | Path, curves: dict, title: str = "", units: str = "") -> Path:
    """2-D paths: ``curves`` maps a label to ``(points (n, 2), matplotlib format)``;
    ``units`` labels the axes."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=figsize(8, 4.6))
    for label, (pts, fmt) in curves.items():
        pts = np.asarray(pts)
        ax.plot(pts[:, 0], pts[:, 1], fmt, label=label, ms=4)
    ax.set_aspect("equal")
    u = f" ({units})" if units else ""
    ax.set_xlabel(f"x{u}")
    ax.set_ylabel(f"y{u}")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    ax.set_title(wrap(title, 60), fontsize=10)
    fig.tight_layout()
    return save(fig, path)
