"""A joint that holds one rotation exactly while its neighbours move on."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from mocapkit.clean.detect._runs import deg, run_around
from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags


@dataclass(frozen=True)
class FrozenJoints:
    """Flag runs of at least ``frozen_seconds`` where the joint holds its rotation (slower than
    ``frozen_speed_deg_s``) while the KNN words move away, at a value it does not rest at
    elsewhere (:func:`~mocapkit.clean.mdm.frozen_cells`).

    Relies on: a live joint trembles; a dropped marker makes the solver repeat a stored value
    exactly, while a joint parked at its limit (straight elbow, flat toes) comes back to rest
    at the same value again and again."""

    name: ClassVar[str] = "frozen"
    veto: ClassVar[bool] = False
    signal: ClassVar[bool] = False
    min_seconds: float = 1.0 / 3.0

    @classmethod
    def from_config(cls, config: DetectConfig) -> FrozenJoints:
        return cls(config.frozen_seconds)

    def apply(self, ev: Evidence, flags: Flags) -> None:
        flags.flag(self.name, ev.frozen)

    def describe(self, ev: Evidence, frame: int, joint: int) -> str:
        run = run_around(ev.frozen[:, joint], frame)
        if run is None:
            return f"not in a frozen run of {self.min_seconds:.2f} s or more"
        a, b = run
        return (
            f"held still frames {a}-{b} ({(b - a + 1) / ev.fps:.2f} s) while its KNN words "
            f"move {deg(ev.digression[a : b + 1, joint].max())} away"
        )
