"""Small helpers the rules share for ``describe``."""

from __future__ import annotations

import numpy as np


def run_around(mask_col: np.ndarray, frame: int) -> tuple[int, int] | None:
    """The run of True in ``mask_col`` (F,) holding ``frame`` (inclusive ends), or None."""
    if not mask_col[frame]:
        return None
    a = frame
    while a > 0 and mask_col[a - 1]:
        a -= 1
    b = frame
    while b + 1 < len(mask_col) and mask_col[b + 1]:
        b += 1
    return a, b


def deg(x: float) -> str:
    return f"{np.degrees(float(x)):.1f} deg"
