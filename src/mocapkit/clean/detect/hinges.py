"""A knee or elbow bent the wrong way."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mocapkit.clean.detect._runs import deg
from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags
from mocapkit.core.runs import true_runs


@dataclass(frozen=True)
class WrongWayHinges:
    """Flag the frames where a straight-at-rest knee or elbow bends more than ``min_deg`` past
    straight the wrong way (flexion about the joint's main rotation axis, signed so that the
    joint spends most of its time on the positive side), or swings its limb out of its bending
    plane by more than ``hinge_plane_deg`` (:attr:`Evidence.off_plane`, on a rig whose hinge
    keeps to its plane over the take), whatever the MDM, and the frames from such a run back to
    a jump far above the joint's own (:attr:`Evidence.big_jumps`) at most ``reach_seconds``
    before it, and on to one at most that long after it.

    The axis is fitted on the hinge's bend alone (the swing of the limb below; its twist about
    that limb is left out: a forearm twisted in a wave is no flexion), on the take's own frames,
    with the context's takes where the hinge barely bends over the take
    (:attr:`Evidence.hinge_flexion`).

    Relies on: anatomy; a hinge cannot bend backwards, whatever the context holds (and several wrong
    bends on one joint would match each other in the KNN search), and it bends about one axis across
    its limb, never about the limb itself nor out of the plane that axis sets. A forearm that
    carries its twist and is mirrored about its full rotation's main axis may keep a right-way
    flexion and leave the plane instead (Bandai-1 tuning half, gestures: an elbow 31 deg out of its
    plane at flexion +14, where clean takes stay within 2.3 deg). A limb reaches a wrong-way bend
    through the frames between, turning at its own speed: where it jumps instead, a few frames
    before the run, the error entered there, and the frames between are the error's while they read
    less than ``min_deg`` past straight (an elbow bent 105 deg mirrored to 2 deg at the jump, then
    past -15 deg four frames on; Bandai-1 tuning half, gestures, bends)."""
    name: ClassVar[str] = "wrong-way-hinge"
    veto: ClassVar[bool] = False
    signal: ClassVar[bool] = True
    min_deg: float = 15.0
    reach_seconds: float = 2.0 / 15.0

    @classmethod
    def from_config(cls, config: DetectConfig) -> WrongWayHinges:
        return cls(config.hinge_deg, config.hinge_reach_seconds)

    def cells(self, ev: Evidence):
        bent = ev.wrong_way | ev.off_plane
        if self.reach_seconds <= 0:
            return bent
        return reach_jumps(bent, ev.big_jumps, ev.frames(self.reach_seconds))

    def apply(self, ev: Evidence, flags: Flags) -> None:
        flags.flag(self.name, self.cells(ev))

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        f = ev.hinge_flexion[frame, joint]
        if not np.isfinite(f):
            return "not a straight-at-rest knee or elbow"
        if -f > np.radians(ev.config.hinge_max_deg):
            return (
                f"limb folded back {deg(-f)}, past any knee's or elbow's reach (over "
                f"{ev.config.hinge_max_deg:g} deg)"
            )
        c = ev.config
        off = ev.hinge_off_plane[frame, joint]
        if not np.isfinite(off) or c.hinge_plane_deg <= 0:
            plane = ""
        elif not ev.planar_hinges[joint]:
            plane = (
                f"; {deg(off)} out of its bending plane (not judged: the rig bends this joint "
                f"in planes tilted over {c.hinge_planar_deg:g} deg from it on half the take's "
                "bent frames)"
            )
        else:
            plane = f"; {deg(off)} out of its bending plane (flagged over {c.hinge_plane_deg:g})"
        if ev.off_plane[frame, joint] and not ev.wrong_way[frame, joint]:
            return f"bent {deg(off)} out of its plane, as no hinge bends; flexion {deg(f)}"
        if (
            not ev.wrong_way[frame, joint]
            and not ev.off_plane[frame, joint]
            and self.cells(ev)[frame, joint]
        ):
            return (
                f"flexion {deg(f)}{plane}, between a wrong-way or out-of-plane bend and a jump far "
                f"above the joint's own within {self.reach_seconds:.2g} s of it"
            )
        return f"flexion {deg(f)} (wrong way below -{self.min_deg:g} deg){plane}"


def reach_jumps(runs: np.ndarray, jumps: np.ndarray, width: int) -> np.ndarray:
    """(F, J) bool: ``runs`` with each run (per joint) stretched back to the latest of
    ``jumps`` (F, J) bool at most ``width`` frames before its first frame, and on to the frame
    before the earliest at most ``width + 1`` frames after its last (a jump into frame f is a
    step between frames f-1 and f). A jump that leaves the run before (the frame after its
    last) or enters the run after (its first frame) is not reached for."""
    out = np.array(runs, dtype=bool, copy=True)
    F = out.shape[0]
    for j in np.flatnonzero(out.any(axis=0)):
        spans = true_runs(runs[:, j])
        for k, (a, b) in enumerate(spans):
            lo = max(0, a - width, spans[k - 1][1] + 2 if k else 0)
            before = np.flatnonzero(jumps[lo:a, j])
            if len(before):
                out[lo + before[-1] : a, j] = True
            hi = min(F, b + 2 + width, spans[k + 1][0] if k + 1 < len(spans) else F)
            after = np.flatnonzero(jumps[b + 1 : hi, j])
            if len(after):
                out[b + 1 : b + 1 + after[0], j] = True
    return out
