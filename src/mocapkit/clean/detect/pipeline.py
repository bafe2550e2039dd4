"""The detection pipeline as data, its runner, and the explanation of one cell."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mocapkit.clean.detect._runs import run_around
from mocapkit.clean.detect.bridge import BridgeHoles
from mocapkit.clean.detect.cancelling_jumps import CancellingJumps
from mocapkit.clean.detect.config import DetectConfig
from mocapkit.clean.detect.dominance import DominanceVeto
from mocapkit.clean.detect.evidence import Evidence
from mocapkit.clean.detect.extend import ExtendToSteps
from mocapkit.clean.detect.flags import Flags
from mocapkit.clean.detect.frozen import FrozenJoints
from mocapkit.clean.detect.hinges import WrongWayHinges
from mocapkit.clean.detect.limit_release import LimitReleaseVeto
from mocapkit.clean.detect.mdm_threshold import MDMHysteresis, PaperThreshold
from mocapkit.clean.detect.noise_bursts import NoiseBursts
from mocapkit.clean.detect.once_at_ends import OnceAtTheEnds
from mocapkit.clean.detect.recurring import RecurringVeto
from mocapkit.clean.detect.smooth import SmoothVeto
from mocapkit.clean.detect.spikes import Spikes

ORIGINAL_ORDER: tuple[type, ...] = (
    MDMHysteresis,
    DominanceVeto,
    CancellingJumps,
    Spikes,
    FrozenJoints,
    SmoothVeto,
    RecurringVeto,
    NoiseBursts,
    WrongWayHinges,
    ExtendToSteps,
    BridgeHoles,
)
"""Every rule the cleaner grew, in the order it ran them (before issue #16's ablation)."""

RETIRED: tuple[type, ...] = (DominanceVeto, ExtendToSteps)
"""Rules that did not earn their place on the validation half of Bandai-1 (bench/eval_clean.py
``--set bandai1-val --ablate --drops ...``: 7 takes x 6 error kinds x 2 contexts, from the same
fits). Backward elimination from :data:`ORIGINAL_ORDER` (recall/precision 0.988/0.981):
without the spike rule 0.988/0.983, then without the dominance veto 0.988/0.983, then without
the extension 0.988/0.983; without the smooth veto as well 0.988/0.977, so the smooth veto
stays. Kept importable for explanations and ablations, not run by default. The spike rule came
back in session 19 at a higher threshold and after the signal rules (:data:`PIPELINE`)."""

ADDED: tuple[type, ...] = (LimitReleaseVeto, OnceAtTheEnds)
"""Rules added after the ablation that retired :data:`RETIRED` (chosen on the Bandai-1 tuning
half, then checked on the validation half, Bandai-2 and CMU without retuning)."""

PIPELINE: tuple[type, ...] = (
    MDMHysteresis,
    CancellingJumps,
    FrozenJoints,
    SmoothVeto,
    RecurringVeto,
    LimitReleaseVeto,
    OnceAtTheEnds,
    NoiseBursts,
    WrongWayHinges,
    Spikes,
    BridgeHoles,
)
"""The rules of ``detect="hysteresis"``, in the order they run: the MDM threshold with seeds,
the cancelling jumps, frozen joints, the smooth, recurring and limit-release vetoes (they clear
what the rules before them flagged; the smooth veto spares frozen runs), then the signal rules
(noise bursts, wrong-way hinges: they need no KNN evidence, so no veto applies to them), the
spikes (after every other rule, so that a spike beside a run already flagged is left to that
run: a spike read off the frames next to a wrong-way bend was a false alarm), and last the
holes of a frame or two between two flagged runs of a joint closed (:class:`BridgeHoles`,
added in session 10: on the Bandai-1 halves it changes no unit; on raw CMU takes it joins a
glitch reported in pieces).

The spike rule catches a one-frame spike whose entry and exit jumps fall on consecutive
frames, of which the cancelling jumps keep only one (the local maxima of the jump size). On the
tuning half it took the gestures' spike recall with small context from 0.938 to 1.000 (a 51 deg
spike on bow_feminine's upper arm) with no false alarm in the injected evaluation; where it ran
before the vetoes and the hinges (its old place) it added one beside a wrong-way bend. Its
threshold and length (``DetectConfig.spike_deg``, ``spike_seconds``) were then chosen on the
tuning half's clean takes, where every flag is a false alarm. Session 24 let a joint whose own
jumps are small spike from 20 deg (``spike_jump_ratio``, ``spike_floor_deg``): one- and
two-frame spikes of 20-40 deg pair with nothing, their jumps tie. Tuning half, seeds 0-6:
spike recall 0.991 -> 1.000 in locomotion and dance/fight, precision unchanged; validation
half, seeds 0-2: dance/fight spike recall (small context) 0.977 -> 1.000, nothing else
changed."""

PAPER_PIPELINE: tuple[type, ...] = (PaperThreshold,)
"""``detect="threshold"``: the paper's plain MDM threshold."""

UNANALYSED = "unanalysed"
"""The last step of every pipeline: joints the search could not analyse are never flagged."""


def pipeline_for(config: DetectConfig) -> tuple[type, ...]:
    """The rule classes ``config.detect`` selects."""
    return PIPELINE if config.detect == "hysteresis" else PAPER_PIPELINE


def build(config: DetectConfig, pipeline: Sequence[type] | None = None) -> list:
    """The rule objects of ``pipeline`` (default :func:`pipeline_for`) with their thresholds
    from ``config``; an empty pipeline flags nothing."""
    rules = pipeline_for(config) if pipeline is None else tuple(pipeline)
    for r in rules:
        if not hasattr(r, "from_config"):
            raise TypeError(
                f"pipeline entries are rule classes (e.g. mocapkit.clean.detect.PIPELINE's), "
                f"got {r!r}"
            )
    return [r.from_config(config) for r in rules]


def run_pipeline(
    evidence: Evidence,
    threshold: float | None = None,
    pipeline: Sequence[type] | None = None,
) -> Flags:
    """Run the rules on ``evidence`` (its config; ``threshold`` replaces the MDM threshold,
    ``pipeline`` the rule list) and return the :class:`Flags`."""
    cfg = evidence.config if threshold is None else evidence.config.replace(threshold=threshold)
    flags = Flags(evidence.shape)
    for rule in build(cfg, pipeline):
        rule.apply(evidence, flags)
    flags.veto(UNANALYSED, np.broadcast_to(~evidence.analysed[None, :], evidence.shape))
    return flags


def signal_cells(evidence: Evidence, pipeline: Sequence[type] | None = None) -> np.ndarray:
    """(F, J) bool: what the pipeline's signal rules (read off the rotations alone) flag; the
    KNN words lying on these cells may not speak for that joint."""
    out = np.zeros(evidence.shape, dtype=bool)
    for rule in build(evidence.config, pipeline):
        if rule.signal:
            out |= rule.cells(evidence)
    return out


@dataclass
class Explanation:
    """Why one cell was or was not flagged: ``flagged``, the rules that flagged it
    (``reasons``), the vetoes that cleared it (``cleared_by``) and, per rule of the pipeline,
    one line of what it measured there (``lines``: (rule, verdict, measurement))."""

    joint: str
    joint_index: int
    frame: int
    seconds: float
    flagged: bool
    reasons: list[str]
    cleared_by: list[str]
    mdm: float
    analysed: bool
    lines: list[tuple[str, str, str]] = field(default_factory=list)
    segment: tuple[int, int] | None = None
    """The flagged segment holding the cell, ``(A, B)``: frames A to B-1 (the report's and the
    summary's); None where it is not flagged. Each rule's line measures that rule's own run,
    before the vetoes and the other rules, so its frames may differ."""

    def to_json(self) -> dict:
        return {
            "joint": self.joint,
            "joint_index": self.joint_index,
            "frame": self.frame,
            "seconds": round(self.seconds, 6),
            "flagged": self.flagged,
            "reasons": list(self.reasons),
            "cleared_by": list(self.cleared_by),
            "mdm": round(self.mdm, 6),
            "analysed": self.analysed,
            "segment": None if self.segment is None else list(self.segment),
            "rules": [{"rule": r, "verdict": v, "measured": m} for r, v, m in self.lines],
        }

    def __str__(self) -> str:
        head = "FLAGGED" if self.flagged else "not flagged"
        why = f" by {', '.join(self.reasons)}" if self.flagged else ""
        if self.cleared_by and self.flagged:  # cleared, then flagged again by a later rule
            why += f" (after {', '.join(self.cleared_by)} cleared the earlier rules' flags)"
        elif self.cleared_by:
            why += f" (cleared by {', '.join(self.cleared_by)})"
        if self.segment is not None:  # the rules' lines measure their own runs
            why += f"; segment {self.segment[0]}:{self.segment[1]}"
        out = [f"{self.joint} frame {self.frame} ({self.seconds:.3f} s): {head}{why}"]
        if not self.analysed:  # no rule's verdict applies: say so instead of listing them
            out.append(
                "  the joint was not analysed (it does not rotate, or no word covers it): no "
                "rule flags it (--report's JSON keeps what each rule measured)"
            )
            return "\n".join(out)
        w = max((len(r) for r, _, _ in self.lines), default=0)
        vw = max((len(v) for _, v, _ in self.lines), default=0)  # the measurements line up
        for r, v, m in self.lines:
            out.append(f"  {r:<{w}s}  {v:<{vw}s}  {m}")
        return "\n".join(out)


def _holds(table: dict, rule: str, frame: int, joint: int) -> bool:
    cells = table.get(rule)
    return cells is not None and bool(cells[frame, joint])


def explain(
    evidence: Evidence,
    flags: Flags,
    joint: int,
    frame: int,
    pipeline: Sequence[type] | None = None,
) -> Explanation:
    """Why cell (``frame``, ``joint``) was or was not flagged by ``flags`` (the result of
    :func:`run_pipeline` on ``evidence`` with the same ``pipeline``)."""
    F, J = evidence.shape
    if not 0 <= joint < J:
        raise ValueError(f"joint index {joint} outside 0:{J}")
    if not 0 <= frame < F:
        raise ValueError(f"frame {frame} outside 0:{F}")
    lines = []
    reasons, cleared = [], []
    for rule in build(evidence.config, pipeline):
        table = flags.removed if rule.veto else flags.added
        cells = table.get(rule.name)
        hit = cells is not None and bool(cells[frame, joint])
        if rule.veto:  # a veto only removes flags: say so, so its measure is read as such
            verdict = "veto: cleared it" if hit else "veto: not applied"
            if hit:
                cleared.append(rule.name)
                reasons = []  # those flags are gone: a later rule may flag the cell again
            spares = getattr(rule, "spares", ())  # optional: rules whose cells a veto keeps
            spared = [r for r in spares if _holds(flags.added, r, frame, joint)]
            if spared and not hit:
                verdict += f" (it spares {', '.join(spared)} cells)"
        else:
            verdict = "flagged it" if hit else "did not flag"
            if hit:
                reasons.append(rule.name)
        try:
            measured = rule.describe(evidence, frame, joint, flags)
        except RuntimeError as e:  # a rule that needs maps on bare evidence
            measured = str(e)
        lines.append((rule.name, verdict, measured))
    un = flags.removed.get(UNANALYSED)
    if un is not None and un[frame, joint]:
        cleared.append(UNANALYSED)
    run = run_around(flags.mask[:, joint], frame)
    return Explanation(
        joint=evidence.names[joint],
        joint_index=int(joint),
        frame=int(frame),
        seconds=frame / evidence.fps,
        flagged=bool(flags.mask[frame, joint]),
        reasons=reasons if flags.mask[frame, joint] else [],
        cleared_by=cleared,
        mdm=float(evidence.mdm[frame, joint]) if evidence.mdm is not None else float("nan"),
        analysed=bool(evidence.analysed[joint]),
        lines=lines,
        segment=None if run is None else (run[0], run[1] + 1),
    )


def segment_evidence(
    evidence: Evidence, reasons: Sequence[str], joint: int, a: int, b: int
) -> dict:
    """The measurements behind a flagged run ``a .. b`` (inclusive) of ``joint``: MDM peak,
    digression and neighbour spread (degrees), the largest jump and step around it (degrees),
    and what each of its ``reasons`` measured (spike size, roughness, wrong-way flexion, held
    seconds). JSON-ready, finite numbers only."""
    sl = slice(a, b + 1)
    around = slice(max(a - 1, 0), b + 2)
    ev = evidence
    out: dict = {"frames": b - a + 1, "seconds": round((b - a + 1) / ev.fps, 4)}

    def put(key: str, value: float) -> None:
        if np.isfinite(value):
            out[key] = round(float(value), 4)

    if ev.mdm is not None:
        put("mdm_peak", ev.mdm[sl, joint].max())
        put("digression_deg", np.degrees(ev.digression[sl, joint].max()))
        if ev.spread is not None:
            put("neighbour_spread_deg", np.degrees(ev.spread[sl, joint].mean()))
    put("jump_deg", np.degrees(ev.jump_size[around, joint].max()))
    put("step_deg", np.degrees(ev.steps[around, joint].max()))
    if "spike" in reasons:
        put("spike_deg", np.degrees(ev.spike_size[sl, joint].max()))
    if "noise" in reasons:
        put("roughness_deg", np.degrees(ev.roughness[sl, joint].max()))
    if "wrong-way-hinge" in reasons:
        with np.errstate(invalid="ignore"):
            if ev.wrong_way[sl, joint].any():
                put("wrong_way_deg", -np.degrees(np.nanmin(ev.hinge_flexion[sl, joint])))
            if ev.off_plane[sl, joint].any():
                put("off_plane_deg", np.degrees(np.nanmax(ev.hinge_off_plane[sl, joint])))
    if "frozen" in reasons:
        put("held_seconds", ev.frozen[sl, joint].sum() / ev.fps)
    return out
