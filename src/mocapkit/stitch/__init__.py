"""Effort-based motion stitching: the L-score and elastic L-score of Li, McCann, Faloutsos and
Pollard, "Laziness is a virtue: Motion stitching using effort minimization".

* :mod:`mocapkit.stitch.kalman` — the per-dimension constant-acceleration Kalman model and its
  RTS smoother (readable reference, and the fast linear-map form).
* :mod:`mocapkit.stitch.lscore` — L, L_k, L*, the windowed-Euclidean baseline, stitch windows
  and the batched landing search.

Conventions: feature clips are (frames, m) arrays, m = 3 × joints of body-local joint positions;
a stitch window is (2w, m) = w query frames ending at the take-off frame, then w data frames
starting at the landing frame (default w = 5); time is in frames (dt = 1); scores are summed
over the m dimensions; L_k sums |Δp̂ · â| over all 2w + k - 1 steps of the window elongated by k
injected (unobserved) frames, without normalisation. Details in the submodules' docstrings.
"""

from mocapkit.stitch.kalman import (
    DEFAULT_MODEL,
    ConstantAccelerationModel,
    rts_smooth_reference,
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
    elastic_lscore_reference,
    elastic_lscores,
    elastic_lscores_reference,
    elastic_mask,
    elastic_operators,
    lscore,
    lscore_reference,
    search_clips,
    search_landings,
    sliding_windows,
    windowed_euclidean,
)

__all__ = [
    "DEFAULT_K_MAX",
    "DEFAULT_MODEL",
    "DEFAULT_W",
    "BestStitch",
    "ClipSearchResult",
    "ConstantAccelerationModel",
    "ElasticResult",
    "SearchResult",
    "elastic_lscore",
    "elastic_lscore_reference",
    "elastic_lscores",
    "elastic_lscores_reference",
    "elastic_mask",
    "elastic_operators",
    "lscore",
    "lscore_reference",
    "rts_smooth_reference",
    "search_clips",
    "search_landings",
    "sliding_windows",
    "smooth",
    "smoother_matrix",
    "windowed_euclidean",
]
