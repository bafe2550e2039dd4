"""In-betweening from a library of real motion: fill frames ``A..B-1`` of a clip with library
segments that continue the frames before ``A`` (the past context) and lead into the frames from
``B`` on (the future context).

A smoother cannot invent a step: over 30 frames the Kalman transition of the elastic L-score
(:func:`kalman_fill`) is a smooth glide between two poses. A library of captured motion holds
the steps, so the gap is filled with its segments. The fact relied on: a captured segment whose
poses just before and at the gap's start are the context's last two poses, whose pose at the
gap's end is the first future pose, and whose body travels over the ground like the context's
does over the gap, is a plausible motion for the gap; its remaining differences at both ends
are small and are blended away.

**Candidates.** A candidate is a library clip, a frame ``s`` and a time warp ``r`` (a speed
factor from :attr:`InbetweenConfig.warps`): the library clip resampled at times ``s + i r``,
i = -1..g+1 (g = B - A), so segments of nearby lengths ``r g`` are time-warped to fit. Every
library clip is also searched played backwards (:attr:`InbetweenConfig.backwards`): backward
steps are forward steps reversed in time. Its frame
i = 0 takes the place of the last past frame A-1, frames 1..g fill the gap, and frame g+1 takes
the place of the first future frame B.

**The clip's own frames.** The clip's stretches of at least a second before and after the gap
are searched too, as library clips named as the clip (:attr:`InbetweenConfig.own_frames`,
:func:`with_own_frames`): a person repeats their steps over a take, and their own steps are
their person's, style's and gait's, which the library may hold none of (Bandai-2 holds no back
or side walks). Held out (the rule has no tunable but the stretch's least length, a gait
cycle), Bandai-1 takes filled at 30-frame gaps every 45 frames from bandai2's walks, turning
walks and runs, mean joint error library alone / with the take's own frames: back walks 4.86
/ 1.97 cm (32 gaps), left walks 5.61 / 2.21 (13), right walks 5.42 / 2.17 (14), forward walks
3.59 / 1.92 (52), runs 5.24 / 3.44 (6), a dash 11.74 / 6.23 (1); foot skate within 1 cm/s of
the takes' own but on left walks' library-alone fills (25.5 against 22.5 cm/s) and runs'
(23.2 against 27.6, now 27.2). The LaFAN1 benchmark's context (10 past frames, one future
frame) is shorter than a stretch worth searching, so its figures are the library's alone.

**The clip's own gait.** Where the clip travels, a share of the combined fill's body-local pose
(:attr:`InbetweenConfig.gait_share`) carries on the clip's own gait through the gap
(:mod:`mocapkit.stitch.gait`): steady locomotion is periodic and left/right symmetric, so the
frames before the gap, mirrored every half gait cycle, predict the person's, style's and gait's
steps, which the library may not hold; the half cycle is read from the first future frame.
The segments keep the ground path, the heading and the feet they plant
(:func:`mocapkit.stitch.gait.stance_kept`).

**Score** (lower is better), in the body-local features of stitching
(:func:`mocapkit.stitch.search.motion_features`: joint positions with the pelvis' ground
position and heading removed):

* ``pose``: the squared distances of the candidate's frames i = -1, 0 and g+1 to the context's
  frames A-2, A-1 and B, over the number of joints and the squared
  :attr:`InbetweenConfig.pose_tolerance_m`, times :attr:`InbetweenConfig.pose_weight`: the
  pose and velocity the segment starts with, and the pose it must arrive at;
* ``bob``: the pelvis' vertical acceleration and speed over the candidate's frames i = -2k,
  -k, 0 against the context's over A-1-2k, A-1-k, A-1 (k = 1 at 30 fps:
  :attr:`InbetweenConfig.bob_span_seconds`; :attr:`InbetweenConfig.bob_tolerance_m_s2` and
  :attr:`InbetweenConfig.bob_speed_tolerance_m_s`, weighted by
  :attr:`InbetweenConfig.bob_weight`): the phase of the body's rise and fall with
  each step, whatever the person's pelvis level;
* ``travel``: the ground path: the pelvis' ground displacement and heading change from frame
  A-1 to B, in the body frame at A-1, against the candidate's from i = 0 to g+1, and the pelvis'
  ground velocity at the last past frame against the candidate's at i = 0
  (:attr:`InbetweenConfig.travel_tolerance_m`, :attr:`InbetweenConfig.turn_tolerance_deg`,
  weighted by :attr:`InbetweenConfig.travel_weight`; judged as rates over a gap longer than
  :attr:`InbetweenConfig.travel_seconds`). The body-local features cannot see it;
* ``L_start + L_end`` times :attr:`InbetweenConfig.lscore_weight` (0 by default): the L-score
  (Li et al., Eq. 2; :mod:`mocapkit.stitch.lscore`) of the window ``w_p`` past frames
  ``A-w_p..A-1`` then the candidate's first ``w`` gap frames, and of the candidate's last ``w``
  gap frames then the ``w_f`` future frames ``B..`` (plain L, k = 0: the candidate's own frames
  are the transition and the time warp is the elastic freedom of its length). The two
  L-scores of the chosen candidates are always computed and reported.

Why the L-scores are out of the score by default: the L-score measures the smoother's effort
(step times acceleration), not how far a pose is from another, and the LaFAN1 protocol gives
one future frame, which a smoother with observation noise all but ignores — a candidate that
misses the target pose scores almost as well as one that reaches it. On the tuning takes
(bench/bench_inbetween.py --tune, L2P over interpolation at 15 and 30 frames), the L-score search
reached 0.53 and 0.50; the pose term with L-scores at weight 1 the same (the L-scores, hundreds of
times larger, decide); the pose term alone 0.33 and 0.40, about the issue's nearest-segment baseline
(0.34, 0.39). The defaults then (pose term, ground path at weight 1, three neighbours averaged,
twelve combined now: :attr:`InbetweenConfig.neighbours`; foot lock) reached 0.23, 0.26, 0.30 and
0.33 at 5, 15, 30 and 45 frames on all 64 tuning windows, the nearest-segment baseline 0.28, 0.31,
0.34 and 0.40 in the same run.

**Search** (:func:`search_inbetween`, :func:`search_inbetween_top`): for each warp the pose
term is three matrix-vector products with the library's features (squared norms cached), the
ground-path and bob terms are vectorised (the pelvis heights are a column of the features),
the L-scores (only with a non-zero weight) come from the
batched numba kernel of the stitching search (:func:`mocapkit.stitch.lscore.search_landings`'
kernel), and candidates whose frames would cross a clip boundary are discarded. The best
:attr:`InbetweenConfig.neighbours` candidates are kept, a candidate overlapping a better one's
library frames passed over. The readable twin is tests/stitch/inbetween_naive.py.

**Fill** (:func:`library_fill`): each segment is sampled from the library motion (slerp of
rotations, lerp of translations) and moved over the ground by a transform that varies along the
gap: at i = 0 it puts the segment's pelvis ground position and facing on the context's at A-1,
at i = g+1 on the context's at B, in between the heading correction grows linearly with i and
bends the path as a steady turn would, and the position it still misses is made up linearly
(:func:`_ground_warp`). The remaining differences of every joint's local rotation (``log(q_ctx
q_seg⁻¹)``) and local translation at both ends are then blended in (inertialization: each end's
offset fades over :attr:`InbetweenConfig.blend_seconds` from its end, with smoothstep weights; a
joint's larger rotation offset over more frames, so that the correction turns it no faster than
:attr:`InbetweenConfig.blend_max_speed_deg`), so frames A-1 and B of the result are the
context's exactly and the frames between are the library's motion turned by a share of the two
ends' mean rotation offset held across the middle (:attr:`InbetweenConfig.offset_keep`: the
clip's person holds their joints their own way). Where the clip has a second frame beside the
gap, the joints' angular-velocity and translations' velocity offsets are carried too
(:func:`_offset_blend` ``v0``, ``v1``, ``u0``, ``u1``; capped at
:data:`TURN_OFFSET_MAX_DEG_S` and :data:`TRANSLATION_OFFSET_MAX_M_S`), so
the fill leaves and reaches the context at its own velocity. Between the two blends the pelvis
is kept at the clip's own level (its mean height before the gap,
:attr:`InbetweenConfig.level_seconds`, not the library person's), the legs turned so that the
feet stay where the segments put them (:func:`_to_level`). The fills of the
:attr:`InbetweenConfig.neighbours` candidates are combined
(normalised weighted quaternion sum, weighted mean translation) with the weights of
:func:`fill_weights`: each candidate's score weight (:func:`neighbour_weights`), corrected by a
local linear regression of the fills on how each candidate's poses beside the gap miss the
context's, read at no miss, so that what the candidates share in missing it is not carried
into the fill. The weights sum to 1 and each fill meets the context exactly, so the
combination does too; where the candidates disagree it is the better estimate of the unknown
motion.
On rigs with a ground root (Bandai's ``joint_Root``) the work is done with the root on the
body's path (:func:`mocapkit.features.ground_root_on_path`) and the filled frames are written
back in the clip's own convention (its root interpolated between A-1 and B, the joint below
re-expressed), so the context frames are untouched.

**Fallback.** The library fill and the Kalman transition (:func:`kalman_fill`) are scored
alike: the two-sided L-score of the filled frames, L of the past window then the first gap
frames plus L of the last gap frames then the future window (same windows, same features, both
on the final filled frames, :attr:`Inbetween.library_lscore` and
:attr:`Inbetween.kalman_lscore`). When the library fill's is more than
:attr:`InbetweenConfig.fallback_margin` times the Kalman transition's, the gap is filled by the
Kalman transition instead and the result says so (:attr:`Inbetween.fell_back`). The Kalman
transition is by construction the smoother's least-effort path, so it wins a like-for-like
comparison on many gaps while being the worse fill on nearly all of them, the more so with one
future frame (LaFAN1): on 24 tuning windows (one library candidate), the like-for-like rule
without a margin sent 10, 11, 1 and 0 of the gaps of 5, 15, 30 and 45 frames to the Kalman
transition, which was the better fill on 5, 0, 0 and 0 of them (L2P at 15 frames 4.9 against
1.55 never falling back). The ratio of the two scores does not tell the better fill (ratios of
the Kalman's wins 0.6 to 1.3, of the library's 0.1 to 2.3); the margin keeps the fallback for a
library that has nothing like the context. A library segment that misses the context by
more than the poor-fit bounds (:attr:`Inbetween.warning`) gives the gap to the Kalman
transition too (:attr:`Inbetween.unlike`). The Kalman transition fills gaps of up to
:attr:`InbetweenConfig.kalman_max_seconds` only (its error grows with the square of the gap's
length): a longer gap keeps the library fill, and is refused where no library segment fits.
A gap over :attr:`InbetweenConfig.average_max_seconds` is filled by the best segment alone,
not an average (averaged segments drift out of step and their feet creep).

**A gap at the clip's start or end** (``0:B`` or ``A:F``) has context on one side only: it is
filled by the best segment continuing that side, meeting it exactly there and free at the
clip's first or last frame. At the end, the pose term is the last two past frames, the ground
path term the start velocity (nothing to arrive at) as the segment plays it, time-warped (the
two-sided term compares the library's own speed and lets the arrival set the warp: alone, it
let a run at x1.25 set off 0.9 m/s faster than the clip, newcomer report; tuning windows, L2P
at 15 / 30 frames 3.43 / 5.46 and 3.90 / 5.57 before, 3.39 / 4.82 and 3.60 / 5.43 after, foot
skate 32.8 / 32.3 and 29.1 / 27.6 cm/s before, 36.2 / 34.5 and 30.4 / 31.6 after; a
constant-velocity guess of the arrival as well: 3.65 / 5.94 and 3.51 / 6.10), and a segment may
end its library clip; the start is filled as the reversed clip's end, from the library played
the other way (:attr:`InbetweenConfig.backwards`), and reversed back. There is no Kalman
transition (it needs both sides) and no average: nothing pins the segments' far ends together,
so averaged segments part and their feet slide. Tuning windows (the take's person left out of
the library; gaps of 15 / 30 frames at a 10-frame context's end, then start; the library's own
speed compared): L2P 3.43 / 5.46 and 3.90 / 5.57 from the best segment, 3.02 / 4.45 and 3.33 /
4.69 averaging six, 6.42 / 8.83 and 6.73 / 9.65 holding the nearest context pose
(zero-velocity); foot skate 32.8 / 32.3 and 29.1 / 27.6 cm/s alone, 38.3 / 39.4 and 35.4 / 40.5
averaging six, the takes' own 31.6 / 31.6 and 29.6 / 30.9. Averaging is nearer the truth but
skates beyond the takes' own (the issue's bound for a fill).

**Feet.** Finally the feet the filled frames plant are held by IK on the legs
(:attr:`InbetweenConfig.foot_lock`), its corrections turning no faster than
:attr:`InbetweenConfig.lock_max_speed_deg` and smoothed over
:attr:`InbetweenConfig.lock_smooth_seconds` (a correction's speed switched within a frame
jolts the foot). A held foot moves as the library segments'
planted feet moved (their roll and settling, weighted), so the lock takes out only the slide
that fitting them to the context added: a fill that is a capture as it was stays so. A foot
the filled frames plant below the clip's own floor (where the context plants it) is raised
onto it over the gap (:func:`_onto_floor`).
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mocapkit.core import rotations as rot
from mocapkit.core.checks import check_field_types, whole_number
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton
from mocapkit.provenance import Provenance, Segment, TransitionTaken
from mocapkit.stitch.gait import gait_continued, stance_kept, with_gait
from mocapkit.stitch.kalman import DEFAULT_MODEL, ConstantAccelerationModel, smoother_matrix
from mocapkit.stitch.lscore import _search_kernel
from mocapkit.stitch.search import conform, feature_joint_indices, motion_features

__all__ = [
    "DEFAULT_CONFIG",
    "METHODS",
    "Candidate",
    "GapContext",
    "Inbetween",
    "InbetweenConfig",
    "InbetweenLibrary",
    "NoLibraryFitError",
    "check_gap",
    "fill_weights",
    "gap_context",
    "inbetween",
    "kalman_fill",
    "kalman_lscore",
    "library_fill",
    "neighbour_weights",
    "prepare_library",
    "search_inbetween",
    "search_inbetween_top",
    "window_lscores",
]


@dataclass(frozen=True)
class InbetweenConfig:
    """Every tunable of in-betweening, in physical units (converted to frames with the clip's
    frame time). Tuned on the held-out tenth of bandai2 (bench/bench_inbetween.py --tune).
    The figures quoted for ``backwards`` and ``blend_max_speed_deg`` were measured with the
    tuning take's style left out of the library (``--tune``, as the test's people and styles
    are not in it); the older ones with it in (``--tune --holdout none``)."""

    window_seconds: float = 1 / 6
    """L-score half window w (5 frames at 30 fps, stitching's default): enough frames for the
    smoother to see a velocity and an acceleration on each side of a junction."""
    warps: tuple[float, ...] = (0.8, 0.9, 1.0, 1.12, 1.25)
    """Speed factors of candidate segments (library time per clip time): people walk and run
    at speeds within about ±25% of one another's for the same gait."""
    travel_tolerance_m: float = 0.1
    """Ground-path difference (pelvis displacement over the gap, velocity at its start) that
    costs as much as ``travel_weight``: a tenth of a stride."""
    turn_tolerance_deg: float = 10.0
    """Heading-change difference over the gap that costs as much as ``travel_weight``."""
    travel_seconds: float = 0.5
    """Over a gap (A-1 to B) longer than this, the ground-path term's tolerances grow with its
    length: past half a second a path difference is judged as the change of speed and of
    turning rate it makes (:func:`_travel_rate_factor`)."""
    travel_weight: float = 1.0
    """Weight of the ground-path term (score units per squared tolerance). With the L-scores
    in the score, 5 beat 1 and 25 on the tuning takes; with the pose term instead, 1 (L2P over
    interpolation at 15 and 30 frames 0.34 and 0.37 on 24 tuning windows, 0.32 and 0.39 at 0)."""
    blend_seconds: float = 0.25
    """How long each end's pose offset takes to fade (inertialization; capped by the gap): long
    enough that removing the offset adds no visible acceleration, short enough that the middle
    of a long gap is the library's own motion (tuning takes, L2P / interpolation at 15 and 30
    frames: 0.61 and 0.48 at 0.25 s, 0.60 and 0.47 at 0.15 s with more foot skate, 0.70 and
    0.58 at 1 s)."""
    offset_keep: float = 0.35
    """Share of the two ends' mean pose offset (each joint's rotation, context less segment)
    held between the end blends, where the blends alone leave the segment's own pose; each end
    blends into it. Relies on: part of what sets a library person's poses apart from the
    clip's is the person (how they carry their arms, turn out their feet, lean), the same at
    both ends and in the frames between; the rest is the moment's (the step's phase) and
    fades. The mean of the two ends still holds some of the moment's, so only a share is held.
    A gap at the clip's start or end has one end, one measurement, and holds none. Tuning
    windows, the take's person left out of the library, at 15 / 30 / 45 frames:

    ===== ====================== ====================== ======================== ==============
    keep  L2P                    L2Q                    NPSS                     skate cm/s
    ===== ====================== ====================== ======================== ==============
    0     2.056 / 2.790 / 3.286  0.470 / 0.670 / 0.779  0.0417 / 0.1676 / 0.3261 33.2/33.0/33.7
    0.35  2.045 / 2.751 / 3.218  0.451 / 0.629 / 0.698  0.0391 / 0.1569 / 0.2845 32.7/32.4/32.8
    0.5   2.032 / 2.763 / 3.233  0.444 / 0.623 / 0.666  0.0382 / 0.1549 / 0.2723 32.5/32.2/32.2
    0.7   2.034 / 2.846 / 3.287  0.447 / 0.615 / 0.628  0.0388 / 0.1530 / 0.2509 32.3/31.6/32.2
    ===== ====================== ====================== ======================== ==============

    (the truth's skate 31.6; 0.7 measured before a joint's overlapping blends were made to
    span the gap, which moved 0.35 from 2.025 / 2.731 / 3.218). With its person and gait left
    out, L2P 2.616 / 3.674 / 4.499 at 0, 2.583 / 3.627 / 4.440 at 0.35, 2.564 / 3.636 / 4.452
    at 0.5, 2.556 / 3.725 / 4.504 at 0.7. 0.35 is better than 0 on every figure;
    more is better on all but L2P at 30 and 45 frames, the issue's weakest target. On
    one-sided gaps (end / start, 15 / 30 frames, person left out) holding a share of the one
    end's offset (half) cost L2P: 3.392 / 4.823 and 3.649 / 5.332 -> 3.403 / 4.885 and 3.693
    / 5.472."""
    blend_max_speed_deg: float = 90.0
    """Fastest a joint's end correction may turn (degrees per second): a larger offset fades
    over more frames than ``blend_seconds`` (up to the whole gap), so that removing it never
    turns a joint faster than this. A correction is not part of the motion; turning a joint
    quickly it adds a jolt that the captured motion does not have (and a spectrum that is not
    the motion's). 90°/s is slower than the hip and knee swing of a walk (a few hundred °/s).
    On the tuning takes (style left out of the library) at 15, 30 and 45 frames, NPSS over
    interpolation 0.77, 0.60, 0.73 without the limit, 0.68, 0.55, 0.68 at 180°/s, 0.65, 0.50,
    0.58 at 90°/s, 0.66, 0.51, 0.52 at 45°/s; L2P 0.47, 0.49, 0.52 without the limit, 0.47,
    0.50, 0.52 at 90°/s, 0.48, 0.51, 0.53 at 45°/s.

    The foot lock's corrections of the legs obeyed it too, and now obey their own limit
    (:attr:`lock_max_speed_deg`). The history: a hold let go of within a frame or
    two (near the gap's end the context's foot can be far from the fill's) snapped a knee from
    straight to 146° (newcomer report: a Bandai-1 walk filled at 80:110, knee acceleration 9.1
    cm/frame² against 1.9 unlocked; 5.1 with the limit, 7.5 at 270°/s). On the tuning takes
    this costs foot skate at 15, 30 and 45 frames (38.6, 39.3, 41.5 cm/s against 36.1, 36.3,
    38.5) for slightly lower L2P (2.160, 2.593, 3.164 against 2.170, 2.615, 3.181) and NPSS.
    A correction that turns the other way from one frame to the next is slowed too (newcomer
    report: Foot_L 40-81 deg in one frame on Bandai-1 walk-back/walk-left fills; now within 3
    deg of the fill's own largest step); tuning takes at 15, 30, 45 frames: L2P 2.160, 2.594,
    3.169 and foot skate 38.3, 38.8, 40.9 cm/s (38.6, 39.3, 41.5 before)."""
    lock_max_speed_deg: float = 360.0
    """Fastest the foot lock's corrections of the legs may turn (degrees per second), as
    :attr:`blend_max_speed_deg` limits the end offsets: a hold let go of within a frame or two
    snapped a knee (see there). Slower, the lock lags its holds and the feet slide; faster, the
    knees jolt, unless the corrections are smoothed (:attr:`lock_smooth_seconds`). Without
    smoothing (session 29), on the tuning windows (at 15 / 30 / 45 frames; the take's person
    and gait left out of the library): foot skate 35.4 / 36.7 / 43.1 cm/s at 90, 33.4 / 35.0 /
    41.2 at 180, 32.4 / 33.9 / 39.9 at 360, 32.3 / 33.7 / 39.5 without a limit (the truth's
    31.6); the legs' largest angular acceleration in a window (degrees per frame², median /
    99th percentile / largest) 12.4 / 21.9 / 38.2 at 90, 13.0 / 21.4 / 41.3 at 180, 14.6 / 32.7
    / 44.0 at 360, 14.6 / 43.9 / 70.6 without (the truth's 15.6 / 26.9 / 27.6); and on 12 whole
    Bandai-1 walks filled at 80:110 from bandai2, 180 raised the knees' largest acceleration
    from 3.7 to 4.4 cm/frame² on average, so 90 was kept. Smoothed over 1/30 s, on tuning
    takes filled whole (140 gaps of 15 and of 30 frames, full context, the person left out):
    the knees' largest acceleration in the filled frames averaged 2.68 / 3.24 cm/frame² at 90,
    2.69 / 3.30 at 135, 2.69 / 3.30 at 180 (over the take's own largest in 20 / 46, 21 / 48,
    21 / 49 gaps), the feet's near B 3.33 / 3.38, 3.37 / 3.40, 3.36 / 3.43; foot skate 34.2 /
    32.8, 32.9 / 32.0, 32.4 / 31.6 cm/s (the takes' own 31.9 / 32.2). On the benchmark's
    tuning windows 180 against 90 (both smoothed): foot skate at 5 / 15 / 30 / 45 frames 25.9
    / 34.7 / 36.4 / 40.6 -> 25.8 / 33.1 / 34.8 / 38.7 (person and gait left out) and 25.8 /
    31.8 / 32.1 / 32.1 -> 25.7 / 30.6 / 30.9 / 31.2 (person), L2P within 0.3%. 360 against
    180 (session 36, smoothed; at 15 / 30 frames): foot skate 33.09 / 34.80 -> 32.65 / 34.02
    cm/s (person and gait left out) and 30.55 / 30.91 -> 30.23 / 30.37 (person), L2P within
    0.1%, the legs' largest angular acceleration in a window (median / 99th percentile /
    largest, degrees per frame²) the same to 0.2 (12.6 / 25.4 / 25.6 and 13.3 / 32.3 / 38.8
    at 180, 12.8 / 25.4 / 25.6 and 13.4 / 32.3 / 38.8 at 360; the truth's 18.9 / 38.6 / 38.9
    and 20.7 / 40.1 / 43.2): smoothed, the faster limit adds no jolt, and the lock keeps up
    with its holds; 720 gave the same as 360."""
    lock_smooth_seconds: float = 1.0 / 30.0
    """The foot lock's corrections of the legs are smoothed over frames by a Gaussian this wide
    (its sigma, seconds; :func:`_smoothed_correction`; 0: off). Relies on: a captured joint
    turns smoothly, its speed changing over several frames (muscles do not switch force
    within a frame), while the correction's speed can switch within one, at the corners of
    :attr:`lock_max_speed_deg`'s limit and where the lock's hold fades out over
    :attr:`lock_ramp_seconds` before B; the foot at the end of the leg then jolts (newcomer
    report: a toe catching up in the last frames before B, 73 m/s² against 37 in the take).
    Tuning takes filled whole as a user fills them (25 bandai2 takes, the take's person left
    out of the library, gaps of 15 / 30 frames every 15 frames, 140 of each, full context):
    the feet's largest acceleration over frames B-4..B+1 averaged 3.88 / 3.92 cm/frame²
    unsmoothed, 3.33 / 3.38 at 1/30 s (the takes' own: 3.34 / 3.39), 3.30 / 3.36 at 2/30 s;
    gaps where it passed 1.5 times the take's own largest: 19 / 22 of 140, 5 / 10, 6 / 10;
    foot skate of the filled frames 34.7 / 33.3 cm/s, 34.2 / 32.8, 35.7 / 34.1 (the takes'
    own 31.9 / 32.2); mean joint error 2.620 / 4.429 cm, 2.610 / 4.420, 2.608 / 4.412. On the
    benchmark's windows (``--tune``, the person and gait left out; the person left out) at 1/30
    s, foot skate at 5 / 15 / 30 / 45 frames 26.1 / 35.5 / 36.8 / 41.0 -> 25.9 / 34.7 / 36.4 /
    40.6 and 25.9 / 32.5 / 32.5 / 32.6 -> 25.8 / 31.8 / 32.1 / 32.1 cm/s, L2P 0.855 / 2.327 /
    3.275 / 4.212 -> 0.848 / 2.312 / 3.290 / 4.218 and 0.722 / 1.913 / 2.579 / 3.121 -> 0.716
    / 1.906 / 2.597 / 3.114."""
    foot_lock: bool = True
    """Hold the feet the filled frames plant still (IK on the legs, :mod:`mocapkit.ik`): the
    ground warp and the end offsets move the whole body a little every frame, and the Kalman
    fallback glides, both of which slide a planted foot; a planted foot does not move. On the
    tuning takes it lowers the filled frames' foot skate at 30 frames from 35.6 to 31.9 cm/s
    (the takes' own: 32.5). A hold moves as the segments' own planted feet moved
    (:func:`_lock_feet` ``sources``): held still instead, a fill that was the clip's own take
    (the take in the library) moved by 7.4 cm (newcomer report); tuning takes at 5, 15, 30,
    45 frames, L2P 0.988, 2.125, 2.554, 3.128 and foot skate 28.9, 37.4, 38.6, 40.8 cm/s
    against 0.993, 2.160, 2.594, 3.169 and 29.1, 38.3, 38.8, 40.9 held still."""
    contact_at_ends: bool = True
    """A contact of the fill that reaches the gap's edge is the context's own where the context
    frame beside it has the foot low and slow (:func:`_planted_at_ends`): the lock anchors it
    where the context plants the foot. The detector cuts such a contact when the heel is
    already rising at B (newcomer report: a walk's 30-frame gap filled from runs held the left
    foot 16 cm behind where the take lifts it at B, then slid it there 3.5-4.2 cm a frame over
    the lock's fade-out; with the rule, held within 4 cm of the take's plant, at most 1.4 cm a
    frame). Tuning takes, whole takes as clips, 140 gaps of 15 and of 30 frames, the take's
    person left out of the library: foot skate 33.68 / 33.23 cm/s without, 33.70 / 33.25 with
    (the takes' own 31.85 / 32.19), mean joint error 2.604 / 4.514 cm without, 2.603 / 4.514
    with: it seldom fires, and changes nothing the benchmark measures (its windows have one
    future frame, too few to tell the foot's speed at B)."""
    lock_context_seconds: float = 0.5
    """Context on each side of the gap seen by the contact detector (a contact that began
    before the gap is held where it began)."""
    lock_ramp_seconds: float = 1.0 / 15.0
    """The foot lock fades in after the last past frame and out before the first future frame,
    so the context frames are untouched and the junctions do not pop. A foot is only partly
    held while its hold fades, so on a short gap a long fade leaves most of it loosely held (at
    30 fps and 0.1 s, a 5-frame gap's frames were held at weights 0.16 / 0.5 / 0.84 / 0.5 /
    0.16; at 1/15 s 0.26 / 0.74 / 1 / 0.74 / 0.26). Since the
    corrections are rate-limited and smoothed (:attr:`lock_max_speed_deg`,
    :attr:`lock_smooth_seconds`), a shorter fade adds no jolt. Tuning windows at 5 / 15 / 30
    frames, the take's person left out of the library, 0.1 s against 1/15 s: foot skate 25.67
    / 30.23 / 30.37 -> 24.61 / 29.35 / 29.96 cm/s (the truth's 27.12 / 31.57 / 31.58), L2P
    0.724 / 1.912 / 2.605 -> 0.745 / 1.922 / 2.612, the legs' largest angular acceleration in
    a window (median / 99th percentile, deg/frame²) at 15 / 30 frames 13.3 / 25.2 and 13.0 /
    22.1 -> 13.5 / 25.2 and 13.0 / 22.1 (the truth's 18.9 / 38.6 and 20.7 / 40.1); its person
    and gait left out, foot skate 25.79 / 32.65 / 34.02 -> 24.74 / 31.71 / 33.67, L2P 0.848 /
    2.316 / 3.296 -> 0.862 / 2.325 / 3.303, the acceleration 12.8 / 25.4 and 13.4 / 32.3 ->
    13.1 / 25.4 and 13.4 / 32.3. (1/30 s: L2P 4% over 0.1 s's at 5 frames.) Tuning takes
    filled whole as a user fills them (25 bandai2 takes, the take's person left out of the
    library, full context; 165 gaps of 15 frames, 75 of 30): the feet's largest acceleration
    over B-4..B+1 averaged 3.43 / 3.48 -> 3.44 / 3.53 cm/frame² (the takes' own 3.62 / 3.62),
    over 1.5 times the take's own in 0 / 3 -> 0 / 4 gaps; foot skate 30.79 / 30.69 -> 30.39
    / 30.38 cm/s (the takes' own 32.12 / 32.04), mean joint error 1.374 / 3.084 -> 1.379 /
    3.088 cm."""
    fallback: bool = True
    """Fill with the Kalman transition when the library fill's two-sided L-score is more than
    ``fallback_margin`` times the Kalman transition's own, or when the best segment is unlike
    the motion around the gap (the warning of :attr:`poor_fit_path_m` and
    :attr:`poor_fit_pose_m`), on gaps of up to ``kalman_max_seconds`` only. Relies on: a
    segment unlike the context is a guess from other motion, while over a gap this short the
    smoother's path between the clip's own poses keeps the clip's motion (newcomer report: a
    Bandai-1 back walk's 6-frame gap from a library of one run, warned about, kept: mean
    acceleration 9.4 m/s² in the gap against the take's 4.7, largest joint error 17 cm; the
    Kalman transition 4.7 m/s² and 2.4 cm). On the tuning windows with hand gestures as the
    library, the Kalman transition from one future frame was the closer fill at 5 frames
    (:attr:`poor_fit_path_m`)."""
    fallback_margin: float = 4.0
    """See :attr:`fallback` and the module docstring (Fallback): above every ratio seen on the
    tuning takes where the library fill was the better one."""
    kalman_max_seconds: float = 0.3
    """Longest gap the Kalman transition fills (asked for, or as the fallback): its
    constant-acceleration model carries the end frames' accelerations across the gap, so its
    error grows with the square of the gap's length. On the tuning windows (every take of the
    tuning take's person left out of the library) its L2P against interpolation's was 0.72 /
    1.18 at 3 frames, 1.46 / 2.18 at 5, 3.18 / 3.61 at 8, 4.60 / 4.06 at 10, 8.81 / 4.78 at
    15 and 13.25 / 5.04 at 20: past about 0.3 s it strays further than a straight
    interpolation, and over 290 frames it put a walker's pelvis 3 m below the floor (newcomer
    report). A longer gap with no library fill is refused, and "auto" keeps the library fill."""
    pose_weight: float = 2.0
    """Weight of the pose term: the candidate's body-local poses at i = -1, 0 (on the last two
    past frames A-2, A-1) and g+1 (on the first future frame B) against the context's. Chosen
    again once the fill carried the context's velocities (session 27; tuning windows, L2P at
    5 / 15 / 30 / 45 frames): with the take's person left out of the library 0.734 / 2.074 /
    2.868 / 3.430 at 1, 0.751 / 2.056 / 2.790 / 3.286 at 2, 0.742 / 2.080 / 2.758 / 3.255 at 3,
    0.759 / 2.164 / 2.942 / 3.552 at 0.5; with its person and gait left out 0.955 / 2.644 /
    3.790 / 4.582 at 1, 0.940 / 2.616 / 3.674 / 4.499 at 2. The foot skate rose by up to 0.6
    cm/s at 30 and 45 frames."""
    pose_tolerance_m: float = 0.05
    """Per-joint RMS position difference that costs as much as ``pose_weight`` per frame."""
    bob_weight: float = 1.0
    """Weight of the bob term: the pelvis' vertical acceleration and speed over the candidate's
    frames on A-1-2k, A-1-k, A-1 against the context's (:func:`_bob_costs`;
    :attr:`bob_span_seconds`). Relies on: at a walk the pelvis rises and falls once per step,
    lowest just after a foot strikes and highest at mid-stance, nearly a sinusoid, whose
    acceleration (its height about the level times minus the square of its angular frequency)
    and speed fix the bob's phase and size whatever the level. The pose term compares heights,
    and people's pelvis levels differ by about as much as the bob itself (1-2 cm; Bandai-2
    walks: 0.6 cm standard deviation between takes), so a library person standing lower matches
    the context's rise with their own top. A run's flight is a free fall (-g whatever its
    phase), so the term tells a run's phase less well: the tuning's run windows are worse with
    it when the library holds runs (below). The benchmark's L2P is mostly the trunk's and
    knees' heights (the library's spread of them is 2-3 cm; 75-84% of the squared error), so a
    fill bobbing out of phase is its largest error. Tuning windows, L2P at 5 / 15 / 30 / 45
    frames, with the take's person and gait left out of the library: 0.940 / 2.583 / 3.627 /
    4.440 without the term, 0.917 / 2.460 / 3.419 / 4.400 with the acceleration alone, 0.875 /
    2.451 / 3.376 / 4.347 with the speed too; with its person left out: 0.751 / 2.045 / 2.751 /
    3.218, 0.740 / 2.009 / 2.758 / 3.281 and 0.743 / 1.999 / 2.718 / 3.272 (its 11 run windows
    worse: 2.862 / 4.428 at 15 / 30 frames without, about 3.1 / 4.7 with the acceleration).
    The acceleration's weight over its squared tolerance (the speed not yet in it; 0.51 per
    (m/s²)² by default): 0.25, 0.5, 1 and 4 gave 2.500 / 3.462, 2.456 / 3.403, 2.454 / 3.378 and
    2.479 / 3.380 at 15 / 30 frames (person and gait left out). Its cost: L2Q at 15 frames 0.489
    -> 0.522 (person and gait left out) and 0.451 -> 0.473 (person), NPSS at 15 frames 0.0461
    -> 0.0508 and 0.0391 -> 0.0421; at 30 and 45 frames both are about the same. (The
    figures with the acceleration alone and with the speed were measured with the foot lock at
    180 deg/s, the sweep of weights at 90; with the defaults,
    0.874 / 2.441 / 3.371 / 4.343 with the person and gait left out, 0.738 / 1.993 / 2.712 /
    3.267 with the person.)"""
    bob_tolerance_m_s2: float = 1.4
    """Pelvis vertical acceleration difference that costs as much as :attr:`bob_weight`:
    about half the peak of a walk's (3 m/s²)."""
    bob_speed_tolerance_m_s: float = 0.2
    """Pelvis vertical speed difference (over the same frames) that costs as much as
    :attr:`bob_weight`. The acceleration is the same on the bob's way up and its way down (the
    height about the level, times minus the square of its angular frequency); the speed tells
    them apart, and does not depend on the level either (reviewer: a context falling through
    its bob got a rising candidate). About the peak of a walk's (0.02 m at 12 rad/s: 0.25
    m/s). Tuning windows (foot lock at 180 deg/s), L2P at 5 / 15 / 30 / 45 frames, the take's
    person and gait left out:
    0.917 / 2.460 / 3.419 / 4.400 without (acceleration only), 0.851 / 2.489 / 3.399 / 4.370
    at 0.1, 0.875 / 2.451 / 3.376 / 4.347 at 0.2; its person left out: 0.740 / 2.009 / 2.758 /
    3.281 without, 0.736 / 2.081 / 2.682 / 3.202 at 0.1, 0.743 / 1.999 / 2.718 / 3.272 at 0.2
    (NPSS at 15 frames 0.0494 -> 0.0508 and 0.0403 -> 0.0421 at 0.2). 0: acceleration only."""
    bob_span_seconds: float = 1 / 15
    """The bob term's acceleration and speed are measured over three frames this far apart end
    to end (three frames in a row at 30 fps, every fourth at 120 fps): the bob's period is
    about half a second, and the heights of frames closer together differ by little more than
    the noise of the capture (a second difference of three frames in a row at 120 fps turns
    0.5 mm of noise into about 17 m/s²). Where a candidate's clip, or the context, has fewer
    frames before A-1, the span is as long as they have: noisier, on a clip's first frames
    and on gaps that start a fraction of a second into the clip."""
    lscore_weight: float = 0.0
    """Weight of the two L-scores in the candidate score (module docstring: why 0)."""
    poor_fit_path_m: float = 0.5
    """The best segment's ground path (the ground-path term in metres: displacement and start
    velocity over the gap, a turn counting ``travel_tolerance_m`` per ``turn_tolerance_deg``)
    missing the context's by more than this makes the result carry a warning that the library
    holds nothing like the motion around the gap. On the tuning windows (15 and 30 frames) the
    best segment of the locomotion library (their style left out) missed by at most 0.25 m,
    of a library of hand gestures by more than 0.5 m in 89% and 100% of them. The poses at
    the gap's ends tell less (up to 10.8 cm RMS per joint from the locomotion library, 6.6 cm
    or more in 95% of windows from the gestures; a limit on them warned about no window the
    path did not) and are judged on their own bound (:attr:`poor_fit_pose_m`). Only a
    warning: on those windows
    the fill from the gestures was still closer to the truth (L2P) than the Kalman transition
    from one future frame at every length but 5 frames. A gap over about 1.4 s is judged by
    :attr:`poor_fit_speed_m_s` instead."""
    poor_fit_pose_m: float = 0.12
    """At a gap at the clip's start or end, the best segment's poses (RMS per joint, body-local)
    missing the context's beside the gap by more than this also make the warning: there is no
    arrival to judge the path by, only the start velocity (newcomer report: a dance's end
    filled from walks, 18.6 cm off, and a CMU playground take's start, 23 cm off, did not
    warn). Tuning windows (the take's person left out; 15 and 30 frames), the best segment of
    the locomotion library missed by at most 9.8 cm, of hand gestures by more than 12 cm in
    50-86% of them (per motion class). A gap with context on both sides is judged by its poses
    too (newcomer report: a run's gap filled from walks, 15.5 cm off at the gap's ends, its
    toes sinking 2.4 cm and sliding, did not warn; its path was close): there the best
    locomotion segment missed by at most 11.5 cm, the gestures' by more than 12 cm in 62-89%."""
    poor_fit_speed_m_s: float = 0.35
    """On a long gap, the warning's bound (:attr:`poor_fit_path_m`) grows with the gap: the path
    missed by more than this many metres per second of gap. A good segment's small difference
    of speed adds up over a long gap (newcomer report: a 4 s gap warned of "nothing like" a walk
    filled from walks). Tuning windows (the take's person left out), best segment's miss per
    second of gap at 2, 3 and 4 s: from the locomotion library at most 0.21, 0.21, 0.18 m/s
    (over 0.5 m in 8% and 14% of windows at 3 and 4 s), from hand gestures at least 0.56, 0.57,
    0.54 m/s; 0.35 m/s is about their geometric mean."""
    neighbours: int = 12
    """How many of the best non-overlapping candidates fill the gap together: each is
    ground-warped and end-blended on its own, then their poses are combined (rotations by
    normalised weighted quaternion sum, translations by weighted mean) with the weights of
    :func:`fill_weights`. Twelve since that regression (:attr:`regression_rank`), which needs
    more candidates than directions to fit. As a plain mean (rank 0), on the tuning windows
    (``--tune``: the take's person and gait left out; its person left out), L2P at 5 / 15 /
    30 / 45 frames was 0.874 / 2.441 / 3.371 / 4.343 and 0.738 / 1.993 / 2.712 / 3.267 with
    six, 0.853 / 2.409 / 3.369 / 4.231 and 0.712 / 1.981 / 2.672 / 3.236 with twelve; regressed
    over twelve, see :attr:`regression_rank`. Earlier (foot lock off, the style left out): L2P
    1.02, 2.19, 2.71, 3.33 with three, 1.00, 2.19, 2.64, 3.24 with six, 0.97, 2.21, 2.63, 3.29
    with ten; foot skate up to 2 cm/s higher with six, up to 4 cm/s with ten. Where the
    library holds no segment like the gap, the neighbours disagree and their combination is
    the better guess."""

    regression_rank: int = 3
    """Main directions of the candidates' mismatches the fill is regressed on
    (:func:`fill_weights`; at most the number of candidates less 2); 0: the score-weighted mean
    of the fills. Tuning windows (``bench_inbetween.py --tune``), L2P at 5 / 15 / 30 / 45
    frames, the take's person and gait left out of the library: 0.874 / 2.441 / 3.371 / 4.343
    as the mean of six, 0.855 / 2.327 / 3.275 / 4.212 regressed over twelve at rank 3, 0.857 /
    2.328 / 3.261 / 4.245 at rank 2; the person left out: 0.738 / 1.993 / 2.712 / 3.267, 0.722
    / 1.913 / 2.579 / 3.121, 0.721 / 1.930 / 2.616 / 3.174. L2Q and NPSS lower at every
    length, foot skate within 0.4 cm/s but at 45 frames (-2.4 and +0.9). Chosen first on the
    averaged segments alone (no pelvis level, no foot lock), ranks 1-5 over 8-20 candidates,
    ridge 0.0006-0.007 m: twelve at rank 3 was within 1% of the best everywhere."""
    regression_ridge_m: float = 0.007
    """Ridge of that regression (metres, RMS over the mismatch's coordinates, squared where it
    is added to the candidates' weighted spread along each direction): about the spread of
    close candidates' mismatches, so that a direction they hardly spread along is not
    extrapolated on. Tuning windows, L2P at 5 / 15 / 30 / 45 frames (person and gait left out;
    person left out): 0.012 m 0.844 / 2.326 / 3.280 / 4.200 and 0.712 / 1.916 / 2.602 / 3.143,
    0.02 m 0.841 / 2.352 / 3.310 / 4.210 and 0.710 / 1.935 / 2.629 / 3.173 (0.007 m: see
    :attr:`regression_rank`); on the segments alone, 0.004 m was 0.6% worse than 0.007."""
    average_max_seconds: float = 1.5
    """Longest gap filled by averaging :attr:`neighbours` segments; a longer one is filled by
    the best segment alone. Segments of slightly different cadences drift out of step over a
    few strides, and their average foot creeps on where each of theirs rests (newcomer: a 4 s
    gap filled by a shuffle, toes sliding 3 cm a frame and 3.6 cm below the floor). On the
    tuning windows (the take's person left out of the library; 101-frame windows), foot skate
    of the filled frames at 30 / 60 / 90 frames was 36.5 / 42.3 / 52.6 cm/s averaging six,
    37.1 / 41.2 / 48.4 averaging three, 36.2 / 40.3 / 44.3 averaging two and 34.2 / 33.1 /
    31.6 from the best alone, against the takes' own 32.3 / 32.3 / 32.7; L2P 2.59 / 3.69 /
    4.59 averaging six, 2.68 / 4.30 / 5.04 alone. Averaging was chosen on gaps of up to 45
    frames (1.5 s), where it lowers L2P; past that the shuffle is what a user sees."""
    average_min_motion: float = 0.7
    """The share of their own motion the combined segments must keep, or the best segment
    fills the gap alone (:func:`motion_kept`: how far the joints swing about their mean pose,
    the combination against the segments' weighted mean), where the clip stands
    (:data:`STANDING_SPEED_M_S`). Relies on: the segments' end offsets bring them into step at
    the gap's ends only; in between, a gesture's strokes (a wave, a beckon) fall where each
    performance put them, at each segment's own tempo and time warp, and their average cancels
    the strokes it should show (newcomer: a Bandai-1 wave filled from bandai2's waves kept 47%
    of the hand's path, and its L-score, lower for less motion, called it smoother). Steps do
    not: the search matches them at both ends, so they stay in step. Tuning gesture takes
    (bandai2's tenth, the person left out of the library; 93 gaps of 15, 30 and 45 frames):
    the combination kept 0.87 in the median gap (5th percentile 0.46); at 0.7, 22 went to one
    segment, and the waves' hand path over the truth's (median by class) went 0.73 / 0.77 /
    0.96 -> 0.88 / 0.84 / 0.97 (right / left / both hands), their joint error 0.56 / 1.02 / 1.38
    -> 0.56 / 1.14 / 1.24 cm. (A first measure, the joints' path length, read a combination's
    jitter as motion: a wave combined to 58% of its hand path read as 108% kept.)"""
    level_seconds: float = 0.5
    """The pelvis keeps the clip's own level across the gap (:func:`_level_offset`, the feet
    kept on the ground by :func:`_to_level`): the level is the mean pelvis height over this
    long before the gap (half a gait cycle at a walk: one whole bob), or over as much of it as
    the clip has before the gap (the benchmark's 10 past frames: 0.33 s), the difference then
    held by the share of this span measured (two thirds in the benchmark). 0: off (the middle
    of the gap at the segment's level)."""
    backwards: bool = True
    """Search every library clip played backwards as well. Walking backwards is close to
    forward walking played backwards: the joint-angle patterns of the leg in backward walking
    are approximately the time-reverse of forward walking's (Thorstensson 1986; Grasso et al.
    1998), so a library of forward steps also holds backward steps. Gravity makes a reversed
    fall or jump implausible, but such segments do not continue a context that walks; a
    reversed segment is chosen only when it scores best. On the tuning takes (all forward,
    their style left out of the library) it changes L2P over interpolation by at most 0.01 at
    every length; what it is for, backward walks, the tuning split does not hold."""

    gait_share: float = 0.3
    """The share of the fill's body-local pose taken from the clip's own gait carried on
    through the gap (:mod:`mocapkit.stitch.gait`: the past frames, alternately mirrored, half a
    gait cycle apart), where the clip travels (:data:`STANDING_SPEED_M_S`), has frames on both
    sides of the gap and the gap is at least the shortest half cycle tried
    (:attr:`gait_half_period_seconds`: a shorter gap is carried by its context); less where the
    library's best segment arrives at the first future frame closer than the gait does
    (:func:`_gait_share`). The ground path, the heading and the feet the segments plant stay
    the library's (:func:`mocapkit.stitch.gait.stance_kept`). 0: off. Relies on: steady
    locomotion is periodic and left/right symmetric, so the context's own frames predict the
    person's, style's and gait's steps, which a library may not hold.

    Chosen on the tuning windows (benchmark ``--tune``), L2P at 15 / 30 / 45 frames, off ->
    0.3: the take's gait and person left out of the library 2.225 / 2.766 / 3.471 -> 2.005 /
    2.580 / 3.393, its person left out 1.859 / 2.299 / 2.828 -> 1.722 / 2.217 / 2.818; foot
    skate 29.2 / 30.5 / 30.9 -> 28.1 / 30.4 / 31.6 and 26.5 / 27.6 / 26.7 -> 26.1 / 28.4 /
    28.6 cm/s (5 frames unchanged). 0.4 (before the rule on the misses): 30 frames 2.577 and
    2.261, 45 frames worse on both. Blended without keeping the planted feet, the skate at 30
    and 45 frames rose by 3-5 cm/s (a planted foot blended with a swinging one slides); held
    on and off without a fade, by 1.6-4.3 cm/s."""
    gait_half_period_seconds: tuple[float, float] = (0.25, 0.8)
    """The half gait cycles tried by :attr:`gait_share`'s prediction: a dash's step to a slow
    walk's."""
    gait_temperature: float = 0.5
    """How sharply :attr:`gait_share`'s prediction prefers the half period that best predicts
    the first future frame (:func:`mocapkit.stitch.gait.gait_continued`)."""

    own_frames: bool = True
    """Search the clip's own frames beside the gap too (each stretch of at least
    :data:`OWN_PIECE_MIN_SECONDS`, :func:`own_pieces`), as library clips named as the clip:
    its own steps are its person's, style's and gait's, which a library may hold none of.
    Relies on: a person repeats their steps over a take (a walk, a run, a back or side walk
    is periodic). Bandai-1 back and side walks (none of which the library holds) filled at
    30-frame gaps from bandai2's walks and runs: mean joint error 4.9-5.6 cm from the library
    alone, 2.0-2.2 with the take's own frames (module docstring). The LaFAN1 benchmark's
    context is shorter than a stretch worth searching, so its figures are the library's
    alone."""

    def __post_init__(self) -> None:
        check_field_types(self)
        object.__setattr__(self, "neighbours", int(self.neighbours))
        object.__setattr__(self, "regression_rank", int(self.regression_rank))
        if not (self.lock_context_seconds >= 0 and self.lock_ramp_seconds >= 0):
            raise ValueError("lock_context_seconds and lock_ramp_seconds must be >= 0")
        if not (self.window_seconds > 0 and self.blend_seconds >= 0):
            raise ValueError("window_seconds must be > 0 and blend_seconds >= 0")
        if not (self.blend_max_speed_deg > 0 and self.lock_max_speed_deg > 0):
            raise ValueError("blend_max_speed_deg and lock_max_speed_deg must be > 0")
        if not (math.isfinite(self.lock_smooth_seconds) and self.lock_smooth_seconds >= 0):
            raise ValueError(f"lock_smooth_seconds must be >= 0, got {self.lock_smooth_seconds}")
        if not self.warps or any(not (0.25 <= r <= 4.0) for r in self.warps):
            raise ValueError(f"warps must be speed factors in [0.25, 4], got {self.warps}")
        if not (self.travel_tolerance_m > 0 and self.turn_tolerance_deg > 0):
            raise ValueError("travel and turn tolerances must be > 0")
        if not (self.travel_weight >= 0 and self.travel_seconds >= 0):
            raise ValueError(
                f"travel_weight and travel_seconds must be >= 0, got {self.travel_weight} and "
                f"{self.travel_seconds}"
            )
        if not (self.pose_weight >= 0 and self.lscore_weight >= 0 and self.pose_tolerance_m > 0):
            raise ValueError("pose_weight and lscore_weight must be >= 0, pose_tolerance_m > 0")
        if not (
            self.bob_weight >= 0
            and self.bob_tolerance_m_s2 > 0
            and self.bob_span_seconds > 0
            and self.bob_speed_tolerance_m_s >= 0
        ):
            raise ValueError(
                "bob_weight and bob_speed_tolerance_m_s must be >= 0, bob_tolerance_m_s2 and "
                "bob_span_seconds > 0"
            )
        if not (
            self.poor_fit_path_m > 0 and self.poor_fit_speed_m_s > 0 and self.poor_fit_pose_m > 0
        ):
            raise ValueError(
                "poor_fit_path_m, poor_fit_speed_m_s and poor_fit_pose_m must be > 0, got "
                f"{self.poor_fit_path_m}, {self.poor_fit_speed_m_s}, {self.poor_fit_pose_m}"
            )
        if not (math.isfinite(self.level_seconds) and self.level_seconds >= 0):
            raise ValueError(f"level_seconds must be >= 0, got {self.level_seconds}")
        if not (math.isfinite(self.average_max_seconds) and self.average_max_seconds >= 0):
            raise ValueError(f"average_max_seconds must be >= 0, got {self.average_max_seconds}")
        if not (math.isfinite(self.kalman_max_seconds) and self.kalman_max_seconds >= 0):
            raise ValueError(f"kalman_max_seconds must be >= 0, got {self.kalman_max_seconds}")
        if not (math.isfinite(self.average_min_motion) and self.average_min_motion >= 0):
            raise ValueError(f"average_min_motion must be >= 0, got {self.average_min_motion}")
        if not self.fallback_margin > 0:
            raise ValueError(f"fallback_margin must be > 0, got {self.fallback_margin}")
        if not self.neighbours >= 1:
            raise ValueError(f"neighbours must be an int >= 1, got {self.neighbours!r}")
        if not (self.regression_rank >= 0 and self.regression_ridge_m > 0):
            raise ValueError(
                "regression_rank must be >= 0 and regression_ridge_m > 0, got "
                f"{self.regression_rank!r}, {self.regression_ridge_m!r}"
            )


DEFAULT_CONFIG = InbetweenConfig()

METHODS = ("auto", "library", "kalman")
"""How :func:`inbetween` fills the gap (see there)."""


# --------------------------------------------------------------------------------- checks


def check_gap(
    gap, num_frames: int, name: str = "clip", fps: float | None = None
) -> tuple[int, int]:
    """``(A, B)`` of a gap given as ``(A, B)`` or ``"A:B"`` (frames A..B-1 replaced; either end
    may be a time such as ``"2.0s:3.0s"``, read at ``fps``, the clip's frame rate, or left out
    for the clip's own: ``":B"``, ``"A:"``), or a
    ValueError saying what is expected: 3 <= A < B < num_frames (three past frames set the
    smoother's prior and give the pose and velocity to continue, and at least one future frame
    is needed to lead into); or a gap at the clip's start, 0:B with B <= num_frames - 3, or at
    its end, A:num_frames with A >= 3, filled from the one side that has context
    (:func:`inbetween`)."""
    mixed = ""
    if isinstance(gap, str):
        from mocapkit.core.ranges import RangeSpec

        spec = RangeSpec.parse(gap, "gap")
        if fps is None and any(e is not None and e.seconds for e in (spec.start, spec.stop)):
            raise ValueError(f"gap {gap!r} is in seconds: the clip's frame rate is needed")
        # an open end is the clip's (":30" its first 30 frames, "165:" from frame 165 on)
        a, b = spec.frames(1.0 if fps is None else fps, num_frames if spec.stop is None else None)
        if spec.start is not None and spec.stop is not None and (
            spec.start.seconds != spec.stop.seconds
        ):  # said where the gap is refused (newcomer: 80:90s "runs past the clip's end")
            mixed = (
                f"; {spec.start} and {spec.stop} are in different units: {spec.stop} is "
                f"{'a time' if spec.stop.seconds else 'a frame number'}"
            )
    else:
        try:
            a, b = (whole_number(x, "a gap end") for x in gap)
        except (TypeError, ValueError):
            raise ValueError(f"gap must be (A, B) in whole frames or 'A:B', got {gap!r}") from None
    F = num_frames
    if F < 4:  # 3 context frames and one gap frame: no gap can fit
        raise ValueError(
            f"{name}: the clip has {F} frame(s); filling a gap needs at least 4 (3 context "
            "frames beside the gap and one in it)"
        )
    at_start = a == 0 and 0 < b <= F - 3
    at_end = b == F and 3 <= a < F
    if not (3 <= a < b < F or at_start or at_end):
        # a gap given with a time says which frames that was (60:90s is frames 60:2700)
        given = (
            f"gap {gap} (frames {a}:{b}{mixed})"
            if isinstance(gap, str) and "s" in gap
            else (f"gap {a}:{b}")
        )
        if a == 0 and b == F:
            raise ValueError(f"{name}: {given} is the whole clip: there is no context to fill from")
        seconds = f", {F / fps:.4g} s at {fps:.4g} fps" if fps else ""
        if b > F:
            why = f"it runs past the clip's end ({F} frames{seconds}); "
        elif 0 < a < 3:
            why = f"only {a} frame{'s' if a > 1 else ''} of the clip before it, 3 needed; "
        elif a == 0 and b > F - 3:
            why = f"only {F - b} frame{'' if F - b == 1 else 's'} of the clip after it, 3 needed; "
        else:
            why = ""
        raise ValueError(
            f"{name}: {given}: {why}expected 3 <= A < B < {F} (it has {F} frames; 3 context "
            f"frames are needed before the gap and 1 after it), or a gap at its start, 0:B with "
            f"B <= {F - 3}, or at its end, A:{F} with A >= 3 (3 context frames on the other "
            "side)"
        )
    return a, b


# --------------------------------------------------------------------------------- library


@dataclass(frozen=True, eq=False)
class _Warped:
    """The library resampled at one speed factor: arrays over the concatenated clips."""

    rate: float
    feats: np.ndarray  # (N, m) float32 body-local features
    ground: np.ndarray  # (N, 2) pelvis ground position
    heading: np.ndarray  # (N,) heading, unwrapped within each clip
    clip: np.ndarray  # (N,) clip index
    time: np.ndarray  # (N,) fractional frame of the clip
    pelvis: np.ndarray | None = None  # (N,) pelvis height (file units); None: no bob term


@dataclass(frozen=True, eq=False)
class InbetweenLibrary:
    """Library motions prepared for :func:`search_inbetween`: on the clip's skeleton and frame
    time, ground root on the body's path, features and ground paths per warp."""

    motions: tuple[Motion, ...]
    names: tuple[str, ...]
    up: str
    warped: tuple[_Warped, ...]
    frames: int
    backwards: tuple[bool, ...] = ()
    """Per motion: True where it is a library clip played backwards (same name; its frame t is
    the clip's frame ``F - 1 - t``; :attr:`InbetweenConfig.backwards`)."""
    file_frames: tuple[float, ...] = ()
    """Per motion: frames of its file per frame here (its file's rate over the clip's: a file
    at another rate is resampled to the clip's)."""
    floors: tuple[np.ndarray, ...] = ()
    """Per motion: (J,) the height at which it plants each foot joint (:func:`_planted_heights`,
    NaN for the other joints), the floor its feet's clearance is measured from."""
    first_frames: tuple[int, ...] = ()
    """Per motion: the frame of its file that is its frame 0 (0 but for a piece of the clip
    itself, :func:`with_own_frames`)."""
    reversed_copies: tuple[int, ...] = ()
    """Per motion: the index of the same frames played the other way; empty where the
    motions are laid out as :func:`prepare_library` lays them (every clip forwards, then every
    clip backwards in the same order: :meth:`reversed_of`)."""

    def reversed_of(self, clip: int) -> int:
        """The index of motion ``clip`` played the other way (the library searched both ways)."""
        if self.reversed_copies:
            return self.reversed_copies[clip]
        n = len(self.motions) // 2
        return (clip + n) % (2 * n)

    def clip_frames(self, clip: int, start: int, stop: int) -> tuple[int, int]:
        """Frames ``start:stop`` of library motion ``clip`` as frames of the file it came from
        (its own frame numbers, ascending, stop excluded): reversed for a clip played
        backwards, scaled for a file at another frame rate."""
        if self.backwards and self.backwards[clip]:
            F = self.motions[clip].num_frames
            start, stop = F - stop, F - start
        k = self.file_frames[clip] if self.file_frames else 1.0
        first = self.first_frames[clip] if self.first_frames else 0
        return first + round(start * k), first + max(round(stop * k), round(start * k) + 1)

    def warp(self, rate: float) -> _Warped:
        for w in self.warped:
            if math.isclose(w.rate, rate):
                return w
        raise KeyError(rate)


def _interp_rows(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Rows of ``x`` (F, ...) linearly interpolated at fractional frames ``t`` (n,)."""
    i0 = np.clip(np.floor(t).astype(np.int64), 0, x.shape[0] - 1)
    i1 = np.minimum(i0 + 1, x.shape[0] - 1)
    f = (t - i0).reshape((-1,) + (1,) * (x.ndim - 1))
    return x[i0] * (1.0 - f) + x[i1] * f


def _leg_length(motion: Motion) -> float | None:
    """Hip-to-ankle length of the first leg at the first frame (file units), None without."""
    from mocapkit.body import body_of

    body = body_of(motion)
    hips, ankles = body.both("hip"), body.both("ankle")
    if not hips or not ankles or motion.num_frames == 0:
        return None
    tr = motion.local_translations()[0]
    sk = motion.skeleton
    for ank in ankles:
        chain = [ank, *sk.ancestors(ank)]
        for h in hips:
            if h in chain[1:]:
                return float(sum(np.linalg.norm(tr[j]) for j in chain[: chain.index(h)]))
    return None


def _fit_proportions(m: Motion, original: Motion, reference: Motion) -> Motion:
    """``m`` (a library motion already on ``reference``'s skeleton) with ``reference``'s bone
    lengths: the local translations of the joints below the pelvis's chain are the reference's
    (first frame), and the root motion (root and pelvis translations) is scaled by the ratio of
    the two people's leg lengths, so a taller actor's pelvis does not float above the clip's
    feet and its strides shrink to the clip's person. Relies on bones not changing length
    during a take (rigid segments)."""
    from mocapkit.body import body_of

    ref_leg, lib_leg = _leg_length(reference), _leg_length(original)
    ratio = ref_leg / lib_leg if ref_leg and lib_leg else 1.0
    pel = body_of(reference).pelvis
    carry = {pel, *reference.skeleton.ancestors(pel)}
    out = m.copy()
    tr = out.local_translations()
    ref_tr = reference.local_translations()[0]
    body_rows = [j for j in range(reference.num_joints) if j not in carry]
    tr[:, body_rows] = ref_tr[body_rows]
    rows = sorted(carry)
    tr[:, rows] *= ratio
    out.root_positions = m.root_positions * ratio
    tr[:, 0] = out.root_positions
    if m.translations is not None or reference.translations is not None:
        out.translations = tr
    return out


def prepare_library(
    motions: Sequence[Motion],
    reference: Motion,
    names: Sequence[str] | None = None,
    *,
    up: str | None = None,
    config: InbetweenConfig = DEFAULT_CONFIG,
) -> InbetweenLibrary:
    """The library of ``motions`` for in-betweening clips like ``reference``: each conformed to
    its skeleton and frame time (:func:`mocapkit.stitch.search.conform`; ValueError naming the
    clip when the joints differ) and to its person's proportions (bone lengths from the
    reference, root motion scaled by leg length), ground root put on the body's path,
    body-local features, pelvis ground path and heading computed, then resampled at every warp
    of ``config``. With ``config.backwards`` every clip is also searched played backwards."""
    from mocapkit import features

    if not motions:
        raise ValueError("the library is empty")
    names = [f"library{i}" for i in range(len(motions))] if names is None else list(names)
    if len(names) != len(motions):
        raise ValueError(f"{len(names)} names for {len(motions)} library motions")
    up = up or features.detect_up_axis(reference)
    prepped, feats, ground, heading, floors = [], [], [], [], []
    scale = [reference.frame_time / m.frame_time for m in motions]
    for m, n in zip(motions, names, strict=True):
        if m.num_frames == 0:
            raise ValueError(f"{n}: the library clip has no frames")
        m.check_finite(n)
        m = _fit_proportions(conform(m, reference, n), m, reference)
        m = features.ground_root_on_path(m, up)
        prepped.append(m)
        feats.append(motion_features(m, up).astype(np.float32))
        ground.append(features.root_trajectory(m, up))
        heading.append(features.heading_angles(m, up, unwrap=True))
        floors.append(_planted_heights(m, up))
    played = [False] * len(prepped)
    if config.backwards:  # per-frame features: a clip played backwards has them reversed
        prepped += [m[::-1] for m in prepped]
        for x in (feats, ground, heading):
            x += [np.ascontiguousarray(v[::-1]) for v in x]
        names += names
        floors += floors
        played += [True] * len(played)
        scale += scale
    warped = []
    for r in config.warps:
        parts = []
        for i, (x, gp, hd) in enumerate(zip(feats, ground, heading, strict=True)):
            n_out = math.floor((x.shape[0] - 1) / r) + 1
            t = np.arange(n_out) * r
            parts.append(
                (
                    _interp_rows(x, t).astype(np.float32),
                    _interp_rows(gp, t),
                    _interp_rows(hd, t),
                    np.full(n_out, i, np.int32),
                    t,
                )
            )
        cols = [np.concatenate(c) for c in zip(*parts, strict=True)]
        warped.append(
            _Warped(
                float(r), np.ascontiguousarray(cols[0]), *cols[1:],
                pelvis_heights(cols[0], reference.skeleton, up),
            )
        )  # fmt: skip
    return InbetweenLibrary(
        tuple(prepped), tuple(names), up, tuple(warped),
        sum(m.num_frames for m in prepped[: len(motions)]), tuple(played), tuple(scale),
        tuple(floors),
    )  # fmt: skip


OWN_PIECE_MIN_SECONDS = 1.0
"""Shortest stretch of the clip beside a gap searched as a library clip
(:attr:`InbetweenConfig.own_frames`): a gait cycle (two steps at a walk), the least that holds
a step to reuse. The LaFAN1 benchmark's context (10 past frames, 1 future frame at 30 fps)
is shorter, so it searches the library alone."""


def own_pieces(
    clip: Motion,
    a: int,
    b: int,
    future_frames: int | None = None,
    skip: Sequence[tuple[int, int]] = (),
) -> list[tuple[int, Motion]]:
    """The clip's own stretches beside the gap ``a:b`` long enough to search
    (:data:`OWN_PIECE_MIN_SECONDS`): ``(first frame, motion)`` for frames ``0..a-1`` and
    ``b..F-1`` (only the ``future_frames`` from B on where that limits what may be looked
    at), split around the frame ranges ``skip`` (``(start, stop)``, stop excluded: frames that
    are not the clip's capture, an earlier run's fill). The gap's own frames are never among
    them (they are what is replaced); nor are ``skip``'s (a fill copied from another fill
    would be named as the take's own capture, newcomer report)."""
    from mocapkit.core.runs import true_runs

    least = max(clip.seconds_to_frames(OWN_PIECE_MIN_SECONDS), 1)
    F = clip.num_frames
    stop = F if future_frames is None else min(F, b + future_frames)
    searched = np.zeros(F, dtype=bool)
    searched[:a] = True
    searched[b:stop] = True
    for s0, s1 in skip:
        searched[max(int(s0), 0) : max(min(int(s1), F), 0)] = False
    return [(r0, clip[r0 : r1 + 1]) for r0, r1 in true_runs(searched) if r1 + 1 - r0 >= least]


def _merged(spans) -> list[tuple[int, int]]:
    """Frame ranges ``(start, stop)`` sorted, overlapping or touching ones merged."""
    out: list[tuple[int, int]] = []
    for x, y in sorted((int(x), int(y)) for x, y in spans):
        if out and x <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], y))
        else:
            out.append((x, y))
    return out


