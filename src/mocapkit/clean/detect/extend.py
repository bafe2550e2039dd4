"""Stretch flagged runs to the steps that bound them."""

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
class ExtendToSteps:
    """Stretch every flagged run back to the latest step above ``min_deg`` at most
    ``max_seconds`` before it and on to the earliest one after it
    (:func:`~mocapkit.clean.mdm.extend_to_steps`).

    Relies on: an error's first and last frames often digress too little to pass the
    threshold, while the error's entry and exit steps mark where it really starts and ends."""

    name: ClassVar[str] = "extend"
    veto: ClassVar[bool] = False
    signal: ClassVar[bool] = False
    min_deg: float = 8.0
    max_seconds: float = 2.0 / 15.0

    @classmethod
    def from_config(cls, config: DetectConfig) -> ExtendToSteps:
        return cls(config.step_min_deg, config.extend_seconds)

    def apply(self, ev: Evidence, flags: Flags) -> None:
        ext = ev.frames(self.max_seconds)
        out = mdm_mod.extend_to_steps(flags.mask, ev.steps, np.radians(self.min_deg), ext)
        flags.flag(self.name, out & ~flags.mask)

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        return f"step into this frame {deg(ev.steps[frame, joint])} (reaches {self.min_deg:g} deg)"
