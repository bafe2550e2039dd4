"""Transition search: the best (take-off, landing, k) of a query over a library of data clips.

Two levels:

* :func:`search_features` works on feature arrays (frames, m): a query, one take-off frame or a
  take-off range, and one or many data clips. Every landing frame of every clip is scored with
  the elastic L-score (k = 0..k_max) in one batched call over the concatenated library
  (:func:`mocapkit.stitch.search_landings`, float32), or only the given landing frame. The
  windowed Euclidean distance of the same window (the paper's straw man) is computed for every
  candidate as well, and ``score="euclidean"`` ranks candidates by it instead (k is then the
  elastic k_opt of the chosen window). The chosen window is re-scored in float64, so the
  reported ``lscore_by_k`` are exact.
* :func:`find_transition` works on :class:`~mocapkit.core.motion.Motion` objects. Durations are
  in **seconds** (``max_inject_seconds=1.0``) and converted to frames with the query's frame
  time. The features are :func:`motion_features`.

Features for the score (:func:`motion_features`): :func:`mocapkit.features.local_positions`
(body-local joint positions: pelvis ground position removed, facing the ground frame's forward
axis, in the clip's units) of the **body joints**, flattened to (F, 3J). Body joints are all
joints except the strict ancestors of the pelvis (:attr:`mocapkit.body.Body.pelvis`): such
joints are reference nodes, not body parts. Bandai-Namco's ``joint_Root`` (a node fixed at the
world origin above ``Hips``) is the typical case; its body-local position only mirrors the
pelvis' travel, so keeping it would score the character's location, not its pose. Bandai clips
thus have 21 feature joints (m = 63). Pass ``joints=`` (names) to choose others.

Windows follow :mod:`mocapkit.stitch.lscore`: the query's take-off window is frames
``a-w+1 .. a`` and the data clip's landing window is ``b .. b+w-1`` (all 0-based), so a take-off
frame must satisfy ``a >= w-1`` and a landing frame ``b <= F-w``.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from mocapkit.body import body_of
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton
from mocapkit.stitch.kalman import DEFAULT_MODEL, ConstantAccelerationModel
from mocapkit.stitch.lscore import (
    DEFAULT_W,
    check_w,
    elastic_lscores,
    search_landings,
    sliding_windows,
    windowed_euclidean,
)

__all__ = [
    "SCORES",
    "Transition",
    "body_joints",
    "conform",
    "euclidean_landings",
    "find_transition",
    "motion_features",
    "parse_takeoffs",
    "search_features",
]

SCORES = ("lscore", "euclidean")


# --------------------------------------------------------------------------------- features


def body_joints(skeleton: Skeleton) -> list[int]:
    """Indices of the joints used as features: all but the strict ancestors of the pelvis."""
    above = set(skeleton.ancestors(body_of(skeleton).pelvis))
    return [i for i in range(skeleton.num_joints) if i not in above]


def feature_joint_indices(skeleton: Skeleton, joints: Sequence[str] | None) -> list[int]:
    if joints is None:
        return body_joints(skeleton)
    try:
        return [skeleton.index(n) for n in joints]
    except (KeyError, ValueError) as e:
        raise ValueError(f"unknown feature joint: {e}") from None


def motion_features(
    motion: Motion, up: str | None = None, joints: Sequence[str] | None = None
) -> np.ndarray:
    """Score features of a motion: body-local positions of the feature joints, (F, 3J) float64.

    ``joints``: joint names (default :func:`body_joints`); ``up``: the up axis (detected when
    None; pass it to keep all clips of a search consistent).
    """
    from mocapkit.features import local_positions

    idx = feature_joint_indices(motion.skeleton, joints)
    lp = local_positions(motion, up=up)
    return np.ascontiguousarray(lp[:, idx, :].reshape(motion.num_frames, 3 * len(idx)))


def check_same_skeleton(
    data: Motion, reference: Motion, name: str = "data clip", reference_name: str = "the query"
) -> None:
    """ValueError naming ``name`` and the differences unless ``data`` has ``reference``'s joint
    names and the same parent of every joint (in any joint order)."""
    from mocapkit.core.skeleton import skeleton_difference

    why = skeleton_difference(data.skeleton, reference.skeleton, reference_name)
    if why:
        raise ValueError(f"{name}: {why}")


def conform(data: Motion, reference: Motion, name: str = "data clip") -> Motion:
    """``data`` expressed on ``reference``'s skeleton: joints reordered by name, resampled to the
    reference's frame time if it differs. The clips must have the same joint names and the same
    parent of every joint (ValueError naming the differences otherwise). Rotations, the root
    position and the animated translations of the joints that have position channels in the
    reference skeleton come from ``data``; bone offsets come from the reference.
    """
    check_same_skeleton(data, reference, name)
    rs, ds = reference.skeleton, data.skeleton
    order = [ds.index(n) for n in rs.names]
    if not np.isclose(data.frame_time, reference.frame_time, rtol=1e-6, atol=0):
        from mocapkit.features import resample

        data = resample(data, reference.fps)
    rots = data.rotations[:, order]
    has_pos = rs.has_position.copy()
    has_pos[0] = False
    trans = None
    if reference.translations is not None or has_pos.any():
        trans = np.broadcast_to(rs.offsets, (data.num_frames, rs.num_joints, 3)).copy()
        dt = data.local_translations()[:, order]
        trans[:, has_pos] = dt[:, has_pos]
        trans[:, 0] = data.root_positions
    return Motion(rs, rots, data.root_positions, reference.frame_time, trans)


# --------------------------------------------------------------------------------- search


@dataclass(frozen=True, eq=False)
class Transition:
    """The chosen stitch of a search.

    ``clip``: index of the data clip; ``takeoff`` a and ``landing`` b: 0-based frames of the query
    and of that clip; ``k``: injected frames (the elastic k_opt of the window); ``lscore``: L* =
    L_k (float64); ``lscore_by_k``: L_0..L_kmax of the window (index = k); ``euclidean``: the
    windowed Euclidean distance of the same window; ``window``: w; ``score``: what ranked the
    candidates ("lscore" or "euclidean"); ``candidates``: number of (take-off, landing) pairs
    scored.
    """

    clip: int
    takeoff: int
    landing: int
    k: int
    lscore: float
    lscore_by_k: np.ndarray
    euclidean: float
    window: int
    score: str = "lscore"
    candidates: int = 1

    @property
    def k_max(self) -> int:
        return int(self.lscore_by_k.shape[0] - 1)

    def as_dict(self) -> dict:
        """JSON-ready fields (``max_inject`` = k_max; ``lscore_by_k`` as a list)."""
        return {
            "clip": self.clip,
            "takeoff": self.takeoff,
            "landing": self.landing,
            "k": self.k,
            "lscore": float(self.lscore),
            "lscore_by_k": [float(x) for x in self.lscore_by_k],
            "euclidean": float(self.euclidean),
            "window": self.window,
            "max_inject": self.k_max,
            "score": self.score,
            "candidates": self.candidates,
        }


def parse_takeoffs(spec: str | int | Iterable[int]) -> list[int]:
    """Take-off frames from an int, an iterable, or a string ``"A"`` or ``"A:B"`` (frames A..B-1,
    half-open like a Python slice)."""
    if isinstance(spec, str):
        s = spec.strip()
        try:
            if ":" in s:
                lo, hi = (int(p) for p in s.split(":", 1))
                if hi <= lo:
                    raise ValueError
                return list(range(lo, hi))
            return [int(s)]
        except ValueError:
            raise ValueError(
                f"take-off must be a frame or a range A:B with A < B (frames A..B-1), got {spec!r}"
            ) from None
    out = [int(a) for a in np.atleast_1d(np.asarray(spec)).ravel()]
    if not out:
        raise ValueError("no take-off frame given")
    return out


def euclidean_landings(query_feats, takeoff: int, data_feats, w: int = DEFAULT_W) -> np.ndarray:
    """Windowed Euclidean distance (:func:`mocapkit.stitch.windowed_euclidean`) of one take-off
    against every landing frame b = 0..F-w of a data clip, (F-w+1,) float64, without building
    the windows: ``|q|² + Σ_j |x_{b+j}|² - 2 Σ_j q_j·x_{b+j}`` with sliding sums."""
    w = check_w(w)
    Q = np.asarray(query_feats, dtype=float)
    X = np.asarray(data_feats, dtype=float)
    a = int(takeoff)
    if not w - 1 <= a < Q.shape[0]:
        raise ValueError(f"take-off frame {takeoff} outside [{w - 1}, {Q.shape[0] - 1}] (w = {w})")
    n_land = X.shape[0] - w + 1
    if n_land < 1:
        raise ValueError(f"data clip has {X.shape[0]} frames, fewer than w = {w}")
    centre = Q[a]
    q = Q[a - w + 1 : a + 1] - centre  # (w, m)
    Xc = X - centre
    S = Xc @ q.T  # (F, w): x_t · q_j
    sq = np.einsum("ij,ij->i", Xc, Xc)
    csum = np.r_[0.0, np.cumsum(sq)]
    total = csum[w:] - csum[:-w] + float((q * q).sum())
    for j in range(w):
        total -= 2.0 * S[j : j + n_land, j]
    return np.sqrt(np.maximum(total, 0.0))


def _check_score(score: str) -> str:
    if score not in SCORES:
        raise ValueError(f"score must be one of {SCORES}, got {score!r}")
    return score


def _rank_k(scores: np.ndarray, inject: int | None) -> np.ndarray:
    """Per candidate, L* (the best k) or, with a forced k, the L-score at that k."""
    return scores.min(axis=1) if inject is None else scores[:, inject]


Best = tuple[float, int, int]
"""A take-off's best candidate: (value, clip index, landing frame)."""


