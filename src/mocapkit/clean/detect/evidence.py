"""The evidence the detection rules read, computed once per take.

:class:`Evidence` holds the take's rotations and, once the self-similarity search has run, its
maps (MDM, digression, neighbour spread); every derived quantity (steps, jumps, roughness, hinge
flexion, spike sizes, frozen runs) is computed on first use and kept, whatever rule asks first.
None of them depends on the MDM threshold, so one Evidence serves every threshold.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cached_property

import numpy as np

from mocapkit.clean import mdm as mdm_mod
from mocapkit.clean.detect.config import DetectConfig, seconds_to_frames
from mocapkit.clean.words import ANALYSIS_FPS, SOURCE_LEN
from mocapkit.core import rotations as rot
from mocapkit.core.runs import true_runs
from mocapkit.core.skeleton import Skeleton
from mocapkit.features import limb_hinges


def _bone_out(skeleton: Skeleton, joint: int) -> np.ndarray | None:
    """The joint's longest bone out (child offset or end site), in the joint's frame."""
    outs = [skeleton.offsets[c] for c in skeleton.children(joint)]
    outs += list(skeleton.end_site_offsets[skeleton.end_site_parents == joint])
    if not outs:
        return None
    return max(outs, key=lambda v: float(np.linalg.norm(v)))


def straight_hinges(skeleton: Skeleton, max_angle: float) -> list[int]:
    """The knees and elbows (:func:`~mocapkit.features.limb_hinges`) whose bone in (their offset)
    and longest bone out lie within ``max_angle`` radians of one straight line at rest: those
    whose zero rotation is the straight limb, so that a flexion below zero is a wrong-way bend."""
    out = []
    for j in limb_hinges(skeleton):
        below = _bone_out(skeleton, j)
        if below is None:
            continue
        above = skeleton.offsets[j]
        n = float(np.linalg.norm(below) * np.linalg.norm(above))
        if n > 0 and np.arccos(np.clip(below @ above / n, -1.0, 1.0)) <= max_angle:
            out.append(j)
    return out


def hinge_bones(skeleton: Skeleton, hinges: Sequence[int]) -> np.ndarray:
    """(H, 3) unit rest directions of each hinge's longest bone out, in the hinge's own frame
    (the limb below the knee or elbow); a zero row where the joint has no bone out."""
    out = np.zeros((len(hinges), 3))
    for i, j in enumerate(hinges):
        b = _bone_out(skeleton, int(j))
        n = 0.0 if b is None else float(np.linalg.norm(b))
        if n > 0:
            out[i] = b / n
    return out


def bend_rotvecs(q: np.ndarray, bone: np.ndarray | None) -> np.ndarray:
    """(F, 3) rotation vectors of the *bend* of a hinge's rotations ``q`` (F, 4): the shortest
    rotation carrying the rest direction ``bone`` (unit, the hinge's frame) of the limb below it
    to where ``q`` points it, the twist about that limb left out (its angle is how far the limb
    turned from its rest direction: for a straight-at-rest hinge, its bend). Without ``bone``
    (or a zero one): the full rotation vectors."""
    if bone is None or not np.any(bone):
        return rot.quat_to_rotvec(q)
    b = np.asarray(bone, dtype=np.float64)
    now = rot.quat_apply(q, np.broadcast_to(b, (len(q), 3)))
    c = np.cross(b, now)
    n = np.linalg.norm(c, axis=1, keepdims=True)
    ang = np.arctan2(n, (now @ b)[:, None])
    return np.where(n > 1e-12, c / np.maximum(n, 1e-12) * ang, 0.0)


def bend_and_twist(q: np.ndarray, bone: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(bend, twist)`` of a hinge's rotations ``q`` (F, 4) about the limb ``bone`` below it:
    the bend's rotation vectors (:func:`bend_rotvecs`) and the twist quaternions (F, 4) about
    ``bone`` that it leaves, ``q = exp(bend) * twist``."""
    bend = bend_rotvecs(q, bone)
    return bend, rot.quat_mul(rot.quat_inv(rot.rotvec_to_quat(bend)), q)


def _limbs(bends: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """(N, 3) unit directions of the limb below a hinge bent by rotation vectors ``bends``
    (N, 3), from its rest direction ``rest``."""
    r = np.asarray(rest, dtype=np.float64) / np.linalg.norm(rest)
    return rot.quat_apply(rot.rotvec_to_quat(bends), np.broadcast_to(r, bends.shape))


def _off_plane(limbs: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """(N,) radians: the angle of unit limb directions ``limbs`` from the plane across
    ``axis`` (the plane a hinge about ``axis`` swings its limb in)."""
    return np.arcsin(np.clip(np.abs(limbs @ axis), 0.0, 1.0))


def _main_axis(bends: np.ndarray, rest: np.ndarray | None, plane: float) -> np.ndarray:
    """The main direction (unit) of a hinge's bend rotation vectors ``bends`` (N, 3). With the
    limb's rest direction ``rest`` and ``plane`` > 0 (radians), fitted again (up to three times)
    on the bends whose limb lies within ``plane`` of the last fit's plane, where most of them
    do: an error's frames (a flip, a limb swung sideways) tilt a least-squares axis, and the
    take's own bends then read off their plane (reviewer: a 20-deg sideways swing of 12 frames
    tilted a Bandai-1 elbow's axis so that the whole take read off its plane)."""
    axis = np.linalg.svd(bends, full_matrices=False)[2][0]
    if rest is None or plane <= 0:
        return axis
    limbs = _limbs(bends, rest)
    for _ in range(3):
        near = _off_plane(limbs, axis) <= plane
        if near.sum() * 2 <= len(bends) or near.all():
            break
        axis = np.linalg.svd(bends[near], full_matrices=False)[2][0]
    return axis


class Evidence:
    """What the rules of :data:`~mocapkit.clean.detect.PIPELINE` read, for one take.

    Args:
        rotations: (F, J, 4) the take's local rotations (w, x, y, z).
        fps: the take's frame rate.
        config: the thresholds (the derived quantities below read only their window lengths).
        hinges: joint indices of the straight-at-rest knees and elbows (wrong-way bends).
        hinge_bones: (H, 3) rest directions of the limb below each hinge (:func:`hinge_bones`):
            how far a hinge bends, and its bend alone, the twist about that limb left out
            (config ``hinge_bend_deg``); None: the full rotations always.
        context_rotations: (F_i, J, 4) rotations of context takes at the same frame rate (the
            recurring veto looks for the same excursion there; the hinge axis is fitted on them
            too if the config's ``hinge_context``).
        names: the J joint names (for explanations).
        parents: the J parent indices (root -1) or None (then a straight hinge's hold is
            never judged by its parent's).

    The maps are set by :meth:`set_maps` after the search: ``mdm`` (F, J) in [0, 1], ``z`` the
    normalised digression (unbounded, (F, J)), ``digression`` (F, J) radians, ``spread`` (F, J)
    radians or None, ``analysed`` (J,) bool.
    """

    def __init__(
        self,
        rotations: np.ndarray,
        fps: float,
        config: DetectConfig | None = None,
        hinges: Sequence[int] = (),
        context_rotations: Sequence[np.ndarray] = (),
        names: Sequence[str] | None = None,
        hinge_bones: np.ndarray | None = None,
        parents: Sequence[int] | None = None,
    ) -> None:
        self.rotations = np.asarray(rotations, dtype=np.float64)
        if self.rotations.ndim != 3 or self.rotations.shape[2] != 4:
            raise ValueError(f"rotations must be (F, J, 4), got {self.rotations.shape}")
        self.fps = float(fps)
        self.config = config or DetectConfig()
        self.hinges = [int(j) for j in hinges]
        self.hinge_bones = None if hinge_bones is None else np.asarray(hinge_bones, float)
        if self.hinge_bones is not None and self.hinge_bones.shape != (len(self.hinges), 3):
            raise ValueError(f"hinge_bones must be ({len(self.hinges)}, 3)")
        self.context_rotations = [np.asarray(c, dtype=np.float64) for c in context_rotations]
        J = self.rotations.shape[1]
        self.names = list(names) if names is not None else [f"joint{j}" for j in range(J)]
        self.parents = None if parents is None else np.asarray(parents, dtype=np.int64)
        self.mdm: np.ndarray | None = None
        self.z: np.ndarray | None = None
        self.digression: np.ndarray | None = None
        self.spread: np.ndarray | None = None
        self.analysed = np.ones(J, dtype=bool)

    @classmethod
    def for_motion(
        cls,
        motion,
        config: DetectConfig | None = None,
        context: Sequence = (),
    ) -> Evidence:
        """Evidence of a :class:`~mocapkit.core.motion.Motion`: the straight hinges from its
        skeleton, the context takes of its own frame rate."""
        cfg = config or DetectConfig()
        same_rate = [
            c.rotations for c in context if np.isclose(c.frame_time, motion.frame_time, rtol=1e-6)
        ]
        sk = motion.skeleton
        hinges = straight_hinges(sk, np.radians(cfg.hinge_straight_deg))
        bones = hinge_bones(sk, hinges)
        return cls(
            motion.rotations, motion.fps, cfg, hinges, same_rate, sk.names, bones, sk.parents
        )

    def set_maps(
        self,
        mdm: np.ndarray,
        z: np.ndarray,
        digression: np.ndarray,
        analysed: np.ndarray | None = None,
        spread: np.ndarray | None = None,
    ) -> Evidence:
        """Attach the self-similarity maps (see the class docstring); returns ``self``."""
        shape = self.rotations.shape[:2]
        for name, a in (("mdm", mdm), ("z", z), ("digression", digression)):
            if np.shape(a) != shape:
                raise ValueError(f"{name} must be {shape}, got {np.shape(a)}")
        self.mdm, self.z, self.digression, self.spread = mdm, z, digression, spread
        if analysed is not None:
            self.analysed = np.asarray(analysed, dtype=bool)
        return self

    def frames(self, seconds: float, minimum: int = 1) -> int:
        """A duration of the config in this take's frames."""
        return seconds_to_frames(seconds, self.fps, minimum)

    @property
    def shape(self) -> tuple[int, int]:
        return self.rotations.shape[:2]

    def _need_maps(self) -> None:
        if self.mdm is None:
            raise RuntimeError("this rule needs the MDM: call set_maps() (fit the cleaner) first")

    # ------------------------------------------------------------------ from the rotations
    @cached_property
    def jump_ratio(self) -> np.ndarray:
        """(F, J) angular acceleration over the joint's median (:func:`mdm.jump_ratio`)."""
        size = 2 * self.frames(self.config.jump_median_seconds, 0) + 1
        return mdm_mod.jump_ratio(self.rotations, np.radians(self.config.jump_floor_deg), size)

    @cached_property
    def body_deviations(self) -> np.ndarray:
        """(F, J, 3) step deviations in the joint's own frame (:func:`mdm.step_deviations`)."""
        return mdm_mod.step_deviations(self.rotations, "body")

    @cached_property
    def parent_deviations(self) -> np.ndarray:
        """(F, J, 3) step deviations in the parent's frame."""
        return mdm_mod.step_deviations(self.rotations, "parent")

    @cached_property
    def steps(self) -> np.ndarray:
        """(F, J) radians: step size (:func:`mdm.step_size`)."""
        return np.linalg.norm(self.body_deviations, axis=-1)

    @cached_property
    def step_peaks(self) -> np.ndarray:
        """(F, J) bool: steps far above the joint's own (:func:`mdm.step_peaks`)."""
        c = self.config
        return mdm_mod.step_peaks(
            self.steps, c.step_ratio, np.radians(c.step_min_deg), c.step_quantile
        )

    @cached_property
    def step_cells(self) -> np.ndarray:
        """(F, J) bool: the cell on each step peak's digressing side (needs the maps)."""
        self._need_maps()
        sides = mdm_mod.step_sides(
            self.step_peaks, self.z, self.frames(self.config.step_side_seconds)
        )
        return mdm_mod.step_cells(self.step_peaks, sides)

    @cached_property
    def jump_size(self) -> np.ndarray:
        """(F, J) radians: how much a step differs from both neighbours (:func:`mdm.jump_size`)."""
        return mdm_mod.jump_size(self.rotations)

    @cached_property
    def jump_scale(self) -> np.ndarray:
        """(J,) radians: the joint's ordinary jump, its ``pair_quantile`` of jumps in the take
        (an error's few jumps stay above it)."""
        if self.jump_size.shape[0] == 0:
            return np.zeros(self.jump_size.shape[1])
        return np.percentile(self.jump_size, self.config.pair_quantile, axis=0)

    @cached_property
    def jump_peaks(self) -> np.ndarray:
        """(F, J) bool: jumps far above the joint's own, and the jumps of a still joint."""
        c = self.config
        peaks = mdm_mod.step_peaks(
            self.jump_size, c.pair_ratio, np.radians(c.step_min_deg), c.pair_quantile
        )
        return peaks | self.still_jumps

    @cached_property
    def still_jumps(self) -> np.ndarray:
        """(F, J) bool: jumps of a joint still before and after them (:func:`mdm.still_jumps`,
        ``still_jump_ratio``), jump peaks however small against the joint's own jumps."""
        c = self.config
        if c.still_jump_ratio <= 0:
            return np.zeros(self.shape, dtype=bool)
        return mdm_mod.still_jumps(
            self.rotations,
            np.radians(c.step_min_deg),
            c.still_jump_ratio,
            self.frames(c.still_jump_seconds),
        )

    @cached_property
    def _pairing(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The cancelling stretches, the peaks that paired, and each peak's side."""
        self._need_maps()
        span = round(self.config.pair_seconds * self.fps)
        devs = [self.body_deviations, self.parent_deviations]
        # which side of each jump digresses (needs the maps), judged only for jumps a source
        # word apart or more: the words' digression blurs the two sides of a shorter stretch
        sides = mdm_mod.step_sides(
            self.jump_peaks, self.z, self.frames(self.config.step_side_seconds)
        )
        word = self.frames(SOURCE_LEN / ANALYSIS_FPS)
        used = np.zeros(self.shape, dtype=bool)
        c = self.config
        cells = mdm_mod.cancelling_steps(
            self.jump_peaks, devs, span, c.pair_tol, sides, word, used, self.pops,
            c.pair_axis_cos, self.big_jumps,
        )  # fmt: skip
        return cells, used, sides

    @cached_property
    def big_jumps(self) -> np.ndarray:
        """(F, J) bool: the jump peaks over ``pair_axis_ratio`` times the joint's ordinary
        jump (:attr:`jump_scale`): far above anything the joint does in the take."""
        c = self.config
        return self.jump_peaks & (self.jump_size > c.pair_axis_ratio * self.jump_scale[None])

    @cached_property
    def pops(self) -> np.ndarray:
        """(F, J) bool: the jump peaks that are one side of a one-frame pop, the frame beside
        them deviating the opposite way (:func:`mdm.one_frame_spikes`, ``pop_tol``): they pair
        with no farther jump."""
        devs = [self.body_deviations, self.parent_deviations]
        return mdm_mod.one_frame_spikes(self.jump_peaks, devs, self.config.pop_tol)

    @cached_property
    def cancelling(self) -> np.ndarray:
        """(F, J) bool: stretches between two jumps that cancel (:func:`mdm.cancelling_steps`),
        not from a jump that leaves an error to one that enters another where jumps flank
        them (needs the maps)."""
        return self._pairing[0]

    @cached_property
    def cut_off(self) -> np.ndarray:
        """(F, J) bool: stretches from an unpaired jump to the take's end or start that an error
        cut off by the take may hold (:func:`mdm.cut_off_steps`; the cancelling-jumps rule
        keeps those whose frames mostly digress or whose one jump is far above the joint's
        own)."""
        _, used, sides = self._pairing
        span = round(self.config.pair_seconds * self.fps)
        return mdm_mod.cut_off_steps(self.jump_peaks, used, sides, span)

    @cached_property
    def spike_size(self) -> np.ndarray:
        """(F, J) radians off the joint's smooth path (:func:`mdm.spike_size`), exact above
        the smaller of ``spike_floor_deg`` and ``spike_deg`` (a bound below it: the
        :class:`Spikes` rule never reads lower); on the take's first and last frames, off the
        joint's constant turn through the frames beside them (:func:`mdm.end_spike_size`)."""
        floor = np.radians(min(self.config.spike_floor_deg, self.config.spike_deg))
        size = mdm_mod.spike_size(self.rotations, self.frames(self.config.spike_seconds), floor)
        return np.maximum(size, mdm_mod.end_spike_size(self.rotations))

    @cached_property
    def limit_excursions(self) -> list[list[tuple[int, int]]]:
        """Per joint, its excursions off a limit it is clamped at, from the limit back to it
        (:func:`mdm.limit_excursions`; frames, inclusive)."""
        c = self.config
        q = self.rotations
        if c.limit_holds <= 0 or len(q) < 3:
            return [[] for _ in range(q.shape[1])]
        args = (self.frames(c.limit_hold_seconds, 2), c.limit_holds, np.radians(c.limit_tol_deg))
        return [
            mdm_mod.limit_excursions(q[:, j], self.still[:, j], *args) for j in range(q.shape[1])
        ]

    @cached_property
    def still(self) -> np.ndarray:
        """(F-1, J) bool: the steps (frame f -> f + 1) turning slower than
        ``frozen_speed_deg_s``: where a joint is held (the frozen rule's "held")."""
        q = self.rotations
        if len(q) < 2:
            return np.zeros((0, q.shape[1]), dtype=bool)
        return rot.quat_angle(q[:-1], q[1:]) < np.radians(self.config.frozen_speed_deg_s / self.fps)

    @cached_property
    def roughness(self) -> np.ndarray:
        """(F, J) radians: second difference of angular velocity (:func:`mdm.burst_roughness`)."""
        return mdm_mod.burst_roughness(self.rotations)

    @cached_property
    def rough_runs(self) -> np.ndarray:
        """(F, J) bool: sustained roughness (:func:`mdm.noise_bursts`), waves included."""
        c = self.config
        return mdm_mod.noise_bursts(
            self.roughness,
            mdm_mod.turn_change(self.rotations),
            self.noise_level,
            self.frames(c.noise_seconds, 2),
            c.noise_edge_share,
            c.noise_edge_jump,
            c.noise_hold_ratio,
        )

    @cached_property
    def noise_bursts(self) -> np.ndarray:
        """(F, J) bool: the rough runs (:attr:`rough_runs`) whose jerk does not lie along one
        axis (:func:`mdm.axis_share` at most ``noise_axis_share``)."""
        c = self.config
        out = self.rough_runs.copy()
        if 0 < c.noise_axis_share < 1:
            # noise turns the joint every which way; a fast wave or shake, back and forth
            # about one axis
            for j in np.flatnonzero(out.any(axis=0)):
                for a, b in true_runs(out[:, j]):
                    if mdm_mod.axis_share(self.rotations[:, j], a, b) > c.noise_axis_share:
                        out[a : b + 1, j] = False
        return out

    @cached_property
    def noise_level(self) -> np.ndarray:
        """(J,) radians: the roughness a noise burst must exceed on each joint, ``noise_deg``
        or ``noise_ratio`` times the joint's median roughness in the take if that is more."""
        c = self.config
        r = self.roughness
        F = r.shape[0]
        med = np.median(r[1 : F - 2], axis=0) if F > 4 else np.zeros(r.shape[1])
        return np.maximum(np.radians(c.noise_deg), c.noise_ratio * med)

    @cached_property
    def hinge_flexion(self) -> np.ndarray:
        """(F, J) radians: flexion of the straight hinges about their main axis (the principal
        direction of their bend's rotation vectors, signed so that the median is positive: the
        usual way), NaN on other joints. A limb folded back further than ``hinge_max_deg``
        (where its rotation vector wraps) reads as that much wrong-way flexion, and is left out
        of the fit; a hinge whose full rotations wrap (no ``hinge_bones``) is left out (NaN).

        The axis is fitted on the hinge's *bend* alone (:func:`bend_rotvecs`: the twist about
        the limb below left out), never on its full rotations: a Bandai elbow carries the
        forearm's twist, and a wave made by twisting the forearm tilts the full rotations' main
        axis towards the twist, which then reads as a wrong-way bend whenever the forearm twists
        back (Bandai-1 validation gestures: 42 false-alarm units with the full fit, none with
        the bend's, no hit lost). A hinge that does not really bend over the take (its bend
        angle spans less than ``hinge_bend_deg`` between its 5th and 95th percentiles) does not
        show its axis even in its bend: it is pooled with the context's takes (same rate, none
        wrapping) where there are any. ``hinge_context``: every hinge pooled with the context (a
        wrapping context then leaves it unjudged). Without the limb's rest direction (no
        ``hinge_bones``) the full rotations are all there is."""
        out = np.full(self.rotations.shape[:2], np.nan)
        for j, axis in self.hinge_axes.items():
            out[:, j] = self.flexion_of(j, self.rotations[:, j], axis)
        return out

    def flexion_of(self, joint: int, q: np.ndarray, axis: np.ndarray | None = None) -> np.ndarray:
        """(F,) radians: the flexion of rotations ``q`` (F, 4) of straight hinge ``joint``
        about its fitted main axis (:attr:`hinge_axes`), as :attr:`hinge_flexion` reads the
        take's own: a limb folded back past ``hinge_max_deg`` reads as that much wrong-way
        flexion. NaN where the hinge is not judged."""
        axis = self.hinge_axes.get(joint) if axis is None else axis
        if axis is None:
            return np.full(len(q), np.nan)
        rest = None if self.hinge_bones is None else self.hinge_bones[self.hinges.index(joint)]
        own = bend_rotvecs(np.asarray(q, dtype=np.float64), rest)
        size = np.linalg.norm(own, axis=1)
        # a limb folded back past hinge_max_deg is past any knee's or elbow's reach (about
        # 150-160 deg): read as a wrong-way bend of that size
        return np.where(size > np.radians(self.config.hinge_max_deg), -size, own @ axis)

    @cached_property
    def hinge_axes(self) -> dict[int, np.ndarray]:
        """Each judged straight hinge's main flexion axis (unit, its own frame), signed so that
        the median flexion is positive; see :attr:`hinge_flexion`."""
        q = self.rotations
        c = self.config
        axes: dict[int, np.ndarray] = {}
        wrap = np.radians(c.hinge_max_deg)
        for i, j in enumerate(self.hinges):
            rest = None if self.hinge_bones is None else self.hinge_bones[i]
            own = bend_rotvecs(q[:, j], rest)
            size = np.linalg.norm(own, axis=1)
            folded = size > wrap  # rotation vectors wrap at 180 deg: no axis to read there
            if len(own) == 0 or (rest is None and folded.any()) or folded.all():
                continue  # the full rotations wrap wherever bend and twist add up to 180
            bends = self._bends(q[:, j], rest)
            pool = own[~folded]
            others = [x[:, j] for x in self.context_rotations]
            if others and (c.hinge_context or not bends):
                theirs = np.concatenate([bend_rotvecs(x, rest) for x in others])
                keep = np.linalg.norm(theirs, axis=1) <= wrap
                if rest is None and not keep.all():
                    if c.hinge_context:
                        continue  # as before: a wrapping context leaves the hinge unjudged
                else:
                    pool = np.concatenate([pool, theirs[keep]])
            axis = _main_axis(pool, rest, np.radians(c.hinge_plane_deg))
            axes[j] = -axis if np.median(pool @ axis) < 0 else axis
        return axes

    def _bends(self, q: np.ndarray, bone: np.ndarray | None) -> bool:
        """Whether a hinge's bend angle spans ``hinge_bend_deg`` over the take (5th to 95th
        percentile); always True when that is 0 or the limb below is unknown."""
        lim = self.config.hinge_bend_deg
        if lim <= 0 or bone is None or not np.any(bone):
            return True
        a = np.linalg.norm(bend_rotvecs(q, bone), axis=1)
        return bool(np.degrees(np.percentile(a, 95) - np.percentile(a, 5)) >= lim)

    @cached_property
    def wrong_way(self) -> np.ndarray:
        """(F, J) bool: hinges bent past straight the wrong way by more than ``hinge_deg``."""
        with np.errstate(invalid="ignore"):
            return self.hinge_flexion < -np.radians(self.config.hinge_deg)

    @cached_property
    def hinge_off_plane(self) -> np.ndarray:
        """(F, J) radians: how far each judged straight hinge's limb swings out of its bending
        plane (:meth:`off_plane_of`), NaN on other joints and on hinges without the limb's rest
        direction (no ``hinge_bones``: the full rotations mix the twist in)."""
        out = np.full(self.rotations.shape[:2], np.nan)
        if self.hinge_bones is None:
            return out
        for j in self.hinge_axes:
            out[:, j] = self.off_plane_of(j, self.rotations[:, j])
        return out

    def off_plane_of(self, joint: int, q: np.ndarray) -> np.ndarray:
        """(F,) radians: the angle between the limb below straight hinge ``joint``, turned by
        rotations ``q`` (F, 4), and the plane it bends in (across the hinge's main axis,
        :attr:`hinge_axes`). NaN without the limb's rest direction."""
        axis = self.hinge_axes[joint]
        rest = None if self.hinge_bones is None else self.hinge_bones[self.hinges.index(joint)]
        if rest is None or not np.any(rest):
            return np.full(len(q), np.nan)
        limbs = rot.quat_apply(np.asarray(q, dtype=np.float64), np.broadcast_to(rest, (len(q), 3)))
        return _off_plane(limbs, axis)

    @cached_property
    def planar_hinges(self) -> np.ndarray:
        """(J,) bool: the judged hinges that keep to their plane over the take: the median tilt of
        the plane each frame's bend lies in, from the hinge's (the limb's angle off the plane,
        over the sine of the bend), over the frames bent more than ``hinge_bend_deg``, at most
        ``hinge_planar_deg``; not a hinge bent that far on fewer than three frames (a forearm
        held straight through a take fitted an axis along itself, and every frame read 90 deg
        off the plane: an Axis Neuron file of the BVH corpus). The tilt, not the angle off the
        plane: a rig whose knee is mostly near straight keeps that angle small whatever its axis
        does (reviewer: an SMPL knee, median bend 15 deg, bent over 30 deg with its plane tilted
        8.6 deg)."""
        off = self.hinge_off_plane
        out = np.zeros(off.shape[1], dtype=bool)
        if not len(off):
            return out
        for j in np.flatnonzero(np.isfinite(off).all(axis=0)):
            rest = self.hinge_bones[self.hinges.index(j)]
            bend = np.linalg.norm(bend_rotvecs(self.rotations[:, j], rest), axis=1)
            bent = bend > np.radians(self.config.hinge_bend_deg)
            if bent.sum() < 3:
                continue  # a hinge that does not bend shows no plane (nor, alone, an axis)
            tilt = np.arcsin(np.clip(np.sin(off[bent, j]) / np.sin(bend[bent]), 0.0, 1.0))
            out[j] = np.median(tilt) <= np.radians(self.config.hinge_planar_deg)
        return out

    def bends_as_hinge(self, joint: int, q: np.ndarray) -> bool:
        """Whether every frame of rotations ``q`` (F, 4) of straight hinge ``joint`` bends as
        the rule judges a knee or elbow may: no more than ``hinge_deg`` past straight the wrong
        way, and (on a planar hinge, :attr:`planar_hinges`) within ``hinge_plane_deg`` of its
        plane. A repair is held to it."""
        c = self.config
        with np.errstate(invalid="ignore"):
            if (self.flexion_of(joint, q) < -np.radians(c.hinge_deg)).any():
                return False
            if c.hinge_plane_deg > 0 and self.planar_hinges[joint]:
                return not (self.off_plane_of(joint, q) > np.radians(c.hinge_plane_deg)).any()
        return True

    @cached_property
    def off_plane(self) -> np.ndarray:
        """(F, J) bool: planar hinges (:attr:`planar_hinges`) whose limb leaves its plane by
        more than ``hinge_plane_deg`` (never with that at 0)."""
        c = self.config
        if c.hinge_plane_deg <= 0:
            return np.zeros(self.shape, dtype=bool)
        with np.errstate(invalid="ignore"):
            far = self.hinge_off_plane > np.radians(c.hinge_plane_deg)
        return far & self.planar_hinges[None]

    # ------------------------------------------------------------------ needing the maps
    def _frozen_params(self) -> dict:
        c = self.config
        recur = self.frames(c.frozen_recur_seconds)
        return {
            "min_frames": self.frames(c.frozen_seconds, 2),
            "speed": np.radians(c.frozen_speed_deg_s / self.fps),
            "min_digression": np.radians(c.frozen_min_digression_deg),
            "tol": np.radians(c.frozen_tol_deg),
            "max_recur": recur,
            "margin": recur,
            "exact_share": c.frozen_exact_share,
        }

    @cached_property
    def exact_tells(self) -> np.ndarray:
        """(J,) bool: whether a hold repeating its value bit for bit tells a dropout on each
        joint (:func:`mdm.exact_holds_tell`)."""
        p = self._frozen_params()
        return np.array(
            [
                mdm_mod.exact_holds_tell(self.rotations[:, j], p["min_frames"], p["exact_share"])
                for j in range(self.rotations.shape[1])
            ],
            dtype=bool,
        )

    def frozen_why(self, joint: int, frame: int) -> tuple[str, int, int, float]:
        """Why the frozen rule does or does not flag cell (``frame``, ``joint``): ``(verdict,
        a, b, value)`` with the still run ``a .. b`` (frames) around it; verdict "moving" (no
        still run there), "short", "calm", "rests", "parked" (a straight hinge held straight)
        "whole" (held through the whole take) or "frozen" (:func:`mdm.frozen_verdict`)."""
        self._need_maps()
        p = self._frozen_params()
        q = self.rotations[:, joint]
        still = self.still[:, joint]
        f = frame if frame < len(still) and still[frame] else frame - 1
        if f < 0 or not still[f]:
            return "moving", frame, frame, 0.0
        tell = bool(self.exact_tells[joint])
        runs = mdm_mod.held_runs(q, still, p["min_frames"], tell)
        a, b = next(r for r in runs if r[0] <= f <= r[1])
        verdict, value = mdm_mod.frozen_verdict(
            q, still, self.digression[:, joint], a, b, p["min_frames"], p["min_digression"],
            p["tol"], p["max_recur"], p["margin"], tell,
        )  # fmt: skip
        if verdict == "frozen" and self._held_throughout[joint]:
            verdict = "whole"
        elif verdict == "frozen" and not self.frozen[mdm_mod.held_from(a), joint]:
            verdict = "parked"
        return verdict, a, b + 1, value

    @cached_property
    def frozen(self) -> np.ndarray:
        """(F, J) bool: frozen runs (:func:`mdm.frozen_cells`), less the straight hinges held
        within ``frozen_straight_deg`` of straight (parked at their limit), unless the hinge's
        parent is frozen over the whole hold: a live upper arm or thigh trembles, so when it
        is held too the straight elbow or knee is the same dropout (CMU 03_02 opens with every
        joint exactly at zero, a straight elbow included: newcomer report)."""
        self._need_maps()
        c = self.config
        p = self._frozen_params()
        out = mdm_mod.frozen_cells(self.rotations, self.digression, **p)
        if c.frozen_straight_deg > 0:
            held = out.copy()
            for j in self.hinges:
                for a, b in true_runs(out[:, j]):
                    w = abs(float(self.rotations[a, j, 0]))
                    straight = 2.0 * np.arccos(min(w, 1.0)) <= np.radians(c.frozen_straight_deg)
                    up = -1 if self.parents is None else int(self.parents[j])
                    if straight and not (up >= 0 and held[a : b + 1, up].all()):
                        out[a : b + 1, j] = False
        # a joint held through the whole take is one the take does not animate (a standing
        # person's toe, judged against walks in the context), not a dropout: a dropped marker
        # holds the value captured before it, inside a take that moves the joint
        out[:, self._held_throughout] = False
        return out

    @property
    def _held_throughout(self) -> np.ndarray:
        """(J,) bool: the joints held (:attr:`still`) on every step of the take."""
        return self.still.all(axis=0) if len(self.still) else np.zeros(self.shape[1], bool)
