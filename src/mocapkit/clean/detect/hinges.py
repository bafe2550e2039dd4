"""A knee or elbow bent the wrong way."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mocapkit.clean.detect._runs import deg
from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags


@dataclass(frozen=True)
class WrongWayHinges:
    """Flag the frames where a straight-at-rest knee or elbow bends more than ``min_deg`` past
    straight the wrong way (flexion about the joint's main rotation axis, signed so that the
    joint spends most of its time on the positive side), whatever the MDM.

    The axis is fitted on the hinge's bend alone (the swing of the limb below; its twist about
    that limb is left out: a forearm twisted in a wave is no flexion), on the take's own frames,
    with the context's takes where the hinge barely bends over the take
    (:attr:`Evidence.hinge_flexion`).

    Relies on: anatomy; a hinge cannot bend backwards, whatever the context holds (and several
    wrong bends on one joint would match each other in the KNN search), and it bends about an
    axis across its limb, never about the limb itself."""

    name: ClassVar[str] = "wrong-way-hinge"
    veto: ClassVar[bool] = False
    signal: ClassVar[bool] = True
    min_deg: float = 15.0

    @classmethod
    def from_config(cls, config: DetectConfig) -> WrongWayHinges:
        return cls(config.hinge_deg)

    def cells(self, ev: Evidence):
        return ev.wrong_way

    def apply(self, ev: Evidence, flags: Flags) -> None:
        flags.flag(self.name, ev.wrong_way)

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        f = ev.hinge_flexion[frame, joint]
        if not np.isfinite(f):
            return "not a straight-at-rest knee or elbow"
        if -f > np.radians(ev.config.hinge_max_deg):
            return (
                f"limb folded back {deg(-f)}, past any knee's or elbow's reach (over "
                f"{ev.config.hinge_max_deg:g} deg)"
            )
        return f"flexion {deg(f)} (wrong way below -{self.min_deg:g} deg)"