def best_per_takeoff(Q, takeoffs, clips, landing, w, k_max, model, score, dtype, inject=None):
    """(per take-off: its best ``(value, clip, landing)`` or None, candidates scored) over
    ``clips``: every landing frame of every clip (``landing`` None; one batched search over the
    concatenated clips per take-off, windows that would cross a clip boundary discarded), or
    the frame ``landing`` of each clip that has a full window there. Ties go to the first clip,
    then the first landing, so that the best of several groups of clips, taken group by group
    in order (:func:`merge_per_takeoff`), is the best of all of them."""
    if landing is not None:
        b = int(landing)
        ok = [i for i, c in enumerate(clips) if 0 <= b <= c.shape[0] - w]
        out: list[Best | None] = []
        for a in takeoffs:
            if not ok:
                out.append(None)
                continue
            wins = np.stack([sliding_windows(Q, a, clips[i], w, landings=[b])[0] for i in ok])
            vals = (
                _rank_k(elastic_lscores(wins, model, w, k_max), inject)
                if score == "lscore"
                else windowed_euclidean(wins, w)
            )
            j = int(np.argmin(vals))
            out.append((float(vals[j]), ok[j], b))
        return out, len(ok) * len(takeoffs)
    usable = [i for i, c in enumerate(clips) if c.shape[0] >= w]
    if not usable:
        return [None] * len(takeoffs), 0
    X = np.concatenate([clips[i] for i in usable]) if len(usable) > 1 else clips[usable[0]]
    lengths = np.array([clips[i].shape[0] for i in usable])
    starts = np.r_[0, np.cumsum(lengths)[:-1]]
    n_land = X.shape[0] - w + 1
    owner = np.repeat(np.arange(len(usable)), lengths)[:n_land]
    local = np.arange(n_land) - starts[owner]
    valid = local <= lengths[owner] - w
    out = []
    for a in takeoffs:
        if score == "lscore":
            res = search_landings(Q, a, X, w, k_max, model, dtype=dtype)
            vals = _rank_k(res.lscore_by_k, inject).astype(float)
        else:
            vals = euclidean_landings(Q, a, X, w)
        vals[~valid] = np.inf
        g = int(np.argmin(vals))
        out.append((float(vals[g]), usable[int(owner[g])], int(local[g])))
    return out, int(valid.sum()) * len(takeoffs)


