"""Detection as a declared pipeline: one rule per module, one :class:`DetectConfig`.

    from mocapkit.clean.detect import PIPELINE, DetectConfig, Evidence, run_pipeline
    ev = cleaner.evidence_            # computed once per take (maps, steps, jumps, ...)
    flags = run_pipeline(ev)          # Flags: .mask, .added[rule], .removed[veto]
    print(explain(ev, flags, joint, frame))

Rules (each module's docstring says what fact it relies on): :class:`MDMHysteresis` (the
paper's MDM threshold, seeded), :class:`DominanceVeto`, :class:`CancellingJumps`,
:class:`Spikes`, :class:`FrozenJoints`, :class:`SmoothVeto`, :class:`RecurringVeto`,
:class:`LimitReleaseVeto`, :class:`OnceAtTheEnds`, :class:`NoiseBursts`, :class:`WrongWayHinges`,
:class:`ExtendToSteps`.
"""

from mocapkit.clean.detect.bridge import BridgeHoles
from mocapkit.clean.detect.cancelling_jumps import CancellingJumps
from mocapkit.clean.detect.config import DetectConfig, seconds_to_frames
from mocapkit.clean.detect.dominance import DominanceVeto
from mocapkit.clean.detect.evidence import Evidence, straight_hinges
from mocapkit.clean.detect.extend import ExtendToSteps
from mocapkit.clean.detect.flags import Flags
from mocapkit.clean.detect.frozen import FrozenJoints
from mocapkit.clean.detect.hinges import WrongWayHinges
from mocapkit.clean.detect.limit_release import LimitReleaseVeto
from mocapkit.clean.detect.mdm_threshold import MDMHysteresis, PaperThreshold, abrupt_seeds
from mocapkit.clean.detect.noise_bursts import NoiseBursts
from mocapkit.clean.detect.once_at_ends import OnceAtTheEnds
from mocapkit.clean.detect.pipeline import (
    ADDED,
    ORIGINAL_ORDER,
    PAPER_PIPELINE,
    PIPELINE,
    RETIRED,
    UNANALYSED,
    Explanation,
    build,
    explain,
    pipeline_for,
    run_pipeline,
    segment_evidence,
    signal_cells,
)
from mocapkit.clean.detect.recurring import RecurringVeto
from mocapkit.clean.detect.smooth import SmoothVeto
from mocapkit.clean.detect.spikes import Spikes

__all__ = [
    "ADDED",
    "ORIGINAL_ORDER",
    "PAPER_PIPELINE",
    "PIPELINE",
    "RETIRED",
    "UNANALYSED",
    "BridgeHoles",
    "CancellingJumps",
    "DetectConfig",
    "DominanceVeto",
    "Evidence",
    "Explanation",
    "ExtendToSteps",
    "Flags",
    "FrozenJoints",
    "LimitReleaseVeto",
    "MDMHysteresis",
    "NoiseBursts",
    "OnceAtTheEnds",
    "PaperThreshold",
    "RecurringVeto",
    "SmoothVeto",
    "Spikes",
    "WrongWayHinges",
    "abrupt_seeds",
    "build",
    "explain",
    "pipeline_for",
    "run_pipeline",
    "seconds_to_frames",
    "segment_evidence",
    "signal_cells",
    "straight_hinges",
]
