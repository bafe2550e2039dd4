"""Figures (PNG files, matplotlib on the Agg backend, imported on use): the only place in
mocapkit that draws with matplotlib. The capabilities return data; these functions draw it.

* :mod:`~mocapkit.viz.figures.stitch` the L_k(k) curve and the joint trajectories around a
  transition; 2-D paths (Three-Circles).
* :mod:`~mocapkit.viz.figures.graph` the cost matrices of two metrics, their difference with the
  transitions, and the rank-ordered cost curves.
* :mod:`~mocapkit.viz.figures.clean` the movement digression map (MDM) heat map.

Shared rules: axes say their unit (seconds with the frame rate, frames, cm, degrees), figures
are at most :data:`MAX_WIDTH_IN` x :data:`MAX_HEIGHT_IN` inches at :data:`DPI`, long titles are
wrapped and long tick-label lists thinned.
"""

from __future__ import annotations

import io
import textwrap
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

__all__ = [
    "DPI",
    "MAX_HEIGHT_IN",
    "MAX_WIDTH_IN",
    "figsize",
    "pyplot",
    "save",
    "short_labels",
    "thin_ticks",
    "wrap",
]

DPI = 110
MAX_WIDTH_IN = 14.0
"""Widest figure (1,540 pixels at :data:`DPI`): wider strips cannot be read on a screen."""
MAX_HEIGHT_IN = 11.0


def pyplot() -> ModuleType:
    """matplotlib.pyplot on the non-interactive Agg backend (ImportError naming the
    ``mocapkit[plot]`` extra when matplotlib is missing)."""
    from mocapkit._optional import require

    mpl = require("matplotlib")
    mpl.use("Agg", force=False)
    return require("matplotlib.pyplot")


def wrap(text: str, width: int = 70) -> str:
    """``text`` wrapped to lines of at most ``width`` characters (for titles)."""
    return "\n".join(textwrap.wrap(text, width)) if len(text) > width else text


def shorten(text: str, width: int) -> str:
    """``text`` shortened to ``width`` characters, the middle elided."""
    if len(text) <= width:
        return text
    head = (width - 1) // 2
    return text[:head] + "…" + text[len(text) - (width - 1 - head) :]


def _common_prefix(texts: Sequence[str]) -> str:
    first = min(texts, key=len)
    n = 0
    while n < len(first) and all(t[n] == first[n] for t in texts):
        n += 1
    return first[:n]


def short_labels(names: Sequence[str], width: int = 22, separators: str = "_-:|") -> list[str]:
    """Tick labels for many names: the prefix and suffix they all share removed (cut at a
    ``separators`` character, e.g. ``dataset-1_`` and ``_001`` of Bandai's clips or
    ``mixamorig:`` of Mixamo joints), then each :func:`shorten`-ed to ``width``."""
    names = [str(n) for n in names]
    if len(names) > 1:
        pre = _common_prefix(names)
        pre = pre[: max(pre.rfind(c) for c in separators) + 1]
        suf = _common_prefix([t[::-1] for t in names])[::-1]
        cut = [i for i, ch in enumerate(suf) if ch in separators]
        suf = suf[cut[0] :] if cut else ""
        if all(len(t) > len(pre) + len(suf) for t in names):
            names = [t[len(pre) : len(t) - len(suf)] for t in names]
    return [shorten(t, width) for t in names]


def thin_ticks(n: int, max_labels: int) -> int:
    """The step between labelled ticks so that at most ``max_labels`` of ``n`` are shown."""
    return max(1, -(-n // max(1, max_labels)))


def figsize(width: float, height: float) -> tuple[float, float]:
    """``(width, height)`` in inches, capped at :data:`MAX_WIDTH_IN` x :data:`MAX_HEIGHT_IN`."""
    return min(float(width), MAX_WIDTH_IN), min(float(height), MAX_HEIGHT_IN)


def save(fig: Any, path: str | Path, dpi: int = DPI) -> Path:
    """Write ``fig`` as PNG to ``path`` atomically and close it."""
    from mocapkit.io.atomic import atomic_write_bytes

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    pyplot().close(fig)
    return atomic_write_bytes(path, buf.getvalue())