def merge_per_takeoff(parts):
    """The best ``(value, clip, take-off index)`` of groups of clips: ``parts`` are the groups'
    :func:`best_per_takeoff` lists in group order, with clip indices over all groups. Per
    take-off the first group wins ties; over take-offs the first take-off does. None when no
    group has a candidate."""
    best = None
    per: list[Best | None] = []
    for part in parts:
        for t, cand in enumerate(part):
            if t == len(per):
                per.append(None)
            if (
                cand is not None
                and np.isfinite(cand[0])
                and (per[t] is None or cand[0] < per[t][0])
            ):
                per[t] = cand
    for t, cand in enumerate(per):
        if cand is not None and (best is None or cand[0] < best[0][0]):
            best = (cand, t)
    return best


def transition_at(Q, a, clip, ci, b, w, model, k_show, inject, score, candidates) -> Transition:
    """The :class:`Transition` of take-off ``a`` onto frame ``b`` of ``clip`` (features; index
    ``ci``), re-scored in float64: its L_0..L_k_show, k_opt (or ``inject``), and Euclidean."""
    window = sliding_windows(Q, a, clip, w, landings=[b]).astype(float)
    scores = elastic_lscores(window, model, w, k_show)[0]
    k = int(np.argmin(scores)) if inject is None else inject
    eu = float(windowed_euclidean(window, w)[0])
    return Transition(ci, a, b, k, float(scores[k]), scores, eu, w, score, candidates)


