"""Veto: a take's first or last movement, performed once, digresses without being wrong."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mocapkit.clean.detect._runs import run_around
from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags
from mocapkit.core.runs import true_runs


@dataclass(frozen=True)
class OnceAtTheEnds:
    """Clear a flagged run (frozen and cancelling-jumps cells aside) that comes within
    ``end_seconds`` of the take's first frame, or of its last, when its other edge holds no
    jump peak (:attr:`Evidence.jump_peaks`: a step differing from both neighbours far more
    than the joint's own, or a still joint's jump) within ``pad_seconds``.

    Relies on: the self-similarity judges a movement by the like movements elsewhere in the
    take, and a take's first or last movement is often performed once (the arm raised into a
    wave, lowered after it), so it digresses however natural it is; there the one edge inside
    the take is a change of speed (the wave starting), not a jump. A capture error cut off by
    the take's start or end still jumps at its edge inside the take (an offset, a flip), and a
    held joint (frozen) or a noise burst is another rule's. Bandai-1 tuning half, its clean
    takes whole: byebye_happy_001's UpperArm_L (frames 0-36) and LowerArm_R (4-35) were
    flagged this way, and their repair turned the arms by up to 135 deg (newcomer)."""

    name: ClassVar[str] = "once-at-ends"
    veto: ClassVar[bool] = True
    signal: ClassVar[bool] = False
    spares: ClassVar[tuple[str, ...]] = ("frozen", "cancelling-jumps")
    """Rules whose cells this veto never clears."""
    end_seconds: float = 0.2
    pad_seconds: float = 0.1

    @classmethod
    def from_config(cls, config: DetectConfig) -> OnceAtTheEnds:
        return cls(config.once_end_seconds, config.once_pad_seconds)

    def _judge(self, ev: Evidence, a: int, b: int, j: int) -> tuple[str, int | None]:
        """Which end run ``a..b`` of joint ``j`` reaches ("start", "end", "" for neither or
        both) and the jump peak nearest its other edge within ``pad_seconds`` (None)."""
        F = ev.shape[0]
        near = ev.frames(self.end_seconds, 0)
        at_start, at_end = a <= near, b >= F - 1 - near
        if at_start == at_end:
            return "", None
        edge = b + 1 if at_start else a
        pad = ev.frames(self.pad_seconds)
        lo, hi = max(edge - pad, 0), min(edge + pad + 1, F)
        peaks = lo + np.flatnonzero(ev.jump_peaks[lo:hi, j])
        jump = int(peaks[np.argmin(np.abs(peaks - edge))]) if len(peaks) else None
        return ("start" if at_start else "end"), jump

    def cells(self, ev: Evidence, mask: np.ndarray) -> np.ndarray:
        """(F, J) bool: the runs of ``mask`` this veto clears."""
        out = np.zeros(mask.shape, dtype=bool)
        if self.end_seconds <= 0:
            return out
        for j in np.flatnonzero(mask.any(axis=0)):
            for a, b in true_runs(mask[:, j]):
                side, jump = self._judge(ev, a, b, j)
                if side and jump is None:
                    out[a : b + 1, j] = True
        return out

    def apply(self, ev: Evidence, flags: Flags) -> None:
        flags.veto(self.name, self.cells(ev, flags.mask & ~flags.cells_of(self.spares)))

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        judged = None if flags is None else flags.judged.get(self.name)
        if judged is None:
            return "no decision at hand"
        spared = flags.cells_of(self.spares)[:, joint] if flags is not None else None
        run = run_around(judged[:, joint] & ~spared, frame)
        if run is None:
            return "not in a run flagged before this veto (frozen and cancelling-jumps aside)"
        a, b = run
        side, jump = self._judge(ev, a, b, joint)
        if not side:
            return (
                f"run {a}:{b + 1} does not come within {self.end_seconds:g} s of the take's "
                "first or last frame (or spans both)"
            )
        edge = b + 1 if side == "start" else a
        if jump is not None:
            return (
                f"run {a}:{b + 1} reaches the take's {side}; its edge at frame {edge} jumps "
                f"(frame {jump}): an error cut off by the take"
            )
        return (
            f"run {a}:{b + 1} reaches the take's {side}, and its edge at frame {edge} holds no "
            f"jump within {self.pad_seconds:g} s: a movement performed once at the take's "
            f"{side}, cleared"
        )
