"""Two jumps on one joint that cancel: the stretch between them was turned by one rotation."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mocapkit.clean import mdm as mdm_mod
from mocapkit.clean.detect._runs import deg, run_around
from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags
from mocapkit.core.runs import true_runs


@dataclass(frozen=True)
class CancellingJumps:
    """Flag the frames between two jumps of a joint (steps differing from both neighbours,
    :func:`~mocapkit.clean.mdm.jump_size`, far above the joint's own) at most ``max_seconds`` apart
    whose step deviations cancel, whatever their MDM.

    Relies on: a spike, an offset or a flip turns a stretch by one constant rotation, entered and
    left with opposite jumps; natural motion that jumps seldom jumps back by the same rotation
    (:func:`~mocapkit.clean.mdm.cancelling_steps`). A wrong-way bend turns its stretch about one
    axis by an angle that follows the joint's own flexion, so its two jumps point opposite ways
    but differ in size: two jumps that both exceed ``DetectConfig.pair_axis_ratio`` times the
    joint's ordinary one and point opposite ways (``pair_axis_cos``; an entry and the next jump,
    an exit, may be read as a turn that passed 180 deg between them,
    :func:`~mocapkit.clean.mdm._opposed`) pair too; on the Bandai-1
    tuning half's clean takes, whole, the largest such natural pair is 3.1 times it. A jump
    leaving an error is not paired with a later one entering another (the frames between are
    clean), where the digression tells the two sides of each jump apart and an entry before and
    an exit after them (or the take's ends) flank
    the two: a lone error whose sides were misread pairs. An error cut off by the take's end (or
    start) has one jump: unpaired, entering (leaving) an error at most ``max_seconds`` from that end
    with no jump leaving (entering) one beyond it, it flags to the end where most of those frames
    have MDM above the threshold (``DetectConfig.pair_cut_off``) or where its jump exceeds
    ``cut_jump_ratio`` times the joint's ordinary jump (:attr:`Evidence.jump_scale`) and no other
    within ``max_seconds`` does: a joint's natural jumps near a take's end (a foot strike) are of
    its usual size, while an error's jump is far above it even where its frames do not digress. (A
    jump is a candidate only where the digression reads its side: near the take's start, where a tie
    reads as an entry, a cut-off error's frames must digress somewhat.) A jump of a joint still
    before and after it counts however small it is against the joint's ordinary jumps
    (:attr:`Evidence.still_jumps`): a toe at rest seldom turns 17 deg in a frame and stops. Jumps
    are not measured on a take's first and last two frames, so an error entered at frame 1 looks cut
    off too: where the step out of frame 0 cancels the stretch's jump, frame 0 is left out (the same
    at the end). A jump that is one side of a one-frame pop (:attr:`Evidence.pops`, the frame beside
    it deviating the opposite way) pairs with nothing farther: a toe popping for one frame at each
    foot strike paired the exit of one pop with the entry of the next across the stance; a one-frame
    spike is the spike rule's."""

    name: ClassVar[str] = "cancelling-jumps"
    veto: ClassVar[bool] = False
    signal: ClassVar[bool] = False
    max_seconds: float = 1.5
    cut_off: bool = True
    threshold: float = 0.5
    cut_jump_ratio: float = 4.0
    tol: float = 0.45

    @classmethod
    def from_config(cls, config: DetectConfig) -> CancellingJumps:
        return cls(
            config.pair_seconds,
            config.pair_cut_off,
            config.threshold,
            config.pair_cut_jump_ratio,
            config.pair_tol,
        )

    def cells(self, ev: Evidence) -> np.ndarray:
        """(F, J) bool: the cancelling stretches, and with ``cut_off`` the stretches cut off
        by the take's end or start whose frames mostly have MDM above ``threshold`` or whose
        jump is ``cut_jump_ratio`` times the joint's ordinary one."""
        out = ev.cancelling.copy()
        if self.cut_off and ev.cut_off.any():
            for j in np.flatnonzero(ev.cut_off.any(axis=0)):
                for a, b in true_runs(ev.cut_off[:, j]):
                    if self._digresses(ev, a, b, j) or self._one_jump(ev, a, b, j):
                        a, b = self._without_clean_end(ev, a, b, j)
                        out[a : b + 1, j] = True
        return out

    def _without_clean_end(self, ev: Evidence, a: int, b: int, j: int) -> tuple[int, int]:
        """The cut-off stretch ``a..b`` less the take's first (last) frame where the step from
        it into the stretch (out of the stretch into it) cancels the stretch's own jump, as two
        jumps of a pair do: the error was entered at frame 1 (left at the next-to-last frame),
        where jumps are undefined, so the take's end frame is clean (a one-frame spike on frame
        1 flagged frame 0 too)."""
        F = ev.shape[0]
        if b - a < 1 or not (a == 0 or b == F - 1) or (a == 0 and b == F - 1) or F < 5:
            return a, b
        q = ev.rotations[:, j]
        # steps i -> i + 1: the outer one at the take's end, the inner one at the stretch's
        # jump, each less the joint's own turn beside it (a knee turning 10 deg a frame would
        # spoil the cancelling of a 30 deg pop's two steps): the step after the exit / before
        # the entry, or, for a stretch of two frames or more, its own first / last step
        if a == 0:
            outer, inner = 0, b
            own_outer, own_inner = (1 if b >= 2 else b + 1), min(b + 1, F - 2)
        else:
            outer, inner = F - 2, a - 1
            own_outer, own_inner = (F - 3 if a <= F - 3 else a - 2), max(a - 2, 0)
        for frame in ("body", "parent"):  # as the pairs are judged
            w = mdm_mod.frame_steps(q, frame)
            u, v = w[outer] - w[own_outer], w[inner] - w[own_inner]
            # a half turn's two steps may both come out the same way round (a flip's exit at
            # the next-to-last frame turned the last, clean frame by 180 deg): try the other
            for x in (u, mdm_mod._other_side(u)):
                if np.linalg.norm(x + v) < self.tol * min(np.linalg.norm(x), np.linalg.norm(v)):
                    return (1, b) if a == 0 else (a, F - 2)
        return a, b

    def _digresses(self, ev: Evidence, a: int, b: int, j: int) -> bool:
        """Most frames of ``a..b`` have MDM above ``threshold``."""
        return bool((ev.mdm[a : b + 1, j] > self.threshold).mean() > 0.5)

    def _one_jump(self, ev: Evidence, a: int, b: int, j: int) -> bool:
        """The stretch ``a..b`` cut off by the take's end (start) is entered (left) by a jump
        over ``cut_jump_ratio`` times the joint's ordinary jump, the only one within
        ``max_seconds`` of it: a spike near the end jumps back, the exit of an error just
        before (a wrong-way bend, whose jumps do not cancel) follows its entry."""
        if self.cut_jump_ratio <= 0:
            return False
        bar = self.cut_jump_ratio * ev.jump_scale[j]
        p = a if b == ev.shape[0] - 1 else b + 1
        span = round(self.max_seconds * ev.fps)
        near = ev.jump_size[max(0, p - span) : p + span + 1, j].copy()
        near[p - max(0, p - span)] = 0.0
        return bool(ev.jump_size[p, j] > bar and near.max() <= bar)

    def apply(self, ev: Evidence, flags: Flags) -> None:
        if self.max_seconds > 0:
            flags.flag(self.name, self.cells(ev))

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        pk = np.flatnonzero(ev.jump_peaks[:, joint])
        before = pk[pk <= frame]
        after = pk[pk > frame]
        # a jump is a change of the frame-to-frame turn (a difference of two rotation vectors,
        # so up to 360 deg), not a turn itself
        parts = [f"jump (change of its turn per frame) here {deg(ev.jump_size[frame, joint])}"]

        devs = [ev.body_deviations, ev.parent_deviations]

        def peak(p: int) -> str:
            g = (
                mdm_mod.pop_partner(devs, p, joint, ev.config.pop_tol)
                if ev.pops[p, joint]
                else None
            )
            pop = (
                ""
                if g is None
                else f", one side of a one-frame pop with frame {g}: pairs with no other"
            )
            c = ev.config
            still = (
                f", a step over {c.still_jump_ratio:g} times every step within "
                f"{c.still_jump_seconds:g} s before and after it"
                if ev.still_jumps[p, joint]
                else ""
            )
            return f"frame {p} ({deg(ev.jump_size[p, joint])}{still}{pop})"

        if len(before):
            parts.append(f"last jump peak {peak(before[-1])}")
        if len(after):
            parts.append(f"next jump peak {peak(after[0])}")
        # a pair's frames lie between two jumps, so a run reaching the take's first or last
        # frame is an error cut off there (jumps are undefined on the two frames at each end)
        run = run_around(self.cells(ev)[:, joint], frame)
        cand = run_around(ev.cut_off[:, joint], frame) if self.cut_off else None
        kept = cand is not None and (
            self._digresses(ev, *cand, joint) or self._one_jump(ev, *cand, joint)
        )
        if run is None and kept:
            parts.append(
                "the take's first or last frame, left out of the stretch cut off there: the step "
                "into it cancels the stretch's own jump, so it is clean"
            )
        elif run is None and cand is not None:
            a, b = cand
            start = a == 0
            jump = b + 1 if start else a
            share = float((ev.mdm[a : b + 1, joint] > self.threshold).mean())
            ratio = ev.jump_size[jump, joint] / max(ev.jump_scale[joint], 1e-12)
            span = round(self.max_seconds * ev.fps)
            lo = max(0, jump - span)
            near = ev.jump_size[lo : jump + span + 1, joint].copy()
            near[jump - lo] = 0.0
            if ratio <= self.cut_jump_ratio:
                big = (
                    f"its jump is {ratio:.1f} times the joint's ordinary one, not over "
                    f"{self.cut_jump_ratio:g}"
                )
            else:
                other = lo + int(np.argmax(near))
                big = (
                    f"its jump is {ratio:.1f} times the joint's ordinary one, but so is another "
                    f"within {self.max_seconds:g} s (frame {other}, {deg(near.max())}): "
                    "not a lone error's edge"
                )
            parts.append(
                f"not between two that cancel; the unpaired jump at frame {jump} may bound an "
                f"error cut off by the take's {'start' if start else 'end'} ({a}:{b + 1}), but "
                f"only {share:.0%} of those frames have MDM above {self.threshold:g} (over half "
                f"needed) and {big}"
            )
        elif run is None:
            parts.append("not between two that cancel")
        elif run[1] == ev.shape[0] - 1:
            parts.append(
                f"from the jump at frame {run[0]} to the take's last frame: an error cut off by "
                f"its end ({self._why_cut(ev, run, run[0], joint)})"
            )
        elif run[0] == 0:
            parts.append(
                f"from the take's first frame to the jump at frame {run[1] + 1}: an error cut "
                f"off by its start ({self._why_cut(ev, run, run[1] + 1, joint)})"
            )
        elif run[1] == ev.shape[0] - 2 and ev.cut_off[-1, joint]:
            parts.append(
                f"from the jump at frame {run[0]} to the next-to-last frame: an error left by the "
                "step into the take's last frame, where jumps are not measured; that step "
                f"cancels the jump at frame {run[0]}, so the last frame is clean "
                f"({self._why_cut(ev, run, run[0], joint)})"
            )
        elif run[0] == 1 and ev.cut_off[0, joint]:
            parts.append(
                f"from frame 1 to the jump at frame {run[1] + 1}: an error entered by the step "
                "out of the take's first frame, where jumps are not measured; that step cancels "
                f"the jump at frame {run[1] + 1}, so frame 0 is clean "
                f"({self._why_cut(ev, run, run[1] + 1, joint)})"
            )
        else:
            parts.append("between two that cancel (or turn there and back about one axis)")
        return "; ".join(parts)

    def _why_cut(self, ev: Evidence, run: tuple[int, int], jump: int, joint: int) -> str:
        if self._digresses(ev, run[0], run[1], joint):
            return f"most of those frames have MDM above {self.threshold:g}"
        scale = ev.jump_scale[joint]
        if scale < np.radians(1e-3):
            return (
                f"its jump of {deg(ev.jump_size[jump, joint])} on a joint that otherwise does "
                "not jump, the only one near it"
            )
        return (
            f"its jump is {ev.jump_size[jump, joint] / scale:.1f} times the joint's ordinary "
            f"one of {deg(scale)}, over {self.cut_jump_ratio:g}, the only one near it"
        )
