"""The estimator: fit on a take and a context, then MDM scores, mask, segments, repaired motion."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from mocapkit.clean import mdm as mdm_mod
from mocapkit.clean.dtw import MAX_RUN, pose_distance_matrices
from mocapkit.clean.knn import K_NEIGHBOURS, Context, GroupNeighbours, search_group, untainted
from mocapkit.clean.repair import (
    ContactConstraint,
    RepairResult,
    chain_of,
    default_margin,
    effector_error,
    pin_with_ik,
    repair_cells,
)
from mocapkit.clean.texture import (
    default_groups,
    interpolate_track,
    make_texture,
    rotating_joints,
)
from mocapkit.clean.words import ANALYSIS_FPS, JointGroup, source_word_starts, word_lengths
from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion
from mocapkit.core.runs import true_runs
from mocapkit.core.skeleton import Skeleton
from mocapkit.features import limb_hinges

Progress = Callable[[str, int, int], None]
"""progress(stage, done, total): called as the search advances (the CLI draws a bar)."""

THRESHOLD = 0.5
"""MDM value above which a cell is erroneous (the paper's 0.5)."""

SCALE = "spread"
GAIN = 4.0
FLOOR_DEG = 15.0
"""MDM normalisation defaults: ``MDM = 1 - exp(-(M / max(GAIN * spread, FLOOR_DEG))²)``.

The paper divides each joint's digression ``M`` by the joint's mean (``scale="mean", gain=1,
floor_deg=0``), which puts an average cell at ``1 - e^-1 = 0.63 > 0.5``: on clean Bandai takes
that flags about half of all cells. Here each cell's digression is measured against how much its
K neighbours disagree there (their mean angle from their mean, "spread"; a joint the context
cannot pin down gets a wider tolerance), times ``GAIN``, and never against less than
``FLOOR_DEG`` degrees: a cell crosses 0.5 when ``M > 0.83 * max(4 * spread, 15 deg)``. Chosen on
injected errors in Bandai walks (bench/eval_clean.py); ``scale="mean", gain=1, floor_deg=0``
reproduces the paper."""

DETECT = "hysteresis"
SEED_THRESHOLD = 0.999
JUMP_RATIO = 6.0
JUMP_FLOOR_DEG = 4.0
JUMP_MIN_MDM = 0.3
JUMP_RATIO_2 = 3.0
JUMP_MIN_MDM_2 = 0.8
FROZEN_SECONDS = 1.0 / 3.0
DOMINANCE = 0.5
STEP_RATIO = 1.5
STEP_MIN_DEG = 8.0
STEP_MIN_MDM = 0.5
PAIR_SECONDS = 1.5
PAIR_TOL = 0.45
PAIR_RATIO = 1.2
EXTEND_SECONDS = 2.0 / 15.0
SPIKE_DEG = 25.0
SPIKE_SECONDS = 1.0 / 6.0
SPIKE_PAD_SECONDS = 0.2
ABRUPT_DEG = 12.0
ABRUPT_SECONDS = 0.2
RECUR_DEG = 8.0
RECUR_RATIO = 0.5
RECUR_SECONDS = 0.2
NOISE_DEG = 20.0
NOISE_SECONDS = 0.2
HINGE_DEG = 15.0
HINGE_STRAIGHT_DEG = 20.0
"""Detection defaults. ``detect="threshold"`` flags every cell with MDM above the threshold (the
paper). ``detect="hysteresis"`` flags the runs (per joint, along time) of cells above the
threshold that hold a *seed*: a cell with MDM above ``SEED_THRESHOLD``, or an abrupt cell (angular
acceleration, median over 3 frames, above ``JUMP_RATIO`` times the joint's median acceleration in
the take, at least ``JUMP_FLOOR_DEG`` per frame²) whose MDM exceeds ``JUMP_MIN_MDM`` (or above
``JUMP_RATIO_2`` times with MDM above ``JUMP_MIN_MDM_2``); seeds and
the cells around them down to the threshold are flagged. A run seeded by the MDM alone is dropped
when another joint digresses more than ``1 / DOMINANCE`` times as much around it
(:func:`~mocapkit.clean.mdm.dominated_runs`: a flipped joint spoils the time warping of every
word around it). Frozen joints (a rotation held for ``FROZEN_SECONDS`` or more while the KNN
words move, :func:`~mocapkit.clean.mdm.frozen_cells`) are flagged too.

Steps: a capture error starts and ends with a frame-to-frame step far from the steps around it
(:func:`~mocapkit.clean.mdm.step_size`). A step above ``STEP_RATIO`` times the joint's 99th
percentile of steps in the take and above ``STEP_MIN_DEG`` seeds the cell on its digressing side
when that cell's MDM exceeds ``STEP_MIN_MDM``. Two jumps (:func:`~mocapkit.clean.mdm.jump_size`
above ``PAIR_RATIO`` times the joint's 99th percentile and ``STEP_MIN_DEG``) at most
``PAIR_SECONDS`` apart whose step deviations cancel (within ``PAIR_TOL``,
:func:`~mocapkit.clean.mdm.cancelling_steps`) flag the whole stretch between them, whatever its
MDM: a joint turned by one constant rotation (spike, offset, flip). A stretch of at most
``SPIKE_SECONDS`` that leaves the joint's smooth path (the cubic through the frames around it)
by more than ``SPIKE_DEG`` at every frame is flagged too (:func:`~mocapkit.clean.mdm.spike_size`),
unless it lies within ``SPIKE_PAD_SECONDS`` of a run already flagged, whose wrong frames spoil
the cubic. After the vetoes below, every flagged run is stretched to the steps (above
``STEP_MIN_DEG``) within ``EXTEND_SECONDS`` of its ends
(:func:`~mocapkit.clean.mdm.extend_to_steps`): an error's first and last frames often digress
too little.

Vetoes: a run (frozen joints aside) with no step above ``ABRUPT_DEG`` within ``ABRUPT_SECONDS``
of it is dropped (:func:`~mocapkit.clean.mdm.smooth_runs`): errors enter and leave with a step,
while a smooth digression is natural motion the context lacks. A run of at most
``RECUR_SECONDS`` whose excursion (the poses before, at the peak of and after the run) the joint
repeats elsewhere in the take or in a context take of the same frame rate, within ``RECUR_DEG``
and within ``RECUR_RATIO`` times the run's digression, is dropped too
(:func:`~mocapkit.clean.mdm.recurring_runs`): the performer's own motif (toe pops at every
push-off), not a random error.

Two rules read the rotations alone, whatever the MDM (the KNN words of a weakly jittered fast
joint may follow the jitter; several wrong-way bends on one joint match each other): a run of at
least ``NOISE_SECONDS`` whose angular velocity changes by more than ``NOISE_DEG`` per frame at
(nearly) every frame is a noise burst (:func:`~mocapkit.clean.mdm.noise_bursts`), and a knee or
elbow (:func:`~mocapkit.features.limb_hinges`, straight at rest within ``HINGE_STRAIGHT_DEG``)
bent more than ``HINGE_DEG`` past straight the wrong way is flagged
(:func:`~mocapkit.clean.mdm.wrong_way_bends`). The KNN word frames that lie on such a burst or bend
of the take do not speak for that joint, in the MDM nor in the repair
(:func:`~mocapkit.clean.knn.untainted`).

On injected Bandai errors (bench/eval_clean.py) these rules remove most isolated false alarms of
the plain threshold (weakly matched clean cells just above 0.5) and catch frozen and jittery
joints whose MDM stays low. They were chosen on seeds 0 to 4 of the evaluation and checked on
seeds 5 and 6 (other error frames, joints and magnitudes)."""


@dataclass
class Segment:
    """A run of flagged frames on one joint (file frames, inclusive)."""

    joint: str
    joint_index: int
    start: int
    end: int
    peak: float

    def as_dict(self) -> dict:
        return {
            "joint": self.joint,
            "joint_index": self.joint_index,
            "start": self.start,
            "end": self.end,
            "peak": round(float(self.peak), 6),
        }


def straight_hinges(skeleton: Skeleton, max_angle: float) -> list[int]:
    """The knees and elbows (:func:`~mocapkit.features.limb_hinges`) whose bone in (their offset)
    and longest bone out lie within ``max_angle`` radians of one straight line at rest: those
    whose zero rotation is the straight limb, so that a flexion below zero is a wrong-way bend."""
    out = []
    for j in limb_hinges(skeleton):
        outs = [skeleton.offsets[c] for c in skeleton.children(j)]
        outs += list(skeleton.end_site_offsets[skeleton.end_site_parents == j])
        if not outs:
            continue
        below = max(outs, key=lambda v: float(np.linalg.norm(v)))
        above = skeleton.offsets[j]
        n = float(np.linalg.norm(below) * np.linalg.norm(above))
        if n > 0 and np.arccos(np.clip(below @ above / n, -1.0, 1.0)) <= max_angle:
            out.append(j)
    return out


def _same_skeleton(a: Motion, b: Motion) -> bool:
    return a.skeleton.names == b.skeleton.names and np.array_equal(
        a.skeleton.parents, b.skeleton.parents
    )


class SelfSimilarityCleaner:
    """Self-similarity analysis for motion-capture cleaning (Aristidou et al. 2018).

    Usage::

        cleaner = SelfSimilarityCleaner().fit(take, context=[other1, other2])
        cleaner.mdm_            # (F, J) movement digression map on the take's frames, in [0, 1]
        cleaner.mask()          # (F, J) bool, MDM > threshold
        cleaner.segments()      # flagged runs per joint
        fixed = cleaner.repair().motion

    Args:
        groups: joint groups (default :func:`~mocapkit.clean.texture.default_groups` over the
            joints that rotate in the take).
        k: neighbours per word (5).
        fps: analysis rate (24); word lengths scale with it.
        max_run: DTW slope constraint (at most this many consecutive non-diagonal steps).
        exclude: minima within this many frames of the source word are skipped (default N // 2).
        threshold: MDM threshold (0.5).
        scale, gain, floor_deg: MDM normalisation (see
            :func:`~mocapkit.clean.mdm.movement_digression_map` and :data:`SCALE`); the paper's
            is ``scale="mean", gain=1, floor_deg=0``.
        two_stage: stage 1 searches the take itself with whole-body words; stage 2 searches the
            context with the sub-group words, only for the words stage 1 flagged (MDM above
            ``stage1_threshold`` on any of their cells).
        stage1_threshold: stage-1 flagging level (default ``0.6 * threshold``).
        weight_power: weight each word's vote by its KNN distance to this power (0: equal).
        robust: a second pass recomputes T̄ without the votes that words holding a flagged
            cell (first pass) cast for their other joints: an error on one joint bends the
            time-warped neighbours of every word around it, which otherwise shows up as false
            alarms on the joints next to it. Off by default: on the Bandai evaluation it did not
            raise precision (fewer votes make T̄ noisier).
        detect: "hysteresis" (default, see :data:`DETECT`) or "threshold" (the paper: MDM above
            the threshold).
        seed_threshold, jump_ratio, jump_floor_deg, jump_min_mdm, jump_ratio_2, jump_min_mdm_2:
            the hysteresis seeds (see :data:`DETECT`).
        frozen: also flag frozen joints (hysteresis mode).
        dominance: drop MDM-only runs dominated by another joint (0: keep; hysteresis mode).
        step_ratio, step_min_deg, step_min_mdm, pair_seconds: the step seeds, and the longest
            stretch between cancelling steps (see :data:`DETECT`; ``pair_seconds=0`` turns the
            pairing off).
        abrupt_deg: drop runs with no step this large around them (0: keep; see
            :data:`DETECT`).
        recur_deg: drop short runs the joint repeats elsewhere this closely (0: keep).
    """

    def __init__(
        self,
        groups: Sequence[JointGroup] | None = None,
        k: int = K_NEIGHBOURS,
        fps: float = ANALYSIS_FPS,
        max_run: int = MAX_RUN,
        exclude: int | None = None,
        threshold: float = THRESHOLD,
        scale: str = SCALE,
        gain: float = GAIN,
        floor_deg: float = FLOOR_DEG,
        two_stage: bool = False,
        stage1_threshold: float | None = None,
        weight_power: float = 0.0,
        robust: bool = False,
        detect: str = DETECT,
        seed_threshold: float = SEED_THRESHOLD,
        jump_ratio: float = JUMP_RATIO,
        jump_floor_deg: float = JUMP_FLOOR_DEG,
        jump_min_mdm: float = JUMP_MIN_MDM,
        jump_ratio_2: float = JUMP_RATIO_2,
        jump_min_mdm_2: float = JUMP_MIN_MDM_2,
        frozen: bool = True,
        dominance: float = DOMINANCE,
        step_ratio: float = STEP_RATIO,
        step_min_deg: float = STEP_MIN_DEG,
        step_min_mdm: float = STEP_MIN_MDM,
        pair_seconds: float = PAIR_SECONDS,
        abrupt_deg: float = ABRUPT_DEG,
        recur_deg: float = RECUR_DEG,
    ) -> None:
        if detect not in ("hysteresis", "threshold"):
            raise ValueError(f"detect must be 'hysteresis' or 'threshold', got {detect!r}")
        if k < 1:
            raise ValueError("k must be >= 1")
        if not 0.0 <= threshold <= 1.0:
            raise ValueError("threshold must lie in [0, 1]")
        if fps <= 0:
            raise ValueError("fps must be positive")
        if step_ratio <= 0 or step_min_deg < 0:
            raise ValueError("step_ratio must be positive and step_min_deg non-negative")
        if not 0.0 <= step_min_mdm <= 1.0:
            raise ValueError("step_min_mdm must lie in [0, 1]")
        if pair_seconds < 0:
            raise ValueError("pair_seconds must be >= 0 (0 turns the pairing off)")
        if abrupt_deg < 0 or recur_deg < 0:
            raise ValueError("abrupt_deg and recur_deg must be >= 0 (0 turns the veto off)")
        self.groups = None if groups is None else list(groups)
        self.k = int(k)
        self.fps = float(fps)
        self.max_run = int(max_run)
        self.exclude = exclude
        self.threshold = float(threshold)
        self.scale = scale
        self.gain = float(gain)
        self.floor_deg = float(floor_deg)
        self.two_stage = bool(two_stage)
        self.stage1_threshold = stage1_threshold
        self.weight_power = float(weight_power)
        self.robust = bool(robust)
        self.detect = detect
        self.seed_threshold = float(seed_threshold)
        self.jump_ratio = float(jump_ratio)
        self.jump_floor_deg = float(jump_floor_deg)
        self.jump_min_mdm = float(jump_min_mdm)
        self.jump_ratio_2 = float(jump_ratio_2)
        self.jump_min_mdm_2 = float(jump_min_mdm_2)
        self.frozen = bool(frozen)
        self.dominance = float(dominance)
        self.step_ratio = float(step_ratio)
        self.step_min_deg = float(step_min_deg)
        self.step_min_mdm = float(step_min_mdm)
        self.pair_seconds = float(pair_seconds)
        self.abrupt_deg = float(abrupt_deg)
        self.recur_deg = float(recur_deg)

    # ---------------------------------------------------------------------------- fitting
    def fit(
        self,
        motion: Motion,
        context: Sequence[Motion] = (),
        progress: Progress | None = None,
        names: Sequence[str] | None = None,
    ) -> SelfSimilarityCleaner:
        """Analyse ``motion`` against itself and the ``context`` takes (same skeleton)."""
        for i, c in enumerate(context):
            if not _same_skeleton(motion, c):
                label = names[i] if names is not None else f"context take {i}"
                raise ValueError(f"{label}: its skeleton differs from the input's")
        self.motion_ = motion
        # same-rate context rotations, for the recurrence veto (compared frame by frame)
        self.context_rotations_ = [
            c.rotations for c in context if np.isclose(c.frame_time, motion.frame_time, rtol=1e-6)
        ]
        tex = make_texture(motion, self.fps, "input")
        ctx_tex = [make_texture(c, self.fps, f"ctx{i}").rotations for i, c in enumerate(context)]
        self.texture_ = tex
        active = rotating_joints(motion)
        for c in context:
            active |= rotating_joints(c)
        self.active_ = active
        groups = self.groups
        if groups is None:
            groups = default_groups(motion.skeleton, include=np.flatnonzero(active))
        if not groups:
            raise ValueError("no joint group has two or more rotating joints")
        self.groups_ = list(groups)
        N, step, M = word_lengths(self.fps)
        self.word_lengths_ = (N, step, M)
        src = tex.rotations
        if src.shape[0] < N:
            raise ValueError(
                f"the take is too short: {src.shape[0]} analysis frames, a word needs {N}"
            )
        starts = source_word_starts(src.shape[0], N, step)
        self.starts_ = starts
        report = progress or (lambda stage, done, total: None)

        if not self.two_stage:
            ctx = Context.build([src, *ctx_tex], self_clip=0)
            self.neighbours_ = self._search(src, ctx, self.groups_, starts, report, "search")
        else:
            self.neighbours_ = self._two_stage(src, ctx_tex, starts, report)
        self._finish_maps()
        return self

    def _search(
        self,
        src: np.ndarray,
        ctx: Context,
        groups: Sequence[JointGroup],
        starts: np.ndarray,
        report: Progress,
        stage: str,
    ) -> list[GroupNeighbours]:
        N, _, M = self.word_lengths_
        out = []
        if len(starts) == 0:
            return [
                GroupNeighbours(
                    g,
                    starts,
                    np.zeros((0, self.k), np.int64),
                    np.zeros((0, self.k)),
                    np.zeros((0, self.k, N, len(g.joints), 4)),
                )
                for g in groups
            ]
        # rows needed: the span of the words (stage 2 only needs a few)
        r0 = int(starts.min())
        r1 = int(starts.max()) + N
        dists = pose_distance_matrices(src[r0:r1], ctx.rotations, groups)
        for gi, g in enumerate(groups):
            out.append(
                search_group(
                    src,
                    ctx,
                    g,
                    starts,
                    N,
                    M,
                    self.k,
                    self.exclude,
                    self.max_run,
                    distances=dists[gi],
                    row_offset=r0,
                )
            )
            report(stage, gi + 1, len(groups))
        return out

    def _two_stage(
        self, src: np.ndarray, ctx_tex: list[np.ndarray], starts: np.ndarray, report: Progress
    ) -> list[GroupNeighbours]:
        N, _, _ = self.word_lengths_
        body = [g for g in self.groups_ if g.name == "body"] or [
            max(self.groups_, key=lambda g: len(g.joints))
        ]
        subs = [g for g in self.groups_ if g is not body[0]] or body
        local = Context.build([src], self_clip=0)
        stage1 = self._search(src, local, body, starts, report, "stage 1")
        mdm1 = self._mdm_from(stage1, analysis=True)
        thr1 = self.stage1_threshold if self.stage1_threshold is not None else 0.6 * self.threshold
        hot = np.array([(mdm1[a : a + N] > thr1).any() for a in starts], dtype=bool)
        self.stage1_flagged_ = hot
        if not hot.any():
            return stage1
        ctx = Context.build([src, *ctx_tex], self_clip=0)
        # stage 2 on contiguous runs of flagged words
        stage2: list[GroupNeighbours] = []
        idx = np.flatnonzero(hot)
        chunks = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
        per_group: dict[str, list[GroupNeighbours]] = {g.name: [] for g in subs}
        for ci, ch in enumerate(chunks):
            res = self._search(src, ctx, subs, starts[ch], lambda *a: None, "stage 2")
            for gn in res:
                per_group[gn.group.name].append(gn)
            report("stage 2", ci + 1, len(chunks))
        for g in subs:
            parts = per_group[g.name]
            stage2.append(
                GroupNeighbours(
                    g,
                    np.concatenate([p.starts for p in parts]),
                    np.concatenate([p.index for p in parts]),
                    np.concatenate([p.distance for p in parts]),
                    np.concatenate([p.words for p in parts]),
                )
            )
        b = stage1[0]
        keep = ~hot
        stage1_kept = GroupNeighbours(
            b.group, b.starts[keep], b.index[keep], b.distance[keep], b.words[keep]
        )
        return [stage1_kept, *stage2]

    def _mdm_from(
        self,
        neighbours: Sequence[GroupNeighbours],
        analysis: bool = False,
        outliers: np.ndarray | None = None,
    ) -> np.ndarray:
        """MDM on the analysis frames, or on the file's frames (keeping digression/spread).
        ``outliers``: (F_analysis, J) cells whose words may not vote for other joints."""
        tex = self.texture_
        tbar, covered = mdm_mod.mean_texture(tex.rotations, neighbours, self.weight_power, outliers)
        spread = None
        if self.scale == "spread":
            spread = mdm_mod.neighbour_spread(tex.rotations, neighbours)
        if analysis:
            dig = mdm_mod.digression(tex.rotations, tbar)
        else:
            tbar_f = interpolate_track(tbar, tex.fps, tex.file_times())
            dig = mdm_mod.digression(tex.file_rotations, tbar_f)
            if spread is not None:
                t_a, t_f = tex.analysis_times(), tex.file_times()
                spread = np.stack(
                    [np.interp(t_f, t_a, spread[:, j]) for j in range(spread.shape[1])], axis=1
                )
            self.mean_texture_ = tbar
            self.digression_ = dig
            self.spread_ = spread
        active = self.active_ & covered.any(axis=0)
        if not analysis:
            self.analysed_ = active
            z = mdm_mod.normalised_digression(
                dig, self.scale, self.gain, np.radians(self.floor_deg), spread
            )
            z[:, ~active] = 0.0
            self.normalised_digression_ = z
        return mdm_mod.movement_digression_map(
            dig, self.scale, self.gain, np.radians(self.floor_deg), active, spread
        )

    def _finish_maps(self) -> None:
        self._signal = None
        bad = self._signal_errors()
        if bad.any():
            # a neighbour word lying on a noise burst or a wrong-way bend of the take may not
            # speak for that joint: several errors on one joint would vouch for each other
            tex = self.texture_
            t_a, t_f = tex.analysis_times(), tex.file_times()
            bad_a = np.stack(
                [np.interp(t_a, t_f, bad[:, j].astype(float)) > 0 for j in range(bad.shape[1])],
                axis=1,
            )
            M = self.word_lengths_[2]
            self.neighbours_ = [untainted(gn, bad_a, M) for gn in self.neighbours_]
        self.mdm_analysis_ = self._mdm_from(self.neighbours_, analysis=True)
        outliers = None
        if self.robust:
            # second pass: words holding a flagged cell on one joint do not vote for the others
            outliers = self.mdm_analysis_ > self.threshold
            if outliers.any():
                self.mdm_analysis_ = self._mdm_from(self.neighbours_, True, outliers)
            else:
                outliers = None
        self.outliers_ = outliers
        self.mdm_ = self._mdm_from(self.neighbours_, outliers=outliers)
        self._jump = None
        self._frozen = None
        self._steps = None
        self._pairs = None
        self._spikes = None

    # ---------------------------------------------------------------------------- results
    def _check(self) -> None:
        if not hasattr(self, "mdm_"):
            raise RuntimeError("call fit() first")

    @property
    def joint_names(self) -> list[str]:
        self._check()
        return list(self.motion_.skeleton.names)

    def scores(self) -> np.ndarray:
        """(F, J) MDM on the take's frames, float64 in [0, 1] (columns in skeleton order)."""
        self._check()
        return self.mdm_.copy()

    def mask(self, threshold: float | None = None) -> np.ndarray:
        """(F, J) bool: the flagged cells (see :data:`DETECT`; ``threshold`` replaces the
        MDM threshold)."""
        self._check()
        thr = self.threshold if threshold is None else float(threshold)
        weak = self.mdm_ > thr
        if self.detect == "threshold":
            return weak
        fps = self.motion_.fps
        if self._jump is None:
            size = max(1, 2 * round(fps / 30.0) + 1)
            self._jump = mdm_mod.jump_ratio(
                self.motion_.rotations, np.radians(self.jump_floor_deg), size
            )
        jumps = ((self._jump > self.jump_ratio) & (self.mdm_ > self.jump_min_mdm)) | (
            (self._jump > self.jump_ratio_2) & (self.mdm_ > self.jump_min_mdm_2)
        )
        z = self.normalised_digression_
        if self._steps is None:
            body = mdm_mod.step_deviations(self.motion_.rotations, "body")
            steps = np.linalg.norm(body, axis=-1)  # step_size, kept for the pairing below
            peaks = mdm_mod.step_peaks(steps, self.step_ratio, np.radians(self.step_min_deg))
            sides = mdm_mod.step_sides(peaks, z, max(1, round(fps / 10.0)))
            self._steps = (peaks, sides, mdm_mod.step_cells(peaks, sides), steps, body)
        peaks, sides, step_cells, steps, body = self._steps
        seeds = jumps | (step_cells & (self.mdm_ > self.step_min_mdm))
        strong = (self.mdm_ > max(self.seed_threshold, thr)) | seeds
        out = mdm_mod.hysteresis(weak, strong)
        if self.dominance > 0:
            pad = max(1, round(fps / 6.0))
            out &= ~mdm_mod.dominated_runs(out, z, seeds, self.dominance, pad)
        if self.pair_seconds > 0:
            if self._pairs is None:
                rq = self.motion_.rotations
                devs = [body, mdm_mod.step_deviations(rq, "parent")]
                span = round(self.pair_seconds * fps)
                sizes = mdm_mod.jump_size(rq)
                pk = mdm_mod.step_peaks(sizes, PAIR_RATIO, np.radians(self.step_min_deg))
                self._pairs = mdm_mod.cancelling_steps(pk, devs, span, PAIR_TOL)
            out |= self._pairs
        if self._spikes is None:
            n = max(1, round(SPIKE_SECONDS * fps))
            self._spikes = mdm_mod.spike_size(self.motion_.rotations, n) > np.radians(SPIKE_DEG)
        pad = max(1, round(SPIKE_PAD_SECONDS * fps))
        near = ndimage.binary_dilation(out, structure=np.ones((2 * pad + 1, 1), dtype=bool))
        out |= self._spikes & ~near
        frozen = np.zeros_like(out)
        if self.frozen:
            if self._frozen is None:
                n = max(2, round(FROZEN_SECONDS * fps))
                self._frozen = mdm_mod.frozen_cells(self.motion_.rotations, self.digression_, n)
            frozen = self._frozen
            out |= frozen
        if self.abrupt_deg > 0:
            pad = max(1, round(ABRUPT_SECONDS * fps))
            min_step = np.radians(self.abrupt_deg)
            out &= ~mdm_mod.smooth_runs(out, steps, frozen, min_step, pad)
        if self.recur_deg > 0:
            out &= ~mdm_mod.recurring_runs(
                out,
                self.motion_.rotations,
                self.digression_,
                max(1, round(RECUR_SECONDS * fps)),
                np.radians(self.recur_deg),
                RECUR_RATIO,
                self.context_rotations_,
                flex=max(1, round(fps / 30.0)),
            )
        out |= self._signal_errors()
        ext = max(1, round(EXTEND_SECONDS * fps))
        out = mdm_mod.extend_to_steps(out, steps, np.radians(self.step_min_deg), ext)
        out[:, ~self.analysed_] = False
        return out

    def _signal_errors(self) -> np.ndarray:
        """(F, J) bool: noise bursts and wrong-way hinge bends, read off the rotations alone."""
        if self._signal is None:
            m = self.motion_
            n = max(2, round(NOISE_SECONDS * m.fps))
            rough = mdm_mod.burst_roughness(m.rotations)
            bursts = mdm_mod.noise_bursts(rough, np.radians(NOISE_DEG), n)
            hinges = straight_hinges(m.skeleton, np.radians(HINGE_STRAIGHT_DEG))
            bends = mdm_mod.wrong_way_bends(
                m.rotations, hinges, np.radians(HINGE_DEG), self.context_rotations_
            )
            self._signal = bursts | bends
        return self._signal

    def segments(self, threshold: float | None = None) -> list[Segment]:
        """Flagged runs per joint, in joint order then time (inclusive file frames)."""
        m = self.mask(threshold)
        out = []
        names = self.motion_.skeleton.names
        for j in range(m.shape[1]):
            for a, b in true_runs(m[:, j]):
                out.append(Segment(names[j], j, a, b, float(self.mdm_[a : b + 1, j].max())))
        return out

    def replacement(self) -> np.ndarray:
        """(F, J, 4) replacement rotations on the take's frames (facing-aligned space for the
        pelvis): the median KNN words around every frame."""
        self._check()
        tex = self.texture_
        med, _ = mdm_mod.median_texture(tex.rotations, self.neighbours_, self.weight_power)
        return interpolate_track(med, tex.fps, tex.file_times())

    def repair(
        self,
        threshold: float | None = None,
        margin: int | None = None,
        mask: np.ndarray | None = None,
        contacts: Sequence[ContactConstraint] = (),
    ) -> RepairResult:
        """Replace the flagged cells by the median KNN words, blended (see
        :mod:`mocapkit.clean.repair`); everything else is copied bit for bit.

        ``mask`` ((F, J) bool) overrides the MDM mask, e.g. a baseline's. ``contacts``: for the
        effector chains of these constraints, the KNN word that keeps the effector nearest its
        contact point replaces the median, then IK pins the effector (changing only the written
        cells of the chain)."""
        self._check()
        tex = self.texture_
        margin = default_margin(self.motion_.fps) if margin is None else margin
        flagged = self.mask(threshold) if mask is None else np.asarray(mask, dtype=bool)
        replacement = self.replacement()
        for c in contacts:
            replacement = self._contact_replacement(c, replacement, flagged)
        result = repair_cells(
            self.motion_,
            flagged,
            replacement,
            margin,
            to_file=tex.pelvis_align,
            pelvis=tex.pelvis,
        )
        motion = result.motion
        for c in contacts:
            motion = pin_with_ik(motion, c, result.written, c.target(self.motion_))
        result.motion = motion
        return result

    def _contact_replacement(
        self, contact: ContactConstraint, replacement: np.ndarray, flagged: np.ndarray
    ) -> np.ndarray:
        """Per source word overlapping the contact, the KNN word (of the smallest group holding
        the effector's chain) whose effector lands nearest the contact point."""
        motion = self.motion_
        fr = contact.frames(motion.num_frames)
        chain = chain_of(motion, contact.joint)
        if not flagged[np.ix_(fr, chain)].any():
            return replacement
        target = contact.target(motion)
        cands = [
            gn for gn in self.neighbours_ if set(chain) <= set(gn.group.joints) and len(gn.starts)
        ]
        if not cands:
            return replacement
        gn = min(cands, key=lambda g: len(g.group.joints))
        tex = self.texture_
        js = list(gn.group.joints)
        cols = [js.index(c) for c in chain]
        N = gn.words.shape[2]
        ta = tex.analysis_times()
        tf = tex.file_times()
        out = replacement.copy()
        for w, a in enumerate(gn.starts):
            span = (tf >= ta[a]) & (tf <= ta[min(a + N - 1, len(ta) - 1)])
            span[: fr[0]] = False
            span[fr[-1] + 1 :] = False
            fidx = np.flatnonzero(span)
            if len(fidx) == 0:
                continue
            aidx = np.clip(np.rint(tf[fidx] * tex.fps).astype(int) - a, 0, N - 1)
            best, best_err = None, np.inf
            for k in range(gn.index.shape[1]):
                if gn.index[w, k] < 0:
                    continue
                trial = motion.rotations.copy()
                vals = gn.words[w, k][aidx][:, cols]  # (n, len(chain), 4)
                for ci, c in enumerate(chain):
                    v = vals[:, ci]
                    if c == tex.pelvis and tex.pelvis_align is not None:
                        v = rot.quat_mul(rot.quat_inv(tex.pelvis_align[fidx]), v)
                    trial[fidx, c] = v
                m = Motion(motion.skeleton, trial, motion.root_positions, motion.frame_time)
                sub = ContactConstraint(contact.joint, int(fidx[0]), int(fidx[-1]), None)
                err = float(effector_error(m, sub, target).mean())
                if err < best_err:
                    best, best_err = vals, err
            if best is not None:
                for ci, c in enumerate(chain):
                    out[fidx, c] = best[:, ci]
        return out


def clean(
    motion: Motion,
    context: Sequence[Motion] = (),
    threshold: float = THRESHOLD,
    two_stage: bool = False,
    **kwargs,
) -> tuple[SelfSimilarityCleaner, RepairResult]:
    """Fit a :class:`SelfSimilarityCleaner` and repair: (cleaner, repair result)."""
    c = SelfSimilarityCleaner(threshold=threshold, two_stage=two_stage, **kwargs).fit(
        motion, context
    )
    return c, c.repair()
