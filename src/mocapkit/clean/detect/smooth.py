"""Veto: a flagged run with no step near it is natural motion the context lacks."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mocapkit.clean import mdm as mdm_mod
from mocapkit.clean.detect._runs import deg
from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags


@dataclass(frozen=True)
class SmoothVeto:
    """Clear a flagged run (frozen runs aside) whose largest step within ``pad_seconds`` stays
    below ``min_deg`` (:func:`~mocapkit.clean.mdm.smooth_runs`).

    Relies on: capture errors (pops, flips, offsets, noise, wrong bends) enter or leave with a
    frame-to-frame step far from the steps around it; a digression reached smoothly is motion
    the context does not hold (a dancer's head whip), not an error."""

    name: ClassVar[str] = "smooth"
    veto: ClassVar[bool] = True
    signal: ClassVar[bool] = False
    min_deg: float = 12.0
    pad_seconds: float = 0.2

    @classmethod
    def from_config(cls, config: DetectConfig) -> SmoothVeto:
        return cls(config.abrupt_deg, config.abrupt_seconds)

    def apply(self, ev: Evidence, flags: Flags) -> None:
        if self.min_deg <= 0:
            return
        keep = flags.added.get("frozen", np.zeros(flags.mask.shape, dtype=bool))
        pad = ev.frames(self.pad_seconds)
        flags.veto(
            self.name,
            mdm_mod.smooth_runs(flags.mask, ev.steps, keep, np.radians(self.min_deg), pad),
        )

    def describe(self, ev: Evidence, frame: int, joint: int) -> str:
        pad = ev.frames(self.pad_seconds)
        s = ev.steps[max(frame - pad, 0) : frame + pad + 1, joint].max()
        return f"largest step within {self.pad_seconds:g} s: {deg(s)} (needs {self.min_deg:g})"
