"""One cleaning run, as ``mocapkit clean`` does it: :func:`run` analyses a take (self-similarity
or one of the paper's rotation baselines), repairs the flagged cells and returns a
:class:`CleanReport`, whose :meth:`~CleanReport.to_json` is the ``--report`` file.

    from mocapkit.clean import run
    report = run(take, [ctx1, ctx2], source="take.bvh", context_names=["a.bvh", "b.bvh"])
    report.segments              # flagged runs (Segment: joint, start, end, peak, reasons,
                                 #   evidence)
    report.explanations          # with explain=[("LeftArm", 120)]: why each cell was flagged
    report.motion                # the repaired take
    report.to_json()             # what `mocapkit clean --report` writes
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mocapkit.clean.cleaner import Progress, Segment, SelfSimilarityCleaner
from mocapkit.clean.detect import DetectConfig, Explanation
from mocapkit.clean.repair import REPAIR_METHOD_NOTES, ContactConstraint, RepairResult
from mocapkit.core.motion import Motion
from mocapkit.summary import nominal_fps

__all__ = ["CleanReport", "run"]


EVIDENCE_KEYS = {
    "mdm_peak": "highest movement digression (0-1) in the run",
    "digression_deg": "largest angle between the joint and its nearest neighbours' pose",
    "neighbour_spread_deg": "mean angle among those neighbours (how much the joint varies)",
    "jump_deg": (
        "largest change of the joint's turn per frame around the run, against both the step "
        "before and after (a difference of two rotation vectors: up to 360, not a rotation)"
    ),
    "step_deg": (
        "largest change of the turn per frame against the mean of its neighbouring steps "
        "(a difference of rotation vectors: up to 360, not a rotation)"
    ),
    "spike_deg": "smallest angle by which the run leaves the joint's own smooth path",
    "roughness_deg": "largest second difference of the angular velocity in the run (per frame)",
    "wrong_way_deg": "how far the hinge bends the wrong way",
    "off_plane_deg": "how far the hinge's limb leaves its bending plane",
    "held_seconds": "how long the joint is held exactly still",
}
"""What each key of a segment's ``evidence`` measures (degrees, seconds), in the report."""




@dataclass(frozen=True, eq=False)
class CleanReport:
    """What a cleaning run found and did.

    Attributes:
        source: the take's name (its path), ``context``: the context takes' names.
        fps, frames, joints: the take's frame rate, frame count and joint names.
        threshold, method ("self-similarity" or "baseline a|b|c"), two_stage: the settings.
        segments: the flagged runs, file frames inclusive.
        mdm: (F, J) float32 in [0, 1], the movement digression map (for a baseline, its mask as
            0/1).
        mask: (F, J) bool, the flagged cells; repair: the :class:`RepairResult` (repaired
            motion, written cells, blend margin).
        analysis_seconds: wall time of the analysis and repair.
        output: where the repaired take is written (recorded in the report only).
        cleaner: the fitted :class:`SelfSimilarityCleaner` (its neighbours and maps).
        config: the :class:`~mocapkit.clean.detect.DetectConfig` used; rules: the rules that
            ran, in order.
        decision: (F, J) int8, per flagged cell the index in ``reason_names`` of the first rule
            that flagged it, -1 elsewhere (the heat map's top panel).
        explanations: :class:`~mocapkit.clean.detect.Explanation` of the cells asked for.
    """

    source: str
    fps: float
    frames: int
    joints: tuple[str, ...]
    threshold: float
    method: str
    two_stage: bool
    context: tuple[str, ...]
    segments: tuple[Segment, ...]
    mdm: np.ndarray
    mask: np.ndarray
    repair: RepairResult
    analysis_seconds: float
    output: str | None = None
    cleaner: SelfSimilarityCleaner | None = None
    config: DetectConfig | None = None
    rules: tuple[str, ...] = ()
    decision: np.ndarray | None = None
    reason_names: tuple[str, ...] = ()
    explanations: tuple[Explanation, ...] = ()

    @property
    def motion(self) -> Motion:
        """The repaired take."""
        return self.repair.motion

    @property
    def flagged_cells(self) -> int:
        return int(self.mask.sum())

    @property
    def repaired_cells(self) -> int:
        return int(self.repair.written.sum())

    def to_json(self) -> dict[str, Any]:
        """The JSON-ready report (``mocapkit clean --report``)."""
        return {
            "input": self.source,
            "fps": nominal_fps(1.0 / self.fps),  # 30, as info gives it (not 30.00003)
            "frames": self.frames,
            "joints": list(self.joints),
            "threshold": self.threshold,
            "method": self.method,
            "two_stage": self.two_stage,
            "context": list(self.context),
            "rules": list(self.rules),
            "config": None if self.config is None else self.config.as_dict(),
            "segments": [
                {**s.as_dict(), "repair": self.repair.methods(s.joint_index, s.start, s.end)}
                for s in self.segments
            ],
            "repair_methods_are": REPAIR_METHOD_NOTES,
            "evidence_keys": EVIDENCE_KEYS,
            "flagged_cells": self.flagged_cells,
            "repaired_cells": self.repaired_cells,
            "repaired_cells_are": (
                "the flagged cells, the blend margin around each run, and the leg joints the "
                "foot lock turned where the repair moved a planted foot"
            ),
            "blend_margin_frames": self.repair.margin,
            "contacts": [c.as_dict() for c in self.repair.contacts],
            "contact_errors_are": "distances in the take's length unit",
            "analysis_seconds": round(self.analysis_seconds, 3),
            "output": self.output,
            "explain": [e.to_json() for e in self.explanations],
        }

    def save_mdm(self, path: str | Path) -> Path:
        """Write the MDM as a float32 ``.npy`` array (frames x joints), atomically."""
        import io

        from mocapkit.io.atomic import atomic_write_bytes

        buf = io.BytesIO()
        np.save(buf, np.ascontiguousarray(self.mdm, dtype=np.float32))
        return atomic_write_bytes(path, buf.getvalue())