def dropout_frames(clip: Motion) -> list[tuple[int, int]]:
    """``(start, stop)`` (sorted, overlapping ones merged) of the frames where a joint repeats
    its rotation bit for bit for at least the cleaning's ``frozen_seconds``
    (:class:`mocapkit.clean.detect.config.DetectConfig`) while it turns elsewhere in the take: a
    dropout, the solver holding the last value it had
    (:func:`mocapkit.clean.mdm.exact_holds_tell`: not on a joint whose data repeat values all
    along, a keyframed or low-rate source; nor a value the joint holds again elsewhere, a park
    at a limit, as the cleaning's frozen rule reads it; nor on a joint so held for over half the
    take, which the take hardly animates: CMU 03_02's fingers, moved once). Relies on: a
    captured joint trembles by more than a file's last digit every frame. Not the take's motion,
    so never searched as its own frames (newcomer report: a frozen stretch elsewhere in the
    take, copied into a fill with a good score, threw a toe 61 cm in a frame)."""
    from mocapkit.clean.detect.config import DetectConfig
    from mocapkit.clean.mdm import exact_holds_tell, held_from
    from mocapkit.core.runs import true_runs

    cfg = DetectConfig()
    least = max(clip.seconds_to_frames(cfg.frozen_seconds), 2)
    q = clip.rotations
    exact = np.all(q[1:] == q[:-1], axis=-1)  # (F-1, J) step f: frame f -> f+1
    out = []
    for j in range(q.shape[1]):
        runs = [(a, b) for a, b in true_runs(exact[:, j]) if b - a + 1 >= least]
        if 2 * sum(b - a + 1 for a, b in runs) > len(exact) or not exact_holds_tell(
            q[:, j], least, cfg.frozen_exact_share
        ):
            continue  # held most of the take (hardly animated: CMU's fingers), or its data
            # repeat values all along
        for a, b in runs:
            elsewhere = np.all(q[:, j] == q[b + 1, j], axis=-1)
            elsewhere[a : b + 2] = False
            if not elsewhere.any():  # a value it returns to: a park
                out.append((held_from(a), b + 2))
    return _merged(out)  # one range where several joints drop out together


