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
    """Flag stretches of at most ``spike_seconds`` (set in the evidence) lying off the cubic
    through the two frames either side by more than the joint's bar at every frame
    (:func:`~mocapkit.clean.mdm.spike_size`), unless within ``pad_seconds`` of a run already
    flagged (its wrong frames spoil the cubic). The bar is ``jump_ratio`` times the joint's
    ordinary jump in the take (:attr:`Evidence.jump_scale`), kept between ``floor_deg`` and
    ``max_deg``; and the stretch must lie off by ``jump_share`` of the largest jump within
    ``spike_seconds`` and the cubic's two anchor frames of it or more (a constant turn's frames
    lie off by the whole jump into them, the frames beside the jump into a longer error by
    about half of it). A take's first and last frames, which have no two frames on their far
    side, are judged off the joint's constant turn through the frames beside them
    (:func:`~mocapkit.clean.mdm.end_spike_size`).

    Relies on: a joint's rotation is smooth at the capture rate; it does not leave its own path
    by 40 deg and come back within a fifteenth of a second, whatever the context holds (a
    punch's impact wobble is 12-15 deg; over longer stretches an impact does leave the cubic
    through the frames around it, so a spike is short). A joint leaves its path by about as much
    as its steps change from one frame to the next: one whose steps barely change (an elbow in
    a bow) does not leave it by 20 deg for a frame or two, while one that whips (a waving
    hand, a dash's toe) may, and its own jumps raise its bar."""

    name: ClassVar[str] = "spike"
    veto: ClassVar[bool] = False
    signal: ClassVar[bool] = False
    max_deg: float = 40.0
    pad_seconds: float = 0.2
    jump_ratio: float = 2.5
    floor_deg: float = 20.0
    jump_share: float = 0.75

    @classmethod
    def from_config(cls, config: DetectConfig) -> Spikes:
        return cls(
            config.spike_deg,
            config.spike_pad_seconds,
            config.spike_jump_ratio,
            config.spike_floor_deg,
            config.spike_jump_share,
        )

    def bar(self, ev: Evidence) -> np.ndarray:
        """(J,) radians: how far off its path a joint must be to spike."""
        lo, hi = np.radians(min(self.floor_deg, self.max_deg)), np.radians(self.max_deg)
        return np.clip(self.jump_ratio * ev.jump_scale, lo, hi)

    def whole(self, ev: Evidence) -> np.ndarray:
        """(F, J) bool: off the path by ``jump_share`` of the largest jump within
        ``spike_seconds`` (and the two frames the cubic is fitted through) or more: a constant
        turn's own frames, not those beside the jump into a longer error or a big spike."""
        # the cubic of a gap is fitted through two frames either side of it: a gap up to two
        # frames away from a jump still sees it
        reach = ev.frames(ev.config.spike_seconds) + 2
        jumps = ndimage.maximum_filter1d(ev.jump_size, 2 * reach + 1, axis=0, mode="nearest")
        return ev.spike_size >= self.jump_share * jumps

    def apply(self, ev: Evidence, flags: Flags) -> None:
        pad = ev.frames(self.pad_seconds)
        near = ndimage.binary_dilation(flags.mask, structure=np.ones((2 * pad + 1, 1), dtype=bool))
        flags.flag(self.name, (ev.spike_size > self.bar(ev)) & self.whole(ev) & ~near)

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        size = ev.spike_size[frame, joint]
        bar = self.bar(ev)[joint]
        text = (
            f"off its smooth path by {deg(size)}; this joint's bar {deg(bar)} "
            f"({self.jump_ratio:g} times its ordinary jump of {deg(ev.jump_scale[joint])}, kept "
            f"between {self.floor_deg:g} and {self.max_deg:g} deg)"
        )
        if size > bar and not self.whole(ev)[frame, joint]:
            text += (
                f", but under {self.jump_share:g} of a jump near it: beside the jump into a "
                "longer stretch, not a spike"
            )
        elif size > bar and flags is not None and not _holds(flags, self.name, frame, joint):
            text += (
                f", but within {self.pad_seconds:g} s of a run another rule flagged first: its "
                "wrong frames spoil the path through them, so the run is left to that rule"
            )
        return text


def _holds(flags: Flags, rule: str, frame: int, joint: int) -> bool:
    cells = flags.added.get(rule)
    return cells is not None and bool(cells[frame, joint])
