"""A burst of frame-to-frame jitter on one joint."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from mocapkit.clean import mdm as mdm_mod
from mocapkit.clean.detect._runs import deg, run_around
from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags


@dataclass(frozen=True)
class NoiseBursts:
    """Flag runs of at least ``min_seconds`` whose roughness (second difference of the angular
    velocity, :func:`~mocapkit.clean.mdm.burst_roughness`) exceeds ``min_deg``, and
    ``ratio`` times the joint's median roughness in the take, at nearly every frame, each
    going on over the frames beside it above half that level (``noise_hold_ratio``:
    :func:`~mocapkit.clean.mdm.noise_bursts`), whatever the MDM.

    Relies on: smooth motion keeps the roughness small (it grows with the cube of the
    frequency); marker noise is white, about 4.5 times its size per axis, and comes in bursts,
    while a joint that moves fast for the whole take (a hand waved at 30 fps) is rough all the
    time. The KNN words of a weakly jittered fast joint may follow the jitter, so the MDM alone
    misses it. Noise is random: on a few frames of a burst it deviates little, which dips the
    roughness inside the burst without ending it; and it turns the joint every which way,
    while a fast wave or shake as rough turns it back and forth about one axis (a burst whose
    jerk lies along one axis for more than ``axis_share`` of it, :func:`~mocapkit.clean.mdm.
    axis_share`, is left: Bandai-1 tuning half, its clean takes' noise flags were all such
    waves, 0.89-0.995, and its injected noise bursts 0.87 at most, 0.82 at the 99th
    percentile, over 132)."""

    name: ClassVar[str] = "noise"
    veto: ClassVar[bool] = False
    signal: ClassVar[bool] = True
    min_deg: float = 20.0
    min_seconds: float = 0.2
    ratio: float = 4.0
    axis_share: float = 0.88

    @classmethod
    def from_config(cls, config: DetectConfig) -> NoiseBursts:
        return cls(
            config.noise_deg, config.noise_seconds, config.noise_ratio, config.noise_axis_share
        )

    def cells(self, ev: Evidence):
        return ev.noise_bursts

    def apply(self, ev: Evidence, flags: Flags) -> None:
        flags.flag(self.name, ev.noise_bursts)

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        # a run counts from one frame more than noise_seconds rounds to (mdm.noise_bursts:
        # b - a >= frames), as the evidence counts it
        frames = ev.frames(ev.config.noise_seconds, 2) + 1
        need = (
            f"above {deg(ev.noise_level[joint])} (the larger of {self.min_deg:g} deg and "
            f"{self.ratio:g} x the joint's median) for {frames} frames or more "
            f"({frames / ev.fps:.2f} s)"
        )
        run = run_around(ev.noise_bursts[:, joint], frame)
        rough = run_around(ev.rough_runs[:, joint], frame)
        if run is None and rough is not None:
            share = mdm_mod.axis_share(ev.rotations[:, joint], rough[0], rough[1])
            return (
                f"rough on frames {rough[0]}:{rough[1] + 1} ({need}), but {share:.2f} of its "
                f"jerk lies along one axis (noise: at most {self.axis_share:g}): a fast wave "
                "or shake, not noise"
            )
        if run is None:
            # a second difference of the angular velocity: it may exceed 180 deg
            r = deg(ev.roughness[frame, joint])
            here = f"roughness (change of its turn's change per frame) {r} here"
            # a burst's roughness spreads to the two frames before it and the one after it
            F = ev.noise_bursts.shape[0]
            for f in (frame + 1, frame + 2, frame - 1):
                edge = run_around(ev.noise_bursts[:, joint], f) if 0 <= f < F else None
                if edge is not None and (edge[0] > frame or edge[1] < frame):
                    return (
                        f"{here}, beside the burst on frames {edge[0]}:{edge[1] + 1}: a burst's "
                        "roughness spreads to the two frames before it and the one after, whose "
                        "own rotations are not noisy, so the flags end where the noisy frames do"
                    )
            above = run_around(ev.roughness[:, joint] > ev.noise_level[joint], frame)
            if above is None:
                return f"{here}, not a burst: a burst is {need}"
            secs = (above[1] - above[0] + 1) / ev.fps
            return (
                f"{here}, above the level on frames {above[0]}:{above[1] + 1} only ({secs:.2f} s): "
                f"not a burst (a burst is {need}; a single pop is left to the other rules)"
            )
        a, b = run
        # the burst's roughness spans its frames and two before and one after it
        peak = ev.roughness[max(a - 2, 0) : b + 2, joint].max()
        return f"in a burst on frames {a}:{b + 1}: roughness up to {deg(peak)} around it, {need}"