def check_search(k_max, inject, w, score, method: str | None = None):
    """Validated ``(k_max, k_show, inject, w, score)`` of a search: with ``inject`` candidates
    are ranked at that k and L_k is shown up to ``max(k_max, inject)``. For a Kalman transition
    (``method`` "kalman") ``inject`` may not exceed ``k_max`` (:func:`check_inject`)."""
    if int(k_max) != k_max or k_max < 0:
        raise ValueError(f"k_max must be an integer >= 0, got {k_max}")
    k_show = int(k_max)
    if inject is not None:
        if int(inject) != inject or inject < 0:
            raise ValueError(f"inject must be an integer >= 0, got {inject}")
        inject = int(inject)
        check_inject(inject, k_show, method)
        k_max, k_show = inject, max(k_show, inject)
    return int(k_max), k_show, inject, check_w(w), _check_score(score)


def check_inject(inject: int, k_max: int, method: str | None = "kalman") -> None:
    """Refuse a Kalman transition forced (``inject``) longer than the longest one searched
    (``k_max``, --max-inject): the constant-acceleration model carries the end frames'
    accelerations across the unobserved frames, so its error grows with the square of their
    number (--inject 60 on a Bandai walk put a joint 2.2 m off, --inject 500 the hips 5 m up;
    newcomer report). Interpolations (slerp, linear) do not stray, and are not limited; a
    cross-fade makes no frames, and refuses ``inject`` (it was taken, ranked by, then not
    used: newcomer). ``method`` None: no method to judge by (a search alone)."""
    if method == "crossfade" and inject > 0:
        raise ValueError(
            "inject (--inject) sets the frames made between the clips; a cross-fade makes none "
            "(it overlaps them over --blend-seconds)"
        )
    if method == "kalman" and inject > k_max:
        raise ValueError(
            f"inject (--inject) {inject} is more frames than the longest Kalman transition "
            f"searched (--max-inject, {k_max} frames): past it the transition strays ever "
            "further from the two clips; raise --max-inject to force it, or use --method slerp"
        )


def check_takeoffs(takeoffs, n_query: int, w: int) -> list[int]:
    """The take-off frames of ``takeoffs`` (:func:`parse_takeoffs`), each with its full
    take-off window in a query of ``n_query`` frames."""
    takeoffs = parse_takeoffs(takeoffs)
    ok = [a for a in takeoffs if w - 1 <= a < n_query]
    if len(takeoffs) > 1 and ok and len(ok) < len(takeoffs):
        # a range reaching past the frames with a full window: search the part that has one
        import warnings

        warnings.warn(
            f"take-off frames {takeoffs[0]}..{takeoffs[-1]}: searched {ok[0]}..{ok[-1]}, the "
            f"ones with a full take-off window (w = {w}) in the query's {n_query} frames",
            stacklevel=2,
        )
        return ok
    if n_query < w:  # no take-off frame can have its window: say so, not an empty range
        raise ValueError(
            f"the query has {n_query} frame(s); a take-off needs the {w} frames up to it "
            f"(the L-score window w = {w})"
        )
    for a in takeoffs:
        if not w - 1 <= a < n_query:
            raise ValueError(
                f"take-off frame {a} outside [{w - 1}, {n_query - 1}] (the take-off window "
                f"{a - w + 1}..{a} must lie in the query; w = {w})"
            )
    return takeoffs


def no_candidate(landing: int | None, w: int) -> ValueError:
    if landing is not None:
        return ValueError(
            f"landing frame {landing} has no full landing window {landing}..{landing + w - 1} "
            f"in any data clip (w = {w})"
        )
    return ValueError(f"no data clip has at least w = {w} frames")


