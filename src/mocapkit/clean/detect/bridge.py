"""Close a joint's short unflagged holes between two flagged runs."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags
from mocapkit.core.runs import true_runs


@dataclass(frozen=True)
class BridgeHoles:
    """Flag the unflagged frames of a joint that lie between two of its flagged runs at most
    ``max_seconds`` apart.

    Relies on: a capture error does not stop for a frame and start again; when the frames just
    before and just after are wrong, the ones between are wrong too (the rules judge each frame
    by its own evidence, and a glitch's middle can look calm: two opposite jumps, a frame that
    happens to fall on the right value)."""

    name: ClassVar[str] = "bridge"
    veto: ClassVar[bool] = False
    signal: ClassVar[bool] = False
    max_seconds: float = 0.05

    @classmethod
    def from_config(cls, config: DetectConfig) -> BridgeHoles:
        return cls(config.bridge_seconds)

    def cells(self, ev: Evidence, mask: np.ndarray) -> np.ndarray:
        """(F, J) bool: the holes of ``mask`` to close."""
        out = np.zeros_like(mask)
        if self.max_seconds <= 0:
            return out
        n = ev.frames(self.max_seconds, 1)
        for j in np.flatnonzero(mask.any(axis=0)):
            for a, b in true_runs(~mask[:, j]):
                if a > 0 and b + 1 < mask.shape[0] and b - a + 1 <= n:
                    out[a : b + 1, j] = True
        return out

    def apply(self, ev: Evidence, flags: Flags) -> None:
        flags.flag(self.name, self.cells(ev, flags.mask))

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        n = ev.frames(self.max_seconds, 1)
        # the frames as this take has them: 0.05 s is 2 frames (0.067 s) at 30 fps
        return (
            f"closes holes of up to {n} frame(s) ({n / ev.fps:.3g} s) between two flagged runs "
            "of a joint"
        )
