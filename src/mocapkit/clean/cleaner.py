"""The estimator: fit on a take and a context, then MDM scores, mask, segments, repaired motion."""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from mocapkit.clean import mdm as mdm_mod
from mocapkit.clean.detect import (
    DetectConfig,
    Evidence,
    Explanation,
    Flags,
    build,
    explain,
    run_pipeline,
    segment_evidence,
    signal_cells,
)
from mocapkit.clean.dtw import pose_distance_matrices
from mocapkit.clean.knn import Context, GroupNeighbours, search_group, untainted
from mocapkit.clean.repair import (
    REPAIR_METHODS,
    ContactConstraint,
    RepairResult,
    chain_of,
    contact_held,
    default_margin,
    dilate,
    effector_error,
    lock_repaired_feet,
    pin_with_ik,
    repair_cells,
    unturned,
)
from mocapkit.clean.texture import (
    default_groups,
    interpolate_track,
    make_texture,
    rotating_joints,
)
from mocapkit.clean.words import (
    ANALYSIS_FPS,
    SOURCE_LEN,
    JointGroup,
    source_word_starts,
    word_lengths,
)
from mocapkit.core import rotations as rot
from mocapkit.core.checks import whole_number
from mocapkit.core.motion import Motion
from mocapkit.core.runs import true_runs
from mocapkit.core.skeleton import skeleton_difference

Progress = Callable[[str, int, int], None]
"""progress(stage, done, total): called as the search advances (the CLI draws a bar)."""

_DEFAULT = DetectConfig()
THRESHOLD = _DEFAULT.threshold
"""MDM value above which a cell is erroneous (the paper's 0.5); :attr:`DetectConfig.threshold`."""
SCALE = _DEFAULT.scale
GAIN = _DEFAULT.gain
FLOOR_DEG = _DEFAULT.floor_deg
"""MDM normalisation defaults: ``MDM = 1 - exp(-(M / max(GAIN * spread, FLOOR_DEG))²)``
(:class:`~mocapkit.clean.detect.DetectConfig`; ``scale="mean", gain=1, floor_deg=0`` is the
paper's)."""


@dataclass
class Segment:
    """A run of flagged frames on one joint (file frames ``start`` to ``end`` inclusive; the
    report also gives ``stop`` = ``end`` + 1, the CLI's ``A:B`` range with B excluded):
    ``peak`` MDM, the rules that flagged it (``reasons``, pipeline order) and what they
    measured (``evidence``)."""

    joint: str
    joint_index: int
    start: int
    end: int
    peak: float
    reasons: tuple[str, ...] = ()
    evidence: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {
            "joint": self.joint,
            "joint_index": self.joint_index,
            "start": self.start,
            "end": self.end,
            "stop": self.end + 1,  # start:stop, stop excluded: the CLI's one range syntax
            "peak": round(float(self.peak), 6),
            "reasons": list(self.reasons),
            "evidence": dict(self.evidence),
        }


def _same_skeleton(a: Motion, b: Motion) -> bool:
    return a.skeleton.names == b.skeleton.names and np.array_equal(
        a.skeleton.parents, b.skeleton.parents
    )