def with_own_frames(
    library: InbetweenLibrary | None,
    clip: Motion,
    a: int,
    b: int,
    clip_name: str,
    up: str,
    config: InbetweenConfig = DEFAULT_CONFIG,
    future_frames: int | None = None,
    skip: Sequence[tuple[int, int]] = (),
) -> InbetweenLibrary:
    """``library`` with the clip's own frames beside the gap ``a:b`` (:func:`own_pieces`, less
    the frame ranges ``skip``) added
    after its motions as library clips named ``clip_name`` (their frames numbered as the
    clip's: :attr:`InbetweenLibrary.first_frames`), so the library's own indices stay as they
    were; ``library`` itself where :attr:`InbetweenConfig.own_frames` is off or no stretch is
    long enough. ``library`` None: the clip's pieces alone (None where there are none).
    ValueError where ``library`` was searched both ways and ``config`` says otherwise (or the
    reverse)."""
    from dataclasses import replace

    pieces = own_pieces(clip, a, b, future_frames, skip) if config.own_frames else []
    if not pieces:
        return library
    if library is not None and any(library.backwards) != config.backwards:
        raise ValueError("the library was prepared with another 'backwards' than the config's")
    own = prepare_library(
        [m for _, m in pieces], clip, [str(clip_name)] * len(pieces), up=up, config=config
    )
    own = replace(own, first_frames=tuple(f for f, _ in pieces) * (len(own.motions) // len(pieces)))
    if library is None:
        return own
    n1, n2 = len(library.motions), len(own.motions)
    warped = tuple(
        _Warped(
            W1.rate, np.ascontiguousarray(np.concatenate([W1.feats, W2.feats])),
            np.concatenate([W1.ground, W2.ground]), np.concatenate([W1.heading, W2.heading]),
            np.concatenate([W1.clip, W2.clip + n1]), np.concatenate([W1.time, W2.time]),
            None if W1.pelvis is None or W2.pelvis is None
            else np.concatenate([W1.pelvis, W2.pelvis]),
        )
        for W1, W2 in zip(library.warped, own.warped, strict=True)
    )  # fmt: skip
    both_ways = config.backwards
    return InbetweenLibrary(
        library.motions + own.motions, library.names + own.names, library.up, warped,
        library.frames + own.frames, (library.backwards or (False,) * n1) + own.backwards,
        (library.file_frames or (1.0,) * n1) + (own.file_frames or (1.0,) * n2),
        library.floors + own.floors if library.floors else (),
        (library.first_frames or (0,) * n1) + own.first_frames,
        tuple(library.reversed_of(i) for i in range(n1))
        + tuple(n1 + own.reversed_of(j) for j in range(n2)) if both_ways else (),
    )  # fmt: skip


# --------------------------------------------------------------------------------- scores


@functools.lru_cache(maxsize=256)
def _window_operators(model: ConstantAccelerationModel, w_before: int, k: int, w_after: int):
    """(D, A), each (T-1, w_before + w_after): smoothed position steps and accelerations of the
    window ``w_before`` observed, ``k`` unobserved, ``w_after`` observed frames."""
    mask = np.r_[np.ones(w_before, bool), np.zeros(k, bool), np.ones(w_after, bool)]
    M = smoother_matrix(model, mask)
    P, Acc = M[:, 0, :], M[:, 2, :]
    D, A = np.ascontiguousarray(P[1:] - P[:-1]), np.ascontiguousarray(Acc[:-1])
    D.setflags(write=False)
    A.setflags(write=False)
    return D, A


def window_lscores(
    before, after, k: int = 0, model: ConstantAccelerationModel = DEFAULT_MODEL
) -> np.ndarray:
    """L-scores of windows ``before`` (N, w_b, m) then ``k`` unobserved frames then ``after``
    (N, w_a, m): ``Σ_d Σ_n |(p̂_{n+1} - p̂_n) â_n|`` (N,) float64; w_b >= 3."""
    B = np.asarray(before, float)
    Af = np.asarray(after, float)
    if B.ndim == 2:
        B, Af = B[None], Af[None]
    D, A = _window_operators(model, B.shape[1], int(k), Af.shape[1])
    Y = np.concatenate([B, Af], axis=1)
    Y = Y - Y[:, B.shape[1] - 1 : B.shape[1]]
    return np.abs(np.einsum("rt,ntm->nrm", D, Y) * np.einsum("rt,ntm->nrm", A, Y)).sum((1, 2))


def kalman_lscore(
    past, future, gap: int, model: ConstantAccelerationModel = DEFAULT_MODEL
) -> float:
    """The Kalman transition's own L-score: ``L_g`` of the window ``past`` (w_p, m), ``gap``
    injected frames, ``future`` (w_f, m)."""
    return float(window_lscores(past, future, gap, model)[0])


def _sliding_lscores(fixed, X: np.ndarray, fixed_first: bool, w: int, model) -> np.ndarray:
    """L-scores of ``fixed`` (w_fixed, m) joined to every run of ``w`` consecutive rows of
    ``X`` (N, m): ``fixed`` then ``X[b:b+w]`` (fixed_first) or ``X[b:b+w]`` then ``fixed``, for
    b = 0..N-w, by the stitching search's numba kernel (float32; both sides are centred on the
    fixed side's frame nearest the junction, which the L-score cannot see)."""
    fixed = np.asarray(fixed, float)
    wf = fixed.shape[0]
    if fixed_first:
        D, A = _window_operators(model, wf, 0, w)
        cols_f, cols_x = slice(0, wf), slice(wf, wf + w)
        centre = fixed[-1]
    else:
        D, A = _window_operators(model, w, 0, wf)
        cols_x, cols_f = slice(0, w), slice(w, w + wf)
        centre = fixed[0]
    fc = fixed - centre
    cD = np.ascontiguousarray((D[:, cols_f] @ fc).T, dtype=np.float32)  # (m, R)
    cA = np.ascontiguousarray((A[:, cols_f] @ fc).T, dtype=np.float32)
    Dx = np.ascontiguousarray(D[:, cols_x], dtype=np.float32)
    Ax = np.ascontiguousarray(A[:, cols_x], dtype=np.float32)
    Xc = np.ascontiguousarray((X - centre.astype(np.float32)).T, dtype=np.float32)
    n = X.shape[0] - w + 1
    out = np.zeros((1, n), np.float32)
    rows = np.array([D.shape[0]], np.int64)
    _search_kernel(w)(Xc, cD, cA, Dx, Ax, np.zeros(1, np.int64), rows, out, 512)
    return out[0].astype(float)


# --------------------------------------------------------------------------------- search


class NoLibraryFitError(ValueError):
    """No library clip is long enough for the gap (the message says the longest it fills)."""


@dataclass(frozen=True)
class Candidate:
    """A library segment for the gap: ``clip`` indexes :attr:`InbetweenLibrary.motions` (the
    prepared motions: each file resampled to the clip's frame rate, then the same played
    backwards, so it is not an index into the list given), its fractional frame ``start``
    taking the place of the last past frame A-1, ``rate`` frames of that motion per clip frame
    (the segment covers its frames ``start .. start + rate (g+1)``), and its scores. Frames of
    the file itself: :meth:`InbetweenLibrary.clip_frames`."""

    clip: int
    start: float
    rate: float
    score: float
    lscore_start: float
    lscore_end: float
    travel: float
    pose: float = 0.0
    mismatch: np.ndarray | None = field(default=None, compare=False, repr=False)
    """(3m,) the segment's body-local features (file units) on its frames s-1, s and s+g+1 less
    the context's on A-2, A-1 and B (2m: no B at the clip's end); what :func:`fill_weights`
    regresses the fill on. None: not known (hand-made candidates)."""

    @property
    def lscore(self) -> float:
        """The two-sided L-score ``L_start + L_end`` (at a gap at the clip's start or end one of
        them is NaN, and left out: there is no junction there)."""
        return sum(x for x in (self.lscore_start, self.lscore_end) if not math.isnan(x))

    def source_frames(self, gap: int) -> tuple[int, int]:
        """Frames of the prepared motion (rounded, stop excluded) that fill the gap's ``gap``
        frames; :meth:`InbetweenLibrary.clip_frames` turns them into the file's frames."""
        return round(self.start + self.rate), round(self.start + self.rate * gap) + 1


@dataclass(frozen=True, eq=False)
class GapContext:
    """What the search needs from the clip around the gap (:func:`gap_context`): body-local
    features of the past and future windows, and the pelvis' ground path across the gap."""

    past: np.ndarray  # (w_p, m) features A-w_p..A-1
    future: np.ndarray  # (w_f, m) features B..
    travel: np.ndarray  # (2,) pelvis ground displacement A-1 -> B in the body frame at A-1
    turn: float  # heading change A-1 -> B (rad)
    velocity: np.ndarray  # (2,) pelvis ground step A-2 -> A-1 in the body frame at A-1
    frame_time: float | None = None
    """The clip's seconds per frame: the search refuses a library prepared at another rate
    (its segments would be read at the wrong speed). None: not checked (hand-made contexts)."""
    pelvis: np.ndarray | None = None
    """(w_p,) the pelvis height (file units) on the past frames: the bob term's. None: none."""

    @property
    def one_sided(self) -> bool:
        """True for a gap at the clip's end: no future frame, nothing to arrive at (``travel``
        and ``turn`` are NaN and left out of the score)."""
        return self.future.shape[0] == 0


def _rotate2(v: np.ndarray, angle) -> np.ndarray:
    """Ground vectors (..., 2) turned by ``-angle`` (into the frame of that heading).

    Ground coordinates are (side, forward) and headings turn right-handed about up."""
    c, s = np.cos(angle), np.sin(angle)
    x, z = v[..., 0], v[..., 1]
    return np.stack([c * x - s * z, s * x + c * z], axis=-1)


def gap_context(
    clip: Motion, a: int, b: int, w: int = 5, up: str = "Y", future_frames: int | None = None
) -> GapContext:
    """The :class:`GapContext` of the gap ``a:b`` of ``clip`` for :func:`search_inbetween`:
    ``w`` frames on each side (fewer at the clip's ends; at most ``future_frames`` after it).
    A clip with a ground root (Bandai's ``joint_Root``) is given with the root on the body's
    path (:func:`mocapkit.features.ground_root_on_path`), as :func:`inbetween` does."""
    from mocapkit import features

    a, b = check_gap((a, b), clip.num_frames)
    if a == 0:
        raise ValueError("gap_context: a gap at the clip's start is searched on the reversed clip")

    wp = min(w, a)
    wf = min(w, clip.num_frames - b)
    if future_frames is not None:
        wf = min(wf, int(future_frames))
    part = clip[a - wp : b + wf]
    f = motion_features(part, up)
    g = b - a
    past, future = f[:wp], f[wp + g :]
    gp = features.root_trajectory(part, up)
    hd = features.heading_angles(part, up, unwrap=True)
    i0, i1 = wp - 1, wp + g
    if wf == 0:  # a gap at the clip's end: no place or heading to arrive at
        travel, turn = np.full(2, np.nan), math.nan
    else:
        travel, turn = _rotate2(gp[i1] - gp[i0], hd[i0]), float(hd[i1] - hd[i0])
    return GapContext(
        past, future, travel, turn, _rotate2(gp[i0] - gp[i0 - 1], hd[i0]), clip.frame_time,
        pelvis_heights(past, clip.skeleton, up),
    )  # fmt: skip


def pelvis_heights(feats: np.ndarray, skeleton: Skeleton, up: str) -> np.ndarray:
    """(n,) the pelvis height in body-local features ``feats`` (n, 3 x feature joints) of
    :func:`mocapkit.stitch.search.motion_features` (which keep heights; the pelvis is one of
    :func:`mocapkit.stitch.search.body_joints`)."""
    from mocapkit import features

    k = list(feature_joint_indices(skeleton, None)).index(features.pelvis_index(skeleton))
    return np.asarray(feats[:, 3 * k : 3 * k + 3], np.float64) @ features.ground_frame(up)[1]


def _last_offset(ctx: GapContext, g: int) -> int:
    """The last frame a candidate at s needs, as an offset from s: the one on B (g + 1), or the
    last gap frame (g) for a gap at the clip's end, so a segment may end a library clip."""
    return g if ctx.one_sided else g + 1


def _travel_costs(
    W: _Warped, ctx: GapContext, g: int, config: InbetweenConfig, mpu: float
) -> tuple[np.ndarray, np.ndarray]:
    """(cost, valid) per warped frame s (the frame on A-1): the ground-path term, its
    differences as displacements (what :attr:`Candidate.travel` keeps: the fit's path miss in
    metres); the score takes it times :func:`_travel_rate_factor`."""
    N = W.feats.shape[0]
    s = np.arange(N)
    valid = np.zeros(N, bool)
    e = _last_offset(ctx, g)
    lo, hi = 1, N - e
    if hi <= lo:
        return np.full(N, np.inf), valid
    idx = s[lo:hi]
    same = W.clip[idx - 1] == W.clip[idx + e]
    h0 = W.heading[idx]
    d = _rotate2(W.ground[idx + e] - W.ground[idx], h0)
    v = _rotate2(W.ground[idx] - W.ground[idx - 1], h0) / W.rate
    turn = W.heading[idx + e] - W.heading[idx]
    tol = config.travel_tolerance_m / mpu
    if ctx.one_sided:  # nothing to arrive at: the fill must set off at the clip's own speed
        v = v * W.rate
    c = np.sum((v - ctx.velocity) ** 2, -1) * (g + 1) ** 2 / tol**2 / 4.0
    if not ctx.one_sided:  # where the body must arrive, and facing which way
        c = (
            c
            + np.sum((d - ctx.travel) ** 2, -1) / tol**2
            + ((turn - ctx.turn) / math.radians(config.turn_tolerance_deg)) ** 2
        )
    cost = np.full(N, np.inf)
    cost[idx] = config.travel_weight * c
    valid[idx] = same
    return cost, valid


def _travel_rate_factor(ctx: GapContext, g: int, config: InbetweenConfig) -> float:
    """The factor on the ground-path term in the score: 1, or over a two-sided gap (A-1 to B)
    longer than :attr:`InbetweenConfig.travel_seconds` the square of that over its length, so
    that the path differences are judged as rates. Relies on: the ground warp
    (:func:`_ground_warp`) spreads a segment's miss of the context's displacement and heading
    change over the whole gap, so what the fill shows of a miss is a change of speed and of
    turning rate, the miss over the gap's length; the pose term does not grow with the gap.
    Judged as displacements a long gap's path term outweighed the poses: tuning windows
    (bandai2's tuning tenth), L2P at 15 / 30 / 45 frames, the take's person and gait left out of
    the library, 2.195 / 3.008 / 3.778 as displacements, 2.207 / 2.775 / 3.495 as rates past 0.5
    s (2.195 / 2.765 / 3.495 past 16 frames; 2.304 / 2.766 past 11; 30 / 45 frames 2.825 / 3.635
    past 21); the person left out 1.840 / 2.478 / 2.897 and 1.839 / 2.293 / 2.816. Rates below
    half a second too (the term heavier on a shorter gap): 5 frames 0.858 -> 0.876. The velocity
    term's growth with the gap (a speed difference at A-1 over half the gap) is undone alike.
    Held out (bench/bench_inbetween.py, one run each): 0.574 / 0.628 / 0.715 of interpolation at
    15 / 30 / 45 frames as displacements, 0.572 / 0.628 / 0.698 as rates."""
    if ctx.one_sided or ctx.frame_time is None or config.travel_seconds <= 0:
        return 1.0
    return min(1.0, config.travel_seconds / ((g + 1) * ctx.frame_time)) ** 2


def _pose_costs(
    W: _Warped, ctx: GapContext, g: int, config: InbetweenConfig, mpu: float
) -> np.ndarray:
    """(N,) per warped frame s (the frame on A-1): the pose term, squared body-local distances
    of frames s-1, s, s+g+1 to the context's A-2, A-1, B over joints and squared tolerance
    (inf where a frame is outside the library; clip boundaries are checked by the caller)."""
    N, m = W.feats.shape
    cost = np.full(N, np.inf)
    if config.pose_weight == 0:
        cost[:] = 0.0
        return cost
    lo, hi = 1, N - _last_offset(ctx, g)
    if hi <= lo:
        return cost
    X = W.feats
    n2 = W.__dict__.get("_sqnorm")
    if n2 is None:  # squared norms of the rows, once per prepared library
        n2 = np.einsum("nm,nm->n", X, X, dtype=np.float64)
        object.__setattr__(W, "_sqnorm", n2)
    C = np.concatenate([ctx.past[-2:], ctx.future[:1]]).astype(float)  # on s-1, s (, s+g+1)
    XC = (X @ C.T.astype(np.float32)).astype(np.float64)  # (N, 3)
    cc = np.einsum("km,km->k", C, C)
    total = np.zeros(hi - lo)
    for j, k in enumerate((-1, 0, g + 1)[: len(C)]):
        total += n2[lo + k : hi + k] - 2.0 * XC[lo + k : hi + k, j] + cc[j]
    tol = config.pose_tolerance_m / mpu
    # per frame matched (3; 2 for a gap at the clip's end), so both read alike in metres
    per = 3.0 / len(C)
    cost[lo:hi] = config.pose_weight * per * np.maximum(total, 0.0) / ((m / 3) * tol**2)
    return cost


def _bob_frames(frame_time: float, config: InbetweenConfig) -> int:
    """k: the bob term measures the pelvis' vertical motion over frames i-2k, i-k, i."""
    return max(1, round(config.bob_span_seconds / 2 / frame_time))


def _bob_spans(W: _Warped, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Per warped frame s (on A-1): the span k_s (frames) over which its clip has frames s-2k_s
    .. s (k_s <= k; 1 where it has fewer, and then the frames s-1, s, s+1), and the frame
    ``end`` the three frames end at (s, or s+1 at a clip's second frame); cached per k."""
    cache = W.__dict__.setdefault("_bob", {})
    if k not in cache:
        N = W.clip.shape[0]
        edge = np.flatnonzero(np.diff(W.clip)) + 1  # first frame of each clip but the first
        first = np.repeat(np.r_[0, edge], np.diff(np.r_[0, edge, N]))
        off = np.arange(N) - first
        ks = np.clip(off // 2, 1, k)
        end = np.where(off >= 2, np.arange(N), np.minimum(np.arange(N) + 1, N - 1))
        cache[k] = (ks, end)
    return cache[k]


def _bob_costs(W: _Warped, ctx: GapContext, config: InbetweenConfig, mpu: float) -> np.ndarray:
    """(N,) per warped frame s (the frame on A-1): the bob term
    (:attr:`InbetweenConfig.bob_weight`), the squared differences of the pelvis' vertical
    acceleration and speed over the candidate's frames on A-1-2k, A-1-k, A-1 and the
    context's, per squared tolerance (k frames: half :attr:`InbetweenConfig.bob_span_seconds`,
    or as many as the candidate's clip or the context have before A-1; a candidate on its
    clip's second frame is measured a frame later, over s-1, s, s+1). Zero everywhere where
    the term is off, the context has fewer than three past frames or no frame time, or the
    library no pelvis heights."""
    N = W.feats.shape[0]
    if config.bob_weight == 0 or W.pelvis is None or ctx.pelvis is None or ctx.frame_time is None:
        return np.zeros(N)
    hc = np.asarray(ctx.pelvis, np.float64)
    if len(hc) < 3:
        return np.zeros(N)
    k = min(_bob_frames(ctx.frame_time, config), (len(hc) - 1) // 2)
    ks, end = _bob_spans(W, k)
    h = W.pelvis
    dt = ctx.frame_time
    i0, i1 = np.maximum(end - 2 * ks, 0), np.maximum(end - ks, 0)
    acc = (h[end] - 2.0 * h[i1] + h[i0]) / (ks * dt) ** 2  # file units / s²
    vel = (h[end] - h[i0]) / (2 * ks * dt)  # at the middle frame, file units / s
    j = np.arange(1, k + 1)
    c_acc = (hc[-1] - 2.0 * hc[-1 - j] + hc[-1 - 2 * j]) / (j * dt) ** 2  # per span 1..k
    c_vel = (hc[-1] - hc[-1 - 2 * j]) / (2 * j * dt)
    da = (acc - c_acc[ks - 1]) * mpu / config.bob_tolerance_m_s2
    cost = da**2
    if config.bob_speed_tolerance_m_s > 0:
        cost = cost + ((vel - c_vel[ks - 1]) * mpu / config.bob_speed_tolerance_m_s) ** 2
    return config.bob_weight * cost


def search_inbetween(
    ctx: GapContext,
    gap: int,
    library: InbetweenLibrary,
    *,
    w: int = 5,
    config: InbetweenConfig = DEFAULT_CONFIG,
    model: ConstantAccelerationModel = DEFAULT_MODEL,
    metres_per_unit: float = 0.01,
) -> tuple[Candidate, int]:
    """The best :class:`Candidate` for a gap of ``gap`` frames and the number scored."""
    cands, count = search_inbetween_top(
        ctx, gap, library, 1, w=w, config=config, model=model, metres_per_unit=metres_per_unit
    )
    return cands[0], count


def search_inbetween_top(
    ctx: GapContext,
    gap: int,
    library: InbetweenLibrary,
    k: int = 1,
    *,
    w: int = 5,
    config: InbetweenConfig = DEFAULT_CONFIG,
    model: ConstantAccelerationModel = DEFAULT_MODEL,
    metres_per_unit: float = 0.01,
) -> tuple[list[Candidate], int]:
    """The ``k`` best :class:`Candidate` s (lowest score first) for a gap of ``gap`` frames, no
    two of them on overlapping library frames (a candidate whose segment overlaps a better
    one's in the same clip is passed over), and the number scored."""
    g = int(gap)
    k = max(1, int(k))
    if ctx.frame_time is not None and library.motions:
        _check_rate(library, ctx.frame_time)
    pool, count = [], 0
    wl = min(w, g)  # the gap frames seen by each junction's window
    rate = _travel_rate_factor(ctx, g, config)
    if wl < 3:
        wl = 3
    for W in library.warped:
        N = W.feats.shape[0]
        e = _last_offset(ctx, g)
        if max(e, wl) + 2 > N:  # no frame s can have its frames s-1 .. s+e and its window
            continue
        travel, valid = _travel_costs(W, ctx, g, config, metres_per_unit)
        ls = np.full(N, np.inf)
        le = np.full(N, np.inf)
        s = np.arange(N)
        ok = (s + 1 + wl <= N) & (s + g - wl + 1 >= 0) & (s + e < N)
        if config.lscore_weight > 0:
            start = _sliding_lscores(ctx.past, W.feats, True, wl, model)  # b = first gap frame
            ls[ok] = start[np.minimum(s[ok] + 1, start.shape[0] - 1)]
            le[ok] = 0.0
            if not ctx.one_sided:
                end = _sliding_lscores(ctx.future, W.feats, False, wl, model)  # last - wl + 1
                le[ok] = end[np.clip(s[ok] + g - wl + 1, 0, end.shape[0] - 1)]
        else:  # not in the score: computed for the chosen candidates only, below
            ls[ok] = le[ok] = 0.0
        # the windows must stay in the candidate's clip
        first = np.clip(s + g - wl + 1, 0, N - 1)
        last = np.clip(s + wl, 0, N - 1)
        valid &= ok & (W.clip[first] == W.clip) & (W.clip[last] == W.clip)
        pose = _pose_costs(W, ctx, g, config, metres_per_unit)
        bob = _bob_costs(W, ctx, config, metres_per_unit)
        lw = config.lscore_weight
        lsum = lw * (ls + le) if lw > 0 else np.zeros(N)
        total = np.where(valid, lsum + rate * travel + pose + bob, np.inf)
        count += int(valid.sum())
        # enough of this warp's best to leave k non-overlapping ones after the overlap check
        m = min(N, k * (2 * g + 8))
        top = np.argpartition(total, m - 1)[:m] if m < N else np.arange(N)
        top = top[np.isfinite(total[top])]
        pool += [(float(total[i]), W, int(i), float(ls[i]), float(le[i]), float(travel[i]),
                  float(pose[i])) for i in top]  # fmt: skip
    if not pool:
        # a candidate spans frames s-1 .. s+g+1 (s+g at the clip's end): g + 3 (g + 2) frames
        longest = max(int(np.bincount(W.clip).max()) for W in library.warped) - (
            2 if ctx.one_sided else 3
        )
        raise NoLibraryFitError(
            f"no library clip is long enough for a gap of {g} frames (the longest fills a gap "
            f"of {max(longest, 0)} frames, played at speed x{min(library.warped[0].rate, 1):g})"
        )
    pool.sort(key=lambda x: x[0])
    chosen: list[Candidate] = []
    for score, W, i, l0, l1, tr, po in pool:
        c, t = int(W.clip[i]), float(W.time[i])
        span = W.rate * (g + 1)
        if any(o.clip == c and abs(o.start - t) <= max(span, o.rate * (g + 1)) for o in chosen):
            continue
        X = W.feats
        if config.lscore_weight == 0:  # the L-scores of the chosen segment, for the report
            l0 = float(window_lscores(ctx.past, X[i + 1 : i + 1 + wl], 0, model)[0])
        if ctx.one_sided:  # no junction after a gap that ends the clip (0 in the score)
            l1 = math.nan
        elif config.lscore_weight == 0:
            l1 = float(window_lscores(X[i + g - wl + 1 : i + g + 1], ctx.future, 0, model)[0])
        mis = None  # the frames fill_weights regresses on: s-1, s (, s+g+1) against A-2, A-1 (, B)
        if ctx.past.shape[0] >= 2:
            rows = [i - 1, i] + ([] if ctx.one_sided else [i + g + 1])
            Cm = np.concatenate([ctx.past[-2:], ctx.future[:1]])
            mis = (X[rows].astype(np.float64) - Cm).ravel()
        chosen.append(Candidate(c, t, W.rate, score, l0, l1, tr, po, mis))
        if len(chosen) == k:
            break
    return chosen, count


# --------------------------------------------------------------------------------- fills


def _sample(motion: Motion, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations (n, J, 4) and translations (n, J, 3) at fractional frames ``t``."""
    i0 = np.clip(np.floor(t).astype(np.int64), 0, motion.num_frames - 1)
    i1 = np.minimum(i0 + 1, motion.num_frames - 1)
    f = t - i0
    q0, q1 = motion.rotations[i0], motion.rotations[i1]
    q1 = np.where(np.sum(q0 * q1, -1, keepdims=True) < 0, -q1, q1)
    rots = rot.quat_slerp(q0, q1, np.broadcast_to(f[:, None], q0.shape[:2]))
    tr = motion.local_translations()
    return rots, tr[i0] * (1 - f)[:, None, None] + tr[i1] * f[:, None, None]


def _decay(n: int, length: int) -> np.ndarray:
    """(n,) weights 1 at index 0 falling to 0 at index ``length`` (smoothstep), 0 after."""
    x = np.clip(np.arange(n) / max(length, 1), 0.0, 1.0)
    return 1.0 - x * x * (3.0 - 2.0 * x)


def _offset_blend(
    rots,
    trans,
    r0,
    r1,
    t0,
    t1,
    blend: int,
    max_step: float = math.inf,
    v0=None,
    v1=None,
    u0=None,
    u1=None,
    keep: float = 0.0,
):
    """Rotations/translations (n, J, ·) with the end offsets to (r0, t0) at index 0 and (r1, t1)
    at index n-1 blended in, each decaying from its end over ``blend`` frames (a translation's
    to zero; a joint's rotation offset into ``keep`` times the two ends' mean offset, held in
    the middle: :attr:`InbetweenConfig.offset_keep`, none with ``r1`` None), or for a joint's
    rotation over as many more frames (at most n - 1) as keep the correction's angular speed
    under ``max_step`` radians per frame (smoothstep's steepest slope is 1.5 / length), the
    length set by the change from the end's offset to the held one. Where a joint's two
    blends would overlap, each spans the whole gap: the correction goes straight from one
    end's offset to the other's, as slowly as the gap allows.
    ``r1`` and ``t1`` None: no end at index n-1 to meet (a gap at the clip's end).

    ``v0``, ``v1`` ((J, 3) radians per frame, optional): the joints' angular-velocity offsets
    (the context's turn per frame less the segment's) at index 0 and n-1, carried as
    inertialization carries them: a term ``v t (1 - t/blend)^2``, so the result leaves the
    context at its own angular velocity, not the segment's (its return turns a joint at a third
    of the offset at most; :func:`library_fill` caps the offsets at
    :data:`TURN_OFFSET_MAX_DEG_S`). Relies on: a joint's angular velocity is continuous; a blend
    that meets the pose but not its velocity jolts the junction (tuning windows, person held
    out: mean joint acceleration at the junction 12.0-14.0 m/s² without, 9.9-10.7 with, the
    truth's 7.9-8.1; L2P at 5 / 15 / 30 / 45 frames 1.034 / 2.245 / 2.943 / 3.491 without, 1.010
    / 2.220 / 2.930 / 3.479 with, NPSS 0.0029 / 0.0419 / 0.1706 / 0.3269 without, 0.0025 /
    0.0414 / 0.1706 / 0.3276 with; fading as smoothstep times t, in one log with the pose
    offset: 1.062 / 2.233 / 2.939 / 3.488, NPSS 0.0028 / 0.0421 / 0.1728 / 0.3293).

    ``u0``, ``u1`` ((J, 3) per frame, optional): the same for the translations (the context's
    step per frame less the segment's), added as ``u t (1 - t/blend)^2``. Relies on: the body
    moves with a continuous velocity; the pelvis rises and falls through a step at its own
    pace, and a fill that meets its height but not its vertical speed bobs out of phase with
    the context (tuning windows, person held out: the pelvis height alone made a third of L2P,
    1.2 cm RMS off at 15 frames). L2P at 5 / 15 / 30 / 45 frames 1.033 / 2.208 / 2.934 /
    3.474 without, 0.734 / 2.074 / 2.868 / 3.430 with; with the take's person and gait left
    out of the library 1.352 / 2.766 / 3.859 / 4.611 without, 0.955 / 2.644 / 3.790 / 4.582
    with. :func:`library_fill` reads both velocities the same way (the segment's from the
    library frame before it, or after it), so that a capture filled from itself is itself;
    the segment's step out of A-1 instead gave 0.763 / 2.065 / 2.868 / 3.432 but moved it.
    Where the library clip has no frame there (the clip's own frames beside the gap end at
    it, and the best segment often runs up to it), the segment's own first (last) step
    stands for the one it lacks (:func:`_carried_on`): left out, a fill from a run's own
    frames met B at the segment's speed, its pelvis falling at 1.3 m/s into a context rising
    at 1.2 m/s. Fills from the take's own frames (1 s gaps at 40% and 60% of 20 bandai2 walks
    and runs and 12 CMU takes), largest joint acceleration of the fill's last two frames over
    the take's 99th percentile: mean 0.922 -> 0.740, over 1.5 in 16% -> 7%, at most 3.36 ->
    1.74; the first two frames' unchanged (0.637). The velocity is then met by accelerating
    over the frames before B rather than by a jump at B: the end junction's L-score, which
    weighs the smoothed effort around it, rose 282.5 -> 289.5 on average (median 182.6 ->
    182.7)."""
    n = rots.shape[0]
    w0 = _decay(n, blend)[:, None, None]
    w1 = w0[::-1]
    one_sided = r1 is None
    if one_sided:  # nothing to meet at the far end: its offset is none
        r1, t1 = rots[-1], trans[-1]
    d0 = rot.quat_mul(r0, rot.quat_inv(rots[0]))
    d1 = rot.quat_mul(r1, rot.quat_inv(rots[-1]))
    l0 = rot.quat_log(np.where(d0[..., :1] < 0, -d0, d0))  # (J, 3), half the angle
    l1 = rot.quat_log(np.where(d1[..., :1] < 0, -d1, d1))

    def frames(log: np.ndarray) -> np.ndarray:  # (J,) frames for a change of ``log``
        angle = 2.0 * np.linalg.norm(log, axis=-1)
        return np.clip(np.ceil(1.5 * angle / max_step), blend, max(n - 1, blend))

    def decay(length: np.ndarray) -> np.ndarray:  # (n, J, 1) per joint, from index 0
        x = np.clip(np.arange(n)[:, None] / np.maximum(length[None], 1), 0.0, 1.0)
        return (1.0 - x * x * (3.0 - 2.0 * x))[..., None]

    # each end's offset blends into the share of their mean held between them (none with one
    # end only), over as many frames as the difference needs to turn no joint too fast; where
    # the two blends would overlap, each spans the gap, so the correction goes straight from
    # one end's offset to the other's, as slowly as the gap allows
    held = np.zeros_like(l0) if one_sided else keep * 0.5 * (l0 + l1)
    n0, n1 = frames(l0 - held), frames(l1 - held)
    if not one_sided:
        overlap = n0 + n1 > n - 1
        n0, n1 = np.where(overlap, max(n - 1, 1), n0), np.where(overlap, max(n - 1, 1), n1)
    e0, e1 = decay(n0), decay(n1)[::-1]
    mid = np.clip(1.0 - e0 - e1, 0.0, 1.0)
    off = rot.quat_exp(l0[None] * e0 + l1[None] * e1 + held[None] * mid)
    # the velocity offsets: t (1 - t/L)^2 leaves at slope 1, is gone with slope 0 at L = blend
    # and swings back at most 1/3 as fast; a left factor of its own, exact however large the
    # pose offset
    x = np.clip(np.arange(n, dtype=float) / max(blend, 1), 0.0, 1.0)
    fade = (np.arange(n) * (1.0 - x) ** 2)[:, None, None]
    vel = np.zeros((n, *l0.shape))
    for v, f in ((v0, fade), (v1, -fade[::-1])):
        if v is not None:
            vel = vel + 0.5 * v[None] * f  # the log is half the rotation vector
    out_r = rot.quat_normalize(rot.quat_mul(rot.quat_exp(vel), rot.quat_mul(off, rots)))
    out_t = trans + (t0 - trans[0])[None] * w0 + (t1 - trans[-1])[None] * w1
    for u, f in ((u0, fade), (u1, -fade[::-1])):
        if u is not None:
            out_t = out_t + u[None] * f
    out_r[0], out_r[-1], out_t[0], out_t[-1] = r0, r1, t0, t1
    return out_r, out_t


def _ground_warp(
    seg: Motion,
    ctx: Motion,
    i_start: int,
    i_end: int | None,
    up: str,
    before: int = 0,
    after: int = 0,
) -> Motion:
    """``seg`` (n frames) moved over the ground by the transform putting its frame ``before``
    on ``ctx[i_start]`` (pelvis ground position and facing), then bent so that its frame
    n-1-``after`` lands on ``ctx[i_end]``: the heading correction dθ that frame still needs grows
    linearly along the segment, turning the body and each frame's step of travel by the share
    reached there (the path bent as a turn bends it), and the position the bent path still
    misses at the end is made up by a translation growing linearly. ``i_end`` None: by the
    first alone. The ``before`` and ``after`` frames beyond them go along (the growth carried
    on), so that the segment's velocity there can be read. The pelvis' ground path is bent
    and each frame turned about its pelvis, wherever the root is.

    Why bent, not swung: turning the whole path about its start by the growing correction
    (the rule before) moves a straight path's point at u sideways by L dθ u², twice the L dθ
    u² / 2 of the same heading change spread along it as a steady turn; after the end is
    pinned that is a sideways bow of L dθ / 4 at mid-gap instead of a circular arc's L dθ / 8.
    The correction is mostly the facing's swing with each step (the pelvis turns 5-10 deg to
    and fro in a walk, more in a run), not a turn, so the doubled bow was mostly error: on the
    tuning windows (bandai2's tuning tenth, the take's person and gait left out) the fill's
    pelvis strayed 7.6 cm RMS off the chord at 30 frames against the capture's 5.0, a run's
    4.9 against 1.5. L2P at 5 / 15 / 30 / 45 frames 0.862 / 2.284 / 3.254 / 4.161 swung,
    0.858 / 2.195 / 3.008 / 3.778 bent; the person left out 1.894 / 2.561 at 15 / 30 swung,
    1.840 / 2.478 bent. Not bending the path at all (the body turned, the path only
    translated) lost the turning walks' arcs (30 frames, gait left out: 3.231)."""
    from mocapkit import features

    n = seg.num_frames
    T0 = features.ground_alignment(ctx, i_start, seg, before, up=up)
    moved = features.apply_ground_transform(seg, T0)
    if i_end is None:
        return moved
    last = n - 1 - after
    T1 = features.ground_alignment(ctx, i_end, moved, last, up=up)
    u = (np.arange(n) - before) / max(last - before, 1)

    def turn(angles: np.ndarray) -> np.ndarray:
        return np.stack([features.GroundTransform(a, np.zeros(3), up).quaternion for a in angles])

    # the pelvis' ground path is bent (the root may be anywhere: a ground root left at the
    # origin, reviewer), and each frame turned about its pelvis' vertical
    side, _, fwd = features.ground_frame(up)
    g2 = features.root_trajectory(moved, up)
    pel = g2[:, :1] * side + g2[:, 1:] * fwd  # (n, 3), no up component
    steps = rot.quat_apply(turn(0.5 * (u[1:] + u[:-1]) * T1.angle), np.diff(pel, axis=0))
    bent = np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])
    bent += pel[before] - bent[before]
    bent += u[:, None] * (T1.apply(pel[last]) - bent[last])[None]  # the end pinned
    q = turn(u * T1.angle)
    out = moved.copy()
    out.root_positions = bent + rot.quat_apply(q, moved.root_positions - pel)
    out.rotations[:, 0] = rot.quat_mul(q, moved.rotations[:, 0])
    if out.translations is not None:
        out.translations[:, 0] = out.root_positions
    return out


def _two_sided(onpath, fill, a, b, ctx: GapContext, w: int, up: str, model) -> tuple[float, float]:
    """The two L-scores of filled frames ``fill`` (frames a..b-1 of ``onpath``), scored as a
    library candidate is: L of the past window then the first gap frames, and L of the last gap
    frames then the future window, in body-local features (their sum is the two-sided score)."""
    from mocapkit.stitch.transition import _join

    g = b - a
    wl = max(3, min(w, g))
    part = _join(onpath[max(0, a - 3) : a], fill, onpath[b : b + 3])
    f = motion_features(part, up)[min(3, a) :][:g]
    if f.shape[0] < wl:  # a gap shorter than three frames: repeat its last frame, as a hold
        f = np.concatenate([f, np.repeat(f[-1:], wl - f.shape[0], axis=0)])
    start = window_lscores(ctx.past, f[:wl], 0, model)[0]
    if ctx.one_sided:  # a gap that ends the clip has no junction there
        return float(start), math.nan
    end = window_lscores(f[-wl:], ctx.future, 0, model)[0]
    return float(start), float(end)


def _lock_feet(
    motion: Motion,
    a: int,
    b: int,
    up: str,
    config: InbetweenConfig,
    sources: Sequence[tuple[Motion, float]] = (),
) -> Motion:
    """``motion`` with the feet planted in frames a..b-1 held (see
    :attr:`InbetweenConfig.foot_lock`): contacts (:func:`mocapkit.features.foot_contacts`) on
    the gap and some context, each contact run held where it began (ground-plane only), or
    where the context frames of the run plant the foot (a foot planted at frame B is already
    where it must be; :func:`mocapkit.ik.lock_targets` ``pins``), the hold faded in and out at
    the gap's ends; only the legs' rotations of frames a..b-1 change.

    ``sources``: the library segments the fill was made of (:func:`_source_segments`) and
    their weights. A hold then moves as their planted feet moved (weighted; a foot in the air
    in a segment adds nothing): the lock takes out the slide that fitting the segments to the
    context added (ground warp, end offsets, averaging), not the captured foot's own roll and
    settling, so a fill that is a capture as it was is left as it was."""
    from mocapkit import ik
    from mocapkit.body import body_of
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.features import foot_contacts, ground_frame

    pad = max(motion.seconds_to_frames(config.lock_context_seconds), 1)  # frames a-1 and b
    lo, hi = max(0, a - pad), min(motion.num_frames, b + pad)
    ex = motion[lo:hi]
    body = body_of(ex)
    chains, effs = ik.legs_and_feet(ex, body)
    if not effs:  # no legs to hold
        return motion
    contacts = foot_contacts(ex, up=up)
    F = ex.num_frames
    flags = ik.effector_contacts(contacts, effs)
    pos, _ = forward_kinematics(ex)
    lock = ik.FootLockConfig()
    i = np.arange(F) + lo
    context = (i < a) | (i >= b)  # frames the fill must not change: a run there is anchored
    floor = _planted_heights(motion, up, list(effs), skip=(a, b))[list(effs)]
    if config.contact_at_ends:
        flags = _planted_at_ends(ex, pos[:, list(effs)], flags, up, a - lo, b - lo, floor)
    drift = None
    _, u, _ = ground_frame(up)
    clearance = np.zeros((F, len(effs)))  # the sources' heights above their floors, weighted
    known = np.zeros((F, len(effs)))  # the weight of the sources that plant the joint somewhere
    if sources:  # steps into frames a..b of the sources' planted feet, weighted
        drift = np.zeros((F, len(effs), 3))
        for seg, w, seg_floor in sources:
            sp, _ = forward_kinematics(seg)
            sp = sp[:, list(effs)]
            planted = foot_contacts(seg, feet=list(effs), up=up).contacts
            step = np.diff(sp, axis=0) * (planted[1:] & planted[:-1])[..., None]
            m = seg.num_frames - (b - a + 2)  # the segment: frames a-1-m/2 .. b+m/2
            n = min(b + 1, hi) - a  # steps into frames a..b (a..b-1 at the clip's end)
            gap_rows = slice(a - lo, a - lo + n)
            drift[gap_rows] += w * step[m // 2 : m // 2 + n]
            above = sp[m // 2 + 1 : m // 2 + 1 + n] @ u - seg_floor[list(effs)][None]
            has = np.isfinite(above)
            clearance[gap_rows] += w * np.where(has, above, 0.0)
            known[gap_rows] += w * has
    targets, weights = ik.lock_targets(
        pos[:, list(effs)], flags, ex.seconds_to_frames(lock.blend), "first",
        ground_frame(up)[1], "offset", np.repeat(context[:, None], len(effs), 1), drift,
    )  # fmt: skip
    # a foot planted through the gap is raised as the end offsets fade (_onto_floor's stand)
    # (whole by the middle of a short gap: reviewer, a short fill's sunk foot stayed low)
    blend = max(min(motion.seconds_to_frames(config.blend_seconds), (b - a + 1) // 2), 1)
    to_end = b - i if b < motion.num_frames else np.inf
    e = np.clip(np.minimum(i - (a - 1), to_end) / blend, 0.0, 1.0)
    targets, weights = _onto_floor(ex, pos[:, list(effs)], flags, ~context, targets, weights, up,
                                   floor, e * e * (3 - 2 * e))  # fmt: skip
    above = clearance / np.where(known > 0, known, 1.0)
    targets, weights = _swing_clearance(ex, pos[:, list(effs)], flags, targets, weights, up,
                                        floor + above, known > 0)  # fmt: skip
    legs_effs = [[effs.index(e) for e in c.effectors] for c in chains]
    bound = _floor_bound(motion, up, list(effs), (a, b), floor)
    targets, weights = _above_floor(ex, pos[:, list(effs)], ~context, targets, weights, up, bound,
                                    legs_effs)  # fmt: skip
    ramp = max(motion.seconds_to_frames(config.lock_ramp_seconds), 1)
    to_end = b - i if b < motion.num_frames else np.inf  # no context after a gap that ends it
    x = np.clip(np.minimum(i - (a - 1), to_end) / (ramp + 1), 0.0, 1.0)
    # faded even where the target meets the context's foot: the leg may reach it in another
    # pose than the context's, and unfaded that pose change pops at the junction (tuning
    # windows: the legs' angular acceleration at the junctions 10.5 deg/frame^2 against the
    # truth's 8.8; faded 8.7)
    weights = weights * (x * x * (3 - 2 * x))[:, None]
    res = ik.solve(ex, chains, targets, weights, lock.ik, body)
    legs = sorted({j for c in chains for j in c.joints})
    # frames a-1 .. b: the correction is none at both (context), and ramps within the gap
    # (a-1 .. b-1 at the clip's end, where the last frame keeps its own)
    span = slice(a - 1 - lo, min(b + 1, hi) - lo)
    locked = _gentle_correction(
        ex.rotations[span, legs], res.motion.rotations[span, legs], motion.fps, config
    )
    out = motion.copy()
    out.rotations[a:b, legs] = locked[1 : 1 + b - a]
    return out


def _planted_at_ends(
    ex: Motion, pos: np.ndarray, flags: np.ndarray, up: str, a: int, b: int, floor: np.ndarray
) -> np.ndarray:
    """``flags`` (F, n) with the context frame beside the gap (``a-1``, ``b``) marked planted
    for a foot joint that is low there (within 3% of the character's height over the clip's
    ``floor``, (n,)) and slow (under 0.6 heights per second to the next context frame out:
    :func:`mocapkit.features.foot_contacts`' two tests) while a contact run of the fill reaches
    the frame next to it (``a``, ``b-1``): the fill's contact is the context's, which the
    detector cut (a heel already rising at B, a toe just down at A-1), so the lock anchors it
    where the context plants the foot, not where the fill put it. Relies on: a foot on the
    floor at the gap's edge and on the floor in the fill's frame beside it has not moved
    between (:attr:`InbetweenConfig.contact_at_ends`). Where the next context frame out lies
    beyond ``ex`` (a gap ending at the clip's next-to-last frame), the speed is unknown and
    the frame is left."""
    from mocapkit.features import character_height, ground_frame

    _, u, _ = ground_frame(up)
    height = character_height(ex, up)
    h = pos @ u
    out = flags.copy()
    F = flags.shape[0]
    for k in range(flags.shape[1]):
        if not (flags[:, k].any() and np.isfinite(floor[k])):
            continue
        for edge, inner, nxt in ((a - 1, a, a - 2), (b, b - 1, b + 1)):
            if not (0 <= edge < F and 0 <= nxt < F and a <= inner < b) or not flags[inner, k]:
                continue
            speed = np.linalg.norm(pos[nxt, k] - pos[edge, k]) * ex.fps  # within the context
            if h[edge, k] - floor[k] < 0.03 * height and speed < 0.6 * height:
                out[edge, k] = True
    return out


FLOOR_TOLERANCE_M = 0.002
"""A foot the fill plants less than this below the clip's floor is left (:func:`_onto_floor`)."""


def _planted_heights(
    motion: Motion, up: str, feet: Sequence[int] | None = None, skip: tuple[int, int] = (0, 0)
) -> np.ndarray:
    """(J,) the height at which ``motion`` plants each foot joint (``feet``, or
    :func:`mocapkit.features.find_feet`): the 10th percentile of its planted frames outside
    frames ``skip`` (a foot rolls up from the floor, not into it); NaN for the other joints and
    for a foot planted nowhere. Over the whole clip: a few steps beside a gap may all sit a
    centimetre high (a walk's start filled from the take itself was raised 1 cm with the half
    second after the gap alone). A foot joint planted nowhere there takes its other foot's
    (both feet stand on one floor: a short run whose left foot lands only in the gap had no
    floor for it, and the fill sank it 8.7 cm). The frames ``skip`` are left out before the
    contacts are judged, not after: the contact detector reads the floor off the motion's
    lowest feet, and a fill that sank them 6 cm made every foot of the clip's own frames too
    high to be planted, leaving the lock no floor at all. On the benchmark's tuning windows
    (65 frames, so the gap was up to 45 of the 56 frames the contacts were judged on), foot
    skate at 5 / 15 / 30 / 45 frames 24.4 / 31.9 / 31.6 / 32.4 -> 24.4 / 29.2 / 30.5 / 30.9
    and 24.1 / 29.3 / 28.9 / 27.9 -> 24.1 / 26.7 / 27.6 / 26.7 cm/s (gait and person / person
    left out), L2P 0.856 / 2.205 / 2.771 / 3.448 -> 0.854 / 2.224 / 2.765 / 3.471 and 0.746 /
    1.837 / 2.297 / 2.806 -> 0.745 / 1.858 / 2.298 / 2.828: the floor the clip's own feet
    stand on, which the truth's feet are on too, lifts fills that sank them."""
    from mocapkit.body import body_of
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.core.motion import concatenate
    from mocapkit.features import foot_contacts, ground_frame

    _, u, _ = ground_frame(up)
    out = np.full(motion.num_joints, np.nan)
    s0, s1 = max(skip[0], 0), min(max(skip[1], skip[0]), motion.num_frames)
    if s1 > s0:
        motion = concatenate([motion[:s0], motion[s1:]])
    if motion.num_frames < 2:
        return out
    try:
        contacts = foot_contacts(motion, feet=feet, up=up)
    except ValueError:  # no feet to plant
        return out
    planted = contacts.contacts
    h = forward_kinematics(motion)[0] @ u
    for k, j in enumerate(contacts.joints):
        if planted[:, k].any():
            out[j] = np.percentile(h[planted[:, k], j], 10)
    body = body_of(motion)
    for part in ("ankle", "toe"):
        pair = body.pair(part)
        if pair is not None:
            left, right = pair
            out[left] = out[right] if np.isnan(out[left]) else out[left]
            out[right] = out[left] if np.isnan(out[right]) else out[right]
    return out


def _floor_bound(
    motion: Motion, up: str, feet: Sequence[int], skip: tuple[int, int], planted: np.ndarray
) -> np.ndarray:
    """(len(feet),) the lowest each foot joint may go in the frames ``skip``: where ``motion``
    plants it (``planted``, :func:`_planted_heights`, for its joints ``feet``), or the lowest
    its frames outside ``skip`` put it, whichever is lower. Relies on: the clip's own frames
    show where its floor is; the planted height is a percentile of the planted frames, and a
    take that stands mostly on a raised heel plants its ankle higher than its flat stance
    (reviewer: Bandai-1 bow_musical_001's own left ankle 2.9 cm below its planted height)."""
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.features import ground_frame

    _, u, _ = ground_frame(up)
    keep = np.ones(motion.num_frames, bool)
    keep[skip[0] : skip[1]] = False
    if not keep.any():
        return planted
    h = forward_kinematics(motion[np.flatnonzero(keep)])[0][:, list(feet)] @ u
    # NaN stays NaN: a foot the clip plants nowhere has no floor (its lowest may be mid-swing)
    return np.minimum(planted, h.min(axis=0))


def _onto_floor(
    ex: Motion, pos, flags, gap, targets, weights, up: str, floor: np.ndarray, stand=None
):
    """``targets`` and ``weights`` of :func:`_lock_feet` (``pos``: the foot joints' positions,
    ``flags`` their contacts, ``gap`` the filled frames, ``floor`` the heights at which the clip
    plants them, :func:`_planted_heights`) with each foot joint that the filled frames plant
    lower than the clip plants it raised by the difference over all the filled frames, the
    lock's own correction kept as its weight applied it. The planted height is the 10th
    percentile of the joint's planted frames (a foot rolls up from the floor, not into it);
    differences under :data:`FLOOR_TOLERANCE_M` are left (a capture's own steps differ by as
    much). A foot is never lowered.

    Relies on: the floor is where the clip's own feet stand; the library segments were captured
    by other people, on their own floor, with their own foot joints, and fitted to the clip's
    bones and level, so their planted feet sit a few millimetres off the clip's floor (Bandai-2:
    the planted toe's height varies by 0.5 cm between takes). A foot below the floor is
    impossible and, moving, reads as skating. Tuning windows (bench_inbetween.py --tune; foot
    skate at 5 / 15 / 30 / 45 frames, the truth's 27.1 / 31.6 / 31.6 / 31.6 cm/s): without
    28.9 / 37.5 / 38.5 / 40.7, raised 28.7 / 34.9 / 33.4 / 34.2 (L2P at 15 / 30 frames 2.025 /
    2.502 against 2.010 / 2.473; with medians for the planted heights and no tolerance 33.1 /
    34.3 at 15 / 30 frames, but a capture filled from itself was moved by 7 mm). A first
    version (medians, every filled frame held at full weight, the toe lift below at 1.5 cm
    on) that also lowered feet planted above the floor: 30.6 / 37.0 / 35.8 / 36.3 (L2P
    2.072 / 2.513), raising only in that
    version 28.5 / 33.2 / 34.2 / 34.7 (2.034 / 2.506): lowering made both worse. Lifting
    free toes that sweep the floor at speed (to 1.5 or 2.5 cm above it) took off under 1 cm/s
    more and was left out: it would change captured swings.

    ``stand`` ((F,), optional): the share of its rise a foot joint planted on every filled
    frame and on the context frames beside them gets on each frame (:func:`_lock_feet`: none
    beside the gap, all once the end offsets have faded, or by the middle of a shorter gap).
    Relies on: a foot that stays planted through the gap stands where the
    context has it at both ends, at the context's own height; the fill sinks it below the floor
    only as it departs from the context (a library person standing with bent knees, the pelvis
    held at the clip's level), and raised whole from the first filled frame, a straight
    standing leg bent at once to lift it (newcomer: a Bandai-1 wave filled from bandai2's
    gestures, the knee 2.8 cm in the first filled frame, the take's largest step 0.58 cm; 0.8
    cm). Tuning gesture takes (bandai2's tenth, their person left out; 113 gaps of 30 frames,
    83 of 60), the legs' largest step in the filled frames over the take's largest: 1.93 ->
    1.55 and 2.38 -> 2.04 mean, over 2 in 42% -> 30% and 48% -> 36%; mean joint error 2.76 ->
    2.74 and 3.50 -> 3.49 cm. Locomotion (benchmark tuning windows) is unchanged (L2P at 5
    frames 0.860 and 0.741, person and gait or person left out; faded over the whole blend
    even in a gap shorter than two, and without asking the context to plant the foot too, it
    was 0.870 and 0.751, and a short fill's sunk foot stayed up to 2 cm low: reviewer).
    Raised frame by frame to the floor instead, or
    faded in on every foot: foot skate up to 1.8 cm/s more on the benchmark's tuning windows
    (a foot raised at once sits above the floor, where the skate measure counts it less)."""
    from mocapkit.features import ground_frame, metres_per_unit

    _, u, _ = ground_frame(up)
    h = pos @ u
    rise = np.zeros(pos.shape[1])
    for k in range(pos.shape[1]):
        fill = h[gap & flags[:, k], k]
        if len(fill) and np.isfinite(floor[k]):
            rise[k] = max(float(floor[k] - np.percentile(fill, 10)), 0.0)
    lift = np.flatnonzero(rise * metres_per_unit(ex, None) > FLOOR_TOLERANCE_M)
    if not len(lift):
        return targets, weights
    targets, weights = targets.copy(), weights.copy()
    r = np.ones(len(h)) if stand is None else np.asarray(stand, dtype=np.float64)
    beside = np.flatnonzero(gap)[[0, -1]] + [-1, 1]  # the context frames either side of it
    beside = beside[(beside >= 0) & (beside < len(h))]
    for k in lift:  # the lock's target as far as its weight pulled, then raised, held fully
        w = weights[gap, k, None]
        stands = flags[gap, k].all() and flags[beside, k].all()  # planted through, and beside
        raised = rise[k] * (r[gap, None] if stands else 1.0) * u
        targets[gap, k] = pos[gap, k] + w * (targets[gap, k] - pos[gap, k]) + raised
        weights[gap, k] = 1.0
    return targets, weights


SWING_SPEED_FRACTION = 0.6
"""A foot joint moving slower than this many character heights per second is not swinging
(:func:`_swing_clearance`): the speed test of :func:`mocapkit.features.foot_contacts`, which
tells a planted foot from a swinging one. A swinging foot moves at 2-4 m/s mid-swing; a slow
foot off the floor stands on something the floor is not, or hovers (newcomer report: CMU
03_01, uneven ground, a foot standing still 42 cm up on a box, not planted for the contact
detector, which assumes a flat floor, was raised towards the library segments' clearance and
slid 11 cm over a 0.1 s gap, 0.5 cm left alone; now 0.5 cm)."""


def _swing_clearance(ex: Motion, pos, planted, targets, weights, up: str, clearance, known):
    """``targets`` and ``weights`` of :func:`_lock_feet` with each filled frame's swinging foot
    joint (``planted`` False, ``known`` True, moving at :data:`SWING_SPEED_FRACTION` or faster)
    that the lock aims lower (its target as far as its
    weight pulls: the floor raise of :func:`_onto_floor` included) than ``clearance`` (F, n),
    the height its library segments had there above their own floor put on the clip's, aimed
    at that height instead, fully, where the difference is over :data:`FLOOR_TOLERANCE_M`. A
    foot is never lowered.

    Relies on: how high a swinging foot passes over the floor is part of the captured step
    (toe clearance is a few centimetres and varies little within a person's gait), while
    fitting a segment to the context (the end offsets of the legs' rotations, the pelvis
    level) moves the foot with the leg and can sweep it along or through the floor: on the
    tuning windows (bench_inbetween.py --tune --holdout person) the filled moving toes' 5th
    percentile height was -0.1 cm against the segments' own 1.2 and the truth's 1.4, and foot
    skate at 5 / 15 / 30 / 45 frames 30.8 / 37.8 / 35.2 / 36.8 cm/s against the truth's 27.1
    / 31.6 / 31.6 / 31.6; raised, 28.4 / 33.5 / 32.8 / 33.0 (L2P at 15 / 30 frames 2.219 /
    2.931 before, 2.208 / 2.934). Measured from the fill as it came, not from the lock's aim
    (a first version, which raised a fill standing low by that much again): 28.3 / 31.9 /
    29.9 / 28.8. Only the segments whose foot is free at the frame counting: 28.5 / 33.6 /
    32.7 / 32.7, left out. The floors are the clips' whole takes' (a segment's own planted
    frames gave within 0.3 cm/s)."""
    from mocapkit.features import character_height, ground_frame, metres_per_unit

    _, u, _ = ground_frame(up)
    tol = FLOOR_TOLERANCE_M / metres_per_unit(ex, None)
    aim = pos + weights[..., None] * (targets - pos)  # where the lock (and floor) put the foot
    # a foot the fill holds slow is not swinging, wherever it is: it stands on something the
    # floor is not (a step, a box) or hovers (the contact detector's speed test)
    speed = np.linalg.norm(np.gradient(pos, ex.frame_time, axis=0), axis=-1)
    swinging = speed >= SWING_SPEED_FRACTION * character_height(ex, up)
    rise = np.where(known & ~planted & swinging, clearance - aim @ u, 0.0)
    low = rise > tol
    if not low.any():
        return targets, weights
    targets, weights = targets.copy(), weights.copy()
    targets[low] = aim[low] + rise[low][:, None] * u  # raised from there, held fully
    weights[low] = 1.0
    return targets, weights


FLOOR_DIP_M = 0.005
"""How far below the height at which the clip plants it (:func:`_planted_heights`) a foot
joint may go in the filled frames (:func:`_above_floor`): a captured foot does not go lower
than where it stands by more than its markers' jitter (bandai2's tuning tenth, 75 takes: at
most 0.44 cm below its planted height, the median take 0.02 cm). A take standing mostly on a
raised heel goes further below its planted height (Bandai-1 bow_musical_001: 2.9 cm), so
the floor used is the lower of that and the clip's own lowest (:func:`_floor_bound`)."""


def _above_floor(ex: Motion, pos, gap, targets, weights, up: str, floor, feet):
    """``targets`` and ``weights`` of :func:`_lock_feet` with every filled frame (``gap``)
    where the lock aims a foot joint (its target as far as its weight pulls: the floor and
    swing rules of :func:`_onto_floor` and :func:`_swing_clearance` included) more than
    :data:`FLOOR_DIP_M` below ``floor`` (its planted height in the clip, (n,)) aimed higher,
    fully, whether the foot is planted, swinging or neither: each foot (``feet``: the columns
    of one leg's joints, ankle and toe) is raised whole by its lowest joint's depth, so that
    lifting the heel does not tip the toe down. A foot is never lowered. ``floor``: the
    clip's own floor (:func:`_floor_bound`).

    Relies on: a foot does not go through the floor (a captured foot joint stays within
    :data:`FLOOR_DIP_M` of where it stands). The floor and swing rules each cover feet the
    contact detector calls planted or fast; a foot between (sliding at a walking pace, as a
    segment of another gait fitted to the context drags it) was left where the fill put it
    (newcomer report: a Bandai-1 run filled from walks only, a toe 4 cm into the floor over
    five frames, unwarned). Not everywhere: on some frames the IK returns the leg as it was
    (run_angry_001 at 20:50 from walks, frames 44-45; why its solve fails there was not found),
    and near the gap's end the correction's speed limit cannot lift the foot in time (there
    the left ankle 7.6 cm below the floor 4 frames before the end, the middle of the gap on
    it; :attr:`Inbetween.feet_warning` says so). With the other
    foot's floor for a foot planted nowhere (:func:`_planted_heights`), on the benchmark's
    tuning windows (``--tune``, the take's gait and person / its person left out of the
    library), foot skate at 5 / 15 / 30 / 45 frames 24.8 / 32.1 / 34.2 / 33.7 -> 24.4 / 31.9 /
    31.6 / 32.4 and 24.6 / 29.8 / 30.6 / 28.5 -> 24.1 / 29.3 / 28.9 / 27.9 cm/s, L2P within
    0.7% (0.860 / 2.207 / 2.779 / 3.451 -> 0.856 / 2.205 / 2.771 / 3.448, gait left out)."""
    from mocapkit.features import ground_frame, metres_per_unit

    _, u, _ = ground_frame(up)
    aim = pos + weights[..., None] * (targets - pos)
    tol = FLOOR_DIP_M / metres_per_unit(ex, None)
    targets, weights = targets.copy(), weights.copy()
    for cols in feet:
        depth = np.nan_to_num(floor[None, cols] - aim[:, cols] @ u, nan=-np.inf).max(axis=1)
        low = gap & (depth > tol)
        if low.any():  # the whole foot onto the floor, held fully
            targets[np.ix_(low, cols)] = aim[np.ix_(low, cols)] + depth[low, None, None] * u
            weights[np.ix_(low, cols)] = 1.0
    return targets, weights


FEET_KEYS = ("floor_depth_m", "floor_depth_joint", "floor_depth_frame", "foot_skate_m_s",
             "clip_foot_skate_m_s", "clip_foot_skate_max_m_s")  # fmt: skip
"""What :func:`feet_measures` gives (and :meth:`Inbetween.to_json` reports)."""

SKATE_HEIGHT_M = 0.05
"""H of the foot-skate measure (:func:`feet_measures`): a foot joint at its planted height
counts whole, at H above it not at all (Zhang et al. 2018's weighting, as the benchmark's)."""


def feet_measures(
    before: Motion, after: Motion, a: int, b: int, up: str
) -> dict[str, Any]:
    """What the filled frames ``a..b-1`` of ``after`` do with the feet, against ``before``
    (the clip as given; only its frames outside the gap are read):

    - ``floor_depth_m``: how far the lowest foot joint goes below the clip's floor for it
      (:func:`_floor_bound`: where the clip plants it, or the lowest its own frames outside
      the gap put it; 0 when none does), with ``floor_depth_joint`` and ``floor_depth_frame``
      where (None at 0);
    - ``foot_skate_m_s``: a foot's horizontal speed over the filled frames (the steps
      A-1 -> A .. B-1 -> B), each of its joints weighted by how near its planted height it is
      (whole there, none :data:`SKATE_HEIGHT_M` above: Zhang et al. 2018, the benchmark's
      measure), the worse foot's (one foot skimming the floor while the other swings was
      averaged away over both: newcomer), ``clip_foot_skate_m_s`` the same over the clip's
      own frames outside the gap (a captured foot rolls and settles, so the clip's own is not
      zero), and
      ``clip_foot_skate_max_m_s`` the largest over the clip's own stretches as long as the
      fill's (as many steps, outside the gap; as long as the clip has on one side where it
      has less): over a few frames a captured foot's toe-off reads as a slide too, so a
      short fill is judged against the clip's short stretches.

    None for each where the rig has no legs (:meth:`mocapkit.body.Body.feet`), or the clip no
    planted foot or frame outside the gap to measure."""
    from mocapkit.body import body_of
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.features import ground_frame, metres_per_unit

    out: dict[str, Any] = dict.fromkeys(FEET_KEYS)
    sided = body_of(before).feet
    feet = sorted({j for _, j in sided})  # a rig without legs has none
    if not feet:
        return out
    by_foot = [[feet.index(j) for side, j in sided if side == s] for s in dict(sided)]
    floor = _planted_heights(before, up, feet, skip=(a, b))[feet]
    if not np.isfinite(floor).any():
        return out
    floor = _floor_bound(before, up, feet, (a, b), floor)
    mpu = metres_per_unit(before, None)
    _, u, _ = ground_frame(up)
    ground = np.eye(3) - np.outer(u, u)

    def skate(pos: np.ndarray) -> np.ndarray:  # (T, n, 3) -> (T-1, feet) m/s, each foot's
        v = np.linalg.norm(np.diff(pos, axis=0) @ ground, axis=-1) * before.fps * mpu
        h = (pos[1:] @ u - floor[None]) * mpu
        w = np.nan_to_num(np.clip(2.0 - np.power(2.0, h / SKATE_HEIGHT_M), 0.0, 1.0))
        return np.stack([(v * w)[:, cols].mean(axis=1) for cols in by_foot], axis=1)

    lo, hi = max(a - 1, 0), min(b + 1, after.num_frames)
    filled = forward_kinematics(after[lo:hi])[0][:, feet]
    depth = np.nan_to_num(floor[None] - filled[a - lo : a - lo + b - a] @ u, nan=-np.inf)
    f, k = np.unravel_index(int(np.argmax(depth)), depth.shape)
    out["floor_depth_m"] = max(float(depth[f, k]) * mpu, 0.0)
    if out["floor_depth_m"] > 0:  # where, only where a foot is below it
        out["floor_depth_joint"] = before.skeleton.names[feet[k]]
        out["floor_depth_frame"] = int(a + f)
    out["foot_skate_m_s"] = float(skate(filled).mean(axis=0).max())  # the worse foot's
    own = forward_kinematics(before)[0][:, feet]
    steps = skate(own)
    keep = np.ones(len(steps), bool)
    keep[max(a - 1, 0) : b] = False  # the steps into, within and out of the gap
    if keep.any():
        out["clip_foot_skate_m_s"] = float(steps[keep].mean(axis=0).max())
    # the clip's own stretches of the fill's steps, none touching the gap (as long as the
    # clip has beside it, where it has less), either foot
    runs = np.diff(np.flatnonzero(np.diff(np.r_[0, keep.astype(int), 0])).reshape(-1, 2))
    n = min(len(filled) - 1, int(runs.max()) if runs.size else 0)
    if n > 0:
        clean = np.convolve(keep, np.ones(n), "valid") == n
        most = max(
            np.convolve(np.where(keep, steps[:, k], 0.0), np.ones(n), "valid")[clean].max()
            for k in range(steps.shape[1])
        )
        out["clip_foot_skate_max_m_s"] = float(most / n)
    return out


FEET_WARN_DEPTH_M = 0.02
"""The written fill is warned of where a foot joint goes more than this below the clip's floor
(:func:`feet_measures`): a captured foot stays within half a centimetre of it
(:data:`FLOOR_DIP_M`); the foot lock holds the feet above it but near the gap's ends, where
its correction fades out to meet the context, a fill that sinks a foot deeply stays sunk."""
FEET_WARN_SKATE = 2.0
"""... and where a foot slides faster than this many times the most either foot does in the
clip's own stretches of the fill's length (``clip_foot_skate_max_m_s``), and faster than
:data:`FEET_WARN_SKATE_M_S`. Chosen on the tuning takes (bandai2's tenth, every class, gaps of
4 / 9 / 15 / 30 / 60 frames, 244 gaps): a foot of the truth slides over the gap at most 2.01x
the clip's largest stretch elsewhere (99th percentile 1.23), and only under 0.1 m/s past 2x,
so 2 never warns of a capture there (1.5 would have once); of the fills (the take's person,
or its person and gait, left out of the library) 0 and 1 went over it (the latter 8.9 cm
of mean joint error, against 1.2 for the rest), and 1 and 2 in 244 went over 2 cm below the
floor (:data:`FEET_WARN_DEPTH_M`). (Measured over both feet together, a foot skimming the
floor while the other swung was averaged away: newcomer.)"""
FEET_WARN_SKATE_M_S = 0.1
"""A standing take's feet barely move: a few centimetres a second over its own is no slide."""


def _feet_warning(feet: dict[str, Any]) -> str:
    """The warning of what the written fill does with the feet (:func:`feet_measures`), or ""."""
    said = []
    depth = feet.get("floor_depth_m")
    if depth is not None and depth > FEET_WARN_DEPTH_M:
        said.append(
            f"{feet['floor_depth_joint']} {depth * 100:.1f} cm below the floor the clip stands "
            f"on at frame {feet['floor_depth_frame']}"
        )
    skate, most = feet.get("foot_skate_m_s"), feet.get("clip_foot_skate_max_m_s")
    if (
        skate is not None
        and most is not None
        and skate > FEET_WARN_SKATE_M_S
        and skate > FEET_WARN_SKATE * most
    ):
        said.append(
            f"a foot sliding {skate:.2f} m/s near the floor, where the clip's own feet reach "
            f"{most:.2f} m/s at most in its stretches of that length"
        )
    return f"the fill puts {' and '.join(said)}" if said else ""


SOURCE_MARGIN = 6
"""Frames of each library segment sampled beyond the gap's ends (:func:`_source_segments`), so
that its contacts are judged with some of the motion around them."""


def _source_segments(onpath: Motion, a: int, b: int, lib: InbetweenLibrary, cands, up: str):
    """Each candidate's library motion over frames a-1-m .. b+m of the clip (m =
    :data:`SOURCE_MARGIN`, as the fill samples it; held at the library clip's ends), put on
    the clip's pelvis ground position and facing at frame a-1, with its normalised score
    weight (:func:`neighbour_weights`: positive, as the planted feet's drift and the swing
    clearance divide by them) and the heights at which its library clip plants its feet
    (:attr:`InbetweenLibrary.floors`)."""
    from mocapkit import features

    w = neighbour_weights([c.score for c in cands])
    w = w / w.sum()
    m = SOURCE_MARGIN
    out = []
    for c, wc in zip(cands, w, strict=True):
        src = lib.motions[c.clip]
        t = np.clip(c.start + c.rate * np.arange(-m, b - a + 2 + m), 0, src.num_frames - 1)
        rots, trans = _sample(src, t)
        has_t = src.translations is not None
        seg = Motion(src.skeleton, rots, trans[:, 0], src.frame_time, trans if has_t else None)
        seg = features.apply_ground_transform(
            seg, features.ground_alignment(onpath, a - 1, seg, m, up=up)
        )
        floor = lib.floors[c.clip] if lib.floors else _planted_heights(src, up)
        out.append((seg, float(wc), floor))
    return out


def _rate_limited(before: np.ndarray, after: np.ndarray, max_step: float) -> np.ndarray:
    """``after`` (F, J, 4) with each joint's correction from ``before`` (the rotation
    ``after before^-1``) turning no faster than ``max_step`` radians per frame. A hold that the
    foot lock lets go of within a frame or two (a knee held straight, then its own 146 deg), or
    a correction that turns the other way from one frame to the next (-18 deg, then +21 deg
    about the foot's axis), otherwise snaps the leg; the correction is not part of the motion,
    and turns no faster than :attr:`InbetweenConfig.lock_max_speed_deg`.

    Two steps, on the correction's rotation vector: its angle is capped by an envelope that
    grows at most ``max_step`` a frame from every frame where it is smaller (so it fades
    before a hold is let go of, and is nowhere larger than asked); then the vector follows the
    capped one, moving at most ``max_step`` a frame, forward from the first frame and backward
    from the last (a change of direction is spread over frames; the first and last frames
    keep theirs: none, on the context frames around a gap). Where nothing had to be slowed the
    result is ``after`` exactly. The rotation-vector difference bounds the turn between two
    frames (the exponential map shortens distances)."""
    d = rot.quat_mul(after, rot.quat_inv(before))
    d = np.where(d[..., :1] < 0, -d, d)
    v = rot.quat_to_rotvec(d)
    angle = np.linalg.norm(v, axis=-1)
    cap = angle.copy()
    for f in range(1, len(cap)):
        cap[f] = np.minimum(cap[f], cap[f - 1] + max_step)
    for f in range(len(cap) - 2, -1, -1):
        cap[f] = np.minimum(cap[f], cap[f + 1] + max_step)
    capped = v * np.where(angle > 1e-12, cap / np.maximum(angle, 1e-12), 1.0)[..., None]

    def follow(target: np.ndarray, start: np.ndarray) -> np.ndarray:
        out = target.copy()
        out[0] = start
        for f in range(1, len(out)):
            step = target[f] - out[f - 1]
            n = np.linalg.norm(step, axis=-1, keepdims=True)
            out[f] = out[f - 1] + step * np.minimum(1.0, max_step / np.maximum(n, 1e-12))
        return out

    lim = follow(follow(capped, capped[0])[::-1], capped[-1])[::-1]
    out = rot.quat_normalize(rot.quat_mul(rot.rotvec_to_quat(lim), before))
    same = np.all(lim == v, axis=-1)
    return np.where(same[..., None], after, out)


def _gentle_correction(
    before: np.ndarray, after: np.ndarray, fps: float, config: InbetweenConfig = DEFAULT_CONFIG
) -> np.ndarray:
    """``after`` (F, J, 4) with each joint's correction from ``before`` turning no faster than
    :attr:`InbetweenConfig.lock_max_speed_deg` (:func:`_rate_limited`), then smoothed over
    :attr:`InbetweenConfig.lock_smooth_seconds` (:func:`_smoothed_correction`); the first and
    last frames keep theirs. What a foot lock's IK correction goes through before it is applied
    (here, and to a stitch's cut: :func:`mocapkit.stitch.transition._planted_through`)."""
    step = math.radians(config.lock_max_speed_deg) / fps
    locked = _rate_limited(before, after, step)
    return _smoothed_correction(before, locked, config.lock_smooth_seconds * fps)


def _smoothed_correction(before: np.ndarray, after: np.ndarray, sigma: float) -> np.ndarray:
    """``after`` (F, J, 4) with each joint's correction from ``before`` (its rotation vector,
    of ``after before^-1``) smoothed over frames by a Gaussian of ``sigma`` frames, the first
    and last frames kept: the correction is extended past each end by odd reflection about
    that end's value (:func:`numpy.pad`, repeated over a span shorter than the kernel), so
    the smoothed ends are their own (none, on the context frames around a gap) and every
    step of the extension is one of the correction's, which a positive kernel of sum 1 cannot
    make larger: :func:`_rate_limited`'s limit holds. It rounds off the corners where the
    speed limit or the lock's fade-out switches the correction's speed within a frame, which
    would otherwise jolt the foot it moves (:attr:`InbetweenConfig.lock_smooth_seconds`). A
    joint with no correction is left exactly as it is; ``sigma`` 0 or fewer than 3 frames:
    ``after`` as it is."""
    from scipy.ndimage import gaussian_filter1d

    F = len(after)
    if sigma <= 0 or F < 3:
        return after
    d = rot.quat_mul(after, rot.quat_inv(before))
    v = rot.quat_to_rotvec(np.where(d[..., :1] < 0, -d, d))
    moved = np.abs(v).max(axis=(0, 2)) >= 1e-12  # (J,) joints the lock corrected
    if not moved.any():
        return after
    pad = math.ceil(4.0 * sigma)  # gaussian_filter1d's own reach (truncate=4)
    ext = np.pad(v, ((pad, pad), (0, 0), (0, 0)), mode="reflect", reflect_type="odd")
    smooth = gaussian_filter1d(ext, sigma, axis=0, truncate=4.0)[pad : pad + F]
    smooth[0], smooth[-1] = v[0], v[-1]  # rounding aside, they are already
    out = rot.quat_normalize(rot.quat_mul(rot.rotvec_to_quat(smooth), before))
    return np.where(moved[None, :, None], out, after)


ROOT_STILL_SECONDS = 0.5
"""A ground root that stays put this long before a gap at the clip's end is held there through
the gap (:func:`_back_to_clip`): half a gait cycle, over which a root riding under a walking
body moves by a step."""


def _back_to_clip(
    fill: Motion, clip: Motion, a: int, b: int, onpath: bool, up: str | None = None
) -> Motion:
    """The filled frames in the clip's own root convention (see the module docstring): the
    ground root interpolated between frames A-1 and B. Past a gap that ends the clip, held at
    A-1's where the clip holds it still over the :data:`ROOT_STILL_SECONDS` before the gap
    (Bandai's sits at the origin), else carried along with the body as it rode at A-1 (a root
    that follows the body's path keeps following it)."""
    if not onpath:
        return fill
    sk = clip.skeleton
    c = sk.children(0)[0]
    g = fill.num_frames
    u = (np.arange(g) + 1.0) / (g + 1.0)
    e = b if b < clip.num_frames else a - 1  # a gap that ends the clip: the root held
    q0 = clip.rotations[a - 1, 0]
    q1 = rot.quat_fix_hemisphere(clip.rotations[e, 0], q0)
    root_q = rot.quat_slerp(np.broadcast_to(q0, (g, 4)), np.broadcast_to(q1, (g, 4)), u)
    p0, p1 = clip.root_positions[a - 1], clip.root_positions[e]
    root_p = p0[None] * (1 - u[:, None]) + p1[None] * u[:, None]
    seen = clip[max(0, a - max(2, clip.seconds_to_frames(ROOT_STILL_SECONDS))) : a]
    still = np.allclose(seen.root_positions, p0, rtol=0, atol=1e-9 * (1 + np.abs(p0).max()))
    still = still and np.allclose(np.abs(np.sum(seen.rotations[:, 0] * q0, -1)), 1.0, atol=1e-12)
    if b >= clip.num_frames and not still:
        from mocapkit import features

        body0 = features.ground_root_on_path(clip[a - 1 : a], up)  # the body's frame at A-1
        gq0_inv = rot.quat_inv(body0.rotations[0, 0])
        rel_q = rot.quat_mul(gq0_inv, q0)  # the root in the body's frame
        rel_p = rot.quat_apply(gq0_inv, p0 - body0.root_positions[0])
        root_q = rot.quat_normalize(rot.quat_mul(fill.rotations[:, 0], rel_q[None]))
        root_p = fill.root_positions + rot.quat_apply(fill.rotations[:, 0], rel_p[None])
    tr = fill.local_translations()
    world_q = rot.quat_mul(fill.rotations[:, 0], fill.rotations[:, c])
    world_p = rot.quat_apply(fill.rotations[:, 0], tr[:, c]) + fill.root_positions
    inv = rot.quat_inv(root_q)
    out = fill.copy()
    out.rotations[:, 0] = root_q
    out.rotations[:, c] = rot.quat_normalize(rot.quat_mul(inv, world_q))
    tr[:, 0] = root_p
    tr[:, c] = rot.quat_apply(inv, world_p - root_p)
    out.root_positions = root_p
    out.translations = tr
    return out


TURN_OFFSET_MAX_DEG_S = 1000.0
"""The largest angular-velocity offset :func:`library_fill` carries into a fill (degrees per
second, per joint): about the fastest a person turns a joint (a sprinter's knee), so a capture
glitch that flips a joint between two context frames is not carried. The cap was three times
:attr:`InbetweenConfig.blend_max_speed_deg` (270 deg/s), so that the offset's return stayed
under that speed; what it left out reached the junction as a jump of velocity, a jolt
(newcomer report: a run's gap ending in a walk's swing, the knee's offset 705 deg/s, the toe at
2.9x its largest acceleration in the take; 2.0x at this cap). Largest joint acceleration from
two frames before a gap to its end over the take's 99th percentile, fills from the take's own
frames (gaps of 30 and 60 frames at 30%, 50%, 70% of the take), capped at 270 / 1000 deg/s:
CMU's 18 takes, mean 1.046 / 1.000 (102 fills: 13 better by over 0.05, 6 worse, the worst
+0.39); bandai2's tuning takes 2.236 / 2.198 (54 fills: 4 better, none worse). Tuning windows
(one future frame: the start's offset alone), L2P at 5 / 30 frames 0.858 / 2.775 -> 0.860 /
2.779, the legs' largest angular acceleration unchanged."""

TRANSLATION_OFFSET_MAX_M_S = 2.0
"""The largest translation velocity offset :func:`library_fill` carries into a fill (metres
per second, per joint): on the tuning windows they were at most 0.88 m/s; a capture glitch that
jumps the root would otherwise swing the fill by about a sixth of the jump per blend frame."""


def _capped(v: np.ndarray, cap: float) -> np.ndarray:
    """``v`` (..., 3) with each vector's length at most ``cap``."""
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return v * np.minimum(1.0, cap / np.maximum(norm, 1e-300))


def library_fill(
    clip: Motion,
    a: int,
    b: int,
    source: Motion,
    candidate: Candidate,
    *,
    up: str,
    config: InbetweenConfig = DEFAULT_CONFIG,
    future_frames: int | None = None,
) -> Motion:
    """The ``b - a`` frames filling ``clip[a:b]`` from ``source`` (a library motion on the
    clip's skeleton) as :class:`Candidate` says: sampled, ground-warped onto frames a-1 and b,
    end offsets blended in (module docstring). Both motions in the same root convention.
    ``future_frames``: how many frames from B on may be looked at (None: all the clip has);
    the velocity offsets at B need two."""
    from mocapkit import features

    g = b - a
    if not (1 <= a < b <= clip.num_frames):
        raise ValueError(
            f"library_fill: gap {a}:{b} needs a frame before it (the clip has {clip.num_frames} "
            "frames); inbetween() fills a gap at the clip's start on the reversed clip"
        )
    one_sided = b == clip.num_frames  # a gap at the clip's end: nothing to arrive at
    # a frame of the library clip before (after) the segment where the clip has a second frame
    # beside the gap: the velocity offsets of the joints' turns and translations
    before = int(a >= 2 and candidate.start - candidate.rate >= 0)
    end = candidate.start + candidate.rate * (g + 2)
    seen = clip.num_frames - b if future_frames is None else min(future_frames, clip.num_frames - b)
    after = int(not one_sided and seen >= 2 and end <= source.num_frames - 1)
    t = candidate.start + candidate.rate * np.arange(-before, g + 2 + after)
    rots, trans = _sample(source, t)
    has_t = source.translations is not None or clip.translations is not None
    seg = Motion(clip.skeleton, rots, trans[:, 0], clip.frame_time, trans if has_t else None)
    seg = _ground_warp(seg, clip, a - 1, None if one_sided else b, up, before, after)
    ct, st = clip.local_translations(), seg.local_translations()
    blend = min(max(clip.seconds_to_frames(config.blend_seconds), 1), g + 1)
    v0 = v1 = u0 = u1 = None
    sr = seg.rotations  # as warped: the root turns with the warp's growing heading correction
    # the segment's steps into A-1 and out of B; where its clip has no frame before (after)
    # it, its own first (last) step stands for the one it lacks
    if a >= 2:
        s_at, t_at = sr[before], st[before]
        s_prev, t_prev = (sr[0], st[0]) if before else (_carried_on(sr[1], sr[0]), 2 * t_at - st[1])
        v0 = _turn_offset(clip.rotations[a - 2], clip.rotations[a - 1], s_prev, s_at, 1)
        u0 = (ct[a - 1] - ct[a - 2]) - (t_at - t_prev)
    if not one_sided and seen >= 2:
        s_at, t_at = sr[-1 - after], st[-1 - after]
        s_next, t_next = (
            (sr[-1], st[-1]) if after else (_carried_on(sr[-2], sr[-1]), 2 * t_at - st[-2])
        )
        v1 = _turn_offset(clip.rotations[b], clip.rotations[b + 1], s_at, s_next, 0)
        u1 = (ct[b + 1] - ct[b]) - (t_next - t_at)
    cap = TRANSLATION_OFFSET_MAX_M_S * clip.frame_time / features.metres_per_unit(clip, None)
    u0, u1 = (None if u is None else _capped(u, cap) for u in (u0, u1))
    turn_cap = math.radians(TURN_OFFSET_MAX_DEG_S) * clip.frame_time
    v0, v1 = (None if v is None else _capped(v, turn_cap) for v in (v0, v1))
    keep = slice(before, seg.num_frames - after)
    seg, st = seg[keep], st[keep]
    r, tr = _offset_blend(
        seg.rotations, st, clip.rotations[a - 1],
        None if one_sided else clip.rotations[b], ct[a - 1], None if one_sided else ct[b],
        blend, math.radians(config.blend_max_speed_deg) * clip.frame_time, v0, v1, u0, u1,
        config.offset_keep,
    )  # fmt: skip
    return Motion(clip.skeleton, r[1:-1], tr[1:-1, 0], clip.frame_time, tr[1:-1] if has_t else None)


def _carried_on(q_from: np.ndarray, q_to: np.ndarray) -> np.ndarray:
    """The rotations one frame past ``q_to`` at the turn from ``q_from`` to ``q_to`` (each joint
    in its parent's frame, the turn ``q_to q_from^-1`` applied once more): a segment's step
    carried on where its clip has no frame beyond it (constant angular velocity)."""
    return rot.quat_normalize(rot.quat_mul(rot.quat_mul(q_to, rot.quat_inv(q_from)), q_to))


def _turn_offset(c0, c1, s0, s1, junction: int) -> np.ndarray:
    """(J, 3) the clip's turn per frame from rotations ``c0`` to ``c1`` less the segment's from
    ``s0`` to ``s1`` (rotation vectors in each joint's parent frame, the segment's carried by
    the offset that puts it on the clip at the junction, the pair's first frame (``junction``
    0) or second (1)): the angular-velocity offset :func:`_offset_blend` carries at a junction.
    The root's too: on a rig without a ground root it is the pelvis, whose tilt and roll the
    ground warp does not set (on Bandai's, a heading, the tuning windows are the same with or
    without it)."""

    def turn(q0, q1):
        d = rot.quat_mul(q1, rot.quat_inv(q0))
        return rot.quat_to_rotvec(np.where(d[..., :1] < 0, -d, d))

    c, s = (c0, s0) if junction == 0 else (c1, s1)
    offset = rot.quat_mul(c, rot.quat_inv(s))
    return turn(c0, c1) - rot.quat_apply(offset, turn(s0, s1))


def _level_offset(
    clip: Motion, a: int, source: Motion, candidate: Candidate, up: str, seconds: float
) -> float | None:
    """How far (file units, along ``up``) the clip's pelvis level is above the segment's, each
    the mean pelvis height over the ``seconds`` before the gap (the clip's frames before A, the
    segment's before its start), or None: off, or less than half of ``seconds`` on either side.
    Measured over fewer frames than ``seconds`` holds (a gap less than ``seconds`` into the
    clip, or into the segment's clip), the difference is shrunk by the share of them measured.

    Relies on: a standing person's pelvis rises and falls twice per gait cycle, about 0.5 s
    apart at a walk, around a level that their build and style set, which a library segment
    of another person or style does not share; the end offsets meet the context at the gap's
    ends but fade out within :attr:`InbetweenConfig.blend_seconds`, leaving the middle at the
    segment's level. A mean over a whole bob is the level; over a fraction of one it carries
    the bob's phase (tuning windows, 10 past frames, a first version shifting each segment on
    its own: over 0.1 s L2P at 15 / 30 frames 2.235 / 2.615 against 2.125 / 2.554 without,
    over 0.2 s 2.106 / 2.549, over 0.33 s 2.022 / 2.477). The two means are taken over the
    same phase of the segment's and the clip's bob (the search matches the bob at A-1), so
    the phase cancels where the two bob alike; where they do not (another gait, a deeper bob),
    a part-bob mean measures the depth as a level, the more so the less of the bob it spans:
    the share held is the share of ``seconds`` measured (a shrinkage toward no shift as the
    estimate gets noisier). Tuning windows (10 past frames of 15: held 0.67), L2P at 15 / 30 /
    45 frames, the take's person and gait left out of the library: 2.325 / 3.303 / 4.220 held
    whole, 2.284 / 3.254 / 4.161 at 0.67 (2.283 / 3.252 / 4.162 at 0.5); its person left out:
    1.922 / 2.612 / 3.123, 1.894 / 2.561 / 3.080 (1.903 / 2.569 / 3.089); at 5 frames the level
    is faded out (0.862 and 0.745 either way). The pelvis height over 30-frame gaps (person
    and gait left out) was 1.87 cm RMS off held whole, 1.93 without the level: held whole,
    the level missed by 2-3 cm the wrong way in the runs whose bob is deeper than the
    library's."""
    from mocapkit import features
    from mocapkit.core.kinematics import forward_kinematics

    if seconds <= 0:
        return None
    m = min(a, clip.seconds_to_frames(seconds))
    k = np.arange(m)
    ts = candidate.start - candidate.rate * k  # the segment's frames for A-1, A-2, ...
    k, ts = k[ts >= 0], ts[ts >= 0]
    if len(k) == 0 or len(k) < clip.seconds_to_frames(seconds / 2):
        return None
    r, tr = _sample(source, ts)
    before = Motion(clip.skeleton, r, tr[:, 0], clip.frame_time, tr)
    pel = features.pelvis_index(clip.skeleton)
    _, upv, _ = features.ground_frame(up)
    seg_h = forward_kinematics(before)[0][:, pel] @ upv
    clip_h = forward_kinematics(clip[a - 1 - int(k[-1]) : a])[0][::-1, pel] @ upv
    share = min(1.0, len(k) / clip.seconds_to_frames(seconds))
    return share * float(clip_h.mean() - seg_h.mean())


LEVEL_MAX_HEIGHT_FRACTION = 0.03
"""A level shift larger than this fraction of the character's height (4-5 cm for a person)
is not made: people's pelvis levels differ by less (Bandai-2 walks: 0.6 cm standard deviation
between takes), so a larger difference is something else (a crouch, a slope) that the legs
could not take up."""


def _to_level(
    clip: Motion, a: int, b: int, fill: Motion, shift: float, up: str, config: InbetweenConfig
) -> Motion:
    """``fill`` (frames A..B-1 on ``clip``'s path) with the pelvis ``shift`` (file units, along
    ``up``: :func:`_level_offset`, combined over the candidates with the fill's weights) up or
    down in the middle of the gap, fading to none at its ends as the end offsets do (the context
    frames are met exactly), and the legs turned by IK (:mod:`mocapkit.ik`) so that the feet
    stay where ``fill`` puts them: the ground is at the same height for everyone, so a foot the
    segments put on it stays there and the legs take up the change of level (tuning windows: the
    level alone, feet moved with the pelvis, L2P at 15 / 30 frames 2.062 / 2.537 and foot skate
    39.2 / 41.2 cm/s; with the feet kept 2.010 / 2.473 and 37.5 / 38.5, against 2.125 / 2.554
    and 37.4 / 38.6 without either). A rise is capped on each frame where a leg could not
    reach its foot (99.9% of the hip-to-ankle length: the knee 5 deg from straight), so every
    foot is within reach and the per-frame IK follows the smooth level without popping.
    The legs' correction turns no faster than a foot lock's (:func:`_gentle_correction`):
    tuning windows (the take's person and gait left out), L2P at 15 / 30 frames 2.284 / 3.254
    either way, the legs' largest angular acceleration in a window at 30 frames (99th
    percentile / largest) 30.1 / 32.9 -> 27.4 / 28.5 deg/frame² (the truth's 40.1 / 43.2).
    Unchanged when the shift is under 1 mm, over :data:`LEVEL_MAX_HEIGHT_FRACTION` of the
    character's height, or the rig has no legs to solve."""
    from mocapkit import features, ik
    from mocapkit.core.kinematics import forward_kinematics

    mpu = features.metres_per_unit(clip, None)
    if abs(shift) * mpu < 1e-3 or abs(shift) > LEVEL_MAX_HEIGHT_FRACTION * (
        features.character_height(clip, up)
    ):
        return fill
    chains, effs = ik.legs_and_feet(fill)
    if not effs:
        return fill
    g = fill.num_frames
    blend = min(max(clip.seconds_to_frames(config.blend_seconds), 1), g + 1)
    w0 = _decay(g + 2, blend)
    w1 = np.zeros_like(w0) if b == clip.num_frames else w0[::-1]  # no end to meet at the clip's
    profile = np.clip(1.0 - w0 - w1, 0.0, 1.0)[1:-1] * shift  # as the end offsets fade
    _, upv, _ = features.ground_frame(up)
    pos, _ = forward_kinematics(fill)
    if shift > 0:  # a rise no leg can follow to its foot is capped there
        tr = fill.local_translations()
        reach = np.full(g, np.inf)
        for c in chains:
            hip, knee, ankle = c.joints
            length = 0.999 * (
                np.linalg.norm(tr[:, knee], axis=-1) + np.linalg.norm(tr[:, ankle], axis=-1)
            )
            d = pos[:, hip] - pos[:, ankle]
            h = d @ upv
            side = np.linalg.norm(d - h[:, None] * upv[None], axis=-1)
            reach = np.minimum(reach, np.sqrt(np.maximum(length**2 - side**2, 0.0)) - h)
        # min() of two smooth curves: continuous, so the cap does not pop the pelvis
        profile = np.minimum(profile, np.maximum(reach, 0.0))
    lifted = fill.copy()
    lifted.root_positions = fill.root_positions + profile[:, None] * upv[None]
    if lifted.translations is not None:
        lifted.translations[:, 0] = lifted.root_positions
    solved = ik.solve(lifted, chains, pos[:, effs]).motion
    legs = sorted({j for c in chains for j in c.joints})
    # the legs' correction goes through the foot lock's speed limit and smoothing: a leg near
    # straight takes up a centimetre of level with a fast swing of the knee, which the capped
    # rise's corner turns into a jolt (newcomer report: a Bandai-1 walk filled at 60:75, the
    # left knee 54 m/s² against the take's own 29 there; 16 with it); the context frames
    # around the fill (no correction) bound its ramp; a gap at the clip's end keeps its last
    # frame's correction (its level does not fade there: reviewer)
    own, fit = fill.rotations[:, legs], solved.rotations[:, legs]
    last = fit[-1:] if b == clip.num_frames else own[-1:]
    before = np.concatenate([own[:1], own, own[-1:]])
    after = np.concatenate([own[:1], fit, last])
    lifted.rotations[:, legs] = _gentle_correction(before, after, clip.fps, config)[1:-1]
    return lifted


STANDING_SPEED_M_S = 0.25
"""A clip whose pelvis travels slower than this over the gap stands (a person shifting their
weight; a slow walk is 0.5 m/s or more): :attr:`InbetweenConfig.average_min_motion` judges the
combination of its segments, whose strokes nothing keeps in step. A travelling clip's steps are
kept in step by the search's path and pose terms at both ends, and combining them is what the
benchmark measures as better even where it damps them (tuning windows, the rule on every clip:
L2P at 30 frames +2.4% and +2.8%, the take's gait and person or its person left out)."""


def _ground_speed(ctx: GapContext, g: int, mpu: float) -> float:
    """The clip's pelvis speed over the ground (m/s): over the gap (A-1 to B), or at A-1 for a
    gap at the clip's end; inf where there is no frame time to tell."""
    if ctx.frame_time is None:
        return math.inf
    if ctx.one_sided:
        return float(np.linalg.norm(ctx.velocity)) * mpu / ctx.frame_time
    return float(np.linalg.norm(ctx.travel)) * mpu / ((g + 1) * ctx.frame_time)


def _gait_share(best: Candidate, gait_miss_m2: float, config: InbetweenConfig, mpu: float) -> float:
    """:attr:`InbetweenConfig.gait_share`, less where the library's best segment arrives at the
    first future frame closer than the clip's gait carried on does (``gait_miss_m2``, m²
    summed over the joints): times the ratio of the two misses, where under 1. Each source is
    trusted as far as it predicts the one frame after the gap both must reach: the clip's own
    take in the library, which meets it exactly, fills the gap alone."""
    share = config.gait_share
    if best.mismatch is None or gait_miss_m2 <= 0:
        return share
    # frames s-1, s and s+g+1 less the clip's (a gap with frames on both sides: three rows)
    at_b = best.mismatch.reshape(3, -1)[2] * mpu
    return share * min(1.0, float(np.sum(at_b**2)) / gait_miss_m2)


def motion_kept(
    combined: Motion, fills: Sequence[Motion], weights: Sequence[float] | None = None
) -> float:
    """How much of ``fills``' own motion ``combined`` (their combination) keeps: how far the
    joints swing about their mean pose over the frames (per joint, the RMS angle of each frame
    from the joint's mean rotation; over the joints, their root sum of squares), the
    combination's over the fills' mean (weighted by ``weights``' sizes: a segment that hardly
    counts does not lower the bar); 1 where the fills do not move. An amplitude, not a path
    length: the jitter a signed combination adds lengthens a joint's path while its strokes
    cancel (newcomer: a wave combined to 58% of its hand path read as 108% kept by the path)."""
    def swing(m: Motion) -> float:
        q = m.rotations
        q = np.where(np.sum(q * q[:1], axis=-1, keepdims=True) < 0, -q, q)
        mean = q.sum(axis=0)
        mean /= np.maximum(np.linalg.norm(mean, axis=-1, keepdims=True), 1e-12)
        cos = np.clip(np.abs(np.sum(q * mean[None], axis=-1)), 0.0, 1.0)
        return float(np.sqrt(np.sum(np.mean((2.0 * np.arccos(cos)) ** 2, axis=0))))

    w = np.ones(len(fills)) if weights is None else np.abs(np.asarray(weights, np.float64))
    own = float(np.dot(w, [swing(f) for f in fills]) / max(w.sum(), 1e-12))
    return swing(combined) / own if own > 0 else 1.0


def _average_fills(fills: Sequence[Motion], weights: Sequence[float] | None = None) -> Motion:
    """The weighted mean of fills of the same frames: local rotations by the normalised weighted
    sum of the quaternions (each put in the first fill's hemisphere), local translations by the
    weighted mean. ``weights``: :func:`fill_weights` (equal without)."""
    if len(fills) == 1:
        return fills[0]
    w = np.ones(len(fills)) if weights is None else np.asarray(weights, np.float64)
    first = fills[0]
    q = np.zeros_like(first.rotations)
    for wi, f in zip(w, fills, strict=True):
        r = f.rotations
        q += wi * np.where(np.sum(r * first.rotations, -1, keepdims=True) < 0, -r, r)
    tr = np.tensordot(w / w.sum(), np.stack([f.local_translations() for f in fills]), axes=1)
    has_t = first.translations is not None
    return Motion(
        first.skeleton, rot.quat_normalize(q), tr[:, 0], first.frame_time, tr if has_t else None
    )


def fill_weights(
    cands: Sequence[Candidate], config: InbetweenConfig = DEFAULT_CONFIG, mpu: float = 0.01
) -> np.ndarray:
    """(k,) the weights (summing to 1, some may be negative) that combine the candidates' fills:
    the local linear estimate at the context. :func:`neighbour_weights` weight each candidate
    by its score; a weighted mean is then biased wherever the candidates sit mostly to one side
    of the context (all a little ahead in their step, all a little higher). Regressing the
    fills on the candidates' mismatches (:attr:`Candidate.mismatch`, in metres) over their
    :attr:`InbetweenConfig.regression_rank` main directions, ridge
    :attr:`InbetweenConfig.regression_ridge_m`, and reading the fit at zero mismatch removes
    that bias to first order. It relies on the motion that follows a junction changing
    smoothly, nearly linearly, with the state at the junction between close neighbours (a
    step a frame later in, a step a frame later through the gap). The estimate is a linear
    combination of the fills: weight ``w_i (1 + z0 A^-1 z_i)`` (local linear regression's
    equivalent kernel), so the mean of fills that each meet the context meets it too."""
    w = neighbour_weights([c.score for c in cands])
    w = w / w.sum()
    r = min(int(config.regression_rank), len(cands) - 2)
    if r < 1 or any(c.mismatch is None for c in cands):
        return w
    X = np.stack([c.mismatch for c in cands]) * (mpu / math.sqrt(cands[0].mismatch.size))
    mx = w @ X
    Xc = X - mx
    _, _, vt = np.linalg.svd(np.sqrt(w)[:, None] * Xc, full_matrices=False)
    Z = Xc @ vt[:r].T  # (k, r) the candidates on the main directions of their spread
    A = Z.T @ (w[:, None] * Z) + config.regression_ridge_m**2 * np.eye(r)
    return w * (1.0 + Z @ np.linalg.solve(A, -(mx @ vt[:r].T)))


def neighbour_weights(scores: Sequence[float]) -> np.ndarray:
    """Score weights of the combined candidates (best first; :func:`fill_weights` corrects
    them): ``exp(-(s - s0) / (s0 + 1))`` with s0 the
    best score, in the score's units (a squared tolerance). A candidate as good as the best
    counts as much; one twice as far from the context counts e^-1 as much; where the best
    meets the context exactly (the clip's own take in the library, s0 = 0), candidates
    hundreds of units worse count for nothing (averaged equally they moved the exact fill by
    5.5 cm on average, newcomer report)."""
    s = np.asarray(scores, dtype=np.float64)
    s0 = float(s.min())
    return np.exp(-(s - s0) / (s0 + 1.0))


def kalman_fill(
    clip: Motion,
    a: int,
    b: int,
    *,
    window: int = 5,
    future_frames: int | None = None,
    model: ConstantAccelerationModel = DEFAULT_MODEL,
) -> Motion:
    """Today's Kalman transition over the gap: every joint's rotation relative to frame a-1
    (``log(q_{a-1}⁻¹ q)``) and every local translation, observed on ``min(window, a)`` past
    frames and ``min(window, frames after b)`` future frames (at most ``future_frames``), the
    ``b - a`` gap frames unobserved, smoothed with the L-score's constant-acceleration model
    (as :func:`mocapkit.stitch.stitch_motions` makes a stitch's injected frames)."""
    from mocapkit.stitch.transition import _relative_logs

    g = b - a
    if not (1 <= a < b < clip.num_frames):
        raise ValueError(
            f"kalman_fill: gap {a}:{b} needs frames before and after it (the clip has "
            f"{clip.num_frames}); a gap at the clip's start or end is filled by inbetween()"
        )
    wp = min(window, a)
    wf = min(window, clip.num_frames - b)
    if future_frames is not None:
        wf = max(1, min(wf, int(future_frames)))
    idx = np.r_[np.arange(a - wp, a), np.arange(b, b + wf)]
    J = clip.num_joints
    ref = clip.rotations[a - 1]
    logs = _relative_logs(ref, clip.rotations[idx]).reshape(len(idx), 3 * J)
    tr = clip.local_translations()[idx]
    centre = tr[wp - 1].copy()
    mask = np.r_[np.ones(wp, bool), np.zeros(g, bool), np.ones(wf, bool)]
    P = smoother_matrix(model, mask)[wp : wp + g, 0, :]  # the gap's steps
    gen_rots = rot.quat_normalize(
        rot.quat_mul(ref[None], rot.quat_exp((P @ logs).reshape(g, J, 3)))
    )
    gen_tr = (P @ (tr - centre).reshape(len(idx), 3 * J)).reshape(g, J, 3) + centre
    has_t = clip.translations is not None
    return Motion(clip.skeleton, gen_rots, gen_tr[:, 0], clip.frame_time, gen_tr if has_t else None)


# --------------------------------------------------------------------------------- result


@dataclass(frozen=True, eq=False)
class Inbetween:
    """An in-betweened motion: ``motion`` is the clip with frames ``gap[0]..gap[1]-1`` replaced.

    ``method``: "library" (filled from the best candidate ``candidate``, library file
    ``source``, its frames ``source_frames``, combined with the next best ones: all of them in
    ``blended_from``, with their weights from :func:`fill_weights`) or "kalman" (the Kalman
    transition: asked for, or the fallback of ``requested`` "auto"; ``candidate`` is still the
    best library candidate, for the report). ``kalman_lscore``: the Kalman transition's own
    two-sided L-score; ``candidates``: library candidates scored; ``search_seconds``: wall time
    of the search.
    """

    motion: Motion
    gap: tuple[int, int]
    method: str
    candidate: Candidate | None
    source: str | None
    kalman_lscore: float
    candidates: int
    search_seconds: float
    clip_name: str = "clip"
    library_names: tuple[str, ...] = ()
    output: str | None = None
    parameters: dict[str, Any] = field(default_factory=dict)
    library_lscore: float = math.nan
    source_frames: tuple[int, int] | None = None
    """Frames of the library clip file that fill the gap (ascending, stop excluded)."""
    backwards: bool = False
    """True when the library clip was played backwards (its frames ``source_frames`` fill the
    gap in reverse order)."""
    blended_from: tuple[dict[str, Any], ...] = ()
    """The library segments combined into the fill, best first (the others where their share
    is not 0 to 4 decimals): ``weight`` (its share, :func:`fill_weights`, to 4 decimals: the
    shares sum to 1 within the rounding and the unlisted, some may be negative), ``source``
    (file),
    ``source_frames`` (its frame numbers, ascending, stop excluded), ``backwards``, ``rate``
    (speed factor), ``score``. Empty when the Kalman transition filled the gap."""
    requested: str = "auto"
    """The method asked for (:data:`METHODS`)."""
    note: str = ""
    """Why there is no library candidate (e.g. no library clip long enough for the gap), in
    which case ``candidate`` and ``source`` are None and the Kalman transition fills it."""
    pose_rms_m: float = math.nan
    """The best segment's RMS joint distance (metres, body-local) to the context's poses at
    the gap's ends (the last two past frames and the first future frame)."""
    path_miss_m: float = math.nan
    """How far (metres) the best segment's ground path over the gap misses the context's (a
    turn counts :attr:`InbetweenConfig.travel_tolerance_m` per ``turn_tolerance_deg``)."""
    warning: str = ""
    """Set when the best segment's ground path is far from the context's
    (:attr:`InbetweenConfig.poor_fit_path_m`): the library holds nothing like the motion around
    the gap, and the fill may not look like the clip's."""
    library_lscore_ends: tuple[float, float] = (math.nan, math.nan)
    """The library fill's L-scores at its two junctions (their sum is :attr:`library_lscore`),
    the costs of the sidecar's two transitions."""
    replaced_lscore: float = math.nan
    """The two-sided L-score of the clip's own frames the fill replaced, scored the same way:
    the scale the other L-scores read on (an L-score has no unit a user knows; a fill scoring
    about what the capture scored there is as smooth at its junctions as the capture was; a
    glitch in the frames replaced scores higher)."""
    unlike: bool = False
    """True when "auto" gave the gap to the Kalman transition because the library holds nothing
    like the motion around it (:attr:`warning`; :attr:`InbetweenConfig.fallback`)."""
    feet: dict[str, Any] = field(default_factory=dict)
    """What the written fill does with the feet (:func:`feet_measures`): how far a foot goes
    below the clip's floor, and how fast the feet slide on it against the clip's own."""

    motion_kept: float = math.nan
    """The share of the combined segments' own motion their combination kept
    (:func:`motion_kept`); under :attr:`InbetweenConfig.average_min_motion` the best segment
    filled the gap alone. Judged where the clip stands only (:data:`STANDING_SPEED_M_S`): NaN
    for a travelling clip, and where one segment was searched for (or none)."""

    gait_share: float = 0.0
    """The share of the fill's body-local pose that carries on the clip's own gait
    (:attr:`InbetweenConfig.gait_share`, :mod:`mocapkit.stitch.gait`); 0 where none was
    (a standing clip, a gap shorter than half a gait cycle or at the clip's start or end, the
    Kalman transition)."""
    gait_half_period_s: float = math.nan
    """The half gait cycle that prediction read from the first future frame (seconds; NaN
    where :attr:`gait_share` is 0)."""

    @property
    def feet_warning(self) -> str:
        """Set when the written fill puts a foot well below the clip's floor or slides the feet
        more than the clip's own stretches of its length do (:func:`feet_measures`): measured
        on the frames written, whatever filled them and however well the library fit."""
        return _feet_warning(self.feet)

    @property
    def largest(self) -> dict[str, Any] | None:
        """The entry of :attr:`blended_from` with the largest weight: the segment the fill owes
        most to, which the sidecar names (None without one)."""
        return max(self.blended_from, key=lambda x: x["weight"]) if self.blended_from else None

    @property
    def fell_back(self) -> bool:
        """True when "auto" chose the Kalman transition over the library."""
        return self.method == "kalman" and self.requested == "auto"

    def difference_to(self, reference: Motion) -> float:
        """The largest joint position difference (file units) between the filled frames and
        the same frames of ``reference`` (e.g. the take before its gap was blanked)."""
        from mocapkit.core.kinematics import forward_kinematics

        a, b = self.gap
        filled, _ = forward_kinematics(self.motion[a:b])
        truth, _ = forward_kinematics(reference[a:b])
        return float(np.abs(filled - truth).max())

    def provenance(self, output: str, parameters: dict[str, Any] | None = None) -> Provenance:
        """The sidecar (:mod:`mocapkit.provenance`): the clip's frames, the filled frames (kind
        "inbetween", with the library clip and frames of the segment with the largest weight in
        :attr:`blended_from`; "generated" for the Kalman fallback),
        the clip's frames again, and the two junctions as transitions."""
        a, b = self.gap
        F = self.motion.num_frames
        backwards = self.backwards
        if self.method == "kalman":
            mid = Segment(a, b, "generated", None, None, None)
            trans = [
                TransitionTaken(a, self.clip_name, a - 1, self.clip_name, b, self.kalman_lscore)
            ]
        else:
            assert self.source_frames is not None and self.candidate is not None
            # the segment the fill owes most to (newcomer report: the best-scoring one was
            # named at a weight of -7%, the one weighing 55% nowhere)
            source, (s0, s1), backwards = self.source, self.source_frames, self.backwards
            if (main := self.largest) is not None:
                source, (s0, s1), backwards = (
                    main["source"], main["source_frames"], main["backwards"]
                )
            mid = Segment(a, b, "inbetween", source, s0, s1, backwards)
            first, last = (s1 - 1, s0) if backwards else (s0, s1 - 1)  # in gap order
            l0, l1 = self.library_lscore_ends  # the written frames' junctions
            trans = [
                TransitionTaken(a, self.clip_name, a - 1, source, first, l0),
                TransitionTaken(b, source, last, self.clip_name, b, l1),
            ]
            # a gap at the clip's start or end has one junction
            trans = [t for t in trans if 0 < t.output_frame < F]
        segs = [
            Segment(0, a, "clip", self.clip_name, 0, a),
            mid,
            Segment(b, F, "clip", self.clip_name, b, F),
        ]
        segs = [x for x in segs if x.output_stop > x.output_start]
        params = {"gap": [a, b], "method": self.method, **self.parameters, **(parameters or {})}
        params["requested"] = self.requested
        if self.warning:
            params["warning"] = self.warning
        if self.feet_warning:
            params["feet_warning"] = self.feet_warning
        if self.unlike:  # the warning is why the Kalman transition filled the gap
            params["unlike"] = True
        if self.note:  # why no library segment filled the gap
            params["note"] = self.note
        if self.method == "library" and len(self.blended_from) == 1 and self.motion_kept < 1:
            params["motion_kept"] = self.motion_kept  # why the best alone (a standing take)
        if self.gait_share > 0:  # how much of the fill is the clip's own gait carried on
            params["gait_share"] = self.gait_share
            params["gait_half_period_s"] = self.gait_half_period_s
        if self.method == "library":
            params["source_backwards"] = backwards  # the segment named, as segments names it
            params["blended_from"] = [dict(x) for x in self.blended_from]
        return Provenance(
            "inbetween", str(output), float(self.motion.fps), F,
            list(dict.fromkeys([self.clip_name, *self.library_names])), params, segs, trans,
        )  # fmt: skip  # the clip once, though its own frames were searched as a library clip

    def to_json(self) -> dict[str, Any]:
        c = self.candidate
        a, b = self.gap
        used = self.method == "library"
        return {
            "clip": self.clip_name,
            "gap": [a, b],
            "method": self.method,
            "requested": self.requested,
            "fell_back": self.fell_back,
            # the best library segment (filled the gap combined with blended_from's others,
            # or, when the Kalman transition filled it, the one it was compared with)
            "source": self.source,
            "source_frames": None if self.source_frames is None else list(self.source_frames),
            "source_backwards": self.backwards,
            "source_used": used,
            "blended_from": [dict(x) for x in self.blended_from],
            # the best segment's own search scores: raw, joined to the context as found
            **{  # the L-score of a junction a gap at the clip's start or end lacks is null
                f"segment_{k}": None if c is None else _finite_or_none(getattr(c, k))
                for k in ("rate", "score", "lscore", "lscore_start", "lscore_end", "travel", "pose")
            },
            # the final filled frames' two-sided L-score, and the Kalman transition's: the pair
            # the fallback compares (the segment's own differs: the fill is blended and combined)
            "library_lscore": _finite_or_none(self.library_lscore),
            "pose_rms_m": _finite_or_none(self.pose_rms_m),
            "path_miss_m": _finite_or_none(self.path_miss_m),
            "warning": self.warning or None,
            "feet_warning": self.feet_warning or None,
            "motion_kept": _finite_or_none(self.motion_kept),
            "gait_share": self.gait_share,
            "gait_half_period_s": _finite_or_none(self.gait_half_period_s),
            "note": self.note or None,
            "kalman_lscore": _finite_or_none(self.kalman_lscore),
            "replaced_lscore": _finite_or_none(self.replaced_lscore),
            **{k: _finite_or_none(v) if isinstance(v, float) else v
               for k, v in {**dict.fromkeys(FEET_KEYS), **self.feet}.items()},
            "candidates": self.candidates,
            "search_seconds": round(self.search_seconds, 4),
            "output": self.output,
        }


def _check_rate(library: InbetweenLibrary, frame_time: float) -> None:
    """Refuse a library prepared for clips at another frame rate than ``frame_time``'s."""
    lib_fps, fps = 1.0 / library.motions[0].frame_time, 1.0 / frame_time
    if not math.isclose(lib_fps, fps, rel_tol=1e-6):
        raise ValueError(
            f"the library was prepared for clips at {lib_fps:.6g} fps, the clip is at "
            f"{fps:.6g} fps: prepare it with this clip as the reference"
        )


def _as_library(library, clip: Motion, names, up: str, config: InbetweenConfig) -> InbetweenLibrary:
    if isinstance(library, InbetweenLibrary):
        if library.up != up:
            raise ValueError(
                f"the library was prepared with up axis {library.up}, the clip uses {up}"
            )
        lib_sk = library.motions[0].skeleton
        if list(lib_sk.names) != list(clip.skeleton.names):
            raise ValueError("the library was prepared for another skeleton")
        # prepared for another person's proportions: its root motion was scaled to their legs
        # (1%: people's legs differ by more; a capture's bones may stretch a little over a take,
        # and a gap at the clip's start reads the reversed clip, whose first frame is the last)
        lib_leg, leg = _leg_length(library.motions[0]), _leg_length(clip)
        if lib_leg and leg and not math.isclose(lib_leg, leg, rel_tol=0.01):
            raise ValueError(
                f"the library was prepared for a person whose legs are {lib_leg:.6g} units "
                f"long, the clip's are {leg:.6g}: prepare it with this clip as the reference"
            )
        if tuple(w.rate for w in library.warped) != tuple(float(r) for r in config.warps):
            raise ValueError("the library was prepared with other warps than the config's")
        if any(library.backwards) != config.backwards:
            raise ValueError("the library was prepared with another 'backwards' than the config's")
        _check_rate(library, clip.frame_time)
        if names is not None:
            raise ValueError("library_names names the motions of a list; a prepared library "
                             "has its names (prepare_library's names)")  # fmt: skip
        return library
    motions = [library] if isinstance(library, Motion) else list(library)
    return prepare_library(motions, clip, names, up=up, config=config)


def inbetween(
    clip: Motion,
    gap,
    library: InbetweenLibrary | Motion | Sequence[Motion] | None,
    *,
    library_names: Sequence[str] | None = None,
    config: InbetweenConfig = DEFAULT_CONFIG,
    model: ConstantAccelerationModel = DEFAULT_MODEL,
    up: str | None = None,
    future_frames: int | None = None,
    method: str = "auto",
    clip_name: str = "clip",
    output: str | None = None,
    not_captured: Sequence[tuple[int, int]] = (),
    _own_added: bool = False,
) -> Inbetween:
    """Replace frames ``A..B-1`` of ``clip`` (``gap`` = ``(A, B)`` or ``"A:B"``) by motion found
    in ``library`` (motions, or an :class:`InbetweenLibrary` from :func:`prepare_library` to
    reuse over many gaps; None or empty: the clip's own frames beside the gap alone, ValueError
    where it has no stretch long enough); see the module docstring. ``future_frames`` limits
    how many frames from B on the method may look at (default: the L-score window for the
    junction's scores, every frame for the clip's own frames searched). Frames before A and
    from B on are returned unchanged. ``method``: "auto" (the library, or the Kalman transition when
    the best candidate's two-sided L-score is more than ``config.fallback_margin`` times the
    Kalman transition's own or the best candidate is unlike the context (the poor-fit warning),
    ``config.fallback`` is on and the gap is within
    ``config.kalman_max_seconds``), "library" (never fall back) or "kalman" (the Kalman
    transition, ValueError past ``config.kalman_max_seconds`` or at the clip's start or end;
    nothing is searched). A gap at the clip's start (``0:B``) or end (``A:F``) is
    filled from its one side (module docstring). The clip's own frames beside the gap are
    searched too, as a library clip named ``clip_name`` (:attr:`InbetweenConfig.own_frames`),
    but for the frame ranges ``not_captured`` (``(start, stop)``: frames an earlier fill made,
    which are not the take's capture) and its dropouts (:func:`dropout_frames`). Returns
    :class:`Inbetween`."""
    from mocapkit import features
    from mocapkit.stitch.transition import _join

    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    a, b = check_gap(gap, clip.num_frames, clip_name, clip.fps)
    clip.check_finite(clip_name)
    if future_frames is not None and int(future_frames) < 1:
        raise ValueError(f"future_frames must be >= 1, got {future_frames}")
    up = up or features.detect_up_axis(clip)
    no_library = library is None or (isinstance(library, (list, tuple)) and not library)
    F = clip.num_frames
    one_sided = a == 0 or b == F
    if one_sided and method == "kalman":
        raise ValueError(
            f"{clip_name}: gap {a}:{b} is at the clip's {'start' if a == 0 else 'end'}: the "
            "Kalman transition needs context on both sides of the gap; fill it from a library "
            "or the clip's own frames beside it (method 'auto' or 'library')"
        )
    # the Kalman transition asked for: nothing is searched (neither the library nor the clip)
    asked_kalman = method == "kalman"
    lib = None if no_library or asked_kalman else _as_library(library, clip, library_names, up,
                                                              config)  # fmt: skip
    dropouts: list[tuple[int, int]] = []
    if not _own_added and not asked_kalman:
        dropouts = dropout_frames(clip)
        skip = [*not_captured, *dropouts]
        lib = with_own_frames(lib, clip, a, b, clip_name, up, config, future_frames, skip)
    kalman_ok = not one_sided and b - a <= kalman_max_frames(clip, config)
    # nothing to search: "auto" gives a gap the Kalman transition may fill to it (below)
    auto_kalman = method == "auto" and config.fallback and kalman_ok
    if lib is None and method != "kalman" and not auto_kalman:
        # the frames left out of the clip's own, said: they may be what leaves too little
        shown = [f"{what} at frames {', '.join(f'{x}:{y}' for x, y in spans)}"
                 for what, spans in (("its dropouts", dropouts),
                                     ("frames an earlier run made", _merged(not_captured)))
                 if spans]  # fmt: skip
        raise ValueError(
            f"{clip_name}: method {method!r} needs a library, or {OWN_PIECE_MIN_SECONDS:g} s "
            f"of the clip before or after the gap {a}:{b} to search"
            f"{'' if config.own_frames else ' (InbetweenConfig.own_frames is off)'}"
            + (f" (not searched: {'; '.join(shown)})" if shown and config.own_frames else "")
            + (" (or method 'kalman')" if kalman_ok else "")
        )
    if a == 0:  # the reversed clip's end, filled from the library played the other way
        if lib is not None and not any(lib.backwards):
            raise ValueError(
                f"{clip_name}: gap 0:{b} is at the clip's start: it is filled by searching the "
                "library played backwards, which InbetweenConfig.backwards turns off"
            )
        rev = inbetween(
            clip[::-1], (F - b, F), lib, config=config, model=model, up=up, method=method,
            clip_name=clip_name, output=output, _own_added=True,
        )  # fmt: skip
        return _reversed(rev, lib)
    w = max(3, clip.seconds_to_frames(config.window_seconds))
    onpath = features.ground_root_on_path(clip, up)
    ctx = gap_context(onpath, a, b, w, up, future_frames)
    mpu = features.metres_per_unit(clip, None)
    if asked_kalman and not kalman_ok:
        raise ValueError(_kalman_too_long(clip, a, b, config, asked=True))
    t0 = time.perf_counter()
    note = ""
    try:
        cands: list[Candidate] = []
        count = 0
        if lib is None and not asked_kalman:  # nothing to search: the Kalman transition alone
            raise NoLibraryFitError(
                f"no library, and not {OWN_PIECE_MIN_SECONDS:g} s of the clip beside the gap, "
                "to search"
            )
        if lib is not None:
            cands, count = search_inbetween_top(
                ctx, b - a, lib, averaged(clip, b - a, config, one_sided), w=w, config=config,
                model=model, metres_per_unit=mpu,
            )  # fmt: skip
    except NoLibraryFitError as e:  # no library clip fits the gap: only the Kalman transition can
        if method == "library" or (not config.fallback and method == "auto"):
            raise
        if one_sided:
            raise NoLibraryFitError(
                f"{e}; a gap at the clip's start or end is filled from the library or the "
                "clip's own frames beside it only, not the Kalman transition"
            ) from None
        if not kalman_ok:
            raise NoLibraryFitError(f"{e}; {_kalman_too_long(clip, a, b, config)}") from None
        cands, count, note = [], 0, str(e)
    cand = cands[0] if cands else None
    seconds = time.perf_counter() - t0
    kfill, kal = None, math.nan  # no Kalman transition without a future to lead into
    if not one_sided:
        kfill = kalman_fill(onpath, a, b, window=w, future_frames=ctx.future.shape[0], model=model)
        kal = sum(_two_sided(onpath, kfill, a, b, ctx, w, up, model))
    lib_ends, lfill = (math.nan, math.nan), None
    share = fill_weights(cands, config, mpu) if cands else np.zeros(0)
    kept = math.nan
    gait_period = math.nan
    gait_share = 0.0  # the share of the fill's pose the clip's own gait carried on gave
    if cands:
        fills = [
            library_fill(onpath, a, b, lib.motions[c.clip], c, up=up, config=config,
                         future_frames=len(ctx.future))
            for c in cands
        ]  # fmt: skip
        lfill = _average_fills(fills, share)
        if len(fills) > 1 and _ground_speed(ctx, b - a, mpu) < STANDING_SPEED_M_S:
            kept = motion_kept(lfill, fills, share)
            if kept < config.average_min_motion:  # out of step: their average stands still
                share = np.eye(len(cands))[0]
                lfill = fills[0]
        # a segment that does not weigh (the best alone) gives no level either (reviewer: the
        # best alone was levelled by the others' where its own was unknown)
        levels = [
            _level_offset(onpath, a, lib.motions[c.clip], c, up, config.level_seconds)
            if wk != 0
            else None
            for c, wk in zip(cands, share, strict=True)
        ]
        # the fill's own weights where every segment has a level; else the score weights of
        # those that have one (signed weights over a part of the segments need not sum to 1)
        wl = share if None not in levels else neighbour_weights([c.score for c in cands])
        known = [(d, wk) for d, wk in zip(levels, wl, strict=True) if d is not None]
        if known:
            shift = sum(d * wk for d, wk in known) / sum(wk for _, wk in known)
            lfill = _to_level(onpath, a, b, lfill, shift, up, config)
        if (
            config.gait_share > 0
            and (b - a) * clip.frame_time >= config.gait_half_period_seconds[0]
            and _ground_speed(ctx, b - a, mpu) >= STANDING_SPEED_M_S
        ):
            cont = gait_continued(onpath, a, b, up, config.gait_half_period_seconds,
                                  config.gait_temperature)  # fmt: skip
            g_share = 0.0 if cont is None else _gait_share(cands[0], cont.miss_m2, config, mpu)
            if g_share > 0:
                pad = max(onpath.seconds_to_frames(config.lock_context_seconds), 1)
                pad = (pad, min(pad, len(ctx.future)))  # no frame past the future context
                mixed = with_gait(lfill, cont.poses, g_share, up)
                # the feet's correction fades in and out as a foot lock's (reviewer: a swinging
                # foot lifted at B-1 bent a straight knee 30 deg in a frame, 84 m/s² against the
                # capture's 30; faded 51, 43 without the gait). Also through the lock's speed
                # limit and smoothing: 46, but the holds smeared, foot skate on the tuning
                # windows +1.1 cm/s at 30 and 45 frames.
                ramp = max(onpath.seconds_to_frames(config.lock_ramp_seconds), 1)
                lfill = stance_kept(onpath, a, b, lfill, mixed, up, pad, ramp)
                gait_period = cont.half_period_s
                gait_share = g_share
        lib_ends = _two_sided(onpath, lfill, a, b, ctx, w, up, model)
    lib_score = sum(x for x in lib_ends if not (one_sided and math.isnan(x)))  # one junction
    replaced = sum(
        x for x in _two_sided(onpath, onpath[a:b], a, b, ctx, w, up, model) if not math.isnan(x)
    )
    # the clip's own frames alone (also in the reversed clip of a gap at its start, which is
    # handed them as its library: reviewer), or a library
    own_only = lib is None or all(n == str(clip_name) for n in lib.names)
    searched = "the clip's own frames" if own_only else "the library"
    pose_rms, path_miss, warning = _fit_of(
        cand, config, (b - a) * clip.frame_time, one_sided, searched
    )
    may_fall_back = method == "auto" and config.fallback and kalman_ok and lfill is not None
    unlike = may_fall_back and bool(warning)  # the library holds nothing like the context
    use_kalman = (
        method == "kalman"
        or lfill is None
        or unlike
        or (may_fall_back and lib_score > config.fallback_margin * kal)
    )
    if use_kalman and warning:  # the fit's assessment stands; the fill is not the library's
        warning = warning.replace(_MAY_NOT_LOOK, KALMAN_FILLED)
    fill = kfill if use_kalman else lfill
    fill = _back_to_clip(fill, clip, a, b, onpath is not clip, up)
    motion = _join(clip[:a], fill, clip[b:])
    if config.foot_lock:
        weighing = [c for c, wk in zip(cands, share, strict=True) if wk != 0]
        sources = () if use_kalman else _source_segments(onpath, a, b, lib, weighing, up)
        motion = _lock_feet(motion, a, b, up, config, sources)
    feet = feet_measures(clip, motion, a, b, up)
    how = "kalman" if use_kalman else "library"
    used = () if lib is None else tuple(dict.fromkeys(lib.names))  # each file once
    blended = tuple(
        {
            "weight": round(float(wk), 4),
            "source": lib.names[c.clip],
            "source_frames": list(lib.clip_frames(c.clip, *c.source_frames(b - a))),
            "backwards": bool(lib.backwards and lib.backwards[c.clip]),
            "rate": c.rate,
            "score": c.score,
        }
        for i, (c, wk) in enumerate(zip(cands, share, strict=True))
        # the best-scoring first, always; the others where they weigh anything at the report's
        # precision (newcomer: "combines 12 segments", 7 of them at weight 0.0)
        if i == 0 or round(float(wk), 4) != 0.0
    )
    best = blended[0] if blended else {"source": None, "source_frames": None, "backwards": False}
    return Inbetween(
        motion, (a, b), how, cand, best["source"], kal, count, seconds,
        str(clip_name), used, None if output is None else str(output),
        {"window": w, "future_frames": int(ctx.future.shape[0]), "warps": list(config.warps)},
        lib_score, None if cand is None else tuple(best["source_frames"]), best["backwards"],
        () if use_kalman else blended, method, note, pose_rms, path_miss, warning, lib_ends,
        replaced, unlike, feet, kept, 0.0 if use_kalman else gait_share,
        math.nan if use_kalman else gait_period,
    )  # fmt: skip


def averaged(
    clip: Motion, gap: int, config: InbetweenConfig = DEFAULT_CONFIG, one_sided: bool = False
) -> int:
    """How many segments fill a gap of ``gap`` frames of ``clip``: :attr:`InbetweenConfig.
    neighbours`, or 1 past :attr:`InbetweenConfig.average_max_seconds` or at the clip's start
    or end (``one_sided``: nothing pins the segments' far ends together, so their paths part
    and their average's feet slide)."""
    if one_sided or gap > clip.seconds_to_frames(config.average_max_seconds):
        return 1
    return config.neighbours


def _reversed(res: Inbetween, lib: InbetweenLibrary) -> Inbetween:
    """``res``, the fill of the reversed clip's end, as the fill of the clip's start: the motion
    reversed, the gap and the junction scores mirrored, every library segment played the other
    way (:func:`inbetween` for a gap at the clip's start; ``lib`` holds every clip both ways:
    :meth:`InbetweenLibrary.reversed_of`)."""
    from dataclasses import replace

    F = res.motion.num_frames
    a, b = res.gap
    c = res.candidate
    if c is not None:  # the same frames of the library clip played the other way
        other = lib.reversed_of(c.clip)
        last = lib.motions[c.clip].num_frames - 1
        c = replace(
            c,
            clip=other,
            start=last - (c.start + c.rate * (b - a + 1)),  # its frame on the clip's A-1 = -1
            lscore_start=c.lscore_end,  # its start junction is the clip's B
            lscore_end=c.lscore_start,
        )
    return replace(
        res,
        motion=res.motion[::-1],
        gap=(F - b, F - a),
        candidate=c,
        backwards=not res.backwards if res.source is not None else False,
        blended_from=tuple({**x, "backwards": not x["backwards"]} for x in res.blended_from),
        library_lscore_ends=res.library_lscore_ends[::-1],
        feet={**res.feet, "floor_depth_frame": F - 1 - res.feet["floor_depth_frame"]}
        if res.feet.get("floor_depth_frame") is not None
        else res.feet,
    )


def kalman_max_frames(clip: Motion, config: InbetweenConfig = DEFAULT_CONFIG) -> int:
    """The longest gap (frames of ``clip``) the Kalman transition fills:
    :attr:`InbetweenConfig.kalman_max_seconds`."""
    return clip.seconds_to_frames(config.kalman_max_seconds)


def _kalman_too_long(
    clip: Motion, a: int, b: int, config: InbetweenConfig, asked: bool = False
) -> str:
    """Why the Kalman transition cannot fill gap a:b, and what can (``asked``: it was asked
    for, method 'kalman'; else nothing in the library or the clip fits the gap)."""
    g, k = b - a, kalman_max_frames(clip, config)
    remedy = (
        "a library or the clip's own frames beside it (method 'auto' or 'library')"
        if asked
        else "a library with clips long enough"
    )
    return (
        f"the Kalman transition fills gaps of up to {k} frames ({config.kalman_max_seconds:g} s "
        f"at {clip.fps:.6g} fps), the gap {a}:{b} is {g} frames ({g * clip.frame_time:.3g} s): "
        "over a longer gap it carries the motion's accelerations across it and strays from the "
        f"ground; fill it from {remedy}, or make the gap shorter"
    )


def _finite_or_none(x: float) -> float | None:
    """JSON has no NaN or Infinity: a score that could not be computed is null."""
    return float(x) if math.isfinite(x) else None


_MAY_NOT_LOOK = "; the fill may not look like the clip's own motion"
KALMAN_FILLED = "; the Kalman transition filled the gap"
"""How the fit's warning ends (:attr:`Inbetween.warning`) when the Kalman transition, not the
library, filled the gap."""


def _fit_of(
    cand: Candidate | None,
    config: InbetweenConfig,
    seconds: float = 0.0,
    one_sided: bool = False,
    searched: str = "the library",
) -> tuple[float, float, str]:
    """The best candidate's pose and ground-path misses in metres (from its score terms), and
    the warning when the path's is beyond :attr:`InbetweenConfig.poor_fit_path_m` (on a gap of
    ``seconds``, beyond :attr:`InbetweenConfig.poor_fit_speed_m_s` per second of it) or the
    poses' beyond :attr:`InbetweenConfig.poor_fit_pose_m` (``one_sided``: the gap is at the
    clip's start or end, its poses matched on one side only; ``searched``: what held the
    candidates, the warning's subject)."""
    if cand is None:
        return math.nan, math.nan, ""
    pose = path = math.nan
    if config.pose_weight > 0:
        pose = config.pose_tolerance_m * math.sqrt(max(cand.pose, 0.0) / (3 * config.pose_weight))
    if config.travel_weight > 0:
        path = config.travel_tolerance_m * math.sqrt(max(cand.travel, 0.0) / config.travel_weight)
    bound = max(config.poor_fit_path_m, config.poor_fit_speed_m_s * seconds)
    why = []
    if path > bound:
        why.append(
            f"the best segment's path over the ground misses the clip's by {path:.2f} m, over "
            f"{bound:.2f} m for a gap of {seconds:.3g} s"
        )
    if pose > config.poor_fit_pose_m:
        where = "beside the gap" if one_sided else "at the gap's ends"
        why.append(
            f"its poses are {pose * 100:.1f} cm RMS per joint off the clip's {where}, "
            f"over {config.poor_fit_pose_m * 100:.0f} cm"
        )
    if not why:
        return pose, path, ""
    return (
        pose,
        path,
        f"{searched} hold{'s' * (searched == 'the library')} nothing like the motion around "
        f"the gap ({'; '.join(why)})"
        + _MAY_NOT_LOOK,
    )
