"""Every tunable of self-similarity detection, in one frozen dataclass.

Units: angles in degrees, durations in seconds (converted to frames at the take's own rate where
a rule runs, so a 30 fps and a 120 fps take are judged alike), MDM levels in [0, 1], ratios bare.
Each field carries the reason for its value. The values were chosen on injected errors in
Bandai-1 walks before issue #16; which rules run was then decided on the validation half of
Bandai-1 (``mocapkit.clean.detect.RETIRED``), and Bandai-2 and the raw CMU takes are reported
without retuning (bench/eval_clean.py). ``noise_ratio``, ``abrupt_nearest``, ``abrupt_trim``,
``hinge_context``, ``hinge_bend_deg`` and ``frozen_straight_deg`` (and the hinges' bend-only
axis, which has no field) were then set on the Bandai-1 tuning half, its gesture takes and its
takes resampled to 120 fps (a stand-in for CMU's rate), and kept on its validation half. Fields
of retired rules matter only when a pipeline puts those rules back.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from mocapkit.core.checks import check_field_types

DETECT_MODES = ("hysteresis", "threshold")
SCALES = ("spread", "mean", "median")
MAX_ANALYSIS_FPS = 240.0
"""Highest analysis rate: ten times the paper's 24 fps, twice CMU's capture rate (the words' DTW
cost grows with the square of the rate)."""


def seconds_to_frames(seconds: float, fps: float, minimum: int = 1) -> int:
    """``max(minimum, round(seconds * fps))``: a duration of the config on a take's frames."""
    return max(int(minimum), round(float(seconds) * float(fps)))


