"""Effort-based motion stitching: the L-score and elastic L-score of Li, McCann, Faloutsos and
Pollard, "Laziness is a virtue: Motion stitching using effort minimization".

* :mod:`mocapkit.stitch.kalman` — the per-dimension constant-acceleration Kalman model and its
  RTS smoother (as a cached linear map; the readable references are in tests/stitch/naive.py).
* :mod:`mocapkit.stitch.lscore` — L, L_k, L*, the windowed-Euclidean baseline, stitch windows
  and the batched landing search.
* :mod:`mocapkit.stitch.search` — score features of motions and the transition search over a
  library of clips (by L* or by windowed Euclidean distance), on arrays or on Motions.
* :mod:`mocapkit.stitch.transition` — the stitched Motion (Kalman-generated frames after a
  ground-plane alignment) and the cross-fade / gap-interpolation baselines.

Conventions: feature clips are (frames, m) arrays, m = 3 × joints of body-local joint positions;
a stitch window is (2w, m) = w query frames ending at the take-off frame, then w data frames
starting at the landing frame (default w = 5); time is in frames (dt = 1); scores are summed
over the m dimensions; L_k sums |Δp̂ · â| over all 2w + k - 1 steps of the window elongated by k
injected (unobserved) frames, without normalisation. Details in the submodules' docstrings.
"""

from mocapkit.stitch.kalman import (
    DEFAULT_MODEL,
    ConstantAccelerationModel,
    smooth,
    smoother_matrix,
)
from mocapkit.stitch.lscore import (
    DEFAULT_K_MAX,
    DEFAULT_W,
    BestStitch,
    ClipSearchResult,
    ElasticResult,
    SearchResult,
    elastic_lscore,
    elastic_lscores,
    elastic_mask,
    elastic_operators,
    lscore,
    search_clips,
    search_landings,
    sliding_windows,
    windowed_euclidean,
)
from mocapkit.stitch.search import (
    SCORES,
    Transition,
    body_joints,
    conform,
    euclidean_landings,
    find_transition,
    motion_features,
    parse_takeoffs,
    search_features,
)
from mocapkit.stitch.transition import (
    METHODS,
    Stitched,
    align_data,
    crossfade,
    interpolate_gap,
    stitch,
    stitch_motions,
)

__all__ = [
    "DEFAULT_K_MAX",
    "DEFAULT_MODEL",
    "DEFAULT_W",
    "METHODS",
    "SCORES",
    "BestStitch",
    "ClipSearchResult",
    "ConstantAccelerationModel",
    "ElasticResult",
    "SearchResult",
    "Stitched",
    "Transition",
    "align_data",
    "body_joints",
    "conform",
    "crossfade",
    "elastic_lscore",
    "elastic_lscores",
    "elastic_mask",
    "elastic_operators",
    "euclidean_landings",
    "find_transition",
    "interpolate_gap",
    "lscore",
    "motion_features",
    "parse_takeoffs",
    "search_clips",
    "search_features",
    "search_landings",
    "sliding_windows",
    "smooth",
    "smoother_matrix",
    "stitch",
    "stitch_motions",
    "windowed_euclidean",
]
