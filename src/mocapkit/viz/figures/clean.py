"""The cleaning decision beside the movement digression map (the paper's Figure 1).

Two panels share the time axis and the joint rows (labelled with joint names): on top the
*decision*, every flagged cell coloured by the first rule that flagged it (legend: the rule
names) and, up to 40 segments, each segment's every rule written beside it, pale grey where the
MDM is above the threshold but no rule flagged the cell (no seed, or a veto cleared it: ``clean
--explain`` says which), white elsewhere, so colour there means "flagged, and why"; below, the
MDM in greys (white = like its neighbours, black = distinct) with the threshold marked on its
colour bar, so a dark MDM cell that is not flagged is visible as such and no box is drawn on it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mocapkit.viz.figures import figsize, pyplot, save, short_labels, thin_ticks, wrap
from mocapkit.viz.reasons import REASON_COLOURS, reason_colour

__all__ = ["REASON_COLOURS", "plot_clean_report", "plot_mdm"]

_MAX_ROW_LABELS = 60  # joint names readable at 7 pt on the tallest figure
_MAX_COLUMNS = 3000  # time columns drawn: a longer take is max-pooled (a flagged frame survives)
_UNFLAGGED = "#d9d9d9"  # MDM above the threshold, not flagged: paler than any rule's colour
_MAX_NOTES = 40  # segments named with all their rules on the decision panel; more would pile up


def _seg(s: Any) -> tuple[int, int, int, tuple[str, ...]]:
    if isinstance(s, Mapping):
        return int(s["joint_index"]), int(s["start"]), int(s["end"]), tuple(s.get("reasons", ()))
    return int(s.joint_index), int(s.start), int(s.end), tuple(getattr(s, "reasons", ()))


def _pool(a: np.ndarray, fn) -> np.ndarray:
    """Max/min-pool (F, J) along time to at most ``_MAX_COLUMNS`` rows."""
    F = a.shape[0]
    if F <= _MAX_COLUMNS:
        return a
    k = int(np.ceil(F / _MAX_COLUMNS))
    pad = (-F) % k
    fill = np.full((pad, a.shape[1]), a.min() if fn is np.max else a.max(), dtype=a.dtype)
    return fn(np.concatenate([a, fill]).reshape(-1, k, a.shape[1]), axis=1)


def _decision_from_segments(segments: Sequence[Any], F: int, J: int) -> tuple[np.ndarray, list]:
    names: list[str] = []
    dec = np.full((F, J), -1, dtype=np.int16)
    for s in segments:
        j, a, b, reasons = _seg(s)
        r = reasons[0] if reasons else "flagged"
        if r not in names:
            names.append(r)
        dec[a : b + 1, j] = names.index(r)
    return dec, names


def plot_mdm(
    mdm: np.ndarray,
    names: Sequence[str],
    segments: Sequence[Any],
    path: str | Path,
    fps: float,
    title: str = "",
    decision: np.ndarray | None = None,
    reason_names: Sequence[str] | None = None,
    threshold: float | None = None,
) -> Path:
    """Write the decision and MDM heat map to ``path`` (PNG).

    ``mdm``: (F, J) in [0, 1]; ``names``: the J joint names (rows, top to bottom in skeleton
    order); ``segments``: flagged runs (:class:`~mocapkit.clean.Segment` or their ``as_dict()``:
    ``joint_index``, ``start``, ``end`` inclusive, ``reasons``); ``decision``: (F, J) int, the
    index in ``reason_names`` of each flagged cell's first reason, -1 where not flagged (default:
    from the segments); ``threshold``: marked on the MDM colour bar; ``fps``: the take's rate.
    """
    from matplotlib.colors import ListedColormap, to_rgb
    from matplotlib.patches import Patch

    plt = pyplot()
    mdm = np.asarray(mdm, dtype=float)
    F, J = mdm.shape
    if decision is None or reason_names is None:
        decision, reason_names = _decision_from_segments(segments, F, J)
    decision = np.asarray(decision)
    reason_names = list(reason_names)
    dt = 1.0 / fps
    seconds = F * dt
    extent = (-0.5 * dt, (F - 0.5) * dt, J - 0.5, -0.5)
    w_in = max(7.0, 2.5 + seconds * 0.9)
    h_in = max(4.8, 2.4 + 2 * J * 0.15)
    fig, (ax_d, ax_m) = plt.subplots(
        2, 1, figsize=figsize(w_in, h_in), sharex=True, sharey=True, constrained_layout=True
    )
    seen: list[str] = []
    colours = [reason_colour(r, seen) for r in reason_names]
    dec = _pool(decision.astype(np.int16), np.max)
    img = np.ones((*dec.T.shape, 3))
    unflagged = np.zeros(dec.shape, dtype=bool)
    if threshold is not None:  # above the threshold, yet no rule flagged it
        unflagged = _pool(mdm > threshold, np.max) & (dec < 0)
        img[unflagged.T] = to_rgb(_UNFLAGGED)
    for i, c in enumerate(colours):
        img[(i == dec.T)] = to_rgb(c)
    ax_d.imshow(img, aspect="auto", origin="upper", interpolation="nearest", extent=extent)
    # a one-frame flag in a long take stays visible: a tick under it
    n_flagged = len(segments)
    min_w = seconds / 400.0
    for s in segments:
        j, a, b, reasons = _seg(s)
        if (b - a + 1) * dt < min_w:
            r = reasons[0] if reasons else None
            col = colours[reason_names.index(r)] if r in reason_names else "black"
            ax_d.plot([(a + b) / 2 * dt] * 2, [j - 0.45, j + 0.45], color=col, lw=1.5)
    # a colour tells one rule; each segment's every rule is written beside it, so a bend that
    # mdm, cancelling-jumps and wrong-way-hinge all flagged does not read as mdm's alone
    noted = 0 < n_flagged <= _MAX_NOTES
    if noted:
        runs = sorted(_seg(s) for s in segments)
        taken: dict[int, float] = {}  # per row, the frame the last label placed reaches
        for i, (j, a, b, reasons) in enumerate(runs):
            text = " + ".join(reasons) if reasons else "flagged"
            # on the side with room for it before the row's next segment (or the take's end),
            # else the other, past the row's labels placed so far; none where neither has
            after = next((a2 for j2, a2, _, _ in runs[i + 1 :] if j2 == j), F)
            before = max((b2 + 1 for j2, _, b2, _ in runs[:i] if j2 == j), default=0)
            before = max(before, taken.get(j, 0.0))
            need = len(text) / 24.0 / (0.8 * w_in) * F + F / 100.0  # 5.5 pt: ~24 chars an inch
            if after - (b + 1) >= need:
                x, ha = (b + 0.5) * dt + seconds / 200.0, "left"
                taken[j] = b + 1 + need
            elif a - before >= need:
                x, ha = (a - 0.5) * dt - seconds / 200.0, "right"
                taken[j] = float(b + 1)
            else:
                continue
            ax_d.text(x, j, text, fontsize=5.5, va="center", ha=ha, color="#333333", clip_on=True)
    shown = set(np.unique(decision).tolist())
    handles = [
        Patch(color=c, label=r)
        for i, (r, c) in enumerate(zip(reason_names, colours, strict=True))
        if i in shown
    ]
    if unflagged.any():
        handles.append(
            Patch(color=_UNFLAGGED, label=f"MDM > {threshold:g}, not\nflagged (--explain)")
        )
    if handles:
        ax_d.legend(
            handles=handles,
            loc="upper left",
            bbox_to_anchor=(1.01, 1.0),
            fontsize=7,
            title="first rule to\nflag the cell",
            title_fontsize=7,
            frameon=False,
        )
    head = title or "cleaning"
    fig.suptitle(
        wrap(f"{head}: {n_flagged} flagged segment{'s' if n_flagged != 1 else ''}", 80),
        fontsize=10,
    )
    ax_d.set_title(  # wrapped to the panel: a short take's figure is 7 in wide
        wrap(
            "decision: the flagged cells, coloured by the first rule to flag them"
            + ("; beside each segment, every rule that flagged it" if noted else ""),
            int(w_in * 11),
        ),
        fontsize=9,
    )
    im = ax_m.imshow(
        _pool(mdm, np.max).T,
        aspect="auto",
        origin="upper",
        cmap=ListedColormap(plt.get_cmap("Greys")(np.linspace(0.0, 0.95, 256))),
        vmin=0.0,
        vmax=1.0,
        interpolation="nearest",
        extent=extent,
    )
    ax_m.set_title("movement digression map (MDM)", fontsize=9)
    # under its panel: a bar at the right sat in the legend's wide column, far from the map
    cb = fig.colorbar(im, ax=ax_m, location="bottom", pad=0.02, fraction=0.05, aspect=40)
    label = "MDM (0 = like its neighbours)"
    if threshold is not None:
        label += f"; threshold {threshold:g} (line)"
    cb.set_label(label, fontsize=7)
    cb.ax.tick_params(labelsize=7)
    if threshold is not None:
        cb.ax.axvline(threshold, color="#d62728", lw=1.5)
    step = thin_ticks(J, _MAX_ROW_LABELS)
    rows = list(range(0, J, step))
    labels = short_labels(names, 26)
    for ax in (ax_d, ax_m):
        ax.set_yticks(rows)
        ax.set_yticklabels([labels[j] for j in rows], fontsize=6 if J > 30 else 7)
        ax.set_ylabel("joint" + (f" (1 in {step} named)" if step > 1 else ""), fontsize=8)
    ax_m.set_xlabel(f"time (s) at {fps:g} fps")
    top = ax_d.secondary_xaxis("top", functions=(lambda t: t * fps, lambda f: f / fps))
    top.set_xlabel("frame", fontsize=8)
    top.tick_params(labelsize=7)
    return save(fig, path)


def plot_clean_report(report: Any, path: str | Path, title: str | None = None) -> Path:
    """:func:`plot_mdm` of a :class:`~mocapkit.clean.CleanReport` (title: the take's name)."""
    name = title if title is not None else Path(report.source).name
    ctx = tuple(getattr(report, "context", ()) or ())
    n = len(ctx)
    name += f" (against {n} context take{'s' if n != 1 else ''})" if n else " (the take alone)"
    return plot_mdm(
        report.mdm,
        report.joints,
        report.segments,
        path,
        report.fps,
        name,
        decision=getattr(report, "decision", None),
        reason_names=getattr(report, "reason_names", None),
        threshold=None if report.method != "self-similarity" else report.threshold,
    )