@dataclass(frozen=True)
class DetectConfig:
    """Thresholds of :class:`~mocapkit.clean.SelfSimilarityCleaner` (search, MDM and rules).

    ``SelfSimilarityCleaner(config=DetectConfig(threshold=0.6))``; ``config.replace(...)`` gives
    a changed copy. A rule whose switch is 0 (``pair_seconds``, ``dominance``, ``abrupt_deg``,
    ``recur_deg``) is skipped; which rules run, and in what order, is
    :data:`mocapkit.clean.detect.PIPELINE`.
    """

    # ------------------------------------------------------------------ search (the paper)
    #: Neighbours per motion-word: the paper's K = 5; fewer make the mean texture follow one
    #: neighbour's quirks, more reach words that no longer resemble the source.
    k: int = 5
    #: Analysis rate (frames per second) the words are defined at: the paper's 24 fps; takes at
    #: other rates are resampled to it for the search only (at most :data:`MAX_ANALYSIS_FPS`).
    analysis_fps: float = 24.0
    #: DTW slope constraint (consecutive non-diagonal steps, a count, not a duration): the
    #: paper's 2 lets a neighbour run at 1/3 to 3 times the source's speed.
    max_run: int = 2
    #: KNN minima within this many seconds of the source word are its own trivial match and are
    #: skipped; ``None``: half a source word (the paper).
    exclude_seconds: float | None = None
    #: Search the take with whole-body words first, then the context with the sub-group words
    #: only around what stage one flagged: faster with large contexts, same words.
    two_stage: bool = False
    #: Stage-one flagging level; ``None``: ``0.6 * threshold`` (stage one sees a coarser MDM, so
    #: it must not miss what stage two would flag).
    stage1_threshold: float | None = None
    #: Weight each word's vote by its KNN distance to this power (0: equal votes, the paper).
    weight_power: float = 0.0
    #: Recompute the mean texture without the votes of words holding a flagged cell. Off: on
    #: Bandai it did not raise precision (fewer votes make the mean texture noisier).
    robust: bool = False

    # ------------------------------------------------------------------ MDM
    #: MDM level a flagged run extends down to: the paper's 0.5.
    threshold: float = 0.5
    #: Digression scale: "spread" (how much the K neighbours disagree at the cell), "mean" (the
    #: paper: the joint's mean digression; an average cell then sits at MDM 0.63 > 0.5).
    scale: str = "spread"
    #: Scale multiplier: with "spread", a cell crosses 0.5 at ``0.83 * 4 = 3.3`` times the
    #: neighbours' own disagreement, i.e. well outside what the context itself varies by.
    gain: float = 4.0
    #: Least scale (degrees): neighbours that agree closely must not turn a few degrees of
    #: natural variation into an error (a cell crosses 0.5 at 12.5 deg or more).
    floor_deg: float = 15.0
    #: "hysteresis" (the rules of :data:`~mocapkit.clean.detect.PIPELINE`) or "threshold" (the
    #: paper: every cell above ``threshold``).
    detect: str = "hysteresis"

    # ------------------------------------------------------------------ MDM seeds (hysteresis)
    #: A run above ``threshold`` is flagged when it holds a near-certain cell (MDM above this,
    #: i.e. a digression over 2.6 times the scale) or an abrupt one (below).
    seed_threshold: float = 0.999
    #: Abrupt cell: angular acceleration (deviation of the next rotation from constant velocity,
    #: median over a short window) this many times the joint's median in the take, ...
    jump_ratio: float = 6.0
    #: ... with the joint's median acceleration taken as at least this (degrees per frame step):
    #: a joint that barely moves must not call every small wobble abrupt.
    jump_floor_deg: float = 4.0
    #: ... on a cell whose MDM exceeds this (the KNN words disagree with it somewhat).
    jump_min_mdm: float = 0.3
    #: Second abrupt level: a smaller acceleration ratio ...
    jump_ratio_2: float = 3.0
    #: ... on a cell the KNN words clearly disagree with.
    jump_min_mdm_2: float = 0.8
    #: Half-width of the acceleration's median window (seconds): one frame at 30 fps, so that a
    #: lasting jitter outweighs one kink.
    jump_median_seconds: float = 1.0 / 30.0

    # ------------------------------------------------------------------ steps
    #: A step (frame-to-frame rotation far from the steps around it) seeds a run when it exceeds
    #: this many times the joint's 99th percentile of steps in the take (feet strike the ground
    #: with natural steps; each joint is judged against its own) ...
    step_ratio: float = 1.5
    #: ... and this many degrees; also the least step :class:`ExtendToSteps` reaches to.
    step_min_deg: float = 8.0
    #: ... and the cell on its digressing side has MDM above this.
    step_min_mdm: float = 0.5
    #: Percentile of the joint's steps the step ratio is measured against.
    step_quantile: float = 99.0
    #: Which side of a step is the error: compare the normalised digression this long (seconds)
    #: after and before it.
    step_side_seconds: float = 0.1

    # ------------------------------------------------------------------ dominance veto
    #: (Retired rule, see ``detect.RETIRED``.) Drop an MDM-only run whose peak is below this
    #: fraction of another joint's peak nearby: a gross error on one joint bends the
    #: time-warped neighbours of every word around it (0: off).
    dominance: float = 0.5
    #: "Nearby" for the dominance veto (seconds either side of the run).
    dominance_pad_seconds: float = 1.0 / 6.0

    # ------------------------------------------------------------------ cancelling jumps
    #: Longest stretch (seconds) between an entry jump and an exit jump that cancel: the longest
    #: injected offset is 1.3 s; natural motion seldom jumps back by the same rotation (0: off).
    pair_seconds: float = 1.5
    #: Two jumps cancel when ``|v_in + v_out| < pair_tol * min(|v_in|, |v_out|)``.
    pair_tol: float = 0.45
    #: Two jumps that do not cancel pair too where their deviations point opposite ways to
    #: within this cosine and both exceed ``pair_axis_ratio`` times the joint's ordinary jump:
    #: a wrong-way bend turns its stretch about one axis by an angle that changes with the
    #: joint's own flexion, so its entry and exit differ in size (a Bandai elbow carries the
    #: forearm's twist, and a bend about that axis does not read as a wrong-way flexion). On a
    #: joint that turns about one axis only every two jumps are opposite or alike, so the size
    #: bar does the work: on the Bandai-1 tuning half's clean takes, whole, the largest such
    #: natural pair (a dance's elbow reversing at once) is 3.1 times the joint's own jump; of
    #: the bends injected there that do not cancel, 55 of 60 are entered and left by jumps over
    #: 5 times it (0: off).
    pair_axis_cos: float = 0.9
    #: ... see ``pair_axis_cos``.
    pair_axis_ratio: float = 5.0
    #: A jump is one side of a one-frame pop, and pairs with no farther jump, when the frame
    #: beside it deviates the opposite way to within ``|v_f + v_g| < pop_tol * min(|v_f|,
    #: |v_g|)``: a pop's two deviations are equal and opposite but for the joint's own
    #: acceleration. Bandai-1 tuning half: the natural toe pops of its clean takes cancel to
    #: 0.04-0.22; an injected 5-frame spike's entry at a heel strike to 0.42 (0: off).
    pop_tol: float = 0.3
    #: A jump counts when it exceeds this many times the joint's ``pair_quantile`` of jumps.
    pair_ratio: float = 1.45
    #: Percentile of the joint's jumps the pair ratio is measured against.
    pair_quantile: float = 97.0
    #: A jump counts too when the joint is still around it: its step is over ``step_min_deg``
    #: and this many times every step within ``still_jump_seconds`` before and after it (0:
    #: off; :func:`~mocapkit.clean.mdm.still_jumps`). A joint at rest does not turn several
    #: degrees in one frame and stop dead, however large its own jumps elsewhere (a toe's pops
    #: at foot strikes set its bar at 17 deg in walk_tired_002, where a 17 deg offset of the
    #: resting toe cut off by the take's end went unseen). Bandai-1 tuning half, 8 takes,
    #: seeds 0-3: locomotion offset recall 0.970 -> 1.000 at seed 0, nothing else changed;
    #: its clean takes, whole, hold 3 such jumps (a dance's toe snaps of 22-27 deg).
    still_jump_ratio: float = 5.0
    #: ... see ``still_jump_ratio``: three frames at 30 fps.
    still_jump_seconds: float = 0.1
    #: A jump entering an error within ``pair_seconds`` of the take's end (or leaving one as
    #: near its start) that pairs with no other flags the frames to that end where most of
    #: them digress (MDM above ``threshold``): an error cut off by the take has one jump only.
    #: Bandai-1 tuning half, 8 errors of each kind run off the end of each class's 4 takes:
    #: the locomotion offsets' units found 36 of 38 without, 38 with, nothing else changed;
    #: on its 86 clean takes, whole, it flags nothing (without the MDM condition it flagged 42
    #: natural stretches, foot strikes near the ends of 3 s dashes).
    pair_cut_off: bool = True
    #: ... or, whatever their MDM, where its one jump exceeds this many times the joint's
    #: ``pair_quantile`` of jumps: a slow joint's error (a hand turned 39 deg at the end of a
    #: bow) need not digress. Tuning half, 20 s of each clean take: the 32 stretches that look
    #: cut off (foot strikes, an arm's swing) jump at most 2.3 times; of 50 offsets injected to
    #: run off the end, 3 whose frames do not digress jump 20-31 times. The jump must be the
    #: only one over the bar within ``pair_seconds``: a spike near the end jumps back, and a
    #: wrong-way bend's exit (its jumps do not cancel) follows its entry. Seeds 0-6: locomotion
    #: offset recall 0.994 -> 1.000, nothing lost; validation half, seeds 0-2: no change,
    #: seeds 3-5: dance/fight offset recall 0.928 -> 0.975, gestures frozen 0.964 -> 1.000
    #: (a hold cut off by the end), precision unchanged.
    pair_cut_jump_ratio: float = 4.0

    # ------------------------------------------------------------------ once at the ends
    #: A flagged run coming within this long (seconds) of the take's first or last frame ...
    #: (0: the veto off; :class:`~mocapkit.clean.detect.OnceAtTheEnds`)
    once_end_seconds: float = 0.2
    #: ... is cleared unless a jump peak lies within this long of its edge inside the take.
    once_pad_seconds: float = 0.1

    # ------------------------------------------------------------------ spikes
    #: A short stretch that leaves the joint's smooth path (the cubic through the frames
    #: around it) by more than this many degrees at every frame is a spike: natural motion of
    #: one joint does not leave and rejoin its own smooth path by 40 deg within two frames at
    #: 30 fps. On the clean takes of the tuning half (88, each alone, every flag a false
    #: alarm) 30 deg over 1/6 s flagged 24 stretches (a wave, a dance, a dash's foot strikes:
    #: the cubic around five frames cannot follow an impact); 40 deg over 1/15 s or 1/30 s
    #: none, at 30 and at 120 fps, and still caught the tuning half's missed one-frame spike.
    #: The bar a joint's spike must clear is at most this (see ``spike_jump_ratio``).
    spike_deg: float = 40.0
    #: A joint whose own jumps are small clears a lower bar: ``spike_jump_ratio`` times its
    #: ``pair_quantile`` of jumps, at least ``spike_floor_deg`` (the smallest error a spike
    #: is: injected ones turn 20-90 deg). Tuning half, 20 s of every clean take (1,845 joints)
    #: and 215 injected spikes of one or two frames: 2.5 times flags no natural stretch the
    #: 40 deg bar does not (2 times flags one, a dash's toe) and catches 207 of the spikes
    #: against 148; at 120 fps none and all 215.
    spike_jump_ratio: float = 2.5
    #: ... see ``spike_jump_ratio``.
    spike_floor_deg: float = 20.0
    #: A spike's frames lie off the path by the whole jump into them (one constant turn): at
    #: least this share of the largest jump within ``spike_seconds`` and the cubic's two anchor
    #: frames. Beside the jump into a longer error (an offset, a 3-frame spike) the cubic runs
    #: halfway: a half share.
    spike_jump_share: float = 0.75
    #: Longest spike (seconds): two frames at 30 fps (see ``spike_deg``).
    spike_seconds: float = 1.0 / 15.0
    #: A spike within this long (seconds) of a run already flagged is left to that run: the run's
    #: wrong frames spoil the cubic around it.
    spike_pad_seconds: float = 0.2

    # ------------------------------------------------------------------ frozen joints
    #: A rotation held exactly for this long (seconds) while the KNN words move away is frozen:
    #: live joints tremble by more than ``frozen_speed_deg_s`` over a third of a second.
    frozen_seconds: float = 1.0 / 3.0
    #: "Held": turning slower than this (degrees per second); a stored value repeated exactly.
    frozen_speed_deg_s: float = 0.3
    #: The KNN words must move this far (degrees) from the held value somewhere in the run.
    frozen_min_digression_deg: float = 3.0
    #: A joint resting again elsewhere within this angle (degrees) of the held value (of an
    #: exact hold: at exactly that value) ...
    frozen_tol_deg: float = 0.5
    #: ... for this long in all (seconds) is parked at a limit (a straight elbow, flat toes),
    #: not frozen; also the margin around the run that does not count.
    frozen_recur_seconds: float = 0.1
    #: A hold repeating its value bit for bit is told apart (a dropout, not a park) only on a
    #: joint whose steps repeat exactly in short runs on at most this share of them: captured
    #: data never do (Bandai-1: 0.01% of its steps; a short take with one 5-frame hold: 2%),
    #: data written at twice their source's rate or from a VR rig do all along (a Unity/VRM
    #: recording in the BVH corpus: about half of every joint's steps).
    frozen_exact_share: float = 0.05
    #: A straight-at-rest knee or elbow held within this angle (degrees) of straight is parked
    #: at its limit (a locked knee while standing: the solver clamps it there, exactly), not
    #: frozen, even when it never leaves that pose in the take (0: off).
    frozen_straight_deg: float = 5.0

    # ------------------------------------------------------------------ smooth veto
    #: Drop a run with no step above this (degrees) near it: capture errors enter or leave with
    #: a step, a smooth digression is natural motion the context lacks (0: off).
    abrupt_deg: float = 12.0
    #: "Near" for the smooth veto (seconds either side of the run), and how far past its first
    #: and last owned steps a run is kept: an error lies between the steps that enter and leave
    #: it, so a run reaching further is the words' digression spilling past it. Chosen on the
    #: Bandai-1 tuning half at 30 and at 120 fps (0.2, 0.1, 0.05 s): at 30 fps the precision
    #: over all kinds and contexts rose, 0.2 -> 0.05, from 0.987 to 0.991 (locomotion) and
    #: from 0.954 / 0.977 to 0.970 / 0.980 (gestures, local / small context), with no recall
    #: lost; 0.1 and 0.05 were equal at 120 fps and 0.05 two units better at 30 fps.
    abrupt_seconds: float = 0.05
    #: A step vouches only for the flagged run nearest to it (one step enters or leaves one
    #: error), and a frozen run inside a flagged run is judged apart from the cells around it: an
    #: error's edge must not keep a run of natural motion the context lacks alive beside it
    #: (False: any step within ``abrupt_seconds`` keeps a run, the whole run spared by a frozen
    #: cell).
    abrupt_nearest: bool = True
    #: ... and a flagged run ends ``abrupt_seconds`` past the first and last steps it owns: an
    #: error lies between the steps that enter and leave it; the MDM beyond them is motion the
    #: context lacks, joined to the error by the hysteresis (only with ``abrupt_nearest``).
    abrupt_trim: bool = True

    # ------------------------------------------------------------------ recurring veto
    #: Drop a short run whose excursion the joint repeats elsewhere within this (degrees): a
    #: motif of the performer (toe pops at every push-off), not a random error (0: off).
    recur_deg: float = 8.0
    #: ... and within this fraction of the run's own digression.
    recur_ratio: float = 0.5
    #: Longest run (seconds) the recurring veto considers.
    recur_seconds: float = 0.2
    #: Timing slack (seconds) when matching an excursion's entry, peak and exit.
    recur_flex_seconds: float = 1.0 / 30.0

    # ------------------------------------------------------------------ limit-release veto
    #: A rotation the joint comes to rest at in this many still runs or more is a limit the
    #: solver clamps it at; a flagged run inside a smooth excursion off it, from the limit back
    #: to the limit, is the clamp letting go (0: off).
    limit_holds: int = 3
    #: A rest at the limit lasts at least this long (seconds).
    limit_hold_seconds: float = 0.1
    #: At the limit: within this angle (degrees) of its value (the clamp writes one value; the
    #: file's last digit moves it by about 1e-5 deg).
    limit_tol_deg: float = 0.5
    #: A released run moves: some frame of it lies this far (degrees) from its first or last;
    #: an error on the parked frames turns them by one rotation and keeps the limit's tremble
    #: (about a degree), which is no release.
    limit_move_deg: float = 3.0
    #: The clamp's own jumps fall within this long (seconds) of the excursion's ends; a jump
    #: further inside belongs to something else (an error), and the excursion is not vetoed.
    limit_edge_seconds: float = 1.0 / 30.0

    # ------------------------------------------------------------------ noise bursts
    #: Second difference of the angular velocity above this (degrees) at nearly every frame is
    #: a noise burst: smooth motion keeps it small, white noise of s per axis gives ~4.5 s.
    noise_deg: float = 20.0
    #: Shortest noise burst (seconds): an error's edge or a limb stopping at once raises the
    #: roughness for a few frames only.
    noise_seconds: float = 0.2
    #: ... and above this many times the joint's median roughness in the take: a hand waved fast
    #: at 30 fps is rough all the time (each joint is judged against its own, as steps are);
    #: injected or marker noise stands tens of times above it (0: the fixed level alone).
    noise_ratio: float = 4.0
    #: A burst's roughness run starts two frames before the burst or one (its outermost
    #: frame sees one noisy step). One frame before, the step out of the run's first frame
    #: enters the burst: it differs from the step into that frame by more than this share of
    #: the roughness there ... (likewise at the end; ``mdm.noise_bursts``)
    noise_edge_share: float = 0.15
    #: ... and by more than this many times the change a frame further out. Tuning half,
    #: seeds 0-6, 581 run ends: the ends misplaced 65 times by the earlier rule (the run's
    #: outermost roughness against the next frame's, at 0.5; 98 at 2/3), 35 by the share
    #: alone, 19 by both.
    noise_edge_jump: float = 2.0
    #: A burst goes on over the frames beside it whose roughness stays above this fraction of
    #: the level: random noise deviates little on some frames, which dips the roughness for two
    #: frames or more inside a burst (1: no hysteresis). Tuning half, 8 takes x 2 seeds: noise
    #: units missed 12 (1), 3 (0.7), 2 (0.5) of 844, no other false alarm at either.
    noise_hold_ratio: float = 0.5
    #: A burst whose jerk lies along one axis for more than this share (of its second moment)
    #: is a fast wave or shake, not noise: noise turns the joint every which way (0: off).
    noise_axis_share: float = 0.88

    # ------------------------------------------------------------------ holes
    #: A joint's unflagged hole between two flagged runs at most this long (seconds) is
    #: flagged: an error does not stop for a frame and start again (0: off).
    bridge_seconds: float = 0.05

    # ------------------------------------------------------------------ wrong-way hinges
    #: A knee or elbow bent more than this (degrees) past straight the wrong way: anatomically
    #: impossible whatever the context holds.
    hinge_deg: float = 15.0
    #: A hinge counts as straight at rest (so negative flexion is wrong-way) within this angle.
    hinge_straight_deg: float = 20.0
    #: A hinge's limb folded back further than this (degrees) is past any knee's or elbow's
    #: reach (about 150-160 deg; Bandai-1's takes reach 144) and reads as a wrong-way bend;
    #: rotation vectors wrap at 180, so no flexion axis can be read there.
    hinge_max_deg: float = 170.0
    #: Fit the hinge's flexion axis on the context takes too. Off: a Bandai elbow turns about
    #: one axis in one style and another in the next (forearm twist), and a context of other
    #: styles turned a take's whole normal flexion into a wrong-way bend.
    hinge_context: bool = False
    #: A hinge whose bend angle (between its two bones) spans less than this (degrees, 5th to
    #: 95th percentile over the take) is held, straight or a little bent, and even its bend does
    #: not show its flexion axis well: the axis is then fitted on the context's takes too, where
    #: there are any (the flexion axis itself is always fitted on the bend, the twist about the
    #: limb below left out: a forearm twisted in a wave is no flexion; see
    #: ``Evidence.hinge_flexion``). 10, 20 and 30 gave the same flags on the tuning half (0: every
    #: hinge on its own take).
    hinge_bend_deg: float = 20.0
    #: A wrong-way run reaches back to a jump far above the joint's own (``pair_axis_ratio``
    #: times its ordinary one) at most this long (seconds) before it, and on to one at most this
    #: long after it: the error entered or left there, and its frames nearer straight read as
    #: no wrong-way bend (0: off).
    hinge_reach_seconds: float = 2.0 / 15.0
    #: A knee or elbow whose limb swings out of its bending plane by more than this (degrees,
    #: the angle between the limb and the plane across the hinge's main axis) is bent a way no
    #: hinge bends. Clean Bandai-1 hinges stay within 2.3 deg of their plane (every take), CMU's
    #: are one-axis joints (0); a forearm that carries its twist, mirrored about its full
    #: rotation's main axis, left it (tuning half, gestures). The hinge's axis is fitted again on
    #: its frames within this of the last fit's plane, so that an error's frames do not tilt it
    #: (0: off).
    hinge_plane_deg: float = 10.0
    #: The plane is judged only on a hinge that keeps to it: the median tilt of the plane of its
    #: frames bent more than ``hinge_bend_deg`` at most this (degrees). Many rigs bend their
    #: knees and elbows as ball joints (video-to-BVH, SMPL, some solvers in the BVH corpus), and
    #: there the plane says nothing.
    hinge_planar_deg: float = 2.0

    # ------------------------------------------------------------------ extension
    #: (Retired rule.) Stretch every flagged run to the steps (above ``step_min_deg``) within
    #: this long (seconds) of its ends: an error's first and last frames often digress too
    #: little.
    extend_seconds: float = 2.0 / 15.0

    def __post_init__(self) -> None:
        check_field_types(self)  # types first: NaN or "no" must not pass as a setting
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if f.name.endswith("_quantile") and not 0.0 <= v <= 100.0:
                raise ValueError(f"{f.name} is a percentile in [0, 100], got {v!r}")
        if self.max_run < 1:
            raise ValueError(f"max_run must be >= 1, got {self.max_run}")
        if not (self.gain > 0 and self.weight_power >= 0 and self.pair_tol >= 0):
            raise ValueError("gain must be > 0, weight_power and pair_tol >= 0")
        if not self.pop_tol >= 0:
            raise ValueError(f"pop_tol must be >= 0 (0: off), got {self.pop_tol}")
        if self.stage1_threshold is not None and not 0.0 <= self.stage1_threshold <= 1.0:
            raise ValueError(f"stage1_threshold must lie in [0, 1], got {self.stage1_threshold}")
        if self.detect not in DETECT_MODES:
            raise ValueError(f"detect must be 'hysteresis' or 'threshold', got {self.detect!r}")
        if self.scale not in SCALES:
            raise ValueError(f"scale must be 'spread', 'mean' or 'median', got {self.scale!r}")
        if self.k < 1:
            raise ValueError("k must be >= 1")
        if not 0 < self.analysis_fps <= MAX_ANALYSIS_FPS:
            # a word's DTW grows with the square of the rate: 1000 fps ran for many minutes
            raise ValueError(
                f"analysis_fps must lie in (0, {MAX_ANALYSIS_FPS:g}] (the paper's is 24), "
                f"got {self.analysis_fps!r}"
            )
        for name in ("threshold", "seed_threshold", "jump_min_mdm", "jump_min_mdm_2",
                     "step_min_mdm"):  # fmt: skip
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must lie in [0, 1]")
        if self.step_ratio <= 0 or self.step_min_deg < 0:
            raise ValueError("step_ratio must be positive and step_min_deg non-negative")
        if self.pair_seconds < 0:
            raise ValueError("pair_seconds must be >= 0 (0 turns the pairing off)")
        if not 0.0 <= self.frozen_exact_share <= 1.0:
            raise ValueError(
                f"frozen_exact_share must lie in [0, 1], got {self.frozen_exact_share!r}"
            )
        if not 0.0 < self.noise_hold_ratio <= 1.0:
            raise ValueError(f"noise_hold_ratio must lie in (0, 1], got {self.noise_hold_ratio!r}")
        if not 0.0 <= self.noise_edge_share < 1.0:
            raise ValueError(f"noise_edge_share must lie in [0, 1), got {self.noise_edge_share!r}")
        if not self.noise_edge_jump >= 0.0:
            raise ValueError(f"noise_edge_jump must be 0 or more, got {self.noise_edge_jump!r}")
        if not self.pair_cut_jump_ratio >= 0.0:
            raise ValueError(
                f"pair_cut_jump_ratio must be 0 or more, got {self.pair_cut_jump_ratio!r}"
            )
        if not self.still_jump_ratio >= 0.0:
            raise ValueError(f"still_jump_ratio must be 0 or more, got {self.still_jump_ratio!r}")
        if not 0.0 <= self.pair_axis_cos <= 1.0:  # a cosine; 0 turns the axis pairing off
            raise ValueError(f"pair_axis_cos must lie in [0, 1], got {self.pair_axis_cos!r}")
        if not self.pair_axis_ratio >= 0.0:
            raise ValueError(f"pair_axis_ratio must be 0 or more, got {self.pair_axis_ratio!r}")
        if not 0.0 <= self.spike_jump_share <= 1.0:
            raise ValueError(f"spike_jump_share must lie in [0, 1], got {self.spike_jump_share!r}")
        if not self.spike_jump_ratio >= 0.0:
            raise ValueError(f"spike_jump_ratio must be 0 or more, got {self.spike_jump_ratio!r}")
        if self.limit_holds < 0 or self.limit_holds == 1:
            # one rest is no limit: every pause would be one
            raise ValueError(
                f"limit_holds must be 0 (the veto off) or >= 2, got {self.limit_holds}"
            )
        if self.abrupt_deg < 0 or self.recur_deg < 0:
            raise ValueError("abrupt_deg and recur_deg must be >= 0 (0 turns the veto off)")
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if f.name.endswith(("_seconds", "_deg", "_deg_s")) and v is not None and v < 0:
                raise ValueError(f"{f.name} must be >= 0, got {v!r}")

    def replace(self, **changes: object) -> DetectConfig:
        """A copy with ``changes`` (field names of this class; anything else is a TypeError)."""
        names = {f.name for f in dataclasses.fields(self)}
        bad = sorted(set(changes) - names)
        if bad:
            raise TypeError(f"unknown DetectConfig field(s): {', '.join(bad)}")
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict:
        """The fields as a JSON-ready dict."""
        return dataclasses.asdict(self)
