"""Veto: a flagged run with no step near it is natural motion the context lacks."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mocapkit.clean import mdm as mdm_mod
from mocapkit.clean.detect._runs import deg
from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags
from mocapkit.core.runs import true_runs


def unowned_runs(
    mask: np.ndarray,
    steps: np.ndarray,
    keep: np.ndarray,
    min_step: float,
    pad: int,
    trim: bool = False,
    z: np.ndarray | None = None,
    width: int = 3,
    snaps: np.ndarray | None = None,
) -> np.ndarray:
    """(F, J) bool: the runs of ``mask & ~keep`` (per joint) that own no step of at least
    ``min_step`` radians. Each such step within ``pad`` frames of a run belongs to the runs
    nearest to it (0 frames: inside), the runs of ``keep`` (frozen cells) competing too; a step
    between two runs vouches for the nearer only (ties for both). A run of ``keep`` owns the
    two steps after it (the snap out of a hold into the next frame, and the step size's
    half-size echo of it a frame on) alone: the MDM of the words overlapping a dropout runs
    on past it, and the snap vouched for that spillover (Bandai-1 tuning half, seeds 0-6:
    gestures' frozen precision 0.975 -> 1.000 local, dance/fight 0.989 -> 0.994 small; a run
    of ``keep`` owning only the snap left the echo to the spillover, 0.814 at seed 3;
    validation half, seeds 0-2: dance/fight frozen precision 0.963 -> 0.966).

    With ``trim``, also the cells of a run more than ``pad`` frames before its first owned step
    or after its last (unless the run comes within ``pad`` frames of the take's first or last
    frame on that side and its step nearest that side does not enter, or leave, the error there:
    an error cut off by the take's start or end has no step there, but a run whose last step
    leaves the error holds natural motion after it however far the run goes; Bandai-1 tuning
    half, gestures, flips with local context: precision 0.917 before, 0.982 after, nothing else
    changed on either half). A run owning one step is cut on one side only, the side away from
    the error: the error lies where the normalised digression ``z`` is higher over the ``width``
    frames after the step than before it, or before (:func:`mdm.step_sides`); without ``z`` such
    a run is kept whole. ``snaps`` ((F, J) bool, optional): a judged run whose last cell is one
    of these (a stretch the cancelling-jumps rule found turned, left by one jump) owns the two
    steps after it alone, as a hold does: the digression the error leaves runs on past its exit
    jump, and that jump vouched for the spill (CMU 03_02, a knee flipped for 6 frames: the 40
    frames of natural swing after it, MDM 1.0, owned the exit's echo, read it as an entry and
    went to the median)."""
    mask = np.asarray(mask, dtype=bool)
    keep = np.asarray(keep, dtype=bool) & mask
    out = np.zeros_like(mask)
    for j in np.flatnonzero(mask.any(axis=0)):
        judged = true_runs(mask[:, j] & ~keep[:, j])
        if not judged:
            continue
        spans = np.array(judged + true_runs(keep[:, j]), dtype=np.int64).reshape(-1, 2)
        first = np.full(len(spans), np.iinfo(np.int64).max)
        last = np.full(len(spans), -1)
        count = np.zeros(len(spans), dtype=np.int64)
        held = np.arange(len(spans)) >= len(judged)
        if snaps is not None:  # turned stretches own their exit jump as a hold does
            held[: len(judged)] = [bool(snaps[b, j]) for _, b in judged]
        for p in np.flatnonzero(steps[:, j] >= min_step):
            # a hold ends with a snap into the frame after it and that step's half-size
            # echo a frame later: both are the hold's own, however near a run beyond it lies
            exits = held & (spans[:, 1] < p) & (p <= spans[:, 1] + 2)
            d = np.maximum(np.maximum(spans[:, 0] - p, p - spans[:, 1]), 0)
            near = 0 if exits.any() else d.min()
            if near <= pad:
                own = exits if exits.any() else d == near
                first[own] = np.minimum(first[own], p)
                last[own] = np.maximum(last[own], p)
                count[own] += 1
        for i, (a, b) in enumerate(judged):
            if last[i] < 0:
                out[a : b + 1, j] = True
            elif trim:
                lo, hi = a > pad, b < len(mask) - 1 - pad
                if count[i] == 1:
                    # one step: the error lies on its digressing side, the run beyond the
                    # step on the other side is not vouched for
                    if z is None:
                        continue
                    if _enters(z[:, j], int(first[i]), width):
                        hi = False
                    else:
                        lo = False
                elif z is not None:
                    # an error cut off by the take's start or end has no step there; but a
                    # run whose first step enters the error (or whose last leaves it) holds
                    # the error between its steps, whatever lies beyond them
                    lo = lo or _enters(z[:, j], int(first[i]), width)
                    hi = hi or not _enters(z[:, j], int(last[i]), width)
                if lo:
                    out[a : max(first[i] - pad, a), j] = True
                if hi:
                    out[min(last[i] + pad, b) + 1 : b + 1, j] = True
    return out


def _enters(z: np.ndarray, p: int, width: int) -> bool:
    """Whether the step at frame ``p`` enters an error: the normalised digression ``z`` (one
    joint's) is higher over the ``width`` frames from ``p`` on than over those before it."""
    after = z[p : p + width].mean()
    before = z[max(0, p - width) : p].mean() if p > 0 else -np.inf
    return bool(after >= before)


@dataclass(frozen=True)
class SmoothVeto:
    """Clear a flagged run (frozen runs aside) that owns no step of ``min_deg`` or more: with
    ``nearest``, a step within ``pad_seconds`` belongs to the flagged run nearest to it
    (:func:`unowned_runs`); without, any step within ``pad_seconds`` keeps a run
    (:func:`~mocapkit.clean.mdm.smooth_runs`).

    Relies on: capture errors (pops, flips, offsets, noise, wrong bends) enter or leave with a
    frame-to-frame step far from the steps around it; a digression reached smoothly is motion
    the context does not hold (a dancer's head whip), not an error. A step vouches for one
    run: the edge of an error beside such motion (a unique gesture of a short take, whose words
    the take alone cannot match) must not keep that motion flagged."""

    name: ClassVar[str] = "smooth"
    veto: ClassVar[bool] = True
    signal: ClassVar[bool] = False
    spares: ClassVar[tuple[str, ...]] = ("frozen",)
    """Rules whose cells this veto never clears (a held joint enters its hold smoothly)."""
    min_deg: float = 12.0
    pad_seconds: float = 0.05
    nearest: bool = True
    trim: bool = True

    @classmethod
    def from_config(cls, config: DetectConfig) -> SmoothVeto:
        return cls(
            config.abrupt_deg, config.abrupt_seconds, config.abrupt_nearest, config.abrupt_trim
        )

    def apply(self, ev: Evidence, flags: Flags) -> None:
        if self.min_deg <= 0:
            return
        keep = flags.cells_of(self.spares)
        pad = ev.frames(self.pad_seconds)
        if self.nearest:
            cells = unowned_runs(
                flags.mask,
                ev.steps,
                keep,
                np.radians(self.min_deg),
                pad,
                self.trim,
                ev.z,
                ev.frames(ev.config.step_side_seconds),
                flags.cells_of(("cancelling-jumps",)),
            )
        else:
            cells = mdm_mod.smooth_runs(flags.mask, ev.steps, keep, np.radians(self.min_deg), pad)
        flags.veto(self.name, cells)

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        pad = ev.frames(self.pad_seconds)
        s = ev.steps[max(frame - pad, 0) : frame + pad + 1, joint].max()
        out = (
            f"largest step (change of the turn per frame) within {self.pad_seconds:g} s: "
            f"{deg(s)} (a flagged run with no step of {self.min_deg:g} deg or more near it is "
            "cleared as natural motion)"
        )
        if self.nearest:
            out += "; a step keeps only the flagged run nearest to it"
            if self.trim:
                out += f", and that run only up to {self.pad_seconds:g} s past its steps"
        return out
