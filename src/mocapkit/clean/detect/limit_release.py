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

    Any joint with such a limit is judged (toes flat, and knees or elbows parked straight:
    on dance-short the lower legs and arms have limits too, and no run of theirs was cleared).

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
    spares: ClassVar[tuple[str, ...]] = ("cancelling-jumps", "frozen")
    """Rules whose runs this veto never clears: two jumps that cancel turned the stretch
    between them by one rotation, which a clamp letting go does not (it leaves the limit for
    motion and comes back from elsewhere); a frozen run is a hold, not motion (a dropout
    that starts off the limit ends with a jump back to it, like a catch)."""
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
        moved = max(rot.quat_angle(q, q[:1]).max(), rot.quat_angle(q, q[-1:]).max())
        if moved <= np.radians(self.move_deg):
            return None
        span = self._excursion(ev, j, a, b)
        if span is None:
            return None
        from_release, to_catch = self._clear_sides(ev, j, a, b, *span)
        return span if from_release or to_catch else None

    def _excursion(self, ev: Evidence, j: int, a: int, b: int) -> tuple[int, int] | None:
        edge = ev.frames(self.edge_seconds, 0)
        for s, e in ev.limit_excursions[j]:
            if s - edge <= a and b <= e + edge:
                return s, e
        return None

    def _foreign(self, ev: Evidence, j: int, s: int, e: int) -> np.ndarray:
        """The jumps of joint ``j`` that are not the clamp's own (further than
        ``edge_seconds`` from the excursion's release at ``s`` and catch at ``e + 1``)."""
        edge = ev.frames(self.edge_seconds, 0)
        peaks = np.flatnonzero(ev.jump_peaks[:, j])
        return peaks[(np.abs(peaks - s) > edge) & (np.abs(peaks - (e + 1)) > edge)]

    def _clear_sides(
        self, ev: Evidence, j: int, a: int, b: int, s: int, e: int
    ) -> tuple[bool, bool]:
        """Whether no foreign jump lies between the run ``a .. b`` (its own jumps at ``a`` and
        ``b + 1`` included) and the release, and between it and the catch."""
        foreign = self._foreign(ev, j, s, e)
        from_release = not np.any((foreign >= s) & (foreign <= b + 1))
        to_catch = not np.any((foreign >= a) & (foreign <= e + 1))
        return from_release, to_catch

    def apply(self, ev: Evidence, flags: Flags) -> None:
        if self.holds <= 0:
            return
        keep = flags.cells_of(self.spares)
        out = np.zeros(ev.shape, dtype=bool)
        for j, spans in enumerate(ev.limit_excursions):
            if spans:
                for a, b in true_runs(flags.mask[:, j]):
                    if keep[a : b + 1, j].any():
                        continue
                    if self._released(ev, j, a, b) is not None:
                        out[a : b + 1, j] = True
        flags.veto(self.name, out)

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        span = self._excursion(ev, joint, frame, frame)
        if span is None:
            return "not in an excursion off a limit the joint is clamped at"
        s, e = span
        foreign = self._foreign(ev, joint, s, e)
        release, catch = self._clear_sides(ev, joint, frame, frame, s, e)
        other = (
            "jumps not the clamp's at frames " + ", ".join(map(str, foreign[foreign <= e + 1]))
            if np.any((foreign >= s) & (foreign <= e + 1))
            else "no jump but the clamp's"
        )
        if release:
            reach = "reached from the release by motion alone"
        elif catch:
            reach = "reaching the catch by motion alone"
        else:
            reach = "neither reached from the release nor reaching the catch by motion alone"
        return (
            f"in an excursion {s}:{e + 1} off a limit the joint is clamped at (release at {s}, "
            f"catch at {e + 1}); {other}; a run here is {reach} (the veto also needs the run "
            f"to move over {self.move_deg:g} deg and to hold no {' or '.join(self.spares)} cell)"
        )