def search_features(
    query_feats,
    takeoffs,
    clips,
    landing: int | None = None,
    w: int = DEFAULT_W,
    k_max: int = 30,
    model: ConstantAccelerationModel = DEFAULT_MODEL,
    *,
    score: str = "lscore",
    dtype=np.float32,
    inject: int | None = None,
) -> Transition:
    """The best stitch of ``query_feats`` (Fq, m) at one of ``takeoffs`` (a frame, an iterable or
    ``"A:B"``) onto one of ``clips`` (an (F, m) array or a list of them).

    Without ``landing``: every landing frame of every clip (clips shorter than w are skipped);
    the clips are concatenated and searched with one :func:`search_landings` call per take-off,
    landings whose window would cross a clip boundary being discarded. With ``landing``: only
    that frame of each clip (clips too short for it are skipped). Ranked by L* (``score=
    "lscore"``) or by windowed Euclidean distance (``"euclidean"``); ties go to the first
    (clip, take-off, landing). ``inject`` forces k (the number of injected frames): candidates
    are ranked by their L-score at that k; the chosen window's ``lscore_by_k`` still runs to
    ``max(k_max, inject)``, so that the optimum the user overrode is seen beside it. Returns a
    :class:`Transition`.
    """
    k_max, k_show, inject, w, score = check_search(k_max, inject, w, score)
    Q = np.asarray(query_feats, dtype=float)
    if Q.ndim != 2:
        raise ValueError(f"query features must be (frames, m), got shape {Q.shape}")
    if isinstance(clips, np.ndarray) and clips.ndim == 2:
        clips = [clips]
    clips = [np.asarray(c) for c in clips]
    if not clips:
        raise ValueError("no data clip given")
    for i, c in enumerate(clips):
        if c.ndim != 2 or c.shape[1] != Q.shape[1]:
            raise ValueError(
                f"data clip {i} features have shape {c.shape}, expected (frames, {Q.shape[1]})"
            )
    takeoffs = check_takeoffs(takeoffs, Q.shape[0], w)
    per, candidates = best_per_takeoff(
        Q, takeoffs, clips, landing, w, k_max, model, score, dtype, inject
    )
    best = merge_per_takeoff([per])
    if best is None:
        raise no_candidate(landing, w)
    (_, ci, b), t = best
    return transition_at(Q, takeoffs[t], clips[ci], ci, b, w, model, k_show, inject, score,
                         candidates)  # fmt: skip


def find_transition(
    query: Motion,
    takeoff,
    data: Motion | Sequence[Motion],
    landing: int | None = None,
    *,
    window: int = DEFAULT_W,
    max_inject_seconds: float = 1.0,
    score: str = "lscore",
    model: ConstantAccelerationModel = DEFAULT_MODEL,
    up: str | None = None,
    joints: Sequence[str] | None = None,
    inject: int | None = None,
) -> Transition:
    """The best stitch of ``query`` at ``takeoff`` (frame, iterable or ``"A:B"``) onto one of the
    ``data`` motions, at ``landing`` or searched over every landing frame.

    k is searched from 0 to ``round(max_inject_seconds / query.frame_time)`` frames (1 s = 30
    frames at 30 fps), or fixed at ``inject`` frames. Data clips must have the query's joint
    names (:func:`conform`; clips at another frame rate are resampled). ``up`` is detected on
    the query when None. Features: :func:`motion_features`. Returns a :class:`Transition`
    (frames are 0-based indices of the given motions; ``clip`` indexes ``data``).
    """
    from mocapkit.features import detect_up_axis

    if isinstance(data, Motion):
        data = [data]
    if not data:
        raise ValueError("no data clip given")
    if not max_inject_seconds >= 0:
        raise ValueError(f"max_inject_seconds must be >= 0, got {max_inject_seconds}")
    k_max = query.seconds_to_frames(max_inject_seconds)
    up = up or detect_up_axis(query)
    names = [query.skeleton.names[j] for j in feature_joint_indices(query.skeleton, joints)]
    qf = motion_features(query, up, names)
    clips = [
        motion_features(conform(d, query, f"data clip {i}"), up, names) for i, d in enumerate(data)
    ]
    return search_features(
        qf, takeoff, clips, landing, window, k_max, model, score=score, inject=inject
    )
