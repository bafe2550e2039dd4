"""Veto: a flagged run off a joint limit, abrupt only where the clamp lets go or catches it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags
from mocapkit.core import rotations as rot
from mocapkit.core.runs import true_runs


@dataclass(frozen=True)
class LimitReleaseVeto:
    """Clear a flagged run that moves (by more than ``move_deg``) within one excursion of its
    joint off a limit (a rotation the joint rests at in ``holds`` still runs or more,
    :func:`~mocapkit.clean.mdm.limit_values`), when no jump (``Evidence.jump_peaks``) lies
    between the run and one end of the excursion but within ``edge_seconds`` of that end: the
    run is reached from the limit's release, or reaches its catch, by motion alone.

    Relies on: a solver that clamps a joint at a limit (toes flat) lets go of it in one step
    when the markers pull the joint off and catches it the same way on its return, so the
    measured motion between is abrupt at those two ends, by the clamp, not by an error; a
    capture error is not tied to the limit: its own jumps fall wherever it starts and stops,
    an error on the parked frames holds its turned value (it does not move), and an error
    turned by one rotation enters and leaves with jumps that cancel (its cancelling-jumps run
    is spared: an offset on a toe parked at its limit, whose own small moves inside the window
    exceed ``move_deg``, was cleared on the Bandai-1 validation half without it)."""

    name: ClassVar[str] = "limit-release"
    veto: ClassVar[bool] = True
    signal: ClassVar[bool] = False
    spares: ClassVar[tuple[str, ...]] = ("cancelling-jumps",)
    """Rules whose runs this veto never clears: two jumps that cancel turned the stretch
    between them by one rotation, which a clamp letting go does not (it leaves the limit for
    motion and comes back from elsewhere)."""
    holds: int = 3
    move_deg: float = 3.0
    edge_seconds: float = 1.0 / 30.0

    @classmethod
    def from_config(cls, config: DetectConfig) -> LimitReleaseVeto:
        return cls(config.limit_holds, config.limit_move_deg, config.limit_edge_seconds)

    def _released(self, ev: Evidence, j: int, a: int, b: int) -> tuple[int, int] | None:
        """The excursion of joint ``j`` whose release (or catch) the run ``a .. b`` belongs
        to, or None."""
        q = ev.rotations[a : b + 1, j]
        span = max(rot.quat_angle(q, q[:1]).max(), rot.quat_angle(q, q[-1:]).max())
        if span <= np.radians(self.move_deg):
            return None
        edge = ev.frames(self.edge_seconds, 0)
        for s, e in ev.limit_excursions[j]:
            if not (s - edge <= a and b <= e + edge):
                continue
            # the jumps that are not the clamp's own (within ``edge`` of the excursion's ends)
            peaks = np.flatnonzero(ev.jump_peaks[:, j])
            foreign = peaks[(np.abs(peaks - s) > edge) & (np.abs(peaks - (e + 1)) > edge)]
            # a run's own jumps are at a and b + 1: none foreign between the run and one end
            from_release = not np.any((foreign >= s) & (foreign <= b + 1))
            to_catch = not np.any((foreign >= a) & (foreign <= e + 1))
            return (s, e) if from_release or to_catch else None
        return None

    def apply(self, ev: Evidence, flags: Flags) -> None:
        if self.holds <= 0:
            return
        keep = np.zeros(flags.mask.shape, dtype=bool)
        for rule in self.spares:
            keep |= flags.added.get(rule, keep)
        out = np.zeros(ev.shape, dtype=bool)
        for j, spans in enumerate(ev.limit_excursions):
            if spans:
                for a, b in true_runs(flags.mask[:, j]):
                    if keep[a : b + 1, j].any():
                        continue
                    if self._released(ev, j, a, b) is not None:
                        out[a : b + 1, j] = True
        flags.veto(self.name, out)

    def describe(self, ev: Evidence, frame: int, joint: int) -> str:
        edge = ev.frames(self.edge_seconds, 0)
        for s, e in ev.limit_excursions[joint]:
            if s - edge <= frame <= e + edge:
                peaks = np.flatnonzero(ev.jump_peaks[s : e + 2, joint]) + s
                inside = [int(p) for p in peaks if min(abs(p - s), abs(p - e - 1)) > edge]
                jumps = (
                    f"jumps of its own inside at frames {', '.join(map(str, inside))}"
                    if inside
                    else "no jump inside but where the clamp lets go and catches"
                )
                return f"in an excursion {s}:{e + 1} off a limit the joint is clamped at; {jumps}"
        return "not in an excursion off a limit the joint is clamped at"