class SelfSimilarityCleaner:
    """Self-similarity analysis for motion-capture cleaning (Aristidou et al. 2018).

    Usage::

        cleaner = SelfSimilarityCleaner(config=DetectConfig()).fit(take, context=[o1, o2])
        cleaner.mdm_            # (F, J) movement digression map on the take's frames, in [0, 1]
        cleaner.mask()          # (F, J) bool: the cells the detection pipeline flags
        cleaner.segments()      # flagged runs per joint, with reasons and evidence
        cleaner.explain("LeftArm", 120)   # why that cell was or was not flagged
        fixed = cleaner.repair().motion

    Args:
        config: every threshold (:class:`~mocapkit.clean.detect.DetectConfig`, degrees and
            seconds); the rules that run are :data:`~mocapkit.clean.detect.PIPELINE`.
        groups: joint groups (default :func:`~mocapkit.clean.texture.default_groups` over the
            joints that rotate in the take).
        pipeline: rule classes to run instead of the config's (ablation studies).
        **changes: shorthand for ``config.replace(**changes)``, e.g.
            ``SelfSimilarityCleaner(two_stage=True)``; unknown names raise TypeError.
    """

    def __init__(
        self,
        config: DetectConfig | None = None,
        groups: Sequence[JointGroup] | None = None,
        pipeline: Sequence[type] | None = None,
        **changes: object,
    ) -> None:
        cfg = config if config is not None else DetectConfig()
        if not isinstance(cfg, DetectConfig):
            raise TypeError(f"config must be a DetectConfig, got {type(cfg).__name__}")
        self.config = cfg.replace(**changes) if changes else cfg
        self.groups = None if groups is None else list(groups)
        self.pipeline = None if pipeline is None else tuple(pipeline)
        if self.pipeline is not None:
            build(self.config, self.pipeline)  # a TypeError now for what is not a rule

    @property
    def threshold(self) -> float:
        return self.config.threshold

    @property
    def fps(self) -> float:
        """The analysis rate (the config's ``analysis_fps``)."""
        return self.config.analysis_fps

    # ---------------------------------------------------------------------------- fitting
    def fit(
        self,
        motion: Motion,
        context: Sequence[Motion] = (),
        progress: Progress | None = None,
        names: Sequence[str] | None = None,
    ) -> SelfSimilarityCleaner:
        """Analyse ``motion`` against itself and the ``context`` takes (same skeleton; a list,
        or one take). A fit that fails (ValueError) leaves the cleaner as it was."""
        context = [context] if isinstance(context, Motion) else list(context)
        if names is not None and len(names) != len(context):
            raise ValueError(f"{len(names)} names for {len(context)} context takes")
        saved = dict(self.__dict__)
        try:
            return self._fit(motion, context, progress, names)
        except BaseException:
            self.__dict__.clear()
            self.__dict__.update(saved)
            raise

    def _fit(
        self,
        motion: Motion,
        context: list[Motion],
        progress: Progress | None,
        names: Sequence[str] | None,
    ) -> SelfSimilarityCleaner:
        for i, c in enumerate(context):
            if not _same_skeleton(motion, c):
                label = names[i] if names is not None else f"context take {i}"
                why = skeleton_difference(c.skeleton, motion.skeleton, "the input")
                why = why or "its joints are in another order than the input's"
                raise ValueError(f"{label}: {why}")
        self.motion_ = motion
        # computed once: the rules' evidence (steps, jumps, roughness, hinges; the maps below)
        self.evidence_ = Evidence.for_motion(motion, self.config, context)
        self._flags: dict[float, Flags] = {}
        tex = make_texture(motion, self.fps, "input")
        labels = names if names is not None else [f"context take {i}" for i in range(len(context))]
        ctx_tex = [
            make_texture(c, self.fps, n).rotations for c, n in zip(context, labels, strict=True)
        ]
        self.texture_ = tex
        N, step, M = word_lengths(self.fps)
        if tex.rotations.shape[0] < N or motion.num_frames < 2:  # before the groups: a short
            # take would be reported as having no rotating joint
            raise ValueError(
                f"the take is too short: {motion.num_frames} frame(s) ({motion.duration:.3f} s); "
                f"cleaning compares motion words of {N / self.fps:.3f} s"
            )
        active = rotating_joints(motion)
        for c in context:
            active |= rotating_joints(c)
        self.active_ = active
        groups = self.groups
        if groups is None:
            groups = default_groups(motion.skeleton, include=np.flatnonzero(active))
        if not groups:
            n = int(active.sum())
            moving = "no joint rotates" if n == 0 else f"only {n} joint(s) rotate"
            raise ValueError(
                f"nothing to compare: {moving} (a take held still?), and self-similarity compares "
                "joints in groups of two or more that rotate"
            )
        self.groups_ = list(groups)
        exclude = (
            None
            if self.config.exclude_seconds is None
            else round(self.config.exclude_seconds * self.fps)
        )
        self.exclude = exclude
        self.word_lengths_ = (N, step, M)
        src = tex.rotations
        starts = source_word_starts(src.shape[0], N, step)
        self.starts_ = starts
        report = progress or (lambda stage, done, total: None)

        if not self.config.two_stage:
            ctx = Context.build([src, *ctx_tex], self_clip=0)
            self.neighbours_ = self._search(src, ctx, self.groups_, starts, report, "search")
        else:
            self.neighbours_ = self._two_stage(src, ctx_tex, starts, report)
        self._finish_maps()
        if not self.analysed_.any():
            raise ValueError(
                f"the take is too short: {motion.num_frames} frames ({motion.duration:.3f} s), "
                f"and no motion word of {N / self.fps:.3f} s found a like word away from itself"
                + ("" if context else " (give context takes, or a longer take)")
            )
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
                    np.zeros((0, self.config.k), np.int64),
                    np.zeros((0, self.config.k)),
                    np.zeros((0, self.config.k, N, len(g.joints), 4)),
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
                    self.config.k,
                    self.exclude,
                    self.config.max_run,
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
        c = self.config
        thr1 = c.stage1_threshold if c.stage1_threshold is not None else 0.6 * c.threshold
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
        c = self.config
        tbar, covered = mdm_mod.mean_texture(tex.rotations, neighbours, c.weight_power, outliers)
        spread = None
        if c.scale == "spread":
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
            z = mdm_mod.normalised_digression(dig, c.scale, c.gain, np.radians(c.floor_deg), spread)
            z[:, ~active] = 0.0
            self.normalised_digression_ = z
        return mdm_mod.movement_digression_map(
            dig, c.scale, c.gain, np.radians(c.floor_deg), active, spread
        )

    def _finish_maps(self) -> None:
        bad = signal_cells(self.evidence_, self.pipeline)
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
        if self.config.robust:
            # second pass: words holding a flagged cell on one joint do not vote for the others
            outliers = self.mdm_analysis_ > self.threshold
            if outliers.any():
                self.mdm_analysis_ = self._mdm_from(self.neighbours_, True, outliers)
            else:
                outliers = None
        self.outliers_ = outliers
        self.mdm_ = self._mdm_from(self.neighbours_, outliers=outliers)
        self.evidence_.set_maps(
            self.mdm_, self.normalised_digression_, self.digression_, self.analysed_, self.spread_
        )

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

    def flags(self, threshold: float | None = None) -> Flags:
        """The detection pipeline's :class:`~mocapkit.clean.detect.Flags` (mask and which rule
        flagged or cleared each cell); ``threshold`` replaces the MDM threshold. Kept per
        threshold; call :meth:`forget_flags` after changing ``mdm_`` by hand."""
        self._check()
        thr = self._threshold(threshold)
        if thr not in self._flags:
            self._flags[thr] = run_pipeline(self.evidence_, thr, self.pipeline)
        return self._flags[thr]

    def _threshold(self, threshold: float | None) -> float:
        """The MDM threshold to use: the config's, or ``threshold`` checked as the config
        checks it (a number in [0, 1]; a string such as "0.5" is refused, not compared)."""
        if threshold is None:
            return self.threshold
        return self.config.replace(threshold=threshold).threshold

    def forget_flags(self) -> None:
        """Drop the kept pipeline results (the evidence's maps stay)."""
        self._flags = {}

    def mask(self, threshold: float | None = None) -> np.ndarray:
        """(F, J) bool: the flagged cells (:meth:`flags`)."""
        return self.flags(threshold).mask.copy()

    def rule_names(self) -> list[str]:
        """The names of the rules that run, in order."""
        return [r.name for r in build(self.config, self.pipeline)]

    def explain(self, joint: str | int, frame: int, threshold: float | None = None) -> Explanation:
        """Why cell (``frame``, ``joint``) was or was not flagged: every rule's verdict and
        measurement there (:class:`~mocapkit.clean.detect.Explanation`, ``str()`` for text)."""
        self._check()
        frame = whole_number(frame, "frame")
        names = list(self.motion_.skeleton.names)
        if isinstance(joint, str):
            if joint not in names:
                raise ValueError(f"no joint named {joint!r}")
            j = names.index(joint)
        else:
            j = whole_number(joint, "joint")  # the pipeline's explain checks the ranges
        ev = self.evidence_
        if threshold is not None:
            ev = copy.copy(ev)
            ev.config = ev.config.replace(threshold=self._threshold(threshold))
        return explain(ev, self.flags(threshold), j, int(frame), self.pipeline)

    def segments(self, threshold: float | None = None) -> list[Segment]:
        """Flagged runs per joint, in joint order then time (inclusive file frames), each with
        the rules that flagged it and their measurements."""
        fl = self.flags(threshold)
        m = fl.mask
        out = []
        names = self.motion_.skeleton.names
        for j in range(m.shape[1]):
            for a, b in true_runs(m[:, j]):
                reasons = tuple(fl.reasons_at(slice(a, b + 1), j))
                ev = segment_evidence(self.evidence_, reasons, j, a, b)
                peak = float(self.mdm_[a : b + 1, j].max())
                out.append(Segment(names[j], j, a, b, peak, reasons, ev))
        return out

    def replacement(self) -> np.ndarray:
        """(F, J, 4) replacement rotations on the take's frames (facing-aligned space for the
        pelvis): the median KNN words around every frame."""
        self._check()
        tex = self.texture_
        med, _ = mdm_mod.median_texture(tex.rotations, self.neighbours_, self.config.weight_power)
        return interpolate_track(med, tex.fps, tex.file_times())

    def repair(
        self,
        threshold: float | None = None,
        margin: int | None = None,
        mask: np.ndarray | None = None,
        contacts: Sequence[ContactConstraint] = (),
        foot_lock: bool = True,
    ) -> RepairResult:
        """Replace the flagged cells by the median KNN words, blended (see
        :mod:`mocapkit.clean.repair`); everything else is copied bit for bit.

        ``mask`` ((F, J) bool) overrides the MDM mask, e.g. a baseline's; without it, a
        stretch the cancelling-jumps rule found turned by one rotation is turned back
        (:func:`~mocapkit.clean.repair.unturned`; not where the noise rule flags it too: a
        burst is no turn; on a knee or elbow, not where the turn-back leaves it bent the wrong
        way, and where the wrong-way-hinge rule flags it, only a flip or a bend whose flexion
        changes linearly over the run, :func:`_bent_right`) and the rest of its flagged run
        keeps the captured rotations; a wrong-way bend (not a half-turn flip) has its flexion
        reflected back instead where that passes its checks (:func:`_reflected`). Those cells
        are written as they are from ``margin`` frames inside their seams
        (:func:`~mocapkit.clean.repair.repair_cells`, ``exact``). ``contacts``: for the
        effector chains of these constraints, the KNN word that keeps the effector nearest its
        contact point replaces the median, then IK pins the effector (changing only the written
        cells of the chain). ``foot_lock``: where the repair changed a leg, hold its planted
        feet still by whole-leg IK (:func:`~mocapkit.clean.repair.lock_repaired_feet`; the
        cells it changes join ``written``)."""
        self._check()
        tex = self.texture_
        if margin is not None and whole_number(margin, "margin (frames)") < 0:
            raise ValueError(f"margin (frames) must be >= 0, got {margin!r}")
        margin = default_margin(self.motion_.fps) if margin is None else int(margin)
        contacts = [_by_index(c, self.motion_.skeleton) for c in contacts]
        flagged = self.mask(threshold) if mask is None else np.asarray(mask, dtype=bool)
        replacement = self.replacement()
        exact = None  # the cells whose replacement is the capture's own motion moved as a whole
        how = np.where(flagged, 0, -1).astype(np.int8)  # per cell, its REPAIR_METHODS index
        if mask is None:  # a stretch turned by one rotation is turned back (repair.unturned)
            fl = self.flags(threshold)
            ev = self.evidence_
            back = np.array(self.motion_.rotations, dtype=np.float64, copy=True)
            done = np.zeros_like(flagged)
            turned = fl.live("cancelling-jumps") & flagged
            # a noise burst is no turn, though its jumps may cancel
            turned &= ~_runs_touching(turned, fl.live("noise"))
            if turned.any():
                back, done = unturned(self.motion_.rotations, turned, within=flagged)
            # the hinge rule's runs (joined through a turned stretch: a mirrored flexion that
            # grazes -hinge_deg splits the rule's run, and each piece reflected on its own met
            # the other's error; reviewer) that bend the wrong way somewhere: a mirrored
            # flexion. Its runs only out of the hinge's plane keep a right-way flexion: a
            # stretch turned by one rotation, as any other joint's (newcomer: a waving forearm
            # swung sideways was sent to the median, its wave flattened)
            wrong = _runs_touching(fl.live("wrong-way-hinge") | done, ev.wrong_way) & flagged
            # nor, on a knee or elbow, is a wrong-way bend whose flexion curves
            done = _bent_right(ev, back, done, wrong)
            # a stretch whose turn-back is refused is no turned stretch (reviewer: its cells
            # beside the run were kept as "captured" with the refused turn-back's rotations)
            back = np.where(done[..., None], back, self.motion_.rotations)
            # a wrong-way bend: its flexion reflected back across straight, where that passes
            # its checks, rather than turned back (but a half-turn flip): the reflection undoes
            # a mirrored bend whatever its flexion does, the turn-back only where it changes
            # linearly (a CMU elbow mirrored for 20 frames at 120 fps: 2.0 deg off turned back,
            # 0.05 reflected; Bandai-1 tuning half, injected bends and flips: no figure moved)
            bent = wrong & ~_half_turns(ev, back, done)
            mirrored = np.zeros_like(flagged)
            if bent.any():
                mirrored_back, mirrored = _reflected(ev, bent, replacement)
                # a turned-back stretch is reflected whole or not at all
                mirrored &= ~_runs_touching(done, done & bent & ~mirrored)
                back = np.where(mirrored[..., None], mirrored_back, back)
                done |= mirrored
            if done.any():
                # the jumps bound the repaired stretch: the cells past them that only the words'
                # digression flags (it spills past an error by up to a source word) hold the
                # captured motion; another rule's cells, or the MDM's farther off, are the
                # median's (0.1 s kept a forearm's clean frames 4-7 past a turned twist for the
                # median, 18 deg off, newcomer; tuning half, seeds 0-1, spikes, offsets and
                # flips: clean cells within 1 s of the error moved over 5 deg 107 -> 69, the
                # injected cells' repair unchanged; validation half: no change)
                others = np.zeros_like(flagged)
                for r in fl.added:
                    if r not in ("mdm", "cancelling-jumps"):
                        others |= fl.live(r)
                pad = self.motion_.seconds_to_frames(SOURCE_LEN / ANALYSIS_FPS)
                keep = _runs_touching(flagged, done) & dilate(done, pad) & ~done & ~others
                bar = np.maximum(
                    ev.config.pair_ratio * ev.jump_scale, np.radians(ev.config.step_min_deg)
                )
                keep = _short_of_jumps(keep, done, ev.jump_peaks | (ev.jump_size > bar[None]))
                if tex.pelvis_align is not None:  # the pelvis column: facing-aligned space
                    p = tex.pelvis
                    back[:, p] = rot.quat_mul(tex.pelvis_align, back[:, p])
                replacement = np.where((done | keep)[..., None], back, replacement)
                how[done & flagged] = _TURNED
                how[mirrored & flagged] = _REFLECTED
                how[keep & flagged] = _KEPT
        for c in contacts:
            before = replacement
            replacement = self._contact_replacement(c, replacement, flagged)
            how[flagged & np.any(replacement != before, axis=-1)] = _CONTACT
        # written as they are past their seams: the capture's own motion moved as a whole, each
        # method its own source (a seam between a reflected and a turned-back cell is a seam)
        exact = np.where(np.isin(how, (_TURNED, _REFLECTED, _KEPT)), how, 0).astype(np.int8)
        result = repair_cells(
            self.motion_,
            flagged,
            replacement,
            margin,
            to_file=tex.pelvis_align,
            pelvis=tex.pelvis,
            exact=exact,
        )
        result.how = how
        motion = result.motion
        targets = [c.target(self.motion_) for c in contacts]
        for c, t in zip(contacts, targets, strict=True):
            motion = pin_with_ik(motion, c, result.written, t)
        result.motion = motion
        if foot_lock and flagged.any():
            locked = lock_repaired_feet(motion, result.written)
            result.motion = locked.motion
            result.written = locked.written
            result.held_contacts = locked.contacts
        result.contacts = tuple(
            contact_held(result.motion, c, t, result.written)
            for c, t in zip(contacts, targets, strict=True)
        )
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
                # translations too: a rig that animates them (Bandai's pelvis under its ground
                # root) has its effector elsewhere without them
                m = Motion(motion.skeleton, trial, motion.root_positions, motion.frame_time,
                           motion.translations)  # fmt: skip
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


