"""A joint that holds one rotation exactly while its neighbours move on."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mocapkit.clean.detect._runs import deg, run_around
from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags
from mocapkit.clean.mdm import held_from


@dataclass(frozen=True)
class FrozenJoints:
    """Flag runs of at least ``frozen_seconds`` where the joint holds its rotation (slower than
    ``frozen_speed_deg_s``) while the KNN words move away, at a value it does not rest at
    elsewhere (:func:`~mocapkit.clean.mdm.frozen_cells`).

    Relies on: a live joint trembles; a dropped marker makes the solver repeat a stored value
    exactly, while a joint parked at its limit (straight elbow, flat toes) comes back to rest
    at the same value again and again (exactly, if the hold is exact: a clamp; a natural rest
    near a held value never repeats it bit for bit). A joint held through the whole take is
    one the take does not animate, not a dropout (a standing person's toe judged against
    context takes that walk: newcomer)."""

    name: ClassVar[str] = "frozen"
    veto: ClassVar[bool] = False
    signal: ClassVar[bool] = False
    min_seconds: float = 1.0 / 3.0

    @classmethod
    def from_config(cls, config: DetectConfig) -> FrozenJoints:
        return cls(config.frozen_seconds)

    def apply(self, ev: Evidence, flags: Flags) -> None:
        flags.flag(self.name, ev.frozen)

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        q = ev.rotations[:, joint]

        def held(a: int, b: int) -> str:
            # a value repeated bit for bit is the solver holding it without data
            exact = np.all(q[a : b + 1] == q[a])
            how = "held bit for bit (one value repeated)" if exact else "held still"
            return f"{how} frames {a}:{b + 1} ({(b - a + 1) / ev.fps:.2f} s)"

        run = run_around(ev.frozen[:, joint], frame)
        if run is not None:
            a, b = run
            return (
                f"{held(a, b)} while its KNN words move "
                f"{deg(ev.digression[a : b + 1, joint].max())} away"
            )
        c = ev.config
        verdict, a, b, value = ev.frozen_why(joint, frame)
        if verdict == "frozen":  # the run's first frame: the value the hold repeats
            return (
                f"{held(held_from(a), b)} after it: this frame is the last value captured "
                "before the hold, genuine"
            )
        exact = bool(ev.exact_tells[joint] and np.all(q[a : b + 1] == q[a]))
        rests = (
            f"at a value it parks at exactly elsewhere ({int(value)} frames): clamped there"
            if exact
            else f"at a value it rests at elsewhere ({int(value)} frames within "
            f"{c.frozen_tol_deg:g} deg): parked there"
        )
        return {
            "moving": f"moving here (held means turning under {c.frozen_speed_deg_s:g} deg/s)",
            "short": f"{held(a, b)}: shorter than {self.min_seconds:.2f} s",
            "calm": f"{held(a, b)}, but its KNN words stay within {deg(value)} of it (they "
            f"hold too; frozen needs {c.frozen_min_digression_deg:g} deg)",
            "rests": f"{held(a, b)} {rests}, not frozen",
            "parked": f"{held(a, b)} straight while the limb above it is not held: a knee or "
            "elbow parked at its limit, not frozen",
            "whole": f"{held(a, b)}: the whole take, a joint this take does not animate, not "
            "frozen",
            "frozen": held(a, b),
        }[verdict]
