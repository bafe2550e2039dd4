"""Veto: a short run whose excursion the joint repeats elsewhere is the performer's motif."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mocapkit.clean import mdm as mdm_mod
from mocapkit.clean.detect._runs import deg, run_around
from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags


@dataclass(frozen=True)
class RecurringVeto:
    """Clear a flagged run of at most ``max_seconds`` whose excursion (entry, peak and exit
    poses of the joint) recurs elsewhere in the take or a same-rate context take within
    ``max_deg`` and within ``ratio`` times the run's digression
    (:func:`~mocapkit.clean.mdm.recurring_runs`).

    Relies on: capture errors are random, so the same excursion does not happen twice; a
    motif of the performer (a toe pop at every push-off) does, closer than the KNN words came."""

    name: ClassVar[str] = "recurring"
    veto: ClassVar[bool] = True
    signal: ClassVar[bool] = False
    max_deg: float = 8.0
    ratio: float = 0.5
    max_seconds: float = 0.2
    flex_seconds: float = 1.0 / 30.0

    @classmethod
    def from_config(cls, config: DetectConfig) -> RecurringVeto:
        return cls(
            config.recur_deg, config.recur_ratio, config.recur_seconds, config.recur_flex_seconds
        )

    def apply(self, ev: Evidence, flags: Flags) -> None:
        if self.max_deg <= 0:
            return
        flags.veto(
            self.name,
            mdm_mod.recurring_runs(
                flags.mask,
                ev.rotations,
                ev.digression,
                ev.frames(self.max_seconds),
                np.radians(self.max_deg),
                self.ratio,
                ev.context_rotations,
                flex=ev.frames(self.flex_seconds),
            ),
        )

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        judged = None if flags is None else flags.judged.get(self.name)
        if judged is not None:  # the flagged run this veto looked at
            run = run_around(judged[:, joint], frame)
            if run is None:
                return "not in a run flagged before this veto: nothing to match"
        else:  # no decision at hand: the digressing run
            run = run_around(ev.mdm[:, joint] > 0.5, frame) if ev.mdm is not None else None
            if run is None:
                return "no digressing run here to match"
        a, b = run
        if b - a + 1 > ev.frames(self.max_seconds):
            return f"run {a}:{b + 1} longer than {self.max_seconds:g} s: not a motif"
        m = mdm_mod.excursion_match(
            ev.rotations[:, joint], a, b + 1, [o[:, joint] for o in ev.context_rotations],
            ev.frames(self.flex_seconds),
        )  # fmt: skip
        return f"closest repeat of run {a}:{b + 1}: {deg(m) if np.isfinite(m) else 'none'}"