def _baseline_segments(mask: np.ndarray, names: Sequence[str]) -> tuple[Segment, ...]:
    from mocapkit.core.runs import true_runs

    return tuple(
        Segment(names[j], j, a, b, 1.0, ("baseline",), {"frames": b - a + 1})
        for j in range(mask.shape[1])
        for a, b in true_runs(mask[:, j])
    )


def run(
    motion: Motion,
    context: Sequence[Motion] = (),
    *,
    threshold: float | None = None,
    two_stage: bool | None = None,
    config: DetectConfig | None = None,
    baseline: str | None = None,
    explain: Sequence[tuple[str | int, int]] = (),
    contacts: Sequence[ContactConstraint] = (),
    source: str | Path = "",
    context_names: Sequence[str | Path] | None = None,
    output: str | Path | None = None,
    progress: Progress | None = None,
) -> CleanReport:
    """Find the erroneous cells of ``motion`` and repair them.

    Detection: :class:`SelfSimilarityCleaner` (``config``; ``threshold`` and ``two_stage``,
    when given, replace the config's) against the take itself and the ``context`` takes, or
    with ``baseline`` ("a", "b", "c") the paper's rotation baselines
    (:class:`~mocapkit.clean.baselines.RotationBaseline`) learned from ``context`` (required
    then). Repair: the KNN words' median in either case, keeping the ``contacts``.
    ``source``, ``context_names`` and ``output`` are only recorded in the report.
    ``progress(stage, done, total)`` is called as the search advances. ``explain``: cells
    ``(joint name or index, frame)`` whose verdict the report explains.
    """
    from mocapkit.clean.baselines import RotationBaseline

    names = [str(n) for n in context_names] if context_names is not None else None
    if names is not None and len(names) != len(context):
        raise ValueError(f"{len(names)} context names for {len(context)} context takes")
    if baseline is not None and explain:
        raise ValueError(
            "explain reads the self-similarity rules; a baseline (--baseline) decides by "
            "rotation limits alone"
        )
    if baseline is not None and not context:
        raise ValueError(
            "the baselines need context takes (--context): their limits are learned from clean "
            "takes"
        )
    cfg = config or DetectConfig()
    changes = {}
    if threshold is not None:
        changes["threshold"] = float(threshold)
    if two_stage is not None:
        changes["two_stage"] = bool(two_stage)
    cfg = cfg.replace(**changes) if changes else cfg
    t0 = time.perf_counter()
    cleaner = SelfSimilarityCleaner(config=cfg)
    cleaner.fit(motion, context, progress=progress, names=names)
    joint_names = tuple(motion.skeleton.names)
    explanations = tuple(cleaner.explain(j, f) for j, f in explain)
    if baseline is None:
        mdm = cleaner.scores().astype(np.float32)
        flags = cleaner.flags()
        mask = flags.mask.copy()
        segments = tuple(cleaner.segments())
        rules = tuple(cleaner.rule_names())
        reason_names = tuple(r for r in rules if r in flags.added and (flags.live(r) & mask).any())
        decision = flags.primary(list(reason_names))
    else:
        mask = RotationBaseline(baseline).fit(list(context)).mask(motion)
        mdm = mask.astype(np.float32)
        segments = _baseline_segments(mask, joint_names)
        rules = ("baseline",)
        reason_names = ("baseline",)
        decision = np.where(mask, 0, -1).astype(np.int8)
    # the pipeline's own decision: the repair also reads which rule flagged each cell
    result = cleaner.repair(mask=mask if baseline is not None else None, contacts=contacts)
    elapsed = time.perf_counter() - t0
    return CleanReport(
        source=str(source),
        fps=motion.fps,
        frames=motion.num_frames,
        joints=joint_names,
        threshold=cfg.threshold,
        method=f"baseline {baseline}" if baseline else "self-similarity",
        two_stage=cfg.two_stage,
        context=tuple(names)
        if names is not None
        else tuple(f"context{i}" for i in range(len(context))),
        segments=segments,
        mdm=mdm,
        mask=mask,
        repair=result,
        analysis_seconds=elapsed,
        output=None if output is None else str(output),
        cleaner=cleaner,
        config=cfg,
        rules=rules,
        decision=decision,
        reason_names=reason_names,
        explanations=explanations,
    )
