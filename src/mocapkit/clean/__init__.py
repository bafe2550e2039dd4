"""Mocap cleaning by self-similarity (Aristidou, Cohen-Or, Hodgins, Shamir, EG 2018).

Motion-words over joint groups, a trimmed quaternion-log pose distance, constrained DTW, KNN words
in a context of takes, the movement digression map (MDM), repair of the flagged cells only,
sparse-joint reconstruction and the paper's rotation baselines.

    from mocapkit.clean import SelfSimilarityCleaner
    cleaner = SelfSimilarityCleaner().fit(take, context=[take2, take3])
    cleaner.mdm_                 # (F, J) in [0, 1] on the take's frames
    cleaner.segments()           # flagged runs (joint, start, end, peak, reasons, evidence)
    print(cleaner.explain("LeftArm", 120))   # why that cell was or was not flagged
    SelfSimilarityCleaner(config=DetectConfig(threshold=0.6))   # every threshold in one place
    fixed = cleaner.repair().motion

    from mocapkit.clean import run  # what `mocapkit clean` does: detect, repair, report
    report = run(take, [take2, take3], source="take.bvh")
    report.to_json()             # the --report JSON; report.motion is the repaired take
"""

from mocapkit.clean.baselines import BASELINES, RotationBaseline
from mocapkit.clean.cleaner import (
    FLOOR_DEG,
    GAIN,
    SCALE,
    THRESHOLD,
    Segment,
    SelfSimilarityCleaner,
    clean,
)
from mocapkit.clean.detect import PIPELINE, DetectConfig, Explanation
from mocapkit.clean.dtw import (
    MAX_RUN,
    constrained_dtw,
    dtw_mean_cost,
    pose_distance,
    pose_distance_matrices,
    scan_words,
)
from mocapkit.clean.inject import ERROR_KINDS, Injected, inject
from mocapkit.clean.knn import K_NEIGHBOURS, Context, GroupNeighbours, search_group, select_knn
from mocapkit.clean.mdm import (
    mean_texture,
    median_texture,
    movement_digression_map,
    neighbour_spread,
)
from mocapkit.clean.repair import ContactConstraint, ContactHeld, RepairResult, repair_cells
from mocapkit.clean.run import CleanReport, run
from mocapkit.clean.sparse import reconstruct
from mocapkit.clean.texture import Texture, default_groups, make_texture
from mocapkit.clean.words import ANALYSIS_FPS, JointGroup, word_lengths

__all__ = [
    "ANALYSIS_FPS",
    "BASELINES",
    "ERROR_KINDS",
    "FLOOR_DEG",
    "GAIN",
    "K_NEIGHBOURS",
    "MAX_RUN",
    "PIPELINE",
    "SCALE",
    "THRESHOLD",
    "CleanReport",
    "ContactConstraint",
    "ContactHeld",
    "Context",
    "DetectConfig",
    "Explanation",
    "GroupNeighbours",
    "Injected",
    "JointGroup",
    "RepairResult",
    "RotationBaseline",
    "Segment",
    "SelfSimilarityCleaner",
    "Texture",
    "clean",
    "constrained_dtw",
    "default_groups",
    "dtw_mean_cost",
    "inject",
    "make_texture",
    "mean_texture",
    "median_texture",
    "movement_digression_map",
    "neighbour_spread",
    "pose_distance",
    "pose_distance_matrices",
    "reconstruct",
    "repair_cells",
    "run",
    "scan_words",
    "search_group",
    "select_knn",
    "word_lengths",
]
