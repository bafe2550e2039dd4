"""A short stretch that leaves the joint's own smooth path."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy import ndimage

from mocapkit.clean.detect._runs import deg
from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags


@dataclass(frozen=True)
class Spikes:
    """Flag stretches of at most ``spike_seconds`` (set in the evidence) lying more than
    ``min_deg`` off the cubic through the two frames either side, at every frame
    (:func:`~mocapkit.clean.mdm.spike_size`), unless within ``pad_seconds`` of a run already
    flagged (its wrong frames spoil the cubic).

    Relies on: a joint's rotation is smooth at the capture rate; it does not leave its own path
    by 40 deg and come back within a fifteenth of a second, whatever the context holds (a
    punch's impact wobble is 12-15 deg; over longer stretches an impact does leave the cubic
    through the frames around it, so a spike is short)."""

    name: ClassVar[str] = "spike"
    veto: ClassVar[bool] = False
    signal: ClassVar[bool] = False
    min_deg: float = 40.0
    pad_seconds: float = 0.2

    @classmethod
    def from_config(cls, config: DetectConfig) -> Spikes:
        return cls(config.spike_deg, config.spike_pad_seconds)

    def apply(self, ev: Evidence, flags: Flags) -> None:
        pad = ev.frames(self.pad_seconds)
        near = ndimage.binary_dilation(flags.mask, structure=np.ones((2 * pad + 1, 1), dtype=bool))
        flags.flag(self.name, (ev.spike_size > np.radians(self.min_deg)) & ~near)

    def describe(self, ev: Evidence, frame: int, joint: int) -> str:
        return (
            f"off its smooth path by {deg(ev.spike_size[frame, joint])} "
            f"(spike above {self.min_deg:g} deg)"
        )
