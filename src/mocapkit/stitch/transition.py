"""The stitched :class:`~mocapkit.core.motion.Motion`: query up to take-off, k generated frames,
data from the landing frame on — by the effort-minimising Kalman transition, or by the plain
baselines (cross-fade, gap interpolation).

Alignment (:func:`align_data`). The data clip (first put on the query's skeleton by
:func:`mocapkit.stitch.search.conform`) is moved rigidly over the ground plane
(:func:`mocapkit.features.ground_alignment`, :func:`mocapkit.features.apply_ground_transform`) so
that at the landing frame b its facing equals the query's at the take-off frame a and its pelvis
ground position *continues* the query's: ``p_b = p_a + (k + 1) v``, where v is the mean of the
query's pelvis ground velocity at a (``p_a - p_{a-1}``) and the aligned data's at b
(``p_{b+1} - p_b``). Placing the landing frame exactly on the take-off position would make the
character stand still for the k + 1 steps of the transition. Heights are never changed and the
heading is not extrapolated (a turn during the transition is not predicted). ``align=False``
keeps the data clip where it is (e.g. two parts of one recording, as in the blank-out
experiment).

Generated frames (:func:`stitch_motions`), k of them. Every joint's local rotation is written
relative to the take-off pose, ``r_t = log(q_a⁻¹ q_t)`` with the quaternion taken in the ``w >= 0``
hemisphere (continuous as long as a joint turns by less than 180° from its take-off pose within
the window), and the root position and the animated local translations are taken as they are
(centred on frame a). Each of these series is smoothed with the same Kalman model and mask as the
score — w observed take-off frames ``a-w+1..a``, k unobserved steps, w observed landing frames
``b..b+w-1`` of the aligned data — and the k unobserved steps become the generated frames
(``q = q_a exp(r̂)``). The query's frames up to a and the data's frames from b are kept unchanged,
but for k = 0, which the score often picks: that is a cut, and the data's first frames are eased
in from where the query was heading (:func:`_eased_cut`, over ``DEFAULT_BLEND_SECONDS``) and a
foot planted across the cut is held where the query put it until it lifts
(:func:`_planted_through`); those frames are reported as the generated ones.

The score's own prediction of the transition is the smoothed trajectory of the *features*
(body-local joint positions). The generated frames are built from rotations instead (so the
result is a valid BVH), so their forward-kinematics body-local positions differ from that
trajectory; :class:`Stitched` reports the discrepancy (``fk_error_mean``/``fk_error_max``, per
joint and frame, in the clip's units).

Baselines: :func:`crossfade` (slerp of rotations and lerp of translations with ease-in/out
weights over a fixed window where query and data overlap) and :func:`interpolate_gap` (g frames
between take-off and landing: ``"slerp"`` — quaternion slerp, the LaFAN1 interpolation baseline —
or ``"linear"`` — component-wise linear interpolation of the quaternions, renormalised; the root
position and translations are interpolated linearly in both).
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion, concatenate
from mocapkit.provenance import Provenance, Segment, TransitionTaken
from mocapkit.stitch.kalman import DEFAULT_MODEL, ConstantAccelerationModel, smoother_matrix
from mocapkit.stitch.lscore import DEFAULT_W, check_w, elastic_mask
from mocapkit.stitch.search import (
    Transition,
    conform,
    feature_joint_indices,
    find_transition,
    motion_features,
    parse_takeoffs,
)

__all__ = [
    "DEFAULT_BLEND_SECONDS",
    "METHODS",
    "Stitched",
    "align_data",
    "build_stitch",
    "crossfade",
    "interpolate_gap",
    "stitch",
    "stitch_motions",
]


DEFAULT_BLEND_SECONDS = 0.25
"""Cross-fade window of :func:`crossfade` (a quarter second, a common game-engine default)."""

METHODS = ("kalman", "crossfade", "slerp", "linear")
"""How :func:`stitch` makes the transition frames: the L-score's Kalman smoother
(:func:`stitch_motions`), a cross-fade (:func:`crossfade`) or slerp / linear interpolation over
k frames (:func:`interpolate_gap`)."""


@dataclass(frozen=True, eq=False)
class Stitched:
    """A stitched motion and where its parts are.

    ``motion``: the result, on the query's skeleton. Output frames ``0..takeoff`` are the query's
    (``takeoff`` = a), ``generated`` (a slice) the generated/blended frames, ``landing_index``
    the first output frame after them, where the data clip plays as it is: from its landing
    frame b, or from ``landing_played`` (a cross-fade blends b .. b + n - 1 into its window,
    and plays b + n there). ``transform``: the ground transform applied
    to the data clip (None without alignment). ``method``: "kalman", "crossfade", "slerp" or
    "linear". For "kalman": ``kalman_positions`` (k, J', 3) — the body-local feature trajectory
    the L-score predicts for the injected frames, ``fk_positions`` (k, J', 3) — the body-local
    forward-kinematics positions of the generated frames, and their distance per joint and
    frame (``fk_error_mean``, ``fk_error_max``, clip units; 0 when k = 0).

    Set by :func:`stitch`: ``transition`` (the search result), ``up`` (the up axis used),
    ``query_name``/``data_names`` (labels of the query and of the data clips, e.g. their
    paths), ``takeoff_spec`` (the take-off argument as given), ``search_seconds`` (wall time of
    the search) and ``output`` (where the motion is written; recorded only); by
    :func:`mocapkit.stitch.library.stitch_library`: ``skipped`` (library files left out, with
    why).
    """

    motion: Motion
    method: str
    takeoff: int
    landing: int
    k: int
    generated: slice
    landing_index: int
    transform: object | None = None
    transition: Transition | None = None
    kalman_positions: np.ndarray | None = None
    fk_positions: np.ndarray | None = None
    fk_error_mean: float = 0.0
    fk_error_max: float = 0.0
    up: str | None = None
    query_name: str = "query"
    data_names: tuple[str, ...] = ()
    takeoff_spec: Any = None
    search_seconds: float | None = None
    output: str | None = None
    skipped: tuple[tuple[str, str], ...] = ()
    data_fps: float | None = None
    landing_played: int | None = None
    data_frames: int | None = None

    def data_frame(self, frame: int) -> int:
        """A frame of the data clip as the search saw it (at the query's rate) as a frame of
        its file (:attr:`data_fps`: the file's rate where it differs and was resampled; its
        :attr:`data_frames` bound the result)."""
        if self.data_fps is None:
            return int(frame)
        f = math.floor(frame * self.data_fps / self.motion.fps + 0.5)
        return min(f, self.data_frames) if self.data_frames is not None else f

    def warn_if_landing_moved(self, asked: int | None) -> None:
        """Warn when the landing frame ``asked`` (of the data file) is no frame at the query's
        rate, so that the search landed on the nearest one instead."""
        if asked is None or self.data_frame(self.landing) == asked:
            return
        import warnings

        name = self.data_names[self.transition.clip] if self.transition else "the data clip"
        warnings.warn(
            f"landing frame {asked} of {name} ({self.data_fps:g} fps) is no frame of it at the "
            f"query's {self.motion.fps:g} fps, at which the search runs: landed on its frame "
            f"{self.data_frame(self.landing)}, the nearest",
            stacklevel=3,
        )

    def provenance(self, output: str, parameters: dict[str, Any] | None = None) -> Provenance:
        """The stitch as a provenance sidecar (:mod:`mocapkit.provenance`): the query's frames,
        the generated (or blended) frames, the data clip's frames from its landing frame, and
        the one transition taken."""
        clip = self.transition.clip if self.transition is not None else 0
        data = self.data_names[clip] if self.data_names else "data"
        g0, g1 = self.generated.start, self.generated.stop
        F = self.motion.num_frames
        played = self.landing if self.landing_played is None else self.landing_played
        tail = played + (g1 - self.landing_index)
        segs = [
            Segment(0, g0, "clip", self.query_name, 0, g0),
            Segment(g0, g1, "generated", None, None, None),
            Segment(g1, F, "clip", data, self.data_frame(tail), self.data_frame(tail + F - g1)),
        ]
        lscore = self.transition.lscore if self.transition is not None else None
        return Provenance(
            "stitch",
            str(output),
            float(self.motion.fps),
            F,
            [self.query_name, *self.data_names],
            {"method": self.method, "k": self.k, **(parameters or {})},
            [sg for sg in segs if sg.output_stop > sg.output_start],
            [
                TransitionTaken(
                    g0, self.query_name, self.takeoff, data, self.data_frame(self.landing), lscore
                )
            ],
        )

    def to_json(self) -> dict[str, Any]:
        """The JSON-ready summary of the stitch (``mocapkit stitch --json``): the search's
        fields (with :attr:`transition`; ``data`` names the chosen clip) and the stitch's."""
        out: dict[str, Any] = {"query": self.query_name}
        tr = self.transition
        if tr is not None:
            d = tr.as_dict()
            clip = d.pop("clip")
            name = self.data_names[clip] if clip < len(self.data_names) else f"data{clip}"
            out.update(takeoff=d.pop("takeoff"), data=name, data_index=clip, **d)
            out["landing"] = self.data_frame(tr.landing)
        else:
            out.update(takeoff=self.takeoff, landing=self.data_frame(self.landing), k=self.k)
        if self.data_fps is not None:  # frames of the data file, which was resampled
            out["data_fps"] = self.data_fps
        out.update(
            method=self.method,
            frames=self.motion.num_frames,
            generated_frames=[self.generated.start, self.generated.stop],
            landing_output_frame=self.landing_index,
            # none where the made frames run to the end: no data frame plays as it is
            data_frame_at_landing_output=self.data_frame(
                self.landing if self.landing_played is None else self.landing_played
            )
            if self.landing_index < self.motion.num_frames
            else None,
            fk_error_mean=float(self.fk_error_mean),
            fk_error_max=float(self.fk_error_max),
        )
        if self.transform is not None:
            out["ground_transform"] = {
                "angle_rad": float(self.transform.angle),
                "translation": [float(x) for x in self.transform.translation],
                "up": self.transform.up,
            }
        if self.takeoff_spec is not None:
            out["takeoff_spec"] = self.takeoff_spec
        if self.search_seconds is not None:
            out["search_seconds"] = round(self.search_seconds, 4)
        out["output"] = self.output
        if self.skipped:
            out["skipped"] = [{"path": p, "error": e} for p, e in self.skipped]
        return out


# --------------------------------------------------------------------------------- alignment


def _check_frames(query: Motion, takeoff: int, data: Motion, landing: int, before: int, after: int):
    a, b = int(takeoff), int(landing)
    if before > query.num_frames:  # no take-off frame can work: say why, not an empty range
        raise ValueError(
            f"the query has {query.num_frames} frame(s); this transition needs {before} of it "
            "up to the take-off (a shorter blend, or a longer query)"
        )
    if after > data.num_frames:
        raise ValueError(
            f"the data clip has {data.num_frames} frame(s); this transition needs {after} of it "
            "from the landing (a shorter blend, or a longer clip)"
        )
    if a != takeoff or not before - 1 <= a < query.num_frames:
        raise ValueError(
            f"take-off frame {takeoff} outside [{before - 1}, {query.num_frames - 1}] of the query"
        )
    if b != landing or not 0 <= b <= data.num_frames - after:
        raise ValueError(
            f"landing frame {landing} outside [0, {data.num_frames - after}] of the data clip "
            f"({data.num_frames} frames; {after} frames from the landing are needed)"
        )
    return a, b


def align_data(
    query: Motion, takeoff: int, data: Motion, landing: int, k: int = 0, up: str | None = None
):
    """``(aligned data, GroundTransform)``: ``data`` moved over the ground so that at ``landing``
    it faces like ``query`` at ``takeoff`` and its pelvis is ``k + 1`` mean steps ahead of the
    query's take-off position (see the module docstring). ``data`` must already be on the query's
    skeleton (:func:`conform`)."""
    from mocapkit import features

    up = up or features.detect_up_axis(query)
    a, b = int(takeoff), int(landing)
    T0 = features.ground_alignment(query, a, data, b, up=up)
    moved = features.apply_ground_transform(data, T0)
    a0 = max(a - 1, 0)
    b1 = min(b + 2, data.num_frames)
    pq = features.root_trajectory(query[a0 : a + 1], up)
    pd = features.root_trajectory(moved[b:b1], up)
    vq = pq[-1] - pq[0] if len(pq) > 1 else np.zeros(2)
    vd = pd[1] - pd[0] if len(pd) > 1 else vq
    if len(pq) < 2:
        vq = vd
    step = 0.5 * (vq + vd) * (int(k) + 1)
    shift = features.GroundTransform.from_2d(0.0, step, up)
    T = shift.compose(T0)
    return features.apply_ground_transform(data, T), T


# --------------------------------------------------------------------------------- Kalman


def _relative_logs(ref: np.ndarray, q: np.ndarray) -> np.ndarray:
    """log(ref⁻¹ q) in the w >= 0 hemisphere: (n, J, 4) → (n, J, 3)."""
    rel = rot.quat_mul(rot.quat_inv(ref)[None], q)
    rel = np.where(rel[..., :1] < 0.0, -rel, rel)
    return rot.quat_log(rel)


def _translation_series(motion: Motion) -> np.ndarray:
    """(F, J, 3) local translations (root position in column 0)."""
    return motion.local_translations()


def stitch_motions(
    query: Motion,
    takeoff: int,
    data: Motion,
    landing: int,
    k: int,
    *,
    window: int = DEFAULT_W,
    model: ConstantAccelerationModel = DEFAULT_MODEL,
    align: bool = True,
    up: str | None = None,
    joints: Sequence[str] | None = None,
) -> Stitched:
    """The Kalman stitch of ``query`` (frames 0..takeoff) and ``data`` (frames landing..) with
    ``k`` generated frames (see the module docstring). ``window`` = w: the query needs frames
    ``takeoff-w+1..takeoff`` and the data ``landing..landing+w-1``. ``joints``: feature joints
    for the FK discrepancy (default: the body joints). Returns :class:`Stitched`."""
    from mocapkit import features

    w = check_w(window)
    if int(k) != k or k < 0:
        raise ValueError(f"k must be an integer >= 0, got {k}")
    k = int(k)
    data = conform(data, query)
    a, b = _check_frames(query, takeoff, data, landing, w, w)
    up = up or features.detect_up_axis(query)
    query, data = _roots_on_path(query, data, up)
    transform = None
    if align:
        data, transform = align_data(query, a, data, b, k, up)
    q_win = np.concatenate([query.rotations[a - w + 1 : a + 1], data.rotations[b : b + w]])
    t_win = np.concatenate(
        [_translation_series(query[a - w + 1 : a + 1]), _translation_series(data[b : b + w])]
    )
    ref = query.rotations[a]
    J = query.num_joints
    logs = _relative_logs(ref, q_win).reshape(2 * w, 3 * J)
    centre = t_win[w - 1].copy()
    trans = (t_win - centre).reshape(2 * w, 3 * J)
    P = smoother_matrix(model, elastic_mask(w, k))[:, 0, :]  # (2w + k, 2w)
    Pk = P[w : w + k]  # the injected steps
    gen_logs = (Pk @ logs).reshape(k, J, 3)
    gen_trans = (Pk @ trans).reshape(k, J, 3) + centre
    gen_rots = rot.quat_normalize(rot.quat_mul(ref[None], rot.quat_exp(gen_logs)))
    gen_trans_out = None
    if query.translations is not None or data.translations is not None:
        gen_trans_out = gen_trans
    gen = Motion(query.skeleton, gen_rots, gen_trans[:, 0], query.frame_time, gen_trans_out)
    motion = _join(query[: a + 1], gen, data[b:])
    settled = 0
    if k == 0:  # a cut: the landing eased in from where the query was heading
        blend = max(query.seconds_to_frames(DEFAULT_BLEND_SECONDS), 1)
        motion, settled = _eased_cut(motion, a + 1, blend, query, a, data, b)
        motion, held_to = _planted_through(motion, a + 1, a + 1 + settled, up, data, b)
        settled = max(settled, held_to - (a + 1))  # every frame changed is reported as made

    idx = feature_joint_indices(query.skeleton, joints)
    names = [query.skeleton.names[j] for j in idx]
    kal = fk = None
    err_mean = err_max = 0.0
    if k:
        qf = motion_features(query[a - w + 1 : a + 1], up, names)
        df = motion_features(data[b : b + w], up, names)
        kal = (Pk @ np.concatenate([qf, df])).reshape(k, len(idx), 3)
        fk = features.local_positions(gen, up=up)[:, idx]
        d = np.linalg.norm(fk - kal, axis=-1)
        err_mean, err_max = float(d.mean()), float(d.max())
        _warn_if_stray(query, err_mean, err_max, k)
    return Stitched(
        motion,
        "kalman",
        a,
        b,
        k,
        slice(a + 1, a + 1 + k + settled),
        a + 1 + k + settled,
        transform,
        None,
        kal,
        fk,
        err_mean,
        err_max,
        up,
        landing_played=b + settled if settled else None,
    )


HOLD_SECONDS = 2.0
"""How long past the eased frames a foot planted across a cut is held where the query put it at
most (:func:`_planted_through`): a step's stance at any gait; a foot still down then (standing,
waving, bowing) is let go of over :data:`RELEASE_SECONDS`."""

RELEASE_SECONDS = 1.0
"""How long a foot still planted after :data:`HOLD_SECONDS` takes to be let go of: the cut's
offset slides back at its size per second (a few centimetres a second, not in a frame)."""


def _planted_through(
    motion: Motion, cut: int, end: int, up: str, data: Motion, b: int
) -> tuple[Motion, int]:
    """``motion``, and the frame after the last it changed, with each foot planted across the
    cut before frame ``cut`` (a contact run, :func:`mocapkit.features.foot_contacts`, holding
    ``cut - 1`` and ``cut``) held where the frames before ``cut`` plant it (ground plane only),
    moving as the data clip's own planted foot moves (``data``, aligned, playing from ``b`` at
    ``cut``: a foot's roll and settling are the capture's; only the cut's offset is taken out),
    until it lifts, or for :data:`HOLD_SECONDS` after the eased frames (``end``) and then let go
    of over :data:`RELEASE_SECONDS` (a foot that stays down for seconds, as in a wave or a bow,
    slides the cut's offset back slowly rather than at once; reviewer: held for a fixed window,
    it popped back 4.8 cm at the window's end); by IK on the legs of frames from ``cut`` on,
    the correction's speed limited and smoothed as the in-between's foot lock limits it (a
    straight knee the IK cannot bend to a held foot would snap otherwise: 11 cm in a frame on a
    CMU take, reviewer). Frames before ``cut`` are unchanged, and nothing is done where the foot
    does not move across the cut. Why: a cut's offset, eased out over the data's first frames,
    still slides a planted foot (4.9 cm on a Bandai walk stitched to its own mirror). Relies on
    a contact run meaning a foot that does not move."""
    from mocapkit import ik
    from mocapkit.body import body_of
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.core.runs import true_runs
    from mocapkit.features import foot_contacts, ground_frame
    from mocapkit.stitch.inbetween import _gentle_correction

    cfg = ik.FootLockConfig()
    blend = max(motion.seconds_to_frames(cfg.blend), 1)
    hold = max(motion.seconds_to_frames(HOLD_SECONDS), 1)
    release = max(motion.seconds_to_frames(RELEASE_SECONDS), 1)
    F = motion.num_frames
    lo, hi = max(0, cut - 4 * blend), min(F, end + hold + release + blend + 2)
    ex = motion[lo:hi]
    body = body_of(ex)
    chains, effs = ik.legs_and_feet(ex, body)
    if not effs or ex.num_frames < 3 or cut - lo < 1:
        return motion, cut
    flags = ik.effector_contacts(foot_contacts(ex, up=up), effs)
    held = np.zeros_like(flags)
    for c in range(len(effs)):
        for r0, r1 in true_runs(flags[:, c]):  # inclusive: a run across the cut
            if r0 <= cut - 1 - lo <= r1 and r1 >= cut - lo:
                held[r0 : r1 + 1, c] = True
    if not held.any():
        return motion, cut
    pos, _ = forward_kinematics(ex)
    feet = pos[:, list(effs)]
    # how each foot is meant to move into each frame: the query's own steps before the cut,
    # the data's own from its landing on (into b: the data's step from b - 1, none at b = 0)
    drift = np.zeros_like(feet)
    drift[1:] = np.diff(feet, axis=0)
    drift[cut - lo :] = 0.0
    src = forward_kinematics(data[max(b - 1, 0) : b + hi - cut])[0][:, list(effs)]
    steps = np.diff(src, axis=0)  # into b (when b > 0), b + 1, ...
    first = cut - lo + (0 if b > 0 else 1)
    n = min(len(steps), hi - lo - first)
    drift[first : first + n] = steps[:n]
    pins = np.repeat((np.arange(ex.num_frames) + lo < cut)[:, None], len(effs), 1)
    targets, weights = ik.lock_targets(
        feet, held, blend, "first", ground_frame(up)[1], "offset", pins, drift
    )
    i = np.arange(lo, hi)
    x = np.clip((i - (end + hold)) / release, 0.0, 1.0)
    weights = weights * (1.0 - x * x * (3 - 2 * x))[:, None]  # let go of a foot still down
    weights[: cut - lo] = 0.0  # the query's frames stay as they are
    miss = np.linalg.norm(targets - feet, axis=-1) * weights
    if miss.max(initial=0.0) < 1e-4 * body.size:  # the foot does not move across the cut
        return motion, cut
    res = ik.solve(ex, chains, targets, weights, cfg.ik, body)
    stop = lo + int(np.flatnonzero(weights.max(axis=1) > 0)[-1]) + 1  # first frame let go
    stop = min(stop, hi - 1)
    legs = sorted({j for c in chains for j in c.joints})
    span = slice(cut - 1 - lo, stop + 1 - lo)  # ends uncorrected: frame cut - 1, frame stop
    locked = _gentle_correction(
        ex.rotations[span][:, legs], res.motion.rotations[span][:, legs], motion.fps
    )
    out = motion.copy()
    rows = out.rotations[cut:stop]
    rows[:, legs] = locked[1 : 1 + stop - cut]
    out.rotations[cut:stop] = rows
    return out, stop


def _eased_cut(
    motion: Motion, cut: int, blend: int, query: Motion, a: int, data: Motion, b: int
) -> tuple[Motion, int]:
    """``motion`` (query frames ``..a``, then data frames ``b..`` from output frame ``cut`` =
    a + 1: a stitch with k = 0) with the cut eased, and how many frames from ``cut`` changed:
    inertialization. The query's pose and velocity at its last frame ``a`` are compared with
    the data clip's at the frame before its landing (``b - 1``, the same moment: ``b`` plays one
    frame after ``a``), and that offset, in each joint's local rotation and translation, is
    added to the data's frames and brought to nothing over ``blend`` frames (a cubic Hermite
    fade: the offset and its rate at the start, none of either at the end). Where the data runs
    on from the query as it was (a take stitched to its own next frame) the offset is none and
    nothing changes.

    Why: the elastic L-score reads body-local joint positions, so the best landing with no
    injected frame can still leave a joint a few centimetres from where it was heading; played
    as a cut, a Bandai walk stitched to its own mirror moved the swinging foot 11.4, then 2.2,
    then 12.0 cm a frame and jolted the planted one 4.9 cm (newcomer report). Relies on a
    joint's pose and velocity being continuous through a cut a viewer should not see."""
    F = motion.num_frames
    n = min(blend, F - cut)
    if n < 1 or a < 1 or data.num_frames < 2:
        return motion, 0
    qd, td = data.rotations, data.local_translations()
    qq, tq = query.rotations, query.local_translations()

    def before(x: np.ndarray, i: int, step) -> np.ndarray:  # frame i of x, or carried back
        return x[i] if i >= 0 else step(x[0], x[min(1, len(x) - 1)], -i)

    def rot_back(q0: np.ndarray, q1: np.ndarray, k: int) -> np.ndarray:
        back = rot.quat_mul(q0, rot.quat_inv(q1))  # one step back, k times
        out = q0
        for _ in range(k):
            out = rot.quat_mul(back, out)
        return rot.quat_normalize(out)

    def lin_back(t0: np.ndarray, t1: np.ndarray, k: int) -> np.ndarray:
        return t0 + k * (t0 - t1)

    def rotvec(d: np.ndarray) -> np.ndarray:
        return rot.quat_to_rotvec(np.where(d[..., :1] < 0, -d, d))

    d1 = before(qd, b - 1, rot_back)  # the data's frames at a and a - 1
    d2 = before(qd, b - 2, rot_back)
    x0 = rotvec(rot.quat_mul(qq[a], rot.quat_inv(d1)))  # (J, 3) radians, left offsets
    v0 = rotvec(rot.quat_mul(qq[a], rot.quat_inv(qq[a - 1]))) - rotvec(
        rot.quat_mul(d1, rot.quat_inv(d2))
    )
    e1, e2 = before(td, b - 1, lin_back), before(td, b - 2, lin_back)
    y0 = tq[a] - e1
    w0 = (tq[a] - tq[a - 1]) - (e1 - e2)
    if max(np.abs(x0).max(), np.abs(v0).max()) < 1e-12 and max(
        np.abs(y0).max(), np.abs(w0).max()
    ) <= 1e-12 * max(1.0, float(np.abs(tq[a]).max())):
        return motion, 0  # the data runs on from the query as it was: no cut to ease
    s = (np.arange(1, n + 1) / blend)[:, None, None]  # frames a+1.. : 1/blend .. 1
    h00 = 2 * s**3 - 3 * s**2 + 1  # Hermite: value 1 -> 0, slope 0 at both ends
    h10 = (s**3 - 2 * s**2 + s) * blend  # slope 1 -> 0 (per frame), value 0 at both ends
    out = motion.copy()
    turn = x0[None] * h00 + v0[None] * h10
    out.rotations[cut : cut + n] = rot.quat_normalize(
        rot.quat_mul(rot.rotvec_to_quat(turn), motion.rotations[cut : cut + n])
    )
    t = motion.local_translations()[cut : cut + n] + y0[None] * h00 + w0[None] * h10
    out.root_positions[cut : cut + n] = t[:, 0]
    if out.translations is not None:
        out.translations[cut : cut + n] = t
    return out, n


STRAY_FRACTION = 0.3
"""A Kalman transition whose generated frames put a joint this fraction of the body's size or
more from the path the L-score predicted for it is warned about (:func:`_warn_if_stray`)."""


def _warn_if_stray(query: Motion, err_mean: float, err_max: float, k: int) -> None:
    """Warn where the generated frames stray from the path the L-score predicted by
    :data:`STRAY_FRACTION` of the body's size or more: the joint rotations, smoothed one by one,
    then no longer make the motion the score judged (a CMU leg swung 56 cm sideways while both
    its ends were planted, newcomer; --inject 500 put the hips 22 m up). Measured: on 31
    default stitches between random bandai2 takes the largest such distance was 0.18 of the
    body's size (median 0.07), so a default stitch is not warned about."""
    from mocapkit.body import body_of
    from mocapkit.features import metres_per_unit

    size = body_of(query).size
    if size > 0 and err_max >= STRAY_FRACTION * size:
        cm = 100.0 * metres_per_unit(query, None)
        warnings.warn(
            f"the {k} generated frames stray up to {err_max * cm:.3g} cm ({err_mean * cm:.3g} "
            f"cm on average) from the path the L-score predicted: fewer injected frames "
            "(--inject, --max-inject) or --method slerp may make a better transition",
            stacklevel=3,
        )


def _roots_on_path(query: Motion, data: Motion, up: str) -> tuple[Motion, Motion]:
    """Both clips with a ground root on the body's path (:func:`features.ground_root_on_path`),
    so that the root motion of the result is continuous and the transition smooths the root
    path and heading, not a static root and a pelvis travelling under it."""
    from mocapkit import features

    return features.ground_root_on_path(query, up), features.ground_root_on_path(data, up)


def _join(*parts: Motion) -> Motion:
    parts = tuple(p for p in parts if p.num_frames)
    if any(p.translations is not None for p in parts):
        parts = tuple(
            Motion(p.skeleton, p.rotations, p.root_positions, p.frame_time, p.local_translations())
            for p in parts
        )
    return concatenate(parts)


def build_stitch(
    query: Motion,
    tr: Transition,
    chosen: Motion,
    *,
    method: str = "kalman",
    window: int = DEFAULT_W,
    model: ConstantAccelerationModel = DEFAULT_MODEL,
    align: bool = True,
    up: str | None = None,
    joints: Sequence[str] | None = None,
    blend_seconds: float = DEFAULT_BLEND_SECONDS,
) -> Stitched:
    """The stitch of ``query`` onto ``chosen`` (the data clip ``tr`` chose) at ``tr``'s
    take-off, landing and k, made by ``method`` (:data:`METHODS`)."""
    if method == "kalman":
        return stitch_motions(
            query, tr.takeoff, chosen, tr.landing, tr.k, window=window, model=model,
            align=align, up=up, joints=joints,
        )  # fmt: skip
    if method == "crossfade":
        return crossfade(query, chosen, tr.takeoff, tr.landing, blend_seconds, align=align, up=up)
    if method in METHODS:
        return interpolate_gap(
            query, chosen, tr.takeoff, tr.landing, tr.k, method, align=align, up=up
        )
    raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")


def stitch(
    query: Motion,
    takeoff,
    data: Motion | Sequence[Motion],
    landing: int | None = None,
    *,
    method: str = "kalman",
    window: int = DEFAULT_W,
    max_inject_seconds: float = 1.0,
    k_max: int | None = None,
    inject: int | None = None,
    score: str = "lscore",
    blend_seconds: float = DEFAULT_BLEND_SECONDS,
    model: ConstantAccelerationModel = DEFAULT_MODEL,
    align: bool = True,
    up: str | None = None,
    joints: Sequence[str] | None = None,
    query_name: str = "query",
    data_names: Sequence[str] | None = None,
    output: str | None = None,
) -> Stitched:
    """Search (:func:`mocapkit.stitch.search.find_transition`) then build the stitch with the
    chosen clip, take-off, landing and k; the search result is ``result.transition``.

    ``method`` (:data:`METHODS`): "kalman" (:func:`stitch_motions`, k generated frames),
    "crossfade" (:func:`crossfade` over ``blend_seconds``), "slerp" or "linear"
    (:func:`interpolate_gap` over k frames). k is searched up to ``max_inject_seconds``, or up
    to ``k_max`` frames when given; ``inject`` forces k (that many generated frames, for a user
    who knows how long the transition should be). ``query_name``, ``data_names`` (default
    "data0", ...) and ``output`` label the result's :meth:`Stitched.to_json`. Data motions at
    another rate are resampled to the query's for the search; ``landing`` and the frames the
    result reports are the data motions' own (as :func:`mocapkit.stitch.library.stitch_library`
    does with files), which with a ``landing`` must then share one rate.
    """
    from mocapkit.features import detect_up_axis

    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    clips = [data] if isinstance(data, Motion) else list(data)
    names = [f"data{i}" for i in range(len(clips))] if data_names is None else list(data_names)
    if len(names) != len(clips):
        raise ValueError(f"{len(names)} data names for {len(clips)} data clips")
    if k_max is not None:
        if int(k_max) != k_max or k_max < 0:
            raise ValueError(f"k_max (--max-inject) must be an integer >= 0, got {k_max}")
        max_inject_seconds = int(k_max) * query.frame_time
    if inject is not None and int(inject) == inject and inject >= 0:
        from mocapkit.stitch.search import check_inject

        check_inject(int(inject), query.seconds_to_frames(max_inject_seconds), method)
    for clip, name in zip(clips, names, strict=True):  # skeleton checks naming the clip's file
        conform(replace(clip[:1], frame_time=query.frame_time), query[:1], name)
    up = up or detect_up_axis(query)
    asked = landing
    if landing is not None and any(not _same_rate(c, query) for c in clips):
        from mocapkit.stitch.library import file_to_query_frame

        if len({round(c.fps, 6) for c in clips}) > 1:
            raise ValueError(
                f"landing {landing}: the data motions are at several frame rates "
                f"({', '.join(sorted({f'{c.fps:g}' for c in clips}))} fps), so a frame number "
                "names no one time; give them at one rate"
            )
        landing = file_to_query_frame(int(landing), clips[0].fps, query.fps)
    t0 = time.perf_counter()
    tr = find_transition(
        query,
        takeoff,
        clips,
        landing,
        window=window,
        max_inject_seconds=max_inject_seconds,
        score=score,
        model=model,
        up=up,
        joints=joints,
        inject=inject,
    )
    search_seconds = time.perf_counter() - t0
    res = build_stitch(
        query, tr, clips[tr.clip], method=method, window=window, model=model, align=align,
        up=up, joints=joints, blend_seconds=blend_seconds,
    )  # fmt: skip
    if isinstance(takeoff, str):
        spec: Any = takeoff
    elif isinstance(takeoff, (int, np.integer)):
        spec = int(takeoff)
    else:
        spec = parse_takeoffs(takeoff)
    chosen = clips[tr.clip]
    out = replace(
        res,
        transition=tr,
        up=up,
        query_name=str(query_name),
        data_names=tuple(str(n) for n in names),
        takeoff_spec=spec,
        search_seconds=search_seconds,
        output=None if output is None else str(output),
        data_fps=None if _same_rate(chosen, query) else float(chosen.fps),
        data_frames=chosen.num_frames,
    )
    out.warn_if_landing_moved(asked)
    return out


def _same_rate(a: Motion, b: Motion) -> bool:
    return math.isclose(a.fps, b.fps, rel_tol=1e-6)


# --------------------------------------------------------------------------------- baselines


def _ease(t: np.ndarray) -> np.ndarray:
    return t * t * (3.0 - 2.0 * t)


def crossfade(
    query: Motion,
    data: Motion,
    takeoff: int,
    landing: int,
    window_seconds: float = DEFAULT_BLEND_SECONDS,
    *,
    align: bool = True,
    up: str | None = None,
) -> Stitched:
    """Plain cross-fade over ``n = round(window_seconds / frame_time)`` frames (at least 1).

    Query frames ``a-n+1..a`` are played at the same time as data frames ``b..b+n-1`` and blended
    with ease-in/out weights ``s = smoothstep((i+1)/(n+1))``: rotations by slerp, translations by
    lerp. Output: query ``0..a-n``, the n blended frames, data ``b+n..``; it is n frames shorter
    than a stitch with k = 0. With ``align``, the data is aligned (facing and pelvis position) at
    the middle of the blend window, ``b + (n-1)//2`` onto ``a - n + 1 + (n-1)//2``.
    """
    from mocapkit import features

    data = conform(data, query)
    n = max(1, query.seconds_to_frames(window_seconds))
    a, b = _check_frames(query, takeoff, data, landing, n, n)
    up = up or features.detect_up_axis(query)
    query, data = _roots_on_path(query, data, up)
    transform = None
    c = (n - 1) // 2
    if align:
        transform = features.ground_alignment(query, a - n + 1 + c, data, b + c, up=up)
        data = features.apply_ground_transform(data, transform)
    s = _ease((np.arange(n) + 1.0) / (n + 1.0))
    qa, qb = query[a - n + 1 : a + 1], data[b : b + n]
    rots = rot.quat_slerp(qa.rotations, qb.rotations, s[:, None])
    s3 = s[:, None, None]
    tra = qa.local_translations() * (1 - s3) + qb.local_translations() * s3
    has_t = query.translations is not None or data.translations is not None
    blend = Motion(query.skeleton, rots, tra[:, 0], query.frame_time, tra if has_t else None)
    motion = _join(query[: a - n + 1], blend, data[b + n :])
    # after the window the data plays as is from b + n (b .. b + n - 1 are in the blend)
    return Stitched(
        motion, "crossfade", a, b, n, slice(a - n + 1, a + 1), a + 1, transform, up=up,
        landing_played=b + n,
    )  # fmt: skip


def interpolate_gap(
    query: Motion,
    data: Motion,
    takeoff: int,
    landing: int,
    gap: int,
    method: str = "slerp",
    *,
    align: bool = True,
    up: str | None = None,
) -> Stitched:
    """Fill ``gap`` frames between query frame ``takeoff`` and data frame ``landing`` by
    interpolating between those two poses at ``t = i/(gap+1)``, i = 1..gap: rotations by
    ``"slerp"`` or ``"linear"`` (component-wise lerp of the quaternions, renormalised), root
    position and translations linearly. With ``align`` the data is aligned as for the Kalman
    stitch with k = gap (:func:`align_data`)."""
    from mocapkit import features

    if method not in ("slerp", "linear"):
        raise ValueError(f"method must be 'slerp' or 'linear', got {method!r}")
    if int(gap) != gap or gap < 0:
        raise ValueError(f"gap must be an integer >= 0, got {gap}")
    g = int(gap)
    data = conform(data, query)
    a, b = _check_frames(query, takeoff, data, landing, 1, 1)
    up = up or features.detect_up_axis(query)
    query, data = _roots_on_path(query, data, up)
    transform = None
    if align:
        data, transform = align_data(query, a, data, b, g, up)
    t = (np.arange(g) + 1.0) / (g + 1.0)
    q0, q1 = query.rotations[a], rot.quat_fix_hemisphere(data.rotations[b], query.rotations[a])
    if method == "slerp":
        rots = rot.quat_slerp(q0[None], q1[None], np.broadcast_to(t[:, None], (g, q0.shape[0])))
    else:
        rots = rot.quat_normalize(q0[None] * (1 - t[:, None, None]) + q1[None] * t[:, None, None])
    t0, t1 = query[a].local_translations()[0], data[b].local_translations()[0]
    tra = t0[None] * (1 - t[:, None, None]) + t1[None] * t[:, None, None]
    has_t = query.translations is not None or data.translations is not None
    gen = Motion(
        query.skeleton,
        rots.reshape(g, q0.shape[0], 4),
        tra[:, 0],
        query.frame_time,
        tra if has_t else None,
    )
    motion = _join(query[: a + 1], gen, data[b:])
    return Stitched(motion, method, a, b, g, slice(a + 1, a + 1 + g), a + 1 + g, transform, up=up)
