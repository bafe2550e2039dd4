"""The movement digression map as a heat map (the paper's Figure 1): joints x time, hot =
the joint digresses from its nearest neighbours, flagged segments outlined."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mocapkit.viz.figures import figsize, pyplot, save, short_labels, thin_ticks, wrap

__all__ = ["plot_clean_report", "plot_mdm"]

_MAX_ROW_LABELS = 60  # joint names readable at 7 pt on the tallest figure


def _seg(s: Any) -> tuple[int, int, int]:
    if isinstance(s, Mapping):
        return int(s["joint_index"]), int(s["start"]), int(s["end"])
    return int(s.joint_index), int(s.start), int(s.end)


def plot_mdm(
    mdm: np.ndarray,
    names: Sequence[str],
    segments: Sequence[Any],
    path: str | Path,
    fps: float,
    title: str = "",
) -> Path:
    """Write the MDM heat map to ``path`` (PNG).

    ``mdm``: (F, J) in [0, 1]; ``names``: the J joint names (one row each, top to bottom in
    skeleton order); ``segments``: flagged runs (:class:`~mocapkit.clean.Segment` or their
    ``as_dict()``: ``joint_index``, ``start``, ``end`` inclusive), outlined in white; ``fps``:
    the take's frame rate (time axis in seconds below, frames above).
    """
    from matplotlib.patches import Rectangle

    plt = pyplot()
    mdm = np.asarray(mdm, dtype=float)
    F, J = mdm.shape
    dt = 1.0 / fps
    seconds = F * dt
    fig, ax = plt.subplots(figsize=figsize(max(7.0, 2.0 + seconds * 0.9), max(3.2, 1.6 + J * 0.17)))
    im = ax.imshow(
        mdm.T,
        aspect="auto",
        origin="upper",
        cmap="magma",
        vmin=0.0,
        vmax=1.0,
        interpolation="nearest",
        extent=(-0.5 * dt, (F - 0.5) * dt, J - 0.5, -0.5),
    )
    min_w = seconds / 300.0  # a one-frame segment of a long take stays visible
    for s in segments:
        j, a, b = _seg(s)
        w = max((b - a + 1) * dt, min_w)
        ax.add_patch(
            Rectangle(
                ((a + b) / 2 * dt - w / 2, j - 0.5),
                w,
                1.0,
                fill=False,
                edgecolor="cyan",
                linewidth=1.3,
            )
        )
    step = thin_ticks(J, _MAX_ROW_LABELS)
    rows = list(range(0, J, step))
    ax.set_yticks(rows)
    labels = short_labels(names, 26)
    ax.set_yticklabels([labels[j] for j in rows], fontsize=7 if J > 30 else 8)
    ax.set_ylabel("joint" + (f" (1 in {step} named)" if step > 1 else ""))
    ax.set_xlabel(f"time (s) at {fps:g} fps")
    top = ax.secondary_xaxis("top", functions=(lambda t: t * fps, lambda f: f / fps))
    top.set_xlabel("frame", fontsize=8)
    top.tick_params(labelsize=7)
    n = len(segments)
    head = title or "movement digression map"
    ax.set_title(
        wrap(f"{head}: {n} flagged segment{'s' if n != 1 else ''} (outlined)", 80), fontsize=10
    )
    fig.colorbar(im, ax=ax, label="MDM (0 = like its neighbours, 1 = distinct)", pad=0.02)
    fig.tight_layout()
    return save(fig, path)


def plot_clean_report(report: Any, path: str | Path, title: str | None = None) -> Path:
    """:func:`plot_mdm` of a :class:`~mocapkit.clean.CleanReport` (title: the take's name)."""
    name = title if title is not None else Path(report.source).name
    return plot_mdm(report.mdm, report.joints, report.segments, path, report.fps, name)
