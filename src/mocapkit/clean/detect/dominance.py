"""Veto: an MDM-only run that another joint's digression dominates nearby."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mocapkit.clean import mdm as mdm_mod
from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags
from mocapkit.clean.detect.mdm_threshold import abrupt_seeds


@dataclass(frozen=True)
class DominanceVeto:
    """Clear a flagged run holding no abrupt seed whose peak normalised digression stays below
    ``ratio`` times another joint's peak within ``pad_seconds``.

    Relies on: a gross error on one joint spoils the time warping of every motion-word around
    it, which raises the digression of the other joints of those words a little; the joint
    that really digresses dominates them."""

    name: ClassVar[str] = "dominance"
    veto: ClassVar[bool] = True
    signal: ClassVar[bool] = False
    ratio: float = 0.5
    pad_seconds: float = 1.0 / 6.0

    @classmethod
    def from_config(cls, config: DetectConfig) -> DominanceVeto:
        return cls(config.dominance, config.dominance_pad_seconds)

    def apply(self, ev: Evidence, flags: Flags) -> None:
        if self.ratio <= 0:
            return
        pad = ev.frames(self.pad_seconds)
        flags.veto(
            self.name, mdm_mod.dominated_runs(flags.mask, ev.z, abrupt_seeds(ev), self.ratio, pad)
        )

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        pad = ev.frames(self.pad_seconds)
        lo, hi = max(frame - pad, 0), frame + pad + 1
        others = np.delete(ev.z[lo:hi], joint, axis=1)
        k = int(np.argmax(others.max(axis=0))) if others.size else 0
        k = k if k < joint else k + 1
        top = float(others.max()) if others.size else 0.0
        return (
            f"normalised digression {ev.z[frame, joint]:.2f}; largest other joint within "
            f"{self.pad_seconds:.2f} s: {top:.2f} ({ev.names[k]}); ratio {self.ratio:g}"
        )
