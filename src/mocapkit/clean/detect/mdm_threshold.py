"""The paper's rule, MDM above a threshold, made robust by hysteresis with seeds."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mocapkit.clean import mdm as mdm_mod
from mocapkit.clean.detect._runs import run_around
from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.flags import Flags


def abrupt_seeds(ev: Evidence) -> np.ndarray:
    """(F, J) bool: cells whose run may be flagged whatever its MDM peak: an abrupt cell (the
    angular acceleration far above the joint's median, on a cell the KNN words disagree with)
    or the digressing side of a step peak whose MDM exceeds ``step_min_mdm``. Capture errors
    enter with a jump; natural motion changes its velocity smoothly."""
    c = ev.config
    mdm = ev.mdm
    jr = ev.jump_ratio
    jumps = ((jr > c.jump_ratio) & (mdm > c.jump_min_mdm)) | (
        (jr > c.jump_ratio_2) & (mdm > c.jump_min_mdm_2)
    )
    return jumps | (ev.step_cells & (mdm > c.step_min_mdm))


@dataclass(frozen=True)
class PaperThreshold:
    """Every cell whose MDM exceeds the threshold (Aristidou et al. 2018, Sec. 3.4): a joint
    whose rotation digresses from the mean of its K nearest motion-words is wrong, because a
    performer repeats their movements and a capture error does not repeat."""

    name: ClassVar[str] = "mdm"
    veto: ClassVar[bool] = False
    signal: ClassVar[bool] = False
    threshold: float = 0.5

    @classmethod
    def from_config(cls, config: DetectConfig) -> PaperThreshold:
        return cls(config.threshold)

    def apply(self, ev: Evidence, flags: Flags) -> None:
        flags.flag(self.name, ev.mdm > self.threshold)

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        v = float(ev.mdm[frame, joint])
        rel = "above" if v > self.threshold else "not above"
        return f"MDM {v:.3f} {rel} the threshold {self.threshold:g}"


@dataclass(frozen=True)
class MDMHysteresis:
    """Runs (per joint, along time) of cells with MDM above ``threshold`` that hold a seed: a
    near-certain cell (MDM above ``seed_threshold``) or an abrupt one (:func:`abrupt_seeds`).

    Relies on: a capture error digresses strongly somewhere or enters abruptly; a clean cell
    that a weak context matches poorly sits just above the threshold, smoothly. The hysteresis
    keeps the whole error down to the threshold once a seed vouches for it."""

    name: ClassVar[str] = "mdm"
    veto: ClassVar[bool] = False
    signal: ClassVar[bool] = False
    threshold: float = 0.5
    seed_threshold: float = 0.999

    @classmethod
    def from_config(cls, config: DetectConfig) -> MDMHysteresis:
        return cls(config.threshold, config.seed_threshold)

    def _strong(self, ev: Evidence) -> np.ndarray:
        return (ev.mdm > max(self.seed_threshold, self.threshold)) | abrupt_seeds(ev)

    def apply(self, ev: Evidence, flags: Flags) -> None:
        flags.flag(self.name, mdm_mod.hysteresis(ev.mdm > self.threshold, self._strong(ev)))

    def describe(self, ev: Evidence, frame: int, joint: int, flags: Flags | None = None) -> str:
        v = float(ev.mdm[frame, joint])
        strong = self._strong(ev)[:, joint]
        run = run_around((ev.mdm[:, joint] > self.threshold) | strong, frame)
        if run is None:
            return f"MDM {v:.3f} not above the threshold {self.threshold:g}"
        a, b = run
        peak = float(ev.mdm[a : b + 1, joint].max())
        seeds = abrupt_seeds(ev)[a : b + 1, joint]
        kinds = []
        if peak > max(self.seed_threshold, self.threshold):
            kinds.append(f"MDM peak {_fine(peak, self.seed_threshold)} > {self.seed_threshold:g}")
        if seeds.any():
            kinds.append(f"an abrupt cell at frame {a + int(np.argmax(seeds))}")
        # a cell below the threshold is in the run only as an abrupt seed (a step far above
        # the joint's own enters the error there)
        own = "" if v > self.threshold else f" (below {self.threshold:g}: an abrupt cell)"
        if kinds:
            return (
                f"MDM {v:.3f}{own} in the stretch {a}:{b + 1} of MDM above {self.threshold:g} "
                "(or abrupt), seeded by " + ", ".join(kinds) + "; the vetoes below may clear "
                "or trim that stretch (the segment is what is left)"
            )
        return (
            f"MDM {v:.3f} in the stretch {a}:{b + 1} of MDM above {self.threshold:g}, with no "
            f"seed (peak {peak:.3f} <= {self.seed_threshold:g}, no abrupt cell or step)"
        )


def _fine(value: float, bound: float) -> str:
    """``value`` with as many decimals as show it apart from ``bound`` (0.9994 against 0.999,
    not 0.999 > 0.999)."""
    for digits in range(3, 8):
        if round(value, digits) != round(bound, digits):
            return f"{value:.{digits}f}"
    return f"{value:g}"