def _by_index(contact: ContactConstraint, skeleton) -> ContactConstraint:
    """``contact`` with its joint as an index (it may be given by name)."""
    if isinstance(contact.joint, str):
        try:
            return dataclasses.replace(contact, joint=skeleton.index(contact.joint))
        except KeyError as e:
            raise ValueError(f"contact: {e.args[0]}") from None
    if not 0 <= int(contact.joint) < skeleton.num_joints:
        raise ValueError(f"contact: joint {contact.joint} out of range ({skeleton.num_joints})")
    return contact


def _reflected(
    ev: Evidence, cells: np.ndarray, median: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """``(out, done)``: the take's rotations with each run of ``cells`` on a straight knee or
    elbow (:attr:`Evidence.hinge_axes`) given its bend reflected back across straight (the flexion
    about the hinge's axis negated, the rest of the bend and the twist about the limb kept), plus a
    flexion offset growing linearly from the one that meets the frames before the run to the one
    that meets the frames after it (:func:`_edge_offsets`); and (F, J) bool of the cells so
    repaired. A run is left out where the reflection still bends the wrong way (or out of the
    hinge's plane, :meth:`Evidence.bends_as_hinge`), where it has fewer than two frames on either
    side, where the twist about the limb jumps at its edges (:func:`_twist_jumps`, over
    ``hinge_deg``), or where ``median`` (F, J, 4: the neighbours' median, the other repair) meets
    the frames beside the run more closely than the reflection does before its offset
    (:func:`_edge_offsets`, summed over the two edges).

    Relies on: how a hinge comes to bend the wrong way in a capture: a solver or a swapped
    marker picks the mirror solution of the limb's bend, so the size of the bend is still the
    capture's and only its side is lost; an offset pushing it further past straight shows as a
    jump at the run's edges, which the linear offset takes up. The neighbours' median, the
    alternative, is another moment's pose: for a one-off gesture (a wave with the elbow bent
    120 deg) it straightened the arm, 125 deg off (newcomer); on a cyclic motion the median is
    another cycle's pose, which meets the run's edges (a walking knee: tuning half, seed 0,
    bends mirrored and pushed 20-50 deg past straight, 4.6 deg off from the median and 10.2
    reflected); the one that meets the edges better is the better guess of the middle."""
    from mocapkit.clean.detect.evidence import bend_and_twist

    q = ev.rotations
    out = np.array(q, dtype=np.float64, copy=True)
    done = np.zeros(cells.shape, dtype=bool)
    F = q.shape[0]
    for j, axis in ev.hinge_axes.items():
        rest = None if ev.hinge_bones is None else ev.hinge_bones[ev.hinges.index(j)]
        if rest is None or not np.any(rest):
            continue
        flex = ev.hinge_flexion[:, j]
        for a, b in true_runs(cells[:, j]):
            if a < 2 or b > F - 3 or b - a < 1:
                continue
            if not np.isfinite(flex[[a - 2, a - 1, b + 1, b + 2]]).all():
                continue
            if _twist_jumps(q[a - 2 : b + 3, j], rest) > np.radians(ev.config.hinge_deg):
                continue  # not the bend alone turned over: the twist is off too
            bend, twist = bend_and_twist(q[a : b + 1, j], rest)
            f = bend @ axis
            off_a, off_b = _edge_offsets(flex, a, b, -f)
            if median is not None:
                fm = ev.flexion_of(j, median[a : b + 1, j])
                m_a, m_b = _edge_offsets(flex, a, b, fm)
                if abs(m_a) + abs(m_b) < abs(off_a) + abs(off_b):
                    continue
            lift = np.linspace(off_a, off_b, len(f))
            new = bend + (lift - 2 * f)[:, None] * axis[None]
            fixed = rot.quat_normalize(rot.quat_mul(rot.rotvec_to_quat(new), twist))
            if not ev.bends_as_hinge(j, fixed):
                continue
            out[a : b + 1, j] = fixed
            done[a : b + 1, j] = True
    return out, done


def _edge_offsets(flex: np.ndarray, a: int, b: int, run: np.ndarray) -> tuple[float, float]:
    """How far the flexion ``run`` (frames a..b, at least two) misses the take's ``flex`` at
    each edge, read both ways: the two frames outside carried on to the edge frame, and the two
    inside carried on to the frame outside. The joint's acceleration puts each reading off, by
    more on the side where it changes faster (a walking knee slowing to straight read 13 deg
    outside, 1 inside, for a run that meets it); the smaller reading is taken where the two
    agree in sign, else none."""

    def one(outside: float, inside: float) -> float:
        return (
            float(np.sign(outside) * min(abs(outside), abs(inside)))
            if outside * inside > 0
            else 0.0
        )

    start = one(2 * flex[a - 1] - flex[a - 2] - run[0], flex[a - 1] - (2 * run[0] - run[1]))
    end = one(2 * flex[b + 1] - flex[b + 2] - run[-1], flex[b + 1] - (2 * run[-1] - run[-2]))
    return start, end


def _twist_jumps(q: np.ndarray, bone: np.ndarray) -> float:
    """Radians: how far the twist about the limb ``bone`` of rotations ``q`` (a run with two
    frames before and after it) leaves, at the run's first and last frames, the twist carried on
    at its speed from the two frames beside each (the larger of the two)."""
    from mocapkit.clean.detect.evidence import bend_and_twist

    tw = bend_and_twist(q, bone)[1]
    b = np.asarray(bone, dtype=np.float64) / np.linalg.norm(bone)
    ang = 2.0 * np.arctan2(tw[:, 1:] @ b, tw[:, 0])
    ang = np.unwrap(ang)
    ends = [(ang[2], 2 * ang[1] - ang[0]), (ang[-3], 2 * ang[-2] - ang[-1])]
    return max(abs(float(np.angle(np.exp(1j * (x - y))))) for x, y in ends)


def _bent_right(
    ev: Evidence, turned_back: np.ndarray, done: np.ndarray, hinge: np.ndarray
) -> np.ndarray:
    """``done`` less the runs on a straight knee or elbow whose turn-back is no repair; those go
    to the neighbours' median:

    - any run the turn-back leaves bent the wrong way (flexion below ``-hinge_deg`` on a frame)
      or out of its plane (:meth:`Evidence.bends_as_hinge`);
    - a run the wrong-way-hinge rule flags (``hinge``) that is not a flip (turned back by less
      than :data:`HALF_TURN_DEG` at an edge) where the hinge's flexion, as given, strays from
      the straight line between the run's edge frames by over :data:`LINEAR_FLEXION_DEG`, or
      that reaches the take's first or last frame (one edge: no line).

    Relies on: anatomy, as the wrong-way-hinge rule, and how the two errors that bend a hinge
    the wrong way come about. A flip (a solver's half-turn ambiguity) turns a stretch by one
    half turn, undone by the turn read at its edges whatever the hinge does. A wrong-way bend
    mirrors the flexion: the turn that made it is twice the flexion (and a push past straight),
    and the turn-back slerps from one edge's turn to the other's, which follows it only where
    the flexion changes linearly over the run (a hinge held still, a short run); where the
    flexion curves (a walking knee's swing over 0.5 s), the middle stays off by twice the curve
    (tuning half, seed 0: locomotion bends turned back 12-22 deg off on average where the
    median, another step's knee, is 4.7)."""
    out = done.copy()
    q = ev.rotations
    F = q.shape[0]
    for j in ev.hinge_axes:
        flex = ev.hinge_flexion[:, j]
        for a, b in true_runs(done[:, j]):
            if not ev.bends_as_hinge(j, turned_back[a : b + 1, j]):
                out[a : b + 1, j] = False
                continue
            if not hinge[a : b + 1, j].any():
                continue
            turn = rot.quat_angle(turned_back[[a, b], j], q[[a, b], j])
            if (turn >= np.radians(HALF_TURN_DEG)).all():
                continue
            if a == 0 or b == F - 1:
                out[a : b + 1, j] = False
                continue
            f = flex[a : b + 1]
            chord = np.linspace(f[0], f[-1], len(f))
            if not np.all(np.abs(f - chord) <= np.radians(LINEAR_FLEXION_DEG)):
                out[a : b + 1, j] = False
    return out


_TURNED, _REFLECTED, _KEPT, _CONTACT = (
    REPAIR_METHODS.index(m) for m in ("turned back", "reflected", "captured kept", "contact word")
)  # the codes of RepairResult.how; 0 is the median


def _half_turns(ev: Evidence, turned_back: np.ndarray, done: np.ndarray) -> np.ndarray:
    """(F, J) bool: the runs of ``done`` turned back by at least :data:`HALF_TURN_DEG` at both
    edges (a flip's half turn)."""
    out = np.zeros(done.shape, dtype=bool)
    for j in np.flatnonzero(done.any(axis=0)):
        for a, b in true_runs(done[:, j]):
            turn = rot.quat_angle(turned_back[[a, b], j], ev.rotations[[a, b], j])
            out[a : b + 1, j] = bool((turn >= np.radians(HALF_TURN_DEG)).all())
    return out


HALF_TURN_DEG = 160.0
"""A turn-back of at least this at both edges of a hinge's run undoes a flip (a half turn, the
ambiguity of a rotation solver); a wrong-way bend turns a hinge by twice its flexion and the
push past straight, rarely this much."""

LINEAR_FLEXION_DEG = 3.0
"""How far (deg) a wrong-way-bent hinge's flexion may stray from the straight line between its
run's edge frames for the slerped turn-back to follow it (the repair then errs by about twice
this, as little as the neighbours' median does on a walking knee: 4-5 deg, tuning half)."""


def _short_of_jumps(keep: np.ndarray, done: np.ndarray, peaks: np.ndarray) -> np.ndarray:
    """``keep`` (cells beside a turned-back stretch, ``done``, that hold the captured motion)
    cut at the first jump (``peaks``: the jump peaks, and every jump as large as one must be)
    away from the stretch: the stretch's own exit jump enters the first cell after it, but a
    jump farther on means the capture is not clean there (a thumb thrashing on after the pair
    of pops that bounds the turned stretch: CMU 01_13, whose kept raw frames left a 23 deg
    jump in the repair)."""
    out = keep.copy()
    F = keep.shape[0]
    for j in np.flatnonzero(keep.any(axis=0)):
        for a, b in true_runs(keep[:, j]):
            jumps = np.flatnonzero(peaks[a + 1 : b + 1, j])
            if not len(jumps):
                continue
            # the cells on a stretch's side of the nearest jump stay (both, between two)
            near = np.zeros(b + 1 - a, dtype=bool)
            if a > 0 and done[a - 1, j]:  # after a stretch: its exit jump enters frame a
                near[: 1 + jumps[0]] = True
            if b < F - 1 and done[b + 1, j]:  # before one: its entry jump enters b + 1
                near[1 + jumps[-1] :] = True
            out[a : b + 1, j] = near
    return out


def _runs_touching(mask: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(F, J) bool: the runs of ``mask`` (per joint, along time) holding a cell of ``cells``."""
    out = np.zeros(mask.shape, dtype=bool)
    for j in np.flatnonzero(cells.any(axis=0)):
        for a, b in true_runs(mask[:, j]):
            if cells[a : b + 1, j].any():
                out[a : b + 1, j] = True
    return out
